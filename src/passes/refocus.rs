//! The refocus pass: a fullscreen fragment shader (`shaders/refocus.frag`) loops over the
//! views of a draw, warps each by its homography, takes one hardware-bilinear sample from the
//! view array texture, masks it, and adds weighted colour and weight into a float accumulation
//! target with additive blending; a resolve pass (`shaders/resolve.frag`) divides by the weight
//! sum into the output: RGBA8 sRGB (the attachment format encodes), RGBA8 UNORM (encoded
//! averaging) or RGBA32F (linear float for EXR).
//!
//! Views can be split over several draws (`views_per_draw`); additive blending makes the
//! result independent of the split up to float rounding.
//!
//! Destruction order: targets → warps buffer → submission → timestamps → pipelines → layouts
//! → descriptor pool → samplers.

use ash::vk;
use image::RgbaImage;

use super::texture::{LightFieldTexture, VIEW_SRGB, VIEW_UNORM};
use crate::error::{Error, Result};
use crate::gpu::commands::{
    begin_rendering, color_copy, image_barrier, stage, ImageTransition, Submission,
};
use crate::gpu::pipeline::{graphics_pipeline, PipelineDesc};
use crate::gpu::resources::{Buffer, Image, ImageDesc};
use crate::gpu::shaders;
use crate::gpu::timing::Timestamps;
use crate::gpu::GpuContext;
use crate::refocus::{Averaging, RefocusImage, RefocusPlan};

/// Bytes of one view's warp in the storage buffer (`ViewWarp` in refocus_interface.glsl).
const WARP_BYTES: usize = 64;
/// Bytes of the push constants (`RefocusPush` in refocus_interface.glsl).
const PUSH_BYTES: usize = 40;

/// What the resolve writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputFormat {
    /// 8-bit sRGB-encoded RGBA (PNG).
    Srgb8,
    /// 32-bit float RGBA in the averaging space (linear light for EXR).
    Float,
}

/// Per-render settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    pub averaging: Averaging,
    pub output: OutputFormat,
    /// Views per draw call; 0 = all views in one draw.
    pub views_per_draw: usize,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            averaging: Averaging::Linear,
            output: OutputFormat::Srgb8,
            views_per_draw: 0,
        }
    }
}

/// GPU times of one frame, from timestamp queries.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PassTimings {
    pub refocus_ms: f64,
    pub resolve_ms: f64,
}

/// A refocus result read back from the GPU.
#[derive(Debug, Clone)]
pub enum GpuImage {
    Srgb8(RgbaImage),
    Float(RefocusImage),
}

/// Output-size dependent resources.
struct Targets {
    width: u32,
    height: u32,
    accum: Image,
    /// RGBA8 with views [UNORM, SRGB].
    out8: Image,
    /// RGBA32F.
    outf: Image,
    readback: Buffer,
}

impl Targets {
    fn new(ctx: &GpuContext, width: u32, height: u32, accum_format: vk::Format) -> Result<Self> {
        let color = vk::ImageUsageFlags::COLOR_ATTACHMENT;
        let accum = Image::new(
            ctx,
            ImageDesc::new_2d(
                accum_format,
                width,
                height,
                color | vk::ImageUsageFlags::SAMPLED,
            ),
            &[accum_format],
            "accumulation target",
        )?;
        let mut desc8 = ImageDesc::new_2d(
            vk::Format::R8G8B8A8_UNORM,
            width,
            height,
            color | vk::ImageUsageFlags::TRANSFER_SRC,
        );
        desc8.mutable_format = true;
        let out8 = match Image::new(
            ctx,
            desc8,
            &[vk::Format::R8G8B8A8_UNORM, vk::Format::R8G8B8A8_SRGB],
            "refocus output (8-bit)",
        ) {
            Ok(i) => i,
            Err(e) => {
                accum.destroy(ctx);
                return Err(e);
            }
        };
        let outf = match Image::new(
            ctx,
            ImageDesc::new_2d(
                vk::Format::R32G32B32A32_SFLOAT,
                width,
                height,
                color | vk::ImageUsageFlags::TRANSFER_SRC,
            ),
            &[vk::Format::R32G32B32A32_SFLOAT],
            "refocus output (float)",
        ) {
            Ok(i) => i,
            Err(e) => {
                accum.destroy(ctx);
                out8.destroy(ctx);
                return Err(e);
            }
        };
        let readback = Buffer::new(
            ctx,
            width as u64 * height as u64 * 16,
            vk::BufferUsageFlags::TRANSFER_DST,
            true,
            "refocus readback",
        );
        match readback {
            Ok(readback) => Ok(Targets {
                width,
                height,
                accum,
                out8,
                outf,
                readback,
            }),
            Err(e) => {
                accum.destroy(ctx);
                out8.destroy(ctx);
                outf.destroy(ctx);
                Err(e)
            }
        }
    }

    fn destroy(self, ctx: &GpuContext) {
        self.accum.destroy(ctx);
        self.out8.destroy(ctx);
        self.outf.destroy(ctx);
        self.readback.destroy(ctx);
    }
}

/// Pipelines, descriptors and targets of the refocus pass for one light field texture.
pub struct RefocusPass {
    accum_format: vk::Format,
    objects: PassObjects,
    warps: Buffer,
    warp_capacity: usize,
    submission: Submission,
    timestamps: Option<Timestamps>,
    targets: Option<Targets>,
}

fn pick_accum_format(ctx: &GpuContext) -> Result<vk::Format> {
    let need = vk::FormatFeatureFlags::COLOR_ATTACHMENT
        | vk::FormatFeatureFlags::COLOR_ATTACHMENT_BLEND
        | vk::FormatFeatureFlags::SAMPLED_IMAGE;
    for f in [
        vk::Format::R32G32B32A32_SFLOAT,
        vk::Format::R16G16B16A16_SFLOAT,
    ] {
        // SAFETY: valid physical device.
        let props = unsafe {
            ctx.instance
                .get_physical_device_format_properties(ctx.physical, f)
        };
        if props.optimal_tiling_features.contains(need) {
            return Ok(f);
        }
    }
    Err(Error::Vulkan(format!(
        "{} cannot blend into a float colour attachment",
        ctx.info.name
    )))
}

impl RefocusPass {
    /// Creates the pass for `texture` (the warp buffer holds one entry per layer).
    pub fn new(ctx: &GpuContext, texture: &LightFieldTexture) -> Result<Self> {
        let accum_format = pick_accum_format(ctx)?;
        let d = &ctx.device;
        // Build step by step; `PassObjects::destroy` frees what exists if a step fails.
        let mut b = PassObjects::default();
        let r = (|| -> Result<()> {
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
            // SAFETY: valid device and create infos throughout this block.
            unsafe {
                b.sampler_linear = d.create_sampler(&sampler(vk::Filter::LINEAR), None)?;
                b.sampler_nearest = d.create_sampler(&sampler(vk::Filter::NEAREST), None)?;
                ctx.name(b.sampler_linear, "view sampler (bilinear)");
                ctx.name(b.sampler_nearest, "accumulation sampler (nearest)");
                let frag = vk::ShaderStageFlags::FRAGMENT;
                let accum_bindings = [
                    vk::DescriptorSetLayoutBinding::default()
                        .binding(0)
                        .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                        .descriptor_count(1)
                        .stage_flags(frag),
                    vk::DescriptorSetLayoutBinding::default()
                        .binding(1)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .descriptor_count(1)
                        .stage_flags(frag),
                ];
                b.accum_set_layout = d.create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&accum_bindings),
                    None,
                )?;
                let resolve_bindings = [vk::DescriptorSetLayoutBinding::default()
                    .binding(0)
                    .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                    .descriptor_count(1)
                    .stage_flags(frag)];
                b.resolve_set_layout = d.create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&resolve_bindings),
                    None,
                )?;
                let push = [vk::PushConstantRange::default()
                    .stage_flags(frag)
                    .offset(0)
                    .size(PUSH_BYTES as u32)];
                let accum_sets = [b.accum_set_layout];
                b.accum_layout = d.create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default()
                        .set_layouts(&accum_sets)
                        .push_constant_ranges(&push),
                    None,
                )?;
                let resolve_sets = [b.resolve_set_layout];
                b.resolve_layout = d.create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default().set_layouts(&resolve_sets),
                    None,
                )?;
                let sizes = [
                    vk::DescriptorPoolSize {
                        ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
                        descriptor_count: 2,
                    },
                    vk::DescriptorPoolSize {
                        ty: vk::DescriptorType::STORAGE_BUFFER,
                        descriptor_count: 1,
                    },
                ];
                b.descriptor_pool = d.create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default()
                        .max_sets(2)
                        .pool_sizes(&sizes),
                    None,
                )?;
                let layouts = [b.accum_set_layout, b.resolve_set_layout];
                let sets = d.allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default()
                        .descriptor_pool(b.descriptor_pool)
                        .set_layouts(&layouts),
                )?;
                b.accum_set = sets[0];
                b.resolve_set = sets[1];
            }
            let vert = shaders::module(ctx, shaders::FULLSCREEN_VERT, "fullscreen.vert")?;
            let modules = [
                Some(vert),
                shaders::module(ctx, shaders::REFOCUS_FRAG, "refocus.frag").ok(),
                shaders::module(ctx, shaders::RESOLVE_FRAG, "resolve.frag").ok(),
            ];
            let made = (|| -> Result<()> {
                let (Some(refocus), Some(resolve)) = (modules[1], modules[2]) else {
                    return Err(Error::Vulkan(
                        "cannot create the refocus shader modules".into(),
                    ));
                };
                b.accum_pipeline =
                    fullscreen_pipeline(ctx, b.accum_layout, vert, refocus, accum_format, true)?;
                ctx.name(b.accum_pipeline, "refocus accumulation pipeline");
                for (i, f) in [
                    vk::Format::R8G8B8A8_UNORM,
                    vk::Format::R8G8B8A8_SRGB,
                    vk::Format::R32G32B32A32_SFLOAT,
                ]
                .into_iter()
                .enumerate()
                {
                    b.resolve_pipelines[i] =
                        fullscreen_pipeline(ctx, b.resolve_layout, vert, resolve, f, false)?;
                    ctx.name(b.resolve_pipelines[i], &format!("resolve pipeline ({f:?})"));
                }
                Ok(())
            })();
            for m in modules.into_iter().flatten() {
                // SAFETY: pipelines keep their own copy of the code.
                unsafe { d.destroy_shader_module(m, None) };
            }
            made
        })();
        if let Err(e) = r {
            b.destroy(ctx);
            return Err(e);
        }
        let capacity = texture.layers as usize;
        let owned = Buffer::new(
            ctx,
            (capacity * WARP_BYTES) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            true,
            "view warps",
        )
        .and_then(|warps| match Submission::new(ctx, "refocus frame") {
            Ok(s) => Ok((warps, s)),
            Err(e) => {
                warps.destroy(ctx);
                Err(e)
            }
        })
        .and_then(|(warps, submission)| match Timestamps::new(ctx, 3) {
            Ok(t) => Ok((warps, submission, t)),
            Err(e) => {
                warps.destroy(ctx);
                submission.destroy(ctx);
                Err(e)
            }
        });
        let (warps, submission, timestamps) = match owned {
            Ok(x) => x,
            Err(e) => {
                b.destroy(ctx);
                return Err(e);
            }
        };
        Ok(RefocusPass {
            accum_format,
            objects: b,
            warps,
            warp_capacity: capacity,
            submission,
            timestamps,
            targets: None,
        })
    }

    /// The accumulation target's format (RGBA32F where the device blends it).
    pub fn accum_format(&self) -> vk::Format {
        self.accum_format
    }

    /// Renders `plan` and reads the result back.
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        texture: &LightFieldTexture,
        plan: &RefocusPlan,
        settings: &RenderSettings,
    ) -> Result<(GpuImage, Option<PassTimings>)> {
        let timings = self.frame(ctx, texture, plan, settings, true)?;
        let t = self
            .targets
            .as_mut()
            .ok_or_else(|| Error::Vulkan("no targets".into()))?;
        let (w, h) = (t.width, t.height);
        let bytes = t.readback.bytes_mut();
        let image = match settings.output {
            OutputFormat::Srgb8 => {
                let raw = bytes[..(w * h * 4) as usize].to_vec();
                GpuImage::Srgb8(
                    RgbaImage::from_raw(w, h, raw)
                        .ok_or_else(|| Error::Vulkan("readback size mismatch".into()))?,
                )
            }
            OutputFormat::Float => {
                let pixels = bytes[..(w * h * 16) as usize]
                    .chunks_exact(16)
                    .map(|c| {
                        let f = |i: usize| f32::from_ne_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                        [f(0), f(4), f(8), f(12)]
                    })
                    .collect();
                GpuImage::Float(RefocusImage {
                    width: w,
                    height: h,
                    averaging: settings.averaging,
                    pixels,
                })
            }
        };
        Ok((image, timings))
    }

    /// Renders `plan` without reading the image back (for timing).
    pub fn render_timed(
        &mut self,
        ctx: &GpuContext,
        texture: &LightFieldTexture,
        plan: &RefocusPlan,
        settings: &RenderSettings,
    ) -> Result<Option<PassTimings>> {
        self.frame(ctx, texture, plan, settings, false)
    }

    fn frame(
        &mut self,
        ctx: &GpuContext,
        texture: &LightFieldTexture,
        plan: &RefocusPlan,
        settings: &RenderSettings,
        readback: bool,
    ) -> Result<Option<PassTimings>> {
        if plan.views.len() > self.warp_capacity
            || plan
                .views
                .iter()
                .any(|v| v.index >= texture.layers as usize)
        {
            return Err(Error::Invalid(
                "the refocus plan does not belong to this light field texture".into(),
            ));
        }
        if (plan.width, plan.height) != (texture.width, texture.height) {
            return Err(Error::Invalid(format!(
                "plan output {}×{} differs from the views' {}×{}",
                plan.width, plan.height, texture.width, texture.height
            )));
        }
        let (w, h) = (plan.width, plan.height);
        if self.targets.as_ref().map(|t| (t.width, t.height)) != Some((w, h)) {
            if let Some(t) = self.targets.take() {
                t.destroy(ctx);
            }
            self.targets = Some(Targets::new(ctx, w, h, self.accum_format)?);
        }
        self.write_warps(plan);
        let Some(t) = self.targets.as_ref() else {
            return Err(Error::Vulkan("no targets".into()));
        };
        let d = &ctx.device;

        let view_image = match settings.averaging {
            Averaging::Linear => texture.image.views[VIEW_SRGB],
            Averaging::Encoded => texture.image.views[VIEW_UNORM],
        };
        let image_info = [vk::DescriptorImageInfo::default()
            .sampler(self.objects.sampler_linear)
            .image_view(view_image)
            .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)];
        let buffer_info = [vk::DescriptorBufferInfo::default()
            .buffer(self.warps.buffer)
            .offset(0)
            .range(vk::WHOLE_SIZE)];
        let accum_info = [vk::DescriptorImageInfo::default()
            .sampler(self.objects.sampler_nearest)
            .image_view(t.accum.views[0])
            .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)];
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_set(self.objects.accum_set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                .image_info(&image_info),
            vk::WriteDescriptorSet::default()
                .dst_set(self.objects.accum_set)
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .buffer_info(&buffer_info),
            vk::WriteDescriptorSet::default()
                .dst_set(self.objects.resolve_set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                .image_info(&accum_info),
        ];
        // SAFETY: the previous frame completed (Submission::run waits), so the sets are idle.
        unsafe { d.update_descriptor_sets(&writes, &[]) };

        let (out_image, out_view, resolve_pipeline) = match (settings.output, settings.averaging) {
            (OutputFormat::Srgb8, Averaging::Linear) => (
                t.out8.image,
                t.out8.views[1],
                self.objects.resolve_pipelines[1],
            ),
            (OutputFormat::Srgb8, Averaging::Encoded) => (
                t.out8.image,
                t.out8.views[0],
                self.objects.resolve_pipelines[0],
            ),
            (OutputFormat::Float, _) => (
                t.outf.image,
                t.outf.views[0],
                self.objects.resolve_pipelines[2],
            ),
        };
        let batch = if settings.views_per_draw == 0 {
            plan.views.len()
        } else {
            settings.views_per_draw
        };
        let m = plan.m.as_vec3();
        let view_size = [texture.width as f32, texture.height as f32];
        let extent = vk::Extent2D {
            width: w,
            height: h,
        };
        let ts = self.timestamps.as_ref();
        let all = vk::PipelineStageFlags2::ALL_COMMANDS;
        self.submission.run(ctx, |d, cmd| {
            if let Some(ts) = ts {
                ts.reset(d, cmd);
                ts.write(d, cmd, all, 0);
            }
            image_barrier(
                d,
                cmd,
                t.accum.image,
                1,
                ImageTransition {
                    from: stage::UNDEFINED,
                    to: stage::COLOR_WRITE,
                },
            );
            begin_rendering(
                d,
                cmd,
                extent,
                t.accum.views[0],
                vk::AttachmentLoadOp::CLEAR,
                None,
            );
            // SAFETY: recording inside a dynamic rendering instance with matching formats.
            unsafe {
                d.cmd_bind_pipeline(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.objects.accum_pipeline,
                );
                d.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.objects.accum_layout,
                    0,
                    &[self.objects.accum_set],
                    &[],
                );
                let mut first = 0usize;
                while first < plan.views.len() {
                    let count = batch.min(plan.views.len() - first);
                    let push =
                        push_bytes([m.x, m.y, m.z, 0.0], view_size, first as u32, count as u32);
                    d.cmd_push_constants(
                        cmd,
                        self.objects.accum_layout,
                        vk::ShaderStageFlags::FRAGMENT,
                        0,
                        &push,
                    );
                    d.cmd_draw(cmd, 3, 1, 0, 0);
                    first += count;
                }
                d.cmd_end_rendering(cmd);
            }
            if let Some(ts) = ts {
                ts.write(d, cmd, all, 1);
            }
            image_barrier(
                d,
                cmd,
                t.accum.image,
                1,
                ImageTransition {
                    from: stage::COLOR_WRITE,
                    to: stage::FRAGMENT_READ,
                },
            );
            image_barrier(
                d,
                cmd,
                out_image,
                1,
                ImageTransition {
                    from: stage::UNDEFINED,
                    to: stage::COLOR_WRITE,
                },
            );
            begin_rendering(
                d,
                cmd,
                extent,
                out_view,
                vk::AttachmentLoadOp::DONT_CARE,
                None,
            );
            // SAFETY: as above.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, resolve_pipeline);
                d.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.objects.resolve_layout,
                    0,
                    &[self.objects.resolve_set],
                    &[],
                );
                d.cmd_draw(cmd, 3, 1, 0, 0);
                d.cmd_end_rendering(cmd);
            }
            if let Some(ts) = ts {
                ts.write(d, cmd, all, 2);
            }
            if readback {
                image_barrier(
                    d,
                    cmd,
                    out_image,
                    1,
                    ImageTransition {
                        from: stage::COLOR_WRITE,
                        to: stage::TRANSFER_SRC,
                    },
                );
                let region = color_copy(0, w, h, 1);
                let to_host = [vk::MemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::COPY)
                    .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                    .dst_stage_mask(vk::PipelineStageFlags2::HOST)
                    .dst_access_mask(vk::AccessFlags2::HOST_READ)];
                // SAFETY: recording; the readback buffer holds w·h·16 bytes.
                unsafe {
                    d.cmd_copy_image_to_buffer(
                        cmd,
                        out_image,
                        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                        t.readback.buffer,
                        &[region],
                    );
                    d.cmd_pipeline_barrier2(
                        cmd,
                        &vk::DependencyInfo::default().memory_barriers(&to_host),
                    );
                }
            }
        })?;
        match &self.timestamps {
            Some(ts) => {
                let ms = ts.read_ms(ctx)?;
                Ok(Some(PassTimings {
                    refocus_ms: ms[0],
                    resolve_ms: ms[1],
                }))
            }
            None => Ok(None),
        }
    }

    fn write_warps(&mut self, plan: &RefocusPlan) {
        let bytes = self.warps.bytes_mut();
        for (dst, v) in bytes.chunks_exact_mut(WARP_BYTES).zip(&plan.views) {
            let a = v.warp.a.as_mat3();
            let b = v.warp.b.as_vec3();
            let values: [f32; 16] = [
                a.x_axis.x,
                a.x_axis.y,
                a.x_axis.z,
                v.index as f32,
                a.y_axis.x,
                a.y_axis.y,
                a.y_axis.z,
                0.0,
                a.z_axis.x,
                a.z_axis.y,
                a.z_axis.z,
                0.0,
                b.x,
                b.y,
                b.z,
                v.weight as f32,
            ];
            for (d, x) in dst.chunks_exact_mut(4).zip(values) {
                d.copy_from_slice(&x.to_ne_bytes());
            }
        }
    }

    /// Frees everything (see the module docs for the order).
    pub fn destroy(mut self, ctx: &GpuContext) {
        if let Some(t) = self.targets.take() {
            t.destroy(ctx);
        }
        self.warps.destroy(ctx);
        self.submission.destroy(ctx);
        if let Some(t) = self.timestamps.take() {
            t.destroy(ctx);
        }
        self.objects.destroy(ctx);
    }
}

/// The Vulkan objects of the pass that are plain handles (null until created). Destroying it
/// frees exactly those that exist, so a failed set-up leaks nothing.
#[derive(Default)]
struct PassObjects {
    sampler_linear: vk::Sampler,
    sampler_nearest: vk::Sampler,
    accum_set_layout: vk::DescriptorSetLayout,
    resolve_set_layout: vk::DescriptorSetLayout,
    accum_layout: vk::PipelineLayout,
    resolve_layout: vk::PipelineLayout,
    descriptor_pool: vk::DescriptorPool,
    accum_set: vk::DescriptorSet,
    resolve_set: vk::DescriptorSet,
    accum_pipeline: vk::Pipeline,
    /// Resolve pipelines for R8G8B8A8_UNORM, R8G8B8A8_SRGB, R32G32B32A32_SFLOAT.
    resolve_pipelines: [vk::Pipeline; 3],
}

impl PassObjects {
    fn destroy(self, ctx: &GpuContext) {
        let d = &ctx.device;
        // SAFETY: nothing uses these objects any more; destroying null handles is a no-op.
        unsafe {
            d.destroy_pipeline(self.accum_pipeline, None);
            for p in self.resolve_pipelines {
                d.destroy_pipeline(p, None);
            }
            d.destroy_pipeline_layout(self.accum_layout, None);
            d.destroy_pipeline_layout(self.resolve_layout, None);
            // Frees the sets allocated from it.
            d.destroy_descriptor_pool(self.descriptor_pool, None);
            d.destroy_descriptor_set_layout(self.accum_set_layout, None);
            d.destroy_descriptor_set_layout(self.resolve_set_layout, None);
            d.destroy_sampler(self.sampler_linear, None);
            d.destroy_sampler(self.sampler_nearest, None);
        }
    }
}

fn push_bytes(plane: [f32; 4], view_size: [f32; 2], first: u32, count: u32) -> [u8; PUSH_BYTES] {
    let mut out = [0u8; PUSH_BYTES];
    let floats = [
        plane[0],
        plane[1],
        plane[2],
        plane[3],
        view_size[0],
        view_size[1],
        1.0,
        1.0,
    ];
    for (i, f) in floats.iter().enumerate() {
        out[i * 4..i * 4 + 4].copy_from_slice(&f.to_ne_bytes());
    }
    out[32..36].copy_from_slice(&first.to_ne_bytes());
    out[36..40].copy_from_slice(&count.to_ne_bytes());
    out
}

/// A pipeline drawing one fullscreen triangle (no vertex input) into one colour attachment of
/// `format`, with additive blending when `additive`.
fn fullscreen_pipeline(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    vert: vk::ShaderModule,
    frag: vk::ShaderModule,
    format: vk::Format,
    additive: bool,
) -> Result<vk::Pipeline> {
    graphics_pipeline(
        ctx,
        &PipelineDesc {
            layout,
            vert,
            frag,
            color_format: format,
            additive,
            color_write: true,
            depth: None,
            vertex_bindings: &[],
            vertex_attributes: &[],
        },
    )
}
