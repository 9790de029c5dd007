//! The depth test set: every scene of [`DepthScene::SET`] (one per known failure mode, exact
//! ground truth) plus any HCI folders with a ground-truth disparity, scored together so that an
//! estimator is judged on the whole set and never on one scene (`tiltfield depth-set`,
//! docs/depth.md). GPU-free: the estimates come from the caller.

use std::fmt::Write as _;
use std::path::Path;

use super::depth_scenes::{truth, DepthScene};
use crate::depth::metrics::{score, DisparityScores, HCI_BORDER};
use crate::depth::{DepthOptions, SweepParams};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::lightfield::pfm::read_pfm_depth;
use crate::lightfield::{DepthKind, GridCameraOptions, LightField, ParallelRig};
use indicatif::ProgressBar;

/// The border left out of the scores of the small synthetic scenes (HCI's 15 px is a sixth of
/// a 96-px view).
pub const SYNTH_BORDER: u32 = 8;

/// One light field of the set with its ground-truth disparity of the reference view.
pub struct SetScene {
    pub name: String,
    /// What the scene tests.
    pub failure_mode: String,
    /// The light field with its own depth maps removed (the estimator must not see them).
    pub light_field: LightField,
    /// Ground-truth disparity (the light field's convention), row-major; NaN where none.
    pub truth: Vec<f32>,
    /// Border excluded from the scores, px.
    pub border: u32,
    /// A light field without a disparity convention (a calibrated rotated rig) is scored as
    /// this regular rig's disparity: the estimate's depth and the exact depth converted
    /// alike ([`DepthScene::scored_as`]).
    pub scored_as: Option<ParallelRig>,
}

impl SetScene {
    /// The disparity of `est` that is scored against [`SetScene::truth`].
    pub fn scored_disparity(&self, est: &crate::depth::DepthEstimate) -> Result<Vec<f32>> {
        match &self.scored_as {
            None => est.values(DepthKind::Disparity),
            Some(rig) => Ok(equivalent_disparity(rig, &est.values(DepthKind::Depth)?)),
        }
    }
}

/// Depths as `rig`'s disparities (NaN stays NaN).
fn equivalent_disparity(rig: &ParallelRig, depth: &[f32]) -> Vec<f32> {
    depth
        .iter()
        .map(|&z| rig.disparity_of_depth(z as f64) as f32)
        .collect()
}

/// The synthetic scenes of [`DepthScene::SET`] (or those named in `only`) as `grid × grid`
/// views of `size²` px.
pub fn synthetic(grid: usize, size: u32, only: Option<&[String]>) -> Result<Vec<SetScene>> {
    let scenes: Vec<DepthScene> = match only {
        None => DepthScene::SET.to_vec(),
        Some(names) => names
            .iter()
            .map(|n| {
                DepthScene::from_name(n).ok_or_else(|| {
                    Error::Invalid(format!(
                        "no depth test scene '{n}'; the set: {}",
                        DepthScene::SET.map(|s| s.name()).join(", ")
                    ))
                })
            })
            .collect::<Result<_>>()?,
    };
    if !(3..=9).contains(&grid) || grid % 2 == 0 {
        return Err(Error::Invalid(format!(
            "--grid: the test set's grid must be 3, 5, 7 or 9 views a side, got {grid}"
        )));
    }
    if !(48..=512).contains(&size) {
        return Err(Error::Invalid(format!(
            "--size: the test set's views must be 48 to 512 px a side, got {size}"
        )));
    }
    Ok(scenes
        .into_iter()
        .map(|scene| {
            let mut lf = scene.light_field(grid, size);
            let scored_as = scene.scored_as(size);
            let t = match &scored_as {
                None => truth(&lf, DepthKind::Disparity),
                Some(rig) => equivalent_disparity(rig, &truth(&lf, DepthKind::Depth)),
            };
            lf.depth.clear();
            SetScene {
                name: scene.name().into(),
                failure_mode: scene.failure_mode().into(),
                light_field: lf,
                truth: t,
                border: SYNTH_BORDER,
                scored_as,
            }
        })
        .collect())
}

/// An HCI folder with `gt_disp_lowres.pfm`, as a member of the set (scored with HCI's 15-px
/// border).
pub fn hci(folder: &Path) -> Result<SetScene> {
    let gt = folder.join("gt_disp_lowres.pfm");
    let truth = read_pfm_depth(&gt, DepthKind::Disparity)?;
    let mut lf = crate::lightfield::open(folder, &GridCameraOptions::default())?;
    if (truth.width, truth.height) != (lf.width, lf.height) {
        return Err(Error::bad_file(
            &gt,
            format!(
                "the ground truth is {}×{}, the views {}×{}",
                truth.width, truth.height, lf.width, lf.height
            ),
        ));
    }
    lf.depth.clear();
    // The benchmark's own scenes name their category in `[meta]`; a folder `tiltfield synth`
    // wrote (or any other HCI-format folder) does not, and is not called a benchmark scene.
    let cfg_path = folder.join(crate::lightfield::hci::CONFIG_NAME);
    let category = crate::io::read_text(&cfg_path, "the HCI parameters file")
        .ok()
        .and_then(|text| crate::lightfield::hci::parse_config(&text, &cfg_path).ok())
        .and_then(|cfg| cfg.meta.get("category").cloned());
    Ok(SetScene {
        name: lf.name.clone(),
        failure_mode: match category {
            Some(c) => format!("HCI benchmark scene ({c})"),
            None => "HCI-format folder".into(),
        },
        light_field: lf,
        truth: truth.values,
        border: HCI_BORDER,
        scored_as: None,
    })
}

/// The estimator variants the set compares, by name: `default` (today's defaults), `naive`
/// (SAD over the same views with box aggregation), `sweep` (the sweep alone: no median, no
/// continuous fit, no global refinement, no plane fill, no edge snapping), `no-fit`,
/// `no-median`, `no-smooth`, `no-plane-fill` and `no-snap` (the default without that step).
pub const VARIANTS: [&str; 8] = [
    "default",
    "no-fit",
    "no-median",
    "no-smooth",
    "no-plane-fill",
    "no-snap",
    "sweep",
    "naive",
];

/// The options of variant `name` ([`VARIANTS`]).
pub fn variant(name: &str) -> Result<DepthOptions> {
    let base = DepthOptions::default();
    match name {
        "default" => Ok(base),
        "sweep" => Ok(DepthOptions {
            params: SweepParams {
                fit: false,
                median_radius: 0,
                edge_snap: false,
                smooth: false,
                plane_fill: false,
                ..SweepParams::default()
            },
            ..base
        }),
        "no-fit" => Ok(DepthOptions {
            params: SweepParams {
                fit: false,
                ..SweepParams::default()
            },
            ..base
        }),
        "naive" => Ok(DepthOptions {
            params: SweepParams::baseline(),
            ..base
        }),
        "no-smooth" => Ok(DepthOptions {
            params: SweepParams {
                smooth: false,
                ..SweepParams::default()
            },
            ..base
        }),
        "no-plane-fill" => Ok(DepthOptions {
            params: SweepParams {
                plane_fill: false,
                ..SweepParams::default()
            },
            ..base
        }),
        "no-snap" => Ok(DepthOptions {
            params: SweepParams {
                edge_snap: false,
                ..SweepParams::default()
            },
            ..base
        }),
        "no-median" => Ok(DepthOptions {
            params: SweepParams {
                median_radius: 0,
                ..SweepParams::default()
            },
            ..base
        }),
        _ => Err(Error::Invalid(format!(
            "unknown depth variant '{name}': expected one of {}",
            VARIANTS.join(", ")
        ))),
    }
}

/// The scores of one estimate of one scene.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SetRow {
    pub scene: String,
    pub failure_mode: String,
    pub variant: String,
    pub scores: DisparityScores,
    /// Share of the scored pixels at or above the confidence threshold, and BadPix 0.07 there.
    pub confident_share: f64,
    pub confident_bad_pix_007: f64,
    /// GPU time of the estimate, ms.
    pub gpu_ms: Option<f64>,
    /// Wall-clock time of the whole estimate (sweep and fit), ms.
    pub total_ms: f64,
    /// Per threshold of [`CALIBRATION_THRESHOLDS`]: scored pixels at or above it, and how
    /// many of them are off by more than 0.07 px.
    pub calibration: Vec<(usize, usize)>,
    /// Every scored pixel's confidence and whether it is off by more than 0.07 px (as
    /// [`crate::depth::metrics::score`] counts: a missing estimate is off), for the table by
    /// confidence decile ([`decile_markdown`]).
    #[serde(skip)]
    pub pixels: Vec<(f32, bool)>,
}

/// The confidence thresholds of the calibration table.
pub const CALIBRATION_THRESHOLDS: [f32; 6] = [0.0, 0.005, 0.01, 0.02, 0.05, 0.1];

/// Scores `disparity` (with its `confidence`) of `scene` against its truth.
pub fn score_row(
    scene: &SetScene,
    variant: &str,
    disparity: &[f32],
    confidence: &[f32],
    min_confidence: f32,
    gpu_ms: Option<f64>,
    total_ms: f64,
) -> SetRow {
    let (w, h) = (scene.light_field.width, scene.light_field.height);
    let all = score(disparity, &scene.truth, w, h, scene.border, None);
    let confident: Vec<bool> = confidence.iter().map(|&c| c >= min_confidence).collect();
    let sure = score(
        disparity,
        &scene.truth,
        w,
        h,
        scene.border,
        Some(&confident),
    );
    let calibration = CALIBRATION_THRESHOLDS
        .iter()
        .map(|&t| {
            let mask: Vec<bool> = confidence.iter().map(|&c| c >= t).collect();
            let s = score(disparity, &scene.truth, w, h, scene.border, Some(&mask));
            (
                s.pixels,
                (s.bad_pix_007 / 100.0 * s.pixels as f64).round() as usize,
            )
        })
        .collect();
    let mut pixels = Vec::new();
    for y in scene.border..h.saturating_sub(scene.border) {
        for x in scene.border..w.saturating_sub(scene.border) {
            let i = (y * w + x) as usize;
            if !scene.truth[i].is_finite() {
                continue;
            }
            let off = !disparity[i].is_finite() || (disparity[i] - scene.truth[i]).abs() > 0.07;
            pixels.push((confidence[i], off));
        }
    }
    SetRow {
        scene: scene.name.clone(),
        failure_mode: scene.failure_mode.clone(),
        variant: variant.into(),
        scores: all,
        confident_share: 100.0 * sure.pixels as f64 / all.pixels.max(1) as f64,
        confident_bad_pix_007: sure.bad_pix_007,
        gpu_ms,
        total_ms,
        calibration,
        pixels,
    }
}

/// BadPix 0.07 by confidence decile of each variant, pooled over its scenes (Markdown): the
/// scored pixels sorted by confidence and cut into ten equal parts, lowest first, each with its
/// confidence range and the share of its pixels off by more than 0.07 px. A confidence that
/// predicts error falls from the first decile to the last.
pub fn decile_markdown(rows: &[SetRow]) -> String {
    let mut out =
        String::from("| variant | decile | confidence | BadPix 0.07 |\n|---|---|---|---|\n");
    let mut variants: Vec<&str> = rows.iter().map(|r| r.variant.as_str()).collect();
    variants.sort_unstable();
    variants.dedup();
    for v in variants {
        let mut all: Vec<(f32, bool)> = rows
            .iter()
            .filter(|r| r.variant == v)
            .flat_map(|r| r.pixels.iter().copied())
            .collect();
        if all.is_empty() {
            continue;
        }
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n = all.len();
        for d in 0..10 {
            let part = &all[d * n / 10..(d + 1) * n / 10];
            let (Some(lo), Some(hi)) = (part.first(), part.last()) else {
                continue;
            };
            let bad = part.iter().filter(|p| p.1).count();
            let _ = writeln!(
                out,
                "| {v} | {} | {:.4} – {:.4} | {:.2} % |",
                d + 1,
                lo.0,
                hi.0,
                100.0 * bad as f64 / part.len() as f64
            );
        }
    }
    out
}

/// A figure of one estimate for the eye: the reference view, the estimate, the truth (both
/// grey, the truth's range from black to white, outside it clamped) and the error (black
/// within 0.03 px, yellow within 0.07, red beyond, blue where the estimate has no value; the
/// scores' border dimmed), side by side with 4-px gaps.
pub fn error_figure(scene: &SetScene, disparity: &[f32]) -> image::RgbImage {
    let (w, h) = (scene.light_field.width, scene.light_field.height);
    let reference = crate::depth::sweep::reference_view(&scene.light_field, None)
        .ok()
        .map(|i| &scene.light_field.views[i].image);
    let finite = scene.truth.iter().copied().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let span = (hi - lo).max(1e-6);
    let grey = |v: f32| {
        if v.is_finite() {
            let g = (((v - lo) / span).clamp(0.0, 1.0) * 255.0).round() as u8;
            [g, g, g]
        } else {
            [0, 0, 96]
        }
    };
    let gap = 4;
    let mut img = image::RgbImage::from_pixel(4 * w + 3 * gap, h, image::Rgb([255, 255, 255]));
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (est, truth) = (disparity[i], scene.truth[i]);
            let err = (est - truth).abs();
            let mut e = if !est.is_finite() {
                [0, 0, 255]
            } else if !truth.is_finite() || err <= 0.03 {
                [0, 0, 0]
            } else if err <= 0.07 {
                [230, 200, 0]
            } else {
                [230, 0, 0]
            };
            let b = scene.border;
            if x < b || y < b || x + b >= w || y + b >= h {
                e = e.map(|c| c / 3 + 40);
            }
            if let Some(r) = reference {
                let p = r.get_pixel(x, y).0;
                img.put_pixel(x, y, image::Rgb([p[0], p[1], p[2]]));
            }
            img.put_pixel(w + gap + x, y, image::Rgb(grey(est)));
            img.put_pixel(2 * (w + gap) + x, y, image::Rgb(grey(truth)));
            img.put_pixel(3 * (w + gap) + x, y, image::Rgb(e));
        }
    }
    img
}

/// The mean of each score over `rows` of one variant (every scene weighs the same).
pub fn mean(rows: &[&SetRow]) -> DisparityScores {
    let n = rows.len().max(1) as f64;
    let sum = |f: fn(&DisparityScores) -> f64| rows.iter().map(|r| f(&r.scores)).sum::<f64>() / n;
    DisparityScores {
        bad_pix_007: sum(|s| s.bad_pix_007),
        bad_pix_003: sum(|s| s.bad_pix_003),
        bad_pix_001: sum(|s| s.bad_pix_001),
        off_01: sum(|s| s.off_01),
        pearson_r: sum(|s| s.pearson_r),
        mse_x100: sum(|s| s.mse_x100),
        pixels: rows.iter().map(|r| r.scores.pixels).sum(),
    }
}

/// A Markdown table of `rows`: one line per scene and variant, then each variant's mean.
pub fn markdown(rows: &[SetRow]) -> String {
    let mut out = String::from(
        "| scene | tests | variant | BadPix 0.07 | 0.03 | MSE × 100 | > 0.1 px | r | confident: share, BadPix 0.07 | GPU ms | total ms |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {:.2} | {:.2} | {:.3} | {:.1} | {:.3} | {:.1} %, {:.2} | {} | {:.0} |",
            r.scene,
            r.failure_mode,
            r.variant,
            r.scores.bad_pix_007,
            r.scores.bad_pix_003,
            r.scores.mse_x100,
            r.scores.off_01,
            r.scores.pearson_r,
            r.confident_share,
            r.confident_bad_pix_007,
            r.gpu_ms.map_or("–".into(), |ms| format!("{ms:.0}")),
            r.total_ms,
        );
    }
    let mut variants: Vec<&str> = rows.iter().map(|r| r.variant.as_str()).collect();
    variants.sort_unstable();
    variants.dedup();
    for v in variants {
        let of: Vec<&SetRow> = rows.iter().filter(|r| r.variant == v).collect();
        let m = mean(&of);
        let gpu: f64 = of.iter().filter_map(|r| r.gpu_ms).sum();
        let total: f64 = of.iter().map(|r| r.total_ms).sum();
        let _ = writeln!(
            out,
            "| **mean of {} scenes** | | {v} | **{:.2}** | {:.2} | **{:.3}** | {:.1} | {:.3} | | {gpu:.0} (sum) | {total:.0} (sum) |",
            of.len(),
            m.bad_pix_007,
            m.bad_pix_003,
            m.mse_x100,
            m.off_01,
            m.pearson_r,
        );
    }
    out
}

/// The confidence calibration of each variant, pooled over its scenes: for every threshold of
/// [`CALIBRATION_THRESHOLDS`], the share of the scored pixels at or above it and BadPix 0.07
/// among them (Markdown).
pub fn calibration_markdown(rows: &[SetRow]) -> String {
    let mut out = String::from("| variant |");
    for t in CALIBRATION_THRESHOLDS {
        let _ = write!(out, " confidence ≥ {t}: kept, BadPix 0.07 |");
    }
    out.push_str("\n|---|");
    out.push_str(&"---|".repeat(CALIBRATION_THRESHOLDS.len()));
    out.push('\n');
    let mut variants: Vec<&str> = rows.iter().map(|r| r.variant.as_str()).collect();
    variants.sort_unstable();
    variants.dedup();
    for v in variants {
        let _ = write!(out, "| {v} |");
        let all: usize = rows
            .iter()
            .filter(|r| r.variant == v)
            .map(|r| r.calibration.first().map_or(0, |c| c.0))
            .sum();
        for k in 0..CALIBRATION_THRESHOLDS.len() {
            let (kept, bad) = rows
                .iter()
                .filter(|r| r.variant == v)
                .filter_map(|r| r.calibration.get(k))
                .fold((0, 0), |(a, b), c| (a + c.0, b + c.1));
            let _ = write!(
                out,
                " {:.1} %, {:.2} |",
                100.0 * kept as f64 / all.max(1) as f64,
                100.0 * bad as f64 / kept.max(1) as f64
            );
        }
        out.push('\n');
    }
    out
}

/// Estimates every scene of `set` with every variant of `variants` (name, options) and
/// scores it (module docs); `progress` advances by scene and variant.
pub fn score_set(
    ctx: &GpuContext,
    set: &[SetScene],
    variants: &[(String, DepthOptions)],
    progress: &ProgressBar,
    mut on_estimate: impl FnMut(&SetScene, &str, &[f32]) -> Result<()>,
) -> Result<Vec<SetRow>> {
    progress.set_length((set.len() * variants.len()) as u64);
    let mut rows = Vec::new();
    for (name, options) in variants {
        for scene in set {
            progress.set_message(format!("{} ({name})", scene.name));
            let est = crate::jobs::depth::estimate(
                ctx,
                &scene.light_field,
                options,
                &ProgressBar::hidden(),
            )?;
            let disparity = scene.scored_disparity(&est)?;
            on_estimate(scene, name, &disparity)?;
            rows.push(score_row(
                scene,
                name,
                &disparity,
                &est.confidence,
                crate::depth::cache::MIN_CONFIDENCE,
                est.timings.gpu_ms,
                est.timings.total_ms,
            ));
            progress.inc(1);
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_set_covers_every_failure_mode_and_refuses_unknown_scenes_and_sizes() {
        assert!(DepthScene::SET.len() >= 6);
        let names: Vec<&str> = DepthScene::SET.iter().map(|s| s.name()).collect();
        for n in &names {
            assert_eq!(DepthScene::from_name(n).map(|s| s.name()), Some(*n));
        }
        let e = synthetic(5, 64, Some(&["moon".into()]))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("moon") && e.contains("bust"), "{e}");
        assert!(synthetic(4, 64, None).is_err());
        assert!(synthetic(5, 16, None).is_err());
    }

    #[test]
    fn every_scene_has_finite_truth_inside_its_border_and_hides_it_from_the_estimator() {
        let set = synthetic(3, 48, None).unwrap();
        for s in &set {
            assert!(s.light_field.depth.is_empty(), "{}", s.name);
            let sc = score(&s.truth, &s.truth, 48, 48, s.border, None);
            assert!(
                sc.pixels > 48 * 48 / 3,
                "{}: {} scored pixels",
                s.name,
                sc.pixels
            );
            assert_eq!(sc.bad_pix_007, 0.0);
        }
        // The plenoptic scene is darker at the grid's rim than in its middle view.
        let p = set.iter().find(|s| s.name == "plenoptic").unwrap();
        let mean = |i: usize| {
            let img = &p.light_field.views[i].image;
            img.pixels().map(|px| px.0[1] as f64).sum::<f64>() / (48.0 * 48.0)
        };
        assert!(mean(0) < 0.75 * mean(4), "{} vs {}", mean(0), mean(4));
    }

    #[test]
    fn the_table_has_a_line_per_scene_and_a_mean_per_variant() {
        let s = |b: f64| DisparityScores {
            bad_pix_007: b,
            bad_pix_003: 2.0 * b,
            bad_pix_001: 3.0 * b,
            off_01: 0.5 * b,
            pearson_r: 0.9,
            mse_x100: b / 10.0,
            pixels: 100,
        };
        let row = |scene: &str, v: &str, b| SetRow {
            scene: scene.into(),
            failure_mode: "x".into(),
            variant: v.into(),
            scores: s(b),
            confident_share: 90.0,
            confident_bad_pix_007: 1.0,
            gpu_ms: Some(10.0),
            total_ms: 20.0,
            calibration: vec![(100, 10), (50, 1)],
            pixels: Vec::new(),
        };
        let rows = [
            row("a", "default", 2.0),
            row("b", "default", 4.0),
            row("a", "naive", 10.0),
        ];
        let t = markdown(&rows);
        assert_eq!(t.lines().count(), 2 + 3 + 2, "{t}");
        assert!(
            t.contains("| **mean of 2 scenes** | | default | **3.00**"),
            "{t}"
        );
        assert!(
            t.contains("| **mean of 1 scenes** | | naive | **10.00**"),
            "{t}"
        );
        // Calibration pools the scenes: 200 pixels, 20 bad at threshold 0; 100, 2 at 0.005.
        let c = calibration_markdown(&rows[..2]);
        assert!(
            c.contains("| default | 100.0 %, 10.00 | 50.0 %, 2.00 |"),
            "{c}"
        );
    }

    #[test]
    fn deciles_cut_the_pooled_pixels_by_confidence_into_ten_equal_parts() {
        let row = |scene: &str, pixels: Vec<(f32, bool)>| SetRow {
            scene: scene.into(),
            failure_mode: "x".into(),
            variant: "default".into(),
            scores: DisparityScores {
                bad_pix_007: 0.0,
                bad_pix_003: 0.0,
                bad_pix_001: 0.0,
                off_01: 0.0,
                pearson_r: 1.0,
                mse_x100: 0.0,
                pixels: pixels.len(),
            },
            confident_share: 100.0,
            confident_bad_pix_007: 0.0,
            gpu_ms: None,
            total_ms: 0.0,
            calibration: Vec::new(),
            pixels,
        };
        // 100 pixels over two scenes, confidence k/100; the 30 least confident are off.
        let (a, b): (Vec<_>, Vec<_>) = (0..100)
            .map(|k| (k as f32 / 100.0, k < 30))
            .partition(|p| (p.0 * 100.0) as u32 % 2 == 0);
        let t = decile_markdown(&[row("a", a), row("b", b)]);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines.len(), 2 + 10, "{t}");
        assert!(
            lines[2].contains("| 1 | 0.0000 – 0.0900 | 100.00 % |"),
            "{t}"
        );
        assert!(
            lines[4].contains("| 3 | 0.2000 – 0.2900 | 100.00 % |"),
            "{t}"
        );
        assert!(lines[5].contains("| 4 | 0.3000 – 0.3900 | 0.00 % |"), "{t}");
        assert!(
            lines[11].contains("| 10 | 0.9000 – 0.9900 | 0.00 % |"),
            "{t}"
        );
    }
}
