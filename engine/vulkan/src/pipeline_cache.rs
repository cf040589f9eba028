//! A persistent `VkPipelineCache`: pipelines built in one run are found by the driver in the
//! next, so a run compiles nothing the device compiled before (on drivers that use the cache;
//! Mesa's lavapipe keeps its own shader cache as well).
//!
//! The file is `DIR/pipelines-VENDOR-DEVICE-UUID.bin`, with DIR from [`ContextDesc::pipeline_cache`]
//! (`crate::ContextDesc`), else `SCRATCHART_CACHE_DIR`, else `$XDG_CACHE_HOME/scratchart`,
//! else `$HOME/.cache/scratchart`; `SCRATCHART_PIPELINE_CACHE=0` turns it off. A file whose header
//! does not match the device (another driver version, a damaged file) is ignored and replaced.
//! The cache is written back, atomically, when the context is dropped, if it changed.
use std::path::{Path, PathBuf};

use ash::vk;

/// Where the pipeline cache lives.
#[derive(Clone, Debug, Default)]
pub enum PipelineCacheDir {
    /// `SCRATCHART_CACHE_DIR`, `$XDG_CACHE_HOME/scratchart` or `$HOME/.cache/scratchart`
    /// (`SCRATCHART_PIPELINE_CACHE=0`: none).
    #[default]
    Auto,
    /// This directory.
    Dir(PathBuf),
    /// No file: an in-memory cache for this process only.
    Off,
}

pub(crate) struct PersistentCache {
    pub cache: vk::PipelineCache,
    path: Option<PathBuf>,
    /// Bytes the cache held when loaded (it is written back only when that changed).
    loaded: usize,
}

fn default_dir() -> Option<PathBuf> {
    if std::env::var("SCRATCHART_PIPELINE_CACHE").is_ok_and(|v| v == "0") {
        return None;
    }
    let nonempty = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    nonempty("SCRATCHART_CACHE_DIR")
        .or_else(|| nonempty("XDG_CACHE_HOME").map(|d| d.join("scratchart")))
        .or_else(|| nonempty("HOME").map(|d| d.join(".cache").join("scratchart")))
}

/// The file name for this device: vendor, device and the driver's pipeline-cache UUID.
fn file_name(props: &vk::PhysicalDeviceProperties) -> String {
    let uuid: String = props.pipeline_cache_uuid.iter().map(|b| format!("{b:02x}")).collect();
    format!("pipelines-{:04x}-{:04x}-{uuid}.bin", props.vendor_id, props.device_id)
}

/// Whether `data` starts with a version-one header for this device (Vulkan spec, "Pipeline
/// Cache": header length, version, vendor ID, device ID, pipeline cache UUID).
pub(crate) fn header_matches(data: &[u8], props: &vk::PhysicalDeviceProperties) -> bool {
    if data.len() < 32 {
        return false;
    }
    let u = |i: usize| u32::from_le_bytes([data[i], data[i + 1], data[i + 2], data[i + 3]]);
    let header_len = u(0) as usize;
    header_len >= 32
        && header_len <= data.len()
        && u(4) == vk::PipelineCacheHeaderVersion::ONE.as_raw() as u32
        && u(8) == props.vendor_id
        && u(12) == props.device_id
        && data[16..32] == props.pipeline_cache_uuid
}

impl PersistentCache {
    /// Creates the cache, seeded from the file when it is there and matches the device.
    pub fn new(
        device: &ash::Device,
        props: &vk::PhysicalDeviceProperties,
        dir: &PipelineCacheDir,
    ) -> Result<PersistentCache, vk::Result> {
        let dir = match dir {
            PipelineCacheDir::Auto => default_dir(),
            PipelineCacheDir::Dir(d) => Some(d.clone()),
            PipelineCacheDir::Off => None,
        };
        let path = dir.map(|d| d.join(file_name(props)));
        let data = path
            .as_deref()
            .and_then(|p| std::fs::read(p).ok())
            .filter(|d| header_matches(d, props))
            .unwrap_or_default();
        let ci = vk::PipelineCacheCreateInfo::default().initial_data(&data);
        let cache = match unsafe { device.create_pipeline_cache(&ci, None) } {
            Ok(c) => c,
            // A driver that rejects the data: start empty.
            Err(_) if !data.is_empty() => unsafe {
                device.create_pipeline_cache(&vk::PipelineCacheCreateInfo::default(), None)?
            },
            Err(e) => return Err(e),
        };
        Ok(PersistentCache {
            cache,
            path,
            loaded: data.len(),
        })
    }

    /// Writes the cache back if it changed, then destroys it; returns the warning to give when
    /// it could not be saved (never fatal: it is a cache). Call before the device is destroyed.
    pub fn save_and_destroy(&mut self, device: &ash::Device) -> Option<String> {
        let mut warning = None;
        if let Some(path) = &self.path {
            if let Ok(data) = unsafe { device.get_pipeline_cache_data(self.cache) } {
                if data.len() != self.loaded && !data.is_empty() {
                    if let Err(e) = write(path, &data) {
                        warning = Some(format!("cannot save the pipeline cache {}: {e}", path.display()));
                    }
                }
            }
        }
        unsafe { device.destroy_pipeline_cache(self.cache, None) };
        self.cache = vk::PipelineCache::null();
        warning
    }

    /// The file, if the cache has one.
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }
}

fn write(path: &Path, data: &[u8]) -> Result<(), String> {
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d).map_err(|e| e.to_string())?;
    }
    scratchart_model::fsio::write_atomic(path, data).map_err(|e| e.to_string())
}
