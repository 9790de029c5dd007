//! Refocus requests: the focus and its plane ([`focus`]), their resolution into per-view warps
//! ([`mod@plan`]), the f64 CPU reference renderer ([`cpu`]), the settings a front end picks for
//! the GPU pass ([`settings`]) and the refocus image type shared with the GPU pass. Writing
//! images to files is [`crate::io`]'s job.

pub mod antialias;
pub mod boxed;
pub mod cpu;
pub mod defocus;
pub mod focus;
pub mod layered;
pub mod options;
pub mod plan;
pub mod prefilter;
pub mod settings;
pub mod surface;

use image::RgbaImage;

use crate::color;
use crate::error::{Error, Result};

pub use focus::{
    resolve_focus, DepthInfo, FocusMethod, FocusRequest, FocusSpec, FocusTarget, ResolvedFocus,
};
pub use plan::{plan, plan_json, PlannedView, RefocusPlan, RefocusRequest};

use crate::geometry::aperture::Aperture;
use crate::lightfield::LightField;

/// Resolves what the user asked to focus on and plans the refocus in one call: the request's
/// focus is resolved from the reference viewpoint (`None`: the grid centre) and the plan uses
/// the aperture there, leaving out the `excluded` views (see
/// [`LightField::excluded_views`]). Every front end (render, frames, the viewer, bench) goes
/// through it, so they validate in the same order: the aperture first, then the focus.
pub fn resolve_and_plan(
    lf: &LightField,
    focus: &FocusRequest,
    aperture: Aperture,
    reference: Option<glam::DVec2>,
    excluded: &[bool],
) -> Result<(ResolvedFocus, RefocusPlan)> {
    aperture.validate()?;
    let resolved = resolve_focus(lf, focus, reference.unwrap_or_else(|| lf.grid.centre()))?;
    let request = RefocusRequest {
        focus: resolved.spec,
        aperture,
        reference,
    };
    let plan = plan(lf, &request, excluded)?;
    Ok((resolved, plan))
}

/// In which space views are averaged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Averaging {
    /// Decode sRGB, average linear light, encode the result (physically right; the default).
    #[default]
    Linear,
    /// Average the encoded values (what most tools do; darkens blurred highlights).
    Encoded,
}

impl std::str::FromStr for Averaging {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "linear" => Ok(Self::Linear),
            "encoded" => Ok(Self::Encoded),
            _ => Err(Error::Invalid(format!(
                "unknown averaging '{s}': expected linear or encoded"
            ))),
        }
    }
}

/// A float refocus image. `rgb` is in the space of `averaging` (linear light, or sRGB-encoded
/// values when averaging encoded); `a` is 1 where at least one view contributed and 0 on the
/// background, whose colour is 0.
#[derive(Debug, Clone)]
pub struct RefocusImage {
    pub width: u32,
    pub height: u32,
    pub averaging: Averaging,
    pub pixels: Vec<[f32; 4]>,
}

impl RefocusImage {
    /// Number of pixels no view contributed to.
    pub fn uncovered(&self) -> usize {
        self.pixels.iter().filter(|p| p[3] == 0.0).count()
    }

    /// True when every value is finite.
    pub fn is_finite(&self) -> bool {
        self.pixels.iter().flatten().all(|v| v.is_finite())
    }

    /// Linear-light RGBA (decoding encoded averages).
    pub fn linear(&self) -> Vec<[f32; 4]> {
        match self.averaging {
            Averaging::Linear => self.pixels.clone(),
            Averaging::Encoded => self
                .pixels
                .iter()
                .map(|p| {
                    let d = |c: f32| color::srgb_to_linear(c as f64) as f32;
                    [d(p[0]), d(p[1]), d(p[2]), p[3]]
                })
                .collect(),
        }
    }

    /// 8-bit sRGB-encoded RGBA, rounding as the GPU's sRGB attachments do.
    pub fn to_srgb8(&self) -> RgbaImage {
        let mut out = RgbaImage::new(self.width, self.height);
        for (dst, p) in out.pixels_mut().zip(&self.pixels) {
            let enc = |c: f32| match self.averaging {
                Averaging::Linear => color::to_u8(color::linear_to_srgb(c as f64)),
                Averaging::Encoded => color::to_u8(c as f64),
            };
            dst.0 = [enc(p[0]), enc(p[1]), enc(p[2]), color::to_u8(p[3] as f64)];
        }
        out
    }
}
