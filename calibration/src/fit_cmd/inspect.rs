//! Each photo as the fit will use it: loaded, shrunk, registered, checked; and `fit --check`.
use scratchart_observe::Observer;
use std::path::{Path, PathBuf};

use anyhow::Result;
use scratchart_exit::InputError;
use scratchart_model::camera::ViewGeom;

use crate::card::Card;
use crate::register::register;

/// One photo as the fit will use it: shrunk to the capture view's scale, registered by the
/// card's marks, its camera recovered, the pixels the fit compares, its own noise.
pub struct Inspection {
    pub file: PathBuf,
    /// The photo's size as taken.
    pub taken: (u32, u32),
    /// Its JPEG quality, when it is a JPEG the fit compares on its own pixel grid.
    pub jpeg: Option<u8>,
    /// The photo at the capture view's height (its own aspect kept), display values.
    pub image: crate::photo::Gray,
    /// The camera that took it, at `image`'s size, with the capture view's name and lamp.
    pub view: scratchart_model::scene::View,
    /// The marks found, with confidences.
    pub found: crate::fiducials::Found,
    /// Taken off the capture pose (its camera from the marks, its eye refined by the fit).
    pub off_pose: bool,
    /// How far the camera stood from the capture position, mm.
    pub moved_mm: f64,
    /// Pixels the fit compares.
    pub mask: Vec<bool>,
    /// The photo's own pixel noise at `image`'s size (display units).
    pub noise: f64,
    /// The whole factor the photo was shrunk by to `image` (1: used as taken).
    pub shrink: u32,
    /// The sensor's noise at the photo's own resolution and in each colour channel (display
    /// units): `shrink` x `noise`, over [`crate::photo::LUMA_NOISE`] for a colour photo (the
    /// noise that was clipped at black, see `fit::noise`).
    pub native_noise: f64,
    /// A colour photo (its channels noisy each on its own).
    pub colour: bool,
    /// The JPEG quality it was saved with, whatever its size or turn (`None`: not a JPEG).
    pub saved_jpeg: Option<u8>,
    /// Its white balance (`photo::Channels::gains`; 1, 1, 1 for a grey photo).
    pub gains: [f64; 3],
    /// Of the bright pixels the fit compares, the fraction at full white.
    pub saturated: f64,
    /// The card's scale: pixels per mm at its centre, in the photo as taken and as the fit
    /// compares it, and the least the fit needs there.
    pub scale: CardScale,
    pub needed_px_per_mm: f64,
}

impl Inspection {
    /// One line on the photo: size, marks found and their confidence, the camera, the noise.
    pub fn summary(&self) -> String {
        let c = &self.view.camera;
        let conf: Vec<String> = self
            .found
            .confidence
            .iter()
            .zip(&self.found.points)
            .map(|(k, p)| if p.is_some() { format!("{k:.2}") } else { "-".into() })
            .collect();
        format!(
            "{}: {}x{} photo of view {}: card at {:.1} px per mm ({:.2} as fitted, at least {:.2} needed); {} of {} marks \
             (confidence {}; {:.2} px rms), taken from ({:.0}, {:.0}, {:.0}) mm, \
             {:.1} mm from the capture position; noise {:.4} ({:.1}% per channel at its own size{}{})",
            self.file.display(),
            self.taken.0,
            self.taken.1,
            self.view.name,
            self.scale.photo_px_per_mm,
            self.scale.fit_px_per_mm,
            self.needed_px_per_mm,
            self.found.count(),
            self.found.points.len(),
            conf.join(" "),
            self.found.rms_px,
            c.eye[0],
            c.eye[1],
            c.eye[2],
            self.moved_mm,
            self.noise,
            100.0 * self.native_noise,
            self.saved_jpeg.map_or(String::new(), |q| format!(", JPEG {q}")),
            if self.gains.iter().any(|g| (g - 1.0).abs() > 0.01) {
                format!(
                    ", white balance {:.2} / 1 / {:.2}",
                    self.gains[0], self.gains[2]
                )
            } else {
                String::new()
            }
        )
    }
}

/// The angle (degrees) between two cameras' directions, seen from what they look at.
fn degrees_between(a: &scratchart_model::scene::Camera, b: &scratchart_model::scene::Camera) -> f64 {
    let dir = |c: &scratchart_model::scene::Camera| {
        let d = [c.eye[0] - c.target[0], c.eye[1] - c.target[1], c.eye[2] - c.target[2]];
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        [d[0] / n, d[1] / n, d[2] / n]
    };
    let (a, b) = (dir(a), dir(b));
    (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// The sensor's noise in each channel, at the photo's own resolution: measured on `cropped` (the
/// photo as the fit crops it) shrunk by m = 1 (a JPEG: m = its shrink `k`, at most 4), over the
/// pixels under the fit's `mask` (on `small`, the photo shrunk by k), then taken back through
/// the clip at black and the JPEG to the sensor's (`fit::noise::sensor_noise`). At m the optics' blur spans k /
/// m times more pixels than in the view and the measure sees noise, not the grooves' edges
/// (k times the noise of a 24 MP photo shrunk by 23 read its 0.8% as 1.6%). JPEG's steps
/// take most of the noise at the photo's own pixels but less of what a shrink keeps.
fn sensor_noise_at_own_size(
    cropped: &crate::photo::Gray,
    small: &crate::photo::Gray,
    mask: &[bool],
    k: u32,
    colour: bool,
    saved_jpeg: Option<u8>,
) -> f64 {
    let (w, h) = (small.width, small.height);
    let m = if saved_jpeg.is_some() { k.min(4) } else { 1 };
    let (mw, mh) = (cropped.width / m, cropped.height / m);
    let at_m = crate::photo::resize(&crate::photo::crop_centre(cropped, mw * m, mh * m), mw, mh);
    let (mw, mh, ku, mu) = (mw as usize, mh as usize, k as usize, m as usize);
    // The view's pixel under each, its offset that of the crop to whole m x m blocks.
    let (ox, oy) = (
        (cropped.width as usize - mw * mu) / 2,
        (cropped.height as usize - mh * mu) / 2,
    );
    let m_mask: Vec<bool> = (0..mw * mh)
        .map(|i| {
            let (x, y) = (((i % mw) * mu + ox) / ku, ((i / mw) * mu + oy) / ku);
            x < w as usize && y < h as usize && mask[y * w as usize + x]
        })
        .collect();
    let measured = crate::photo::pixel_noise_in(&at_m, Some(&m_mask));
    let mut on: Vec<f32> = small
        .data
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|(x, _)| *x)
        .collect();
    let level = crate::photo::median(&mut on) as f64;
    crate::fit::noise::sensor_noise(measured, level, colour, m, saved_jpeg)
}

/// The camera that took the photo, from the marks: the card is rendered as that camera saw it
/// (the light on the grooves depends on where the camera stood), and the photo is used as
/// taken, without resampling. Within 2 px of the capture view everywhere, the capture camera
/// explains the photo better than a camera from a few marks found to about 0.3 px (its focal
/// length and distance trade against each other); the fit's shift takes up the rest. This is
/// the camera of a photo off that pose. `taken` is the photo's size as taken, `k` its shrink.
fn camera_from_marks(
    f: &Path,
    plate_to_image: &[f64; 9],
    v: &scratchart_model::scene::View,
    taken: (u32, u32),
    k: u32,
) -> Result<scratchart_model::scene::Camera> {
    let camera = crate::fiducials::plausible_camera_with_focal(
        plate_to_image,
        v.camera.width,
        v.camera.height,
        v,
        // The photo's EXIF focal length, on the raster the marks were found on.
        crate::photo::focal_35mm(f).map(|f35| crate::exif::focal_px(f35, taken.0, taken.1) / k as f64),
    )
    .map_err(|e| {
        InputError(format!(
            "photo `{}` (view {}): the camera recovered from the card's marks is implausible: {e}. \
                     Photograph from the capture position of card.json",
            f.display(),
            v.name
        ))
    })?;
    Ok(camera)
}

/// A card shown on fewer pixels per mm than `needed` (as the fit compares it) is refused,
/// naming the scale and the distance that would give the capture view's.
fn refuse_too_small(
    f: &Path,
    view: &str,
    capture_view: &scratchart_model::scene::View,
    scale: &CardScale,
    needed: f64,
) -> Result<()> {
    if scale.fit_px_per_mm < needed {
        let dist = (capture_view.camera.eye[0].powi(2)
            + capture_view.camera.eye[1].powi(2)
            + capture_view.camera.eye[2].powi(2))
        .sqrt();
        return Err(InputError(format!(
            "photo `{}` (view {}) shows the card at {:.2} pixels per mm; the fit needs at least {:.2} (the capture \
             guide's {:.2} at {:.0} mm, less {:.0}%): photograph from nearer (about {:.0} mm) or zoom in with the \
             lens, and send the photo as the phone saved it (a messenger, an app or an editor may have shrunk it)",
            f.display(),
            view,
            scale.photo_px_per_mm,
            needed,
            view_scale(capture_view),
            dist,
            100.0 * (1.0 - MIN_SCALE),
            dist * scale.photo_px_per_mm / view_scale(capture_view)
        ))
        .into());
    }
    Ok(())
}

/// The share of the ladder's `bright` pixels that are full white (`sat` of them), refused over
/// the guide's `MAX_SATURATED`.
fn refuse_saturated(f: &Path, sat: usize, bright: usize) -> Result<f64> {
    let saturated = if bright > 0 { sat as f64 / bright as f64 } else { 0.0 };
    if saturated > MAX_SATURATED {
        return Err(InputError(format!(
            "photo `{}` is saturated: {sat} of its {bright} bright pixels on the ladder are full white ({:.0}%; \
             the capture guide allows {:.0}%), so groove widths cannot be read; lower the exposure (tap the \
             card and drag the exposure down) and photograph again",
            f.display(),
            100.0 * saturated,
            100.0 * MAX_SATURATED
        ))
        .into());
    }
    Ok(saturated)
}

/// A camera more than the guide's `MAX_OFF_DEG` from its capture view's direction is refused.
fn refuse_off_view(f: &Path, view: &str, off_deg: f64) -> Result<()> {
    if off_deg > MAX_OFF_DEG {
        return Err(InputError(format!(
            "photo `{}` (view {}) was taken {off_deg:.0} degrees from the capture view's direction; the capture \
             guide allows {MAX_OFF_DEG:.0}: the grooves glint where the camera and the lamp are where it says, so \
             photograph again from the capture position (capture_guide.png)",
            f.display(),
            view
        ))
        .into());
    }
    Ok(())
}

/// More noise per channel than the guide's `MAX_NOISE` is refused.
fn refuse_noisy(f: &Path, view: &str, native_noise: f64) -> Result<()> {
    if native_noise > MAX_NOISE {
        return Err(InputError(format!(
            "photo `{}` (view {}) has {:.1}% noise per colour channel at its own size; the capture guide allows \
             {:.1}%: the noise clipped at black lifts the dark card by more than the fit can be sure of. Give the \
             card more light (the lamp nearer), hold the phone on a stand so it picks a lower ISO, or switch off \
             night mode",
            f.display(),
            view,
            100.0 * native_noise,
            100.0 * MAX_NOISE
        ))
        .into());
    }
    Ok(())
}

/// A JPEG saved below the guide's `MIN_JPEG_QUALITY` is refused.
fn refuse_low_jpeg(f: &Path, view: &str, saved_jpeg: Option<u8>) -> Result<()> {
    if let Some(q) = saved_jpeg.filter(|q| *q < MIN_JPEG_QUALITY) {
        return Err(InputError(format!(
            "photo `{}` (view {}) was saved as JPEG of quality {q}; the capture guide needs at least \
             {MIN_JPEG_QUALITY} (a phone saves 85 to 95; a messenger or an app recompresses lower): send the photo \
             as the phone saved it, or save as PNG",
            f.display(),
            view
        ))
        .into());
    }
    Ok(())
}

/// Refuses a photo enlarged after it was taken: by the period an enlargement leaves in its
/// pixels' sharpness (`resampled`), or by the EXIF's saved size, where an app kept the EXIF of
/// an enlargement too smooth to leave a pattern (by 1.25 to 2, or a smooth filter).
fn refuse_enlarged(f: &Path, v: &scratchart_model::scene::View, img: &crate::photo::Gray) -> Result<()> {
    if let Some(p) = crate::resampled::enlarged(img) {
        return Err(InputError(format!(
            "photo `{}` (view {}) was enlarged after it was taken: its pixels repeat a pattern every {:.2} pixels \
             ({:.0} times the spectrum's floor), which only an enlargement leaves (an app, a messenger, a digital \
             zoom). An enlargement in the display's encoding changes thin grooves' light more than wide ones' and \
             would give a wrong tool. Send the photo as the phone saved it; zoom with the lens or come nearer instead",
            f.display(),
            v.name,
            p.period_px,
            p.peak_over_floor
        ))
        .into());
    }
    if let Some((r, (sw, sh))) = crate::photo::resized_since_saved(f, img.width, img.height) {
        if r > 1.01 {
            return Err(InputError(format!(
                "photo `{}` (view {}) was enlarged after it was taken: it is {} x {} pixels where its EXIF says the \
                 camera saved {sw} x {sh} ({r:.2} times larger; an app, a messenger, an editor). An enlargement \
                 interpolates the grooves' light in a way the fit cannot follow and would give a wrong tool. Send \
                 the photo as the phone saved it; zoom with the lens or come nearer instead",
                f.display(),
                v.name,
                img.width,
                img.height,
            ))
            .into());
        }
    }
    Ok(())
}

/// Loads, registers and checks the photo `file` of capture view `v`: refused (exit 3, naming the
/// photo and the reason) when it cannot be read, the card's marks are not found in it, the
/// camera they give is not one near the capture view, or it is saturated.
pub fn inspect_photo(
    card: &Card,
    capture: &scratchart_model::scene::Scene,
    v: &scratchart_model::scene::View,
    f: &Path,
) -> Result<Inspection> {
    let half = 0.5 * capture.plate.size_mm;
    let capture_view = v;
    let (img, channels) = crate::photo::load_photo_with_channels(f).map_err(InputError)?;
    refuse_enlarged(f, v, &img)?;
    // The photo shrunk by a whole factor k to at most the capture view's height (never
    // enlarged), its own aspect kept (square pixels): each pixel the mean light of k x k of the
    // photo's, as the model's pixels add up their subpixels. A fractional factor (640 x 480 to
    // 256 high: 1.875) mixes pixels with weights that change with the sub-pixel phase, a blur
    // the model cannot follow: it put a 75 degree V-bit at 73.9 with a stated +- 0.12. The rows
    // and columns left over are cropped evenly from both sides (the field of view with them).
    let shrunk = |k: u32| {
        let mut v = capture_view.clone();
        let (w, h) = ((img.width / k).max(16), (img.height / k).max(16));
        let cropped = crate::photo::crop_centre(&img, (w * k).min(img.width), (h * k).min(img.height));
        let t = (0.5 * v.camera.fov_y_deg).to_radians().tan() * cropped.height as f64 / img.height as f64;
        v.camera.fov_y_deg = 2.0 * t.atan().to_degrees();
        (v.camera.width, v.camera.height) = (w, h);
        let small = crate::photo::resize(&cropped, w, h);
        (v, cropped, small)
    };
    let mut k = img.height.div_ceil(capture_view.camera.height).max(1);
    let (mut v, mut cropped, mut small) = shrunk(k);
    // A photo mostly white is saturated before anything can be found in it (the marks alone
    // may be white: they are a small part of the frame).
    let white = small.data.iter().filter(|x| **x >= 0.99).count();
    if white * 6 > small.data.len() {
        return Err(InputError(format!(
            "photo `{}` is saturated: {:.0}% of it is full white, so neither the card's marks nor its grooves \
             can be read; lower the exposure (or the lamp) and photograph again",
            f.display(),
            100.0 * white as f64 / small.data.len() as f64
        ))
        .into());
    }
    // Less white than that, but the marks lost in it: the saturation is named with the rest (a
    // photo 15 times over the guide's exposure, 8% white, gave only "card not found").
    let white_share = white as f64 / small.data.len() as f64;
    let not_found = |e: String| {
        let white = if white_share > 0.02 {
            format!(
                " {:.0}% of the photo is full white: if it is saturated, lower the exposure (or the lamp).",
                100.0 * white_share
            )
        } else {
            String::new()
        };
        InputError(format!(
            "card not found in photo `{}` (view {}): {e}. At least {} of the card's {} hatched marks must \
             glint; photograph from the capture position of card.json with the lamp where it says (see \
             capture_guide.png beside card.json).{white}",
            f.display(),
            capture_view.name,
            card.marks.len().min(5),
            card.marks.len()
        ))
    };
    let mut reg = register(&small, card, &v).map_err(not_found)?;
    // The card's scale in the photo against the capture view's: a photo shrunk after it was
    // taken (a messenger, an app) or taken from too far shows the grooves on fewer pixels than
    // the fit needs (two photos shrunk to half with an image editor were fitted at a V angle
    // 11.5 degrees off).
    let mut scale = card_scale(&reg.found.plate_to_image, k);
    let needed = MIN_SCALE * view_scale(capture_view);
    // A whole shrink that leaves too few pixels (a photo 1.5 times the view's height, halved;
    // a card smaller in the frame than in the view) is made smaller: the fit then compares more
    // pixels than the view has.
    // (Each shrink's marks give the scale anew, a percent apart: a 21 MP photo at 25.6 px per
    // mm shrunk by 15 read 25.4 there, 1.69 where 1.70 were needed, and was refused as too
    // small. So smaller shrinks are tried until one is enough.)
    while scale.fit_px_per_mm < needed && k > 1 {
        let most = (scale.photo_px_per_mm / needed).floor() as u32;
        if most < 1 {
            break;
        }
        k = most.min(k - 1);
        (v, cropped, small) = shrunk(k);
        reg = register(&small, card, &v).map_err(not_found)?;
        scale = card_scale(&reg.found.plate_to_image, k);
    }
    refuse_too_small(f, &v.name, capture_view, &scale, needed)?;
    // More than 2 px off the capture pose: the camera the marks give (see `camera_from_marks`).
    let off_pose = reg.pose_offset_px > 2.0;
    let camera = if off_pose {
        camera_from_marks(f, &reg.found.plate_to_image, &v, (img.width, img.height), k)?
    } else {
        v.camera.clone()
    };
    let e = v.camera.eye;
    let moved_mm =
        ((camera.eye[0] - e[0]).powi(2) + (camera.eye[1] - e[1]).powi(2) + (camera.eye[2] - e[2]).powi(2)).sqrt();
    let fv = scratchart_model::scene::View { camera, ..v.clone() };
    let mask = fit_mask(card, &fv, half);
    // Saturation, over the pixels the fit compares (the marks glint brightest and are left out).
    let bright = small.data.iter().zip(&mask).filter(|(x, m)| **m && **x > 0.25).count();
    let sat = small.data.iter().zip(&mask).filter(|(x, m)| **m && **x >= 0.99).count();
    let saturated = refuse_saturated(f, sat, bright)?;
    // How far the camera stood from the capture view's direction, seen from the card.
    let off_deg = degrees_between(&fv.camera, &capture_view.camera);
    refuse_off_view(f, &capture_view.name, off_deg)?;
    let noise = crate::photo::pixel_noise_in(&small, Some(&mask));
    let saved_jpeg = std::fs::read(f).ok().and_then(|b| crate::photo::jpeg_table_quality(&b));
    // A colour photo's grey has less noise than the channels that were clipped; a JPEG's
    // quantization took part of the noise after it was clipped, and its chroma's coarse steps
    // hide whether the channels' noise was their own, so a colour JPEG is taken as a sensor's
    // (each channel its own). The noise is the one whose simulated photo, at the card's
    // typical level and saved as this one was, shows what was measured (`fit::noise`).
    let colour = match (saved_jpeg, channels) {
        (Some(_), c) => c.is_some(),
        // Channels whose noise is mostly their own.
        (None, c) => c.is_some_and(|c| c.noise_share < 0.5 * (1.0 + crate::photo::LUMA_NOISE)),
    };
    let native_noise = sensor_noise_at_own_size(&cropped, &small, &mask, k, colour, saved_jpeg);
    refuse_noisy(f, &capture_view.name, native_noise)?;
    refuse_low_jpeg(f, &capture_view.name, saved_jpeg)?;
    // A JPEG compared on its own pixel grid: the fit puts the same JPEG on its model.
    let jpeg = if (small.width, small.height) == (img.width, img.height) {
        crate::photo::jpeg_quality(f)
    } else {
        None
    };
    Ok(Inspection {
        file: f.to_path_buf(),
        taken: (img.width, img.height),
        jpeg,
        image: small,
        view: fv,
        found: reg.found,
        off_pose,
        moved_mm,
        mask,
        noise,
        shrink: k,
        native_noise,
        colour,
        saved_jpeg,
        gains: channels.map_or([1.0; 3], |c| c.gains),
        saturated,
        scale,
        needed_px_per_mm: needed,
    })
}

/// The capture guide's limits, which `fit --check` and `fit` both hold each photo to (refused
/// beyond them, naming the limit and what to change):
/// the least card scale (pixels per mm at the card's centre) a photo may have, as a fraction
/// of its capture view's;
pub const MIN_SCALE: f64 = 0.85;
/// the most noise per colour channel at the photo's own size (display units);
pub const MAX_NOISE: f64 = 0.03;
/// the least JPEG quality (as read from its quantization tables);
pub const MIN_JPEG_QUALITY: u8 = 80;
/// the most the camera may stand from the capture view's direction, degrees;
pub const MAX_OFF_DEG: f64 = 25.0;
/// the largest share of the ladder's bright pixels that may be full white (photos at 17 to 19
/// times the guide's exposure, 13% and 18% white, were fitted with a residual 87 times their
/// noise and refused without the cause named; 40 photos taken within the guide: under 10%).
pub const MAX_SATURATED: f64 = 0.10;

/// The card's scale in a photo: pixels per mm at the card's centre (the square root of the
/// area a square millimetre there covers), as taken and as the fit compares it.
#[derive(Clone, Copy, Debug)]
pub struct CardScale {
    pub photo_px_per_mm: f64,
    pub fit_px_per_mm: f64,
}

fn px_per_mm(map: impl Fn([f64; 2]) -> Option<[f64; 2]>) -> f64 {
    let h = 1.0;
    let (Some(a), Some(b), Some(c)) = (map([-h, -h]), map([h, -h]), map([-h, h])) else {
        return 0.0;
    };
    let (u, w) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
    ((u[0] * w[1] - u[1] * w[0]).abs()).sqrt() / (2.0 * h)
}

/// The card's scale under the homography `plate_to_image` of a photo shrunk by `shrink`.
pub fn card_scale(plate_to_image: &[f64; 9], shrink: u32) -> CardScale {
    let fit = px_per_mm(|q| Some(crate::fiducials::homography::apply(plate_to_image, q)));
    CardScale {
        photo_px_per_mm: fit * shrink as f64,
        fit_px_per_mm: fit,
    }
}

/// The card's scale in a capture view (pixels per mm at the card's centre).
pub fn view_scale(view: &scratchart_model::scene::View) -> f64 {
    let g = ViewGeom::new(view);
    px_per_mm(|q| g.project([q[0], q[1], 0.0]).map(|p| [p.0, p.1]))
}

/// `fit --check`: says of each photo whether the fit can use it, without fitting. A photo named
/// after a capture view is checked against it, others against the views in order. Exit 3 when
/// any is unusable.
pub(super) fn check_photos(
    card: &Card,
    capture: &scratchart_model::scene::Scene,
    images: &[PathBuf],
    obs: &dyn Observer,
) -> Result<()> {
    let mut bad = Vec::new();
    for (i, f) in images.iter().enumerate() {
        let stem = f
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
        let v = capture
            .views
            .iter()
            .find(|v| v.name == stem)
            .unwrap_or(&capture.views[i % capture.views.len()]);
        let t = std::time::Instant::now();
        let named = capture.views.iter().any(|v| v.name == stem);
        let mut got = inspect_photo(card, capture, v, f);
        // Not named after a view and not of the view in its place: the marks say which it is.
        if got.is_err() && !named {
            if let Some(other) = capture
                .views
                .iter()
                .filter(|o| o.name != v.name)
                .find_map(|o| inspect_photo(card, capture, o, f).ok())
            {
                obs.result(&format!(
                    "         `{}` is view {} (found by the card's marks), not {} as its place among the photos says",
                    f.display(),
                    other.view.name,
                    v.name
                ));
                got = Ok(other);
            }
        }
        match got {
            Ok(insp) => {
                let weak: Vec<&str> = insp
                    .found
                    .confidence
                    .iter()
                    .zip(&card.marks)
                    .filter(|(c, _)| **c < 0.5)
                    .map(|(_, m)| m.label.as_str())
                    .collect();
                obs.result(&format!(
                    "usable   {} ({:.1} s)",
                    insp.summary(),
                    t.elapsed().as_secs_f64()
                ));
                if !weak.is_empty() {
                    obs.result(&format!("         marks not found or weak: {}", weak.join(", ")));
                }
                if insp.saturated > 0.5 * MAX_SATURATED {
                    obs.result(&format!(
                        "         {:.0}% of the ladder's bright pixels are full white: a lower exposure reads the widths better",
                        100.0 * insp.saturated
                    ));
                }
            }
            Err(e) => {
                obs.result(&format!("UNUSABLE {}: {e:#}", f.display()));
                bad.push(f.display().to_string());
            }
        }
    }
    if bad.is_empty() {
        Ok(())
    } else {
        Err(InputError(format!(
            "{} of {} photo(s) cannot be used: {}",
            bad.len(),
            images.len(),
            bad.join(", ")
        ))
        .into())
    }
}

/// The pixels of view `view` the fit compares: on the card, and away from the fiducial marks
/// (their squares widened by 1.5 times their half side, past the blur of their light).
pub fn fit_mask(card: &Card, view: &scratchart_model::scene::View, half_plate: f64) -> Vec<bool> {
    let g = ViewGeom::new(view);
    let mut mask = g.on_plate_mask(half_plate);
    let w = view.camera.width;
    for (i, m) in mask.iter_mut().enumerate() {
        if *m {
            let (x, y) = (i as u32 % w, i as u32 / w);
            if let Some(q) = g.shading_point(x, y) {
                if card.marks.iter().any(|mk| mk.covers(q, 1.5 * mk.half_mm)) {
                    *m = false;
                }
            }
        }
    }
    mask
}
