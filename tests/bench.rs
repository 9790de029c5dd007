//! `tiltfield bench` end to end (the quick scene, validation layer on): the JSON report has
//! the documented structure with every variant measured for speed and accuracy, the CSV has a
//! row per measurement, both charts are written as SVG (well-formed XML) and PNG (decodes,
//! drawn on); `render --filter bicubic --accumulation rgba16f` follows the bicubic model; and
//! bad options fail with clear messages. Speed is reported, never asserted.

mod common;

use common::*;
use serde_json::Value;
use tiltfield::bench::variant;

/// Checks that `text` is well-formed XML as far as tags go: every opened element is closed in
/// order; declarations, comments and self-closing tags are skipped.
fn assert_well_formed(text: &str) {
    let mut stack: Vec<String> = Vec::new();
    let mut rest = text;
    let mut elements = 0;
    while let Some(start) = rest.find('<') {
        rest = &rest[start..];
        if rest.starts_with("<!--") {
            let end = rest.find("-->").expect("comment closes");
            rest = &rest[end + 3..];
            continue;
        }
        let end = rest.find('>').expect("tag closes");
        let tag = &rest[1..end];
        rest = &rest[end + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            let open = stack
                .pop()
                .unwrap_or_else(|| panic!("</{name}> closes nothing"));
            assert_eq!(open, name.trim(), "mismatched closing tag");
        } else {
            elements += 1;
            let name = tag.split_whitespace().next().expect("tag name").to_string();
            if !tag.ends_with('/') {
                stack.push(name);
            }
        }
    }
    assert!(stack.is_empty(), "unclosed elements: {stack:?}");
    assert!(elements > 20, "only {elements} elements");
    assert!(text.contains("<svg"), "no <svg> root");
}

fn assert_png_drawn(path: &std::path::Path) {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8();
    assert!(img.width() >= 400 && img.height() >= 300);
    let colours: std::collections::BTreeSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    assert!(
        colours.len() > 20,
        "{}: {} colours",
        path.display(),
        colours.len()
    );
}

fn number(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is not a number in {v}"))
}

#[test]
fn quick_bench_writes_report_csv_and_both_charts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let o = tiltfield(&["bench", "--quick", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: Value =
        serde_json::from_slice(&std::fs::read(out.join("bench.json")).unwrap()).unwrap();
    for key in ["name", "driver", "api_version"] {
        assert!(report["device"][key].is_string(), "device.{key}");
    }
    let lf = &report["light_field"];
    assert_eq!(lf["synthetic"], true);
    assert!(lf["views_used"].as_u64().unwrap() >= 9);
    // The anti-aliasing study: the plain sum first (cost ratio 1), then each cap, timed in the
    // same run; anti-aliasing beats the plain sum off the focus plane against the lens.
    let aa = report["antialias"]["points"]
        .as_array()
        .expect("antialias points");
    assert_eq!(aa[0]["name"], "plain");
    assert_eq!(number(&aa[0], "cost_ratio"), 1.0);
    let aa4 = aa.iter().find(|p| p["name"] == "aa4").expect("aa4");
    assert!(number(aa4, "cost_ratio") > 0.0);
    assert!(
        number(aa4, "psnr_out_of_focus_db") > number(&aa[0], "psnr_out_of_focus_db") + 3.0,
        "{aa4} vs {}",
        aa[0]
    );
    // One prefiltered sub-sample per view integrates its footprint where one full-resolution
    // fetch (area weights only) still draws the lattice (quick scene, footprints of at most
    // 3 px: measured +1.2 dB; +6.5 dB at 128 px).
    let aa1 = aa.iter().find(|p| p["name"] == "aa1").expect("aa1");
    let sharp = aa
        .iter()
        .find(|p| p["name"] == "aa1-sharp")
        .expect("aa1-sharp");
    assert_eq!(aa1["prefilter"], true);
    assert!(
        number(aa1, "psnr_out_of_focus_db") > number(sharp, "psnr_out_of_focus_db") + 0.5,
        "{aa1} vs {sharp}"
    );
    // The footprint routes are points of their own, named by route (the chart's lines join
    // only the sub-sampling settings); layered footprints integrate like the sub-samples
    // out of focus (quick scene: measured 36.9 against aa4's 37.1 and plain's 31.8 dB).
    for route in ["boxed", "layered", "defocus"] {
        let p = aa.iter().find(|p| p["name"] == route).expect(route);
        assert_eq!(p["route"], route, "{p}");
        assert!(
            number(p, "psnr_out_of_focus_db") > number(&aa[0], "psnr_out_of_focus_db") + 3.0,
            "{p} vs {}",
            aa[0]
        );
    }
    assert!(aa4["route"].is_null(), "{aa4}");
    let variants = report["variants"].as_array().expect("variants");
    let names: Vec<&str> = variants
        .iter()
        .map(|v| v["name"].as_str().unwrap())
        .collect();
    for v in variant::catalogue() {
        assert!(names.contains(&v.name().as_str()), "{} missing", v.name());
    }
    assert_eq!(variants.iter().filter(|v| v["default"] == true).count(), 1);
    for v in variants {
        for key in ["name", "strategy", "filter", "storage", "accumulation"] {
            assert!(v[key].is_string(), "{key} in {v}");
        }
        for key in ["views", "width", "height"] {
            assert!(v[key].as_u64().unwrap() > 0, "{key} in {v}");
        }
        let (med, min, max) = (
            number(v, "gpu_ms_median"),
            number(v, "gpu_ms_min"),
            number(v, "gpu_ms_max"),
        );
        assert!(min > 0.0 && min <= med && med <= max, "{v}");
        let expected = number(v, "views") * number(v, "width") * number(v, "height") / (med / 1e3);
        assert!((number(v, "samples_per_s") / expected - 1.0).abs() < 1e-9);
        assert!(number(v, "psnr_vs_reference_db") > 10.0, "{v}");
        assert!(number(v, "max_error_vs_reference") >= 0.0);
        assert_eq!(v["within_bound"], true, "{v}");
        // Synthetic scene: the key is there; a number for full-size outputs.
        let truth = &v["psnr_vs_truth_db"];
        if v["width"] == lf["view_size"][0] {
            assert!(truth.as_f64().unwrap() > 10.0, "{v}");
        } else {
            assert!(truth.is_null(), "{v}");
        }
    }
    let scaling = report["scaling"].as_array().expect("scaling");
    assert!(scaling.len() >= 4);
    let views: std::collections::BTreeSet<u64> = scaling
        .iter()
        .map(|p| p["views"].as_u64().unwrap())
        .collect();
    assert!(views.len() >= 2, "the sweep varies the views");
    assert!(report["scaling_fit"]["ns_per_sample"].is_number());
    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 1 + variants.len() + scaling.len());
    let columns = lines[0].split(',').count();
    assert!(lines[0].starts_with("kind,name,"));
    for l in &lines[1..] {
        // Quoted names have no commas here, so a plain split counts the fields.
        assert_eq!(l.split(',').count(), columns, "{l}");
    }
    for chart in ["speed_accuracy", "scaling", "antialias"] {
        let svg = std::fs::read_to_string(out.join(format!("{chart}.svg"))).unwrap();
        assert_well_formed(&svg);
        assert!(svg.contains("PSNR") || chart == "scaling");
        assert_png_drawn(&out.join(format!("{chart}.png")));
    }
    // The anti-aliasing chart labels every setting of the study, with its cost.
    let svg = std::fs::read_to_string(out.join("antialias.svg")).unwrap();
    for p in aa {
        let name = p["name"].as_str().unwrap();
        assert!(
            svg.contains(&format!("{name} ×")),
            "{name} not on the chart"
        );
    }
    let hs: Value =
        serde_json::from_slice(&std::fs::read(out.join("homographies.json")).unwrap()).unwrap();
    assert_eq!(
        hs["views"].as_array().unwrap().len() as u64,
        lf["views_used"].as_u64().unwrap()
    );
}

#[test]
fn chosen_variants_only_and_no_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let o = tiltfield(&[
        "bench",
        "--quick",
        "--no-scaling",
        "--frames",
        "2",
        "--variants",
        "compute/bicubic,r1/nearest",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let report = json_of(&o);
    let names: Vec<&str> = report["variants"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "compute/bicubic/linear16/rgba32f",
            "fragment/nearest/linear16/rgba32f/r1"
        ]
    );
    assert_eq!(report["variants"][1]["frames"], 2);
    assert!(report["scaling"].as_array().unwrap().is_empty());
    assert!(out.join("speed_accuracy.png").is_file());
    assert!(
        !out.join("scaling.svg").exists(),
        "no sweep, no scaling chart"
    );
    if report["antialias"].is_null() {
        assert!(
            !out.join("antialias.svg").exists(),
            "no study, no anti-aliasing chart"
        );
    }
}

#[test]
fn bad_bench_options_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let out = out.to_str().unwrap();
    fails_with(
        &[
            "bench",
            "--quick",
            "--variants",
            "compute/bogus",
            "--out",
            out,
        ],
        &["unknown token 'bogus'"],
    );
    fails_with(
        &["bench", "--quick", "--frames", "0", "--out", out],
        &["--frames 0"],
    );
    fails_with(
        &["bench", "--quick", "--variants", "x9", "--out", out],
        &["output scale"],
    );
    fails_with(
        &["bench", "--quick", "--peak-gbps", "0", "--out", out],
        &["--peak-gbps must be positive"],
    );
    let file = dir.path().join("file");
    std::fs::write(&file, b"x").unwrap();
    fails_with(
        &["bench", "--quick", "--out", file.to_str().unwrap()],
        &["output folder is a file"],
    );
    fails_with(
        &["bench", "--quick", "--disparity", "1", "--out", out],
        &["focus options need a light field"],
    );
    fails_with(
        &["bench", "--quick", "--frame", "3", "--out", out],
        &["--frame needs a camera-array video"],
    );
}

#[test]
fn render_bicubic_with_half_float_accumulation_follows_the_bicubic_model() {
    use tiltfield::refocus::cpu::{self, Kernel};
    use tiltfield::refocus::{self, Averaging, FocusSpec};
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("bicubic.png");
    let o = tiltfield(&[
        "render",
        "builtin:tilted",
        "--disparity",
        "0.37",
        "--filter",
        "bicubic",
        "--accumulation",
        "rgba16f",
        // The plain sum's model (the light field ships depth, so anti-aliasing would be on).
        "--antialias",
        "off",
        "-o",
        png.to_str().unwrap(),
        "--json",
    ]);
    let j = json_of(&o);
    assert_eq!(j["filter"], "bicubic");
    assert_eq!(j["accumulation"], "rgba16f");
    let gpu = image::open(&png).unwrap().to_rgba8();
    let lf = builtin("tilted");
    let plan = refocus::plan(&lf, &request(FocusSpec::Disparity(0.37)), &[]).unwrap();
    let (w, h) = (lf.width, lf.height);
    let model = cpu::render_with(&lf, &plan, Averaging::Linear, w, h, Kernel::Bicubic).to_srgb8();
    let bilinear = cpu::render(&lf, &plan, Averaging::Linear).to_srgb8();
    let max_diff = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels()
            .zip(b.pixels())
            .flat_map(|(p, q)| (0..3).map(move |k| (p.0[k] as i32 - q.0[k] as i32).abs()))
            .max()
            .unwrap()
    };
    assert!(max_diff(&gpu, &model) <= 1, "vs bicubic model");
    assert!(
        max_diff(&gpu, &bilinear) >= 3,
        "bicubic should differ from bilinear"
    );
    fails_with(
        &[
            "render",
            "builtin:tilted",
            "--disparity",
            "0",
            "--accumulation",
            "rgba8",
            "-o",
            png.to_str().unwrap(),
        ],
        &["rgba8"],
    );
}
