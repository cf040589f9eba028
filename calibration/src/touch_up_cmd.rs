//! `scratchart-cal plan DESIGN.json --tool tool.json --touch-up DIR/inspect.json --out touch.nc`:
//! the G-code of the touch-up ([`scratchart_calibration::touch_up`]): recuts of existing
//! scratches along their own paths, deeper, and new scratches (numbered past the design's),
//! in the plan's order and with the plan's checks; no marks (the plate has them).
use std::path::Path;

use anyhow::{Context as _, Result};
use scratchart_exit::{InputError, UsageError};
use scratchart_machine::gcode::{write_blocks, Options};
use scratchart_machine::plan::{
    check_bounds, check_moves, nearest_neighbour, program_time_split, surface_depth_mm, two_opt, Block, Cut,
};
use scratchart_model::scene::Scene;
use scratchart_tool::machine::MachineProfile;
use scratchart_tool::Tool;

use scratchart_calibration::touch_up::{self, Goal};

/// What `inspect` found, from its inspect.json.
struct Inspection {
    carved: Tool,
    calibrated: Tool,
    alpha: f64,
    /// The carving's shift (mm) and turn (degrees) when it sits off the design.
    moved: Option<([f64; 2], f64)>,
    /// The machine's Z moves this many times what it is told.
    depth_scale: f64,
    /// The plans the plate was inspected as carved by (`inspect --plan`), if any.
    plans: Vec<std::path::PathBuf>,
}

fn read_inspection(path: &Path) -> Result<Inspection> {
    let bad = |why: String| {
        InputError(format!(
            "{}: {why} (write it with `scratchart-cal inspect`)",
            path.display()
        ))
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read it: {e}")))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let tool = |key: &str| -> Result<Tool> {
        let t: Tool = serde_json::from_value(v[key].clone()).map_err(|e| bad(format!("no valid `{key}`: {e}")))?;
        t.validate().map_err(|e| bad(format!("`{key}`: {e}")))?;
        Ok(t)
    };
    let alpha = v["alpha"]
        .as_f64()
        .filter(|a| *a > 0.0 && *a < 1.0)
        .ok_or_else(|| bad("no valid `alpha`".into()))?;
    let f = &v["found"];
    let moved = match (
        f["moved"].as_bool(),
        f["shift_mm"][0].as_f64(),
        f["shift_mm"][1].as_f64(),
        f["turn_deg"].as_f64(),
    ) {
        (Some(true), Some(x), Some(y), Some(t)) => Some(([x, y], t)),
        _ => None,
    };
    Ok(Inspection {
        carved: tool("tool_as_carved")?,
        calibrated: tool("tool_as_calibrated")?,
        alpha,
        moved,
        plans: v["grooves_from"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|p| p.as_str())
                    .map(std::path::PathBuf::from)
                    .collect()
            })
            .unwrap_or_default(),
        depth_scale: f["depth_scale"]
            .as_f64()
            .filter(|a| *a > 0.0 && a.is_finite())
            .unwrap_or(1.0),
    })
}

/// The design's commanded depths (the grooves it asked for) and the grooves' present depths:
/// the plans' that `inspect` read (`--plan`, an earlier touch-up among them), else the design's.
/// The new scratches of an earlier touch-up (numbered past the design's) join `design` as
/// scratches of their own, designed as they were cut.
fn depths(
    design: &mut Scene,
    extra: &scratchart_model::scene_file::Extra,
    tool: &Tool,
    ins: &Inspection,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let mut designed: Vec<f64> = match extra.column("z_mm") {
        Some(z) => z,
        None => scratchart_machine::depths::depths(&design.scratches, tool, 0.5)
            .into_iter()
            .map(|d| d.0)
            .collect(),
    };
    let mut cut = designed.clone();
    // A plate inspected with the plans it was carved with (`inspect --plan`, an earlier
    // touch-up among them): its grooves are as deep as those plans left them.
    if !ins.plans.is_empty() {
        let (grooves, _) = scratchart_calibration::simulate_plate::plate_grooves(&ins.plans)?;
        let n = design.scratches.len();
        let mut added: Vec<&scratchart_machine::carved::CarvedCut> = Vec::new();
        for g in grooves.iter().filter(|g| g.label.starts_with("scratch")) {
            match g.cut.scratch.checked_sub(1) {
                Some(k) if k < n => cut[k] = cut[k].max(g.cut.z),
                Some(_) => added.push(g),
                None => {}
            }
        }
        added.sort_by_key(|g| g.cut.scratch);
        let like = design.scratches.first().copied();
        for g in added {
            if let Some(s) = like {
                design.scratches.push(scratchart_model::scene::Scratch {
                    p0: g.cut.a,
                    p1: g.cut.b,
                    bulge: g.cut.bulge,
                    ..s
                });
                designed.push(g.cut.z);
                cut.push(g.cut.z);
            }
        }
    }
    Ok((designed, cut))
}

/// Writes the touch-up plan of `design` to `out`.
pub fn plan_touch_up(
    design_file: &Path,
    tool: Option<&Tool>,
    inspect: &Path,
    m: &MachineProfile,
    opts: &touch_up::refine::Options,
    out: &Path,
) -> Result<()> {
    let tool = tool.ok_or_else(|| {
        UsageError("--touch-up needs the calibrated tool the plate was cut with (--tool tool.json)".into())
    })?;
    let ins = read_inspection(inspect)?;
    if *tool != ins.calibrated {
        return Err(UsageError(format!(
            "--tool is not the tool {} inspected the plate with: give the same tool.json",
            inspect.display()
        ))
        .into());
    }
    let (mut design, extra) = Scene::load_extra(design_file)?;
    let (designed, cut) = depths(&mut design, &extra, tool, &ins)?;
    let ctx = scratchart_vulkan::Context::new(scratchart_vulkan::ContextDesc {
        notify: Some(scratchart::term::stderr_notices()),
        ..Default::default()
    })?;
    let renderer = scratchart_render::Renderer::new(&ctx)?;
    let goal = Goal::of(design_file, &design);
    let obs = scratchart::term::Terminal::new(false);
    // Where the carving put the scratches: the recuts follow the grooves, not the design.
    let mut placed = design.clone();
    if let Some((shift, turn)) = ins.moved {
        for sc in &mut placed.scratches {
            sc.p0 = scratchart_calibration::simulate_plate::moved_point(sc.p0, shift, turn);
            sc.p1 = scratchart_calibration::simulate_plate::moved_point(sc.p1, shift, turn);
        }
    }
    // The marks where the carving put them, and the design's shortest scratch (what the
    // machine was trusted to cut): the new scratches keep to both.
    let mut marks = scratchart_machine::marks::plate_marks(design.plate.size_mm, &design.views);
    if let Some((shift, turn)) = ins.moved {
        for mk in &mut marks.marks {
            mk.centre = scratchart_calibration::simulate_plate::moved_point(mk.centre, shift, turn);
        }
    }
    let min_length_mm = design
        .scratches
        .iter()
        .map(|s| ((s.p1[0] - s.p0[0]).powi(2) + (s.p1[1] - s.p0[1]).powi(2)).sqrt())
        .fold(f64::INFINITY, f64::min);
    let carving = touch_up::Carving {
        marks: Some(&marks),
        min_length_mm,
        placed: &placed,
        cut: &cut,
        designed: &designed,
        calibrated: tool,
        carved: &ins.carved,
        alpha: ins.alpha,
        z_step: m.z_step_mm,
        depth_scale: ins.depth_scale,
    };
    let t = touch_up::plan(&renderer, &design, &carving, &goal, opts, &obs)?;
    let views: Vec<String> = design
        .views
        .iter()
        .zip(t.before.iter().zip(&t.after))
        .map(|(v, (b, a))| format!("{} {b:.3} -> {a:.3}", v.name))
        .collect();
    if t.recut.is_empty() && t.added.is_empty() {
        println!(
            "no touch-up helps this plate: no deepening of its grooves and no new scratch renders closer to {} ({}); no plan written",
            t.against,
            views.join(", ")
        );
        return Ok(());
    }
    let written = Written {
        design_file,
        inspect,
        design: &design,
        placed: &placed,
        ins: &ins,
    };
    write_touch_up(&written, &t, &views, m, out)
}

/// What the touch-up's G-code is written from.
struct Written<'a> {
    design_file: &'a Path,
    inspect: &'a Path,
    design: &'a Scene,
    /// The design's scratches where the carving put them.
    placed: &'a Scene,
    ins: &'a Inspection,
}

/// The plan's header line that says what is cut.
fn what_is_cut(t: &touch_up::TouchUp, recuts: usize, added: usize, n: usize) -> String {
    let how = match (t.optimized, t.ratio) {
        (true, _) => "to the depths the touch-up's optimizer found".to_string(),
        (false, Some(r)) => format!("to {r:.2} times the designed groove widths"),
        (false, None) => "deeper".to_string(),
    };
    format!(
        "{recuts} of {n} scratches recut deeper along their own paths, {how}; {added} new scratches (numbered from {}) \
         where a view lacked light; {} grooves are already wider than the design asks and stay (metal cannot be put back)",
        n + 1,
        t.too_wide
    )
}

/// Writes the touch-up `t` as G-code to `out` (see the module doc).
fn write_touch_up(w: &Written, t: &touch_up::TouchUp, views: &[String], m: &MachineProfile, out: &Path) -> Result<()> {
    let (design, placed, ins) = (w.design, w.placed, w.ins);
    let plate = design.plate.size_mm;
    // A groove the shifted or turned carving ran off the plate's edge is not recut (the machine
    // would cut beyond the plate).
    let on_plate = |c: &Cut| {
        c.points(0.01)
            .iter()
            .all(|p| p[0].abs() <= 0.5 * plate && p[1].abs() <= 0.5 * plate)
    };
    // The recuts in the plan's own coordinates: carved with the plate where it was and the same
    // zero, the machine puts them where it put the grooves (shifted and turned with them).
    let cut_of = |k: usize, sc: &[scratchart_model::scene::Scratch]| Cut {
        a: sc[k].p0,
        b: sc[k].p1,
        z: t.depths[k],
        scratch: k,
        bulge: sc[k].bulge,
    };
    let (kept, off): (Vec<usize>, Vec<usize>) = t.recut.iter().partition(|&&k| on_plate(&cut_of(k, &placed.scratches)));
    let mut cuts: Vec<Cut> = kept.iter().map(|&k| cut_of(k, &design.scratches)).collect();
    // The new scratches, found where the carving is, in the plan's coordinates too.
    let unmoved = |p: [f64; 2]| match ins.moved {
        Some((s, turn)) => {
            scratchart_calibration::simulate_plate::moved_point([p[0] - s[0], p[1] - s[1]], [0.0; 2], -turn)
        }
        None => p,
    };
    let n = design.scratches.len();
    cuts.extend(t.added.iter().enumerate().map(|(j, a)| Cut {
        a: unmoved(a.p0),
        b: unmoved(a.p1),
        z: a.z,
        scratch: n + j,
        bulge: 0.0,
    }));
    if !off.is_empty() {
        eprintln!(
            "warning: {} recuts left out: the carving's shift or turn ran their grooves off the plate's edge",
            off.len()
        );
    }
    let surface = surface_depth_mm(Some(ins.carved.z_offset_mm()));
    check_bounds(&cuts, plate, m, surface).map_err(|e| InputError(format!("the touch-up leaves its bounds: {e}")))?;
    let ordered = two_opt(nearest_neighbour(&cuts), 200);
    let blocks: Vec<Block> = ordered.iter().map(Block::flat).collect();
    check_moves(&blocks, m).map_err(|e| InputError(format!("the touch-up leaves its bounds: {e}")))?;
    let split = program_time_split(&blocks, m);
    let record = |t: &Tool| {
        serde_json::to_string(t)
            .unwrap_or_default()
            .replace(',', ", ")
            .replace("\":", "\": ")
    };
    let summary = vec![
        format!("touch-up of {} by {}", w.design_file.display(), w.inspect.display()),
        format!("tool as carved {}", record(&ins.carved)),
        if ins.plans.is_empty() {
            "the plate's grooves as the design's depths cut them".to_string()
        } else {
            format!(
                "the plate's grooves as {} cut them",
                ins.plans.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(" then ")
            )
        },
        format!(
            "the machine's Z moves {:.4} times what it is told (inspect's depth scale): the recuts' depths allow for it",
            ins.depth_scale
        ),
        match ins.moved {
            Some((s, t)) => format!(
                "the carving sits shifted ({:+.3}, {:+.3}) mm and turned {t:+.3} deg off the design (a zero off the \
                 plate's centre, a plate clamped askew): carve this touch-up with the plate where it was and the same \
                 zero, so that the recuts land on the grooves as the first cuts did",
                s[0], s[1]
            ),
            None => "the carving sits where the design puts it".to_string(),
        },
        what_is_cut(t, kept.len(), t.added.len(), design.scratches.len()),
        format!("correlation with {}: {}", t.against, views.join(", ")),
        format!("{} recuts left out: their grooves run off the plate's edge", off.len()),
        "no marks: the plate has them. Zero Z on the plate's surface as for the first carving".to_string(),
        format!("estimated job time {:.1} min: {}", split.total() / 60.0, split.shares()),
    ];
    let g = write_blocks(&blocks, m, plate, &summary, &Options::default());
    if let Some(dir) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create output directory {}", dir.display()))?;
    }
    scratchart_render::io::write_atomic(out, g.as_bytes())?;
    println!(
        "wrote {} ({} recuts, {} new scratches{}; {} grooves already wider stay)",
        out.display(),
        kept.len(),
        t.added.len(),
        match (t.optimized, t.ratio) {
            (true, _) => " by the touch-up's optimizer".to_string(),
            (false, Some(r)) => format!(" at {r:.2} x the designed widths"),
            (false, None) => String::new(),
        },
        t.too_wide
    );
    println!("  correlation with {}: {}", t.against, views.join(", "));
    Ok(())
}
