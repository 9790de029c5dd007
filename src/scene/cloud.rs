//! The point cloud of one view: every valid depth sample back-projected to the world frame
//! (`X = Rᵀ (z K⁻¹ [x, y, 1]ᵀ − t)`, docs/conventions.md §8) with the view's sRGB colour and,
//! where the PCA fit is reliable, its normal (facing the view's camera) and planarity.
//!
//! Invariants: points are in row-major pixel order, every `stride`-th pixel in x and y from
//! (0, 0); only valid samples ([`ViewDepth::point`]) appear; `bounds` is the axis-aligned box
//! of exactly these points and `None` only for an empty cloud.

use glam::DVec3;
use image::RgbaImage;

use super::ColourVertex;
use crate::error::{Error, Result};
use crate::geometry::depth::ViewDepth;
use crate::geometry::normals::{NormalEstimate, NormalProblem};

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl Bounds {
    /// The box of `points`; `None` when there are none.
    pub fn of(points: impl IntoIterator<Item = DVec3>) -> Option<Self> {
        let mut it = points.into_iter();
        let first = it.next()?;
        Some(it.fold(
            Bounds {
                min: first,
                max: first,
            },
            |b, p| Bounds {
                min: b.min.min(p),
                max: b.max.max(p),
            },
        ))
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }

    /// The centre of the box.
    pub fn centre(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }
}

/// One back-projected pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CloudPoint {
    pub pixel: (u32, u32),
    /// World frame.
    pub position: DVec3,
    /// sRGB-encoded colour of the pixel.
    pub colour: [u8; 3],
    /// Unit normal (world frame, facing the camera) where the estimate is reliable.
    pub normal: Option<DVec3>,
    /// Planarity `1 − λ0/λ1` of the normal's fit; 0 without a normal.
    pub planarity: f64,
}

/// The point cloud of one view.
#[derive(Debug, Clone, PartialEq)]
pub struct PointCloud {
    /// Index of the view in `lf.views`.
    pub view: usize,
    pub points: Vec<CloudPoint>,
    pub bounds: Option<Bounds>,
}

impl PointCloud {
    /// The cloud of `depth`'s view with colours from `image` (that view's image) and
    /// `normals` (row-major, one per pixel, as [`crate::geometry::normals::estimate_normals`]
    /// returns them), keeping every `stride`-th pixel in x and y.
    pub fn from_depth(
        depth: &ViewDepth,
        image: &RgbaImage,
        normals: &[std::result::Result<NormalEstimate, NormalProblem>],
        stride: u32,
    ) -> Result<Self> {
        if stride == 0 {
            return Err(Error::Invalid("--stride must be at least 1".into()));
        }
        let pixels = depth.width as usize * depth.height as usize;
        if image.dimensions() != (depth.width, depth.height) || normals.len() != pixels {
            return Err(Error::LightField(format!(
                "the image ({}×{}) or normals ({}) for depth map {} do not match its {}×{} \
                 pixels",
                image.width(),
                image.height(),
                normals.len(),
                depth.source,
                depth.width,
                depth.height
            )));
        }
        Self::collect(depth, image, stride, |i| match &normals[i] {
            Ok(n) => (Some(n.normal), n.planarity),
            Err(_) => (None, 0.0),
        })
    }

    fn collect(
        depth: &ViewDepth,
        image: &RgbaImage,
        stride: u32,
        normal_of: impl Fn(usize) -> (Option<DVec3>, f64),
    ) -> Result<Self> {
        if stride == 0 {
            return Err(Error::Invalid("--stride must be at least 1".into()));
        }
        if image.dimensions() != (depth.width, depth.height) {
            return Err(Error::LightField(format!(
                "the image ({}×{}) for depth map {} does not match its {}×{} pixels",
                image.width(),
                image.height(),
                depth.source,
                depth.width,
                depth.height
            )));
        }
        let mut points = Vec::new();
        for y in (0..depth.height).step_by(stride as usize) {
            for x in (0..depth.width).step_by(stride as usize) {
                let Some(position) = depth.point(x, y) else {
                    continue;
                };
                let c = image.get_pixel(x, y).0;
                let (normal, planarity) = normal_of(depth.index(x, y));
                points.push(CloudPoint {
                    pixel: (x, y),
                    position,
                    colour: [c[0], c[1], c[2]],
                    normal,
                    planarity,
                });
            }
        }
        let bounds = Bounds::of(points.iter().map(|p| p.position));
        Ok(PointCloud {
            view: depth.view,
            points,
            bounds,
        })
    }

    /// The cloud of `depth`'s view with colours from `image`, every `stride`-th pixel, without
    /// normals (what a 3-D view draws; picks estimate their own normals).
    pub fn colours_only(depth: &ViewDepth, image: &RgbaImage, stride: u32) -> Result<Self> {
        Self::collect(depth, image, stride, |_| (None, 0.0))
    }

    /// Number of points with a normal.
    pub fn with_normal(&self) -> usize {
        self.points.iter().filter(|p| p.normal.is_some()).count()
    }

    /// The points for upload (opaque).
    pub fn vertices(&self) -> Vec<ColourVertex> {
        self.points
            .iter()
            .map(|p| ColourVertex::new(p.position, p.colour, 1.0))
            .collect()
    }
}
