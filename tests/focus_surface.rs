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
use tiltfield::passes::refocus::{Filter, OutputFormat, Strategy};
use tiltfield::refocus::antialias::{plan_antialias, AntialiasSettings};
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

    // With anti-aliasing the surface's s drives the footprints too (one depth bound for both).
    let plan = plan_of(&lf, frontal(zb), None);
    let depth = lf.view_depth().unwrap();
    let aa = plan_antialias(
        &lf,
        &plan,
        disk(),
        &[],
        &depth,
        AntialiasSettings::default(),
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
