//! Presentation to a window: the surface's swapchain, its image views, and one
//! "render finished" semaphore per image (present waits on it).
//!
//! `SUBOPTIMAL` and `OUT_OF_DATE` are legal answers of acquire and present, not errors: they
//! come back as [`Acquire::OutOfDate`] / `Ok(true)` ("recreate before the next frame"), and
//! [`Swapchain::recreate`] rebuilds for the window's new size. A zero-sized (minimised) window
//! has no swapchain; callers do not render until it has a size again.
//!
//! The surface is created by the window system (it needs the window) and handed over: the
//! swapchain owns it from then on. Teardown: views → semaphores → swapchain → surface.

use ash::vk;

use super::context::GpuContext;
use crate::error::{Error, Result, VkContext};

/// How frames are paced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PresentMode {
    /// Vertical sync; always available.
    #[default]
    Fifo,
    /// Newest frame wins without tearing (falls back to FIFO where unsupported).
    Mailbox,
    /// No waiting, may tear: for profiling (falls back to FIFO where unsupported).
    Immediate,
}

impl PresentMode {
    fn vk(self) -> vk::PresentModeKHR {
        match self {
            PresentMode::Fifo => vk::PresentModeKHR::FIFO,
            PresentMode::Mailbox => vk::PresentModeKHR::MAILBOX,
            PresentMode::Immediate => vk::PresentModeKHR::IMMEDIATE,
        }
    }
}

impl std::str::FromStr for PresentMode {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "fifo" => Ok(Self::Fifo),
            "mailbox" => Ok(Self::Mailbox),
            "immediate" => Ok(Self::Immediate),
            _ => Err(Error::Invalid(format!(
                "unknown present mode '{s}': expected fifo, mailbox or immediate"
            ))),
        }
    }
}

/// The result of acquiring an image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Acquire {
    /// Render into image `index`; `suboptimal` asks for a recreate after presenting it.
    Image { index: u32, suboptimal: bool },
    /// The swapchain no longer matches the surface: recreate, then acquire again.
    OutOfDate,
}

/// A surface's swapchain.
pub struct Swapchain {
    surface_loader: ash::khr::surface::Instance,
    loader: ash::khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    handle: vk::SwapchainKHR,
    pub images: Vec<vk::Image>,
    pub views: Vec<vk::ImageView>,
    /// One per image, signalled by the frame that rendered into it.
    pub render_finished: Vec<vk::Semaphore>,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    pub present_mode: vk::PresentModeKHR,
    wanted: PresentMode,
    ctx: GpuContext,
}

impl Swapchain {
    /// Takes ownership of `surface` and creates a swapchain of about `extent` (the surface's
    /// own extent wins where it dictates one). The context must have been created with the
    /// window system's instance extensions and `swapchain: true`.
    pub fn new(
        ctx: &GpuContext,
        surface: vk::SurfaceKHR,
        extent: vk::Extent2D,
        mode: PresentMode,
    ) -> Result<Self> {
        let surface_loader = ash::khr::surface::Instance::new(&ctx.entry, &ctx.instance);
        // SAFETY: valid physical device, queue family and surface of this instance.
        let supported = unsafe {
            surface_loader.get_physical_device_surface_support(
                ctx.physical,
                ctx.queue_family,
                surface,
            )
        };
        if !supported.unwrap_or(false) {
            // SAFETY: the surface is ours and unused.
            unsafe { surface_loader.destroy_surface(surface, None) };
            return Err(Error::Vulkan(format!(
                "{}'s graphics queue cannot present to this window",
                ctx.info.name
            )));
        }
        let mut sc = Swapchain {
            loader: ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device),
            surface_loader,
            surface,
            handle: vk::SwapchainKHR::null(),
            images: Vec::new(),
            views: Vec::new(),
            render_finished: Vec::new(),
            format: vk::Format::UNDEFINED,
            extent,
            present_mode: vk::PresentModeKHR::FIFO,
            wanted: mode,
            ctx: ctx.clone(),
        };
        sc.recreate(ctx, extent)?;
        Ok(sc)
    }

    /// Rebuilds the swapchain for a window of `extent` (after a resize, OUT_OF_DATE or
    /// SUBOPTIMAL). Waits for the device to be idle first: a resize is rare, and the old
    /// images may still be in flight.
    pub fn recreate(&mut self, ctx: &GpuContext, extent: vk::Extent2D) -> Result<()> {
        let d = &ctx.device;
        // SAFETY: waiting has no preconditions.
        unsafe { d.device_wait_idle() }.vk("vkDeviceWaitIdle")?;
        // SAFETY: valid physical device and surface.
        let (caps, formats, modes) = unsafe {
            (
                self.surface_loader
                    .get_physical_device_surface_capabilities(ctx.physical, self.surface)
                    .vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR")?,
                self.surface_loader
                    .get_physical_device_surface_formats(ctx.physical, self.surface)
                    .vk("vkGetPhysicalDeviceSurfaceFormatsKHR")?,
                self.surface_loader
                    .get_physical_device_surface_present_modes(ctx.physical, self.surface)
                    .vk("vkGetPhysicalDeviceSurfacePresentModesKHR")?,
            )
        };
        // UNORM formats: tiltfield's shaders write exactly rounded sRGB-encoded values
        // themselves, so the attachment must not encode again.
        let format = formats
            .iter()
            .find(|f| {
                matches!(
                    f.format,
                    vk::Format::B8G8R8A8_UNORM | vk::Format::R8G8B8A8_UNORM
                ) && f.color_space == vk::ColorSpaceKHR::SRGB_NONLINEAR
            })
            .or(formats.first())
            .copied()
            .ok_or_else(|| Error::Vulkan("the surface offers no formats".into()))?;
        let wanted = self.wanted.vk();
        self.present_mode = if modes.contains(&wanted) {
            wanted
        } else {
            vk::PresentModeKHR::FIFO
        };
        self.extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: extent
                    .width
                    .clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: extent
                    .height
                    .clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let old = self.handle;
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(self.extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(self.present_mode)
            .clipped(true)
            .old_swapchain(old);
        self.release_images(ctx);
        // SAFETY: valid surface; the old swapchain is retired by this call and idle.
        self.handle =
            unsafe { self.loader.create_swapchain(&info, None) }.vk("vkCreateSwapchainKHR")?;
        // SAFETY: the old swapchain is retired and no longer used (device idle).
        unsafe { self.loader.destroy_swapchain(old, None) };
        self.format = format.format;
        // SAFETY: valid swapchain.
        self.images = unsafe { self.loader.get_swapchain_images(self.handle) }
            .vk("vkGetSwapchainImagesKHR")?;
        for (i, &image) in self.images.iter().enumerate() {
            let view_info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(self.format)
                .subresource_range(super::resources::color_range(1));
            // SAFETY: the image belongs to the swapchain; each object is pushed (and so freed
            // by `release_images`) as soon as it exists.
            unsafe {
                self.views.push(
                    d.create_image_view(&view_info, None)
                        .vk("vkCreateImageView")?,
                );
                self.render_finished.push(
                    d.create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
                        .vk("vkCreateSemaphore")?,
                );
            }
            ctx.name(self.views[i], &format!("swapchain image {i}"));
            ctx.name(
                self.render_finished[i],
                &format!("swapchain image {i} rendered"),
            );
        }
        log::debug!(
            "swapchain {}×{} {:?} {:?}, {} images",
            self.extent.width,
            self.extent.height,
            self.format,
            self.present_mode,
            self.images.len()
        );
        Ok(())
    }

    /// Acquires the next image; `signal` is signalled when it may be rendered into.
    pub fn acquire(&self, signal: vk::Semaphore) -> Result<Acquire> {
        // SAFETY: valid swapchain and unsignalled semaphore (its last wait completed).
        match unsafe {
            self.loader
                .acquire_next_image(self.handle, u64::MAX, signal, vk::Fence::null())
        } {
            Ok((index, suboptimal)) => Ok(Acquire::Image { index, suboptimal }),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(Acquire::OutOfDate),
            Err(result) => Err(Error::VkCall {
                call: "vkAcquireNextImageKHR",
                result,
            }),
        }
    }

    /// Presents image `index` once its `render_finished` semaphore is signalled. Returns true
    /// when the swapchain should be recreated (SUBOPTIMAL or OUT_OF_DATE).
    pub fn present(&self, ctx: &GpuContext, index: u32) -> Result<bool> {
        let waits = [self.render_finished[index as usize]];
        let swapchains = [self.handle];
        let indices = [index];
        let info = vk::PresentInfoKHR::default()
            .wait_semaphores(&waits)
            .swapchains(&swapchains)
            .image_indices(&indices);
        // SAFETY: the image was acquired and rendered into by a submitted frame.
        match unsafe { self.loader.queue_present(ctx.queue, &info) } {
            Ok(suboptimal) => Ok(suboptimal),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(true),
            Err(result) => Err(Error::VkCall {
                call: "vkQueuePresentKHR",
                result,
            }),
        }
    }

    fn release_images(&mut self, ctx: &GpuContext) {
        // SAFETY: callers made the device idle; nothing uses the views or semaphores.
        unsafe {
            for v in self.views.drain(..) {
                ctx.device.destroy_image_view(v, None);
            }
            for s in self.render_finished.drain(..) {
                ctx.device.destroy_semaphore(s, None);
            }
        }
        self.images.clear();
    }
}

impl Drop for Swapchain {
    /// Frees everything (see the module docs for the order).
    fn drop(&mut self) {
        let ctx = self.ctx.clone();
        // SAFETY: waiting has no preconditions; afterwards nothing uses the swapchain.
        unsafe {
            let _ = ctx.device.device_wait_idle();
        }
        self.release_images(&ctx);
        // SAFETY: idle device; the swapchain goes before its surface.
        unsafe {
            self.loader.destroy_swapchain(self.handle, None);
            self.surface_loader.destroy_surface(self.surface, None);
        }
    }
}
