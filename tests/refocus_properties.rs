//! Properties of refocusing that follow from the optics, checked on generated light fields
//! with exact ground truth (GPU, validation on).

mod common;

use common::*;
use glam::DVec2;
use tiltfield::geometry::aperture::Aperture;
use tiltfield::refocus::{self, cpu, Averaging, FocusMethod, FocusSpec, RefocusRequest};

#[test]
fn frontoparallel_homography_path_equals_classic_shift_and_sum() {
    let lf = builtin("planes");
    let d = -0.667;
    let general = refocus::plan(&lf, &request(FocusSpec::Disparity(d)), &[]).unwrap();
    assert_eq!(general.method, FocusMethod::HciDisparity);
    // The same light field without rig parameters takes the classic path, whose sign
    // convention is u + (s − s_r)·δ: HCI disparity d is δ = −d.
    let mut bare = lf.clone();
    bare.rig = None;
    let classic = refocus::plan(&bare, &request(FocusSpec::Disparity(-d)), &[]).unwrap();
    assert_eq!(classic.method, FocusMethod::ClassicShift);
    // Identical homographies (to rounding)...
    for (g, c) in general.views.iter().zip(&classic.views) {
        let hg = g.warp.homography(general.m);
        let hc = c.warp.homography(classic.m);
        assert!(
            (hg - hc).abs_diff_eq(glam::DMat3::ZERO, 1e-9),
            "view ({},{}): {hg} vs {hc}",
            g.s,
            g.t
        );
    }
    // ...and identical images.
    let mut r = renderer(&lf);
    let a = render_float(&mut r, &general, Averaging::Linear);
    let b = render_float(&mut r, &classic, Averaging::Linear);
    let dd = diff(&a, &b, None);
    assert!(dd.max_levels <= 1.0, "max {} levels", dd.max_levels);
    assert_no_validation_errors(&r);
}

#[test]
fn a_plane_refocused_onto_itself_reproduces_its_texture_and_blurs_the_rest() {
    // Integer disparities: back plane −1 px, card +2 px per grid step. The card covers
    // x, y ≥ 36 of the centre view and shifts by up to 2·2 px across the grid, so the regions
    // below stay clear of occlusion boundaries in every view.
    let lf = two_planes(-1.0, 2.0);
    let truth = view_rgb(&lf.views[lf.grid.index(2, 2)].image);
    let back = rect_mask(6, 6, 30, 30);
    let card = rect_mask(44, 44, 58, 58);
    let mut r = renderer(&lf);
    for (name, d, on, off) in [("back", -1.0, &back, &card), ("card", 2.0, &card, &back)] {
        let plan = refocus::plan(&lf, &request(FocusSpec::Disparity(d)), &[]).unwrap();
        let img = encoded(&render_float(&mut r, &plan, Averaging::Linear));
        let psnr = psnr_rgb(&img, &truth, on);
        let lost = gradient_energy(&img, 64, off) / gradient_energy(&truth, 64, off);
        eprintln!("focus {name}: {psnr:.1} dB against the pinhole view on the plane; off-plane sharpness {lost:.2}");
        assert!(
            psnr > 45.0,
            "focus {name}: texture not reproduced ({psnr:.1} dB)"
        );
        assert!(
            lost < 0.3,
            "focus {name}: off-plane content not blurred ({lost:.2})"
        );
    }
    assert_no_validation_errors(&r);
}

#[test]
fn sharpness_peaks_at_the_planes_own_disparity() {
    // A focus sweep over fractional disparities: the back plane's region is sharpest at its
    // own disparity, and falls off on both sides.
    let lf = two_planes(-1.0, 2.0);
    let back = rect_mask(6, 6, 30, 30);
    let mut r = renderer(&lf);
    let sweep: Vec<(f64, f64)> = [-2.0, -1.5, -1.25, -1.0, -0.75, -0.5, 0.0]
        .iter()
        .map(|&d| {
            let plan = refocus::plan(&lf, &request(FocusSpec::Disparity(d)), &[]).unwrap();
            let img = encoded(&render_float(&mut r, &plan, Averaging::Linear));
            (d, gradient_energy(&img, 64, &back))
        })
        .collect();
    eprintln!("sweep (disparity, sharpness): {sweep:?}");
    let best = sweep
        .iter()
        .cloned()
        .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    assert_eq!(best.0, -1.0, "sharpest at {} instead of −1", best.0);
    for w in sweep.windows(2) {
        let rising = w[1].0 <= -1.0;
        assert_eq!(w[1].1 > w[0].1, rising, "not unimodal around −1: {sweep:?}");
    }
    assert_no_validation_errors(&r);
}

#[test]
fn tilted_plane_is_in_focus_everywhere_along_it() {
    // builtin:tilted: one quad tilted by 40° about x fills the view, so the plane's depth is
    // constant along each image row and changes from row to row. Row y of the tilt-shift
    // refocus must therefore equal row y of a frontoparallel refocus at that row's disparity
    // d(y): a composite built row by row with the f64 reference is exact ground truth for
    // the generalized homographies. A single frontoparallel focus is sharp in one band only.
    let scene = tiltfield::synth::builtin("tilted").unwrap();
    let lf = scene.light_field(2);
    let rig = lf.rig.unwrap();
    let (_, point, normal) = scene.planes().into_iter().next().unwrap();
    let plane = tiltfield::geometry::plane::Plane::new(point, normal).unwrap();
    let centre_cam = lf.views[lf.grid.index(2, 2)].camera;
    let (w, h) = (lf.width as usize, lf.height as usize);
    let mut composite = vec![[0f32; 4]; w * h];
    for y in 0..h {
        let ray = centre_cam.ray_camera(DVec2::new(31.5, y as f64));
        let z = plane.normal.dot(plane.point) / plane.normal.dot(ray);
        let plan = refocus::plan(
            &lf,
            &request(FocusSpec::Disparity(rig.disparity_of_depth(z))),
            &[],
        )
        .unwrap();
        let row = cpu::render(&lf, &plan, Averaging::Linear);
        composite[y * w..(y + 1) * w].copy_from_slice(&row.pixels[y * w..(y + 1) * w]);
    }
    let composite = tiltfield::refocus::RefocusImage {
        width: lf.width,
        height: lf.height,
        averaging: Averaging::Linear,
        pixels: composite,
    };
    let mut r = renderer(&lf);
    let tilt_plan = refocus::plan(&lf, &request(FocusSpec::Plane(plane)), &[]).unwrap();
    let tilt = render_float(&mut r, &tilt_plan, Averaging::Linear);
    let d = diff(&tilt, &composite, None);
    eprintln!(
        "tilt-shift vs row-wise frontoparallel composite: {:.1} dB, max {:.2} levels",
        d.psnr_db, d.max_levels
    );
    assert!(d.psnr_db > 50.0 && d.max_levels <= 2.0, "{d:?}");

    // A fixed frontoparallel focus on the middle row is clearly worse at the top and bottom.
    let truth = view_rgb(&lf.views[lf.grid.index(2, 2)].image);
    let flat = refocus::plan(
        &lf,
        &request(FocusSpec::Disparity(rig.disparity_of_depth(point.z))),
        &[],
    )
    .unwrap();
    let flat = encoded(&render_float(&mut r, &flat, Averaging::Linear));
    let tilt = encoded(&tilt);
    for (band, y0) in [("top", 2usize), ("bottom", 50)] {
        let mask = rect_mask(2, y0, 62, y0 + 12);
        let (pt, pf) = (
            psnr_rgb(&tilt, &truth, &mask),
            psnr_rgb(&flat, &truth, &mask),
        );
        eprintln!(
            "{band}: tilt-shift {pt:.1} dB, frontoparallel {pf:.1} dB against the pinhole view"
        );
        assert!(
            pt > pf + 3.0,
            "{band}: tilt-shift {pt:.1} dB vs frontoparallel {pf:.1} dB"
        );
    }
    assert_no_validation_errors(&r);
}

#[test]
fn virtual_view_between_cameras_matches_the_reference_renderer_and_moves_parallax() {
    let lf = builtin("planes");
    let mut r = renderer(&lf);
    let at = |s: f64, t: f64| RefocusRequest {
        focus: FocusSpec::Disparity(-0.667),
        aperture: Aperture {
            shape: tiltfield::geometry::aperture::ApertureShape::Disk,
            radius: Some(1.0),
        },
        reference: Some(DVec2::new(s, t)),
    };
    let p1 = refocus::plan(&lf, &at(1.0, 2.0), &[]).unwrap();
    let p2 = refocus::plan(&lf, &at(1.5, 2.0), &[]).unwrap();
    let p3 = refocus::plan(&lf, &at(2.0, 2.0), &[]).unwrap();
    // The virtual camera sits halfway between its neighbours.
    let c = |p: &tiltfield::refocus::RefocusPlan| p.reference_camera.centre();
    assert!(((c(&p1) + c(&p3)) * 0.5 - c(&p2)).length() < 1e-12);
    let gpu = render_float(&mut r, &p2, Averaging::Linear);
    let d = diff(&gpu, &cpu::render(&lf, &p2, Averaging::Linear), None);
    assert!(d.psnr_db > 45.0, "virtual view PSNR {:.1}", d.psnr_db);
    assert_no_validation_errors(&r);
}
