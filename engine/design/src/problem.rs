//! The design problem (plate, views, targets, pictures), the design job's configuration, and
//! what a run produced: the types that the job ([`crate::design`]) and its reports
//! ([`crate::report`]) share.
use std::path::PathBuf;

use serde_json::json;

use scratchart_model::scene::Scene;
use scratchart_optim::adam::AdamConfig;
use scratchart_optim::driver::{Evaluation, Hooks, Rollback};
use scratchart_optim::loss::{LossConfig, LossValues};
use scratchart_optim::prune::{PruneConfig, PruneStats};
use scratchart_optim::tool_params::Fabrication;

/// One image per view (row-major f32, top row first).
pub type Images = Vec<Vec<f32>>;

/// A design problem: plate, views (with their lights), initial scratches, one target per view
/// (display values in [0, 1], W x H, top row first).
#[derive(Clone, Debug)]
pub struct Problem {
    pub scene: Scene,
    pub targets: Vec<Vec<f32>>,
    /// Per view, the pixels that show the picture (where quality is measured); the on-plate
    /// pixels when the target has no picture region of its own.
    pub pictures: Vec<Vec<bool>>,
    /// Per view, the picture's rectangle in the frame (pixels), when it has one.
    pub picture_rects: Vec<Option<crate::framing::Rect>>,
    /// A walk-past design (`design --walk/--hold/--object`): its arc and its in-between views,
    /// which follow the design views in `scene` (see [`crate::walk`]).
    pub walk: Option<crate::walk::Walk>,
    /// Per view, its picture as read from its file, for moving it while the design runs
    /// ([`crate::steer`]); None where a view cannot be steered.
    pub sources: Vec<Option<crate::steer::Source>>,
    /// The steering applied so far (a live design's working copy of the problem).
    pub steering: Vec<crate::steer::SteerEvent>,
    /// How the first scratches were drawn, so that scratches added while the design runs are
    /// drawn alike (None: scratches cannot be added).
    pub init: Option<crate::steer::ScratchInit>,
}

impl Problem {
    /// A problem whose pictures cover every on-plate pixel.
    pub fn new(scene: Scene, targets: Vec<Vec<f32>>) -> Problem {
        let pictures = (0..scene.views.len())
            .map(|v| scratchart_model::camera::on_plate_mask(&scene, v))
            .collect();
        let picture_rects = vec![None; scene.views.len()];
        Problem {
            scene,
            targets,
            pictures,
            picture_rects,
            walk: None,
            sources: Vec::new(),
            steering: Vec::new(),
            init: None,
        }
    }
}

#[derive(Clone, Debug)]
pub struct DesignConfig {
    pub iters: u32,
    pub loss: LossConfig,
    pub adam: AdamConfig,
    /// Write a checkpoint every this many iterations (0: only at the end).
    pub checkpoint_every: u32,
    pub out: PathBuf,
    /// Continue from `out/checkpoint.bin`.
    pub resume: bool,
    pub prune: PruneConfig,
    pub hooks: Hooks,
    /// Seed of the initialization (recorded; the optimizer itself draws no random numbers).
    pub seed: u64,
    /// The share of the initial scratches drawn facing a view (`--aim`; recorded).
    pub aim: f64,
    /// The learning rates' share at the last step (`--lr-final`; 1: constant;
    /// [`scratchart_optim::driver::lr_schedule`]).
    pub lr_final: f64,
    /// Scale the lights at the start so that each view's mean on-plate L matches its target's.
    pub calibrate_lights: bool,
    /// `--exposure fixed`: the views of each lamp stay tied (one intensity moves, each view's
    /// exposure stays as the scene gives it, 1 by default), so the plate under one lamp looks as
    /// the renders do without any adaptation. Otherwise (`free`) each view's brightness is its
    /// own (an exposure per view, what an eye's adaptation or a camera does), reported as such.
    pub keep_exposures: bool,
    /// Views left blank on purpose (`--blank-view`): their pictures are uniform; the set-up
    /// sheet says so instead of tolerances, and `summary.json` lists them.
    pub blank_views: Vec<String>,
    /// Give up after this many rollbacks.
    pub max_rollbacks: u32,
    /// Write the output files (design, images, plot, summary).
    pub write_outputs: bool,
    /// Fabrication mode: one carve depth per scratch through this tool (`design --tool`).
    pub tool: Option<Fabrication>,
    /// Within a machine (`design --machine`): carvings perturbed by the machine's error that the
    /// written design is scored on (`summary.json`'s `machine_error`); 0: none.
    pub carvings: u32,
    /// When the job started (the process, for a program), for the start-up time in the wall
    /// times; None: the start-up is not counted.
    pub started: Option<std::time::Instant>,
    /// Steering to replay (`scratchart design --steer`), in the order of its iterations.
    pub steer: Vec<crate::steer::SteerEvent>,
    /// Each view's weight follows its shortfall against its cap (`design --balance`,
    /// [`crate::balance`]).
    pub balance: bool,
    /// Scratches may bend (`design --arcs`): each bulge is a parameter too.
    pub arcs: Option<scratchart_optim::arc_params::ArcConfig>,
}

impl DesignConfig {
    pub fn new(plate_mm: f64, out: PathBuf) -> DesignConfig {
        DesignConfig {
            iters: 200,
            loss: LossConfig::default(),
            adam: AdamConfig::for_plate(plate_mm),
            checkpoint_every: 50,
            out,
            resume: false,
            prune: PruneConfig::default(),
            hooks: Hooks::default(),
            seed: 1,
            aim: 0.0,
            lr_final: 1.0,
            calibrate_lights: true,
            keep_exposures: false,
            blank_views: Vec::new(),
            max_rollbacks: 30,
            write_outputs: true,
            tool: None,
            carvings: 8,
            started: None,
            steer: Vec::new(),
            balance: false,
            arcs: None,
        }
    }
}

/// One accepted loss evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct IterRecord {
    pub pixel: Vec<f32>,
    pub gram: Vec<f32>,
    pub total: f32,
}

impl From<&Evaluation> for IterRecord {
    fn from(e: &Evaluation) -> Self {
        let l = LossValues::from(e);
        IterRecord {
            pixel: l.pixel,
            gram: l.gram,
            total: l.total,
        }
    }
}

/// Where the set-up sheet's wall time went: its tolerance searches (of them, the engine's
/// uploads, renders and read-backs; the steps, each its moves' renders in batches) and its
/// picture.
#[derive(Clone, Copy, Debug, Default)]
pub struct SheetWall {
    pub searches: f64,
    pub search_steps: usize,
    pub png: f64,
    /// The searches' seconds taken apart (`set_up_sheet_uploads`, `..._render_s`, ...; those in
    /// the engine's calls are `set_up_sheet_searches_engine`).
    pub clock: crate::tolerance::SearchClock,
}

/// Wall-clock seconds of a design run's phases.
#[derive(Clone, Copy, Debug, Default)]
pub struct WallTimes {
    /// From the process start (device, kernels, uploads, light calibration, the first render)
    /// to the first iteration.
    pub start_up: f64,
    /// The optimization loop.
    pub iterations: f64,
    /// Pruning trials.
    pub pruning: f64,
    /// The final render, the quality report, images, plots and the set-up sheet (0 until written).
    pub reports: f64,
    /// Of `reports`: the final render (upload, render, loss, read-back) and the set-up sheet
    /// (its searches' renders and measures, its text and picture).
    pub final_render: f64,
    pub set_up_sheet: f64,
    /// Of `set_up_sheet`: its searches, their engine calls, and its picture.
    pub sheet: SheetWall,
    /// Of `iterations`: the evaluations' submissions (recording, the device's work, the wait),
    /// the checkpoints and the hooks after each iteration (`scratchart_optim::driver::RunStats`).
    pub iterations_submissions: f64,
    pub iterations_checkpoints: f64,
    pub iterations_hooks: f64,
}

impl WallTimes {
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = json!({
            "start_up": self.start_up,
            "iterations": self.iterations,
            "pruning": self.pruning,
            "final_render_and_reports": self.reports,
            "final_render": self.final_render,
            "set_up_sheet": self.set_up_sheet,
            "set_up_sheet_searches": self.sheet.searches,
            "set_up_sheet_searches_engine": self.sheet.clock.engine_s(),
            "set_up_sheet_search_steps": self.sheet.search_steps,
            "set_up_sheet_png": self.sheet.png,
            "iterations_submissions": self.iterations_submissions,
            "iterations_checkpoints": self.iterations_checkpoints,
            "iterations_hooks": self.iterations_hooks,
            "total": self.start_up + self.iterations + self.pruning + self.reports,
        });
        if let (Some(w), serde_json::Value::Object(c)) = (v.as_object_mut(), self.sheet.clock.to_json()) {
            w.extend(c);
        }
        v
    }
}

/// What a design run produced.
#[derive(Clone, Debug)]
pub struct DesignReport {
    /// The final design (after pruning, if any).
    pub scene: Scene,
    /// The optimized design before pruning.
    pub unpruned: Scene,
    pub history: Vec<IterRecord>,
    pub rollbacks: Vec<Rollback>,
    pub prune: Option<PruneStats>,
    /// Loss of the final design (after pruning).
    pub final_loss: LossValues,
    /// Wall seconds of the optimization loop and iterations run in this process.
    pub loop_seconds: f64,
    pub iters_run: u32,
    /// Mean (pixel, scratch) pairs per iteration and GPU milliseconds per phase.
    pub mean_pairs: f64,
    pub gpu_ms: Vec<(String, f64)>,
    /// Display images of the final design and of the initial one, per view.
    pub final_images: Vec<Vec<f32>>,
    pub initial_images: Vec<Vec<f32>>,
    pub resumed_from: Option<u32>,
    /// What `summary.json` holds, when the outputs were written.
    pub summary: Option<serde_json::Value>,
    /// Fabrication mode: the commanded depth of every written scratch, mm.
    pub depths: Option<Vec<f64>>,
    /// Each view's weight in the loss at the end of the run (all 1 without `--balance`).
    pub view_weights: Vec<f32>,
    /// Wall time by phase.
    pub wall: WallTimes,
    /// Bytes of device memory the job's buffers held when the iterations ended (the tile lists
    /// grown to the design's pairs, the loss, the optimizer).
    pub device_bytes: u64,
}
