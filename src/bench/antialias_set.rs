//! The anti-aliasing test set (`tiltfield antialias-set`): anti-aliased refocus scored against
//! the lens over several synthetic cases, one per way it can fail, so that a change is judged
//! on the whole set and never on one scene. Each case is a sparse 5×5 light field rendered by
//! synth with its exact depth, a focus plane and a disk aperture; it is refocused plainly, with
//! anti-aliasing on the given depth, and with anti-aliasing on depth estimated from the views
//! (`tiltfield depth`, the defaults), and each image is scored in 8-bit PSNR against the optical
//! truth of a thin lens with the same disk (synth's dense-aperture render): overall, on the
//! out-of-focus pixels (residual disparity over half a pixel per grid step) and on the focused
//! pixels clear of nearer surfaces' blur. The GPU time of the anti-aliased sum is reported as a
//! ratio to the plain sum's, timed side by side.
//!
//! | case | what it tests |
//! |---|---|
//! | `layers` | sparse frontoparallel layers (−3 … +6 px per grid step), focus on the 0-px panel: the scene |
//! | `layers-back` | focus on the back wall: the nearer layers' blur over a focused background |
//! | `layers-near` | focus on the nearest card: a background 9 px per grid step out of focus, footprints past the sub-sample cap |
//! | `layers-tilted` | a focus plane tilted through two layers |
//! | `layers-rotated` | a converging rig (every camera turned to a point at 2.5 m): footprints not axis-aligned |
//! | `layers-small` | a disk of radius 1: rim cells only partly inside |
//! | `depths` | seven finely textured cards from 1.2 to 6 m before a fine checker (baseline ×3): aliasing at many depths |
//! | `tower` | turned boxes on a floor (baseline ×3): slanted faces and silhouettes |
//! | `room` | a room's receding floor, ceiling and walls (baseline ×4): depth varying continuously |

use std::sync::Arc;

use glam::{DVec2, DVec3};
use indicatif::ProgressBar;

use super::antialias::{encoded, float, masks, psnr};
use super::stats;
use crate::error::{Error, Result};
use crate::geometry::aperture::{Aperture, ApertureShape};
use crate::geometry::plane::Plane;
use crate::gpu::GpuContext;
use crate::jobs::raster::{render_light_field, Rasterizer};
use crate::jobs::refocus::{HeadlessRenderer, PassTimings, RenderSettings};
use crate::lightfield::{GridSize, LightField};
use crate::refocus::antialias::{plan_for, AntialiasSettings};
use crate::refocus::settings::{Filter, OutputFormat};
use crate::refocus::{self, FocusSpec, RefocusPlan, RefocusRequest};
use crate::synth::scenes::LAYER_DEPTHS;
use crate::synth::{synth_scene, RigKind, SynthRig};

/// Where a case focuses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CaseFocus {
    /// The frontoparallel plane at this depth (m).
    Depth(f64),
    /// The plane through these two points that contains the vertical (y) direction.
    Through(DVec3, DVec3),
}

/// One case of the set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AntialiasCase {
    pub name: &'static str,
    /// What the case tests.
    pub what: &'static str,
    /// The synth scene ([`synth_scene`]).
    pub scene: &'static str,
    /// The baseline over the scene's own (how sparse the light field is).
    pub baseline_scale: f64,
    /// `None`: parallel cameras; `Some(d)`: every camera turned to (0, 0, d).
    pub converging: Option<f64>,
    pub focus: CaseFocus,
    /// Disk radius, grid steps.
    pub radius: f64,
}

const fn case(
    name: &'static str,
    what: &'static str,
    scene: &'static str,
    focus: CaseFocus,
) -> AntialiasCase {
    AntialiasCase {
        name,
        what,
        scene,
        baseline_scale: 1.0,
        converging: None,
        focus,
        radius: 2.0,
    }
}

/// The set (module docs).
pub fn cases() -> Vec<AntialiasCase> {
    let [zb, zm, zn, zc] = LAYER_DEPTHS;
    vec![
        case(
            "layers",
            "sparse frontoparallel layers, focus on the 0-px panel",
            "layers",
            CaseFocus::Depth(zm),
        ),
        case(
            "layers-back",
            "focus on the back wall: nearer layers' blur over it",
            "layers",
            CaseFocus::Depth(zb),
        ),
        case(
            "layers-near",
            "focus on the nearest card: background 9 px/step out of focus",
            "layers",
            CaseFocus::Depth(zc),
        ),
        case(
            "layers-tilted",
            "focus plane tilted through two layers",
            "layers",
            // The 2 m panel (left) and the 1.52 m panel (lower right), turned about y.
            CaseFocus::Through(
                DVec3::new(-0.5, 0.0, zm),
                DVec3::new(0.22 * zn, 0.24 * zn, zn),
            ),
        ),
        AntialiasCase {
            converging: Some(2.5),
            ..case(
                "layers-rotated",
                "converging rig: footprints not axis-aligned",
                "layers",
                CaseFocus::Depth(zm),
            )
        },
        AntialiasCase {
            radius: 1.0,
            ..case(
                "layers-small",
                "disk of radius 1: rim cells partly inside",
                "layers",
                CaseFocus::Depth(zm),
            )
        },
        AntialiasCase {
            baseline_scale: 3.0,
            ..case(
                "depths",
                "fine textures at seven depths before a fine checker",
                "depths",
                CaseFocus::Depth(2.1),
            )
        },
        AntialiasCase {
            baseline_scale: 3.0,
            ..case(
                "tower",
                "turned boxes on a floor: slanted faces, silhouettes",
                "tower",
                CaseFocus::Depth(3.5),
            )
        },
        AntialiasCase {
            baseline_scale: 4.0,
            ..case(
                "room",
                "receding floor, ceiling and walls: continuous depth",
                "room",
                CaseFocus::Depth(3.0),
            )
        },
    ]
}

/// The cases named in `only` (all when `None`), or an error naming the unknown one.
pub fn select(only: Option<&[String]>) -> Result<Vec<AntialiasCase>> {
    let all = cases();
    let Some(names) = only else {
        return Ok(all);
    };
    names
        .iter()
        .map(|n| {
            all.iter().find(|c| c.name == n).copied().ok_or_else(|| {
                Error::Invalid(format!(
                    "no anti-aliasing case '{n}'; the set: {}",
                    all.iter().map(|c| c.name).collect::<Vec<_>>().join(", ")
                ))
            })
        })
        .collect()
}

/// Jittered samples per pixel and axis of the set's views and lens, unless told otherwise.
///
/// Why 8: the cases' textures are finer than the pixels (1024 texels over a few dozen), so a
/// view is the mean of its jitters over fine grain, and too few jitters leave each view its
/// own sampling noise, which a camera's pixel (and the lens's thousands of pinholes) averages
/// away. Wherever the focus needs the views resampled between their pixels that noise, not the
/// method, bounded the focused pixels: `layers-tilted` on its plane, bicubic, 33.2 dB at 3
/// jitters a side, 36.4 at 6, 37.9 at 9. From 8 on, the tilted plane's scores move by under
/// 0.1 dB (3: 33.0 / 37.7 / 29.6, 8: 34.0 / 38.3 / 30.8, 12: 34.0 / 38.2 / 30.9 dB overall /
/// out of focus / focused, bilinear). Rendering the views is a small part of the set's time
/// (`layers`: 6.0 s at 3, 6.5 s at 8).
pub const SUPERSAMPLES: u32 = 8;

/// Most pinholes a side of the lens (synth's `--gt-samples` limit).
pub const MAX_TRUTH_GRID: u32 = 257;
/// Most jitters a pixel side (synth's `--samples` limit).
pub const MAX_SUPERSAMPLES: u32 = 16;
/// Most timed frames per image (bench's `--frames` limit).
pub const MAX_FRAMES: usize = 1000;

/// How the set is run.
#[derive(Debug, Clone, PartialEq)]
pub struct SetOptions {
    /// View size, px (48 to 512).
    pub size: u32,
    /// Pinholes per side of the truth's aperture grid (≥ 9).
    pub truth_grid: u32,
    /// Timed frames per image (after a warm-up frame, which is the image scored).
    pub frames: usize,
    /// Also score anti-aliasing on an estimated depth.
    pub estimate: bool,
    /// How every image of the set samples its views (the plain sum's too).
    pub filter: Filter,
    /// Jittered samples per pixel and axis of the rendered views, and of the lens (each
    /// pinhole takes one of the same jitters).
    pub supersamples: u32,
    /// How the anti-aliased images sample their footprints.
    pub antialias: AntialiasSettings,
    /// Also score the f64 model of layered anti-aliasing ([`crate::refocus::layered`]) on the
    /// given depth (and on the estimate when that is scored): the route of a constant-cost pass.
    pub layered_model: bool,
}

impl SetOptions {
    /// Checks the size, the truth's grid, the jitters and the timed frames.
    pub fn validate(&self) -> Result<()> {
        if !(48..=512).contains(&self.size) {
            return Err(Error::Invalid(format!(
                "the anti-aliasing set's views must be 48 to 512 px a side, got {}",
                self.size
            )));
        }
        // Upper bounds as synth's --gt-samples and --samples: beyond them the lens and the
        // views take minutes to hours (the lens allocates grid² images before it starts), and
        // 0 would silently run as 1.
        if !(9..=MAX_TRUTH_GRID).contains(&self.truth_grid) {
            return Err(Error::Invalid(format!(
                "--truth-grid must be 9 to {MAX_TRUTH_GRID} (pinholes a side of the lens), got {}",
                self.truth_grid
            )));
        }
        if !(1..=MAX_SUPERSAMPLES).contains(&self.supersamples) {
            return Err(Error::Invalid(format!(
                "--supersamples must be 1 to {MAX_SUPERSAMPLES} (jitters a pixel side), got {}",
                self.supersamples
            )));
        }
        if !(1..=MAX_FRAMES).contains(&self.frames) {
            return Err(Error::Invalid(format!(
                "--frames must be 1 to {MAX_FRAMES} (timed frames per image), got {}",
                self.frames
            )));
        }
        self.antialias.validate()
    }
}

/// PSNR (dB) overall, out of focus and focused; `None` where the case has no such pixels.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Psnr3 {
    pub overall: f64,
    pub out_of_focus: Option<f64>,
    pub focused: Option<f64>,
}

/// One case's scores.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CaseResult {
    pub name: String,
    pub what: String,
    pub views_plain: usize,
    pub views_antialiased: usize,
    pub out_of_focus_px: usize,
    pub focused_px: usize,
    pub truth_pinholes: usize,
    pub plain: Psnr3,
    /// Anti-aliased on the rendered depth.
    pub given: Psnr3,
    /// Anti-aliased on the estimated depth.
    pub estimated: Option<Psnr3>,
    /// The layered model ([`SetOptions::layered_model`]) on the given depth and on the
    /// estimate.
    pub layered: Option<Psnr3>,
    pub layered_estimated: Option<Psnr3>,
    /// Median GPU time of the anti-aliased sum (given depth) over the plain sum's.
    pub cost_ratio: f64,
    /// Median GPU times, ms, of the plain and the anti-aliased sum (given depth): the ratio's
    /// terms, so that runs of different filters can be set side by side.
    pub plain_ms: f64,
    pub antialiased_ms: f64,
    /// The images scored (sRGB-encoded, row-major): truth, plain, given, estimated, and the
    /// layered model on the given depth.
    #[serde(skip)]
    pub images: Vec<Vec<[f64; 3]>>,
    #[serde(skip)]
    pub size: u32,
}

fn scores(img: &[[f64; 3]], truth: &[[f64; 3]], m: &[Vec<bool>; 3]) -> Psnr3 {
    let part = |mask: &Vec<bool>| mask.iter().any(|&b| b).then(|| psnr(img, truth, mask));
    Psnr3 {
        overall: psnr(img, truth, &m[0]),
        out_of_focus: part(&m[1]),
        focused: part(&m[2]),
    }
}

fn focus_plane(focus: CaseFocus) -> Result<Plane> {
    match focus {
        CaseFocus::Depth(z) => Plane::new(DVec3::new(0.0, 0.0, z), DVec3::new(0.0, 0.0, -1.0)),
        CaseFocus::Through(a, b) => {
            let n = (b - a).cross(DVec3::Y).normalize();
            // Facing the cameras (normals point back towards them, −z).
            Plane::new(a, if n.z > 0.0 { -n } else { n })
        }
    }
}

/// A case ready to score: its light field, the plain plan, the disk, the lens's image and
/// the masks (all, out of focus, focused).
pub(super) struct Prepared {
    pub lf: LightField,
    pub plan: RefocusPlan,
    pub aperture: Aperture,
    /// The lens's image, sRGB-encoded (0–1), row-major.
    pub truth: Vec<[f64; 3]>,
    pub pinholes: usize,
    pub masks: [Vec<bool>; 3],
}

/// Renders `case`'s light field (`size²` views, `supersamples` jitters a pixel and axis) and
/// its lens (`truth_grid` pinholes a side) on `ctx`; `progress` gets the steps as messages.
pub(super) fn prepare(
    ctx: &Arc<GpuContext>,
    case: &AntialiasCase,
    (size, truth_grid, supersamples): (u32, u32, u32),
    progress: &ProgressBar,
) -> Result<Prepared> {
    let scene = synth_scene(case.scene)
        .ok_or_else(|| Error::Invalid(format!("no synth scene '{}'", case.scene)))?;
    let rig = SynthRig {
        grid: GridSize { cols: 5, rows: 5 },
        width: size,
        height: size,
        focal_px: scene.focal_per_width * size as f64,
        baseline: scene.baseline * case.baseline_scale,
        focus_distance: scene.focus_distance,
        kind: match case.converging {
            None => RigKind::Parallel,
            Some(distance) => RigKind::Converging { distance },
        },
    };
    progress.set_message(format!("{}: rendering the views", case.name));
    let mut r = Rasterizer::with_context(Arc::clone(ctx), &scene.mesh())?;
    let lf = render_light_field(&mut r, &rig, supersamples, false)?.light_field;
    let plane = focus_plane(case.focus)?;
    let aperture = Aperture {
        shape: ApertureShape::Disk,
        radius: Some(case.radius),
    };
    let plan = refocus::plan(
        &lf,
        &RefocusRequest {
            focus: FocusSpec::Plane(plane),
            aperture,
            reference: None::<DVec2>,
        },
        &[],
    )?;
    progress.set_message(format!("{}: rendering the lens", case.name));
    let (gt, pinholes) = r.optical_ground_truth(
        &plan.reference_camera,
        &plane,
        case.radius * rig.baseline,
        truth_grid,
        (size, size),
        supersamples,
    )?;
    let masks = masks(&lf, &plan, rig.baseline * rig.focal_px, case.radius)?;
    Ok(Prepared {
        lf,
        plan,
        aperture,
        truth: encoded(&gt),
        pinholes,
        masks,
    })
}

/// Runs one case on `ctx`; `progress` gets its steps as messages. (Validation errors are
/// the caller's to check on `ctx`, as [`run`] does.)
pub fn run_case(
    ctx: &Arc<GpuContext>,
    case: &AntialiasCase,
    options: &SetOptions,
    progress: &ProgressBar,
) -> Result<CaseResult> {
    options.validate()?;
    let size = options.size;
    let Prepared {
        lf,
        plan,
        aperture,
        truth,
        pinholes,
        masks: m,
    } = prepare(
        ctx,
        case,
        (size, options.truth_grid, options.supersamples),
        progress,
    )?;
    // Timed with render's default strategy on this device (`--strategy auto`).
    let settings = RenderSettings {
        output: OutputFormat::Float,
        filter: options.filter,
        strategy: crate::jobs::strategy::choose(ctx, None)?.strategy,
        ..RenderSettings::default()
    };
    let aa = plan_for(&lf, &plan, aperture, &[], options.antialias)?;
    let mut h = HeadlessRenderer::with_context(Arc::clone(ctx), &lf, Default::default())?;
    progress.set_message(format!("{}: refocusing", case.name));
    let plain_img = encoded(&float(h.render(&plan, &settings)?.0)?.pixels);
    let given_img = encoded(&float(h.render_antialiased(&aa, &settings)?.0)?.pixels);
    let timed = |t: Option<PassTimings>| {
        t.map(|t| t.refocus_ms).ok_or_else(|| {
            Error::Vulkan(format!(
                "{} has no timestamp queries: GPU times cannot be measured",
                ctx.info.name
            ))
        })
    };
    let (mut t_plain, mut t_aa) = (Vec::new(), Vec::new());
    for _ in 0..options.frames.max(1) {
        t_plain.push(timed(h.render_timed(&plan, &settings)?)?);
        t_aa.push(timed(h.render_timed_antialiased(&aa, &settings)?)?);
    }
    let median = |t: &[f64]| stats::summarize(t).map_or(f64::NAN, |s| s.median);
    let (plain, given) = (
        scores(&plain_img, &truth, &m),
        scores(&given_img, &truth, &m),
    );
    let layered = |aa: &crate::refocus::antialias::AntialiasPlan| {
        let img =
            crate::refocus::layered::render_layered(&lf, aa, crate::refocus::Averaging::Linear);
        let img = encoded(&img.pixels);
        (scores(&img, &truth, &m), img)
    };
    let layered_given = options.layered_model.then(|| layered(&aa));
    let mut layered_estimated = None;
    let estimated = if options.estimate {
        progress.set_message(format!("{}: estimating depth", case.name));
        let mut est = lf.clone();
        est.depth.clear();
        crate::jobs::depth::ensure_depth_in(
            ctx,
            &mut est,
            &crate::depth::DepthOptions::default(),
            &ProgressBar::hidden(),
            None,
        )?;
        let aa_est = plan_for(&est, &plan, aperture, &[], options.antialias)?;
        let img = encoded(&float(h.render_antialiased(&aa_est, &settings)?.0)?.pixels);
        layered_estimated = options.layered_model.then(|| layered(&aa_est).0);
        Some((scores(&img, &truth, &m), img))
    } else {
        None
    };
    let mut images = vec![truth, plain_img, given_img];
    let estimated = estimated.map(|(s, img)| {
        images.push(img);
        s
    });
    let layered_given = layered_given.map(|(s, img)| {
        images.push(img);
        s
    });
    Ok(CaseResult {
        name: case.name.into(),
        what: case.what.into(),
        views_plain: plan.views.len(),
        views_antialiased: aa.plan.views.len(),
        out_of_focus_px: m[1].iter().filter(|&&b| b).count(),
        focused_px: m[2].iter().filter(|&&b| b).count(),
        truth_pinholes: pinholes,
        plain,
        given,
        estimated,
        layered: layered_given,
        layered_estimated,
        cost_ratio: median(&t_aa) / median(&t_plain),
        plain_ms: median(&t_plain),
        antialiased_ms: median(&t_aa),
        images,
        size,
    })
}

/// Runs `cases` one after another (a progress bar over the cases) and fails on any
/// validation error.
pub fn run(
    ctx: &Arc<GpuContext>,
    cases: &[AntialiasCase],
    options: &SetOptions,
    progress: &ProgressBar,
) -> Result<Vec<CaseResult>> {
    options.validate()?;
    progress.set_length(cases.len() as u64);
    let mut out = Vec::with_capacity(cases.len());
    for c in cases {
        out.push(run_case(ctx, c, options, progress)?);
        progress.inc(1);
    }
    ctx.check_validation("in the anti-aliasing set")?;
    Ok(out)
}

fn db(v: Option<f64>) -> String {
    v.map_or_else(|| "–".into(), |v| format!("{v:.1}"))
}

fn triple(p: &Psnr3) -> String {
    format!(
        "{:.1} / {} / {}",
        p.overall,
        db(p.out_of_focus),
        db(p.focused)
    )
}

/// The mean of the values present (`None` when none is).
fn mean(v: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let (s, n) = v.flatten().fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| s / n as f64)
}

/// The set's Markdown table: a row per case and the mean over the cases.
pub fn markdown(rows: &[CaseResult]) -> String {
    let mut out = String::from(
        "PSNR in dB against the lens: overall / out of focus / focused.\n\n\
         | case | what it tests | plain | anti-aliased, given depth | anti-aliased, estimated \
         depth | × plain |\n|---|---|---|---|---|---|\n",
    );
    let layered = rows.iter().any(|r| r.layered.is_some());
    if layered {
        out = String::from(
            "PSNR in dB against the lens: overall / out of focus / focused.\n\n\
             | case | what it tests | plain | anti-aliased, given depth | anti-aliased, estimated \
             depth | layered model, given depth | layered model, estimated depth | × plain |\n\
             |---|---|---|---|---|---|---|---|\n",
        );
    }
    let extra = |r: &CaseResult| {
        if layered {
            format!(
                " {} | {} |",
                r.layered.as_ref().map_or_else(|| "–".into(), triple),
                r.layered_estimated
                    .as_ref()
                    .map_or_else(|| "–".into(), triple)
            )
        } else {
            String::new()
        }
    };
    for r in rows {
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} |{} {:.1} |\n",
            r.name,
            r.what,
            triple(&r.plain),
            triple(&r.given),
            r.estimated.as_ref().map_or_else(|| "–".into(), triple),
            extra(r),
            r.cost_ratio
        ));
    }
    let avg = |f: &dyn Fn(&CaseResult) -> Option<Psnr3>| -> String {
        let present: Vec<Psnr3> = rows.iter().filter_map(f).collect();
        if present.is_empty() {
            return "–".into();
        }
        triple(&Psnr3 {
            overall: mean(present.iter().map(|p| Some(p.overall))).unwrap_or(f64::NAN),
            out_of_focus: mean(present.iter().map(|p| p.out_of_focus)),
            focused: mean(present.iter().map(|p| p.focused)),
        })
    };
    let extra_mean = if layered {
        format!(
            " {} | {} |",
            avg(&|r| r.layered),
            avg(&|r| r.layered_estimated)
        )
    } else {
        String::new()
    };
    out.push_str(&format!(
        "| **mean** | {} cases | {} | {} | {} |{} {:.1} |\n",
        rows.len(),
        avg(&|r| Some(r.plain)),
        avg(&|r| Some(r.given)),
        avg(&|r| r.estimated),
        extra_mean,
        mean(rows.iter().map(|r| Some(r.cost_ratio))).unwrap_or(f64::NAN)
    ));
    out
}

/// The case's images side by side (truth, plain, anti-aliased on the given depth, and on the
/// estimate when scored), 8-bit sRGB.
pub fn figure(r: &CaseResult) -> image::RgbImage {
    let n = r.size;
    let mut img = image::RgbImage::new(n * r.images.len() as u32, n);
    for (k, px) in r.images.iter().enumerate() {
        for (i, p) in px.iter().enumerate() {
            let (x, y) = (i as u32 % n, i as u32 / n);
            let c = p.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
            img.put_pixel(k as u32 * n + x, y, image::Rgb(c));
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn case_names_are_unique_and_select_finds_them_or_names_the_set() {
        let all = cases();
        let mut names: Vec<_> = all.iter().map(|c| c.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), all.len());
        let picked = select(Some(&["room".into(), "layers".into()])).unwrap();
        assert_eq!(
            picked.iter().map(|c| c.name).collect::<Vec<_>>(),
            ["room", "layers"]
        );
        let err = select(Some(&["nope".into()])).unwrap_err().to_string();
        assert!(
            err.contains("'nope'") && err.contains("layers-tilted"),
            "{err}"
        );
        for c in &all {
            assert!(synth_scene(c.scene).is_some(), "{}", c.name);
            assert!(focus_plane(c.focus).is_ok(), "{}", c.name);
        }
    }

    #[test]
    fn the_tilted_focus_contains_both_points_and_faces_the_cameras() {
        let (a, b) = (DVec3::new(-0.5, 0.0, 2.0), DVec3::new(0.3, 0.4, 1.5));
        let p = focus_plane(CaseFocus::Through(a, b)).unwrap();
        assert!(p.signed_distance(a).abs() < 1e-12 && p.signed_distance(b).abs() < 1e-12);
        assert!(p.normal.z < 0.0 && p.normal.y.abs() < 1e-12);
    }

    #[test]
    fn bad_options_are_refused_with_the_cause() {
        let o = SetOptions {
            size: 16,
            truth_grid: 65,
            frames: 1,
            estimate: false,
            filter: Filter::Hardware,
            supersamples: 3,
            antialias: AntialiasSettings::default(),
            layered_model: false,
        };
        assert!(o.validate().unwrap_err().to_string().contains("48 to 512"));
        let o = SetOptions {
            size: 64,
            truth_grid: 3,
            ..o
        };
        assert!(o.validate().unwrap_err().to_string().contains("9 to 257"));
        let o = SetOptions {
            truth_grid: 65,
            antialias: AntialiasSettings {
                max_samples: 0,
                ..AntialiasSettings::default()
            },
            ..o
        };
        assert!(o.validate().unwrap_err().to_string().contains("1 to 16"));
    }

    #[test]
    fn the_table_has_a_row_per_case_and_their_mean() {
        let row = |name: &str, oof: Option<f64>| CaseResult {
            name: name.into(),
            what: "w".into(),
            views_plain: 13,
            views_antialiased: 21,
            out_of_focus_px: 1,
            focused_px: 1,
            truth_pinholes: 100,
            plain: Psnr3 {
                overall: 30.0,
                out_of_focus: oof,
                focused: Some(50.0),
            },
            given: Psnr3 {
                overall: 40.0,
                out_of_focus: Some(38.0),
                focused: None,
            },
            estimated: None,
            layered: None,
            layered_estimated: None,
            cost_ratio: 10.0,
            plain_ms: 1.0,
            antialiased_ms: 10.0,
            images: Vec::new(),
            size: 0,
        };
        let md = markdown(&[row("a", Some(20.0)), row("b", None)]);
        assert!(md.contains("| a | w | 30.0 / 20.0 / 50.0 | 40.0 / 38.0 / – | – | 10.0 |"));
        assert!(md.contains("| b | w | 30.0 / – / 50.0 |"), "{md}");
        // The mean skips what a case does not have.
        assert!(
            md.contains("| **mean** | 2 cases | 30.0 / 20.0 / 50.0 | 40.0 / 38.0 / – | – | 10.0 |"),
            "{md}"
        );
        assert!(!md.contains("layered"), "{md}");
        // With the layered model scored, its two columns stand before the cost.
        let mut with = row("c", Some(20.0));
        with.layered = Some(Psnr3 {
            overall: 41.0,
            out_of_focus: Some(39.0),
            focused: Some(50.0),
        });
        let md = markdown(&[with]);
        assert!(
            md.contains("layered model, given depth | layered model, estimated depth | × plain")
        );
        assert!(
            md.contains("| c | w | 30.0 / 20.0 / 50.0 | 40.0 / 38.0 / – | – | 41.0 / 39.0 / 50.0 | – | 10.0 |"),
            "{md}"
        );
    }
}
