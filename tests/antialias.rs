//! Anti-aliased refocus (docs/conventions.md §11) against the optical ground truth of a real
//! lens, and the GPU against its f64 CPU model. Every GPU test runs with the validation layer
//! and asserts zero errors.
//!
//! The scene is synth's `layers`: a sparse 5×5 light field of four textured planes at −3, 0,
//! +2 and +6 px of disparity per grid step (128-pixel views), refocused with a disk aperture of
//! radius 2 grid steps and compared, in 8-bit PSNR of the encoded values, with the mean of
//! ~13 000 pinhole renders spread over the same disk (a thin lens of that aperture).

mod common;

use common::*;
use glam::{DVec2, DVec3};
use tiltfield::geometry::aperture::{Aperture, ApertureShape};
use tiltfield::geometry::plane::Plane;
use tiltfield::jobs::raster::{render_light_field, Rasterizer};
use tiltfield::jobs::refocus::{GpuImage, HeadlessRenderer, RenderSettings};
use tiltfield::lightfield::{DepthKind, GridSize, LightField};
use tiltfield::refocus::antialias::{plan_antialias, AntialiasPlan, AntialiasSettings, Layered};
use tiltfield::refocus::settings::{Filter, OutputFormat};
use tiltfield::refocus::{self, cpu, Averaging, FocusSpec, RefocusPlan, RefocusRequest};
use tiltfield::synth::{synth_scene, RigKind, SynthRig};

const SIZE: u32 = 128;
const RADIUS: f64 = 2.0;
/// Pinholes per side of the optical truth's aperture grid (~13 000 inside the disk). The
/// textures' fine grain needs that many: with 33 per side (~800 pinholes) the truth itself is
/// still noisy on the back wall (its interior scored 35 dB against anti-aliasing, 46.5 dB
/// against the same truth with 129 per side).
const GT_GRID: u32 = 129;

fn disk() -> Aperture {
    Aperture {
        shape: ApertureShape::Disk,
        radius: Some(RADIUS),
    }
}

fn layers_rig(size: u32, kind: RigKind) -> SynthRig {
    let s = synth_scene("layers").unwrap();
    SynthRig {
        grid: GridSize { cols: 5, rows: 5 },
        width: size,
        height: size,
        focal_px: s.focal_per_width * size as f64,
        baseline: s.baseline,
        focus_distance: s.focus_distance,
        kind,
    }
}

fn rasterizer() -> Rasterizer {
    let s = synth_scene("layers").unwrap();
    Rasterizer::new(&s.mesh(), &gpu_options())
        .unwrap_or_else(|e| panic!("cannot create a validated rasterizer: {e}"))
}

fn assert_raster_clean(r: &Rasterizer) {
    let log = r.context().validation();
    assert_eq!(log.errors(), 0, "validation errors: {:#?}", log.messages());
}

fn encoded_linear(px: &[[f32; 4]]) -> Vec<[f64; 3]> {
    px.iter()
        .map(|p| std::array::from_fn(|k| tiltfield::color::linear_to_srgb(p[k] as f64)))
        .collect()
}

fn plain_and_aa(
    lf: &LightField,
    plane: Plane,
    reference: Option<DVec2>,
    settings: AntialiasSettings,
) -> (RefocusPlan, AntialiasPlan) {
    let req = RefocusRequest {
        focus: FocusSpec::Plane(plane),
        aperture: disk(),
        reference,
    };
    let plan = refocus::plan(lf, &req, &[]).unwrap();
    let depth = lf.view_depth().unwrap();
    let aa = plan_antialias(lf, &plan, disk(), &[], &depth, settings).unwrap();
    (plan, aa)
}

fn float_settings(filter: Filter) -> RenderSettings {
    RenderSettings {
        output: OutputFormat::Float,
        filter,
        ..RenderSettings::default()
    }
}

fn float(img: GpuImage) -> tiltfield::refocus::RefocusImage {
    match img {
        GpuImage::Float(f) => f,
        GpuImage::Srgb8(_) => panic!("asked for float output"),
    }
}

/// Residual disparity (px per grid step) of the scene against the focus plane at every
/// reference pixel, from the reference view's exact depth.
fn residual_px(lf: &LightField, plan: &RefocusPlan) -> Vec<f64> {
    let depth = lf.view_depth().unwrap();
    // Every rig of these tests has the layers scene's baseline and f = W.
    let bf = synth_scene("layers").unwrap().baseline * lf.width as f64;
    (0..lf.width * lf.height)
        .map(|i| {
            let (x, y) = (i % lf.width, i / lf.width);
            let s = plan.m.dot(DVec3::new(x as f64, y as f64, 1.0)).max(0.0);
            let z = depth.depth(x, y).unwrap_or(f64::INFINITY);
            bf * (1.0 / z - s)
        })
        .collect()
}

/// Pixels at least `border` from the image edge whose every neighbour within `margin` px has a
/// residual satisfying `keep` (so a mask of the focused plane stays clear of occlusion edges,
/// where the lens sees a nearer layer's blur spill over it).
fn mask_where(
    res: &[f64],
    size: u32,
    border: u32,
    margin: i64,
    keep: impl Fn(f64) -> bool,
) -> Vec<bool> {
    let n = size as i64;
    (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            if x < border as i64
                || y < border as i64
                || x >= n - border as i64
                || y >= n - border as i64
            {
                return false;
            }
            (-margin..=margin).all(|dy| {
                (-margin..=margin).all(|dx| {
                    let (u, v) = ((x + dx).clamp(0, n - 1), (y + dy).clamp(0, n - 1));
                    keep(res[(v * n + u) as usize])
                })
            })
        })
        .collect()
}

struct Scores {
    overall: f64,
    out_of_focus: f64,
    focused: f64,
}

fn scores(
    img: &[[f64; 3]],
    truth: &[[f64; 3]],
    masks: &(Vec<bool>, Vec<bool>, Vec<bool>),
) -> Scores {
    Scores {
        overall: psnr_rgb(img, truth, &masks.0),
        out_of_focus: psnr_rgb(img, truth, &masks.1),
        focused: psnr_rgb(img, truth, &masks.2),
    }
}

/// Renders plain and anti-aliased refocus of `plane` and scores both against the lens.
fn against_the_lens(
    r: &mut Rasterizer,
    h: &mut HeadlessRenderer,
    lf: &LightField,
    plane: Plane,
    label: &str,
) -> (Scores, Scores) {
    let (p, a, _) = against_the_lens_masked(r, h, lf, lf, plane, label, false);
    (p, a)
}

/// [`against_the_lens`] with the masks (focused, out of focus) from `truth_lf`'s depth, so
/// a light field with estimated depth is scored on the true layers; with `bicubic`, also the
/// anti-aliased refocus with the bicubic filter (against the same lens).
fn against_the_lens_masked(
    r: &mut Rasterizer,
    h: &mut HeadlessRenderer,
    lf: &LightField,
    truth_lf: &LightField,
    plane: Plane,
    label: &str,
    bicubic: bool,
) -> (Scores, Scores, Option<Scores>) {
    let (plan, aa) = plain_and_aa(lf, plane, None, AntialiasSettings::default());
    let radius = RADIUS * synth_scene("layers").unwrap().baseline;
    let (gt, pinholes) = r
        .optical_ground_truth(
            &plan.reference_camera,
            &plane,
            radius,
            GT_GRID,
            (SIZE, SIZE),
            3,
        )
        .unwrap();
    assert!(pinholes > 12_000, "{pinholes} pinholes");
    let truth = encoded_linear(&gt);
    let settings = float_settings(Filter::Hardware);
    let (plain, t_plain) = h.render(&plan, &settings).unwrap();
    let (anti, t_aa) = h.render_antialiased(&aa, &settings).unwrap();
    let (plain, anti) = (encoded(&float(plain)), encoded(&float(anti)));
    let cubic = bicubic.then(|| {
        let (img, t) = h
            .render_antialiased(&aa, &float_settings(Filter::Bicubic))
            .unwrap();
        (encoded(&float(img)), t)
    });
    let res = residual_px(truth_lf, &plan);
    let masks = (
        mask_where(&res, SIZE, 4, 0, |_| true),
        mask_where(&res, SIZE, 4, 0, |d| d.abs() > 0.5),
        // Clear of nearer layers by more than their blur's reach (|d| R px), where the lens
        // sees them spill over the focused plane.
        mask_where(&res, SIZE, 4, 14, |d| d <= 0.5)
            .iter()
            .zip(mask_where(&res, SIZE, 4, 0, |d| d.abs() <= 0.5))
            .map(|(a, b)| *a && b)
            .collect(),
    );
    let (p, a) = (
        scores(&plain, &truth, &masks),
        scores(&anti, &truth, &masks),
    );
    eprintln!(
        "{label}: plain {:.1} / {:.1} / {:.1} dB, anti-aliased {:.1} / {:.1} / {:.1} dB \
         (overall / out of focus / focused; {} and {} focused and out-of-focus pixels); GPU \
         {:?} vs {:?} ms",
        p.overall,
        p.out_of_focus,
        p.focused,
        a.overall,
        a.out_of_focus,
        a.focused,
        masks.2.iter().filter(|&&m| m).count(),
        masks.1.iter().filter(|&&m| m).count(),
        t_plain.map(|t| t.refocus_ms),
        t_aa.map(|t| t.refocus_ms),
    );
    let c = cubic.map(|(img, t)| {
        let c = scores(&img, &truth, &masks);
        eprintln!(
            "{label}, anti-aliased with --filter bicubic: {:.1} / {:.1} / {:.1} dB; GPU {:?} ms",
            c.overall,
            c.out_of_focus,
            c.focused,
            t.map(|t| t.refocus_ms)
        );
        c
    });
    (p, a, c)
}

/// The acceptance numbers: on the sparse layered scene, anti-aliasing approaches the lens off
/// the focus plane (where the plain sum draws a lattice of copies) and keeps the focused plane
/// as sharp as the plain sum; for a frontoparallel and a tilted focus plane.
#[test]
fn antialiasing_matches_the_lens_where_the_plain_sum_draws_a_lattice() {
    let mut r = rasterizer();
    let rig = layers_rig(SIZE, RigKind::Parallel);
    let lf = render_light_field(&mut r, &rig, 3, false)
        .unwrap()
        .light_field;
    let mut h = renderer(&lf);
    let [_, zm, zn, _] = tiltfield::synth::scenes::LAYER_DEPTHS;

    let front = Plane::new(DVec3::new(0.0, 0.0, zm), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let (p, a) = against_the_lens(&mut r, &mut h, &lf, front, "frontoparallel at 0 px");
    // Measured on lavapipe: plain 29.8 / 27.8 / 59.1 dB, anti-aliased with the default's
    // layered footprints (a given depth) 43.5 / 42.2 / 59.1 dB; with the sub-samples 42.8 /
    // 41.2 / 59.1 dB (the issue asks 42 / 40 / 55; 42.7 / 41.0 before rim cells were centred on their
    // part's centroid). With the occlusion decided per view (its plain sample's
    // ray alone, no visibility maps) it was 40.3 / 38.8: the focused panel's edges were
    // smeared into the wall's blur behind them (docs/conventions.md §11); with the half-pixel
    // guard of an estimated depth on this exact map, 41.8 / 41.2.
    assert!(a.overall >= 42.0 && a.out_of_focus >= 40.0 && a.focused >= 55.0);
    assert!(a.out_of_focus >= p.out_of_focus + 10.0);
    assert!(a.focused >= p.focused - 0.5);

    // The same with the depth estimated from the views (plane sweep, `tiltfield depth`)
    // instead of the rendered map.
    let mut estimated = lf.clone();
    estimated.depth.clear();
    tiltfield::jobs::depth::ensure_depth_in(
        h.context(),
        &mut estimated,
        &tiltfield::depth::DepthOptions::default(),
        &indicatif::ProgressBar::hidden(),
        None,
    )
    .unwrap();
    let (pe, ae, _) = against_the_lens_masked(
        &mut r,
        &mut h,
        &estimated,
        &lf,
        front,
        "estimated depth",
        false,
    );
    // Measured: plain 29.8 / 27.8 / 59.1 dB, anti-aliased 40.9 / 40.4 / 56.9 dB (the issue
    // asks 38 overall). 37.1 before the estimator placed its depth edges to the pixel
    // (depth::edges): a card's edge column taken for the wall behind it was blurred into the
    // wall's blur (30 levels of error), a wall column taken for the card left sharp; 34.3
    // before the per-sub-sample occlusion. What remains: the wall's mortar next to the
    // focused panel's grey frame, which colour cannot tell apart.
    assert!(ae.out_of_focus >= pe.out_of_focus + 10.0);
    assert!(ae.overall >= 38.0 && ae.focused >= 50.0);

    // Through the 2 m panel (left) and the 1.52 m panel (lower right), turned about y.
    let p1 = DVec3::new(-0.5, 0.0, zm);
    let p2 = DVec3::new(0.22 * zn, 0.24 * zn, zn);
    let normal = (p2 - p1).cross(DVec3::Y).normalize();
    let tilted = Plane::new(p1, if normal.z > 0.0 { -normal } else { normal }).unwrap();
    let (p, a, c) = against_the_lens_masked(
        &mut r,
        &mut h,
        &lf,
        &lf,
        tilted,
        "tilted through two layers",
        true,
    );
    // Measured: plain 28.7 / 28.5 / 29.5 dB, anti-aliased 35.7 / 37.7 / 33.2 dB, with
    // `--filter bicubic` 35.9 / 38.5 / 33.1 dB (3 x 3 jitters a pixel; the anti-aliasing
    // set's 8 x 8 meets the 34 / 38 / 36: README). On the tilted plane every view's
    // shift is fractional and bilinear interpolation softens the panels' fine grain: before
    // in-focus sub-samples read Catmull-Rom the default scored 33.0 / 37.7 / 29.6 dB. Now
    // it is as sharp on the plane as bicubic everywhere, at a fraction of its GPU time.
    assert!(a.out_of_focus >= p.out_of_focus + 8.0);
    assert!(a.focused >= p.focused + 2.0, "Catmull-Rom on the plane");
    let c = c.unwrap();
    assert!(a.focused >= c.focused - 0.5, "as sharp as bicubic");
    assert!(a.overall >= 34.0 && a.out_of_focus >= 37.5);
    assert!(c.overall >= 34.0 && c.out_of_focus >= 37.5, "bicubic");
    assert_no_validation_errors(&h);
    assert_raster_clean(&r);
}

/// The default with sub-sampled footprints (boxed where they apply): what the default takes on
/// an estimated depth, a focus surface or a scaled output, and on a given depth with
/// `--antialias-layered off`.
fn sub_samples() -> AntialiasSettings {
    AntialiasSettings {
        layered: Layered::Off,
        ..AntialiasSettings::default()
    }
}

/// Holds the GPU's anti-aliased sum to the f64 model (`cpu::render_antialiased`) with the
/// shader's exact bilinear filter, leaving out the pixels where f32 may round a sub-sample count
/// or a mask the other way.
fn gpu_matches_model(lf: &LightField, aa: &AntialiasPlan, label: &str) {
    let mut h = renderer(lf);
    let (img, _) = h
        .render_antialiased(aa, &float_settings(Filter::Shader))
        .unwrap();
    let gpu = float(img);
    assert!(gpu.is_finite(), "{label}: non-finite pixels");
    let model = cpu::render_antialiased(lf, aa, Averaging::Linear, lf.width, lf.height);
    let ambiguous =
        cpu::ambiguous_antialiased(lf, aa, Averaging::Linear, (lf.width, lf.height), 1e-4);
    let keep: Vec<bool> = ambiguous.iter().map(|a| !a).collect();
    let d = diff(&gpu, &model, Some(&keep));
    let left_out = ambiguous.iter().filter(|&&a| a).count();
    eprintln!(
        "{label}: GPU vs f64 model {:.1} dB, max {:.3} levels ({left_out} ambiguous pixels left out)",
        d.psnr_db, d.max_levels
    );
    assert!(
        left_out < (lf.width * lf.height / 20) as usize,
        "{left_out}"
    );
    assert!(d.psnr_db >= 60.0 && d.max_levels <= 1.0, "{label}: {d:?}");
    assert_eq!(d.coverage_mismatch, 0);
    assert_no_validation_errors(&h);
}

/// The GPU equals the f64 model: at the grid centre, from a virtual reference view between the
/// cameras (the depth map reprojected into it), and on a converging rig whose rotated cameras
/// make every footprint a parallelogram that is not axis-aligned.
#[test]
fn gpu_antialiasing_matches_the_f64_model() {
    let mut r = rasterizer();
    let size = 64;
    let lf = render_light_field(&mut r, &layers_rig(size, RigKind::Parallel), 2, false)
        .unwrap()
        .light_field;
    // Off the layers' depths, so footprint lengths are not whole pixels (where f32 and f64
    // may round a sub-sample count differently).
    let front = Plane::new(DVec3::new(0.0, 0.0, 2.1), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let settings = sub_samples();
    let (_, aa) = plain_and_aa(&lf, front, None, settings);
    gpu_matches_model(&lf, &aa, "grid centre");
    // Focused a hair behind the 0-px panel (its views shift by at most 0.01 px and agree): the
    // focus test takes its pixels to the plain sum (the shader reads every view of the plan
    // for the test). Exactly on it, sub-samples of the other layers land on half pixels.
    let panel = Plane::new(DVec3::new(0.0, 0.0, 2.003), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let (_, tested) = plain_and_aa(&lf, panel, None, settings);
    gpu_matches_model(
        &lf,
        &tested,
        "focused on the panel, the focus test deciding",
    );
    let untested = AntialiasSettings {
        focus_test: false,
        ..settings
    };
    let (_, untested) = plain_and_aa(&lf, panel, None, untested);
    gpu_matches_model(
        &lf,
        &untested,
        "focused on the panel, without the focus test",
    );
    // The test decided somewhere: the two models differ there.
    let model = |aa: &AntialiasPlan| {
        cpu::render_antialiased(&lf, aa, Averaging::Linear, lf.width, lf.height).pixels
    };
    let (a, b) = (model(&tested), model(&untested));
    let changed = a
        .iter()
        .zip(&b)
        .filter(|(p, q)| (0..3).any(|k| (p[k] - q[k]).abs() > 1e-6))
        .count();
    assert!(changed > 100, "the focus test changed {changed} pixels");
    // Without the focus test every pixel of the panel is its own focused surface: its
    // in-focus sub-samples read Catmull-Rom, and without that bilinear, as the model does.
    let bilinear = AntialiasSettings {
        focus_test: false,
        focused_bicubic: false,
        ..settings
    };
    let (_, bilinear) = plain_and_aa(&lf, panel, None, bilinear);
    gpu_matches_model(
        &lf,
        &bilinear,
        "focused on the panel, in-focus sub-samples bilinear",
    );
    let changed = model(&untested)
        .iter()
        .zip(&model(&bilinear))
        .filter(|(p, q)| (0..3).any(|k| (p[k] - q[k]).abs() > 1e-4))
        .count();
    assert!(changed > 100, "Catmull-Rom changed {changed} pixels");
    // One sub-sample per view: footprints up to 3 px read the prefilter pyramid's levels
    // (refocus::prefilter), the shader's trilinear from texel fetches against the model's.
    let one = AntialiasSettings {
        max_samples: 1,
        ..settings
    };
    let (_, aa1) = plain_and_aa(&lf, front, None, one);
    gpu_matches_model(&lf, &aa1, "grid centre, prefiltered single sub-sample");
    // Caps 1 and 2 have their own unrolled paths in the shader.
    let two = AntialiasSettings {
        max_samples: 2,
        ..settings
    };
    let (_, aa2) = plain_and_aa(&lf, front, None, two);
    gpu_matches_model(&lf, &aa2, "grid centre, prefiltered 2 x 2");
    let sharp = AntialiasSettings {
        max_samples: 2,
        prefilter: false,
        focus_test: false,
        ..settings
    };
    let (_, aa2) = plain_and_aa(&lf, front, Some(DVec2::new(1.5, 2.25)), sharp);
    gpu_matches_model(&lf, &aa2, "virtual view, sharp 2 x 2");
    // Past MAX_VISIBILITY_BYTES a plan has no visibility maps: the pass then skips the view
    // test, as the model does.
    let (_, mut blind) = plain_and_aa(&lf, front, None, settings);
    assert!(blind.visibility.is_some());
    blind.visibility = None;
    gpu_matches_model(&lf, &blind, "grid centre without visibility maps");
    // Without the occlusion tests no front is searched and no visibility map is built: every
    // sub-sample takes its pixel's own residual, on the GPU as in the model.
    let open = AntialiasSettings {
        occlusion: false,
        ..settings
    };
    let (_, open) = plain_and_aa(&lf, front, None, open);
    assert!(open.visibility.is_none());
    assert_eq!(open.depth.front, open.depth.inverse_depth);
    gpu_matches_model(&lf, &open, "grid centre without the occlusion tests");
    let changed = model(&aa)
        .iter()
        .zip(&model(&open))
        .filter(|(p, q)| (0..3).any(|k| (p[k] - q[k]).abs() > 1e-4))
        .count();
    assert!(
        changed > 100,
        "the occlusion tests changed {changed} pixels"
    );
    let (_, fastest) = plain_and_aa(&lf, front, None, AntialiasSettings::FASTEST);
    gpu_matches_model(&lf, &fastest, "grid centre, the fastest setting");
    // On an estimated depth sub-samples within the guard of the plain sample skip the test.
    let (_, mut guarded) = plain_and_aa(&lf, front, None, settings);
    guarded.guard_px = tiltfield::refocus::antialias::ESTIMATED_DEPTH_GUARD_PX;
    gpu_matches_model(&lf, &guarded, "grid centre, an estimated depth's guard");
    let (_, aa) = plain_and_aa(&lf, front, Some(DVec2::new(1.5, 2.25)), settings);
    assert!(
        aa.depth.unknown < 64,
        "{} pixels without depth",
        aa.depth.unknown
    );
    gpu_matches_model(&lf, &aa, "virtual view (1.5, 2.25)");

    let rig = layers_rig(size, RigKind::Converging { distance: 2.5 });
    let lf = render_light_field(&mut r, &rig, 2, false)
        .unwrap()
        .light_field;
    let (_, aa) = plain_and_aa(&lf, front, None, settings);
    let (s, t) = (aa.footprints[0].span_s, aa.footprints[0].span_t);
    assert!(
        s.y.abs() > 1e-3 * s.x.abs() || t.x.abs() > 1e-3 * t.y.abs(),
        "{s} {t}"
    );
    gpu_matches_model(&lf, &aa, "converging rig");
    assert_raster_clean(&r);
}

/// Defocused views (`AntialiasSettings::defocus`, `refocus::defocus`) on the GPU equal their
/// f64 model (`cpu::render_antialiased` follows the setting): at the grid centre, from a
/// virtual reference view, on a plane tilted through the layers and on a converging rig. The
/// GPU's tables are f32 sums (offset by about the view's mean) and its defocused views half
/// floats, against the model's f64: at 64 px they stay within a level.
#[test]
fn defocused_views_match_the_f64_model() {
    let mut r = rasterizer();
    let size = 64;
    let settings = AntialiasSettings {
        defocus: true,
        ..AntialiasSettings::default()
    };
    let lf = render_light_field(&mut r, &layers_rig(size, RigKind::Parallel), 2, false)
        .unwrap()
        .light_field;
    let front = Plane::new(DVec3::new(0.0, 0.0, 2.1), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let (_, aa) = plain_and_aa(&lf, front, None, settings);
    assert!(
        aa.visibility.is_some(),
        "defocused views need the views' depth maps"
    );
    gpu_matches_model(&lf, &aa, "defocused, grid centre");
    let (_, aa) = plain_and_aa(&lf, front, Some(DVec2::new(1.5, 2.25)), settings);
    gpu_matches_model(&lf, &aa, "defocused, virtual view");
    let tilted = Plane::new(DVec3::new(0.0, 0.0, 2.2), DVec3::new(0.3, 0.0, -1.0)).unwrap();
    let (_, aa) = plain_and_aa(&lf, tilted, None, settings);
    gpu_matches_model(&lf, &aa, "defocused, tilted plane");
    // The defocused views are not the sub-sampled footprints: the two models differ.
    let changed = models_differ(&lf, front, settings);
    assert!(changed > 500, "defocused views changed {changed} pixels");
    let rig = layers_rig(size, RigKind::Converging { distance: 2.0 });
    let lf = render_light_field(&mut r, &rig, 2, false)
        .unwrap()
        .light_field;
    let (_, aa) = plain_and_aa(&lf, front, None, settings);
    gpu_matches_model(&lf, &aa, "defocused, converging rig");
    assert_raster_clean(&r);
}

/// Pixels where the f64 model with `settings` differs (by over 1e-3) from the sub-samples at
/// every pixel (the default without boxed footprints), focused on `plane`.
fn models_differ(lf: &LightField, plane: Plane, settings: AntialiasSettings) -> usize {
    let every = AntialiasSettings {
        boxed: false,
        ..sub_samples()
    };
    let (_, sub) = plain_and_aa(lf, plane, None, every);
    let (_, other) = plain_and_aa(lf, plane, None, settings);
    let model = |aa: &AntialiasPlan| {
        cpu::render_antialiased(lf, aa, Averaging::Linear, lf.width, lf.height).pixels
    };
    model(&sub)
        .iter()
        .zip(&model(&other))
        .filter(|(p, q)| (0..3).any(|k| (p[k] - q[k]).abs() > 1e-3))
        .count()
}

/// Boxed footprints (`AntialiasSettings::boxed`, the default; `refocus::boxed`) on the GPU
/// equal their f64 model where they decide a pixel and where they hand it to the sub-samples:
/// focused on the nearest card (the back wall's footprints several pixels long), on a plane
/// tilted through the layers, from a virtual reference view and on a converging rig. The GPU's
/// summed-area tables are integers (exact sums whatever the table's size), the model's f64.
#[test]
fn boxed_footprints_match_the_f64_model() {
    let mut r = rasterizer();
    let size = 96;
    let settings = sub_samples();
    assert!(
        settings.boxed,
        "boxed footprints are the sub-samples' default"
    );
    let lf = render_light_field(&mut r, &layers_rig(size, RigKind::Parallel), 2, false)
        .unwrap()
        .light_field;
    let near = Plane::new(DVec3::new(0.0, 0.0, 1.3), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let tilted = Plane::new(DVec3::new(0.0, 0.0, 1.6), DVec3::new(0.3, 0.0, -1.0)).unwrap();
    let (_, aa) = plain_and_aa(&lf, near, None, settings);
    assert!(tiltfield::refocus::boxed::can_box(
        &aa,
        (lf.width, lf.height)
    ));
    gpu_matches_model(&lf, &aa, "boxed, focused near");
    // The boxes decided pixels: the model differs from the sub-samples' there.
    let changed = models_differ(&lf, near, settings);
    assert!(changed > 500, "boxed footprints changed {changed} pixels");
    let (_, aa) = plain_and_aa(&lf, tilted, None, settings);
    gpu_matches_model(&lf, &aa, "boxed, tilted plane");
    // (On the near plane a virtual view's masks leave too many pixels ambiguous to compare.)
    let (_, aa) = plain_and_aa(&lf, tilted, Some(DVec2::new(1.5, 2.25)), settings);
    gpu_matches_model(&lf, &aa, "boxed, virtual view");
    // Without the occlusion tests no pixel is an edge: every out-of-focus pixel with a long
    // enough footprint takes its box.
    let open = AntialiasSettings {
        occlusion: false,
        ..settings
    };
    let (_, aa) = plain_and_aa(&lf, near, None, open);
    gpu_matches_model(&lf, &aa, "boxed, without the occlusion tests");
    let rig = layers_rig(64, RigKind::Converging { distance: 2.5 });
    let lf = render_light_field(&mut r, &rig, 2, false)
        .unwrap()
        .light_field;
    // The others' planes leave too many pixels of this rig ambiguous (masks, sub-sample counts).
    let front = Plane::new(DVec3::new(0.0, 0.0, 2.1), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let (_, aa) = plain_and_aa(&lf, front, None, settings);
    assert!(tiltfield::refocus::boxed::can_box(
        &aa,
        (lf.width, lf.height)
    ));
    gpu_matches_model(&lf, &aa, "boxed, converging rig");
    assert_raster_clean(&r);
}

/// Layered footprints (`AntialiasSettings::layered`, `refocus::layered`) on the GPU equal their
/// f64 model (`cpu::render_antialiased` follows the setting): at the grid centre, on a plane
/// tilted through the layers, from a virtual reference view, with an estimate's guard and on a
/// converging rig. The GPU sums and boxes in f32 with the shader's bilinear filter (exact
/// weights), the model in f64.
#[test]
fn layered_footprints_match_the_f64_model() {
    let mut r = rasterizer();
    let size = 64;
    let settings = AntialiasSettings {
        layered: tiltfield::refocus::antialias::Layered::On,
        ..AntialiasSettings::default()
    };
    let lf = render_light_field(&mut r, &layers_rig(size, RigKind::Parallel), 2, false)
        .unwrap()
        .light_field;
    let front = Plane::new(DVec3::new(0.0, 0.0, 2.1), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let tilted = Plane::new(DVec3::new(0.0, 0.0, 2.2), DVec3::new(0.3, 0.0, -1.0)).unwrap();
    let check = |lf: &LightField, aa: &AntialiasPlan, label: &str| {
        let mut h = renderer(lf);
        let (img, _) = h
            .render_antialiased(aa, &float_settings(Filter::Shader))
            .unwrap();
        let gpu = float(img);
        assert!(gpu.is_finite(), "{label}: non-finite pixels");
        let model = cpu::render_antialiased(lf, aa, Averaging::Linear, lf.width, lf.height);
        let d = diff(&gpu, &model, None);
        eprintln!(
            "{label}: GPU vs f64 model {:.1} dB, max {:.3} levels",
            d.psnr_db, d.max_levels
        );
        assert!(d.psnr_db >= LAYERED_MODEL_DB, "{label}: {d:?}");
        assert_eq!(d.coverage_mismatch, 0, "{label}");
        assert_no_validation_errors(&h);
    };
    let (_, aa) = plain_and_aa(&lf, front, None, settings);
    assert!(
        aa.visibility.is_some(),
        "layered footprints need the views' depth maps"
    );
    check(&lf, &aa, "layered, grid centre");
    let (_, aa) = plain_and_aa(&lf, tilted, None, settings);
    check(&lf, &aa, "layered, tilted plane");
    let (_, aa) = plain_and_aa(&lf, front, Some(DVec2::new(1.5, 2.25)), settings);
    check(&lf, &aa, "layered, virtual view");
    let (_, mut guarded) = plain_and_aa(&lf, front, None, settings);
    guarded.guard_px = tiltfield::refocus::antialias::ESTIMATED_DEPTH_GUARD_PX;
    check(&lf, &guarded, "layered, an estimated depth's guard");
    // The layers are not the sub-sampled footprints: the two models differ.
    let changed = models_differ(&lf, front, settings);
    assert!(changed > 500, "layered footprints changed {changed} pixels");
    let rig = layers_rig(size, RigKind::Converging { distance: 2.0 });
    let lf = render_light_field(&mut r, &rig, 2, false)
        .unwrap()
        .light_field;
    let (_, aa) = plain_and_aa(&lf, front, None, settings);
    check(&lf, &aa, "layered, converging rig");
    assert_raster_clean(&r);
}

/// Layered footprints added batch by batch (the viewer's progressive refinement) end where
/// one accumulation of every view does: a later batch that reaches a layer no pixel of a tile
/// held before starts that layer's sums there from zero, and the stages after the binning read
/// only the tiles some batch wrote.
#[test]
fn layered_batches_add_up_to_one_accumulation() {
    let mut r = rasterizer();
    let lf = render_light_field(&mut r, &layers_rig(64, RigKind::Parallel), 2, false)
        .unwrap()
        .light_field;
    let tilted = Plane::new(DVec3::new(0.0, 0.0, 2.2), DVec3::new(0.3, 0.0, -1.0)).unwrap();
    let settings = AntialiasSettings {
        layered: tiltfield::refocus::antialias::Layered::On,
        ..AntialiasSettings::default()
    };
    let (_, aa) = plain_and_aa(&lf, tilted, None, settings);
    let n = aa.plan.views.len();
    assert!(n >= 9, "{n} views: too few for three batches");
    let render = float_settings(Filter::Shader);
    let mut h = renderer(&lf);
    let whole = float(h.render_antialiased(&aa, &render).unwrap().0);
    let mut last = None;
    for (k, w) in [0, 1, n / 2, n].windows(2).enumerate() {
        let img = h
            .accumulate_antialiased(&aa, &render, w[0]..w[1], k == 0)
            .unwrap();
        last = Some(float(img));
    }
    let last = last.unwrap();
    assert!(last.is_finite(), "non-finite pixels");
    let d = diff(&last, &whole, None);
    assert!(
        d.max_levels <= 0.01,
        "batches against one accumulation: {d:?}"
    );
    // The first batch alone is not the whole: the test sees what the batches add.
    let first = float(h.accumulate_antialiased(&aa, &render, 0..1, true).unwrap());
    assert!(diff(&first, &whole, None).max_levels > 1.0);
    assert_no_validation_errors(&h);
    assert_raster_clean(&r);
}

/// How close the GPU's layered footprints come to their f64 model: measured 108.6-115.8 dB
/// (at most 0.007 levels) at 64 px; a wrong node, group or box costs tens of dB.
const LAYERED_MODEL_DB: f64 = 90.0;

/// On a rotated (converging) rig the footprint comes from the same homography
/// parametrisation, so anti-aliasing still approaches the lens there.
#[test]
fn antialiasing_on_a_rotated_rig_approaches_the_lens() {
    let mut r = rasterizer();
    let rig = layers_rig(SIZE, RigKind::Converging { distance: 2.0 });
    let lf = render_light_field(&mut r, &rig, 3, false)
        .unwrap()
        .light_field;
    let mut h = renderer(&lf);
    let [_, zm, _, _] = tiltfield::synth::scenes::LAYER_DEPTHS;
    let front = Plane::new(DVec3::new(0.0, 0.0, zm), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let (p, a) = against_the_lens(&mut r, &mut h, &lf, front, "converging rig");
    // Measured: plain 25.9 / 29.1 / 23.0 dB, anti-aliased 27.5 / 41.5 / 23.1 dB. (The
    // focused plane scores low for both against this truth on the converging rig; the plain
    // sum's resampling of the rotated views, not anti-aliasing, which leaves it unchanged.)
    assert!(a.out_of_focus >= p.out_of_focus + 10.0);
    assert!(a.overall >= p.overall + 1.0);
    assert!(a.focused >= p.focused - 0.5);
    assert_no_validation_errors(&h);
    assert_raster_clean(&r);
}

/// What the occlusion tests must add at the focused edges of
/// `occlusion_edges_keep_the_focused_background` (measured 40.8 against 27.8 dB without them).
const OCCLUSION_GAIN_DB: f64 = 8.0;

/// An occlusion edge: focused on the back wall, the pixels of the wall next to the nearer
/// layers come closer to the lens than the plain sum's (measured 40.4 vs 27.1 dB; 32.7 with
/// the occlusion decided per view): the sub-samples whose rays meet an occluder blur it
/// with the occluder's footprint, those that pass it keep the wall sharp (no footprint: it is
/// in focus), so the occluder is not smeared over the focused wall. Out of focus,
/// anti-aliasing wins by far (37.5 vs 25.8 dB). With the half-pixel guard an estimated depth
/// gets, the edges score 33.9 dB: the given map is trusted to the pixel for that.
#[test]
fn occlusion_edges_keep_the_focused_background() {
    let mut r = rasterizer();
    let lf = render_light_field(&mut r, &layers_rig(SIZE, RigKind::Parallel), 3, false)
        .unwrap()
        .light_field;
    let mut h = renderer(&lf);
    let [zb, _, _, _] = tiltfield::synth::scenes::LAYER_DEPTHS;
    let back = Plane::new(DVec3::new(0.0, 0.0, zb), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let (plan, aa) = plain_and_aa(&lf, back, None, sub_samples());
    let radius = RADIUS * lf.rig.unwrap().baseline;
    let (gt, _) = r
        .optical_ground_truth(
            &plan.reference_camera,
            &back,
            radius,
            GT_GRID,
            (SIZE, SIZE),
            3,
        )
        .unwrap();
    let truth = encoded_linear(&gt);
    let settings = float_settings(Filter::Hardware);
    let plain = encoded(&float(h.render(&plan, &settings).unwrap().0));
    let anti = encoded(&float(h.render_antialiased(&aa, &settings).unwrap().0));
    assert_eq!(
        aa.guard_px, 0.0,
        "the rendered map is the light field's own"
    );
    let mut guarded = aa.clone();
    guarded.guard_px = tiltfield::refocus::antialias::ESTIMATED_DEPTH_GUARD_PX;
    let guarded = encoded(&float(h.render_antialiased(&guarded, &settings).unwrap().0));
    // Without the occlusion tests every sub-sample takes its pixel's own residual: the
    // focused wall's sub-samples stay on the wall where an occluder's blur should cover it.
    let open = AntialiasSettings {
        occlusion: false,
        ..sub_samples()
    };
    let (_, open) = plain_and_aa(&lf, back, None, open);
    let open = encoded(&float(h.render_antialiased(&open, &settings).unwrap().0));
    // The default on this given depth: layered footprints, whose compositing keeps the
    // focused wall's own colour wherever the lens sees past the occluder's blur.
    let (_, layered) = plain_and_aa(&lf, back, None, AntialiasSettings::default());
    assert_eq!(layered.settings.layered, Layered::On);
    let layered = encoded(&float(h.render_antialiased(&layered, &settings).unwrap().0));
    let res = residual_px(&lf, &plan);
    // Focused wall pixels within 6 px of a nearer layer (an occlusion edge), and the rest.
    let focused = mask_where(&res, SIZE, 4, 0, |d| d.abs() <= 0.5);
    let clear = mask_where(&res, SIZE, 4, 6, |d| d.abs() <= 0.5);
    let edge: Vec<bool> = focused.iter().zip(&clear).map(|(f, c)| *f && !c).collect();
    let out: Vec<bool> = mask_where(&res, SIZE, 4, 0, |d| d.abs() > 0.5);
    let (pe, ae) = (
        psnr_rgb(&plain, &truth, &edge),
        psnr_rgb(&anti, &truth, &edge),
    );
    let ge = psnr_rgb(&guarded, &truth, &edge);
    let oe = psnr_rgb(&open, &truth, &edge);
    let le = psnr_rgb(&layered, &truth, &edge);
    eprintln!("at the occlusion edges, layered footprints (the default here) {le:.1} dB");
    assert!(le >= pe + 10.0, "layered {le} vs plain {pe}");
    let (po, ao) = (
        psnr_rgb(&plain, &truth, &out),
        psnr_rgb(&anti, &truth, &out),
    );
    eprintln!(
        "focused on the wall: at occlusion edges ({} px) plain {pe:.1} dB, anti-aliased \
         {ae:.1} dB ({ge:.1} dB with an estimate's guard, {oe:.1} dB without the occlusion \
         tests); out of focus plain {po:.1} dB, anti-aliased {ao:.1} dB",
        edge.iter().filter(|&&e| e).count()
    );
    assert!(ae >= pe + 10.0, "{ae} vs {pe}");
    assert!(ge >= pe + 5.0 && ae >= ge + 4.0, "{ae} and {ge} vs {pe}");
    assert!(
        ae >= oe + OCCLUSION_GAIN_DB,
        "{ae} vs {oe} without the tests"
    );
    assert!(ao >= po + 6.0, "{ao} vs {po}");
    assert_no_validation_errors(&h);
    assert_raster_clean(&r);
}

/// Bad depth input: NaN depths are pixels without depth (the plain sum there, finite), a
/// depth map of the wrong size and classic shift-and-sum on a rotated grid are errors that say
/// why.
#[test]
fn bad_depth_gives_a_clear_error_or_the_plain_sum_never_nan() {
    let mut lf = builtin("planes");
    let (index, map) = lf
        .depth
        .iter()
        .find(|(_, d)| d.kind == DepthKind::Depth)
        .cloned()
        .unwrap();
    let plane = Plane::new(DVec3::new(0.0, 0.0, 3.0), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let req = RefocusRequest {
        focus: FocusSpec::Plane(plane),
        aperture: disk(),
        reference: None,
    };
    let plan = refocus::plan(&lf, &req, &[]).unwrap();
    // Every depth NaN: no footprint anywhere, so the image is the area-weighted plain sum.
    let mut nan = map.clone();
    nan.values.iter_mut().for_each(|v| *v = f32::NAN);
    let depth = lf.view_depth_of(index, &nan).unwrap();
    let aa = plan_antialias(
        &lf,
        &plan,
        disk(),
        &[],
        &depth,
        AntialiasSettings::default(),
    )
    .unwrap();
    assert_eq!(aa.depth.unknown, (lf.width * lf.height) as usize);
    let mut h = renderer(&lf);
    let (img, _) = h
        .render_antialiased(&aa, &float_settings(Filter::Shader))
        .unwrap();
    let img = float(img);
    assert!(img.is_finite() && img.uncovered() == 0);
    let model = cpu::render_antialiased(&lf, &aa, Averaging::Linear, lf.width, lf.height);
    let no_footprint = cpu::render_with(
        &lf,
        &aa.plan,
        Averaging::Linear,
        lf.width,
        lf.height,
        cpu::Kernel::Bilinear,
    );
    assert!(diff(&model, &no_footprint, None).max_levels < 1e-9);
    assert!(diff(&img, &model, None).max_levels <= 1.0);
    assert_no_validation_errors(&h);

    // A depth map of another size.
    let mut small = map.clone();
    small.width /= 2;
    small.values.truncate((small.width * small.height) as usize);
    lf.depth = vec![(index, small.clone())];
    let e = match lf.view_depth_of(index, &small) {
        Err(e) => e.to_string(),
        Ok(d) => plan_antialias(&lf, &plan, disk(), &[], &d, AntialiasSettings::default())
            .unwrap_err()
            .to_string(),
    };
    assert!(e.contains("32") && e.contains("64"), "{e}");

    // Classic shift-and-sum on cameras that are not a parallel grid (one turned a degree)
    // has no plane to move along (on a parallel grid it is that grid's frontoparallel plane:
    // `a_grid_folder_focused_by_disparity_antialiases_on_its_estimate`).
    let mut no_rig = builtin("planes");
    no_rig.rig = None;
    let c = no_rig.views[0].camera;
    no_rig.views[0].camera = tiltfield::geometry::camera::Camera::from_centre(
        c.k,
        glam::DMat3::from_rotation_y(1f64.to_radians()) * c.r,
        c.centre(),
    );
    let classic = refocus::plan(
        &no_rig,
        &RefocusRequest {
            focus: FocusSpec::Disparity(1.0),
            aperture: disk(),
            reference: None,
        },
        &[],
    )
    .unwrap();
    let depth = no_rig.view_depth_of(index, &map).unwrap();
    let e = plan_antialias(
        &no_rig,
        &classic,
        disk(),
        &[],
        &depth,
        AntialiasSettings::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("classic shift-and-sum") && e.contains("not a parallel grid"),
        "{e}"
    );
    // Sample caps outside 1..=16.
    let e = plan_antialias(
        &lf,
        &plan,
        disk(),
        &[],
        &lf.view_depth_of(index, &map).unwrap(),
        AntialiasSettings {
            max_samples: 0,
            ..AntialiasSettings::default()
        },
    );
    assert!(e.is_err());
}

/// `--antialias off` is the previous release's image, bit for bit: the files in
/// tests/data/antialias_off were written by the commit before anti-aliasing existed, with the
/// same arguments (lavapipe; a driver change would need them rewritten).
#[test]
fn antialias_off_reproduces_the_previous_output_bit_for_bit() {
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/antialias_off");
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &[&str]); 3] = [
        ("planes_d05.png", &["builtin:planes", "--disparity", "0.5"]),
        (
            "tilted_virtual.png",
            &[
                "builtin:tilted",
                "--focus",
                "3",
                "--tilt",
                "20",
                "--view",
                "1.5,2.25",
                "--aperture-radius",
                "1.6",
            ],
        ),
        (
            "planes_tilt.exr",
            &[
                "builtin:planes",
                "--focus",
                "2.5",
                "--tilt",
                "-10",
                "--aperture",
                "square",
                "--aperture-radius",
                "1",
            ],
        ),
    ];
    for (file, args) in cases {
        let out = dir.path().join(file);
        let mut all = vec!["render"];
        all.extend_from_slice(args);
        all.extend_from_slice(&["--antialias", "off", "-o", out.to_str().unwrap()]);
        let o = tiltfield(&all);
        assert!(o.status.success(), "{}", stderr(&o));
        let want = std::fs::read(format!("{data}/{file}")).unwrap();
        let got = std::fs::read(&out).unwrap();
        assert!(
            want == got,
            "{file} differs from the previous release's output"
        );
    }
}

/// The default follows the light field's own depth; `--json` says whether anti-aliasing ran
/// and with which depth; on an image, the anti-aliased render differs from the plain one.
#[test]
fn render_reports_antialiasing_and_its_depth() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str], name: &str| {
        let out = dir.path().join(name);
        let mut args = vec!["render", "builtin:planes", "--disparity", "0.5", "--json"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", out.to_str().unwrap()]);
        let o = tiltfield(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        (json_of(&o), std::fs::read(out).unwrap())
    };
    let (on, on_png) = run(&[], "on.png");
    assert_eq!(on["antialias"]["used"], true, "{on}");
    assert_eq!(on["antialias"]["depth_origin"]["origin"], "given", "{on}");
    assert_eq!(on["antialias"]["max_samples"], 4);
    let (off, off_png) = run(&["--antialias", "off"], "off.png");
    assert_eq!(off["antialias"]["used"], false, "{off}");
    assert_ne!(on_png, off_png);
    let (eight, _) = run(
        &["--antialias", "on", "--antialias-samples", "8"],
        "eight.png",
    );
    assert_eq!(eight["antialias"]["max_samples"], 8);
    // The shipped depth takes layered footprints, which test no sample for occlusion; the
    // sub-samples do unless told not to.
    assert_eq!(on["antialias"]["layered"], true, "{on}");
    assert_eq!(on["antialias"]["occlusion"], false, "{on}");
    let (sub, _) = run(&["--antialias-layered", "off"], "sub.png");
    assert_eq!(sub["antialias"]["layered"], false, "{sub}");
    assert_eq!(sub["antialias"]["occlusion"], true, "{sub}");
    let (open, _) = run(
        &["--antialias-layered", "off", "--antialias-occlusion", "off"],
        "open.png",
    );
    assert_eq!(open["antialias"]["occlusion"], false, "{open}");
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "0.5",
            "--antialias-samples",
            "17",
            "-o",
            dir.path().join("x.png").to_str().unwrap(),
        ],
        &["1 to 16"],
    );
}

/// On by default only where it can be: a light field with depth but no rig focused by
/// `--disparity` (classic shift-and-sum) renders the plain sum with a warning; asked for
/// explicitly, it is an error that says why.
#[test]
fn default_antialiasing_falls_back_where_it_cannot_apply() {
    let dir = tempfile::tempdir().unwrap();
    let lf = dir.path().join("conv");
    let lf = lf.to_str().unwrap();
    let o = tiltfield(&[
        "synth",
        "builtin:planes",
        "--rig",
        "converging",
        "--layout",
        "manifest",
        "--grid",
        "3x3",
        "--size",
        "32x32",
        "-o",
        lf,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("c.png");
    let out = out.to_str().unwrap();
    let o = tiltfield(&["render", lf, "--disparity", "0", "-o", out, "--json"]);
    assert_eq!(json_of(&o)["antialias"]["used"], false);
    assert!(
        stderr(&o).contains("classic shift-and-sum"),
        "{}",
        stderr(&o)
    );
    fails_with(
        &[
            "render",
            lf,
            "--disparity",
            "0",
            "--antialias",
            "on",
            "-o",
            out,
        ],
        &["classic shift-and-sum", "--antialias off"],
    );
    // A focus with a plane anti-aliases on the same light field (a rotated rig).
    let o = tiltfield(&["render", lf, "--focus", "3", "-o", out, "--json"]);
    assert_eq!(json_of(&o)["antialias"]["used"], true);
}

/// The depth estimate anti-aliasing falls back on, on a converging rig: its automatic range is
/// centred where the cameras look (2.5 m) rather than at infinity, so the nearest card
/// (1.03 m, beyond the 1.6 m that a range anchored at infinity reached at this size) gets its
/// own depth instead of the wall's.
#[test]
fn depth_estimated_on_a_converging_rig_finds_the_nearest_card() {
    let mut r = rasterizer();
    let rig = layers_rig(96, RigKind::Converging { distance: 2.5 });
    let mut lf = render_light_field(&mut r, &rig, 2, false)
        .unwrap()
        .light_field;
    let truth = lf.view_depth().unwrap();
    lf.depth.clear();
    tiltfield::jobs::depth::ensure_depth_in(
        r.context(),
        &mut lf,
        &tiltfield::depth::DepthOptions::default(),
        &indicatif::ProgressBar::hidden(),
        None,
    )
    .unwrap();
    let est = lf.view_depth().unwrap();
    let near = tiltfield::synth::scenes::LAYER_DEPTHS[3];
    let (mut card, mut found) = (0usize, 0usize);
    for y in 0..truth.height {
        for x in 0..truth.width {
            if truth
                .depth(x, y)
                .is_some_and(|z| (z - near).abs() < 0.01 * near)
            {
                card += 1;
                if est
                    .depth(x, y)
                    .is_some_and(|z| (z - near).abs() < 0.05 * near)
                {
                    found += 1;
                }
            }
        }
    }
    assert!(card > 200, "the nearest card covers {card} pixels");
    // Measured: 378 of 475 pixels; 0 with the range anchored at infinity, which stopped
    // short of the card.
    assert!(
        found as f64 >= 0.6 * card as f64,
        "{found} of the nearest card's {card} pixels within 5 % of its depth"
    );
    assert_raster_clean(&r);
}

/// A grid folder (no calibration) focused by `--disparity`, its natural focus, anti-aliases
/// on its estimated depth: the classic disparity becomes the frontoparallel plane of its
/// nominal cameras that shifts every view alike. The same views as an HCI folder, with the
/// same disparity and their exact depth, give the reference: the grid folder's anti-aliased
/// image must come far closer to it than its plain sum does. A disparity beyond the nominal
/// cameras' infinity is refused naming it.
#[test]
fn a_grid_folder_focused_by_disparity_antialiases_on_its_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let hci = dir.path().join("hci");
    let o = tiltfield(&[
        "synth",
        "builtin:layers",
        "--grid",
        "5x5",
        "--size",
        "64x64",
        "-o",
        hci.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let gf = dir.path().join("grid");
    hci_as_grid_folder(&hci, &gf, 5, 5);
    let png = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    // The HCI disparity −D is the classic D of the same views (and 0 is 0).
    let render = |lf: &std::path::Path, aa: &str, out: &str| {
        let o = tiltfield(&[
            "render",
            lf.to_str().unwrap(),
            "--disparity",
            "0",
            "--aperture-radius",
            "2",
            "--antialias",
            aa,
            "-o",
            out,
            "--json",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let j = json_of(&o);
        assert_eq!(j["antialias"]["used"], aa == "on", "{j}");
        view_rgb(&image::open(out).unwrap().to_rgba8())
    };
    let reference = render(&hci, "on", &png("hci.png"));
    let anti = render(&gf, "on", &png("grid_aa.png"));
    let plain = render(&gf, "off", &png("grid_plain.png"));
    let all = vec![true; reference.len()];
    let (a, p) = (
        psnr_rgb(&anti, &reference, &all),
        psnr_rgb(&plain, &reference, &all),
    );
    // Measured: anti-aliased 43.1 dB, plain 34.5 dB.
    eprintln!("grid folder vs HCI anti-aliased: anti-aliased {a:.1} dB, plain {p:.1} dB");
    assert!(a >= p + 5.0, "anti-aliased {a:.1} dB, plain {p:.1} dB");
    fails_with(
        &[
            "render",
            gf.to_str().unwrap(),
            "--disparity",
            "40",
            "--antialias",
            "on",
            "-o",
            &png("far.png"),
        ],
        &[
            "--disparity 40 lies at or beyond the cameras' infinity",
            "--antialias off",
        ],
    );
}

/// A session's requests (the Python module's) share the views' depth maps while only the plane
/// moves, as a focal stack does, and each image equals that of a session without the previous
/// plan; a change of the aperture's views makes new maps.
#[test]
fn a_session_keeps_the_views_maps_while_only_the_plane_moves() {
    use tiltfield::geometry::aperture::Aperture;
    use tiltfield::jobs::render::{RenderOptions, Session};
    use tiltfield::refocus::options::FocusOptions;
    let lf = builtin("planes");
    let ctx = std::sync::Arc::new(
        tiltfield::gpu::GpuContext::new(&gpu_options())
            .unwrap_or_else(|e| panic!("cannot create a validated Vulkan context: {e}")),
    );
    let at = |d: f64, radius: Option<f64>| RenderOptions {
        focus: FocusOptions {
            disparity: vec![d],
            ..FocusOptions::default()
        },
        aperture: Aperture {
            radius,
            ..Aperture::default()
        },
        ..RenderOptions::default()
    };
    let hidden = indicatif::ProgressBar::hidden();
    let mut session = Session::new(std::sync::Arc::clone(&ctx), lf.clone());
    let maps = |p: &tiltfield::jobs::render::Prepared| {
        std::sync::Arc::clone(p.antialias.as_ref().unwrap().visibility.as_ref().unwrap())
    };
    let (_, _, first) = session.render(&at(0.5, None), &hidden).unwrap();
    let (second, _, p2) = session.render(&at(-0.5, None), &hidden).unwrap();
    assert!(
        std::sync::Arc::ptr_eq(&maps(&first), &maps(&p2)),
        "maps reused"
    );
    let mut fresh = Session::new(std::sync::Arc::clone(&ctx), lf);
    let (alone, _, p3) = fresh.render(&at(-0.5, None), &hidden).unwrap();
    assert!(!std::sync::Arc::ptr_eq(&maps(&p2), &maps(&p3)));
    let bytes = |g: &GpuImage| match g {
        GpuImage::Srgb8(i) => i.as_raw().clone(),
        GpuImage::Float(_) => panic!("an sRGB render"),
    };
    assert_eq!(
        bytes(&second),
        bytes(&alone),
        "the same image with and without reuse"
    );
    let (_, _, p4) = session.render(&at(-0.5, Some(1.0)), &hidden).unwrap();
    assert!(
        !std::sync::Arc::ptr_eq(&maps(&p2), &maps(&p4)),
        "other views, other maps"
    );
    assert_eq!(
        ctx.validation().errors(),
        0,
        "{:#?}",
        ctx.validation().messages()
    );
}
