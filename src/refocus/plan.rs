//! Resolves a refocus request against a light field: the reference (possibly virtual) camera,
//! the refocus plane, and for every view inside the aperture its weight and warp.
//!
//! The plane comes from [`super::focus`] (one definition for renders, overlays and viewers).
//! `--disparity D` has two meanings (docs/conventions.md §6):
//! - on a regular parallel rig with sensor shift (HCI folders, built-in scenes; `lf.rig` set)
//!   D is an HCI disparity: the frontoparallel plane at depth Z with 1/Z = D/(b·f) + 1/Z_focus,
//!   refocused through the general homography path (a centre-view pixel x of disparity D is
//!   seen in view (s, t) at x − D·(s − s_c, t − t_c));
//! - otherwise it is classic shift-and-sum (Ng 2005): view (s, t) is sampled at
//!   u + (s − s_r)·D, v + (t − t_r)·D, with no camera model involved.

use std::borrow::Cow;

use glam::{DVec2, DVec3};

use super::focus::{focus_plane, FocusMethod, FocusSpec, ResolvedFocus};
use crate::error::{Error, Result};
use crate::geometry::aperture::Aperture;
use crate::geometry::camera::Camera;
use crate::geometry::homography::ViewWarp;
use crate::geometry::plane::Plane;
use crate::lightfield::LightField;

/// Everything a refocus needs besides the light field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefocusRequest {
    pub focus: FocusSpec,
    pub aperture: Aperture,
    /// Reference view (s, t), fractional allowed; `None` = grid centre.
    pub reference: Option<DVec2>,
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

/// Resolves `req` for `lf`. `excluded[i]` (if given) removes view i from the aperture, e.g. a
/// vignetted black corner view.
pub fn plan(lf: &LightField, req: &RefocusRequest, excluded: &[bool]) -> Result<RefocusPlan> {
    req.aperture.validate()?;
    let reference = req.reference.unwrap_or_else(|| lf.grid.centre());
    let reference_camera = lf.camera_at(reference)?;
    let (method, plane, m) = focus_plane(lf, &req.focus, &reference_camera)?;

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

/// The disparity of a classic shift-and-sum plan (pixels per grid step, read back from its
/// translations; 0 for an aperture of the reference view alone); `None` for any other plan.
fn classic_disparity(plan: &RefocusPlan) -> Option<f64> {
    if plan.method != FocusMethod::ClassicShift {
        return None;
    }
    let offset = |v: &PlannedView| DVec2::new(v.s as f64, v.t as f64) - plan.reference;
    Some(
        plan.views
            .iter()
            .find(|v| offset(v).length() > 0.5)
            .map_or(0.0, |v| {
                let o = offset(v);
                v.warp.a.z_axis.truncate().dot(o) / o.length_squared()
            }),
    )
}

/// The distance (along the optical axis of the camera at grid position `reference`) of the
/// frontoparallel plane that classic shift-and-sum by `d` pixels per grid step stands for,
/// where `lf`'s cameras (those `excluded` leaves in) form a parallel grid: same orientation
/// and focal length, centres on a plane — a grid folder's nominal cameras, which take the
/// sensor shift of its depth estimate's range (`depth::cache::install`) so that every
/// estimated surface lies in front of infinity. The plane's plain sum is the classic one up
/// to rounding. An error names the cause where the cameras are not such a grid or `d` lies
/// at or beyond their infinity.
pub fn classic_distance(
    lf: &LightField,
    reference: DVec2,
    d: f64,
    excluded: &[bool],
) -> Result<f64> {
    let refuse = |why: String| {
        Error::Invalid(format!(
            "--disparity {d} on a light field without a rig is classic shift-and-sum, and {why}"
        ))
    };
    let rc = lf.camera_at(reference)?;
    // Under the cameras, view j's sample moves by t_j + b_j w from the output pixel on the
    // frontoparallel plane of inverse depth w (reference frame), when its warp's linear part
    // is the identity and b_j has no depth component; w solves t_j + b_j w = d·offset_j.
    let mut rows = Vec::new();
    for (j, v) in lf.views.iter().enumerate() {
        if excluded.get(j).copied().unwrap_or(false) {
            continue;
        }
        let w = ViewWarp::new(&v.camera, &rc);
        let scale = 1.0 + w.a.z_axis.truncate().length();
        let parallel = (w.a.x_axis - DVec3::X).length() < 1e-9
            && (w.a.y_axis - DVec3::Y).length() < 1e-9
            && (w.a.z_axis.z - 1.0).abs() < 1e-9
            && w.b.z.abs() < 1e-9 * scale.max(w.b.length());
        if !parallel {
            return Err(refuse("these cameras are not a parallel grid".into()));
        }
        let offset = DVec2::new(v.s as f64, v.t as f64) - reference;
        rows.push((w.a.z_axis.truncate(), w.b.truncate(), offset));
    }
    let (num, den) = rows.iter().fold((0.0, 0.0), |(n, dd), (t, b, o)| {
        (n + b.dot(d * *o - *t), dd + b.length_squared())
    });
    if den <= 0.0 {
        return Err(refuse("these cameras share one centre".into()));
    }
    let w = num / den;
    let misfit = rows
        .iter()
        .map(|(t, b, o)| (*t + *b * w - d * *o).length())
        .fold(0.0, f64::max);
    if misfit.is_nan() || misfit > 1e-6 * (1.0 + d.abs()) {
        return Err(refuse(format!(
            "these cameras shift their views unlike it (by up to {misfit:.3} px)"
        )));
    }
    if w.is_nan() || w <= 0.0 {
        // d at w = 0, measured along the grid's first offset.
        let at_infinity = rows
            .iter()
            .find(|(_, _, o)| o.length() > 0.5)
            .map_or(f64::NAN, |(t, _, o)| t.dot(*o) / o.length_squared());
        return Err(Error::Invalid(format!(
            "--disparity {d} lies at or beyond the cameras' infinity ({at_infinity:.3} px per \
             grid step), so it stands for no plane (focus nearer)"
        )));
    }
    Ok(1.0 / w)
}

/// The frontoparallel plane of the camera at grid position `reference` that classic
/// shift-and-sum by `d` pixels per grid step stands for ([`classic_distance`]).
pub fn classic_plane(
    lf: &LightField,
    reference: DVec2,
    d: f64,
    excluded: &[bool],
) -> Result<Plane> {
    let distance = classic_distance(lf, reference, d, excluded)?;
    Plane::from_focus_tilt_swing(&lf.camera_at(reference)?, distance, 0.0, 0.0)
}

/// `focus` (resolved for the reference view at grid position `reference`) with its plane:
/// classic shift-and-sum gets the plane it stands for ([`classic_plane`]), for drawing; an
/// error names the cause where it stands for none.
pub fn with_classic_plane(
    lf: &LightField,
    mut focus: ResolvedFocus,
    reference: DVec2,
) -> Result<ResolvedFocus> {
    if let (None, FocusSpec::Disparity(d)) = (focus.plane, focus.spec) {
        let plane = classic_plane(lf, reference, d, &[]).map_err(|e| {
            Error::Invalid(format!(
                "{e}, so '{}' has no focus plane to draw; give --plane, --focus or a click option",
                lf.name
            ))
        })?;
        focus.plane = Some(plane);
    }
    Ok(focus)
}

/// `plan` as a plan with a plane: itself, or for classic shift-and-sum the plan of the
/// frontoparallel plane it stands for ([`classic_distance`]: the keyboard definition at that
/// distance, tilt and swing 0), over the same `aperture` and views. For what needs the plane's
/// geometry (anti-aliasing's parallax, focus surfaces' inverse depths).
pub fn with_plane<'a>(
    lf: &LightField,
    plan: &'a RefocusPlan,
    aperture: Aperture,
    excluded: &[bool],
) -> Result<Cow<'a, RefocusPlan>> {
    let Some(d) = classic_disparity(plan) else {
        return Ok(Cow::Borrowed(plan));
    };
    let distance = classic_distance(lf, plan.reference, d, excluded)?;
    let request = RefocusRequest {
        focus: FocusSpec::FocusTiltSwing {
            distance,
            tilt_deg: 0.0,
            swing_deg: 0.0,
        },
        aperture,
        reference: Some(plan.reference),
    };
    Ok(Cow::Owned(self::plan(lf, &request, excluded)?))
}

/// The JSON description of a plan (`render --json`, `demo`, the viewer's `--json` and screenshots).
pub fn plan_json(plan: &RefocusPlan) -> serde_json::Value {
    let v3 = |v: DVec3| [v.x, v.y, v.z];
    serde_json::json!({
        "method": plan.method,
        "plane": plan.plane.map(|p| p.json()),
        "reference_view": [plan.reference.x, plan.reference.y],
        "reference_centre": v3(plan.reference_camera.centre()),
        "views_used": plan.views.len(),
        "views": plan.views.iter().map(|v| serde_json::json!({"s": v.s, "t": v.t, "weight": v.weight})).collect::<Vec<_>>(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::aperture::ApertureShape;
    use crate::lightfield::{GridSize, ParallelRig, Source, View};
    use glam::DMat3;

    const RIG: ParallelRig = ParallelRig {
        focal_px: 40.0,
        baseline: 0.1,
        focus_distance: 2.0,
    };

    /// A 5×3 grid of 32×24 blank views on `RIG`'s cameras; `rig` says whether the light field
    /// declares the rig (HCI disparity) or not (classic shift-and-sum).
    fn grid(rig: bool) -> LightField {
        let grid = GridSize { cols: 5, rows: 3 };
        let (w, h) = (32, 24);
        let views = RIG
            .cameras(grid, w, h)
            .into_iter()
            .enumerate()
            .map(|(i, camera)| View {
                s: i % grid.cols,
                t: i / grid.cols,
                camera,
                image: image::RgbaImage::new(w, h),
                source: format!("view {i}"),
            })
            .collect();
        let lf = LightField {
            name: "grid".into(),
            grid,
            width: w,
            height: h,
            views,
            depth: Vec::new(),
            rig: rig.then_some(RIG),
            disparity_range: None,
            source: Source::Generated {
                scene: "grid".into(),
            },
        };
        lf.validate().unwrap();
        lf
    }

    fn request(focus: FocusSpec, aperture: Aperture, reference: Option<DVec2>) -> RefocusRequest {
        RefocusRequest {
            focus,
            aperture,
            reference,
        }
    }

    fn disk(r: f64) -> Aperture {
        Aperture {
            shape: ApertureShape::Disk,
            radius: Some(r),
        }
    }

    #[test]
    fn classic_shift_translates_each_view_by_its_grid_offset_times_the_disparity() {
        let lf = grid(false);
        let d = 1.5;
        let p = plan(
            &lf,
            &request(FocusSpec::Disparity(d), Aperture::default(), None),
            &[],
        )
        .unwrap();
        assert_eq!(p.method, FocusMethod::ClassicShift);
        assert!(p.plane.is_none());
        assert_eq!(p.m, DVec3::ZERO);
        assert_eq!(p.reference, DVec2::new(2.0, 1.0));
        assert_eq!(p.views.len(), 15);
        let x = DVec2::new(7.0, 5.0);
        for v in &p.views {
            let y = v.warp.apply(p.m, x);
            let expect = x + DVec2::new(v.s as f64 - 2.0, v.t as f64 - 1.0) * d;
            assert!(
                (y.truncate() / y.z - expect).length() < 1e-12,
                "view ({}, {})",
                v.s,
                v.t
            );
        }
    }

    #[test]
    fn hci_disparity_moves_a_centre_pixel_by_minus_d_per_grid_step() {
        let lf = grid(true);
        let d = 0.75;
        let p = plan(
            &lf,
            &request(FocusSpec::Disparity(d), Aperture::default(), None),
            &[],
        )
        .unwrap();
        assert_eq!(p.method, FocusMethod::HciDisparity);
        let z = RIG.depth_of_disparity(d).unwrap();
        assert!((p.plane.unwrap().point.z - z).abs() < 1e-12);
        let x = DVec2::new(3.0, 17.0);
        for v in &p.views {
            let y = v.warp.apply(p.m, x);
            let expect = x - DVec2::new(v.s as f64 - 2.0, v.t as f64 - 1.0) * d;
            assert!(
                (y.truncate() / y.z - expect).length() < 1e-9,
                "view ({}, {})",
                v.s,
                v.t
            );
        }
    }

    #[test]
    fn plane_term_is_inverse_transposed_intrinsics_times_normal_over_distance() {
        let lf = grid(true);
        let plane = Plane::new(DVec3::new(0.3, -0.1, 2.5), DVec3::new(0.2, -0.3, 1.0)).unwrap();
        let reference = DVec2::new(1.0, 2.0);
        let p = plan(
            &lf,
            &request(
                FocusSpec::Plane(plane),
                Aperture::default(),
                Some(reference),
            ),
            &[],
        )
        .unwrap();
        // At an integer grid position the reference camera is the real one.
        let real = &lf.view(1, 2).camera;
        let cam = &p.reference_camera;
        assert!((cam.centre() - real.centre()).length() < 1e-12);
        assert!((cam.k - real.k).abs_diff_eq(DMat3::ZERO, 1e-12));
        let d_r = plane.normal.dot(plane.point - cam.centre());
        let expect = cam.k.inverse().transpose() * (cam.r * plane.normal) / d_r;
        assert!((p.m - expect).length() <= 1e-12 * expect.length());
        // Every homography maps the reference image of a plane point onto its image in view i.
        let q = plane.point + DVec3::new(0.1, 0.05, 0.0).cross(plane.normal);
        let xr = cam.project(q).unwrap();
        for v in &p.views {
            let y = v.warp.homography(p.m) * xr.extend(1.0);
            let expect = lf.views[v.index].camera.project(q).unwrap();
            assert!((y.truncate() / y.z - expect).length() < 1e-9);
        }
    }

    #[test]
    fn aperture_selects_views_around_a_fractional_reference_and_skips_excluded_ones() {
        let lf = grid(true);
        let focus = FocusSpec::Disparity(0.0);
        // Disk of radius 1 around the centre: the centre and its 4 neighbours, weight 1.
        let p = plan(&lf, &request(focus, disk(1.0), None), &[]).unwrap();
        let mut st: Vec<_> = p.views.iter().map(|v| (v.s, v.t)).collect();
        st.sort();
        assert_eq!(st, [(1, 1), (2, 0), (2, 1), (2, 2), (3, 1)]);
        assert!(p.views.iter().all(|v| v.weight == 1.0));
        // Between views (1.5, 1): radius 0.5 reaches exactly the two neighbours.
        let p = plan(
            &lf,
            &request(focus, disk(0.5), Some(DVec2::new(1.5, 1.0))),
            &[],
        )
        .unwrap();
        let st: Vec<_> = p.views.iter().map(|v| (v.s, v.t)).collect();
        assert_eq!(st, [(1, 1), (2, 1)]);
        // The virtual camera sits halfway between them.
        let mid = 0.5 * (lf.view(1, 1).camera.centre() + lf.view(2, 1).camera.centre());
        assert!((p.reference_camera.centre() - mid).length() < 1e-12);
        // Excluding one leaves the other; excluding both is an error that says so.
        let mut excluded = vec![false; lf.views.len()];
        excluded[lf.grid.index(1, 1)] = true;
        let req = request(focus, disk(0.5), Some(DVec2::new(1.5, 1.0)));
        assert_eq!(plan(&lf, &req, &excluded).unwrap().views.len(), 1);
        excluded[lf.grid.index(2, 1)] = true;
        let e = plan(&lf, &req, &excluded).unwrap_err().to_string();
        assert!(
            e.contains("no usable view") && e.contains("2 dark views excluded"),
            "{e}"
        );
        // Gaussian weights fall off with the distance from the reference.
        let g = Aperture {
            shape: ApertureShape::Gaussian,
            radius: Some(1.0),
        };
        let p = plan(&lf, &request(focus, g, None), &[]).unwrap();
        let w = |s, t| {
            p.views
                .iter()
                .find(|v| (v.s, v.t) == (s, t))
                .unwrap()
                .weight
        };
        assert_eq!(w(2, 1), 1.0);
        assert!((w(3, 1) - (-0.5f64).exp()).abs() < 1e-12);
        assert!(w(4, 2) < w(3, 1));
    }

    #[test]
    fn a_plane_through_the_reference_camera_and_a_reference_outside_the_grid_are_refused() {
        let lf = grid(true);
        let through = Plane::new(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0)).unwrap();
        let e = plan(
            &lf,
            &request(FocusSpec::Plane(through), Aperture::default(), None),
            &[],
        );
        assert!(e.is_err());
        let outside = Some(DVec2::new(4.5, 0.0));
        let e = plan(
            &lf,
            &request(FocusSpec::Disparity(0.0), Aperture::default(), outside),
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("outside the grid"), "{e}");
    }
}
