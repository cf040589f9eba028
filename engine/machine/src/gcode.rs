//! The one G-code writer (used by `plan` and by the calibration card): a program's blocks as
//! GRBL- or Marlin-flavoured G-code. The first line names the firmware (`carve` refuses a plan
//! made for the other one); the header says where the work zero is; each block opens with its
//! comment (`; scratch N (cut K of T)`: N the design's scratch number, K the place in the cut
//! order; `; mark +x edge (cut K of T)` for the orientation mark, `; mark corner -x -y hatch 3
//! (cut K of T)` for a registration mark's hatch line). Lines stay under 80
//! characters and end in `\n` only.
use std::fmt::Write as _;

use super::plan::{Block, Cut};
use scratchart_tool::machine::{Firmware, MachineProfile};

/// Numbers as G-code wants them: fixed decimals, no exponent, no negative zero.
fn num(x: f64, decimals: usize) -> String {
    let s = format!("{:.*}", decimals, x);
    if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// How the program starts: whether it homes (Marlin: `--home`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Options {
    /// Marlin only: raise Z by the safe height (relative move), home X and Y (`G28 X Y`) and set
    /// the work zero at the centre of the bed (`G92`, with the bed as the profile's X/Y travel):
    /// for printers whose X/Y home is the bed's (0, 0) corner and a plate centred on the bed. Z is
    /// never homed (a printer homes Z by lowering the head onto the bed) and keeps its zero.
    pub home: bool,
}

/// The G-code of `cuts` (in order) for machine `m`. `summary` lines go into the header as
/// comments (travel, time, the tool).
pub fn write(cuts: &[Cut], m: &MachineProfile, plate_mm: f64, summary: &[String]) -> String {
    let blocks: Vec<Block> = cuts.iter().map(Block::flat).collect();
    write_blocks(&blocks, m, plate_mm, summary, &Options::default())
}

/// Header comment lines, folded at spaces so that every line stays under 80 characters; a word
/// longer than a line is split across lines, never cut short.
fn comment(g: &mut String, s: &str) {
    const WIDTH: usize = 74;
    let mut line = String::new();
    for word in s.split(' ') {
        if !line.is_empty() && line.len() + 1 + word.len() > WIDTH {
            let _ = writeln!(g, "; {line}");
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        let mut rest = word;
        while line.len() + rest.len() > WIDTH {
            let mut cut = WIDTH - line.len();
            while !rest.is_char_boundary(cut) {
                cut -= 1;
            }
            line.push_str(&rest[..cut]);
            let _ = writeln!(g, "; {line}");
            line.clear();
            rest = &rest[cut..];
        }
        line.push_str(rest);
    }
    if !line.is_empty() {
        let _ = writeln!(g, "; {line}");
    }
}

/// One arc move from `a` to `b` (the same Z) with DXF's `bulge`: G3 counter-clockwise (bulge >
/// 0), G2 clockwise, I and J the centre relative to `a` (GRBL's and Marlin's incremental arc
/// centre, the default).
fn arc_line(a: &[f64; 3], b: &[f64; 3], bulge: f64, feed: &str) -> String {
    let g = scratchart_model::arc::ArcGeom::of([a[0], a[1]], [b[0], b[1]], bulge).expect("an arc block has an arc");
    format!(
        "{} X{} Y{} I{} J{} F{feed}",
        if bulge > 0.0 { "G3" } else { "G2" },
        num(b[0], 4),
        num(b[1], 4),
        num(g.centre[0] - a[0], 4),
        num(g.centre[1] - a[1], 4)
    )
}

/// The G-code of a program of blocks (in order) for machine `m`.
///
/// GRBL: `G21 G90 G94`, `G54` (the work offset the user set), rapids (`G0`) at safe Z, plunges
/// at the plunge feed, cuts at the cut feed, the spindle on (`M3`, with a dwell) and off (`M5`),
/// `M2` at the end. Marlin: `G21`, `G90`, homing only with [`Options::home`], no spindle
/// commands, a feed on every move (Marlin's G0 and G1 share one modal feed), every Z move at the
/// printer's Z feed (`plunge_mm_min`), `M400` (wait for the moves to finish) at the end.
///
/// Every block ends with its retract `G0 Z<safe>`; the orientation mark comes after the last
/// scratch, so a streamer that splits the plan at `; scratch N` comments keeps it with the last
/// scratch and never replays it with the preamble. An arc block is one G2 or G3 move.
pub fn write_blocks(blocks: &[Block], m: &MachineProfile, plate_mm: f64, summary: &[String], opt: &Options) -> String {
    let mut g = String::new();
    let fw = match m.firmware {
        Firmware::Grbl => "grbl",
        Firmware::Marlin => "marlin",
    };
    let marlin = m.firmware == Firmware::Marlin;
    let _ = writeln!(g, "; scratchart plan machine={fw}");
    let _ = writeln!(g, "; work zero: X0 Y0 at the plate centre, Z0 on the plate surface");
    if marlin && opt.home {
        comment(
            &mut g,
            &format!(
                "homes X and Y (G28 X Y) and puts X0 Y0 at the centre of the {} x {} mm bed: \
                 the plate must lie centred on the bed; Z is not homed: touch the tip on the plate \
                 and set Z0 (G92 Z0) first",
                num(m.travel_mm[0], 1),
                num(m.travel_mm[1], 1)
            ),
        );
    } else if marlin {
        comment(
            &mut g,
            "no homing: set the zero with the tip on the plate centre (G92 X0 Y0 Z0)",
        );
    }
    let _ = writeln!(
        g,
        "; plate {} mm square, its +x edge along machine +X; {} blocks",
        num(plate_mm, 1),
        blocks.len()
    );
    for s in summary {
        comment(&mut g, s);
    }
    let safe = num(m.clearance_mm, 3);
    let retract = num(m.retract_mm, 3);
    let zf = num(m.plunge_mm_min, 0);
    let cf = num(m.cut_mm_min, 0);
    let rf = num(m.rapid_mm_min, 0);
    match m.firmware {
        Firmware::Grbl => {
            let _ = writeln!(g, "G21 G90 G94");
            let _ = writeln!(g, "G54");
            let _ = writeln!(g, "G0 Z{safe}");
        }
        Firmware::Marlin => {
            let _ = writeln!(g, "G21");
            let _ = writeln!(g, "G90");
            if opt.home {
                let _ = writeln!(g, "G91");
                let _ = writeln!(g, "G1 Z{safe} F{zf}");
                let _ = writeln!(g, "G90");
                let _ = writeln!(g, "G28 X Y");
                let _ = writeln!(
                    g,
                    "G92 X{} Y{}",
                    num(-0.5 * m.travel_mm[0], 4),
                    num(-0.5 * m.travel_mm[1], 4)
                );
            }
            let _ = writeln!(g, "G0 Z{safe} F{zf}");
        }
    }
    if let (Firmware::Grbl, Some(rpm)) = (m.firmware, m.spindle_rpm) {
        let _ = writeln!(g, "M3 S{}", num(rpm, 0));
        let _ = writeln!(g, "G4 P{}", num(crate::plan::SPINDLE_DWELL_S, 0));
    }
    let xy = |p: &[f64; 3]| format!("X{} Y{}", num(p[0], 4), num(p[1], 4));
    let z_to = |h: &str| match m.firmware {
        Firmware::Grbl => format!("G0 Z{h}"),
        Firmware::Marlin => format!("G0 Z{h} F{zf}"),
    };
    // Between neighbouring cuts the tool waits at the retract height; a long travel (and the
    // first) goes at the clearance height ([`crate::plan::Hop`]).
    let mut at = [0.0, 0.0];
    let mut high = true;
    for (i, b) in blocks.iter().enumerate() {
        // The design's number, and where it comes in the cut order (as `carve` counts).
        let _ = writeln!(g, "; {} (cut {} of {})", b.label, i + 1, blocks.len());
        let first = &b.path[0];
        let hop = crate::plan::Hop::of(m, at, [first[0], first[1]], high);
        if hop.rise {
            let _ = writeln!(g, "{}", z_to(&safe));
        }
        let _ = match m.firmware {
            Firmware::Grbl => writeln!(g, "G0 {}", xy(first)),
            Firmware::Marlin => writeln!(g, "G0 {} F{rf}", xy(first)),
        };
        if hop.descend {
            let _ = writeln!(g, "{}", z_to(&retract));
        }
        let _ = writeln!(g, "G1 Z{} F{zf}", num(first[2], 4));
        let mut z = first[2];
        if b.bulge != 0.0 && b.path.len() == 2 {
            let _ = writeln!(g, "{}", arc_line(first, &b.path[1], b.bulge, &cf));
            let last = b.path[1];
            let _ = writeln!(g, "{}", z_to(&retract));
            at = [last[0], last[1]];
            high = false;
            continue;
        }
        for p in &b.path[1..] {
            if num(p[2], 4) == num(z, 4) {
                let _ = writeln!(g, "G1 {} F{cf}", xy(p));
            } else {
                let _ = writeln!(g, "G1 {} Z{} F{cf}", xy(p), num(p[2], 4));
            }
            z = p[2];
        }
        let _ = writeln!(g, "{}", z_to(&retract));
        let last = b.path[b.path.len() - 1];
        at = [last[0], last[1]];
        high = false;
    }
    let _ = writeln!(g, "{}", z_to(&safe));
    match m.firmware {
        Firmware::Grbl => {
            if m.spindle_rpm.is_some() {
                let _ = writeln!(g, "M5");
            }
            let _ = writeln!(g, "G0 X0 Y0");
            let _ = writeln!(g, "M2");
        }
        Firmware::Marlin => {
            let _ = writeln!(g, "G0 X0 Y0 F{rf}");
            let _ = writeln!(g, "M400");
        }
    }
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_comments_keep_every_character() {
        // A tool record as `plan` writes it, and one word longer than any line.
        let record = r#"tool {"kind": "profile", "depths_mm": [0.001, 0.002, 0.004, 0.008, 0.016, 0.032], "widths_mm": [0.0101, 0.0202, 0.0404, 0.0808, 0.1616, 0.3232], "z_offset_mm": 0.007, "alpha": 0.1}"#;
        let long = "x".repeat(200);
        for s in [record.to_string(), long.clone(), format!("a {long} b")] {
            let mut g = String::new();
            comment(&mut g, &s);
            assert!(g.lines().all(|l| l.len() < 80 && l.starts_with("; ")), "{g}");
            // Lines joined (at a space where the fold was at one) give the text back.
            let pieces: Vec<&str> = g.lines().map(|l| &l[2..]).collect();
            let joined_tight = pieces.concat();
            assert_eq!(joined_tight.replace(' ', ""), s.replace(' ', ""), "{g}");
        }
        let mut g = String::new();
        comment(&mut g, record);
        let text: Vec<&str> = g.lines().map(|l| &l[2..]).collect();
        let json: serde_json::Value = serde_json::from_str(&text.join(" ")["tool ".len()..]).unwrap();
        assert_eq!(json["alpha"], 0.1);
        assert_eq!(json["widths_mm"][5], 0.3232);
    }
}
