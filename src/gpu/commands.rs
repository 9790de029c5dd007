//! Command recording helpers: one-shot submissions and synchronization2 image barriers.

use ash::vk;

use super::context::GpuContext;
use super::owned::{Owned, OwnedResult};
use super::resources::{color_range, range_of};
use crate::error::{Result, VkContext};

/// A primary command buffer and the fence of its submission, reused across frames.
pub struct Submission {
    pub cmd: vk::CommandBuffer,
    fence: Owned<vk::Fence>,
    ctx: GpuContext,
}

impl Submission {
    /// Allocates the command buffer and an unsignalled fence.
    pub fn new(ctx: &GpuContext, name: &str) -> Result<Self> {
        // SAFETY: valid device.
        let fence = unsafe {
            ctx.device
                .create_fence(&vk::FenceCreateInfo::default(), None)
        }
        .vk("vkCreateFence")
        .owned(ctx)?;
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(ctx.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: valid pool of this device.
        let cmd = unsafe { ctx.device.allocate_command_buffers(&info) }
            .vk("vkAllocateCommandBuffers")?[0];
        ctx.name(cmd, name);
        ctx.name(*fence, name);
        Ok(Submission {
            cmd,
            fence,
            ctx: ctx.clone(),
        })
    }

    /// Records with `record`, submits and waits for completion.
    pub fn run(
        &self,
        ctx: &GpuContext,
        record: impl FnOnce(&ash::Device, vk::CommandBuffer),
    ) -> Result<()> {
        let d = &ctx.device;
        // SAFETY: the previous submission of this buffer completed (run always waits).
        unsafe {
            d.reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())
                .vk("vkResetCommandBuffer")?;
            d.begin_command_buffer(
                self.cmd,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .vk("vkBeginCommandBuffer")?;
        }
        record(d, self.cmd);
        let cmd_infos = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
        let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmd_infos)];
        // SAFETY: recorded buffer, unsignalled fence; we wait before returning.
        unsafe {
            d.end_command_buffer(self.cmd).vk("vkEndCommandBuffer")?;
            d.queue_submit2(ctx.queue, &submit, *self.fence)
                .vk("vkQueueSubmit2")?;
            d.wait_for_fences(&[*self.fence], true, u64::MAX)
                .vk("vkWaitForFences")?;
            d.reset_fences(&[*self.fence]).vk("vkResetFences")?;
        }
        Ok(())
    }
}

impl Drop for Submission {
    fn drop(&mut self) {
        // SAFETY: run() waited for the last submission; the fence goes with the field.
        unsafe {
            self.ctx
                .device
                .free_command_buffers(self.ctx.command_pool, &[self.cmd])
        };
    }
}

/// A layout transition / execution + memory dependency on all layers of a colour image.
#[derive(Debug, Clone, Copy)]
pub struct ImageTransition {
    pub from: (vk::ImageLayout, vk::PipelineStageFlags2, vk::AccessFlags2),
    pub to: (vk::ImageLayout, vk::PipelineStageFlags2, vk::AccessFlags2),
}

/// Records one barrier on all `layers` layers of a colour image (niagara's `imageBarrier`,
/// synchronization2 form).
pub fn image_barrier(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    layers: u32,
    t: ImageTransition,
) {
    barrier(d, cmd, image, color_range(layers), t);
}

/// [`image_barrier`] over `levels` mip levels.
pub fn levels_barrier(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    layers: u32,
    levels: u32,
    t: ImageTransition,
) {
    let range = vk::ImageSubresourceRange {
        level_count: levels.max(1),
        ..color_range(layers)
    };
    barrier(d, cmd, image, range, t);
}

/// Records one barrier on a single-layer image of `format`: the depth aspect for depth formats,
/// colour otherwise.
pub fn format_barrier(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    format: vk::Format,
    t: ImageTransition,
) {
    barrier(d, cmd, image, range_of(format, 1), t);
}

fn barrier(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    range: vk::ImageSubresourceRange,
    t: ImageTransition,
) {
    let barrier = [vk::ImageMemoryBarrier2::default()
        .src_stage_mask(t.from.1)
        .src_access_mask(t.from.2)
        .old_layout(t.from.0)
        .dst_stage_mask(t.to.1)
        .dst_access_mask(t.to.2)
        .new_layout(t.to.0)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range)];
    // SAFETY: cmd is recording; the barrier references a valid image.
    unsafe {
        d.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().image_memory_barriers(&barrier),
        )
    };
}

/// Begins dynamic rendering into one colour attachment (and optionally a depth attachment,
/// cleared to `clear_depth` and stored, so a later pass can test against it) covering `extent`, and sets viewport and scissor
/// to it. `color_load` CLEAR clears colour to 0.
pub fn begin_rendering(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    extent: vk::Extent2D,
    color: vk::ImageView,
    color_load: vk::AttachmentLoadOp,
    depth: Option<(vk::ImageView, f32)>,
) {
    let layout = vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL;
    begin_rendering_in(d, cmd, extent, (color, layout), color_load, depth);
}

/// [`begin_rendering`] with the colour attachment in `layout` (e.g. `GENERAL` for an image
/// that is also a storage image).
pub fn begin_rendering_in(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    extent: vk::Extent2D,
    (color, layout): (vk::ImageView, vk::ImageLayout),
    color_load: vk::AttachmentLoadOp,
    depth: Option<(vk::ImageView, f32)>,
) {
    let attachment = [vk::RenderingAttachmentInfo::default()
        .image_view(color)
        .image_layout(layout)
        .load_op(color_load)
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue {
            color: vk::ClearColorValue { float32: [0.0; 4] },
        })];
    let depth_attachment = depth.map(|(view, clear)| {
        vk::RenderingAttachmentInfo::default()
            .image_view(view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: clear,
                    stencil: 0,
                },
            })
    });
    let area = vk::Rect2D {
        offset: vk::Offset2D { x: 0, y: 0 },
        extent,
    };
    let mut info = vk::RenderingInfo::default()
        .render_area(area)
        .layer_count(1)
        .color_attachments(&attachment);
    if let Some(d) = &depth_attachment {
        info = info.depth_attachment(d);
    }
    let viewport = [vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: extent.width as f32,
        height: extent.height as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    }];
    // SAFETY: recording outside a rendering instance; the attachments are in the layouts
    // named above (the callers' barriers put them there).
    unsafe {
        d.cmd_begin_rendering(cmd, &info);
        d.cmd_set_viewport(cmd, 0, &viewport);
        d.cmd_set_scissor(cmd, 0, &[area]);
    }
}

/// A buffer ↔ image copy of mip 0 of `layers` colour layers of a `width × height` image, the
/// buffer tightly packed from `offset` (layer after layer).
pub fn color_copy(offset: u64, width: u32, height: u32, layers: u32) -> vk::BufferImageCopy {
    level_copy(offset, (width, height), layers, 0)
}

/// [`color_copy`] into mip level `level` (`size` is that level's).
pub fn level_copy(
    offset: u64,
    (width, height): (u32, u32),
    layers: u32,
    level: u32,
) -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .buffer_offset(offset)
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: level,
            base_array_layer: 0,
            layer_count: layers,
        })
        .image_extent(vk::Extent3D {
            width,
            height,
            depth: 1,
        })
}

/// Common barrier endpoints.
pub mod stage {
    use ash::vk::{AccessFlags2 as A, ImageLayout as L, PipelineStageFlags2 as S};

    pub type End = (L, S, A);
    pub const UNDEFINED: End = (L::UNDEFINED, S::NONE, A::NONE);
    /// Contents discarded once everything earlier in the queue is done with the image: the
    /// write-after-read guard for an image rewritten every frame while the previous frame may
    /// still sample it (frames in flight).
    pub const DISCARD: End = (L::UNDEFINED, S::ALL_COMMANDS, A::NONE);
    /// A swapchain image just acquired: the submission waits for its semaphore at the colour
    /// output stage, and the transition chains after that wait.
    pub const ACQUIRED: End = (L::UNDEFINED, S::COLOR_ATTACHMENT_OUTPUT, A::NONE);
    /// Handed to the presentation engine (the frame's semaphore signal orders it).
    pub const PRESENT: End = (L::PRESENT_SRC_KHR, S::NONE, A::NONE);
    pub const TRANSFER_DST: End = (L::TRANSFER_DST_OPTIMAL, S::COPY, A::TRANSFER_WRITE);
    pub const TRANSFER_SRC: End = (L::TRANSFER_SRC_OPTIMAL, S::COPY, A::TRANSFER_READ);
    pub const FRAGMENT_READ: End = (
        L::SHADER_READ_ONLY_OPTIMAL,
        S::FRAGMENT_SHADER,
        A::SHADER_SAMPLED_READ,
    );
    /// Sampled by fragment or compute shaders.
    pub const SHADER_READ: End = (
        L::SHADER_READ_ONLY_OPTIMAL,
        S::from_raw(S::FRAGMENT_SHADER.as_raw() | S::COMPUTE_SHADER.as_raw()),
        A::SHADER_SAMPLED_READ,
    );
    /// Written (and read) as a depth attachment.
    pub const DEPTH_WRITE: End = (
        L::DEPTH_ATTACHMENT_OPTIMAL,
        S::from_raw(S::EARLY_FRAGMENT_TESTS.as_raw() | S::LATE_FRAGMENT_TESTS.as_raw()),
        A::from_raw(
            A::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw() | A::DEPTH_STENCIL_ATTACHMENT_READ.as_raw(),
        ),
    );
    /// Any use in `GENERAL` layout by attachments, shaders (sampled or storage) or copies:
    /// the accumulation image of the refocus pass, between its strategies and the resolve.
    pub const GENERAL_ANY: End = (
        L::GENERAL,
        S::from_raw(
            S::COLOR_ATTACHMENT_OUTPUT.as_raw()
                | S::FRAGMENT_SHADER.as_raw()
                | S::COMPUTE_SHADER.as_raw()
                | S::CLEAR.as_raw(),
        ),
        A::from_raw(
            A::COLOR_ATTACHMENT_WRITE.as_raw()
                | A::COLOR_ATTACHMENT_READ.as_raw()
                | A::SHADER_SAMPLED_READ.as_raw()
                | A::SHADER_STORAGE_READ.as_raw()
                | A::SHADER_STORAGE_WRITE.as_raw()
                | A::TRANSFER_WRITE.as_raw(),
        ),
    );
    pub const COLOR_WRITE: End = (
        L::COLOR_ATTACHMENT_OPTIMAL,
        S::COLOR_ATTACHMENT_OUTPUT,
        A::from_raw(A::COLOR_ATTACHMENT_WRITE.as_raw() | A::COLOR_ATTACHMENT_READ.as_raw()),
    );
}

/// Records one global memory barrier: everything `src` (stages, accesses) did before it is
/// available to `dst` after it.
pub fn memory_barrier(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
) {
    let barrier = [vk::MemoryBarrier2::default()
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1)];
    // SAFETY: recording outside a rendering instance.
    unsafe {
        d.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().memory_barriers(&barrier),
        )
    };
}

/// One colour image → buffer readback, recorded by [`record_readback`]: the only place the
/// crate records an image-to-buffer copy.
#[derive(Debug, Clone, Copy)]
pub struct ImageReadback {
    pub image: vk::Image,
    /// Where the image's last use left it.
    pub from: stage::End,
    /// Where the image goes after the copy (its next use), or None to leave it in
    /// TRANSFER_SRC.
    pub then: Option<stage::End>,
    pub width: u32,
    pub height: u32,
    pub buffer: vk::Buffer,
    /// Byte offset of the tightly packed rows in `buffer`.
    pub offset: u64,
}

/// Records `r`: transition to TRANSFER_SRC, copy layer 0 into the buffer, the optional onward
/// transition, and the barrier that makes the copy visible to the host once the submission's
/// fence has signalled. The caller sizes the buffer (width · height · texel size from
/// `offset`).
pub fn record_readback(d: &ash::Device, cmd: vk::CommandBuffer, r: &ImageReadback) {
    let to_copy = ImageTransition {
        from: r.from,
        to: stage::TRANSFER_SRC,
    };
    image_barrier(d, cmd, r.image, 1, to_copy);
    // SAFETY: recording outside a rendering instance; the image is in TRANSFER_SRC and the
    // caller guarantees the buffer holds the copy.
    unsafe {
        d.cmd_copy_image_to_buffer(
            cmd,
            r.image,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            r.buffer,
            &[color_copy(r.offset, r.width, r.height, 1)],
        )
    };
    host_read_barrier(d, cmd);
    if let Some(then) = r.then {
        let onward = ImageTransition {
            from: stage::TRANSFER_SRC,
            to: then,
        };
        image_barrier(d, cmd, r.image, 1, onward);
    }
}

/// Makes transfer writes (readback copies) visible to the host after the submission's fence.
pub fn host_read_barrier(d: &ash::Device, cmd: vk::CommandBuffer) {
    memory_barrier(
        d,
        cmd,
        (
            vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::TRANSFER_WRITE,
        ),
        (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
    );
}
