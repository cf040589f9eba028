// Push constants of the viewer's present pass (view_present.comp); Rust twin: PresentPush in
// engine/render/src/present.rs (checked by tests/layout.rs through test/layout_push.comp).
#ifndef SA_PRESENT_PUSH_GLSL
#define SA_PRESENT_PUSH_GLSL
layout(push_constant) uniform Push {
    uvec4 dims;       // out_w, out_h, src_w, src_h
    uvec4 view_rect;  // x0, y0, w, h of the render in the output
    uvec4 tgt_rect;   // x0, y0, w, h of the target in the output (w = 0: none)
    uvec4 misc;       // first pixel of the view in img, tgt_w, tgt_h, flags (bit 0: nearest)
    vec4 params;      // exposure, background display value in [0, 1], 0, 0
} pc;
#endif
