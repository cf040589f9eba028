//! The design's parameter set: every scratch's (x0, y0, x1, y1, w, d, alpha) and every light's
//! intensity, optimized in place in the [`GpuScene`]'s own buffers.
//!
//! Adam's groups clamp the endpoints to the plate and w, d, alpha to their bounds, and move a
//! light's intensity in log space (so it stays positive). What couples several numbers is the
//! projection pass `shaders/scratch_project.comp`: a scratch shorter than `min_len` is stretched
//! about its midpoint, kept on the plate.
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::adam::{AdamConfig, AdamGroup, ParamBlock};
use super::driver::ParamSet;
use crate::render::GpuScene;
use crate::vulkan::{Buffer, ComputePipeline, Context, GpuError, Recorder, ShaderCompiler};

/// `#[repr(C)]` twin of the push block in `shaders/inc/project_push.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ProjectPush {
    pub n_scratches: u32,
    pub half_plate: f32,
    pub min_len: f32,
    pub pad0: u32,
}

/// Scratches and lights of a [`GpuScene`] as a parameter set.
pub struct SceneParams {
    cfg: AdamConfig,
    project: ComputePipeline,
}

impl SceneParams {
    pub fn new(ctx: &Arc<Context>, cfg: &AdamConfig) -> Result<SceneParams, GpuError> {
        let push = std::mem::size_of::<ProjectPush>() as u32;
        Ok(SceneParams {
            cfg: *cfg,
            project: ComputePipeline::new(ctx, &ShaderCompiler::embedded()?, "scratch_project.comp", &[], 3, push)?,
        })
    }

    /// The groups of a scratch's 8 floats: x0, y0, x1, y1 (clamped to the plate), w, d, alpha
    /// and the unused eighth (frozen).
    pub fn scratch_groups(cfg: &AdamConfig, half_plate: f32) -> Vec<AdamGroup> {
        let end = AdamGroup::linear(cfg.lr_end, (-half_plate, half_plate));
        vec![
            end,
            end,
            end,
            end,
            AdamGroup::linear(cfg.lr_w, cfg.w_bounds),
            AdamGroup::linear(cfg.lr_d, cfg.d_bounds),
            AdamGroup::linear(cfg.lr_alpha, cfg.alpha_bounds),
            AdamGroup::frozen(),
        ]
    }

    /// The group of a light's intensity: log space, at least `phi_min`; frozen when its learning
    /// rate is 0.
    pub fn light_group(cfg: &AdamConfig) -> AdamGroup {
        if cfg.lr_light > 0.0 {
            AdamGroup::log(cfg.lr_light, cfg.phi_min)
        } else {
            AdamGroup::frozen()
        }
    }

    /// The block of the lights' intensities of `gs` ([`light_group`](Self::light_group)), which
    /// every design parameter set moves alike.
    pub fn light_block<'a>(cfg: &AdamConfig, gs: &'a GpuScene) -> ParamBlock<'a> {
        ParamBlock {
            name: "lights",
            params: gs.lights(),
            grad: gs.light_grad(),
            len: gs.n_views(),
            groups: vec![Self::light_group(cfg)],
        }
    }

    /// Records the projection of the scratches after a step; `before` holds them as they were
    /// before it, `flags` Adam's flags (a refused step is not projected).
    pub fn record_projection(&self, rec: &mut Recorder, gs: &GpuScene, before: &Buffer, flags: &Buffer) {
        self.record_projection_of(rec, gs.scratches(), gs.n_scratches(), gs.half_plate(), before, flags);
    }

    /// [`record_projection`](Self::record_projection) of `n` scratches in `scratches` (one
    /// `ScratchGpu` each) on a plate of half size `half_plate`.
    pub fn record_projection_of(
        &self,
        rec: &mut Recorder,
        scratches: &Buffer,
        n: u32,
        half_plate: f32,
        before: &Buffer,
        flags: &Buffer,
    ) {
        let push = ProjectPush {
            n_scratches: n,
            half_plate,
            min_len: self.cfg.min_len,
            pad0: 0,
        };
        rec.dispatch_1d(
            &self.project,
            &[scratches, before, flags],
            bytemuck::bytes_of(&push),
            n.div_ceil(256),
        );
        rec.barrier();
    }
}

impl ParamSet for SceneParams {
    fn blocks<'a>(&'a self, gs: &'a GpuScene) -> Vec<ParamBlock<'a>> {
        vec![
            ParamBlock {
                name: "scratches",
                params: gs.scratches(),
                grad: gs.scratch_grad(),
                len: 8 * gs.n_scratches(),
                groups: Self::scratch_groups(&self.cfg, gs.half_plate()),
            },
            Self::light_block(&self.cfg, gs),
        ]
    }

    fn record_project(&self, rec: &mut Recorder, gs: &GpuScene, before: &[&Buffer], flags: &Buffer) {
        self.record_projection(rec, gs, before[0], flags);
    }
}

/// CPU twin of one step on one scratch (test oracle): `p` = [x0, y0, x1, y1, w, d, alpha], `g`
/// its gradient, `m`, `v` its moments (updated in place); step `t` (1-based) with learning rates
/// scaled by `lr_scale`. f32 arithmetic in the kernels' order (adam.comp, then
/// scratch_project.comp).
#[allow(clippy::too_many_arguments)]
pub fn reference_step(
    p: &mut [f32; 7],
    g: &[f32; 7],
    m: &mut [f32; 7],
    v: &mut [f32; 7],
    cfg: &AdamConfig,
    half_plate: f32,
    t: u32,
    lr_scale: f64,
) {
    let groups = SceneParams::scratch_groups(cfg, half_plate);
    let bc1 = (1.0 - (cfg.beta1 as f64).powi(t as i32)) as f32;
    let bc2 = (1.0 - (cfg.beta2 as f64).powi(t as i32)) as f32;
    let q = *p;
    let mut x = *p;
    for k in 0..7 {
        let lr = (groups[k].lr as f64 * lr_scale) as f32;
        m[k] = cfg.beta1 * m[k] + (1.0 - cfg.beta1) * g[k];
        v[k] = cfg.beta2 * v[k] + (1.0 - cfg.beta2) * g[k] * g[k];
        let step = lr * (m[k] / bc1) / ((v[k] / bc2).sqrt() + cfg.eps);
        x[k] = (p[k] - step).clamp(groups[k].lo, groups[k].hi);
    }
    let h = half_plate;
    let (dx, dy) = (x[2] - x[0], x[3] - x[1]);
    let len = (dx * dx + dy * dy).sqrt();
    if !(len >= cfg.min_len) {
        let (ux, uy) = if len > 0.0 {
            (dx / len, dy / len)
        } else {
            let (a, b) = (q[2] - q[0], q[3] - q[1]);
            let l = (a * a + b * b).sqrt();
            (a / l, b / l)
        };
        let (hx, hy) = (0.5 * cfg.min_len * ux, 0.5 * cfg.min_len * uy);
        let (lx, ly) = (h - hx.abs(), h - hy.abs());
        let mx = (0.5 * (x[0] + x[2])).clamp(-lx, lx);
        let my = (0.5 * (x[1] + x[3])).clamp(-ly, ly);
        x[0] = mx - hx;
        x[1] = my - hy;
        x[2] = mx + hx;
        x[3] = my + hy;
    }
    *p = x;
}
