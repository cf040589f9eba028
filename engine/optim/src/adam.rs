//! Adam on the GPU (`shaders/adam.comp`) over flat parameter buffers with learning-rate groups.
//!
//! A parameter set (see [`super::driver::ParamSet`]) hands the optimizer one or more
//! [`ParamBlock`]s: a buffer of f32 parameters, the buffer of their gradients, and a group per
//! element (element i is in group `i % stride`). A group has a learning rate, box bounds, a space
//! (linear, or logarithmic for quantities that must stay positive) and may be frozen. Adam knows
//! nothing else about what the numbers mean: a scratch's minimum length, for instance, is the
//! scratch parameter set's own projection pass.
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use crate::vulkan::{Buffer, ComputePipeline, Context, GpuError, MemLoc, Recorder, ShaderCompiler};

/// Learning rates (per step, in the parameter's own units) and bounds of the design's
/// parameters (scratches and lights); see [`super::scene_params::SceneParams`].
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

    /// The moment decay rates and epsilon (what [`Adam`] needs besides the groups).
    pub fn hyper(&self) -> AdamHyper {
        AdamHyper {
            beta1: self.beta1,
            beta2: self.beta2,
            eps: self.eps,
        }
    }
}

/// Adam's moment decay rates and epsilon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamHyper {
    pub beta1: f32,
    pub beta2: f32,
    pub eps: f32,
}

/// How a group's parameters move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Space {
    /// x -= step, then clamped to [lo, hi].
    Linear,
    /// x = exp(u): u -= step with gradient x dE/dx, so x stays positive; then x >= lo.
    Log,
}

/// One learning-rate group.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamGroup {
    pub lr: f32,
    pub lo: f32,
    pub hi: f32,
    pub space: Space,
    /// Neither checked nor moved (padding, or a parameter held fixed).
    pub frozen: bool,
}

impl AdamGroup {
    pub fn linear(lr: f32, (lo, hi): (f32, f32)) -> AdamGroup {
        AdamGroup {
            lr,
            lo,
            hi,
            space: Space::Linear,
            frozen: false,
        }
    }

    pub fn log(lr: f32, lo: f32) -> AdamGroup {
        AdamGroup {
            lr,
            lo,
            hi: f32::INFINITY,
            space: Space::Log,
            frozen: false,
        }
    }

    pub fn frozen() -> AdamGroup {
        AdamGroup {
            lr: 0.0,
            lo: 0.0,
            hi: 0.0,
            space: Space::Linear,
            frozen: true,
        }
    }

    /// The GPU record with the learning rate scaled by `lr_scale` (the rollback factor).
    fn gpu(&self, lr_scale: f64) -> AdamGroupGpu {
        AdamGroupGpu {
            lr_lo_hi: [(self.lr as f64 * lr_scale) as f32, self.lo, self.hi, 0.0],
            mode_frozen: [(self.space == Space::Log) as u32, self.frozen as u32, 0, 0],
        }
    }
}

/// `#[repr(C)]` twin of `AdamGroupGPU` in `shaders/inc/adam_push.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct AdamGroupGpu {
    /// learning rate (scaled), lower bound, upper bound, 0
    pub lr_lo_hi: [f32; 4],
    /// 1 = logarithmic space, 1 = frozen, 0, 0
    pub mode_frozen: [u32; 4],
}

/// `#[repr(C)]` twin of the push block in `shaders/inc/adam_push.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct AdamPush {
    pub n: u32,
    pub stride: u32,
    pub check_objective: u32,
    pub objective_index: u32,
    pub capacity: u32,
    pub beta1: f32,
    pub beta2: f32,
    pub eps: f32,
    pub bc1: f32,
    pub bc2: f32,
    pub loss_limit: f32,
    pub pad0: u32,
}

/// A flat block of parameters as a parameter set hands it to the optimizer.
pub struct ParamBlock<'a> {
    /// Names the block in checkpoints and buffer names ("scratches", "lights", ...).
    pub name: &'static str,
    /// The parameters, `len` f32 (the buffer may be longer).
    pub params: &'a Buffer,
    /// dE/d(parameter), laid out like `params`.
    pub grad: &'a Buffer,
    pub len: u32,
    /// Element i is in `groups[i % groups.len()]`.
    pub groups: Vec<AdamGroup>,
}

/// Flags set by the CHECK pass; any set flag makes APPLY (and projections) a no-op.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepFlags {
    pub nonfinite_grad: bool,
    /// The objective was NaN/inf or above the limit (10x the best so far).
    pub bad_loss: bool,
    /// The tile list overflowed: the render (and so the gradient) was incomplete.
    pub overflow: bool,
}

impl StepFlags {
    pub fn any(&self) -> bool {
        self.nonfinite_grad || self.bad_loss || self.overflow
    }
}

/// What one step checks besides the gradients: the objective's total on the device and the
/// render's counters.
pub struct StepCheck<'a> {
    /// The objective's values; the total is at `index`.
    pub objective: &'a Buffer,
    pub index: u32,
    /// The renderer's counters ([2] = tile-list entries) and the tile-list capacity.
    pub stats: &'a Buffer,
    pub capacity: u32,
    /// A total above this is an exploding step.
    pub limit: f32,
}

/// Adam's moments of one block.
pub struct Moments {
    pub m: Buffer,
    pub v: Buffer,
}

impl Moments {
    /// Zero moments for `len` parameters.
    pub fn zeros(ctx: &Arc<Context>, name: &str, len: u32) -> Result<Moments, GpuError> {
        let zeros = vec![0f32; len.max(1) as usize];
        Ok(Moments {
            m: ctx.upload(&format!("{name} adam m"), &zeros)?,
            v: ctx.upload(&format!("{name} adam v"), &zeros)?,
        })
    }
}

/// The two Adam passes and the flag buffer.
pub struct Adam {
    check: ComputePipeline,
    apply: ComputePipeline,
    pub flags: Buffer,
}

impl Adam {
    pub fn new(ctx: &Arc<Context>) -> Result<Adam, GpuError> {
        let sc = ShaderCompiler::embedded()?;
        let push = std::mem::size_of::<AdamPush>() as u32;
        Ok(Adam {
            check: ComputePipeline::new(ctx, &sc, "adam.comp", &[("CHECK", "1")], 8, push)?,
            apply: ComputePipeline::new(ctx, &sc, "adam.comp", &[("APPLY", "1")], 8, push)?,
            flags: Buffer::new(ctx, "adam flags", 16, MemLoc::GpuToCpu)?,
        })
    }

    /// A host-visible buffer for the group records of `block` (written by [`record`](Self::record)).
    pub fn group_buffer(ctx: &Arc<Context>, block: &ParamBlock) -> Result<Buffer, GpuError> {
        let bytes = (block.groups.len().max(1) * std::mem::size_of::<AdamGroupGpu>()) as u64;
        Buffer::new(ctx, &format!("{} adam groups", block.name), bytes, MemLoc::CpuToGpu)
    }

    /// Records step `t` (1-based) over `blocks` with learning rates scaled by `lr_scale`: the flag
    /// reset, CHECK of every block (the first also checks `check`), then APPLY of every block.
    /// `moments[i]` and `groups[i]` belong to `blocks[i]`. The flags are readable after submission.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        rec: &mut Recorder,
        blocks: &[ParamBlock],
        moments: &[&Moments],
        groups: &[&Buffer],
        hyper: &AdamHyper,
        t: u32,
        lr_scale: f64,
        check: &StepCheck,
    ) -> Result<(), GpuError> {
        assert!(blocks.len() == moments.len() && blocks.len() == groups.len());
        assert!(!blocks.is_empty(), "Adam needs at least one parameter block");
        let mut pushes = Vec::with_capacity(blocks.len());
        for (i, (b, gbuf)) in blocks.iter().zip(groups).enumerate() {
            let recs: Vec<AdamGroupGpu> = b.groups.iter().map(|g| g.gpu(lr_scale)).collect();
            // Written before submission; the previous step's submission has completed.
            gbuf.write(0, &recs)?;
            pushes.push(AdamPush {
                n: b.len,
                stride: b.groups.len() as u32,
                check_objective: (i == 0) as u32,
                objective_index: check.index,
                capacity: check.capacity,
                beta1: hyper.beta1,
                beta2: hyper.beta2,
                eps: hyper.eps,
                bc1: (1.0 - (hyper.beta1 as f64).powi(t as i32)) as f32,
                bc2: (1.0 - (hyper.beta2 as f64).powi(t as i32)) as f32,
                loss_limit: check.limit,
                pad0: 0,
            });
        }
        rec.fill(&self.flags, 0);
        rec.barrier();
        for pass in [&self.check, &self.apply] {
            for (i, b) in blocks.iter().enumerate() {
                let bufs = [
                    b.params,
                    b.grad,
                    &moments[i].m,
                    &moments[i].v,
                    groups[i],
                    &self.flags,
                    check.objective,
                    check.stats,
                ];
                rec.dispatch_1d(pass, &bufs, bytemuck::bytes_of(&pushes[i]), b.len.max(1).div_ceil(256));
            }
            rec.barrier();
        }
        Ok(())
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
