//! Refocus planes Λ = { X : n·X = n·p } (world point p, unit normal n) and the ways to define
//! one: point + normal, three points, or focus distance + tilt + swing relative to a camera.
//!
//! Tilt and swing (keyboard definition): starting from the frontoparallel normal n = (0, 0, 1)
//! of the reference camera, the camera-frame normal is
//! `n_c = (−sin(swing)·cos(tilt), sin(tilt), cos(swing)·cos(tilt))`, i.e. `R_y(−swing) R_x(−tilt) ẑ`.
//! Positive tilt turns the plane so that the top of the image is farther away (a floor, the
//! classic Scheimpflug use); positive swing makes the right side farther. Both are in (−90°, 90°).

use glam::DVec3;

use super::camera::Camera;
use crate::error::{Error, Result};

/// A plane with a world point and a unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub point: DVec3,
    pub normal: DVec3,
}

impl Plane {
    /// `{"point": [x, y, z], "normal": [x, y, z]}`: a plane as every report writes it.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({"point": self.point.to_array(), "normal": self.normal.to_array()})
    }

    /// A plane through `point` with normal `normal` (normalised here). Refuses non-finite input
    /// and a zero normal.
    pub fn new(point: DVec3, normal: DVec3) -> Result<Self> {
        if !point.is_finite() || !normal.is_finite() {
            return Err(Error::Geometry(format!(
                "plane point {point} or normal {normal} is not finite"
            )));
        }
        let len = normal.length();
        if len < 1e-12 {
            return Err(Error::Geometry(
                "plane normal has zero length; give a non-zero normal".into(),
            ));
        }
        Ok(Plane {
            point,
            normal: normal / len,
        })
    }

    /// The plane through three points. `scale` is the scene's length scale (e.g. the distance
    /// of the points from the camera); points closer than `1e-9·scale` count as coincident, and
    /// a triangle whose smallest angle is below 0.01° counts as collinear, because its normal
    /// is then dominated by measurement noise.
    pub fn from_points(a: DVec3, b: DVec3, c: DVec3, scale: f64) -> Result<Self> {
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            return Err(Error::Geometry("a plane point is not finite".into()));
        }
        let eps = 1e-9 * scale.abs().max(f64::MIN_POSITIVE);
        let edges = [b - a, c - b, a - c];
        if edges.iter().any(|e| e.length() <= eps) {
            return Err(Error::Geometry(
                "two of the three plane points coincide; pick three distinct points".into(),
            ));
        }
        let n = (b - a).cross(c - a);
        // sin of the smallest angle = 2·area / (product of the two longest edges) ≥ |n| / max².
        let longest = edges.iter().map(|e| e.length()).fold(0.0, f64::max);
        let sin_min = n.length() / (longest * longest);
        if sin_min < 0.01f64.to_radians().sin() {
            return Err(Error::Geometry(
                "the three plane points are (nearly) collinear; pick points spread over the surface"
                    .into(),
            ));
        }
        Plane::new(a, n)
    }

    /// The keyboard definition: a point on the camera's optical axis at distance `distance`,
    /// normal from `tilt_deg` and `swing_deg` (see the module docs for the convention).
    pub fn from_focus_tilt_swing(
        camera: &Camera,
        distance: f64,
        tilt_deg: f64,
        swing_deg: f64,
    ) -> Result<Self> {
        if !(distance.is_finite() && distance > 0.0) {
            return Err(Error::Geometry(format!(
                "focus distance must be positive and finite, got {distance}"
            )));
        }
        for (name, v) in [("tilt", tilt_deg), ("swing", swing_deg)] {
            if !(v.is_finite() && v.abs() < 90.0) {
                return Err(Error::Geometry(format!(
                    "{name} must lie strictly between −90° and 90°, got {}°",
                    crate::error::compact(v)
                )));
            }
        }
        let p = camera.to_world(DVec3::new(0.0, 0.0, distance));
        let n_c = tilt_swing_normal(tilt_deg, swing_deg);
        Plane::new(p, camera.r.transpose() * n_c)
    }

    /// Tilt, swing (degrees) and on-axis distance of this plane seen from `camera`: the inverse
    /// of [`Plane::from_focus_tilt_swing`]. `None` when the optical axis does not meet the plane
    /// in front of the camera or the normal is edge-on.
    pub fn to_focus_tilt_swing(&self, camera: &Camera) -> Option<(f64, f64, f64)> {
        let mut n_c = camera.r * self.normal;
        if n_c.z < 0.0 {
            n_c = -n_c;
        }
        if n_c.z <= 1e-12 {
            return None;
        }
        let d = n_c.dot(camera.to_camera(self.point));
        let distance = d / n_c.z;
        if distance.is_nan() || distance <= 0.0 {
            return None;
        }
        let tilt = n_c.y.clamp(-1.0, 1.0).asin().to_degrees();
        let swing = (-n_c.x).atan2(n_c.z).to_degrees();
        Some((distance, tilt, swing))
    }

    /// Signed distance of `x` from the plane (positive on the normal's side).
    pub fn signed_distance(&self, x: DVec3) -> f64 {
        self.normal.dot(x - self.point)
    }
}

/// Camera-frame normal for tilt and swing in degrees (see the module docs).
pub fn tilt_swing_normal(tilt_deg: f64, swing_deg: f64) -> DVec3 {
    let (st, ct) = tilt_deg.to_radians().sin_cos();
    let (ss, cs) = swing_deg.to_radians().sin_cos();
    DVec3::new(-ss * ct, st, cs * ct)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::intrinsics;
    use glam::DMat3;

    fn cam() -> Camera {
        Camera::from_centre(
            intrinsics(200.0, 200.0, 63.5, 63.5),
            DMat3::from_rotation_y(0.2) * DMat3::from_rotation_x(-0.1),
            DVec3::new(0.1, 0.2, -0.3),
        )
    }

    #[test]
    fn focus_tilt_swing_round_trips() {
        let c = cam();
        for &(z, tilt, swing) in &[(2.0, 0.0, 0.0), (3.5, 30.0, -20.0), (0.7, -75.0, 60.0)] {
            let p = Plane::from_focus_tilt_swing(&c, z, tilt, swing).unwrap();
            let (z2, t2, s2) = p.to_focus_tilt_swing(&c).unwrap();
            assert!((z - z2).abs() < 1e-9 * z, "{z} vs {z2}");
            assert!((tilt - t2).abs() < 1e-9, "{tilt} vs {t2}");
            assert!((swing - s2).abs() < 1e-9, "{swing} vs {s2}");
        }
    }

    #[test]
    fn positive_tilt_pushes_the_top_of_the_image_away() {
        let c = Camera::from_centre(
            intrinsics(100.0, 100.0, 50.0, 50.0),
            DMat3::IDENTITY,
            DVec3::ZERO,
        );
        let p = Plane::from_focus_tilt_swing(&c, 2.0, 20.0, 0.0).unwrap();
        // Depth of the plane along rays through the top (y < 0) and bottom of the optical axis.
        let depth_at = |y: f64| {
            let dir = DVec3::new(0.0, y, 1.0);
            p.normal.dot(p.point) / p.normal.dot(dir)
        };
        assert!(depth_at(-0.2) > depth_at(0.2));
        let p = Plane::from_focus_tilt_swing(&c, 2.0, 0.0, 20.0).unwrap();
        let depth_x = |x: f64| p.normal.dot(p.point) / p.normal.dot(DVec3::new(x, 0.0, 1.0));
        assert!(
            depth_x(0.2) > depth_x(-0.2),
            "positive swing: right side farther"
        );
    }

    #[test]
    fn three_points_define_the_plane_through_them() {
        let (a, b, c) = (
            DVec3::new(0.0, 0.0, 2.0),
            DVec3::new(1.0, 0.0, 3.0),
            DVec3::new(0.0, 1.0, 2.5),
        );
        let p = Plane::from_points(a, b, c, 3.0).unwrap();
        for x in [a, b, c] {
            assert!(p.signed_distance(x).abs() < 1e-12);
        }
        assert!((p.normal.length() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn collinear_and_coincident_points_are_refused() {
        let a = DVec3::new(0.0, 0.0, 2.0);
        let b = DVec3::new(1.0, 0.0, 2.0);
        let err = Plane::from_points(a, b, DVec3::new(2.0, 1e-7, 2.0), 2.0).unwrap_err();
        assert!(err.to_string().contains("collinear"), "{err}");
        let err = Plane::from_points(a, a, b, 2.0).unwrap_err();
        assert!(err.to_string().contains("coincide"), "{err}");
    }

    #[test]
    fn degenerate_definitions_are_refused() {
        assert!(Plane::new(DVec3::ZERO, DVec3::ZERO).is_err());
        assert!(Plane::new(DVec3::NAN, DVec3::Z).is_err());
        let c = cam();
        assert!(Plane::from_focus_tilt_swing(&c, -1.0, 0.0, 0.0).is_err());
        assert!(Plane::from_focus_tilt_swing(&c, 1.0, 90.0, 0.0).is_err());
        assert!(Plane::from_focus_tilt_swing(&c, f64::INFINITY, 0.0, 0.0).is_err());
    }
}
