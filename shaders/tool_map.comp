#version 450
// Fabrication mode (engine/optim/src/tool_params.rs): one commanded carve depth z per scratch,
// mapped through the calibrated tool's curve z -> (w, d), sampled on the host at n_table points
// uniformly spaced in s = sqrt(z - z_first) (dense where the curve bends most, near first
// contact) and interpolated linearly in s.
//   mode 0  writes each scratch's w, d and the fixed alpha from its z (endpoints untouched);
//   mode 1  writes dE/dz = dE/dw dw/dz + dE/dd dd/dz into the depth gradient, with the slopes of
//           the table segment that mode 0 used: the exact derivative of the piecewise-linear map
//           (dw/dz = dw/ds / (2 s); s >= sqrt(1 um) > 0 on the valid range).
// z outside the table's range (f32 rounding of the bounds) extrapolates the end segment.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
#include "inc/tool_map_push.glsl"
layout(local_size_x = 256) in;
layout(std430, binding = 0) buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 1) readonly buffer Depths { float z[]; };
layout(std430, binding = 2) readonly buffer Table { vec2 tab[]; };          // (w, d) per sample
layout(std430, binding = 3) readonly buffer ScratchGrad { float sg[]; };   // 8 per scratch
layout(std430, binding = 4) buffer DepthGrad { float zg[]; };

void main() {
    uint t = (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) * 256u + gl_LocalInvocationID.x;
    if (t >= pc.n_scratches) return;
    float s = sqrt(max(z[t] - pc.z_first, 0.0));
    float u = (s - pc.s_lo) * pc.inv_ds;
    float kf = clamp(floor(u), 0.0, float(pc.n_table - 2u));
    uint k = uint(kf);
    float f = u - kf;
    vec2 a = tab[k];
    vec2 b = tab[k + 1u];
    if (pc.mode == 0u) {
        vec2 wd = a + f * (b - a);
        scr[t].shape.xyz = vec3(wd, pc.alpha);
    } else {
        vec2 slope = (b - a) * (pc.inv_ds / (2.0 * s));  // (dw/dz, dd/dz)
        zg[t] = sg[8u * t + 4u] * slope.x + sg[8u * t + 5u] * slope.y;
    }
}
