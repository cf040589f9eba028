//! The design optimizer (`scratchart design`): fits scratch parameters and light intensities so
//! that each view of the plate shows its target image (MODEL.md section 7).
//!
//! - [`loss`]: the loss on the GPU (display transform, blurred squared error, Gram matrices of a
//!   fixed multi-scale oriented feature bank) and its backward to dE/dL; f64 CPU twin for tests.
//! - [`adam`]: Adam on the GPU with the projection onto valid parameters; CPU twin for tests.
//! - [`design`]: the optimization loop (one GPU submission per iteration: binning, forward, loss,
//!   backward, Adam), rollback of bad steps, checkpoints and bit-exact resume.
//! - [`prune`]: removal of scratches that barely matter, checked by true forward evaluations.
//! - [`targets`]: target images (files, or the built-in circle / triangle / star).
//! - [`report`]: compare images, SSIM, the loss-curve plot and the summary.
//! - [`cli`]: the `design` subcommand's flags and driver.
//!
//! Determinism: every GPU reduction runs in a fixed order and the host feeds back only values it
//! read from the GPU, so a run is bit-reproducible on one device, and a resumed run equals an
//! uninterrupted one bit for bit.
pub mod adam;
pub mod cli;
pub mod design;
pub mod loss;
pub mod prune;
pub mod report;
pub mod targets;

pub use adam::AdamConfig;
pub use design::{DesignConfig, DesignReport, Problem};
pub use loss::LossConfig;
pub use prune::PruneConfig;
