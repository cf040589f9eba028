//! The design's parameter set when scratches may bend (`design --arcs`): every scratch's
//! (x0, y0, x1, y1, w, d, alpha, bulge) and every light's intensity. The scene is uploaded with
//! [`Renderer::upload_bendable`](crate::render::Renderer::upload_bendable), so the scratches the
//! optimizer moves are the arcs' own buffer ([`GpuScene::arc_params`]); the renderer writes
//! their chords before every render and chains the chords' gradients into
//! [`GpuScene::arc_grad`] after every backward (`shaders/arc_map.comp`). The groups are
//! [`SceneParams`]'s, with the bulge (the eighth float) moved within +-`max_bulge`; the
//! projection is [`SceneParams`]'s (a scratch shorter than `min_len` is stretched).
//!
//! What the optimizer cannot hold is repaired where the design is written
//! ([`scratchart_model::scene_file::legal_bulge`]): an arc that runs off the plate or turns tighter
//! than its groove's width gets the largest bulge of the same sign that is legal.
use std::sync::Arc;

use super::adam::{AdamConfig, AdamGroup, ParamBlock};
use super::driver::ParamSet;
use super::scene_params::SceneParams;
use crate::render::GpuScene;
use crate::vulkan::{Buffer, Context, GpuError, Recorder};

/// How a design moves bulges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcConfig {
    /// Chords each scratch is rendered as while the design runs (the written design is judged
    /// by the accuracy bar's own rule: engine/docs/model.md section 11).
    pub chords: u32,
    /// The largest |bulge| (tan of a quarter of the included angle).
    pub max_bulge: f32,
    /// Adam's learning rate for the bulge.
    pub lr_bulge: f32,
    /// Whether the optimizer renders the chords with their area weights (the arc kernels);
    /// false: the straight kernels (engine/docs/model.md section 11 measures the difference).
    pub weighted: bool,
}

impl Default for ArcConfig {
    fn default() -> ArcConfig {
        ArcConfig {
            chords: 8,
            max_bulge: 0.5,
            lr_bulge: 0.01,
            weighted: false,
        }
    }
}

impl ArcConfig {
    /// Chords per arc that a finished design is judged at: four times `chords`, at least 32
    /// (a design's renders at 32 agree with 128 within 0.002 of correlation; at 8, 0.977 to 0.989:
    /// engine/docs/model.md section 11).
    pub fn judged_chords(&self) -> u32 {
        (4 * self.chords).max(32)
    }
}

/// Scratches that may bend, and lights, as a parameter set.
pub struct ArcParams {
    cfg: AdamConfig,
    arcs: ArcConfig,
    scene: SceneParams,
}

impl ArcParams {
    pub fn new(ctx: &Arc<Context>, cfg: &AdamConfig, arcs: &ArcConfig) -> Result<ArcParams, GpuError> {
        Ok(ArcParams {
            cfg: *cfg,
            arcs: *arcs,
            scene: SceneParams::new(ctx, cfg)?,
        })
    }

    /// [`SceneParams::scratch_groups`] with the bulge free within +-`max_bulge`.
    pub fn scratch_groups(cfg: &AdamConfig, arcs: &ArcConfig, half_plate: f32) -> Vec<AdamGroup> {
        let mut g = SceneParams::scratch_groups(cfg, half_plate);
        g[7] = AdamGroup::linear(arcs.lr_bulge, (-arcs.max_bulge, arcs.max_bulge));
        g
    }
}

/// The arcs' buffers of `gs`, which [`Renderer::upload_bendable`](crate::render::Renderer::upload_bendable)
/// made.
fn arc_buffers(gs: &GpuScene) -> (&Buffer, &Buffer) {
    match (gs.arc_params(), gs.arc_grad()) {
        (Some(p), Some(g)) => (p, g),
        _ => panic!("ArcParams needs a scene uploaded with Renderer::upload_bendable"),
    }
}

impl ParamSet for ArcParams {
    fn blocks<'a>(&'a self, gs: &'a GpuScene) -> Vec<ParamBlock<'a>> {
        let (params, grad) = arc_buffers(gs);
        vec![
            ParamBlock {
                name: "scratches",
                params,
                grad,
                len: 8 * gs.n_scene_scratches(),
                groups: Self::scratch_groups(&self.cfg, &self.arcs, gs.half_plate()),
            },
            SceneParams::light_block(&self.cfg, gs),
        ]
    }

    fn moves_arcs(&self) -> bool {
        true
    }

    fn record_project(&self, rec: &mut Recorder, gs: &GpuScene, before: &[&Buffer], flags: &Buffer) {
        let (params, _) = arc_buffers(gs);
        self.scene
            .record_projection_of(rec, params, gs.n_scene_scratches(), gs.half_plate(), before[0], flags);
    }
}
