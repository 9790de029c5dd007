//! Benchmark variants: one combination of strategy, filter, view storage, accumulation format,
//! aperture and output size, each with the accuracy bound it promises against the f64 model
//! of its own filter.
//!
//! A variant is written as `/`-separated tokens in any order; what is not given is `render`'s
//! default: `fragment|batched:N|compute`, `hardware|shader|bicubic|nearest`,
//! `srgb8|linear16`, `rgba32f|rgba16f`, `rR` (disk aperture of radius R grid steps; default all
//! views), `WxH` (output size) or `xF` (output scale F, e.g. `x0.5`; default the views' size),
//! `ubo|ssbo` (where the shaders read the warps; default a uniform buffer where they fit).
//! Its canonical name lists the four sampling tokens, then the aperture, size and warp memory
//! if given: `compute/bicubic/linear16/rgba32f/r2/x0.5/ssbo`.

use crate::error::{Error, Result};
use crate::refocus::cpu::Kernel;
use crate::refocus::settings::ViewStorage;
use crate::refocus::settings::{Accumulation, Filter, Strategy, WarpMemory};

/// Largest output side a variant may ask for: each variant is checked against an f64 CPU
/// model of the same size, which costs minutes beyond 2048² (and 99999² overflowed).
pub const MAX_SIDE: u32 = 2048;

/// Output size of a variant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OutputSize {
    /// The views' size.
    Full,
    /// The views' size times a factor in (0, 4], rounded, at least 1 pixel.
    Scale(f64),
    /// An explicit size.
    Pixels(u32, u32),
}

impl OutputSize {
    /// The output size for views of `w × h`.
    pub fn resolve(self, w: u32, h: u32) -> (u32, u32) {
        match self {
            OutputSize::Full => (w, h),
            OutputSize::Scale(f) => (
                ((w as f64 * f).round() as u32).max(1),
                ((h as f64 * f).round() as u32).max(1),
            ),
            OutputSize::Pixels(a, b) => (a, b),
        }
    }
}

/// One benchmark variant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Variant {
    pub strategy: Strategy,
    pub filter: Filter,
    pub storage: ViewStorage,
    pub accumulation: Accumulation,
    /// Disk aperture radius in grid steps; `None`: every view.
    pub aperture_radius: Option<f64>,
    pub size: OutputSize,
    /// Where the shaders read the warps; `None`: the pass's default (a uniform buffer where
    /// the views fit).
    pub warps: Option<WarpMemory>,
}

impl Default for Variant {
    /// `render`'s defaults (linear averaging).
    fn default() -> Self {
        Variant {
            strategy: Strategy::default(),
            filter: Filter::default(),
            storage: ViewStorage::default(),
            accumulation: Accumulation::default(),
            aperture_radius: None,
            size: OutputSize::Full,
            warps: None,
        }
    }
}

/// The accuracy a variant promises against the f64 model of its own filter
/// ([`Variant::model`]): PSNR of the sRGB-encoded image at least `min_psnr_db`, no channel of any
/// pixel more than `max_levels` 8-bit levels off.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Bound {
    pub min_psnr_db: f64,
    pub max_levels: f64,
}

impl Variant {
    /// The canonical name (see the module docs).
    pub fn name(&self) -> String {
        let storage = match self.storage {
            ViewStorage::Srgb8 => "srgb8",
            ViewStorage::Linear16 => "linear16",
        };
        let mut name = format!(
            "{}/{}/{}/{}",
            self.strategy.name(),
            self.filter.name(),
            storage,
            self.accumulation.name()
        );
        if let Some(r) = self.aperture_radius {
            name.push_str(&format!("/r{r}"));
        }
        match self.size {
            OutputSize::Full => {}
            OutputSize::Scale(f) => name.push_str(&format!("/x{f}")),
            OutputSize::Pixels(w, h) => name.push_str(&format!("/{w}x{h}")),
        }
        if let Some(m) = self.warps {
            name.push_str(&format!("/{}", m.name()));
        }
        name
    }

    /// A shorter label for charts: the tokens that differ from the default.
    pub fn label(&self) -> String {
        let d = Variant::default();
        let full = self.name();
        let base = d.name();
        let tokens: Vec<&str> = full
            .split('/')
            .zip(base.split('/').chain(std::iter::repeat("")))
            .filter(|(a, b)| a != b)
            .map(|(a, _)| a)
            .collect();
        if tokens.is_empty() {
            "default".into()
        } else {
            tokens.join("/")
        }
    }

    /// True when this is exactly what `render` does by default.
    pub fn is_default(&self) -> bool {
        *self == Variant::default()
    }

    /// The CPU model this variant's filter implements.
    pub fn model(&self) -> Kernel {
        match self.filter {
            Filter::Hardware | Filter::Shader => Kernel::Bilinear,
            Filter::Bicubic => Kernel::Bicubic,
            Filter::Nearest => Kernel::Nearest,
        }
    }

    /// The bound this variant is held to against [`Variant::model`] (float output, linear
    /// averaging). The maximum error is taken over pixels whose masks (nearest: texels) f32 and
    /// f64 decide alike (see `refocus::cpu::ambiguous_pixels`); the PSNR over every pixel.
    /// Hardware bilinear snaps sample positions to 8 fractional bits (and on lavapipe filters
    /// 8-bit texels in 8-bit steps): 55 dB, 2 levels. The shader's own filters compute f32
    /// weights from exactly decoded texels: 60 dB, 1 level. Nearest picks a different texel
    /// wherever f32 and f64 round a tie differently, and half-pixel shifts or output scales put
    /// many samples on ties: 30 dB, and away from ties one view's full swing, 255 / views,
    /// plus 2 levels. RGBA16F sums are rounded once to 11 bits: no extra allowance.
    pub fn bound(&self, views: usize) -> Bound {
        match self.filter {
            Filter::Hardware => Bound {
                min_psnr_db: 55.0,
                max_levels: 2.0,
            },
            Filter::Shader | Filter::Bicubic => Bound {
                min_psnr_db: 60.0,
                max_levels: 1.0,
            },
            Filter::Nearest => Bound {
                min_psnr_db: 30.0,
                max_levels: 255.0 / views.max(1) as f64 + 2.0,
            },
        }
    }
}

impl std::str::FromStr for Variant {
    type Err = Error;
    fn from_str(text: &str) -> Result<Self> {
        let mut v = Variant::default();
        let text = text.trim();
        if text.is_empty() || text == "default" {
            return Ok(v);
        }
        for token in text.split('/') {
            let bad = |why: &str| {
                Error::Invalid(format!(
                    "variant '{text}': {why} '{token}' (tokens: fragment, batched:N, compute, \
                     hardware, shader, bicubic, nearest, srgb8, linear16, rgba32f, rgba16f, rR, \
                     WxH, xF, ubo, ssbo)"
                ))
            };
            if let Ok(s) = token.parse::<Strategy>() {
                v.strategy = s;
            } else if let Ok(f) = token.parse::<Filter>() {
                v.filter = f;
            } else if let Ok(s) = token.parse::<ViewStorage>() {
                v.storage = s;
            } else if let Ok(a) = token.parse::<Accumulation>() {
                v.accumulation = a;
            } else if let Ok(m) = token.parse::<WarpMemory>() {
                v.warps = Some(m);
            } else if let Some(r) = token.strip_prefix('r') {
                let r: f64 = r.parse().map_err(|_| bad("bad aperture radius"))?;
                if !(r.is_finite() && r >= 0.0) {
                    return Err(bad("the aperture radius must be finite and ≥ 0 in"));
                }
                v.aperture_radius = Some(r);
            } else if let Some(f) = token.strip_prefix('x') {
                let f: f64 = f.parse().map_err(|_| bad("bad output scale"))?;
                if !(f.is_finite() && f > 0.0 && f <= 4.0) {
                    return Err(bad("the output scale must lie in (0, 4] in"));
                }
                v.size = OutputSize::Scale(f);
            } else if let Some((w, h)) = token.split_once('x') {
                let (w, h) = match (w.parse::<u32>(), h.parse::<u32>()) {
                    (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
                    _ => return Err(bad("bad output size")),
                };
                if w > MAX_SIDE || h > MAX_SIDE {
                    return Err(Error::Invalid(format!(
                        "variant '{text}': output size {w}x{h} is larger than {MAX_SIDE} pixels \
                         a side (each variant is checked against a CPU model of its size)"
                    )));
                }
                v.size = OutputSize::Pixels(w, h);
            } else {
                return Err(bad("unknown token"));
            }
        }
        Ok(v)
    }
}

/// Parses a comma-separated list of variants (at least one; duplicates removed, order kept).
pub fn parse_list(text: &str) -> Result<Vec<Variant>> {
    let mut out: Vec<Variant> = Vec::new();
    for item in text.split(',') {
        let v: Variant = item.parse()?;
        if !out.contains(&v) {
            out.push(v);
        }
    }
    Ok(out)
}

/// The variants `bench` measures by default: every strategy (batched at three batch sizes,
/// one draw per view among them), every filter, both storages, both accumulation formats,
/// two smaller apertures, two smaller outputs and warps in a storage buffer (the formulation
/// before the uniform buffer won on lavapipe), each changing one thing from the default
/// (compute also with bicubic, RGBA16F and storage-buffer warps).
pub fn catalogue() -> Vec<Variant> {
    [
        "default",
        "batched:1",
        "batched:4",
        "batched:16",
        "compute",
        "shader",
        "bicubic",
        "nearest",
        "srgb8",
        "shader/srgb8",
        "rgba16f",
        "compute/rgba16f",
        "compute/bicubic",
        "r1",
        "r2",
        "x0.5",
        "x0.25",
        "ssbo",
        "compute/ssbo",
    ]
    .iter()
    .map(|t| t.parse().expect("catalogue entries parse"))
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_defaults_fill_in() {
        for v in catalogue() {
            let again: Variant = v.name().parse().unwrap();
            assert_eq!(again, v, "{}", v.name());
        }
        let v: Variant = "x0.5/compute/r2/bicubic".parse().unwrap();
        assert_eq!(v.name(), "compute/bicubic/linear16/rgba32f/r2/x0.5");
        assert_eq!(v.label(), "compute/bicubic/r2/x0.5");
        assert_eq!(Variant::default().label(), "default");
        assert!(Variant::default().is_default() && !v.is_default());
        let v: Variant = "batched:4/srgb8/rgba16f/320x200".parse().unwrap();
        assert_eq!(v.size.resolve(64, 64), (320, 200));
        assert_eq!(OutputSize::Scale(0.5).resolve(65, 64), (33, 32));
    }

    #[test]
    fn bad_tokens_are_named() {
        for bad in [
            "fragment/bogus",
            "r-1",
            "x0",
            "x9",
            "0x5",
            "batched:0",
            "rnan",
        ] {
            let e = bad.parse::<Variant>().unwrap_err().to_string();
            assert!(e.contains(bad.rsplit('/').next().unwrap()), "{bad}: {e}");
        }
        assert_eq!(parse_list("compute,compute,default").unwrap().len(), 2);
    }

    #[test]
    fn catalogue_covers_every_strategy_filter_storage_and_accumulation() {
        let c = catalogue();
        assert_eq!(c.iter().filter(|v| v.is_default()).count(), 1);
        for f in Filter::ALL {
            assert!(c.iter().any(|v| v.filter == f), "{f:?}");
        }
        assert!(c.iter().any(|v| v.strategy == Strategy::Compute));
        assert!(c
            .iter()
            .any(|v| v.strategy == Strategy::Batched { views_per_draw: 1 }));
        assert!(c.iter().any(|v| v.storage == ViewStorage::Srgb8));
        assert!(c.iter().any(|v| v.accumulation == Accumulation::Rgba16f));
        assert!(c.iter().any(|v| v.aperture_radius.is_some()));
        assert!(c.iter().any(|v| v.size != OutputSize::Full));
    }
}
