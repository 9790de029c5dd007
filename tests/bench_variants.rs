//! Every benchmark variant against the f64 models, on lavapipe with the validation layer:
//! each variant stays within the bound it states against the model of its own filter
//! (bilinear for hardware and shader filtering, Catmull-Rom for bicubic, nearest for nearest),
//! and the bilinear ones against the reference of the method. Plus the properties that make
//! the new variants what they claim: bicubic interpolates (exact at whole-pixel shifts) and
//! differs from bilinear elsewhere, RGBA16F sums stay within half-float rounding of RGBA32F,
//! and the exported homographies are the plan's warps.

mod common;

use std::sync::Arc;

use common::*;
use glam::{DVec2, DVec3};
use tiltfield::bench::{self, variant, Variant};
use tiltfield::gpu::GpuContext;
use tiltfield::jobs::refocus::{GpuImage, HeadlessRenderer};
use tiltfield::lightfield::LightField;
use tiltfield::refocus::cpu::{self, Kernel};
use tiltfield::refocus::settings::ViewStorage;
use tiltfield::refocus::settings::{Accumulation, Filter, Strategy};
use tiltfield::refocus::{self, Averaging, FocusSpec, RefocusImage, RefocusPlan};

fn float(
    r: &mut HeadlessRenderer,
    lf: &LightField,
    plan: &RefocusPlan,
    v: &Variant,
) -> RefocusImage {
    match r
        .render(plan, &bench::settings_of(v, lf))
        .expect("render")
        .0
    {
        GpuImage::Float(img) => img,
        GpuImage::Srgb8(_) => panic!("asked for float"),
    }
}

fn tilted_plan(lf: &LightField, radius: Option<f64>) -> RefocusPlan {
    let mut req = request(FocusSpec::FocusTiltSwing {
        distance: 2.5,
        tilt_deg: 35.0,
        swing_deg: -10.0,
    });
    req.aperture.radius = radius;
    refocus::plan(lf, &req, &[]).expect("plan")
}

#[test]
fn every_catalogue_variant_is_within_its_bound_against_its_model() {
    let lf = builtin("tilted");
    let ctx = Arc::new(GpuContext::new(&gpu_options()).expect("validated context"));
    let mut renderers: Vec<(ViewStorage, HeadlessRenderer)> = Vec::new();
    for v in variant::catalogue() {
        let plan = tilted_plan(&lf, v.aperture_radius);
        let (w, h) = v.size.resolve(lf.width, lf.height);
        let i = match renderers.iter().position(|(s, _)| *s == v.storage) {
            Some(i) => i,
            None => {
                let r = HeadlessRenderer::with_context(Arc::clone(&ctx), &lf, v.storage)
                    .expect("renderer");
                renderers.push((v.storage, r));
                renderers.len() - 1
            }
        };
        let gpu = float(&mut renderers[i].1, &lf, &plan, &v);
        assert_eq!((gpu.width, gpu.height), (w, h), "{}", v.name());
        assert!(gpu.is_finite(), "{}", v.name());
        let model = cpu::render_with(&lf, &plan, Averaging::Linear, w, h, v.model());
        let d = diff(&gpu, &model, None);
        let bound = v.bound(plan.views.len());
        eprintln!(
            "{}: vs {:?} model {d:?}, bound {bound:?}",
            v.name(),
            v.model()
        );
        assert!(
            d.psnr_db >= bound.min_psnr_db && d.max_levels <= bound.max_levels,
            "{}: {d:?} outside {bound:?}",
            v.name()
        );
        assert!(
            d.coverage_mismatch <= gpu.pixels.len() / 500,
            "{}",
            v.name()
        );
        if v.model() == Kernel::Bilinear {
            // The same model: the bound holds against the reference of the method too.
            let reference = cpu::render_scaled(&lf, &plan, Averaging::Linear, w, h);
            let d = diff(&gpu, &reference, None);
            assert!(d.psnr_db >= bound.min_psnr_db, "{}: {d:?}", v.name());
        }
    }
    for (_, r) in &renderers {
        assert_no_validation_errors(r);
    }
}

#[test]
fn bicubic_interpolates_texels_and_differs_from_bilinear_between_them() {
    let lf = builtin("planes");
    let ctx = Arc::new(GpuContext::new(&gpu_options()).expect("validated context"));
    let mut r = HeadlessRenderer::with_context(ctx, &lf, ViewStorage::Linear16).expect("renderer");
    let bicubic: Variant = "bicubic".parse().unwrap();
    // An integer HCI disparity shifts every view by whole pixels: every kernel samples texel
    // centres, where Catmull-Rom weights are (0, 1, 0, 0).
    let whole = refocus::plan(&lf, &request(FocusSpec::Disparity(1.0)), &[]).expect("plan");
    let bilinear_ref = cpu::render(&lf, &whole, Averaging::Linear);
    for strategy in [Strategy::Fragment, Strategy::Compute] {
        let v = Variant {
            strategy,
            ..bicubic
        };
        let d = diff(&float(&mut r, &lf, &whole, &v), &bilinear_ref, None);
        assert!(d.max_levels <= 0.5, "{}: {d:?}", v.name());
    }
    // Half-pixel shifts: bicubic must follow its own model and visibly differ from bilinear.
    // In the outermost rows and columns samples land exactly on a view's border
    // (−0.5 = 0 − 0.5·1), where f32 and f64 may decide the mask differently for a whole row of
    // views; the interior is compared.
    let half = refocus::plan(&lf, &request(FocusSpec::Disparity(0.5)), &[]).expect("plan");
    let gpu = float(&mut r, &lf, &half, &bicubic);
    let (w, h) = (lf.width, lf.height);
    let model = cpu::render_with(&lf, &half, Averaging::Linear, w, h, Kernel::Bicubic);
    let interior = rect_mask(2, 2, 62, 62);
    let d_model = diff(&gpu, &model, Some(&interior));
    let d_bilinear = diff(
        &gpu,
        &cpu::render(&lf, &half, Averaging::Linear),
        Some(&interior),
    );
    eprintln!("bicubic at half-pixel shifts: vs model {d_model:?}, vs bilinear {d_bilinear:?}");

    assert!(d_model.max_levels <= 1.0, "{d_model:?}");
    assert!(d_bilinear.max_levels > 2.0, "{d_bilinear:?}");
    assert_no_validation_errors(&r);
}

#[test]
fn half_float_accumulation_stays_within_half_precision_of_float() {
    let lf = builtin("tilted");
    let plan = tilted_plan(&lf, None);
    let ctx = Arc::new(GpuContext::new(&gpu_options()).expect("validated context"));
    let mut r = HeadlessRenderer::with_context(ctx, &lf, ViewStorage::Linear16).expect("renderer");
    for strategy in [
        Strategy::Fragment,
        Strategy::Batched { views_per_draw: 4 },
        Strategy::Compute,
    ] {
        let full = Variant {
            strategy,
            filter: Filter::Shader,
            ..Variant::default()
        };
        let half = Variant {
            accumulation: Accumulation::Rgba16f,
            ..full
        };
        let a = float(&mut r, &lf, &plan, &full);
        let b = float(&mut r, &lf, &plan, &half);
        // Relative error of one half-float rounding is ≤ 2⁻¹¹ of the sum and of the weight;
        // batched draws round once per draw. Compare linear values relative to their size.
        let draws = match strategy {
            Strategy::Batched { views_per_draw } => plan.views.len().div_ceil(views_per_draw),
            _ => 1,
        } as f32;
        let mut worst = 0f32;
        let mut any_diff = false;
        for (p, q) in a.pixels.iter().zip(&b.pixels) {
            for k in 0..3 {
                let rel = (p[k] - q[k]).abs() / p[k].abs().max(1e-3);
                worst = worst.max(rel);
                any_diff |= p[k] != q[k];
            }
        }
        eprintln!("{}: worst relative difference {worst:e}", strategy.name());
        assert!(
            worst <= 2.0 * (draws + 1.0) / 2048.0,
            "{}: {worst}",
            strategy.name()
        );
        assert!(
            any_diff,
            "{}: RGBA16F should round somewhere",
            strategy.name()
        );
        assert_eq!(half.accumulation.name(), "rgba16f");
    }
    assert_no_validation_errors(&r);
}

#[test]
fn exported_homographies_are_the_plans_warps() {
    let lf = builtin("tilted");
    let plan = tilted_plan(&lf, None);
    let hs = bench::homographies(&lf, &plan);
    assert_eq!(hs.views.len(), plan.views.len());
    assert_eq!((hs.width, hs.height), (lf.width, lf.height));
    for (h, v) in hs.views.iter().zip(&plan.views) {
        assert_eq!((h.index, h.weight), (v.index, v.weight));
        for &(x, y) in &[(0.0, 0.0), (63.0, 0.0), (10.5, 40.25), (63.0, 63.0)] {
            let want = v.warp.apply(plan.m, DVec2::new(x, y));
            let got = DVec3::new(
                h.h[0][0] * x + h.h[0][1] * y + h.h[0][2],
                h.h[1][0] * x + h.h[1][1] * y + h.h[1][2],
                h.h[2][0] * x + h.h[2][1] * y + h.h[2][2],
            );
            if hs.exact {
                assert!(
                    (got - want).length() <= 1e-9 * want.length(),
                    "{got} vs {want}"
                );
            }
        }
        // Generated views have no image file to point at.
        assert!(h.image.is_none());
    }
    assert!(
        hs.exact,
        "the whole tilted-plane image lies below its horizon"
    );
}

#[test]
fn more_views_than_the_uniform_buffer_holds_fall_back_to_the_storage_buffer() {
    use tiltfield::jobs::refocus::RenderSettings;
    use tiltfield::lightfield::GridSize;
    use tiltfield::refocus::settings::{OutputFormat, WarpMemory, UBO_WARPS};
    use tiltfield::synth::{Quad, Scene, Texture};
    // 17 × 17 = 289 views of 8 × 8: more than the uniform buffer's 256 records.
    let rig = TWO_PLANE_RIG;
    let scene = Scene {
        quads: vec![Quad {
            centre: DVec3::new(0.0, 0.0, 4.0),
            half_u: DVec3::new(3.0, 0.0, 0.0),
            half_v: DVec3::new(0.0, 3.0, 0.0),
            texture: Texture::Checker {
                cells_u: 9,
                cells_v: 9,
                a: [0.9, 0.35, 0.05],
                b: [0.05, 0.35, 0.35],
            },
        }],
        background: [0.0; 3],
        solids: Vec::new(),
        lighting: None,
    };
    let grid = GridSize { cols: 17, rows: 17 };
    let lf = tiltfield::synth::render_light_field(&scene, "many", grid, 8, 8, &rig, 1);
    assert!(lf.views.len() > UBO_WARPS);
    // 0.37 px per step: no sample lands exactly on a view's border (0.3 would at 5 steps).
    let plan = refocus::plan(&lf, &request(FocusSpec::Disparity(0.37)), &[]).expect("plan");
    let mut r = renderer(&lf);
    let settings = RenderSettings {
        output: OutputFormat::Float,
        warps: Some(WarpMemory::Uniform),
        ..RenderSettings::default()
    };
    let e = r.render(&plan, &settings).unwrap_err().to_string();
    assert!(e.contains("at most 256"), "{e}");
    // The default picks the storage buffer, and it renders the reference.
    let settings = RenderSettings {
        warps: None,
        ..settings
    };
    let gpu = match r.render(&plan, &settings).expect("render").0 {
        GpuImage::Float(img) => img,
        GpuImage::Srgb8(_) => panic!("asked for float"),
    };
    let reference = cpu::render(&lf, &plan, Averaging::Linear);
    let d = diff(&gpu, &reference, None);
    assert!(d.psnr_db >= 55.0, "{d:?}");
    assert_no_validation_errors(&r);
}

#[test]
fn uniform_and_storage_warps_render_the_same_image() {
    let lf = builtin("tilted");
    let plan = tilted_plan(&lf, None);
    let ctx = Arc::new(GpuContext::new(&gpu_options()).expect("validated context"));
    let mut r = HeadlessRenderer::with_context(ctx, &lf, ViewStorage::Srgb8).expect("renderer");
    for base in [
        "fragment",
        "compute",
        "batched:4",
        "shader",
        "shader/compute",
    ] {
        let ubo: Variant = format!("{base}/ubo").parse().unwrap();
        let ssbo: Variant = format!("{base}/ssbo").parse().unwrap();
        let a = float(&mut r, &lf, &plan, &ubo);
        let b = float(&mut r, &lf, &plan, &ssbo);
        assert_eq!(a.pixels, b.pixels, "{base}: the warps are the same bytes");
    }
    assert_no_validation_errors(&r);
}
