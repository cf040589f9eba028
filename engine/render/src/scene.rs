//! [`GpuScene`]: one scene resident on the device: the parameters (scratches, light
//! intensities), the cameras, the pair-search state (tile lists, private to `render`), the images
//! and the gradient buffers. Callers reach the buffers they may read or write through accessors;
//! the binning buffers stay private so that only [`super::Renderer`] can size and fill them.
use crate::model::scene::{Scene, Scratch, View};
use crate::vulkan::{Buffer, Context, GpuError, MemLoc};

use super::binning::{
    binning_bands, binning_parts, offset_buffers, scratch_base_buffers, BinMode, PairSort, TileLists,
};
use super::layout::{self, ScratchGpu, ShadePush, ViewSlots};
use super::GROUP_SIZE;

/// Counters of one render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// (tile, scratch) entries produced by binning
    pub entries: u64,
    /// (pixel, scratch) candidates tested by the shading kernel
    pub candidates: u64,
    /// (pixel, scratch) pairs whose footprint and carved rectangle really overlap
    pub pairs: u64,
    /// The longest tile list, in chunks of 64 scratches.
    pub max_tile_chunks: u64,
    /// Pairs the forward left out by their error bound (the integrator `adaptive`; 0 for the
    /// others): not in `pairs`, so `pairs + culled` are the pairs the scene has.
    pub culled: u64,
    /// The most tile tests one binning thread made (its serial loop; 0 when the render kept
    /// the last tile lists).
    pub bin_tests_per_thread: u64,
}

/// The `stats` slot the scans set when the (tile, scratch) entries pass `u32::MAX`.
pub(super) const STAT_ENTRIES_WRAPPED: u32 = 9;

/// How the shading work of a tile is split into passes (see `shaders/inc/limits.glsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct PassPlan {
    /// Chunks of a tile's list one pass handles (`u32::MAX`: all of them).
    pub chunks_per_pass: u32,
    /// Passes recorded.
    pub passes: u32,
}

impl PassPlan {
    const ONE: PassPlan = PassPlan {
        chunks_per_pass: u32::MAX,
        passes: 1,
    };

    /// The passes that cover tiles of up to `max_chunks` chunks.
    fn covering(chunks_per_pass: u32, max_chunks: u32) -> PassPlan {
        if chunks_per_pass == u32::MAX {
            return PassPlan::ONE;
        }
        PassPlan {
            chunks_per_pass,
            passes: max_chunks.div_ceil(chunks_per_pass).max(1),
        }
    }

    /// Whether tiles of `max_chunks` chunks are covered.
    fn covers(&self, max_chunks: u32) -> bool {
        self.chunks_per_pass == u32::MAX || self.chunks_per_pass as u64 * self.passes as u64 >= max_chunks as u64
    }

    /// After the loop limit was hit: half the chunks per pass (of what the largest tile needs).
    fn split(&self, max_chunks: u32) -> Option<u32> {
        let cur = self.chunks_per_pass.min(max_chunks.max(1));
        (cur > 1).then_some(cur / 2)
    }
}

/// What every kernel family reads: the cameras, the scratches, the lights, and the records the
/// shading kernels make of them at the start of every render.
pub(super) struct SceneInputs {
    pub(super) views: Buffer,
    /// the same cameras in float64 (`ViewGPU64`)
    pub(super) views64: Buffer,
    pub(super) scratches: Buffer,
    /// Four RGBA32F texels per scratch for the shading kernels, written at the start of every
    /// render (`scratch_records.comp`, `shaders/inc/scratch_records.glsl`).
    pub(super) records: Buffer,
    /// Five RGBA32F texels per pixel of every view (its set-up: footprint corners, half vector,
    /// the rest the shading kernels use), written at the start of every render
    /// (`pixel_records.comp`).
    pub(super) pixel_records: Buffer,
    /// per view: the light's intensity Phi (f32): optimized state, apart from the cameras
    pub(super) lights: Buffer,
}

/// The pair search's state (binning): which scratches cross which tiles, as tile lists and the
/// maps between them.
pub(super) struct Binning {
    /// per (tile, group) counts, scanned in place into list offsets; n_tiles * n_groups + 1 entries
    pub(super) hist: Buffer,
    pub(super) cursor: Buffer,
    pub(super) sums: Buffer,
    /// tile lists of scratch indices
    pub(super) list: Buffer,
    pub(super) capacity: u32,
    /// per (scratch, binning part): entry count, scanned into the first slot of those entries in
    /// `inv`; n * parts + 1 entries
    pub(super) sbase: Buffer,
    pub(super) sbase_sums: Buffer,
    /// bands of tile rows per view in binning (0: one binning thread per group does every view;
    /// see `shaders/bin.comp` and [`binning_bands`])
    pub(super) n_bands: u32,
    /// how binning spreads its work over threads (see [`BinMode`])
    pub(super) mode: BinMode,
    /// the sort's buffers of [`BinMode::Pairs`] (None in [`BinMode::Groups`])
    pub(super) pair_sort: Option<PairSort>,
    /// scratch-major entry -> tile-list position (for deterministic gradient sums)
    pub(super) inv: Buffer,
    /// scratches per binning thread (halved when binning hits a device's loop limit)
    pub(super) group_size: u32,
}

/// The shading kernels' state: their push block, how they split a tile's list into passes,
/// their outputs and what the backward replays.
pub(super) struct Shading {
    pub(super) shade: ShadePush,
    /// raw coverage sum_k area / S_P per pixel (forward output, backward input)
    pub(super) cov_raw: Buffer,
    /// L of every view, concatenated (views[v].base[1] is the first pixel of view v)
    pub(super) image: Buffer,
    /// per pixel: the forward kernel's sums between passes (a placeholder until needed)
    pub(super) carry: Buffer,
    /// The forward's pair queues for the backward's replay (`shaders/inc/tile_queue.glsl`):
    /// 2 words per tile-list entry (the chunk records), then `shade.store_cap` entries. A
    /// placeholder while `shade.store_cap` is 0.
    pub(super) pair_store: Buffer,
    /// how the forward and the backward kernel split a tile's list into passes
    pub(super) fwd_plan: PassPlan,
    pub(super) bwd_plan: PassPlan,
    /// The placeholder of the shading slots a kernel does not declare (`bindings::shade_buffers`):
    /// 16 bytes with an R32_UINT view, so it fills a storage or a texel slot.
    pub(super) unbound: Buffer,
}

/// The backward pass's buffers: its input dE/dL and the gradients it sums.
pub(super) struct Backward {
    /// dE/dL per pixel (same layout as `image`): input of the backward pass
    pub(super) dl: Buffer,
    /// per tile-list entry: partial gradient (8 f32)
    pub(super) partials: Buffer,
    /// per scratch: dE/d(x0, y0, x1, y1, w, d, alpha), 8 f32 (last unused)
    pub(super) grad: Buffer,
    /// per view: dE/dPhi of its light
    pub(super) grad_light: Buffer,
}

/// Device-resident scene: parameters, binning state and images, in the parts each kernel
/// family needs.
pub struct GpuScene {
    pub(super) slots: ViewSlots,
    pub(super) n_scratches: u32,
    pub(super) n_groups: u32,
    pub(super) inputs: SceneInputs,
    pub(super) bin: Binning,
    pub(super) shading: Shading,
    pub(super) backward: Backward,
    /// the render counters and completeness flags (`shaders/inc/limits.glsl`)
    pub(super) stats: Buffer,
    /// A backward without replay was recorded although the kernels replay: size the store after
    /// the next complete submission ([`after_complete`](Self::after_complete)).
    store_wanted: std::sync::atomic::AtomicBool,
    /// The store does not fit the device (or its counter wrapped): backward passes search.
    store_off: bool,
    /// The plate's shape (the views carry it; `update_views` keeps it).
    shape: crate::model::surface::PlateShape,
    /// Some when the scene's scratches include arcs, uploaded as their chords (`crate::arcs`):
    /// the kernels' scratches are then chords, not the scene's.
    arcs: Option<arcs::ArcLayout>,
}

/// Stats words of the pair store (`shaders/inc/tile_queue.glsl`): entries the forward's chunks
/// needed, and flags (bit 0: the replay found a chunk not stored; bit 1: the counter wrapped).
const STAT_STORE_NEEDED: usize = 13;
const STAT_STORE_FLAGS: usize = 14;

pub(crate) mod arcs;
mod store;
mod update;

impl GpuScene {
    /// Uploads a (validated) scene whose renders compute only each view's window (`windows[v]`; None or
    /// past the end: the whole image): see [`layout::TileWindow`]. Arcs as `arc_chords` chords
    /// each (None: the accuracy bar's rule, [`crate::arcs::chord_count`]).
    pub(super) fn new_in(
        ctx: &std::sync::Arc<Context>,
        scene: &Scene,
        windows: &[Option<layout::TileWindow>],
        arc_chords: Option<u32>,
    ) -> Result<GpuScene, GpuError> {
        if crate::arcs::any_arc(&scene.scratches) {
            let mode = arcs::ChordMode::of(arc_chords);
            let mut chords = scene.clone();
            chords.scratches = match mode {
                // The rule's expansion names an arc over the cap.
                arcs::ChordMode::Rule => crate::arcs::expand(&scene.scratches)?,
                _ => scene
                    .scratches
                    .iter()
                    .zip(mode.counts(&scene.scratches))
                    .flat_map(|(s, n)| s.chords(n as usize))
                    .collect(),
            };
            return GpuScene::new_arcs(ctx, scene, chords, mode, windows);
        }
        GpuScene::new_kernel_scene(ctx, scene, windows)
    }

    /// [`GpuScene::new_in`] of the kernels' own scratches (straight; for a scene with arcs, its
    /// chords, which `shaders/arc_map.comp` writes again with their weights before every render).
    fn new_kernel_scene(
        ctx: &std::sync::Arc<Context>,
        scene: &Scene,
        windows: &[Option<layout::TileWindow>],
    ) -> Result<GpuScene, GpuError> {
        // Every size against the device before anything is allocated.
        let sizes: Vec<(u32, u32)> = scene.views.iter().map(|v| (v.camera.width, v.camera.height)).collect();
        let mut dims = crate::limits::SceneDims::new(&sizes, scene.scratches.len() as u64, false);
        if let Some((what, size, limit)) = dims.over_device_limit(ctx.info()) {
            return Err(GpuError::BufferTooLarge {
                name: format!(
                    "{what} ({} pixels in {} views, {} scratches)",
                    dims.pixels, dims.views, dims.scratches
                ),
                size,
                limit,
            });
        }
        if let Some(why) = dims.over_loop_limit(ctx.info()) {
            return Err(GpuError::Capacity(format!("{why}; use smaller views")));
        }
        if let Some(why) = dims.over_device_memory(ctx.info()) {
            return Err(GpuError::Capacity(format!(
                "{why}; reduce the scene (fewer scratches, views or pixels)"
            )));
        }
        let slots = layout::view_slots_in(scene, windows);
        assert_eq!(slots.n_pixels, dims.pixels, "one count of pixels");
        assert!(slots.n_tiles as u64 <= dims.tiles, "a window is part of its image");
        // The tiles a render computes: the windows' (the limits above held for whole images).
        dims.tiles = slots.n_tiles as u64;
        let n_scratches = scene.scratches.len() as u32;
        let mode = BinMode::for_device(ctx.info());
        let n_groups = dims.groups() as u32;
        let max_rows = slots.views.iter().map(|v| v.dims[3]).max().unwrap_or(1);
        let threads = match mode {
            BinMode::Groups => n_groups,
            BinMode::Pairs => n_scratches.max(1),
        };
        let n_bands = binning_bands(ctx.info(), n_scratches, threads, scene.views.len() as u32, max_rows);
        let (sbase, sbase_sums) =
            scratch_base_buffers(ctx, n_scratches, binning_parts(n_bands, scene.views.len() as u32))?;
        let scr: Vec<ScratchGpu> = scene.scratches.iter().map(ScratchGpu::from).collect();
        let phi: Vec<f32> = scene.views.iter().map(|v| v.radiance_scale() as f32).collect();
        let hist_len = match mode {
            BinMode::Groups => dims.offsets_len(),
            BinMode::Pairs => dims.tiles + 1,
        };
        let (hist, cursor, sums) = offset_buffers(ctx, hist_len)?;
        let capacity = dims.first_list_capacity(ctx.info().max_storage_buffer_range);
        let gpu_only = |name: &str, bytes: u64| Buffer::new(ctx, name, bytes, MemLoc::GpuOnly);
        // Host-visible so a viewer can move cameras and lights every frame without reallocating
        // (see `update_views`).
        let host = |name: &str, bytes: &[u8]| -> Result<Buffer, GpuError> {
            let b = Buffer::new(ctx, name, bytes.len() as u64, MemLoc::CpuToGpu)?;
            b.write(0, bytes)?;
            Ok(b)
        };
        let views = host("views", bytemuck::cast_slice(&slots.views))?;
        let views64 = host("views (float64 cameras)", bytemuck::cast_slice(&slots.views64))?;
        let scratches = ctx.upload("scratches", &scr)?;
        let records = Buffer::new_texel(ctx, "scratch records", dims.records_bytes(), MemLoc::GpuOnly)?;
        let pixel_records = Buffer::new_texel(ctx, "pixel records", dims.pixel_records_bytes(), MemLoc::GpuOnly)?;
        // Host-visible too (the viewer's light slider); Adam writes it on the device.
        let lights = host("light intensities", bytemuck::cast_slice(&phi))?;
        let list = Buffer::new_u32_texel(ctx, "tile lists", capacity as u64 * 4, MemLoc::GpuOnly)?;
        let pair_sort = match mode {
            BinMode::Pairs => Some(PairSort::new(ctx, capacity)?),
            BinMode::Groups => None,
        };
        let inv = gpu_only("entry inverse map", capacity as u64 * 4)?;
        let partials = gpu_only("partial gradients", capacity as u64 * 32)?;
        let cov_raw = gpu_only("coverage", dims.image_bytes())?;
        let dl = gpu_only("dE/dL", dims.image_bytes())?;
        let grad = gpu_only("scratch gradients", dims.scratch_bytes())?;
        let grad_light = gpu_only("light gradients", scene.views.len() as u64 * 4)?;
        let image = gpu_only("image", dims.image_bytes())?;
        let stats = Buffer::new(ctx, "stats", 64, MemLoc::GpuToCpu)?;
        let carry = gpu_only("shading carry (unused: one pass)", 16)?;
        let pair_store = Buffer::new_u32_texel(ctx, "pair store (unused: no replay yet)", 16, MemLoc::GpuOnly)?;
        let unbound = Buffer::new_u32_texel(ctx, "unused shading slot", 16, MemLoc::GpuOnly)?;
        Ok(GpuScene {
            inputs: SceneInputs {
                views,
                views64,
                scratches,
                records,
                pixel_records,
                lights,
            },
            bin: Binning {
                hist,
                cursor,
                sums,
                list,
                capacity,
                sbase,
                sbase_sums,
                n_bands,
                mode,
                pair_sort,
                inv,
                group_size: if mode == BinMode::Pairs { 1 } else { GROUP_SIZE },
            },
            shading: Shading {
                shade: ShadePush {
                    half_plate: (scene.plate.size_mm * 0.5) as f32,
                    alpha_s: scene.plate.roughness as f32,
                    f0: scene.plate.f0 as f32,
                    n_views: scene.views.len() as u32,
                    // the stride of the scanned histogram: per tile in the pairs mode
                    n_groups: if mode == BinMode::Pairs { 1 } else { n_groups },
                    n_tiles: slots.n_tiles,
                    capacity,
                    chunks_per_pass: u32::MAX,
                    pass: 0,
                    n_passes: 1,
                    sentinel: 2,
                    store_cap: 0,
                },
                cov_raw,
                image,
                carry,
                pair_store,
                fwd_plan: PassPlan::ONE,
                bwd_plan: PassPlan::ONE,
                unbound,
            },
            backward: Backward {
                dl,
                partials,
                grad,
                grad_light,
            },
            stats,
            store_wanted: std::sync::atomic::AtomicBool::new(false),
            store_off: false,
            shape: scene.plate.shape,
            arcs: None,
            n_scratches,
            // binning threads per part: scratch groups, or scratches in the pairs mode
            n_groups: threads,
            slots,
        })
    }

    /// The counters of the last render (`stats` is host-visible: a small read, no copy).
    pub fn stats(&self) -> Result<RenderStats, GpuError> {
        Ok(Self::counters(&self.stats.read()?))
    }

    /// The counters in the raw words of `stats` (layout: `shaders/inc/limits.glsl`).
    pub(super) fn counters(st: &[u32]) -> RenderStats {
        RenderStats {
            candidates: (st[8] as u64) << 32 | st[0] as u64,
            pairs: (st[10] as u64) << 32 | st[1] as u64,
            entries: st[2] as u64,
            max_tile_chunks: st[4] as u64,
            culled: (st[12] as u64) << 32 | st[11] as u64,
            bin_tests_per_thread: st[15] as u64,
        }
    }

    /// The raw words of the render counters and flags (one read of a small host-visible buffer).
    pub(super) fn raw_stats(&self) -> Result<Vec<u32>, GpuError> {
        self.stats.read()
    }

    /// Whether the last render (and the backward pass recorded with it) did all its work: the
    /// tile lists held every entry, and no kernel hit a capacity (`shaders/inc/limits.glsl`).
    pub(super) fn complete(&self, raw: &[u32]) -> bool {
        raw[2] as u64 <= self.bin.capacity as u64 && raw[5] == 0 && raw[STAT_ENTRIES_WRAPPED as usize] == 0
    }

    /// After an incomplete render: grows the tile lists, splits binning into smaller groups or
    /// the shading into more passes, as the counters say. Errors when a limit cannot be met by
    /// splitting (one scratch, or one chunk, already over it).
    pub(super) fn adapt(&mut self, ctx: &std::sync::Arc<Context>, raw: &[u32]) -> Result<(), GpuError> {
        let stats = Self::counters(raw);
        let limit_err = |what: &str| {
            GpuError::Capacity(format!(
                "{what} needs more loop iterations in one shader invocation than this device allows \
             (Mesa's llvmpipe stops every loop after 65535 in all); use smaller views (fewer \
             tiles per scratch) or a GPU"
            ))
        };
        if raw[STAT_ENTRIES_WRAPPED as usize] != 0 {
            return Err(GpuError::Capacity(format!(
                "the scene has more than {} (tile, scratch) pairs for the pair search to count; \
                 use fewer or narrower scratches, or fewer or smaller views",
                u32::MAX
            )));
        }
        if raw[7] != 0 {
            // Binning hit the loop limit: fewer scratches per binning thread.
            if self.bin.group_size == 1 || self.bin.mode == BinMode::Pairs {
                return Err(limit_err("binning a single scratch over every tile it crosses"));
            }
            self.set_group_size(ctx, self.bin.group_size / 2)?;
            return Ok(());
        }
        if stats.entries > self.bin.capacity as u64 {
            return self.grow_list(ctx, stats.entries);
        }
        let max_chunks = raw[4];
        for (hit, plan, what) in [
            (raw[3], &mut self.shading.fwd_plan, "shading one chunk of 64 scratches"),
            (
                raw[6],
                &mut self.shading.bwd_plan,
                "the gradient of one chunk of 64 scratches",
            ),
        ] {
            if hit != 0 {
                let m = plan.split(max_chunks).ok_or_else(|| limit_err(what))?;
                *plan = PassPlan::covering(m, max_chunks);
            }
        }
        // Lists that grew since the plans were made.
        if !self.shading.fwd_plan.covers(max_chunks) {
            self.shading.fwd_plan = PassPlan::covering(self.shading.fwd_plan.chunks_per_pass, max_chunks);
        }
        if !self.shading.bwd_plan.covers(max_chunks) {
            self.shading.bwd_plan = PassPlan::covering(self.shading.bwd_plan.chunks_per_pass, max_chunks);
        }
        if raw[STAT_STORE_FLAGS] & 2 != 0 {
            self.drop_store(ctx, true)?;
        } else if raw[STAT_STORE_FLAGS] & 1 != 0 {
            // The replay met a chunk the forward could not store: a store for all of them.
            self.size_store(ctx, raw[STAT_STORE_NEEDED] as u64)?;
        }
        self.ensure_carry(ctx)
    }

    /// The buffer of per-pixel sums between forward passes, once there is more than one.
    fn ensure_carry(&mut self, ctx: &std::sync::Arc<Context>) -> Result<(), GpuError> {
        if self.shading.fwd_plan.passes > 1 && self.shading.carry.size() < self.slots.n_pixels * 16 {
            self.shading.carry = Buffer::new(
                ctx,
                "shading carry (sums between passes)",
                self.slots.n_pixels.max(1) * 16,
                MemLoc::GpuOnly,
            )?;
        }
        Ok(())
    }

    /// Scratches per binning thread; reallocates the per-(tile, group) buffers.
    fn set_group_size(&mut self, ctx: &std::sync::Arc<Context>, group_size: u32) -> Result<(), GpuError> {
        self.bin.group_size = group_size.max(1);
        self.n_groups = self.n_scratches.div_ceil(self.bin.group_size).max(1);
        self.shading.shade.n_groups = self.n_groups;
        let hist_len = self.slots.n_tiles as u64 * self.n_groups as u64 + 1;
        if hist_len * 4 > ctx.info().max_storage_buffer_range {
            return Err(GpuError::BufferTooLarge {
                name: format!(
                    "pair-search offsets ({} tiles x {} scratch groups)",
                    self.slots.n_tiles, self.n_groups
                ),
                size: hist_len * 4,
                limit: ctx.info().max_storage_buffer_range,
            });
        }
        (self.bin.hist, self.bin.cursor, self.bin.sums) = offset_buffers(ctx, hist_len)?;
        Ok(())
    }

    /// Test hook: split every tile's shading into passes of `chunks` chunks (forward and
    /// backward), as the host does after a device's loop limit was hit. Results must not change.
    #[doc(hidden)]
    pub fn force_chunks_per_pass(
        &mut self,
        ctx: &std::sync::Arc<Context>,
        chunks: u32,
        max_chunks: u32,
    ) -> Result<(), GpuError> {
        self.shading.fwd_plan = PassPlan::covering(chunks.max(1), max_chunks);
        self.shading.bwd_plan = self.shading.fwd_plan;
        self.ensure_carry(ctx)
    }

    /// The passes the forward and the backward kernel run per render (1 unless a device limit
    /// made the host split them).
    pub fn shading_passes(&self) -> (u32, u32) {
        (self.shading.fwd_plan.passes, self.shading.bwd_plan.passes)
    }

    /// Scratches per binning thread (64 unless a device limit made the host split them).
    pub fn binning_group_size(&self) -> u32 {
        self.bin.group_size
    }

    /// Bands of tile rows per view that binning splits its work into (0: none, one thread per
    /// scratch group does every view: CPU drivers).
    pub fn binning_bands(&self) -> u32 {
        self.bin.n_bands
    }

    /// How binning spreads its work over threads ([`BinMode::for_device`] unless forced).
    pub fn binning_mode(&self) -> BinMode {
        self.bin.mode
    }

    /// Bins in `mode` from the next render, with the device's choice of bands for it (tests
    /// and benchmarks: tile lists, images and gradients must not change).
    pub fn force_binning_mode(&mut self, ctx: &std::sync::Arc<Context>, mode: BinMode) -> Result<(), GpuError> {
        if mode == self.bin.mode {
            return Ok(());
        }
        self.bin.mode = mode;
        let n_views = self.shading.shade.n_views;
        let max_rows = self.slots.views.iter().map(|v| v.dims[3]).max().unwrap_or(1);
        match mode {
            BinMode::Pairs => {
                self.bin.group_size = 1;
                self.n_groups = self.n_scratches.max(1);
                self.shading.shade.n_groups = 1;
                (self.bin.hist, self.bin.cursor, self.bin.sums) = offset_buffers(ctx, self.slots.n_tiles as u64 + 1)?;
                self.bin.pair_sort = Some(PairSort::new(ctx, self.bin.capacity)?);
            }
            BinMode::Groups => {
                self.bin.pair_sort = None;
                self.set_group_size(ctx, crate::GROUP_SIZE)?;
            }
        }
        let n_bands = binning_bands(ctx.info(), self.n_scratches, self.n_groups, n_views, max_rows);
        self.force_binning_bands(ctx, n_bands)
    }

    /// Test hook: the tile lists of the last render, read back: (first entry of each tile and
    /// the total, n_tiles + 1 words; the lists; the scratch-major entry -> list position map).
    #[doc(hidden)]
    pub fn tile_lists(&self, ctx: &std::sync::Arc<Context>) -> Result<TileLists, GpuError> {
        let hist: Vec<u32> = ctx.download(&self.bin.hist)?;
        let stride = self.shading.shade.n_groups as usize;
        let offsets: Vec<u32> = (0..=self.slots.n_tiles as usize).map(|t| hist[t * stride]).collect();
        let n = *offsets.last().unwrap_or(&0) as usize;
        let mut list: Vec<u32> = ctx.download(&self.bin.list)?;
        let mut inv: Vec<u32> = ctx.download(&self.bin.inv)?;
        list.truncate(n);
        inv.truncate(n);
        Ok(TileLists { offsets, list, inv })
    }

    /// The push constants of `bin.comp` for this scene's mode (in the pairs mode a "group" is
    /// one scratch).
    pub(super) fn bin_push(&self) -> super::layout::BinPush {
        super::layout::BinPush {
            n_scratches: self.n_scratches,
            n_views: self.shading.shade.n_views,
            n_groups: self.n_groups,
            group_size: self.bin.group_size,
            capacity: self.bin.capacity,
            sentinel: 2,
            n_bands: self.bin.n_bands,
            pad: 0,
        }
    }

    /// Threads of binning's pass over (scratch, tile) work: scratch groups (or scratches, in the
    /// pairs mode) x binning parts.
    pub fn binning_threads(&self) -> u64 {
        self.n_groups as u64 * self.n_parts() as u64
    }

    /// Binning parts per scratch: `binning_bands` x views, or 1.
    pub(super) fn n_parts(&self) -> u32 {
        binning_parts(self.bin.n_bands, self.shading.shade.n_views)
    }

    /// Entries of `sbase` (per scratch and binning part, plus the total).
    pub(super) fn sbase_len(&self) -> u64 {
        self.n_scratches as u64 * self.n_parts() as u64 + 1
    }

    /// Test hook: bin with `n_bands` bands of tile rows per view (0: none), as a GPU would.
    /// Tile lists, images and gradients must not change.
    #[doc(hidden)]
    pub fn force_binning_bands(&mut self, ctx: &std::sync::Arc<Context>, n_bands: u32) -> Result<(), GpuError> {
        self.bin.n_bands = n_bands;
        (self.bin.sbase, self.bin.sbase_sums) = scratch_base_buffers(ctx, self.n_scratches, self.n_parts())?;
        Ok(())
    }

    pub fn n_scratches(&self) -> u32 {
        self.n_scratches
    }

    pub fn n_views(&self) -> u32 {
        self.shading.shade.n_views
    }

    /// Pixels of all views together (the length of `image`, `dl`).
    pub fn n_pixels(&self) -> u64 {
        self.slots.n_pixels
    }

    /// The cameras as the kernels see them (image sizes, first pixel of each view).
    pub fn views(&self) -> &[layout::ViewGpu] {
        &self.slots.views
    }

    /// The cameras on the device (`ViewGPU` per view).
    pub fn views_buffer(&self) -> &Buffer {
        &self.inputs.views
    }

    /// Half the plate size, mm.
    pub fn half_plate(&self) -> f32 {
        self.shading.shade.half_plate
    }

    /// Scratch parameters, one [`ScratchGpu`] per scratch: read by every kernel, moved by the
    /// optimizer.
    pub fn scratches(&self) -> &Buffer {
        &self.inputs.scratches
    }

    /// Light intensity Phi of each view (f32 each).
    pub fn lights(&self) -> &Buffer {
        &self.inputs.lights
    }

    /// L of every view, concatenated (row-major, top row first; view v starts at
    /// `views()[v].base[1]`).
    pub fn image(&self) -> &Buffer {
        &self.shading.image
    }

    /// dE/dL per pixel, laid out like [`image`](Self::image): the input of the backward pass.
    pub fn dl(&self) -> &Buffer {
        &self.backward.dl
    }

    /// Per scratch: dE/d(x0, y0, x1, y1, w, d, alpha) and one unused float (8 f32).
    pub fn scratch_grad(&self) -> &Buffer {
        &self.backward.grad
    }

    /// Per view: dE/dPhi of its light.
    pub fn light_grad(&self) -> &Buffer {
        &self.backward.grad_light
    }

    /// The render counters on the device ([0] candidates, [1] pairs, [2] tile-list entries).
    pub fn stats_buffer(&self) -> &Buffer {
        &self.stats
    }

    /// Capacity of the tile lists (entries): a render whose `entries` exceed it is incomplete.
    pub fn capacity(&self) -> u32 {
        self.bin.capacity
    }

    /// Replaces the tile-list buffers by ones that hold `entries` (plus slack).
    pub(super) fn grow_list(&mut self, ctx: &std::sync::Arc<Context>, entries: u64) -> Result<(), GpuError> {
        let want = entries + entries / 4 + 1024;
        // The partial-gradient buffer (32 bytes per entry) is the largest of the three.
        if want * 32 > ctx.info().max_storage_buffer_range || want > u32::MAX as u64 {
            return Err(GpuError::BufferTooLarge {
                name: "partial gradients (one per tile-list entry)".into(),
                size: want * 32,
                limit: ctx.info().max_storage_buffer_range,
            });
        }
        // The shading kernels gather the lists through a texel view (`Buffer::new_u32_texel`).
        self.bin.list = Buffer::new_u32_texel(ctx, "tile lists", want * 4, MemLoc::GpuOnly)?;
        self.bin.inv = Buffer::new(ctx, "entry inverse map", want * 4, MemLoc::GpuOnly)?;
        self.backward.partials = Buffer::new(ctx, "partial gradients", want * 32, MemLoc::GpuOnly)?;
        self.bin.capacity = want as u32;
        self.shading.shade.capacity = self.bin.capacity;
        if self.bin.mode == BinMode::Pairs {
            self.bin.pair_sort = Some(PairSort::new(ctx, self.bin.capacity)?);
        }
        // The store's chunk records are laid out by list position: a new store when asked.
        if self.shading.shade.store_cap > 0 {
            self.want_store();
        }
        self.drop_store(ctx, false)
    }
}
