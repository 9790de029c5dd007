//! Surface normals of a depth view by local PCA (Hoppe et al. 1992), with a depth-discontinuity
//! guard and a planarity confidence.
//!
//! Neighbourhood: the square image-space window of `window × window` pixels centred on the
//! pixel (truncated at the image border). A depth view is an organised point cloud, so its
//! image neighbours are its spatial neighbours on a surface, found by indexing with no search
//! structure; across a depth discontinuity they are not, which the guard handles. (A k-d tree
//! was measured against this window; see docs/stability.md: the window is faster and needs no
//! build step, and a k-nearest query in 3D does not stop at discontinuities either.)
//!
//! Discontinuity guard: inverse depth w = 1/z is affine in the pixel coordinates on any plane,
//! so each neighbour's w is compared with the centre's w (the median of its 3 × 3 neighbourhood
//! brought to the centre along the trend, so one noisy pixel does not decide; where the guard
//! around it keeps too few pixels, moved to the mode of its side of the window by a few median
//! steps within the guard, so a smooth bump of the estimate under the click does not decide
//! either) extrapolated along the window's
//! robust trend (the medians of the per-pixel changes of w in x and y): a neighbour enters the
//! fit
//! only when `|w − (w_c + g_x Δu + g_y Δv)| ≤ τ·w_c`. A window that straddles a depth edge
//! thus uses the centre's side only (pairs across the edge are too few to move the medians),
//! and a steep but smooth surface keeps its whole window. τ = max(`max_depth_jump` (default
//! 2 %), 4·σ̂) with σ̂ the robust relative noise of the window (the median absolute deviation
//! of the per-pixel changes from the trend): on noisy depth a fixed τ would cut into the noise
//! distribution, drop good neighbours and bias the fit. A jump smaller than τ is not seen as an
//! edge. (A second pass that re-selected pixels by their distance to a first fitted plane was
//! measured and removed: it let noisy fits lock onto wrong planes — docs/stability.md.)
//!
//! Fits ([`NormalMethod`]):
//! - **inverse depth** (default): least squares of `1/z = α·Δu + β·Δv + γ` over the neighbours
//!   (Δu, Δv their pixel offsets). A plane is exactly affine in inverse depth, and depth noise
//!   lies along the rays, i.e. in the fitted variable alone, so ordinary least squares is the
//!   right estimator: with `θ = (α, β, γ − α·u_c − β·v_c)` the camera-frame plane is `Kᵀθ·X = 1`
//!   and the normal `−Kᵀθ/|Kᵀθ|` (towards the camera). Its **uncertainty** is the standard
//!   deviation of the normal's direction propagated from the fit's residuals
//!   (`σ² (MᵀM)⁻¹` through the Jacobian of `θ ↦ n`), in degrees; the confidence is
//!   `1 − uncertainty / max_uncertainty_deg`. docs/stability.md measures it 2–13× more
//!   accurate than PCA on noisy depth, and it is what estimated depth needs;
//! - **PCA** (the paper's Hoppe normals): the eigenvectors of the neighbours' covariance,
//!   eigenvalues λ0 ≤ λ1 ≤ λ2; the normal is the eigenvector of λ0, oriented towards the camera
//!   (n·(C − centroid) > 0); the confidence is the planarity.
//!
//! Reported quality (both methods):
//! - `planarity = 1 − λ0/λ1` (1 for a perfect plane, → 0 when depth noise or curvature is as
//!   large as the in-plane spread): the confidence of a click;
//! - `curvature = λ0/(λ0 + λ1 + λ2)` (surface variation, Pauly et al. 2002);
//! - `view_angle_deg`: the angle between the normal and the line of sight.
//!
//! A PCA normal is **reliable** when planarity ≥ 0.9 and the view angle ≤ 80°; an inverse-depth
//! normal when its uncertainty is at most `max_uncertainty_deg` (4°: the angle's p95 is then
//! about 7°) and the view angle ≤ 80°.
//! Why the PCA checks: depth noise
//! lies along the rays; PCA (a total-least-squares fit) tilts the normal towards the line of
//! sight by roughly `(1 − planarity)·sin(2θ)/2` radians (θ the view angle), ≤ 3° at planarity
//! 0.9, and when the noise exceeds the window's lateral extent the smallest-variance direction
//! is no longer the normal at all but lies in the surface — planarity drops and the "normal"
//! turns perpendicular to the line of sight, which the two checks refuse.

use std::fmt;

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use super::depth::{DepthProblem, ViewDepth};

/// Default window (px) of a click's normal on a depth map the light field carries (exact or
/// nearly: HCI ground truth, generated scenes).
pub const GIVEN_DEPTH_WINDOW: u32 = 9;
/// Default window (px) of a click's normal on depth estimated from the views, whose errors are
/// larger and correlated over the estimate's aggregation window (docs/depth.md).
pub const ESTIMATED_DEPTH_WINDOW: u32 = 31;

/// How a normal is fitted (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum NormalMethod {
    /// A plane fitted to the inverse depth (least squares); the default.
    #[default]
    InverseDepth,
    /// Local PCA of the back-projected points (Hoppe 1992).
    Pca,
}

impl std::str::FromStr for NormalMethod {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        match s {
            "inverse-depth" => Ok(Self::InverseDepth),
            "pca" => Ok(Self::Pca),
            _ => Err(crate::Error::Invalid(format!(
                "unknown normal method '{s}': expected inverse-depth or pca"
            ))),
        }
    }
}

/// Parameters of the normal estimation.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct NormalParams {
    /// The fit.
    pub method: NormalMethod,
    /// Side of the square image-space window in pixels (odd, ≥ 3).
    pub window: u32,
    /// Discontinuity guard: the smallest relative jump τ of inverse depth (against the centre's,
    /// extrapolated along the local trend) that leaves a neighbour out; raised to 4× the
    /// window's estimated noise.
    pub max_depth_jump: f64,
    /// Fewest neighbours (centre included) a fit may use, as a fraction of the window's area;
    /// never fewer than 6.
    pub min_fraction: f64,
    /// Smallest planarity `1 − λ0/λ1` of a reliable normal.
    pub min_planarity: f64,
    /// Largest angle (degrees) between a reliable normal and the line of sight to the
    /// neighbourhood. Beyond it the surface is seen edge-on — or, far more often, depth noise
    /// along the rays exceeds the window's lateral extent and PCA returns a direction inside
    /// the surface instead of its normal (docs/stability.md).
    pub max_view_angle_deg: f64,
    /// Largest uncertainty (degrees) of a reliable inverse-depth normal.
    pub max_uncertainty_deg: f64,
}

impl Default for NormalParams {
    /// The inverse-depth fit, window 9, τ = 2 %, at least 20 % of the window, planarity ≥ 0.9
    /// (PCA), uncertainty ≤ 4° (inverse depth), view angle ≤ 80°.
    /// See docs/stability.md
    /// for the measurements behind these values.
    fn default() -> Self {
        NormalParams {
            method: NormalMethod::InverseDepth,
            window: 9,
            max_depth_jump: 0.02,
            min_fraction: 0.2,
            min_planarity: 0.9,
            max_view_angle_deg: 80.0,
            max_uncertainty_deg: 4.0,
        }
    }
}

impl NormalParams {
    /// The same parameters with another fit.
    pub fn with_method(self, method: NormalMethod) -> Self {
        NormalParams { method, ..self }
    }

    /// The same parameters with another window size.
    pub fn with_window(self, window: u32) -> Self {
        NormalParams { window, ..self }
    }

    /// Fewest neighbours a fit may use.
    pub fn required_neighbours(&self) -> usize {
        let area = (self.window as f64).powi(2);
        ((self.min_fraction * area).ceil() as usize).max(6)
    }

    /// Checks the parameters; the message names the offending one.
    pub fn validate(&self) -> crate::Result<()> {
        if self.window < 3 || self.window % 2 == 0 || self.window > 255 {
            return Err(crate::Error::Invalid(format!(
                "the normal window must be an odd number of pixels from 3 to 255, got {}",
                self.window
            )));
        }
        if !(self.max_depth_jump.is_finite() && self.max_depth_jump > 0.0) {
            return Err(crate::Error::Invalid(format!(
                "the depth-jump threshold must be positive, got {}",
                self.max_depth_jump
            )));
        }
        if !(self.max_uncertainty_deg.is_finite() && self.max_uncertainty_deg > 0.0) {
            return Err(crate::Error::Invalid(format!(
                "the largest normal uncertainty must be positive, got {}",
                self.max_uncertainty_deg
            )));
        }
        if !(0.0..=1.0).contains(&self.min_fraction) || !(0.0..=1.0).contains(&self.min_planarity) {
            return Err(crate::Error::Invalid(format!(
                "min_fraction ({}) and min_planarity ({}) must lie in [0, 1]",
                self.min_fraction, self.min_planarity
            )));
        }
        Ok(())
    }
}

/// A fitted normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalEstimate {
    /// The fit that gave `normal`.
    pub method: NormalMethod,
    /// Unit normal in the world frame, facing the camera of the depth view.
    pub normal: DVec3,
    /// Centroid of the neighbours used, world frame.
    pub centroid: DVec3,
    /// `1 − λ0/λ1`, in [0, 1].
    pub planarity: f64,
    /// `λ0/(λ0 + λ1 + λ2)`, in [0, 1/3].
    pub curvature: f64,
    /// Neighbours used by the fit, the centre included.
    pub neighbours: usize,
    /// Valid pixels in the window that the guard left out.
    pub rejected: usize,
    /// Angle between the normal and the line of sight to the centroid, degrees.
    pub view_angle_deg: f64,
    /// Robust estimate σ̂ of the relative depth noise in the window (see the module docs).
    pub noise: f64,
    /// The guard threshold τ used: `max(max_depth_jump, 4·noise)`.
    pub depth_jump: f64,
    /// Standard deviation of the inverse-depth normal's direction from its fit residuals,
    /// degrees (computed for both methods; it decides reliability for the inverse-depth fit).
    pub uncertainty_deg: f64,
    /// In [0, 1]: the planarity (PCA) or `1 − uncertainty / max_uncertainty_deg` (inverse
    /// depth); what a click reports as its confidence.
    pub confidence: f64,
}

impl NormalEstimate {
    /// Whether this estimate is reliable under `params` (planarity and view angle).
    pub fn check(&self, params: &NormalParams) -> Result<(), NormalProblem> {
        if self.method == NormalMethod::InverseDepth {
            // NaN uncertainty is refused too.
            if self.uncertainty_deg.is_nan() || self.uncertainty_deg > params.max_uncertainty_deg {
                return Err(NormalProblem::Uncertain {
                    deg: self.uncertainty_deg,
                    max: params.max_uncertainty_deg,
                });
            }
        } else if self.planarity < params.min_planarity {
            return Err(NormalProblem::LowPlanarity {
                planarity: self.planarity,
                min: params.min_planarity,
            });
        }
        if self.view_angle_deg > params.max_view_angle_deg {
            return Err(NormalProblem::Grazing {
                angle_deg: self.view_angle_deg,
                max: params.max_view_angle_deg,
            });
        }
        Ok(())
    }
}

/// Why no (reliable) normal exists at a pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NormalProblem {
    /// The pixel lies outside the view.
    OutsideView,
    /// The pixel's own depth is invalid.
    InvalidCentre(DepthProblem),
    /// Too few valid neighbours on the pixel's side of any depth discontinuity.
    TooFewNeighbours { found: usize, needed: usize },
    /// The neighbours are (nearly) collinear or coincident: no plane through them.
    Degenerate,
    /// The neighbours are not planar enough for a trustworthy normal.
    LowPlanarity { planarity: f64, min: f64 },
    /// The normal is almost perpendicular to the line of sight.
    Grazing { angle_deg: f64, max: f64 },
    /// The inverse-depth normal's direction is uncertain by more than the limit.
    Uncertain { deg: f64, max: f64 },
}

impl fmt::Display for NormalProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NormalProblem::OutsideView => write!(f, "the pixel lies outside the view"),
            NormalProblem::InvalidCentre(p) => write!(f, "its depth is invalid: {p}"),
            NormalProblem::TooFewNeighbours { found, needed } => write!(
                f,
                "only {found} neighbours with valid depth on the same surface (at least {needed} \
                 needed); it is too close to a depth edge or to invalid depth — click further \
                 inside the surface or use a larger --normal-window"
            ),
            NormalProblem::Degenerate => write!(
                f,
                "its neighbours are collinear or coincident, so they span no plane"
            ),
            NormalProblem::LowPlanarity { planarity, min } => write!(
                f,
                "the surface around it is not planar enough for a reliable normal (planarity \
                 {planarity:.3} < {min}); the depth is too noisy or the surface too curved at \
                 this window size — try a larger --normal-window or three clicks (--points)"
            ),
            NormalProblem::Uncertain { deg, max } => write!(
                f,
                "the depth around it is too noisy for a reliable normal at this window size (its \
                 direction is uncertain by ±{deg:.1}°, more than {max}°); use a larger \
                 --normal-window, click where the surface shows more texture, or use three \
                 clicks spread over the surface (--points)"
            ),
            NormalProblem::Grazing { angle_deg, max } => write!(
                f,
                "the estimated normal is {angle_deg:.1}° from the line of sight (more than \
                 {max}°): either the surface is seen edge-on or the depth noise exceeds the \
                 window's extent, and the normal cannot be trusted — try a larger \
                 --normal-window or three clicks (--points)"
            ),
        }
    }
}

/// Camera-frame plane fit of a set of points.
#[derive(Debug, Clone, Copy)]
struct Fit {
    centroid: DVec3,
    normal: DVec3,
    eigenvalues: [f64; 3],
}

fn fit(points: &[DVec3]) -> Option<Fit> {
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let centroid = points.iter().copied().sum::<DVec3>() / n;
    // Two-pass covariance (centred first): no cancellation at large depths.
    let (mut xx, mut xy, mut xz, mut yy, mut yz, mut zz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for p in points {
        let d = *p - centroid;
        xx += d.x * d.x;
        xy += d.x * d.y;
        xz += d.x * d.z;
        yy += d.y * d.y;
        yz += d.y * d.z;
        zz += d.z * d.z;
    }
    let c = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]].map(|row| row.map(|v| v / n));
    let (values, vectors) = symmetric_eigen3(c);
    let scale = values[2].max(f64::MIN_POSITIVE);
    // Collinear or coincident neighbours: the middle eigenvalue vanishes with the smallest.
    if values[1].is_nan() || values[1] <= 1e-12 * scale || !values.iter().all(|v| v.is_finite()) {
        return None;
    }
    Some(Fit {
        centroid,
        normal: vectors[0],
        eigenvalues: values,
    })
}

/// Eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations: eigenvalues in
/// ascending order and their unit eigenvectors. Jacobi is slower than the closed form but
/// accurate for the nearly-degenerate spectra of planar neighbourhoods (λ0 ≪ λ1).
pub fn symmetric_eigen3(m: [[f64; 3]; 3]) -> ([f64; 3], [DVec3; 3]) {
    let mut a = m;
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-32 * diag || off == 0.0 {
            break;
        }
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← JᵀAJ with the rotation J in the (p, q) plane: columns, then rows.
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
            a[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let col = |i: usize| DVec3::new(v[0][i], v[1][i], v[2][i]).normalize();
    (
        [
            a[order[0]][order[0]],
            a[order[1]][order[1]],
            a[order[2]][order[2]],
        ],
        [col(order[0]), col(order[1]), col(order[2])],
    )
}

/// Reusable buffers for one thread.
#[derive(Default)]
struct Scratch {
    /// Valid window pixels: (camera-frame point, depth, pixel offset from the centre).
    window: Vec<(DVec3, f64, (f64, f64))>,
    chosen: Vec<DVec3>,
    /// (Δu, Δv, 1/z) of the chosen neighbours.
    inverse: Vec<(f64, f64, f64)>,
    dx: Vec<f64>,
    dy: Vec<f64>,
    diffs: Vec<f64>,
}

/// The PCA normal at pixel (x, y) of `depth` with `params`, whatever its planarity; errors
/// when no fit is possible. See the module docs for the guard and the quality values.
pub fn estimate_normal(
    depth: &ViewDepth,
    x: u32,
    y: u32,
    params: &NormalParams,
) -> Result<NormalEstimate, NormalProblem> {
    estimate_with(depth, x, y, params, &mut Scratch::default())
}

/// [`estimate_normal`], and an error when the planarity is below `params.min_planarity`.
pub fn reliable_normal(
    depth: &ViewDepth,
    x: u32,
    y: u32,
    params: &NormalParams,
) -> Result<NormalEstimate, NormalProblem> {
    let e = estimate_normal(depth, x, y, params)?;
    e.check(params)?;
    Ok(e)
}

/// Normals of every pixel, row-major (in parallel over rows).
pub fn estimate_normals(
    depth: &ViewDepth,
    params: &NormalParams,
) -> Vec<Result<NormalEstimate, NormalProblem>> {
    let (w, h) = (depth.width, depth.height);
    (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut scratch = Scratch::default();
            (0..w)
                .map(|x| estimate_with(depth, x, y, params, &mut scratch))
                .collect::<Vec<_>>()
        })
        .collect()
}

fn estimate_with(
    depth: &ViewDepth,
    x: u32,
    y: u32,
    params: &NormalParams,
    s: &mut Scratch,
) -> Result<NormalEstimate, NormalProblem> {
    if x >= depth.width || y >= depth.height {
        return Err(NormalProblem::OutsideView);
    }
    let zc = depth
        .depth_checked(x, y)
        .map_err(NormalProblem::InvalidCentre)?;
    let needed = params.required_neighbours();
    let r = params.window / 2;
    let (x0, x1) = (x.saturating_sub(r), (x + r).min(depth.width - 1));
    let (y0, y1) = (y.saturating_sub(r), (y + r).min(depth.height - 1));
    s.window.clear();
    for j in y0..=y1 {
        for i in x0..=x1 {
            if let Some(p) = depth.point_camera(i, j) {
                let offset = (i as f64 - x as f64, j as f64 - y as f64);
                s.window.push((p, p.z, offset));
            }
        }
    }
    let local = local_trend(depth, (x0, x1), (y0, y1), zc, s);
    let tau = params.max_depth_jump.max(NOISE_TO_GUARD * local.noise);

    // The guard: only neighbours whose inverse depth lies near the centre's, extrapolated
    // along the robust local trend (exactly affine in the pixel coordinates on a plane). The
    // centre's inverse depth is the median of its 3 × 3 neighbourhood brought to the centre
    // along the trend (on a plane exactly its own): on estimated depth the clicked pixel alone
    // can sit 0.05 px of disparity off its wall, and a guard around that one value kept 55 of
    // the window's 961 pixels and refused the click.
    s.diffs.clear();
    for j in y.saturating_sub(1)..=(y + 1).min(depth.height - 1) {
        for i in x.saturating_sub(1)..=(x + 1).min(depth.width - 1) {
            if let Some(z) = depth.depth(i, j) {
                let (du, dv) = (i as f64 - x as f64, j as f64 - y as f64);
                s.diffs.push(1.0 / z - local.gx * du - local.gy * dv);
            }
        }
    }
    let mut wc = median(&mut s.diffs);
    let select = |wc: f64, s: &mut Scratch| {
        s.chosen.clear();
        s.inverse.clear();
        for (p, z, (du, dv)) in &s.window {
            let predicted = wc + local.gx * du + local.gy * dv;
            if (1.0 / z - predicted).abs() <= tau * wc {
                s.chosen.push(*p);
                s.inverse.push((*du, *dv, 1.0 / z));
            }
        }
    };
    select(wc, s);
    // The centre's 3 × 3 can itself sit on a patch where the estimate is a little off its
    // surface: a depth map refined with a smoothness prior (docs/depth.md, step 7b) has
    // little pixel noise left, so τ is tight, but can stay a few hundredths of a pixel off
    // over a patch, and on `demo`'s wall a guard around the click's patch kept 96 of 961
    // pixels (853 before the refinement). Where the guard keeps too few, its centre climbs
    // to the mode of its own side and the guard is applied again: a few steps of moving it
    // to the median residual of the pixels within the guard (a mean shift with the guard as
    // its window). The other side of a depth edge lies beyond the guard and never enters it
    // (a band three guards wide, tried first, let a 5 % step's far side pull the centre
    // over). Only then: on every pixel (`cloud`'s normals) the steps took a third more time.
    if s.chosen.len() < needed {
        for _ in 0..RECENTRE_STEPS {
            s.diffs.clear();
            for (_, z, (du, dv)) in &s.window {
                let r = 1.0 / z - (wc + local.gx * du + local.gy * dv);
                if r.abs() <= tau * wc {
                    s.diffs.push(r);
                }
            }
            let shift = median(&mut s.diffs);
            wc += shift;
            if shift.abs() <= 0.05 * tau * wc {
                break;
            }
        }
        select(wc, s);
    }
    if s.chosen.len() < needed {
        return Err(NormalProblem::TooFewNeighbours {
            found: s.chosen.len(),
            needed,
        });
    }
    let f = fit(&s.chosen).ok_or(NormalProblem::Degenerate)?;
    let inv = inverse_fit(&s.inverse, (x as f64, y as f64), depth.camera.k)
        .ok_or(NormalProblem::Degenerate)?;
    let mut e = finish(depth, f, s.chosen.len(), s.window.len());
    e.noise = local.noise;
    e.depth_jump = tau;
    e.uncertainty_deg = inv.1.to_degrees();
    e.method = params.method;
    match params.method {
        NormalMethod::Pca => e.confidence = e.planarity,
        NormalMethod::InverseDepth => {
            let n = inv.0;
            let to_eye = -f.centroid.normalize_or_zero();
            e.view_angle_deg = n.dot(to_eye).clamp(-1.0, 1.0).acos().to_degrees();
            e.normal = (depth.camera.r.transpose() * n).normalize();
            e.confidence = (1.0 - e.uncertainty_deg / params.max_uncertainty_deg).clamp(0.0, 1.0);
        }
    }
    Ok(e)
}

/// Least-squares plane of inverse depth `w = α·Δu + β·Δv + γ` over `samples` (Δu, Δv, w)
/// around pixel `centre` of a camera with intrinsics `k`: the camera-frame unit normal facing
/// the camera and the standard deviation of its direction (radians). `None` when the samples
/// span no plane.
fn inverse_fit(samples: &[(f64, f64, f64)], centre: (f64, f64), k: DMat3) -> Option<(DVec3, f64)> {
    if samples.len() < 3 {
        return None;
    }
    let (mut m, mut rhs) = (DMat3::ZERO, DVec3::ZERO);
    for &(du, dv, w) in samples {
        let row = DVec3::new(du, dv, 1.0);
        m += DMat3::from_cols(row * row.x, row * row.y, row * row.z);
        rhs += row * w;
    }
    let scale = m.to_cols_array().iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if m.determinant().abs() <= 1e-12 * scale.powi(3) {
        return None;
    }
    let m_inv = m.inverse();
    let local = m_inv * rhs;
    let rss: f64 = samples
        .iter()
        .map(|&(du, dv, w)| (w - local.dot(DVec3::new(du, dv, 1.0))).powi(2))
        .sum();
    let dof = samples.len().saturating_sub(3).max(1) as f64;
    let cov_local = m_inv * (rss / dof);
    // θ in absolute pixel coordinates, and the camera-frame plane Kᵀθ·X = 1.
    let t = DMat3::from_cols(
        DVec3::new(1.0, 0.0, -centre.0),
        DVec3::new(0.0, 1.0, -centre.1),
        DVec3::Z,
    );
    let theta = t * local;
    let g = k.transpose() * theta;
    let len = g.length();
    if !(len.is_finite() && len > 0.0) {
        return None;
    }
    let n = -g / len;
    // d n / d θ = −(I − n nᵀ) Kᵀ / |g|; the sign does not matter for the covariance.
    let proj = DMat3::IDENTITY - DMat3::from_cols(n * n.x, n * n.y, n * n.z);
    let j = proj * k.transpose() / len;
    let cov_n = j * t * cov_local * t.transpose() * j.transpose();
    let var = cov_n.x_axis.x + cov_n.y_axis.y + cov_n.z_axis.z;
    Some((n, var.max(0.0).sqrt()))
}

/// The guard's threshold is at least this many noise standard deviations.
const NOISE_TO_GUARD: f64 = 4.0;

/// At most this many steps move the guard's centre to the median residual of the pixels
/// within the guard (see `estimate_with`).
const RECENTRE_STEPS: usize = 8;

/// The robust local behaviour of inverse depth w = 1/z in a window.
struct LocalTrend {
    /// Median change of w per pixel in x and in y.
    gx: f64,
    gy: f64,
    /// Relative noise σ̂: the median absolute deviation of the per-pixel changes from (gx, gy),
    /// × 1.4826 (a Gaussian's MAD → σ), / √2 (a difference of two samples), / w_centre.
    noise: f64,
}

/// Inverse-depth trend and noise from the 4-adjacent valid pairs of the window. Pairs across a
/// depth edge are few (one row or column of the window), so the medians ignore them. Zero
/// trend and noise when the window has no adjacent valid pair.
fn local_trend(
    depth: &ViewDepth,
    (x0, x1): (u32, u32),
    (y0, y1): (u32, u32),
    zc: f64,
    s: &mut Scratch,
) -> LocalTrend {
    s.dx.clear();
    s.dy.clear();
    for j in y0..=y1 {
        for i in x0..=x1 {
            let Some(z) = depth.depth(i, j) else { continue };
            if i < x1 {
                if let Some(zn) = depth.depth(i + 1, j) {
                    s.dx.push(1.0 / zn - 1.0 / z);
                }
            }
            if j < y1 {
                if let Some(zn) = depth.depth(i, j + 1) {
                    s.dy.push(1.0 / zn - 1.0 / z);
                }
            }
        }
    }
    let gx = median(&mut s.dx);
    let gy = median(&mut s.dy);
    s.diffs.clear();
    s.diffs.extend(s.dx.iter().map(|d| (d - gx).abs()));
    s.diffs.extend(s.dy.iter().map(|d| (d - gy).abs()));
    let mad = median(&mut s.diffs);
    LocalTrend {
        gx,
        gy,
        noise: 1.4826 * mad / std::f64::consts::SQRT_2 * zc,
    }
}

/// Median of `v` (reordered), 0 for an empty slice.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

fn finish(depth: &ViewDepth, f: Fit, used: usize, valid: usize) -> NormalEstimate {
    let mut n = f.normal;
    // Towards the camera: the camera centre is the origin of the camera frame.
    if n.dot(f.centroid) > 0.0 {
        n = -n;
    }
    let [l0, l1, l2] = f.eigenvalues;
    let l0 = l0.max(0.0);
    let rt: DMat3 = depth.camera.r.transpose();
    let to_eye = -f.centroid.normalize_or_zero();
    NormalEstimate {
        method: NormalMethod::Pca,
        view_angle_deg: n.dot(to_eye).clamp(-1.0, 1.0).acos().to_degrees(),
        noise: 0.0,
        depth_jump: 0.0,
        uncertainty_deg: 0.0,
        confidence: 0.0,
        normal: (rt * n).normalize(),
        centroid: depth.camera.to_world(f.centroid),
        planarity: (1.0 - l0 / l1).clamp(0.0, 1.0),
        curvature: (l0 / (l0 + l1 + l2)).clamp(0.0, 1.0),
        neighbours: used,
        rejected: valid - used,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::{intrinsics, Camera};
    use crate::lightfield::{DepthKind, DepthMap};

    fn camera() -> Camera {
        Camera::from_centre(
            intrinsics(60.0, 60.0, 15.5, 15.5),
            DMat3::IDENTITY,
            DVec3::ZERO,
        )
    }

    /// Depth of plane n·X = d seen by `camera()` (32×32), NaN where behind.
    fn plane_depth(n: DVec3, d: f64) -> ViewDepth {
        let cam = camera();
        let k_inv = cam.k.inverse();
        let mut values = Vec::new();
        for y in 0..32 {
            for x in 0..32 {
                let ray = k_inv * DVec3::new(x as f64, y as f64, 1.0);
                let z = d / n.dot(ray);
                values.push(if z > 0.0 { z as f32 } else { f32::NAN });
            }
        }
        let map = DepthMap {
            width: 32,
            height: 32,
            kind: DepthKind::Depth,
            values,
            source: "plane".into(),
            estimated: false,
        };
        ViewDepth::new(cam, &map, None, None, 0).unwrap()
    }

    fn angle_deg(a: DVec3, b: DVec3) -> f64 {
        a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
    }

    #[test]
    fn jacobi_diagonalises_symmetric_matrices() {
        let m = [[4.0, 1.0, -2.0], [1.0, 2.0, 0.5], [-2.0, 0.5, 3.0]];
        let (vals, vecs) = symmetric_eigen3(m);
        assert!(vals[0] <= vals[1] && vals[1] <= vals[2]);
        let mm = DMat3::from_cols_array_2d(&m);
        for k in 0..3 {
            assert!((mm * vecs[k] - vecs[k] * vals[k]).length() < 1e-12);
            assert!((vecs[k].length() - 1.0).abs() < 1e-12);
        }
        assert!((vals.iter().sum::<f64>() - 9.0).abs() < 1e-12);
        // Already diagonal, and repeated eigenvalues.
        let (vals, _) = symmetric_eigen3([[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        assert_eq!(vals, [1.0, 1.0, 2.0]);
    }

    #[test]
    fn exact_planes_give_exact_camera_facing_normals() {
        for n in [
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(0.3, -0.5, -1.0).normalize(),
            DVec3::new(-0.7, 0.2, -0.6).normalize(),
        ] {
            let depth = plane_depth(n, -2.0);
            for (x, y) in [(16, 16), (3, 28), (0, 0), (31, 31)] {
                let e = reliable_normal(&depth, x, y, &NormalParams::default()).unwrap();
                assert!(
                    angle_deg(e.normal, n) < 1e-3,
                    "{n} at ({x},{y}): {}",
                    e.normal
                );
                assert!(e.planarity > 1.0 - 1e-9 && e.curvature < 1e-9);
                assert_eq!(e.rejected, 0, "a plane has no depth jump");
                assert!(e.noise < 1e-6, "{}", e.noise);
            }
        }
    }

    /// The clicked pixel alone off its plane (estimated depth's noise at one pixel, beyond the
    /// guard's 2 %): the guard centres on its neighbourhood, keeps the window and finds the
    /// plane; around the outlier's own value it kept only the pixels that happened to match.
    #[test]
    fn one_outlying_centre_pixel_does_not_empty_the_window() {
        let n = DVec3::new(0.2, -0.1, -1.0).normalize();
        let clean = plane_depth(n, -2.0);
        let mut values: Vec<f32> = (0..32 * 32)
            .map(|i| clean.depth(i % 32, i / 32).unwrap() as f32)
            .collect();
        values[16 * 32 + 16] *= 1.05;
        let map = DepthMap {
            width: 32,
            height: 32,
            kind: DepthKind::Depth,
            values,
            source: "outlier".into(),
            estimated: false,
        };
        let depth = ViewDepth::new(camera(), &map, None, None, 0).unwrap();
        let e = reliable_normal(&depth, 16, 16, &NormalParams::default()).unwrap();
        assert!(angle_deg(e.normal, n) < 0.5, "{}", e.normal);
        // Every pixel of the window but the outlier itself is on the plane.
        assert_eq!(e.rejected, 1);
    }

    /// A smooth bump under the click, 5 % off its plane at its top (σ = 3 px; a refined
    /// estimate's error, beyond the guard's 2 %): the guard around the top keeps too few of
    /// the window's pixels, so its centre climbs down to the plane around it, which it then
    /// finds, leaving out the bump's top alone. (A patch off its plane by a 5 % *step* is a
    /// depth edge, and its surface is the patch: `the_guard_keeps_a_depth_edge_…`.)
    #[test]
    fn a_bump_under_the_click_does_not_empty_the_window() {
        let n = DVec3::new(0.2, -0.1, -1.0).normalize();
        let clean = plane_depth(n, -2.0);
        let values: Vec<f32> = (0..32 * 32)
            .map(|i| {
                let (x, y) = ((i % 32) as f64 - 16.0, (i / 32) as f64 - 16.0);
                let bump = 1.0 + 0.05 * (-(x * x + y * y) / 18.0).exp();
                (clean.depth(i % 32, i / 32).unwrap() * bump) as f32
            })
            .collect();
        let map = DepthMap {
            width: 32,
            height: 32,
            kind: DepthKind::Depth,
            values,
            source: "bump".into(),
            estimated: false,
        };
        let depth = ViewDepth::new(camera(), &map, None, None, 0).unwrap();
        let params = NormalParams::default().with_window(31);
        let e = reliable_normal(&depth, 16, 16, &params).unwrap();
        assert!(angle_deg(e.normal, n) < 1.0, "{}", e.normal);
        // Off the plane by over 2 %: the pixels within 4.1 px of the top (53).
        assert!((40..=70).contains(&e.rejected), "{}", e.rejected);
    }

    #[test]
    fn the_guard_keeps_a_depth_edge_from_mixing_surfaces() {
        // Left half at z = 2 (frontoparallel), right half on a plane at z ≈ 3 slanted by 30°.
        let near = plane_depth(DVec3::new(0.0, 0.0, -1.0), -2.0);
        let slanted_n = DVec3::new(30f64.to_radians().sin(), 0.0, -30f64.to_radians().cos());
        let far = plane_depth(slanted_n, slanted_n.dot(DVec3::new(0.0, 0.0, 3.0)));
        let mut values = Vec::new();
        for y in 0..32u32 {
            for x in 0..32u32 {
                let z = if x < 16 {
                    near.depth(x, y)
                } else {
                    far.depth(x, y)
                };
                values.push(z.unwrap() as f32);
            }
        }
        let map = DepthMap {
            width: 32,
            height: 32,
            kind: DepthKind::Depth,
            values,
            source: "edge".into(),
            estimated: false,
        };
        let depth = ViewDepth::new(camera(), &map, None, None, 0).unwrap();
        let params = NormalParams::default();
        for x in [13, 15] {
            let e = reliable_normal(&depth, x, 16, &params).unwrap();
            assert!(
                angle_deg(e.normal, -DVec3::Z) < 1e-3,
                "x = {x}: {}",
                e.normal
            );
            assert!(e.rejected > 0);
        }
        for x in [16, 18] {
            let e = reliable_normal(&depth, x, 16, &params).unwrap();
            assert!(
                angle_deg(e.normal, slanted_n) < 1e-3,
                "x = {x}: {}",
                e.normal
            );
        }
        // Without the guard the edge pixel's normal mixes both planes.
        let open = NormalParams {
            max_depth_jump: 10.0,
            ..params
        };
        let e = estimate_normal(&depth, 15, 16, &open).unwrap();
        assert!(angle_deg(e.normal, -DVec3::Z) > 5.0);
    }

    #[test]
    fn refusals_say_why() {
        let n = DVec3::new(0.0, 0.0, -1.0);
        let mut depth = plane_depth(n, -2.0);
        let params = NormalParams::default();
        assert_eq!(
            estimate_normal(&depth, 40, 0, &params),
            Err(NormalProblem::OutsideView)
        );
        // Invalidate everything but a thin line: centre valid, too few neighbours.
        let mut values = vec![f32::NAN; 32 * 32];
        for x in 0..32 {
            values[16 * 32 + x] = 2.0;
        }
        let map = DepthMap {
            width: 32,
            height: 32,
            kind: DepthKind::Depth,
            values,
            source: "line".into(),
            estimated: false,
        };
        depth = ViewDepth::new(camera(), &map, None, None, 0).unwrap();
        assert!(matches!(
            estimate_normal(&depth, 16, 15, &params),
            Err(NormalProblem::InvalidCentre(DepthProblem::NoValue))
        ));
        assert!(matches!(
            estimate_normal(&depth, 16, 16, &params),
            Err(NormalProblem::TooFewNeighbours { found: 9, .. })
        ));
        // Enough points but all on one line: degenerate.
        let line = NormalParams {
            min_fraction: 0.0,
            ..params
        };
        assert_eq!(
            estimate_normal(&depth, 16, 16, &line),
            Err(NormalProblem::Degenerate)
        );
        for p in [
            NormalProblem::Degenerate,
            NormalProblem::LowPlanarity {
                planarity: 0.1,
                min: 0.5,
            },
            NormalProblem::TooFewNeighbours {
                found: 1,
                needed: 6,
            },
        ] {
            assert!(p.to_string().len() > 20);
        }
    }

    #[test]
    fn whole_image_normals_match_single_pixel_ones() {
        let n = DVec3::new(0.2, 0.3, -1.0).normalize();
        let depth = plane_depth(n, -2.5);
        let params = NormalParams::default().with_window(5);
        let all = estimate_normals(&depth, &params);
        assert_eq!(all.len(), 32 * 32);
        for (x, y) in [(0, 0), (7, 21), (31, 5)] {
            assert_eq!(
                all[depth.index(x, y)],
                estimate_normal(&depth, x, y, &params)
            );
        }
    }

    #[test]
    fn parameters_are_checked() {
        assert!(NormalParams::default().validate().is_ok());
        for p in [
            NormalParams::default().with_window(4),
            NormalParams::default().with_window(1),
            NormalParams {
                max_depth_jump: f64::NAN,
                ..Default::default()
            },
            NormalParams {
                min_planarity: 2.0,
                ..Default::default()
            },
        ] {
            assert!(p.validate().is_err(), "{p:?}");
        }
        assert_eq!(NormalParams::default().required_neighbours(), 17);
        assert_eq!(
            NormalParams::default().with_window(3).required_neighbours(),
            6
        );
    }
}
