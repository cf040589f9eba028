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
//
// A perturbed carving (design --robust, sigma_z or sigma_xy > 0): mode 0 maps z + sigma_z n0
// and moves the endpoints by sigma_xy (n1, n2) and (n3, n4), keeping the exact endpoints in
// `saved`; mode 1 takes the slopes at the same perturbed z and puts the saved endpoints back, so
// Adam steps the exact parameters with the gradient of the perturbed carving (for an additive
// error the gradient with respect to the exact endpoint is the perturbed one's). The n are
// standard normals from a counter-based hash of (seed, scratch): the same seed, the same carving.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
#include "inc/tool_map_push.glsl"
layout(local_size_x = 256) in;
layout(std430, binding = 0) buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 1) readonly buffer Depths { float z[]; };
layout(std430, binding = 2) readonly buffer Table { vec2 tab[]; };          // (w, d) per sample
layout(std430, binding = 3) readonly buffer ScratchGrad { float sg[]; };   // 8 per scratch
layout(std430, binding = 4) buffer DepthGrad { float zg[]; };
layout(std430, binding = 5) buffer Saved { vec4 saved[]; };                // exact endpoints

uint pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Two standard normals (Box-Muller) for draw `c` of scratch `t` in carving `seed`.
vec2 normals(uint t, uint c) {
    uint h = pcg(pcg(pc.seed) ^ (t * 4u + c));
    float u1 = (float(h >> 8u) + 0.5) / 16777216.0;
    float u2 = (float(pcg(h) >> 8u) + 0.5) / 16777216.0;
    float r = sqrt(-2.0 * log(u1));
    return r * vec2(cos(6.28318530718 * u2), sin(6.28318530718 * u2));
}

void main() {
    uint t = (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) * 256u + gl_LocalInvocationID.x;
    if (t >= pc.n_scratches) return;
    bool perturbed = pc.sigma_z > 0.0 || pc.sigma_xy > 0.0;
    float zt = z[t];
    if (perturbed) {
        zt += pc.sigma_z * normals(t, 0u).x;
    }
    float s = sqrt(max(zt - pc.z_first, 0.0));
    float u = (s - pc.s_lo) * pc.inv_ds;
    float kf = clamp(floor(u), 0.0, float(pc.n_table - 2u));
    uint k = uint(kf);
    float f = u - kf;
    vec2 a = tab[k];
    vec2 b = tab[k + 1u];
    // Shallower than the table's first sample (only a perturbed carving gets there): the groove
    // shrinks linearly in s to nothing at first contact, not along the end segment's
    // extrapolation (which can turn negative); at least 1e-3 of the first sample's.
    bool below = perturbed && s < pc.s_lo;
    float q = s / pc.s_lo;
    if (pc.mode == 0u) {
        vec2 wd = below ? tab[0] * max(q, 1e-3) : a + f * (b - a);
        scr[t].shape.xyz = vec3(wd, pc.alpha);
        if (perturbed) {
            vec4 e = scr[t].ends;
            saved[t] = e;
            scr[t].ends = e + pc.sigma_xy * vec4(normals(t, 1u), normals(t, 2u));
        }
    } else {
        vec2 slope;  // (dw/dz, dd/dz)
        if (below) {
            slope = q > 1e-3 ? tab[0] / (pc.s_lo * 2.0 * s) : vec2(0.0);
        } else {
            slope = (b - a) * (pc.inv_ds / (2.0 * s));
        }
        zg[t] = sg[8u * t + 4u] * slope.x + sg[8u * t + 5u] * slope.y;
        if (perturbed) {
            scr[t].ends = saved[t];
        }
    }
}
