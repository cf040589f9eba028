//! Walk-past plates (`scratchart design --walk / --hold / --object`): a plate that plays a
//! sequence as the viewer walks along a horizontal arc.
//!
//! - The **design views** stand evenly along an arc of `arc_deg` degrees centred on
//!   `centre_azimuth_deg`, at one elevation and distance, each framed as the ring's views are
//!   (the plate's silhouette fills 95% of the frame). Design view k shows frame k, placed as
//!   photos are (`--fit`).
//! - **In-between views** (`between` per pair of neighbours) join the loss too, so the plate
//!   does not go dark or flicker between the design views. Between frames, an in-between view's
//!   target is the cross-fade of its two neighbours' frames, each placed in the in-between view
//!   itself: (1 - t) left + t right at the fraction t of the way. For a 3D object it is the
//!   object seen from there (the truth between two views of an object is not a cross-fade).
//!   They come after the design views in the problem's scene, are not written as design views
//!   (design.json has the design views only) and are listed apart in `summary.json`'s `walk`.
//! - The outputs: `summary.json`'s `walk` (each view's correlation with its frame or blend, in
//!   arc order), `walk.png` (that correlation along the arc) and `walk_sheet.png` (the renders
//!   along the arc above their targets).
use std::path::PathBuf;

use super::framing::{fit_picture_walk, Fit, Fitted};
use scratchart_model::scene::{Light, Plate, Scene, View};

#[cfg(test)]
mod tests;

/// The arc of design views of a walk.
#[derive(Clone, Debug, PartialEq)]
pub struct WalkArc {
    /// Total angle from the first design view to the last, degrees.
    pub arc_deg: f64,
    /// Azimuth of the arc's middle, degrees (counter-clockwise from the plate's +x).
    pub centre_azimuth_deg: f64,
    /// Elevation of every view above the plate's plane, degrees.
    pub elevation_deg: f64,
    /// Distance of every eye from the plate centre, mm.
    pub distance_mm: f64,
    /// Number of design views (at least 2).
    pub views: usize,
    /// In-between views per pair of neighbouring design views in the loss (0: none).
    pub between: usize,
    /// Square view resolution, pixels.
    pub res: u32,
}

impl WalkArc {
    /// Degrees between neighbouring design views.
    pub fn step_deg(&self) -> f64 {
        self.arc_deg / (self.views.max(2) - 1) as f64
    }

    /// The azimuth at position `s` along the arc: design view k is at s = k, an in-between view
    /// at a fraction in between.
    pub fn azimuth_at(&self, s: f64) -> f64 {
        self.centre_azimuth_deg - 0.5 * self.arc_deg + s * self.step_deg()
    }

    /// The design views' count a held picture or an object gets by default: one view every 5
    /// degrees or closer, at least 2.
    pub fn default_views(arc_deg: f64) -> usize {
        ((arc_deg / 5.0).ceil() as usize + 1).max(2)
    }

    /// Checks the arc (messages name the flags).
    pub fn check(&self) -> Result<(), String> {
        if !(self.arc_deg > 0.0 && self.arc_deg < 360.0) {
            return Err(format!(
                "--arc {}: the arc's total angle must lie above 0 and below 360 degrees",
                self.arc_deg
            ));
        }
        if self.views < 2 {
            return Err(format!(
                "a walk needs at least 2 views along its arc (it has {}); for one picture use --targets",
                self.views
            ));
        }
        if !(self.elevation_deg > 0.0 && self.elevation_deg < 90.0) {
            return Err(format!(
                "--elevation {}: must lie strictly between 0 and 90 degrees",
                self.elevation_deg
            ));
        }
        if !(self.distance_mm.is_finite() && self.distance_mm > 0.0) {
            return Err(format!("--distance {}: a distance above 0 mm", self.distance_mm));
        }
        if self.between > 16 {
            return Err(format!(
                "--between {}: at most 16 in-between views per pair",
                self.between
            ));
        }
        if self.res < 8 {
            return Err("--res must be at least 8 pixels".into());
        }
        Ok(())
    }
}

/// An in-between view: scene view `view`, the fraction `t` (0 < t < 1) of the way from design
/// view `left` to design view `left + 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct BetweenView {
    pub view: usize,
    pub left: usize,
    pub t: f64,
}

/// A walk-past design: its arc, what its frames are, and its in-between views.
#[derive(Clone, Debug, PartialEq)]
pub struct Walk {
    pub arc: WalkArc,
    /// `frames`, `hold` or `object`.
    pub source: String,
    /// What each design view shows: a file name per view, or the object's file.
    pub frames: Vec<String>,
    /// The in-between views, in the order they follow the design views in the scene.
    pub between: Vec<BetweenView>,
    /// Views that judge the design between its design views without joining the loss (see
    /// [`Probe`]).
    pub probes: Vec<Probe>,
}

/// A view that judges the finished design between two design views and is not in the loss:
/// the fraction `t` of the way from design view `left` to `left + 1`, with its target (the
/// cross-fade, or the object seen from there) and its picture's pixels. The design is rendered
/// from every probe once at the end, so `walk.png` shows the whole arc, not only the points the
/// optimizer saw.
#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    pub left: usize,
    pub t: f64,
    pub view: View,
    pub target: Vec<f32>,
    pub picture: Vec<bool>,
}

impl Walk {
    /// Number of design views (the first views of the problem's scene).
    pub fn design_views(&self) -> usize {
        self.arc.views
    }

    /// Position along the arc of scene view `v` (design view k at k).
    pub fn position(&self, v: usize) -> f64 {
        if v < self.arc.views {
            v as f64
        } else {
            let b = &self.between[v - self.arc.views];
            b.left as f64 + b.t
        }
    }

    /// Every scene view's index in arc order (design and in-between views interleaved).
    pub fn arc_order(&self) -> Vec<usize> {
        let mut order: Vec<usize> = (0..self.arc.views + self.between.len()).collect();
        order.sort_by(|&a, &b| self.position(a).total_cmp(&self.position(b)));
        order
    }
}

/// The name of the in-between view `i` (1-based) of `per_pair` between design views `left`
/// and `left + 1`.
fn between_name(left: usize, i: usize, per_pair: usize) -> String {
    if per_pair == 1 {
        format!("v{left}-v{}", left + 1)
    } else {
        format!("v{left}-v{}.{i}", left + 1)
    }
}

/// A view at azimuth `az` on the arc: the ring's camera, framed as the ring's views are.
fn arc_view(name: String, arc: &WalkArc, az: f64, plate: &Plate, light: &Light) -> View {
    let mut v = View {
        exposure: 1.0,
        name,
        camera: crate::scenes::orbit_camera(arc.distance_mm, arc.elevation_deg, az, plate.size_mm, arc.res, arc.res),
        light: light.clone(),
    };
    crate::scenes::frame_plate(&mut v, plate, 0.95);
    v
}

/// The walk's views: the design views v0 .. v{N-1} along the arc, then the in-between views
/// (`arc.between` per pair, evenly spaced), all lit by `light`.
pub fn arc_views(arc: &WalkArc, plate: &Plate, light: &Light) -> (Vec<View>, Vec<BetweenView>) {
    let mut views: Vec<View> = (0..arc.views)
        .map(|k| arc_view(format!("v{k}"), arc, arc.azimuth_at(k as f64), plate, light))
        .collect();
    let mut between = Vec::new();
    for left in 0..arc.views - 1 {
        for i in 1..=arc.between {
            let t = i as f64 / (arc.between + 1) as f64;
            between.push(BetweenView {
                view: views.len(),
                left,
                t,
            });
            views.push(arc_view(
                between_name(left, i, arc.between),
                arc,
                arc.azimuth_at(left as f64 + t),
                plate,
                light,
            ));
        }
    }
    (views, between)
}

/// The probe views of `arc`: `per_pair` per pair of neighbouring design views, at the fractions
/// i / (per_pair + 1), named `v0-v1@0.25` and so on; each pair's left view index and fraction.
pub fn probe_views(arc: &WalkArc, plate: &Plate, light: &Light, per_pair: usize) -> Vec<(usize, f64, View)> {
    let mut out = Vec::new();
    for left in 0..arc.views.saturating_sub(1) {
        for i in 1..=per_pair {
            let t = i as f64 / (per_pair + 1) as f64;
            let name = format!("v{left}-v{}@{t:.2}", left + 1);
            out.push((
                left,
                t,
                arc_view(name, arc, arc.azimuth_at(left as f64 + t), plate, light),
            ));
        }
    }
    out
}

use super::targets::Picture;

/// What a walk shows.
pub enum Frames<'a> {
    /// One picture per design view, in arc order (a held picture is the same one repeated).
    Pictures(Vec<Picture>),
    /// A 3D object, rendered from every view (design and in-between) with a key light fixed in
    /// the world, so it is lit as one real object.
    Object {
        mesh: &'a scratchart_model::mesh::Mesh,
        placement: scratchart_model::mesh::Placement,
        key_light: [f64; 3],
    },
}

/// The frames of `--walk`: the files given, or, for one directory, its PNG and JPEG files in
/// name order.
pub fn frame_files(given: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    if let [dir] = given {
        if dir.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
                .map_err(|e| format!("cannot read the frames' directory {}: {e}", dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.is_file()
                        && p.extension()
                            .and_then(|e| e.to_str())
                            .is_some_and(|e| ["png", "jpg", "jpeg"].contains(&e.to_ascii_lowercase().as_str()))
                })
                .collect();
            files.sort();
            if files.len() < 2 {
                return Err(format!(
                    "--walk {}: a walk needs at least 2 frames (PNG or JPEG files, taken in name order); the directory has {}",
                    dir.display(),
                    files.len()
                ));
            }
            return Ok(files);
        }
    }
    if given.len() < 2 {
        return Err(format!(
            "--walk needs at least 2 frames (or a directory of them); it has {}. To show one picture over the whole arc, use --hold PICTURE",
            given.len()
        ));
    }
    Ok(given.to_vec())
}

/// Reads a walk's frames, frame k for design view `v{k}` ([`super::targets::read_picture`]).
pub fn read_pictures(files: &[PathBuf], blank: &[String]) -> Result<Vec<Picture>, super::targets::TargetError> {
    files
        .iter()
        .enumerate()
        .map(|(k, p)| super::targets::read_picture(p, &format!("v{k}"), blank))
        .collect()
}

/// The target of `view` at the fraction `t` of the way from design view `left` to `left + 1`
/// (t = 0: design view `left` itself): the frame there, the cross-fade (1 - t) left + t right of
/// the neighbours' frames, each placed in `view` as `fit` says and put through the tone curve
/// `gamma` (as `design --targets` does), or the object seen from `view`.
#[allow(clippy::too_many_arguments)] // the placement's settings, named at the one call site
pub fn target_at(
    view: &View,
    plate: &Plate,
    left: usize,
    t: f64,
    frames: &Frames,
    fit: Fit,
    background: f32,
    gamma: f32,
) -> Fitted {
    let tone = |mut f: Fitted| {
        if gamma != 1.0 {
            for (v, p) in f.image.iter_mut().zip(&f.picture) {
                if *p {
                    *v = v.powf(gamma);
                }
            }
        }
        f
    };
    let on = || scratchart_model::camera::ViewGeom::of(view, plate).on_plate_mask(0.5 * plate.size_mm);
    match frames {
        Frames::Pictures(pics) => {
            let place = |pic: &Picture| {
                tone(fit_picture_walk(
                    &pic.data, pic.width, pic.height, view, plate, fit, background,
                ))
            };
            if t == 0.0 {
                return place(&pics[left]);
            }
            let (l, r) = (place(&pics[left]), place(&pics[left + 1]));
            let tf = t as f32;
            Fitted {
                image: l
                    .image
                    .iter()
                    .zip(&r.image)
                    .map(|(a, c)| (1.0 - tf) * a + tf * c)
                    .collect(),
                rect: None,
                picture: l
                    .picture
                    .iter()
                    .zip(&r.picture)
                    .zip(&on())
                    .map(|((a, c), o)| (*a || *c) && *o)
                    .collect(),
            }
        }
        Frames::Object {
            mesh,
            placement,
            key_light,
        } => {
            let img = scratchart_model::mesh::render_object(mesh, placement, view, *key_light, background);
            let on = on();
            let image: Vec<f32> = img
                .shade
                .iter()
                .zip(&on)
                .map(|(s, o)| if *o { *s } else { 0.0 })
                .collect();
            tone(Fitted {
                image,
                rect: None,
                picture: on,
            })
        }
    }
}

/// Every view's target (design views, then in-between views); see [`target_at`].
pub fn walk_targets(scene: &Scene, walk: &Walk, frames: &Frames, fit: Fit, background: f32, gamma: f32) -> Vec<Fitted> {
    let plate = &scene.plate;
    let n = walk.design_views();
    let at = |v: usize, left: usize, t: f64| target_at(&scene.views[v], plate, left, t, frames, fit, background, gamma);
    (0..n)
        .map(|k| at(k, k, 0.0))
        .chain(walk.between.iter().map(|b| at(b.view, b.left, b.t)))
        .collect()
}

/// The probes of `views` ([`probe_views`]) with their targets.
pub fn probes(
    views: Vec<(usize, f64, View)>,
    plate: &Plate,
    frames: &Frames,
    fit: Fit,
    background: f32,
    gamma: f32,
) -> Vec<Probe> {
    views
        .into_iter()
        .map(|(left, t, view)| {
            let f = target_at(&view, plate, left, t, frames, fit, background, gamma);
            Probe {
                left,
                t,
                view,
                target: f.image,
                picture: f.picture,
            }
        })
        .collect()
}

/// Renders the finished design `scene` (its design views first, as [`Walk`] numbers them) from
/// every probe, lit as the probe's left neighbour is, a few views at a time; returns each
/// probe's correlation with its target.
pub fn judge_probes(
    renderer: &scratchart_render::Renderer,
    scene: &Scene,
    walk: &Walk,
    sigma: f32,
) -> Result<Vec<f64>, scratchart_vulkan::GpuError> {
    let probe_views: Vec<scratchart_model::scene::View> = walk.probes.iter().map(|p| p.view.clone()).collect();
    let batch = crate::tolerance::batch_views(renderer, scene, &probe_views).min(12);
    let mut out = Vec::with_capacity(walk.probes.len());
    for chunk in walk.probes.chunks(batch) {
        let mut s = scene.clone();
        s.views = chunk
            .iter()
            .map(|p| {
                let mut v = p.view.clone();
                v.light = scene.views[p.left].light.clone();
                v.exposure = scene.views[p.left].exposure;
                v
            })
            .collect();
        let mut gs = renderer.upload(&s)?;
        let frame = renderer.render(&mut gs)?;
        for (p, img) in chunk.iter().zip(&frame.images) {
            let display: Vec<f32> = img.iter().map(|&l| scratchart_render::io::display_value(l)).collect();
            let (w, h) = (p.view.camera.width, p.view.camera.height);
            out.push(corr_of(&display, &p.target, &p.picture, w, h, sigma));
        }
    }
    Ok(out)
}

/// The correlation the walk reports: the render (clamped to [0, 1] and blurred as the loss
/// blurs it) against the target over its picture's pixels.
pub fn corr_of(display: &[f32], target: &[f32], picture: &[bool], w: u32, h: u32, sigma: f32) -> f64 {
    let c: Vec<f32> = display.iter().map(|x| x.clamp(0.0, 1.0)).collect();
    let blurred = super::measure::blur3(&c, w, h, sigma);
    let t: Vec<f64> = target.iter().map(|&x| x as f64).collect();
    super::measure::correlation(&blurred, &t, picture)
}
