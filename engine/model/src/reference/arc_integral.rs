//! The reference's integral of one arc scratch (crate::arc) over a footprint, in the arc's polar
//! coordinates (rho from the centre, psi along the sweep):
//!   I = ∫ drho rho ∫_{psi in Φ(rho)} D(n(u(rho), phi) . h) dpsi,   A = ∫ drho rho |Φ(rho)|,
//! u = sign(b) (r - rho) the straight scratch's across coordinate, n the groove's normal there
//! turned to the arc's local frame at polar angle phi, Φ(rho) the part of the sweep whose circle
//! of radius rho lies in the footprint (exact: the circle's crossings with the quad's edges).
//! Both levels are globally adaptive Gauss-Kronrod G7/K15 (`integrate.rs`), split where the
//! integrand is not smooth or is sharp: along psi at the chi+ cuts (n . h = 0), at the lobe peak
//! (the local direction of travel perpendicular to h's plate part) and at lobe-width multiples
//! around it; along rho at the footprint's vertex radii, its edges' nearest radii, where the
//! sweep's end radii cross its edges, and at the across-profile's lobe peak and chi+ cut for
//! directions sampled over the footprint. Inner tolerance 1e-11, outer 1e-10 (relative).

use std::f64::consts::PI;

use super::integrate::{integrate, Profile};
use crate::arc::ArcGeom;

/// An arc scratch prepared for the reference.
#[derive(Clone, Copy, Debug)]
pub(super) struct ArcPrep {
    pub g: ArcGeom,
    /// Carved half-width e and the width parameter w.
    pub e: f64,
    pub w: f64,
    pub alpha: f64,
    /// Test switch: integrate with the measure of the arc's chords (straight rectangles along
    /// it: r drho dpsi) instead of the plane's (rho drho dpsi). As the chords shorten, their
    /// integrals tend to this one, which checks everything here but the factor rho / r.
    pub chord_measure: bool,
}

/// Whether point q lies in the convex quad `f` (either orientation; on an edge counts).
fn inside(f: &[[f64; 2]; 4], q: [f64; 2]) -> bool {
    let mut pos = false;
    let mut neg = false;
    for k in 0..4 {
        let (a, b) = (f[k], f[(k + 1) % 4]);
        let c = (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]);
        pos |= c > 0.0;
        neg |= c < 0.0;
    }
    !(pos && neg)
}

impl ArcPrep {
    /// Point at radius rho and sweep position psi (radians along the sweep from p0).
    fn at(&self, rho: f64, psi: f64) -> [f64; 2] {
        let phi = self.g.phi0 + self.g.sweep.signum() * psi;
        [self.g.centre[0] + rho * phi.cos(), self.g.centre[1] + rho * phi.sin()]
    }

    /// The sweep positions where the circle of radius rho crosses the footprint's edges (within
    /// the sweep), with 0 and the sweep's end.
    fn cuts(&self, foot: &[[f64; 2]; 4], rho: f64) -> Vec<f64> {
        let total = self.g.sweep.abs();
        let mut out = vec![0.0, total];
        let c = self.g.centre;
        for k in 0..4 {
            let (a, b) = (foot[k], foot[(k + 1) % 4]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let f = [a[0] - c[0], a[1] - c[1]];
            let qa = d[0] * d[0] + d[1] * d[1];
            let qb = f[0] * d[0] + f[1] * d[1];
            let qc = f[0] * f[0] + f[1] * f[1] - rho * rho;
            let disc = qb * qb - qa * qc;
            if !(qa > 0.0) || disc < 0.0 {
                continue;
            }
            let sq = disc.sqrt();
            for t in [(-qb - sq) / qa, (-qb + sq) / qa] {
                if (0.0..=1.0).contains(&t) {
                    let p = [f[0] + t * d[0], f[1] + t * d[1]];
                    if let Some(x) = self.g.fraction_of(p[1].atan2(p[0])) {
                        out.push(x * total);
                    }
                }
            }
        }
        out.sort_by(|a, b| a.partial_cmp(b).unwrap());
        out.dedup();
        out
    }

    /// The intervals of Φ(rho): the sweep positions whose point at radius rho is in the footprint.
    fn inside_intervals(&self, foot: &[[f64; 2]; 4], rho: f64) -> Vec<(f64, f64)> {
        let cuts = self.cuts(foot, rho);
        let mut out: Vec<(f64, f64)> = Vec::new();
        for w in cuts.windows(2) {
            if w[1] > w[0] && inside(foot, self.at(rho, 0.5 * (w[0] + w[1]))) {
                match out.last_mut() {
                    Some(l) if l.1 == w[0] => l.1 = w[1],
                    _ => out.push((w[0], w[1])),
                }
            }
        }
        out
    }

    /// The across-profile of the groove at sweep position psi for half vector h.
    fn profile(&self, h: [f64; 3], psi: f64) -> Profile {
        let sg = self.g.sweep.signum();
        let phi = self.g.phi0 + sg * psi;
        let (c, s) = (phi.cos(), phi.sin());
        let t = [-sg * s, sg * c];
        let b = [-t[1], t[0]];
        let ht = h[0] * t[0] + h[1] * t[1];
        Profile {
            hz: h[2],
            hb: h[0] * b[0] + h[1] * b[1],
            ht2: ht * ht,
            inv_half_w: 2.0 / self.w,
            alpha: self.alpha,
        }
    }

    /// Breakpoints along psi for h: the lobe peaks (direction of travel perpendicular to h's
    /// plate part) with lobe-width multiples, and the chi+ cuts at across coordinate u.
    fn psi_breaks(&self, h: [f64; 3], u: f64) -> Vec<f64> {
        let total = self.g.sweep.abs();
        let hxy = h[0].hypot(h[1]);
        let mut out = Vec::new();
        let push_phi = |phi: f64, out: &mut Vec<f64>| {
            if let Some(x) = self.g.fraction_of(phi) {
                out.push(x * total);
            }
        };
        if hxy > 0.0 {
            let ph = h[1].atan2(h[0]);
            let dphi = self.alpha / hxy;
            for base in [ph, ph + PI] {
                push_phi(base, &mut out);
                for k in [0.25, 1.0, 4.0, 16.0, 64.0, 256.0] {
                    if k * dphi < PI {
                        push_phi(base - k * dphi, &mut out);
                        push_phi(base + k * dphi, &mut out);
                    }
                }
            }
            // chi+ cut: hz (1 - s^2) = 2 s hb(phi), hb = -sign(b) |h_xy| cos(phi - ph).
            let s = u * 2.0 / self.w;
            if s != 0.0 {
                let v = -h[2] * (1.0 - s * s) / (2.0 * s * self.g.sweep.signum() * hxy);
                if v.abs() <= 1.0 {
                    let a = v.acos();
                    push_phi(ph + a, &mut out);
                    push_phi(ph - a, &mut out);
                }
            }
        }
        out
    }

    /// The area element's factor at radius rho (see `chord_measure`).
    fn measure(&self, rho: f64) -> f64 {
        if self.chord_measure {
            self.g.radius
        } else {
            rho
        }
    }

    /// ∫ rho D dpsi over Φ(rho).
    fn inner(&self, foot: &[[f64; 2]; 4], h: [f64; 3], rho: f64) -> f64 {
        let iv = self.inside_intervals(foot, rho);
        if iv.is_empty() {
            return 0.0;
        }
        let sg = self.g.sweep.signum();
        let u = sg * (self.g.radius - rho);
        let br = self.psi_breaks(h, u);
        let mut val = 0.0;
        for (a, b) in iv {
            let mut pts: Vec<f64> = br.iter().copied().filter(|&x| x > a && x < b).collect();
            pts.push(a);
            pts.push(b);
            pts.sort_by(|x, y| x.partial_cmp(y).unwrap());
            pts.dedup();
            let f = |psi: f64| self.profile(h, psi).d(u);
            val += integrate(&f, &pts, 1e-11, 1e-300);
        }
        self.measure(rho) * val
    }

    /// Breakpoints along rho.
    fn rho_breaks(&self, foot: &[[f64; 2]; 4], h: [f64; 3], lo: f64, hi: f64) -> Vec<f64> {
        let c = self.g.centre;
        let mut pts = vec![lo, hi];
        for k in 0..4 {
            let (a, b) = (foot[k], foot[(k + 1) % 4]);
            pts.push((a[0] - c[0]).hypot(a[1] - c[1]));
            let d = [b[0] - a[0], b[1] - a[1]];
            let qa = d[0] * d[0] + d[1] * d[1];
            if qa > 0.0 {
                let t = -((a[0] - c[0]) * d[0] + (a[1] - c[1]) * d[1]) / qa;
                if (0.0..=1.0).contains(&t) {
                    pts.push((a[0] + t * d[0] - c[0]).hypot(a[1] + t * d[1] - c[1]));
                }
            }
            // The sweep's end rays crossing this edge.
            for end in [0.0, 1.0] {
                let phi = self.g.phi0 + self.g.sweep * end;
                let r = [phi.cos(), phi.sin()];
                let den = d[0] * r[1] - d[1] * r[0];
                if den != 0.0 {
                    let f = [a[0] - c[0], a[1] - c[1]];
                    let t = (f[1] * r[0] - f[0] * r[1]) / den;
                    let rho = (f[0] + t * d[0]) * r[0] + (f[1] + t * d[1]) * r[1];
                    if (0.0..=1.0).contains(&t) && rho > 0.0 {
                        pts.push(rho);
                    }
                }
            }
        }
        // The across lobe and chi+ cut at directions sampled over the footprint's part of the
        // sweep (the arc's direction changes little across one footprint).
        let total = self.g.sweep.abs();
        let iv = self.inside_intervals(foot, self.g.radius);
        let (a, b) = match (iv.first(), iv.last()) {
            (Some(f), Some(l)) => (f.0, l.1),
            _ => (0.0, total),
        };
        let sg = self.g.sweep.signum();
        let half_w = 0.5 * self.w;
        for k in 0..=8 {
            let p = self.profile(h, a + (b - a) * k as f64 / 8.0);
            let theta = -p.hb.atan2(p.hz);
            if theta.abs() < PI * 0.999 {
                let s = (0.5 * theta).tan();
                let up = s * half_w;
                let du = self.alpha * 0.5 * half_w * (1.0 + s * s);
                for m in [0.0, -1.0, 1.0, -4.0, 4.0, -16.0, 16.0] {
                    pts.push(self.g.radius - sg * (up + m * du));
                }
            }
            let rt = p.hb.hypot(p.hz);
            let qq = -(p.hb + if p.hb >= 0.0 { rt } else { -rt });
            if qq != 0.0 {
                if p.hz != 0.0 {
                    pts.push(self.g.radius - sg * qq / p.hz * half_w);
                }
                pts.push(self.g.radius + sg * p.hz / qq * half_w);
            }
        }
        pts.retain(|x| x.is_finite() && *x >= lo && *x <= hi);
        pts.sort_by(|x, y| x.partial_cmp(y).unwrap());
        pts.dedup();
        pts
    }
}

/// (∫ D dA over the footprint ∩ the arc's carved band, its area).
pub(super) fn arc_patch_integral(p: &ArcPrep, foot: &[[f64; 2]; 4], h: [f64; 3]) -> (f64, f64) {
    let c = p.g.centre;
    let dist: Vec<f64> = foot.iter().map(|q| (q[0] - c[0]).hypot(q[1] - c[1])).collect();
    let far = dist.iter().copied().fold(0.0, f64::max);
    let near = if inside(foot, c) {
        0.0
    } else {
        (0..4)
            .map(|k| {
                let (a, b) = (foot[k], foot[(k + 1) % 4]);
                let d = [b[0] - a[0], b[1] - a[1]];
                let qa = d[0] * d[0] + d[1] * d[1];
                let t = if qa > 0.0 {
                    (-((a[0] - c[0]) * d[0] + (a[1] - c[1]) * d[1]) / qa).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (a[0] + t * d[0] - c[0]).hypot(a[1] + t * d[1] - c[1])
            })
            .fold(f64::INFINITY, f64::min)
    };
    let lo = (p.g.radius - p.e).max(near);
    let hi = (p.g.radius + p.e).min(far);
    if !(hi > lo) {
        return (0.0, 0.0);
    }
    let pts = p.rho_breaks(foot, h, lo, hi);
    let len = |rho: f64| p.measure(rho) * p.inside_intervals(foot, rho).iter().map(|(a, b)| b - a).sum::<f64>();
    let area = integrate(&len, &pts, 1e-10, 1e-300);
    if !(area > 0.0) {
        return (0.0, 0.0);
    }
    let val = integrate(&|rho: f64| p.inner(foot, h, rho), &pts, 1e-10, 1e-300);
    (val, area)
}

#[cfg(test)]
mod tests {
    use super::super::{patch_integral, prep};
    use crate::scene::Scratch;

    fn rng(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A random convex quad of about `r` around `c`.
    fn quad(seed: &mut u64, c: [f64; 2], r: f64) -> [[f64; 2]; 4] {
        let t0 = rng(seed) * std::f64::consts::TAU;
        let mut foot = [[0.0; 2]; 4];
        for (k, q) in foot.iter_mut().enumerate() {
            let t = t0 + k as f64 * std::f64::consts::FRAC_PI_2 + 0.5 * (rng(seed) - 0.5);
            let rr = r * (0.6 + 0.4 * rng(seed));
            *q = [c[0] + rr * t.cos(), c[1] + rr * t.sin()];
        }
        foot
    }

    fn half_vector(seed: &mut u64) -> [f64; 3] {
        let hz = 0.3 + 0.7 * rng(seed);
        let ph = rng(seed) * std::f64::consts::TAU;
        let hh = (1.0 - hz * hz).sqrt();
        [hh * ph.cos(), hh * ph.sin(), hz]
    }

    /// The arc's integral with the chords' measure (`chord_measure`: the chords' rectangles
    /// weigh the groove's inner side by r / rho against the plane) is the limit of its chords'
    /// (straight scratches, integrated by the straight reference): 2000 and 4000 chords,
    /// extrapolated, agree with it to 2e-6 beyond the chords' own convergence (|I_4000 - I_2000|:
    /// where a footprint's edge crosses the groove the chords' slivers converge slowly, 1.5e-6
    /// apart at 4000 chords), for arcs of either sense, sharp and broad
    /// lobes, footprints across the groove, at its ends and around its middle.
    #[test]
    fn arc_is_the_limit_of_its_chords() {
        let mut seed = 7u64;
        let mut worst = (0.0f64, 0.0f64);
        let mut compared = 0;
        for case in 0..40 {
            let alpha = [0.02, 0.1, 0.4][case % 3];
            let bulge = [0.3, -0.6, 1.0, -0.1][case % 4];
            let w = 0.05 + 0.2 * rng(&mut seed);
            let s = Scratch {
                p0: [-1.0, 0.2],
                p1: [1.5, -0.3],
                w,
                d: w * (0.1 + rng(&mut seed)),
                alpha,
                bulge,
            };
            let a = s.arc().unwrap();
            let at = [0.0, 0.5, 1.0, rng(&mut seed)][case % 4];
            let c = a.point(at);
            let n = [c[0] - a.centre[0], c[1] - a.centre[1]];
            let off = (rng(&mut seed) - 0.5) * 1.5 * s.half_width() / a.radius;
            let c = [c[0] + off * n[0], c[1] + off * n[1]];
            let size = 0.05 + 0.3 * rng(&mut seed);
            let foot = quad(&mut seed, c, size);
            let h = half_vector(&mut seed);
            let mut pr = prep(&s);
            pr.arc.as_mut().unwrap().chord_measure = true;
            let (v, area) = patch_integral(&pr, &foot, h);
            let by_chords = |n: usize| {
                s.chords(n).iter().fold((0.0, 0.0), |acc, ch| {
                    let (i, a) = patch_integral(&prep(ch), &foot, h);
                    (acc.0 + i, acc.1 + a)
                })
            };
            let (v1, a1) = by_chords(2000);
            let (v2, a2) = by_chords(4000);
            let (ve, ae) = ((4.0 * v2 - v1) / 3.0, (4.0 * a2 - a1) / 3.0);
            if area > 0.0 {
                let ea = (area / ae - 1.0).abs();
                worst.1 = worst.1.max(ea);
                assert!(
                    (area - ae).abs() <= 2e-6 * area + (a2 - a1).abs(),
                    "case {case}: area {area} vs chords {ae} (chords {a1} {a2})"
                );
            } else {
                assert!(ae.abs() < 1e-12, "case {case}: no area, chords {ae}");
            }
            if v > 1e-300 {
                let ev = (v / ve - 1.0).abs();
                worst.0 = worst.0.max(ev);
                // Within 2e-6 beyond the chords' own convergence (|I_4000 - I_2000|).
                assert!(
                    (v - ve).abs() <= 2e-6 * v + (v2 - v1).abs(),
                    "case {case}: I {v} vs chords {ve} ({ev:e}; chords {v1} {v2})"
                );
                compared += 1;
            }
        }
        eprintln!(
            "worst relative differences: I {:e}, A {:e} ({compared} lit)",
            worst.0, worst.1
        );
        assert!(compared >= 20, "only {compared} cases lit");
    }

    /// As the bulge goes to 0 from either side, the arc's integral tends to the straight
    /// scratch's: I(b) and I(-b) differ from I(0) in first order (the sagitta moves the groove
    /// across the footprint's edges: 3.5e-5 of the area at b = 1e-6 here), their mean only in
    /// second order.
    #[test]
    fn nearly_straight_arc_is_the_straight_scratch() {
        let mut seed = 11u64;
        for case in 0..30 {
            let mut s = Scratch {
                p0: [-1.0, 0.0],
                p1: [1.0, 0.5],
                w: 0.1,
                d: 0.03,
                alpha: [0.05, 0.3][case % 2],
                bulge: 0.0,
            };
            let c = [rng(&mut seed) - 0.5, 0.25 * (rng(&mut seed) - 0.5) + 0.1];
            let foot = quad(&mut seed, c, 0.2);
            let h = half_vector(&mut seed);
            let straight = patch_integral(&prep(&s), &foot, h);
            s.bulge = 1e-6;
            let up = patch_integral(&prep(&s), &foot, h);
            s.bulge = -1e-6;
            let down = patch_integral(&prep(&s), &foot, h);
            let mean = (0.5 * (up.0 + down.0), 0.5 * (up.1 + down.1));
            assert!(
                (mean.1 - straight.1).abs() <= 1e-7 * straight.1.max(1e-12),
                "case {case}: area {up:?} {down:?} {straight:?}"
            );
            assert!(
                (mean.0 - straight.0).abs() <= 1e-7 * straight.0.max(1e-12),
                "case {case}: I {up:?} {down:?} {straight:?}"
            );
        }
    }
}
