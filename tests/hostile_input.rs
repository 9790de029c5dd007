//! Hostile input (issue 13): malformed files, absurd numbers and odd paths end in one clear
//! error naming the cause, or a warning where the input is legitimate — never a panic, a hang,
//! NaN pixels, a silent subset, or an allocation the input does not justify. Sizes and counts
//! are checked before anything is allocated, decoded, rendered or written, so none of these
//! tests allocates much: the refusals come first.

mod common;

use std::path::{Path, PathBuf};

use common::{fails_with, stderr, tiltfield};
use glam::DVec2;
use serde_json::{json, Value};
use tiltfield::geometry::aperture::{Aperture, ApertureShape};
use tiltfield::lightfield::{self, LoadLimits};

// ---------------------------------------------------------------------------------------------
// Small inputs written from scratch: 8×8 views, a few views per grid.

const W: u32 = 8;

fn png(path: &Path, shade: u8) {
    let img = image::RgbImage::from_fn(W, W, |x, y| {
        image::Rgb([shade, (x * 30) as u8, (y * 30) as u8])
    });
    img.save(path).unwrap();
}

/// An HCI folder of `cols × rows` 8×8 views; `views` files `input_Cam*.png` are written (at
/// least `cols · rows`).
fn hci_folder(dir: &Path, cols: usize, rows: usize, views: usize, baseline_mm: &str) {
    let count = cols * rows;
    for i in 0..views {
        png(
            &dir.join(lightfield::hci::view_file_name(i, count)),
            40 + i as u8,
        );
    }
    std::fs::write(
        dir.join("parameters.cfg"),
        format!(
            "[intrinsics]\nfocal_length_mm = 50\nimage_resolution_x_px = {W}\n\
             image_resolution_y_px = {W}\nsensor_size_mm = 36\n\n[extrinsics]\n\
             num_cams_x = {cols}\nnum_cams_y = {rows}\nbaseline_mm = {baseline_mm}\n\
             focus_distance_m = 3\n"
        ),
    )
    .unwrap();
}

fn identity() -> Value {
    json!([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
}

/// A manifest value for a `cols × rows` grid whose views all use the image `image`.
fn manifest_value(cols: usize, rows: usize, image: &str) -> Value {
    let views: Vec<Value> = (0..rows)
        .flat_map(|t| (0..cols).map(move |s| (s, t)))
        .map(|(s, t)| {
            json!({
                "image": image,
                "grid": {"s": s, "t": t},
                "K": [[10.0, 0.0, 3.5], [0.0, 10.0, 3.5], [0.0, 0.0, 1.0]],
                "R": identity(),
                "centre": [s as f64 * 0.1, t as f64 * 0.1, 0.0],
            })
        })
        .collect();
    json!({"version": 1, "views": views})
}

fn write_json(path: &Path, v: &Value) {
    std::fs::write(path, serde_json::to_string_pretty(v).unwrap()).unwrap();
}

/// A 3×3 manifest folder with one real 8×8 image; returns the manifest path.
fn manifest_folder(dir: &Path) -> PathBuf {
    png(&dir.join("v.png"), 100);
    let path = dir.join("tiltfield.json");
    write_json(&path, &manifest_value(3, 3, "v.png"));
    path
}

fn open_err(path: &Path) -> String {
    match lightfield::open(path, &Default::default()) {
        Ok(_) => panic!("{} should be refused", path.display()),
        Err(e) => e.to_string(),
    }
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Bytes of a PNG whose header declares `w × h` but holds no image data (a valid signature
/// and IHDR chunk with a correct CRC).
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    let mut out = vec![0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]);
    // The decoder reads the header up to the first IDAT; this one holds no valid data.
    for (kind, data) in [(b"IHDR", ihdr), (b"IDAT", vec![0; 4]), (b"IEND", vec![])] {
        let mut chunk = kind.to_vec();
        chunk.extend_from_slice(&data);
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        out.extend_from_slice(&chunk);
        out.extend_from_slice(&crc32(&chunk).to_be_bytes());
    }
    out
}

// ---------------------------------------------------------------------------------------------
// glTF built from JSON with an embedded buffer.

/// A one-mesh glTF: `positions`, u16 `indices` stored in the buffer, and an index accessor
/// declaring `index_count`; `node` is merged into node 0; `position_offset` is the POSITION
/// accessor's byte offset.
fn gltf_file(
    dir: &Path,
    positions: &[[f32; 3]],
    indices: &[u16],
    index_count: usize,
    node: Value,
    position_offset: usize,
) -> PathBuf {
    let mut bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let pos_len = bytes.len();
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    while bytes.len() % 4 != 0 {
        bytes.push(0);
    }
    let lo: Vec<f32> = (0..3)
        .map(|k| positions.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min))
        .collect();
    let hi: Vec<f32> = (0..3)
        .map(|k| {
            positions
                .iter()
                .map(|p| p[k])
                .fold(f32::NEG_INFINITY, f32::max)
        })
        .collect();
    let mut node0 = json!({"mesh": 0});
    if let (Some(n), Some(extra)) = (node0.as_object_mut(), node.as_object()) {
        n.extend(extra.clone());
    }
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [node0],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{
            "byteLength": bytes.len(),
            "uri": format!("data:application/octet-stream;base64,{}", common::base64(&bytes)),
        }],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pos_len},
            {"buffer": 0, "byteOffset": pos_len, "byteLength": indices.len() * 2},
        ],
        "accessors": [
            {"bufferView": 0, "byteOffset": position_offset, "componentType": 5126,
             "count": positions.len(), "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5123, "count": index_count, "type": "SCALAR"},
        ],
    });
    let path = dir.join("scene.gltf");
    write_json(&path, &doc);
    path
}

/// Two triangles of a unit quad at z = 0, scaled by `scale`.
fn quad(scale: f32) -> Vec<[f32; 3]> {
    [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ]
    .map(|p: [f32; 3]| p.map(|v| v * scale))
    .to_vec()
}

const QUAD_INDICES: [u16; 6] = [0, 1, 2, 0, 2, 3];

fn gltf_err(path: &Path) -> String {
    match tiltfield::synth::gltf::load(path) {
        Ok(_) => panic!("{} should be refused", path.display()),
        Err(e) => e.to_string(),
    }
}

// ---------------------------------------------------------------------------------------------
// Crashes and hangs.

#[test]
fn synth_sizes_and_counts_are_checked_before_allocating() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o = s(&out);
    let synth = |extra: &[&str], needles: &[&str]| {
        let mut args = vec!["synth", "builtin:planes", "--out", o];
        args.extend_from_slice(extra);
        fails_with(&args, needles);
    };
    // Used to overflow (a panic) or abort on allocation failure.
    synth(
        &["--size", "100000x100000"],
        &["--size 100000x100000", "at most"],
    );
    synth(
        &["--size", "20000x20000"],
        &["--size 20000x20000", "at most"],
    );
    synth(
        &["--grid", "100000x100000"],
        &["--grid 100000x100000", "at most"],
    );
    synth(&["--samples", "100000"], &["--samples", "got 100000"]);
    // Used to render 1×1 samples silently.
    synth(&["--samples", "0"], &["--samples", "got 0"]);
    // Used to write 13 files first.
    synth(
        &["--disparity", "0.5", "--gt-samples", "100000"],
        &["--gt-samples", "got 100000"],
    );
    // Used to write the whole light field, then fail.
    synth(&["--disparity", "nan"], &["finite"]);
    assert!(
        !out.exists(),
        "nothing may be written before the options are checked"
    );
}

#[test]
fn gltf_node_that_is_its_own_child_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let p = gltf_file(
        tmp.path(),
        &quad(1.0),
        &QUAD_INDICES,
        6,
        json!({"children": [0]}),
        0,
    );
    let msg = gltf_err(&p);
    assert!(
        msg.contains("node 0 is reached twice") && msg.contains("cycle"),
        "{msg}"
    );
}

#[test]
fn render_repeat_is_bounded_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("r.png");
    // The light field does not exist: the bound must be checked before loading anything.
    fails_with(
        &[
            "render",
            "no-such-folder",
            "--disparity",
            "0",
            "-o",
            s(&out),
            "--repeat",
            "1000000",
        ],
        &["--repeat 1000000", "10000"],
    );
}

// ---------------------------------------------------------------------------------------------
// Nonsense accepted silently.

#[test]
fn tiny_gaussian_aperture_gives_the_centre_view_weight_one_not_nan() {
    let a = Aperture {
        shape: ApertureShape::Gaussian,
        radius: Some(1e-300),
    };
    let c = DVec2::new(2.0, 2.0);
    assert_eq!(a.weight(c, c, 5, 5), 1.0);
    assert_eq!(a.weight(DVec2::new(3.0, 2.0), c, 5, 5), 0.0);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("g.png");
    let o = tiltfield(&[
        "render",
        "builtin:planes",
        "--disparity",
        "0",
        "--aperture",
        "gaussian",
        "--aperture-radius",
        "1e-300",
        "-o",
        s(&out),
        "--json",
    ]);
    let report = common::json_of(&o);
    assert_eq!(report["views_used"], 1, "{report}");
    assert_eq!(report["uncovered_pixels"], 0, "{report}");
    let img = image::open(&out).unwrap().to_rgba8();
    assert!(img.pixels().all(|p| p.0[3] == 255), "transparent pixels");
}

#[test]
fn hci_folder_with_more_views_than_declared_warns_naming_the_extra_files() {
    for (cols, rows, expected) in [(2, 3, "input_Cam006.png"), (1, 1, "input_Cam001.png")] {
        let tmp = tempfile::tempdir().unwrap();
        hci_folder(tmp.path(), cols, rows, 9, "10");
        let o = tiltfield(&["info", s(tmp.path())]);
        assert!(o.status.success(), "{}", stderr(&o));
        let err = stderr(&o);
        assert!(
            err.contains("ignored") && err.contains(expected) && err.contains("input_Cam008.png"),
            "{cols}×{rows}: {err}"
        );
    }
}

#[test]
fn manifest_that_exists_but_cannot_be_read_is_an_error_not_a_grid_folder() {
    let tmp = tempfile::tempdir().unwrap();
    // Grid-named views that a grid folder would happily load.
    for (s_, t) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
        png(&tmp.path().join(format!("view_{s_}_{t}.png")), 90);
    }
    std::fs::create_dir(tmp.path().join("tiltfield.json")).unwrap();
    let msg = open_err(tmp.path());
    assert!(
        msg.contains("tiltfield.json") && msg.contains("folder"),
        "{msg}"
    );

    std::fs::remove_dir(tmp.path().join("tiltfield.json")).unwrap();
    std::os::unix::fs::symlink("tiltfield.json", tmp.path().join("tiltfield.json")).unwrap();
    let msg = open_err(tmp.path());
    assert!(
        msg.contains("tiltfield.json") && msg.contains("cannot be read"),
        "{msg}"
    );
}

#[test]
fn manifest_numbers_that_describe_no_camera_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let path = manifest_folder(tmp.path());
    let mut m = manifest_value(3, 3, "v.png");
    m["views"][4]["K"][0][0] = json!(1e300);
    write_json(&path, &m);
    let msg = open_err(&path);
    assert!(msg.contains("view 4") && msg.contains("1e300"), "{msg}");

    let mut m = manifest_value(3, 3, "v.png");
    m["views"][2]["centre"] = json!([0.0, 1e300, 0.0]);
    write_json(&path, &m);
    let msg = open_err(&path);
    assert!(msg.contains("view 2") && msg.contains("1e300"), "{msg}");
}

#[test]
fn gltf_geometry_that_describes_no_mesh_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    // Quads at ±1e30.
    let p = gltf_file(d, &quad(1e30), &QUAD_INDICES, 6, json!({}), 0);
    let msg = gltf_err(&p);
    assert!(msg.contains("beyond"), "{msg}");
    // An index accessor longer than its buffer view (the second triangle was dropped).
    let p = gltf_file(d, &quad(1.0), &QUAD_INDICES[..4], 6, json!({}), 0);
    let msg = gltf_err(&p);
    assert!(msg.contains("index accessor 1"), "{msg}");
    // Not a multiple of three.
    let p = gltf_file(d, &quad(1.0), &QUAD_INDICES[..4], 4, json!({}), 0);
    let msg = gltf_err(&p);
    assert!(msg.contains("not a multiple of three"), "{msg}");
    // A zero rotation quaternion collapses the mesh to a point.
    let p = gltf_file(
        d,
        &quad(1.0),
        &QUAD_INDICES,
        6,
        json!({"rotation": [0, 0, 0, 0]}),
        0,
    );
    let msg = gltf_err(&p);
    assert!(
        msg.contains("node 0") && msg.contains("quaternion"),
        "{msg}"
    );
    // Two inputs that panicked inside the gltf crate (found by tests/parser_fuzz.rs): an
    // accessor of count 0, and a binary glTF whose header declares a length of 0.
    let p = gltf_file(d, &quad(1.0), &QUAD_INDICES, 0, json!({}), 0);
    let msg = gltf_err(&p);
    assert!(msg.contains("accessor 1 has a count of 0"), "{msg}");
    let glb = d.join("empty.glb");
    std::fs::write(&glb, b"glTF\x02\0\0\0\0\0\0\0").unwrap();
    let msg = gltf_err(&glb);
    assert!(msg.contains("declares 0 bytes"), "{msg}");
    // A POSITION accessor that lies outside its buffer view.
    let p = gltf_file(d, &quad(1.0), &QUAD_INDICES, 6, json!({}), 64);
    let msg = gltf_err(&p);
    assert!(
        msg.contains("POSITION accessor 0") && !msg.contains("no POSITION"),
        "{msg}"
    );
}

#[test]
fn too_many_views_for_the_device_are_refused_before_decoding() {
    let tmp = tempfile::tempdir().unwrap();
    // Every view is a valid header with no pixel data: decoding any of them would fail, so
    // the device-limit error proves the check comes first.
    std::fs::write(tmp.path().join("v.png"), png_header_only(W, W)).unwrap();
    let path = tmp.path().join("tiltfield.json");
    write_json(&path, &manifest_value(5, 5, "v.png"));
    let limits = LoadLimits::for_device(16, 4096, 1 << 30, "a small GPU");
    let err = lightfield::open_within(&path, &Default::default(), &limits).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("device limit") && msg.contains("25 views") && msg.contains("16 layers"),
        "{msg}"
    );
    // The same through `render`, against the real device's layer limit (2048 on lavapipe).
    let ctx = tiltfield::gpu::GpuContext::new(&common::gpu_options()).unwrap();
    let layers = tiltfield::passes::texture::TextureLimits::of(&ctx).max_layers as usize;
    drop(ctx);
    let cols = layers / 8 + 1;
    write_json(&path, &manifest_value(cols, 8, "v.png"));
    let out = tmp.path().join("r.png");
    fails_with(
        &["render", s(&path), "--disparity", "0", "-o", s(&out)],
        &["device limit", "layers"],
    );
}

// ---------------------------------------------------------------------------------------------
// Messages that mislead.

#[test]
fn degenerate_focus_and_calibration_name_the_actual_cause() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("r.png");
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "1e30",
            "-o",
            s(&out),
        ],
        &["--disparity 1.0000e30 px is far too large"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--focus",
            "1e-42",
            "-o",
            s(&out),
        ],
        &["--focus 1e-42", "practically on the reference camera"],
    );
    let hci = tmp.path().join("hci");
    std::fs::create_dir(&hci).unwrap();
    hci_folder(&hci, 3, 3, 9, "1e-300");
    fails_with(
        &["render", s(&hci), "--disparity", "1", "-o", s(&out)],
        &["degenerate calibration"],
    );
}

#[test]
fn folder_without_parameters_cfg_says_so_once() {
    let tmp = tempfile::tempdir().unwrap();
    hci_folder(tmp.path(), 3, 3, 9, "10");
    std::fs::remove_file(tmp.path().join("parameters.cfg")).unwrap();
    let o = tiltfield(&["info", s(tmp.path())]);
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("no parameters.cfg") && err.contains("input_Cam000.png"),
        "{err}"
    );
    assert!(
        !err.contains("ignored:"),
        "one message, not one per file: {err}"
    );
}

#[test]
fn a_view_that_is_not_a_file_is_not_called_missing() {
    let tmp = tempfile::tempdir().unwrap();
    hci_folder(tmp.path(), 3, 3, 9, "10");
    let view = tmp.path().join("input_Cam004.png");
    let check = |needle: &str| {
        let msg = open_err(tmp.path());
        assert!(
            msg.contains("input_Cam004.png") && msg.contains(needle) && !msg.contains("missing"),
            "{needle}: {msg}"
        );
    };
    std::fs::remove_file(&view).unwrap();
    std::fs::create_dir(&view).unwrap();
    check("is a folder");
    std::fs::remove_dir(&view).unwrap();
    std::os::unix::fs::symlink("input_Cam004.png", &view).unwrap();
    check("symbolic links");
    std::fs::remove_file(&view).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &view).unwrap();
    check("not a regular file");
}

#[test]
fn a_png_declaring_a_huge_size_is_refused_naming_the_size() {
    let tmp = tempfile::tempdir().unwrap();
    hci_folder(tmp.path(), 3, 3, 9, "10");
    std::fs::write(
        tmp.path().join("input_Cam002.png"),
        png_header_only(60000, 60000),
    )
    .unwrap();
    let msg = open_err(tmp.path());
    assert!(
        msg.contains("input_Cam002.png") && msg.contains("60000×60000"),
        "{msg}"
    );
    assert!(!msg.contains("Memory limit"), "{msg}");
}

#[test]
fn an_unwritable_output_is_refused_before_loading() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("file");
    std::fs::write(&file, b"x").unwrap();
    let out = file.join("out.png");
    // The light field does not exist: the output must be checked first.
    fails_with(
        &[
            "render",
            "no-such-folder",
            "--disparity",
            "0",
            "-o",
            s(&out),
        ],
        &["file"],
    );
    let o = tiltfield(&[
        "render",
        "no-such-folder",
        "--disparity",
        "0",
        "-o",
        s(&out),
    ]);
    assert!(!stderr(&o).contains("no-such-folder"), "{}", stderr(&o));
    let dir = tmp.path().join("d.png");
    std::fs::create_dir(&dir).unwrap();
    let o = tiltfield(&[
        "render",
        "no-such-folder",
        "--disparity",
        "0",
        "-o",
        s(&dir),
    ]);
    assert!(
        stderr(&o).contains("folder; give a file name"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn manifest_top_level_and_byte_order_mark() {
    let tmp = tempfile::tempdir().unwrap();
    let path = manifest_folder(tmp.path());
    std::fs::write(&path, "[1, 2, 3]").unwrap();
    let msg = open_err(&path);
    assert!(
        msg.contains("top level must be a JSON object") && msg.contains("an array"),
        "{msg}"
    );
    assert!(!msg.contains("Probe"), "{msg}");
    let text = serde_json::to_string(&manifest_value(3, 3, "v.png")).unwrap();
    std::fs::write(&path, format!("\u{feff}{text}")).unwrap();
    let lf = lightfield::open(&path, &Default::default()).expect("a BOM is accepted");
    assert_eq!(lf.views.len(), 9);
}

#[test]
fn a_file_that_is_not_what_it_should_be_is_not_echoed() {
    let tmp = tempfile::tempdir().unwrap();
    hci_folder(tmp.path(), 3, 3, 9, "10");
    // A PNG in the place of the disparity map.
    std::fs::copy(
        tmp.path().join("input_Cam000.png"),
        tmp.path().join("gt_disp_lowres.pfm"),
    )
    .unwrap();
    let msg = open_err(tmp.path());
    assert!(msg.contains("not a PFM file (it is a PNG image)"), "{msg}");
    assert!(!msg.contains("PNG\\r") && !msg.contains("\\u{89}"), "{msg}");
}

#[test]
fn usage_errors_exit_2_other_errors_exit_1_as_documented() {
    let o = tiltfield(&["render", "--no-such-option"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = tiltfield(&["info", "no-such-folder"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let readme = include_str!("../README.md")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    assert!(
        readme.contains("exit with status 2") && readme.contains("exits with status 1"),
        "the README's errors paragraph documents both exit codes"
    );
    assert!(
        readme.contains("`../`"),
        "the README documents the paths policy"
    );
}

// ---------------------------------------------------------------------------------------------
// Round two (issue 24): files that are not files, numbers at the edge, a cache others can
// write, outputs that must be whole or absent.

/// Runs `f` on another thread and fails the test if it has not returned within `secs`: a
/// regression that blocks on a FIFO fails instead of hanging the suite.
fn within<R: Send + 'static>(secs: u64, what: &str, f: impl FnOnce() -> R + Send + 'static) -> R {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(std::time::Duration::from_secs(secs))
        .unwrap_or_else(|_| panic!("{what} did not return within {secs} s (blocked?)"))
}

/// `tiltfield args` killed after `secs` (a failed test, not a hung suite), with extra
/// environment variables.
fn tiltfield_within(secs: u64, args: &[&str], env: &[(&str, &Path)]) -> std::process::Output {
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_tiltfield"));
    cmd.args(args)
        .env("TILTFIELD_VALIDATION", "1")
        .env_remove("RUST_LOG")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().expect("run tiltfield");
    let t0 = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed().as_secs() >= secs {
            child.kill().unwrap();
            panic!("{args:?} did not finish within {secs} s");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

fn mkfifo(path: &Path) {
    let st = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo");
    assert!(st.success(), "mkfifo {}", path.display());
}

/// Every file in `dir` and below, relative, sorted.
fn listing(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            out.push(p.strip_prefix(base).unwrap().display().to_string());
            if p.is_dir() && !p.is_symlink() {
                walk(base, &p, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

#[test]
fn a_fifo_or_device_where_a_file_is_expected_is_refused_without_blocking() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().to_path_buf();
    // A manifest whose depth map is a FIFO, then /dev/zero.
    let manifest = manifest_folder(&dir);
    let mut m = manifest_value(3, 3, "v.png");
    m["views"][4]["disparity"] = json!("d.pfm");
    write_json(&manifest, &m);
    mkfifo(&dir.join("d.pfm"));
    let msg = within(20, "a FIFO depth map", {
        let p = manifest.clone();
        move || open_err(&p)
    });
    assert!(msg.contains("d.pfm") && msg.contains("FIFO"), "{msg}");
    std::fs::remove_file(dir.join("d.pfm")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.join("d.pfm")).unwrap();
    let msg = within(20, "/dev/zero as a depth map", move || open_err(&manifest));
    assert!(
        msg.contains("d.pfm") && msg.contains("character device"),
        "{msg}"
    );
    assert!(!msg.contains("out of memory"), "{msg}");

    // A viewer script.
    let script = dir.join("s.txt");
    mkfifo(&script);
    let msg = within(20, "a FIFO script", move || {
        tiltfield::viewer::script::load(&script)
            .unwrap_err()
            .to_string()
    });
    assert!(
        msg.contains("s.txt") && msg.contains("--script") && msg.contains("FIFO"),
        "{msg}"
    );

    // depth --score (refused before the light field is even looked at).
    let score = dir.join("truth.pfm");
    mkfifo(&score);
    let o = tiltfield_within(
        30,
        &[
            "depth",
            "builtin:planes",
            "--score",
            s(&score),
            "-o",
            s(&dir.join("o.pfm")),
        ],
        &[],
    );
    let err = stderr(&o);
    assert!(
        !o.status.success() && err.contains("--score") && err.contains("FIFO"),
        "{err}"
    );

    // A glTF buffer URI.
    let gltf_dir = dir.join("g");
    std::fs::create_dir(&gltf_dir).unwrap();
    let path = gltf_file(&gltf_dir, &quad(1.0), &[0, 1, 2, 0, 2, 3], 6, json!({}), 0);
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    v["buffers"][0]["uri"] = json!("buf.bin");
    write_json(&path, &v);
    mkfifo(&gltf_dir.join("buf.bin"));
    let msg = within(20, "a FIFO glTF buffer", move || gltf_err(&path));
    assert!(msg.contains("buf.bin") && msg.contains("FIFO"), "{msg}");
}

#[test]
fn a_folder_or_special_file_named_as_the_scene_or_parameters_is_named_not_missing() {
    let tmp = tempfile::tempdir().unwrap();
    // A folder given as the glTF scene.
    let folder = tmp.path().join("scene.gltf");
    std::fs::create_dir(&folder).unwrap();
    let msg = gltf_err(&folder);
    assert!(
        msg.contains("a folder") && !msg.contains("no such"),
        "{msg}"
    );

    // parameters.cfg that is a folder, a FIFO or a dangling link.
    let hci = tmp.path().join("hci");
    std::fs::create_dir(&hci).unwrap();
    hci_folder(&hci, 3, 3, 9, "10");
    let cfg = hci.join("parameters.cfg");
    for (make, needle) in [
        (
            &(|p: &Path| std::fs::create_dir(p).unwrap()) as &dyn Fn(&Path),
            "a folder",
        ),
        (&|p: &Path| mkfifo(p), "FIFO"),
        (
            &|p: &Path| std::os::unix::fs::symlink("nowhere.cfg", p).unwrap(),
            "a dangling link: its target nowhere.cfg does not exist",
        ),
    ] {
        let _ = std::fs::remove_file(&cfg).or_else(|_| std::fs::remove_dir(&cfg));
        make(&cfg);
        let msg = within(20, "a special parameters.cfg", {
            let hci = hci.clone();
            move || open_err(&hci)
        });
        assert!(
            msg.contains("parameters.cfg")
                && msg.contains(needle)
                && !msg.contains("no parameters.cfg"),
            "{needle}: {msg}"
        );
    }

    // cameras_parameters.txt that is a folder or a FIFO: still a video folder, and the error
    // names the file instead of loading the views as a plain grid.
    let video = tmp.path().join("video");
    std::fs::create_dir(&video).unwrap();
    for (r, c) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
        png(&video.join(format!("{r:02}_{c:02}.png")), 50);
    }
    let params = video.join("cameras_parameters.txt");
    std::fs::create_dir(&params).unwrap();
    let msg = open_err(&video);
    assert!(
        msg.contains("cameras_parameters.txt") && msg.contains("a folder"),
        "{msg}"
    );
    std::fs::remove_dir(&params).unwrap();
    mkfifo(&params);
    let msg = within(20, "a FIFO cameras_parameters.txt", move || {
        open_err(&video)
    });
    assert!(
        msg.contains("cameras_parameters.txt") && msg.contains("FIFO"),
        "{msg}"
    );
}

#[test]
fn outputs_are_written_whole_or_not_at_all() {
    use tiltfield::io;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let img = image::RgbaImage::from_pixel(4, 4, image::Rgba([1, 2, 3, 255]));
    // A device, a dangling link and a link to a file are refused; nothing is written through
    // them.
    let e = io::save_png(&img, Path::new("/dev/full"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("/dev/full") && e.contains("character device"),
        "{e}"
    );
    let target = dir.join("target.png");
    let link = dir.join("link.png");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let e = io::save_png(&img, &link).unwrap_err().to_string();
    assert!(e.contains("symbolic link"), "{e}");
    assert!(!target.exists(), "written through a dangling link");
    // A failing write leaves neither the file, a temporary file, nor the folders it made.
    let deep = dir.join("a/b/out.bin");
    let e = io::write_with(&deep, "test data", |w| {
        use std::io::Write;
        w.write_all(b"partial").map_err(|e| e.to_string())?;
        Err("the encoder failed".into())
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("out.bin") && e.contains("the encoder failed"),
        "{e}"
    );
    assert_eq!(listing(dir), vec!["link.png"], "left behind");
    // A successful write makes the folders and exactly one file; checking creates nothing.
    io::check_writable(&dir.join("c/d/x.png")).unwrap();
    assert_eq!(listing(dir), vec!["link.png"]);
    io::save_png(&img, &dir.join("c/d/x.png")).unwrap();
    assert_eq!(listing(dir), vec!["c", "c/d", "c/d/x.png", "link.png"]);
    assert_eq!(image::open(dir.join("c/d/x.png")).unwrap().to_rgba8(), img);

    // The command line: a render that fails (the light field has no views) leaves no folder.
    let empty = dir.join("empty");
    std::fs::create_dir(&empty).unwrap();
    let out = dir.join("x/y/out.png");
    let o = tiltfield(&["render", s(&empty), "--disparity", "0", "-o", s(&out)]);
    assert!(!o.status.success());
    assert!(
        !dir.join("x").exists(),
        "a failed run left its output folder"
    );
    // A file in the way of the output's folder is named; a FIFO given as the light field is
    // called a FIFO, not "Not a directory".
    let blocker = dir.join("blocker");
    std::fs::write(&blocker, b"x").unwrap();
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "-o",
            s(&blocker.join("o.png")),
        ],
        &["blocker", "not a folder"],
    );
    let fifo = dir.join("lf");
    mkfifo(&fifo);
    fails_with(
        &[
            "render",
            s(&fifo),
            "--disparity",
            "0",
            "-o",
            s(&dir.join("o.png")),
        ],
        &["not a light field", "FIFO"],
    );
    // -o at a link to /dev/full: refused before rendering, the link left as it was.
    let full = dir.join("full.png");
    std::os::unix::fs::symlink("/dev/full", &full).unwrap();
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "-o",
            s(&full),
        ],
        &["full.png", "symbolic link"],
    );
    assert!(full.is_symlink());
}

#[test]
fn a_write_error_is_reported_and_leaves_no_file() {
    // A file size limit makes the PNG's writes fail (EFBIG; SIGXFSZ ignored, as a full disk
    // fails a write): the run must fail naming the file, and leave neither it nor a
    // temporary file behind.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.png");
    let o = std::process::Command::new("sh")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 4; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_tiltfield"))
        .args([
            "render",
            "builtin:planes",
            "--disparity",
            "0",
            "-o",
            s(&out),
        ])
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(
        !o.status.success(),
        "a failed write reported success: {err}"
    );
    assert!(
        err.contains("out.png") && !err.contains("panicked"),
        "{err}"
    );
    assert!(listing(tmp.path()).is_empty(), "{:?}", listing(tmp.path()));
}

#[test]
fn the_depth_cache_verifies_its_entries_and_follows_no_planted_link() {
    use tiltfield::bench::depth_scenes::DepthScene;
    let tmp = tempfile::tempdir().unwrap();
    let grid = tmp.path().join("grid");
    std::fs::create_dir(&grid).unwrap();
    let lf = DepthScene::Planes.light_field(3, 32);
    for v in &lf.views {
        v.image
            .save(grid.join(format!("view_{:02}_{:02}.png", v.t, v.s)))
            .unwrap();
    }
    let cache = tmp.path().join("cache");
    let outside = tmp.path().join("outside");
    std::fs::create_dir(&outside).unwrap();
    let ply = tmp.path().join("c.ply");
    let run = || {
        let o = tiltfield_within(
            120,
            &["cloud", s(&grid), "-o", s(&ply), "--json"],
            &[
                ("TILTFIELD_CACHE_DIR", &cache),
                ("TILTFIELD_VALIDATION", Path::new("1")),
            ],
        );
        let err = stderr(&o);
        (common::json_of(&o), err)
    };
    let (v, _) = run();
    assert_eq!(v["depth"]["cached"], false);
    let meta = PathBuf::from(v["depth"]["cache_file"].as_str().unwrap());
    let data = meta.with_extension("pfm");
    let good = std::fs::read(&data).unwrap();
    let (v, _) = run();
    assert_eq!(v["depth"]["cached"], true, "an intact entry is used");

    // Altered values: detected by the hash, estimated again, and the entry repaired.
    let mut bad = good.clone();
    let n = bad.len();
    bad[n - 8..n - 4].copy_from_slice(&0.25f32.to_le_bytes());
    std::fs::write(&data, &bad).unwrap();
    let (v, err) = run();
    assert_eq!(v["depth"]["cached"], false, "an altered entry was used");
    assert!(err.contains("does not match the hash"), "{err}");
    assert_eq!(
        std::fs::read(&data).unwrap(),
        good,
        "the entry is not repaired"
    );

    // Links planted in the cache folder, pointing outside it: never written through.
    let victim = outside.join("victim");
    std::fs::write(&victim, b"keep me").unwrap();
    std::fs::remove_file(&data).unwrap();
    std::os::unix::fs::symlink(&victim, &data).unwrap();
    std::fs::remove_file(&meta).unwrap();
    std::os::unix::fs::symlink(outside.join("created"), &meta).unwrap();
    let (v, _) = run();
    assert_eq!(v["depth"]["cached"], false);
    assert_eq!(std::fs::read(&victim).unwrap(), b"keep me");
    assert_eq!(
        listing(&outside),
        vec!["victim"],
        "a file appeared outside the cache"
    );
    assert!(!data.is_symlink() && !meta.is_symlink());
    let (v, _) = run();
    assert_eq!(
        v["depth"]["cached"], true,
        "the replaced entry is used again"
    );

    // An entry that is a FIFO: no hang, estimated again.
    std::fs::remove_file(&data).unwrap();
    mkfifo(&data);
    let (v, _) = run();
    assert_eq!(v["depth"]["cached"], false);
    // Nothing but the two entry files in the cache (no temporary files left).
    assert_eq!(listing(&cache).len(), 2, "{:?}", listing(&cache));
}

#[test]
fn depth_numbers_at_the_edge_name_their_origin() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("o.pfm");
    // An all-NaN ground truth scores nothing: refused, not a perfect score.
    let nan = tmp.path().join("nan.pfm");
    tiltfield::lightfield::pfm::write_pfm(&nan, 64, 64, 1, &[f32::NAN; 64 * 64]).unwrap();
    fails_with(
        &["depth", "builtin:planes", "--score", s(&nan), "-o", s(&out)],
        &["nan.pfm", "no finite disparity"],
    );
    // Depths so extreme that the sweep range overflows.
    fails_with(
        &[
            "depth",
            "builtin:planes",
            "--kind",
            "depth",
            "--range=1e-308,1e308",
            "-o",
            s(&out),
        ],
        &["--range", "out of reach"],
    );
    assert!(!out.exists());
    // A range that came from the dataset is called that, not --range.
    let hci = tmp.path().join("hci");
    std::fs::create_dir(&hci).unwrap();
    hci_folder(&hci, 3, 3, 9, "10");
    let cfg = hci.join("parameters.cfg");
    let text = std::fs::read_to_string(&cfg).unwrap();
    std::fs::write(
        &cfg,
        format!("{text}\n[meta]\ndisp_min = -1000\ndisp_max = 1\n"),
    )
    .unwrap();
    let o = tiltfield(&["depth", s(&hci), "-o", s(&out)]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("[meta] disp_min") && !err.contains("--range"),
        "{err}"
    );
}

#[test]
fn numbers_at_the_edge_are_refused_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("synth");
    // synth: a sensor that makes the focal length infinite; a render that would take long.
    fails_with(
        &[
            "synth",
            "builtin:planes",
            "--sensor-mm=1e308",
            "-o",
            s(&out),
        ],
        &["--sensor-mm", "at most"],
    );
    fails_with(
        &[
            "synth",
            "builtin:planes",
            "--focal-mm=1e300",
            "--sensor-mm=1e-300",
            "-o",
            s(&out),
        ],
        &["focal length", "--focal-mm"],
    );
    fails_with(
        &[
            "synth",
            "builtin:planes",
            "--size",
            "8192x8192",
            "--grid",
            "2x2",
            "-o",
            s(&out),
        ],
        &["--size 8192x8192", "--samples"],
    );
    assert!(!out.exists(), "a refused synth created its folder");
    // render: an output size no device holds is named as such, before loading anything.
    fails_with(
        &[
            "render",
            "no-such-lf",
            "--disparity",
            "0",
            "--size",
            "16384x16384",
            "-o",
            "x.png",
        ],
        &["--size 16384x16384", "8192"],
    );
    // bench: variant sizes that overflowed, aborted or ran for minutes.
    for size in ["99999x99999", "33000x33000", "4096x4096"] {
        fails_with(
            &[
                "bench",
                "--variants",
                size,
                "--out",
                s(&tmp.path().join("b")),
            ],
            &[size, "2048"],
        );
    }
    fails_with(
        &[
            "bench",
            "--frames",
            "18446744073709551615",
            "--out",
            s(&tmp.path().join("b")),
        ],
        &["--frames", "1000"],
    );
    assert!(!tmp.path().join("b").exists());
}

/// A Technicolor-layout video of four parallel 16×12 cameras in a row (0.1 apart), with the
/// frames numbered `frames`.
fn small_video(video: &Path, frames: &[u64]) {
    std::fs::create_dir(video).unwrap();
    let views: Vec<image::RgbaImage> = (0..4)
        .map(|k| image::RgbaImage::from_pixel(16, 12, image::Rgba([40 * k as u8, 90, 120, 255])))
        .collect();
    let mut params = String::from("f cu cv ar sk qw qx qy qz tx ty tz\n");
    for k in 0..4 {
        params.push_str(&format!("14 7.5 5.5 1 0 1 0 0 0 {} 0 0\n", -0.1 * k as f64));
    }
    std::fs::write(video.join("cameras_parameters.txt"), params).unwrap();
    for &f in frames {
        for (k, v) in views.iter().enumerate() {
            v.save(video.join(format!("S_undist_{f:05}_{k:02}.png")))
                .unwrap();
        }
    }
}

#[test]
fn frames_at_the_top_of_u64_and_every_output_checked_first() {
    let tmp = tempfile::tempdir().unwrap();
    let video = tmp.path().join("video");
    let top = u64::MAX;
    small_video(&video, &[top - 1, top]);
    let out = tmp.path().join("f_{frame}.png");
    let o = tiltfield_within(
        120,
        &[
            "render",
            s(&video),
            "--frames",
            &format!("{top}.."),
            "--disparity",
            "0",
            "-o",
            s(&out),
        ],
        &[],
    );
    let err = stderr(&o);
    assert!(o.status.success() && !err.contains("panicked"), "{err}");
    assert!(tmp.path().join(format!("f_{top}.png")).exists());
    // The second frame's output is a folder: refused before the first is written.
    std::fs::create_dir(tmp.path().join(format!("g_{top}.png"))).unwrap();
    let out = tmp.path().join("g_{frame}.png");
    let o = tiltfield_within(
        120,
        &[
            "render",
            s(&video),
            "--frames",
            &format!("{}..", top - 1),
            "--disparity",
            "0",
            "-o",
            s(&out),
        ],
        &[],
    );
    let err = stderr(&o);
    assert!(
        !o.status.success() && err.contains(&format!("g_{top}.png")),
        "{err}"
    );
    assert!(
        !tmp.path().join(format!("g_{}.png", top - 1)).exists(),
        "wrote before failing"
    );
}

#[test]
fn scripts_with_a_bom_huge_counts_or_device_screenshots() {
    use tiltfield::viewer::script;
    let lines = script::parse("\u{feff}wait 0\nquit\n").unwrap();
    assert_eq!(
        lines.len(),
        2,
        "a byte-order mark is not part of the first command"
    );
    let err = script::parse("key UP 10000\n").unwrap_err();
    assert!(
        err.contains("line 1") && err.contains("count must be 1 to"),
        "{err}"
    );
    let many = "key UP 500\n".repeat(5);
    let err = script::parse(&many).unwrap_err();
    assert!(
        err.contains("line 5") && err.contains("presses keys"),
        "{err}"
    );
    let waits = "wait 3600\nwait 1\n";
    assert!(script::parse(waits).unwrap_err().contains("line 2"));
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("s.txt");
    std::fs::write(&path, "\u{feff}screenshot /dev/full\n").unwrap();
    let e = script::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("line 1") && e.contains("character device"),
        "{e}"
    );
    assert!(!Path::new("/dev/full_refocus.png").exists());
}

#[test]
fn a_focus_no_view_reaches_is_an_error_not_a_transparent_image() {
    // A plane 1 mm in front of a virtual camera between the real ones: every view's sample
    // lands hundreds of pixels outside it.
    let tmp = tempfile::tempdir().unwrap();
    let video = tmp.path().join("video");
    small_video(&video, &[1]);
    let out = tmp.path().join("o.png");
    fails_with(
        &["render", s(&video), "--focus", "0.001", "-o", s(&out)],
        &["no view reaches", "nothing was written"],
    );
    assert!(!out.exists());
    // The same for a frame range: no transparent frame is written either.
    let pattern = tmp.path().join("f_{frame}.png");
    fails_with(
        &[
            "render",
            s(&video),
            "--frames",
            "1..1",
            "--focus",
            "0.001",
            "-o",
            s(&pattern),
        ],
        &["no view reaches", "nothing was written"],
    );
    let written: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .filter(|n| n.to_string_lossy().starts_with("f_"))
        .collect();
    assert!(written.is_empty(), "{written:?}");
}

#[test]
fn output_cut_short_by_its_reader_ends_quietly() {
    // `tiltfield demo --list | head -1`: the reader goes away; no panic message.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_tiltfield"))
        .args(["demo", "--list"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
}

// ---------------------------------------------------------------------------------------------
// The second campaign's findings (tools/hostile_campaign.py).

#[test]
fn a_light_field_of_one_view_renders_without_validation_errors() {
    // Its one-layer texture was viewed as a plain 2D image where the shader samples an array
    // (VUID-vkCmdDraw-viewType-07752, with every strategy).
    let tmp = tempfile::tempdir().unwrap();
    hci_folder(tmp.path(), 1, 1, 1, "30");
    let lf = tmp.path().to_str().unwrap();
    for strategy in ["fragment", "compute"] {
        let out = tmp.path().join(format!("{strategy}.png"));
        let o = tiltfield(&[
            "render",
            lf,
            "--disparity",
            "0",
            "--strategy",
            strategy,
            "-o",
            out.to_str().unwrap(),
            "--validate",
        ]);
        assert!(o.status.success(), "{strategy}: {}", stderr(&o));
        // The one view, unchanged: a refocus of a single view at any plane is that view.
        let img = image::open(&out).unwrap().to_rgb8();
        let view = image::open(tmp.path().join(lightfield::hci::view_file_name(0, 1)))
            .unwrap()
            .to_rgb8();
        let diff = img
            .pixels()
            .zip(view.pixels())
            .map(|(a, b)| {
                (0..3)
                    .map(|c| (a[c] as i32 - b[c] as i32).abs())
                    .max()
                    .unwrap()
            })
            .max()
            .unwrap();
        assert!(
            diff <= 1,
            "{strategy}: differs from the view by {diff} levels"
        );
    }
}

#[test]
fn output_names_that_are_not_utf8_are_refused_where_they_are_reported_or_patterned() {
    use std::os::unix::ffi::OsStrExt;
    let tmp = tempfile::tempdir().unwrap();
    let bad = |name: &[u8]| {
        let mut p = tmp.path().as_os_str().as_bytes().to_vec();
        p.push(b'/');
        p.extend_from_slice(name);
        PathBuf::from(std::ffi::OsStr::from_bytes(&p))
    };
    // synth and demo wrote part of a folder, then panicked serialising its name to JSON.
    for args in [
        vec![
            "synth".into(),
            "builtin:planes".into(),
            "--out".into(),
            bad(b"s\xff\xfe").into_os_string(),
            "--grid".into(),
            "2x2".into(),
            "--size".into(),
            "32x32".into(),
        ],
        vec![
            "demo".into(),
            "-o".into(),
            bad(b"d\xff\xfe").into_os_string(),
        ],
    ] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_tiltfield"))
            .args(&args)
            .env("TILTFIELD_VALIDATION", "1")
            .output()
            .unwrap();
        let err = stderr(&o);
        assert!(
            !o.status.success() && err.contains("not valid UTF-8"),
            "{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    assert_eq!(
        std::fs::read_dir(tmp.path()).unwrap().count(),
        0,
        "nothing is left behind"
    );
    // A frame pattern was made lossy, so the frames went to other names than the ones asked.
    let pattern = bad(b"f\xff\xfe_{frame}.png");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tiltfield"))
        .args([
            std::ffi::OsStr::new("render"),
            std::ffi::OsStr::new("no-such-video"),
            std::ffi::OsStr::new("--frames"),
            std::ffi::OsStr::new("1..2"),
            std::ffi::OsStr::new("--disparity"),
            std::ffi::OsStr::new("0"),
            std::ffi::OsStr::new("-o"),
            pattern.as_os_str(),
        ])
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(
        !o.status.success() && err.contains("not valid UTF-8"),
        "{err}"
    );
}

#[test]
fn a_plane_quad_too_large_for_the_ply_is_refused() {
    // 1e308 passed the finiteness check and wrote infinite corners into the PLY.
    fails_with(
        &[
            "cloud",
            "builtin:planes",
            "-o",
            "/tmp/never-written.ply",
            "--disparity",
            "0",
            "--plane-size=1e308",
        ],
        &["--plane-size", "at most"],
    );
}

#[test]
fn gltf_accessors_whose_extent_overflows_are_refused_not_panicked_on() {
    // The crate's readers computed offset + (count − 1)·stride unchecked.
    let tmp = tempfile::tempdir().unwrap();
    let base = gltf_file(tmp.path(), &quad(1.0), &QUAD_INDICES, 6, json!({}), 0);
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&base).unwrap()).unwrap();
    let edits: [(&str, &[&str], u64); 5] = [
        ("count 2^61", &["accessors", "0", "count"], 1 << 61),
        ("count 2^63", &["accessors", "0", "count"], 1 << 63),
        (
            "count u64/12 + 1",
            &["accessors", "0", "count"],
            u64::MAX / 12 + 1,
        ),
        (
            "accessor offset u64",
            &["accessors", "0", "byteOffset"],
            u64::MAX,
        ),
        (
            "view offset u64",
            &["bufferViews", "0", "byteOffset"],
            u64::MAX,
        ),
    ];
    for (k, (what, at, value)) in edits.into_iter().enumerate() {
        let mut d = doc.clone();
        let mut v = &mut d;
        for key in at {
            v = match key.parse::<usize>() {
                Ok(i) => &mut v[i],
                Err(_) => &mut v[*key],
            };
        }
        *v = json!(value);
        let p = tmp.path().join(format!("edit{k}.gltf"));
        write_json(&p, &d);
        let msg = gltf_err(&p);
        assert!(
            msg.contains("accessor 0") && msg.contains("beyond"),
            "{what}: {msg}"
        );
    }
}

#[test]
fn a_ground_truth_map_that_is_not_a_file_is_named_not_skipped() {
    // It was skipped in silence: `info` said "depth none" and depth was estimated instead.
    // A folder, a FIFO, a dangling link.
    for make in 0..3 {
        let tmp = tempfile::tempdir().unwrap();
        hci_folder(tmp.path(), 3, 3, 9, "30");
        let gt = tmp.path().join(lightfield::hci::DISPARITY_NAME);
        match make {
            0 => std::fs::create_dir(&gt).unwrap(),
            1 => mkfifo(&gt),
            _ => std::os::unix::fs::symlink(tmp.path().join("nowhere.pfm"), &gt).unwrap(),
        }
        fails_with(
            &["info", tmp.path().to_str().unwrap()],
            &[lightfield::hci::DISPARITY_NAME],
        );
    }
}
