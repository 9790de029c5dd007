//! The scene pass: a 3-D view of the point cloud with the cameras, the reference optical axis,
//! the plane normal and the refocus plane, drawn by its own pipelines (separate from the
//! refocus pass) into a caller-owned [`SceneTarget`].
//!
//! Draw order inside one rendering instance (reverse Z: depth cleared to 0, test `GREATER_OR_
//! EQUAL`, infinite far plane, see [`crate::passes::raster::Projection`]):
//! 1. the cloud's points, depth-tested and depth-writing;
//! 2. lines (camera frustums, optical axis, normal, the quad's outline) and larger points
//!    (camera centres), depth-tested and writing;
//! 3. the plane quad, alpha-blended, depth-tested against everything opaque, no depth write —
//!    so points behind it show through tinted and points in front hide it;
//! 4. markers (picked points) as large points with the depth test passing always, so a pick is
//!    visible wherever it is.
//!
//! Colours are linear light with straight alpha ([`ColourVertex`]); the target is an sRGB image,
//! so blending happens in linear light and the hardware encodes.
//!
//! The cloud is the expensive part (hundreds of thousands of points) and changes only with
//! the view; the overlay changes with every plane move. So step 1 renders into a cached cloud
//! layer (colour and depth) only when the caller says the view changed, and every frame starts
//! by copying that layer into the target and draws steps 2–4 over it, depth-tested against
//! the cloud's depth.
//!
//! The cloud is uploaded once ([`ScenePass::set_cloud`]); the small overlay geometry that
//! changes with the plane and the aperture is written per frame into one buffer per frame slot
//! ([`ScenePass::record`]'s `slot`), so a frame never overwrites what an earlier frame in flight
//! still reads.
//!
//! Everything frees itself when the pass is dropped, in field order: overlay buffers → cloud
//! buffer → pipelines → layout.

use ash::vk;

use crate::error::{Error, Result};
use image::RgbaImage;

use crate::gpu::commands::{
    begin_rendering, format_barrier, record_readback, stage, ImageReadback, ImageTransition,
    Submission,
};
use crate::gpu::pipeline::{self, graphics_pipeline, Blend, DepthTest, PipelineDesc};
use crate::gpu::pod::{as_bytes, Pod};
use crate::gpu::resources::{Buffer, Image, ImageDesc};
use crate::gpu::{shaders, GpuContext, Owned};
use crate::scene::ColourVertex;

/// Colour format of scene targets (linear blending, encoded storage).
pub const SCENE_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;
const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
const VERTEX_BYTES: u64 = std::mem::size_of::<ColourVertex>() as u64;

// SAFETY: repr(C), seven f32s (28 bytes, tested in `scene`): no padding, no pointers.
unsafe impl Pod for ColourVertex {}
const PUSH_BYTES: u32 = std::mem::size_of::<ScenePush>() as u32;

/// The push constants `Push` of shaders/scene.vert, member for member (tested).
#[derive(Debug, Clone, Copy)]
#[repr(C)]
struct ScenePush {
    /// Column-major clip-from-world matrix (reverse Z).
    clip_from_world: [f32; 16],
    /// Point diameter in pixels, within the device's range.
    point_size: f32,
}

// SAFETY: repr(C), seventeen f32s: no padding, no pointers.
unsafe impl Pod for ScenePush {}

/// The geometry that changes with the focus, the aperture and the picks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SceneOverlay {
    /// Pairs of vertices.
    pub lines: Vec<ColourVertex>,
    /// Triples of vertices, alpha-blended (the plane quad).
    pub triangles: Vec<ColourVertex>,
    /// Points drawn like the cloud's but larger (camera centres), depth-tested.
    pub points: Vec<ColourVertex>,
    /// Large points drawn over everything (picks).
    pub markers: Vec<ColourVertex>,
}

impl SceneOverlay {
    fn vertex_count(&self) -> usize {
        self.lines.len() + self.triangles.len() + self.points.len() + self.markers.len()
    }
}

/// How to draw one frame of the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneView {
    /// Column-major clip-from-world matrix (reverse Z).
    pub clip_from_world: [f32; 16],
    /// Diameter of cloud points in pixels.
    pub point_size: f32,
    /// Diameter of markers in pixels.
    pub marker_size: f32,
}

/// Colour (sRGB) and depth images of one scene view, and the cached cloud layer.
pub struct SceneTarget {
    pub width: u32,
    pub height: u32,
    pub color: Image,
    pub depth: Image,
    cloud_color: Image,
    cloud_depth: Image,
    /// Whether the cloud layer holds the cloud as last drawn.
    cloud_valid: bool,
}

impl SceneTarget {
    /// Creates the images; the colour image can be sampled (a window draws it into its panel)
    /// and copied (screenshots, tests).
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Result<Self> {
        let (w, h) = (width.max(1), height.max(1));
        let attach = vk::ImageUsageFlags::COLOR_ATTACHMENT;
        let depth_attach = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
        let src = vk::ImageUsageFlags::TRANSFER_SRC;
        let dst = vk::ImageUsageFlags::TRANSFER_DST;
        let specs = [
            (
                SCENE_FORMAT,
                attach | vk::ImageUsageFlags::SAMPLED | src | dst,
                "scene colour",
            ),
            (DEPTH_FORMAT, depth_attach | dst, "scene depth"),
            (SCENE_FORMAT, attach | src, "scene cloud layer"),
            (DEPTH_FORMAT, depth_attach | src, "scene cloud depth"),
        ];
        let made = specs
            .into_iter()
            .map(|(format, usage, name)| {
                Image::new(ctx, ImageDesc::new_2d(format, w, h, usage), &[format], name)
            })
            .collect::<Result<Vec<Image>>>()?;
        let mut it = made.into_iter();
        let mut next = || it.next().expect("four images made above");
        Ok(SceneTarget {
            width: w,
            height: h,
            color: next(),
            depth: next(),
            cloud_color: next(),
            cloud_depth: next(),
            cloud_valid: false,
        })
    }

    /// Reads the colour image back (sRGB-encoded RGBA, alpha set to opaque), waiting for the
    /// GPU. `layout` is where the last use left the image; it is put back there.
    pub fn read(&self, ctx: &GpuContext, layout: stage::End) -> Result<RgbaImage> {
        let (w, h) = (self.width, self.height);
        let mut readback = Buffer::readback(ctx, w as u64 * h as u64 * 4, "scene readback")?;
        Submission::new(ctx, "scene readback")?.run(ctx, |d, cmd| {
            let copy = ImageReadback {
                image: self.color.image,
                from: layout,
                then: Some(layout),
                width: w,
                height: h,
                buffer: readback.buffer,
                offset: 0,
            };
            record_readback(d, cmd, &copy);
        })?;
        readback.invalidate(ctx)?;
        let mut raw = readback.bytes_mut()[..(w * h * 4) as usize].to_vec();
        for p in raw.chunks_exact_mut(4) {
            p[3] = 255;
        }
        RgbaImage::from_raw(w, h, raw)
            .ok_or_else(|| Error::Internal("scene readback size mismatch".into()))
    }
}

/// Pipelines and vertex buffers of the scene view.
pub struct ScenePass {
    overlay: Vec<Option<Buffer>>,
    cloud: Option<Buffer>,
    cloud_count: u32,
    points: Owned<vk::Pipeline>,
    lines: Owned<vk::Pipeline>,
    quad: Owned<vk::Pipeline>,
    markers: Owned<vk::Pipeline>,
    layout: Owned<vk::PipelineLayout>,
    max_point_size: f32,
}

impl ScenePass {
    /// Creates the pipelines, with `slots` overlay buffers (one per frame in flight).
    pub fn new(ctx: &GpuContext, slots: usize) -> Result<Self> {
        let push = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::VERTEX)
            .size(PUSH_BYTES)];
        let layout = pipeline::pipeline_layout(ctx, &[], &push, "scene layout")?;
        let vert = shaders::module(ctx, shaders::SCENE_VERT, "scene.vert")?;
        let frag = shaders::module(ctx, shaders::SCENE_FRAG, "scene.frag")?;
        let bindings = [vk::VertexInputBindingDescription::default()
            .binding(0)
            .stride(VERTEX_BYTES as u32)
            .input_rate(vk::VertexInputRate::VERTEX)];
        let attributes = [
            vk::VertexInputAttributeDescription::default()
                .location(0)
                .format(vk::Format::R32G32B32_SFLOAT)
                .offset(0),
            vk::VertexInputAttributeDescription::default()
                .location(1)
                .format(vk::Format::R32G32B32A32_SFLOAT)
                .offset(12),
        ];
        let depth = |compare, write| {
            Some(DepthTest {
                format: DEPTH_FORMAT,
                compare,
                write,
            })
        };
        let base = PipelineDesc {
            layout: *layout,
            vert: *vert,
            frag: *frag,
            color_format: SCENE_FORMAT,
            topology: vk::PrimitiveTopology::POINT_LIST,
            blend: Blend::Replace,
            color_write: true,
            depth: depth(vk::CompareOp::GREATER_OR_EQUAL, true),
            vertex_bindings: &bindings,
            vertex_attributes: &attributes,
            frag_constants: &[],
        };
        let lines = PipelineDesc {
            topology: vk::PrimitiveTopology::LINE_LIST,
            ..base
        };
        let quad = PipelineDesc {
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
            blend: Blend::Alpha,
            depth: depth(vk::CompareOp::GREATER_OR_EQUAL, false),
            ..base
        };
        let markers = PipelineDesc {
            depth: depth(vk::CompareOp::ALWAYS, false),
            ..base
        };
        let range = ctx.properties.limits.point_size_range;
        Ok(ScenePass {
            overlay: (0..slots.max(1)).map(|_| None).collect(),
            cloud: None,
            cloud_count: 0,
            points: graphics_pipeline(ctx, &base, "scene points")?,
            lines: graphics_pipeline(ctx, &lines, "scene lines")?,
            quad: graphics_pipeline(ctx, &quad, "scene plane quad")?,
            markers: graphics_pipeline(ctx, &markers, "scene markers")?,
            layout,
            max_point_size: if ctx.large_points { range[1] } else { 1.0 },
        })
    }

    /// Replaces the point cloud. The GPU must not be using the old one (call it before the
    /// first frame, or after waiting for the frames in flight).
    pub fn set_cloud(&mut self, ctx: &GpuContext, points: &[ColourVertex]) -> Result<()> {
        self.cloud = None;
        self.cloud_count = 0;
        if points.is_empty() {
            return Ok(());
        }
        let bytes = as_bytes(points);
        let buffer = Buffer::with_bytes(
            ctx,
            bytes,
            vk::BufferUsageFlags::VERTEX_BUFFER,
            "scene cloud",
        )?;
        self.cloud = Some(buffer);
        self.cloud_count = points.len() as u32;
        Ok(())
    }

    /// The largest point size the device draws (1 without `largePoints`).
    pub fn max_point_size(&self) -> f32 {
        self.max_point_size
    }

    /// Records the scene into `target`: the cloud seen through `view` (re-rendered into the
    /// cached layer when `cloud_changed` or the layer is new, else copied from it), then
    /// `overlay` over it. `slot` picks the overlay buffer: the caller guarantees that the
    /// previous frame that used `slot` has completed (frames in flight). Leaves the colour image
    /// in `COLOR_ATTACHMENT_OPTIMAL`; the caller adds the barrier for its next use.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        slot: usize,
        target: &mut SceneTarget,
        view: &SceneView,
        overlay: &SceneOverlay,
        cloud_changed: bool,
    ) -> Result<()> {
        let overlay_buffer = self.write_overlay(ctx, slot, overlay)?;
        let d = &ctx.device;
        let extent = vk::Extent2D {
            width: target.width,
            height: target.height,
        };
        let push = |size: f32| ScenePush {
            clip_from_world: view.clip_from_world,
            point_size: size.clamp(1.0, self.max_point_size),
        };
        let draw =
            |pipeline: vk::Pipeline, buffer: vk::Buffer, first: usize, count: usize, size| {
                if count == 0 {
                    return;
                }
                // SAFETY: recording inside a rendering instance; the buffer holds `first + count`
                // vertices.
                unsafe {
                    d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
                    d.cmd_push_constants(
                        cmd,
                        *self.layout,
                        vk::ShaderStageFlags::VERTEX,
                        0,
                        as_bytes(&[push(size)]),
                    );
                    d.cmd_bind_vertex_buffers(cmd, 0, &[buffer], &[0]);
                    d.cmd_draw(cmd, count as u32, 1, first as u32, 0);
                }
            };
        let barrier = |image: &Image, from, to| transition(d, cmd, image, from, to);

        // 1. The cloud layer, when the view changed.
        if cloud_changed || !target.cloud_valid {
            barrier(&target.cloud_color, stage::DISCARD, stage::COLOR_WRITE);
            barrier(&target.cloud_depth, stage::DISCARD, stage::DEPTH_WRITE);
            begin_rendering(
                d,
                cmd,
                extent,
                target.cloud_color.views[0],
                vk::AttachmentLoadOp::CLEAR,
                Some((target.cloud_depth.views[0], 0.0)),
            );
            if let Some(cloud) = &self.cloud {
                draw(
                    *self.points,
                    cloud.buffer,
                    0,
                    self.cloud_count as usize,
                    view.point_size,
                );
            }
            // SAFETY: inside the rendering instance begun above.
            unsafe { d.cmd_end_rendering(cmd) };
            barrier(&target.cloud_color, stage::COLOR_WRITE, stage::TRANSFER_SRC);
            barrier(&target.cloud_depth, stage::DEPTH_WRITE, stage::TRANSFER_SRC);
            target.cloud_valid = true;
        }

        // 2. Copy the layer into the target.
        copy_cloud_layer(d, cmd, target);

        // 3. The overlay over the cloud, depth-tested against it.
        begin_loaded(d, cmd, extent, target);
        let (nl, nt, np) = (
            overlay.lines.len(),
            overlay.triangles.len(),
            overlay.points.len(),
        );
        draw(*self.lines, overlay_buffer, 0, nl, 1.0);
        draw(
            *self.points,
            overlay_buffer,
            nl + nt,
            np,
            0.5 * view.marker_size,
        );
        draw(*self.quad, overlay_buffer, nl, nt, 1.0);
        draw(
            *self.markers,
            overlay_buffer,
            nl + nt + np,
            overlay.markers.len(),
            view.marker_size,
        );
        // SAFETY: inside the rendering instance begun above.
        unsafe { d.cmd_end_rendering(cmd) };
        Ok(())
    }

    /// Writes `overlay` into the slot's host-visible buffer (grown when too small).
    fn write_overlay(
        &mut self,
        ctx: &GpuContext,
        slot: usize,
        overlay: &SceneOverlay,
    ) -> Result<vk::Buffer> {
        let n = overlay.vertex_count();
        let slot_buffer = self
            .overlay
            .get_mut(slot)
            .ok_or_else(|| Error::Invalid(format!("scene pass has no frame slot {slot}")))?;
        let needed = (n.max(1) as u64) * VERTEX_BYTES;
        if slot_buffer.as_ref().map_or(true, |b| b.size < needed) {
            *slot_buffer = None;
            // Grow geometrically so a growing number of picks does not reallocate every frame.
            let size = needed.next_power_of_two().max(64 * VERTEX_BYTES);
            *slot_buffer = Some(Buffer::new(
                ctx,
                size,
                vk::BufferUsageFlags::VERTEX_BUFFER,
                true,
                &format!("scene overlay {slot}"),
            )?);
        }
        let buffer = slot_buffer.as_mut().expect("created above");
        let mut all = Vec::with_capacity(n);
        all.extend_from_slice(&overlay.lines);
        all.extend_from_slice(&overlay.triangles);
        all.extend_from_slice(&overlay.points);
        all.extend_from_slice(&overlay.markers);
        let bytes = as_bytes(&all);
        buffer.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
        Ok(buffer.buffer)
    }
}

/// One layout transition of a scene image (colour or depth, by its format).
fn transition(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    image: &Image,
    from: stage::End,
    to: stage::End,
) {
    let t = ImageTransition { from, to };
    format_barrier(d, cmd, image.image, image.desc.format, t);
}

/// Copies the cached cloud layer (colour and depth) into `target`'s images, leaving them ready
/// to draw over.
fn copy_cloud_layer(d: &ash::Device, cmd: vk::CommandBuffer, target: &SceneTarget) {
    let barrier = |image: &Image, from, to| transition(d, cmd, image, from, to);
    barrier(&target.color, stage::DISCARD, stage::TRANSFER_DST);
    barrier(&target.depth, stage::DISCARD, stage::TRANSFER_DST);
    let pairs = [
        (
            &target.cloud_color,
            &target.color,
            vk::ImageAspectFlags::COLOR,
        ),
        (
            &target.cloud_depth,
            &target.depth,
            vk::ImageAspectFlags::DEPTH,
        ),
    ];
    for (src, dst, aspect) in pairs {
        let layers = vk::ImageSubresourceLayers {
            aspect_mask: aspect,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        };
        let region = vk::ImageCopy {
            src_subresource: layers,
            src_offset: vk::Offset3D::default(),
            dst_subresource: layers,
            dst_offset: vk::Offset3D::default(),
            extent: vk::Extent3D {
                width: target.width,
                height: target.height,
                depth: 1,
            },
        };
        // SAFETY: recording outside a rendering instance; layouts set by the barriers.
        unsafe {
            d.cmd_copy_image(
                cmd,
                src.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst.image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
    }
    barrier(&target.color, stage::TRANSFER_DST, stage::COLOR_WRITE);
    barrier(&target.depth, stage::TRANSFER_DST, stage::DEPTH_WRITE);
}

/// Begins rendering into `target` keeping the colour and depth already there.
fn begin_loaded(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    extent: vk::Extent2D,
    target: &SceneTarget,
) {
    let color = [vk::RenderingAttachmentInfo::default()
        .image_view(target.color.views[0])
        .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
        .load_op(vk::AttachmentLoadOp::LOAD)
        .store_op(vk::AttachmentStoreOp::STORE)];
    let depth = vk::RenderingAttachmentInfo::default()
        .image_view(target.depth.views[0])
        .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
        .load_op(vk::AttachmentLoadOp::LOAD)
        .store_op(vk::AttachmentStoreOp::DONT_CARE);
    let area = vk::Rect2D {
        offset: vk::Offset2D::default(),
        extent,
    };
    let info = vk::RenderingInfo::default()
        .render_area(area)
        .layer_count(1)
        .color_attachments(&color)
        .depth_attachment(&depth);
    let viewport = [vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: extent.width as f32,
        height: extent.height as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    }];
    // SAFETY: recording outside a rendering instance; the attachments are in the layouts
    // named (the caller's barriers put them there).
    unsafe {
        d.cmd_begin_rendering(cmd, &info);
        d.cmd_set_viewport(cmd, 0, &viewport);
        d.cmd_set_scissor(cmd, 0, &[area]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::offset_of;

    #[test]
    fn push_constants_match_the_glsl_block() {
        let glsl = include_str!("../../shaders/scene.vert");
        let rust = vec![
            (
                "clip_from_world".to_string(),
                offset_of!(ScenePush, clip_from_world),
                64,
            ),
            (
                "point_size".to_string(),
                offset_of!(ScenePush, point_size),
                4,
            ),
        ];
        assert_eq!(crate::gpu::pod::glsl_block(glsl, "uniform Push"), rust);
        assert_eq!(PUSH_BYTES, 68);
    }
}
