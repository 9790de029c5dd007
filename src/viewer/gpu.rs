//! The viewer's GPU side: the resident light field texture, the refocus pass with a full-size
//! and a preview target, the scene pass and its panel-size target, the text overlay image, the
//! compositor, the swapchain and the frames in flight. It records one frame from a
//! [`FrameRequest`] (what to accumulate, whether the scene or the text changed) and captures
//! screenshots; what to draw is decided by the caller (UI state never lives here).
//!
//! Per frame ([`ViewerGpu::frame`]): wait for the slot's previous frame (its timestamps are
//! read then) → acquire → a global barrier (images reused across frames are rewritten only
//! after earlier frames are done with them) → the named steps: accumulate + resolve a batch of
//! views (`RefocusTargets::record_batch`) → scene view, only when it changed
//! (`SceneImage::record`) → overlay rows, only those that changed (`Overlay::upload_rows`) →
//! compose the window (`compose`) → capture it for a screenshot (`record_capture`) → present.
//!
//! Teardown (in `Drop`): wait idle, then every field frees itself in declaration order:
//! frames → readback → overlay → scene target → scene pass → refocus targets → refocus pass →
//! texture → frame staging → timestamps → compositor → swapchain (and its surface). The
//! context goes with its last user.

use std::sync::Arc;

use ash::vk;
use image::RgbaImage;

use super::refine::{shows_batch, Batch};
use super::text::Canvas;
use crate::error::{Error, Result};
use crate::gpu::commands::{
    begin_rendering, color_copy, image_barrier, memory_barrier, record_readback, stage,
    ImageReadback, ImageTransition, Submission,
};
use crate::gpu::frames::Frames;
use crate::gpu::resources::{Buffer, Image, ImageDesc};
use crate::gpu::swapchain::{Acquire, PresentMode, Swapchain};
use crate::gpu::timing::Timestamps;
use crate::gpu::upload::Staging;
use crate::gpu::GpuContext;
use crate::jobs::refocus as refocus_job;
use crate::lightfield::LightField;
use crate::passes::panel::{Compositor, PanelMode, Rect};
use crate::passes::refocus::{Accumulate, RefocusPass, RefocusTarget};
use crate::passes::scene::{SceneOverlay, ScenePass, SceneTarget, SceneView};
use crate::passes::texture::LightFieldTexture;
use crate::refocus::antialias::AntialiasPlan;
use crate::refocus::settings::ViewStorage;
use crate::refocus::settings::{Filter, OutputFormat, Strategy};
use crate::refocus::surface::SurfacePlan;
use crate::refocus::{Averaging, RefocusPlan};

use super::layout::Layout;

/// Frames in flight.
pub const FRAMES_IN_FLIGHT: usize = 2;
const OVERLAY_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// What one frame does besides composing the window.
pub struct FrameRequest<'a> {
    /// The plan in refinement order (the batch's ranges index it).
    pub plan: &'a RefocusPlan,
    /// Anti-aliasing: its plan in the same order (`plan` is its `plan`), when on.
    pub antialias: Option<&'a AntialiasPlan>,
    /// The focus surface, when it is more than the plan's plane (its depth is
    /// anti-aliasing's when that is on).
    pub surface: Option<&'a SurfacePlan>,
    pub averaging: Averaging,
    /// Views to add, if refinement is not complete.
    pub batch: Option<Batch>,
    /// The scene to redraw, when it changed, and whether the view (and so the cloud) did.
    pub scene: Option<(SceneView, &'a SceneOverlay, bool)>,
    pub canvas: &'a mut Canvas,
    pub layout: &'a Layout,
    /// Copy the composed window for a screenshot.
    pub capture_window: bool,
    /// Returned with this frame's timings (the caller's refinement id, interactive or not).
    pub tag: (u32, bool),
    /// The parts of the window the text overlay has content in (only these are composited).
    pub overlay_parts: &'a [Rect],
}

/// GPU times of a completed frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameTiming {
    /// Views it accumulated and at which preview divisor.
    pub views: usize,
    pub divisor: u32,
    pub accumulate_ms: f64,
    pub frame_ms: f64,
    /// The request's tag.
    pub tag: (u32, bool),
}

/// What recording a frame produced.
#[derive(Debug, Default)]
pub struct FrameResult {
    /// Timings of the earlier frame whose slot this frame reused.
    pub timing: Option<FrameTiming>,
    /// The swapchain had to be recreated; the frame was not shown.
    pub skipped: bool,
    /// The composed window, when asked for.
    pub window: Option<RgbaImage>,
}

/// What a frame slot's last frame accumulated: views, preview divisor, the request's tag.
type SlotWork = (usize, u32, (u32, bool));

struct RefocusTargets {
    full: RefocusTarget,
    full_set: vk::DescriptorSet,
    full_ready: bool,
    preview: Option<(u32, RefocusTarget, vk::DescriptorSet)>,
    preview_ready: bool,
    /// Which target the window shows (its divisor).
    shown: Option<u32>,
}

struct Overlay {
    image: Image,
    set: vk::DescriptorSet,
    staging: Vec<Buffer>,
    ready: bool,
}

struct SceneImage {
    target: SceneTarget,
    set: vk::DescriptorSet,
    ready: bool,
}

/// Everything the window renders with.
pub struct ViewerGpu {
    frames: Option<Frames>,
    readback: Option<Buffer>,
    overlay: Option<Overlay>,
    scene: Option<SceneImage>,
    scene_pass: Option<ScenePass>,
    targets: Option<RefocusTargets>,
    pass: Option<RefocusPass>,
    texture: Option<LightFieldTexture>,
    /// Kept between video frames (see [`LightFieldTexture::reupload`]).
    staging: Option<Staging>,
    timestamps: Vec<Option<Timestamps>>,
    /// Per slot: what its last frame accumulated and its tag (to attribute its timestamps).
    slot_work: Vec<Option<SlotWork>>,
    /// The slot the next frame uses (the oldest in flight).
    next_slot: usize,
    compositor: Option<Compositor>,
    swapchain: Option<Swapchain>,
    ctx: Arc<GpuContext>,
    /// Output size of full-quality refocus images.
    pub full_size: (u32, u32),
    pub strategy: Strategy,
    /// How the views are sampled (`view --filter`, as `render --filter`).
    pub filter: Filter,
    /// How the views are stored: one upload for the session, so E (encoded averaging) keeps
    /// it; screenshots record it so `render --storage` reproduces them.
    pub storage: ViewStorage,
    /// The focus surface the pass holds (uploaded by [`ViewerGpu::prepare`]; `None` after
    /// anything else may have rewritten the pass's scene depth).
    surface: Option<SurfacePlan>,
}

fn out_size(full: (u32, u32), divisor: u32) -> (u32, u32) {
    let d = divisor.max(1);
    (full.0.div_ceil(d), full.1.div_ceil(d))
}

impl ViewerGpu {
    /// Builds what a window whose surface is `surface` (owned from here on) of `extent` needs
    /// before any light field: the swapchain, the compositor, the scene pass and the frames, so
    /// the window can show the loading screen ([`ViewerGpu::loading_frame`]) while the views
    /// are read; [`ViewerGpu::attach_views`] then uploads them.
    pub fn new_window(
        ctx: Arc<GpuContext>,
        surface: vk::SurfaceKHR,
        extent: vk::Extent2D,
        present: PresentMode,
        storage: ViewStorage,
    ) -> Result<Self> {
        let swapchain = Swapchain::new(&ctx, surface, extent, present)?;
        let mut g = ViewerGpu {
            frames: None,
            readback: None,
            overlay: None,
            scene: None,
            scene_pass: None,
            targets: None,
            pass: None,
            texture: None,
            staging: None,
            timestamps: Vec::new(),
            slot_work: vec![None; FRAMES_IN_FLIGHT],
            next_slot: 0,
            compositor: None,
            swapchain: Some(swapchain),
            ctx,
            full_size: (1, 1),
            strategy: Strategy::default(),
            filter: Filter::default(),
            storage,
            surface: None,
        };
        // Each step stores what it made, so `Drop` frees it when a later step fails.
        let ctx = Arc::clone(&g.ctx);
        let format = g
            .swapchain
            .as_ref()
            .map_or(vk::Format::UNDEFINED, |s| s.format);
        g.compositor = Some(Compositor::new(&ctx, format)?);
        for _ in 0..FRAMES_IN_FLIGHT {
            g.timestamps.push(Timestamps::new(&ctx, 3)?);
        }
        g.scene_pass = Some(ScenePass::new(&ctx, FRAMES_IN_FLIGHT)?);
        g.frames = Some(Frames::new(&ctx, FRAMES_IN_FLIGHT)?);
        Ok(g)
    }

    /// Uploads `lf`'s views and builds the refocus pass (once, after the loading screen);
    /// [`ViewerGpu::rebuild_panels`] then makes the refocus targets.
    pub fn attach_views(&mut self, lf: &LightField) -> Result<()> {
        if self.texture.is_some() {
            return Err(Error::Vulkan(
                "the viewer's views are already uploaded".into(),
            ));
        }
        self.wait_idle()?;
        let ctx = Arc::clone(&self.ctx);
        let texture = LightFieldTexture::upload(&ctx, lf, self.storage)?;
        let pass = RefocusPass::new(&ctx, &texture);
        self.texture = Some(texture);
        self.pass = Some(pass?);
        self.full_size = (lf.width, lf.height);
        Ok(())
    }

    /// One frame of the loading screen: `canvas` (the window's text) composed over a cleared
    /// window and presented; nothing else is drawn.
    pub fn loading_frame(&mut self, canvas: &mut Canvas, layout: &Layout) -> Result<()> {
        let ctx = Arc::clone(&self.ctx);
        let d = &ctx.device;
        let (Some(frames), Some(swapchain), Some(compositor), Some(overlay)) = (
            self.frames.as_mut(),
            self.swapchain.as_ref(),
            self.compositor.as_ref(),
            self.overlay.as_mut(),
        ) else {
            return Err(Error::Vulkan(
                "the viewer's window was not fully created".into(),
            ));
        };
        let frame = frames.begin(&ctx)?;
        self.next_slot = (frame.slot + 1) % FRAMES_IN_FLIGHT;
        let index = match swapchain.acquire(frame.image_available)? {
            Acquire::Image { index, .. } => index,
            Acquire::OutOfDate => {
                frames.submit(&ctx, &[], &[])?;
                return Ok(());
            }
        };
        let cmd = frame.cmd;
        let all = vk::PipelineStageFlags2::ALL_COMMANDS;
        let any = vk::AccessFlags2::MEMORY_WRITE | vk::AccessFlags2::MEMORY_READ;
        memory_barrier(d, cmd, (all, any), (all, any));
        overlay.upload_rows(d, cmd, frame.slot, canvas);
        let whole = [Rect::new(
            0.0,
            0.0,
            canvas.width as f32,
            canvas.height as f32,
        )];
        let sources = Sources {
            refocus: None,
            scene: None,
            overlay: overlay.source(),
            layout,
            parts: &whole,
        };
        compose(&ctx, cmd, compositor, swapchain, index, &sources);
        let to_present = ImageTransition {
            from: stage::COLOR_WRITE,
            to: stage::PRESENT,
        };
        image_barrier(d, cmd, swapchain.images[index as usize], 1, to_present);
        submit_and_present(&ctx, frames, swapchain, frame.image_available, index)?;
        Ok(())
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The swapchain's extent and present mode.
    pub fn swapchain_info(&self) -> (vk::Extent2D, vk::PresentModeKHR) {
        self.swapchain
            .as_ref()
            .map_or((vk::Extent2D::default(), vk::PresentModeKHR::FIFO), |s| {
                (s.extent, s.present_mode)
            })
    }

    /// The largest point size the scene pass can draw.
    pub fn max_point_size(&self) -> f32 {
        self.scene_pass.as_ref().map_or(1.0, |p| p.max_point_size())
    }

    /// Uploads the scene's point cloud (waits for the frames in flight).
    pub fn set_cloud(&mut self, vertices: &[crate::scene::ColourVertex]) -> Result<()> {
        self.wait_idle()?;
        let ctx = Arc::clone(&self.ctx);
        match self.scene_pass.as_mut() {
            Some(p) => p.set_cloud(&ctx, vertices),
            None => Ok(()),
        }
    }

    /// Replaces the views with those of `lf` (the next frame of a video: same grid, same size),
    /// after the frames in flight are done with the old ones.
    pub fn replace_views(&mut self, lf: &LightField) -> Result<()> {
        self.wait_idle()?;
        let ctx = Arc::clone(&self.ctx);
        let Some(texture) = self.texture.as_mut() else {
            return Err(Error::Internal("the viewer was not fully created".into()));
        };
        if self.staging.is_none() {
            self.staging = Some(Staging::new(
                &ctx,
                texture.staging_bytes(),
                "viewer frame staging",
            )?);
        }
        match self.staging.as_mut() {
            Some(staging) => texture.reupload(&ctx, lf, staging)?,
            None => return Err(Error::Internal("no staging buffer".into())),
        }
        if let Some(pass) = self.pass.as_mut() {
            pass.views_reuploaded();
        }
        Ok(())
    }

    /// Waits for every frame in flight.
    pub fn wait_idle(&mut self) -> Result<()> {
        match self.frames.as_mut() {
            Some(f) => f.wait_all(&self.ctx),
            None => Ok(()),
        }
    }

    /// Rebuilds the swapchain and the window-size images for a window of `extent` (after a
    /// resize or an out-of-date swapchain) and the panel images for `layout`.
    pub fn resize(&mut self, extent: vk::Extent2D, layout: &Layout) -> Result<()> {
        self.wait_idle()?;
        let ctx = Arc::clone(&self.ctx);
        if let Some(sc) = self.swapchain.as_mut() {
            let old = sc.format;
            sc.recreate(&ctx, extent)?;
            if sc.format != old {
                self.compositor = None;
                self.compositor = Some(Compositor::new(&ctx, sc.format)?);
            }
        }
        self.rebuild_panels(layout)
    }

    /// (Re)creates the scene target and the overlay for `layout` (and the full-size refocus
    /// target the first time). Callers have waited for the frames in flight.
    pub fn rebuild_panels(&mut self, layout: &Layout) -> Result<()> {
        let ctx = Arc::clone(&self.ctx);
        (self.scene, self.overlay) = (None, None);
        let (sw, sh) = (
            (layout.scene.width as u32).max(1),
            (layout.scene.height as u32).max(1),
        );
        self.scene = Some(SceneImage {
            target: SceneTarget::new(&ctx, sw, sh)?,
            set: vk::DescriptorSet::null(),
            ready: false,
        });
        let (ww, wh) = (layout.window.0.max(1), layout.window.1.max(1));
        let image = Image::new(
            &ctx,
            ImageDesc::new_2d(
                OVERLAY_FORMAT,
                ww,
                wh,
                vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
            ),
            &[OVERLAY_FORMAT],
            "text overlay",
        )?;
        let mut overlay = Overlay {
            image,
            set: vk::DescriptorSet::null(),
            staging: Vec::new(),
            ready: false,
        };
        for i in 0..FRAMES_IN_FLIGHT {
            overlay.staging.push(Buffer::new(
                &ctx,
                ww as u64 * wh as u64 * 4,
                vk::BufferUsageFlags::TRANSFER_SRC,
                true,
                &format!("overlay staging {i}"),
            )?);
        }
        self.overlay = Some(overlay);
        // Before the views are attached (the loading screen) there is nothing to refocus into.
        if let (None, Some(pass)) = (self.targets.as_ref(), self.pass.as_mut()) {
            let (w, h) = self.full_size;
            self.targets = Some(RefocusTargets {
                full: pass.create_target(&ctx, w, h)?,
                full_set: vk::DescriptorSet::null(),
                full_ready: false,
                preview: None,
                preview_ready: false,
                shown: None,
            });
        }
        self.make_sets()
    }

    /// Resets the compositor's pool and makes the descriptor sets of every panel image. No
    /// frame in flight may use the old sets.
    fn make_sets(&mut self) -> Result<()> {
        let ctx = Arc::clone(&self.ctx);
        let Some(compositor) = self.compositor.as_ref() else {
            return Err(Error::Internal("the viewer was not fully created".into()));
        };
        compositor.reset(&ctx)?;
        if let Some(s) = self.scene.as_mut() {
            s.set = compositor.source(&ctx, s.target.color.views[0])?;
        }
        if let Some(o) = self.overlay.as_mut() {
            o.set = compositor.source(&ctx, o.image.views[0])?;
        }
        if let Some(t) = self.targets.as_mut() {
            t.full_set = compositor.source(&ctx, t.full.out8.views[0])?;
            if let Some((_, target, set)) = t.preview.as_mut() {
                *set = compositor.source(&ctx, target.out8.views[0])?;
            }
        }
        Ok(())
    }

    /// Makes sure a preview target of `divisor` exists (waits for the frames in flight when
    /// it has to be replaced).
    fn ensure_preview(&mut self, divisor: u32) -> Result<()> {
        let current = self
            .targets
            .as_ref()
            .and_then(|t| t.preview.as_ref().map(|p| p.0));
        if divisor <= 1 || current == Some(divisor) {
            return Ok(());
        }
        self.wait_idle()?;
        let ctx = Arc::clone(&self.ctx);
        let (Some(pass), Some(targets)) = (self.pass.as_mut(), self.targets.as_mut()) else {
            return Err(Error::Internal("the viewer was not fully created".into()));
        };
        targets.preview = None;
        targets.preview_ready = false;
        if targets.shown.is_some_and(|d| d > 1) {
            targets.shown = None;
        }
        let (w, h) = out_size(self.full_size, divisor);
        let target = pass.create_target(&ctx, w, h)?;
        targets.preview = Some((divisor, target, vk::DescriptorSet::null()));
        self.make_sets()
    }

    /// Before recording: the preview target the batch needs, and the plan's warps (the frames
    /// in flight read the old ones: they are waited for before the rewrite).
    fn prepare(&mut self, req: &FrameRequest) -> Result<()> {
        if let Some(b) = &req.batch {
            self.ensure_preview(b.divisor)?;
        }
        match req.antialias {
            Some(aa) => {
                if self.pass.as_ref().is_some_and(|p| p.antialias_differs(aa)) {
                    self.wait_idle()?;
                    if let Some(p) = self.pass.as_mut() {
                        p.set_antialias(&self.ctx, aa)?;
                    }
                    // Anti-aliasing rewrote the scene depth the surface reads.
                    self.surface = None;
                }
            }
            None => {
                if self.pass.as_ref().is_some_and(|p| p.views_differ(req.plan)) {
                    self.wait_idle()?;
                    if let Some(p) = self.pass.as_mut() {
                        p.set_views(req.plan)?;
                    }
                }
            }
        }
        // After anti-aliasing's upload (both bind one scene depth): the surface's terms and
        // depth, rewritten only when they changed, after the frames in flight are done.
        if let Some(sp) = refocus_job::active_surface(req.surface) {
            if self.surface.as_ref() != Some(sp) {
                self.wait_idle()?;
                if let Some(p) = self.pass.as_mut() {
                    p.set_surface(sp)?;
                }
                self.surface = Some(sp.clone());
            }
        }
        Ok(())
    }

    /// Records, submits and presents one frame: refocus batch → scene → overlay rows →
    /// compose → present (or capture and present), between timestamps 0, 1 and 2.
    pub fn frame(&mut self, req: FrameRequest) -> Result<FrameResult> {
        self.prepare(&req)?;
        let ctx = Arc::clone(&self.ctx);
        let d = &ctx.device;
        let (
            Some(frames),
            Some(swapchain),
            Some(compositor),
            Some(pass),
            Some(targets),
            Some(scene),
            Some(scene_pass),
            Some(overlay),
        ) = (
            self.frames.as_mut(),
            self.swapchain.as_ref(),
            self.compositor.as_ref(),
            self.pass.as_mut(),
            self.targets.as_mut(),
            self.scene.as_mut(),
            self.scene_pass.as_mut(),
            self.overlay.as_mut(),
        )
        else {
            return Err(Error::Internal("the viewer was not fully created".into()));
        };
        let frame = frames.begin(&ctx)?;
        let mut result = FrameResult::default();
        self.next_slot = (frame.slot + 1) % FRAMES_IN_FLIGHT;
        let ts = self.timestamps[frame.slot].as_ref();
        result.timing = read_timing(&ctx, ts, self.slot_work[frame.slot].take())?;
        let index = match swapchain.acquire(frame.image_available)? {
            Acquire::Image { index, .. } => index,
            Acquire::OutOfDate => {
                // Nothing was recorded: submit the empty buffer so the slot's fence signals.
                frames.submit(&ctx, &[], &[])?;
                result.skipped = true;
                return Ok(result);
            }
        };
        let cmd = frame.cmd;
        let all = vk::PipelineStageFlags2::ALL_COMMANDS;
        let any = vk::AccessFlags2::MEMORY_WRITE | vk::AccessFlags2::MEMORY_READ;
        memory_barrier(d, cmd, (all, any), (all, any));
        if let Some(ts) = ts {
            ts.reset(d, cmd);
            ts.write(d, cmd, all, 0);
        }
        if let Some(batch) = &req.batch {
            let work = RefocusWork {
                plan: req.plan,
                antialias: req.antialias.map_or(0, |a| a.settings.max_samples),
                surface: refocus_job::active_surface(req.surface).is_some(),
                batch,
                averaging: req.averaging,
                strategy: self.strategy,
                filter: self.filter,
            };
            targets.record_batch(&ctx, cmd, pass, &work)?;
            self.slot_work[frame.slot] = Some((batch.views.len(), batch.divisor.max(1), req.tag));
        }
        if let Some(ts) = ts {
            ts.write(d, cmd, all, 1);
        }
        if let Some((view, geometry, cloud_changed)) = req.scene {
            let draw = (&view, geometry, cloud_changed);
            scene.record(&ctx, cmd, scene_pass, frame.slot, draw)?;
        }
        overlay.upload_rows(d, cmd, frame.slot, req.canvas);
        let sources = Sources {
            refocus: targets.shown_set(),
            scene: scene.ready.then_some(scene.set),
            overlay: overlay.source(),
            layout: req.layout,
            parts: req.overlay_parts,
        };
        compose(&ctx, cmd, compositor, swapchain, index, &sources);
        if let Some(ts) = ts {
            ts.write(d, cmd, all, 2);
        }
        let image = swapchain.images[index as usize];
        let extent = swapchain.extent;
        if req.capture_window {
            record_capture(&ctx, cmd, &mut self.readback, image, extent)?;
        } else {
            let to_present = ImageTransition {
                from: stage::COLOR_WRITE,
                to: stage::PRESENT,
            };
            image_barrier(d, cmd, image, 1, to_present);
        }
        result.skipped = submit_and_present(&ctx, frames, swapchain, frame.image_available, index)?;
        if req.capture_window {
            frames.wait_all(&ctx)?;
            result.window = read_window(&ctx, self.readback.as_mut(), swapchain.format, extent)?;
        }
        Ok(result)
    }

    /// Waits for the frames in flight and returns the timings not yet reported, oldest first.
    pub fn drain_timings(&mut self) -> Result<Vec<FrameTiming>> {
        self.wait_idle()?;
        let mut out = Vec::new();
        for k in 0..FRAMES_IN_FLIGHT {
            let slot = (self.next_slot + k) % FRAMES_IN_FLIGHT;
            let work = self.slot_work[slot].take();
            out.extend(read_timing(
                &self.ctx,
                self.timestamps[slot].as_ref(),
                work,
            )?);
        }
        Ok(out)
    }

    /// The refocus image of `plan` (render order) at full quality and `size`, exactly as
    /// `render` computes it: one accumulation over all views in plan order, then the 8-bit
    /// resolve. Waits for the frames in flight; the next frame re-uploads its own warps.
    pub fn capture_refocus(
        &mut self,
        plan: &RefocusPlan,
        aa: Option<&AntialiasPlan>,
        surface: Option<&SurfacePlan>,
        averaging: Averaging,
        size: (u32, u32),
    ) -> Result<RgbaImage> {
        self.wait_idle()?;
        // What the capture uploads is not necessarily what the next frame wants.
        self.surface = None;
        let ctx = Arc::clone(&self.ctx);
        let Some(pass) = self.pass.as_mut() else {
            return Err(Error::Internal("the viewer was not fully created".into()));
        };
        let with_surface = refocus_job::upload_refocus(&ctx, pass, plan, aa, surface)?;
        let plan = aa.map_or(plan, |aa| &aa.plan);
        let (w, h) = size;
        let mut target = pass.create_target(&ctx, w, h)?;
        let mut readback = Buffer::readback(&ctx, w as u64 * h as u64 * 4, "capture")?;
        let m = plan.m.as_vec3();
        let accumulate = Accumulate {
            m: [m.x, m.y, m.z],
            views: 0..plan.views.len(),
            clear: true,
            strategy: self.strategy,
            filter: self.filter,
            averaging,
            antialias: aa.map_or(0, |a| a.settings.max_samples),
            surface: with_surface,
        };
        let output = (OutputFormat::Srgb8, Some(readback.buffer));
        let mut recorded = Ok(());
        Submission::new(&ctx, "refocus capture")?.run(&ctx, |_, cmd| {
            recorded = refocus_job::record_refocus(
                &ctx,
                cmd,
                pass,
                &mut target,
                &accumulate,
                output,
                None,
            );
        })?;
        recorded?;
        readback.invalidate(&ctx)?;
        let raw = readback.bytes_mut()[..(w * h * 4) as usize].to_vec();
        RgbaImage::from_raw(w, h, raw)
            .ok_or_else(|| Error::Internal("capture size mismatch".into()))
    }

    /// The scene panel as last drawn (sRGB-encoded RGBA).
    pub fn capture_scene(&mut self) -> Result<RgbaImage> {
        self.wait_idle()?;
        match self.scene.as_ref().filter(|s| s.ready) {
            Some(scene) => scene.target.read(&self.ctx, stage::FRAGMENT_READ),
            None => Err(Error::Vulkan("the scene has not been drawn yet".into())),
        }
    }
}

/// One frame's refocus work: the batch of `plan` (refinement order) to accumulate.
struct RefocusWork<'a> {
    plan: &'a RefocusPlan,
    /// Anti-aliasing's sub-sample cap (0: the plain sum).
    antialias: u32,
    /// The pass's SURFACE path (its surface uploaded by `prepare`).
    surface: bool,
    batch: &'a Batch,
    averaging: Averaging,
    strategy: Strategy,
    filter: Filter,
}

impl RefocusTargets {
    /// Step 1, refocus: the next batch of views into the target of its size, then resolve; the
    /// window shows that target from now on (a full-size one once it has enough views).
    fn record_batch(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        pass: &mut RefocusPass,
        work: &RefocusWork,
    ) -> Result<()> {
        let batch = work.batch;
        let m = work.plan.m.as_vec3();
        let accumulate = Accumulate {
            m: [m.x, m.y, m.z],
            views: batch.views.clone(),
            clear: batch.clear,
            strategy: work.strategy,
            filter: work.filter,
            averaging: work.averaging,
            antialias: work.antialias,
            surface: work.surface,
        };
        let target = if batch.divisor > 1 {
            match self.preview.as_mut() {
                Some((_, t, _)) => t,
                None => return Err(Error::Internal("no preview target".into())),
            }
        } else {
            &mut self.full
        };
        let output = (OutputFormat::Srgb8, None);
        refocus_job::record_refocus(ctx, cmd, pass, target, &accumulate, output, None)?;
        let to_read = ImageTransition {
            from: stage::COLOR_WRITE,
            to: stage::FRAGMENT_READ,
        };
        image_barrier(&ctx.device, cmd, target.out8.image, 1, to_read);
        if batch.divisor > 1 {
            self.preview_ready = true;
        } else {
            self.full_ready = true;
        }
        // A full-size sum of fewer views than a preview has is grainy and sharper than the
        // final image: the preview stays on screen until the full-size sum has as many views
        // as a preview's first frame (or all of them).
        if shows_batch(batch, work.plan.views.len(), self.preview_ready) {
            self.shown = Some(batch.divisor.max(1));
        }
        Ok(())
    }

    /// The set of the refocus image the window shows: the target last drawn into, else the
    /// full-size one if it has content.
    fn shown_set(&self) -> Option<vk::DescriptorSet> {
        match self.shown {
            Some(1) if self.full_ready => Some(self.full_set),
            Some(_) if self.preview_ready => self.preview.as_ref().map(|p| p.2),
            _ if self.full_ready => Some(self.full_set),
            _ => None,
        }
    }
}

impl SceneImage {
    /// Step 2, the scene view (only when it changed): `draw` is the view, the geometry and
    /// whether the cloud layer is redrawn too.
    fn record(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        pass: &mut ScenePass,
        slot: usize,
        draw: (&SceneView, &SceneOverlay, bool),
    ) -> Result<()> {
        let (view, geometry, cloud_changed) = draw;
        pass.record(
            ctx,
            cmd,
            slot,
            &mut self.target,
            view,
            geometry,
            cloud_changed,
        )?;
        let to_read = ImageTransition {
            from: stage::COLOR_WRITE,
            to: stage::FRAGMENT_READ,
        };
        image_barrier(&ctx.device, cmd, self.target.color.image, 1, to_read);
        self.ready = true;
        Ok(())
    }
}

impl Overlay {
    /// Step 3, the overlay text: copies the canvas rows that changed through the slot's
    /// staging buffer (a canvas of another width than the image waits for the resize).
    fn upload_rows(
        &mut self,
        d: &ash::Device,
        cmd: vk::CommandBuffer,
        slot: usize,
        canvas: &mut Canvas,
    ) {
        let Some((y0, y1)) = canvas.take_dirty() else {
            return;
        };
        let y1 = y1.min(self.image.desc.height);
        if y0 >= y1 || canvas.width != self.image.desc.width {
            return;
        }
        let rows = canvas.rows(y0, y1);
        let staging = &mut self.staging[slot];
        staging.bytes_mut()[..rows.len()].copy_from_slice(rows);
        let to_write = ImageTransition {
            from: if self.ready {
                stage::FRAGMENT_READ
            } else {
                stage::UNDEFINED
            },
            to: stage::TRANSFER_DST,
        };
        image_barrier(d, cmd, self.image.image, 1, to_write);
        let region = color_copy(0, canvas.width, y1 - y0, 1).image_offset(vk::Offset3D {
            x: 0,
            y: y0 as i32,
            z: 0,
        });
        // SAFETY: recording; the staging buffer holds the rows, the image is in
        // TRANSFER_DST (barrier above).
        unsafe {
            d.cmd_copy_buffer_to_image(
                cmd,
                staging.buffer,
                self.image.image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
        let to_read = ImageTransition {
            from: stage::TRANSFER_DST,
            to: stage::FRAGMENT_READ,
        };
        image_barrier(d, cmd, self.image.image, 1, to_read);
        self.ready = true;
    }

    /// The overlay's set and its full rectangle, once it has content.
    fn source(&self) -> Option<(vk::DescriptorSet, Rect)> {
        let (w, h) = (self.image.desc.width, self.image.desc.height);
        self.ready
            .then(|| (self.set, Rect::new(0.0, 0.0, w as f32, h as f32)))
    }
}

/// What the window is composed from: the panel images that have content, where they go,
/// and the parts of the overlay with content.
struct Sources<'a> {
    refocus: Option<vk::DescriptorSet>,
    scene: Option<vk::DescriptorSet>,
    overlay: Option<(vk::DescriptorSet, Rect)>,
    layout: &'a Layout,
    parts: &'a [Rect],
}

/// Step 4, compose the window: swapchain image `index` cleared, then the refocus panel, the
/// scene panel and the overlay's parts drawn into it.
fn compose(
    ctx: &GpuContext,
    cmd: vk::CommandBuffer,
    compositor: &Compositor,
    swapchain: &Swapchain,
    index: u32,
    sources: &Sources,
) {
    let d = &ctx.device;
    let to_write = ImageTransition {
        from: stage::ACQUIRED,
        to: stage::COLOR_WRITE,
    };
    image_barrier(d, cmd, swapchain.images[index as usize], 1, to_write);
    let extent = swapchain.extent;
    let view = swapchain.views[index as usize];
    begin_rendering(d, cmd, extent, view, vk::AttachmentLoadOp::CLEAR, None);
    let layout = sources.layout;
    if let Some(set) = sources.refocus {
        compositor.draw(ctx, cmd, set, layout.refocus, extent, PanelMode::Encoded);
    }
    if let Some(set) = sources.scene {
        compositor.draw(ctx, cmd, set, layout.scene, extent, PanelMode::Linear);
    }
    if let Some((set, full)) = sources.overlay {
        for part in sources.parts {
            compositor.draw_part(ctx, cmd, set, full, *part, extent, PanelMode::Overlay);
        }
    }
    // SAFETY: inside the rendering instance begun above.
    unsafe { d.cmd_end_rendering(cmd) };
}

/// Submits the frame's commands (waiting for swapchain image `index`, signalling its
/// render-finished semaphore) and presents the image; true when the swapchain is out of date.
fn submit_and_present(
    ctx: &GpuContext,
    frames: &mut Frames,
    swapchain: &Swapchain,
    image_available: vk::Semaphore,
    index: u32,
) -> Result<bool> {
    frames.submit(
        ctx,
        &[(
            image_available,
            vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
        )],
        &[swapchain.render_finished[index as usize]],
    )?;
    swapchain.present(ctx, index)
}

/// Step 5, capture: copies the composed `image` into the readback buffer (grown to fit
/// `extent`) and leaves it ready to present.
fn record_capture(
    ctx: &GpuContext,
    cmd: vk::CommandBuffer,
    readback: &mut Option<Buffer>,
    image: vk::Image,
    extent: vk::Extent2D,
) -> Result<()> {
    let bytes = extent.width as u64 * extent.height as u64 * 4;
    if readback.as_ref().map_or(true, |b| b.size < bytes) {
        // The last capture waited for its frame: the old buffer is idle.
        *readback = None;
        *readback = Some(Buffer::readback(ctx, bytes, "window readback")?);
    }
    let buffer = readback.as_ref().map(|b| b.buffer).unwrap_or_default();
    // The buffer was sized for this extent above.
    let copy = ImageReadback {
        image,
        from: stage::COLOR_WRITE,
        then: Some(stage::PRESENT),
        width: extent.width,
        height: extent.height,
        buffer,
        offset: 0,
    };
    record_readback(&ctx.device, cmd, &copy);
    Ok(())
}

/// The captured window as RGBA (swizzled from BGRA swapchains, opaque), after its frame
/// completed.
fn read_window(
    ctx: &GpuContext,
    readback: Option<&mut Buffer>,
    format: vk::Format,
    extent: vk::Extent2D,
) -> Result<Option<RgbaImage>> {
    let Some(b) = readback else { return Ok(None) };
    b.invalidate(ctx)?;
    let n = extent.width as usize * extent.height as usize * 4;
    let mut raw = b.bytes_mut()[..n].to_vec();
    if matches!(
        format,
        vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB
    ) {
        for p in raw.chunks_exact_mut(4) {
            p.swap(0, 2);
        }
    }
    for p in raw.chunks_exact_mut(4) {
        p[3] = 255;
    }
    Ok(RgbaImage::from_raw(extent.width, extent.height, raw))
}

/// The timings of a completed slot that accumulated `work`.
fn read_timing(
    ctx: &GpuContext,
    ts: Option<&Timestamps>,
    work: Option<SlotWork>,
) -> Result<Option<FrameTiming>> {
    let (Some(ts), Some((views, divisor, tag))) = (ts, work) else {
        return Ok(None);
    };
    Ok(ts.read_ms(ctx)?.map(|ms| FrameTiming {
        views,
        divisor,
        accumulate_ms: ms[0],
        frame_ms: ms[0] + ms[1],
        tag,
    }))
}

impl Drop for ViewerGpu {
    fn drop(&mut self) {
        // SAFETY: waiting has no preconditions; afterwards nothing is in use, and the fields
        // free themselves in declaration order.
        unsafe {
            let _ = self.ctx.device.device_wait_idle();
        }
    }
}
