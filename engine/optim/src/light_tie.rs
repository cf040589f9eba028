//! Views that share a lamp share its intensity: a [`ParamSet`] wrapper that ties the lights of
//! each lamp (`design --exposure fixed`). After the inner set's chain rule it records
//! `shaders/light_tie.comp`, which gives every view of a lamp the lamp's log-space gradient; Adam
//! then moves them by one factor, so each view's exposure (its light relative to the lamp's)
//! stays where it started.
use std::sync::Arc;

use super::adam::ParamBlock;
use super::driver::ParamSet;
use crate::render::GpuScene;
use crate::vulkan::{Buffer, ComputePipeline, Context, GpuError, MemLoc, Recorder, ShaderCompiler};

pub struct TiedLights {
    inner: Box<dyn ParamSet>,
    pipe: ComputePipeline,
    groups: Buffer,
    n_lamps: u32,
}

impl TiedLights {
    /// `lamps[i]`: the views lamp i lights (disjoint, every index below the view count).
    pub fn new(ctx: &Arc<Context>, inner: Box<dyn ParamSet>, lamps: &[Vec<usize>]) -> Result<TiedLights, GpuError> {
        let mut words: Vec<u32> = Vec::new();
        let mut at = 0u32;
        words.push(0);
        for l in lamps {
            at += l.len() as u32;
            words.push(at);
        }
        words.extend(lamps.iter().flatten().map(|&v| v as u32));
        let bytes: &[u8] = bytemuck::cast_slice(&words);
        let groups = Buffer::new(ctx, "lamp groups", bytes.len() as u64, MemLoc::CpuToGpu)?;
        groups.write(0, bytes)?;
        Ok(TiedLights {
            inner,
            pipe: ComputePipeline::new(ctx, &ShaderCompiler::embedded()?, "light_tie.comp", &[], 3, 4)?,
            groups,
            n_lamps: lamps.len() as u32,
        })
    }
}

impl ParamSet for TiedLights {
    fn blocks<'a>(&'a self, gs: &'a GpuScene) -> Vec<ParamBlock<'a>> {
        self.inner.blocks(gs)
    }

    fn begin_iteration(&self, k: u32, step: bool) {
        self.inner.begin_iteration(k, step)
    }

    fn moves_arcs(&self) -> bool {
        self.inner.moves_arcs()
    }

    fn record_to_scene(&self, rec: &mut Recorder, gs: &GpuScene) {
        self.inner.record_to_scene(rec, gs)
    }

    fn record_grad(&self, rec: &mut Recorder, gs: &GpuScene) {
        self.inner.record_grad(rec, gs);
        rec.dispatch_1d(
            &self.pipe,
            &[gs.lights(), gs.light_grad(), &self.groups],
            bytemuck::bytes_of(&self.n_lamps),
            self.n_lamps.div_ceil(64),
        );
        rec.barrier();
    }

    fn record_project(&self, rec: &mut Recorder, gs: &GpuScene, before: &[&Buffer], flags: &Buffer) {
        self.inner.record_project(rec, gs, before, flags)
    }
}
