//! `tiltfield animate` (issue 44): every frame is the `render` of its state, the formats hold
//! the frames they should, and bad motions fail with clear messages. The backgammon
//! checks run where the HCI folder is (`TILTFIELD_BACKGAMMON`, default
//! /work/shared/data/hci/backgammon); the rest use the small built-in scenes.

mod common;

use std::path::{Path, PathBuf};

use common::{fails_with, json_of, stderr, tiltfield};
use image::{AnimationDecoder, RgbaImage};

/// The HCI backgammon folder, when this machine has it.
fn backgammon() -> Option<PathBuf> {
    let dir = std::env::var_os("TILTFIELD_BACKGAMMON")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/work/shared/data/hci/backgammon"));
    if dir.join("parameters.cfg").exists() {
        Some(dir)
    } else {
        eprintln!("skipped: no HCI backgammon at {}", dir.display());
        None
    }
}

fn run_ok(args: &[&str]) {
    let o = tiltfield(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
}

/// `tiltfield render ARGS -o DIR/render.png`, decoded.
fn render(dir: &Path, args: &[&str]) -> RgbaImage {
    let out = dir.join("render.png");
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["-o", out.to_str().unwrap()]);
    run_ok(&all);
    image::open(&out).unwrap().to_rgba8()
}

/// `tiltfield animate ARGS -o DIR/NAME`, returning the output path.
fn animate(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let mut all = vec!["animate"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["-o", out.to_str().unwrap()]);
    run_ok(&all);
    out
}

fn reader(path: &Path) -> std::io::BufReader<std::fs::File> {
    std::io::BufReader::new(std::fs::File::open(path).unwrap())
}

/// The frames of an animated PNG (it must be one).
fn apng_frames(path: &Path) -> Vec<RgbaImage> {
    let decoder = image::codecs::png::PngDecoder::new(reader(path)).unwrap();
    assert!(
        decoder.is_apng().unwrap(),
        "{} is not animated",
        path.display()
    );
    let frames = decoder.apng().unwrap().into_frames().collect_frames();
    frames
        .unwrap()
        .into_iter()
        .map(|f| f.into_buffer())
        .collect()
}

fn gif_frames(path: &Path) -> Vec<RgbaImage> {
    let decoder = image::codecs::gif::GifDecoder::new(reader(path)).unwrap();
    let frames = decoder.into_frames().collect_frames().unwrap();
    frames.into_iter().map(|f| f.into_buffer()).collect()
}

/// PSNR of `a` against `b` over RGB, dB.
fn psnr(a: &RgbaImage, b: &RgbaImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions());
    let (mut sum, mut n) = (0.0, 0.0);
    for (p, q) in a.pixels().zip(b.pixels()) {
        for c in 0..3 {
            let d = p.0[c] as f64 - q.0[c] as f64;
            sum += d * d;
            n += 1.0;
        }
    }
    10.0 * (255.0f64 * 255.0 / (sum / n)).log10()
}

fn assert_same(a: &RgbaImage, b: &RgbaImage, what: &str) {
    assert_eq!(a.dimensions(), b.dimensions(), "{what}: sizes");
    let differ = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
    assert_eq!(differ, 0, "{what}: {differ} pixels differ");
}

#[test]
fn backgammon_focus_pull_apng_frames_are_renders_and_the_gif_is_within_30_db() {
    let Some(bg) = backgammon() else { return };
    let bg = bg.to_str().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let sweep = [
        bg,
        "--sweep",
        "disparity=-1.5..1.5",
        "--frames",
        "5",
        "--antialias",
        "off",
    ];
    let expected = render(tmp.path(), &[bg, "--disparity", "0", "--antialias", "off"]);
    let frames = apng_frames(&animate(tmp.path(), "pull.png", &sweep));
    assert_eq!(frames.len(), 5);
    assert_same(&frames[2], &expected, "the APNG's middle frame");
    // The ends are other focus planes.
    assert!(psnr(&frames[0], &expected) < 40.0 && psnr(&frames[4], &expected) < 40.0);
    let gif = gif_frames(&animate(tmp.path(), "pull.gif", &sweep));
    assert_eq!(gif.len(), 5);
    let db = psnr(&gif[2], &expected);
    eprintln!("GIF middle frame: PSNR {db:.1} dB against render --disparity 0");
    assert!(
        db >= 30.0,
        "the GIF's middle frame is {db:.1} dB from the render"
    );
}

#[test]
fn backgammon_orbit_begins_at_view_6_4() {
    let Some(bg) = backgammon() else { return };
    let bg = bg.to_str().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let orbit = [bg, "--orbit", "2", "--disparity", "0", "--frames", "8"];
    let frames = apng_frames(&animate(tmp.path(), "orbit.png", &orbit));
    assert_eq!(frames.len(), 8);
    let expected = render(tmp.path(), &[bg, "--view", "6,4", "--disparity", "0"]);
    assert_same(&frames[0], &expected, "the orbit's first frame");
    // The viewpoint moves: the quarter turn sees the scene from elsewhere.
    assert!(frames[2] != frames[0]);
}

#[test]
fn sweeps_of_tilt_and_aperture_take_every_render_option() {
    let tmp = tempfile::tempdir().unwrap();
    // A tilt sweep of the keyboard plane, with a size and a strategy given.
    let opts = [
        "--size",
        "80x72",
        "--strategy",
        "fragment",
        "--antialias",
        "off",
    ];
    let mut args = vec!["builtin:tilted", "--focus", "3", "--sweep", "tilt=-20..20"];
    args.extend_from_slice(&["--frames", "3"]);
    args.extend_from_slice(&opts);
    let frames = apng_frames(&animate(tmp.path(), "tilt.png", &args));
    assert_eq!(frames.len(), 3);
    let mut one = vec!["builtin:tilted", "--focus", "3", "--tilt", "20"];
    one.extend_from_slice(&opts);
    assert_same(&frames[2], &render(tmp.path(), &one), "tilt 20°");
    // An aperture opening on anti-aliased refocus (the scene ships depth), backwards.
    let frames = apng_frames(&animate(
        tmp.path(),
        "aperture.png",
        &[
            "builtin:planes",
            "--disparity",
            "0.5",
            "--sweep",
            "aperture-radius=2..1",
            "--frames",
            "3",
        ],
    ));
    let expected = render(
        tmp.path(),
        &[
            "builtin:planes",
            "--disparity",
            "0.5",
            "--aperture-radius",
            "1.5",
        ],
    );
    assert_same(&frames[1], &expected, "aperture radius 1.5");
    // A focus sweep keeps the --tilt given with it.
    let frames = apng_frames(&animate(
        tmp.path(),
        "focus.png",
        &[
            "builtin:tilted",
            "--tilt",
            "30",
            "--sweep",
            "focus=2.5..3.5",
            "--frames",
            "3",
            "--antialias",
            "off",
        ],
    ));
    let expected = render(
        tmp.path(),
        &[
            "builtin:tilted",
            "--focus",
            "3",
            "--tilt",
            "30",
            "--antialias",
            "off",
        ],
    );
    assert_same(&frames[1], &expected, "focus 3, tilt 30°");
}

#[test]
fn bounce_plays_back_without_repeating_the_ends_and_json_reports_the_frames() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("bounce.png");
    let o = tiltfield(&[
        "animate",
        "builtin:planes",
        "--sweep",
        "disparity=-1..1",
        "--frames",
        "4",
        "--bounce",
        "--antialias",
        "off",
        "--json",
        "-o",
        out.to_str().unwrap(),
    ]);
    let report = json_of(&o);
    assert_eq!(report["frames"], 4);
    assert_eq!(report["shown"], 6);
    assert_eq!(report["order"], serde_json::json!([0, 1, 2, 3, 2, 1]));
    let values: Vec<f64> = serde_json::from_value(report["values"].clone()).unwrap();
    let third = 1.0 / 3.0;
    let expected = [-1.0, -1.0 + 2.0 * third, -1.0 + 4.0 * third, 1.0];
    assert!(values
        .iter()
        .zip(expected)
        .all(|(v, e)| (v - e).abs() < 1e-12));
    let frames = apng_frames(&out);
    assert_eq!(frames.len(), 6);
    assert_same(&frames[4], &frames[2], "bounce frame 5");
    assert_same(&frames[5], &frames[1], "bounce frame 6");
    assert!(frames[0] != frames[3]);
}

fn ffprobe_frames(path: &Path) -> (u64, u32, u32) {
    let o = std::process::Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0", "-count_frames"])
        .args([
            "-show_entries",
            "stream=nb_read_frames,width,height,pix_fmt,codec_name",
        ])
        .args(["-of", "default=noprint_wrappers=1"])
        .arg(path)
        .output()
        .expect("run ffprobe");
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let field = |k: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(&format!("{k}=")))
            .unwrap_or_else(|| panic!("no {k} in {text}"))
            .to_string()
    };
    assert_eq!(field("codec_name"), "h264");
    assert_eq!(field("pix_fmt"), "yuv420p");
    (
        field("nb_read_frames").parse().unwrap(),
        field("width").parse().unwrap(),
        field("height").parse().unwrap(),
    )
}

fn on_path(program: &str) -> bool {
    std::process::Command::new(program)
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success())
}

#[test]
fn an_mp4_has_its_frames_in_h264_with_odd_sides_cropped() {
    if !(on_path("ffmpeg") && on_path("ffprobe")) {
        eprintln!("skipped: ffmpeg or ffprobe is not on PATH (tools/setup.sh installs them)");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("pull.mp4");
    let o = tiltfield(&[
        "animate",
        "builtin:planes",
        "--sweep",
        "disparity=-1..1",
        "--frames",
        "5",
        "--size",
        "65x63",
        "--antialias",
        "off",
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("even sides") && err.contains("64×62"), "{err}");
    assert_eq!(ffprobe_frames(&out), (5, 64, 62));
}

#[test]
fn an_mp4_without_ffmpeg_on_path_fails_naming_ffmpeg() {
    let tmp = tempfile::tempdir().unwrap();
    let empty = tmp.path().join("bin");
    std::fs::create_dir(&empty).unwrap();
    let out = tmp.path().join("pull.mp4");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tiltfield"))
        .args(["animate", "builtin:planes", "--sweep", "disparity=-1..1"])
        .args(["--frames", "5", "-o", out.to_str().unwrap()])
        .env("PATH", &empty)
        .env("TILTFIELD_VALIDATION", "1")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("needs ffmpeg")
            && err.contains("no ffmpeg is on PATH")
            && !err.contains("panicked"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn bad_motions_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("a.gif");
    let out = out.to_str().unwrap();
    let lf = "builtin:planes";
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--sweep", "disparity=0..1", "--frames", "0"],
            &["--frames 0", "1 to"],
        ),
        (
            &["--sweep", "disparity=0..1", "--frames", "five"],
            &["--frames", "'five'"],
        ),
        (
            &["--sweep", "blur=0..1", "--frames", "3"],
            &["unknown key 'blur'", "disparity"],
        ),
        (
            &["--sweep", "disparity=0-1", "--frames", "3"],
            &["'disparity=0-1'", "KEY=A..B"],
        ),
        (
            &["--sweep", "disparity=..1", "--frames", "3"],
            &["'' is not a number"],
        ),
        (
            &["--sweep", "disparity=0..inf", "--frames", "3"],
            &["finite"],
        ),
        (
            &["--sweep", "disparity=NaN..1", "--frames", "3"],
            &["finite"],
        ),
        (
            &["--orbit", "1", "--frames", "3"],
            &["--orbit 1", "give one of --disparity"],
        ),
        (
            &["--orbit", "2.5", "--disparity", "0", "--frames", "3"],
            &["--orbit 2.5", "5×5 grid", "at most 2"],
        ),
        (
            &["--orbit", "0", "--disparity", "0", "--frames", "3"],
            &["--orbit 0", "positive"],
        ),
        (
            &["--orbit", "nan", "--disparity", "0", "--frames", "3"],
            &["--orbit NaN", "positive"],
        ),
        (
            &[
                "--orbit",
                "1",
                "--disparity",
                "0",
                "--view",
                "2,2",
                "--frames",
                "3",
            ],
            &["drop --view"],
        ),
        (
            &[
                "--orbit",
                "1",
                "--sweep",
                "disparity=0..1",
                "--disparity",
                "0",
                "--frames",
                "3",
            ],
            &["--sweep", "cannot be used with", "--orbit"],
        ),
        (
            &["--disparity", "0", "--frames", "3"],
            &["--sweep", "--orbit"],
        ),
        (
            &[
                "--sweep",
                "disparity=0..1",
                "--disparity",
                "0",
                "--frames",
                "3",
            ],
            &["drop --disparity"],
        ),
        (
            &["--sweep", "tilt=0..10", "--disparity", "0", "--frames", "3"],
            &["give one --focus Z", "not --disparity"],
        ),
        (
            &[
                "--sweep",
                "tilt=0..10",
                "--focus",
                "3",
                "--tilt",
                "5",
                "--frames",
                "3",
            ],
            &["drop --tilt"],
        ),
        (
            &[
                "--sweep",
                "aperture-radius=-1..2",
                "--disparity",
                "0",
                "--frames",
                "3",
            ],
            &["frame 1 of 3", "aperture radius"],
        ),
        (
            &["--sweep", "disparity=0..1", "--frames", "3", "--fps", "60"],
            &["--fps 60", "GIF"],
        ),
        (
            &["--sweep", "disparity=0..1", "--frames", "3", "--fps", "0"],
            &["--fps 0"],
        ),
        (
            &[
                "--sweep",
                "disparity=0..1",
                "--frames",
                "3",
                "--repeat",
                "2",
            ],
            &["--repeat"],
        ),
    ];
    for (args, needles) in cases {
        let mut all = vec!["animate", lf];
        all.extend_from_slice(args);
        all.extend_from_slice(&["-o", out]);
        let o = tiltfield(&all);
        let err = stderr(&o);
        assert!(
            matches!(o.status.code(), Some(1 | 2)),
            "{all:?}: exit code {:?}: {err}",
            o.status.code()
        );
        assert!(!err.contains("panicked"), "{all:?} panicked: {err}");
        for n in *needles {
            assert!(err.contains(n), "{all:?}: expected '{n}' in: {err}");
        }
    }
    fails_with(
        &[
            "animate",
            lf,
            "--sweep",
            "disparity=0..1",
            "--frames",
            "3",
            "-o",
            "a.webm",
        ],
        &["a.webm", ".gif", ".mp4"],
    );
    assert!(!Path::new(out).exists());
}
