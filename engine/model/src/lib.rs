//! `scratchart-model`: the scratch reflection model of `engine/docs/model.md`, with no GPU code
//! and no image or shader libraries, so the machine driver and other tools that need scenes but
//! no Vulkan build and test on any machine.
//!
//! - [`scene`]: the scene's types; [`scene_file`]: the scene file (JSON + scratch CSV), read,
//!   validated (with [`camera`]'s geometry) and written.
//! - [`camera`]: float64 view geometry (camera basis, rays, footprints, shading points,
//!   on-plate mask, light).
//! - [`reference`](mod@reference): the float64 CPU reference renderer — a test oracle only, never a fallback
//!   for the GPU path.
//! - [`mesh`]: OBJ meshes: reading, placing behind the plate and rendering their views (the target
//!   images of a scratch hologram).
//! - [`arc`](mod@arc): arc scratches' geometry (bulge, centre, sweep, chords, carved box).
//! - [`surface`]: the plate's shape (flat, or bent into a cylinder after carving) in float64.
//! - [`fsio`]: the atomic file writer (temporary file, fsync, rename) every output goes through.

// `!(x > 0.0)` is used on purpose throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod arc;
pub mod camera;
pub mod display;
pub mod fsio;
pub mod mesh;
pub mod par;
pub mod reference;
pub mod scene;
pub mod scene_file;
pub mod surface;

pub use camera::{CameraBasis, LightSample, ViewGeom};
pub use reference::{check_loss, pixel, render_view, scratch_patch_integral, PixelRef};
pub use scene::{Camera, Light, LightKind, Plate, Scene, SceneError, Scratch, View};
pub use scene_file::read_scratches_csv;
pub use surface::{BendAxis, PlateShape};
