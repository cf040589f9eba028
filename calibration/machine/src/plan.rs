//! A carving plan: the order the scratches are cut in, the travel between them, the time the job
//! takes, and the bounds it must keep. Each scratch is one straight cut between its endpoints, in
//! either direction.
//!
//! Order: greedy nearest neighbour from the work zero, choosing each cut's direction, then 2-opt
//! (reversing a run of cuts also reverses each cut) until no improvement, with the partner search
//! limited to a window of the next 200 cuts so large designs stay fast.
//!
//! Time: every move follows a trapezoidal speed profile (accelerate at `accel` to the feed,
//! cruise, decelerate to a stop), so t(d) = d / v + v / a when d >= v^2 / a, else 2 sqrt(d / a).
use serde::{Deserialize, Serialize};

/// The machine a plan is made for (`--machine-file machine.json`; built-in defaults for a desktop
/// GRBL router and a Marlin printer with an engraving bit).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineProfile {
    /// "grbl" or "marlin"
    pub firmware: Firmware,
    /// Travel of the X, Y and Z axes, mm.
    pub travel_mm: [f64; 3],
    /// Feeds, mm/min: rapid moves, cuts, plunges.
    pub rapid_mm_min: f64,
    pub cut_mm_min: f64,
    pub plunge_mm_min: f64,
    /// Acceleration, mm/s^2.
    pub accel_mm_s2: f64,
    /// Height of rapid moves above the plate, mm.
    pub safe_z_mm: f64,
    /// Spindle speed, rpm (`None`: no spindle, e.g. a drag engraver).
    pub spindle_rpm: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Firmware {
    Grbl,
    Marlin,
}

impl MachineProfile {
    /// A desktop GRBL router (3018 class).
    pub fn grbl() -> MachineProfile {
        MachineProfile {
            firmware: Firmware::Grbl,
            travel_mm: [300.0, 180.0, 45.0],
            rapid_mm_min: 1000.0,
            cut_mm_min: 300.0,
            plunge_mm_min: 100.0,
            accel_mm_s2: 200.0,
            safe_z_mm: 2.0,
            spindle_rpm: Some(10_000.0),
        }
    }

    /// A Marlin printer (Ender / Prusa class) with an engraving bit: no spindle.
    pub fn marlin() -> MachineProfile {
        MachineProfile {
            firmware: Firmware::Marlin,
            travel_mm: [220.0, 220.0, 250.0],
            rapid_mm_min: 3000.0,
            cut_mm_min: 600.0,
            plunge_mm_min: 300.0,
            accel_mm_s2: 500.0,
            safe_z_mm: 2.0,
            spindle_rpm: None,
        }
    }
}

/// One cut: from `a` to `b` (mm, work coordinates: the plate centre is the origin) at commanded
/// depth `z` (mm below the surface), and the index of its scratch in the design.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cut {
    pub a: [f64; 2],
    pub b: [f64; 2],
    pub z: f64,
    pub scratch: usize,
}

impl Cut {
    fn reversed(self) -> Cut {
        Cut {
            a: self.b,
            b: self.a,
            ..self
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

/// The job's time, s: for every cut a rapid to its start, a plunge, the cut and a retract.
pub fn job_time(cuts: &[Cut], m: &MachineProfile) -> f64 {
    let mut at = [0.0, 0.0];
    let mut t = 0.0;
    for c in cuts {
        t += move_time(dist(at, c.a), m.rapid_mm_min, m.accel_mm_s2);
        t += move_time(m.safe_z_mm + c.z, m.plunge_mm_min, m.accel_mm_s2);
        t += move_time(dist(c.a, c.b), m.cut_mm_min, m.accel_mm_s2);
        t += move_time(m.safe_z_mm + c.z, m.rapid_mm_min, m.accel_mm_s2);
        at = c.b;
    }
    t + move_time(dist(at, [0.0, 0.0]), m.rapid_mm_min, m.accel_mm_s2)
}

/// Checks a plan against the plate and the machine: every cut on the plate, no deeper than the
/// machine's Z travel, and the plate (with the tool at safe height) inside the machine's travel.
pub fn check_bounds(cuts: &[Cut], plate_mm: f64, m: &MachineProfile) -> Result<(), String> {
    let h = 0.5 * plate_mm;
    for c in cuts {
        for p in [c.a, c.b] {
            if p[0].abs() > h + 1e-9 || p[1].abs() > h + 1e-9 {
                return Err(format!(
                    "scratch {} reaches ({:.3}, {:.3}) mm, off the {plate_mm} mm plate",
                    c.scratch + 1,
                    p[0],
                    p[1]
                ));
            }
        }
        if !(c.z >= 0.0) || c.z + m.safe_z_mm > m.travel_mm[2] {
            return Err(format!(
                "scratch {}: depth {:.4} mm is outside the machine's Z travel ({} mm with {} mm safe height)",
                c.scratch + 1,
                c.z,
                m.travel_mm[2],
                m.safe_z_mm
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
