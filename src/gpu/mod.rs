//! Hand-written Vulkan (ash) for tiltfield: the context (shared by every pass of a process
//! through an `Arc`), owning resource wrappers, one staging upload, command and barrier
//! helpers, pipelines, frames in flight, the swapchain of a window, timestamp queries.
//!
//! Design decisions:
//! - Vulkan 1.3 with `dynamicRendering` and `synchronization2`: no render pass or framebuffer
//!   objects, barriers through [`commands::image_barrier`].
//! - Every object that owns a handle is destroyed by value (`destroy(self, &ctx)`), so a double
//!   free does not compile; none of them is `Clone`. [`context::GpuContext`] waits for the device
//!   to be idle and tears down in reverse creation order in its `Drop`.
//! - Validation messages are counted per context (through the messenger's user data), so tests
//!   assert zero errors for the context they used.
//! - Objects are named through `VK_EXT_debug_utils`, so messages say "accumulation target".
//! - A failed call names itself: `vk::Result` does not convert into the crate's error by `?`;
//!   each call site says which call it was (`.vk("vkCreateImage")?`,
//!   [`crate::error::VkContext`]), so a report reads "vkCreateImage failed: …".

pub mod commands;
pub mod context;
pub mod frames;
pub mod pipeline;
pub mod pod;
pub mod resources;
pub mod shaders;
pub mod swapchain;
pub mod timing;
pub mod upload;
pub mod validation;

pub use context::{GpuContext, GpuOptions};
