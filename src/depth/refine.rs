//! Continuous refinement of the sweep's winner on many views (CPU, f64 sums over f32 pixels).
//!
//! The sweep chooses among discrete planes and refines the winner by a parabola through three
//! aggregated costs. On smooth, slanted or curved surfaces that leaves a staircase of
//! frontoparallel steps, and under sensor noise the parabola follows the noise. The refinement
//! here is a Gauss–Newton (Lucas–Kanade) fit of the sweep parameter p itself, per pixel: the
//! photometric residuals `r = I_v(y_v(x', p)) − I_r(x')` of every refinement view v over a small
//! window x' around the pixel, linearised in p through the view's image gradient and the
//! derivative of its sample position, minimised in least squares. The fit is continuous (no
//! planes), uses every view (its precision grows with their number, where the sweep matches a
//! cross for speed), and is statistically the right estimator under Gaussian noise.
//!
//! - Window weights follow the reference's colours (a bilateral weight around the centre
//!   pixel), so the window does not reach across a colour edge into another surface.
//! - Occlusion: at each step the views whose windowed residual is more than
//!   [`OCCLUDED_RATIO`] times that of the view 30 % of the way up ([`OCCLUSION_QUANTILE`])
//!   are left out of that step (an occluder hides the pixel from the views on one side).
//! - The fitted model is affine: p and its slopes across the window (a slanted or curved
//!   surface is not a staircase of frontoparallel windows); a weak prior keeps the slopes
//!   near 0 where the window cannot tell them.
//! - Each step is clamped to one plane of the sweep and the result to [`MAX_PLANES_AWAY`]
//!   planes of the winner; where the window has no gradient (no texture) p stays the winner.
//! - Noisy views are smoothed once before the fit (by the driver, [`crate::jobs::depth`]):
//!   bilinear interpolation averages the noise of neighbouring texels, so a noisy view
//!   sampled between texels looks less noisy than one sampled on them and every cost, L1 or
//!   L2, leans towards half-pixel shifts; smoothing first correlates the noise and removes
//!   that bias. Clean views are fitted as they are (smoothing costs fine texture).

use glam::DVec2;
use image::RgbaImage;
use rayon::prelude::*;

use super::sweep::SweepPlan;

/// Views whose windowed residual exceeds this multiple of the [`OCCLUSION_QUANTILE`] view's are
/// treated as occluded in a step.
pub const OCCLUDED_RATIO: f64 = 2.5;
/// Which view's residual the occlusion test measures against, as a quantile of the views':
/// 30 % of the way up, not the median. Next to a nearer surface more than half the views
/// can be occluded (the wall between a panel and a card 3 px per grid step nearer: the outer
/// views of a 5 × 5 grid see the panel), and against the median the occluded views set the
/// scale and stay in. Measured on the test set with backgammon and `layers`: the mean BadPix
/// 0.07 9.14 → 8.69 % (layers 6.1 → 3.1, backgammon 2.14 → 1.71, thin 11.6 → 9.6, wide 10.8 →
/// 9.1; sphere 5.5 → 6.5, bust 12.4 → 13.3); a quarter 8.78 %, 40 % 8.83 %, a tenth 9.42 %
/// (the bust 21 %: too few views left to fit a weak texture).
pub const OCCLUSION_QUANTILE: f64 = 0.3;
/// The refined p stays within this many plane steps of the sweep's winner.
pub const MAX_PLANES_AWAY: f64 = 1.5;

/// Settings of the refinement.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RefineParams {
    /// Gauss–Newton steps per pixel.
    pub iterations: u32,
    /// Window radius (a (2r + 1)² window).
    pub radius: u32,
    /// Colour distance (encoded, per channel RMS) at which a window pixel's weight is e^(−½).
    pub colour_sigma: f64,
    /// Weight of the prior that keeps the fitted slopes near 0, relative to the data's.
    pub slope_prior: f64,
    /// A pixel whose 8 neighbours' start values differ from its own by more than this many
    /// planes keeps its start value (0: fit everywhere). There the window spans two surfaces
    /// and half the views see the other one: the fit pulled bars and column edges onto their
    /// background (measured on the test set: `thin` 15.4 → 12.1 % BadPix 0.07, backgammon's
    /// wedge edges 2.8 → 2.2 %; the mean MSE rises 8.3 → 8.5, from `cylinder`). Two planes
    /// left a ring-textured plane striped between winners two planes apart.
    pub edge_planes: f64,
    /// A prior holds p near its start (the sweep's winner after the median) with a standard
    /// deviation of this many planes, against residuals of [`FIT_NOISE`] (0: no prior). On a
    /// weakly textured surface a 3 × 3 window has little gradient and its step follows noise,
    /// where the sweep's winner came from a guided 11 × 11 window: the prior weighs the two by
    /// their precisions. Measured on the test set: 0.15 planes lowers the mean BadPix 0.07
    /// 9.81 → 9.19 % (plenoptic 25.9 → 21.7, cylinder's floor 10.7 → 10.1); 0.05 lets the
    /// staircase of the planes back (bust 21 %).
    pub start_planes: f64,
}

/// The residual noise the [`RefineParams::start_planes`] prior is weighed against: 2 levels of
/// an 8-bit encoding, per channel.
pub const FIT_NOISE: f64 = 2.0 / 255.0;

impl Default for RefineParams {
    fn default() -> Self {
        RefineParams {
            // One Gauss–Newton step from the sweep's winner: measured on the test set, a second
            // step (and a check that the step lowered the residual) changed BadPix by less than
            // 0.1 % and doubled the time.
            iterations: 1,
            // 3 × 3: as accurate on the test set as 5 × 5, at a third of the time.
            radius: 1,
            colour_sigma: 0.04,
            slope_prior: 0.01,
            edge_planes: 3.0,
            start_planes: 0.15,
        }
    }
}

/// An image as f32 planar-free RGB rows, encoded values in [0, 1].
pub(super) struct Rgb32 {
    pub(super) w: usize,
    pub(super) h: usize,
    px: Vec<[f32; 3]>,
}

impl Rgb32 {
    pub(super) fn new(img: &RgbaImage) -> Self {
        Rgb32 {
            w: img.width() as usize,
            h: img.height() as usize,
            px: img
                .pixels()
                .map(|p| {
                    [
                        p.0[0] as f32 / 255.0,
                        p.0[1] as f32 / 255.0,
                        p.0[2] as f32 / 255.0,
                    ]
                })
                .collect(),
        }
    }

    pub(super) fn at(&self, x: usize, y: usize) -> [f32; 3] {
        self.px[y * self.w + x]
    }

    /// Bilinear sample (clamp to edge) and its gradient ∂/∂x, ∂/∂y at pixel position (x, y),
    /// for `x, y > −1` (the fit only samples inside the image's half-pixel border).
    #[inline]
    pub(super) fn sample(&self, x: f64, y: f64) -> Sample {
        // Truncation is the floor above −1; `f64::floor` is a library call on the baseline
        // x86-64 target and was a tenth of the fit's time.
        let (i, j) = ((x + 1.0) as i64 - 1, (y + 1.0) as i64 - 1);
        let (fx, fy) = ((x - i as f64) as f32, (y - j as f64) as f32);
        let (wm, hm) = (self.w as i64 - 1, self.h as i64 - 1);
        let (p00, p10, p01, p11) = if i >= 0 && j >= 0 && i < wm && j < hm {
            // Inside: the four texels without clamping.
            let k = j as usize * self.w + i as usize;
            (
                self.px[k],
                self.px[k + 1],
                self.px[k + self.w],
                self.px[k + self.w + 1],
            )
        } else {
            let t = |a: i64, b: i64| self.at(a.clamp(0, wm) as usize, b.clamp(0, hm) as usize);
            (t(i, j), t(i + 1, j), t(i, j + 1), t(i + 1, j + 1))
        };
        let mut v = [0.0; 3];
        let mut gx = [0.0; 3];
        let mut gy = [0.0; 3];
        for c in 0..3 {
            let (a, b, d, e) = (p00[c], p10[c], p01[c], p11[c]);
            let top = a + (b - a) * fx;
            let bottom = d + (e - d) * fx;
            v[c] = top + (bottom - top) * fy;
            gx[c] = (1.0 - fy) * (b - a) + fy * (e - d);
            gy[c] = bottom - top;
        }
        (v, gx, gy)
    }
}

/// A bilinear sample: value, ∂/∂x, ∂/∂y per channel.
pub(super) type Sample = ([f32; 3], [f32; 3], [f32; 3]);

impl Rgb32 {
    /// The `n × n` bilinear samples (with gradients) at `(x0 + u, y0 + v)`, u, v < n, row by row
    /// into `out`, or `false` when the block does not lie inside the image (then nothing is
    /// written). One position's fractions serve the whole block and each texel row is
    /// interpolated once: the samples of a translated window at a fraction of [`Rgb32::sample`]'s
    /// cost each, with the same values.
    fn block(&self, x0: f64, y0: f64, n: usize, out: &mut [Sample]) -> bool {
        if !(x0 >= 0.0 && y0 >= 0.0) {
            return false;
        }
        let (i0, j0) = (x0 as usize, y0 as usize);
        if i0 + n >= self.w || j0 + n >= self.h || out.len() < n * n {
            return false;
        }
        let (fx, fy) = ((x0 - i0 as f64) as f32, (y0 - j0 as f64) as f32);
        // Texel row j's horizontal interpolation and difference at the block's n columns.
        let row = |j: usize, u: usize| -> ([f32; 3], [f32; 3]) {
            let k = (j0 + j) * self.w + i0 + u;
            let (a, b) = (self.px[k], self.px[k + 1]);
            (
                std::array::from_fn(|c| a[c] + (b[c] - a[c]) * fx),
                std::array::from_fn(|c| b[c] - a[c]),
            )
        };
        for u in 0..n {
            let mut upper = row(0, u);
            for v in 0..n {
                let lower = row(v + 1, u);
                let (top, dtop) = upper;
                let (bottom, dbottom) = lower;
                out[v * n + u] = (
                    std::array::from_fn(|c| top[c] + (bottom[c] - top[c]) * fy),
                    std::array::from_fn(|c| (1.0 - fy) * dtop[c] + fy * dbottom[c]),
                    std::array::from_fn(|c| bottom[c] - top[c]),
                );
                upper = lower;
            }
        }
        true
    }
}

/// One view's sums over a window: the weighted squared residual, the normal equations of
/// (p, ∂p/∂x, ∂p/∂y) (gradient and the upper triangle of the Hessian) and the pixels used.
#[derive(Default)]
struct Sums {
    e: f64,
    g: [f64; 3],
    hh: [f64; 6],
    n: usize,
}

impl Sums {
    /// Adds window pixel (dx, dy) of colour `c` and weight `wt`, sampled as `sample` in a view
    /// whose sample position moves by `dq` per unit of p. The channels' sums first (f32: three
    /// terms of encoded values), then the window position's basis once: the normal equations
    /// take each sum times 1, dx, dy and their products.
    #[inline]
    fn add(&mut self, (s, gx, gy): Sample, dq: (f32, f32), c: [f32; 3], wt: f64, dx: f64, dy: f64) {
        let (mut rr, mut jr, mut jj) = (0f32, 0f32, 0f32);
        for ch in 0..3 {
            let res = s[ch] - c[ch];
            let jac = gx[ch] * dq.0 + gy[ch] * dq.1;
            rr += res * res;
            jr += jac * res;
            jj += jac * jac;
        }
        self.e += wt * rr as f64;
        let (wj, wjj) = (wt * jr as f64, wt * jj as f64);
        self.g[0] += wj;
        self.g[1] += wj * dx;
        self.g[2] += wj * dy;
        self.hh[0] += wjj;
        self.hh[1] += wjj * dx;
        self.hh[2] += wjj * dy;
        self.hh[3] += wjj * dx * dx;
        self.hh[4] += wjj * dx * dy;
        self.hh[5] += wjj * dy * dy;
        self.n += 1;
    }
}

/// Whether a finite start value of one of the 8 neighbours of `(x, y)` differs from `p0` by
/// more than `reach`.
fn at_depth_edge(
    param: &[f32],
    (w, h): (usize, usize),
    (x, y): (usize, usize),
    p0: f64,
    reach: f64,
) -> bool {
    (-1i64..=1).any(|dy| {
        (-1i64..=1).any(|dx| {
            let (xx, yy) = (x as i64 + dx, y as i64 + dy);
            if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                return false;
            }
            let q = param[yy as usize * w + xx as usize] as f64;
            q.is_finite() && (q - p0).abs() > reach
        })
    })
}

/// What every pixel's fit shares: the images, the plan's views and the settings in the units
/// the fit works in.
struct FitSetup<'a> {
    plan: &'a SweepPlan,
    reference: Rgb32,
    views: Vec<Rgb32>,
    view_weights: &'a [f64],
    /// Per view: the warp is a translation (a window samples as one texel block).
    translation: Vec<bool>,
    /// Plane spacing of the sweep parameter.
    step: f64,
    /// Window radius.
    r: i64,
    inv_two_sigma2: f64,
    /// Depth-edge reach (p units); 0: none.
    edge_reach: f64,
    /// The prior's weight on p's start in the normal equations: (noise / prior deviation)².
    start_prior: f64,
    slope_prior: f64,
    iterations: u32,
}

/// One pixel's colour-weighted window: position, reference colour and weight per pixel.
type Window = Vec<(f64, f64, [f32; 3], f64)>;

/// Per-view sums of one evaluation and the buffers of a row of pixels, kept across its pixels.
struct ViewSums {
    /// Per view: the windowed residual, and the normal equations of (p, ∂p/∂x, ∂p/∂y).
    residual: Vec<f64>,
    grad: Vec<[f64; 3]>,
    hess: Vec<[f64; 6]>,
    used: Vec<bool>,
    /// The views not treated as occluded.
    keep: Vec<bool>,
    scratch: Vec<f64>,
    block: Vec<Sample>,
    window: Window,
}

impl ViewSums {
    fn new(n_views: usize, r: i64) -> Self {
        let side = 2 * r as usize + 1;
        ViewSums {
            residual: vec![0.0; n_views],
            grad: vec![[0.0; 3]; n_views],
            hess: vec![[0.0; 6]; n_views],
            used: vec![false; n_views],
            keep: vec![false; n_views],
            scratch: Vec::with_capacity(n_views),
            block: vec![Default::default(); side * side],
            window: Vec::with_capacity(side * side),
        }
    }
}

impl FitSetup<'_> {
    /// The window around `(x, y)` and its colour weights into `window`.
    fn colour_window(&self, (x, y): (usize, usize), window: &mut Window) {
        let (w, h) = (self.reference.w, self.reference.h);
        let r = self.r;
        let centre = self.reference.at(x, y);
        window.clear();
        for dy in -r..=r {
            for dx in -r..=r {
                let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                    continue;
                }
                let c = self.reference.at(xx as usize, yy as usize);
                let d2 = (0..3).map(|k| (c[k] - centre[k]).powi(2)).sum::<f32>() as f64 / 3.0;
                window.push((xx as f64, yy as f64, c, (-d2 * self.inv_two_sigma2).exp()));
            }
        }
    }

    /// Every view's windowed residual and normal equations at the affine model `theta`
    /// (p, ∂p/∂x, ∂p/∂y) around `(cx, cy)`, into `s`.
    fn evaluate(&self, (cx, cy): (f64, f64), theta: [f64; 3], s: &mut ViewSums) {
        let r = self.r;
        let side = 2 * r as usize + 1;
        let (wf, hf) = (self.reference.w as f64 - 0.5, self.reference.h as f64 - 0.5);
        for (k, (v, img)) in self.plan.views.iter().zip(&self.views).enumerate() {
            let mut sums = Sums::default();
            // A translated view with a frontoparallel window (every first step) samples
            // a whole texel block at one fraction.
            let whole_block = self.translation[k]
                && theta[1] == 0.0
                && theta[2] == 0.0
                && s.window.len() == side * side
                && {
                    let o = v.sample(DVec2::new(cx - r as f64, cy - r as f64), theta[0]);
                    img.block(o.x / o.z, o.y / o.z, side, &mut s.block)
                };
            if whole_block {
                let dq = (v.b.x as f32, v.b.y as f32);
                for (&(xx, yy, c, wt), &sample) in s.window.iter().zip(s.block.iter()) {
                    sums.add(sample, dq, c, wt, xx - cx, yy - cy);
                }
            } else {
                for &(xx, yy, c, wt) in &s.window {
                    let (dx, dy) = (xx - cx, yy - cy);
                    let p = theta[0] + theta[1] * dx + theta[2] * dy;
                    let q = v.sample(DVec2::new(xx, yy), p);
                    if q.z <= 0.0 {
                        continue;
                    }
                    let (qx, qy) = (q.x / q.z, q.y / q.z);
                    if qx < -0.5 || qy < -0.5 || qx > wf || qy > hf {
                        continue;
                    }
                    // d(sample position)/dp of the projective map.
                    let dqx = (v.b.x - qx * v.b.z) / q.z;
                    let dqy = (v.b.y - qy * v.b.z) / q.z;
                    sums.add(img.sample(qx, qy), (dqx as f32, dqy as f32), c, wt, dx, dy);
                }
            }
            let Sums { e, g, hh, n } = sums;
            s.used[k] = n * 2 > s.window.len();
            let vw = self.view_weights[k];
            s.residual[k] = vw * e;
            s.grad[k] = g.map(|x| vw * x);
            s.hess[k] = hh.map(|x| vw * x);
        }
    }

    /// One Gauss–Newton step of `theta` on the kept views' normal equations, with the priors
    /// (slopes near 0, p near its start `p0`) and the clamps; `None` where the equations cannot
    /// be solved (no gradient). Returns the step of p before its clamp to the winner's reach.
    fn step(&self, theta: &mut [f64; 3], p0: f64, s: &ViewSums) -> Option<f64> {
        let mut g = [0.0; 3];
        let mut hh = [0.0; 6];
        for k in (0..s.keep.len()).filter(|&k| s.keep[k]) {
            for (sum, x) in g.iter_mut().zip(&s.grad[k]) {
                *sum += x;
            }
            for (sum, x) in hh.iter_mut().zip(&s.hess[k]) {
                *sum += x;
            }
        }
        if hh[0].is_nan() || hh[0] <= 1e-12 {
            return None;
        }
        // A prior pulls the slopes towards 0 (frontoparallel) where the window cannot
        // tell them (weak texture); its weight scales with the data's own. Another
        // holds p near its start (`start_planes`), with a fixed weight: it decides only
        // where the data's own weight is small.
        let lambda = self.slope_prior * hh[0];
        let start_prior = self.start_prior;
        let m = glam::DMat3::from_cols_array(&[
            hh[0] + start_prior,
            hh[1],
            hh[2],
            hh[1],
            hh[3] + lambda,
            hh[4],
            hh[2],
            hh[4],
            hh[5] + lambda,
        ]);
        let rhs = glam::DVec3::new(
            g[0] + start_prior * (theta[0] - p0),
            g[1] + lambda * theta[1],
            g[2] + lambda * theta[2],
        );
        if m.determinant().abs() < 1e-300 {
            return None;
        }
        let d = -(m.inverse() * rhs);
        if !d.is_finite() {
            return None;
        }
        let step = self.step;
        let delta = d.x.clamp(-step, step);
        let max_away = MAX_PLANES_AWAY;
        theta[0] = (theta[0] + delta).clamp(p0 - max_away * step, p0 + max_away * step);
        // A slope of more than a plane per pixel is no surface the window can fit.
        theta[1] = (theta[1] + d.y).clamp(-step, step);
        theta[2] = (theta[2] + d.z).clamp(-step, step);
        Some(delta)
    }

    /// The fitted p of pixel `(x, y)` whose start is `p0`, or `None` to keep the start.
    fn fit_pixel(
        &self,
        param: &[f32],
        (x, y): (usize, usize),
        p0: f64,
        s: &mut ViewSums,
    ) -> Option<(f64, f64)> {
        let (w, h) = (self.reference.w, self.reference.h);
        if !p0.is_finite() {
            return None;
        }
        if self.edge_reach > 0.0 && at_depth_edge(param, (w, h), (x, y), p0, self.edge_reach) {
            return None;
        }
        self.colour_window((x, y), &mut s.window);
        let centre = (x as f64, y as f64);
        let mut theta = [p0, 0.0, 0.0];
        self.evaluate(centre, theta, s);
        let e0 = keep_unoccluded(s);
        if !e0.is_finite() {
            return None;
        }
        // The data's weight on p at the start (the views kept): how precisely the window's
        // own texture fixes p.
        let precision: f64 = (0..s.keep.len())
            .filter(|&k| s.keep[k])
            .map(|k| s.hess[k][0])
            .sum();
        for it in 0..self.iterations {
            let Some(delta) = self.step(&mut theta, p0, s) else {
                break;
            };
            // The last step needs no new residuals: nothing is decided on them.
            if it + 1 == self.iterations {
                break;
            }
            self.evaluate(centre, theta, s);
            keep_unoccluded(s);
            if delta.abs() < 1e-3 * self.step {
                break;
            }
        }
        theta[0].is_finite().then_some((theta[0], precision))
    }
}

/// Marks in `s.keep` the views not treated as occluded (none far above the
/// [`OCCLUSION_QUANTILE`] view) and returns their total residual; infinite when no view was
/// usable.
fn keep_unoccluded(s: &mut ViewSums) -> f64 {
    let ViewSums {
        residual,
        used,
        keep,
        scratch,
        ..
    } = s;
    scratch.clear();
    scratch.extend(
        residual
            .iter()
            .zip(used.iter())
            .filter(|(_, &u)| u)
            .map(|(&r, _)| r),
    );
    if scratch.is_empty() {
        keep.fill(false);
        return f64::INFINITY;
    }
    let at = (scratch.len() as f64 * OCCLUSION_QUANTILE) as usize;
    let cut = OCCLUDED_RATIO
        * scratch
            .select_nth_unstable_by(at, f64::total_cmp)
            .1
            .max(1e-12);
    let mut sum = 0.0;
    for ((k, &r), &u) in keep.iter_mut().zip(residual.iter()).zip(used.iter()) {
        *k = u && r <= cut;
        if *k {
            sum += r;
        }
    }
    sum
}

/// Refines the sweep parameter `param` (one per reference pixel, row-major) of `plan` against
/// `images` (the reference first, then one per `plan.views`, the same size), each view's
/// residuals weighted by `view_weights` (its inverse noise variance relative to the
/// reference's: a vignetted view amplified by a gain g weighs 1/g²). `plan.step()` is the plane
/// spacing the clamps refer to. Non-finite inputs are returned unchanged.
pub fn refine(
    plan: &SweepPlan,
    images: &[&RgbaImage],
    view_weights: &[f64],
    param: &[f32],
    params: &RefineParams,
) -> Vec<f32> {
    refine_with_precision(plan, images, view_weights, param, params).0
}

/// [`refine`], and per pixel the data's weight on p in the fit's normal equations at the
/// start (Σ over the kept views and the window of the squared derivative of the residual by
/// p: how precisely the pixel's own window fixes p; 0 where the pixel was not fitted).
pub fn refine_with_precision(
    plan: &SweepPlan,
    images: &[&RgbaImage],
    view_weights: &[f64],
    param: &[f32],
    params: &RefineParams,
) -> (Vec<f32>, Vec<f32>) {
    let (w, h) = (plan.width as usize, plan.height as usize);
    let unchanged = || (param.to_vec(), vec![0.0; param.len()]);
    if images.len() != plan.views.len() + 1
        || view_weights.len() != plan.views.len()
        || param.len() != w * h
        || w == 0
        || h == 0
    {
        return unchanged();
    }
    let reference = Rgb32::new(images[0]);
    let views: Vec<Rgb32> = images[1..].par_iter().map(|i| Rgb32::new(i)).collect();
    if reference.w != w || reference.h != h || views.iter().any(|v| v.w != w || v.h != h) {
        return unchanged();
    }
    let step = plan.step().abs().max(1e-12);
    let setup = FitSetup {
        plan,
        reference,
        views,
        view_weights,
        translation: plan.views.iter().map(|v| v.is_translation()).collect(),
        step,
        r: params.radius as i64,
        inv_two_sigma2: 1.0 / (2.0 * params.colour_sigma.max(1e-6).powi(2)),
        edge_reach: params.edge_planes * step,
        start_prior: if params.start_planes > 0.0 {
            (FIT_NOISE / (params.start_planes * step)).powi(2)
        } else {
            0.0
        },
        slope_prior: params.slope_prior,
        iterations: params.iterations,
    };
    let mut out = param.to_vec();
    let mut precision = vec![0f32; param.len()];
    out.par_chunks_mut(w)
        .zip(precision.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (row, prec))| {
            let mut sums = ViewSums::new(setup.views.len(), setup.r);
            for (x, (value, prec)) in row.iter_mut().zip(prec.iter_mut()).enumerate() {
                if let Some((p, h)) = setup.fit_pixel(param, (x, y), *value as f64, &mut sums) {
                    *value = p as f32;
                    *prec = h as f32;
                }
            }
        });
    (out, precision)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_texel_block_samples_as_each_position_alone_and_refuses_to_leave_the_image() {
        let img = RgbaImage::from_fn(12, 9, |x, y| {
            image::Rgba([
                (x * 37 + y * 11) as u8,
                (x * x + 5 * y) as u8,
                (200 - 9 * y) as u8,
                255,
            ])
        });
        let img = Rgb32::new(&img);
        let mut block = vec![Sample::default(); 9];
        for (x0, y0) in [(0.0, 0.0), (2.25, 3.75), (8.0 - 1e-9, 5.5)] {
            assert!(img.block(x0, y0, 3, &mut block), "({x0}, {y0})");
            for v in 0..3 {
                for u in 0..3 {
                    let (a, b) = (block[v * 3 + u], img.sample(x0 + u as f64, y0 + v as f64));
                    for (p, q) in [(a.0, b.0), (a.1, b.1), (a.2, b.2)] {
                        for c in 0..3 {
                            assert!((p[c] - q[c]).abs() < 1e-5, "({x0}, {y0}) + ({u}, {v})");
                        }
                    }
                }
            }
        }
        // A block reaching the last column or row, or left of the image, is refused.
        for (x0, y0) in [(9.0, 0.0), (0.0, 6.0), (-0.25, 1.0), (f64::NAN, 1.0)] {
            assert!(!img.block(x0, y0, 3, &mut block), "({x0}, {y0})");
        }
    }

    #[test]
    fn the_fit_pulls_a_perturbed_slanted_plane_back_to_its_true_disparity() {
        let fixture = crate::depth::fixtures::Tilted::new();
        let (plan, exact) = (&fixture.plan, &fixture.exact);
        let images = fixture.images();
        let step = plan.step() as f32;
        // Start a third of a plane off everywhere, one pixel without a value.
        let mut start: Vec<f32> = exact.iter().map(|d| d + 0.33 * step).collect();
        start[0] = f32::NAN;
        let weights = vec![1.0; plan.views.len()];
        // Errors in planes (median, 90th percentile) inside a 4-px border.
        let errors = |out: &[f32]| {
            let mut err: Vec<f32> = out
                .iter()
                .zip(exact)
                .enumerate()
                .filter(|(i, (o, t))| {
                    let (x, y) = (i % 64, i / 64);
                    (4..60).contains(&x) && (4..60).contains(&y) && o.is_finite() && t.is_finite()
                })
                .map(|(_, (o, t))| (o - t).abs() / step)
                .collect();
            err.sort_by(f32::total_cmp);
            (err[err.len() / 2], err[err.len() * 9 / 10])
        };
        // The data alone (no prior on the start) pull the fit back to the plane.
        let data_only = RefineParams {
            start_planes: 0.0,
            ..RefineParams::default()
        };
        let out = refine(plan, &images, &weights, &start, &data_only);
        assert!(out[0].is_nan());
        let (median, p90) = errors(&out);
        assert!(
            median < 0.08 && p90 < 0.2,
            "median {median}, p90 {p90} planes"
        );
        // The default's prior holds p nearer its start, which is wrong here by a third of a
        // plane, yet the data still move every pixel most of the way (without a step the
        // error would stay 0.33).
        let (median, p90) = errors(&refine(
            plan,
            &images,
            &weights,
            &start,
            &RefineParams::default(),
        ));
        assert!(
            (0.08..0.28).contains(&median) && p90 < 0.3,
            "median {median}, p90 {p90} planes"
        );
        // Mismatched inputs are returned unchanged.
        assert_eq!(
            refine(
                plan,
                &images[..1],
                &weights,
                &start,
                &RefineParams::default()
            )[1],
            start[1]
        );
    }
}
