//! The anti-aliasing test set (`tiltfield antialias-set`, `bench::antialias_set`): over every
//! case (sparse layers focused near, far and tilted, a converging rig, a small disk, fine
//! textures at many depths, slanted boxes, a room's receding walls), anti-aliasing must beat the
//! plain sum against the lens out of focus and overall, on the given and on an estimated depth,
//! without losing the focused pixels; validation on, zero errors.

mod common;

use std::sync::Arc;

use common::gpu_options;
use tiltfield::bench::antialias_set::{self, SetOptions};
use tiltfield::gpu::GpuContext;
use tiltfield::refocus::antialias::AntialiasSettings;
use tiltfield::refocus::settings::Filter;

#[test]
fn antialiasing_beats_the_plain_sum_on_every_case_of_the_set() {
    let ctx = Arc::new(
        GpuContext::new(&gpu_options())
            .unwrap_or_else(|e| panic!("cannot create a validated Vulkan context: {e}")),
    );
    let options = SetOptions {
        size: 96,
        truth_grid: 97,
        frames: 1,
        estimate: true,
        filter: Filter::Hardware,
        supersamples: antialias_set::SUPERSAMPLES,
        antialias: AntialiasSettings::default(),
        layered_model: true,
    };
    let cases = antialias_set::cases();
    let rows = antialias_set::run(&ctx, &cases, &options, &indicatif::ProgressBar::hidden())
        .unwrap_or_else(|e| panic!("the set failed: {e}"));
    eprintln!("{}", antialias_set::markdown(&rows));
    assert_eq!(rows.len(), cases.len());
    // Measured at 96 px (overall / out of focus / focused, plain -> anti-aliased): the
    // smallest gains are the room's 35.5 / 34.0 / 37.2 -> 37.2 / 36.7 / 36.9 dB and the
    // converging rig's 25.6 -> 26.3 dB overall (its focused panel is limited by bilinear
    // resampling of the rotated views for both); the largest focused loss is the nearest
    // card's 19.8 -> 18.9 dB (its colour bars' edges, resampled at 4.5 px per grid step).
    for r in &rows {
        let (p, g) = (&r.plain, &r.given);
        let e = r.estimated.as_ref().expect("scored on an estimate");
        for v in [p.overall, g.overall, e.overall] {
            assert!(v.is_finite() && v > 15.0, "{}: {v} dB", r.name);
        }
        assert!(r.out_of_focus_px > 0 && r.focused_px > 0, "{}", r.name);
        let (po, go, eo) = (
            p.out_of_focus.unwrap(),
            g.out_of_focus.unwrap(),
            e.out_of_focus.unwrap(),
        );
        assert!(
            go >= po + 2.0,
            "{}: out of focus {po:.1} -> {go:.1} dB",
            r.name
        );
        assert!(
            eo >= po + 1.5,
            "{}: estimated, out of focus {po:.1} -> {eo:.1} dB",
            r.name
        );
        assert!(
            g.overall >= p.overall + 0.5,
            "{}: overall {:.1} -> {:.1} dB",
            r.name,
            p.overall,
            g.overall
        );
        let (pf, gf) = (p.focused.unwrap(), g.focused.unwrap());
        assert!(gf >= pf - 1.5, "{}: focused {pf:.1} -> {gf:.1} dB", r.name);
        assert!(r.cost_ratio.is_finite() && r.cost_ratio > 0.0);
        assert_eq!(r.images.len(), 5);
        let fig = antialias_set::figure(r);
        assert_eq!((fig.width(), fig.height()), (5 * 96, 96));
    }
    let mean = |f: &dyn Fn(&antialias_set::CaseResult) -> f64| {
        rows.iter().map(f).sum::<f64>() / rows.len() as f64
    };
    // Measured: plain 29.5 / 30.0 dB, given 33.7 / 37.4, estimated 32.9 / 36.5 (overall / out
    // of focus). Per case the estimate is not held overall: on `depths` it scores 29.5 dB
    // against the plain sum's 29.6 (its colour-bar card, README).
    // On the converging rig the estimate finds the nearest card now that the depth search is
    // centred where the cameras look (docs/depth.md step 2); with the range anchored at
    // infinity it put the card on the wall, 3.7 dB below the given depth out of focus, which
    // this bound catches. Measured: 38.0 dB against the given depth's 39.5. (38.7 while the
    // brightness equaliser still took these views' parallax for vignetting and rescaled
    // them, although the estimate on the views as they are is closer to the truth: 12.9 % of
    // the pixels off by over 2 % in inverse depth, against 17.8 %; where its edge errors fall
    // moved.)
    let rotated = rows.iter().find(|r| r.name == "layers-rotated").unwrap();
    let (go, eo) = (
        rotated.given.out_of_focus.unwrap(),
        rotated.estimated.as_ref().unwrap().out_of_focus.unwrap(),
    );
    assert!(
        eo >= go - 2.0,
        "converging rig: given {go:.1}, estimated {eo:.1} dB"
    );
    let plain = mean(&|r| r.plain.out_of_focus.unwrap());
    assert!(mean(&|r| r.given.out_of_focus.unwrap()) >= plain + 6.0);
    let plain = mean(&|r| r.plain.overall);
    assert!(mean(&|r| r.given.overall) >= plain + 3.0);
    assert!(mean(&|r| r.estimated.unwrap().overall) >= plain + 2.0);
    // The f64 model of layered anti-aliasing (boxed layers composited front to back, no
    // per-sample test) stays near the default's accuracy over the set. Measured at 96 px,
    // mean overall / out of focus on the given depth 36.1 / 38.5 dB against the default's
    // 36.7 / 39.3 (at 128 px 39.5 / 40.8 against 39.4 / 40.7), on the estimate 35.0 against
    // 35.3 overall; without its cell groups it lost 1.7 dB overall at 128 px, without the
    // compositing several dB at occlusion edges. Every case keeps the lattice away.
    for r in &rows {
        let l = r.layered.expect("the layered model scored");
        assert!(
            l.out_of_focus.unwrap() >= r.plain.out_of_focus.unwrap() + 2.0,
            "{}: layered out of focus {:?} against plain {:?}",
            r.name,
            l.out_of_focus,
            r.plain.out_of_focus
        );
    }
    let (lo, go) = (
        mean(&|r| r.layered.unwrap().overall),
        mean(&|r| r.given.overall),
    );
    assert!(
        lo >= go - 1.0,
        "layered {lo:.2} against default {go:.2} dB overall"
    );
    let (lf, gf) = (
        mean(&|r| r.layered.unwrap().out_of_focus.unwrap()),
        mean(&|r| r.given.out_of_focus.unwrap()),
    );
    assert!(
        lf >= gf - 1.2,
        "layered {lf:.2} against default {gf:.2} dB out of focus"
    );
    let (le, ge) = (
        mean(&|r| r.layered_estimated.unwrap().overall),
        mean(&|r| r.estimated.unwrap().overall),
    );
    assert!(
        le >= ge - 0.8,
        "estimated: layered {le:.2} against default {ge:.2} dB"
    );
    let log = ctx.validation();
    assert_eq!(log.errors(), 0, "validation errors: {:#?}", log.messages());
}

/// On a tilted plane every view is resampled between its pixels, and a bilinear fetch softens
/// the plane's fine grain. In-focus sub-samples read Catmull-Rom by default: on the plane that
/// is as sharp as `--filter bicubic` everywhere, and the out-of-focus blur is untouched.
/// Measured at 96 px, anti-aliased on the given depth, on the plane / out of focus: 28.5 /
/// 37.5 dB with every sub-sample bilinear, 33.0 / 37.5 by default, 32.7 / 37.9 bicubic.
#[test]
fn catmull_rom_in_focus_sharpens_the_tilted_plane_without_losing_the_blur() {
    let ctx = Arc::new(
        GpuContext::new(&gpu_options())
            .unwrap_or_else(|e| panic!("cannot create a validated Vulkan context: {e}")),
    );
    let cases =
        antialias_set::select(Some(&["layers-tilted".to_string()])).expect("the tilted case");
    let score = |filter, focused_bicubic| {
        let options = SetOptions {
            size: 96,
            truth_grid: 97,
            frames: 1,
            estimate: false,
            filter,
            supersamples: antialias_set::SUPERSAMPLES,
            antialias: AntialiasSettings {
                focused_bicubic,
                ..AntialiasSettings::default()
            },
            layered_model: false,
        };
        let rows = antialias_set::run(&ctx, &cases, &options, &indicatif::ProgressBar::hidden())
            .unwrap_or_else(|e| panic!("the tilted case failed: {e}"));
        let g = &rows[0].given;
        (g.focused.unwrap(), g.out_of_focus.unwrap())
    };
    let bilinear = score(Filter::Hardware, false);
    let default = score(Filter::Hardware, true);
    let bicubic = score(Filter::Bicubic, true);
    eprintln!("on the plane / out of focus: bilinear {bilinear:.1?}, default {default:.1?}, bicubic {bicubic:.1?}");
    assert!(
        default.0 >= bilinear.0 + 2.5 && default.0 >= bicubic.0 - 0.5,
        "on the plane: bilinear {:.1}, default {:.1}, bicubic {:.1} dB",
        bilinear.0,
        default.0,
        bicubic.0
    );
    assert!(
        default.1 >= bilinear.1 - 0.5 && bicubic.1 >= bilinear.1 - 0.5,
        "out of focus: bilinear {:.1}, default {:.1}, bicubic {:.1} dB",
        bilinear.1,
        default.1,
        bicubic.1
    );
    let log = ctx.validation();
    assert_eq!(log.errors(), 0, "validation errors: {:#?}", log.messages());
}

/// Bad options of `tiltfield antialias-set` fail with their cause, before any work.
#[test]
fn bad_set_options_fail_clearly() {
    for (args, want) in [
        (
            vec!["antialias-set", "--cases", "moon"],
            "no anti-aliasing case 'moon'",
        ),
        (vec!["antialias-set", "--size", "4000"], "48 to 512 px"),
        (
            vec!["antialias-set", "--truth-grid", "3"],
            "--truth-grid must be 9 to 257",
        ),
        (vec!["antialias-set", "--filter", "sinc"], "sinc"),
    ] {
        let out = common::tiltfield(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(want),
            "{args:?}: {err}"
        );
    }
}

/// Defocused views (`--antialias-defocus on`, `refocus::defocus`): each view box-filtered once
/// over its footprints, one fetch per view. Over every case they beat the plain sum out of focus
/// and overall; without the occlusion tests they lose to the default at occlusion edges
/// (README). Measured at 64 px (mean overall / out of focus / focused): plain 32.1 / 32.1 /
/// 40.4 dB, defocused 35.8 / 36.8 / 42.0; the smallest gain out of focus is the tower's, 39.1
/// -> 41.0 dB. The focused pixels may lose a little where a focused
/// edge borders a far, wide blur: the bilinear read of a defocused view mixes the edge's texel
/// with its blurred neighbour (`layers-near`'s card at 64 px: 54.5 -> 51.5 dB; at 128 px 49.2
/// -> 49.3).
#[test]
fn defocused_views_beat_the_plain_sum_on_every_case_of_the_set() {
    let ctx = Arc::new(
        GpuContext::new(&gpu_options())
            .unwrap_or_else(|e| panic!("cannot create a validated Vulkan context: {e}")),
    );
    let options = SetOptions {
        size: 64,
        truth_grid: 65,
        frames: 1,
        estimate: false,
        filter: Filter::Hardware,
        supersamples: antialias_set::SUPERSAMPLES,
        antialias: AntialiasSettings {
            defocus: true,
            ..AntialiasSettings::default()
        },
        layered_model: false,
    };
    let cases = antialias_set::cases();
    let rows = antialias_set::run(&ctx, &cases, &options, &indicatif::ProgressBar::hidden())
        .unwrap_or_else(|e| panic!("the set failed: {e}"));
    eprintln!("{}", antialias_set::markdown(&rows));
    for r in &rows {
        let (p, g) = (&r.plain, &r.given);
        let (po, go) = (p.out_of_focus.unwrap(), g.out_of_focus.unwrap());
        assert!(
            go >= po + 1.5,
            "{}: out of focus {po:.1} -> {go:.1} dB",
            r.name
        );
        assert!(
            g.overall >= p.overall + 0.5,
            "{}: overall {:.1} -> {:.1} dB",
            r.name,
            p.overall,
            g.overall
        );
        let (pf, gf) = (p.focused.unwrap(), g.focused.unwrap());
        assert!(gf >= pf - 3.5, "{}: focused {pf:.1} -> {gf:.1} dB", r.name);
    }
    let mean = |f: &dyn Fn(&antialias_set::CaseResult) -> f64| {
        rows.iter().map(f).sum::<f64>() / rows.len() as f64
    };
    let plain = mean(&|r| r.plain.out_of_focus.unwrap());
    let defocused = mean(&|r| r.given.out_of_focus.unwrap());
    assert!(
        defocused >= plain + 4.0,
        "out of focus {plain:.1} -> {defocused:.1} dB"
    );
    let log = ctx.validation();
    assert_eq!(log.errors(), 0, "validation errors: {:#?}", log.messages());
}
