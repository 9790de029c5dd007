//! The window compositor: draws a sampled image into a rectangle of the current rendering (the
//! refocus image and the scene view into their panels, the text overlay over everything).
//!
//! The destination is a UNORM attachment that receives sRGB-encoded values (the swapchain).
//! Sources are either already encoded (the refocus pass's 8-bit output: copied) or sRGB images
//! whose samples are linear light (the scene view: encoded in the shader), see
//! `shaders/panel.frag`. Sampling is bilinear with clamped edges, so a panel of another size than
//! its image is a smooth resample; the text overlay is drawn 1:1 and stays sharp.
//!
//! Descriptor sets come from one pool that is reset whenever the sources change (a resize):
//! callers reset only when no frame in flight uses the old sets.
//!
//! Every object frees itself when the compositor is dropped, in field order: pipelines →
//! pipeline layout → descriptor pool → set layout → sampler.

use ash::vk;

use crate::error::{Result, VkContext};
use crate::gpu::pipeline::{self, graphics_pipeline, Blend, PipelineDesc};
use crate::gpu::pod::{as_bytes, Pod};
use crate::gpu::{shaders, GpuContext, Owned};

/// The push constants `Push` of shaders/panel.frag, member for member (tested).
#[derive(Debug, Clone, Copy)]
#[repr(C)]
struct PanelPush {
    /// Destination rectangle in window pixels: x, y, width, height.
    rect: [f32; 4],
}

// SAFETY: repr(C), four f32s: no padding, no pointers.
unsafe impl Pod for PanelPush {}

/// How a source's pixels reach the destination.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PanelMode {
    /// Encoded values, replacing the destination.
    Encoded,
    /// Linear-light samples of an sRGB image, encoded, replacing the destination.
    Linear,
    /// Encoded values with straight alpha over the destination (text, markers).
    Overlay,
}

/// A destination rectangle in window pixels.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rect {
    pub x: f32,
    pub y: f32,
    pub width: f32,
    pub height: f32,
}

impl Rect {
    pub fn new(x: f32, y: f32, width: f32, height: f32) -> Self {
        Rect {
            x,
            y,
            width,
            height,
        }
    }

    /// Whether window pixel position (x, y) lies inside.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.x as f64
            && y >= self.y as f64
            && x < (self.x + self.width) as f64
            && y < (self.y + self.height) as f64
    }

    /// Whether it covers at least one pixel.
    pub fn is_empty(&self) -> bool {
        self.width < 1.0 || self.height < 1.0
    }
}

/// Pipelines, sampler and descriptor sets of the compositor.
pub struct Compositor {
    pipelines: [Owned<vk::Pipeline>; 3],
    layout: Owned<vk::PipelineLayout>,
    pool: Owned<vk::DescriptorPool>,
    set_layout: Owned<vk::DescriptorSetLayout>,
    sampler: Owned<vk::Sampler>,
}

/// Most descriptor sets alive between two resets.
const MAX_SETS: u32 = 16;

impl Compositor {
    /// Creates the compositor for destinations of `format`.
    pub fn new(ctx: &GpuContext, format: vk::Format) -> Result<Self> {
        let sampler = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        let sampler = pipeline::sampler(ctx, &sampler, "panel sampler")?;
        let bindings = [vk::DescriptorSetLayoutBinding::default()
            .binding(0)
            .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::FRAGMENT)];
        let set_layout = pipeline::set_layout(ctx, &bindings, "panel set layout")?;
        let sizes = [vk::DescriptorPoolSize::default()
            .ty(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .descriptor_count(MAX_SETS)];
        let pool = pipeline::descriptor_pool(ctx, MAX_SETS, &sizes, "panel descriptors")?;
        let push = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::FRAGMENT)
            .size(std::mem::size_of::<PanelPush>() as u32)];
        let layout = pipeline::pipeline_layout(ctx, &[*set_layout], &push, "panel layout")?;
        let vert = shaders::module(ctx, shaders::FULLSCREEN_VERT, "fullscreen.vert")?;
        let frag = shaders::module(ctx, shaders::PANEL_FRAG, "panel.frag")?;
        let make = |i: usize, blend: Blend, encode: u32| {
            let constants = [encode];
            let desc = PipelineDesc {
                blend,
                frag_constants: &constants,
                ..PipelineDesc::fullscreen(*layout, *vert, *frag, format)
            };
            graphics_pipeline(ctx, &desc, &format!("panel pipeline {i}"))
        };
        let pipelines = [
            make(0, Blend::Replace, 0)?,
            make(1, Blend::Replace, 1)?,
            make(2, Blend::Alpha, 0)?,
        ];
        Ok(Compositor {
            pipelines,
            layout,
            pool,
            set_layout,
            sampler,
        })
    }

    /// A descriptor set that samples `view` (in `SHADER_READ_ONLY_OPTIMAL`). Valid until the
    /// next [`Compositor::reset`].
    pub fn source(&self, ctx: &GpuContext, view: vk::ImageView) -> Result<vk::DescriptorSet> {
        // The pool is sized for MAX_SETS sets between resets.
        let set = pipeline::allocate_sets(ctx, *self.pool, &[*self.set_layout])?[0];
        let image = [vk::DescriptorImageInfo::default()
            .sampler(*self.sampler)
            .image_view(view)
            .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)];
        let write = [vk::WriteDescriptorSet::default()
            .dst_set(set)
            .dst_binding(0)
            .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .image_info(&image)];
        // SAFETY: the set is new and unused.
        unsafe { ctx.device.update_descriptor_sets(&write, &[]) };
        Ok(set)
    }

    /// Frees every set from [`Compositor::source`]; no pending frame may use them.
    pub fn reset(&self, ctx: &GpuContext) -> Result<()> {
        // SAFETY: callers guarantee the sets are unused.
        unsafe {
            ctx.device
                .reset_descriptor_pool(*self.pool, vk::DescriptorPoolResetFlags::empty())
        }
        .vk("vkResetDescriptorPool")?;
        Ok(())
    }

    /// Records a draw of `set`'s image into `rect` of the current rendering instance, clipped
    /// to `bounds` (the attachment's extent).
    pub fn draw(
        &self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        set: vk::DescriptorSet,
        rect: Rect,
        bounds: vk::Extent2D,
        mode: PanelMode,
    ) {
        self.draw_part(ctx, cmd, set, rect, rect, bounds, mode);
    }

    /// [`Compositor::draw`] restricted to the part `clip` of `rect`: only those pixels are
    /// shaded (a sparse overlay costs what it covers, not the whole window).
    #[allow(clippy::too_many_arguments)]
    pub fn draw_part(
        &self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        set: vk::DescriptorSet,
        rect: Rect,
        clip: Rect,
        bounds: vk::Extent2D,
        mode: PanelMode,
    ) {
        let x0 = rect.x.max(clip.x).max(0.0);
        let y0 = rect.y.max(clip.y).max(0.0);
        let x1 = (rect.x + rect.width)
            .min(clip.x + clip.width)
            .min(bounds.width as f32);
        let y1 = (rect.y + rect.height)
            .min(clip.y + clip.height)
            .min(bounds.height as f32);
        if x1 - x0 < 1.0 || y1 - y0 < 1.0 {
            return;
        }
        let pipeline = *self.pipelines[match mode {
            PanelMode::Encoded => 0,
            PanelMode::Linear => 1,
            PanelMode::Overlay => 2,
        }];
        let viewport = [vk::Viewport {
            x: rect.x,
            y: rect.y,
            width: rect.width,
            height: rect.height,
            min_depth: 0.0,
            max_depth: 1.0,
        }];
        let scissor = [vk::Rect2D {
            offset: vk::Offset2D {
                x: x0.floor() as i32,
                y: y0.floor() as i32,
            },
            extent: vk::Extent2D {
                width: (x1.ceil() - x0.floor()) as u32,
                height: (y1.ceil() - y0.floor()) as u32,
            },
        }];
        let push = PanelPush {
            rect: [rect.x, rect.y, rect.width, rect.height],
        };
        let d = &ctx.device;
        // SAFETY: recording inside a rendering instance of the compositor's format; the set
        // is valid (not reset since it was made).
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
            d.cmd_set_viewport(cmd, 0, &viewport);
            d.cmd_set_scissor(cmd, 0, &scissor);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                *self.layout,
                0,
                &[set],
                &[],
            );
            d.cmd_push_constants(
                cmd,
                *self.layout,
                vk::ShaderStageFlags::FRAGMENT,
                0,
                as_bytes(&[push]),
            );
            d.cmd_draw(cmd, 3, 1, 0, 0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_constants_match_the_glsl_block() {
        let glsl = include_str!("../../shaders/panel.frag");
        let rust = vec![(
            "rect".to_string(),
            std::mem::offset_of!(PanelPush, rect),
            16,
        )];
        assert_eq!(crate::gpu::pod::glsl_block(glsl, "uniform Push"), rust);
    }
}
