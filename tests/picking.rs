//! Scene-based plane placement end to end: clicks on the built-in scenes find their planes, a
//! click-focused render brings the clicked surface into focus (GPU, validation layer on), the
//! command-line forms work and every refusal exits with one clear message, and `cloud` writes
//! a PLY that an independent reader (ply-rs-bw) parses.

mod common;

use std::path::Path;

use common::*;
use glam::{DVec2, DVec3};
use tiltfield::geometry::aperture::Aperture;
use tiltfield::geometry::normals::NormalParams;
use tiltfield::geometry::picking;
use tiltfield::geometry::plane::Plane;
use tiltfield::lightfield::{hci, manifest, DepthKind};
use tiltfield::refocus::{self, Averaging, FocusSpec, RefocusRequest};
use tiltfield::synth::surfaces::angle_deg;

fn v3(v: &serde_json::Value) -> DVec3 {
    DVec3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

/// The centre-view pixel of each built-in plane's reported point.
fn plane_pixels(name: &str) -> Vec<(String, DVec2, DVec3, DVec3)> {
    let b = tiltfield::synth::builtin(name).unwrap();
    let cams = b.rig.cameras(b.grid, b.width, b.height);
    let centre = &cams[b.grid.index(b.grid.cols / 2, b.grid.rows / 2)];
    b.planes()
        .into_iter()
        .map(|(label, p, n)| (label, centre.project(p).unwrap().round(), p, n))
        .collect()
}

#[test]
fn clicks_on_every_builtin_plane_find_it() {
    for name in ["planes", "tilted", "demo"] {
        let lf = tiltfield::synth::builtin(name).unwrap().light_field(1);
        let depth = lf.view_depth().unwrap();
        assert_eq!(
            depth.kind,
            DepthKind::Depth,
            "the exact depth map is preferred"
        );
        for (label, px, p, n) in plane_pixels(name) {
            let pick = picking::click(&depth, px.x, px.y, &NormalParams::default())
                .unwrap_or_else(|e| panic!("{name} {label}: {e}"));
            let err = angle_deg(pick.plane.normal, n);
            assert!(err < 0.01, "{name} {label}: normal off by {err}°");
            let truth = Plane::new(p, n).unwrap();
            let off = truth.signed_distance(pick.plane.point).abs();
            assert!(off < 1e-5 * p.length(), "{name} {label}: point {off} off");
            assert!(
                pick.confidence > 0.999,
                "{name} {label}: {}",
                pick.confidence
            );
            // Facing the camera like the built-in planes' reported normals.
            assert!(pick.plane.normal.dot(n) > 0.0);
        }
    }
}

#[test]
fn three_clicks_on_the_demo_painting_find_it() {
    let lf = tiltfield::synth::builtin("demo").unwrap().light_field(1);
    let depth = lf.view_depth().unwrap();
    let (_, c, p, n) = plane_pixels("demo").remove(2);
    let pick = picking::three_clicks(
        &depth,
        [
            c + DVec2::new(-12.0, -10.0),
            c + DVec2::new(12.0, -8.0),
            c + DVec2::new(0.0, 12.0),
        ],
    )
    .unwrap();
    assert!(angle_deg(pick.plane.normal, n) < 0.01);
    assert!(
        Plane::new(p, n)
            .unwrap()
            .signed_distance(pick.plane.point)
            .abs()
            < 1e-4
    );
}

#[test]
fn a_click_focused_render_matches_the_true_plane_and_sharpens_the_clicked_surface() {
    // Tilted plane: the clicked plane renders like the exact one.
    let lf = builtin("tilted");
    let depth = lf.view_depth().unwrap();
    let pick = picking::click(&depth, 40.0, 20.0, &NormalParams::default()).unwrap();
    let (_, _, p, n) = plane_pixels("tilted").remove(0);
    let req = |plane: Plane| RefocusRequest {
        focus: FocusSpec::Plane(plane),
        aperture: Aperture::default(),
        reference: None,
    };
    let mut r = renderer(&lf);
    let clicked = refocus::plan(&lf, &req(pick.plane), &[]).unwrap();
    let exact = refocus::plan(&lf, &req(Plane::new(p, n).unwrap()), &[]).unwrap();
    let a = render_float(&mut r, &clicked, Averaging::Linear);
    let b = render_float(&mut r, &exact, Averaging::Linear);
    let d = diff(&a, &b, None);
    assert!(d.psnr_db > 50.0, "{d:?}");
    assert_no_validation_errors(&r);

    // Demo: clicking the painting makes it sharper than focusing on the card does.
    let demo = builtin("demo");
    let scene = tiltfield::synth::builtin("demo").unwrap();
    let depth = demo.view_depth().unwrap();
    let (_, c, _, _) = plane_pixels("demo").remove(2);
    let painting = picking::click(&depth, c.x, c.y, &NormalParams::default()).unwrap();
    let (_, c, _, _) = plane_pixels("demo").remove(3);
    let card = picking::click(&depth, c.x, c.y, &NormalParams::default()).unwrap();
    let cam = depth.camera;
    let mask: Vec<bool> = (0..demo.width * demo.height)
        .map(|i| {
            let px = DVec2::new((i % demo.width) as f64, (i / demo.width) as f64);
            tiltfield::synth::trace_pixel(&scene.scene, &cam, px)
                .is_some_and(|(h, _)| h.quad_index == 2)
        })
        .collect();
    assert!(mask.iter().filter(|m| **m).count() > 2000);
    let mut r = renderer(&demo);
    let mut sharpness = |plane: Plane| {
        let plan = refocus::plan(&demo, &req(plane), &[]).unwrap();
        let img = render_float(&mut r, &plan, Averaging::Linear);
        gradient_energy(&encoded(&img), demo.width as usize, &mask)
    };
    let (_, _, p, n) = plane_pixels("demo").remove(2);
    let (on_painting, on_card) = (sharpness(painting.plane), sharpness(card.plane));
    let on_truth = sharpness(Plane::new(p, n).unwrap());
    assert!(
        on_painting > 10.0 * on_card && on_painting > 0.98 * on_truth,
        "painting {on_painting}, card {on_card}, true plane {on_truth}"
    );
    assert_no_validation_errors(&r);
}

#[test]
fn render_click_points_and_nudges_report_how_the_plane_was_found() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x.png");
    let out = out.to_str().unwrap();
    let v = json_of(&tiltfield(&[
        "render",
        "builtin:tilted",
        "--click",
        "32,20",
        "-o",
        out,
        "--json",
    ]));
    assert_eq!(v["focus"]["how"], "click");
    assert_eq!(v["focus"]["nudged"], false);
    assert!(v["focus"]["confidence"].as_f64().unwrap() > 0.999);
    assert_eq!(v["method"], "plane");
    let n = v3(&v["plane"]["normal"]);
    let truth = DVec3::new(0.0, -40f64.to_radians().sin(), -40f64.to_radians().cos());
    assert!(angle_deg(n, truth) < 0.01, "{n}");
    assert!(Path::new(out).is_file());

    // Nudged: the tilt of the plane as seen from the centre camera grows by the nudge.
    let v = json_of(&tiltfield(&[
        "render",
        "builtin:tilted",
        "--click",
        "32,20",
        "--nudge-tilt",
        "-5",
        "--nudge-distance",
        "0.25",
        "-o",
        out,
        "--json",
    ]));
    assert_eq!(v["focus"]["nudged"], true);
    let before = &v["focus"]["nudge"]["before"];
    let after = &v["focus"]["nudge"]["after"];
    assert!((before["tilt_deg"].as_f64().unwrap() - 40.0).abs() < 0.01);
    assert!((after["tilt_deg"].as_f64().unwrap() - 35.0).abs() < 0.01);
    assert!((after["distance"].as_f64().unwrap() - 3.25).abs() < 1e-3);
    assert!(angle_deg(v3(&v["plane"]["normal"]), truth) > 4.9);

    let v = json_of(&tiltfield(&[
        "render",
        "builtin:tilted",
        "--points",
        "10,10,50,12,30,50",
        "-o",
        out,
        "--json",
    ]));
    assert_eq!(v["focus"]["how"], "three-points");
    assert!(angle_deg(v3(&v["plane"]["normal"]), truth) < 0.01);
    assert_eq!(v["focus"]["pixels"][1], serde_json::json!([50, 12]));

    let v = json_of(&tiltfield(&[
        "render",
        "builtin:planes",
        "--points-3d",
        "0,0,4,1,0,4,0,1,4",
        "--view",
        "1,3",
        "-o",
        out,
        "--json",
    ]));
    assert_eq!(v["focus"]["how"], "three-points-3d");
    assert!((v["focus"]["confidence"].as_f64().unwrap() - 0.816).abs() < 0.01);
    assert!(angle_deg(v3(&v["plane"]["normal"]), DVec3::Z) < 1e-9);

    // The plain options report no confidence.
    let v = json_of(&tiltfield(&[
        "render",
        "builtin:planes",
        "--focus",
        "3",
        "-o",
        out,
        "--json",
    ]));
    assert_eq!(v["focus"]["how"], "focus-tilt-swing");
    assert!(v["focus"]["confidence"].is_null());
}

/// The two-plane scene as an HCI folder with only a disparity map, `[meta]` disparity range
/// −1.5 … 2.5, NaN in 4-px bands along the top and left edges except at the lone pixel
/// (1, 1), and an out-of-range 3.0 at (10, 10).
fn write_hci_with_bad_disparity(dir: &Path) {
    let mut lf = two_planes(-1.0, 2.0);
    lf.depth.retain(|(_, d)| d.kind == DepthKind::Disparity);
    let (_, disp) = &mut lf.depth[0];
    for y in 0..64 {
        for x in 0..64 {
            if (x < 4 || y < 4) && (x, y) != (1, 1) {
                disp.values[y * 64 + x] = f32::NAN;
            }
        }
    }
    disp.values[10 * 64 + 10] = 3.0;
    let mut cfg = hci::config_for(&lf, &TWO_PLANE_RIG, 36.0);
    cfg.meta.insert("disp_min".into(), "-1.5".into());
    cfg.meta.insert("disp_max".into(), "2.5".into());
    hci::write(&lf, &cfg, dir).unwrap();
}

#[test]
fn click_refusals_exit_with_one_clear_message() {
    let tmp = tempfile::tempdir().unwrap();
    let hci_dir = tmp.path().join("hci");
    write_hci_with_bad_disparity(&hci_dir);
    let lf = hci_dir.to_str().unwrap();
    let out = tmp.path().join("x.png");
    let out = out.to_str().unwrap();
    fails_with(
        &["render", lf, "--click", "2,2", "-o", out],
        &["pixel (2, 2)", "NaN", "gt_disp_lowres.pfm"],
    );
    fails_with(
        &["render", lf, "--click", "10,10", "-o", out],
        &["outside the dataset's range", "-1.5"],
    );
    fails_with(
        &["render", lf, "--click", "64,3", "-o", out],
        &["outside the 64×64 view"],
    );
    fails_with(
        &[
            "render",
            lf,
            "--click",
            "5,5",
            "--normal-window",
            "8",
            "-o",
            out,
        ],
        &["odd"],
    );
    // A lone valid pixel among invalid ones.
    fails_with(
        &["render", lf, "--click", "1,1", "-o", out],
        &["no reliable normal", "neighbours"],
    );
    fails_with(
        &["render", lf, "--points", "20,20,20,20,40,40", "-o", out],
        &["coincide"],
    );
    fails_with(
        &["render", lf, "--points", "2,2,20,20,40,30", "-o", out],
        &["point 1", "NaN"],
    );
    fails_with(
        &[
            "render",
            lf,
            "--points-3d",
            "0,0,4,1,0,4,2,0.0000000001,4",
            "-o",
            out,
        ],
        &["collinear"],
    );
    fails_with(
        &[
            "render",
            lf,
            "--click",
            "20,20",
            "--nudge-tilt",
            "95",
            "-o",
            out,
        ],
        &["nudge", "tilt", "90"],
    );
    fails_with(
        &["render", lf, "--focus", "3", "--nudge-tilt", "5", "-o", out],
        &["--nudge-tilt"],
    );
    fails_with(
        &[
            "render",
            lf,
            "--click",
            "20,20",
            "--plane",
            "0,0,1,0,0,1",
            "-o",
            out,
        ],
        &["cannot be used with"],
    );
    fails_with(
        &["render", lf, "--click", "20", "-o", out],
        &["--click", "2"],
    );
    // Valid clicks on the same data work (the back plane at disparity −1).
    let o = tiltfield(&["render", lf, "--click", "20,20", "-o", out, "--json"]);
    let v = json_of(&o);
    assert_eq!(v["focus"]["depth_map"]["kind"], "disparity");
    assert!(angle_deg(v3(&v["plane"]["normal"]), DVec3::Z) < 0.01);
}

#[test]
fn a_light_field_without_depth_estimates_it_for_clicks_and_clouds() {
    let tmp = tempfile::tempdir().unwrap();
    let mut lf = two_planes(-1.0, 2.0);
    lf.depth.clear();
    lf.name = "nodepth".into();
    let path = tmp.path().join("nodepth").join(manifest::DEFAULT_NAME);
    manifest::write(&lf, &path).unwrap();
    let lf_arg = path.to_str().unwrap();
    let out = tmp.path().join("x.png");
    let out = out.to_str().unwrap();
    // The depth cache goes to the test's folder, not the user's.
    let cache = tmp.path().join("cache");
    let run = |args: &[&str]| tiltfield_cached(args, &cache);
    // Clicks and three clicks: depth estimated from the views (HCI convention: the manifest
    // declares its rig), reported as such, and the back plane (disparity −1) found.
    let v = json_of(&run(&[
        "render", lf_arg, "--click", "20,20", "-o", out, "--json",
    ]));
    assert_eq!(v["depth"]["origin"], "estimated");
    assert!(
        angle_deg(v3(&v["plane"]["normal"]), DVec3::Z) < 10.0,
        "{}",
        v["plane"]
    );
    let o = run(&[
        "render",
        lf_arg,
        "--points",
        // Three points of the back plane away from the image's corner rows, where the
        // estimate's confidence is lowest.
        "8,8,30,6,6,30",
        "-o",
        out,
        "--json",
    ]);
    let v = json_of(&o);
    assert_eq!(v["depth"]["cached"], true);
    let ply = tmp.path().join("c.ply");
    let v = json_of(&run(&[
        "cloud",
        lf_arg,
        "-o",
        ply.to_str().unwrap(),
        "--json",
    ]));
    assert_eq!(v["depth"]["origin"], "estimated");
    for args in [
        vec!["--plane", "0,0,4,0,0,1"],
        vec!["--focus", "4", "--tilt", "10"],
        vec!["--points-3d", "0,0,4,1,0,4,0,1,4.5"],
    ] {
        let mut all = vec!["render", lf_arg, "-o", out];
        all.extend(args);
        let o = tiltfield(&all);
        assert!(o.status.success(), "{all:?}: {}", stderr(&o));
    }
}

#[test]
fn cloud_writes_a_ply_that_a_ply_reader_parses() {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("sub/cloud.ply");
    let o = tiltfield(&[
        "cloud",
        "builtin:planes",
        "-o",
        path.to_str().unwrap(),
        "--click",
        "20,20",
        "--cameras",
        "--json",
    ]);
    let v = json_of(&o);
    assert_eq!(v["points"], 64 * 64);
    let mut f = std::fs::File::open(&path).unwrap();
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut f)
        .expect("ply-rs-bw parses the file");
    let vertices = &ply.payload["vertex"];
    assert_eq!(vertices.len(), 64 * 64 + 4 + 25);
    let faces = &ply.payload["face"];
    assert_eq!(faces.len(), 1);
    match &faces[0]["vertex_indices"] {
        Property::ListInt(ix) => assert_eq!(ix, &vec![4096, 4097, 4098, 4099]),
        other => panic!("{other:?}"),
    }
    let f32_of = |e: &DefaultElement, k: &str| match e[k] {
        Property::Float(x) => x as f64,
        ref other => panic!("{k}: {other:?}"),
    };
    let u8_of = |e: &DefaultElement, k: &str| match e[k] {
        Property::UChar(x) => x,
        ref other => panic!("{k}: {other:?}"),
    };
    // Every point against the back-projection of its pixel, normals against the scene.
    let lf = tiltfield::synth::builtin("planes").unwrap().light_field(2);
    let depth = lf.view_depth().unwrap();
    let image = &lf.views[depth.view].image;
    let mut with_normal = 0;
    for (i, e) in vertices.iter().take(64 * 64).enumerate() {
        let (x, y) = ((i % 64) as u32, (i / 64) as u32);
        let p = depth.point(x, y).unwrap();
        let q = DVec3::new(f32_of(e, "x"), f32_of(e, "y"), f32_of(e, "z"));
        assert!(
            (p - q).length() < 1e-5 * p.length(),
            "({x}, {y}): {p} vs {q}"
        );
        assert_eq!(u8_of(e, "red"), image.get_pixel(x, y).0[0]);
        let n = DVec3::new(f32_of(e, "nx"), f32_of(e, "ny"), f32_of(e, "nz"));
        let quality = f32_of(e, "quality");
        if n != DVec3::ZERO {
            assert!((n.length() - 1.0).abs() < 1e-5);
            assert!((0.0..=1.0).contains(&quality));
            // Both planes are frontoparallel; the guard keeps the 100 % depth jump at the
            // square's border from tilting any normal.
            assert!(angle_deg(n, -DVec3::Z) < 0.01, "({x}, {y}): {n}");
            with_normal += 1;
        }
    }
    assert!(with_normal as f64 > 0.98 * 4096.0, "{with_normal}");
    assert_eq!(v["points_with_normal"], with_normal);
    // The camera points sit at the grid positions.
    let cam0 = &vertices[64 * 64 + 4];
    assert!((f32_of(cam0, "x") - -0.2).abs() < 1e-6 && (f32_of(cam0, "y") - -0.2).abs() < 1e-6);
    assert_eq!(u8_of(cam0, "green"), 0);

    fails_with(
        &["cloud", "builtin:planes", "-o", "x.txt"],
        &["x.txt", ".ply"],
    );
    fails_with(
        &["cloud", "builtin:planes", "-o", "x.ply", "--stride", "0"],
        &["--stride"],
    );
}
