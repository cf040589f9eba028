//! A carving plan: the order the scratches are cut in, the travel between them, the time the job
//! takes, and the bounds it must keep. Each scratch is one straight cut between its endpoints, in
//! either direction; a scratch that is an arc (a nonzero bulge, DXF's convention) is one G2 or G3
//! move with I and J, which the controller cuts into lines within its arc tolerance (GRBL's `$12`,
//! [`ARC_TOL_MM`] here for the job's time and bounds).
//!
//! Order: greedy nearest neighbour from the work zero, choosing each cut's direction, then 2-opt
//! (reversing a run of cuts also reverses each cut) until no improvement, with the partner search
//! limited to a window of the next 200 cuts so large designs stay fast.
//!
//! Time: the moves the G-code writer makes, as the controller's planner runs them
//! ([`crate::planner`]: GRBL's junction speeds, acceleration and lookahead). [`move_time`] is
//! one move from rest to rest, t(d) = d / v + v / a when d >= v^2 / a, else 2 sqrt(d / a): a
//! sum of those over the moves is the upper bound the tests hold the planner to. A design's job
//! time with the marks `scratchart-cal plan` carves after its scratches (the +x mark and the
//! registration marks) is [`crate::marks::design_job_time`].

use scratchart_tool::machine::{Firmware, MachineProfile};

/// Seconds the plan waits after starting the spindle (GRBL's `G4 P..`), for it to reach speed.
pub const SPINDLE_DWELL_S: f64 = 2.0;

/// One cut: from `a` to `b` (mm, work coordinates: the plate centre is the origin) at commanded
/// depth `z` (mm below the surface), and the index of its scratch in the design.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cut {
    pub a: [f64; 2],
    pub b: [f64; 2],
    pub z: f64,
    pub scratch: usize,
    /// 0: a straight cut; else an arc from `a` to `b` with this bulge (tan of a quarter of its
    /// included angle, positive counter-clockwise seen from +z: `scratchart_model::arc`).
    pub bulge: f64,
}

/// The arc tolerance the job's time and bounds assume, mm: GRBL's default `$12` (how far the
/// lines a controller cuts an arc into stray from it).
pub const ARC_TOL_MM: f64 = 0.002;

impl Cut {
    pub fn reversed(self) -> Cut {
        Cut {
            a: self.b,
            b: self.a,
            bulge: -self.bulge,
            ..self
        }
    }

    /// The points the cut passes through: its ends, and for an arc the points of the lines a
    /// controller cuts it into within `tol` (ends exact).
    pub fn points(&self, tol: f64) -> Vec<[f64; 2]> {
        arc_points(self.a, self.b, self.bulge, tol)
    }
}

/// `a` and `b`, and between them for an arc (`bulge` != 0) the points of its lines within `tol`.
pub fn arc_points(a: [f64; 2], b: [f64; 2], bulge: f64, tol: f64) -> Vec<[f64; 2]> {
    match scratchart_model::arc::ArcGeom::of(a, b, bulge) {
        None => vec![a, b],
        Some(g) => {
            let mut p = g.polyline(tol);
            let n = p.len();
            p[0] = a;
            p[n - 1] = b;
            p
        }
    }
}

fn dist(p: [f64; 2], q: [f64; 2]) -> f64 {
    (p[0] - q[0]).hypot(p[1] - q[1])
}

/// Rapid travel of a sequence starting and ending at the work zero, mm.
pub fn travel(cuts: &[Cut]) -> f64 {
    let mut at = [0.0, 0.0];
    let mut t = 0.0;
    for c in cuts {
        t += dist(at, c.a);
        at = c.b;
    }
    t + dist(at, [0.0, 0.0])
}

/// Greedy nearest neighbour from the work zero, each cut in its nearer direction.
pub fn nearest_neighbour(cuts: &[Cut]) -> Vec<Cut> {
    let mut left: Vec<Cut> = cuts.to_vec();
    let mut out = Vec::with_capacity(cuts.len());
    let mut at = [0.0, 0.0];
    while !left.is_empty() {
        let (mut best, mut rev, mut bd) = (0, false, f64::INFINITY);
        for (i, c) in left.iter().enumerate() {
            let (da, db) = (dist(at, c.a), dist(at, c.b));
            if da < bd {
                (best, rev, bd) = (i, false, da);
            }
            if db < bd {
                (best, rev, bd) = (i, true, db);
            }
        }
        let c = left.swap_remove(best);
        let c = if rev { c.reversed() } else { c };
        at = c.b;
        out.push(c);
    }
    out
}

/// 2-opt over the sequence (reversing runs of up to `window` cuts), until no move shortens it.
pub fn two_opt(mut seq: Vec<Cut>, window: usize) -> Vec<Cut> {
    let n = seq.len();
    let end_of = |s: &[Cut], i: usize| if i == 0 { [0.0, 0.0] } else { s[i - 1].b };
    let start_of = |s: &[Cut], j: usize| if j >= s.len() { [0.0, 0.0] } else { s[j].a };
    let mut improved = true;
    let mut rounds = 0;
    while improved && rounds < 50 {
        improved = false;
        rounds += 1;
        for i in 0..n {
            for j in i + 1..n.min(i + window) {
                // Reverse seq[i..=j]: edges (prev -> a_i) and (b_j -> next) become
                // (prev -> b_j) and (a_i -> next).
                let (p, q) = (end_of(&seq, i), start_of(&seq, j + 1));
                let before = dist(p, seq[i].a) + dist(seq[j].b, q);
                let after = dist(p, seq[j].b) + dist(seq[i].a, q);
                if after + 1e-9 < before {
                    seq[i..=j].reverse();
                    for c in &mut seq[i..=j] {
                        *c = c.reversed();
                    }
                    improved = true;
                }
            }
        }
    }
    seq
}

/// Seconds for a move of `d` mm at feed `v_mm_min` with acceleration `a` mm/s^2 (from and to rest).
pub fn move_time(d: f64, v_mm_min: f64, a: f64) -> f64 {
    if d <= 0.0 {
        return 0.0;
    }
    let v = v_mm_min / 60.0;
    if d >= v * v / a {
        d / v + v / a
    } else {
        2.0 * (d / a).sqrt()
    }
}

/// The job's time, s: for every cut the hop to its start, a plunge, the cut and a retract
/// ([`program_time`]).
pub fn job_time(cuts: &[Cut], m: &MachineProfile) -> f64 {
    let blocks: Vec<Block> = cuts.iter().map(Block::flat).collect();
    program_time(&blocks, m)
}

/// How the tool goes from one cut to the next: at the retract height between neighbouring cuts,
/// up to the clearance height for a travel longer than `long_travel_mm` (and from the start,
/// where the tool stands at the clearance height).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Hop {
    /// Rise from the retract to the clearance height before the travel.
    pub rise: bool,
    /// Go down from the clearance to the retract height (at the rapid rate) before the plunge.
    pub descend: bool,
}

impl Hop {
    /// From `at` (the tool at the clearance height when `high`, else at the retract height) to a
    /// cut starting at `to`.
    pub fn of(m: &MachineProfile, at: [f64; 2], to: [f64; 2], high: bool) -> Hop {
        let long = dist(at, to) > m.long_travel_mm;
        Hop {
            rise: long && !high,
            descend: long || high,
        }
    }
}

/// The time of a program of blocks, s, as the G-code writer moves and the controller's planner
/// runs it: for every block the hop to it ([`Hop`]: a rise to the clearance height, the rapid,
/// the way down to the retract height), the plunge from the retract height, each of its G1
/// moves at the cut feed, and the retract; at the end the rise to the clearance height and the
/// rapid home. Z moves outside the plate are rapids
/// on GRBL and at the Z feed `plunge_mm_min` on Marlin, where every Z move is made at the printer's
/// Z feed.
pub fn program_time(blocks: &[Block], m: &MachineProfile) -> f64 {
    program_time_split(blocks, m).total()
}

/// Where a job's time goes, s: cutting (the G1 moves in the plate), travelling (the rapids in X
/// and Y), in Z (plunges, retracts, rises to the clearance height and the ways down), and
/// waiting (the spindle's spin-up dwell, [`SPINDLE_DWELL_S`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TimeSplit {
    pub cutting: f64,
    pub travel: f64,
    pub z: f64,
    pub dwell: f64,
}

impl TimeSplit {
    pub fn total(&self) -> f64 {
        self.cutting + self.travel + self.z + self.dwell
    }

    /// "62% cutting, 21% travelling, 17% in Z" (and the spindle's wait where it has one:
    /// ", 0.3% waiting for the spindle").
    pub fn shares(&self) -> String {
        let t = self.total().max(1e-12);
        let mut s = format!(
            "{:.0}% cutting, {:.0}% travelling, {:.0}% in Z",
            100.0 * self.cutting / t,
            100.0 * self.travel / t,
            100.0 * self.z / t
        );
        if self.dwell > 0.0 {
            s += &format!(", {:.1}% waiting for the spindle", 100.0 * self.dwell / t);
        }
        s
    }
}

/// What a move of the program does, for [`TimeSplit`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Doing {
    Cutting,
    Travel,
    Z,
}

/// [`program_time`], split by what the machine does: the moves the G-code writer makes, timed
/// as the controller's planner runs them ([`crate::planner`], with the profile's rates,
/// acceleration and junction deviation).
pub fn program_time_split(blocks: &[Block], m: &MachineProfile) -> TimeSplit {
    let k = crate::planner::Kinematics::of_profile(m);
    let mv = program_moves(blocks, m, &k);
    let mut t = TimeSplit {
        dwell: spindle_dwell(m),
        ..TimeSplit::default()
    };
    for (doing, secs) in mv.times() {
        match doing {
            Doing::Cutting => t.cutting += secs,
            Doing::Travel => t.travel += secs,
            Doing::Z => t.z += secs,
        }
    }
    t
}

/// The same moves summed one by one from rest to rest ([`move_time`]) at the profile's rates
/// and acceleration along each move's path (a rapid at `rapid_mm_min`, without the faster
/// diagonal that axes limited one by one allow), s: an upper bound of [`program_time`], and of
/// any simple sum of the G-code's moves at their feeds.
pub fn program_time_rest_to_rest(blocks: &[Block], m: &MachineProfile) -> f64 {
    let k = crate::planner::Kinematics::of_profile(m);
    program_moves(blocks, m, &k)
        .segs
        .iter()
        .map(|s| move_time(s.len, (60.0 * s.v_max).min(m.rapid_mm_min), m.accel_mm_s2))
        .sum::<f64>()
        + spindle_dwell(m)
}

/// The dwell the G-code writer adds after starting the spindle (GRBL with a spindle), s.
fn spindle_dwell(m: &MachineProfile) -> f64 {
    match (m.firmware, m.spindle_rpm) {
        (Firmware::Grbl, Some(_)) => SPINDLE_DWELL_S,
        _ => 0.0,
    }
}

/// The moves the G-code writer makes for `blocks` (see [`program_time`]).
fn program_moves<'k>(
    blocks: &[Block],
    m: &MachineProfile,
    k: &'k crate::planner::Kinematics,
) -> crate::planner::Moves<'k, Doing> {
    // Z outside the plate: rapids on GRBL, the Z feed on Marlin; Marlin's rapids at the rapid
    // feed (its G0 shares G1's modal feed, which the writer sets).
    let (z_feed, rapid) = match m.firmware {
        Firmware::Grbl => (None, None),
        Firmware::Marlin => (Some(m.plunge_mm_min), Some(m.rapid_mm_min)),
    };
    let mut mv = crate::planner::Moves::new([0.0, 0.0, m.clearance_mm], k);
    let mut high = true;
    for b in blocks {
        let (first, last) = (b.path[0], b.path[b.path.len() - 1]);
        let at = [mv.at[0], mv.at[1]];
        let hop = Hop::of(m, at, [first[0], first[1]], high);
        if hop.rise {
            mv.go([at[0], at[1], m.clearance_mm], z_feed, Doing::Z);
        }
        mv.go([first[0], first[1], mv.at[2]], rapid, Doing::Travel);
        if hop.descend {
            mv.go([first[0], first[1], m.retract_mm], z_feed, Doing::Z);
        }
        mv.go(first, Some(m.plunge_mm_min), Doing::Z);
        for p in &b.moves(ARC_TOL_MM)[1..] {
            mv.go(*p, Some(m.cut_mm_min), Doing::Cutting);
        }
        mv.go([last[0], last[1], m.retract_mm], z_feed, Doing::Z);
        high = false;
    }
    if !high {
        mv.go([mv.at[0], mv.at[1], m.clearance_mm], z_feed, Doing::Z);
    }
    if m.firmware == Firmware::Grbl && m.spindle_rpm.is_some() {
        mv.stop(); // M5: the spindle stops with the machine standing
    }
    mv.go([0.0, 0.0, mv.at[2]], rapid, Doing::Travel);
    mv
}

/// Rapid travel of a program starting and ending at the work zero, mm.
pub fn program_travel(blocks: &[Block]) -> f64 {
    let mut at = [0.0, 0.0];
    let mut t = 0.0;
    for b in blocks {
        let (first, last) = (b.path[0], b.path[b.path.len() - 1]);
        t += dist(at, [first[0], first[1]]);
        at = [last[0], last[1]];
    }
    t + dist(at, [0.0, 0.0])
}

/// Checks a plan against the plate and the machine: every cut on the plate, no shallower than
/// `min_depth_mm` (for a design the plate's surface, [`check_bounds`]: grooves are cut into the
/// plate, never above it; the calibration card passes a lower value, for its rungs above the
/// surface), no deeper than
/// the machine's Z travel, and the plate inside the machine's X/Y travel.
pub fn check_cuts(cuts: &[Cut], plate_mm: f64, m: &MachineProfile, min_depth_mm: f64) -> Result<(), String> {
    let h = 0.5 * plate_mm;
    for c in cuts {
        for p in c.points(ARC_TOL_MM) {
            if !(p[0].abs() <= h + 1e-9 && p[1].abs() <= h + 1e-9) {
                return Err(format!(
                    "scratch {} reaches ({:.3}, {:.3}) mm, off the {plate_mm} mm plate",
                    c.scratch + 1,
                    p[0],
                    p[1]
                ));
            }
        }
        if !(c.z >= min_depth_mm) || c.z + m.clearance_mm > m.travel_mm[2] {
            let least = format!("depths must be >= {min_depth_mm} mm");
            return Err(format!(
                "scratch {}: depth {:.4} mm is outside the machine's Z travel ({} mm with {} mm clearance; {least})",
                c.scratch + 1,
                c.z,
                m.travel_mm[2],
                m.clearance_mm
            ));
        }
    }
    if plate_mm > m.travel_mm[0] || plate_mm > m.travel_mm[1] {
        return Err(format!(
            "the {plate_mm} mm plate does not fit the machine's {} x {} mm travel",
            m.travel_mm[0], m.travel_mm[1]
        ));
    }
    Ok(())
}

/// [`check_cuts`] for a design: every cut reaches the plate, whose surface lies at the commanded
/// depth `surface_mm` ([`surface_depth_mm`]).
pub fn check_bounds(cuts: &[Cut], plate_mm: f64, m: &MachineProfile, surface_mm: f64) -> Result<(), String> {
    check_cuts(cuts, plate_mm, m, surface_mm)
}

/// The commanded depth of the plate's surface: a cut commanded to depth z reaches z + z_offset_mm
/// (tool.json), so the surface is at -z_offset_mm; at commanded zero without a calibrated tool.
/// A design's commanded depths (`design --tool` writes them) start there.
pub fn surface_depth_mm(z_offset_mm: Option<f64>) -> f64 {
    z_offset_mm.map_or(0.0, |o| -o)
}

/// Checks every move of a program (rapids from and back to the work zero, plunges, cuts, retracts)
/// against the machine's travel, taken as a box centred on the work zero (the plate centre):
/// |X| <= travel_x / 2, |Y| <= travel_y / 2, and Z between the deepest point and the clearance height
/// within travel_z. With `--bed WxH` the bed is that box: the plate lies centred on the bed.
pub fn check_moves(blocks: &[Block], m: &MachineProfile) -> Result<(), String> {
    let (hx, hy) = (0.5 * m.travel_mm[0], 0.5 * m.travel_mm[1]);
    for b in blocks {
        if b.path.is_empty() {
            return Err(format!("{} has no moves", b.label));
        }
        for p in &b.moves(ARC_TOL_MM) {
            if !(p[0].abs() <= hx + 1e-9 && p[1].abs() <= hy + 1e-9) {
                return Err(format!(
                    "{}: the move to ({:.3}, {:.3}) mm leaves the {} x {} mm bed centred on the work zero",
                    b.label, p[0], p[1], m.travel_mm[0], m.travel_mm[1]
                ));
            }
            if !(p[2].is_finite() && m.clearance_mm - p[2] <= m.travel_mm[2] && p[2] < m.clearance_mm) {
                return Err(format!(
                    "{}: the move to Z {:.4} mm is outside the machine's Z travel ({} mm below the {} mm clearance height)",
                    b.label, p[2], m.travel_mm[2], m.clearance_mm
                ));
            }
        }
    }
    Ok(())
}

/// What a block of the program cuts: a scratch of the design (or a cut of the calibration card),
/// the orientation mark, or one hatch line of a registration mark (the calibration card's hatched
/// squares, which `scratchart-cal plan` carves in every plate's corners). The G-code comment that
/// opens the block is `; scratch N` (N from 1), `; mark +x edge` or `; mark LABEL hatch K` (the
/// mark's label, `corner -x -y`, and the line's place, from 1, in the mark's cut order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Label {
    Scratch(usize),
    Mark,
    Registration {
        /// The mark's label (`corner -x -y`).
        mark: &'static str,
        /// The line's place in the mark's cut order, from 0.
        line: usize,
    },
}

impl std::fmt::Display for Label {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Label::Scratch(k) => write!(f, "scratch {}", k + 1),
            Label::Mark => f.write_str("mark +x edge"),
            Label::Registration { mark, line } => write!(f, "mark {mark} hatch {}", line + 1),
        }
    }
}

/// One block of the program: the tool plunges at the path's first point and follows it with G1
/// moves; points are commanded (X, Y, Z) in work coordinates, Z < 0 below commanded zero. With a
/// nonzero `bulge` the path is two points joined by one arc (G2 or G3).
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    pub label: Label,
    pub path: Vec<[f64; 3]>,
    pub bulge: f64,
}

impl Block {
    /// A cut on a flat plate: one G1 line, or one arc, at Z = -depth.
    pub fn flat(c: &Cut) -> Block {
        Block {
            label: Label::Scratch(c.scratch),
            path: vec![[c.a[0], c.a[1], -c.z], [c.b[0], c.b[1], -c.z]],
            bulge: c.bulge,
        }
    }

    /// The path as the controller moves along it: an arc's lines within `tol` (Z as at its
    /// start), else the path itself.
    pub fn moves(&self, tol: f64) -> Vec<[f64; 3]> {
        if self.bulge == 0.0 || self.path.len() != 2 {
            return self.path.clone();
        }
        let (a, b) = (self.path[0], self.path[1]);
        let pts = arc_points([a[0], a[1]], [b[0], b[1]], self.bulge, tol);
        let n = pts.len();
        pts.iter()
            .enumerate()
            .map(|(k, q)| [q[0], q[1], if k + 1 == n { b[2] } else { a[2] }])
            .collect()
    }
}

/// The orientation mark's rule. One straight cut along +x, `len` = min(3 mm, plate / 10) long,
/// ending `edge` = min(1 mm, plate / 30) inside the plate's +x edge. Its y is the one nearest the
/// edge's middle (y = 0, then alternately above and below in steps of `len` / 4, keeping `edge`
/// from the plate's corners) at which the mark stays `clear_mm` plus half each groove's visible
/// width away from every scratch; when no such place exists (the scratches fill the edge), it goes
/// at y = 0 across them, and `clear` is false.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mark {
    pub a: [f64; 2],
    pub b: [f64; 2],
    /// Depth below the surface, mm.
    pub z: f64,
    pub clear: bool,
}

impl Mark {
    /// The mark's block on a flat plate.
    pub fn block(&self) -> Block {
        Block {
            label: Label::Mark,
            path: vec![[self.a[0], self.a[1], -self.z], [self.b[0], self.b[1], -self.z]],
            bulge: 0.0,
        }
    }
}

fn seg_dist(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> f64 {
    let cross = |o: [f64; 2], p: [f64; 2], q: [f64; 2]| (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]);
    let (d1, d2, d3, d4) = (cross(c, d, a), cross(c, d, b), cross(a, b, c), cross(a, b, d));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return 0.0;
    }
    let pt = |p: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        let (vx, vy) = (b[0] - a[0], b[1] - a[1]);
        let l2 = vx * vx + vy * vy;
        let t = if l2 > 0.0 {
            (((p[0] - a[0]) * vx + (p[1] - a[1]) * vy) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        dist(p, [a[0] + t * vx, a[1] + t * vy])
    };
    pt(a, c, d).min(pt(b, c, d)).min(pt(c, a, b)).min(pt(d, a, b))
}

/// The segments the orientation mark keeps clear of (endpoints and visible width): each cut's,
/// an arc's lines within a tenth of a millimetre.
pub fn mark_segments(cuts: &[Cut], widths: &[f64]) -> Vec<([f64; 2], [f64; 2], f64)> {
    let mut out = Vec::with_capacity(cuts.len());
    for (c, &w) in cuts.iter().zip(widths) {
        let p = c.points(0.1);
        out.extend(p.windows(2).map(|q| (q[0], q[1], w)));
    }
    out
}

/// The room the orientation mark keeps from every scratch (beyond half its visible width), mm.
pub const MARK_CLEAR_MM: f64 = 0.5;

/// Places the orientation mark (see [`Mark`]) among `scratches` (endpoints and visible width, mm)
/// on a plate of `plate_mm`, cut `depth` deep.
pub fn orientation_mark(scratches: &[([f64; 2], [f64; 2], f64)], plate_mm: f64, depth: f64, clear_mm: f64) -> Mark {
    let h = 0.5 * plate_mm;
    let len = (plate_mm / 10.0).min(3.0);
    let edge = (plate_mm / 30.0).min(1.0);
    let (x0, x1) = (h - edge - len, h - edge);
    let near: Vec<_> = scratches
        .iter()
        .filter(|(a, b, w)| a[0].max(b[0]) + 0.5 * w + clear_mm >= x0)
        .collect();
    let at = |y: f64, clear: bool| Mark {
        a: [x0, y],
        b: [x1, y],
        z: depth,
        clear,
    };
    let step = 0.25 * len;
    let n = ((h - edge) / step).floor() as i64;
    for k in 0..=2 * n {
        let y = if k % 2 == 1 { (k + 1) / 2 } else { -(k / 2) } as f64 * step;
        let c = at(y, true);
        if near
            .iter()
            .all(|(a, b, w)| seg_dist(c.a, c.b, *a, *b) >= clear_mm + 0.5 * w)
        {
            return c;
        }
    }
    at(0.0, false)
}

impl crate::planner::Kinematics {
    /// A machine profile's rates: its rapid feed and one acceleration on every axis.
    pub fn of_profile(m: &MachineProfile) -> crate::planner::Kinematics {
        crate::planner::Kinematics {
            rate_mm_min: [m.rapid_mm_min; 3],
            accel_mm_s2: [m.accel_mm_s2; 3],
            junction_deviation_mm: m.junction_deviation_mm,
            source: "the machine profile's rapid feed, acceleration and junction deviation".into(),
        }
    }
}
