#version 450
// The check loss of engine/docs/model.md section 8 on the GPU (engine/optim/src/check.rs):
//   E_lin = sum over views j of mean over view j's on-plate pixels of (L - T)^2.
// `weight` is 1 / (on-plate pixels of the view) on the plate and 0 off it (from the float64
// camera geometry, on the host), so E_lin = sum_pixels weight (L - T)^2 and dE/dL = 2 weight (L - T).
// Passes: VALUE (one workgroup per view, fixed-order sums -> out[v]), TOTAL (out[n_views] = sum
// over views in view order), GRAD (dE/dL per pixel). No float atomics: bit-reproducible.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
#include "inc/check_push.glsl"
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Views { ViewGPU views[]; };
layout(std430, binding = 1) readonly buffer Image { float img[]; };
layout(std430, binding = 2) readonly buffer Target { float tgt[]; };
layout(std430, binding = 3) readonly buffer Weight { float weight[]; };
layout(std430, binding = 4) buffer DL { float dl[]; };
layout(std430, binding = 5) buffer Out { float outv[]; };  // per view, then the total
shared float part[256];

void main() {
    uint lid = gl_LocalInvocationIndex;
#if defined(VALUE)
    ViewGPU V = views[gl_WorkGroupID.x];
    uint n = V.dims.x * V.dims.y, base = V.base.y;
    float acc = 0.0;
    for (uint i = lid; i < n; i += 256u) {
        float r = img[base + i] - tgt[base + i];
        acc += weight[base + i] * r * r;
    }
    part[lid] = acc;
    barrier();
    if (lid == 0u) {
        float s = 0.0;
        for (uint i = 0u; i < 256u; ++i) s += part[i];
        outv[gl_WorkGroupID.x] = s;
    }
#elif defined(TOTAL)
    if (gl_GlobalInvocationID.x == 0u) {
        float s = 0.0;
        for (uint v = 0u; v < pc.n_views; ++v) s += outv[v];
        outv[pc.n_views] = s;
    }
#elif defined(GRAD)
    uint i = (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) * 256u + lid;
    if (i >= pc.n_pixels) return;
    dl[i] = 2.0 * weight[i] * (img[i] - tgt[i]);
#endif
}
