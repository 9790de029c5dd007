//! Focus options as numbers, before they are resolved: what every front end builds from its own
//! input (the CLI from option text, the Python module from tuples) so that one set of checks,
//! with one set of messages, decides which focus was asked for.
//!
//! Messages name the options by their command-line spelling (`--plane`, `--click`): the CLI
//! and the Python module report a bad value in the same words, and the README maps the
//! spellings one to one (`--points-3d` is `points_3d=`).
//!
//! **Several planes.** Each plane form may be given 2 to 8 times
//! ([`crate::refocus::surface::MAX_PLANES`]), a focus surface of several planes
//! ([`FocusSurface::Planes`]) whose first is the render's focus: `--plane`, `--focus` (each
//! the keyboard plane through the reference optical axis) and `--disparity` (each a
//! frontoparallel plane of the rig). `--tilt` and `--swing` are given once (they turn every
//! `--focus` plane) or once per `--focus` (paired by order); any other count is refused. The
//! forms do not mix in one surface: which plane is the first (the render's own focus and the
//! fallback where the depth is unknown) would then depend on an order that neither the
//! command line's option groups nor Python's keywords keep.

use glam::{DVec2, DVec3};

use crate::error::{Error, Result};
use crate::geometry::normals::{NormalMethod, NormalParams};
use crate::geometry::picking::Nudge;
use crate::geometry::plane::Plane;
use crate::refocus::surface::FocusSurface;
use crate::refocus::{FocusRequest, FocusSpec, FocusTarget};

/// Parses "a,b,c" into exactly `n` finite numbers; `what` names the option in the message.
pub fn parse_numbers(text: &str, n: usize, what: &str) -> Result<Vec<f64>> {
    let values: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| {
            Error::Invalid(format!(
                "{what}: expected {n} comma-separated numbers, got '{text}'"
            ))
        })?;
    numbers_of(values, n, what, text)
}

/// [`parse_numbers`] for values that are numbers already (the Python module's tuples): the
/// message shows them as the option text that holds them (`0,0,NaN,0,0,1`), so a bad value
/// reads the same from either front end.
pub fn numbers(values: &[f64], n: usize, what: &str) -> Result<Vec<f64>> {
    let text = values
        .iter()
        .map(f64::to_string)
        .collect::<Vec<_>>()
        .join(",");
    numbers_of(values.to_vec(), n, what, &text)
}

fn numbers_of(values: Vec<f64>, n: usize, what: &str, text: &str) -> Result<Vec<f64>> {
    if values.len() != n || values.iter().any(|v| !v.is_finite()) {
        return Err(Error::Invalid(format!(
            "{what}: expected {n} comma-separated finite numbers, got '{text}'"
        )));
    }
    Ok(values)
}

/// The plane of six checked numbers `px, py, pz, nx, ny, nz` (a `--plane` value).
pub fn plane_of(v: &[f64]) -> Result<Plane> {
    Plane::new(DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5]))
}

/// The focus of a render, as given (see the module docs). At most one of `disparity`,
/// `planes`, `focus`, `click`, `points` and `points_3d` may be set; several `disparity`,
/// `planes` or `focus` values are a focus surface focused on the first.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FocusOptions {
    /// Disparities, px per grid step (each a frontoparallel plane on a rig).
    pub disparity: Vec<f64>,
    pub planes: Vec<Plane>,
    /// On-axis distances of the keyboard definition, with `tilt` and `swing` in degrees.
    pub focus: Vec<f64>,
    /// None (0°), one for every `focus`, or one per `focus` in order.
    pub tilt: Vec<f64>,
    /// As `tilt`.
    pub swing: Vec<f64>,
    /// A pixel of the depth map's view.
    pub click: Option<DVec2>,
    /// Three pixels of the depth map's view.
    pub points: Option<[DVec2; 3]>,
    /// Three world points.
    pub points_3d: Option<[DVec3; 3]>,
    /// Keyboard adjustment of a picked plane (`--nudge-*`).
    pub nudge: Option<Nudge>,
    /// Side of a click's normal window; `None`: the default of the depth's origin.
    pub normal_window: Option<u32>,
    pub normal_method: NormalMethod,
}

impl FocusOptions {
    /// The option names that are set, in the CLI's order.
    fn given(&self) -> Vec<&'static str> {
        [
            ("--disparity", !self.disparity.is_empty()),
            ("--plane", !self.planes.is_empty()),
            ("--focus", !self.focus.is_empty()),
            ("--click", self.click.is_some()),
            ("--points", self.points.is_some()),
            ("--points-3d", self.points_3d.is_some()),
        ]
        .into_iter()
        .filter_map(|(name, set)| set.then_some(name))
        .collect()
    }

    /// Checks that exactly one focus is given and that the options that refine one belong to
    /// it. The CLI's argument parser enforces the same rules before this runs; front ends
    /// without such a parser (the Python module) get them here.
    pub fn validate(&self) -> Result<()> {
        match self.given().as_slice() {
            [] => {
                return Err(Error::Invalid(
                    "give one of --disparity, --plane, --focus, --click, --points or --points-3d"
                        .into(),
                ))
            }
            [_] => {}
            several => {
                return Err(Error::Invalid(format!(
                    "give one focus, got {}",
                    several.join(" and ")
                )))
            }
        }
        if !self.tilt.iter().chain(&self.swing).all(|a| a.is_finite()) {
            return Err(Error::Invalid(format!(
                "--tilt and --swing must be finite numbers, got {} and {}",
                list(&self.tilt),
                list(&self.swing)
            )));
        }
        self.specs()?;
        let picked = self.click.is_some() || self.points.is_some() || self.points_3d.is_some();
        if self.nudge.is_some() && !picked {
            return Err(Error::Invalid(
                "a nudge adjusts a plane picked from the scene: give it with --click, --points \
                 or --points-3d"
                    .into(),
            ));
        }
        Ok(())
    }

    /// [`FocusOptions::validate`] where the focus is optional (the plane a point cloud may
    /// show): nothing given at all passes.
    pub fn validate_optional(&self) -> Result<()> {
        let nothing = self.given().is_empty()
            && self.tilt.is_empty()
            && self.swing.is_empty()
            && self.nudge.is_none();
        if nothing {
            return Ok(());
        }
        self.validate()
    }

    /// True when the focus picks pixels of the depth view (a click or three clicks).
    pub fn needs_depth(&self) -> bool {
        self.click.is_some() || self.points.is_some()
    }

    /// The normal parameters of a click: the method, and the window or `default_window`.
    pub fn normal_params(&self, default_window: u32) -> NormalParams {
        NormalParams::default()
            .with_method(self.normal_method)
            .with_window(self.normal_window.unwrap_or(default_window))
    }

    /// Every plane the scene-free options give, in order: each `--disparity`, each `--plane`,
    /// each `--focus` with its `--tilt` and `--swing` (one value turns every `--focus`
    /// plane, one per `--focus` pairs by order; none is 0°). Empty for a pick. Refuses any
    /// other count of `--tilt` or `--swing`, naming the options and the counts, and either
    /// without `--focus` (the CLI's parser lets `--tilt` pass with another focus option).
    pub fn specs(&self) -> Result<Vec<FocusSpec>> {
        if self.focus.is_empty() && !(self.tilt.is_empty() && self.swing.is_empty()) {
            return Err(Error::Invalid(
                "--tilt and --swing turn the --focus plane; give --focus with them".into(),
            ));
        }
        let angle = |values: &[f64], name: &str, k: usize| -> Result<f64> {
            match values.len() {
                0 => Ok(0.0),
                1 => Ok(values[0]),
                n if n == self.focus.len() => Ok(values[k]),
                n => Err(Error::Invalid(format!(
                    "{name} is given {n} times and --focus {}: give {name} once (it turns \
                     every --focus plane) or once per --focus (paired by order)",
                    times(self.focus.len())
                ))),
            }
        };
        let mut specs: Vec<FocusSpec> = self
            .disparity
            .iter()
            .map(|&d| FocusSpec::Disparity(d))
            .chain(self.planes.iter().map(|&p| FocusSpec::Plane(p)))
            .collect();
        for (k, &distance) in self.focus.iter().enumerate() {
            specs.push(FocusSpec::FocusTiltSwing {
                distance,
                tilt_deg: angle(&self.tilt, "--tilt", k)?,
                swing_deg: angle(&self.swing, "--swing", k)?,
            });
        }
        Ok(specs)
    }

    /// The one plane of a command that takes one ([`FocusOptions::specs`] with a single
    /// plane), or `None` for none or a pick. A plane form given more than once is a focus
    /// surface, which only `render` and `cloud` take: refused, naming the option.
    pub fn one_spec(&self) -> Result<Option<FocusSpec>> {
        for (name, n) in [
            ("--disparity", self.disparity.len()),
            ("--plane", self.planes.len()),
            ("--focus", self.focus.len()),
        ] {
            if n > 1 {
                return Err(Error::Invalid(format!(
                    "{name} is given {n} times; several planes are a focus surface, which only \
                     `render` and `cloud` take"
                )));
            }
        }
        Ok(self.specs()?.first().copied())
    }

    /// The focus request (of the first plane when several are given), or `None` when no
    /// focus is given; a click's window defaults to `default_window`. Refuses what
    /// [`FocusOptions::specs`] refuses.
    pub fn request(&self, default_window: u32) -> Result<Option<FocusRequest>> {
        if let Some(spec) = self.specs()?.first() {
            return Ok(Some((*spec).into()));
        }
        let target = if let Some(pixel) = self.click {
            FocusTarget::Click {
                pixel,
                normals: self.normal_params(default_window),
            }
        } else if let Some(p) = self.points {
            FocusTarget::ThreeClicks(p)
        } else if let Some(p) = self.points_3d {
            FocusTarget::ThreePoints(p)
        } else {
            return Ok(None);
        };
        Ok(Some(FocusRequest {
            target,
            nudge: self.nudge,
        }))
    }

    /// The focus surface of these options with a slab or all-in-focus, its planes as given
    /// ([`FocusOptions::specs`]; checked: the counts, the slab's width, the combinations).
    /// [`FocusSurface::resolve`] places its planes for a render's reference camera.
    pub fn surface(
        &self,
        slab: Option<f64>,
        all_in_focus: bool,
    ) -> Result<FocusSurface<FocusSpec>> {
        FocusSurface::from_request(&self.specs()?, slab, all_in_focus)
    }
}

/// "once", "2 times", …
fn times(n: usize) -> String {
    match n {
        1 => "once".into(),
        n => format!("{n} times"),
    }
}

/// Numbers as an option's text: `1,2.5`.
fn list(values: &[f64]) -> String {
    values
        .iter()
        .map(f64::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_and_text_report_a_bad_value_in_the_same_words() {
        let text = parse_numbers("0,0,NaN,0,0,1", 6, "--plane").unwrap_err();
        let nums = numbers(&[0.0, 0.0, f64::NAN, 0.0, 0.0, 1.0], 6, "--plane").unwrap_err();
        assert_eq!(text.to_string(), nums.to_string());
        let short = numbers(&[1.0, 2.5], 6, "--plane").unwrap_err().to_string();
        assert!(
            short.contains("expected 6") && short.contains("'1,2.5'"),
            "{short}"
        );
        assert_eq!(
            numbers(&[1.0, -2.0], 2, "--click").unwrap(),
            vec![1.0, -2.0]
        );
    }

    #[test]
    fn exactly_one_focus_is_accepted() {
        let none = FocusOptions::default().validate().unwrap_err().to_string();
        assert!(none.contains("give one of --disparity"), "{none}");
        let two = FocusOptions {
            disparity: vec![1.0],
            focus: vec![2.0],
            ..Default::default()
        };
        let e = two.validate().unwrap_err().to_string();
        assert!(e.contains("--disparity and --focus"), "{e}");
        let tilt = FocusOptions {
            disparity: vec![1.0],
            tilt: vec![5.0],
            ..Default::default()
        };
        assert!(tilt.validate().unwrap_err().to_string().contains("--tilt"));
        // Given without --focus, even at 0°, the angle is refused, not dropped.
        let zero = FocusOptions {
            planes: vec![Plane::new(DVec3::new(0.0, 0.0, 2.0), DVec3::Z).unwrap()],
            swing: vec![0.0],
            ..Default::default()
        };
        for e in [zero.validate().unwrap_err(), zero.request(9).unwrap_err()] {
            assert_eq!(
                e.to_string(),
                "--tilt and --swing turn the --focus plane; give --focus with them"
            );
        }
        let ok = FocusOptions {
            focus: vec![2.0],
            tilt: vec![5.0],
            ..Default::default()
        };
        ok.validate().unwrap();
        assert!(matches!(
            ok.request(9).unwrap().unwrap().target,
            FocusTarget::Spec(FocusSpec::FocusTiltSwing { .. })
        ));
    }

    fn keyboard(distance: f64, tilt_deg: f64, swing_deg: f64) -> FocusSpec {
        FocusSpec::FocusTiltSwing {
            distance,
            tilt_deg,
            swing_deg,
        }
    }

    #[test]
    fn tilt_and_swing_are_given_once_or_once_per_focus() {
        let options = |tilt: Vec<f64>, swing: Vec<f64>| FocusOptions {
            focus: vec![2.0, 3.0, 4.0],
            tilt,
            swing,
            ..Default::default()
        };
        // None: every plane frontoparallel; once: every plane turned alike.
        assert_eq!(
            options(vec![], vec![7.0]).specs().unwrap(),
            vec![
                keyboard(2.0, 0.0, 7.0),
                keyboard(3.0, 0.0, 7.0),
                keyboard(4.0, 0.0, 7.0)
            ]
        );
        // Once per --focus: paired by order.
        let paired = options(vec![10.0, -5.0, 0.5], vec![1.0]);
        paired.validate().unwrap();
        assert_eq!(
            paired.specs().unwrap(),
            vec![
                keyboard(2.0, 10.0, 1.0),
                keyboard(3.0, -5.0, 1.0),
                keyboard(4.0, 0.5, 1.0)
            ]
        );
        // The request is the first plane; the surface holds all three in order.
        assert_eq!(
            paired.request(9).unwrap().unwrap().target,
            FocusTarget::Spec(keyboard(2.0, 10.0, 1.0))
        );
        assert_eq!(
            paired.surface(None, false).unwrap(),
            FocusSurface::Planes(paired.specs().unwrap())
        );
        // Any other count is refused by name, with both counts, wherever it is checked.
        let bad = options(vec![1.0, 2.0], vec![]);
        for e in [
            bad.specs().unwrap_err(),
            bad.validate().unwrap_err(),
            bad.surface(None, false).unwrap_err(),
            bad.request(9).unwrap_err(),
        ] {
            assert_eq!(
                e.to_string(),
                "--tilt is given 2 times and --focus 3 times: give --tilt once (it turns \
                 every --focus plane) or once per --focus (paired by order)"
            );
        }
        let e = options(vec![], vec![1.0, 2.0, 3.0, 4.0])
            .specs()
            .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("--swing is given 4 times and --focus 3 times"),
            "{e}"
        );
        // One --focus with two tilts: also refused, not the first tilt taken.
        let one = FocusOptions {
            focus: vec![2.0],
            tilt: vec![1.0, 2.0],
            ..Default::default()
        };
        assert!(one
            .validate()
            .unwrap_err()
            .to_string()
            .starts_with("--tilt is given 2 times and --focus once"));
    }

    #[test]
    fn each_plane_form_repeated_is_a_surface_and_one_plane_commands_refuse_it() {
        let disparities = FocusOptions {
            disparity: vec![0.5, -0.5],
            ..Default::default()
        };
        assert_eq!(
            disparities.surface(None, false).unwrap(),
            FocusSurface::Planes(vec![FocusSpec::Disparity(0.5), FocusSpec::Disparity(-0.5)])
        );
        let e = disparities.one_spec().unwrap_err().to_string();
        assert_eq!(
            e,
            "--disparity is given 2 times; several planes are a focus surface, which only \
             `render` and `cloud` take"
        );
        let focus = FocusOptions {
            focus: vec![2.0, 3.0],
            ..Default::default()
        };
        let e = focus.one_spec().unwrap_err().to_string();
        assert!(e.starts_with("--focus is given 2 times"), "{e}");
        assert_eq!(
            FocusOptions {
                focus: vec![2.0],
                tilt: vec![3.0],
                ..Default::default()
            }
            .one_spec()
            .unwrap(),
            Some(keyboard(2.0, 3.0, 0.0))
        );
        // More than eight planes, of any form: the surface's own refusal.
        let nine = FocusOptions {
            focus: (0..9).map(|k| 2.0 + k as f64).collect(),
            ..Default::default()
        };
        let e = nine.surface(None, false).unwrap_err().to_string();
        assert_eq!(e, "a focus surface takes at most 8 planes, got 9");
        // Several --focus with a slab or all in focus: refused as several --plane are.
        let e = focus.surface(Some(0.1), false).unwrap_err().to_string();
        assert!(e.contains("exactly one plane, got 2 planes"), "{e}");
        let e = focus.surface(None, true).unwrap_err().to_string();
        assert!(
            e.contains("all-in-focus needs no plane set, got 2 planes"),
            "{e}"
        );
        // The forms do not mix.
        let mixed = FocusOptions {
            planes: vec![Plane::new(DVec3::new(0.0, 0.0, 2.0), DVec3::Z).unwrap()],
            focus: vec![3.0, 4.0],
            ..Default::default()
        };
        let e = mixed.validate().unwrap_err().to_string();
        assert_eq!(e, "give one focus, got --plane and --focus");
    }
}
