//! Plane-to-image maps of the marks: the homography by least squares, and the affine map of
//! three points (the hypotheses of `find_marks`).

/// The homography H (row-major 3x3, H[8] = 1) with H src[k] ~ dst[k], least squares over all
/// pairs (at least 4), after moving each point set to its centroid and unit spread (Hartley's
/// normalization).
pub fn homography_lsq(src: &[[f64; 2]], dst: &[[f64; 2]]) -> Option<[f64; 9]> {
    if src.len() < 4 || src.len() != dst.len() {
        return None;
    }
    let norm = |p: &[[f64; 2]]| {
        let n = p.len() as f64;
        let (mx, my) = (
            p.iter().map(|q| q[0]).sum::<f64>() / n,
            p.iter().map(|q| q[1]).sum::<f64>() / n,
        );
        let d = p.iter().map(|q| (q[0] - mx).hypot(q[1] - my)).sum::<f64>() / n;
        let s = if d > 0.0 { 2f64.sqrt() / d } else { 1.0 };
        (s, mx, my)
    };
    let (ss, sx, sy) = norm(src);
    let (ds, dx, dy) = norm(dst);
    // Normal equations of the 2n x 8 system with h33 = 1.
    let mut ata = [[0.0f64; 8]; 8];
    let mut atb = [0.0f64; 8];
    for (a, b) in src.iter().zip(dst) {
        let (x, y) = ((a[0] - sx) * ss, (a[1] - sy) * ss);
        let (u, v) = ((b[0] - dx) * ds, (b[1] - dy) * ds);
        for (row, rhs) in [
            ([x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y], u),
            ([0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y], v),
        ] {
            for i in 0..8 {
                atb[i] += row[i] * rhs;
                for j in 0..8 {
                    ata[i][j] += row[i] * row[j];
                }
            }
        }
    }
    let a: Vec<Vec<f64>> = ata.iter().map(|r| r.to_vec()).collect();
    let hn = scratchart_optim::least_squares::solve_spd(&a, &atb)?;
    let hn = [hn[0], hn[1], hn[2], hn[3], hn[4], hn[5], hn[6], hn[7], 1.0];
    // H = Td^-1 Hn Ts.
    let ts = [ss, 0.0, -ss * sx, 0.0, ss, -ss * sy, 0.0, 0.0, 1.0];
    let td_inv = [1.0 / ds, 0.0, dx, 0.0, 1.0 / ds, dy, 0.0, 0.0, 1.0];
    let h = mul3(&td_inv, &mul3(&hn, &ts));
    if !(h[8].abs() > 1e-15) || h.iter().any(|v| !v.is_finite()) {
        return None;
    }
    Some(h.map(|v| v / h[8]))
}

fn mul3(a: &[f64; 9], b: &[f64; 9]) -> [f64; 9] {
    let mut c = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            c[3 * i + j] = (0..3).map(|k| a[3 * i + k] * b[3 * k + j]).sum();
        }
    }
    c
}

/// Applies H to the point p.
pub fn apply(h: &[f64; 9], p: [f64; 2]) -> [f64; 2] {
    let z = h[6] * p[0] + h[7] * p[1] + h[8];
    [
        (h[0] * p[0] + h[1] * p[1] + h[2]) / z,
        (h[3] * p[0] + h[4] * p[1] + h[5]) / z,
    ]
}

/// The affine map [a b c; d e f] with A src[k] = dst[k] for three pairs.
pub(super) fn affine3(src: [[f64; 2]; 3], dst: [[f64; 2]; 3]) -> Option<[f64; 6]> {
    let (p, q, r) = (src[0], src[1], src[2]);
    let (ux, uy, vx, vy) = (q[0] - p[0], q[1] - p[1], r[0] - p[0], r[1] - p[1]);
    let det = ux * vy - uy * vx;
    if det.abs() < 1e-9 {
        return None;
    }
    let (p2, q2, r2) = (dst[0], dst[1], dst[2]);
    let (sx, sy, tx, ty) = (q2[0] - p2[0], q2[1] - p2[1], r2[0] - p2[0], r2[1] - p2[1]);
    // M [u v] = [s t]  =>  M = [s t] [u v]^-1.
    let inv = [vy / det, -vx / det, -uy / det, ux / det];
    let a = sx * inv[0] + tx * inv[2];
    let b = sx * inv[1] + tx * inv[3];
    let d = sy * inv[0] + ty * inv[2];
    let e = sy * inv[1] + ty * inv[3];
    Some([a, b, p2[0] - a * p[0] - b * p[1], d, e, p2[1] - d * p[0] - e * p[1]])
}
