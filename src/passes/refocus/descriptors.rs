//! The refocus pass's input descriptor table: one set per view of the texture (stored and sRGB,
//! see `passes::texture`), every set binding the same inputs.
//!
//! | binding | what | type |
//! |---|---|---|
//! | 0 | the views, bilinear at level 0 | combined image sampler |
//! | 1 | the warps, any number of views | storage buffer |
//! | 2 | the sRGB decode table | uniform buffer |
//! | 3 | the warps, the first [`UBO_WARPS`] views | uniform buffer |
//! | 4 | anti-aliasing footprints | uniform buffer |
//! | 5 | the scene's inverse depth | storage buffer |
//! | 6 | a focus surface's plane terms | uniform buffer |
//! | 7 | the views, trilinear over their levels | combined image sampler |
//! | 8 | the views' visibility maps | storage buffer |
//! | 9 | the defocused views | combined image sampler |
//! | 10 | what the boxed stage decided per pixel | storage buffer |
//!
//! `shaders/refocus_accumulate.glsl` declares the same table. Bindings 8 and 9 are rewritten
//! when their buffer or image grows; the others never change after creation.

use ash::vk;

use super::inputs::{AntialiasInputs, SceneDepthInput, SurfaceInputs, ViewInputs};
use crate::gpu::resources::Buffer;
use crate::gpu::GpuContext;
use crate::refocus::settings::UBO_WARPS;

/// What the input sets bind, for their first writing.
pub(super) struct Inputs<'a> {
    /// The texture's views (one per set) and the samplers reading them.
    pub views: &'a [vk::ImageView],
    pub linear: vk::Sampler,
    pub mip: vk::Sampler,
    pub warps: &'a ViewInputs,
    pub depth: &'a SceneDepthInput,
    pub antialias: &'a AntialiasInputs,
    pub surface: &'a SurfaceInputs,
    /// Binding 9.
    pub defocused: vk::DescriptorImageInfo,
    /// Binding 10.
    pub boxed: &'a Buffer,
}

fn whole(buffer: &Buffer) -> [vk::DescriptorBufferInfo; 1] {
    [vk::DescriptorBufferInfo::default()
        .buffer(buffer.buffer)
        .offset(0)
        .range(vk::WHOLE_SIZE)]
}

fn write<'a>(set: vk::DescriptorSet, binding: u32) -> vk::WriteDescriptorSet<'a> {
    vk::WriteDescriptorSet::default()
        .dst_set(set)
        .dst_binding(binding)
}

/// Writes every binding of `sets` (set k reads `inputs.views[k]`). The sets must be unused.
pub(super) fn write_all(ctx: &GpuContext, sets: &[vk::DescriptorSet], inputs: &Inputs) {
    use vk::DescriptorType as T;
    let warps = whole(&inputs.warps.warps);
    let ubo_warps = [vk::DescriptorBufferInfo::default()
        .buffer(inputs.warps.warps.buffer)
        .offset(0)
        .range((UBO_WARPS * std::mem::size_of::<super::GpuViewWarp>()) as u64)];
    let decode = whole(&inputs.warps.decode);
    let footprints = whole(&inputs.antialias.footprints);
    let depth = whole(&inputs.depth.buffer);
    let surface = whole(&inputs.surface.buffer);
    let visibility = whole(&inputs.antialias.visibility);
    let defocused = [inputs.defocused];
    let boxed = whole(inputs.boxed);
    let images: Vec<_> = inputs
        .views
        .iter()
        .map(|&view| {
            let info = vk::DescriptorImageInfo::default()
                .sampler(inputs.linear)
                .image_view(view)
                .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
            ([info], [info.sampler(inputs.mip)])
        })
        .collect();
    let mut writes = Vec::new();
    for (&set, (image, mip)) in sets.iter().zip(&images) {
        let buffers = [
            (1, T::STORAGE_BUFFER, &warps),
            (2, T::UNIFORM_BUFFER, &decode),
            (3, T::UNIFORM_BUFFER, &ubo_warps),
            (4, T::UNIFORM_BUFFER, &footprints),
            (5, T::STORAGE_BUFFER, &depth),
            (6, T::UNIFORM_BUFFER, &surface),
            (8, T::STORAGE_BUFFER, &visibility),
            (10, T::STORAGE_BUFFER, &boxed),
        ];
        writes.extend(
            buffers.into_iter().map(|(binding, ty, info)| {
                write(set, binding).descriptor_type(ty).buffer_info(info)
            }),
        );
        let samplers = [(0, image), (7, mip), (9, &defocused)];
        writes.extend(samplers.into_iter().map(|(binding, info)| {
            write(set, binding)
                .descriptor_type(T::COMBINED_IMAGE_SAMPLER)
                .image_info(info)
        }));
    }
    // SAFETY: the caller guarantees the sets are unused; the infos reference live objects.
    unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
}

/// Points binding 8 of `sets` at `visibility` (grown). The sets must be unused.
pub(super) fn write_visibility(ctx: &GpuContext, sets: &[vk::DescriptorSet], visibility: &Buffer) {
    let info = whole(visibility);
    rewrite(ctx, sets, |set| {
        write(set, 8)
            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
            .buffer_info(&info)
    });
}

/// Points binding 9 of `sets` at the defocused views `info` (recreated). The sets must be
/// unused.
pub(super) fn write_defocused(
    ctx: &GpuContext,
    sets: &[vk::DescriptorSet],
    info: vk::DescriptorImageInfo,
) {
    let info = [info];
    rewrite(ctx, sets, |set| {
        write(set, 9)
            .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .image_info(&info)
    });
}

/// Applies one write, made by `write` for each set, to every set of `sets`.
fn rewrite<'a>(
    ctx: &GpuContext,
    sets: &[vk::DescriptorSet],
    write: impl Fn(vk::DescriptorSet) -> vk::WriteDescriptorSet<'a>,
) {
    let writes: Vec<_> = sets.iter().map(|&set| write(set)).collect();
    // SAFETY: the caller guarantees the sets are unused; the writes reference live objects.
    unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
}
