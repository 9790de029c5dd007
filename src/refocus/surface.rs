//! Focus surfaces beyond one plane (docs/conventions.md §12). Generalized shift-and-sum samples
//! every view where it sees the point in which the output pixel's ray meets the focus surface;
//! the pass only needs that point's inverse depth `s(x)` along the ray (`y_i = A_i x + b_i s`).
//! One plane gives `s = max(m·x, 0)`; a surface makes `s` a per-pixel choice between plane terms
//! and the scene's own inverse depth `σ(x)` (the same [`SceneDepth`] anti-aliasing reads):
//!
//! - **planes** (2–[`MAX_PLANES`]): `s = s_k` for the plane whose `s_k = max(m_k·x, 0)` is
//!   nearest σ (the first such plane on a tie), so each scene point is focused on the plane it
//!   lies on or nearest to in inverse depth;
//! - **slab** of half-width W around a plane (distances along its normal, world units): its two
//!   boundary planes have the plane terms `m·d/(d + W)` (far) and `m·d/(d − W)` (near), with
//!   `d = |n·(p − C_r)|`, so `s = min(max(σ, s_far), s_near)`: the scene point itself inside the
//!   slab, the nearer boundary outside it. The reference camera must lie outside the slab
//!   (`d > W`), as a single plane must not pass through it;
//! - **all in focus**: `s = σ`.
//!
//! Pixels without a scene depth (σ < 0: holes of a reprojected map, invalid depth) fall back
//! to the plan's plane (the first plane, or the slab's middle plane), so they render as the
//! single-plane refocus does and never NaN. At occlusion edges σ is the nearest reference texel
//! (never interpolated), so a pixel takes the surface of the layer it sees.

use glam::{DVec2, DVec3};

use super::antialias::{scene_depth, AntialiasPlan, SceneDepth};
use super::focus::{focus_plane, FocusSpec};
use super::plan::{classic_plane, RefocusPlan};
use crate::error::{Error, Result};
use crate::geometry::homography::plane_term;
use crate::geometry::plane::Plane;
use crate::lightfield::LightField;

/// Most planes of a [`FocusSurface::Planes`]: the pass reads their terms from a uniform
/// buffer of this many records (`passes::refocus` binding 6).
pub const MAX_PLANES: usize = 8;

/// What is kept in focus, relative to the plan's plane. `P` is how a plane of
/// [`FocusSurface::Planes`] is given: a world [`Plane`] (the default, what a render uses), or
/// as asked for, a [`FocusSpec`] (the keyboard definition and a disparity are relative to the
/// reference camera; [`FocusSurface::resolve`] places them in the world).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum FocusSurface<P = Plane> {
    /// The plan's plane alone: the classic tilt-shift refocus (needs no scene depth).
    #[default]
    Plane,
    /// Several planes, the plan's first (the plan is made from `planes[0]`): 2 to
    /// [`MAX_PLANES`] in all.
    Planes(Vec<P>),
    /// Everything within `half_width` (world units, along the plan plane's normal) of the
    /// plan's plane.
    Slab { half_width: f64 },
    /// Every pixel focused on the scene point it sees.
    AllInFocus,
}

impl<P: Clone> FocusSurface<P> {
    /// The surface a request names: `planes` (the focus planes given, possibly none when the
    /// focus is not a plane), a slab half-width, all in focus. Refuses combinations that do
    /// not name one surface, naming the cause.
    pub fn from_request(
        planes: &[P],
        slab: Option<f64>,
        all_in_focus: bool,
    ) -> Result<FocusSurface<P>> {
        if planes.len() > MAX_PLANES {
            return Err(Error::Invalid(format!(
                "a focus surface takes at most {MAX_PLANES} planes, got {}",
                planes.len()
            )));
        }
        let several = planes.len() > 1;
        let surface = match (slab, all_in_focus) {
            (Some(_), true) => {
                return Err(Error::Invalid(
                    "a focus slab and all-in-focus are two different surfaces; give one".into(),
                ))
            }
            (Some(_), false) if several => {
                return Err(Error::Invalid(format!(
                    "a focus slab lies around exactly one plane, got {} planes",
                    planes.len()
                )))
            }
            (Some(w), false) => FocusSurface::Slab { half_width: w },
            (None, true) if several => {
                return Err(Error::Invalid(format!(
                    "all-in-focus needs no plane set, got {} planes",
                    planes.len()
                )))
            }
            (None, true) => FocusSurface::AllInFocus,
            (None, false) if several => FocusSurface::Planes(planes.to_vec()),
            (None, false) => FocusSurface::Plane,
        };
        surface.validate()?;
        Ok(surface)
    }

    /// Whether the surface depends on the scene's depth.
    pub fn needs_depth(&self) -> bool {
        !matches!(self, FocusSurface::Plane)
    }

    /// The name used in reports: `plane`, `planes`, `slab` or `all-in-focus`.
    pub fn name(&self) -> &'static str {
        match self {
            FocusSurface::Plane => "plane",
            FocusSurface::Planes(_) => "planes",
            FocusSurface::Slab { .. } => "slab",
            FocusSurface::AllInFocus => "all-in-focus",
        }
    }

    /// Checks what needs no camera: the plane count and the slab width.
    pub fn validate(&self) -> Result<()> {
        match self {
            FocusSurface::Planes(p) if p.len() < 2 || p.len() > MAX_PLANES => {
                Err(Error::Invalid(format!(
                    "a focus surface of planes takes 2 to {MAX_PLANES} planes, got {}",
                    p.len()
                )))
            }
            FocusSurface::Slab { half_width: w } if !(w.is_finite() && *w > 0.0) => {
                Err(Error::Invalid(format!(
                    "the focus slab's half-width must be finite and > 0 (world units, as the \
                     plane), got {w}"
                )))
            }
            _ => Ok(()),
        }
    }
}

impl FocusSurface<FocusSpec> {
    /// The surface with every plane placed in the world as seen from the camera at grid
    /// position `reference` (the render's reference camera), each the plane
    /// [`super::resolve_focus`] would give for it alone: a `--plane` as given,
    /// `--focus/--tilt/--swing` through the camera's optical axis, a `--disparity` the rig's
    /// frontoparallel plane; without a rig (classic shift-and-sum) the plane its shifts stand
    /// for ([`super::plan::classic_plane`]), refused where there is none. Errors name the
    /// plane by its place.
    pub fn resolve(&self, lf: &LightField, reference: DVec2) -> Result<FocusSurface> {
        let specs = match self {
            FocusSurface::Planes(specs) => specs,
            FocusSurface::Plane => return Ok(FocusSurface::Plane),
            FocusSurface::Slab { half_width } => {
                return Ok(FocusSurface::Slab {
                    half_width: *half_width,
                })
            }
            FocusSurface::AllInFocus => return Ok(FocusSurface::AllInFocus),
        };
        let camera = lf.camera_at(reference)?;
        let planes = specs
            .iter()
            .enumerate()
            .map(|(k, spec)| match spec {
                FocusSpec::Plane(p) => Ok(*p),
                _ => match focus_plane(lf, spec, &camera) {
                    Ok((_, Some(p), _)) => Ok(p),
                    // Classic shift-and-sum: the plane it stands for on a parallel grid.
                    Ok((_, None, _)) => match spec {
                        FocusSpec::Disparity(d) => classic_plane(lf, reference, *d, &[])
                            .map_err(|e| in_plane(k, in_surface(self.name(), e))),
                        _ => Err(needs_geometry(self.name())),
                    },
                    Err(e) => Err(in_plane(k, e)),
                },
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(FocusSurface::Planes(planes))
    }
}

/// `e` naming plane `k` (from 0) of a surface.
fn in_plane(k: usize, e: Error) -> Error {
    match e {
        Error::Invalid(m) => Error::Invalid(format!("focus plane {}: {m}", k + 1)),
        Error::Geometry(m) => Error::Geometry(format!("focus plane {}: {m}", k + 1)),
        e => e,
    }
}

/// `e` (why a classic shift-and-sum stands for no plane) as the refusal of surface `name`.
pub fn in_surface(name: &str, e: Error) -> Error {
    match e {
        Error::Invalid(m) => Error::Invalid(format!(
            "the focus surface '{name}' needs the cameras' geometry: {m}; focus with --plane or \
             --focus"
        )),
        e => e,
    }
}

/// The refusal of a surface on classic shift-and-sum, which has no plane geometry.
fn needs_geometry(name: &str) -> Error {
    Error::Invalid(format!(
        "the focus surface '{name}' needs the cameras' geometry, but --disparity on a light \
         field without a rig is classic shift-and-sum; focus with --plane or --focus"
    ))
}

impl FocusSurface {
    /// The planes that draw this surface around `plane` (the focus plane, the first of
    /// several): every plane of [`FocusSurface::Planes`]; a slab's middle plane and its two
    /// boundaries (`n·X = n·p ± W`); otherwise `plane` alone.
    pub fn planes_to_draw(&self, plane: &Plane) -> Vec<Plane> {
        match self {
            FocusSurface::Planes(p) => p.clone(),
            FocusSurface::Slab { half_width: w } => {
                let shifted = |d: f64| Plane {
                    point: plane.point + plane.normal * d,
                    normal: plane.normal,
                };
                vec![*plane, shifted(-w), shifted(*w)]
            }
            _ => vec![*plane],
        }
    }
}

/// How the pass picks `s` per pixel (the `SURFACE` specialisation constant of
/// refocus_accumulate.glsl).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SurfaceRule {
    /// `s = max(m·x, 0)`: the single plane (today's shader path, unchanged).
    Plane = 0,
    /// The plane term nearest σ.
    Nearest = 1,
    /// σ clamped between the first (far) and second (near) plane terms.
    Clamp = 2,
    /// `s = σ`.
    Scene = 3,
}

/// A [`FocusSurface`] resolved for a plan's reference camera: the rule, its plane terms and
/// the scene depth it reads.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfacePlan {
    pub surface: FocusSurface,
    pub rule: SurfaceRule,
    /// Plane terms seen from the reference camera: [`SurfaceRule::Nearest`]: one per plane,
    /// the plan's `m` first; [`SurfaceRule::Clamp`]: far then near boundary; otherwise the
    /// plan's `m` (the fallback where σ is unknown).
    pub terms: Vec<DVec3>,
    /// The plan's plane term: the fallback where σ is unknown.
    pub m: DVec3,
    /// The plan's plane (world frame; `None` for classic shift-and-sum), for reports.
    pub plane: Option<Plane>,
    /// σ per reference pixel (`None` only for [`SurfaceRule::Plane`]).
    pub depth: Option<SceneDepth>,
}

impl SurfacePlan {
    /// The f64 model of the focus surface's inverse depth along reference pixel position
    /// `x`'s ray (the shader's `surface_s` computes the same in f32).
    pub fn inverse_depth(&self, x: DVec2) -> f64 {
        let xh = x.extend(1.0);
        let s = self.m.dot(xh).max(0.0);
        let Some(sigma) = self.depth.as_ref().and_then(|d| d.at(x)) else {
            return s;
        };
        match self.rule {
            SurfaceRule::Plane => s,
            SurfaceRule::Scene => sigma,
            SurfaceRule::Clamp => {
                let lo = self.terms[0].dot(xh).max(0.0);
                let hi = self.terms[1].dot(xh).max(0.0);
                sigma.max(lo).min(hi)
            }
            SurfaceRule::Nearest => {
                let (mut best, mut err) = (s, (s - sigma).abs());
                for m in &self.terms[1..] {
                    let sk = m.dot(xh).max(0.0);
                    if (sk - sigma).abs() < err {
                        (best, err) = (sk, (sk - sigma).abs());
                    }
                }
                best
            }
        }
    }

    /// Where f32 may choose differently from f64 at `x`: two planes' distances to σ within
    /// `eps` (relative) of each other. Elsewhere the surface is continuous in its inputs.
    pub fn ambiguous(&self, x: DVec2, eps: f64) -> bool {
        if self.rule != SurfaceRule::Nearest {
            return false;
        }
        let Some(sigma) = self.depth.as_ref().and_then(|d| d.at(x)) else {
            return false;
        };
        let xh = x.extend(1.0);
        let mut errs: Vec<f64> = self
            .terms
            .iter()
            .map(|m| (m.dot(xh).max(0.0) - sigma).abs())
            .collect();
        errs.sort_by(f64::total_cmp);
        errs[1] - errs[0] <= eps * sigma.abs().max(1e-3)
    }

    /// The JSON description for reports: the surface, its planes, the slab width, the depth.
    pub fn json(&self, depth_origin: Option<serde_json::Value>) -> serde_json::Value {
        let pj = Plane::json;
        let planes: Vec<_> = match (&self.surface, &self.plane) {
            (FocusSurface::Planes(p), _) => p.iter().map(pj).collect(),
            (_, Some(p)) => vec![pj(p)],
            (_, None) => Vec::new(),
        };
        let boundaries: Vec<_> = match (&self.surface, &self.plane) {
            (FocusSurface::Slab { .. }, Some(p)) => {
                self.surface.planes_to_draw(p)[1..].iter().map(pj).collect()
            }
            _ => Vec::new(),
        };
        serde_json::json!({
            "kind": self.surface.name(),
            "planes": planes,
            "slab_boundaries": boundaries,
            "slab_half_width": match self.surface {
                FocusSurface::Slab { half_width } => Some(half_width),
                _ => None,
            },
            "depth_source": self.depth.as_ref().map(|d| d.source.clone()),
            "depth_origin": depth_origin,
            "pixels_without_depth": self.depth.as_ref().map(|d| d.unknown),
        })
    }
}

/// Resolves `surface` for `plan` (made from the surface's first plane, or the slab's middle
/// plane) with the scene's inverse depth `depth` seen from the plan's reference camera.
pub fn plan_surface(
    plan: &RefocusPlan,
    surface: &FocusSurface,
    depth: Option<SceneDepth>,
) -> Result<SurfacePlan> {
    surface.validate()?;
    let single = |depth| SurfacePlan {
        surface: surface.clone(),
        rule: SurfaceRule::Plane,
        terms: vec![plan.m],
        m: plan.m,
        plane: plan.plane,
        depth,
    };
    if !surface.needs_depth() {
        return Ok(single(None));
    }
    let (rule, terms) = surface_terms(plan, surface)?;
    let Some(depth) = depth else {
        return Err(Error::Invalid(format!(
            "the focus surface '{}' needs the scene's depth",
            surface.name()
        )));
    };
    if (depth.width, depth.height) != (plan.width, plan.height) {
        return Err(Error::Invalid(format!(
            "the scene depth is {}×{}, the views {}×{}",
            depth.width, depth.height, plan.width, plan.height
        )));
    }
    Ok(SurfacePlan {
        surface: surface.clone(),
        rule,
        terms,
        m: plan.m,
        plane: plan.plane,
        depth: Some(depth),
    })
}

/// The distance of `plane` from the reference camera centre `centre`, refusing a slab of
/// half-width `w` around `plane` that reaches the camera: the reference camera would see its
/// own position as in focus, and the near boundary plane would pass through or behind it.
/// `render` refuses such a slab here, and `cloud` draws no boundary behind the camera.
pub fn slab_clearance(plane: &Plane, centre: DVec3, w: f64) -> Result<f64> {
    let d = plane.normal.dot(plane.point - centre).abs();
    if d - w <= 1e-9 * d.max(1.0) {
        return Err(Error::Geometry(format!(
            "the reference camera lies inside the focus slab (the plane is {d:.4} from it, the \
             half-width {}); narrow the slab or move the plane",
            crate::error::compact(w)
        )));
    }
    Ok(d)
}

/// The rule and plane terms of `surface` seen from `plan`'s reference camera (the geometry
/// of [`plan_surface`], without the scene depth): refuses classic shift-and-sum (no plane)
/// and a slab around the reference camera. Cheap: the viewer checks every change with it.
pub fn surface_terms(
    plan: &RefocusPlan,
    surface: &FocusSurface,
) -> Result<(SurfaceRule, Vec<DVec3>)> {
    surface.validate()?;
    if !surface.needs_depth() {
        return Ok((SurfaceRule::Plane, vec![plan.m]));
    }
    let Some(plane) = plan.plane else {
        return Err(needs_geometry(surface.name()));
    };
    let rc = &plan.reference_camera;
    let (rule, terms) = match surface {
        FocusSurface::Plane => unreachable!("handled above"),
        FocusSurface::AllInFocus => (SurfaceRule::Scene, vec![plan.m]),
        FocusSurface::Planes(planes) => {
            let mut terms = vec![plan.m];
            for (k, p) in planes.iter().enumerate().skip(1) {
                let m = plane_term(rc, p, 1e-9 * (1.0 + rc.centre().length()))
                    .map_err(|e| Error::Geometry(format!("focus plane {}: {e}", k + 1)))?;
                terms.push(m);
            }
            (SurfaceRule::Nearest, terms)
        }
        FocusSurface::Slab { half_width: w } => {
            let d = slab_clearance(&plane, rc.centre(), *w)?;
            (
                SurfaceRule::Clamp,
                vec![plan.m * (d / (d + w)), plan.m * (d / (d - w))],
            )
        }
    };
    if terms.iter().any(|m| !m.is_finite()) {
        return Err(Error::Geometry(
            "a focus surface plane term is not finite".into(),
        ));
    }
    Ok((rule, terms))
}

/// [`plan_surface`] with the depth anti-aliasing uses when `aa` is given (the pass binds one
/// scene depth for both), else `lf`'s depth map seen from the plan's reference camera; an
/// error naming the cause when the surface needs depth and the light field has none.
pub fn surface_for(
    lf: &LightField,
    plan: &RefocusPlan,
    surface: &FocusSurface,
    aa: Option<&AntialiasPlan>,
) -> Result<SurfacePlan> {
    surface.validate()?;
    if !surface.needs_depth() {
        return plan_surface(plan, surface, None);
    }
    let depth = match aa {
        Some(aa) => aa.depth.clone(),
        None => {
            let map = lf.view_depth().map_err(|e| {
                Error::Invalid(format!(
                    "the focus surface '{}' needs the scene's depth: {e}",
                    surface.name()
                ))
            })?;
            scene_depth(&map, &plan.reference_camera, (lf.width, lf.height))?
        }
    };
    plan_surface(plan, surface, Some(depth))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::Camera;
    use crate::geometry::homography::ViewWarp;
    use crate::refocus::focus::FocusMethod;
    use glam::DMat3;

    fn plan_at(z: f64) -> RefocusPlan {
        let cam = Camera {
            k: crate::geometry::camera::intrinsics(10.0, 10.0, 2.0, 2.0),
            r: DMat3::IDENTITY,
            t: DVec3::ZERO,
        };
        let plane = Plane::new(DVec3::new(0.0, 0.0, z), DVec3::Z).unwrap();
        RefocusPlan {
            reference: DVec2::ZERO,
            m: plane_term(&cam, &plane, 1e-9).unwrap(),
            reference_camera: cam,
            method: FocusMethod::Plane,
            plane: Some(plane),
            views: Vec::new(),
            width: 4,
            height: 4,
        }
    }

    fn depth(sigma: f32) -> SceneDepth {
        let mut v = vec![sigma; 16];
        v[0] = -1.0;
        SceneDepth {
            width: 4,
            height: 4,
            front: v.clone(),
            front_radius: 0,
            fronts: Vec::new(),
            inverse_depth: v,
            unknown: 1,
            source: "test".into(),
        }
    }

    #[test]
    fn each_rule_picks_the_inverse_depth_of_its_definition() {
        let plan = plan_at(2.0);
        let x = DVec2::new(1.0, 1.0);
        let far = Plane::new(DVec3::new(0.0, 0.0, 4.0), DVec3::Z).unwrap();
        let planes = FocusSurface::Planes(vec![plan.plane.unwrap(), far]);
        // Scene at z = 3.5: nearer (in inverse depth) the far plane at 4 than the plane at 2.
        let sp = plan_surface(&plan, &planes, Some(depth(1.0 / 3.5))).unwrap();
        assert!((sp.inverse_depth(x) - 0.25).abs() < 1e-12);
        // Scene at z = 2.5: the plane at 2.
        let sp = plan_surface(&plan, &planes, Some(depth(1.0 / 2.5))).unwrap();
        assert!((sp.inverse_depth(x) - 0.5).abs() < 1e-12);
        // A slab of half-width 1 around z = 2 spans z ∈ [1, 3] on the frontoparallel plane.
        let slab = FocusSurface::Slab { half_width: 1.0 };
        for (z, want) in [
            (2.5, 1.0 / 2.5),
            (1.5, 1.0 / 1.5),
            (5.0, 1.0 / 3.0),
            (0.5, 1.0),
        ] {
            let sp = plan_surface(&plan, &slab, Some(depth((1.0 / z) as f32))).unwrap();
            let got = sp.inverse_depth(x);
            assert!((got - want).abs() < 1e-6, "z {z}: {got} vs {want}");
        }
        let all = plan_surface(&plan, &FocusSurface::AllInFocus, Some(depth(0.125))).unwrap();
        assert_eq!(all.inverse_depth(x), 0.125);
        // Unknown depth (pixel 0): the plan's plane, finite.
        assert_eq!(all.inverse_depth(DVec2::ZERO), 0.5);
    }

    #[test]
    fn a_tilted_slab_keeps_points_within_w_along_the_normal() {
        // Plane through (0, 0, 2) with a tilted normal; points at known signed distances.
        let mut plan = plan_at(2.0);
        let n = DVec3::new(0.0, -0.6, 0.8);
        let plane = Plane::new(DVec3::new(0.0, 0.0, 2.0), n).unwrap();
        plan.m = plane_term(&plan.reference_camera, &plane, 1e-9).unwrap();
        plan.plane = Some(plane);
        let w = 0.3;
        let cam = plan.reference_camera;
        for dist in [-0.5, -0.29, 0.0, 0.2, 0.29, 0.45] {
            // A point along the ray of pixel (1, 3) at signed distance `dist` from the plane.
            let px = DVec2::new(1.0, 3.0);
            let ray = cam.k.inverse() * px.extend(1.0);
            let z = (plane.normal.dot(plane.point) + dist) / plane.normal.dot(ray);
            let d = depth((1.0 / z) as f32);
            let sp = plan_surface(&plan, &FocusSurface::Slab { half_width: w }, Some(d)).unwrap();
            let s = sp.inverse_depth(px);
            let kept = 1.0 / s * plane.normal.dot(ray) - plane.normal.dot(plane.point);
            let want = dist.clamp(-w, w);
            assert!((kept - want).abs() < 1e-5, "{dist}: focus at {kept}");
        }
    }

    #[test]
    fn planes_as_asked_are_placed_as_the_focus_alone_would_be() {
        let lf = crate::synth::builtin("planes").unwrap().light_field(1);
        let reference = DVec2::new(1.0, 2.0);
        let cam = lf.camera_at(reference).unwrap();
        let given = Plane::new(DVec3::new(0.1, 0.0, 3.0), DVec3::new(0.0, 0.3, 1.0)).unwrap();
        let keyboard = FocusSpec::FocusTiltSwing {
            distance: 2.5,
            tilt_deg: 12.0,
            swing_deg: -4.0,
        };
        let asked = FocusSurface::Planes(vec![
            keyboard,
            FocusSpec::Plane(given),
            FocusSpec::Disparity(0.5),
        ]);
        let FocusSurface::Planes(placed) = asked.resolve(&lf, reference).unwrap() else {
            panic!("several planes stay several planes");
        };
        // Each plane is the one resolve_focus gives for it alone from the same viewpoint.
        for (spec, got) in [keyboard, FocusSpec::Plane(given), FocusSpec::Disparity(0.5)]
            .iter()
            .zip(&placed)
        {
            let alone = crate::refocus::resolve_focus(&lf, &(*spec).into(), reference).unwrap();
            let want = alone.plane.unwrap();
            assert!(
                (want.point - got.point).length() < 1e-12
                    && (want.normal - got.normal).length() < 1e-12,
                "{spec:?}: {got:?} vs {want:?}"
            );
        }
        // The keyboard plane follows the reference camera: another viewpoint, another plane.
        let other = asked.resolve(&lf, DVec2::new(3.0, 2.0)).unwrap();
        assert_ne!(other, FocusSurface::Planes(placed.clone()));
        // Surfaces without planes pass through.
        let slab: FocusSurface<FocusSpec> = FocusSurface::Slab { half_width: 0.2 };
        assert_eq!(
            slab.resolve(&lf, reference).unwrap(),
            FocusSurface::Slab { half_width: 0.2 }
        );
        // A bad later plane is named by its place; a disparity without a rig has no plane.
        let bad = FocusSurface::Planes(vec![
            keyboard,
            FocusSpec::FocusTiltSwing {
                distance: 2.0,
                tilt_deg: 95.0,
                swing_deg: 0.0,
            },
        ]);
        let e = bad.resolve(&lf, reference).unwrap_err().to_string();
        assert!(
            e.contains("focus plane 2: tilt must lie strictly between"),
            "{e}"
        );
        // Without a rig a disparity is classic shift-and-sum: on these parallel cameras each
        // plane is the frontoparallel one that moves view (s, t)'s sample by D·(s, t) minus
        // the reference's grid position, as the classic sum does.
        let mut no_rig = lf.clone();
        no_rig.rig = None;
        let d = FocusSurface::Planes(vec![FocusSpec::Disparity(0.5), FocusSpec::Disparity(-1.5)]);
        let FocusSurface::Planes(placed) = d.resolve(&no_rig, reference).unwrap() else {
            panic!("several planes stay several planes");
        };
        for (disparity, plane) in [0.5, -1.5].into_iter().zip(&placed) {
            let m = plane_term(&cam, plane, 1e-9).unwrap();
            for v in &no_rig.views {
                let x = DVec2::new(10.0, 7.0);
                let y = ViewWarp::new(&v.camera, &cam).apply(m, x);
                let moved = DVec2::new(y.x / y.z, y.y / y.z) - x;
                let want = (DVec2::new(v.s as f64, v.t as f64) - reference) * disparity;
                assert!((moved - want).length() < 1e-9, "{moved} vs {want}");
            }
        }
        // Cameras that are not a parallel grid (one turned a degree): refused, naming why.
        let c = no_rig.views[3].camera;
        no_rig.views[3].camera = Camera::from_centre(
            c.k,
            DMat3::from_rotation_y(1f64.to_radians()) * c.r,
            c.centre(),
        );
        let e = d.resolve(&no_rig, reference).unwrap_err().to_string();
        assert!(
            e.contains("focus plane 1: the focus surface 'planes' needs the cameras' geometry")
                && e.contains("classic shift-and-sum")
                && e.contains("not a parallel grid"),
            "{e}"
        );
    }

    #[test]
    fn bad_surfaces_are_refused_with_their_cause() {
        let plan = plan_at(2.0);
        let p = plan.plane.unwrap();
        let err = |s: FocusSurface| plan_surface(&plan, &s, Some(depth(0.5))).unwrap_err();
        assert!(err(FocusSurface::Planes(vec![p; 9]))
            .to_string()
            .contains("2 to 8 planes, got 9"));
        for w in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = err(FocusSurface::Slab { half_width: w }).to_string();
            assert!(e.contains("half-width must be finite and > 0"), "{e}");
        }
        let e = err(FocusSurface::Slab { half_width: 2.5 }).to_string();
        assert!(e.contains("inside the focus slab"), "{e}");
        let e = plan_surface(&plan, &FocusSurface::AllInFocus, None).unwrap_err();
        assert!(e.to_string().contains("needs the scene's depth"), "{e}");
        // One plane needs nothing.
        assert!(plan_surface(&plan, &FocusSurface::Plane, None).is_ok());
        let req = |n: usize, slab, all| FocusSurface::from_request(&vec![p; n], slab, all);
        let msg = |r: Result<FocusSurface>| r.unwrap_err().to_string();
        assert!(msg(req(9, None, false)).contains("at most 8 planes, got 9"));
        assert!(msg(req(2, Some(0.1), false)).contains("exactly one plane, got 2 planes"));
        assert!(msg(req(1, Some(f64::NAN), false)).contains("finite and > 0"));
        assert!(msg(req(1, Some(0.1), true)).contains("give one"));
        assert_eq!(req(1, None, false).unwrap(), FocusSurface::Plane);
        assert_eq!(req(0, None, true).unwrap(), FocusSurface::AllInFocus);
        assert_eq!(
            req(8, None, false).unwrap(),
            FocusSurface::Planes(vec![p; 8])
        );
        // A slab draws its middle plane and both boundaries, W away along the normal.
        let drawn = FocusSurface::Slab { half_width: 0.5 }.planes_to_draw(&p);
        assert_eq!(drawn.len(), 3);
        for (q, d) in drawn.iter().zip([0.0, -0.5, 0.5]) {
            assert!((p.signed_distance(q.point) - d).abs() < 1e-12 && q.normal == p.normal);
        }
    }
}
