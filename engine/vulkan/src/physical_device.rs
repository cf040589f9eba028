//! Physical devices: listing them (`scratchart devices`), choosing one (`--device`, else
//! discrete, integrated, virtual, CPU in that order), querying the optional features the
//! shaders may use, and [`DeviceInfo`], the limits the rest of the engine must respect.
use ash::vk;

use super::error::{vk_err, GpuError};

/// What the chosen device is and the limits the rest of the engine must respect.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub name: String,
    /// "discrete" | "integrated" | "virtual" | "cpu" | "other"
    pub kind: String,
    pub api_version: String,
    pub max_storage_buffer_range: u64,
    /// Texels of one texel-buffer view ([`super::Buffer::new_texel`]).
    pub max_texel_buffer_elements: u64,
    pub max_workgroup_count: [u32; 3],
    pub max_workgroup_invocations: u32,
    pub max_shared_memory: u32,
    pub max_push_constants_size: u32,
    pub timestamp_period_ns: f64,
    /// Whether the compute queue supports timestamps (otherwise [`super::Timings`] is empty).
    pub timestamps: bool,
    pub timestamp_valid_bits: u32,
    pub subgroup_size: u32,
    /// Subgroup arithmetic (`subgroupAdd`, scans) in compute shaders: the shading kernels' queue
    /// scan needs it.
    pub subgroup_arithmetic: bool,
    /// `shaderFloat64` enabled.
    pub float64: bool,
    /// `shaderInt64` enabled.
    pub int64: bool,
    /// `VK_EXT_shader_atomic_float` with `shaderBufferFloat32AtomicAdd` enabled
    /// (`atomicAdd` on `float` in storage buffers, GLSL `GL_EXT_shader_atomic_float`).
    pub float32_atomic_add: bool,
    /// Bytes of the device's largest device-local memory heap: what one job's buffers share
    /// (0 where the device reports none).
    pub device_memory: u64,
}

pub(super) fn kind_name(t: vk::PhysicalDeviceType) -> &'static str {
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

struct Candidate {
    pd: vk::PhysicalDevice,
    props: vk::PhysicalDeviceProperties,
    name: String,
    /// Queue family with COMPUTE (preferring one that also has GRAPHICS, for the viewer).
    family: Option<(u32, vk::QueueFamilyProperties)>,
}

/// The physical device [`choose`] picked, with its compute queue family.
pub(super) struct Chosen {
    pub pd: vk::PhysicalDevice,
    pub props: vk::PhysicalDeviceProperties,
    pub queue_family: u32,
    pub family_props: vk::QueueFamilyProperties,
}

/// Picks the physical device: the one `selector` names (an index or a case-insensitive
/// substring of the name), else the first usable one of the best kind. Usable: a compute queue
/// and Vulkan 1.1. Errors list the devices there are.
pub(super) fn choose(instance: &ash::Instance, selector: Option<&str>) -> Result<Chosen, GpuError> {
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
    let (queue_family, family_props) = chosen.family.unwrap();
    Ok(Chosen {
        pd: chosen.pd,
        props: chosen.props,
        queue_family,
        family_props,
    })
}

/// What a device supports of the features [`super::Context`] may enable.
pub(super) struct Supported {
    pub core: vk::PhysicalDeviceFeatures,
    /// Vulkan 1.1 and 1.2 features, on devices with Vulkan 1.2.
    pub sup1x: Option<(
        vk::PhysicalDeviceVulkan11Features<'static>,
        vk::PhysicalDeviceVulkan12Features<'static>,
    )>,
    /// `VK_EXT_shader_atomic_float`, when it offers `shaderBufferFloat32AtomicAdd`.
    pub atomic_float: Option<vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT<'static>>,
    pub subgroup_size: u32,
    pub subgroup_arithmetic: bool,
}

/// Queries the supported features of `pd`. `has_atomic_float`: the device lists
/// `VK_EXT_shader_atomic_float`.
pub(super) fn query_features(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    props: &vk::PhysicalDeviceProperties,
    has_atomic_float: bool,
) -> Supported {
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
    Supported {
        core,
        sup1x: api12.then_some((sup11, sup12)),
        atomic_float: atomic_float.then_some(sup_af),
        subgroup_size: sup_sub.subgroup_size,
        subgroup_arithmetic: sup_sub.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
            && sup_sub
                .supported_operations
                .contains(vk::SubgroupFeatureFlags::BASIC | vk::SubgroupFeatureFlags::ARITHMETIC),
    }
}

impl DeviceInfo {
    /// The info of a device created with these properties and enabled features.
    pub(super) fn new(
        props: &vk::PhysicalDeviceProperties,
        family_props: &vk::QueueFamilyProperties,
        subgroup_size: u32,
        subgroup_arithmetic: bool,
        en_core: &vk::PhysicalDeviceFeatures,
        en_af: &vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT<'_>,
    ) -> DeviceInfo {
        let l = &props.limits;
        let v = props.api_version;
        DeviceInfo {
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
            max_texel_buffer_elements: l.max_texel_buffer_elements as u64,
            max_workgroup_count: l.max_compute_work_group_count,
            max_workgroup_invocations: l.max_compute_work_group_invocations,
            max_shared_memory: l.max_compute_shared_memory_size,
            max_push_constants_size: l.max_push_constants_size,
            timestamp_period_ns: l.timestamp_period as f64,
            timestamps: family_props.timestamp_valid_bits > 0 && l.timestamp_period > 0.0,
            timestamp_valid_bits: family_props.timestamp_valid_bits,
            subgroup_size,
            subgroup_arithmetic,
            float64: en_core.shader_float64 == vk::TRUE,
            int64: en_core.shader_int64 == vk::TRUE,
            float32_atomic_add: en_af.shader_buffer_float32_atomic_add == vk::TRUE,
            device_memory: 0,
        }
    }
}
