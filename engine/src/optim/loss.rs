//! The design loss on the GPU (MODEL.md section 7): values per view and dE/dL per pixel.
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

/// `#[repr(C)]` twin of `LossSeg` in `shaders/inc/loss_bindings.glsl`.
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
    pub pad: u32,
}

/// `#[repr(C)]` twin of the push block in `shaders/inc/loss_bindings.glsl`.
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
                    pad: 0,
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

    fn push(&self, level: u32, begin: u32, end: u32) -> LossPush {
        let (g_c, g_s) = self.cfg.gauss_1d();
        LossPush {
            n_views: self.pyr.n_views,
            n_levels: self.pyr.levels.len() as u32,
            level,
            n_blocks: self.pyr.n_blocks,
            lvl_begin: begin,
            lvl_end: end,
            lambda_p: self.cfg.lambda_p,
            lambda_g: self.cfg.lambda_g,
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
pub mod reference {
    use super::{LossConfig, Pyramid};

    const SMOOTH: [f64; 3] = [0.25, 0.5, 0.25];
    const DERIV: [f64; 3] = [-0.5, 0.0, 0.5];

    /// Tap (ox, oy) of linear filter k (as `bank_w` in `shaders/inc/loss_bank.glsl`).
    pub fn bank_w(k: usize, ox: i32, oy: i32) -> f64 {
        let (x, y) = ((ox + 1) as usize, (oy + 1) as usize);
        match k {
            0 => SMOOTH[x] * SMOOTH[y],
            1 => DERIV[x] * SMOOTH[y],
            2 => SMOOTH[x] * DERIV[y],
            _ => {
                let a = if k == 3 { ox - oy } else { ox + oy };
                if a == 0 {
                    0.0
                } else {
                    a.signum() as f64 * if a.abs() == 2 { 2.0 } else { 1.0 } / 8.0
                }
            }
        }
    }

    fn cl(x: i64, n: u32) -> usize {
        x.clamp(0, n as i64 - 1) as usize
    }

    fn display(l: f64) -> f64 {
        if l > 0.0 {
            l.powf(1.0 / 2.2)
        } else {
            0.0
        }
    }

    /// Pyramid levels (each W x H, top row first) of one image.
    fn levels(img: &[f64], w: u32, h: u32, n: u32) -> Vec<(u32, u32, Vec<f64>)> {
        let mut out = vec![(w, h, img.to_vec())];
        for _ in 1..n.max(1) {
            let (pw, ph, prev) = out.last().unwrap();
            let (w2, h2) = ((pw / 2).max(1), (ph / 2).max(1));
            let mut next = vec![0.0; (w2 * h2) as usize];
            for y in 0..h2 {
                for x in 0..w2 {
                    let mut acc = 0.0;
                    for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        acc += prev[cl((2 * y + b) as i64, *ph) * *pw as usize + cl((2 * x + a) as i64, *pw)];
                    }
                    next[(y * w2 + x) as usize] = 0.25 * acc;
                }
            }
            out.push((w2, h2, next));
        }
        out
    }

    /// The 9 channels of every pixel of one level.
    fn features(w: u32, h: u32, x: &[f64]) -> (Vec<[f64; 5]>, Vec<[f64; 9]>) {
        let mut pre = vec![[0.0; 5]; (w * h) as usize];
        let mut ch = vec![[0.0; 9]; (w * h) as usize];
        for py in 0..h as i64 {
            for px in 0..w as i64 {
                let mut r = [0.0; 5];
                for oy in -1..=1 {
                    for ox in -1..=1 {
                        let v = x[cl(py + oy as i64, h) * w as usize + cl(px + ox as i64, w)];
                        for (k, rk) in r.iter_mut().enumerate() {
                            *rk += bank_w(k, ox, oy) * v;
                        }
                    }
                }
                let i = (py * w as i64 + px) as usize;
                pre[i] = r;
                ch[i][0] = r[0];
                for k in 1..5 {
                    ch[i][2 * k - 1] = r[k].max(0.0);
                    ch[i][2 * k] = (-r[k]).max(0.0);
                }
            }
        }
        (pre, ch)
    }

    fn gram(ch: &[[f64; 9]]) -> [[f64; 9]; 9] {
        let mut g = [[0.0; 9]; 9];
        for c in ch {
            for i in 0..9 {
                for j in 0..9 {
                    g[i][j] += c[i] * c[j];
                }
            }
        }
        let n = ch.len() as f64;
        g.iter_mut().flatten().for_each(|v| *v /= n);
        g
    }

    /// Loss of one view and dE/dL of its pixels: (pixel term, Gram term, gradient).
    /// `l`: linear render, `t`: target display values, both W x H top row first.
    pub fn view_loss(l: &[f64], t: &[f64], w: u32, h: u32, cfg: &LossConfig) -> (f64, f64, Vec<f64>) {
        let (gc, gs) = {
            let s = (-0.5 / (cfg.sigma as f64).powi(2)).exp();
            (1.0 / (1.0 + 2.0 * s), s / (1.0 + 2.0 * s))
        };
        let g1 = [gs, gc, gs];
        let n = (w * h) as usize;
        let img: Vec<f64> = l.iter().map(|&v| display(v)).collect();
        // Pixel term.
        let mut bimg = vec![0.0; n];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let mut acc = 0.0;
                for oy in -1..=1i64 {
                    for ox in -1..=1i64 {
                        let c = cl(y + oy, h) * w as usize + cl(x + ox, w);
                        acc += g1[(ox + 1) as usize] * g1[(oy + 1) as usize] * (img[c] - t[c]);
                    }
                }
                bimg[(y * w as i64 + x) as usize] = acc;
            }
        }
        let lp = cfg.lambda_p as f64 * bimg.iter().map(|b| b * b).sum::<f64>() / n as f64;
        let mut d_img = vec![0.0; n];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let gp = 2.0 * cfg.lambda_p as f64 / n as f64 * bimg[(y * w as i64 + x) as usize];
                for oy in -1..=1i64 {
                    for ox in -1..=1i64 {
                        let c = cl(y + oy, h) * w as usize + cl(x + ox, w);
                        d_img[c] += g1[(ox + 1) as usize] * g1[(oy + 1) as usize] * gp;
                    }
                }
            }
        }
        // Gram term: forward per level, then backward coarse to fine.
        let lv = levels(&img, w, h, cfg.levels);
        let lt = levels(t, w, h, cfg.levels);
        let mut lg = 0.0;
        let mut dpre_levels = Vec::new();
        for ((lw, lh, x), (_, _, tx)) in lv.iter().zip(&lt) {
            let (pre, ch) = features(*lw, *lh, x);
            let (_, cht) = features(*lw, *lh, tx);
            let (g, gt) = (gram(&ch), gram(&cht));
            let mut r = [[0.0; 9]; 9];
            for i in 0..9 {
                for j in 0..9 {
                    let d = g[i][j] - gt[i][j];
                    lg += d * d;
                    r[i][j] = 2.0 * cfg.lambda_g as f64 * d;
                }
            }
            let np = ch.len() as f64;
            let dpre: Vec<[f64; 5]> = pre
                .iter()
                .zip(&ch)
                .map(|(p, c)| {
                    let mut dc = [0.0; 9];
                    for a in 0..9 {
                        dc[a] = 2.0 / np * (0..9).map(|b| r[a][b] * c[b]).sum::<f64>();
                    }
                    let mut out = [0.0; 5];
                    out[0] = dc[0];
                    for k in 1..5 {
                        out[k] = if p[k] > 0.0 {
                            dc[2 * k - 1]
                        } else if p[k] < 0.0 {
                            -dc[2 * k]
                        } else {
                            0.0
                        };
                    }
                    out
                })
                .collect();
            dpre_levels.push(dpre);
        }
        let lg = cfg.lambda_g as f64 * lg;
        let mut d_up: Vec<f64> = Vec::new();
        for s in (0..lv.len()).rev() {
            let (lw, lh, _) = &lv[s];
            let (lw, lh) = (*lw, *lh);
            let mut dx = vec![0.0; (lw * lh) as usize];
            for py in 0..lh as i64 {
                for px in 0..lw as i64 {
                    let gp = dpre_levels[s][(py * lw as i64 + px) as usize];
                    for oy in -1..=1 {
                        for ox in -1..=1 {
                            let c = cl(py + oy as i64, lh) * lw as usize + cl(px + ox as i64, lw);
                            for (k, g) in gp.iter().enumerate() {
                                dx[c] += bank_w(k, ox, oy) * g;
                            }
                        }
                    }
                }
            }
            if s + 1 < lv.len() {
                let (uw, uh, _) = &lv[s + 1];
                for uy in 0..*uh {
                    for ux in 0..*uw {
                        let gu = d_up[(uy * uw + ux) as usize];
                        for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            dx[cl((2 * uy + b) as i64, lh) * lw as usize + cl((2 * ux + a) as i64, lw)] += 0.25 * gu;
                        }
                    }
                }
            }
            d_up = dx;
        }
        let dl: Vec<f64> = (0..n)
            .map(|i| {
                let slope = (1.0 / 2.2) * l[i].max(1e-4).powf(1.0 / 2.2 - 1.0);
                (d_img[i] + d_up[i]) * slope
            })
            .collect();
        (lp, lg, dl)
    }

    /// The loss of every view of a render laid out as `pyr` level 0 (the renderer's image).
    pub fn loss(image: &[f32], targets: &[Vec<f32>], pyr: &Pyramid, cfg: &LossConfig) -> (Vec<(f64, f64)>, Vec<f64>) {
        let mut per_view = Vec::new();
        let mut dl = vec![0.0; image.len()];
        for (v, t) in targets.iter().enumerate() {
            let s = &pyr.segs[v];
            let (o, n) = (s.off as usize, (s.w * s.h) as usize);
            let l: Vec<f64> = image[o..o + n].iter().map(|&x| x as f64).collect();
            let t: Vec<f64> = t.iter().map(|&x| x as f64).collect();
            let (lp, lg, d) = view_loss(&l, &t, s.w, s.h, cfg);
            dl[o..o + n].copy_from_slice(&d);
            per_view.push((lp, lg));
        }
        (per_view, dl)
    }
}

/// The design loss as the optimizer's objective: terms are, per view, the pixel and the Gram term.
impl super::driver::Objective for Loss {
    fn record_forward(&self, rec: &mut Recorder, gs: &crate::render::GpuScene) {
        self.record_forward(rec, gs.image());
    }

    fn record_backward(&self, rec: &mut Recorder, gs: &crate::render::GpuScene) {
        self.record_backward(rec, gs.image(), gs.dl());
    }

    fn total_on_device(&self) -> (&Buffer, u32) {
        (&self.out, 2 * self.pyr.n_views)
    }

    fn read(&self) -> Result<super::driver::Evaluation, GpuError> {
        let o: Vec<f32> = self.out.read()?;
        let nv = self.pyr.n_views as usize;
        Ok(super::driver::Evaluation {
            terms: o[..2 * nv].to_vec(),
            total: o[2 * nv],
        })
    }
}

impl From<&super::driver::Evaluation> for LossValues {
    /// The design loss's terms, split per view (see [`Loss`]'s objective).
    fn from(e: &super::driver::Evaluation) -> LossValues {
        LossValues {
            pixel: e.terms.iter().step_by(2).copied().collect(),
            gram: e.terms.iter().skip(1).step_by(2).copied().collect(),
            total: e.total,
        }
    }
}
