#version 450
// dE/dPhi for each view's light: L is linear in Phi, so dE/dPhi = sum_pixels dE/dL * L / Phi.
// One workgroup per view, fixed summation order.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Views { ViewGPU views[]; };
layout(std430, binding = 1) readonly buffer Image { float img[]; };
layout(std430, binding = 2) readonly buffer DL { float dl[]; };
layout(std430, binding = 3) writeonly buffer GradLight { float grad_light[]; };
layout(std430, binding = 4) readonly buffer Lights { float intensity[]; };  // Phi per view
shared float part[256];

void main() {
    ViewGPU V = views[gl_WorkGroupID.x];
    uint n = V.dims.x * V.dims.y, base = V.base.y, lid = gl_LocalInvocationIndex;
    float acc = 0.0;
    for (uint i = lid; i < n; i += 256u) acc += dl[base + i] * img[base + i];
    part[lid] = acc;
    barrier();
    if (lid == 0u) {
        float s = 0.0;
        for (uint i = 0u; i < 256u; ++i) s += part[i];
        grad_light[gl_WorkGroupID.x] = s / intensity[gl_WorkGroupID.x];
    }
}
