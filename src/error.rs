//! The library's error type. Every user-facing failure (bad input, degenerate geometry, a light
//! field the device cannot hold, a missing Vulkan driver) is a variant with a message that names
//! the cause; `main` prints it once and exits non-zero.

use std::path::PathBuf;

use ash::vk;

/// Errors at tiltfield's library boundary.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file exists but its content is wrong (truncated, malformed, unsupported).
    #[error("{path}: {message}")]
    BadFile { path: PathBuf, message: String },
    /// A light field is inconsistent as a whole (missing views, mismatched sizes, ...).
    #[error("light field: {0}")]
    LightField(String),
    /// A refocus request is geometrically impossible or degenerate.
    #[error("refocus: {0}")]
    Geometry(String),
    /// Invalid command-line or API argument.
    #[error("{0}")]
    Invalid(String),
    /// The light field or request exceeds what the Vulkan device can hold.
    #[error("device limit: {0}")]
    DeviceLimit(String),
    /// Vulkan is unusable (no loader, no device, missing features or layers).
    #[error("vulkan: {0}")]
    Vulkan(String),
    /// The window system is unusable (no display, no Vulkan presentation).
    #[error("window: {0}")]
    Window(String),
    /// A Vulkan call failed: `call` names it (`vkCreateImage`), so a report says which of the
    /// hundreds of calls the device refused; `result` is the code it returned.
    #[error("vulkan: {call} failed: {result} ({result:?})")]
    VkCall {
        call: &'static str,
        result: vk::Result,
    },
    /// An internal invariant does not hold (an object used before it was fully created, a
    /// readback of the wrong size): a bug in tiltfield, not bad input or a device failure.
    #[error("internal error (a bug in tiltfield): {0}")]
    Internal(String),
}

/// Gives a Vulkan call's `vk::Result` the name of the call, e.g.
/// `unsafe { d.create_image(&info, None) }.vk("vkCreateImage")?`.
pub trait VkContext<T> {
    /// [`Error::VkCall`] naming `call` on failure.
    fn vk(self, call: &'static str) -> Result<T>;
}

impl<T> VkContext<T> for std::result::Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| Error::VkCall { call, result })
    }
}

/// Result alias used throughout the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Wrap an I/O error with the path it concerns. A path that is not found because it is
    /// a link to nothing says so and names the target: "No such file or directory" about a
    /// name that `ls` shows sent users looking for the wrong file.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        let path = path.into();
        let source = match (source.kind(), std::fs::read_link(&path)) {
            (std::io::ErrorKind::NotFound, Ok(target)) => std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!(
                    "a dangling link: its target {} does not exist",
                    target.display()
                ),
            ),
            _ => source,
        };
        Error::Io { path, source }
    }

    /// A malformed-file error naming the file.
    pub fn bad_file(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::BadFile {
            path: path.into(),
            message: message.into(),
        }
    }
}

/// A number as error messages and warnings print it: as typed up to a million, in scientific
/// notation (4 decimals) beyond and below 1e-4, so `--disparity=1e308` is not echoed as 309
/// digits.
pub fn compact(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-4..1e6).contains(&a) {
        format!("{v:.4e}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_vulkan_call_names_the_call_and_its_result() {
        let failed: std::result::Result<(), vk::Result> =
            Err(vk::Result::ERROR_OUT_OF_DEVICE_MEMORY);
        let e = failed.vk("vkCreateImage").unwrap_err();
        assert!(
            matches!(
                e,
                Error::VkCall {
                    call: "vkCreateImage",
                    result: vk::Result::ERROR_OUT_OF_DEVICE_MEMORY
                }
            ),
            "{e:?}"
        );
        let text = e.to_string();
        assert!(text.starts_with("vulkan: vkCreateImage failed: "), "{text}");
        assert!(text.contains("ERROR_OUT_OF_DEVICE_MEMORY"), "{text}");
        assert_eq!(Ok::<u32, vk::Result>(7).vk("vkCreateImage").unwrap(), 7);
    }

    #[test]
    fn huge_and_tiny_numbers_are_compact_others_as_typed() {
        assert_eq!(compact(1e308), "1.0000e308");
        assert_eq!(compact(-2.5e-9), "-2.5000e-9");
        assert_eq!(compact(0.25), "0.25");
        assert_eq!(compact(-3.0), "-3");
        assert_eq!(compact(0.0), "0");
        assert_eq!(compact(f64::NAN), "NaN");
    }
}
