#version 450
// Per-scratch records for the shading kernels, once per render before the pair search: four
// RGBA32F texels per scratch, read through a uniform texel buffer (`recs`, see
// inc/scratch_records.glsl). The shading kernels fetch a scratch's data per candidate and per
// pair with per-lane indices; on CPU drivers (llvmpipe) a texel fetch is a vector gather, where a
// shared-memory or storage-buffer load with a per-lane index is a scalar loop over the lanes.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 1) writeonly buffer Records { vec4 rec[]; };
layout(push_constant) uniform Push {
    uint n_scratches;
    uint pad0, pad1, pad2;
} pc;

void main() {
    uint t = (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) * 64u + gl_LocalInvocationID.x;
    if (t >= pc.n_scratches) return;
    ScratchGPU S = scr[t];
    // The culling record: p0, unit direction t, length, w, carved half-width s_e = carved_se(w, d)
    // (in s = 2u/w units), alpha. A scratch shorter than float32 resolves at its position (p1
    // rounds onto p0) gets length 0 and overlaps nothing (pixel_masks skips it): no NaN
    // direction reaches the integrals or gradients.
    vec2 d = S.ends.zw - S.ends.xy;
    float len = length(d);
    rec[4u * t] = S.ends;
    rec[4u * t + 1u] = S.shape;
    rec[4u * t + 2u] = vec4(S.ends.xy, len > 0.0 ? d / len : vec2(1.0, 0.0));
    rec[4u * t + 3u] = vec4(len, S.shape.x, carved_se(S.shape.x, S.shape.y), S.shape.z);
}
