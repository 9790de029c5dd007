//! What `tiltfield info` reports about a light field, computed here (the command line only
//! prints it): grid, view size, the centre camera, how far the cameras spread and whether they
//! are rotated, the parallel-rig parameters, the depth maps and the dark views.

use serde::Serialize;

use super::{DepthKind, LightField, ParallelRig, Source};
use crate::error::Result;

/// A light field's summary; serialises as `info --json` prints it.
#[derive(Debug, Clone, Serialize)]
pub struct Summary<'a> {
    pub name: &'a str,
    pub source: &'a Source,
    pub grid: GridSummary,
    pub view_size: [u32; 2],
    pub centre_camera: CentreCamera,
    /// The largest distance of a camera centre from the first view's, in world units.
    pub rig_extent: f64,
    /// Whether any camera is rotated against the centre camera.
    pub rotated_cameras: bool,
    pub parallel_rig: Option<ParallelRig>,
    pub depth: Vec<DepthSummary<'a>>,
    /// Grid positions (s, t) of views that are (almost) black.
    pub dark_views: Vec<(usize, usize)>,
}

#[derive(Debug, Clone, Copy, Serialize)]
pub struct GridSummary {
    pub cols: usize,
    pub rows: usize,
    pub views: usize,
}

/// The camera at the grid's centre: intrinsics in pixels and its centre.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct CentreCamera {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub centre: [f64; 3],
}

/// One depth or disparity map.
#[derive(Debug, Clone, Serialize)]
pub struct DepthSummary<'a> {
    /// The view's grid position (s, t).
    pub view: [usize; 2],
    pub kind: DepthKind,
    pub source: &'a str,
    /// Finite values over all values.
    pub valid_fraction: f64,
    /// Smallest and largest finite value (`None`: no finite value).
    pub range: Option<[f32; 2]>,
}

impl LightField {
    /// The summary of this light field (an error only where its centre camera cannot be
    /// interpolated).
    pub fn summary(&self) -> Result<Summary<'_>> {
        let ref_cam = self.camera_at(self.grid.centre())?;
        let c0 = self.views[0].camera.centre();
        let rig_extent = self
            .views
            .iter()
            .map(|v| (v.camera.centre() - c0).length())
            .fold(0.0, f64::max);
        let rotated_cameras = self
            .views
            .iter()
            .any(|v| !(v.camera.r - ref_cam.r).abs_diff_eq(glam::DMat3::ZERO, 1e-9));
        let depth = self
            .depth
            .iter()
            .map(|(i, d)| {
                let v = &self.views[*i];
                let finite: Vec<f32> = d.values.iter().copied().filter(|x| x.is_finite()).collect();
                let (lo, hi) = finite
                    .iter()
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| {
                        (a.min(x), b.max(x))
                    });
                DepthSummary {
                    view: [v.s, v.t],
                    kind: d.kind,
                    source: &d.source,
                    valid_fraction: finite.len() as f64 / d.values.len().max(1) as f64,
                    range: (!finite.is_empty()).then_some([lo, hi]),
                }
            })
            .collect();
        let dark_views = self
            .views
            .iter()
            .zip(self.dark_views())
            .filter(|(_, dark)| *dark)
            .map(|(v, _)| (v.s, v.t))
            .collect();
        let (k, centre) = (ref_cam.k, ref_cam.centre());
        Ok(Summary {
            name: &self.name,
            source: &self.source,
            grid: GridSummary {
                cols: self.grid.cols,
                rows: self.grid.rows,
                views: self.grid.len(),
            },
            view_size: [self.width, self.height],
            centre_camera: CentreCamera {
                fx: k.x_axis.x,
                fy: k.y_axis.y,
                cx: k.z_axis.x,
                cy: k.z_axis.y,
                centre: centre.to_array(),
            },
            rig_extent,
            rotated_cameras,
            parallel_rig: self.rig,
            depth,
            dark_views,
        })
    }
}
