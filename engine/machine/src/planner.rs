//! The job time as the controller's motion planner makes it (the estimate of `plan`, `card` and
//! `carve`): GRBL's planner (`planner.c` of GRBL 1.1, which Marlin's junction-deviation planner
//! follows), not a sum of moves from rest to rest.
//!
//! Each straight move has a top speed (its feed, no faster than any axis's rate along it) and an
//! acceleration (no more than any axis's along it). Consecutive moves pass their junction at
//! most at the junction speed of the angle between them, with the junction deviation delta:
//! v_j^2 = a_j delta sin(theta/2) / (1 - sin(theta/2)), theta the angle between the reversed
//! incoming and the outgoing direction (straight on: no limit but the moves' own speeds; a
//! reversal: a stop), a_j the acceleration along the junction's direction. The planner sees
//! [`LOOKAHEAD`] moves ahead and plans the last of them to stop, so every move must be able to
//! stop within the moves it sees; a dwell, a spindle change or any line that empties the
//! planner's buffer stops the machine before the next move. Each move's speed then follows a
//! trapezoid (accelerate from the entry speed, cruise, decelerate to the exit speed) or a
//! triangle where it is too short to cruise.
//!
//! A move-by-move sum (each move from rest to rest, `plan::move_time`) is an upper
//! bound of this time and the moves' lengths over their top speeds a lower one; the tests check
//! both, and that moves split along a straight line take the time of the whole.
/// The machine's own motion limits, as its controller reports them: the job time `carve` states
/// comes from these, not from a profile's defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct Kinematics {
    /// Top rate of each axis (X, Y, Z), mm/min (GRBL `$110-$112`; Marlin `M203`, mm/s there).
    pub rate_mm_min: [f64; 3],
    /// Acceleration of each axis, mm/s^2 (GRBL `$120-$122`; Marlin `M201`).
    pub accel_mm_s2: [f64; 3],
    /// The planner's junction deviation, mm (GRBL `$11`; Marlin `M205 J`): how fast the machine
    /// takes a corner (see this module's doc).
    pub junction_deviation_mm: f64,
    /// Where they came from, for the user ("the controller's $110-$112 and $120-$122").
    pub source: String,
}

/// Moves the planner sees ahead of the one it runs (GRBL 1.1 on an ATmega328P: a buffer of 16
/// blocks, 15 planned).
pub const LOOKAHEAD: usize = 15;

/// One straight move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Length, mm.
    pub len: f64,
    /// Unit direction.
    pub unit: [f64; 3],
    /// Top speed along the move, mm/s.
    pub v_max: f64,
    /// Acceleration along the move, mm/s^2.
    pub accel: f64,
    /// The machine stands still before this move (a dwell, a spindle change, the start).
    pub stop_before: bool,
}

impl Segment {
    /// The move from `from` to `to` at `feed_mm_min` (`None`: a rapid, at the axes' own rates),
    /// limited by the machine's axes; `None` for a move of zero length.
    pub fn between(from: [f64; 3], to: [f64; 3], feed_mm_min: Option<f64>, k: &Kinematics) -> Option<Segment> {
        let d: [f64; 3] = std::array::from_fn(|i| to[i] - from[i]);
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if len <= 0.0 {
            return None;
        }
        let unit = d.map(|x| x / len);
        let (mut v, mut a) = (f64::INFINITY, f64::INFINITY);
        for i in 0..3 {
            let u = unit[i].abs();
            if u > 1e-12 {
                v = v.min(k.rate_mm_min[i] / u);
                a = a.min(k.accel_mm_s2[i] / u);
            }
        }
        if let Some(f) = feed_mm_min {
            v = v.min(f);
        }
        Some(Segment {
            len,
            unit,
            v_max: v / 60.0,
            accel: a,
            stop_before: false,
        })
    }
}

/// The largest speed at the junction from `a` into `b`, mm/s (GRBL's `max_junction_speed`).
pub fn junction_speed(a: &Segment, b: &Segment, k: &Kinematics) -> f64 {
    let cos_theta = -(a.unit[0] * b.unit[0] + a.unit[1] * b.unit[1] + a.unit[2] * b.unit[2]);
    if cos_theta > 0.999_999 {
        return 0.0; // a reversal
    }
    if cos_theta < -0.999_999 {
        return f64::INFINITY; // straight on
    }
    // The acceleration along the junction's direction (b - a), no axis over its own.
    let j: [f64; 3] = std::array::from_fn(|i| b.unit[i] - a.unit[i]);
    let jn = (j[0] * j[0] + j[1] * j[1] + j[2] * j[2]).sqrt();
    let mut acc = f64::INFINITY;
    for i in 0..3 {
        let u = j[i].abs() / jn;
        if u > 1e-12 {
            acc = acc.min(k.accel_mm_s2[i] / u);
        }
    }
    let sin_half = (0.5 * (1.0 - cos_theta)).sqrt();
    (acc * k.junction_deviation_mm * sin_half / (1.0 - sin_half)).sqrt()
}

/// Seconds of a move of `len` at most `v_max` with acceleration `a`, entered at `v_in` and left
/// at `v_out` (both reachable: the planner's passes see to it).
pub fn trapezoid_time(len: f64, v_max: f64, a: f64, v_in: f64, v_out: f64) -> f64 {
    if len <= 0.0 {
        return 0.0;
    }
    let up = (v_max * v_max - v_in * v_in) / (2.0 * a);
    let down = (v_max * v_max - v_out * v_out) / (2.0 * a);
    if up + down <= len {
        (v_max - v_in) / a + (v_max - v_out) / a + (len - up - down) / v_max
    } else {
        let peak = ((2.0 * a * len + v_in * v_in + v_out * v_out) / 2.0).sqrt();
        ((peak - v_in) / a + (peak - v_out) / a).max(0.0)
    }
}

/// Each move's seconds, as the planner runs them (see the module doc). The machine stands still
/// before the first move and after the last.
pub fn segment_times(segs: &[Segment], k: &Kinematics) -> Vec<f64> {
    let n = segs.len();
    // The largest entry speed of each move: its junction with the one before, both moves' top
    // speeds; 0 after a stop.
    let entry_max: Vec<f64> = (0..n)
        .map(|i| {
            if i == 0 || segs[i].stop_before {
                0.0
            } else {
                junction_speed(&segs[i - 1], &segs[i], k)
                    .min(segs[i - 1].v_max)
                    .min(segs[i].v_max)
            }
        })
        .collect();
    // The exit speed each move can have and still stop within the moves the planner sees
    // (backward over them from a stop at the last), then the speeds reachable from the start
    // (forward).
    let mut exit = vec![0.0f64; n];
    for i in 0..n {
        let last = (i + LOOKAHEAD).min(n - 1);
        let mut v = 0.0f64; // the exit of move `last`
        for j in (i + 1..=last).rev() {
            v = entry_max[j].min((v * v + 2.0 * segs[j].accel * segs[j].len).sqrt());
        }
        exit[i] = v; // the entry of move i + 1 (0 after the last move)
    }
    let mut times = Vec::with_capacity(n);
    let mut v_in = 0.0f64;
    for i in 0..n {
        let s = &segs[i];
        if s.stop_before {
            v_in = 0.0;
        }
        let reach = (v_in * v_in + 2.0 * s.accel * s.len).sqrt();
        let v_out = exit[i].min(reach);
        // (a move entered faster than it can slow down from: the backward pass rules it out)
        times.push(trapezoid_time(s.len, s.v_max, s.accel, v_in, v_out));
        v_in = v_out;
    }
    times
}

/// A run of moves being built from machine positions: [`Moves::go`] appends the move to a
/// point (each tagged, e.g. by what the machine does or by the block it belongs to), and
/// [`Moves::stop`] marks a stop before the next one.
pub struct Moves<'k, T> {
    pub at: [f64; 3],
    pub segs: Vec<Segment>,
    pub tags: Vec<T>,
    k: &'k Kinematics,
    stop: bool,
}

impl<'k, T: Copy> Moves<'k, T> {
    pub fn new(at: [f64; 3], k: &'k Kinematics) -> Moves<'k, T> {
        Moves {
            at,
            segs: Vec::new(),
            tags: Vec::new(),
            k,
            stop: false,
        }
    }

    /// A move to `to` at `feed_mm_min` (`None`: rapid).
    pub fn go(&mut self, to: [f64; 3], feed_mm_min: Option<f64>, tag: T) {
        if let Some(mut s) = Segment::between(self.at, to, feed_mm_min, self.k) {
            s.stop_before = std::mem::take(&mut self.stop);
            self.segs.push(s);
            self.tags.push(tag);
        }
        self.at = to;
    }

    /// The machine stops before the next move.
    pub fn stop(&mut self) {
        self.stop = true;
    }

    /// Each move's seconds with its tag.
    pub fn times(&self) -> impl Iterator<Item = (T, f64)> + '_ {
        self.tags.iter().copied().zip(segment_times(&self.segs, self.k))
    }
}
