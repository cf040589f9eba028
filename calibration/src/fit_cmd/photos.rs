//! The photos of a fit: paired with the capture views by name or order, placed by the card's
//! marks where given in another order, and each inspected and loaded for the fit.
use std::path::PathBuf;

use anyhow::Result;
use scratchart_exit::{InputError, UsageError};
use scratchart_observe::Observer;
use serde_json::json;

use super::inspect_photo;
use crate::card::Card;

/// Pairs photos with capture views: by file name (the view's name) when every photo names one,
/// else in order.
pub(super) fn pair_photos(images: &[PathBuf], names: &[String]) -> Result<Vec<PathBuf>> {
    if images.len() < names.len() {
        return Err(InputError(format!(
            "the fit needs one photo per capture view ({}), got {}; photograph the card from each",
            names.join(", "),
            images.len()
        ))
        .into());
    }
    let stem = |p: &PathBuf| {
        p.file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default()
    };
    let by_name: Vec<Option<&PathBuf>> = names.iter().map(|n| images.iter().find(|p| stem(p) == *n)).collect();
    if by_name.iter().all(|p| p.is_some()) {
        return Ok(by_name.into_iter().map(|p| p.unwrap().clone()).collect());
    }
    if images.len() != names.len() {
        return Err(UsageError(format!(
            "{} photos for {} capture views: name each after its view ({}) or give exactly one per view in order",
            images.len(),
            names.len(),
            names.join(", ")
        ))
        .into());
    }
    Ok(images.to_vec())
}

/// Whether every capture view has a photo named after it.
pub(super) fn all_named(images: &[PathBuf], names: &[String]) -> bool {
    names.iter().all(|n| {
        images
            .iter()
            .any(|p| p.file_stem().is_some_and(|s| s.to_string_lossy() == *n))
    })
}

/// Photos given in an order that is not the views' (IMG_0001 is the west view): each photo is
/// tried against each capture view, and where the views' order does not register every photo
/// but another order does, that order is taken and said. The card's marks fix which view a
/// photo was taken from: from another view's camera they are not found (the camera they give
/// would stand a quarter turn from it).
pub fn order_by_marks(
    card: &Card,
    capture: &scratchart_model::scene::Scene,
    files: Vec<PathBuf>,
    obs: &dyn Observer,
) -> Vec<PathBuf> {
    let n = files.len();
    if !(2..=6).contains(&n) {
        return files;
    }
    let mut ok: Vec<Vec<Option<bool>>> = vec![vec![None; n]; n];
    let mut fits = |i: usize, v: usize| -> bool {
        *ok[i][v].get_or_insert_with(|| inspect_photo(card, capture, &capture.views[v], &files[i]).is_ok())
    };
    if (0..n).all(|i| fits(i, i)) {
        return files;
    }
    // The order that registers the most photos, the views' own first among equals.
    let mut perm: Vec<usize> = (0..n).collect();
    let mut best: (usize, Vec<usize>) = ((0..n).filter(|&i| fits(i, i)).count(), perm.clone());
    while next_permutation(&mut perm) {
        let good = (0..n).filter(|&i| fits(i, perm[i])).count();
        if good > best.0 {
            best = (good, perm.clone());
        }
    }
    let (good, perm) = best;
    if perm.iter().enumerate().all(|(i, &v)| i == v) {
        return files;
    }
    let mut out = files.clone();
    for (i, &v) in perm.iter().enumerate() {
        out[v] = files[i].clone();
        if i != v {
            obs.info(&format!(
                "photo `{}` is view {} (found by the card's marks; it was given in the place of {})",
                files[i].display(),
                capture.views[v].name,
                capture.views[i].name
            ));
        }
    }
    if good < n {
        obs.info(&format!("{} of {n} photos register in any order of the views", good));
    }
    out
}

/// The next permutation in lexicographic order (false after the last).
pub(super) fn next_permutation(p: &mut [usize]) -> bool {
    let n = p.len();
    if n < 2 {
        return false;
    }
    let mut i = n - 1;
    while i > 0 && p[i - 1] >= p[i] {
        i -= 1;
    }
    if i == 0 {
        return false;
    }
    let mut j = n - 1;
    while p[j] <= p[i - 1] {
        j -= 1;
    }
    p.swap(i - 1, j);
    p[i..].reverse();
    true
}

/// What the fit takes from each photo (see [`load_photos`]).
pub(super) struct PhotoData {
    pub(super) photos: Vec<Vec<f32>>,
    pub(super) masks: Vec<Vec<bool>>,
    pub(super) refine_pose: Vec<bool>,
    pub(super) jpeg: Vec<Option<u8>>,
    pub(super) noise: Vec<f64>,
    pub(super) shrink: Vec<u32>,
    pub(super) native_noise: Vec<f64>,
    pub(super) colour: Vec<bool>,
    pub(super) saved_jpeg: Vec<Option<u8>>,
    pub(super) gains: Vec<[f64; 3]>,
}

/// Per photo, for the report: its size as taken, the marks found and their confidences, the
/// camera's eye and how far it stood from the capture position, the shrink, the sensor's noise
/// per channel at the photo's own resolution, colour or grey, and its JPEG quality.
pub(super) type PhotoRecord = serde_json::Value;

/// Each photo inspected ([`inspect_photo`]: loaded, shrunk, registered, checked) against its
/// capture view; the scene of the photos' own cameras, what the fit compares, and the report's
/// record of each photo.
pub(super) fn load_photos(
    card: &Card,
    capture: &scratchart_model::scene::Scene,
    files: &[PathBuf],
    obs: &dyn Observer,
) -> Result<(scratchart_model::scene::Scene, PhotoData, Vec<PhotoRecord>)> {
    let mut photos = Vec::new();
    let mut masks = Vec::new();
    let mut fit_views = Vec::new();
    let mut refine_pose = Vec::new();
    let mut noise = Vec::new();
    let mut shrink = Vec::new();
    let mut native_noise = Vec::new();
    let mut colour = Vec::new();
    let mut saved_jpeg = Vec::new();
    let mut gains = Vec::new();
    let mut jpeg = Vec::new();
    let mut inspections = Vec::new();
    for (v, f) in capture.views.iter().zip(files) {
        let insp = inspect_photo(card, capture, v, f)?;
        obs.info(&insp.summary());
        photos.push(insp.image.data.clone());
        masks.push(insp.mask);
        refine_pose.push(insp.off_pose);
        jpeg.push(insp.jpeg);
        noise.push(insp.noise);
        shrink.push(insp.shrink);
        native_noise.push(insp.native_noise);
        colour.push(insp.colour);
        saved_jpeg.push(insp.saved_jpeg);
        gains.push(insp.gains);
        inspections.push(json!({
            "size": [insp.taken.0, insp.taken.1],
            "marks_found": insp.found.count(),
            "mark_confidence": insp.found.confidence,
            "camera_eye_mm": insp.view.camera.eye,
            "moved_mm": insp.moved_mm,
            "shrunk_by": insp.shrink,
            "sensor_noise": insp.native_noise,
            "colour": insp.colour,
            "jpeg_quality": insp.saved_jpeg,
            "white_balance": insp.gains,
            "px_per_mm": insp.scale.photo_px_per_mm,
            "fit_px_per_mm": insp.scale.fit_px_per_mm,
            "needed_px_per_mm": insp.needed_px_per_mm,
        }));
        fit_views.push(insp.view);
    }
    let fit_scene = scratchart_model::scene::Scene {
        plate: capture.plate.clone(),
        views: fit_views,
        scratches: vec![],
    };
    fit_scene
        .validate()
        .map_err(|e| InputError(format!("the photos' cameras do not make a valid scene: {e}")))?;
    let data = PhotoData {
        photos,
        masks,
        refine_pose,
        jpeg,
        noise,
        shrink,
        native_noise,
        colour,
        saved_jpeg,
        gains,
    };
    Ok((fit_scene, data, inspections))
}

#[cfg(test)]
mod order_tests {
    use super::next_permutation;

    #[test]
    fn permutations_come_in_order_and_end() {
        let mut p = vec![0, 1, 2];
        let mut seen = vec![p.clone()];
        while next_permutation(&mut p) {
            seen.push(p.clone());
        }
        assert_eq!(
            seen,
            vec![
                vec![0, 1, 2],
                vec![0, 2, 1],
                vec![1, 0, 2],
                vec![1, 2, 0],
                vec![2, 0, 1],
                vec![2, 1, 0]
            ]
        );
        assert!(!next_permutation(&mut [0]));
    }
}
