#version 450
// Adam on one flat parameter buffer (engine/optim/src/adam.rs), one thread per float. Element i
// belongs to learning-rate group i % stride (a scratch's 8 floats: 4 endpoint coordinates, w, d,
// alpha and an unused one; a light: one group). Each group has a learning rate, box bounds, a
// space (linear, or logarithmic: x = exp(u), moved in u with gradient x dE/dx, for quantities
// that must stay positive) and a frozen flag (frozen elements are neither checked nor moved).
// Two passes:
//   CHECK  flags a non-finite gradient (flags[0]); with `check_objective` (set on one block per
//          step), also a non-finite or exploding objective (flags[1]) and an incomplete render
//          (flags[2]: the tile lists overflowed, so the gradient misses pairs);
//   APPLY  does nothing when any flag is set (the host then rolls back or retries), else one Adam
//          step per element and the clamp to its group's bounds. Constraints that couple several
//          elements (a scratch's minimum length) are the parameter set's own projection pass.
// Integer atomics only (flags), so results are bit-reproducible.
#extension GL_GOOGLE_include_directive : require
#include "inc/adam_push.glsl"
layout(local_size_x = 256) in;

layout(std430, binding = 0) buffer Params { float x[]; };
layout(std430, binding = 1) readonly buffer Grad { float grad[]; };
layout(std430, binding = 2) buffer M { float mom[]; };
layout(std430, binding = 3) buffer V { float vel[]; };
layout(std430, binding = 4) readonly buffer Groups { AdamGroupGPU groups[]; };
layout(std430, binding = 5) buffer Flags { uint flags[]; };
layout(std430, binding = 6) readonly buffer Objective { float objv[]; };  // [objective_index] = total
layout(std430, binding = 7) readonly buffer Stats { uint stats[]; };      // [2] tile-list entries

void main() {
    uint i = (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) * 256u + gl_LocalInvocationID.x;
#if defined(CHECK)
    if (i == 0u && pc.check_objective != 0u) {
        float L = objv[pc.objective_index];
        if (isnan(L) || isinf(L) || L > pc.loss_limit) atomicOr(flags[1], 1u);
        if (stats[2] > pc.capacity || stats[5] != 0u) atomicOr(flags[2], 1u);  // incomplete render (inc/limits.glsl)
    }
    if (i >= pc.n) return;
    AdamGroupGPU G = groups[i % pc.stride];
    if (G.mode_frozen.y != 0u) return;
    float g = grad[i];
    if (isnan(g) || isinf(g)) atomicOr(flags[0], 1u);
#elif defined(APPLY)
    if (i >= pc.n) return;
    if ((flags[0] | flags[1] | flags[2]) != 0u) return;
    AdamGroupGPU G = groups[i % pc.stride];
    if (G.mode_frozen.y != 0u) return;
    float xi = x[i];
    float g = grad[i];
    bool log_space = G.mode_frozen.x != 0u;
    if (log_space) g = xi * g;  // dE/du = x dE/dx for x = exp(u)
    float m = pc.beta1 * mom[i] + (1.0 - pc.beta1) * g;
    float v = pc.beta2 * vel[i] + (1.0 - pc.beta2) * g * g;
    mom[i] = m;
    vel[i] = v;
    float step = G.lr_lo_hi.x * (m / pc.bc1) / (sqrt(v / pc.bc2) + pc.eps);
    float y = log_space ? xi * exp(-step) : xi - step;
    x[i] = log_space ? max(y, G.lr_lo_hi.y) : clamp(y, G.lr_lo_hi.y, G.lr_lo_hi.z);
#endif
}
