#version 450
// Per scratch: adds its per-tile partial gradients (grad.comp) in enumeration order (bin.comp's
// `inv` map), so the result does not depend on thread timing.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Partials { vec4 partial[]; };
// scanned per (scratch, binning part), n * n_parts + 1: scratch k's entries are
// [sbase[k * n_parts], sbase[(k + 1) * n_parts])
layout(std430, binding = 1) readonly buffer ScratchBase { uint sbase[]; };
layout(std430, binding = 2) readonly buffer Inverse { uint inv[]; };
layout(std430, binding = 3) writeonly buffer Grad { vec4 grad[]; };        // 2 per scratch
#extension GL_GOOGLE_include_directive : require
#include "inc/reduce_push.glsl"

void main() {
    uint k = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    if (k >= pc.n_scratches) return;
    vec4 a0 = vec4(0.0), a1 = vec4(0.0);
    uint hi = min(sbase[(k + 1u) * pc.n_parts], pc.capacity);
    uint i = sbase[k * pc.n_parts];
    if (i < hi) do {  // tested at the bottom (a top test runs the body once more, masked, on CPU drivers)
        uint pos = inv[i];
        a0 += partial[2u * pos];
        a1 += partial[2u * pos + 1u];
    } while (++i < hi);
    grad[2u * k] = a0;
    grad[2u * k + 1u] = a1;
}
