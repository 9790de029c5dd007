//! The plane-sweep depth pass: photo-consistency costs of frontoparallel planes, edge-aware
//! aggregation and a streamed winner-take-all, in compute shaders (`depth_cost.comp`,
//! `depth_box.comp`, `depth_wta.comp`; the maths in [`crate::depth`]).
//!
//! The planes are processed in chunks, one submission each (a progress bar step): the cost of
//! every plane of the chunk, its aggregation (guided filter: two box filters, each a row pass
//! and a column pass with running sums; or one box filter; or none), then the winner-take-all
//! state of every pixel is updated from the chunk's aggregated costs. Only a chunk of the cost
//! volume is ever held, so memory is bounded by the chunk, not the plane count. A last dispatch
//! turns the state into the result, which is read back.
//!
//! Views are read from a storage buffer of packed RGBA8 texels with bilinear filtering in the
//! shader: llvmpipe's sampler path is far slower than plain loads, and the sweep reads
//! `planes × views` samples per pixel.
//!
//! Everything frees itself when the sweep is done, in field order: buffers → timestamps →
//! pipelines → pipeline layout → descriptor pool (frees the set) → set layout.

pub mod interface;

use ash::vk;
use image::RgbaImage;
use indicatif::ProgressBar;

pub use interface::{DepthPush, GpuSweepView};

use crate::depth::guide::{guide_pixels, GuidePixel};
use crate::depth::sweep::SweepPlan;
use crate::depth::{Aggregation, CostKind, Refine, SweepOutput, SweepParams};
use crate::error::{Error, Result};
use crate::gpu::commands::{memory_barrier, Submission};
use crate::gpu::pipeline::{self, compute_pipeline};
use crate::gpu::pod::{as_bytes, Pod};
use crate::gpu::resources::Buffer;
use crate::gpu::shaders;
use crate::gpu::timing::Timestamps;
use crate::gpu::{GpuContext, Owned};

/// Workgroup edge of `depth_cost.comp`.
const COST_TILE: u32 = 8;
/// Workgroup size of `depth_box.comp` and `depth_wta.comp`.
const LINE_GROUP: u32 = 64;
/// Target size of the largest per-chunk buffer (the box filter's vec4 row sums).
const CHUNK_BYTES: u64 = 64 << 20;
/// Most planes per chunk (one submission, one progress step).
const MAX_CHUNK: usize = 16;

/// Bytes of the per-pixel winner-take-all state (`WtaState`: two vec4).
const STATE_BYTES: u64 = 32;

/// Records of the uniform-buffer copy of the view records (`UBO_VIEWS` in
/// `depth_interface.glsl`): sweeps of at most this many views read them there.
pub const UBO_VIEWS: usize = 160;

/// Runs the sweep of `plan` on `images` (`images[0]` the reference view, then the matched
/// views in plan order) with `params`. Returns the per-pixel result and the GPU time summed
/// over the submissions (`None` without timestamps). `progress` advances by planes.
pub fn run_sweep(
    ctx: &GpuContext,
    plan: &SweepPlan,
    images: &[&RgbaImage],
    params: &SweepParams,
    progress: &ProgressBar,
) -> Result<(SweepOutput, Option<f64>)> {
    SweepPass::default().run(ctx, plan, images, params, progress)
}

/// Buffers, pipelines and descriptors of one sweep, made as the sweep sets up (so a failed
/// set-up frees exactly what it made).
#[derive(Default)]
struct SweepPass {
    buffers: Vec<Buffer>,
    timestamps: Option<Timestamps>,
    /// Per [`Stage`]; `None` for the stages the aggregation does not use.
    pipelines: Vec<Option<Owned<vk::Pipeline>>>,
    layout: Option<Owned<vk::PipelineLayout>>,
    pool: Option<Owned<vk::DescriptorPool>>,
    set_layout: Option<Owned<vk::DescriptorSetLayout>>,
}

/// Index of the result buffer in `SweepPass::buffers` (= its binding; the buffers are bound
/// in the order of `depth_interface.glsl`: texels, views, guide, costs, row sums,
/// coefficients, state, result, history, then the views' uniform copy).
const RESULT: usize = 7;
/// Binding of the uniform buffer (every other binding is a storage buffer).
const VIEWS_UNIFORM: usize = 9;

/// The pipelines, in `SweepPass::pipelines` order.
#[derive(Clone, Copy)]
enum Stage {
    Cost = 0,
    RowsProducts = 1,
    RowsCoeffs = 2,
    RowsPlain = 3,
    ColumnsCoeffs = 4,
    ColumnsGuided = 5,
    ColumnsPlain = 6,
    WtaUpdate = 7,
    WtaFinish = 8,
}

impl SweepPass {
    fn run(
        &mut self,
        ctx: &GpuContext,
        plan: &SweepPlan,
        images: &[&RgbaImage],
        params: &SweepParams,
        progress: &ProgressBar,
    ) -> Result<(SweepOutput, Option<f64>)> {
        let (w, h) = (plan.width, plan.height);
        if images.len() != plan.views.len() + 1 || images.iter().any(|i| i.dimensions() != (w, h)) {
            return Err(Error::Invalid(
                "the sweep needs the reference and every matched view at the plan's size".into(),
            ));
        }
        let n = w as u64 * h as u64;
        let limit = ctx.properties.limits.max_storage_buffer_range as u64;
        let texel_bytes = n * 4 * images.len() as u64;
        let history_bytes = n * 4 * plan.confidence_gap() as u64;
        if texel_bytes > limit
            || n * 64 > limit
            || history_bytes > limit
            || texel_bytes > u32::MAX as u64
        {
            return Err(Error::DeviceLimit(format!(
                "{} views of {w}×{h} need {:.0} MiB in one storage buffer but {} allows {:.0} MiB \
                 (maxStorageBufferRange); match fewer views (--views cross) or use smaller views",
                images.len(),
                texel_bytes as f64 / 1048576.0,
                ctx.info.name,
                limit as f64 / 1048576.0
            )));
        }
        let chunk = ((CHUNK_BYTES.min(limit) / (n * 16)) as usize).clamp(1, MAX_CHUNK);
        let chunk = chunk.min(plan.planes);

        // Inputs: texels (the reference first), view records, guide data.
        let mut texels = Vec::with_capacity(texel_bytes as usize);
        for img in images {
            texels.extend_from_slice(img.as_raw());
        }
        let records: Vec<GpuSweepView> = plan
            .views
            .iter()
            .enumerate()
            .map(|(i, v)| GpuSweepView::new(v, ((i + 1) as u64 * n) as u32))
            .collect();
        let guide: Vec<GuidePixel> = match params.aggregation {
            Aggregation::Guided => guide_pixels(images[0], params.radius as usize, params.eps),
            _ => Vec::new(),
        };
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let inputs: [(&[u8], &str); 3] = [
            (&texels, "depth texels"),
            (bytes_or_empty(&records), "depth views"),
            (bytes_or_empty(&guide), "depth guide"),
        ];
        for (bytes, name) in inputs {
            let b = self.device_buffer(ctx, bytes.len().max(4) as u64, storage, name)?;
            self.buffers.push(b);
        }
        upload(
            ctx,
            &self.buffers[..3],
            &[&texels, bytes_or_empty(&records), bytes_or_empty(&guide)],
        )?;
        let guided = params.aggregation == Aggregation::Guided;
        let sizes = [
            (chunk as u64 * n * 4, "depth costs"),
            (chunk as u64 * n * 16, "depth row sums"),
            (
                if guided { chunk as u64 * n * 16 } else { 16 },
                "depth guided coefficients",
            ),
            (n * STATE_BYTES, "depth winner state"),
        ];
        let gap = plan.confidence_gap();
        for (size, name) in sizes {
            let b = self.device_buffer(ctx, size, storage, name)?;
            self.buffers.push(b);
        }
        self.buffers
            .push(Buffer::new(ctx, n * 16, storage, true, "depth result")?);
        let history = self.device_buffer(ctx, n * 4 * gap as u64, storage, "depth cost history")?;
        self.buffers.push(history);
        // The uniform copy is always bound whole (the block's declared size), and read only
        // where every record fits.
        let mut uniform_records = records.clone();
        uniform_records.resize(UBO_VIEWS, GpuSweepView::default());
        let uniform_views = records.len() <= UBO_VIEWS;
        self.buffers.push(Buffer::with_bytes(
            ctx,
            as_bytes(&uniform_records),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            "depth views (uniform)",
        )?);
        self.timestamps = Timestamps::new(ctx, 2)?;
        let set = self.descriptors(ctx)?;
        let translation = plan.views.iter().all(|v| v.is_translation())
            && std::env::var_os("TILTFIELD_DEPTH_GENERAL").is_none();
        self.pipelines(ctx, params, translation, uniform_views)?;

        let mut push = DepthPush {
            width: w,
            height: h,
            view_count: plan.views.len() as u32,
            ref_texel: 0,
            p0: plan.range.0 as f32,
            dp: plan.step() as f32,
            plane_first: 0,
            plane_count: 0,
            radius: params.radius,
            truncation: params.truncation as f32,
            conf_eps: params.conf_eps as f32,
            conf_gap: gap as u32,
        };
        let submission = Submission::new(ctx, "depth sweep")?;
        let mut gpu_ms = Some(0.0);
        let mut first = 0;
        while first < plan.planes {
            let count = chunk.min(plan.planes - first);
            push.plane_first = first as u32;
            push.plane_count = count as u32;
            let last = first + count == plan.planes;
            submission.run(ctx, |d, cmd| {
                self.record_chunk(d, cmd, set, &push, params, last);
            })?;
            gpu_ms = match (&self.timestamps, gpu_ms) {
                (Some(ts), Some(total)) => ts.read_ms(ctx)?.map(|ms| total + ms[0]),
                _ => None,
            };
            first += count;
            progress.inc(count as u64);
        }

        let out = &mut self.buffers[RESULT];
        out.invalidate(ctx)?;
        let values = crate::gpu::resources::rgba_f32(&out.bytes_mut()[..(n * 16) as usize], 1.0);
        Ok((
            SweepOutput {
                index: values.iter().map(|v| v[0]).collect(),
                confidence: values.iter().map(|v| v[1]).collect(),
                best_cost: values.iter().map(|v| v[2]).collect(),
            },
            gpu_ms,
        ))
    }

    /// Records one chunk: cost, aggregation, winner-take-all update (and on the `last`
    /// chunk the result), each dispatch behind a compute → compute barrier.
    fn record_chunk(
        &self,
        d: &ash::Device,
        cmd: vk::CommandBuffer,
        set: vk::DescriptorSet,
        push: &DepthPush,
        params: &SweepParams,
        last: bool,
    ) {
        let all = vk::PipelineStageFlags2::ALL_COMMANDS;
        if let Some(ts) = &self.timestamps {
            ts.reset(d, cmd);
            ts.write(d, cmd, all, 0);
        }
        let (w, h, k) = (push.width, push.height, push.plane_count);
        let n = w * h;
        let layout = self.layout.as_deref().copied().unwrap_or_default();
        // SAFETY: recording outside a rendering instance; the set matches the layout.
        unsafe {
            d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, layout, 0, &[set], &[]);
            d.cmd_push_constants(
                cmd,
                layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                as_bytes(std::slice::from_ref(push)),
            );
        }
        let dispatch = |stage: Stage, groups: (u32, u32)| {
            compute_barrier(d, cmd);
            // The aggregation only dispatches the stages it made pipelines for.
            let pipeline = self.pipelines[stage as usize]
                .as_deref()
                .copied()
                .unwrap_or_default();
            // SAFETY: recording; the pipeline uses the bound layout and push range.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
                d.cmd_dispatch(cmd, groups.0, groups.1, 1);
            }
        };
        dispatch(Stage::Cost, (w.div_ceil(COST_TILE), h.div_ceil(COST_TILE)));
        let rows = (h.div_ceil(LINE_GROUP), k);
        let cols = (w.div_ceil(LINE_GROUP), k);
        match params.aggregation {
            Aggregation::Guided => {
                dispatch(Stage::RowsProducts, rows);
                dispatch(Stage::ColumnsCoeffs, cols);
                dispatch(Stage::RowsCoeffs, rows);
                dispatch(Stage::ColumnsGuided, cols);
            }
            Aggregation::Box => {
                dispatch(Stage::RowsPlain, rows);
                dispatch(Stage::ColumnsPlain, cols);
            }
            Aggregation::None => {}
        }
        dispatch(Stage::WtaUpdate, (n.div_ceil(LINE_GROUP), 1));
        if last {
            dispatch(Stage::WtaFinish, (n.div_ceil(LINE_GROUP), 1));
            memory_barrier(
                d,
                cmd,
                (
                    vk::PipelineStageFlags2::COMPUTE_SHADER,
                    vk::AccessFlags2::SHADER_STORAGE_WRITE,
                ),
                (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
            );
        }
        if let Some(ts) = &self.timestamps {
            ts.write(d, cmd, all, 1);
        }
    }

    /// A device-local storage buffer that uploads can copy into.
    fn device_buffer(
        &self,
        ctx: &GpuContext,
        size: u64,
        usage: vk::BufferUsageFlags,
        name: &str,
    ) -> Result<Buffer> {
        Buffer::new(
            ctx,
            size,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            false,
            name,
        )
    }

    /// The descriptor set layout (9 storage buffers and a uniform one), pipeline layout, pool
    /// and the one set.
    fn descriptors(&mut self, ctx: &GpuContext) -> Result<vk::DescriptorSet> {
        let kind = |i: usize| {
            if i == VIEWS_UNIFORM {
                vk::DescriptorType::UNIFORM_BUFFER
            } else {
                vk::DescriptorType::STORAGE_BUFFER
            }
        };
        let bindings: Vec<_> = (0..self.buffers.len() as u32)
            .map(|i| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i)
                    .descriptor_type(kind(i as usize))
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let set_layout = pipeline::set_layout(ctx, &bindings, "depth sweep set layout")?;
        let push = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .offset(0)
            .size(std::mem::size_of::<DepthPush>() as u32)];
        let layout =
            pipeline::pipeline_layout(ctx, &[*set_layout], &push, "depth sweep pipeline layout")?;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_BUFFER,
                descriptor_count: bindings.len() as u32 - 1,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::UNIFORM_BUFFER,
                descriptor_count: 1,
            },
        ];
        let pool = pipeline::descriptor_pool(ctx, 1, &sizes, "depth sweep descriptors")?;
        let set = pipeline::allocate_sets(ctx, *pool, &[*set_layout])?[0];
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = self
            .buffers
            .iter()
            .map(|b| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(b.buffer)
                    .offset(0)
                    .range(vk::WHOLE_SIZE)]
            })
            .collect();
        let writes: Vec<_> = infos
            .iter()
            .enumerate()
            .map(|(i, info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(i as u32)
                    .descriptor_type(kind(i))
                    .buffer_info(info)
            })
            .collect();
        // SAFETY: a new, unused set; the infos reference live buffers.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
        self.set_layout = Some(set_layout);
        self.layout = Some(layout);
        self.pool = Some(pool);
        Ok(set)
    }

    /// The nine pipelines of [`Stage`], specialised for `params`.
    fn pipelines(
        &mut self,
        ctx: &GpuContext,
        params: &SweepParams,
        translation: bool,
        uniform_views: bool,
    ) -> Result<()> {
        let cost = match params.cost {
            CostKind::Robust => 0,
            CostKind::Mean => 1,
            CostKind::DropWorst => 2,
        };
        let stages: [(&[u8], &str, u32); 9] = [
            (shaders::DEPTH_COST_COMP, "depth cost", cost),
            (shaders::DEPTH_BOX_COMP, "depth rows (p, pI)", 0),
            (shaders::DEPTH_BOX_COMP, "depth rows (a, b)", 1),
            (shaders::DEPTH_BOX_COMP, "depth rows (p)", 2),
            (shaders::DEPTH_BOX_COMP, "depth columns → a, b", 3),
            (shaders::DEPTH_BOX_COMP, "depth columns → guided cost", 4),
            (shaders::DEPTH_BOX_COMP, "depth columns → box cost", 5),
            (shaders::DEPTH_WTA_COMP, "depth winner update", 0),
            (shaders::DEPTH_WTA_COMP, "depth winner result", 1),
        ];
        let needed = |i: usize| match params.aggregation {
            Aggregation::Guided => ![3, 6].contains(&i),
            Aggregation::Box => ![1, 2, 4, 5].contains(&i),
            Aggregation::None => ![1, 2, 3, 4, 5, 6].contains(&i),
        };
        let layout = self.layout.as_deref().copied().unwrap_or_default();
        for (i, (spirv, name, constant)) in stages.into_iter().enumerate() {
            if !needed(i) {
                // Never bound: `None` keeps the indices of `Stage`.
                self.pipelines.push(None);
                continue;
            }
            let module = shaders::module(ctx, spirv, name)?;
            let second = match i {
                0 => u32::from(translation),
                8 => u32::from(params.refine == Refine::Equiangular),
                _ => 0,
            };
            let constants = [constant, second, u32::from(uniform_views)];
            let name = format!("{name} pipeline");
            let p = compute_pipeline(ctx, layout, *module, &constants, &name)?;
            self.pipelines.push(Some(p));
        }
        Ok(())
    }
}

/// The bytes of `values`, or none for an empty slice.
fn bytes_or_empty<T: Pod>(values: &[T]) -> &[u8] {
    as_bytes(values)
}

/// Copies `data[i]` into `buffers[i]` through one staging buffer and one submission, and makes
/// the copies visible to compute shaders.
fn upload(ctx: &GpuContext, buffers: &[Buffer], data: &[&[u8]]) -> Result<()> {
    let total: u64 = data.iter().map(|b| b.len() as u64).sum();
    let mut staging = Buffer::new(
        ctx,
        total.max(4),
        vk::BufferUsageFlags::TRANSFER_SRC,
        true,
        "depth staging",
    )?;
    let mut offsets = Vec::with_capacity(data.len());
    let mut at = 0usize;
    {
        let dst = staging.bytes_mut();
        for bytes in data {
            dst[at..at + bytes.len()].copy_from_slice(bytes);
            offsets.push(at as u64);
            at += bytes.len();
        }
    }
    Submission::new(ctx, "depth upload")?.run(ctx, |d, cmd| {
        for ((buffer, bytes), offset) in buffers.iter().zip(data).zip(&offsets) {
            if bytes.is_empty() {
                continue;
            }
            let region = [vk::BufferCopy {
                src_offset: *offset,
                dst_offset: 0,
                size: bytes.len() as u64,
            }];
            // SAFETY: recording; both buffers hold the region.
            unsafe { d.cmd_copy_buffer(cmd, staging.buffer, buffer.buffer, &region) };
        }
        let barrier = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ)];
        // SAFETY: recording outside a rendering instance.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&barrier),
            )
        };
    })
}

/// Compute writes (and everything before) finish before later compute reads and writes.
fn compute_barrier(d: &ash::Device, cmd: vk::CommandBuffer) {
    let barrier = [vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
        )];
    // SAFETY: recording outside a rendering instance.
    unsafe {
        d.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().memory_barriers(&barrier),
        )
    };
}
