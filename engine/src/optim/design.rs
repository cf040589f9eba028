//! The optimization loop: one GPU submission per iteration (snapshot of the state, binning,
//! forward, loss, loss backward, renderer backward, Adam), a few scalars read back (loss per
//! view, step flags, pair count), rollback of bad steps, checkpoints and bit-exact resume.
//!
//! Iteration k evaluates the loss at the parameters x_k and (for k < iters) steps to x_{k+1}; the
//! last iteration only evaluates, so the design written out always has a verified loss.
//! A step is rejected when its loss is NaN/inf or above 10x the best so far, or its gradient is
//! not finite: the state is restored from the last good copy (kept on the GPU: the snapshot taken
//! at the start of the last accepted iteration), the learning rates are halved, and that
//! iteration is redone. Adam itself refuses to move when any of these holds (see `adam.comp`),
//! so a NaN never reaches the parameters.
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde_json::{json, Value};

use super::adam::{Adam, AdamConfig, Moments, StepBuffers, StepFlags};
use super::loss::{Loss, LossConfig, LossValues};
use super::prune::{PruneConfig, PruneStats};
use crate::model::scene::{Scene, Scratch};
use crate::render::layout::{ScratchGpu, ViewGpu};
use crate::render::{GpuScene, Renderer};
use crate::vulkan::{Buffer, Context, GpuError, MemLoc, Recorder};

/// A design problem: plate, views (with their lights), initial scratches, one target per view
/// (display values in [0, 1], W x H, top row first).
#[derive(Clone, Debug)]
pub struct Problem {
    pub scene: Scene,
    pub targets: Vec<Vec<f32>>,
}

/// Test hooks: inject failures to exercise the rollback path.
#[derive(Clone, Copy, Debug, Default)]
pub struct Hooks {
    /// Fill the gradient with NaN at this iteration (once).
    pub nan_grad_at: Option<u32>,
    /// Fill the rendered image with NaN at this iteration (once): a NaN loss.
    pub nan_image_at: Option<u32>,
    /// Stop with an error at the top of this iteration (after any checkpoint), as a killed run would.
    pub stop_at: Option<u32>,
}

#[derive(Clone, Debug)]
pub struct DesignConfig {
    pub iters: u32,
    pub loss: LossConfig,
    pub adam: AdamConfig,
    /// Write a checkpoint every this many iterations (0: only at the end).
    pub checkpoint_every: u32,
    pub out: PathBuf,
    /// Continue from `out/checkpoint.bin`.
    pub resume: bool,
    pub prune: PruneConfig,
    pub hooks: Hooks,
    pub progress: bool,
    /// Seed of the initialization (recorded; the optimizer itself draws no random numbers).
    pub seed: u64,
    /// Scale the lights at the start so that each view's mean on-plate L matches its target's.
    pub calibrate_lights: bool,
    /// Give up after this many rollbacks.
    pub max_rollbacks: u32,
    /// Write the output files (design, images, plot, summary).
    pub write_outputs: bool,
}

impl DesignConfig {
    pub fn new(plate_mm: f64, out: PathBuf) -> DesignConfig {
        DesignConfig {
            iters: 200,
            loss: LossConfig::default(),
            adam: AdamConfig::for_plate(plate_mm),
            checkpoint_every: 50,
            out,
            resume: false,
            prune: PruneConfig::default(),
            hooks: Hooks::default(),
            progress: true,
            seed: 1,
            calibrate_lights: true,
            max_rollbacks: 30,
            write_outputs: true,
        }
    }
}

/// One accepted loss evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct IterRecord {
    pub pixel: Vec<f32>,
    pub gram: Vec<f32>,
    pub total: f32,
}

impl From<&LossValues> for IterRecord {
    fn from(l: &LossValues) -> Self {
        IterRecord {
            pixel: l.pixel.clone(),
            gram: l.gram.clone(),
            total: l.total,
        }
    }
}

/// A rejected step.
#[derive(Clone, Debug, PartialEq)]
pub struct Rollback {
    /// Iteration whose evaluation failed.
    pub iter: u32,
    pub reason: String,
    /// Learning-rate scale after halving.
    pub lr_scale: f64,
}

/// What a design run produced.
#[derive(Clone, Debug)]
pub struct DesignReport {
    /// The final design (after pruning, if any).
    pub scene: Scene,
    /// The optimized design before pruning.
    pub unpruned: Scene,
    pub history: Vec<IterRecord>,
    pub rollbacks: Vec<Rollback>,
    pub prune: Option<PruneStats>,
    /// Loss of the final design (after pruning).
    pub final_loss: LossValues,
    /// Wall seconds of the optimization loop and iterations run in this process.
    pub loop_seconds: f64,
    pub iters_run: u32,
    /// Mean (pixel, scratch) pairs per iteration and GPU milliseconds per phase.
    pub mean_pairs: f64,
    pub gpu_ms: Vec<(String, f64)>,
    /// Display images of the final design and of the initial one, per view.
    pub final_images: Vec<Vec<f32>>,
    pub initial_images: Vec<Vec<f32>>,
    pub resumed_from: Option<u32>,
}

/// A copy of the optimizer state on the GPU (parameters, moments, views).
struct Snapshot {
    scratches: Buffer,
    m: Buffer,
    v: Buffer,
    views: Buffer,
}

impl Snapshot {
    fn new(ctx: &Arc<Context>, name: &str, gs: &GpuScene, mom: &Moments) -> Result<Snapshot, GpuError> {
        Ok(Snapshot {
            scratches: Buffer::new(ctx, &format!("{name} scratches"), gs.scratches.size(), MemLoc::GpuOnly)?,
            m: Buffer::new(ctx, &format!("{name} adam m"), mom.m.size(), MemLoc::GpuOnly)?,
            v: Buffer::new(ctx, &format!("{name} adam v"), mom.v.size(), MemLoc::GpuOnly)?,
            views: Buffer::new(ctx, &format!("{name} views"), gs.views.size(), MemLoc::GpuOnly)?,
        })
    }
}

fn copy_state(rec: &mut Recorder, from: [&Buffer; 4], to: [&Buffer; 4]) {
    for (a, b) in from.iter().zip(to.iter()) {
        rec.copy(a, b, a.size().min(b.size()));
    }
    rec.barrier();
}

/// The optimizer's host-side state (everything else lives in GPU buffers).
#[derive(Clone, Debug, PartialEq)]
struct HostState {
    /// next iteration to evaluate
    k: u32,
    /// Adam steps applied to the current state
    t: u32,
    /// Adam steps of the good copy
    good_t: u32,
    /// whether the good copy holds a verified state (false before the first accepted iteration)
    have_good: bool,
    lr_scale: f64,
    best: f32,
    history: Vec<IterRecord>,
    rollbacks: Vec<Rollback>,
}

const CKPT_MAGIC: &[u8; 8] = b"SACKPT01";
const CKPT_FILE: &str = "checkpoint.bin";

/// A running optimization: the GPU scene and every optimizer buffer.
pub struct Optimizer<'r> {
    ctx: Arc<Context>,
    renderer: &'r Renderer,
    pub gs: GpuScene,
    pub loss: Loss,
    adam: Adam,
    mom: Moments,
    snap: Snapshot,
    good: Snapshot,
    st: HostState,
    cfg: DesignConfig,
    fingerprint: Value,
    hooks_fired: (bool, bool),
    pairs_sum: f64,
    gpu_ms: Vec<(String, f64)>,
    /// GPU milliseconds per stage of every accepted evaluation, in order (for benchmarks).
    pub timing_log: Vec<Vec<(String, f64)>>,
    evals: u32,
}

/// FNV-1a 64 of bytes (checkpoint integrity and target fingerprints).
fn fnv(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

impl<'r> Optimizer<'r> {
    /// Uploads the problem and builds the loss and Adam state (moments zero).
    pub fn new(renderer: &'r Renderer, problem: &Problem, cfg: &DesignConfig) -> Result<Optimizer<'r>, GpuError> {
        let ctx = renderer.ctx.clone();
        renderer.prepare_backward()?;
        let gs = renderer.upload(&problem.scene)?;
        let loss = Loss::new(&ctx, &gs.slots.views, &problem.targets, cfg.loss)?;
        let adam = Adam::new(&ctx)?;
        let nv = gs.shade.n_views;
        let zeros = vec![0f32; Moments::len_floats(gs.n_scratches, nv)];
        let mom = Moments {
            m: ctx.upload("adam m", &zeros)?,
            v: ctx.upload("adam v", &zeros)?,
        };
        let snap = Snapshot::new(&ctx, "snapshot", &gs, &mom)?;
        let good = Snapshot::new(&ctx, "good copy", &gs, &mom)?;
        let mut tbytes = Vec::new();
        for t in &problem.targets {
            tbytes.extend_from_slice(bytemuck::cast_slice(t));
        }
        // What a checkpoint must agree with to be resumed (iters may differ: no schedule depends on it).
        let views: Vec<Value> = gs
            .slots
            .views
            .iter()
            .map(|v| {
                let mut v = *v;
                v.right[3] = 0.0; // the intensity is optimized state, not setup
                json!(bytemuck::cast_slice::<ViewGpu, u32>(&[v]))
            })
            .collect();
        let fingerprint = json!({
            "n_scratches": gs.n_scratches,
            "views": views,
            "plate": [problem.scene.plate.size_mm, problem.scene.plate.roughness, problem.scene.plate.f0],
            "targets_fnv": format!("{:016x}", fnv(&tbytes)),
            "loss": format!("{:?}", cfg.loss),
            "adam": format!("{:?}", cfg.adam),
            "seed": cfg.seed,
        });
        Ok(Optimizer {
            ctx,
            renderer,
            gs,
            loss,
            adam,
            mom,
            snap,
            good,
            st: HostState {
                k: 0,
                t: 0,
                good_t: 0,
                have_good: false,
                lr_scale: 1.0,
                best: f32::INFINITY,
                history: Vec::new(),
                rollbacks: Vec::new(),
            },
            cfg: cfg.clone(),
            fingerprint,
            hooks_fired: (false, false),
            pairs_sum: 0.0,
            gpu_ms: Vec::new(),
            timing_log: Vec::new(),
            evals: 0,
        })
    }

    fn state_bufs(&self) -> [&Buffer; 4] {
        [&self.gs.scratches, &self.mom.m, &self.mom.v, &self.gs.views]
    }

    /// Renders the current state and returns the display images (and the linear ones).
    pub fn render(&mut self) -> Result<(Vec<Vec<f32>>, Vec<Vec<f32>>), GpuError> {
        let frame = self.renderer.render(&mut self.gs)?;
        let disp = frame
            .images
            .iter()
            .map(|img| img.iter().map(|&l| crate::io::display_value(l)).collect())
            .collect();
        Ok((disp, frame.images))
    }

    /// Scales each light so that its view's mean L over on-plate pixels equals the mean of the
    /// target's linear values (T^2.2) there: a sensible starting brightness for any target.
    pub fn calibrate_lights(&mut self, scene: &Scene, targets: &[Vec<f32>]) -> Result<(), GpuError> {
        let (_, lin) = self.render()?;
        let mut views: Vec<ViewGpu> = self.gs.views.read()?;
        views.truncate(scene.views.len());
        for (v, (img, t)) in lin.iter().zip(targets).enumerate() {
            let mask = crate::model::reference::on_plate_mask(scene, v);
            let (mut sl, mut st, mut n) = (0.0f64, 0.0f64, 0usize);
            for ((&l, &tv), &m) in img.iter().zip(t).zip(&mask) {
                if m {
                    sl += l as f64;
                    st += (tv as f64).powf(2.2);
                    n += 1;
                }
            }
            if n > 0 && sl > 0.0 && st > 0.0 {
                let phi = views[v].right[3] as f64 * st / sl;
                views[v].right[3] = (phi as f32).max(self.cfg.adam.phi_min);
            }
        }
        self.gs.views.write(0, &views)?;
        self.gs.slots.views = views;
        Ok(())
    }

    /// The current design as a scene (parameters and light intensities read back).
    pub fn scene(&self, template: &Scene) -> Result<Scene, GpuError> {
        let scr: Vec<ScratchGpu> = self.ctx.download(&self.gs.scratches)?;
        let views: Vec<ViewGpu> = self.gs.views.read()?;
        Ok(to_scene(template, &scr[..self.gs.n_scratches as usize], &views))
    }

    fn record_eval(&self, rec: &mut Recorder, step: bool, nan_image: bool, nan_grad: bool) {
        let gs = &self.gs;
        copy_state(
            rec,
            self.state_bufs(),
            [&self.snap.scratches, &self.snap.m, &self.snap.v, &self.snap.views],
        );
        rec.fill(&gs.stats, 0);
        rec.barrier();
        self.renderer.record_binning(rec, gs);
        rec.timestamp("binning");
        self.renderer.record_shading(rec, gs);
        rec.timestamp("forward");
        if nan_image {
            rec.fill(&gs.image, f32::NAN.to_bits());
            rec.barrier();
        }
        self.loss.record_forward(rec, &gs.image);
        rec.timestamp("loss");
        if step {
            self.loss.record_backward(rec, &gs.image, &gs.dl);
            rec.timestamp("loss backward");
            self.renderer.record_backward(rec, gs);
            rec.timestamp("backward");
            if nan_grad {
                rec.fill(&gs.grad, f32::NAN.to_bits());
                rec.barrier();
            }
            let limit = if self.st.best.is_finite() {
                10.0 * self.st.best
            } else {
                f32::INFINITY
            };
            let push = Adam::push(
                &self.cfg.adam,
                gs.n_scratches,
                gs.shade.n_views,
                gs.capacity,
                gs.shade.half_plate,
                self.st.t + 1,
                self.st.lr_scale,
                limit,
            );
            let b = StepBuffers {
                scratches: &gs.scratches,
                grad: &gs.grad,
                moments: &self.mom,
                views: &gs.views,
                grad_light: &gs.grad_light,
                loss: &self.loss.out,
                stats: &gs.stats,
            };
            self.adam.record(rec, &b, &push);
            rec.timestamp("adam");
        }
    }

    /// Runs iteration `st.k` until it is accepted (retrying after tile-list growth, rolling back
    /// after a bad step). Returns the accepted loss values.
    fn iterate(&mut self, rec: &mut Recorder) -> anyhow::Result<LossValues> {
        loop {
            let k = self.st.k;
            let step = k < self.cfg.iters;
            let nan_image = self.cfg.hooks.nan_image_at == Some(k) && !self.hooks_fired.0;
            let nan_grad = step && self.cfg.hooks.nan_grad_at == Some(k) && !self.hooks_fired.1;
            rec.begin()?;
            self.record_eval(rec, step, nan_image, nan_grad);
            let timings = rec.submit_and_wait()?;
            let stats: Vec<u32> = self.gs.stats.read()?;
            if stats[2] > self.gs.capacity {
                // Incomplete render (Adam did not move): grow the tile lists and redo.
                self.renderer.grow_list(&mut self.gs, stats[2] as u64)?;
                continue;
            }
            self.hooks_fired.0 |= nan_image;
            self.hooks_fired.1 |= nan_grad;
            self.evals += 1;
            self.pairs_sum += stats[1] as f64;
            self.timing_log.push(timings.entries.clone());
            for (label, ms) in &timings.entries {
                match self.gpu_ms.iter_mut().find(|(l, _)| l == label) {
                    Some(e) => e.1 += ms,
                    None => self.gpu_ms.push((label.clone(), *ms)),
                }
            }
            let lv = self.loss.read()?;
            let mut flags = if step {
                self.adam.read_flags()?
            } else {
                StepFlags::default()
            };
            let limit = if self.st.best.is_finite() {
                10.0 * self.st.best
            } else {
                f32::INFINITY
            };
            if !lv.total.is_finite() || lv.total > limit {
                flags.bad_loss = true;
            }
            if flags.bad_loss || flags.nonfinite_grad {
                let reason = if !lv.total.is_finite() {
                    format!("non-finite loss {} at iteration {k}", lv.total)
                } else if flags.bad_loss {
                    format!(
                        "exploding step: loss {} at iteration {k} is above 10x the best so far ({})",
                        lv.total, self.st.best
                    )
                } else {
                    format!("non-finite gradient at iteration {k}")
                };
                self.rollback(rec, reason)?;
                continue;
            }
            // Accepted: the snapshot (state at the start of this iteration) is the new good copy.
            std::mem::swap(&mut self.snap, &mut self.good);
            self.st.good_t = self.st.t;
            self.st.have_good = true;
            if step {
                self.st.t += 1;
            }
            self.st.best = self.st.best.min(lv.total);
            self.st.history.push(IterRecord::from(&lv));
            self.st.k += 1;
            return Ok(lv);
        }
    }

    fn rollback(&mut self, rec: &mut Recorder, reason: String) -> anyhow::Result<()> {
        let k = self.st.k;
        // A non-finite gradient at an otherwise fine x_k recurs deterministically, so in every case
        // go back to the last accepted state x_{k-1} and redo its step with half the rate.
        if !self.st.have_good {
            anyhow::bail!("{reason}: the initial design is already bad, nothing to roll back to (check the targets, lights and initial scratches)");
        }
        if self.st.rollbacks.len() as u32 >= self.cfg.max_rollbacks {
            anyhow::bail!("{reason}: giving up after {} rollbacks", self.st.rollbacks.len());
        }
        self.st.lr_scale *= 0.5;
        rec.begin()?;
        copy_state(
            rec,
            [&self.good.scratches, &self.good.m, &self.good.v, &self.good.views],
            self.state_bufs(),
        );
        rec.submit_and_wait()?;
        self.st.t = self.st.good_t;
        self.st.k = k - 1;
        self.st.history.pop();
        self.st.best = self.st.history.iter().map(|h| h.total).fold(f32::INFINITY, f32::min);
        // The good copy still holds x_{k-1} (now also the current state): a verified state to
        // come back to if the redone iteration fails too.
        eprintln!(
            "warning: {reason}; rolled back to iteration {} and halved the learning rates (scale {})",
            k - 1,
            self.st.lr_scale
        );
        self.st.rollbacks.push(Rollback {
            iter: k,
            reason,
            lr_scale: self.st.lr_scale,
        });
        Ok(())
    }

    /// Writes `out/checkpoint.bin` atomically: a JSON header (host state, fingerprint, checksum)
    /// and the raw GPU state (current and good copies).
    pub fn save_checkpoint(&self, out: &Path) -> anyhow::Result<()> {
        let mut data: Vec<u8> = Vec::new();
        for b in
            self.state_bufs()
                .into_iter()
                .chain([&self.good.scratches, &self.good.m, &self.good.v, &self.good.views])
        {
            let bytes: Vec<u8> = self.ctx.download(b)?;
            data.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
            data.extend_from_slice(&bytes);
        }
        let h = &self.st;
        let meta = json!({
            "version": 1,
            "fingerprint": self.fingerprint,
            "k": h.k, "t": h.t, "good_t": h.good_t, "have_good": h.have_good,
            "lr_scale": h.lr_scale, "best": h.best as f64,
            "history": h.history.iter().map(|r| json!({"pixel": r.pixel, "gram": r.gram, "total": r.total})).collect::<Vec<_>>(),
            "rollbacks": h.rollbacks.iter().map(|r| json!({"iter": r.iter, "reason": r.reason, "lr_scale": r.lr_scale})).collect::<Vec<_>>(),
            "data_fnv": format!("{:016x}", fnv(&data)),
        });
        let text = serde_json::to_vec(&meta)?;
        let mut file = Vec::with_capacity(16 + text.len() + data.len());
        file.extend_from_slice(CKPT_MAGIC);
        file.extend_from_slice(&(text.len() as u64).to_le_bytes());
        file.extend_from_slice(&text);
        file.extend_from_slice(&data);
        crate::io::write_atomic(&out.join(CKPT_FILE), &file)?;
        Ok(())
    }

    /// Restores the state saved by [`save_checkpoint`](Self::save_checkpoint).
    pub fn load_checkpoint(&mut self, out: &Path) -> anyhow::Result<()> {
        use anyhow::{bail, Context as _};
        let path = out.join(CKPT_FILE);
        let file = std::fs::read(&path).with_context(|| {
            format!(
                "cannot resume: cannot read checkpoint `{}` (run without --resume to start afresh)",
                path.display()
            )
        })?;
        let bad = |msg: &str| {
            anyhow::anyhow!(
                "checkpoint `{}` is damaged: {msg}; run without --resume",
                path.display()
            )
        };
        if file.len() < 16 || &file[..8] != CKPT_MAGIC {
            return Err(bad("bad magic"));
        }
        let n = u64::from_le_bytes(file[8..16].try_into().unwrap()) as usize;
        let meta: Value = serde_json::from_slice(file.get(16..16 + n).ok_or_else(|| bad("truncated header"))?)
            .map_err(|_| bad("bad header"))?;
        let data = &file[16 + n..];
        if meta["data_fnv"].as_str() != Some(&format!("{:016x}", fnv(data))) {
            return Err(bad("checksum mismatch"));
        }
        if meta["fingerprint"] != self.fingerprint {
            let fp = &meta["fingerprint"];
            let what: Vec<&str> = ["n_scratches", "views", "plate", "targets_fnv", "loss", "adam", "seed"]
                .into_iter()
                .filter(|k| fp[*k] != self.fingerprint[*k])
                .collect();
            bail!(
                "checkpoint `{}` was made with different settings ({} differ); resume with the same flags and targets, or run without --resume",
                path.display(),
                what.join(", ")
            );
        }
        let mut pos = 0usize;
        let mut chunks = Vec::new();
        for _ in 0..8 {
            let len = u64::from_le_bytes(
                data.get(pos..pos + 8)
                    .ok_or_else(|| bad("truncated data"))?
                    .try_into()
                    .unwrap(),
            ) as usize;
            chunks.push(
                data.get(pos + 8..pos + 8 + len)
                    .ok_or_else(|| bad("truncated data"))?
                    .to_vec(),
            );
            pos += 8 + len;
        }
        let ctx = self.ctx.clone();
        let up = |name: &str, c: &[u8]| -> Result<Buffer, GpuError> { ctx.upload(name, c) };
        self.gs.scratches = up("scratches", &chunks[0])?;
        self.mom.m = up("adam m", &chunks[1])?;
        self.mom.v = up("adam v", &chunks[2])?;
        self.gs
            .views
            .write(0, &chunks[3][..chunks[3].len().min(self.gs.views.size() as usize)])?;
        self.good.scratches = up("good copy scratches", &chunks[4])?;
        self.good.m = up("good copy adam m", &chunks[5])?;
        self.good.v = up("good copy adam v", &chunks[6])?;
        self.good.views = up("good copy views", &chunks[7])?;
        let views: Vec<ViewGpu> = self.gs.views.read()?;
        self.gs.slots.views = views[..self.gs.slots.views.len()].to_vec();
        let num = |k: &str| meta[k].as_f64().ok_or_else(|| bad(k));
        let f32s = |v: &Value| -> Vec<f32> {
            v.as_array()
                .map(|a| a.iter().filter_map(|x| x.as_f64()).map(|x| x as f32).collect())
                .unwrap_or_default()
        };
        self.st = HostState {
            k: num("k")? as u32,
            t: num("t")? as u32,
            good_t: num("good_t")? as u32,
            have_good: meta["have_good"].as_bool().ok_or_else(|| bad("have_good"))?,
            lr_scale: num("lr_scale")?,
            best: meta["best"].as_f64().map(|x| x as f32).unwrap_or(f32::INFINITY),
            history: meta["history"]
                .as_array()
                .ok_or_else(|| bad("history"))?
                .iter()
                .map(|r| IterRecord {
                    pixel: f32s(&r["pixel"]),
                    gram: f32s(&r["gram"]),
                    total: r["total"].as_f64().unwrap_or(f64::NAN) as f32,
                })
                .collect(),
            rollbacks: meta["rollbacks"]
                .as_array()
                .ok_or_else(|| bad("rollbacks"))?
                .iter()
                .map(|r| Rollback {
                    iter: r["iter"].as_u64().unwrap_or(0) as u32,
                    reason: r["reason"].as_str().unwrap_or("").to_string(),
                    lr_scale: r["lr_scale"].as_f64().unwrap_or(1.0),
                })
                .collect(),
        };
        Ok(())
    }

    /// Runs iterations until `cfg.iters` has been evaluated, checkpointing on the way.
    pub fn run(&mut self) -> anyhow::Result<(f64, u32)> {
        let mut rec = Recorder::new(&self.ctx)?;
        let total = self.cfg.iters + 1;
        let bar = if self.cfg.progress {
            let b = indicatif::ProgressBar::new(total as u64);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} design [{bar:30}] {pos}/{len} iters, {elapsed} elapsed, ETA {eta} | loss {msg}",
                )
                .unwrap()
                .progress_chars("=> "),
            );
            b
        } else {
            indicatif::ProgressBar::hidden()
        };
        bar.set_position(self.st.k as u64);
        let t0 = Instant::now();
        let mut run = 0u32;
        while self.st.k <= self.cfg.iters {
            let k = self.st.k;
            if self.cfg.write_outputs
                && k > 0
                && (k == self.cfg.iters || (self.cfg.checkpoint_every > 0 && k % self.cfg.checkpoint_every == 0))
            {
                self.save_checkpoint(&self.cfg.out)?;
            }
            if self.cfg.hooks.stop_at == Some(k) {
                anyhow::bail!("stopped by the test hook at iteration {k}");
            }
            let lv = self.iterate(&mut rec)?;
            run += 1;
            bar.set_position(self.st.k as u64);
            let per: Vec<String> = lv.per_view().iter().map(|v| format!("{v:.4}")).collect();
            bar.set_message(format!("{:.5} (views {})", lv.total, per.join(" ")));
        }
        bar.finish_and_clear();
        Ok((t0.elapsed().as_secs_f64(), run))
    }

    /// The render counters of the last evaluation: [candidates, pairs, list entries].
    pub fn gs_stats(&self) -> Result<Vec<u32>, GpuError> {
        self.gs.stats.read()
    }

    pub fn history(&self) -> &[IterRecord] {
        &self.st.history
    }

    pub fn rollbacks(&self) -> &[Rollback] {
        &self.st.rollbacks
    }

    pub fn next_iter(&self) -> u32 {
        self.st.k
    }
}

/// Builds a scene from GPU parameters: `template`'s plate and views with the lights' optimized
/// intensities (`views[v].right[3]`).
pub fn to_scene(template: &Scene, scr: &[ScratchGpu], views: &[ViewGpu]) -> Scene {
    let mut scene = template.clone();
    scene.scratches = scr
        .iter()
        .map(|s| Scratch {
            p0: [s.ends[0] as f64, s.ends[1] as f64],
            p1: [s.ends[2] as f64, s.ends[3] as f64],
            w: s.shape[0] as f64,
            d: s.shape[1] as f64,
            alpha: s.shape[2] as f64,
        })
        .collect();
    for (v, g) in scene.views.iter_mut().zip(views) {
        v.light.intensity = g.right[3] as f64;
    }
    scene
}

/// The whole `design` job: optimize, prune, evaluate and (if configured) write the outputs.
pub fn run_design(ctx: &Arc<Context>, problem: &Problem, cfg: &DesignConfig) -> anyhow::Result<DesignReport> {
    use anyhow::Context as _;
    if cfg.write_outputs {
        std::fs::create_dir_all(&cfg.out)
            .with_context(|| format!("cannot create output directory `{}`", cfg.out.display()))?;
    }
    let renderer = Renderer::new(ctx)?;
    let mut opt = Optimizer::new(&renderer, problem, cfg)?;
    let resumed_from = if cfg.resume {
        opt.load_checkpoint(&cfg.out)?;
        anyhow::ensure!(
            opt.next_iter() <= cfg.iters,
            "the checkpoint in `{}` is at iteration {}, beyond --iters {}; resume with --iters {} or more",
            cfg.out.display(),
            opt.next_iter(),
            cfg.iters,
            opt.next_iter()
        );
        Some(opt.next_iter())
    } else {
        if cfg.calibrate_lights {
            opt.calibrate_lights(&problem.scene, &problem.targets)?;
        }
        None
    };
    let initial_scene = if resumed_from.is_some() {
        None
    } else {
        Some(opt.scene(&problem.scene)?)
    };
    let (initial_images, _) = opt.render()?;
    let (loop_seconds, iters_run) = opt.run()?;
    let unpruned = opt.scene(&problem.scene)?;
    let evals = opt.evals.max(1) as f64;
    let mean_pairs = opt.pairs_sum / evals;
    let gpu_ms: Vec<(String, f64)> = opt.gpu_ms.iter().map(|(l, ms)| (l.clone(), ms / evals)).collect();
    let history = opt.history().to_vec();
    let rollbacks = opt.rollbacks().to_vec();
    let loss = &opt.loss;

    let (scene, prune) = if cfg.prune.enabled() {
        let (s, st) = super::prune::prune(&renderer, loss, &unpruned, &cfg.prune, &cfg.adam)?;
        (s, Some(st))
    } else {
        (unpruned.clone(), None)
    };
    // Final evaluation and images of the written design.
    let mut gs = renderer.upload(&scene)?;
    let frame = renderer.render(&mut gs)?;
    let final_loss = loss.evaluate(ctx, &gs.image, None)?;
    let final_images: Vec<Vec<f32>> = frame
        .images
        .iter()
        .map(|img| img.iter().map(|&l| crate::io::display_value(l)).collect())
        .collect();
    let report = DesignReport {
        scene,
        unpruned,
        history,
        rollbacks,
        prune,
        final_loss,
        loop_seconds,
        iters_run,
        mean_pairs,
        gpu_ms,
        final_images,
        initial_images,
        resumed_from,
    };
    if cfg.write_outputs {
        super::report::write_outputs(&cfg.out, problem, cfg, &report, initial_scene.as_ref())?;
    }
    Ok(report)
}
