//! Photos of the card, registered to its capture views.
//!
//! The card is flat, so a photo taken from near (not exactly at) the capture position is related
//! to the capture view by a homography of the plate plane, fitted to the card's fiducial marks
//! ([`crate::fiducials`]: a robust match of bright blobs to the marks' layout, each mark with a
//! confidence). Fewer than four marks that fit one view of a flat card means the card was not
//! found, and says so. From the homography of the plate itself, [`crate::pose::camera_from_homography`]
//! recovers the camera that took the photo.
use scratchart_model::scene::View;

use super::fiducials::{apply, find_marks, homography_lsq, nominal_marks, Found};
use super::photo::{resize, Gray};

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
    use crate::pose::camera_from_homography;
    use scratchart_model::camera::ViewGeom;

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
                exposure: 1.0,
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
