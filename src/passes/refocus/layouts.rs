//! The refocus pass's fixed objects: samplers, descriptor set layouts, pipeline layouts and the
//! pool of its input sets. Made once per pass, each frees itself (field order: pipeline layouts
//! → pool, which frees the sets → set layouts → samplers).

use ash::vk;

use super::interface::RefocusPush;
use crate::error::Result;
use crate::gpu::pipeline::{self, allocate_sets};
use crate::gpu::{GpuContext, Owned};

pub(super) struct PassLayouts {
    pub accum: Owned<vk::PipelineLayout>,
    pub compute: Owned<vk::PipelineLayout>,
    pub resolve: Owned<vk::PipelineLayout>,
    _pool: Owned<vk::DescriptorPool>,
    pub input_set: Owned<vk::DescriptorSetLayout>,
    pub resolve_set: Owned<vk::DescriptorSetLayout>,
    pub storage_set: Owned<vk::DescriptorSetLayout>,
    /// Bilinear at level 0: the views (bindings 0 and 9).
    pub linear: Owned<vk::Sampler>,
    /// Nearest at level 0: the accumulation image in the resolve.
    pub nearest: Owned<vk::Sampler>,
    /// Trilinear over every mip level: anti-aliasing's prefiltered lookup (binding 7). The
    /// other samplers stop at level 0, so the plain sum reads exactly what it read before the
    /// views had levels.
    pub mip: Owned<vk::Sampler>,
}

impl PassLayouts {
    /// Creates the objects and `input_sets` input descriptor sets (one per texture view).
    pub fn new(ctx: &GpuContext, input_sets: usize) -> Result<(Self, Vec<vk::DescriptorSet>)> {
        let sampler = |filter| {
            vk::SamplerCreateInfo::default()
                .mag_filter(filter)
                .min_filter(filter)
                .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .max_lod(0.0)
        };
        let linear =
            pipeline::sampler(ctx, &sampler(vk::Filter::LINEAR), "view sampler (bilinear)")?;
        let nearest = pipeline::sampler(
            ctx,
            &sampler(vk::Filter::NEAREST),
            "accumulation sampler (nearest)",
        )?;
        let trilinear = sampler(vk::Filter::LINEAR)
            .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
            .max_lod(vk::LOD_CLAMP_NONE);
        let mip = pipeline::sampler(
            ctx,
            &trilinear,
            "view sampler (trilinear, prefilter levels)",
        )?;
        let binding = |i: u32, ty, stages| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(i)
                .descriptor_type(ty)
                .descriptor_count(1)
                .stage_flags(stages)
        };
        let shading = vk::ShaderStageFlags::FRAGMENT | vk::ShaderStageFlags::COMPUTE;
        use vk::DescriptorType as T;
        let input_bindings = [
            T::COMBINED_IMAGE_SAMPLER,
            T::STORAGE_BUFFER,
            T::UNIFORM_BUFFER,
            T::UNIFORM_BUFFER,
            T::UNIFORM_BUFFER,
            T::STORAGE_BUFFER,
            T::UNIFORM_BUFFER,
            T::COMBINED_IMAGE_SAMPLER,
            T::STORAGE_BUFFER,
            T::COMBINED_IMAGE_SAMPLER,
            T::STORAGE_BUFFER,
        ]
        .into_iter()
        .enumerate()
        .map(|(i, ty)| binding(i as u32, ty, shading))
        .collect::<Vec<_>>();
        let input_set = pipeline::set_layout(ctx, &input_bindings, "refocus input set layout")?;
        let resolve_set = pipeline::set_layout(
            ctx,
            &[binding(
                0,
                T::COMBINED_IMAGE_SAMPLER,
                vk::ShaderStageFlags::FRAGMENT,
            )],
            "resolve set layout",
        )?;
        let storage_set = pipeline::set_layout(
            ctx,
            &[binding(0, T::STORAGE_IMAGE, vk::ShaderStageFlags::COMPUTE)],
            "accumulation storage set layout",
        )?;
        let push = |stages| {
            [vk::PushConstantRange::default()
                .stage_flags(stages)
                .offset(0)
                .size(std::mem::size_of::<RefocusPush>() as u32)]
        };
        let accum = pipeline::pipeline_layout(
            ctx,
            &[*input_set],
            &push(vk::ShaderStageFlags::FRAGMENT),
            "refocus fragment layout",
        )?;
        let compute = pipeline::pipeline_layout(
            ctx,
            &[*input_set, *storage_set],
            &push(vk::ShaderStageFlags::COMPUTE),
            "refocus compute layout",
        )?;
        let resolve = pipeline::pipeline_layout(ctx, &[*resolve_set], &[], "resolve layout")?;
        let n = input_sets as u32;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: T::COMBINED_IMAGE_SAMPLER,
                descriptor_count: 3 * n,
            },
            vk::DescriptorPoolSize {
                ty: T::STORAGE_BUFFER,
                descriptor_count: 3 * n,
            },
            vk::DescriptorPoolSize {
                ty: T::UNIFORM_BUFFER,
                descriptor_count: 4 * n,
            },
        ];
        let pool = pipeline::descriptor_pool(ctx, n, &sizes, "refocus input descriptors")?;
        let sets = allocate_sets(ctx, *pool, &vec![*input_set; input_sets])?;
        let layouts = PassLayouts {
            accum,
            compute,
            resolve,
            _pool: pool,
            input_set,
            resolve_set,
            storage_set,
            linear,
            nearest,
            mip,
        };
        Ok((layouts, sets))
    }
}
