//! The boxed stage of the refocus pass (`shaders/boxed.comp`; the method and its f64 model are
//! [`crate::refocus::boxed`]): before an anti-aliased accumulation at the views' size it sums
//! every pixel's views by cell shape into integer summed-area tables, and decides every pixel
//! it can (the box of its footprint, the focus test's plain sum, the plain sum without depth)
//! into a result buffer that the accumulation reads at binding 10; the other pixels (next to
//! a nearer surface, in focus, small footprints) the accumulation sub-samples as before.
//! Four compute dispatches: sums, rows, columns, boxes.

use ash::vk;

use super::compute_stage;
use super::interface::RefocusPush;
use crate::error::{Error, Result};
use crate::gpu::commands::memory_barrier;
use crate::gpu::pipeline::{self, compute_pipeline};
use crate::gpu::pod::{as_bytes, Pod};
use crate::gpu::resources::Buffer;
use crate::gpu::{shaders, GpuContext, Owned};
use crate::refocus::antialias::AntialiasPlan;
use crate::refocus::boxed::{full_px, ray_px, FRONT_LEVELS, MIN_BOX_PX};
use crate::refocus::layered::{cell_groups, MAX_GROUPS};
use crate::refocus::settings::UBO_WARPS;

const TILE: u32 = 8;
const LINE_GROUP: u32 = 64;

/// The plan as boxed.comp reads it (`BoxParams`, std140).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpuBoxParams {
    /// Group count, whether the front maps are bound (1) or not (0); zw unused.
    pub header: [i32; 4],
    /// The rays' longest parallax (px per unit residual), the smallest boxed footprint (px),
    /// a full cell's footprint px per unit residual, 1 / the plan's total weight.
    pub scale: [f32; 4],
    /// Per group: its footprint px per unit residual along x and y.
    pub units: [[f32; 4]; MAX_GROUPS],
    /// View k's group at `[k / 4][k % 4]`.
    pub group_of: [[u32; 4]; UBO_WARPS / 4],
}

// SAFETY: repr(C), only 4-byte scalars in arrays of four: no padding.
unsafe impl Pod for GpuBoxParams {}

impl GpuBoxParams {
    /// The record of `aa` at the views' size `(w, h)`; `None` when its cells fall into more
    /// shapes than the stage holds (the accumulation then sub-samples every pixel).
    pub fn new(aa: &AntialiasPlan, (w, h): (u32, u32)) -> Option<Self> {
        let (groups, group_of, _) = cell_groups(aa, (w, h));
        if groups.len() > MAX_GROUPS || group_of.len() > UBO_WARPS {
            return None;
        }
        let mut units = [[0f32; 4]; MAX_GROUPS];
        for (u, g) in units.iter_mut().zip(&groups) {
            *u = [g.x as f32, g.y as f32, 0.0, 0.0];
        }
        let mut by_view = [[0u32; 4]; UBO_WARPS / 4];
        for (k, &g) in group_of.iter().enumerate() {
            by_view[k / 4][k % 4] = g as u32;
        }
        let total: f64 = aa.plan.views.iter().map(|v| v.weight).sum();
        let fronts = aa.depth.fronts.len() == FRONT_LEVELS * (w * h) as usize;
        let rays = if aa.settings.occlusion {
            ray_px(aa)
        } else {
            0.0
        };
        Some(GpuBoxParams {
            header: [groups.len() as i32, i32::from(fronts), 0, 0],
            scale: [
                rays as f32,
                MIN_BOX_PX as f32,
                full_px(&groups) as f32,
                if total > 0.0 {
                    (1.0 / total) as f32
                } else {
                    0.0
                },
            ],
            units,
            group_of: by_view,
        })
    }
}

/// Which shader variant: the accumulation's sampling constants the stage shares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoxedKey {
    pub filter: u32,
    pub texel: u32,
    pub uniform_warps: bool,
    pub surface: u32,
}

/// The buffers, descriptors and pipelines of the boxed stage.
pub struct BoxedStage {
    pipelines: Vec<((BoxedKey, u32), Owned<vk::Pipeline>)>,
    layout: Owned<vk::PipelineLayout>,
    _pool: Owned<vk::DescriptorPool>,
    _set_layout: Owned<vk::DescriptorSetLayout>,
    set: vk::DescriptorSet,
    params: Buffer,
    fronts: Buffer,
    /// The tables, grown with the group count.
    tables: Option<Buffer>,
    groups_held: u32,
    /// Per pixel: what the stage decided (binding 10 of the accumulation's input sets).
    pub results: Buffer,
    size: (u32, u32),
    uploaded: Option<GpuBoxParams>,
    uploaded_fronts: Vec<f32>,
}

impl BoxedStage {
    /// The stage for views of `size`, its pipelines laid out after the accumulation's input
    /// set (`input_layout`, set 0).
    pub fn new(
        ctx: &GpuContext,
        input_layout: vk::DescriptorSetLayout,
        size: (u32, u32),
    ) -> Result<Self> {
        let (set_layout, pool, set) = compute_stage::buffer_set(ctx, 3, "boxed")?;
        let push = compute_stage::push_range();
        let layout =
            pipeline::pipeline_layout(ctx, &[input_layout, *set_layout], &push, "boxed layout")?;
        let pixels = size.0 as u64 * size.1 as u64;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let params = Buffer::new(
            ctx,
            std::mem::size_of::<GpuBoxParams>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            true,
            "boxed parameters",
        )?;
        let fronts = Buffer::new(
            ctx,
            4 * FRONT_LEVELS as u64 * pixels.max(1),
            storage,
            true,
            "boxed front maps",
        )?;
        let results = Buffer::new(ctx, 16 * pixels.max(1), storage, false, "boxed results")?;
        let stage = BoxedStage {
            pipelines: Vec::new(),
            layout,
            _pool: pool,
            _set_layout: set_layout,
            set,
            params,
            fronts,
            tables: None,
            groups_held: 0,
            results,
            size,
            uploaded: None,
            uploaded_fronts: Vec::new(),
        };
        Ok(stage)
    }

    /// Uploads `aa`'s record and front maps, growing the tables to its group count. Returns
    /// whether the stage can box `aa` (false: more cell shapes than it holds). The GPU must
    /// not be using the buffers.
    pub fn set(&mut self, ctx: &GpuContext, aa: &AntialiasPlan) -> Result<bool> {
        let Some(params) = GpuBoxParams::new(aa, self.size) else {
            self.uploaded = None;
            return Ok(false);
        };
        let groups = params.header[0].max(1) as u32;
        if self.tables.is_none() || groups > self.groups_held {
            let texels = (self.size.0 as u64 + 1) * (self.size.1 as u64 + 1);
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            self.tables = Some(Buffer::new(
                ctx,
                16 * texels * groups as u64,
                usage,
                false,
                "boxed tables",
            )?);
            self.groups_held = groups;
            self.write_set(ctx);
        }
        if self.uploaded != Some(params) {
            self.params.bytes_mut()[..std::mem::size_of::<GpuBoxParams>()]
                .copy_from_slice(as_bytes(&[params]));
            self.uploaded = Some(params);
        }
        if params.header[1] != 0 && aa.depth.fronts != self.uploaded_fronts {
            let bytes = as_bytes(&aa.depth.fronts);
            self.fronts.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
            self.uploaded_fronts = aa.depth.fronts.clone();
        }
        Ok(true)
    }

    /// Whether [`BoxedStage::set`] would write anything for `aa`.
    pub fn differs(&self, aa: &AntialiasPlan) -> bool {
        let params = GpuBoxParams::new(aa, self.size);
        params != self.uploaded
            || params.is_some_and(|p| p.header[1] != 0 && aa.depth.fronts != self.uploaded_fronts)
    }

    fn write_set(&self, ctx: &GpuContext) {
        let info = |b: &Buffer| {
            [vk::DescriptorBufferInfo::default()
                .buffer(b.buffer)
                .range(vk::WHOLE_SIZE)]
        };
        let Some(tables) = &self.tables else {
            return;
        };
        let infos = [
            info(&self.params),
            info(&self.fronts),
            info(tables),
            info(&self.results),
        ];
        let writes: Vec<_> = infos
            .iter()
            .enumerate()
            .map(|(i, inf)| {
                let ty = if i == 0 {
                    vk::DescriptorType::UNIFORM_BUFFER
                } else {
                    vk::DescriptorType::STORAGE_BUFFER
                };
                vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(i as u32)
                    .descriptor_type(ty)
                    .buffer_info(inf)
            })
            .collect();
        // SAFETY: the caller guarantees the GPU is not using the set; the infos reference
        // live buffers.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
    }

    fn pipeline(&mut self, ctx: &GpuContext, key: BoxedKey, stage: u32) -> Result<vk::Pipeline> {
        if let Some((_, p)) = self.pipelines.iter().find(|(k, _)| *k == (key, stage)) {
            return Ok(**p);
        }
        let (tx, ty) = if stage == 1 || stage == 2 {
            (LINE_GROUP, 1)
        } else {
            (TILE, TILE)
        };
        // The accumulation's constant ids 0-7 (refocus_accumulate.glsl: anti-aliasing on, the
        // focus's rule, no pyramid, no occlusion tests, no defocused views), then STAGE and
        // the workgroup's shape.
        let constants = [
            key.filter,
            key.texel,
            u32::from(key.uniform_warps),
            1,
            key.surface,
            0,
            0,
            0,
            stage,
            tx,
            ty,
        ];
        let module = shaders::module(ctx, shaders::BOXED_COMP, "boxed.comp")?;
        let what = ["sums", "rows", "columns", "boxes"][stage as usize];
        let name = format!("boxed {what} pipeline ({key:?})");
        let p = compute_pipeline(ctx, *self.layout, *module, &constants, &name)?;
        let raw = *p;
        self.pipelines.push(((key, stage), p));
        Ok(raw)
    }

    /// Records the four stages over every uploaded view (`push` as the accumulation's, its
    /// view range ignored), leaving `results` ready for the accumulation's reads.
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        input_set: vk::DescriptorSet,
        key: BoxedKey,
        push: RefocusPush,
    ) -> Result<()> {
        let Some(params) = self.uploaded else {
            return Err(Error::Invalid(
                "boxed accumulation without its plan (RefocusPass::set_antialias)".into(),
            ));
        };
        let pipelines = [
            self.pipeline(ctx, key, 0)?,
            self.pipeline(ctx, key, 1)?,
            self.pipeline(ctx, key, 2)?,
            self.pipeline(ctx, key, 3)?,
        ];
        let d = &ctx.device;
        let (w, h) = self.size;
        let groups = params.header[0].max(1) as u32;
        let dispatches = [
            (pipelines[0], [w.div_ceil(TILE), h.div_ceil(TILE), 1]),
            (pipelines[1], [(h + 1).div_ceil(LINE_GROUP), groups, 1]),
            (pipelines[2], [(w + 1).div_ceil(LINE_GROUP), groups, 1]),
            (pipelines[3], [w.div_ceil(TILE), h.div_ceil(TILE), 1]),
        ];
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let any = A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE;
        let shaders = S::COMPUTE_SHADER | S::FRAGMENT_SHADER;
        // The previous accumulation's reads of the results before these writes.
        memory_barrier(d, cmd, (shaders, any), (S::COMPUTE_SHADER, any));
        let between = ((S::COMPUTE_SHADER, any), (S::COMPUTE_SHADER, any));
        let sets = [input_set, self.set];
        compute_stage::record_chain(d, cmd, *self.layout, &sets, &push, &dispatches, between);
        // The results before the accumulation reads them, in either strategy.
        memory_barrier(
            d,
            cmd,
            (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE),
            (shaders, any),
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::refocus::boxed::{MAX_BOX_PX, QUANT};

    /// The shader's copies of the model's constants, and the record's std140 size.
    #[test]
    fn the_shader_boxes_as_the_model() {
        let glsl = include_str!("../../../shaders/boxed.comp");
        assert!(glsl.contains(&format!("const uint MAX_GROUPS = {MAX_GROUPS}u;")));
        assert!(glsl.contains(&format!("const uint FRONT_LEVELS = {FRONT_LEVELS}u;")));
        assert!(glsl.contains(&format!("const float MAX_BOX_PX = {MAX_BOX_PX:?};")));
        assert!(glsl.contains(&format!("const float QUANT = {QUANT:?};")));
        assert_eq!(
            std::mem::size_of::<GpuBoxParams>(),
            16 * (2 + MAX_GROUPS + UBO_WARPS / 4)
        );
    }
}
