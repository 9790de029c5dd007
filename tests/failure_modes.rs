//! Degenerate and failing cases handled on purpose (docs/conventions.md §5): each gives a clear
//! error or a documented, finite result — never NaN, a panic or a hang.

mod common;

use common::*;
use glam::{DVec2, DVec3};
use tiltfield::geometry::aperture::{Aperture, ApertureShape};
use tiltfield::geometry::camera::{intrinsics, Camera};
use tiltfield::geometry::plane::Plane;
use tiltfield::lightfield::{GridSize, LightField, Source, View};
use tiltfield::passes::texture::TextureLimits;
use tiltfield::refocus::{self, cpu, Averaging, FocusSpec, RefocusRequest};

#[test]
fn plane_through_the_reference_camera_is_refused() {
    let lf = builtin("planes");
    // The centre camera sits at the world origin.
    let plane = Plane::new(DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0)).unwrap();
    let err = refocus::plan(&lf, &request(FocusSpec::Plane(plane)), &[]).unwrap_err();
    assert!(
        err.to_string()
            .contains("passes through the reference camera"),
        "{err}"
    );
}

#[test]
fn disparity_beyond_infinity_is_refused() {
    let lf = builtin("planes");
    let inf = lf.rig.unwrap().disparity_at_infinity();
    let err = refocus::plan(&lf, &request(FocusSpec::Disparity(inf - 0.5)), &[]).unwrap_err();
    assert!(err.to_string().contains("beyond infinity"), "{err}");
}

#[test]
fn horizon_crossing_plane_renders_finite_pixels_focused_at_infinity() {
    // A plane tilted by 85° about the reference x axis: its horizon crosses the image, rows
    // above it have no in-focus point. Documented rule: those pixels focus at infinity.
    let lf = builtin("planes");
    let plan = refocus::plan(
        &lf,
        &request(FocusSpec::FocusTiltSwing {
            distance: 1.0,
            tilt_deg: 85.0,
            swing_deg: 0.0,
        }),
        &[],
    )
    .unwrap();
    let mut r = renderer(&lf);
    let gpu = render_float(&mut r, &plan, Averaging::Linear);
    assert!(gpu.is_finite(), "NaN or inf pixels");
    let reference = cpu::render(&lf, &plan, Averaging::Linear);
    assert!(reference.is_finite());
    let d = diff(&gpu, &reference, None);
    assert!(d.psnr_db > 45.0, "PSNR {:.1}", d.psnr_db);
    // Past the horizon the result equals refocusing at infinity.
    let w = lf.width as usize;
    let past_horizon: Vec<bool> = (0..gpu.pixels.len())
        .map(|i| {
            let x = DVec2::new((i % w) as f64, (i / w) as f64);
            plan.m.dot(x.extend(1.0)) <= 0.0
        })
        .collect();
    assert!(
        past_horizon.iter().any(|&b| b) && !past_horizon.iter().all(|&b| b),
        "horizon must cross the image"
    );
    let inf = lf.rig.unwrap().disparity_at_infinity();
    // Infinity through the classic path (no rig): δ = −d.
    let mut bare = lf.clone();
    bare.rig = None;
    let at_inf = refocus::plan(&bare, &request(FocusSpec::Disparity(-inf)), &[]).unwrap();
    let at_inf = render_float(&mut r, &at_inf, Averaging::Linear);
    let d = diff(&gpu, &at_inf, Some(&past_horizon));
    assert!(
        d.max_levels <= 1.0,
        "past the horizon differs from focus at infinity by {} levels",
        d.max_levels
    );
    assert_no_validation_errors(&r);
}

#[test]
fn empty_aperture_is_refused() {
    let lf = builtin("planes");
    let req = RefocusRequest {
        focus: FocusSpec::Disparity(0.0),
        aperture: Aperture {
            shape: ApertureShape::Disk,
            radius: Some(0.0),
        },
        reference: Some(DVec2::new(1.5, 1.5)),
    };
    let err = refocus::plan(&lf, &req, &[]).unwrap_err();
    assert!(err.to_string().contains("contains no usable view"), "{err}");
    // All views excluded as dark is the same failure, and says so.
    let all_dark = vec![true; lf.views.len()];
    let err = refocus::plan(&lf, &request(FocusSpec::Disparity(0.0)), &all_dark).unwrap_err();
    assert!(err.to_string().contains("dark views excluded"), "{err}");
}

#[test]
fn reference_view_outside_the_grid_is_refused() {
    let lf = builtin("planes");
    let req = RefocusRequest {
        focus: FocusSpec::Disparity(0.0),
        aperture: Aperture::default(),
        reference: Some(DVec2::new(4.5, 0.0)),
    };
    let err = refocus::plan(&lf, &req, &[]).unwrap_err();
    assert!(err.to_string().contains("outside the grid"), "{err}");
}

#[test]
fn pixels_no_view_reaches_are_background_and_counted() {
    // Classic shift far larger than the image: every sample lands outside every view except
    // the reference view's own (shift 0), so with the centre view excluded nothing contributes.
    let mut lf = builtin("planes");
    lf.rig = None;
    let mut excluded = vec![false; lf.views.len()];
    excluded[lf.grid.index(2, 2)] = true;
    let plan = refocus::plan(&lf, &request(FocusSpec::Disparity(1000.0)), &excluded).unwrap();
    let mut r = renderer(&lf);
    let img = render_float(&mut r, &plan, Averaging::Linear);
    assert!(img.is_finite());
    assert_eq!(img.uncovered(), (lf.width * lf.height) as usize);
    assert!(
        img.pixels.iter().all(|p| *p == [0.0; 4]),
        "background is transparent black"
    );
    assert_no_validation_errors(&r);
}

/// A light field of `n` views of 1×1 pixel (cheap way to exceed the layer limit).
fn tiny_light_field(n: usize) -> LightField {
    let k = intrinsics(1.0, 1.0, 0.0, 0.0);
    let views = (0..n)
        .map(|i| View {
            s: i,
            t: 0,
            camera: Camera::from_centre(k, glam::DMat3::IDENTITY, DVec3::new(i as f64, 0.0, 0.0)),
            image: image::RgbaImage::from_pixel(1, 1, image::Rgba([10, 20, 30, 255])),
            source: format!("tiny {i}"),
        })
        .collect();
    LightField {
        name: "tiny".into(),
        grid: GridSize { cols: n, rows: 1 },
        width: 1,
        height: 1,
        views,
        depth: Vec::new(),
        rig: None,
        disparity_range: None,
        source: Source::Generated {
            scene: "tiny".into(),
        },
    }
}

#[test]
fn more_views_than_array_layers_is_a_clear_error() {
    let ctx = tiltfield::gpu::GpuContext::new(&gpu_options()).expect("validated context");
    let limits = TextureLimits::of(&ctx);
    let lf = tiny_light_field(limits.max_layers as usize + 1);
    let ctx = std::sync::Arc::new(ctx);
    let storage = tiltfield::refocus::settings::ViewStorage::default();
    let err = match tiltfield::jobs::refocus::HeadlessRenderer::with_context(ctx, &lf, storage) {
        Ok(_) => panic!("uploading {} layers should fail", limits.max_layers + 1),
        Err(e) => e.to_string(),
    };
    assert!(err.contains("maxImageArrayLayers"), "{err}");
    assert!(
        err.contains(&format!("{} views", limits.max_layers + 1)),
        "{err}"
    );
}

#[test]
fn non_finite_or_degenerate_inputs_are_refused() {
    let lf = builtin("planes");
    assert!(refocus::plan(&lf, &request(FocusSpec::Disparity(f64::NAN)), &[]).is_err());
    let bad = FocusSpec::FocusTiltSwing {
        distance: 0.0,
        tilt_deg: 0.0,
        swing_deg: 0.0,
    };
    assert!(refocus::plan(&lf, &request(bad), &[]).is_err());
    let bad = FocusSpec::FocusTiltSwing {
        distance: 2.0,
        tilt_deg: 95.0,
        swing_deg: 0.0,
    };
    assert!(refocus::plan(&lf, &request(bad), &[]).is_err());
    let req = RefocusRequest {
        focus: FocusSpec::Disparity(0.0),
        aperture: Aperture {
            shape: ApertureShape::Gaussian,
            radius: Some(-2.0),
        },
        reference: None,
    };
    assert!(refocus::plan(&lf, &req, &[]).is_err());
}
