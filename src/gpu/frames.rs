//! Frames in flight: a ring of command buffers, each with the fence of its last submission and
//! the semaphore its swapchain image arrives on, so the CPU records frame k+1 while the GPU
//! runs frame k, with no `vkDeviceWaitIdle` per frame.
//!
//! Deferred release: what a frame's commands use (a buffer replaced mid-flight, an old
//! target after a resize) is handed to [`Frames::defer`] and freed the next time that frame's
//! slot is reused, i.e. after its fence signalled — never while the GPU may still read it.
//!
//! Teardown: wait for every fence → run every pending release → semaphores, fences, command
//! buffers.

use ash::vk;

use super::context::GpuContext;
use crate::error::{Result, VkContext};

/// A release to run once the frame that used the object has completed.
pub type Release = Box<dyn FnOnce(&GpuContext)>;

struct Slot {
    cmd: vk::CommandBuffer,
    /// Signalled when the slot's last submission completed (created signalled).
    fence: vk::Fence,
    /// Signalled by the swapchain when the image acquired for this frame is ready.
    image_available: vk::Semaphore,
    deferred: Vec<Release>,
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
}

impl Frames {
    /// Creates `n` (≥ 1) slots; every fence starts signalled, so the first `begin` never waits.
    pub fn new(ctx: &GpuContext, n: usize) -> Result<Self> {
        let mut frames = Frames {
            slots: Vec::new(),
            current: 0,
            recording: false,
        };
        let d = &ctx.device;
        for i in 0..n.max(1) {
            let alloc = vk::CommandBufferAllocateInfo::default()
                .command_pool(ctx.command_pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            // SAFETY: valid pool and create infos; each object is pushed (and so freed by
            // `destroy`) as soon as it exists.
            let made = unsafe {
                d.allocate_command_buffers(&alloc)
                    .vk("vkAllocateCommandBuffers")
                    .and_then(|cmds| {
                        let fence = d
                            .create_fence(
                                &vk::FenceCreateInfo::default()
                                    .flags(vk::FenceCreateFlags::SIGNALED),
                                None,
                            )
                            .vk("vkCreateFence");
                        let fence = match fence {
                            Ok(f) => f,
                            Err(e) => {
                                d.free_command_buffers(ctx.command_pool, &cmds);
                                return Err(e);
                            }
                        };
                        match d
                            .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
                            .vk("vkCreateSemaphore")
                        {
                            Ok(s) => Ok((cmds[0], fence, s)),
                            Err(e) => {
                                d.destroy_fence(fence, None);
                                d.free_command_buffers(ctx.command_pool, &cmds);
                                Err(e)
                            }
                        }
                    })
            };
            match made {
                Ok((cmd, fence, image_available)) => {
                    ctx.name(cmd, &format!("frame {i}"));
                    ctx.name(fence, &format!("frame {i} done"));
                    ctx.name(image_available, &format!("frame {i} image available"));
                    frames.slots.push(Slot {
                        cmd,
                        fence,
                        image_available,
                        deferred: Vec::new(),
                    });
                }
                Err(e) => {
                    frames.destroy(ctx);
                    return Err(e);
                }
            }
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

    /// Waits until the next slot's previous frame completed, runs its deferred releases and
    /// begins recording its command buffer.
    pub fn begin(&mut self, ctx: &GpuContext) -> Result<Frame> {
        let slot = &mut self.slots[self.current];
        let d = &ctx.device;
        // SAFETY: the fence belongs to this device; after the wait the command buffer and
        // everything the deferred releases free are no longer in use.
        unsafe {
            d.wait_for_fences(&[slot.fence], true, u64::MAX)
                .vk("vkWaitForFences")?;
            for release in slot.deferred.drain(..) {
                release(ctx);
            }
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
            image_available: slot.image_available,
            slot: self.current,
        })
    }

    /// Frees `release` once the frame being recorded has completed.
    pub fn defer(&mut self, release: Release) {
        self.slots[self.current].deferred.push(release);
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
            d.reset_fences(&[slot.fence]).vk("vkResetFences")?;
            d.queue_submit2(ctx.queue, &submit, slot.fence)
                .vk("vkQueueSubmit2")?;
        }
        self.current = (self.current + 1) % self.slots.len();
        Ok(())
    }

    /// Waits for every submitted frame and runs every pending release.
    pub fn wait_all(&mut self, ctx: &GpuContext) -> Result<()> {
        let fences: Vec<_> = self.slots.iter().map(|s| s.fence).collect();
        // SAFETY: fences of this device.
        unsafe { ctx.device.wait_for_fences(&fences, true, u64::MAX) }.vk("vkWaitForFences")?;
        // Oldest first: `current` is the slot submitted longest ago.
        let n = self.slots.len();
        for k in 0..n {
            for release in self.slots[(self.current + k) % n].deferred.drain(..) {
                release(ctx);
            }
        }
        Ok(())
    }

    /// Frees everything (see the module docs for the order).
    pub fn destroy(mut self, ctx: &GpuContext) {
        if self.recording {
            // SAFETY: a recording buffer is not pending; ending it makes it freeable.
            let _ = unsafe { ctx.device.end_command_buffer(self.slots[self.current].cmd) };
        }
        let _ = self.wait_all(ctx);
        for slot in self.slots.drain(..) {
            // SAFETY: every submission completed (waited above).
            unsafe {
                ctx.device.destroy_semaphore(slot.image_available, None);
                ctx.device.destroy_fence(slot.fence, None);
                ctx.device
                    .free_command_buffers(ctx.command_pool, &[slot.cmd]);
            }
        }
    }
}
