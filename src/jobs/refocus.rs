//! Headless offscreen refocus: the uploaded light field, the refocus pass, one target, a
//! submission, timestamps and a readback buffer on a shared [`GpuContext`]. What the CLI and the
//! tests drive. Every frame is submitted and waited for, since its pixels are read back.
//!
//! Teardown (in `Drop`): frame staging → readback → timestamps → submission → target → pass → texture; the
//! context is shared (`Arc`) and goes when its last user does.

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
    submission: Option<Submission>,
    target: Option<RefocusTarget>,
    pass: Option<RefocusPass>,
    texture: Option<LightFieldTexture>,
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
        let mut r = HeadlessRenderer {
            staging: None,
            readback: None,
            timestamps: None,
            submission: None,
            target: None,
            pass: None,
            texture: None,
            ctx,
        };
        // Each step stores what it made, so `Drop` frees it if a later step fails.
        let ctx = &r.ctx;
        let texture = LightFieldTexture::upload(ctx, lf, storage)?;
        let pass = RefocusPass::new(ctx, &texture);
        r.texture = Some(texture);
        r.pass = Some(pass?);
        r.submission = Some(Submission::new(&r.ctx, "refocus frame")?);
        r.timestamps = Timestamps::new(&r.ctx, 3)?;
        Ok(r)
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
        self.texture
            .as_ref()
            .map_or_else(ViewStorage::default, |t| t.storage)
    }

    /// Replaces the uploaded views with those of `lf` in place — the next frame of a video,
    /// with the same grid, cameras and view size — keeping the pass, target and plans valid.
    pub fn replace_views(&mut self, lf: &LightField) -> Result<()> {
        let Some(texture) = self.texture.as_mut() else {
            return Err(Error::Internal("the renderer was not fully created".into()));
        };
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
        if let Some(pass) = self.pass.as_mut() {
            pass.views_reuploaded();
        }
        Ok(())
    }

    /// How the compute strategy's invocations cover the output
    /// ([`RefocusPass::set_compute_shape`]).
    pub fn set_compute_shape(&mut self, shape: ComputeShape) -> Result<()> {
        match self.pass.as_mut() {
            Some(p) => p.set_compute_shape(shape),
            None => Err(Error::Internal("the renderer was not fully created".into())),
        }
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
        let (Some(pass), Some(texture)) = (self.pass.as_mut(), self.texture.as_ref()) else {
            return Err(Error::Internal("the renderer was not fully created".into()));
        };
        let (w, h) = settings.size.unwrap_or((texture.width, texture.height));
        let want = (w, h, settings.accumulation);
        if self
            .target
            .as_ref()
            .map(|t| (t.width, t.height, t.accumulation()))
            != Some(want)
        {
            if let Some(t) = self.target.take() {
                t.destroy(&ctx);
            }
            if let Some(b) = self.readback.take() {
                b.destroy(&ctx);
            }
            self.target = Some(pass.create_target_with(&ctx, w, h, settings.accumulation)?);
            self.readback = Some(Buffer::readback(
                &ctx,
                w as u64 * h as u64 * 16,
                "refocus readback",
            )?);
        }
        pass.set_warp_memory(settings.warps)?;
        match aa {
            Some(aa) => pass.set_antialias(&ctx, aa)?,
            None => pass.set_views(plan)?,
        };
        // After anti-aliasing's upload: both bind the same scene depth, so this rewrites nothing
        // there when the surface carries anti-aliasing's depth.
        let with_surface = match surface {
            Some(sp) if sp.rule != SurfaceRule::Plane => {
                pass.set_surface(sp)?;
                true
            }
            _ => false,
        };
        let (Some(target), Some(submission), Some(readback_buffer)) = (
            self.target.as_mut(),
            self.submission.as_ref(),
            self.readback.as_ref(),
        ) else {
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
        let ts = self.timestamps.as_ref();
        let all = vk::PipelineStageFlags2::ALL_COMMANDS;
        let mut recorded = Ok(());
        submission.run(&ctx, |d, cmd| {
            if let Some(ts) = ts {
                ts.reset(d, cmd);
                ts.write(d, cmd, all, 0);
            }
            recorded = pass.record_accumulate(&ctx, cmd, target, &accumulate);
            if let Some(ts) = ts {
                ts.write(d, cmd, all, 1);
            }
            if recorded.is_err() {
                if let Some(ts) = ts {
                    ts.write(d, cmd, all, 2);
                }
                return;
            }
            recorded = pass.record_resolve(&ctx, cmd, target, settings.output, settings.averaging);
            if let Some(ts) = ts {
                ts.write(d, cmd, all, 2);
            }
            if readback && recorded.is_ok() {
                let (out, _) = target.output(settings.output);
                // The readback buffer holds w·h·16 bytes.
                let copy = ImageReadback {
                    image: out.image,
                    from: stage::COLOR_WRITE,
                    then: None,
                    width: w,
                    height: h,
                    buffer: readback_buffer.buffer,
                    offset: 0,
                };
                record_readback(d, cmd, &copy);
            }
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

impl Drop for HeadlessRenderer {
    fn drop(&mut self) {
        let ctx = &self.ctx;
        // SAFETY: waiting for idle has no preconditions; every submission of this renderer
        // completes before its resources go.
        unsafe {
            let _ = ctx.device.device_wait_idle();
        }
        if let Some(s) = self.staging.take() {
            s.destroy(ctx);
        }
        if let Some(b) = self.readback.take() {
            b.destroy(ctx);
        }
        if let Some(t) = self.timestamps.take() {
            t.destroy(ctx);
        }
        if let Some(s) = self.submission.take() {
            s.destroy(ctx);
        }
        if let Some(t) = self.target.take() {
            t.destroy(ctx);
        }
        if let Some(p) = self.pass.take() {
            p.destroy(ctx);
        }
        if let Some(t) = self.texture.take() {
            t.destroy(ctx);
        }
    }
}
