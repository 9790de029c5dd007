//! Key bindings: which key does what, the names scripts use for keys (GLFW's names: `UP`, `W`,
//! `LEFT_BRACKET`, …, with optional `shift+` and `ctrl+`), and the help text listing every
//! control.

use glam::DVec2;
use glfw::Key;

use super::session::video::VideoStep;
use super::state::Action;

/// Tilt and swing step of the arrow keys, degrees.
pub const ANGLE_STEP_DEG: f64 = 1.0;
/// Distance step of W/S as a fraction of the plane's distance.
pub const DISTANCE_STEP: f64 = 0.01;
/// Aperture radius step of `[`/`]`, grid steps.
pub const APERTURE_STEP: f64 = 0.5;
/// Viewpoint step of I/J/K/L, grid steps.
pub const VIEW_STEP: f64 = 0.25;
/// Slab half-width step of `=`/`-`, as a fraction of the plane's distance from the camera.
pub const SLAB_STEP: f64 = 0.02;
/// What Shift multiplies a step by.
pub const FINE: f64 = 0.1;

/// Every control, as (input, effect), for the help overlay and the README.
pub const CONTROLS: &[(&str, &str)] = &[
    (
        "click (refocus)",
        "single-click plane: point + surface normal",
    ),
    ("Shift+click x3 (refocus)", "plane through three points"),
    (
        "scroll (refocus)",
        "focus nearer/farther (a tilted plane keeps its tilt)",
    ),
    (
        "click x3 (scene)",
        "plane through three picked cloud points",
    ),
    ("left drag (scene)", "orbit"),
    ("right/middle drag (scene)", "pan"),
    ("scroll (scene)", "zoom"),
    ("Up/Down", "tilt +/-1 deg"),
    ("Right/Left", "swing +/-1 deg"),
    ("W/S", "distance +/-1 %"),
    ("Shift + key", "a tenth of the step"),
    ("[ / ]", "aperture radius -/+0.5"),
    ("A", "aperture disk/square/gaussian"),
    ("I/J/K/L", "move viewpoint up/left/down/right"),
    ("C", "recentre viewpoint"),
    (", / .", "previous/next video frame"),
    ("Space", "play/pause video"),
    ("E", "linear/encoded averaging"),
    ("X", "anti-aliasing on/off (needs depth)"),
    ("N", "keep this plane in focus (up to 8 planes)"),
    ("Backspace", "drop the plane kept last"),
    ("Shift+Backspace", "single plane again (no kept, slab, all)"),
    ("= / -", "widen/narrow the focus slab by 2 %"),
    ("G", "all in focus on/off (needs depth)"),
    ("F", "frame the cloud and the cameras"),
    ("R", "reset focus and scene view"),
    ("Ctrl+Z / Ctrl+Shift+Z", "undo / redo a focus change"),
    ("P", "screenshot"),
    ("Tab", "control panel: sliders and buttons"),
    ("O", "focus peaking: tint what is in focus"),
    ("H", "this help"),
    ("Q or Esc", "quit"),
];

/// The action of `key` pressed with Shift and Control as given: with Control only undo
/// (Ctrl+Z), redo (Ctrl+Shift+Z, also Ctrl+Y) and nothing else, so that a held Control never
/// turns a shortcut into a nudge.
pub fn action_for_chord(key: Key, shift: bool, ctrl: bool) -> Option<Action> {
    if !ctrl {
        return action_for_key(key, shift);
    }
    match key {
        Key::Z if shift => Some(Action::Redo),
        Key::Z => Some(Action::Undo),
        Key::Y => Some(Action::Redo),
        _ => None,
    }
}

/// The action of `key` pressed with or without Shift, if it has one.
pub fn action_for_key(key: Key, shift: bool) -> Option<Action> {
    let f = if shift { FINE } else { 1.0 };
    Some(match key {
        Key::Up => Action::Tilt(ANGLE_STEP_DEG * f),
        Key::Down => Action::Tilt(-ANGLE_STEP_DEG * f),
        Key::Right => Action::Swing(ANGLE_STEP_DEG * f),
        Key::Left => Action::Swing(-ANGLE_STEP_DEG * f),
        Key::W => Action::Distance(DISTANCE_STEP * f),
        Key::S => Action::Distance(-DISTANCE_STEP * f),
        Key::LeftBracket => Action::ApertureRadius(-APERTURE_STEP),
        Key::RightBracket => Action::ApertureRadius(APERTURE_STEP),
        Key::A => Action::CycleAperture,
        Key::I => Action::MoveView(DVec2::new(0.0, -VIEW_STEP * f)),
        Key::K => Action::MoveView(DVec2::new(0.0, VIEW_STEP * f)),
        Key::J => Action::MoveView(DVec2::new(-VIEW_STEP * f, 0.0)),
        Key::L => Action::MoveView(DVec2::new(VIEW_STEP * f, 0.0)),
        Key::C => Action::Recentre,
        Key::E => Action::ToggleAveraging,
        Key::X => Action::ToggleAntialias,
        Key::N => Action::KeepPlane,
        Key::Backspace if shift => Action::ClearSurface,
        Key::Backspace => Action::DropPlane,
        Key::Equal => Action::Slab(SLAB_STEP * f),
        Key::Minus => Action::Slab(-SLAB_STEP * f),
        Key::G => Action::ToggleAllInFocus,
        Key::F => Action::Frame,
        Key::R => Action::Reset,
        Key::P => Action::Screenshot,
        Key::H => Action::ToggleHelp,
        Key::O => Action::TogglePeaking,
        Key::Tab => Action::TogglePanel,
        Key::Q | Key::Escape => Action::Quit,
        _ => return None,
    })
}

/// The video step of `key`, if it is a video key (`,` `.` Space).
pub fn video_step_for_key(key: Key) -> Option<VideoStep> {
    match key {
        Key::Comma => Some(VideoStep::Previous),
        Key::Period => Some(VideoStep::Next),
        Key::Space => Some(VideoStep::PlayPause),
        _ => None,
    }
}

/// The key of a GLFW key name (`UP`, `W`, `LEFT_BRACKET`, `KP_ADD`-style names of the keys
/// tiltfield binds, letters, digits and a few punctuation keys).
pub fn key_from_name(name: &str) -> Option<Key> {
    let upper = name.to_ascii_uppercase();
    let letters = [
        Key::A,
        Key::B,
        Key::C,
        Key::D,
        Key::E,
        Key::F,
        Key::G,
        Key::H,
        Key::I,
        Key::J,
        Key::K,
        Key::L,
        Key::M,
        Key::N,
        Key::O,
        Key::P,
        Key::Q,
        Key::R,
        Key::S,
        Key::T,
        Key::U,
        Key::V,
        Key::W,
        Key::X,
        Key::Y,
        Key::Z,
    ];
    let digits = [
        Key::Num0,
        Key::Num1,
        Key::Num2,
        Key::Num3,
        Key::Num4,
        Key::Num5,
        Key::Num6,
        Key::Num7,
        Key::Num8,
        Key::Num9,
    ];
    if upper.len() == 1 {
        let c = upper.as_bytes()[0];
        if c.is_ascii_uppercase() {
            return Some(letters[(c - b'A') as usize]);
        }
        if c.is_ascii_digit() {
            return Some(digits[(c - b'0') as usize]);
        }
    }
    Some(match upper.as_str() {
        "UP" => Key::Up,
        "DOWN" => Key::Down,
        "LEFT" => Key::Left,
        "RIGHT" => Key::Right,
        "LEFT_BRACKET" => Key::LeftBracket,
        "RIGHT_BRACKET" => Key::RightBracket,
        "ESCAPE" => Key::Escape,
        "SPACE" => Key::Space,
        "COMMA" => Key::Comma,
        "PERIOD" => Key::Period,
        "ENTER" => Key::Enter,
        "BACKSPACE" => Key::Backspace,
        "TAB" => Key::Tab,
        "MINUS" => Key::Minus,
        "EQUAL" => Key::Equal,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_map_to_keys_and_bound_keys_have_actions() {
        assert_eq!(key_from_name("UP"), Some(Key::Up));
        assert_eq!(key_from_name("left_bracket"), Some(Key::LeftBracket));
        assert_eq!(key_from_name("W"), Some(Key::W));
        assert_eq!(key_from_name("7"), Some(Key::Num7));
        assert_eq!(key_from_name("NOPE"), None);
        assert_eq!(key_from_name(""), None);
        assert_eq!(action_for_key(Key::Up, false), Some(Action::Tilt(1.0)));
        assert_eq!(action_for_key(Key::Up, true), Some(Action::Tilt(0.1)));
        assert_eq!(action_for_key(Key::S, false), Some(Action::Distance(-0.01)));
        assert_eq!(
            action_for_key(Key::I, false),
            Some(Action::MoveView(DVec2::new(0.0, -0.25)))
        );
        assert_eq!(action_for_key(Key::B, false), None);
        assert_eq!(key_from_name("backspace"), Some(Key::Backspace));
        assert_eq!(
            action_for_key(Key::Backspace, false),
            Some(Action::DropPlane)
        );
        assert_eq!(
            action_for_key(Key::Backspace, true),
            Some(Action::ClearSurface)
        );
        assert_eq!(action_for_key(Key::Equal, false), Some(Action::Slab(0.02)));
        assert_eq!(
            action_for_key(Key::Minus, true),
            Some(Action::Slab(-SLAB_STEP * FINE))
        );
        assert_eq!(action_for_chord(Key::Z, false, true), Some(Action::Undo));
        assert_eq!(action_for_chord(Key::Z, true, true), Some(Action::Redo));
        assert_eq!(action_for_chord(Key::W, false, true), None);
        assert_eq!(
            action_for_chord(Key::W, false, false),
            Some(Action::Distance(0.01))
        );
        // Every control the help lists fits the help box's key column.
        assert!(CONTROLS.iter().all(|(k, _)| k.len() <= 26));
    }
}
