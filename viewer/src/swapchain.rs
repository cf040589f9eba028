//! [`Presenter`]: the window surface and its swapchain. Created when the window exists (winit's
//! `resumed`), dropped on `suspended`; the swapchain is rebuilt on resize, OUT_OF_DATE and
//! SUBOPTIMAL, the surface on SURFACE_LOST.
//!
//! Synchronisation: images are acquired with a fence that the host waits on (with a timeout),
//! frames are rendered with a host wait too, and presentation then needs no semaphore. On a CPU
//! device this costs nothing; on a GPU it gives up CPU/GPU overlap, which the viewer (one
//! synchronous engine render per frame) does not have anyway.
use std::sync::Arc;

use anyhow::{bail, Context as _, Result};
use ash::vk;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use scratchart_vulkan::{Context, GpuError};
use winit::window::Window;

/// How long an acquire may block before the frame is skipped.
const ACQUIRE_TIMEOUT_NS: u64 = 2_000_000_000;

/// Maps a failed swapchain call; device loss becomes [`GpuError::DeviceLost`] (exit code 4).
fn vk_fail(call: &'static str) -> impl Fn(vk::Result) -> anyhow::Error {
    move |result| match result {
        vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost.into(),
        result => GpuError::Vk { call, result }.into(),
    }
}

pub enum Acquired {
    /// Image index; `true` when the swapchain is suboptimal (present it, then rebuild).
    Image(u32, bool),
    OutOfDate,
    SurfaceLost,
    Timeout,
}

pub enum Presented {
    Ok,
    /// Suboptimal or out of date: rebuild the swapchain before the next frame.
    Rebuild,
    SurfaceLost,
}

pub struct Presenter {
    ctx: Arc<Context>,
    surface_fn: ash::khr::surface::Instance,
    swap_fn: ash::khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    pub extent: vk::Extent2D,
    pub format: vk::Format,
    fence: vk::Fence,
    vsync: bool,
}

/// The Vulkan instance extensions a surface on this display needs.
pub fn required_instance_extensions(display: &impl HasDisplayHandle) -> Result<Vec<&'static std::ffi::CStr>> {
    let raw = display.display_handle().context("no display handle")?.as_raw();
    let names = ash_window::enumerate_required_extensions(raw)
        .context("this windowing system has no Vulkan surface support")?;
    // SAFETY: ash-window returns pointers to 'static, NUL-terminated extension names.
    Ok(names.iter().map(|&p| unsafe { std::ffi::CStr::from_ptr(p) }).collect())
}

impl Presenter {
    pub fn new(ctx: &Arc<Context>, window: &Window, vsync: bool) -> Result<Presenter> {
        let surface_fn = ash::khr::surface::Instance::new(&ctx.entry, &ctx.instance);
        let swap_fn = ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device);
        let fence = unsafe { ctx.device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .map_err(vk_fail("vkCreateFence"))?;
        ctx.set_object_name(fence, "acquire fence");
        let mut p = Presenter {
            ctx: ctx.clone(),
            surface_fn,
            swap_fn,
            surface: vk::SurfaceKHR::null(),
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            extent: vk::Extent2D::default(),
            format: vk::Format::UNDEFINED,
            fence,
            vsync,
        };
        p.create_surface(window)?;
        Ok(p)
    }

    fn create_surface(&mut self, window: &Window) -> Result<()> {
        let ctx = &self.ctx;
        let surface = unsafe {
            ash_window::create_surface(
                &ctx.entry,
                &ctx.instance,
                window.display_handle()?.as_raw(),
                window.window_handle()?.as_raw(),
                None,
            )
        }
        .map_err(vk_fail("vkCreate*SurfaceKHR"))?;
        self.surface = surface;
        let ok = unsafe {
            self.surface_fn
                .get_physical_device_surface_support(ctx.physical_device, ctx.queue_family, surface)
        }
        .map_err(vk_fail("vkGetPhysicalDeviceSurfaceSupportKHR"))?;
        if !ok {
            bail!(
                "device '{}' cannot present to this window from its compute queue; pick another \
                 device with --device, or use --screenshot",
                ctx.info().name
            );
        }
        Ok(())
    }

    /// Destroys the swapchain and surface and makes a new surface (after SURFACE_LOST).
    pub fn recreate_surface(&mut self, window: &Window) -> Result<()> {
        self.destroy_swapchain();
        unsafe { self.surface_fn.destroy_surface(self.surface, None) };
        self.surface = vk::SurfaceKHR::null();
        self.create_surface(window)
    }

    pub fn has_swapchain(&self) -> bool {
        self.swapchain != vk::SwapchainKHR::null()
    }

    fn destroy_swapchain(&mut self) {
        if self.swapchain != vk::SwapchainKHR::null() {
            // Hazard: presentation may still read the images; frames are host-waited, and an
            // idle device also covers a pending present.
            self.ctx.wait_idle();
            unsafe { self.swap_fn.destroy_swapchain(self.swapchain, None) };
            self.swapchain = vk::SwapchainKHR::null();
            self.images.clear();
        }
    }

    /// (Re)builds the swapchain for a window of `size` pixels. Returns Ok(false) and keeps no
    /// swapchain when the surface has zero area (minimized): the caller skips rendering.
    pub fn rebuild(&mut self, size: (u32, u32)) -> Result<bool> {
        let caps = unsafe {
            self.surface_fn
                .get_physical_device_surface_capabilities(self.ctx.physical_device, self.surface)
        }
        .map_err(vk_fail("vkGetPhysicalDeviceSurfaceCapabilitiesKHR"))?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: size.0.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: size.1.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        if extent.width == 0 || extent.height == 0 || size.0 == 0 || size.1 == 0 {
            self.destroy_swapchain();
            return Ok(false);
        }
        if !caps.supported_usage_flags.contains(vk::ImageUsageFlags::TRANSFER_DST) {
            bail!("the surface's images cannot be copied to (no TRANSFER_DST usage)");
        }
        let formats = unsafe {
            self.surface_fn
                .get_physical_device_surface_formats(self.ctx.physical_device, self.surface)
        }
        .map_err(vk_fail("vkGetPhysicalDeviceSurfaceFormatsKHR"))?;
        // UNORM first: the present pass already writes display-encoded values. An sRGB format
        // would also do (a copy does not convert), it only labels them differently.
        let pref = [
            vk::Format::B8G8R8A8_UNORM,
            vk::Format::R8G8B8A8_UNORM,
            vk::Format::B8G8R8A8_SRGB,
            vk::Format::R8G8B8A8_SRGB,
        ];
        let Some(format) = pref
            .iter()
            .find_map(|f| formats.iter().find(|sf| sf.format == *f))
            .copied()
        else {
            bail!("the surface offers no 8-bit RGBA/BGRA format: {formats:?}");
        };
        let modes = unsafe {
            self.surface_fn
                .get_physical_device_surface_present_modes(self.ctx.physical_device, self.surface)
        }
        .map_err(vk_fail("vkGetPhysicalDeviceSurfacePresentModesKHR"))?;
        let mode = if self.vsync {
            vk::PresentModeKHR::FIFO
        } else {
            [vk::PresentModeKHR::MAILBOX, vk::PresentModeKHR::IMMEDIATE]
                .into_iter()
                .find(|m| modes.contains(m))
                .unwrap_or(vk::PresentModeKHR::FIFO)
        };
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let alpha = [
            vk::CompositeAlphaFlagsKHR::OPAQUE,
            vk::CompositeAlphaFlagsKHR::INHERIT,
            vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
            vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
        ]
        .into_iter()
        .find(|a| caps.supported_composite_alpha.contains(*a))
        .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE);
        let old = self.swapchain;
        let ci = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            .present_mode(mode)
            .clipped(true)
            .old_swapchain(old);
        // The old swapchain is retired by the create call; destroy it once the device is idle.
        self.ctx.wait_idle();
        let created = unsafe { self.swap_fn.create_swapchain(&ci, None) };
        if old != vk::SwapchainKHR::null() {
            unsafe { self.swap_fn.destroy_swapchain(old, None) };
            self.swapchain = vk::SwapchainKHR::null();
            self.images.clear();
        }
        let swapchain = match created {
            Ok(s) => s,
            Err(vk::Result::ERROR_SURFACE_LOST_KHR) => {
                bail!(GpuError::Vk {
                    call: "vkCreateSwapchainKHR",
                    result: vk::Result::ERROR_SURFACE_LOST_KHR
                })
            }
            Err(e) => return Err(vk_fail("vkCreateSwapchainKHR")(e)),
        };
        self.ctx.set_object_name(swapchain, "swapchain");
        self.swapchain = swapchain;
        self.images =
            unsafe { self.swap_fn.get_swapchain_images(swapchain) }.map_err(vk_fail("vkGetSwapchainImagesKHR"))?;
        self.extent = extent;
        self.format = format.format;
        Ok(true)
    }

    /// Acquires the next image and waits until the presentation engine has released it.
    pub fn acquire(&mut self) -> Result<Acquired> {
        let d = &self.ctx.device;
        unsafe { d.reset_fences(&[self.fence]) }.map_err(vk_fail("vkResetFences"))?;
        let r = unsafe {
            self.swap_fn
                .acquire_next_image(self.swapchain, ACQUIRE_TIMEOUT_NS, vk::Semaphore::null(), self.fence)
        };
        let (index, suboptimal) = match r {
            Ok(x) => x,
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => return Ok(Acquired::OutOfDate),
            Err(vk::Result::ERROR_SURFACE_LOST_KHR) => return Ok(Acquired::SurfaceLost),
            Err(vk::Result::TIMEOUT | vk::Result::NOT_READY) => return Ok(Acquired::Timeout),
            Err(e) => return Err(vk_fail("vkAcquireNextImageKHR")(e)),
        };
        match unsafe { d.wait_for_fences(&[self.fence], true, ACQUIRE_TIMEOUT_NS) } {
            Ok(()) => Ok(Acquired::Image(index, suboptimal)),
            Err(vk::Result::TIMEOUT) => {
                // The fence is still pending: it must signal before it can be reset and reused.
                self.ctx.wait_idle();
                let _ = unsafe { d.wait_for_fences(&[self.fence], true, ACQUIRE_TIMEOUT_NS) };
                Ok(Acquired::Timeout)
            }
            Err(e) => Err(vk_fail("vkWaitForFences")(e)),
        }
    }

    pub fn image(&self, index: u32) -> vk::Image {
        self.images[index as usize]
    }

    pub fn present(&self, index: u32) -> Result<Presented> {
        let swapchains = [self.swapchain];
        let indices = [index];
        let info = vk::PresentInfoKHR::default()
            .swapchains(&swapchains)
            .image_indices(&indices);
        let r = self.ctx.with_queue(|q| unsafe { self.swap_fn.queue_present(q, &info) });
        match r {
            Ok(false) => Ok(Presented::Ok),
            Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(Presented::Rebuild),
            Err(vk::Result::ERROR_SURFACE_LOST_KHR) => Ok(Presented::SurfaceLost),
            Err(e) => Err(vk_fail("vkQueuePresentKHR")(e)),
        }
    }
}

impl Drop for Presenter {
    fn drop(&mut self) {
        self.destroy_swapchain();
        self.ctx.wait_idle();
        unsafe {
            if self.surface != vk::SurfaceKHR::null() {
                self.surface_fn.destroy_surface(self.surface, None);
            }
            self.ctx.device.destroy_fence(self.fence, None);
        }
    }
}
