//! The geometry of a regular camera grid: its size and centre, and the parallel rig with sensor
//! shift of the HCI convention (disparity ↔ depth, the cameras of every grid position).
//! Pure maths: the light field model re-exports these types.

use glam::DVec2;

use super::camera::Camera;

/// Grid dimensions: `cols` views horizontally (s), `rows` vertically (t).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct GridSize {
    pub cols: usize,
    pub rows: usize,
}

impl GridSize {
    /// Number of views.
    pub fn len(&self) -> usize {
        self.cols * self.rows
    }

    /// True for an empty grid.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row-major index of view (s, t).
    pub fn index(&self, s: usize, t: usize) -> usize {
        t * self.cols + s
    }

    /// Grid centre in (s, t) grid units (fractional for even sizes).
    pub fn centre(&self) -> DVec2 {
        DVec2::new(
            (self.cols as f64 - 1.0) / 2.0,
            (self.rows as f64 - 1.0) / 2.0,
        )
    }
}

/// Parameters of a regular, parallel camera grid with sensor shift, as the HCI benchmark uses.
/// Present when `--disparity` follows the HCI convention (HCI folders, built-in scenes).
///
/// Camera (s, t) sits at ((s − s_c)·b, (t − t_c)·b, 0) in the centre camera's frame and its
/// principal point is shifted by (s − s_c)·f·b/Z_focus, (t − t_c)·f·b/Z_focus, so a centre-view
/// pixel x with disparity d appears in view (s, t) at x − d·(s − s_c, t − t_c).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ParallelRig {
    /// Focal length in pixels (`f_px = focal_mm · max(W, H) / sensor_mm`).
    pub focal_px: f64,
    /// Baseline between neighbouring cameras, world units (metres for HCI).
    pub baseline: f64,
    /// Distance of the zero-disparity plane, world units.
    pub focus_distance: f64,
}

impl ParallelRig {
    /// Depth of disparity `d`: `1/Z = d / (b · f) + 1/Z_focus`. `None` when `d` lies at or
    /// beyond infinity (1/Z ≤ 0).
    pub fn depth_of_disparity(&self, d: f64) -> Option<f64> {
        let inv = d / (self.baseline * self.focal_px) + 1.0 / self.focus_distance;
        (inv > 0.0).then(|| 1.0 / inv)
    }

    /// Disparity of depth `z` (inverse of [`Self::depth_of_disparity`]).
    pub fn disparity_of_depth(&self, z: f64) -> f64 {
        self.baseline * self.focal_px * (1.0 / z - 1.0 / self.focus_distance)
    }

    /// The disparity of a point at infinity, `−f·b/Z_focus`: the most negative physical value.
    pub fn disparity_at_infinity(&self) -> f64 {
        -self.baseline * self.focal_px / self.focus_distance
    }

    /// The cameras of a `grid` of `width × height` views (row-major), world frame = centre
    /// camera frame. Principal point at the image centre ((W−1)/2, (H−1)/2) plus sensor shift.
    pub fn cameras(&self, grid: GridSize, width: u32, height: u32) -> Vec<Camera> {
        let c = grid.centre();
        let shift = self.focal_px * self.baseline / self.focus_distance;
        let mut cams = Vec::with_capacity(grid.len());
        for t in 0..grid.rows {
            for s in 0..grid.cols {
                let ds = s as f64 - c.x;
                let dt = t as f64 - c.y;
                let k = super::camera::intrinsics(
                    self.focal_px,
                    self.focal_px,
                    (width as f64 - 1.0) / 2.0 + ds * shift,
                    (height as f64 - 1.0) / 2.0 + dt * shift,
                );
                let centre = glam::DVec3::new(ds * self.baseline, dt * self.baseline, 0.0);
                cams.push(Camera::from_centre(k, glam::DMat3::IDENTITY, centre));
            }
        }
        cams
    }
}
