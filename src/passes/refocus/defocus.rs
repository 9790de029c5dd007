//! The defocus stage of the refocus pass (`shaders/defocus.comp`; the method is
//! [`crate::refocus::defocus`]): before an anti-aliased accumulation with defocused views,
//! three compute dispatches build each view's summed-area table (rows, then columns) and
//! box-filter the view over its footprints into the *defocused views*, which the accumulation
//! samples at binding 9 of its input set (with its own bilinear sampler).
//!
//! Both images keep one layer per view of the uploaded plan (the footprints' map index) and
//! live in `GENERAL` layout from creation on: written as storage images here, sampled by the
//! accumulation and by the box stage. The stage grows them when a plan has more views than
//! they hold; the caller then rewrites binding 9 of its input sets
//! ([`DefocusStage::sampled_info`]).

use std::ops::Range;

use ash::vk;

use super::compute_stage;
use super::interface::RefocusPush;
use crate::error::{Error, Result};
use crate::gpu::commands::{image_barrier, memory_barrier, stage, ImageTransition, Submission};
use crate::gpu::pipeline::{self, compute_pipeline};
use crate::gpu::resources::{Image, ImageDesc};
use crate::gpu::{shaders, GpuContext, Owned};

/// The summed-area tables' format: f32 sums (the table stage subtracts an offset near each
/// view's mean first, so small boxes keep their precision at 512² and beyond). The box stage
/// reads them with `imageLoad` and interpolates in f32 itself: exact weights (a sampler snaps
/// them to 8 bits) and no need for linear filtering of f32 images, which is optional.
const SAT_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
/// The defocused views' format (filtered by every Vulkan device, storable by every one).
const DEFOCUSED_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
const TILE: u32 = 8;

/// Which shader variant: the accumulation's sampling constants that the stage shares
/// (`FILTER`, `TEXEL`, `UNIFORM_WARPS`, `SURFACE`) and the stage itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DefocusKey {
    pub filter: u32,
    pub texel: u32,
    pub uniform_warps: bool,
    pub surface: u32,
}

/// The images, descriptors and pipelines of the defocus stage.
pub struct DefocusStage {
    pipelines: Vec<((DefocusKey, u32), Owned<vk::Pipeline>)>,
    layout: Owned<vk::PipelineLayout>,
    _pool: Owned<vk::DescriptorPool>,
    _set_layout: Owned<vk::DescriptorSetLayout>,
    set: vk::DescriptorSet,
    size: (u32, u32),
    /// Views the images hold (layers).
    capacity: u32,
    sat: Option<Image>,
    defocused: Option<Image>,
    /// What each layer's summed-area table holds: the texture layer and the texel transform
    /// it was built from (`None`: nothing valid). The tables depend on the views alone, so
    /// they are built once, not per frame.
    tables: Vec<Option<(u32, u32)>>,
}

impl DefocusStage {
    /// The stage for views of `size`, its pipelines laid out after the accumulation's input
    /// set (`input_layout`, set 0), with room for one view until [`DefocusStage::reserve`].
    pub fn new(
        ctx: &GpuContext,
        input_layout: vk::DescriptorSetLayout,
        size: (u32, u32),
    ) -> Result<Self> {
        use vk::DescriptorType as T;
        let binding = |i: u32, ty| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(i)
                .descriptor_type(ty)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
        };
        let bindings = [binding(0, T::STORAGE_IMAGE), binding(1, T::STORAGE_IMAGE)];
        let set_layout = pipeline::set_layout(ctx, &bindings, "defocus set layout")?;
        let sizes = [vk::DescriptorPoolSize {
            ty: T::STORAGE_IMAGE,
            descriptor_count: 2,
        }];
        let pool = pipeline::descriptor_pool(ctx, 1, &sizes, "defocus descriptors")?;
        let set = pipeline::allocate_sets(ctx, *pool, &[*set_layout])?[0];
        let push = compute_stage::push_range();
        let layout =
            pipeline::pipeline_layout(ctx, &[input_layout, *set_layout], &push, "defocus layout")?;
        let mut stage = DefocusStage {
            pipelines: Vec::new(),
            layout,
            _pool: pool,
            _set_layout: set_layout,
            set,
            size,
            capacity: 0,
            sat: None,
            defocused: None,
            tables: Vec::new(),
        };
        stage.reserve(ctx, 1)?;
        Ok(stage)
    }

    /// Makes room for `views` views (layers), recreating both images when they hold fewer.
    /// Returns whether they were recreated: then binding 9 of the accumulation's input sets
    /// must be rewritten with [`DefocusStage::sampled_info`]. The GPU must not be using them.
    pub fn reserve(&mut self, ctx: &GpuContext, views: u32) -> Result<bool> {
        if views <= self.capacity {
            return Ok(false);
        }
        let (w, h) = self.size;
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::SAMPLED;
        let desc = |format, w, h| ImageDesc {
            layers: views,
            array: true,
            ..ImageDesc::new_2d(format, w, h, usage)
        };
        let sat = Image::new(
            ctx,
            desc(SAT_FORMAT, w + 1, h + 1),
            &[SAT_FORMAT],
            "defocus summed-area tables",
        )?;
        let defocused = Image::new(
            ctx,
            desc(DEFOCUSED_FORMAT, w, h),
            &[DEFOCUSED_FORMAT],
            "defocused views",
        )?;
        // Both live in GENERAL from now on.
        let general = ImageTransition {
            from: stage::UNDEFINED,
            to: (
                vk::ImageLayout::GENERAL,
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::SHADER_SAMPLED_READ
                    | vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        };
        Submission::new(ctx, "defocus image layouts")?.run(ctx, |d, cmd| {
            image_barrier(d, cmd, sat.image, views, general);
            image_barrier(d, cmd, defocused.image, views, general);
        })?;
        self.sat = Some(sat);
        self.defocused = Some(defocused);
        self.capacity = views;
        self.tables = vec![None; views as usize];
        let storage = |img: &Image| {
            [vk::DescriptorImageInfo::default()
                .image_view(img.views[0])
                .image_layout(vk::ImageLayout::GENERAL)]
        };
        let (sat, defocused) = (self.sat.as_ref(), self.defocused.as_ref());
        let (sat, defocused) = (sat.expect("just made"), defocused.expect("just made"));
        let (sat_info, out_info) = (storage(sat), storage(defocused));
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_set(self.set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                .image_info(&sat_info),
            vk::WriteDescriptorSet::default()
                .dst_set(self.set)
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                .image_info(&out_info),
        ];
        // SAFETY: the caller guarantees the GPU is not using the set; the infos reference
        // live images.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
        Ok(true)
    }

    /// The defocused views as the accumulation samples them (binding 9, with `sampler`).
    pub fn sampled_info(&self, sampler: vk::Sampler) -> vk::DescriptorImageInfo {
        vk::DescriptorImageInfo::default()
            .sampler(sampler)
            .image_view(
                self.defocused
                    .as_ref()
                    .map_or(vk::ImageView::null(), |i| i.views[0]),
            )
            .image_layout(vk::ImageLayout::GENERAL)
    }

    /// Forgets the summed-area tables: the views' texels changed (a new frame of a video).
    pub fn invalidate_tables(&mut self) {
        self.tables.iter_mut().for_each(|t| *t = None);
    }

    fn pipeline(&mut self, ctx: &GpuContext, key: DefocusKey, stage: u32) -> Result<vk::Pipeline> {
        if let Some((_, p)) = self.pipelines.iter().find(|(k, _)| *k == (key, stage)) {
            return Ok(**p);
        }
        // The accumulation's constant ids 0-7 (refocus_accumulate.glsl), then STAGE.
        let constants = [
            key.filter,
            key.texel,
            u32::from(key.uniform_warps),
            1,
            key.surface,
            0,
            0,
            1,
            stage,
        ];
        let module = shaders::module(ctx, shaders::DEFOCUS_COMP, "defocus.comp")?;
        let what = ["table rows", "table columns", "box"][stage as usize];
        let name = format!("defocus {what} pipeline ({key:?})");
        let p = compute_pipeline(ctx, *self.layout, *module, &constants, &name)?;
        let raw = *p;
        self.pipelines.push(((key, stage), p));
        Ok(raw)
    }

    /// Records the stages for the uploaded views `views` (their warps and footprints in
    /// `input_set`, the plane and view size in `push`; `layers` their texture layer and map
    /// index each), after whatever sampled the images before and before whatever samples the
    /// defocused views next (compute or fragment). The tables are rebuilt only where a layer
    /// holds another view's or another transform's (the box runs every time: it follows the
    /// plane).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        input_set: vk::DescriptorSet,
        key: DefocusKey,
        push: RefocusPush,
        views: Range<usize>,
        layers: &[(u32, u32)],
    ) -> Result<()> {
        if views.is_empty() {
            return Ok(());
        }
        if layers.len() != views.len() || layers.iter().any(|&(_, map)| map >= self.capacity) {
            return Err(Error::Invalid(format!(
                "defocused views: {} layers for {} views, room for {}",
                layers.len(),
                views.len(),
                self.capacity
            )));
        }
        let stale = layers
            .iter()
            .any(|&(layer, map)| self.tables[map as usize] != Some((layer, key.texel)));
        for &(layer, map) in layers {
            self.tables[map as usize] = Some((layer, key.texel));
        }
        let pipelines = [
            self.pipeline(ctx, key, 0)?,
            self.pipeline(ctx, key, 1)?,
            self.pipeline(ctx, key, 2)?,
        ];
        let d = &ctx.device;
        let push = RefocusPush {
            first_view: views.start as u32,
            view_count: views.len() as u32,
            ..push
        };
        let (w, h) = self.size;
        let n = views.len() as u32;
        let dispatches = [
            (pipelines[0], [(h + 1).div_ceil(TILE), 1, n]),
            (pipelines[1], [(w + 1).div_ceil(TILE), 1, n]),
            (pipelines[2], [w.div_ceil(TILE), h.div_ceil(TILE), n]),
        ];
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let shaders = S::COMPUTE_SHADER | S::FRAGMENT_SHADER;
        let any = A::SHADER_SAMPLED_READ | A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE;
        // Earlier samplings (the previous frame's accumulation) before these writes.
        memory_barrier(d, cmd, (shaders, any), (S::COMPUTE_SHADER, any));
        // The tables (the first two dispatches) only when the views changed.
        let first = if stale { 0 } else { 2 };
        let between = (
            (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE),
            (S::COMPUTE_SHADER, any),
        );
        let sets = [input_set, self.set];
        let chain = &dispatches[first..];
        compute_stage::record_chain(d, cmd, *self.layout, &sets, &push, chain, between);
        memory_barrier(
            d,
            cmd,
            (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE),
            (shaders, A::SHADER_SAMPLED_READ),
        );
        Ok(())
    }
}
