//! What the refocus pass's compute stages (defocused views, layered and boxed footprints)
//! share: the stage's own descriptor set of one uniform and several storage buffers, and the
//! recording of its chain of dispatches.

use ash::vk;

use super::interface::RefocusPush;
use crate::error::Result;
use crate::gpu::commands::memory_barrier;
use crate::gpu::pipeline;
use crate::gpu::pod::as_bytes;
use crate::gpu::{GpuContext, Owned};

/// A barrier's source and destination scopes, as [`memory_barrier`] takes them.
pub type Scopes = (
    (vk::PipelineStageFlags2, vk::AccessFlags2),
    (vk::PipelineStageFlags2, vk::AccessFlags2),
);

/// A compute stage's own set: binding 0 a uniform buffer, bindings 1..=`storage` storage
/// buffers; its layout, the pool it comes from, and the set.
pub fn buffer_set(
    ctx: &GpuContext,
    storage: u32,
    name: &str,
) -> Result<(
    Owned<vk::DescriptorSetLayout>,
    Owned<vk::DescriptorPool>,
    vk::DescriptorSet,
)> {
    use vk::DescriptorType as T;
    let binding = |i: u32, ty| {
        vk::DescriptorSetLayoutBinding::default()
            .binding(i)
            .descriptor_type(ty)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
    };
    let bindings: Vec<_> = std::iter::once(binding(0, T::UNIFORM_BUFFER))
        .chain((1..=storage).map(|i| binding(i, T::STORAGE_BUFFER)))
        .collect();
    let set_layout = pipeline::set_layout(ctx, &bindings, &format!("{name} set layout"))?;
    let sizes = [
        vk::DescriptorPoolSize {
            ty: T::UNIFORM_BUFFER,
            descriptor_count: 1,
        },
        vk::DescriptorPoolSize {
            ty: T::STORAGE_BUFFER,
            descriptor_count: storage,
        },
    ];
    let pool = pipeline::descriptor_pool(ctx, 1, &sizes, &format!("{name} descriptors"))?;
    let set = pipeline::allocate_sets(ctx, *pool, &[*set_layout])?[0];
    Ok((set_layout, pool, set))
}

/// The push-constant range of every compute stage: the accumulation's [`RefocusPush`].
pub fn push_range() -> [vk::PushConstantRange; 1] {
    [vk::PushConstantRange::default()
        .stage_flags(vk::ShaderStageFlags::COMPUTE)
        .offset(0)
        .size(std::mem::size_of::<RefocusPush>() as u32)]
}

/// Binds `sets` (from set 0) and `push` on `layout`, then records `dispatches` (pipeline and
/// workgroup counts) in order with a barrier of `between` before each after the first: each
/// dispatch reads what the one before wrote.
pub fn record_chain(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    layout: vk::PipelineLayout,
    sets: &[vk::DescriptorSet],
    push: &RefocusPush,
    dispatches: &[(vk::Pipeline, [u32; 3])],
    between: Scopes,
) {
    // SAFETY: recording outside a rendering instance; the caller's sets match the layout.
    unsafe {
        d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, layout, 0, sets, &[]);
        d.cmd_push_constants(
            cmd,
            layout,
            vk::ShaderStageFlags::COMPUTE,
            0,
            as_bytes(std::slice::from_ref(push)),
        );
    }
    for (i, &(p, [gx, gy, gz])) in dispatches.iter().enumerate() {
        if i > 0 {
            memory_barrier(d, cmd, between.0, between.1);
        }
        // SAFETY: as above; `p` was made with `layout`.
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, p);
            d.cmd_dispatch(cmd, gx, gy, gz);
        }
    }
}
