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
use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::framing::{fit_picture_walk, Fit, Fitted};
use super::problem::{DesignReport, IterRecord, Problem};
use crate::model::scene::{Light, Scene, View};

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
fn arc_view(name: String, arc: &WalkArc, az: f64, plate_mm: f64, light: &Light) -> View {
    let mut v = View {
        exposure: 1.0,
        name,
        camera: crate::scenes::orbit_camera(arc.distance_mm, arc.elevation_deg, az, plate_mm, arc.res, arc.res),
        light: light.clone(),
    };
    crate::scenes::frame_plate(&mut v, plate_mm, 0.95);
    v
}

/// The walk's views: the design views v0 .. v{N-1} along the arc, then the in-between views
/// (`arc.between` per pair, evenly spaced), all lit by `light`.
pub fn arc_views(arc: &WalkArc, plate_mm: f64, light: &Light) -> (Vec<View>, Vec<BetweenView>) {
    let mut views: Vec<View> = (0..arc.views)
        .map(|k| arc_view(format!("v{k}"), arc, arc.azimuth_at(k as f64), plate_mm, light))
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
                plate_mm,
                light,
            ));
        }
    }
    (views, between)
}

/// The probe views of `arc`: `per_pair` per pair of neighbouring design views, at the fractions
/// i / (per_pair + 1), named `v0-v1@0.25` and so on; each pair's left view index and fraction.
pub fn probe_views(arc: &WalkArc, plate_mm: f64, light: &Light, per_pair: usize) -> Vec<(usize, f64, View)> {
    let mut out = Vec::new();
    for left in 0..arc.views.saturating_sub(1) {
        for i in 1..=per_pair {
            let t = i as f64 / (per_pair + 1) as f64;
            let name = format!("v{left}-v{}@{t:.2}", left + 1);
            out.push((
                left,
                t,
                arc_view(name, arc, arc.azimuth_at(left as f64 + t), plate_mm, light),
            ));
        }
    }
    out
}

pub use super::targets::Picture;

/// What a walk shows.
pub enum Frames<'a> {
    /// One picture per design view, in arc order (a held picture is the same one repeated).
    Pictures(Vec<Picture>),
    /// A 3D object, rendered from every view (design and in-between) with a key light fixed in
    /// the world, so it is lit as one real object.
    Object {
        mesh: &'a crate::model::mesh::Mesh,
        placement: crate::model::mesh::Placement,
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
    plate_mm: f64,
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
    let on = || crate::model::camera::ViewGeom::new(view).on_plate_mask(0.5 * plate_mm);
    match frames {
        Frames::Pictures(pics) => {
            let place = |pic: &Picture| {
                tone(fit_picture_walk(
                    &pic.data, pic.width, pic.height, view, plate_mm, fit, background,
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
            let img = crate::model::mesh::render_object(mesh, placement, view, *key_light, background);
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
    let plate = scene.plate.size_mm;
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
    plate_mm: f64,
    frames: &Frames,
    fit: Fit,
    background: f32,
    gamma: f32,
) -> Vec<Probe> {
    views
        .into_iter()
        .map(|(left, t, view)| {
            let f = target_at(&view, plate_mm, left, t, frames, fit, background, gamma);
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
    renderer: &crate::render::Renderer,
    scene: &Scene,
    walk: &Walk,
    sigma: f32,
) -> Result<Vec<f64>, crate::vulkan::GpuError> {
    const CHUNK: usize = 12;
    let mut out = Vec::with_capacity(walk.probes.len());
    for chunk in walk.probes.chunks(CHUNK) {
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
            let display: Vec<f32> = img.iter().map(|&l| crate::io::display_value(l)).collect();
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

/// The problem and report of a walk cut down to its design views, for the outputs every design
/// writes (design.json, the per-view images and summary, the set-up sheet): the in-between
/// views were in the loss and are reported apart ([`walk_summary`]).
pub fn design_views_only(problem: &Problem, report: &DesignReport) -> (Problem, DesignReport) {
    let Some(walk) = &problem.walk else {
        return (problem.clone(), report.clone());
    };
    let n = walk.design_views();
    let mut p = problem.clone();
    p.scene.views.truncate(n);
    p.targets.truncate(n);
    p.pictures.truncate(n);
    p.picture_rects.truncate(n);
    let mut r = report.clone();
    r.scene.views.truncate(n);
    r.unpruned.views.truncate(n);
    let cut = |x: &IterRecord| IterRecord {
        pixel: x.pixel[..n].to_vec(),
        gram: x.gram[..n].to_vec(),
        total: x.total,
    };
    r.history = r.history.iter().map(cut).collect();
    r.final_loss.pixel.truncate(n);
    r.final_loss.gram.truncate(n);
    r.final_images.truncate(n);
    r.initial_images.truncate(n);
    (p, r)
}

/// `summary.json`'s `walk`: the arc, and every view's correlation with its frame (design
/// views) or its neighbours' blend (in-between views), in arc order; with the smallest of each.
pub fn walk_summary(
    problem: &Problem,
    final_images: &[Vec<f32>],
    probe_corr: &[f64],
    sigma: f32,
) -> Option<(Value, Vec<f64>)> {
    let walk = problem.walk.as_ref()?;
    let scene = &problem.scene;
    let corr: Vec<f64> = (0..scene.views.len())
        .map(|v| {
            let (w, h) = (scene.views[v].camera.width, scene.views[v].camera.height);
            corr_of(&final_images[v], &problem.targets[v], &problem.pictures[v], w, h, sigma)
        })
        .collect();
    let n = walk.design_views();
    let entry = |v: usize| {
        let mut e = json!({
            "name": scene.views[v].name,
            "azimuth_deg": walk.arc.azimuth_at(walk.position(v)),
            "position": walk.position(v),
            "corr": corr[v],
        });
        if v < n {
            e["frame"] = json!(walk.frames.get(v).or(walk.frames.first()));
        } else {
            let b = &walk.between[v - n];
            e["between"] = json!([scene.views[b.left].name, scene.views[b.left + 1].name]);
            e["t"] = json!(b.t);
            e["target"] = json!(if walk.source == "object" {
                "the object seen from this view"
            } else {
                "the cross-fade (1 - t) left + t right of its neighbours' frames"
            });
        }
        e
    };
    let probes: Vec<Value> = walk
        .probes
        .iter()
        .zip(probe_corr)
        .map(|(p, c)| {
            json!({
                "name": p.view.name,
                "azimuth_deg": walk.arc.azimuth_at(p.left as f64 + p.t),
                "position": p.left as f64 + p.t,
                "between": [scene.views[p.left].name, scene.views[p.left + 1].name],
                "t": p.t,
                "corr": c,
            })
        })
        .collect();
    let min = |r: std::ops::Range<usize>| r.map(|v| corr[v]).fold(f64::INFINITY, f64::min);
    let min_probe = probe_corr.iter().cloned().fold(f64::INFINITY, f64::min);
    let a = &walk.arc;
    let value = json!({
        "source": walk.source,
        "arc_deg": a.arc_deg,
        "centre_azimuth_deg": a.centre_azimuth_deg,
        "elevation_deg": a.elevation_deg,
        "distance_mm": a.distance_mm,
        "step_deg": a.step_deg(),
        "design_views": n,
        "between_per_pair": a.between,
        "frames": walk.frames,
        "views": (0..n).map(entry).collect::<Vec<_>>(),
        "between": (n..scene.views.len()).map(entry).collect::<Vec<_>>(),
        "min_corr_views": min(0..n),
        "min_corr_between": if scene.views.len() > n { json!(min(n..scene.views.len())) } else { Value::Null },
        "probes": probes,
        "probes_are": "views between the design views that are not in the loss: the finished design rendered from there, against the same kind of target as an in-between view's",
        "min_corr_probes": if probe_corr.is_empty() { Value::Null } else { json!(min_probe) },
        "corr": "correlation of the render (blurred as the loss blurs it) with the view's target over its picture's pixels",
        "walk_png": "x: azimuth along the arc, degrees; y: correlation; filled: design views, hollow: in-between views (in the loss), grey crosses: probes (judged only)",
    });
    Some((value, corr))
}

/// `walk.png`: each view's correlation along the arc (design views filled, in-between views
/// hollow, probes grey crosses), with the bars 0.9 and 0.8 dashed.
pub fn walk_plot_png(
    path: &Path,
    problem: &Problem,
    corr: &[f64],
    probe_corr: &[f64],
) -> Result<(), super::OptimError> {
    use plotters::prelude::*;
    let Some(walk) = &problem.walk else { return Ok(()) };
    let (wpx, hpx) = (900u32, 420u32);
    let mut buf = vec![0u8; (wpx * hpx * 3) as usize];
    let order = walk.arc_order();
    let az = |v: usize| walk.arc.azimuth_at(walk.position(v));
    let (x0, x1) = (az(order[0]), az(*order.last().expect("a walk has views")));
    let pad = 0.04 * (x1 - x0).max(1.0);
    let lo = corr
        .iter()
        .chain(probe_corr)
        .cloned()
        .fold(0.5f64, f64::min)
        .clamp(-1.0, 0.5);
    // Every point along the arc (views and probes), for the line through them.
    let mut line: Vec<(f64, f64)> = order
        .iter()
        .map(|&v| (az(v), corr[v]))
        .chain(
            walk.probes
                .iter()
                .zip(probe_corr)
                .map(|(p, &c)| (walk.arc.azimuth_at(p.left as f64 + p.t), c)),
        )
        .collect();
    line.sort_by(|a, b| a.0.total_cmp(&b.0));
    let pe = |e: DrawingAreaErrorKind<_>| super::OptimError::Report(format!("plot: {e}"));
    let n = walk.design_views();
    {
        let root = BitMapBackend::with_buffer(&mut buf, (wpx, hpx)).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let blue = RGBColor(30, 90, 200);
        let orange = RGBColor(230, 120, 20);
        let mut builder = ChartBuilder::on(&root);
        builder.margin(16).x_label_area_size(40).y_label_area_size(56);
        let font = super::report::plot_font();
        if let Some(f) = font {
            builder.caption(
                format!(
                    "correlation along the walk ({} views, {:.1} deg apart; hollow: in between, x: probes)",
                    n,
                    walk.arc.step_deg()
                ),
                (f, 18),
            );
        }
        let mut chart = builder
            .build_cartesian_2d((x0 - pad)..(x1 + pad), lo..1.0)
            .map_err(pe)?;
        if let Some(f) = font {
            chart
                .configure_mesh()
                .x_desc("azimuth (degrees)")
                .y_desc("correlation with the frame / blend")
                .label_style((f, 13))
                .axis_desc_style((f, 14))
                .draw()
                .map_err(pe)?;
        }
        for (bar, c) in [(0.9, blue), (0.8, orange)] {
            let mut x = x0 - pad;
            let dash = (x1 - x0 + 2.0 * pad) / 80.0;
            while x < x1 + pad {
                chart
                    .draw_series(LineSeries::new(
                        vec![(x, bar), ((x + dash).min(x1 + pad), bar)],
                        c.mix(0.5),
                    ))
                    .map_err(pe)?;
                x += 2.0 * dash;
            }
        }
        chart
            .draw_series(LineSeries::new(line.iter().copied(), RGBColor(90, 90, 90)))
            .map_err(pe)?;
        chart
            .draw_series(walk.probes.iter().zip(probe_corr).map(|(p, &c)| {
                Cross::new(
                    (walk.arc.azimuth_at(p.left as f64 + p.t), c),
                    4,
                    RGBColor(120, 120, 120),
                )
            }))
            .map_err(pe)?;
        chart
            .draw_series(
                order
                    .iter()
                    .filter(|&&v| v < n)
                    .map(|&v| Circle::new((az(v), corr[v]), 5, blue.filled())),
            )
            .map_err(pe)?;
        chart
            .draw_series(
                order
                    .iter()
                    .filter(|&&v| v >= n)
                    .map(|&v| Circle::new((az(v), corr[v]), 5, orange.stroke_width(2))),
            )
            .map_err(pe)?;
        root.present().map_err(pe)?;
    }
    super::report::write_rgb_png(path, wpx, hpx, buf)
}

/// `walk_sheet.png`: the walk's contact sheet, in arc order, up to 12 views a row: each view's
/// render above its target, framed blue for a design view and orange for an in-between view.
pub fn walk_sheet_png(path: &Path, problem: &Problem, displays: &[Vec<f32>]) -> Result<(), super::OptimError> {
    let Some(walk) = &problem.walk else { return Ok(()) };
    const GAP: u32 = 6;
    const BORDER: u32 = 2;
    const PER_ROW: usize = 12;
    let scene = &problem.scene;
    let order = walk.arc_order();
    let cw = scene.views.iter().map(|v| v.camera.width).max().unwrap_or(1) + 2 * BORDER;
    let ch = scene.views.iter().map(|v| v.camera.height).max().unwrap_or(1) + 2 * BORDER;
    let cols = order.len().min(PER_ROW) as u32;
    let rows = order.len().div_ceil(PER_ROW) as u32;
    let (w, h) = (cols * (cw + GAP) + GAP, rows * (2 * ch + 2 * GAP) + GAP);
    let mut px = vec![255u8; (w * h * 3) as usize];
    let n = walk.design_views();
    let mut put = |x: u32, y: u32, c: [u8; 3]| {
        let i = 3 * (y * w + x) as usize;
        px[i..i + 3].copy_from_slice(&c);
    };
    for (slot, &v) in order.iter().enumerate() {
        let (cx, cy) = ((slot % PER_ROW) as u32, (slot / PER_ROW) as u32);
        let frame = if v < n { [30, 90, 200] } else { [230, 120, 20] };
        let (vw, vh) = (scene.views[v].camera.width, scene.views[v].camera.height);
        for (k, img) in [&displays[v], &problem.targets[v]].into_iter().enumerate() {
            let x0 = GAP + cx * (cw + GAP);
            let y0 = GAP + cy * (2 * ch + 2 * GAP) + k as u32 * (ch + GAP / 2);
            for y in 0..vh + 2 * BORDER {
                for x in 0..vw + 2 * BORDER {
                    let inside = x >= BORDER && y >= BORDER && x < vw + BORDER && y < vh + BORDER;
                    let c = if inside {
                        let g = (255.0 * img[((y - BORDER) * vw + x - BORDER) as usize].clamp(0.0, 1.0)).round() as u8;
                        [g, g, g]
                    } else {
                        frame
                    };
                    put(x0 + x, y0 + y, c);
                }
            }
        }
    }
    super::report::write_rgb_png(path, w, h, px)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arc(views: usize, between: usize) -> WalkArc {
        WalkArc {
            arc_deg: 60.0,
            centre_azimuth_deg: 10.0,
            elevation_deg: 40.0,
            distance_mm: 300.0,
            views,
            between,
            res: 32,
        }
    }

    /// The cameras stand where the flags put them: evenly along the arc about its centre, at
    /// the elevation and distance asked, the in-between views between their neighbours.
    #[test]
    fn the_arcs_cameras_stand_where_the_flags_put_them() {
        let a = arc(5, 2);
        let light = crate::scenes::orbit_light(300.0, 60.0, 10.0, 1e4);
        let (views, between) = arc_views(&a, 100.0, &light);
        assert_eq!(views.len(), 5 + 4 * 2);
        assert_eq!(between.len(), 8);
        let names: Vec<&str> = views.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(&names[..6], &["v0", "v1", "v2", "v3", "v4", "v0-v1.1"]);
        let walk = Walk {
            arc: a.clone(),
            source: "frames".into(),
            frames: vec![],
            between: between.clone(),
            probes: vec![],
        };
        for (v, view) in views.iter().enumerate() {
            let e = view.camera.eye;
            let d = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
            let az = e[1].atan2(e[0]).to_degrees();
            let el = (e[2] / d).asin().to_degrees();
            let want = a.azimuth_at(walk.position(v));
            assert!((d - 300.0).abs() < 1e-9, "view {v}: distance {d}");
            assert!((el - 40.0).abs() < 1e-9, "view {v}: elevation {el}");
            assert!((az - want).abs() < 1e-9, "view {v}: azimuth {az}, want {want}");
        }
        // The design views span the arc about its centre, 15 degrees apart.
        assert!((a.azimuth_at(0.0) - (-20.0)).abs() < 1e-12);
        assert!((a.azimuth_at(4.0) - 40.0).abs() < 1e-12);
        assert!((a.step_deg() - 15.0).abs() < 1e-12);
        // In arc order, azimuths grow and design view k sits between its in-between views.
        let order = walk.arc_order();
        let az: Vec<f64> = order.iter().map(|&v| a.azimuth_at(walk.position(v))).collect();
        assert!(az.windows(2).all(|p| p[1] > p[0]), "{az:?}");
        assert_eq!(order[0], 0);
        assert_eq!(order[3], 1);
        assert!(between.iter().all(|b| b.t > 0.0 && b.t < 1.0));
    }

    /// Along a walk a picture stays on the same part of the plate: its rectangle moves by a
    /// fraction of a pixel per half degree, also where the view passes the symmetric one (the
    /// largest rectangle of a near-symmetric silhouette jumps there from one end to the other).
    #[test]
    fn a_walks_pictures_move_smoothly_along_the_arc() {
        let light = crate::scenes::orbit_light(300.0, 65.0, 0.0, 1e4);
        let a = arc(3, 0);
        let centre = |az: f64| {
            let mut a = a.clone();
            a.res = 64;
            let v = arc_view("x".into(), &a, az, 100.0, &light);
            let f = fit_picture_walk(&[1.0; 4], 2, 2, &v, 100.0, Fit::Contain, 0.0);
            let r = f.rect.expect("a rectangle");
            (r.x0 + 0.5 * r.w, r.y0 + 0.5 * r.h, r.w)
        };
        let mut last = centre(-6.0);
        for i in -11..=12 {
            let now = centre(0.5 * i as f64);
            let moved = (now.0 - last.0).hypot(now.1 - last.1);
            assert!(moved < 1.0, "at {} deg the picture moved {moved} px", 0.5 * i as f64);
            assert!(
                now.2 > 30.0,
                "at {} deg the picture is {} px wide",
                0.5 * i as f64,
                now.2
            );
            last = now;
        }
    }

    #[test]
    fn a_bad_arc_is_refused_with_its_flag() {
        let mut a = arc(5, 1);
        a.arc_deg = 0.0;
        assert!(a.check().unwrap_err().contains("--arc"));
        let mut a = arc(1, 1);
        a.arc_deg = 30.0;
        assert!(a.check().unwrap_err().contains("at least 2 views"));
        let mut a = arc(3, 1);
        a.elevation_deg = 95.0;
        assert!(a.check().unwrap_err().contains("--elevation"));
        assert_eq!(WalkArc::default_views(30.0), 7);
        assert_eq!(WalkArc::default_views(1.0), 2);
    }

    /// An in-between view's target is the cross-fade of its neighbours' frames, each placed in
    /// the in-between view itself.
    #[test]
    fn an_in_between_target_is_the_cross_fade_of_its_neighbours() {
        let a = arc(3, 1);
        let light = crate::scenes::orbit_light(300.0, 60.0, 10.0, 1e4);
        let (views, between) = arc_views(&a, 100.0, &light);
        let scene = Scene {
            plate: crate::model::scene::Plate {
                size_mm: 100.0,
                roughness: crate::model::scene::DEFAULT_ROUGHNESS,
                f0: crate::model::scene::DEFAULT_F0,
            },
            views,
            scratches: vec![],
        };
        let pic = |v: f32| Picture {
            path: PathBuf::from("p.png"),
            width: 4,
            height: 4,
            data: vec![v; 16],
        };
        let walk = Walk {
            arc: a,
            source: "frames".into(),
            frames: vec![],
            between,
            probes: vec![],
        };
        let frames = Frames::Pictures(vec![pic(0.2), pic(1.0), pic(0.6)]);
        let t = walk_targets(&scene, &walk, &frames, Fit::Contain, 0.0, 1.0);
        assert_eq!(t.len(), 5);
        for (v, want) in [(0, 0.2f32), (1, 1.0), (2, 0.6), (3, 0.6), (4, 0.8)] {
            let vals: Vec<f32> = t[v]
                .image
                .iter()
                .zip(&t[v].picture)
                .filter(|(_, p)| **p)
                .map(|(x, _)| *x)
                .collect();
            assert!(vals.len() > 100, "view {v}: {} picture pixels", vals.len());
            // Interior pixels carry the blend; edge pixels are partly covered.
            let mut sorted = vals.clone();
            sorted.sort_by(f32::total_cmp);
            let median = sorted[sorted.len() / 2];
            assert!((median - want).abs() < 1e-4, "view {v}: median {median}, want {want}");
        }
    }
}
