//! The GPU renderer: tile binning (pair search), deterministic scan, and the patch-NDF shading
//! kernels; produces the linear pixel values L of engine/docs/model.md section 5 for every view, and (in
//! [`grad`]) their gradients.
//!
//! Buffers live in a [`GpuScene`] (the binning state private to this module); a [`Renderer`]
//! owns the pipelines. Every render anywhere (the `render` command, the optimizer, pruning,
//! benchmarks, the viewer) is recorded by [`Renderer::record_render`] and submitted by
//! [`Renderer::submit`], the one place that grows the tile lists and redoes an incomplete render.
//!
//! The shading kernels are described by [`kernels::KernelSet`]: a forward and a backward
//! [`kernels::ShadeKernel`], each an integrator and a mode that become a shader file and its
//! defines. [`Renderer::new`] builds the default set (closed-form pair integral, reverse-mode
//! backward); [`Renderer::with_kernels`] any other, e.g. for comparisons. On the GLSL side both
//! kernels run one tile loop (`shaders/inc/tile_loop.glsl`) and one pair set-up
//! (`pair_integrate` in `shaders/inc/patch_ndf.glsl`), differing only in their hooks: the forward
//! kernel sums per pixel in float, the backward one per scratch (reverse mode, or dual numbers
//! for the oracle).
pub mod arcs;
mod bindings;
mod binning;
pub mod grad;
pub mod io;
pub mod kernels;
pub mod layout;
pub mod limits;
pub mod present;
mod scene;
pub mod tangent;

// The crates beneath, by the names the engine gives them.
use scratchart_model as model;
use scratchart_vulkan as vulkan;

pub use binning::{bands_on_gpu, radix_passes, BinMode, TileLists};
pub use scene::{GpuScene, RenderStats};

use std::sync::Arc;

use crate::model::scene::Scene;
use crate::vulkan::{Buffer, ComputePipeline, Context, GpuError, Recorder, ShaderCompiler, Texel, Timings};
use kernels::{KernelSet, ShadeKernel};
use layout::{BinPush, RadixPush, ScanPush, ShadePush};

/// Scratches per binning thread (see `shaders/bin.comp`).
pub const GROUP_SIZE: u32 = 64;
/// Elements per block of the scan (see `shaders/scan.comp`).
const SCAN_BLOCK: u32 = 4096;

/// Compute pipelines of the forward path.
pub struct Renderer {
    pub ctx: Arc<Context>,
    bin_count: ComputePipeline,
    bin_scatter: ComputePipeline,
    /// [`BinMode::Pairs`]: bin.comp's PAIRS passes and radix.comp's
    pair_count: ComputePipeline,
    pair_emit: ComputePipeline,
    radix_hist: ComputePipeline,
    radix_scatter: ComputePipeline,
    radix_final: ComputePipeline,
    scan_reduce: ComputePipeline,
    scan_sums: ComputePipeline,
    scan_apply: ComputePipeline,
    /// The per-scratch and per-pixel records of the shading kernels (`scratch_records.comp`,
    /// `pixel_records.comp`).
    records: ComputePipeline,
    pixel_records: ComputePipeline,
    /// Arcs: the chords from the scene's scratches before a render, the scratches' gradients
    /// from the chords' after a backward (`shaders/arc_map.comp`).
    arc_map: ComputePipeline,
    /// The shading kernels this renderer builds (`forward` at once, the backward on first use).
    kernels: KernelSet,
    forward: ComputePipeline,
    /// The backward kernel, compiled on first use (`prepare_backward`): it is the largest
    /// pipeline, and rendering or viewing never needs it.
    grad: std::sync::OnceLock<ComputePipeline>,
    /// The backward kernel's replay build (`SA_REPLAY`), compiled with `grad` when
    /// `kernels.replay`.
    grad_replay: std::sync::OnceLock<ComputePipeline>,
    grad_reduce: ComputePipeline,
    grad_light: ComputePipeline,
    /// The tangent kernel (`tangent.comp`), compiled on first use ([`Renderer::tangents`]).
    tangent: std::sync::OnceLock<ComputePipeline>,
    /// The tangent kernel's build that writes each pixel's first moments of light
    /// (`SA_MOMENTS`), compiled on first use ([`Renderer::moments`]).
    moments: std::sync::OnceLock<ComputePipeline>,
    /// The forward kernel's build for scenes with arcs (`shade_pipeline_with`), compiled by the
    /// first upload of one.
    forward_arcs: std::sync::OnceLock<ComputePipeline>,
    /// The backward for scenes with arcs: the dual-number kernel with `SA_ARCS` (the chords'
    /// weights and dE/dkappa), compiled by the first `gradients` of one.
    grad_arcs: std::sync::OnceLock<ComputePipeline>,
    /// Chords per arc of every upload ([`Renderer::set_arc_chords`]); 0: the accuracy bar's rule.
    arc_chords: std::sync::atomic::AtomicU32,
}

/// Compute shared memory the shading kernels need (lavapipe and desktop GPUs have 32 KiB or more).
pub const MIN_SHARED_MEMORY: u32 = 32 * 1024;

/// The pipeline of a shading kernel (the layout of [`bindings::SLOTS`] and `ShadePush`);
/// `replay`: the backward's replay build (see [`KernelSet::replay`]).
fn shade_pipeline(
    ctx: &Arc<Context>,
    sc: &ShaderCompiler,
    k: &ShadeKernel,
    replay: bool,
) -> Result<ComputePipeline, GpuError> {
    shade_pipeline_with(ctx, sc, k, replay, false, None, &[])
}

/// [`shade_pipeline`], with `arcs`: the build that weighs arc chords (`SA_ARCS`,
/// `shaders/inc/patch_ndf.glsl`); without it the kernel has no trace of them. `walk`: how a
/// backward's rounds add each scratch's entries ([`KernelSet::walk`]; None: the device's
/// choice). `extra`: more defines (a build of another role: `SA_MOMENTS`).
fn shade_pipeline_with(
    ctx: &Arc<Context>,
    sc: &ShaderCompiler,
    k: &ShadeKernel,
    replay: bool,
    arcs: bool,
    walk: Option<kernels::Walk>,
    extra: &[(&'static str, &'static str)],
) -> Result<ComputePipeline, GpuError> {
    let (mut name, mut defines) = if replay {
        (k.replay_name(), k.replay_defines(ctx.info()))
    } else {
        (k.name(), k.defines(ctx.info()))
    };
    if let Some(w) = walk.filter(|_| k.is_backward()) {
        defines.retain(|d| d.0 != kernels::PARALLEL_LINKS && d.0 != kernels::WALK_SPLIT);
        defines.extend(w.defines());
        name.push_str(&format!(" (walk {})", w.name()));
    }
    if arcs {
        name.push_str(" (arcs)");
        defines.push(("SA_ARCS", "1"));
    }
    if k.is_backward() {
        for (d, v) in kernels::grad_diagnostics() {
            name.push_str(&format!(" ({d}={v})"));
            defines.retain(|x| x.0 != d);
            defines.push((d, v));
        }
    }
    for &(d, v) in extra {
        name.push_str(&format!(" ({d})"));
        defines.push((d, v));
    }
    let spirv = sc.compile(k.file(), &defines)?;
    ComputePipeline::with_texels(
        ctx,
        &name,
        &spirv,
        bindings::STORAGE,
        &bindings::TEXELS,
        std::mem::size_of::<ShadePush>() as u32,
    )
}

/// Output of a render: one image per view (row-major, top row first).
pub struct Frame {
    pub images: Vec<Vec<f32>>,
    pub stats: RenderStats,
    pub timings: Timings,
}

impl Renderer {
    /// The renderer with the default shading kernels ([`KernelSet::default`]: the closed-form
    /// pair integral).
    pub fn new(ctx: &Arc<Context>) -> Result<Renderer, GpuError> {
        Self::with_kernels(ctx, KernelSet::default())
    }

    /// The renderer with the shading kernels `kernels` (e.g. another integrator, for
    /// comparisons). Panics if `kernels.forward` is not a forward kernel or `kernels.backward`
    /// not a backward one (a contract).
    pub fn with_kernels(ctx: &Arc<Context>, kernels: KernelSet) -> Result<Renderer, GpuError> {
        assert!(
            !kernels.forward.is_backward() && kernels.backward.is_backward(),
            "KernelSet needs a forward and a backward kernel, got {kernels:?}"
        );
        // The shading kernels keep a tile's pixels, a chunk of scratches and a round of pairs in
        // workgroup memory: about 28 KiB (forward.comp) and 30 KiB (grad.comp, 256-entry rounds).
        let shared = ctx.info().max_shared_memory;
        if shared < MIN_SHARED_MEMORY {
            return Err(GpuError::Capacity(format!(
                "the shading kernels need {} KiB of compute shared memory per workgroup, this device has {} KiB                  (maxComputeSharedMemorySize); use another device (--device)",
                MIN_SHARED_MEMORY / 1024,
                shared / 1024
            )));
        }
        if !ctx.info().subgroup_arithmetic {
            return Err(GpuError::Capacity(
                "the shading kernels need subgroup arithmetic in compute shaders (VK_SUBGROUP_FEATURE_ARITHMETIC_BIT), \
                 which this device does not offer; use another device (--device)"
                    .into(),
            ));
        }
        let sc = ShaderCompiler::embedded()?;
        let bin_push = std::mem::size_of::<BinPush>() as u32;
        let scan_push = std::mem::size_of::<ScanPush>() as u32;
        let radix_push = std::mem::size_of::<RadixPush>() as u32;
        Ok(Renderer {
            ctx: ctx.clone(),
            bin_count: ComputePipeline::new(ctx, &sc, "bin.comp", &[("COUNT", "1")], 7, bin_push)?,
            bin_scatter: ComputePipeline::new(ctx, &sc, "bin.comp", &[("SCATTER", "1")], 7, bin_push)?,
            pair_count: ComputePipeline::new(ctx, &sc, "bin.comp", &[("PAIRS", "1"), ("COUNT", "1")], 7, bin_push)?,
            pair_emit: ComputePipeline::new(ctx, &sc, "bin.comp", &[("PAIRS", "1"), ("SCATTER", "1")], 7, bin_push)?,
            radix_hist: ComputePipeline::new(ctx, &sc, "radix.comp", &[("HIST", "1")], 6, radix_push)?,
            radix_scatter: ComputePipeline::new(ctx, &sc, "radix.comp", &[("SCATTER", "1")], 6, radix_push)?,
            radix_final: ComputePipeline::new(ctx, &sc, "radix.comp", &[("FINAL", "1")], 6, radix_push)?,
            scan_reduce: ComputePipeline::new(ctx, &sc, "scan.comp", &[("REDUCE", "1")], 3, scan_push)?,
            scan_sums: ComputePipeline::new(ctx, &sc, "scan.comp", &[("SUMS", "1")], 3, scan_push)?,
            scan_apply: ComputePipeline::new(ctx, &sc, "scan.comp", &[("APPLY", "1")], 3, scan_push)?,
            records: ComputePipeline::new(ctx, &sc, "scratch_records.comp", &[], 2, 16)?,
            arc_map: ComputePipeline::new(ctx, &sc, "arc_map.comp", &[], 6, 16)?,
            pixel_records: ComputePipeline::with_texels(
                ctx,
                "pixel_records.comp",
                &sc.compile("pixel_records.comp", &[])?,
                3,
                &[Texel::Write],
                std::mem::size_of::<ShadePush>() as u32,
            )?,
            kernels,
            forward: shade_pipeline(ctx, &sc, &kernels.forward, false)?,
            grad: std::sync::OnceLock::new(),
            grad_replay: std::sync::OnceLock::new(),
            grad_reduce: ComputePipeline::new(ctx, &sc, "grad_reduce.comp", &[], 4, scan_push)?,
            grad_light: ComputePipeline::new(ctx, &sc, "grad_light.comp", &[], 5, 0)?,
            tangent: std::sync::OnceLock::new(),
            moments: std::sync::OnceLock::new(),
            forward_arcs: std::sync::OnceLock::new(),
            grad_arcs: std::sync::OnceLock::new(),
            arc_chords: std::sync::atomic::AtomicU32::new(0),
        })
    }

    /// The shading kernels this renderer was built with.
    pub fn kernels(&self) -> KernelSet {
        self.kernels
    }

    /// Compiles the backward kernel (and its replay build) if it is not compiled yet. Call
    /// before `record_backward` (`gradients` and the design job do).
    pub fn prepare_backward(&self) -> Result<(), GpuError> {
        if self.grad.get().is_some() {
            return Ok(());
        }
        let sc = ShaderCompiler::embedded()?;
        if self.kernels.replay {
            let _ = self.grad_replay.set(shade_pipeline_with(
                &self.ctx,
                &sc,
                &self.kernels.backward,
                true,
                false,
                self.kernels.walk,
                &[],
            )?);
        }
        let walk = self.kernels.walk;
        let p = shade_pipeline_with(&self.ctx, &sc, &self.kernels.backward, false, false, walk, &[])?;
        let _ = self.grad.set(p);
        Ok(())
    }

    /// Uploads a (validated) scene. Fails with a clear error when a buffer would exceed the
    /// device's storage-buffer limit.
    pub fn upload(&self, scene: &Scene) -> Result<GpuScene, GpuError> {
        self.prepare_arcs(scene)?;
        GpuScene::new_in(&self.ctx, scene, &[], self.arc_chords())
    }

    /// Every later upload of this renderer renders each arc as `n` chords (equal angles) instead
    /// of the accuracy bar's rule ([`arcs::chord_count`]; None restores it): for a job that
    /// renders arcs many times and states the layout it judged them at (`design --arcs`;
    /// engine/docs/model.md section 11 measures what the count costs in accuracy).
    pub fn set_arc_chords(&self, n: Option<u32>) {
        let n = n.map_or(0, |n| n.clamp(1, arcs::MAX_CHORDS_PER_ARC as u32));
        self.arc_chords.store(n, std::sync::atomic::Ordering::Relaxed);
    }

    /// Whether [`upload`](Self::upload) of `scene` fits the device's buffers and loops (its arcs
    /// counted as the chords this renderer lays them out as): for callers that choose how many
    /// views to render at once.
    pub fn fits(&self, scene: &Scene) -> bool {
        let mode = scene::arcs::ChordMode::of(self.arc_chords());
        let scratches: u64 = mode.counts(&scene.scratches).iter().map(|&n| n as u64).sum();
        let sizes: Vec<(u32, u32)> = scene.views.iter().map(|v| (v.camera.width, v.camera.height)).collect();
        let dims = limits::SceneDims::new(&sizes, scratches, false);
        dims.over_device_limit(self.ctx.info()).is_none() && dims.over_loop_limit(self.ctx.info()).is_none()
    }

    /// The chords per arc of this renderer's uploads (None: the accuracy bar's rule).
    pub fn arc_chords(&self) -> Option<u32> {
        match self.arc_chords.load(std::sync::atomic::Ordering::Relaxed) {
            0 => None,
            n => Some(n),
        }
    }

    /// [`Renderer::upload`] of a scene whose every scratch may bend (`design --arcs`): each is
    /// uploaded as `chords` chords whatever its bulge, straight ones too, so an optimizer moves
    /// the bulges in [`GpuScene::arc_params`] without a new upload. The chords follow the arcs on
    /// the device at every render; how close `chords` renders an arc is the caller's choice
    /// (engine/docs/model.md section 11: [`arcs::chord_count`] is the accuracy bar's).
    ///
    /// `weighted` false renders the chords without their area weights (the straight kernels,
    /// forward and reverse-mode backward: 15 times cheaper an iteration for a design's arcs,
    /// engine/BENCHMARKS.md), so dE/dbulge leaves out the weight's part; true, the arc kernels.
    pub fn upload_bendable(&self, scene: &Scene, chords: u32, weighted: bool) -> Result<GpuScene, GpuError> {
        if weighted {
            self.prepare_arc_forward()?;
        }
        let mut gs = GpuScene::new_bendable(&self.ctx, scene, chords)?;
        gs.weigh_arcs(weighted);
        Ok(gs)
    }

    /// [`prepare_backward`](Self::prepare_backward) for scene `gs`: with arcs, the backward that
    /// weighs chords too. Call before `record_backward` on a scene that may hold arcs.
    pub fn prepare_backward_of(&self, gs: &GpuScene) -> Result<(), GpuError> {
        if gs.arc_kernels() {
            self.prepare_arc_backward()?;
        }
        self.prepare_backward()
    }

    /// Records `shaders/arc_map.comp` in `mode` (0: the chords from the arcs, 1: the arcs'
    /// gradients from the chords'), then a barrier.
    fn record_arc_map(&self, rec: &mut Recorder, gs: &GpuScene, a: &scene::arcs::ArcLayout, mode: u32) {
        let n = if mode == 0 { a.n_chords() } else { a.chords.len() as u32 };
        let push = [n, mode, 0, 0];
        rec.dispatch_1d(
            &self.arc_map,
            &[
                &a.params,
                &gs.inputs.scratches,
                &a.chord_of,
                &a.arc_chords,
                &gs.backward.grad,
                &a.grad,
            ],
            bytemuck::cast_slice(&push),
            n.div_ceil(64),
        );
        rec.barrier();
    }

    /// Compiles the backward for scenes with arcs (`grad_arcs`) if it is not compiled yet.
    fn prepare_arc_backward(&self) -> Result<(), GpuError> {
        if self.grad_arcs.get().is_some() {
            return Ok(());
        }
        let sc = ShaderCompiler::embedded()?;
        let k = kernels::ShadeKernel {
            integrator: kernels::Integrator::ClosedForm,
            mode: kernels::Mode::BackwardDual,
        };
        let _ = self
            .grad_arcs
            .set(shade_pipeline_with(&self.ctx, &sc, &k, false, true, None, &[])?);
        Ok(())
    }

    /// Compiles the forward kernel's arc build if `scene` has arcs and it is not compiled yet.
    /// Arcs need the closed-form integrator (the one that weighs chords).
    fn prepare_arcs(&self, scene: &Scene) -> Result<(), GpuError> {
        if !arcs::any_arc(&scene.scratches) {
            return Ok(());
        }
        self.prepare_arc_forward()
    }

    /// Compiles the forward kernel's arc build if it is not compiled yet.
    fn prepare_arc_forward(&self) -> Result<(), GpuError> {
        if self.forward_arcs.get().is_some() {
            return Ok(());
        }
        if self.kernels.forward.integrator != kernels::Integrator::ClosedForm {
            return Err(GpuError::Capacity(format!(
                "arc scratches render with the closed-form integrator only, not {}",
                self.kernels.forward.integrator.name()
            )));
        }
        let sc = ShaderCompiler::embedded()?;
        let p = shade_pipeline_with(&self.ctx, &sc, &self.kernels.forward, false, true, None, &[])?;
        let _ = self.forward_arcs.set(p);
        Ok(())
    }

    /// [`Renderer::upload`] for forward renders of part of each image: view v's renders compute
    /// only `windows[v]`'s tiles (None, or past the end of `windows`: the whole image), and
    /// [`Renderer::render`] returns 0 outside them. Inside, the pixels are those of the whole
    /// image's render, bit for bit.
    pub fn upload_windowed(&self, scene: &Scene, windows: &[Option<layout::TileWindow>]) -> Result<GpuScene, GpuError> {
        self.prepare_arcs(scene)?;
        GpuScene::new_in(&self.ctx, scene, windows, self.arc_chords())
    }

    /// Records binning of `gs` into `rec`, in its [`BinMode`].
    fn record_binning(&self, rec: &mut Recorder, gs: &GpuScene) {
        match &gs.bin.pair_sort {
            Some(sort) if gs.bin.mode == BinMode::Pairs => self.record_pair_binning(rec, gs, sort),
            _ => self.record_group_binning(rec, gs),
        }
    }

    /// The count pass of either mode (`pipeline`): every per-tile and per-(scratch, part)
    /// count from zero.
    fn record_count(&self, rec: &mut Recorder, gs: &GpuScene, pipeline: &ComputePipeline) {
        let push = gs.bin_push();
        rec.fill(&gs.bin.hist, 0);
        rec.fill(&gs.bin.sbase, 0);
        rec.barrier();
        let bufs = [
            &gs.inputs.views,
            &gs.inputs.scratches,
            &gs.bin.hist,
            &gs.bin.list,
            &gs.bin.sbase,
            &gs.bin.inv,
            &gs.stats,
        ];
        let threads = gs.binning_threads().div_ceil(64) as u32;
        rec.dispatch_1d(pipeline, &bufs, bytemuck::bytes_of(&push), threads);
        rec.barrier();
    }

    /// [`BinMode::Pairs`]: count per (scratch, part) and per tile, scan both, emit the pairs in
    /// scratch-major order, sort them by tile (stable, 8 bits a pass), write the lists.
    fn record_pair_binning(&self, rec: &mut Recorder, gs: &GpuScene, sort: &binning::PairSort) {
        self.record_count(rec, gs, &self.pair_count);
        self.record_scan(rec, &gs.bin.hist, &gs.bin.sums, &gs.stats, gs.slots.n_tiles as u64 + 1);
        self.record_scan(rec, &gs.bin.sbase, &gs.bin.sbase_sums, &gs.stats, gs.sbase_len());
        // The keys (tiles) to the lists' buffer, the scratches to the sort's.
        let bufs = [
            &gs.inputs.views,
            &gs.inputs.scratches,
            &gs.bin.hist,
            &gs.bin.list,
            &gs.bin.sbase,
            &sort.scratch_of,
            &gs.stats,
        ];
        let threads = gs.binning_threads().div_ceil(64) as u32;
        rec.dispatch_1d(&self.pair_emit, &bufs, bytemuck::bytes_of(&gs.bin_push()), threads);
        rec.barrier();
        let keys = [&gs.bin.list, &sort.keys];
        let passes = binning::radix_passes(gs.slots.n_tiles);
        let mut radix = RadixPush {
            n_blocks: sort.blocks,
            shift: 0,
            total_index: (gs.sbase_len() - 1) as u32,
            capacity: gs.bin.capacity,
            first: 1,
            pad: [0; 3],
        };
        for p in 0..passes as usize {
            radix.shift = 8 * p as u32;
            radix.first = (p == 0) as u32;
            let bufs = [
                keys[p % 2],
                &sort.vals[p % 2],
                &sort.digits,
                keys[(p + 1) % 2],
                &sort.vals[(p + 1) % 2],
                &gs.bin.sbase,
            ];
            rec.dispatch_1d(&self.radix_hist, &bufs, bytemuck::bytes_of(&radix), sort.blocks);
            rec.barrier();
            self.record_scan(rec, &sort.digits, &sort.digit_sums, &gs.stats, sort.blocks as u64 * 256);
            rec.dispatch_1d(&self.radix_scatter, &bufs, bytemuck::bytes_of(&radix), sort.blocks);
            rec.barrier();
        }
        let bufs = [
            &sort.scratch_of,
            &sort.vals[passes as usize % 2],
            &sort.digits,
            &gs.bin.list,
            &gs.bin.inv,
            &gs.bin.sbase,
        ];
        rec.dispatch_1d(&self.radix_final, &bufs, bytemuck::bytes_of(&radix), sort.blocks);
        rec.barrier();
    }

    /// [`BinMode::Groups`]: count per (tile, group), scan, scatter.
    fn record_group_binning(&self, rec: &mut Recorder, gs: &GpuScene) {
        self.record_count(rec, gs, &self.bin_count);
        let n_hist = gs.slots.n_tiles as u64 * gs.n_groups as u64 + 1;
        self.record_scan(rec, &gs.bin.hist, &gs.bin.sums, &gs.stats, n_hist);
        self.record_scan(rec, &gs.bin.sbase, &gs.bin.sbase_sums, &gs.stats, gs.sbase_len());
        rec.copy(&gs.bin.hist, &gs.bin.cursor, gs.bin.hist.size());
        rec.barrier();
        let bufs = [
            &gs.inputs.views,
            &gs.inputs.scratches,
            &gs.bin.cursor,
            &gs.bin.list,
            &gs.bin.sbase,
            &gs.bin.inv,
            &gs.stats,
        ];
        let groups = gs.binning_threads().div_ceil(64) as u32;
        rec.dispatch_1d(&self.bin_scatter, &bufs, bytemuck::bytes_of(&gs.bin_push()), groups);
        rec.barrier();
    }

    /// Exclusive scan of `n` u32 in `data`, in place; a total past `u32::MAX` sets
    /// `stats[STAT_ENTRIES_WRAPPED]`.
    fn record_scan(&self, rec: &mut Recorder, data: &Buffer, sums: &Buffer, stats: &Buffer, n: u64) {
        let n_blocks = n.div_ceil(SCAN_BLOCK as u64) as u32;
        let push = ScanPush {
            n: n as u32,
            n_blocks,
            flag_index: scene::STAT_ENTRIES_WRAPPED,
            pad: 0,
        };
        let pb = bytemuck::bytes_of(&push);
        rec.dispatch_1d(&self.scan_reduce, &[data, sums, stats], pb, n_blocks);
        rec.barrier();
        rec.dispatch(&self.scan_sums, &[data, sums, stats], pb, [1, 1, 1]);
        rec.barrier();
        rec.dispatch_1d(&self.scan_apply, &[data, sums, stats], pb, n_blocks);
        rec.barrier();
    }

    /// The pair search's exclusive scan of `data` on the device, and whether its total wrapped
    /// (for tests of the scan and its overflow check).
    #[doc(hidden)]
    pub fn scan_u32(&self, data: &[u32]) -> Result<(Vec<u32>, bool), GpuError> {
        let buf = self.ctx.upload("scan test data", data)?;
        let n = data.len() as u64;
        let sums = Buffer::new(
            &self.ctx,
            "scan test sums",
            n.div_ceil(SCAN_BLOCK as u64).max(1) * 4,
            crate::vulkan::MemLoc::GpuOnly,
        )?;
        let stats = Buffer::new(&self.ctx, "scan test stats", 64, crate::vulkan::MemLoc::GpuToCpu)?;
        let mut rec = Recorder::new(&self.ctx)?;
        rec.begin()?;
        rec.fill(&stats, 0);
        rec.barrier();
        self.record_scan(&mut rec, &buf, &sums, &stats, n);
        rec.submit_and_wait()?;
        let flags: Vec<u32> = stats.read()?;
        let out: Vec<u32> = self.ctx.download(&buf)?;
        Ok((
            out[..data.len()].to_vec(),
            flags[scene::STAT_ENTRIES_WRAPPED as usize] != 0,
        ))
    }

    /// Records the shading kernel (writes the image, the coverage and the counters).
    fn record_shading(&self, rec: &mut Recorder, gs: &GpuScene) {
        let kernel = if gs.arc_kernels() {
            self.forward_arcs
                .get()
                .expect("an upload of arcs builds the arc kernel")
        } else {
            &self.forward
        };
        record_passes(rec, kernel, gs, bindings::Role::Forward);
    }

    /// Records one render of `gs` (counters cleared, pair search, shading), with the timestamps
    /// `binning` and `forward`. Every caller records renders through this and submits through
    /// [`submit`](Self::submit), which checks that the render was complete.
    pub fn record_render(&self, rec: &mut Recorder, gs: &GpuScene) {
        self.record_render_with(rec, gs, true);
    }

    /// [`record_render`](Self::record_render) that keeps the tile lists of the last render of
    /// `gs` when `bin` is false: valid when neither the cameras nor the scratches changed since
    /// (a lamp that moves needs the shading only; the viewer uses it). The images are the
    /// same bits as with binning, since the shading reads the same lists. The `binning`
    /// timestamp is still written (an empty span).
    pub fn record_render_with(&self, rec: &mut Recorder, gs: &GpuScene, bin: bool) {
        rec.fill(&gs.stats, 0);
        if let Some(a) = gs.arc_layout() {
            self.record_arc_map(rec, gs, a, 0);
        }
        let push = [gs.n_scratches, 0, 0, 0];
        rec.dispatch_1d(
            &self.records,
            &[&gs.inputs.scratches, &gs.inputs.records],
            bytemuck::cast_slice(&push),
            gs.n_scratches.div_ceil(64),
        );
        rec.dispatch_1d(
            &self.pixel_records,
            &[
                &gs.inputs.views,
                &gs.inputs.views64,
                &gs.inputs.lights,
                &gs.inputs.pixel_records,
            ],
            bytemuck::bytes_of(&gs.shading.shade),
            gs.slots.n_tiles,
        );
        rec.barrier();
        if bin {
            self.record_binning(rec, gs);
        }
        rec.timestamp("binning");
        self.record_shading(rec, gs);
        rec.timestamp("forward");
    }

    /// Records (with `record`, which must call [`record_render`](Self::record_render) once, and may
    /// add passes that read its results, such as the backward pass), submits and waits. When the
    /// work was incomplete (the tile lists overflowed, or a kernel hit a device limit such as
    /// llvmpipe's loop limit: see `shaders/inc/limits.glsl`), grows the lists or splits the work
    /// into more passes and does it all again, so the returned render is always complete; a
    /// limit that splitting cannot meet is an error. Returns the counters and timings of
    /// the final submission.
    pub fn submit<F>(
        &self,
        rec: &mut Recorder,
        gs: &mut GpuScene,
        mut record: F,
    ) -> Result<(RenderStats, Timings), GpuError>
    where
        F: FnMut(&mut Recorder, &GpuScene),
    {
        loop {
            rec.begin()?;
            record(rec, gs);
            let timings = rec.submit_and_wait()?;
            let raw = gs.raw_stats()?;
            if gs.complete(&raw) {
                gs.after_complete(&self.ctx, &raw)?;
                return Ok((GpuScene::counters(&raw), timings));
            }
            gs.adapt(&self.ctx, &raw)?;
        }
    }

    /// Renders `gs` (images stay on the device).
    pub fn run(&self, rec: &mut Recorder, gs: &mut GpuScene) -> Result<(RenderStats, Timings), GpuError> {
        self.submit(rec, gs, |rec, gs| self.record_render(rec, gs))
    }

    /// Renders every view and downloads the images.
    pub fn render(&self, gs: &mut GpuScene) -> Result<Frame, GpuError> {
        let mut rec = Recorder::new(&self.ctx)?;
        let (stats, timings) = self.run(&mut rec, gs)?;
        let images = self.download_images(gs)?;
        Ok(Frame { images, stats, timings })
    }

    /// The images of the last render, one per view (row-major, top row first).
    pub fn download_images(&self, gs: &GpuScene) -> Result<Vec<Vec<f32>>, GpuError> {
        let all: Vec<f32> = self.ctx.download(&gs.shading.image)?;
        Ok(gs
            .slots
            .views
            .iter()
            .map(|v| {
                let n = v.dims[0] as usize * v.dims[1] as usize;
                let mut img = all[v.base[1] as usize..v.base[1] as usize + n].to_vec();
                // A window's render leaves the pixels outside it unwritten: 0 there.
                let win = v.window();
                if win != layout::TileWindow::whole(v.dims[0], v.dims[1]) {
                    for (k, p) in img.iter_mut().enumerate() {
                        if !win.contains(k as u32 % v.dims[0], k as u32 / v.dims[0]) {
                            *p = 0.0;
                        }
                    }
                }
                img
            })
            .collect())
    }
}

/// Records a shading kernel (forward, backward or tangent: one workgroup per tile, `ShadePush`)
/// in `role` once per pass of the scene's plan for it (the forward's, or the backward's, which
/// the tangent kernel shares), each followed by a barrier.
fn record_passes(rec: &mut Recorder, kernel: &ComputePipeline, gs: &GpuScene, role: bindings::Role) {
    let plan = match role {
        bindings::Role::Forward => gs.shading.fwd_plan,
        bindings::Role::Backward { .. } | bindings::Role::Tangent { .. } => gs.shading.bwd_plan,
    };
    let buffers = bindings::shade_buffers(gs, role);
    for pass in 0..plan.passes {
        let push = ShadePush {
            chunks_per_pass: plan.chunks_per_pass,
            pass,
            n_passes: plan.passes,
            ..gs.shading.shade
        };
        rec.dispatch_1d(kernel, &buffers, bytemuck::bytes_of(&push), gs.slots.n_tiles);
        rec.barrier();
    }
}
