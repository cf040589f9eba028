//! The low-level Vulkan layer (ash), in the spirit of kajiya's `kajiya-backend`: one small
//! module per concept.
//!
//! - [`instance`]: the instance, the validation layer and the debug messenger ([`ValidationLog`]).
//! - [`physical_device`]: device listing and choice, optional features, [`DeviceInfo`].
//! - [`device`]: [`Context`], the logical device with its compute queue and memory allocator;
//!   it owns the instance and destroys everything in the right order.
//! - [`transfer`]: one-off uploads and read-backs through staging buffers.
//! - [`buffer`]: storage buffers backed by `gpu-allocator`.
//! - [`shader`]: GLSL -> SPIR-V: built in at build time for the kernels in use, else via shaderc
//!   from embedded sources or a directory.
//! - [`pipeline`]: compute pipelines with a fixed "N storage buffers + push constants" layout.
//! - [`pipeline_cache`]: the persistent `VkPipelineCache` every pipeline is built with.
//! - [`recorder`]: command recording, descriptor sets, barriers, submission, GPU timestamps.
//! - [`error`]: the [`GpuError`] type every fallible call returns.
//!
//! Lifetime rule: every [`Buffer`], [`ComputePipeline`] and [`Recorder`] holds an
//! `Arc<Context>`, so the device always outlives the objects created from it.
pub mod buffer;
pub mod device;
pub mod error;
pub mod instance;
pub mod physical_device;
pub mod pipeline;
pub mod pipeline_cache;
pub mod recorder;
pub mod shader;
pub mod transfer;

pub use buffer::{Buffer, MemLoc};
pub use device::{Context, ContextDesc};
pub use error::GpuError;
pub use instance::ValidationLog;
pub use physical_device::{list_devices, DeviceInfo, DeviceSummary};
pub use pipeline::{ComputePipeline, Texel};
pub use pipeline_cache::PipelineCacheDir;
pub use recorder::{Recorder, Timings};
pub use shader::ShaderCompiler;
