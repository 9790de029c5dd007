//! Placing the refocus plane from the scene (paper §3): a single click, three clicks, three
//! world points, and keyboard fine adjustment ("click, then refine with the keyboard").
//!
//! - **Single click** on pixel (u, v) of the depth view ([`ViewDepth`]): p is the back-projected
//!   pixel, n its normal ([`super::normals`]: the inverse-depth plane fit by default, or PCA).
//!   Refused (with the reason) where the depth is invalid or the normal is unreliable (too few
//!   neighbours on the same surface; an uncertainty above the limit, or for PCA a planarity
//!   below it). Confidence: the normal's ([`NormalEstimate::confidence`]).
//! - **Three clicks** on pixels of the depth view, or **three world points**: the plane through
//!   them ([`Plane::from_points`], which refuses coincident and collinear points with
//!   tolerances relative to the scene scale — here the largest distance of a point from the
//!   camera). Confidence: `sin(smallest angle) / sin 60°`, 1 for an equilateral triangle; the
//!   normal's sensitivity to depth noise grows as 1/sin(smallest angle) (docs/stability.md).
//! - **Nudge**: the found plane is converted to the keyboard definition (on-axis distance,
//!   tilt, swing; [`Plane::to_focus_tilt_swing`]) relative to the *reference camera of the
//!   render*, the nudges are added, and the plane is rebuilt with
//!   [`Plane::from_focus_tilt_swing`]. A plane that does not cross the reference optical axis
//!   in front of the camera has no such definition and is refused, as is a nudge that takes
//!   tilt or swing to ±90° or the distance to ≤ 0.
//!
//! Pixels are those of the view that carries the depth map (normally the centre view), even
//! when a render uses another reference view: the plane is in the world frame, so it is the
//! same plane from every viewpoint. Every plane found here has its normal facing the camera of
//! the depth view (or, for world points, the given camera).

use glam::{DVec2, DVec3};

use super::camera::Camera;
use super::depth::ViewDepth;
use super::normals::{reliable_normal, NormalEstimate, NormalParams};
use super::plane::Plane;
use crate::error::{Error, Result};

/// How a plane was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PickMethod {
    /// One pixel: its point and PCA normal.
    Click,
    /// Three pixels of the depth view.
    ThreePoints,
    /// Three world points.
    ThreePoints3d,
}

impl PickMethod {
    /// The name used in reports (`click`, `three-points`, `three-points-3d`).
    pub fn name(&self) -> &'static str {
        match self {
            PickMethod::Click => "click",
            PickMethod::ThreePoints => "three-points",
            PickMethod::ThreePoints3d => "three-points-3d",
        }
    }
}

/// Keyboard increments: added to the on-axis distance (world units), tilt and swing (degrees)
/// of a plane seen from the reference camera.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Nudge {
    pub distance: f64,
    pub tilt_deg: f64,
    pub swing_deg: f64,
}

impl Nudge {
    /// True when it changes nothing.
    pub fn is_zero(&self) -> bool {
        self.distance == 0.0 && self.tilt_deg == 0.0 && self.swing_deg == 0.0
    }
}

/// The keyboard definition of a plane relative to a camera.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct KeyboardPlane {
    pub distance: f64,
    pub tilt_deg: f64,
    pub swing_deg: f64,
}

impl KeyboardPlane {
    /// The keyboard definition of `plane` seen from `camera`; an error when the optical axis
    /// does not meet the plane in front of the camera.
    pub fn of(plane: &Plane, camera: &Camera) -> Result<Self> {
        let (distance, tilt_deg, swing_deg) =
            plane.to_focus_tilt_swing(camera).ok_or_else(|| {
                Error::Geometry(
                    "the plane does not cross the reference camera's optical axis in front of the \
                 camera, so it has no distance/tilt/swing to adjust; drop the --nudge-* options \
                 or pick another plane"
                        .into(),
                )
            })?;
        Ok(KeyboardPlane {
            distance,
            tilt_deg,
            swing_deg,
        })
    }
}

/// A nudge that was applied, with the keyboard definitions before and after.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AppliedNudge {
    pub nudge: Nudge,
    pub before: KeyboardPlane,
    pub after: KeyboardPlane,
}

/// A plane found from the scene, with how it was found and how far to trust it.
#[derive(Debug, Clone, PartialEq)]
pub struct Pick {
    pub method: PickMethod,
    /// The plane to use (after any nudge).
    pub plane: Plane,
    /// The plane as found, before any nudge.
    pub found: Plane,
    /// In [0, 1]: the normal's confidence for a click (planarity for PCA, 1 − uncertainty/limit
    /// for the inverse-depth fit), `sin(smallest angle)/sin 60°` for three points.
    pub confidence: f64,
    /// The depth-view pixels used (empty for world points).
    pub pixels: Vec<(u32, u32)>,
    /// The world points used (the clicked point, or the three points).
    pub points: Vec<DVec3>,
    /// The normal estimate of a click.
    pub normal: Option<NormalEstimate>,
    /// The smallest angle of the triangle of three points, degrees.
    pub min_angle_deg: Option<f64>,
    /// The nudge, when one was applied.
    pub nudge: Option<AppliedNudge>,
}

impl Pick {
    /// Applies `nudge` relative to `camera` (the render's reference camera). A zero nudge still
    /// checks that the plane has a keyboard definition, so `--nudge-* 0` fails where a real
    /// nudge would.
    pub fn nudged(mut self, camera: &Camera, nudge: Nudge) -> Result<Self> {
        let (plane, applied) = nudge_plane(&self.found, camera, nudge)?;
        self.plane = plane;
        self.nudge = Some(applied);
        Ok(self)
    }
}

/// `plane` adjusted by `nudge` in the keyboard definition relative to `camera`.
pub fn nudge_plane(plane: &Plane, camera: &Camera, nudge: Nudge) -> Result<(Plane, AppliedNudge)> {
    // Named as the options that set them (the message printed the struct's Debug form).
    for (option, value) in [
        ("--nudge-distance", nudge.distance),
        ("--nudge-tilt", nudge.tilt_deg),
        ("--nudge-swing", nudge.swing_deg),
    ] {
        if !value.is_finite() {
            return Err(Error::Invalid(format!(
                "{option} must be a finite number, got {value}"
            )));
        }
    }
    let before = KeyboardPlane::of(plane, camera)?;
    let after = KeyboardPlane {
        distance: before.distance + nudge.distance,
        tilt_deg: before.tilt_deg + nudge.tilt_deg,
        swing_deg: before.swing_deg + nudge.swing_deg,
    };
    let nudged =
        Plane::from_focus_tilt_swing(camera, after.distance, after.tilt_deg, after.swing_deg)
            .map_err(|e| {
                Error::Geometry(format!(
                "the nudge takes the plane (distance {:.4}, tilt {:.2}°, swing {:.2}°) to distance \
                 {:.4}, tilt {:.2}°, swing {:.2}°, which is not a valid plane: {}",
                before.distance,
                before.tilt_deg,
                before.swing_deg,
                after.distance,
                after.tilt_deg,
                after.swing_deg,
                inner_message(&e)
            ))
            })?;
    Ok((
        nudged,
        AppliedNudge {
            nudge,
            before,
            after,
        },
    ))
}

/// The message of an error without its category prefix, for nesting in another message.
fn inner_message(e: &Error) -> String {
    match e {
        Error::Geometry(m) | Error::Invalid(m) | Error::LightField(m) => m.clone(),
        other => other.to_string(),
    }
}

/// The back-projected point of pixel position (u, v) of the depth view, or an error saying why
/// there is none. `what` names the pick in the message ("the click", "point 2").
fn picked_point(depth: &ViewDepth, u: f64, v: f64, what: &str) -> Result<((u32, u32), DVec3)> {
    let (x, y) = depth
        .pixel_at(u, v)
        .map_err(|e| Error::Invalid(format!("{what}: {}", inner_message(&e))))?;
    match (depth.depth_checked(x, y), depth.point(x, y)) {
        (Ok(_), Some(p)) => Ok(((x, y), p)),
        (Err(problem), _) => Err(Error::Geometry(format!(
            "{what} at pixel ({x}, {y}) of view ({}, {}) has no usable depth in {}: {problem}; \
             pick a pixel with valid depth",
            depth.grid_position.0, depth.grid_position.1, depth.source
        ))),
        (Ok(_), None) => Err(Error::Geometry(format!(
            "{what} at pixel ({x}, {y}) has no usable depth"
        ))),
    }
}

/// Single click on pixel position (u, v) of the depth view.
pub fn click(depth: &ViewDepth, u: f64, v: f64, params: &NormalParams) -> Result<Pick> {
    params.validate()?;
    let ((x, y), p) = picked_point(depth, u, v, "the click")?;
    let normal = reliable_normal(depth, x, y, params).map_err(|problem| {
        Error::Geometry(format!(
            "no reliable normal at the clicked pixel ({x}, {y}) (window {}×{} px): {problem}",
            params.window, params.window
        ))
    })?;
    let plane = Plane::new(p, normal.normal)?;
    Ok(Pick {
        method: PickMethod::Click,
        plane,
        found: plane,
        confidence: normal.confidence,
        pixels: vec![(x, y)],
        points: vec![p],
        normal: Some(normal),
        min_angle_deg: None,
        nudge: None,
    })
}

/// Three clicks on pixel positions of the depth view.
pub fn three_clicks(depth: &ViewDepth, pixels: [DVec2; 3]) -> Result<Pick> {
    let mut px = Vec::with_capacity(3);
    let mut pts = [DVec3::ZERO; 3];
    for (k, p) in pixels.iter().enumerate() {
        let (pixel, point) = picked_point(depth, p.x, p.y, &format!("point {}", k + 1))?;
        px.push(pixel);
        pts[k] = point;
    }
    let mut pick = through_points(pts, depth.camera.centre(), PickMethod::ThreePoints)?;
    pick.pixels = px;
    Ok(pick)
}

/// Three world points; `camera` (the render's reference camera) sets the scene scale for the
/// degeneracy tolerances and the side the normal faces.
pub fn three_points(points: [DVec3; 3], camera: &Camera) -> Result<Pick> {
    through_points(points, camera.centre(), PickMethod::ThreePoints3d)
}

fn through_points(points: [DVec3; 3], eye: DVec3, method: PickMethod) -> Result<Pick> {
    let [a, b, c] = points;
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return Err(Error::Invalid(
            "the three plane points must be finite".into(),
        ));
    }
    let scale = points
        .iter()
        .map(|p| (*p - eye).length())
        .fold(0.0, f64::max);
    let plane = Plane::from_points(a, b, c, scale)?;
    let plane = if plane.signed_distance(eye) < 0.0 {
        Plane::new(plane.point, -plane.normal)?
    } else {
        plane
    };
    let min_angle = triangle_min_angle_deg(a, b, c);
    Ok(Pick {
        method,
        plane,
        found: plane,
        confidence: (min_angle.to_radians().sin() / 60f64.to_radians().sin()).clamp(0.0, 1.0),
        pixels: Vec::new(),
        points: points.to_vec(),
        normal: None,
        min_angle_deg: Some(min_angle),
        nudge: None,
    })
}

/// The smallest interior angle of triangle abc in degrees (0 for a degenerate one).
pub fn triangle_min_angle_deg(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let angle = |p: DVec3, q: DVec3, r: DVec3| {
        let (u, v) = ((q - p).normalize_or_zero(), (r - p).normalize_or_zero());
        u.dot(v).clamp(-1.0, 1.0).acos().to_degrees()
    };
    let angles = [angle(a, b, c), angle(b, c, a), angle(c, a, b)];
    let m = angles.iter().copied().fold(f64::INFINITY, f64::min);
    if m.is_finite() {
        m
    } else {
        0.0
    }
}

/// The refusal of three clicks on one line of the image (the viewer's Shift+clicks and
/// `--points`).
pub const COLLINEAR_CLICKS: &str =
    "the three points lie on one line in the image (collinear), so their plane would pass \
     through the camera; pick the third point off that line";

/// Whether three image points lie on one line (within a tenth of a pixel of it).
/// Back-projected, such points span a plane through the camera.
pub fn image_collinear(p: &[DVec2]) -> bool {
    let (a, b) = (p[1] - p[0], p[2] - p[0]);
    let longest = a.length().max(b.length()).max((p[2] - p[1]).length());
    longest == 0.0 || a.perp_dot(b).abs() / longest <= 0.1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::intrinsics;
    use crate::lightfield::{DepthKind, DepthMap};
    use glam::DMat3;

    fn camera() -> Camera {
        Camera::from_centre(
            intrinsics(50.0, 50.0, 19.5, 19.5),
            DMat3::from_rotation_y(0.1),
            DVec3::new(0.05, 0.0, 0.0),
        )
    }

    /// 40×40 view of the plane n·X = n·p (world), with the top-left 10×10 corner invalid.
    fn plane_view(p: DVec3, n: DVec3) -> ViewDepth {
        let cam = camera();
        let mut values = Vec::new();
        for y in 0..40 {
            for x in 0..40 {
                let (o, dir) = (
                    cam.centre(),
                    cam.r.transpose() * cam.ray_camera(DVec2::new(x as f64, y as f64)),
                );
                let t = n.dot(p - o) / n.dot(dir);
                values.push(if x < 10 && y < 10 { f32::NAN } else { t as f32 });
            }
        }
        let map = DepthMap {
            width: 40,
            height: 40,
            kind: DepthKind::Depth,
            values,
            source: "plane map".into(),
            estimated: false,
        };
        ViewDepth::new(cam, &map, None, None, 0).unwrap()
    }

    fn angle(a: DVec3, b: DVec3) -> f64 {
        a.dot(b).abs().clamp(0.0, 1.0).acos().to_degrees()
    }

    #[test]
    fn a_click_on_a_plane_finds_it() {
        let n = DVec3::new(0.2, -0.4, -1.0).normalize();
        let p = DVec3::new(0.0, 0.0, 3.0);
        let depth = plane_view(p, n);
        let pick = click(&depth, 25.0, 30.2, &NormalParams::default()).unwrap();
        assert_eq!(pick.method, PickMethod::Click);
        assert_eq!(pick.pixels, vec![(25, 30)]);
        assert!(angle(pick.plane.normal, n) < 1e-5);
        assert!(
            Plane::new(p, n)
                .unwrap()
                .signed_distance(pick.plane.point)
                .abs()
                < 1e-5
        );
        assert!(pick.confidence > 0.999);
        // Facing the camera.
        assert!(pick.plane.signed_distance(camera().centre()) > 0.0);
    }

    #[test]
    fn click_refusals_name_the_cause() {
        let depth = plane_view(DVec3::new(0.0, 0.0, 3.0), -DVec3::Z);
        let params = NormalParams::default();
        let err = click(&depth, 3.0, 3.0, &params).unwrap_err().to_string();
        assert!(
            err.contains("no usable depth") && err.contains("NaN"),
            "{err}"
        );
        let err = click(&depth, 40.0, 3.0, &params).unwrap_err().to_string();
        assert!(err.contains("outside"), "{err}");
        // Next to the invalid corner: too few valid neighbours for a 21-px window.
        let wide = NormalParams {
            min_fraction: 0.9,
            ..params.with_window(21)
        };
        let err = click(&depth, 12.0, 12.0, &wide).unwrap_err().to_string();
        assert!(
            err.contains("no reliable normal") && err.contains("neighbours"),
            "{err}"
        );
        let err = click(&depth, 20.0, 20.0, &params.with_window(4)).unwrap_err();
        assert!(err.to_string().contains("odd"), "{err}");
    }

    #[test]
    fn three_clicks_and_three_points_find_the_plane() {
        let n = DVec3::new(-0.3, 0.1, -1.0).normalize();
        let p = DVec3::new(0.1, 0.2, 2.5);
        let depth = plane_view(p, n);
        let pick = three_clicks(
            &depth,
            [
                DVec2::new(12.0, 12.0),
                DVec2::new(35.0, 14.0),
                DVec2::new(20.0, 36.0),
            ],
        )
        .unwrap();
        assert_eq!(pick.method, PickMethod::ThreePoints);
        assert!(angle(pick.plane.normal, n) < 1e-4);
        assert!(pick.confidence > 0.5 && pick.confidence <= 1.0);
        assert_eq!(pick.pixels.len(), 3);
        let pts = [
            DVec3::new(0.0, 0.0, 2.0),
            DVec3::new(1.0, 0.0, 2.0),
            DVec3::new(0.5, 3f64.sqrt() / 2.0, 2.0),
        ];
        let pick = three_points(pts, &camera()).unwrap();
        assert_eq!(pick.method, PickMethod::ThreePoints3d);
        assert!((pick.confidence - 1.0).abs() < 1e-12);
        assert!((pick.min_angle_deg.unwrap() - 60.0).abs() < 1e-9);
        assert!(pick.plane.signed_distance(camera().centre()) > 0.0);
    }

    #[test]
    fn degenerate_point_sets_are_refused() {
        let cam = camera();
        let a = DVec3::new(0.0, 0.0, 2.0);
        let b = DVec3::new(1.0, 0.0, 2.0);
        let err = three_points([a, a, b], &cam).unwrap_err().to_string();
        assert!(err.contains("coincide"), "{err}");
        let err = three_points([a, b, DVec3::new(2.0, 1e-8, 2.0)], &cam)
            .unwrap_err()
            .to_string();
        assert!(err.contains("collinear"), "{err}");
        let err = three_points([a, b, DVec3::NAN], &cam)
            .unwrap_err()
            .to_string();
        assert!(err.contains("finite"), "{err}");
        // Three clicks on the same pixel are coincident points.
        let depth = plane_view(DVec3::new(0.0, 0.0, 3.0), -DVec3::Z);
        let q = DVec2::new(20.0, 20.0);
        let err = three_clicks(&depth, [q, q, DVec2::new(30.0, 30.0)]).unwrap_err();
        assert!(err.to_string().contains("coincide"), "{err}");
        let err =
            three_clicks(&depth, [q, DVec2::new(1.0, 1.0), DVec2::new(30.0, 30.0)]).unwrap_err();
        assert!(err.to_string().contains("point 2"), "{err}");
    }

    #[test]
    fn nudges_act_in_the_keyboard_definition() {
        let cam = camera();
        let plane = Plane::from_focus_tilt_swing(&cam, 3.0, 10.0, -5.0).unwrap();
        let nudge = Nudge {
            distance: 0.5,
            tilt_deg: 4.0,
            swing_deg: 2.0,
        };
        let (nudged, applied) = nudge_plane(&plane, &cam, nudge).unwrap();
        let expected = Plane::from_focus_tilt_swing(&cam, 3.5, 14.0, -3.0).unwrap();
        assert!((nudged.normal - expected.normal).length() < 1e-12);
        assert!(expected.signed_distance(nudged.point).abs() < 1e-12);
        assert!((applied.before.distance - 3.0).abs() < 1e-12);
        assert!((applied.after.tilt_deg - 14.0).abs() < 1e-9);
        // A zero nudge returns the same plane.
        let (same, _) = nudge_plane(&plane, &cam, Nudge::default()).unwrap();
        assert!((same.normal - plane.normal).length() < 1e-12);
        assert!(plane.signed_distance(same.point).abs() < 1e-12);
    }

    #[test]
    fn invalid_nudges_are_refused_with_a_message() {
        let cam = camera();
        let plane = Plane::from_focus_tilt_swing(&cam, 3.0, 80.0, 0.0).unwrap();
        let too_far = Nudge {
            tilt_deg: 15.0,
            ..Default::default()
        };
        let err = nudge_plane(&plane, &cam, too_far).unwrap_err().to_string();
        assert!(err.contains("tilt") && err.contains("90"), "{err}");
        let behind = Nudge {
            distance: -4.0,
            ..Default::default()
        };
        let err = nudge_plane(&plane, &cam, behind).unwrap_err().to_string();
        assert!(err.contains("distance"), "{err}");
        // A plane containing the optical axis has no keyboard definition.
        let edge_on = Plane::new(cam.centre(), cam.r.transpose() * DVec3::X).unwrap();
        let err = nudge_plane(&edge_on, &cam, Nudge::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("optical axis"), "{err}");
        let nan = Nudge {
            distance: f64::NAN,
            ..Default::default()
        };
        let err = nudge_plane(&plane, &cam, nan).unwrap_err().to_string();
        assert!(err.contains("--nudge-distance"), "{err}");
        let inf = Nudge {
            tilt_deg: f64::INFINITY,
            ..Default::default()
        };
        let err = nudge_plane(&plane, &cam, inf).unwrap_err().to_string();
        assert!(
            err.contains("--nudge-tilt") && !err.contains("Nudge {"),
            "{err}"
        );
    }
}
