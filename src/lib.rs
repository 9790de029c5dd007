//! # tiltfield
//!
//! A Vulkan-native light field renderer: tilt-shift refocus with generalized shift-and-sum
//! (Alain, Aenchbacher, Smolic 2019). Every view of a light field is warped by a per-view
//! homography onto a refocus plane of any orientation and the views inside a synthetic aperture
//! are averaged, in linear light by default.
//!
//! Layout:
//! - [`geometry`]: cameras, planes, homographies, apertures, depth → points, normals,
//!   plane picking — pure f64 maths, no GPU;
//! - [`lightfield`]: the data model and the loaders (HCI, manifest, grid folders, PFM,
//!   Technicolor-layout camera-array video and its frame sequence), PLY output;
//! - [`depth`]: depth from the light field itself — the plane sweep's maths, the CPU reference,
//!   the cache and `ensure_depth` (the GPU sweep is [`passes::depth`]);
//! - [`refocus`]: focus requests → the refocus plane (focus), → per-view warps (plan), the f64
//!   CPU reference renderer;
//! - [`scene`]: scene geometry as CPU data — the point cloud, the plane quad, camera markers,
//!   axis and normal lines — and the triangle meshes the rasterizer draws;
//! - [`io`]: writing PNG and EXR images;
//! - [`gpu`]: hand-written Vulkan (context, resources, upload, commands, pipelines, frames in
//!   flight, swapchain, timing, validation);
//! - [`passes`]: the light field texture, the refocus pass (fragment, batched and compute
//!   strategies recording into caller-owned targets), the scene pass (point cloud, cameras and
//!   the plane as a transparent quad), the window compositor and the mesh rasterizer;
//! - [`headless`]: offscreen rendering for the CLI and the tests;
//! - [`viewer`]: the interactive window (`tiltfield view`): UI state, input, progressive
//!   refinement, the scene panel camera, and the window loop;
//! - [`batch`]: a frame range of a camera-array video with one GPU set-up (decode, refocus and
//!   encode overlapped on three threads);
//! - [`synth`]: synthetic scenes with exact ground truth: a CPU ray tracer of textured quads,
//!   triangle meshes from glTF or the built-in scenes rendered by the Vulkan rasterizer
//!   (`tiltfield synth`), and the optical ground truth of a tilt-shift lens;
//! - [`bench`]: the speed–accuracy benchmark (variants, scaling sweep, charts);
//! - [`cli`]: the `tiltfield` command line; it parses options into library requests and
//!   reports the results.
//!
//! `tiltfield view` opens a window; every other command renders offscreen. Conventions and equations (camera
//! model, homographies, masks, disparity, colour) are stated in `docs/conventions.md`; the
//! code cites its sections as `docs/conventions.md §N`.

pub mod bench;
pub mod cli;
pub mod color;
pub mod depth;
pub mod error;
pub mod geometry;
pub mod gpu;
pub mod io;
pub mod jobs;
pub mod lightfield;
pub mod passes;
pub mod refocus;
pub mod scene;
pub mod synth;
pub mod viewer;

pub use error::{Error, Result};
