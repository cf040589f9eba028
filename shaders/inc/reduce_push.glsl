// Push constants of grad_reduce.comp; Rust twin: ReducePush in engine/render/src/layout.rs
// (checked by tests/layout.rs).
#ifndef SA_REDUCE_PUSH_GLSL
#define SA_REDUCE_PUSH_GLSL
layout(push_constant) uniform Push {
    uint n_scratches;
    uint capacity;  // tile-list capacity (entries past it were not listed)
    uint n_parts;   // binning parts per scratch (sbase has n_scratches * n_parts + 1 entries)
    uint pad1;
} pc;
#endif
