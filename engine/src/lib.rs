//! scratchart: a GPU engine for scratch-based reflection art.
//!
//! - [`vulkan`]: the ash layer (instance, device, buffers, compute pipelines, command recording):
//!   the crate `scratchart-vulkan` (`engine/vulkan/`), re-exported here.
//! - [`model`]: the scratch model of `engine/docs/model.md`: scene files, geometry, and the float64 CPU
//!   reference (a test oracle only; never a fallback for the GPU path). It is the crate
//!   `scratchart-model` (`engine/model/`), re-exported here so `scratchart::model::...` paths hold;
//!   it builds without Vulkan, for the crates that need the scene model but no GPU.
//! - [`render`]: the GPU renderer (pair search, patch-NDF shading, images, gradients): the crate
//!   `scratchart-render` (`engine/render/`), re-exported here, with [`limits`].
//! - [`io`]: PFM/PNG image files, written atomically.
//! - [`optim`]: the generic optimizer (objective and parameter-set interfaces, Adam, rollback,
//!   checkpoints) and the design job behind `scratchart design`.
//! - [`observe`]: the [`observe::Observer`] trait: how libraries report progress and warnings
//!   (they never print).
//! - [`exit`]: the exit-code contract shared by every binary.
//! - [`limits`]: scene sizes checked against the device and the host before any work.
//! - [`design_cmd`]: `scratchart design`'s flags, problem and run, shared with the viewer's live
//!   design (`scratchart-view --design`).
// The library's own modules name it `scratchart::` as its programs do (`design_cmd`).
extern crate self as scratchart;

pub mod bench;
pub mod design_cmd;
pub mod exit;
pub use scratchart_model as model;
pub use scratchart_optim::observe;
pub use scratchart_render::io;
pub use scratchart_render::limits;
pub mod optim;
pub use scratchart_render as render;
pub mod scenes;
pub mod study;
pub mod term;
pub use scratchart_vulkan as vulkan;
