//! The Vulkan instance: the loader, the Khronos validation layer (with synchronization
//! validation where the layer offers it) and the debug messenger, whose WARNING and ERROR
//! messages are printed and collected in a [`ValidationLog`]. The [`super::Context`] owns what is
//! created here and destroys it last, after the device.
use std::{
    ffi::{c_void, CStr},
    sync::{Arc, Mutex},
};

use ash::vk;

use super::error::{vk_err, GpuError};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// A cloneable handle on the validation messages a [`Context`] collected. It stays valid after
/// the context is dropped, so tests can also see messages emitted while destroying the device
/// and instance (e.g. leaked objects).
#[derive(Clone, Default)]
pub struct ValidationLog(pub(super) Arc<LogInner>);

#[derive(Default)]
pub(super) struct LogInner {
    messages: Mutex<Vec<String>>,
    pub(super) notify: Option<Notify>,
}

/// Where the Vulkan layer's notices go (the device chosen, validation messages, a pipeline
/// cache that cannot be saved, dropped timestamps): an observer, as for every library. The
/// binaries pass one that prints (`scratchart::term::stderr_notices`); a library user may log
/// them or leave them out (`None`; validation messages are still kept in the [`ValidationLog`]).
pub type Notify = scratchart_observe::SharedObserver;

impl ValidationLog {
    /// Every WARNING or ERROR message seen so far.
    pub fn messages(&self) -> Vec<String> {
        self.0.messages.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
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
        let log = unsafe { &*(user as *const LogInner) };
        if let Some(n) = &log.notify {
            n.warn(&format!("vulkan validation: {msg}"));
        }
        log.messages.lock().unwrap_or_else(|e| e.into_inner()).push(msg);
    }
    vk::FALSE
}

pub(super) fn has_ext(list: &[vk::ExtensionProperties], name: &CStr) -> bool {
    list.iter().any(|e| e.extension_name_as_c_str().ok() == Some(name))
}

/// A created instance with its messenger, before a device exists. Device creation takes it
/// apart into the [`super::Context`]; when device creation fails, [`Instance::destroy`] undoes it.
pub(super) struct Instance {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    /// `VK_EXT_debug_utils` is enabled (object names, and the messenger when validating).
    pub debug_utils: bool,
    pub debug_instance: Option<ash::ext::debug_utils::Instance>,
    /// Null when validation is off.
    pub messenger: vk::DebugUtilsMessengerEXT,
    /// Its `Arc` payload is the messenger's user data: whoever owns the messenger must keep it
    /// alive until the instance is destroyed.
    pub log: ValidationLog,
    /// The validation layer is on (requested and installed).
    pub validation: bool,
}

impl Instance {
    /// Loads Vulkan and creates the instance, with `extensions`, debug utils when available, and
    /// the validation layer and messenger when `want_validation` and installed (its notices to
    /// `notify`).
    pub(super) fn new(
        extensions: &[&'static CStr],
        notify: Option<&Notify>,
        want_validation: bool,
    ) -> Result<Instance, GpuError> {
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loading(e.to_string()))?;

        let inst_exts = unsafe { entry.enumerate_instance_extension_properties(None) }
            .map_err(vk_err("vkEnumerateInstanceExtensionProperties"))?;
        let layers = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(vk_err("vkEnumerateInstanceLayerProperties"))?;
        let validation = want_validation
            && layers
                .iter()
                .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
        if want_validation && !validation {
            if let Some(n) = notify {
                n.warn("validation requested but VK_LAYER_KHRONOS_validation is not installed");
            }
        }
        let debug_utils = has_ext(&inst_exts, ash::ext::debug_utils::NAME);
        let mut ext_names: Vec<&CStr> = extensions.to_vec();
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

        let log = ValidationLog(Arc::new(LogInner {
            messages: Mutex::default(),
            notify: notify.cloned(),
        }));
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
        Ok(Instance {
            entry,
            instance,
            debug_utils,
            debug_instance,
            messenger,
            log,
            validation,
        })
    }

    /// Destroys the messenger and the instance, for a failure before a [`super::Context`] took
    /// them over (the context's `Drop` does the same, after the device).
    ///
    /// # Safety
    /// No object created from the instance may be alive.
    pub(super) unsafe fn destroy(self) {
        unsafe {
            if let Some(di) = &self.debug_instance {
                if self.messenger != vk::DebugUtilsMessengerEXT::null() {
                    di.destroy_debug_utils_messenger(self.messenger, None);
                }
            }
            self.instance.destroy_instance(None);
        }
    }
}
