//! `tiltfield cloud`: the point cloud of the view that carries the depth map, as binary PLY
//! (positions, colours, normals, normal confidence), optionally with the refocus plane as a
//! quad and the camera centres as points. See [`crate::lightfield::ply`] for the layout.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use glam::{DVec2, DVec3};
use serde_json::json;

use super::focus::{FocusArgs, FOCUS_OPTIONS};
use super::{ensure_parent, load_light_field, parse_numbers, LightFieldArgs};
use crate::error::{Error, Result};
use crate::geometry::aperture::Aperture;
use crate::geometry::depth::ViewDepth;
use crate::geometry::normals::{estimate_normals, NormalParams};
use crate::geometry::plane::Plane;
use crate::lightfield::ply::{PlyMesh, PlyVertex};
use crate::refocus::{self, RefocusRequest};

/// Colour of the plane quad's corners (a light blue that stands out from most scenes).
const PLANE_COLOUR: [u8; 3] = [0, 190, 255];
/// Colour of the camera centres.
const CAMERA_COLOUR: [u8; 3] = [255, 0, 255];

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
    /// Reference (virtual) view S,T for --focus and --nudge-*; default: grid centre.
    #[arg(long, value_name = "S,T")]
    pub view: Option<String>,
    /// Half the side of the plane quad in world units; default: half the cloud's bounding-box
    /// diagonal.
    #[arg(long, value_name = "H")]
    pub plane_size: Option<f64>,
    /// Add every view's camera centre as a point (normal = its optical axis).
    #[arg(long)]
    pub cameras: bool,
    /// Keep every N-th pixel in x and y.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub stride: u32,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

fn f32x3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

pub fn run(args: &CloudArgs) -> Result<()> {
    let ext = args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if ext.as_deref() != Some("ply") {
        return Err(Error::Invalid(format!(
            "{}: the cloud is written as PLY; give a file name ending in .ply",
            args.output.display()
        )));
    }
    if args.stride == 0 {
        return Err(Error::Invalid("--stride must be at least 1".into()));
    }
    if let Some(h) = args.plane_size {
        if !(h.is_finite() && h > 0.0) {
            return Err(Error::Invalid(format!(
                "--plane-size must be positive, got {h}"
            )));
        }
    }
    let lf = load_light_field(&args.lf)?;
    if lf.depth.is_empty() {
        return Err(Error::Invalid(format!(
            "light field '{}' has no depth or disparity map, so it has no point cloud",
            lf.name
        )));
    }
    let depth = ViewDepth::from_light_field(&lf)?;
    let params = NormalParams::default().with_window(args.focus.normal_window);
    params.validate()?;
    let t0 = Instant::now();
    let normals = estimate_normals(&depth, &params);
    let normals_ms = t0.elapsed().as_secs_f64() * 1e3;

    let image = &lf.views[depth.view].image;
    let mut mesh = PlyMesh::default();
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut with_normal = 0usize;
    for y in (0..depth.height).step_by(args.stride as usize) {
        for x in (0..depth.width).step_by(args.stride as usize) {
            let Some(p) = depth.point(x, y) else { continue };
            lo = lo.min(p);
            hi = hi.max(p);
            let c = image.get_pixel(x, y).0;
            let (normal, quality) = match &normals[depth.index(x, y)] {
                Ok(n) => {
                    with_normal += 1;
                    (f32x3(n.normal), n.planarity as f32)
                }
                Err(_) => ([0.0; 3], 0.0),
            };
            mesh.vertices.push(PlyVertex {
                position: f32x3(p),
                normal,
                colour: [c[0], c[1], c[2]],
                quality,
            });
        }
    }
    let points = mesh.vertices.len();
    if points == 0 {
        return Err(Error::LightField(format!(
            "{}: depth map {} has no valid sample, so the cloud would be empty",
            lf.name, depth.source
        )));
    }

    let reference = match &args.view {
        Some(text) => {
            let v = parse_numbers(text, 2, "--view")?;
            DVec2::new(v[0], v[1])
        }
        None => lf.grid.centre(),
    };
    let mut plane_report = None;
    if let Some((spec, report)) = args.focus.resolve(&lf, reference)? {
        // The plan resolves every focus option to the same plane a render would use.
        let req = RefocusRequest {
            focus: spec,
            aperture: Aperture::default(),
            reference: Some(reference),
        };
        let plan = refocus::plan(&lf, &req, &[])?;
        let plane = plan.plane.ok_or_else(|| {
            Error::Invalid(format!(
                "--disparity on '{}' is classic shift-and-sum (no camera rig), which has no \
                 plane to draw; give --plane, --focus or a click option",
                lf.name
            ))
        })?;
        let centre = report
            .pick
            .as_ref()
            .and_then(|p| p.points.first().copied())
            .map(|p| p - plane.normal * plane.signed_distance(p))
            .unwrap_or(plane.point);
        let half = args
            .plane_size
            .unwrap_or_else(|| 0.5 * (hi - lo).length().max(1e-6));
        add_quad(&mut mesh, &plane, centre, half, &plan.reference_camera.r);
        mesh.comments.push(format!(
            "refocus plane ({}): point {} {} {} normal {} {} {} (vertices {}..{}, face 0)",
            report.how,
            plane.point.x,
            plane.point.y,
            plane.point.z,
            plane.normal.x,
            plane.normal.y,
            plane.normal.z,
            points,
            points + 3
        ));
        plane_report = Some(json!({
            "plane": {"point": [plane.point.x, plane.point.y, plane.point.z],
                      "normal": [plane.normal.x, plane.normal.y, plane.normal.z]},
            "focus": report.to_json(),
            "half_size": half,
        }));
    }
    let first_camera = mesh.vertices.len();
    if args.cameras {
        for v in &lf.views {
            let axis = v.camera.r.transpose() * DVec3::Z;
            mesh.vertices.push(PlyVertex {
                position: f32x3(v.camera.centre()),
                normal: f32x3(axis),
                colour: CAMERA_COLOUR,
                quality: 1.0,
            });
        }
        mesh.comments.push(format!(
            "camera centres: vertices {}..{} (colour 255 0 255, normal = optical axis)",
            first_camera,
            mesh.vertices.len() - 1
        ));
    }
    mesh.comments.insert(
        0,
        format!(
            "tiltfield cloud of '{}': view ({}, {}) from {}; {} points (stride {}), normals by \
             PCA over {}x{} px windows, quality = planarity",
            lf.name,
            depth.grid_position.0,
            depth.grid_position.1,
            depth.source,
            points,
            args.stride,
            params.window,
            params.window
        ),
    );
    mesh.comments.insert(
        1,
        "world frame of the light field; built-in scenes and HCI data: the centre camera's \
         (x right, y down, z forward)"
            .into(),
    );
    ensure_parent(&args.output)?;
    mesh.write(&args.output)?;
    if args.json {
        let report = json!({
            "output": args.output,
            "light_field": lf.name,
            "depth_map": {"source": depth.source, "view": [depth.grid_position.0, depth.grid_position.1], "kind": depth.kind},
            "points": points,
            "points_with_normal": with_normal,
            "normal_window": params.window,
            "normals_ms": normals_ms,
            "plane": plane_report,
            "cameras": if args.cameras { lf.views.len() } else { 0 },
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| Error::Invalid(e.to_string()))?
        );
    } else {
        eprintln!(
            "wrote {} ({points} points, {with_normal} with a normal, normals in {normals_ms:.0} ms{}{})",
            args.output.display(),
            if plane_report.is_some() { ", plane quad" } else { "" },
            if args.cameras {
                format!(", {} cameras", lf.views.len())
            } else {
                String::new()
            }
        );
    }
    Ok(())
}

/// Appends the square of half-side `half` centred at `centre` in `plane` as 4 vertices and one
/// face. Its edges follow the reference camera's x axis projected into the plane (y when the
/// plane is perpendicular to x), so the quad looks square from that camera.
fn add_quad(
    mesh: &mut PlyMesh,
    plane: &Plane,
    centre: DVec3,
    half: f64,
    reference_r: &glam::DMat3,
) {
    let n = plane.normal;
    let rt = reference_r.transpose();
    let along = |a: DVec3| (a - n * n.dot(a)).normalize_or_zero();
    let mut u = along(rt * DVec3::X);
    if u.length_squared() < 0.5 {
        u = along(rt * DVec3::Y);
    }
    let v = n.cross(u);
    let first = mesh.vertices.len() as u32;
    for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        mesh.vertices.push(PlyVertex {
            position: f32x3(centre + (a * u + b * v) * half),
            normal: f32x3(n),
            colour: PLANE_COLOUR,
            quality: 1.0,
        });
    }
    mesh.faces
        .push(vec![first, first + 1, first + 2, first + 3]);
}
