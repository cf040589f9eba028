//! The `scratchart design` subcommand: flags, problem setup (views, lights, initial scratches,
//! targets), the call into [`scratchart::optim::design::run_design`] and the printed summary.
//! In the library so that the viewer's live design (`scratchart-view --design`) takes the same
//! flags and makes the same problem: a design it saves is one `scratchart design --resume`
//! continues bit for bit.
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context as _;

use scratchart::limits::{largest_fitting, SceneDims};
use scratchart::model::scene::{Plate, Scene, View};
use scratchart::observe::Observer;
use scratchart::optim::design::{run_design, DesignConfig, Hooks, Problem};
use scratchart::scenes::{framed_ring_views, orbit_light, random_scratches, Rng};
use scratchart::vulkan::{Context, DeviceInfo};

/// Fails with a [`scratchart::exit::UsageError`] (exit code 2) unless the flag condition holds.
macro_rules! ensure_flag {
    ($cond:expr, $($msg:tt)*) => {
        if !$cond {
            return Err(scratchart::exit::UsageError(format!($($msg)*)).into());
        }
    };
}

/// The default lamp stands this many degrees above the views' elevation (at most 80)...
pub const LIGHT_ELEVATION_ABOVE_VIEWS: f64 = 20.0;
/// ... and this many times the views' distance from the plate centre.
pub const LIGHT_DISTANCE_FACTOR: f64 = 1.0;

/// Scratches of a design without --scratches (a walk has 1000 per walk view, at least this).
pub const DEFAULT_SCRATCHES: usize = 6000;

mod args;
mod print;
mod walk;

pub use args::{DesignArgs, ExposureMode};
use print::{job_limit_text, machine_error_text, walk_text};
use walk::{walk_arc, walk_problem};

/// The lamp of `args` for views at `distance` (its azimuth `default_azimuth` unless
/// --light-azimuth is given); its intensity a placeholder, calibrated against the targets before
/// the first step.
fn lamp(args: &DesignArgs, distance: f64, default_azimuth: f64) -> anyhow::Result<scratchart::model::scene::Light> {
    let light_elevation = args
        .light_elevation
        .unwrap_or((args.elevation + LIGHT_ELEVATION_ABOVE_VIEWS).min(80.0));
    ensure_flag!(
        light_elevation > 0.0 && light_elevation <= 90.0,
        "--light-elevation must lie above 0 and at most 90 degrees"
    );
    let light_distance = args.light_distance.unwrap_or(LIGHT_DISTANCE_FACTOR * distance);
    ensure_flag!(
        light_distance.is_finite() && light_distance > 0.0,
        "--light-distance must be a distance above 0 mm"
    );
    let azimuth = args.light_azimuth.unwrap_or(default_azimuth);
    ensure_flag!(azimuth.is_finite(), "--light-azimuth must be a number of degrees");
    Ok(orbit_light(light_distance, light_elevation, azimuth, 1.0e4))
}

/// Builds the problem (views, initial scratches, targets) of `args`.
pub fn problem(args: &DesignArgs, info: &DeviceInfo) -> anyhow::Result<Problem> {
    let plate_mm = args.plate;
    ensure_flag!(plate_mm > 0.0, "--plate must be > 0 mm");
    let walk = walk_arc(args)?;
    let n_scratches = args.scratches.unwrap_or_else(|| {
        walk.as_ref()
            .map_or(DEFAULT_SCRATCHES, |a| (1000 * a.views).max(DEFAULT_SCRATCHES))
    });
    ensure_flag!(n_scratches > 0, "--scratches must be at least 1");
    check_scratch_flags(args)?;
    let plate = Plate {
        size_mm: plate_mm,
        roughness: scratchart::model::scene::DEFAULT_ROUGHNESS,
        f0: scratchart::model::scene::DEFAULT_F0,
    };
    let (views, between) = design_views(args, walk.as_ref(), &plate)?;
    check_size(args, &views, n_scratches, info)?;
    for w in views.iter().flat_map(scratchart::limits::view_warnings) {
        eprintln!("warning: {w}");
    }
    let mut rng = Rng::new(args.seed);
    let scratches = random_scratches(
        &mut rng,
        n_scratches,
        plate_mm,
        0.01 * args.len_min_pct * plate_mm,
        0.01 * args.len_max_pct * plate_mm,
        args.init_w,
        args.init_d,
        args.init_alpha,
    );
    let scene = Scene {
        plate,
        views,
        scratches,
    };
    scene.validate()?;
    check_target_flags(args, &scene, walk.is_some())?;
    if let Some(arc) = walk {
        return walk_problem(args, scene, arc, between);
    }
    if args.targets.is_empty() {
        let targets = scratchart::optim::targets::builtin_targets(&scene);
        return Ok(Problem::new(scene, targets));
    }
    picture_problem(args, scene)
}

/// The flags of the initial scratches and of the learning rates, each within its range.
fn check_scratch_flags(args: &DesignArgs) -> anyhow::Result<()> {
    ensure_flag!(args.init_w > 0.0, "--init-w must be > 0 mm (it is {})", args.init_w);
    ensure_flag!(args.init_d > 0.0, "--init-d must be > 0 mm (it is {})", args.init_d);
    ensure_flag!(
        args.init_alpha > 0.0 && args.init_alpha < 1.0,
        "--init-alpha must lie strictly between 0 and 1 (it is {})",
        args.init_alpha
    );
    for (flag, v) in [
        ("--lr-end", args.lr_end),
        ("--lr-w", args.lr_w),
        ("--lr-d", args.lr_d),
        ("--lr-alpha", args.lr_alpha),
        ("--lr-light", args.lr_light),
    ] {
        if let Some(v) = v {
            ensure_flag!(v.is_finite() && v >= 0.0, "{flag} must be a number >= 0 (it is {v})");
        }
    }
    ensure_flag!(
        args.len_min_pct > 0.0 && args.len_max_pct >= args.len_min_pct && args.len_max_pct < 100.0,
        "--len-min-pct / --len-max-pct must satisfy 0 < min <= max < 100"
    );
    Ok(())
}

/// The design's views: from `--view-file`, along a walk's arc (with the views between its
/// frames), or a ring of `--views` framed on the plate.
fn design_views(
    args: &DesignArgs,
    walk: Option<&scratchart::optim::walk::WalkArc>,
    plate: &Plate,
) -> anyhow::Result<(Vec<View>, Vec<scratchart::optim::walk::BetweenView>)> {
    let plate_mm = plate.size_mm;
    let distance = 3.0 * plate_mm;
    let mut between = Vec::new();
    let views: Vec<View> = match &args.view_file {
        Some(path) => {
            let text =
                std::fs::read_to_string(path).with_context(|| format!("cannot read view file `{}`", path.display()))?;
            let arr: serde_json::Value = serde_json::from_str(&text)
                .with_context(|| format!("view file `{}` is not valid JSON", path.display()))?;
            anyhow::ensure!(
                arr.as_array().is_some_and(|a| !a.is_empty()),
                "view file `{}` must hold a non-empty JSON array of view objects (engine/docs/model.md section 6)",
                path.display()
            );
            let doc = serde_json::json!({
                "plate": {"size_mm": plate.size_mm, "roughness": plate.roughness, "f0": plate.f0},
                "views": arr,
                "scratches": [],
            });
            let base = path.parent().map(PathBuf::from).unwrap_or_default();
            Scene::from_json_str(&doc.to_string(), &base, &path.display().to_string())?.views
        }
        None => {
            ensure_flag!(args.res >= 8, "--res must be at least 8 pixels");
            ensure_flag!(
                args.elevation > 0.0 && args.elevation < 90.0,
                "--elevation must lie strictly between 0 and 90 degrees"
            );
            match walk {
                Some(arc) => {
                    let light = lamp(args, arc.distance_mm, arc.centre_azimuth_deg)?;
                    let (views, b) = scratchart::optim::walk::arc_views(arc, plate_mm, &light);
                    between = b;
                    views
                }
                None => {
                    ensure_flag!(args.views >= 1, "--views must be at least 1");
                    // Initial intensity: a placeholder, calibrated against the targets before the first step.
                    let light = lamp(args, distance, 0.0)?;
                    // The plate's silhouette fills 95% of each frame (width or height, whichever binds).
                    framed_ring_views(args.views, args.elevation, distance, plate_mm, args.res, &light, 0.95)
                }
            }
        }
    };
    Ok((views, between))
}

/// The flags of the targets (background, gamma, blank views), against the scene's views.
fn check_target_flags(args: &DesignArgs, scene: &Scene, walk: bool) -> anyhow::Result<()> {
    ensure_flag!(
        (0.0..=1.0).contains(&args.background),
        "--background must lie between 0 (black) and 1 (white) (it is {})",
        args.background
    );

    ensure_flag!(
        args.gamma > 0.0 && args.gamma.is_finite(),
        "--gamma must be > 0 (it is {})",
        args.gamma
    );
    for b in &args.blank_view {
        ensure_flag!(
            scene.views.iter().any(|v| &v.name == b),
            "--blank-view {b}: no view is named so (the views: {})",
            scene
                .views
                .iter()
                .map(|v| v.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    ensure_flag!(
        args.blank_view.is_empty() || !args.targets.is_empty() || walk,
        "--blank-view needs --targets or --walk (the built-in shapes are never blank)"
    );
    Ok(())
}

/// The problem of pictures given with `--targets`: each fitted into its view (`--fit`,
/// `--background`, `--gamma`), blank views left free, the sources kept for steering.
fn picture_problem(args: &DesignArgs, scene: Scene) -> anyhow::Result<Problem> {
    let pictures = scratchart::optim::targets::read_pictures(&args.targets, &scene, &args.blank_view)?;
    let mut fitted = scratchart::optim::targets::fit_pictures(&pictures, &scene, args.fit, args.background);
    for b in &args.blank_view {
        eprintln!("view {b}: blank on purpose (--blank-view): its picture is not asked to show anything");
    }
    if args.gamma != 1.0 {
        for f in &mut fitted {
            for (v, p) in f.image.iter_mut().zip(&f.picture) {
                if *p {
                    *v = v.powf(args.gamma);
                }
            }
        }
    }
    let mut problem = Problem::new(scene, fitted.iter().map(|f| f.image.clone()).collect());
    problem.picture_rects = fitted.iter().map(|f| f.rect).collect();
    problem.pictures = fitted.into_iter().map(|f| f.picture).collect();
    // Each picture as read, for steering (pictures placed in a rectangle only).
    problem.sources = pictures
        .into_iter()
        .zip(&problem.picture_rects)
        .map(|(p, rect)| {
            Some(scratchart::optim::steer::Source {
                width: p.width,
                height: p.height,
                data: p.data,
                fit: args.fit,
                background: args.background,
                gamma: args.gamma,
                rect: (*rect)?,
            })
        })
        .collect();
    Ok(problem)
}

/// The configuration of `args`.
pub fn config(args: &DesignArgs) -> DesignConfig {
    let mut cfg = DesignConfig::new(args.plate, args.out.clone());
    cfg.started = Some(scratchart::exit::process_start());
    cfg.iters = args.iters;
    cfg.seed = args.seed;
    cfg.loss.lambda_p = args.lambda_p;
    cfg.loss.lambda_g = args.lambda_g;
    cfg.loss.sigma = args.blur_sigma;
    let a = &mut cfg.adam;
    a.lr_end = args.lr_end.unwrap_or(a.lr_end);
    a.lr_w = args.lr_w.unwrap_or(a.lr_w);
    a.lr_d = args.lr_d.unwrap_or(a.lr_d);
    a.lr_alpha = args.lr_alpha.unwrap_or(a.lr_alpha);
    a.lr_light = args.lr_light.unwrap_or(a.lr_light);
    cfg.checkpoint_every = args.checkpoint_every;
    cfg.resume = args.resume;
    cfg.prune.tol = args.prune_tol;
    cfg.prune.max_trials = args.prune_trials;
    cfg.calibrate_lights = args.view_file.is_none();
    cfg.blank_views = args.blank_view.clone();
    cfg.keep_exposures = args.exposure == ExposureMode::Fixed;
    cfg.hooks = Hooks {
        nan_grad_at: args.inject_nan_grad_at,
        nan_image_at: None,
        stop_at: args.inject_stop_at,
    };
    cfg
}

/// Checks the job's size against the device and the host before anything is computed; the
/// error names the flag to change and the largest value that fits.
fn check_size(args: &DesignArgs, views: &[View], n_scratches: usize, info: &DeviceInfo) -> anyhow::Result<()> {
    let sizes: Vec<(u32, u32)> = views.iter().map(|v| (v.camera.width, v.camera.height)).collect();
    let n = n_scratches as u64;
    let Err(why) = SceneDims::new(&sizes, n, true).check(info) else {
        return Ok(());
    };
    let fits = |sizes: &[(u32, u32)], n: u64| SceneDims::new(sizes, n, true).check(info).is_ok();
    let max_n = largest_fitting(n, |k| fits(&sizes, k));
    let hint = if args.view_file.is_none() {
        let nv = views.len();
        let max_res = largest_fitting(args.res as u64, |r| fits(&vec![(r as u32, r as u32); nv], n));
        if max_res > 0 && max_res < args.res as u64 {
            let with = if args.arc.is_some() {
                format!("the walk's {nv} views (in-between views included; fewer with --between 0)")
            } else {
                format!("--views {nv}")
            };
            format!("use a smaller --res: the largest that fits with {with} and --scratches {n} is {max_res}")
        } else if max_n > 0 {
            format!("use fewer --scratches: at --res {} at most {max_n} fit", args.res)
        } else {
            "use a smaller --res and fewer --views or --scratches".into()
        }
    } else if max_n > 0 && max_n < n {
        format!("use fewer --scratches: with these views at most {max_n} fit")
    } else {
        "use smaller views in the --view-file (width x height) or fewer views".into()
    };
    Err(scratchart::exit::UsageError(format!("this design is too large: {why}; {hint}")).into())
}

/// This command line with `--resume` added (what continues an interrupted run).
fn resume_command() -> String {
    let mut args: Vec<String> = std::env::args().collect();
    if let Some(first) = args.first_mut() {
        *first = "scratchart".into();
    }
    // The viewer's live design (`scratchart-view --design ...`): the same run is `scratchart
    // design` with the design's flags (the live view's own left out).
    if let Some(i) = args.iter().position(|a| a == "--design") {
        let mut design = vec!["scratchart".to_string(), "design".to_string()];
        let mut rest = args[1..i].iter().chain(&args[i + 1..]);
        while let Some(a) = rest.next() {
            match a.as_str() {
                "--headless" | "--paused" | "--log-frames" | "--validation" => {}
                "--size" | "--device" | "--exit-after" | "--script" => {
                    rest.next();
                }
                _ if ["--size=", "--device=", "--exit-after=", "--script="]
                    .iter()
                    .any(|p| a.starts_with(p)) => {}
                _ => design.push(a.clone()),
            }
        }
        args = design;
    }
    if !args.iter().any(|a| a == "--resume") {
        args.push("--resume".into());
    }
    args.iter()
        .map(|a| {
            if a.contains(char::is_whitespace) {
                format!("'{a}'")
            } else {
                a.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs `scratchart design`.
pub fn run(ctx: &Arc<Context>, args: &DesignArgs, obs: &dyn Observer) -> anyhow::Result<()> {
    let (problem, cfg) = prepare(ctx, args, obs)?;
    let result = match args.max_job_min {
        Some(limit) => scratchart::optim::job_limit::run_design_within(ctx, &problem, &cfg, limit, obs),
        None => run_design(ctx, &problem, &cfg, obs),
    };
    finish(result, &cfg)
}

/// The problem and configuration of `scratchart design ARGS` (every flag checked), as the
/// command runs it; `scratchart-view --design` runs the same.
pub fn prepare(ctx: &Arc<Context>, args: &DesignArgs, obs: &dyn Observer) -> anyhow::Result<(Problem, DesignConfig)> {
    ensure_flag!(args.blur_sigma > 0.0, "--blur-sigma must be > 0");
    // What only a design for a machine has.
    let machine_given = args.machine.is_some() || args.machine_file.is_some();
    for (given, flag) in [
        (args.min_length_mm.is_some(), "--min-length-mm"),
        (args.robust, "--robust"),
        (args.max_job_min.is_some(), "--max-job-min"),
    ] {
        if given && !machine_given {
            return Err(scratchart::exit::UsageError(format!(
                "{flag} needs the machine: --machine grbl|marlin or --machine-file machine.json (with --tool)"
            ))
            .into());
        }
    }
    let mut problem = problem(args, ctx.info())?;
    if args.targets.is_empty() && problem.walk.is_none() {
        let names: Vec<&str> = (0..problem.scene.views.len())
            .map(|j| scratchart::optim::targets::SHAPES[j % scratchart::optim::targets::SHAPES.len()])
            .collect();
        obs.info(&format!(
            "no --targets given: using the built-in shapes ({})",
            names.join(", ")
        ));
    }
    let mut cfg = config(args);
    if let Some(path) = &args.tool {
        let fab = scratchart::optim::tool_params::Fabrication::load(
            path,
            args.init_alpha,
            "--init-alpha (the design's default scratch alpha; the tool file has no `alpha`)",
            cfg.adam.lr_d,
            &cfg.adam,
        )
        .map_err(scratchart::exit::InputError)?;
        let fab = match machine_limits(args, &fab)? {
            Some(limits) => {
                // The projection after every step keeps each scratch at least this long.
                // (2e-4 mm more: the endpoints are f32 on the GPU and 4 decimals in the G-code, so
                // a scratch read back from either is still no shorter than asked.)
                cfg.adam.min_len = cfg.adam.min_len.max((limits.min_length_mm + 2e-4) as f32);
                let fab = fab
                    .with_machine(limits, &cfg.adam)
                    .map_err(scratchart::exit::InputError)?;
                if args.robust {
                    fab.with_robust(cfg.seed as u32).map_err(scratchart::exit::InputError)?
                } else {
                    fab
                }
            }
            None => fab,
        };
        cfg.carvings = args.carvings;
        cfg.tool = Some(fab);
    }
    problem.init = Some(scratchart::optim::steer::ScratchInit {
        len_mm: (
            0.01 * args.len_min_pct * problem.scene.plate.size_mm,
            0.01 * args.len_max_pct * problem.scene.plate.size_mm,
        ),
        w: args.init_w,
        d: args.init_d,
        alpha: args.init_alpha,
    });
    if let Some(path) = &args.steer {
        ensure_flag!(
            args.max_job_min.is_none(),
            "--steer and --max-job-min cannot be used together"
        );
        let events = scratchart::optim::steer::read(path).map_err(scratchart::exit::InputError)?;
        for e in &events {
            scratchart::optim::steer::check(e, &problem.scene.views, &problem.sources)
                .map_err(scratchart::exit::UsageError)?;
            ensure_flag!(
                !(e.resizes() && cfg.tool.is_some()),
                "--steer: the event at iteration {} adds or removes scratches, which a design with --tool cannot do",
                e.iteration
            );
        }
        obs.info(&format!(
            "replaying {} steering event(s) from {}",
            events.len(),
            path.display()
        ));
        cfg.steer = events;
    }
    Ok((problem, cfg))
}

/// Prints what a design run made (the summary and its parts), or the error, with the command
/// that continues a stopped run.
pub fn finish(
    result: Result<scratchart::optim::DesignReport, scratchart::optim::OptimError>,
    cfg: &DesignConfig,
) -> anyhow::Result<()> {
    let report = match result {
        Ok(r) => r,
        Err(
            e @ scratchart::optim::OptimError::Interrupted {
                checkpoint: Some(_), ..
            },
        ) => {
            return Err(anyhow::Error::new(e).context(format!("stopped; continue with `{}`", resume_command())));
        }
        Err(e) => return Err(e.into()),
    };
    if let Some(s) = &report.summary {
        print!("{}", scratchart::optim::report::summary_text(s, &cfg.out));
        if let Some(f) = s.get("fabrication") {
            let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
            println!(
                "  fabrication: tool {} ({}), alpha {} from {}; commanded depths z_mm {:.4} .. {:.4} mm (range {:.4} .. {:.4} mm; table error w {:.1e}, d {:.1e}) in scratches.csv",
                f["tool_file"].as_str().unwrap_or("?"),
                f["tool"]["kind"].as_str().unwrap_or("?"),
                n(&f["alpha"]),
                f["alpha_from"].as_str().unwrap_or("?"),
                n(&f["z_written_mm"][0]),
                n(&f["z_written_mm"][1]),
                n(&f["z_range_mm"][0]),
                n(&f["z_range_mm"][1]),
                n(&f["table_max_rel_err_w"]),
                n(&f["table_max_rel_err_d"]),
            );
        }
        if let Some(m) = s.get("machine") {
            let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
            println!(
                "  machine ({}): cuts {:.4} mm or deeper below the surface on a {} mm Z grid, scratches {:.3} mm or longer ({}); \
                 {} of {} scratches at the shallowest cut, {} at the shortest length, {} of the {} optimized moved onto the Z grid (at most {:.2} um)",
                m["profile"].as_str().unwrap_or("?"),
                n(&m["min_cut_depth_mm"]),
                n(&m["z_step_mm"]),
                n(&m["min_length_mm"]),
                m["min_length_from"].as_str().unwrap_or("?"),
                m["at_min_cut_depth"],
                m["scratches"],
                m["at_min_length"],
                m["moved_onto_z_grid"],
                m["scratches_optimized"],
                n(&m["largest_z_grid_move_um"]),
            );
        }
        if let Some(e) = s.get("machine_error") {
            print!("{}", machine_error_text(e));
        }
        if let Some(j) = s.get("job_limit") {
            print!("{}", job_limit_text(j));
        }
        if let Some(w) = s.get("walk") {
            print!("{}", walk_text(w, &cfg.out));
        }
    }
    Ok(())
}

/// The machine limits of `--machine` / `--machine-file` for a design with this tool, or None.
fn machine_limits(
    args: &DesignArgs,
    fab: &scratchart::optim::tool_params::Fabrication,
) -> anyhow::Result<Option<scratchart::optim::tool_params::MachineLimits>> {
    use scratchart_tool::machine::{Firmware, MachineProfile};
    if args.machine.is_none() && args.machine_file.is_none() {
        return Ok(None);
    }
    let firmware = match args.machine.as_deref() {
        Some("marlin") => Firmware::Marlin,
        _ => Firmware::Grbl,
    };
    let (profile, source) = match &args.machine_file {
        Some(f) => {
            let text = std::fs::read_to_string(f).map_err(|e| {
                scratchart::exit::InputError(format!("cannot read machine profile {}: {e}", f.display()))
            })?;
            let (m, warnings) = MachineProfile::from_json(&text, firmware)
                .map_err(|e| scratchart::exit::InputError(format!("machine profile {}: {e}", f.display())))?;
            for w in warnings {
                eprintln!("warning: machine profile {}: {w}", f.display());
            }
            (m, f.display().to_string())
        }
        None => (
            MachineProfile::builtin(firmware),
            format!("built-in {}", args.machine.as_deref().unwrap_or("grbl")),
        ),
    };
    let (min_length_mm, min_length_from) = match args.min_length_mm {
        Some(l) => {
            if !(l >= 0.0 && l.is_finite()) {
                return Err(scratchart::exit::UsageError(format!("--min-length-mm {l}: a length >= 0 mm")).into());
            }
            (l, "--min-length-mm".to_string())
        }
        None => {
            // The table's range before the machine's limits: its widest groove.
            let w = fab.widest_groove_mm();
            (
                3.0 * w,
                format!("3 x the tool's widest groove in the design's depth range ({w:.4} mm)"),
            )
        }
    };
    Ok(Some(scratchart::optim::tool_params::MachineLimits {
        profile,
        source,
        min_length_mm,
        min_length_from,
    }))
}
