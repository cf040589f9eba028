//! A design's typed specification ([`DesignSpec`]): everything `scratchart design`'s flags say,
//! and what the viewer's live design (`scratchart-view --design`) fills in from the same flags.
//! [`prepare`] checks it and makes the [`Problem`] and the [`DesignConfig`] that
//! [`crate::design::run_design`] runs, so a design the viewer saves is one `scratchart design
//! --resume` continues bit for bit.
//!
//! Each field is named as its flag (`init_w` is `--init-w`), and the errors name the flag: a
//! [`SpecError::Usage`] is a value that cannot work (exit class 2), a [`SpecError::Input`] or a
//! file's own error a file that cannot be read or is wrong (3).
use std::path::PathBuf;
use std::sync::Arc;

use scratchart_exit::{Class, ExitClass};
use scratchart_model::mesh::MeshError;
use scratchart_model::scene::SceneError;
use scratchart_model::surface::{BendAxis, PlateShape, MAX_WRAP_RAD};
use scratchart_observe::Observer;
use scratchart_optim::tool_params::{Fabrication, FabricationError, MachineLimits};
use scratchart_tool::machine::{Firmware, MachineProfile};
use scratchart_vulkan::Context;

use crate::framing::Fit;
use crate::problem::DesignConfig;
use crate::problem::Problem;
use crate::targets::TargetError;
use scratchart_optim::driver::Hooks;

/// Fails with a [`SpecError::Usage`] unless the condition holds.
macro_rules! ensure_flag {
    ($cond:expr, $($msg:tt)*) => {
        if !$cond {
            return Err(SpecError::Usage(format!($($msg)*)));
        }
    };
}

mod problem;
mod walk;

pub use problem::problem;

/// The default lamp stands this many degrees above the views' elevation (at most 80)...
pub const LIGHT_ELEVATION_ABOVE_VIEWS: f64 = 20.0;
/// ... and this many times the views' distance from the plate centre.
pub const LIGHT_DISTANCE_FACTOR: f64 = 1.0;
/// Scratches, iterations and view resolution (square, pixels) of a ring design without
/// `scratches`, `iters` or `res`: where a 2-core CPU's 20 seconds pay most (18,000 x 60 at 144
/// px beat 18,000 x 70 at 128 px on every photo set measured, in the same time: a view that ends
/// within 0.01 of its cap is held by its resolution, not by the optimizer; 160 px stripes large
/// bright areas; engine/docs/worst_view.md, "The default's resolution").
pub const DEFAULT_SCRATCHES: usize = 18_000;
pub const DEFAULT_ITERS: u32 = 60;
pub const DEFAULT_RES: u32 = 144;
/// The same for a walk, a hold or an object (many views): 1000 scratches per view, at least
/// this many; 140 iterations; 112 px.
pub const WALK_MIN_SCRATCHES: usize = 10_000;
pub const WALK_ITERS: u32 = 140;
pub const WALK_RES: u32 = 112;

/// How each view's brightness is set (`--exposure`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exposure {
    /// Each view its own exposure (an eye's adaptation, a camera's setting).
    Free,
    /// One intensity per lamp; the views keep their exposures.
    Fixed,
}

/// What a design is: its pictures, views, lamp, scratches, optimization, tool and machine. The
/// meaning of each field is its flag's in `scratchart design --help`; [`Default`] is the
/// command's default (the built-in 3-view demo into `./out`).
#[derive(Clone, Debug, PartialEq)]
pub struct DesignSpec {
    /// Target pictures, one per view in view order (empty: the built-in shapes).
    pub targets: Vec<PathBuf>,
    pub fit: Fit,
    pub gamma: f32,
    pub background: f32,
    pub blank_view: Vec<String>,
    pub views: usize,
    /// A walk's frames (or one directory of them).
    pub walk: Vec<PathBuf>,
    pub hold: Option<PathBuf>,
    pub object: Option<PathBuf>,
    pub arc: Option<f64>,
    pub azimuth: Option<f64>,
    pub distance: Option<f64>,
    pub walk_views: Option<usize>,
    pub between: usize,
    pub walk_probes: usize,
    pub object_size: Option<f64>,
    pub object_depth: Option<f64>,
    pub object_yaw: f64,
    pub view_file: Option<PathBuf>,
    pub scratches: Option<usize>,
    pub iters: u32,
    pub res: u32,
    pub seed: u64,
    pub elevation: f64,
    pub light_azimuth: Option<f64>,
    pub light_elevation: Option<f64>,
    pub light_distance: Option<f64>,
    pub exposure: Exposure,
    pub plate: f64,
    /// `--plate-shape cylinder` (false: flat), `--radius`, `--bend-axis`, `--concave`: see
    /// [`DesignSpec::plate_shape`].
    pub cylinder: bool,
    pub radius: Option<f64>,
    pub bend_axis: Option<BendAxis>,
    pub concave: bool,
    pub len_min_pct: f64,
    pub len_max_pct: f64,
    /// `--init-w`; None: [`DesignSpec::init_w`]'s default.
    pub init_w: Option<f64>,
    pub init_d: f64,
    pub init_alpha: f64,
    pub lr_end: Option<f32>,
    pub lr_w: Option<f32>,
    pub lr_d: Option<f32>,
    pub lr_alpha: Option<f32>,
    pub lr_light: Option<f32>,
    /// `--lr-final`; None: [`DesignSpec::lr_final`]'s default.
    pub lr_final: Option<f64>,
    pub lambda_p: f32,
    pub lambda_g: f32,
    /// Each view's weight follows its shortfall against its cap ([`crate::balance`]).
    pub balance: bool,
    /// `--arcs`: scratches may bend, rendered as this many chords each while the design runs
    /// (None: straight scratches).
    pub arcs: Option<u32>,
    /// `--max-bulge`: the largest |bulge| of a design with arcs.
    pub max_bulge: f64,
    pub blur_sigma: f32,
    /// `--crosstalk`: the loss's cross-talk weight kappa (0: none; `LossConfig::crosstalk`).
    pub crosstalk: f32,
    /// `--aim`: the share of the initial scratches turned to face a view ([`crate::aim`]); None:
    /// [`DesignSpec::aim_share`]'s default.
    pub aim: Option<f64>,
    pub out: PathBuf,
    pub checkpoint_every: u32,
    pub resume: bool,
    pub prune_tol: f64,
    pub prune_trials: u32,
    /// Fabrication mode: the calibrated tool's tool.json.
    pub tool: Option<PathBuf>,
    /// The machine's built-in profile (`--machine grbl|marlin`).
    pub machine: Option<Firmware>,
    pub machine_file: Option<PathBuf>,
    pub min_length_mm: Option<f64>,
    pub robust: bool,
    pub carvings: u32,
    pub max_job_min: Option<f64>,
    pub steer: Option<PathBuf>,
    /// Test hook: the gradient is NaN at this iteration (exercises the rollback).
    pub inject_nan_grad_at: Option<u32>,
    /// Test hook: the run stops with an error at the top of this iteration.
    pub inject_stop_at: Option<u32>,
}

/// The share of the initial scratches a ring of views on a flat plate draws facing a view
/// (`--aim`; [`crate::aim`]), and the endpoints' learning rate it runs with, as a share of the
/// plate's default: scratches that start facing their views need less moving, and moving them
/// as far as random ones need undoes their placement (engine/docs/worst_view.md, "Scratches
/// drawn facing the views").
pub const RING_AIM: f64 = 1.0;
pub const AIMED_LR_END_SHARE: f32 = 0.5;

/// The scratches' first width parameter w (mm) from a random start, and from an aimed one: a
/// start that faces its views at 0.05 mm leaves a dark picture 0.012 below what the random start
/// gives it (engine/docs/worst_view.md, "The aimed start's width").
pub const INIT_W: f64 = 0.05;
pub const AIMED_INIT_W: f64 = 0.1;

/// The learning rates' share at an aimed design's last step (they fall linearly to it over the
/// run's second half): a design near its caps, at a constant rate, still moves enough at its end
/// to lose a view's correlation (the clock set's worst view 0.875 to 0.886 over four seeds; with
/// the fall 0.882 to 0.884; engine/docs/worst_view.md, "The learning rates' fall").
pub const AIMED_LR_FINAL: f64 = 0.1;

impl DesignSpec {
    /// The share of the initial scratches drawn facing a view: `--aim`, else [`RING_AIM`] for a
    /// ring of views on a flat plate with straight scratches (where it was measured) and 0 for
    /// walks, holds, objects, view files, bent plates and arcs.
    pub fn aim_share(&self) -> f64 {
        self.aim.unwrap_or({
            let ring = self.walk.is_empty() && self.hold.is_none() && self.object.is_none() && self.view_file.is_none();
            if ring && !self.cylinder && self.arcs.is_none() {
                RING_AIM
            } else {
                0.0
            }
        })
    }

    /// The scratches' first width parameter w, mm: `--init-w`, else [`AIMED_INIT_W`] where they
    /// start facing the views ([`DesignSpec::aim_share`] above 0) and [`INIT_W`] elsewhere.
    pub fn init_w(&self) -> f64 {
        self.init_w
            .unwrap_or(if self.aim_share() > 0.0 { AIMED_INIT_W } else { INIT_W })
    }

    /// The learning rates' share at the last step: `--lr-final`, else [`AIMED_LR_FINAL`] where
    /// the scratches start facing the views and 1 (constant rates) elsewhere.
    pub fn lr_final(&self) -> f64 {
        self.lr_final
            .unwrap_or(if self.aim_share() > 0.0 { AIMED_LR_FINAL } else { 1.0 })
    }

    /// The plate's shape the flags say: flat, or the carved sheet bent into a cylinder of
    /// `--radius` about `--bend-axis` (convex unless `--concave`), engine/docs/model.md section 10.
    pub fn plate_shape(&self) -> Result<PlateShape, SpecError> {
        if !self.cylinder {
            ensure_flag!(
                self.radius.is_none() && self.bend_axis.is_none() && !self.concave,
                "--radius, --bend-axis and --concave describe a bent plate: add --plate-shape cylinder"
            );
            return Ok(PlateShape::Flat);
        }
        let Some(radius_mm) = self.radius else {
            return Err(SpecError::Usage(
                "--plate-shape cylinder needs --radius MM: the radius of the form the sheet is bent around \
                 (a can is about 33 mm, a vase band 60 to 150)"
                    .into(),
            ));
        };
        let least = self.plate / MAX_WRAP_RAD;
        ensure_flag!(
            radius_mm.is_finite() && radius_mm >= least,
            "--radius {radius_mm} is too small for a {} mm plate: at least {least:.1} mm (the sheet may span {:.0} \
             degrees of the cylinder)",
            self.plate,
            MAX_WRAP_RAD.to_degrees()
        );
        Ok(PlateShape::Cylinder {
            radius_mm,
            axis: self.bend_axis.unwrap_or(BendAxis::Y),
            convex: !self.concave,
        })
    }
}

impl Default for DesignSpec {
    fn default() -> DesignSpec {
        DesignSpec {
            targets: Vec::new(),
            fit: Fit::Contain,
            gamma: 1.0,
            background: 0.0,
            blank_view: Vec::new(),
            views: 3,
            walk: Vec::new(),
            hold: None,
            object: None,
            arc: None,
            azimuth: None,
            distance: None,
            walk_views: None,
            between: 1,
            walk_probes: 3,
            object_size: None,
            object_depth: None,
            object_yaw: 0.0,
            view_file: None,
            scratches: None,
            iters: DEFAULT_ITERS,
            res: DEFAULT_RES,
            seed: 1,
            elevation: 45.0,
            light_azimuth: None,
            light_elevation: None,
            light_distance: None,
            exposure: Exposure::Fixed,
            plate: 100.0,
            cylinder: false,
            radius: None,
            bend_axis: None,
            concave: false,
            len_min_pct: 2.0,
            len_max_pct: 8.0,
            init_w: None,
            init_d: 0.05,
            init_alpha: 0.06,
            lr_end: None,
            lr_final: None,
            lr_w: None,
            lr_d: None,
            lr_alpha: None,
            lr_light: None,
            lambda_p: 1.0,
            lambda_g: 0.01,
            balance: true,
            arcs: None,
            max_bulge: 0.5,
            blur_sigma: 1.0,
            crosstalk: 0.0,
            aim: None,
            out: PathBuf::from("out"),
            checkpoint_every: 50,
            resume: false,
            prune_tol: 0.01,
            prune_trials: 8,
            tool: None,
            machine: None,
            machine_file: None,
            min_length_mm: None,
            robust: false,
            carvings: 8,
            max_job_min: None,
            steer: None,
            inject_nan_grad_at: None,
            inject_stop_at: None,
        }
    }
}

/// Why a specification makes no design.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    /// A value that cannot work, or values that contradict each other (the message names the
    /// flag and what would work).
    #[error("{0}")]
    Usage(String),
    /// A file the specification names cannot be read or is wrong.
    #[error("{0}")]
    Input(String),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Target(#[from] TargetError),
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error(transparent)]
    Fabrication(#[from] FabricationError),
}

impl ExitClass for SpecError {
    fn exit_class(&self) -> Option<Class> {
        match self {
            SpecError::Usage(_) => Some(Class::Usage),
            SpecError::Input(_) => Some(Class::Input),
            SpecError::Scene(e) => e.exit_class(),
            SpecError::Target(e) => e.exit_class(),
            SpecError::Mesh(e) => e.exit_class(),
            SpecError::Fabrication(e) => e.exit_class(),
        }
    }
}

impl ExitClass for TargetError {
    fn exit_class(&self) -> Option<Class> {
        match self {
            TargetError::Image(io) => io.exit_class(),
            TargetError::Count { .. } | TargetError::Uniform { .. } => Some(Class::Input),
        }
    }
}

/// The optimizer's configuration of `spec` (its start time left to the caller: `started`).
pub fn config(spec: &DesignSpec) -> DesignConfig {
    let mut cfg = DesignConfig::new(spec.plate, spec.out.clone());
    cfg.iters = spec.iters;
    cfg.seed = spec.seed;
    cfg.aim = spec.aim_share();
    cfg.lr_final = spec.lr_final();
    cfg.loss.lambda_p = spec.lambda_p;
    cfg.loss.lambda_g = spec.lambda_g;
    cfg.loss.sigma = spec.blur_sigma;
    cfg.loss.crosstalk = spec.crosstalk;
    let a = &mut cfg.adam;
    let aimed_share = if cfg.aim > 0.0 { AIMED_LR_END_SHARE } else { 1.0 };
    a.lr_end = spec.lr_end.unwrap_or(aimed_share * a.lr_end);
    a.lr_w = spec.lr_w.unwrap_or(a.lr_w);
    a.lr_d = spec.lr_d.unwrap_or(a.lr_d);
    a.lr_alpha = spec.lr_alpha.unwrap_or(a.lr_alpha);
    a.lr_light = spec.lr_light.unwrap_or(a.lr_light);
    cfg.checkpoint_every = spec.checkpoint_every;
    cfg.resume = spec.resume;
    cfg.prune.tol = spec.prune_tol;
    cfg.prune.max_trials = spec.prune_trials;
    cfg.calibrate_lights = spec.view_file.is_none();
    cfg.blank_views = spec.blank_view.clone();
    cfg.balance = spec.balance;
    cfg.arcs = spec.arcs.map(|chords| scratchart_optim::arc_params::ArcConfig {
        chords,
        max_bulge: spec.max_bulge as f32,
        ..Default::default()
    });
    cfg.keep_exposures = spec.exposure == Exposure::Fixed;
    cfg.hooks = Hooks {
        nan_grad_at: spec.inject_nan_grad_at,
        nan_image_at: None,
        stop_at: spec.inject_stop_at,
    };
    cfg
}

/// The problem and configuration of `spec`, every field checked, as `scratchart design` runs
/// them; the viewer's live design runs the same.
pub fn prepare(
    ctx: &Arc<Context>,
    spec: &DesignSpec,
    obs: &dyn Observer,
) -> Result<(Problem, DesignConfig), SpecError> {
    ensure_flag!(spec.blur_sigma > 0.0, "--blur-sigma must be > 0");
    ensure_flag!(
        spec.crosstalk >= 0.0 && spec.crosstalk.is_finite(),
        "--crosstalk must be a finite number >= 0 (0: no cross-talk term)"
    );
    ensure_flag!(
        spec.aim.is_none_or(|a| (0.0..=1.0).contains(&a)),
        "--aim must be a share between 0 and 1 (0: every scratch in a random direction)"
    );
    ensure_flag!(
        spec.lr_final.is_none_or(|a| (0.0..=1.0).contains(&a)),
        "--lr-final must be a share between 0 and 1 (1: constant learning rates)"
    );
    // What only a design for a machine has.
    let machine_given = spec.machine.is_some() || spec.machine_file.is_some();
    for (given, flag) in [
        (spec.min_length_mm.is_some(), "--min-length-mm"),
        (spec.robust, "--robust"),
        (spec.max_job_min.is_some(), "--max-job-min"),
    ] {
        ensure_flag!(
            !given || machine_given,
            "{flag} needs the machine: --machine grbl|marlin or --machine-file machine.json (with --tool)"
        );
    }
    if let Some(n) = spec.arcs {
        ensure_flag!(
            (1..=64).contains(&n),
            "--arc-chords {n}: a design renders each scratch as 1 to 64 chords while it runs"
        );
        ensure_flag!(
            spec.max_bulge > 0.0 && spec.max_bulge <= scratchart_model::arc::MAX_BULGE,
            "--max-bulge {}: must lie in (0, {:.4}] (an arc of at most 270 degrees)",
            spec.max_bulge,
            scratchart_model::arc::MAX_BULGE
        );
    }
    ensure_flag!(
        spec.tool.is_some() || !machine_given,
        "--machine and --machine-file need the tool: --tool tool.json"
    );
    let mut problem = problem(spec, ctx.info(), obs)?;
    if spec.targets.is_empty() && problem.walk.is_none() {
        let names: Vec<&str> = (0..problem.scene.views.len())
            .map(|j| crate::targets::SHAPES[j % crate::targets::SHAPES.len()])
            .collect();
        obs.info(&format!(
            "no --targets given: using the built-in shapes ({})",
            names.join(", ")
        ));
    }
    let mut cfg = config(spec);
    if let Some(path) = &spec.tool {
        let fab = Fabrication::load(
            path,
            spec.init_alpha,
            "--init-alpha (the design's default scratch alpha; the tool file has no `alpha`)",
            cfg.adam.lr_d,
            &cfg.adam,
        )?;
        let fab = match machine_limits(spec, &fab, obs)? {
            Some(limits) => {
                // The projection after every step keeps each scratch at least this long.
                // (2e-4 mm more: the endpoints are f32 on the GPU and 4 decimals in the G-code, so
                // a scratch read back from either is still no shorter than asked.)
                cfg.adam.min_len = cfg.adam.min_len.max((limits.min_length_mm + 2e-4) as f32);
                let fab = fab.with_machine(limits, &cfg.adam)?;
                if spec.robust {
                    fab.with_robust(cfg.seed as u32)?
                } else {
                    fab
                }
            }
            None => fab,
        };
        cfg.carvings = spec.carvings;
        cfg.tool = Some(fab);
    }
    problem.init = Some(crate::steer::ScratchInit {
        len_mm: (
            0.01 * spec.len_min_pct * problem.scene.plate.size_mm,
            0.01 * spec.len_max_pct * problem.scene.plate.size_mm,
        ),
        w: spec.init_w(),
        d: spec.init_d,
        alpha: spec.init_alpha,
    });
    if let Some(path) = &spec.steer {
        ensure_flag!(
            spec.max_job_min.is_none(),
            "--steer and --max-job-min cannot be used together"
        );
        let events = crate::steer::read(path).map_err(SpecError::Input)?;
        for e in &events {
            crate::steer::check(e, &problem.scene.views, &problem.sources).map_err(SpecError::Usage)?;
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

/// The machine limits of `--machine` / `--machine-file` for a design with this tool, or None.
fn machine_limits(
    spec: &DesignSpec,
    fab: &Fabrication,
    obs: &dyn Observer,
) -> Result<Option<MachineLimits>, SpecError> {
    if spec.machine.is_none() && spec.machine_file.is_none() {
        return Ok(None);
    }
    let firmware = spec.machine.unwrap_or(Firmware::Grbl);
    let (profile, source) = match &spec.machine_file {
        Some(f) => {
            let text = std::fs::read_to_string(f)
                .map_err(|e| SpecError::Input(format!("cannot read machine profile {}: {e}", f.display())))?;
            let (m, warnings) = MachineProfile::from_json(&text, firmware)
                .map_err(|e| SpecError::Input(format!("machine profile {}: {e}", f.display())))?;
            for w in warnings {
                obs.warn(&format!("machine profile {}: {w}", f.display()));
            }
            (m, f.display().to_string())
        }
        None => (
            MachineProfile::builtin(firmware),
            format!(
                "built-in {}",
                scratchart_machine::program::Program::firmware_name(firmware)
            ),
        ),
    };
    let (min_length_mm, min_length_from) = match spec.min_length_mm {
        Some(l) => {
            ensure_flag!(l >= 0.0 && l.is_finite(), "--min-length-mm {l}: a length >= 0 mm");
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
    Ok(Some(MachineLimits {
        profile,
        source,
        min_length_mm,
        min_length_from,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ring on a flat plate starts aimed, with half the endpoints' learning rate and wider
    /// scratches; `--aim 0`, a walk, a bent plate and arcs start at random with the whole rate
    /// and the old width; `--lr-end` and `--init-w` win.
    #[test]
    fn a_ring_on_a_flat_plate_starts_aimed_wide_at_half_the_endpoints_rate() {
        let whole = config(&DesignSpec {
            aim: Some(0.0),
            ..Default::default()
        })
        .adam
        .lr_end;
        assert_eq!(whole, (1.5e-3 * 100.0) as f32);
        let ring = DesignSpec::default();
        assert_eq!(ring.aim_share(), RING_AIM);
        assert_eq!(config(&ring).adam.lr_end, AIMED_LR_END_SHARE * whole);
        assert_eq!(config(&ring).aim, RING_AIM);
        assert_eq!(ring.init_w(), AIMED_INIT_W);
        assert_eq!(config(&ring).lr_final, AIMED_LR_FINAL);
        for other in [
            DesignSpec {
                walk: vec![PathBuf::from("a.png"), PathBuf::from("b.png")],
                ..Default::default()
            },
            DesignSpec {
                hold: Some(PathBuf::from("a.png")),
                ..Default::default()
            },
            DesignSpec {
                object: Some(PathBuf::from("a.obj")),
                ..Default::default()
            },
            DesignSpec {
                view_file: Some(PathBuf::from("v.json")),
                ..Default::default()
            },
            DesignSpec {
                cylinder: true,
                ..Default::default()
            },
            DesignSpec {
                arcs: Some(8),
                ..Default::default()
            },
        ] {
            assert_eq!(other.aim_share(), 0.0);
            assert_eq!(config(&other).adam.lr_end, whole);
            assert_eq!(other.init_w(), INIT_W);
            assert_eq!(config(&other).lr_final, 1.0);
        }
        let given_w = DesignSpec {
            init_w: Some(0.07),
            ..Default::default()
        };
        assert_eq!(given_w.init_w(), 0.07);
        let given_final = DesignSpec {
            lr_final: Some(0.5),
            ..Default::default()
        };
        assert_eq!(config(&given_final).lr_final, 0.5);
        let given = DesignSpec {
            lr_end: Some(0.2),
            ..Default::default()
        };
        assert_eq!(config(&given).adam.lr_end, 0.2);
        let half = DesignSpec {
            walk: vec![PathBuf::from("a.png")],
            aim: Some(0.5),
            ..Default::default()
        };
        assert_eq!(
            (half.aim_share(), config(&half).adam.lr_end),
            (0.5, AIMED_LR_END_SHARE * whole)
        );
    }
}
