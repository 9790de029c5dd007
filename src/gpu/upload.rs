//! One staging upload for any number of images: one host-visible buffer filled by the caller,
//! one submission that copies every region and leaves the images readable by shaders. Used for
//! the light field views and the mesh textures alike (never one wait per image).

use ash::vk;

use super::commands::{level_copy, levels_barrier, stage, ImageTransition, Submission};
use super::context::GpuContext;
use super::resources::{Buffer, Image};
use crate::error::Result;

/// Where one image's texels lie in the staging buffer: one offset per mip level (level 0
/// first), each level tightly packed, layer after layer. The caller packed the buffer, so it
/// says where; the levels' sizes follow from the image's (halved, at least 1).
pub struct ImageRegion<'a> {
    pub image: &'a Image,
    pub offsets: Vec<u64>,
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
    Staging::new(ctx, bytes, name)?.upload(ctx, regions, bytes, fill)
}

/// A staging buffer and submission kept for repeated uploads of the same size (the frames of
/// a video), so each upload writes into memory that is already mapped and faulted in instead
/// of allocating 10–100 MiB per frame. Every upload waits, so dropping it is always safe.
pub struct Staging {
    buffer: Buffer,
    submission: Submission,
}

impl Staging {
    /// A host-visible staging buffer of `bytes` bytes and its submission.
    pub fn new(ctx: &GpuContext, bytes: u64, name: &str) -> Result<Self> {
        Ok(Staging {
            buffer: Buffer::new(ctx, bytes, vk::BufferUsageFlags::TRANSFER_SRC, true, name)?,
            submission: Submission::new(ctx, name)?,
        })
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
        if let Some(r) = regions
            .iter()
            .find(|r| r.offsets.len() != r.image.desc.mip_levels.max(1) as usize)
        {
            return Err(crate::error::Error::Invalid(format!(
                "{} staging offsets for an image of {} mip levels",
                r.offsets.len(),
                r.image.desc.mip_levels.max(1)
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
                let copies: Vec<vk::BufferImageCopy> = region
                    .offsets
                    .iter()
                    .enumerate()
                    .map(|(l, &offset)| {
                        let l = l as u32;
                        let size = ((desc.width >> l).max(1), (desc.height >> l).max(1));
                        level_copy(offset, size, layers, l)
                    })
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
}
