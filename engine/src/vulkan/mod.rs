//! The low-level Vulkan layer (ash), in the spirit of kajiya's `kajiya-backend`: one small
//! module per concept.
//!
//! - [`context`]: instance, validation messenger, physical-device choice, device, queue,
//!   memory allocator, plus one-off upload/download helpers.
//! - [`buffer`]: storage buffers backed by `gpu-allocator`.
//! - [`shader`]: GLSL -> SPIR-V via shaderc, from embedded sources or a directory.
//! - [`pipeline`]: compute pipelines with a fixed "N storage buffers + push constants" layout.
//! - [`recorder`]: command recording, descriptor sets, barriers, submission, GPU timestamps.
//! - [`error`]: the [`GpuError`] type every fallible call returns.
//!
//! Lifetime rule: every [`Buffer`], [`ComputePipeline`] and [`Recorder`] holds an
//! `Arc<Context>`, so the device always outlives the objects created from it.
pub mod buffer;
pub mod context;
pub mod error;
pub mod pipeline;
pub mod recorder;
pub mod shader;

pub use buffer::{Buffer, MemLoc};
pub use context::{list_devices, Context, ContextDesc, DeviceInfo, DeviceSummary, ValidationLog};
pub use error::GpuError;
pub use pipeline::ComputePipeline;
pub use recorder::{Recorder, Timings};
pub use shader::ShaderCompiler;
