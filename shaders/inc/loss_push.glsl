// The loss kernels' segment struct and push constants (loss_fwd.comp, loss_bwd.comp, through
// inc/loss_bindings.glsl); Rust twins: LossSeg and LossPush in engine/optim/src/loss/mod.rs (checked
// by tests/layout.rs through test/layout_push.comp).
#ifndef SA_LOSS_PUSH_GLSL
#define SA_LOSS_PUSH_GLSL

struct LossSeg {
    uint off;    // first pyramid pixel
    uint w;
    uint h;
    uint view;
    uint level;
    uint blk0;   // first reduction block
    uint nblk;   // number of reduction blocks
    float weight;  // the view's weight in the loss (1 unless `design --balance` moves it)
};

// One cross-talk pair (engine/docs/model.md section 7): view v's blurred error B_v projected on
// u(i) = mask_v(i) (T_k(i) - mu) * s, view k's target centred over view v's picture and scaled
// to norm sqrt(kappa) (s = sqrt(kappa) / its norm; 0 where T_k is flat there).
struct XPair {
    uint v;      // the view whose error is projected
    uint k;      // the other view, whose target gives the direction (same size as v)
    uint part0;  // first of its partial sums in XPart (one per 256-pixel block of v's level 0)
    uint pad;
    float mu;
    float s;
    float pad1;
    float pad2;
};

layout(push_constant) uniform Push {
    uint n_views;
    uint n_levels;
    uint level;      // POOL / LEVEL_GRAD: the level processed
    uint n_blocks;   // reduction blocks over all segments
    uint lvl_begin;  // first pyramid pixel of the range processed
    uint lvl_end;    // one past its last pixel
    float lambda_p;
    float lambda_g;
    float g_c;       // 1D Gaussian weights: centre ...
    float g_s;       // ... and side (g_c + 2 g_s = 1); the 3x3 blur is their outer product
    uint n_segs;
    uint n_pairs;    // cross-talk pairs (XPart, XC; 0: no cross-talk term)
} pc;

#endif
