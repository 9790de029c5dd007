//! The on-screen text, drawn on the CPU into a window-size [`Canvas`] that the compositor
//! blends over the panels: the two-line status strip (focus, frame; aperture, viewpoint,
//! averaging, GPU time, frame rate, refinement progress), the last message, the marks of a
//! three-click plane in progress and the help. Only the parts with content
//! ([`Hud::parts`]) are composited.

use std::time::Instant;

use super::super::controls::CONTROLS;
use super::super::layout::Layout;
use super::super::state::{effective_radius, ViewerState};
use super::super::text::{Canvas, CLEAR, PANEL_BG, TEXT, WARN};
use super::depth::DepthState;
use super::refinement::Refinement;
use crate::geometry::picking::KeyboardPlane;
use crate::lightfield::LightField;
use crate::passes::panel::Rect;
use crate::refocus::FocusSpec;

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
                .map_or(String::new(), |f| format!("  {f}"))
        )
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
        (self.focus_line(), self.render_line())
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
        for (k, line) in lines.iter().enumerate() {
            self.canvas
                .text(8, s.y as i64 + 4 + k as i64 * step, scale, line, TEXT);
        }
        let state = status.state;
        if let Some(msg) = &state.message {
            self.message(layout, msg);
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

    /// Every control, over the scene panel.
    fn help(&mut self, layout: &Layout) {
        let sc = layout.scene;
        let (x0, y0) = (sc.x as i64 + 10, sc.y as i64 + 10);
        let rows = CONTROLS.len() as i64 + 1;
        let key_w = CONTROLS.iter().map(|(k, _)| k.len()).max().unwrap_or(0) as i64 * 8 + 16;
        let what_w = CONTROLS.iter().map(|(_, w)| w.len()).max().unwrap_or(0) as i64 * 8;
        self.canvas
            .fill(x0, y0, key_w + what_w + 16, rows * 18 + 12, PANEL_BG);
        self.parts.push(Rect::new(
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::aperture::Aperture;
    use crate::refocus::Averaging;
    use crate::viewer::refine::Refiner;
    use crate::viewer::state::Action;

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
        let mut state = ViewerState::new(
            &lf,
            FocusSpec::Disparity(0.0).into(),
            Aperture::default(),
            None,
            Averaging::Linear,
            Vec::new(),
        )
        .unwrap();
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
