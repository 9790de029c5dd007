//! The scene panel's geometry besides the point cloud, built from the UI state: the cameras as
//! frustums (in the aperture: sized by their weight; out of it: small and dim), the reference
//! camera, the optical axis, the plane normal, the refocus plane as an outlined transparent
//! quad, and markers at the picked points (also those of a three-point plane in progress).

use glam::DVec3;

use super::super::state::ViewerState;
use super::depth::DepthCache;
use crate::error::Result;
use crate::geometry::camera::Camera;
use crate::lightfield::LightField;
use crate::passes::scene::SceneOverlay;
use crate::scene::{
    ColourVertex, SceneBuilder, CAMERA_IN_COLOUR, CAMERA_OUT_COLOUR, NORMAL_COLOUR,
    OPTICAL_AXIS_COLOUR, PLANE_COLOUR,
};

const PICK_COLOUR: [u8; 3] = [255, 60, 40];
/// Half side of the plane quad as a fraction of the cloud's bounding-box diagonal.
const PLANE_HALF_OF_DIAGONAL: f64 = 0.3;
/// Opacity of the plane quad in the scene panel.
const PLANE_OPACITY: f32 = 0.28;
const REFERENCE_COLOUR: [u8; 3] = [255, 230, 0];
/// The focus surface's further planes (kept planes, a slab's boundaries): a lighter blue
/// than the focus plane's, so the plane that moves stays apparent.
const SURFACE_COLOUR: [u8; 3] = [110, 200, 255];

fn line(out: &mut SceneOverlay, a: DVec3, b: DVec3, c: [u8; 3]) {
    out.lines.push(ColourVertex::new(a, c, 1.0));
    out.lines.push(ColourVertex::new(b, c, 1.0));
}

/// Points along a thick line: the scene pass draws points (as camera centres, half a marker
/// wide) but its lines are one pixel wide (`wideLines` is optional in Vulkan), so the optical
/// axis and the normal, which a reader follows across the panel, are drawn as a dense row of
/// points over the line.
const THICK_LINE_POINTS: usize = 400;

fn thick_line(out: &mut SceneOverlay, a: DVec3, b: DVec3, c: [u8; 3]) {
    line(out, a, b, c);
    out.points.extend((0..=THICK_LINE_POINTS).map(|i| {
        let t = i as f64 / THICK_LINE_POINTS as f64;
        ColourVertex::new(a.lerp(b, t), c, 1.0)
    }));
}

/// The frustum of `cam` over the view's image rectangle, cut at depth `s`.
fn frustum(out: &mut SceneOverlay, lf: &LightField, cam: &Camera, s: f64, c: [u8; 3]) {
    let k_inv = cam.k.inverse();
    let (w, h) = (lf.width as f64 - 0.5, lf.height as f64 - 0.5);
    let corners = [(-0.5, -0.5), (w, -0.5), (w, h), (-0.5, h)]
        .map(|(x, y)| cam.to_world(k_inv * DVec3::new(x, y, 1.0) * s));
    let apex = cam.centre();
    for i in 0..4 {
        line(out, apex, corners[i], c);
        line(out, corners[i], corners[(i + 1) % 4], c);
    }
}

/// Frustum depth: from the grid spacing, so frustums never swamp the scene; from the cloud's
/// size for a single view.
fn frustum_scale(lf: &LightField, depth: &DepthCache) -> f64 {
    let spacing = if lf.views.len() > 1 {
        let c0 = lf.views[0].camera.centre();
        lf.views[1..]
            .iter()
            .map(|v| (v.camera.centre() - c0).length())
            .filter(|d| *d > 0.0)
            .fold(f64::INFINITY, f64::min)
    } else {
        f64::INFINITY
    };
    if spacing.is_finite() {
        0.4 * spacing
    } else {
        0.02 * depth.diagonal().unwrap_or(1.0)
    }
}

/// The picked points to mark: the pick of the current plane and those of a plane in progress.
fn picks(state: &ViewerState, depth: &DepthCache) -> Vec<DVec3> {
    let mut picks: Vec<DVec3> = state.pending_points.clone();
    if let Some(pick) = &state.resolved.pick {
        picks.extend(pick.points.iter().copied());
    }
    if let Some(depth) = &depth.depth {
        for p in &state.pending_clicks {
            if let Ok((x, y)) = depth.pixel_at(p.x, p.y) {
                picks.extend(depth.point(x, y));
            }
        }
    }
    picks
}

/// The scene panel's geometry besides the cloud.
pub fn scene_overlay(
    lf: &LightField,
    state: &ViewerState,
    depth: &DepthCache,
) -> Result<SceneOverlay> {
    let mut builder = SceneBuilder::new(lf)
        .reference(state.reference())
        .aperture(state.aperture(), state.excluded());
    if let Some(plane) = state.plan.plane.or(state.resolved.plane) {
        builder = builder.plane(plane, state.anchor());
    }
    if let Some(diagonal) = depth.diagonal() {
        // A little smaller than the builder's default (half the diagonal), so the quad
        // reads as a plane in the scene rather than a tint over the whole panel.
        builder = builder.plane_half_size(PLANE_HALF_OF_DIAGONAL * diagonal.max(1e-6));
    }
    let geometry = builder.build()?;
    let mut out = SceneOverlay::default();
    let scale = frustum_scale(lf, depth);
    let max_weight = geometry
        .cameras
        .iter()
        .map(|c| c.weight)
        .fold(0.0, f64::max)
        .max(1e-12);
    for m in &geometry.cameras {
        let cam = &lf.views[m.index].camera;
        out.points
            .push(ColourVertex::new(m.centre, m.colour(), 1.0));
        if m.in_aperture {
            let s = scale * (0.5 + 0.5 * m.weight / max_weight);
            frustum(&mut out, lf, cam, s, CAMERA_IN_COLOUR);
        } else {
            frustum(&mut out, lf, cam, scale * 0.5, CAMERA_OUT_COLOUR);
        }
    }
    let reference = &geometry.reference_camera;
    frustum(&mut out, lf, reference, scale * 1.2, REFERENCE_COLOUR);
    let axis = geometry.optical_axis;
    thick_line(&mut out, axis.a, axis.b, OPTICAL_AXIS_COLOUR);
    if let Some(n) = geometry.normal_line {
        thick_line(&mut out, n.a, n.b, NORMAL_COLOUR);
    }
    if let Some(q) = &geometry.plane {
        for i in 0..4 {
            line(&mut out, q.corners[i], q.corners[(i + 1) % 4], PLANE_COLOUR);
        }
    }
    let mut quads: Vec<ColourVertex> = geometry.plane_vertices();
    // Every further plane of the focus surface (kept planes; a slab's two boundaries) as its
    // own outlined transparent quad, the same size as the focus plane's, centred where the
    // focus quad's centre projects onto it.
    if let Some(q) = &geometry.plane {
        let r = geometry.reference_camera.r;
        for p in state.surface().planes_to_draw(&q.plane).iter().skip(1) {
            let other = q.moved_to(p, &r);
            for i in 0..4 {
                line(
                    &mut out,
                    other.corners[i],
                    other.corners[(i + 1) % 4],
                    SURFACE_COLOUR,
                );
            }
            let tint = ColourVertex::new(DVec3::ZERO, SURFACE_COLOUR, 1.0).colour;
            quads.extend(
                other
                    .vertices()
                    .iter()
                    .map(|v| ColourVertex { colour: tint, ..*v }),
            );
        }
    }
    out.triangles.extend(quads.into_iter().map(|mut v| {
        v.colour[3] = PLANE_OPACITY;
        v
    }));
    out.markers.extend(
        picks(state, depth)
            .iter()
            .map(|p| ColourVertex::new(*p, PICK_COLOUR, 1.0)),
    );
    Ok(out)
}
