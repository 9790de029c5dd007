//! Depth estimation held to bounds over the whole depth test set (one synthetic scene per
//! failure mode, exact ground truth), never one scene: the default against the sweep without
//! its continuous fit and against the naive SAD sweep, the per-mode gains the fit was chosen
//! for, and a confidence that means something. GPU work runs under the Khronos validation
//! layer and asserts zero validation errors. Bounds hold the measured 64-px scores (docs/
//! depth.md) with margin.

mod common;

use std::collections::HashMap;

use tiltfield::bench::depth_set::score_set;
use tiltfield::bench::depth_set::{self as testset, SetRow};
use tiltfield::gpu::GpuContext;

/// The set's scores, computed once for all the tests of this file.
fn scores() -> Vec<SetRow> {
    static ROWS: std::sync::OnceLock<Vec<SetRow>> = std::sync::OnceLock::new();
    ROWS.get_or_init(compute).clone()
}

fn compute() -> Vec<SetRow> {
    let set = testset::synthetic(5, 64, None).unwrap();
    estimate(&set, &["default", "no-median", "sweep", "naive"])
}

/// Every scene of `set` estimated with every variant, on a validated context that must log no
/// validation error.
fn estimate(set: &[testset::SetScene], variants: &[&str]) -> Vec<SetRow> {
    let ctx = GpuContext::new(&common::gpu_options())
        .unwrap_or_else(|e| panic!("cannot create a validated Vulkan context: {e}"));
    let variants: Vec<_> = variants
        .iter()
        .map(|v| (v.to_string(), testset::variant(v).unwrap()))
        .collect();
    let rows = score_set(
        &ctx,
        set,
        &variants,
        &indicatif::ProgressBar::hidden(),
        |_, _, _| Ok(()),
    )
    .unwrap();
    assert_eq!(ctx.validation().errors(), 0, "validation errors");
    rows
}

/// The agreement measures the issue asks of a real plenoptic capture against a learned
/// estimate (r ≥ 0.9, at most 15 % of pixels off by more than 0.1 px), here against the exact
/// truth of the plenoptic scene at the documented 96 px (at 64 px its small ball is mostly
/// rim, and every variant is 40 % off).
#[test]
fn the_plenoptic_scene_agrees_with_its_truth_as_the_issue_asks_of_a_real_capture() {
    let set = testset::synthetic(5, 96, Some(&["plenoptic".to_string()])).unwrap();
    let rows = estimate(&set, &["default", "sweep"]);
    let (d, s) = (&rows[0].scores, &rows[1].scores);
    assert_eq!(
        (rows[0].variant.as_str(), rows[1].variant.as_str()),
        ("default", "sweep")
    );
    // Measured: r 0.990 with 14.3 % off, the sweep alone 33.5 %.
    eprintln!(
        "plenoptic: r {:.3}, {:.1} % off by > 0.1 px (sweep {:.1} %)",
        d.pearson_r, d.off_01, s.off_01
    );
    assert!(d.pearson_r >= 0.9 && d.off_01 <= 15.0, "{d:?}");
    assert!(d.off_01 <= s.off_01 - 10.0, "{d:?} vs sweep {s:?}");
}

#[test]
fn the_default_beats_the_sweep_and_the_naive_sweep_over_the_whole_set() {
    let rows = scores();
    assert_eq!(
        rows.len(),
        4 * testset::synthetic(3, 48, None).unwrap().len()
    );
    // The means' bounds were measured on the nine scenes before the converging rig and the
    // shaded scenes joined the set; those are held to their own bounds below.
    let mean = |v: &str| {
        let of: Vec<&SetRow> = rows
            .iter()
            .filter(|r| r.variant == v && r.scene != "converging" && !shaded(&r.scene))
            .collect();
        testset::mean(&of)
    };
    let (d, s, n) = (mean("default"), mean("sweep"), mean("naive"));
    eprintln!("{}", testset::markdown(&rows));
    // Measured at 64 px: default 15.0 % / 4.55, sweep 24.7 % / 9.0, naive 46.5 % / 52.9
    // (before the plane fill and the winner-against-median step: 17.0 % / 4.31; before the
    // global refinement: 18.5 % / 5.4).
    assert!(
        d.bad_pix_007 <= 20.0,
        "default mean BadPix0.07 {}",
        d.bad_pix_007
    );
    assert!(d.mse_x100 <= 5.0, "default mean MSE×100 {}", d.mse_x100);
    let nm = mean("no-median");
    assert!(d.mse_x100 <= nm.mse_x100 - 0.5, "{d:?} vs no median {nm:?}");
    assert!(
        d.bad_pix_007 <= nm.bad_pix_007 + 1.0,
        "{d:?} vs no median {nm:?}"
    );
    assert!(d.bad_pix_007 <= s.bad_pix_007 - 2.0, "{d:?} vs sweep {s:?}");
    assert!(n.bad_pix_007 >= 1.6 * d.bad_pix_007, "{n:?} vs {d:?}");
    assert!(n.mse_x100 >= 3.0 * d.mse_x100, "{n:?} vs {d:?}");
    // What the fit was chosen for: weak texture on a smooth surface and slanted planes (the
    // sweep's staircase), and noise with vignetting in the mean square (at 64 px its
    // BadPix0.07 is worse than the sweep's: docs/depth.md).
    let at: HashMap<(&str, &str), (f64, f64)> = rows
        .iter()
        .map(|r| {
            (
                (r.scene.as_str(), r.variant.as_str()),
                (r.scores.bad_pix_007, r.scores.mse_x100),
            )
        })
        .collect();
    let (bust, bust_sweep) = (at[&("bust", "default")], at[&("bust", "sweep")]);
    // The median gives the dark wall back the pixels the bust was fattened into, its second
    // pass those in the concave corners too (measured MSE×100 4.7 at 64 px;
    // the issue asks at most 5 on the HCI scene the bust stands in for).
    let bust_nm = at[&("bust", "no-median")];
    assert!(bust.1 <= 0.6 * bust_nm.1, "bust {bust:?} vs {bust_nm:?}");
    assert!(bust.1 <= 5.0, "bust {bust:?}");
    assert!(
        bust.0 <= bust_sweep.0 - 10.0,
        "bust {bust:?} vs {bust_sweep:?}"
    );
    let (tilted, tilted_sweep) = (at[&("tilted", "default")], at[&("tilted", "sweep")]);
    assert!(
        tilted.0 <= 1.0 && tilted.1 <= 0.5 * tilted_sweep.1,
        "{tilted:?} vs {tilted_sweep:?}"
    );
    let (pleno, pleno_sweep) = (at[&("plenoptic", "default")], at[&("plenoptic", "sweep")]);
    assert!(
        pleno.0 <= 70.0 && pleno.1 <= 0.9 * pleno_sweep.1,
        "{pleno:?} vs {pleno_sweep:?}"
    );
    // A converging calibrated rig: the automatic range centred on the point the cameras look
    // at keeps its nearest card (measured 19.7 % / 32.8 at 64 px; anchored at infinity, as
    // before, the range lost that card: 35.1 %).
    let conv = at[&("converging", "default")];
    let conv_naive = at[&("converging", "naive")];
    assert!(
        conv.0 <= 27.0 && conv.0 <= conv_naive.0 - 15.0,
        "converging {conv:?} vs naive {conv_naive:?}"
    );
    // Every estimate has a finite value in every scored pixel (NaN would count as bad, but
    // should not happen at all).
    assert!(rows.iter().all(|r| r.scores.mse_x100.is_finite()));
}

/// Whether `scene` is one of the set's shaded scenes (renderer-like output).
fn shaded(scene: &str) -> bool {
    tiltfield::bench::depth_scenes::DepthScene::from_name(scene).is_some_and(|s| s.shaded())
}

/// The shaded scenes (an area light: Lambertian shading, soft shadows, highlights) are where
/// the estimator fails today, as it fails on real renderer output (docs/depth.md): held here
/// to what they measure, so that a change that helps shows and one that hurts fails.
#[test]
fn the_shaded_scenes_are_scored_and_held_to_their_measured_bounds() {
    let rows = scores();
    let of = |variant: &str| -> Vec<&SetRow> {
        rows.iter()
            .filter(|r| r.variant == variant && shaded(&r.scene))
            .collect()
    };
    let (d, n) = (of("default"), of("naive"));
    assert_eq!(d.len(), 3, "three shaded scenes in the set");
    let (dm, nm) = (testset::mean(&d), testset::mean(&n));
    eprintln!("shaded: default {dm:?}, naive {nm:?}");
    // Measured at 64 px: default 49.0 % / 6.30 mean (57.9, 55.3 and 33.9 %), naive
    // 61.1 % / 54.2. At this size the estimate of the lit walls is biased as a whole (0.08 px:
    // their texture is a pixel wide), and the plane fill makes the bias uniform where noise
    // scattered it: 45.6 % / 7.15 without the plane fill and the winner-against-median step.
    // At 96 px, where the set is reported, they meet most of the issue's target (below).
    assert!(dm.bad_pix_007 <= 50.0, "{dm:?}");
    assert!(dm.mse_x100 <= 8.5, "{dm:?}");
    assert!(nm.bad_pix_007 >= dm.bad_pix_007 + 10.0, "{nm:?} vs {dm:?}");
    assert!(nm.mse_x100 >= 3.0 * dm.mse_x100, "{nm:?} vs {dm:?}");
    assert!(d.iter().all(|r| r.scores.mse_x100.is_finite()));
}

/// The issue's target for the shaded scenes (BadPix 0.07 ≤ 12 % and MSE × 100 ≤ 5 on each) at
/// the set's reporting size, 96 px: the plane fill puts the lit walls back on their planes
/// and the winner-against-median step gives the column's shaded ball back its depth.
#[test]
fn the_shaded_scenes_at_96_px_are_held_to_the_issues_target() {
    let set = testset::synthetic(
        5,
        96,
        Some(&[
            "shaded-bust".into(),
            "sculpture".into(),
            "shaded-column".into(),
        ]),
    )
    .unwrap();
    let rows = estimate(&set, &["default", "no-plane-fill"]);
    let at = |scene: &str, variant: &str| {
        let r = rows
            .iter()
            .find(|r| r.scene == scene && r.variant == variant)
            .unwrap();
        (r.scores.bad_pix_007, r.scores.mse_x100)
    };
    for scene in ["shaded-bust", "sculpture", "shaded-column"] {
        let (d, n) = (at(scene, "default"), at(scene, "no-plane-fill"));
        eprintln!("{scene}: default {d:?}, without the plane fill {n:?}");
    }
    // Measured: shaded-bust 7.2 % / 3.32, sculpture 8.0 % / 2.96, shaded-column 10.7 % /
    // 3.77 (before the mixed outline pixels of step 8 the bust's MSE was 5.83, over the
    // target; before the smooth winners of step 6c the column's BadPix was 13.1 %).
    for (scene, bad, mse) in [
        ("shaded-bust", 12.0, 5.0),
        ("sculpture", 12.0, 5.0),
        ("shaded-column", 12.0, 5.0),
    ] {
        let d = at(scene, "default");
        assert!(d.0 <= bad && d.1 <= mse, "{scene}: {d:?}");
    }
    let (d, n) = (at("sculpture", "default"), at("sculpture", "no-plane-fill"));
    assert!(d.0 <= n.0 - 10.0, "sculpture {d:?} vs {n:?}");
}

/// On a 9 × 9 grid the automatic range reaches as near per grid step as on 5 × 5: the
/// converging rig's nearest card lies inside it. When the range allowed an eighth of the
/// image of motion in the farthest view (half the reach per step on 9 × 9) the card took the
/// range's end: BadPix 0.07 24.6 % at 96 px (measured after: 7.6 %).
#[test]
fn a_nine_by_nine_grid_finds_the_converging_rigs_nearest_card() {
    let set = testset::synthetic(9, 96, Some(&["converging".to_string()])).unwrap();
    let rows = estimate(&set, &["default"]);
    let s = &rows[0].scores;
    eprintln!("converging 9x9 at 96 px: {s:?}");
    assert!(s.bad_pix_007 <= 12.0 && s.mse_x100 <= 40.0, "{s:?}");
}

#[test]
fn confidence_ranks_errors_over_the_set() {
    // Over the nine scenes the bound was measured on: on the converging rig (joined later)
    // the confident pixels are as often wrong as the rest (19.6 against 19.7 % at 64 px).
    let rows: Vec<SetRow> = scores()
        .into_iter()
        .filter(|r| r.variant == "default" && r.scene != "converging" && !shaded(&r.scene))
        .collect();
    let pooled = |k: usize| {
        rows.iter()
            .map(|r| r.calibration[k])
            .fold((0usize, 0usize), |(a, b), (k, e)| (a + k, b + e))
    };
    let (all, bad_all) = pooled(0);
    let last = testset::CALIBRATION_THRESHOLDS.len() - 1;
    let (kept, bad_kept) = pooled(last);
    let rate = |bad: usize, n: usize| bad as f64 / n.max(1) as f64;
    eprintln!("{}", testset::calibration_markdown(&rows));
    // The most confident pixels are clearly more often right than all pixels, and the
    // threshold keeps most of the image.
    assert!(
        rate(bad_kept, kept) <= 0.85 * rate(bad_all, all),
        "BadPix0.07 {:.3} above the top threshold vs {:.3} overall",
        rate(bad_kept, kept),
        rate(bad_all, all)
    );
    assert!(kept as f64 >= 0.8 * all as f64, "{kept} of {all} kept");
    // Thresholds are nested: each keeps no more pixels than the one below it.
    for k in 1..=last {
        assert!(pooled(k).0 <= pooled(k - 1).0);
    }
}

#[test]
fn depth_set_prints_and_writes_the_table_and_refuses_unknown_scenes_and_variants() {
    let dir = tempfile::tempdir().unwrap();
    let md = dir.path().join("set.md");
    // An HCI-format folder that `tiltfield synth` wrote joins the set (with its ground truth),
    // named as such: it is no benchmark scene (those name their category in [meta]).
    let synth = dir.path().join("synth-planes");
    let made = common::tiltfield(&[
        "synth",
        "builtin:planes",
        "--grid",
        "3x3",
        "--size",
        "48x48",
        "-o",
        synth.to_str().unwrap(),
    ]);
    assert!(
        made.status.success(),
        "{}",
        String::from_utf8_lossy(&made.stderr)
    );
    let out = common::tiltfield(&[
        "depth-set",
        "--scenes",
        "planes,tilted",
        "--size",
        "48",
        "--grid",
        "3",
        "--variants",
        "default",
        "--hci",
        synth.to_str().unwrap(),
        "--markdown",
        md.to_str().unwrap(),
        "--validate",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = std::fs::read_to_string(&md).unwrap();
    assert_eq!(table.trim(), stdout.trim());
    assert!(
        table.contains("| planes | occlusion edge | default |"),
        "{table}"
    );
    assert!(
        table.contains("| tilted | slanted plane | default |"),
        "{table}"
    );
    assert!(
        table.contains("| planes | HCI-format folder | default |"),
        "{table}"
    );
    assert!(
        table.contains("| **mean of 3 scenes** | | default |"),
        "{table}"
    );
    assert!(table.contains("Confidence calibration"), "{table}");
    for (args, want) in [
        (
            vec!["depth-set", "--scenes", "moon"],
            "no depth test scene 'moon'",
        ),
        (
            vec!["depth-set", "--variants", "best"],
            "unknown depth variant 'best'",
        ),
        (vec!["depth-set", "--size", "4000"], "48 to 512 px"),
        (vec!["depth-set", "--grid", "4"], "3, 5, 7 or 9"),
    ] {
        let out = common::tiltfield(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(want),
            "{args:?}: {err}"
        );
    }
}
