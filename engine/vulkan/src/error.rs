//! [`GpuError`]: every failure the Vulkan layer reports. Contract violations by the caller
//! (wrong number of buffers for a pipeline, oversized dispatch, ...) panic instead.
use ash::vk;

/// Formats a byte count as MiB with one decimal, e.g. `300.0 MiB`.
pub(crate) fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / (1024.0 * 1024.0))
}

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("cannot load the Vulkan library: {0}")]
    Loading(String),

    #[error("no usable Vulkan device: {reason}; available devices: {}", list_or_none(.available))]
    NoDevice { reason: String, available: Vec<String> },

    #[error("{call} failed: {result}")]
    Vk { call: &'static str, result: vk::Result },

    #[error(
        "buffer '{name}' needs {} but this device binds at most {} per storage buffer; \
         reduce the scene (fewer scratches, views or pixels)",
        mib(*.size),
        mib(*.limit)
    )]
    BufferTooLarge { name: String, size: u64, limit: u64 },

    #[error("out of GPU memory allocating buffer '{name}' ({}); reduce the scene", mib(*.size))]
    OutOfMemory { name: String, size: u64 },

    #[error("memory allocation for '{name}' failed: {msg}")]
    Allocation { name: String, msg: String },

    #[error("buffer '{0}' is not host-visible; use Context::download or a GpuToCpu/CpuToGpu buffer")]
    NotHostVisible(String),

    #[error("shader '{path}' failed to compile:\n{log}")]
    Shader { path: String, log: String },

    /// A kernel capacity that splitting the work cannot meet; the message says what to change.
    #[error("{0}")]
    Capacity(String),

    #[error("GPU work did not finish within {0} s (hung or far too large a dispatch)")]
    Timeout(u64),

    #[error(
        "the Vulkan device was lost (VK_ERROR_DEVICE_LOST) while running submitted work; usually \
         an out-of-bounds access in a shader or a dispatch that exceeded the driver's watchdog"
    )]
    DeviceLost,
}

fn list_or_none(v: &[String]) -> String {
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

/// Maps a raw `vk::Result` from the call named `call` to a [`GpuError`].
pub(crate) fn vk_err(call: &'static str) -> impl Fn(vk::Result) -> GpuError {
    move |result| match result {
        vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost,
        _ => GpuError::Vk { call, result },
    }
}

/// Every failure of the Vulkan layer is the device's (exit 5 in the one exit contract).
impl scratchart_exit::ExitClass for GpuError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        Some(scratchart_exit::Class::Device)
    }
}
