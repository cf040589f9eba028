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

/// `design --exposure`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ExposureMode {
    /// Each view its own exposure.
    Free,
    /// One intensity per lamp; the exposures stay.
    Fixed,
}

/// Flags of `scratchart design`. Without any, designs the built-in 3-view demo (circle, triangle,
/// star) into ./out in a few minutes on a CPU (lavapipe).
#[derive(clap::Args, Clone, Debug)]
pub struct DesignArgs {
    /// Target images, one per view in view order (PNG/JPEG, any size; converted to gray and resized
    /// to the view resolution). Default: the built-in shapes (circle, triangle, star, ...).
    #[arg(long, num_args = 1..)]
    pub targets: Vec<PathBuf>,
    /// How each target picture is placed in its view: `contain` (upright, aspect kept, as large
    /// as fits inside the plate's silhouette in that view; the rest of the plate shows
    /// --background), `frame` (stretched over the whole camera frame), `cover` (aspect kept,
    /// filling the plate's silhouette and cropping the picture) or `printed` (laid on the plate
    /// itself and seen in perspective). NAME_target.png shows the result, as the loss uses it
    #[arg(long, default_value = "contain", value_parser = parse_fit)]
    pub fit: scratchart::optim::framing::Fit,
    /// Tone curve of the pictures: each display value v becomes v^GAMMA before fitting (below 1
    /// lifts dark mid-tones, which a scratched plate renders poorly; 1 keeps the picture)
    #[arg(long, default_value_t = 1.0)]
    pub gamma: f32,
    /// Display level (0 black .. 1 white) of the plate around a fitted picture
    #[arg(long, default_value_t = 0.0)]
    pub background: f32,
    /// Leave view NAME blank on purpose: its picture may be uniform (a blank frame), which is
    /// otherwise refused (repeat for more views)
    #[arg(long, value_name = "NAME")]
    pub blank_view: Vec<String>,
    /// Number of views on the paper's ring: elevation --elevation, view j at azimuth 360 j / N
    #[arg(long, default_value_t = 3)]
    pub views: usize,
    /// A walk-past plate: the frames it plays as the viewer walks along --arc, one design view
    /// per frame, evenly spaced, in the order given (first frame at the arc's start, counter-
    /// clockwise seen from above); or one directory, whose PNG and JPEG files are taken in name
    /// order. Each frame is placed in its view as --fit says
    #[arg(long, num_args = 1.., value_name = "FRAME", conflicts_with_all = ["targets", "view_file", "views", "hold", "object"])]
    pub walk: Vec<PathBuf>,
    /// A walk that shows one picture over the whole --arc (the same frame at every view)
    #[arg(long, value_name = "PICTURE", conflicts_with_all = ["targets", "view_file", "views", "object"])]
    pub hold: Option<PathBuf>,
    /// A walk that shows a 3D object (an OBJ mesh) with parallax: the object, placed behind the
    /// plate (--object-depth) at --object-size and lit by a fixed lamp, seen from every view of
    /// the --arc, is each view's target: a scratch hologram designed by optimization
    #[arg(long, value_name = "OBJ", conflicts_with_all = ["targets", "view_file", "views"])]
    pub object: Option<PathBuf>,
    /// The walk's arc: total angle from its first view to its last, degrees (needs --walk,
    /// --hold or --object)
    #[arg(long, value_name = "DEG")]
    pub arc: Option<f64>,
    /// Azimuth of the arc's middle, degrees (counter-clockwise from the plate's +x edge); the
    /// lamp stands there too unless --light-azimuth says otherwise
    #[arg(long, value_name = "DEG")]
    pub azimuth: Option<f64>,
    /// Distance of the walk's eyes from the plate centre, mm (default 3 x --plate)
    #[arg(long, value_name = "MM")]
    pub distance: Option<f64>,
    /// Design views along the arc for --hold and --object (default: one every 5 degrees or
    /// closer, at least 2); --walk has one per frame
    #[arg(long, value_name = "N")]
    pub walk_views: Option<usize>,
    /// In-between views per pair of neighbouring walk views that join the loss, so the plate
    /// does not go dark or flicker between them: their targets are the cross-fades of their
    /// neighbours' frames (for --object, the object seen from there). 0: none
    #[arg(long, default_value_t = 1, value_name = "K")]
    pub between: usize,
    /// Views per pair of neighbouring walk views that judge the finished design without joining
    /// the loss (at 1/(K+1), 2/(K+1), ... of the way): summary.json's walk.probes and the crosses
    /// of walk.png. 0: none
    #[arg(long, default_value_t = 3, value_name = "K")]
    pub walk_probes: usize,
    /// --object: the object's largest extent, mm (default: half the plate)
    #[arg(long, value_name = "MM")]
    pub object_size: Option<f64>,
    /// --object: how far the object's centre lies behind the plate, mm (negative: in front;
    /// default: a quarter of the plate)
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    pub object_depth: Option<f64>,
    /// --object: turn the object about the plate's normal, degrees (0: the OBJ's front, +Z,
    /// faces the arc's middle, its +Y up the plate's normal)
    #[arg(long, value_name = "DEG", default_value_t = 0.0, allow_hyphen_values = true)]
    pub object_yaw: f64,
    /// Views from a file instead: a JSON array of MODEL.md view objects (their lights' intensities are used as given)
    #[arg(long, conflicts_with_all = ["views", "res", "elevation", "light_azimuth", "light_elevation", "light_distance"])]
    pub view_file: Option<PathBuf>,
    /// Number of scratches (default 6000; for a walk, 1000 per walk view, at least 6000: a plate
    /// that shows more pictures needs more scratches)
    #[arg(long)]
    pub scratches: Option<usize>,
    /// Optimization iterations
    #[arg(long, default_value_t = 200)]
    pub iters: u32,
    /// View resolution (square), pixels
    #[arg(long, default_value_t = 112)]
    pub res: u32,
    /// Seed of the random initial scratches
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Elevation of the views, degrees
    #[arg(long, default_value_t = 45.0)]
    pub elevation: f64,
    /// Azimuth of the lamp, degrees (views sit at 0, 360/N, ...; a walk's lamp defaults to its
    /// arc's middle). The default, 0, puts it on view
    /// 0's side: its mirror direction then falls between views, so no view sees the plate's own
    /// specular highlight (at 30 degrees one view does, and its target dims)
    #[arg(long, allow_hyphen_values = true)]
    pub light_azimuth: Option<f64>,
    /// Elevation of the lamp, degrees (default: 20 degrees above the views', at most 80: a lamp on
    /// a stand above the first viewer's head, where a person can stand beside it; the views' own
    /// elevation puts it in view 0's eye, as designs did before)
    #[arg(long)]
    pub light_elevation: Option<f64>,
    /// Distance of the lamp from the plate centre, mm (default: the views' distance)
    #[arg(long)]
    pub light_distance: Option<f64>,
    /// How each view's brightness is set: `fixed` (the default), views that share a lamp share its
    /// intensity and keep their exposures (1 unless a --view-file gives them), so the plate looks
    /// as rendered under the one lamp, with no adaptation; `free`, each view gets its own exposure
    /// (what an eye's adaptation or a camera does), reported on the set-up sheet as its
    /// brightness relative to the others under the lamp
    #[arg(long, value_enum, default_value_t = ExposureMode::Fixed)]
    pub exposure: ExposureMode,
    /// Plate size, mm
    #[arg(long, default_value_t = 100.0)]
    pub plate: f64,
    /// Initial scratch length range, percent of the plate size
    #[arg(long, default_value_t = 2.0)]
    pub len_min_pct: f64,
    #[arg(long, default_value_t = 8.0)]
    pub len_max_pct: f64,
    /// Initial width parameter w, depth d (mm) and roughness alpha of every scratch
    #[arg(long, default_value_t = 0.05)]
    pub init_w: f64,
    #[arg(long, default_value_t = 0.05)]
    pub init_d: f64,
    #[arg(long, default_value_t = 0.06)]
    pub init_alpha: f64,
    /// Learning rate of the endpoints, mm per step (default 1.5e-3 x plate size)
    #[arg(long)]
    pub lr_end: Option<f32>,
    /// Learning rate of w, mm per step
    #[arg(long)]
    pub lr_w: Option<f32>,
    /// Learning rate of d, mm per step
    #[arg(long)]
    pub lr_d: Option<f32>,
    /// Learning rate of alpha per step
    #[arg(long)]
    pub lr_alpha: Option<f32>,
    /// Learning rate of ln(light intensity) per step (0 keeps the lights fixed)
    #[arg(long)]
    pub lr_light: Option<f32>,
    /// Weight of the blurred squared error
    #[arg(long, default_value_t = 1.0)]
    pub lambda_p: f32,
    /// Weight of the Gram-matrix (feature statistics) term
    #[arg(long, default_value_t = 0.01)]
    pub lambda_g: f32,
    /// Standard deviation of the loss's 3x3 Gaussian blur, pixels
    #[arg(long, default_value_t = 1.0)]
    pub blur_sigma: f32,
    /// Output directory
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Write a checkpoint every N iterations (and at the end)
    #[arg(long, default_value_t = 50)]
    pub checkpoint_every: u32,
    /// Continue a stopped run from the checkpoint in --out (same flags and targets; --iters may grow)
    #[arg(long)]
    pub resume: bool,
    /// Pruning after the optimization: scratches that barely matter are removed, in batches, as
    /// long as the loss grows by at most this fraction (0.01: 1%). In short runs most random
    /// initial scratches never become visible, and pruning removes them (often 70-99%): the
    /// summary says how many were kept. 0 keeps every scratch
    #[arg(long, default_value_t = 0.01)]
    pub prune_tol: f64,
    /// Pruning: forward evaluations spent on trial batches
    #[arg(long, default_value_t = 8)]
    pub prune_trials: u32,
    /// Fabrication mode: the calibrated tool (tool.json from `scratchart-cal fit`). Each scratch
    /// then has one commanded carve depth z (learning rate --lr-d) in place of w, d and alpha;
    /// its groove is the tool's cut at z, with alpha fixed at the file's `alpha` (else
    /// --init-alpha). scratches.csv gets the column z_mm
    #[arg(long, conflicts_with_all = ["lr_w", "lr_alpha"])]
    pub tool: Option<PathBuf>,
    /// Design within a machine's limits (needs --tool): grbl or marlin, the built-in profile that
    /// `scratchart-cal plan --print-machine` prints. Every commanded depth then lies between the
    /// profile's min_cut_depth_mm below the surface and the tool's deepest, on its z_step_mm grid,
    /// and every scratch is at least --min-length-mm long; summary.json's `machine` counts the
    /// scratches each limit touched
    #[arg(long, value_parser = ["grbl", "marlin"], requires = "tool")]
    pub machine: Option<String>,
    /// The machine profile (machine.json: any fields over the built-in profile of its firmware;
    /// the fields are listed in `scratchart-cal plan --help`). Implies --machine (needs --tool)
    #[arg(long, requires = "tool")]
    pub machine_file: Option<PathBuf>,
    /// With --machine: the shortest scratch, mm (default: 3 times the tool's widest groove in the
    /// design's depth range, so that no scratch is as short as the tapered ends a plunged tool
    /// leaves, about one groove width together)
    #[arg(long)]
    pub min_length_mm: Option<f64>,
    /// With --machine: a design that survives the machine's error. Each iteration's gradient is
    /// taken on the plate carved as the machine would cut it: every commanded depth off by the
    /// profile's z_repeatability_mm, every endpoint by its xy_repeatability_mm (1 sigma), a new
    /// carving each iteration. Either way summary.json's `machine_error` gives each view's
    /// correlation with its picture as written and averaged over --carvings such carvings
    #[arg(long)]
    pub robust: bool,
    /// With --machine: how many carvings with the machine's error the written design is scored
    /// on (summary.json's `machine_error`; 0: none)
    #[arg(long, default_value_t = 8)]
    pub carvings: u32,
    /// With --machine: the longest job the maker has, minutes. The design is made as asked (in
    /// OUT/unlimited/), its job time taken as `scratchart-cal plan` makes it for the same
    /// machine, and if it is longer, the scratches that matter least go and the rest is
    /// optimized again, until the job (summed move by move from rest, an upper bound of the
    /// planner's estimate) fits. summary.json's `job_limit` says what the limit cost each view
    #[arg(long)]
    pub max_job_min: Option<f64>,
    /// Replay steering: pictures moved or scaled at given iterations, as a live design
    /// (`scratchart-view --design`) recorded them: its summary.json, or a JSON array of
    /// {"iteration", "view", "shift_px": [x, y], "scale"} (shift in pixels from where the
    /// design placed the picture, scale about its centre; pictures from --targets only) and
    /// {"iteration", "lambda_p", "lambda_g"} (the loss's weights from that iteration on)
    #[arg(long, value_name = "FILE")]
    pub steer: Option<PathBuf>,
    /// No progress bar
    #[arg(long)]
    pub quiet: bool,
    /// Test hook: fill the gradient with NaN at this iteration (exercises the rollback)
    #[arg(long, hide = true)]
    pub inject_nan_grad_at: Option<u32>,
    /// Test hook: stop with an error at the top of this iteration (after its checkpoint), as a
    /// killed run would
    #[arg(long, hide = true)]
    pub inject_stop_at: Option<u32>,
}

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

/// The walk's arc of `--walk / --hold / --object` with `--arc`, or None for a design that is
/// not a walk (whose walk flags are then refused).
fn walk_arc(args: &DesignArgs) -> anyhow::Result<Option<scratchart::optim::walk::WalkArc>> {
    use scratchart::optim::walk::{frame_files, WalkArc};
    let kinds = !args.walk.is_empty() as usize + args.hold.is_some() as usize + args.object.is_some() as usize;
    ensure_flag!(kinds <= 1, "give one of --walk, --hold and --object");
    for (set, flag) in [
        (args.object_size.is_some(), "--object-size"),
        (args.object_depth.is_some(), "--object-depth"),
        (args.object_yaw != 0.0, "--object-yaw"),
    ] {
        ensure_flag!(!set || args.object.is_some(), "{flag} belongs to --object MODEL.obj");
    }
    if kinds == 0 {
        for (set, flag) in [
            (args.arc.is_some(), "--arc"),
            (args.azimuth.is_some(), "--azimuth"),
            (args.distance.is_some(), "--distance"),
            (args.walk_views.is_some(), "--walk-views"),
            (args.between != 1, "--between"),
            (args.walk_probes != 3, "--walk-probes"),
        ] {
            ensure_flag!(
                !set,
                "{flag} belongs to a walk: give --walk FRAMES..., --hold PICTURE or --object MODEL.obj with it"
            );
        }
        return Ok(None);
    }
    let Some(arc_deg) = args.arc else {
        return Err(scratchart::exit::UsageError(
            "--walk, --hold and --object need --arc DEG: the total angle from the walk's first view to its last".into(),
        )
        .into());
    };
    let views = if args.walk.is_empty() {
        args.walk_views.unwrap_or(WalkArc::default_views(arc_deg))
    } else {
        ensure_flag!(
            args.walk_views.is_none(),
            "--walk-views is for --hold and --object: a --walk has one view per frame"
        );
        frame_files(&args.walk).map_err(scratchart::exit::UsageError)?.len()
    };
    let arc = WalkArc {
        arc_deg,
        centre_azimuth_deg: args.azimuth.unwrap_or(0.0),
        elevation_deg: args.elevation,
        distance_mm: args.distance.unwrap_or(3.0 * args.plate),
        views,
        between: args.between,
        res: args.res,
    };
    arc.check().map_err(scratchart::exit::UsageError)?;
    ensure_flag!(
        arc.centre_azimuth_deg.is_finite(),
        "--azimuth must be a number of degrees"
    );
    Ok(Some(arc))
}

/// The problem of a walk: its targets (frames, a held picture or an object's views) on the
/// walk's views and in-between views.
fn walk_problem(
    args: &DesignArgs,
    scene: Scene,
    arc: scratchart::optim::walk::WalkArc,
    between: Vec<scratchart::optim::walk::BetweenView>,
) -> anyhow::Result<Problem> {
    use scratchart::optim::walk::{frame_files, probe_views, probes, read_pictures, walk_targets, Frames, Walk};
    let mesh;
    let name = |p: &std::path::Path| p.display().to_string();
    let (source, frames_named, frames) = if let Some(obj) = &args.object {
        mesh = scratchart::model::mesh::Mesh::load_obj(obj)?;
        let size_mm = args.object_size.unwrap_or(0.5 * args.plate);
        let depth_mm = args.object_depth.unwrap_or(0.25 * args.plate);
        ensure_flag!(
            size_mm.is_finite() && size_mm > 0.0,
            "--object-size must be a size above 0 mm (it is {size_mm})"
        );
        ensure_flag!(
            depth_mm.is_finite(),
            "--object-depth must be a number of mm (it is {depth_mm})"
        );
        ensure_flag!(args.object_yaw.is_finite(), "--object-yaw must be a number of degrees");
        let placement = scratchart::model::mesh::Placement {
            size_mm,
            depth_mm,
            front_azimuth_deg: arc.centre_azimuth_deg,
            yaw_deg: args.object_yaw,
        };
        // The object's own lamp: above and to one side of the walk's middle, the same for
        // every view, so it is lit as one object.
        let key_light = scratchart::model::camera::spherical(1.0, arc.centre_azimuth_deg + 40.0, 50.0);
        (
            "object",
            vec![name(obj)],
            Frames::Object {
                mesh: &mesh,
                placement,
                key_light,
            },
        )
    } else {
        let (source, files) = match &args.hold {
            Some(h) => ("hold", vec![h.clone(); arc.views]),
            None => ("frames", frame_files(&args.walk).map_err(scratchart::exit::UsageError)?),
        };
        let pictures = read_pictures(&files, &args.blank_view)?;
        (
            source,
            files.iter().map(|f| name(f)).collect(),
            Frames::Pictures(pictures),
        )
    };
    let probe_views = probe_views(&arc, scene.plate.size_mm, &scene.views[0].light, args.walk_probes);
    let mut walk = Walk {
        arc,
        source: source.into(),
        frames: frames_named,
        between,
        probes: Vec::new(),
    };
    let fitted = walk_targets(&scene, &walk, &frames, args.fit, args.background, args.gamma);
    walk.probes = probes(
        probe_views,
        scene.plate.size_mm,
        &frames,
        args.fit,
        args.background,
        args.gamma,
    );
    let mut problem = Problem::new(scene, fitted.iter().map(|f| f.image.clone()).collect());
    problem.picture_rects = fitted.iter().map(|f| f.rect).collect();
    problem.pictures = fitted.into_iter().map(|f| f.picture).collect();
    problem.walk = Some(walk);
    Ok(problem)
}

fn parse_fit(s: &str) -> Result<scratchart::optim::framing::Fit, String> {
    s.parse()
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
    let plate = Plate {
        size_mm: plate_mm,
        roughness: scratchart::model::scene::DEFAULT_ROUGHNESS,
        f0: scratchart::model::scene::DEFAULT_F0,
    };
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
                "view file `{}` must hold a non-empty JSON array of view objects (MODEL.md section 6)",
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
            match &walk {
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
        args.blank_view.is_empty() || !args.targets.is_empty() || walk.is_some(),
        "--blank-view needs --targets or --walk (the built-in shapes are never blank)"
    );
    if let Some(arc) = walk {
        return walk_problem(args, scene, arc, between);
    }
    if args.targets.is_empty() {
        let targets = scratchart::optim::targets::builtin_targets(&scene);
        return Ok(Problem::new(scene, targets));
    }
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
    let problem = problem(args, ctx.info())?;
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
    if let Some(path) = &args.steer {
        ensure_flag!(
            args.max_job_min.is_none(),
            "--steer and --max-job-min cannot be used together"
        );
        let events = scratchart::optim::steer::read(path).map_err(scratchart::exit::InputError)?;
        for e in &events {
            scratchart::optim::steer::check(e, &problem.scene.views, &problem.sources)
                .map_err(scratchart::exit::UsageError)?;
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

/// The lines that say what the machine's error costs each view (summary.json's `machine_error`).
fn machine_error_text(e: &serde_json::Value) -> String {
    let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let mut out = format!(
        "  machine error ({} carvings, depth +-{:.1} um, position +-{:.1} um, 1 sigma; {}): correlation as written -> as carved\n",
        e["carvings"],
        1e3 * n(&e["sigma_z_mm"]),
        1e3 * n(&e["sigma_xy_mm"]),
        if e["robust"].as_bool() == Some(true) { "designed with --robust" } else { "without --robust" },
    );
    for v in e["per_view"].as_array().into_iter().flatten() {
        out += &format!(
            "    {}: {:.3} -> {:.3} +- {:.3} (worst {:.3})\n",
            v["name"].as_str().unwrap_or("?"),
            n(&v["corr_exact"]),
            n(&v["corr_carved_mean"]),
            n(&v["corr_carved_std"]),
            n(&v["corr_carved_worst"]),
        );
    }
    out
}

/// The lines that say how a walk shows its frames along its arc (summary.json's `walk`).
fn walk_text(w: &serde_json::Value, out: &std::path::Path) -> String {
    let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let corrs = |k: &str| -> Vec<f64> { w[k].as_array().into_iter().flatten().map(|e| n(&e["corr"])).collect() };
    let (views, between) = (corrs("views"), corrs("between"));
    let mean = |c: &[f64]| c.iter().sum::<f64>() / c.len().max(1) as f64;
    let mut text = format!(
        "  walk ({}): {} views over {:.1} degrees ({:.2} apart) about azimuth {:.1}; correlation with {}: min {:.3}, mean {:.3}\n",
        w["source"].as_str().unwrap_or("?"),
        views.len(),
        n(&w["arc_deg"]),
        n(&w["step_deg"]),
        n(&w["centre_azimuth_deg"]),
        if w["source"] == "object" { "the object seen from there" } else { "their frames" },
        n(&w["min_corr_views"]),
        mean(&views),
    );
    let probes = corrs("probes");
    if !between.is_empty() {
        text += &format!(
            "    {} in-between views in the loss ({} per pair), correlation with {}: min {:.3}, mean {:.3}\n",
            between.len(),
            w["between_per_pair"],
            if w["source"] == "object" {
                "the object seen from there"
            } else {
                "their neighbours' cross-fades"
            },
            n(&w["min_corr_between"]),
            mean(&between),
        );
    }
    if !probes.is_empty() {
        text += &format!(
            "    {} probes between the views, judged only (not in the loss): min {:.3}, mean {:.3}\n",
            probes.len(),
            n(&w["min_corr_probes"]),
            mean(&probes),
        );
    }
    text += &format!(
        "    wrote {0}/walk.png (correlation along the arc) and {0}/walk_sheet.png (the renders along the arc above their targets)\n",
        out.display()
    );
    text
}

/// The lines that say what `--max-job-min` did and cost (summary.json's `job_limit`).
fn job_limit_text(j: &serde_json::Value) -> String {
    let n = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let side = |k: &str| {
        format!(
            "{} scratches, {:.1} min ({:.1} at most; {})",
            j[k]["scratches"],
            n(&j[k]["job_min"]),
            n(&j[k]["job_min_upper"]),
            j[k]["shares"].as_str().unwrap_or("?")
        )
    };
    let mut out = format!(
        "  job limit {} min ({:.1} s in all; the lines above are its last stage's): without it {}; within it {}\n",
        n(&j["max_job_min"]),
        n(&j["wall_s"]),
        side("unlimited"),
        side("limited")
    );
    let costs: Vec<String> = j["corr_cost"]
        .as_array()
        .into_iter()
        .flatten()
        .zip(j["limited"]["corr"].as_array().into_iter().flatten())
        .zip(j["unlimited"]["corr"].as_array().into_iter().flatten())
        .enumerate()
        .map(|(v, ((c, l), u))| format!("v{v} {:.3} -> {:.3} ({:+.3})", n(u), n(l), -n(c)))
        .collect();
    out += &format!("    what the limit cost in correlation: {}\n", costs.join(", "));
    out
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
