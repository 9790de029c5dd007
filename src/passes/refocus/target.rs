//! The caller-owned render target of the refocus pass: the float accumulation image and the
//! resolved outputs at one output size, with the descriptor sets that read them. Owned by
//! whoever renders (the headless renderer, a window), so the pass records into targets it does
//! not own and several targets (frames in flight, panels) can share one pass.
//!
//! The accumulation image lives in `GENERAL` layout after its first use: it is a colour
//! attachment (fragment strategies), a storage image (compute) and sampled by the resolve, and
//! one layout for all three keeps the barriers to plain memory dependencies.
//!
//! Everything frees itself when the target is dropped, in field order: descriptor pool (frees
//! the sets) → accumulation image → outputs.

use ash::vk;

use crate::error::{Result, VkContext};
use crate::gpu::resources::{Image, ImageDesc};
use crate::gpu::{GpuContext, Owned, OwnedResult};
use crate::refocus::settings::{Accumulation, OutputFormat};

/// Accumulation and outputs of one output size.
pub struct RefocusTarget {
    _pool: Owned<vk::DescriptorPool>,
    pub width: u32,
    pub height: u32,
    pub accum_format: vk::Format,
    pub accum: Image,
    /// R8G8B8A8_UNORM: receives exact multiples of 1/255 from the resolve.
    pub out8: Image,
    /// R32G32B32A32_SFLOAT.
    pub outf: Image,
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
        )?;
        let outf = Image::new(
            ctx,
            ImageDesc::new_2d(vk::Format::R32G32B32A32_SFLOAT, width, height, out_usage),
            &[vk::Format::R32G32B32A32_SFLOAT],
            "refocus output (float)",
        )?;
        let (pool, resolve_set, storage_set) = make_sets(ctx, &accum, storage, layouts, sampler)?;
        Ok(RefocusTarget {
            _pool: pool,
            width,
            height,
            accum_format,
            accum,
            out8,
            outf,
            resolve_set,
            storage_set,
            accum_ready: false,
        })
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
}

/// The descriptor pool and the sets reading `accum`: sampled for the resolve, and as a storage
/// image for the compute strategy when `storage` (else a null set).
fn make_sets(
    ctx: &GpuContext,
    accum: &Image,
    storage: bool,
    (resolve_layout, storage_layout): (vk::DescriptorSetLayout, vk::DescriptorSetLayout),
    sampler: vk::Sampler,
) -> Result<(
    Owned<vk::DescriptorPool>,
    vk::DescriptorSet,
    vk::DescriptorSet,
)> {
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
    let pool = unsafe {
        d.create_descriptor_pool(
            &vk::DescriptorPoolCreateInfo::default()
                .max_sets(2)
                .pool_sizes(&sizes),
            None,
        )
    }
    .vk("vkCreateDescriptorPool")
    .owned(ctx)?;
    ctx.name(*pool, "refocus target descriptors");
    let layouts: Vec<_> = if storage {
        vec![resolve_layout, storage_layout]
    } else {
        vec![resolve_layout]
    };
    // SAFETY: the pool has room for these sets.
    let sets = unsafe {
        d.allocate_descriptor_sets(
            &vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(*pool)
                .set_layouts(&layouts),
        )
    }
    .vk("vkAllocateDescriptorSets")?;
    let view = accum.views[0];
    let sampled = [vk::DescriptorImageInfo::default()
        .sampler(sampler)
        .image_view(view)
        .image_layout(vk::ImageLayout::GENERAL)];
    let stored = [vk::DescriptorImageInfo::default()
        .image_view(view)
        .image_layout(vk::ImageLayout::GENERAL)];
    let mut writes = vec![vk::WriteDescriptorSet::default()
        .dst_set(sets[0])
        .dst_binding(0)
        .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
        .image_info(&sampled)];
    let storage_set = if storage {
        writes.push(
            vk::WriteDescriptorSet::default()
                .dst_set(sets[1])
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                .image_info(&stored),
        );
        sets[1]
    } else {
        vk::DescriptorSet::null()
    };
    // SAFETY: the sets are new and unused; the infos reference live views.
    unsafe { d.update_descriptor_sets(&writes, &[]) };
    Ok((pool, sets[0], storage_set))
}
