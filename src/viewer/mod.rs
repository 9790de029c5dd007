//! `tiltfield view`: the interactive tilt-shift refocus window.
//!
//! One window, two panels: the refocus image (left or top) and a 3-D scene view of the point
//! cloud with the cameras, the reference optical axis, the plane normal and the refocus plane
//! as a transparent quad (right or bottom), with a status strip along the bottom.
//!
//! The parts, each in its own module:
//! - [`state`]: what is shown, and how every action changes it (pure; no window, no GPU);
//! - [`controls`]: key bindings and the help text;
//! - [`script`]: `--script` files, checked before the window opens;
//! - [`refine`]: progressive refinement — view order, batch size, preview size;
//! - [`orbit`]: the scene panel's camera and point picking;
//! - [`layout`]: where the panels are;
//! - [`text`]: the on-screen text canvas;
//! - [`gpu`]: the Vulkan side (texture, passes, targets, swapchain, frames in flight);
//! - [`app`]: the window and the event loop that ties them together.
//!
//! Idle costs nothing: when the image has converged and nothing changed, the loop blocks in
//! the window system's event wait (no frames, no GPU work).

pub mod app;
pub mod controls;
pub mod gpu;
pub mod layout;
pub mod orbit;
pub mod refine;
pub mod script;
pub mod state;
pub mod text;

pub use app::{run, FrameStats, ViewerOptions, ViewerReport};
