//! The `tiltfield` binary end to end: the documented command forms work, and every bad input
//! exits non-zero with one clear message naming the cause (never a panic or backtrace).
//! GPU runs use the validation layer (TILTFIELD_VALIDATION=1), and `render` fails on any
//! validation error.

mod common;

use std::path::Path;
use std::process::Command;

use common::{fails_with, stderr, tiltfield};

use tiltfield::lightfield::hci;

/// Writes the two-plane scene (back plane at disparity −1, card at +2) in the exact HCI
/// layout into `dir`.
fn write_hci(dir: &Path) -> tiltfield::lightfield::LightField {
    let lf = common::two_planes(-1.0, 2.0);
    let cfg = hci::config_for(&lf, &common::TWO_PLANE_RIG, 36.0);
    hci::write(&lf, &cfg, dir).expect("write HCI layout");
    lf
}

#[test]
fn render_writes_png_and_exr_and_reports_json() {
    let tmp = tempfile::tempdir().unwrap();
    let png = tmp.path().join("out/refocus.png");
    let o = tiltfield(&[
        "render",
        "builtin:planes",
        "--disparity",
        "-0.667",
        "-o",
        png.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
    assert_eq!(report["method"], "hci-disparity");
    assert_eq!(report["views_used"], 25);
    let n = &report["plane"]["normal"];
    assert_eq!(
        (n[0].as_f64(), n[1].as_f64(), n[2].as_f64()),
        (Some(0.0), Some(0.0), Some(1.0))
    );
    let z = report["plane"]["point"][2].as_f64().unwrap();
    assert!(
        (z - 4.0).abs() < 0.01,
        "disparity −0.667 is the plane z = 4, got {z}"
    );
    let img = image::open(&png).expect("PNG readable").to_rgba8();
    assert_eq!(img.dimensions(), (64, 64));

    let exr = tmp.path().join("refocus.exr");
    let o = tiltfield(&[
        "render",
        "builtin:planes",
        "--focus",
        "3",
        "--tilt",
        "20",
        "--swing",
        "-10",
        "-o",
        exr.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let read = exr::prelude::read_first_rgba_layer_from_file(
        &exr,
        |res, _| vec![[0f32; 4]; res.width() * res.height()],
        |px: &mut Vec<[f32; 4]>, pos, (r, g, b, a): (f32, f32, f32, f32)| {
            px[pos.y() * 64 + pos.x()] = [r, g, b, a];
        },
    )
    .expect("EXR readable");
    let px = read.layer_data.channel_data.pixels;
    assert!(px.iter().flatten().all(|v| v.is_finite()));
    // Linear light in [0, 1] with full coverage.
    assert!(px.iter().all(|p| p[3] == 1.0 && p[0] >= 0.0 && p[0] <= 1.0));
}

#[test]
fn hci_folder_refocus_brings_the_disparity_d_content_into_focus() {
    let tmp = tempfile::tempdir().unwrap();
    let lf = write_hci(tmp.path());
    let o = tiltfield(&["info", tmp.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("5 × 5 views") && text.contains("64 × 64 px") && text.contains("disparity"),
        "{text}"
    );

    // Ground-truth disparity of the back plane from the written PFM, read back by the loader.
    let loaded = tiltfield::lightfield::open(tmp.path(), &Default::default()).unwrap();
    let (_, disp) = loaded
        .depth
        .iter()
        .find(|(_, d)| d.kind == tiltfield::lightfield::DepthKind::Disparity)
        .expect("gt_disp_lowres.pfm loaded");
    let d_back = disp.at(5, 5) as f64;
    assert!((d_back - -1.0).abs() < 1e-4, "ground truth says {d_back}");
    assert!((disp.at(50, 50) as f64 - 2.0).abs() < 1e-4);
    assert_eq!(lf.views.len(), loaded.views.len());

    let centre = image::open(tmp.path().join("input_Cam012.png"))
        .unwrap()
        .to_rgba8();
    let psnr_at = |d: f64| {
        let out = tmp.path().join(format!("d{d}.png"));
        let o = tiltfield(&[
            "render",
            tmp.path().to_str().unwrap(),
            "--disparity",
            &d.to_string(),
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let img = image::open(&out).unwrap().to_rgba8();
        let mut se = 0f64;
        for y in 6..30 {
            for x in 6..30 {
                for k in 0..3 {
                    let e = img.get_pixel(x, y).0[k] as f64 - centre.get_pixel(x, y).0[k] as f64;
                    se += e * e;
                }
            }
        }
        10.0 * (255.0f64.powi(2) * (24.0 * 24.0 * 3.0) / se.max(1e-9)).log10()
    };
    // Focused at its ground-truth disparity the back plane reproduces the centre view; the
    // opposite sign (a flipped convention) or a missing sensor shift (disparity 0) does not.
    let (at_d, at_minus_d, at_zero) = (psnr_at(d_back), psnr_at(-d_back), psnr_at(0.0));
    eprintln!("back plane: {at_d:.1} dB at d, {at_minus_d:.1} dB at −d, {at_zero:.1} dB at 0");
    assert!(at_d > 40.0, "{at_d:.1} dB");
    assert!(at_minus_d < 30.0 && at_zero < 30.0);
}

#[test]
fn info_and_demo_run() {
    let o = tiltfield(&["info", "builtin:planes", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["grid"]["views"], 25);
    let o = tiltfield(&["demo", "--list"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("builtin:demo"));
    let tmp = tempfile::tempdir().unwrap();
    let o = tiltfield(&[
        "demo",
        "--scene",
        "planes",
        "-o",
        tmp.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("demo.json")).unwrap())
            .unwrap();
    let images = summary["images"].as_array().unwrap();
    assert!(images.len() >= 3);
    for i in images {
        assert!(Path::new(i["file"].as_str().unwrap()).is_file());
    }
    // Built-in scenes have exact depth: their refocus images are anti-aliased.
    assert_eq!(images[1]["antialias"]["used"], true, "{}", images[1]);
}

#[test]
fn bad_command_lines_fail_clearly() {
    fails_with(
        &["render", "builtin:planes", "-o", "x.png"],
        &["--disparity"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "1",
            "--focus",
            "2",
            "-o",
            "x.png",
        ],
        &["cannot be used with"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "1",
            "-o",
            "x.jpg",
        ],
        &["x.jpg", ".png", ".exr"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--plane",
            "0,0,1,0,0",
            "-o",
            "x.png",
        ],
        &["--plane", "6"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--plane",
            "0,0,0,1,0,0",
            "-o",
            "x.png",
        ],
        &["passes through the reference camera"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--plane",
            "0,0,2,0,0,0",
            "-o",
            "x.png",
        ],
        &["zero length"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "--aperture-radius",
            "0",
            "--view",
            "1.5,1.5",
            "-o",
            "x.png",
        ],
        &["no usable view"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "--view",
            "9,0",
            "-o",
            "x.png",
        ],
        &["outside the grid"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "--aperture",
            "hexagon",
            "-o",
            "x.png",
        ],
        &["hexagon"],
    );
    fails_with(
        &[
            "render",
            "builtin:nothing",
            "--disparity",
            "0",
            "-o",
            "x.png",
        ],
        &["nothing", "demo"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--focus",
            "2",
            "--tilt",
            "90",
            "-o",
            "x.png",
        ],
        &["tilt"],
    );
}

#[test]
fn devices_are_listed_and_selectable_by_index_or_name() {
    let o = tiltfield(&["devices"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let listing = String::from_utf8_lossy(&o.stdout).into_owned();
    let first = listing.lines().next().expect("at least one device");
    // "0: NAME [kind, ...]": select it by index and by a part of its name.
    let name = first
        .split_once(": ")
        .unwrap()
        .1
        .split(" [")
        .next()
        .unwrap();
    let word = name.split_whitespace().next().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x.png");
    for sel in ["0", word] {
        let o = tiltfield(&[
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "--device",
            sel,
            "--json",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "--device {sel}: {}", stderr(&o));
        let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(r["device"], name, "--device {sel}");
    }
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "--device",
            "no-such-gpu",
            "-o",
            out.to_str().unwrap(),
        ],
        &["no Vulkan device matches 'no-such-gpu'", name],
    );
}

#[test]
fn a_missing_vulkan_driver_is_a_clear_error() {
    let o = Command::new(env!("CARGO_BIN_EXE_tiltfield"))
        .args([
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "-o",
            "unused.png",
        ])
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(err.contains("vulkan") && err.contains("driver"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_light_fields_fail_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("nope");
    fails_with(&["info", missing.to_str().unwrap()], &["nope"]);

    let dir = tmp.path().join("hci");
    write_hci(&dir);
    let d = dir.to_str().unwrap();
    // Truncated view.
    let cam = dir.join("input_Cam007.png");
    let bytes = std::fs::read(&cam).unwrap();
    std::fs::write(&cam, &bytes[..bytes.len() / 2]).unwrap();
    fails_with(&["info", d], &["input_Cam007.png"]);
    std::fs::write(&cam, &bytes).unwrap();
    // Missing view.
    std::fs::rename(&cam, dir.join("moved.png")).unwrap();
    fails_with(&["info", d], &["input_Cam007.png"]);
    std::fs::rename(dir.join("moved.png"), &cam).unwrap();
    // Wrong size.
    image::RgbaImage::new(32, 64).save(&cam).unwrap();
    fails_with(&["info", d], &["input_Cam007.png", "32"]);
    std::fs::write(&cam, &bytes).unwrap();
    // Malformed parameters.cfg.
    let cfg_path = dir.join("parameters.cfg");
    let cfg = std::fs::read_to_string(&cfg_path).unwrap();
    std::fs::write(
        &cfg_path,
        cfg.replace("baseline_mm = ", "baseline_mm = abc"),
    )
    .unwrap();
    fails_with(&["info", d], &["parameters.cfg", "baseline_mm"]);
    let without: String = cfg
        .lines()
        .filter(|l| !l.starts_with("num_cams_x"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&cfg_path, without).unwrap();
    fails_with(&["info", d], &["parameters.cfg", "num_cams_x"]);
    std::fs::write(&cfg_path, &cfg).unwrap();
    // Truncated ground-truth disparity.
    let pfm = dir.join("gt_disp_lowres.pfm");
    let bytes = std::fs::read(&pfm).unwrap();
    std::fs::write(&pfm, &bytes[..bytes.len() - 100]).unwrap();
    fails_with(&["info", d], &["gt_disp_lowres.pfm"]);
    std::fs::write(&pfm, &bytes).unwrap();
    // And intact again, it loads.
    assert!(tiltfield(&["info", d]).status.success());
}

/// By default (`--antialias-layered auto`) a light field that ships its depth is anti-aliased
/// with layered footprints on one plane at the views' size; a focus surface and a scaled output
/// take boxed footprints and sub-samples instead (and render), and so does `off`.
#[test]
fn the_default_takes_layered_footprints_where_the_depth_is_shipped() {
    let tmp = tempfile::tempdir().unwrap();
    let report = |extra: &[&str]| -> serde_json::Value {
        let png = tmp.path().join("x.png");
        let mut args = vec![
            "render",
            "builtin:planes",
            "-o",
            png.to_str().unwrap(),
            "--json",
        ];
        args.extend_from_slice(extra);
        let o = tiltfield(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        let r: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
        assert_eq!(r["antialias"]["used"], true, "{extra:?}: {r}");
        r
    };
    let plane = report(&["--disparity", "-0.667"]);
    assert_eq!(plane["antialias"]["layered"], true, "{plane}");
    let routes = [
        vec!["--all-in-focus"],
        vec!["--disparity", "-0.667", "--size", "40x40"],
        vec!["--disparity", "-0.667", "--antialias-layered", "off"],
    ];
    for extra in routes {
        let r = report(&extra);
        assert_eq!(r["antialias"]["layered"], false, "{extra:?}: {r}");
        assert_eq!(r["antialias"]["occlusion"], true, "{extra:?}: {r}");
    }
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "--antialias-layered",
            "maybe",
        ],
        &["--antialias-layered", "auto"],
    );
}

/// `--antialias-layered on` renders a shipped-depth light field with layered footprints and
/// reports it; asked together with defocused views it is refused, naming both switches; a
/// focus surface, naming the switch to turn off; an output of another size, naming the views'.
#[test]
fn layered_antialiasing_renders_and_refuses_what_it_cannot_do() {
    let tmp = tempfile::tempdir().unwrap();
    let out = |name: &str| tmp.path().join(name).to_str().unwrap().to_owned();
    // render builtin:planes with layered anti-aliasing, `extra` after the switches.
    let layered = |extra: &[&str]| -> Vec<String> {
        [
            "render",
            "builtin:planes",
            "--antialias",
            "on",
            "--antialias-layered",
            "on",
        ]
        .iter()
        .chain(extra)
        .map(|a| a.to_string())
        .collect()
    };
    fn args(v: &[String]) -> Vec<&str> {
        v.iter().map(String::as_str).collect()
    }
    let png = out("layered.png");
    let run = layered(&["--disparity", "-0.667", "-o", &png, "--json"]);
    let o = tiltfield(&args(&run));
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
    assert_eq!(report["antialias"]["layered"], true, "{report}");
    assert_eq!(report["antialias"]["occlusion"], false, "{report}");
    let img = image::open(&png).unwrap().to_rgba8();
    assert!(img.pixels().all(|p| p[3] == 255));
    let x = out("x.png");
    let both = layered(&[
        "--disparity",
        "-0.667",
        "--antialias-defocus",
        "on",
        "-o",
        &x,
    ]);
    fails_with(
        &args(&both),
        &["--antialias-layered", "--antialias-defocus"],
    );
    let y = out("y.png");
    let surface = layered(&["--all-in-focus", "-o", &y]);
    fails_with(&args(&surface), &["layered", "--antialias-layered off"]);
    // An output of another size than the views: refused, naming the views' size.
    let z = out("z.png");
    let scaled = layered(&["--disparity", "-0.667", "--size", "40x40", "-o", &z]);
    fails_with(&args(&scaled), &["layered", "views' size"]);
}
