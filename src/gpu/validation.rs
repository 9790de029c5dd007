//! The debug messenger's callback and the per-context message counts it updates.

use std::ffi::{c_void, CStr};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use ash::vk;

use crate::error::{Error, Result};

/// Message counts of one context. Owned (through an `Arc`) by the context; the messenger only
/// borrows it through its user-data pointer and is destroyed first.
#[derive(Debug, Default)]
pub struct ValidationLog {
    errors: AtomicUsize,
    warnings: AtomicUsize,
    messages: Mutex<Vec<String>>,
}

/// Fails when `errors` validation errors were reported while doing `what` ("while rendering",
/// "in the viewer"): a run the validation layer objected to may have drawn anything, so every
/// front end refuses its result with this one message. The messages themselves are in the log.
pub fn check_errors(errors: usize, what: &str) -> Result<()> {
    if errors > 0 {
        return Err(Error::Vulkan(format!(
            "{errors} validation errors {what} (see the log above)"
        )));
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_validation_error_passes_any_other_count_names_it_and_the_work() {
        assert!(check_errors(0, "while rendering").is_ok());
        let e = check_errors(3, "while rendering").unwrap_err();
        assert!(matches!(e, Error::Vulkan(_)), "{e:?}");
        assert_eq!(
            e.to_string(),
            "vulkan: 3 validation errors while rendering (see the log above)"
        );
    }
}
