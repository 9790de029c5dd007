//! Owning wrappers for buffers and images, described by small value types.
//! Each allocates its own memory (tiltfield has a handful of resources, so a general allocator
//! would buy nothing) and is freed by value with `destroy(self, ctx)`.

use ash::vk;

use super::context::GpuContext;
use crate::error::Result;

/// A buffer with its own memory. Host-visible buffers stay mapped for their whole life.
pub struct Buffer {
    pub buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    pub size: u64,
    mapped: Option<*mut u8>,
}

impl Buffer {
    /// Creates a buffer of `size` bytes; `host` makes it host-visible, coherent and mapped.
    pub fn new(
        ctx: &GpuContext,
        size: u64,
        usage: vk::BufferUsageFlags,
        host: bool,
        name: &str,
    ) -> Result<Self> {
        let d = &ctx.device;
        let info = vk::BufferCreateInfo::default()
            .size(size.max(4))
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let buffer = unsafe { d.create_buffer(&info, None) }?;
        // SAFETY: buffer belongs to d.
        let req = unsafe { d.get_buffer_memory_requirements(buffer) };
        let flags = if host {
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT
        } else {
            vk::MemoryPropertyFlags::DEVICE_LOCAL
        };
        let memory = match allocate(ctx, req, flags) {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: unbound, unused buffer.
                unsafe { d.destroy_buffer(buffer, None) };
                return Err(e);
            }
        };
        // SAFETY: memory was allocated for this buffer's requirements.
        let mapped = unsafe {
            d.bind_buffer_memory(buffer, memory, 0)?;
            if host {
                Some(
                    d.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())?
                        as *mut u8,
                )
            } else {
                None
            }
        };
        ctx.name(buffer, name);
        ctx.name(memory, name);
        Ok(Buffer {
            buffer,
            memory,
            size,
            mapped,
        })
    }

    /// A host-visible buffer holding a copy of `bytes`.
    pub fn with_bytes(
        ctx: &GpuContext,
        bytes: &[u8],
        usage: vk::BufferUsageFlags,
        name: &str,
    ) -> Result<Self> {
        let mut b = Buffer::new(ctx, bytes.len() as u64, usage, true, name)?;
        b.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
        Ok(b)
    }

    /// The mapped bytes of a host-visible buffer.
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        match self.mapped {
            // SAFETY: the mapping covers `size` bytes and lives as long as self; &mut self
            // prevents aliasing from the CPU side (the GPU is idle whenever tiltfield maps).
            Some(p) => unsafe { std::slice::from_raw_parts_mut(p, self.size as usize) },
            None => &mut [],
        }
    }

    /// Frees the buffer.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU no longer uses the buffer (callers wait for their submissions).
        unsafe {
            if self.mapped.is_some() {
                ctx.device.unmap_memory(self.memory);
            }
            ctx.device.destroy_buffer(self.buffer, None);
            ctx.device.free_memory(self.memory, None);
        }
    }
}

/// Description of a 2D (array) image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageDesc {
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    pub layers: u32,
    pub usage: vk::ImageUsageFlags,
    /// Allow views in other formats of the same class (UNORM and SRGB of RGBA8).
    pub mutable_format: bool,
}

impl ImageDesc {
    /// A single-layer 2D image.
    pub fn new_2d(format: vk::Format, width: u32, height: u32, usage: vk::ImageUsageFlags) -> Self {
        ImageDesc {
            format,
            width,
            height,
            layers: 1,
            usage,
            mutable_format: false,
        }
    }

    fn create_info(&self) -> vk::ImageCreateInfo<'static> {
        vk::ImageCreateInfo::default()
            .flags(if self.mutable_format {
                vk::ImageCreateFlags::MUTABLE_FORMAT
            } else {
                vk::ImageCreateFlags::empty()
            })
            .image_type(vk::ImageType::TYPE_2D)
            .format(self.format)
            .extent(vk::Extent3D {
                width: self.width,
                height: self.height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(self.layers)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(self.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED)
    }

    /// Bytes of device memory this image would need on `ctx`'s device.
    pub fn memory_size(&self, ctx: &GpuContext) -> Result<u64> {
        let info = self.create_info();
        let req = vk::DeviceImageMemoryRequirements::default().create_info(&info);
        let mut out = vk::MemoryRequirements2::default();
        // SAFETY: valid device (Vulkan 1.3 core query).
        unsafe {
            ctx.device
                .get_device_image_memory_requirements(&req, &mut out)
        };
        Ok(out.memory_requirements.size)
    }
}

/// A device-local image with its own memory and one view per requested format.
pub struct Image {
    pub image: vk::Image,
    memory: vk::DeviceMemory,
    pub desc: ImageDesc,
    /// Views in the order of the formats given to [`Image::new`].
    pub views: Vec<vk::ImageView>,
}

impl Image {
    /// Creates the image and a view (2D, or 2D array for several layers) for each format.
    pub fn new(
        ctx: &GpuContext,
        desc: ImageDesc,
        view_formats: &[vk::Format],
        name: &str,
    ) -> Result<Self> {
        let d = &ctx.device;
        // SAFETY: valid device and create info.
        let image = unsafe { d.create_image(&desc.create_info(), None) }?;
        // SAFETY: image belongs to d.
        let req = unsafe { d.get_image_memory_requirements(image) };
        let memory = match allocate(ctx, req, vk::MemoryPropertyFlags::DEVICE_LOCAL) {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: unbound, unused image.
                unsafe { d.destroy_image(image, None) };
                return Err(e);
            }
        };
        let mut img = Image {
            image,
            memory,
            desc,
            views: Vec::new(),
        };
        // SAFETY: memory allocated for this image's requirements.
        if let Err(e) = unsafe { d.bind_image_memory(image, memory, 0) } {
            img.destroy(ctx);
            return Err(e.into());
        }
        for &format in view_formats {
            let info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(if desc.layers > 1 {
                    vk::ImageViewType::TYPE_2D_ARRAY
                } else {
                    vk::ImageViewType::TYPE_2D
                })
                .format(format)
                .subresource_range(range_of(desc.format, desc.layers));
            // SAFETY: the format is the image's or compatible with it (MUTABLE_FORMAT).
            match unsafe { d.create_image_view(&info, None) } {
                Ok(v) => {
                    ctx.name(v, &format!("{name} ({format:?} view)"));
                    img.views.push(v);
                }
                Err(e) => {
                    img.destroy(ctx);
                    return Err(e.into());
                }
            }
        }
        ctx.name(image, name);
        ctx.name(memory, name);
        Ok(img)
    }

    /// Frees the image and its views.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU no longer uses the image (callers wait for their submissions).
        unsafe {
            for v in self.views {
                ctx.device.destroy_image_view(v, None);
            }
            ctx.device.destroy_image(self.image, None);
            ctx.device.free_memory(self.memory, None);
        }
    }
}

/// The subresource range of all `layers` layers, mip 0, with the depth aspect for depth
/// formats and the colour aspect otherwise.
pub fn range_of(format: vk::Format, layers: u32) -> vk::ImageSubresourceRange {
    let depth = matches!(
        format,
        vk::Format::D32_SFLOAT | vk::Format::D16_UNORM | vk::Format::X8_D24_UNORM_PACK32
    );
    vk::ImageSubresourceRange {
        aspect_mask: if depth {
            vk::ImageAspectFlags::DEPTH
        } else {
            vk::ImageAspectFlags::COLOR
        },
        ..color_range(layers)
    }
}

/// The colour subresource range of all `layers` layers, mip 0.
pub fn color_range(layers: u32) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: layers,
    }
}

fn allocate(
    ctx: &GpuContext,
    req: vk::MemoryRequirements,
    flags: vk::MemoryPropertyFlags,
) -> Result<vk::DeviceMemory> {
    let type_index = ctx.memory_type(req.memory_type_bits, flags)?;
    let info = vk::MemoryAllocateInfo::default()
        .allocation_size(req.size)
        .memory_type_index(type_index);
    // SAFETY: valid device and allocation info.
    unsafe { ctx.device.allocate_memory(&info, None) }.map_err(|e| match e {
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
            crate::error::Error::DeviceLimit(format!(
                "{} is out of memory allocating {:.1} MiB",
                ctx.info.name,
                req.size as f64 / (1024.0 * 1024.0)
            ))
        }
        e => e.into(),
    })
}
