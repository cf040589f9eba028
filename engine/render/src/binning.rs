//! Binning's modes and what they need beside the scene: the sort's buffers of the pairs mode,
//! the bands of tile rows a device bins with, the per-(scratch, part) bases, the tile lists read
//! back (see `shaders/bin.comp` and `shaders/radix.comp`).
use crate::vulkan::{Buffer, Context, GpuError, MemLoc};

use super::{GROUP_SIZE, SCAN_BLOCK};

/// How binning spreads its work over threads. Both give the same tile lists in the same order
/// (every tile's scratches in increasing index), so the same images and gradients, bit for bit
/// (`tests/dense.rs::binning_modes_give_the_same_tile_lists`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinMode {
    /// One thread per group of [`crate::GROUP_SIZE`] scratches (on GPUs per group, view and band
    /// of tile rows) counts into a (tile, group) histogram, which a scan turns into list
    /// positions (`shaders/bin.comp`). Few threads, each doing much: CPU drivers, whose threads
    /// are few. Its histogram has tiles x groups entries, scanned every render.
    Groups,
    /// One thread per (scratch, view) (and band) counts and emits its (tile, scratch) pairs in
    /// scratch order, and a stable radix sort by tile, 8 bits a pass, orders them
    /// (`shaders/radix.comp`): as many threads as pairs at every step, no loop longer than one
    /// scratch's tiles or 46 (the sort's rank). GPUs.
    Pairs,
}

impl BinMode {
    pub fn name(self) -> &'static str {
        match self {
            BinMode::Groups => "groups",
            BinMode::Pairs => "pairs",
        }
    }

    /// `groups` or `pairs`.
    pub fn parse(s: &str) -> Option<BinMode> {
        match s {
            "groups" => Some(BinMode::Groups),
            "pairs" => Some(BinMode::Pairs),
            _ => None,
        }
    }

    /// The device's mode: groups on a CPU driver, pairs on a GPU.
    pub fn for_device(info: &crate::vulkan::DeviceInfo) -> BinMode {
        if info.kind == "cpu" {
            BinMode::Groups
        } else {
            BinMode::Pairs
        }
    }
}

/// The buffers of [`BinMode::Pairs`]'s sort, each one word per tile-list entry (the emitted
/// keys are the tile lists' own buffer), and the per-(digit, block) counts.
pub(crate) struct PairSort {
    /// the keys' second buffer (the first is `list`)
    pub keys: Buffer,
    /// the values (emission indices), ping-pong
    pub vals: [Buffer; 2],
    /// the scratch of each emission index
    pub scratch_of: Buffer,
    /// 256 x `blocks` digit counts, scanned in place
    pub digits: Buffer,
    pub digit_sums: Buffer,
    /// blocks of 256 entries that cover the capacity
    pub blocks: u32,
}

impl PairSort {
    pub(crate) fn new(ctx: &std::sync::Arc<Context>, capacity: u32) -> Result<PairSort, GpuError> {
        let cap = capacity.max(1) as u64;
        let blocks = cap.div_ceil(256);
        let gpu_only = |name: &str, words: u64| Buffer::new(ctx, name, words * 4, MemLoc::GpuOnly);
        Ok(PairSort {
            keys: gpu_only("pair sort keys", cap)?,
            vals: [gpu_only("pair sort values", cap)?, gpu_only("pair sort values", cap)?],
            scratch_of: gpu_only("pair sort scratches", cap)?,
            digits: gpu_only("pair sort digit counts", blocks * 256)?,
            digit_sums: gpu_only("pair sort scan sums", (blocks * 256).div_ceil(SCAN_BLOCK as u64))?,
            blocks: blocks as u32,
        })
    }
}

/// The tile lists as [`GpuScene::tile_lists`] reads them back.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TileLists {
    /// first entry of each tile, then the total
    pub offsets: Vec<u32>,
    /// scratch indices, tile by tile
    pub list: Vec<u32>,
    /// scratch-major entry -> list position
    pub inv: Vec<u32>,
}

/// Radix passes of 8 bits that sort tile indices below `n_tiles` (at least one).
pub fn radix_passes(n_tiles: u32) -> u32 {
    let bits = 32 - n_tiles.saturating_sub(1).leading_zeros();
    bits.div_ceil(8).max(1)
}

/// Bands of tile rows per view for binning on this device: none on a CPU driver (its threads
/// are few, and each band would project its scratches again); on a GPU enough for about 64k
/// binning threads (scratch groups x views x bands), at most the views' tile rows, and at most
/// 16 M (scratch, part) bases (64 MiB).
pub(crate) fn binning_bands(
    info: &crate::vulkan::DeviceInfo,
    n_scratches: u32,
    n_groups: u32,
    n_views: u32,
    max_rows: u32,
) -> u32 {
    if info.kind == "cpu" {
        return 0;
    }
    gpu_bands(n_scratches, n_groups, n_views, max_rows)
}

/// The bands of tile rows per view a GPU bins `mode` with (a CPU driver: none). For statements
/// of binning's work that do not depend on the device (`scratchart bench --binning-work`).
pub fn bands_on_gpu(mode: BinMode, n_scratches: u32, n_views: u32, max_rows: u32) -> u32 {
    let threads = match mode {
        BinMode::Groups => n_scratches.div_ceil(GROUP_SIZE).max(1),
        BinMode::Pairs => n_scratches.max(1),
    };
    gpu_bands(n_scratches, threads, n_views, max_rows)
}

/// Enough bands for about 64k binning threads (`n_groups` threads per part x views x bands), at
/// most the views' tile rows, and at most 16 M (scratch, part) bases (64 MiB).
fn gpu_bands(n_scratches: u32, n_groups: u32, n_views: u32, max_rows: u32) -> u32 {
    let jobs = (n_groups as u64 * n_views.max(1) as u64).max(1);
    let want = 65_536u64.div_ceil(jobs);
    let fit = ((16u64 << 20) / (n_scratches.max(1) as u64 * n_views.max(1) as u64)).max(1);
    want.min(max_rows.max(1) as u64).min(fit).max(1) as u32
}

/// Binning parts per scratch with `n_bands` bands of tile rows per view: one per band and view,
/// or 1 without bands.
pub(crate) fn binning_parts(n_bands: u32, n_views: u32) -> u32 {
    if n_bands == 0 {
        1
    } else {
        n_views * n_bands
    }
}

/// `sbase` (per scratch and binning part, plus the total) and its scan's block sums.
pub(crate) fn scratch_base_buffers(
    ctx: &std::sync::Arc<Context>,
    n_scratches: u32,
    parts: u32,
) -> Result<(Buffer, Buffer), GpuError> {
    let len = n_scratches as u64 * parts as u64 + 1;
    Ok((
        Buffer::new(ctx, "scratch entry bases", len * 4, MemLoc::GpuOnly)?,
        Buffer::new(
            ctx,
            "scan block sums (scratches)",
            len.div_ceil(SCAN_BLOCK as u64) * 4,
            MemLoc::GpuOnly,
        )?,
    ))
}

/// The pair search's offsets of `len` words (scanned in place), their copy as cursors, and the
/// scan's block sums.
pub(crate) fn offset_buffers(ctx: &std::sync::Arc<Context>, len: u64) -> Result<(Buffer, Buffer, Buffer), GpuError> {
    Ok((
        Buffer::new(ctx, "bin offsets", len * 4, MemLoc::GpuOnly)?,
        Buffer::new(ctx, "bin cursors", len * 4, MemLoc::GpuOnly)?,
        Buffer::new(
            ctx,
            "scan block sums",
            len.div_ceil(SCAN_BLOCK as u64) * 4,
            MemLoc::GpuOnly,
        )?,
    ))
}
