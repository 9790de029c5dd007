//! The Vulkan context: instance (with validation on request), debug messenger, physical device
//! choice, logical device, one graphics queue and a command pool.
//!
//! Teardown order (in `Drop`): wait idle → command pool → device → messenger → instance; the
//! validation log is freed after the messenger that points to it.

use std::ffi::{c_char, CStr, CString};
use std::sync::Arc;

use ash::vk;

use super::validation::{debug_callback, ValidationLog};
use crate::error::{Error, Result, VkContext};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to create a context.
#[derive(Debug, Clone, Default)]
pub struct GpuOptions {
    /// Device override: an index into the enumerated devices, or a case-insensitive part of the
    /// device name. `None` picks a discrete GPU first, then integrated, virtual, CPU (lavapipe).
    pub device: Option<String>,
    /// Enable the Khronos validation layer; creation fails if the layer is missing.
    pub validation: bool,
    /// Extra instance extensions, e.g. the surface extensions a window system needs.
    pub instance_extensions: Vec<CString>,
    /// Enable `VK_KHR_swapchain` (presenting to windows); devices without it are unusable.
    pub swapchain: bool,
}

impl GpuOptions {
    /// Options from the environment: `TILTFIELD_VALIDATION=1` enables validation,
    /// `TILTFIELD_DEVICE` selects a device.
    pub fn from_env() -> Self {
        GpuOptions {
            device: std::env::var("TILTFIELD_DEVICE")
                .ok()
                .filter(|s| !s.is_empty()),
            validation: std::env::var("TILTFIELD_VALIDATION").is_ok_and(|v| v != "0"),
            ..GpuOptions::default()
        }
    }
}

/// A summary of one physical device, for listings and reports.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub kind: String,
    pub api_version: String,
    pub driver: String,
    /// Why the device cannot be used, if it cannot.
    pub unsupported: Option<String>,
}

/// The Vulkan context: a cheap, shared handle to the instance, the device and the queue.
///
/// Cloning shares the same device. Every resource and pass keeps a clone, so the device outlives
/// whatever was made from it and each owner frees itself in `Drop`, in any order and on any
/// failure path; the device is torn down when the last clone goes.
#[derive(Clone)]
pub struct GpuContext(Arc<ContextCore>);

impl std::ops::Deref for GpuContext {
    type Target = ContextCore;
    fn deref(&self) -> &ContextCore {
        &self.0
    }
}

/// What a [`GpuContext`] shares: the handles every Vulkan call needs.
pub struct ContextCore {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    debug_device: Option<ash::ext::debug_utils::Device>,
    log: Arc<ValidationLog>,
    pub physical: vk::PhysicalDevice,
    pub properties: vk::PhysicalDeviceProperties,
    pub memory_properties: vk::PhysicalDeviceMemoryProperties,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    /// Valid bits of timestamps on the queue (0: no timestamps).
    pub timestamp_valid_bits: u32,
    pub command_pool: vk::CommandPool,
    pub info: DeviceInfo,
    /// Whether `largePoints` is enabled: points may be larger than one pixel.
    pub large_points: bool,
}

fn kind_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
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

fn version_string(v: u32) -> String {
    format!(
        "{}.{}.{}",
        vk::api_version_major(v),
        vk::api_version_minor(v),
        vk::api_version_patch(v)
    )
}

fn load_entry() -> Result<ash::Entry> {
    // SAFETY: loading the system Vulkan loader library; no other invariants.
    unsafe { ash::Entry::load() }.map_err(|e| {
        Error::Vulkan(format!(
            "cannot load the Vulkan loader ({e}); install libvulkan1 and a driver such as \
             mesa-vulkan-drivers (tools/setup.sh does both)"
        ))
    })
}

/// Queue family with graphics support, the features tiltfield needs, or why not.
fn check_device(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    swapchain: bool,
) -> Result<(u32, u32), String> {
    // SAFETY: pd comes from this instance.
    let props = unsafe { instance.get_physical_device_properties(pd) };
    if props.api_version < vk::API_VERSION_1_3 {
        return Err(format!(
            "supports Vulkan {} only; tiltfield needs 1.3",
            version_string(props.api_version)
        ));
    }
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f13);
    // SAFETY: valid structures chained as the spec requires.
    unsafe { instance.get_physical_device_features2(pd, &mut f2) };
    if f13.dynamic_rendering == vk::FALSE
        || f13.synchronization2 == vk::FALSE
        || f13.maintenance4 == vk::FALSE
    {
        return Err("lacks dynamicRendering, synchronization2 or maintenance4".into());
    }
    if swapchain {
        // SAFETY: pd comes from this instance.
        let exts = unsafe { instance.enumerate_device_extension_properties(pd) }
            .map_err(|e| format!("cannot list its extensions ({e})"))?;
        let has = exts.iter().any(|e| {
            e.extension_name_as_c_str()
                .is_ok_and(|n| n == ash::khr::swapchain::NAME)
        });
        if !has {
            return Err("cannot present to windows (no VK_KHR_swapchain)".into());
        }
    }
    // SAFETY: pd comes from this instance.
    let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    families
        .iter()
        .enumerate()
        .find(|(_, f)| f.queue_flags.contains(vk::QueueFlags::GRAPHICS))
        .map(|(i, f)| (i as u32, f.timestamp_valid_bits))
        .ok_or_else(|| "has no graphics queue".to_string())
}

fn describe(instance: &ash::Instance, index: usize, pd: vk::PhysicalDevice) -> DeviceInfo {
    // SAFETY: pd comes from this instance.
    let props = unsafe { instance.get_physical_device_properties(pd) };
    let name = props
        .device_name_as_c_str()
        .map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_else(|_| "(unnamed)".into());
    let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
    let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver_props);
    // SAFETY: valid structures chained as the spec requires (Vulkan 1.2+ instance).
    unsafe { instance.get_physical_device_properties2(pd, &mut p2) };
    let driver = driver_props
        .driver_info_as_c_str()
        .map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_default();
    DeviceInfo {
        index,
        name,
        kind: kind_name(props.device_type).into(),
        api_version: version_string(props.api_version),
        driver,
        unsupported: check_device(instance, pd, false).err(),
    }
}

fn create_instance(
    entry: &ash::Entry,
    validation: bool,
    requested: &[CString],
    log: &Arc<ValidationLog>,
) -> Result<(ash::Instance, bool)> {
    // SAFETY: plain enumeration calls.
    let layers = unsafe { entry.enumerate_instance_layer_properties() }
        .vk("vkEnumerateInstanceLayerProperties")?;
    let has_layer = |name: &CStr| {
        layers
            .iter()
            .any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == name))
    };
    if validation && !has_layer(VALIDATION_LAYER) {
        return Err(Error::Vulkan(
            "the Khronos validation layer (VK_LAYER_KHRONOS_validation) is not installed; \
             install vulkan-validationlayers or run without validation"
                .into(),
        ));
    }
    // SAFETY: plain enumeration call.
    let extensions = unsafe { entry.enumerate_instance_extension_properties(None) }
        .vk("vkEnumerateInstanceExtensionProperties")?;
    let has_debug_utils = extensions.iter().any(|e| {
        e.extension_name_as_c_str()
            .is_ok_and(|n| n == ash::ext::debug_utils::NAME)
    });
    if validation && !has_debug_utils {
        return Err(Error::Vulkan(
            "validation needs VK_EXT_debug_utils, which the loader does not offer".into(),
        ));
    }
    let app_name = c"tiltfield";
    let app = vk::ApplicationInfo::default()
        .application_name(app_name)
        .engine_name(app_name)
        .api_version(vk::API_VERSION_1_3);
    let layer_ptrs: Vec<*const c_char> = if validation {
        vec![VALIDATION_LAYER.as_ptr()]
    } else {
        Vec::new()
    };
    for name in requested {
        let offered = extensions.iter().any(|e| {
            e.extension_name_as_c_str()
                .is_ok_and(|n| n == name.as_c_str())
        });
        if !offered {
            return Err(Error::Vulkan(format!(
                "the Vulkan loader does not offer the instance extension {}, which the window \
                 system needs",
                name.to_string_lossy()
            )));
        }
    }
    let mut ext_ptrs: Vec<*const c_char> = requested.iter().map(|n| n.as_ptr()).collect();
    if has_debug_utils {
        ext_ptrs.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    // Chained into instance creation so that messages about creating and destroying the
    // instance itself are counted too.
    let mut messenger_info = messenger_create_info(log);
    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layer_ptrs)
        .enabled_extension_names(&ext_ptrs);
    if has_debug_utils {
        info = info.push_next(&mut messenger_info);
    }
    // SAFETY: all pointers in `info` live until the call returns.
    let instance = unsafe { entry.create_instance(&info, None) }.map_err(|e| {
        Error::Vulkan(format!(
            "cannot create a Vulkan 1.3 instance ({e}); is a Vulkan driver installed \
             (mesa-vulkan-drivers for software rendering)?"
        ))
    })?;
    Ok((instance, has_debug_utils))
}

fn messenger_create_info(
    log: &Arc<ValidationLog>,
) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug_callback))
        .user_data(Arc::as_ptr(log) as *mut _)
}

/// Held while an instance and its device are made or destroyed. The validation layer keeps
/// every instance's and device's state in process-wide tables; with instances made and
/// destroyed on two threads at once (the test harness runs GPU tests side by side, each with
/// its own context) it once crashed inside the layer (a SIGSEGV in
/// libVkLayer_khronos_validation.so, one run of the suite in about a hundred). Contexts are
/// made a few times a process, so serialising their lifecycle costs nothing.
static LIFECYCLE: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn lifecycle() -> std::sync::MutexGuard<'static, ()> {
    // A panic while holding it leaves nothing half-made that a later context would see.
    LIFECYCLE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Lists the physical devices (for `tiltfield devices`).
pub fn list_devices() -> Result<Vec<DeviceInfo>> {
    let _lifecycle = lifecycle();
    let entry = load_entry()?;
    let log = Arc::new(ValidationLog::default());
    let (instance, _) = create_instance(&entry, false, &[], &log)?;
    // SAFETY: instance is valid; destroyed below after use.
    let result = unsafe { instance.enumerate_physical_devices() }
        .map(|pds| {
            pds.iter()
                .enumerate()
                .map(|(i, &pd)| describe(&instance, i, pd))
                .collect()
        })
        .vk("vkEnumeratePhysicalDevices");
    // SAFETY: no child objects exist.
    unsafe { instance.destroy_instance(None) };
    result
}

impl GpuContext {
    /// Creates the context.
    pub fn new(options: &GpuOptions) -> Result<Self> {
        let made = lifecycle();
        let entry = load_entry()?;
        let log = Arc::new(ValidationLog::default());
        let (instance, has_debug_utils) = create_instance(
            &entry,
            options.validation,
            &options.instance_extensions,
            &log,
        )?;
        // From here on, `partial` tears down what exists if a later step fails.
        let debug = if has_debug_utils {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = messenger_create_info(&log);
            // SAFETY: info's user data outlives the messenger (both owned by the context).
            match unsafe { loader.create_debug_utils_messenger(&info, None) }
                .vk("vkCreateDebugUtilsMessengerEXT")
            {
                Ok(m) => Some((loader, m)),
                Err(e) => {
                    // SAFETY: no child objects exist.
                    unsafe { instance.destroy_instance(None) };
                    return Err(e);
                }
            }
        } else {
            None
        };
        let destroy_instance =
            |debug: &Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>| {
                // SAFETY: the instance's only children at this point are the messenger.
                unsafe {
                    if let Some((l, m)) = debug {
                        l.destroy_debug_utils_messenger(*m, None);
                    }
                    instance.destroy_instance(None);
                }
            };
        let chosen = match choose_device(&instance, options.device.as_deref(), options.swapchain) {
            Ok(c) => c,
            Err(e) => {
                destroy_instance(&debug);
                return Err(e);
            }
        };
        let (physical, info, queue_family, timestamp_valid_bits) = chosen;
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        // maintenance4 (required of every Vulkan 1.3 device): compute shaders whose workgroup
        // size is a specialisation constant compile to the LocalSizeId execution mode with
        // some shaderc versions (Debian 12's), which needs it.
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .synchronization2(true)
            .maintenance4(true);
        let device_extensions = if options.swapchain {
            vec![ash::khr::swapchain::NAME.as_ptr()]
        } else {
            Vec::new()
        };
        // Points wider than one pixel (the viewer's point cloud and pick markers) where the
        // device has them; shaders clamp their point size to 1 otherwise.
        // SAFETY: physical comes from this instance.
        let large_points =
            unsafe { instance.get_physical_device_features(physical) }.large_points == vk::TRUE;
        let core = vk::PhysicalDeviceFeatures::default().large_points(large_points);
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&device_extensions)
            .enabled_features(&core)
            .push_next(&mut f13);
        // SAFETY: physical comes from this instance; the features were checked.
        let device = match unsafe { instance.create_device(physical, &device_info, None) }
            .vk("vkCreateDevice")
        {
            Ok(d) => d,
            Err(e) => {
                destroy_instance(&debug);
                return Err(e);
            }
        };
        // SAFETY: queue family and index 0 were requested at device creation.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device.
        let command_pool = match unsafe { device.create_command_pool(&pool_info, None) }
            .vk("vkCreateCommandPool")
        {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: no children of the device exist yet.
                unsafe { device.destroy_device(None) };
                destroy_instance(&debug);
                return Err(e);
            }
        };
        // SAFETY: physical comes from this instance.
        let (properties, memory_properties) = unsafe {
            (
                instance.get_physical_device_properties(physical),
                instance.get_physical_device_memory_properties(physical),
            )
        };
        let debug_device = debug
            .as_ref()
            .map(|_| ash::ext::debug_utils::Device::new(&instance, &device));
        // Released before the context exists: its drop takes the lock again.
        drop(made);
        let ctx = GpuContext(Arc::new(ContextCore {
            entry,
            instance,
            debug,
            debug_device,
            log,
            physical,
            properties,
            memory_properties,
            device,
            queue,
            queue_family,
            timestamp_valid_bits,
            command_pool,
            info,
            large_points,
        }));
        ctx.name(ctx.queue, "graphics queue");
        ctx.name(ctx.command_pool, "command pool");
        log::info!(
            "using {} ({}, Vulkan {}, {})",
            ctx.info.name,
            ctx.info.kind,
            ctx.info.api_version,
            ctx.info.driver
        );
        Ok(ctx)
    }

    /// The validation message log of this context.
    pub fn validation(&self) -> &ValidationLog {
        &self.log
    }

    /// Fails when the validation layer reported errors on this context so far, naming `what`
    /// was being done ("while rendering"); see [`super::validation::check_errors`].
    pub fn check_validation(&self, what: &str) -> Result<()> {
        super::validation::check_errors(self.log.errors(), what)
    }

    /// Names a Vulkan object for validation messages and debuggers (no-op without debug utils).
    pub fn name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(d) = &self.debug_device {
            let Ok(cname) = CString::new(name) else {
                return;
            };
            let info = vk::DebugUtilsObjectNameInfoEXT::default()
                .object_handle(handle)
                .object_name(&cname);
            // SAFETY: handle belongs to this device; naming is purely informational.
            let _ = unsafe { d.set_debug_utils_object_name(&info) };
        }
    }

    /// Index of a memory type allowed by `type_bits` with `flags`.
    pub fn memory_type(&self, type_bits: u32, flags: vk::MemoryPropertyFlags) -> Result<u32> {
        let mp = &self.memory_properties;
        (0..mp.memory_type_count)
            .find(|&i| {
                type_bits & (1 << i) != 0
                    && mp.memory_types[i as usize].property_flags.contains(flags)
            })
            .ok_or_else(|| {
                Error::DeviceLimit(format!(
                    "{} has no memory type with {flags:?} for this resource",
                    self.info.name
                ))
            })
    }

    /// Size of the largest device-local memory heap in bytes.
    pub fn device_local_heap(&self) -> u64 {
        let mp = &self.memory_properties;
        mp.memory_heaps[..mp.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0)
    }
}

fn choose_device(
    instance: &ash::Instance,
    selector: Option<&str>,
    swapchain: bool,
) -> Result<(vk::PhysicalDevice, DeviceInfo, u32, u32)> {
    // SAFETY: valid instance.
    let pds = unsafe { instance.enumerate_physical_devices() }.unwrap_or_default();
    if pds.is_empty() {
        return Err(Error::Vulkan(
            "no Vulkan device found; install a driver (mesa-vulkan-drivers provides the \
             lavapipe software renderer)"
                .into(),
        ));
    }
    let infos: Vec<DeviceInfo> = pds
        .iter()
        .enumerate()
        .map(|(i, &pd)| {
            let mut info = describe(instance, i, pd);
            if info.unsupported.is_none() {
                info.unsupported = check_device(instance, pd, swapchain).err();
            }
            info
        })
        .collect();
    let list = || {
        infos
            .iter()
            .map(|d| format!("{}: {} ({})", d.index, d.name, d.kind))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let index = match selector {
        Some(sel) => {
            let by_index = sel.parse::<usize>().ok().filter(|&i| i < infos.len());
            let lower = sel.to_lowercase();
            by_index
                .or_else(|| {
                    infos
                        .iter()
                        .position(|d| d.name.to_lowercase().contains(&lower))
                })
                .ok_or_else(|| {
                    Error::Vulkan(format!(
                        "no Vulkan device matches '{sel}'; devices: {}",
                        list()
                    ))
                })?
        }
        None => {
            let mut usable: Vec<&DeviceInfo> =
                infos.iter().filter(|d| d.unsupported.is_none()).collect();
            // SAFETY: valid physical devices of this instance.
            usable.sort_by_key(|d| {
                kind_rank(
                    unsafe { instance.get_physical_device_properties(pds[d.index]) }.device_type,
                )
            });
            usable.first().map(|d| d.index).ok_or_else(|| {
                Error::Vulkan(format!(
                    "no usable Vulkan device: {}",
                    infos
                        .iter()
                        .map(|d| format!("{} {}", d.name, d.unsupported.as_deref().unwrap_or("")))
                        .collect::<Vec<_>>()
                        .join("; ")
                ))
            })?
        }
    };
    let info = infos[index].clone();
    let (family, bits) = check_device(instance, pds[index], swapchain)
        .map_err(|why| Error::Vulkan(format!("{} cannot be used: it {why}", info.name)))?;
    Ok((pds[index], info, family, bits))
}

impl Drop for ContextCore {
    fn drop(&mut self) {
        let _lifecycle = lifecycle();
        // SAFETY: reverse creation order after the device is idle; every resource created from
        // this context holds a clone of it, so they were all freed before the last clone went.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_command_pool(self.command_pool, None);
            self.device.destroy_device(None);
            if let Some((loader, messenger)) = self.debug.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}
