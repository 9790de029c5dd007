//! Pipelines of the shapes tiltfield uses. Graphics: one colour attachment, optional depth,
//! no culling, dynamic viewport and scissor, dynamic rendering (no render pass objects), a
//! topology (points, lines, triangles) and a blend mode (replace, additive, alpha). Compute:
//! one shader. Passes describe what differs; this builds the rest once.
//!
//! Specialisation constants are 4-byte values at consecutive constant ids from 0, the form
//! every tiltfield shader uses (`layout(constant_id = N) const uint/bool …`).
//!
//! The layouts, pools and samplers every pass needs are one call each here, named for the
//! validation layer and returned as [`Owned`] guards.

use ash::vk;

use super::context::GpuContext;
use super::owned::{Owned, OwnedResult};
use crate::error::{Result, VkContext};

/// A descriptor set layout of `bindings`.
pub fn set_layout(
    ctx: &GpuContext,
    bindings: &[vk::DescriptorSetLayoutBinding],
    name: &str,
) -> Result<Owned<vk::DescriptorSetLayout>> {
    let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(bindings);
    // SAFETY: valid device and create info.
    let layout = unsafe { ctx.device.create_descriptor_set_layout(&info, None) }
        .vk("vkCreateDescriptorSetLayout")
        .owned(ctx)?;
    ctx.name(*layout, name);
    Ok(layout)
}

/// A pipeline layout of `set_layouts` and `push` constant ranges.
pub fn pipeline_layout(
    ctx: &GpuContext,
    set_layouts: &[vk::DescriptorSetLayout],
    push: &[vk::PushConstantRange],
    name: &str,
) -> Result<Owned<vk::PipelineLayout>> {
    let info = vk::PipelineLayoutCreateInfo::default()
        .set_layouts(set_layouts)
        .push_constant_ranges(push);
    // SAFETY: valid device; the set layouts belong to it.
    let layout = unsafe { ctx.device.create_pipeline_layout(&info, None) }
        .vk("vkCreatePipelineLayout")
        .owned(ctx)?;
    ctx.name(*layout, name);
    Ok(layout)
}

/// A descriptor pool for `max_sets` sets holding `sizes` descriptors in all.
pub fn descriptor_pool(
    ctx: &GpuContext,
    max_sets: u32,
    sizes: &[vk::DescriptorPoolSize],
    name: &str,
) -> Result<Owned<vk::DescriptorPool>> {
    let info = vk::DescriptorPoolCreateInfo::default()
        .max_sets(max_sets)
        .pool_sizes(sizes);
    // SAFETY: valid device and create info.
    let pool = unsafe { ctx.device.create_descriptor_pool(&info, None) }
        .vk("vkCreateDescriptorPool")
        .owned(ctx)?;
    ctx.name(*pool, name);
    Ok(pool)
}

/// A sampler.
pub fn sampler(
    ctx: &GpuContext,
    info: &vk::SamplerCreateInfo,
    name: &str,
) -> Result<Owned<vk::Sampler>> {
    // SAFETY: valid device and create info.
    let sampler = unsafe { ctx.device.create_sampler(info, None) }
        .vk("vkCreateSampler")
        .owned(ctx)?;
    ctx.name(*sampler, name);
    Ok(sampler)
}

/// Allocates one set of each of `layouts` from `pool`.
pub fn allocate_sets(
    ctx: &GpuContext,
    pool: vk::DescriptorPool,
    layouts: &[vk::DescriptorSetLayout],
) -> Result<Vec<vk::DescriptorSet>> {
    let info = vk::DescriptorSetAllocateInfo::default()
        .descriptor_pool(pool)
        .set_layouts(layouts);
    // SAFETY: valid pool and layouts of this device; callers size the pool for their sets.
    unsafe { ctx.device.allocate_descriptor_sets(&info) }.vk("vkAllocateDescriptorSets")
}

/// Depth test of a pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DepthTest {
    pub format: vk::Format,
    pub compare: vk::CompareOp,
    pub write: bool,
}

/// How fragment outputs combine with the attachment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Blend {
    /// Replace the attachment's value.
    #[default]
    Replace,
    /// Add (`ONE + ONE`): accumulation of weighted samples.
    Additive,
    /// Straight alpha over (`SRC_ALPHA, ONE_MINUS_SRC_ALPHA`): transparent overlays.
    Alpha,
}

/// What differs between tiltfield's graphics pipelines.
#[derive(Debug, Clone, Copy)]
pub struct PipelineDesc<'a> {
    pub layout: vk::PipelineLayout,
    pub vert: vk::ShaderModule,
    pub frag: vk::ShaderModule,
    pub color_format: vk::Format,
    pub topology: vk::PrimitiveTopology,
    pub blend: Blend,
    /// Write colour at all (a depth pre-pass does not).
    pub color_write: bool,
    pub depth: Option<DepthTest>,
    pub vertex_bindings: &'a [vk::VertexInputBindingDescription],
    pub vertex_attributes: &'a [vk::VertexInputAttributeDescription],
    /// Fragment shader specialisation constants (ids 0, 1, …).
    pub frag_constants: &'a [u32],
}

impl<'a> PipelineDesc<'a> {
    /// A fullscreen-triangle pipeline (no vertex input) replacing one colour attachment.
    pub fn fullscreen(
        layout: vk::PipelineLayout,
        vert: vk::ShaderModule,
        frag: vk::ShaderModule,
        color_format: vk::Format,
    ) -> Self {
        PipelineDesc {
            layout,
            vert,
            frag,
            color_format,
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
            blend: Blend::Replace,
            color_write: true,
            depth: None,
            vertex_bindings: &[],
            vertex_attributes: &[],
            frag_constants: &[],
        }
    }
}

/// Map entries and data of 4-byte specialisation constants with ids 0, 1, ….
fn specialization(values: &[u32]) -> (Vec<vk::SpecializationMapEntry>, Vec<u8>) {
    let entries = (0..values.len() as u32)
        .map(|i| vk::SpecializationMapEntry {
            constant_id: i,
            offset: i * 4,
            size: 4,
        })
        .collect();
    let data = values.iter().flat_map(|v| v.to_ne_bytes()).collect();
    (entries, data)
}

/// Creates the pipeline described by `desc`, named `name`.
pub fn graphics_pipeline(
    ctx: &GpuContext,
    desc: &PipelineDesc,
    name: &str,
) -> Result<Owned<vk::Pipeline>> {
    let entry = c"main";
    let (spec_entries, spec_data) = specialization(desc.frag_constants);
    let spec = vk::SpecializationInfo::default()
        .map_entries(&spec_entries)
        .data(&spec_data);
    let stages = [
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(desc.vert)
            .name(entry),
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::FRAGMENT)
            .module(desc.frag)
            .name(entry)
            .specialization_info(&spec),
    ];
    let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
        .vertex_binding_descriptions(desc.vertex_bindings)
        .vertex_attribute_descriptions(desc.vertex_attributes);
    let assembly = vk::PipelineInputAssemblyStateCreateInfo::default().topology(desc.topology);
    let viewport = vk::PipelineViewportStateCreateInfo::default()
        .viewport_count(1)
        .scissor_count(1);
    let raster = vk::PipelineRasterizationStateCreateInfo::default()
        .polygon_mode(vk::PolygonMode::FILL)
        .cull_mode(vk::CullModeFlags::NONE)
        .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
        .line_width(1.0);
    let multisample = vk::PipelineMultisampleStateCreateInfo::default()
        .rasterization_samples(vk::SampleCountFlags::TYPE_1);
    let depth = desc
        .depth
        .map_or_else(vk::PipelineDepthStencilStateCreateInfo::default, |d| {
            vk::PipelineDepthStencilStateCreateInfo::default()
                .depth_test_enable(true)
                .depth_write_enable(d.write)
                .depth_compare_op(d.compare)
        });
    let (src, dst) = match desc.blend {
        Blend::Replace | Blend::Additive => (vk::BlendFactor::ONE, vk::BlendFactor::ONE),
        Blend::Alpha => (
            vk::BlendFactor::SRC_ALPHA,
            vk::BlendFactor::ONE_MINUS_SRC_ALPHA,
        ),
    };
    let blend_attachment = [vk::PipelineColorBlendAttachmentState::default()
        .blend_enable(desc.blend != Blend::Replace)
        .src_color_blend_factor(src)
        .dst_color_blend_factor(dst)
        .color_blend_op(vk::BlendOp::ADD)
        .src_alpha_blend_factor(vk::BlendFactor::ONE)
        .dst_alpha_blend_factor(dst)
        .alpha_blend_op(vk::BlendOp::ADD)
        .color_write_mask(if desc.color_write {
            vk::ColorComponentFlags::RGBA
        } else {
            vk::ColorComponentFlags::empty()
        })];
    let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachment);
    let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
    let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
    let formats = [desc.color_format];
    let mut rendering = vk::PipelineRenderingCreateInfo::default()
        .color_attachment_formats(&formats)
        .depth_attachment_format(desc.depth.map_or(vk::Format::UNDEFINED, |d| d.format));
    let mut info = vk::GraphicsPipelineCreateInfo::default()
        .stages(&stages)
        .vertex_input_state(&vertex_input)
        .input_assembly_state(&assembly)
        .viewport_state(&viewport)
        .rasterization_state(&raster)
        .multisample_state(&multisample)
        .color_blend_state(&blend)
        .dynamic_state(&dynamic)
        .layout(desc.layout)
        .push_next(&mut rendering);
    if desc.depth.is_some() {
        info = info.depth_stencil_state(&depth);
    }
    // SAFETY: every referenced structure lives until the call returns.
    let pipelines = unsafe {
        ctx.device
            .create_graphics_pipelines(vk::PipelineCache::null(), &[info], None)
    }
    .map_err(|(_, e)| e)
    .vk("vkCreateGraphicsPipelines")?;
    let pipeline = Owned::new(ctx, pipelines[0]);
    ctx.name(*pipeline, name);
    Ok(pipeline)
}

/// Creates a compute pipeline running `module` with specialisation `constants` (ids 0, 1, …),
/// named `name`.
pub fn compute_pipeline(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    module: vk::ShaderModule,
    constants: &[u32],
    name: &str,
) -> Result<Owned<vk::Pipeline>> {
    let (spec_entries, spec_data) = specialization(constants);
    let spec = vk::SpecializationInfo::default()
        .map_entries(&spec_entries)
        .data(&spec_data);
    let stage = vk::PipelineShaderStageCreateInfo::default()
        .stage(vk::ShaderStageFlags::COMPUTE)
        .module(module)
        .name(c"main")
        .specialization_info(&spec);
    let info = vk::ComputePipelineCreateInfo::default()
        .stage(stage)
        .layout(layout);
    // SAFETY: every referenced structure lives until the call returns.
    let pipelines = unsafe {
        ctx.device
            .create_compute_pipelines(vk::PipelineCache::null(), &[info], None)
    }
    .map_err(|(_, e)| e)
    .vk("vkCreateComputePipelines")?;
    let pipeline = Owned::new(ctx, pipelines[0]);
    ctx.name(*pipeline, name);
    Ok(pipeline)
}
