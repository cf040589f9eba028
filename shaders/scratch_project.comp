#version 450
// Projection of the scratch parameter set after an Adam step (engine/optim/src/scene_params.rs):
// a scratch shorter than min_len keeps its direction (the one before the step if the new one
// vanished) and its midpoint, moved inwards just enough for both ends to stay on the plate, and
// is stretched to min_len. Adam has already clamped every coordinate to the plate and w, d, alpha
// to their bounds. Nothing happens when the step was refused (any flag set).
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
#include "inc/project_push.glsl"
layout(local_size_x = 256) in;
layout(std430, binding = 0) buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 1) readonly buffer Before { ScratchGPU before[]; };  // state before the step
layout(std430, binding = 2) readonly buffer Flags { uint flags[]; };

void main() {
    uint t = (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) * 256u + gl_LocalInvocationID.x;
    if (t >= pc.n_scratches) return;
    if ((flags[0] | flags[1] | flags[2]) != 0u) return;
    vec4 e = scr[t].ends;
    vec2 p0 = e.xy, p1 = e.zw;
    vec2 dv = p1 - p0;
    float len = length(dv);
    if (!(len >= pc.min_len)) {
        vec2 q0 = before[t].ends.xy, q1 = before[t].ends.zw;
        vec2 dir = len > 0.0 ? dv / len : normalize(q1 - q0);
        vec2 half_d = 0.5 * pc.min_len * dir;
        vec2 lim = vec2(pc.half_plate) - abs(half_d);
        vec2 mid = clamp(0.5 * (p0 + p1), -lim, lim);
        scr[t].ends = vec4(mid - half_d, mid + half_d);
    }
}
