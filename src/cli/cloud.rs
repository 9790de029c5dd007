//! `tiltfield cloud`: the point cloud of the view that carries the depth map, as binary PLY
//! (positions, colours, normals, normal confidence), optionally with the refocus plane as a
//! quad and the camera centres as points. The geometry comes from [`crate::scene`]; this
//! module parses, writes the PLY ([`crate::lightfield::ply`] for the layout) and reports.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use glam::{DVec2, DVec3};
use serde_json::json;

use super::focus::{focus_json, FocusArgs, FOCUS_OPTIONS};
use super::{load_light_field, parse_numbers, LightFieldArgs};
use crate::error::{Error, Result};
use crate::geometry::normals::estimate_normals;
use crate::lightfield::ply::{PlyMesh, PlyVertex};
use crate::refocus::surface::FocusSurface;
use crate::scene::{PlaneQuad, PointCloud, SceneBuilder, PLANE_COLOUR};

/// Largest `--plane-size`, world units (far inside f32, which the PLY stores).
const MAX_PLANE_SIZE: f64 = 1e9;

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

/// Appends `quad` as four vertices (the plane's colour and normal) and one face; returns the
/// index of its first vertex.
fn push_quad(mesh: &mut PlyMesh, quad: &PlaneQuad) -> u32 {
    let first = mesh.vertices.len() as u32;
    mesh.vertices
        .extend(quad.corners.iter().map(|&c| PlyVertex {
            position: f32x3(c),
            normal: f32x3(quad.plane.normal),
            colour: PLANE_COLOUR,
            quality: 1.0,
        }));
    mesh.faces
        .push(vec![first, first + 1, first + 2, first + 3]);
    first
}

fn f32x3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
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
    if args.stride == 0 {
        return Err(Error::Invalid("--stride must be at least 1".into()));
    }
    if let Some(h) = args.plane_size {
        // The PLY stores f32 coordinates: a quad of 1e308 wrote infinite corners.
        if !(h.is_finite() && h > 0.0 && h <= MAX_PLANE_SIZE) {
            return Err(Error::Invalid(format!(
                "--plane-size must be positive and at most {MAX_PLANE_SIZE:e} world units, got {h:e}"
            )));
        }
    }
    let mut lf = load_light_field(&args.lf)?;
    // Without a depth map of its own the light field's depth is estimated from its views (on
    // the GPU; cached).
    let (origin, window) = if lf.depth.is_empty() {
        let ctx = crate::gpu::GpuContext::new(&crate::gpu::GpuOptions::from_env())?;
        super::depth::ensure_for(&ctx, &mut lf)?
    } else {
        let source = lf.depth[0].1.source.clone();
        (
            crate::depth::DepthOrigin::Given { source },
            super::focus::GIVEN_DEPTH_WINDOW,
        )
    };
    let depth = lf.view_depth()?;
    let params = args.focus.options()?.normal_params(window);
    params.validate()?;
    let t0 = Instant::now();
    let normals = estimate_normals(&depth, &params);
    let normals_ms = t0.elapsed().as_secs_f64() * 1e3;

    let cloud = PointCloud::from_depth(&depth, &lf.views[depth.view].image, &normals, args.stride)?;
    let points = cloud.points.len();
    let with_normal = cloud.with_normal();
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
    let asked = args.focus.options()?.surface(args.slab, false)?;
    let focus = args
        .focus
        .request_of_first(window)?
        .map(|req| crate::refocus::resolve_focus(&lf, &req, reference))
        .transpose()?;
    if asked != FocusSurface::Plane && focus.is_none() {
        return Err(Error::Invalid(
            "--slab needs a focus plane to lie around; give --plane, --focus or a click".into(),
        ));
    }
    // Classic shift-and-sum (--disparity without a rig) is drawn as the plane it stands for.
    let focus = focus
        .map(|f| crate::refocus::plan::with_classic_plane(&lf, f, reference))
        .transpose()?;
    // The surface's planes placed as the focus is, from the reference camera.
    let surface = asked.resolve(&lf, reference)?;
    if let (FocusSurface::Slab { half_width }, Some(plane)) =
        (&surface, focus.as_ref().and_then(|f| f.plane))
    {
        // The same refusal as render's: a slab reaching the camera has a boundary behind it.
        crate::refocus::surface::slab_clearance(
            &plane,
            lf.camera_at(reference)?.centre(),
            *half_width,
        )?;
    }
    let mut builder = SceneBuilder::new(&lf).reference(reference).cloud(cloud);
    if let Some(f) = &focus {
        builder = builder.focus(f);
    }
    if let Some(h) = args.plane_size {
        builder = builder.plane_half_size(h);
    }
    let scene = builder.build()?;

    let mut mesh = PlyMesh::default();
    if let Some(cloud) = &scene.cloud {
        mesh.vertices.extend(cloud.points.iter().map(|p| PlyVertex {
            position: f32x3(p.position),
            normal: p.normal.map_or([0.0; 3], f32x3),
            colour: p.colour,
            quality: p.planarity as f32,
        }));
    }
    let mut plane_report = None;
    let mut surface_quads = Vec::new();
    if let (Some(quad), Some(focus)) = (&scene.plane, &focus) {
        let r = lf.camera_at(reference)?.r;
        surface_quads = surface
            .planes_to_draw(&quad.plane)
            .iter()
            .skip(1)
            .map(|p| quad.moved_to(p, &r))
            .collect::<Vec<_>>();
        let plane = quad.plane;
        push_quad(&mut mesh, quad);
        mesh.comments.push(format!(
            "refocus plane ({}): point {} {} {} normal {} {} {} (vertices {}..{}, face 0)",
            focus.how,
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
            "focus": focus_json(focus),
            "half_size": quad.half,
        }));
    }
    // The surface's other planes (several planes; a slab's boundaries): one quad each,
    // faces 1, 2, … in the order of `FocusSurface::planes_to_draw`.
    let mut surface_report = Vec::new();
    for (k, quad) in surface_quads.iter().enumerate() {
        let plane = quad.plane;
        let first = push_quad(&mut mesh, quad);
        mesh.comments.push(format!(
            "focus surface ({}) plane {}: point {} {} {} normal {} {} {} (vertices {}..{}, face {})",
            surface.name(),
            k + 2,
            plane.point.x,
            plane.point.y,
            plane.point.z,
            plane.normal.x,
            plane.normal.y,
            plane.normal.z,
            first,
            first + 3,
            k + 1
        ));
        surface_report.push(json!({
            "point": [plane.point.x, plane.point.y, plane.point.z],
            "normal": [plane.normal.x, plane.normal.y, plane.normal.z],
        }));
    }
    let first_camera = mesh.vertices.len();
    if args.cameras {
        mesh.vertices
            .extend(scene.cameras.iter().map(|c| PlyVertex {
                position: f32x3(c.centre),
                normal: f32x3(c.axis),
                colour: c.colour(),
                quality: 1.0,
            }));
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
             {:?} fits over {}x{} px windows, quality = planarity",
            lf.name,
            depth.grid_position.0,
            depth.grid_position.1,
            depth.source,
            points,
            args.stride,
            params.method,
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
    mesh.write(&args.output)?;
    if args.json {
        let report = json!({
            "output": args.output,
            "light_field": lf.name,
            "depth_map": {"source": depth.source, "view": [depth.grid_position.0, depth.grid_position.1], "kind": depth.kind},
            "depth": super::depth::origin_json(&origin),
            "points": points,
            "points_with_normal": with_normal,
            "normal_window": params.window,
            "normals_ms": normals_ms,
            "plane": plane_report,
            "surface": {
                "kind": surface.name(),
                "slab_half_width": args.slab,
                "other_planes": surface_report,
            },
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
            match (plane_report.is_some(), surface_quads.len()) {
                (false, _) => String::new(),
                (true, 0) => ", plane quad".to_string(),
                (true, n) => format!(", {} plane quads ({})", n + 1, surface.name()),
            },
            if args.cameras {
                format!(", {} cameras", lf.views.len())
            } else {
                String::new()
            }
        );
    }
    Ok(())
}
