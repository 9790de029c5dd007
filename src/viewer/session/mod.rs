//! One viewing session of a light field: the UI state and everything derived from it that
//! outlives a frame — the depth map and point cloud ([`depth`]), progressive refinement
//! ([`refinement`]), video stepping and decoding ([`video`]), the on-screen text ([`hud`]),
//! the scene panel's geometry ([`scene`]), screenshots ([`screenshot`]) and frame statistics
//! ([`stats`]). No window here: the event loop ([`super::app`]) turns input into the calls
//! below, and the session turns them into [`Action`]s on its [`ViewerState`] and into one
//! [`FrameRequest`] per frame for [`ViewerGpu`].
//!
//! Invariants:
//! - the state changes only through [`Session::act`] (so through [`ViewerState::apply`]); the
//!   [`Effect`] it returns says what to redraw ([`Dirty`]);
//! - a change of [`ViewerState::version`] restarts refinement on the next frame;
//!   [`ViewerState::marks_version`] redraws the scene and the text;
//! - a frame is recorded only when there is something to draw (a batch, a dirty panel or a
//!   screenshot); otherwise the event loop may block.

pub mod depth;
pub mod hud;
pub mod refinement;
pub mod scene;
pub mod screenshot;
pub mod stats;
pub mod video;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use ash::vk;
use glam::DVec2;

use super::gpu::{FrameRequest, FrameResult, ViewerGpu};
use super::layout::Layout;
use super::panel::{self as controls_panel, Button, ControlPanel, Hit, Slider};
use super::refine::Refiner;
use super::state::{default_focus, Action, Effect, ViewerState};
use crate::depth::DepthOrigin;
use crate::error::Result;
use crate::gpu::GpuOptions;
use crate::lightfield::video::FrameSequence;
use crate::lightfield::LightField;
use crate::passes::scene::SceneView;
use crate::refocus::antialias::{AntialiasPlan, AntialiasSettings};
use crate::refocus::surface::SurfacePlan;
use depth::{DepthCache, DepthJob, DepthState};
use hud::{Field, Hud, Status};
use refinement::{FramePlan, Refinement};
use screenshot::Screenshots;
use stats::Stats;
use video::{Video, VideoStep};

/// How often the status text refreshes its timings while frames are rendered.
const STATUS_PERIOD: Duration = Duration::from_millis(250);
/// How long the field a control changed stays highlighted in the status strip.
pub const HIGHLIGHT_FOR: Duration = Duration::from_millis(1200);
/// How long a notice (where a `P` screenshot went) stays in the status strip.
pub const NOTICE_FOR: Duration = Duration::from_secs(4);
/// Focus peaking follows a change once input has paused this long (it samples every view at
/// every pixel of the refocus panel on the CPU: not per frame of a held key).
const PEAKS_AFTER_INPUT: Duration = Duration::from_millis(150);

/// The focus-peaking mask of the refocus panel for one state.
pub struct Peaks {
    /// The state version it was computed for.
    version: u64,
    /// The mask at the views' resolution (`cpu::focus_peaks`), kept so a resize only maps it.
    at_views: Vec<bool>,
    /// The refocus panel's size in window pixels: one mask value each, row-major.
    pub size: (u32, u32),
    pub mask: Vec<bool>,
}

impl Peaks {
    /// The share of the panel tinted (in focus).
    pub fn fraction(&self) -> f64 {
        self.mask.iter().filter(|&&b| b).count() as f64 / self.mask.len().max(1) as f64
    }
}
/// Size of the pick markers in the scene panel, pixels.
const MARKER_SIZE: f32 = 11.0;

/// What the next frame has to redraw besides refinement.
#[derive(Debug, Clone, Copy)]
pub struct Dirty {
    /// The scene panel's geometry.
    pub scene: bool,
    /// The scene view (camera, panel size) changed: the cloud layer is redrawn.
    pub cloud: bool,
    pub text: bool,
    /// The window needs composing again (exposed, resized).
    pub window: bool,
    /// The state's `marks_version` last drawn.
    marks_seen: u64,
}

impl Dirty {
    /// After a resize or an out-of-date swapchain: everything in the window.
    fn window_changed(&mut self) {
        self.scene = true;
        self.text = true;
        self.window = true;
    }
}

/// How the session gets its depth when the light field has none of its own.
#[derive(Debug, Clone)]
pub struct DepthPlan {
    /// The GPU options of the background estimate's own context.
    pub gpu: GpuOptions,
    /// Anti-aliasing once depth is here (the front end's default; R returns to it).
    pub antialias: bool,
    /// No focus was given: the default focus with depth ([`default_focus`]) replaces the
    /// initial one if the user has not changed it.
    pub default_focus: bool,
}

/// When things happened, in milliseconds since the process started.
#[derive(Debug, Clone, Copy, Default)]
pub struct Milestones {
    /// When the window first showed something (the loading screen, before the views are read).
    pub window_ms: Option<f64>,
    pub first_frame_ms: Option<f64>,
    pub depth_ready_ms: Option<f64>,
}

/// A viewing session.
pub struct Session {
    /// The light field (shared with a background depth estimate while one runs; the
    /// estimate is installed into it when it arrives).
    pub lf: Arc<LightField>,
    pub state: ViewerState,
    pub depth: DepthCache,
    pub layout: Layout,
    pub refinement: Refinement,
    /// Playback, for videos.
    pub video: Option<Video>,
    pub hud: Hud,
    pub screenshots: Screenshots,
    pub dirty: Dirty,
    pub stats: Stats,
    /// The last input that changed the image (interaction lasts a while after it).
    pub last_input: Instant,
    /// Anti-aliasing's sampling, when the session can anti-alias (it has depth).
    pub antialias: Option<AntialiasSettings>,
    /// The anti-aliasing plan of the state (views in plan order, as `render` uses them), when
    /// it is on, and the state version it was made for.
    pub aa: Option<AntialiasPlan>,
    aa_version: u64,
    /// The focus surface of the state resolved with the scene depth (the anti-aliasing plan's
    /// when on), when it is more than one plane; made with `aa`.
    pub surface: Option<SurfacePlan>,
    /// Where the depth came from, once there is depth.
    pub depth_origin: Option<DepthOrigin>,
    /// The status strip's reading of the depth under the cursor.
    cursor_depth: Option<String>,
    /// Depth still to be estimated (started after the first frame) and the estimate running.
    depth_plan: Option<DepthPlan>,
    depth_job: Option<DepthJob>,
    /// The video frame the running estimate is of (`None` outside videos).
    depth_job_frame: Option<u64>,
    /// A video without depth of its own: how each newly shown frame gets its depth (the
    /// first frame's plan, keeping the focus as it is), so that anti-aliasing, clicks and the
    /// cloud follow what moves, as `render --frame N` does.
    frame_depth_plan: Option<DepthPlan>,
    /// Validation errors of the depth estimate's own GPU context.
    pub depth_validation_errors: usize,
    /// The process's start (`--json` reports milestones from it).
    launched: Instant,
    /// The strip's field the last control changed, and when.
    highlight: Option<(Field, Instant)>,
    /// A notice for the status strip and when it came (display only: no part of the state).
    notice: Option<(String, Instant)>,
    /// Focus peaking's mask, while O shows it and it matches the state.
    peaks: Option<Peaks>,
    /// Where the user clicked when the state's message is about that click (window pixels).
    message_at: Option<DVec2>,
    pub milestones: Milestones,
    /// The control panel's widgets for the current layout (drawn while the state shows it).
    pub panel: ControlPanel,
}

impl Session {
    /// A session on `lf` starting in `state`, in a window of `layout`; `video` is the
    /// sequence `lf` is a frame of and that frame's number.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        lf: Arc<LightField>,
        state: ViewerState,
        depth: DepthCache,
        layout: Layout,
        refiner: Refiner,
        video: Option<(FrameSequence, u64)>,
        screenshot_prefix: PathBuf,
        launched: Instant,
    ) -> Self {
        let milestones = Milestones {
            depth_ready_ms: (depth.depth.is_some()).then(|| launched.elapsed().as_secs_f64() * 1e3),
            ..Milestones::default()
        };
        // The distance slider centres on the starting plane's distance.
        let centre = controls_panel::current(Slider::Distance, &state, &lf).unwrap_or(1.0);
        let panel = ControlPanel::new(layout.scene, centre);
        Session {
            lf,
            refinement: Refinement::new(refiner, &state.plan),
            hud: Hud::new(layout.window),
            dirty: Dirty {
                scene: true,
                cloud: true,
                text: true,
                window: true,
                marks_seen: state.marks_version,
            },
            state,
            depth,
            layout,
            // Frames are decoded on a background thread, two ahead while playing.
            video: video.map(|(sequence, frame)| Video::new(sequence, frame)),
            screenshots: Screenshots::new(screenshot_prefix),
            stats: Stats::default(),
            last_input: Instant::now(),
            antialias: None,
            aa: None,
            // No version yet: the first frame makes the plan.
            aa_version: u64::MAX,
            surface: None,
            depth_origin: None,
            cursor_depth: None,
            depth_plan: None,
            depth_job: None,
            depth_job_frame: None,
            frame_depth_plan: None,
            depth_validation_errors: 0,
            launched,
            milestones,
            highlight: None,
            notice: None,
            peaks: None,
            message_at: None,
            panel,
        }
    }

    /// What of the control panel lies under window position `p`, while it is shown.
    pub fn panel_hit(&self, p: DVec2) -> Option<Hit> {
        self.state.show_panel.then(|| self.panel.hit(p)).flatten()
    }

    /// Slider `s` dragged to window x: the value there, set through the keys' actions.
    pub fn panel_slide(&mut self, s: Slider, x: f64) {
        let value = self.panel.value_at(s, self.panel.fraction(s, x), &self.lf);
        match controls_panel::set_action(s, value, &self.state, &self.lf) {
            Some(action) => {
                self.interact(action);
            }
            None if controls_panel::current(s, &self.state, &self.lf).is_none() => {
                self.refuse(format!(
                    "{} needs a focus plane; classic shift-and-sum has none",
                    s.label()
                ));
            }
            None => {}
        }
    }

    /// Button `b` pressed.
    pub fn panel_press(&mut self, b: Button) {
        self.interact(b.action());
    }

    /// How long the highlighted field or the notice has left, the sooner of the two (the
    /// event loop wakes to clear it).
    pub fn highlight_left(&self) -> Option<Duration> {
        let highlight = self
            .highlight
            .map(|(_, at)| HIGHLIGHT_FOR.saturating_sub(at.elapsed()));
        let notice = self
            .notice
            .as_ref()
            .map(|(_, at)| NOTICE_FOR.saturating_sub(at.elapsed()));
        match (highlight, notice) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The light field's depth comes from `origin` (its own map, given).
    pub fn with_depth_origin(mut self, origin: Option<DepthOrigin>) -> Self {
        self.depth_origin = origin;
        self
    }

    /// Estimates depth in the background once the first frame is shown.
    pub fn with_depth_plan(mut self, plan: DepthPlan) -> Self {
        self.depth.state = DepthState::Estimating { done: 0, total: 0 };
        if self.video.is_some() {
            self.frame_depth_plan = Some(DepthPlan {
                default_focus: false,
                ..plan.clone()
            });
        }
        self.depth_plan = Some(plan);
        self
    }

    /// The video frame whose views are shown (`None` outside videos).
    fn shown_frame(&self) -> Option<u64> {
        self.video.as_ref().map(|v| v.shown)
    }

    /// Depth is still on its way (a script's clicks and `wait-converged` wait for it).
    pub fn depth_pending(&self) -> bool {
        matches!(self.depth.state, DepthState::Estimating { .. })
    }

    fn since_launch_ms(&self) -> f64 {
        self.launched.elapsed().as_secs_f64() * 1e3
    }

    /// Starts the background estimate (after the first frame: the window comes first),
    /// follows its progress, and installs the depth when it arrives: the point cloud, the
    /// normals' window, anti-aliasing's default, the scene's framing.
    pub fn poll_depth(&mut self, gpu: &mut ViewerGpu) -> Result<()> {
        if self.depth_job.is_none() && self.milestones.first_frame_ms.is_some() {
            if let Some(plan) = &self.depth_plan {
                eprintln!(
                    "estimating the depth of '{}' in the background",
                    self.lf.name
                );
                match DepthJob::start(Arc::clone(&self.lf), plan.gpu.clone()) {
                    Ok(job) => {
                        self.depth_job = Some(job);
                        self.depth_job_frame = self.shown_frame();
                    }
                    Err(e) => self.depth_failed(e.to_string()),
                }
            }
        }
        let Some(job) = self.depth_job.as_mut() else {
            return Ok(());
        };
        let Some(result) = job.poll(&self.lf.name) else {
            let (done, total) = job.progress();
            let now = DepthState::Estimating { done, total };
            if self.depth.state != now {
                self.depth.state = now;
                self.dirty.text = true;
            }
            return Ok(());
        };
        let elapsed = job.elapsed_s();
        self.depth_job = None;
        if self.depth_job_frame != self.shown_frame() {
            // A frame shown since the estimate began has its own: this one is stale (its
            // validation errors still count). The next poll starts the shown frame's.
            if let Ok(e) = &result {
                self.depth_validation_errors += e.validation_errors;
            }
            return Ok(());
        }
        let plan = self.depth_plan.take();
        let estimated = match result {
            Ok(e) => e,
            Err(e) => {
                self.depth_failed(e.to_string());
                return Ok(());
            }
        };
        self.depth_validation_errors += estimated.validation_errors;
        let origin = estimated.origin;
        if let DepthOrigin::Estimated { estimate, .. } = &origin {
            // The job's thread has ended and dropped its reference: no copy of the views.
            let lf = Arc::make_mut(&mut self.lf);
            if let Err(e) = crate::depth::cache::install(lf, estimate) {
                self.depth_failed(e.to_string());
                return Ok(());
            }
        }
        let lf = Arc::clone(&self.lf);
        self.depth = DepthCache::new(&lf, lf.view_depth().ok())?;
        if let Some(c) = &self.depth.cloud {
            gpu.set_cloud(&c.vertices())?;
        }
        // A later video frame's depth replaces the one before: the scene camera stays where
        // it is and the console is told once.
        let first_depth = self.milestones.depth_ready_ms.is_none();
        if first_depth {
            eprintln!(
                "depth of '{}' ready after {elapsed:.1} s: the point cloud, clicks and \
                 anti-aliasing are on",
                lf.name
            );
            self.milestones.depth_ready_ms = Some(self.since_launch_ms());
        } else {
            log::info!(
                "depth of frame {:?} ready after {elapsed:.1} s",
                self.shown_frame()
            );
        }
        let plan = plan.as_ref();
        self.act(Action::DepthArrived {
            normal_window: origin.normal_window(),
            antialias: plan.is_some_and(|p| p.antialias),
            focus: plan
                .is_some_and(|p| p.default_focus)
                .then(|| default_focus(&lf, self.depth.depth.as_ref())),
        });
        if first_depth {
            let (centre, keep, array) = framing(&lf, &self.depth);
            let scene = self.layout.scene;
            self.act(Action::Reframe {
                centre,
                keep,
                array,
                aspect: scene.width.max(1.0) as f64 / scene.height.max(1.0) as f64,
            });
        }
        self.depth_origin = Some(origin);
        self.dirty.window_changed();
        self.dirty.cloud = true;
        Ok(())
    }

    fn depth_failed(&mut self, why: String) {
        log::warn!(
            "no depth for '{}': {why}; clicks and the point cloud are off",
            self.lf.name
        );
        self.depth_plan = None;
        self.depth.state = DepthState::Unavailable(format!("no depth ({why})"));
        self.refuse(format!("no depth: {why}"));
    }

    /// Applies `action` to the state and notes what to redraw.
    pub fn act(&mut self, action: Action) -> Effect {
        let orbit = self.state.orbit;
        let field = Field::of(&action);
        let message = self.state.message.clone();
        let effect = self.state.apply(&self.lf, action);
        if let (Some(field), Effect::Changed) = (field, &effect) {
            self.highlight = Some((field, Instant::now()));
        }
        if self.state.message != message {
            // A new message is anchored by the click that caused it, if any (set after this).
            self.message_at = None;
        }
        if self.state.orbit != orbit {
            // The cached cloud layer was rendered from the old scene camera.
            self.dirty.scene = true;
            self.dirty.cloud = true;
        }
        match &effect {
            Effect::Changed | Effect::Marked | Effect::Refused(_) => {
                self.dirty.text = true;
                self.dirty.scene = true;
            }
            Effect::NewViews | Effect::Message => self.dirty.text = true,
            Effect::SceneView => {
                self.dirty.scene = true;
                self.dirty.cloud = true;
            }
            Effect::Screenshot | Effect::Quit => {}
        }
        effect
    }

    /// An action from the user that changes the image: the view counts as interacted with.
    pub fn interact(&mut self, action: Action) -> Effect {
        self.last_input = Instant::now();
        self.act(action)
    }

    /// Shows why an input could not become an action.
    pub fn refuse(&mut self, why: String) {
        self.act(Action::Refuse(why));
    }

    pub fn scene_size(&self) -> (u32, u32) {
        (
            (self.layout.scene.width as u32).max(1),
            (self.layout.scene.height as u32).max(1),
        )
    }

    /// A click at refocus-image position `p` (full-size pixels of the reference view): a
    /// single-click plane, or with `shift` one of three clicks.
    pub fn click_refocus(&mut self, p: DVec2, shift: bool) {
        let reference = self.state.plan.reference_camera;
        match self.depth.depth_pixel(&self.lf, &reference, p) {
            Ok(d) => self.click_depth_pixel(d, shift),
            Err(why) => self.refuse(why),
        }
        let size = (self.lf.width, self.lf.height);
        self.anchor_message(self.layout.refocus_to_window(p, size));
    }

    /// A click at depth-view pixel `d` (what scripts give): a single-click plane, or with
    /// `shift` one of three clicks; a refusal is shown where the click landed.
    pub fn click_depth_pixel(&mut self, d: DVec2, shift: bool) {
        self.interact(if shift {
            Action::ThreeClick(d)
        } else {
            Action::Click(d)
        });
        let size = (self.lf.width, self.lf.height);
        self.anchor_message(self.layout.refocus_to_window(d, size));
    }

    /// The cursor is at window position `at`: the status strip reads the depth under it when
    /// it is over the refocus image (redrawn only when the reading changes).
    pub fn hover(&mut self, at: DVec2) {
        let view = (self.lf.width, self.lf.height);
        let reading = self
            .layout
            .refocus_pixel(at.x + 0.5, at.y + 0.5, view)
            .and_then(|p| {
                self.depth.reading(
                    &self.lf,
                    &self.state.plan.reference_camera,
                    p,
                    self.depth_origin.as_ref(),
                )
            });
        if reading != self.cursor_depth {
            self.cursor_depth = reading;
            self.dirty.text = true;
        }
    }

    /// The state's message (if any) is about a click at window position `at`.
    fn anchor_message(&mut self, at: DVec2) {
        if self.state.message.is_some() {
            self.message_at = Some(at);
            self.dirty.text = true;
        }
    }

    /// A click at pixel `p` of the scene panel: picks the cloud point there.
    pub fn click_scene(&mut self, p: DVec2) {
        let size = self.scene_size();
        match self.depth.scene_pick(&self.lf, &self.state.orbit, size, p) {
            Ok(point) => {
                self.interact(Action::ScenePick(point));
            }
            Err(why) => self.refuse(why),
        }
        let scene = self.layout.scene;
        self.anchor_message(DVec2::new(scene.x as f64, scene.y as f64) + p);
    }

    /// A video key: steps or plays the video, or says this is no video.
    pub fn video_key(&mut self, step: VideoStep) {
        match self.video.as_mut() {
            Some(v) => {
                v.step(step);
                self.dirty.text = true;
            }
            None => self.refuse(format!(
                "'{}' is not a video: , . and Space step and play camera-array videos",
                self.lf.name
            )),
        }
    }

    /// Shows the newest decoded video frame that is still wanted; keeps playing.
    pub fn poll_video(&mut self, gpu: &mut ViewerGpu) -> Result<()> {
        while let Some(decoded) = self.video.as_mut().and_then(Video::receive) {
            match decoded.light_field {
                Ok(frame_lf) => {
                    gpu.replace_views(&frame_lf)?;
                    if let Some(v) = self.video.as_mut() {
                        v.shown(decoded.frame);
                    }
                    if let Some(plan) = &self.frame_depth_plan {
                        // The frame's own depth, estimated in the background (cached by
                        // content); until it arrives the frame before's stays in use.
                        self.lf = Arc::new(frame_lf);
                        self.depth_plan = Some(plan.clone());
                        self.depth.state = DepthState::Estimating { done: 0, total: 0 };
                        self.dirty.text = true;
                    }
                    self.act(Action::ShowFrame(decoded.frame));
                }
                Err(e) => {
                    if let Some(v) = self.video.as_mut() {
                        v.playing = false;
                    }
                    self.refuse(format!("frame {}: {e}", decoded.frame));
                }
            }
        }
        if let Some(v) = self.video.as_mut() {
            v.keep_playing();
        }
        Ok(())
    }

    /// Lays the window out for `size` and rebuilds the GPU's window-size images.
    pub fn resize(&mut self, gpu: &mut ViewerGpu, size: (u32, u32)) -> Result<()> {
        let lf = &self.lf;
        self.layout = Layout::new(size.0, size.1, (lf.width, lf.height));
        self.panel = ControlPanel::new(self.layout.scene, self.panel.distance_centre);
        gpu.resize(
            vk::Extent2D {
                width: size.0,
                height: size.1,
            },
            &self.layout,
        )?;
        self.dirty.window_changed();
        Ok(())
    }

    /// The swapchain was out of date: rebuild for the window's current `size` (if it has one)
    /// and draw everything again.
    pub fn out_of_date(&mut self, gpu: &mut ViewerGpu, size: (i32, i32)) -> Result<()> {
        if size.0 > 0 && size.1 > 0 {
            self.resize(gpu, (size.0 as u32, size.1 as u32))?;
        }
        self.dirty.window_changed();
        Ok(())
    }

    /// Refinement is complete and nothing waits to be drawn.
    pub fn idle(&self) -> bool {
        self.refinement.refiner.converged()
            && self.refinement.is_current(self.state.version)
            && !self.dirty.scene
            && !self.dirty.text
            && !self.dirty.window
            && self.screenshots.next.is_none()
    }

    /// The image is final (`wait-converged`): refinement is complete for the current state,
    /// and no video frame asked for is still on its way.
    pub fn converged(&self) -> bool {
        !self.depth_pending()
            && self.video.as_ref().map_or(true, Video::settled)
            && self.refinement.refiner.converged()
            && self.refinement.is_current(self.state.version)
    }

    /// Restarts refinement after a change (full size once the input stops) and plans the next
    /// frame; `None` when there is nothing to draw.
    pub fn next_frame(&mut self, interactive: bool) -> Option<FramePlan> {
        if self
            .highlight
            .is_some_and(|(_, at)| at.elapsed() >= HIGHLIGHT_FOR)
        {
            self.highlight = None;
            self.dirty.text = true;
        }
        if self
            .notice
            .as_ref()
            .is_some_and(|(_, at)| at.elapsed() >= NOTICE_FOR)
        {
            self.notice = None;
            self.dirty.text = true;
        }
        if self.aa_version != self.state.version {
            self.aa = self.antialias_plan();
            self.surface = self.surface_plan();
            self.aa_version = self.state.version;
        }
        let state = &self.state;
        if self
            .refinement
            .update(&state.plan, self.aa.as_ref(), state.version, interactive)
        {
            self.dirty.text = true;
        }
        if state.marks_version != self.dirty.marks_seen {
            self.dirty.marks_seen = state.marks_version;
            self.dirty.scene = true;
            self.dirty.text = true;
        }
        let batch = self.refinement.refiner.next_batch(interactive);
        if batch.is_none()
            && !self.dirty.scene
            && !self.dirty.text
            && !self.dirty.window
            && self.screenshots.next.is_none()
        {
            return None;
        }
        if batch.is_some() && self.hud.drawn_at.elapsed() >= STATUS_PERIOD {
            self.dirty.text = true;
        }
        Some(FramePlan { batch, interactive })
    }

    /// The anti-aliasing plan of the current state, when it is on and the session has depth;
    /// a plan that cannot be made (classic shift-and-sum) is the plain sum, with a warning.
    fn antialias_plan(&self) -> Option<AntialiasPlan> {
        let (settings, depth) = (self.antialias?, self.depth.depth.as_ref()?);
        if !self.state.antialias() {
            return None;
        }
        let s = &self.state;
        // The full-size target is the views' size; a focus surface takes boxed footprints and
        // sub-samples (`AntialiasSettings::for_output`).
        let settings = settings.for_output(!s.surface().needs_depth());
        // The views' visibility maps depend on the depth and the view set, not on the plane:
        // moving the plane reuses them.
        crate::refocus::antialias::plan_antialias_reusing(
            &self.lf,
            &s.plan,
            s.aperture(),
            s.excluded(),
            depth,
            settings,
            self.aa.as_ref(),
        )
        .map_err(|e| log::warn!("anti-aliasing is off for this view: {e}"))
        .ok()
    }

    /// The state's focus surface with the scene depth, when it is more than the plane: the
    /// same `refocus::surface::surface_for` as `render`, reading anti-aliasing's depth when
    /// that is on. The state checked its geometry; what fails here (no depth) is shown.
    fn surface_plan(&mut self) -> Option<SurfacePlan> {
        let surface = self.state.surface();
        if !surface.needs_depth() {
            return None;
        }
        let made = crate::refocus::surface::surface_for(
            &self.lf,
            &self.state.plan,
            &surface,
            self.aa.as_ref(),
        );
        match made {
            Ok(sp) => Some(sp),
            Err(e) => {
                log::warn!("the focus surface is off for this view: {e}");
                self.refuse(format!("focus surface off: {e}"));
                None
            }
        }
    }

    /// Brings focus peaking's mask up to date with the state (once input pauses), or drops it
    /// while peaking is off or the mask belongs to an earlier state. A new panel size alone
    /// only maps the views' mask again.
    fn update_peaks(&mut self) {
        let r = self.layout.refocus;
        let size = (r.width.max(0.0) as u32, r.height.max(0.0) as u32);
        if !self.state.show_peaking || size.0 == 0 || size.1 == 0 {
            self.peaks = None;
            return;
        }
        let at_views = match self.peaks.take() {
            Some(p) if p.version == self.state.version && p.size == size => {
                self.peaks = Some(p);
                return;
            }
            Some(p) if p.version == self.state.version => p.at_views,
            _ if self.last_input.elapsed() < PEAKS_AFTER_INPUT => return,
            _ => {
                let plan = &self.state.plan;
                let m = plan.m;
                let averaging = self.state.averaging();
                match &self.surface {
                    Some(surface) => {
                        crate::refocus::cpu::focus_peaks(&self.lf, plan, averaging, |px| {
                            surface.inverse_depth(px)
                        })
                    }
                    None => crate::refocus::cpu::focus_peaks(&self.lf, plan, averaging, |px| {
                        m.dot(px.extend(1.0)).max(0.0)
                    }),
                }
            }
        };
        // The panel's pixels take their nearest reference pixel's value.
        let (vw, vh) = (self.lf.width as usize, self.lf.height as usize);
        let mask = (0..size.0 as usize * size.1 as usize)
            .map(|i| {
                let (x, y) = (i % size.0 as usize, i / size.0 as usize);
                let vx = ((x as f64 + 0.5) / size.0 as f64 * vw as f64) as usize;
                let vy = ((y as f64 + 0.5) / size.1 as f64 * vh as f64) as usize;
                at_views[vy.min(vh - 1) * vw + vx.min(vw - 1)]
            })
            .collect();
        self.peaks = Some(Peaks {
            version: self.state.version,
            at_views,
            size,
            mask,
        });
    }

    /// Redraws the on-screen text if it changed; returns the new status line (for the title).
    pub fn redraw_text(&mut self) -> Option<String> {
        if !self.dirty.text {
            return None;
        }
        self.update_peaks();
        let status = Status {
            lf: &self.lf,
            state: &self.state,
            depth: &self.depth.state,
            refinement: &self.refinement,
            fps: self.stats.fps,
            highlight: self.highlight.map(|(f, _)| f),
            message_at: self.message_at,
            panel: self.state.show_panel.then_some(&self.panel),
            cursor: self.cursor_depth.as_deref(),
            notice: self.notice.as_ref().map(|(n, _)| n.as_str()),
            peaks: self.peaks.as_ref(),
        };
        let line = self.hud.draw(&self.layout, &status);
        self.dirty.text = false;
        Some(line)
    }

    /// Records and presents the frame `plan` (its batch goes to the GPU).
    pub fn draw(&mut self, gpu: &mut ViewerGpu, plan: &mut FramePlan) -> Result<FrameResult> {
        let overlay = if self.dirty.scene {
            Some(scene::scene_overlay(&self.lf, &self.state, &self.depth)?)
        } else {
            None
        };
        let view = SceneView {
            clip_from_world: self.state.orbit.clip_from_world(self.scene_size()),
            point_size: self.depth.point_size(self.layout.scene.height as f64),
            marker_size: MARKER_SIZE,
        };
        // A reduced-size preview (input in progress on a device too slow for full size) is
        // the plain sum of the same views: their spread over the aperture already shows the
        // defocus, and anti-aliasing would cost the preview most of its frame rate (on
        // lavapipe with backgammon 48 ms of GPU per preview frame against a few). Full-size
        // frames, and so the converged image, are anti-aliased as before.
        let preview = plan.batch.as_ref().is_some_and(|b| b.divisor > 1);
        let result = gpu.frame(FrameRequest {
            plan: &self.refinement.ordered,
            antialias: self.refinement.ordered_aa.as_ref().filter(|_| !preview),
            surface: self.surface.as_ref(),
            averaging: self.state.averaging(),
            batch: plan.batch.take(),
            scene: overlay.as_ref().map(|o| (view, o, self.dirty.cloud)),
            canvas: &mut self.hud.canvas,
            layout: &self.layout,
            capture_window: self.screenshots.next.is_some(),
            tag: (self.refinement.id, plan.interactive),
            overlay_parts: &self.hud.parts,
        })?;
        if overlay.is_some() {
            self.dirty.cloud = false;
        }
        self.dirty.scene = false;
        self.dirty.window = false;
        Ok(result)
    }

    /// After a frame: statistics, the timings of completed frames, the screenshot it took.
    /// `full_size` is whether the frame's batch was at full size.
    pub fn finish_frame(
        &mut self,
        gpu: &mut ViewerGpu,
        plan: &FramePlan,
        full_size: bool,
        result: FrameResult,
    ) -> Result<()> {
        self.stats.presented(plan.interactive);
        if self.milestones.first_frame_ms.is_none() {
            self.milestones.first_frame_ms = Some(self.since_launch_ms());
        }
        let converged_now = full_size && self.refinement.refiner.converged();
        let mut timings: Vec<_> = result.timing.into_iter().collect();
        if converged_now {
            // The view is about to go idle: collect the timings of the last frames now.
            timings.extend(gpu.drain_timings()?);
        }
        for t in &timings {
            self.refinement.measured(t, &mut self.stats);
        }
        if converged_now {
            self.dirty.text = true;
            self.refinement.converged(&mut self.stats);
        }
        if let Some(prefix) = self.screenshots.next.take() {
            screenshot::save(
                gpu,
                &self.lf,
                &self.state,
                self.aa.as_ref(),
                self.surface.as_ref(),
                self.depth_origin.as_ref(),
                &prefix,
                result.window.as_ref(),
                self.stats.frames,
                (
                    self.cursor_depth.as_deref(),
                    self.notice.as_ref().map(|(n, _)| n.as_str()),
                    serde_json::json!({
                        "on": self.state.show_peaking,
                        "tinted_fraction": self.peaks.as_ref().map(Peaks::fraction),
                    }),
                ),
            )?;
            if std::mem::take(&mut self.screenshots.announce) {
                self.notice = Some((
                    format!(
                        "saved {}_window.png (+ refocus, scene, json)",
                        prefix.display()
                    ),
                    Instant::now(),
                ));
                self.dirty.text = true;
            }
        }
        Ok(())
    }
}

/// What the scene panel frames: the cloud's centre (if there is a cloud), the points to keep
/// in view (its box corners and the camera centres) and the camera array.
pub fn framing(
    lf: &LightField,
    depth: &DepthCache,
) -> (Option<glam::DVec3>, Vec<glam::DVec3>, Vec<glam::DVec3>) {
    let cameras: Vec<glam::DVec3> = lf.views.iter().map(|v| v.camera.centre()).collect();
    let mut keep = depth.corners();
    keep.extend(&cameras);
    (depth.centre(), keep, cameras)
}
