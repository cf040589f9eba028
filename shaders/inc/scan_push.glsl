// Push constants of the scan kernel (scan.comp); Rust twin: ScanPush in
// engine/src/render/layout.rs (checked by tests/layout.rs through test/layout_push.comp).
#ifndef SA_SCAN_PUSH_GLSL
#define SA_SCAN_PUSH_GLSL
layout(push_constant) uniform Push { uint n; uint n_blocks; uint pad0, pad1; } pc;
#endif
