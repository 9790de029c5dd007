//! Frames in flight: a ring of command buffers, each with the fence of its last submission and
//! the semaphore its swapchain image arrives on, so the CPU records frame k+1 while the GPU
//! runs frame k, with no `vkDeviceWaitIdle` per frame.
//!
//! Teardown (in `Drop`): wait for every fence → command buffers; the fences and semaphores
//! free themselves after.

use ash::vk;

use super::context::GpuContext;
use super::owned::{Owned, OwnedResult};
use crate::error::{Result, VkContext};

struct Slot {
    cmd: vk::CommandBuffer,
    /// Signalled when the slot's last submission completed (created signalled).
    fence: Owned<vk::Fence>,
    /// Signalled by the swapchain when the image acquired for this frame is ready.
    image_available: Owned<vk::Semaphore>,
}

/// The frame being recorded: its command buffer and image-available semaphore.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    pub cmd: vk::CommandBuffer,
    pub image_available: vk::Semaphore,
    /// Position of this frame's slot in the ring (for per-slot resources of the caller).
    pub slot: usize,
}

/// A ring of `n` frames in flight.
pub struct Frames {
    slots: Vec<Slot>,
    current: usize,
    recording: bool,
    ctx: GpuContext,
}

impl Frames {
    /// Creates `n` (≥ 1) slots; every fence starts signalled, so the first `begin` never waits.
    pub fn new(ctx: &GpuContext, n: usize) -> Result<Self> {
        let mut frames = Frames {
            slots: Vec::new(),
            current: 0,
            recording: false,
            ctx: ctx.clone(),
        };
        let d = &ctx.device;
        for i in 0..n.max(1) {
            let signalled = vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED);
            // SAFETY: valid device and create infos.
            let fence = unsafe { d.create_fence(&signalled, None) }
                .vk("vkCreateFence")
                .owned(ctx)?;
            // SAFETY: as above.
            let image_available =
                unsafe { d.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                    .vk("vkCreateSemaphore")
                    .owned(ctx)?;
            let alloc = vk::CommandBufferAllocateInfo::default()
                .command_pool(ctx.command_pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            // SAFETY: valid pool; the buffer joins a slot (and is freed with the ring) at once.
            let cmd =
                unsafe { d.allocate_command_buffers(&alloc) }.vk("vkAllocateCommandBuffers")?[0];
            ctx.name(cmd, &format!("frame {i}"));
            ctx.name(*fence, &format!("frame {i} done"));
            ctx.name(*image_available, &format!("frame {i} image available"));
            frames.slots.push(Slot {
                cmd,
                fence,
                image_available,
            });
        }
        Ok(frames)
    }

    /// Number of slots.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Always false: a ring has at least one slot.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Waits until the next slot's previous frame completed and begins recording its command
    /// buffer.
    pub fn begin(&mut self, ctx: &GpuContext) -> Result<Frame> {
        let slot = &mut self.slots[self.current];
        let d = &ctx.device;
        // SAFETY: the fence belongs to this device; after the wait the command buffer is no
        // longer in use.
        unsafe {
            d.wait_for_fences(&[*slot.fence], true, u64::MAX)
                .vk("vkWaitForFences")?;
            d.reset_command_buffer(slot.cmd, vk::CommandBufferResetFlags::empty())
                .vk("vkResetCommandBuffer")?;
            d.begin_command_buffer(
                slot.cmd,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .vk("vkBeginCommandBuffer")?;
        }
        self.recording = true;
        Ok(Frame {
            cmd: slot.cmd,
            image_available: *slot.image_available,
            slot: self.current,
        })
    }

    /// Ends and submits the frame being recorded, waiting on `wait` (semaphore, stage) and
    /// signalling `signal`; moves on to the next slot without waiting.
    pub fn submit(
        &mut self,
        ctx: &GpuContext,
        wait: &[(vk::Semaphore, vk::PipelineStageFlags2)],
        signal: &[vk::Semaphore],
    ) -> Result<()> {
        let slot = &self.slots[self.current];
        let d = &ctx.device;
        let waits: Vec<_> = wait
            .iter()
            .map(|&(semaphore, stage)| {
                vk::SemaphoreSubmitInfo::default()
                    .semaphore(semaphore)
                    .stage_mask(stage)
            })
            .collect();
        let signals: Vec<_> = signal
            .iter()
            .map(|&semaphore| {
                vk::SemaphoreSubmitInfo::default()
                    .semaphore(semaphore)
                    .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            })
            .collect();
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(slot.cmd)];
        let submit = [vk::SubmitInfo2::default()
            .wait_semaphore_infos(&waits)
            .command_buffer_infos(&cmds)
            .signal_semaphore_infos(&signals)];
        self.recording = false;
        // SAFETY: the buffer is recording (begin) and its fence is signalled and unused.
        unsafe {
            d.end_command_buffer(slot.cmd).vk("vkEndCommandBuffer")?;
            d.reset_fences(&[*slot.fence]).vk("vkResetFences")?;
            d.queue_submit2(ctx.queue, &submit, *slot.fence)
                .vk("vkQueueSubmit2")?;
        }
        self.current = (self.current + 1) % self.slots.len();
        Ok(())
    }

    /// Waits for every submitted frame.
    pub fn wait_all(&mut self, ctx: &GpuContext) -> Result<()> {
        let fences: Vec<_> = self.slots.iter().map(|s| *s.fence).collect();
        // SAFETY: fences of this device.
        unsafe { ctx.device.wait_for_fences(&fences, true, u64::MAX) }.vk("vkWaitForFences")?;
        Ok(())
    }
}

impl Drop for Frames {
    fn drop(&mut self) {
        let ctx = self.ctx.clone();
        if self.recording {
            // SAFETY: a recording buffer is not pending; ending it makes it freeable.
            let _ = unsafe { ctx.device.end_command_buffer(self.slots[self.current].cmd) };
        }
        let _ = self.wait_all(&ctx);
        let cmds: Vec<_> = self.slots.iter().map(|s| s.cmd).collect();
        if !cmds.is_empty() {
            // SAFETY: every submission completed (waited above); fences and semaphores follow
            // with the slots.
            unsafe { ctx.device.free_command_buffers(ctx.command_pool, &cmds) };
        }
    }
}
