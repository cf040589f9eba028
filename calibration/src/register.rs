//! Photos of the card, registered to its capture views.
//!
//! The card is flat, so a photo taken from near (not exactly at) the capture position is related
//! to the capture view by a homography of the plate plane, fitted to the card's fiducial marks
//! ([`crate::fiducials`]: a robust match of bright blobs to the marks' layout, each mark with a
//! confidence). Fewer than four marks that fit one view of a flat card means the card was not
//! found, and says so. From the homography of the plate itself, [`camera_from_homography`]
//! recovers the camera that took the photo.
use scratchart::model::scene::View;

pub use super::fiducials::{apply, find_marks, homography_lsq, nominal_marks, Found};
pub use super::photo::{load_photo, resize, Gray};

use super::card::Card;

/// A photo registered to a capture view: its values on the view's raster and where they are
/// valid (inside the photo).
#[derive(Clone, Debug)]
pub struct Registered {
    /// The photo resized to the view's raster (before the homography).
    pub photo: Gray,
    /// The homography from the view's image points to the resized photo's.
    pub h: [f64; 9],
    pub image: Vec<f32>,
    pub valid: Vec<bool>,
    /// The card's marks found in the (resized) photo, in the card's order (`None`: not found),
    /// with their confidences and the plate-to-photo homography.
    pub found: Found,
    /// Largest distance between a found mark and the capture view's, pixels (how far the
    /// photo's pose was from the capture position).
    pub pose_offset_px: f64,
}

/// Samples `photo` at H(A(p)) for every pixel centre p of a `w` x `h` raster, where A is the
/// affine correction p + (a0 + a2 x' + a3 y', a1 + a4 x' + a5 y') about the raster's centre
/// (x' = x - w/2, y' = y - h/2). Pixels outside the photo are 0 and invalid.
pub fn warp(photo: &Gray, hm: &[f64; 9], a: &[f64; 6], w: u32, h: u32) -> (Vec<f32>, Vec<bool>) {
    let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
    let mut image = Vec::with_capacity((w * h) as usize);
    let mut valid = Vec::with_capacity((w * h) as usize);
    for j in 0..h {
        for i in 0..w {
            let (x, y) = (i as f64 + 0.5, j as f64 + 0.5);
            let p = [
                x + a[0] + a[2] * (x - cx) + a[3] * (y - cy),
                y + a[1] + a[4] * (x - cx) + a[5] * (y - cy),
            ];
            let q = apply(hm, p);
            match photo.sample_cubic(q[0], q[1]) {
                Some(v) => {
                    image.push(v);
                    valid.push(true);
                }
                None => {
                    image.push(0.0);
                    valid.push(false);
                }
            }
        }
    }
    (image, valid)
}

/// The camera that took a photo of `w` x `h` pixels (square pixels, principal point at the
/// centre, MODEL.md's pinhole) from the homography `g` that maps plate points (x, y) in mm to
/// its image points: with u = sx - w/2, v = h/2 - sy, g ~ K [r1 r2 t] with K = diag(f, f, 1),
/// and the two rotation columns r1, r2 being orthogonal and of equal length gives f (least
/// squares over both conditions); the rest follows. `None` when the homography is not that of
/// a camera looking down at the plate.
pub fn camera_from_homography(g: &[f64; 9], w: u32, h: u32) -> Option<scratchart::model::scene::Camera> {
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
pub fn camera_with_focal(g: &[f64; 9], w: u32, h: u32, f: f64) -> Option<scratchart::model::scene::Camera> {
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
    // MODEL.md's frame (right = forward x up) is left-handed as rows, so det R = -1 and the
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
    // MODEL.md's camera: right = forward x up. A mirrored solution is not a camera.
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
    Some(scratchart::model::scene::Camera {
        eye,
        target: std::array::from_fn(|i| eye[i] + dist * forward[i]),
        up,
        fov_y_deg: 2.0 * (0.5 * h as f64 / f).atan().to_degrees(),
        width: w,
        height: h,
    })
}

/// Registers `photo` to capture view `view` of `card` (the photo is resized to the view's raster
/// first).
pub fn register(photo: &Gray, card: &Card, view: &View) -> Result<Registered, String> {
    let (w, h) = (view.camera.width, view.camera.height);
    let img = resize(photo, w, h);
    let found = find_marks(&img, card, view)?;
    let (nominal, _) = nominal_marks(card, view);
    let (s, d): (Vec<[f64; 2]>, Vec<[f64; 2]>) = found
        .points
        .iter()
        .zip(&nominal)
        .filter_map(|(p, n)| p.map(|p| (*n, p)))
        .unzip();
    let hm = homography_lsq(&s, &d).ok_or("the marks found are degenerate (collinear)")?;
    let (image, valid) = warp(&img, &hm, &[0.0; 6], w, h);
    let pose_offset_px = s
        .iter()
        .zip(&d)
        .map(|(n, p)| (p[0] - n[0]).hypot(p[1] - n[1]))
        .fold(0.0, f64::max);
    Ok(Registered {
        photo: img,
        h: hm,
        image,
        valid,
        found,
        pose_offset_px,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn homography_maps_the_four_points_and_between() {
        let src = [[10.0, 10.0], [200.0, 12.0], [210.0, 190.0], [5.0, 180.0]];
        let dst = [[20.0, 30.0], [190.0, 25.0], [230.0, 210.0], [15.0, 170.0]];
        let h = homography_lsq(&src, &dst).unwrap();
        for k in 0..4 {
            let q = apply(&h, src[k]);
            assert!(
                (q[0] - dst[k][0]).abs() < 1e-9 && (q[1] - dst[k][1]).abs() < 1e-9,
                "{q:?}"
            );
        }
        // The identity maps to itself.
        let id = homography_lsq(&src, &src).unwrap();
        let q = apply(&id, [77.0, 33.0]);
        assert!((q[0] - 77.0).abs() < 1e-9 && (q[1] - 33.0).abs() < 1e-9);
        // Collinear points have none.
        assert!(homography_lsq(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]], &dst).is_none());
    }

    #[test]
    fn bilinear_sample_is_exact_at_centres_and_between() {
        let g = Gray {
            width: 2,
            height: 1,
            data: vec![0.0, 1.0],
        };
        assert_eq!(g.sample(0.5, 0.5), Some(0.0));
        assert_eq!(g.sample(1.5, 0.5), Some(1.0));
        assert_eq!(g.sample(1.0, 0.5), Some(0.5));
        assert_eq!(g.sample(2.5, 0.5), None);
    }
}

#[cfg(test)]
mod camera_tests {
    use super::*;
    use crate::card::CardSpec;
    use scratchart::model::camera::ViewGeom;

    /// The camera of a capture view comes back from the homography of its own projections.
    #[test]
    fn a_camera_is_recovered_from_its_plate_homography() {
        let card = Card::new(&CardSpec::default());
        for view in card.views(256) {
            let g = ViewGeom::new(&view);
            let (nominal, _) = nominal_marks(&card, &view);
            let plate: Vec<[f64; 2]> = card.marks.iter().map(|m| m.centre).collect();
            let hp = homography_lsq(&plate, &nominal).unwrap();
            let cam = camera_from_homography(&hp, 256, 256).expect("a camera");
            for k in 0..3 {
                assert!(
                    (cam.eye[k] - view.camera.eye[k]).abs() < 1e-6,
                    "{:?} vs {:?}",
                    cam.eye,
                    view.camera.eye
                );
            }
            assert!((cam.fov_y_deg - view.camera.fov_y_deg).abs() < 1e-9);
            // It projects plate points where the view does.
            let back = ViewGeom::new(&View {
                camera: cam,
                ..view.clone()
            });
            for p in [[10.0, -7.0, 0.0], [-30.0, 25.0, 0.0]] {
                let (a, b) = (g.project(p).unwrap(), back.project(p).unwrap());
                assert!((a.0 - b.0).abs() < 1e-6 && (a.1 - b.1).abs() < 1e-6, "{a:?} vs {b:?}");
            }
        }
    }
}
