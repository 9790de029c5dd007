//! The point cloud of the view that carries the depth map as a PLY mesh (positions, colours,
//! normals, normal confidence), optionally with the refocus plane and the focus surface's
//! other planes as quads and the camera centres as points. The geometry comes from
//! [`crate::scene`]; the PLY layout is [`crate::lightfield::ply`]'s. The front ends (`tiltfield
//! cloud`) parse the request, write the mesh and report what [`Cloud`] holds.

use std::time::Instant;

use glam::{DVec2, DVec3};
use indicatif::ProgressBar;

use crate::depth::DepthOrigin;
use crate::error::{Error, Result};
use crate::geometry::normals::{estimate_normals, NormalParams, GIVEN_DEPTH_WINDOW};
use crate::geometry::plane::Plane;
use crate::gpu::{GpuContext, GpuOptions};
use crate::lightfield::ply::{PlyMesh, PlyVertex};
use crate::lightfield::{DepthKind, LightField};
use crate::refocus::options::FocusOptions;
use crate::refocus::surface::FocusSurface;
use crate::refocus::ResolvedFocus;
use crate::scene::{PlaneQuad, PointCloud, SceneBuilder, PLANE_COLOUR};

/// Largest plane half size, world units (far inside f32, which the PLY stores).
pub const MAX_PLANE_SIZE: f64 = 1e9;

/// What to put into the cloud.
#[derive(Debug, Clone)]
pub struct CloudRequest {
    /// The refocus plane to add as a quad, and the normals' window (`--normal-window`).
    pub focus: FocusOptions,
    /// A focus slab's half width around the plane (its two boundary planes are added).
    pub slab: Option<f64>,
    /// Reference (virtual) view for the focus; `None`: the grid centre.
    pub reference: Option<DVec2>,
    /// Half the side of the plane quads; `None`: half the cloud's bounding-box diagonal.
    pub plane_size: Option<f64>,
    /// Add every view's camera centre as a point.
    pub cameras: bool,
    /// Keep every N-th pixel in x and y.
    pub stride: u32,
}

impl CloudRequest {
    /// Checks what needs no light field.
    pub fn validate(&self) -> Result<()> {
        self.focus.validate_optional()?;
        if self.stride == 0 {
            return Err(Error::Invalid("--stride must be at least 1".into()));
        }
        if let Some(h) = self.plane_size {
            // The PLY stores f32 coordinates: a quad of 1e308 wrote infinite corners.
            if !(h.is_finite() && h > 0.0 && h <= MAX_PLANE_SIZE) {
                return Err(Error::Invalid(format!(
                    "--plane-size must be positive and at most {MAX_PLANE_SIZE:e} world units, \
                     got {h:e}"
                )));
            }
        }
        Ok(())
    }
}

/// The refocus plane's quad in the mesh.
#[derive(Debug, Clone)]
pub struct CloudPlane {
    pub plane: Plane,
    pub half_size: f64,
    pub focus: ResolvedFocus,
}

/// A cloud ready to write, and what went into it.
#[derive(Debug, Clone)]
pub struct Cloud {
    pub mesh: PlyMesh,
    /// Where the depth came from (estimated from the views when the light field had none).
    pub origin: DepthOrigin,
    pub depth_source: String,
    pub depth_view: (usize, usize),
    pub depth_kind: DepthKind,
    pub points: usize,
    pub points_with_normal: usize,
    pub normals: NormalParams,
    pub normals_ms: f64,
    pub plane: Option<CloudPlane>,
    /// The focus surface's kind and its planes beyond the first, as written (faces 1, 2, …).
    pub surface: FocusSurface,
    pub other_planes: Vec<Plane>,
    /// Camera centres written (0 without [`CloudRequest::cameras`]).
    pub cameras: usize,
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

/// A plane as the PLY's comments write it: `point X Y Z normal X Y Z`.
fn point_normal(p: &Plane) -> String {
    let (a, n) = (p.point, p.normal);
    format!(
        "point {} {} {} normal {} {} {}",
        a.x, a.y, a.z, n.x, n.y, n.z
    )
}

fn f32x3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The cloud of `lf` as `req` asks for it. Without a depth map of its own the light field's
/// depth is estimated from its views first (on `ctx`, else on a context made for it; cached;
/// `progress` follows it) and kept in `lf`.
pub fn cloud(
    lf: &mut LightField,
    req: &CloudRequest,
    ctx: Option<&GpuContext>,
    progress: &ProgressBar,
) -> Result<Cloud> {
    req.validate()?;
    let (origin, window) = if lf.depth.is_empty() {
        let made;
        let ctx = match ctx {
            Some(ctx) => ctx,
            None => {
                made = GpuContext::new(&GpuOptions::from_env())?;
                &made
            }
        };
        super::depth::ensure_for(ctx, lf, progress)?
    } else {
        let source = lf.depth[0].1.source.clone();
        (DepthOrigin::Given { source }, GIVEN_DEPTH_WINDOW)
    };
    let depth = lf.view_depth()?;
    let params = req.focus.normal_params(window);
    params.validate()?;
    let t0 = Instant::now();
    let normals = estimate_normals(&depth, &params);
    let normals_ms = t0.elapsed().as_secs_f64() * 1e3;

    let cloud = PointCloud::from_depth(&depth, &lf.views[depth.view].image, &normals, req.stride)?;
    let points = cloud.points.len();
    let points_with_normal = cloud.with_normal();
    if points == 0 {
        return Err(Error::LightField(format!(
            "{}: depth map {} has no valid sample, so the cloud would be empty",
            lf.name, depth.source
        )));
    }

    let reference = req.reference.unwrap_or_else(|| lf.grid.centre());
    let (focus, surface) = focus_and_surface(lf, req, window, reference)?;
    let mut builder = SceneBuilder::new(lf).reference(reference).cloud(cloud);
    if let Some(f) = &focus {
        builder = builder.focus(f);
    }
    if let Some(h) = req.plane_size {
        builder = builder.plane_half_size(h);
    }
    let scene = builder.build()?;

    let (mut mesh, plane, other_planes) =
        mesh_of(lf, &scene, focus, &surface, reference, req.cameras)?;
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
            req.stride,
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
    Ok(Cloud {
        mesh,
        origin,
        depth_source: depth.source.clone(),
        depth_view: depth.grid_position,
        depth_kind: depth.kind,
        points,
        points_with_normal,
        normals: params,
        normals_ms,
        plane,
        surface,
        other_planes,
        cameras: if req.cameras { lf.views.len() } else { 0 },
    })
}

/// The focus of `req` resolved from `reference` (classic shift-and-sum drawn as the plane it
/// stands for) and its surface, with render's refusals (a slab needs a plane and must clear the
/// camera).
fn focus_and_surface(
    lf: &LightField,
    req: &CloudRequest,
    window: u32,
    reference: DVec2,
) -> Result<(Option<ResolvedFocus>, FocusSurface)> {
    let asked = req.focus.surface(req.slab, false)?;
    let focus = req
        .focus
        .request(window)?
        .map(|r| crate::refocus::resolve_focus(lf, &r, reference))
        .transpose()?;
    if asked != FocusSurface::Plane && focus.is_none() {
        return Err(Error::Invalid(
            "--slab needs a focus plane to lie around; give --plane, --focus or a click".into(),
        ));
    }
    // Classic shift-and-sum (--disparity without a rig) is drawn as the plane it stands for.
    let focus = focus
        .map(|f| crate::refocus::plan::with_classic_plane(lf, f, reference))
        .transpose()?;
    // The surface's planes placed as the focus is, from the reference camera.
    let surface = asked.resolve(lf, reference)?;
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
    Ok((focus, surface))
}

/// The mesh of `scene`: its cloud's points, the plane's quad (face 0) and the surface's other
/// planes (faces 1, 2, …), then the camera centres when `cameras`; with what was written.
fn mesh_of(
    lf: &LightField,
    scene: &crate::scene::SceneGeometry,
    focus: Option<ResolvedFocus>,
    surface: &FocusSurface,
    reference: DVec2,
    cameras: bool,
) -> Result<(PlyMesh, Option<CloudPlane>, Vec<Plane>)> {
    let points = scene.cloud.as_ref().map_or(0, |c| c.points.len());
    let mut mesh = PlyMesh::default();
    if let Some(cloud) = &scene.cloud {
        mesh.vertices.extend(cloud.points.iter().map(|p| PlyVertex {
            position: f32x3(p.position),
            normal: p.normal.map_or([0.0; 3], f32x3),
            colour: p.colour,
            quality: p.planarity as f32,
        }));
    }
    let mut plane = None;
    let mut surface_quads = Vec::new();
    if let (Some(quad), Some(focus)) = (&scene.plane, focus) {
        let r = lf.camera_at(reference)?.r;
        surface_quads = surface
            .planes_to_draw(&quad.plane)
            .iter()
            .skip(1)
            .map(|p| quad.moved_to(p, &r))
            .collect::<Vec<_>>();
        let p = quad.plane;
        push_quad(&mut mesh, quad);
        mesh.comments.push(format!(
            "refocus plane ({}): {} (vertices {}..{}, face 0)",
            focus.how,
            point_normal(&p),
            points,
            points + 3
        ));
        plane = Some(CloudPlane {
            plane: p,
            half_size: quad.half,
            focus,
        });
    }
    // The surface's other planes (several planes; a slab's boundaries): one quad each,
    // faces 1, 2, … in the order of `FocusSurface::planes_to_draw`.
    let mut other_planes = Vec::new();
    for (k, quad) in surface_quads.iter().enumerate() {
        let p = quad.plane;
        let first = push_quad(&mut mesh, quad);
        mesh.comments.push(format!(
            "focus surface ({}) plane {}: {} (vertices {}..{}, face {})",
            surface.name(),
            k + 2,
            point_normal(&p),
            first,
            first + 3,
            k + 1
        ));
        other_planes.push(p);
    }
    let first_camera = mesh.vertices.len();
    if cameras {
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
    Ok((mesh, plane, other_planes))
}
