//! The GPU forward renderer: tile binning (pair search), deterministic scan, and the patch-NDF
//! shading kernel; produces the linear pixel values L of MODEL.md section 5 for every view.
//!
//! Buffers live in a [`GpuScene`]; a [`Renderer`] owns the pipelines. One `render` call records
//! binning and shading into one command buffer and waits for it.
pub mod grad;
pub mod layout;
pub mod present;

use std::sync::Arc;

use crate::model::scene::Scene;
use crate::vulkan::{Buffer, ComputePipeline, Context, GpuError, MemLoc, Recorder, ShaderCompiler, Timings};
use layout::{BinPush, ScanPush, ScratchGpu, ShadePush, ViewSlots};

/// Scratches per binning thread (see `shaders/bin.comp`).
pub const GROUP_SIZE: u32 = 64;
const SCAN_BLOCK: u32 = 4096;

/// Compute pipelines of the forward path.
pub struct Renderer {
    pub ctx: Arc<Context>,
    bin_count: ComputePipeline,
    bin_scatter: ComputePipeline,
    scan_reduce: ComputePipeline,
    scan_sums: ComputePipeline,
    scan_apply: ComputePipeline,
    forward: ComputePipeline,
    /// The backward kernel, compiled on first use (`prepare_backward`): it is the largest
    /// pipeline, and rendering or viewing never needs it.
    grad: std::sync::OnceLock<ComputePipeline>,
    grad_reduce: ComputePipeline,
    grad_light: ComputePipeline,
}

/// Device-resident scene: parameters, binning state and images.
pub struct GpuScene {
    pub slots: ViewSlots,
    pub n_scratches: u32,
    pub n_groups: u32,
    pub shade: ShadePush,
    pub views: Buffer,
    /// the same cameras in float64 (`ViewGPU64`)
    pub views64: Buffer,
    pub scratches: Buffer,
    /// per (tile, group) counts, scanned in place into list offsets; n_tiles * n_groups + 1 entries
    pub hist: Buffer,
    cursor: Buffer,
    sums: Buffer,
    /// tile lists of scratch indices
    pub list: Buffer,
    pub capacity: u32,
    /// per scratch: entry count, scanned into the first slot of its entries in `inv`; n + 1 entries
    pub sbase: Buffer,
    sbase_sums: Buffer,
    /// scratch-major entry -> tile-list position (for deterministic gradient sums)
    pub inv: Buffer,
    /// per tile-list entry: partial gradient (8 f32)
    pub partials: Buffer,
    /// raw coverage sum_k area / S_P per pixel (forward output, backward input)
    pub cov_raw: Buffer,
    /// dE/dL per pixel (same layout as `image`): input of the backward pass
    pub dl: Buffer,
    /// per scratch: dE/d(x0, y0, x1, y1, w, d, alpha), 8 f32 (last unused)
    pub grad: Buffer,
    /// per view: dE/dPhi of its light
    pub grad_light: Buffer,
    /// L of every view, concatenated (views[v].base[1] is the first pixel of view v)
    pub image: Buffer,
    /// [0] candidates tested, [1] overlapping pairs, [2] tile-list entries
    pub stats: Buffer,
}

impl GpuScene {
    /// The counters of the last render (`stats` is host-visible: a small read, no copy).
    pub fn read_stats(&self) -> Result<RenderStats, GpuError> {
        let st: Vec<u32> = self.stats.read()?;
        Ok(RenderStats {
            candidates: st[0] as u64,
            pairs: st[1] as u64,
            entries: st[2] as u64,
        })
    }
}

/// Counters of one render.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderStats {
    /// (tile, scratch) entries produced by binning
    pub entries: u64,
    /// (pixel, scratch) candidates tested by the shading kernel
    pub candidates: u64,
    /// (pixel, scratch) pairs whose footprint and carved rectangle really overlap
    pub pairs: u64,
}

/// Output of a render: one image per view (row-major, top row first).
pub struct Frame {
    pub images: Vec<Vec<f32>>,
    pub stats: RenderStats,
    pub timings: Timings,
}

impl Renderer {
    pub fn new(ctx: &Arc<Context>) -> Result<Renderer, GpuError> {
        let sc = ShaderCompiler::embedded()?;
        let bin_push = std::mem::size_of::<BinPush>() as u32;
        let scan_push = std::mem::size_of::<ScanPush>() as u32;
        let shade_push = std::mem::size_of::<ShadePush>() as u32;
        // Ray hits in float64 where the device has it (see ViewGPU64 in shaders/inc/common.glsl).
        let f64_def: Vec<(&str, &str)> = if ctx.info().float64 {
            vec![]
        } else {
            vec![("SA_NO_F64", "1")]
        };
        Ok(Renderer {
            ctx: ctx.clone(),
            bin_count: ComputePipeline::new(ctx, &sc, "bin.comp", &[("COUNT", "1")], 6, bin_push)?,
            bin_scatter: ComputePipeline::new(ctx, &sc, "bin.comp", &[("SCATTER", "1")], 6, bin_push)?,
            scan_reduce: ComputePipeline::new(ctx, &sc, "scan.comp", &[("REDUCE", "1")], 2, scan_push)?,
            scan_sums: ComputePipeline::new(ctx, &sc, "scan.comp", &[("SUMS", "1")], 2, scan_push)?,
            scan_apply: ComputePipeline::new(ctx, &sc, "scan.comp", &[("APPLY", "1")], 2, scan_push)?,
            forward: ComputePipeline::new(ctx, &sc, "forward.comp", &f64_def, 8, shade_push)?,
            grad: std::sync::OnceLock::new(),
            grad_reduce: ComputePipeline::new(ctx, &sc, "grad_reduce.comp", &[], 4, scan_push)?,
            grad_light: ComputePipeline::new(ctx, &sc, "grad_light.comp", &[], 4, 0)?,
        })
    }

    /// Compiles the backward kernel if it is not compiled yet. Call before `record_backward`
    /// (`gradients` and the design job do).
    pub fn prepare_backward(&self) -> Result<(), GpuError> {
        if self.grad.get().is_some() {
            return Ok(());
        }
        let ctx = &self.ctx;
        // grad.comp needs ~30 KiB of shared memory with a 256-entry queue, ~39 KiB with 512.
        let qcap = if ctx.info().max_shared_memory >= 48 * 1024 {
            "512"
        } else {
            "256"
        };
        let mut defs = vec![("GRAD_QCAP", qcap)];
        if !ctx.info().float64 {
            defs.push(("SA_NO_F64", "1"));
        }
        let shade_push = std::mem::size_of::<ShadePush>() as u32;
        let p = ComputePipeline::new(ctx, &ShaderCompiler::embedded()?, "grad.comp", &defs, 8, shade_push)?;
        let _ = self.grad.set(p);
        Ok(())
    }

    /// Uploads a (validated) scene. Fails with a clear error when a buffer would exceed the
    /// device's storage-buffer limit.
    pub fn upload(&self, scene: &Scene) -> Result<GpuScene, GpuError> {
        let slots = layout::view_slots(scene);
        let n_scratches = scene.scratches.len() as u32;
        let n_groups = n_scratches.div_ceil(GROUP_SIZE).max(1);
        let scr: Vec<ScratchGpu> = scene.scratches.iter().map(ScratchGpu::from).collect();
        let hist_len = slots.n_tiles as u64 * n_groups as u64 + 1;
        let n_blocks = hist_len.div_ceil(SCAN_BLOCK as u64);
        // Initial list capacity: a guess, grown on demand after the first binning.
        // (bounded so that the 32-byte-per-entry partial-gradient buffer fits the device limit).
        let capacity = ((n_scratches as u64 * scene.views.len() as u64 * 4).max(1 << 16))
            .min(self.ctx.info().max_storage_buffer_range / 32) as u32;
        let ctx = &self.ctx;
        Ok(GpuScene {
            shade: ShadePush {
                half_plate: (scene.plate.size_mm * 0.5) as f32,
                alpha_s: scene.plate.roughness as f32,
                f0: scene.plate.f0 as f32,
                n_views: scene.views.len() as u32,
                n_groups,
                n_tiles: slots.n_tiles,
                capacity,
                pad0: 0,
            },
            views: {
                // Host-visible so a viewer can move cameras and lights every frame without
                // reallocating (see `update_views`).
                let b = Buffer::new(
                    ctx,
                    "views",
                    std::mem::size_of_val(slots.views.as_slice()) as u64,
                    MemLoc::CpuToGpu,
                )?;
                b.write(0, &slots.views)?;
                b
            },
            views64: {
                let b = Buffer::new(
                    ctx,
                    "views (float64 cameras)",
                    std::mem::size_of_val(slots.views64.as_slice()) as u64,
                    MemLoc::CpuToGpu,
                )?;
                b.write(0, &slots.views64)?;
                b
            },
            scratches: ctx.upload("scratches", &scr)?,
            hist: Buffer::new(ctx, "bin offsets", hist_len * 4, MemLoc::GpuOnly)?,
            cursor: Buffer::new(ctx, "bin cursors", hist_len * 4, MemLoc::GpuOnly)?,
            sums: Buffer::new(ctx, "scan block sums", n_blocks * 4, MemLoc::GpuOnly)?,
            list: Buffer::new(ctx, "tile lists", capacity as u64 * 4, MemLoc::GpuOnly)?,
            capacity,
            sbase: Buffer::new(
                ctx,
                "scratch entry bases",
                (n_scratches as u64 + 1) * 4,
                MemLoc::GpuOnly,
            )?,
            sbase_sums: Buffer::new(
                ctx,
                "scan block sums (scratches)",
                (n_scratches as u64 + 1).div_ceil(SCAN_BLOCK as u64) * 4,
                MemLoc::GpuOnly,
            )?,
            inv: Buffer::new(ctx, "entry inverse map", capacity as u64 * 4, MemLoc::GpuOnly)?,
            partials: Buffer::new(ctx, "partial gradients", capacity as u64 * 32, MemLoc::GpuOnly)?,
            cov_raw: Buffer::new(ctx, "coverage", slots.n_pixels * 4, MemLoc::GpuOnly)?,
            dl: Buffer::new(ctx, "dE/dL", slots.n_pixels * 4, MemLoc::GpuOnly)?,
            grad: Buffer::new(
                ctx,
                "scratch gradients",
                n_scratches.max(1) as u64 * 32,
                MemLoc::GpuOnly,
            )?,
            grad_light: Buffer::new(ctx, "light gradients", scene.views.len() as u64 * 4, MemLoc::GpuOnly)?,
            image: Buffer::new(ctx, "image", slots.n_pixels * 4, MemLoc::GpuOnly)?,
            stats: Buffer::new(ctx, "stats", 64, MemLoc::GpuToCpu)?,
            n_scratches,
            n_groups,
            slots,
        })
    }

    /// Replaces the cameras and lights of an uploaded scene (same number of views, same image
    /// sizes): cheap enough for every frame of a viewer. Returns false (and changes nothing) when
    /// the sizes differ, in which case the caller uploads the scene again.
    pub fn update_views(&self, gs: &mut GpuScene, views: &[crate::model::scene::View]) -> Result<bool, GpuError> {
        if views.len() != gs.slots.views.len() {
            return Ok(false);
        }
        let mut new = Vec::with_capacity(views.len());
        for (v, old) in views.iter().zip(&gs.slots.views) {
            if v.camera.width != old.dims[0] || v.camera.height != old.dims[1] {
                return Ok(false);
            }
            new.push(layout::view_gpu(v, old.base[0], old.base[1]));
        }
        let new64: Vec<_> = views.iter().map(layout::view_gpu64).collect();
        gs.views.write(0, &new)?;
        gs.views64.write(0, &new64)?;
        gs.slots.views = new;
        gs.slots.views64 = new64;
        Ok(true)
    }

    /// Records tile binning (count, scan, scatter) into `rec`.
    pub fn record_binning(&self, rec: &mut Recorder, gs: &GpuScene) {
        let push = BinPush {
            n_scratches: gs.n_scratches,
            n_views: gs.shade.n_views,
            n_groups: gs.n_groups,
            group_size: GROUP_SIZE,
            capacity: gs.capacity,
            pad: [0; 3],
        };
        let groups = gs.n_groups.div_ceil(64);
        rec.fill(&gs.hist, 0);
        rec.fill(&gs.sbase, 0);
        rec.barrier();
        let bufs = [&gs.views, &gs.scratches, &gs.hist, &gs.list, &gs.sbase, &gs.inv];
        rec.dispatch_1d(&self.bin_count, &bufs, bytemuck::bytes_of(&push), groups);
        rec.barrier();
        let n_hist = gs.slots.n_tiles as u64 * gs.n_groups as u64 + 1;
        self.record_scan(rec, &gs.hist, &gs.sums, n_hist);
        self.record_scan(rec, &gs.sbase, &gs.sbase_sums, gs.n_scratches as u64 + 1);
        rec.copy(&gs.hist, &gs.cursor, gs.hist.size());
        rec.barrier();
        let bufs = [&gs.views, &gs.scratches, &gs.cursor, &gs.list, &gs.sbase, &gs.inv];
        rec.dispatch_1d(&self.bin_scatter, &bufs, bytemuck::bytes_of(&push), groups);
        rec.barrier();
    }

    /// Exclusive scan of `n` u32 in `data`, in place.
    pub fn record_scan(&self, rec: &mut Recorder, data: &Buffer, sums: &Buffer, n: u64) {
        let n_blocks = n.div_ceil(SCAN_BLOCK as u64) as u32;
        let push = ScanPush {
            n: n as u32,
            n_blocks,
            pad: [0; 2],
        };
        let pb = bytemuck::bytes_of(&push);
        rec.dispatch_1d(&self.scan_reduce, &[data, sums], pb, n_blocks);
        rec.barrier();
        rec.dispatch(&self.scan_sums, &[data, sums], pb, [1, 1, 1]);
        rec.barrier();
        rec.dispatch_1d(&self.scan_apply, &[data, sums], pb, n_blocks);
        rec.barrier();
    }

    /// Records the shading kernel (writes `gs.image` and `gs.stats`).
    pub fn record_shading(&self, rec: &mut Recorder, gs: &GpuScene) {
        rec.dispatch_1d(
            &self.forward,
            &[
                &gs.views,
                &gs.scratches,
                &gs.hist,
                &gs.list,
                &gs.image,
                &gs.stats,
                &gs.cov_raw,
                &gs.views64,
            ],
            bytemuck::bytes_of(&gs.shade),
            gs.slots.n_tiles,
        );
        rec.barrier();
    }

    /// Bins and shades; grows the tile-list buffer and repeats if binning overflowed it.
    /// Returns the stats of the final pass; images stay on the device.
    pub fn run(&self, rec: &mut Recorder, gs: &mut GpuScene) -> Result<(RenderStats, Timings), GpuError> {
        loop {
            rec.begin()?;
            rec.fill(&gs.stats, 0);
            rec.barrier();
            self.record_binning(rec, gs);
            rec.timestamp("bin");
            self.record_shading(rec, gs);
            rec.timestamp("shade");
            let timings = rec.submit_and_wait()?;
            let stats = gs.read_stats()?;
            if stats.entries <= gs.capacity as u64 {
                return Ok((stats, timings));
            }
            self.grow_list(gs, stats.entries)?;
        }
    }

    /// Replaces the tile-list buffer by one that holds `entries` (plus slack).
    pub fn grow_list(&self, gs: &mut GpuScene, entries: u64) -> Result<(), GpuError> {
        let want = entries + entries / 4 + 1024;
        // The partial-gradient buffer (32 bytes per entry) is the largest of the three.
        if want * 32 > self.ctx.info().max_storage_buffer_range || want > u32::MAX as u64 {
            return Err(GpuError::BufferTooLarge {
                name: "partial gradients (one per tile-list entry)".into(),
                size: want * 32,
                limit: self.ctx.info().max_storage_buffer_range,
            });
        }
        gs.list = Buffer::new(&self.ctx, "tile lists", want * 4, MemLoc::GpuOnly)?;
        gs.inv = Buffer::new(&self.ctx, "entry inverse map", want * 4, MemLoc::GpuOnly)?;
        gs.partials = Buffer::new(&self.ctx, "partial gradients", want * 32, MemLoc::GpuOnly)?;
        gs.capacity = want as u32;
        gs.shade.capacity = gs.capacity;
        Ok(())
    }

    /// Renders every view and downloads the images.
    pub fn render(&self, gs: &mut GpuScene) -> Result<Frame, GpuError> {
        let mut rec = Recorder::new(&self.ctx)?;
        let (stats, timings) = self.run(&mut rec, gs)?;
        let all: Vec<f32> = self.ctx.download(&gs.image)?;
        let images = gs
            .slots
            .views
            .iter()
            .map(|v| {
                let n = v.dims[0] as usize * v.dims[1] as usize;
                all[v.base[1] as usize..v.base[1] as usize + n].to_vec()
            })
            .collect();
        Ok(Frame { images, stats, timings })
    }
}
