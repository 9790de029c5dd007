//! The driver layer: everything that runs GPU work to completion for a front end (the CLI, the
//! benchmark, the tests, the viewer's captures) and hands back plain data.
//!
//! A job owns (or shares) the [`GpuContext`](crate::gpu::GpuContext), creates the targets,
//! records the passes of [`crate::passes`] into them, submits, times with timestamp queries and
//! reads the result back through the one readback helper
//! ([`crate::gpu::commands::record_readback`]). Passes only record into targets their caller
//! owns; the model modules (`geometry`, `lightfield`, `refocus`, `depth`, `scene`, `synth`)
//! never import this layer, `gpu` or `passes`.
//!
//! - [`refocus`]: headless refocus images (render, frames, tests);
//! - [`render`]: one render as a front end asks for it (options, depth, focus, plans);
//! - [`animate`]: focus pulls, tilt sweeps and orbits as animated PNG, GIF or MP4;
//! - [`cloud`]: the point cloud with the focus planes and the cameras, as a PLY mesh;
//! - [`batch`]: many refocus images of one light field in one set-up (focal stacks, videos);
//! - [`depth`]: the GPU plane sweep of [`crate::depth`]'s plan, and `ensure_depth` with its cache;
//! - [`strategy`]: `--strategy auto`, the fastest way of summing on this device (measured once);
//! - [`raster`]: synthetic light fields and optical ground truth from the mesh rasterizer.

pub mod animate;
pub mod batch;
pub mod cloud;
pub mod depth;
pub mod raster;
pub mod refocus;
pub mod render;
pub mod strategy;
