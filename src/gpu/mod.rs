//! Hand-written Vulkan (ash) for tiltfield: the context (a shared handle every pass and resource
//! of a process holds), owning resource wrappers, one staging upload, command and barrier
//! helpers, pipelines, frames in flight, the swapchain of a window, timestamp queries.
//!
//! Design decisions:
//! - Vulkan 1.3 with `dynamicRendering` and `synchronization2`: no render pass or framebuffer
//!   objects, barriers through [`commands::image_barrier`].
//! - Every object that owns a handle frees it in `Drop`: buffers, images, submissions and the
//!   frames in flight hold a clone of the [`context::GpuContext`] (a shared handle), and passes
//!   hold their pipelines, layouts and pools as [`owned::Owned`] guards. So a failure half-way
//!   through building anything is a plain `?`, and the device, torn down with its last clone,
//!   outlives every object made from it. Owners are not `Clone`: a double free does not
//!   compile. Dropping is only safe once the GPU is done with an object, so jobs and the viewer
//!   wait for their submissions before letting go of what they recorded.
//! - Validation messages are counted per context (through the messenger's user data), so tests
//!   assert zero errors for the context they used.
//! - Objects are named through `VK_EXT_debug_utils`, so messages say "accumulation target".
//! - A failed call names itself: `vk::Result` does not convert into the crate's error by `?`;
//!   each call site says which call it was (`.vk("vkCreateImage")?`,
//!   [`crate::error::VkContext`]), so a report reads "vkCreateImage failed: …".

pub mod commands;
pub mod context;
pub mod frames;
pub mod owned;
pub mod pipeline;
pub mod pod;
pub mod resources;
pub mod shaders;
pub mod swapchain;
pub mod timing;
pub mod upload;
pub mod validation;

pub use context::{GpuContext, GpuOptions};
pub use owned::{Owned, OwnedResult};
