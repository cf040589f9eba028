//! scratchart-design: the design job of a scratched plate (engine/docs/model.md section 7), a
//! quiet library. A typed [`spec::DesignSpec`] (what `scratchart design`'s flags and the viewer's
//! live design fill in) becomes a [`problem::Problem`] and a [`design::DesignConfig`]
//! ([`spec::prepare`]); [`design::run_design`] optimizes it on the GPU with the generic optimizer of
//! `scratchart-optim` (the driver, Adam, the losses and the parameter sets named below live there)
//! and writes the design and its reports. It reports through an [`scratchart_observe::Observer`]
//! and never prints; its errors carry their exit class (`scratchart-exit`).
//!
//! - [`spec`]: the design's typed specification, checked, and the problem and configuration it
//!   makes (views on a ring or a walk's arc, the lamp, the initial scratches, the targets, the
//!   tool and the machine's limits, steering).
//! - [`scenes`]: built-in scenes and their parts (seeded random scratches, views on a ring framed
//!   on the plate, orbiting lamps, the demo plate, the benchmark scenes).
//! - [`aim`]: the initial scratches turned to face the views, placed where each view's picture
//!   asks for light (`--aim`).
//!
//! In `scratchart-optim`:
//! - `driver`: the generic optimizer: iterate, roll back, checkpoint, resume, over any
//!   `Objective` and any `ParamSet`.
//! - `least_squares`: the generic optimizer for a few parameters and many residuals: robust
//!   Levenberg-Marquardt within bounds over any `LeastSquares` problem (the
//!   tool calibration; its Jacobian from the engine's tangents).
//! - `adam`: Adam on flat parameter buffers with learning-rate groups (`shaders/adam.comp`).
//! - `checkpoint`: the checkpoint file (serde header, named chunks).
//! - `loss`: the design loss on the GPU (display transform, blurred squared error, Gram
//!   matrices of a fixed multi-scale oriented feature bank) and its backward to dE/dL; f64 CPU
//!   twin for tests. It is the design's objective.
//! - `check`: the check loss E_lin of engine/docs/model.md section 8 as an objective on the GPU.
//! - `scene_params`: the design's parameter set (scratches and lights) and its projection.
//! - `tool_params`: fabrication mode's parameter set: one carve depth per scratch through a
//!   calibrated tool's curve (`design --tool`).
//! - `prune`: removal of scratches that barely matter, checked by true forward evaluations.
//!
//! Here:
//! - [`carving`]: what the machine's error costs a design: perturbed carvings rendered and
//!   scored (`design --machine`).
//! - [`design`]: the design job: the driver with the design loss and the scene's (or the tool's) parameters, then pruning and the reports.
//! - [`arcs`]: designs whose scratches bend (`--arcs`): their summary and the chords per arc they
//!   were judged at.
//! - [`job_time`]: a design's job time as `plan` makes it for a machine.
//! - [`job_limit`]: a design sized to the job time the maker has (`design --max-job-min`).
//! - [`targets`]: target images (files, or the built-in circle / triangle / star).
//! - [`framing`]: where a picture goes in a view (upright and as large as fits inside the
//!   plate's silhouette by default).
//! - [`problem`]: the design problem, the job's configuration and what a run produced.
//! - [`measure`]: image measures (blur, SSIM, correlation, each view's quality and cross-talk).
//! - [`report`]: the design's outputs: compare images, the loss-curve plot and the summary.
//! - [`setup`]: where the lamp and the viewers go, and how precisely (setup sheet, sensitivity).
//! - [`live`]: a live design's view of the running optimizer and the changes it makes.
//! - [`steer`]: a picture moved or scaled while the design runs, and the same replayed
//!   (`scratchart-view --design`, `scratchart design --steer`).
//! - [`walk`]: walk-past plates: views along an arc, in-between views whose targets are
//!   cross-fades, and their report (`design --walk/--hold/--object`).
//!
//! Determinism: every GPU reduction runs in a fixed order and the host feeds back only values it
//! read from the GPU, so a run is bit-reproducible on one device, and a resumed run equals an
//! uninterrupted one bit for bit.
pub mod aim;
pub mod arcs;
pub mod balance;
pub mod bend;
pub mod carving;
pub mod design;
pub mod framing;
pub mod job_limit;
pub mod job_time;
pub mod lamp_place;
pub mod live;
pub mod measure;
pub mod problem;
pub mod reach;
pub mod report;
pub mod scenes;
pub mod setup;
pub mod setup_sheet;
pub mod spec;
pub mod steer;
pub mod targets;
pub mod tolerance;
pub mod walk;
pub mod walk_report;

pub use design::run_design;
pub use problem::Problem;
pub use problem::{DesignConfig, DesignReport};
pub use spec::{prepare, DesignSpec, SpecError};
