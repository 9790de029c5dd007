//! The plane sweep as pure maths: which view is the reference, which views are matched against
//! it, the per-view warps, the sweep parameter and its range, and how a swept value becomes a
//! disparity or a depth. No GPU here; the GPU pass ([`crate::passes::depth`]) and the f64 CPU
//! reference ([`super::cpu`]) both take a [`SweepPlan`].
//!
//! Planes are frontoparallel to the reference camera r. For such a plane at depth Z the refocus
//! plane term is `m = K_r⁻ᵀ n_r / d_r = (0, 0, 1/Z)` (docs/conventions.md §3: `K_r⁻ᵀ e₃ = e₃` for
//! every K whose last row is (0, 0, 1)), so view i samples the reference pixel x at
//! `A_i x + b_i w` with the refocus warp `(A_i, b_i)` of [`ViewWarp::new`] and `w = 1/Z`. The
//! sweep runs over a parameter p that is affine in w, so planes uniform in p are uniform in
//! inverse depth, and each view's sample position is `A'_i x + b'_i p`:
//!
//! | light field | p | `A'_i`, `b'_i` |
//! |---|---|---|
//! | regular parallel rig (HCI folders, built-in scenes, manifests with `rig`) | HCI disparity d, px per grid step: `w = d/(b·f) + 1/Z_focus` | `A_i + (b_i/Z_focus) e₃ᵀ`, `b_i/(b·f)` |
//! | grid folder (no calibration) | classic shift-and-sum disparity D, px per grid step | `I`, `(s − s_r, t − t_r, 0)` |
//! | calibrated rig without a regular grid (rotated cameras) | inverse depth w = 1/Z of the reference camera | `A_i`, `b_i` |
//!
//! Half-apertures: every matched view belongs to the halves of the aperture it lies in, by its
//! grid offset from the reference: left (Δs < 0), right (Δs > 0), up (Δt < 0), down (Δt > 0).
//! An occluder covers a pixel in the views on one side of it only, so the robust cost
//! ([`super::CostKind::Robust`]) keeps the two best halves.

use glam::{DMat3, DVec2, DVec3};

use super::{Convention, DepthKind, RangeOrigin, ViewSet};
use crate::error::{Error, Result};
use crate::geometry::camera::Camera;
use crate::geometry::homography::ViewWarp;
use crate::lightfield::{LightField, Source};

/// Fewest planes of a sweep: sub-plane refinement needs a neighbour on each side.
pub const MIN_PLANES: usize = 3;
/// Most planes of a sweep.
pub const MAX_PLANES: usize = 1024;
/// Motion (px, farthest matched view) within which planes are too close to the winner to be
/// its rival in the confidence ([`SweepPlan::confidence_gap`]).
pub const CONF_GAP_MOTION: f64 = 1.0;

/// One view matched against the reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepView {
    /// Index in `lf.views`.
    pub index: usize,
    pub s: usize,
    pub t: usize,
    /// Sample position of reference pixel x at parameter p: `a·x + b·p` (homogeneous).
    pub a: DMat3,
    pub b: DVec3,
    /// Membership of the half-apertures left, right, up, down (see the module docs).
    pub halves: [bool; 4],
}

impl SweepView {
    /// True when the warp moves every pixel by the same offset: `a = [I | t]` and `b.z = 0`
    /// (parallel cameras with equal intrinsics, classic shift-and-sum).
    /// (Within 1e-9: the warps are products of f64 matrices and inverses.)
    pub fn is_translation(&self) -> bool {
        let a = self.a;
        let near = |u: DVec3, v: DVec3| (u - v).abs().max_element() <= 1e-9;
        near(a.x_axis, DVec3::X)
            && near(a.y_axis, DVec3::Y)
            && (a.z_axis.z - 1.0).abs() <= 1e-9
            && self.b.z.abs() <= 1e-9 * self.b.length().max(1e-300)
    }

    /// The (homogeneous) sample position of reference pixel position `x` at parameter `p`.
    pub fn sample(&self, x: DVec2, p: f64) -> DVec3 {
        self.a * x.extend(1.0) + self.b * p
    }
}

/// A resolved sweep: reference, matched views, parameter range and plane count.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPlan {
    /// Index of the reference view in `lf.views`.
    pub reference: usize,
    /// Its grid position (s, t).
    pub reference_st: (usize, usize),
    pub reference_camera: Camera,
    pub width: u32,
    pub height: u32,
    pub views: Vec<SweepView>,
    /// What p means.
    pub convention: Convention,
    /// p of the first and the last plane (first < last).
    pub range: (f64, f64),
    pub range_origin: RangeOrigin,
    pub planes: usize,
}

impl SweepPlan {
    /// p of plane k (k may be fractional).
    pub fn param(&self, k: f64) -> f64 {
        self.range.0 + k * self.step()
    }

    /// Spacing of the planes in p.
    pub fn step(&self) -> f64 {
        (self.range.1 - self.range.0) / (self.planes - 1) as f64
    }

    /// The same sweep on views downscaled by `factor` (pixel-index coordinates: fine position
    /// x ↦ (x + ½)/factor − ½): the warps are conjugated by that scaling, p keeps its meaning.
    pub fn scaled(&self, factor: u32, planes: usize, range: (f64, f64)) -> SweepPlan {
        let f = factor as f64;
        let c = 0.5 / f - 0.5;
        let s = DMat3::from_cols(
            DVec3::new(1.0 / f, 0.0, 0.0),
            DVec3::new(0.0, 1.0 / f, 0.0),
            DVec3::new(c, c, 1.0),
        );
        let s_inv = s.inverse();
        let mut cam = self.reference_camera;
        cam.k = s * cam.k;
        SweepPlan {
            reference_camera: cam,
            width: (self.width / factor).max(1),
            height: (self.height / factor).max(1),
            views: self
                .views
                .iter()
                .map(|v| SweepView {
                    a: s * v.a * s_inv,
                    b: s * v.b,
                    ..*v
                })
                .collect(),
            planes,
            range,
            ..self.clone()
        }
    }

    /// Planes closer than this to the winner do not count as its rival c₂ in the confidence:
    /// those within [`CONF_GAP_MOTION`] px of motion in the farthest view (the width of a cost
    /// minimum), at least 2, at most a quarter of the planes.
    pub fn confidence_gap(&self) -> usize {
        let per_plane = self.centre_motion(self.range.0, self.range.1) / (self.planes - 1) as f64;
        let gap = if per_plane > 0.0 && per_plane.is_finite() {
            (CONF_GAP_MOTION / per_plane).round() as usize
        } else {
            2
        };
        gap.clamp(2, (self.planes / 4).max(2))
    }

    /// The largest grid offset of a matched view from the reference, in grid steps.
    pub fn max_offset(&self) -> f64 {
        let (sr, tr) = self.reference_st;
        self.views
            .iter()
            .map(|v| {
                let ds = v.s as f64 - sr as f64;
                let dt = v.t as f64 - tr as f64;
                ds.abs().max(dt.abs())
            })
            .fold(0.0, f64::max)
    }

    /// Largest motion (pixels) of the reference image centre over all matched views between
    /// parameters `p0` and `p1`.
    pub fn centre_motion(&self, p0: f64, p1: f64) -> f64 {
        let x = DVec2::new(
            (self.width as f64 - 1.0) / 2.0,
            (self.height as f64 - 1.0) / 2.0,
        );
        let at = |v: &SweepView, p: f64| {
            let y = v.sample(x, p);
            DVec2::new(y.x / y.z, y.y / y.z)
        };
        self.views
            .iter()
            .map(|v| (at(v, p1) - at(v, p0)).length())
            .filter(|m| m.is_finite())
            .fold(0.0, f64::max)
    }
}

/// The reference view: `requested` (s, t) or the grid's middle view (cols/2, rows/2, the
/// view that carries the HCI and generated depth maps). An error outside the grid.
pub fn reference_view(lf: &LightField, requested: Option<(usize, usize)>) -> Result<usize> {
    let (s, t) = requested.unwrap_or((lf.grid.cols / 2, lf.grid.rows / 2));
    if s >= lf.grid.cols || t >= lf.grid.rows {
        return Err(Error::Invalid(format!(
            "reference view ({s}, {t}) lies outside the {}×{} grid",
            lf.grid.cols, lf.grid.rows
        )));
    }
    Ok(lf.grid.index(s, t))
}

/// What p means on `lf` (see the module docs).
pub fn convention_of(lf: &LightField) -> Convention {
    match (&lf.rig, &lf.source) {
        (Some(rig), _) => Convention::Hci(*rig),
        (None, Source::GridFolder { .. } | Source::Arrays) => {
            // The folder's nominal cameras: focal length and baseline from the loader.
            let c0 = &lf.views[0].camera;
            let next = if lf.grid.cols > 1 { 1 } else { lf.grid.cols };
            let baseline = lf
                .views
                .get(next)
                .map_or(1.0, |v| (v.camera.centre() - c0.centre()).length());
            Convention::Classic {
                focal_px: c0.focal_px(),
                baseline,
            }
        }
        (None, _) => Convention::InverseDepth,
    }
}

/// The views of `set` around `reference` (the reference itself excluded), in grid order,
/// leaving out `excluded` ones.
pub fn select_views(
    lf: &LightField,
    reference: usize,
    set: ViewSet,
    excluded: &[bool],
) -> Vec<usize> {
    let r = &lf.views[reference];
    lf.views
        .iter()
        .enumerate()
        .filter(|(i, v)| {
            let ds = v.s.abs_diff(r.s);
            let dt = v.t.abs_diff(r.t);
            *i != reference
                && !excluded.get(*i).copied().unwrap_or(false)
                && match set {
                    ViewSet::All => true,
                    ViewSet::Cross(n) => (ds == 0 || dt == 0) && ds.max(dt) <= n,
                    ViewSet::Square(n) => ds.max(dt) <= n,
                }
        })
        .map(|(i, _)| i)
        .collect()
}

/// The sweep warps of view `index` against the reference for `convention`.
pub fn sweep_view(
    lf: &LightField,
    reference: usize,
    index: usize,
    convention: Convention,
) -> SweepView {
    let (v, r) = (&lf.views[index], &lf.views[reference]);
    let ds = v.s as f64 - r.s as f64;
    let dt = v.t as f64 - r.t as f64;
    let (a, b) = match convention {
        Convention::Classic { .. } => (DMat3::IDENTITY, DVec3::new(ds, dt, 0.0)),
        Convention::Hci(rig) => {
            let w = ViewWarp::new(&v.camera, &r.camera);
            let mut a = w.a;
            a.z_axis += w.b / rig.focus_distance;
            (a, w.b / (rig.baseline * rig.focal_px))
        }
        Convention::InverseDepth => {
            let w = ViewWarp::new(&v.camera, &r.camera);
            (w.a, w.b)
        }
    };
    SweepView {
        index,
        s: v.s,
        t: v.t,
        a,
        b,
        halves: [ds < 0.0, ds > 0.0, dt < 0.0, dt > 0.0],
    }
}

/// `v` for a message: exponent notation for huge and tiny magnitudes (1e308, not 309 digits).
fn short(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Largest disparity magnitude a sweep accepts, px per grid step: far beyond any real light
/// field (the views would not overlap), small enough that every plane stays finite.
pub const MAX_DISPARITY: f64 = 1e6;

/// A range given in `kind` units (disparity px per grid step, or depth in world units) as
/// a range of p, first < last. Errors name what is wrong with it and call it `--range`.
pub fn param_range(
    convention: Convention,
    kind: DepthKind,
    given: (f64, f64),
) -> Result<(f64, f64)> {
    param_range_from(convention, kind, given, "--range")
}

/// [`param_range`] for a range that came from `origin` (`--range`, or the dataset's
/// `[meta] disp_min, disp_max`), which its errors name.
pub fn param_range_from(
    convention: Convention,
    kind: DepthKind,
    given: (f64, f64),
    origin: &str,
) -> Result<(f64, f64)> {
    let (lo, hi) = given;
    let what = format!("{origin} {},{}", short(lo), short(hi));
    if !(lo.is_finite() && hi.is_finite()) || lo >= hi {
        return Err(Error::Invalid(format!(
            "{what}: give two finite numbers MIN,MAX with MIN < MAX"
        )));
    }
    let p = match (kind, convention) {
        (DepthKind::Disparity, Convention::InverseDepth) => Err(Error::Invalid(
            "this light field is a calibrated rig without a regular grid, so it has no disparity \
             convention: give --kind depth (and a --range in depth units)"
                .into(),
        )),
        (DepthKind::Disparity, Convention::Hci(rig)) => {
            let inf = rig.disparity_at_infinity();
            if hi <= inf {
                return Err(Error::Invalid(format!(
                    "{what} lies entirely at or beyond infinity: on this rig a \
                     disparity of {inf:.4} px is infinitely far, so every disparity must be larger"
                )));
            }
            if lo <= inf {
                return Err(Error::Invalid(format!(
                    "{what} reaches beyond infinity: on this rig a disparity of \
                     {inf:.4} px is infinitely far; give a MIN above it"
                )));
            }
            Ok((lo, hi))
        }
        (DepthKind::Disparity, Convention::Classic { .. }) => Ok((lo, hi)),
        (DepthKind::Depth, _) if lo <= 0.0 => Err(Error::Invalid(format!(
            "{what}: depths must be positive (MIN is the nearest, MAX the farthest \
             distance along the optical axis)"
        ))),
        (DepthKind::Depth, Convention::Hci(rig)) => {
            Ok((rig.disparity_of_depth(hi), rig.disparity_of_depth(lo)))
        }
        (DepthKind::Depth, Convention::InverseDepth) => Ok((1.0 / hi, 1.0 / lo)),
        (DepthKind::Depth, Convention::Classic { .. }) => Err(Error::Invalid(
            "a grid folder has no calibration, so a depth range means nothing to it: give \
             --range in classic disparity (px per grid step) with --kind disparity"
                .into(),
        )),
    }?;
    // Extreme depths (1e-308, 1e308) turn into infinite or equal sweep parameters, which
    // would sweep nothing and write NaN everywhere: refuse them naming the range.
    let limit = match (kind, convention) {
        (_, Convention::InverseDepth) => f64::MAX,
        _ => MAX_DISPARITY,
    };
    if !(p.0.is_finite()
        && p.1.is_finite()
        && p.0 < p.1
        && p.0.abs() <= limit
        && p.1.abs() <= limit)
    {
        let unit = match convention {
            Convention::InverseDepth => "inverse depths",
            _ => "disparities",
        };
        return Err(Error::Invalid(format!(
            "{what} is out of reach: it becomes {unit} {} … {} on this rig; sweeps need finite, \
             distinct values{}",
            short(p.0),
            short(p.1),
            if limit < f64::MAX {
                format!(" of at most {MAX_DISPARITY:e} px")
            } else {
                String::new()
            }
        )));
    }
    Ok(p)
}

/// The wide range searched when no range is known: the reference centre moves by up to an
/// eighth of the smaller image side per two grid steps of the farthest matched view (an
/// eighth in all where that view is at most two steps away), on either side of the depth it
/// does not move at all (the zero-disparity distance of an HCI rig; infinity for parallel
/// calibrated cameras, the point they look at for converging ones), nearer than infinity.
/// Per grid step, not in the farthest view: an eighth of the image in the farthest view of a
/// 9 × 9 grid is half the disparity of a 5 × 5 grid's, and cut off the near surfaces of the
/// depth set on 7 × 7 and 9 × 9 grids (`converging` at 9 × 9, 192²: BadPix 0.07 19.4 → 3.0 %,
/// the nearest card outside the range; the set's mean 6.5 → 4.7 %, docs/depth.md).
pub fn wide_range(plan: &SweepPlan) -> (f64, f64) {
    let per_two_steps = (plan.max_offset() / 2.0).max(1.0);
    let motion = plan.width.min(plan.height) as f64 / 8.0 * per_two_steps;
    match plan.convention {
        Convention::Hci(rig) => {
            let d = motion / plan.max_offset().max(1.0);
            let inf = rig.disparity_at_infinity();
            // Just short of infinity: its disparity has no depth.
            let far = (-d).max(inf + 1e-3 * (d - inf).abs());
            (far, d)
        }
        Convention::Classic { .. } => {
            let d = motion / plan.max_offset().max(1.0);
            (-d, d)
        }
        Convention::InverseDepth => {
            // The scale: the inverse depth w whose centre moves `motion` from infinity (w = 0;
            // motion grows monotonically with w for a view in front).
            let scale = bisect_motion(plan, 0.0, motion, 1.0);
            let w0 = still_point(plan, scale);
            let hi = bisect_motion(plan, w0, motion, 1.0);
            // w = 0 is infinity: start a hair in front of it.
            let lo = if w0 > 0.0 {
                bisect_motion(plan, w0, motion, -1.0)
            } else {
                0.0
            };
            (lo.max(1e-3 * hi), hi)
        }
    }
}

/// The inverse depth on side `dir` (+1 nearer, −1 farther, never past infinity) of `from`
/// where the reference centre has moved `motion` pixels from where it is at `from`: the
/// nearest such w, by doubling then bisection; the end of the search where it never does.
fn bisect_motion(plan: &SweepPlan, from: f64, motion: f64, dir: f64) -> f64 {
    let at = |step: f64| (from + dir * step).max(0.0);
    let moved = |step: f64| plan.centre_motion(from, at(step)) >= motion;
    let (mut lo, mut hi) = if dir > 0.0 {
        let (mut lo, mut hi) = (0.0, 1e-9_f64.max(1e-6 * from));
        while !moved(hi) && hi < 1e12 {
            lo = hi;
            hi *= 2.0;
        }
        (lo, hi)
    } else {
        // Farther only as far as infinity.
        if !moved(from) {
            return 0.0;
        }
        (0.0, from)
    };
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if moved(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    at(hi)
}

/// The inverse depth in `[0, 64·scale]` at which the reference centre moves least between the
/// matched views (it stays still there on a rig that converges on it): the largest distance
/// from the reference centre of its image in any matched view, minimised by a scan and a
/// golden-section refinement. 0 (infinity) for parallel cameras.
fn still_point(plan: &SweepPlan, scale: f64) -> f64 {
    let x = DVec2::new(
        (plan.width as f64 - 1.0) / 2.0,
        (plan.height as f64 - 1.0) / 2.0,
    );
    let spread = |w: f64| {
        plan.views
            .iter()
            .map(|v| {
                let y = v.sample(x, w);
                (DVec2::new(y.x / y.z, y.y / y.z) - x).length()
            })
            .map(|m| if m.is_finite() { m } else { f64::INFINITY })
            .fold(0.0, f64::max)
    };
    const STEPS: usize = 1024;
    let top = 64.0 * scale;
    let step = top / STEPS as f64;
    let best = (0..=STEPS)
        .map(|k| (k, spread(k as f64 * step)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0, |(k, _)| k);
    let (mut a, mut b) = (
        (best as f64 - 1.0).max(0.0) * step,
        (best as f64 + 1.0).min(STEPS as f64) * step,
    );
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..80 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if spread(c) <= spread(d) {
            b = d;
        } else {
            a = c;
        }
    }
    let w = 0.5 * (a + b);
    // Parallel cameras are still only at infinity: keep w = 0 exactly there.
    if spread(0.0) <= spread(w) {
        0.0
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::{GridSize, ParallelRig, View};

    const RIG: ParallelRig = ParallelRig {
        focal_px: 50.0,
        baseline: 0.1,
        focus_distance: 2.0,
    };

    /// Black views of `w × h` for `cameras`, row-major on a grid `cols` wide.
    fn blank_views(
        cameras: Vec<crate::geometry::camera::Camera>,
        cols: usize,
        (w, h): (u32, u32),
    ) -> Vec<View> {
        cameras
            .into_iter()
            .enumerate()
            .map(|(i, camera)| View {
                s: i % cols,
                t: i / cols,
                camera,
                image: image::RgbaImage::new(w, h),
                source: format!("view {i}"),
            })
            .collect()
    }

    fn lf(rig: bool) -> LightField {
        let grid = GridSize { cols: 5, rows: 3 };
        let views = blank_views(RIG.cameras(grid, 32, 24), 5, (32, 24));
        LightField {
            name: "t".into(),
            grid,
            width: 32,
            height: 24,
            views,
            depth: Vec::new(),
            rig: rig.then_some(RIG),
            disparity_range: None,
            source: Source::Generated { scene: "t".into() },
        }
    }

    #[test]
    fn hci_sweep_moves_a_pixel_by_minus_d_per_grid_step() {
        let lf = lf(true);
        let r = reference_view(&lf, None).unwrap();
        assert_eq!(lf.views[r].s, 2);
        let conv = convention_of(&lf);
        let x = DVec2::new(7.0, 11.0);
        for i in select_views(&lf, r, ViewSet::All, &[]) {
            let v = sweep_view(&lf, r, i, conv);
            for d in [-1.5, 0.0, 0.7] {
                let y = v.sample(x, d);
                let expect = x - d * DVec2::new(v.s as f64 - 2.0, v.t as f64 - 1.0);
                assert!((y.truncate() / y.z - expect).length() < 1e-9);
            }
        }
    }

    #[test]
    fn the_hci_sweep_is_the_refocus_homography_of_the_frontoparallel_plane() {
        // Through the same homography as the refocus: the plane at the depth of disparity d.
        let lf = lf(true);
        let r = reference_view(&lf, None).unwrap();
        let conv = convention_of(&lf);
        let d = 0.4;
        let z = RIG.depth_of_disparity(d).unwrap();
        let m = DVec3::new(0.0, 0.0, 1.0 / z);
        let x = DVec2::new(3.0, 20.0);
        for i in select_views(&lf, r, ViewSet::All, &[]) {
            let w = ViewWarp::new(&lf.views[i].camera, &lf.views[r].camera);
            let h = w.homography(m) * x.extend(1.0);
            let y = sweep_view(&lf, r, i, conv).sample(x, d);
            assert!((h.truncate() / h.z - y.truncate() / y.z).length() < 1e-9);
        }
    }

    #[test]
    fn classic_sweep_is_shift_and_sum() {
        let mut lf = lf(false);
        lf.source = Source::GridFolder {
            path: "grid".into(),
            naming: crate::lightfield::grid_naming::GridNaming {
                pattern: "{row}_{col}.png".into(),
                fields: Vec::new(),
                files: lf.views.len(),
                subfolder: None,
            },
        };
        let r = reference_view(&lf, None).unwrap();
        let conv = convention_of(&lf);
        assert!(matches!(conv, Convention::Classic { focal_px, baseline }
            if (focal_px - 50.0).abs() < 1e-12 && (baseline - 0.1).abs() < 1e-12));
        let v = sweep_view(&lf, r, lf.grid.index(4, 0), conv);
        let y = v.sample(DVec2::new(1.0, 2.0), 0.5);
        assert_eq!(y, DVec3::new(2.0, 1.5, 1.0));
        assert_eq!(v.halves, [false, true, true, false]);
    }

    #[test]
    fn view_sets_select_around_the_reference() {
        let lf = lf(true);
        let r = lf.grid.index(2, 1);
        let st = |set| {
            select_views(&lf, r, set, &[])
                .iter()
                .map(|&i| (lf.views[i].s, lf.views[i].t))
                .collect::<Vec<_>>()
        };
        assert_eq!(st(ViewSet::All).len(), 14);
        assert_eq!(
            st(ViewSet::Cross(usize::MAX)),
            vec![(2, 0), (0, 1), (1, 1), (3, 1), (4, 1), (2, 2)]
        );
        assert_eq!(st(ViewSet::Cross(1)), vec![(2, 0), (1, 1), (3, 1), (2, 2)]);
        assert_eq!(st(ViewSet::Square(1)).len(), 8);
        let mut excluded = vec![false; 15];
        excluded[lf.grid.index(2, 0)] = true;
        assert_eq!(select_views(&lf, r, ViewSet::Cross(1), &excluded).len(), 3);
        assert!(reference_view(&lf, Some((5, 0))).is_err());
    }

    #[test]
    fn ranges_convert_and_bad_ones_name_the_problem() {
        let hci = Convention::Hci(RIG);
        assert_eq!(
            param_range(hci, DepthKind::Disparity, (-1.0, 1.0)).unwrap(),
            (-1.0, 1.0)
        );
        // Depth 1 … 4 m: nearer is the larger disparity.
        let (lo, hi) = param_range(hci, DepthKind::Depth, (1.0, 4.0)).unwrap();
        assert!((lo - RIG.disparity_of_depth(4.0)).abs() < 1e-12);
        assert!((hi - RIG.disparity_of_depth(1.0)).abs() < 1e-12);
        let inv = param_range(Convention::InverseDepth, DepthKind::Depth, (2.0, 8.0)).unwrap();
        assert_eq!(inv, (0.125, 0.5));
        for (conv, kind, r, needle) in [
            (hci, DepthKind::Disparity, (1.0, 1.0), "MIN < MAX"),
            (hci, DepthKind::Disparity, (2.0, -1.0), "MIN < MAX"),
            (hci, DepthKind::Disparity, (f64::NAN, 1.0), "finite"),
            (hci, DepthKind::Disparity, (-9.0, -5.0), "entirely"),
            (hci, DepthKind::Disparity, (-9.0, 1.0), "beyond infinity"),
            (hci, DepthKind::Depth, (0.0, 1.0), "positive"),
            (
                Convention::InverseDepth,
                DepthKind::Disparity,
                (0.0, 1.0),
                "--kind depth",
            ),
        ] {
            let e = param_range(conv, kind, r).unwrap_err().to_string();
            assert!(e.contains(needle), "{r:?}: {e}");
        }
    }

    #[test]
    fn scaling_conjugates_the_warps() {
        let lf = lf(true);
        let r = reference_view(&lf, None).unwrap();
        let conv = convention_of(&lf);
        let views = select_views(&lf, r, ViewSet::All, &[])
            .into_iter()
            .map(|i| sweep_view(&lf, r, i, conv))
            .collect();
        let plan = SweepPlan {
            reference: r,
            reference_st: (2, 1),
            reference_camera: lf.views[r].camera,
            width: 32,
            height: 24,
            views,
            convention: conv,
            range: (-1.0, 1.0),
            range_origin: RangeOrigin::Given,
            planes: 9,
        };
        let half = plan.scaled(2, 5, (-1.0, 1.0));
        assert_eq!((half.width, half.height), (16, 12));
        // Fine pixel x ↦ coarse (x + ½)/2 − ½, and so do the sample positions.
        let to_coarse = |p: DVec2| (p + 0.5) / 2.0 - 0.5;
        let x = DVec2::new(9.0, 5.0);
        for (f, c) in plan.views.iter().zip(&half.views) {
            let yf = f.sample(x, 0.6);
            let yc = c.sample(to_coarse(x), 0.6);
            let expect = to_coarse(yf.truncate() / yf.z);
            assert!((yc.truncate() / yc.z - expect).length() < 1e-9);
        }
        // Half-size images move half as far.
        let m = plan.centre_motion(-1.0, 1.0);
        assert!((half.centre_motion(-1.0, 1.0) - m / 2.0).abs() < 1e-9);
        assert!((m - 2.0 * 2.0_f64.hypot(1.0)).abs() < 1e-9, "{m}");
    }

    /// A sweep plan of `lf` (a calibrated rig: inverse-depth convention) from its middle view
    /// against `set`, at the views' size.
    fn calibrated_plan(lf: &LightField, set: ViewSet) -> SweepPlan {
        let r = reference_view(lf, None).unwrap();
        let conv = convention_of(lf);
        assert_eq!(conv, Convention::InverseDepth);
        let views = select_views(lf, r, set, &[])
            .into_iter()
            .map(|i| sweep_view(lf, r, i, conv))
            .collect();
        SweepPlan {
            reference: r,
            reference_st: (lf.views[r].s, lf.views[r].t),
            reference_camera: lf.views[r].camera,
            width: lf.width,
            height: lf.height,
            views,
            convention: conv,
            range: (0.1, 1.0),
            range_origin: RangeOrigin::Given,
            planes: 9,
        }
    }

    #[test]
    fn the_wide_range_moves_the_centre_an_eighth_image() {
        let lf = lf(false);
        let plan = calibrated_plan(&lf, ViewSet::All);
        let (lo, hi) = wide_range(&plan);
        assert!(lo > 0.0 && lo < hi);
        // These parallel cameras' sensors are shifted to hold the rig's focus distance (2 m)
        // still: the range reaches an eighth of the image of motion nearer than it, and
        // farther as far as that motion or infinity, whichever comes first.
        let still = 1.0 / RIG.focus_distance;
        assert!((plan.centre_motion(still, hi) - 3.0).abs() < 1e-6, "{hi}");
        let far = plan.centre_motion(lo, still);
        assert!(
            (far - 3.0).abs() < 1e-6 || (lo - 1e-3 * hi).abs() < 1e-12,
            "{lo} {far}"
        );
    }

    /// The sweep plan (the cross) of an `n` × `n` rig of cameras 0.1 m apart, each turned to
    /// the point 2.5 m in front of the rig's centre, with 128² views.
    fn converging_plan(n: usize) -> SweepPlan {
        let rig = crate::synth::SynthRig {
            grid: GridSize { cols: n, rows: n },
            width: 128,
            height: 128,
            focal_px: 128.0,
            baseline: 0.1,
            focus_distance: 2.5,
            kind: crate::synth::RigKind::Converging { distance: 2.5 },
        };
        let lf = LightField {
            name: "converging".into(),
            grid: rig.grid,
            width: 128,
            height: 128,
            views: blank_views(rig.cameras(), n, (128, 128)),
            depth: Vec::new(),
            rig: None,
            disparity_range: None,
            source: Source::Generated {
                scene: "converging".into(),
            },
        };
        calibrated_plan(&lf, ViewSet::Cross(usize::MAX))
    }

    /// Cameras turned to a point 2.5 m away see it still in every view: the wide range is
    /// centred there, and reaches an eighth of the image of motion on both sides of it (a
    /// range anchored at infinity stopped at 1.6 m here and lost everything nearer).
    #[test]
    fn a_converging_rig_searches_around_the_point_it_looks_at() {
        let plan = converging_plan(5);
        let (lo, hi) = wide_range(&plan);
        let still = 1.0 / 2.5;
        assert!(lo < still && still < hi, "{lo} … {hi}");
        assert!((plan.centre_motion(still, hi) - 16.0).abs() < 1e-3, "{hi}");
        // Infinity moves less than 16 px from there: the range goes all the way out.
        assert!(plan.centre_motion(0.0, still) < 16.0);
        assert!((lo - 1e-3 * hi).abs() < 1e-12, "{lo}");
        // The nearest layer of the anti-aliasing set's converging case (1.03 m) is inside.
        assert!(hi > 1.0 / 1.03, "{hi}");
    }

    /// On a 9 × 9 grid of the same spacing the farthest view is four steps away: the range
    /// allows twice the motion there (an eighth of the image per two steps), so it reaches as
    /// near as on 5 × 5 (an eighth in the farthest view had stopped at about half the inverse
    /// depth and cut off the depth set's nearest card).
    #[test]
    fn a_larger_grid_searches_as_near_per_grid_step() {
        let (small, large) = (converging_plan(5), converging_plan(9));
        assert_eq!((small.max_offset(), large.max_offset()), (2.0, 4.0));
        let (hi5, hi9) = (wide_range(&small).1, wide_range(&large).1);
        let still = 1.0 / 2.5;
        assert!(
            (large.centre_motion(still, hi9) - 32.0).abs() < 1e-3,
            "{hi9}"
        );
        // Motion grows nearly linearly with inverse depth: the same reach within 10 %.
        assert!((hi9 / hi5 - 1.0).abs() < 0.1, "{hi5} {hi9}");
        assert!(hi9 > 1.0 / 1.03, "{hi9}");
    }
}
