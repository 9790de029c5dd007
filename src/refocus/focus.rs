//! Focus requests and their resolution to a refocus plane: the one place that turns any way of
//! giving focus — a disparity, a plane, the keyboard definition (distance, tilt, swing), a
//! click, three clicks, three world points, each pick optionally nudged — into the plane a
//! render, a point-cloud overlay or a viewer uses (docs/conventions.md §7).
//!
//! [`FocusRequest`] is plain data that any front end builds (the CLI from its options, an
//! interactive viewer from mouse and keys); [`resolve_focus`] resolves it against a light field
//! and a reference view into a [`ResolvedFocus`]: the [`FocusSpec`] that [`super::plan()`]
//! takes, the plane, and for scene picks how the plane was found.
//!
//! Invariants:
//! - every plane returned is valid for the reference camera: finite, unit normal, not through
//!   the reference camera centre (|d_r| above 10⁻⁶ of the rig's extent), so the plane term
//!   `m` is finite;
//! - `--disparity` without a parallel rig is classic shift-and-sum and has no plane
//!   ([`FocusMethod::ClassicShift`], `plane: None`; what needs one takes the plane its shifts
//!   stand for, [`super::plan::classic_plane`]);
//! - pixels of clicks are pixels of the view that carries the depth map; the plane found is a
//!   world-frame plane, the same from every viewpoint. Nudges and three world points act
//!   relative to the reference camera (`reference`, fractional grid position).

use glam::{DVec2, DVec3};

use crate::error::{Error, Result};
use crate::geometry::camera::Camera;
use crate::geometry::depth::ViewDepth;
use crate::geometry::homography::plane_term;
use crate::geometry::normals::NormalParams;
use crate::geometry::picking::{self, Nudge, Pick, PickMethod};
use crate::geometry::plane::Plane;
use crate::lightfield::{DepthKind, LightField};

/// A focus that needs no scene: what [`super::plan()`] takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FocusSpec {
    /// Disparity in pixels per grid step: the HCI disparity of a frontoparallel plane on a
    /// parallel rig (`lf.rig` set), classic shift-and-sum elsewhere.
    Disparity(f64),
    /// A plane in the world frame.
    Plane(Plane),
    /// Point on the reference optical axis at `distance`, normal from tilt and swing (degrees).
    FocusTiltSwing {
        distance: f64,
        tilt_deg: f64,
        swing_deg: f64,
    },
}

/// How the plane of a plan was obtained (reported by `--json`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FocusMethod {
    ClassicShift,
    HciDisparity,
    Plane,
    FocusTiltSwing,
}

/// What the user asked to focus on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FocusTarget {
    /// One of the scene-free definitions.
    Spec(FocusSpec),
    /// A click on pixel position (u, v) of the depth view: its point and PCA normal.
    Click { pixel: DVec2, normals: NormalParams },
    /// Three clicks on pixel positions of the depth view.
    ThreeClicks([DVec2; 3]),
    /// Three world points.
    ThreePoints([DVec3; 3]),
}

/// A focus request: a target and, for the scene picks, a keyboard adjustment of the plane
/// found ("click, then refine with the keyboard").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FocusRequest {
    pub target: FocusTarget,
    /// Only for [`FocusTarget::Click`], [`FocusTarget::ThreeClicks`] and
    /// [`FocusTarget::ThreePoints`]; a scene-free target is adjusted by changing it instead.
    pub nudge: Option<Nudge>,
}

impl From<FocusSpec> for FocusRequest {
    fn from(spec: FocusSpec) -> Self {
        FocusRequest {
            target: FocusTarget::Spec(spec),
            nudge: None,
        }
    }
}

impl FocusRequest {
    /// The name used in reports: `disparity`, `plane`, `focus-tilt-swing`, `click`,
    /// `three-points` or `three-points-3d`.
    pub fn name(&self) -> &'static str {
        match self.target {
            FocusTarget::Spec(FocusSpec::Disparity(_)) => "disparity",
            FocusTarget::Spec(FocusSpec::Plane(_)) => "plane",
            FocusTarget::Spec(FocusSpec::FocusTiltSwing { .. }) => "focus-tilt-swing",
            FocusTarget::Click { .. } => PickMethod::Click.name(),
            FocusTarget::ThreeClicks(_) => PickMethod::ThreePoints.name(),
            FocusTarget::ThreePoints(_) => PickMethod::ThreePoints3d.name(),
        }
    }
}

/// The depth map a pixel pick used.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthInfo {
    pub source: String,
    /// Grid position (s, t) of the view that carries the map.
    pub view: (usize, usize),
    pub kind: DepthKind,
}

/// A resolved focus request.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedFocus {
    /// [`FocusRequest::name`] of the request.
    pub how: &'static str,
    /// What [`super::plan()`] takes; scene picks become [`FocusSpec::Plane`].
    pub spec: FocusSpec,
    pub method: FocusMethod,
    /// The refocus plane in the world frame; `None` for classic shift-and-sum.
    pub plane: Option<Plane>,
    /// The scene pick, for clicks and points.
    pub pick: Option<Pick>,
    /// Where the depth of a pixel pick came from.
    pub depth: Option<DepthInfo>,
}

impl ResolvedFocus {
    /// The JSON report of a focus: `how`, `nudged`, `confidence` and, for picks, the details.
    pub fn json(&self) -> serde_json::Value {
        let Some(pick) = &self.pick else {
            return serde_json::json!({"how": self.how, "nudged": false, "confidence": null});
        };
        let mut v = serde_json::json!({
            "how": self.how,
            "nudged": pick.nudge.is_some(),
            "confidence": pick.confidence,
            "plane_found": pick.found.json(),
            "plane": pick.plane.json(),
            "points": pick.points.iter().map(|p| p.to_array()).collect::<Vec<_>>(),
        });
        let obj = v.as_object_mut();
        if let Some(obj) = obj {
            if !pick.pixels.is_empty() {
                obj.insert("pixels".into(), serde_json::json!(pick.pixels));
            }
            if let Some(n) = &pick.normal {
                obj.insert(
                    "normal_estimate".into(),
                    serde_json::json!({
                        "method": n.method,
                        "normal": n.normal.to_array(),
                        "centroid": n.centroid.to_array(),
                        "confidence": n.confidence,
                        "uncertainty_deg": n.uncertainty_deg,
                        "planarity": n.planarity,
                        "curvature": n.curvature,
                        "view_angle_deg": n.view_angle_deg,
                        "neighbours": n.neighbours,
                        "rejected": n.rejected,
                    }),
                );
            }
            if let Some(a) = pick.min_angle_deg {
                obj.insert("min_angle_deg".into(), serde_json::json!(a));
            }
            if let Some(n) = &pick.nudge {
                obj.insert("nudge".into(), serde_json::json!(n));
            }
            if let Some(d) = &self.depth {
                obj.insert(
                    "depth_map".into(),
                    serde_json::json!({"source": d.source, "view": [d.view.0, d.view.1], "kind": d.kind}),
                );
            }
        }
        v
    }
}

/// Resolves `request` on `lf` for the reference view at grid position `reference` (fractional
/// allowed). Errors name the problem: no usable depth at a click, collinear points, a nudge
/// past 90°, a plane through the reference camera, a disparity beyond infinity, a reference
/// view outside the grid.
pub fn resolve_focus(
    lf: &LightField,
    request: &FocusRequest,
    reference: DVec2,
) -> Result<ResolvedFocus> {
    let how = request.name();
    let (pick, depth) = match request.target {
        FocusTarget::Spec(spec) => {
            if request.nudge.is_some() {
                return Err(Error::Invalid(format!(
                    "a nudge adjusts a plane picked from the scene (click, three points); \
                     change the {how} focus itself instead"
                )));
            }
            let camera = lf.camera_at(reference)?;
            let (method, plane, _) = focus_plane(lf, &spec, &camera)?;
            return Ok(ResolvedFocus {
                how,
                spec,
                method,
                plane,
                pick: None,
                depth: None,
            });
        }
        FocusTarget::Click { pixel, normals } => {
            let d = pick_depth(lf)?;
            (picking::click(&d, pixel.x, pixel.y, &normals)?, Some(d))
        }
        FocusTarget::ThreeClicks(pixels) => {
            // Said in the user's terms, not as a plane distance of 1e-16 from the camera.
            // Two pixels that coincide keep three_clicks' own, more precise message.
            let distinct =
                pixels[0] != pixels[1] && pixels[1] != pixels[2] && pixels[0] != pixels[2];
            if distinct && picking::image_collinear(&pixels) {
                return Err(Error::Geometry(picking::COLLINEAR_CLICKS.into()));
            }
            let d = pick_depth(lf)?;
            (picking::three_clicks(&d, pixels)?, Some(d))
        }
        FocusTarget::ThreePoints(points) => (
            picking::three_points(points, &lf.camera_at(reference)?)?,
            None,
        ),
    };
    let pick = match request.nudge {
        Some(n) => pick.nudged(&lf.camera_at(reference)?, n)?,
        None => pick,
    };
    if pick.method != PickMethod::Click && pick.confidence < 0.2 {
        log::warn!(
            "the three points are nearly collinear (smallest angle {:.2}°): the plane's \
             orientation is very sensitive to depth errors; spread the points wider",
            pick.min_angle_deg.unwrap_or(0.0)
        );
    }
    let spec = FocusSpec::Plane(pick.plane);
    let (method, plane, _) = focus_plane(lf, &spec, &lf.camera_at(reference)?)?;
    Ok(ResolvedFocus {
        how,
        spec,
        method,
        plane,
        depth: depth.map(|d| DepthInfo {
            source: d.source.clone(),
            view: d.grid_position,
            kind: d.kind,
        }),
        pick: Some(pick),
    })
}

/// The depth of the view with the depth map, refused when it has no valid sample (a click
/// could never succeed).
fn pick_depth(lf: &LightField) -> Result<ViewDepth> {
    let d = lf.view_depth()?;
    if d.valid_count() == 0 {
        return Err(Error::LightField(format!(
            "{}: depth map {} has no valid sample",
            lf.name, d.source
        )));
    }
    Ok(d)
}

/// The plane of a scene-free focus seen from `camera` (the reference camera), with its plane
/// term `m = K_r⁻ᵀ n_r / d_r` (zero for classic shift-and-sum). Shared by [`resolve_focus`]
/// and [`super::plan()`], so a render and an overlay always agree on the plane.
pub(crate) fn focus_plane(
    lf: &LightField,
    spec: &FocusSpec,
    camera: &Camera,
) -> Result<(FocusMethod, Option<Plane>, DVec3)> {
    // Planes closer than this to the cameras are degenerate; saying which option put them
    // there beats plane_term's generic "passes through the reference camera centre".
    let near = 1e-6 * rig_scale(lf);
    let (method, plane) = match *spec {
        FocusSpec::Disparity(d) if !d.is_finite() => {
            return Err(Error::Invalid(format!("disparity must be finite, got {d}")));
        }
        FocusSpec::Disparity(d) => match lf.rig {
            Some(rig) => {
                let z = rig.depth_of_disparity(d).ok_or_else(|| {
                    Error::Geometry(format!(
                        "disparity {} px lies at or beyond infinity for this rig (the most \
                         negative physical disparity is {:.4} px)",
                        crate::error::compact(d),
                        rig.disparity_at_infinity()
                    ))
                })?;
                if z < near {
                    return Err(Error::Invalid(format!(
                        "--disparity {} px is far too large for this rig: it puts the focus \
                         plane at depth {z:.1e}, practically on the cameras (disparity 0 is the \
                         focus distance {}, {:.4} px is infinity)",
                        crate::error::compact(d),
                        rig.focus_distance,
                        rig.disparity_at_infinity()
                    )));
                }
                // World frame = centre camera frame: the plane z = Z.
                let p = Plane::new(DVec3::new(0.0, 0.0, z), DVec3::Z)?;
                (FocusMethod::HciDisparity, Some(p))
            }
            None => (FocusMethod::ClassicShift, None),
        },
        FocusSpec::Plane(p) => (FocusMethod::Plane, Some(Plane::new(p.point, p.normal)?)),
        FocusSpec::FocusTiltSwing { distance, .. } if distance.abs() < near => {
            return Err(Error::Invalid(format!(
                "--focus {distance:e} puts the focus plane practically on the reference camera \
                 (the cameras span {:.3e}); give a larger distance",
                near / 1e-6
            )));
        }
        FocusSpec::FocusTiltSwing {
            distance,
            tilt_deg,
            swing_deg,
        } => (
            FocusMethod::FocusTiltSwing,
            Some(Plane::from_focus_tilt_swing(
                camera, distance, tilt_deg, swing_deg,
            )?),
        ),
    };
    let m = match &plane {
        Some(p) => plane_term(camera, p, near)?,
        None => DVec3::ZERO,
    };
    Ok((method, plane, m))
}

/// Length scale of the rig: the largest distance of a camera centre from the first one
/// (1 for a single camera). Degeneracy tolerances are relative to it.
fn rig_scale(lf: &LightField) -> f64 {
    let c0 = lf.views[0].camera.centre();
    let s = lf
        .views
        .iter()
        .map(|v| (v.camera.centre() - c0).length())
        .fold(0.0, f64::max);
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn planes() -> LightField {
        crate::synth::builtin("planes").unwrap().light_field(1)
    }

    #[test]
    fn planes_practically_on_the_cameras_name_the_option_that_put_them_there() {
        let lf = planes();
        let plan = |focus| {
            let req = super::super::RefocusRequest {
                focus,
                aperture: Default::default(),
                reference: None,
            };
            super::super::plan(&lf, &req, &[]).unwrap_err().to_string()
        };
        let e = plan(FocusSpec::Disparity(1e30));
        assert!(
            e.contains("far too large") && e.contains("--disparity"),
            "{e}"
        );
        let e = plan(FocusSpec::FocusTiltSwing {
            distance: 1e-42,
            tilt_deg: 0.0,
            swing_deg: 0.0,
        });
        assert!(
            e.contains("--focus 1e-42") && e.contains("practically on"),
            "{e}"
        );
    }

    #[test]
    fn scene_free_targets_resolve_to_the_plane_the_plan_uses() {
        let lf = planes();
        let reference = DVec2::new(1.5, 2.0);
        let spec = FocusSpec::FocusTiltSwing {
            distance: 3.0,
            tilt_deg: 20.0,
            swing_deg: -10.0,
        };
        let f = resolve_focus(&lf, &spec.into(), reference).unwrap();
        assert_eq!(
            (f.how, f.method),
            ("focus-tilt-swing", FocusMethod::FocusTiltSwing)
        );
        let camera = lf.camera_at(reference).unwrap();
        let expect = Plane::from_focus_tilt_swing(&camera, 3.0, 20.0, -10.0).unwrap();
        assert_eq!(f.plane, Some(expect));
        let req = super::super::RefocusRequest {
            focus: f.spec,
            aperture: Default::default(),
            reference: Some(reference),
        };
        let plan = super::super::plan(&lf, &req, &[]).unwrap();
        assert_eq!(plan.plane, f.plane);
        // A disparity on a rig is the frontoparallel plane at its HCI depth.
        let f = resolve_focus(&lf, &FocusSpec::Disparity(0.5).into(), reference).unwrap();
        let z = lf.rig.unwrap().depth_of_disparity(0.5).unwrap();
        assert_eq!(f.method, FocusMethod::HciDisparity);
        assert!((f.plane.unwrap().point.z - z).abs() < 1e-12);
    }

    #[test]
    fn picks_resolve_to_planes_and_nudges_apply_only_to_picks() {
        let lf = planes();
        let centre = lf.grid.centre();
        let pts = [
            DVec3::new(-0.3, -0.2, 3.0),
            DVec3::new(0.4, -0.1, 3.2),
            DVec3::new(0.0, 0.3, 3.1),
        ];
        let req = FocusRequest {
            target: FocusTarget::ThreePoints(pts),
            nudge: None,
        };
        let f = resolve_focus(&lf, &req, centre).unwrap();
        assert_eq!(f.how, "three-points-3d");
        let plane = f.plane.unwrap();
        assert_eq!(f.spec, FocusSpec::Plane(plane));
        for p in pts {
            assert!(plane.signed_distance(p).abs() < 1e-12);
        }
        // Nudged: 0.5 farther along the axis, same orientation.
        let nudge = Nudge {
            distance: 0.5,
            tilt_deg: 0.0,
            swing_deg: 0.0,
        };
        let g = resolve_focus(
            &lf,
            &FocusRequest {
                nudge: Some(nudge),
                ..req
            },
            centre,
        )
        .unwrap();
        let (p0, p1) = (plane, g.plane.unwrap());
        // Same orientation (the keyboard definition may flip the normal's sign).
        assert!(p0.normal.dot(p1.normal).abs() > 1.0 - 1e-12);
        let cam = lf.camera_at(centre).unwrap();
        let z = |p: &Plane| p.to_focus_tilt_swing(&cam).unwrap().0;
        assert!((z(&p1) - z(&p0) - 0.5).abs() < 1e-9);
        assert!(g.pick.unwrap().nudge.is_some());
        // A nudge on a scene-free target is refused.
        let bad = FocusRequest {
            target: FocusTarget::Spec(FocusSpec::Disparity(0.0)),
            nudge: Some(nudge),
        };
        assert!(resolve_focus(&lf, &bad, centre).is_err());
    }

    #[test]
    fn a_click_on_the_depth_view_finds_the_surface_there() {
        let lf = planes();
        let depth = lf.view_depth().unwrap();
        let (_, p, n) = crate::synth::builtin("planes").unwrap().planes()[0].clone();
        let px = depth.camera.project(p).unwrap().round();
        let req = FocusRequest {
            target: FocusTarget::Click {
                pixel: px,
                normals: NormalParams::default(),
            },
            nudge: None,
        };
        let f = resolve_focus(&lf, &req, lf.grid.centre()).unwrap();
        assert_eq!(f.how, "click");
        assert_eq!(f.depth.as_ref().unwrap().view, depth.grid_position);
        let plane = f.plane.unwrap();
        assert!(plane.normal.dot(n) > 0.999, "{plane:?} vs {n}");
        assert!(plane.signed_distance(p).abs() < 1e-3);
    }
}
