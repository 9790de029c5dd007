//! The scene panel's camera: orbits a target point (left drag), pans (right or middle drag),
//! zooms (scroll) within limits that keep the scene in view (the target stays within the
//! framed scene's reach of where it started; the distance within [`ZOOM_IN_LIMIT`] and
//! [`ZOOM_OUT_LIMIT`] of the start's), and starts over the reference camera's shoulder so the scene panel shows
//! what the refocus panel shows, from a little behind and above. It is an ordinary tiltfield
//! [`Camera`] (x right, y down, z forward), so projection, picking and the GPU matrix share one
//! convention. Pure f64 maths.

use glam::{DMat3, DQuat, DVec2, DVec3};

use crate::geometry::camera::{intrinsics, Camera};
use crate::passes::raster::{camera_from_world, projection_rows, Projection};

/// Vertical field of view of the scene panel, degrees.
pub const FOV_DEG: f64 = 50.0;
/// Turn of a drag across the whole panel, radians: orbit speed follows the panel's size, so
/// the same hand movement turns a small and a large panel alike.
pub const ORBIT_RAD_PER_PANEL: f64 = std::f64::consts::PI;
/// The closest and farthest the scene camera may get, as fractions of its start distance.
pub const ZOOM_IN_LIMIT: f64 = 1.0 / 64.0;
pub const ZOOM_OUT_LIMIT: f64 = 8.0;
/// Share of the scene panel's width the camera array should span at the start (the framing
/// stops narrowing its angle once it does).
pub const ARRAY_SPAN: f64 = 0.12;
/// Distance factor per scroll step.
const ZOOM_PER_STEP: f64 = 0.9;

/// An orbiting camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbitCamera {
    /// World axes of the reference camera: right, down, forward (the orbit's frame).
    basis: DMat3,
    pub target: DVec3,
    pub distance: f64,
    /// Turn about the frame's vertical axis, radians (positive: the view swings right).
    pub yaw: f64,
    /// Turn about the frame's right axis, radians (positive: looking down on the target).
    pub pitch: f64,
    /// Where the target started and how far it may pan from there (the framed scene's
    /// reach), and the start distance (zoom limits are relative to it).
    home: DVec3,
    reach: f64,
    start_distance: f64,
}

impl OrbitCamera {
    /// Looking at `target` from over the shoulder of `reference`: behind it, a little above and
    /// to the side, far enough back that the reference camera is in view.
    pub fn over_shoulder(reference: &Camera, target: DVec3) -> Self {
        let basis = reference.r.transpose();
        let reach = (target - reference.centre()).length().max(1e-6);
        OrbitCamera {
            basis,
            target,
            distance: 1.8 * reach,
            yaw: 12f64.to_radians(),
            pitch: 12f64.to_radians(),
            home: target,
            reach,
            start_distance: 1.8 * reach,
        }
    }

    /// This camera as the start of its limits: pans stay within `reach` of its target, zooms
    /// within [`ZOOM_IN_LIMIT`]..[`ZOOM_OUT_LIMIT`] of its distance.
    fn homed(mut self, reach: f64) -> Self {
        self.home = self.target;
        self.reach = reach.max(1e-6);
        self.start_distance = self.distance;
        self
    }

    /// A start that shows the whole scene and the camera array: looking at `target` (the
    /// cloud's centre) from behind the reference camera, every point of `keep` (the cloud's
    /// box corners, the camera centres) inside a panel of `aspect` (width / height) with a
    /// margin, and the cameras in `array` as large as that allows. Over-the-shoulder angles
    /// from 12° down to ½° are tried and the distance is stepped by 10 %: the array is small
    /// next to the scene it films (backgammon's 0.24 m against 12 m), so a view from far
    /// behind shows it as a dot, while an eye just behind it, looking nearly along the optical
    /// axis, sees both the array at a readable size and the scene the array saw. Falls back to
    /// [`OrbitCamera::over_shoulder`] when no candidate keeps everything in view.
    pub fn framing(
        reference: &Camera,
        target: DVec3,
        keep: &[DVec3],
        array: &[DVec3],
        aspect: f64,
    ) -> Self {
        let fallback = OrbitCamera::over_shoulder(reference, target);
        let size = (((480.0 * aspect.clamp(0.25, 4.0)).round()) as u32, 480u32);
        let reach = (target - reference.centre()).length().max(1e-6);
        let inside = |o: &OrbitCamera, p: DVec3, margin: f64| {
            let c = o.camera(size);
            let q = c.k * (c.r * p + c.t);
            if q.z <= 1e-9 {
                return None;
            }
            let (x, y) = (q.x / q.z, q.y / q.z);
            let (w, h) = (size.0 as f64, size.1 as f64);
            (x >= margin * w
                && x <= (1.0 - margin) * w
                && y >= margin * h
                && y <= (1.0 - margin) * h)
                .then_some(x / w)
        };
        let mut best: Option<(f64, OrbitCamera)> = None;
        for angle in [12.0f64, 8.0, 5.0, 3.0, 2.0, 1.0, 0.5] {
            for k in -40..30 {
                let o = OrbitCamera {
                    distance: reach * 1.1f64.powi(k),
                    yaw: angle.to_radians(),
                    pitch: angle.to_radians(),
                    ..fallback
                };
                if !keep.iter().all(|&p| inside(&o, p, 0.04).is_some()) {
                    continue;
                }
                let xs: Vec<f64> = array.iter().filter_map(|&p| inside(&o, p, 0.0)).collect();
                if xs.len() != array.len() {
                    continue;
                }
                let span = xs.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
                    - xs.iter().fold(f64::INFINITY, |a, &b| a.min(b));
                // The first distance that keeps everything inside is the closest at this
                // angle: the array's largest view of it.
                if best.as_ref().map_or(true, |(s, _)| span > *s + 1e-9) {
                    best = Some((span, o));
                }
                // A readable array at the widest angle wins: the most 3-D look.
                break;
            }
            if best.as_ref().is_some_and(|(s, _)| *s >= ARRAY_SPAN) {
                break;
            }
        }
        // The scene's reach around the target: how far the kept points lie from it.
        let reach = keep
            .iter()
            .map(|p| (*p - target).length())
            .fold(reach, f64::max);
        best.map_or(fallback, |(_, o)| o).homed(reach)
    }

    fn rotation(&self) -> DQuat {
        let right = self.basis.x_axis;
        let down = self.basis.y_axis;
        // Yaw about "up" (−down) and pitch about right; the signs make positive values swing
        // right and look down.
        DQuat::from_axis_angle(-down, -self.yaw) * DQuat::from_axis_angle(right, -self.pitch)
    }

    /// The camera for a panel of `size` = (width, height) pixels.
    pub fn camera(&self, size: (u32, u32)) -> Camera {
        let q = self.rotation();
        let right = q * self.basis.x_axis;
        let down = q * self.basis.y_axis;
        let forward = q * self.basis.z_axis;
        let eye = self.target - forward * self.distance;
        let r = DMat3::from_cols(right, down, forward).transpose();
        let (w, h) = (size.0.max(1) as f64, size.1.max(1) as f64);
        let f = 0.5 * h / (0.5 * FOV_DEG.to_radians()).tan();
        let k = intrinsics(f, f, 0.5 * w - 0.5, 0.5 * h - 0.5);
        Camera::from_centre(k, r, eye)
    }

    /// Column-major clip-from-world matrix (reverse Z) for a panel of `size`.
    pub fn clip_from_world(&self, size: (u32, u32)) -> [f32; 16] {
        let c = self.camera(size);
        Projection::new(
            projection_rows(c.k, c.r, c.t),
            camera_from_world(c.r, c.t),
            size.0.max(1),
            size.1.max(1),
            DVec2::ZERO,
        )
        .clip_from_world
    }

    /// Orbit by a drag of `delta` pixels in a panel of `size`: a drag across the panel's
    /// width (height) turns by [`ORBIT_RAD_PER_PANEL`] about the vertical (horizontal) axis.
    pub fn orbit(&mut self, delta: DVec2, size: (u32, u32)) {
        let (w, h) = (size.0.max(1) as f64, size.1.max(1) as f64);
        self.yaw += delta.x * ORBIT_RAD_PER_PANEL / w;
        let limit = 89f64.to_radians();
        self.pitch = (self.pitch + delta.y * ORBIT_RAD_PER_PANEL / h).clamp(-limit, limit);
    }

    /// Pan so the scene follows a drag of `delta` pixels in a panel of `size`; the target
    /// stops at the framed scene's reach from where it started.
    pub fn pan(&mut self, delta: DVec2, size: (u32, u32)) {
        let c = self.camera(size);
        let per_px = self.distance / c.focal_px();
        let rt = c.r.transpose();
        let target = self.target - (rt.x_axis * delta.x + rt.y_axis * delta.y) * per_px;
        let off = target - self.home;
        self.target = self.home + off.clamp_length_max(self.reach);
    }

    /// Zoom by `steps` scroll steps (positive: closer), within the zoom limits.
    pub fn zoom(&mut self, steps: f64) {
        let (lo, hi) = (
            self.start_distance * ZOOM_IN_LIMIT,
            self.start_distance * ZOOM_OUT_LIMIT,
        );
        self.distance = (self.distance * ZOOM_PER_STEP.powf(steps)).clamp(lo, hi);
    }
}

/// The index of the point that `camera` sees within `tolerance` pixels of `pixel` and nearest
/// to the camera (what the user sees there), or `None`.
pub fn pick_point(
    camera: &Camera,
    pixel: DVec2,
    points: impl IntoIterator<Item = DVec3>,
    tolerance: f64,
) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (i, p) in points.into_iter().enumerate() {
        let z = camera.to_camera(p).z;
        if z <= 0.0 {
            continue;
        }
        let Some(q) = camera.project(p) else { continue };
        if (q - pixel).length() <= tolerance && best.map_or(true, |(_, bz)| z < bz) {
            best = Some((i, z));
        }
    }
    best.map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference() -> Camera {
        Camera::from_centre(
            intrinsics(100.0, 100.0, 49.5, 49.5),
            DMat3::IDENTITY,
            DVec3::ZERO,
        )
    }

    #[test]
    fn framing_keeps_the_scene_and_a_small_array_in_view_and_the_array_readable() {
        // A scene 8–12 m deep and 6 m wide filmed by a 9 × 9 array 3 cm apart (backgammon's
        // proportions): from far behind, the array would be a dot.
        let keep_box: Vec<DVec3> = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { -3.0 } else { 3.0 },
                    if i & 2 == 0 { -3.0 } else { 3.0 },
                    if i & 4 == 0 { 8.0 } else { 12.0 },
                )
            })
            .collect();
        let array: Vec<DVec3> = (0..81)
            .map(|i| {
                DVec3::new(
                    (i % 9) as f64 * 0.03 - 0.12,
                    (i / 9) as f64 * 0.03 - 0.12,
                    0.0,
                )
            })
            .collect();
        let mut keep = keep_box.clone();
        keep.extend(&array);
        let target = DVec3::new(0.0, 0.0, 10.0);
        for aspect in [0.9, 1.0, 1.6] {
            let o = OrbitCamera::framing(&reference(), target, &keep, &array, aspect);
            let size = ((480.0 * aspect) as u32, 480);
            let c = o.camera(size);
            let project = |p: DVec3| {
                let q = c.k * (c.r * p + c.t);
                assert!(q.z > 0.0);
                DVec2::new(q.x / q.z / size.0 as f64, q.y / q.z / size.1 as f64)
            };
            for p in &keep {
                let q = project(*p);
                assert!(
                    q.min_element() >= 0.0 && q.max_element() <= 1.0,
                    "{p} at {q}"
                );
            }
            let xs: Vec<f64> = array.iter().map(|&p| project(p).x).collect();
            let span = xs.iter().cloned().fold(f64::MIN, f64::max)
                - xs.iter().cloned().fold(f64::MAX, f64::min);
            assert!(span >= 0.1, "aspect {aspect}: the array spans {span}");
        }
        // The over-the-shoulder start (the fallback) shows the same array far smaller.
        let far = OrbitCamera::over_shoulder(&reference(), target).camera((480, 480));
        let x = |p: DVec3| {
            let q = far.k * (far.r * p + far.t);
            q.x / q.z / 480.0
        };
        assert!(x(array[8]) - x(array[0]) < 0.05);
    }

    #[test]
    fn over_the_shoulder_sees_the_target_centred_and_the_reference_camera() {
        let target = DVec3::new(0.0, 0.0, 5.0);
        let orbit = OrbitCamera::over_shoulder(&reference(), target);
        let c = orbit.camera((200, 100));
        let centre = c.project(target).unwrap();
        assert!(
            (centre - DVec2::new(99.5, 49.5)).length() < 1e-9,
            "{centre}"
        );
        // Behind and above the reference camera (y down: above is negative y).
        assert!(c.centre().z < 0.0 && c.centre().y < 0.0, "{}", c.centre());
        let seen = c.project(DVec3::ZERO).unwrap();
        assert!(
            seen.x > 0.0 && seen.x < 200.0 && seen.y > 0.0 && seen.y < 100.0,
            "{seen}"
        );
    }

    #[test]
    fn orbit_pan_and_zoom_move_the_view_as_a_user_expects() {
        let target = DVec3::new(0.0, 0.0, 5.0);
        let mut orbit = OrbitCamera::over_shoulder(&reference(), target);
        let size = (200, 100);
        let d0 = (orbit.camera(size).centre() - target).length();
        orbit.zoom(2.0);
        let d1 = (orbit.camera(size).centre() - target).length();
        assert!((d1 / d0 - 0.81).abs() < 1e-9);
        // Panning by a drag moves the target's image by that drag.
        let before = orbit.camera(size).project(target).unwrap();
        orbit.pan(DVec2::new(10.0, -4.0), size);
        let after = orbit.camera(size).project(target).unwrap();
        assert!(
            (after - before - DVec2::new(10.0, -4.0)).length() < 1e-6,
            "{before} {after}"
        );
        // Zoom and pan stop where the scene would leave the view.
        let mut z = OrbitCamera::over_shoulder(&reference(), target);
        let start = z.distance;
        z.zoom(-1000.0);
        assert!((z.distance / start - ZOOM_OUT_LIMIT).abs() < 1e-9);
        z.zoom(1000.0);
        assert!((z.distance / start - ZOOM_IN_LIMIT).abs() < 1e-9);
        let mut p = OrbitCamera::over_shoulder(&reference(), target);
        p.pan(DVec2::new(1e7, 0.0), size);
        assert!(
            ((p.target - target).length() - 5.0).abs() < 1e-9,
            "{}",
            p.target
        );
        // Orbit speed follows the panel: the same share of a small and a large panel turns
        // the view alike.
        let mut small = OrbitCamera::over_shoulder(&reference(), target);
        let mut large = small;
        small.orbit(DVec2::new(50.0, 0.0), (200, 100));
        large.orbit(DVec2::new(200.0, 0.0), (800, 400));
        assert!((small.yaw - large.yaw).abs() < 1e-12);
        assert!((small.yaw - 12f64.to_radians() - std::f64::consts::PI / 4.0).abs() < 1e-12);
        // Orbiting keeps the distance to the target and clamps the pitch.
        let mut o = OrbitCamera::over_shoulder(&reference(), target);
        o.orbit(DVec2::new(50.0, 1e6), size);
        assert!(o.pitch < 90f64.to_radians());
        let c = o.camera(size);
        assert!(((c.centre() - target).length() - o.distance).abs() < 1e-9);
        // The matrix agrees with the camera: the target lands at the panel centre in NDC.
        let m = glam::Mat4::from_cols_array(&o.clip_from_world(size));
        let clip = m * target.as_vec3().extend(1.0);
        assert!((clip.x / clip.w).abs() < 1e-4 && (clip.y / clip.w).abs() < 1e-4);
    }

    #[test]
    fn picking_takes_the_front_point_within_tolerance() {
        let cam = reference();
        let points = [
            DVec3::new(0.0, 0.0, 10.0), // projects to the centre, far
            DVec3::new(0.0, 0.0, 5.0),  // same pixel, nearer: wins
            DVec3::new(0.0, 0.0, -5.0), // behind the camera
            DVec3::new(1.0, 0.0, 4.0),  // 25 px away
        ];
        assert_eq!(
            pick_point(&cam, DVec2::new(49.5, 49.5), points, 3.0),
            Some(1)
        );
        assert_eq!(
            pick_point(&cam, DVec2::new(74.5, 49.5), points, 3.0),
            Some(3)
        );
        assert_eq!(pick_point(&cam, DVec2::new(10.0, 10.0), points, 3.0), None);
    }
}
