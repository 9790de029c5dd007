//! What the viewer shows, as plain data: the focus, the aperture, the viewpoint, the averaging,
//! the picks in progress, the scene panel's camera, the video frame shown, the on-screen
//! message — and how every action changes it. No window and no GPU here: the event loop and
//! the session turn input, script commands and decoded video frames into [`Action`]s, apply
//! them, and render the resulting [`RefocusPlan`]. Nothing else writes this state; the
//! [`Effect`] an action returns tells the session what to redraw.
//!
//! Rules:
//! - an action that cannot be applied (a click without usable depth, collinear points, a tilt
//!   of a plane-less classic shift, an aperture with no view) changes nothing and leaves its
//!   reason in [`ViewerState::message`], shown on screen;
//! - the refocus plane is a world plane: moving the viewpoint keeps it where it is in the scene
//!   (a focus given relative to the reference camera is first turned into its world plane);
//! - keyboard adjustments (tilt, swing, distance) act on the plane as seen from the current
//!   reference camera, exactly as `render`'s `--nudge-*` options, and leave a world plane;
//! - every change of the focus, the aperture, the viewpoint, the averaging, anti-aliasing or
//!   the focus surface made by the user (keys, clicks, picks, R) can be undone and redone,
//!   [`UNDO_STEPS`] deep ([`Action::Undo`], [`Action::Redo`]); a new change drops what could
//!   be redone. Depth arriving in the background is not a step of its own;
//! - every change of what is rendered (a new plan, or new views: the next video frame)
//!   increments [`ViewerState::version`]; changes that only affect markers increment
//!   [`ViewerState::marks_version`]; moving the scene camera and messages change neither.

use glam::{DVec2, DVec3};

use super::orbit::OrbitCamera;
use crate::error::{Error, Result};
use crate::geometry::aperture::{Aperture, ApertureShape};
use crate::geometry::camera::Camera;
use crate::geometry::depth::ViewDepth;
use crate::geometry::normals::NormalParams;
use crate::geometry::picking::{nudge_plane, KeyboardPlane, Nudge};
use crate::geometry::plane::Plane;
use crate::lightfield::LightField;
use crate::refocus::surface::{in_surface, surface_terms, FocusSurface, MAX_PLANES};
use crate::refocus::{
    self, Averaging, FocusRequest, FocusSpec, FocusTarget, RefocusPlan, RefocusRequest,
    ResolvedFocus,
};

/// One action, whatever produced it (key, mouse, script, the video decoder).
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// Tilt the plane by degrees (as `--nudge-tilt`).
    Tilt(f64),
    /// Swing the plane by degrees (as `--nudge-swing`).
    Swing(f64),
    /// Move the plane along the reference optical axis by this fraction of its distance.
    Distance(f64),
    /// Frontoparallel focus, this many disparity steps nearer (negative: farther).
    DisparitySteps(f64),
    /// Change the aperture radius by grid steps.
    ApertureRadius(f64),
    /// Disk → square → gaussian → disk.
    CycleAperture,
    /// Move the virtual viewpoint by grid steps (the aperture follows).
    MoveView(DVec2),
    /// Viewpoint back to the grid centre.
    Recentre,
    /// Linear ↔ encoded averaging.
    ToggleAveraging,
    /// Anti-aliased refocus on/off (where the session has depth for it).
    ToggleAntialias,
    /// Keep the current focus plane in the focus surface's set of planes (the focus then
    /// moves on, and every kept plane stays in focus with it).
    KeepPlane,
    /// Drop the plane kept last.
    DropPlane,
    /// Back to the single focus plane: no kept planes, no slab, all in focus off.
    ClearSurface,
    /// Widen (negative: narrow) the focus slab around the plane by this fraction of the
    /// plane's distance from the reference camera; narrowed to nothing, the slab is off.
    Slab(f64),
    /// All in focus on/off (the kept planes or the slab come back when it goes off).
    ToggleAllInFocus,
    /// Back to the state the viewer started in (keeping the user's anti-aliasing choice).
    Reset,
    /// Undo the last change of the focus, aperture, viewpoint, averaging, anti-aliasing or
    /// focus surface.
    Undo,
    /// Redo the change undone last.
    Redo,
    /// The scene camera back to a view of the whole cloud and camera array.
    Frame,
    /// Single-click plane at a pixel of the depth view (as `render --click`).
    Click(DVec2),
    /// One of three clicks at pixels of the depth view (as `render --points`).
    ThreeClick(DVec2),
    /// One of three picked world points (as `render --points-3d`).
    ScenePick(DVec3),
    /// Orbit the scene camera by this many dragged pixels in a scene panel of this size.
    Orbit(DVec2, (u32, u32)),
    /// Pan the scene camera by this many dragged pixels in a scene panel of this size.
    Pan(DVec2, (u32, u32)),
    /// Zoom the scene camera by scroll steps.
    Zoom(f64),
    /// The video frame with this number is now the one whose views are rendered.
    ShowFrame(u64),
    /// Depth arrived (estimated in the background): see `ViewerState::depth_arrived`.
    DepthArrived {
        normal_window: u32,
        antialias: bool,
        focus: Option<FocusRequest>,
    },
    /// Frame the scene again, now with these points (the cloud's box corners and the
    /// cameras) around `centre`, in a panel of `aspect` (see `ViewerState::reframe`).
    Reframe {
        centre: Option<DVec3>,
        keep: Vec<DVec3>,
        array: Vec<DVec3>,
        aspect: f64,
    },
    /// Show why an input could not become an action (a click without depth, a key that needs
    /// a video, a frame that failed to decode).
    Refuse(String),
    ToggleHelp,
    /// Focus peaking on/off: tint the refocus image where the views agree (in focus).
    TogglePeaking,
    /// Show or hide the control panel (sliders and buttons).
    TogglePanel,
    Screenshot,
    Quit,
}

/// What applying an action did.
#[derive(Debug, Clone, PartialEq)]
pub enum Effect {
    /// The rendered state changed (restart refinement).
    Changed,
    /// Only markers or on-screen text changed.
    Marked,
    /// Nothing changed; the reason is in [`ViewerState::message`].
    Refused(String),
    /// The views changed (a new video frame): refinement restarts, the scene is as it was.
    NewViews,
    /// Only the scene camera moved: the scene panel (and its cloud layer) is redrawn.
    SceneView,
    /// Only the on-screen message changed.
    Message,
    Screenshot,
    Quit,
}

/// The focus surface around the focus plane (docs/conventions.md §12) as the viewer keeps it:
/// world planes kept besides the current focus plane, a slab, all in focus. All in focus
/// hides the others while it is on; kept planes and a slab exclude each other (the library's
/// slab lies around exactly one plane).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SurfaceChoice {
    kept: [Option<Plane>; MAX_PLANES - 1],
    /// Half-width of the slab (world units along the plane's normal, as `render --slab`).
    pub slab: Option<f64>,
    pub all_in_focus: bool,
}

impl SurfaceChoice {
    /// The kept planes, in the order they were kept.
    pub fn kept(&self) -> impl Iterator<Item = Plane> + '_ {
        self.kept.iter().flatten().copied()
    }

    /// The library's surface with `focus` the current focus plane (the surface's first).
    pub fn surface(&self, focus: Option<Plane>) -> FocusSurface {
        if self.all_in_focus {
            return FocusSurface::AllInFocus;
        }
        if let Some(half_width) = self.slab {
            return FocusSurface::Slab { half_width };
        }
        match focus {
            Some(f) if self.kept().next().is_some() => {
                FocusSurface::Planes(std::iter::once(f).chain(self.kept()).collect())
            }
            _ => FocusSurface::Plane,
        }
    }

    fn keep(&mut self, plane: Plane) -> Result<()> {
        if self.all_in_focus {
            return Err(Error::Invalid(
                "all in focus is on (G turns it off); it keeps no planes".into(),
            ));
        }
        if self.slab.is_some() {
            return Err(Error::Invalid(
                "a focus slab lies around one plane: narrow it away (-) before keeping planes"
                    .into(),
            ));
        }
        if self.kept().any(|p| p == plane) {
            return Err(Error::Invalid(
                "this plane is kept already: move the focus (scroll, W/S, arrows, a click), \
                 then keep the next"
                    .into(),
            ));
        }
        let slot = self.kept.iter_mut().find(|p| p.is_none()).ok_or_else(|| {
            Error::Invalid(format!(
                "a focus surface takes at most {MAX_PLANES} planes (the focus and {} kept): \
                 drop one (Backspace) first",
                MAX_PLANES - 1
            ))
        })?;
        *slot = Some(plane);
        Ok(())
    }

    fn drop_last(&mut self) -> Result<()> {
        let last = self
            .kept
            .iter_mut()
            .rev()
            .find(|p| p.is_some())
            .ok_or_else(|| Error::Invalid("no kept focus plane to drop".into()))?;
        *last = None;
        Ok(())
    }
}

/// The parts of the state that define the image.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Core {
    focus: FocusRequest,
    /// Where the plane quad is centred (the first picked point), if anywhere particular.
    anchor: Option<DVec3>,
    aperture: Aperture,
    reference: DVec2,
    averaging: Averaging,
    /// Anti-aliased refocus wanted (the session draws it where it has depth).
    antialias: bool,
    surface: SurfaceChoice,
}

// The library refuses `render --points` on one line in the same words.
use crate::geometry::picking::image_collinear;
pub use crate::geometry::picking::COLLINEAR_CLICKS;

/// How many changes [`Action::Undo`] can take back (the oldest are forgotten first).
pub const UNDO_STEPS: usize = 256;

/// The viewer's state.
#[derive(Debug, Clone)]
pub struct ViewerState {
    core: Core,
    initial: Core,
    /// What undo restores, the latest last (at most [`UNDO_STEPS`]).
    undo: Vec<Core>,
    /// What redo restores, the next last; emptied by any new change.
    redo: Vec<Core>,
    excluded: Vec<bool>,
    /// The current focus, resolved.
    pub resolved: ResolvedFocus,
    /// The current plan (views in plan order, as `render` uses them).
    pub plan: RefocusPlan,
    /// Depth-view pixels of the three-click plane in progress.
    pub pending_clicks: Vec<DVec2>,
    /// Depth-view pixels of the three clicks that made the plane in effect: their marks stay
    /// on the refocus image until the next pick or a reset.
    pub placed_clicks: Vec<DVec2>,
    /// World points of the three-pick plane in progress.
    pub pending_points: Vec<DVec3>,
    pub show_help: bool,
    /// Focus peaking is shown (a way of looking, not a focus: no undo step).
    pub show_peaking: bool,
    /// The control panel is shown.
    pub show_panel: bool,
    /// Why the last action was refused, or a hint about a pick in progress.
    pub message: Option<String>,
    pub version: u64,
    pub marks_version: u64,
    /// How clicks estimate the surface normal (the window suits the depth's origin: larger on
    /// an estimated map, as `render` chooses).
    pub normals: NormalParams,
    /// The scene panel's camera.
    pub orbit: OrbitCamera,
    /// The scene camera at start, which R restores with the focus.
    initial_orbit: OrbitCamera,
    /// The video frame shown, for videos.
    pub frame: Option<u64>,
}

/// The focus a viewer starts with when none is given: on a calibrated rig without the
/// parallel-rig disparity, frontoparallel at the scene's typical depth (once there is depth),
/// else disparity 0.
pub fn default_focus(lf: &LightField, depth: Option<&ViewDepth>) -> FocusRequest {
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

/// Disparity change of one scroll step: 1/64 of the data's disparity range, else 0.05 px.
pub fn disparity_step(lf: &LightField) -> f64 {
    lf.disparity_range
        .map(|(a, b)| ((b - a) / 64.0).max(1e-3))
        .unwrap_or(0.05)
}

/// The radius (grid steps) an aperture without one behaves as: covering the grid (disk,
/// square), σ of half the larger extent (gaussian).
pub fn effective_radius(aperture: &Aperture, lf: &LightField) -> f64 {
    aperture.radius.unwrap_or_else(|| {
        let hx = (lf.grid.cols as f64 - 1.0) / 2.0;
        let hy = (lf.grid.rows as f64 - 1.0) / 2.0;
        match aperture.shape {
            ApertureShape::Disk => hx.hypot(hy),
            ApertureShape::Square => hx.max(hy),
            ApertureShape::Gaussian => hx.max(hy).max(0.5),
        }
    })
}

impl ViewerState {
    /// The state for `focus`, `aperture`, `reference` (default: grid centre) and `averaging`;
    /// `excluded[i]` leaves view i out (dark views). Fails when that state cannot be rendered.
    pub fn new(
        lf: &LightField,
        focus: FocusRequest,
        aperture: Aperture,
        reference: Option<DVec2>,
        averaging: Averaging,
        excluded: Vec<bool>,
    ) -> Result<Self> {
        let core = Core {
            focus,
            anchor: None,
            aperture,
            reference: reference.unwrap_or_else(|| lf.grid.centre()),
            averaging,
            antialias: false,
            surface: SurfaceChoice::default(),
        };
        let (resolved, plan) = resolve(lf, &core, &excluded)?;
        let anchor = anchor_of(&resolved);
        let core = Core { anchor, ..core };
        let orbit =
            OrbitCamera::over_shoulder(&plan.reference_camera, scene_centre(&resolved, &plan));
        Ok(ViewerState {
            core,
            initial: core,
            undo: Vec::new(),
            redo: Vec::new(),
            excluded,
            resolved,
            plan,
            pending_clicks: Vec::new(),
            placed_clicks: Vec::new(),
            pending_points: Vec::new(),
            show_help: false,
            show_peaking: false,
            show_panel: false,
            message: None,
            version: 0,
            marks_version: 0,
            normals: NormalParams::default(),
            orbit,
            initial_orbit: orbit,
            frame: None,
        })
    }

    /// The scene camera framing the scene ([`OrbitCamera::framing`]): looking at `centre`
    /// (the point cloud's; the focus plane's point without a cloud) with every point of `keep`
    /// (the cloud's box corners and the camera centres) in view and the cameras of `array` as
    /// large as that allows, in a panel of `aspect`. F and R return to it.
    pub fn with_scene_framing(
        mut self,
        centre: Option<DVec3>,
        keep: Vec<DVec3>,
        array: Vec<DVec3>,
        aspect: f64,
    ) -> Self {
        let target = centre.unwrap_or(self.orbit.target);
        self.orbit =
            OrbitCamera::framing(&self.plan.reference_camera, target, &keep, &array, aspect);
        self.initial_orbit = self.orbit;
        self
    }

    /// The scene framing again (after depth arrived: the cloud joins what is framed); the
    /// scene camera moves to it unless the user has moved it.
    fn reframe(
        &mut self,
        centre: Option<DVec3>,
        keep: Vec<DVec3>,
        array: Vec<DVec3>,
        aspect: f64,
    ) -> Effect {
        let untouched = self.orbit == self.initial_orbit;
        let target = centre.unwrap_or(self.initial_orbit.target);
        self.initial_orbit =
            OrbitCamera::framing(&self.plan.reference_camera, target, &keep, &array, aspect);
        if !untouched {
            return Effect::Marked;
        }
        self.orbit = self.initial_orbit;
        Effect::SceneView
    }

    /// Depth arrived while the window was open (estimated in the background). `lf` is the
    /// light field with it installed — a grid folder's cameras may have changed (the
    /// estimate's nominal rig), so the focus is resolved again. Clicks get `normal_window`;
    /// anti-aliasing turns on when `antialias` (the front end's default with depth) unless
    /// the user toggled it meanwhile, and R returns to that; `focus` (the default focus with
    /// depth) replaces the focus if the user has not changed it.
    fn depth_arrived(
        &mut self,
        lf: &LightField,
        normal_window: u32,
        antialias: bool,
        focus: Option<FocusRequest>,
    ) -> Effect {
        self.normals = self.normals.with_window(normal_window);
        let untouched = self.core == self.initial;
        let toggled = self.core.antialias != self.initial.antialias;
        self.initial.antialias = antialias;
        if let (Some(f), true) = (focus, untouched) {
            self.initial.focus = f;
            self.initial.anchor = None;
        }
        let initial = self.initial;
        let effect = self.change(lf, |_, core| {
            if !toggled {
                core.antialias = antialias;
            }
            if let (Some(f), true) = (focus, untouched) {
                core.focus = f;
                core.anchor = None;
            }
            Ok(())
        });
        if let Effect::Refused(_) = effect {
            // The focus does not resolve with the new cameras: start over from the initial
            // state on them.
            return self.change(lf, |_, core| {
                *core = initial;
                Ok(())
            });
        }
        if matches!(effect, Effect::Marked) {
            // Same core and plan, but the cameras (and the scene) may still be new.
            self.version += 1;
            return Effect::Changed;
        }
        effect
    }

    pub fn focus(&self) -> &FocusRequest {
        &self.core.focus
    }

    pub fn aperture(&self) -> Aperture {
        self.core.aperture
    }

    pub fn reference(&self) -> DVec2 {
        self.core.reference
    }

    pub fn averaging(&self) -> Averaging {
        self.core.averaging
    }

    /// Whether anti-aliased refocus is wanted.
    pub fn antialias(&self) -> bool {
        self.core.antialias
    }

    /// The state starting with anti-aliasing `on` (what R returns to).
    pub fn with_antialias(mut self, on: bool) -> Self {
        self.core.antialias = on;
        self.initial.antialias = on;
        self
    }

    /// The focus surface as the viewer keeps it.
    pub fn surface_choice(&self) -> &SurfaceChoice {
        &self.core.surface
    }

    /// The focus surface around the current plan's plane (what `render` is given with
    /// `--plane` repeated, `--slab` or `--all-in-focus`).
    pub fn surface(&self) -> FocusSurface {
        self.core
            .surface
            .surface(self.plan.plane.or(self.resolved.plane))
    }

    /// Where the plane quad is centred.
    pub fn anchor(&self) -> Option<DVec3> {
        self.core.anchor
    }

    pub fn excluded(&self) -> &[bool] {
        &self.excluded
    }

    /// Applies `action`. Refused actions leave the state as it was (see the module docs).
    pub fn apply(&mut self, lf: &LightField, action: Action) -> Effect {
        let effect = match action {
            Action::ToggleHelp => {
                self.show_help = !self.show_help;
                self.marks_version += 1;
                return Effect::Marked;
            }
            Action::TogglePanel => {
                self.show_panel = !self.show_panel;
                self.marks_version += 1;
                return Effect::Marked;
            }
            Action::TogglePeaking => {
                self.show_peaking = !self.show_peaking;
                self.marks_version += 1;
                return Effect::Marked;
            }
            Action::Screenshot => return Effect::Screenshot,
            Action::Orbit(delta, size) => {
                self.orbit.orbit(delta, size);
                return Effect::SceneView;
            }
            Action::Pan(delta, size) => {
                self.orbit.pan(delta, size);
                return Effect::SceneView;
            }
            Action::Zoom(steps) => {
                self.orbit.zoom(steps);
                return Effect::SceneView;
            }
            Action::ShowFrame(frame) => {
                self.frame = Some(frame);
                self.version += 1;
                return Effect::NewViews;
            }
            Action::Refuse(why) => {
                self.message = Some(why);
                return Effect::Message;
            }
            Action::Reframe {
                centre,
                keep,
                array,
                aspect,
            } => return self.reframe(centre, keep, array, aspect),
            Action::DepthArrived {
                normal_window,
                antialias,
                focus,
            } => self.depth_arrived(lf, normal_window, antialias, focus),
            Action::Frame => {
                if self.orbit == self.initial_orbit {
                    return Effect::Marked;
                }
                self.orbit = self.initial_orbit;
                Effect::SceneView
            }
            Action::Reset => self.reset(lf),
            Action::Quit => return Effect::Quit,
            Action::Undo => self.step_history(lf, false),
            Action::Redo => self.step_history(lf, true),
            Action::ThreeClick(pixel) => self.three_click(lf, pixel),
            Action::ScenePick(point) => {
                self.pending_clicks.clear();
                self.placed_clicks.clear();
                self.pending_points.push(point);
                if self.pending_points.len() < 3 {
                    return self.mark_pending(self.pending_points.len(), "click in the scene");
                }
                let p: Vec<DVec3> = std::mem::take(&mut self.pending_points);
                self.change_recorded(lf, |_, core| {
                    core.focus = FocusRequest {
                        target: FocusTarget::ThreePoints([p[0], p[1], p[2]]),
                        nudge: None,
                    };
                    Ok(())
                })
            }
            Action::Click(pixel) => {
                self.pending_clicks.clear();
                self.placed_clicks.clear();
                self.pending_points.clear();
                let normals = self.normals;
                self.change_recorded(lf, |_, core| {
                    core.focus = FocusRequest {
                        target: FocusTarget::Click { pixel, normals },
                        nudge: None,
                    };
                    Ok(())
                })
            }
            action => {
                let resolved = self.resolved.clone();
                let plan = self.plan.clone();
                self.change_recorded(lf, |lf, core| modify(lf, core, action, &resolved, &plan))
            }
        };
        if matches!(effect, Effect::Changed) {
            self.marks_version += 1;
        }
        effect
    }

    /// R: the initial focus and scene camera, keeping anti-aliasing (the user's choice of how
    /// to look, X, not a focus).
    fn reset(&mut self, lf: &LightField) -> Effect {
        self.pending_clicks.clear();
        self.pending_points.clear();
        self.placed_clicks.clear();
        let moved = self.orbit != self.initial_orbit;
        self.orbit = self.initial_orbit;
        let initial = Core {
            antialias: self.core.antialias,
            ..self.initial
        };
        match self.change_recorded(lf, |_, core| {
            *core = initial;
            Ok(())
        }) {
            // Only the scene camera was off its start.
            Effect::Marked if moved => Effect::SceneView,
            effect => effect,
        }
    }

    /// A Shift+click: the third places the plane through the three clicked points.
    fn three_click(&mut self, lf: &LightField, pixel: DVec2) -> Effect {
        self.pending_points.clear();
        self.placed_clicks.clear();
        self.pending_clicks.push(pixel);
        if self.pending_clicks.len() < 3 {
            return self.mark_pending(self.pending_clicks.len(), "Shift+click");
        }
        let p: Vec<DVec2> = std::mem::take(&mut self.pending_clicks);
        let effect = self.change_recorded(lf, |_, core| {
            core.focus = FocusRequest {
                target: FocusTarget::ThreeClicks([p[0], p[1], p[2]]),
                nudge: None,
            };
            Ok(())
        });
        match effect {
            Effect::Refused(_) if image_collinear(&p) => {
                // Back-projected, points on one image line span a plane through the camera:
                // say so in the user's terms, not as a plane distance of 1e-16.
                let why = COLLINEAR_CLICKS.to_string();
                self.message = Some(why.clone());
                Effect::Refused(why)
            }
            Effect::Refused(_) => effect,
            _ => {
                self.placed_clicks = p;
                effect
            }
        }
    }

    fn mark_pending(&mut self, n: usize, how: &str) -> Effect {
        self.message = Some(format!(
            "three-point plane: point {n} of 3 ({how} {} more)",
            3 - n
        ));
        self.marks_version += 1;
        Effect::Marked
    }

    /// [`ViewerState::change`], and a step that undo can take back when the core changed.
    fn change_recorded(
        &mut self,
        lf: &LightField,
        f: impl FnOnce(&LightField, &mut Core) -> Result<()>,
    ) -> Effect {
        let before = self.core;
        let effect = self.change(lf, f);
        if self.core != before {
            if self.undo.len() == UNDO_STEPS {
                self.undo.remove(0);
            }
            self.undo.push(before);
            self.redo.clear();
        }
        effect
    }

    /// Undo (`forward` false) or redo: back to the core the history holds, the current one
    /// moving to the other history. The picks in progress and the marks of the last clicks go.
    fn step_history(&mut self, lf: &LightField, forward: bool) -> Effect {
        let (from, what) = if forward {
            (&mut self.redo, "redo")
        } else {
            (&mut self.undo, "undo")
        };
        let Some(target) = from.pop() else {
            let why = format!("nothing to {what}");
            self.message = Some(why.clone());
            self.marks_version += 1;
            return Effect::Refused(why);
        };
        self.pending_clicks.clear();
        self.pending_points.clear();
        self.placed_clicks.clear();
        let current = self.core;
        let effect = self.change(lf, |_, core| {
            *core = target;
            Ok(())
        });
        if matches!(effect, Effect::Refused(_)) {
            // It no longer resolves (the depth it was picked on changed): keep it where it was.
            if forward {
                self.redo.push(target);
            } else {
                self.undo.push(target);
            }
        } else if forward {
            self.undo.push(current);
        } else {
            self.redo.push(current);
        }
        effect
    }

    /// Applies `f` to a copy of the core; commits when the result resolves, else keeps the
    /// old state and reports why.
    fn change(
        &mut self,
        lf: &LightField,
        f: impl FnOnce(&LightField, &mut Core) -> Result<()>,
    ) -> Effect {
        let mut core = self.core;
        let attempt = f(lf, &mut core).and_then(|()| resolve(lf, &core, &self.excluded));
        match attempt {
            Ok((resolved, plan)) => {
                if resolved.pick.is_some() {
                    core.anchor = anchor_of(&resolved);
                }
                let changed = core != self.core || plan != self.plan;
                self.core = core;
                self.resolved = resolved;
                self.plan = plan;
                self.message = None;
                if changed {
                    self.version += 1;
                    Effect::Changed
                } else {
                    Effect::Marked
                }
            }
            Err(e) => {
                let reason = e.to_string();
                self.message = Some(reason.clone());
                self.marks_version += 1;
                Effect::Refused(reason)
            }
        }
    }

    /// The `RefocusRequest` of the current state (what `render` would be given).
    pub fn request(&self) -> RefocusRequest {
        RefocusRequest {
            focus: self.resolved.spec,
            aperture: self.core.aperture,
            reference: Some(self.core.reference),
        }
    }
}

/// Where the scene camera looks when there is no point cloud: the focus plane's point, else a
/// unit in front of the reference camera.
fn scene_centre(resolved: &ResolvedFocus, plan: &RefocusPlan) -> DVec3 {
    resolved
        .plane
        .map(|p| p.point)
        .unwrap_or_else(|| plan.reference_camera.to_world(DVec3::Z))
}

fn anchor_of(resolved: &ResolvedFocus) -> Option<DVec3> {
    resolved
        .pick
        .as_ref()
        .and_then(|p| p.points.first().copied())
}

fn resolve(
    lf: &LightField,
    core: &Core,
    excluded: &[bool],
) -> Result<(ResolvedFocus, RefocusPlan)> {
    let (resolved, plan) = refocus::resolve_and_plan(
        lf,
        &core.focus,
        core.aperture,
        Some(core.reference),
        excluded,
    )?;
    // The surface must hold around the new plane too (a slab must not reach the reference
    // camera): checked by the library's own geometry, without the scene depth.
    let surface = core.surface.surface(plan.plane.or(resolved.plane));
    // A surface chooses between the inverse depths of planes: classic shift-and-sum becomes
    // the plane it stands for, as `render` does.
    let plan = match surface.needs_depth() {
        true => refocus::plan::with_plane(lf, &plan, core.aperture, excluded)
            .map_err(|e| in_surface(surface.name(), e))?
            .into_owned(),
        false => plan,
    };
    surface_terms(&plan, &surface)?;
    Ok((resolved, plan))
}

/// Focus surfaces choose per pixel from the scene's depth.
fn need_depth(lf: &LightField) -> Result<()> {
    if lf.depth.is_empty() {
        return Err(Error::Invalid(format!(
            "focus surfaces follow the scene's depth, and '{}' has none (yet: an estimate may \
             be on its way)",
            lf.name
        )));
    }
    Ok(())
}

/// The focus as a world plane that no longer depends on the reference camera (before the
/// viewpoint moves). Classic shift-and-sum and disparities on parallel rigs are already
/// independent of the viewpoint and stay as they are.
fn world_fixed(core: &mut Core, resolved: &ResolvedFocus) {
    let relative = match core.focus.target {
        FocusTarget::Spec(FocusSpec::FocusTiltSwing { .. }) => true,
        FocusTarget::Spec(_) => false,
        _ => core.focus.nudge.is_some(),
    };
    if let (true, Some(plane)) = (relative, resolved.plane) {
        core.focus = FocusSpec::Plane(plane).into();
    }
}

/// The depth `n` scroll steps nearer than `z` along the reference axis: one disparity step
/// ([`disparity_step`]) per scroll step on a parallel rig, else the inverse depth stepped by
/// 1/64 of itself.
fn stepped_depth(lf: &LightField, z: f64, n: f64) -> Result<f64> {
    let moved = match lf.rig.as_ref() {
        Some(rig) => rig.depth_of_disparity(rig.disparity_of_depth(z) + disparity_step(lf) * n),
        None => {
            let inv = (1.0 / z) * (1.0 + n / 64.0);
            (inv.is_finite() && inv > 0.0).then(|| 1.0 / inv)
        }
    };
    moved.ok_or_else(|| Error::Geometry("the focus cannot move farther than infinity".into()))
}

/// Tilt or swing (degrees) above which a plane counts as tilted: scrolling keeps it tilted.
const TILTED_DEG: f64 = 1e-6;

fn no_plane() -> Error {
    Error::Geometry(
        "this light field has no calibrated cameras, so its classic shift-and-sum focus has no \
         plane to tilt, swing or move; scroll over the refocus image to change the disparity"
            .into(),
    )
}

fn modify(
    lf: &LightField,
    core: &mut Core,
    action: Action,
    resolved: &ResolvedFocus,
    plan: &RefocusPlan,
) -> Result<()> {
    let camera = &plan.reference_camera;
    let mut nudge = |n: Nudge| -> Result<()> {
        let plane = resolved.plane.ok_or_else(no_plane)?;
        let (plane, _) = nudge_plane(&plane, camera, n)?;
        core.focus = FocusSpec::Plane(plane).into();
        Ok(())
    };
    match action {
        Action::Tilt(deg) => nudge(Nudge {
            tilt_deg: deg,
            ..Nudge::default()
        }),
        Action::Swing(deg) => nudge(Nudge {
            swing_deg: deg,
            ..Nudge::default()
        }),
        Action::Distance(fraction) => {
            let plane = resolved.plane.ok_or_else(no_plane)?;
            let kb = KeyboardPlane::of(&plane, camera)?;
            nudge(Nudge {
                distance: fraction * kb.distance,
                ..Nudge::default()
            })
        }
        Action::DisparitySteps(n) => step_disparity(lf, core, n, resolved, camera),
        Action::ApertureRadius(delta) => {
            let min = if core.aperture.shape == ApertureShape::Gaussian {
                0.5
            } else {
                0.0
            };
            let r = (effective_radius(&core.aperture, lf) + delta).max(min);
            core.aperture.radius = Some(r);
            Ok(())
        }
        Action::CycleAperture => {
            core.aperture.shape = match core.aperture.shape {
                ApertureShape::Disk => ApertureShape::Square,
                ApertureShape::Square => ApertureShape::Gaussian,
                ApertureShape::Gaussian => ApertureShape::Disk,
            };
            if core.aperture.shape == ApertureShape::Gaussian {
                core.aperture.radius = core.aperture.radius.map(|r| r.max(0.5));
            }
            Ok(())
        }
        Action::MoveView(d) => {
            world_fixed(core, resolved);
            let max = DVec2::new(lf.grid.cols as f64 - 1.0, lf.grid.rows as f64 - 1.0);
            core.reference = (core.reference + d).clamp(DVec2::ZERO, max);
            Ok(())
        }
        Action::Recentre => {
            world_fixed(core, resolved);
            core.reference = lf.grid.centre();
            Ok(())
        }
        Action::ToggleAntialias => {
            core.antialias = !core.antialias;
            Ok(())
        }
        Action::KeepPlane => {
            need_depth(lf)?;
            let plane = resolved.plane.ok_or_else(no_plane)?;
            core.surface.keep(plane)
        }
        Action::DropPlane => core.surface.drop_last(),
        Action::ClearSurface => {
            core.surface = SurfaceChoice::default();
            Ok(())
        }
        Action::Slab(fraction) => widen_slab(lf, core, fraction, resolved, camera),
        Action::ToggleAllInFocus => {
            need_depth(lf)?;
            core.surface.all_in_focus = !core.surface.all_in_focus;
            Ok(())
        }
        Action::ToggleAveraging => {
            core.averaging = match core.averaging {
                Averaging::Linear => Averaging::Encoded,
                Averaging::Encoded => Averaging::Linear,
            };
            Ok(())
        }
        // Handled by `ViewerState::apply` before the core is copied.
        _ => Ok(()),
    }
}

/// Scroll: the focus `n` disparity steps nearer (or farther, negative).
fn step_disparity(
    lf: &LightField,
    core: &mut Core,
    n: f64,
    resolved: &ResolvedFocus,
    camera: &Camera,
) -> Result<()> {
    let step = disparity_step(lf) * n;
    // A tilted or swung plane keeps its orientation: the scroll moves it along the reference
    // axis by the same step in disparity (or inverse depth) that moves a frontoparallel plane,
    // instead of silently replacing it with a frontoparallel one.
    if let Some(plane) = resolved.plane {
        let kb = KeyboardPlane::of(&plane, camera)?;
        if kb.tilt_deg.abs() > TILTED_DEG || kb.swing_deg.abs() > TILTED_DEG {
            let z = kb.distance;
            let z_new = stepped_depth(lf, z, n)?;
            let nudge = Nudge {
                distance: z_new - z,
                ..Nudge::default()
            };
            let (plane, _) = nudge_plane(&plane, camera, nudge)?;
            core.focus = FocusSpec::Plane(plane).into();
            return Ok(());
        }
    }
    let current = match (core.focus.target, resolved.plane) {
        (FocusTarget::Spec(FocusSpec::Disparity(d)), _) => Some(d),
        (_, Some(plane)) => {
            let z = KeyboardPlane::of(&plane, camera)?.distance;
            lf.rig.as_ref().map(|rig| rig.disparity_of_depth(z))
        }
        (_, None) => Some(0.0),
    };
    match current {
        Some(d) => core.focus = FocusSpec::Disparity(d + step).into(),
        None => {
            // A calibrated rig without the parallel-rig disparity: frontoparallel to the camera
            // at the stepped depth.
            let plane = resolved.plane.ok_or_else(no_plane)?;
            let z = KeyboardPlane::of(&plane, camera)?.distance;
            let p = Plane::from_focus_tilt_swing(camera, stepped_depth(lf, z, n)?, 0.0, 0.0)?;
            core.focus = FocusSpec::Plane(p).into();
        }
    }
    core.anchor = None;
    Ok(())
}

/// `[` / `]`: the focus slab around the plane widened by `fraction` of its distance (narrowed
/// when negative; to nothing, the single plane again).
fn widen_slab(
    lf: &LightField,
    core: &mut Core,
    fraction: f64,
    resolved: &ResolvedFocus,
    camera: &Camera,
) -> Result<()> {
    need_depth(lf)?;
    let plane = resolved.plane.ok_or_else(no_plane)?;
    if core.surface.all_in_focus {
        return Err(Error::Invalid(
            "all in focus is on (G turns it off); it has no slab".into(),
        ));
    }
    if core.surface.kept().next().is_some() {
        return Err(Error::Invalid(
            "a focus slab lies around one plane: drop the kept planes (Backspace) first".into(),
        ));
    }
    let d = plane.normal.dot(plane.point - camera.centre()).abs();
    let w = core.surface.slab.unwrap_or(0.0) + fraction * d;
    core.surface.slab = (w > 1e-6 * d).then_some(w);
    Ok(())
}

/// The viewer's state on `lf` focused by `focus`, with the default aperture and linear
/// averaging: the fixture of the viewer's unit tests.
#[cfg(test)]
pub(crate) fn test_state(lf: &LightField, focus: FocusSpec) -> ViewerState {
    ViewerState::new(
        lf,
        focus.into(),
        Aperture::default(),
        None,
        Averaging::Linear,
        Vec::new(),
    )
    .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::plane::tilt_swing_normal;
    use crate::refocus::resolve_focus;

    fn lf(name: &str) -> LightField {
        crate::synth::builtin(name).unwrap().light_field(1)
    }

    use super::test_state as state;

    #[test]
    fn keys_tilt_swing_and_move_the_plane_as_the_nudge_options_do() {
        let lf = lf("planes");
        let mut s = state(&lf, FocusSpec::Disparity(0.0));
        let camera = s.plan.reference_camera;
        let before = KeyboardPlane::of(&s.resolved.plane.unwrap(), &camera).unwrap();
        assert_eq!(s.apply(&lf, Action::Tilt(1.0)), Effect::Changed);
        assert_eq!(s.apply(&lf, Action::Swing(-2.0)), Effect::Changed);
        assert_eq!(s.apply(&lf, Action::Distance(0.01)), Effect::Changed);
        assert_eq!(s.version, 3);
        let after = KeyboardPlane::of(&s.plan.plane.unwrap(), &camera).unwrap();
        assert!((after.tilt_deg - 1.0).abs() < 1e-9, "{after:?}");
        assert!((after.swing_deg + 2.0).abs() < 1e-9, "{after:?}");
        assert!((after.distance / before.distance - 1.01).abs() < 1e-9);
        let n = camera.r * s.plan.plane.unwrap().normal;
        assert!((n - tilt_swing_normal(1.0, -2.0)).length() < 1e-9);
        // Reset brings back the initial plan.
        assert_eq!(s.apply(&lf, Action::Reset), Effect::Changed);
        assert_eq!(s.resolved.spec, FocusSpec::Disparity(0.0));
    }

    #[test]
    fn undo_and_redo_step_through_the_focus_changes() {
        let lf = lf("planes");
        let mut s = state(&lf, FocusSpec::Disparity(0.0));
        let start = s.resolved.plane;
        assert!(matches!(s.apply(&lf, Action::Undo), Effect::Refused(_)));
        assert_eq!(s.message.as_deref(), Some("nothing to undo"));
        s.apply(&lf, Action::Tilt(3.0));
        let tilted = s.resolved.plane;
        s.apply(&lf, Action::ApertureRadius(0.5));
        let wider = s.aperture();
        assert_ne!(tilted, start);
        // Back two steps, forward one: the tilt without the wider aperture.
        assert_eq!(s.apply(&lf, Action::Undo), Effect::Changed);
        assert_eq!(s.resolved.plane, tilted);
        assert_ne!(s.aperture(), wider);
        assert_eq!(s.apply(&lf, Action::Undo), Effect::Changed);
        assert_eq!(s.resolved.plane, start);
        assert_eq!(s.apply(&lf, Action::Redo), Effect::Changed);
        assert_eq!(s.resolved.plane, tilted);
        // A new change drops what could be redone.
        s.apply(&lf, Action::Swing(1.0));
        assert!(matches!(s.apply(&lf, Action::Redo), Effect::Refused(_)));
        // A refused action is no step.
        let before = s.resolved.plane;
        let refused = s.apply(&lf, Action::Click(DVec2::new(500.0, 3.0)));
        assert!(matches!(refused, Effect::Refused(_)), "{refused:?}");
        assert_eq!(s.apply(&lf, Action::Undo), Effect::Changed);
        assert_eq!(s.resolved.plane, tilted, "undo skipped the refused change");
        assert_ne!(s.resolved.plane, before);
        // R is a step too, and the history keeps the last UNDO_STEPS of them.
        s.apply(&lf, Action::Reset);
        assert_eq!(s.resolved.plane, start);
        s.apply(&lf, Action::Undo);
        assert_eq!(s.resolved.plane, tilted);
        for _ in 0..UNDO_STEPS + 10 {
            s.apply(&lf, Action::Tilt(0.01));
        }
        let mut undone = 0;
        while s.apply(&lf, Action::Undo) == Effect::Changed {
            undone += 1;
        }
        assert_eq!(undone, UNDO_STEPS);
    }

    #[test]
    fn moving_the_viewpoint_keeps_the_plane_fixed_in_the_world() {
        let lf = lf("planes");
        let mut s = state(
            &lf,
            FocusSpec::FocusTiltSwing {
                distance: 3.0,
                tilt_deg: 20.0,
                swing_deg: 0.0,
            },
        );
        let plane = s.plan.plane.unwrap();
        assert_eq!(
            s.apply(&lf, Action::MoveView(DVec2::new(0.75, -0.5))),
            Effect::Changed
        );
        assert_eq!(s.reference(), DVec2::new(2.75, 1.5));
        let moved = s.plan.plane.unwrap();
        assert!((moved.normal - plane.normal).length() < 1e-12);
        assert!(moved.signed_distance(plane.point).abs() < 1e-12);
        // The viewpoint is clamped to the grid and the aperture follows it.
        s.apply(&lf, Action::MoveView(DVec2::new(10.0, 10.0)));
        assert_eq!(s.reference(), DVec2::new(4.0, 4.0));
        assert_eq!(s.apply(&lf, Action::Recentre), Effect::Changed);
        assert_eq!(s.reference(), lf.grid.centre());
    }

    #[test]
    fn the_clicks_of_a_three_click_plane_stay_marked_until_the_next_pick() {
        let lf = lf("planes");
        let mut s = state(&lf, FocusSpec::Disparity(0.0));
        let clicks = [
            DVec2::new(10.0, 10.0),
            DVec2::new(50.0, 12.0),
            DVec2::new(30.0, 50.0),
        ];
        for c in clicks {
            s.apply(&lf, Action::ThreeClick(c));
        }
        assert_eq!(s.resolved.how, "three-points");
        assert_eq!(s.placed_clicks, clicks.to_vec());
        // Kept through a nudge of the plane …
        s.apply(&lf, Action::Tilt(1.0));
        assert_eq!(s.placed_clicks.len(), 3);
        // … gone once the next pick starts, and on a reset.
        s.apply(&lf, Action::ThreeClick(clicks[0]));
        assert!(s.placed_clicks.is_empty());
        assert_eq!(s.pending_clicks, vec![clicks[0]]);
        s.apply(&lf, Action::Reset);
        assert!(s.placed_clicks.is_empty() && s.pending_clicks.is_empty());
    }

    #[test]
    fn refused_actions_keep_the_state_and_say_why() {
        let lf = lf("planes");
        let mut s = state(&lf, FocusSpec::Disparity(0.0));
        // Three collinear clicks.
        for x in [10.0, 20.0] {
            assert_eq!(
                s.apply(&lf, Action::ThreeClick(DVec2::new(x, 30.0))),
                Effect::Marked
            );
            assert!(s.message.as_deref().unwrap().contains("of 3"));
        }
        let e = s.apply(&lf, Action::ThreeClick(DVec2::new(30.0, 30.0)));
        assert!(matches!(e, Effect::Refused(_)), "{e:?}");
        assert_eq!(s.message.as_deref(), Some(COLLINEAR_CLICKS));
        assert_eq!(s.version, 0);
        assert!(s.pending_clicks.is_empty());
        assert!(
            s.placed_clicks.is_empty(),
            "a refused plane leaves no marks"
        );
        // A click outside the view.
        let e = s.apply(&lf, Action::Click(DVec2::new(500.0, 3.0)));
        assert!(
            matches!(e, Effect::Refused(ref m) if m.contains("outside")),
            "{e:?}"
        );
        // An aperture of radius 0 around a viewpoint between views holds no view.
        s.apply(&lf, Action::MoveView(DVec2::new(0.5, 0.0)));
        let v = s.version;
        for _ in 0..10 {
            s.apply(&lf, Action::ApertureRadius(-0.5));
        }
        assert!(
            s.message.as_deref().unwrap().contains("no usable view"),
            "{:?}",
            s.message
        );
        assert!(!s.plan.views.is_empty());
        assert!(s.version > v, "the radius shrank as far as it could");
        // Classic shift-and-sum has no plane to tilt.
        let mut classic_lf = lf.clone();
        classic_lf.rig = None;
        let mut c = state(&classic_lf, FocusSpec::Disparity(0.5));
        let e = c.apply(&classic_lf, Action::Tilt(1.0));
        assert!(
            matches!(e, Effect::Refused(ref m) if m.contains("no plane")),
            "{e:?}"
        );
        assert_eq!(c.resolved.spec, FocusSpec::Disparity(0.5));
        // But scrolling changes its disparity.
        assert_eq!(
            c.apply(&classic_lf, Action::DisparitySteps(2.0)),
            Effect::Changed
        );
        match c.resolved.spec {
            FocusSpec::Disparity(d) => {
                assert!((d - 0.5 - 2.0 * disparity_step(&classic_lf)).abs() < 1e-12)
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn scrolling_moves_a_tilted_plane_and_keeps_its_tilt() {
        let lf = lf("planes");
        let mut s = state(&lf, FocusSpec::Disparity(0.0));
        let camera = s.plan.reference_camera;
        assert_eq!(s.apply(&lf, Action::Tilt(10.0)), Effect::Changed);
        let before = KeyboardPlane::of(&s.resolved.plane.unwrap(), &camera).unwrap();
        assert_eq!(s.apply(&lf, Action::DisparitySteps(2.0)), Effect::Changed);
        let after = KeyboardPlane::of(&s.resolved.plane.unwrap(), &camera).unwrap();
        assert!((after.tilt_deg - before.tilt_deg).abs() < 1e-9, "{after:?}");
        assert!(
            (after.swing_deg - before.swing_deg).abs() < 1e-9,
            "{after:?}"
        );
        // Nearer by the disparity step a frontoparallel plane would move.
        let rig = lf.rig.unwrap();
        let expected = rig
            .depth_of_disparity(rig.disparity_of_depth(before.distance) + 2.0 * disparity_step(&lf))
            .unwrap();
        assert!(
            (after.distance - expected).abs() < 1e-9 * expected,
            "{after:?}"
        );
        assert!(after.distance < before.distance);
        // A frontoparallel plane still becomes a disparity.
        let mut f = state(&lf, FocusSpec::Disparity(0.0));
        f.apply(&lf, Action::DisparitySteps(1.0));
        assert!(matches!(f.resolved.spec, FocusSpec::Disparity(_)));
    }

    #[test]
    fn depth_arriving_turns_on_antialiasing_unless_the_user_toggled_it() {
        let lf = lf("planes");
        let mut s = state(&lf, FocusSpec::Disparity(0.0));
        assert!(!s.antialias());
        let arrived = Action::DepthArrived {
            normal_window: 31,
            antialias: true,
            focus: None,
        };
        assert_eq!(s.apply(&lf, arrived.clone()), Effect::Changed);
        assert!(s.antialias());
        assert_eq!(s.normals.window, 31);
        // R keeps the user's anti-aliasing choice (X), and restores the focus.
        s.apply(&lf, Action::ToggleAntialias);
        s.apply(&lf, Action::Tilt(2.0));
        s.apply(&lf, Action::Reset);
        assert!(!s.antialias());
        s.apply(&lf, Action::ToggleAntialias);
        assert!(s.antialias());
        // Toggled off before depth came: it stays off, and so does the user's focus.
        let mut t = state(&lf, FocusSpec::Disparity(0.0));
        t.apply(&lf, Action::ToggleAntialias);
        t.apply(&lf, Action::ToggleAntialias);
        t.apply(&lf, Action::ToggleAntialias);
        t.apply(&lf, Action::Tilt(2.0));
        let plane = t.resolved.plane;
        let focus = FocusSpec::FocusTiltSwing {
            distance: 3.0,
            tilt_deg: 0.0,
            swing_deg: 0.0,
        };
        t.apply(
            &lf,
            Action::DepthArrived {
                normal_window: 31,
                antialias: false,
                focus: Some(focus.into()),
            },
        );
        assert!(t.antialias(), "the user's X stands");
        assert_eq!(t.resolved.plane, plane, "the user's focus stands");
        // An untouched state takes the default focus with depth.
        let mut u = state(&lf, FocusSpec::Disparity(0.0));
        u.apply(
            &lf,
            Action::DepthArrived {
                normal_window: 31,
                antialias: false,
                focus: Some(focus.into()),
            },
        );
        assert_eq!(u.resolved.spec, focus);
        // The scene camera is framed anew unless the user moved it.
        let keep = vec![DVec3::new(-5.0, -5.0, 10.0), DVec3::new(5.0, 5.0, 20.0)];
        let reframe = Action::Reframe {
            centre: Some(DVec3::new(0.0, 0.0, 15.0)),
            keep,
            array: Vec::new(),
            aspect: 1.0,
        };
        let before = u.orbit;
        assert_eq!(u.apply(&lf, reframe.clone()), Effect::SceneView);
        assert_ne!(u.orbit, before);
        u.apply(&lf, Action::Orbit(DVec2::new(30.0, 0.0), (400, 300)));
        let moved = u.orbit;
        assert_eq!(u.apply(&lf, reframe), Effect::Marked);
        assert_eq!(u.orbit, moved);
        u.apply(&lf, Action::Frame);
        assert_ne!(u.orbit, moved, "F goes to the new framing");
    }

    #[test]
    fn focus_surfaces_are_kept_planes_a_slab_or_all_in_focus_and_refuse_mixtures() {
        let lf = lf("planes");
        let mut s = state(&lf, FocusSpec::Disparity(0.0));
        assert_eq!(s.surface(), FocusSurface::Plane);
        let first = s.plan.plane.unwrap();
        // Keep the plane, move on: two planes, the current one first (render's first --plane).
        assert_eq!(s.apply(&lf, Action::KeepPlane), Effect::Changed);
        let e = s.apply(&lf, Action::KeepPlane);
        assert!(
            matches!(e, Effect::Refused(ref m) if m.contains("kept already")),
            "{e:?}"
        );
        s.apply(&lf, Action::DisparitySteps(3.0));
        let now = s.plan.plane.unwrap();
        assert_eq!(s.surface(), FocusSurface::Planes(vec![now, first]));
        // A slab does not mix with kept planes, nor planes with a slab.
        let e = s.apply(&lf, Action::Slab(0.02));
        assert!(
            matches!(e, Effect::Refused(ref m) if m.contains("Backspace")),
            "{e:?}"
        );
        // At most 8 planes: the focus and 7 kept.
        for k in 0..10 {
            s.apply(&lf, Action::KeepPlane);
            s.apply(&lf, Action::DisparitySteps(1.0 + k as f64));
        }
        match s.surface() {
            FocusSurface::Planes(p) => assert_eq!(p.len(), MAX_PLANES),
            other => panic!("{other:?}"),
        }
        let e = s.apply(&lf, Action::KeepPlane);
        assert!(
            matches!(e, Effect::Refused(ref m) if m.contains("at most 8")),
            "{e:?}"
        );
        // Backspace drops the last kept; Shift+Backspace clears.
        assert_eq!(s.apply(&lf, Action::DropPlane), Effect::Changed);
        match s.surface() {
            FocusSurface::Planes(p) => assert_eq!(p.len(), MAX_PLANES - 1),
            other => panic!("{other:?}"),
        }
        assert_eq!(s.apply(&lf, Action::ClearSurface), Effect::Changed);
        assert_eq!(s.surface(), FocusSurface::Plane);
        assert!(matches!(
            s.apply(&lf, Action::DropPlane),
            Effect::Refused(_)
        ));
        // The slab widens by 2 % of the plane's distance per step and narrows away to nothing.
        let d = {
            let p = s.plan.plane.unwrap();
            p.normal
                .dot(p.point - s.plan.reference_camera.centre())
                .abs()
        };
        s.apply(&lf, Action::Slab(0.02));
        s.apply(&lf, Action::Slab(0.02));
        match s.surface() {
            FocusSurface::Slab { half_width } => assert!((half_width - 0.04 * d).abs() < 1e-12),
            other => panic!("{other:?}"),
        }
        let e = s.apply(&lf, Action::KeepPlane);
        assert!(
            matches!(e, Effect::Refused(ref m) if m.contains("slab")),
            "{e:?}"
        );
        // A slab reaching the reference camera is refused by the library's geometry.
        let e = s.apply(&lf, Action::Slab(1.5));
        assert!(
            matches!(e, Effect::Refused(ref m) if m.contains("inside the focus slab")),
            "{e:?}"
        );
        // All in focus hides the slab and gives it back.
        assert_eq!(s.apply(&lf, Action::ToggleAllInFocus), Effect::Changed);
        assert_eq!(s.surface(), FocusSurface::AllInFocus);
        s.apply(&lf, Action::ToggleAllInFocus);
        assert!(matches!(s.surface(), FocusSurface::Slab { .. }));
        s.apply(&lf, Action::Slab(-0.02));
        s.apply(&lf, Action::Slab(-0.02));
        assert_eq!(s.surface(), FocusSurface::Plane, "narrowed to nothing");
        // R returns to the single plane.
        s.apply(&lf, Action::ToggleAllInFocus);
        s.apply(&lf, Action::Reset);
        assert_eq!(s.surface(), FocusSurface::Plane);
        // Without depth every surface is refused, naming the cause.
        let mut bare = lf.clone();
        bare.depth.clear();
        let mut b = state(&bare, FocusSpec::Disparity(0.0));
        for a in [
            Action::KeepPlane,
            Action::Slab(0.02),
            Action::ToggleAllInFocus,
        ] {
            let e = b.apply(&bare, a);
            assert!(
                matches!(e, Effect::Refused(ref m) if m.contains("depth")),
                "{e:?}"
            );
        }
    }

    #[test]
    fn video_frames_scene_moves_and_messages_are_actions_too() {
        let lf = lf("planes");
        let mut s = state(&lf, FocusSpec::Disparity(0.0));
        let plan = s.plan.clone();
        // A new video frame changes what is rendered (new views), not the plan.
        assert_eq!(s.apply(&lf, Action::ShowFrame(7)), Effect::NewViews);
        assert_eq!((s.frame, s.version, s.marks_version), (Some(7), 1, 0));
        assert_eq!(s.plan, plan);
        // The scene camera and messages change neither version.
        let orbit = s.orbit;
        assert_eq!(
            s.apply(&lf, Action::Orbit(DVec2::new(10.0, 0.0), (400, 300))),
            Effect::SceneView
        );
        assert_eq!(s.apply(&lf, Action::Zoom(1.0)), Effect::SceneView);
        assert_ne!(s.orbit, orbit);
        // F brings the scene camera back to its framing, then has nothing left to do.
        assert_eq!(s.apply(&lf, Action::Frame), Effect::SceneView);
        assert_eq!(s.orbit, orbit);
        assert_eq!(s.apply(&lf, Action::Frame), Effect::Marked);
        s.apply(&lf, Action::Zoom(1.0));
        // R brings the scene camera back with the focus; the plan was never changed.
        assert_eq!(s.apply(&lf, Action::Reset), Effect::SceneView);
        assert_eq!(s.orbit, orbit);
        assert_eq!(
            s.apply(&lf, Action::Orbit(DVec2::new(10.0, 0.0), (400, 300))),
            Effect::SceneView
        );
        assert_eq!(
            s.apply(&lf, Action::Refuse("no depth".into())),
            Effect::Message
        );
        assert_eq!(s.message.as_deref(), Some("no depth"));
        assert_eq!((s.version, s.marks_version), (1, 0));
    }

    #[test]
    fn clicks_and_scene_picks_set_the_plane_through_the_library() {
        let lf = lf("tilted");
        let mut s = state(&lf, FocusSpec::Disparity(0.0));
        assert_eq!(
            s.apply(&lf, Action::Click(DVec2::new(32.0, 40.0))),
            Effect::Changed
        );
        assert_eq!(s.resolved.how, "click");
        let expected = resolve_focus(
            &lf,
            &FocusRequest {
                target: FocusTarget::Click {
                    pixel: DVec2::new(32.0, 40.0),
                    normals: NormalParams::default(),
                },
                nudge: None,
            },
            lf.grid.centre(),
        )
        .unwrap();
        assert_eq!(s.resolved.plane, expected.plane);
        assert_eq!(s.anchor(), expected.pick.unwrap().points.first().copied());
        // Three scene picks give the plane through them.
        let pts = [
            DVec3::new(0.0, 0.0, 3.0),
            DVec3::new(1.0, 0.0, 3.0),
            DVec3::new(0.0, 1.0, 4.0),
        ];
        for p in pts {
            s.apply(&lf, Action::ScenePick(p));
        }
        assert_eq!(s.resolved.how, "three-points-3d");
        let plane = s.resolved.plane.unwrap();
        for p in pts {
            assert!(plane.signed_distance(p).abs() < 1e-9);
        }
        // Aperture shape cycles and averaging toggles.
        s.apply(&lf, Action::CycleAperture);
        assert_eq!(s.aperture().shape, ApertureShape::Square);
        s.apply(&lf, Action::ToggleAveraging);
        assert_eq!(s.averaging(), Averaging::Encoded);
    }
}
