//! Property tests of every parser against hostile input (issue 13): arbitrary bytes and
//! arbitrary numbers give `Ok` or a clear error — never a panic — and never an allocation
//! larger than the input justifies.
//!
//! Bounded for the suite (a few seconds); run longer with e.g.
//! `PROPTEST_CASES=20000 cargo test --test parser_fuzz`.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;
use std::sync::OnceLock;

use glam::{DVec2, DVec3};
use proptest::prelude::*;
use tiltfield::geometry::aperture::{Aperture, ApertureShape};
use tiltfield::geometry::plane::Plane;
use tiltfield::lightfield::{self, grid_naming, hci, manifest, pfm, LightField};
use tiltfield::refocus::{self, FocusSpec, RefocusRequest};

// ---------------------------------------------------------------------------------------------
// The largest single allocation made by this thread while a parser runs.

struct Counting;

thread_local! {
    // const-initialised and without a destructor: safe to touch from inside the allocator.
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = LARGEST.try_with(|c| c.set(c.get().max(size)));
}

// SAFETY: forwards every call to the system allocator unchanged; only records sizes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `f` and returns its result with the largest single allocation it made on this thread.
fn largest_allocation<R>(f: impl FnOnce() -> R) -> (R, usize) {
    LARGEST.with(|c| c.set(0));
    let r = f();
    (r, LARGEST.with(Cell::get))
}

/// What an input of `len` bytes may justify allocating at once: a generous constant factor
/// plus 1 MiB of fixed overhead (buffers, tables), far below what a hostile header declares.
fn justified(len: usize) -> usize {
    64 * len + (1 << 20)
}

/// Cases per property: a few seconds in the suite, more on demand.
fn config() -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(96);
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// An error message is one clear line.
fn clear(e: &tiltfield::Error) {
    let m = e.to_string();
    assert!(!m.is_empty() && !m.contains('\n'), "not one line: {m:?}");
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Bytes that look like the format often enough to get past the first check.
fn bytes_with_prefix(prefixes: &'static [&'static [u8]]) -> impl Strategy<Value = Vec<u8>> {
    (
        proptest::sample::select(prefixes),
        proptest::collection::vec(any::<u8>(), 0..256),
    )
        .prop_map(|(p, rest)| [p, &rest[..]].concat())
}

/// A camera-array video of two 4×4 cameras with frames 1 and 2 in `dir`; returns its folder.
fn small_video(dir: &Path) -> String {
    let video = dir.join("video");
    std::fs::create_dir(&video).unwrap();
    let mut params = String::from("f cu cv ar sk qw qx qy qz tx ty tz\n");
    for k in 0..2 {
        params.push_str(&format!("4 1.5 1.5 1 0 1 0 0 0 {} 0 0\n", -0.1 * k as f64));
        for f in [1, 2] {
            image::RgbaImage::from_pixel(4, 4, image::Rgba([9, 9, 9, 255]))
                .save(video.join(format!("S_undist_{f:05}_{k:02}.png")))
                .unwrap();
        }
    }
    std::fs::write(video.join("cameras_parameters.txt"), params).unwrap();
    video.display().to_string()
}

/// Script commands, good and bad, for the script parser's property.
const SCRIPT_WORDS: &[&str] = &[
    "wait",
    "wait-converged",
    "key UP",
    "key shift+W",
    "key",
    "click refocus",
    "click scene",
    "shift-click refocus",
    "drag scene",
    "scroll refocus",
    "scroll scene",
    "resize",
    "screenshot",
    "quit",
    "# comment",
    "",
    "jump",
];

/// Numbers as text, concentrated at the edges: zero, negatives, the ends of u32/u64/f64,
/// non-finite and malformed spellings.
fn number_text() -> impl Strategy<Value = String> {
    prop_oneof![
        proptest::sample::select(vec![
            "0",
            "1",
            "-1",
            "2",
            "3",
            "4096",
            "8192",
            "16384",
            "99999",
            "33000",
            "65535",
            "4294967295",
            "4294967296",
            "18446744073709551615",
            "18446744073709551616",
            "1e308",
            "-1e308",
            "1e-308",
            "5e-324",
            "inf",
            "-inf",
            "NaN",
            "0.001",
            "1e9",
            "",
            "x",
            "1,2",
            "0x10",
            " 7",
        ])
        .prop_map(str::to_string),
        any::<u32>().prop_map(|v| v.to_string()),
        any::<f64>().prop_map(|v| v.to_string()),
    ]
}

// ---------------------------------------------------------------------------------------------
// Parsers.

const CFG_LINES: &[&[u8]] = &[
    b"",
    b"[intrinsics]\nfocal_length_mm = 50\nimage_resolution_x_px = ",
    b"[extrinsics]\nnum_cams_x = ",
    b"\xef\xbb\xbf[meta]\n",
    b"[intrinsics]\nfocal_length_mm = 50\nimage_resolution_x_px = 8\nimage_resolution_y_px = 8\n\
      sensor_size_mm = 36\n[extrinsics]\nnum_cams_x = 3\nnum_cams_y = ",
];

const PFM_HEADERS: &[&[u8]] = &[
    b"",
    b"Pf\n",
    b"PF\n",
    b"Pf\n4294967295 4294967295\n-1\n",
    b"PF\n2 2\n1\n",
    b"Pf\n1 1\n-1.0\r\n",
];

const JSON_STARTS: &[&[u8]] = &[
    b"",
    b"{\"version\": 1, \"views\": [{\"image\": \"v.png\", \"grid\": {\"s\": ",
    b"\xef\xbb\xbf{\"version\": ",
    b"[",
    b"{\"version\": 1, \"views\": [], \"rig\": {\"focal_px\": ",
];

const GLTF_STARTS: &[&[u8]] = &[
    b"",
    b"glTF\x02\x00\x00\x00",
    b"{\"asset\": {\"version\": \"2.0\"}, \"scenes\": [{\"nodes\": [",
    b"{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": ",
];

proptest! {
    #![proptest_config(config())]

    #[test]
    fn parameters_cfg_never_panics(bytes in bytes_with_prefix(CFG_LINES)) {
        let text = String::from_utf8_lossy(&bytes);
        let (r, largest) = largest_allocation(|| {
            hci::parse_config(&text, Path::new("parameters.cfg"))
        });
        if let Err(e) = &r {
            clear(e);
        }
        prop_assert!(largest <= justified(bytes.len()), "{largest} bytes at once");
    }

    #[test]
    fn pfm_never_panics_or_trusts_its_header(bytes in bytes_with_prefix(PFM_HEADERS)) {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "d.pfm", &bytes);
        let (r, largest) = largest_allocation(|| pfm::read_pfm(&p));
        match r {
            Ok((w, h, c, data)) => prop_assert_eq!(data.len(), w as usize * h as usize * c),
            Err(e) => clear(&e),
        }
        prop_assert!(largest <= justified(bytes.len()), "{largest} bytes at once");
    }

    #[test]
    fn manifest_never_panics(bytes in bytes_with_prefix(JSON_STARTS)) {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "m.json", &bytes);
        let (r, largest) = largest_allocation(|| manifest::load(&p));
        if let Err(e) = &r {
            clear(e);
        }
        prop_assert!(largest <= justified(bytes.len()), "{largest} bytes at once");
    }

    #[test]
    fn manifest_numbers_give_a_camera_or_an_error(
        k in proptest::array::uniform4(prop_oneof![any::<f64>(), -1e4..1e4f64]),
        c in proptest::array::uniform3(prop_oneof![any::<f64>(), -10.0..10.0f64]),
        s in 0usize..3, t in 0usize..3,
    ) {
        let dir = tempfile::tempdir().unwrap();
        image::RgbImage::new(4, 4).save(dir.path().join("v.png")).unwrap();
        let mut views = Vec::new();
        for (vs, vt) in [(0usize, 0usize), (s, t)] {
            views.push(serde_json::json!({
                "image": "v.png",
                "grid": {"s": vs, "t": vt},
                "K": [[k[0], 0.0, k[1]], [0.0, k[2], k[3]], [0.0, 0.0, 1.0]],
                "R": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                "centre": [c[0] * (vs as f64), c[1] * (vt as f64), c[2]],
            }));
        }
        // serde_json writes non-finite numbers as null, which the parser must refuse too.
        let text = serde_json::json!({"version": 1, "views": views}).to_string();
        let p = write(dir.path(), "tiltfield.json", text.as_bytes());
        match lightfield::open(&p, &Default::default()) {
            Ok(lf) => prop_assert!(lf.views.iter().all(|v| v.camera.k.is_finite())),
            Err(e) => clear(&e),
        }
    }

    #[test]
    fn grid_names_never_panic(stems in proptest::collection::vec(".{0,40}", 0..12)) {
        for stem in &stems {
            // Every number found is the text at its place in the name, in order.
            let mut at = 0;
            for n in grid_naming::numbers(stem) {
                prop_assert!(n.start >= at && stem.get(n.start..n.end) == Some(n.text.as_str()));
                at = n.end;
            }
        }
        let names: Vec<String> = stems.iter().map(|s| format!("{s}.png")).collect();
        if let Ok(g) = grid_naming::read_grid(&names, None) {
            prop_assert_eq!(g.order.len(), g.grid.len());
            prop_assert!(g.order.iter().all(|&i| i < names.len()));
        }
    }

    #[test]
    fn gltf_bytes_never_panic(bytes in bytes_with_prefix(GLTF_STARTS), glb in any::<bool>()) {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), if glb { "s.glb" } else { "s.gltf" }, &bytes);
        let (r, largest) = largest_allocation(|| tiltfield::synth::gltf::load(&p));
        if let Err(e) = &r {
            clear(e);
        }
        prop_assert!(largest <= justified(bytes.len()), "{largest} bytes at once");
    }

    #[test]
    fn gltf_numbers_give_a_mesh_or_an_error(
        scale in prop_oneof![any::<f32>(), -10.0..10.0f32],
        rotation in proptest::array::uniform4(prop_oneof![Just(0.0f32), -1.0..1.0f32]),
        count in 0usize..12,
        offset in prop_oneof![Just(0usize), 0usize..64],
        child in any::<bool>(),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let p = gltf_quad(dir.path(), scale, rotation, count, offset, child);
        match tiltfield::synth::gltf::load(&p) {
            Ok(scene) => {
                prop_assert!(scene.mesh.triangle_count() > 0);
                prop_assert!(scene.mesh.vertices.iter().all(|v| v.position.iter().all(|x| x.is_finite())));
            }
            Err(e) => clear(&e),
        }
    }

    #[test]
    fn script_parser_never_panics_and_keeps_its_limits(
        lines in proptest::collection::vec(
            (
                proptest::sample::select(SCRIPT_WORDS),
                proptest::collection::vec(number_text(), 0..5),
                any::<bool>(),
            ),
            0..12,
        ),
    ) {
        use tiltfield::viewer::script::{self, Command};
        let text: String = lines
            .iter()
            .map(|(cmd, args, bom)| {
                format!("{}{cmd} {}\n", if *bom { "\u{feff}" } else { "" }, args.join(" "))
            })
            .collect();
        match script::parse(&text) {
            Ok(parsed) => {
                let mut presses = 0u64;
                let mut waited = 0.0;
                for l in &parsed {
                    match &l.command {
                        Command::Key { count, .. } => {
                            prop_assert!((1..=script::MAX_COUNT).contains(count));
                            presses += *count as u64;
                        }
                        Command::Wait(s) => {
                            prop_assert!(s.is_finite() && *s >= 0.0);
                            waited += s;
                        }
                        Command::Click { x, y, .. } => prop_assert!(x.is_finite() && y.is_finite()),
                        Command::Scroll { dy, .. } => prop_assert!(dy.is_finite()),
                        Command::Resize(w, h) => prop_assert!(
                            script::WINDOW_SIZES.contains(w) && script::WINDOW_SIZES.contains(h)
                        ),
                        _ => {}
                    }
                }
                prop_assert!(presses <= script::MAX_PRESSES as u64);
                prop_assert!(waited <= script::MAX_WAIT_S);
            }
            Err(e) => prop_assert!(e.starts_with("line ") && !e.contains('\n'), "{e}"),
        }
    }

    #[test]
    fn cli_numbers_are_refused_or_bounded_before_any_work(
        case in 0usize..5,
        a in number_text(),
        b in number_text(),
        c in number_text(),
    ) {
        // Every command is given an output it cannot write (inside a regular file), so a case
        // whose numbers are all valid ends at that refusal, before any GPU or file work:
        // the property is that hostile numbers end in one clear message naming an option (or
        // the output), never a panic, overflow or allocation.
        let tmp = tempfile::tempdir().unwrap();
        let blocker = write(tmp.path(), "blocker", b"x");
        let out = |name: &str| blocker.join(name).display().to_string();
        let args: Vec<String> = match case {
            0 => vec![
                "synth".into(), "builtin:planes".into(), "--grid".into(), format!("{a}x{b}"),
                "--size".into(), format!("{b}x{c}"), format!("--sensor-mm={c}"),
                format!("--focal-mm={a}"), "-o".into(), blocker.display().to_string(),
            ],
            1 => vec![
                "render".into(), "no-such-lf".into(), format!("--disparity={a}"),
                "--size".into(), format!("{b}x{c}"), "--repeat".into(), c.clone(),
                "-o".into(), out("o.png"),
            ],
            2 => vec![
                "bench".into(), "--frames".into(), a.clone(),
                "--variants".into(), format!("{b}x{c},x{a},r{b}"),
                format!("--peak-gtexels={c}"), "--out".into(), out("b"),
            ],
            3 => vec![
                "depth".into(), "no-such-lf".into(), "--planes".into(), a.clone(),
                format!("--range={b},{c}"), "-o".into(), out("d.pfm"),
            ],
            _ => vec![
                "render".into(), small_video(tmp.path()), "--frames".into(),
                format!("{a}..{b}"), "--disparity".into(), "0".into(),
                "-o".into(), out("f_{frame}.png"),
            ],
        };
        let mut argv = vec!["tiltfield".to_string()];
        argv.extend(args.iter().cloned());
        let Ok(cli) = <tiltfield::cli::Cli as clap::Parser>::try_parse_from(&argv) else {
            return Ok(()); // a usage error from the argument parser: clear by construction
        };
        let (result, largest) = largest_allocation(|| tiltfield::cli::run(cli));
        match result {
            Ok(()) => prop_assert!(false, "{args:?} succeeded despite an unwritable output"),
            Err(e) => {
                clear(&e);
                let m = e.to_string();
                prop_assert!(
                    m.contains("--") || m.contains("blocker") || m.contains("no-such-lf")
                        || m.contains("variant") || m.contains("frame"),
                    "{args:?}: the message names no option or file: {m}"
                );
            }
        }
        prop_assert!(largest < 64 << 20, "{args:?} allocated {largest} bytes at once");
    }

    #[test]
    fn number_lists_never_panic(text in ".{0,60}", n in 0usize..8) {
        match tiltfield::cli::parse_numbers(&text, n, "--plane") {
            Ok(v) => prop_assert!(v.len() == n && v.iter().all(|x| x.is_finite())),
            Err(e) => clear(&e),
        }
    }

    #[test]
    fn focus_requests_give_finite_weights_and_warps_or_an_error(
        focus in focus_spec(),
        shape in prop_oneof![
            Just(ApertureShape::Disk), Just(ApertureShape::Square), Just(ApertureShape::Gaussian)
        ],
        radius in proptest::option::of(prop_oneof![any::<f64>(), 0.0..4.0f64, Just(1e-300)]),
        view in proptest::option::of(proptest::array::uniform2(prop_oneof![any::<f64>(), -1.0..5.0f64])),
    ) {
        let lf = light_field();
        let req = RefocusRequest {
            focus,
            aperture: Aperture { shape, radius },
            reference: view.map(|[s, t]| DVec2::new(s, t)),
        };
        match refocus::plan(lf, &req, &[]) {
            Ok(plan) => {
                for v in &plan.views {
                    prop_assert!(v.weight.is_finite() && v.weight > 0.0, "weight {}", v.weight);
                    prop_assert!(v.warp.a.is_finite() && v.warp.b.is_finite());
                }
            }
            Err(e) => clear(&e),
        }
    }
}

fn focus_spec() -> impl Strategy<Value = FocusSpec> {
    let num = || {
        prop_oneof![
            any::<f64>(),
            -10.0..10.0f64,
            Just(0.0),
            Just(1e-300),
            Just(1e300)
        ]
    };
    prop_oneof![
        num().prop_map(FocusSpec::Disparity),
        (num(), num(), num()).prop_map(|(distance, tilt_deg, swing_deg)| {
            FocusSpec::FocusTiltSwing {
                distance,
                tilt_deg,
                swing_deg,
            }
        }),
        (num(), num(), num(), num(), num(), num()).prop_filter_map(
            "not a plane",
            |(a, b, c, d, e, f)| Plane::new(DVec3::new(a, b, c), DVec3::new(d, e, f))
                .ok()
                .map(FocusSpec::Plane)
        ),
    ]
}

/// The built-in `planes` scene, rendered once per test process.
fn light_field() -> &'static LightField {
    static LF: OnceLock<LightField> = OnceLock::new();
    LF.get_or_init(|| common::builtin("planes"))
}

/// A one-quad glTF with an embedded buffer, `count` u16 indices declared (6 stored), the
/// POSITION accessor at byte `offset`, the node scaled by `scale` and rotated by `rotation`,
/// and listing itself as a child when `child`.
fn gltf_quad(
    dir: &Path,
    scale: f32,
    rotation: [f32; 4],
    count: usize,
    offset: usize,
    child: bool,
) -> std::path::PathBuf {
    let positions: [[f32; 3]; 4] = [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ];
    let mut bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    bytes.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    let mut node = serde_json::json!({
        "mesh": 0,
        "scale": [scale, scale, scale],
        "rotation": rotation,
    });
    if child {
        node["children"] = serde_json::json!([0]);
    }
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [node],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{
            "byteLength": bytes.len(),
            "uri": format!("data:application/octet-stream;base64,{}", common::base64(&bytes)),
        }],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 12},
        ],
        "accessors": [
            {"bufferView": 0, "byteOffset": offset, "componentType": 5126, "count": 4,
             "type": "VEC3", "min": [-1.0, -1.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5123, "count": count, "type": "SCALAR"},
        ],
    });
    let p = dir.join("q.gltf");
    std::fs::write(&p, doc.to_string()).unwrap();
    p
}
