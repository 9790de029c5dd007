//! One staging upload for any number of images: one host-visible buffer filled by the caller,
//! one submission that copies every region and leaves the images readable by shaders. Used for
//! the light field views and the mesh textures alike (never one wait per image).

use ash::vk;

use super::commands::{level_copy, levels_barrier, stage, ImageTransition, Submission};
use super::context::GpuContext;
use super::resources::{Buffer, Image, ImageDesc};
use crate::error::Result;

/// Where one image's texels start in the staging buffer (tightly packed, layer after layer;
/// with mip levels, level after level, each holding every layer).
pub struct ImageRegion<'a> {
    pub image: &'a Image,
    pub offset: u64,
}

/// Copies `bytes` bytes, written by `fill` into a staging buffer, into `regions` and waits.
/// Every image ends in `SHADER_READ_ONLY_OPTIMAL` for fragment and compute shaders.
pub fn upload_images(
    ctx: &GpuContext,
    regions: &[ImageRegion],
    bytes: u64,
    name: &str,
    fill: impl FnOnce(&mut [u8]) -> Result<()>,
) -> Result<()> {
    let mut staging = Staging::new(ctx, bytes, name)?;
    let result = staging.upload(ctx, regions, bytes, fill);
    staging.destroy(ctx);
    result
}

/// Where each mip level of `desc` starts in a staging region at `offset` and its size: level
/// after level, each `width × height × layers` texels of `texel_bytes(desc.format)`.
fn level_offsets(desc: &ImageDesc, offset: u64) -> Vec<(u64, (u32, u32))> {
    let texel = texel_bytes(desc.format);
    let mut at = offset;
    (0..desc.mip_levels.max(1))
        .map(|l| {
            let size = ((desc.width >> l).max(1), (desc.height >> l).max(1));
            let here = at;
            at += size.0 as u64 * size.1 as u64 * desc.layers as u64 * texel;
            (here, size)
        })
        .collect()
}

/// Bytes per texel of the formats uploaded through staging.
fn texel_bytes(format: vk::Format) -> u64 {
    match format {
        vk::Format::R16G16B16A16_UNORM
        | vk::Format::R16G16B16A16_SFLOAT
        | vk::Format::R32G32_SFLOAT => 8,
        vk::Format::R32G32B32A32_SFLOAT => 16,
        vk::Format::R8_UNORM => 1,
        _ => 4,
    }
}

/// A staging buffer and submission kept for repeated uploads of the same size (the frames of
/// a video), so each upload writes into memory that is already mapped and faulted in instead
/// of allocating 10–100 MiB per frame. Free with [`Staging::destroy`] (buffer, then
/// submission).
pub struct Staging {
    buffer: Buffer,
    submission: Submission,
}

impl Staging {
    /// A host-visible staging buffer of `bytes` bytes and its submission.
    pub fn new(ctx: &GpuContext, bytes: u64, name: &str) -> Result<Self> {
        let buffer = Buffer::new(ctx, bytes, vk::BufferUsageFlags::TRANSFER_SRC, true, name)?;
        match Submission::new(ctx, name) {
            Ok(submission) => Ok(Staging { buffer, submission }),
            Err(e) => {
                buffer.destroy(ctx);
                Err(e)
            }
        }
    }

    /// Size in bytes.
    pub fn size(&self) -> u64 {
        self.buffer.size
    }

    /// [`upload_images`] through this buffer (`bytes` at most its size) and waits.
    pub fn upload(
        &mut self,
        ctx: &GpuContext,
        regions: &[ImageRegion],
        bytes: u64,
        fill: impl FnOnce(&mut [u8]) -> Result<()>,
    ) -> Result<()> {
        if bytes > self.buffer.size {
            return Err(crate::error::Error::Invalid(format!(
                "{bytes} bytes do not fit the {}-byte staging buffer",
                self.buffer.size
            )));
        }
        fill(&mut self.buffer.bytes_mut()[..bytes as usize])?;
        let staging = &self.buffer;
        self.submission.run(ctx, |d, cmd| {
            for region in regions {
                let img = region.image;
                let desc = &img.desc;
                let (layers, levels) = (desc.layers, desc.mip_levels.max(1));
                let to_dst = ImageTransition {
                    from: stage::UNDEFINED,
                    to: stage::TRANSFER_DST,
                };
                levels_barrier(d, cmd, img.image, layers, levels, to_dst);
                let copies: Vec<vk::BufferImageCopy> = level_offsets(desc, region.offset)
                    .into_iter()
                    .enumerate()
                    .map(|(l, (offset, size))| level_copy(offset, size, layers, l as u32))
                    .collect();
                // SAFETY: recording; the staging buffer holds every region (the caller sized it).
                unsafe {
                    d.cmd_copy_buffer_to_image(
                        cmd,
                        staging.buffer,
                        img.image,
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        &copies,
                    )
                };
                let to_read = ImageTransition {
                    from: stage::TRANSFER_DST,
                    to: stage::SHADER_READ,
                };
                levels_barrier(d, cmd, img.image, layers, levels, to_read);
            }
        })
    }

    /// Frees the buffer and the submission (after the last upload completed; every upload
    /// waits).
    pub fn destroy(self, ctx: &GpuContext) {
        self.buffer.destroy(ctx);
        self.submission.destroy(ctx);
    }
}
