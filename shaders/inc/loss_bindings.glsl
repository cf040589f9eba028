// Storage buffers and push constants shared by loss_fwd.comp and loss_bwd.comp (one pipeline
// layout of 17 buffers for every loss pass; a pass ignores what it does not use). Twin:
// engine/optim/src/loss/mod.rs (binding order in `Loss::bufs`; LossSeg and LossPush, declared in
// inc/loss_push.glsl).
#ifndef SA_LOSS_BINDINGS_GLSL
#define SA_LOSS_BINDINGS_GLSL

layout(local_size_x = 256) in;

#include "inc/loss_push.glsl"

layout(std430, binding = 0) readonly buffer Segs { LossSeg segs[]; };     // level-major, view-minor
layout(std430, binding = 1) readonly buffer Blocks { uvec4 blocks[]; };   // (segment, first pixel, count, 0)
layout(std430, binding = 2) readonly buffer Img { float img[]; };         // linear L (renderer's image)
layout(std430, binding = 3) buffer Pyr { float pyr[]; };                  // display pyramid (render, or the target at setup)
layout(std430, binding = 4) readonly buffer TPyr { float tpyr[]; };       // target pyramid
layout(std430, binding = 5) buffer Pre { float pre[]; };                  // 5 filter responses per pyramid pixel; backward: their gradients
layout(std430, binding = 6) buffer Bbuf { float bbuf[]; };                // level 0: g * (I - T)
layout(std430, binding = 7) buffer Part { float part[]; };                // per block: 46 partial sums
layout(std430, binding = 8) buffer Gram { float gram[]; };                // per segment: 45 Gram entries / N, mean (g*(I-T))^2
layout(std430, binding = 9) readonly buffer GramT { float gramT[]; };     // the target's
layout(std430, binding = 10) buffer Out { float outv[]; };                // per view (pixel, gram) loss; [2 n_views] = total
layout(std430, binding = 11) buffer Gx { float gx[]; };                   // dE/d(pyramid value), levels >= 1
layout(std430, binding = 12) buffer Dl { float dl[]; };                   // dE/dL (level 0 layout = image layout)
layout(std430, binding = 13) readonly buffer XMask { float xmask[]; };    // level 0: 1 inside the view's picture, else 0
layout(std430, binding = 14) readonly buffer XPairs { XPair xpairs[]; };  // cross-talk pairs (v, k), by v then k
layout(std430, binding = 15) buffer XPart { float xpart[]; };             // per pair and block of v: partial <B_v, u>
layout(std430, binding = 16) buffer XC { float xc[]; };                   // per pair: c = <B_v, u>

uint flat_id() {
    return (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) * 256u + gl_LocalInvocationID.x;
}

#endif
