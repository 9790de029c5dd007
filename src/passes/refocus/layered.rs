//! The layered stage of the refocus pass (`shaders/layered.glsl`; the method and its f64
//! model are [`crate::refocus::layered`]): an anti-aliased accumulation with layered
//! footprints bins the views' samples into layers, box-filters each layer along its rows and
//! then its columns, and composites the layers into the accumulation image, four compute
//! dispatches in all.
//!
//! Most of a layer's image is zero (a pixel's views reach a few nodes), so the stage pays for
//! the layers only where they hold something: each pixel records the layers its sums hold and
//! its 8×8 tile's mask gathers them; a layer's first write stores (nothing clears the sums);
//! the boxes run over the tiles within their reach of an occupied one and mark the tiles they
//! wrote; the composite reads only the marked layers. A layer whose box has no width (a node
//! near the focus) is not boxed at all: the composite reads its sums, which share a buffer with
//! the boxes so that either is one load. What is skipped is exactly zero or a copy, so the
//! output is the same as boxing every layer everywhere.
//!
//! The sums (`bins`, per layer and pixel) and the focus test's sums (`stats`) persist between
//! accumulations into the same target, so views can be added batch by batch (the viewer's
//! progressive refinement); every accumulation boxes and composites what has been binned so
//! far, so the accumulation image always holds the composite of the views added.

use std::ops::Range;

use ash::vk;

use super::compute_stage;
use super::interface::RefocusPush;
use crate::error::{Error, Result};
use crate::gpu::commands::memory_barrier;
use crate::gpu::pipeline::{self, compute_pipeline};
use crate::gpu::pod::{as_bytes, Pod};
use crate::gpu::resources::Buffer;
use crate::gpu::{shaders, GpuContext, Owned};
use crate::refocus::layered::{node_px, LayerPlan, MAX_GROUPS, MAX_LAYERS, MAX_NODES};
use crate::refocus::settings::UBO_WARPS;

/// The bin and composite workgroups' side: the occupancy's tiles (`TILE_PX` in layered.glsl).
const TILE: u32 = 8;
const LINE_GROUP: u32 = 64;

// The occupancy holds three 32-bit words of layer bits a tile and stage.
const _: () = assert!(MAX_LAYERS <= 96);

/// The layer plan as the shader reads it (`LayerParams` in layered.glsl, std140).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpuLayerParams {
    /// First node, node count (the residual's range), group count, pixels per layer.
    pub header: [i32; 4],
    /// Footprint px per unit residual and the guard (px); zw unused.
    pub scale: [f32; 4],
    /// The reachable nodes' count (slots); for the host's [`GpuLayerParams::batch_ranges`]
    /// (the shader reads neither), the views whose cell is centred (first in `order`) and all
    /// the plan's views; w unused.
    pub slots: [i32; 4],
    /// A bit per layer (`slot × groups + group`, word `l / 32`): set where its box is zero
    /// wide along both axes (`box_of` in layered.glsl, in the same f32 arithmetic), so the
    /// boxes skip it and the composite reads its sums. Decided once per plan, not per pixel.
    pub sharp: [u32; 4],
    /// Per node j of the range: its footprint in pixels and the next node's (signed), their
    /// slots (−1 where unreachable or past the range).
    pub nodes: [[f32; 4]; MAX_NODES],
    /// Per slot: its node's footprint in pixels, signed.
    pub slot_px: [[f32; 4]; MAX_LAYERS / 4],
    /// Per group: its footprint px per unit residual along x and y.
    pub units: [[f32; 4]; MAX_GROUPS],
    /// View k's group at `[k / 4][k % 4]`.
    pub group_of: [[u32; 4]; UBO_WARPS / 4],
    /// The views in binning order at `[i / 4][i % 4]`: those whose cell's centroid is the view
    /// (its sample is the plain one: no second projection or fetch) ascending, then the others
    /// ascending. The binning loops over each part on its own, so the centred views' loop
    /// carries none of the rim cells' code (llvmpipe runs a branch's both sides; the rim
    /// cells' fetch cost every full cell 6–10 % of backgammon's time).
    pub order: [[u32; 4]; UBO_WARPS / 4],
}

// SAFETY: repr(C), only 4-byte scalars in arrays of four: no padding.
unsafe impl Pod for GpuLayerParams {}

impl GpuLayerParams {
    /// The record of `layers` for `pixels` output pixels, with the plan's guard; `centred[k]`:
    /// view k's cell's centroid is the view itself ([`Footprint::is_centred`]).
    ///
    /// [`Footprint::is_centred`]: crate::refocus::antialias::Footprint::is_centred
    pub fn new(layers: &LayerPlan, pixels: u32, guard_px: f64, centred: &[bool]) -> Self {
        let mut units = [[0f32; 4]; MAX_GROUPS];
        for (u, g) in units.iter_mut().zip(&layers.groups) {
            *u = [g.x as f32, g.y as f32, 0.0, 0.0];
        }
        let mut nodes = [[0f32; 4]; MAX_NODES];
        let slot = |j: usize| layers.slot_of.get(j).copied().unwrap_or(-1) as f32;
        for (j, e) in nodes.iter_mut().enumerate().take(layers.nodes) {
            let at = layers.first + j as i64;
            *e = [
                node_px(at) as f32,
                node_px(at + 1) as f32,
                slot(j),
                slot(j + 1),
            ];
        }
        let mut slot_px = [[0f32; 4]; MAX_LAYERS / 4];
        for (k, &j) in layers.slots.iter().enumerate().take(MAX_LAYERS) {
            slot_px[k / 4][k % 4] = node_px(j) as f32;
        }
        // The shader's box_of: the node's footprint per unit residual times the group's unit,
        // narrowed by the interpolation's variance; zero where e² ≤ 2.
        let scale = layers.px_per_residual as f32;
        let mut sharp = [0u32; 4];
        for (k, &j) in layers.slots.iter().enumerate().take(MAX_LAYERS) {
            let d = node_px(j) as f32 / scale.max(1e-12);
            for (g, u) in units.iter().enumerate().take(layers.groups.len()) {
                let flat = |unit: f32| {
                    let e = d.abs() * unit;
                    e * e - 2.0 <= 0.0
                };
                let l = k * layers.groups.len() + g;
                if l < MAX_LAYERS && flat(u[0]) && flat(u[1]) {
                    sharp[l / 32] |= 1 << (l % 32);
                }
            }
        }
        let mut group_of = [[0u32; 4]; UBO_WARPS / 4];
        for (k, &g) in layers.group_of.iter().enumerate().take(UBO_WARPS) {
            group_of[k / 4][k % 4] = g as u32;
        }
        let views = layers.group_of.len().min(UBO_WARPS);
        let (full, rim): (Vec<usize>, Vec<usize>) =
            (0..views).partition(|&k| centred.get(k).copied().unwrap_or(false));
        let mut order = [[0u32; 4]; UBO_WARPS / 4];
        for (i, &k) in full.iter().chain(&rim).enumerate() {
            order[i / 4][i % 4] = k as u32;
        }
        GpuLayerParams {
            header: [
                layers.first as i32,
                layers.nodes as i32,
                layers.groups.len() as i32,
                pixels as i32,
            ],
            scale: [scale, guard_px as f32, 0.0, 0.0],
            slots: [
                layers.slots.len() as i32,
                full.len() as i32,
                views as i32,
                0,
            ],
            sharp,
            nodes,
            slot_px,
            units,
            group_of,
            order,
        }
    }

    /// The views `views` (a batch) as ranges of the binning order: the centred part's and the
    /// rest's, for [`RefocusPush`]'s `centred_from..rim_to`. Both parts are ascending, so a
    /// range of views is a range of each.
    pub fn batch_ranges(&self, views: &Range<usize>) -> [u32; 4] {
        let (centred, all) = (self.slots[1].max(0) as usize, self.slots[2].max(0) as usize);
        let at = |i: usize| self.order[i / 4][i % 4] as usize;
        let before = |part: Range<usize>, k: usize| part.filter(|&i| at(i) < k).count();
        let c = (
            before(0..centred, views.start),
            before(0..centred, views.end),
        );
        let r = (
            before(centred..all, views.start),
            before(centred..all, views.end),
        );
        [c.0, c.1, centred + r.0, centred + r.1].map(|v| v as u32)
    }

    fn layers(&self) -> u32 {
        (self.slots[0] * self.header[2]) as u32
    }
}

/// Which shader variant: the accumulation's sampling constants the stage shares, and the
/// accumulation image's format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LayeredKey {
    pub filter: u32,
    pub texel: u32,
    pub uniform_warps: bool,
    pub half: bool,
}

/// The buffers, descriptors and pipelines of the layered stage.
pub struct LayeredStage {
    pipelines: Vec<((LayeredKey, u32), Owned<vk::Pipeline>)>,
    layout: Owned<vk::PipelineLayout>,
    _pool: Owned<vk::DescriptorPool>,
    _set_layout: Owned<vk::DescriptorSetLayout>,
    set: vk::DescriptorSet,
    params: Buffer,
    /// Sums and boxes (layers × pixels vec4 each, one buffer), rows (the same), the focus
    /// test's sums (3 per pixel), the layers' occupancy (a mask per stage and tile) and the
    /// layers each pixel's sums hold.
    bins: Option<[Buffer; 5]>,
    /// Layers × pixels the buffers hold.
    capacity: (u32, u32),
    uploaded: Option<GpuLayerParams>,
    /// The accumulation image whose views the sums hold (its storage set; null after the
    /// buffers were made or the plan changed: the next accumulation starts from zero).
    binned_for: vk::DescriptorSet,
}

impl LayeredStage {
    /// The stage, its pipelines laid out after the accumulation's input set (`input_layout`,
    /// set 0) and its storage image (`storage_layout`, set 1).
    pub fn new(
        ctx: &GpuContext,
        input_layout: vk::DescriptorSetLayout,
        storage_layout: vk::DescriptorSetLayout,
    ) -> Result<Self> {
        let (set_layout, pool, set) = compute_stage::buffer_set(ctx, 5, "layered")?;
        let push = compute_stage::push_range();
        let layout = pipeline::pipeline_layout(
            ctx,
            &[input_layout, storage_layout, *set_layout],
            &push,
            "layered layout",
        )?;
        let params = Buffer::new(
            ctx,
            std::mem::size_of::<GpuLayerParams>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            true,
            "layered parameters",
        )?;
        Ok(LayeredStage {
            pipelines: Vec::new(),
            layout,
            _pool: pool,
            _set_layout: set_layout,
            set,
            params,
            bins: None,
            capacity: (0, 0),
            uploaded: None,
            binned_for: vk::DescriptorSet::null(),
        })
    }

    /// Uploads `params`, growing the buffers when they hold fewer layers or pixels (their sums
    /// are then lost: the next accumulation must clear). The GPU must not be using them.
    pub fn set(&mut self, ctx: &GpuContext, params: GpuLayerParams) -> Result<()> {
        let (layers, pixels) = (params.layers(), params.header[3] as u32);
        if self.bins.is_none() || layers > self.capacity.0 || pixels > self.capacity.1 {
            let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
            let big = 16 * layers.max(1) as u64 * pixels.max(1) as u64;
            let make = |name: &str, size: u64| Buffer::new(ctx, size, storage, false, name);
            // A w × h image has at most w·h / 64 + (w + h) / 8 + 1 tiles: w·h / 8 + 1 at most.
            let tiles = pixels.max(1) as u64 / 8 + 1;
            let bins = [
                // The sums, then the boxes (layered.glsl finds the boxes at its half).
                make("layered sums and boxes", 2 * big)?,
                make("layered focus sums", 64 * pixels.max(1) as u64)?,
                make("layered rows", big)?,
                Buffer::new(
                    ctx,
                    48 * tiles,
                    storage | vk::BufferUsageFlags::TRANSFER_DST,
                    false,
                    "layered occupancy",
                )?,
                make("layered pixel layers", 16 * pixels.max(1) as u64)?,
            ];
            let info = |b: &Buffer| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(b.buffer)
                    .range(vk::WHOLE_SIZE)]
            };
            let uniform = [vk::DescriptorBufferInfo::default()
                .buffer(self.params.buffer)
                .range(vk::WHOLE_SIZE)];
            let infos = bins.each_ref().map(info);
            let mut writes = vec![vk::WriteDescriptorSet::default()
                .dst_set(self.set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
                .buffer_info(&uniform)];
            for (i, inf) in infos.iter().enumerate() {
                writes.push(
                    vk::WriteDescriptorSet::default()
                        .dst_set(self.set)
                        .dst_binding(i as u32 + 1)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .buffer_info(inf),
                );
            }
            // SAFETY: the caller guarantees the GPU is not using the set; the infos reference
            // live buffers.
            unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
            self.bins = Some(bins);
            self.capacity = (layers, pixels);
            self.uploaded = None;
        }
        if self.uploaded != Some(params) {
            self.binned_for = vk::DescriptorSet::null();
            self.params.bytes_mut()[..std::mem::size_of::<GpuLayerParams>()]
                .copy_from_slice(as_bytes(&[params]));
            self.uploaded = Some(params);
        }
        Ok(())
    }

    /// Whether [`LayeredStage::set`] would write anything for `params`.
    pub fn differs(&self, params: &GpuLayerParams) -> bool {
        self.uploaded.as_ref() != Some(params)
    }

    fn pipeline(&mut self, ctx: &GpuContext, key: LayeredKey, stage: u32) -> Result<vk::Pipeline> {
        if let Some((_, p)) = self.pipelines.iter().find(|(k, _)| *k == (key, stage)) {
            return Ok(**p);
        }
        let (tx, ty) = if stage == 1 || stage == 2 {
            (LINE_GROUP, 1)
        } else {
            (TILE, TILE)
        };
        // The accumulation's constant ids 0-7 (refocus_accumulate.glsl: anti-aliasing on, the
        // plane alone, no pyramid, no occlusion tests, no defocused views), then STAGE and the
        // workgroup's shape.
        let constants = [
            key.filter,
            key.texel,
            u32::from(key.uniform_warps),
            1,
            0,
            0,
            0,
            0,
            stage,
            tx,
            ty,
        ];
        let (code, file) = if key.half {
            (shaders::LAYERED_HALF_COMP, "layered_half.comp")
        } else {
            (shaders::LAYERED_COMP, "layered.comp")
        };
        let module = shaders::module(ctx, code, file)?;
        let what = ["bin", "rows", "columns", "composite"][stage as usize];
        let name = format!("layered {what} pipeline ({key:?})");
        let p = compute_pipeline(ctx, *self.layout, *module, &constants, &name)?;
        let raw = *p;
        self.pipelines.push(((key, stage), p));
        Ok(raw)
    }

    /// Records the four stages for the uploaded views `views` into the accumulation image of
    /// `storage_set` (`size`: the views' and the output's pixels), adding to what was binned
    /// before unless `clear` (or the sums hold another target's views, or another plan's).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        (input_set, storage_set): (vk::DescriptorSet, vk::DescriptorSet),
        key: LayeredKey,
        push: RefocusPush,
        views: Range<usize>,
        clear: bool,
        size: (u32, u32),
    ) -> Result<()> {
        let Some(params) = self.uploaded else {
            return Err(Error::Invalid(
                "layered accumulation without its layer plan (RefocusPass::set_antialias)".into(),
            ));
        };
        if params.header[3] as u64 != size.0 as u64 * size.1 as u64 {
            return Err(Error::Invalid(format!(
                "layered anti-aliasing renders at the views' size ({} pixels), not {}×{}",
                params.header[3], size.0, size.1
            )));
        }
        let pipelines = [
            self.pipeline(ctx, key, 0)?,
            self.pipeline(ctx, key, 1)?,
            self.pipeline(ctx, key, 2)?,
            self.pipeline(ctx, key, 3)?,
        ];
        let d = &ctx.device;
        // The sums are the stage's, not the target's: views add to them only where they hold
        // this target's views of this plan.
        let clear = clear || self.binned_for != storage_set;
        self.binned_for = storage_set;
        let [centred_from, centred_to, rim_from, rim_to] = params.batch_ranges(&views);
        let push = RefocusPush {
            first_view: views.start as u32,
            view_count: views.len() as u32,
            accumulate: u32::from(!clear),
            centred_from,
            centred_to,
            rim_from,
            rim_to,
            ..push
        };
        let (w, h) = size;
        let layers = params.layers();
        let dispatches = [
            (pipelines[0], [w.div_ceil(TILE), h.div_ceil(TILE), 1]),
            (pipelines[1], [h.div_ceil(LINE_GROUP), layers.max(1), 1]),
            (pipelines[2], [w.div_ceil(LINE_GROUP), layers.max(1), 1]),
            (pipelines[3], [w.div_ceil(TILE), h.div_ceil(TILE), 1]),
        ];
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let any = A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE | A::SHADER_SAMPLED_READ;
        let shaders = S::COMPUTE_SHADER | S::FRAGMENT_SHADER;
        // The previous accumulation's reads and writes before these.
        memory_barrier(
            d,
            cmd,
            (shaders, any),
            (S::COMPUTE_SHADER | S::CLEAR, any | A::TRANSFER_WRITE),
        );
        // The occupancy's masks start empty: the sums' where the sums start, the rows' and
        // boxes' at every accumulation (they box everything binned so far).
        let Some(bins) = &self.bins else {
            return Err(Error::Internal("layered buffers before the plan".into()));
        };
        let mask = 16 * w.div_ceil(TILE) as u64 * h.div_ceil(TILE) as u64;
        let from = if clear { 0 } else { mask };
        // SAFETY: recording outside a rendering instance; the range lies within the buffer
        // (at most w·h / 8 + 1 tiles) and is a multiple of 4 bytes.
        unsafe { d.cmd_fill_buffer(cmd, bins[3].buffer, from, 3 * mask - from, 0) };
        memory_barrier(
            d,
            cmd,
            (S::CLEAR, A::TRANSFER_WRITE),
            (
                S::COMPUTE_SHADER,
                A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
            ),
        );
        let between = (
            (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE),
            (
                S::COMPUTE_SHADER,
                A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
            ),
        );
        let sets = [input_set, storage_set, self.set];
        compute_stage::record_chain(d, cmd, *self.layout, &sets, &push, &dispatches, between);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::refocus::layered::{NODE_LINEAR_PX, NODE_RATIO, NODE_STEP_PX};

    /// A full cell (its rectangle centred on the view, up to rounding) is centred; a rim cell,
    /// whose part inside the aperture lies to one side, is not; and the binning order lists
    /// the centred views first, each part ascending.
    #[test]
    fn full_cells_bin_first_and_rim_cells_keep_their_centroid() {
        use crate::refocus::antialias::Footprint;
        use glam::DVec3;
        let cell = |origin: DVec3, s: DVec3, t: DVec3| Footprint {
            origin,
            span_s: s,
            span_t: t,
            parallax: DVec3::ZERO,
            map: 0,
        };
        let (s, t) = (DVec3::new(0.7, 0.0, 0.0), DVec3::new(0.0, 0.3, 1e-3));
        let full = cell(-0.5 * (s + t) * (1.0 + 1e-15), s, t);
        let rim = cell(-0.5 * (s + t) + DVec3::new(0.05, 0.0, 0.0), s, t);
        let centred: Vec<bool> = [rim, full, rim, full]
            .iter()
            .map(Footprint::is_centred)
            .collect();
        assert_eq!(centred, [false, true, false, true]);
        let plan = LayerPlan {
            groups: vec![glam::DVec2::ONE, glam::DVec2::splat(0.5)],
            group_of: vec![1, 0, 1, 0],
            px_per_residual: 1.0,
            first: 0,
            nodes: 1,
            slots: vec![0],
            slot_of: vec![0],
        };
        let p = GpuLayerParams::new(&plan, 16, 0.0, &centred);
        assert_eq!(p.slots[1..3], [2, 4]);
        assert_eq!(p.order[0], [1, 3, 0, 2]);
        // A batch of views 1..3 is view 1 of the centred part and view 2 of the rest.
        assert_eq!(p.batch_ranges(&(1..3)), [0, 1, 3, 4]);
        assert_eq!(p.batch_ranges(&(0..4)), [0, 2, 2, 4]);
        assert_eq!(p.batch_ranges(&(4..4)), [2, 2, 4, 4]);
    }

    /// The shader's copies of the node layout and the group limit are the model's.
    #[test]
    fn the_shader_lays_out_the_nodes_as_the_model() {
        let glsl = include_str!("../../../shaders/layered.glsl");
        for (name, value) in [
            ("NODE_STEP_PX", NODE_STEP_PX),
            ("NODE_LINEAR_PX", NODE_LINEAR_PX),
            ("NODE_RATIO", NODE_RATIO),
        ] {
            assert!(
                glsl.contains(&format!("const float {name} = {value:?};")),
                "{name} = {value:?}"
            );
        }
        assert!(glsl.contains(&format!("const uint MAX_GROUPS = {MAX_GROUPS}u;")));
        assert!(glsl.contains(&format!("const uint MAX_NODES = {MAX_NODES}u;")));
        assert!(glsl.contains(&format!("const uint MAX_LAYERS = {MAX_LAYERS}u;")));
        assert!(glsl.contains(&format!("const uint TILE_PX = {TILE}u;")));
        // std140: vec4s and uvec4s only, so the C layout is the block's.
        assert_eq!(
            std::mem::size_of::<GpuLayerParams>(),
            16 * (4 + MAX_NODES + MAX_LAYERS / 4 + MAX_GROUPS + 2 * UBO_WARPS / 4)
        );
    }
}
