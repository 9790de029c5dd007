//! Scene geometry as plain CPU data, no GPU: what a 3-D view of a light field shows and what
//! `tiltfield cloud` writes.
//!
//! - [`cloud`]: the point cloud of the view that carries the depth map (positions, sRGB
//!   colours, PCA normals with their planarity), and its bounding box;
//! - [`overlay`]: the refocus plane as a quad sized to the scene, camera markers (in or out
//!   of the aperture, with weights), the reference optical axis and the plane-normal line,
//!   gathered by [`SceneBuilder`] into a [`SceneGeometry`];
//! - [`mesh`]: triangle meshes for the rasterizer (shared by [`crate::passes`] and
//!   [`crate::synth`], so neither depends on the other).
//!
//! Invariants: positions are in the light field's world frame (built-in scenes and HCI data:
//! the centre camera's frame, x right, y down, z forward; docs/conventions.md §1). The f64
//! records keep full precision for files (PLY); [`ColourVertex`] lists are what a GPU pass
//! uploads: `#[repr(C)]`, 28 bytes, position then linear-light RGBA with straight alpha.

pub mod cloud;
pub mod mesh;
pub mod overlay;

pub use cloud::{Bounds, CloudPoint, PointCloud};
pub use overlay::{
    CameraMarker, PlaneQuad, SceneBuilder, SceneGeometry, Segment, CAMERA_IN_COLOUR,
    CAMERA_OUT_COLOUR, NORMAL_COLOUR, OPTICAL_AXIS_COLOUR, PLANE_ALPHA, PLANE_COLOUR,
};

use glam::DVec3;

use crate::color;

/// One vertex for upload: position (world frame) and linear-light RGBA, straight alpha.
/// `#[repr(C)]` with no padding, so a slice of them is the vertex buffer as it is.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C)]
pub struct ColourVertex {
    pub position: [f32; 3],
    pub colour: [f32; 4],
}

impl ColourVertex {
    /// A vertex at `p` with sRGB-encoded colour `srgb` (decoded here: the GPU blends and
    /// averages linear light) and alpha `alpha`.
    pub fn new(p: DVec3, srgb: [u8; 3], alpha: f32) -> Self {
        let lin = |c: u8| color::srgb_to_linear(c as f64 / 255.0) as f32;
        ColourVertex {
            position: p.as_vec3().to_array(),
            colour: [lin(srgb[0]), lin(srgb[1]), lin(srgb[2]), alpha],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_vertex_is_tightly_packed_and_decodes_srgb() {
        assert_eq!(std::mem::size_of::<ColourVertex>(), 28);
        assert_eq!(std::mem::align_of::<ColourVertex>(), 4);
        let v = ColourVertex::new(DVec3::new(1.0, 2.0, 3.0), [255, 0, 188], 0.5);
        assert_eq!(v.position, [1.0, 2.0, 3.0]);
        assert_eq!(v.colour[0], 1.0);
        assert_eq!(v.colour[1], 0.0);
        // sRGB 188 is about half linear light.
        assert!((v.colour[2] - 0.5).abs() < 0.01, "{:?}", v.colour);
        assert_eq!(v.colour[3], 0.5);
    }
}
