//! [`Context`]: the Vulkan instance, the validation messenger, the choice of physical device,
//! the logical device with its single compute queue, and the `gpu-allocator` memory allocator.
//! Also hosts the one-off transfer helpers [`Context::upload`] and [`Context::download`].
use std::{
    ffi::{c_void, CStr, CString},
    mem::ManuallyDrop,
    sync::{Arc, Mutex, MutexGuard},
};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::{
    buffer::{Buffer, MemLoc},
    error::{vk_err, GpuError},
};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";
/// How long one-off and recorded submissions may run before we report [`GpuError::Timeout`].
pub(crate) const SUBMIT_TIMEOUT_S: u64 = 60;

/// How to create a [`Context`].
#[derive(Clone, Debug, Default)]
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
    /// When false, print `device: NAME (kind)` to stderr once at creation.
    pub quiet: bool,
}

/// What the chosen device is and the limits the rest of the engine must respect.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub name: String,
    /// "discrete" | "integrated" | "virtual" | "cpu" | "other"
    pub kind: String,
    pub api_version: String,
    pub max_storage_buffer_range: u64,
    pub max_workgroup_count: [u32; 3],
    pub max_workgroup_invocations: u32,
    pub max_shared_memory: u32,
    pub max_push_constants_size: u32,
    pub timestamp_period_ns: f64,
    /// Whether the compute queue supports timestamps (otherwise [`super::Timings`] is empty).
    pub timestamps: bool,
    pub timestamp_valid_bits: u32,
    pub subgroup_size: u32,
    /// `shaderFloat64` enabled.
    pub float64: bool,
    /// `shaderInt64` enabled.
    pub int64: bool,
    /// `VK_EXT_shader_atomic_float` with `shaderBufferFloat32AtomicAdd` enabled
    /// (`atomicAdd` on `float` in storage buffers, GLSL `GL_EXT_shader_atomic_float`).
    pub float32_atomic_add: bool,
}

/// A cloneable handle on the validation messages a [`Context`] collected. It stays valid after
/// the context is dropped, so tests can also see messages emitted while destroying the device
/// and instance (e.g. leaked objects).
#[derive(Clone, Default)]
pub struct ValidationLog(Arc<Mutex<Vec<String>>>);

impl ValidationLog {
    /// Every WARNING or ERROR message seen so far.
    pub fn messages(&self) -> Vec<String> {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

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
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // Never panic here: unwinding across the FFI boundary aborts.
    if data.is_null() || user.is_null() {
        return vk::FALSE;
    }
    let msg = unsafe { (*data).message_as_c_str() }
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    if severity
        .intersects(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
    {
        eprintln!("vulkan validation: {msg}");
        let log = unsafe { &*(user as *const Mutex<Vec<String>>) };
        log.lock().unwrap_or_else(|e| e.into_inner()).push(msg);
    }
    vk::FALSE
}

fn kind_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual",
        vk::PhysicalDeviceType::CPU => "cpu",
        _ => "other",
    }
}

/// One Vulkan device as `list_devices` reports it.
#[derive(Clone, Debug)]
pub struct DeviceSummary {
    /// Index for `--device` / `SCRATCHART_DEVICE`.
    pub index: usize,
    pub name: String,
    pub kind: &'static str,
    pub api_version: String,
    /// Whether the default choice (discrete, integrated, virtual, CPU) picks it.
    pub default: bool,
    /// Usable: a compute queue and Vulkan 1.1.
    pub usable: bool,
}

/// Every Vulkan device, in the order `--device INDEX` counts them, with the default marked.
/// Creates and destroys a bare instance (no validation layer, no surface extensions).
pub fn list_devices() -> Result<Vec<DeviceSummary>, GpuError> {
    let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loading(e.to_string()))?;
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_2);
    let ci = vk::InstanceCreateInfo::default().application_info(&app);
    let instance = unsafe { entry.create_instance(&ci, None) }.map_err(vk_err("vkCreateInstance"))?;
    let pds = unsafe { instance.enumerate_physical_devices() };
    let mut out = Vec::new();
    if let Ok(pds) = &pds {
        for (index, &pd) in pds.iter().enumerate() {
            let props = unsafe { instance.get_physical_device_properties(pd) };
            let name = props
                .device_name_as_c_str()
                .map(|c| c.to_string_lossy().into_owned())
                .unwrap_or_else(|_| "?".into());
            let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
            let compute = families.iter().any(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE));
            let v = props.api_version;
            out.push((
                DeviceSummary {
                    index,
                    name,
                    kind: kind_name(props.device_type),
                    api_version: format!(
                        "{}.{}.{}",
                        vk::api_version_major(v),
                        vk::api_version_minor(v),
                        vk::api_version_patch(v)
                    ),
                    default: false,
                    usable: compute && v >= vk::API_VERSION_1_1,
                },
                kind_rank(props.device_type),
            ));
        }
    }
    unsafe { instance.destroy_instance(None) };
    pds.map_err(vk_err("vkEnumeratePhysicalDevices"))?;
    if let Some(best) = out
        .iter()
        .filter(|(d, _)| d.usable)
        .min_by_key(|(_, r)| *r)
        .map(|(d, _)| d.index)
    {
        out[best].0.default = true;
    }
    Ok(out.into_iter().map(|(d, _)| d).collect())
}

fn kind_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

fn has_ext(list: &[vk::ExtensionProperties], name: &CStr) -> bool {
    list.iter().any(|e| e.extension_name_as_c_str().ok() == Some(name))
}

struct Candidate {
    pd: vk::PhysicalDevice,
    props: vk::PhysicalDeviceProperties,
    name: String,
    /// Queue family with COMPUTE (preferring one that also has GRAPHICS, for the viewer).
    family: Option<(u32, vk::QueueFamilyProperties)>,
}

impl Context {
    pub fn new(desc: ContextDesc) -> Result<Arc<Context>, GpuError> {
        let env_on = |k: &str| std::env::var(k).is_ok_and(|v| !v.is_empty() && v != "0");
        let want_validation = desc.validation || env_on("SCRATCHART_VALIDATION");
        let selector = desc
            .device
            .clone()
            .or_else(|| std::env::var("SCRATCHART_DEVICE").ok().filter(|s| !s.is_empty()));

        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loading(e.to_string()))?;

        // ---- instance ----
        let inst_exts = unsafe { entry.enumerate_instance_extension_properties(None) }
            .map_err(vk_err("vkEnumerateInstanceExtensionProperties"))?;
        let layers = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(vk_err("vkEnumerateInstanceLayerProperties"))?;
        let validation = want_validation
            && layers
                .iter()
                .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
        if want_validation && !validation {
            eprintln!("warning: validation requested but VK_LAYER_KHRONOS_validation is not installed");
        }
        let debug_utils = has_ext(&inst_exts, ash::ext::debug_utils::NAME);
        let mut ext_names: Vec<&CStr> = desc.instance_extensions.clone();
        if debug_utils {
            ext_names.push(ash::ext::debug_utils::NAME);
        }
        let mut flags = vk::InstanceCreateFlags::empty();
        if has_ext(&inst_exts, ash::khr::portability_enumeration::NAME) {
            // Lets MoltenVK-style portability drivers be enumerated.
            ext_names.push(ash::khr::portability_enumeration::NAME);
            flags |= vk::InstanceCreateFlags::ENUMERATE_PORTABILITY_KHR;
        }
        // Synchronization validation catches missing barriers between dispatches; it needs
        // VK_EXT_validation_features, which the validation layer itself provides.
        let layer_exts = if validation {
            unsafe { entry.enumerate_instance_extension_properties(Some(VALIDATION_LAYER)) }.unwrap_or_default()
        } else {
            Vec::new()
        };
        let sync_validation = validation && has_ext(&layer_exts, ash::ext::validation_features::NAME);
        if sync_validation {
            ext_names.push(ash::ext::validation_features::NAME);
        }
        ext_names.sort();
        ext_names.dedup();
        let ext_ptrs: Vec<_> = ext_names.iter().map(|e| e.as_ptr()).collect();
        let layer_ptrs: Vec<_> = if validation {
            vec![VALIDATION_LAYER.as_ptr()]
        } else {
            vec![]
        };

        let log = ValidationLog::default();
        let log_ptr = Arc::as_ptr(&log.0) as *mut c_void;
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(log_ptr);
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);

        let app = vk::ApplicationInfo::default()
            .application_name(c"scratchart")
            .engine_name(c"scratchart")
            .api_version(vk::API_VERSION_1_2);
        let mut ci = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_extension_names(&ext_ptrs)
            .enabled_layer_names(&layer_ptrs)
            .flags(flags);
        if validation && debug_utils {
            // Chained so vkCreateInstance/vkDestroyInstance messages are caught too.
            ci = ci.push_next(&mut messenger_info);
        }
        if sync_validation {
            ci = ci.push_next(&mut validation_features);
        }
        let instance = unsafe { entry.create_instance(&ci, None) }.map_err(vk_err("vkCreateInstance"))?;

        let debug_instance = debug_utils.then(|| ash::ext::debug_utils::Instance::new(&entry, &instance));
        let mut messenger = vk::DebugUtilsMessengerEXT::null();
        if let (true, Some(di)) = (validation, &debug_instance) {
            let info = vk::DebugUtilsMessengerCreateInfoEXT {
                p_next: std::ptr::null(),
                ..messenger_info
            };
            match unsafe { di.create_debug_utils_messenger(&info, None) } {
                Ok(m) => messenger = m,
                Err(e) => {
                    unsafe { instance.destroy_instance(None) };
                    return Err(vk_err("vkCreateDebugUtilsMessengerEXT")(e));
                }
            }
        }
        // From here on, failures must tear down the messenger and instance.
        let cleanup_instance = |instance: &ash::Instance| unsafe {
            if let Some(di) = &debug_instance {
                if messenger != vk::DebugUtilsMessengerEXT::null() {
                    di.destroy_debug_utils_messenger(messenger, None);
                }
            }
            instance.destroy_instance(None);
        };

        let built = Self::create_device(&instance, &desc, selector.as_deref());
        let (physical_device, device, queue_family, info, allocator) = match built {
            Ok(b) => b,
            Err(e) => {
                cleanup_instance(&instance);
                return Err(e);
            }
        };
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let debug_device = debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        if !desc.quiet {
            eprintln!("device: {} ({})", info.name, info.kind);
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
        }))
    }

    /// Picks the physical device, creates the logical device and allocator.
    #[allow(clippy::type_complexity)]
    fn create_device(
        instance: &ash::Instance,
        desc: &ContextDesc,
        selector: Option<&str>,
    ) -> Result<(vk::PhysicalDevice, ash::Device, u32, DeviceInfo, Allocator), GpuError> {
        let pds = unsafe { instance.enumerate_physical_devices() }.map_err(vk_err("vkEnumeratePhysicalDevices"))?;
        let candidates: Vec<Candidate> = pds
            .iter()
            .map(|&pd| {
                let props = unsafe { instance.get_physical_device_properties(pd) };
                let name = props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned());
                let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
                let compute: Vec<_> = families
                    .iter()
                    .enumerate()
                    .filter(|(_, f)| f.queue_flags.contains(vk::QueueFlags::COMPUTE) && f.queue_count > 0)
                    .map(|(i, f)| (i as u32, *f))
                    .collect();
                let family = compute
                    .iter()
                    .find(|(_, f)| f.queue_flags.contains(vk::QueueFlags::GRAPHICS))
                    .or(compute.first())
                    .copied();
                Candidate {
                    pd,
                    props,
                    name: name.unwrap_or_else(|_| "?".into()),
                    family,
                }
            })
            .collect();
        let available: Vec<String> = candidates
            .iter()
            .enumerate()
            .map(|(i, c)| format!("{i}: {} ({})", c.name, kind_name(c.props.device_type)))
            .collect();
        // SPIR-V 1.3 (our shader target) needs Vulkan 1.1.
        let usable = |c: &Candidate| c.family.is_some() && c.props.api_version >= vk::API_VERSION_1_1;
        let chosen = match selector {
            Some(sel) => {
                let found = match sel.trim().parse::<usize>() {
                    Ok(i) => candidates.get(i),
                    Err(_) => {
                        let s = sel.to_lowercase();
                        candidates.iter().find(|c| c.name.to_lowercase().contains(&s))
                    }
                };
                match found {
                    Some(c) if usable(c) => c,
                    Some(c) => {
                        return Err(GpuError::NoDevice {
                            reason: format!("device '{}' has no compute queue or is older than Vulkan 1.1", c.name),
                            available,
                        })
                    }
                    None => {
                        return Err(GpuError::NoDevice {
                            reason: format!("no device matches '{sel}'"),
                            available,
                        })
                    }
                }
            }
            None => candidates
                .iter()
                .filter(|c| usable(c))
                .min_by_key(|c| kind_rank(c.props.device_type))
                .ok_or_else(|| GpuError::NoDevice {
                    reason: "no device with a compute queue and Vulkan 1.1".into(),
                    available: available.clone(),
                })?,
        };
        let pd = chosen.pd;
        let (queue_family, family_props) = chosen.family.unwrap();
        let props = chosen.props;

        let dev_exts = unsafe { instance.enumerate_device_extension_properties(pd) }
            .map_err(vk_err("vkEnumerateDeviceExtensionProperties"))?;
        let mut ext_names: Vec<&CStr> = desc.device_extensions.clone();
        if has_ext(&dev_exts, ash::khr::portability_subset::NAME) {
            // Required by the spec whenever the device exposes it.
            ext_names.push(ash::khr::portability_subset::NAME);
        }
        let has_atomic_float = has_ext(&dev_exts, ash::ext::shader_atomic_float::NAME);
        let api12 = props.api_version >= vk::API_VERSION_1_2;

        // ---- query supported features ----
        let mut sup11 = vk::PhysicalDeviceVulkan11Features::default();
        let mut sup12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut sup_af = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default();
        let mut sup_sub = vk::PhysicalDeviceSubgroupProperties::default();
        let mut f2 = vk::PhysicalDeviceFeatures2::default();
        if api12 {
            f2 = f2.push_next(&mut sup11).push_next(&mut sup12);
        }
        if has_atomic_float {
            f2 = f2.push_next(&mut sup_af);
        }
        unsafe { instance.get_physical_device_features2(pd, &mut f2) };
        let core = f2.features;
        let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut sup_sub);
        unsafe { instance.get_physical_device_properties2(pd, &mut p2) };
        // The queried structs still point into the (dead) query chain; unlink them.
        sup11.p_next = std::ptr::null_mut();
        sup12.p_next = std::ptr::null_mut();
        sup_af.p_next = std::ptr::null_mut();
        let atomic_float = has_atomic_float && sup_af.shader_buffer_float32_atomic_add == vk::TRUE;
        Self::finish_device(
            instance,
            pd,
            props,
            queue_family,
            family_props,
            core,
            api12.then_some((sup11, sup12)),
            atomic_float.then_some(sup_af),
            sup_sub.subgroup_size,
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

        let l = &props.limits;
        let v = props.api_version;
        let info = DeviceInfo {
            name: props
                .device_name_as_c_str()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            kind: kind_name(props.device_type).into(),
            api_version: format!(
                "{}.{}.{}",
                vk::api_version_major(v),
                vk::api_version_minor(v),
                vk::api_version_patch(v)
            ),
            max_storage_buffer_range: l.max_storage_buffer_range as u64,
            max_workgroup_count: l.max_compute_work_group_count,
            max_workgroup_invocations: l.max_compute_work_group_invocations,
            max_shared_memory: l.max_compute_shared_memory_size,
            max_push_constants_size: l.max_push_constants_size,
            timestamp_period_ns: l.timestamp_period as f64,
            timestamps: family_props.timestamp_valid_bits > 0 && l.timestamp_period > 0.0,
            timestamp_valid_bits: family_props.timestamp_valid_bits,
            subgroup_size,
            float64: en_core.shader_float64 == vk::TRUE,
            int64: en_core.shader_int64 == vk::TRUE,
            float32_atomic_add: en_af.shader_buffer_float32_atomic_add == vk::TRUE,
        };
        Ok((pd, device, queue_family, info, allocator))
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

    /// Records `f` into a throwaway command buffer, submits it and waits. Used for the rare
    /// staging transfers; hot paths use a [`super::Recorder`].
    pub(crate) fn one_shot(&self, f: impl FnOnce(vk::CommandBuffer)) -> Result<(), GpuError> {
        let d = &self.device;
        let pool_ci = vk::CommandPoolCreateInfo::default()
            .queue_family_index(self.queue_family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        let pool = unsafe { d.create_command_pool(&pool_ci, None) }.map_err(vk_err("vkCreateCommandPool"))?;
        let result = (|| {
            let ai = vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            let cmd = unsafe { d.allocate_command_buffers(&ai) }.map_err(vk_err("vkAllocateCommandBuffers"))?[0];
            let bi = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            unsafe { d.begin_command_buffer(cmd, &bi) }.map_err(vk_err("vkBeginCommandBuffer"))?;
            f(cmd);
            // Make transfer results visible to host reads after the fence.
            let mb = [vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ)];
            unsafe {
                d.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &mb,
                    &[],
                    &[],
                )
            };
            unsafe { d.end_command_buffer(cmd) }.map_err(vk_err("vkEndCommandBuffer"))?;
            let fence =
                unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.map_err(vk_err("vkCreateFence"))?;
            let r = self.queue_submit(cmd, fence).and_then(|_| self.wait_fence(fence));
            if r.is_ok() {
                unsafe { d.destroy_fence(fence, None) };
            } else {
                // Hazard: after a timeout the work may still be pending; idle the device before
                // destroying what it uses.
                self.wait_idle();
                unsafe { d.destroy_fence(fence, None) };
            }
            r
        })();
        unsafe { d.destroy_command_pool(pool, None) };
        result
    }

    /// Creates a device-local storage buffer holding `data` (via a staging buffer).
    pub fn upload<T: bytemuck::Pod>(self: &Arc<Self>, name: &str, data: &[T]) -> Result<Buffer, GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buf = Buffer::new(self, name, bytes.len() as u64, MemLoc::GpuOnly)?;
        if !bytes.is_empty() {
            let staging = Buffer::new(self, &format!("{name} (staging)"), bytes.len() as u64, MemLoc::CpuToGpu)?;
            staging.write(0, bytes)?;
            let region = [vk::BufferCopy::default().size(bytes.len() as u64)];
            self.one_shot(|cmd| unsafe { self.device.cmd_copy_buffer(cmd, staging.raw(), buf.raw(), &region) })?;
        }
        Ok(buf)
    }

    /// Reads back a whole buffer: device-only buffers through a staging copy, host-visible ones
    /// directly.
    pub fn download<T: bytemuck::Pod>(self: &Arc<Self>, buf: &Buffer) -> Result<Vec<T>, GpuError> {
        // Device-only buffers always go through a staging copy, even where their memory happens
        // to be mappable (lavapipe, resizable BAR): reading device-local memory from the host is
        // slow on real GPUs, and this way every test on lavapipe runs the path a GPU takes.
        if buf.is_host_visible() && !matches!(buf.location(), MemLoc::GpuOnly) {
            return buf.read();
        }
        let staging = Buffer::new(
            self,
            &format!("{} (readback)", buf.name()),
            buf.size(),
            MemLoc::GpuToCpu,
        )?;
        let region = [vk::BufferCopy::default().size(buf.size())];
        self.one_shot(|cmd| unsafe { self.device.cmd_copy_buffer(cmd, buf.raw(), staging.raw(), &region) })?;
        staging.read()
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
