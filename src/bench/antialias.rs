//! The anti-aliasing study of `bench`: the plain sum and anti-aliased refocus at several
//! sub-sample caps, on synth's `layers` scene (four textured planes at −3, 0, +2 and +6 px of
//! disparity per grid step at 128-pixel views; a sparse 5×5 grid; a disk aperture of radius 2
//! grid steps; focus on the 0-px panel), timed side by side in one run and scored against the
//! optical ground truth of a lens with the same disk: overall, on the out-of-focus pixels and
//! on the focused plane. Each point reports its GPU time as a ratio to the plain sum's.
//!
//! The truth uses 129 pinholes per side of the aperture grid (~13 000 in the disk; quick: 65):
//! with ~800 the truth itself is still noisy on the scene's fine grain.

use std::sync::Arc;

use glam::DVec3;
use indicatif::ProgressBar;

use super::{antialias_set, stats};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::jobs::refocus::{GpuImage, HeadlessRenderer, PassTimings, RenderSettings};
use crate::lightfield::LightField;
use crate::refocus::antialias::{plan_for, AntialiasPlan, AntialiasSettings, Layered};
use crate::refocus::settings::OutputFormat;
use crate::refocus::{RefocusImage, RefocusPlan};

/// The settings the study measures: sub-sample caps per axis with the prefiltered lookup
/// (`aaN`), without it (`aaN-sharp`: every sub-sample a full-resolution fetch), the default
/// without the focus test (`aa4-untested`: the depth alone decides every pixel), without
/// Catmull-Rom for in-focus sub-samples (`aa4-bilinear`) and without the occlusion tests
/// (`aa4-open`), the cheapest sub-sampling setting, [`AntialiasSettings::FASTEST`]
/// (`aa1-fastest`), defocused views (`defocus`: constant cost per view, no occlusion
/// tests), layered footprints (`layered`: every view's sample binned by depth, each layer
/// box-filtered once, no per-sample tests: the default on the study's given depth), and boxed
/// footprints (`boxed`: the box of the plain sums away from occlusion edges, `aa4`'s
/// sub-samples at them and in focus; the default before layered footprints). Every `aaN`
/// point sub-samples every pixel: `aa4` is the default before boxed footprints.
pub const VARIANTS: [AntialiasSettings; 14] = [
    aa(1, true),
    aa(2, true),
    aa(4, true),
    aa(1, false),
    aa(2, false),
    aa(4, false),
    aa(8, false),
    AntialiasSettings {
        focus_test: false,
        ..aa(4, true)
    },
    AntialiasSettings {
        focused_bicubic: false,
        ..aa(4, true)
    },
    AntialiasSettings {
        occlusion: false,
        ..aa(4, true)
    },
    AntialiasSettings::FASTEST,
    AntialiasSettings {
        defocus: true,
        ..aa(4, true)
    },
    AntialiasSettings {
        layered: Layered::On,
        ..aa(4, true)
    },
    AntialiasSettings {
        boxed: true,
        ..aa(4, true)
    },
];

const fn aa(max_samples: u32, prefilter: bool) -> AntialiasSettings {
    AntialiasSettings {
        max_samples,
        prefilter,
        focus_test: true,
        focused_bicubic: true,
        occlusion: true,
        defocus: false,
        layered: Layered::Off,
        boxed: false,
    }
}

/// The study's name for `s`.
fn variant_name(s: &AntialiasSettings) -> String {
    if *s == AntialiasSettings::FASTEST {
        return format!("aa{}-fastest", s.max_samples);
    }
    // Boxed and layered footprints are named by their route alone (no switch below applies).
    if let Some(r @ ("boxed" | "layered")) = route(s) {
        return r.into();
    }
    if s.defocus {
        let base = "defocus".to_string();
        return if s.focus_test {
            base
        } else {
            format!("{base}-untested")
        };
    }
    let base = if s.prefilter {
        format!("aa{}", s.max_samples)
    } else {
        format!("aa{}-sharp", s.max_samples)
    };
    let base = if s.focused_bicubic {
        base
    } else {
        format!("{base}-bilinear")
    };
    let base = if s.focus_test {
        base
    } else {
        format!("{base}-untested")
    };
    if s.occlusion {
        base
    } else {
        format!("{base}-open")
    }
}

/// The footprint route of `s` when it is not sub-samples everywhere (see
/// [`AntialiasPoint::route`]).
fn route(s: &AntialiasSettings) -> Option<&'static str> {
    if s.boxed {
        Some("boxed")
    } else if s.layered == Layered::On {
        Some("layered")
    } else if s.defocus {
        Some("defocus")
    } else {
        None
    }
}

/// One point of the study.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AntialiasPoint {
    /// `plain`, `aaN` (at most N × N sub-samples per view, prefiltered) or `aaN-sharp`
    /// (without the prefilter).
    pub name: String,
    pub max_samples: Option<u32>,
    /// Whether the sub-samples read the prefilter pyramid.
    pub prefilter: bool,
    /// Whether the focus test ran (views that agree at the focus plane: the plain sum).
    pub focus_test: bool,
    /// Whether in-focus sub-samples read Catmull-Rom.
    pub focused_bicubic: bool,
    /// Whether sub-samples near a nearer surface were tested for occlusion.
    pub occlusion: bool,
    /// The footprint route other than sub-samples everywhere, if any: `defocus` (each view's
    /// cell read once, defocused), `layered` (the samples binned by depth, each layer boxed
    /// once; the default on a given depth) or `boxed` (the box of the plain sums away from
    /// edges).
    pub route: Option<&'static str>,
    pub views: usize,
    pub gpu_ms_median: f64,
    /// GPU time over the plain sum's, same run.
    pub cost_ratio: f64,
    pub psnr_vs_truth_db: f64,
    pub psnr_out_of_focus_db: f64,
    pub psnr_focused_db: f64,
}

/// The study's scene and results.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AntialiasReport {
    pub scene: String,
    pub size: [u32; 2],
    pub truth_pinholes: usize,
    pub frames: usize,
    pub points: Vec<AntialiasPoint>,
}

pub(super) fn float(img: GpuImage) -> Result<RefocusImage> {
    match img {
        GpuImage::Float(f) => Ok(f),
        GpuImage::Srgb8(_) => Err(Error::Internal("asked for float output".into())),
    }
}

/// Linear RGBA to the sRGB-encoded values the scores compare (0–1).
pub(super) fn encoded(px: &[[f32; 4]]) -> Vec<[f64; 3]> {
    px.iter()
        .map(|p| {
            std::array::from_fn(|k| crate::color::linear_to_srgb((p[k] as f64).clamp(0.0, 1.0)))
        })
        .collect()
}

/// PSNR (dB, peak 1) of `a` against `b` over the pixels of `mask`.
pub(super) fn psnr(a: &[[f64; 3]], b: &[[f64; 3]], mask: &[bool]) -> f64 {
    let (mut se, mut n) = (0.0, 0usize);
    for i in 0..a.len() {
        if mask[i] {
            for k in 0..3 {
                se += (a[i][k] - b[i][k]).powi(2);
            }
            n += 3;
        }
    }
    10.0 * (n as f64 / se.max(1e-300)).log10()
}

/// Masks (all, out of focus, focused clear of nearer layers' blur) from the true residual
/// disparity against the plane (`bf` px per grid step per unit of inverse depth), 4 px from
/// the border, for an aperture of `radius` grid steps.
pub(super) fn masks(
    lf: &LightField,
    plan: &RefocusPlan,
    bf: f64,
    radius: f64,
) -> Result<[Vec<bool>; 3]> {
    let depth = lf.view_depth()?;
    let (w, h) = (lf.width as i64, lf.height as i64);
    let res: Vec<f64> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let s = plan.m.dot(DVec3::new(x as f64, y as f64, 1.0)).max(0.0);
            bf * (1.0 / depth.depth(x, y).unwrap_or(f64::INFINITY) - s)
        })
        .collect();
    // The largest blur reach of a nearer layer: |residual| × radius, plus a pixel.
    let reach = (res.iter().fold(0f64, |m, r| m.max(*r)) * radius).ceil() as i64 + 1;
    let inner = |x: i64, y: i64| x >= 4 && y >= 4 && x < w - 4 && y < h - 4;
    let mut all = vec![false; (w * h) as usize];
    let mut out = all.clone();
    let mut focused = all.clone();
    for y in 0..h {
        for x in 0..w {
            if !inner(x, y) {
                continue;
            }
            let i = (y * w + x) as usize;
            all[i] = true;
            out[i] = res[i].abs() > 0.5;
            focused[i] = res[i].abs() <= 0.5
                && (-reach..=reach).all(|dy| {
                    (-reach..=reach).all(|dx| {
                        let (u, v) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1));
                        res[(v * w + u) as usize] <= 0.5
                    })
                });
        }
    }
    Ok([all, out, focused])
}

/// Runs the study on `ctx` with `frames` timed frames per point (after one warm-up frame),
/// the points timed round-robin so that load changes affect all alike.
pub fn run(ctx: Arc<GpuContext>, quick: bool, frames: usize) -> Result<AntialiasReport> {
    let (size, gt_grid) = if quick { (64, 65) } else { (128, 129) };
    // The anti-aliasing set's first case: `layers` focused on its 0-px panel, a disk of 2.
    let case = antialias_set::cases()
        .into_iter()
        .next()
        .ok_or_else(|| Error::Invalid("no anti-aliasing case".into()))?;
    let antialias_set::Prepared {
        lf,
        plan,
        aperture,
        truth,
        pinholes,
        masks: [all, out, focused],
    } = antialias_set::prepare(
        &ctx,
        &case,
        (size, gt_grid, antialias_set::SUPERSAMPLES),
        &ProgressBar::hidden(),
    )?;
    let aa: Vec<AntialiasPlan> = VARIANTS
        .iter()
        .map(|&s| plan_for(&lf, &plan, aperture, &[], s))
        .collect::<Result<_>>()?;
    // Timed with render's default strategy on this device (`--strategy auto`).
    let settings = RenderSettings {
        output: OutputFormat::Float,
        strategy: crate::jobs::strategy::choose(&ctx, None)?.strategy,
        ..RenderSettings::default()
    };
    let mut h = HeadlessRenderer::with_context(Arc::clone(&ctx), &lf, Default::default())?;
    let timed = |t: Option<PassTimings>| {
        t.map(|t| t.refocus_ms).ok_or_else(|| {
            Error::Vulkan(format!(
                "{} has no timestamp queries: GPU times cannot be measured",
                ctx.info.name
            ))
        })
    };
    // Point 0 is the plain sum, point k the settings VARIANTS[k − 1]; a warm-up frame each, which is
    // also the image scored.
    let mut images = Vec::new();
    let (img, _) = h.render(&plan, &settings)?;
    images.push(encoded(&float(img)?.pixels));
    for a in &aa {
        let (img, _) = h.render_antialiased(a, &settings)?;
        images.push(encoded(&float(img)?.pixels));
    }
    let frames = frames.max(1);
    let mut times = vec![Vec::with_capacity(frames); aa.len() + 1];
    for _ in 0..frames {
        times[0].push(timed(h.render_timed(&plan, &settings)?)?);
        for (k, a) in aa.iter().enumerate() {
            times[k + 1].push(timed(h.render_timed_antialiased(a, &settings)?)?);
        }
    }
    let validated = h.context().check_validation("in the anti-aliasing study");
    drop(h);
    validated?;
    let medians: Vec<f64> = times
        .iter()
        .map(|t| stats::summarize(t).map_or(f64::NAN, |s| s.median))
        .collect();
    let points = (0..=aa.len())
        .map(|k| AntialiasPoint {
            name: if k == 0 {
                "plain".into()
            } else {
                variant_name(&VARIANTS[k - 1])
            },
            max_samples: (k > 0).then(|| VARIANTS[k - 1].max_samples),
            prefilter: k > 0 && VARIANTS[k - 1].prefilter,
            focus_test: k > 0 && VARIANTS[k - 1].focus_test,
            focused_bicubic: k > 0 && VARIANTS[k - 1].focused_bicubic,
            occlusion: k > 0 && VARIANTS[k - 1].occlusion,
            route: (k > 0).then(|| route(&VARIANTS[k - 1])).flatten(),
            views: if k == 0 {
                plan.views.len()
            } else {
                aa[k - 1].plan.views.len()
            },
            gpu_ms_median: medians[k],
            cost_ratio: medians[k] / medians[0],
            psnr_vs_truth_db: psnr(&images[k], &truth, &all),
            psnr_out_of_focus_db: psnr(&images[k], &truth, &out),
            psnr_focused_db: psnr(&images[k], &truth, &focused),
        })
        .collect();
    Ok(AntialiasReport {
        scene: format!(
            "synthetic 'layers': 5×5 views of {size}², disk aperture of radius 2, focus on the \
             0-px panel"
        ),
        size: [size, size],
        truth_pinholes: pinholes,
        frames,
        points,
    })
}
