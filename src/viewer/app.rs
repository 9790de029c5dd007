//! The window and the event loop — the only module that touches GLFW. Each turn of the loop:
//! script commands until one has to wait → wait for (or poll) window events → events become
//! calls on the [`Session`] (and through it [`Action`]s on the UI state) → at most one key
//! press → the next decoded video frame → the window's size → one frame, if anything is to be
//! drawn. When nothing is, the loop blocks in the window system's event wait.
//!
//! The loop's own state is input in progress ([`Input`]: keys waiting for their frame, the
//! pointer) and the window's ([`Viewer`]: a scripted resize in progress, minimised, quit).

use std::collections::VecDeque;
use std::ffi::CString;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use ash::vk;
use ash::vk::Handle;
use glam::DVec2;
use glfw::{Action as KeyAction, Key, Modifiers, MouseButton, WindowEvent};

use super::controls::{action_for_chord, video_step_for_key, FINE};
use super::gpu::ViewerGpu;
use super::layout::Layout;
use super::panel::Hit;
use super::refine::Refiner;
use super::script::{self, Command, Line, Panel, Runner};
use super::session::depth::DepthCache;
use super::session::stats::FrameStats;
use super::session::{framing, DepthPlan, Milestones, Session};
use super::state::{default_focus, Action, Effect, ViewerState};
use crate::depth::DepthOrigin;
use crate::error::{Error, Result};
use crate::geometry::aperture::Aperture;
use crate::gpu::swapchain::PresentMode;
use crate::gpu::{GpuContext, GpuOptions};
use crate::jobs::strategy::Chosen;
use crate::lightfield::video::FrameSequence;
use crate::lightfield::LightField;
use crate::refocus::antialias::AntialiasSettings;
use crate::refocus::settings::ViewStorage;
use crate::refocus::settings::{Filter, Strategy};
use crate::refocus::{Averaging, FocusRequest};

/// How long after the last input the view counts as "being interacted with".
const INTERACTION: Duration = Duration::from_millis(150);
/// Pixels the pointer may move between press and release and still click.
const CLICK_SLOP: f64 = 3.0;
/// How often the idle loop looks for a video frame being decoded, seconds.
const DECODE_POLL_S: f64 = 0.01;
/// How often the idle loop looks at a script waiting for convergence, seconds.
const SCRIPT_POLL_S: f64 = 0.05;
/// How often the idle loop looks at a depth estimate in the background, seconds.
const DEPTH_POLL_S: f64 = 0.1;

/// Everything `view` is asked to do.
#[derive(Debug, Clone)]
pub struct ViewerOptions {
    /// Initial focus; `None` = the light field's natural focus (disparity 0 on parallel rigs,
    /// the median scene depth on calibrated rigs with depth).
    pub focus: Option<FocusRequest>,
    pub aperture: Aperture,
    pub reference: Option<DVec2>,
    pub averaging: Averaging,
    /// Views left out of the aperture (dark corners).
    pub excluded: Vec<bool>,
    pub present: PresentMode,
    pub frame_budget_ms: f64,
    /// Initial window size.
    pub window: (u32, u32),
    pub script: Vec<Line>,
    pub gpu: GpuOptions,
    pub storage: ViewStorage,
    /// How the views are sampled (as `render --filter`).
    pub filter: Filter,
    /// How the views are summed (`None`: the device's fastest, [`crate::jobs::strategy`]).
    pub strategy: Option<Strategy>,
    /// Where `P` writes screenshots (prefix; a counter is appended).
    pub screenshot_prefix: PathBuf,
    /// The video `lf` is a frame of, and that frame's number: `,` `.` step, Space plays.
    pub video: Option<(FrameSequence, u64)>,
    /// Normal window of clicks (see [`crate::depth::DepthOrigin::normal_window`]).
    pub normal_window: u32,
    /// Anti-aliasing's sampling (the X key toggles it; it needs the light field's depth) and
    /// whether it is on when there is depth (at start with the light field's own map, else
    /// once the background estimate arrives).
    pub antialias: AntialiasSettings,
    pub antialias_on: bool,
    /// Where `lf`'s depth comes from when it has its own map; without one the viewer opens
    /// at once and estimates depth in the background ([`Session::poll_depth`]).
    pub depth: Option<DepthOrigin>,
    /// When the process started (`first_frame_ms` and `depth_ready_ms` count from it).
    pub launched: Instant,
}

/// The final state and what the session measured.
pub struct ViewerReport {
    /// The light field shown: its name, grid and view size.
    pub light_field: (String, crate::lightfield::GridSize, (u32, u32)),
    pub state: ViewerState,
    pub frames: FrameStats,
    /// The window's context's and the depth estimate's together.
    pub validation_errors: usize,
    /// Where the depth came from (`None`: the light field has none and none could be made).
    pub depth: Option<DepthOrigin>,
    pub milestones: Milestones,
    /// The final focus surface, as `render --json` reports it.
    pub surface: serde_json::Value,
    /// The final anti-aliasing plan, as `render --json` reports it: the route taken (layered
    /// footprints or sub-samples), not only the settings asked for.
    pub antialias: serde_json::Value,
    pub device: String,
    /// How the views were summed and whether that was chosen for the device.
    pub strategy: Chosen,
    pub present_mode: String,
    pub window: (u32, u32),
}

/// Pointer state between press and release.
#[derive(Debug, Clone, Copy)]
struct Press {
    button: MouseButton,
    at: DVec2,
    last: DVec2,
    shift: bool,
    moved: bool,
    /// The control panel's widget pressed (the panel takes the pointer until release).
    panel: Option<Hit>,
}

/// Input in progress.
#[derive(Debug, Default)]
struct Input {
    /// Key presses (key, Shift, Control) waiting for their frame: from the keyboard or a
    /// script.
    pending: VecDeque<(Key, bool, bool)>,
    press: Option<Press>,
    cursor: DVec2,
    shift: bool,
}

/// The open window, its GPU side and the session shown in it. `gpu` is declared (so dropped)
/// before `window`: the swapchain's surface goes before the window it was made for.
struct Viewer {
    gpu: ViewerGpu,
    session: Session,
    window: glfw::PWindow,
    events: glfw::GlfwReceiver<(f64, WindowEvent)>,
    glfw: glfw::Glfw,
    input: Input,
    script: Runner,
    /// A scripted resize the window system has not applied yet.
    resize_to: Option<(u32, u32)>,
    minimised: bool,
    quit: bool,
    /// The window title's prefix and the device's name (the title shows the status line).
    title: String,
    device: String,
    strategy: Chosen,
}

fn init_glfw() -> Result<glfw::Glfw> {
    let glfw = glfw::init(glfw::log_errors).map_err(|e| {
        Error::Window(format!(
            "cannot start GLFW ({e:?}); is there a display? (DISPLAY={}; headless machines can \
             run the viewer under xvfb-run)",
            std::env::var("DISPLAY").unwrap_or_default()
        ))
    })?;
    if !glfw.vulkan_supported() {
        return Err(Error::Window(
            "GLFW finds no Vulkan loader for windows (install libvulkan1)".into(),
        ));
    }
    Ok(glfw)
}

fn create_window(
    glfw: &mut glfw::Glfw,
    size: (u32, u32),
    title: &str,
) -> Result<(glfw::PWindow, glfw::GlfwReceiver<(f64, WindowEvent)>)> {
    glfw.window_hint(glfw::WindowHint::ClientApi(glfw::ClientApiHint::NoApi));
    let (mut window, events) = glfw
        .create_window(size.0, size.1, title, glfw::WindowMode::Windowed)
        .ok_or_else(|| Error::Window("cannot create a window".into()))?;
    window.set_key_polling(true);
    window.set_mouse_button_polling(true);
    window.set_cursor_pos_polling(true);
    window.set_scroll_polling(true);
    window.set_framebuffer_size_polling(true);
    window.set_close_polling(true);
    window.set_refresh_polling(true);
    Ok((window, events))
}

/// The GPU context with the window system's surface extensions, and the window's surface.
fn create_context(
    glfw: &glfw::Glfw,
    window: &mut glfw::PWindow,
    gpu: &GpuOptions,
) -> Result<(Arc<GpuContext>, vk::SurfaceKHR)> {
    let extensions = glfw.get_required_instance_extensions().ok_or_else(|| {
        Error::Window("the window system offers no Vulkan surface extensions".into())
    })?;
    let mut gpu_opts = gpu.clone();
    gpu_opts.swapchain = true;
    for e in extensions {
        gpu_opts
            .instance_extensions
            .push(CString::new(e).map_err(|e| Error::Window(e.to_string()))?);
    }
    let ctx = Arc::new(GpuContext::new(&gpu_opts)?);
    let mut raw: glfw::ffi::VkSurfaceKHR = std::ptr::null_mut();
    // SAFETY: the instance is valid and created with GLFW's required extensions; `raw`
    // receives a new surface that the swapchain takes over.
    let r = unsafe {
        window.create_window_surface(
            ctx.instance.handle().as_raw() as glfw::ffi::VkInstance,
            std::ptr::null(),
            &mut raw,
        )
    };
    if r != 0 {
        return Err(Error::Window(format!(
            "cannot create a Vulkan surface for the window (VkResult {r})"
        )));
    }
    Ok((ctx, vk::SurfaceKHR::from_raw(raw as u64)))
}

/// The UI state the viewer starts in (before the window opens, so bad options fail early).
fn initial_state(lf: &LightField, opts: &ViewerOptions) -> Result<ViewerState> {
    let depth = lf.view_depth().ok();
    let focus = opts
        .focus
        .unwrap_or_else(|| default_focus(lf, depth.as_ref()));
    let mut state = ViewerState::new(
        lf,
        focus,
        opts.aperture,
        opts.reference,
        opts.averaging,
        opts.excluded.clone(),
    )?;
    state.normals = state.normals.with_window(opts.normal_window);
    state.frame = opts.video.as_ref().map(|(_, f)| *f);
    Ok(state.with_antialias(opts.antialias_on && depth.is_some()))
}

/// What a [`Loader`] hands over: the light field and the options that depend on it.
pub struct Loaded {
    pub lf: LightField,
    /// Views left out of the aperture (dark corners).
    pub excluded: Vec<bool>,
    /// Normal window of clicks (see [`crate::depth::DepthOrigin::normal_window`]).
    pub normal_window: u32,
    /// Where `lf`'s depth comes from when it has its own map.
    pub depth: Option<DepthOrigin>,
    /// The video `lf` is a frame of, and that frame's number.
    pub video: Option<(FrameSequence, u64)>,
}

/// Reads the light field, on a thread of its own while the window shows the loading screen.
pub type Loader = Box<dyn FnOnce() -> Result<Loaded> + Send>;

/// How often the loading screen is redrawn, seconds.
const LOADING_POLL_S: f64 = 0.05;

/// What the loading thread is doing (the loading screen says it).
const STAGE_VIEWS: u8 = 0;
const STAGE_DEPTH: u8 = 1;

/// Opens the window at once, shows what is loading while `load` reads the light field on a
/// thread (the views, then the depth and its point cloud), then runs until the user or the
/// script quits. `source` names what is loading. Without a depth map of its own, the light
/// field gets one estimated in the background while the window shows it.
pub fn run(load: Loader, source: &str, mut opts: ViewerOptions) -> Result<ViewerReport> {
    if !(opts.frame_budget_ms.is_finite() && opts.frame_budget_ms > 0.0) {
        return Err(Error::Invalid(format!(
            "--frame-budget-ms must be a positive number of milliseconds, got {}",
            opts.frame_budget_ms
        )));
    }
    let mut glfw = init_glfw()?;
    let (mut window, events) = create_window(&mut glfw, opts.window, "tiltfield — loading")?;
    let (ctx, surface) = create_context(&glfw, &mut window, &opts.gpu)?;
    let (fw, fh) = window.get_framebuffer_size();
    let mut gpu = ViewerGpu::new_window(
        Arc::clone(&ctx),
        surface,
        extent_of(fw, fh),
        opts.present,
        opts.storage,
    )?;
    let stage = Arc::new(std::sync::atomic::AtomicU8::new(STAGE_VIEWS));
    let loading = {
        let stage = Arc::clone(&stage);
        std::thread::Builder::new()
            .name("tiltfield-load".into())
            .spawn(move || -> Result<(Loaded, DepthCache)> {
                let loaded = load()?;
                stage.store(STAGE_DEPTH, std::sync::atomic::Ordering::Relaxed);
                let depth = DepthCache::new(&loaded.lf, loaded.lf.view_depth().ok())?;
                Ok((loaded, depth))
            })
            .map_err(|e| Error::Window(format!("cannot start the loading thread: {e}")))?
    };
    let window_ms = show_loading(
        &mut glfw,
        &mut window,
        &events,
        &mut gpu,
        &loading,
        &stage,
        source,
        opts.launched,
    )?;
    let (loaded, depth) = loading
        .join()
        .map_err(|_| Error::Window("the light field's loading thread panicked".into()))??;
    let Loaded {
        lf,
        excluded,
        normal_window,
        depth: depth_origin,
        video,
    } = loaded;
    opts.excluded = excluded;
    opts.normal_window = normal_window;
    opts.depth = depth_origin;
    opts.video = video;

    let lf = Arc::new(lf);
    let state = initial_state(&lf, &opts)?;
    script::check(&opts.script, (lf.width, lf.height), opts.window).map_err(Error::Invalid)?;
    let has_depth = depth.depth.is_some();
    // The scene panel frames the cloud (where there is one) and the camera array.
    let (centre, keep, cameras) = framing(&lf, &depth);
    let (fw, fh) = window.get_framebuffer_size();
    let extent = extent_of(fw, fh);
    let layout = Layout::new(extent.width, extent.height, (lf.width, lf.height));
    let panel = layout.scene;
    let aspect = panel.width.max(1.0) as f64 / panel.height.max(1.0) as f64;
    let state = state.with_scene_framing(centre, keep, cameras, aspect);

    let title = format!("tiltfield — {}", lf.name);
    window.set_title(&title);
    if gpu.swapchain_info().0 != extent {
        gpu.resize(extent, &layout)?;
    }
    gpu.attach_views(&lf)?;
    gpu.filter = opts.filter;
    let strategy = crate::jobs::strategy::choose(&ctx, opts.strategy)?;
    gpu.strategy = strategy.strategy;
    gpu.rebuild_panels(&layout)?;
    if let Some(c) = &depth.cloud {
        gpu.set_cloud(&c.vertices())?;
    }
    let refiner = Refiner::new(opts.frame_budget_ms, lf.width as u64 * lf.height as u64);
    let depth_plan = (!has_depth).then(|| DepthPlan {
        gpu: opts.gpu.clone(),
        antialias: opts.antialias_on,
        default_focus: opts.focus.is_none(),
    });
    let mut session = Session::new(
        Arc::clone(&lf),
        state,
        depth,
        layout,
        refiner,
        opts.video.clone(),
        opts.screenshot_prefix.clone(),
        opts.launched,
    )
    .with_depth_origin(opts.depth.clone());
    session.milestones.window_ms = window_ms;
    if let Some(plan) = depth_plan {
        session = session.with_depth_plan(plan);
    }
    drop(lf);
    session.antialias = Some(opts.antialias);
    let viewer = Viewer {
        gpu,
        session,
        window,
        events,
        glfw,
        input: Input::default(),
        script: Runner::new(&opts.script),
        resize_to: None,
        minimised: false,
        quit: false,
        title,
        device: ctx.info.name.clone(),
        strategy,
    };
    viewer.run()
}

fn extent_of(width: i32, height: i32) -> vk::Extent2D {
    vk::Extent2D {
        width: width.max(1) as u32,
        height: height.max(1) as u32,
    }
}

/// The loading screen: redrawn every [`LOADING_POLL_S`] with what `loading` is doing (the
/// views decoded so far, then the depth and the point cloud) until it finishes; follows
/// resizes. Returns when the first loading frame was presented (ms since `launched`). A window
/// closed meanwhile is an error: the light field's reading cannot be interrupted, and there is
/// nothing to report yet.
#[allow(clippy::too_many_arguments)]
fn show_loading<T>(
    glfw: &mut glfw::Glfw,
    window: &mut glfw::PWindow,
    events: &glfw::GlfwReceiver<(f64, WindowEvent)>,
    gpu: &mut ViewerGpu,
    loading: &std::thread::JoinHandle<T>,
    stage: &std::sync::atomic::AtomicU8,
    source: &str,
    launched: Instant,
) -> Result<Option<f64>> {
    let (fw, fh) = window.get_framebuffer_size();
    let mut extent = extent_of(fw, fh);
    let mut layout = Layout::new(extent.width, extent.height, (1, 1));
    gpu.rebuild_panels(&layout)?;
    let mut shown = None;
    loop {
        let mut canvas = super::text::Canvas::new(extent.width, extent.height);
        let line = match stage.load(std::sync::atomic::Ordering::Relaxed) {
            STAGE_VIEWS => match crate::lightfield::images::DECODE_PROGRESS.get() {
                (_, 0) => format!("loading {source}: reading"),
                (done, total) => format!(
                    "loading {source}: decoding views {done}/{total} ({:.0} %)",
                    100.0 * done as f64 / total as f64
                ),
            },
            _ => format!("loading {source}: depth and point cloud"),
        };
        loading_text(&mut canvas, &layout, &line);
        gpu.loading_frame(&mut canvas, &layout)?;
        shown.get_or_insert_with(|| launched.elapsed().as_secs_f64() * 1e3);
        if loading.is_finished() {
            return Ok(shown);
        }
        glfw.wait_events_timeout(LOADING_POLL_S);
        for (_, event) in glfw::flush_messages(events) {
            if let WindowEvent::FramebufferSize(w, h) = event {
                if w > 0 && h > 0 {
                    extent = extent_of(w, h);
                    layout = Layout::new(extent.width, extent.height, (1, 1));
                    gpu.resize(extent, &layout)?;
                }
            }
        }
        if window.should_close() {
            return Err(Error::Window(format!(
                "the window was closed while {source} was loading"
            )));
        }
    }
}

/// The loading screen's text: the program's name in the middle of the window and `line` in
/// the status strip, over the strip's background.
fn loading_text(canvas: &mut super::text::Canvas, layout: &Layout, line: &str) {
    use super::text::{GLYPH, PANEL_BG, TEXT};
    let (w, h) = (canvas.width as i64, canvas.height as i64);
    let s = layout.status;
    canvas.fill(
        s.x as i64,
        s.y as i64,
        s.width as i64,
        s.height as i64,
        PANEL_BG,
    );
    let y = s.y as i64 + (s.height as i64 - GLYPH as i64) / 2;
    canvas.text(s.x as i64 + 12, y, 1, line, TEXT);
    let name = "tiltfield";
    let scale = 3;
    let x = (w - (name.len() as i64) * (GLYPH * scale) as i64) / 2;
    canvas.text(x, (h - s.height as i64) / 2 - 12, scale, name, TEXT);
}

impl Viewer {
    /// The event loop (see the module docs); the report once it quits.
    fn run(mut self) -> Result<ViewerReport> {
        while !self.quit {
            self.run_script();
            if self.quit {
                break;
            }
            self.wait_for_events();
            let events: Vec<WindowEvent> =
                glfw::flush_messages(&self.events).map(|(_, e)| e).collect();
            for event in events {
                self.handle_event(event);
            }
            if self.window.should_close() {
                self.quit = true;
            }
            self.press_next_key();
            if self.quit {
                break;
            }
            if self.minimised {
                continue;
            }
            self.session.poll_video(&mut self.gpu)?;
            self.session.poll_depth(&mut self.gpu)?;
            if !self.fit_window()? {
                continue;
            }
            self.frame()?;
        }
        self.finish()
    }

    /// Runs script commands until one has to wait (for time, convergence, or the frame of a
    /// key press or screenshot already asked for).
    fn run_script(&mut self) {
        while !self.quit && self.input.pending.is_empty() && self.session.screenshots.next.is_none()
        {
            let session = &self.session;
            let Some(line) = self
                .script
                .next(|| session.converged(), !session.depth_pending())
            else {
                break;
            };
            self.run_command(line.command);
            log::debug!("script line {} done", line.number);
        }
    }

    fn run_command(&mut self, command: Command) {
        let s = &mut self.session;
        match command {
            Command::Key {
                key,
                shift,
                ctrl,
                count,
            } => {
                for _ in 0..count {
                    self.input.pending.push_back((key, shift, ctrl));
                }
            }
            // Script clicks give depth-view pixels directly.
            Command::Click {
                panel: Panel::Refocus,
                x,
                y,
                shift,
            } => {
                s.click_depth_pixel(DVec2::new(x, y), shift);
            }
            Command::Click {
                panel: Panel::Scene,
                x,
                y,
                ..
            } => s.click_scene(DVec2::new(x + 0.5, y + 0.5)),
            Command::Pointer { from, to } => {
                // The mouse's own path: press, move, release.
                self.input.cursor = DVec2::new(from.0, from.1);
                self.pressed(MouseButton::Button1, false);
                self.pointer_moved(DVec2::new(to.0, to.1));
                self.pointer_released(MouseButton::Button1);
            }
            Command::Drag { from, to } => {
                let size = s.scene_size();
                s.act(Action::Orbit(
                    DVec2::new(to.0 - from.0, to.1 - from.1),
                    size,
                ));
            }
            Command::Scroll {
                panel: Panel::Refocus,
                dy,
            } => {
                s.interact(Action::DisparitySteps(dy));
            }
            Command::Scroll {
                panel: Panel::Scene,
                dy,
            } => {
                s.act(Action::Zoom(dy));
            }
            Command::Resize(w, h) => {
                self.window.set_size(w as i32, h as i32);
                self.resize_to = Some((w, h));
            }
            Command::Screenshot(prefix) => s.screenshots.next = Some(prefix),
            Command::Quit => self.quit = true,
            // Taken by the runner.
            Command::Wait(_) | Command::WaitConverged => {}
        }
    }

    /// Polls the window system while there is work; else blocks until input, or until a
    /// script wait, a video frame being decoded or the interaction window ends.
    fn wait_for_events(&mut self) {
        let busy =
            !self.session.idle() || !self.input.pending.is_empty() || self.resize_to.is_some();
        if busy && !self.minimised {
            self.glfw.poll_events();
            return;
        }
        self.session.stats.idle();
        let mut timeout: Option<f64> = self.script.wakes_at().map(|t| {
            t.saturating_duration_since(std::time::Instant::now())
                .as_secs_f64()
        });
        if self.session.video.as_ref().is_some_and(|v| v.decoding()) {
            timeout = Some(timeout.map_or(DECODE_POLL_S, |t| t.min(DECODE_POLL_S)));
        }
        if let Some(left) = self.session.highlight_left() {
            let left = left.as_secs_f64();
            timeout = Some(timeout.map_or(left, |t| t.min(left)));
        }
        if self.session.depth_pending() {
            timeout = Some(timeout.map_or(DEPTH_POLL_S, |t| t.min(DEPTH_POLL_S)));
        }
        if self.session.refinement.refiner.divisor() > 1 {
            let left = INTERACTION
                .saturating_sub(self.session.last_input.elapsed())
                .as_secs_f64();
            timeout = Some(timeout.map_or(left, |t| t.min(left)));
        }
        match timeout {
            Some(t) => self.glfw.wait_events_timeout(t.max(0.001)),
            None if self.script.finished() => self.glfw.wait_events(),
            None => self.glfw.wait_events_timeout(SCRIPT_POLL_S),
        }
    }

    fn handle_event(&mut self, event: WindowEvent) {
        match event {
            WindowEvent::Close => self.quit = true,
            WindowEvent::FramebufferSize(w, h) => {
                self.minimised = w <= 0 || h <= 0;
                self.session.dirty.window = true;
            }
            WindowEvent::Refresh => self.session.dirty.window = true,
            WindowEvent::Key(key, _, KeyAction::Press | KeyAction::Repeat, mods) => {
                self.input.shift = mods.contains(Modifiers::Shift);
                let ctrl = mods.contains(Modifiers::Control);
                self.input.pending.push_back((key, self.input.shift, ctrl));
            }
            WindowEvent::Key(_, _, KeyAction::Release, mods) => {
                self.input.shift = mods.contains(Modifiers::Shift);
            }
            WindowEvent::CursorPos(x, y) => self.pointer_moved(DVec2::new(x, y)),
            WindowEvent::MouseButton(button, KeyAction::Press, mods) => {
                self.pressed(button, mods.contains(Modifiers::Shift))
            }
            WindowEvent::MouseButton(button, KeyAction::Release, _) => {
                self.pointer_released(button)
            }
            WindowEvent::Scroll(_, dy) => self.scrolled(dy),
            _ => {}
        }
    }

    /// A button pressed at the cursor; over the control panel's slider it sets the value there.
    fn pressed(&mut self, button: MouseButton, shift: bool) {
        let at = self.input.cursor;
        let panel = self.session.panel_hit(at);
        if let (Some(Hit::Slider(s, _)), MouseButton::Button1) = (panel, button) {
            self.session.panel_slide(s, at.x);
        }
        self.input.press = Some(Press {
            button,
            at,
            last: at,
            shift,
            moved: false,
            panel,
        });
    }

    /// A drag that started in the scene panel orbits (left button) or pans (other buttons).
    fn pointer_moved(&mut self, now: DVec2) {
        if let Some(p) = self.input.press.as_mut() {
            let delta = now - p.last;
            p.last = now;
            if (now - p.at).length() > CLICK_SLOP {
                p.moved = true;
            }
            let s = &mut self.session;
            if let Some(hit) = p.panel {
                // The control panel holds the pointer: a slider follows it, nothing else moves.
                if let (Hit::Slider(slider, _), MouseButton::Button1) = (hit, p.button) {
                    s.panel_slide(slider, now.x);
                }
            } else if p.moved && s.layout.scene.contains(p.at.x, p.at.y) {
                let action = match p.button {
                    MouseButton::Button1 => Action::Orbit(delta, s.scene_size()),
                    _ => Action::Pan(delta, s.scene_size()),
                };
                s.act(action);
            }
        }
        self.input.cursor = now;
        self.session.hover(now);
    }

    /// A left click (press and release without moving) on the refocus image or the scene.
    fn pointer_released(&mut self, button: MouseButton) {
        let Some(p) = self.input.press.take() else {
            return;
        };
        if let Some(hit) = p.panel {
            // A button acts on release over itself (a press that slid off does nothing).
            if let (Hit::Button(b), MouseButton::Button1) = (hit, button) {
                if self.session.panel_hit(self.input.cursor) == Some(Hit::Button(b)) {
                    self.session.panel_press(b);
                }
            }
            return;
        }
        if p.moved || p.button != button || button != MouseButton::Button1 {
            return;
        }
        let s = &mut self.session;
        let (x, y) = (p.at.x + 0.5, p.at.y + 0.5);
        let view = (s.lf.width, s.lf.height);
        if let Some(px) = s.layout.refocus_pixel(x, y, view) {
            s.click_refocus(px, p.shift);
        } else if s.layout.scene.contains(x, y) {
            let scene = s.layout.scene;
            s.click_scene(DVec2::new(x - scene.x as f64, y - scene.y as f64));
        }
    }

    /// Scrolling moves the focus over the refocus image (Shift: finely) and zooms the scene.
    fn scrolled(&mut self, dy: f64) {
        let (cursor, shift) = (self.input.cursor, self.input.shift);
        let s = &mut self.session;
        if s.panel_hit(cursor).is_some() {
            // Over the control panel: nothing under it scrolls.
            return;
        }
        if s.layout.refocus_area.contains(cursor.x, cursor.y) {
            s.interact(Action::DisparitySteps(if shift { dy * FINE } else { dy }));
        } else if s.layout.scene.contains(cursor.x, cursor.y) {
            s.act(Action::Zoom(dy));
        }
    }

    /// One key press per frame, so a held key (or a script's COUNT) is a run of frames.
    fn press_next_key(&mut self) {
        let Some((key, shift, ctrl)) = self.input.pending.pop_front() else {
            return;
        };
        let s = &mut self.session;
        if let Some(step) = video_step_for_key(key).filter(|_| !ctrl) {
            s.video_key(step);
            return;
        }
        let Some(action) = action_for_chord(key, shift, ctrl) else {
            return;
        };
        // Screenshots, quitting and help leave the image as it is: no interaction.
        let effect = if matches!(
            action,
            Action::Screenshot | Action::Quit | Action::ToggleHelp | Action::TogglePeaking
        ) {
            s.act(action)
        } else {
            s.interact(action)
        };
        match effect {
            Effect::Quit => self.quit = true,
            Effect::Screenshot => s.screenshots.numbered(),
            _ => {}
        }
    }

    /// Follows the window's size; false while it has none (minimised).
    fn fit_window(&mut self) -> Result<bool> {
        let (fw, fh) = self.window.get_framebuffer_size();
        let size = (fw.max(0) as u32, fh.max(0) as u32);
        if size.0 == 0 || size.1 == 0 {
            self.minimised = true;
            return Ok(false);
        }
        let current = self.session.layout.window;
        if let Some(want) = self.resize_to {
            // The window system may take a few events to apply a scripted resize.
            if size == want || current == size {
                self.resize_to = None;
            }
        }
        if size != current {
            self.session.resize(&mut self.gpu, size)?;
        }
        Ok(true)
    }

    /// Draws a frame if there is anything to draw.
    fn frame(&mut self) -> Result<()> {
        let s = &mut self.session;
        let interactive = s.last_input.elapsed() < INTERACTION || !self.input.pending.is_empty();
        let Some(mut plan) = s.next_frame(interactive) else {
            return Ok(());
        };
        if let Some(status) = s.redraw_text() {
            let title = format!("{} — {status} — {}", self.title, self.device);
            self.window.set_title(&title);
        }
        let full_size = plan.full_size();
        let result = s.draw(&mut self.gpu, &mut plan)?;
        if result.skipped {
            // Out of date: rebuild for the window's current size and draw again.
            s.out_of_date(&mut self.gpu, self.window.get_framebuffer_size())?;
        }
        s.finish_frame(&mut self.gpu, &plan, full_size, result)
    }

    /// Waits for the GPU and reports; the GPU side goes before the window.
    fn finish(self) -> Result<ViewerReport> {
        let Viewer {
            mut gpu,
            session,
            device,
            strategy,
            ..
        } = self;
        gpu.wait_idle()?;
        let validation_errors =
            gpu.context().validation().errors() + session.depth_validation_errors;
        let (extent, mode) = gpu.swapchain_info();
        drop(gpu);
        let surface = super::session::screenshot::surface_json(
            &session.state,
            session.surface.as_ref(),
            session.depth_origin.as_ref(),
        );
        let antialias = crate::refocus::antialias::antialias_json(
            session.aa.as_ref(),
            session.depth_origin.as_ref().map(DepthOrigin::json),
        );
        let lf = &session.lf;
        let light_field = (lf.name.clone(), lf.grid, (lf.width, lf.height));
        Ok(ViewerReport {
            antialias,
            light_field,
            frames: session.stats.report(),
            depth: session.depth_origin,
            milestones: session.milestones,
            surface,
            state: session.state,
            validation_errors,
            device,
            strategy,
            present_mode: format!("{mode:?}").to_lowercase(),
            window: (extent.width, extent.height),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viewer::text::{Canvas, TEXT};

    #[test]
    fn the_loading_screen_names_the_program_and_says_what_is_loading_in_the_strip() {
        let layout = Layout::new(800, 600, (1, 1));
        let mut canvas = Canvas::new(800, 600);
        loading_text(
            &mut canvas,
            &layout,
            "loading demo: decoding views 3/25 (12 %)",
        );
        if let Ok(path) = std::env::var("TILTFIELD_TEST_LOADING_PNG") {
            image::RgbaImage::from_raw(800, 600, canvas.pixels.clone())
                .unwrap()
                .save(path)
                .unwrap();
        }
        let text_in = |y0: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (0..800u32).map(move |x| (x, y)))
                .filter(|&(x, y)| {
                    let i = ((y * 800 + x) * 4) as usize;
                    canvas.pixels[i..i + 4] == TEXT
                })
                .count()
        };
        let strip = layout.status;
        let (s0, s1) = (strip.y as u32, (strip.y + strip.height) as u32);
        assert!(text_in(s0, s1) > 100, "the strip's line");
        assert!(text_in(0, s0) > 100, "the name above the strip");
        // The line's length shows: a longer line lights more of the strip.
        let mut longer = Canvas::new(800, 600);
        loading_text(
            &mut longer,
            &layout,
            "loading demo: decoding views 3/25 (12 %) and more text",
        );
        let lit = |c: &Canvas| c.pixels.chunks(4).filter(|p| *p == TEXT).count();
        assert!(lit(&longer) > lit(&canvas));
    }
}
