//! Synthetic camera rigs (parallel with sensor shift, or converging), the light field a
//! render of one yields, and the linear → sRGB encoding of rendered pixels. Pure data and maths:
//! the GPU rasterizer that renders them is [`crate::jobs::raster`].

use glam::{DMat3, DVec3};
use image::RgbaImage;

use crate::color::encode_srgb8;
use crate::geometry::camera::{intrinsics, Camera};
use crate::lightfield::{GridSize, LightField, ParallelRig};

/// Linear RGBA → 8-bit sRGB with alpha 255.
pub fn encode(linear: &[[f32; 4]], width: u32, height: u32) -> RgbaImage {
    let raw: Vec<u8> = linear
        .iter()
        .flat_map(|p| {
            [
                encode_srgb8(p[0]),
                encode_srgb8(p[1]),
                encode_srgb8(p[2]),
                255,
            ]
        })
        .collect();
    RgbaImage::from_raw(width, height, raw).unwrap_or_else(|| RgbaImage::new(width, height))
}

/// How the cameras of a synthetic rig are oriented.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RigKind {
    /// Parallel cameras with sensor shift (the HCI benchmark's rig): zero disparity at the
    /// focus distance.
    Parallel,
    /// Each camera rotated to look at the point (0, 0, `distance`) of the centre axis (a
    /// converging camera-array video rig); principal points at the image centre.
    Converging { distance: f64 },
}

/// A synthetic camera grid in the world frame of the centre camera (x right, y down,
/// z forward): camera (s, t) sits at ((s − s_c)·b, (t − t_c)·b, 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SynthRig {
    pub grid: GridSize,
    pub width: u32,
    pub height: u32,
    pub focal_px: f64,
    pub baseline: f64,
    /// Zero-disparity distance of the parallel rig (HCI `focus_distance_m`).
    pub focus_distance: f64,
    pub kind: RigKind,
}

impl SynthRig {
    /// The parallel rig's parameters (`None` for converging rigs).
    pub fn parallel(&self) -> Option<ParallelRig> {
        (self.kind == RigKind::Parallel).then_some(ParallelRig {
            focal_px: self.focal_px,
            baseline: self.baseline,
            focus_distance: self.focus_distance,
        })
    }

    /// The cameras, row-major.
    pub fn cameras(&self) -> Vec<Camera> {
        match self.kind {
            RigKind::Parallel => self
                .parallel()
                .map_or_else(Vec::new, |r| r.cameras(self.grid, self.width, self.height)),
            RigKind::Converging { distance } => {
                let c = self.grid.centre();
                let k = intrinsics(
                    self.focal_px,
                    self.focal_px,
                    (self.width as f64 - 1.0) / 2.0,
                    (self.height as f64 - 1.0) / 2.0,
                );
                let target = DVec3::new(0.0, 0.0, distance);
                let mut cams = Vec::with_capacity(self.grid.len());
                for t in 0..self.grid.rows {
                    for s in 0..self.grid.cols {
                        let centre = DVec3::new(
                            (s as f64 - c.x) * self.baseline,
                            (t as f64 - c.y) * self.baseline,
                            0.0,
                        );
                        let z = (target - centre).normalize();
                        let x = DVec3::Y.cross(z).normalize();
                        let y = z.cross(x);
                        let r = DMat3::from_cols(x, y, z).transpose();
                        cams.push(Camera::from_centre(k, r, centre));
                    }
                }
                cams
            }
        }
    }
}

/// A rendered light field with the reference view's normals.
#[derive(Debug, Clone)]
pub struct SynthLightField {
    pub light_field: LightField,
    /// Index of the reference (centre) view.
    pub reference: usize,
    /// Camera-frame normals of the reference view (NaN on background).
    pub normals: Vec<[f32; 3]>,
}
