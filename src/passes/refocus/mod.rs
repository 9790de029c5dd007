//! The refocus pass: generalized shift-and-sum on the GPU.
//!
//! Every view is warped by its homography `H_i = A_i + b_i mᵀ`, sampled from the view array
//! texture, masked (behind camera i, outside its image) and its weighted colour and weight are
//! summed into a float accumulation image; a resolve divides by the weight sum into the output.
//!
//! The pass owns what is shared by every frame of one light field: pipelines, the descriptor
//! sets of the view texture and the warp buffer. It records into command buffers and targets
//! the caller owns ([`RefocusTarget`]); submission, readback and frames in flight are the
//! caller's (the headless renderer, a window).
//!
//! - [`RefocusPass::set_views`] uploads the per-view part `(A_i, b_i, weight, layer)`; it changes
//!   only with the view set, the aperture or the reference camera. Moving the plane changes only
//!   `m`, a push constant: no buffer or descriptor writes per frame.
//! - [`RefocusPass::record_accumulate`] adds a range of the uploaded views into a target
//!   ([`Strategy`]: one fullscreen draw, batched draws, or a compute dispatch), so a caller can
//!   accumulate progressively over several submissions; [`RefocusPass::record_resolve`]
//!   normalises whatever has been summed so far.
//! - [`Filter`] picks hardware bilinear, nearest, bilinear or bicubic (Catmull-Rom) in the
//!   shader; with 8-bit sRGB views and linear averaging the shader filters decode texels
//!   exactly before filtering.
//! - [`WarpMemory`]: the warps are read from a uniform buffer where they fit (up to
//!   [`UBO_WARPS`] views), else from a storage buffer; the sRGB decode table is a uniform
//!   buffer.
//! - [`Accumulation`] is the float format of a target's sum (RGBA32F or RGBA16F), chosen
//!   when the target is created ([`RefocusPass::create_target_with`]).
//!
//! Output pixel (i, j) has its centre at reference-view pixel position
//! ((i + ½)·W_view/W_out − ½, (j + ½)·H_view/H_out − ½), so any output size is exact.
//!
//! - [`RefocusPass::set_antialias`] uploads an anti-aliasing plan (views by aperture cell,
//!   their footprints, the scene's inverse depth per reference pixel); accumulations with
//!   `antialias > 0` integrate each view over its footprint (docs/conventions.md §11).
//!   With defocused views ([`crate::refocus::defocus`]) a compute stage of its own
//!   ([`defocus`]) box-filters the views first and the accumulation reads them at binding 9.
//! - [`RefocusPass::set_surface`] uploads a focus surface (its plane terms, binding 6, and the
//!   scene depth it shares with anti-aliasing, binding 5); accumulations with `surface` pick
//!   the focus's inverse depth per pixel by its rule (the `SURFACE` specialisation constant,
//!   docs/conventions.md §12). Without it the shader is the single-plane path.
//!
//! Destruction order: pipelines → pipeline layouts → descriptor pool (frees the sets) → set
//! layouts → samplers → warp buffer → decode table → anti-aliasing buffers → surface buffer →
//! defocus stage. Targets are the caller's and destroyed by it.

mod defocus;
mod interface;
mod target;

use std::ops::Range;

use ash::vk;

use crate::gpu::pod::as_bytes;
use defocus::{DefocusKey, DefocusStage};
pub use interface::{GpuFootprint, GpuSurface, GpuViewWarp, RefocusPush};
pub use target::RefocusTarget;

use super::texture::{LightFieldTexture, VIEW_SRGB, VIEW_STORED};
use crate::error::{Error, Result, VkContext};
use crate::gpu::commands::{
    begin_rendering, begin_rendering_in, image_barrier, stage, ImageTransition,
};
use crate::gpu::pipeline::{compute_pipeline, graphics_pipeline, Blend, PipelineDesc};
use crate::gpu::resources::Buffer;
use crate::gpu::shaders;
use crate::gpu::GpuContext;
use crate::refocus::antialias::{AntialiasPlan, MAX_VISIBILITY_BYTES};
use crate::refocus::settings::{
    Accumulation, Filter, OutputFormat, Strategy, ViewStorage, WarpMemory, UBO_WARPS,
};
use crate::refocus::surface::{SurfacePlan, SurfaceRule, MAX_PLANES};
use crate::refocus::{Averaging, RefocusPlan};

/// The Vulkan format a target sums in with `accumulation`.
pub fn accumulation_format(accumulation: Accumulation) -> vk::Format {
    match accumulation {
        Accumulation::Rgba32f => vk::Format::R32G32B32A32_SFLOAT,
        Accumulation::Rgba16f => vk::Format::R16G16B16A16_SFLOAT,
    }
}

/// The accumulation whose Vulkan format is `format`, if any.
fn accumulation_of_format(format: vk::Format) -> Option<Accumulation> {
    [Accumulation::Rgba32f, Accumulation::Rgba16f]
        .into_iter()
        .find(|a| accumulation_format(*a) == format)
}

/// The `FILTER` code the accumulation shaders read (shaders/refocus_accumulate.glsl).
fn filter_code(filter: Filter) -> u32 {
    match filter {
        Filter::Hardware => 0,
        Filter::Nearest => 1,
        Filter::Shader => 2,
        Filter::Bicubic => 3,
    }
}

/// What one accumulation records.
#[derive(Debug, Clone, PartialEq)]
pub struct Accumulate {
    /// The plane term m (zero for classic shift-and-sum).
    pub m: [f32; 3],
    /// Which uploaded views (indices into the last [`RefocusPass::set_views`]).
    pub views: Range<usize>,
    /// Start from zero (true) or add to what the target holds (false).
    pub clear: bool,
    pub strategy: Strategy,
    pub filter: Filter,
    pub averaging: Averaging,
    /// Anti-aliasing: at most this many sub-samples per axis of each view's aperture cell,
    /// from the footprints and scene depth of the last [`RefocusPass::set_antialias`]; 0: the
    /// plain sum.
    pub antialias: u32,
    /// Focus on the surface of the last [`RefocusPass::set_surface`] (its plane terms and the
    /// scene depth) instead of the plane `m` alone; `m` stays the fallback where the depth is
    /// unknown.
    pub surface: bool,
}

/// What the shader does to each texel before filtering (`TEXEL` in refocus_accumulate.glsl).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Texel {
    AsStored = 0,
    /// 8-bit sRGB → linear through the exact table.
    DecodeSrgb = 1,
    /// Linear → sRGB with the exact curve.
    EncodeSrgb = 2,
}

/// Texture view, texel transform and the filter actually used for `filter` and `averaging`
/// on `storage`. Transforms need the shader's own filtering, so encoded averaging from linear
/// storage filters in the shader even when hardware filtering was asked for.
fn sampling(storage: ViewStorage, filter: Filter, averaging: Averaging) -> (usize, Texel, Filter) {
    match (storage, averaging, filter) {
        (ViewStorage::Srgb8, Averaging::Encoded, f) => (VIEW_STORED, Texel::AsStored, f),
        (ViewStorage::Srgb8, Averaging::Linear, Filter::Hardware) => {
            (VIEW_SRGB, Texel::AsStored, Filter::Hardware)
        }
        (ViewStorage::Srgb8, Averaging::Linear, f) => (VIEW_STORED, Texel::DecodeSrgb, f),
        (ViewStorage::Linear16, Averaging::Linear, f) => (VIEW_STORED, Texel::AsStored, f),
        (ViewStorage::Linear16, Averaging::Encoded, Filter::Hardware) => {
            (VIEW_STORED, Texel::EncodeSrgb, Filter::Shader)
        }
        (ViewStorage::Linear16, Averaging::Encoded, f) => (VIEW_STORED, Texel::EncodeSrgb, f),
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct AccumKey {
    compute: bool,
    filter: u32,
    texel: u32,
    format: vk::Format,
    uniform_warps: bool,
    antialias: u32,
    /// Anti-aliasing reads the views' pyramid (`refocus::prefilter`, binding 7).
    prefilter: bool,
    /// Anti-aliasing's occlusion tests are compiled in (`AntialiasSettings::occlusion`).
    occlusion: bool,
    /// `SurfaceRule` code (0: the plane alone).
    surface: u32,
    /// Anti-aliasing reads the defocused views (binding 9) instead of sub-sampling.
    defocus: bool,
    /// The compute shader's shape (the default for fragment pipelines, which ignore it).
    shape: ComputeShape,
}

/// How the compute strategy's invocations cover the output: output pixels per invocation of
/// the plain sum (the shader's PIXELS, 0-4; 0: the per-pixel loop), views per iteration of its
/// loop (UNROLL, 1-8) and the workgroup's shape. Every shape gives the same image; they differ
/// in speed by device, so `TILTFIELD_COMPUTE_PIXELS`, `TILTFIELD_COMPUTE_UNROLL` and
/// `TILTFIELD_COMPUTE_TILE` (`WxH`) override the defaults for profiling (tools/gpu-bench.sh
/// compares them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ComputeShape {
    pub pixels: u32,
    pub unroll: u32,
    pub tile: (u32, u32),
}

impl Default for ComputeShape {
    /// Measured on an NVIDIA H200 (81 views of 512², 200 frames, two interleaved rounds):
    /// 2 pixels × 4 views per iteration in 8×16 workgroups 0.0745 ms, against 0.090 ms for
    /// one pixel and one view per iteration in 8×8 (the per-pixel loop 0.091); 4 pixels or 8
    /// views per iteration were slower again (registers). The same numbers on every device.
    fn default() -> Self {
        ComputeShape {
            pixels: 2,
            unroll: 4,
            tile: (8, 16),
        }
    }
}

impl ComputeShape {
    /// Checks the ranges: a workgroup of at most 1024 invocations, what desktop and data-centre
    /// GPUs take (Vulkan guarantees 128; the default, 8×16, stays within that).
    pub fn validate(&self) -> Result<()> {
        let (w, h) = self.tile;
        if self.pixels > 4 || !(1..=8).contains(&self.unroll) || w == 0 || h == 0 || w * h > 1024 {
            return Err(Error::Invalid(format!(
                "compute shape: pixels 0-4, unroll 1-8 and a tile of at most 1024 invocations, \
                 got {self:?}"
            )));
        }
        Ok(())
    }

    /// The default with the environment's overrides (those out of range are ignored).
    fn from_env() -> Self {
        let num = |k: &str| {
            std::env::var(k)
                .ok()
                .and_then(|v| v.trim().parse::<u32>().ok())
        };
        let d = ComputeShape::default();
        let tile = std::env::var("TILTFIELD_COMPUTE_TILE").ok().and_then(|v| {
            let (a, b) = v.trim().split_once('x')?;
            Some((a.parse().ok()?, b.parse().ok()?))
        });
        let s = ComputeShape {
            pixels: num("TILTFIELD_COMPUTE_PIXELS").unwrap_or(d.pixels),
            unroll: num("TILTFIELD_COMPUTE_UNROLL").unwrap_or(d.unroll),
            tile: tile.unwrap_or(d.tile),
        };
        match s.validate() {
            Ok(()) => s,
            Err(e) => {
                log::warn!("TILTFIELD_COMPUTE_*: {e}; using the default {d:?}");
                d
            }
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct ResolveKey {
    mode: u32,
    format: vk::Format,
}

/// Pipelines, descriptors and the warp buffer of the refocus pass for one view texture.
pub struct RefocusPass {
    objects: PassObjects,
    /// One input set per texture view (index = `VIEW_STORED`, `VIEW_SRGB`).
    input_sets: Vec<vk::DescriptorSet>,
    storage: ViewStorage,
    view_size: [f32; 2],
    layers: usize,
    warps: Buffer,
    /// `color::decode_table` as f32, read by shaders that decode texels exactly.
    decode: Buffer,
    warp_capacity: usize,
    /// Where the shaders read the warps from (see [`WarpMemory`]).
    warp_memory: WarpMemory,
    /// What `warps` holds now, so an unchanged view set is not rewritten.
    uploaded: Vec<GpuViewWarp>,
    /// Anti-aliasing footprints (uniform buffer of [`UBO_WARPS`] records, binding 4).
    footprints: Buffer,
    /// The scene's inverse depth per reference pixel at the views' size (storage buffer,
    /// binding 5).
    scene_depth: Buffer,
    /// What the footprint and scene-depth buffers hold (empty: nothing for these views), so
    /// an unchanged anti-aliasing plan is not rewritten.
    uploaded_footprints: Vec<GpuFootprint>,
    uploaded_depth: Vec<f32>,
    /// The views' visibility maps (storage buffer, binding 8): a placeholder until a plan
    /// with maps is uploaded, then grown to hold them.
    visibility: Buffer,
    /// The id of the uploaded maps (`ViewVisibility::id`).
    uploaded_visibility: Option<u64>,
    /// The uploaded plan's `AntialiasSettings::prefilter`.
    uploaded_prefilter: bool,
    /// How the compute strategy's invocations cover the output (see [`ComputeShape`]).
    compute_shape: ComputeShape,
    /// The uploaded plan's `AntialiasSettings::occlusion`.
    uploaded_occlusion: bool,
    /// The uploaded plan's `AntialiasSettings::defocus`.
    uploaded_defocus: bool,
    /// Box-filters the views before an accumulation with defocused views.
    defocus: Option<DefocusStage>,
    /// The uploaded plan's [`AntialiasPlan::focused_reach`], pushed with every draw.
    uploaded_focused_reach: f32,
    /// The focus surface's plane terms (uniform buffer, binding 6).
    surface: Buffer,
    /// What [`RefocusPass::set_surface`] uploaded last: rule and plane count.
    uploaded_surface: Option<(SurfaceRule, u32)>,
    accum_pipelines: Vec<(AccumKey, vk::Pipeline)>,
    resolve_pipelines: Vec<(ResolveKey, vk::Pipeline)>,
}

/// The accumulation format: RGBA32F where the device blends into it (and, for the compute
/// strategy, stores to it), else RGBA16F.
pub fn pick_accum_format(ctx: &GpuContext) -> Result<(vk::Format, bool)> {
    for a in [Accumulation::Rgba32f, Accumulation::Rgba16f] {
        if let Some(storage) = accum_support(ctx, a) {
            return Ok((accumulation_format(a), storage));
        }
    }
    Err(Error::Vulkan(format!(
        "{} cannot blend into a float colour attachment",
        ctx.info.name
    )))
}

/// Whether the device can accumulate in `a` (blend into it and sample it): `None` if not,
/// else whether it can also be a storage image (the compute strategy).
fn accum_support(ctx: &GpuContext, a: Accumulation) -> Option<bool> {
    use vk::FormatFeatureFlags as F;
    let need = F::COLOR_ATTACHMENT | F::COLOR_ATTACHMENT_BLEND | F::SAMPLED_IMAGE;
    // SAFETY: valid physical device.
    let props = unsafe {
        ctx.instance
            .get_physical_device_format_properties(ctx.physical, accumulation_format(a))
    };
    let features = props.optimal_tiling_features;
    features
        .contains(need)
        .then_some(features.contains(F::STORAGE_IMAGE))
}

impl RefocusPass {
    /// Creates the pass for `texture`; the warp buffer holds one entry per layer.
    pub fn new(ctx: &GpuContext, texture: &LightFieldTexture) -> Result<Self> {
        let mut b = PassObjects::default();
        let made = b.build(ctx, texture.image.views.len());
        let sets = match made {
            Ok(sets) => sets,
            Err(e) => {
                b.destroy(ctx);
                return Err(e);
            }
        };
        let capacity = texture.layers as usize;
        let table: Vec<u8> = crate::color::decode_table()
            .iter()
            .flat_map(|&v| (v as f32).to_ne_bytes())
            .collect();
        // The warp buffer is bound twice: as a storage buffer (any number of views) and as a
        // uniform buffer of UBO_WARPS records, so it is at least that large.
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::UNIFORM_BUFFER;
        let bytes = (capacity.max(UBO_WARPS) * std::mem::size_of::<GpuViewWarp>()) as u64;
        let buffers = Buffer::new(ctx, bytes, usage, true, "view warps").and_then(|warps| {
            let usage = vk::BufferUsageFlags::UNIFORM_BUFFER;
            match Buffer::with_bytes(ctx, &table, usage, "sRGB decode table") {
                Ok(decode) => Ok((warps, decode)),
                Err(e) => {
                    warps.destroy(ctx);
                    Err(e)
                }
            }
        });
        let (warps, decode) = match buffers {
            Ok(x) => x,
            Err(e) => {
                b.destroy(ctx);
                return Err(e);
            }
        };
        // Anti-aliasing's inputs exist from the start (a footprint per uniform warp, a float
        // per view pixel), so the descriptor sets never change after creation.
        let aa_buffers = Buffer::new(
            ctx,
            (UBO_WARPS * std::mem::size_of::<GpuFootprint>()) as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            true,
            "anti-aliasing footprints",
        )
        .and_then(|footprints| {
            // σ and the front σ per pixel.
            let bytes = (texture.width as u64 * texture.height as u64 * 8).max(8);
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            match Buffer::new(ctx, bytes, usage, true, "scene inverse depth") {
                Ok(depth) => Ok((footprints, depth)),
                Err(e) => {
                    footprints.destroy(ctx);
                    Err(e)
                }
            }
        });
        let (footprints, scene_depth) = match aa_buffers {
            Ok(x) => x,
            Err(e) => {
                warps.destroy(ctx);
                decode.destroy(ctx);
                b.destroy(ctx);
                return Err(e);
            }
        };
        let surface = match Buffer::new(
            ctx,
            std::mem::size_of::<GpuSurface>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            true,
            "focus surface planes",
        )
        .and_then(|surface| {
            // Room for every layer's map up front where that fits the budget, so the binding
            // is written once; a larger light field grows it on first use.
            let full = texture.layers.min(UBO_WARPS as u32) as u64
                * texture.width as u64
                * texture.height as u64
                * 4;
            let bytes = if full as usize <= MAX_VISIBILITY_BYTES {
                full.max(16)
            } else {
                16
            };
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            match Buffer::new(ctx, bytes, usage, true, VISIBILITY) {
                Ok(v) => Ok((surface, v)),
                Err(e) => {
                    surface.destroy(ctx);
                    Err(e)
                }
            }
        }) {
            Ok(b) => b,
            Err(e) => {
                footprints.destroy(ctx);
                scene_depth.destroy(ctx);
                warps.destroy(ctx);
                decode.destroy(ctx);
                b.destroy(ctx);
                return Err(e);
            }
        };
        let (surface, visibility) = surface;
        let visibility_info = [vk::DescriptorBufferInfo::default()
            .buffer(visibility.buffer)
            .offset(0)
            .range(vk::WHOLE_SIZE)];
        let surface_info = [vk::DescriptorBufferInfo::default()
            .buffer(surface.buffer)
            .offset(0)
            .range(vk::WHOLE_SIZE)];
        let footprint_info = [vk::DescriptorBufferInfo::default()
            .buffer(footprints.buffer)
            .offset(0)
            .range(vk::WHOLE_SIZE)];
        let depth_info = [vk::DescriptorBufferInfo::default()
            .buffer(scene_depth.buffer)
            .offset(0)
            .range(vk::WHOLE_SIZE)];
        // The input sets never change: texture and warp buffer live as long as the pass.
        let buffer_info = [vk::DescriptorBufferInfo::default()
            .buffer(warps.buffer)
            .offset(0)
            .range(vk::WHOLE_SIZE)];
        let ubo_info = [vk::DescriptorBufferInfo::default()
            .buffer(warps.buffer)
            .offset(0)
            .range((UBO_WARPS * std::mem::size_of::<GpuViewWarp>()) as u64)];
        let decode_info = [vk::DescriptorBufferInfo::default()
            .buffer(decode.buffer)
            .offset(0)
            .range(vk::WHOLE_SIZE)];
        let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = texture
            .image
            .views
            .iter()
            .map(|&view| {
                [vk::DescriptorImageInfo::default()
                    .sampler(b.sampler_linear)
                    .image_view(view)
                    .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)]
            })
            .collect();
        let mip_infos: Vec<[vk::DescriptorImageInfo; 1]> = image_infos
            .iter()
            .map(|[info]| [info.sampler(b.sampler_mip)])
            .collect();
        let mut writes = Vec::new();
        for ((set, info), mip_info) in sets.iter().zip(&image_infos).zip(&mip_infos) {
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(0)
                    .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                    .image_info(info),
            );
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(1)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(&buffer_info),
            );
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(2)
                    .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
                    .buffer_info(&decode_info),
            );
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(3)
                    .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
                    .buffer_info(&ubo_info),
            );
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(4)
                    .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
                    .buffer_info(&footprint_info),
            );
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(5)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(&depth_info),
            );
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(6)
                    .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
                    .buffer_info(&surface_info),
            );
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(7)
                    .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                    .image_info(mip_info),
            );
            writes.push(visibility_write(*set, &visibility_info));
        }
        // SAFETY: new, unused sets; the infos reference live objects.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
        let mut pass = RefocusPass {
            objects: b,
            input_sets: sets,
            storage: texture.storage,
            view_size: [texture.width as f32, texture.height as f32],
            layers: texture.layers as usize,
            warps,
            decode,
            warp_capacity: capacity,
            warp_memory: WarpMemory::for_views(capacity),
            uploaded: Vec::new(),
            footprints,
            scene_depth,
            uploaded_footprints: Vec::new(),
            uploaded_prefilter: false,
            compute_shape: ComputeShape::from_env(),
            uploaded_occlusion: false,
            uploaded_defocus: false,
            defocus: None,
            uploaded_focused_reach: 0.0,
            uploaded_depth: Vec::new(),
            visibility,
            uploaded_visibility: None,
            surface,
            uploaded_surface: None,
            accum_pipelines: Vec::new(),
            resolve_pipelines: Vec::new(),
        };
        // Binding 9 needs an image from the start: the stage's one-view placeholder.
        let size = (texture.width, texture.height);
        match DefocusStage::new(ctx, pass.objects.input_set_layout, size) {
            Ok(stage) => {
                pass.defocus = Some(stage);
                pass.write_defocused_binding(ctx);
                Ok(pass)
            }
            Err(e) => {
                pass.destroy(ctx);
                Err(e)
            }
        }
    }

    /// Sets how the compute strategy's invocations cover the output ([`ComputeShape`]).
    /// Every shape gives the same image.
    pub fn set_compute_shape(&mut self, shape: ComputeShape) -> Result<()> {
        shape.validate()?;
        self.compute_shape = shape;
        Ok(())
    }

    /// Tells the pass that the texture's views were uploaded again (the next frame of a
    /// video): what it derived from their texels is rebuilt on next use.
    pub fn views_reuploaded(&mut self) {
        if let Some(stage) = &mut self.defocus {
            stage.invalidate_tables();
        }
    }

    /// Points binding 9 of every input set at the defocus stage's current image. The GPU must
    /// not be using the sets.
    fn write_defocused_binding(&self, ctx: &GpuContext) {
        let Some(stage) = &self.defocus else {
            return;
        };
        let info = [stage.sampled_info(self.objects.sampler_linear)];
        let writes: Vec<_> = self
            .input_sets
            .iter()
            .map(|&set| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(9)
                    .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                    .image_info(&info)
            })
            .collect();
        // SAFETY: the caller guarantees the sets are unused; the info references a live image.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
    }

    /// Where the shaders read the warps from: `None` picks the default for this light field
    /// ([`WarpMemory::for_views`]). The uniform buffer holds at most [`UBO_WARPS`] views; asking
    /// for it with more is an error.
    pub fn set_warp_memory(&mut self, memory: Option<WarpMemory>) -> Result<()> {
        let memory = memory.unwrap_or_else(|| WarpMemory::for_views(self.warp_capacity));
        if memory == WarpMemory::Uniform && self.warp_capacity > UBO_WARPS {
            return Err(Error::Invalid(format!(
                "the light field has {} views; a uniform buffer of warps holds at most {UBO_WARPS}",
                self.warp_capacity
            )));
        }
        self.warp_memory = memory;
        Ok(())
    }

    /// Where the shaders read the warps from.
    pub fn warp_memory(&self) -> WarpMemory {
        self.warp_memory
    }

    /// How the views are stored in the texture this pass reads.
    pub fn storage(&self) -> ViewStorage {
        self.storage
    }

    /// A target of `width × height` for this pass (the caller owns and destroys it), summing
    /// in RGBA32F where the device can, else RGBA16F.
    pub fn create_target(
        &self,
        ctx: &GpuContext,
        width: u32,
        height: u32,
    ) -> Result<RefocusTarget> {
        let (format, storage) = pick_accum_format(ctx)?;
        self.target_of(ctx, width, height, format, storage)
    }

    /// A target of `width × height` that sums in `accumulation`; an error when the device
    /// cannot blend into that format.
    pub fn create_target_with(
        &self,
        ctx: &GpuContext,
        width: u32,
        height: u32,
        accumulation: Accumulation,
    ) -> Result<RefocusTarget> {
        let storage = accum_support(ctx, accumulation).ok_or_else(|| {
            Error::DeviceLimit(format!(
                "{} cannot blend into {} colour attachments: use --accumulation {}",
                ctx.info.name,
                accumulation.name(),
                Accumulation::Rgba16f.name()
            ))
        })?;
        self.target_of(
            ctx,
            width,
            height,
            accumulation_format(accumulation),
            storage,
        )
    }

    fn target_of(
        &self,
        ctx: &GpuContext,
        width: u32,
        height: u32,
        format: vk::Format,
        storage: bool,
    ) -> Result<RefocusTarget> {
        if width == 0 || height == 0 {
            return Err(Error::Invalid(format!(
                "output size {width}×{height} is empty"
            )));
        }
        let limit = ctx.properties.limits.max_image_dimension2_d;
        if width.max(height) > limit {
            return Err(Error::DeviceLimit(format!(
                "output size {width}×{height} exceeds {}'s maximum image size of {limit} px",
                ctx.info.name
            )));
        }
        RefocusTarget::new(
            ctx,
            width,
            height,
            format,
            storage,
            (
                self.objects.resolve_set_layout,
                self.objects.storage_set_layout,
            ),
            self.objects.sampler_nearest,
        )
    }

    /// Uploads the per-view warps of `plan`, in plan order. Returns false (and writes nothing)
    /// when they equal what the buffer holds, as after a plane change alone. The GPU must not be
    /// reading the buffer (callers wait for the frames that used it).
    pub fn set_views(&mut self, plan: &RefocusPlan) -> Result<bool> {
        if plan.views.len() > self.warp_capacity
            || plan.views.iter().any(|v| v.index >= self.layers)
        {
            return Err(Error::Invalid(
                "the refocus plan does not belong to this light field texture".into(),
            ));
        }
        let records: Vec<GpuViewWarp> = plan
            .views
            .iter()
            .map(|v| GpuViewWarp::new(&v.warp, v.index, v.weight))
            .collect();
        if records == self.uploaded {
            return Ok(false);
        }
        let bytes = as_bytes(&records);
        self.warps.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
        self.uploaded = records;
        // The footprints belonged to the previous views.
        self.uploaded_footprints.clear();
        Ok(true)
    }

    /// Uploads the views of `aa.plan` ([`RefocusPass::set_views`]) and anti-aliasing's
    /// footprints and scene depth, for accumulations with `antialias > 0`. Same rules as
    /// `set_views`: the GPU must not be reading the buffers. Returns whether the warps changed.
    pub fn set_antialias(&mut self, ctx: &GpuContext, aa: &AntialiasPlan) -> Result<bool> {
        if aa.plan.views.len() > UBO_WARPS {
            return Err(Error::Invalid(format!(
                "anti-aliasing handles at most {UBO_WARPS} views in the aperture, this one has {}; \
                 use a smaller --aperture-radius or --antialias off",
                aa.plan.views.len()
            )));
        }
        if aa.footprints.len() != aa.plan.views.len() {
            return Err(Error::Invalid(
                "the anti-aliasing plan has a footprint per view".into(),
            ));
        }
        let px = self.view_size[0] as usize * self.view_size[1] as usize;
        if (aa.depth.width as usize * aa.depth.height as usize) != px
            || aa.depth.inverse_depth.len() != px
            || aa.depth.front.len() != px
        {
            return Err(Error::Invalid(format!(
                "the scene depth is {}×{}, the views {}×{}",
                aa.depth.width, aa.depth.height, self.view_size[0], self.view_size[1]
            )));
        }
        let changed = self.set_views(&aa.plan)?;
        self.set_visibility(ctx, aa)?;
        if aa.settings.defocus {
            let stage = self.defocus.as_mut().expect("made with the pass");
            if stage.reserve(ctx, aa.plan.views.len() as u32)? {
                self.write_defocused_binding(ctx);
            }
        }
        self.uploaded_defocus = aa.settings.defocus;
        let records = footprint_records(aa);
        if records != self.uploaded_footprints {
            let bytes = as_bytes(&records);
            self.footprints.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
            self.uploaded_footprints = records;
        }
        self.uploaded_prefilter = aa.settings.prefilter;
        self.uploaded_occlusion = aa.settings.occlusion;
        self.uploaded_focused_reach = aa.focused_reach() as f32;
        let interleaved = aa.depth.interleaved();
        if interleaved != self.uploaded_depth {
            let depth = as_bytes(&interleaved);
            self.scene_depth.bytes_mut()[..depth.len()].copy_from_slice(depth);
            self.uploaded_depth = interleaved;
        }
        Ok(changed)
    }

    /// Uploads `aa`'s visibility maps (binding 8), growing the buffer (and rewriting the
    /// binding) when they do not fit. Same rules as `set_views`.
    fn set_visibility(&mut self, ctx: &GpuContext, aa: &AntialiasPlan) -> Result<()> {
        let Some(vis) = &aa.visibility else {
            return Ok(());
        };
        if self.uploaded_visibility == Some(vis.id) {
            return Ok(());
        }
        let bytes = as_bytes(&vis.sigma);
        if bytes.len() as u64 > self.visibility.size {
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            let grown = Buffer::new(ctx, bytes.len() as u64, usage, true, VISIBILITY)?;
            let old = std::mem::replace(&mut self.visibility, grown);
            old.destroy(ctx);
            let info = [vk::DescriptorBufferInfo::default()
                .buffer(self.visibility.buffer)
                .offset(0)
                .range(vk::WHOLE_SIZE)];
            let writes: Vec<_> = self
                .input_sets
                .iter()
                .map(|&set| visibility_write(set, &info))
                .collect();
            // SAFETY: the caller guarantees the GPU is not using the sets (as for the
            // buffers); the info references the live new buffer.
            unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
        }
        self.visibility.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
        self.uploaded_visibility = Some(vis.id);
        Ok(())
    }

    /// Uploads a focus surface's plane terms and its scene depth (the depth anti-aliasing
    /// reads too: with anti-aliasing, `surface` must carry the same depth as the
    /// [`RefocusPass::set_antialias`] plan, see `refocus::surface::surface_for`), for
    /// accumulations with `surface`. Same rules as `set_views`: the GPU must not be reading
    /// the buffers.
    pub fn set_surface(&mut self, surface: &SurfacePlan) -> Result<()> {
        let count = surface.terms.len();
        if count == 0 || count > MAX_PLANES {
            return Err(Error::Invalid(format!(
                "a focus surface has 1 to {MAX_PLANES} plane terms, this one {count}"
            )));
        }
        if let Some(depth) = &surface.depth {
            let px = self.view_size[0] as usize * self.view_size[1] as usize;
            if depth.inverse_depth.len() != px || depth.front.len() != px {
                return Err(Error::Invalid(format!(
                    "the scene depth is {}×{}, the views {}×{}",
                    depth.width, depth.height, self.view_size[0], self.view_size[1]
                )));
            }
            let interleaved = depth.interleaved();
            if interleaved != self.uploaded_depth {
                let bytes = as_bytes(&interleaved);
                self.scene_depth.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
                self.uploaded_depth = interleaved;
            }
        } else if surface.rule != SurfaceRule::Plane {
            return Err(Error::Invalid(
                "a focus surface other than one plane needs the scene depth".into(),
            ));
        }
        let record = GpuSurface::new(surface);
        let bytes = as_bytes(std::slice::from_ref(&record));
        self.surface.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
        self.uploaded_surface = Some((surface.rule, count as u32));
        Ok(())
    }

    /// Whether [`RefocusPass::set_antialias`] would rewrite anything for `aa`: a caller with
    /// frames in flight waits for them first.
    pub fn antialias_differs(&self, aa: &AntialiasPlan) -> bool {
        self.views_differ(&aa.plan)
            || footprint_records(aa) != self.uploaded_footprints
            || aa.visibility.as_ref().map(|v| v.id) != self.uploaded_visibility
            || aa.depth.interleaved() != self.uploaded_depth
            || aa.settings.prefilter != self.uploaded_prefilter
            || aa.settings.occlusion != self.uploaded_occlusion
            || aa.settings.defocus != self.uploaded_defocus
            || aa.focused_reach() as f32 != self.uploaded_focused_reach
    }

    /// Whether [`RefocusPass::set_views`] would rewrite the warps for `plan`: a caller with
    /// frames in flight waits for them first.
    pub fn views_differ(&self, plan: &RefocusPlan) -> bool {
        plan.views.len() != self.uploaded.len()
            || plan
                .views
                .iter()
                .zip(&self.uploaded)
                .any(|(v, u)| GpuViewWarp::new(&v.warp, v.index, v.weight) != *u)
    }

    /// Number of views uploaded by the last [`RefocusPass::set_views`].
    pub fn view_count(&self) -> usize {
        self.uploaded.len()
    }

    /// Records the accumulation of `a.views` into `target` (see the module docs).
    pub fn record_accumulate(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        target: &mut RefocusTarget,
        a: &Accumulate,
    ) -> Result<()> {
        if a.views.start > a.views.end || a.views.end > self.uploaded.len() {
            return Err(Error::Invalid(format!(
                "views {:?} lie outside the {} uploaded warps",
                a.views,
                self.uploaded.len()
            )));
        }
        if a.antialias > 0 && self.uploaded_footprints.len() != self.uploaded.len() {
            return Err(Error::Invalid(
                "anti-aliased accumulation without the footprints of the uploaded views \
                 (RefocusPass::set_antialias)"
                    .into(),
            ));
        }
        let (rule, plane_count) = match (a.surface, self.uploaded_surface) {
            (false, _) => (SurfaceRule::Plane, 1),
            (true, Some(u)) => u,
            (true, None) => {
                return Err(Error::Invalid(
                    "focus-surface accumulation without an uploaded surface \
                     (RefocusPass::set_surface)"
                        .into(),
                ))
            }
        };
        let (set_index, texel, filter) = sampling(self.storage, a.filter, a.averaging);
        let compute = a.strategy == Strategy::Compute;
        if compute && target.storage_set == vk::DescriptorSet::null() {
            return Err(Error::DeviceLimit(format!(
                "{} cannot store to an {} image: use a fragment strategy",
                ctx.info.name,
                accumulation_of_format(target.accum_format).map_or("accumulation", |a| a.name())
            )));
        }
        let key = AccumKey {
            compute,
            filter: filter_code(filter),
            texel: texel as u32,
            format: target.accum_format,
            uniform_warps: self.warp_memory == WarpMemory::Uniform,
            antialias: a.antialias,
            prefilter: a.antialias > 0 && self.uploaded_prefilter,
            occlusion: a.antialias > 0 && self.uploaded_occlusion && !self.uploaded_defocus,
            surface: rule as u32,
            defocus: a.antialias > 0 && self.uploaded_defocus,
            shape: if compute {
                self.compute_shape
            } else {
                ComputeShape::default()
            },
        };
        let pipeline = self.accum_pipeline(ctx, key)?;
        let d = &ctx.device;
        let mut push = RefocusPush {
            plane: [a.m[0], a.m[1], a.m[2], 0.0],
            view_size: self.view_size,
            out_scale: [
                self.view_size[0] / target.width as f32,
                self.view_size[1] / target.height as f32,
            ],
            first_view: a.views.start as u32,
            view_count: 0,
            accumulate: 0,
            plane_count,
            total_views: self.uploaded.len() as u32,
            // Catmull-Rom for in-focus sub-samples refines the bilinear filters; bicubic has
            // it everywhere and nearest is asked for as it is.
            focused_reach: match filter {
                Filter::Hardware | Filter::Shader if a.antialias > 0 => self.uploaded_focused_reach,
                _ => 0.0,
            },
        };
        let input_set = self.input_sets[set_index];
        if key.defocus {
            let stage_key = DefocusKey {
                filter: key.filter,
                texel: key.texel,
                uniform_warps: key.uniform_warps,
                surface: key.surface,
            };
            let layers: Vec<(u32, u32)> = a
                .views
                .clone()
                .map(|k| {
                    let (w, f) = (&self.uploaded[k], &self.uploaded_footprints[k]);
                    (w.a0[3] as u32, f.vis[1] as u32)
                })
                .collect();
            let stage = self.defocus.as_mut().expect("made with the pass");
            stage.record(
                ctx,
                cmd,
                input_set,
                stage_key,
                push,
                a.views.clone(),
                &layers,
            )?;
        }
        // Whatever touched the accumulation image before (a previous accumulation, a resolve,
        // possibly in an earlier submission) finishes first.
        let from = if target.accum_ready {
            stage::GENERAL_ANY
        } else {
            stage::UNDEFINED
        };
        let clear = a.clear || !target.accum_ready;
        image_barrier(
            d,
            cmd,
            target.accum.image,
            1,
            ImageTransition {
                from,
                to: stage::GENERAL_ANY,
            },
        );
        target.accum_ready = true;
        let extent = vk::Extent2D {
            width: target.width,
            height: target.height,
        };
        if compute {
            let layout = self.objects.compute_layout;
            // SAFETY: recording outside a rendering instance; sets match the layout.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
                d.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    layout,
                    0,
                    &[input_set, target.storage_set],
                    &[],
                );
            }
            // An empty range still runs when clearing, so the image then holds zeros.
            push.view_count = a.views.len() as u32;
            push.accumulate = u32::from(!clear);
            // SAFETY: as above; the push range covers RefocusPush.
            unsafe {
                d.cmd_push_constants(
                    cmd,
                    layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    as_bytes(&[push]),
                );
                // The plain sum's invocations cover `pixels` pixels each along x.
                let (tw, th) = key.shape.tile;
                let across = match (key.shape.pixels, key.antialias, key.surface) {
                    (n @ 1.., 0, 0) => tw * n,
                    _ => tw,
                };
                d.cmd_dispatch(
                    cmd,
                    target.width.div_ceil(across),
                    target.height.div_ceil(th),
                    1,
                );
            }
            return Ok(());
        }
        let load = if clear {
            vk::AttachmentLoadOp::CLEAR
        } else {
            vk::AttachmentLoadOp::LOAD
        };
        let accum = (target.accum.views[0], vk::ImageLayout::GENERAL);
        begin_rendering_in(d, cmd, extent, accum, load, None);
        let layout = self.objects.accum_layout;
        // SAFETY: recording inside a dynamic rendering instance with matching formats.
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                layout,
                0,
                &[input_set],
                &[],
            );
        }
        let batch = match a.strategy {
            Strategy::Batched { views_per_draw } => views_per_draw.max(1),
            _ => a.views.len().max(1),
        };
        let mut first = a.views.start;
        while first < a.views.end {
            let count = batch.min(a.views.end - first);
            push.first_view = first as u32;
            push.view_count = count as u32;
            // SAFETY: as above; the push range covers RefocusPush.
            unsafe {
                d.cmd_push_constants(
                    cmd,
                    layout,
                    vk::ShaderStageFlags::FRAGMENT,
                    0,
                    as_bytes(&[push]),
                );
                d.cmd_draw(cmd, 3, 1, 0, 0);
            }
            first += count;
        }
        // SAFETY: inside the rendering instance begun above.
        unsafe { d.cmd_end_rendering(cmd) };
        Ok(())
    }

    /// Records the resolve of what `target` has accumulated into its `format` output, which is
    /// left in `COLOR_ATTACHMENT_OPTIMAL` after its colour writes; the caller adds the barrier
    /// for its next use (copy, sampling). `averaging` is the space the sums are in.
    pub fn record_resolve(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        target: &RefocusTarget,
        format: OutputFormat,
        averaging: Averaging,
    ) -> Result<()> {
        if !target.accum_ready {
            return Err(Error::Invalid(
                "resolve before any accumulation into this target".into(),
            ));
        }
        let (mode, vk_format) = match (format, averaging) {
            (OutputFormat::Float, _) => (0, vk::Format::R32G32B32A32_SFLOAT),
            (OutputFormat::Srgb8, Averaging::Encoded) => (1, vk::Format::R8G8B8A8_UNORM),
            (OutputFormat::Srgb8, Averaging::Linear) => (2, vk::Format::R8G8B8A8_UNORM),
        };
        let pipeline = self.resolve_pipeline(
            ctx,
            ResolveKey {
                mode,
                format: vk_format,
            },
        )?;
        let d = &ctx.device;
        image_barrier(
            d,
            cmd,
            target.accum.image,
            1,
            ImageTransition {
                from: stage::GENERAL_ANY,
                to: stage::GENERAL_ANY,
            },
        );
        let (out, out_view) = target.output(format);
        image_barrier(
            d,
            cmd,
            out.image,
            1,
            ImageTransition {
                from: stage::DISCARD,
                to: stage::COLOR_WRITE,
            },
        );
        let extent = vk::Extent2D {
            width: target.width,
            height: target.height,
        };
        begin_rendering(
            d,
            cmd,
            extent,
            out_view,
            vk::AttachmentLoadOp::DONT_CARE,
            None,
        );
        // SAFETY: recording inside a rendering instance whose format matches the pipeline.
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.objects.resolve_layout,
                0,
                &[target.resolve_set],
                &[],
            );
            d.cmd_draw(cmd, 3, 1, 0, 0);
            d.cmd_end_rendering(cmd);
        }
        Ok(())
    }

    fn accum_pipeline(&mut self, ctx: &GpuContext, key: AccumKey) -> Result<vk::Pipeline> {
        if let Some((_, p)) = self.accum_pipelines.iter().find(|(k, _)| *k == key) {
            return Ok(*p);
        }
        let constants = [
            key.filter,
            key.texel,
            u32::from(key.uniform_warps),
            key.antialias,
            key.surface,
            u32::from(key.prefilter),
            u32::from(key.occlusion),
            u32::from(key.defocus),
            key.shape.pixels,
            key.shape.unroll,
            key.shape.tile.0,
            key.shape.tile.1,
        ];
        let name = format!(
            "refocus {} pipeline (filter {}, texel {}, {} warps, antialias {}{}{}{}, surface {})",
            if key.compute { "compute" } else { "fragment" },
            key.filter,
            key.texel,
            if key.uniform_warps {
                "uniform"
            } else {
                "storage"
            },
            key.antialias,
            if key.prefilter { " prefiltered" } else { "" },
            if key.occlusion {
                " occlusion-tested"
            } else {
                ""
            },
            if key.defocus { " defocused" } else { "" },
            key.surface
        ) + &if key.compute {
            format!(", {:?}", key.shape)
        } else {
            String::new()
        };
        let pipeline = if key.compute {
            // The storage image's format is part of the shader: one module per format.
            let (spirv, file) = if key.format == accumulation_format(Accumulation::Rgba16f) {
                (shaders::REFOCUS_HALF_COMP, "refocus_half.comp")
            } else {
                (shaders::REFOCUS_COMP, "refocus.comp")
            };
            let module = shaders::module(ctx, spirv, file)?;
            let p = compute_pipeline(ctx, self.objects.compute_layout, module, &constants);
            // SAFETY: pipelines keep their own copy of the code.
            unsafe { ctx.device.destroy_shader_module(module, None) };
            p?
        } else {
            let desc = PipelineDesc {
                blend: Blend::Additive,
                frag_constants: &constants,
                ..PipelineDesc::fullscreen(
                    self.objects.accum_layout,
                    vk::ShaderModule::null(),
                    vk::ShaderModule::null(),
                    key.format,
                )
            };
            fullscreen(ctx, desc, shaders::REFOCUS_FRAG, "refocus.frag")?
        };
        ctx.name(pipeline, &name);
        self.accum_pipelines.push((key, pipeline));
        Ok(pipeline)
    }

    fn resolve_pipeline(&mut self, ctx: &GpuContext, key: ResolveKey) -> Result<vk::Pipeline> {
        if let Some((_, p)) = self.resolve_pipelines.iter().find(|(k, _)| *k == key) {
            return Ok(*p);
        }
        let constants = [key.mode];
        let desc = PipelineDesc {
            frag_constants: &constants,
            ..PipelineDesc::fullscreen(
                self.objects.resolve_layout,
                vk::ShaderModule::null(),
                vk::ShaderModule::null(),
                key.format,
            )
        };
        let pipeline = fullscreen(ctx, desc, shaders::RESOLVE_FRAG, "resolve.frag")?;
        ctx.name(
            pipeline,
            &format!("resolve pipeline (mode {}, {:?})", key.mode, key.format),
        );
        self.resolve_pipelines.push((key, pipeline));
        Ok(pipeline)
    }

    /// Frees everything (see the module docs for the order). The GPU must be done with it.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: no pending work uses these pipelines.
        unsafe {
            let accum = self.accum_pipelines.iter().map(|(_, p)| p);
            for p in accum.chain(self.resolve_pipelines.iter().map(|(_, p)| p)) {
                ctx.device.destroy_pipeline(*p, None);
            }
        }
        self.objects.destroy(ctx);
        self.warps.destroy(ctx);
        self.decode.destroy(ctx);
        self.footprints.destroy(ctx);
        self.scene_depth.destroy(ctx);
        self.visibility.destroy(ctx);
        self.surface.destroy(ctx);
        if let Some(stage) = self.defocus {
            stage.destroy(ctx);
        }
    }
}

/// Debug name of the visibility buffer.
const VISIBILITY: &str = "anti-aliasing view visibility";

/// The descriptor write binding `info` (the visibility buffer) to binding 8 of `set`.
fn visibility_write<'a>(
    set: vk::DescriptorSet,
    info: &'a [vk::DescriptorBufferInfo; 1],
) -> vk::WriteDescriptorSet<'a> {
    vk::WriteDescriptorSet::default()
        .dst_set(set)
        .dst_binding(8)
        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
        .buffer_info(info)
}

/// Creates a fullscreen pipeline of `desc` with `fullscreen.vert` and the fragment shader
/// `spirv`, freeing the modules afterwards.
fn fullscreen(
    ctx: &GpuContext,
    mut desc: PipelineDesc,
    spirv: &[u8],
    name: &str,
) -> Result<vk::Pipeline> {
    let vert = shaders::module(ctx, shaders::FULLSCREEN_VERT, "fullscreen.vert")?;
    let frag = match shaders::module(ctx, spirv, name) {
        Ok(f) => f,
        Err(e) => {
            // SAFETY: unused module.
            unsafe { ctx.device.destroy_shader_module(vert, None) };
            return Err(e);
        }
    };
    desc.vert = vert;
    desc.frag = frag;
    let p = graphics_pipeline(ctx, &desc);
    // SAFETY: pipelines keep their own copy of the code.
    unsafe {
        ctx.device.destroy_shader_module(vert, None);
        ctx.device.destroy_shader_module(frag, None);
    }
    p
}

/// The Vulkan objects of the pass that are plain handles (null until created). Destroying it
/// frees exactly those that exist, so a failed set-up leaks nothing.
#[derive(Default)]
struct PassObjects {
    sampler_linear: vk::Sampler,
    sampler_nearest: vk::Sampler,
    /// Trilinear over every mip level: anti-aliasing's prefiltered lookup (binding 7). The
    /// other samplers stop at level 0, so the plain sum reads exactly what it read before
    /// the views had levels.
    sampler_mip: vk::Sampler,
    input_set_layout: vk::DescriptorSetLayout,
    resolve_set_layout: vk::DescriptorSetLayout,
    storage_set_layout: vk::DescriptorSetLayout,
    accum_layout: vk::PipelineLayout,
    compute_layout: vk::PipelineLayout,
    resolve_layout: vk::PipelineLayout,
    descriptor_pool: vk::DescriptorPool,
}

impl PassObjects {
    /// Creates samplers, layouts and `input_sets` input descriptor sets.
    fn build(&mut self, ctx: &GpuContext, input_sets: usize) -> Result<Vec<vk::DescriptorSet>> {
        let d = &ctx.device;
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
        let binding = |i: u32, ty, stages| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(i)
                .descriptor_type(ty)
                .descriptor_count(1)
                .stage_flags(stages)
        };
        let shading = vk::ShaderStageFlags::FRAGMENT | vk::ShaderStageFlags::COMPUTE;
        let set_layout = |bindings: &[vk::DescriptorSetLayoutBinding]| {
            // SAFETY: valid device and create info.
            unsafe {
                d.create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(bindings),
                    None,
                )
            }
        };
        let pipeline_layout = |sets: &[vk::DescriptorSetLayout], stages| {
            let push = [vk::PushConstantRange::default()
                .stage_flags(stages)
                .offset(0)
                .size(std::mem::size_of::<RefocusPush>() as u32)];
            let info = vk::PipelineLayoutCreateInfo::default().set_layouts(sets);
            let info = if stages.is_empty() {
                info
            } else {
                info.push_constant_ranges(&push)
            };
            // SAFETY: valid device and create info.
            unsafe { d.create_pipeline_layout(&info, None) }
        };
        // SAFETY: valid device and create infos.
        unsafe {
            self.sampler_linear = d
                .create_sampler(&sampler(vk::Filter::LINEAR), None)
                .vk("vkCreateSampler")?;
            self.sampler_nearest = d
                .create_sampler(&sampler(vk::Filter::NEAREST), None)
                .vk("vkCreateSampler")?;
            self.sampler_mip = d
                .create_sampler(
                    &sampler(vk::Filter::LINEAR)
                        .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
                        .max_lod(vk::LOD_CLAMP_NONE),
                    None,
                )
                .vk("vkCreateSampler")?;
        }
        ctx.name(
            self.sampler_mip,
            "view sampler (trilinear, prefilter levels)",
        );
        ctx.name(self.sampler_linear, "view sampler (bilinear)");
        ctx.name(self.sampler_nearest, "accumulation sampler (nearest)");
        use vk::DescriptorType as T;
        self.input_set_layout = set_layout(&[
            binding(0, T::COMBINED_IMAGE_SAMPLER, shading),
            binding(1, T::STORAGE_BUFFER, shading),
            binding(2, T::UNIFORM_BUFFER, shading),
            binding(3, T::UNIFORM_BUFFER, shading),
            binding(4, T::UNIFORM_BUFFER, shading),
            binding(5, T::STORAGE_BUFFER, shading),
            binding(6, T::UNIFORM_BUFFER, shading),
            binding(7, T::COMBINED_IMAGE_SAMPLER, shading),
            binding(8, T::STORAGE_BUFFER, shading),
            binding(9, T::COMBINED_IMAGE_SAMPLER, shading),
        ])
        .vk("vkCreateDescriptorSetLayout")?;
        self.resolve_set_layout = set_layout(&[binding(
            0,
            T::COMBINED_IMAGE_SAMPLER,
            vk::ShaderStageFlags::FRAGMENT,
        )])
        .vk("vkCreateDescriptorSetLayout")?;
        self.storage_set_layout =
            set_layout(&[binding(0, T::STORAGE_IMAGE, vk::ShaderStageFlags::COMPUTE)])
                .vk("vkCreateDescriptorSetLayout")?;
        self.accum_layout =
            pipeline_layout(&[self.input_set_layout], vk::ShaderStageFlags::FRAGMENT)
                .vk("vkCreatePipelineLayout")?;
        self.compute_layout = pipeline_layout(
            &[self.input_set_layout, self.storage_set_layout],
            vk::ShaderStageFlags::COMPUTE,
        )
        .vk("vkCreatePipelineLayout")?;
        self.resolve_layout =
            pipeline_layout(&[self.resolve_set_layout], vk::ShaderStageFlags::empty())
                .vk("vkCreatePipelineLayout")?;
        let n = input_sets as u32;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: T::COMBINED_IMAGE_SAMPLER,
                descriptor_count: 3 * n,
            },
            vk::DescriptorPoolSize {
                ty: T::STORAGE_BUFFER,
                descriptor_count: 3 * n,
            },
            vk::DescriptorPoolSize {
                ty: T::UNIFORM_BUFFER,
                descriptor_count: 4 * n,
            },
        ];
        // SAFETY: valid device and create info.
        self.descriptor_pool = unsafe {
            d.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(n)
                    .pool_sizes(&sizes),
                None,
            )
        }
        .vk("vkCreateDescriptorPool")?;
        let layouts = vec![self.input_set_layout; input_sets];
        // SAFETY: the pool has room for these sets.
        let sets = unsafe {
            d.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(self.descriptor_pool)
                    .set_layouts(&layouts),
            )
        }
        .vk("vkAllocateDescriptorSets")?;
        Ok(sets)
    }

    fn destroy(self, ctx: &GpuContext) {
        let d = &ctx.device;
        // SAFETY: nothing uses these objects any more; destroying null handles is a no-op.
        unsafe {
            d.destroy_pipeline_layout(self.accum_layout, None);
            d.destroy_pipeline_layout(self.compute_layout, None);
            d.destroy_pipeline_layout(self.resolve_layout, None);
            // Frees the sets allocated from it.
            d.destroy_descriptor_pool(self.descriptor_pool, None);
            d.destroy_descriptor_set_layout(self.input_set_layout, None);
            d.destroy_descriptor_set_layout(self.resolve_set_layout, None);
            d.destroy_descriptor_set_layout(self.storage_set_layout, None);
            d.destroy_sampler(self.sampler_linear, None);
            d.destroy_sampler(self.sampler_nearest, None);
            d.destroy_sampler(self.sampler_mip, None);
        }
    }
}

/// The footprint records of `aa` as the pass uploads them (one per view), so that
/// [`RefocusPass::set_antialias`] and [`RefocusPass::antialias_differs`] build them alike.
fn footprint_records(aa: &AntialiasPlan) -> Vec<GpuFootprint> {
    let visible = aa.visibility.is_some();
    aa.footprints
        .iter()
        .map(|f| GpuFootprint::new(f, visible, aa.guard_px, aa.focus_threshold()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn antialiasing_view_limit_is_the_uniform_buffers() {
        assert_eq!(crate::refocus::antialias::MAX_VIEWS, UBO_WARPS);
    }

    #[test]
    fn sampling_transforms_texels_only_where_the_shader_filters() {
        use Averaging::*;
        use Filter::*;
        let s8 = ViewStorage::Srgb8;
        let l16 = ViewStorage::Linear16;
        assert_eq!(
            sampling(s8, Hardware, Linear),
            (VIEW_SRGB, Texel::AsStored, Hardware)
        );
        assert_eq!(
            sampling(s8, Shader, Linear),
            (VIEW_STORED, Texel::DecodeSrgb, Shader)
        );
        assert_eq!(
            sampling(s8, Nearest, Linear),
            (VIEW_STORED, Texel::DecodeSrgb, Nearest)
        );
        assert_eq!(
            sampling(s8, Hardware, Encoded),
            (VIEW_STORED, Texel::AsStored, Hardware)
        );
        assert_eq!(
            sampling(l16, Hardware, Linear),
            (VIEW_STORED, Texel::AsStored, Hardware)
        );
        assert_eq!(
            sampling(l16, Hardware, Encoded),
            (VIEW_STORED, Texel::EncodeSrgb, Shader)
        );
        assert_eq!(
            sampling(l16, Nearest, Encoded),
            (VIEW_STORED, Texel::EncodeSrgb, Nearest)
        );
    }
}
