//! Resolves a refocus request against a light field: the reference (possibly virtual) camera,
//! the refocus plane, and for every view inside the aperture its weight and warp.
//!
//! `--disparity D` has two meanings, as DESIGN.md §2–3 prescribe:
//! - on a regular parallel rig with sensor shift (HCI folders, built-in scenes; `lf.rig` set)
//!   D is an HCI disparity: the frontoparallel plane at depth Z with 1/Z = D/(b·f) + 1/Z_focus,
//!   refocused through the general homography path (a centre-view pixel x of disparity D is
//!   seen in view (s, t) at x − D·(s − s_c, t − t_c));
//! - otherwise it is classic shift-and-sum (Ng 2005): view (s, t) is sampled at
//!   u + (s − s_r)·D, v + (t − t_r)·D, with no camera model involved.

use glam::{DVec2, DVec3};

use crate::error::{Error, Result};
use crate::geometry::aperture::Aperture;
use crate::geometry::camera::{interpolate_cameras, Camera};
use crate::geometry::homography::{plane_term, ViewWarp};
use crate::geometry::plane::Plane;
use crate::lightfield::LightField;

/// How the refocus surface is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FocusSpec {
    /// Disparity in pixels per grid step (see the module docs for its two meanings).
    Disparity(f64),
    /// A plane in the world frame.
    Plane(Plane),
    /// Point on the reference optical axis at `distance`, normal from tilt and swing (degrees).
    FocusTiltSwing {
        distance: f64,
        tilt_deg: f64,
        swing_deg: f64,
    },
}

/// Everything a refocus needs besides the light field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefocusRequest {
    pub focus: FocusSpec,
    pub aperture: Aperture,
    /// Reference view (s, t), fractional allowed; `None` = grid centre.
    pub reference: Option<DVec2>,
}

/// How the plane of a plan was obtained (reported by `--json`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FocusMethod {
    ClassicShift,
    HciDisparity,
    Plane,
    FocusTiltSwing,
}

/// One view inside the aperture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedView {
    /// Index into `lf.views` (= texture array layer).
    pub index: usize,
    pub s: usize,
    pub t: usize,
    pub weight: f64,
    pub warp: ViewWarp,
}

/// A resolved refocus: shared plane term `m` and per-view warps (`H_i = A_i + b_i mᵀ`).
#[derive(Debug, Clone, PartialEq)]
pub struct RefocusPlan {
    pub reference: DVec2,
    pub reference_camera: Camera,
    pub method: FocusMethod,
    /// The refocus plane (world frame); `None` for classic shift-and-sum.
    pub plane: Option<Plane>,
    /// Plane term `m = K_r⁻ᵀ n_r / d_r` (zero for classic shift-and-sum).
    pub m: DVec3,
    pub views: Vec<PlannedView>,
    /// Output size (the reference view's size).
    pub width: u32,
    pub height: u32,
}

/// The reference camera at fractional grid position `st`: bilinear between the four
/// neighbouring cameras (exactly a real camera at integer positions).
pub fn reference_camera(lf: &LightField, st: DVec2) -> Result<Camera> {
    let (cols, rows) = (lf.grid.cols, lf.grid.rows);
    let max = DVec2::new(cols as f64 - 1.0, rows as f64 - 1.0);
    if !st.is_finite() || st.x < 0.0 || st.y < 0.0 || st.x > max.x || st.y > max.y {
        return Err(Error::Invalid(format!(
            "reference view ({}, {}) lies outside the grid: s must be in [0, {}], t in [0, {}]",
            st.x, st.y, max.x, max.y
        )));
    }
    let s0 = (st.x.floor() as usize).min(cols.saturating_sub(2));
    let t0 = (st.y.floor() as usize).min(rows.saturating_sub(2));
    let s1 = (s0 + 1).min(cols - 1);
    let t1 = (t0 + 1).min(rows - 1);
    let cam = |s, t| &lf.view(s, t).camera;
    Ok(interpolate_cameras(
        cam(s0, t0),
        cam(s1, t0),
        cam(s0, t1),
        cam(s1, t1),
        st.x - s0 as f64,
        st.y - t0 as f64,
    ))
}

/// Length scale of the rig: the largest distance of a camera centre from the first one
/// (1 for a single camera). Degeneracy tolerances are relative to it.
fn rig_scale(lf: &LightField) -> f64 {
    let c0 = lf.views[0].camera.centre();
    let s = lf
        .views
        .iter()
        .map(|v| (v.camera.centre() - c0).length())
        .fold(0.0, f64::max);
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

/// Resolves `req` for `lf`. `excluded[i]` (if given) removes view i from the aperture, e.g. a
/// vignetted black corner view.
pub fn plan(lf: &LightField, req: &RefocusRequest, excluded: &[bool]) -> Result<RefocusPlan> {
    req.aperture.validate()?;
    let reference = req.reference.unwrap_or_else(|| lf.grid.centre());
    let reference_camera = reference_camera(lf, reference)?;
    let min_distance = 1e-6 * rig_scale(lf);

    let (method, plane) = match req.focus {
        FocusSpec::Disparity(d) if !d.is_finite() => {
            return Err(Error::Invalid(format!("disparity must be finite, got {d}")));
        }
        FocusSpec::Disparity(d) => match lf.rig {
            Some(rig) => {
                let z = rig.depth_of_disparity(d).ok_or_else(|| {
                    Error::Geometry(format!(
                        "disparity {d} px lies at or beyond infinity for this rig (the most \
                         negative physical disparity is {:.4} px)",
                        rig.disparity_at_infinity()
                    ))
                })?;
                // World frame = centre camera frame: the plane z = Z.
                let p = Plane::new(DVec3::new(0.0, 0.0, z), DVec3::Z)?;
                (FocusMethod::HciDisparity, Some(p))
            }
            None => (FocusMethod::ClassicShift, None),
        },
        FocusSpec::Plane(p) => (FocusMethod::Plane, Some(Plane::new(p.point, p.normal)?)),
        FocusSpec::FocusTiltSwing {
            distance,
            tilt_deg,
            swing_deg,
        } => (
            FocusMethod::FocusTiltSwing,
            Some(Plane::from_focus_tilt_swing(
                &reference_camera,
                distance,
                tilt_deg,
                swing_deg,
            )?),
        ),
    };
    let m = match &plane {
        Some(p) => plane_term(&reference_camera, p, min_distance)?,
        None => DVec3::ZERO,
    };

    let mut views = Vec::new();
    for (index, v) in lf.views.iter().enumerate() {
        if excluded.get(index).copied().unwrap_or(false) {
            continue;
        }
        let pos = DVec2::new(v.s as f64, v.t as f64);
        let weight = req
            .aperture
            .weight(pos, reference, lf.grid.cols, lf.grid.rows);
        if weight <= 0.0 {
            continue;
        }
        let warp = match (method, req.focus) {
            (FocusMethod::ClassicShift, FocusSpec::Disparity(d)) => {
                ViewWarp::translation((pos.x - reference.x) * d, (pos.y - reference.y) * d)
            }
            _ => ViewWarp::new(&v.camera, &reference_camera),
        };
        if !(warp.a.is_finite() && warp.b.is_finite()) {
            return Err(Error::Geometry(format!(
                "the warp of view ({}, {}) is not finite",
                v.s, v.t
            )));
        }
        views.push(PlannedView {
            index,
            s: v.s,
            t: v.t,
            weight,
            warp,
        });
    }
    if views.is_empty() {
        let excluded_count = excluded.iter().filter(|&&e| e).count();
        return Err(Error::Geometry(format!(
            "the aperture ({:?}, radius {}) around view ({}, {}) contains no usable view{}",
            req.aperture.shape,
            req.aperture
                .radius
                .map_or("default".to_string(), |r| r.to_string()),
            reference.x,
            reference.y,
            if excluded_count > 0 {
                format!(" ({excluded_count} dark views excluded)")
            } else {
                String::new()
            }
        )));
    }
    Ok(RefocusPlan {
        reference,
        reference_camera,
        method,
        plane,
        m,
        views,
        width: lf.width,
        height: lf.height,
    })
}
