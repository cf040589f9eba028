//! The design loss on the GPU (engine/docs/model.md section 7): values per view and dE/dL per pixel.
//!
//! E = lambda_p sum_v mean_p (g * (I_v - T_v))^2 + lambda_g sum_v sum_s ||Gram_s(phi(I_v)) - Gram_s(phi(T_v))||^2
//! with I = L^(1/2.2), g the normalized 3x3 Gaussian (clamp-to-edge borders), and phi the fixed
//! feature bank of `shaders/inc/loss_bank.glsl` (3 scales x 9 rectified oriented channels). The
//! kernels are `shaders/loss_fwd.comp` and `shaders/loss_bwd.comp`; [`reference`] is their f64 CPU
//! twin (a test oracle). Off-plate pixels (L = 0) count in the loss like any other pixel.
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use crate::render::layout::ViewGpu;
use crate::vulkan::{Buffer, ComputePipeline, Context, GpuError, MemLoc, Recorder, ShaderCompiler};

/// Values per block in the partial sums (45 Gram entries + sum of squared blurred differences).
const NPART: u64 = 46;
const NPRE: u64 = 5;
const BLOCK: u32 = 256;

/// Weights and filter settings of the loss.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LossConfig {
    /// Weight of the blurred squared error (paper: 1).
    pub lambda_p: f32,
    /// Weight of the Gram term (paper: 0.01).
    pub lambda_g: f32,
    /// Standard deviation of the 3x3 Gaussian, pixels.
    pub sigma: f32,
    /// Pyramid levels of the feature bank (scales 1, 1/2, 1/4 for 3).
    pub levels: u32,
}

impl Default for LossConfig {
    fn default() -> Self {
        LossConfig {
            lambda_p: 1.0,
            lambda_g: 0.01,
            sigma: 1.0,
            levels: 3,
        }
    }
}

impl LossConfig {
    /// Centre and side weights of the normalized 1D Gaussian on {-1, 0, 1}.
    pub fn gauss_1d(&self) -> (f32, f32) {
        let s = (-0.5 / (self.sigma as f64 * self.sigma as f64)).exp();
        let norm = 1.0 + 2.0 * s;
        ((1.0 / norm) as f32, (s / norm) as f32)
    }
}

/// `#[repr(C)]` twin of `LossSeg` in `shaders/inc/loss_push.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct LossSeg {
    pub off: u32,
    pub w: u32,
    pub h: u32,
    pub view: u32,
    pub level: u32,
    pub blk0: u32,
    pub nblk: u32,
    /// The view's weight in both terms (1 unless [`Loss::set_view_weights`] moves it).
    pub weight: f32,
}

/// `#[repr(C)]` twin of the push block in `shaders/inc/loss_push.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct LossPush {
    pub n_views: u32,
    pub n_levels: u32,
    pub level: u32,
    pub n_blocks: u32,
    pub lvl_begin: u32,
    pub lvl_end: u32,
    pub lambda_p: f32,
    pub lambda_g: f32,
    pub g_c: f32,
    pub g_s: f32,
    pub n_segs: u32,
    pub pad: u32,
}

/// Pyramid geometry: segments (level-major, view-minor) and the pixel range of each level.
#[derive(Clone, Debug)]
pub struct Pyramid {
    pub segs: Vec<LossSeg>,
    /// (first, one past last) pyramid pixel of each level
    pub levels: Vec<(u32, u32)>,
    pub n_views: u32,
    pub n_blocks: u32,
}

impl Pyramid {
    /// Level 0 follows the renderer's image layout (view v at `base[1]`); coarser levels follow.
    pub fn new(views: &[ViewGpu], n_levels: u32) -> Pyramid {
        let nv = views.len() as u32;
        let mut segs = Vec::new();
        let mut levels = Vec::new();
        let mut dims: Vec<(u32, u32)> = views.iter().map(|v| (v.dims[0], v.dims[1])).collect();
        let mut off = 0u32;
        let mut blk = 0u32;
        for level in 0..n_levels.max(1) {
            let begin = off;
            for (v, &(w, h)) in dims.iter().enumerate() {
                let o = if level == 0 { views[v].base[1] } else { off };
                let nblk = (w * h).div_ceil(BLOCK);
                segs.push(LossSeg {
                    off: o,
                    w,
                    h,
                    view: v as u32,
                    level,
                    blk0: blk,
                    nblk,
                    weight: 1.0,
                });
                blk += nblk;
                off = o + w * h;
            }
            levels.push((begin, off));
            dims = dims.iter().map(|&(w, h)| ((w / 2).max(1), (h / 2).max(1))).collect();
        }
        Pyramid {
            segs,
            levels,
            n_views: nv,
            n_blocks: blk,
        }
    }

    pub fn n_pixels(&self) -> u32 {
        self.levels.last().unwrap().1
    }

    /// (segment, first pixel, count, 0) of every reduction block.
    pub fn blocks(&self) -> Vec<[u32; 4]> {
        let mut out = Vec::with_capacity(self.n_blocks as usize);
        for (s, seg) in self.segs.iter().enumerate() {
            let n = seg.w * seg.h;
            for b in 0..seg.nblk {
                let start = b * BLOCK;
                out.push([s as u32, seg.off + start, (n - start).min(BLOCK), 0]);
            }
        }
        out
    }
}

/// Loss of one evaluation, read back from the GPU.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LossValues {
    /// Pixel term lambda_p mean (g * (I - T))^2, per view.
    pub pixel: Vec<f32>,
    /// Gram term, per view.
    pub gram: Vec<f32>,
    /// Sum over views (in view order) of both terms: the objective.
    pub total: f32,
}

impl LossValues {
    pub fn per_view(&self) -> Vec<f32> {
        self.pixel.iter().zip(&self.gram).map(|(p, g)| p + g).collect()
    }
}

struct Pipes {
    display: ComputePipeline,
    pool: ComputePipeline,
    feat: ComputePipeline,
    partial: ComputePipeline,
    gram: ComputePipeline,
    final_: ComputePipeline,
    pre_grad: ComputePipeline,
    level_grad: ComputePipeline,
}

/// GPU loss: pipelines, the target's pyramid and Gram matrices, and scratch buffers.
pub struct Loss {
    pub cfg: LossConfig,
    pub pyr: Pyramid,
    pipes: Pipes,
    segs: Buffer,
    blocks: Buffer,
    /// display pyramid of the render
    disp: Buffer,
    tpyr: Buffer,
    pre: Buffer,
    bbuf: Buffer,
    part: Buffer,
    gram: Buffer,
    gram_t: Buffer,
    /// per view (pixel, gram), then the total; host-readable
    pub out: Buffer,
    gx: Buffer,
    /// The weights of the pixel and Gram terms as f32 bits: `cfg`'s, until a steered design
    /// changes them between iterations ([`Loss::set_weights`]).
    weights: [std::sync::atomic::AtomicU32; 2],
    /// Each view's weight as last set ([`Loss::set_view_weights`]).
    view_w: std::sync::Mutex<Vec<f32>>,
}

const NUM_BUFFERS: u32 = 13;

impl Loss {
    /// Builds the pipelines and buffers for the views of an uploaded scene (their `dims` and
    /// `base`) and uploads the targets (display values in [0, 1], one image per view, W x H each,
    /// top row first), computing their pyramid and Gram matrices once.
    pub fn new(ctx: &Arc<Context>, views: &[ViewGpu], targets: &[Vec<f32>], cfg: LossConfig) -> Result<Loss, GpuError> {
        assert_eq!(targets.len(), views.len(), "Loss::new: one target per view");
        for (v, (t, view)) in targets.iter().zip(views).enumerate() {
            assert_eq!(
                t.len(),
                view.dims[0] as usize * view.dims[1] as usize,
                "Loss::new: target {v} must have {}x{} values",
                view.dims[0],
                view.dims[1]
            );
        }
        let sc = ShaderCompiler::embedded()?;
        let push = std::mem::size_of::<LossPush>() as u32;
        let p = |file: &str, def: &str| ComputePipeline::new(ctx, &sc, file, &[(def, "1")], NUM_BUFFERS, push);
        let pipes = Pipes {
            display: p("loss_fwd.comp", "DISPLAY")?,
            pool: p("loss_fwd.comp", "POOL")?,
            feat: p("loss_fwd.comp", "FEAT")?,
            partial: p("loss_fwd.comp", "PARTIAL")?,
            gram: p("loss_fwd.comp", "GRAM")?,
            final_: p("loss_fwd.comp", "FINAL")?,
            pre_grad: p("loss_bwd.comp", "PRE_GRAD")?,
            level_grad: p("loss_bwd.comp", "LEVEL_GRAD")?,
        };
        let pyr = Pyramid::new(views, cfg.levels);
        let n = pyr.n_pixels() as u64;
        let n_segs = pyr.segs.len() as u64;
        let mut t0 = vec![0f32; n as usize];
        for (t, view) in targets.iter().zip(views) {
            let b = view.base[1] as usize;
            t0[b..b + t.len()].copy_from_slice(t);
        }
        let loss = Loss {
            cfg,
            segs: ctx.upload("loss segments", &pyr.segs)?,
            blocks: ctx.upload("loss blocks", &pyr.blocks())?,
            disp: Buffer::new(ctx, "loss display pyramid", n * 4, MemLoc::GpuOnly)?,
            tpyr: ctx.upload("loss target pyramid", &t0)?,
            pre: Buffer::new(ctx, "loss filter responses", n * NPRE * 4, MemLoc::GpuOnly)?,
            bbuf: Buffer::new(
                ctx,
                "loss blurred difference",
                pyr.levels[0].1 as u64 * 4,
                MemLoc::GpuOnly,
            )?,
            part: Buffer::new(
                ctx,
                "loss partial sums",
                pyr.n_blocks as u64 * NPART * 4,
                MemLoc::GpuOnly,
            )?,
            gram: Buffer::new(ctx, "loss gram", n_segs * NPART * 4, MemLoc::GpuOnly)?,
            gram_t: Buffer::new(ctx, "loss target gram", n_segs * NPART * 4, MemLoc::GpuOnly)?,
            out: Buffer::new(ctx, "loss values", (2 * views.len() as u64 + 1) * 4, MemLoc::GpuToCpu)?,
            gx: Buffer::new(ctx, "loss pyramid gradient", n * 4, MemLoc::GpuOnly)?,
            weights: [
                std::sync::atomic::AtomicU32::new(cfg.lambda_p.to_bits()),
                std::sync::atomic::AtomicU32::new(cfg.lambda_g.to_bits()),
            ],
            view_w: std::sync::Mutex::new(vec![1.0; views.len()]),
            pyr,
            pipes,
        };
        // The target's pyramid, filter responses and Gram matrices, once.
        let mut rec = Recorder::new(ctx)?;
        rec.begin()?;
        loss.record_features(&mut rec, &loss.tpyr, &loss.gram_t, &loss.tpyr);
        rec.submit_and_wait()?;
        Ok(loss)
    }

    /// Replaces the targets (as [`Loss::new`] takes them) between evaluations: a live design
    /// steered by its user (a picture moved or scaled on the plate). Their pyramid and Gram
    /// matrices are computed again, exactly as `new` computes them, so a design steered live
    /// and one given the same changes from the command line see the same bits.
    pub fn set_targets(&self, ctx: &Arc<Context>, targets: &[Vec<f32>]) -> Result<(), GpuError> {
        assert_eq!(
            targets.len(),
            self.pyr.n_views as usize,
            "Loss::set_targets: one target per view"
        );
        let n = self.pyr.n_pixels() as usize;
        let mut t0 = vec![0f32; n];
        // Level 0 holds each view at its `base`, as in `new`.
        for seg in self.pyr.segs.iter().filter(|s| s.level == 0) {
            let t = &targets[seg.view as usize];
            assert_eq!(
                t.len(),
                (seg.w * seg.h) as usize,
                "Loss::set_targets: target {} size",
                seg.view
            );
            t0[seg.off as usize..seg.off as usize + t.len()].copy_from_slice(t);
        }
        let staging = ctx.upload("loss new targets", &t0)?;
        let mut rec = Recorder::new(ctx)?;
        rec.begin()?;
        rec.copy(&staging, &self.tpyr, (n * 4) as u64);
        rec.barrier();
        self.record_features(&mut rec, &self.tpyr, &self.gram_t, &self.tpyr);
        rec.submit_and_wait()?;
        Ok(())
    }

    /// Each view's weight in the loss (both terms, every level), 1 where never set.
    pub fn view_weights(&self) -> Vec<f32> {
        let w = self.view_w.lock().unwrap();
        w.clone()
    }

    /// Sets each view's weight in both terms from the next evaluation on (`design --balance`):
    /// the loss becomes sum_v weight_v (pixel_v + Gram_v). Weights of 1 give the loss bit for
    /// bit as before.
    pub fn set_view_weights(&self, ctx: &Arc<Context>, weights: &[f32]) -> Result<(), GpuError> {
        assert_eq!(
            weights.len(),
            self.pyr.n_views as usize,
            "Loss::set_view_weights: one weight per view"
        );
        let segs: Vec<LossSeg> = self
            .pyr
            .segs
            .iter()
            .map(|s| LossSeg {
                weight: weights[s.view as usize],
                ..*s
            })
            .collect();
        let staging = ctx.upload("loss view weights", &segs)?;
        let mut rec = Recorder::new(ctx)?;
        rec.begin()?;
        rec.copy(&staging, &self.segs, std::mem::size_of_val(segs.as_slice()) as u64);
        rec.barrier();
        rec.submit_and_wait()?;
        *self.view_w.lock().unwrap() = weights.to_vec();
        Ok(())
    }

    /// The weights (lambda_p, lambda_g) the next evaluation uses.
    pub fn weights(&self) -> (f32, f32) {
        use std::sync::atomic::Ordering;
        (
            f32::from_bits(self.weights[0].load(Ordering::Relaxed)),
            f32::from_bits(self.weights[1].load(Ordering::Relaxed)),
        )
    }

    /// Changes the weights of the pixel and Gram terms from the next evaluation on (a steered
    /// design; `cfg` keeps the ones it started with).
    pub fn set_weights(&self, lambda_p: f32, lambda_g: f32) {
        use std::sync::atomic::Ordering;
        self.weights[0].store(lambda_p.to_bits(), Ordering::Relaxed);
        self.weights[1].store(lambda_g.to_bits(), Ordering::Relaxed);
    }

    fn push(&self, level: u32, begin: u32, end: u32) -> LossPush {
        let (g_c, g_s) = self.cfg.gauss_1d();
        LossPush {
            n_views: self.pyr.n_views,
            n_levels: self.pyr.levels.len() as u32,
            level,
            n_blocks: self.pyr.n_blocks,
            lvl_begin: begin,
            lvl_end: end,
            lambda_p: self.weights().0,
            lambda_g: self.weights().1,
            g_c,
            g_s,
            n_segs: self.pyr.segs.len() as u32,
            pad: 0,
        }
    }

    /// Binding order of every loss kernel (see `shaders/inc/loss_bindings.glsl`).
    fn bufs<'a>(&'a self, img: &'a Buffer, pyr: &'a Buffer, gram: &'a Buffer, dl: &'a Buffer) -> [&'a Buffer; 13] {
        [
            &self.segs,
            &self.blocks,
            img,
            pyr,
            &self.tpyr,
            &self.pre,
            &self.bbuf,
            &self.part,
            gram,
            &self.gram_t,
            &self.out,
            &self.gx,
            dl,
        ]
    }

    fn dispatch(&self, rec: &mut Recorder, p: &ComputePipeline, b: &[&Buffer], push: LossPush, threads: u32) {
        rec.dispatch_1d(p, b, bytemuck::bytes_of(&push), threads.div_ceil(256));
        rec.barrier();
    }

    /// Pooling, features and Gram matrices of the pyramid in `pyr` (level 0 already written).
    fn record_features(&self, rec: &mut Recorder, pyr: &Buffer, gram: &Buffer, img: &Buffer) {
        let b = self.bufs(img, pyr, gram, img);
        let n = self.pyr.n_pixels();
        for (level, &(begin, end)) in self.pyr.levels.iter().enumerate().skip(1) {
            self.dispatch(
                rec,
                &self.pipes.pool,
                &b,
                self.push(level as u32, begin, end),
                end - begin,
            );
        }
        self.dispatch(rec, &self.pipes.feat, &b, self.push(0, 0, n), n);
        let push = self.push(0, 0, n);
        rec.dispatch_1d(&self.pipes.partial, &b, bytemuck::bytes_of(&push), self.pyr.n_blocks);
        rec.barrier();
        let n_gram = self.pyr.segs.len() as u32 * NPART as u32;
        self.dispatch(rec, &self.pipes.gram, &b, push, n_gram);
    }

    /// Records the loss of the linear image `image` (the renderer's layout) into [`Loss::out`].
    pub fn record_forward(&self, rec: &mut Recorder, image: &Buffer) {
        let n0 = self.pyr.levels[0].1;
        let b = self.bufs(image, &self.disp, &self.gram, image);
        self.dispatch(rec, &self.pipes.display, &b, self.push(0, 0, n0), n0);
        self.record_features(rec, &self.disp, &self.gram, image);
        rec.dispatch(
            &self.pipes.final_,
            &b,
            bytemuck::bytes_of(&self.push(0, 0, 0)),
            [1, 1, 1],
        );
        rec.barrier();
    }

    /// Records dE/dL of the loss just recorded by [`record_forward`](Self::record_forward) into
    /// `dl` (f32 per pixel, the image's layout). The derivative of L^(1/2.2) is taken at
    /// max(L, 1e-4).
    pub fn record_backward(&self, rec: &mut Recorder, image: &Buffer, dl: &Buffer) {
        let n = self.pyr.n_pixels();
        let b = self.bufs(image, &self.disp, &self.gram, dl);
        self.dispatch(rec, &self.pipes.pre_grad, &b, self.push(0, 0, n), n);
        for (level, &(begin, end)) in self.pyr.levels.iter().enumerate().rev() {
            self.dispatch(
                rec,
                &self.pipes.level_grad,
                &b,
                self.push(level as u32, begin, end),
                end - begin,
            );
        }
    }

    /// Reads the values of the last recorded forward (after `submit_and_wait`).
    pub fn read(&self) -> Result<LossValues, GpuError> {
        let o: Vec<f32> = self.out.read()?;
        let nv = self.pyr.n_views as usize;
        Ok(LossValues {
            pixel: (0..nv).map(|v| o[2 * v]).collect(),
            gram: (0..nv).map(|v| o[2 * v + 1]).collect(),
            total: o[2 * nv],
        })
    }

    /// Evaluates the loss of `image` in a submission of its own (optionally with dE/dL into `dl`).
    pub fn evaluate(&self, ctx: &Arc<Context>, image: &Buffer, dl: Option<&Buffer>) -> Result<LossValues, GpuError> {
        let mut rec = Recorder::new(ctx)?;
        rec.begin()?;
        self.record_forward(&mut rec, image);
        if let Some(dl) = dl {
            self.record_backward(&mut rec, image, dl);
        }
        rec.submit_and_wait()?;
        self.read()
    }
}

/// Float64 CPU twin of the loss kernels (test oracle, never a fallback).
pub mod reference;

/// The design loss as the optimizer's objective: terms are, per view, the pixel and the Gram term.
impl crate::driver::Objective for Loss {
    fn record_forward(&self, rec: &mut Recorder, gs: &crate::render::GpuScene) {
        self.record_forward(rec, gs.image());
    }

    fn record_backward(&self, rec: &mut Recorder, gs: &crate::render::GpuScene) {
        self.record_backward(rec, gs.image(), gs.dl());
    }

    fn total_on_device(&self) -> (&Buffer, u32) {
        (&self.out, 2 * self.pyr.n_views)
    }

    fn read(&self) -> Result<crate::driver::Evaluation, GpuError> {
        let o: Vec<f32> = self.out.read()?;
        let nv = self.pyr.n_views as usize;
        Ok(crate::driver::Evaluation {
            terms: o[..2 * nv].to_vec(),
            total: o[2 * nv],
        })
    }
}

impl From<&crate::driver::Evaluation> for LossValues {
    /// The design loss's terms, split per view (see [`Loss`]'s objective).
    fn from(e: &crate::driver::Evaluation) -> LossValues {
        LossValues {
            pixel: e.terms.iter().step_by(2).copied().collect(),
            gram: e.terms.iter().skip(1).step_by(2).copied().collect(),
            total: e.total,
        }
    }
}
