//! A plan read back for streaming: the firmware named on its first line, the lines before the
//! first scratch (units, offsets, spindle), one block of lines per scratch (from each
//! `; scratch N (cut K of T)` comment to the next: N the design's number, K the cut order), and
//! the lines after the last one. Comments and blank lines
//! are never sent.
use crate::planner::Kinematics;
use crate::planner::Moves;
use scratchart_tool::machine::Firmware;

/// One block of the plan: what its opening comment says (`scratch N`, `mark +x edge`), the
/// scratch number in the design when it is a scratch, and its G-code lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    pub label: String,
    pub scratch: Option<usize>,
    pub lines: Vec<String>,
}

/// A plan ready to stream.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    pub firmware: Firmware,
    /// Plate size from the header (`; plate 100.0 mm square`), when the plan states it.
    pub plate_mm: Option<f64>,
    /// The deepest plunge (mm below Z0) and the highest Z of the plan, mm.
    pub min_z: f64,
    pub max_z: f64,
    /// Largest |X| and |Y| the plan reaches, mm (work coordinates).
    pub max_xy: f64,
    /// The job time the plan's header states for the profile it was made for (`; estimated job
    /// time 4.7 min ...`), when it does.
    pub estimate_min: Option<f64>,
    /// The highest spindle speed the plan commands (`M3 S..`, `M4 S..`), when it does.
    pub spindle_rpm: Option<f64>,
    pub preamble: Vec<String>,
    pub blocks: Vec<Block>,
    pub postamble: Vec<String>,
    /// FNV-1a 64 of the plan's bytes: a changed plan is refused on resume.
    pub checksum: String,
}

/// Longest line a controller takes: GRBL's line buffer is 80 characters, and Marlin's framing
/// (`N<n> ` and `*<checksum>`) must still fit in its 96.
pub const MAX_LINE: usize = 79;

/// FNV-1a, 64 bits, as 16 hex digits.
pub fn checksum(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{h:016x}")
}

pub(crate) fn word(line: &str, letter: char) -> Option<f64> {
    line.split_whitespace()
        .find(|w| w.starts_with(letter))
        .and_then(|w| w[1..].parse().ok())
}

/// The plan's time on a machine ([`Program::timing`]), s.
#[derive(Clone, Debug, PartialEq)]
pub struct Timing {
    pub preamble: f64,
    /// Each block's.
    pub blocks: Vec<f64>,
    pub postamble: f64,
}

impl Timing {
    /// A job from block `from` to the end (preamble and postamble included).
    pub fn from(&self, from: usize) -> f64 {
        self.preamble + self.blocks.iter().skip(from).sum::<f64>() + self.postamble
    }
}

/// The modal state of a machine following G-code, for [`Program::timing`]: its moves go to the
/// planner ([`crate::planner`]) tagged with the section they belong to; dwells are counted
/// apart.
struct Motion<'k> {
    moves: Moves<'k, usize>,
    dwell: Vec<f64>,
    feed: Option<f64>,
    rapid: bool,
    /// The modal arc (G2: Some(false), clockwise; G3: Some(true)), or None for G0 and G1.
    arc: Option<bool>,
    relative: bool,
    marlin: bool,
}

/// The bulge of the arc from `a` to `b` about `centre`, counter-clockwise when `ccw` (a full turn
/// where the ends meet, as GRBL reads it).
pub(crate) fn bulge_of(a: [f64; 2], b: [f64; 2], centre: [f64; 2], ccw: bool) -> f64 {
    let tau = std::f64::consts::TAU;
    let p0 = (a[1] - centre[1]).atan2(a[0] - centre[0]);
    let p1 = (b[1] - centre[1]).atan2(b[0] - centre[0]);
    let mut sweep = if ccw {
        (p1 - p0).rem_euclid(tau)
    } else {
        -(p0 - p1).rem_euclid(tau)
    };
    if sweep.abs() < 1e-9 {
        sweep = if ccw { tau } else { -tau };
    }
    (0.25 * sweep).tan()
}

impl Motion<'_> {
    /// Follows one line of section `sec`.
    fn line(&mut self, line: &str, sec: usize) {
        let words: Vec<&str> = line.split_whitespace().collect();
        let has = |w: &str| words.contains(&w);
        if has("G90") {
            self.relative = false;
        }
        if has("G91") {
            self.relative = true;
        }
        if let Some(f) = word(line, 'F').filter(|f| *f > 0.0) {
            self.feed = Some(f);
        }
        if has("G4") || has("G04") {
            // GRBL: P in seconds; Marlin: P in milliseconds, S in seconds. The planner empties
            // its buffer first: the machine stops.
            self.dwell[sec] += match (self.marlin, word(line, 'P'), word(line, 'S')) {
                (true, Some(p), _) => p / 1000.0,
                (true, None, Some(s)) => s,
                (false, Some(p), _) => p,
                _ => 0.0,
            };
            self.moves.stop();
            return;
        }
        if has("G92") || has("G28") {
            // A new zero, or homing (its time is the machine's): the position the words give.
            for (i, c) in ['X', 'Y', 'Z'].iter().enumerate() {
                if let Some(v) = word(line, *c) {
                    self.moves.at[i] = v;
                }
            }
            self.moves.stop();
            return;
        }
        if words.first().is_some_and(|w| w.starts_with('M')) {
            // Spindle and other machine commands: GRBL and Marlin finish the moves before them.
            self.moves.stop();
            return;
        }
        if has("G0") || has("G00") {
            self.rapid = true;
            self.arc = None;
        } else if has("G1") || has("G01") {
            self.rapid = false;
            self.arc = None;
        } else if has("G2") || has("G02") || has("G3") || has("G03") {
            self.rapid = false;
            self.arc = Some(has("G3") || has("G03"));
        } else if !['X', 'Y', 'Z'].iter().any(|c| word(line, *c).is_some()) {
            return;
        }
        let mut to = self.moves.at;
        for (i, c) in ['X', 'Y', 'Z'].iter().enumerate() {
            if let Some(v) = word(line, *c) {
                to[i] = if self.relative { self.moves.at[i] + v } else { v };
            }
        }
        // GRBL's G0 runs at the axes' rates; Marlin's G0 shares G1's modal feed.
        let feed = if !self.rapid || self.marlin { self.feed } else { None };
        if let Some(ccw) = self.arc {
            // The lines the controller cuts the arc into (its Z moves along with them).
            let at = self.moves.at;
            let centre = [
                at[0] + word(line, 'I').unwrap_or(0.0),
                at[1] + word(line, 'J').unwrap_or(0.0),
            ];
            let bulge = bulge_of([at[0], at[1]], [to[0], to[1]], centre, ccw);
            let pts = crate::plan::arc_points([at[0], at[1]], [to[0], to[1]], bulge, crate::plan::ARC_TOL_MM);
            let n = pts.len() - 1;
            for (k, q) in pts.iter().enumerate().skip(1) {
                let z = at[2] + (to[2] - at[2]) * k as f64 / n as f64;
                self.moves.go([q[0], q[1], z], feed, sec);
            }
            return;
        }
        self.moves.go(to, feed, sec);
    }
}

/// A plan file that cannot be read, or is not a plan `scratchart-cal plan` wrote: the user's
/// input (exit 3). The message names the file, the line and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct ProgramError(pub String);

impl std::fmt::Display for ProgramError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ProgramError {}

impl scratchart_exit::ExitClass for ProgramError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        Some(scratchart_exit::Class::Input)
    }
}

impl Program {
    /// Parses a plan written by `scratchart-cal plan`. Errors say which line and what is wrong.
    pub fn parse(text: &str) -> Result<Program, ProgramError> {
        Program::parse_text(text).map_err(ProgramError)
    }

    fn parse_text(text: &str) -> Result<Program, String> {
        let first = text.lines().next().unwrap_or("");
        let firmware = match first.trim() {
            "; scratchart plan machine=grbl" => Firmware::Grbl,
            "; scratchart plan machine=marlin" => Firmware::Marlin,
            _ => {
                return Err(format!(
                    "line 1 is `{}`, not `; scratchart plan machine=grbl` or `machine=marlin`: \
                     carve streams plans written by `scratchart-cal plan`",
                    first.chars().take(60).collect::<String>()
                ))
            }
        };
        let mut p = Program {
            firmware,
            plate_mm: None,
            estimate_min: None,
            min_z: 0.0,
            max_z: 0.0,
            max_xy: 0.0,
            spindle_rpm: None,
            preamble: Vec::new(),
            blocks: Vec::new(),
            postamble: Vec::new(),
            checksum: checksum(text.as_bytes()),
        };
        for (k, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if let Some(c) = line.strip_prefix(';') {
                let c = c.trim();
                // `scratch N (cut K of T)` (or `scratch N` from older plans): the label is
                // what comes before the cut index.
                let label = c.split(" (cut ").next().unwrap_or(c).trim();
                if let Some(n) = label.strip_prefix("scratch ") {
                    let n: usize = n
                        .trim()
                        .parse()
                        .map_err(|_| format!("line {}: `{line}` has no scratch number", k + 1))?;
                    // A block ends where the next begins; the lines after the last block's
                    // retract belong to the postamble (see below).
                    p.blocks.push(Block {
                        label: label.to_string(),
                        scratch: Some(n),
                        lines: Vec::new(),
                    });
                } else if label.starts_with("mark ") {
                    p.blocks.push(Block {
                        label: label.to_string(),
                        scratch: None,
                        lines: Vec::new(),
                    });
                } else if let Some(rest) = c.strip_prefix("estimated job time ") {
                    p.estimate_min = rest.split(' ').next().and_then(|v| v.parse().ok());
                } else if let Some(rest) = c.strip_prefix("plate ") {
                    p.plate_mm = rest.split_whitespace().next().and_then(|s| s.parse().ok());
                }
                continue;
            }
            if line.is_empty() {
                continue;
            }
            if line.contains(';') || line.contains('(') {
                return Err(format!("line {}: an inline comment in `{line}`", k + 1));
            }
            if line.len() > MAX_LINE || !line.is_ascii() {
                return Err(format!(
                    "line {}: {} characters (or not ASCII); controllers take at most {MAX_LINE}",
                    k + 1,
                    line.len()
                ));
            }
            for (letter, is_xy) in [('X', true), ('Y', true), ('Z', false)] {
                if let Some(v) = word(line, letter) {
                    if is_xy {
                        p.max_xy = p.max_xy.max(v.abs());
                    } else {
                        p.min_z = p.min_z.min(v);
                        p.max_z = p.max_z.max(v);
                    }
                }
            }
            if line.starts_with("M3") || line.starts_with("M4") {
                if let Some(s) = word(line, 'S') {
                    p.spindle_rpm = Some(p.spindle_rpm.map_or(s, |r: f64| r.max(s)));
                }
            }
            match p.blocks.last_mut() {
                Some(b) => b.lines.push(line.to_string()),
                None => p.preamble.push(line.to_string()),
            }
        }
        // The last block ends with its retract, the first `G0 Z..` after its cut (`G1`); what
        // follows it (the rise to the clearance height, the way home) is the postamble.
        if let Some(b) = p.blocks.last_mut() {
            let cut = b.lines.iter().position(|l| l.starts_with("G1")).unwrap_or(0);
            let end = b
                .lines
                .iter()
                .skip(cut)
                .position(|l| l.starts_with("G0 Z"))
                .map_or(b.lines.len(), |i| cut + i + 1);
            p.postamble = b.lines.split_off(end);
        }
        if let Some(b) = p.blocks.iter().find(|b| b.lines.is_empty()) {
            return Err(format!("`{}` has no G-code lines", b.label));
        }
        Ok(p)
    }

    /// Reads and parses a plan file.
    pub fn load(path: &std::path::Path) -> Result<Program, ProgramError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ProgramError(format!("cannot read plan {}: {e}", path.display())))?;
        Program::parse(&text).map_err(|e| ProgramError(format!("plan {}: {e}", path.display())))
    }

    /// The lines to send for a job that starts at block `from` (0 = the whole plan): the
    /// preamble, blocks `from..`, the postamble; each with the block it belongs to.
    pub fn lines_from(&self, from: usize) -> Vec<(String, Option<usize>)> {
        let mut out: Vec<(String, Option<usize>)> = self.preamble.iter().map(|l| (l.clone(), None)).collect();
        for (i, b) in self.blocks.iter().enumerate().skip(from) {
            out.extend(b.lines.iter().map(|l| (l.clone(), Some(i))));
        }
        out.extend(self.postamble.iter().map(|l| (l.clone(), None)));
        out
    }

    /// How long the machine takes for the plan by its own motion limits `k`, as its planner
    /// runs it ([`crate::planner`]: junction speeds, acceleration, lookahead): a rapid at the
    /// fastest rate every axis allows, a feed move at its F but no faster than the axes allow,
    /// the acceleration the slowest axis of the move allows; dwells (`G4`) as long as they say,
    /// with the machine stopped before and after them and around spindle commands. The machine
    /// starts at X0 Y0 at the plan's highest Z.
    pub fn timing(&self, k: &Kinematics) -> Timing {
        let sections = self.blocks.len() + 2;
        let mut m = Motion {
            moves: Moves::new([0.0, 0.0, self.max_z], k),
            dwell: vec![0.0; sections],
            feed: None,
            rapid: true,
            arc: None,
            relative: false,
            marlin: self.firmware == Firmware::Marlin,
        };
        let all = std::iter::once(&self.preamble)
            .chain(self.blocks.iter().map(|b| &b.lines))
            .chain(std::iter::once(&self.postamble));
        for (sec, lines) in all.enumerate() {
            for l in lines {
                m.line(l, sec);
            }
        }
        let mut t = m.dwell.clone();
        for (sec, secs) in m.moves.times() {
            t[sec] += secs;
        }
        Timing {
            preamble: t[0],
            blocks: t[1..sections - 1].to_vec(),
            postamble: t[sections - 1],
        }
    }

    /// The rectangle the cuts' X and Y words span, `[x_min, y_min, x_max, y_max]` in mm (the
    /// job's bounding box: every block's moves, the marks' included); `None` for a plan
    /// without blocks.
    pub fn xy_bounds(&self) -> Option<[f64; 4]> {
        let mut b: Option<[f64; 4]> = None;
        let mut at = [0.0, 0.0];
        for l in self.blocks.iter().flat_map(|b| &b.lines) {
            if let (Some(x), Some(y)) = (word(l, 'X'), word(l, 'Y')) {
                // An arc's way between its ends counts too (G2 and G3 name their motion).
                let words: Vec<&str> = l.split_whitespace().collect();
                let ccw = words.iter().any(|w| matches!(*w, "G3" | "G03"));
                let cw = words.iter().any(|w| matches!(*w, "G2" | "G02"));
                let pts = if ccw || cw {
                    let centre = [at[0] + word(l, 'I').unwrap_or(0.0), at[1] + word(l, 'J').unwrap_or(0.0)];
                    let bulge = bulge_of(at, [x, y], centre, ccw);
                    crate::plan::arc_points(at, [x, y], bulge, crate::plan::ARC_TOL_MM)
                } else {
                    vec![[x, y]]
                };
                for q in pts {
                    let r = b.get_or_insert([q[0], q[1], q[0], q[1]]);
                    *r = [r[0].min(q[0]), r[1].min(q[1]), r[2].max(q[0]), r[3].max(q[1])];
                }
                at = [x, y];
            }
        }
        b
    }

    /// The firmware's name as the plan writes it.
    pub fn firmware_name(f: Firmware) -> &'static str {
        match f {
            Firmware::Grbl => "grbl",
            Firmware::Marlin => "marlin",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Cut;
    use scratchart_tool::machine::MachineProfile;

    #[test]
    fn blocks_follow_the_scratch_comments() {
        let cuts = [
            Cut {
                a: [0.0, 0.0],
                b: [1.0, 0.0],
                z: 0.02,
                scratch: 4,
                bulge: 0.0,
            },
            Cut {
                a: [2.0, 1.0],
                b: [-3.0, 1.0],
                z: 0.05,
                scratch: 0,
                bulge: 0.0,
            },
        ];
        let g = crate::gcode::write(&cuts, &MachineProfile::grbl(), 50.0, &["a note".into()]);
        assert!(g.contains("\n; scratch 5 (cut 1 of 2)\n") && g.contains("\n; scratch 1 (cut 2 of 2)\n"));
        let p = Program::parse(&g).unwrap();
        // A plan written before the cut index was added reads the same.
        let old = Program::parse(&g.replace(" (cut 1 of 2)", "").replace(" (cut 2 of 2)", "")).unwrap();
        assert_eq!(old.blocks, p.blocks);
        assert_eq!(p.firmware, Firmware::Grbl);
        assert_eq!(p.plate_mm, Some(50.0));
        assert_eq!(p.blocks.len(), 2);
        assert_eq!(p.blocks[0].scratch, Some(5));
        assert_eq!(p.blocks[1].label, "scratch 1");
        assert_eq!(p.blocks[1].lines.len(), 4);
        // A neighbour 1.4 mm away: the hop at the retract height, no rise to the clearance.
        assert_eq!(p.blocks[1].lines[0], "G0 X2.0000 Y1.0000");
        assert_eq!(p.blocks[1].lines[3], "G0 Z0.300");
        assert_eq!(p.postamble, vec!["G0 Z2.000", "M5", "G0 X0 Y0", "M2"]);
        assert!(p.preamble.contains(&"M3 S10000".to_string()));
        assert_eq!(p.spindle_rpm, Some(10000.0));
        assert!((p.min_z + 0.05).abs() < 1e-12 && p.max_xy == 3.0);
        assert!(p.lines_from(0).iter().all(|(l, _)| !l.starts_with(';')));
        assert_eq!(p.lines_from(1).iter().filter(|l| l.1 == Some(1)).count(), 4);
        assert!(p.lines_from(1).iter().all(|l| l.1 != Some(0)));
        // The time by the machine's limits: with the profile's own rates it is the plan's
        // estimate (GRBL: rapids and retracts at the rapid feed, each axis limited on its own,
        // so a diagonal rapid is faster than one axis), and slower axes take longer.
        let prof = MachineProfile::grbl();
        let k = Kinematics::of_profile(&prof);
        let on_x: Vec<Cut> = cuts
            .iter()
            .map(|c| Cut {
                a: [c.a[0], 0.0],
                b: [c.b[0], 0.0],
                ..*c
            })
            .collect();
        let px = Program::parse(&crate::gcode::write(&on_x, &prof, 50.0, &[])).unwrap();
        let t = px.timing(&k);
        let blocks: Vec<_> = on_x.iter().map(crate::plan::Block::flat).collect();
        let want = crate::plan::program_time(&blocks, &prof); // the spindle's G4 P2 included
        assert!((t.from(0) - want).abs() < 1e-9, "{} vs {want}", t.from(0));
        assert!(t.from(1) < t.from(0) && t.blocks.len() == 2);
        let diagonal = p.timing(&k).from(0);
        let blocks: Vec<_> = cuts.iter().map(crate::plan::Block::flat).collect();
        let want = crate::plan::program_time(&blocks, &prof);
        assert!((diagonal - want).abs() < 1e-9, "{diagonal} vs {want}");
        let slow = Kinematics {
            rate_mm_min: [500.0, 500.0, 100.0],
            accel_mm_s2: [50.0, 50.0, 10.0],
            junction_deviation_mm: 0.01,
            source: String::new(),
        };
        assert!(p.timing(&slow).from(0) > t.from(0) + 1.0);
        let m = crate::gcode::write(&cuts, &MachineProfile::marlin(), 50.0, &[]);
        assert_eq!(Program::parse(&m).unwrap().firmware, Firmware::Marlin);
        assert_ne!(Program::parse(&m).unwrap().checksum, p.checksum);
        assert!(Program::parse("G0 X1\n").unwrap_err().0.contains("line 1"));
    }
}
