//! `#[repr(C)]` twins of the GLSL structs in `shaders/inc/common.glsl` and of the kernels'
//! push-constant blocks. Field order and padding must match std430 / push-constant layout
//! exactly; `tests/` checks them against the shaders on the device.
use bytemuck::{Pod, Zeroable};

use glam::DVec3;

use crate::model::scene::{LightKind, Scene, Scratch, View};
use crate::model::surface::{BendAxis, PlateShape};

pub const TILE: u32 = 16;

/// Bytes of one scratch's records for the shading kernels: four RGBA32F texels
/// (`shaders/scratch_records.comp`, `shaders/inc/scratch_records.glsl`).
pub const SCRATCH_RECORD_BYTES: u64 = 4 * 16;
/// Bytes of one pixel's records: `SA_PIXEL_TEXELS` (5, `shaders/inc/pixel.glsl`) RGBA32F texels
/// (`shaders/pixel_records.comp`).
pub const PIXEL_RECORD_BYTES: u64 = 5 * 16;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct ViewGpu {
    /// xyz eye; w = tan(fov_y / 2)
    pub eye: [f32; 4],
    /// xyz forward; w = aspect W / H
    pub fwd: [f32; 4],
    /// xyz right; w = the plate's signed bend radius: 0 flat, +R convex, -R concave
    /// (engine/docs/model.md section 10; light intensities live in their own buffer)
    pub right: [f32; 4],
    /// xyz up'; w = light kind (0 point, 1 directional)
    pub up: [f32; 4],
    /// xyz light position (point) or unit direction towards the light (directional); w = the
    /// bend's axis: 0 the sheet's y (its x wraps), 1 its x
    pub light: [f32; 4],
    /// W, H, and the tiles across and down that a render computes (the whole image's, or its
    /// [`TileWindow`]'s)
    pub dims: [u32; 4],
    /// first tile index, first pixel index, and the column and row (in tiles) of the first tile
    /// a render computes (0, 0 for the whole image)
    pub base: [u32; 4],
}

impl ViewGpu {
    /// The tiles a render of this view computes.
    pub fn window(&self) -> TileWindow {
        TileWindow {
            x0: self.base[2],
            y0: self.base[3],
            nx: self.dims[2],
            ny: self.dims[3],
        }
    }
}

/// The part of a view's image that a forward render computes: tiles `[x0, x0 + nx)` across and
/// `[y0, y0 + ny)` down (16-pixel tiles). Pixels outside it come back as 0. A search that only
/// compares part of each image (the set-up sheet's tolerances) renders just that part; the
/// pixels inside are bit for bit those of the whole image's render (`tests/render_window.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileWindow {
    pub x0: u32,
    pub y0: u32,
    pub nx: u32,
    pub ny: u32,
}

impl TileWindow {
    /// The tiles of a `width` x `height` image that cover the pixels `[x0, x1) x [y0, y1)`
    /// (clipped to the image; at least one tile).
    pub fn covering(width: u32, height: u32, x0: u32, y0: u32, x1: u32, y1: u32) -> TileWindow {
        let (tw, th) = (width.div_ceil(TILE).max(1), height.div_ceil(TILE).max(1));
        let (tx0, ty0) = ((x0 / TILE).min(tw - 1), (y0 / TILE).min(th - 1));
        let (tx1, ty1) = (
            x1.div_ceil(TILE).clamp(tx0 + 1, tw),
            y1.div_ceil(TILE).clamp(ty0 + 1, th),
        );
        TileWindow {
            x0: tx0,
            y0: ty0,
            nx: tx1 - tx0,
            ny: ty1 - ty0,
        }
    }

    /// The tiles of a render at `scale` times a `width` x `height` image that cover the pixels
    /// of `mask` (row-major at the image's size) and `margin` of the render's pixels about them;
    /// None for an empty mask.
    pub fn covering_mask(mask: &[bool], width: u32, height: u32, scale: u32, margin: u32) -> Option<TileWindow> {
        let w = width as usize;
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
        for (i, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
            let (x, y) = (i % w, i / w);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
        }
        let (k, m) = (scale as usize, margin as usize);
        (x0 < x1).then(|| {
            TileWindow::covering(
                scale * width,
                scale * height,
                (k * x0).saturating_sub(m) as u32,
                (k * y0).saturating_sub(m) as u32,
                (k * x1 + m) as u32,
                (k * y1 + m) as u32,
            )
        })
    }

    /// The whole image of a `width` x `height` view.
    pub fn whole(width: u32, height: u32) -> TileWindow {
        TileWindow {
            x0: 0,
            y0: 0,
            nx: width.div_ceil(TILE),
            ny: height.div_ceil(TILE),
        }
    }

    /// This window clipped to a `width` x `height` image (at least one tile): what a render
    /// computes when asked for it.
    pub fn clipped(&self, width: u32, height: u32) -> TileWindow {
        let (x1, y1) = ((self.x0 + self.nx) * TILE, (self.y0 + self.ny) * TILE);
        TileWindow::covering(width, height, self.x0 * TILE, self.y0 * TILE, x1, y1)
    }

    /// Whether pixel (x, y) lies in one of the window's tiles.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        let (tx, ty) = (x / TILE, y / TILE);
        tx >= self.x0 && tx < self.x0 + self.nx && ty >= self.y0 && ty < self.y0 + self.ny
    }
}

/// The camera of a view in float64 (`ViewGPU64`): footprint corners and shading points are ray
/// hits computed in float64 on devices with shaderFloat64.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct ViewGpu64 {
    /// xyz eye; w = tan(fov_y / 2)
    pub eye: [f64; 4],
    /// xyz forward; w = aspect W / H
    pub fwd: [f64; 4],
    /// xyz right; w = the signed bend radius, as `ViewGpu::right`'s
    pub right: [f64; 4],
    /// xyz up'; w = the bend's axis code, as `ViewGpu::light`'s
    pub up: [f64; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct ScratchGpu {
    /// p0.x, p0.y, p1.x, p1.y
    pub ends: [f32; 4],
    /// w, d, alpha, and an arc chord's area weight k (`crate::arcs::expand`; 0 for a straight
    /// scratch)
    pub shape: [f32; 4],
}

impl From<&Scratch> for ScratchGpu {
    fn from(s: &Scratch) -> Self {
        ScratchGpu {
            ends: [s.p0[0] as f32, s.p0[1] as f32, s.p1[0] as f32, s.p1[1] as f32],
            shape: [s.w as f32, s.d as f32, s.alpha as f32, 0.0],
        }
    }
}

/// Push constants of `bin.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct BinPush {
    pub n_scratches: u32,
    pub n_views: u32,
    pub n_groups: u32,
    pub group_size: u32,
    pub capacity: u32,
    /// 2 (the loop-limit sentinel of `shaders/inc/limits.glsl`)
    pub sentinel: u32,
    /// 0: one thread bins its scratch group in every view; n > 0: one thread per (group, view,
    /// band of tile rows), n bands per view (GPUs: many more threads)
    pub n_bands: u32,
    pub pad: u32,
}

/// Push constants of `radix.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct RadixPush {
    /// blocks of 256 pairs that cover the capacity
    pub n_blocks: u32,
    /// the digit's first bit
    pub shift: u32,
    /// the word of `sbase` that holds the number of pairs
    pub total_index: u32,
    pub capacity: u32,
    /// 1: the values are the emission indices themselves (the first pass)
    pub first: u32,
    pub pad: [u32; 3],
}

/// Push constants of `scan.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ScanPush {
    pub n: u32,
    pub n_blocks: u32,
    /// the `stats` slot the scan sets when its total would wrap past `u32::MAX`
    pub flag_index: u32,
    pub pad: u32,
}

/// Push constants of `grad_reduce.comp` (`shaders/inc/reduce_push.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ReducePush {
    pub n_scratches: u32,
    /// tile-list capacity (entries past it were not listed)
    pub capacity: u32,
    /// binning parts per scratch (`BinPush::n_bands` x views, or 1)
    pub n_parts: u32,
    pub pad: u32,
}

/// Push constants of `forward.comp` (and the backward kernels).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ShadePush {
    pub half_plate: f32,
    pub alpha_s: f32,
    pub f0: f32,
    pub n_views: u32,
    pub n_groups: u32,
    pub n_tiles: u32,
    pub capacity: u32,
    /// chunks of a tile's list one pass handles (`u32::MAX`: all, one pass)
    pub chunks_per_pass: u32,
    /// this pass (set per dispatch)
    pub pass: u32,
    /// passes recorded
    pub n_passes: u32,
    /// 2 (the loop-limit sentinel of `shaders/inc/limits.glsl`)
    pub sentinel: u32,
    /// entries the pair store holds (0: none; see `shaders/inc/tile_queue.glsl`)
    pub store_cap: u32,
}

/// Where each view's tiles and pixels sit in the concatenated buffers.
#[derive(Clone, Debug)]
pub struct ViewSlots {
    pub views: Vec<ViewGpu>,
    pub views64: Vec<ViewGpu64>,
    pub n_tiles: u32,
    pub n_pixels: u64,
}

/// The bend as the views carry it: (signed radius, axis code) (`ViewGpu::right`'s and
/// `light`'s w).
pub fn bend_code(shape: &PlateShape) -> (f64, f32) {
    match *shape {
        PlateShape::Flat => (0.0, 0.0),
        PlateShape::Cylinder {
            radius_mm,
            axis,
            convex,
        } => (
            if convex { radius_mm } else { -radius_mm },
            match axis {
                BendAxis::Y => 0.0,
                BendAxis::X => 1.0,
            },
        ),
    }
}

/// The GPU view of `view` of a plate of shape `shape`, whose renders compute only `window`'s
/// tiles (None: the whole image).
pub fn view_gpu_in(
    view: &View,
    shape: &PlateShape,
    tile_base: u32,
    pixel_base: u32,
    window: Option<TileWindow>,
) -> ViewGpu {
    let cam = &view.camera;
    // engine/docs/model.md section 4: f = normalize(T - C), r = normalize(f x U), up' = r x f.
    let b = cam.basis();
    let (fwd, right, up) = (b.fwd, b.right, b.up);
    let (w, h) = (cam.width, cam.height);
    // (A window is clipped to the image and holds at least one tile, as `covering` makes it.)
    let win = window.map_or_else(|| TileWindow::whole(w, h), |t| t.clipped(w, h));
    let f3 = |v: [f64; 3], w: f32| [v[0] as f32, v[1] as f32, v[2] as f32, w];
    let (kind, light) = match view.light.kind {
        LightKind::Point { position } => (0.0, position),
        LightKind::Directional { direction } => (1.0, direction),
    };
    let (radius, axis) = bend_code(shape);
    ViewGpu {
        eye: f3(cam.eye, (cam.fov_y_deg.to_radians() * 0.5).tan() as f32),
        fwd: f3(fwd.to_array(), (w as f64 / h as f64) as f32),
        right: f3(right.to_array(), radius as f32),
        up: f3(up.to_array(), kind),
        light: f3(light, axis),
        dims: [w, h, win.nx, win.ny],
        base: [tile_base, pixel_base, win.x0, win.y0],
    }
}

pub fn view_gpu64(view: &View, shape: &PlateShape) -> ViewGpu64 {
    let cam = &view.camera;
    let b = cam.basis();
    let (fwd, right, up) = (b.fwd, b.right, b.up);
    let c = |v: DVec3, w: f64| [v.x, v.y, v.z, w];
    ViewGpu64 {
        eye: c(DVec3::from(cam.eye), (cam.fov_y_deg.to_radians() * 0.5).tan()),
        fwd: c(fwd, cam.width as f64 / cam.height as f64),
        right: c(right, bend_code(shape).0),
        up: c(up, bend_code(shape).1 as f64),
    }
}

pub fn view_slots(scene: &Scene) -> ViewSlots {
    view_slots_in(scene, &[])
}

/// [`view_slots`] where view v's renders compute only `windows[v]`'s tiles (None, or past the
/// end of `windows`: the whole image).
pub fn view_slots_in(scene: &Scene, windows: &[Option<TileWindow>]) -> ViewSlots {
    let mut views = Vec::with_capacity(scene.views.len());
    let shape = &scene.plate.shape;
    let views64 = scene.views.iter().map(|v| view_gpu64(v, shape)).collect();
    let (mut tiles, mut pixels) = (0u32, 0u64);
    for (k, v) in scene.views.iter().enumerate() {
        let gv = view_gpu_in(v, shape, tiles, pixels as u32, windows.get(k).copied().flatten());
        tiles += gv.dims[2] * gv.dims[3];
        pixels += v.camera.width as u64 * v.camera.height as u64;
        views.push(gv);
    }
    ViewSlots {
        views,
        views64,
        n_tiles: tiles,
        n_pixels: pixels,
    }
}
