//! Pure, GPU-free geometry in f64: cameras, refocus planes, homographies, apertures, and the
//! scene side of plane placement: depth maps → point clouds ([`depth`]), PCA normals
//! ([`normals`]), click / three-point / nudge picking ([`picking`]).
//! The CPU reference renderer and the GPU pass share these definitions; the GPU only receives
//! f32 copies of the matrices computed here.

pub mod aperture;
pub mod camera;
pub mod depth;
pub mod homography;
pub mod normals;
pub mod picking;
pub mod plane;
pub mod rig;
