//! The refocus pass: generalized shift-and-sum on the GPU.
//!
//! Every view is warped by its homography `H_i = A_i + b_i mᵀ`, sampled from the view array
//! texture, masked (behind camera i, outside its image) and its weighted colour and weight are
//! summed into a float accumulation image; a resolve divides by the weight sum into the output.
//!
//! The pass owns what is shared by every frame of one light field: pipelines
//! ([`pipelines`]), samplers and layouts ([`layouts`]), the descriptor sets of the view texture
//! ([`descriptors`]) and the inputs it uploads ([`inputs`]). It records into command buffers and targets
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
//! Everything frees itself when the pass is dropped, pipelines first; targets are the caller's.

mod boxed;
mod compute_stage;
mod defocus;
mod descriptors;
mod inputs;
mod interface;
mod layered;
mod layouts;
mod pipelines;
mod target;

use std::ops::Range;

use ash::vk;

use crate::gpu::pod::as_bytes;
use boxed::{BoxedKey, BoxedStage};
use defocus::{DefocusKey, DefocusStage};
use inputs::{AntialiasInputs, SceneDepthInput, SurfaceInputs, ViewInputs};
pub use interface::{GpuFootprint, GpuSurface, GpuViewWarp, RefocusPush};
use layered::{GpuLayerParams, LayeredKey, LayeredStage};
use layouts::PassLayouts;
use pipelines::{AccumKey, Pipelines, ResolveKey};
pub use target::RefocusTarget;

use super::texture::{LightFieldTexture, VIEW_SRGB, VIEW_STORED};
use crate::error::{Error, Result};
use crate::gpu::commands::{
    begin_rendering, begin_rendering_in, image_barrier, stage, ImageTransition,
};
use crate::gpu::GpuContext;
use crate::refocus::antialias::AntialiasPlan;
use crate::refocus::settings::{
    Accumulation, Filter, OutputFormat, Strategy, ViewStorage, WarpMemory, UBO_WARPS,
};
use crate::refocus::surface::{SurfacePlan, SurfaceRule};
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

/// The refocus pass for one view texture: its pipelines, descriptor table and inputs.
pub struct RefocusPass {
    /// First, so the pipelines go before the layouts they were made with.
    pipelines: Pipelines,
    layouts: PassLayouts,
    /// One input set per texture view (index = `VIEW_STORED`, `VIEW_SRGB`).
    input_sets: Vec<vk::DescriptorSet>,
    storage: ViewStorage,
    view_size: [f32; 2],
    views: ViewInputs,
    depth: SceneDepthInput,
    antialias: AntialiasInputs,
    surface: SurfaceInputs,
    /// Box-filters the views before an accumulation with defocused views.
    defocus: DefocusStage,
    /// Bins, boxes and composites an accumulation with layered footprints.
    layered: LayeredStage,
    /// Sums, boxes and decides the pixels it can before an accumulation with boxed footprints.
    boxed: BoxedStage,
    /// Whether `boxed` holds the uploaded plan (false: too many cell shapes, or not asked for).
    boxed_ready: bool,
    /// How the compute strategy's invocations cover the output (see [`ComputeShape`]).
    compute_shape: ComputeShape,
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
        let (w, h) = (texture.width, texture.height);
        let (layouts, input_sets) = PassLayouts::new(ctx, texture.image.views.len())?;
        let views = ViewInputs::new(ctx, texture.layers as usize)?;
        let depth = SceneDepthInput::new(ctx, w, h)?;
        let antialias = AntialiasInputs::new(ctx, w, h, texture.layers)?;
        let surface = SurfaceInputs::new(ctx)?;
        // Binding 9 needs an image from the start: the stage's one-view placeholder.
        let defocus = DefocusStage::new(ctx, *layouts.input_set, (w, h))?;
        let layered = LayeredStage::new(ctx, *layouts.input_set, *layouts.storage_set)?;
        let boxed = BoxedStage::new(ctx, *layouts.input_set, (w, h))?;
        let inputs = descriptors::Inputs {
            views: &texture.image.views,
            linear: *layouts.linear,
            mip: *layouts.mip,
            warps: &views,
            depth: &depth,
            antialias: &antialias,
            surface: &surface,
            defocused: defocus.sampled_info(*layouts.linear),
            boxed: &boxed.results,
        };
        descriptors::write_all(ctx, &input_sets, &inputs);
        Ok(RefocusPass {
            pipelines: Pipelines::default(),
            layouts,
            input_sets,
            storage: texture.storage,
            view_size: [w as f32, h as f32],
            views,
            depth,
            antialias,
            surface,
            defocus,
            layered,
            boxed,
            boxed_ready: false,
            compute_shape: ComputeShape::from_env(),
        })
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
        self.defocus.invalidate_tables();
    }

    /// Where the shaders read the warps from: `None` picks the default for this light field
    /// ([`WarpMemory::for_views`]). The uniform buffer holds at most [`UBO_WARPS`] views; asking
    /// for it with more is an error.
    pub fn set_warp_memory(&mut self, memory: Option<WarpMemory>) -> Result<()> {
        let capacity = self.views.capacity;
        let memory = memory.unwrap_or_else(|| WarpMemory::for_views(capacity));
        if memory == WarpMemory::Uniform && capacity > UBO_WARPS {
            return Err(Error::Invalid(format!(
                "the light field has {capacity} views; a uniform buffer of warps holds at most \
                 {UBO_WARPS}"
            )));
        }
        self.views.memory = memory;
        Ok(())
    }

    /// Where the shaders read the warps from.
    pub fn warp_memory(&self) -> WarpMemory {
        self.views.memory
    }

    /// How the views are stored in the texture this pass reads.
    pub fn storage(&self) -> ViewStorage {
        self.storage
    }

    /// A target of `width × height` for this pass (the caller owns it), summing in RGBA32F
    /// where the device can, else RGBA16F.
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
            (*self.layouts.resolve_set, *self.layouts.storage_set),
            *self.layouts.nearest,
        )
    }

    /// Uploads the per-view warps of `plan`, in plan order. Returns false (and writes nothing)
    /// when they equal what the buffer holds, as after a plane change alone. The GPU must not be
    /// reading the buffer (callers wait for the frames that used it).
    pub fn set_views(&mut self, plan: &RefocusPlan) -> Result<bool> {
        let changed = self.views.set(plan)?;
        if changed {
            // The footprints belonged to the previous views.
            self.antialias.uploaded_footprints.clear();
        }
        Ok(changed)
    }

    /// Uploads the views of `aa.plan` ([`RefocusPass::set_views`]) and anti-aliasing's
    /// footprints and scene depth, for accumulations with `antialias > 0`. Same rules as
    /// `set_views`: the GPU must not be reading the buffers. Returns whether the warps changed.
    pub fn set_antialias(&mut self, ctx: &GpuContext, aa: &AntialiasPlan) -> Result<bool> {
        AntialiasInputs::check(aa)?;
        self.depth.check(&aa.depth)?;
        let changed = self.set_views(&aa.plan)?;
        if self.antialias.set_visibility(ctx, aa)? {
            descriptors::write_visibility(ctx, &self.input_sets, &self.antialias.visibility);
        }
        if aa.settings.layered.on() {
            self.layered.set(ctx, self.layer_params(aa)?)?;
        }
        let boxing = aa.settings.boxes();
        let size = (self.view_size[0] as u32, self.view_size[1] as u32);
        let useful = crate::refocus::boxed::can_box(aa, size);
        self.boxed_ready = boxing && useful && self.boxed.set(ctx, aa)?;
        if aa.settings.defocus && self.defocus.reserve(ctx, aa.plan.views.len() as u32)? {
            let info = self.defocus.sampled_info(*self.layouts.linear);
            descriptors::write_defocused(ctx, &self.input_sets, info);
        }
        self.antialias.set(aa);
        self.depth.set(&aa.depth)?;
        Ok(changed)
    }

    /// Uploads a focus surface's plane terms and its scene depth (the depth anti-aliasing
    /// reads too: with anti-aliasing, `surface` must carry the same depth as the
    /// [`RefocusPass::set_antialias`] plan, see `refocus::surface::surface_for`), for
    /// accumulations with `surface`. Same rules as `set_views`: the GPU must not be reading
    /// the buffers.
    pub fn set_surface(&mut self, surface: &SurfacePlan) -> Result<()> {
        SurfaceInputs::check(surface)?;
        if let Some(depth) = &surface.depth {
            self.depth.set(depth)?;
        }
        self.surface.set(surface);
        Ok(())
    }

    /// Whether [`RefocusPass::set_antialias`] would rewrite anything for `aa`: a caller with
    /// frames in flight waits for them first.
    pub fn antialias_differs(&self, aa: &AntialiasPlan) -> bool {
        self.views_differ(&aa.plan)
            || self.antialias.differ(aa)
            || self.depth.differs(&aa.depth)
            || (aa.settings.layered.on()
                && self
                    .layer_params(aa)
                    .map_or(true, |p| self.layered.differs(&p)))
            || (aa.settings.boxes() && self.boxed.differs(aa))
    }

    /// The layer plan of `aa` at the views' size ([`crate::refocus::layered::LayerPlan`]),
    /// checked against what the stage holds.
    fn layer_params(&self, aa: &AntialiasPlan) -> Result<GpuLayerParams> {
        let (w, h) = (self.view_size[0] as u32, self.view_size[1] as u32);
        let layers = crate::refocus::layered::LayerPlan::new(aa, (w, h));
        layers.check()?;
        let centred: Vec<bool> = aa.footprints.iter().map(|f| f.is_centred()).collect();
        Ok(GpuLayerParams::new(&layers, w * h, aa.guard_px, &centred))
    }

    /// Whether [`RefocusPass::set_views`] would rewrite the warps for `plan`: a caller with
    /// frames in flight waits for them first.
    pub fn views_differ(&self, plan: &RefocusPlan) -> bool {
        self.views.differ(plan)
    }

    /// Number of views uploaded by the last [`RefocusPass::set_views`].
    pub fn view_count(&self) -> usize {
        self.views.uploaded.len()
    }

    /// Records the accumulation of `a.views` into `target` (see the module docs).
    pub fn record_accumulate(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        target: &mut RefocusTarget,
        a: &Accumulate,
    ) -> Result<()> {
        let (key, set_index, push) = self.specialise(ctx, target, a)?;
        let input_set = self.input_sets[set_index];
        if key.antialias > 0 && self.antialias.layered {
            return self.record_layered(ctx, cmd, target, (input_set, key), push, a);
        }
        let pipeline = self.pipelines.accum(ctx, &self.layouts, key)?;
        if key.defocus {
            self.record_defocus(ctx, cmd, input_set, key, push, a)?;
        }
        // The boxed stage decides its pixels over every view at once: the accumulation of the
        // first views (every accumulation's first batch) runs it, later batches read it.
        if key.boxed && a.views.start == 0 {
            let stage_key = BoxedKey {
                filter: key.filter,
                texel: key.texel,
                uniform_warps: key.uniform_warps,
                surface: key.surface,
            };
            self.boxed.record(ctx, cmd, input_set, stage_key, push)?;
        }
        let clear = begin_accumulation(&ctx.device, cmd, target, a.clear);
        if key.compute {
            self.record_compute(ctx, cmd, target, (pipeline, input_set), key, push, a, clear);
        } else {
            self.record_fragment(ctx, cmd, target, (pipeline, input_set), push, a, clear);
        }
        Ok(())
    }

    /// Checks `a` against what is uploaded and `target`, and returns the pipeline's
    /// specialisation, the input set to bind and the push constants (views left to set).
    fn specialise(
        &self,
        ctx: &GpuContext,
        target: &RefocusTarget,
        a: &Accumulate,
    ) -> Result<(AccumKey, usize, RefocusPush)> {
        let uploaded = self.views.uploaded.len();
        if a.views.start > a.views.end || a.views.end > uploaded {
            return Err(Error::Invalid(format!(
                "views {:?} lie outside the {uploaded} uploaded warps",
                a.views
            )));
        }
        let aa = &self.antialias;
        if a.antialias > 0 && aa.uploaded_footprints.len() != uploaded {
            return Err(Error::Invalid(
                "anti-aliased accumulation without the footprints of the uploaded views \
                 (RefocusPass::set_antialias)"
                    .into(),
            ));
        }
        let (rule, plane_count) = match (a.surface, self.surface.uploaded) {
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
        let anti = a.antialias > 0;
        let key = AccumKey {
            compute,
            filter: filter_code(filter),
            texel: texel as u32,
            format: target.accum_format,
            uniform_warps: self.views.memory == WarpMemory::Uniform,
            antialias: a.antialias,
            prefilter: anti && aa.prefilter,
            occlusion: anti && aa.occlusion && !aa.defocus,
            surface: rule as u32,
            defocus: anti && aa.defocus,
            // At the views' size only (the stage's pixels are the reference's), focused on one
            // plane (whose residuals `can_box` bounded).
            boxed: anti
                && aa.boxed
                && self.boxed_ready
                && rule == SurfaceRule::Plane
                && [target.width as f32, target.height as f32] == self.view_size,
            shape: if compute {
                self.compute_shape
            } else {
                ComputeShape::default()
            },
        };
        let push = RefocusPush {
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
            total_views: uploaded as u32,
            // Catmull-Rom for in-focus sub-samples refines the bilinear filters; bicubic has
            // it everywhere and nearest is asked for as it is.
            focused_reach: match filter {
                Filter::Hardware | Filter::Shader if anti => aa.focused_reach,
                _ => 0.0,
            },
            // The layered stage sets its batch's ranges (LayeredStage::record).
            ..RefocusPush::default()
        };
        Ok((key, set_index, push))
    }

    /// Records an accumulation with layered footprints: the layered stage, on the compute
    /// queue whatever the strategy (it writes the accumulation image as a storage image).
    fn record_layered(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        target: &mut RefocusTarget,
        (input_set, key): (vk::DescriptorSet, AccumKey),
        push: RefocusPush,
        a: &Accumulate,
    ) -> Result<()> {
        if key.surface != 0 {
            return Err(Error::Invalid(
                "layered anti-aliasing focuses on one plane; a focus surface needs \
                 --antialias-layered off"
                    .into(),
            ));
        }
        if target.storage_set == vk::DescriptorSet::null() {
            return Err(Error::DeviceLimit(format!(
                "{} cannot store to an {} image, which layered anti-aliasing writes: use \
                 --antialias-layered off",
                ctx.info.name,
                accumulation_of_format(target.accum_format).map_or("accumulation", |a| a.name())
            )));
        }
        let layered_key = LayeredKey {
            filter: key.filter,
            texel: key.texel,
            uniform_warps: key.uniform_warps,
            half: target.accum_format == accumulation_format(Accumulation::Rgba16f),
        };
        let clear = begin_accumulation(&ctx.device, cmd, target, a.clear);
        self.layered.record(
            ctx,
            cmd,
            (input_set, target.storage_set),
            layered_key,
            push,
            a.views.clone(),
            clear,
            (target.width, target.height),
        )
    }

    /// Records the defocus stage for `a.views` (accumulations with defocused views).
    fn record_defocus(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        input_set: vk::DescriptorSet,
        key: AccumKey,
        push: RefocusPush,
        a: &Accumulate,
    ) -> Result<()> {
        let stage_key = DefocusKey {
            filter: key.filter,
            texel: key.texel,
            uniform_warps: key.uniform_warps,
            surface: key.surface,
        };
        let footprints = &self.antialias.uploaded_footprints;
        let layers: Vec<(u32, u32)> = a
            .views
            .clone()
            .map(|k| {
                let (w, f) = (&self.views.uploaded[k], &footprints[k]);
                (w.a0[3] as u32, f.vis[1] as u32)
            })
            .collect();
        self.defocus.record(
            ctx,
            cmd,
            input_set,
            stage_key,
            push,
            a.views.clone(),
            &layers,
        )
    }

    /// One compute dispatch over the output (an empty range still runs when clearing, so the
    /// image then holds zeros).
    #[allow(clippy::too_many_arguments)]
    fn record_compute(
        &self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        target: &RefocusTarget,
        (pipeline, input_set): (vk::Pipeline, vk::DescriptorSet),
        key: AccumKey,
        mut push: RefocusPush,
        a: &Accumulate,
        clear: bool,
    ) {
        let d = &ctx.device;
        let layout = *self.layouts.compute;
        push.view_count = a.views.len() as u32;
        push.accumulate = u32::from(!clear);
        // The plain sum's invocations cover `pixels` pixels each along x.
        let (tw, th) = key.shape.tile;
        let across = match (key.shape.pixels, key.antialias, key.surface) {
            (n @ 1.., 0, 0) => tw * n,
            _ => tw,
        };
        // SAFETY: recording outside a rendering instance; the sets match the layout and the
        // push range covers RefocusPush.
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
            d.cmd_push_constants(
                cmd,
                layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                as_bytes(&[push]),
            );
            d.cmd_dispatch(
                cmd,
                target.width.div_ceil(across),
                target.height.div_ceil(th),
                1,
            );
        }
    }

    /// Fullscreen draws into the accumulation image, one per batch of views.
    #[allow(clippy::too_many_arguments)]
    fn record_fragment(
        &self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        target: &RefocusTarget,
        (pipeline, input_set): (vk::Pipeline, vk::DescriptorSet),
        mut push: RefocusPush,
        a: &Accumulate,
        clear: bool,
    ) {
        let d = &ctx.device;
        let load = if clear {
            vk::AttachmentLoadOp::CLEAR
        } else {
            vk::AttachmentLoadOp::LOAD
        };
        let extent = vk::Extent2D {
            width: target.width,
            height: target.height,
        };
        let accum = (target.accum.views[0], vk::ImageLayout::GENERAL);
        begin_rendering_in(d, cmd, extent, accum, load, None);
        let layout = *self.layouts.accum;
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
        let key = ResolveKey {
            mode,
            format: vk_format,
        };
        let pipeline = self.pipelines.resolve(ctx, &self.layouts, key)?;
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
                *self.layouts.resolve,
                0,
                &[target.resolve_set],
                &[],
            );
            d.cmd_draw(cmd, 3, 1, 0, 0);
            d.cmd_end_rendering(cmd);
        }
        Ok(())
    }
}

/// Orders whatever touched `target`'s accumulation image before (a previous accumulation, a
/// resolve, possibly in an earlier submission) before the next accumulation. Returns whether
/// that accumulation starts from zero: when asked (`clear`) or the image is new.
fn begin_accumulation(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    target: &mut RefocusTarget,
    clear: bool,
) -> bool {
    let from = if target.accum_ready {
        stage::GENERAL_ANY
    } else {
        stage::UNDEFINED
    };
    let clear = clear || !target.accum_ready;
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
    clear
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
