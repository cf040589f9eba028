//! The integral of one scratch's NDF over the intersection of a footprint and its carved
//! rectangle: clip (`clip.rs`), then integrate D(u) chord(u) over u with globally adaptive
//! Gauss-Kronrod G7/K15 between breakpoints at the polygon's vertices, the chi+ cuts and around
//! the lobe peak (see the method in `mod.rs`).

use std::f64::consts::PI;

use super::clip::{chord_at, clip, polygon_area};
use super::{ndf, Prep};
use crate::camera::dot;

/// The scratch's NDF along u for a fixed h: D(n(u) . h; alpha).
#[derive(Clone, Copy)]
pub(super) struct Profile {
    pub hz: f64,
    pub hb: f64,
    pub ht2: f64,
    pub inv_half_w: f64, // 2 / w
    pub alpha: f64,
}

impl Profile {
    #[inline]
    pub(super) fn d(&self, u: f64) -> f64 {
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
pub(super) fn integrate(f: &dyn Fn(f64) -> f64, pts: &[f64], rel: f64, abs: f64) -> f64 {
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

/// (∫ D dA over F ∩ R, area(F ∩ R)) for one prepared straight scratch and a footprint in plate
/// coords.
pub(super) fn patch_integral(p: &Prep, foot: &[[f64; 2]; 4], h: [f64; 3]) -> (f64, f64) {
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

#[cfg(test)]
mod tests {
    use super::super::prep;
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
                bulge: 0.0,
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
}
