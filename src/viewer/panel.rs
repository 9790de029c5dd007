//! The control panel (Tab shows and hides it): sliders for the plane's distance, tilt and swing,
//! the aperture radius and the viewpoint, and buttons for the aperture shape, the averaging,
//! anti-aliasing and the focus surface — the keys' controls for a desktop user who would
//! rather see and drag them. Pure: where the widgets are, which one is under the pointer, each
//! slider's value and range, and the [`Action`] a drag or a press makes; the session's text
//! canvas draws it ([`super::session::hud`]) and the event loop feeds it the pointer.
//!
//! Why hand-drawn with the viewer's 8×8 text and not egui (+ egui-ash-renderer, which targets
//! ash 0.38 as this crate does): a trial build of egui 0.36 with egui-ash-renderer 0.13 took
//! 40 s on 2 cores (unoptimised) — not the obstacle — but egui would bring its own render
//! pass, font atlas, textures and descriptor pool into a window whose compositor, overlay
//! canvas, screenshots and validation-clean teardown are already in place, plus input
//! translated by hand from GLFW; a dozen widgets over the existing canvas need none of it.
//! Text fields (typing a value) are not offered: the sliders and the keys cover the values.
//! Sliders set absolute values through the same relative actions the keys use (a tilt of 12°
//! is `Tilt(12 − current)`), so every change still goes through `ViewerState::apply`.

use glam::DVec2;

use super::controls::SLAB_STEP;
use super::state::{effective_radius, Action, ViewerState};
use crate::geometry::aperture::ApertureShape;
use crate::geometry::picking::KeyboardPlane;
use crate::lightfield::LightField;
use crate::passes::panel::Rect;
use crate::refocus::Averaging;

/// Row height and the panel's margins, pixels.
pub const ROW: f32 = 18.0;
const PAD: f32 = 8.0;
/// Columns: label, track, value (8-pixel glyphs).
const LABEL_W: f32 = 10.0 * 8.0;
const TRACK_W: f32 = 150.0;
const VALUE_W: f32 = 9.0 * 8.0;
/// Panel width.
pub const WIDTH: f32 = PAD + LABEL_W + TRACK_W + 8.0 + VALUE_W + PAD;
/// The tilt and swing sliders' range, degrees either way.
pub const ANGLE_RANGE_DEG: f64 = 60.0;
/// The distance slider spans this factor either way around the starting distance (log scale).
pub const DISTANCE_RANGE: f64 = 4.0;

/// A quantity a slider sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Slider {
    Distance,
    Tilt,
    Swing,
    Radius,
    ViewS,
    ViewT,
}

impl Slider {
    pub const ALL: [Slider; 6] = [
        Slider::Distance,
        Slider::Tilt,
        Slider::Swing,
        Slider::Radius,
        Slider::ViewS,
        Slider::ViewT,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Slider::Distance => "distance",
            Slider::Tilt => "tilt",
            Slider::Swing => "swing",
            Slider::Radius => "aperture",
            Slider::ViewS => "view s",
            Slider::ViewT => "view t",
        }
    }
}

/// A button and what it does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Button {
    Shape,
    Averaging,
    Antialias,
    Keep,
    Drop,
    Clear,
    SlabNarrow,
    SlabWiden,
    AllInFocus,
}

impl Button {
    /// Rows of buttons, in order.
    const ROWS: [&'static [Button]; 3] = [
        &[Button::Shape, Button::Averaging, Button::Antialias],
        &[Button::Keep, Button::Drop, Button::Clear],
        &[Button::SlabNarrow, Button::SlabWiden, Button::AllInFocus],
    ];

    /// Its label for `state`: what pressing it does (the setting it leads to), at most 12
    /// characters; a toggle that is on is lit ([`Button::on`]), so the state shows too.
    pub fn label(self, state: &ViewerState) -> String {
        let on = self.on(state);
        match self {
            Button::Shape => match state.aperture().shape {
                ApertureShape::Disk => "to square",
                ApertureShape::Square => "to gaussian",
                ApertureShape::Gaussian => "to disk",
            }
            .into(),
            Button::Averaging => match state.averaging() {
                Averaging::Linear => "to encoded",
                Averaging::Encoded => "to linear",
            }
            .into(),
            Button::Antialias => if on { "turn aa off" } else { "turn aa on" }.into(),
            Button::Keep => "keep plane".into(),
            Button::Drop => "drop kept".into(),
            Button::Clear => "one plane".into(),
            Button::SlabNarrow => "narrow slab".into(),
            Button::SlabWiden => "widen slab".into(),
            Button::AllInFocus => if on { "plane focus" } else { "all in focus" }.into(),
        }
    }

    /// Whether it shows as on.
    pub fn on(self, state: &ViewerState) -> bool {
        let s = state.surface_choice();
        match self {
            Button::Antialias => state.antialias(),
            Button::Keep => s.kept().next().is_some(),
            Button::SlabWiden | Button::SlabNarrow => s.slab.is_some(),
            Button::AllInFocus => s.all_in_focus,
            _ => false,
        }
    }

    pub fn action(self) -> Action {
        match self {
            Button::Shape => Action::CycleAperture,
            Button::Averaging => Action::ToggleAveraging,
            Button::Antialias => Action::ToggleAntialias,
            Button::Keep => Action::KeepPlane,
            Button::Drop => Action::DropPlane,
            Button::Clear => Action::ClearSurface,
            Button::SlabNarrow => Action::Slab(-SLAB_STEP),
            Button::SlabWiden => Action::Slab(SLAB_STEP),
            Button::AllInFocus => Action::ToggleAllInFocus,
        }
    }
}

/// What lies under a window position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Hit {
    /// A slider's track, at this fraction of its length (0..1).
    Slider(Slider, f64),
    Button(Button),
    /// The panel's background: the pointer is taken, nothing happens.
    Panel,
}

/// Where the panel and its widgets are in a window.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlPanel {
    pub rect: Rect,
    /// Each slider's track.
    pub sliders: Vec<(Slider, Rect)>,
    pub buttons: Vec<(Button, Rect)>,
    /// The plane's distance the distance slider is centred on (the starting plane's).
    pub distance_centre: f64,
}

impl ControlPanel {
    /// The panel at the top left of `scene` (the scene panel), `distance_centre` the distance
    /// the distance slider centres on.
    pub fn new(scene: Rect, distance_centre: f64) -> Self {
        let (x0, y0) = (scene.x + 10.0, scene.y + 10.0);
        let mut y = y0 + PAD + ROW; // the title row
        let mut sliders = Vec::new();
        for s in Slider::ALL {
            sliders.push((s, Rect::new(x0 + PAD + LABEL_W, y + 4.0, TRACK_W, 8.0)));
            y += ROW;
        }
        let mut buttons = Vec::new();
        let inner = WIDTH - 2.0 * PAD;
        for row in Button::ROWS {
            let w = (inner - 6.0 * (row.len() as f32 - 1.0)) / row.len() as f32;
            for (k, b) in row.iter().enumerate() {
                let x = x0 + PAD + k as f32 * (w + 6.0);
                buttons.push((*b, Rect::new(x, y + 1.0, w, ROW - 3.0)));
            }
            y += ROW;
        }
        ControlPanel {
            rect: Rect::new(x0, y0, WIDTH, y + PAD - y0),
            sliders,
            buttons,
            distance_centre: distance_centre.max(1e-9),
        }
    }

    /// What is under window position `p`, if the panel is.
    pub fn hit(&self, p: DVec2) -> Option<Hit> {
        if !self.rect.contains(p.x, p.y) {
            return None;
        }
        for (b, r) in &self.buttons {
            if r.contains(p.x, p.y) {
                return Some(Hit::Button(*b));
            }
        }
        for (s, r) in &self.sliders {
            // The track's row is the grip: a few pixels above and below the thin track.
            let grip = Rect::new(r.x - 4.0, r.y - 5.0, r.width + 8.0, r.height + 10.0);
            if grip.contains(p.x, p.y) {
                return Some(Hit::Slider(*s, self.fraction(*s, p.x)));
            }
        }
        Some(Hit::Panel)
    }

    /// The fraction of slider `s`'s track at window x (clamped to the track).
    pub fn fraction(&self, s: Slider, x: f64) -> f64 {
        let r = self
            .sliders
            .iter()
            .find(|(t, _)| *t == s)
            .map_or(Rect::new(0.0, 0.0, 1.0, 1.0), |(_, r)| *r);
        ((x - r.x as f64) / r.width.max(1.0) as f64).clamp(0.0, 1.0)
    }

    /// The range of slider `s` on `lf` (value at fraction 0 and 1).
    pub fn range(&self, s: Slider, lf: &LightField) -> (f64, f64) {
        let (cols, rows) = (lf.grid.cols as f64 - 1.0, lf.grid.rows as f64 - 1.0);
        match s {
            Slider::Distance => (
                self.distance_centre / DISTANCE_RANGE,
                self.distance_centre * DISTANCE_RANGE,
            ),
            Slider::Tilt | Slider::Swing => (-ANGLE_RANGE_DEG, ANGLE_RANGE_DEG),
            Slider::Radius => (0.0, (0.5 * cols.hypot(rows)).max(1.0) * 1.5),
            Slider::ViewS => (0.0, cols.max(0.0)),
            Slider::ViewT => (0.0, rows.max(0.0)),
        }
    }

    /// The value at `fraction` of slider `s` (the distance slider is logarithmic).
    pub fn value_at(&self, s: Slider, fraction: f64, lf: &LightField) -> f64 {
        let (lo, hi) = self.range(s, lf);
        let f = fraction.clamp(0.0, 1.0);
        match s {
            Slider::Distance => lo * (hi / lo).powf(f),
            _ => lo + (hi - lo) * f,
        }
    }

    /// Where value `v` of slider `s` lies on its track (clamped to 0..1).
    pub fn fraction_of(&self, s: Slider, v: f64, lf: &LightField) -> f64 {
        let (lo, hi) = self.range(s, lf);
        let f = match s {
            Slider::Distance => (v / lo).ln() / (hi / lo).ln(),
            _ => (v - lo) / (hi - lo),
        };
        if f.is_finite() {
            f.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// The current value of slider `s` in `state` (`None`: it does not apply, e.g. tilting
/// classic shift-and-sum, which has no plane).
pub fn current(s: Slider, state: &ViewerState, lf: &LightField) -> Option<f64> {
    let kb = || {
        let plane = state.plan.plane.or(state.resolved.plane)?;
        KeyboardPlane::of(&plane, &state.plan.reference_camera).ok()
    };
    Some(match s {
        Slider::Distance => kb()?.distance,
        Slider::Tilt => kb()?.tilt_deg,
        Slider::Swing => kb()?.swing_deg,
        Slider::Radius => effective_radius(&state.aperture(), lf),
        Slider::ViewS => state.reference().x,
        Slider::ViewT => state.reference().y,
    })
}

/// The action that brings slider `s` to `value` from the state's current value: the keys'
/// relative actions (see the module docs); `None` when it does not apply or nothing moves.
pub fn set_action(s: Slider, value: f64, state: &ViewerState, lf: &LightField) -> Option<Action> {
    let now = current(s, state, lf)?;
    if (value - now).abs() <= 1e-9 * (1.0 + now.abs()) {
        return None;
    }
    Some(match s {
        Slider::Distance => Action::Distance(value / now - 1.0),
        Slider::Tilt => Action::Tilt(value - now),
        Slider::Swing => Action::Swing(value - now),
        Slider::Radius => Action::ApertureRadius(value - now),
        Slider::ViewS => Action::MoveView(DVec2::new(value - now, 0.0)),
        Slider::ViewT => Action::MoveView(DVec2::new(0.0, value - now)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::refocus::FocusSpec;

    fn setup() -> (LightField, ViewerState) {
        let lf = crate::synth::builtin("planes").unwrap().light_field(1);
        let s = crate::viewer::state::test_state(&lf, FocusSpec::Disparity(0.0));
        (lf, s)
    }

    #[test]
    fn widgets_are_found_under_the_pointer_and_inside_the_panel() {
        let panel = ControlPanel::new(Rect::new(640.0, 0.0, 640.0, 676.0), 3.0);
        assert!(panel.rect.x >= 640.0 && panel.rect.width == WIDTH);
        for (s, r) in &panel.sliders {
            let mid = DVec2::new((r.x + 0.75 * r.width) as f64, (r.y + 4.0) as f64);
            match panel.hit(mid) {
                Some(Hit::Slider(t, f)) => {
                    assert_eq!(t, *s);
                    assert!((f - 0.75).abs() < 1e-6, "{f}");
                }
                other => panic!("{s:?}: {other:?}"),
            }
            assert!(panel.rect.contains(r.x as f64, r.y as f64));
        }
        for (b, r) in &panel.buttons {
            let mid = DVec2::new((r.x + r.width / 2.0) as f64, (r.y + r.height / 2.0) as f64);
            assert_eq!(panel.hit(mid), Some(Hit::Button(*b)));
            assert!(panel
                .rect
                .contains((r.x + r.width) as f64, (r.y + r.height) as f64));
        }
        assert_eq!(panel.hit(DVec2::new(651.0, 12.0)), Some(Hit::Panel));
        assert_eq!(panel.hit(DVec2::new(100.0, 100.0)), None);
    }

    #[test]
    fn sliders_map_values_both_ways_and_set_them_through_the_keys_actions() {
        let (lf, mut s) = setup();
        let d0 = current(Slider::Distance, &s, &lf).unwrap();
        let panel = ControlPanel::new(Rect::new(0.0, 0.0, 500.0, 500.0), d0);
        // The distance slider is centred on the start distance, logarithmic.
        assert!((panel.value_at(Slider::Distance, 0.5, &lf) - d0).abs() < 1e-9);
        for sl in Slider::ALL {
            for f in [0.0, 0.3, 1.0] {
                let v = panel.value_at(sl, f, &lf);
                assert!(
                    (panel.fraction_of(sl, v, &lf) - f).abs() < 1e-9,
                    "{sl:?} {f}"
                );
            }
        }
        // Dragging to a value applies the relative action that reaches it.
        for (sl, v) in [
            (Slider::Tilt, 12.0),
            (Slider::Swing, -7.5),
            (Slider::Distance, 1.5 * d0),
            (Slider::Radius, 1.25),
            (Slider::ViewS, 1.5),
            (Slider::ViewT, 3.25),
        ] {
            let a = set_action(sl, v, &s, &lf).unwrap();
            s.apply(&lf, a);
            let now = current(sl, &s, &lf).unwrap();
            assert!(
                (now - v).abs() < 1e-6 * (1.0 + v.abs()),
                "{sl:?}: {now} ≠ {v}"
            );
            assert_eq!(set_action(sl, v, &s, &lf), None, "nothing left to move");
        }
        // Buttons are the keys' actions.
        assert_eq!(Button::Antialias.action(), Action::ToggleAntialias);
        // Labels say what a press does.
        assert_eq!(Button::Shape.label(&s), "to square");
        s.apply(&lf, Button::Shape.action());
        assert_eq!(s.aperture().shape, ApertureShape::Square);
        assert_eq!(Button::Shape.label(&s), "to gaussian");
        let aa = Button::Antialias.label(&s);
        s.apply(&lf, Button::Antialias.action());
        assert_ne!(Button::Antialias.label(&s), aa);
        for b in Button::ROWS.iter().flat_map(|r| r.iter()) {
            assert!(b.label(&s).chars().count() <= 12, "{b:?}");
        }
    }
}
