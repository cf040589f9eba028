//! Photos of the card as a phone takes them, for the tests and the recovery study (`scratchart-cal
//! study`): the card as a known tool cuts it, rendered by the engine from a camera held near a
//! capture view (moved, tilted, turned by any angle, another field of view), then what a phone
//! does to the light: lens blur, exposure, vignetting, a white-balance cast, sensor noise at the
//! photo's own resolution, any size from a fraction of a megapixel to tens, JPEG, an EXIF
//! orientation tag with the pixels stored turned, and optionally one fiducial mark covered (a
//! thumb, a clamp).
use std::path::{Path, PathBuf};

use scratchart_design::scenes::Rng;
use scratchart_model::camera::ViewGeom;
use scratchart_model::scene::{Scene, View};
use scratchart_render::Renderer;
use scratchart_tool::Tool;

use super::card::Card;
use super::simulate::cut_scene;

use super::simulate::RENDER_SCALE;

/// Where the phone is held, relative to a capture view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Angle between the capture direction and the phone's, seen from the card's centre, degrees.
    pub tilt_deg: f64,
    /// Direction of that tilt about the capture direction, degrees.
    pub tilt_dir_deg: f64,
    /// Then moved by this much, mm.
    pub shift_mm: [f64; 3],
    /// Aimed at this plate point, mm.
    pub aim_mm: [f64; 2],
    /// Turned about its own axis, degrees (any angle).
    pub roll_deg: f64,
    /// Its vertical field of view over the capture view's.
    pub fov_scale: f64,
    /// Its frame's width over its height.
    pub aspect: f64,
}

impl Default for Pose {
    fn default() -> Pose {
        Pose {
            tilt_deg: 0.0,
            tilt_dir_deg: 0.0,
            shift_mm: [0.0; 3],
            aim_mm: [0.0; 2],
            roll_deg: 0.0,
            fov_scale: 1.0,
            aspect: 1.0,
        }
    }
}

/// What the phone does to the light.
#[derive(Clone, Debug, PartialEq)]
pub struct Shot {
    pub pose: Pose,
    /// Linear exposure factor.
    pub exposure: f64,
    /// Gaussian blur of the lens, in pixels of the capture view's scale.
    pub blur_px: f64,
    /// Sensor noise, standard deviation on display values in [0, 1], at the photo's resolution.
    pub noise: f64,
    /// Light lost at the frame's corners (0: none; 0.4: 40%).
    pub vignetting: f64,
    /// White-balance gains on red, green and blue (linear).
    pub cast: [f64; 3],
    /// Size of the photo, megapixels.
    pub megapixels: f64,
    /// JPEG quality (None: PNG).
    pub jpeg_quality: Option<u8>,
    /// EXIF orientation stored with the pixels turned to match (1: none; 3, 6 or 8; JPEG only).
    pub exif_orientation: u8,
    /// The fiducial mark (index in `card.marks`) covered by a dark patch.
    pub cover: Option<usize>,
    pub seed: u64,
    /// The phone's own exposure: scaled so that the frame's brightest light (its 99.9th
    /// percentile: the glinting marks) shows at this display value, times `exposure`; `None`:
    /// `exposure` alone.
    pub auto_exposure: Option<f64>,
    /// Enlarged by this factor after it was taken, in its display encoding (an app, a messenger,
    /// a digital zoom), Catmull-Rom or bilinear by `seed`; 1: as taken.
    pub enlarge: f64,
}

impl Default for Shot {
    fn default() -> Shot {
        Shot {
            pose: Pose::default(),
            exposure: 1.0,
            blur_px: 0.5,
            noise: 0.0,
            vignetting: 0.0,
            cast: [1.0; 3],
            megapixels: 0.3,
            jpeg_quality: None,
            exif_orientation: 1,
            cover: None,
            seed: 1,
            auto_exposure: None,
            enlarge: 1.0,
        }
    }
}

fn rotate(v: [f64; 3], axis: [f64; 3], deg: f64) -> [f64; 3] {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let k = [axis[0] / n, axis[1] / n, axis[2] / n];
    let (s, c) = deg.to_radians().sin_cos();
    let kxv = [
        k[1] * v[2] - k[2] * v[1],
        k[2] * v[0] - k[0] * v[2],
        k[0] * v[1] - k[1] * v[0],
    ];
    let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    std::array::from_fn(|i| v[i] * c + kxv[i] * s + k[i] * kv * (1.0 - c))
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The phone's camera for capture view `view`, `height` pixels high.
pub fn posed_view(view: &View, pose: &Pose, height: u32) -> View {
    let e = view.camera.eye;
    let t = view.camera.target;
    let d = [e[0] - t[0], e[1] - t[1], e[2] - t[2]];
    // Tilt the direction from the card about an axis across it, turned by tilt_dir about it.
    let across = cross(d, [0.0, 0.0, 1.0]);
    let axis = rotate(across, d, pose.tilt_dir_deg);
    let d2 = rotate(d, axis, pose.tilt_deg);
    let eye = [
        t[0] + d2[0] + pose.shift_mm[0],
        t[1] + d2[1] + pose.shift_mm[1],
        t[2] + d2[2] + pose.shift_mm[2],
    ];
    let target = [pose.aim_mm[0], pose.aim_mm[1], 0.0];
    let f = [target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]];
    let right = cross(f, [0.0, 0.0, 1.0]);
    let up = rotate(cross(right, f), f, pose.roll_deg);
    let fov = 2.0
        * ((0.5 * view.camera.fov_y_deg).to_radians().tan() * pose.fov_scale)
            .atan()
            .to_degrees();
    let mut v = view.clone();
    v.camera.eye = eye;
    v.camera.target = target;
    let n = (up[0] * up[0] + up[1] * up[1] + up[2] * up[2]).sqrt();
    v.camera.up = [up[0] / n, up[1] / n, up[2] / n];
    v.camera.fov_y_deg = fov;
    v.camera.height = height;
    v.camera.width = ((height as f64 * pose.aspect).round() as u32).max(16);
    v
}

/// A phone held near a capture view: up to `max_tilt_deg` and `max_shift_mm` off it, aimed up
/// to 4 mm off the card's centre, turned by any angle, its field of view `fov` times the view's,
/// 4:3 or 3:4 (the draws in this order: the studies' seeds depend on it).
fn random_pose(rng: &mut Rng, max_tilt_deg: f64, max_shift_mm: f64, fov: (f64, f64)) -> Pose {
    let dir = rng.range(0.0, std::f64::consts::TAU);
    let shift = rng.range(0.0, max_shift_mm);
    let el = rng.range(-0.5, 0.5);
    Pose {
        tilt_deg: rng.range(0.0, max_tilt_deg),
        tilt_dir_deg: rng.range(0.0, 360.0),
        shift_mm: [
            shift * dir.cos() * el.cos(),
            shift * dir.sin() * el.cos(),
            shift * el.sin(),
        ],
        aim_mm: [rng.range(-4.0, 4.0), rng.range(-4.0, 4.0)],
        roll_deg: rng.range(-180.0, 180.0),
        fov_scale: rng.range(fov.0, fov.1),
        aspect: if rng.f64() < 0.5 { 4.0 / 3.0 } else { 3.0 / 4.0 },
    }
}

/// A random shot with every degradation of the calibration issue drawn in its range: the
/// camera up to `max_tilt_deg` and 30 mm off the capture pose and turned by any angle, exposure
/// 0.3x to 3x, noise up to 3%, blur up to 2 px, vignetting up to 40%, a cast up to 25% per
/// channel, 0.3 to 50 megapixels, JPEG quality 70 to 95 (or PNG), an EXIF orientation, and in
/// a third of the shots one mark covered.
pub fn random_shot(rng: &mut Rng, n_marks: usize, max_tilt_deg: f64) -> Shot {
    Shot {
        pose: random_pose(rng, max_tilt_deg, 30.0, (1.15, 1.35)),
        exposure: (rng.range(0.3f64.ln(), 3f64.ln())).exp(),
        blur_px: rng.range(0.3, 2.0),
        noise: rng.range(0.0, 0.03),
        vignetting: rng.range(0.0, 0.4),
        cast: [rng.range(0.75, 1.25), 1.0, rng.range(0.75, 1.25)],
        megapixels: (rng.range(0.3f64.ln(), 50f64.ln())).exp(),
        jpeg_quality: if rng.f64() < 0.8 {
            Some(rng.range(70.0, 95.0) as u8)
        } else {
            None
        },
        exif_orientation: [1, 1, 3, 6, 8][(rng.f64() * 5.0) as usize % 5],
        cover: (rng.f64() < 1.0 / 3.0).then(|| (rng.f64() * n_marks as f64) as usize % n_marks),
        seed: rng.next_u64(),
        auto_exposure: None,
        enlarge: 1.0,
    }
}

/// What takes a photo outside the capture guide's limits (`fit_cmd::inspect`'s), one at a time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Violation {
    /// Too few pixels per mm on the card (a small photo, or shrunk by a messenger).
    Shrunk,
    /// More noise than the guide allows.
    Noisy,
    /// Recompressed as a low-quality JPEG.
    LowJpeg,
    /// Taken from too far off the capture view's direction.
    OffPose,
    /// Most of the ladder full white.
    Saturated,
    /// Enlarged after it was taken.
    Enlarged,
}

impl Violation {
    pub const ALL: [Violation; 6] = [
        Violation::Shrunk,
        Violation::Noisy,
        Violation::LowJpeg,
        Violation::OffPose,
        Violation::Saturated,
        Violation::Enlarged,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Violation::Shrunk => "shrunk",
            Violation::Noisy => "noisy",
            Violation::LowJpeg => "low JPEG quality",
            Violation::OffPose => "off the capture pose",
            Violation::Saturated => "saturated",
            Violation::Enlarged => "enlarged",
        }
    }

    /// Words of the refusal that name this limit (`fit_cmd::inspect`).
    pub fn named_by(self, msg: &str) -> bool {
        match self {
            Violation::Shrunk => msg.contains("pixels per mm"),
            Violation::Noisy => msg.contains("noise per colour channel"),
            Violation::LowJpeg => msg.contains("JPEG of quality"),
            Violation::OffPose => msg.contains("degrees from the capture view") || msg.contains("implausible"),
            Violation::Saturated => msg.contains("saturated"),
            Violation::Enlarged => msg.contains("enlarged after it was taken"),
        }
    }
}

/// A random shot within the capture guide's limits (`fit_cmd::inspect`: at least 0.85 of the
/// capture view's pixels per mm, noise at most 3% per channel, JPEG 80 or better, at most 25
/// degrees off the capture view's direction, at most a tenth of the ladder's bright pixels
/// white, not enlarged), drawn well inside them as a maker following the guide takes it: the
/// phone held within 12 degrees and 20 mm of the capture position and turned by any angle, its
/// own exposure (the glinting marks at 0.5 to 0.95 of full scale), blur 0.3 to 1.5 px, noise to
/// 2%, vignetting to 30%, a cast to 15%, 2 to 24 megapixels, JPEG 85 to 97 or PNG, an EXIF
/// turn, a covered mark in a third.
pub fn random_shot_within(rng: &mut Rng, n_marks: usize) -> Shot {
    Shot {
        pose: random_pose(rng, 12.0, 20.0, (1.1, 1.3)),
        exposure: 1.0,
        auto_exposure: Some(rng.range(0.5, 0.95)),
        blur_px: rng.range(0.3, 1.5),
        noise: rng.range(0.0, 0.02),
        vignetting: rng.range(0.0, 0.3),
        cast: [rng.range(0.85, 1.15), 1.0, rng.range(0.85, 1.15)],
        megapixels: (rng.range(2f64.ln(), 24f64.ln())).exp(),
        jpeg_quality: if rng.f64() < 0.7 {
            Some(rng.range(85.0, 97.0) as u8)
        } else {
            None
        },
        exif_orientation: [1, 1, 3, 6, 8][(rng.f64() * 5.0) as usize % 5],
        cover: (rng.f64() < 1.0 / 3.0).then(|| (rng.f64() * n_marks as f64) as usize % n_marks),
        seed: rng.next_u64(),
        enlarge: 1.0,
    }
}

/// A shot within the guide's limits but for `what`, which takes it clearly beyond one of them.
pub fn random_shot_outside(rng: &mut Rng, n_marks: usize, what: Violation) -> Shot {
    let mut s = random_shot_within(rng, n_marks);
    match what {
        // 0.4 to 0.7 of the capture view's scale.
        Violation::Shrunk => s.megapixels = rng.range(0.02, 0.05),
        Violation::Noisy => s.noise = rng.range(0.05, 0.08),
        Violation::LowJpeg => s.jpeg_quality = Some(rng.range(40.0, 72.0) as u8),
        Violation::OffPose => s.pose.tilt_deg = rng.range(29.0, 33.0),
        Violation::Saturated => s.auto_exposure = Some(rng.range(10.0, 30.0)),
        Violation::Enlarged => {
            // A small photo (about the capture view's scale) enlarged 1.5 to 3 times.
            s.megapixels = rng.range(0.1, 0.15);
            s.enlarge = rng.range(1.5, 3.0);
        }
    }
    s
}

/// The photo of capture view `view` (of `capture`) that `shot` takes of the card cut by `tool`,
/// written to `dir/NAME.jpg` (or `.png`). Returns the path and the phone's camera as it
/// rendered (at the render's resolution).
pub fn take(
    renderer: &Renderer,
    card: &Card,
    capture: &Scene,
    view: usize,
    tool: &Tool,
    shot: &Shot,
    dir: &Path,
) -> anyhow::Result<(PathBuf, View)> {
    let marks: Vec<([f64; 2], f64)> = card.marks.iter().map(|m| (m.centre, m.half_mm)).collect();
    take_of(renderer, &cut_scene(card, capture, tool), &marks, view, shot, dir)
}

/// [`take`] of any plate: `plate` holds the grooves and the views, `marks` the marks a shot may
/// cover (`shot.cover` indexes them: each its centre and half side, mm).
pub fn take_of(
    renderer: &Renderer,
    plate: &Scene,
    marks: &[([f64; 2], f64)],
    view: usize,
    shot: &Shot,
    dir: &Path,
) -> anyhow::Result<(PathBuf, View)> {
    let base = &plate.views[view];
    // Rendered at RENDER_SCALE times the capture view's height (the blur is given at the
    // view's scale), then resampled to the photo's size: a camera's optics are continuous, and
    // the fit models them at SUPERSAMPLE (2) times the view's resolution, so the photos are made
    // finer than that.
    let rh = RENDER_SCALE * base.camera.height;
    let pv = posed_view(base, &shot.pose, rh);
    let (rw, rh) = (pv.camera.width as usize, pv.camera.height as usize);
    let scene = Scene {
        views: vec![pv.clone()],
        ..plate.clone()
    };
    let mut gs = renderer.upload(&scene)?;
    let sigma = (rh as f64 / base.camera.height as f64) * shot.blur_px;
    let frame = crate::simulate::render_for_optics(renderer, &mut gs, sigma)?;
    let lin = crate::simulate::optics_blur(&frame[0], rw, rh, sigma);
    // The phone's own exposure: the frame's brightest light at the display value asked for.
    let exposure = match shot.auto_exposure {
        Some(target) => {
            let mut sorted = lin.clone();
            let i = ((sorted.len() as f64 * 0.999) as usize).min(sorted.len() - 1);
            let top = *sorted.select_nth_unstable_by(i, |a, b| a.total_cmp(b)).1 as f64;
            shot.exposure * crate::encoding::decode(target) / top.max(1e-12)
        }
        None => shot.exposure,
    };
    // Vignetting and exposure on the light.
    let (cx, cy) = (0.5 * rw as f64, 0.5 * rh as f64);
    let r2max = cx * cx + cy * cy;
    let mut lin: Vec<f32> = lin
        .iter()
        .enumerate()
        .map(|(i, &l)| {
            let (x, y) = ((i % rw) as f64 + 0.5 - cx, (i / rw) as f64 + 0.5 - cy);
            (l as f64 * exposure * (1.0 - shot.vignetting * (x * x + y * y) / r2max)) as f32
        })
        .collect();
    // A covered mark: a black patch (a thumb in shadow, a clamp) over its square and beyond it
    // towards the card's edge, so that nothing of the mark shows and the patch is not centred
    // on it.
    if let Some(k) = shot.cover.filter(|_| !marks.is_empty()) {
        let g = ViewGeom::new(&pv);
        let (centre, half_mm) = marks[k % marks.len()];
        let pad = 1.3 * half_mm;
        let out = [centre[0].signum(), centre[1].signum()];
        let c = [centre[0] + out[0] * 1.5 * half_mm, centre[1] + out[1] * 1.5 * half_mm];
        let reach = pad + 1.5 * half_mm;
        for (i, l) in lin.iter_mut().enumerate() {
            let (x, y) = ((i % rw) as u32, (i / rw) as u32);
            if let Some(q) = g.shading_point(x, y) {
                if (q[0] - c[0]).abs() <= reach && (q[1] - c[1]).abs() <= reach {
                    *l = 0.0;
                }
            }
        }
    }
    // To the photo's size (bilinear on light), then the sensor: cast, display encoding, noise.
    let aspect = rw as f64 / rh as f64;
    let ph = ((shot.megapixels * 1e6 / aspect).sqrt().round() as u32).max(32);
    let pw = ((ph as f64 * aspect).round() as u32).max(32);
    let big = scratchart_render::io::resize_bilinear(&lin, rw as u32, rh as u32, pw, ph);
    let mut rng = Rng::new(shot.seed);
    let mut gauss = move || rng.normal();
    let mut rgb = Vec::with_capacity(big.len() * 3);
    for &l in &big {
        for c in 0..3 {
            let d = crate::encoding::encode(l as f64 * shot.cast[c]);
            let v = (d + shot.noise * gauss()).clamp(0.0, 1.0);
            rgb.push((255.0 * v).round() as u8);
        }
    }
    let mut upright = image::RgbImage::from_raw(pw, ph, rgb).expect("sized");
    if shot.enlarge > 1.0 {
        // In its display encoding, as apps do.
        let (ew, eh) = (
            (pw as f64 * shot.enlarge).round() as u32,
            (ph as f64 * shot.enlarge).round() as u32,
        );
        let filter = if shot.seed % 2 == 0 {
            image::imageops::FilterType::CatmullRom
        } else {
            image::imageops::FilterType::Triangle
        };
        upright = image::imageops::resize(&upright, ew, eh, filter);
    }
    std::fs::create_dir_all(dir)?;
    let path = match shot.jpeg_quality {
        Some(q) => {
            use image::ImageEncoder as _;
            // Stored turned, with the tag that turns it back.
            let img = match shot.exif_orientation {
                3 => image::imageops::rotate180(&upright),
                6 => image::imageops::rotate270(&upright),
                8 => image::imageops::rotate90(&upright),
                _ => upright,
            };
            let mut buf = Vec::new();
            let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, q);
            // As a phone writes it: the orientation and the 35 mm equivalent focal length of
            // the frame (`crate::exif`).
            let f35 = crate::exif::focal_35mm_of(pv.camera.fov_y_deg, pw as f64 / ph as f64);
            // The size the camera saved: an app's enlargement after it keeps the EXIF as it was.
            let saved = match shot.exif_orientation {
                6 | 8 => (ph, pw),
                _ => (pw, ph),
            };
            enc.set_exif_metadata(crate::exif::exif_blob(shot.exif_orientation, f35.round() as u16, saved))?;
            enc.write_image(img.as_raw(), img.width(), img.height(), image::ExtendedColorType::Rgb8)?;
            let p = dir.join(format!("{}.jpg", base.name));
            scratchart_render::io::write_atomic(&p, &buf)?;
            p
        }
        None => {
            // PNG: no orientation tag here, stored upright.
            let p = dir.join(format!("{}.png", base.name));
            scratchart_render::io::write_png_rgb(&p, upright.width(), upright.height(), upright.as_raw())?;
            p
        }
    };
    Ok((path, pv))
}
