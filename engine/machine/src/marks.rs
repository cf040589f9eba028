//! The marks `scratchart-cal plan` carves after a design's scratches, and the design's job time
//! with them.
//!
//! - The registration marks: the calibration card's six hatched squares ([`Mark`]), placed in
//!   the plate's corners ([`plate_marks`]) and hatched at the orientations that glint in the
//!   design's views ([`glint_orientations_spread`]), by which `scratchart-cal inspect` finds the
//!   carved plate in photos. Each hatch line is one block, `; mark corner -x -y hatch 3`
//!   ([`PlateMarks::blocks`]). The calibration card (`scratchart-cal card`) carves the same
//!   squares in its margin.
//! - The +x orientation mark ([`crate::plan::orientation_mark`]), kept clear of the design's
//!   scratches and of the registration marks' hatches.
//!
//! [`after_scratches`] gives both as `plan` carves them, and [`design_job_time`] times the design
//! with them: `plan` and the design's job time (`scratchart design --machine`, its summary and
//! `--max-job-min`) use the same code.
use scratchart_model::scene::{LightKind, View};
use scratchart_tool::machine::MachineProfile;
use serde::{Deserialize, Serialize};

use crate::plan::{self, Block, Cut, Label, TimeSplit};

/// A straight cut of a hatch: its two ends on the plate (mm, the plate centre the origin).
pub type Segment = ([f64; 2], [f64; 2]);

/// A fiducial mark: a square of the plate, `half_mm` either side of `centre`, densely hatched
/// with parallel cuts at the orientations that glint under the capture lamps. In the dark-field
/// capture views the flat plate is dark and a cut shows only where its walls face the
/// half-vector; a single cross (the first cards' marks) then shows one faint arm or nothing. A
/// hatched square shows a bright filled square in every capture view, also with the camera 20
/// degrees off (the card's hatches cover the glinting orientation +- 15 degrees), bright enough
/// to be found through blur, noise and JPEG, and its centre is the centroid of its light. Six
/// marks (four corners and two in the margin at places no rotation of the plate maps onto
/// another mark) fix the plate's orientation, and any four of them still give the camera when
/// one is covered. The calibration card's card.json lists its marks in this form.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mark {
    pub label: String,
    pub centre: [f64; 2],
    pub half_mm: f64,
}

/// A plate's marks are this fraction of the card's size (squares of 3% of the plate a side):
/// they glint in the pictures' corners, and at the card's size the six of them took 0.032 from
/// the worst view's correlation with its picture on a 100 mm, three-view design (0.793 without
/// marks, 0.761 with), at half the size 0.009 (0.784). A 12 MP photo still shows them tens of
/// pixels wide.
const PLATE_MARK_SIZE: f64 = 0.5;

/// Half the side of a mark, as a fraction of the plate (2.1 mm on the 70 mm card).
const MARK_HALF: f64 = 0.03;
/// Hatch lines across a mark per orientation (0.42 mm apart on the 70 mm card).
const MARK_LINES: f64 = 10.0;

/// The six marks' labels, in [`Mark::layout`]'s order. Static, so that a plan's blocks can carry
/// them (`; mark corner -x -y hatch 3`, [`Label::Registration`]).
pub const MARK_LABELS: [&str; 6] = [
    "corner -x -y",
    "corner +x -y",
    "corner +x +y",
    "corner -x +y",
    "key top edge",
    "key right edge",
];

impl Mark {
    /// The six marks of a plate of `plate_mm` whose margin (outside the card's ladder) is
    /// `margin_mm` wide: four corners, one on the top edge left of centre and one on the right
    /// edge below centre. Turned by 90, 180 or 270 degrees, the two keys land at least 0.3 of the
    /// marks' spacing from any mark, so a wrong rotation matches at most four of the six.
    pub fn layout(plate_mm: f64, margin_mm: f64) -> Vec<Mark> {
        let f = 0.5 * plate_mm - 0.5 * margin_mm;
        let half = MARK_HALF * plate_mm;
        let m = |label: &str, x: f64, y: f64| Mark {
            label: label.into(),
            centre: [x * f, y * f],
            half_mm: half,
        };
        let [a, b, c, d, top, right] = MARK_LABELS;
        vec![
            m(a, -1.0, -1.0),
            m(b, 1.0, -1.0),
            m(c, 1.0, 1.0),
            m(d, -1.0, 1.0),
            m(top, -0.7, 1.0),
            m(right, 1.0, -0.35),
        ]
    }

    /// The mark's hatch: for each orientation (degrees), parallel cuts across the square
    /// `MARK_LINES` to a side ([`Mark::hatch_spacing_mm`] apart), clipped to it, in the
    /// orientations' order and across each from -n to +n.
    pub fn hatch(&self, orientations_deg: &[f64]) -> Vec<Segment> {
        let h = self.half_mm;
        let spacing = self.hatch_spacing_mm();
        let mut cuts = Vec::new();
        for &deg in orientations_deg {
            let a = deg.to_radians();
            let (t, n) = ([a.cos(), a.sin()], [-a.sin(), a.cos()]);
            // Offsets along n that cross the square: |c| < h (|n.x| + |n.y|).
            let reach = h * (n[0].abs() + n[1].abs());
            let k_max = (reach / spacing).floor() as i64;
            for k in -k_max..=k_max {
                let c = k as f64 * spacing;
                // Points c n + s t inside the square: intersect the s-intervals of both axes.
                let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
                for ax in 0..2 {
                    let base = c * n[ax];
                    if t[ax].abs() < 1e-12 {
                        if base.abs() > h {
                            lo = f64::INFINITY;
                        }
                        continue;
                    }
                    let (s0, s1) = ((-h - base) / t[ax], (h - base) / t[ax]);
                    lo = lo.max(s0.min(s1));
                    hi = hi.min(s0.max(s1));
                }
                if hi - lo < 0.3 * h {
                    continue;
                }
                let p = |s: f64| {
                    [
                        self.centre[0] + c * n[0] + s * t[0],
                        self.centre[1] + c * n[1] + s * t[1],
                    ]
                };
                cuts.push((p(lo), p(hi)));
            }
        }
        cuts
    }

    /// The distance between neighbouring hatch lines of one orientation, mm.
    pub fn hatch_spacing_mm(&self) -> f64 {
        2.0 * self.half_mm / MARK_LINES
    }

    /// Whether plate point `q` lies within `pad_mm` of the mark's square.
    pub fn covers(&self, q: [f64; 2], pad_mm: f64) -> bool {
        let r = self.half_mm + pad_mm;
        (q[0] - self.centre[0]).abs() <= r && (q[1] - self.centre[1]).abs() <= r
    }

    /// Whether the segment from `a` to `b` (plate mm) meets the mark's square (its border
    /// included): the segment clipped to the square's slabs, axis by axis, is not empty.
    pub fn crossed_by(&self, a: [f64; 2], b: [f64; 2]) -> bool {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for ax in 0..2 {
            let (p, d) = (a[ax] - self.centre[ax], b[ax] - a[ax]);
            if d.abs() < 1e-15 {
                if p.abs() > self.half_mm {
                    return false;
                }
                continue;
            }
            let (t0, t1) = ((-self.half_mm - p) / d, (self.half_mm - p) / d);
            lo = lo.max(t0.min(t1));
            hi = hi.min(t0.max(t1));
        }
        lo <= hi
    }
}

/// The registration marks of a design's plate ([`plate_marks`]): the card's six marks, placed in
/// the plate's corners, and the orientations their hatches are cut at.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlateMarks {
    pub marks: Vec<Mark>,
    /// Degrees, in [0, 180): those that glint at the plate's centre in the design's views.
    pub orientations_deg: Vec<f64>,
}

/// How far the registration marks of a design's plate keep inside its edges, mm: 2% of the
/// plate, at least 0.5 mm (0.8 mm on a 40 mm plate, 2 mm on a 100 mm one).
pub fn plate_mark_inset_mm(plate_mm: f64) -> f64 {
    (0.02 * plate_mm).max(0.5)
}

/// The registration marks every plan of a design carves (`scratchart-cal plan`), by which
/// `scratchart-cal inspect` finds the plate in photos: [`Mark::layout`]'s six marks (squares of
/// 3% of the plate a side, [`PLATE_MARK_SIZE`]: 1.2 mm on a 40 mm plate, 3 mm on a 100 mm one) with the margin chosen
/// so that each square's outer edges lie [`plate_mark_inset_mm`] inside the plate's edges (2%
/// of the plate, at least 0.5 mm): as far into the corners as a deburred edge allows, so that
/// they take as little of the pictures as the card's layout can. Their hatches run at the
/// orientations that glint at the plate's centre in `views` ([`glint_orientations_spread`]), so
/// that each mark shows from each of the design's views. A function of the plate's size and
/// the views alone: `inspect` calls it with the design's to know where the marks are.
pub fn plate_marks(plate_mm: f64, views: &[View]) -> PlateMarks {
    let half = PLATE_MARK_SIZE * MARK_HALF * plate_mm;
    let margin = 2.0 * (half + plate_mark_inset_mm(plate_mm));
    let mut marks = Mark::layout(plate_mm, margin);
    for m in &mut marks {
        m.half_mm = half;
    }
    PlateMarks {
        marks,
        // Each view's own orientation only: a plate is photographed from its views (the card's
        // +-15 degrees serve a hand-held camera up to 20 degrees off its capture pose), and every
        // orientation more costs the job a hatch per mark (on a 100 mm plate, three views: 654
        // hatch cuts and 15 min with the spread, a third of that without).
        orientations_deg: glint_orientations_spread(views, &[0.0]),
    }
}

impl PlateMarks {
    /// Each mark's hatch ([`Mark::hatch`]), in the marks' order.
    pub fn hatches(&self) -> Vec<Vec<Segment>> {
        self.marks.iter().map(|m| m.hatch(&self.orientations_deg)).collect()
    }

    /// How many hatch cuts the marks take, all together.
    pub fn hatch_cuts(&self) -> usize {
        self.hatches().iter().map(Vec::len).sum()
    }

    /// Whether the path through `points` (plate mm) meets any mark's square.
    pub fn crossed_by(&self, points: &[[f64; 2]]) -> bool {
        let segments = points.windows(2);
        segments
            .into_iter()
            .any(|s| self.marks.iter().any(|m| m.crossed_by(s[0], s[1])))
    }

    /// The hatches as `plan` carves them, at commanded depth `z_mm`, the tool at `at` (plate mm)
    /// before them: one block per hatch line, labelled `mark LABEL hatch K`
    /// ([`Label::Registration`]), the marks round the plate's centre (by angle) starting with the
    /// one nearest `at`; in each, its lines in the hatch's order, each cut from its end nearer
    /// the tool.
    ///
    /// # Panics
    ///
    /// When a mark's label is not one of [`MARK_LABELS`] ([`plate_marks`]' always are).
    pub fn blocks(&self, z_mm: f64, at: [f64; 2]) -> Vec<Block> {
        let hatches = self.hatches();
        let n = self.marks.len();
        let angle = |i: usize| self.marks[i].centre[1].atan2(self.marks[i].centre[0]);
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&i, &j| angle(i).total_cmp(&angle(j)));
        let dist = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
        let start = (0..n)
            .min_by(|&i, &j| dist(self.marks[order[i]].centre, at).total_cmp(&dist(self.marks[order[j]].centre, at)))
            .unwrap_or(0);
        order.rotate_left(start);
        let mut at = at;
        let mut out = Vec::new();
        for i in order {
            let mark = MARK_LABELS
                .iter()
                .copied()
                .find(|l| *l == self.marks[i].label)
                .expect("a plate's marks are the layout's");
            for (k, &(p0, p1)) in hatches[i].iter().enumerate() {
                let (a, b) = if dist(p1, at) < dist(p0, at) {
                    (p1, p0)
                } else {
                    (p0, p1)
                };
                out.push(Block {
                    label: Label::Registration { mark, line: k },
                    path: vec![[a[0], a[1], -z_mm], [b[0], b[1], -z_mm]],
                    bulge: 0.0,
                });
                at = b;
            }
        }
        out
    }
}

/// The cut orientations (degrees, in [0, 180), to 0.1 degree) that glint at the plate's centre
/// (the origin) in `views`: each view's, and those `spread` degrees from it, in the views'
/// order, orientations within 5 degrees of one already taken left out. A cut shows where its
/// walls face the half-vector h of the camera and the lamp, i.e. when it runs across h's
/// horizontal direction. A view whose h is (within 0.06 degree) vertical, its camera seeing the
/// lamp's reflection in the plate, has no such direction: every groove then shows dark on the
/// bright plate, and it takes 0 and 90 degrees (a cross-hatch), as do no views at all. (The
/// calibration card spreads each view's by +- 15 degrees, a design's plate not at all.)
pub fn glint_orientations_spread(views: &[View], spread: &[f64]) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::new();
    let mut add = |a: f64| {
        let a = a.rem_euclid(180.0);
        if !out.iter().any(|b| {
            let diff = (a - b).rem_euclid(180.0);
            diff.min(180.0 - diff) < 5.0
        }) {
            out.push((a * 10.0).round() / 10.0);
        }
    };
    let norm = |p: [f64; 3]| {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        [p[0] / l, p[1] / l, p[2] / l]
    };
    let mut level = views.is_empty();
    for v in views {
        let o = norm(v.camera.eye);
        let i = match v.light.kind {
            LightKind::Point { position } => norm(position),
            LightKind::Directional { direction } => norm(direction),
        };
        let h = [o[0] + i[0], o[1] + i[1], o[2] + i[2]];
        if h[0].hypot(h[1]) <= 1e-3 * h[2].abs() {
            level = true;
            continue;
        }
        let across = h[1].atan2(h[0]).to_degrees() + 90.0;
        for d in spread {
            add(across + d);
        }
    }
    if level {
        add(0.0);
        add(90.0);
    }
    out
}

/// Which of the marks `plan` carves after the scratches: by default both; `plan --no-mark`
/// leaves out the +x orientation mark, `--no-marks` the registration marks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Which {
    pub orientation: bool,
    pub registration: bool,
}

impl Which {
    /// Both, as `plan` carves them by default.
    pub const ALL: Which = Which {
        orientation: true,
        registration: true,
    };
}

/// The marks `plan` carves after a design's scratches ([`after_scratches`]).
#[derive(Clone, Debug, PartialEq)]
pub struct AfterScratches {
    /// The +x orientation mark, unless left out.
    pub orientation: Option<plan::Mark>,
    /// The registration marks, unless left out.
    pub registration: Option<PlateMarks>,
    /// Their blocks in cut order: the +x mark's, then the hatch lines' ([`PlateMarks::blocks`]).
    pub blocks: Vec<Block>,
}

impl AfterScratches {
    /// How many hatch cuts of the registration marks there are (0 without them).
    pub fn hatch_cuts(&self) -> usize {
        self.blocks
            .iter()
            .filter(|b| matches!(b.label, Label::Registration { .. }))
            .count()
    }
}

/// The marks `plan` carves after the design's `cuts` (in the design's order; `widths`: each one's
/// visible groove width, `scratchart_machine::export::visible_width`) on a plate of `plate_mm`
/// seen from `views`, all at commanded depth `depth` (the design's deepest), the tool at `at`
/// after the scratches (the end of the last one cut, or the work zero): first the +x orientation
/// mark ([`plan::orientation_mark`]), [`plan::MARK_CLEAR_MM`] clear of the scratches and of the
/// registration marks' hatches (as wide as the widest groove: they are cut to the deepest
/// depth); then the registration marks ([`plate_marks`], [`PlateMarks::blocks`]) from where the
/// tool is then. `which` leaves either out.
pub fn after_scratches(
    cuts: &[Cut],
    widths: &[f64],
    plate_mm: f64,
    views: &[View],
    depth: f64,
    at: [f64; 2],
    which: Which,
) -> AfterScratches {
    let registration = which.registration.then(|| plate_marks(plate_mm, views));
    let mut blocks = Vec::new();
    let orientation = which.orientation.then(|| {
        let mut sc = plan::mark_segments(cuts, widths);
        let widest = widths.iter().cloned().fold(0.0f64, f64::max);
        let hatches = registration.as_ref().map(PlateMarks::hatches).unwrap_or_default();
        sc.extend(hatches.iter().flatten().map(|&(a, b)| (a, b, widest)));
        plan::orientation_mark(&sc, plate_mm, depth, plan::MARK_CLEAR_MM)
    });
    let mut at = at;
    if let Some(mk) = &orientation {
        blocks.push(mk.block());
        at = mk.b;
    }
    if let Some(reg) = &registration {
        blocks.extend(reg.blocks(depth, at));
    }
    AfterScratches {
        orientation,
        registration,
        blocks,
    }
}

/// The registration marks' part of the planner's estimate of a program, s: its time less that of
/// the same program without their blocks (0 without them).
pub fn registration_time(blocks: &[Block], m: &MachineProfile) -> f64 {
    match without_registration(blocks) {
        None => 0.0,
        Some(rest) => (plan::program_time(blocks, m) - plan::program_time(&rest, m)).max(0.0),
    }
}

/// `blocks` without the registration marks' blocks; None when it has none.
fn without_registration(blocks: &[Block]) -> Option<Vec<Block>> {
    let rest: Vec<Block> = blocks
        .iter()
        .filter(|b| !matches!(b.label, Label::Registration { .. }))
        .cloned()
        .collect();
    (rest.len() < blocks.len()).then_some(rest)
}

/// A design's job time as `plan` makes it by default ([`design_job_time`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JobTime {
    /// The planner's estimate, split by what the machine does.
    pub split: TimeSplit,
    /// The move-by-move sum from rest to rest ([`plan::program_time_rest_to_rest`]), s: an upper
    /// bound of the estimate.
    pub upper_s: f64,
    /// The registration marks' part of the estimate, s ([`registration_time`]).
    pub registration_s: f64,
    /// Their part of the upper bound, s.
    pub registration_upper_s: f64,
    /// The registration marks' hatch cuts.
    pub hatch_cuts: usize,
}

/// The job time of a design's cuts (`widths`: each one's visible groove width) on a plate of
/// `plate_mm` seen from `views`, as `plan` makes it by default: the cuts ordered (nearest
/// neighbour, then 2-opt), then the +x mark and the registration marks at the deepest cut's
/// depth ([`after_scratches`]), no levelling. `plan --no-marks` (or `--no-mark`) makes a shorter
/// job.
pub fn design_job_time(cuts: &[Cut], widths: &[f64], plate_mm: f64, views: &[View], m: &MachineProfile) -> JobTime {
    let ordered = plan::two_opt(plan::nearest_neighbour(cuts), 200);
    let mut blocks: Vec<Block> = ordered.iter().map(Block::flat).collect();
    let at = ordered.last().map_or([0.0, 0.0], |c| c.b);
    let deepest = cuts.iter().map(|c| c.z).fold(0.0f64, f64::max);
    let after = after_scratches(cuts, widths, plate_mm, views, deepest, at, Which::ALL);
    let hatch_cuts = after.hatch_cuts();
    blocks.extend(after.blocks);
    let (split, upper_s) = (
        plan::program_time_split(&blocks, m),
        plan::program_time_rest_to_rest(&blocks, m),
    );
    let (registration_s, registration_upper_s) = match without_registration(&blocks) {
        None => (0.0, 0.0),
        Some(rest) => (
            (split.total() - plan::program_time(&rest, m)).max(0.0),
            (upper_s - plan::program_time_rest_to_rest(&rest, m)).max(0.0),
        ),
    };
    JobTime {
        split,
        upper_s,
        registration_s,
        registration_upper_s,
        hatch_cuts,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scratchart_model::scene::{Camera, Light, Scene};

    /// A view from azimuth `az` at 50 degrees elevation, its lamp a quarter turn round and lower
    /// (the calibration card's capture views).
    fn oblique(az: f64) -> View {
        let place = |az: f64, el: f64| scratchart_model::camera::spherical(280.0, az, el);
        View {
            exposure: 1.0,
            name: format!("v{az}"),
            camera: Camera {
                eye: place(az, 50.0),
                target: [0.0; 3],
                up: [0.0, 0.0, 1.0],
                fov_y_deg: 20.0,
                width: 8,
                height: 8,
            },
            light: Light {
                kind: LightKind::Point {
                    position: place(az + 90.0, 35.0),
                },
                intensity: 1.0,
            },
        }
    }

    /// Each mark square wholly on the plate, its outer edges 2% of the plate (at least 0.5 mm)
    /// inside the plate's edges, hatched at the views' glinting orientations and only inside its
    /// square; the same plate and views give the same marks.
    #[test]
    fn plate_marks_sit_in_the_corners_inside_the_edges() {
        let views = [oblique(-90.0), oblique(180.0)];
        for plate in [10.0, 40.0, 70.0, 100.0, 300.0] {
            let pm = plate_marks(plate, &views);
            assert_eq!(pm, plate_marks(plate, &views), "deterministic");
            assert_eq!(pm.orientations_deg, glint_orientations_spread(&views, &[0.0]));
            assert_eq!(pm.orientations_deg.len(), 2, "{:?}", pm.orientations_deg);
            let labels: Vec<&str> = pm.marks.iter().map(|m| m.label.as_str()).collect();
            assert_eq!(labels, MARK_LABELS);
            let inset = (0.02 * plate).max(0.5);
            let hatches = pm.hatches();
            assert_eq!(pm.hatch_cuts(), hatches.iter().map(Vec::len).sum::<usize>());
            for (m, hatch) in pm.marks.iter().zip(hatches) {
                let edge = 0.5 * plate - m.centre[0].abs().max(m.centre[1].abs()) - m.half_mm;
                assert!(
                    edge >= 0.5 - 1e-12 && (edge - inset).abs() < 1e-9 * plate,
                    "{plate}: {m:?}"
                );
                assert!(hatch.len() >= 10, "{plate}: {}", m.label);
                assert!(hatch.iter().all(|&(a, b)| m.covers(a, 1e-9) && m.covers(b, 1e-9)));
            }
        }
        let (small, big) = (plate_marks(40.0, &views), plate_marks(100.0, &views));
        // Squares of 3% of the plate a side, their outer edges at the inset.
        assert!((small.marks[0].half_mm - 0.6).abs() < 1e-12 && (small.marks[0].centre[0] + 18.6).abs() < 1e-12);
        assert!((big.marks[0].half_mm - 1.5).abs() < 1e-12 && (big.marks[0].centre[0] + 46.5).abs() < 1e-12);
    }

    /// A view takes its orientation and those `spread` from it; a view that sees the lamp's
    /// reflection in the plate, and no view at all, take a cross-hatch.
    #[test]
    fn glint_orientations_follow_the_views() {
        let v = [oblique(-90.0)];
        let one = glint_orientations_spread(&v, &[0.0]);
        let three = glint_orientations_spread(&v, &[-15.0, 0.0, 15.0]);
        assert_eq!(one.len(), 1);
        assert_eq!(three.len(), 3);
        assert_eq!(three[1], one[0]);
        let level = Scene::bare(50.0, vec![]).views;
        assert_eq!(glint_orientations_spread(&level, &[0.0]), vec![0.0, 90.0]);
        assert_eq!(glint_orientations_spread(&[], &[0.0]), vec![0.0, 90.0]);
        // A directional lamp is read as the direction towards it, as a point lamp's position.
        let mut dir = v[0].clone();
        if let LightKind::Point { position } = dir.light.kind {
            dir.light.kind = LightKind::Directional { direction: position };
        }
        assert_eq!(glint_orientations_spread(&[dir], &[0.0]), one);
    }

    #[test]
    fn a_segment_crosses_a_mark_where_it_meets_its_square() {
        let m = Mark {
            label: "m".into(),
            centre: [10.0, 10.0],
            half_mm: 1.0,
        };
        assert!(m.crossed_by([0.0, 10.0], [20.0, 10.0]), "straight through");
        assert!(m.crossed_by([10.0, 10.0], [10.2, 10.1]), "inside");
        assert!(m.crossed_by([8.0, 10.0], [10.0, 12.0]), "across a corner");
        assert!(!m.crossed_by([8.0, 10.5], [9.5, 12.0]), "past a corner");
        assert!(!m.crossed_by([0.0, 0.0], [20.0, 0.0]), "below");
        assert!(!m.crossed_by([0.0, 10.0], [8.9, 10.0]), "short of it");
        let pm = PlateMarks {
            marks: vec![m],
            orientations_deg: vec![],
        };
        assert!(pm.crossed_by(&[[0.0, 0.0], [0.0, 10.0], [20.0, 10.0]]));
    }

    /// Every hatch line once, at the depth, labelled by its mark and its place in the mark's cut
    /// order; the marks round the centre from the one nearest the tool; each line from its end
    /// nearer the tool.
    #[test]
    fn the_blocks_cut_each_hatch_line_once_mark_by_mark() {
        let pm = plate_marks(60.0, &[oblique(-90.0), oblique(180.0)]);
        let hatches = pm.hatches();
        let at = [25.0, 20.0];
        let blocks = pm.blocks(0.03, at);
        assert_eq!(blocks.len(), pm.hatch_cuts());
        let mut seen: Vec<&str> = Vec::new();
        let mut tool = at;
        let d = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
        for b in &blocks {
            let Label::Registration { mark, line } = b.label else {
                panic!("{}", b.label)
            };
            if seen.last() != Some(&mark) {
                assert!(!seen.contains(&mark), "{mark} cut twice");
                seen.push(mark);
            }
            let i = MARK_LABELS.iter().position(|l| *l == mark).unwrap();
            let (p0, p1) = hatches[i][line];
            let (a, e) = ([b.path[0][0], b.path[0][1]], [b.path[1][0], b.path[1][1]]);
            assert!((a, e) == (p0, p1) || (a, e) == (p1, p0), "{}", b.label);
            assert!(d(a, tool) <= d(e, tool), "{}: from its nearer end", b.label);
            assert!(b.path.iter().all(|p| p[2] == -0.03) && b.bulge == 0.0);
            tool = e;
        }
        assert_eq!(seen.len(), 6);
        assert_eq!(seen[0], "corner +x +y", "the mark nearest the tool first");
        let angle = |l: &str| {
            let c = pm.marks.iter().find(|m| m.label == l).unwrap().centre;
            c[1].atan2(c[0])
        };
        let turns: Vec<f64> = seen.iter().map(|l| angle(l)).collect();
        assert_eq!(
            turns.windows(2).filter(|w| w[1] < w[0]).count(),
            1,
            "once round the centre: {seen:?}"
        );
    }

    /// The +x mark keeps clear of the hatches as of the scratches, the registration marks
    /// follow it, and the design's job time is the program's of the ordered cuts and these
    /// blocks, with the marks' share.
    #[test]
    fn the_design_job_time_carves_the_marks_as_plan_does() {
        let m = MachineProfile::grbl();
        let views = [oblique(-90.0)];
        let cut = |k: usize, a: [f64; 2], b: [f64; 2], z: f64| Cut {
            a,
            b,
            z,
            scratch: k,
            bulge: 0.0,
        };
        let cuts = vec![
            cut(0, [-10.0, -5.0], [10.0, 5.0], 0.02),
            cut(1, [-10.0, 5.0], [5.0, -8.0], 0.04),
        ];
        let widths = [0.05, 0.07];
        let after = after_scratches(&cuts, &widths, 40.0, &views, 0.04, [5.0, -8.0], Which::ALL);
        let mk = after.orientation.expect("the +x mark");
        let reg = after.registration.clone().expect("the registration marks");
        assert_eq!(after.blocks[0], mk.block());
        assert_eq!(after.blocks[1..], reg.blocks(0.04, mk.b));
        assert_eq!(after.hatch_cuts(), reg.hatch_cuts());
        let mut sc = plan::mark_segments(&cuts, &widths);
        sc.extend(reg.hatches().iter().flatten().map(|&(a, b)| (a, b, 0.07)));
        assert_eq!(mk, plan::orientation_mark(&sc, 40.0, 0.04, plan::MARK_CLEAR_MM));
        // Each left out on its own.
        let none = Which {
            orientation: false,
            registration: false,
        };
        assert!(after_scratches(&cuts, &widths, 40.0, &views, 0.04, [0.0; 2], none)
            .blocks
            .is_empty());
        let reg_only = Which {
            orientation: false,
            registration: true,
        };
        let r = after_scratches(&cuts, &widths, 40.0, &views, 0.04, [5.0, -8.0], reg_only);
        assert_eq!(r.blocks, reg.blocks(0.04, [5.0, -8.0]));
        // The job time.
        let t = design_job_time(&cuts, &widths, 40.0, &views, &m);
        let ordered = plan::two_opt(plan::nearest_neighbour(&cuts), 200);
        let mut blocks: Vec<Block> = ordered.iter().map(Block::flat).collect();
        let at = ordered.last().unwrap().b;
        blocks.extend(after_scratches(&cuts, &widths, 40.0, &views, 0.04, at, Which::ALL).blocks);
        assert_eq!(t.split, plan::program_time_split(&blocks, &m));
        assert_eq!(t.upper_s, plan::program_time_rest_to_rest(&blocks, &m));
        assert_eq!(t.hatch_cuts, reg.hatch_cuts());
        assert_eq!(t.registration_s, registration_time(&blocks, &m));
        let without: Vec<Block> = blocks[..ordered.len() + 1].to_vec();
        let bare = plan::program_time(&without, &m);
        assert!((t.split.total() - t.registration_s - bare).abs() < 1e-9);
        assert!(t.registration_s > 0.5 * bare, "{t:?}: {bare} s without the marks");
        assert!(t.upper_s >= t.split.total() && t.registration_upper_s > 0.0);
        assert_eq!(registration_time(&without, &m), 0.0);
    }
}
