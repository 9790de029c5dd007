//! The validation layer is really on in GPU tests and its errors are really counted: a
//! deliberately invalid call must register (wgpu's "validation canary" idea). Without this,
//! "zero validation errors" in the other tests could mean "validation never ran".

mod common;

use ash::vk;

#[test]
fn an_invalid_call_is_counted_as_a_validation_error() {
    let ctx = tiltfield::gpu::GpuContext::new(&common::gpu_options()).expect("validated context");
    assert_eq!(
        ctx.validation().errors(),
        0,
        "{:?}",
        ctx.validation().messages()
    );
    // A buffer of size 0 violates VUID-VkBufferCreateInfo-size-00912.
    let info = vk::BufferCreateInfo::default()
        .size(0)
        .usage(vk::BufferUsageFlags::TRANSFER_SRC);
    // SAFETY: deliberately invalid create info; the driver may still return a handle, which is
    // destroyed right away.
    if let Ok(b) = unsafe { ctx.device.create_buffer(&info, None) } {
        unsafe { ctx.device.destroy_buffer(b, None) };
    }
    assert!(
        ctx.validation().errors() >= 1,
        "the validation layer did not report the invalid call"
    );
    assert!(
        ctx.validation()
            .messages()
            .iter()
            .any(|m| m.contains("size")),
        "{:?}",
        ctx.validation().messages()
    );
}
