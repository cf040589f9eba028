//! The one G-code writer (used by `plan`, and later by the calibration card): a plan's cuts as
//! GRBL- or Marlin-flavoured G-code. The first line names the firmware (`carve` refuses a plan
//! made for the other one); the header says where the work zero is. Lines stay under 80
//! characters and end in `\n` only.
use std::fmt::Write as _;

use super::plan::{Cut, Firmware, MachineProfile};

/// Numbers as G-code wants them: fixed decimals, no exponent, no negative zero.
fn num(x: f64, decimals: usize) -> String {
    let s = format!("{:.*}", decimals, x);
    if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// The G-code of `cuts` (in order) for machine `m`. `summary` lines go into the header as
/// comments (travel, time, the tool).
pub fn write(cuts: &[Cut], m: &MachineProfile, plate_mm: f64, summary: &[String]) -> String {
    let mut g = String::new();
    let fw = match m.firmware {
        Firmware::Grbl => "grbl",
        Firmware::Marlin => "marlin",
    };
    let _ = writeln!(g, "; scratchart plan machine={fw}");
    let _ = writeln!(g, "; work zero: X0 Y0 at the plate centre, Z0 on the plate surface");
    let _ = writeln!(
        g,
        "; plate {} mm square, its +x edge along machine +X; {} cuts",
        num(plate_mm, 1),
        cuts.len()
    );
    for s in summary {
        // Folded at spaces so every line stays under 80 characters.
        let mut line = String::new();
        for word in s.split(' ') {
            if !line.is_empty() && line.len() + 1 + word.len() > 74 {
                let _ = writeln!(g, "; {line}");
                line.clear();
            }
            if !line.is_empty() {
                line.push(' ');
            }
            line.push_str(&word[..word.len().min(74)]);
        }
        if !line.is_empty() {
            let _ = writeln!(g, "; {line}");
        }
    }
    let safe = num(m.safe_z_mm, 3);
    match m.firmware {
        Firmware::Grbl => {
            let _ = writeln!(g, "G21 G90 G94");
            let _ = writeln!(g, "G54");
        }
        Firmware::Marlin => {
            let _ = writeln!(g, "G21");
            let _ = writeln!(g, "G90");
        }
    }
    let _ = writeln!(g, "G0 Z{safe}");
    if let Some(rpm) = m.spindle_rpm {
        let _ = writeln!(g, "M3 S{}", num(rpm, 0));
        let _ = writeln!(g, "G4 P2");
    }
    let zf = num(m.plunge_mm_min, 0);
    let cf = num(m.cut_mm_min, 0);
    for c in cuts {
        let _ = writeln!(g, "; scratch {}", c.scratch + 1);
        let _ = writeln!(g, "G0 X{} Y{}", num(c.a[0], 4), num(c.a[1], 4));
        let _ = writeln!(g, "G1 Z{} F{zf}", num(-c.z, 4));
        let _ = writeln!(g, "G1 X{} Y{} F{cf}", num(c.b[0], 4), num(c.b[1], 4));
        let _ = writeln!(g, "G0 Z{safe}");
    }
    if m.spindle_rpm.is_some() {
        let _ = writeln!(g, "M5");
    }
    let _ = writeln!(g, "G0 X0 Y0");
    match m.firmware {
        Firmware::Grbl => {
            let _ = writeln!(g, "M2");
        }
        Firmware::Marlin => {
            let _ = writeln!(g, "M400");
        }
    }
    g
}
