//! Graphics pipelines of the shape tiltfield uses: triangle lists, no culling, one colour
//! attachment, optional depth, dynamic viewport and scissor, dynamic rendering (no render
//! pass objects). Passes describe what differs; this builds the rest once.

use ash::vk;

use super::context::GpuContext;
use crate::error::{Error, Result};

/// Depth test of a pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DepthTest {
    pub format: vk::Format,
    pub compare: vk::CompareOp,
    pub write: bool,
}

/// What differs between tiltfield's graphics pipelines.
#[derive(Debug, Clone, Copy)]
pub struct PipelineDesc<'a> {
    pub layout: vk::PipelineLayout,
    pub vert: vk::ShaderModule,
    pub frag: vk::ShaderModule,
    pub color_format: vk::Format,
    /// Add fragment outputs to the attachment (`ONE + ONE`) instead of replacing it.
    pub additive: bool,
    /// Write colour at all (a depth pre-pass does not).
    pub color_write: bool,
    pub depth: Option<DepthTest>,
    pub vertex_bindings: &'a [vk::VertexInputBindingDescription],
    pub vertex_attributes: &'a [vk::VertexInputAttributeDescription],
}

/// Creates the pipeline described by `desc`.
pub fn graphics_pipeline(ctx: &GpuContext, desc: &PipelineDesc) -> Result<vk::Pipeline> {
    let entry = c"main";
    let stages = [
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(desc.vert)
            .name(entry),
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::FRAGMENT)
            .module(desc.frag)
            .name(entry),
    ];
    let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
        .vertex_binding_descriptions(desc.vertex_bindings)
        .vertex_attribute_descriptions(desc.vertex_attributes);
    let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
        .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
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
    let blend_attachment = [vk::PipelineColorBlendAttachmentState::default()
        .blend_enable(desc.additive)
        .src_color_blend_factor(vk::BlendFactor::ONE)
        .dst_color_blend_factor(vk::BlendFactor::ONE)
        .color_blend_op(vk::BlendOp::ADD)
        .src_alpha_blend_factor(vk::BlendFactor::ONE)
        .dst_alpha_blend_factor(vk::BlendFactor::ONE)
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
    .map_err(|(_, e)| Error::from(e))?;
    Ok(pipelines[0])
}
