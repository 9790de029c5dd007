//! Synthetic scenes: an analytic CPU ray tracer of textured rectangles, used for the built-in
//! `demo` light field (no files needed) and by tests that need light fields with exact ground
//! truth; and triangle meshes (from glTF or the same quad scenes) rendered by the Vulkan
//! rasterizer for `tiltfield synth`, with depth, disparity, normals and the optical ground truth
//! of a tilt-shift lens.
//!
//! Model: by default albedo only — a pixel's colour is the procedural texture
//! ([`texture::Texture`], linear light) of the nearest surface its ray hits, or the scene's
//! background. The ray tracer can also light a scene ([`scene::Lighting`]: Lambertian under an
//! area light with soft shadows, ambient, a mild view-dependent highlight), as the depth test
//! set's shaded scenes do; the rasterizer of `tiltfield synth` draws albedo only.
//!
//! Conventions (those of [`crate::geometry::camera`]):
//! - world → camera `X_c = R X + t`, camera axes x right, y down, z forward;
//! - pixel-index coordinates: pixel (i, j)'s centre is at (i, j); a pixel's footprint is
//!   [i − ½, i + ½] × [j − ½, j + ½];
//! - a built-in scene's world frame is its centre camera's frame, and its cameras are an HCI
//!   parallel rig with sensor shift ([`crate::lightfield::ParallelRig::cameras`]);
//! - colours are computed and averaged in linear light and stored as 8-bit sRGB
//!   ([`crate::color`], the exact IEC 61966-2-1 curves);
//! - depth maps store camera-frame z at the pixel centre (NaN for background), disparity maps
//!   the HCI disparity of that depth.
//!
//! Modules: [`texture`] (procedural textures), [`scene`] (quads, ray
//! intersection, [`scene::plane_scene`]), [`raytrace`] (views and light fields), [`mod@builtin`]
//! (the named scenes, their planes and disparity ranges); for the rasterizer [`mesh`] (quad
//! scenes baked into textured meshes of [`crate::scene::mesh`]), [`mod@gltf`] (glTF input),
//! [`scenes`] (the built-in scenes of `synth`) and [`rig`] (camera rigs, the rendered light
//! field, sRGB encoding; the GPU rasterizer that renders views, light fields and the optical
//! ground truth is the driver [`crate::jobs::raster`]);
//! for the geometry studies [`surfaces`] (analytic depth views with exact normals and seeded
//! depth noise).

pub mod builtin;
pub mod gltf;
pub mod mesh;
pub mod raytrace;
pub mod rig;
pub mod scene;
pub mod scenes;
pub mod surfaces;
pub mod texture;

pub use crate::scene::mesh::MeshScene;
pub use builtin::{builtin, builtin_names, BuiltinScene};
pub use raytrace::{pixel_ray, render_light_field, render_view, trace_pixel};
pub use rig::{RigKind, SynthLightField, SynthRig};
pub use scene::{plane_scene, Hit, Quad, Scene};
pub use scenes::{synth_scene, synth_scene_names, SynthScene};
pub use texture::{Rgb, Texture};
