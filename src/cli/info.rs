//! `tiltfield info` and `tiltfield devices`.

use clap::Args;

use super::{load_light_field, LightFieldArgs};
use crate::error::{Error, Result};
use crate::lightfield::summary::Summary;
use crate::lightfield::{DepthKind, LightField, Source};

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
    let summary = lf.summary()?;
    if args.json {
        // Through a JSON value: the keys print sorted, as every report of the tool.
        let value = serde_json::to_value(&summary).map_err(|e| Error::Invalid(e.to_string()))?;
        println!(
            "{}",
            serde_json::to_string_pretty(&value).map_err(|e| Error::Invalid(e.to_string()))?
        );
        return Ok(());
    }
    print_text(&lf, &summary);
    Ok(())
}

fn print_text(lf: &LightField, summary: &Summary) {
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
        summary.grid.cols, summary.grid.rows, summary.grid.views
    );
    println!("  views       {} × {} px", lf.width, lf.height);
    let cam = &summary.centre_camera;
    println!(
        "  centre cam  fx {:.2} fy {:.2} cx {:.2} cy {:.2} px, centre ({:.4}, {:.4}, {:.4})",
        cam.fx, cam.fy, cam.cx, cam.cy, cam.centre[0], cam.centre[1], cam.centre[2]
    );
    println!(
        "  rig         extent {:.4} world units, {}",
        summary.rig_extent,
        if summary.rotated_cameras {
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
    let dark = &summary.dark_views;
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
    if summary.depth.is_empty() {
        println!("  depth       none (click-based plane placement unavailable)");
    }
    for d in &summary.depth {
        let kind = match d.kind {
            DepthKind::Depth => "depth",
            DepthKind::Disparity => "disparity",
        };
        println!(
            "  {kind:<11} view ({}, {}) from {} ({:.1} % valid)",
            d.view[0],
            d.view[1],
            d.source,
            100.0 * d.valid_fraction
        );
    }
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
