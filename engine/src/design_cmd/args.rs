//! The flags of `scratchart design` ([`DesignArgs`]) and the typed specification they make.
use std::path::PathBuf;

use scratchart_design::spec::{DesignSpec, Exposure};
use scratchart_tool::machine::Firmware;

/// `design --exposure`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ExposureMode {
    /// Each view its own exposure.
    Free,
    /// One intensity per lamp; the exposures stay.
    Fixed,
}

/// `design --plate-shape`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PlateShapeArg {
    Flat,
    Cylinder,
}

/// `design --bend-axis`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BendAxisArg {
    X,
    Y,
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
    pub fit: scratchart_design::framing::Fit,
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
    /// Views from a file instead: a JSON array of engine/docs/model.md view objects (their lights' intensities are used as given)
    #[arg(long, conflicts_with_all = ["views", "res", "elevation", "light_azimuth", "light_elevation", "light_distance"])]
    pub view_file: Option<PathBuf>,
    /// The design's size where --scratches, --iters and --res do not say: `default` (18,000
    /// scratches, 60 iterations, 144 px: where a 2-core CPU's 20 seconds pay most,
    /// engine/docs/worst_view.md; a walk, a hold or an object: 1000 scratches per view, at least
    /// 10,000, 140 iterations, 112 px) or `paper` (the paper's scale for a GPU: 40,000 scratches, 300
    /// iterations, 512 px; a few seconds on a large GPU, hours on a CPU)
    #[arg(long, value_enum, default_value_t = Preset::Default)]
    pub preset: Preset,
    /// Number of scratches (default 18000, --preset paper 40000; for a walk, 1000 per walk view,
    /// at least 10000: a plate that shows more pictures needs more scratches)
    #[arg(long)]
    pub scratches: Option<usize>,
    /// Optimization iterations (default 60, a walk's 140, --preset paper 300)
    #[arg(long)]
    pub iters: Option<u32>,
    /// View resolution (square), pixels (default 144, a walk's 112, --preset paper 512)
    #[arg(long)]
    pub res: Option<u32>,
    /// Seed of the random initial scratches
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Elevation of the views, degrees
    #[arg(long, default_value_t = 45.0)]
    pub elevation: f64,
    /// Azimuth of the lamp, degrees (views sit at 0, 360/N, ...; a walk's lamp defaults to its
    /// arc's middle). Without this and --light-elevation, a ring of two or more views gets the
    /// lamp where their grooves differ most in direction, clear of every eye and of the plate's
    /// own highlight (three views: overhead; engine/docs/worst_view.md); with one of them, 0
    /// puts it on view 0's side
    #[arg(long, allow_hyphen_values = true)]
    pub light_azimuth: Option<f64>,
    /// Elevation of the lamp, degrees (default for a ring of two or more views: see
    /// --light-azimuth; otherwise 20 degrees above the views', at most 80; the views' own
    /// elevation puts it in view 0's eye)
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
    /// The plate's shape once carved: `flat` (the default), or `cylinder`: the flat sheet, carved
    /// as usual, then bent around a form of --radius mm (a can, a pipe, a printed form) about
    /// the sheet's --bend-axis, the scratched face outside (or inside with --concave). The plan
    /// carves the flat sheet; the set-up sheet says how to bend it and where to stand
    #[arg(long, value_enum, default_value_t = PlateShapeArg::Flat)]
    pub plate_shape: PlateShapeArg,
    /// The bend's radius, mm (with --plate-shape cylinder; at least --plate / 5.24)
    #[arg(long)]
    pub radius: Option<f64>,
    /// The sheet's axis the bend runs along: `y` (default: the sheet's left and right edges
    /// curve) or `x` (its top and bottom edges curve)
    #[arg(long, value_enum)]
    pub bend_axis: Option<BendAxisArg>,
    /// The scratched face inside the bend (a bowl, a reflector), not outside (a vase, a bracelet)
    #[arg(long)]
    pub concave: bool,
    /// Initial scratch length range, percent of the plate size
    #[arg(long, default_value_t = 2.0)]
    pub len_min_pct: f64,
    #[arg(long, default_value_t = 8.0)]
    pub len_max_pct: f64,
    /// Initial width parameter w, depth d (mm) and roughness alpha of every scratch. --init-w's
    /// default: 0.1 where the scratches start facing the views (--aim), 0.05 where they start at
    /// random
    #[arg(long)]
    pub init_w: Option<f64>,
    #[arg(long, default_value_t = 0.05)]
    pub init_d: f64,
    #[arg(long, default_value_t = 0.06)]
    pub init_alpha: f64,
    /// Learning rate of the endpoints, mm per step (default 1.5e-3 x plate size; half that where
    /// the scratches start facing the views: --aim)
    #[arg(long)]
    pub lr_end: Option<f32>,
    /// The learning rates' share at the last step: they hold until half the run, then fall
    /// linearly to it (default: 0.1 where the scratches start facing the views, --aim; 1,
    /// constant rates, elsewhere)
    #[arg(long, value_name = "SHARE", allow_hyphen_values = true)]
    pub lr_final: Option<f64>,
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
    /// Weigh each view in the loss by how far it stands below what its picture allows, from 30%
    /// of the run on (every tenth of the run; engine/docs/worst_view.md measures it). The
    /// default; --no-balance weighs every view alike
    #[arg(long, overrides_with = "no_balance")]
    pub balance: bool,
    /// Weigh every view alike in the loss (the loss before --balance became the default)
    #[arg(long)]
    pub no_balance: bool,
    /// Let scratches bend: each scratch's bulge (an arc through its two ends, DXF's convention)
    /// is optimized with its ends, from straight; the design writes a `bulge` column and the
    /// plan carves G2/G3 arcs (engine/docs/model.md section 11). No pruning
    #[arg(long)]
    pub arcs: bool,
    /// --arcs: chords each scratch is rendered as while the design runs (the finished design is
    /// judged at four times as many, at least 32)
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub arc_chords: u32,
    /// --arcs: the largest |bulge| (0.5: a 106 degree arc; at most 2.4142, 270 degrees)
    #[arg(long, default_value_t = 0.5, value_name = "B")]
    pub max_bulge: f64,
    /// Standard deviation of the loss's 3x3 Gaussian blur, pixels
    #[arg(long, default_value_t = 1.0)]
    pub blur_sigma: f32,
    /// Weight K of the loss's cross-talk term: the part of each view's error that looks like
    /// another view's picture counts 1 + K times (the quality report's cross-talk; 0: none;
    /// engine/docs/worst_view.md measures it)
    #[arg(long, default_value_t = 0.0, value_name = "K")]
    pub crosstalk: f32,
    /// The share of the first scratches drawn facing a view, 0 to 1: each turned across the half
    /// vector of a view drawn in proportion to the light its picture asks for, placed where that
    /// picture asks for light and cut where it turns dark; the rest in random directions. Default: 1 for a ring of views on a
    /// flat plate (with straight scratches), whose endpoints' learning rate is then halved unless
    /// --lr-end is given; 0 for walks, objects, view files, bent plates and arcs. --aim 0 draws
    /// every scratch at random, as designs before it did (engine/docs/worst_view.md)
    #[arg(long, value_name = "SHARE", allow_hyphen_values = true)]
    pub aim: Option<f64>,
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
    /// machine (the +x mark and the registration marks included), and if it is longer, the scratches that matter least go and the rest is
    /// optimized again, until the job (summed move by move from rest, an upper bound of the
    /// planner's estimate) fits. summary.json's `job_limit` says what the limit cost each view
    #[arg(long)]
    pub max_job_min: Option<f64>,
    /// Replay steering: pictures moved or scaled at given iterations, as a live design
    /// (`scratchart-view --design`) recorded them: its summary.json, or a JSON array of
    /// {"iteration", "view", "shift_px": [x, y], "scale"} (shift in pixels from where the
    /// design placed the picture, scale about its centre; pictures from --targets only) and
    /// {"iteration", "lambda_p", "lambda_g"} (the loss's weights from that iteration on) and
    /// {"iteration", "remove": [indices], "add": N, "seed": S} (scratches removed, then N
    /// added, drawn as the first ones were from the random stream S)
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

/// `--preset`: the design's size where its flags do not say.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Preset {
    /// 18,000 scratches, 60 iterations, 144 px (a walk: 1000 scratches per view, at least
    /// 10,000, 140 iterations, 112 px).
    Default,
    /// The paper's scale: 40,000 scratches, 300 iterations, 512 px.
    Paper,
}

impl Preset {
    /// Scratches (None: the default's rule, which floors a walk's at 1000 per view).
    pub fn scratches(self) -> Option<usize> {
        match self {
            Preset::Default => None,
            Preset::Paper => Some(40_000),
        }
    }
    pub fn iters(self, walk: bool) -> u32 {
        match self {
            Preset::Default if walk => scratchart_design::spec::WALK_ITERS,
            Preset::Default => scratchart_design::spec::DEFAULT_ITERS,
            Preset::Paper => 300,
        }
    }
    pub fn res(self, walk: bool) -> u32 {
        match self {
            Preset::Default if walk => scratchart_design::spec::WALK_RES,
            Preset::Default => scratchart_design::spec::DEFAULT_RES,
            Preset::Paper => 512,
        }
    }
}

impl DesignArgs {
    /// Whether the flags leave the design's size to the default preset (no --preset, --scratches,
    /// --iters or --res).
    pub fn default_size(&self) -> bool {
        self.preset == Preset::Default && self.scratches.is_none() && self.iters.is_none() && self.res.is_none()
    }

    /// The design these flags specify (`--quiet` is the terminal's, not the design's).
    pub fn spec(&self) -> DesignSpec {
        let walk = !self.walk.is_empty() || self.hold.is_some() || self.object.is_some();
        DesignSpec {
            targets: self.targets.clone(),
            fit: self.fit,
            gamma: self.gamma,
            background: self.background,
            blank_view: self.blank_view.clone(),
            views: self.views,
            walk: self.walk.clone(),
            hold: self.hold.clone(),
            object: self.object.clone(),
            arc: self.arc,
            azimuth: self.azimuth,
            distance: self.distance,
            walk_views: self.walk_views,
            between: self.between,
            walk_probes: self.walk_probes,
            object_size: self.object_size,
            object_depth: self.object_depth,
            object_yaw: self.object_yaw,
            view_file: self.view_file.clone(),
            scratches: self.scratches.or(self.preset.scratches()),
            iters: self.iters.unwrap_or(self.preset.iters(walk)),
            res: self.res.unwrap_or(self.preset.res(walk)),
            seed: self.seed,
            elevation: self.elevation,
            light_azimuth: self.light_azimuth,
            light_elevation: self.light_elevation,
            light_distance: self.light_distance,
            exposure: match self.exposure {
                ExposureMode::Free => Exposure::Free,
                ExposureMode::Fixed => Exposure::Fixed,
            },
            plate: self.plate,
            cylinder: self.plate_shape == PlateShapeArg::Cylinder,
            radius: self.radius,
            bend_axis: self.bend_axis.map(|a| match a {
                BendAxisArg::X => scratchart_model::surface::BendAxis::X,
                BendAxisArg::Y => scratchart_model::surface::BendAxis::Y,
            }),
            concave: self.concave,
            len_min_pct: self.len_min_pct,
            len_max_pct: self.len_max_pct,
            init_w: self.init_w,
            init_d: self.init_d,
            init_alpha: self.init_alpha,
            lr_end: self.lr_end,
            lr_w: self.lr_w,
            lr_d: self.lr_d,
            lr_alpha: self.lr_alpha,
            lr_light: self.lr_light,
            lambda_p: self.lambda_p,
            lambda_g: self.lambda_g,
            balance: !self.no_balance,
            arcs: self.arcs.then_some(self.arc_chords),
            max_bulge: self.max_bulge,
            blur_sigma: self.blur_sigma,
            crosstalk: self.crosstalk,
            aim: self.aim,
            lr_final: self.lr_final,
            out: self.out.clone(),
            checkpoint_every: self.checkpoint_every,
            resume: self.resume,
            prune_tol: self.prune_tol,
            prune_trials: self.prune_trials,
            tool: self.tool.clone(),
            machine: self.machine.as_deref().map(|m| match m {
                "marlin" => Firmware::Marlin,
                _ => Firmware::Grbl,
            }),
            machine_file: self.machine_file.clone(),
            min_length_mm: self.min_length_mm,
            robust: self.robust,
            carvings: self.carvings,
            max_job_min: self.max_job_min,
            steer: self.steer.clone(),
            inject_nan_grad_at: self.inject_nan_grad_at,
            inject_stop_at: self.inject_stop_at,
        }
    }
}

pub(super) fn parse_fit(s: &str) -> Result<scratchart_design::framing::Fit, String> {
    s.parse()
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        design: super::DesignArgs,
    }

    /// The flags' defaults are the specification's: a design run without flags is
    /// `DesignSpec::default()`.
    #[test]
    fn no_flags_make_the_default_spec() {
        let cli = Cli::try_parse_from(["design"]).unwrap();
        assert_eq!(cli.design.spec(), scratchart_design::DesignSpec::default());
    }

    #[test]
    fn flags_reach_the_spec() {
        let cli = Cli::try_parse_from([
            "design",
            "--iters",
            "7",
            "--exposure",
            "free",
            "--tool",
            "t.json",
            "--machine",
            "marlin",
            "--res",
            "64",
        ])
        .unwrap();
        let spec = cli.design.spec();
        assert_eq!(spec.iters, 7);
        assert_eq!(spec.res, 64);
        assert_eq!(spec.exposure, scratchart_design::spec::Exposure::Free);
        assert_eq!(spec.machine, Some(scratchart_tool::machine::Firmware::Marlin));
        assert_eq!(spec.tool.as_deref(), Some(std::path::Path::new("t.json")));
        // The loss's balance is on unless --no-balance (the last of the two wins).
        assert!(spec.balance);
        let balance_of = |flags: &[&str]| Cli::try_parse_from(flags).unwrap().design.spec().balance;
        assert!(!balance_of(&["design", "--no-balance"]));
        assert!(balance_of(&["design", "--no-balance", "--balance"]));
        assert!(!balance_of(&["design", "--balance", "--no-balance"]));
    }

    #[test]
    fn a_preset_sizes_what_the_flags_leave() {
        let spec = |flags: &[&str]| Cli::try_parse_from(flags).unwrap().design.spec();
        let paper = spec(&["design", "--preset", "paper"]);
        assert_eq!((paper.scratches, paper.iters, paper.res), (Some(40_000), 300, 512));
        let mixed = spec(&["design", "--preset", "paper", "--iters", "50", "--scratches", "900"]);
        assert_eq!((mixed.scratches, mixed.iters, mixed.res), (Some(900), 50, 512));
        let default = spec(&["design", "--res", "64"]);
        assert_eq!((default.scratches, default.iters, default.res), (None, 60, 64));
        let ring = spec(&["design"]);
        assert_eq!((ring.iters, ring.res), (60, 144));
        // A walk (many views) keeps its own size; its scratches follow its views.
        let walk = spec(&["design", "--walk", "a.png", "b.png", "c.png"]);
        assert_eq!((walk.scratches, walk.iters, walk.res), (None, 140, 112));
        let args = |flags: &[&str]| Cli::try_parse_from(flags).unwrap().design;
        assert!(args(&["design"]).default_size());
        assert!(!args(&["design", "--iters", "140"]).default_size());
        assert!(!args(&["design", "--preset", "paper"]).default_size());
    }
}
