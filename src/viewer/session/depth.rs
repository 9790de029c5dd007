//! The light field's depth, loaded once per session: the reference view's depth map (if the
//! light field has one) and the point cloud made from it, thinned by a stride to at most
//! [`MAX_CLOUD_POINTS`]. Clicks on the refocus image become depth-view pixels here, and clicks
//! in the scene panel become cloud points.

use glam::{DVec2, DVec3};

use super::super::orbit::{pick_point, OrbitCamera};
use crate::error::Result;
use crate::geometry::depth::ViewDepth;
use crate::lightfield::LightField;
use crate::scene::PointCloud;

/// Most cloud points drawn (a stride thins larger depth maps).
const MAX_CLOUD_POINTS: usize = 100_000;
/// Pick tolerance in the scene panel, pixels.
const PICK_TOLERANCE: f64 = 6.0;

/// The depth map and its point cloud, when the light field has depth.
pub struct DepthCache {
    pub depth: Option<ViewDepth>,
    pub cloud: Option<PointCloud>,
    /// Every stride-th depth pixel (per axis) is a cloud point.
    stride: u32,
}

impl DepthCache {
    /// The point cloud of `depth`, the depth map of `lf` (none for a light field without).
    pub fn new(lf: &LightField, depth: Option<ViewDepth>) -> Result<Self> {
        let stride = depth.as_ref().map_or(1, |d| {
            let pixels = d.width as usize * d.height as usize;
            ((pixels as f64 / MAX_CLOUD_POINTS as f64).sqrt().ceil() as u32).max(1)
        });
        let cloud = match &depth {
            Some(d) => Some(PointCloud::colours_only(
                d,
                &lf.views[d.view].image,
                stride,
            )?),
            None => None,
        };
        Ok(DepthCache {
            depth,
            cloud,
            stride,
        })
    }

    /// The centre of the cloud's bounding box.
    pub fn centre(&self) -> Option<DVec3> {
        self.cloud
            .as_ref()
            .and_then(|c| c.bounds)
            .map(|b| b.centre())
    }

    /// The eight corners of the cloud's bounding box (none without a cloud).
    pub fn corners(&self) -> Vec<DVec3> {
        let Some(b) = self.cloud.as_ref().and_then(|c| c.bounds) else {
            return Vec::new();
        };
        (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { b.min.x } else { b.max.x },
                    if i & 2 == 0 { b.min.y } else { b.max.y },
                    if i & 4 == 0 { b.min.z } else { b.max.z },
                )
            })
            .collect()
    }

    /// The diagonal of the cloud's bounding box.
    pub fn diagonal(&self) -> Option<f64> {
        self.cloud
            .as_ref()
            .and_then(|c| c.bounds)
            .map(|b| b.diagonal())
    }

    /// Cloud points large enough to close the gaps between neighbouring depth pixels at the
    /// initial zoom: the panel's pixels per (thinned) depth pixel, with some overlap.
    pub fn point_size(&self, panel_height: f64) -> f32 {
        let Some(d) = &self.depth else { return 2.0 };
        let per_px = panel_height / d.height.max(1) as f64 * self.stride as f64;
        (1.3 * per_px).clamp(2.0, 8.0) as f32
    }

    /// The depth-view pixel under refocus-image position `p` (full-size pixels of the current
    /// reference view): the position itself when the reference camera is the depth view's,
    /// else the pixel of the cloud point seen there.
    pub fn depth_pixel(
        &self,
        lf: &LightField,
        reference: &crate::geometry::camera::Camera,
        p: DVec2,
    ) -> std::result::Result<DVec2, String> {
        let depth = self.depth.as_ref().ok_or_else(|| {
            format!(
                "light field '{}' has no depth map: clicks need one (keys and scroll work)",
                lf.name
            )
        })?;
        if *reference == depth.camera {
            return Ok(p);
        }
        let cloud = self.cloud.as_ref().ok_or("no point cloud to pick from")?;
        let i = pick_point(reference, p, cloud.points.iter().map(|c| c.position), 1.5)
            .ok_or("no depth under the cursor from this viewpoint")?;
        let (x, y) = cloud.points[i].pixel;
        Ok(DVec2::new(x as f64, y as f64))
    }

    /// The world point of the cloud under pixel `p` of a scene panel of `size` seen by `orbit`.
    pub fn scene_pick(
        &self,
        lf: &LightField,
        orbit: &OrbitCamera,
        size: (u32, u32),
        p: DVec2,
    ) -> std::result::Result<DVec3, String> {
        let cloud = self.cloud.as_ref().ok_or_else(|| {
            format!(
                "light field '{}' has no depth map, so the scene has no points to pick",
                lf.name
            )
        })?;
        let cam = orbit.camera(size);
        let i = pick_point(
            &cam,
            p,
            cloud.points.iter().map(|c| c.position),
            PICK_TOLERANCE,
        )
        .ok_or("no cloud point within a few pixels of the cursor")?;
        Ok(cloud.points[i].position)
    }
}
