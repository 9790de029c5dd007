//! The real viewer window on lavapipe under `xvfb-run`, with the validation layer: scripts
//! press keys, click, drag, scroll and resize; every screenshot's refocus image equals what
//! `render` writes for the state the screenshot recorded; the process exits 0 with zero
//! validation errors. A machine without xvfb fails these tests (tools/setup.sh installs it).

mod common;
mod realworld_rig;

use std::path::Path;
use std::process::{Command, Output};

use common::{fails_with, json_of, stderr, tiltfield};
use glam::DVec3;
use tiltfield::viewer::layout::Layout;

/// Runs `tiltfield view ARGS` in a virtual X server with validation on.
fn view_in_xvfb(args: &[&str]) -> Output {
    view_in_xvfb_cached(
        args,
        &std::env::temp_dir().join("tiltfield-viewer-test-cache"),
    )
}

/// [`view_in_xvfb`] with the depth cache in `cache`.
fn view_in_xvfb_cached(args: &[&str], cache: &Path) -> Output {
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1600x1200x24"])
        .arg(env!("CARGO_BIN_EXE_tiltfield"))
        .arg("view")
        .args(args)
        .env("TILTFIELD_VALIDATION", "1")
        .env("TILTFIELD_CACHE_DIR", cache)
        .env_remove("RUST_LOG")
        .output();
    match out {
        Ok(o) => o,
        Err(e) => panic!("cannot run xvfb-run ({e}); install xvfb (tools/setup.sh does)"),
    }
}

/// Runs `tiltfield view ARGS --script DIR/NAME --json` with `script` written to DIR/NAME (in a
/// virtual X server, validation on), asserts that it succeeded without a panic or a validation
/// error, and returns its JSON report and its stderr.
fn run_script(dir: &Path, name: &str, script: &str, args: &[&str]) -> (serde_json::Value, String) {
    let path = dir.join(name);
    std::fs::write(&path, script).unwrap();
    let mut all = args.to_vec();
    all.extend(["--script", path.to_str().unwrap(), "--json"]);
    let o = view_in_xvfb(&all);
    let err = stderr(&o);
    assert!(o.status.success(), "viewer failed: {err}");
    assert!(!err.contains("panicked"), "{err}");
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
    assert_eq!(report["validation_errors"], 0, "{report}\n{err}");
    (report, err)
}

fn json_file(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// `render`'s PNG of the state a screenshot recorded.
fn render_state(lf: &str, state: &serde_json::Value, focus: &[String], out: &Path) -> Vec<u8> {
    render_state_cached(lf, state, focus, out, None)
}

/// [`render_state`] with the depth cache in `cache` (where the viewer's estimate went).
fn render_state_cached(
    lf: &str,
    state: &serde_json::Value,
    focus: &[String],
    out: &Path,
    cache: Option<&Path>,
) -> Vec<u8> {
    let aperture = &state["aperture"];
    let view = numbers(&state["reference_view"]);
    let mut args: Vec<String> = vec![
        "render".into(),
        lf.into(),
        "-o".into(),
        out.display().to_string(),
        "--aperture".into(),
        aperture["shape"].as_str().unwrap().into(),
        format!("--view={},{}", view[0], view[1]),
        "--average".into(),
        state["averaging"].as_str().unwrap().into(),
        // As the screenshot recorded it: the viewer keeps one storage whatever E does.
        "--storage".into(),
        state["storage"].as_str().unwrap_or("linear16").into(),
    ];
    // Anti-aliasing as the screenshot recorded it (on by default: these light fields have depth).
    match state["antialias"]["max_samples"].as_u64() {
        Some(n) if state["antialias"]["used"] == true => args.extend([
            "--antialias".into(),
            "on".into(),
            format!("--antialias-samples={n}"),
        ]),
        _ => args.extend(["--antialias".into(), "off".into()]),
    }
    if let Some(r) = aperture["radius"].as_f64() {
        args.push(format!("--aperture-radius={r:?}"));
    }
    if let Some(f) = state["filter"].as_str() {
        args.push(format!("--filter={f}"));
    }
    args.extend(focus.iter().cloned());
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = match cache {
        Some(c) => Command::new(env!("CARGO_BIN_EXE_tiltfield"))
            .args(&refs)
            .env("TILTFIELD_VALIDATION", "1")
            .env("TILTFIELD_CACHE_DIR", c)
            .env_remove("RUST_LOG")
            .output()
            .unwrap(),
        None => tiltfield(&refs),
    };
    assert!(o.status.success(), "render {refs:?}: {}", stderr(&o));
    std::fs::read(out).unwrap()
}

fn plane_args(state: &serde_json::Value) -> Vec<String> {
    let p = &state["plane"];
    let v: Vec<String> = numbers(&p["point"])
        .into_iter()
        .chain(numbers(&p["normal"]))
        .map(|x| format!("{x:?}"))
        .collect();
    vec![format!("--plane={}", v.join(","))]
}

fn decoded(path: &Path) -> image::RgbaImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgba8()
}

/// The viewer sums with any strategy: progressive compute dispatches converge to render's
/// compute image byte for byte (what a device whose fastest path is compute shows).
#[test]
fn the_viewer_converges_to_render_with_the_compute_strategy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lf = "builtin:tilted";
    let script = format!(
        "wait-converged\n\
         key UP 2\n\
         wait-converged\n\
         screenshot {d}/a\n\
         quit\n",
        d = d.display()
    );
    let (report, _) = run_script(d, "compute.txt", &script, &[lf, "--strategy", "compute"]);
    assert_eq!(
        (
            report["strategy"].as_str(),
            report["strategy_source"].as_str()
        ),
        (Some("compute"), Some("option")),
        "{report}"
    );
    let a = json_file(&d.join("a.json"));
    let mut focus = plane_args(&a);
    // The report names the anti-aliasing route taken, as render's does for the same plane
    // (builtin:tilted ships its depth: layered footprints), not only the setting asked for.
    let mut args: Vec<&str> = vec!["render", lf, "--json", "-o"];
    let rendered = d.join("route.png");
    args.push(rendered.to_str().unwrap());
    args.extend(focus.iter().map(String::as_str));
    let o = tiltfield(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let route = &json_of(&o)["antialias"];
    assert_eq!(route["layered"], true, "{route}");
    for key in ["used", "layered", "boxed", "max_samples", "views_by_cell"] {
        assert_eq!(report["antialias"][key], route[key], "{key}: {report}");
    }
    focus.push("--strategy=compute".into());
    let want = render_state(lf, &a, &focus, &d.join("ra.png"));
    assert_eq!(
        std::fs::read(d.join("a_refocus.png")).unwrap(),
        want,
        "viewer (compute) ≠ render --strategy compute"
    );
}

#[test]
fn scripted_session_matches_render_and_has_no_validation_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lf = "builtin:tilted";
    let script = format!(
        "# initial state, then keyboard, click, scene navigation and a resize\n\
         wait-converged\n\
         screenshot {d}/a\n\
         key UP 3\n\
         key shift+W 2\n\
         key LEFT_BRACKET 3\n\
         key A\n\
         wait-converged\n\
         screenshot {d}/b\n\
         click refocus 32 40\n\
         wait-converged\n\
         screenshot {d}/c\n\
         key X\n\
         wait-converged\n\
         screenshot {d}/c2\n\
         key X\n\
         key P\n\
         resize 640 400\n\
         drag scene 100 100 140 110\n\
         scroll scene 1\n\
         scroll refocus 2\n\
         wait-converged\n\
         screenshot {d}/d\n\
         quit\n",
        d = d.display()
    );
    let prefix = d.join("key");
    let (report, _) = run_script(
        d,
        "session.txt",
        &script,
        &[lf, "--screenshot-prefix", prefix.to_str().unwrap()],
    );
    assert!(report["frames"]["count"].as_u64().unwrap() >= 4, "{report}");
    // The strategy is the device's choice (render's default too, so the images below match).
    assert_eq!(report["strategy_source"], "auto", "{report}");
    assert!(report["frames"]["full_quality_gpu_ms_median"]
        .as_f64()
        .is_some());

    // a: the initial focus is disparity 0 (the scene's focus distance).
    let a = json_file(&d.join("a.json"));
    assert_eq!(a["focus_how"], "disparity");
    assert_eq!(a["antialias"]["used"], true, "{a}");
    let want = render_state(lf, &a, &["--disparity=0".into()], &d.join("ra.png"));
    assert_eq!(
        std::fs::read(d.join("a_refocus.png")).unwrap(),
        want,
        "a: viewer ≠ render"
    );

    // b: three degrees of tilt, 0.2 % farther, a smaller square aperture.
    let b = json_file(&d.join("b.json"));
    assert_eq!(b["aperture"]["shape"], "square");
    let r = b["aperture"]["radius"].as_f64().unwrap();
    let start = 2f64.hypot(2.0); // the disk covering the 5×5 grid
    assert!((r - (start - 1.5)).abs() < 1e-9, "radius {r}");
    let n = numbers(&b["plane"]["normal"]);
    let tilt = n[1].atan2(n[2]).to_degrees();
    assert!((tilt - 3.0).abs() < 1e-6, "tilt {tilt}");
    let want = render_state(lf, &b, &plane_args(&b), &d.join("rb.png"));
    assert_eq!(
        std::fs::read(d.join("b_refocus.png")).unwrap(),
        want,
        "b: viewer ≠ render"
    );
    assert!(b["views_used"].as_u64().unwrap() < 25);

    // c: a click on the tilted floor finds its normal (40° about x) and matches render --click.
    let c = json_file(&d.join("c.json"));
    assert_eq!(c["focus_how"], "click");
    let n = numbers(&c["plane"]["normal"]);
    let n = DVec3::new(n[0], n[1], n[2]);
    let floor = DVec3::new(0.0, 40f64.to_radians().sin(), 40f64.to_radians().cos());
    let angle = n
        .angle_between(floor)
        .to_degrees()
        .min(n.angle_between(-floor).to_degrees());
    assert!(angle < 2.0, "click normal {n} is {angle}° from the floor's");
    let want = render_state(lf, &c, &["--click=32,40".into()], &d.join("rc.png"));
    assert_eq!(
        std::fs::read(d.join("c_refocus.png")).unwrap(),
        want,
        "c: viewer ≠ render"
    );
    // c2: X turned anti-aliasing off: the plain sum, as render --antialias off draws it.
    let c2 = json_file(&d.join("c2.json"));
    assert_eq!(c["antialias"]["used"], true, "{c}");
    assert_eq!(c2["antialias"]["used"], false, "{c2}");
    let want = render_state(lf, &c2, &["--click=32,40".into()], &d.join("rc2.png"));
    let got = std::fs::read(d.join("c2_refocus.png")).unwrap();
    assert_eq!(got, want, "c2: viewer ≠ render --antialias off");
    assert_ne!(got, std::fs::read(d.join("c_refocus.png")).unwrap());

    // The P key wrote the same set of files with the prefix and a counter.
    for suffix in ["_refocus.png", "_scene.png", "_window.png", ".json"] {
        assert!(d.join(format!("key-1{suffix}")).exists(), "key-1{suffix}");
    }

    // d: after the resize the window and the scene panel have the new sizes; the scene view
    // moved (drag, zoom) and the plane moved nearer (scroll).
    let window = decoded(&d.join("d_window.png"));
    assert_eq!(window.dimensions(), (640, 400));
    let layout = Layout::new(640, 400, (64, 64));
    let scene = decoded(&d.join("d_scene.png"));
    assert_eq!(
        scene.dimensions(),
        (layout.scene.width as u32, layout.scene.height as u32)
    );
    assert_ne!(
        decoded(&d.join("a_scene.png")),
        decoded(&d.join("b_scene.png")),
        "tilt moves the quad"
    );
    let dj = json_file(&d.join("d.json"));
    // The clicked plane is tilted: the scroll moved it along the axis and kept its normal.
    assert_eq!(dj["focus_how"], "plane");
    let cj = json_file(&d.join("c.json"));
    let (nc, nd) = (
        numbers(&cj["plane"]["normal"]),
        numbers(&dj["plane"]["normal"]),
    );
    // The same orientation (the normal's sign is free), and not frontoparallel.
    let dot: f64 = nc.iter().zip(&nd).map(|(a, b)| a * b).sum();
    assert!(
        dot.abs() > 1.0 - 1e-9 && nc[2].abs() < 0.99,
        "{nc:?} {nd:?}"
    );
    assert_ne!(
        cj["plane"]["point"], dj["plane"]["point"],
        "the scroll moved the plane"
    );
    let want = render_state(lf, &dj, &plane_args(&dj), &d.join("rd.png"));
    let got = decoded(&d.join("d_refocus.png"));
    let want_img = image::load_from_memory(&want).unwrap().to_rgba8();
    // The plane re-rendered by `render --plane`: equal up to rounding of m.
    let differing = got
        .pixels()
        .zip(want_img.pixels())
        .filter(|(a, b)| a.0.iter().zip(b.0.iter()).any(|(x, y)| x.abs_diff(*y) > 1))
        .count();
    assert_eq!(differing, 0);
    // The plane quad is visible in the scene panel: some pixels are tinted with its blue.
    let blueish = scene
        .pixels()
        .filter(|p| p.0[2] > 60 && p.0[2] as i32 > p.0[0] as i32 + 40)
        .count();
    assert!(blueish > 100, "{blueish} plane-coloured pixels");
}

/// A light field without a depth map: synth's demo scene as an HCI folder, its ground truth
/// removed.
fn demo_without_depth(dir: &Path, grid: &str, size: &str) -> String {
    let lf = dir.join("nodepth");
    let o = tiltfield(&[
        "synth",
        "builtin:demo",
        "--grid",
        grid,
        "--size",
        size,
        "-o",
        lf.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for e in std::fs::read_dir(&lf).unwrap() {
        let p = e.unwrap().path();
        if p.file_name().unwrap().to_string_lossy().starts_with("gt_") {
            std::fs::remove_file(p).unwrap();
        }
    }
    lf.display().to_string()
}

#[test]
fn without_depth_the_window_opens_at_once_and_depth_arrives_in_the_background() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lf = demo_without_depth(d, "7x7", "256x256");
    // A cache of its own: the estimate really runs (a cached one would arrive at once).
    let cache = d.join("cache");
    let script = d.join("s.txt");
    std::fs::write(
        &script,
        format!(
            "screenshot {d}/early
             click refocus 128 60
             wait-converged
             screenshot {d}/a
             quit
",
            d = d.display()
        ),
    )
    .unwrap();
    let o = view_in_xvfb_cached(
        &[&lf, "--script", script.to_str().unwrap(), "--json"],
        &cache,
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["validation_errors"], 0, "{err}");
    let first = report["first_frame_ms"].as_f64().unwrap();
    let ready = report["depth_ready_ms"].as_f64().unwrap();
    // The window shows the loading screen before the views are read and decoded.
    let window = report["window_ms"].as_f64().unwrap();
    assert!(
        window < first,
        "window after {window} ms, first frame {first} ms"
    );
    assert!(first < 5000.0, "first frame after {first} ms");
    assert!(first < ready, "first frame {first} ms, depth {ready} ms");
    assert_eq!(
        report["depth"]["origin"], "estimated",
        "{}",
        report["depth"]
    );
    assert_eq!(report["depth"]["cached"], false, "{}", report["depth"]);
    // Progress on stderr for scripts, and the arrival.
    assert!(err.contains("estimating the depth of 'demo'"), "{err}");
    assert!(err.contains("ready after"), "{err}");
    // The first screenshot is the first frame, before depth: no anti-aliasing yet.
    let early = json_file(&d.join("early.json"));
    assert_eq!(early["antialias"]["used"], false, "{early}");
    assert_eq!(early["frames_presented"], 1, "{early}");
    // The click waited for depth, and found the brick wall's plane; with depth came
    // anti-aliasing (on by default with depth). The screenshot equals render on the same
    // (cached) estimate.
    let a = json_file(&d.join("a.json"));
    assert_eq!(a["focus_how"], "click", "{a}");
    assert_eq!(a["antialias"]["used"], true, "{a}");
    let want = render_state_cached(
        &lf,
        &a,
        &["--click=128,60".into()],
        &d.join("ra.png"),
        Some(&cache),
    );
    assert_eq!(
        std::fs::read(d.join("a_refocus.png")).unwrap(),
        want,
        "viewer ≠ render after depth arrived"
    );
    // The scene panel shows the cloud once depth is there: more distinct colours than the
    // plane quad and camera frustums alone.
    let colours = |p: &str| {
        let img = decoded(&d.join(p));
        let mut c: Vec<[u8; 4]> = img.pixels().map(|p| p.0).collect();
        c.sort_unstable();
        c.dedup();
        c.len()
    };
    assert!(
        colours("a_scene.png") > 4 * colours("early_scene.png"),
        "{} vs {} colours",
        colours("a_scene.png"),
        colours("early_scene.png")
    );
}

/// `render`'s options for the focus surface a screenshot recorded (its first plane is the
/// focus).
fn surface_args(state: &serde_json::Value) -> Vec<String> {
    let surface = &state["surface"];
    let plane = |p: &serde_json::Value| {
        let v: Vec<String> = numbers(&p["point"])
            .into_iter()
            .chain(numbers(&p["normal"]))
            .map(|x| format!("{x:?}"))
            .collect();
        format!("--plane={}", v.join(","))
    };
    let planes = surface["planes"].as_array().unwrap();
    match surface["kind"].as_str().unwrap() {
        "planes" => planes.iter().map(plane).collect(),
        "slab" => vec![
            plane(&planes[0]),
            format!("--slab={:?}", surface["slab_half_width"].as_f64().unwrap()),
        ],
        "all-in-focus" => vec![plane(&planes[0]), "--all-in-focus".into()],
        _ => vec![plane(&planes[0])],
    }
}

/// Pixels of the scene panel tinted with the focus surface's light blue (its further planes).
fn surface_tinted(scene: &image::RgbaImage) -> usize {
    scene
        .pixels()
        .filter(|p| {
            let [r, g, b, _] = p.0;
            // Lighter than the focus plane's blue: green well above red, blue highest.
            b > 150 && g > 110 && g as i32 > r as i32 + 40 && b >= g
        })
        .count()
}

#[test]
fn focus_surfaces_from_keys_match_render_and_show_in_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lf = "builtin:demo";
    let script = format!(
        "wait-converged\n\
         screenshot {d}/p\n\
         # keep the card's plane, focus farther, keep that too, move on: three planes\n\
         click refocus 60 80\n\
         key N\n\
         scroll refocus -6\n\
         key N\n\
         key UP 2\n\
         wait-converged\n\
         screenshot {d}/a\n\
         # a slab is refused next to kept planes; Shift+Backspace clears them\n\
         key EQUAL\n\
         wait-converged\n\
         screenshot {d}/refused\n\
         key BACKSPACE\n\
         key shift+BACKSPACE\n\
         key EQUAL 3\n\
         wait-converged\n\
         screenshot {d}/b\n\
         key G\n\
         wait-converged\n\
         screenshot {d}/c\n\
         key G\n\
         key MINUS 3\n\
         wait-converged\n\
         screenshot {d}/e\n\
         quit\n",
        d = d.display()
    );
    let (report, _) = run_script(d, "surfaces.txt", &script, &[lf]);
    // Every screenshot equals render given the same surface, byte for byte.
    for (shot, kind, planes) in [
        ("p", "plane", 1),
        ("a", "planes", 3),
        ("b", "slab", 1),
        ("c", "all-in-focus", 1),
        ("e", "plane", 1),
    ] {
        let state = json_file(&d.join(format!("{shot}.json")));
        let surface = &state["surface"];
        assert_eq!(surface["kind"], kind, "{shot}: {surface}");
        assert_eq!(
            surface["planes"].as_array().unwrap().len(),
            planes,
            "{shot}: {surface}"
        );
        let want = render_state(
            lf,
            &state,
            &surface_args(&state),
            &d.join(format!("r{shot}.png")),
        );
        assert_eq!(
            std::fs::read(d.join(format!("{shot}_refocus.png"))).unwrap(),
            want,
            "{shot}: viewer ≠ render with the same surface"
        );
    }
    // The slab: three 2 % steps of the plane's distance; its boundaries are reported.
    let b = json_file(&d.join("b.json"));
    assert_eq!(b["surface"]["slab_boundaries"].as_array().unwrap().len(), 2);
    let w = b["surface"]["slab_half_width"].as_f64().unwrap();
    assert!(w > 0.0, "{w}");
    // Surfaces change the image; the refusal changed nothing and said why.
    let refocus = |s: &str| std::fs::read(d.join(format!("{s}_refocus.png"))).unwrap();
    assert_ne!(refocus("a"), refocus("p"));
    assert_ne!(refocus("c"), refocus("b"));
    let refused = json_file(&d.join("refused.json"));
    assert_eq!(refused["surface"]["kind"], "planes");
    assert!(
        refused["message"].as_str().unwrap_or("").contains("slab"),
        "{refused}"
    );
    assert_eq!(refocus("refused"), refocus("a"));
    // The scene panel draws the further planes (kept planes, slab boundaries) as their own
    // quads; a single plane has none.
    let tinted = |s: &str| surface_tinted(&decoded(&d.join(format!("{s}_scene.png"))));
    assert!(
        tinted("a") > 200,
        "{} tinted pixels with three planes",
        tinted("a")
    );
    assert!(
        tinted("b") > 200,
        "{} tinted pixels with a slab",
        tinted("b")
    );
    assert!(
        tinted("p") < tinted("a") / 4,
        "{} vs {}",
        tinted("p"),
        tinted("a")
    );
    // --json names the final surface.
    assert_eq!(report["surface"]["kind"], "plane", "{}", report["surface"]);
}

#[test]
fn feedback_highlights_the_changed_field_and_shows_refusals_where_clicked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Three collinear shift-clicks along a row: the third is refused.
    let script = format!(
        "wait-converged\n\
         key UP\n\
         screenshot {d}/a\n\
         wait 1.6\n\
         screenshot {d}/b\n\
         shift-click refocus 20 150\n\
         shift-click refocus 60 150\n\
         shift-click refocus 100 150\n\
         wait-converged\n\
         screenshot {d}/c\n\
         quit\n",
        d = d.display()
    );
    run_script(d, "feedback.txt", &script, &["builtin:demo"]);
    let layout = Layout::new(1280, 720, (192, 192));
    let strip = layout.status;
    // The highlight's amber behind the changed field (the tilt), in the strip only while it
    // lasts.
    let amber = |img: &image::RgbaImage| {
        img.enumerate_pixels()
            .filter(|(_, y, p)| {
                *y as f32 >= strip.y && p.0[0] > 110 && (50..130).contains(&p.0[1]) && p.0[2] < 40
            })
            .count()
    };
    let a = decoded(&d.join("a_window.png"));
    let b = decoded(&d.join("b_window.png"));
    assert!(
        amber(&a) > 100,
        "{} amber pixels right after the key",
        amber(&a)
    );
    assert_eq!(amber(&b), 0, "the highlight is gone after a moment");
    // The refusal of the third click is drawn next to it: orange text within a box below
    // and right of the click, not along the panel's bottom.
    let c = json_file(&d.join("c.json"));
    assert!(
        c["message"].as_str().unwrap_or("").contains("collinear"),
        "{c}"
    );
    let at = layout.refocus_to_window(glam::DVec2::new(100.0, 150.0), (192, 192));
    let window = decoded(&d.join("c_window.png"));
    let orange_near = window
        .enumerate_pixels()
        .filter(|(x, y, p)| {
            let (dx, dy) = (*x as f64 - at.x, *y as f64 - at.y);
            (0.0..500.0).contains(&dx)
                && (0.0..60.0).contains(&dy)
                && p.0[0] > 200
                && (140..230).contains(&p.0[1])
                && p.0[2] < 110
        })
        .count();
    assert!(
        orange_near > 100,
        "{orange_near} message pixels next to the click"
    );
}

#[test]
fn the_control_panel_sets_values_by_drag_and_toggles_by_click() {
    use tiltfield::viewer::panel::{Button, ControlPanel, Slider};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let layout = Layout::new(1280, 720, (192, 192));
    let panel = ControlPanel::new(layout.scene, 1.0);
    let track = |s: Slider| panel.sliders.iter().find(|(t, _)| *t == s).unwrap().1;
    let button = |b: Button| {
        let r = panel.buttons.iter().find(|(t, _)| *t == b).unwrap().1;
        (r.x + r.width / 2.0, r.y + r.height / 2.0)
    };
    // Tilt: from the middle (0°) to three quarters of the track (+30°); the aperture radius
    // to the track's start (0); anti-aliasing off; the plane kept.
    let tilt = track(Slider::Tilt);
    let radius = track(Slider::Radius);
    let (ty, tx0, tx1) = (
        tilt.y + 4.0,
        tilt.x + 0.5 * tilt.width,
        tilt.x + 0.75 * tilt.width,
    );
    let aa = button(Button::Antialias);
    let keep = button(Button::Keep);
    let script = format!(
        "wait-converged\n\
         key TAB\n\
         drag window {tx0} {ty} {tx1} {ty}\n\
         drag window {rx0} {ry} {rx1} {ry}\n\
         click window {ax} {ay}\n\
         click window {kx} {ky}\n\
         wait-converged\n\
         screenshot {d}/a\n\
         key TAB\n\
         wait-converged\n\
         screenshot {d}/b\n\
         quit\n",
        rx0 = radius.x + 0.5 * radius.width,
        rx1 = radius.x - 20.0,
        ry = radius.y + 4.0,
        ax = aa.0,
        ay = aa.1,
        kx = keep.0,
        ky = keep.1,
        d = d.display()
    );
    let lf = "builtin:demo";
    run_script(d, "panel.txt", &script, &[lf]);
    let a = json_file(&d.join("a.json"));
    let n = numbers(&a["plane"]["normal"]);
    let tilt_deg = n[1].atan2(n[2]).to_degrees();
    assert!(
        (tilt_deg - 30.0).abs() < 1.0,
        "tilt {tilt_deg}° after the drag: {a}"
    );
    assert_eq!(a["aperture"]["radius"].as_f64(), Some(0.0), "{a}");
    assert_eq!(a["antialias"]["used"], false, "{a}");
    assert_eq!(a["surface"]["kind"], "planes", "{a}");
    // What the panel set renders as render renders it.
    let want = render_state(lf, &a, &surface_args(&a), &d.join("ra.png"));
    assert_eq!(std::fs::read(d.join("a_refocus.png")).unwrap(), want);
    // The panel is drawn over the scene panel while shown (its dark background), and Tab
    // hides it; the drags did not orbit the scene behind it.
    let dark = |s: &str| {
        let img = decoded(&d.join(format!("{s}_window.png")));
        let r = panel.rect;
        (r.x as u32 + 2..(r.x + r.width) as u32 - 2)
            .flat_map(|x| (r.y as u32 + 30..r.y as u32 + 40).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y).0[..3].iter().all(|&c| c < 40))
            .count()
    };
    assert!(dark("a") > 1000, "{}", dark("a"));
    assert_eq!(
        decoded(&d.join("a_scene.png")),
        decoded(&d.join("b_scene.png")),
        "the scene camera did not move"
    );
}

#[test]
fn an_idle_viewer_renders_nothing_and_present_modes_fall_back_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = d.join("idle.txt");
    std::fs::write(
        &script,
        format!(
            "wait-converged\nscreenshot {d}/a\nwait 1.0\nscreenshot {d}/b\nquit\n",
            d = d.display()
        ),
    )
    .unwrap();
    for mode in ["immediate", "mailbox"] {
        let o = view_in_xvfb(&[
            "builtin:planes",
            "--present",
            mode,
            "--script",
            script.to_str().unwrap(),
            "--json",
        ]);
        assert!(o.status.success(), "{mode}: {}", stderr(&o));
        let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(report["validation_errors"], 0);
        let used = report["present_mode"].as_str().unwrap();
        assert!(used == mode || used == "fifo", "{mode} → {used}");
        // A second of idling between the screenshots: only the second screenshot's own frame.
        let a = json_file(&d.join("a.json"))["frames_presented"]
            .as_u64()
            .unwrap();
        let b = json_file(&d.join("b.json"))["frames_presented"]
            .as_u64()
            .unwrap();
        assert_eq!(b, a + 1, "{mode}: frames while idle");
    }
}

/// A 4×4 camera-array video of 64×48 views, frames 1 to 3 (a card moving before a wall), in
/// `d/video`, and its rig.
/// Runs the viewer under xvfb on `birthday_video` in `d` with `args` and the script `lines`
/// (`{d}` replaced by `d`), its depth cached in `d/cache`; asserts it ran cleanly with no
/// validation error. Returns the video's folder and the cache.
fn view_video_script(
    d: &Path,
    lines: &str,
    args: &[&str],
) -> (std::path::PathBuf, std::path::PathBuf) {
    let (video, _) = birthday_video(d);
    let cache = d.join("cache");
    let script = d.join("frames.txt");
    std::fs::write(&script, lines.replace("{d}", &d.display().to_string())).unwrap();
    let mut all = vec![video.to_str().unwrap()];
    all.extend(args);
    all.extend(["--script", script.to_str().unwrap(), "--json"]);
    let o = view_in_xvfb_cached(&all, &cache);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["validation_errors"], 0);
    (video, cache)
}

fn birthday_video(d: &Path) -> (std::path::PathBuf, realworld_rig::Rig) {
    let video = d.join("video");
    std::fs::create_dir_all(&video).unwrap();
    let rig = realworld_rig::rig(tiltfield::lightfield::GridSize { cols: 4, rows: 4 }, 64, 48);
    realworld_rig::write_video(&video, &rig, "Birthday", &[1, 2, 3]);
    (video, rig)
}

#[test]
fn video_frames_step_with_comma_and_period_and_match_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (video, rig) = birthday_video(d);
    let (p, n) = rig.wall_plane();
    let plane: Vec<String> = [p.x, p.y, p.z, n.x, n.y, n.z]
        .iter()
        .map(|v| format!("{v:?}"))
        .collect();
    let plane = format!("--plane={}", plane.join(","));
    let script = d.join("frames.txt");
    std::fs::write(
        &script,
        format!(
            "wait-converged\nscreenshot {d}/f1\nkey PERIOD\nwait-converged\nscreenshot {d}/f2\n\
             key PERIOD 2\nwait-converged\nscreenshot {d}/f3\nkey COMMA\nwait-converged\n\
             screenshot {d}/g2\nquit\n",
            d = d.display()
        ),
    )
    .unwrap();
    let v = video.to_str().unwrap();
    let o = view_in_xvfb(&[v, &plane, "--script", script.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["validation_errors"], 0);
    // A video carries no depth map: the viewer estimated one (for clicks and the cloud).
    assert_eq!(
        report["depth"]["origin"], "estimated",
        "{}",
        report["depth"]
    );
    // Each screenshot shows the frame it names, exactly as render --frame draws it (with
    // depth the viewer anti-aliases: render --antialias on estimates the same); the period at
    // the last frame stays there.
    for (shot, frame) in [("f1", 1), ("f2", 2), ("f3", 3), ("g2", 2)] {
        let state = json_file(&d.join(format!("{shot}.json")));
        assert_eq!(state["frame"], frame, "{shot}");
        let out = d.join(format!("r{shot}.png"));
        let frame_arg = format!("--frame={frame}");
        let o = tiltfield(&[
            "render",
            v,
            &plane,
            &frame_arg,
            "--antialias=on",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            std::fs::read(d.join(format!("{shot}_refocus.png"))).unwrap(),
            std::fs::read(&out).unwrap(),
            "{shot}: viewer ≠ render --frame {frame}"
        );
    }
    assert_ne!(
        std::fs::read(d.join("f1_refocus.png")).unwrap(),
        std::fs::read(d.join("f2_refocus.png")).unwrap(),
        "frames differ"
    );
}

/// With anti-aliasing on, each video frame the viewer steps to is anti-aliased on its own
/// depth, estimated in the background (the card moves between frames): the converged frame
/// equals `render --frame N --antialias on`, which differs from the plain sum.
#[test]
fn video_frames_anti_alias_on_their_own_depth_as_render_does() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let focus = ["--focus", "2.4", "--aperture-radius", "1.5"];
    let mut args = focus.to_vec();
    args.extend(["--antialias", "on"]);
    let (video, cache) = view_video_script(
        d,
        "wait-converged\nkey PERIOD\nwait-converged\nscreenshot {d}/f2\nkey PERIOD\n\
         wait-converged\nscreenshot {d}/f3\nquit\n",
        &args,
    );
    let v = video.to_str().unwrap();
    for (shot, frame) in [("f2", 2), ("f3", 3)] {
        let state = json_file(&d.join(format!("{shot}.json")));
        assert_eq!(state["frame"], frame, "{shot}");
        assert_eq!(state["antialias"]["used"], true, "{shot}");
        let frame_arg = format!("--frame={frame}");
        let render = |aa: &str, out: &Path| {
            let mut args = vec!["render", v, &frame_arg];
            args.extend(focus);
            args.extend(["--antialias", aa, "-o", out.to_str().unwrap()]);
            let o = common::tiltfield_cached(&args, &cache);
            assert!(o.status.success(), "{}", stderr(&o));
            std::fs::read(out).unwrap()
        };
        let viewer = std::fs::read(d.join(format!("{shot}_refocus.png"))).unwrap();
        assert!(
            viewer == render("on", &d.join(format!("aa{shot}.png"))),
            "{shot}: viewer ≠ render --frame {frame} --antialias on"
        );
        assert!(
            viewer != render("off", &d.join(format!("plain{shot}.png"))),
            "{shot}: anti-aliasing changed nothing"
        );
    }
}

/// All in focus (G) on a video: every frame the viewer steps to chooses its focus on that
/// frame's own depth, as `render --frame N --all-in-focus` does (here without anti-aliasing,
/// so the surface alone reads the depth).
#[test]
fn video_frames_keep_all_in_focus_on_their_own_depth_as_render_does() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let focus = [
        "--focus",
        "2.4",
        "--aperture-radius",
        "1.5",
        "--antialias",
        "off",
    ];
    let (video, cache) = view_video_script(
        d,
        "wait-converged\nkey G\nwait-converged\nkey PERIOD\nwait-converged\n\
         screenshot {d}/f2\nquit\n",
        &focus,
    );
    let v = video.to_str().unwrap();
    let state = json_file(&d.join("f2.json"));
    assert_eq!(state["frame"], 2);
    assert_eq!(state["surface"]["kind"], "all-in-focus", "{state}");
    let render = |surface: Option<&str>, out: &Path| {
        let mut args = vec!["render", v, "--frame=2"];
        args.extend(focus);
        args.extend(surface);
        args.extend(["-o", out.to_str().unwrap()]);
        let o = common::tiltfield_cached(&args, &cache);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(out).unwrap()
    };
    let viewer = std::fs::read(d.join("f2_refocus.png")).unwrap();
    assert!(
        viewer == render(Some("--all-in-focus"), &d.join("all.png")),
        "viewer ≠ render --frame 2 --all-in-focus"
    );
    assert!(
        viewer != render(None, &d.join("plane.png")),
        "all in focus changed nothing"
    );
}

/// `view --filter bicubic` samples the views as `render --filter bicubic` does: at a focus
/// that reads every view between its pixels the converged image equals that render, byte for
/// byte, and differs from the bilinear one.
#[test]
fn the_filter_option_samples_as_render_does() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = d.join("cubic");
    let script = format!("wait-converged\nscreenshot {}\nquit\n", shot.display());
    let focus = ["--disparity", "1.3"];
    let mut args = vec!["builtin:demo", "--filter", "bicubic", "--window", "640x400"];
    args.extend(focus);
    let (report, _) = run_script(d, "cubic.txt", &script, &args);
    assert_eq!(report["filter"], "bicubic", "{report}");
    let state = json_file(&d.join("cubic.json"));
    assert_eq!(state["filter"], "bicubic", "{state}");
    let focus: Vec<String> = focus.iter().map(|s| s.to_string()).collect();
    let viewer = std::fs::read(d.join("cubic_refocus.png")).unwrap();
    let render = render_state("builtin:demo", &state, &focus, &d.join("render.png"));
    assert!(viewer == render, "viewer ≠ render --filter bicubic");
    let mut bilinear = state.clone();
    bilinear["filter"] = "hardware".into();
    let plain = render_state("builtin:demo", &bilinear, &focus, &d.join("bilinear.png"));
    assert!(viewer != plain, "the filter changed nothing");
}

#[test]
fn bad_scripts_are_refused_with_the_line_before_any_window_opens() {
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("bad.txt");
    let s_arg = s.to_str().unwrap();
    for (text, needles) in [
        ("wait 1\nfly 3\n", &["line 2", "unknown command 'fly'"][..]),
        ("key UP many\n", &["line 1", "count"][..]),
    ] {
        std::fs::write(&s, text).unwrap();
        // No display is needed to be told: the script is checked before the window opens.
        let o = Command::new(env!("CARGO_BIN_EXE_tiltfield"))
            .args(["view", "builtin:planes", "--script", s_arg])
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .unwrap();
        let err = stderr(&o);
        assert!(!o.status.success(), "{text}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        for n in needles {
            assert!(err.contains(n), "{text}: expected '{n}' in {err}");
        }
    }
    // Positions are checked against the light field's size, known once it is read: the
    // window (open from the start, showing the loading screen) closes with the line named.
    for (text, needles) in [
        (
            "click refocus 64 3\n",
            &["line 1", "outside the 64×64 view"][..],
        ),
        (
            "resize 800 600\nclick scene 700 10\n",
            &["line 2", "outside the scene panel"][..],
        ),
    ] {
        std::fs::write(&s, text).unwrap();
        let o = view_in_xvfb(&["builtin:planes", "--script", s_arg]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{text}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        for n in needles {
            assert!(err.contains(n), "{text}: expected '{n}' in {err}");
        }
    }
    fails_with(
        &["view", "builtin:planes", "--script", "/no/such/script.txt"],
        &["/no/such/script.txt"],
    );
    fails_with(
        &["view", "builtin:planes", "--window", "10x10"],
        &["--window", "64"],
    );
    fails_with(
        &["view", "builtin:planes", "--frame-budget-ms", "0"],
        &["--frame-budget-ms"],
    );
    fails_with(&["view", "builtin:nope"], &["no built-in scene 'nope'"]);
}

#[test]
fn without_a_display_the_viewer_says_so() {
    let o = Command::new(env!("CARGO_BIN_EXE_tiltfield"))
        .args(["view", "builtin:planes"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("display") && err.contains("xvfb-run"), "{err}");
}

/// The status strip reads the depth under the cursor over the refocus image (the light
/// field's own map here), and nothing off it; the screenshot JSON carries the reading.
#[test]
fn the_strip_reads_the_depth_under_the_cursor() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = format!(
        "wait 0\n\
         click window 120 200\n\
         wait-converged\n\
         screenshot {d}/over\n\
         click window 1000 20\n\
         wait-converged\n\
         screenshot {d}/off\n\
         quit\n",
        d = d.display()
    );
    run_script(
        d,
        "hover.txt",
        &script,
        &["builtin:demo", "--window", "1120x600"],
    );
    let over = json_file(&d.join("over.json"));
    let reading = over["cursor_depth"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    assert!(
        reading.starts_with("cursor: z ") && reading.ends_with("(given)"),
        "{over}"
    );
    let z: f64 = reading["cursor: z ".len()..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(z.is_finite() && z > 0.0, "{reading}");
    let off = json_file(&d.join("off.json"));
    assert!(off["cursor_depth"].is_null(), "{off}");
}

/// Ctrl+Z takes a click's plane back and Ctrl+Shift+Z brings it again (the screenshots' JSON
/// records the plane in effect); with nothing left to undo the strip says so and the plane
/// stays.
#[test]
fn undo_and_redo_take_a_click_back_and_bring_it_again() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = format!(
        "screenshot {d}/before\n\
         click refocus 32 40\n\
         screenshot {d}/clicked\n\
         key ctrl+Z\n\
         screenshot {d}/undone\n\
         key ctrl+shift+Z\n\
         screenshot {d}/redone\n\
         key ctrl+Z 3\n\
         screenshot {d}/exhausted\n\
         quit\n",
        d = d.display()
    );
    let (_, _) = run_script(
        d,
        "undo.txt",
        &script,
        &["builtin:tilted", "--antialias", "off"],
    );
    let plane = |name: &str| {
        let s = json_file(&d.join(format!("{name}.json")));
        let p = &s["plane"];
        let mut v = numbers(&p["point"]);
        v.extend(numbers(&p["normal"]));
        v
    };
    let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9);
    let (before, clicked) = (plane("before"), plane("clicked"));
    assert!(!close(&before, &clicked), "the click moved the plane");
    assert!(
        close(&plane("undone"), &before),
        "undo: {:?}",
        plane("undone")
    );
    assert!(
        close(&plane("redone"), &clicked),
        "redo: {:?}",
        plane("redone")
    );
    assert!(close(&plane("exhausted"), &before));
}

/// P says where its screenshot went, in the strip (the next screenshot's JSON records the
/// notice), and the notice goes after a few seconds; three clicks along one image row are
/// refused in the user's terms.
#[test]
fn p_says_where_the_screenshot_went_and_collinear_clicks_are_explained() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let prefix = d.join("shot");
    let script = format!(
        "key P\n\
         screenshot {d}/after_p\n\
         wait 4.5\n\
         screenshot {d}/later\n\
         shift-click refocus 10 30\n\
         shift-click refocus 20 30\n\
         shift-click refocus 30 30\n\
         screenshot {d}/collinear\n\
         quit\n",
        d = d.display()
    );
    run_script(
        d,
        "notice.txt",
        &script,
        &[
            "builtin:tilted",
            "--antialias",
            "off",
            "--screenshot-prefix",
            prefix.to_str().unwrap(),
        ],
    );
    assert!(d.join("shot-1_window.png").is_file(), "P wrote its files");
    let after = json_file(&d.join("after_p.json"));
    let notice = after["notice"].as_str().unwrap_or("");
    assert!(
        notice.starts_with("saved ") && notice.contains("shot-1_window.png"),
        "{after}"
    );
    assert!(json_file(&d.join("later.json"))["notice"].is_null());
    let c = json_file(&d.join("collinear.json"));
    let message = c["message"].as_str().unwrap_or("");
    assert!(
        message.contains("one line in the image") && message.contains("off that line"),
        "{c}"
    );
}

/// The viewer's refinement with `switch on` (`key` in its screenshot's `antialias` report),
/// batch by batch, converges to exactly what `render switch on` writes.
fn refinement_converges_to_render(switch: &str, key: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lf = "builtin:tilted";
    let script = format!("wait-converged\nscreenshot {d}/a\nquit\n", d = d.display());
    run_script(d, "refine.txt", &script, &[lf, switch, "on"]);
    let a = json_file(&d.join("a.json"));
    assert_eq!(a["antialias"][key], true, "{a}");
    let out = d.join("render.png");
    let o = tiltfield(&[
        "render",
        lf,
        "-o",
        out.to_str().unwrap(),
        "--disparity=0",
        switch,
        "on",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(d.join("a_refocus.png")).unwrap(),
        std::fs::read(&out).unwrap(),
        "viewer ≠ render with {switch} on"
    );
}

/// With defocused views (`--antialias-defocus on`) the viewer's refinement, batch by batch,
/// converges to exactly what `render --antialias-defocus on` writes.
#[test]
fn defocused_views_converge_to_render() {
    refinement_converges_to_render("--antialias-defocus", "defocus");
}

/// With layered footprints (`--antialias-layered on`) the viewer's refinement, batch by batch
/// (each batch adds its views to the layers and composites them again), converges to exactly
/// what `render --antialias-layered on` writes.
#[test]
fn layered_footprints_converge_to_render() {
    refinement_converges_to_render("--antialias-layered", "layered");
}

/// O after a click tints what is in focus: a share of the refocus panel between 2 % and 60 %
/// (the screenshot's JSON reports it; the window shows the magenta tint there), and O again
/// takes it away.
#[test]
fn focus_peaking_tints_part_of_the_refocus_panel() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = format!(
        "click refocus 32 40\n\
         key O\n\
         wait-converged\n\
         screenshot {d}/on\n\
         key O\n\
         wait-converged\n\
         screenshot {d}/off\n\
         quit\n",
        d = d.display()
    );
    run_script(d, "peaking.txt", &script, &["builtin:tilted"]);
    let on = json_file(&d.join("on.json"));
    let f = on["peaking"]["tinted_fraction"].as_f64().unwrap_or(-1.0);
    assert!((0.02..=0.6).contains(&f), "tinted {f}: {on}");
    let magenta = |name: &str| {
        decoded(&d.join(name))
            .pixels()
            .filter(|p| p.0[0] > 200 && p.0[1] < 140 && p.0[2] > 200)
            .count()
    };
    let (tinted, plain) = (magenta("on_window.png"), magenta("off_window.png"));
    assert!(
        tinted > plain + 1000,
        "magenta pixels {tinted} on, {plain} off"
    );
    let off = json_file(&d.join("off.json"));
    assert_eq!(off["peaking"]["on"], false);
    assert!(off["peaking"]["tinted_fraction"].is_null());
}

/// E (encoded averaging) keeps the views in the session's storage (linear16, one upload): the
/// screenshot records the storage, and `render` with the recorded `--average` and `--storage`
/// reproduces it. `render --average encoded` alone defaults to srgb8, whose sampler decode is
/// biased, so without the record the two did not match (issue 42).
#[test]
fn encoded_averaging_records_its_storage_and_render_reproduces_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lf = "builtin:tilted";
    let script = format!(
        "wait-converged\n\
         key E\n\
         wait-converged\n\
         screenshot {d}/e\n\
         quit\n",
        d = d.display()
    );
    run_script(d, "encoded.txt", &script, &[lf]);
    let e = json_file(&d.join("e.json"));
    assert_eq!(e["averaging"], "encoded", "{e}");
    assert_eq!(e["storage"], "linear16", "{e}");
    let want = render_state(lf, &e, &["--disparity=0".into()], &d.join("re.png"));
    assert_eq!(
        std::fs::read(d.join("e_refocus.png")).unwrap(),
        want,
        "viewer after E ≠ render with the recorded storage"
    );
}
