//! Photos of the card, registered to its capture views.
//!
//! The card is flat, so a photo taken from near (not exactly at) the capture position is related
//! to the capture view by a homography of the plate plane, found from the card's four corner
//! crosses ([`crate::fiducials`]). A quadrilateral of crosses that is not convex, or much smaller
//! than expected, means the card was not found, and says so. From the homography of the plate
//! itself, [`camera_from_homography`] recovers the camera that took the photo.
use scratchart::model::scene::View;

pub use super::fiducials::{arm_directions, find_fiducials, nominal_fiducials};
pub use super::photo::{load_photo, resize, Gray};

use super::card::{Card, CutRole};

/// The homography H (row-major 3x3, H[8] = 1) with H src[k] ~ dst[k] for the four pairs.
pub fn homography(src: &[[f64; 2]; 4], dst: &[[f64; 2]; 4]) -> Option<[f64; 9]> {
    let mut a = [[0.0f64; 9]; 8];
    for k in 0..4 {
        let ([x, y], [u, v]) = (src[k], dst[k]);
        a[2 * k] = [x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, u];
        a[2 * k + 1] = [0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, v];
    }
    // Gaussian elimination with partial pivoting on the 8x8 system (last column: right side).
    for col in 0..8 {
        let piv = (col..8).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() < 1e-12 {
            return None;
        }
        a.swap(col, piv);
        for r in 0..8 {
            if r != col {
                let f = a[r][col] / a[col][col];
                for c in col..9 {
                    a[r][c] -= f * a[col][c];
                }
            }
        }
    }
    let mut h = [0.0; 9];
    for k in 0..8 {
        h[k] = a[k][8] / a[k][k];
    }
    h[8] = 1.0;
    Some(h)
}

/// Applies H to the image point p.
pub fn apply(h: &[f64; 9], p: [f64; 2]) -> [f64; 2] {
    let z = h[6] * p[0] + h[7] * p[1] + h[8];
    [
        (h[0] * p[0] + h[1] * p[1] + h[2]) / z,
        (h[3] * p[0] + h[4] * p[1] + h[5]) / z,
    ]
}

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
    /// The fiducials found in the (resized) photo.
    pub fiducials: [[f64; 2]; 4],
    /// Largest distance between a found fiducial and the capture view's, pixels (how far the
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
    let (a, b, t) = (col(0), col(1), col(2));
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
    let f = 1.0 / q.sqrt();
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

/// The homography from plate points (mm) to the photo's image points, from the fiducials found
/// in it.
pub fn plate_homography(card: &Card, found: &[[f64; 2]; 4]) -> Option<[f64; 9]> {
    let fid: Vec<_> = card.cuts.iter().filter(|c| c.role == CutRole::Fiducial).collect();
    let mut plate = [[0.0; 2]; 4];
    for (k, pair) in fid.chunks(2).take(4).enumerate() {
        let c = pair[0];
        plate[k] = [0.5 * (c.p0[0] + c.p1[0]), 0.5 * (c.p0[1] + c.p1[1])];
    }
    homography(&plate, found)
}

/// Registers `photo` to capture view `view` of `card`.
pub fn register(photo: &Gray, card: &Card, view: &View) -> Result<Registered, String> {
    let (w, h) = (view.camera.width, view.camera.height);
    let img = resize(photo, w, h);
    let (nominal, arm) = nominal_fiducials(card, view);
    let found = find_fiducials(&img, &nominal, &arm_directions(card, view), arm)?;
    let hm = homography(&nominal, &found).ok_or("the corner crosses are degenerate (collinear)")?;
    let (image, valid) = warp(&img, &hm, &[0.0; 6], w, h);
    let pose_offset_px = (0..4)
        .map(|k| (found[k][0] - nominal[k][0]).hypot(found[k][1] - nominal[k][1]))
        .fold(0.0, f64::max);
    Ok(Registered {
        photo: img,
        h: hm,
        image,
        valid,
        fiducials: found,
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
        let h = homography(&src, &dst).unwrap();
        for k in 0..4 {
            let q = apply(&h, src[k]);
            assert!(
                (q[0] - dst[k][0]).abs() < 1e-9 && (q[1] - dst[k][1]).abs() < 1e-9,
                "{q:?}"
            );
        }
        // The identity maps to itself.
        let id = homography(&src, &src).unwrap();
        let q = apply(&id, [77.0, 33.0]);
        assert!((q[0] - 77.0).abs() < 1e-9 && (q[1] - 33.0).abs() < 1e-9);
        // Collinear points have none.
        assert!(homography(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]], &dst).is_none());
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
            let (nominal, _) = nominal_fiducials(&card, &view);
            let hp = plate_homography(&card, &nominal).unwrap();
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
