// Test shader for engine/tests/vulkan_core.rs: out[i] = a[i] + b[i] * scale.
#version 450
#extension GL_GOOGLE_include_directive : require

#include "test/inc_test.glsl"

#ifndef WG
#define WG 64
#endif

layout(local_size_x = WG) in;

layout(set = 0, binding = 0) readonly buffer A { float a[]; };
layout(set = 0, binding = 1) readonly buffer B { float b[]; };
layout(set = 0, binding = 2) writeonly buffer Out { float o[]; };

layout(push_constant) uniform Push {
    uint n;
    float scale;
} pc;

void main() {
    uint i = flat_group_id() * WG + gl_LocalInvocationID.x;
    if (i >= pc.n) {
        return;
    }
    // precise: forbid contraction into an fma so the result matches the CPU bit for bit.
    precise float r = a[i] + b[i] * pc.scale;
    o[i] = r;
}
