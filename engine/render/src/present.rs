//! The `#[repr(C)]` twin of the push constants of `shaders/view_present.comp`, the viewer's
//! present pass (linear L -> display bytes, upscaled, with the target beside it). The kernel
//! ships with the engine's embedded shaders, so its twin lives here, where `tests/layout.rs`
//! checks it against `shaders/inc/present_push.glsl`; `scratchart-view` records the pass.
use bytemuck::{Pod, Zeroable};

/// Push constants of `shaders/view_present.comp` (same field order and meaning).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct PresentPush {
    /// out_w, out_h, src_w, src_h
    pub dims: [u32; 4],
    /// x0, y0, w, h of the render in the output
    pub view_rect: [u32; 4],
    /// x0, y0, w, h of the target in the output (w = 0: none)
    pub tgt_rect: [u32; 4],
    /// first pixel of the view in the image buffer, tgt_w, tgt_h, flags (bit 0: nearest)
    pub misc: [u32; 4],
    /// exposure, background display value, 0, 0
    pub params: [f32; 4],
}
