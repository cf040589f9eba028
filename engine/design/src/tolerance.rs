//! How far the lamp and each eye may move: every view rendered with the lamp or the eye moved
//! in azimuth, elevation and distance, both ways, and a search (outwards on a grid, then by
//! bisection) for how far each keeps [`KEEP`] of the view's correlation with its picture, from
//! what the design wrote beside itself ([`SheetInputs`]); a lamp's or an eye's [`Place`] as a
//! maker measures it. The set-up sheet (`setup`, `setup_sheet`) states the results.
use serde_json::{json, Value};

use crate::measure::{blur3_within, correlation};
use scratchart_model::scene::{LightKind, Scene, View};
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
        // A point on the vertical axis (an overhead lamp) turns onto itself, not onto its
        // rounding error's circle.
        "azimuth" if p[0].hypot(p[1]) <= 1e-12 * q.distance_mm => p,
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
    /// The search steps (each renders its moves in batches).
    pub steps: usize,
    /// Wall seconds of the searches: in the engine's calls (uploads, renders, read-backs and
    /// the display conversion; [`SearchClock::engine_s`]) and the host's, with the round trips.
    pub clock: SearchClock,
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
    render_views_clocked(renderer, scene, views, masks, &mut SearchClock::default())
}

/// [`render_views`], its seconds and round trips added to `clock`.
fn render_views_clocked(
    renderer: &Renderer,
    scene: &Scene,
    views: Vec<View>,
    masks: &[&[bool]],
    clock: &mut SearchClock,
) -> Result<Vec<Vec<f32>>, OptimError> {
    let mut out = Vec::with_capacity(views.len());
    let batch = batch_views(renderer, scene, &views);
    let mut rec: Option<scratchart_vulkan::Recorder> = None;
    for (chunk, masks) in views.chunks(batch).zip(masks.chunks(batch)) {
        let mut batch = scene.clone();
        batch.views = chunk.to_vec();
        let windows: Vec<Option<TileWindow>> = chunk.iter().zip(masks).map(|(v, m)| mask_window(v, m)).collect();
        let mut gs = clock.time(|c| &mut c.upload_s, || renderer.upload_windowed(&batch, &windows))?;
        clock.uploads += 1;
        if rec.is_none() {
            rec = Some(scratchart_vulkan::Recorder::new(&renderer.ctx)?);
        }
        let rec = rec.as_mut().expect("made above");
        clock.time(|c| &mut c.render_s, || renderer.run(rec, &mut gs))?;
        clock.submissions += 1;
        let images = clock.time(|c| &mut c.read_s, || renderer.download_images(&gs).map(display_images))?;
        out.extend(images);
    }
    Ok(out)
}

/// Rendered images (linear) as display values in [0, 1], converted on all cores.
pub(crate) fn display_images(images: Vec<Vec<f32>>) -> Vec<Vec<f32>> {
    scratchart_model::par::par_map(images.len(), |k| {
        images[k]
            .iter()
            .map(|&l| scratchart_render::io::display_value(l).clamp(0.0, 1.0))
            .collect()
    })
}

/// The tiles of view `v` that hold the pixels of `mask` and the pixels next to them (None for
/// an empty mask: nothing there is compared).
fn mask_window(v: &View, mask: &[bool]) -> Option<TileWindow> {
    TileWindow::covering_mask(mask, v.camera.width, v.camera.height, 1, 1)
}

/// A view's picture as the designed view shows it, or as it appears from a moved eye (see
/// [`as_seen_from`]): its target (display values) and the pixels it covers.
type Picture = (Vec<f64>, Vec<bool>);

/// What a moved view's render depends on beside its view's scratches: the view, its lamp and its
/// eye (the bits of each coordinate). Two moves with one key render the same image.
type MoveKey = (usize, [u64; 6]);

fn move_key(j: usize, v: &View) -> MoveKey {
    let l = match v.light.kind {
        LightKind::Point { position } => position,
        LightKind::Directional { direction } => direction,
    };
    let e = v.camera.eye;
    (j, [l[0], l[1], l[2], e[0], e[1], e[2]].map(f64::to_bits))
}

/// The picture view `j` is compared with, as seen from `eye` (view j itself when None). A move
/// that only makes the picture larger, smaller or foreshortened is no loss; what the reflection
/// does there is.
fn picture_of(scene: &Scene, inputs: &SheetInputs, j: usize, eye: Option<&View>) -> Picture {
    match eye {
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
    }
}

/// View `j`'s render (display values), blurred as the loss blurs, against its picture.
fn corr_of(scene: &Scene, inputs: &SheetInputs, img: &[f32], j: usize, (t, m): &Picture) -> f64 {
    let (w, h) = (scene.views[j].camera.width, scene.views[j].camera.height);
    correlation(&blur3_within(img, w, h, inputs.sigma, m), t, m)
}

/// Each view's correlation with its picture as designed and, for every view that shows its
/// picture (and is not blank on purpose), how far the lamp and the eye may move in azimuth,
/// elevation and distance and keep [`KEEP`] of it: each found by search, outwards on a grid up
/// to [`ANGLE_RANGE`] and [`DISTANCE_RANGE`], then by bisection. All searches step together, one
/// batched render per step. Each move is rendered once: one that leaves its view as designed (an
/// overhead lamp turned in azimuth) or as an earlier step had it (an elevation held at its limit)
/// takes that render's correlation, the same bits (a render depends only on its view).
pub fn sensitivity(renderer: &Renderer, scene: &Scene, inputs: &SheetInputs) -> Result<Sensitivity, OptimError> {
    let designed: Vec<Picture> = (0..scene.views.len())
        .map(|j| picture_of(scene, inputs, j, None))
        .collect();
    let masks: Vec<&[bool]> = designed.iter().map(|(_, m)| m.as_slice()).collect();
    let mut clock = SearchClock::default();
    let images = render_views_clocked(renderer, scene, scene.views.clone(), &masks, &mut clock)?;
    let base: Vec<f64> = clock.time(
        |c| &mut c.measure_s,
        || scratchart_model::par::par_map(images.len(), |j| corr_of(scene, inputs, &images[j], j, &designed[j])),
    );
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
    let mut steps = 0;
    let mut lamps = lamp::LampRenders::default();
    let mut memo: std::collections::HashMap<MoveKey, f64> = (0..scene.views.len())
        .map(|j| (move_key(j, &scene.views[j]), base[j]))
        .collect();
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
        let keys: Vec<MoveKey> = step
            .iter()
            .zip(&views)
            .map(|(&(i, _), v)| move_key(searches[i].view, v))
            .collect();
        let mut fresh: Vec<usize> = Vec::new();
        for (k, key) in keys.iter().enumerate() {
            if !memo.contains_key(key) && !fresh.iter().any(|&f| keys[f] == *key) {
                fresh.push(k);
            }
        }
        let moves: Vec<Move> = fresh
            .iter()
            .map(|&k| Move {
                search: step[k].0,
                view: searches[step[k].0].view,
                lamp: searches[step[k].0].moved == "lamp",
                moved: views[k].clone(),
            })
            .collect();
        let corrs = render_moves(renderer, scene, inputs, &designed, &mut lamps, &moves, &mut clock)?;
        steps += 1;
        for (&k, corr) in fresh.iter().zip(corrs) {
            memo.insert(keys[k], corr);
        }
        for (&(i, size), key) in step.iter().zip(&keys) {
            let s = &mut searches[i];
            let corr = memo[key];
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
        steps,
        clock,
    })
}

/// One move of a search step to render: the search, its view, whether the lamp moved (else the
/// eye), and the view so moved.
struct Move {
    search: usize,
    view: usize,
    lamp: bool,
    moved: View,
}

/// Each move's correlation with its picture: the lamp moves rendered on their kept tile lists
/// ([`lamp`]), the eye moves binned afresh (their cameras move); the moved eyes' pictures and
/// every correlation computed on all cores. `clock` gains their seconds.
fn render_moves(
    renderer: &Renderer,
    scene: &Scene,
    inputs: &SheetInputs,
    designed: &[Picture],
    lamps: &mut lamp::LampRenders,
    moves: &[Move],
    clock: &mut SearchClock,
) -> Result<Vec<f64>, OptimError> {
    // (A moved lamp leaves the picture where it was: the designed view's, not copied.)
    let own = clock.time(
        |c| &mut c.pictures_s,
        || {
            scratchart_model::par::par_map(moves.len(), |k| {
                let m = &moves[k];
                (!m.lamp).then(|| picture_of(scene, inputs, m.view, Some(&m.moved)))
            })
        },
    );
    let pictures: Vec<&Picture> = moves
        .iter()
        .zip(&own)
        .map(|(m, own)| own.as_ref().unwrap_or(&designed[m.view]))
        .collect();
    let pick = |lamp: bool| -> Vec<usize> { (0..moves.len()).filter(|&k| moves[k].lamp == lamp).collect() };
    let (lamp_k, eye_k) = (pick(true), pick(false));
    let views_of = |ks: &[usize]| ks.iter().map(|&k| moves[k].moved.clone()).collect::<Vec<_>>();
    let masks_of = |ks: &[usize]| ks.iter().map(|&k| pictures[k].1.as_slice()).collect::<Vec<_>>();
    let searches: Vec<usize> = lamp_k.iter().map(|&k| moves[k].search).collect();
    let lamp_imgs = lamps.render(renderer, scene, &searches, views_of(&lamp_k), &masks_of(&lamp_k), clock)?;
    let eye_imgs = render_views_clocked(renderer, scene, views_of(&eye_k), &masks_of(&eye_k), clock)?;
    let mut images: Vec<Vec<f32>> = vec![Vec::new(); moves.len()];
    for (k, img) in lamp_k.into_iter().zip(lamp_imgs).chain(eye_k.into_iter().zip(eye_imgs)) {
        images[k] = img;
    }
    Ok(clock.time(
        |c| &mut c.measure_s,
        || {
            scratchart_model::par::par_map(moves.len(), |k| {
                corr_of(scene, inputs, &images[k], moves[k].view, pictures[k])
            })
        },
    ))
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

mod clock;
mod inputs;
mod lamp;

pub use clock::SearchClock;

pub use inputs::SheetInputs;

#[cfg(test)]
mod tests;
