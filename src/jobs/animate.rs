//! Animations of one light field (`tiltfield animate`, Python's `LightField.animate`): a focus
//! pull, a tilt or swing sweep, an aperture opening, or the viewpoint circling inside the
//! aperture, rendered with one GPU set-up and one upload and written as an animated PNG, a GIF
//! or an H.264 MP4 ([`encode`]).
//!
//! An animation is a base render request ([`RenderOptions`], every `render` option) and one
//! motion ([`Motion`]) that changes one thing of it from frame to frame. Each frame is exactly
//! a render: its [`RenderOptions`] go through the same [`Session`] the Python module renders
//! with, so every frame is byte for byte what `tiltfield render` writes for its state, and the
//! views are uploaded (and any depth estimated) once for all frames.

pub mod encode;

use std::time::Instant;

use glam::DVec2;
use image::RgbaImage;
use indicatif::ProgressBar;

use crate::error::{Error, Result};
use crate::geometry::rig::GridSize;
use crate::jobs::refocus::GpuImage;
use crate::jobs::render::{Prepared, RenderOptions, Session};
use crate::refocus::options::FocusOptions;

/// Most frames of an animation: every frame is held for encoding (and for `--bounce`), and a
/// longer piece is a video, which `render --frames` writes frame by frame.
pub const MAX_FRAMES: usize = 10_000;

/// What a sweep changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepKey {
    /// `--disparity`: a focus pull on frontoparallel planes.
    Disparity,
    /// `--focus`: the distance of the keyboard plane (turned by `--tilt`/`--swing`).
    Focus,
    /// `--tilt` of the `--focus` plane, degrees.
    Tilt,
    /// `--swing` of the `--focus` plane, degrees.
    Swing,
    /// `--aperture-radius`, grid steps.
    ApertureRadius,
}

impl SweepKey {
    /// Every key with its spelling, for parsing and messages.
    const ALL: [(SweepKey, &'static str); 5] = [
        (SweepKey::Disparity, "disparity"),
        (SweepKey::Focus, "focus"),
        (SweepKey::Tilt, "tilt"),
        (SweepKey::Swing, "swing"),
        (SweepKey::ApertureRadius, "aperture-radius"),
    ];

    /// The key's spelling (`aperture-radius`).
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(k, _)| *k == self)
            .map_or("", |(_, n)| n)
    }

    /// The key of `text` (as `--sweep` spells it; `aperture_radius` too, Python's spelling).
    pub fn parse(text: &str) -> Result<Self> {
        let wanted = text.trim().replace('_', "-");
        Self::ALL
            .iter()
            .find(|(_, n)| *n == wanted)
            .map(|(k, _)| *k)
            .ok_or_else(|| {
                Error::Invalid(format!(
                    "--sweep: unknown key '{text}'; sweep one of {}",
                    Self::ALL.map(|(_, n)| n).join(", ")
                ))
            })
    }
}

/// How the frames differ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// One option from `from` to `to`, evenly and inclusive (`from > to` runs backwards).
    Sweep { key: SweepKey, from: f64, to: f64 },
    /// The reference view on a circle of `radius` grid steps around the grid centre, frame k
    /// at angle 2πk/N from the +s (column) axis towards +t (rows, downwards).
    Orbit { radius: f64 },
}

impl Motion {
    /// A sweep from `--sweep KEY=A..B`.
    pub fn parse_sweep(text: &str) -> Result<Self> {
        let malformed = |why: &str| {
            Error::Invalid(format!(
                "--sweep '{text}': {why}; expected KEY=A..B, e.g. disparity=-1.5..1.5"
            ))
        };
        let (key, range) = text.split_once('=').ok_or_else(|| malformed("no '='"))?;
        let key = SweepKey::parse(key)?;
        let (a, b) = range
            .split_once("..")
            .ok_or_else(|| malformed("no '..' between the two values"))?;
        // "1...2" would otherwise read as 1 to .2.
        if b.starts_with('.') {
            return Err(malformed("one '..' between two numbers"));
        }
        let number = |s: &str| {
            s.trim()
                .parse::<f64>()
                .map_err(|_| malformed(&format!("'{s}' is not a number")))
        };
        Self::sweep(key, number(a)?, number(b)?)
    }

    /// A sweep of `key` from `from` to `to` (checked: both finite).
    pub fn sweep(key: SweepKey, from: f64, to: f64) -> Result<Self> {
        if !(from.is_finite() && to.is_finite()) {
            return Err(Error::Invalid(format!(
                "--sweep {}={from}..{to}: both ends must be finite numbers",
                key.name()
            )));
        }
        Ok(Motion::Sweep { key, from, to })
    }

    /// An orbit of `radius` grid steps (checked: positive and finite; against the grid by
    /// [`Animation::states`]).
    pub fn orbit(radius: f64) -> Result<Self> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(Error::Invalid(format!(
                "--orbit {radius}: the radius must be a positive number of grid steps"
            )));
        }
        Ok(Motion::Orbit { radius })
    }

    /// How the motion reads in messages and reports (`disparity=-1.5..1.5`, `orbit 2`).
    pub fn describe(&self) -> String {
        match self {
            Motion::Sweep { key, from, to } => format!("{}={from}..{to}", key.name()),
            Motion::Orbit { radius } => format!("orbit {radius}"),
        }
    }
}

/// An animation: the motion over `frames` rendered frames, played forward (and backward with
/// `bounce`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Animation {
    pub motion: Motion,
    pub frames: usize,
    /// Play forward then backward, without repeating the end frames (a seamless loop).
    pub bounce: bool,
}

/// One frame's state: the swept value (or the orbit's view) and the render request.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameState {
    /// The swept value; for an orbit, the angle in degrees.
    pub value: f64,
    /// The reference view of an orbit's frame.
    pub view: Option<DVec2>,
    pub options: RenderOptions,
}

impl Animation {
    /// An animation of `frames` frames (checked: 1 to [`MAX_FRAMES`]).
    pub fn new(motion: Motion, frames: usize, bounce: bool) -> Result<Self> {
        if frames == 0 || frames > MAX_FRAMES {
            return Err(Error::Invalid(format!(
                "--frames {frames}: an animation has 1 to {MAX_FRAMES} frames"
            )));
        }
        Ok(Animation {
            motion,
            frames,
            bounce,
        })
    }

    /// The frames in playback order, as indices of the rendered frames: 0..N, then with
    /// `bounce` back through N−2..1 (the ends are not shown twice, so the loop is seamless).
    pub fn order(&self) -> Vec<usize> {
        let n = self.frames;
        let mut order: Vec<usize> = (0..n).collect();
        if self.bounce && n > 2 {
            order.extend((1..n - 1).rev());
        }
        order
    }

    /// The value of frame `k` of a sweep from `from` to `to`: evenly spaced, both ends
    /// included exactly.
    fn value(&self, from: f64, to: f64, k: usize) -> f64 {
        match (self.frames, k) {
            (1, _) | (_, 0) => from,
            (n, k) if k + 1 == n => to,
            (n, k) => from + (to - from) * (k as f64 / (n - 1) as f64),
        }
    }

    /// Every frame's render request: `base` with the motion applied. Checks the combination
    /// (a sweep's option is not also given; tilt, swing and orbit need a focus) and every
    /// frame's focus and aperture, so a bad value fails before anything is rendered; an orbit
    /// is checked against `grid` when given (the light field's, once loaded).
    pub fn states(&self, base: &RenderOptions, grid: Option<GridSize>) -> Result<Vec<FrameState>> {
        let motion = self.motion.describe();
        let given = focus_given(&base.focus);
        let conflict = |what: &str, option: &str| {
            Err(Error::Invalid(format!(
                "--sweep {motion} sets {what} of every frame: drop {option}"
            )))
        };
        match self.motion {
            Motion::Sweep { key, .. } => match key {
                SweepKey::Disparity | SweepKey::Focus => {
                    if let Some(other) = given.first() {
                        return conflict("the focus", other);
                    }
                    if key == SweepKey::Disparity
                        && !(base.focus.tilt.is_empty() && base.focus.swing.is_empty())
                    {
                        return Err(Error::Invalid(format!(
                            "--sweep {motion}: --tilt and --swing turn a --focus plane; sweep \
                             focus=A..B to turn it"
                        )));
                    }
                }
                SweepKey::Tilt | SweepKey::Swing => {
                    let own = if key == SweepKey::Tilt {
                        &base.focus.tilt
                    } else {
                        &base.focus.swing
                    };
                    if !own.is_empty() {
                        let option = format!("--{}", key.name());
                        return conflict(&option, &option);
                    }
                    if given != ["--focus"] || base.focus.focus.len() != 1 {
                        return Err(Error::Invalid(format!(
                            "--sweep {motion} turns the keyboard plane: give one --focus Z (its \
                             distance along the reference optical axis){}",
                            match given.as_slice() {
                                [] | ["--focus"] => String::new(),
                                other => format!(", not {}", other.join(" or ")),
                            }
                        )));
                    }
                }
                SweepKey::ApertureRadius => {
                    if base.aperture.radius.is_some() {
                        return conflict("the aperture radius", "--aperture-radius");
                    }
                    base.focus.validate()?;
                }
            },
            Motion::Orbit { radius } => {
                if given.is_empty() {
                    return Err(Error::Invalid(format!(
                        "--orbit {radius} moves the viewpoint around a fixed focus: give one of \
                         --disparity, --plane, --focus, --click, --points or --points-3d"
                    )));
                }
                base.focus.validate()?;
                if base.reference.is_some() {
                    return Err(Error::Invalid(format!(
                        "--orbit {radius} circles the grid centre: drop --view"
                    )));
                }
                if let Some(grid) = grid {
                    let c = grid.centre();
                    let most = c.x.min(c.y);
                    if radius > most {
                        return Err(Error::Invalid(format!(
                            "--orbit {radius}: the circle leaves the {}×{} grid; at most {most} \
                             grid steps around its centre ({}, {})",
                            grid.cols, grid.rows, c.x, c.y
                        )));
                    }
                }
            }
        }
        (0..self.frames)
            .map(|k| {
                let state = self.state(base, grid, k);
                state
                    .options
                    .focus
                    .validate()
                    .and_then(|()| state.options.aperture.validate())
                    .and_then(|()| state.options.check().map(|_| ()))
                    .map_err(|e| frame_error(k, self.frames, &state, e))?;
                Ok(state)
            })
            .collect()
    }

    /// Frame `k` of `base` (unchecked).
    fn state(&self, base: &RenderOptions, grid: Option<GridSize>, k: usize) -> FrameState {
        let mut options = base.clone();
        match self.motion {
            Motion::Sweep { key, from, to } => {
                let v = self.value(from, to, k);
                match key {
                    SweepKey::Disparity => options.focus.disparity = vec![v],
                    SweepKey::Focus => options.focus.focus = vec![v],
                    SweepKey::Tilt => options.focus.tilt = vec![v],
                    SweepKey::Swing => options.focus.swing = vec![v],
                    SweepKey::ApertureRadius => options.aperture.radius = Some(v),
                }
                FrameState {
                    value: v,
                    view: None,
                    options,
                }
            }
            Motion::Orbit { radius } => {
                let theta = std::f64::consts::TAU * k as f64 / self.frames as f64;
                let centre = grid.map_or(DVec2::ZERO, |g| g.centre());
                let view = centre + radius * DVec2::new(theta.cos(), theta.sin());
                options.reference = Some(view);
                FrameState {
                    value: theta.to_degrees(),
                    view: Some(view),
                    options,
                }
            }
        }
    }
}

/// The focus options `focus` sets, by their command-line names.
fn focus_given(focus: &FocusOptions) -> Vec<&'static str> {
    [
        ("--disparity", !focus.disparity.is_empty()),
        ("--plane", !focus.planes.is_empty()),
        ("--focus", !focus.focus.is_empty()),
        ("--click", focus.click.is_some()),
        ("--points", focus.points.is_some()),
        ("--points-3d", focus.points_3d.is_some()),
    ]
    .into_iter()
    .filter_map(|(name, set)| set.then_some(name))
    .collect()
}

/// `e` for frame `k` of `n`, naming the frame and its state.
fn frame_error(k: usize, n: usize, state: &FrameState, e: Error) -> Error {
    let what = match state.view {
        Some(v) => format!("view {},{}", v.x, v.y),
        None => format!("value {}", state.value),
    };
    Error::Invalid(format!("frame {} of {n} ({what}): {e}", k + 1))
}

/// What [`render`] did.
#[derive(Debug, Clone)]
pub struct AnimationReport {
    /// The first frame's plans (views used, strategy, focus, anti-aliasing).
    pub first: Prepared,
    /// Output size.
    pub size: (u32, u32),
    /// Frames rendered (the animation's `frames`) and shown (with `bounce`, more).
    pub rendered: usize,
    pub shown: usize,
    /// Each rendered frame's swept value (orbits: angle in degrees).
    pub values: Vec<f64>,
    /// Each rendered frame's wall time of planning, rendering and readback, ms (the first
    /// includes the upload and any depth estimate).
    pub frame_ms: Vec<f64>,
    /// Each rendered frame's GPU refocus time, ms, when the device has timers.
    pub gpu_ms: Vec<Option<f64>>,
    /// Each rendered frame's pixels no view reached.
    pub uncovered: Vec<usize>,
    /// From the first frame's planning to the last frame handed to the sink, s.
    pub wall_s: f64,
}

impl AnimationReport {
    /// The mean wall time of a frame in the steady state, ms: the first frame includes the
    /// upload and any depth estimate and is left out (`None` with one frame).
    pub fn mean_frame_ms(&self) -> Option<f64> {
        mean(&self.frame_ms[1.min(self.frame_ms.len())..])
    }

    /// The mean GPU refocus time of the steady-state frames, ms (`None` without timers).
    pub fn mean_gpu_ms(&self) -> Option<f64> {
        let gpu: Vec<f64> = self.gpu_ms.iter().skip(1).flatten().copied().collect();
        mean(&gpu)
    }
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Renders `states` on `session` (one upload for all) and hands the frames to `sink` in the
/// playback order of `animation` (frames shown again by `bounce` are kept, not rendered again).
/// `depth` counts the planes of a depth estimate if the first frame needs one; `rendered` is
/// called after each frame is rendered.
pub fn render(
    session: &mut Session,
    animation: &Animation,
    states: &[FrameState],
    depth: &ProgressBar,
    mut rendered: impl FnMut(usize),
    sink: &mut dyn FnMut(&RgbaImage) -> Result<()>,
) -> Result<AnimationReport> {
    let t0 = Instant::now();
    let n = states.len();
    let order = animation.order();
    // Frames the backward half shows again.
    let mut kept: Vec<Option<RgbaImage>> = vec![None; n];
    let mut report: Option<AnimationReport> = None;
    for (k, state) in states.iter().enumerate() {
        let t = Instant::now();
        let hidden = ProgressBar::hidden();
        let progress = if k == 0 { depth } else { &hidden };
        let (image, timings, prepared) = session
            .render(&state.options, progress)
            .map_err(|e| frame_error(k, n, state, e))?;
        let frame_ms = t.elapsed().as_secs_f64() * 1e3;
        let GpuImage::Srgb8(image) = image else {
            return Err(Error::Invalid(
                "animations are 8-bit sRGB frames; the render returned float".into(),
            ));
        };
        let uncovered = image.pixels().filter(|p| p.0[3] == 0).count();
        if uncovered == image.pixels().len() {
            // As `render` refuses to write such an image, an animation does not show it.
            return Err(frame_error(
                k,
                n,
                state,
                Error::Geometry(
                    "no view reaches any output pixel; the plane is probably too near or beyond \
                     the views' overlap"
                        .into(),
                ),
            ));
        }
        let r = report.get_or_insert_with(|| AnimationReport {
            size: prepared.output_size(),
            first: prepared,
            rendered: n,
            shown: order.len(),
            values: Vec::with_capacity(n),
            frame_ms: Vec::with_capacity(n),
            gpu_ms: Vec::with_capacity(n),
            uncovered: Vec::with_capacity(n),
            wall_s: 0.0,
        });
        r.values.push(state.value);
        r.frame_ms.push(frame_ms);
        r.gpu_ms.push(timings.map(|t| t.refocus_ms));
        r.uncovered.push(uncovered);
        rendered(k);
        sink(&image)?;
        if order[n..].contains(&k) {
            kept[k] = Some(image);
        }
    }
    for &k in &order[n..] {
        let image = kept[k]
            .as_ref()
            .ok_or_else(|| Error::Invalid(format!("frame {} was not kept for --bounce", k + 1)))?;
        sink(image)?;
    }
    let mut report = report.ok_or_else(|| Error::Invalid("no frame was rendered".into()))?;
    report.wall_s = t0.elapsed().as_secs_f64();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sweep(text: &str, frames: usize) -> Animation {
        Animation::new(Motion::parse_sweep(text).unwrap(), frames, false).unwrap()
    }

    fn err(r: Result<impl std::fmt::Debug>) -> String {
        r.unwrap_err().to_string()
    }

    #[test]
    fn sweeps_space_values_evenly_with_both_ends_exact() {
        let a = sweep("disparity=-1.5..1.5", 5);
        let values: Vec<f64> = (0..5).map(|k| a.value(-1.5, 1.5, k)).collect();
        assert_eq!(values, [-1.5, -0.75, 0.0, 0.75, 1.5]);
        let states = a.states(&RenderOptions::default(), None).unwrap();
        assert_eq!(states[2].options.focus.disparity, [0.0]);
        // Backwards is fine; one frame is the start.
        let b = sweep("aperture_radius=3..1", 3);
        let base = RenderOptions {
            focus: FocusOptions {
                disparity: vec![0.5],
                ..FocusOptions::default()
            },
            ..RenderOptions::default()
        };
        let radii: Vec<_> = b
            .states(&base, None)
            .unwrap()
            .iter()
            .map(|s| s.options.aperture.radius)
            .collect();
        assert_eq!(radii, [Some(3.0), Some(2.0), Some(1.0)]);
        assert_eq!(sweep("tilt=-10..10", 1).value(-10.0, 10.0, 0), -10.0);
    }

    #[test]
    fn bounce_plays_back_without_repeating_the_ends() {
        let order = |n, bounce| {
            Animation::new(Motion::Orbit { radius: 1.0 }, n, bounce)
                .unwrap()
                .order()
        };
        assert_eq!(order(5, true), [0, 1, 2, 3, 4, 3, 2, 1]);
        assert_eq!(order(5, false), [0, 1, 2, 3, 4]);
        assert_eq!(order(2, true), [0, 1]);
        assert_eq!(order(1, true), [0]);
    }

    #[test]
    fn an_orbit_starts_on_the_column_axis_and_stays_in_the_grid() {
        let base = RenderOptions {
            focus: FocusOptions {
                disparity: vec![0.0],
                ..FocusOptions::default()
            },
            ..RenderOptions::default()
        };
        let grid = GridSize { cols: 9, rows: 9 };
        let a = Animation::new(Motion::orbit(2.0).unwrap(), 8, false).unwrap();
        let states = a.states(&base, Some(grid)).unwrap();
        assert_eq!(states[0].options.reference, Some(DVec2::new(6.0, 4.0)));
        let quarter = states[2].view.unwrap();
        assert!(
            (quarter - DVec2::new(4.0, 6.0)).length() < 1e-12,
            "{quarter}"
        );
        let far = Animation::new(Motion::orbit(4.5).unwrap(), 8, false).unwrap();
        let e = err(far.states(&base, Some(grid)));
        assert!(e.contains("--orbit 4.5") && e.contains("at most 4"), "{e}");
        let e = err(a.states(&RenderOptions::default(), Some(grid)));
        assert!(e.contains("--orbit 2") && e.contains("--disparity"), "{e}");
    }

    #[test]
    fn bad_motions_name_the_cause() {
        for (text, needle) in [
            ("blur=0..1", "unknown key 'blur'"),
            ("disparity=0", "no '..'"),
            ("disparity", "no '='"),
            ("disparity=a..1", "'a' is not a number"),
            ("disparity=0...1", "one '..'"),
            ("disparity=0..inf", "finite"),
            ("disparity=nan..1", "finite"),
        ] {
            let e = err(Motion::parse_sweep(text));
            assert!(e.contains(needle), "{text}: {e}");
        }
        for r in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(err(Motion::orbit(r)).contains("--orbit"));
        }
        assert!(err(Animation::new(Motion::orbit(1.0).unwrap(), 0, false)).contains("--frames 0"));
    }

    #[test]
    fn a_sweep_refuses_the_option_it_sets_and_needs_what_it_turns() {
        let with = |focus: FocusOptions| RenderOptions {
            focus,
            ..RenderOptions::default()
        };
        let disparity = with(FocusOptions {
            disparity: vec![1.0],
            ..FocusOptions::default()
        });
        let e = err(sweep("disparity=0..1", 3).states(&disparity, None));
        assert!(e.contains("drop --disparity"), "{e}");
        let e = err(sweep("tilt=0..10", 3).states(&disparity, None));
        assert!(
            e.contains("give one --focus Z") && e.contains("not --disparity"),
            "{e}"
        );
        let focus = with(FocusOptions {
            focus: vec![3.0],
            tilt: vec![5.0],
            ..FocusOptions::default()
        });
        let e = err(sweep("tilt=0..10", 3).states(&focus, None));
        assert!(e.contains("drop --tilt"), "{e}");
        // A focus sweep keeps the given tilt; a swing sweep the given tilt too.
        let s = sweep("swing=-5..5", 3).states(&focus, None).unwrap();
        assert_eq!(s[2].options.focus.tilt, [5.0]);
        assert_eq!(s[2].options.focus.swing, [5.0]);
        let tilt_only = with(FocusOptions {
            tilt: vec![5.0],
            ..FocusOptions::default()
        });
        let s = sweep("focus=2..4", 3).states(&tilt_only, None).unwrap();
        assert_eq!(s[1].options.focus.focus, [3.0]);
        let e = err(sweep("aperture-radius=-1..2", 3).states(&disparity, None));
        assert!(
            e.contains("frame 1 of 3") && e.contains("aperture radius"),
            "{e}"
        );
    }
}
