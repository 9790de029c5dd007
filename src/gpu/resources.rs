//! Owning wrappers for buffers and images, described by small value types.
//! Each allocates its own memory (tiltfield has a handful of resources, so a general allocator
//! would buy nothing) and frees it when dropped (each keeps a clone of the context).

use ash::vk;

use super::context::GpuContext;
use crate::error::{Result, VkContext};

/// A buffer with its own memory. Host-visible buffers stay mapped for their whole life.
pub struct Buffer {
    pub buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    pub size: u64,
    mapped: Option<*mut u8>,
    coherent: bool,
    ctx: GpuContext,
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
        let flags = if host {
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT
        } else {
            vk::MemoryPropertyFlags::DEVICE_LOCAL
        };
        Self::with_memory(ctx, size, usage, &[flags], name)
    }

    /// A mapped buffer the GPU writes and the CPU reads: host-cached memory where the device
    /// has it (uncached reads of mapped memory are very slow on discrete GPUs), else any
    /// host-visible memory. Call [`Buffer::invalidate`] before reading.
    pub fn readback(ctx: &GpuContext, size: u64, name: &str) -> Result<Self> {
        use vk::MemoryPropertyFlags as M;
        let preferences = [
            M::HOST_VISIBLE | M::HOST_CACHED | M::HOST_COHERENT,
            M::HOST_VISIBLE | M::HOST_CACHED,
            M::HOST_VISIBLE | M::HOST_COHERENT,
        ];
        Self::with_memory(
            ctx,
            size,
            vk::BufferUsageFlags::TRANSFER_DST,
            &preferences,
            name,
        )
    }

    /// Creates the buffer in the first memory kind of `preferences` the device offers for it;
    /// host-visible memory is mapped. Frees what it made when a later step fails.
    fn with_memory(
        ctx: &GpuContext,
        size: u64,
        usage: vk::BufferUsageFlags,
        preferences: &[vk::MemoryPropertyFlags],
        name: &str,
    ) -> Result<Self> {
        let d = &ctx.device;
        let info = vk::BufferCreateInfo::default()
            .size(size.max(4))
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let buffer = unsafe { d.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        // SAFETY: buffer belongs to d.
        let req = unsafe { d.get_buffer_memory_requirements(buffer) };
        let chosen = preferences.iter().find_map(|&f| {
            ctx.memory_type(req.memory_type_bits, f)
                .ok()
                .map(|t| (f, t))
        });
        let Some((flags, type_index)) = chosen else {
            // SAFETY: unbound, unused buffer.
            unsafe { d.destroy_buffer(buffer, None) };
            return Err(crate::error::Error::DeviceLimit(format!(
                "{} has no memory type among {preferences:?} for buffer '{name}'",
                ctx.info.name
            )));
        };
        let memory = match allocate_type(ctx, req, type_index) {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: unbound, unused buffer.
                unsafe { d.destroy_buffer(buffer, None) };
                return Err(e);
            }
        };
        let host = flags.contains(vk::MemoryPropertyFlags::HOST_VISIBLE);
        // SAFETY: memory was allocated for this buffer's requirements.
        let bound = unsafe { d.bind_buffer_memory(buffer, memory, 0) }
            .vk("vkBindBufferMemory")
            .and_then(|()| {
                if host {
                    // SAFETY: host-visible memory, not mapped yet.
                    unsafe { d.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()) }
                        .map(|p| Some(p as *mut u8))
                        .vk("vkMapMemory")
                } else {
                    Ok(None)
                }
            });
        let mapped = match bound {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: nothing uses the buffer or the memory yet.
                unsafe {
                    d.destroy_buffer(buffer, None);
                    d.free_memory(memory, None);
                }
                return Err(e);
            }
        };
        ctx.name(buffer, name);
        ctx.name(memory, name);
        Ok(Buffer {
            buffer,
            memory,
            size,
            mapped,
            coherent: flags.contains(vk::MemoryPropertyFlags::HOST_COHERENT),
            ctx: ctx.clone(),
        })
    }

    /// Makes GPU writes visible to the mapping (needed for non-coherent memory; cheap
    /// otherwise). Call after the writing submission completed and before reading.
    pub fn invalidate(&self, ctx: &GpuContext) -> Result<()> {
        if self.coherent || self.mapped.is_none() {
            return Ok(());
        }
        let range = vk::MappedMemoryRange::default()
            .memory(self.memory)
            .offset(0)
            .size(vk::WHOLE_SIZE);
        // SAFETY: the memory is mapped; the GPU finished writing it.
        unsafe { ctx.device.invalidate_mapped_memory_ranges(&[range]) }
            .vk("vkInvalidateMappedMemoryRanges")?;
        Ok(())
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
}

impl Drop for Buffer {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        // SAFETY: the GPU no longer uses the buffer (owners wait for their submissions).
        unsafe {
            if self.mapped.is_some() {
                d.unmap_memory(self.memory);
            }
            d.destroy_buffer(self.buffer, None);
            d.free_memory(self.memory, None);
        }
    }
}

/// RGBA32F texels read back into host memory (native byte order, tightly packed), each
/// channel multiplied by `scale`. Trailing bytes short of a texel are ignored.
pub fn rgba_f32(bytes: &[u8], scale: f32) -> Vec<[f32; 4]> {
    bytes
        .chunks_exact(16)
        .map(|c| {
            std::array::from_fn(|k| {
                f32::from_ne_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]]) * scale
            })
        })
        .collect()
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
    /// View it as a 2D array even with one layer (a shader's `sampler2DArray` needs an array
    /// view whatever the layer count: a light field of one view is still an array).
    pub array: bool,
    /// Mip levels (1: the image alone). Views, barriers and uploads cover every level.
    pub mip_levels: u32,
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
            array: false,
            mip_levels: 1,
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
            .mip_levels(self.mip_levels.max(1))
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
    ctx: GpuContext,
}

impl Image {
    /// Creates the image and a view (2D, or 2D array for several layers or `desc.array`) for
    /// each format.
    pub fn new(
        ctx: &GpuContext,
        desc: ImageDesc,
        view_formats: &[vk::Format],
        name: &str,
    ) -> Result<Self> {
        let d = &ctx.device;
        // SAFETY: valid device and create info.
        let image = unsafe { d.create_image(&desc.create_info(), None) }.vk("vkCreateImage")?;
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
            ctx: ctx.clone(),
        };
        // SAFETY: memory allocated for this image's requirements.
        unsafe { d.bind_image_memory(image, memory, 0) }.vk("vkBindImageMemory")?;
        for &format in view_formats {
            let info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(if desc.layers > 1 || desc.array {
                    vk::ImageViewType::TYPE_2D_ARRAY
                } else {
                    vk::ImageViewType::TYPE_2D
                })
                .format(format)
                .subresource_range(vk::ImageSubresourceRange {
                    level_count: desc.mip_levels.max(1),
                    ..range_of(desc.format, desc.layers)
                });
            // SAFETY: the format is the image's or compatible with it (MUTABLE_FORMAT).
            let v = unsafe { d.create_image_view(&info, None) }.vk("vkCreateImageView")?;
            ctx.name(v, &format!("{name} ({format:?} view)"));
            img.views.push(v);
        }
        ctx.name(image, name);
        ctx.name(memory, name);
        Ok(img)
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        // SAFETY: the GPU no longer uses the image (owners wait for their submissions); an image
        // dropped half-built has only the views made so far, and unbound memory may be freed.
        unsafe {
            for &v in &self.views {
                d.destroy_image_view(v, None);
            }
            d.destroy_image(self.image, None);
            d.free_memory(self.memory, None);
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
    allocate_type(ctx, req, ctx.memory_type(req.memory_type_bits, flags)?)
}

fn allocate_type(
    ctx: &GpuContext,
    req: vk::MemoryRequirements,
    type_index: u32,
) -> Result<vk::DeviceMemory> {
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
        result => crate::error::Error::VkCall {
            call: "vkAllocateMemory",
            result,
        },
    })
}
