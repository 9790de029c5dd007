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
use std::time::{Duration, Instant};

use ash::vk;
use glam::DVec2;

use super::gpu::{FrameRequest, FrameResult, ViewerGpu};
use super::layout::Layout;
use super::refine::Refiner;
use super::state::{Action, Effect, ViewerState};
use crate::error::Result;
use crate::lightfield::video::FrameSequence;
use crate::lightfield::LightField;
use crate::passes::scene::SceneView;
use crate::refocus::antialias::{AntialiasPlan, AntialiasSettings};
use depth::DepthCache;
use hud::{Hud, Status};
use refinement::{FramePlan, Refinement};
use screenshot::Screenshots;
use stats::Stats;
use video::{Video, VideoStep};

/// How often the status text refreshes its timings while frames are rendered.
const STATUS_PERIOD: Duration = Duration::from_millis(250);
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

/// A viewing session.
pub struct Session<'a> {
    pub lf: &'a LightField,
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
}

impl<'a> Session<'a> {
    /// A session on `lf` starting in `state`, in a window of `layout`; `video` is the
    /// sequence `lf` is a frame of and that frame's number.
    pub fn new(
        lf: &'a LightField,
        state: ViewerState,
        depth: DepthCache,
        layout: Layout,
        refiner: Refiner,
        video: Option<(FrameSequence, u64)>,
        screenshot_prefix: PathBuf,
    ) -> Self {
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
        }
    }

    /// Applies `action` to the state and notes what to redraw.
    pub fn act(&mut self, action: Action) -> Effect {
        let orbit = self.state.orbit;
        let effect = self.state.apply(self.lf, action);
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
        match self.depth.depth_pixel(self.lf, &reference, p) {
            Ok(d) => {
                self.interact(if shift {
                    Action::ThreeClick(d)
                } else {
                    Action::Click(d)
                });
            }
            Err(why) => self.refuse(why),
        }
    }

    /// A click at pixel `p` of the scene panel: picks the cloud point there.
    pub fn click_scene(&mut self, p: DVec2) {
        let size = self.scene_size();
        match self.depth.scene_pick(self.lf, &self.state.orbit, size, p) {
            Ok(point) => {
                self.interact(Action::ScenePick(point));
            }
            Err(why) => self.refuse(why),
        }
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
        let lf = self.lf;
        self.layout = Layout::new(size.0, size.1, (lf.width, lf.height));
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
        self.video.as_ref().map_or(true, Video::settled)
            && self.refinement.refiner.converged()
            && self.refinement.is_current(self.state.version)
    }

    /// Restarts refinement after a change (full size once the input stops) and plans the next
    /// frame; `None` when there is nothing to draw.
    pub fn next_frame(&mut self, interactive: bool) -> Option<FramePlan> {
        if self.aa_version != self.state.version {
            self.aa = self.antialias_plan();
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
        crate::refocus::antialias::plan_antialias(
            self.lf,
            &s.plan,
            s.aperture(),
            s.excluded(),
            depth,
            settings,
        )
        .map_err(|e| log::warn!("anti-aliasing is off for this view: {e}"))
        .ok()
    }

    /// Redraws the on-screen text if it changed; returns the new status line (for the title).
    pub fn redraw_text(&mut self) -> Option<String> {
        if !self.dirty.text {
            return None;
        }
        let status = Status {
            lf: self.lf,
            state: &self.state,
            refinement: &self.refinement,
            fps: self.stats.fps,
        };
        let line = self.hud.draw(&self.layout, &status);
        self.dirty.text = false;
        Some(line)
    }

    /// Records and presents the frame `plan` (its batch goes to the GPU).
    pub fn draw(&mut self, gpu: &mut ViewerGpu, plan: &mut FramePlan) -> Result<FrameResult> {
        let overlay = if self.dirty.scene {
            Some(scene::scene_overlay(self.lf, &self.state, &self.depth)?)
        } else {
            None
        };
        let view = SceneView {
            clip_from_world: self.state.orbit.clip_from_world(self.scene_size()),
            point_size: self.depth.point_size(self.layout.scene.height as f64),
            marker_size: MARKER_SIZE,
        };
        let result = gpu.frame(FrameRequest {
            plan: &self.refinement.ordered,
            antialias: self.refinement.ordered_aa.as_ref(),
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
                self.lf,
                &self.state,
                self.aa.as_ref(),
                &prefix,
                result.window.as_ref(),
                self.stats.frames,
            )?;
        }
        Ok(())
    }
}
