// Push constants of the binning kernel (bin.comp); Rust twin: BinPush in
// engine/render/src/layout.rs (checked by tests/layout.rs through test/layout_push.comp).
#ifndef SA_BIN_PUSH_GLSL
#define SA_BIN_PUSH_GLSL
layout(push_constant) uniform Push {
    uint n_scratches;
    uint n_views;
    uint n_groups;
    uint group_size;
    uint capacity;   // length of list[]
    uint sentinel;   // 2 (loop_limit_hit, inc/limits.glsl)
    uint n_bands;    // 0: a thread bins its group in every view; else per (group, view, band of tile rows)
    uint pad2;
} pc;
#endif
