//! scratchart: a GPU engine for scratch-based reflection art.
//!
//! - [`vulkan`]: the ash layer (instance, device, buffers, compute pipelines, command recording).
//! - [`model`]: the scratch model of `MODEL.md`: scene files, geometry, and the float64 CPU
//!   reference (a test oracle only; never a fallback for the GPU path).
//! - [`render`]: the GPU forward renderer (pair search, patch-NDF shading, images).
//! - [`io`]: PFM/PNG image files, written atomically.
//! - [`optim`]: the design optimizer (loss, Adam, rollback, checkpoints, pruning) behind `scratchart design`.
pub mod bench;
pub mod io;
pub mod model;
pub mod optim;
pub mod render;
pub mod scenes;
pub mod vulkan;
