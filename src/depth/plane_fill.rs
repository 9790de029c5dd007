//! Plane fill: the dominant planes of the estimate (walls, floors) given to their weakly
//! textured pixels (docs/depth.md, step 7c).
//!
//! On a dark, faint wall the views barely fix the depth, and what little they say can be
//! biased: a view-dependent highlight moves with the camera like the mirror image of the light
//! behind the surface, so matching puts the highlight's patch of wall 0.2–0.35 px too far
//! (`sculpture` in the depth set), and the global refinement only smooths that bias. The wall
//! around the patch, where the estimate is right, is a plane. So:
//!
//! 1. **Find planes** in the estimate by RANSAC: hypotheses from triples of pixels within
//!    [`TRIPLE_REACH`] of each other (a surface holding a tenth of the image is rarely hit
//!    by three uniform picks), scored by the pixels within [`INLIER_PLANES`] of them, refitted
//!    by least squares to their inliers until those settle. A plane needs [`MIN_SUPPORT`] of
//!    the image as inliers; at most [`MAX_PLANES`], each searched outside the regions of the
//!    ones before (a smooth deviation from a plane must not pass for a plane of its own).
//! 2. **Regions**: the pixels within [`NEAR_PLANES`] of a plane that are connected to its
//!    inliers without a jump of more than [`LINK_PLANES`] between neighbours. A pixel in
//!    several regions takes the nearest plane.
//! 3. **Test**: a region's pixel that its own views do not fix precisely (the fit's data
//!    weight below [`SmoothParams::anchor_precision`](super::smooth::SmoothParams)) takes
//!    the plane's value where the views agree there as well as at its own value, up to
//!    [`MARGIN`]: per view, the colour difference of every pixel at its own value and at the
//!    plane's, over a colour-weighted 3 × 3 window, averaged over the best
//!    [`AGREEING_SHARE`](super::edges::AGREEING_SHARE) of the views. Precisely fixed pixels keep their value.
//!
//! Measured on the depth set (`tiltfield depth-set`, 96², docs/depth.md): `sculpture` BadPix
//! 0.07 28.8 → 6.2 %, `shaded-bust` 17.3 → 6.8 %, `plenoptic` 20.6 → 10.5 %, every scene
//! equal or better; backgammon 1.71 → 1.67 %. Where it fails: a curved surface whose central
//! strip passes for a plane (`cylinder` at 128² 9.1 → 11.0 %: its weak pixels take the
//! strip's plane), and a wall whose whole estimate is biased (the shaded scenes at 64²: the
//! plane locks in the bias that noise used to scatter).

use glam::{DMat3, DVec2, DVec3};
use image::RgbaImage;
use rayon::prelude::*;

use super::arbitrate::SIGMA;
use super::edges::mean_of_agreeing;
use super::refine::Rgb32;
use super::sweep::SweepPlan;

/// At most this many planes are looked for.
pub const MAX_PLANES: usize = 4;
/// A plane's inliers are at least this share of the image (5 %: spurious planes through
/// curved and textureless parts took the bust from 11 % to 18 %).
pub const MIN_SUPPORT: f64 = 0.08;
/// An inlier lies within this many plane steps of the plane (0.06 steps, 0.03 px of
/// disparity on the set's rigs; 0.1 and 0.15 found planes across surfaces).
pub const INLIER_PLANES: f64 = 0.06;
/// A region's pixels lie within this many plane steps of the plane: the highlight's bias on
/// `sculpture` is up to 0.7 steps (0.6 left part of it, 0.75 took the set's shaded mean from
/// 8.6 to 10.8 %).
pub const NEAR_PLANES: f64 = 1.0;
/// Neighbours in a region differ by less than this many plane steps.
pub const LINK_PLANES: f64 = 0.5;
/// The views must agree at the plane's value to within this much of their agreement at the
/// pixel's own (mean absolute difference of encoded channels).
pub const MARGIN: f64 = 0.1 / 255.0;
/// Hypotheses per plane.
pub const HYPOTHESES: u64 = 1000;
/// The second and third pixel of a hypothesis lie within this many pixels of the first.
pub const TRIPLE_REACH: usize = 12;
/// Least-squares refits of a plane to its inliers.
pub const REFITS: usize = 4;
/// Inliers are counted on at most about this many pixels per hypothesis.
const SCORE_SAMPLE: usize = 4096;

/// SplitMix64: deterministic hypotheses without a dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// A plane of the estimate: p = a·x + b·y + c at pixel (x, y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub a: f64,
    pub b: f64,
    pub c: f64,
}

impl Plane {
    pub fn at(&self, x: f64, y: f64) -> f64 {
        self.a * x + self.b * y + self.c
    }

    /// The plane through three (x, y, p); `None` when they are (nearly) collinear.
    fn through(pts: [(f64, f64, f64); 3]) -> Option<Plane> {
        let [(x0, y0, p0), (x1, y1, p1), (x2, y2, p2)] = pts;
        let (ax, ay, ap) = (x1 - x0, y1 - y0, p1 - p0);
        let (bx, by, bp) = (x2 - x0, y2 - y0, p2 - p0);
        let det = ax * by - ay * bx;
        if det.abs() < 1e-6 {
            return None;
        }
        let (a, b) = ((ap * by - ay * bp) / det, (ax * bp - ap * bx) / det);
        Some(Plane {
            a,
            b,
            c: p0 - a * x0 - b * y0,
        })
    }

    /// The least-squares plane through the pixels `idx` of the row-major map `param`.
    fn fit(param: &[f32], w: usize, idx: &[usize]) -> Option<Plane> {
        let (mut m, mut r) = (DMat3::ZERO, DVec3::ZERO);
        for &i in idx {
            let v = DVec3::new((i % w) as f64, (i / w) as f64, 1.0);
            m += DMat3::from_cols(v * v.x, v * v.y, v * v.z);
            r += v * param[i] as f64;
        }
        (m.determinant().abs() > 1e-9).then(|| {
            let s = m.inverse() * r;
            Plane {
                a: s.x,
                b: s.y,
                c: s.z,
            }
        })
    }
}

/// The map `param` (the sweep parameter of `plan` per reference pixel, row-major, non-finite
/// where unknown) with its dominant planes given to their weakly fixed pixels (module docs).
/// `precision` is the fit's data weight per pixel (empty: every pixel is weak); `images` are
/// the reference, then one per `plan.views`, all of the plan's size. Returns the map and the
/// planes found; anything inconsistent returns `param` unchanged.
pub fn plane_fill(
    plan: &SweepPlan,
    images: &[&RgbaImage],
    param: &[f32],
    precision: &[f32],
    anchor_precision: f64,
) -> (Vec<f32>, Vec<Plane>) {
    let (w, h) = (plan.width as usize, plan.height as usize);
    if param.len() != w * h
        || images.len() != plan.views.len() + 1
        || w < 3
        || h < 3
        || images
            .iter()
            .any(|i| (i.width() as usize, i.height() as usize) != (w, h))
    {
        return (param.to_vec(), Vec::new());
    }
    let step = plan.step().abs();
    let (inlier, near, link) = (INLIER_PLANES * step, NEAR_PLANES * step, LINK_PLANES * step);
    let pt = |i: usize| ((i % w) as f64, (i / w) as f64, param[i] as f64);
    let residual = |plane: &Plane, i: usize| {
        let (x, y, p) = pt(i);
        (plane.at(x, y) - p).abs()
    };
    // The pixels near `plane` connected to its inliers without a jump (4-connected).
    let region_of = |plane: &Plane, inliers: &[usize], allowed: &[bool]| {
        let mut region = vec![false; w * h];
        let mut stack = inliers.to_vec();
        for &i in inliers {
            region[i] = true;
        }
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            let neighbours = [
                (x > 0).then(|| i - 1),
                (x + 1 < w).then(|| i + 1),
                (y > 0).then(|| i - w),
                (y + 1 < h).then(|| i + w),
            ];
            for j in neighbours.into_iter().flatten() {
                if !region[j]
                    && allowed[j]
                    && residual(plane, j) < near
                    && (((param[i] - param[j]).abs() as f64) < link)
                {
                    region[j] = true;
                    stack.push(j);
                }
            }
        }
        region
    };
    let finite: Vec<bool> = param.iter().map(|v| v.is_finite()).collect();
    let mut free = finite.clone();
    let mut rng = Rng(0x5eed);
    let mut planes: Vec<(Plane, Vec<usize>)> = Vec::new();
    while planes.len() < MAX_PLANES {
        let cand: Vec<usize> = (0..w * h).filter(|&i| free[i]).collect();
        if (cand.len() as f64) < MIN_SUPPORT * (w * h) as f64 {
            break;
        }
        let sample: Vec<(f32, f32, f32)> = cand
            .iter()
            .step_by((cand.len() / SCORE_SAMPLE).max(1))
            .map(|&i| {
                let (x, y, p) = pt(i);
                (x as f32, y as f32, p as f32)
            })
            .collect();
        // Each hypothesis has its own seed: the same planes on any number of threads.
        let round = rng.next();
        let best = (0..HYPOTHESES)
            .into_par_iter()
            .filter_map(|k| {
                let mut r = Rng(round ^ k.wrapping_mul(0x2545_F491_4F6C_DD1D));
                let first = cand[r.below(cand.len())];
                let (x0, y0) = ((first % w) as i64, (first / w) as i64);
                let reach = TRIPLE_REACH as i64;
                let pick = |r: &mut Rng| {
                    (0..8).find_map(|_| {
                        let x = x0 + r.below(2 * TRIPLE_REACH + 1) as i64 - reach;
                        let y = y0 + r.below(2 * TRIPLE_REACH + 1) as i64 - reach;
                        (x >= 0 && y >= 0 && x < w as i64 && y < h as i64)
                            .then(|| y as usize * w + x as usize)
                            .filter(|&j| free[j] && j != first)
                    })
                };
                let triple = [first, pick(&mut r)?, pick(&mut r)?];
                let plane = Plane::through(triple.map(pt))?;
                let (a, b, c, t) = (
                    plane.a as f32,
                    plane.b as f32,
                    plane.c as f32,
                    inlier as f32,
                );
                let n = sample
                    .iter()
                    .filter(|(x, y, p)| (a * x + b * y + c - p).abs() < t)
                    .count();
                Some((n, std::cmp::Reverse(k), plane))
            })
            .max_by_key(|&(n, k, _)| (n, k))
            .map(|(_, _, plane)| plane);
        let Some(mut plane) = best else { break };
        let inliers_of = |plane: &Plane| -> Vec<usize> {
            cand.iter()
                .copied()
                .filter(|&i| residual(plane, i) < inlier)
                .collect()
        };
        let mut inliers = inliers_of(&plane);
        // Refitted to its inliers while they grow (LO-RANSAC).
        for _ in 0..REFITS {
            let Some(refit) = Plane::fit(param, w, &inliers) else {
                break;
            };
            let more = inliers_of(&refit);
            if more.len() < inliers.len() {
                break;
            }
            (plane, inliers) = (refit, more);
        }
        if (inliers.len() as f64) < MIN_SUPPORT * (w * h) as f64 {
            break;
        }
        log::debug!("plane fill: {plane:?}, {} inliers", inliers.len());
        for (i, inside) in region_of(&plane, &inliers, &free).into_iter().enumerate() {
            if inside {
                free[i] = false;
            }
        }
        planes.push((plane, inliers));
    }
    // Each pixel in some planes' regions takes the nearest of them.
    let mut nearest: Vec<Option<usize>> = vec![None; w * h];
    for (k, (plane, inliers)) in planes.iter().enumerate() {
        for (i, inside) in region_of(plane, inliers, &finite).into_iter().enumerate() {
            if inside && nearest[i].map_or(true, |o| residual(plane, i) < residual(&planes[o].0, i))
            {
                nearest[i] = Some(k);
            }
        }
    }
    // Pixels next to a depth jump are the edge snapping's (step 8), as in the refinement:
    // a fattened pixel beside a nearer plane took it exactly and kept it (`wide` at 64²:
    // MSE × 100 8.4 → 19.7).
    let jump = super::edges::JUMP_PLANES * step;
    let at_edge = |i: usize| {
        let (x, y) = (i % w, i / w);
        (y.saturating_sub(1)..(y + 2).min(h)).any(|yy| {
            (x.saturating_sub(1)..(x + 2).min(w))
                .any(|xx| ((param[yy * w + xx] - param[i]).abs() as f64) > jump)
        })
    };
    let weak = |i: usize| {
        precision
            .get(i)
            .map_or(true, |&q| (q as f64) < anchor_precision)
    };
    let rgb: Vec<Rgb32> = images.par_iter().map(|i| Rgb32::new(i)).collect();
    let mut out = param.to_vec();
    for (k, (plane, _)) in planes.iter().enumerate() {
        let tested: Vec<usize> = (0..w * h)
            .filter(|&i| nearest[i] == Some(k) && weak(i) && residual(plane, i) >= inlier)
            .filter(|&i| !at_edge(i))
            .collect();
        for i in agreeing(plan, &rgb, param, plane, &tested) {
            out[i] = plane.at((i % w) as f64, (i / w) as f64) as f32;
        }
    }
    (out, planes.into_iter().map(|(plane, _)| plane).collect())
}

/// The pixels of `tested` whose views agree at `plane`'s value as well as at their own, up to
/// [`MARGIN`]: per view, each pixel's colour difference at both values, once; then per tested
/// pixel a colour-weighted 3 × 3 window of them, averaged over the best
/// [`AGREEING_SHARE`](super::edges::AGREEING_SHARE) of the views.
fn agreeing(
    plan: &SweepPlan,
    rgb: &[Rgb32],
    param: &[f32],
    plane: &Plane,
    tested: &[usize],
) -> Vec<usize> {
    let (w, h) = (plan.width as usize, plan.height as usize);
    const RADIUS: usize = 1;
    // The pixels the windows reach, indexed compactly.
    let mut slot = vec![u32::MAX; w * h];
    let mut reached = Vec::new();
    for &i in tested {
        let (x, y) = (i % w, i / w);
        for yy in y.saturating_sub(RADIUS)..(y + RADIUS + 1).min(h) {
            for xx in x.saturating_sub(RADIUS)..(x + RADIUS + 1).min(w) {
                let j = yy * w + xx;
                if slot[j] == u32::MAX {
                    slot[j] = reached.len() as u32;
                    reached.push(j);
                }
            }
        }
    }
    let reference = &rgb[0];
    let (wf, hf) = (w as f64 - 0.5, h as f64 - 0.5);
    // Per view, at every reached pixel: the colour difference at its own value and at the
    // plane's; NaN where the sample falls outside that view.
    let differences: Vec<Vec<[f32; 2]>> = plan
        .views
        .par_iter()
        .zip(&rgb[1..])
        .map(|(view, img)| {
            reached
                .iter()
                .map(|&j| {
                    let (x, y) = (j % w, j / w);
                    let c = reference.at(x, y);
                    let at = DVec2::new(x as f64, y as f64);
                    let difference = |p: f64| {
                        let q = view.sample(at, p);
                        let (u, v) = (q.x / q.z, q.y / q.z);
                        if !p.is_finite() || q.z <= 0.0 || u < -0.5 || v < -0.5 || u > wf || v > hf
                        {
                            return f32::NAN;
                        }
                        let s = img.sample(u, v).0;
                        ((s[0] - c[0]).abs() + (s[1] - c[1]).abs() + (s[2] - c[2]).abs()) / 3.0
                    };
                    [
                        difference(param[j] as f64),
                        difference(plane.at(x as f64, y as f64)),
                    ]
                })
                .collect()
        })
        .collect();
    let inv = -1.0 / (2.0 * (SIGMA / 255.0).powi(2));
    tested
        .par_iter()
        .copied()
        .filter(|&i| {
            let (x, y) = (i % w, i / w);
            let c0 = reference.at(x, y);
            let mut taps = [(0usize, 0.0f64); (2 * RADIUS + 1) * (2 * RADIUS + 1)];
            let (mut n, mut total) = (0, 0.0);
            for yy in y.saturating_sub(RADIUS)..(y + RADIUS + 1).min(h) {
                for xx in x.saturating_sub(RADIUS)..(x + RADIUS + 1).min(w) {
                    let c = reference.at(xx, yy);
                    let d2: f64 = (0..3).map(|k| ((c[k] - c0[k]) as f64).powi(2)).sum();
                    let weight = (d2 * inv).exp();
                    taps[n] = (slot[yy * w + xx] as usize, weight);
                    n += 1;
                    total += weight;
                }
            }
            let mut costs = [Vec::with_capacity(differences.len()), Vec::new()];
            costs[1].reserve(differences.len());
            for view in &differences {
                for (k, costs) in costs.iter_mut().enumerate() {
                    let (mut sum, mut weights) = (0.0, 0.0);
                    for &(s, weight) in &taps[..n] {
                        let d = view[s][k];
                        if d.is_finite() {
                            sum += weight * d as f64;
                            weights += weight;
                        }
                    }
                    if weights >= 0.5 * total {
                        costs.push(sum / weights);
                    }
                }
            }
            let [own, on] = costs.map(|mut v| mean_of_agreeing(&mut v));
            matches!((own, on), (Some(own), Some(on)) if on <= own + MARGIN)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::depth::fixtures::SetScene;

    /// The bust's dark, faint wall with a smooth bump of up to 0.3 px in the estimate (what a
    /// highlight does): the wall's plane is found and the bump goes back onto it; the bust,
    /// curved, is left alone; precisely fixed pixels keep their values.
    #[test]
    fn a_bump_on_a_faint_wall_goes_back_onto_its_plane() {
        let fixture = SetScene::new("bust");
        let (scene, plan, images) = (&fixture.scene, &fixture.plan, fixture.images());
        let (w, truth) = (plan.width as usize, &scene.truth);
        let wall = truth.iter().copied().fold(f32::INFINITY, f32::min);
        let bump = |i: usize| {
            let (x, y) = ((i % w) as f32 - 16.0, (i / w) as f32 - 12.0);
            0.3 * (-(x * x + y * y) / (2.0 * 6.0 * 6.0)).exp()
        };
        let on_wall = |i: usize| (truth[i] - wall).abs() < 1e-4;
        let bumped: Vec<f32> = (0..truth.len())
            .map(|i| truth[i] - if on_wall(i) { bump(i) } else { 0.0 })
            .collect();
        let off: Vec<usize> = (0..truth.len())
            .filter(|&i| (bumped[i] - truth[i]).abs() > 0.07)
            .collect();
        assert!(off.len() > 50, "{} pixels off", off.len());
        let (filled, planes) = plane_fill(plan, &images, &bumped, &[], 0.3);
        assert!(
            planes
                .iter()
                .any(|p| (p.at(16.0, 12.0) - wall as f64).abs() < 0.02),
            "{planes:?}"
        );
        let back = off
            .iter()
            .filter(|&&i| (filled[i] - truth[i]).abs() <= 0.07)
            .count();
        eprintln!("{back} of {} bump pixels back on the wall", off.len());
        assert!(back * 10 >= off.len() * 9, "{back} of {}", off.len());
        // The bust itself (no pixel of the wall's plane) keeps its values.
        let bust: Vec<usize> = (0..truth.len())
            .filter(|&i| truth[i] > wall + 0.5)
            .collect();
        let moved = bust.iter().filter(|&&i| filled[i] != bumped[i]).count();
        assert!(
            moved * 50 <= bust.len(),
            "{moved} of {} bust pixels moved",
            bust.len()
        );
        // Every pixel fixed precisely keeps its value.
        let precise = vec![1.0f32; truth.len()];
        assert_eq!(plane_fill(plan, &images, &bumped, &precise, 0.3).0, bumped);
        // A map of the wrong size comes back unchanged, without planes.
        assert_eq!(
            plane_fill(plan, &images, &bumped[1..], &[], 0.3),
            (bumped[1..].to_vec(), Vec::new())
        );
    }

    /// Curved surfaces before a textured wall, with their exact depth and every pixel taken
    /// to be weak: the views agree best at the truth, so the sphere keeps every value; the
    /// cylinder's central strip passes for a plane, and 54 of its 4 096 pixels (1.3 %, faint
    /// texture on its flanks) take it, the known failure (module docs).
    #[test]
    fn an_exact_map_stays_exact() {
        for name in ["sphere", "cylinder"] {
            let fixture = SetScene::new(name);
            let (scene, plan, images) = (&fixture.scene, &fixture.plan, fixture.images());
            let truth = &scene.truth;
            let (filled, _) = plane_fill(plan, &images, truth, &[], 0.3);
            let moved = (0..truth.len())
                .filter(|&i| (filled[i] - truth[i]).abs() > 0.07)
                .count();
            eprintln!("{name}: {moved} pixels moved by more than 0.07");
            assert!(moved * 50 <= truth.len(), "{name}: {moved} pixels moved");
        }
    }
}
