//! All views of a light field in one 2D array texture (RGBA8, one layer per view, in the
//! light field's row-major order), uploaded through one staging buffer and one submission.
//!
//! The image is created with MUTABLE_FORMAT and two views of the same texels: `UNORM` (encoded
//! averaging: texels are filtered as stored) and `SRGB` (linear averaging: the sampler decodes
//! to linear light before filtering, as the Vulkan spec requires).

use ash::vk;

use crate::error::{Error, Result};
use crate::gpu::commands::{color_copy, image_barrier, stage, ImageTransition, Submission};
use crate::gpu::resources::{Buffer, Image, ImageDesc};
use crate::gpu::GpuContext;
use crate::lightfield::LightField;

/// The device limits that decide whether a light field fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureLimits {
    pub max_layers: u32,
    pub max_dimension: u32,
    /// Largest device-local heap, bytes.
    pub heap_bytes: u64,
    /// Largest single allocation, bytes.
    pub max_allocation: u64,
}

impl TextureLimits {
    /// The limits of `ctx`'s device.
    pub fn of(ctx: &GpuContext) -> Self {
        let mut m3 = vk::PhysicalDeviceMaintenance3Properties::default();
        let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut m3);
        // SAFETY: valid physical device and chained structures.
        unsafe {
            ctx.instance
                .get_physical_device_properties2(ctx.physical, &mut p2)
        };
        let limits = &ctx.properties.limits;
        TextureLimits {
            max_layers: limits.max_image_array_layers,
            max_dimension: limits.max_image_dimension2_d,
            heap_bytes: ctx.device_local_heap(),
            max_allocation: m3.max_memory_allocation_size,
        }
    }
}

/// Checks that `views` views of `width × height` needing `bytes` of memory fit the limits.
/// Pure, so every refusal is unit-testable without a device.
pub fn check_fits(
    views: usize,
    width: u32,
    height: u32,
    bytes: u64,
    limits: &TextureLimits,
    device: &str,
) -> Result<()> {
    if views > limits.max_layers as usize {
        return Err(Error::DeviceLimit(format!(
            "the light field has {views} views but {device} holds at most {} layers in one \
             array texture (maxImageArrayLayers); use fewer views",
            limits.max_layers
        )));
    }
    if width.max(height) > limits.max_dimension {
        return Err(Error::DeviceLimit(format!(
            "views of {width}×{height} exceed {device}'s maximum image size of {} px",
            limits.max_dimension
        )));
    }
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    if bytes > limits.heap_bytes || bytes > limits.max_allocation {
        return Err(Error::DeviceLimit(format!(
            "the light field texture needs {:.1} MiB but {device} offers {:.1} MiB of device \
             memory and {:.1} MiB per allocation; use fewer or smaller views",
            mib(bytes),
            mib(limits.heap_bytes),
            mib(limits.max_allocation)
        )));
    }
    Ok(())
}

/// The uploaded light field. Not `Clone`; free with [`LightFieldTexture::destroy`].
pub struct LightFieldTexture {
    pub image: Image,
    pub layers: u32,
    pub width: u32,
    pub height: u32,
}

/// Index of the UNORM view in `image.views`.
pub const VIEW_UNORM: usize = 0;
/// Index of the SRGB view in `image.views`.
pub const VIEW_SRGB: usize = 1;

impl LightFieldTexture {
    /// Checks the limits, then uploads every view.
    pub fn upload(ctx: &GpuContext, lf: &LightField) -> Result<Self> {
        let (w, h) = (lf.width, lf.height);
        let layers = lf.views.len();
        let desc = ImageDesc {
            format: vk::Format::R8G8B8A8_UNORM,
            width: w,
            height: h,
            layers: layers.clamp(1, u32::MAX as usize) as u32,
            usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
            mutable_format: true,
        };
        let limits = TextureLimits::of(ctx);
        // Limits first: creating an image beyond maxImageArrayLayers is invalid usage.
        check_fits(layers, w, h, 0, &limits, &ctx.info.name)?;
        let bytes = desc.memory_size(ctx)?;
        check_fits(layers, w, h, bytes, &limits, &ctx.info.name)?;

        let staging_size = layers as u64 * w as u64 * h as u64 * 4;
        let mut staging = Buffer::new(
            ctx,
            staging_size,
            vk::BufferUsageFlags::TRANSFER_SRC,
            true,
            "light field staging",
        )?;
        let layer_bytes = (w * h * 4) as usize;
        for (dst, v) in staging
            .bytes_mut()
            .chunks_exact_mut(layer_bytes)
            .zip(&lf.views)
        {
            dst.copy_from_slice(v.image.as_raw());
        }
        let image = match Image::new(
            ctx,
            desc,
            &[vk::Format::R8G8B8A8_UNORM, vk::Format::R8G8B8A8_SRGB],
            "light field views",
        ) {
            Ok(i) => i,
            Err(e) => {
                staging.destroy(ctx);
                return Err(e);
            }
        };
        let upload = Submission::new(ctx, "light field upload").and_then(|sub| {
            let r = sub.run(ctx, |d, cmd| {
                image_barrier(
                    d,
                    cmd,
                    image.image,
                    desc.layers,
                    ImageTransition {
                        from: stage::UNDEFINED,
                        to: stage::TRANSFER_DST,
                    },
                );
                // Views are packed layer after layer, so one region covers all of them.
                let region = color_copy(0, w, h, desc.layers);
                // SAFETY: recording; the buffer holds layers·w·h·4 bytes.
                unsafe {
                    d.cmd_copy_buffer_to_image(
                        cmd,
                        staging.buffer,
                        image.image,
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        &[region],
                    )
                };
                image_barrier(
                    d,
                    cmd,
                    image.image,
                    desc.layers,
                    ImageTransition {
                        from: stage::TRANSFER_DST,
                        to: stage::FRAGMENT_READ,
                    },
                );
            });
            sub.destroy(ctx);
            r
        });
        staging.destroy(ctx);
        if let Err(e) = upload {
            image.destroy(ctx);
            return Err(e);
        }
        Ok(LightFieldTexture {
            image,
            layers: desc.layers,
            width: w,
            height: h,
        })
    }

    /// Frees the texture.
    pub fn destroy(self, ctx: &GpuContext) {
        self.image.destroy(ctx);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: TextureLimits = TextureLimits {
        max_layers: 2048,
        max_dimension: 16384,
        heap_bytes: 1 << 30,
        max_allocation: 1 << 30,
    };

    #[test]
    fn fitting_light_fields_pass() {
        assert!(check_fits(81, 512, 512, 81 * 512 * 512 * 4, &LIMITS, "dev").is_ok());
    }

    #[test]
    fn too_many_layers_names_the_limit() {
        let e = check_fits(2049, 8, 8, 0, &LIMITS, "dev")
            .unwrap_err()
            .to_string();
        assert!(e.contains("2049 views") && e.contains("2048"), "{e}");
    }

    #[test]
    fn oversized_views_and_memory_are_refused() {
        let e = check_fits(4, 20000, 10, 0, &LIMITS, "dev")
            .unwrap_err()
            .to_string();
        assert!(e.contains("20000"), "{e}");
        let e = check_fits(4, 10, 10, 2 << 30, &LIMITS, "dev")
            .unwrap_err()
            .to_string();
        assert!(e.contains("MiB"), "{e}");
    }
}
