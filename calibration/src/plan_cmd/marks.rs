//! The marks `plan` carves after the design's scratches: the +x orientation mark (`--no-mark`
//! leaves it out) and the registration marks (`--no-marks`), the calibration card's six hatched
//! squares in the plate's corners, by which `scratchart-cal inspect` finds the carved plate in
//! photos. Each hatch line is one block, `; mark corner -x -y hatch 3`. Where they go and in what
//! order is `scratchart_machine::marks::after_scratches`, which a design's job time uses too;
//! here the header's lines on them and the check that they stay on the plate.
use anyhow::Result;

use scratchart_exit::InputError;
use scratchart_machine::export::visible_width;
use scratchart_machine::marks::{after_scratches, plate_mark_inset_mm, PlateMarks, Which};
use scratchart_machine::plan::{Block, Cut};
use scratchart_model::scene::Scene;

/// What [`add_marks`] added after the scratches.
pub struct Added {
    /// Whether the +x orientation mark was.
    pub orientation: bool,
    /// How many registration hatch cuts were (0 with `--no-marks`).
    pub hatch_cuts: usize,
}

/// Appends to `blocks` (the ordered scratches) the +x orientation mark, unless `no_mark`, then the
/// registration marks' hatches, unless `no_marks`, all at `depth` (the design's deepest commanded
/// depth); `cuts` are the design's cuts in its own order. What was added goes to `summary`.
pub fn add_marks(
    scene: &Scene,
    cuts: &[Cut],
    depth: f64,
    (no_mark, no_marks): (bool, bool),
    blocks: &mut Vec<Block>,
    summary: &mut Vec<String>,
) -> Result<Added> {
    let plate = scene.plate.size_mm;
    let widths: Vec<f64> = scene.scratches.iter().map(|s| visible_width(s.w, s.d)).collect();
    let at = blocks.last().map_or([0.0, 0.0], |b| {
        let p = b.path[b.path.len() - 1];
        [p[0], p[1]]
    });
    let which = Which {
        orientation: !no_mark,
        registration: !no_marks,
    };
    let after = after_scratches(cuts, &widths, plate, &scene.views, depth, at, which);
    let added = Added {
        orientation: after.orientation.is_some(),
        hatch_cuts: after.hatch_cuts(),
    };
    if let Some(mk) = &after.orientation {
        summary.push(format!(
            "mark: one cut at the +x edge from ({:.3}, {:.3}) to ({:.3}, {:.3}) mm, {:.4} mm deep, pointing +x; {}",
            mk.a[0],
            mk.a[1],
            mk.b[0],
            mk.b[1],
            mk.z,
            if mk.clear {
                "clear of every scratch"
            } else {
                "the scratches fill the edge: it crosses them"
            }
        ));
        if !mk.clear {
            eprintln!("warning: the design leaves no room at the +x edge: the orientation mark crosses scratches");
        }
    }
    for b in &after.blocks {
        for p in &b.path {
            if !(p[0].abs() <= 0.5 * plate + 1e-9 && p[1].abs() <= 0.5 * plate + 1e-9) {
                return Err(InputError(format!(
                    "{} reaches ({:.3}, {:.3}) mm, off the {plate} mm plate",
                    b.label, p[0], p[1]
                ))
                .into());
            }
        }
    }
    if let Some(reg) = &after.registration {
        summary.push(describe(reg, plate, cuts, depth, added.hatch_cuts));
    }
    blocks.extend(after.blocks);
    Ok(added)
}

/// The header's line on the registration marks: how many, their size and place, the hatch, and
/// how many of the design's scratches cross a mark's square (they stay in the plan).
fn describe(reg: &PlateMarks, plate: f64, cuts: &[Cut], depth: f64, hatch_cuts: usize) -> String {
    let crossing = cuts.iter().filter(|c| reg.crossed_by(&c.points(0.01))).count();
    let (side, spacing) = reg
        .marks
        .first()
        .map_or((0.0, 0.0), |m| (2.0 * m.half_mm, m.hatch_spacing_mm()));
    let crossing = match crossing {
        0 => "none of the design's scratches cross a square".to_string(),
        k => format!(
            "{k} of the design's {} scratches cross a square (the squares sit in the picture's corners): \
             they stay in the plan, and the hatch is cut over them",
            cuts.len()
        ),
    };
    format!(
        "registration marks (--no-marks leaves them out): {} hatched squares of {side:.2} mm, {:.2} mm inside \
         the plate's edges (four corners, a key on the top edge left of centre and one on the right edge \
         below centre), {hatch_cuts} hatch cuts {:.3} mm apart at {} degrees (those that glint in the \
         design's views), {depth:.4} mm deep, after the scratches; scratchart-cal inspect finds the plate \
         in photos by them; {crossing}",
        reg.marks.len(),
        plate_mark_inset_mm(plate),
        spacing,
        reg.orientations_deg
            .iter()
            .map(|o| format!("{o}"))
            .collect::<Vec<_>>()
            .join(", "),
    )
}
