//! The refocus settings every front end chooses from: how views are summed ([`Strategy`]),
//! sampled ([`Filter`]) and stored ([`ViewStorage`]), the float format of the sum
//! ([`Accumulation`]), where the warps are read from ([`WarpMemory`]) and what a resolve writes
//! ([`OutputFormat`]).
//!
//! They live here, free of the GPU, so the command line, the bench and the Python module can
//! name, parse and report them without importing the passes that implement them
//! ([`crate::passes::refocus`], [`crate::passes::texture`] map them to Vulkan formats and
//! shader codes). Parsing accepts the command line's spellings; messages name the setting.

use crate::error::{Error, Result};
use crate::refocus::Averaging;

/// How the views are summed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase", tag = "kind")]
pub enum Strategy {
    /// One fullscreen draw loops over every view.
    #[default]
    Fragment,
    /// Draws of at most `views_per_draw` views, summed by additive blending.
    Batched { views_per_draw: usize },
    /// One compute dispatch per range of views, summed in a storage image.
    Compute,
}

impl Strategy {
    /// Batch size of `batched` when none is given.
    pub const DEFAULT_BATCH: usize = 9;

    /// A short name: `fragment`, `batched:N`, `compute`.
    pub fn name(&self) -> String {
        match self {
            Strategy::Fragment => "fragment".into(),
            Strategy::Batched { views_per_draw } => format!("batched:{views_per_draw}"),
            Strategy::Compute => "compute".into(),
        }
    }
}

impl std::str::FromStr for Strategy {
    type Err = Error;
    /// `fragment`, `batched`, `batched:N` or `compute`.
    fn from_str(s: &str) -> Result<Self> {
        let bad = || {
            Error::Invalid(format!(
                "unknown strategy '{s}': expected fragment, batched, batched:N (N ≥ 1) or compute"
            ))
        };
        match s.split_once(':') {
            None => match s {
                "fragment" => Ok(Self::Fragment),
                "batched" => Ok(Self::Batched {
                    views_per_draw: Self::DEFAULT_BATCH,
                }),
                "compute" => Ok(Self::Compute),
                _ => Err(bad()),
            },
            Some(("batched", n)) => match n.parse::<usize>() {
                Ok(n) if n >= 1 => Ok(Self::Batched { views_per_draw: n }),
                _ => Err(bad()),
            },
            Some(_) => Err(bad()),
        }
    }
}

/// How a view is sampled at a warped position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Filter {
    /// The sampler's bilinear filter: one fetch, positions snapped to 8 fractional bits.
    #[default]
    Hardware,
    /// The nearest texel.
    Nearest,
    /// Bilinear in the shader from four texel fetches with f32 weights.
    Shader,
    /// Bicubic (Catmull-Rom, a = −½) in the shader from sixteen texel fetches with f32
    /// weights: sharper than bilinear at fractional shifts, interpolating (texel centres are
    /// reproduced exactly), and may overshoot near edges (no clamping before the average).
    Bicubic,
}

impl Filter {
    /// Every filter, in the order the CLI lists them.
    pub const ALL: [Filter; 4] = [
        Filter::Hardware,
        Filter::Shader,
        Filter::Bicubic,
        Filter::Nearest,
    ];

    /// The name the CLI accepts.
    pub fn name(self) -> &'static str {
        match self {
            Filter::Hardware => "hardware",
            Filter::Nearest => "nearest",
            Filter::Shader => "shader",
            Filter::Bicubic => "bicubic",
        }
    }
}

impl std::str::FromStr for Filter {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "hardware" => Ok(Self::Hardware),
            "nearest" => Ok(Self::Nearest),
            "shader" => Ok(Self::Shader),
            "bicubic" => Ok(Self::Bicubic),
            _ => Err(Error::Invalid(format!(
                "unknown filter '{s}': expected hardware, shader, bicubic or nearest"
            ))),
        }
    }
}

/// The float format the views are summed in (a property of the
/// [`RefocusTarget`](crate::passes::refocus::RefocusTarget)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Accumulation {
    /// RGBA32F: 24-bit mantissas, exact for any practical number of views. The default.
    #[default]
    Rgba32f,
    /// RGBA16F: half the memory and bandwidth. The fragment and compute strategies write
    /// each pixel's sum once (one rounding, relative error ≤ 2⁻¹¹); batched draws round after
    /// every draw.
    Rgba16f,
}

impl Accumulation {
    /// The name the CLI accepts.
    pub fn name(self) -> &'static str {
        match self {
            Accumulation::Rgba32f => "rgba32f",
            Accumulation::Rgba16f => "rgba16f",
        }
    }
}

impl std::str::FromStr for Accumulation {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "rgba32f" => Ok(Self::Rgba32f),
            "rgba16f" => Ok(Self::Rgba16f),
            _ => Err(Error::Invalid(format!(
                "unknown accumulation '{s}': expected rgba32f or rgba16f"
            ))),
        }
    }
}

/// Records in the uniform-buffer binding of the warps: 16 KiB, the least
/// `maxUniformBufferRange` Vulkan guarantees.
pub const UBO_WARPS: usize = 256;

/// Where the accumulation shaders read the per-view warps from.
///
/// Measured on lavapipe (llvmpipe, Mesa 22.3): a storage-buffer load whose index is the loop
/// counter is compiled as a loop over the SIMD lanes with a bounds check and a branch per
/// lane, while a uniform-buffer load is one vector gather; with 81 views the storage path
/// spent about 90 % of the refocus time loading warps. GPUs serve both from the same caches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum WarpMemory {
    /// A uniform buffer of at most [`UBO_WARPS`] records (the default where the views fit).
    #[default]
    Uniform,
    /// A storage buffer: any number of views.
    Storage,
}

impl WarpMemory {
    /// The default for a light field of `views` views.
    pub fn for_views(views: usize) -> Self {
        if views <= UBO_WARPS {
            WarpMemory::Uniform
        } else {
            WarpMemory::Storage
        }
    }

    /// The name the CLI accepts (`ubo`, `ssbo`).
    pub fn name(self) -> &'static str {
        match self {
            WarpMemory::Uniform => "ubo",
            WarpMemory::Storage => "ssbo",
        }
    }
}

impl std::str::FromStr for WarpMemory {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "ubo" => Ok(Self::Uniform),
            "ssbo" => Ok(Self::Storage),
            _ => Err(Error::Invalid(format!(
                "unknown warp memory '{s}': expected ubo or ssbo"
            ))),
        }
    }
}

/// How the views are stored on the GPU ([`crate::passes::texture`] says what each costs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ViewStorage {
    /// RGBA8 sRGB-encoded, as loaded (4 bytes per texel).
    Srgb8,
    /// RGBA16 UNORM linear light, decoded exactly on upload (8 bytes per texel). The default:
    /// hardware filtering then averages exact linear values (an unbiased 8-bit output on
    /// every device), at the speed of 8-bit sRGB storage on lavapipe (measured 0.99× its
    /// time for 81 × 512²).
    #[default]
    Linear16,
}

impl ViewStorage {
    /// The storage to use for `averaging` when none is asked for: exact linear light for
    /// linear averaging; for encoded averaging the texels as loaded, which the hardware can
    /// filter directly (linear storage would need a per-texel re-encode in the shader).
    pub fn for_averaging(averaging: Averaging) -> Self {
        match averaging {
            Averaging::Linear => ViewStorage::Linear16,
            Averaging::Encoded => ViewStorage::Srgb8,
        }
    }
}

impl std::str::FromStr for ViewStorage {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "srgb8" => Ok(Self::Srgb8),
            "linear16" => Ok(Self::Linear16),
            _ => Err(Error::Invalid(format!(
                "unknown view storage '{s}': expected srgb8 or linear16"
            ))),
        }
    }
}

/// Output format of a resolve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputFormat {
    /// 8-bit sRGB-encoded RGBA (PNG), rounded to nearest in the shader.
    Srgb8,
    /// 32-bit float RGBA in the averaging space (linear light for EXR).
    Float,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strategies_parse_and_name_round_trip() {
        for s in ["fragment", "batched:4", "compute"] {
            assert_eq!(s.parse::<Strategy>().unwrap().name(), s);
        }
        assert_eq!(
            "batched".parse::<Strategy>().unwrap(),
            Strategy::Batched {
                views_per_draw: Strategy::DEFAULT_BATCH
            }
        );
        for bad in ["batched:0", "batched:x", "vertex", "compute:2"] {
            let e = bad.parse::<Strategy>().unwrap_err().to_string();
            assert!(e.contains(bad), "{e}");
        }
    }
}
