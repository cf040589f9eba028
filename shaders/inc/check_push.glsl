// Push constants of check_loss.comp; Rust twin: CheckPush in engine/optim/src/check.rs
// (checked by tests/layout.rs).
#ifndef SA_CHECK_PUSH_GLSL
#define SA_CHECK_PUSH_GLSL
layout(push_constant) uniform Push {
    uint n_views;
    uint n_pixels;  // pixels of all views
    uint pad0, pad1;
} pc;
#endif
