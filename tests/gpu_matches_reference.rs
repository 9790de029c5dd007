//! The GPU refocus pass against the f64 CPU reference of the same equations, on small generated
//! light fields: frontoparallel and tilted planes, virtual views, every aperture shape, both
//! averaging spaces, split draws. Validation layer on; zero validation errors asserted.
//!
//! Measured on lavapipe (Mesa 22.3): PSNR ≥ 55 dB and at most a few 8-bit levels off at any
//! pixel. The residual comes from hardware bilinear filtering, which snaps sample positions to
//! 8 fractional bits, and from float32 warps; the bounds asserted below leave a margin.

mod common;

use common::*;
use glam::{DVec2, DVec3};
use tiltfield::geometry::aperture::{Aperture, ApertureShape};
use tiltfield::geometry::plane::Plane;
use tiltfield::refocus::{self, cpu, Averaging, FocusSpec, RefocusRequest};

/// PSNR bound asserted for every case (dB, 8-bit encoded scale).
const MIN_PSNR_DB: f64 = 55.0;
/// Largest per-pixel difference asserted, in 8-bit levels of the encoded values.
const MAX_LEVELS: f64 = 2.0;

fn cases() -> Vec<(&'static str, RefocusRequest, Averaging)> {
    let all = Aperture::default();
    let req = |focus, aperture, reference| RefocusRequest {
        focus,
        aperture,
        reference,
    };
    vec![
        (
            "hci disparity far",
            req(FocusSpec::Disparity(-0.667), all, None),
            Averaging::Linear,
        ),
        (
            "hci disparity near",
            req(FocusSpec::Disparity(1.333), all, None),
            Averaging::Linear,
        ),
        (
            "tilted plane, encoded averaging",
            req(
                FocusSpec::FocusTiltSwing {
                    distance: 3.0,
                    tilt_deg: 25.0,
                    swing_deg: -15.0,
                },
                all,
                None,
            ),
            Averaging::Encoded,
        ),
        (
            "plane given by point and normal, virtual view",
            req(
                FocusSpec::Plane(
                    Plane::new(DVec3::new(0.2, 0.1, 2.5), DVec3::new(0.3, -0.2, 1.0)).unwrap(),
                ),
                Aperture {
                    shape: ApertureShape::Disk,
                    radius: Some(1.5),
                },
                Some(DVec2::new(1.5, 2.25)),
            ),
            Averaging::Linear,
        ),
        (
            "square aperture off centre",
            req(
                FocusSpec::Disparity(0.3),
                Aperture {
                    shape: ApertureShape::Square,
                    radius: Some(1.0),
                },
                Some(DVec2::new(0.75, 3.5)),
            ),
            Averaging::Linear,
        ),
        (
            "gaussian aperture, steep tilt",
            req(
                FocusSpec::FocusTiltSwing {
                    distance: 2.0,
                    tilt_deg: 60.0,
                    swing_deg: 0.0,
                },
                Aperture {
                    shape: ApertureShape::Gaussian,
                    radius: Some(1.0),
                },
                None,
            ),
            Averaging::Linear,
        ),
    ]
}

#[test]
fn gpu_refocus_matches_the_f64_reference() {
    let lf = builtin("planes");
    let mut r = renderer(&lf);
    for (name, req, averaging) in cases() {
        let plan = refocus::plan(&lf, &req, &[]).unwrap_or_else(|e| panic!("{name}: {e}"));
        let gpu = render_float(&mut r, &plan, averaging);
        let reference = cpu::render(&lf, &plan, averaging);
        assert!(gpu.is_finite(), "{name}: non-finite GPU pixels");
        let d = diff(&gpu, &reference, None);
        eprintln!(
            "{name}: {} views, PSNR {:.1} dB, max {:.2} levels, {} coverage mismatches",
            plan.views.len(),
            d.psnr_db,
            d.max_levels,
            d.coverage_mismatch
        );
        assert!(d.psnr_db >= MIN_PSNR_DB, "{name}: PSNR {:.1} dB", d.psnr_db);
        assert!(
            d.max_levels <= MAX_LEVELS,
            "{name}: max error {:.2} levels",
            d.max_levels
        );
        assert_eq!(d.coverage_mismatch, 0, "{name}: coverage differs");
    }
    assert_no_validation_errors(&r);
}

#[test]
fn srgb8_output_matches_the_reference_encoding() {
    let lf = builtin("tilted");
    let mut r = renderer(&lf);
    let plan = refocus::plan(
        &lf,
        &RefocusRequest {
            focus: FocusSpec::FocusTiltSwing {
                distance: 2.5,
                tilt_deg: 40.0,
                swing_deg: 0.0,
            },
            aperture: Aperture::default(),
            reference: None,
        },
        &[],
    )
    .unwrap();
    for averaging in [Averaging::Linear, Averaging::Encoded] {
        let gpu8 = render_srgb8(&mut r, &plan, averaging);
        let ref8 = cpu::render(&lf, &plan, averaging).to_srgb8();
        let max = gpu8
            .as_raw()
            .iter()
            .zip(ref8.as_raw())
            .map(|(a, b)| (*a as i32 - *b as i32).abs())
            .max()
            .unwrap();
        eprintln!("{averaging:?}: max 8-bit difference {max}");
        assert!(max as f64 <= MAX_LEVELS, "{averaging:?}: {max} levels");
    }
    assert_no_validation_errors(&r);
}

#[test]
fn splitting_views_over_draws_does_not_change_the_result() {
    let lf = builtin("planes");
    let mut r = renderer(&lf);
    let plan = refocus::plan(
        &lf,
        &RefocusRequest {
            focus: FocusSpec::Disparity(0.5),
            aperture: Aperture::default(),
            reference: None,
        },
        &[],
    )
    .unwrap();
    let one = render_float_split(&mut r, &plan, Averaging::Linear, 0);
    let split = render_float_split(&mut r, &plan, Averaging::Linear, 4);
    let d = diff(&split, &one, None);
    // Only the order of float additions differs.
    assert!(d.max_levels < 0.01, "max {} levels", d.max_levels);
    assert_no_validation_errors(&r);
}

#[test]
fn linear_averaging_keeps_blurred_highlights_brighter_than_encoded() {
    // Averaging encoded values darkens a mix of bright and dark (Jensen's inequality on the
    // concave encoding); linear light does not. Focus far off every surface to blur strongly.
    let lf = builtin("planes");
    let mut r = renderer(&lf);
    let plan = refocus::plan(
        &lf,
        &RefocusRequest {
            focus: FocusSpec::Disparity(6.0),
            aperture: Aperture::default(),
            reference: None,
        },
        &[],
    )
    .unwrap();
    let lin = render_float(&mut r, &plan, Averaging::Linear);
    let enc = render_float(&mut r, &plan, Averaging::Encoded);
    let mean = |img: &tiltfield::refocus::RefocusImage| {
        let v = img.linear();
        v.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / v.len() as f32
    };
    assert!(
        mean(&lin) > mean(&enc) * 1.01,
        "linear {} encoded {}",
        mean(&lin),
        mean(&enc)
    );
    assert_no_validation_errors(&r);
}
