//! Depth of one view from its depth or disparity map, and back-projection of that view's
//! pixels to world-frame points (docs/conventions.md §8; the point cloud itself is
//! [`crate::scene::cloud`]).
//!
//! Conventions:
//! - depth z is the camera-frame z of the surface seen at a pixel centre (distance along the
//!   optical axis, world units), as [`DepthKind::Depth`] maps store it;
//! - pixel (x, y) with depth z back-projects to `X_c = z K⁻¹ [x, y, 1]ᵀ` in the camera frame of
//!   the view that owns the map, then to the world frame with that view's camera
//!   (`X = Rᵀ (X_c − t)`). This is the general calibrated case of the manifest: a depth map of
//!   a rotated camera still gives world-frame points, because its own K, R, t are used;
//! - disparity → depth follows the HCI convention of regular parallel rigs with sensor shift,
//!   `1/Z = d / (b · f_px) + 1/Z_focus` ([`ParallelRig::depth_of_disparity`]). It needs
//!   `lf.rig` (HCI folders, built-in scenes, manifests that declare `rig`); a disparity map
//!   of a rig without that declaration has no defined depth and is refused with a message.
//!
//! A sample is **valid** when it is finite, when (for disparity) it lies inside the dataset's
//! disparity range ([`LightField::disparity_range`]: `[meta] disp_min … disp_max` of HCI
//! folders, the documented range of built-in scenes) and in front of infinity (1/Z > 0), and
//! when the resulting depth is finite and positive. Every other sample is invalid and carries
//! a [`DepthProblem`] that says why, so that a click on it can be refused with a message
//! instead of producing NaN.
//!
//! The view with the map is normally the centre view. Pixels given to the picking functions
//! ([`super::picking`]) are pixels of *this* view, whatever reference view a render uses;
//! the planes found are world-frame, so they apply to any reference view.

use std::fmt;

use glam::{DMat3, DVec2, DVec3};

use super::camera::Camera;
use super::rig::ParallelRig;
use crate::error::{Error, Result};

/// What a depth map stores per pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DepthKind {
    /// Distance along the optical axis (camera z), in world units.
    Depth,
    /// HCI disparity in pixels per grid step (positive = nearer than the focus distance).
    Disparity,
}

/// A per-pixel depth or disparity map of one view, row 0 at the top.
/// Invalid samples are stored as NaN (never as 0 or a sentinel).
#[derive(Debug, Clone)]
pub struct DepthMap {
    pub width: u32,
    pub height: u32,
    pub kind: DepthKind,
    pub values: Vec<f32>,
    /// Where it came from (file path or "generated"), for messages.
    pub source: String,
    /// Made from the views by the depth estimator (`tiltfield depth`), not handed over with
    /// the light field: noisy at silhouettes, so anti-aliasing does not trust it to the last
    /// pixel (refocus::antialias::AntialiasPlan::guard_px).
    pub estimated: bool,
}

impl DepthMap {
    /// Value at pixel (x, y).
    pub fn at(&self, x: u32, y: u32) -> f32 {
        self.values[(y * self.width + x) as usize]
    }

    /// The HCI disparity map of this depth map on `rig` (NaN stays NaN), labelled `source`.
    pub fn to_disparity(&self, rig: &ParallelRig, source: String) -> DepthMap {
        DepthMap {
            width: self.width,
            height: self.height,
            kind: DepthKind::Disparity,
            values: self
                .values
                .iter()
                .map(|&z| {
                    if z.is_nan() {
                        f32::NAN
                    } else {
                        rig.disparity_of_depth(z as f64) as f32
                    }
                })
                .collect(),
            source,
            estimated: self.estimated,
        }
    }
}

/// Why a depth sample is unusable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DepthProblem {
    /// NaN: the map has no value there (background, occlusion, unknown).
    NoValue,
    /// ±∞ in the map.
    Infinite,
    /// A depth (or the depth of a disparity) that is zero or negative.
    NotPositive(f64),
    /// A disparity at or beyond infinity for the rig (1/Z ≤ 0).
    BeyondInfinity(f64),
    /// A disparity outside the dataset's declared range.
    OutsideRange { value: f64, min: f64, max: f64 },
}

impl fmt::Display for DepthProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DepthProblem::NoValue => write!(f, "the map has no value there (NaN)"),
            DepthProblem::Infinite => write!(f, "the map stores an infinite value there"),
            DepthProblem::NotPositive(z) => {
                write!(f, "the depth there is {z}, not in front of the camera")
            }
            DepthProblem::BeyondInfinity(d) => write!(
                f,
                "the disparity there ({d} px) lies at or beyond infinity for this rig"
            ),
            DepthProblem::OutsideRange { value, min, max } => write!(
                f,
                "the disparity there ({value} px) lies outside the dataset's range {min} … {max} px"
            ),
        }
    }
}

/// The depth of one view, with invalid samples marked, ready for back-projection.
#[derive(Debug, Clone)]
pub struct ViewDepth {
    /// Index of the view in `lf.views` that owns the map.
    pub view: usize,
    /// Grid position (s, t) of that view.
    pub grid_position: (usize, usize),
    /// That view's camera.
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    /// What the source map stored.
    pub kind: DepthKind,
    /// Where the map came from, for messages.
    pub source: String,
    /// The map is the depth estimator's ([`DepthMap::estimated`]).
    pub estimated: bool,
    /// The dataset's valid disparity range (min, max), when known.
    pub disparity_range: Option<(f64, f64)>,
    rig: Option<ParallelRig>,
    raw: Vec<f32>,
    /// Camera-frame depth per pixel, NaN where invalid.
    z: Vec<f64>,
    k_inv: DMat3,
    valid: usize,
}

impl ViewDepth {
    /// Builds the depth of a view with camera `camera` from `map`. `rig` converts disparity;
    /// `disparity_range` (min, max) marks disparities outside it as invalid (for depth maps
    /// it is applied to the disparity of the depth when `rig` is given).
    pub fn new(
        camera: Camera,
        map: &DepthMap,
        rig: Option<ParallelRig>,
        disparity_range: Option<(f64, f64)>,
        view: usize,
    ) -> Result<Self> {
        let n = map.width as usize * map.height as usize;
        if map.values.len() != n || n == 0 {
            return Err(Error::LightField(format!(
                "depth map {} has {} values for {}×{} pixels",
                map.source,
                map.values.len(),
                map.width,
                map.height
            )));
        }
        if map.kind == DepthKind::Disparity && rig.is_none() {
            return Err(Error::LightField(format!(
                "disparity map {} cannot be converted to depth: the light field declares no \
                 regular rig (focal length, baseline, focus distance); give a depth map, or a \
                 `rig` entry in the manifest",
                map.source
            )));
        }
        let k_inv = camera.k.inverse();
        if !k_inv.is_finite() {
            return Err(Error::LightField(format!(
                "the camera of depth map {} has a singular K",
                map.source
            )));
        }
        let mut d = ViewDepth {
            view,
            grid_position: (0, 0),
            camera,
            width: map.width,
            height: map.height,
            kind: map.kind,
            source: map.source.clone(),
            estimated: map.estimated,
            disparity_range,
            rig,
            raw: map.values.clone(),
            z: Vec::new(),
            k_inv,
            valid: 0,
        };
        d.z = d
            .raw
            .iter()
            .map(|&v| d.classify(v).unwrap_or(f64::NAN))
            .collect();
        d.valid = d.z.iter().filter(|z| !z.is_nan()).count();
        Ok(d)
    }

    /// Depth of a raw map sample, or why it is invalid.
    pub fn classify(&self, raw: f32) -> std::result::Result<f64, DepthProblem> {
        let v = raw as f64;
        if v.is_nan() {
            return Err(DepthProblem::NoValue);
        }
        if v.is_infinite() {
            return Err(DepthProblem::Infinite);
        }
        let (z, disparity) = match (self.kind, self.rig) {
            (DepthKind::Depth, rig) => (v, rig.map(|r| r.disparity_of_depth(v))),
            (DepthKind::Disparity, Some(rig)) => match rig.depth_of_disparity(v) {
                Some(z) => (z, Some(v)),
                None => return Err(DepthProblem::BeyondInfinity(v)),
            },
            // Refused in `new`; kept total so no sample can slip through as a number.
            (DepthKind::Disparity, None) => return Err(DepthProblem::NoValue),
        };
        if z.is_nan() || z <= 0.0 {
            return Err(DepthProblem::NotPositive(z));
        }
        if !z.is_finite() {
            return Err(DepthProblem::Infinite);
        }
        if let (Some(d), Some((min, max))) = (disparity, self.disparity_range) {
            // A hair of slack: ranges are printed with limited digits, maps are f32.
            let slack = 1e-6 * (1.0 + min.abs().max(max.abs()));
            if d < min - slack || d > max + slack {
                return Err(DepthProblem::OutsideRange { value: d, min, max });
            }
        }
        Ok(z)
    }

    /// Camera-frame depth at pixel (x, y), `None` when invalid or outside the view.
    pub fn depth(&self, x: u32, y: u32) -> Option<f64> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let z = self.z[self.index(x, y)];
        (!z.is_nan()).then_some(z)
    }

    /// Camera-frame depth at pixel (x, y), or why there is none.
    pub fn depth_checked(&self, x: u32, y: u32) -> std::result::Result<f64, DepthProblem> {
        if x >= self.width || y >= self.height {
            return Err(DepthProblem::NoValue);
        }
        self.classify(self.raw[self.index(x, y)])
    }

    /// The raw map value at (x, y) (disparity or depth as stored).
    pub fn raw(&self, x: u32, y: u32) -> f32 {
        self.raw[self.index(x, y)]
    }

    /// Back-projected pixel (x, y) in this view's camera frame: `z K⁻¹ [x, y, 1]ᵀ`.
    pub fn point_camera(&self, x: u32, y: u32) -> Option<DVec3> {
        self.depth(x, y)
            .map(|z| self.k_inv * DVec3::new(x as f64, y as f64, 1.0) * z)
    }

    /// Back-projected pixel (x, y) in the world frame.
    pub fn point(&self, x: u32, y: u32) -> Option<DVec3> {
        self.point_camera(x, y).map(|p| self.camera.to_world(p))
    }

    /// The camera-frame ray (z = 1) through pixel position `pixel`.
    pub fn ray_camera(&self, pixel: DVec2) -> DVec3 {
        self.k_inv * pixel.extend(1.0)
    }

    /// The integer pixel nearest to pixel position (u, v) (pixel-index coordinates: the centre
    /// of pixel (i, j) is at (i, j)); an error naming the view size when it lies outside.
    pub fn pixel_at(&self, u: f64, v: f64) -> Result<(u32, u32)> {
        let inside = |c: f64, n: u32| c.is_finite() && c >= -0.5 && c < n as f64 - 0.5;
        if !(inside(u, self.width) && inside(v, self.height)) {
            return Err(Error::Invalid(format!(
                "pixel ({u}, {v}) lies outside the {}×{} view ({}, {}) that carries the depth \
                 map (x in 0…{}, y in 0…{})",
                self.width,
                self.height,
                self.grid_position.0,
                self.grid_position.1,
                self.width - 1,
                self.height - 1
            )));
        }
        // Rounding half up keeps (i − 0.5) in pixel i, matching the footprint [i − ½, i + ½).
        let r = |c: f64, n: u32| ((c + 0.5).floor() as i64).clamp(0, n as i64 - 1) as u32;
        Ok((r(u, self.width), r(v, self.height)))
    }

    /// Number of valid samples.
    pub fn valid_count(&self) -> usize {
        self.valid
    }

    /// The median valid depth, a length scale for tolerances (1 when no sample is valid).
    pub fn typical_depth(&self) -> f64 {
        let mut v: Vec<f64> = self.z.iter().copied().filter(|z| !z.is_nan()).collect();
        if v.is_empty() {
            return 1.0;
        }
        let mid = v.len() / 2;
        let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
        *m
    }

    /// Row-major index of pixel (x, y).
    pub fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::intrinsics;

    fn map(kind: DepthKind, values: Vec<f32>, w: u32) -> DepthMap {
        DepthMap {
            width: w,
            height: values.len() as u32 / w,
            kind,
            values,
            source: "test map".into(),
            estimated: false,
        }
    }

    fn cam() -> Camera {
        Camera::from_centre(
            intrinsics(100.0, 100.0, 1.0, 0.5),
            DMat3::from_rotation_y(0.3),
            DVec3::new(0.2, -0.1, 0.5),
        )
    }

    const RIG: ParallelRig = ParallelRig {
        focal_px: 100.0,
        baseline: 0.1,
        focus_distance: 2.0,
    };

    #[test]
    fn depth_back_projects_through_the_views_own_camera() {
        let d = ViewDepth::new(
            cam(),
            &map(DepthKind::Depth, vec![2.0, 3.0, 4.0, 5.0, 6.0, 7.0], 3),
            None,
            None,
            0,
        )
        .unwrap();
        for (x, y) in [(0, 0), (2, 1), (1, 1)] {
            let p = d.point(x, y).unwrap();
            let z = d.depth(x, y).unwrap();
            assert!((cam().to_camera(p).z - z).abs() < 1e-12);
            let px = cam().project(p).unwrap();
            assert!((px - DVec2::new(x as f64, y as f64)).length() < 1e-9);
        }
        assert_eq!(d.valid_count(), 6);
        assert_eq!(d.typical_depth(), 5.0);
    }

    #[test]
    fn disparity_converts_with_the_hci_formula() {
        // 1/Z = d/(b f) + 1/Z_focus = d/10 + 0.5.
        let d = ViewDepth::new(
            cam(),
            &map(DepthKind::Disparity, vec![0.0, 5.0, -2.5, 1.0], 2),
            Some(RIG),
            None,
            0,
        )
        .unwrap();
        assert_eq!(d.depth(0, 0), Some(2.0));
        assert_eq!(d.depth(1, 0), Some(1.0));
        assert_eq!(d.depth(0, 1), Some(4.0));
        assert!((d.depth(1, 1).unwrap() - 1.0 / 0.6).abs() < 1e-6);
    }

    #[test]
    fn invalid_samples_are_marked_with_their_reason() {
        let values = vec![f32::NAN, f32::INFINITY, -5.0, 3.0, 0.5, -0.5];
        let d = ViewDepth::new(
            cam(),
            &map(DepthKind::Disparity, values, 3),
            Some(RIG),
            Some((-1.0, 1.0)),
            0,
        )
        .unwrap();
        assert_eq!(d.depth_checked(0, 0), Err(DepthProblem::NoValue));
        assert_eq!(d.depth_checked(1, 0), Err(DepthProblem::Infinite));
        assert_eq!(
            d.depth_checked(2, 0),
            Err(DepthProblem::BeyondInfinity(-5.0))
        );
        assert!(matches!(
            d.depth_checked(0, 1),
            Err(DepthProblem::OutsideRange { value, .. }) if value == 3.0
        ));
        assert!(d.depth_checked(1, 1).is_ok() && d.depth_checked(2, 1).is_ok());
        assert_eq!(d.valid_count(), 2);
        for (x, y) in [(0, 0), (1, 0), (2, 0), (0, 1)] {
            assert!(d.depth(x, y).is_none() && d.point(x, y).is_none());
        }
        let depth = ViewDepth::new(
            cam(),
            &map(DepthKind::Depth, vec![0.0, -1.0, f32::NEG_INFINITY, 1.0], 2),
            None,
            None,
            0,
        )
        .unwrap();
        assert_eq!(
            depth.depth_checked(0, 0),
            Err(DepthProblem::NotPositive(0.0))
        );
        assert_eq!(
            depth.depth_checked(1, 0),
            Err(DepthProblem::NotPositive(-1.0))
        );
        assert_eq!(depth.depth_checked(0, 1), Err(DepthProblem::Infinite));
        assert_eq!(depth.valid_count(), 1);
        for p in [
            DepthProblem::NoValue,
            DepthProblem::NotPositive(0.0),
            DepthProblem::OutsideRange {
                value: 3.0,
                min: -1.0,
                max: 1.0,
            },
        ] {
            assert!(!p.to_string().is_empty());
        }
    }

    #[test]
    fn disparity_without_a_rig_is_refused_naming_the_map() {
        let err = ViewDepth::new(
            cam(),
            &map(DepthKind::Disparity, vec![0.0; 4], 2),
            None,
            None,
            0,
        )
        .unwrap_err();
        assert!(err.to_string().contains("test map"), "{err}");
        assert!(err.to_string().contains("rig"), "{err}");
    }

    #[test]
    fn pixels_round_to_the_nearest_and_outside_is_an_error() {
        let d = ViewDepth::new(
            cam(),
            &map(DepthKind::Depth, vec![1.0; 12], 4),
            None,
            None,
            0,
        )
        .unwrap();
        assert_eq!(d.pixel_at(0.0, 0.0).unwrap(), (0, 0));
        assert_eq!(d.pixel_at(2.49, 1.5).unwrap(), (2, 2));
        assert_eq!(d.pixel_at(-0.5, 2.49).unwrap(), (0, 2));
        for (u, v) in [(-0.51, 0.0), (3.5, 0.0), (0.0, 2.5), (f64::NAN, 0.0)] {
            let err = d.pixel_at(u, v).unwrap_err();
            assert!(err.to_string().contains("outside the 4×3 view"), "{err}");
        }
    }
}
