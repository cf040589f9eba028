//! Sizes checked against the device's and the host's limits before anything is allocated or
//! computed, so a scene that cannot run fails at once with a message that says what to reduce
//! and the largest value that fits, instead of minutes later naming an internal buffer.
//!
//! The sizes of [`crate::GpuScene`]'s buffers have one source: the methods of [`SceneDims`],
//! which `GpuScene::new` allocates by and [`SceneDims::buffers`] checks. The design loss's
//! pyramid (`scratchart_optim::loss::Loss`) is bounded here from above (4/3 of the pixels).
use crate::layout::{PIXEL_RECORD_BYTES, SCRATCH_RECORD_BYTES, TILE};
use crate::vulkan::DeviceInfo;

/// The quantities that decide how large the device buffers are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneDims {
    /// Pixels of all views together.
    pub pixels: u64,
    /// 16x16 tiles of all views together.
    pub tiles: u64,
    pub views: u64,
    pub scratches: u64,
    /// Whether the design loss (and its pyramid) is allocated too.
    pub with_loss: bool,
    /// Pixels of the largest view.
    pub max_view_pixels: u64,
}

/// Pixels one thread of the per-view reductions (light gradient, check loss, loss statistics)
/// may walk on a device that caps loop iterations per shader invocation (Mesa's llvmpipe: 65535
/// in all): 256 threads x 60,000 iterations, with a margin for the kernel's other loops.
pub const LOOP_CAPPED_VIEW_PIXELS: u64 = 256 * 60_000;

/// Whether the device stops shader loops after a fixed number of iterations (see
/// `shaders/inc/limits.glsl`).
pub fn caps_loops(info: &DeviceInfo) -> bool {
    info.name.contains("llvmpipe")
}

/// The per-scratch records buffer of the shading kernels (a storage and a texel buffer).
const RECORDS: &str = "scratch records of the shading kernels (4 texels each)";
/// The per-pixel records of the shading kernels (a texel buffer only: bounded by the device's
/// texel count, not by its storage-buffer range).
const PIXEL_RECORDS: &str = "pixel records of the shading kernels (5 texels per pixel)";

impl SceneDims {
    /// `views` of W x H pixels each.
    pub fn new(view_sizes: &[(u32, u32)], scratches: u64, with_loss: bool) -> SceneDims {
        let pixels = view_sizes.iter().map(|&(w, h)| w as u64 * h as u64).sum();
        let tiles = view_sizes
            .iter()
            .map(|&(w, h)| w.div_ceil(TILE) as u64 * h.div_ceil(TILE) as u64)
            .sum();
        SceneDims {
            pixels,
            tiles,
            views: view_sizes.len() as u64,
            scratches,
            with_loss,
            max_view_pixels: view_sizes.iter().map(|&(w, h)| w as u64 * h as u64).max().unwrap_or(0),
        }
    }

    /// Scratch groups of the pair search (`GROUP_SIZE` scratches each; at least one).
    pub fn groups(&self) -> u64 {
        self.scratches.div_ceil(crate::GROUP_SIZE as u64).max(1)
    }

    /// Bytes of one per-pixel float image of all views (the image, coverage, dE/dL).
    pub fn image_bytes(&self) -> u64 {
        self.pixels * 4
    }

    /// Entries of the pair search's offsets: one per tile and scratch group, and one past the end.
    pub fn offsets_len(&self) -> u64 {
        self.tiles * self.groups() + 1
    }

    /// Bytes of the scratch parameters, and of their gradients (8 floats per scratch).
    pub fn scratch_bytes(&self) -> u64 {
        self.scratches.max(1) * 32
    }

    /// Bytes of the shading kernels' per-scratch records.
    pub fn records_bytes(&self) -> u64 {
        self.scratches.max(1) * SCRATCH_RECORD_BYTES
    }

    /// Bytes of the shading kernels' per-pixel records.
    pub fn pixel_records_bytes(&self) -> u64 {
        self.pixels.max(1) * PIXEL_RECORD_BYTES
    }

    /// The tile lists' first capacity, in entries: a guess (four tiles per scratch and view, at
    /// least 2^16) that the renderer grows on demand after the first binning, bounded so that
    /// the 32-byte partial gradient of each entry fits `max_range` bytes.
    pub fn first_list_capacity(&self, max_range: u64) -> u32 {
        (self.scratches * self.views * 4).max(1 << 16).min(max_range / 32) as u32
    }

    /// Entries of the pair search's offsets in `mode`: per tile and scratch group (groups), or
    /// per tile (pairs), and one past the end.
    pub fn offsets_len_in(&self, mode: crate::BinMode) -> u64 {
        match mode {
            crate::BinMode::Groups => self.offsets_len(),
            crate::BinMode::Pairs => self.tiles + 1,
        }
    }

    /// The device buffers that grow with the scene on `info`'s device (its binning mode): (what,
    /// bytes), largest first.
    pub fn buffers(&self, info: &DeviceInfo) -> Vec<(&'static str, u64)> {
        let offsets = match crate::BinMode::for_device(info) {
            crate::BinMode::Groups => ("pair-search offsets (tiles x scratch groups)", self.offsets_len() * 4),
            crate::BinMode::Pairs => ("pair-search offsets (one per tile)", (self.tiles + 1) * 4),
        };
        let mut b = vec![
            ("per-pixel images (image, coverage, dE/dL), each", self.image_bytes()),
            offsets,
            ("scratch parameters and gradients, each", self.scratch_bytes()),
            (RECORDS, self.records_bytes()),
            // A lower bound: every visible scratch is listed in at least one tile per view; the
            // lists grow with the scene's pairs (and are checked again then).
            (
                "partial gradients (one per tile-list entry)",
                (self.scratches * self.views).max(1 << 16) * 32,
            ),
        ];
        if self.with_loss {
            // The pyramid has at most 4/3 of the pixels; the loss keeps 5 filter responses each.
            let pyr = self.pixels + self.pixels / 3 + self.views;
            b.push(("loss filter responses (5 per pyramid pixel)", pyr * 5 * 4));
        }
        b.sort_by_key(|b| std::cmp::Reverse(b.1));
        b
    }

    /// The first buffer over the device's per-buffer limit, if any: (what, bytes, limit).
    pub fn over_device_limit(&self, info: &DeviceInfo) -> Option<(&'static str, u64, u64)> {
        let limit = info.max_storage_buffer_range;
        // The records are also texel buffers: 16-byte texels, at most maxTexelBufferElements.
        let texel_limit = info.max_texel_buffer_elements.saturating_mul(16);
        let texels = [(PIXEL_RECORDS, self.pixel_records_bytes())];
        self.buffers(info)
            .into_iter()
            .find_map(|(n, b)| {
                let limit = if n == RECORDS { limit.min(texel_limit) } else { limit };
                (b > limit).then_some((n, b, limit))
            })
            .or_else(|| {
                texels
                    .into_iter()
                    .find_map(|(n, b)| (b > texel_limit).then_some((n, b, texel_limit)))
            })
    }

    /// Device memory the scene's buffers take at least on `info`'s device: every buffer of an
    /// upload at its first size (the tile lists and what goes with them grow with the pairs
    /// after the first render; the backward's pair store is taken only where memory is left),
    /// and the design loss's where it is allocated. Checked against the allocator in
    /// `tests/limits.rs`.
    pub fn device_bytes(&self, info: &DeviceInfo) -> u64 {
        self.device_bytes_in(info, crate::BinMode::for_device(info))
    }

    /// [`device_bytes`](Self::device_bytes) with binning in `mode`.
    pub fn device_bytes_in(&self, info: &DeviceInfo, mode: crate::BinMode) -> u64 {
        let cap = self.first_list_capacity(info.max_storage_buffer_range) as u64;
        // list, inverse map and partial gradients per entry; the sort's keys, two values and
        // scratches, and its digit counts, in the pairs mode
        let per_entry = match mode {
            crate::BinMode::Groups => 4 + 4 + 32,
            crate::BinMode::Pairs => 4 + 4 + 32 + 16 + 4,
        };
        let offsets = self.offsets_len_in(mode);
        let mut bytes = 3 * self.image_bytes()
            + 2 * self.scratch_bytes()
            + self.records_bytes()
            + self.pixel_records_bytes()
            + 2 * offsets * 4
            + (self.scratches + 1) * 4
            + cap * per_entry;
        if self.with_loss {
            // Its pyramid's filter responses (a lower bound of the loss's buffers).
            bytes += (self.pixels + self.pixels / 3) * 5 * 4;
        }
        bytes
    }

    /// Where the buffers need more than the device's memory (a lower bound, see
    /// [`device_bytes`](Self::device_bytes)): what they need and what it has.
    pub fn over_device_memory(&self, info: &DeviceInfo) -> Option<String> {
        let need = self.device_bytes(info);
        (info.device_memory > 0 && need > info.device_memory).then(|| {
            format!(
                "the buffers of {} pixels in {} views and {} scratches need at least {} of device memory but this device has {}",
                self.pixels,
                self.views,
                self.scratches,
                mib(need),
                mib(info.device_memory)
            )
        })
    }

    /// Host memory the job needs at least (targets, images read back, reports): a lower bound.
    pub fn host_bytes(&self) -> u64 {
        // Targets, linear and display images, compare images: about a dozen f32 per pixel.
        self.pixels * 48 + self.scratches * 128
    }

    /// A view too large for the per-view reductions on a device that caps loop iterations.
    pub fn over_loop_limit(&self, info: &DeviceInfo) -> Option<String> {
        (caps_loops(info) && self.max_view_pixels > LOOP_CAPPED_VIEW_PIXELS).then(|| {
            format!(
                "a view of {} pixels is over the {} pixels per view that this device's loop limit \
                 allows (Mesa's llvmpipe stops shader loops after 65535 iterations)",
                self.max_view_pixels, LOOP_CAPPED_VIEW_PIXELS
            )
        })
    }

    /// Whether the scene fits the device and the host. The message names the limit.
    pub fn check(&self, info: &DeviceInfo) -> Result<(), String> {
        if let Some((what, bytes, limit)) = self.over_device_limit(info) {
            return Err(format!(
                "the {what} need {} but this device binds at most {} per storage buffer",
                mib(bytes),
                mib(limit)
            ));
        }
        if let Some(why) = self.over_loop_limit(info) {
            return Err(why);
        }
        if let Some(why) = self.over_device_memory(info) {
            return Err(why);
        }
        if let Some(avail) = host_available() {
            if self.host_bytes() > avail {
                return Err(format!(
                    "the job needs at least {} of host memory, {} is available",
                    mib(self.host_bytes()),
                    mib(avail)
                ));
            }
        }
        Ok(())
    }
}

/// The largest `x` in [1, hi] for which `fits(x)` holds, when `fits` is monotone (true, then
/// false); 0 when even 1 does not fit.
pub fn largest_fitting(hi: u64, fits: impl Fn(u64) -> bool) -> u64 {
    let (mut lo, mut hi) = (0u64, hi);
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    lo
}

/// `bytes` as MiB or GiB, one decimal.
pub fn mib(bytes: u64) -> String {
    if bytes >= 1 << 30 {
        format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
    } else {
        format!("{:.1} MiB", bytes as f64 / (1u64 << 20) as f64)
    }
}

/// MemAvailable of /proc/meminfo (Linux), if readable.
pub fn host_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// What in a valid scene will surprise its user: a view that must render black (camera or light
/// below the plate), no scratches at all. One sentence each, naming the view.
pub fn scene_warnings(scene: &crate::model::scene::Scene) -> Vec<String> {
    let mut w = Vec::new();
    if scene.scratches.is_empty() {
        w.push("the scene has 0 scratches: every view shows the bare plate".to_string());
    }
    for v in &scene.views {
        w.extend(view_warnings(v));
    }
    w
}

/// A view that must render black: camera or light below the plate.
pub fn view_warnings(v: &crate::model::scene::View) -> Vec<String> {
    use crate::model::scene::LightKind;
    let mut w = Vec::new();
    if v.camera.eye[2] <= 0.0 {
        w.push(format!(
            "view `{}`: the camera is below the plate (eye z = {} mm): it sees the plate's back, \
             and the view renders black",
            v.name, v.camera.eye[2]
        ));
    }
    let below = match v.light.kind {
        LightKind::Point { position } => (position[2] <= 0.0).then(|| format!("position z = {} mm", position[2])),
        LightKind::Directional { direction } => {
            (direction[2] <= 0.0).then(|| format!("direction z = {}", direction[2]))
        }
    };
    if let Some(why) = below {
        w.push(format!(
            "view `{}`: the light is below the plate ({why}): the view renders black",
            v.name
        ));
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A GPU of `memory` bytes binding up to 4 GiB per buffer.
    fn gpu(memory: u64) -> DeviceInfo {
        DeviceInfo {
            name: "a GPU".into(),
            kind: "discrete".into(),
            api_version: "1.3.0".into(),
            max_storage_buffer_range: (1 << 32) - 1,
            max_texel_buffer_elements: 1 << 30,
            max_workgroup_count: [65535; 3],
            max_workgroup_invocations: 1024,
            max_shared_memory: 49152,
            max_push_constants_size: 256,
            timestamp_period_ns: 1.0,
            timestamps: true,
            timestamp_valid_bits: 64,
            subgroup_size: 32,
            subgroup_arithmetic: true,
            float64: true,
            int64: true,
            float32_atomic_add: true,
            device_memory: memory,
        }
    }

    /// A GPU bins by pairs: its offsets are one word per tile, so the groups mode's tiles x
    /// groups table (2.9 GiB for a million scratches on 3 x 2048^2) limits nothing there; what
    /// does is the device's memory, stated and checked before anything is allocated.
    #[test]
    fn a_gpu_is_held_to_its_memory_not_to_the_groups_table() {
        let big = SceneDims::new(&[(2048, 2048); 3], 4_000_000, true);
        assert!(
            big.offsets_len() * 4 > (1 << 32),
            "the groups table would not fit one buffer"
        );
        let roomy = gpu(140 << 30);
        assert_eq!(big.over_device_limit(&roomy), None);
        assert_eq!(big.check(&roomy), Ok(()));
        let need = big.device_bytes(&roomy);
        assert!(need > 2 << 30 && need < 140 << 30, "{need}");
        let small = gpu(need - 1);
        let err = big.check(&small).expect_err("over the device's memory");
        assert!(err.contains("device memory") && err.contains(&mib(need)), "{err}");
        // The CPU driver bins by groups, and its table is checked.
        let mut cpu = roomy.clone();
        cpu.kind = "cpu".into();
        assert!(big
            .over_device_limit(&cpu)
            .is_some_and(|(what, _, _)| what.contains("groups")));
    }
}
