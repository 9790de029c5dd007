//! `tiltfield view`: the interactive tilt-shift refocus window.
//!
//! One window, two panels: the refocus image (left or top) and a 3-D scene view of the point
//! cloud with the cameras, the reference optical axis, the plane normal and the refocus plane
//! as a transparent quad (right or bottom), with a status strip along the bottom.
//!
//! The parts, each in its own module, in three layers:
//! - [`app`]: the window and the event loop — GLFW, events and script commands → session
//!   calls and [`state::Action`]s, one frame per turn when there is anything to draw;
//! - [`session`]: one viewing session — the UI state with everything derived from it that
//!   outlives a frame: depth and point cloud, progressive refinement, video stepping and
//!   decoding, the on-screen text, the scene panel's geometry, screenshots, statistics;
//! - [`state`]: the UI state and every action on it (pure; no window, no GPU); every change
//!   of the state goes through [`state::ViewerState::apply`];
//!
//! and their helpers:
//! - [`controls`]: key bindings and the help text;
//! - [`script`]: `--script` files, checked before the window opens, and their runner;
//! - [`refine`]: the refinement schedule — view order, batch size, preview size;
//! - [`orbit`]: the scene panel's camera and point picking;
//! - [`panel`]: the control panel's widgets (sliders and buttons) and the actions they make;
//! - [`layout`]: where the panels are;
//! - [`text`]: the on-screen text canvas;
//! - [`gpu`]: the Vulkan side (texture, passes, targets, swapchain, frames in flight), which
//!   records what a [`gpu::FrameRequest`] asks for and holds no UI state.
//!
//! Idle costs nothing: when the image has converged and nothing changed, the loop blocks in
//! the window system's event wait (no frames, no GPU work).

pub mod app;
pub mod controls;
pub mod gpu;
pub mod layout;
pub mod orbit;
pub mod panel;
pub mod refine;
pub mod script;
pub mod session;
pub mod state;
pub mod text;

pub use app::{run, Loaded, Loader, ViewerOptions, ViewerReport};
pub use session::screenshot::screenshot_json;
pub use session::stats::FrameStats;
