#version 450
// Adam on the GPU for the design optimizer (engine/src/optim/adam.rs), one thread per parameter
// group: a scratch (its 7 parameters) or a light (log intensity). Two passes:
//   CHECK  flags a non-finite gradient (flags[0]), a non-finite or exploding loss (flags[1]) and an
//          overflowed tile list (flags[2]: the render missed pairs, so its gradient is incomplete);
//   APPLY  does nothing when any flag is set (the host then rolls back or retries), else one Adam
//          step per parameter and the projection onto the valid set:
//          endpoints clamped to the plate, |p1 - p0| >= min_len (pushed apart about the midpoint
//          along the scratch, which is kept on the plate), w, d, alpha clamped to their bounds;
//          a light's intensity is updated as u = ln Phi (gradient Phi dE/dPhi), Phi >= phi_min.
// Integer atomics only (flags), so results are bit-reproducible.
layout(local_size_x = 256) in;

struct ScratchGPU { vec4 ends; vec4 shape; };
struct ViewGPU { vec4 eye; vec4 fwd; vec4 right; vec4 up; vec4 light; uvec4 dims; uvec4 base; };

layout(std430, binding = 0) buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 1) readonly buffer Grad { float grad[]; };       // 8 per scratch
layout(std430, binding = 2) buffer M { float mom[]; };                    // 8 per scratch, then 1 per light
layout(std430, binding = 3) buffer V { float vel[]; };
layout(std430, binding = 4) buffer Views { ViewGPU views[]; };            // right.w = Phi
layout(std430, binding = 5) readonly buffer GradLight { float grad_light[]; };
layout(std430, binding = 6) readonly buffer Loss { float outv[]; };       // [2 n_views] = total loss
layout(std430, binding = 7) readonly buffer Stats { uint stats[]; };      // [2] tile-list entries
layout(std430, binding = 8) buffer Flags { uint flags[]; };

layout(push_constant) uniform Push {
    uint n_scratches;
    uint n_views;
    uint capacity;      // tile-list capacity of this render
    uint opt_light;     // 0: lights fixed
    float lr_end;       // per-kind learning rates (already scaled by the rollback factor)
    float lr_w;
    float lr_d;
    float lr_alpha;
    float lr_light;
    float beta1;
    float beta2;
    float eps;
    float bc1;          // 1 - beta1^t
    float bc2;          // 1 - beta2^t
    float half_plate;
    float min_len;
    float w_lo, w_hi;
    float d_lo, d_hi;
    float a_lo, a_hi;
    float phi_min;
    float loss_limit;   // a loss above this (10x the best so far) is an exploding step
} pc;

float adam_step(uint k, float g, float lr) {
    float m = pc.beta1 * mom[k] + (1.0 - pc.beta1) * g;
    float v = pc.beta2 * vel[k] + (1.0 - pc.beta2) * g * g;
    mom[k] = m;
    vel[k] = v;
    return lr * (m / pc.bc1) / (sqrt(v / pc.bc2) + pc.eps);
}

void main() {
    uint t = (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) * 256u + gl_LocalInvocationID.x;
    uint n = pc.n_scratches + pc.n_views;
    if (t >= n) return;
#if defined(CHECK)
    bool bad = false;
    if (t < pc.n_scratches) {
        for (uint k = 0u; k < 7u; ++k) {
            float g = grad[8u * t + k];
            bad = bad || isnan(g) || isinf(g);
        }
    } else if (pc.opt_light != 0u) {
        float g = grad_light[t - pc.n_scratches];
        bad = isnan(g) || isinf(g);
    }
    if (bad) atomicOr(flags[0], 1u);
    if (t == 0u) {
        float L = outv[2u * pc.n_views];
        if (isnan(L) || isinf(L) || L > pc.loss_limit) atomicOr(flags[1], 1u);
        if (stats[2] > pc.capacity) atomicOr(flags[2], 1u);
    }
#elif defined(APPLY)
    if ((flags[0] | flags[1] | flags[2]) != 0u) return;
    if (t < pc.n_scratches) {
        ScratchGPU s = scr[t];
        vec2 q0 = s.ends.xy, q1 = s.ends.zw;
        vec2 p0 = q0, p1 = q1;
        p0.x -= adam_step(8u * t + 0u, grad[8u * t + 0u], pc.lr_end);
        p0.y -= adam_step(8u * t + 1u, grad[8u * t + 1u], pc.lr_end);
        p1.x -= adam_step(8u * t + 2u, grad[8u * t + 2u], pc.lr_end);
        p1.y -= adam_step(8u * t + 3u, grad[8u * t + 3u], pc.lr_end);
        float w = s.shape.x - adam_step(8u * t + 4u, grad[8u * t + 4u], pc.lr_w);
        float d = s.shape.y - adam_step(8u * t + 5u, grad[8u * t + 5u], pc.lr_d);
        float a = s.shape.z - adam_step(8u * t + 6u, grad[8u * t + 6u], pc.lr_alpha);
        float h = pc.half_plate;
        p0 = clamp(p0, vec2(-h), vec2(h));
        p1 = clamp(p1, vec2(-h), vec2(h));
        vec2 dv = p1 - p0;
        float len = length(dv);
        if (!(len >= pc.min_len)) {
            // Too short: keep the direction (the previous one if the new one vanished) and the
            // midpoint, moved inwards just enough for both ends to stay on the plate.
            vec2 dir = len > 0.0 ? dv / len : normalize(q1 - q0);
            vec2 half_d = 0.5 * pc.min_len * dir;
            vec2 lim = vec2(h) - abs(half_d);
            vec2 mid = clamp(0.5 * (p0 + p1), -lim, lim);
            p0 = mid - half_d;
            p1 = mid + half_d;
        }
        scr[t].ends = vec4(p0, p1);
        scr[t].shape = vec4(clamp(w, pc.w_lo, pc.w_hi), clamp(d, pc.d_lo, pc.d_hi), clamp(a, pc.a_lo, pc.a_hi), s.shape.w);
    } else if (pc.opt_light != 0u) {
        uint v = t - pc.n_scratches;
        float phi = views[v].right.w;
        float du = adam_step(8u * pc.n_scratches + v, phi * grad_light[v], pc.lr_light);
        views[v].right.w = max(phi * exp(-du), pc.phi_min);
    }
#endif
}
