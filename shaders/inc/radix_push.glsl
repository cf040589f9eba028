// Push constants of the radix sort's passes (radix.comp); Rust twin: RadixPush in
// engine/render/src/layout.rs (checked by tests/layout.rs through test/layout_push.comp).
#ifndef SA_RADIX_PUSH_GLSL
#define SA_RADIX_PUSH_GLSL
layout(push_constant) uniform Push {
    uint n_blocks;     // blocks of 256 pairs that cover the capacity
    uint shift;        // the digit's first bit
    uint total_index;  // sbase[total_index] = the number of pairs
    uint capacity;     // pairs the buffers hold
    uint first;        // 1: the values are the emission indices themselves
    uint pad0;
    uint pad1;
    uint pad2;
} pc;
#endif
