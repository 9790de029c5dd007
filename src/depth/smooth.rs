//! Global refinement of the continuous estimate: the views' photometric evidence of every
//! pixel, weighed against a smoothness prior that follows curvature (CPU).
//!
//! The fit of [`super::refine`] decides each pixel on its own 3 × 3 window. On a smooth, shaded
//! surface with little texture (a lit bust, a sculpture) that window holds too little gradient
//! for the views to pull p anywhere, and a prior then keeps the sweep's winner — a staircase
//! of planes, biased towards the far side of a dome by the sweep's 11 × 11 frontoparallel
//! windows. Here every pixel's evidence is linearised at the current estimate, as in the fit
//! (per view: the residual `r = I_v(y_v(x, p)) − I_r(x)` and its derivative `J = ∂r/∂p`), and
//! the whole map is solved at once:
//!
//! `min over δ:  Σ_x [h(x) δ(x)² + 2 g(x) δ(x)] + λ Σ w·(second difference of p + δ)²`
//!
//! with `h = Σ J²` and `g = Σ J r` over the views not treated as occluded at that pixel. The
//! prior penalises the second differences of p along the rows and the columns, so planes —
//! slanted ones too — cost nothing and a curved surface costs its curvature, not its slope
//! (a first-order prior would pull slopes towards frontoparallel steps). A pixel whose own
//! views say little takes its value from the surface around it; textured pixels keep theirs.
//!
//! - The prior's links follow the reference's colours: a second difference across a colour
//!   edge weighs `exp(−|Δc|²/2σ²)`, across a jump of more than [`SmoothParams::edge_planes`]
//!   planes nothing.
//! - Pixels next to a depth edge of the start (a neighbour more than `edge_planes` planes away:
//!   the fit's rule, [`super::refine::RefineParams::edge_planes`]) keep their value, and no
//!   link reaches them: their start is often wrong by a fattened pixel and must not anchor the
//!   surface beside them (the edge snapping after this step places them).
//! - Occlusion: a view whose residual, summed over the 3 × 3 neighbourhood, is more than
//!   [`super::refine::OCCLUDED_RATIO`] times that of the view 30 % of the way up is left out at
//!   that pixel (the fit's test).
//! - Pixels whose own fit window fixes p precisely (the fit's data weight on p at least
//!   [`SmoothParams::anchor_precision`], [`super::refine::refine_with_precision`]) keep the
//!   fit's value and anchor the surface around them: on strong texture the 3 × 3 fit is the
//!   better estimate (without anchors HCI backgammon went 1.73 → 2.34 % BadPix 0.07), and
//!   only the weakly textured pixels are unknowns, which keeps the solve small where the
//!   texture is rich.
//! - Two Gauss–Newton steps, each solved by 30 conjugate-gradient iterations (Jacobi
//!   preconditioner, matrix-free, over the unknowns only) and clamped to one plane per pixel.

use glam::DVec2;
use image::RgbaImage;
use rayon::prelude::*;

use super::refine::{Rgb32, OCCLUDED_RATIO, OCCLUSION_QUANTILE};
use super::sweep::SweepPlan;

/// Settings of the global refinement.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SmoothParams {
    /// Gauss–Newton steps (each re-linearises the views at the current estimate).
    pub iterations: u32,
    /// Weight of the second-order prior against the data (`h` summed over the views and
    /// channels of encoded values in [0, 1]).
    pub lambda: f64,
    /// Colour distance (encoded, per channel RMS) at which a link's weight is e^(−½).
    pub colour_sigma: f64,
    /// A link across a jump of more than this many planes is cut; a pixel of the start with a
    /// neighbour this far away keeps its value.
    pub edge_planes: f64,
    /// Conjugate-gradient iterations per Gauss–Newton step.
    pub solver_iterations: u32,
    /// Pixels whose fit had at least this data weight on p (Σ J² over the window and the
    /// views, encoded values in [0, 1] per unit of p) keep the fit's value and anchor the
    /// surface around them. 0.3: p fixed to about 0.015 px against residuals of 2 levels.
    pub anchor_precision: f64,
}

impl Default for SmoothParams {
    /// Chosen on the depth set with backgammon (96 px, docs/depth.md): λ 0.01, 0.02, 0.05,
    /// 0.1 against 0.03 traded the shaded scenes against the flat-shaded ones (0.1: shaded mean
    /// BadPix 0.07 25.3 % against 21.8, old scenes 8.75 against 9.34, without anchors); four
    /// steps of 100 iterations gained 2 points on the shaded scenes at four times the time;
    /// anchors at 0.2, 0.5 and 1.5 gave backgammon 1.72, 1.80 and 2.04 %.
    fn default() -> Self {
        SmoothParams {
            iterations: 2,
            lambda: 0.03,
            colour_sigma: 0.04,
            edge_planes: 3.0,
            solver_iterations: 30,
            anchor_precision: 0.3,
        }
    }
}

/// The images and views every step shares.
struct Setup<'a> {
    plan: &'a SweepPlan,
    reference: Rgb32,
    views: Vec<Rgb32>,
    view_weights: &'a [f64],
    w: usize,
    h: usize,
}

impl Setup<'_> {
    /// Per moving pixel (`active`) and view, linearised at `p`: the residual Σ r², Σ J r and
    /// Σ J² over the channels, times the view's weight (NaN residual where the view does not
    /// see the pixel), `active`'s order, view by view.
    fn linearise(&self, p: &[f64], active: &[usize]) -> Vec<[f32; 3]> {
        let (w, nv) = (self.w, self.views.len());
        let (wf, hf) = (w as f64 - 0.5, self.h as f64 - 0.5);
        let mut out = vec![[f32::NAN, 0.0, 0.0]; active.len() * nv];
        out.par_chunks_mut(nv)
            .zip(active.par_iter())
            .for_each(|(lin, &i)| {
                let (x, y) = (i % w, i / w);
                let c = self.reference.at(x, y);
                for (k, (v, img)) in self.plan.views.iter().zip(&self.views).enumerate() {
                    let q = v.sample(DVec2::new(x as f64, y as f64), p[i]);
                    if q.z <= 0.0 {
                        continue;
                    }
                    let (qx, qy) = (q.x / q.z, q.y / q.z);
                    if qx < -0.5 || qy < -0.5 || qx > wf || qy > hf {
                        continue;
                    }
                    let dqx = ((v.b.x - qx * v.b.z) / q.z) as f32;
                    let dqy = ((v.b.y - qy * v.b.z) / q.z) as f32;
                    let (s, gx, gy) = img.sample(qx, qy);
                    let (mut rr, mut jr, mut jj) = (0f32, 0f32, 0f32);
                    for ch in 0..3 {
                        let r = s[ch] - c[ch];
                        let j = gx[ch] * dqx + gy[ch] * dqy;
                        rr += r * r;
                        jr += j * r;
                        jj += j * j;
                    }
                    let vw = self.view_weights[k] as f32;
                    lin[k] = [vw * rr, vw * jr, vw * jj];
                }
            });
        out
    }

    /// Per moving pixel, `(h, g)` over the views not treated as occluded: a view whose
    /// residual summed over the moving pixels of the 3 × 3 neighbourhood (`slot`: a pixel's
    /// place in `active`, `u32::MAX` for the others) exceeds [`OCCLUDED_RATIO`] times the
    /// [`OCCLUSION_QUANTILE`] view's is left out.
    fn data(&self, lin: &[[f32; 3]], active: &[usize], slot: &[u32]) -> Vec<(f64, f64)> {
        let (w, h, nv) = (self.w, self.h, self.views.len());
        active
            .par_iter()
            .enumerate()
            .map_init(
                || (vec![0f64; nv], Vec::with_capacity(nv)),
                |(sums, scratch), (k, &i)| {
                    let (x, y) = (i % w, i / w);
                    sums.fill(0.0);
                    for yy in y.saturating_sub(1)..(y + 2).min(h) {
                        for xx in x.saturating_sub(1)..(x + 2).min(w) {
                            let j = slot[yy * w + xx];
                            if j == u32::MAX {
                                continue;
                            }
                            let at = j as usize * nv;
                            for (s, l) in sums.iter_mut().zip(&lin[at..at + nv]) {
                                if l[0].is_finite() {
                                    *s += l[0] as f64;
                                }
                            }
                        }
                    }
                    let centre = &lin[k * nv..(k + 1) * nv];
                    scratch.clear();
                    scratch.extend(
                        sums.iter()
                            .zip(centre)
                            .filter(|(_, l)| l[0].is_finite())
                            .map(|(&s, _)| s),
                    );
                    if scratch.is_empty() {
                        return (0.0, 0.0);
                    }
                    let at = (scratch.len() as f64 * OCCLUSION_QUANTILE) as usize;
                    let cut = OCCLUDED_RATIO
                        * scratch
                            .select_nth_unstable_by(at, f64::total_cmp)
                            .1
                            .max(1e-12);
                    let (mut hh, mut g) = (0.0, 0.0);
                    for (&s, l) in sums.iter().zip(centre) {
                        if l[0].is_finite() && s <= cut {
                            g += l[1] as f64;
                            hh += l[2] as f64;
                        }
                    }
                    (hh, g)
                },
            )
            .collect()
    }

    /// The prior's weights of the second differences centred on each pixel of `centres`
    /// along the rows (`.0`) and the columns (`.1`), on the whole image (0 elsewhere): λ times
    /// the colour weight of the link's weaker half, 0 across a jump of more than `reach` in
    /// `p`, at the image's edge and where a link touches a pixel left out (`skip`).
    fn links(
        &self,
        p: &[f64],
        skip: &[bool],
        centres: &[usize],
        params: &SmoothParams,
        reach: f64,
    ) -> Vec<(f64, f64)> {
        let (w, h) = (self.w, self.h);
        let inv_two_sigma2 = 1.0 / (2.0 * params.colour_sigma.max(1e-6).powi(2));
        let colour = |a: usize, b: usize| {
            let (ca, cb) = (
                self.reference.at(a % w, a / w),
                self.reference.at(b % w, b / w),
            );
            let d2 = (0..3).map(|k| (ca[k] - cb[k]).powi(2)).sum::<f32>() as f64 / 3.0;
            (-d2 * inv_two_sigma2).exp()
        };
        let link = |l: usize, c: usize, r: usize| {
            if skip[l] || skip[c] || skip[r] {
                return 0.0;
            }
            if (p[l] - p[c]).abs() > reach || (p[r] - p[c]).abs() > reach {
                return 0.0;
            }
            params.lambda * colour(l, c).min(colour(r, c))
        };
        let values: Vec<(f64, f64)> = centres
            .par_iter()
            .map(|&i| {
                let (x, y) = (i % w, i / w);
                let along_row = if x > 0 && x + 1 < w {
                    link(i - 1, i, i + 1)
                } else {
                    0.0
                };
                let along_column = if y > 0 && y + 1 < h {
                    link(i - w, i, i + w)
                } else {
                    0.0
                };
                (along_row, along_column)
            })
            .collect();
        let mut out = vec![(0.0, 0.0); w * h];
        for (&i, v) in centres.iter().zip(values) {
            out[i] = v;
        }
        out
    }
}

/// Elements per parallel chunk of the solver's passes (fixed: its sums do not depend on the
/// thread count).
const CHUNK: usize = 4096;

/// The linear system of one Gauss–Newton step over the pixels that move (the unknowns),
/// the others held where they are.
struct System<'a> {
    w: usize,
    /// The prior's weights per pixel (see [`Setup::links`]).
    links: &'a [(f64, f64)],
    /// The unknowns' pixels.
    active: &'a [usize],
    /// The centres of the links that touch an unknown.
    centres: Vec<usize>,
    /// The data's weight per unknown.
    h: Vec<f64>,
}

impl System<'_> {
    /// `W D v` at the link centres into `u` (a buffer of the image's size, zero elsewhere).
    fn weighted_second(&self, v: &[f64], u: &mut [(f64, f64)]) {
        let (w, links) = (self.w, self.links);
        let values: Vec<(f64, f64)> = self
            .centres
            .par_chunks(CHUNK)
            .flat_map_iter(|chunk| {
                chunk.iter().map(move |&i| {
                    let (lx, ly) = links[i];
                    (
                        if lx > 0.0 {
                            lx * (v[i - 1] - 2.0 * v[i] + v[i + 1])
                        } else {
                            0.0
                        },
                        if ly > 0.0 {
                            ly * (v[i - w] - 2.0 * v[i] + v[i + w])
                        } else {
                            0.0
                        },
                    )
                })
            })
            .collect();
        for (&i, v) in self.centres.iter().zip(values) {
            u[i] = v;
        }
    }

    /// `(Dᵀ u)` at the unknowns.
    fn transposed(&self, u: &[(f64, f64)]) -> Vec<f64> {
        let w = self.w;
        let n = u.len();
        self.active
            .par_chunks(CHUNK)
            .flat_map_iter(|chunk| {
                chunk.iter().map(move |&i| {
                    let mut s = -2.0 * (u[i].0 + u[i].1);
                    if i % w > 0 {
                        s += u[i - 1].0;
                    }
                    if i % w + 1 < w {
                        s += u[i + 1].0;
                    }
                    if i >= w {
                        s += u[i - w].1;
                    }
                    if i + w < n {
                        s += u[i + w].1;
                    }
                    s
                })
            })
            .collect()
    }

    /// The system's diagonal at the unknowns: a link centred on c adds its weight to c − d
    /// and c + d and four times it to c.
    fn diagonal(&self) -> Vec<f64> {
        let (w, links) = (self.w, self.links);
        self.active
            .iter()
            .zip(&self.h)
            .map(|(&i, &h)| {
                let mut d = h + 1e-12;
                let (x, y) = (i % w, i / w);
                let n = links.len();
                d += 4.0 * (links[i].0 + links[i].1);
                if x > 0 {
                    d += links[i - 1].0;
                }
                if x + 1 < w {
                    d += links[i + 1].0;
                }
                if y > 0 {
                    d += links[i - w].1;
                }
                if i + w < n {
                    d += links[i + w].1;
                }
                d
            })
            .collect()
    }

    /// `Σ Dᵀ W D v` at the unknowns for `v` on the whole image.
    fn prior(&self, v: &[f64], u: &mut [(f64, f64)]) -> Vec<f64> {
        self.weighted_second(v, u);
        self.transposed(u)
    }

    /// Solves for the unknowns' step against `rhs` (per unknown) by `iterations` of
    /// preconditioned conjugate gradients from 0 (Jacobi preconditioner, matrix-free).
    fn solve(&self, rhs: &[f64], iterations: u32) -> Vec<f64> {
        let m = rhs.len();
        let n = self.links.len();
        let inv: Vec<f64> = self.diagonal().iter().map(|d| 1.0 / d).collect();
        let dot = |a: &[f64], b: &[f64]| -> f64 {
            a.par_chunks(CHUNK)
                .zip(b.par_chunks(CHUNK))
                .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>())
                .collect::<Vec<f64>>()
                .iter()
                .sum()
        };
        let mut x = vec![0.0; m];
        let mut r = rhs.to_vec();
        let mut z: Vec<f64> = r.iter().zip(&inv).map(|(r, i)| r * i).collect();
        let mut d = z.clone();
        let mut rz = dot(&r, &z);
        // The search direction on the whole image (zero off the unknowns) and the prior's
        // buffer.
        let mut full = vec![0.0; n];
        let mut u = vec![(0.0, 0.0); n];
        for _ in 0..iterations {
            if rz <= 0.0 || !rz.is_finite() {
                break;
            }
            for (&i, &v) in self.active.iter().zip(&d) {
                full[i] = v;
            }
            let mut ad = self.prior(&full, &mut u);
            ad.par_iter_mut()
                .zip(self.h.par_iter().zip(d.par_iter()))
                .for_each(|(a, (h, d))| *a += (h + 1e-12) * d);
            let dad = dot(&d, &ad);
            if dad <= 0.0 || !dad.is_finite() {
                break;
            }
            let alpha = rz / dad;
            x.par_iter_mut()
                .zip(d.par_iter())
                .for_each(|(x, d)| *x += alpha * d);
            r.par_iter_mut()
                .zip(ad.par_iter())
                .for_each(|(r, a)| *r -= alpha * a);
            z.par_iter_mut()
                .zip(r.par_iter().zip(inv.par_iter()))
                .for_each(|(z, (r, i))| *z = r * i);
            let rz_next = dot(&r, &z);
            let beta = rz_next / rz;
            rz = rz_next;
            d.par_iter_mut()
                .zip(z.par_iter())
                .for_each(|(d, z)| *d = z + beta * *d);
        }
        x
    }
}

/// Whether a finite neighbour of pixel `i` (8-neighbourhood) differs from it by more than
/// `reach`.
fn at_depth_edge(p: &[f32], (w, h): (usize, usize), i: usize, reach: f64) -> bool {
    let (x, y) = ((i % w) as i64, (i / w) as i64);
    let p0 = p[i] as f64;
    (-1i64..=1).any(|dy| {
        (-1i64..=1).any(|dx| {
            let (xx, yy) = (x + dx, y + dy);
            if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                return false;
            }
            let q = p[yy as usize * w + xx as usize] as f64;
            q.is_finite() && (q - p0).abs() > reach
        })
    })
}

/// Refines `param` (one sweep parameter per reference pixel, row-major) of `plan` against
/// `images` (the reference, then one per `plan.views`, the same size), each view's evidence
/// weighted by `view_weights` (see [`super::refine::refine`]). Non-finite values, and
/// everything when the inputs do not match, are returned unchanged.
pub fn smooth(
    plan: &SweepPlan,
    images: &[&RgbaImage],
    view_weights: &[f64],
    param: &[f32],
    precision: &[f32],
    params: &SmoothParams,
) -> Vec<f32> {
    let (w, h) = (plan.width as usize, plan.height as usize);
    if images.len() != plan.views.len() + 1
        || view_weights.len() != plan.views.len()
        || param.len() != w * h
        || w < 3
        || h < 3
        || params.iterations == 0
    {
        return param.to_vec();
    }
    let reference = Rgb32::new(images[0]);
    let views: Vec<Rgb32> = images[1..].par_iter().map(|i| Rgb32::new(i)).collect();
    if reference.w != w || reference.h != h || views.iter().any(|v| v.w != w || v.h != h) {
        return param.to_vec();
    }
    let setup = Setup {
        plan,
        reference,
        views,
        view_weights,
        w,
        h,
    };
    let step = plan.step().abs().max(1e-12);
    let reach = params.edge_planes * step;
    let skip: Vec<bool> = (0..w * h)
        .into_par_iter()
        .map(|i| !param[i].is_finite() || at_depth_edge(param, (w, h), i, reach))
        .collect();
    // Pixels whose fit found enough texture of their own keep its value and anchor the
    // surface; the rest move.
    let anchored: Vec<bool> = (0..w * h)
        .map(|i| {
            skip[i]
                || precision
                    .get(i)
                    .is_some_and(|&h| h as f64 >= params.anchor_precision)
        })
        .collect();
    let active: Vec<usize> = (0..w * h).filter(|&i| !anchored[i]).collect();
    if active.is_empty() {
        return param.to_vec();
    }
    let mut slot = vec![u32::MAX; w * h];
    for (k, &i) in active.iter().enumerate() {
        slot[i] = k as u32;
    }
    // The centres of the links that can touch a moving pixel: the moving pixels and their
    // four neighbours.
    let mut near = vec![false; w * h];
    for &i in &active {
        near[i] = true;
        let (x, y) = (i % w, i / w);
        if x > 0 {
            near[i - 1] = true;
        }
        if x + 1 < w {
            near[i + 1] = true;
        }
        if y > 0 {
            near[i - w] = true;
        }
        if y + 1 < h {
            near[i + w] = true;
        }
    }
    let candidates: Vec<usize> = (0..w * h).filter(|&i| near[i]).collect();
    drop(near);
    let mut p: Vec<f64> = param.iter().map(|&v| v as f64).collect();
    log::debug!(
        "global refinement: {} of {} pixels move",
        active.len(),
        w * h
    );
    for _ in 0..params.iterations {
        let lin = setup.linearise(&p, &active);
        let data = setup.data(&lin, &active, &slot);
        drop(lin);
        let links = setup.links(&p, &skip, &candidates, params, reach);
        let touches = |c: usize, d: usize| !anchored[c - d] || !anchored[c] || !anchored[c + d];
        let centres: Vec<usize> = candidates
            .iter()
            .copied()
            .filter(|&c| (links[c].0 > 0.0 && touches(c, 1)) || (links[c].1 > 0.0 && touches(c, w)))
            .collect();
        let system = System {
            w,
            links: &links,
            active: &active,
            centres,
            h: data.iter().map(|d| d.0).collect(),
        };
        let mut u = vec![(0.0, 0.0); w * h];
        let prior = system.prior(&p, &mut u);
        let rhs: Vec<f64> = data.iter().zip(&prior).map(|(d, pr)| -(d.1 + pr)).collect();
        let delta = system.solve(&rhs, params.solver_iterations);
        for (&i, d) in active.iter().zip(&delta) {
            if d.is_finite() {
                p[i] += d.clamp(-step, step);
            }
        }
    }
    p.iter()
        .zip(param)
        .map(|(&p, &orig)| if p.is_finite() { p as f32 } else { orig })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_prior_pulls_a_staircase_of_planes_back_onto_a_slanted_plane() {
        let fixture = crate::depth::fixtures::Tilted::new();
        let (plan, exact) = (&fixture.plan, &fixture.exact);
        let images = fixture.images();
        let step = plan.step() as f32;
        let lo = plan.range.0 as f32;
        // The sweep's staircase: every pixel on its nearest plane; one pixel without a value.
        let mut start: Vec<f32> = exact
            .iter()
            .map(|d| lo + ((d - lo) / step).round() * step)
            .collect();
        start[0] = f32::NAN;
        let weights = vec![1.0; plan.views.len()];
        // Median error in planes inside a 4-px border.
        let error = |out: &[f32]| {
            let mut err: Vec<f32> = out
                .iter()
                .zip(exact)
                .enumerate()
                .filter(|(i, _)| (4..60).contains(&(i % 64)) && (4..60).contains(&(i / 64)))
                .map(|(_, (o, t))| (o - t).abs() / step)
                .collect();
            err.sort_by(f32::total_cmp);
            err[err.len() / 2]
        };
        let no_anchors = vec![0.0; start.len()];
        let out = smooth(
            plan,
            &images,
            &weights,
            &start,
            &no_anchors,
            &SmoothParams::default(),
        );
        assert!(out[0].is_nan());
        let (before, after) = (error(&start), error(&out));
        assert!(before > 0.15 && after < 0.05, "{before} → {after} planes");
        // Anchored pixels keep their values; with every pixel anchored nothing moves.
        let all = vec![f32::INFINITY; start.len()];
        let kept = smooth(
            plan,
            &images,
            &weights,
            &start,
            &all,
            &SmoothParams::default(),
        );
        assert!(kept
            .iter()
            .zip(&start)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        // Mismatched inputs are returned unchanged.
        let short = smooth(
            plan,
            &images[..1],
            &weights,
            &start,
            &all,
            &SmoothParams::default(),
        );
        assert_eq!(short[1], start[1]);
    }
}
