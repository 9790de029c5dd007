//! [`Owned`]: a device object that frees itself.
//!
//! Every pass holds its pipelines, layouts, pools and samplers as `Owned<…>`, so a pass needs no
//! teardown code of its own and a failure half-way through building one is a plain `?`: what
//! was made so far is dropped, and each piece destroys its handle. The guard keeps a clone of
//! the [`GpuContext`], so the device outlives it whatever the drop order.

use ash::vk;

use super::context::GpuContext;

/// A Vulkan object created from the device and destroyed by one `vkDestroy…` call.
pub trait DeviceChild: vk::Handle + Copy {
    /// Destroys the object.
    ///
    /// # Safety
    /// The object belongs to `device` and no pending GPU work uses it.
    unsafe fn destroy(self, device: &ash::Device);
}

macro_rules! device_children {
    ($($handle:ty => $destroy:ident),* $(,)?) => {$(
        impl DeviceChild for $handle {
            unsafe fn destroy(self, device: &ash::Device) {
                // SAFETY: the caller's contract (see the trait).
                unsafe { device.$destroy(self, None) }
            }
        }
    )*};
}

device_children! {
    vk::Pipeline => destroy_pipeline,
    vk::PipelineLayout => destroy_pipeline_layout,
    vk::DescriptorSetLayout => destroy_descriptor_set_layout,
    vk::DescriptorPool => destroy_descriptor_pool,
    vk::Sampler => destroy_sampler,
    vk::ShaderModule => destroy_shader_module,
    vk::Semaphore => destroy_semaphore,
    vk::Fence => destroy_fence,
    vk::QueryPool => destroy_query_pool,
    vk::ImageView => destroy_image_view,
}

/// A device object destroyed when dropped. Dereferences to the raw handle for recording.
///
/// Owners drop their objects only once the GPU is done with them (each job and the viewer wait
/// for their submissions before letting a pass go), which is the contract of
/// [`DeviceChild::destroy`].
pub struct Owned<H: DeviceChild> {
    handle: H,
    ctx: GpuContext,
}

impl<H: DeviceChild> Owned<H> {
    /// Takes ownership of `handle`, created from `ctx`'s device.
    pub fn new(ctx: &GpuContext, handle: H) -> Self {
        Owned {
            handle,
            ctx: ctx.clone(),
        }
    }
}

impl<H: DeviceChild> std::ops::Deref for Owned<H> {
    type Target = H;
    fn deref(&self) -> &H {
        &self.handle
    }
}

impl<H: DeviceChild> Drop for Owned<H> {
    fn drop(&mut self) {
        // SAFETY: created from this context's device; owners drop after their work completed.
        unsafe { self.handle.destroy(&self.ctx.device) }
    }
}

/// Creation results wrapped in [`Owned`]: `ctx.device.create_x(..).vk("vkCreateX").owned(ctx)`.
pub trait OwnedResult<H: DeviceChild> {
    fn owned(self, ctx: &GpuContext) -> crate::error::Result<Owned<H>>;
}

impl<H: DeviceChild> OwnedResult<H> for crate::error::Result<H> {
    fn owned(self, ctx: &GpuContext) -> crate::error::Result<Owned<H>> {
        self.map(|h| Owned::new(ctx, h))
    }
}
