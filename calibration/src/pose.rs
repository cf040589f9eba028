//! The camera that took a photo of the flat card, from the homography that maps plate points to
//! the photo's (engine/docs/model.md's pinhole: square pixels, principal point at the centre): the closed
//! form, and the focal length near a hint where the closed form is poorly determined. The marks'
//! search ([`crate::fiducials`]) and the registration ([`crate::register`]) both use it.

/// The camera that took a photo of `w` x `h` pixels (square pixels, principal point at the
/// centre, engine/docs/model.md's pinhole) from the homography `g` that maps plate points (x, y) in mm to
/// its image points: with u = sx - w/2, v = h/2 - sy, g ~ K [r1 r2 t] with K = diag(f, f, 1),
/// and the two rotation columns r1, r2 being orthogonal and of equal length gives f (least
/// squares over both conditions); the rest follows. `None` when the homography is not that of
/// a camera looking down at the plate.
pub fn camera_from_homography(g: &[f64; 9], w: u32, h: u32) -> Option<scratchart_model::scene::Camera> {
    // M = diag(1, -1, 1) T^-1 g: plate -> (u, v, 1).
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
    let row = |r: usize| [g[3 * r], g[3 * r + 1], g[3 * r + 2]];
    let (r0, r1, r2) = (row(0), row(1), row(2));
    let m0: [f64; 3] = std::array::from_fn(|c| r0[c] - cx * r2[c]);
    let m1: [f64; 3] = std::array::from_fn(|c| -(r1[c] - cy * r2[c]));
    let m = [m0, m1, r2]; // rows of M
    let col = |c: usize| [m[0][c], m[1][c], m[2][c]];
    let (a, b) = (col(0), col(1));
    // Orthogonality: (a0 b0 + a1 b1) q + a2 b2 = 0; equal norms:
    // (a0^2 + a1^2 - b0^2 - b1^2) q + a2^2 - b2^2 = 0, with q = 1 / f^2.
    let (p1, s1) = (a[0] * b[0] + a[1] * b[1], a[2] * b[2]);
    let (p2, s2) = (
        a[0] * a[0] + a[1] * a[1] - b[0] * b[0] - b[1] * b[1],
        a[2] * a[2] - b[2] * b[2],
    );
    let q = -(p1 * s1 + p2 * s2) / (p1 * p1 + p2 * p2);
    if !(q > 0.0 && q.is_finite()) {
        return None;
    }
    camera_with_focal(g, w, h, 1.0 / q.sqrt())
}

/// The focal length (pixels), within a factor 3 of `f_hint`, that makes the homography `g` most
/// nearly a camera's (its two rotation columns orthogonal and of equal length), with a weak
/// prior that the camera stood `dist_hint` from the card (the capture guide's distance; a
/// phone's focal length is unknown): a homography fitted to a few marks on a card small
/// against its distance leaves f poorly determined (it trades with the distance), and the
/// closed form of [`camera_from_homography`] can then be far off or fail.
pub fn focal_near(g: &[f64; 9], w: u32, h: u32, f_hint: f64, dist_hint: f64) -> f64 {
    // The weight of the prior on the distance (a factor 1.25 at one unit), against the defect
    // (which is 0 for an exact camera homography). Over random phone shots (examples/
    // detect_probe) 1e-3 gave the smallest eye errors: median 2.6 mm, 90% within 8 mm; 1e-4
    // 2.7 and 6.8 but more distances off by half; 1e-2 3.7 and 12.7.
    let prior = 1e-3;
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
    let m0: [f64; 3] = std::array::from_fn(|c| g[c] - cx * g[6 + c]);
    let m1: [f64; 3] = std::array::from_fn(|c| -(g[3 + c] - cy * g[6 + c]));
    let (a, b) = ([m0[0], m1[0], g[6]], [m0[1], m1[1], g[7]]);
    let defect = |f: f64| {
        let (ka, kb) = ([a[0] / f, a[1] / f, a[2]], [b[0] / f, b[1] / f, b[2]]);
        let (aa, bb) = (
            ka[0] * ka[0] + ka[1] * ka[1] + ka[2] * ka[2],
            kb[0] * kb[0] + kb[1] * kb[1] + kb[2] * kb[2],
        );
        let ab = ka[0] * kb[0] + ka[1] * kb[1] + ka[2] * kb[2];
        (ab * ab + 0.25 * (aa - bb) * (aa - bb)) / (aa * bb)
    };
    // A weak prior at the hint (log-normal, a factor 2 at one sigma): where the card is small
    // against its distance (weak perspective) the homography hardly tells f, and the defect is
    // flat; where it does, the defect's minimum is sharp and wins.
    let dist = |f: f64| {
        camera_with_focal(g, w, h, f).map_or(f64::INFINITY, |c| {
            (c.eye[0] * c.eye[0] + c.eye[1] * c.eye[1] + c.eye[2] * c.eye[2]).sqrt()
        })
    };
    let defect = |f: f64| defect(f) + prior * ((dist(f) / dist_hint).ln() / 1.25f64.ln()).powi(2);
    // A log grid over [f/3, 3f], then golden section around its best.
    let (lo, hi) = ((f_hint / 3.0).ln(), (3.0 * f_hint).ln());
    let n = 60;
    let best = (0..=n)
        .map(|k| lo + (hi - lo) * k as f64 / n as f64)
        .min_by(|x, y| defect(x.exp()).total_cmp(&defect(y.exp())))
        .unwrap_or(f_hint.ln());
    let step = (hi - lo) / n as f64;
    let (mut x0, mut x1) = (best - step, best + step);
    let gr = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..40 {
        let (m1, m2) = (x1 - gr * (x1 - x0), x0 + gr * (x1 - x0));
        if defect(m1.exp()) < defect(m2.exp()) {
            x1 = m2;
        } else {
            x0 = m1;
        }
    }
    (0.5 * (x0 + x1)).exp()
}

/// The camera of focal length `f` pixels whose plate homography is (nearest) `g`, for a `w` x
/// `h` photo (see [`camera_from_homography`]).
pub fn camera_with_focal(g: &[f64; 9], w: u32, h: u32, f: f64) -> Option<scratchart_model::scene::Camera> {
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
    let row = |r: usize| [g[3 * r], g[3 * r + 1], g[3 * r + 2]];
    let (r0, r1, r2) = (row(0), row(1), row(2));
    let m0: [f64; 3] = std::array::from_fn(|c| r0[c] - cx * r2[c]);
    let m1: [f64; 3] = std::array::from_fn(|c| -(r1[c] - cy * r2[c]));
    let m = [m0, m1, r2];
    let col = |c: usize| [m[0][c], m[1][c], m[2][c]];
    let (a, b, t) = (col(0), col(1), col(2));
    let kinv = |v: [f64; 3]| [v[0] / f, v[1] / f, v[2]];
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let (ka, kb, kt) = (kinv(a), kinv(b), kinv(t));
    let mut lambda = 2.0 / (norm(ka) + norm(kb));
    if kt[2] * lambda < 0.0 {
        lambda = -lambda; // the plate lies in front of the camera
    }
    let c0: Vec<f64> = ka.iter().map(|x| x * lambda).collect();
    let c1: Vec<f64> = kb.iter().map(|x| x * lambda).collect();
    let tt: Vec<f64> = kt.iter().map(|x| x * lambda).collect();
    // Gram-Schmidt on the two columns, the third by the cross product.
    let n0 = norm([c0[0], c0[1], c0[2]]);
    let e0 = [c0[0] / n0, c0[1] / n0, c0[2] / n0];
    let d = c1[0] * e0[0] + c1[1] * e0[1] + c1[2] * e0[2];
    let c1o = [c1[0] - d * e0[0], c1[1] - d * e0[1], c1[2] - d * e0[2]];
    let n1 = norm(c1o);
    let e1 = [c1o[0] / n1, c1o[1] / n1, c1o[2] / n1];
    // engine/docs/model.md's frame (right = forward x up) is left-handed as rows, so det R = -1 and the
    // third column is -(e0 x e1).
    let e2 = [
        -(e0[1] * e1[2] - e0[2] * e1[1]),
        -(e0[2] * e1[0] - e0[0] * e1[2]),
        -(e0[0] * e1[1] - e0[1] * e1[0]),
    ];
    // R has columns e0, e1, e2; its rows are the camera's right, up and forward in world axes.
    let right = [e0[0], e1[0], e2[0]];
    let up = [e0[1], e1[1], e2[1]];
    let forward = [e0[2], e1[2], e2[2]];
    // engine/docs/model.md's camera: right = forward x up. A mirrored solution is not a camera.
    let fx = [
        forward[1] * up[2] - forward[2] * up[1],
        forward[2] * up[0] - forward[0] * up[2],
        forward[0] * up[1] - forward[1] * up[0],
    ];
    if fx[0] * right[0] + fx[1] * right[1] + fx[2] * right[2] < 0.5 {
        return None;
    }
    // eye = -R^T t
    let eye: [f64; 3] = std::array::from_fn(|i| -(right[i] * tt[0] + up[i] * tt[1] + forward[i] * tt[2]));
    if !(eye[2] > 0.0) {
        return None;
    }
    let dist = tt[2];
    Some(scratchart_model::scene::Camera {
        eye,
        target: std::array::from_fn(|i| eye[i] + dist * forward[i]),
        up,
        fov_y_deg: 2.0 * (0.5 * h as f64 / f).atan().to_degrees(),
        width: w,
        height: h,
    })
}
