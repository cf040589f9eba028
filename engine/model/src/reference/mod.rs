//! The float64 CPU reference of engine/docs/model.md sections 1-5.
//!
//! **This is a test oracle only.** It is never used as a fallback for the GPU renderer: when the
//! GPU path is unavailable the engine reports an error instead of silently computing on the CPU.
//!
//! Method, per pixel (i, j) and scratch k (all in float64):
//! 1. The footprint F (four corner-ray hits) is taken to scratch k's local frame (u across,
//!    v along) and clipped exactly against the carved rectangle R_k = {|u| <= e, 0 <= v <= l}
//!    (Sutherland-Hodgman against four axis-aligned half-planes). F is convex (a projective image
//!    of the pixel square entirely in front of the camera), so F ∩ R_k is a convex polygon P.
//! 2. The integrand D(n(u) . h; alpha) depends on u only, so
//!    ∫_P D dA = ∫ D(u) chord(u) du, with chord(u) the length of P's cross-section at u,
//!    linear between consecutive vertex u-values.
//! 3. The u-range is split at every vertex u, at the chi+ cut(s) where n(u) . h = 0 (D jumps),
//!    at the lobe peak (theta(u) = -atan2(h.b, h.z)) and at peak ± {1/4, 1, 4, 16, 64, 256} lobe
//!    widths (alpha in angle). The pieces are integrated together by globally adaptive
//!    Gauss-Kronrod G7/K15 (bisecting the piece with the largest |K15 - G7|) until the summed
//!    |K15 - G7| is below 1e-12 of the integral: |K15 - G7| grossly over-estimates the K15 error
//!    of a smooth integrand, so the result is far inside the 1e-9 bar of engine/docs/model.md section 8.
//! 4. D is evaluated with the stable denominator alpha^2 c^2 + |n x h|^2 (section 9), where
//!    |n x h|^2 = (h.t)^2 + (cos theta h.b + sin theta h.z)^2 is computed from the components.
//! 5. Coverage uses the exact polygon areas; BRDF, Fresnel, flat-plate term and L per section 5.
//!
//! An arc scratch (crate::arc) is integrated in its own polar coordinates instead
//! (`arc_integral.rs`: nested adaptive Gauss-Kronrod over radius and sweep, exact footprint
//! crossings).
//!
//! Scratches are culled per pixel with a uniform grid over the plate holding each carved
//! rectangle's axis-aligned bounding box (exact: culling only skips pairs with empty F ∩ R_k).
//!
//! Files: this one holds the per-pixel evaluation and the public entry points; `cull.rs` the
//! culling grid; `clip.rs` the polygon clipping and chords; `integrate.rs` the adaptive
//! Gauss-Kronrod quadrature of one (footprint, scratch) pair.

mod arc_integral;
mod clip;
mod cull;
mod integrate;

use std::f64::consts::PI;

use crate::camera::{dot, normalize, LightSample, ViewGeom};
use crate::scene::Scene;
use crate::surface::SurfacePoint;

use clip::polygon_area;
use cull::Grid;

use crate::camera::on_plate_mask;

/// Everything the reference computes for one pixel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PixelRef {
    /// Linear pixel value L (0 off the plate or when cos_i <= 0 or cos_o <= 0).
    pub l: f64,
    /// Patch NDF D_P = sum_k D_k.
    pub d_p: f64,
    /// Coverage min(1, sum_k area(F ∩ R_k) / S_P).
    pub cov: f64,
    pub on_plate: bool,
    /// Footprint area S_P (0 when a corner ray misses).
    pub s_p: f64,
    /// Shading point X ([0, 0] when the centre ray misses).
    pub x: [f64; 2],
    pub h: [f64; 3],
    pub cos_i: f64,
    pub cos_o: f64,
    /// Irradiance E.
    pub e_irr: f64,
    pub fresnel: f64,
    /// Number of scratches whose carved rectangle meets F with positive area.
    pub n_pairs: usize,
}

/// Point NDF D(c; alpha) with the stable denominator alpha^2 c^2 + |n x h|^2.
/// `c` = n . h, `s2` = |n x h|^2.
#[inline]
pub fn ndf(c: f64, s2: f64, alpha: f64) -> f64 {
    if c <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let den = a2 * c * c + s2;
    a2 / (PI * den * den)
}

/// Flat-plate NDF D(h . z; alpha_s) for a unit h.
#[inline]
pub fn ndf_flat(h: [f64; 3], alpha: f64) -> f64 {
    ndf(h[2], h[0] * h[0] + h[1] * h[1], alpha)
}

/// Per-scratch precomputed frame.
#[derive(Clone, Copy, Debug)]
struct Prep {
    p0: [f64; 2],
    t: [f64; 2],
    b: [f64; 2],
    l: f64,
    e: f64,
    w: f64,
    alpha: f64,
    bbox: [f64; 4], // xmin, ymin, xmax, ymax
    /// An arc scratch's polar set-up (`arc_integral.rs`); None for a straight one.
    arc: Option<arc_integral::ArcPrep>,
}

fn prep(s: &crate::scene::Scratch) -> Prep {
    let l = s.length();
    let t = [(s.p1[0] - s.p0[0]) / l, (s.p1[1] - s.p0[1]) / l];
    let b = [-t[1], t[0]];
    let e = s.half_width();
    let mut bbox = s.carved_bbox();
    // Pad by a relative epsilon so rounding in the bbox never culls a touching pair.
    let pad = 1e-12 * (1.0 + bbox[2].abs().max(bbox[3].abs()).max(bbox[0].abs()).max(bbox[1].abs()));
    bbox[0] -= pad;
    bbox[1] -= pad;
    bbox[2] += pad;
    bbox[3] += pad;
    Prep {
        p0: s.p0,
        t,
        b,
        l,
        e,
        w: s.w,
        alpha: s.alpha,
        bbox,
        arc: s.arc().map(|g| arc_integral::ArcPrep {
            g,
            e,
            w: s.w,
            alpha: s.alpha,
            chord_measure: false,
        }),
    }
}

/// (∫ D dA over F ∩ R, area(F ∩ R)) for one prepared scratch, straight or arc.
fn patch_integral(p: &Prep, foot: &[[f64; 2]; 4], h: [f64; 3]) -> (f64, f64) {
    match &p.arc {
        None => integrate::patch_integral(p, foot, h),
        Some(a) => {
            let mut bb = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
            for q in foot {
                bb = [bb[0].min(q[0]), bb[1].min(q[1]), bb[2].max(q[0]), bb[3].max(q[1])];
            }
            if p.bbox[0] > bb[2] || p.bbox[2] < bb[0] || p.bbox[1] > bb[3] || p.bbox[3] < bb[1] {
                return (0.0, 0.0);
            }
            arc_integral::arc_patch_integral(a, foot, h)
        }
    }
}

/// A prepared scene: view geometries, scratch frames and the culling grid.
struct Prepared<'a> {
    scene: &'a Scene,
    preps: Vec<Prep>,
    grid: Grid,
}

impl<'a> Prepared<'a> {
    fn new(scene: &'a Scene) -> Prepared<'a> {
        let preps: Vec<Prep> = scene.scratches.iter().map(prep).collect();
        let grid = Grid::new(&preps);
        Prepared { scene, preps, grid }
    }

    fn pixel(&self, g: &ViewGeom, i: u32, j: u32, cand: &mut Vec<u32>) -> PixelRef {
        let mut out = PixelRef::default();
        let half = 0.5 * self.scene.plate.size_mm;
        let xs = match g.surface_hit(i as f64 + 0.5, j as f64 + 0.5) {
            Some(x) => x,
            None => return out,
        };
        let x = xs.uv;
        out.x = x;
        let foot = match g.footprint(i, j) {
            Some(f) => f,
            None => return out,
        };
        out.s_p = polygon_area(&foot);
        out.on_plate = x[0].abs() <= half && x[1].abs() <= half && !g.hidden(&xs);
        let (h, wo, light) = shading(g, &xs);
        out.h = h;
        out.cos_i = dot(light.omega_i, xs.n);
        out.cos_o = dot(wo, xs.n);
        out.e_irr = light.e;
        let f0 = self.scene.plate.f0;
        out.fresnel = f0 + (1.0 - f0) * (1.0 - dot(xs.local(wo), h)).powi(5);
        if !out.on_plate {
            return out;
        }
        let mut bb = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
        for q in &foot {
            bb[0] = bb[0].min(q[0]);
            bb[1] = bb[1].min(q[1]);
            bb[2] = bb[2].max(q[0]);
            bb[3] = bb[3].max(q[1]);
        }
        self.grid.candidates(bb, &self.preps, cand);
        let mut sum_d = 0.0;
        let mut sum_a = 0.0;
        for &k in cand.iter() {
            let (d, a) = patch_integral(&self.preps[k as usize], &foot, h);
            if a > 0.0 {
                out.n_pairs += 1;
            }
            sum_d += d;
            sum_a += a;
        }
        out.d_p = sum_d / out.s_p;
        out.cov = (sum_a / out.s_p).min(1.0);
        if out.cos_i > 0.0 && out.cos_o > 0.0 {
            let alpha_s = self.scene.plate.roughness;
            out.l = out.e_irr * out.fresnel * (out.d_p + (1.0 - out.cov) * ndf_flat(h, alpha_s)) / (4.0 * out.cos_o);
        }
        out
    }
}

/// Render view `view` with the float64 reference: L, row-major, row 0 = top image row (sy = 0),
/// length W*H. Off-plate pixels are exactly 0.
pub fn render_view(scene: &Scene, view: usize) -> Vec<f64> {
    let prepared = Prepared::new(scene);
    render_prepared(&prepared, view)
}

fn render_prepared(prepared: &Prepared, view: usize) -> Vec<f64> {
    let g = ViewGeom::of(&prepared.scene.views[view], &prepared.scene.plate);
    let (w, h) = (g.width as usize, g.height as usize);
    let mut out = vec![0.0f64; w * h];
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .clamp(1, 16)
        .min(h.max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let rows: Vec<std::sync::Mutex<Option<Vec<f64>>>> = (0..h).map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                let mut cand = Vec::new();
                loop {
                    let j = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    if j >= h {
                        break;
                    }
                    let row: Vec<f64> = (0..w)
                        .map(|i| prepared.pixel(&g, i as u32, j as u32, &mut cand).l)
                        .collect();
                    *rows[j].lock().unwrap() = Some(row);
                }
            });
        }
    });
    for (j, r) in rows.into_iter().enumerate() {
        let r = r.into_inner().unwrap().expect("row rendered");
        out[j * w..(j + 1) * w].copy_from_slice(&r);
    }
    out
}

/// Everything the reference computes for pixel (i, j) of view `view`.
pub fn pixel(scene: &Scene, view: usize, i: u32, j: u32) -> PixelRef {
    let prepared = Prepared::new(scene);
    let g = ViewGeom::of(&scene.views[view], &scene.plate);
    prepared.pixel(&g, i, j, &mut Vec::new())
}

/// The linear check loss of engine/docs/model.md section 8:
/// E_lin = sum over views j of (mean over view j's on-plate pixels of (L_j - T_j)^2).
/// `targets[j]` is row-major, top row first, W*H values. A view without on-plate pixels adds 0.
pub fn check_loss(scene: &Scene, targets: &[Vec<f64>]) -> f64 {
    assert_eq!(targets.len(), scene.views.len(), "one target per view");
    let prepared = Prepared::new(scene);
    let mut e = 0.0;
    for (v, t) in targets.iter().enumerate() {
        let l = render_prepared(&prepared, v);
        assert_eq!(t.len(), l.len(), "target size of view {v}");
        let mask = on_plate_mask(scene, v);
        let mut sum = 0.0;
        let mut n = 0usize;
        for k in 0..l.len() {
            if mask[k] {
                let d = l[k] - t[k];
                sum += d * d;
                n += 1;
            }
        }
        if n > 0 {
            e += sum / n as f64;
        }
    }
    e
}

/// For pixel (i, j) of view `view` and scratch k: (∫ D dA over F ∩ R_k — not divided by S_P —,
/// area(F ∩ R_k)). Computed whenever all four corner rays hit (the pixel need not be on the
/// plate); (0, 0) otherwise.
pub fn scratch_patch_integral(scene: &Scene, view: usize, i: u32, j: u32, k: usize) -> (f64, f64) {
    let g = ViewGeom::of(&scene.views[view], &scene.plate);
    let (foot, x) = match (g.footprint(i, j), g.surface_hit(i as f64 + 0.5, j as f64 + 0.5)) {
        (Some(f), Some(x)) => (f, x),
        _ => return (0.0, 0.0),
    };
    patch_integral(&prep(&scene.scratches[k]), &foot, shading(&g, &x).0)
}

/// The half vector in the surface frame at `x` (what the scratches' NDFs see: on a flat plate the
/// world's), omega_o and the light (world), with E = 0 where the sheet shades x (section 10).
fn shading(g: &ViewGeom, x: &SurfacePoint) -> ([f64; 3], [f64; 3], LightSample) {
    let wo = g.omega_o_at(x.p);
    let mut light = g.light_at_point(x.p);
    if g.shaded(x) {
        light.e = 0.0;
    }
    let h = normalize([
        light.omega_i[0] + wo[0],
        light.omega_i[1] + wo[1],
        light.omega_i[2] + wo[2],
    ]);
    (x.local(h), wo, light)
}
