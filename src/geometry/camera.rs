//! Pinhole cameras.
//!
//! Conventions (binding everywhere in tiltfield):
//! - world → camera: `X_c = R X + t`; camera centre `C = −Rᵀ t`;
//! - camera axes: x right, y down, z forward (the optical axis);
//! - intrinsics `K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]` in pixel-index coordinates: the
//!   centre of pixel (i, j) is at (i, j), so an image of width W spans [−0.5, W − 0.5].
//!
//! All maths is f64 (`glam::D*`); the GPU receives f32 copies of derived matrices only.

use glam::{DMat3, DQuat, DVec2, DVec3};

/// A pinhole camera: intrinsics `k`, rotation `r` and translation `t` (world → camera).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub k: DMat3,
    pub r: DMat3,
    pub t: DVec3,
}

/// Intrinsic matrix from focal lengths and principal point (pixel-index coordinates).
pub fn intrinsics(fx: f64, fy: f64, cx: f64, cy: f64) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(fx, 0.0, 0.0),
        DVec3::new(0.0, fy, 0.0),
        DVec3::new(cx, cy, 1.0),
    )
}

impl Camera {
    /// A camera from intrinsics, rotation and its centre in world coordinates.
    pub fn from_centre(k: DMat3, r: DMat3, centre: DVec3) -> Self {
        Camera {
            k,
            r,
            t: -(r * centre),
        }
    }

    /// Camera centre in world coordinates, `C = −Rᵀ t`.
    pub fn centre(&self) -> DVec3 {
        -(self.r.transpose() * self.t)
    }

    /// World point → camera frame.
    pub fn to_camera(&self, x: DVec3) -> DVec3 {
        self.r * x + self.t
    }

    /// Camera frame → world point.
    pub fn to_world(&self, xc: DVec3) -> DVec3 {
        self.r.transpose() * (xc - self.t)
    }

    /// Projects a world point to pixel coordinates; `None` when it is not in front of the
    /// camera (z ≤ 0).
    pub fn project(&self, x: DVec3) -> Option<DVec2> {
        let p = self.k * self.to_camera(x);
        (p.z > 0.0).then(|| DVec2::new(p.x / p.z, p.y / p.z))
    }

    /// Direction (camera frame, z = 1) of the ray through pixel `pixel`: `K⁻¹ [u, v, 1]ᵀ`.
    pub fn ray_camera(&self, pixel: DVec2) -> DVec3 {
        self.k.inverse() * pixel.extend(1.0)
    }

    /// Back-projects pixel `(u, v)` with depth `z` (distance along the optical axis):
    /// `X = z K⁻¹ [u, v, 1]ᵀ` in the camera frame, returned in world coordinates.
    pub fn back_project(&self, pixel: DVec2, z: f64) -> DVec3 {
        self.to_world(self.ray_camera(pixel) * z)
    }

    /// Focal length in pixels along x (`fx`).
    pub fn focal_px(&self) -> f64 {
        self.k.x_axis.x
    }
}

/// Bilinear interpolation of cameras on a grid cell: `c00` at (0,0), `c10` at (1,0), `c01` at
/// (0,1), `c11` at (1,1); `(fs, ft)` in [0, 1]. Centres and intrinsics interpolate linearly,
/// rotations by quaternion slerp, so a virtual camera between calibrated, rotated cameras stays
/// a rigid pinhole.
pub fn interpolate_cameras(
    c00: &Camera,
    c10: &Camera,
    c01: &Camera,
    c11: &Camera,
    fs: f64,
    ft: f64,
) -> Camera {
    let lerp3 = |a: DVec3, b: DVec3, f: f64| a + (b - a) * f;
    let lerp_m = |a: DMat3, b: DMat3, f: f64| {
        DMat3::from_cols(
            lerp3(a.x_axis, b.x_axis, f),
            lerp3(a.y_axis, b.y_axis, f),
            lerp3(a.z_axis, b.z_axis, f),
        )
    };
    let q = |c: &Camera| DQuat::from_mat3(&c.r).normalize();
    let slerp = |a: DQuat, b: DQuat, f: f64| {
        // Take the short way round: q and −q are the same rotation.
        let b = if a.dot(b) < 0.0 { -b } else { b };
        a.slerp(b, f)
    };
    let centre = lerp3(
        lerp3(c00.centre(), c10.centre(), fs),
        lerp3(c01.centre(), c11.centre(), fs),
        ft,
    );
    let k = lerp_m(lerp_m(c00.k, c10.k, fs), lerp_m(c01.k, c11.k, fs), ft);
    let r = slerp(slerp(q(c00), q(c10), fs), slerp(q(c01), q(c11), fs), ft);
    Camera::from_centre(k, DMat3::from_quat(r), centre)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_camera() -> Camera {
        Camera::from_centre(
            intrinsics(100.0, 110.0, 31.5, 23.5),
            DMat3::from_euler(glam::EulerRot::XYZ, 0.1, -0.2, 0.05),
            DVec3::new(0.3, -0.1, -2.0),
        )
    }

    #[test]
    fn centre_round_trips_through_translation() {
        let c = test_camera();
        assert!((c.centre() - DVec3::new(0.3, -0.1, -2.0)).length() < 1e-12);
        assert!(c.to_camera(c.centre()).length() < 1e-12);
    }

    #[test]
    fn back_projection_inverts_projection() {
        let c = test_camera();
        let px = DVec2::new(12.25, 40.75);
        let x = c.back_project(px, 3.5);
        assert!((c.to_camera(x).z - 3.5).abs() < 1e-12);
        assert!((c.project(x).unwrap() - px).length() < 1e-9);
    }

    #[test]
    fn points_behind_do_not_project() {
        let c = test_camera();
        let behind = c.back_project(DVec2::new(10.0, 10.0), -1.0);
        assert!(c.project(behind).is_none());
    }

    #[test]
    fn interpolation_hits_corners_and_midpoints() {
        let a = test_camera();
        let mut b = a;
        b.t += DVec3::new(1.0, 0.0, 0.0);
        let m = interpolate_cameras(&a, &b, &a, &b, 0.5, 0.3);
        assert!((m.centre() - (a.centre() + b.centre()) * 0.5).length() < 1e-12);
        let m0 = interpolate_cameras(&a, &b, &a, &b, 0.0, 0.0);
        assert!((m0.r - a.r).abs_diff_eq(DMat3::ZERO, 1e-12));
        assert!((m0.centre() - a.centre()).length() < 1e-12);
    }
}
