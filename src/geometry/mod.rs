//! Pure, GPU-free geometry in f64: cameras, refocus planes, homographies, apertures.
//! The CPU reference renderer and the GPU pass share these definitions; the GPU only receives
//! f32 copies of the matrices computed here.

pub mod aperture;
pub mod camera;
pub mod homography;
pub mod plane;
