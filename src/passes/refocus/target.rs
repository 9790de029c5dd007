//! The caller-owned render target of the refocus pass: the float accumulation image and the
//! resolved outputs at one output size, with the descriptor sets that read them. Owned by
//! whoever renders (the headless renderer, a window), so the pass records into targets it does
//! not own and several targets (frames in flight, panels) can share one pass.
//!
//! The accumulation image lives in `GENERAL` layout after its first use: it is a colour
//! attachment (fragment strategies), a storage image (compute) and sampled by the resolve, and
//! one layout for all three keeps the barriers to plain memory dependencies.
//!
//! Destruction order: descriptor pool (frees the sets) → outputs → accumulation image.

use ash::vk;

use crate::error::{Result, VkContext};
use crate::gpu::resources::{Image, ImageDesc};
use crate::gpu::GpuContext;
use crate::refocus::settings::{Accumulation, OutputFormat};

/// Accumulation and outputs of one output size.
pub struct RefocusTarget {
    pub width: u32,
    pub height: u32,
    pub accum_format: vk::Format,
    pub accum: Image,
    /// R8G8B8A8_UNORM: receives exact multiples of 1/255 from the resolve.
    pub out8: Image,
    /// R32G32B32A32_SFLOAT.
    pub outf: Image,
    pool: vk::DescriptorPool,
    /// The accumulation image as a sampled image (resolve, set 0).
    pub(super) resolve_set: vk::DescriptorSet,
    /// The accumulation image as a storage image (compute strategy, set 1); null when the
    /// accumulation format cannot be a storage image.
    pub(super) storage_set: vk::DescriptorSet,
    /// Whether the accumulation image has been moved to `GENERAL` (by a recorded barrier).
    pub(super) accum_ready: bool,
}

impl RefocusTarget {
    /// Creates the images and the descriptor sets (layouts from the pass).
    pub(super) fn new(
        ctx: &GpuContext,
        width: u32,
        height: u32,
        accum_format: vk::Format,
        storage: bool,
        layouts: (vk::DescriptorSetLayout, vk::DescriptorSetLayout),
        sampler: vk::Sampler,
    ) -> Result<Self> {
        let color = vk::ImageUsageFlags::COLOR_ATTACHMENT;
        let mut accum_usage = color | vk::ImageUsageFlags::SAMPLED;
        if storage {
            accum_usage |= vk::ImageUsageFlags::STORAGE;
        }
        let out_usage = color | vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::SAMPLED;
        let accum = Image::new(
            ctx,
            ImageDesc::new_2d(accum_format, width, height, accum_usage),
            &[accum_format],
            "accumulation target",
        )?;
        let out8 = Image::new(
            ctx,
            ImageDesc::new_2d(vk::Format::R8G8B8A8_UNORM, width, height, out_usage),
            &[vk::Format::R8G8B8A8_UNORM],
            "refocus output (8-bit)",
        );
        let out8 = match out8 {
            Ok(i) => i,
            Err(e) => {
                accum.destroy(ctx);
                return Err(e);
            }
        };
        let outf = Image::new(
            ctx,
            ImageDesc::new_2d(vk::Format::R32G32B32A32_SFLOAT, width, height, out_usage),
            &[vk::Format::R32G32B32A32_SFLOAT],
            "refocus output (float)",
        );
        let outf = match outf {
            Ok(i) => i,
            Err(e) => {
                accum.destroy(ctx);
                out8.destroy(ctx);
                return Err(e);
            }
        };
        let mut target = RefocusTarget {
            width,
            height,
            accum_format,
            accum,
            out8,
            outf,
            pool: vk::DescriptorPool::null(),
            resolve_set: vk::DescriptorSet::null(),
            storage_set: vk::DescriptorSet::null(),
            accum_ready: false,
        };
        if let Err(e) = target.make_sets(ctx, storage, layouts, sampler) {
            target.destroy(ctx);
            return Err(e);
        }
        Ok(target)
    }

    fn make_sets(
        &mut self,
        ctx: &GpuContext,
        storage: bool,
        (resolve_layout, storage_layout): (vk::DescriptorSetLayout, vk::DescriptorSetLayout),
        sampler: vk::Sampler,
    ) -> Result<()> {
        let d = &ctx.device;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
                descriptor_count: 1,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_IMAGE,
                descriptor_count: 1,
            },
        ];
        // SAFETY: valid device and create info.
        self.pool = unsafe {
            d.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(2)
                    .pool_sizes(&sizes),
                None,
            )
        }
        .vk("vkCreateDescriptorPool")?;
        ctx.name(self.pool, "refocus target descriptors");
        let layouts: Vec<_> = if storage {
            vec![resolve_layout, storage_layout]
        } else {
            vec![resolve_layout]
        };
        // SAFETY: the pool has room for these sets.
        let sets = unsafe {
            d.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(self.pool)
                    .set_layouts(&layouts),
            )
        }
        .vk("vkAllocateDescriptorSets")?;
        self.resolve_set = sets[0];
        let view = self.accum.views[0];
        let sampled = [vk::DescriptorImageInfo::default()
            .sampler(sampler)
            .image_view(view)
            .image_layout(vk::ImageLayout::GENERAL)];
        let stored = [vk::DescriptorImageInfo::default()
            .image_view(view)
            .image_layout(vk::ImageLayout::GENERAL)];
        let mut writes = vec![vk::WriteDescriptorSet::default()
            .dst_set(self.resolve_set)
            .dst_binding(0)
            .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .image_info(&sampled)];
        if storage {
            self.storage_set = sets[1];
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(self.storage_set)
                    .dst_binding(0)
                    .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                    .image_info(&stored),
            );
        }
        // SAFETY: the sets are new and unused; the infos reference live views.
        unsafe { d.update_descriptor_sets(&writes, &[]) };
        Ok(())
    }

    /// The format the views are summed in.
    pub fn accumulation(&self) -> super::Accumulation {
        if self.accum_format == super::accumulation_format(Accumulation::Rgba16f) {
            Accumulation::Rgba16f
        } else {
            Accumulation::Rgba32f
        }
    }

    /// The image and view a resolve into `format` writes.
    pub fn output(&self, format: OutputFormat) -> (&Image, vk::ImageView) {
        let image = match format {
            OutputFormat::Srgb8 => &self.out8,
            OutputFormat::Float => &self.outf,
        };
        (image, image.views[0])
    }

    /// Frees everything (see the module docs for the order). The GPU must be done with it.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: no pending work uses the pool; destroying it frees its sets.
        unsafe { ctx.device.destroy_descriptor_pool(self.pool, None) };
        self.out8.destroy(ctx);
        self.outf.destroy(ctx);
        self.accum.destroy(ctx);
    }
}
