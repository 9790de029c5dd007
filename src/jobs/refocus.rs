//! Headless offscreen refocus: the uploaded light field, the refocus pass, one target, a
//! submission, timestamps and a readback buffer on a shared [`GpuContext`]. What the CLI and the
//! tests drive. Every frame is submitted and waited for, since its pixels are read back.
//!
//! [`upload_refocus`] and [`record_refocus`] are the one way a full refocus is uploaded and
//! recorded: the renderer's frames and the viewer's capture both go through them, so a capture
//! equals `render` by construction.
//!
//! Everything frees itself when the renderer is dropped (after waiting for the device), in
//! field order; the context is shared and goes when its last user does.

use std::ops::Range;
use std::sync::Arc;

use ash::vk;
use image::RgbaImage;

use crate::error::{Error, Result};
use crate::gpu::commands::{record_readback, stage, ImageReadback, Submission};
use crate::gpu::resources::{rgba_f32, Buffer};
use crate::gpu::timing::Timestamps;
use crate::gpu::upload::Staging;
use crate::gpu::{GpuContext, GpuOptions};
use crate::lightfield::LightField;
use crate::passes::refocus::{Accumulate, ComputeShape, RefocusPass, RefocusTarget};
use crate::passes::texture::LightFieldTexture;
use crate::refocus::antialias::AntialiasPlan;
use crate::refocus::settings::ViewStorage;
use crate::refocus::settings::{Accumulation, Filter, OutputFormat, Strategy, WarpMemory};
use crate::refocus::surface::{SurfacePlan, SurfaceRule};
use crate::refocus::{Averaging, RefocusImage, RefocusPlan};

/// Per-render settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    pub averaging: Averaging,
    pub output: OutputFormat,
    pub strategy: Strategy,
    pub filter: Filter,
    /// Output size; `None` = the views' size.
    pub size: Option<(u32, u32)>,
    /// The float format the views are summed in.
    pub accumulation: Accumulation,
    /// Where the shaders read the warps from; `None`: the pass's default for the light field.
    pub warps: Option<WarpMemory>,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            averaging: Averaging::Linear,
            output: OutputFormat::Srgb8,
            strategy: Strategy::default(),
            filter: Filter::default(),
            size: None,
            accumulation: Accumulation::default(),
            warps: None,
        }
    }
}

/// GPU times of one frame, from timestamp queries.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PassTimings {
    pub refocus_ms: f64,
    pub resolve_ms: f64,
}

/// A refocus result read back from the GPU.
#[derive(Debug, Clone)]
pub enum GpuImage {
    Srgb8(RgbaImage),
    Float(RefocusImage),
}

impl GpuImage {
    /// Output pixels.
    pub fn pixel_count(&self) -> usize {
        match self {
            GpuImage::Srgb8(img) => img.width() as usize * img.height() as usize,
            GpuImage::Float(img) => img.width as usize * img.height as usize,
        }
    }

    /// Pixels no view reached (alpha 0: the defined background).
    pub fn uncovered(&self) -> usize {
        match self {
            GpuImage::Srgb8(img) => img.pixels().filter(|p| p.0[3] == 0).count(),
            GpuImage::Float(img) => img.uncovered(),
        }
    }
}

/// A ready-to-render light field on a Vulkan device.
pub struct HeadlessRenderer {
    /// Kept between [`HeadlessRenderer::replace_views`] calls (created by the first).
    staging: Option<Staging>,
    readback: Option<Buffer>,
    timestamps: Option<Timestamps>,
    submission: Submission,
    target: Option<RefocusTarget>,
    pass: RefocusPass,
    texture: LightFieldTexture,
    ctx: Arc<GpuContext>,
}

impl HeadlessRenderer {
    /// Creates a context and uploads `lf` with the default view storage.
    pub fn new(lf: &LightField, options: &GpuOptions) -> Result<Self> {
        let ctx = Arc::new(GpuContext::new(options)?);
        Self::with_context(ctx, lf, ViewStorage::default())
    }

    /// Uploads `lf` in `storage` to a shared context.
    pub fn with_context(
        ctx: Arc<GpuContext>,
        lf: &LightField,
        storage: ViewStorage,
    ) -> Result<Self> {
        let texture = LightFieldTexture::upload(&ctx, lf, storage)?;
        Ok(HeadlessRenderer {
            staging: None,
            readback: None,
            timestamps: Timestamps::new(&ctx, 3)?,
            submission: Submission::new(&ctx, "refocus frame")?,
            target: None,
            pass: RefocusPass::new(&ctx, &texture)?,
            texture,
            ctx,
        })
    }

    /// The Vulkan context (device name, validation counts).
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The shared context, for other passes on the same device.
    pub fn shared_context(&self) -> Arc<GpuContext> {
        Arc::clone(&self.ctx)
    }

    /// How the views are stored on the GPU.
    pub fn storage(&self) -> ViewStorage {
        self.texture.storage
    }

    /// Replaces the uploaded views with those of `lf` in place — the next frame of a video,
    /// with the same grid, cameras and view size — keeping the pass, target and plans valid.
    pub fn replace_views(&mut self, lf: &LightField) -> Result<()> {
        let texture = &mut self.texture;
        if self.staging.is_none() {
            self.staging = Some(Staging::new(
                &self.ctx,
                texture.staging_bytes(),
                "light field frame staging",
            )?);
        }
        let Some(staging) = self.staging.as_mut() else {
            return Err(Error::Internal("no staging buffer".into()));
        };
        texture.reupload(&self.ctx, lf, staging)?;
        self.pass.views_reuploaded();
        Ok(())
    }

    /// How the compute strategy's invocations cover the output
    /// ([`RefocusPass::set_compute_shape`]).
    pub fn set_compute_shape(&mut self, shape: ComputeShape) -> Result<()> {
        self.pass.set_compute_shape(shape)
    }

    /// Renders `plan` and reads the image back.
    pub fn render(
        &mut self,
        plan: &RefocusPlan,
        settings: &RenderSettings,
    ) -> Result<(GpuImage, Option<PassTimings>)> {
        let views = 0..plan.views.len();
        let timings = self.frame(plan, None, settings, views, true, true)?;
        Ok((self.read_image(settings)?, timings))
    }

    /// Renders the anti-aliased refocus of `aa` (docs/conventions.md §11) and reads it back.
    pub fn render_antialiased(
        &mut self,
        aa: &AntialiasPlan,
        settings: &RenderSettings,
    ) -> Result<(GpuImage, Option<PassTimings>)> {
        let views = 0..aa.plan.views.len();
        let timings = self.frame(&aa.plan, Some(aa), settings, views, true, true)?;
        Ok((self.read_image(settings)?, timings))
    }

    /// Renders `plan` focused on `surface` (docs/conventions.md §12), anti-aliased when `aa`
    /// is given (`aa.plan` then replaces `plan`'s views, and `surface` must read `aa`'s scene
    /// depth, as [`crate::refocus::surface::surface_for`] builds it), and reads it back.
    pub fn render_surface(
        &mut self,
        plan: &RefocusPlan,
        aa: Option<&AntialiasPlan>,
        surface: &SurfacePlan,
        settings: &RenderSettings,
    ) -> Result<(GpuImage, Option<PassTimings>)> {
        if let (Some(aa), Some(depth)) = (aa, &surface.depth) {
            if aa.depth.inverse_depth != depth.inverse_depth {
                return Err(Error::Invalid(
                    "the focus surface and anti-aliasing read different scene depths; build the \
                     surface from the anti-aliasing plan (refocus::surface::surface_for)"
                        .into(),
                ));
            }
        }
        let plan = aa.map_or(plan, |a| &a.plan);
        let views = 0..plan.views.len();
        let timings = self.frame_with(plan, aa, Some(surface), settings, views, true, true)?;
        Ok((self.read_image(settings)?, timings))
    }

    /// [`Self::render_antialiased`] without readback, for timing.
    pub fn render_timed_antialiased(
        &mut self,
        aa: &AntialiasPlan,
        settings: &RenderSettings,
    ) -> Result<Option<PassTimings>> {
        let views = 0..aa.plan.views.len();
        self.frame(&aa.plan, Some(aa), settings, views, true, false)
    }

    /// Renders `plan` without readback and returns the GPU timings (for benchmarks).
    pub fn render_timed(
        &mut self,
        plan: &RefocusPlan,
        settings: &RenderSettings,
    ) -> Result<Option<PassTimings>> {
        self.frame(plan, None, settings, 0..plan.views.len(), true, false)
    }

    /// Progressive accumulation: adds the views `views` of `plan` (plan order) to the sum, in a
    /// submission of its own, starting from zero when `restart`; then resolves and reads back
    /// the normalised partial sum (what a viewer shows while it refines).
    pub fn accumulate(
        &mut self,
        plan: &RefocusPlan,
        settings: &RenderSettings,
        views: Range<usize>,
        restart: bool,
    ) -> Result<GpuImage> {
        self.frame(plan, None, settings, views, restart, true)?;
        self.read_image(settings)
    }

    /// [`Self::accumulate`] anti-aliased: adds the views `views` of `aa`'s plan to what the
    /// target holds (from zero when `restart`) and reads back the result so far.
    pub fn accumulate_antialiased(
        &mut self,
        aa: &AntialiasPlan,
        settings: &RenderSettings,
        views: Range<usize>,
        restart: bool,
    ) -> Result<GpuImage> {
        self.frame(&aa.plan, Some(aa), settings, views, restart, true)?;
        self.read_image(settings)
    }

    fn frame(
        &mut self,
        plan: &RefocusPlan,
        aa: Option<&AntialiasPlan>,
        settings: &RenderSettings,
        views: Range<usize>,
        restart: bool,
        readback: bool,
    ) -> Result<Option<PassTimings>> {
        self.frame_with(plan, aa, None, settings, views, restart, readback)
    }

    #[allow(clippy::too_many_arguments)]
    fn frame_with(
        &mut self,
        plan: &RefocusPlan,
        aa: Option<&AntialiasPlan>,
        surface: Option<&SurfacePlan>,
        settings: &RenderSettings,
        views: Range<usize>,
        restart: bool,
        readback: bool,
    ) -> Result<Option<PassTimings>> {
        let ctx = Arc::clone(&self.ctx);
        let (pass, texture) = (&mut self.pass, &self.texture);
        let (w, h) = settings.size.unwrap_or((texture.width, texture.height));
        let want = (w, h, settings.accumulation);
        if self
            .target
            .as_ref()
            .map(|t| (t.width, t.height, t.accumulation()))
            != Some(want)
        {
            (self.target, self.readback) = (None, None);
            self.target = Some(pass.create_target_with(&ctx, w, h, settings.accumulation)?);
            self.readback = Some(Buffer::readback(
                &ctx,
                w as u64 * h as u64 * 16,
                "refocus readback",
            )?);
        }
        pass.set_warp_memory(settings.warps)?;
        let with_surface = upload_refocus(&ctx, pass, plan, aa, surface)?;
        let (Some(target), Some(readback_buffer)) = (self.target.as_mut(), self.readback.as_ref())
        else {
            return Err(Error::Internal("no target".into()));
        };
        let m = plan.m.as_vec3();
        let accumulate = Accumulate {
            m: [m.x, m.y, m.z],
            views,
            clear: restart,
            strategy: settings.strategy,
            filter: settings.filter,
            averaging: settings.averaging,
            antialias: aa.map_or(0, |a| a.settings.max_samples),
            surface: with_surface,
        };
        let output = (settings.output, readback.then_some(readback_buffer.buffer));
        let ts = self.timestamps.as_ref();
        let mut recorded = Ok(());
        self.submission.run(&ctx, |_, cmd| {
            recorded = record_refocus(&ctx, cmd, pass, target, &accumulate, output, ts);
        })?;
        recorded?;
        let Some(ts) = &self.timestamps else {
            return Ok(None);
        };
        Ok(ts.read_ms(&ctx)?.map(|ms| PassTimings {
            refocus_ms: ms[0],
            resolve_ms: ms[1],
        }))
    }

    fn read_image(&mut self, settings: &RenderSettings) -> Result<GpuImage> {
        let (Some(t), Some(buffer)) = (self.target.as_ref(), self.readback.as_mut()) else {
            return Err(Error::Internal("no target".into()));
        };
        let (w, h) = (t.width, t.height);
        buffer.invalidate(&self.ctx)?;
        let bytes = buffer.bytes_mut();
        Ok(match settings.output {
            OutputFormat::Srgb8 => {
                let raw = bytes[..(w * h * 4) as usize].to_vec();
                GpuImage::Srgb8(
                    RgbaImage::from_raw(w, h, raw)
                        .ok_or_else(|| Error::Internal("readback size mismatch".into()))?,
                )
            }
            OutputFormat::Float => {
                let pixels = rgba_f32(&bytes[..(w * h * 16) as usize], 1.0);
                GpuImage::Float(RefocusImage {
                    width: w,
                    height: h,
                    averaging: settings.averaging,
                    pixels,
                })
            }
        })
    }
}

/// Uploads what one refocus reads into `pass`: `plan`'s warps, or with `aa` anti-aliasing's
/// plan and depth; then the focus surface unless it is one plane (after anti-aliasing: both bind
/// the same scene depth, so this rewrites nothing there when the surface carries
/// anti-aliasing's depth). Returns whether the accumulation takes the surface path. The GPU must
/// not be reading the pass's inputs.
pub fn upload_refocus(
    ctx: &GpuContext,
    pass: &mut RefocusPass,
    plan: &RefocusPlan,
    aa: Option<&AntialiasPlan>,
    surface: Option<&SurfacePlan>,
) -> Result<bool> {
    match aa {
        Some(aa) => pass.set_antialias(ctx, aa)?,
        None => pass.set_views(plan)?,
    };
    match active_surface(surface) {
        Some(sp) => {
            pass.set_surface(sp)?;
            Ok(true)
        }
        None => Ok(false),
    }
}

/// The surface the pass must run, if any: only surfaces beyond one plane take its SURFACE
/// path (one plane is the plain path, unchanged).
pub fn active_surface(surface: Option<&SurfacePlan>) -> Option<&SurfacePlan> {
    surface.filter(|s| s.rule != SurfaceRule::Plane)
}

/// Records one refocus into `cmd`: the accumulation `a` into `target`, its resolve into
/// `output.0`, and with a buffer in `output.1` the copy of that output into it (the buffer holds
/// the output's bytes). With `ts`, timestamps 0, 1 and 2 bracket the accumulation and the
/// resolve (all three are written even when recording fails, so the queries stay valid).
pub fn record_refocus(
    ctx: &GpuContext,
    cmd: vk::CommandBuffer,
    pass: &mut RefocusPass,
    target: &mut RefocusTarget,
    a: &Accumulate,
    output: (OutputFormat, Option<vk::Buffer>),
    ts: Option<&Timestamps>,
) -> Result<()> {
    let d = &ctx.device;
    let all = vk::PipelineStageFlags2::ALL_COMMANDS;
    let stamp = |i: u32| {
        if let Some(ts) = ts {
            if i == 0 {
                ts.reset(d, cmd);
            }
            ts.write(d, cmd, all, i);
        }
    };
    stamp(0);
    let accumulated = pass.record_accumulate(ctx, cmd, target, a);
    stamp(1);
    if accumulated.is_err() {
        stamp(2);
        return accumulated;
    }
    let resolved = pass.record_resolve(ctx, cmd, target, output.0, a.averaging);
    stamp(2);
    resolved?;
    if let (Some(buffer), (out, _)) = (output.1, target.output(output.0)) {
        let copy = ImageReadback {
            image: out.image,
            from: stage::COLOR_WRITE,
            then: None,
            width: target.width,
            height: target.height,
            buffer,
            offset: 0,
        };
        record_readback(d, cmd, &copy);
    }
    Ok(())
}

impl Drop for HeadlessRenderer {
    fn drop(&mut self) {
        // SAFETY: waiting for idle has no preconditions. Every submission of this renderer
        // waits anyway; this keeps it so should one ever not, before the fields free
        // themselves.
        unsafe {
            let _ = self.ctx.device.device_wait_idle();
        }
    }
}
