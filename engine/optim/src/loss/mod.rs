//! The design loss on the GPU (engine/docs/model.md section 7): values per view and dE/dL per pixel.
//!
//! E = lambda_p sum_v mean_p (g * (I_v - T_v))^2 + lambda_g sum_v sum_s ||Gram_s(phi(I_v)) - Gram_s(phi(T_v))||^2
//! with I = L^(1/2.2), g the normalized 3x3 Gaussian (clamp-to-edge borders), and phi the fixed
//! feature bank of `shaders/inc/loss_bank.glsl` (3 scales x 9 rectified oriented channels). The
//! kernels are `shaders/loss_fwd.comp` and `shaders/loss_bwd.comp`; [`reference`] is their f64 CPU
//! twin (a test oracle). Off-plate pixels (L = 0) count in the loss like any other pixel.
//! With the cross-talk term (`LossConfig::crosstalk` = kappa > 0, [`Loss::with_crosstalk`]),
//! view v's pixel term is lambda_p (mean B_v^2 + sum_k c_vk^2 / N_v), B_v = g * (I_v - T_v),
//! c_vk = sum_p B_v(p) u_vk(p), u_vk = mask_v (T_k - mean) scaled to norm sqrt(kappa).
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
    /// Weight kappa of the cross-talk term (0: none): the part of each view's blurred error
    /// along another view's picture (centred over this view's picture) counts 1 + kappa times
    /// in the pixel term ([`Loss::with_crosstalk`] names the views and their pictures).
    pub crosstalk: f32,
}

impl Default for LossConfig {
    fn default() -> Self {
        LossConfig {
            lambda_p: 1.0,
            lambda_g: 0.01,
            sigma: 1.0,
            levels: 3,
            crosstalk: 0.0,
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
    /// Cross-talk pairs (0: no cross-talk term).
    pub n_pairs: u32,
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
    xpart: ComputePipeline,
    xsum: ComputePipeline,
    xgrad: ComputePipeline,
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
    /// The cross-talk term (None: none; its buffers are then placeholders).
    cross: Option<std::sync::Mutex<Cross>>,
    n_pairs: u32,
    /// Its partial sums in all (one per pair and 256-pixel block of the pair's view).
    n_parts: u32,
    xmask: Buffer,
    xpairs: Buffer,
    xpart: Buffer,
    xc: Buffer,
}

const NUM_BUFFERS: u32 = 17;

impl Loss {
    /// Builds the pipelines and buffers for the views of an uploaded scene (their `dims` and
    /// `base`) and uploads the targets (display values in [0, 1], one image per view, W x H each,
    /// top row first), computing their pyramid and Gram matrices once.
    pub fn new(ctx: &Arc<Context>, views: &[ViewGpu], targets: &[Vec<f32>], cfg: LossConfig) -> Result<Loss, GpuError> {
        Self::with_crosstalk(ctx, views, targets, cfg, &[], &[])
    }

    /// [`Loss::new`] with the cross-talk term when `cfg.crosstalk` > 0: for every ordered pair
    /// (v, k) of `among` (views of the same size), the component of view v's blurred error
    /// g * (I_v - T_v) along view k's target, centred over view v's picture (`pictures[v]`) and
    /// scaled to norm sqrt(kappa), adds its square to view v's pixel term: the error that looks
    /// like another view's picture (what the quality report calls cross-talk) counts 1 + kappa
    /// times. `pictures` holds one mask per view (W x H) when `among` is not empty.
    pub fn with_crosstalk(
        ctx: &Arc<Context>,
        views: &[ViewGpu],
        targets: &[Vec<f32>],
        cfg: LossConfig,
        pictures: &[Vec<bool>],
        among: &[usize],
    ) -> Result<Loss, GpuError> {
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
            xpart: p("loss_fwd.comp", "XPART")?,
            xsum: p("loss_fwd.comp", "XSUM")?,
            xgrad: p("loss_bwd.comp", "XGRAD")?,
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
        let pairs: Vec<(usize, usize)> = if cfg.crosstalk > 0.0 {
            among
                .iter()
                .flat_map(|&v| among.iter().map(move |&k| (v, k)))
                .filter(|&(v, k)| v != k && views[v].dims[..2] == views[k].dims[..2])
                .collect()
        } else {
            Vec::new()
        };
        let cross = (!pairs.is_empty()).then(|| {
            assert_eq!(
                pictures.len(),
                views.len(),
                "Loss::with_crosstalk: one picture per view"
            );
            Cross {
                kappa: cfg.crosstalk,
                pairs: pairs.clone(),
                pictures: pictures.to_vec(),
                targets: targets.to_vec(),
            }
        });
        let n_parts: u32 = pairs.iter().map(|&(v, _)| pyr.segs[v].nblk).sum();
        let (xmask, xpairs) = match &cross {
            Some(c) => (
                ctx.upload("loss cross-talk masks", &c.mask(&pyr))?,
                ctx.upload("loss cross-talk pairs", &c.pair_data(&pyr))?,
            ),
            None => (
                Buffer::new(ctx, "loss cross-talk masks (none)", 16, MemLoc::GpuOnly)?,
                Buffer::new(ctx, "loss cross-talk pairs (none)", 32, MemLoc::GpuOnly)?,
            ),
        };
        let loss = Loss {
            n_pairs: pairs.len() as u32,
            n_parts,
            xmask,
            xpairs,
            xpart: Buffer::new(
                ctx,
                "loss cross-talk partial sums",
                n_parts.max(1) as u64 * 4,
                MemLoc::GpuOnly,
            )?,
            xc: Buffer::new(
                ctx,
                "loss cross-talk projections",
                pairs.len().max(1) as u64 * 4,
                MemLoc::GpuOnly,
            )?,
            cross: cross.map(std::sync::Mutex::new),
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
        let pairs = match &self.cross {
            Some(c) => {
                let mut c = c.lock().unwrap();
                c.targets = targets.to_vec();
                Some(ctx.upload("loss cross-talk pairs", &c.pair_data(&self.pyr))?)
            }
            None => None,
        };
        if let Some(p) = &pairs {
            rec.copy(p, &self.xpairs, p.size());
        }
        rec.barrier();
        self.record_features(&mut rec, &self.tpyr, &self.gram_t, &self.tpyr);
        rec.submit_and_wait()?;
        Ok(())
    }

    /// Moves the pictures the cross-talk term centres and masks over (a steered design: call
    /// before [`Loss::set_targets`] with the targets that go with them); nothing without the term.
    pub fn set_pictures(&self, ctx: &Arc<Context>, pictures: &[Vec<bool>]) -> Result<(), GpuError> {
        let Some(c) = &self.cross else { return Ok(()) };
        let mut c = c.lock().unwrap();
        assert_eq!(
            pictures.len(),
            c.pictures.len(),
            "Loss::set_pictures: one picture per view"
        );
        c.pictures = pictures.to_vec();
        let staging = ctx.upload("loss cross-talk masks", &c.mask(&self.pyr))?;
        let pairs = ctx.upload("loss cross-talk pairs", &c.pair_data(&self.pyr))?;
        let mut rec = Recorder::new(ctx)?;
        rec.begin()?;
        rec.copy(&staging, &self.xmask, staging.size());
        rec.copy(&pairs, &self.xpairs, pairs.size());
        rec.barrier();
        rec.submit_and_wait()?;
        Ok(())
    }

    /// The ordered pairs (v, k) of the cross-talk term (empty without it).
    pub fn crosstalk_pairs(&self) -> Vec<(usize, usize)> {
        self.cross
            .as_ref()
            .map_or(Vec::new(), |c| c.lock().unwrap().pairs.clone())
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
            n_pairs: self.n_pairs,
        }
    }

    /// Binding order of every loss kernel (see `shaders/inc/loss_bindings.glsl`).
    fn bufs<'a>(&'a self, img: &'a Buffer, pyr: &'a Buffer, gram: &'a Buffer, dl: &'a Buffer) -> [&'a Buffer; 17] {
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
            &self.xmask,
            &self.xpairs,
            &self.xpart,
            &self.xc,
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
        if self.n_pairs > 0 {
            self.dispatch(rec, &self.pipes.xpart, &b, self.push(0, 0, self.n_parts), self.n_parts);
            self.dispatch(rec, &self.pipes.xsum, &b, self.push(0, 0, 0), self.n_pairs);
        }
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
        if self.n_pairs > 0 {
            let n0 = self.pyr.levels[0].1;
            self.dispatch(rec, &self.pipes.xgrad, &b, self.push(0, 0, n0), n0);
        }
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

mod cross;
use cross::Cross;
pub use cross::XPair;

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
