//! Pruning after optimization (as the paper does): drop scratches whose removal barely changes
//! the loss.
//!
//! Importance of scratch k: how far its gradient would move it, sum_i |dE/dp_i| lr_i over its 7
//! parameters with the optimizer's per-kind learning rates (gradient times parameter scale). A
//! scratch that no view sees (its normals never send the light to an eye) has importance 0, and a
//! random initialization leaves many of those. This is only a ranking: scratches are removed in
//! batches, least important first (ties by index, so the result is deterministic), and each batch
//! is kept only if a true forward evaluation of the pruned design keeps the loss within `tol`
//! (relative) of the unpruned loss; otherwise the batch is halved.
use crate::model::scene::Scene;
use crate::render::Renderer;
use crate::vulkan::{GpuError, Recorder};

use super::adam::AdamConfig;
use super::loss::{Loss, LossValues};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PruneConfig {
    /// Largest relative loss increase accepted (0 disables pruning).
    pub tol: f64,
    /// First batch, as a fraction of the scratches.
    pub first_frac: f64,
    /// Forward evaluations spent on trial batches.
    pub max_trials: u32,
}

impl Default for PruneConfig {
    fn default() -> Self {
        PruneConfig {
            tol: 0.01,
            first_frac: 0.2,
            max_trials: 8,
        }
    }
}

impl PruneConfig {
    pub fn enabled(&self) -> bool {
        self.tol > 0.0 && self.max_trials > 0
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct PruneStats {
    pub before: usize,
    pub after: usize,
    pub loss_before: f32,
    pub loss_after: f32,
    pub trials: u32,
    pub accepted: u32,
}

/// Loss and per-scratch gradients (8 f32 each) of `scene`.
pub fn evaluate(renderer: &Renderer, loss: &Loss, scene: &Scene) -> Result<(LossValues, Vec<[f32; 8]>), GpuError> {
    let ctx = &renderer.ctx;
    let mut gs = renderer.upload(scene)?;
    gs.refuse_arcs("pruning")?;
    let mut rec = Recorder::new(ctx)?;
    renderer.submit(&mut rec, &mut gs, |rec, gs| {
        renderer.record_render(rec, gs);
        loss.record_forward(rec, gs.image());
        loss.record_backward(rec, gs.image(), gs.dl());
        renderer.record_backward(rec, gs);
    })?;
    let lv = loss.read()?;
    let g: Vec<[f32; 8]> = ctx.download(gs.scratch_grad())?;
    Ok((lv, g[..scene.scratches.len()].to_vec()))
}

/// Each scratch's importance (see the module doc) from its gradient `grads` (as [`evaluate`]
/// gives them) and the optimizer's learning rates.
pub fn importance(grads: &[[f32; 8]], adam: &AdamConfig) -> Vec<f64> {
    let lr = [
        adam.lr_end,
        adam.lr_end,
        adam.lr_end,
        adam.lr_end,
        adam.lr_w,
        adam.lr_d,
        adam.lr_alpha,
    ];
    grads
        .iter()
        .map(|g| (0..7).map(|i| (g[i] * lr[i]).abs() as f64).sum())
        .collect()
}

/// Prunes `scene` (see the module doc). Returns the pruned scene and what happened.
pub fn prune(
    renderer: &Renderer,
    loss: &Loss,
    scene: &Scene,
    cfg: &PruneConfig,
    adam: &AdamConfig,
) -> Result<(Scene, PruneStats), GpuError> {
    let (lv0, mut grads) = evaluate(renderer, loss, scene)?;
    let e0 = lv0.total;
    let limit = e0 as f64 * (1.0 + cfg.tol);
    let mut current = scene.clone();
    let mut cur_loss = e0;
    let n0 = scene.scratches.len();
    let min_batch = (n0 / 200).max(1);
    let mut batch = ((cfg.first_frac * n0 as f64).ceil() as usize).max(1);
    let (mut trials, mut accepted) = (0u32, 0u32);
    while trials < cfg.max_trials && batch >= min_batch && current.scratches.len() > 1 {
        let b = batch.min(current.scratches.len() - 1);
        let mut order: Vec<(f64, usize)> = importance(&grads, adam).into_iter().zip(0..).collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut drop = vec![false; current.scratches.len()];
        for &(_, k) in &order[..b] {
            drop[k] = true;
        }
        let mut cand = current.clone();
        cand.scratches = current
            .scratches
            .iter()
            .zip(&drop)
            .filter(|(_, d)| !**d)
            .map(|(s, _)| *s)
            .collect();
        trials += 1;
        let (lv, g) = evaluate(renderer, loss, &cand)?;
        if lv.total.is_finite() && (lv.total as f64) <= limit {
            current = cand;
            grads = g;
            cur_loss = lv.total;
            accepted += 1;
        } else {
            batch /= 2;
        }
    }
    let stats = PruneStats {
        before: n0,
        after: current.scratches.len(),
        loss_before: e0,
        loss_after: cur_loss,
        trials,
        accepted,
    };
    Ok((current, stats))
}
