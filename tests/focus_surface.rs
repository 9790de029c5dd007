//! Focus surfaces beyond one plane (docs/conventions.md §12): the GPU held to the f64 model of
//! the per-pixel surface, and the surfaces against the optical ground truth of a lens focused
//! on them. Every GPU test runs with the validation layer and asserts zero errors.
//!
//! The scene is synth's `layers`: four textured frontoparallel planes at −3, 0, +2 and +6 px of
//! disparity per grid step (5×5 views), its depth map given. A lens focused on a surface
//! images a scene point on the surface sharply; where the layers are frontoparallel that is
//! the lens focused on the point's own layer, so the truth of "inside the surface" pixels is
//! the truth of their layer's plane.

mod common;

use common::*;
use glam::{DVec2, DVec3};
use tiltfield::geometry::aperture::{Aperture, ApertureShape};
use tiltfield::geometry::plane::Plane;
use tiltfield::jobs::raster::{render_light_field, Rasterizer};
use tiltfield::jobs::refocus::{GpuImage, RenderSettings};
use tiltfield::lightfield::{GridSize, LightField};
use tiltfield::refocus::antialias::{plan_antialias, AntialiasSettings};
use tiltfield::refocus::settings::{Filter, OutputFormat, Strategy};
use tiltfield::refocus::surface::{surface_for, FocusSurface};
use tiltfield::refocus::RefocusRequest;
use tiltfield::refocus::{self, cpu, Averaging, FocusSpec, RefocusImage, RefocusPlan};
use tiltfield::synth::scenes::LAYER_DEPTHS;
use tiltfield::synth::{synth_scene, RigKind, SynthRig};

const RADIUS: f64 = 2.0;

fn disk() -> Aperture {
    Aperture {
        shape: ApertureShape::Disk,
        radius: Some(RADIUS),
    }
}

fn layers_rig(size: u32) -> SynthRig {
    let s = synth_scene("layers").unwrap();
    SynthRig {
        grid: GridSize { cols: 5, rows: 5 },
        width: size,
        height: size,
        focal_px: s.focal_per_width * size as f64,
        baseline: s.baseline,
        focus_distance: s.focus_distance,
        kind: RigKind::Parallel,
    }
}

fn rasterizer() -> Rasterizer {
    let s = synth_scene("layers").unwrap();
    Rasterizer::new(&s.mesh(), &gpu_options())
        .unwrap_or_else(|e| panic!("cannot create a validated rasterizer: {e}"))
}

fn frontal(z: f64) -> Plane {
    Plane::new(DVec3::new(0.0, 0.0, z), DVec3::new(0.0, 0.0, -1.0)).unwrap()
}

/// Through the 2 m panel (left) and the 1.52 m card (lower right), turned about y (the tilted
/// plane of tests/antialias.rs).
fn tilted() -> Plane {
    let [_, zm, zn, _] = LAYER_DEPTHS;
    let p1 = DVec3::new(-0.5, 0.0, zm);
    let p2 = DVec3::new(0.22 * zn, 0.24 * zn, zn);
    let normal = (p2 - p1).cross(DVec3::Y).normalize();
    Plane::new(p1, if normal.z > 0.0 { -normal } else { normal }).unwrap()
}

fn plan_of(lf: &LightField, plane: Plane, reference: Option<DVec2>) -> RefocusPlan {
    let req = RefocusRequest {
        focus: FocusSpec::Plane(plane),
        aperture: disk(),
        reference,
    };
    refocus::plan(lf, &req, &[]).unwrap()
}

fn float_settings(filter: Filter, strategy: Strategy) -> RenderSettings {
    RenderSettings {
        output: OutputFormat::Float,
        filter,
        strategy,
        ..RenderSettings::default()
    }
}

fn float(img: GpuImage) -> RefocusImage {
    match img {
        GpuImage::Float(f) => f,
        GpuImage::Srgb8(_) => panic!("asked for float output"),
    }
}

/// Holds the GPU's surface refocus to the f64 model [`cpu::render_surface`] with the shader's
/// exact bilinear filter, leaving out the pixels where f32 may choose the other plane or mask.
#[test]
fn gpu_focus_surfaces_match_the_f64_model() {
    let size = 64;
    let mut r = rasterizer();
    let lf = render_light_field(&mut r, &layers_rig(size), 2, false)
        .unwrap()
        .light_field;
    let [zb, zm, zn, _] = LAYER_DEPTHS;
    let mut h = renderer(&lf);
    let cases: Vec<(&str, Plane, FocusSurface, Option<DVec2>, Strategy)> = vec![
        (
            "two planes",
            frontal(zb),
            FocusSurface::Planes(vec![frontal(zb), frontal(zm)]),
            None,
            Strategy::Fragment,
        ),
        (
            "three planes, compute",
            frontal(zm),
            FocusSurface::Planes(vec![frontal(zm), frontal(zb), frontal(zn)]),
            None,
            Strategy::Compute,
        ),
        (
            "frontoparallel slab",
            frontal(0.5 * (zm + zn)),
            FocusSurface::Slab { half_width: 0.3 },
            None,
            Strategy::Fragment,
        ),
        (
            "tilted slab, virtual view",
            tilted(),
            FocusSurface::Slab { half_width: 0.15 },
            Some(DVec2::new(1.5, 2.5)),
            Strategy::Fragment,
        ),
        (
            "all in focus, virtual view",
            frontal(zm),
            FocusSurface::AllInFocus,
            Some(DVec2::new(2.5, 1.25)),
            Strategy::Compute,
        ),
    ];
    for (label, plane, surface, reference, strategy) in cases {
        let plan = plan_of(&lf, plane, reference);
        let sp = surface_for(&lf, &plan, &surface, None).unwrap();
        let (img, _) = h
            .render_surface(&plan, None, &sp, &float_settings(Filter::Shader, strategy))
            .unwrap();
        let gpu = float(img);
        assert!(gpu.is_finite(), "{label}: non-finite pixels");
        let model = cpu::render_surface(&lf, &plan, &sp, None, Averaging::Linear, (size, size));
        let ambiguous = cpu::ambiguous_surface(&lf, &plan, &sp, (size, size), 1e-4);
        let keep: Vec<bool> = ambiguous.iter().map(|a| !a).collect();
        let d = diff(&gpu, &model, Some(&keep));
        let left_out = ambiguous.iter().filter(|&&a| a).count();
        // The surface must change the image: against the plane alone it differs.
        let single = cpu::render(&lf, &plan, Averaging::Linear);
        let vs_plane = diff(&model, &single, None);
        eprintln!(
            "{label}: GPU vs f64 model {:.1} dB, max {:.3} levels ({left_out} ambiguous); \
             model vs the plane alone {:.1} dB",
            d.psnr_db, d.max_levels, vs_plane.psnr_db
        );
        assert!(
            left_out < (size * size / 20) as usize,
            "{label}: {left_out}"
        );
        assert!(d.psnr_db >= 60.0 && d.max_levels <= 1.0, "{label}: {d:?}");
        assert_eq!(d.coverage_mismatch, 0, "{label}");
        assert!(vs_plane.psnr_db < 40.0, "{label}: {vs_plane:?}");
    }

    // Another output size (pixel centres map to fractional reference positions) through
    // batched draws: the surface is evaluated at the output pixel's reference position.
    let plan = plan_of(&lf, frontal(zm), None);
    let surface = FocusSurface::Planes(vec![frontal(zm), frontal(zb), frontal(zn)]);
    let sp = surface_for(&lf, &plan, &surface, None).unwrap();
    let (w, hgt) = (96, 80);
    let settings = RenderSettings {
        size: Some((w, hgt)),
        ..float_settings(Filter::Shader, Strategy::Batched { views_per_draw: 4 })
    };
    let gpu = float(h.render_surface(&plan, None, &sp, &settings).unwrap().0);
    let model = cpu::render_surface(&lf, &plan, &sp, None, Averaging::Linear, (w, hgt));
    let ambiguous = cpu::ambiguous_surface(&lf, &plan, &sp, (w, hgt), 1e-4);
    let keep: Vec<bool> = ambiguous.iter().map(|a| !a).collect();
    let d = diff(&gpu, &model, Some(&keep));
    eprintln!(
        "three planes at 96×80, batched: GPU vs f64 model {:.1} dB, max {:.3} levels",
        d.psnr_db, d.max_levels
    );
    assert!(d.psnr_db >= 60.0 && d.max_levels <= 1.0, "{d:?}");
    assert!(ambiguous.iter().filter(|&&a| a).count() < (w * hgt / 20) as usize);

    // With anti-aliasing the surface's s drives the footprints too (one depth bound for both).
    let plan = plan_of(&lf, frontal(zb), None);
    let depth = lf.view_depth().unwrap();
    let aa = plan_antialias(
        &lf,
        &plan,
        disk(),
        &[],
        &depth,
        // A focus surface takes the sub-samples (`for_output`: not one plane).
        AntialiasSettings::default().for_output(false),
    )
    .unwrap();
    let surface = FocusSurface::Planes(vec![frontal(zb), frontal(zm)]);
    let sp = surface_for(&lf, &plan, &surface, Some(&aa)).unwrap();
    let (img, _) = h
        .render_surface(
            &plan,
            Some(&aa),
            &sp,
            &float_settings(Filter::Shader, Strategy::Fragment),
        )
        .unwrap();
    let gpu = float(img);
    let model = cpu::render_surface(&lf, &plan, &sp, Some(&aa), Averaging::Linear, (size, size));
    let d = diff(&gpu, &model, None);
    eprintln!(
        "two planes, anti-aliased: GPU vs f64 model {:.1} dB, max {:.3} levels (all pixels)",
        d.psnr_db, d.max_levels
    );
    assert!(d.psnr_db >= 45.0, "{d:?}");
    // A surface built on another depth than anti-aliasing's is refused.
    let other = surface_for(
        &lf,
        &plan_of(&lf, frontal(zb), Some(DVec2::new(1.0, 1.0))),
        &surface,
        None,
    )
    .unwrap();
    let err = h
        .render_surface(
            &plan,
            Some(&aa),
            &other,
            &float_settings(Filter::Shader, Strategy::Fragment),
        )
        .unwrap_err();
    assert!(err.to_string().contains("different scene depths"), "{err}");
    assert_no_validation_errors(&h);
    let log = r.context().validation();
    assert_eq!(log.errors(), 0, "validation errors: {:#?}", log.messages());
}

fn encoded_linear(px: &[[f32; 4]]) -> Vec<[f64; 3]> {
    px.iter()
        .map(|p| std::array::from_fn(|k| tiltfield::color::linear_to_srgb(p[k] as f64)))
        .collect()
}

/// Index (0 back … 3 front) of the layer each reference pixel sees, from the surface's scene
/// depth (exact for the centre view, reprojected for a virtual one); `None` where unknown.
fn layer_map(sigma: &[f32]) -> Vec<Option<usize>> {
    sigma
        .iter()
        .map(|&s| {
            (s >= 0.0).then(|| {
                (0..4)
                    .min_by(|&a, &b| {
                        let d = |k: usize| (1.0 / LAYER_DEPTHS[k] - s as f64).abs();
                        d(a).total_cmp(&d(b))
                    })
                    .unwrap()
            })
        })
        .collect()
}

/// Pixels at least 4 px from the border that see a layer in `keep` and no nearer layer within
/// the reach of that layer's blur at the aperture's rim (R·Δd px, plus one for the bilinear
/// footprint): there a lens focused on the pixel's layer sees that layer alone.
fn inside_mask(
    layers: &[Option<usize>],
    size: u32,
    keep: impl Fn(usize, usize) -> bool,
) -> Vec<bool> {
    const DISPARITY: [f64; 4] = [-3.0, 0.0, 2.0, 6.0];
    let n = size as i64;
    (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            if x < 4 || y < 4 || x >= n - 4 || y >= n - 4 {
                return false;
            }
            let Some(l) = layers[i as usize] else {
                return false;
            };
            if !keep(l, i as usize) {
                return false;
            }
            let reach = (RADIUS * (DISPARITY[3] - DISPARITY[l])).ceil() as i64 + 1;
            (-reach..=reach).all(|dy| {
                (-reach..=reach).all(|dx| {
                    let (u, v) = ((x + dx).clamp(0, n - 1), (y + dy).clamp(0, n - 1));
                    layers[(v * n + u) as usize].map_or(true, |m| m <= l)
                })
            })
        })
        .collect()
}

/// The refocus surfaces against the lens: inside each surface they are as sharp as a
/// single-plane refocus on the pixel's own plane, where a single-plane render of the surface's
/// first plane is clearly worse; for two planes, a frontoparallel and a tilted slab, all in
/// focus, and two planes from a virtual viewpoint.
#[test]
fn focus_surfaces_match_the_lens_inside_the_surface() {
    const SIZE: u32 = 128;
    // Pinholes per side of the truth's aperture grid: inside the surface every pinhole sees
    // the same scene point, so the truth there does not need the dense grid of blurred parts.
    const GT_GRID: u32 = 33;
    let mut r = rasterizer();
    let lf = render_light_field(&mut r, &layers_rig(SIZE), 3, false)
        .unwrap()
        .light_field;
    let mut h = renderer(&lf);
    let [zb, zm, zn, _] = LAYER_DEPTHS;
    let radius = RADIUS * synth_scene("layers").unwrap().baseline;
    let settings = float_settings(Filter::Hardware, Strategy::Fragment);
    let depth = lf.view_depth().unwrap();

    struct Case {
        label: &'static str,
        plane: Plane,
        surface: FocusSurface,
        reference: Option<DVec2>,
        /// Whether the scene point (world) seen on `layer` lies inside the surface.
        inside: Box<dyn Fn(usize, DVec3) -> bool>,
        /// Measured minus a margin (dB): surface inside; single plane worse by at least.
        min_db: f64,
        min_gain: f64,
    }
    let w_tilt = 0.12;
    let tilt = tilted();
    let cases = vec![
        Case {
            label: "two planes (back wall, FOCUS panel)",
            plane: frontal(zb),
            surface: FocusSurface::Planes(vec![frontal(zb), frontal(zm)]),
            reference: None,
            inside: Box::new(|l, _| l <= 1),
            // Measured 57.7 dB (the issue asks 55), the first plane alone 13.9 dB.
            min_db: 56.5,
            min_gain: 20.0,
        },
        Case {
            label: "frontoparallel slab (panel and card)",
            plane: frontal(0.5 * (zm + zn)),
            surface: FocusSurface::Slab { half_width: 0.3 },
            reference: None,
            inside: Box::new(|l, _| l == 1 || l == 2),
            // Measured 56.1 dB, exactly the single-plane refocus on each pixel's own layer.
            // The 60 dB lies above the 8-bit ceiling (the lens's image itself stored
            // in 8 bits scores 59.6 dB on these pixels): views stored in 8 bits cannot reach
            // it against the lens's float image. The slab's middle plane alone: 16.2 dB.
            min_db: 55.0,
            min_gain: 20.0,
        },
        Case {
            label: "tilted slab",
            plane: tilt,
            surface: FocusSurface::Slab { half_width: w_tilt },
            reference: None,
            inside: Box::new(move |_, p| tilt.signed_distance(p).abs() <= 0.9 * w_tilt),
            // Measured 57.8 dB (the issue asks 50), the tilted plane alone 23.0 dB.
            min_db: 56.5,
            min_gain: 20.0,
        },
        Case {
            label: "all in focus",
            plane: frontal(zm),
            surface: FocusSurface::AllInFocus,
            reference: None,
            inside: Box::new(|_, _| true),
            // Measured 55.4 dB (the issue asks 55), the panel's plane alone 15.8 dB.
            min_db: 54.5,
            min_gain: 20.0,
        },
        Case {
            label: "two planes, virtual view (1.5, 2.5)",
            plane: frontal(zb),
            surface: FocusSurface::Planes(vec![frontal(zb), frontal(zm)]),
            reference: Some(DVec2::new(1.5, 2.5)),
            inside: Box::new(|l, _| l <= 1),
            // Measured 35.9 dB, again exactly the single-plane refocus on each pixel's layer
            // from this viewpoint (35.9 dB): between the cameras every view's shift is
            // fractional and bilinear resampling softens the fine texture; the surface adds
            // nothing to that. The first plane alone: 13.1 dB.
            min_db: 34.5,
            min_gain: 20.0,
        },
    ];
    let mut truths: Vec<(Option<DVec2>, usize, Vec<[f64; 3]>)> = Vec::new();
    for c in &cases {
        let plan = plan_of(&lf, c.plane, c.reference);
        let aa = plan_antialias(
            &lf,
            &plan,
            disk(),
            &[],
            &depth,
            AntialiasSettings::default().for_output(false),
        )
        .unwrap();
        let sp = surface_for(&lf, &plan, &c.surface, Some(&aa)).unwrap();
        let sigma = &sp.depth.as_ref().unwrap().inverse_depth;
        let layers = layer_map(sigma);
        let cam = plan.reference_camera;
        let kinv = cam.k.inverse();
        let point = |i: usize| {
            let x = DVec3::new((i as u32 % SIZE) as f64, (i as u32 / SIZE) as f64, 1.0);
            let xc = kinv * x / sigma[i] as f64;
            cam.r.transpose() * (xc - cam.t)
        };
        let mask = inside_mask(&layers, SIZE, |l, i| (c.inside)(l, point(i)));
        // The lens focused on each pixel's own layer.
        let mut truth = vec![[0.0; 3]; (SIZE * SIZE) as usize];
        for (l, &z) in LAYER_DEPTHS.iter().enumerate() {
            if !(0..truth.len()).any(|i| mask[i] && layers[i] == Some(l)) {
                continue;
            }
            if !truths.iter().any(|(r, k, _)| *r == c.reference && *k == l) {
                let (gt, _) = r
                    .optical_ground_truth(&cam, &frontal(z), radius, GT_GRID, (SIZE, SIZE), 3)
                    .unwrap();
                truths.push((c.reference, l, encoded_linear(&gt)));
            }
            let gt = &truths
                .iter()
                .find(|(r, k, _)| *r == c.reference && *k == l)
                .unwrap()
                .2;
            for i in 0..truth.len() {
                if layers[i] == Some(l) {
                    truth[i] = gt[i];
                }
            }
        }
        let (plain, _) = h.render_surface(&plan, None, &sp, &settings).unwrap();
        let (anti, _) = h.render_surface(&plan, Some(&aa), &sp, &settings).unwrap();
        let (single, _) = h.render(&plan, &settings).unwrap();
        let score = |img: GpuImage| psnr_rgb(&encoded(&float(img)), &truth, &mask);
        let (p, a, s) = (score(plain), score(anti), score(single));
        // Single-plane refocus on each pixel's own layer, over the same pixels: the
        // sharpness the surface must match.
        let mut own = vec![[0.0; 3]; truth.len()];
        for (l, &z) in LAYER_DEPTHS.iter().enumerate() {
            if !(0..truth.len()).any(|i| mask[i] && layers[i] == Some(l)) {
                continue;
            }
            let lp = plan_of(&lf, frontal(z), c.reference);
            let img = encoded(&float(h.render(&lp, &settings).unwrap().0));
            for i in 0..truth.len() {
                if layers[i] == Some(l) {
                    own[i] = img[i];
                }
            }
        }
        let o = psnr_rgb(&own, &truth, &mask);
        // The ceiling an 8-bit light field allows: the truth itself stored in 8 bits.
        let stored: Vec<[f64; 3]> = truth
            .iter()
            .map(|p| p.map(|v| (v * 255.0).round() / 255.0))
            .collect();
        let ceiling = psnr_rgb(&stored, &truth, &mask);
        eprintln!(
            "{}: inside the surface ({} px) surface {p:.1} dB, anti-aliased {a:.1} dB; \
             single plane on each pixel's layer {o:.1} dB; the surface's first plane alone \
             {s:.1} dB; the truth stored in 8 bits {ceiling:.1} dB",
            c.label,
            mask.iter().filter(|&&m| m).count(),
        );
        assert!(mask.iter().filter(|&&m| m).count() > 300, "{}", c.label);
        assert!(p >= c.min_db && a >= c.min_db, "{}: {p} / {a}", c.label);
        assert!(p >= o - 1.0, "{}: surface {p} vs own planes {o}", c.label);
        // Nothing made of 8-bit views beats the truth stored in 8 bits (a check of the
        // comparison itself: 59.1–59.8 dB here, so 60 dB is out of any method's reach).
        assert!(
            p <= ceiling + 0.5,
            "{}: {p} above the 8-bit ceiling {ceiling}",
            c.label
        );
        assert!(
            p >= s + c.min_gain,
            "{}: surface {p} vs single {s}",
            c.label
        );
    }
    assert_no_validation_errors(&h);
    let log = r.context().validation();
    assert_eq!(log.errors(), 0, "validation errors: {:#?}", log.messages());
}

/// `render` with surfaces: the JSON names the surface, every plane, the slab width and the
/// depth origin; bad input fails with its cause, never a panic.
#[test]
fn render_reports_surfaces_and_refuses_bad_ones() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.png");
    let out = out.to_str().unwrap();
    let floor = "--plane=0,0.8863,0.1563,0,0.98481,0.17365";
    let card = "--plane=0.32,0.12,1.6,0,0,1";
    let o = tiltfield(&["render", "builtin:demo", floor, card, "-o", out, "--json"]);
    let j = json_of(&o);
    assert_eq!(j["surface"]["kind"], "planes");
    assert_eq!(j["surface"]["planes"].as_array().unwrap().len(), 2);
    assert_eq!(j["surface"]["planes"][1]["point"][2], 1.6);
    assert_eq!(j["surface"]["depth_origin"]["origin"], "given");
    let o = tiltfield(&[
        "render",
        "builtin:demo",
        card,
        "--slab",
        "0.25",
        "-o",
        out,
        "--json",
    ]);
    let j = json_of(&o);
    assert_eq!(j["surface"]["kind"], "slab");
    assert_eq!(j["surface"]["slab_half_width"], 0.25);
    assert_eq!(j["surface"]["planes"][0]["point"][2], 1.6);
    let b = |k: usize| {
        j["surface"]["slab_boundaries"][k]["point"][2]
            .as_f64()
            .unwrap()
    };
    assert!(
        (b(0) - 1.35).abs() < 1e-9 && (b(1) - 1.85).abs() < 1e-9,
        "{j}"
    );
    let o = tiltfield(&[
        "render",
        "builtin:demo",
        "--focus",
        "2.5",
        "--all-in-focus",
        "-o",
        out,
        "--json",
    ]);
    assert_eq!(json_of(&o)["surface"]["kind"], "all-in-focus");
    // One plane: the surface is the plane, nothing else changes.
    let o = tiltfield(&["render", "builtin:demo", card, "-o", out, "--json"]);
    let j = json_of(&o);
    assert_eq!(j["surface"]["kind"], "plane");
    assert_eq!(j["surface"]["planes"].as_array().unwrap().len(), 1);

    let nine: Vec<String> = (0..9)
        .map(|k| format!("--plane=0,0,{},0,0,1", 2 + k))
        .collect();
    let mut args = vec!["render", "builtin:demo", "-o", out];
    args.extend(nine.iter().map(|s| s.as_str()));
    fails_with(&args, &["at most 8 planes, got 9"]);
    for w in ["0", "-0.5", "NaN", "inf"] {
        fails_with(
            &["render", "builtin:demo", card, "--slab", w, "-o", out],
            &["half-width must be finite and > 0"],
        );
    }
    fails_with(
        &[
            "render",
            "builtin:demo",
            card,
            floor,
            "--slab",
            "0.1",
            "-o",
            out,
        ],
        &["exactly one plane, got 2 planes"],
    );
    fails_with(
        &["render", "builtin:demo", card, "--slab", "2", "-o", out],
        &["reference camera lies inside the focus slab"],
    );
    // `cloud` writes every plane of the surface: several planes, a slab's boundaries.
    let ply = format!("{out}.ply");
    let o = tiltfield(&["cloud", "builtin:demo", card, floor, "-o", &ply, "--json"]);
    let j = json_of(&o);
    assert_eq!(j["surface"]["kind"], "planes");
    assert_eq!(j["surface"]["other_planes"][0]["point"][1], 0.8863);
    let o = tiltfield(&[
        "cloud",
        "builtin:demo",
        card,
        "--slab",
        "0.2",
        "-o",
        &ply,
        "--json",
    ]);
    let j = json_of(&o);
    let z = |k: usize| {
        j["surface"]["other_planes"][k]["point"][2]
            .as_f64()
            .unwrap()
    };
    assert!(
        (z(0) - 1.4).abs() < 1e-9 && (z(1) - 1.8).abs() < 1e-9,
        "{j}"
    );
    fails_with(
        &[
            "cloud",
            "builtin:demo",
            card,
            floor,
            "--slab",
            "0.2",
            "-o",
            &ply,
        ],
        &["exactly one plane, got 2 planes"],
    );
    // Elsewhere several planes are refused with the cause.
    fails_with(
        &[
            "synth",
            "builtin:planes",
            card,
            floor,
            "-o",
            &format!("{out}.d"),
        ],
        &["--plane is given 2 times"],
    );

    // A single view without a depth map: its depth cannot be estimated.
    let one = dir.path().join("one");
    let one = one.to_str().unwrap();
    let o = tiltfield(&[
        "synth",
        "builtin:planes",
        "--grid",
        "1x1",
        "--layout",
        "hci",
        "--size",
        "32x32",
        "-o",
        one,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in std::fs::read_dir(one).unwrap() {
        let p = f.unwrap().path();
        if p.extension().is_some_and(|e| e == "pfm") {
            std::fs::remove_file(p).unwrap();
        }
    }
    fails_with(
        &["render", one, "--focus", "3", "--all-in-focus", "-o", out],
        &[
            "focus surface 'all-in-focus' needs the scene's depth",
            "at least two views",
        ],
    );
}

/// The `--plane` text of the plane a single-plane render of `focus` resolves (its `--json`):
/// the plane each repeated form must give on its own. Rust prints an f64 so that it parses
/// back to the same number.
fn plane_alone(focus: &[&str], out: &str) -> String {
    let mut args = vec!["render", "builtin:demo", "-o", out, "--json"];
    args.extend_from_slice(focus);
    let j = json_of(&tiltfield(&args));
    assert_eq!(j["surface"]["kind"], "plane", "{focus:?} is one plane");
    let p = &j["plane"];
    let v: Vec<f64> = ["point", "normal"]
        .iter()
        .flat_map(|k| (0..3).map(move |i| p[k][i].as_f64().unwrap()))
        .collect();
    format!(
        "--plane={}",
        v.iter().map(f64::to_string).collect::<Vec<_>>().join(",")
    )
}

/// The RGBA pixels of a PNG, and how many differ between two.
fn pixels(path: &str) -> Vec<[u8; 4]> {
    let img = image::open(path).unwrap().to_rgba8();
    img.pixels().map(|p| p.0).collect()
}

fn differing(a: &str, b: &str) -> usize {
    let (a, b) = (pixels(a), pixels(b));
    assert_eq!(a.len(), b.len());
    a.iter().zip(&b).filter(|(x, y)| x != y).count()
}

/// `--focus` (with `--tilt`/`--swing` once or once per `--focus`) and `--disparity` repeated
/// are focus surfaces of the planes each gives alone: the image is byte for byte the one of
/// `--plane` repeated with those planes, and `--json` reports them. Wrong counts, a ninth
/// plane, mixed forms, a surface with a slab or `--frames`, and one-plane commands are refused
/// by name; `cloud` draws the planes as it does for `--plane`.
#[test]
fn repeated_focus_and_disparity_are_the_surfaces_of_their_planes() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (scratch, focus_png, plane_png, first_png) = (
        path("scratch.png"),
        path("focus.png"),
        path("plane.png"),
        path("first.png"),
    );
    // Tilt once per --focus (paired by order), swing once (every plane).
    let keyboard = [
        "--focus", "1.6", "--focus", "2.4", "--tilt", "0", "--tilt", "25", "--swing", "5",
    ];
    let p1 = plane_alone(&["--focus", "1.6", "--swing", "5"], &scratch);
    let p2 = plane_alone(
        &["--focus", "2.4", "--tilt", "25", "--swing", "5"],
        &scratch,
    );
    assert_ne!(p1, p2);
    let mut args = vec!["render", "builtin:demo", "-o", &focus_png, "--json"];
    args.extend_from_slice(&keyboard);
    let j = json_of(&tiltfield(&args));
    assert_eq!(j["surface"]["kind"], "planes");
    assert_eq!(j["focus"]["how"], "focus-tilt-swing");
    let reported: Vec<String> = j["surface"]["planes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let v: Vec<String> = ["point", "normal"]
                .iter()
                .flat_map(|k| (0..3).map(move |i| p[k][i].as_f64().unwrap().to_string()))
                .collect();
            format!("--plane={}", v.join(","))
        })
        .collect();
    assert_eq!(reported, vec![p1.clone(), p2.clone()]);
    let o = tiltfield(&["render", "builtin:demo", &p1, &p2, "-o", &plane_png]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(&focus_png).unwrap(),
        std::fs::read(&plane_png).unwrap(),
        "--focus repeated and the same planes by --plane render alike"
    );
    // The second plane matters: the first alone renders otherwise.
    let o = tiltfield(&[
        "render",
        "builtin:demo",
        "--focus",
        "1.6",
        "--swing",
        "5",
        "-o",
        &first_png,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let changed = differing(&focus_png, &first_png);
    assert!(
        changed > 1000,
        "only {changed} pixels from the second plane"
    );

    // --disparity repeated on a rig: its frontoparallel planes.
    let d1 = plane_alone(&["--disparity", "0.5"], &scratch);
    let d2 = plane_alone(&["--disparity", "-0.5"], &scratch);
    let o = tiltfield(&[
        "render",
        "builtin:demo",
        "--disparity",
        "0.5",
        "--disparity=-0.5",
        "-o",
        &focus_png,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = tiltfield(&["render", "builtin:demo", &d1, &d2, "-o", &plane_png]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(&focus_png).unwrap(),
        std::fs::read(&plane_png).unwrap(),
        "--disparity repeated and the same planes by --plane render alike"
    );

    // Counts of --tilt and --swing other than once or once per --focus.
    let out = scratch.as_str();
    fn with<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
        let mut a = vec!["render", "builtin:demo", "-o", out];
        a.extend_from_slice(extra);
        a
    }
    let render = |extra: &[&'static str]| with(out, extra);
    fails_with(
        &render(&[
            "--focus", "2", "--focus", "3", "--focus", "4", "--tilt", "1", "--tilt", "2",
        ]),
        &[
            "--tilt is given 2 times and --focus 3 times",
            "paired by order",
        ],
    );
    fails_with(
        &render(&["--focus", "2", "--swing", "1", "--swing", "2"]),
        &["--swing is given 2 times and --focus once"],
    );
    // --tilt or --swing without --focus: refused, not ignored (even at 0°).
    for extra in [
        &["--plane=0,0,2,0,0,1", "--tilt", "3"][..],
        &["--disparity", "0.5", "--swing", "0"],
    ] {
        fails_with(
            &render(extra),
            &["--tilt and --swing turn the --focus plane; give --focus with them"],
        );
    }
    // A ninth plane, in any form.
    let nine: Vec<String> = (0..9).map(|k| format!("--focus={}", 2 + k)).collect();
    let mut a = render(&[]);
    a.extend(nine.iter().map(|s| s.as_str()));
    fails_with(&a, &["at most 8 planes, got 9"]);
    let nine: Vec<String> = (0..9).map(|k| format!("--disparity={}", k)).collect();
    let mut a = render(&[]);
    a.extend(nine.iter().map(|s| s.as_str()));
    fails_with(&a, &["at most 8 planes, got 9"]);
    // Forms do not mix in one surface.
    fails_with(
        &render(&["--plane=0,0,2,0,0,1", "--focus", "3"]),
        &["--plane", "--focus", "cannot be used with"],
    );
    // A slab lies around one plane.
    fails_with(
        &render(&["--focus", "2", "--focus", "3", "--slab", "0.1"]),
        &["exactly one plane, got 2 planes"],
    );
    // A later plane that cannot be is named by its place.
    fails_with(
        &render(&[
            "--focus", "2", "--focus", "3", "--tilt", "0", "--tilt", "95",
        ]),
        &["focus plane 2: tilt must lie strictly between"],
    );

    // `cloud` draws the keyboard planes as it draws the same planes given by --plane.
    let ply = path("c.ply");
    let mut a = vec!["cloud", "builtin:demo", "-o", &ply, "--json"];
    a.extend_from_slice(&keyboard);
    let j = json_of(&tiltfield(&a));
    assert_eq!(j["surface"]["kind"], "planes");
    let j2 = json_of(&tiltfield(&[
        "cloud",
        "builtin:demo",
        &p1,
        &p2,
        "-o",
        &ply,
        "--json",
    ]));
    assert_eq!(
        j["surface"]["other_planes"][0]["point"],
        j2["surface"]["other_planes"][0]["point"]
    );
    let n = |j: &serde_json::Value| {
        (0..3)
            .map(|i| {
                j["surface"]["other_planes"][0]["normal"][i]
                    .as_f64()
                    .unwrap()
            })
            .collect::<Vec<_>>()
    };
    let (a_n, b_n) = (n(&j), n(&j2));
    assert!(
        a_n.iter().zip(&b_n).all(|(x, y)| (x - y).abs() < 1e-12),
        "{a_n:?} vs {b_n:?}"
    );
    fails_with(
        &[
            "cloud",
            "builtin:demo",
            "--focus",
            "2",
            "--focus",
            "3",
            "--tilt",
            "1",
            "--tilt",
            "2",
            "--tilt",
            "3",
            "-o",
            &ply,
        ],
        &["--tilt is given 3 times and --focus 2 times"],
    );
    // Commands that take one plane refuse any form repeated, naming it.
    for (form, values) in [("--focus", ["2", "3"]), ("--disparity", ["0.5", "1"])] {
        fails_with(
            &[
                "synth",
                "builtin:planes",
                form,
                values[0],
                form,
                values[1],
                "-o",
                &path("synth"),
            ],
            &[
                &format!("{form} is given 2 times"),
                "only `render` and `cloud` take",
            ],
        );
    }
}

/// `--disparity` repeated without a camera rig (a grid folder: classic shift-and-sum) is the
/// surface of the frontoparallel planes those classic shifts stand for: on the same views as
/// an HCI folder, classic D samples view (s, t) at u + D·(s − s_c), the HCI disparity −D, so
/// the grid folder's surface on its estimated depth renders as the HCI folder's surface of the
/// negated disparities on the exact depth; all in focus from a classic focus is its all in
/// focus; and `cloud` draws a classic focus's plane.
#[test]
fn repeated_disparity_on_a_grid_folder_is_the_surface_of_its_planes() {
    let dir = tempfile::tempdir().unwrap();
    let hci = dir.path().join("hci");
    let o = tiltfield(&[
        "synth",
        "builtin:planes",
        "--grid",
        "3x3",
        "--size",
        "32x32",
        "--layout",
        "hci",
        "-o",
        hci.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The same views as a grid folder (row_col.png): nominal cameras, no rig, no depth.
    let grid = dir.path().join("grid");
    hci_as_grid_folder(&hci, &grid, 3, 3);
    let cache = dir.path().join("cache");
    let run = |lf: &std::path::Path, focus: &[&str], out: &str| {
        let out = dir.path().join(out);
        let mut args = vec!["render", lf.to_str().unwrap()];
        args.extend_from_slice(focus);
        args.extend_from_slice(&["--antialias", "off", "-o", out.to_str().unwrap()]);
        let o = tiltfield_cached(&args, &cache);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        view_rgb(&image::open(&out).unwrap().to_rgba8())
    };
    // `planes`: the card at HCI disparity 4/3, the back plane at -2/3.
    let truth = run(
        &hci,
        &["--disparity=1.3333333", "--disparity=-0.6666667"],
        "hci.png",
    );
    let surface = run(
        &grid,
        &["--disparity=-1.3333333", "--disparity=0.6666667"],
        "surface.png",
    );
    let card = run(&grid, &["--disparity=-1.3333333"], "card.png");
    let back = run(&grid, &["--disparity=0.6666667"], "back.png");
    let all = vec![true; truth.len()];
    let (s, c, b) = (
        psnr_rgb(&surface, &truth, &all),
        psnr_rgb(&card, &truth, &all),
        psnr_rgb(&back, &truth, &all),
    );
    eprintln!(
        "grid surface vs HCI surface: {s:.1} dB (card plane alone {c:.1}, back alone {b:.1})"
    );
    // Measured 55.3 dB (21.4 and 32.1 alone): both layers in focus at once.
    assert!(s >= 45.0 && s >= c.max(b) + 10.0, "{s} {c} {b}");

    // All in focus from a classic focus: the same image as the HCI folder's.
    let grid_all = run(
        &grid,
        &["--disparity=-1.3333333", "--all-in-focus"],
        "ga.png",
    );
    let hci_all = run(&hci, &["--disparity=1.3333333", "--all-in-focus"], "ha.png");
    let a = psnr_rgb(&grid_all, &hci_all, &all);
    let alone = psnr_rgb(&card, &hci_all, &all).max(psnr_rgb(&back, &hci_all, &all));
    eprintln!("all in focus, grid vs HCI: {a:.1} dB (a plane alone at best {alone:.1})");
    // Measured 39.6 dB (the estimate's sub-pixel errors refocus each pixel slightly off).
    assert!(a >= 35.0 && a >= alone + 5.0, "{a} {alone}");

    // A classic disparity at or beyond the nominal cameras' infinity stands for no plane:
    // refused, naming it, and no image written.
    let beyond = dir.path().join("beyond.png");
    let o = tiltfield_cached(
        &[
            "render",
            grid.to_str().unwrap(),
            "--disparity=-1.3333333",
            "--disparity=40",
            "-o",
            beyond.to_str().unwrap(),
        ],
        &cache,
    );
    let err = stderr(&o);
    assert!(!o.status.success() && !err.contains("panicked"), "{err}");
    assert!(
        err.contains("focus plane 2: the focus surface 'planes' needs the cameras' geometry")
            && err.contains("--disparity 40 lies at or beyond the cameras' infinity"),
        "{err}"
    );
    assert!(!beyond.exists());

    // The point cloud draws the plane a classic --disparity stands for.
    let o = tiltfield_cached(
        &[
            "cloud",
            grid.to_str().unwrap(),
            "--disparity=-1.3333333",
            "--json",
            "-o",
            dir.path().join("c.ply").to_str().unwrap(),
        ],
        &cache,
    );
    let j = json_of(&o);
    let normal = &j["plane"]["plane"]["normal"];
    assert!(
        (normal[2].as_f64().unwrap().abs() - 1.0).abs() < 1e-9,
        "a frontoparallel plane: {j}"
    );
}
