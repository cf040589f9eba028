//! The generic optimizer: iterate, roll back, checkpoint, resume, over any [`Objective`] and any
//! [`ParamSet`]. One GPU submission per iteration: a snapshot of the state, the parameter set's
//! map to the scene, the render ([`Renderer::record_render`]), the objective and its dE/dL, the
//! renderer's backward, the parameter set's chain rule, Adam over the set's flat blocks, and its
//! projection. A few scalars come back (objective terms, step flags, render counters).
//!
//! Iteration k evaluates the objective at x_k and (for k < iters) steps to x_{k+1}; the last
//! iteration only evaluates, so the state written out always has a verified value. A step is
//! rejected when its objective is NaN/inf or above 10x the best so far, or its gradient is not
//! finite: the state goes back to the last good copy (on the GPU: the snapshot taken at the start
//! of the last accepted iteration), the learning rates are halved, and that iteration is redone.
//! Adam refuses to move when any of these holds, so a NaN never reaches the parameters.
//!
//! The design job (`design.rs`) is one use: the design loss over scratches and lights. Tool
//! calibration will be another parameter set (a tool profile mapped to the scratches of a test
//! card) with another objective; the check loss E_lin ([`super::check::CheckObjective`]) is a
//! third objective.
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::adam::{Adam, AdamHyper, Moments, ParamBlock, StepCheck, StepFlags};
use super::checkpoint::{self, Chunk};
use super::error::OptimError;
use crate::render::{GpuScene, RenderStats, Renderer};
use crate::vulkan::{Buffer, Context, GpuError, MemLoc, Recorder};
use scratchart_observe::{Observer, Progress};

mod state;

/// The values of one evaluation of an objective.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    /// The objective's terms, in the objective's own order (for the design loss: per view, the
    /// pixel term and the Gram term).
    pub terms: Vec<f32>,
    /// The objective: what the optimizer minimizes.
    pub total: f32,
}

/// What the optimizer minimizes, given the render of the current parameters.
pub trait Objective {
    /// Records the objective of the render just recorded (`gs.image()`), on the device.
    fn record_forward(&self, rec: &mut Recorder, gs: &GpuScene);
    /// Records dE/dL of the objective just recorded into `gs.dl()`.
    fn record_backward(&self, rec: &mut Recorder, gs: &GpuScene);
    /// The device buffer that holds the total after `record_forward`, and its f32 index (read by
    /// Adam's check, so a bad step never moves the parameters).
    fn total_on_device(&self) -> (&Buffer, u32);
    /// Reads the values of the last recorded evaluation (after submission).
    fn read(&self) -> Result<Evaluation, GpuError>;
}

/// A borrowed objective is an objective (the caller keeps it for evaluations after the run).
impl<T: Objective + ?Sized> Objective for &T {
    fn record_forward(&self, rec: &mut Recorder, gs: &GpuScene) {
        (**self).record_forward(rec, gs)
    }
    fn record_backward(&self, rec: &mut Recorder, gs: &GpuScene) {
        (**self).record_backward(rec, gs)
    }
    fn total_on_device(&self) -> (&Buffer, u32) {
        (**self).total_on_device()
    }
    fn read(&self) -> Result<Evaluation, GpuError> {
        (**self).read()
    }
}

/// What the optimizer moves: flat blocks of parameters on the device.
pub trait ParamSet {
    /// The blocks, with their gradients and learning-rate groups. Their buffers must not change
    /// between calls (the optimizer keeps copies of them for rollback).
    fn blocks<'a>(&'a self, gs: &'a GpuScene) -> Vec<ParamBlock<'a>>;
    /// Called before iteration `k` is recorded (again, when it is redone after a rollback);
    /// `step`: whether it steps (the last iteration only evaluates). A set that draws something
    /// per iteration (a perturbed carving) draws it from `k`, so a resumed run draws the same.
    fn begin_iteration(&self, _k: u32, _step: bool) {}
    /// Whether the set moves the scratches of a scene with arcs (their own buffer,
    /// [`GpuScene::arc_params`]); a set that does not is refused on such a scene, since the
    /// kernels' scratches there are the chords, written again before every render.
    fn moves_arcs(&self) -> bool {
        false
    }
    /// Records the map from the parameters to the scene before the render (nothing when the
    /// parameters are the scene's own buffers).
    fn record_to_scene(&self, _rec: &mut Recorder, _gs: &GpuScene) {}
    /// Records the chain rule from the renderer's scene gradients to the blocks' gradients
    /// (nothing when the parameters are the scene's own).
    fn record_grad(&self, _rec: &mut Recorder, _gs: &GpuScene) {}
    /// Records the projection onto the valid set after Adam (box bounds are Adam's own).
    /// `before[i]` holds block i as it was before the step; nothing may move when `flags` has a
    /// flag set (the step was refused).
    fn record_project(&self, _rec: &mut Recorder, _gs: &GpuScene, _before: &[&Buffer], _flags: &Buffer) {}
}

/// Test hooks: inject failures to exercise the rollback path.
#[derive(Clone, Copy, Debug, Default)]
pub struct Hooks {
    /// Fill the gradient with NaN at this iteration (once).
    pub nan_grad_at: Option<u32>,
    /// Fill the rendered image with NaN at this iteration (once): a NaN objective.
    pub nan_image_at: Option<u32>,
    /// Stop with an error at the top of this iteration (after any checkpoint), as a killed run would.
    pub stop_at: Option<u32>,
}

/// How the driver runs.
#[derive(Clone, Debug)]
pub struct DriverConfig {
    /// Iterations with a step; iteration `iters` only evaluates.
    pub iters: u32,
    pub hyper: AdamHyper,
    /// Write a checkpoint every this many iterations (0: only at the end).
    pub checkpoint_every: u32,
    /// Where checkpoints go (`DIR/checkpoint.bin`); `None` writes none.
    pub checkpoint_dir: Option<PathBuf>,
    /// Give up after this many rollbacks.
    pub max_rollbacks: u32,
    pub hooks: Hooks,
    /// Names the job in progress reports ("design", "calibration", ...).
    pub task: &'static str,
    /// The learning rates' share at the last step: they hold until half the run and fall
    /// linearly to it ([`lr_schedule`]; 1: constant).
    pub lr_final: f64,
}

/// The learning rates' factor at the step of iteration `k` of `iters`: 1 until half the run,
/// then falling linearly to `lr_final` at the run's end (1: constant).
pub fn lr_schedule(k: u32, iters: u32, lr_final: f64) -> f64 {
    let f = k as f64 / iters.max(1) as f64;
    if f <= 0.5 {
        1.0
    } else {
        1.0 + (lr_final - 1.0) * ((f - 0.5) / 0.5).min(1.0)
    }
}

/// A rejected step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rollback {
    /// Iteration whose evaluation failed.
    pub iter: u32,
    pub reason: String,
    /// Learning-rate scale after halving.
    pub lr_scale: f64,
}

/// The optimizer's host-side state (everything else lives in GPU buffers); saved in checkpoints.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct HostState {
    /// next iteration to evaluate
    pub k: u32,
    /// Adam steps applied to the current state
    pub t: u32,
    /// Adam steps of the good copy
    pub good_t: u32,
    /// whether the good copy holds a verified state (false before the first accepted iteration)
    pub have_good: bool,
    pub lr_scale: f64,
    /// best accepted total so far (None before the first)
    pub best: Option<f32>,
    pub history: Vec<Evaluation>,
    pub rollbacks: Vec<Rollback>,
    /// Scratches of the state (None in checkpoints that predate [`Driver::replace_scene`]: the
    /// problem's own number).
    #[serde(default)]
    pub n_scratches: Option<u32>,
    /// Times the scene was replaced by another number of scratches ([`Driver::replace_scene`]):
    /// a resumed run does not apply those changes again.
    #[serde(default)]
    pub resized: u32,
}

/// Copies of one block's state on the GPU (parameters and moments).
struct Copy3 {
    params: Buffer,
    m: Buffer,
    v: Buffer,
}

impl Copy3 {
    fn new(ctx: &Arc<Context>, what: &str, block: &ParamBlock, mom: &Moments) -> Result<Copy3, GpuError> {
        let b = |n: &str, size: u64| Buffer::new(ctx, &format!("{what} {} {n}", block.name), size, MemLoc::GpuOnly);
        Ok(Copy3 {
            params: b("parameters", block.params.size())?,
            m: b("adam m", mom.m.size())?,
            v: b("adam v", mom.v.size())?,
        })
    }
}

/// Per block: moments, the group records, the snapshot of this iteration and the good copy.
struct BlockState {
    moments: Moments,
    groups: Buffer,
    snap: Copy3,
    good: Copy3,
}

/// Everything of a running optimization except the scene (kept apart so that recording can
/// borrow both).
struct Inner<'r> {
    ctx: Arc<Context>,
    renderer: &'r Renderer,
    objective: Box<dyn Objective + 'r>,
    params: Box<dyn ParamSet + 'r>,
    adam: Adam,
    blocks: Vec<BlockState>,
    st: HostState,
    cfg: DriverConfig,
    fingerprint: serde_json::Value,
    hooks_fired: (bool, bool),
}

/// Counters of the evaluations run in this process.
#[derive(Clone, Debug, Default)]
pub struct RunStats {
    /// Accepted evaluations.
    pub evals: u32,
    /// Sum of their overlapping (pixel, scratch) pairs.
    pub pairs_sum: f64,
    /// GPU milliseconds per stage, summed over them.
    pub gpu_ms: Vec<(String, f64)>,
    /// GPU milliseconds per stage of every accepted evaluation, in order (for benchmarks).
    pub timing_log: Vec<Vec<(String, f64)>>,
    /// Wall seconds of the evaluations' submissions (recording, the device's work, the wait and
    /// the counters' read; retries and rollbacks included), of the checkpoints, and of the
    /// hooks after each iteration (a design's balance, steering and live view): where a run's
    /// wall time per iteration goes beyond its GPU time.
    pub submit_s: f64,
    pub checkpoint_s: f64,
    pub hooks_s: f64,
}

/// A running optimization: the device scene, the objective, the parameter set, Adam's state.
pub struct Driver<'r> {
    pub gs: GpuScene,
    inner: Inner<'r>,
    pub stats: RunStats,
}

impl<'r> Driver<'r> {
    /// Builds the optimizer state (moments zero) for `params` moved against `objective` on `gs`.
    /// `fingerprint` is what a checkpoint must agree with to be resumed.
    pub fn new(
        renderer: &'r Renderer,
        gs: GpuScene,
        objective: Box<dyn Objective + 'r>,
        params: Box<dyn ParamSet + 'r>,
        cfg: DriverConfig,
        fingerprint: serde_json::Value,
    ) -> Result<Driver<'r>, GpuError> {
        if !params.moves_arcs() {
            gs.refuse_arcs("optimization")?;
        }
        let ctx = renderer.ctx.clone();
        renderer.prepare_backward_of(&gs)?;
        let mut blocks = Vec::new();
        for b in params.blocks(&gs) {
            let moments = Moments::zeros(&ctx, b.name, b.len)?;
            blocks.push(BlockState {
                groups: Adam::group_buffer(&ctx, &b)?,
                snap: Copy3::new(&ctx, "snapshot", &b, &moments)?,
                good: Copy3::new(&ctx, "good copy", &b, &moments)?,
                moments,
            });
        }
        Ok(Driver {
            gs,
            inner: Inner {
                adam: Adam::new(&ctx)?,
                ctx,
                renderer,
                objective,
                params,
                blocks,
                st: HostState {
                    k: 0,
                    t: 0,
                    good_t: 0,
                    have_good: false,
                    lr_scale: 1.0,
                    best: None,
                    history: Vec::new(),
                    rollbacks: Vec::new(),
                    n_scratches: None,
                    resized: 0,
                },
                cfg,
                fingerprint,
                hooks_fired: (false, false),
            },
            stats: RunStats::default(),
        })
    }

    pub fn history(&self) -> &[Evaluation] {
        &self.inner.st.history
    }

    pub fn rollbacks(&self) -> &[Rollback] {
        &self.inner.st.rollbacks
    }

    /// The next iteration to evaluate.
    pub fn next_iter(&self) -> u32 {
        self.inner.st.k
    }

    pub fn objective(&self) -> &dyn Objective {
        self.inner.objective.as_ref()
    }

    /// Runs iterations until `cfg.iters` has been evaluated, checkpointing on the way and
    /// reporting progress to `obs`. Returns the wall seconds and the iterations run.
    pub fn run(&mut self, obs: &dyn Observer) -> Result<(f64, u32), OptimError> {
        self.run_with(obs, &mut |_, _| Ok(true))
    }

    /// [`Driver::run`] that calls `after` with the driver and each accepted evaluation (a live
    /// view of the run: read the parameters, save a checkpoint, wait while paused). `after`
    /// returning false ends the run there, after the iteration it saw, as if it had been the
    /// last. `after` must not change the optimizer's state, so a run with a hook gives the same
    /// bits as one without.
    pub fn run_with(
        &mut self,
        obs: &dyn Observer,
        after: &mut dyn FnMut(&mut Driver<'r>, &Evaluation) -> Result<bool, OptimError>,
    ) -> Result<(f64, u32), OptimError> {
        let mut rec = Recorder::new(&self.inner.ctx)?;
        // Progress counts steps: iteration k (0-based) done means k steps taken; the last
        // evaluation (iteration `iters`, no step) completes the count.
        let total = self.inner.cfg.iters as u64;
        let task = self.inner.cfg.task;
        let t0 = Instant::now();
        let mut run = 0u32;
        obs.progress(&Progress::new(
            task,
            (self.inner.st.k as u64).min(total),
            total,
            String::new(),
        ));
        while self.inner.st.k <= self.inner.cfg.iters {
            let k = self.inner.st.k;
            let cfg = &self.inner.cfg;
            if let Some(dir) = &cfg.checkpoint_dir {
                if k > 0 && (k == cfg.iters || (cfg.checkpoint_every > 0 && k % cfg.checkpoint_every == 0)) {
                    let dir = dir.clone();
                    let t = Instant::now();
                    self.save_checkpoint(&dir)?;
                    self.stats.checkpoint_s += t.elapsed().as_secs_f64();
                }
            }
            if self.inner.cfg.hooks.stop_at == Some(k) {
                obs.finish(task);
                return Err(OptimError::Stopped(k));
            }
            if obs.should_stop() {
                obs.finish(task);
                let checkpoint = match &self.inner.cfg.checkpoint_dir {
                    Some(dir) => {
                        let dir = dir.clone();
                        self.save_checkpoint(&dir)?;
                        Some(checkpoint::path(&dir))
                    }
                    None => None,
                };
                return Err(OptimError::Interrupted { iter: k, checkpoint });
            }
            let ev = self.iterate(&mut rec, obs)?;
            run += 1;
            obs.progress(&Progress::new(
                task,
                (self.inner.st.k as u64).min(total),
                total,
                format!("loss {:.5}", ev.total),
            ));
            let t = Instant::now();
            let go_on = after(self, &ev)?;
            self.stats.hooks_s += t.elapsed().as_secs_f64();
            if !go_on {
                break;
            }
        }
        obs.finish(task);
        Ok((t0.elapsed().as_secs_f64(), run))
    }

    /// Runs iteration `st.k` until it is accepted (the render redone after tile-list growth,
    /// rolled back after a bad step). Returns the accepted evaluation.
    fn iterate(&mut self, rec: &mut Recorder, obs: &dyn Observer) -> Result<Evaluation, OptimError> {
        loop {
            let inner = &mut self.inner;
            let k = inner.st.k;
            let step = k < inner.cfg.iters;
            let nan_image = inner.cfg.hooks.nan_image_at == Some(k) && !inner.hooks_fired.0;
            let nan_grad = step && inner.cfg.hooks.nan_grad_at == Some(k) && !inner.hooks_fired.1;
            let mut failed = None;
            inner.params.begin_iteration(k, step);
            let inner_ref = &*inner;
            let t = Instant::now();
            let (stats, timings) = inner.renderer.submit(rec, &mut self.gs, |rec, gs| {
                if let Err(e) = inner_ref.record_eval(rec, gs, step, nan_image, nan_grad) {
                    failed = Some(e);
                }
            })?;
            self.stats.submit_s += t.elapsed().as_secs_f64();
            if let Some(e) = failed {
                return Err(e.into());
            }
            let inner = &mut self.inner;
            inner.hooks_fired.0 |= nan_image;
            inner.hooks_fired.1 |= nan_grad;
            self.stats.add(&stats, &timings.entries);
            let ev = inner.objective.read()?;
            let mut flags = if step {
                inner.adam.read_flags()?
            } else {
                StepFlags::default()
            };
            let limit = inner.st.best.map_or(f32::INFINITY, |b| 10.0 * b);
            if !ev.total.is_finite() || ev.total > limit {
                flags.bad_loss = true;
            }
            if flags.bad_loss || flags.nonfinite_grad {
                let reason = if !ev.total.is_finite() {
                    format!("non-finite loss {} at iteration {k}", ev.total)
                } else if flags.bad_loss {
                    format!(
                        "exploding step: loss {} at iteration {k} is above 10x the best so far ({})",
                        ev.total,
                        inner.st.best.unwrap_or(f32::INFINITY)
                    )
                } else {
                    format!("non-finite gradient at iteration {k}")
                };
                inner.rollback(&self.gs, rec, reason, obs)?;
                continue;
            }
            // Accepted: the snapshot (state at the start of this iteration) is the new good copy.
            for b in &mut inner.blocks {
                std::mem::swap(&mut b.snap, &mut b.good);
            }
            inner.st.good_t = inner.st.t;
            inner.st.have_good = true;
            if step {
                inner.st.t += 1;
            }
            inner.st.best = Some(inner.st.best.map_or(ev.total, |b| b.min(ev.total)));
            inner.st.history.push(ev.clone());
            inner.st.k += 1;
            return Ok(ev);
        }
    }
}

impl RunStats {
    fn add(&mut self, stats: &RenderStats, timings: &[(String, f64)]) {
        self.evals += 1;
        self.pairs_sum += stats.pairs as f64;
        self.timing_log.push(timings.to_vec());
        for (label, ms) in timings {
            match self.gpu_ms.iter_mut().find(|(l, _)| l == label) {
                Some(e) => e.1 += ms,
                None => self.gpu_ms.push((label.clone(), *ms)),
            }
        }
    }
}

impl Inner<'_> {
    /// Records one evaluation (and, with `step`, one step) of the current state.
    fn record_eval(
        &self,
        rec: &mut Recorder,
        gs: &GpuScene,
        step: bool,
        nan_image: bool,
        nan_grad: bool,
    ) -> Result<(), GpuError> {
        let blocks = self.params.blocks(gs);
        for (b, s) in blocks.iter().zip(&self.blocks) {
            copy(
                rec,
                [b.params, &s.moments.m, &s.moments.v],
                [&s.snap.params, &s.snap.m, &s.snap.v],
            );
        }
        rec.barrier();
        self.params.record_to_scene(rec, gs);
        self.renderer.record_render(rec, gs);
        if nan_image {
            rec.fill(gs.image(), f32::NAN.to_bits());
            rec.barrier();
        }
        self.objective.record_forward(rec, gs);
        rec.timestamp("loss");
        if !step {
            return Ok(());
        }
        self.objective.record_backward(rec, gs);
        rec.timestamp("loss backward");
        self.renderer.record_backward(rec, gs);
        self.params.record_grad(rec, gs);
        rec.timestamp("backward");
        if nan_grad {
            rec.fill(blocks[0].grad, f32::NAN.to_bits());
            rec.barrier();
        }
        let (objective, index) = self.objective.total_on_device();
        let check = StepCheck {
            objective,
            index,
            stats: gs.stats_buffer(),
            capacity: gs.capacity(),
            limit: self.st.best.map_or(f32::INFINITY, |b| 10.0 * b),
        };
        let moments: Vec<&Moments> = self.blocks.iter().map(|s| &s.moments).collect();
        let groups: Vec<&Buffer> = self.blocks.iter().map(|s| &s.groups).collect();
        self.adam.record(
            rec,
            &blocks,
            &moments,
            &groups,
            &self.cfg.hyper,
            self.st.t + 1,
            self.st.lr_scale * lr_schedule(self.st.k, self.cfg.iters, self.cfg.lr_final),
            &check,
        )?;
        let before: Vec<&Buffer> = self.blocks.iter().map(|s| &s.snap.params).collect();
        self.params.record_project(rec, gs, &before, &self.adam.flags);
        rec.timestamp("adam");
        Ok(())
    }

    fn rollback(
        &mut self,
        gs: &GpuScene,
        rec: &mut Recorder,
        reason: String,
        obs: &dyn Observer,
    ) -> Result<(), OptimError> {
        let k = self.st.k;
        // A non-finite gradient at an otherwise fine x_k recurs deterministically, so in every
        // case go back to the last accepted state x_{k-1} and redo its step with half the rate.
        if !self.st.have_good {
            return Err(OptimError::Diverged(format!(
                "{reason}: the initial state is already bad, nothing to roll back to (check the targets, lights and initial scratches)"
            )));
        }
        if self.st.rollbacks.len() as u32 >= self.cfg.max_rollbacks {
            return Err(OptimError::Diverged(format!(
                "{reason}: giving up after {} rollbacks",
                self.st.rollbacks.len()
            )));
        }
        self.st.lr_scale *= 0.5;
        rec.begin()?;
        for (b, s) in self.params.blocks(gs).iter().zip(&self.blocks) {
            copy(
                rec,
                [&s.good.params, &s.good.m, &s.good.v],
                [b.params, &s.moments.m, &s.moments.v],
            );
        }
        rec.barrier();
        rec.submit_and_wait()?;
        self.st.t = self.st.good_t;
        self.st.k = k - 1;
        self.st.history.pop();
        self.st.best = self
            .st
            .history
            .iter()
            .map(|h| h.total)
            .fold(None, |a: Option<f32>, t| Some(a.map_or(t, |a| a.min(t))));
        // The good copy still holds x_{k-1} (now also the current state): a verified state to
        // come back to if the redone iteration fails too.
        obs.warn(&format!(
            "{reason}; rolled back to iteration {} and halved the learning rates (scale {})",
            k - 1,
            self.st.lr_scale
        ));
        self.st.rollbacks.push(Rollback {
            iter: k,
            reason,
            lr_scale: self.st.lr_scale,
        });
        Ok(())
    }
}

/// `v`, or one zero when empty (buffers are never empty).
fn padded(v: &[f32]) -> Vec<f32> {
    if v.is_empty() {
        vec![0.0]
    } else {
        v.to_vec()
    }
}

fn copy(rec: &mut Recorder, from: [&Buffer; 3], to: [&Buffer; 3]) {
    for (a, b) in from.iter().zip(to.iter()) {
        rec.copy(a, b, a.size().min(b.size()));
    }
}

#[cfg(test)]
mod tests {
    use super::lr_schedule;

    /// Constant through the first half, then a straight fall to the final share at the end; a
    /// final share of 1 is constant throughout.
    #[test]
    fn the_rates_hold_then_fall_to_their_final_share() {
        for k in [0, 10, 35] {
            assert_eq!(lr_schedule(k, 70, 0.1), 1.0);
        }
        assert!((lr_schedule(52, 70, 0.1) - (1.0 - 0.9 * 17.0 / 35.0)).abs() < 1e-12);
        assert!((lr_schedule(70, 70, 0.1) - 0.1).abs() < 1e-12);
        let falls: Vec<f64> = (35..=70).map(|k| lr_schedule(k, 70, 0.1)).collect();
        assert!(falls.windows(2).all(|w| w[1] < w[0]), "{falls:?}");
        assert!((0..=70).all(|k| lr_schedule(k, 70, 1.0) == 1.0));
        // No division by zero for a run of no steps.
        assert_eq!(lr_schedule(0, 0, 0.1), 1.0);
    }
}
