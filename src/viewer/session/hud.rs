//! The on-screen text, drawn on the CPU into a window-size [`Canvas`] that the compositor
//! blends over the panels: the two-line status strip (focus, frame; aperture, viewpoint,
//! averaging, GPU time, frame rate, refinement progress), the last message, the marks of a
//! three-click plane in progress and the help. Only the parts with content
//! ([`Hud::parts`]) are composited.
//!
//! Feedback: the field of the strip that the last control changed ([`Field`]) is drawn on an
//! amber background for a moment, and a message about a click (a refusal, a pick in
//! progress) is drawn next to where the user clicked rather than along the panel's bottom.

use std::time::Instant;

use super::super::controls::CONTROLS;
use super::super::layout::Layout;
use super::super::panel::{self as controls_panel, ControlPanel, Slider};
use super::super::state::{effective_radius, Action, ViewerState};
use super::super::text::{Canvas, CLEAR, PANEL_BG, TEXT, WARN};
use super::depth::DepthState;
use super::refinement::Refinement;
use crate::geometry::picking::KeyboardPlane;
use crate::lightfield::LightField;
use crate::passes::panel::Rect;
use crate::refocus::FocusSpec;
use glam::DVec2;

/// Background of the field the last control changed.
const HIGHLIGHT: [u8; 4] = [150, 95, 0, 255];

/// A field of the status strip that a control changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    Plane,
    Distance,
    Tilt,
    Swing,
    Surface,
    Aperture,
    View,
    Averaging,
    Antialias,
}

impl Field {
    /// The field `action` changes, if it changes one shown in the strip.
    pub fn of(action: &Action) -> Option<Field> {
        Some(match action {
            Action::Tilt(_) => Field::Tilt,
            Action::Swing(_) => Field::Swing,
            Action::Distance(_) | Action::DisparitySteps(_) => Field::Distance,
            Action::ApertureRadius(_) | Action::CycleAperture => Field::Aperture,
            Action::MoveView(_) | Action::Recentre => Field::View,
            Action::ToggleAveraging => Field::Averaging,
            Action::ToggleAntialias => Field::Antialias,
            Action::KeepPlane
            | Action::DropPlane
            | Action::ClearSurface
            | Action::Slab(_)
            | Action::ToggleAllInFocus => Field::Surface,
            Action::Click(_) | Action::ThreeClick(_) | Action::ScenePick(_) => Field::Plane,
            _ => return None,
        })
    }

    /// How the field starts in the strip (any of these).
    fn markers(self) -> &'static [&'static str] {
        match self {
            Field::Plane => &["plane p=", "classic shift-and-sum"],
            Field::Distance => &["distance ", "classic shift-and-sum"],
            Field::Tilt => &["tilt "],
            Field::Swing => &["swing "],
            // A single plane again: the plane's field shows what is in focus.
            Field::Surface => &["surface: ", "plane p="],
            Field::Aperture => &["aperture "],
            Field::View => &["view ("],
            Field::Averaging => &["linear", "encoded"],
            Field::Antialias => &["aa "],
        }
    }
}

/// Where in `line` (fields separated by two spaces) the field starting with one of
/// `markers` lies: its first character and its length, in characters.
pub fn field_span(line: &str, markers: &[&str]) -> Option<(usize, usize)> {
    let mut at = 0;
    for field in line.split("  ") {
        if !field.is_empty() && markers.iter().any(|m| field.starts_with(m)) {
            return Some((at, field.chars().count()));
        }
        at += field.chars().count() + 2;
    }
    None
}

/// The text canvas and where it has content.
pub struct Hud {
    pub canvas: Canvas,
    /// Where the canvas has content (what the compositor draws of it).
    pub parts: Vec<Rect>,
    /// When the status text was last drawn (its timings refresh periodically).
    pub drawn_at: Instant,
}

/// What the status strip reports besides the UI state.
pub struct Status<'a> {
    pub lf: &'a LightField,
    pub state: &'a ViewerState,
    pub refinement: &'a Refinement,
    /// Where the depth stands (an estimate's progress is shown until it arrives).
    pub depth: &'a DepthState,
    pub fps: f64,
    /// The field the last control changed, while it is highlighted.
    pub highlight: Option<Field>,
    /// Where the user clicked, when the message is about that click (window pixels).
    pub message_at: Option<DVec2>,
    /// The control panel, while it is shown.
    pub panel: Option<&'a ControlPanel>,
    /// The depth under the cursor over the refocus image (`DepthCache::reading`).
    pub cursor: Option<&'a str>,
    /// A passing notice (where a screenshot went), after the refinement progress.
    pub notice: Option<&'a str>,
    /// Focus peaking's mask over the refocus panel, while shown.
    pub peaks: Option<&'a super::Peaks>,
}

impl Status<'_> {
    /// The focus plane (or shift), how it was set, the video frame.
    fn focus_line(&self) -> String {
        let state = self.state;
        let plan = &state.plan;
        let plane = match (plan.plane, state.resolved.plane) {
            (Some(p), _) | (None, Some(p)) => {
                let kb = KeyboardPlane::of(&p, &plan.reference_camera).ok();
                format!(
                    "plane p=({:.3},{:.3},{:.3}) n=({:.3},{:.3},{:.3}){}",
                    shown(p.point.x, 3),
                    shown(p.point.y, 3),
                    shown(p.point.z, 3),
                    shown(p.normal.x, 3),
                    shown(p.normal.y, 3),
                    shown(p.normal.z, 3),
                    kb.map_or(String::new(), |k| format!(
                        "  distance {:.4}  tilt {:.1}°  swing {:.1}°",
                        shown(k.distance, 4),
                        shown(k.tilt_deg, 1),
                        shown(k.swing_deg, 1)
                    ))
                )
            }
            _ => match state.resolved.spec {
                FocusSpec::Disparity(d) => format!("classic shift-and-sum, {d:.3} px per view"),
                _ => "no plane".into(),
            },
        };
        format!(
            "{plane}  [{}]{}{}{}",
            state.resolved.how,
            surface_label(state).map_or(String::new(), |l| format!("  surface: {l}")),
            state
                .frame
                .map_or(String::new(), |f| format!("  frame {f}")),
            self.depth
                .field()
                .map_or(String::new(), |f| format!("  {f}")),
        ) + &self.cursor.map_or(String::new(), |c| format!("  {c}"))
    }

    /// Aperture, viewpoint, averaging, GPU time, frame rate and refinement progress.
    fn render_line(&self) -> String {
        let (lf, state) = (self.lf, self.state);
        let refiner = &self.refinement.refiner;
        let a = state.aperture();
        let (done, total) = refiner.progress();
        let aa = self.refinement.ordered_aa.as_ref();
        format!(
            "aperture {:?} r={:.1} ({} of {} views)  view ({:.2}, {:.2})  {:?}  {}  GPU {}  \
             {:.0} fps  {}",
            a.shape,
            effective_radius(&a, lf),
            aa.map_or(state.plan.views.len(), |a| a.plan.views.len()),
            lf.views.len(),
            state.reference().x,
            state.reference().y,
            state.averaging(),
            match aa {
                Some(a) if a.settings.defocus => "aa defocused".to_string(),
                Some(a) if a.settings.layered.on() => "aa layered".to_string(),
                Some(a) => format!("aa {}x{}", a.settings.max_samples, a.settings.max_samples),
                None => "aa off".to_string(),
            },
            self.refinement
                .last_gpu_ms
                .map_or("-".to_string(), |ms| format!("{ms:.1} ms")),
            self.fps,
            if refiner.converged() {
                "full quality".to_string()
            } else {
                format!(
                    "refining {done}/{total}{}",
                    if refiner.divisor() > 1 {
                        format!(" (preview 1/{})", refiner.divisor())
                    } else {
                        String::new()
                    }
                )
            },
        )
        .to_lowercase()
    }

    /// The status strip's two lines.
    pub fn lines(&self) -> (String, String) {
        let render = match self.notice {
            Some(n) => format!("{}  {n}", self.render_line()),
            None => self.render_line(),
        };
        (self.focus_line(), render)
    }
}

/// The focus surface, named for the status strip (`None`: the single plane).
pub fn surface_label(state: &ViewerState) -> Option<String> {
    let choice = state.surface_choice();
    if choice.all_in_focus {
        return Some("all in focus".into());
    }
    if let Some(w) = choice.slab {
        return Some(format!("slab ±{w:.4}"));
    }
    match choice.kept().count() {
        0 => None,
        k => Some(format!("{} planes", k + 1)),
    }
}

/// `text` broken between words into lines of at most `chars` characters (a longer word is
/// cut), at most six lines.
pub fn wrap_words(text: &str, chars: usize) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        let word: String = word.chars().take(chars).collect();
        match out.last_mut() {
            Some(last) if last.chars().count() + 1 + word.chars().count() <= chars => {
                last.push(' ');
                last.push_str(&word);
            }
            _ => out.push(word),
        }
    }
    out.truncate(6);
    out
}

/// `line` broken between its fields (separated by two spaces) into lines of at most `chars`
/// characters; a field longer than that is cut.
pub fn wrap_fields(line: &str, chars: usize) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for field in line.split("  ").filter(|f| !f.is_empty()) {
        let field: String = field.chars().take(chars).collect();
        match out.last_mut() {
            Some(last) if last.chars().count() + 2 + field.chars().count() <= chars => {
                last.push_str("  ");
                last.push_str(&field);
            }
            _ => out.push(field),
        }
    }
    out
}

impl Hud {
    pub fn new(size: (u32, u32)) -> Self {
        Hud {
            canvas: Canvas::new(size.0, size.1),
            parts: Vec::new(),
            drawn_at: Instant::now(),
        }
    }

    /// Redraws the canvas for `layout`: status strip, message, click marks, help. Returns the
    /// status strip's second line (the window title shows it).
    pub fn draw(&mut self, layout: &Layout, status: &Status) -> String {
        let (w, h) = layout.window;
        if self.canvas.width != w || self.canvas.height != h {
            self.canvas = Canvas::new(w, h);
        }
        // Every redraw starts from a cleared canvas above the strip, so the parts are listed
        // anew: kept from earlier redraws they grew with every one (help shown: one more
        // copy of its box composited per redraw).
        self.parts.clear();
        let (l1, l2) = status.lines();
        let s = layout.status;
        // The strip is content too: without its part it was drawn but never composited.
        self.parts.push(s);
        self.canvas.fill(0, 0, w as i64, s.y as i64, CLEAR);
        self.canvas.fill(
            s.x as i64,
            s.y as i64,
            s.width as i64,
            s.height as i64,
            PANEL_BG,
        );
        // Twice the glyph size where the longer line fits, else the plain 8-pixel font, the
        // lines wrapped between their fields where even that is too wide (up to four lines of
        // 10 px fit the strip: an 800-px window shows everything).
        let longest = l1.chars().count().max(l2.chars().count()) as i64;
        let (scale, lines) = if longest * 16 + 16 <= w as i64 {
            (2, vec![l1, l2.clone()])
        } else {
            let chars = ((w as i64 - 16) / 8).max(8) as usize;
            let mut lines = wrap_fields(&l1, chars);
            lines.extend(wrap_fields(&l2, chars));
            (1, lines)
        };
        let step = 10 * scale as i64;
        if let Some(field) = status.highlight {
            let glyph = 8 * scale as i64;
            // The first line holding the field (a wrapped strip holds it once).
            let found = lines
                .iter()
                .enumerate()
                .find_map(|(k, l)| field_span(l, field.markers()).map(|span| (k, span)));
            if let Some((k, (at, len))) = found {
                self.canvas.fill(
                    8 + at as i64 * glyph - 2,
                    s.y as i64 + 4 + k as i64 * step - 2,
                    len as i64 * glyph + 4,
                    glyph + 3,
                    HIGHLIGHT,
                );
            }
        }
        for (k, line) in lines.iter().enumerate() {
            self.canvas
                .text(8, s.y as i64 + 4 + k as i64 * step, scale, line, TEXT);
        }
        let state = status.state;
        if let Some(msg) = &state.message {
            match status.message_at {
                Some(at) => self.message_at(layout, msg, at),
                None => self.message(layout, msg),
            }
        }
        // Focus peaking: what is in focus tinted magenta, half transparent (a colour that
        // photographs rarely have, readable over light and dark alike).
        if let Some(p) = status.peaks {
            let r = layout.refocus;
            let (x0, y0) = (r.x as i64, r.y as i64);
            for (i, _) in p.mask.iter().enumerate().filter(|(_, &b)| b) {
                let (x, y) = (
                    (i % p.size.0 as usize) as i64,
                    (i / p.size.0 as usize) as i64,
                );
                self.canvas.fill(x0 + x, y0 + y, 1, 1, PEAK);
            }
            self.parts.push(r);
        }
        // Marks of the three-click plane in progress (red), and of the one in effect (green).
        let size = (status.lf.width, status.lf.height);
        let pending = state.pending_clicks.iter().map(|p| (p, [255, 60, 40, 255]));
        let placed = state.placed_clicks.iter().map(|p| (p, [60, 220, 90, 255]));
        for (p, colour) in pending.chain(placed) {
            let at = layout.refocus_to_window(*p, size);
            self.canvas.cross(at.x, at.y, 6, colour);
            self.parts
                .push(Rect::new(at.x as f32 - 8.0, at.y as f32 - 8.0, 17.0, 17.0));
        }
        if let Some(panel) = status.panel {
            self.control_panel(panel, state, status.lf);
        }
        if state.show_help {
            self.help(layout);
        }
        self.drawn_at = Instant::now();
        l2
    }

    /// The message along the bottom of the refocus panel.
    fn message(&mut self, layout: &Layout, msg: &str) {
        let area = layout.refocus_area;
        let y = (area.y + area.height) as i64 - 22;
        let chars = ((area.width as i64 - 16) / 8).max(8) as usize;
        let text: String = msg.chars().take(chars).collect();
        self.canvas
            .fill(area.x as i64, y - 4, area.width as i64, 20, PANEL_BG);
        self.parts
            .push(Rect::new(area.x, (y - 4) as f32, area.width, 20.0));
        self.canvas.text(area.x as i64 + 8, y, 1, &text, WARN);
    }

    /// The message next to where the user clicked (below and right of it, kept inside the
    /// window above the strip), wrapped to lines of at most 56 characters.
    fn message_at(&mut self, layout: &Layout, msg: &str, at: DVec2) {
        let (w, _) = layout.window;
        let max_chars = (((w as i64 - 24) / 8).clamp(8, 56)) as usize;
        let lines = wrap_words(msg, max_chars);
        let box_w = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0) as i64 * 8 + 16;
        let box_h = lines.len() as i64 * 12 + 8;
        let bottom = layout.status.y as i64;
        let x = (at.x as i64 + 12).min(w as i64 - box_w).max(0);
        let mut y = at.y as i64 + 12;
        if y + box_h > bottom {
            // No room below the click: above it.
            y = (at.y as i64 - 12 - box_h).max(0);
        }
        self.canvas.fill(x, y, box_w, box_h, PANEL_BG);
        self.parts
            .push(Rect::new(x as f32, y as f32, box_w as f32, box_h as f32));
        for (k, line) in lines.iter().enumerate() {
            self.canvas
                .text(x + 8, y + 4 + k as i64 * 12, 1, line, WARN);
        }
    }

    /// The control panel: sliders (track, knob at the current value, the value) and buttons
    /// (lit when their setting is on).
    fn control_panel(&mut self, panel: &ControlPanel, state: &ViewerState, lf: &LightField) {
        let r = panel.rect;
        let (x0, y0) = (r.x as i64, r.y as i64);
        self.canvas
            .fill(x0, y0, r.width as i64, r.height as i64, PANEL_BG);
        self.parts.push(r);
        self.canvas
            .text(x0 + 8, y0 + 8, 1, "controls (Tab hides)", WARN);
        for (s, t) in &panel.sliders {
            let (tx, ty) = (t.x as i64, t.y as i64);
            self.canvas.text(x0 + 8, ty, 1, s.label(), TEXT);
            self.canvas
                .fill(tx, ty + 2, t.width as i64, 4, [80, 80, 92, 255]);
            let value = controls_panel::current(*s, state, lf);
            if let Some(v) = value {
                let f = panel.fraction_of(*s, v, lf);
                let kx = tx + (f * t.width as f64).round() as i64;
                self.canvas.fill(kx - 3, ty - 3, 7, 14, TEXT);
            }
            let text = match (s, value) {
                (_, None) => "-".to_string(),
                (Slider::Distance, Some(v)) => format!("{:.3}", shown(v, 3)),
                (Slider::Tilt | Slider::Swing, Some(v)) => format!("{:.1}°", shown(v, 1)),
                (_, Some(v)) => format!("{:.2}", shown(v, 2)),
            };
            self.canvas
                .text(tx + t.width as i64 + 12, ty, 1, &text, TEXT);
        }
        for (b, br) in &panel.buttons {
            let colour = if b.on(state) {
                [40, 100, 170, 255]
            } else {
                [55, 55, 66, 255]
            };
            let (bx, by, bw, bh) = (br.x as i64, br.y as i64, br.width as i64, br.height as i64);
            self.canvas.fill(bx, by, bw, bh, colour);
            let label = b.label(state);
            let lw = label.chars().count() as i64 * 8;
            self.canvas.text(
                bx + (bw - lw).max(0) / 2,
                by + (bh - 8) / 2,
                1,
                &label,
                TEXT,
            );
        }
    }

    /// Every control ([`help_box`]).
    fn help(&mut self, layout: &Layout) {
        let h = help_box(layout);
        self.canvas.fill(h.x, h.y, h.width, h.height, PANEL_BG);
        self.parts.push(Rect::new(
            h.x as f32,
            h.y as f32,
            h.width as f32,
            h.height as f32,
        ));
        self.canvas
            .text(h.x + 8, h.y + 6, 1, "controls (H hides)", WARN);
        let mut y = h.y + 6;
        for (key, what) in &h.lines {
            y += h.row;
            self.canvas.text(h.x + 8, y, 1, key, TEXT);
            for (i, line) in what.iter().enumerate() {
                if i > 0 {
                    y += h.row;
                }
                self.canvas.text(h.x + 8 + h.key_width, y, 1, line, TEXT);
            }
        }
    }
}

/// Where the help goes and its lines: over the scene panel, or over the whole window above the
/// strip where the panel leaves descriptions under [`HELP_MIN_CHARS`]; descriptions wrap
/// between words to the room there is, so no control is cut off at any window size (800 × 600
/// and up).
struct HelpBox {
    x: i64,
    y: i64,
    width: i64,
    height: i64,
    row: i64,
    key_width: i64,
    lines: Vec<(&'static str, Vec<String>)>,
}

fn help_box(layout: &Layout) -> HelpBox {
    let sc = layout.scene;
    let key_width = CONTROLS.iter().map(|(k, _)| k.len()).max().unwrap_or(0) as i64 * 8 + 16;
    let (area_x, area_w) = if (sc.width as i64 - 36 - key_width) / 8 >= HELP_MIN_CHARS {
        (sc.x as i64, sc.width as i64)
    } else {
        (0, layout.window.0 as i64)
    };
    let chars = ((area_w - 36 - key_width) / 8).max(8) as usize;
    let lines: Vec<(&'static str, Vec<String>)> = CONTROLS
        .iter()
        .map(|(k, w)| (*k, wrap_words(w, chars)))
        .collect();
    let what_w = lines
        .iter()
        .flat_map(|(_, w)| w.iter().map(|l| l.chars().count()))
        .max()
        .unwrap_or(0) as i64
        * 8;
    let rows = lines.iter().map(|(_, w)| w.len().max(1)).sum::<usize>() as i64 + 1;
    // 18-pixel rows where the panel is tall enough, closer (down to 10) where not, so every
    // control stays listed in a short window.
    let row = ((sc.height as i64 - 32) / rows).clamp(10, 18);
    HelpBox {
        x: area_x + 10,
        y: sc.y as i64 + 10,
        width: key_width + what_w + 16,
        height: rows * row + 12,
        row,
        key_width,
        lines,
    }
}

/// Focus peaking's tint.
const PEAK: [u8; 4] = [255, 0, 255, 150];

/// The narrowest column of descriptions the help wraps into over the scene panel (characters);
/// a narrower panel gets the help over the whole window.
const HELP_MIN_CHARS: i64 = 32;

/// `v` as the strip shows it to `decimals` places, without a negative zero ("swing -0.0°"
/// for a swing of -1e-17): rounded first, then `+ 0.0`, which turns -0.0 into 0.0.
fn shown(v: f64, decimals: i32) -> f64 {
    let f = 10f64.powi(decimals);
    (v * f).round() / f + 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viewer::refine::Refiner;
    use crate::viewer::state::Action;

    #[test]
    fn the_help_fits_every_window_from_800_by_600() {
        for (w, h) in [
            (800, 600),
            (1024, 768),
            (1280, 720),
            (1920, 1080),
            (3000, 900),
        ] {
            let layout = Layout::new(w, h, (512, 512));
            let b = help_box(&layout);
            assert!(
                b.x >= 0 && b.x + b.width <= w as i64,
                "{w}x{h}: {} + {}",
                b.x,
                b.width
            );
            assert!(
                b.y + b.height <= layout.status.y as i64,
                "{w}x{h}: the help runs into the strip"
            );
            let words: usize = b.lines.iter().map(|(_, l)| l.join(" ").len()).sum();
            let want: usize = CONTROLS.iter().map(|(_, w)| w.len()).sum();
            assert_eq!(words, want, "{w}x{h}: every description, whole");
        }
    }

    #[test]
    fn the_strip_shows_no_negative_zero() {
        assert_eq!(format!("{:.1}", shown(-0.0, 1)), "0.0");
        assert_eq!(format!("{:.1}", shown(-0.04, 1)), "0.0");
        assert_eq!(format!("{:.1}", shown(-0.06, 1)), "-0.1");
        assert_eq!(format!("{:.3}", shown(-1e-17, 3)), "0.000");
        assert_eq!(format!("{:.4}", shown(2.5, 4)), "2.5000");
    }

    #[test]
    fn the_changed_field_is_found_in_the_strip_and_messages_wrap_between_words() {
        let line = "aperture disk r=2.8 (25 of 25 views)  view (2.00, 2.00)  linear  aa 4x4";
        assert_eq!(field_span(line, Field::Aperture.markers()), Some((0, 36)));
        assert_eq!(field_span(line, Field::View.markers()), Some((38, 17)));
        assert_eq!(field_span(line, Field::Averaging.markers()), Some((57, 6)));
        assert_eq!(field_span(line, Field::Antialias.markers()), Some((65, 6)));
        assert_eq!(field_span(line, Field::Tilt.markers()), None);
        assert_eq!(Field::of(&Action::Tilt(1.0)), Some(Field::Tilt));
        assert_eq!(Field::of(&Action::Slab(0.02)), Some(Field::Surface));
        assert_eq!(Field::of(&Action::Zoom(1.0)), None);
        let w = wrap_words("no reliable normal at the clicked pixel (128, 200)", 20);
        assert!(w.iter().all(|l| l.chars().count() <= 20), "{w:?}");
        assert_eq!(
            w.join(" "),
            "no reliable normal at the clicked pixel (128, 200)"
        );
    }

    #[test]
    fn narrow_windows_wrap_the_status_between_fields_and_keep_every_field() {
        let line = "plane p=(0.000,0.000,2.500) n=(0,0,1)  distance 2.5000  tilt 0.0°  swing -0.0°";
        let wrapped = wrap_fields(line, 40);
        assert!(wrapped.len() >= 2, "{wrapped:?}");
        assert!(
            wrapped.iter().all(|l| l.chars().count() <= 40),
            "{wrapped:?}"
        );
        assert_eq!(wrapped.join("  "), line);
        assert_eq!(wrap_fields(line, 200), vec![line.to_string()]);
        // A field longer than the line is cut, never lost whole or overflowing.
        assert_eq!(wrap_fields("abcdefghij", 4), vec!["abcd".to_string()]);
    }

    #[test]
    fn the_strip_is_composited_and_redraws_do_not_grow_the_parts() {
        let lf = crate::synth::builtin("planes").unwrap().light_field(1);
        let mut state = crate::viewer::state::test_state(&lf, FocusSpec::Disparity(0.0));
        let refinement = Refinement::new(Refiner::new(33.0, 1 << 20), &state.plan);
        let layout = Layout::new(800, 600, (lf.width, lf.height));
        let mut hud = Hud::new(layout.window);
        let draw = |state: &ViewerState, hud: &mut Hud| {
            let status = Status {
                lf: &lf,
                state,
                refinement: &refinement,
                depth: &DepthState::Ready,
                fps: 30.0,
                highlight: None,
                message_at: None,
                panel: None,
                cursor: Some("cursor: z 2.000 (given)"),
                notice: None,
                peaks: None,
            };
            hud.draw(&layout, &status);
            hud.parts.clone()
        };
        let plain = draw(&state, &mut hud);
        assert!(plain.contains(&layout.status), "strip missing: {plain:?}");
        state.apply(&lf, Action::ToggleHelp);
        let with_help = draw(&state, &mut hud);
        assert_eq!(with_help.len(), plain.len() + 1, "help adds one box");
        for _ in 0..40 {
            assert_eq!(
                draw(&state, &mut hud),
                with_help,
                "redraws repeat, never grow"
            );
        }
        state.apply(&lf, Action::ToggleHelp);
        assert_eq!(
            draw(&state, &mut hud),
            plain,
            "hidden help is no longer composited"
        );
    }
}
