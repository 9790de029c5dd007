//! Hostile input, round 3 (issue 42): the limits that were missing (aborts and hangs), the
//! outputs that were silently wrong, what a user types first that was refused, and the
//! messages that named the wrong cause. Each case ends in a clear error naming the option, file
//! or cause (exit 1 or 2, no panic, within seconds) or in a correct result.

mod common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use common::stderr;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `tiltfield args` with the validation layer on and the depth cache in `cache`, killed after
/// `secs` (a failed test, not a hung suite).
fn run_within(secs: u64, args: &[&str], cache: &Path) -> std::process::Output {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_tiltfield"))
        .args(args)
        .env("TILTFIELD_VALIDATION", "1")
        .env("TILTFIELD_CACHE_DIR", cache)
        .env_remove("RUST_LOG")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run tiltfield");
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() >= Duration::from_secs(secs) {
            child.kill().unwrap();
            panic!("{args:?} did not finish within {secs} s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// Asserts that `args` fails within `secs` with exit status `code`, no panic, and a message
/// holding every needle; returns the message.
fn refused(secs: u64, code: i32, args: &[&str], cache: &Path, needles: &[&str]) -> String {
    let o = run_within(secs, args, cache);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
    assert!(
        !err.contains("panicked") && !err.contains("RUST_BACKTRACE"),
        "{args:?} panicked: {err}"
    );
    for n in needles {
        assert!(err.contains(n), "{args:?}: expected '{n}' in: {err}");
    }
    err
}

/// Asserts that `args` succeeds within `secs`; returns stderr.
fn accepted(secs: u64, args: &[&str], cache: &Path) -> String {
    let o = run_within(secs, args, cache);
    let err = stderr(&o);
    assert!(o.status.success(), "{args:?} failed: {err}");
    err
}

/// A 5×5 HCI folder of 48×48 views of builtin:planes, with its disparity and depth maps
/// (every pixel sees a surface).
fn planes_hci(dir: &Path) -> PathBuf {
    planes_hci_sized(dir, "planes", 48)
}

/// [`planes_hci`] named `name`, of `size²` views.
fn planes_hci_sized(dir: &Path, name: &str, size: u32) -> PathBuf {
    let lf = dir.join(name);
    let size = format!("{size}x{size}");
    accepted(
        60,
        &[
            "synth",
            "builtin:planes",
            "--grid",
            "5x5",
            "--size",
            &size,
            "-o",
            s(&lf),
        ],
        &dir.join("cache"),
    );
    lf
}

fn mkfifo(path: &Path) {
    let st = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .unwrap();
    assert!(st.success());
}

/// A one-channel little-endian PFM of `w × h` holding `value` everywhere but at `holes`
/// (row-major indices), which hold `hole`.
fn write_pfm(path: &Path, w: u32, h: u32, value: f32, holes: &[usize], hole: f32) {
    let mut bytes = format!("Pf\n{w} {h}\n-1\n").into_bytes();
    for i in 0..(w * h) as usize {
        let v = if holes.contains(&i) { hole } else { value };
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(path, bytes).unwrap();
}

/// Fraction of fully transparent pixels of a PNG.
fn transparent(path: &Path) -> f64 {
    let img = image::open(path).unwrap().to_rgba8();
    let n = img.pixels().filter(|p| p[3] == 0).count();
    n as f64 / (img.width() * img.height()) as f64
}

#[test]
fn antialias_set_counts_are_bounded_and_zero_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let base = [
        "antialias-set",
        "--size",
        "48",
        "--cases",
        "layers",
        "--no-estimate",
    ];
    // Each of these aborted on an 8 GiB allocation, hung, or ran silently as 1.
    for (extra, needles) in [
        (
            vec![
                "--truth-grid",
                "1000000",
                "--frames",
                "1",
                "--supersamples",
                "1",
            ],
            vec!["--truth-grid", "9 to 257", "1000000"],
        ),
        (
            vec!["--truth-grid", "600"],
            vec!["--truth-grid", "9 to 257"],
        ),
        (
            vec!["--truth-grid", "4294967295"],
            vec!["--truth-grid", "4294967295"],
        ),
        (
            vec!["--truth-grid", "9", "--supersamples", "1000000"],
            vec!["--supersamples", "1 to 16"],
        ),
        (vec!["--supersamples", "0"], vec!["--supersamples", "got 0"]),
        (vec!["--frames", "1000000"], vec!["--frames", "1 to 1000"]),
        (vec!["--frames", "0"], vec!["--frames", "got 0"]),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra).collect();
        refused(10, 1, &args, &cache, &needles);
    }
    // A negative count names the option (clap's parser, a usage error).
    let args: Vec<&str> = base.iter().copied().chain(["--truth-grid", "-5"]).collect();
    refused(10, 2, &args, &cache, &["--truth-grid", "-5"]);
}

#[test]
fn negative_numbers_name_their_option_not_an_unexpected_argument() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let out = tmp.path().join("x.png");
    // Checked before loading: the light field need not exist.
    for value in ["-1", "-0.5", "-1e308"] {
        let err = refused(
            10,
            1,
            &[
                "render",
                "no-such-lf",
                "--disparity",
                "0",
                "--aperture-radius",
                value,
                "-o",
                s(&out),
            ],
            &cache,
            &["--aperture-radius", "≥ 0"],
        );
        assert!(!err.contains("unexpected argument"), "{err}");
    }
    // Counts: clap names the option and the value.
    let err = refused(
        10,
        2,
        &["cloud", "no-such-lf", "-o", s(&out), "--stride", "-1"],
        &cache,
        &["--stride", "-1"],
    );
    assert!(!err.contains("unexpected argument"), "{err}");
}

#[test]
fn all_in_focus_alone_renders_where_the_depth_covers_every_pixel() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let lf = planes_hci(tmp.path());
    let out = tmp.path().join("aif.png");
    accepted(
        60,
        &["render", s(&lf), "--all-in-focus", "-o", s(&out)],
        &cache,
    );
    assert!(transparent(&out) < 0.01, "{}", transparent(&out));
    // Where the depth leaves pixels unknown, a fallback is needed and asked for by name.
    let holes = tmp.path().join("holes");
    std::fs::create_dir(&holes).unwrap();
    for e in std::fs::read_dir(&lf).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), holes.join(e.file_name())).unwrap();
    }
    std::fs::remove_file(holes.join("gt_depth_lowres.pfm")).unwrap();
    write_pfm(
        &holes.join("gt_disp_lowres.pfm"),
        48,
        48,
        0.5,
        &[0, 1, 2],
        f32::NAN,
    );
    refused(
        60,
        1,
        &["render", s(&holes), "--all-in-focus", "-o", s(&out)],
        &cache,
        &[
            "--all-in-focus",
            "unknown at 3 of 2304 pixels",
            "--disparity",
        ],
    );
    accepted(
        60,
        &[
            "render",
            s(&holes),
            "--all-in-focus",
            "--disparity",
            "0",
            "-o",
            s(&out),
        ],
        &cache,
    );
    // No focus at all is still clap's usage error.
    refused(
        10,
        2,
        &["render", s(&lf), "-o", s(&out)],
        &cache,
        &["--all-in-focus"],
    );
}

#[test]
fn a_cloud_slab_reaching_the_camera_is_refused_as_render_refuses_it() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let lf = planes_hci(tmp.path());
    let ply = tmp.path().join("c.ply");
    let png = tmp.path().join("r.png");
    let slab = ["--focus", "8", "--slab", "1000"];
    let cloud = refused(
        60,
        1,
        &[&["cloud", s(&lf), "-o", s(&ply)][..], &slab].concat(),
        &cache,
        &["inside the focus slab", "1000"],
    );
    assert!(!ply.exists(), "a refused cloud wrote its file");
    let render = refused(
        60,
        1,
        &[&["render", s(&lf), "-o", s(&png)][..], &slab].concat(),
        &cache,
        &["inside the focus slab"],
    );
    assert_eq!(cloud, render, "one check, one message");
    // A slab that clears the camera still writes its two boundaries.
    let err = accepted(
        60,
        &[
            "cloud",
            s(&lf),
            "-o",
            s(&ply),
            "--focus",
            "8",
            "--slab",
            "1",
        ],
        &cache,
    );
    assert!(err.contains("3 plane quads"), "{err}");
}

#[test]
fn a_depth_map_no_camera_could_measure_is_named_and_ignored() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let lf = planes_hci(tmp.path());
    std::fs::remove_file(lf.join("gt_depth_lowres.pfm")).unwrap();
    let out = tmp.path().join("r.png");
    let disp = lf.join("gt_disp_lowres.pfm");
    // 1e30 px everywhere: before, 84–91 % of the render was transparent without a word.
    write_pfm(&disp, 48, 48, 1e30, &[], 0.0);
    let err = accepted(
        60,
        &["render", s(&lf), "--disparity", "0", "-o", s(&out)],
        &cache,
    );
    assert!(
        err.contains("gt_disp_lowres.pfm")
            && err.contains("2304 of 2304")
            && err.contains("1.0000e30")
            && err.contains("the map is ignored"),
        "{err}"
    );
    assert!(transparent(&out) < 0.01, "{}", transparent(&out));
    // Some absurd values among sane ones: those become unknown, the map is kept.
    write_pfm(&disp, 48, 48, 0.5, &[5, 6], -1e30);
    let err = accepted(
        60,
        &["render", s(&lf), "--disparity", "0", "-o", s(&out)],
        &cache,
    );
    assert!(
        err.contains("2 of 2304") && err.contains("taken as unknown"),
        "{err}"
    );
    assert!(transparent(&out) < 0.01, "{}", transparent(&out));
}

#[test]
fn huge_numbers_are_printed_compactly() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let lf = planes_hci(tmp.path());
    let out = tmp.path().join("r.png");
    for (args, needle) in [
        (vec!["--disparity=1e308"], "1.0000e308"),
        (vec!["--disparity=-1e308"], "-1.0000e308"),
        (vec!["--disparity", "0", "--slab=1e308"], "1.0000e308"),
        (vec!["--disparity", "0", "--view", "1e308,0"], "1.0000e308"),
        (vec!["--focus", "3", "--tilt=1e308"], "1.0000e308"),
    ] {
        let all: Vec<&str> = [&["render", s(&lf), "-o", s(&out)][..], &args].concat();
        let err = refused(60, 1, &all, &cache, &[needle]);
        assert!(err.len() < 400, "{args:?}: {err}");
    }
}

#[test]
fn a_grid_view_that_is_not_an_image_file_is_named_with_what_it_is() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let hci = planes_hci_sized(tmp.path(), "hci", 32);
    let out = tmp.path().join("x.png");
    type Plant<'a> = (&'a str, &'a dyn Fn(&Path));
    let plant: [Plant; 4] = [
        ("a FIFO", &|p| mkfifo(p)),
        ("a folder", &|p| std::fs::create_dir(p).unwrap()),
        ("a character device", &|p| {
            std::os::unix::fs::symlink("/dev/zero", p).unwrap()
        }),
        ("a dangling link to", &|p| {
            std::os::unix::fs::symlink("/no/such/view.png", p).unwrap()
        }),
    ];
    for (k, (what, make)) in plant.iter().enumerate() {
        let grid = tmp.path().join(format!("grid{k}"));
        common::hci_as_grid_folder(&hci, &grid, 5, 5);
        let view = grid.join("02_02.png");
        std::fs::remove_file(&view).unwrap();
        make(&view);
        let err = refused(
            10,
            1,
            &["render", s(&grid), "--disparity", "0", "-o", s(&out)],
            &cache,
            &["02_02.png", what, "image file"],
        );
        assert!(!err.contains("missing"), "{err}");
    }
}

#[test]
fn dangling_links_are_named_with_their_target() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let lf = planes_hci_sized(tmp.path(), "planes", 32);
    let link = tmp.path().join("link");
    std::os::unix::fs::symlink(tmp.path().join("gone"), &link).unwrap();
    let out = tmp.path().join("x.png");
    let link_s = s(&link);
    for args in [
        vec!["render", link_s, "--disparity", "0", "-o", s(&out)],
        vec!["info", link_s],
        vec![
            "depth",
            s(&lf),
            "-o",
            s(&tmp.path().join("d.pfm")),
            "--score",
            link_s,
        ],
        vec!["synth", link_s, "-o", s(&tmp.path().join("synth"))],
    ] {
        let err = refused(30, 1, &args, &cache, &[link_s, "dangling link", "gone"]);
        assert!(!err.contains("os error 2"), "{args:?}: {err}");
    }
    // A view of an HCI folder.
    std::fs::remove_file(lf.join("input_Cam007.png")).unwrap();
    std::os::unix::fs::symlink("../nowhere.png", lf.join("input_Cam007.png")).unwrap();
    refused(
        30,
        1,
        &["render", s(&lf), "--disparity", "0", "-o", s(&out)],
        &cache,
        &["input_Cam007.png", "dangling link", "nowhere.png"],
    );
}

#[test]
fn collinear_points_say_they_lie_on_a_line() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let lf = planes_hci(tmp.path());
    let out = tmp.path().join("x.png");
    let err = refused(
        30,
        1,
        &[
            "render",
            s(&lf),
            "--points",
            "10,10,20,20,30,30",
            "-o",
            s(&out),
        ],
        &cache,
        &[tiltfield::viewer::state::COLLINEAR_CLICKS],
    );
    assert!(!err.contains("reference camera centre"), "{err}");
    // Three points off a line still pick a plane.
    accepted(
        60,
        &[
            "render",
            s(&lf),
            "--points",
            "10,10,38,12,20,36",
            "-o",
            s(&out),
        ],
        &cache,
    );
}

#[test]
fn a_ground_truth_too_small_to_score_says_so() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let lf = planes_hci_sized(tmp.path(), "planes", 32);
    let gt = tmp.path().join("tiny.pfm");
    write_pfm(&gt, 20, 20, 0.5, &[], 0.0);
    refused(
        30,
        1,
        &[
            "depth",
            s(&lf),
            "-o",
            s(&tmp.path().join("d.pfm")),
            "--score",
            s(&gt),
        ],
        &cache,
        &["tiny.pfm", "20×20", "too small", "15 px border"],
    );
}

#[test]
fn a_forged_cache_entry_is_named_and_estimated_again() {
    use tiltfield::depth::cache;
    let tmp = tempfile::tempdir().unwrap();
    // Two grid folders without depth, of 32² and 40² views: each gets an estimate, cached.
    let mut grids = Vec::new();
    for size in [32, 40] {
        let hci = planes_hci_sized(tmp.path(), &format!("hci{size}"), size);
        let grid = tmp.path().join(format!("grid{size}"));
        common::hci_as_grid_folder(&hci, &grid, 5, 5);
        let dir = tmp.path().join(format!("cache{size}"));
        let ply = tmp.path().join(format!("c{size}.ply"));
        accepted(120, &["cloud", s(&grid), "-o", s(&ply)], &dir);
        let key = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.extension().is_some_and(|e| e == "json"))
            .unwrap()
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        grids.push((grid, dir, key));
    }
    // The 32² estimate written, with a matching hash, as the 40² grid's entry: what anyone who
    // can write a shared cache can do.
    let small = cache::load(&grids[0].1, &grids[0].2).expect("the 32² entry");
    let (grid, dir, key) = &grids[1];
    cache::store(dir, key, &small).unwrap();
    let ply = tmp.path().join("forged.ply");
    let err = accepted(120, &["cloud", s(grid), "-o", s(&ply)], dir);
    let entry = dir.join(format!("{key}.json"));
    assert!(
        err.contains(s(&entry)) && err.contains("32×32") && err.contains("estimating again"),
        "{err}"
    );
    // Replaced: the next run uses it without a word.
    let err = accepted(120, &["cloud", s(grid), "-o", s(&ply)], dir);
    assert!(!err.contains("estimating again"), "{err}");
}

/// The fourth campaign's unclear messages about lengths and sizes: extreme `synth` lengths and
/// `depth-set` sizes are refused naming the option and its range, before any work.
#[test]
fn extreme_lengths_and_sizes_name_their_option() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("cache");
    let out = tmp.path().join("out");
    for (option, value) in [
        ("--baseline", "18446744073709551615"),
        ("--baseline", "1e-308"),
        ("--focus-distance", "1e308"),
        ("--converge-distance", "1e308"),
        ("--converge-distance", "1e-308"),
    ] {
        let arg = format!("{option}={value}");
        let mut args = vec![
            "synth",
            "builtin:planes",
            "--out",
            s(&out),
            "--grid",
            "3x3",
            "--size",
            "32x32",
        ];
        if option == "--converge-distance" {
            args.extend(["--layout", "manifest", "--rig", "converging"]);
        }
        args.push(&arg);
        refused(30, 1, &args, &cache, &[option, "world units"]);
        assert!(!out.exists(), "{arg}: nothing may be written");
    }
    for size in ["0", "1", "4096"] {
        let arg = format!("--size={size}");
        refused(
            30,
            1,
            &["depth-set", "--scenes", "planes", "--grid", "3", &arg],
            &cache,
            &["--size", "48 to 512"],
        );
    }
}
