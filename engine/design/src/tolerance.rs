//! How far the lamp and each eye may move: every view rendered with the lamp or the eye moved
//! in azimuth, elevation and distance, both ways, and a search (outwards on a grid, then by
//! bisection) for how far each keeps [`KEEP`] of the view's correlation with its picture, from
//! what the design wrote beside itself ([`SheetInputs`]); a lamp's or an eye's [`Place`] as a
//! maker measures it. The set-up sheet (`setup`, `setup_sheet`) states the results.
use std::path::Path;

use serde_json::{json, Value};

use crate::measure::{blur3, correlation};
use scratchart_model::scene::{LightKind, Scene, View};
use scratchart_observe::Observer;
use scratchart_optim::error::OptimError;
use scratchart_render::layout::TileWindow;
use scratchart_render::Renderer;

/// One render of a view with the lamp or the eye moved, and its correlation with its picture.
#[derive(Clone, Debug, PartialEq)]
pub struct Moved {
    pub view: String,
    /// "lamp" or "eye"
    pub moved: &'static str,
    /// "azimuth", "elevation" or "distance"
    pub axis: &'static str,
    /// degrees, or a fraction of the distance
    pub delta: f64,
    pub corr: f64,
}

/// The share of a view's correlation that a tolerance keeps.
pub const KEEP: f64 = 0.9;
/// How far the searches go: degrees of azimuth or elevation, and a fraction of the distance.
pub const ANGLE_RANGE: f64 = 20.0;
pub const DISTANCE_RANGE: f64 = 0.5;
/// The moves tried first, outwards; between the last that keeps [`KEEP`] and the first that
/// does not, the search bisects down to [`resolution`].
const ANGLE_GRID: [f64; 5] = [1.0, 2.0, 5.0, 10.0, ANGLE_RANGE];
const DISTANCE_GRID: [f64; 5] = [0.02, 0.05, 0.1, 0.2, DISTANCE_RANGE];
/// Views rendered per batch (bounds the batch's buffers whatever the number of views).
const BATCH_VIEWS: usize = 48;

/// Views rendered per batch of `scene`'s views: [`BATCH_VIEWS`], halved until a batch of the
/// first views fits the device (a design with many scratches, or arcs as many chords); at least 1
/// (an upload that still does not fit names its limit).
pub(crate) fn batch_views(renderer: &scratchart_render::Renderer, scene: &Scene, views: &[View]) -> usize {
    let mut n = BATCH_VIEWS;
    while n > 1 {
        let mut batch = scene.clone();
        batch.views = views.iter().take(n).cloned().collect();
        if renderer.fits(&batch) {
            break;
        }
        n /= 2;
    }
    n
}

/// How finely a tolerance of about `safe` is found: 10% of it, at least 0.25 degrees or 1% of the
/// distance.
pub fn resolution(axis: &str, safe: f64) -> f64 {
    let floor = if axis == "distance" { 0.01 } else { 0.25 };
    (0.1 * safe).max(floor)
}

fn range_of(axis: &str) -> f64 {
    if axis == "distance" {
        DISTANCE_RANGE
    } else {
        ANGLE_RANGE
    }
}

/// `p` moved along `axis` by `delta` on the sphere about the plate centre (the elevation kept
/// between 0.5 and 89.9 degrees).
fn moved(p: [f64; 3], axis: &str, delta: f64) -> [f64; 3] {
    let q = Place::of(p);
    match axis {
        "azimuth" => Place::at(q.azimuth_deg + delta, q.elevation_deg, q.distance_mm),
        "elevation" => Place::at(q.azimuth_deg, (q.elevation_deg + delta).clamp(0.5, 89.9), q.distance_mm),
        _ => Place::at(q.azimuth_deg, q.elevation_deg, q.distance_mm * (1.0 + delta)),
    }
}

/// View `v` with the lamp or the eye moved (the camera keeps looking at the same plate point).
fn variant(v: &View, what: &str, axis: &str, delta: f64) -> View {
    let mut w = v.clone();
    w.name = format!("{}~{what}~{axis}~{delta}", v.name);
    if what == "lamp" {
        w.light.kind = match w.light.kind {
            LightKind::Point { position } => LightKind::Point {
                position: moved(position, axis, delta),
            },
            // A directional light has no distance (never searched); its direction moves in angle.
            LightKind::Directional { direction } => LightKind::Directional {
                direction: moved(direction, axis, delta),
            },
        };
    } else {
        w.camera.eye = moved(w.camera.eye, axis, delta);
    }
    w
}

/// How far the lamp or the eye of one view may move along one axis and keep [`KEEP`] of the
/// view's correlation, found by search in both directions.
#[derive(Clone, Debug, PartialEq)]
pub struct Tolerance {
    pub view: String,
    /// "lamp" or "eye"
    pub moved: &'static str,
    pub axis: &'static str,
    /// The largest move found to keep it, towards minus and towards plus (degrees or a fraction).
    pub safe: [f64; 2],
    /// The smallest move found to lose it, each way; `None` where it never did within the range.
    pub lost: [Option<f64>; 2],
}

impl Tolerance {
    /// How far it may move either way.
    pub fn within(&self) -> f64 {
        self.safe[0].min(self.safe[1])
    }

    /// The tolerance as a share of the range searched (to compare angles with distances).
    pub fn relative(&self) -> f64 {
        self.within() / range_of(self.axis)
    }

    /// "up to 3.5 deg", "more than 20 deg", "less than 0.25 deg", "up to 12%".
    pub fn phrase(&self) -> String {
        let say = |x: f64| {
            if self.axis == "distance" {
                let pc = 100.0 * x;
                if pc < 5.0 {
                    format!("{pc:.1}%")
                } else {
                    format!("{pc:.0}%")
                }
            } else if x < 1.0 {
                format!("{x:.2} deg")
            } else if x < 10.0 {
                format!("{x:.1} deg")
            } else {
                format!("{x:.0} deg")
            }
        };
        let w = self.within();
        if self.lost == [None, None] {
            format!("more than {}", say(range_of(self.axis)))
        } else if w <= 0.0 {
            let first = self.lost.iter().flatten().fold(f64::INFINITY, |a, &b| a.min(b));
            format!("less than {}", say(first))
        } else {
            format!("up to {}", say(w))
        }
    }

    pub fn to_json(&self) -> Value {
        json!({
            "view": self.view, "moved": self.moved, "axis": self.axis,
            "unit": if self.axis == "distance" { "fraction of the distance" } else { "degrees" },
            "within": self.within(), "safe_minus": self.safe[0], "safe_plus": self.safe[1],
            "lost_minus": self.lost[0], "lost_plus": self.lost[1],
            "range": range_of(self.axis), "phrase": self.phrase(),
        })
    }
}

/// One search in progress: a (view, moved, axis, direction).
struct Search {
    view: usize,
    moved: &'static str,
    axis: &'static str,
    sign: f64,
    safe: f64,
    lost: Option<f64>,
    next_grid: usize,
}

impl Search {
    /// The next move to try (its size), or None when found.
    fn next(&self) -> Option<f64> {
        match self.lost {
            Some(l) => (l - self.safe > resolution(self.axis, self.safe)).then_some(0.5 * (self.safe + l)),
            None => {
                let grid: &[f64] = if self.axis == "distance" {
                    &DISTANCE_GRID
                } else {
                    &ANGLE_GRID
                };
                grid.get(self.next_grid).copied()
            }
        }
    }

    fn record(&mut self, size: f64, kept: bool) {
        if kept {
            self.safe = size;
            self.next_grid += 1;
        } else {
            self.lost = Some(size);
        }
    }
}

/// Every view's correlation as designed, the tolerances found, and every render the search made.
#[derive(Clone, Debug, Default)]
pub struct Sensitivity {
    pub base: Vec<f64>,
    pub tolerances: Vec<Tolerance>,
    pub samples: Vec<Moved>,
}

impl Sensitivity {
    /// The tolerances of view `name`.
    pub fn of<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Tolerance> + 'a {
        self.tolerances.iter().filter(move |t| t.view == name)
    }

    /// The tightest tolerance of all, relative to the range searched: what the maker must get
    /// right first.
    pub fn most_sensitive(&self) -> Option<&Tolerance> {
        self.tolerances
            .iter()
            .min_by(|a, b| a.relative().total_cmp(&b.relative()))
    }
}

/// Renders `views` of `scene` (in batches) and returns each one's display image. View k's render
/// computes only the tiles that hold `masks[k]`'s pixels and their neighbours (what
/// [`blur3`] reads for them): the pixels there are the whole render's, bit for bit; elsewhere 0.
pub(crate) fn render_views(
    renderer: &Renderer,
    scene: &Scene,
    views: Vec<View>,
    masks: &[&[bool]],
) -> Result<Vec<Vec<f32>>, OptimError> {
    let mut out = Vec::with_capacity(views.len());
    let batch = batch_views(renderer, scene, &views);
    for (chunk, masks) in views.chunks(batch).zip(masks.chunks(batch)) {
        let mut batch = scene.clone();
        batch.views = chunk.to_vec();
        let windows: Vec<Option<TileWindow>> = chunk.iter().zip(masks).map(|(v, m)| mask_window(v, m)).collect();
        let mut gs = renderer.upload_windowed(&batch, &windows)?;
        for img in renderer.render(&mut gs)?.images {
            out.push(
                img.iter()
                    .map(|&l| scratchart_render::io::display_value(l).clamp(0.0, 1.0))
                    .collect(),
            );
        }
    }
    Ok(out)
}

/// The tiles of view `v` that hold the pixels of `mask` and the pixels next to them (None for
/// an empty mask: nothing there is compared).
fn mask_window(v: &View, mask: &[bool]) -> Option<TileWindow> {
    let w = v.camera.width as usize;
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for (k, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
        let (x, y) = (k % w, k / w);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
    }
    (x0 < x1).then(|| {
        TileWindow::covering(
            v.camera.width,
            v.camera.height,
            x0.saturating_sub(1) as u32,
            y0.saturating_sub(1) as u32,
            (x1 + 1) as u32,
            (y1 + 1) as u32,
        )
    })
}

/// Each view's correlation with its picture as designed and, for every view that shows its
/// picture (and is not blank on purpose), how far the lamp and the eye may move in azimuth,
/// elevation and distance and keep [`KEEP`] of it: each found by search, outwards on a grid up
/// to [`ANGLE_RANGE`] and [`DISTANCE_RANGE`], then by bisection. All searches step together, one
/// batched render per step.
pub fn sensitivity(renderer: &Renderer, scene: &Scene, inputs: &SheetInputs) -> Result<Sensitivity, OptimError> {
    // A render from view j as designed, or from `eye`, a view with its eye moved: against the
    // picture as it appears from there (a move that only makes the picture larger, smaller or
    // foreshortened is no loss; what the reflection does there is).
    // The picture view j is compared with, as seen from `eye` (view j itself when None): its
    // target and the pixels it covers.
    let picture_of = |j: usize, eye: Option<&View>| match eye {
        None => (
            inputs.targets[j].iter().map(|&x| x as f64).collect(),
            inputs.pictures[j].clone(),
        ),
        Some(moved) => as_seen_from(
            &scene.views[j],
            moved,
            &inputs.targets[j],
            &inputs.pictures[j],
            &scene.plate,
        ),
    };
    let corr_of = |img: &[f32], j: usize, (t, m): &(Vec<f64>, Vec<bool>)| {
        let (w, h) = (scene.views[j].camera.width, scene.views[j].camera.height);
        correlation(&blur3(img, w, h, inputs.sigma), t, m)
    };
    let designed: Vec<(Vec<f64>, Vec<bool>)> = (0..scene.views.len()).map(|j| picture_of(j, None)).collect();
    let masks: Vec<&[bool]> = designed.iter().map(|(_, m)| m.as_slice()).collect();
    let images = render_views(renderer, scene, scene.views.clone(), &masks)?;
    let base: Vec<f64> = images
        .iter()
        .enumerate()
        .map(|(j, img)| corr_of(img, j, &designed[j]))
        .collect();
    let mut searches = Vec::new();
    for (j, v) in scene.views.iter().enumerate() {
        if inputs.blank_views.contains(&v.name) || !(base[j] >= ADVICE_MIN_CORR) {
            continue;
        }
        for moved in ["lamp", "eye"] {
            for axis in ["azimuth", "elevation", "distance"] {
                let directional = matches!(v.light.kind, LightKind::Directional { .. });
                if moved == "lamp" && axis == "distance" && directional {
                    continue;
                }
                for sign in [-1.0, 1.0] {
                    searches.push(Search {
                        view: j,
                        moved,
                        axis,
                        sign,
                        safe: 0.0,
                        lost: None,
                        next_grid: 0,
                    });
                }
            }
        }
    }
    let mut samples = Vec::new();
    let mut lamps = lamp::LampRenders::default();
    loop {
        let step: Vec<(usize, f64)> = searches
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.next().map(|size| (i, size)))
            .collect();
        if step.is_empty() {
            break;
        }
        let views: Vec<View> = step
            .iter()
            .map(|&(i, size)| {
                let s = &searches[i];
                variant(&scene.views[s.view], s.moved, s.axis, s.sign * size)
            })
            .collect();
        // (A moved lamp leaves the picture where it was: the designed view's, not copied.)
        let pictures: Vec<std::borrow::Cow<(Vec<f64>, Vec<bool>)>> = step
            .iter()
            .zip(&views)
            .map(|(&(i, _), view)| {
                let s = &searches[i];
                match s.moved {
                    "eye" => std::borrow::Cow::Owned(picture_of(s.view, Some(view))),
                    _ => std::borrow::Cow::Borrowed(&designed[s.view]),
                }
            })
            .collect();
        let masks: Vec<&[bool]> = pictures.iter().map(|p| p.1.as_slice()).collect();
        // The lamp searches keep their tile lists between steps ([`lamp`]); the eye searches
        // bin each step (their cameras move).
        let is_lamp: Vec<bool> = step.iter().map(|&(i, _)| searches[i].moved == "lamp").collect();
        let pick = |want: bool| -> Vec<usize> { (0..step.len()).filter(|&k| is_lamp[k] == want).collect() };
        let (lamp_k, eye_k) = (pick(true), pick(false));
        let lamp_imgs = lamps.render(
            renderer,
            scene,
            &lamp_k.iter().map(|&k| step[k].0).collect::<Vec<_>>(),
            lamp_k.iter().map(|&k| views[k].clone()).collect(),
            &lamp_k.iter().map(|&k| masks[k]).collect::<Vec<_>>(),
        )?;
        let eye_imgs = render_views(
            renderer,
            scene,
            eye_k.iter().map(|&k| views[k].clone()).collect(),
            &eye_k.iter().map(|&k| masks[k]).collect::<Vec<_>>(),
        )?;
        let mut images: Vec<Vec<f32>> = vec![Vec::new(); step.len()];
        for (k, img) in lamp_k.into_iter().zip(lamp_imgs).chain(eye_k.into_iter().zip(eye_imgs)) {
            images[k] = img;
        }
        for ((&(i, size), img), picture) in step.iter().zip(&images).zip(&pictures) {
            let s = &mut searches[i];
            let corr = corr_of(img, s.view, picture);
            samples.push(Moved {
                view: scene.views[s.view].name.clone(),
                moved: s.moved,
                axis: s.axis,
                delta: s.sign * size,
                corr,
            });
            s.record(size, corr >= KEEP * base[s.view]);
        }
    }
    samples.sort_by(|a, b| {
        (a.view.as_str(), a.moved, a.axis)
            .cmp(&(b.view.as_str(), b.moved, b.axis))
            .then(a.delta.total_cmp(&b.delta))
    });
    let mut tolerances: Vec<Tolerance> = Vec::new();
    for pair in searches.chunks(2) {
        let (m, p) = (&pair[0], &pair[1]);
        tolerances.push(Tolerance {
            view: scene.views[m.view].name.clone(),
            moved: m.moved,
            axis: m.axis,
            safe: [m.safe, p.safe],
            lost: [m.lost, p.lost],
        });
    }
    Ok(Sensitivity {
        base,
        tolerances,
        samples,
    })
}

/// View `designed`'s picture (its target, display values, and its picture's pixels) as it
/// appears from `moved` (the same view with the eye elsewhere, same image size): each pixel of
/// `moved` takes the target where `designed` saw the same point of the plate (bilinear among the
/// picture's pixels), and belongs to the picture where that point did. Pixels off the plate, or whose point `designed`
/// did not see, are left out.
pub fn as_seen_from(
    designed: &View,
    moved: &View,
    target: &[f32],
    picture: &[bool],
    plate: &scratchart_model::scene::Plate,
) -> (Vec<f64>, Vec<bool>) {
    let half = 0.5 * plate.size_mm;
    let (a, b) = (
        scratchart_model::camera::ViewGeom::of(designed, plate),
        scratchart_model::camera::ViewGeom::of(moved, plate),
    );
    let (w, h) = (moved.camera.width as usize, moved.camera.height as usize);
    let (dw, dh) = (designed.camera.width as usize, designed.camera.height as usize);
    let mut t = vec![0.0; w * h];
    let mut m = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let Some(p) = b.shading_point(x as u32, y as u32) else {
                continue;
            };
            if p[0].abs() > half || p[1].abs() > half {
                continue;
            }
            let Some((sx, sy)) = a.project(plate.shape.to_world(p)) else {
                continue;
            };
            // Seen by the designed view: inside its image.
            if !(sx >= 0.0 && sy >= 0.0 && sx < dw as f64 && sy < dh as f64) {
                continue;
            }
            // Bilinear between the four pixel centres around (sx, sy) (at the image's edge, the
            // edge pixels again).
            let (fx, fy) = ((sx - 0.5).max(0.0), (sy - 0.5).max(0.0));
            let (x0, y0) = ((fx.floor() as usize).min(dw - 1), (fy.floor() as usize).min(dh - 1));
            let (u, v) = ((fx - x0 as f64).clamp(0.0, 1.0), (fy - y0 as f64).clamp(0.0, 1.0));
            let (x1, y1) = ((x0 + 1).min(dw - 1), (y0 + 1).min(dh - 1));
            let k = y * w + x;
            let near = (sy.floor() as usize).min(dh - 1) * dw + (sx.floor() as usize).min(dw - 1);
            // In the picture where its nearest pixel is (so an unmoved eye gives the picture
            // itself); its value from the neighbours that are the picture's (what lies beyond
            // the picture's edge is no part of it).
            let (mut sum, mut weight) = (0.0, 0.0);
            for (i, j, wt) in [
                (x0, y0, (1.0 - u) * (1.0 - v)),
                (x1, y0, u * (1.0 - v)),
                (x0, y1, (1.0 - u) * v),
                (x1, y1, u * v),
            ] {
                if picture[j * dw + i] {
                    sum += wt * target[j * dw + i] as f64;
                    weight += wt;
                }
            }
            if picture[near] && weight > 1e-9 {
                t[k] = sum / weight;
                m[k] = true;
            }
        }
    }
    (t, m)
}

/// A point as a maker measures it from the plate centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Place {
    pub xyz: [f64; 3],
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    pub distance_mm: f64,
}

impl Place {
    pub fn of(p: [f64; 3]) -> Place {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        Place {
            xyz: p,
            azimuth_deg: p[1].atan2(p[0]).to_degrees(),
            elevation_deg: p[2].atan2(p[0].hypot(p[1])).to_degrees(),
            distance_mm: r,
        }
    }

    /// The point at these spherical coordinates.
    pub fn at(azimuth_deg: f64, elevation_deg: f64, distance_mm: f64) -> [f64; 3] {
        scratchart_model::camera::spherical(distance_mm, azimuth_deg, elevation_deg)
    }
}

/// Below this correlation with its picture a view does not show its picture yet, and how far
/// the lamp may move "to keep 90% of it" says nothing useful (90% of about nothing).
pub const ADVICE_MIN_CORR: f64 = 0.3;

/// What the set-up sheet is computed from: each view's target exactly as the design's loss saw
/// it (display values), where its picture is, the blur of the quality measure, and the views left
/// blank on purpose. `design` writes them beside the design ([`SheetInputs::FILE`],
/// `NAME_target.pfm`, `NAME_picture.png`: lossless) and `scratchart setup` reads them back, so the
/// two build the sheet through [`write_setup`] from the same numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct SheetInputs {
    pub targets: Vec<Vec<f32>>,
    pub pictures: Vec<Vec<bool>>,
    pub sigma: f32,
    pub blank_views: Vec<String>,
}

impl SheetInputs {
    /// The index file beside the design.
    pub const FILE: &'static str = "setup_inputs.json";

    /// Writes the inputs into `dir` (atomically, each file).
    pub fn save(&self, dir: &Path, scene: &Scene) -> Result<(), OptimError> {
        let mut views = Vec::new();
        for (j, v) in scene.views.iter().enumerate() {
            let (w, h) = (v.camera.width, v.camera.height);
            let (t, m) = (format!("{}_target.pfm", v.name), format!("{}_picture.png", v.name));
            scratchart_render::io::write_pfm(&dir.join(&t), w, h, &self.targets[j])?;
            let mask: Vec<u8> = self.pictures[j].iter().map(|&p| if p { 255 } else { 0 }).collect();
            scratchart_render::io::write_png_gray(&dir.join(&m), w, h, &mask)?;
            views.push(json!({"name": v.name, "target": t, "picture": m}));
        }
        let index = json!({
            "what": "the set-up sheet's inputs: each view's target as the design's loss saw it (display values, PFM) and its picture's pixels (PNG, white); `scratchart setup` reads them",
            "sigma_px": self.sigma,
            "blank_views": self.blank_views,
            "views": views,
        });
        let text = serde_json::to_string_pretty(&index).expect("the index always serializes");
        Ok(scratchart_render::io::write_atomic(
            &dir.join(Self::FILE),
            text.as_bytes(),
        )?)
    }

    /// The sheet's inputs of a design in `dir` that wrote none: NAME_target.png beside it (else
    /// the design's own render), the whole plate as each picture, the loss's default blur, and
    /// the views its summary.json lists as blank on purpose.
    pub fn approximate(
        renderer: &Renderer,
        scene: &Scene,
        dir: &Path,
        obs: &dyn Observer,
    ) -> Result<SheetInputs, OptimError> {
        let mut gs = renderer.upload(scene)?;
        let frame = renderer.render(&mut gs)?;
        let mut targets = Vec::new();
        for (v, img) in scene.views.iter().zip(&frame.images) {
            let t = dir.join(format!("{}_target.png", v.name));
            let (w, h) = (v.camera.width, v.camera.height);
            let own = || img.iter().map(|&l| scratchart_render::io::display_value(l)).collect();
            let target = match scratchart_render::io::read_image_gray(&t) {
                Ok((tw, th, data)) if (tw, th) == (w, h) => data,
                Ok((tw, th, _)) => {
                    obs.warn(&format!(
                        "{} is {tw}x{th}, the view {w}x{h}: using the design's own render",
                        t.display()
                    ));
                    own()
                }
                Err(_) => own(),
            };
            targets.push(target);
        }
        let pictures: Vec<Vec<bool>> = (0..scene.views.len())
            .map(|v| scratchart_model::camera::on_plate_mask(scene, v))
            .collect();
        // Views the design left blank on purpose, as its summary.json lists them.
        let blank_views: Vec<String> = std::fs::read_to_string(dir.join("summary.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<Value>(&t).ok())
            .and_then(|v| v["blank_views"].as_array().cloned())
            .map(|a| a.iter().filter_map(|x| x.as_str().map(String::from)).collect())
            .unwrap_or_default();
        Ok(SheetInputs {
            targets,
            pictures,
            sigma: scratchart_optim::loss::LossConfig::default().sigma,
            blank_views,
        })
    }

    /// Reads the inputs a design wrote into `dir`; `Ok(None)` when it wrote none (a design made
    /// before they were written).
    pub fn load(dir: &Path, scene: &Scene) -> Result<Option<SheetInputs>, OptimError> {
        let path = dir.join(Self::FILE);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(cause) => {
                return Err(OptimError::Io(scratchart_render::io::IoError::Io {
                    action: "read",
                    path,
                    cause,
                }))
            }
        };
        let bad = |msg: String| {
            OptimError::Io(scratchart_render::io::IoError::Format {
                kind: "set-up inputs",
                path: path.clone(),
                msg,
            })
        };
        let index: Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        let sigma = index["sigma_px"]
            .as_f64()
            .filter(|s| s.is_finite() && *s >= 0.0)
            .ok_or_else(|| bad("`sigma_px` is not a number >= 0".into()))? as f32;
        let blank_views = index["blank_views"]
            .as_array()
            .map(|a| a.iter().filter_map(|x| x.as_str().map(String::from)).collect())
            .unwrap_or_default();
        let listed = index["views"].as_array().cloned().unwrap_or_default();
        let (mut targets, mut pictures) = (Vec::new(), Vec::new());
        for v in &scene.views {
            let entry = listed
                .iter()
                .find(|e| e["name"].as_str() == Some(v.name.as_str()))
                .ok_or_else(|| bad(format!("it lists no view `{}` (the design has it)", v.name)))?;
            let file = |key: &str| {
                entry[key]
                    .as_str()
                    .map(|f| dir.join(f))
                    .ok_or_else(|| bad(format!("view `{}` has no `{key}` file", v.name)))
            };
            let (w, h) = (v.camera.width, v.camera.height);
            let tp = file("target")?;
            let (tw, th, t) = scratchart_render::io::read_pfm(&tp)?;
            let mp = file("picture")?;
            let (mw, mh, m) = scratchart_render::io::read_image_gray(&mp)?;
            if (tw, th) != (w, h) || (mw, mh) != (w, h) {
                return Err(bad(format!(
                    "view `{}` is {w}x{h}, but `{}` is {tw}x{th} and `{}` {mw}x{mh}",
                    v.name,
                    tp.display(),
                    mp.display()
                )));
            }
            targets.push(t);
            pictures.push(m.iter().map(|&x| x > 0.5).collect());
        }
        Ok(Some(SheetInputs {
            targets,
            pictures,
            sigma,
            blank_views,
        }))
    }
}

mod lamp;

#[cfg(test)]
mod tests;
