//! The debug messenger's callback and the per-context message counts it updates.

use std::ffi::{c_void, CStr};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use ash::vk;

/// Message counts of one context. Owned (through an `Arc`) by the context; the messenger only
/// borrows it through its user-data pointer and is destroyed first.
#[derive(Debug, Default)]
pub struct ValidationLog {
    errors: AtomicUsize,
    warnings: AtomicUsize,
    messages: Mutex<Vec<String>>,
}

/// At most this many messages are kept for reports.
const KEEP: usize = 32;

impl ValidationLog {
    /// Number of error messages so far.
    pub fn errors(&self) -> usize {
        self.errors.load(Ordering::SeqCst)
    }

    /// Number of warning messages so far.
    pub fn warnings(&self) -> usize {
        self.warnings.load(Ordering::SeqCst)
    }

    /// The first error and warning messages, for test failure reports.
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }

    fn record(&self, severity: vk::DebugUtilsMessageSeverityFlagsEXT, text: String) {
        let label = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
            self.errors.fetch_add(1, Ordering::SeqCst);
            log::error!("vulkan: {text}");
            "error"
        } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
            self.warnings.fetch_add(1, Ordering::SeqCst);
            log::warn!("vulkan: {text}");
            "warning"
        } else {
            log::debug!("vulkan: {text}");
            return;
        };
        if let Ok(mut m) = self.messages.lock() {
            if m.len() < KEEP {
                m.push(format!("{label}: {text}"));
            }
        }
    }
}

/// The messenger callback. Never unwinds across the FFI boundary.
///
/// # Safety
/// Called by the Vulkan loader with valid callback data; `user_data` is null or points to a
/// live [`ValidationLog`].
pub unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    let _ = std::panic::catch_unwind(|| {
        // SAFETY: the loader passes valid callback data for the duration of the call.
        let text = unsafe {
            if data.is_null() || (*data).p_message.is_null() {
                String::from("(no message)")
            } else {
                CStr::from_ptr((*data).p_message)
                    .to_string_lossy()
                    .into_owned()
            }
        };
        if user_data.is_null() {
            log::warn!("vulkan: {text}");
        } else {
            // SAFETY: user_data is the context's ValidationLog, which outlives the messenger.
            let log = unsafe { &*(user_data as *const ValidationLog) };
            log.record(severity, text);
        }
    });
    vk::FALSE
}
