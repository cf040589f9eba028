//! `scratchart-cal plan`: a design in, G-code and a preview PNG out; and the machine profile the
//! `plan` and `card` commands share (`--machine`, `--machine-file`, `--bed`).
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};

use scratchart_exit::{InputError, UsageError};
use scratchart_machine::gcode::{write_blocks, Options};
use scratchart_machine::level::{compensate, HeightMap};
use scratchart_machine::plan::{
    check_bounds, check_moves, nearest_neighbour, program_time_split, program_travel, surface_depth_mm, travel,
    two_opt, Block, Cut, Label,
};
use scratchart_model::scene::Scene;
use scratchart_tool::machine::{Firmware, MachineProfile};
use scratchart_tool::Tool;

mod marks;

/// The levelling tolerance: the measured surface stays within this of every G1 segment, mm.
pub const LEVEL_TOL_MM: f64 = 0.001;

/// How the groove ends are handled, stated in every plan's header.
pub const GROOVE_ENDS: &str = "groove ends: cuts are not shortened. The tool plunges at one designed endpoint \
     and lifts at the other, so the full-depth groove (its side walls, which make the picture) has \
     the designed length; the tool's own shape adds a tapered end about half a groove width long \
     beyond each endpoint, whose walls face along the groove and send little light the designed \
     way. Shortening the cuts by that much would shorten the side walls instead.";

/// The machine flags `plan` and `card` share.
#[derive(clap::Args, Debug)]
pub struct MachineArgs {
    /// Firmware of the machine: grbl (a router) or marlin (a printer with an engraving bit)
    #[arg(long, default_value = "grbl", value_parser = ["grbl", "marlin"])]
    pub machine: String,
    /// Machine profile, a JSON object of any of these fields (the rest from the built-in profile
    /// of its firmware; `plan --print-machine` prints one to start from): firmware ("grbl" or
    /// "marlin"); travel_mm ([X, Y, Z], the plate centred on X/Y); rapid_mm_min, cut_mm_min,
    /// plunge_mm_min (feeds; plunge is every Z move on Marlin); accel_mm_s2; retract_mm (height
    /// above the surface between neighbouring cuts); clearance_mm (for long travels, start and
    /// end; older name safe_z_mm); long_travel_mm (a travel longer than this rises to the
    /// clearance); z_step_mm (the Z step: designs command depths in its multiples);
    /// z_repeatability_mm (1 sigma); min_cut_depth_mm (the shallowest cut the maker trusts);
    /// spindle_rpm (or null). Default: the built-in profile of --machine
    #[arg(long)]
    pub machine_file: Option<PathBuf>,
}

/// `scratchart-cal plan`'s flags.
#[derive(clap::Args, Debug)]
pub struct PlanArgs {
    /// The design (design.json from `scratchart design`)
    #[arg(required_unless_present = "print_machine")]
    pub design: Option<PathBuf>,
    /// Print the machine profile (the built-in one of --machine, or --machine-file over it) as
    /// JSON, to start a machine.json from, and stop
    #[arg(long)]
    pub print_machine: bool,
    /// The tool (tool.json); needed unless the design's scratch CSV has a z_mm column
    #[arg(long)]
    pub tool: Option<PathBuf>,
    /// Output G-code file (default: plan.nc, or plan.gcode with --machine marlin)
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Bed (X/Y travel) WxH in mm, replacing the profile's; every move is checked against it
    #[arg(long)]
    pub bed: Option<String>,
    /// Marlin: home X and Y first (G28 X Y) and put X0 Y0 at the bed's centre (never homes Z)
    #[arg(long)]
    pub home: bool,
    /// Leave out the orientation mark at the plate's +x edge
    #[arg(long)]
    pub no_mark: bool,
    /// Leave out the registration marks: the calibration card's six hatched squares, carved after
    /// the scratches in the plate's corners (inside its edges by 2% of the plate, at least 0.5 mm),
    /// by which `scratchart-cal inspect` finds the carved plate in photos. The job is then shorter
    /// than the job time `scratchart design --machine` states (and holds to --max-job-min), which
    /// counts them
    #[arg(long)]
    pub no_marks: bool,
    /// Height map of the plate surface (heightmap.json): each cut follows the measured surface
    #[arg(long)]
    pub heightmap: Option<PathBuf>,
    /// The touch-up of a carved plate: inspect.json from `scratchart-cal inspect` (what the
    /// carving did differently from the tool's calibration). The plan then only recuts the
    /// design's scratches deeper along their own paths (metal cannot be put back) and adds new
    /// scratches where a view lacks light, as far as that brings the plate's render closer to
    /// the pictures, and says what the views gain and what it cannot fix; no marks (the plate
    /// has them). Needs the same --tool as inspect
    #[arg(long, value_name = "INSPECT_JSON")]
    pub touch_up: Option<PathBuf>,
    /// Iterations of the touch-up's optimizer (after the width ratio search): every groove's
    /// depth (never shallower than its cut) and new scratches where a view lacks light, kept only
    /// where the worst view gains. 0: the width ratio alone
    #[arg(long, default_value_t = 100, value_name = "N")]
    pub touch_up_iters: u32,
    /// New scratches the touch-up tries, as a share of the design's (0: only deeper recuts)
    #[arg(long, default_value_t = 0.25, value_name = "SHARE")]
    pub touch_up_new: f64,
    /// Write the plan even where the design cannot be carved as designed (cuts shallower than
    /// the machine's smallest trusted cut, grooves off the tool's curve); the plan's header and
    /// the output say what was forced. Without it such a design is refused (exit 2)
    #[arg(long)]
    pub force: bool,
}

/// How far a scratch's groove may lie from the tool's cut at its commanded depth, relative
/// (|dw|/w + |dd|/d), before `plan` refuses the design. A design made with `design --tool` holds
/// the tool's own grooves (to its table's interpolation error, under 0.1%); 5% is well above that
/// and well below what a design made without the tool, or with another tool, is off by (tens to
/// hundreds of percent).
pub const GROOVE_TOLERANCE: f64 = 0.05;

/// `--bed WxH` in mm.
pub fn parse_bed(s: &str) -> Result<[f64; 2]> {
    let bad = || UsageError(format!("--bed {s}: expected WxH in mm, both > 0 (for example 220x220)"));
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (f64, f64) = (
        w.trim().parse().map_err(|_| bad())?,
        h.trim().parse().map_err(|_| bad())?,
    );
    if !(w > 0.0 && h > 0.0 && w.is_finite() && h.is_finite()) {
        return Err(bad().into());
    }
    Ok([w, h])
}

/// The machine profile: the built-in one of `--machine`, or `--machine-file`; `--bed` replaces its
/// X/Y travel. The profile's firmware must agree with `--machine` when both are given.
pub fn machine_profile(machine: &str, machine_file: Option<&Path>, bed: Option<&str>) -> Result<MachineProfile> {
    let mut m = match machine {
        "marlin" => MachineProfile::marlin(),
        "grbl" => MachineProfile::grbl(),
        other => return Err(UsageError(format!("--machine {other}: expected grbl or marlin")).into()),
    };
    if let Some(f) = machine_file {
        m = load_profile(f, m.firmware)?;
    }
    if let Some(b) = bed {
        let [w, h] = parse_bed(b)?;
        m.travel_mm[0] = w;
        m.travel_mm[1] = h;
    }
    Ok(m)
}

/// Reads a machine.json ([`MachineProfile::from_json`]): the fields it gives over the built-in
/// profile of its firmware (`default` where it names none); unknown keys are warned about.
pub fn load_profile(f: &Path, default: Firmware) -> Result<MachineProfile> {
    let text = std::fs::read_to_string(f)
        .map_err(|e| InputError(format!("cannot read machine profile {}: {e}", f.display())))?;
    let (m, warnings) = MachineProfile::from_json(&text, default)
        .map_err(|e| InputError(format!("machine profile {}: {e}", f.display())))?;
    for w in warnings {
        eprintln!("warning: machine profile {}: {w}", f.display());
    }
    Ok(m)
}

/// `scratchart-cal plan`.
pub fn plan(a: &PlanArgs) -> Result<()> {
    let m = machine_profile(&a.machine.machine, a.machine.machine_file.as_deref(), a.bed.as_deref())?;
    if a.print_machine {
        println!("{}", m.to_json());
        return Ok(());
    }
    let design = a
        .design
        .as_deref()
        .ok_or_else(|| UsageError("give the design to plan".into()))?;
    let out = a.out.clone().unwrap_or_else(|| {
        PathBuf::from(match m.firmware {
            scratchart_tool::machine::Firmware::Marlin => "plan.gcode",
            scratchart_tool::machine::Firmware::Grbl => "plan.nc",
        })
    });
    let out = out.as_path();
    if let Some(inspect) = &a.touch_up {
        return touch_up(a, design, inspect, &m, out);
    }
    let (scene, extra) = Scene::load_extra(design)?;
    if a.home && m.firmware != scratchart_tool::machine::Firmware::Marlin {
        return Err(UsageError("--home is for Marlin printers (GRBL uses its own work offsets)".into()).into());
    }
    let tool = match &a.tool {
        Some(t) => Some(Tool::load(t).map_err(|e| InputError(e.to_string()))?),
        None => None,
    };
    let map = match &a.heightmap {
        Some(p) => Some(HeightMap::load(p).map_err(|e| InputError(e.to_string()))?),
        None => None,
    };
    let mut summary = Vec::new();
    let surface = plate_surface(tool.as_ref(), &extra, design, &mut summary);
    let (depths, mismatch) = plan_depths(a, &scene, &extra, tool.as_ref(), surface, &mut summary)?;
    carvable_as_designed(a, &m, &depths, &mismatch, surface, &mut summary)?;
    if let Some(t) = &tool {
        // The whole record, spaced so that the header folds it between values.
        let record = serde_json::to_string(t)?.replace(',', ", ").replace("\":", "\": ");
        summary.insert(0, format!("tool {record}"));
    }
    let cuts: Vec<Cut> = scene
        .scratches
        .iter()
        .zip(&depths)
        .enumerate()
        .map(|(k, (s, z))| Cut {
            a: s.p0,
            b: s.p1,
            z: *z,
            scratch: k,
            bulge: s.bulge,
        })
        .collect();
    let plate = scene.plate.size_mm;
    check_bounds(&cuts, plate, &m, surface).map_err(|e| InputError(format!("the plan leaves its bounds: {e}")))?;
    let t0 = travel(&cuts);
    let ordered = two_opt(nearest_neighbour(&cuts), 200);
    let mut blocks: Vec<Block> = ordered.iter().map(Block::flat).collect();
    let deepest = depths.iter().cloned().fold(0.0f64, f64::max);
    let added = marks::add_marks(
        &scene,
        &cuts,
        deepest,
        (a.no_mark, a.no_marks),
        &mut blocks,
        &mut summary,
    )?;
    if let Some(map) = &map {
        level(map, &mut blocks, a, &mut summary)?;
    }
    check_moves(&blocks, &m).map_err(|e| InputError(format!("the plan leaves its bounds: {e}")))?;
    let t1 = program_travel(&blocks);
    let split = program_time_split(&blocks, &m);
    let secs = split.total();
    summary.push(format!("travel {t0:.0} mm in design order, {t1:.0} mm ordered"));
    summary.push(format!(
        "estimated job time {:.1} min for the profile's rates (carve states the machine's own): {}{}",
        secs / 60.0,
        split.shares(),
        registration_share(&blocks, &m)
    ));
    summary.push(GROOVE_ENDS.to_string());
    let g = write_blocks(&blocks, &m, plate, &summary, &Options { home: a.home });
    if let Some(dir) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create output directory {}", dir.display()))?;
    }
    scratchart_render::io::write_atomic(out, g.as_bytes())?;
    let preview = out.with_extension("png");
    let caption = crate::toolpath::Caption {
        plan: out
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned()),
        machine: match (&a.machine.machine_file, m.firmware) {
            (Some(f), _) => format!(
                "{} ({})",
                scratchart_machine::program::Program::firmware_name(m.firmware),
                f.display()
            ),
            (None, scratchart_tool::machine::Firmware::Grbl) => "GRBL router (built-in profile)".into(),
            (None, scratchart_tool::machine::Firmware::Marlin) => "Marlin printer (built-in profile)".into(),
        },
        tool: match &tool {
            Some(t) => describe_tool(t),
            None => "depths from the design's z_mm column".into(),
        },
        seconds: secs,
    };
    crate::toolpath::write(&preview, &blocks, plate, &caption)?;
    println!(
        "wrote {} ({} cuts{}{}) and {}",
        out.display(),
        ordered.len(),
        if added.orientation { ", the +x mark" } else { "" },
        match added.hatch_cuts {
            0 => String::new(),
            n => format!(", the registration marks in {n} hatch cuts"),
        },
        preview.display()
    );
    println!(
        "  travel: {t0:.0} mm in design order -> {t1:.0} mm ordered; estimated job time {:.1} min ({})",
        secs / 60.0,
        split.shares()
    );
    for s in &summary {
        if s.starts_with("depths") {
            println!("  {s}");
        }
    }
    if !scene.plate.shape.is_flat() {
        println!(
            "  the design is for a bent plate ({}): the plan carves the flat sheet; bend it after carving as \
             the design's setup.txt says (bend_template.svg is the form at 1:1)",
            scene.plate.shape.describe()
        );
    }
    Ok(())
}

/// The registration marks' part of the job time (`scratchart_machine::marks::registration_time`),
/// for the header's job time line; empty without them.
/// `plan --touch-up`: the options checked, then [`crate::touch_up_cmd::plan_touch_up`].
fn touch_up(a: &PlanArgs, design: &Path, inspect: &Path, m: &MachineProfile, out: &Path) -> Result<()> {
    let tool = match &a.tool {
        Some(t) => Some(Tool::load(t).map_err(|e| InputError(e.to_string()))?),
        None => None,
    };
    if !(a.touch_up_new.is_finite() && (0.0..=2.0).contains(&a.touch_up_new)) {
        return Err(UsageError(format!(
            "--touch-up-new {}: give a share of the design's scratches from 0 to 2",
            a.touch_up_new
        ))
        .into());
    }
    let opts = scratchart_calibration::touch_up::refine::Options {
        iters: a.touch_up_iters,
        new_share: a.touch_up_new,
        ..Default::default()
    };
    crate::touch_up_cmd::plan_touch_up(design, tool.as_ref(), inspect, m, &opts, out)
}

fn registration_share(blocks: &[Block], m: &MachineProfile) -> String {
    if !blocks.iter().any(|b| matches!(b.label, Label::Registration { .. })) {
        return String::new();
    }
    format!(
        "; the registration marks take {:.1} min of it",
        scratchart_machine::marks::registration_time(blocks, m) / 60.0
    )
}

/// The commanded depth of the plate's surface: where the tool's z offset puts it (`--tool`),
/// or without --tool, for a design whose commanded depths are its z_mm column, where the z
/// offset of the tool it was made with puts it (its summary.json); else commanded zero.
fn plate_surface(
    tool: Option<&Tool>,
    extra: &scratchart_model::scene_file::Extra,
    design: &Path,
    summary: &mut Vec<String>,
) -> f64 {
    let offset = tool.map(|t| t.z_offset_mm()).or_else(|| {
        let o = extra.column("z_mm").and_then(|_| design_tool_offset(design))?;
        summary.push(format!(
            "the surface at commanded depth {:.4} mm: the z offset of the tool the design was made with (its summary.json)",
            -o
        ));
        Some(o)
    });
    surface_depth_mm(offset)
}

/// The z offset of the tool that `design` was made with (`summary.json` beside it,
/// `fabrication.tool`), if it says.
fn design_tool_offset(design: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(design.parent()?.join("summary.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["fabrication"]["tool"]["z_offset_mm"]
        .as_f64()
        .filter(|o| o.is_finite())
}

/// Whether the plan carves the design as it was designed: every cut at least the machine's
/// smallest trusted cut below the surface, every groove within [`GROOVE_TOLERANCE`] of the
/// tool's cut at its depth (`mismatch`, each scratch's). Otherwise a usage error naming what is
/// wrong and the fix, or, with `--force`, a warning and a line in the plan's header.
fn carvable_as_designed(
    a: &PlanArgs,
    m: &MachineProfile,
    depths: &[f64],
    mismatch: &[f64],
    surface: f64,
    summary: &mut Vec<String>,
) -> Result<()> {
    let mut problems = Vec::new();
    let shallow: Vec<usize> = (0..depths.len())
        .filter(|&k| depths[k] - surface < m.min_cut_depth_mm - 1e-9)
        .collect();
    if let Some(&k0) = shallow.iter().min_by(|&&i, &&j| depths[i].total_cmp(&depths[j])) {
        problems.push(format!(
            "{} of {} cuts are shallower than the machine's smallest trusted cut, {} mm below the surface \
             (the shallowest, scratch {}, {:.4} mm)",
            shallow.len(),
            depths.len(),
            m.min_cut_depth_mm,
            k0 + 1,
            depths[k0] - surface
        ));
    }
    let off: Vec<usize> = (0..mismatch.len())
        .filter(|&k| !(mismatch[k] <= GROOVE_TOLERANCE))
        .collect();
    if let Some(&k0) = off.iter().max_by(|&&i, &&j| mismatch[i].total_cmp(&mismatch[j])) {
        problems.push(format!(
            "{} of {} grooves are not the tool's cut at their depth (more than {:.0}% off in |dw|/w + |dd|/d; \
             the worst, scratch {}, {:.1}%): the design was made without this tool",
            off.len(),
            mismatch.len(),
            100.0 * GROOVE_TOLERANCE,
            k0 + 1,
            100.0 * mismatch[k0]
        ));
    }
    if problems.is_empty() {
        return Ok(());
    }
    let what = problems.join("; ");
    if !a.force {
        return Err(UsageError(format!(
            "{} cannot be carved as designed: {what}. Design it again for this tool and machine \
             (`scratchart design ... --tool TOOL.json --machine {}` or `--machine-file machine.json`), whose \
             depths plan uses as designed; or give --force to write this plan anyway",
            a.design.as_deref().unwrap_or(Path::new("-")).display(),
            scratchart_machine::program::Program::firmware_name(m.firmware)
        ))
        .into());
    }
    eprintln!("warning: --force: writing a plan that does not carve the design as designed: {what}");
    summary.push(format!("forced (--force): {what}"));
    Ok(())
}

/// Each scratch's commanded depth: the design's z_mm column when it has one (refused where a
/// depth lies above the plate's surface), else the tool's curve; what was used goes to `summary`.
/// With each, how far its groove lies from the tool's cut at that depth (|dw|/w + |dd|/d; empty
/// without a tool).
fn plan_depths(
    a: &PlanArgs,
    scene: &Scene,
    extra: &scratchart_model::scene_file::Extra,
    tool: Option<&Tool>,
    surface: f64,
    summary: &mut Vec<String>,
) -> Result<(Vec<f64>, Vec<f64>)> {
    Ok(match extra.column("z_mm") {
        Some(z) => {
            if let Some(k) = z.iter().position(|z| !(*z >= surface)) {
                let why = match tool {
                    Some(_) => format!(
                        "above the plate's surface, which the tool's z offset puts at commanded depth {surface} mm"
                    ),
                    None => "above the plate's surface at commanded zero; a design made with `design --tool` \
                         needs the same --tool here (its z offset moves the surface)"
                        .to_string(),
                };
                return Err(InputError(format!(
                    "{}: scratch {} has z_mm = {}: {why}",
                    a.design.as_deref().unwrap_or(Path::new("-")).display(),
                    k + 1,
                    z[k]
                ))
                .into());
            }
            let mut line = format!("depths: the design's z_mm column ({} scratches)", z.len());
            let mut mismatch = Vec::new();
            if let Some(t) = tool {
                mismatch = scene
                    .scratches
                    .iter()
                    .zip(&z)
                    .map(|(s, &z)| {
                        t.model(z)
                            .map_or(f64::INFINITY, |g| (g.w - s.w).abs() / s.w + (g.d - s.d).abs() / s.d)
                    })
                    .collect();
                let worst = mismatch.iter().cloned().fold(0.0f64, f64::max);
                line += &format!("; worst mismatch of the tool's groove at z_mm: {:.1}%", 100.0 * worst);
            }
            summary.push(line);
            (z, mismatch)
        }
        None => {
            let t = tool.ok_or_else(|| {
                UsageError(format!(
                    "{} has no z_mm column: give the tool (--tool tool.json) to map each scratch to a depth",
                    a.design.as_deref().unwrap_or(Path::new("-")).display()
                ))
            })?;
            let d = scratchart_machine::depths::depths(&scene.scratches, t, 0.5);
            let worst = d.iter().map(|d| d.1).fold(0.0f64, f64::max);
            summary.push(format!(
                "depths: the tool's curve; worst groove mismatch {:.1}% (|dw|/w + |dd|/d)",
                100.0 * worst
            ));
            d.into_iter().unzip()
        }
    })
}

/// Levels every cut by the probed height map (`--heightmap`): each becomes G1 segments that
/// follow the surface within `LEVEL_TOL_MM` (an arc first becomes the lines a controller would
/// cut it into, within `ARC_TOL_MM`); the correction's range goes to `summary`.
fn level(map: &HeightMap, blocks: &mut [Block], a: &PlanArgs, summary: &mut Vec<String>) -> Result<()> {
    let (mut lo, mut hi, mut outside, mut segs) = (f64::INFINITY, f64::NEG_INFINITY, 0usize, 0usize);
    for b in blocks.iter_mut() {
        let lines = b.moves(scratchart_machine::plan::ARC_TOL_MM);
        let depth = -lines[0][2];
        let mut path: Vec<[f64; 3]> = Vec::new();
        for w in lines.windows(2) {
            let piece = compensate(map, [w[0][0], w[0][1]], [w[1][0], w[1][1]], depth, LEVEL_TOL_MM)
                .map_err(|e| InputError(format!("{}: {e}", b.label)))?;
            let skip = usize::from(!path.is_empty());
            path.extend(piece.into_iter().skip(skip));
        }
        b.bulge = 0.0;
        for v in &path {
            lo = lo.min(v[2] + depth);
            hi = hi.max(v[2] + depth);
            if !map.covers(v[0], v[1]) {
                outside += 1;
            }
        }
        segs += path.len() - 1;
        b.path = path;
    }
    summary.push(format!(
        "levelled by {}: surface correction {:+.4} to {:+.4} mm, {segs} G1 segments for {} cuts, \
         within {LEVEL_TOL_MM} mm of the probed surface",
        a.heightmap.as_ref().unwrap().display(),
        lo,
        hi,
        blocks.len()
    ));
    println!(
        "  levelling: correction from {lo:+.4} to {hi:+.4} mm ({segs} segments for {} cuts)",
        blocks.len()
    );
    if outside > 0 {
        eprintln!("warning: {outside} cut points lie outside the probed area; their height is the nearest edge's");
    }
    Ok(())
}

/// A tool in a few words for the toolpath picture's title: its kind and numbers, in um and
/// degrees (a measured profile: its number of points).
fn describe_tool(t: &Tool) -> String {
    let v = serde_json::to_value(t).unwrap_or_default();
    let Some(o) = v.as_object() else {
        return String::new();
    };
    let mut parts = vec![o.get("kind").and_then(|k| k.as_str()).unwrap_or("tool").to_string()];
    for (k, x) in o {
        if k == "kind" || k == "alpha" {
            continue;
        }
        match (x.as_f64(), x.as_array()) {
            (Some(f), _) if k.ends_with("_deg") => {
                parts.push(format!("{} {} deg", &k[..k.len() - 4], (f * 100.0).round() / 100.0))
            }
            (Some(f), _) if k.ends_with("_mm") => {
                parts.push(format!("{} {} um", &k[..k.len() - 3], (f * 1e4).round() / 10.0))
            }
            (_, Some(a)) => parts.push(format!("{k}: {} points", a.len())),
            _ => {}
        }
    }
    parts.join(", ")
}

/// `scratchart-cal card`'s G-code: `DIR/card.nc` (GRBL) or `DIR/card.gcode` (Marlin), written
/// atomically; returns its path.
pub fn write_card_gcode(card: &scratchart_calibration::card::Card, dir: &Path, a: &MachineArgs) -> Result<PathBuf> {
    let m = machine_profile(&a.machine, a.machine_file.as_deref(), None)?;
    let g = card
        .gcode(&m)
        .map_err(|e| InputError(format!("the card does not fit the machine: {e}")))?;
    let path = dir.join(match m.firmware {
        scratchart_tool::machine::Firmware::Marlin => "card.gcode",
        scratchart_tool::machine::Firmware::Grbl => "card.nc",
    });
    scratchart_render::io::write_atomic(&path, g.as_bytes())?;
    Ok(path)
}

/// `scratchart-cal export`'s flags. The drawing holds the design's scratches and the +x mark,
/// never the registration marks `plan` carves in the plate's corners (they serve photos of the
/// carved plate, `scratchart-cal inspect`); its --help says so.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "The drawing leaves out the registration marks that `scratchart-cal plan` carves \
    after the scratches (six hatched squares in the plate's corners, by which `scratchart-cal inspect` \
    registers photos of the carved plate): a plate carved from this drawing has none."
)]
pub struct ExportArgs {
    /// The design (design.json from `scratchart design`)
    pub design: PathBuf,
    /// Write an SVG drawing (mm, +y up, one group per depth band, stroke = visible groove width)
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Write a DXF drawing (AutoCAD 2000 ASCII, mm, one layer per depth band)
    #[arg(long)]
    pub dxf: Option<PathBuf>,
    /// The tool (tool.json): band by commanded depth when the design has no z_mm column
    #[arg(long)]
    pub tool: Option<PathBuf>,
    /// Leave out the orientation mark at the plate's +x edge (as `plan --no-mark`). The
    /// registration marks `plan` carves in the corners are never in the drawing
    #[arg(long)]
    pub no_mark: bool,
}

/// `scratchart-cal export`.
pub fn export(a: &ExportArgs) -> Result<()> {
    use scratchart_machine::export::{drawing, dxf, svg, BandBy};
    if a.svg.is_none() && a.dxf.is_none() {
        return Err(UsageError("export needs --svg FILE.svg and/or --dxf FILE.dxf".into()).into());
    }
    let (scene, extra) = Scene::load_extra(&a.design)?;
    let depths = match (extra.column("z_mm"), &a.tool) {
        (Some(z), _) => Some(z),
        (None, Some(t)) => {
            let tool = Tool::load(t).map_err(|e| InputError(e.to_string()))?;
            let d = scratchart_machine::depths::depths(&scene.scratches, &tool, 0.5);
            Some(d.into_iter().map(|d| d.0).collect())
        }
        (None, None) => None,
    };
    let mut d = drawing(&scene, depths.as_deref()).map_err(|e| InputError(format!("{}: {e}", a.design.display())))?;
    if a.no_mark {
        d.mark = None;
    }
    let by = match d.by {
        BandBy::Depth => "commanded depth",
        BandBy::Width => "visible width",
    };
    for (path, text) in [
        (&a.svg, a.svg.as_ref().map(|_| svg(&d))),
        (&a.dxf, a.dxf.as_ref().map(|_| dxf(&d))),
    ] {
        if let (Some(p), Some(t)) = (path, text) {
            if let Some(dir) = p.parent().filter(|p| !p.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("cannot create output directory {}", dir.display()))?;
            }
            scratchart_render::io::write_atomic(p, t.as_bytes())?;
            println!("wrote {}", p.display());
        }
    }
    println!(
        "  {} scratches at true size on a {} mm plate, {} bands by {by}: {}",
        d.lines.len(),
        d.plate_mm,
        d.bands.len(),
        d.bands.iter().map(|b| b.name.as_str()).collect::<Vec<_>>().join(", ")
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    /// The title's numbers are as a maker reads them, not as a fit left them.
    #[test]
    fn the_tool_in_the_title_is_rounded() {
        let t = scratchart_tool::Tool::VBit {
            angle_deg: 59.99613414773586,
            tip_flat_mm: 0.012345,
            z_offset_mm: 0.0,
        };
        let s = super::describe_tool(&t);
        assert!(s.contains("angle 60 deg") && s.contains("tip_flat 12.3 um"), "{s}");
    }
}
