//! Viewer scripts (`view --script FILE`): one command per line, `#` starts a comment.
//!
//! ```text
//! wait SECONDS                    wall-clock pause (frames keep rendering)
//! wait-converged                  until refinement reached the full aperture at full size
//!                                 (and depth being estimated in the background arrived)
//! key NAME [COUNT]                press and release a key COUNT times, one press per frame
//!                                 (GLFW names: UP, W, LEFT_BRACKET, …; shift+UP for Shift,
//!                                 ctrl+Z for Control: ctrl+Z undo, ctrl+shift+Z redo)
//! click refocus U V               single-click plane at pixel (U, V) of the depth view — the
//!                                 pixels `render --click U,V` takes, not window pixels; clicks
//!                                 wait for depth being estimated in the background
//! shift-click refocus U V         one of three clicks (as `render --points`)
//! click scene X Y                 pick the cloud point under scene-panel pixel (X, Y)
//! drag scene X0 Y0 X1 Y1          left-drag in the scene panel (orbit)
//! click window X Y                a left click at window pixel (X, Y), as the mouse gives it
//!                                 (the control panel's buttons and sliders, or a panel)
//! drag window X0 Y0 X1 Y1         a left drag between window pixels (a control panel slider)
//! scroll refocus|scene DY         scroll DY steps (refocus: disparity; scene: zoom)
//! resize W H                      resize the window
//! screenshot PREFIX               write PREFIX_refocus.png, PREFIX_scene.png, PREFIX_window.png
//! quit                            close the viewer
//! ```
//!
//! A script is parsed and checked completely before the window opens: unknown commands, bad
//! numbers, pixels outside their panel (given the window size at that line), screenshots that
//! could not be written, and scripts that would run for too long (more than [`MAX_PRESSES`]
//! key presses, each one frame, or [`MAX_WAIT_S`] seconds of waiting in all) are errors naming
//! the line. A leading UTF-8 byte-order mark is ignored. While the window is open a [`Runner`]
//! hands out the commands, holding them back while a `wait` or `wait-converged` line is in
//! effect.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use glfw::Key;

use super::controls::key_from_name;
use super::layout::Layout;
use crate::error::{Error, Result};

/// Most presses of one `key` line. Each press takes one rendered frame (a fraction of a second
/// to seconds on a software renderer), so this bounds one line to minutes at worst.
pub const MAX_COUNT: u32 = 500;
/// Most key presses in a whole script.
pub const MAX_PRESSES: u32 = 2_000;
/// Longest `wait`, and longest total of all waits of a script, seconds.
pub const MAX_WAIT_S: f64 = 3600.0;
/// Window sizes a script may ask for.
pub const WINDOW_SIZES: std::ops::RangeInclusive<u32> = 64..=8192;

/// Which panel a pointer command addresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Panel {
    Refocus,
    Scene,
}

/// One script command.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    Wait(f64),
    WaitConverged,
    Key {
        key: Key,
        shift: bool,
        /// Control held (`ctrl+Z`: undo).
        ctrl: bool,
        count: u32,
    },
    /// Refocus panel: depth-view pixels; scene panel: panel pixels.
    Click {
        panel: Panel,
        x: f64,
        y: f64,
        shift: bool,
    },
    Drag {
        from: (f64, f64),
        to: (f64, f64),
    },
    /// A left press at window pixel `from`, moved to `to` and released there (`from == to`:
    /// a click), through the same handlers as the mouse.
    Pointer {
        from: (f64, f64),
        to: (f64, f64),
    },
    Scroll {
        panel: Panel,
        dy: f64,
    },
    Resize(u32, u32),
    Screenshot(PathBuf),
    Quit,
}

/// A command with its 1-based line number.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    pub number: usize,
    pub command: Command,
}

/// A script being run: the lines left and what the current one waits for.
#[derive(Debug, Default)]
pub struct Runner {
    lines: VecDeque<Line>,
    /// A `wait` line in effect until then.
    wait_until: Option<Instant>,
    /// A `wait-converged` line in effect.
    wait_converged: bool,
}

impl Runner {
    pub fn new(lines: &[Line]) -> Self {
        Runner {
            lines: lines.iter().cloned().collect(),
            ..Runner::default()
        }
    }

    /// The next command to run now, or `None` while the script waits (or has ended). `wait`
    /// and `wait-converged` lines are taken here; `converged` says whether the image is final.
    /// Clicks wait while `depth_ready` is false (depth still estimated in the background), as
    /// a user would, so a script's clicks land on the same depth every run.
    pub fn next(&mut self, converged: impl Fn() -> bool, depth_ready: bool) -> Option<Line> {
        loop {
            if let Some(t) = self.wait_until {
                if Instant::now() < t {
                    return None;
                }
                self.wait_until = None;
            }
            if self.wait_converged {
                if !converged() {
                    return None;
                }
                self.wait_converged = false;
            }
            if !depth_ready && matches!(self.lines.front()?.command, Command::Click { .. }) {
                return None;
            }
            let line = self.lines.pop_front()?;
            match line.command {
                Command::Wait(sec) => {
                    self.wait_until = Some(Instant::now() + Duration::from_secs_f64(sec))
                }
                Command::WaitConverged => self.wait_converged = true,
                _ => return Some(line),
            }
            log::debug!("script line {} done", line.number);
        }
    }

    /// When a `wait` line ends, if one is in effect.
    pub fn wakes_at(&self) -> Option<Instant> {
        self.wait_until
    }

    /// No line is left and none waits for convergence (input alone drives the window).
    pub fn finished(&self) -> bool {
        self.lines.is_empty() && !self.wait_converged
    }
}

/// Reads and parses a script file (a regular file: a FIFO or device given as `--script` is
/// refused, not waited on), and checks that its screenshots can be written.
pub fn load(path: &Path) -> Result<Vec<Line>> {
    let text = crate::io::read_text(path, "the --script file")?;
    let lines = parse(&text).map_err(|e| Error::bad_file(path, e))?;
    for line in &lines {
        if let Command::Screenshot(prefix) = &line.command {
            check_screenshot_prefix(prefix).map_err(|e| {
                Error::bad_file(path, format!("line {}: screenshot {e}", line.number))
            })?;
        }
    }
    Ok(lines)
}

/// The files a screenshot with `prefix` writes.
pub fn screenshot_files(prefix: &Path) -> Vec<PathBuf> {
    ["_refocus.png", "_scene.png", "_window.png", ".json"]
        .iter()
        .map(|suffix| {
            let mut s = prefix.as_os_str().to_owned();
            s.push(suffix);
            PathBuf::from(s)
        })
        .collect()
}

/// Checks before the window opens that screenshots with `prefix` can be written: the prefix
/// does not name a device, FIFO or socket (`screenshot /dev/full` would write next to the
/// device), and every file it writes passes [`crate::io::check_writable`].
pub fn check_screenshot_prefix(prefix: &Path) -> std::result::Result<(), String> {
    if let Ok(m) = std::fs::metadata(prefix) {
        if !m.is_file() && !m.is_dir() {
            return Err(format!(
                "{}: the prefix names {}; give a path prefix such as shots/a",
                prefix.display(),
                crate::io::kind_of(&m)
            ));
        }
    }
    for file in screenshot_files(prefix) {
        crate::io::check_writable(&file).map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Parses script text; the error names the line.
pub fn parse(text: &str) -> std::result::Result<Vec<Line>, String> {
    // Editors on Windows start files with a byte-order mark; it is not part of a command.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = Vec::new();
    let (mut presses, mut waited) = (0u32, 0.0f64);
    for (i, raw) in text.lines().enumerate() {
        let number = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let command = parse_line(line).map_err(|e| format!("line {number}: {e} ('{line}')"))?;
        match command {
            Command::Key { count, .. } => {
                presses = presses.saturating_add(count);
                if presses > MAX_PRESSES {
                    return Err(format!(
                        "line {number}: the script presses keys {presses} times by here, more \
                         than the {MAX_PRESSES} a script may (each press renders a frame)"
                    ));
                }
            }
            Command::Wait(s) => {
                waited += s;
                if waited > MAX_WAIT_S {
                    return Err(format!(
                        "line {number}: the script waits {waited} s by here, more than the \
                         {MAX_WAIT_S} s a script may"
                    ));
                }
            }
            _ => {}
        }
        out.push(Line { number, command });
    }
    Ok(out)
}

fn number(word: Option<&str>, what: &str) -> std::result::Result<f64, String> {
    let word = word.ok_or_else(|| format!("missing {what}"))?;
    let v: f64 = word
        .parse()
        .map_err(|_| format!("{what} must be a number, got '{word}'"))?;
    if !v.is_finite() {
        return Err(format!("{what} must be finite, got '{word}'"));
    }
    Ok(v)
}

fn whole(word: Option<&str>, what: &str) -> std::result::Result<u32, String> {
    let word = word.ok_or_else(|| format!("missing {what}"))?;
    word.parse()
        .map_err(|_| format!("{what} must be a whole number ≥ 0, got '{word}'"))
}

fn panel(word: Option<&str>) -> std::result::Result<Panel, String> {
    match word {
        Some("refocus") => Ok(Panel::Refocus),
        Some("scene") => Ok(Panel::Scene),
        Some(w) => Err(format!("unknown panel '{w}': expected refocus or scene")),
        None => Err("missing panel (refocus or scene)".into()),
    }
}

fn parse_line(line: &str) -> std::result::Result<Command, String> {
    let mut words = line.split_whitespace();
    let name = words.next().unwrap_or("");
    let command = match name {
        "wait" => {
            let s = number(words.next(), "seconds")?;
            if !(0.0..=MAX_WAIT_S).contains(&s) {
                return Err(format!("wait takes 0 to {MAX_WAIT_S} seconds, got {s}"));
            }
            Command::Wait(s)
        }
        "wait-converged" => Command::WaitConverged,
        "key" => {
            let spec = words.next().ok_or("missing key name")?;
            // Modifiers in any order before the key: shift+, ctrl+ (ctrl+shift+Z: redo).
            let (mut shift, mut ctrl, mut name) = (false, false, spec);
            loop {
                let lower = name.to_ascii_lowercase();
                if lower.starts_with("shift+") && !shift {
                    shift = true;
                    name = &name[6..];
                } else if lower.starts_with("ctrl+") && !ctrl {
                    ctrl = true;
                    name = &name[5..];
                } else {
                    break;
                }
            }
            let key = key_from_name(name).ok_or_else(|| format!("unknown key '{name}'"))?;
            let count = match words.next() {
                Some(w) => whole(Some(w), "count")?,
                None => 1,
            };
            if count == 0 || count > MAX_COUNT {
                return Err(format!("count must be 1 to {MAX_COUNT}, got {count}"));
            }
            Command::Key {
                key,
                shift,
                ctrl,
                count,
            }
        }
        "click" | "drag" if line.split_whitespace().nth(1) == Some("window") => {
            words.next();
            let n = if name == "click" { 2 } else { 4 };
            let v: Vec<f64> = ["x0", "y0", "x1", "y1"][..n]
                .iter()
                .map(|w| number(words.next(), w))
                .collect::<std::result::Result<_, _>>()?;
            let from = (v[0], v[1]);
            let to = if n == 2 { from } else { (v[2], v[3]) };
            Command::Pointer { from, to }
        }
        "click" | "shift-click" => {
            let panel = panel(words.next())?;
            let shift = name == "shift-click";
            if shift && panel == Panel::Scene {
                return Err(
                    "shift-click is for the refocus panel; scene picks are plain clicks".into(),
                );
            }
            let x = number(words.next(), "x")?;
            let y = number(words.next(), "y")?;
            Command::Click { panel, x, y, shift }
        }
        "drag" => {
            if panel(words.next())? != Panel::Scene {
                return Err("drag works in the scene panel".into());
            }
            let v: Vec<f64> = ["x0", "y0", "x1", "y1"]
                .iter()
                .map(|w| number(words.next(), w))
                .collect::<std::result::Result<_, _>>()?;
            Command::Drag {
                from: (v[0], v[1]),
                to: (v[2], v[3]),
            }
        }
        "scroll" => {
            let panel = panel(words.next())?;
            let dy = number(words.next(), "dy")?;
            if dy.abs() > 1000.0 {
                return Err(format!("scroll takes -1000 to 1000 steps, got {dy}"));
            }
            Command::Scroll { panel, dy }
        }
        "resize" => {
            let w = whole(words.next(), "width")?;
            let h = whole(words.next(), "height")?;
            for v in [w, h] {
                if !WINDOW_SIZES.contains(&v) {
                    return Err(format!(
                        "window sizes must be {} to {} pixels, got {w}×{h}",
                        WINDOW_SIZES.start(),
                        WINDOW_SIZES.end()
                    ));
                }
            }
            Command::Resize(w, h)
        }
        "screenshot" => {
            let prefix = words.next().ok_or("missing file prefix")?;
            Command::Screenshot(PathBuf::from(prefix))
        }
        "quit" => Command::Quit,
        "" => return Err("empty command".into()),
        other => {
            return Err(format!(
                "unknown command '{other}' (expected wait, wait-converged, key, click, \
                 shift-click, drag, scroll, resize, screenshot or quit)"
            ))
        }
    };
    if let Some(extra) = words.next() {
        return Err(format!("unexpected '{extra}' at the end"));
    }
    Ok(command)
}

/// Checks pointer positions against the panels: refocus pixels inside the `view` size
/// (width, height of the depth view), scene pixels inside the scene panel of the window size
/// in effect at that line (`window` initially, then each `resize`).
pub fn check(
    lines: &[Line],
    view: (u32, u32),
    window: (u32, u32),
) -> std::result::Result<(), String> {
    let mut window = window;
    for line in lines {
        let scene = Layout::new(window.0, window.1, view).scene;
        let inside_scene = |x: f64, y: f64| {
            x >= 0.0 && y >= 0.0 && x < scene.width as f64 && y < scene.height as f64
        };
        match &line.command {
            Command::Resize(w, h) => window = (*w, *h),
            Command::Click {
                panel: Panel::Refocus,
                x,
                y,
                ..
            } if !(*x >= 0.0
                && *y >= 0.0
                && *x <= view.0 as f64 - 1.0
                && *y <= view.1 as f64 - 1.0) =>
            {
                return Err(format!(
                    "line {}: refocus pixel ({x}, {y}) is outside the {}×{} view (pixels 0 to \
                     {} and 0 to {})",
                    line.number,
                    view.0,
                    view.1,
                    view.0 - 1,
                    view.1 - 1
                ));
            }
            Command::Click {
                panel: Panel::Scene,
                x,
                y,
                ..
            } if !inside_scene(*x, *y) => {
                return Err(scene_error(line.number, *x, *y, &scene));
            }
            Command::Drag { from, to } => {
                for (x, y) in [from, to] {
                    if !inside_scene(*x, *y) {
                        return Err(scene_error(line.number, *x, *y, &scene));
                    }
                }
            }
            Command::Pointer { from, to } => {
                for (x, y) in [from, to] {
                    if !(*x >= 0.0 && *y >= 0.0 && *x < window.0 as f64 && *y < window.1 as f64) {
                        return Err(format!(
                            "line {}: window pixel ({x}, {y}) is outside the {}×{} window",
                            line.number, window.0, window.1
                        ));
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

fn scene_error(line: usize, x: f64, y: f64, scene: &crate::passes::panel::Rect) -> String {
    format!(
        "line {line}: scene pixel ({x}, {y}) is outside the scene panel ({}×{} pixels at this \
         window size)",
        scene.width, scene.height
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_clicks_and_drags_parse_and_stay_inside_the_window() {
        let lines = parse("click window 700 40\ndrag window 10 20 30 40\n").unwrap();
        assert_eq!(
            lines[0].command,
            Command::Pointer {
                from: (700.0, 40.0),
                to: (700.0, 40.0)
            }
        );
        assert_eq!(
            lines[1].command,
            Command::Pointer {
                from: (10.0, 20.0),
                to: (30.0, 40.0)
            }
        );
        assert!(check(&lines, (64, 64), (800, 600)).is_ok());
        let e = check(&lines, (64, 64), (640, 400)).unwrap_err();
        assert!(
            e.contains("line 1") && e.contains("outside the 640×400 window"),
            "{e}"
        );
        assert!(parse("drag window 1 2 3\n").is_err());
    }

    #[test]
    fn clicks_wait_for_depth_and_keys_do_not() {
        let lines = parse("key UP\nclick refocus 1 2\nkey DOWN\n").unwrap();
        let mut r = Runner::new(&lines);
        assert_eq!(r.next(|| true, false).unwrap().number, 1);
        // Depth is still being estimated: the click and everything after it wait.
        assert!(r.next(|| true, false).is_none());
        assert!(!r.finished());
        assert_eq!(r.next(|| true, true).unwrap().number, 2);
        assert_eq!(r.next(|| true, false).unwrap().number, 3);
        assert!(r.next(|| true, true).is_none() && r.finished());
    }

    #[test]
    fn parses_every_command() {
        let text =
            "# a comment\n\nwait 0.5\nwait-converged\nkey UP\nkey shift+LEFT_BRACKET 3 # fine\n\
                    key ctrl+shift+Z\nkey Shift+Ctrl+z 2\n\
                    click refocus 10 20\nshift-click refocus 1.5 2\nclick scene 3 4\n\
                    drag scene 1 2 3 4\nscroll refocus -2\nscroll scene 1.5\nresize 800 600\n\
                    screenshot out/a\nquit\n";
        let lines = parse(text).unwrap();
        let commands: Vec<_> = lines.iter().map(|l| l.command.clone()).collect();
        assert_eq!(lines[0].number, 3);
        assert_eq!(
            commands,
            vec![
                Command::Wait(0.5),
                Command::WaitConverged,
                Command::Key {
                    key: Key::Up,
                    shift: false,
                    ctrl: false,
                    count: 1
                },
                Command::Key {
                    key: Key::LeftBracket,
                    shift: true,
                    ctrl: false,
                    count: 3
                },
                Command::Key {
                    key: Key::Z,
                    shift: true,
                    ctrl: true,
                    count: 1
                },
                Command::Key {
                    key: Key::Z,
                    shift: true,
                    ctrl: true,
                    count: 2
                },
                Command::Click {
                    panel: Panel::Refocus,
                    x: 10.0,
                    y: 20.0,
                    shift: false
                },
                Command::Click {
                    panel: Panel::Refocus,
                    x: 1.5,
                    y: 2.0,
                    shift: true
                },
                Command::Click {
                    panel: Panel::Scene,
                    x: 3.0,
                    y: 4.0,
                    shift: false
                },
                Command::Drag {
                    from: (1.0, 2.0),
                    to: (3.0, 4.0)
                },
                Command::Scroll {
                    panel: Panel::Refocus,
                    dy: -2.0
                },
                Command::Scroll {
                    panel: Panel::Scene,
                    dy: 1.5
                },
                Command::Resize(800, 600),
                Command::Screenshot(PathBuf::from("out/a")),
                Command::Quit,
            ]
        );
    }

    #[test]
    fn bad_lines_name_the_line_and_the_cause() {
        for (text, needle) in [
            ("jump 3", "unknown command 'jump'"),
            ("wait", "missing seconds"),
            ("wait x", "must be a number"),
            ("wait -1", "0 to 3600"),
            ("wait inf", "finite"),
            ("key", "missing key name"),
            ("key FOO", "unknown key 'FOO'"),
            ("key UP 0", "count must be 1"),
            ("key UP 99999", "count must be 1"),
            ("key UP 2 3", "unexpected '3'"),
            ("click", "missing panel"),
            ("click desk 1 2", "unknown panel 'desk'"),
            ("click refocus 1", "missing y"),
            ("shift-click scene 1 2", "refocus panel"),
            ("drag refocus 1 2 3 4", "scene panel"),
            ("scroll scene 5000", "-1000 to 1000"),
            ("resize 10 10", "64 to 8192"),
            ("resize 800", "missing height"),
            ("screenshot", "missing file prefix"),
        ] {
            let err = parse(&format!("wait 0\n{text}\n")).unwrap_err();
            assert!(err.starts_with("line 2:"), "{text}: {err}");
            assert!(err.contains(needle), "{text}: {err}");
        }
    }

    #[test]
    fn pixels_outside_their_panel_are_refused_with_the_line() {
        let view = (64, 48);
        let ok = parse("click refocus 63 47\nclick scene 1 1\n").unwrap();
        check(&ok, view, (1000, 500)).unwrap();
        let err = check(
            &parse("wait 0\nclick refocus 64 10\n").unwrap(),
            view,
            (1000, 500),
        )
        .unwrap_err();
        assert!(
            err.starts_with("line 2:") && err.contains("outside the 64×48 view"),
            "{err}"
        );
        let err = check(&parse("click scene 5000 1\n").unwrap(), view, (1000, 500)).unwrap_err();
        assert!(err.contains("outside the scene panel"), "{err}");
        // After a resize the scene panel is smaller: the same pixel becomes invalid.
        let scene = Layout::new(1000, 500, view).scene;
        let text = format!(
            "click scene {x} 10\nresize 200 200\nclick scene {x} 10\n",
            x = scene.width - 5.0
        );
        let err = check(&parse(&text).unwrap(), view, (1000, 500)).unwrap_err();
        assert!(err.starts_with("line 3:"), "{err}");
    }
}
