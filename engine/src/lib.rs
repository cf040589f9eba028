//! scratchart: the program. Its command line (`scratchart render | grad | design | bench | study
//! ...`), the terminal (progress, Ctrl-C), the benchmarks, the speed-against-accuracy study, and the
//! one exit mapping of every binary (engine, viewer, calibration). The work is the libraries':
//! `scratchart-model` (the scene model and the float64 reference), `scratchart-vulkan`,
//! `scratchart-render`, `scratchart-optim` and `scratchart-design` (the design job); each import
//! names the crate it comes from.
//!
//! - [`design_cmd`]: `scratchart design`'s flags, which make a `scratchart_design::DesignSpec`,
//!   shared with the viewer's live design (`scratchart-view --design`), and its printed summary.
//! - [`exit`]: the exit-code contract shared by every binary.
//! - [`term`]: the terminal observer (a progress bar, or lines in a log) and Ctrl-C.
//! - [`bench`]: the benchmarks (`scratchart bench`).
//! - [`study`]: the speed-against-accuracy study (`scratchart study`).
pub mod bench;
pub mod design_cmd;
pub mod exit;
pub mod study;
pub mod term;
