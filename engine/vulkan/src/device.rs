//! [`Context`]: the logical device with its single compute queue (and the lock that queue
//! submissions need), the `gpu-allocator` memory allocator and object names for validation
//! messages. It owns the instance and messenger (`instance.rs`) and is made on the physical
//! device `physical_device.rs` chooses; its one-off transfers are in `transfer.rs`.
use std::{
    ffi::{CStr, CString},
    mem::ManuallyDrop,
    sync::{Arc, Mutex, MutexGuard},
};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::{
    error::{vk_err, GpuError},
    instance::{has_ext, Instance, ValidationLog},
    physical_device::{self, DeviceInfo},
    pipeline_cache::{PersistentCache, PipelineCacheDir},
};
use std::path::{Path, PathBuf};

/// How long one-off and recorded submissions may run before we report [`GpuError::Timeout`].
pub(crate) const SUBMIT_TIMEOUT_S: u64 = 60;

/// How to create a [`Context`].
#[derive(Clone, Default)]
pub struct ContextDesc {
    /// Enable `VK_LAYER_KHRONOS_validation` and the debug messenger. Also forced on by the
    /// environment variable `SCRATCHART_VALIDATION=1`.
    pub validation: bool,
    /// Device selector: an index into the enumerated devices ("0", "1") or a case-insensitive
    /// substring of the device name. When `None`, `SCRATCHART_DEVICE` is used if set.
    pub device: Option<String>,
    /// Extra instance extensions (e.g. surface extensions for the viewer).
    pub instance_extensions: Vec<&'static CStr>,
    /// Extra device extensions (e.g. swapchain).
    pub device_extensions: Vec<&'static CStr>,
    /// When false, say `device: NAME (kind)` to `notify` once at creation.
    pub quiet: bool,
    /// Where the layer's notices go (see [`super::instance::Notify`]); `None`: nowhere.
    pub notify: Option<super::instance::Notify>,
    /// Where the persistent pipeline cache lives (see `vulkan::pipeline_cache`).
    pub pipeline_cache: PipelineCacheDir,
}

/// The Vulkan context every GPU object is made from (through an `Arc`, so it outlives them).
/// `Drop` destroys, in order: the allocator, the device, the messenger, the instance.
pub struct Context {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub physical_device: vk::PhysicalDevice,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    /// Dropped by hand in `Drop` *before* the device is destroyed (it frees device memory).
    allocator: ManuallyDrop<Mutex<Allocator>>,
    /// `vkQueueSubmit`/`vkQueueWaitIdle` need external synchronisation of the queue.
    queue_lock: Mutex<()>,
    debug_instance: Option<ash::ext::debug_utils::Instance>,
    debug_device: Option<ash::ext::debug_utils::Device>,
    messenger: vk::DebugUtilsMessengerEXT,
    /// Its `Arc` payload is the messenger's user data: it must outlive the instance, which it
    /// does because the field is dropped after `Drop::drop` destroyed the instance.
    log: ValidationLog,
    validation: bool,
    info: DeviceInfo,
    /// Pipelines of earlier runs (written back at drop).
    pipelines: Mutex<PersistentCache>,
}

impl Context {
    pub fn new(desc: ContextDesc) -> Result<Arc<Context>, GpuError> {
        let env_on = |k: &str| std::env::var(k).is_ok_and(|v| !v.is_empty() && v != "0");
        let want_validation = desc.validation || env_on("SCRATCHART_VALIDATION");
        let selector = desc
            .device
            .clone()
            .or_else(|| std::env::var("SCRATCHART_DEVICE").ok().filter(|s| !s.is_empty()));

        let inst = Instance::new(&desc.instance_extensions, desc.notify.as_ref(), want_validation)?;
        // From here on, failures must tear down the messenger and instance.
        let built = Self::create_device(&inst.instance, &desc, selector.as_deref());
        let (physical_device, device, queue_family, info, allocator) = match built {
            Ok(b) => b,
            Err(e) => {
                unsafe { inst.destroy() };
                return Err(e);
            }
        };
        let props = unsafe { inst.instance.get_physical_device_properties(physical_device) };
        let pipelines = match PersistentCache::new(&device, &props, &desc.pipeline_cache) {
            Ok(c) => c,
            Err(e) => {
                drop(allocator);
                unsafe {
                    device.destroy_device(None);
                    inst.destroy();
                }
                return Err(vk_err("vkCreatePipelineCache")(e));
            }
        };
        let Instance {
            entry,
            instance,
            debug_utils,
            debug_instance,
            messenger,
            log,
            validation,
        } = inst;
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let debug_device = debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        if let Some(n) = desc.notify.as_ref().filter(|_| !desc.quiet) {
            n.info(&format!("device: {} ({})", info.name, info.kind));
        }
        Ok(Arc::new(Context {
            entry,
            instance,
            physical_device,
            device,
            queue,
            queue_family,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            queue_lock: Mutex::new(()),
            debug_instance,
            debug_device,
            messenger,
            log,
            validation,
            info,
            pipelines: Mutex::new(pipelines),
        }))
    }

    /// The pipeline cache every pipeline of this context is built with.
    pub fn pipeline_cache(&self) -> vk::PipelineCache {
        self.pipelines.lock().unwrap_or_else(|e| e.into_inner()).cache
    }

    /// The file of the persistent pipeline cache, if it has one.
    pub fn pipeline_cache_file(&self) -> Option<PathBuf> {
        self.pipelines
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .path()
            .map(Path::to_path_buf)
    }

    /// Picks the physical device, creates the logical device and allocator.
    #[allow(clippy::type_complexity)]
    fn create_device(
        instance: &ash::Instance,
        desc: &ContextDesc,
        selector: Option<&str>,
    ) -> Result<(vk::PhysicalDevice, ash::Device, u32, DeviceInfo, Allocator), GpuError> {
        let physical_device::Chosen {
            pd,
            props,
            queue_family,
            family_props,
        } = physical_device::choose(instance, selector)?;

        let dev_exts = unsafe { instance.enumerate_device_extension_properties(pd) }
            .map_err(vk_err("vkEnumerateDeviceExtensionProperties"))?;
        let mut ext_names: Vec<&CStr> = desc.device_extensions.clone();
        if has_ext(&dev_exts, ash::khr::portability_subset::NAME) {
            // Required by the spec whenever the device exposes it.
            ext_names.push(ash::khr::portability_subset::NAME);
        }
        let has_atomic_float = has_ext(&dev_exts, ash::ext::shader_atomic_float::NAME);

        let sup = physical_device::query_features(instance, pd, &props, has_atomic_float);
        Self::finish_device(
            instance,
            pd,
            props,
            queue_family,
            family_props,
            sup.core,
            sup.sup1x,
            sup.atomic_float,
            sup.subgroup_size,
            sup.subgroup_arithmetic,
            ext_names,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn finish_device(
        instance: &ash::Instance,
        pd: vk::PhysicalDevice,
        props: vk::PhysicalDeviceProperties,
        queue_family: u32,
        family_props: vk::QueueFamilyProperties,
        core: vk::PhysicalDeviceFeatures,
        sup1x: Option<(
            vk::PhysicalDeviceVulkan11Features<'static>,
            vk::PhysicalDeviceVulkan12Features<'static>,
        )>,
        atomic_float: Option<vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT<'static>>,
        subgroup_size: u32,
        subgroup_arithmetic: bool,
        mut ext_names: Vec<&CStr>,
    ) -> Result<(vk::PhysicalDevice, ash::Device, u32, DeviceInfo, Allocator), GpuError> {
        // ---- choose features: only what exists and what shaders may use ----
        let en_core = vk::PhysicalDeviceFeatures {
            shader_float64: core.shader_float64,
            shader_int64: core.shader_int64,
            shader_int16: core.shader_int16,
            ..Default::default()
        };
        let mut en11 = vk::PhysicalDeviceVulkan11Features::default();
        let mut en12 = vk::PhysicalDeviceVulkan12Features::default();
        if let Some((s11, s12)) = &sup1x {
            en11.storage_buffer16_bit_access = s11.storage_buffer16_bit_access;
            en11.uniform_and_storage_buffer16_bit_access = s11.uniform_and_storage_buffer16_bit_access;
            en12.shader_float16 = s12.shader_float16;
            en12.shader_int8 = s12.shader_int8;
            en12.storage_buffer8_bit_access = s12.storage_buffer8_bit_access;
            en12.uniform_and_storage_buffer8_bit_access = s12.uniform_and_storage_buffer8_bit_access;
            en12.shader_buffer_int64_atomics = s12.shader_buffer_int64_atomics;
            en12.shader_shared_int64_atomics = s12.shader_shared_int64_atomics;
            en12.scalar_block_layout = s12.scalar_block_layout;
            en12.uniform_buffer_standard_layout = s12.uniform_buffer_standard_layout;
            en12.shader_subgroup_extended_types = s12.shader_subgroup_extended_types;
            en12.subgroup_broadcast_dynamic_id = s12.subgroup_broadcast_dynamic_id;
            en12.host_query_reset = s12.host_query_reset;
            en12.timeline_semaphore = s12.timeline_semaphore;
            en12.vulkan_memory_model = s12.vulkan_memory_model;
            en12.vulkan_memory_model_device_scope = s12.vulkan_memory_model_device_scope;
        }
        let mut en_af = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default();
        if let Some(s) = &atomic_float {
            ext_names.push(ash::ext::shader_atomic_float::NAME);
            en_af.shader_buffer_float32_atomics = s.shader_buffer_float32_atomics;
            en_af.shader_buffer_float32_atomic_add = s.shader_buffer_float32_atomic_add;
            en_af.shader_shared_float32_atomics = s.shader_shared_float32_atomics;
            en_af.shader_shared_float32_atomic_add = s.shader_shared_float32_atomic_add;
        }
        ext_names.sort();
        ext_names.dedup();
        let ext_ptrs: Vec<_> = ext_names.iter().map(|e| e.as_ptr()).collect();

        let prio = [1.0f32];
        let qci = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&prio)];
        let mut f2 = vk::PhysicalDeviceFeatures2::default().features(en_core);
        if sup1x.is_some() {
            f2 = f2.push_next(&mut en11).push_next(&mut en12);
        }
        if atomic_float.is_some() {
            f2 = f2.push_next(&mut en_af);
        }
        // With features in the pNext chain, pEnabledFeatures must stay null.
        let dci = vk::DeviceCreateInfo::default()
            .queue_create_infos(&qci)
            .enabled_extension_names(&ext_ptrs)
            .push_next(&mut f2);
        let device = unsafe { instance.create_device(pd, &dci, None) }.map_err(vk_err("vkCreateDevice"))?;

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: pd,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        });
        let allocator = match allocator {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.destroy_device(None) };
                return Err(GpuError::Allocation {
                    name: "allocator".into(),
                    msg: e.to_string(),
                });
            }
        };

        let mut info = DeviceInfo::new(
            &props,
            &family_props,
            subgroup_size,
            subgroup_arithmetic,
            &en_core,
            &en_af,
        );
        let mem = unsafe { instance.get_physical_device_memory_properties(pd) };
        info.device_memory = mem.memory_heaps[..mem.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0);
        Ok((pd, device, queue_family, info, allocator))
    }

    /// Gives the warning `msg` to the context's observer (`ContextDesc::notify`), if any.
    pub fn warn(&self, msg: &str) {
        if let Some(n) = &self.log.0.notify {
            n.warn(msg);
        }
    }

    pub fn info(&self) -> &DeviceInfo {
        &self.info
    }

    pub fn validation_enabled(&self) -> bool {
        self.validation
    }

    /// Every WARNING or ERROR message the messenger saw since creation.
    pub fn validation_messages(&self) -> Vec<String> {
        self.log.messages()
    }

    /// A handle on the message list that outlives the context (see [`ValidationLog`]).
    pub fn validation_log(&self) -> ValidationLog {
        self.log.clone()
    }

    /// Names a Vulkan object for validation messages and debuggers; no-op without debug utils.
    pub fn set_object_name<H: vk::Handle>(&self, handle: H, name: &str) {
        let Some(dd) = &self.debug_device else { return };
        let Ok(cname) = CString::new(name.replace('\0', " ")) else {
            return;
        };
        let info = vk::DebugUtilsObjectNameInfoEXT::default()
            .object_handle(handle)
            .object_name(&cname);
        // A failure to name an object is harmless; ignore it.
        let _ = unsafe { dd.set_debug_utils_object_name(&info) };
    }

    /// Bytes of device memory this context's buffers hold now (their allocations' sizes).
    pub fn allocated_bytes(&self) -> u64 {
        self.allocator().generate_report().total_allocated_bytes
    }

    pub(crate) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Submits to the queue under the queue lock.
    pub(crate) fn queue_submit(&self, cmd: vk::CommandBuffer, fence: vk::Fence) -> Result<(), GpuError> {
        let cmds = [cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        let _g = self.queue_lock.lock().unwrap_or_else(|e| e.into_inner());
        unsafe { self.device.queue_submit(self.queue, &submit, fence) }.map_err(vk_err("vkQueueSubmit"))
    }

    /// Waits for `fence` with the standard timeout.
    pub(crate) fn wait_fence(&self, fence: vk::Fence) -> Result<(), GpuError> {
        match unsafe {
            self.device
                .wait_for_fences(&[fence], true, SUBMIT_TIMEOUT_S * 1_000_000_000)
        } {
            Ok(()) => Ok(()),
            Err(vk::Result::TIMEOUT) => Err(GpuError::Timeout(SUBMIT_TIMEOUT_S)),
            Err(e) => Err(vk_err("vkWaitForFences")(e)),
        }
    }

    /// Runs `f` with the queue while holding the queue lock, for queue operations this type does
    /// not wrap (e.g. the viewer's `vkQueuePresentKHR`, which needs the same external
    /// synchronisation as `vkQueueSubmit`).
    pub fn with_queue<R>(&self, f: impl FnOnce(vk::Queue) -> R) -> R {
        let _g = self.queue_lock.lock().unwrap_or_else(|e| e.into_inner());
        f(self.queue)
    }

    /// `vkDeviceWaitIdle` (under the queue lock, which it requires).
    pub fn wait_idle(&self) {
        let _g = self.queue_lock.lock().unwrap_or_else(|e| e.into_inner());
        let _ = unsafe { self.device.device_wait_idle() };
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        unsafe {
            let _ = self.device.device_wait_idle();
            let warning = self
                .pipelines
                .get_mut()
                .unwrap_or_else(|e| e.into_inner())
                .save_and_destroy(&self.device);
            if let Some(w) = warning {
                self.warn(&w);
            }
            // The allocator frees its device memory blocks: it must go before the device.
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            // The messenger outlives the device so leaks reported at vkDestroyDevice are seen.
            if let Some(di) = &self.debug_instance {
                if self.messenger != vk::DebugUtilsMessengerEXT::null() {
                    di.destroy_debug_utils_messenger(self.messenger, None);
                }
            }
            self.instance.destroy_instance(None);
        }
    }
}
