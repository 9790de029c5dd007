//! `tiltfield synth`: renders a synthetic light field with ground truth from a glTF scene or a
//! built-in scene with the Vulkan mesh rasterizer, and writes it in the HCI layout or as a
//! manifest; optionally the optical ground truth of a tilt-shift lens focused on a plane.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, ValueEnum};
use glam::{DMat3, DVec3};
use serde_json::json;

use super::focus::PlaneArgs;
use super::GpuArgs;
use crate::error::{Error, Result};
use crate::geometry::aperture::{Aperture, ApertureShape};
use crate::jobs::raster::{render_light_field, Rasterizer};
use crate::lightfield::{hci, manifest, GridSize, LightField};
use crate::refocus::{self, FocusSpec, RefocusRequest};
use crate::synth::gltf::{self, gl_to_cv};
use crate::synth::rig::encode;
use crate::synth::{synth_scene, synth_scene_names, MeshScene, RigKind, SynthRig};

/// Output layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    /// The HCI 4D Light Field Benchmark layout (parallel rigs only).
    Hci,
    /// tiltfield.json with K, R, t and a depth map per view.
    Manifest,
}

/// Camera rig.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RigArg {
    /// Parallel cameras with sensor shift (HCI).
    Parallel,
    /// Cameras rotated to look at a point on the centre axis (--converge-distance).
    Converging,
}

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("gt_plane").args(["disparity", "plane", "focus"])))]
pub struct SynthArgs {
    /// The scene: a .gltf or .glb file, or builtin:NAME (see --list).
    #[arg(required_unless_present = "list")]
    pub scene: Option<String>,
    /// Output folder.
    #[arg(
        short,
        long,
        value_name = "DIR",
        visible_alias = "output",
        required_unless_present = "list"
    )]
    pub out: Option<PathBuf>,
    /// Camera grid, columns x rows.
    #[arg(long, value_name = "SxT", default_value = "9x9")]
    pub grid: String,
    /// View size in pixels, width x height.
    #[arg(long, value_name = "WxH", default_value = "512x512")]
    pub size: String,
    /// Distance between neighbouring cameras (metres); default: the scene's.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub baseline: Option<f64>,
    /// Focal length in mm (f_px = F · max(W, H) / sensor); default: the scene's or the glTF
    /// camera's field of view.
    #[arg(long, value_name = "F", allow_negative_numbers = true)]
    pub focal_mm: Option<f64>,
    /// Sensor width in mm (HCI `sensor_size_mm`).
    #[arg(
        long,
        value_name = "S",
        default_value_t = 36.0,
        allow_negative_numbers = true
    )]
    pub sensor_mm: f64,
    /// Zero-disparity distance of the parallel rig (metres); default: the scene's.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub focus_distance: Option<f64>,
    /// Output layout.
    #[arg(long, value_enum, default_value = "hci")]
    pub layout: Layout,
    /// Camera rig: parallel (sensor shift) or converging (rotated cameras; manifest only).
    #[arg(long, value_enum, default_value = "parallel")]
    pub rig: RigArg,
    /// Converging rigs: distance of the point on the centre axis all cameras look at
    /// (default: the focus distance).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub converge_distance: Option<f64>,
    /// Anti-aliasing: N×N jittered renders per view.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 3,
        allow_negative_numbers = true
    )]
    pub samples: u32,
    /// Optical ground truth (with a plane option): aperture radius in grid steps (default: half
    /// the grid's larger side, i.e. the whole grid's disk).
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    pub gt_aperture_radius: Option<f64>,
    /// Optical ground truth: pinholes per side of the dense aperture grid.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 33,
        allow_negative_numbers = true
    )]
    pub gt_samples: u32,
    /// The plane of the optical ground truth (optional; same options as `render`).
    #[command(flatten)]
    pub plane_opts: PlaneArgs,
    /// List the built-in scenes and exit.
    #[arg(long)]
    pub list: bool,
    /// Print what was written as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

/// Parses "AxB" into two positive integers.
pub(super) fn parse_pair(text: &str, what: &str) -> Result<(u32, u32)> {
    let err = || {
        Error::Invalid(format!(
            "{what}: expected AxB with positive integers, got '{text}'"
        ))
    };
    let (a, b) = text.split_once(['x', 'X']).ok_or_else(err)?;
    let a: u32 = a.trim().parse().map_err(|_| err())?;
    let b: u32 = b.trim().parse().map_err(|_| err())?;
    if a == 0 || b == 0 {
        return Err(err());
    }
    Ok((a, b))
}

/// Most views a synthetic grid may have (a 64 × 64 camera array).
const MAX_VIEWS: u64 = 4096;
/// Most pixels of one view (8192²): the rasterizer holds several float copies of a view.
const MAX_VIEW_PIXELS: u64 = 1 << 26;
/// Most bytes of the rendered light field held in memory (RGBA8 views and depth maps).
const MAX_LIGHT_FIELD_BYTES: u64 = 8 << 30;
/// Most jittered renders per pixel side (`--samples`), i.e. 256 renders per view.
const MAX_SAMPLES: u32 = 16;
/// Most pinholes per side of the optical ground truth's aperture grid (`--gt-samples`).
const MAX_GT_SAMPLES: u32 = 257;
/// Most rasterized samples of the whole light field (views × pixels × samples²): about 2·10⁹,
/// ten times the default 9×9×512² at 3×3 samples, a few minutes on a software renderer.
const MAX_RENDER_SAMPLES: u64 = 1 << 31;
/// Largest `--sensor-mm`: larger than any camera's sensor (large format is ~250 mm), small
/// enough that every derived number (focal length in mm) stays finite.
const MAX_SENSOR_MM: f64 = 1000.0;

/// Checks every size and count before anything is loaded, rendered or written, so a request
/// that cannot be served fails at once with the limit it exceeds (not by overflowing, running
/// out of memory, or after half the files are written).
fn check_request(args: &SynthArgs, cols: u32, rows: u32, width: u32, height: u32) -> Result<()> {
    let views = cols as u64 * rows as u64;
    if views > MAX_VIEWS {
        return Err(Error::Invalid(format!(
            "--grid {cols}x{rows} asks for {views} views; at most {MAX_VIEWS}"
        )));
    }
    let pixels = width as u64 * height as u64;
    if pixels > MAX_VIEW_PIXELS {
        return Err(Error::Invalid(format!(
            "--size {width}x{height} asks for {pixels} pixels per view; at most {MAX_VIEW_PIXELS} \
             (8192x8192)"
        )));
    }
    let per_pixel = if args.layout == Layout::Manifest {
        8
    } else {
        4
    };
    let bytes = views * pixels * per_pixel;
    if bytes > MAX_LIGHT_FIELD_BYTES {
        return Err(Error::Invalid(format!(
            "--grid {cols}x{rows} of --size {width}x{height} needs {:.1} GiB in memory; at most \
             {} GiB",
            bytes as f64 / (1u64 << 30) as f64,
            MAX_LIGHT_FIELD_BYTES >> 30
        )));
    }
    if !(1..=MAX_SAMPLES).contains(&args.samples) {
        return Err(Error::Invalid(format!(
            "--samples must be 1 to {MAX_SAMPLES} (renders per pixel side), got {}",
            args.samples
        )));
    }
    let render_samples = views * pixels * (args.samples as u64).pow(2);
    if render_samples > MAX_RENDER_SAMPLES {
        return Err(Error::Invalid(format!(
            "--grid {cols}x{rows} of --size {width}x{height} with --samples {} rasterizes \
             {render_samples} samples, more than the {MAX_RENDER_SAMPLES} a synth run may (it \
             would take very long); use fewer views, a smaller size or fewer samples",
            args.samples
        )));
    }
    if !(1..=MAX_GT_SAMPLES).contains(&args.gt_samples) {
        return Err(Error::Invalid(format!(
            "--gt-samples must be 1 to {MAX_GT_SAMPLES} (pinholes per side), got {}",
            args.gt_samples
        )));
    }
    if let Some(r) = args.gt_aperture_radius {
        if !(r.is_finite() && r >= 0.0) {
            return Err(Error::Invalid(format!(
                "--gt-aperture-radius must be a finite number ≥ 0, got {r}"
            )));
        }
    }
    if let Some(v) = args.focal_mm {
        positive(v, "--focal-mm")?;
    }
    // Lengths in world units within the bounds a grid folder's --baseline has: beyond them the
    // cameras leave the geometry's ±1e12 or see nothing, and the message would not name the
    // option.
    let (lo, hi) = DISTANCE_RANGE;
    for (what, v) in [
        ("--baseline", args.baseline),
        ("--focus-distance", args.focus_distance),
        ("--converge-distance", args.converge_distance),
    ] {
        if let Some(v) = v {
            if !(lo..=hi).contains(&v) {
                return Err(Error::Invalid(format!(
                    "{what} must lie in {}..{} world units, got {}",
                    crate::error::compact(lo),
                    crate::error::compact(hi),
                    crate::error::compact(v)
                )));
            }
        }
    }
    Ok(())
}

/// The rig's numbers as they are written (HCI's focal_length_mm and baseline_mm, the manifest's
/// K and t) must be finite: products of extreme options overflow to infinity, which tiltfield
/// itself would refuse to read back.
fn check_rig_numbers(rig: &SynthRig, sensor_mm: f64) -> Result<()> {
    let max_px = rig.width.max(rig.height) as f64;
    let derived = [
        (
            "the focal length in pixels (--focal-mm, --sensor-mm)",
            rig.focal_px,
        ),
        (
            "the focal length in mm (--focal-mm, --sensor-mm)",
            rig.focal_px * sensor_mm / max_px,
        ),
        ("the baseline in mm (--baseline)", rig.baseline * 1000.0),
        ("the focus distance (--focus-distance)", rig.focus_distance),
        (
            "the disparity at infinity (--focal-mm, --baseline, --focus-distance)",
            rig.focal_px * rig.baseline / rig.focus_distance,
        ),
    ];
    for (what, v) in derived {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Invalid(format!(
                "{what} would be {v}: the options are too extreme to describe a camera"
            )));
        }
    }
    Ok(())
}

/// The numbers of the ground truth's plane must be finite; checked before rendering because
/// the plan that would otherwise refuse them needs the rendered light field.
fn check_focus(focus: &Option<FocusSpec>) -> Result<()> {
    let finite = match focus {
        Some(FocusSpec::Disparity(d)) => d.is_finite(),
        Some(FocusSpec::FocusTiltSwing {
            distance,
            tilt_deg,
            swing_deg,
        }) => distance.is_finite() && tilt_deg.is_finite() && swing_deg.is_finite(),
        Some(FocusSpec::Plane(p)) => p.point.is_finite() && p.normal.is_finite(),
        None => true,
    };
    if finite {
        Ok(())
    } else {
        Err(Error::Invalid(format!(
            "the plane of the optical ground truth must be given by finite numbers, got {focus:?}"
        )))
    }
}

/// Refuses an output folder that cannot be created or written, before rendering; creates
/// nothing (the folder is made when the light field is written).
fn check_out_dir(out: &Path) -> Result<()> {
    crate::io::check_writable_folder(out, hci::CONFIG_NAME)
        .map_err(|e| Error::Invalid(format!("--out: {e}")))
}

/// Bounds of `synth`'s lengths (`--baseline`, `--focus-distance`, `--converge-distance`).
pub const DISTANCE_RANGE: (f64, f64) = (1e-9, crate::jobs::render::MAX_BASELINE);

fn positive(v: f64, what: &str) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(Error::Invalid(format!("{what} must be positive, got {v}")))
    }
}

/// The scene in the reference camera's frame with default focal length (px), baseline and
/// focus distance.
struct Placed {
    mesh: MeshScene,
    focal_px: f64,
    baseline: f64,
    focus_distance: f64,
    camera: &'static str,
}

fn place(scene: &str, width: u32, height: u32) -> Result<Placed> {
    if let Some(name) = scene.strip_prefix("builtin:") {
        let s = synth_scene(name).ok_or_else(|| {
            Error::Invalid(format!(
                "no built-in synth scene '{name}'; available: {}",
                synth_scene_names().join(", ")
            ))
        })?;
        return Ok(Placed {
            mesh: s.mesh(),
            focal_px: s.focal_per_width * width as f64,
            baseline: s.baseline,
            focus_distance: s.focus_distance,
            camera: "built-in",
        });
    }
    let g = gltf::load(Path::new(scene))?;
    let mut mesh = g.mesh;
    let (lo, hi) = mesh
        .bounds()
        .ok_or_else(|| Error::Invalid(format!("{scene}: no triangles")))?;
    let centre = (lo + hi) / 2.0;
    let (r, c, focal_px, how) = match g.camera {
        Some(cam) => (
            cam.r,
            cam.centre,
            height as f64 / (2.0 * (cam.yfov / 2.0).tan()),
            "from the file",
        ),
        None => {
            // Look at the bounds' centre along glTF's −z (models face +z), far enough for the
            // bounding sphere to fit a field of view of f = 1.2 W.
            let f = 1.2 * width.max(height) as f64;
            let radius = ((hi - lo) / 2.0).length().max(1e-6);
            let half_fov = (width.min(height) as f64 / (2.0 * f)).atan();
            let distance = 1.1 * radius / half_fov.sin();
            (
                gl_to_cv(),
                centre + DVec3::new(0.0, 0.0, distance),
                f,
                "placed automatically (none in the file)",
            )
        }
    };
    let t = -(r * c);
    mesh.transform(r, t);
    let z = (r * centre + t).z;
    let focus_distance = if z > 0.0 { z } else { 1.0 };
    Ok(Placed {
        mesh,
        focal_px,
        baseline: 0.005 * focus_distance,
        focus_distance,
        camera: how,
    })
}

/// The rig `args` ask for on the placed `scene`: the camera model's defaults from the scene,
/// overridden by the options, each checked (in the order the options are reported).
fn rig_of(
    args: &SynthArgs,
    scene: &str,
    (cols, rows): (u32, u32),
    (width, height): (u32, u32),
    sensor: f64,
) -> Result<(Placed, SynthRig)> {
    let kind = match args.rig {
        RigArg::Parallel => RigKind::Parallel,
        RigArg::Converging => RigKind::Converging { distance: 0.0 },
    };
    if args.layout == Layout::Hci && kind != RigKind::Parallel {
        return Err(Error::Invalid(
            "--layout hci needs parallel cameras (the HCI layout has no per-view rotation); use \
             --layout manifest for a converging rig"
                .into(),
        ));
    }
    let placed = place(scene, width, height)?;
    let focal_px = match args.focal_mm {
        Some(f) => positive(f, "--focal-mm")? * width.max(height) as f64 / sensor,
        None => placed.focal_px,
    };
    let baseline = positive(args.baseline.unwrap_or(placed.baseline), "--baseline")?;
    let focus_distance = positive(
        args.focus_distance.unwrap_or(placed.focus_distance),
        "--focus-distance",
    )?;
    let kind = match kind {
        RigKind::Converging { .. } => RigKind::Converging {
            distance: positive(
                args.converge_distance.unwrap_or(focus_distance),
                "--converge-distance",
            )?,
        },
        k => k,
    };
    let rig = SynthRig {
        grid: GridSize {
            cols: cols as usize,
            rows: rows as usize,
        },
        width,
        height,
        focal_px,
        baseline,
        focus_distance,
        kind,
    };
    check_rig_numbers(&rig, sensor)?;
    Ok((placed, rig))
}

/// Renders the optical ground truth of a thin lens focused on `focus` (a disk aperture of
/// `--gt-aperture-radius` grid steps) into `folder`, adding its files to `written`; returns its
/// report.
fn optical_truth(
    r: &mut Rasterizer,
    args: &SynthArgs,
    rig: &SynthRig,
    lf: &LightField,
    focus: FocusSpec,
    folder: &crate::io::OutputFolder,
    written: &mut Vec<PathBuf>,
) -> Result<serde_json::Value> {
    let (cols, rows) = (rig.grid.cols, rig.grid.rows);
    let (width, height) = (rig.width, rig.height);
    let baseline = rig.baseline;
    let out = folder.path();
    let steps = args
        .gt_aperture_radius
        .unwrap_or((cols.max(rows) as f64 - 1.0) / 2.0);
    let req = RefocusRequest {
        focus,
        aperture: Aperture {
            shape: ApertureShape::Disk,
            radius: Some(steps),
        },
        reference: None,
    };
    let plan = refocus::plan(lf, &req, &[])?;
    let plane = plan.plane.ok_or_else(|| {
        Error::Invalid(
            "the optical ground truth needs a plane: on a converging rig --disparity is \
             classic shift-and-sum; use --plane or --focus"
                .into(),
        )
    })?;
    // The camera `render` uses by default: the grid centre (virtual for even grids).
    let reference = plan.reference_camera;
    let t_gt = Instant::now();
    let (linear, pinholes) = r.optical_ground_truth(
        &reference,
        &plane,
        steps * baseline,
        args.gt_samples,
        (width, height),
        args.samples,
    )?;
    let png = out.join("optical_gt.png");
    let exr = out.join("optical_gt.exr");
    folder.track(&png, |p| {
        crate::io::save_png(&encode(&linear, width, height), p)
    })?;
    folder.track(&exr, |p| crate::io::save_exr(width, height, &linear, p))?;
    let report = json!({
        "plane": plane.json(),
        "aperture_radius_steps": steps,
        "aperture_radius": steps * baseline,
        "pinholes": pinholes,
        "seconds": t_gt.elapsed().as_secs_f64(),
        "files": [png.clone(), exr.clone()],
    });
    written.push(png);
    written.push(exr);
    Ok(report)
}

pub fn run(args: &SynthArgs) -> Result<()> {
    if args.list {
        for name in synth_scene_names() {
            if let Some(s) = synth_scene(name) {
                println!("builtin:{name:<8} {}", s.description);
            }
        }
        return Ok(());
    }
    let (Some(scene), Some(out)) = (&args.scene, &args.out) else {
        return Err(Error::Invalid("give a SCENE and --out DIR".into()));
    };
    crate::io::utf8_path(out, "--out")?;
    let t0 = Instant::now();
    let (cols, rows) = parse_pair(&args.grid, "--grid")?;
    let (width, height) = parse_pair(&args.size, "--size")?;
    check_request(args, cols, rows, width, height)?;
    let sensor = positive(args.sensor_mm, "--sensor-mm")?;
    if sensor > MAX_SENSOR_MM {
        return Err(Error::Invalid(format!(
            "--sensor-mm must be at most {MAX_SENSOR_MM} mm, got {sensor:e}"
        )));
    }
    let (placed, rig) = rig_of(args, scene, (cols, rows), (width, height), sensor)?;
    let focus = args.plane_opts.spec()?.map(|(_, spec)| spec);
    check_focus(&focus)?;
    check_out_dir(out)?;
    let mut r = Rasterizer::new(&placed.mesh, &args.gpu.options())?;
    let device = r.context().info.name.clone();
    r.check_view_size(width, height)?;
    let t_render = Instant::now();
    let synth = render_light_field(&mut r, &rig, args.samples, args.layout == Layout::Manifest)?;
    let render_s = t_render.elapsed().as_secs_f64();
    let lf = &synth.light_field;
    // Every file goes through one output folder: a failure half way (a full disk, the ground
    // truth's plane refused) removes what this run wrote and the folders it made.
    let folder = crate::io::OutputFolder::create(out)?;
    let mut written = Vec::new();
    match args.layout {
        Layout::Hci => {
            let p = rig
                .parallel()
                .ok_or_else(|| Error::Invalid("--layout hci needs parallel cameras".into()))?;
            let cfg = hci::config_for(lf, &p, sensor);
            hci::write_into(lf, &cfg, &folder)?;
            written.push(out.join(hci::CONFIG_NAME));
        }
        Layout::Manifest => {
            manifest::write_into(lf, &folder, manifest::DEFAULT_NAME)?;
            written.push(out.join(manifest::DEFAULT_NAME));
        }
    }
    let normals_path = out.join("gt_normals_centre.exr");
    let normals: Vec<[f32; 4]> = synth
        .normals
        .iter()
        .map(|n| [n[0], n[1], n[2], if n[0].is_nan() { 0.0 } else { 1.0 }])
        .collect();
    folder.track(&normals_path, |p| {
        crate::io::save_exr(width, height, &normals, p)
    })?;
    written.push(normals_path);

    let gt_report = match focus {
        Some(focus) => optical_truth(&mut r, args, &rig, lf, focus, &folder, &mut written)?,
        None => serde_json::Value::Null,
    };
    let validated = r.context().check_validation("while rendering");
    drop(r);
    validated?;
    folder.finish();
    let rot = |m: DMat3| m == DMat3::IDENTITY;
    let report = json!({
        "scene": scene,
        "out": out,
        "layout": args.layout,
        "grid": [cols, rows],
        "size": [width, height],
        "focal_px": rig.focal_px,
        "baseline": rig.baseline,
        "focus_distance": rig.focus_distance,
        "rig": match rig.kind { RigKind::Parallel => "parallel", RigKind::Converging { .. } => "converging" },
        "parallel_cameras": lf.views.iter().all(|v| rot(v.camera.r)),
        "camera": placed.camera,
        "triangles": placed.mesh.triangle_count(),
        "device": device,
        "render_seconds": render_s,
        "total_seconds": t0.elapsed().as_secs_f64(),
        "optical_ground_truth": gt_report,
        "files": written,
    });
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| Error::Invalid(e.to_string()))?
        );
    } else {
        eprintln!(
            "wrote {}×{} views of {}×{} ({:?} layout, camera {}) to {} in {:.2} s on {device}",
            cols,
            rows,
            width,
            height,
            args.layout,
            placed.camera,
            out.display(),
            render_s
        );
        for f in &written {
            eprintln!("  {}", f.display());
        }
    }
    Ok(())
}
