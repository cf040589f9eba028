//! The optimizer: fits parameters against an objective on the GPU, over the renderer.
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
//!   twin for tests.
//! - [`check`]: the check loss E_lin of engine/docs/model.md section 8 as an objective on the GPU, and the
//!   gradients of any objective in one submission.
//! - [`scene_params`]: the design's parameter set (scratches and lights) and its projection.
//! - [`arc_params`]: the same where scratches may bend (`design --arcs`): the bulge too.
//! - [`tool_params`]: fabrication mode's parameter set: one carve depth per scratch through a
//!   calibrated tool's curve.
//! - [`light_tie`]: views that share a lamp share its intensity (a parameter-set wrapper).
//! - [`prune`]: removal of scratches that barely matter, checked by true forward evaluations.
//! - [`error`]: what can stop an optimization.
//!
//! Determinism: every GPU reduction runs in a fixed order and the host feeds back only values it
//! read from the GPU, so a run is bit-reproducible on one device, and a resumed run equals an
//! uninterrupted one bit for bit.
pub mod adam;
pub mod arc_params;
pub mod check;
pub mod checkpoint;
pub mod driver;
pub mod error;
pub mod least_squares;
pub mod light_tie;
pub mod loss;
pub mod prune;
pub mod scene_params;
pub mod tool_params;

pub use adam::AdamConfig;
pub use driver::{Driver, DriverConfig, Evaluation, Objective, ParamSet};
pub use error::OptimError;
pub use loss::LossConfig;
pub use prune::PruneConfig;

// The crates beneath, by the names the engine gives them.
use scratchart_model as model;
use scratchart_render as render;
use scratchart_render::io;
use scratchart_vulkan as vulkan;
