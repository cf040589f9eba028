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
    uint pad;
} pc;

#endif
