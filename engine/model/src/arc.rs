//! Arc scratches (engine/docs/model.md section 11): a scratch whose path is a circular arc from
//! p0 to p1, given by DXF's bulge b = tan(included angle / 4), positive when the arc runs
//! counter-clockwise (seen from +z) from p0 to p1; b = 0 is the straight scratch. The groove's
//! cross-section (w, d, alpha) holds along the arc: at a point at distance rho from the arc's
//! centre, the across coordinate of the straight scratch's frame is u = sign(b) (r - rho) (the
//! left of the direction of travel points to the centre of a counter-clockwise arc), and the
//! groove's ends are cut along the radii through p0 and p1.

use crate::scene::Scratch;

/// The largest |bulge| accepted: an included angle of 270 degrees (tan(67.5 degrees)). A larger
/// one nearly closes the circle, which no carving or optimization needs.
pub const MAX_BULGE: f64 = 2.414_213_562_373_095;

/// An arc scratch's circle and the part of it the scratch runs along.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcGeom {
    pub centre: [f64; 2],
    pub radius: f64,
    /// Polar angle of p0 about the centre (radians).
    pub phi0: f64,
    /// Signed included angle (radians): positive counter-clockwise, 4 atan(bulge).
    pub sweep: f64,
}

impl ArcGeom {
    /// The arc from `p0` to `p1` with DXF's `bulge`; None for bulge 0 or coincident endpoints.
    pub fn of(p0: [f64; 2], p1: [f64; 2], bulge: f64) -> Option<ArcGeom> {
        let c = (p1[0] - p0[0]).hypot(p1[1] - p0[1]);
        if bulge == 0.0 || !(c > 0.0) {
            return None;
        }
        let sweep = 4.0 * bulge.atan();
        let half = 0.5 * sweep;
        let radius = 0.5 * c / half.sin().abs();
        // Centre: the chord's midpoint moved along its left normal by (c/2) cot(sweep/2), signed
        // (left of p0 -> p1 for a counter-clockwise arc under half a turn).
        let (dx, dy) = ((p1[0] - p0[0]) / c, (p1[1] - p0[1]) / c);
        let off = 0.5 * c * half.cos() / half.sin();
        let centre = [0.5 * (p0[0] + p1[0]) - dy * off, 0.5 * (p0[1] + p1[1]) + dx * off];
        let phi0 = (p0[1] - centre[1]).atan2(p0[0] - centre[0]);
        Some(ArcGeom {
            centre,
            radius,
            phi0,
            sweep,
        })
    }

    /// Points along the arc, its ends included, whose chords stray at most `tol` from it (as a
    /// controller cuts an arc into lines: GRBL's `$12` arc tolerance).
    pub fn polyline(&self, tol: f64) -> Vec<[f64; 2]> {
        // A chord turning by t strays r (1 - cos(t / 2)) from the arc.
        let t = 2.0 * (1.0 - tol / self.radius).clamp(-1.0, 1.0).acos();
        let n = if t > 0.0 {
            (self.sweep.abs() / t).ceil().max(1.0) as usize
        } else {
            1
        };
        (0..=n).map(|k| self.point(k as f64 / n as f64)).collect()
    }

    /// The point at fraction `t` of the way along the arc.
    pub fn point(&self, t: f64) -> [f64; 2] {
        let phi = self.phi0 + self.sweep * t;
        [
            self.centre[0] + self.radius * phi.cos(),
            self.centre[1] + self.radius * phi.sin(),
        ]
    }

    /// The unit direction of travel at fraction `t`.
    pub fn tangent(&self, t: f64) -> [f64; 2] {
        let phi = self.phi0 + self.sweep * t;
        let sg = self.sweep.signum();
        [-sg * phi.sin(), sg * phi.cos()]
    }

    /// Arc length.
    pub fn length(&self) -> f64 {
        self.radius * self.sweep.abs()
    }

    /// Whether polar angle `phi` lies on the arc's sweep, and at which fraction of it.
    pub fn fraction_of(&self, phi: f64) -> Option<f64> {
        let tau = std::f64::consts::TAU;
        let d = (phi - self.phi0) * self.sweep.signum();
        let d = d.rem_euclid(tau);
        let t = d / self.sweep.abs();
        (t <= 1.0).then_some(t)
    }

    /// Axis-aligned box [xmin, ymin, xmax, ymax] of the band within `e` of the arc (the carved
    /// region): its four corners and the outer circle's extremes within the sweep.
    pub fn band_bbox(&self, e: f64) -> [f64; 4] {
        let mut bb = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
        let mut add = |q: [f64; 2]| {
            bb[0] = bb[0].min(q[0]);
            bb[1] = bb[1].min(q[1]);
            bb[2] = bb[2].max(q[0]);
            bb[3] = bb[3].max(q[1]);
        };
        for t in [0.0, 1.0] {
            let phi = self.phi0 + self.sweep * t;
            for r in [self.radius - e, self.radius + e] {
                add([self.centre[0] + r * phi.cos(), self.centre[1] + r * phi.sin()]);
            }
        }
        for k in 0..4 {
            let phi = k as f64 * std::f64::consts::FRAC_PI_2;
            if self.fraction_of(phi).is_some() {
                let r = self.radius + e;
                add([self.centre[0] + r * phi.cos(), self.centre[1] + r * phi.sin()]);
            }
        }
        bb
    }
}

impl Scratch {
    /// Whether this scratch is an arc (bulge != 0).
    pub fn is_arc(&self) -> bool {
        self.bulge != 0.0
    }

    /// The arc's circle and sweep; None for a straight scratch (or coincident endpoints).
    pub fn arc(&self) -> Option<ArcGeom> {
        ArcGeom::of(self.p0, self.p1, self.bulge)
    }

    /// Length along the scratch's path: the arc's for an arc, |p1 - p0| for a straight one.
    pub fn path_length(&self) -> f64 {
        match self.arc() {
            Some(a) => a.length(),
            None => self.length(),
        }
    }

    /// Axis-aligned box [xmin, ymin, xmax, ymax] of the carved region (the band of half-width
    /// `half_width()` along the path).
    pub fn carved_bbox(&self) -> [f64; 4] {
        let e = self.half_width();
        if let Some(a) = self.arc() {
            return a.band_bbox(e);
        }
        let l = self.length();
        let (tx, ty) = if l > 0.0 {
            ((self.p1[0] - self.p0[0]) / l, (self.p1[1] - self.p0[1]) / l)
        } else {
            (1.0, 0.0)
        };
        let mut bb = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
        for p in [self.p0, self.p1] {
            for sg in [-1.0, 1.0] {
                let q = [p[0] - sg * e * ty, p[1] + sg * e * tx];
                bb[0] = bb[0].min(q[0]);
                bb[1] = bb[1].min(q[1]);
                bb[2] = bb[2].max(q[0]);
                bb[3] = bb[3].max(q[1]);
            }
        }
        bb
    }

    /// The arc as `n` straight scratches along its chords (endpoints on the arc at equal angles,
    /// the same w, d and alpha); a straight scratch is itself.
    pub fn chords(&self, n: usize) -> Vec<Scratch> {
        let a = match self.arc() {
            Some(a) if n > 1 => a,
            _ => {
                let mut s = *self;
                s.bulge = 0.0;
                return vec![s];
            }
        };
        (0..n)
            .map(|k| {
                let p0 = if k == 0 { self.p0 } else { a.point(k as f64 / n as f64) };
                let p1 = if k + 1 == n {
                    self.p1
                } else {
                    a.point((k + 1) as f64 / n as f64)
                };
                Scratch {
                    p0,
                    p1,
                    bulge: 0.0,
                    ..*self
                }
            })
            .collect()
    }
}

/// The point at fraction `t` of the way along the arc from `p0` to `p1` with `bulge`, and its
/// derivatives with respect to (x0, y0, x1, y1, bulge): the chain rule from a chord's endpoints
/// to its arc's parameters. In complex numbers P(t) = p0 + (p1 - p0) g(t), with
/// g = rho e^{i a}, rho = sin(theta t / 2) / sin(theta / 2), a = theta (t - 1) / 2 and
/// theta = 4 atan(bulge) (the chord from p0 to P(t) is |p1 - p0| rho long and turned by a from
/// the chord p0 -> p1); at bulge 0, g = t.
pub fn point_and_jacobian(p0: [f64; 2], p1: [f64; 2], bulge: f64, t: f64) -> ([f64; 2], [[f64; 5]; 2]) {
    let theta = 4.0 * bulge.atan();
    let dtheta = 4.0 / (1.0 + bulge * bulge);
    let (rho, drho) = if theta.abs() < 1e-6 {
        // rho = t (1 + (1 - t^2) theta^2 / 24 + ...)
        (
            t * (1.0 + (1.0 - t * t) * theta * theta / 24.0),
            t * (1.0 - t * t) * theta / 12.0,
        )
    } else {
        let (sh, ch) = (0.5 * theta).sin_cos();
        let (st, ct) = (0.5 * theta * t).sin_cos();
        (st / sh, (0.5 * t * ct * sh - 0.5 * st * ch) / (sh * sh))
    };
    let a = 0.5 * theta * (t - 1.0);
    let da = 0.5 * (t - 1.0);
    let g = [rho * a.cos(), rho * a.sin()];
    // dg/dtheta = (rho' + i rho a') e^{i a}
    let dg = [drho * a.cos() - rho * da * a.sin(), drho * a.sin() + rho * da * a.cos()];
    let c = [p1[0] - p0[0], p1[1] - p0[1]];
    let p = [p0[0] + c[0] * g[0] - c[1] * g[1], p0[1] + c[0] * g[1] + c[1] * g[0]];
    // d/dp1 is multiplication by g; d/dp0 is 1 - that.
    let db = [
        (c[0] * dg[0] - c[1] * dg[1]) * dtheta,
        (c[0] * dg[1] + c[1] * dg[0]) * dtheta,
    ];
    let jac = [
        [1.0 - g[0], g[1], g[0], -g[1], db[0]],
        [-g[1], 1.0 - g[0], g[1], g[0], db[1]],
    ];
    (p, jac)
}

/// An arc chord's area weight k = sign(bulge) w / (2 r) = w sin(theta / 2) / |p1 - p0|
/// (`scratchart-render`'s chords), and its derivatives with respect to (x0, y0, x1, y1, w, bulge).
pub fn chord_weight_and_gradient(p0: [f64; 2], p1: [f64; 2], w: f64, bulge: f64) -> (f64, [f64; 6]) {
    let c = [p1[0] - p0[0], p1[1] - p0[1]];
    let len = c[0].hypot(c[1]);
    let theta = 4.0 * bulge.atan();
    let (sh, ch) = (0.5 * theta).sin_cos();
    let k = w * sh / len;
    let dlen = [-c[0] / len, -c[1] / len, c[0] / len, c[1] / len];
    let dk_dlen = -k / len;
    (
        k,
        [
            dk_dlen * dlen[0],
            dk_dlen * dlen[1],
            dk_dlen * dlen[2],
            dk_dlen * dlen[3],
            sh / len,
            w * 0.5 * ch / len * 4.0 / (1.0 + bulge * bulge),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arc(p0: [f64; 2], p1: [f64; 2], bulge: f64) -> Scratch {
        Scratch {
            p0,
            p1,
            w: 0.1,
            d: 0.02,
            alpha: 0.1,
            bulge,
        }
    }

    #[test]
    fn half_circle_counter_clockwise() {
        // From (1, 0) to (-1, 0) counter-clockwise: the upper half circle about the origin.
        let a = arc([1.0, 0.0], [-1.0, 0.0], 1.0).arc().unwrap();
        assert!((a.radius - 1.0).abs() < 1e-15);
        assert!(a.centre[0].abs() < 1e-15 && a.centre[1].abs() < 1e-15, "{:?}", a.centre);
        let mid = a.point(0.5);
        assert!((mid[0]).abs() < 1e-15 && (mid[1] - 1.0).abs() < 1e-15, "{mid:?}");
        assert!((a.length() - std::f64::consts::PI).abs() < 1e-14);
        // Clockwise: the lower half.
        let b = arc([1.0, 0.0], [-1.0, 0.0], -1.0).arc().unwrap();
        assert!((b.point(0.5)[1] + 1.0).abs() < 1e-15);
        let t = b.tangent(0.0);
        assert!((t[1] + 1.0).abs() < 1e-15, "{t:?}");
    }

    #[test]
    fn ends_and_sagitta() {
        for &b in &[0.05, -0.3, 0.9, -2.0, 2.4] {
            let s = arc([-2.0, 0.5], [3.0, -1.0], b);
            let a = s.arc().unwrap();
            for (t, p) in [(0.0, s.p0), (1.0, s.p1)] {
                let q = a.point(t);
                assert!(
                    (q[0] - p[0]).abs() < 1e-12 && (q[1] - p[1]).abs() < 1e-12,
                    "b {b} t {t}: {q:?}"
                );
            }
            // The sagitta is b times half the chord, on the right of p0 -> p1 for b > 0.
            let m = a.point(0.5);
            let c = s.length();
            let (dx, dy) = ((s.p1[0] - s.p0[0]) / c, (s.p1[1] - s.p0[1]) / c);
            let mid = [0.5 * (s.p0[0] + s.p1[0]), 0.5 * (s.p0[1] + s.p1[1])];
            let left = (m[0] - mid[0]) * -dy + (m[1] - mid[1]) * dx;
            assert!((left + b * 0.5 * c).abs() < 1e-12, "b {b}: {left}");
            let chords = s.chords(7);
            assert_eq!(chords.len(), 7);
            assert_eq!(chords[0].p0, s.p0);
            assert_eq!(chords[6].p1, s.p1);
            let bb = s.carved_bbox();
            for k in 0..=100 {
                let q = a.point(k as f64 / 100.0);
                assert!(q[0] >= bb[0] && q[0] <= bb[2] && q[1] >= bb[1] && q[1] <= bb[3]);
            }
        }
    }

    /// The chain rule's Jacobians agree with central differences, and the points with the arc's.
    #[test]
    fn jacobians_match_central_differences() {
        let p0 = [-1.3, 0.4];
        let p1 = [2.1, -0.7];
        for &b in &[0.0, 1e-9, 0.3, -0.8, 1.0, -2.2] {
            for &t in &[0.0, 0.17, 0.5, 0.93, 1.0] {
                let (p, j) = point_and_jacobian(p0, p1, b, t);
                // (The centre form loses digits for tiny bulges, whose radius is huge.)
                if let Some(a) = ArcGeom::of(p0, p1, b).filter(|_| b.abs() > 1e-3) {
                    let q = a.point(t);
                    assert!(
                        (p[0] - q[0]).abs() < 1e-12 && (p[1] - q[1]).abs() < 1e-12,
                        "b {b} t {t}"
                    );
                }
                let h = 1e-6;
                for v in 0..5 {
                    let mut x = [p0[0], p0[1], p1[0], p1[1], b];
                    x[v] += h;
                    let up = point_and_jacobian([x[0], x[1]], [x[2], x[3]], x[4], t).0;
                    x[v] -= 2.0 * h;
                    let down = point_and_jacobian([x[0], x[1]], [x[2], x[3]], x[4], t).0;
                    for c in 0..2 {
                        let fd = (up[c] - down[c]) / (2.0 * h);
                        assert!(
                            (fd - j[c][v]).abs() < 1e-7 * (1.0 + fd.abs()),
                            "b {b} t {t} d{c}/d{v}: {fd} vs {}",
                            j[c][v]
                        );
                    }
                }
            }
            if b != 0.0 {
                let w = 0.07;
                let (k, g) = chord_weight_and_gradient(p0, p1, w, b);
                let a = ArcGeom::of(p0, p1, b).unwrap();
                assert!((k - b.signum() * w / (2.0 * a.radius)).abs() < 1e-14);
                let h = 1e-6;
                for v in 0..6 {
                    let mut x = [p0[0], p0[1], p1[0], p1[1], w, b];
                    x[v] += h;
                    let up = chord_weight_and_gradient([x[0], x[1]], [x[2], x[3]], x[4], x[5]).0;
                    x[v] -= 2.0 * h;
                    let down = chord_weight_and_gradient([x[0], x[1]], [x[2], x[3]], x[4], x[5]).0;
                    let fd = (up - down) / (2.0 * h);
                    assert!(
                        (fd - g[v]).abs() < 1e-7 * (1.0 + fd.abs()),
                        "b {b} dk/d{v}: {fd} vs {}",
                        g[v]
                    );
                }
            }
        }
    }
}
