// Push constants of the scan kernel (scan.comp); Rust twin: ScanPush in
// engine/render/src/layout.rs (checked by tests/layout.rs through test/layout_push.comp).
#ifndef SA_SCAN_PUSH_GLSL
#define SA_SCAN_PUSH_GLSL
layout(push_constant) uniform Push {
    uint n;
    uint n_blocks;
    uint flag_index;  // stats[] slot set when the total would wrap past 2^32 - 1
    uint pad1;
} pc;
#endif
