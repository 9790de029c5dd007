//! What the refocus pass uploads besides the views' texels, one type per input, each holding
//! its buffers and what it last wrote into them (so an unchanged input is not rewritten, and a
//! caller with frames in flight can ask whether an upload would write anything):
//!
//! - [`ViewInputs`]: the per-view warps (bindings 1 and 3) and the sRGB decode table
//!   (binding 2);
//! - [`SceneDepthInput`]: the scene's inverse depth per reference pixel (binding 5), read by
//!   anti-aliasing and by focus surfaces alike;
//! - [`AntialiasInputs`]: the footprints (binding 4), the views' visibility maps (binding 8)
//!   and the settings the pipelines are specialised on;
//! - [`SurfaceInputs`]: a focus surface's plane terms (binding 6).
//!
//! Every buffer exists from the pass's creation, so the input descriptor sets are written once
//! (the visibility maps may grow: see [`AntialiasInputs::set_visibility`]).

use ash::vk;

use super::interface::{GpuFootprint, GpuSurface, GpuViewWarp};
use crate::error::{Error, Result};
use crate::gpu::pod::as_bytes;
use crate::gpu::resources::Buffer;
use crate::gpu::GpuContext;
use crate::refocus::antialias::{AntialiasPlan, SceneDepth, MAX_VISIBILITY_BYTES};
use crate::refocus::settings::{WarpMemory, UBO_WARPS};
use crate::refocus::surface::{SurfacePlan, SurfaceRule, MAX_PLANES};
use crate::refocus::RefocusPlan;

/// Debug name of the visibility buffer.
const VISIBILITY: &str = "anti-aliasing view visibility";

/// Copies `records` to the start of a mapped buffer.
fn write<T: crate::gpu::pod::Pod>(buffer: &mut Buffer, records: &[T]) {
    let bytes = as_bytes(records);
    buffer.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
}

/// The views' warps and the sRGB decode table.
pub(super) struct ViewInputs {
    /// Bound twice: as a storage buffer (any number of views, binding 1) and as a uniform
    /// buffer of [`UBO_WARPS`] records (binding 3), so it is at least that large.
    pub warps: Buffer,
    /// `color::decode_table` as f32, read by shaders that decode texels exactly.
    pub decode: Buffer,
    /// Views the warp buffer holds: the texture's layers.
    pub capacity: usize,
    /// Where the shaders read the warps from (see [`WarpMemory`]).
    pub memory: WarpMemory,
    /// What `warps` holds now.
    pub uploaded: Vec<GpuViewWarp>,
}

impl ViewInputs {
    pub fn new(ctx: &GpuContext, capacity: usize) -> Result<Self> {
        let table: Vec<f32> = crate::color::decode_table()
            .iter()
            .map(|&v| v as f32)
            .collect();
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::UNIFORM_BUFFER;
        let bytes = (capacity.max(UBO_WARPS) * std::mem::size_of::<GpuViewWarp>()) as u64;
        Ok(ViewInputs {
            warps: Buffer::new(ctx, bytes, usage, true, "view warps")?,
            decode: Buffer::with_bytes(
                ctx,
                as_bytes(&table),
                vk::BufferUsageFlags::UNIFORM_BUFFER,
                "sRGB decode table",
            )?,
            capacity,
            memory: WarpMemory::for_views(capacity),
            uploaded: Vec::new(),
        })
    }

    /// Writes `plan`'s warps unless they are what the buffer holds; returns whether it wrote.
    /// A plan's view indices are texture layers, so they lie below the capacity too.
    pub fn set(&mut self, plan: &RefocusPlan) -> Result<bool> {
        let cap = self.capacity;
        if plan.views.len() > cap || plan.views.iter().any(|v| v.index >= cap) {
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
        write(&mut self.warps, &records);
        self.uploaded = records;
        Ok(true)
    }

    /// Whether [`ViewInputs::set`] would write for `plan`.
    pub fn differ(&self, plan: &RefocusPlan) -> bool {
        plan.views.len() != self.uploaded.len()
            || plan
                .views
                .iter()
                .zip(&self.uploaded)
                .any(|(v, u)| GpuViewWarp::new(&v.warp, v.index, v.weight) != *u)
    }
}

/// The scene's inverse depth and the front's per reference pixel, interleaved.
pub(super) struct SceneDepthInput {
    pub buffer: Buffer,
    /// The views' size: the depth must have one value per view pixel.
    size: (u32, u32),
    uploaded: Vec<f32>,
}

impl SceneDepthInput {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Result<Self> {
        // σ and the front σ per pixel.
        let bytes = (width as u64 * height as u64 * 8).max(8);
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        Ok(SceneDepthInput {
            buffer: Buffer::new(ctx, bytes, usage, true, "scene inverse depth")?,
            size: (width, height),
            uploaded: Vec::new(),
        })
    }

    /// Fails unless `depth` has a value per view pixel.
    pub fn check(&self, depth: &SceneDepth) -> Result<()> {
        let (w, h) = self.size;
        let px = w as usize * h as usize;
        if (depth.width as usize * depth.height as usize) != px
            || depth.inverse_depth.len() != px
            || depth.front.len() != px
        {
            return Err(Error::Invalid(format!(
                "the scene depth is {}×{}, the views {w}×{h}",
                depth.width, depth.height
            )));
        }
        Ok(())
    }

    /// Writes `depth` (checked) unless the buffer holds it.
    pub fn set(&mut self, depth: &SceneDepth) -> Result<()> {
        self.check(depth)?;
        let interleaved = depth.interleaved();
        if interleaved != self.uploaded {
            write(&mut self.buffer, &interleaved);
            self.uploaded = interleaved;
        }
        Ok(())
    }

    /// Whether [`SceneDepthInput::set`] would write for `depth`.
    pub fn differs(&self, depth: &SceneDepth) -> bool {
        depth.interleaved() != self.uploaded
    }
}

/// Anti-aliasing's footprints, the views' visibility maps and the uploaded plan's settings.
pub(super) struct AntialiasInputs {
    /// A uniform buffer of [`UBO_WARPS`] footprint records.
    pub footprints: Buffer,
    /// A placeholder until a plan with maps is uploaded, then grown to hold them.
    pub visibility: Buffer,
    /// What the footprint buffer holds (empty: nothing for the uploaded views).
    pub uploaded_footprints: Vec<GpuFootprint>,
    /// The id of the uploaded maps (`ViewVisibility::id`).
    uploaded_visibility: Option<u64>,
    /// The uploaded plan's `AntialiasSettings::prefilter`.
    pub prefilter: bool,
    /// The uploaded plan's `AntialiasSettings::occlusion`.
    pub occlusion: bool,
    /// The uploaded plan's `AntialiasSettings::defocus`.
    pub defocus: bool,
    /// The uploaded plan's `AntialiasSettings::layered`.
    pub layered: bool,
    /// Whether the uploaded plan asks for boxed footprints (`AntialiasSettings::boxed`, with
    /// neither defocused views nor layers).
    pub boxed: bool,
    /// The uploaded plan's [`AntialiasPlan::focused_reach`], pushed with every draw.
    pub focused_reach: f32,
}

impl AntialiasInputs {
    /// The buffers for views of `width × height` in a texture of `layers` layers.
    pub fn new(ctx: &GpuContext, width: u32, height: u32, layers: u32) -> Result<Self> {
        // Room for every layer's map up front where that fits the budget, so the binding is
        // written once; a larger light field grows it on first use.
        let full = layers.min(UBO_WARPS as u32) as u64 * width as u64 * height as u64 * 2;
        let visibility_bytes = if full as usize <= MAX_VISIBILITY_BYTES {
            full.max(16)
        } else {
            16
        };
        Ok(AntialiasInputs {
            footprints: Buffer::new(
                ctx,
                (UBO_WARPS * std::mem::size_of::<GpuFootprint>()) as u64,
                vk::BufferUsageFlags::UNIFORM_BUFFER,
                true,
                "anti-aliasing footprints",
            )?,
            visibility: Buffer::new(
                ctx,
                visibility_bytes,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                true,
                VISIBILITY,
            )?,
            uploaded_footprints: Vec::new(),
            uploaded_visibility: None,
            prefilter: false,
            occlusion: false,
            defocus: false,
            layered: false,
            boxed: false,
            focused_reach: 0.0,
        })
    }

    /// Checks what the buffers can hold of `aa`.
    pub fn check(aa: &AntialiasPlan) -> Result<()> {
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
        // The layers bin each view's sample by what that view sees: its map (a plan made
        // without them, past the budget, takes the sub-samples).
        if aa.settings.layered.on() && aa.visibility.is_none() {
            return Err(Error::Invalid(
                "layered anti-aliasing needs every view's depth map, and this plan has none".into(),
            ));
        }
        Ok(())
    }

    /// Writes `aa`'s footprints and settings (its views and depth are the pass's).
    pub fn set(&mut self, aa: &AntialiasPlan) {
        let records = footprint_records(aa);
        if records != self.uploaded_footprints {
            write(&mut self.footprints, &records);
            self.uploaded_footprints = records;
        }
        self.prefilter = aa.settings.prefilter;
        self.occlusion = aa.settings.occlusion;
        self.defocus = aa.settings.defocus;
        self.layered = aa.settings.layered.on();
        self.boxed = aa.settings.boxes();
        self.focused_reach = aa.focused_reach() as f32;
    }

    /// Writes `aa`'s visibility maps unless they are uploaded already. Returns the new buffer
    /// when they did not fit the old one: binding 8 must then be rewritten (the old buffer is
    /// dropped, so the GPU must not be using it).
    pub fn set_visibility(&mut self, ctx: &GpuContext, aa: &AntialiasPlan) -> Result<bool> {
        let Some(vis) = &aa.visibility else {
            return Ok(false);
        };
        if self.uploaded_visibility == Some(vis.id) {
            return Ok(false);
        }
        let words = vis.half_words();
        let bytes = as_bytes(&words);
        let grown = bytes.len() as u64 > self.visibility.size;
        if grown {
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            self.visibility = Buffer::new(ctx, bytes.len() as u64, usage, true, VISIBILITY)?;
        }
        self.visibility.bytes_mut()[..bytes.len()].copy_from_slice(bytes);
        self.uploaded_visibility = Some(vis.id);
        Ok(grown)
    }

    /// Whether [`AntialiasInputs::set`] or [`AntialiasInputs::set_visibility`] would write
    /// anything for `aa`.
    pub fn differ(&self, aa: &AntialiasPlan) -> bool {
        footprint_records(aa) != self.uploaded_footprints
            || aa.visibility.as_ref().map(|v| v.id) != self.uploaded_visibility
            || aa.settings.prefilter != self.prefilter
            || aa.settings.occlusion != self.occlusion
            || aa.settings.defocus != self.defocus
            || aa.settings.layered.on() != self.layered
            || aa.settings.boxes() != self.boxed
            || aa.focused_reach() as f32 != self.focused_reach
    }
}

/// The footprint records of `aa` as the pass uploads them (one per view), so that uploading
/// and comparing build them alike.
fn footprint_records(aa: &AntialiasPlan) -> Vec<GpuFootprint> {
    let visible = aa.visibility.is_some();
    aa.footprints
        .iter()
        .map(|f| GpuFootprint::new(f, visible, aa.guard_px, aa.focus_threshold()))
        .collect()
}

/// A focus surface's plane terms.
pub(super) struct SurfaceInputs {
    pub buffer: Buffer,
    /// What was uploaded last: rule and plane count.
    pub uploaded: Option<(SurfaceRule, u32)>,
}

impl SurfaceInputs {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Ok(SurfaceInputs {
            buffer: Buffer::new(
                ctx,
                std::mem::size_of::<GpuSurface>() as u64,
                vk::BufferUsageFlags::UNIFORM_BUFFER,
                true,
                "focus surface planes",
            )?,
            uploaded: None,
        })
    }

    /// Checks `surface`'s plane count and that a rule other than one plane brings a depth.
    pub fn check(surface: &SurfacePlan) -> Result<()> {
        let count = surface.terms.len();
        if count == 0 || count > MAX_PLANES {
            return Err(Error::Invalid(format!(
                "a focus surface has 1 to {MAX_PLANES} plane terms, this one {count}"
            )));
        }
        if surface.depth.is_none() && surface.rule != SurfaceRule::Plane {
            return Err(Error::Invalid(
                "a focus surface other than one plane needs the scene depth".into(),
            ));
        }
        Ok(())
    }

    /// Writes `surface`'s plane terms (checked by [`SurfaceInputs::check`]).
    pub fn set(&mut self, surface: &SurfacePlan) {
        write(&mut self.buffer, &[GpuSurface::new(surface)]);
        self.uploaded = Some((surface.rule, surface.terms.len() as u32));
    }
}
