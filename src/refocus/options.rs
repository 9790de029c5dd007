//! Focus options as numbers, before they are resolved: what every front end builds from its own
//! input (the CLI from option text, the Python module from tuples) so that one set of checks,
//! with one set of messages, decides which focus was asked for.
//!
//! Messages name the options by their command-line spelling (`--plane`, `--click`): the CLI
//! and the Python module report a bad value in the same words, and the README maps the
//! spellings one to one (`--points-3d` is `points_3d=`).

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
/// `planes`, `focus`, `click`, `points` and `points_3d` may be set; several `planes` are a
/// focus surface focused on the first.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FocusOptions {
    pub disparity: Option<f64>,
    pub planes: Vec<Plane>,
    /// On-axis distance of the keyboard definition, with `tilt` and `swing` in degrees.
    pub focus: Option<f64>,
    pub tilt: f64,
    pub swing: f64,
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
            ("--disparity", self.disparity.is_some()),
            ("--plane", !self.planes.is_empty()),
            ("--focus", self.focus.is_some()),
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
        if self.focus.is_none() && (self.tilt != 0.0 || self.swing != 0.0) {
            return Err(Error::Invalid(
                "--tilt and --swing turn the --focus plane; give --focus with them".into(),
            ));
        }
        if !(self.tilt.is_finite() && self.swing.is_finite()) {
            return Err(Error::Invalid(format!(
                "--tilt and --swing must be finite numbers, got {} and {}",
                self.tilt, self.swing
            )));
        }
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

    /// The focus request (of the first plane when several are given), or `None` when no
    /// focus is given; a click's window defaults to `default_window`.
    pub fn request(&self, default_window: u32) -> Option<FocusRequest> {
        let spec = if let Some(d) = self.disparity {
            Some(FocusSpec::Disparity(d))
        } else if let Some(p) = self.planes.first() {
            Some(FocusSpec::Plane(*p))
        } else {
            self.focus.map(|z| FocusSpec::FocusTiltSwing {
                distance: z,
                tilt_deg: self.tilt,
                swing_deg: self.swing,
            })
        };
        if let Some(spec) = spec {
            return Some(spec.into());
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
            return None;
        };
        Some(FocusRequest {
            target,
            nudge: self.nudge,
        })
    }

    /// The focus surface of these planes with a slab or all-in-focus (validated).
    pub fn surface(&self, slab: Option<f64>, all_in_focus: bool) -> Result<FocusSurface> {
        FocusSurface::from_request(&self.planes, slab, all_in_focus)
    }
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
            disparity: Some(1.0),
            focus: Some(2.0),
            ..Default::default()
        };
        let e = two.validate().unwrap_err().to_string();
        assert!(e.contains("--disparity and --focus"), "{e}");
        let tilt = FocusOptions {
            disparity: Some(1.0),
            tilt: 5.0,
            ..Default::default()
        };
        assert!(tilt.validate().unwrap_err().to_string().contains("--tilt"));
        let ok = FocusOptions {
            focus: Some(2.0),
            tilt: 5.0,
            ..Default::default()
        };
        ok.validate().unwrap();
        assert!(matches!(
            ok.request(9).unwrap().target,
            FocusTarget::Spec(FocusSpec::FocusTiltSwing { .. })
        ));
    }
}
