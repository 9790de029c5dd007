//! The window and the event loop: GLFW input (or script commands) → [`Action`]s on the
//! [`ViewerState`] → a [`FrameRequest`] per frame for [`ViewerGpu`], paced by the refinement
//! schedule. The only module that touches GLFW.

use std::collections::VecDeque;
use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use ash::vk;
use ash::vk::Handle;
use glam::{DVec2, DVec3};
use glfw::{Action as KeyAction, Key, Modifiers, MouseButton, WindowEvent};

use super::controls::{action_for_key, CONTROLS, FINE};
use super::gpu::{FrameRequest, ViewerGpu};
use super::layout::Layout;
use super::orbit::{pick_point, OrbitCamera};
use super::refine::{spread_order, Refiner};
use super::script::{self, Command, Line, Panel};
use super::state::{effective_radius, Action, Effect, ViewerState};
use super::text::{Canvas, CLEAR, PANEL_BG, TEXT, WARN};
use crate::error::{Error, Result};
use crate::geometry::aperture::Aperture;
use crate::geometry::depth::ViewDepth;
use crate::geometry::picking::KeyboardPlane;
use crate::gpu::swapchain::PresentMode;
use crate::gpu::timing::median;
use crate::gpu::{GpuContext, GpuOptions};
use crate::lightfield::video::{FrameLoader, FrameSequence};
use crate::lightfield::{LightField, LoadLimits};
use crate::passes::panel::Rect;
use crate::passes::scene::{SceneOverlay, SceneView};
use crate::passes::texture::ViewStorage;
use crate::refocus::{Averaging, FocusRequest, FocusSpec, RefocusPlan};
use crate::scene::{
    ColourVertex, PointCloud, SceneBuilder, CAMERA_IN_COLOUR, CAMERA_OUT_COLOUR, NORMAL_COLOUR,
    OPTICAL_AXIS_COLOUR, PLANE_COLOUR,
};

/// How long after the last input the view counts as "being interacted with".
const INTERACTION: Duration = Duration::from_millis(150);
/// How often the status text refreshes its timings while frames are rendered.
const STATUS_PERIOD: Duration = Duration::from_millis(250);
/// Pixels the pointer may move between press and release and still click.
const CLICK_SLOP: f64 = 3.0;
/// Pick tolerance in the scene panel, pixels.
const PICK_TOLERANCE: f64 = 6.0;
/// Most cloud points drawn (a stride thins larger depth maps).
const MAX_CLOUD_POINTS: usize = 100_000;
const PICK_COLOUR: [u8; 3] = [255, 60, 40];
/// Half side of the plane quad as a fraction of the cloud's bounding-box diagonal.
const PLANE_HALF_OF_DIAGONAL: f64 = 0.3;
/// Opacity of the plane quad in the scene panel.
const PLANE_OPACITY: f32 = 0.28;
const REFERENCE_COLOUR: [u8; 3] = [255, 230, 0];

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
    /// Where `P` writes screenshots (prefix; a counter is appended).
    pub screenshot_prefix: PathBuf,
    /// The video `lf` is a frame of, and that frame's number: `,` `.` step, Space plays.
    pub video: Option<(FrameSequence, u64)>,
    /// Normal window of clicks (see [`crate::depth::DepthOrigin::normal_window`]).
    pub normal_window: u32,
}

/// Frame statistics of a session.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct FrameStats {
    /// Frames presented.
    pub count: usize,
    /// Median GPU time of frames rendered while input was arriving.
    pub interactive_gpu_ms_median: Option<f64>,
    /// Frames per second while input was arriving (wall clock).
    pub interactive_fps: Option<f64>,
    /// Median over refinements of the GPU time from a full-size restart to full quality.
    pub full_quality_gpu_ms_median: Option<f64>,
    /// Median over refinements of the wall time from a full-size restart to full quality.
    pub full_quality_wall_ms_median: Option<f64>,
    /// Frames per second over all rendering (wall clock, idle time excluded).
    pub fps: Option<f64>,
}

/// The final state and what the session measured.
pub struct ViewerReport {
    pub state: ViewerState,
    pub frames: FrameStats,
    pub validation_errors: usize,
    pub device: String,
    pub present_mode: String,
    pub window: (u32, u32),
}

/// The focus a viewer starts with when none is given.
fn default_focus(lf: &LightField, depth: Option<&ViewDepth>) -> FocusRequest {
    match (&lf.rig, depth) {
        (None, Some(d)) => FocusSpec::FocusTiltSwing {
            distance: d.typical_depth(),
            tilt_deg: 0.0,
            swing_deg: 0.0,
        }
        .into(),
        _ => FocusSpec::Disparity(0.0).into(),
    }
}

/// The plan with its views in refinement order.
fn refinement_plan(plan: &RefocusPlan) -> RefocusPlan {
    let positions: Vec<DVec2> = plan
        .views
        .iter()
        .map(|v| DVec2::new(v.s as f64, v.t as f64))
        .collect();
    let order = spread_order(&positions, plan.reference);
    let mut p = plan.clone();
    p.views = order.iter().map(|&i| plan.views[i]).collect();
    p
}

/// Pointer state between press and release.
#[derive(Debug, Clone, Copy)]
struct Press {
    button: MouseButton,
    at: DVec2,
    last: DVec2,
    shift: bool,
    moved: bool,
}

struct Session<'a> {
    lf: &'a LightField,
    state: ViewerState,
    depth: Option<ViewDepth>,
    cloud: Option<PointCloud>,
    cloud_stride: u32,
    orbit: OrbitCamera,
    layout: Layout,
    refiner: Refiner,
    ordered: RefocusPlan,
    canvas: Canvas,
    last_version: u64,
    last_marks: u64,
    scene_dirty: bool,
    /// The scene view (camera, panel size) changed: the cloud layer is redrawn.
    cloud_dirty: bool,
    text_dirty: bool,
    last_input: Instant,
    last_status: Instant,
    // Statistics.
    frames: usize,
    render_time: Duration,
    interactive_ms: Vec<f64>,
    interactive_frames: usize,
    interactive_time: Duration,
    refinement: u32,
    refinement_gpu_ms: f64,
    refinement_started: Option<Instant>,
    full_gpu_ms: Vec<f64>,
    full_wall_ms: Vec<f64>,
    last_gpu_ms: Option<f64>,
    fps: f64,
    /// Where the text canvas has content (what the compositor draws of it).
    overlay_parts: Vec<Rect>,
    /// The video frame shown, for videos.
    frame: Option<u64>,
}

/// Video playback: the frames, the background decoder, what is shown and wanted.
struct Video {
    sequence: FrameSequence,
    loader: FrameLoader,
    shown: u64,
    wanted: u64,
    playing: bool,
}

impl Video {
    /// Asks for the next few frames after the one shown (wrapping to the first at the end).
    fn request_ahead(&mut self) {
        let mut f = self.shown;
        let mut next = Vec::new();
        for _ in 0..2 {
            f = self
                .sequence
                .next(f)
                .unwrap_or_else(|| self.sequence.first());
            next.push(f);
        }
        self.loader.replace_requests(next);
    }
}

impl Session<'_> {
    fn status_lines(&self) -> (String, String) {
        let plan = &self.state.plan;
        let plane = match (plan.plane, self.state.resolved.plane) {
            (Some(p), _) | (None, Some(p)) => {
                let kb = KeyboardPlane::of(&p, &plan.reference_camera).ok();
                format!(
                    "plane p=({:.3},{:.3},{:.3}) n=({:.3},{:.3},{:.3}){}",
                    p.point.x,
                    p.point.y,
                    p.point.z,
                    p.normal.x,
                    p.normal.y,
                    p.normal.z,
                    kb.map_or(String::new(), |k| format!(
                        "  distance {:.4} tilt {:.1}° swing {:.1}°",
                        k.distance, k.tilt_deg, k.swing_deg
                    ))
                )
            }
            _ => match self.state.resolved.spec {
                FocusSpec::Disparity(d) => format!("classic shift-and-sum, {d:.3} px per view"),
                _ => "no plane".into(),
            },
        };
        let line1 = format!(
            "{plane}  [{}]{}",
            self.state.resolved.how,
            self.frame.map_or(String::new(), |f| format!("  frame {f}"))
        );
        let a = self.state.aperture();
        let (done, total) = self.refiner.progress();
        let line2 = format!(
            "aperture {:?} r={:.1} ({} of {} views)  view ({:.2}, {:.2})  {:?}  GPU {}  {:.0} fps  \
             {}",
            a.shape,
            effective_radius(&a, self.lf),
            plan.views.len(),
            self.lf.views.len(),
            self.state.reference().x,
            self.state.reference().y,
            self.state.averaging(),
            self.last_gpu_ms
                .map_or("-".to_string(), |ms| format!("{ms:.1} ms")),
            self.fps,
            if self.refiner.converged() {
                "full quality".to_string()
            } else {
                format!(
                    "refining {done}/{total}{}",
                    if self.refiner.divisor() > 1 {
                        format!(" (preview 1/{})", self.refiner.divisor())
                    } else {
                        String::new()
                    }
                )
            },
        )
        .to_lowercase();
        (line1, line2)
    }

    /// Redraws the text canvas: status strip, message, help, click marks.
    fn draw_text(&mut self) {
        let (w, h) = self.layout.window;
        if self.canvas.width != w || self.canvas.height != h {
            self.canvas = Canvas::new(w, h);
            self.overlay_parts.clear();
        }
        let (l1, l2) = self.status_lines();
        let s = self.layout.status;
        self.canvas.fill(0, 0, w as i64, s.y as i64, CLEAR);
        self.canvas.fill(
            s.x as i64,
            s.y as i64,
            s.width as i64,
            s.height as i64,
            PANEL_BG,
        );
        // Twice the glyph size where the longer line fits, else the plain 8-pixel font.
        let longest = l1.chars().count().max(l2.chars().count()) as i64;
        let scale = if longest * 16 + 16 <= w as i64 { 2 } else { 1 };
        let step = 10 * scale as i64;
        self.canvas.text(8, s.y as i64 + 4, scale, &l1, TEXT);
        self.canvas.text(8, s.y as i64 + 4 + step, scale, &l2, TEXT);
        if let Some(msg) = &self.state.message {
            let area = self.layout.refocus_area;
            let y = (area.y + area.height) as i64 - 22;
            let chars = ((area.width as i64 - 16) / 8).max(8) as usize;
            let text: String = msg.chars().take(chars).collect();
            self.canvas
                .fill(area.x as i64, y - 4, area.width as i64, 20, PANEL_BG);
            self.overlay_parts
                .push(Rect::new(area.x, (y - 4) as f32, area.width, 20.0));
            self.canvas.text(area.x as i64 + 8, y, 1, &text, WARN);
        }
        // Marks of the three-click plane in progress.
        let size = (self.lf.width, self.lf.height);
        for p in &self.state.pending_clicks {
            let at = self.layout.refocus_to_window(*p, size);
            self.canvas.cross(at.x, at.y, 6, [255, 60, 40, 255]);
            self.overlay_parts
                .push(Rect::new(at.x as f32 - 8.0, at.y as f32 - 8.0, 17.0, 17.0));
        }
        if self.state.show_help {
            let sc = self.layout.scene;
            let (x0, y0) = (sc.x as i64 + 10, sc.y as i64 + 10);
            let rows = CONTROLS.len() as i64 + 1;
            let key_w = CONTROLS.iter().map(|(k, _)| k.len()).max().unwrap_or(0) as i64 * 8 + 16;
            let what_w = CONTROLS.iter().map(|(_, w)| w.len()).max().unwrap_or(0) as i64 * 8;
            self.canvas
                .fill(x0, y0, key_w + what_w + 16, rows * 18 + 12, PANEL_BG);
            self.overlay_parts.push(Rect::new(
                x0 as f32,
                y0 as f32,
                (key_w + what_w + 16) as f32,
                (rows * 18 + 12) as f32,
            ));
            self.canvas
                .text(x0 + 8, y0 + 6, 1, "controls (H hides)", WARN);
            for (i, (key, what)) in CONTROLS.iter().enumerate() {
                let y = y0 + 6 + (i as i64 + 1) * 18;
                self.canvas.text(x0 + 8, y, 1, key, TEXT);
                self.canvas.text(x0 + 8 + key_w, y, 1, what, TEXT);
            }
        }
        self.text_dirty = false;
    }

    /// The scene panel's geometry besides the cloud.
    fn scene_overlay(&self) -> Result<SceneOverlay> {
        let lf = self.lf;
        let mut builder = SceneBuilder::new(lf)
            .reference(self.state.reference())
            .aperture(self.state.aperture(), self.state.excluded());
        if let Some(plane) = self.state.plan.plane.or(self.state.resolved.plane) {
            builder = builder.plane(plane, self.state.anchor());
        }
        if let Some(b) = self.cloud.as_ref().and_then(|c| c.bounds) {
            // A little smaller than the builder's default (half the diagonal), so the quad
            // reads as a plane in the scene rather than a tint over the whole panel.
            builder = builder.plane_half_size(PLANE_HALF_OF_DIAGONAL * b.diagonal().max(1e-6));
        }
        let geometry = builder.build()?;
        let mut out = SceneOverlay::default();
        let line = |out: &mut SceneOverlay, a: DVec3, b: DVec3, c: [u8; 3]| {
            out.lines.push(ColourVertex::new(a, c, 1.0));
            out.lines.push(ColourVertex::new(b, c, 1.0));
        };
        // Camera frustums: size from the grid spacing, so they never swamp the scene.
        let spacing = if lf.views.len() > 1 {
            let c0 = lf.views[0].camera.centre();
            lf.views[1..]
                .iter()
                .map(|v| (v.camera.centre() - c0).length())
                .filter(|d| *d > 0.0)
                .fold(f64::INFINITY, f64::min)
        } else {
            f64::INFINITY
        };
        let scale = if spacing.is_finite() {
            0.4 * spacing
        } else {
            0.02 * self
                .cloud
                .as_ref()
                .and_then(|c| c.bounds)
                .map_or(1.0, |b| b.diagonal())
        };
        let max_weight = geometry
            .cameras
            .iter()
            .map(|c| c.weight)
            .fold(0.0, f64::max)
            .max(1e-12);
        let frustum = |out: &mut SceneOverlay, cam: &crate::geometry::camera::Camera, s: f64, c| {
            let k_inv = cam.k.inverse();
            let (w, h) = (lf.width as f64 - 0.5, lf.height as f64 - 0.5);
            let corners = [(-0.5, -0.5), (w, -0.5), (w, h), (-0.5, h)]
                .map(|(x, y)| cam.to_world(k_inv * DVec3::new(x, y, 1.0) * s));
            let apex = cam.centre();
            for i in 0..4 {
                line(out, apex, corners[i], c);
                line(out, corners[i], corners[(i + 1) % 4], c);
            }
        };
        for m in &geometry.cameras {
            let cam = &lf.views[m.index].camera;
            out.points
                .push(ColourVertex::new(m.centre, m.colour(), 1.0));
            if m.in_aperture {
                frustum(
                    &mut out,
                    cam,
                    scale * (0.5 + 0.5 * m.weight / max_weight),
                    CAMERA_IN_COLOUR,
                );
            } else {
                frustum(&mut out, cam, scale * 0.5, CAMERA_OUT_COLOUR);
            }
        }
        frustum(
            &mut out,
            &geometry.reference_camera,
            scale * 1.2,
            REFERENCE_COLOUR,
        );
        line(
            &mut out,
            geometry.optical_axis.a,
            geometry.optical_axis.b,
            OPTICAL_AXIS_COLOUR,
        );
        if let Some(n) = geometry.normal_line {
            line(&mut out, n.a, n.b, NORMAL_COLOUR);
        }
        if let Some(q) = &geometry.plane {
            for i in 0..4 {
                line(&mut out, q.corners[i], q.corners[(i + 1) % 4], PLANE_COLOUR);
            }
        }
        out.triangles
            .extend(geometry.plane_vertices().into_iter().map(|mut v| {
                v.colour[3] = PLANE_OPACITY;
                v
            }));
        let mut picks: Vec<DVec3> = self.state.pending_points.clone();
        if let Some(pick) = &self.state.resolved.pick {
            picks.extend(pick.points.iter().copied());
        }
        if let Some(depth) = &self.depth {
            for p in &self.state.pending_clicks {
                if let Ok((x, y)) = depth.pixel_at(p.x, p.y) {
                    picks.extend(depth.point(x, y));
                }
            }
        }
        out.markers.extend(
            picks
                .iter()
                .map(|p| ColourVertex::new(*p, PICK_COLOUR, 1.0)),
        );
        Ok(out)
    }

    /// Cloud points large enough to close the gaps between neighbouring depth pixels at the
    /// initial zoom: the panel's pixels per (thinned) depth pixel, with some overlap.
    fn point_size(&self) -> f32 {
        let Some(d) = &self.depth else { return 2.0 };
        let stride = self.cloud_stride as f64;
        let per_px = self.layout.scene.height as f64 / d.height.max(1) as f64 * stride;
        (1.3 * per_px).clamp(2.0, 8.0) as f32
    }

    fn scene_size(&self) -> (u32, u32) {
        (
            (self.layout.scene.width as u32).max(1),
            (self.layout.scene.height as u32).max(1),
        )
    }

    /// The depth-view pixel under refocus-image position `p` (full-size pixels of the current
    /// reference view): the position itself when the reference camera is the depth view's,
    /// else the pixel of the cloud point seen there.
    fn depth_pixel(&self, p: DVec2) -> std::result::Result<DVec2, String> {
        let depth = self.depth.as_ref().ok_or_else(|| {
            format!(
                "light field '{}' has no depth map: clicks need one (keys and scroll work)",
                self.lf.name
            )
        })?;
        let reference = self.state.plan.reference_camera;
        if reference == depth.camera {
            return Ok(p);
        }
        let cloud = self.cloud.as_ref().ok_or("no point cloud to pick from")?;
        let i = pick_point(&reference, p, cloud.points.iter().map(|c| c.position), 1.5)
            .ok_or("no depth under the cursor from this viewpoint")?;
        let (x, y) = cloud.points[i].pixel;
        Ok(DVec2::new(x as f64, y as f64))
    }

    /// The world point of the cloud under scene-panel pixel `p`.
    fn scene_pick(&self, p: DVec2) -> std::result::Result<DVec3, String> {
        let cloud = self.cloud.as_ref().ok_or_else(|| {
            format!(
                "light field '{}' has no depth map, so the scene has no points to pick",
                self.lf.name
            )
        })?;
        let cam = self.orbit.camera(self.scene_size());
        let i = pick_point(
            &cam,
            p,
            cloud.points.iter().map(|c| c.position),
            PICK_TOLERANCE,
        )
        .ok_or("no cloud point within a few pixels of the cursor")?;
        Ok(cloud.points[i].position)
    }

    fn act(&mut self, action: Action) -> Effect {
        let effect = self.state.apply(self.lf, action);
        match &effect {
            Effect::Changed | Effect::Marked | Effect::Refused(_) => {
                self.text_dirty = true;
                self.scene_dirty = true;
            }
            _ => {}
        }
        effect
    }

    fn refuse(&mut self, why: String) {
        self.state.message = Some(why);
        self.text_dirty = true;
    }
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

fn with_suffix(prefix: &Path, suffix: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// The state of a screenshot: the plan as `render --json` reports it, with the focus method,
/// aperture and averaging, so `render` can reproduce `PREFIX_refocus.png`.
pub fn screenshot_json(state: &ViewerState) -> serde_json::Value {
    let mut v = crate::refocus::plan_json(&state.plan);
    if let Some(obj) = v.as_object_mut() {
        obj.insert("focus_how".into(), state.resolved.how.into());
        obj.insert(
            "aperture".into(),
            serde_json::json!({"shape": state.aperture().shape, "radius": state.aperture().radius}),
        );
        obj.insert(
            "averaging".into(),
            serde_json::to_value(state.averaging()).unwrap_or_default(),
        );
    }
    v
}

/// Opens the window on `lf` and runs until the user or the script quits.
pub fn run(lf: &LightField, opts: ViewerOptions) -> Result<ViewerReport> {
    if !(opts.frame_budget_ms.is_finite() && opts.frame_budget_ms > 0.0) {
        return Err(Error::Invalid(format!(
            "--frame-budget-ms must be a positive number of milliseconds, got {}",
            opts.frame_budget_ms
        )));
    }
    let depth = ViewDepth::from_light_field(lf).ok();
    let focus = opts
        .focus
        .unwrap_or_else(|| default_focus(lf, depth.as_ref()));
    let state = ViewerState::new(
        lf,
        focus,
        opts.aperture,
        opts.reference,
        opts.averaging,
        opts.excluded.clone(),
    )?;
    let mut state = state;
    state.normals = state.normals.with_window(opts.normal_window);
    script::check(&opts.script, (lf.width, lf.height), opts.window).map_err(Error::Invalid)?;
    let cloud_stride = depth.as_ref().map_or(1, |d| {
        let pixels = d.width as usize * d.height as usize;
        ((pixels as f64 / MAX_CLOUD_POINTS as f64).sqrt().ceil() as u32).max(1)
    });
    let cloud = match &depth {
        Some(d) => Some(PointCloud::colours_only(
            d,
            &lf.views[d.view].image,
            cloud_stride,
        )?),
        None => None,
    };

    let mut glfw = glfw::init(glfw::log_errors).map_err(|e| {
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
    let extensions = glfw.get_required_instance_extensions().ok_or_else(|| {
        Error::Window("the window system offers no Vulkan surface extensions".into())
    })?;
    let title = format!("tiltfield — {}", lf.name);
    let (mut window, events) = create_window(&mut glfw, opts.window, &title)?;
    let mut gpu_opts = opts.gpu.clone();
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
    let surface = vk::SurfaceKHR::from_raw(raw as u64);
    let (fw, fh) = window.get_framebuffer_size();
    let extent = vk::Extent2D {
        width: fw.max(1) as u32,
        height: fh.max(1) as u32,
    };
    let mut gpu = ViewerGpu::new(
        Arc::clone(&ctx),
        lf,
        surface,
        extent,
        opts.present,
        opts.storage,
    )?;
    let layout = Layout::new(extent.width, extent.height, (lf.width, lf.height));
    gpu.rebuild_panels(&layout)?;
    if let Some(c) = &cloud {
        gpu.set_cloud(&c.vertices())?;
    }
    let target = cloud
        .as_ref()
        .and_then(|c| c.bounds)
        .map(|b| b.centre())
        .or(state.resolved.plane.map(|p| p.point))
        .unwrap_or_else(|| state.plan.reference_camera.to_world(DVec3::Z));
    let orbit = OrbitCamera::over_shoulder(&state.plan.reference_camera, target);
    let device = ctx.info.name.clone();
    let ordered = refinement_plan(&state.plan);
    let mut s = Session {
        lf,
        refiner: Refiner::new(opts.frame_budget_ms, lf.width as u64 * lf.height as u64),
        ordered,
        canvas: Canvas::new(extent.width, extent.height),
        last_version: u64::MAX,
        last_marks: state.marks_version,
        state,
        depth,
        cloud,
        cloud_stride,
        orbit,
        layout,
        scene_dirty: true,
        cloud_dirty: true,
        text_dirty: true,
        last_input: Instant::now(),
        last_status: Instant::now(),
        frames: 0,
        render_time: Duration::ZERO,
        interactive_ms: Vec::new(),
        interactive_frames: 0,
        interactive_time: Duration::ZERO,
        refinement: 0,
        refinement_gpu_ms: 0.0,
        refinement_started: None,
        full_gpu_ms: Vec::new(),
        full_wall_ms: Vec::new(),
        last_gpu_ms: None,
        fps: 0.0,
        overlay_parts: Vec::new(),
        frame: opts.video.as_ref().map(|(_, f)| *f),
    };
    // Frames are decoded on a background thread, two ahead while playing.
    let mut video = opts.video.clone().map(|(sequence, frame)| Video {
        loader: FrameLoader::new(sequence.clone(), LoadLimits::default(), 2),
        sequence,
        shown: frame,
        wanted: frame,
        playing: false,
    });

    let mut script: VecDeque<Line> = opts.script.iter().cloned().collect();
    // Key presses (key, Shift) waiting for their frame: from the keyboard or a script.
    let mut pending: VecDeque<(Key, bool)> = VecDeque::new();
    let mut wait_until: Option<Instant> = None;
    let mut wait_converged = false;
    let mut screenshot: Option<PathBuf> = None;
    let mut screenshots = 0u32;
    let mut press: Option<Press> = None;
    let mut cursor = DVec2::ZERO;
    let mut shift = false;
    let mut quit = false;
    let mut resize_to: Option<(u32, u32)> = None;
    let mut window_dirty = true;
    let mut minimised = false;
    let mut last_frame_at: Option<Instant> = None;

    while !quit {
        // Script commands run until one has to wait.
        while !quit && pending.is_empty() && screenshot.is_none() {
            if let Some(t) = wait_until {
                if Instant::now() < t {
                    break;
                }
                wait_until = None;
            }
            if wait_converged {
                // A video frame asked for and not yet shown is not converged either.
                let settled = video.as_ref().map_or(true, |v| {
                    v.playing || (v.shown == v.wanted && v.loader.outstanding() == 0)
                });
                if settled && s.refiner.converged() && s.state.version == s.last_version {
                    wait_converged = false;
                } else {
                    break;
                }
            }
            let Some(line) = script.pop_front() else {
                break;
            };
            match line.command {
                Command::Wait(sec) => {
                    wait_until = Some(Instant::now() + Duration::from_secs_f64(sec))
                }
                Command::WaitConverged => wait_converged = true,
                Command::Key { key, shift, count } => {
                    for _ in 0..count {
                        pending.push_back((key, shift));
                    }
                }
                Command::Click {
                    panel: Panel::Refocus,
                    x,
                    y,
                    shift,
                } => {
                    let p = DVec2::new(x, y);
                    s.last_input = Instant::now();
                    s.act(if shift {
                        Action::ThreeClick(p)
                    } else {
                        Action::Click(p)
                    });
                }
                Command::Click {
                    panel: Panel::Scene,
                    x,
                    y,
                    ..
                } => match s.scene_pick(DVec2::new(x + 0.5, y + 0.5)) {
                    Ok(p) => {
                        s.last_input = Instant::now();
                        s.act(Action::ScenePick(p));
                    }
                    Err(why) => s.refuse(why),
                },
                Command::Drag { from, to } => {
                    s.orbit.orbit(DVec2::new(to.0 - from.0, to.1 - from.1));
                    s.scene_dirty = true;
                    s.cloud_dirty = true;
                }
                Command::Scroll { panel, dy } => match panel {
                    Panel::Refocus => {
                        s.last_input = Instant::now();
                        s.act(Action::DisparitySteps(dy));
                    }
                    Panel::Scene => {
                        s.orbit.zoom(dy);
                        s.scene_dirty = true;
                        s.cloud_dirty = true;
                    }
                },
                Command::Resize(w, h) => {
                    window.set_size(w as i32, h as i32);
                    resize_to = Some((w, h));
                }
                Command::Screenshot(prefix) => screenshot = Some(prefix),
                Command::Quit => quit = true,
            }
            log::debug!("script line {} done", line.number);
        }
        if quit {
            break;
        }

        let busy = !s.refiner.converged()
            || s.state.version != s.last_version
            || s.scene_dirty
            || s.text_dirty
            || window_dirty
            || !pending.is_empty()
            || screenshot.is_some()
            || resize_to.is_some();
        if busy && !minimised {
            glfw.poll_events();
        } else {
            // Idle: block until input, or until a script wait or the interaction window ends.
            let mut timeout: Option<f64> = None;
            if let Some(t) = wait_until {
                timeout = Some(t.saturating_duration_since(Instant::now()).as_secs_f64());
            }
            if video
                .as_ref()
                .is_some_and(|v| v.playing || v.loader.outstanding() > 0)
            {
                // A frame is being decoded: look for it every 10 ms.
                timeout = Some(timeout.map_or(0.01, |t: f64| t.min(0.01)));
            }
            if s.refiner.divisor() > 1 {
                let left = INTERACTION.saturating_sub(s.last_input.elapsed());
                timeout = Some(timeout.map_or(left.as_secs_f64(), |t| t.min(left.as_secs_f64())));
            }
            match timeout {
                Some(t) => glfw.wait_events_timeout(t.max(0.001)),
                None if script.is_empty() && !wait_converged => glfw.wait_events(),
                None => glfw.wait_events_timeout(0.05),
            }
        }

        for (_, event) in glfw::flush_messages(&events) {
            match event {
                WindowEvent::Close => quit = true,
                WindowEvent::FramebufferSize(w, h) => {
                    minimised = w <= 0 || h <= 0;
                    window_dirty = true;
                }
                WindowEvent::Refresh => window_dirty = true,
                WindowEvent::Key(key, _, KeyAction::Press | KeyAction::Repeat, mods) => {
                    shift = mods.contains(Modifiers::Shift);
                    pending.push_back((key, shift));
                }
                WindowEvent::Key(_, _, KeyAction::Release, mods) => {
                    shift = mods.contains(Modifiers::Shift);
                }
                WindowEvent::CursorPos(x, y) => {
                    let now = DVec2::new(x, y);
                    if let Some(p) = press.as_mut() {
                        let delta = now - p.last;
                        p.last = now;
                        if (now - p.at).length() > CLICK_SLOP {
                            p.moved = true;
                        }
                        if p.moved && s.layout.scene.contains(p.at.x, p.at.y) {
                            match p.button {
                                MouseButton::Button1 => s.orbit.orbit(delta),
                                _ => s.orbit.pan(delta, s.scene_size()),
                            }
                            s.scene_dirty = true;
                            s.cloud_dirty = true;
                        }
                    }
                    cursor = now;
                }
                WindowEvent::MouseButton(button, KeyAction::Press, mods) => {
                    press = Some(Press {
                        button,
                        at: cursor,
                        last: cursor,
                        shift: mods.contains(Modifiers::Shift),
                        moved: false,
                    });
                }
                WindowEvent::MouseButton(button, KeyAction::Release, _) => {
                    let Some(p) = press.take() else { continue };
                    if p.moved || p.button != button || button != MouseButton::Button1 {
                        continue;
                    }
                    let (x, y) = (p.at.x + 0.5, p.at.y + 0.5);
                    if let Some(px) = s.layout.refocus_pixel(x, y, (lf.width, lf.height)) {
                        match s.depth_pixel(px) {
                            Ok(d) => {
                                s.last_input = Instant::now();
                                s.act(if p.shift {
                                    Action::ThreeClick(d)
                                } else {
                                    Action::Click(d)
                                });
                            }
                            Err(why) => s.refuse(why),
                        }
                    } else if s.layout.scene.contains(x, y) {
                        let local =
                            DVec2::new(x - s.layout.scene.x as f64, y - s.layout.scene.y as f64);
                        match s.scene_pick(local) {
                            Ok(point) => {
                                s.last_input = Instant::now();
                                s.act(Action::ScenePick(point));
                            }
                            Err(why) => s.refuse(why),
                        }
                    }
                }
                WindowEvent::Scroll(_, dy) => {
                    if s.layout.refocus_area.contains(cursor.x, cursor.y) {
                        s.last_input = Instant::now();
                        s.act(Action::DisparitySteps(if shift { dy * FINE } else { dy }));
                    } else if s.layout.scene.contains(cursor.x, cursor.y) {
                        s.orbit.zoom(dy);
                        s.scene_dirty = true;
                        s.cloud_dirty = true;
                    }
                }
                _ => {}
            }
        }
        if window.should_close() {
            quit = true;
        }
        // One key press per frame, so a held key (or a script's COUNT) is a run of frames.
        if let Some((key, sh)) = pending.pop_front() {
            if matches!(key, Key::Comma | Key::Period | Key::Space) {
                match video.as_mut() {
                    Some(v) => {
                        let step = match key {
                            Key::Comma => v.sequence.previous(v.wanted),
                            Key::Period => v.sequence.next(v.wanted),
                            _ => {
                                v.playing = !v.playing;
                                None
                            }
                        };
                        if let Some(f) = step {
                            v.playing = false;
                            v.wanted = f;
                            v.loader.replace_requests([f]);
                        } else if v.playing {
                            v.request_ahead();
                        }
                        s.text_dirty = true;
                    }
                    None => s.refuse(format!(
                        "'{}' is not a video: , . and Space step and play camera-array videos",
                        lf.name
                    )),
                }
            } else if let Some(action) = action_for_key(key, sh) {
                if !matches!(
                    action,
                    Action::Screenshot | Action::Quit | Action::ToggleHelp
                ) {
                    s.last_input = Instant::now();
                }
                match s.act(action) {
                    Effect::Quit => quit = true,
                    Effect::Screenshot => {
                        screenshots += 1;
                        screenshot = Some(with_suffix(
                            &opts.screenshot_prefix,
                            &format!("-{screenshots}"),
                        ));
                    }
                    _ => {}
                }
            }
        }
        if quit {
            break;
        }
        if minimised {
            continue;
        }

        // Video: show the newest decoded frame that is still wanted; keep playing.
        if let Some(v) = video.as_mut() {
            while let Some(decoded) = v.loader.try_recv() {
                let keep = if v.playing {
                    decoded.frame > v.shown
                } else {
                    decoded.frame == v.wanted
                };
                if !keep {
                    continue;
                }
                match decoded.light_field {
                    Ok(frame_lf) => {
                        gpu.replace_views(&frame_lf)?;
                        v.shown = decoded.frame;
                        v.wanted = decoded.frame;
                        s.frame = Some(decoded.frame);
                        s.state.version += 1;
                        s.text_dirty = true;
                    }
                    Err(e) => {
                        v.playing = false;
                        s.refuse(format!("frame {}: {e}", decoded.frame));
                    }
                }
            }
            if v.playing && v.loader.outstanding() == 0 {
                v.request_ahead();
            }
        }

        // Window size.
        let (fw, fh) = window.get_framebuffer_size();
        let size = (fw.max(0) as u32, fh.max(0) as u32);
        if size.0 == 0 || size.1 == 0 {
            minimised = true;
            continue;
        }
        if let Some(want) = resize_to {
            // The window system may take a few events to apply a scripted resize.
            if size == want || s.layout.window == size {
                resize_to = None;
            }
        }
        if size != s.layout.window {
            s.layout = Layout::new(size.0, size.1, (lf.width, lf.height));
            gpu.resize(
                vk::Extent2D {
                    width: size.0,
                    height: size.1,
                },
                &s.layout,
            )?;
            s.scene_dirty = true;
            s.text_dirty = true;
            window_dirty = true;
        }

        // Restart refinement after a change; full size once the input stops.
        let interactive = s.last_input.elapsed() < INTERACTION || !pending.is_empty();
        if s.state.version != s.last_version {
            s.ordered = refinement_plan(&s.state.plan);
            s.last_version = s.state.version;
            s.refiner.restart(s.ordered.views.len(), interactive);
            s.refinement += 1;
            s.refinement_gpu_ms = 0.0;
            s.refinement_started = (s.refiner.divisor() == 1).then(Instant::now);
            s.text_dirty = true;
        } else if !interactive && s.refiner.divisor() > 1 {
            s.refiner.restart(s.ordered.views.len(), false);
            s.refinement += 1;
            s.refinement_gpu_ms = 0.0;
            s.refinement_started = Some(Instant::now());
        }
        if s.state.marks_version != s.last_marks {
            s.last_marks = s.state.marks_version;
            s.scene_dirty = true;
            s.text_dirty = true;
        }
        let batch = s.refiner.next_batch(interactive);
        if batch.is_none()
            && !s.scene_dirty
            && !s.text_dirty
            && !window_dirty
            && screenshot.is_none()
        {
            continue;
        }
        if batch.is_some() && s.last_status.elapsed() >= STATUS_PERIOD {
            s.text_dirty = true;
        }
        if s.text_dirty {
            s.draw_text();
            s.last_status = Instant::now();
            let (_, l2) = s.status_lines();
            window.set_title(&format!("{title} — {l2} — {device}"));
        }
        let overlay = if s.scene_dirty {
            Some(s.scene_overlay()?)
        } else {
            None
        };
        let view = SceneView {
            clip_from_world: s.orbit.clip_from_world(s.scene_size()),
            point_size: s.point_size(),
            marker_size: 11.0,
        };
        let full_size_batch = batch.as_ref().is_some_and(|b| b.divisor == 1);
        let result = gpu.frame(FrameRequest {
            plan: &s.ordered,
            averaging: s.state.averaging(),
            batch,
            scene: overlay.as_ref().map(|o| (view, o, s.cloud_dirty)),
            canvas: &mut s.canvas,
            layout: &s.layout,
            capture_window: screenshot.is_some(),
            tag: (s.refinement, interactive),
            overlay_parts: &s.overlay_parts,
        })?;
        if overlay.is_some() {
            s.cloud_dirty = false;
        }
        s.scene_dirty = false;
        window_dirty = false;
        if result.skipped {
            // Out of date: rebuild for the window's current size and draw again.
            let (fw, fh) = window.get_framebuffer_size();
            if fw > 0 && fh > 0 {
                s.layout = Layout::new(fw as u32, fh as u32, (lf.width, lf.height));
                gpu.resize(
                    vk::Extent2D {
                        width: fw as u32,
                        height: fh as u32,
                    },
                    &s.layout,
                )?;
            }
            s.scene_dirty = true;
            s.text_dirty = true;
            window_dirty = true;
        }
        // Frame rates from the wall time between frames; gaps (idle, waits) do not count.
        let now = Instant::now();
        if let Some(prev) = last_frame_at {
            let dt = now - prev;
            if dt < Duration::from_millis(500) {
                s.render_time += dt;
                s.fps = 0.8 * s.fps + 0.2 / dt.as_secs_f64().max(1e-6);
                if interactive {
                    s.interactive_frames += 1;
                    s.interactive_time += dt;
                }
            }
        }
        last_frame_at = Some(now);
        s.frames += 1;
        let converged_now = full_size_batch && s.refiner.converged();
        let mut timings: Vec<_> = result.timing.into_iter().collect();
        if converged_now {
            // The view is about to go idle: collect the timings of the last frames now.
            timings.extend(gpu.drain_timings()?);
        }
        for t in timings {
            log::debug!(
                "frame: {} views at 1/{}: accumulate {:.1} ms, frame {:.1} ms (GPU)",
                t.views,
                t.divisor,
                t.accumulate_ms,
                t.frame_ms
            );
            s.refiner
                .measured(t.views, t.divisor, t.accumulate_ms, t.frame_ms);
            s.last_gpu_ms = Some(t.frame_ms);
            let (id, was_interactive) = t.tag;
            if was_interactive {
                s.interactive_ms.push(t.frame_ms);
            }
            if t.divisor == 1 && id == s.refinement {
                s.refinement_gpu_ms += t.frame_ms;
            }
        }
        if converged_now {
            s.text_dirty = true;
            if let Some(t0) = s.refinement_started.take() {
                s.full_wall_ms.push(t0.elapsed().as_secs_f64() * 1e3);
                s.full_gpu_ms.push(s.refinement_gpu_ms);
            }
        }

        if let Some(prefix) = screenshot.take() {
            let full = s.state.plan.clone();
            let refocus = gpu.capture_refocus(&full, s.state.averaging(), (lf.width, lf.height))?;
            crate::io::save_png(&refocus, &with_suffix(&prefix, "_refocus.png"))?;
            let scene = gpu.capture_scene()?;
            crate::io::save_png(&scene, &with_suffix(&prefix, "_scene.png"))?;
            if let Some(w) = &result.window {
                crate::io::save_png(w, &with_suffix(&prefix, "_window.png"))?;
            }
            let mut json = screenshot_json(&s.state);
            if let Some(obj) = json.as_object_mut() {
                if let Some(f) = s.frame {
                    obj.insert("frame".into(), f.into());
                }
                // Frames presented so far (this one included): scripts can check that an idle
                // viewer renders nothing.
                obj.insert("frames_presented".into(), s.frames.into());
            }
            let path = with_suffix(&prefix, ".json");
            crate::io::write_bytes(&path, "JSON", format!("{json:#}\n").as_bytes())?;
            log::info!("screenshot {}", prefix.display());
            eprintln!(
                "wrote {0}_refocus.png, {0}_scene.png, {0}_window.png and {0}.json",
                prefix.display()
            );
        }
    }
    gpu.wait_idle()?;
    let validation_errors = ctx.validation().errors();
    let (extent, mode) = gpu.swapchain_info();
    drop(gpu);
    let frames = FrameStats {
        count: s.frames,
        interactive_gpu_ms_median: median(&s.interactive_ms),
        interactive_fps: (s.interactive_frames > 0)
            .then(|| s.interactive_frames as f64 / s.interactive_time.as_secs_f64().max(1e-9)),
        full_quality_gpu_ms_median: median(&s.full_gpu_ms),
        full_quality_wall_ms_median: median(&s.full_wall_ms),
        fps: (s.frames > 0).then(|| s.frames as f64 / s.render_time.as_secs_f64().max(1e-9)),
    };
    Ok(ViewerReport {
        state: s.state,
        frames,
        validation_errors,
        device,
        present_mode: format!("{mode:?}").to_lowercase(),
        window: (extent.width, extent.height),
    })
}
