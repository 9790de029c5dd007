//! # tiltfield
//!
//! A Vulkan-native light field renderer: tilt-shift refocus with generalized shift-and-sum
//! (Alain, Aenchbacher, Smolic 2019). Every view of a light field is warped by a per-view
//! homography onto a refocus plane of any orientation and the views inside a synthetic aperture
//! are averaged, in linear light by default.
//!
//! Layout, in the layers of `docs/architecture.md` (each imports only the layers below it;
//! `tests/architecture.rs` checks it):
//!
//! The model (plain data and maths, no GPU):
//! - [`geometry`]: cameras, planes, homographies, apertures, depth → points, normals,
//!   plane picking — pure f64 maths;
//! - [`lightfield`]: the data model and the loaders (HCI, manifest, grid folders, PFM,
//!   Technicolor-layout camera-array video and its frame sequence), PLY output;
//! - [`refocus`]: focus requests → the refocus plane (focus), → per-view warps (plan), focus
//!   surfaces, anti-aliasing plans, the refocus settings a front end picks (strategy, filter,
//!   storage, …) and the f64 CPU reference renderer;
//! - [`depth`]: depth from the light field itself — the plane sweep's maths, the CPU reference,
//!   the evaluation sets and the cache (the GPU sweep is [`passes::depth`], run by
//!   [`jobs::depth`]);
//! - [`scene`]: scene geometry as CPU data — the point cloud, the plane quad, camera markers,
//!   axis and normal lines — and the triangle meshes the rasterizer draws;
//! - [`synth`]: synthetic scenes with exact ground truth: a CPU ray tracer of textured quads,
//!   triangle meshes from glTF or the built-in scenes, and the optical ground truth of a
//!   tilt-shift lens;
//! - [`color`]: the sRGB transfer functions; [`io`]: reading input files and writing PNG and
//!   EXR images; [`error`]: the error type.
//!
//! The GPU, from the bottom up:
//! - [`gpu`]: hand-written Vulkan (context, resources, upload, commands, pipelines, frames in
//!   flight, swapchain, timing, validation);
//! - [`passes`]: the light field texture, the refocus pass (fragment, batched and compute
//!   strategies recording into caller-owned targets), the depth plane sweep, the scene pass
//!   (point cloud, cameras and the plane as a transparent quad), the window compositor and the
//!   mesh rasterizer;
//! - [`jobs`]: GPU work run to completion for a front end — headless refocus images, one
//!   render as a front end asks for it, animations, batches of frames with one GPU set-up, the
//!   depth sweep with its cache, the strategy calibration and the rasterized synthetic light
//!   fields.
//!
//! The front ends:
//! - [`viewer`]: the interactive window (`tiltfield view`): UI state, input, progressive
//!   refinement, the scene panel camera, and the window loop;
//! - [`mod@bench`]: the speed–accuracy benchmark (variants, scaling sweep, charts);
//! - [`cli`]: the `tiltfield` command line; it parses options into library requests and
//!   reports the results. (The Python module is a crate of its own, `python/`.)
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
