//! The optimizer and the design job (`scratchart design`): fits parameters against an objective
//! on the GPU (engine/docs/model.md section 7 for the design). The generic optimizer is the crate
//! `scratchart-optim` (`engine/optim/`), re-exported here module by module; the design job and
//! its reports are the application's.
//!
//! - [`driver`]: the generic optimizer: iterate, roll back, checkpoint, resume, over any
//!   [`driver::Objective`] and any [`driver::ParamSet`].
//! - [`least_squares`]: the generic optimizer for a few parameters and many residuals: robust
//!   Levenberg-Marquardt within bounds over any [`least_squares::LeastSquares`] problem (the
//!   tool calibration; its Jacobian from the engine's tangents).
//! - [`adam`]: Adam on flat parameter buffers with learning-rate groups (`shaders/adam.comp`).
//! - [`checkpoint`]: the checkpoint file (serde header, named chunks).
//! - [`loss`]: the design loss on the GPU (display transform, blurred squared error, Gram
//!   matrices of a fixed multi-scale oriented feature bank) and its backward to dE/dL; f64 CPU
//!   twin for tests. It is the design's objective.
//! - [`check`]: the check loss E_lin of engine/docs/model.md section 8 as an objective on the GPU.
//! - [`scene_params`]: the design's parameter set (scratches and lights) and its projection.
//! - [`tool_params`]: fabrication mode's parameter set: one carve depth per scratch through a
//!   calibrated tool's curve (`design --tool`).
//! - [`carving`]: what the machine's error costs a design: perturbed carvings rendered and
//!   scored (`design --machine`).
//! - [`design`]: the design job: the driver with those two, then pruning and the reports.
//! - [`job_limit`]: a design sized to the job time the maker has (`design --max-job-min`).
//! - [`prune`]: removal of scratches that barely matter, checked by true forward evaluations.
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
//! - [`error`]: what can stop an optimization.
//!
//! Determinism: every GPU reduction runs in a fixed order and the host feeds back only values it
//! read from the GPU, so a run is bit-reproducible on one device, and a resumed run equals an
//! uninterrupted one bit for bit.
pub use scratchart_optim::{
    adam, check, checkpoint, driver, error, least_squares, light_tie, loss, prune, scene_params, tool_params,
};

pub mod carving;
pub mod design;
pub mod framing;
pub mod job_limit;
pub mod live;
pub mod measure;
pub mod problem;
pub mod report;
pub mod setup;
pub mod setup_sheet;
pub mod steer;
pub mod targets;
pub mod tolerance;
pub mod walk;
pub mod walk_report;

pub use adam::AdamConfig;
pub use design::{DesignConfig, DesignReport, Problem};
pub use driver::{Driver, DriverConfig, Evaluation, Objective, ParamSet};
pub use error::OptimError;
pub use loss::LossConfig;
pub use prune::PruneConfig;
