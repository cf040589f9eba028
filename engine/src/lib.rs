//! scratchart: a GPU engine for scratch-based reflection art.
//!
//! - [`vulkan`]: the ash layer (instance, device, buffers, compute pipelines, command recording).
//! - [`model`]: the scratch model of `MODEL.md`: scene files, geometry, and the float64 CPU
//!   reference (a test oracle only; never a fallback for the GPU path). It is the crate
//!   `scratchart-model` (`engine/model/`), re-exported here so `scratchart::model::...` paths hold;
//!   it builds without Vulkan, for the crates that need the scene model but no GPU.
//! - [`render`]: the GPU forward renderer (pair search, patch-NDF shading, images).
//! - [`io`]: PFM/PNG image files, written atomically.
//! - [`optim`]: the design optimizer (loss, Adam, rollback, checkpoints, pruning) behind `scratchart design`.
pub mod bench;
pub mod io;
pub use scratchart_model as model;
pub mod optim;
pub mod render;
pub mod scenes;
pub mod vulkan;
