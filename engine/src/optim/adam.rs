//! Adam on the GPU (`shaders/adam.comp`): the moment buffers, the parameter bounds, and the
//! copies of the optimizer state used for rollback and checkpoints.
//!
//! State = scratches buffer (the parameters themselves), first and second moments (8 floats per
//! scratch, then one per light), the views buffer (light intensities Phi in `right[3]`), and the
//! host-side step count. Lights are optimized as u = ln Phi, so they stay positive.
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use crate::vulkan::{Buffer, ComputePipeline, Context, GpuError, MemLoc, Recorder, ShaderCompiler};

/// Learning rates (per step, in the parameter's own units) and bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamConfig {
    /// Endpoints, mm.
    pub lr_end: f32,
    /// Width parameter w, mm.
    pub lr_w: f32,
    /// Depth d, mm.
    pub lr_d: f32,
    /// Roughness alpha.
    pub lr_alpha: f32,
    /// ln Phi of each light (0 keeps lights fixed).
    pub lr_light: f32,
    pub beta1: f32,
    pub beta2: f32,
    pub eps: f32,
    pub w_bounds: (f32, f32),
    pub d_bounds: (f32, f32),
    pub alpha_bounds: (f32, f32),
    /// Shortest allowed scratch, mm.
    pub min_len: f32,
    /// Smallest light intensity.
    pub phi_min: f32,
}

impl AdamConfig {
    /// Defaults for a plate of `plate_mm`: endpoints move up to ~1.5e-3 of the plate per step
    /// (the paper's 1e-3 in normalized units, a little faster for the short default runs).
    pub fn for_plate(plate_mm: f64) -> AdamConfig {
        AdamConfig {
            lr_end: (1.5e-3 * plate_mm) as f32,
            lr_w: 2e-3,
            lr_d: 2e-3,
            lr_alpha: 3e-3,
            lr_light: 0.02,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-12,
            w_bounds: (0.01, 0.2),
            d_bounds: (0.005, 0.2),
            alpha_bounds: (0.005, 0.5),
            min_len: (5e-4 * plate_mm) as f32,
            phi_min: 1e-6,
        }
    }
}

/// `#[repr(C)]` twin of the push block of `shaders/adam.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct AdamPush {
    pub n_scratches: u32,
    pub n_views: u32,
    pub capacity: u32,
    pub opt_light: u32,
    pub lr_end: f32,
    pub lr_w: f32,
    pub lr_d: f32,
    pub lr_alpha: f32,
    pub lr_light: f32,
    pub beta1: f32,
    pub beta2: f32,
    pub eps: f32,
    pub bc1: f32,
    pub bc2: f32,
    pub half_plate: f32,
    pub min_len: f32,
    pub w_lo: f32,
    pub w_hi: f32,
    pub d_lo: f32,
    pub d_hi: f32,
    pub a_lo: f32,
    pub a_hi: f32,
    pub phi_min: f32,
    pub loss_limit: f32,
}

/// Flags set by the CHECK pass; any set flag makes APPLY a no-op.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepFlags {
    pub nonfinite_grad: bool,
    /// The loss was NaN/inf or above the limit (10x the best so far).
    pub bad_loss: bool,
    /// The tile list overflowed: the render (and so the gradient) was incomplete.
    pub overflow: bool,
}

impl StepFlags {
    pub fn any(&self) -> bool {
        self.nonfinite_grad || self.bad_loss || self.overflow
    }
}

/// The GPU-resident optimizer state other than the parameters' own buffers.
pub struct Moments {
    pub m: Buffer,
    pub v: Buffer,
}

impl Moments {
    pub fn new(ctx: &Arc<Context>, name: &str, n_scratches: u32, n_views: u32) -> Result<Moments, GpuError> {
        let bytes = (8 * n_scratches as u64 + n_views as u64) * 4;
        Ok(Moments {
            m: Buffer::new(ctx, &format!("{name} adam m"), bytes, MemLoc::GpuOnly)?,
            v: Buffer::new(ctx, &format!("{name} adam v"), bytes, MemLoc::GpuOnly)?,
        })
    }

    pub fn len_floats(n_scratches: u32, n_views: u32) -> usize {
        8 * n_scratches as usize + n_views as usize
    }
}

/// The two Adam passes and the flag buffer.
pub struct Adam {
    check: ComputePipeline,
    apply: ComputePipeline,
    pub flags: Buffer,
}

/// What one step needs besides the push constants.
pub struct StepBuffers<'a> {
    pub scratches: &'a Buffer,
    pub grad: &'a Buffer,
    pub moments: &'a Moments,
    pub views: &'a Buffer,
    pub grad_light: &'a Buffer,
    /// the loss values (`Loss::out`): the total is at index 2 n_views
    pub loss: &'a Buffer,
    /// the renderer's stats ([2] = tile-list entries)
    pub stats: &'a Buffer,
}

impl Adam {
    pub fn new(ctx: &Arc<Context>) -> Result<Adam, GpuError> {
        let sc = ShaderCompiler::embedded()?;
        let push = std::mem::size_of::<AdamPush>() as u32;
        Ok(Adam {
            check: ComputePipeline::new(ctx, &sc, "adam.comp", &[("CHECK", "1")], 9, push)?,
            apply: ComputePipeline::new(ctx, &sc, "adam.comp", &[("APPLY", "1")], 9, push)?,
            flags: Buffer::new(ctx, "adam flags", 16, MemLoc::GpuToCpu)?,
        })
    }

    /// Push constants of step `t` (1-based) with learning rates scaled by `lr_scale`.
    #[allow(clippy::too_many_arguments)]
    pub fn push(
        cfg: &AdamConfig,
        n_scratches: u32,
        n_views: u32,
        capacity: u32,
        half_plate: f32,
        t: u32,
        lr_scale: f64,
        loss_limit: f32,
    ) -> AdamPush {
        let s = |lr: f32| (lr as f64 * lr_scale) as f32;
        AdamPush {
            n_scratches,
            n_views,
            capacity,
            opt_light: (cfg.lr_light > 0.0) as u32,
            lr_end: s(cfg.lr_end),
            lr_w: s(cfg.lr_w),
            lr_d: s(cfg.lr_d),
            lr_alpha: s(cfg.lr_alpha),
            lr_light: s(cfg.lr_light),
            beta1: cfg.beta1,
            beta2: cfg.beta2,
            eps: cfg.eps,
            bc1: (1.0 - (cfg.beta1 as f64).powi(t as i32)) as f32,
            bc2: (1.0 - (cfg.beta2 as f64).powi(t as i32)) as f32,
            half_plate,
            min_len: cfg.min_len,
            w_lo: cfg.w_bounds.0,
            w_hi: cfg.w_bounds.1,
            d_lo: cfg.d_bounds.0,
            d_hi: cfg.d_bounds.1,
            a_lo: cfg.alpha_bounds.0,
            a_hi: cfg.alpha_bounds.1,
            phi_min: cfg.phi_min,
            loss_limit,
        }
    }

    /// Records the flag reset, CHECK and APPLY. The flags are readable after submission.
    pub fn record(&self, rec: &mut Recorder, b: &StepBuffers, push: &AdamPush) {
        rec.fill(&self.flags, 0);
        rec.barrier();
        let bufs = [
            b.scratches,
            b.grad,
            &b.moments.m,
            &b.moments.v,
            b.views,
            b.grad_light,
            b.loss,
            b.stats,
            &self.flags,
        ];
        let n = push.n_scratches + push.n_views;
        let groups = n.div_ceil(256);
        rec.dispatch_1d(&self.check, &bufs, bytemuck::bytes_of(push), groups);
        rec.barrier();
        rec.dispatch_1d(&self.apply, &bufs, bytemuck::bytes_of(push), groups);
        rec.barrier();
    }

    pub fn read_flags(&self) -> Result<StepFlags, GpuError> {
        let f: Vec<u32> = self.flags.read()?;
        Ok(StepFlags {
            nonfinite_grad: f[0] != 0,
            bad_loss: f[1] != 0,
            overflow: f[2] != 0,
        })
    }
}

/// CPU twin of one APPLY step on one scratch (test oracle): `p` = [x0, y0, x1, y1, w, d, alpha],
/// `g` its gradient, `m`, `v` its moments (updated in place). f32 arithmetic in the kernel's order.
pub fn reference_step(p: &mut [f32; 7], g: &[f32; 7], m: &mut [f32; 7], v: &mut [f32; 7], push: &AdamPush) {
    let lrs = [
        push.lr_end,
        push.lr_end,
        push.lr_end,
        push.lr_end,
        push.lr_w,
        push.lr_d,
        push.lr_alpha,
    ];
    let q = *p;
    let mut x = *p;
    for k in 0..7 {
        m[k] = push.beta1 * m[k] + (1.0 - push.beta1) * g[k];
        v[k] = push.beta2 * v[k] + (1.0 - push.beta2) * g[k] * g[k];
        x[k] = p[k] - lrs[k] * (m[k] / push.bc1) / ((v[k] / push.bc2).sqrt() + push.eps);
    }
    let h = push.half_plate;
    for c in x.iter_mut().take(4) {
        *c = c.clamp(-h, h);
    }
    let (dx, dy) = (x[2] - x[0], x[3] - x[1]);
    let len = (dx * dx + dy * dy).sqrt();
    if !(len >= push.min_len) {
        let (ux, uy) = if len > 0.0 {
            (dx / len, dy / len)
        } else {
            let (a, b) = (q[2] - q[0], q[3] - q[1]);
            let l = (a * a + b * b).sqrt();
            (a / l, b / l)
        };
        let (hx, hy) = (0.5 * push.min_len * ux, 0.5 * push.min_len * uy);
        let (lx, ly) = (h - hx.abs(), h - hy.abs());
        let mx = (0.5 * (x[0] + x[2])).clamp(-lx, lx);
        let my = (0.5 * (x[1] + x[3])).clamp(-ly, ly);
        x[0] = mx - hx;
        x[1] = my - hy;
        x[2] = mx + hx;
        x[3] = my + hy;
    }
    x[4] = x[4].clamp(push.w_lo, push.w_hi);
    x[5] = x[5].clamp(push.d_lo, push.d_hi);
    x[6] = x[6].clamp(push.a_lo, push.a_hi);
    *p = x;
}
