//! Per-view refocus homographies (generalized shift-and-sum, Alain et al. 2019;
//! docs/conventions.md §3–5).
//!
//! For a refocus plane Λ (world point p, unit normal n) and reference camera r, view i gets
//!
//! ```text
//! n_r = R_r n,   d_r = n·(p − C_r)
//! H_i = K_i ( R_i R_rᵀ + (R_i C_r + t_i) n_rᵀ / d_r ) K_r⁻¹
//! ```
//!
//! tiltfield stores H_i split as `H_i = A_i + b_i mᵀ` with the view part
//! `A_i = K_i R_i R_rᵀ K_r⁻¹` (the homography of the plane at infinity), `b_i = K_i (R_i C_r + t_i)`
//! (view i's image of the reference centre) and the plane part shared by all views,
//! `m = K_r⁻ᵀ n_r / d_r`. For an output pixel x (homogeneous, z = 1), `m·x = (n_r·K_r⁻¹x)/d_r`
//! is the inverse depth at which the pixel's ray meets the plane: positive in front of the
//! reference camera, ≤ 0 when the plane is behind it or parallel to the ray.
//!
//! **Horizon rule.** A steeply tilted plane's horizon can cross the image; past it a ray meets
//! no in-focus point. tiltfield focuses such pixels at infinity: it samples view i at
//! `A_i x + b_i·max(m·x, 0)`. That is exact where the plane is in front and continuous across
//! the horizon, since the plane's depth → ∞ as m·x → 0⁺.
//!
//! **Masks.** A sample `y = (y₀, y₁, y₂)` is used only when `y₂ > 0` (the point is in front of
//! camera i: y₂ is its depth there divided by the positive ray parameter) and the pixel position
//! `(y₀/y₂, y₁/y₂)` lies inside the view, `[−0.5, W − 0.5] × [−0.5, H − 0.5]`.

use glam::{DMat3, DVec2, DVec3};

use super::camera::Camera;
use super::plane::Plane;
use crate::error::{Error, Result};

/// The view-dependent part of a refocus warp: `H = a + b mᵀ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewWarp {
    pub a: DMat3,
    pub b: DVec3,
}

impl ViewWarp {
    /// View part for `view` relative to `reference` (see module docs).
    pub fn new(view: &Camera, reference: &Camera) -> Self {
        let a = view.k * view.r * reference.r.transpose() * reference.k.inverse();
        let b = view.k * (view.r * reference.centre() + view.t);
        ViewWarp { a, b }
    }

    /// Classic shift-and-sum: sample at `x + (dx, dy)`.
    pub fn translation(dx: f64, dy: f64) -> Self {
        ViewWarp {
            a: DMat3::from_cols(DVec3::X, DVec3::Y, DVec3::new(dx, dy, 1.0)),
            b: DVec3::ZERO,
        }
    }

    /// The full homography `a + b mᵀ` for plane term `m`.
    pub fn homography(&self, m: DVec3) -> DMat3 {
        self.a + outer(self.b, m)
    }

    /// Homogeneous sample position for output pixel `x` with the horizon rule applied.
    pub fn apply(&self, m: DVec3, x: DVec2) -> DVec3 {
        let xh = x.extend(1.0);
        self.a * xh + self.b * m.dot(xh).max(0.0)
    }
}

/// `u vᵀ`.
fn outer(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x, u * v.y, u * v.z)
}

/// The plane term `m = K_r⁻ᵀ n_r / d_r`. Refuses a plane through (or within `min_distance` of)
/// the reference camera centre, where every ray meets the plane at the centre itself.
pub fn plane_term(reference: &Camera, plane: &Plane, min_distance: f64) -> Result<DVec3> {
    let d_r = reference_distance(reference, plane, min_distance)?;
    let n_r = reference.r * plane.normal;
    Ok(reference.k.inverse().transpose() * n_r / d_r)
}

/// Signed distance `d_r = n·(p − C_r)` of the plane from the reference centre; refuses
/// `|d_r| ≤ min_distance` (and NaN).
fn reference_distance(reference: &Camera, plane: &Plane, min_distance: f64) -> Result<f64> {
    let d_r = plane.normal.dot(plane.point - reference.centre());
    if d_r.is_nan() || d_r.abs() <= min_distance {
        return Err(Error::Geometry(format!(
            "the refocus plane passes through the reference camera centre (distance {d_r:.3e}); \
             move the plane or the reference view"
        )));
    }
    Ok(d_r)
}

/// The homography of docs/conventions.md §3 in its direct form, for tests and reports.
pub fn homography(
    view: &Camera,
    reference: &Camera,
    plane: &Plane,
    min_distance: f64,
) -> Result<DMat3> {
    let d_r = reference_distance(reference, plane, min_distance)?;
    let n_r = reference.r * plane.normal;
    let inner =
        view.r * reference.r.transpose() + outer(view.r * reference.centre() + view.t, n_r) / d_r;
    Ok(view.k * inner * reference.k.inverse())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::intrinsics;

    fn rotated_pair() -> (Camera, Camera) {
        let r = Camera::from_centre(
            intrinsics(300.0, 310.0, 64.0, 48.0),
            DMat3::from_rotation_y(0.05),
            DVec3::new(0.0, 0.0, 0.0),
        );
        let v = Camera::from_centre(
            intrinsics(290.0, 295.0, 60.0, 50.0),
            DMat3::from_rotation_y(-0.1) * DMat3::from_rotation_x(0.03),
            DVec3::new(0.2, -0.05, 0.02),
        );
        (r, v)
    }

    #[test]
    fn split_form_equals_direct_form() {
        let (r, v) = rotated_pair();
        let plane = Plane::new(DVec3::new(0.1, 0.0, 3.0), DVec3::new(0.2, -0.3, 1.0)).unwrap();
        let h = homography(&v, &r, &plane, 1e-9).unwrap();
        let m = plane_term(&r, &plane, 1e-9).unwrap();
        let h2 = ViewWarp::new(&v, &r).homography(m);
        assert!((h - h2).abs_diff_eq(
            DMat3::ZERO,
            1e-9 * h.abs().to_cols_array().iter().cloned().fold(0.0, f64::max)
        ));
    }

    #[test]
    fn plane_points_map_to_their_projections() {
        let (r, v) = rotated_pair();
        let plane = Plane::new(DVec3::new(0.1, 0.0, 3.0), DVec3::new(0.2, -0.3, 1.0)).unwrap();
        let m = plane_term(&r, &plane, 1e-9).unwrap();
        let w = ViewWarp::new(&v, &r);
        for px in [
            DVec2::new(5.0, 7.0),
            DVec2::new(100.0, 80.0),
            DVec2::new(64.0, 48.0),
        ] {
            // Intersect the reference ray with the plane, project into the view.
            let dir = r.r.transpose() * r.ray_camera(px);
            let lambda = plane.normal.dot(plane.point - r.centre()) / plane.normal.dot(dir);
            assert!(lambda > 0.0);
            let x = r.centre() + dir * lambda;
            let expected = v.project(x).unwrap();
            let y = w.apply(m, px);
            assert!(y.z > 0.0);
            assert!((DVec2::new(y.x / y.z, y.y / y.z) - expected).length() < 1e-9);
        }
    }

    #[test]
    fn frontoparallel_plane_is_classic_shift_and_sum() {
        // Parallel cameras with equal focal lengths: H_i is a pure translation by
        // f·(C_r − C_i)/Z, i.e. classic shift-and-sum with δ = f·b/Z per grid step.
        let f = 250.0;
        let k = intrinsics(f, f, 31.5, 31.5);
        let r = Camera::from_centre(k, DMat3::IDENTITY, DVec3::ZERO);
        let b = 0.1;
        let z = 4.0;
        let plane = Plane::new(DVec3::new(0.0, 0.0, z), DVec3::Z).unwrap();
        let m = plane_term(&r, &plane, 1e-9).unwrap();
        for (s, t) in [(-2.0, -1.0), (1.0, 2.0), (0.0, 0.0)] {
            let v = Camera::from_centre(k, DMat3::IDENTITY, DVec3::new(s * b, t * b, 0.0));
            let h = ViewWarp::new(&v, &r).homography(m);
            let delta = -f * b / z;
            let classic = ViewWarp::translation(s * delta, t * delta).a;
            assert!(
                (h - classic).abs_diff_eq(DMat3::ZERO, 1e-12),
                "{h} vs {classic}"
            );
        }
    }

    #[test]
    fn plane_through_reference_centre_is_refused() {
        let (r, _) = rotated_pair();
        let plane = Plane::new(r.centre(), DVec3::new(1.0, 0.0, 0.0)).unwrap();
        let err = plane_term(&r, &plane, 1e-6).unwrap_err();
        assert!(err
            .to_string()
            .contains("passes through the reference camera"));
    }

    #[test]
    fn horizon_rule_is_continuous_and_finite() {
        // A floor plane seen at a grazing angle: its horizon crosses the image.
        let k = intrinsics(100.0, 100.0, 50.0, 50.0);
        let r = Camera::from_centre(k, DMat3::IDENTITY, DVec3::ZERO);
        let v = Camera::from_centre(k, DMat3::IDENTITY, DVec3::new(0.1, 0.0, 0.0));
        let floor = Plane::new(DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, -1.0, 0.0)).unwrap();
        let m = plane_term(&r, &floor, 1e-9).unwrap();
        let w = ViewWarp::new(&v, &r);
        let inf = ViewWarp {
            a: w.a,
            b: DVec3::ZERO,
        };
        // Rows above the principal point look at the sky: exactly the infinity mapping.
        let above = w.apply(m, DVec2::new(10.0, 20.0));
        assert_eq!(above, inf.apply(m, DVec2::new(10.0, 20.0)));
        // Just below the horizon the mapping approaches the infinity mapping.
        let below = w.apply(m, DVec2::new(10.0, 50.0 + 1e-6));
        let at_inf = inf.apply(m, DVec2::new(10.0, 50.0 + 1e-6));
        assert!((below / below.z - at_inf / at_inf.z).length() < 1e-5);
        assert!(below.is_finite() && above.is_finite());
    }
}
