//! `tiltfield info` and `tiltfield devices`.

use clap::Args;
use serde_json::json;

use super::{load_light_field, LightFieldArgs};
use crate::error::{Error, Result};
use crate::lightfield::{DepthKind, Source};

#[derive(Debug, Args)]
pub struct InfoArgs {
    #[command(flatten)]
    pub lf: LightFieldArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &InfoArgs) -> Result<()> {
    let lf = load_light_field(&args.lf)?;
    let centre = lf.grid.centre();
    let ref_cam = lf.camera_at(centre)?;
    let c0 = lf.views[0].camera.centre();
    let extent = lf
        .views
        .iter()
        .map(|v| (v.camera.centre() - c0).length())
        .fold(0.0, f64::max);
    let rotated = lf
        .views
        .iter()
        .any(|v| !(v.camera.r - ref_cam.r).abs_diff_eq(glam::DMat3::ZERO, 1e-9));
    let depth: Vec<_> = lf
        .depth
        .iter()
        .map(|(i, d)| {
            let v = &lf.views[*i];
            let finite: Vec<f32> = d.values.iter().copied().filter(|x| x.is_finite()).collect();
            let (lo, hi) = finite
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| {
                    (a.min(x), b.max(x))
                });
            json!({
                "view": [v.s, v.t],
                "kind": d.kind,
                "source": d.source,
                "valid_fraction": finite.len() as f64 / d.values.len().max(1) as f64,
                "range": if finite.is_empty() { json!(null) } else { json!([lo, hi]) },
            })
        })
        .collect();
    let dark: Vec<(usize, usize)> = lf
        .views
        .iter()
        .zip(lf.dark_views())
        .filter(|(_, dark)| *dark)
        .map(|(v, _)| (v.s, v.t))
        .collect();
    let k = ref_cam.k;
    let report = json!({
        "name": lf.name,
        "source": lf.source,
        "grid": {"cols": lf.grid.cols, "rows": lf.grid.rows, "views": lf.grid.len()},
        "view_size": [lf.width, lf.height],
        "centre_camera": {
            "fx": k.x_axis.x, "fy": k.y_axis.y, "cx": k.z_axis.x, "cy": k.z_axis.y,
            "centre": [ref_cam.centre().x, ref_cam.centre().y, ref_cam.centre().z],
        },
        "rig_extent": extent,
        "rotated_cameras": rotated,
        "parallel_rig": lf.rig,
        "depth": depth,
        "dark_views": dark,
    });
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| Error::Invalid(e.to_string()))?
        );
        return Ok(());
    }
    let format = match &lf.source {
        Source::Hci(_) => "HCI benchmark folder",
        Source::Manifest { .. } => "tiltfield manifest",
        Source::GridFolder { .. } => "grid of views named by row and column",
        Source::TechnicolorVideo(_) => "camera-array video, Technicolor layout",
        Source::Generated { .. } => "built-in scene",
        Source::Arrays => "grid of views in memory",
    };
    println!("{} ({format})", lf.name);
    match &lf.source {
        Source::GridFolder { naming, .. } => println!("  names       {}", naming.describe()),
        Source::TechnicolorVideo(v) => println!(
            "  video       frame {} of {} frames ({}–{}), {} values per camera{}",
            v.frame,
            v.frames,
            v.first_frame,
            v.last_frame,
            v.parameter_columns,
            if v.undistorted_on_load {
                ", radial distortion removed on load"
            } else {
                ""
            }
        ),
        _ => {}
    }
    println!(
        "  grid        {} × {} views (s × t), {} in all",
        lf.grid.cols,
        lf.grid.rows,
        lf.grid.len()
    );
    println!("  views       {} × {} px", lf.width, lf.height);
    println!(
        "  centre cam  fx {:.2} fy {:.2} cx {:.2} cy {:.2} px, centre ({:.4}, {:.4}, {:.4})",
        k.x_axis.x,
        k.y_axis.y,
        k.z_axis.x,
        k.z_axis.y,
        ref_cam.centre().x,
        ref_cam.centre().y,
        ref_cam.centre().z
    );
    println!(
        "  rig         extent {extent:.4} world units, {}",
        if rotated {
            "rotated cameras"
        } else {
            "parallel cameras"
        }
    );
    match lf.rig {
        Some(r) => println!(
            "  disparity   HCI convention: f {:.2} px, baseline {}, focus distance {} \
             (infinity at {:.3} px)",
            r.focal_px,
            r.baseline,
            r.focus_distance,
            r.disparity_at_infinity()
        ),
        None => println!("  disparity   classic shift-and-sum (no parallel-rig parameters)"),
    }
    if !dark.is_empty() {
        println!(
            "  dark views  {} (almost) black, left out of the aperture by default: {}",
            dark.len(),
            dark.iter()
                .map(|(s, t)| format!("({s}, {t})"))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    if lf.depth.is_empty() {
        println!("  depth       none (click-based plane placement unavailable)");
    }
    for (i, d) in &lf.depth {
        let v = &lf.views[*i];
        let kind = match d.kind {
            DepthKind::Depth => "depth",
            DepthKind::Disparity => "disparity",
        };
        let finite = d.values.iter().filter(|x| x.is_finite()).count();
        println!(
            "  {kind:<11} view ({}, {}) from {} ({:.1} % valid)",
            v.s,
            v.t,
            d.source,
            100.0 * finite as f64 / d.values.len().max(1) as f64
        );
    }
    Ok(())
}

/// `tiltfield devices` options.
#[derive(Debug, clap::Args)]
pub struct DevicesArgs {
    /// Time fragment, compute and batched:16 on the device (`--device`, else the default
    /// one), print the medians and keep the fastest as `--strategy auto`'s choice there.
    #[arg(long)]
    pub calibrate: bool,
    /// Print the calibration as JSON.
    #[arg(long, requires = "calibrate")]
    pub json: bool,
    #[command(flatten)]
    pub gpu: super::GpuArgs,
}

pub fn devices(args: &DevicesArgs) -> Result<()> {
    if args.calibrate {
        return calibrate(args);
    }
    let devices = crate::gpu::context::list_devices()?;
    if devices.is_empty() {
        return Err(Error::Vulkan("no Vulkan devices found".into()));
    }
    for d in devices {
        println!(
            "{}: {} [{}, Vulkan {}, {}]{}",
            d.index,
            d.name,
            d.kind,
            d.api_version,
            d.driver,
            d.unsupported
                .map(|why| format!(" — unusable: {why}"))
                .unwrap_or_default()
        );
    }
    Ok(())
}

fn calibrate(args: &DevicesArgs) -> Result<()> {
    let ctx = std::sync::Arc::new(crate::gpu::GpuContext::new(&args.gpu.options())?);
    eprintln!("timing the refocus strategies on {} …", ctx.info.name);
    let (c, path) = crate::jobs::strategy::recalibrate(&ctx)?;
    ctx.check_validation("while calibrating")?;
    if args.json {
        let mut v = serde_json::to_value(&c).map_err(|e| Error::Invalid(e.to_string()))?;
        if let Some(o) = v.as_object_mut() {
            o.insert("cache_file".into(), serde_json::json!(path));
        }
        println!(
            "{}",
            serde_json::to_string_pretty(&v).map_err(|e| Error::Invalid(e.to_string()))?
        );
        return Ok(());
    }
    println!("{} ({}, Vulkan {})", c.device, c.driver, c.api_version);
    for (name, ms) in &c.medians_ms {
        let mark = if *name == c.chosen { "  ← auto" } else { "" };
        println!("  {name:<12} {ms:9.3} ms{mark}");
    }
    match path {
        Some(p) => println!("kept in {}", p.display()),
        None => println!("not kept (no writable cache folder)"),
    }
    Ok(())
}
