//! `tiltfield cloud`: the point cloud of the view that carries the depth map, as binary PLY
//! (positions, colours, normals, normal confidence), optionally with the refocus plane as a
//! quad and the camera centres as points. [`crate::jobs::cloud`] makes it; this module
//! parses, writes the PLY and reports.

use std::path::PathBuf;

use clap::Args;
use glam::DVec2;
use serde_json::json;

use super::focus::{FocusArgs, FOCUS_OPTIONS};
use super::{load_light_field, parse_numbers, LightFieldArgs};
use crate::error::{Error, Result};
use crate::geometry::plane::Plane;
use crate::jobs::cloud::CloudRequest;

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("focus_plane").args(FOCUS_OPTIONS)))]
pub struct CloudArgs {
    #[command(flatten)]
    pub lf: LightFieldArgs,
    /// Output file (.ply, binary little-endian).
    #[arg(short, long, value_name = "OUT.ply")]
    pub output: PathBuf,
    /// Optional refocus plane to add as a quad (same options as `render`).
    #[command(flatten)]
    pub focus: FocusArgs,
    /// Focus slab around the plane: also write its two boundary planes, W away along the
    /// normal (world units; see `render --slab`). `--plane` given 2 to 8 times writes every
    /// plane of the surface.
    #[arg(long, value_name = "W", allow_hyphen_values = true)]
    pub slab: Option<f64>,
    /// Reference (virtual) view S,T for --focus and --nudge-*; default: grid centre.
    #[arg(long, value_name = "S,T")]
    pub view: Option<String>,
    /// Half the side of the plane quad in world units; default: half the cloud's bounding-box
    /// diagonal.
    #[arg(long, value_name = "H", allow_negative_numbers = true)]
    pub plane_size: Option<f64>,
    /// Add every view's camera centre as a point (normal = its optical axis).
    #[arg(long)]
    pub cameras: bool,
    /// Keep every N-th pixel in x and y.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 1,
        allow_negative_numbers = true
    )]
    pub stride: u32,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &CloudArgs) -> Result<()> {
    let ext = crate::io::extension_lower(&args.output);
    if ext.as_deref() != Some("ply") {
        return Err(Error::Invalid(format!(
            "{}: the cloud is written as PLY; give a file name ending in .ply",
            args.output.display()
        )));
    }
    super::check_output(&args.output)?;
    let request = CloudRequest {
        focus: args.focus.options()?,
        slab: args.slab,
        reference: args
            .view
            .as_deref()
            .map(|text| parse_numbers(text, 2, "--view").map(|v| DVec2::new(v[0], v[1])))
            .transpose()?,
        plane_size: args.plane_size,
        cameras: args.cameras,
        stride: args.stride,
    };
    request.validate()?;
    let mut lf = load_light_field(&args.lf)?;
    // Without a depth map of its own the light field's depth is estimated from its views.
    let bar = super::depth::progress_bar_for(&lf);
    let cloud = crate::jobs::cloud::cloud(&mut lf, &request, None, &bar);
    bar.finish_and_clear();
    let cloud = cloud?;
    cloud.mesh.write(&args.output)?;
    let planes = cloud.plane.is_some() as usize + cloud.other_planes.len();
    if args.json {
        let report = json!({
            "output": args.output,
            "light_field": lf.name,
            "depth_map": {"source": cloud.depth_source, "view": [cloud.depth_view.0, cloud.depth_view.1], "kind": cloud.depth_kind},
            "depth": cloud.origin.json(),
            "points": cloud.points,
            "points_with_normal": cloud.points_with_normal,
            "normal_window": cloud.normals.window,
            "normals_ms": cloud.normals_ms,
            "plane": cloud.plane.as_ref().map(|p| json!({
                "plane": p.plane.json(),
                "focus": p.focus.json(),
                "half_size": p.half_size,
            })),
            "surface": {
                "kind": cloud.surface.name(),
                "slab_half_width": args.slab,
                "other_planes": cloud.other_planes.iter()
                    .map(Plane::json)
                    .collect::<Vec<_>>(),
            },
            "cameras": cloud.cameras,
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| Error::Invalid(e.to_string()))?
        );
    } else {
        eprintln!(
            "wrote {} ({} points, {} with a normal, normals in {:.0} ms{}{})",
            args.output.display(),
            cloud.points,
            cloud.points_with_normal,
            cloud.normals_ms,
            match planes {
                0 => String::new(),
                1 => ", plane quad".to_string(),
                n => format!(", {n} plane quads ({})", cloud.surface.name()),
            },
            if cloud.cameras > 0 {
                format!(", {} cameras", cloud.cameras)
            } else {
                String::new()
            }
        );
    }
    Ok(())
}
