//! Camera-array video in the Technicolor layout: generated rigs written in exactly the
//! dataset's layout (12- and 14-column parameter files, rotated cameras, frames whose content
//! differs, radial distortion), loaded, refocused on the GPU (validation on, zero errors) and
//! compared with the f64 reference and with ground truth; `--frames` against single-frame
//! renders; every malformed input a clear error.

mod common;
mod realworld_rig;

use std::path::Path;

use common::*;
use glam::{DVec2, DVec3};
use realworld_rig::{frame_name, rig, write_frame, write_parameters, write_video, Rig};
use tiltfield::geometry::aperture::Aperture;
use tiltfield::geometry::plane::Plane;
use tiltfield::lightfield::video::{FrameLoader, FrameRange, FrameSequence};
use tiltfield::lightfield::{self, GridSize, LightField, LoadLimits, Source};
use tiltfield::refocus::{self, cpu, Averaging, FocusSpec, RefocusRequest};

const W: u32 = 64;
const H: u32 = 48;

fn grid4() -> GridSize {
    GridSize { cols: 4, rows: 4 }
}

fn open_frame(path: &Path, frame: Option<u64>) -> tiltfield::Result<LightField> {
    lightfield::open_frame_within(path, &Default::default(), &LoadLimits::default(), frame)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A 4×4 undist-named video with frames 1–3 (frame numbers from 1, as some scenes are).
fn video(dir: &Path) -> Rig {
    let r = rig(grid4(), W, H);
    write_video(dir, &r, "Painter", &[1, 2, 3]);
    r
}

fn wall_request(r: &Rig, reference: Option<DVec2>) -> RefocusRequest {
    let (p, n) = r.wall_plane();
    RefocusRequest {
        focus: FocusSpec::Plane(Plane::new(p, n).unwrap()),
        aperture: Aperture::default(),
        reference,
    }
}

#[test]
fn twelve_column_video_loads_each_frame_with_the_calibrated_cameras() {
    let tmp = tempfile::tempdir().unwrap();
    let r = video(tmp.path());
    let seq = FrameSequence::open(tmp.path()).unwrap();
    assert_eq!(seq.frames(), &[1, 2, 3]);
    assert_eq!(seq.grid(), grid4());
    assert_eq!(seq.view_size(), (W, H));
    assert_eq!(seq.name(), "Painter");
    assert_eq!(
        (seq.next(1), seq.previous(1), seq.next(3)),
        (Some(2), None, None)
    );
    // Cameras as generated (the parameter file prints shortest round-trip decimals).
    for (got, want) in seq.cameras().iter().zip(&r.cameras) {
        assert!(
            (got.k - want.k).abs_diff_eq(glam::DMat3::ZERO, 1e-9),
            "{got:?}"
        );
        assert!(
            (got.r - want.r).abs_diff_eq(glam::DMat3::ZERO, 1e-9),
            "{got:?}"
        );
        assert!((got.centre() - want.centre()).length() < 1e-9);
    }
    // The default is the first frame; --frame picks another; pixels are the files'.
    let first = open_frame(tmp.path(), None).unwrap();
    let Source::TechnicolorVideo(info) = &first.source else {
        panic!("{:?}", first.source)
    };
    assert_eq!(
        (info.frame, info.frames, info.parameter_columns),
        (1, 3, 12)
    );
    assert!(!info.undistorted_on_load && info.undist_names);
    let f2 = open_frame(tmp.path(), Some(2)).unwrap();
    for (k, v) in f2.views.iter().enumerate() {
        assert_eq!((v.s, v.t), (k % 4, k / 4));
        let file = image::open(tmp.path().join(frame_name("Painter", true, 2, k)))
            .unwrap()
            .to_rgba8();
        assert_eq!(v.image, file, "view {k}");
    }
    // The frames differ (the card moves, the wall's texture changes).
    assert_ne!(first.views[5].image, f2.views[5].image);
}

#[test]
fn frames_in_a_subfolder_numbered_from_zero_on_a_three_wide_rig() {
    let tmp = tempfile::tempdir().unwrap();
    let r = rig(GridSize { cols: 3, rows: 3 }, W, H);
    write_parameters(tmp.path(), &r.cameras, None);
    let frames = tmp.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    for f in [0, 1] {
        write_frame(&frames, "Birthday", false, f, &r.render(f));
    }
    let seq = FrameSequence::open(tmp.path()).unwrap();
    assert_eq!(seq.frames(), &[0, 1]);
    assert_eq!(seq.grid(), GridSize { cols: 3, rows: 3 });
    let lf = seq.load(1).unwrap();
    assert_eq!(lf.views.len(), 9);
    assert!(lf.views[4].source.contains("Birthday_00001_04.png"));
}

#[test]
fn refocus_of_a_chosen_frame_matches_the_f64_reference() {
    let tmp = tempfile::tempdir().unwrap();
    let r = video(tmp.path());
    let lf = open_frame(tmp.path(), Some(2)).unwrap();
    let mut gpu = renderer(&lf);
    let tilted = RefocusRequest {
        focus: FocusSpec::FocusTiltSwing {
            distance: 2.2,
            tilt_deg: 20.0,
            swing_deg: -10.0,
        },
        aperture: Aperture::default(),
        reference: Some(DVec2::new(1.25, 2.0)),
    };
    for (name, req) in [
        ("wall plane", wall_request(&r, None)),
        ("tilted plane", tilted),
    ] {
        let plan = refocus::plan(&lf, &req, &[]).unwrap();
        let got = render_float(&mut gpu, &plan, Averaging::Linear);
        let want = cpu::render(&lf, &plan, Averaging::Linear);
        let d = diff(&got, &want, None);
        eprintln!(
            "{name}: PSNR {:.1} dB, max {:.2} levels",
            d.psnr_db, d.max_levels
        );
        assert!(got.is_finite());
        assert!(d.psnr_db >= 55.0, "{name}: {d:?}");
        assert!(d.max_levels <= 2.0, "{name}: {d:?}");
        assert_eq!(d.coverage_mismatch, 0, "{name}");
    }
    // Another frame through the same renderer, its views replaced in place: the reference of
    // that frame, not of the previous one.
    let lf3 = open_frame(tmp.path(), Some(3)).unwrap();
    gpu.replace_views(&lf3).unwrap();
    let plan = refocus::plan(&lf3, &wall_request(&r, None), &[]).unwrap();
    let got = render_float(&mut gpu, &plan, Averaging::Linear);
    let d3 = diff(&got, &cpu::render(&lf3, &plan, Averaging::Linear), None);
    let d2 = diff(&got, &cpu::render(&lf, &plan, Averaging::Linear), None);
    assert!(d3.psnr_db >= 55.0, "{d3:?}");
    assert!(
        d2.psnr_db < 35.0,
        "frame 3 must differ from frame 2: {d2:?}"
    );
    // A light field of another shape cannot replace the views in place.
    let other = builtin("planes");
    let e = gpu.replace_views(&other).unwrap_err().to_string();
    assert!(e.contains("cannot replace"), "{e}");
    assert_no_validation_errors(&gpu);
}

/// Pixels of the reference camera whose ray meets the wall where every view sees that wall
/// point unoccluded and inside its image.
fn wall_mask(r: &Rig, frame: u64, reference: usize) -> Vec<bool> {
    use tiltfield::synth::trace_pixel;
    let scene = r.scene(frame);
    let cam = &r.cameras[reference];
    (0..W * H)
        .map(|i| {
            let px = DVec2::new((i % W) as f64, (i / W) as f64);
            let Some((hit, _)) = trace_pixel(&scene, cam, px) else {
                return false;
            };
            hit.quad_index == 0
                && r.cameras.iter().all(|c| {
                    let Some(p) = c.project(hit.point) else {
                        return false;
                    };
                    let inside =
                        p.x >= 1.0 && p.y >= 1.0 && p.x <= W as f64 - 2.0 && p.y <= H as f64 - 2.0;
                    inside
                        && trace_pixel(&scene, c, p).is_some_and(|(h, _)| {
                            h.quad_index == 0 && (h.point - hit.point).length() < 1e-6
                        })
                })
        })
        .collect()
}

#[test]
fn refocus_on_the_wall_reproduces_the_reference_camera_view() {
    // Ground truth for the calibration's meaning (quaternion convention, world → camera t,
    // K layout): refocused onto the wall plane, every view's warp lands the wall exactly on
    // the reference camera's pixels, so the refocus equals that camera's own image there.
    // Focusing a quarter nearer must be far worse, or the comparison would prove nothing.
    let tmp = tempfile::tempdir().unwrap();
    let r = video(tmp.path());
    let frame = 2;
    let lf = open_frame(tmp.path(), Some(frame)).unwrap();
    let reference = 5; // s = 1, t = 1: a real camera, so its image is the ground truth.
    let mask = wall_mask(&r, frame, reference);
    let used = mask.iter().filter(|&&m| m).count();
    assert!(used > (W * H / 3) as usize, "{used} wall pixels");
    let truth = view_rgb(&lf.views[reference].image);
    let psnr = |req: &RefocusRequest| {
        let plan = refocus::plan(&lf, req, &[]).unwrap();
        let img = cpu::render(&lf, &plan, Averaging::Linear);
        psnr_rgb(&encoded(&img), &truth, &mask)
    };
    let on_wall = psnr(&wall_request(&r, Some(DVec2::new(1.0, 1.0))));
    let (p, n) = r.wall_plane();
    let centre = r.cameras[reference].centre();
    let nearer = RefocusRequest {
        focus: FocusSpec::Plane(Plane::new(centre + (p - centre) * 0.75, n).unwrap()),
        ..wall_request(&r, Some(DVec2::new(1.0, 1.0)))
    };
    let off = psnr(&nearer);
    eprintln!("wall: {on_wall:.1} dB on {used} pixels; a quarter nearer: {off:.1} dB");
    // Measured 28.5 dB (bilinear resampling of sharp ring edges) against 23.3 dB a quarter
    // nearer; a misread rotation or translation moves the wall by many pixels.
    assert!(on_wall >= 27.0, "{on_wall:.1} dB");
    assert!(on_wall >= off + 3.0, "{on_wall:.1} vs {off:.1} dB");
}

#[test]
fn fourteen_columns_with_distortion_are_undistorted_on_load() {
    // Views rendered through lenses with radial distortion x_d = x(1 + d1 r² + d2 r⁴) and
    // described by a 14-column file must load as the pinhole views of the same cameras.
    let tmp = tempfile::tempdir().unwrap();
    let r = rig(GridSize { cols: 3, rows: 3 }, W, H);
    let dist = |k: usize| (-0.25 + 0.01 * k as f64, 0.02);
    write_parameters(tmp.path(), &r.cameras, Some(&dist));
    let distorted = r.render_distorted(0, dist);
    write_frame(tmp.path(), "Theater", false, 0, &distorted);
    let seq = FrameSequence::open(tmp.path()).unwrap();
    assert_eq!(seq.technicolor().calibration.columns, 14);
    let lf = seq.load(0).unwrap();
    let Source::TechnicolorVideo(info) = &lf.source else {
        panic!()
    };
    assert!(info.undistorted_on_load);
    let pinhole = r.render(0);
    // Inside a 2-pixel border (bilinear resampling clamps at the edges).
    let mask: Vec<bool> = (0..W * H)
        .map(|i| {
            let (x, y) = (i % W, i / W);
            x >= 2 && y >= 2 && x < W - 2 && y < H - 2
        })
        .collect();
    for k in 0..9 {
        let truth = view_rgb(&pinhole[k]);
        let fixed = psnr_rgb(&view_rgb(&lf.views[k].image), &truth, &mask);
        let raw = psnr_rgb(&view_rgb(&distorted[k]), &truth, &mask);
        eprintln!("view {k}: undistorted {fixed:.1} dB, as stored {raw:.1} dB");
        // Measured 27.8–28.3 dB against 21.6–23.4 dB as stored; what remains is bilinear
        // resampling of sharp ring edges that the distortion had compressed.
        assert!(fixed >= 26.0, "view {k}: {fixed:.1} dB");
        assert!(fixed >= raw + 4.0, "view {k}: {fixed:.1} vs {raw:.1} dB");
    }
    // 14 columns with zero distortion: the same cameras as 12 columns, pixels untouched.
    let plain = tempfile::tempdir().unwrap();
    write_parameters(plain.path(), &r.cameras, Some(&|_| (0.0, 0.0)));
    write_frame(plain.path(), "Theater", false, 0, &pinhole);
    let lf0 = FrameSequence::open(plain.path()).unwrap().load(0).unwrap();
    assert_eq!(lf0.views[3].image, pinhole[3]);
    assert_eq!(lf0.views[3].camera.k, lf.views[3].camera.k);
}

#[test]
fn distortion_that_folds_the_image_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let r = rig(GridSize { cols: 2, rows: 2 }, W, H);
    write_parameters(
        tmp.path(),
        &r.cameras,
        Some(&|k| if k == 2 { (-0.9, 0.0) } else { (0.0, 0.0) }),
    );
    write_frame(tmp.path(), "S", false, 0, &r.render(0));
    let e = FrameSequence::open(tmp.path()).unwrap_err().to_string();
    assert!(
        e.contains("camera 2") && e.contains("folds the image over"),
        "{e}"
    );
}

/// The last line of a parameter file replaced by `line`.
fn with_line(dir: &Path, index: usize, line: &str) {
    let p = dir.join("cameras_parameters.txt");
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[index] = line.to_string();
    std::fs::write(&p, lines.join("\n")).unwrap();
}

#[test]
fn malformed_videos_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let r = rig(GridSize { cols: 2, rows: 2 }, W, H);
    write_video(d, &r, "Remy", &[1, 2, 3]);
    let err = |frame: Option<u64>| open_frame(d, frame).unwrap_err().to_string();

    // A frame that does not exist names itself and the frames there are.
    let e = err(Some(9));
    assert!(e.contains("no frame 9") && e.contains("1–3"), "{e}");
    // A frame with a missing camera.
    std::fs::remove_file(d.join(frame_name("Remy", true, 2, 3))).unwrap();
    let e = err(Some(2));
    assert!(e.contains("frame 2 lacks camera 3"), "{e}");
    let seq = FrameSequence::open(d).unwrap();
    let e = seq
        .select("1..3".parse::<FrameRange>().unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("frame 2 lacks camera 3"), "{e}");
    assert_eq!(seq.select("3..".parse().unwrap()).unwrap(), vec![3]);
    let e = seq.select("5..9".parse().unwrap()).unwrap_err().to_string();
    assert!(
        e.contains("no frames in frames 5..9") && e.contains("1–3"),
        "{e}"
    );
    let e = seq.select("0..3".parse().unwrap()).unwrap_err().to_string();
    assert!(e.contains("asks for frame 0"), "{e}");
    // A frame file that is there but is a folder, or a dangling link, is named as what it is
    // (it read as plainly missing).
    let name = frame_name("Remy", true, 2, 3);
    std::fs::create_dir(d.join(&name)).unwrap();
    let e = err(Some(2));
    assert!(
        e.contains("lacks camera 3") && e.contains(&format!("{name} is a folder")),
        "{e}"
    );
    std::fs::remove_dir(d.join(&name)).unwrap();
    std::os::unix::fs::symlink(d.join("nowhere.png"), d.join(&name)).unwrap();
    let e = err(Some(2));
    assert!(e.contains(&format!("{name} is a dangling link")), "{e}");
    std::fs::remove_file(d.join(&name)).unwrap();
    write_frame(d, "Remy", true, 2, &r.render(2));

    // An image that is not a frame.
    image::RgbaImage::new(4, 4)
        .save(d.join("Remy_poster.png"))
        .unwrap();
    let e = err(None);
    assert!(
        e.contains("Remy_poster.png") && e.contains("<Scene>_undist_<frame:05d>_<cam:02d>.png"),
        "{e}"
    );
    std::fs::remove_file(d.join("Remy_poster.png")).unwrap();
    // A camera the parameter file does not describe.
    r.render(1)[0]
        .save(d.join(frame_name("Remy", true, 1, 4)))
        .unwrap();
    let e = err(None);
    assert!(
        e.contains("Remy_undist_00001_04.png")
            && e.contains("camera 4 of frame 1")
            && e.contains("describes 4 cameras"),
        "{e}"
    );
    std::fs::remove_file(d.join(frame_name("Remy", true, 1, 4))).unwrap();
    // Two scenes in one folder.
    r.render(1)[0]
        .save(d.join(frame_name("Other", true, 1, 0)))
        .unwrap();
    let e = err(None);
    assert!(e.contains("2 scenes") && e.contains("Other, Remy"), "{e}");
    std::fs::remove_file(d.join(frame_name("Other", true, 1, 0))).unwrap();
    assert!(open_frame(d, None).is_ok());

    // Parameter lines: short, non-numeric, bad quaternions.
    let original = std::fs::read_to_string(d.join("cameras_parameters.txt")).unwrap();
    let good_line = original.lines().nth(3).unwrap().to_string();
    let values: Vec<&str> = good_line.split(' ').collect();
    with_line(d, 3, &values[..11].join(" "));
    let e = err(None);
    assert!(
        e.contains("cameras_parameters.txt")
            && e.contains("line 4 has 11 values")
            && e.contains("f cu cv ar sk qw qx qy qz tx ty tz"),
        "{e}"
    );
    let mut zero_q = values.clone();
    zero_q[5..9].copy_from_slice(&["0", "0", "0", "0"]);
    with_line(d, 3, &zero_q.join(" "));
    let e = err(None);
    assert!(
        e.contains("line 4 (camera 2)") && e.contains("is zero"),
        "{e}"
    );
    let mut long_q = values.clone();
    long_q[5] = "1.5";
    with_line(d, 3, &long_q.join(" "));
    let e = err(None);
    assert!(
        e.contains("line 4 (camera 2)") && e.contains("not 1"),
        "{e}"
    );
    // Slightly off unit norm (a file printed with few digits) is normalised.
    let q: Vec<f64> = values[5..9].iter().map(|v| v.parse().unwrap()).collect();
    let mut short_q = values.iter().map(|v| v.to_string()).collect::<Vec<_>>();
    for (i, v) in q.iter().enumerate() {
        short_q[5 + i] = format!("{:.4}", v * 1.0003);
    }
    with_line(d, 3, &short_q.join(" "));
    let lf = open_frame(d, None).unwrap();
    let rot = lf.views[2].camera.r;
    assert!((rot.transpose() * rot - glam::DMat3::IDENTITY).abs_diff_eq(glam::DMat3::ZERO, 1e-12));
    assert!((rot - r.cameras[2].r).abs_diff_eq(glam::DMat3::ZERO, 1e-3));
    std::fs::write(d.join("cameras_parameters.txt"), original).unwrap();

    // --frame on something that is not a video.
    let e = open_frame(&d.join("nowhere"), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("nowhere"), "{e}");
    fails_with(
        &["info", "builtin:planes", "--frame", "2"],
        &["--frame 2", "not a video"],
    );
}

#[test]
fn frame_loader_decodes_in_request_order_in_the_background() {
    let tmp = tempfile::tempdir().unwrap();
    let r = rig(GridSize { cols: 2, rows: 2 }, W, H);
    write_video(tmp.path(), &r, "Loader", &[0, 1, 2, 3]);
    let seq = FrameSequence::open(tmp.path()).unwrap();
    let loader = FrameLoader::new(seq.clone(), LoadLimits::default(), 1);
    assert!(loader.recv().is_none(), "nothing requested: no wait");
    loader.request_all([2, 0]);
    loader.request(3);
    for want in [2, 0, 3] {
        let got = loader.recv().unwrap();
        assert_eq!(got.frame, want);
        let lf = got.light_field.unwrap();
        assert_eq!(lf.views[1].image, seq.load(want).unwrap().views[1].image);
        assert!(got.decode_ms >= 0.0);
    }
    assert_eq!(loader.outstanding(), 0);
    // A missing frame comes back as an error, in order.
    loader.request_all([7, 1]);
    let e = loader.recv().unwrap();
    assert_eq!(e.frame, 7);
    assert!(e
        .light_field
        .unwrap_err()
        .to_string()
        .contains("no frame 7"));
    assert_eq!(loader.recv().unwrap().frame, 1);
    // Replacing the requests drops those not started; dropping a busy loader does not hang.
    loader.request_all([0, 1, 2, 3]);
    loader.replace_requests([3]);
    let mut seen = Vec::new();
    while let Some(f) = loader.recv() {
        seen.push(f.frame);
    }
    assert_eq!(*seen.last().unwrap(), 3);
    assert!(seen.len() <= 3, "{seen:?}");
    loader.request_all([0, 1, 2, 3]);
    drop(loader);
}

#[test]
fn frames_render_equals_single_frame_renders_and_reports_where_time_goes() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("video");
    std::fs::create_dir(&d).unwrap();
    video(&d);
    let out = tmp.path().join("out");
    let pattern = out.join("refocus_{frame:03}.png");
    let plane = ["--focus", "2.4", "--tilt", "10", "--aperture-radius", "1.5"];
    let mut args = vec![
        "render",
        s(&d),
        "--frames",
        "1..3",
        "-o",
        s(&pattern),
        "--json",
    ];
    args.extend(plane);
    let report = json_of(&tiltfield(&args));
    assert_eq!(report["frames"], serde_json::json!([1, 2, 3]));
    assert!(report["frames_per_second"].as_f64().unwrap() > 0.0);
    for key in ["decode", "upload", "render_and_readback", "encode"] {
        assert!(
            report["mean_ms"][key].as_f64().unwrap() >= 0.0,
            "{key}: {report}"
        );
    }
    assert_eq!(report["per_frame"].as_array().unwrap().len(), 3);
    let mut previous: Option<image::RgbaImage> = None;
    for f in 1..=3u64 {
        let batch = image::open(out.join(format!("refocus_{f:03}.png")))
            .unwrap()
            .to_rgba8();
        let single_path = tmp.path().join(format!("single_{f}.png"));
        let frame = f.to_string();
        let mut single = vec!["render", s(&d), "--frame", &frame, "-o", s(&single_path)];
        single.extend(plane);
        let o = tiltfield(&single);
        assert!(o.status.success(), "{}", stderr(&o));
        let one = image::open(&single_path).unwrap().to_rgba8();
        assert_eq!(batch, one, "frame {f}: --frames differs from --frame");
        if let Some(p) = &previous {
            assert_ne!(p, &batch, "frames {} and {f} render alike", f - 1);
        }
        previous = Some(batch);
    }
    // Plain text: a summary with frames per second.
    let mut args = vec!["render", s(&d), "--frames", "2..", "-o", s(&pattern)];
    args.extend(plane);
    let o = tiltfield(&args);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("wrote 2 frames (2–3)") && err.contains("frames/s"),
        "{err}"
    );
    assert!(
        err.contains("decode") && err.contains("upload") && err.contains("encode"),
        "{err}"
    );
}

#[test]
fn frame_options_are_checked_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    video(d);
    let out = d.join("x.png");
    fails_with(
        &[
            "render",
            s(d),
            "--frames",
            "1..3",
            "-o",
            s(&out),
            "--disparity",
            "0",
        ],
        &["{frame}"],
    );
    let pat = d.join("o_{frame}.png");
    fails_with(
        &[
            "render",
            s(d),
            "--frames",
            "7..9",
            "-o",
            s(&pat),
            "--disparity",
            "0",
        ],
        &["no frames in frames 7..9", "1–3"],
    );
    fails_with(
        &[
            "render",
            s(d),
            "--frames",
            "a..b",
            "-o",
            s(&pat),
            "--disparity",
            "0",
        ],
        &["--frames 'a..b'"],
    );
    fails_with(
        &[
            "render",
            "builtin:planes",
            "--frames",
            "1..2",
            "-o",
            s(&pat),
            "--disparity",
            "0",
        ],
        &["not a video"],
    );
    // --frame and --frames together are a usage error (exit status 2).
    let o = tiltfield(&[
        "render",
        s(d),
        "--frame",
        "1",
        "--frames",
        "1..2",
        "-o",
        s(&pat),
        "--disparity",
        "0",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("cannot be used with"), "{}", stderr(&o));
    fails_with(&["info", s(d), "--frame", "12"], &["no frame 12", "1–3"]);
    fails_with(
        &["cloud", s(d), "--frame", "12", "-o", s(&d.join("c.ply"))],
        &["no frame 12"],
    );
    let o = tiltfield(&["info", s(d), "--frame", "2"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        text.contains("camera-array video") && text.contains("frame 2 of 3 frames (1–3)"),
        "{text}"
    );
    let v = json_of(&tiltfield(&["info", s(d), "--json"]));
    assert_eq!(v["source"]["format"], "technicolor_video");
    assert_eq!(v["source"]["frame"], 1);
    assert_eq!(v["rotated_cameras"], true);
}

#[test]
fn world_frame_is_the_calibrations() {
    // Camera centres in the world frame as written (the rig is turned and moved), grid
    // positions row-major.
    let tmp = tempfile::tempdir().unwrap();
    let r = video(tmp.path());
    let lf = open_frame(tmp.path(), None).unwrap();
    let c = lf.camera_at(DVec2::new(3.0, 1.0)).unwrap().centre();
    assert!((c - r.cameras[7].centre()).length() < 1e-9);
    let spacing = (lf.view(1, 0).camera.centre() - lf.view(0, 0).camera.centre()).length();
    assert!((spacing - 0.08).abs() < 1e-9, "{spacing}");
    let down = lf.view(0, 1).camera.centre() - lf.view(0, 0).camera.centre();
    assert!((down - r.m * DVec3::new(0.0, 0.08, 0.0)).length() < 1e-9);
}

/// Renders frames 1–3 of the video in `d` with `render --frames` and each on its own with
/// `render --frame N`, both with `args`, and asserts that every frame of the range equals its
/// own render, byte for byte. Returns the range's `--json` report and its frames.
fn frames_equal_single_renders(
    tmp: &Path,
    d: &Path,
    name: &str,
    args: &[&str],
) -> (serde_json::Value, Vec<image::RgbaImage>) {
    let cache = tmp.join("cache");
    let run = |a: &[&str]| tiltfield_cached(a, &cache);
    let pattern = tmp.join(format!("{name}_{{frame}}.png"));
    let mut range = vec![
        "render",
        s(d),
        "--frames",
        "1..3",
        "-o",
        s(&pattern),
        "--json",
    ];
    range.extend(args);
    let report = json_of(&run(&range));
    let mut frames = Vec::new();
    for frame in ["1", "2", "3"] {
        let single = tmp.join(format!("{name}_single_{frame}.png"));
        let mut one = vec!["render", s(d), "--frame", frame, "-o", s(&single)];
        one.extend(args);
        let o = run(&one);
        assert!(o.status.success(), "{}", stderr(&o));
        let batch = image::open(tmp.join(format!("{name}_{frame}.png")))
            .unwrap()
            .to_rgba8();
        assert!(
            batch == image::open(&single).unwrap().to_rgba8(),
            "{name}: frame {frame} differs from its own render"
        );
        frames.push(batch);
    }
    (report, frames)
}

/// `render --frames --antialias on` on a video without depth: each frame is anti-aliased on its
/// own estimated depth (the card moves between frames), so every frame equals `render --frame
/// N --antialias on` of it.
#[test]
fn frames_render_anti_aliased_each_on_its_own_estimated_depth() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("video");
    std::fs::create_dir(&d).unwrap();
    video(&d);
    let plane = [
        "--focus",
        "2.4",
        "--aperture-radius",
        "1.5",
        "--antialias",
        "on",
    ];
    let (report, _) = frames_equal_single_renders(tmp.path(), &d, "aa", &plane);
    assert_eq!(report["antialias"]["used"], true, "{report}");
    assert_eq!(report["antialias"]["depth_frames"], 3, "{report}");
    assert_eq!(
        report["antialias"]["depth_origin"]["origin"], "estimated",
        "{report}"
    );
    // Off (the default here: a video ships no depth) is the plain sum.
    let pattern = tmp.path().join("plain_{frame}.png");
    let report = json_of(&tiltfield_cached(
        &[
            "render",
            s(&d),
            "--frames",
            "1..1",
            "-o",
            s(&pattern),
            "--json",
            "--focus",
            "2.4",
            "--aperture-radius",
            "1.5",
        ],
        &tmp.path().join("cache"),
    ));
    assert_eq!(report["antialias"]["used"], false, "{report}");
}

/// A focus surface over a frame range keeps the first frame's planes and chooses among them
/// on each frame's own depth, as `render --frame N` of the same surface does: on the
/// generated video the card moves 0.12 m a frame, and the first frame's depth would focus it
/// where it had been.
#[test]
fn frames_keep_a_focus_surface_on_each_frames_own_depth() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("video");
    std::fs::create_dir(&d).unwrap();
    video(&d);
    for (name, surface, kind, aa) in [
        ("all", &["--all-in-focus"][..], "all-in-focus", false),
        (
            "two",
            &["--focus", "3.5", "--antialias", "on"][..],
            "planes",
            true,
        ),
    ] {
        let mut args = vec!["--focus", "2.4", "--aperture-radius", "1.5"];
        args.extend(surface);
        let (report, frames) = frames_equal_single_renders(tmp.path(), &d, name, &args);
        assert_eq!(report["surface"]["kind"], kind, "{report}");
        assert_eq!(report["antialias"]["used"], aa, "{report}");
        assert_eq!(report["antialias"]["depth_frames"], 3, "{report}");
        assert!(
            frames[0] != frames[1],
            "{name}: frames 1 and 2 are the same image"
        );
    }
}

/// A click over a frame range picks on the first frame's depth, estimated when the video has
/// none, as `--frame N --click` does (it said the video "has no depth or disparity map"); the
/// plane it finds is the one `--frame 1 --click` finds.
#[test]
fn frames_with_a_click_estimate_the_first_frames_depth_as_one_frame_does() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("video");
    std::fs::create_dir(&d).unwrap();
    video(&d);
    let cache = tmp.path().join("cache");
    let click = ["--click", "10,10", "--json"];
    let one = json_of(&tiltfield_cached(
        &[
            &[
                "render",
                s(&d),
                "--frame",
                "1",
                "-o",
                s(&tmp.path().join("one.png")),
            ][..],
            &click,
        ]
        .concat(),
        &cache,
    ));
    let pattern = tmp.path().join("range_{frame}.png");
    let range = json_of(&tiltfield_cached(
        &[
            &["render", s(&d), "--frames", "1..2", "-o", s(&pattern)][..],
            &click,
        ]
        .concat(),
        &cache,
    ));
    assert_eq!(range["focus"]["how"], "click", "{range}");
    assert_eq!(
        range["focus"]["plane"], one["focus"]["plane"],
        "{range}\n{one}"
    );
    for f in [1, 2] {
        assert!(tmp.path().join(format!("range_{f}.png")).is_file());
    }
}
