//! Convex polygons in a scratch's local (u, v) frame: exact clipping against the carved
//! rectangle (Sutherland-Hodgman, one axis-aligned half-plane at a time), areas and the chord
//! length along v at a given u, which the integral over u needs.

/// Shoelace area (absolute value) of a polygon.
pub(super) fn polygon_area(p: &[[f64; 2]]) -> f64 {
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
pub(super) fn clip(poly: &[[f64; 2]], axis: usize, c: f64, sign: f64) -> Vec<[f64; 2]> {
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
pub(super) fn chord_at(poly: &[[f64; 2]], u: f64) -> f64 {
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

#[cfg(test)]
mod tests {
    use super::*;

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
