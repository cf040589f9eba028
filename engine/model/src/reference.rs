//! The float64 CPU reference of MODEL.md sections 1-5.
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
//!    of a smooth integrand, so the result is far inside the 1e-9 bar of MODEL.md section 8.
//! 4. D is evaluated with the stable denominator alpha^2 c^2 + |n x h|^2 (section 9), where
//!    |n x h|^2 = (h.t)^2 + (cos theta h.b + sin theta h.z)^2 is computed from the components.
//! 5. Coverage uses the exact polygon areas; BRDF, Fresnel, flat-plate term and L per section 5.
//!
//! Scratches are culled per pixel with a uniform grid over the plate holding each carved
//! rectangle's axis-aligned bounding box (exact: culling only skips pairs with empty F ∩ R_k).

use std::f64::consts::PI;

use super::camera::{dot, normalize, ViewGeom};
use super::scene::Scene;

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
}

fn prep(s: &super::scene::Scratch) -> Prep {
    let l = s.length();
    let t = [(s.p1[0] - s.p0[0]) / l, (s.p1[1] - s.p0[1]) / l];
    let b = [-t[1], t[0]];
    let e = s.half_width();
    let mut bbox = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    for p in [s.p0, s.p1] {
        for sg in [-1.0, 1.0] {
            let q = [p[0] + sg * e * b[0], p[1] + sg * e * b[1]];
            bbox[0] = bbox[0].min(q[0]);
            bbox[1] = bbox[1].min(q[1]);
            bbox[2] = bbox[2].max(q[0]);
            bbox[3] = bbox[3].max(q[1]);
        }
    }
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
    }
}

/// Uniform grid of scratch bounding boxes.
struct Grid {
    min: [f64; 2],
    cell: [f64; 2],
    n: usize,
    cells: Vec<Vec<u32>>,
}

impl Grid {
    fn new(preps: &[Prep]) -> Grid {
        if preps.is_empty() {
            return Grid {
                min: [0.0; 2],
                cell: [1.0; 2],
                n: 0,
                cells: Vec::new(),
            };
        }
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in preps {
            lo[0] = lo[0].min(p.bbox[0]);
            lo[1] = lo[1].min(p.bbox[1]);
            hi[0] = hi[0].max(p.bbox[2]);
            hi[1] = hi[1].max(p.bbox[3]);
        }
        let n = ((preps.len() as f64).sqrt().ceil() as usize).clamp(1, 128);
        let cell = [
            ((hi[0] - lo[0]) / n as f64).max(1e-300),
            ((hi[1] - lo[1]) / n as f64).max(1e-300),
        ];
        let mut g = Grid {
            min: lo,
            cell,
            n,
            cells: vec![Vec::new(); n * n],
        };
        for (k, p) in preps.iter().enumerate() {
            let (i0, j0, i1, j1) = g.range(p.bbox).expect("scratch inside its own grid");
            for j in j0..=j1 {
                for i in i0..=i1 {
                    g.cells[j * n + i].push(k as u32);
                }
            }
        }
        g
    }

    /// Cell index range overlapped by a bbox, or None when it misses the grid.
    fn range(&self, bb: [f64; 4]) -> Option<(usize, usize, usize, usize)> {
        if self.n == 0 {
            return None;
        }
        let top = [
            self.min[0] + self.cell[0] * self.n as f64,
            self.min[1] + self.cell[1] * self.n as f64,
        ];
        if bb[2] < self.min[0] || bb[3] < self.min[1] || bb[0] > top[0] || bb[1] > top[1] {
            return None;
        }
        let idx = |x: f64, a: usize| -> usize {
            let f = ((x - self.min[a]) / self.cell[a]).floor();
            if f < 0.0 {
                0
            } else {
                (f as usize).min(self.n - 1)
            }
        };
        Some((idx(bb[0], 0), idx(bb[1], 1), idx(bb[2], 0), idx(bb[3], 1)))
    }

    fn candidates(&self, bb: [f64; 4], preps: &[Prep], out: &mut Vec<u32>) {
        out.clear();
        if let Some((i0, j0, i1, j1)) = self.range(bb) {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    for &k in &self.cells[j * self.n + i] {
                        let p = &preps[k as usize].bbox;
                        if p[0] <= bb[2] && p[2] >= bb[0] && p[1] <= bb[3] && p[3] >= bb[1] {
                            out.push(k);
                        }
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
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
        let x = match g.shading_point(i, j) {
            Some(x) => x,
            None => return out,
        };
        out.x = x;
        let foot = match g.footprint(i, j) {
            Some(f) => f,
            None => return out,
        };
        out.s_p = polygon_area(&foot);
        out.on_plate = x[0].abs() <= half && x[1].abs() <= half;
        let wo = g.omega_o(x);
        let light = g.light_at(x);
        let h = normalize([
            light.omega_i[0] + wo[0],
            light.omega_i[1] + wo[1],
            light.omega_i[2] + wo[2],
        ]);
        out.h = h;
        out.cos_i = light.omega_i[2];
        out.cos_o = wo[2];
        out.e_irr = light.e;
        let f0 = self.scene.plate.f0;
        out.fresnel = f0 + (1.0 - f0) * (1.0 - dot(wo, h)).powi(5);
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

/// Shoelace area (absolute value) of a polygon.
fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    let mut a = 0.0;
    for k in 0..n {
        let (q, r) = (p[k], p[(k + 1) % n]);
        a += q[0] * r[1] - q[1] * r[0];
    }
    0.5 * a.abs()
}

/// Clip a polygon against the half-plane sign * coord[axis] <= sign * c (keeps coord <= c for
/// sign = 1, coord >= c for sign = -1). Points on the boundary get the coordinate exactly c.
fn clip(poly: &[[f64; 2]], axis: usize, c: f64, sign: f64) -> Vec<[f64; 2]> {
    let n = poly.len();
    let mut out = Vec::with_capacity(n + 4);
    if n == 0 {
        return out;
    }
    let inside = |p: &[f64; 2]| sign * (p[axis] - c) <= 0.0;
    for k in 0..n {
        let a = poly[k];
        let b = poly[(k + 1) % n];
        let (ia, ib) = (inside(&a), inside(&b));
        if ia {
            out.push(a);
        }
        if ia != ib {
            let t = (c - a[axis]) / (b[axis] - a[axis]);
            let o = 1 - axis;
            let mut q = [0.0; 2];
            q[axis] = c;
            q[o] = a[o] + t * (b[o] - a[o]);
            out.push(q);
        }
    }
    out
}

/// Length of the convex polygon's cross-section at u = `u`.
fn chord_at(poly: &[[f64; 2]], u: f64) -> f64 {
    let n = poly.len();
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for k in 0..n {
        let a = poly[k];
        let b = poly[(k + 1) % n];
        let (umin, umax) = if a[0] <= b[0] { (a[0], b[0]) } else { (b[0], a[0]) };
        if u < umin || u > umax {
            continue;
        }
        if a[0] == b[0] {
            lo = lo.min(a[1]).min(b[1]);
            hi = hi.max(a[1]).max(b[1]);
        } else {
            let t = ((u - a[0]) / (b[0] - a[0])).clamp(0.0, 1.0);
            let v = a[1] + t * (b[1] - a[1]);
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if hi > lo {
        hi - lo
    } else {
        0.0
    }
}

/// The scratch's NDF along u for a fixed h: D(n(u) . h; alpha).
#[derive(Clone, Copy)]
struct Profile {
    hz: f64,
    hb: f64,
    ht2: f64,
    inv_half_w: f64, // 2 / w
    alpha: f64,
}

impl Profile {
    #[inline]
    fn d(&self, u: f64) -> f64 {
        let s = u * self.inv_half_w;
        let s2 = s * s;
        let q = 1.0 + s2;
        // cos theta = (1 - s^2)/q, sin theta = 2s/q.
        let c = (self.hz * (1.0 - s2) - 2.0 * s * self.hb) / q;
        if c <= 0.0 {
            return 0.0;
        }
        let m = (self.hb * (1.0 - s2) + 2.0 * s * self.hz) / q;
        ndf(c, self.ht2 + m * m, self.alpha)
    }
}

// Gauss-Kronrod 7/15 nodes and weights (QUADPACK qk15).
#[allow(clippy::excessive_precision)]
const XGK: [f64; 8] = [
    0.991455371120812639206854697526329,
    0.949107912342758524526189684047851,
    0.864864423359769072789712788640926,
    0.741531185599394439863864773280788,
    0.586087235467691130294144845693013,
    0.405845151377397166906606412076961,
    0.207784955007898467600689403773245,
    0.000000000000000000000000000000000,
];
#[allow(clippy::excessive_precision)]
const WGK: [f64; 8] = [
    0.022935322010529224963732008058970,
    0.063092092629978553290700663189204,
    0.104790010322250183839876322541518,
    0.140653259715525918745189590510238,
    0.169004726639267902826583426598550,
    0.190350578064785409913256402421014,
    0.204432940075298892414161999234649,
    0.209482141084727828012999174891714,
];
#[allow(clippy::excessive_precision)]
const WG: [f64; 4] = [
    0.129484966168869693270611432679082,
    0.279705391489276667901467771423780,
    0.381830050505118944950369775488975,
    0.417959183673469387755102040816327,
];

/// One G7/K15 rule on [a, b]: (K15 result, |K15 - G7|).
fn gk15(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let c = 0.5 * (a + b);
    let hl = 0.5 * (b - a);
    let fc = f(c);
    let mut rk = fc * WGK[7];
    let mut rg = fc * WG[3];
    for k in 0..7 {
        let dx = hl * XGK[k];
        let s = f(c - dx) + f(c + dx);
        rk += WGK[k] * s;
        if k % 2 == 1 {
            rg += WG[k / 2] * s;
        }
    }
    (rk * hl, ((rk - rg) * hl).abs())
}

/// Globally adaptive G7/K15 over consecutive breakpoints `pts` (sorted). Stops when the summed
/// |K15 - G7| is below `rel` times the integral's magnitude (or below `abs`).
pub(crate) fn integrate(f: &dyn Fn(f64) -> f64, pts: &[f64], rel: f64, abs: f64) -> f64 {
    let mut iv: Vec<(f64, f64, f64, f64)> = Vec::with_capacity(pts.len() + 64);
    for w in pts.windows(2) {
        if w[1] > w[0] {
            let (r, e) = gk15(f, w[0], w[1]);
            iv.push((w[0], w[1], r, e));
        }
    }
    for _ in 0..4000 {
        let total: f64 = iv.iter().map(|x| x.2).sum();
        let err: f64 = iv.iter().map(|x| x.3).sum();
        if err <= (rel * total.abs()).max(abs) {
            break;
        }
        // Bisect the interval with the largest error estimate.
        let (k, _) = iv
            .iter()
            .enumerate()
            .fold((0, -1.0), |acc, (k, x)| if x.3 > acc.1 { (k, x.3) } else { acc });
        let (a, b, _, _) = iv[k];
        let m = 0.5 * (a + b);
        if !(m > a && m < b) {
            iv[k].3 = 0.0; // cannot split further
            continue;
        }
        let (r1, e1) = gk15(f, a, m);
        let (r2, e2) = gk15(f, m, b);
        iv[k] = (a, m, r1, e1);
        iv.push((m, b, r2, e2));
    }
    iv.iter().map(|x| x.2).sum()
}

/// (∫ D dA over F ∩ R, area(F ∩ R)) for one prepared scratch and a footprint in plate coords.
fn patch_integral(p: &Prep, foot: &[[f64; 2]; 4], h: [f64; 3]) -> (f64, f64) {
    patch_integral_with(p, foot, h, 1e-12, 0)
}

/// `patch_integral` with a given relative tolerance and `extra` additional uniform breakpoints
/// (the latter only for self-tests of the quadrature).
fn patch_integral_with(p: &Prep, foot: &[[f64; 2]; 4], h: [f64; 3], rel: f64, extra: usize) -> (f64, f64) {
    // Quick reject on bounding boxes.
    let mut bb = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    for q in foot {
        bb[0] = bb[0].min(q[0]);
        bb[1] = bb[1].min(q[1]);
        bb[2] = bb[2].max(q[0]);
        bb[3] = bb[3].max(q[1]);
    }
    if p.bbox[0] > bb[2] || p.bbox[2] < bb[0] || p.bbox[1] > bb[3] || p.bbox[3] < bb[1] {
        return (0.0, 0.0);
    }
    let local: Vec<[f64; 2]> = foot
        .iter()
        .map(|q| {
            let d = [q[0] - p.p0[0], q[1] - p.p0[1]];
            [d[0] * p.b[0] + d[1] * p.b[1], d[0] * p.t[0] + d[1] * p.t[1]]
        })
        .collect();
    let poly = clip(&local, 0, p.e, 1.0);
    let poly = clip(&poly, 0, -p.e, -1.0);
    let poly = clip(&poly, 1, p.l, 1.0);
    let poly = clip(&poly, 1, 0.0, -1.0);
    if poly.len() < 3 {
        return (0.0, 0.0);
    }
    let area = polygon_area(&poly);
    if !(area > 0.0) {
        return (0.0, 0.0);
    }
    let b3 = [p.b[0], p.b[1], 0.0];
    let t3 = [p.t[0], p.t[1], 0.0];
    let hb = dot(h, b3);
    let ht = dot(h, t3);
    let prof = Profile {
        hz: h[2],
        hb,
        ht2: ht * ht,
        inv_half_w: 2.0 / p.w,
        alpha: p.alpha,
    };
    let umin = poly.iter().map(|q| q[0]).fold(f64::INFINITY, f64::min);
    let umax = poly.iter().map(|q| q[0]).fold(f64::NEG_INFINITY, f64::max);
    if !(umax > umin) {
        return (0.0, area);
    }
    let half_w = 0.5 * p.w;
    let mut pts: Vec<f64> = poly.iter().map(|q| q[0]).collect();
    // chi+ cuts: hz s^2 + 2 hb s - hz = 0 (roots' product is -1).
    let (hz, hb2) = (h[2], hb);
    let rt = (hb2 * hb2 + hz * hz).sqrt();
    let qq = -(hb2 + if hb2 >= 0.0 { rt } else { -rt });
    if qq != 0.0 {
        if hz != 0.0 {
            pts.push(qq / hz * half_w);
        }
        pts.push(-hz / qq * half_w);
    } else if hz == 0.0 {
        pts.push(0.0);
    }
    // Lobe peak and lobe-width multiples.
    let theta = -hb2.atan2(hz);
    if theta.abs() < PI * 0.999 {
        let s = (0.5 * theta).tan();
        let up = s * half_w;
        let du = p.alpha * 0.5 * half_w * (1.0 + s * s); // alpha * du/dtheta
        pts.push(up);
        for k in [0.25, 1.0, 4.0, 16.0, 64.0, 256.0] {
            pts.push(up - k * du);
            pts.push(up + k * du);
        }
    }
    for k in 1..extra {
        pts.push(umin + (umax - umin) * k as f64 / extra as f64);
    }
    pts.retain(|u| u.is_finite() && *u >= umin && *u <= umax);
    pts.push(umin);
    pts.push(umax);
    pts.sort_by(|a, b| a.partial_cmp(b).unwrap());
    pts.dedup();
    // Chord is linear between consecutive breakpoints (all vertex u's are breakpoints).
    let chords: Vec<f64> = pts.iter().map(|&u| chord_at(&poly, u)).collect();
    let f = |u: f64| -> f64 {
        // Locate the piece (few breakpoints: linear scan).
        let mut k = pts.partition_point(|&x| x <= u);
        k = k.clamp(1, pts.len() - 1);
        let (a, b) = (pts[k - 1], pts[k]);
        let t = if b > a { (u - a) / (b - a) } else { 0.0 };
        let ch = chords[k - 1] + t * (chords[k] - chords[k - 1]);
        prof.d(u) * ch
    };
    let val = integrate(&f, &pts, rel, 1e-300);
    (val, area)
}

/// Render view `view` with the float64 reference: L, row-major, row 0 = top image row (sy = 0),
/// length W*H. Off-plate pixels are exactly 0.
pub fn render_view(scene: &Scene, view: usize) -> Vec<f64> {
    let prepared = Prepared::new(scene);
    render_prepared(&prepared, view)
}

fn render_prepared(prepared: &Prepared, view: usize) -> Vec<f64> {
    let g = ViewGeom::new(&prepared.scene.views[view]);
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
    let g = ViewGeom::new(&scene.views[view]);
    prepared.pixel(&g, i, j, &mut Vec::new())
}

/// On-plate mask of a view (row-major, top row first).
pub fn on_plate_mask(scene: &Scene, view: usize) -> Vec<bool> {
    let g = ViewGeom::new(&scene.views[view]);
    let half = 0.5 * scene.plate.size_mm;
    let mut m = Vec::with_capacity(g.width as usize * g.height as usize);
    for j in 0..g.height {
        for i in 0..g.width {
            m.push(g.on_plate(i, j, half));
        }
    }
    m
}

/// The linear check loss of MODEL.md section 8:
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
    let g = ViewGeom::new(&scene.views[view]);
    let (foot, x) = match (g.footprint(i, j), g.shading_point(i, j)) {
        (Some(f), Some(x)) => (f, x),
        _ => return (0.0, 0.0),
    };
    let wo = g.omega_o(x);
    let wi = g.light_at(x).omega_i;
    let h = normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]);
    patch_integral(&prep(&scene.scratches[k]), &foot, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gk15_is_exact_for_polynomials() {
        for deg in 0..=21 {
            let f = move |x: f64| x.powi(deg);
            let (r, _) = gk15(&f, -0.3, 1.7);
            let exact = (1.7f64.powi(deg + 1) - (-0.3f64).powi(deg + 1)) / (deg + 1) as f64;
            assert!(
                (r - exact).abs() <= 1e-13 * exact.abs().max(1.0),
                "deg {deg}: {r} vs {exact}"
            );
        }
        // G7 is exact to degree 13: the error estimate vanishes there.
        let (_, e) = gk15(&|x: f64| x.powi(13), -1.0, 2.0);
        assert!(e < 1e-10, "G7 error estimate for x^13: {e}");
    }

    #[test]
    fn adaptive_handles_peaks() {
        let a = 1e-4;
        let f = move |x: f64| a / (x * x + a * a);
        let v = integrate(&f, &[-1.0, 0.0, 1.0], 1e-12, 1e-300);
        let exact = 2.0 * (1.0 / a).atan();
        assert!((v - exact).abs() < 1e-10 * exact, "{v} vs {exact}");
    }

    /// The adaptive quadrature agrees with a much finer one (tolerance 1e-15 and 3000 extra
    /// uniform breakpoints) to 1e-10 relative, for sharp lobes, tilted h (h.t != 0), chi+ cuts
    /// and partial overlaps.
    #[test]
    fn quadrature_self_convergence() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut worst = 0.0f64;
        for case in 0..200 {
            let alpha = [1e-3, 3e-3, 0.02, 0.2, 0.9][case % 5];
            let w = 0.01 + 0.5 * rnd();
            let d = w * (0.05 + 3.0 * rnd());
            let a = rnd() * std::f64::consts::TAU;
            let l = 0.2 + rnd();
            let s = crate::scene::Scratch {
                p0: [0.0, 0.0],
                p1: [l * a.cos(), l * a.sin()],
                w,
                d,
                alpha,
            };
            let pr = prep(&s);
            // A random convex quad near the scratch.
            let c = [
                0.5 * l * a.cos() + 0.4 * (rnd() - 0.5),
                0.5 * l * a.sin() + 0.4 * (rnd() - 0.5),
            ];
            let r = 0.05 + 0.5 * rnd();
            let t0 = rnd() * std::f64::consts::TAU;
            let mut foot = [[0.0; 2]; 4];
            for (k, q) in foot.iter_mut().enumerate() {
                let t = t0 + k as f64 * std::f64::consts::FRAC_PI_2 + 0.5 * (rnd() - 0.5);
                let rr = r * (0.6 + 0.4 * rnd());
                *q = [c[0] + rr * t.cos(), c[1] + rr * t.sin()];
            }
            let hz = 0.2 + 0.8 * rnd();
            let ph = rnd() * std::f64::consts::TAU;
            let hh = (1.0 - hz * hz).sqrt();
            let h = [hh * ph.cos(), hh * ph.sin(), hz];
            let (v1, a1) = patch_integral(&pr, &foot, h);
            let (v2, a2) = patch_integral_with(&pr, &foot, h, 1e-15, 3000);
            assert_eq!(a1, a2);
            if v2 > 0.0 {
                let rel = (v1 / v2 - 1.0).abs();
                worst = worst.max(rel);
                assert!(rel < 1e-10, "case {case}: {v1} vs {v2} ({rel})");
            } else {
                assert_eq!(v1, 0.0);
            }
        }
        eprintln!("worst relative difference: {worst:e}");
    }

    #[test]
    fn clipping_square() {
        let sq = vec![[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
        let p = clip(&sq, 0, 0.5, 1.0);
        let p = clip(&p, 1, -0.25, -1.0);
        assert!((polygon_area(&p) - 1.5 * 1.25).abs() < 1e-15);
        assert!((chord_at(&p, 0.0) - 1.25).abs() < 1e-15);
        assert!((chord_at(&p, 0.5) - 1.25).abs() < 1e-15);
    }
}
