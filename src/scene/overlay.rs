//! What is drawn with the point cloud: the refocus plane as a square quad, a marker per camera
//! (in or out of the synthetic aperture, with its weight), the reference optical axis and the
//! plane's normal. [`SceneBuilder`] gathers them, with an optional [`PointCloud`], into a
//! [`SceneGeometry`].
//!
//! Invariants:
//! - the quad lies in the refocus plane and contains its centre: the first picked point
//!   projected onto the plane when the focus came from a scene pick, else the plane's own
//!   point; its edges follow the reference camera's x axis projected into the plane (y when
//!   the plane is perpendicular to x), so it looks square from that camera;
//! - its half side is the one asked for, else half the cloud's bounding-box diagonal (it spans
//!   the scene), else — no cloud — the half width of the reference view's frustum at the quad
//!   centre's distance (it fills the reference view);
//! - a camera is in the aperture exactly when [`crate::refocus::plan()`] would use it with the
//!   same aperture, reference view and exclusions: weight > 0 and not excluded.

use glam::{DMat3, DVec2, DVec3};

use super::cloud::{Bounds, PointCloud};
use super::ColourVertex;
use crate::error::Result;
use crate::geometry::aperture::Aperture;
use crate::geometry::camera::Camera;
use crate::geometry::plane::Plane;
use crate::lightfield::LightField;
use crate::refocus::ResolvedFocus;

/// sRGB colour of the plane quad (a light blue that stands out from most scenes).
pub const PLANE_COLOUR: [u8; 3] = [0, 190, 255];
/// Opacity of the plane quad in a 3-D view (the cloud stays visible through it).
pub const PLANE_ALPHA: f32 = 0.35;
/// sRGB colour of cameras inside the aperture.
pub const CAMERA_IN_COLOUR: [u8; 3] = [255, 0, 255];
/// sRGB colour of cameras outside the aperture.
pub const CAMERA_OUT_COLOUR: [u8; 3] = [110, 110, 110];
/// sRGB colour of the reference optical axis.
pub const OPTICAL_AXIS_COLOUR: [u8; 3] = [255, 200, 0];
/// sRGB colour of the plane-normal line.
pub const NORMAL_COLOUR: [u8; 3] = [0, 255, 120];

/// A line segment from `a` to `b` (world frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub a: DVec3,
    pub b: DVec3,
}

/// The refocus plane as a square.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneQuad {
    pub plane: Plane,
    /// Centre of the square, in the plane.
    pub centre: DVec3,
    /// Half the side length.
    pub half: f64,
    /// Unit edge directions in the plane; `u × v = n`.
    pub u: DVec3,
    pub v: DVec3,
    /// Corners counter-clockwise in (u, v): (−,−), (+,−), (+,+), (−,+).
    pub corners: [DVec3; 4],
}

impl PlaneQuad {
    /// The square of half side `half` centred at `centre` (which must lie in `plane`), edges
    /// aligned with the camera of rotation `reference_r` (see the module docs).
    pub fn new(plane: &Plane, centre: DVec3, half: f64, reference_r: &DMat3) -> Self {
        let n = plane.normal;
        let rt = reference_r.transpose();
        let along = |a: DVec3| (a - n * n.dot(a)).normalize_or_zero();
        let mut u = along(rt * DVec3::X);
        if u.length_squared() < 0.5 {
            u = along(rt * DVec3::Y);
        }
        let v = n.cross(u);
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(a, b)| centre + (a * u + b * v) * half);
        PlaneQuad {
            plane: *plane,
            centre,
            half,
            u,
            v,
            corners,
        }
    }

    /// The same square moved onto `plane`: its centre projected onto it along `plane`'s
    /// normal, the same size and camera alignment (how a focus surface's other planes are
    /// drawn next to the first).
    pub fn moved_to(&self, plane: &Plane, reference_r: &DMat3) -> Self {
        let n = plane.normal;
        let centre = self.centre - n * n.dot(self.centre - plane.point);
        PlaneQuad::new(plane, centre, self.half, reference_r)
    }

    /// Two triangles (0, 1, 2), (0, 2, 3) for upload, in the plane colour and opacity.
    pub fn vertices(&self) -> [ColourVertex; 6] {
        [0, 1, 2, 0, 2, 3].map(|i| ColourVertex::new(self.corners[i], PLANE_COLOUR, PLANE_ALPHA))
    }
}

/// One camera of the light field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraMarker {
    /// Index in `lf.views`.
    pub index: usize,
    pub s: usize,
    pub t: usize,
    /// Camera centre, world frame.
    pub centre: DVec3,
    /// Unit optical axis (camera z) in the world frame.
    pub axis: DVec3,
    /// Aperture weight around the reference view (0 outside).
    pub weight: f64,
    /// Whether a refocus with this aperture uses the view.
    pub in_aperture: bool,
}

impl CameraMarker {
    /// The marker colour: [`CAMERA_IN_COLOUR`] or [`CAMERA_OUT_COLOUR`].
    pub fn colour(&self) -> [u8; 3] {
        if self.in_aperture {
            CAMERA_IN_COLOUR
        } else {
            CAMERA_OUT_COLOUR
        }
    }
}

/// Everything a 3-D view of the scene draws, as CPU data.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneGeometry {
    pub reference: DVec2,
    pub reference_camera: Camera,
    pub cloud: Option<PointCloud>,
    pub plane: Option<PlaneQuad>,
    pub cameras: Vec<CameraMarker>,
    /// From the reference camera centre along its optical axis to the plane (when the axis
    /// meets it in front of the camera), else to the depth of the cloud's centre or the rig's
    /// focus distance, else one world unit.
    pub optical_axis: Segment,
    /// From the quad centre along the plane normal, as long as the quad's half side.
    pub normal_line: Option<Segment>,
}

impl SceneGeometry {
    /// Point vertices: the cloud (opaque, its own colours), then the camera centres.
    pub fn point_vertices(&self) -> Vec<ColourVertex> {
        let mut out = self.cloud.as_ref().map_or_else(Vec::new, |c| c.vertices());
        out.extend(
            self.cameras
                .iter()
                .map(|c| ColourVertex::new(c.centre, c.colour(), 1.0)),
        );
        out
    }

    /// Line-list vertices (pairs): the optical axis, then the normal line.
    pub fn line_vertices(&self) -> Vec<ColourVertex> {
        let mut out = vec![
            ColourVertex::new(self.optical_axis.a, OPTICAL_AXIS_COLOUR, 1.0),
            ColourVertex::new(self.optical_axis.b, OPTICAL_AXIS_COLOUR, 1.0),
        ];
        if let Some(n) = self.normal_line {
            out.push(ColourVertex::new(n.a, NORMAL_COLOUR, 1.0));
            out.push(ColourVertex::new(n.b, NORMAL_COLOUR, 1.0));
        }
        out
    }

    /// Triangle-list vertices of the transparent plane quad (empty without a plane).
    pub fn plane_vertices(&self) -> Vec<ColourVertex> {
        self.plane.map_or_else(Vec::new, |q| q.vertices().to_vec())
    }
}

/// Gathers the scene geometry of a light field. Defaults: reference view at the grid centre,
/// the default aperture (every view), no exclusions, no cloud, no plane.
#[derive(Debug, Clone)]
pub struct SceneBuilder<'a> {
    lf: &'a LightField,
    reference: DVec2,
    aperture: Aperture,
    excluded: Vec<bool>,
    cloud: Option<PointCloud>,
    plane: Option<(Plane, Option<DVec3>)>,
    plane_half: Option<f64>,
}

impl<'a> SceneBuilder<'a> {
    pub fn new(lf: &'a LightField) -> Self {
        SceneBuilder {
            lf,
            reference: lf.grid.centre(),
            aperture: Aperture::default(),
            excluded: Vec::new(),
            cloud: None,
            plane: None,
            plane_half: None,
        }
    }

    /// The reference (possibly virtual) view, grid units.
    pub fn reference(mut self, st: DVec2) -> Self {
        self.reference = st;
        self
    }

    /// The aperture, and views left out of it (`excluded[i]`, as [`crate::refocus::plan()`]).
    pub fn aperture(mut self, aperture: Aperture, excluded: &[bool]) -> Self {
        self.aperture = aperture;
        self.excluded = excluded.to_vec();
        self
    }

    /// The point cloud.
    pub fn cloud(mut self, cloud: PointCloud) -> Self {
        self.cloud = Some(cloud);
        self
    }

    /// The refocus plane; the quad is centred at `anchor` projected onto it (else at the
    /// plane's point).
    pub fn plane(mut self, plane: Plane, anchor: Option<DVec3>) -> Self {
        self.plane = Some((plane, anchor));
        self
    }

    /// The plane of a resolved focus (none for classic shift-and-sum), anchored at the first
    /// picked point of a scene pick.
    pub fn focus(mut self, focus: &ResolvedFocus) -> Self {
        self.plane = focus.plane.map(|p| {
            let anchor = focus.pick.as_ref().and_then(|k| k.points.first().copied());
            (p, anchor)
        });
        self
    }

    /// A fixed half side for the quad instead of sizing it to the scene.
    pub fn plane_half_size(mut self, half: f64) -> Self {
        self.plane_half = Some(half);
        self
    }

    /// The geometry. Errors when the reference view lies outside the grid or the aperture is
    /// invalid.
    pub fn build(self) -> Result<SceneGeometry> {
        let lf = self.lf;
        self.aperture.validate()?;
        let camera = lf.camera_at(self.reference)?;
        let cameras = lf
            .views
            .iter()
            .enumerate()
            .map(|(index, v)| {
                let pos = DVec2::new(v.s as f64, v.t as f64);
                let weight = self
                    .aperture
                    .weight(pos, self.reference, lf.grid.cols, lf.grid.rows);
                let excluded = self.excluded.get(index).copied().unwrap_or(false);
                CameraMarker {
                    index,
                    s: v.s,
                    t: v.t,
                    centre: v.camera.centre(),
                    axis: v.camera.r.transpose() * DVec3::Z,
                    weight,
                    in_aperture: weight > 0.0 && !excluded,
                }
            })
            .collect();
        let bounds = self.cloud.as_ref().and_then(|c| c.bounds);
        let plane = self.plane.map(|(plane, anchor)| {
            let centre = anchor
                .map(|p| p - plane.normal * plane.signed_distance(p))
                .unwrap_or(plane.point);
            let half = self
                .plane_half
                .unwrap_or_else(|| default_half(&bounds, &camera, centre, lf));
            PlaneQuad::new(&plane, centre, half, &camera.r)
        });
        let optical_axis = optical_axis(&camera, plane.as_ref(), &bounds, lf);
        let normal_line = plane.map(|q| Segment {
            a: q.centre,
            b: q.centre + q.plane.normal * q.half,
        });
        Ok(SceneGeometry {
            reference: self.reference,
            reference_camera: camera,
            cloud: self.cloud,
            plane,
            cameras,
            optical_axis,
            normal_line,
        })
    }
}

/// Half side of a quad sized to the scene (see the module docs).
fn default_half(bounds: &Option<Bounds>, camera: &Camera, centre: DVec3, lf: &LightField) -> f64 {
    match bounds {
        Some(b) => 0.5 * b.diagonal().max(1e-6),
        None => {
            let distance = (centre - camera.centre()).length();
            let half_frame = 0.5 * lf.width.max(lf.height) as f64 / camera.focal_px();
            (distance * half_frame).max(1e-6)
        }
    }
}

fn optical_axis(
    camera: &Camera,
    plane: Option<&PlaneQuad>,
    bounds: &Option<Bounds>,
    lf: &LightField,
) -> Segment {
    let c = camera.centre();
    let axis = camera.r.transpose() * DVec3::Z;
    let hit = plane.and_then(|q| {
        let n = q.plane.normal;
        let t = n.dot(q.plane.point - c) / n.dot(axis);
        (t.is_finite() && t > 0.0).then_some(t)
    });
    let length = hit
        .or_else(|| {
            bounds
                .map(|b| axis.dot(b.centre() - c))
                .filter(|&d| d > 0.0)
        })
        .or_else(|| lf.rig.map(|r| r.focus_distance))
        .unwrap_or(1.0);
    Segment {
        a: c,
        b: c + axis * length,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::aperture::ApertureShape;
    use crate::geometry::normals::{estimate_normals, NormalParams};

    fn planes() -> LightField {
        crate::synth::builtin("planes").unwrap().light_field(1)
    }

    fn cloud(lf: &LightField) -> PointCloud {
        let depth = lf.view_depth().unwrap();
        let normals = estimate_normals(&depth, &NormalParams::default());
        PointCloud::from_depth(&depth, &lf.views[depth.view].image, &normals, 4).unwrap()
    }

    #[test]
    fn quad_lies_in_the_plane_contains_its_point_and_spans_the_cloud() {
        let lf = planes();
        let cloud = cloud(&lf);
        let b = cloud.bounds.unwrap();
        let plane = Plane::new(DVec3::new(0.1, -0.2, 3.0), DVec3::new(0.2, 0.1, -1.0)).unwrap();
        let g = SceneBuilder::new(&lf)
            .cloud(cloud)
            .plane(plane, None)
            .build()
            .unwrap();
        let q = g.plane.unwrap();
        for c in q.corners {
            assert!(
                plane.signed_distance(c).abs() < 1e-9,
                "corner off the plane"
            );
        }
        // The plane's point is the centre, inside the square.
        assert!((q.centre - plane.point).length() < 1e-12);
        let local = plane.point - q.corners[0];
        let (a, c) = (local.dot(q.u), local.dot(q.v));
        assert!(a > 0.0 && a < 2.0 * q.half && c > 0.0 && c < 2.0 * q.half);
        assert!((q.half - 0.5 * b.diagonal()).abs() < 1e-12);
        assert!(q.u.dot(q.v).abs() < 1e-12 && (q.u.cross(q.v) - plane.normal).length() < 1e-12);
        // The normal line starts at the centre and follows the normal.
        let n = g.normal_line.unwrap();
        assert_eq!(n.a, q.centre);
        assert!(((n.b - n.a).normalize() - plane.normal).length() < 1e-12);
    }

    #[test]
    fn quad_anchor_is_projected_onto_the_plane_and_without_a_cloud_fills_the_view() {
        let lf = planes();
        let plane = Plane::new(DVec3::new(0.0, 0.0, 3.0), DVec3::Z).unwrap();
        let g = SceneBuilder::new(&lf)
            .plane(plane, Some(DVec3::new(0.2, 0.1, 2.5)))
            .build()
            .unwrap();
        let q = g.plane.unwrap();
        assert!((q.centre - DVec3::new(0.2, 0.1, 3.0)).length() < 1e-12);
        // Frontoparallel plane seen from the centre camera: its corners project to the frame
        // edges (u along x) when the quad is centred on the axis.
        let g = SceneBuilder::new(&lf).plane(plane, None).build().unwrap();
        let q = g.plane.unwrap();
        let cam = &g.reference_camera;
        let right = cam.project(q.centre + q.u * q.half).unwrap();
        let centre = cam.project(q.centre).unwrap();
        let half_px = 0.5 * lf.width.max(lf.height) as f64;
        assert!(((right - centre).length() - half_px).abs() < 1e-6);
        // The optical axis ends on the plane.
        assert!(plane.signed_distance(g.optical_axis.b).abs() < 1e-9);
        assert!((g.optical_axis.a - cam.centre()).length() < 1e-12);
    }

    #[test]
    fn cameras_are_classified_by_the_aperture_like_the_plan() {
        let lf = planes();
        let aperture = Aperture {
            shape: ApertureShape::Disk,
            radius: Some(1.0),
        };
        let mut excluded = vec![false; lf.views.len()];
        excluded[lf.grid.index(1, 2)] = true;
        let reference = DVec2::new(2.0, 2.0);
        let g = SceneBuilder::new(&lf)
            .reference(reference)
            .aperture(aperture, &excluded)
            .build()
            .unwrap();
        let req = crate::refocus::RefocusRequest {
            focus: crate::refocus::FocusSpec::Disparity(0.0),
            aperture,
            reference: Some(reference),
        };
        let plan = crate::refocus::plan(&lf, &req, &excluded).unwrap();
        let used: Vec<usize> = plan.views.iter().map(|v| v.index).collect();
        let inside: Vec<usize> = g
            .cameras
            .iter()
            .filter(|c| c.in_aperture)
            .map(|c| c.index)
            .collect();
        assert_eq!(inside, used);
        assert_eq!(g.cameras.len(), lf.views.len());
        for c in &g.cameras {
            assert_eq!(c.colour() == CAMERA_IN_COLOUR, c.in_aperture);
            if let Some(v) = plan.views.iter().find(|v| v.index == c.index) {
                assert_eq!(v.weight, c.weight);
            }
        }
        // The excluded view has weight but is out.
        let ex = &g.cameras[lf.grid.index(1, 2)];
        assert!(ex.weight > 0.0 && !ex.in_aperture);
        // Vertices: every cloud point and camera as a point; the axis as one line.
        assert_eq!(g.point_vertices().len(), lf.views.len());
        assert_eq!(g.line_vertices().len(), 2);
        assert!(g.plane_vertices().is_empty());
    }

    #[test]
    fn a_resolved_pick_anchors_the_quad_at_the_picked_point() {
        let lf = planes();
        let req = crate::refocus::FocusRequest {
            target: crate::refocus::FocusTarget::ThreePoints([
                DVec3::new(-0.3, -0.2, 3.0),
                DVec3::new(0.4, -0.1, 3.0),
                DVec3::new(0.0, 0.3, 3.0),
            ]),
            nudge: None,
        };
        let focus = crate::refocus::resolve_focus(&lf, &req, lf.grid.centre()).unwrap();
        let g = SceneBuilder::new(&lf).focus(&focus).build().unwrap();
        let q = g.plane.unwrap();
        assert!((q.centre - DVec3::new(-0.3, -0.2, 3.0)).length() < 1e-12);
    }
}
