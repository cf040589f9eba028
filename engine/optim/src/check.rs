//! The check loss of engine/docs/model.md section 8 as an [`Objective`] on the GPU (`shaders/check_loss.comp`):
//! E_lin = sum over views of the mean over the view's on-plate pixels of (L - T)^2, for given
//! linear target images T. The `grad` command reports it and its gradients; the gradient tests
//! hold it against central differences of the float64 reference.
//!
//! On-plate pixels come from the float64 camera geometry (`model::camera`), on the host, once.
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::driver::{Evaluation, Objective};
use crate::model::scene::Scene;
use crate::render::grad::Gradients;
use crate::render::{GpuScene, Renderer};
use crate::vulkan::{Buffer, ComputePipeline, Context, GpuError, MemLoc, Recorder, ShaderCompiler};

/// `#[repr(C)]` twin of the push block in `shaders/inc/check_push.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct CheckPush {
    pub n_views: u32,
    pub n_pixels: u32,
    pub pad: [u32; 2],
}

/// E_lin against fixed linear targets.
pub struct CheckObjective {
    value: ComputePipeline,
    total: ComputePipeline,
    grad: ComputePipeline,
    target: Buffer,
    weight: Buffer,
    out: Buffer,
    push: CheckPush,
}

impl CheckObjective {
    /// `targets`: one linear image per view of `scene` (row-major, top row first).
    pub fn new(ctx: &Arc<Context>, scene: &Scene, targets: &[Vec<f32>]) -> Result<CheckObjective, GpuError> {
        assert_eq!(targets.len(), scene.views.len(), "one target image per view");
        let half = 0.5 * scene.plate.size_mm;
        let (mut t, mut w) = (Vec::new(), Vec::new());
        for (v, view) in scene.views.iter().enumerate() {
            let (vw, vh) = (view.camera.width, view.camera.height);
            assert_eq!(targets[v].len(), (vw * vh) as usize, "target {v} has the wrong size");
            let mask = crate::model::camera::ViewGeom::of(view, &scene.plate).on_plate_mask(half);
            let n = mask.iter().filter(|m| **m).count().max(1) as f64;
            w.extend(mask.iter().map(|&m| if m { (1.0 / n) as f32 } else { 0.0 }));
            t.extend_from_slice(&targets[v]);
        }
        let sc = ShaderCompiler::embedded()?;
        let push = std::mem::size_of::<CheckPush>() as u32;
        let pipe = |pass: &str| ComputePipeline::new(ctx, &sc, "check_loss.comp", &[(pass, "1")], 6, push);
        Ok(CheckObjective {
            value: pipe("VALUE")?,
            total: pipe("TOTAL")?,
            grad: pipe("GRAD")?,
            target: ctx.upload("check loss targets", &t)?,
            weight: ctx.upload("check loss weights", &w)?,
            out: Buffer::new(
                ctx,
                "check loss values",
                (scene.views.len() as u64 + 1) * 4,
                MemLoc::GpuToCpu,
            )?,
            push: CheckPush {
                n_views: scene.views.len() as u32,
                n_pixels: t.len() as u32,
                pad: [0; 2],
            },
        })
    }

    fn bufs<'a>(&'a self, gs: &'a GpuScene) -> [&'a Buffer; 6] {
        [
            gs.views_buffer(),
            gs.image(),
            &self.target,
            &self.weight,
            gs.dl(),
            &self.out,
        ]
    }
}

impl Objective for CheckObjective {
    fn record_forward(&self, rec: &mut Recorder, gs: &GpuScene) {
        let pb = bytemuck::bytes_of(&self.push);
        rec.dispatch(&self.value, &self.bufs(gs), pb, [self.push.n_views, 1, 1]);
        rec.barrier();
        rec.dispatch(&self.total, &self.bufs(gs), pb, [1, 1, 1]);
        rec.barrier();
    }

    fn record_backward(&self, rec: &mut Recorder, gs: &GpuScene) {
        let pb = bytemuck::bytes_of(&self.push);
        rec.dispatch_1d(&self.grad, &self.bufs(gs), pb, self.push.n_pixels.div_ceil(256));
        rec.barrier();
    }

    fn total_on_device(&self) -> (&Buffer, u32) {
        (&self.out, self.push.n_views)
    }

    fn read(&self) -> Result<Evaluation, GpuError> {
        let o: Vec<f32> = self.out.read()?;
        let nv = self.push.n_views as usize;
        Ok(Evaluation {
            terms: o[..nv].to_vec(),
            total: o[nv],
        })
    }
}

/// Renders `gs` and evaluates `objective` and its gradients with respect to every scratch and
/// light, in one submission; gradients downloaded.
pub fn objective_gradients(
    renderer: &Renderer,
    gs: &mut GpuScene,
    objective: &dyn Objective,
) -> Result<(Evaluation, Gradients), GpuError> {
    renderer.prepare_backward_of(gs)?;
    let mut rec = Recorder::new(&renderer.ctx)?;
    renderer.submit(&mut rec, gs, |rec, gs| {
        renderer.record_render(rec, gs);
        objective.record_forward(rec, gs);
        objective.record_backward(rec, gs);
        renderer.record_backward(rec, gs);
    })?;
    let ev = objective.read()?;
    Ok((ev, renderer.download_gradients(gs)?))
}

/// The check loss of engine/docs/model.md section 8 and its gradients, for the `grad` command:
/// E_lin = sum over views of the mean over the view's on-plate pixels of (L - T)^2, with T the
/// given linear target images (one per view, row-major, top row first).
pub struct CheckLoss {
    pub e_lin: f64,
    pub grads: Gradients,
}

/// Renders `scene` and evaluates E_lin against `targets` and its gradients on the GPU
/// ([`CheckObjective`]); on-plate pixels come from the float64 camera geometry of
/// `model::camera`.
pub fn check_loss_gradients(
    renderer: &Renderer,
    gs: &mut GpuScene,
    scene: &Scene,
    targets: &[Vec<f32>],
) -> Result<CheckLoss, GpuError> {
    let objective = CheckObjective::new(&renderer.ctx, scene, targets)?;
    let (ev, grads) = objective_gradients(renderer, gs, &objective)?;
    Ok(CheckLoss {
        e_lin: ev.total as f64,
        grads,
    })
}
