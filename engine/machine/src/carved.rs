//! What a plan carves: its cuts read back from the G-code (`scratchart-cal simulate-plate`,
//! and the touch-up's record of what is already in the plate). The machine is followed line by
//! line (G90/G91, G0/G1/G2/G3 with X, Y, Z, I and J): every move in the plate's plane with the
//! tool below commanded zero is a cut at commanded depth -Z (a levelled plan's segments each at
//! the mean of their ends), an arc one cut with its bulge. Several plans carved in turn on one
//! plate ([`merge`]): a later cut along a groove already there (the same ends, either way) deepens
//! it to the deeper of the two; it never makes it shallower.
use crate::plan::Cut;
use crate::program::{bulge_of, word, Program};

/// One cut of a plan, with the block it belongs to.
#[derive(Clone, Debug, PartialEq)]
pub struct CarvedCut {
    /// Ends, commanded depth (mm below commanded zero) and bulge; `scratch` is the design's
    /// scratch number (from 1) of its block, 0 for a mark's.
    pub cut: Cut,
    /// The block's label (`scratch 12`, `mark +x edge`).
    pub label: String,
}

/// The cuts of `program` in the order it makes them.
pub fn cuts(program: &Program) -> Vec<CarvedCut> {
    let mut at = [0.0f64; 3];
    let mut relative = false;
    let mut mode = 0u8; // 0 G0, 1 G1, 2 G2, 3 G3
    let mut out = Vec::new();
    let lines = program
        .preamble
        .iter()
        .map(|l| (l, None))
        .chain(
            program
                .blocks
                .iter()
                .flat_map(|b| b.lines.iter().map(move |l| (l, Some(b)))),
        )
        .chain(program.postamble.iter().map(|l| (l, None)));
    for (line, block) in lines {
        let words: Vec<&str> = line.split_whitespace().collect();
        let has = |w: &str| words.contains(&w);
        if has("G90") {
            relative = false;
        }
        if has("G91") {
            relative = true;
        }
        if has("G92") || has("G28") || words.first().is_some_and(|w| w.starts_with('M') || *w == "G4") {
            continue;
        }
        for (g, m) in [
            ("G0", 0),
            ("G00", 0),
            ("G1", 1),
            ("G01", 1),
            ("G2", 2),
            ("G02", 2),
            ("G3", 3),
            ("G03", 3),
        ] {
            if has(g) {
                mode = m;
            }
        }
        let mut to = at;
        let mut moved = false;
        for (i, c) in ['X', 'Y', 'Z'].iter().enumerate() {
            if let Some(v) = word(line, *c) {
                to[i] = if relative { at[i] + v } else { v };
                moved = true;
            }
        }
        if !moved {
            continue;
        }
        let in_plane = (to[0] - at[0]).hypot(to[1] - at[1]) > 1e-9;
        let z = 0.5 * (at[2] + to[2]);
        if mode != 0 && in_plane && z < 0.0 {
            let bulge = if mode >= 2 {
                let centre = [
                    at[0] + word(line, 'I').unwrap_or(0.0),
                    at[1] + word(line, 'J').unwrap_or(0.0),
                ];
                bulge_of([at[0], at[1]], [to[0], to[1]], centre, mode == 3)
            } else {
                0.0
            };
            out.push(CarvedCut {
                cut: Cut {
                    a: [at[0], at[1]],
                    b: [to[0], to[1]],
                    z: -z,
                    scratch: block.and_then(|b| b.scratch).unwrap_or(0),
                    bulge,
                },
                label: block.map_or_else(|| "outside the blocks".to_string(), |b| b.label.clone()),
            });
        }
        at = to;
    }
    out
}

/// Whether two cuts run along the same path (ends within `tol` mm, either way round, the same
/// arc).
fn same_path(p: &Cut, q: &Cut, tol: f64) -> bool {
    let near = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).abs() <= tol && (u[1] - v[1]).abs() <= tol;
    (near(p.a, q.a) && near(p.b, q.b) && (p.bulge - q.bulge).abs() < 1e-6)
        || (near(p.a, q.b) && near(p.b, q.a) && (p.bulge + q.bulge).abs() < 1e-6)
}

/// The grooves in a plate after `plans` were carved in turn: each later cut along an earlier
/// groove's path (ends within 1 um) deepens it to the deeper commanded depth; other cuts are
/// new grooves. Returns the grooves and how many cuts deepened one.
pub fn merge(plans: &[Vec<CarvedCut>]) -> (Vec<CarvedCut>, usize) {
    let mut grooves: Vec<CarvedCut> = Vec::new();
    let mut deepened = 0;
    // Grooves by a coarse key of their ends, for long plans.
    let key = |c: &Cut| {
        let (p, q) = if (c.a[0], c.a[1]) <= (c.b[0], c.b[1]) {
            (c.a, c.b)
        } else {
            (c.b, c.a)
        };
        [p[0], p[1], q[0], q[1]].map(|v| (v * 100.0).round() as i64)
    };
    let mut index: std::collections::HashMap<[i64; 4], Vec<usize>> = std::collections::HashMap::new();
    for plan in plans {
        for c in plan {
            let k = key(&c.cut);
            let hit = index
                .get(&k)
                .and_then(|v| v.iter().copied().find(|&i| same_path(&grooves[i].cut, &c.cut, 1e-3)));
            match hit {
                Some(i) => {
                    grooves[i].cut.z = grooves[i].cut.z.max(c.cut.z);
                    deepened += 1;
                }
                None => {
                    index.entry(k).or_default().push(grooves.len());
                    grooves.push(c.clone());
                }
            }
        }
    }
    (grooves, deepened)
}

#[cfg(test)]
mod tests {
    use super::*;

    const PLAN: &str = "; scratchart plan machine=grbl
; plate 40.0 mm square
G21 G90 G94
G0 Z2.000
M3 S10000
; scratch 3 (cut 1 of 3)
G0 X1.0000 Y2.0000
G0 Z0.300
G1 Z-0.1000 F100
G1 X5.0000 Y2.0000 F300
G0 Z0.300
; scratch 1 (cut 2 of 3)
G0 X0.0000 Y0.0000
G1 Z-0.0500 F100
G3 X2.0000 Y0.0000 I1.0000 J0.0000 F300
G0 Z0.300
; mark +x edge (cut 3 of 3)
G0 X16.0000 Y2.2500
G1 Z-0.1150 F100
G1 X19.0000 Y2.2500 F300
G0 Z0.300
G0 Z2.000
M5
G0 X0 Y0
M2
";

    /// The cuts of a plan: straight, arc (a half turn counter-clockwise: bulge 1) and mark, at
    /// their depths; travels and plunges are not cuts.
    #[test]
    fn reads_the_cuts_of_a_plan() {
        let p = Program::parse(PLAN).unwrap();
        let c = cuts(&p);
        assert_eq!(c.len(), 3, "{c:?}");
        assert_eq!(
            (c[0].cut.a, c[0].cut.b, c[0].cut.z, c[0].cut.scratch),
            ([1.0, 2.0], [5.0, 2.0], 0.1, 3)
        );
        assert!(
            (c[1].cut.bulge - 1.0).abs() < 1e-12 && c[1].cut.scratch == 1,
            "{:?}",
            c[1]
        );
        assert_eq!((c[2].label.as_str(), c[2].cut.scratch), ("mark +x edge", 0));
        // A second plan recutting scratch 3 the other way round, deeper, and a new cut.
        let again = vec![
            CarvedCut {
                cut: Cut {
                    a: [5.0, 2.0],
                    b: [1.0, 2.0],
                    z: 0.13,
                    ..c[0].cut
                },
                label: "scratch 3".into(),
            },
            CarvedCut {
                cut: Cut {
                    a: [7.0, 7.0],
                    b: [8.0, 8.0],
                    z: 0.05,
                    ..c[0].cut
                },
                label: "scratch 9".into(),
            },
        ];
        // A shallower recut leaves the groove as it was.
        let shallow = vec![CarvedCut {
            cut: Cut { z: 0.02, ..c[1].cut },
            label: "scratch 1".into(),
        }];
        let (g, deepened) = merge(&[c.clone(), again, shallow]);
        assert_eq!((g.len(), deepened), (4, 2));
        assert_eq!((g[0].cut.z, g[1].cut.z, g[3].cut.a), (0.13, 0.05, [7.0, 7.0]));
    }
}
