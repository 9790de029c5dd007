//! The sweep's winner against the colour-weighted median, pixel by pixel (docs/depth.md,
//! steps 6b and 6c: large moves arbitrated on the views, small ones undone on smooth winners).
//!
//! The median (step 6) hands each pixel the value most of its colour region holds. That
//! undoes the sweep's fattening on a dark, faint wall, where every depth that keeps a nearer
//! silhouette consistent agrees about as well as the wall's own. But where a surface shares
//! its colours with a larger one at another depth (the shadowed half of a grey ball before a
//! grey wall, a column's shaded edge), the median hands it the larger surface's depth, which
//! the views plainly contradict. So wherever the median moved a pixel by more than
//! [`MOVED_PLANES`] planes, the two values are compared on the views themselves: over a small
//! window weighted by the reference's colours ([`RADIUS`], [`SIGMA`]), each view's mean
//! colour difference at the candidate, averaged over the [`AGREEING_SHARE`](super::edges::AGREEING_SHARE) of the views that
//! agree best (an occluder hides a pixel from some views). The winner comes back only when it
//! agrees [`RATIO`] times better and by [`MARGIN`]: on the dark wall the fattened depth agrees
//! nearly as well as the true one, and there the median must stay in charge.
//!
//! Measured on the depth set (`tiltfield depth-set`, 96², docs/depth.md), before the plane
//! fill: `shaded-column` BadPix 0.07 24.5 → 16.9 %, MSE × 100 8.84 → 4.12; the ten older
//! scenes' mean 9.10 → 8.98 % (`wide` 8.5 → 7.7, `converging` 7.2 → 6.4, `planes` 1.55 →
//! 1.88: a few pixels of its card's edge); backgammon 1.72 → 1.71 %. A ratio of 0.6 took the
//! column to 15.3 % but gave 54 fattened pixels of the lit bust's neck back (its MSE × 100
//! 6.1 → 13.1).

use glam::DVec2;
use image::RgbaImage;
use rayon::prelude::*;

use super::cpu::bilinear;
use super::edges::mean_of_agreeing;
use super::sweep::SweepPlan;

/// Pixels the median moved by more than this many plane steps are arbitrated (1: 0.1 points
/// better on the set than 2 or 3, for a few more pixels to compare).
pub const MOVED_PLANES: f64 = 1.0;
/// The winner must agree this many times better than the median's value (0.1–0.25 measured:
/// below, the column keeps more of its errors; above, the lit bust's neck fattens again).
pub const RATIO: f64 = 0.15;
/// ...and better by at least this much (mean absolute difference of encoded channels): two
/// values that both agree within noise are left to the median.
pub const MARGIN: f64 = 1.0 / 255.0;
/// The comparison window's radius (5 × 5: one pixel decides nothing on faint texture, a wider
/// window reaches across the silhouettes it must tell apart).
pub const RADIUS: i64 = 2;
/// A window pixel weighs `exp(−|Δc|²/2σ²)` by its RGB distance (8-bit levels) from the centre.
pub const SIGMA: f64 = 10.0;

/// The window of one pixel: position, colour (encoded, in [0, 1]) and weight of each tap.
struct Window {
    taps: Vec<(DVec2, [f64; 3], f64)>,
}

impl Window {
    fn around(reference: &RgbaImage, x0: usize, y0: usize, radius: i64) -> Window {
        let (w, h) = (reference.width() as i64, reference.height() as i64);
        let c0 = reference.get_pixel(x0 as u32, y0 as u32).0;
        let inv = -1.0 / (2.0 * SIGMA * SIGMA);
        let mut taps = Vec::with_capacity(((2 * radius + 1) * (2 * radius + 1)) as usize);
        for y in y0 as i64 - radius..=y0 as i64 + radius {
            for x in x0 as i64 - radius..=x0 as i64 + radius {
                if x < 0 || y < 0 || x >= w || y >= h {
                    continue;
                }
                let c = reference.get_pixel(x as u32, y as u32).0;
                let d2: f64 = (0..3).map(|k| (c[k] as f64 - c0[k] as f64).powi(2)).sum();
                taps.push((
                    DVec2::new(x as f64, y as f64),
                    std::array::from_fn(|k| c[k] as f64 / 255.0),
                    (d2 * inv).exp(),
                ));
            }
        }
        Window { taps }
    }

    /// Each view's weighted mean colour difference at parameter `p` (over the taps inside its
    /// image, at least half the weight), averaged over the [`AGREEING_SHARE`](super::edges::AGREEING_SHARE) that agree
    /// best; `None` without any view.
    fn cost(&self, plan: &SweepPlan, images: &[&RgbaImage], p: f64) -> Option<f64> {
        let (wf, hf) = (plan.width as f64 - 0.5, plan.height as f64 - 0.5);
        let total: f64 = self.taps.iter().map(|t| t.2).sum();
        let mut costs: Vec<f64> = plan
            .views
            .iter()
            .zip(&images[1..])
            .filter_map(|(view, img)| {
                let (mut sum, mut weights) = (0.0, 0.0);
                for (x, c, weight) in &self.taps {
                    let q = view.sample(*x, p);
                    let (u, v) = (q.x / q.z, q.y / q.z);
                    if q.z <= 0.0 || u < -0.5 || v < -0.5 || u > wf || v > hf {
                        continue;
                    }
                    let s = bilinear(img, u, v);
                    let d = (0..3).map(|k| (s[k] - c[k]).abs()).sum::<f64>() / 3.0;
                    sum += weight * d;
                    weights += weight;
                }
                (weights >= 0.5 * total).then(|| sum / weights)
            })
            .collect();
        mean_of_agreeing(&mut costs)
    }
}

/// `median` with each pixel it moved by more than [`MOVED_PLANES`] from the sweep's `winner`
/// given back the winner where the views clearly agree better with it (module docs).
/// `images` are the reference, then one per `plan.views`, all of the plan's size; anything
/// else returns `median` unchanged. Also returns how many pixels went back.
pub fn arbitrate(
    plan: &SweepPlan,
    images: &[&RgbaImage],
    winner: &[f32],
    median: &[f32],
) -> (Vec<f32>, usize) {
    let (w, h) = (plan.width as usize, plan.height as usize);
    if images.len() != plan.views.len() + 1
        || winner.len() != w * h
        || median.len() != w * h
        || images
            .iter()
            .any(|i| (i.width() as usize, i.height() as usize) != (w, h))
    {
        return (median.to_vec(), 0);
    }
    let moved = MOVED_PLANES * plan.step().abs();
    let mut out = median.to_vec();
    let back: usize = out
        .par_chunks_mut(w)
        .enumerate()
        .map(|(y, row)| {
            let mut back = 0;
            for (x, value) in row.iter_mut().enumerate() {
                let (p0, pm) = (winner[y * w + x] as f64, median[y * w + x] as f64);
                if !p0.is_finite() || !pm.is_finite() || (p0 - pm).abs() <= moved {
                    continue;
                }
                let window = Window::around(images[0], x, y, RADIUS);
                let cost = |p| window.cost(plan, images, p);
                let (Some(c0), Some(cm)) = (cost(p0), cost(pm)) else {
                    continue;
                };
                if c0 < RATIO * cm && cm - c0 >= MARGIN {
                    *value = p0 as f32;
                    back += 1;
                }
            }
            back
        })
        .sum();
    (out, back)
}

/// A winner within this many plane steps of the mean of its four neighbours' winners is
/// *smooth* there: [`keep_smooth_winners`] keeps it against a small move of the median.
/// Measured on the depth set (96², 5 × 5, with backgammon): 0.03 lowers the mean BadPix 0.07
/// 7.72 → 7.16 %, backgammon 1.68 → 1.73; 0.1 gives 7.02 % but backgammon 1.83 and, on a
/// 7 × 7 grid, two shaded scenes 7–15 points worse; no test (keeping every small move)
/// 7.26 % with backgammon 2.14 (docs/depth.md, step 6c).
pub const SMOOTH_PLANES: f64 = 0.03;

/// Step 6c: the sweep's `winner` back wherever the median (`median`, after [`arbitrate`])
/// moved it by at most [`MOVED_PLANES`] planes of `step` and the winner is smooth at the
/// pixel ([`SMOOTH_PLANES`]), unless the views are `noisy`
/// ([`is_noisy`](super::photometric::is_noisy)). The median's window is wide (radius 14) and
/// on a curved surface of one colour its value is a neighbour's from the flatter bulk of the
/// surface, which the fit's prior then holds: the median flattened `shaded-column`'s curved
/// flank and `sphere`'s cap by a fraction of a plane. Where the winner is rough (noise, a
/// fattened or jagged edge) or the views noisy, the median is what removes the noise and stays.
/// Maps of different lengths, or a `width` that does not divide them, come back as `median`.
/// `median` is updated in place and returned, with how many pixels took the winner where the
/// median had moved them.
pub fn keep_smooth_winners(
    width: usize,
    step: f64,
    winner: &[f32],
    mut median: Vec<f32>,
    noisy: bool,
) -> (Vec<f32>, usize) {
    let n = median.len();
    if noisy || winner.len() != n || width == 0 || n % width != 0 {
        return (median, 0);
    }
    let (w, h) = (width, n / width);
    let (moved, smooth) = (MOVED_PLANES * step.abs(), SMOOTH_PLANES * step.abs());
    let kept = median
        .par_chunks_mut(w)
        .enumerate()
        .map(|(y, row)| {
            let mut kept = 0;
            let at = |x: usize, y: usize| winner[y * w + x] as f64;
            for (x, value) in row.iter_mut().enumerate() {
                let (p0, pm) = (at(x, y), *value as f64);
                // Non-finite values (and neighbours) fail every comparison and stay.
                let small_move = (p0 - pm).abs() <= moved;
                if p0 == pm || !small_move {
                    continue;
                }
                let mean = (at(x.saturating_sub(1), y)
                    + at((x + 1).min(w - 1), y)
                    + at(x, y.saturating_sub(1))
                    + at(x, (y + 1).min(h - 1)))
                    / 4.0;
                if (p0 - mean).abs() <= smooth {
                    *value = p0 as f32;
                    kept += 1;
                }
            }
            kept
        })
        .sum();
    (median, kept)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::depth::fixtures::SetScene;

    /// `truth` with every pixel within `band` pixels of a nearer neighbour (more than a
    /// disparity of `jump` nearer) given that neighbour's value: the nearer surface widened.
    fn widened(truth: &[f32], w: usize, band: usize, jump: f32) -> (Vec<f32>, Vec<usize>) {
        let h = truth.len() / w;
        let mut out = truth.to_vec();
        let mut moved = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let mut near = truth[i];
                for yy in y.saturating_sub(band)..(y + band + 1).min(h) {
                    for xx in x.saturating_sub(band)..(x + band + 1).min(w) {
                        near = near.max(truth[yy * w + xx]);
                    }
                }
                if near - truth[i] > jump {
                    out[i] = near;
                    moved.push(i);
                }
            }
        }
        (out, moved)
    }

    /// `shaded-column` (a grey column and ball before a grey wall): the colour-weighted
    /// median, run on the exact map, hands the ball's shadowed half and the column's shaded
    /// edge the wall's depth; with the exact map as the winner, the views take most of them
    /// back, and no pixel the median left right is changed.
    #[test]
    fn a_median_that_erased_a_shaded_surface_is_overruled() {
        let fixture = SetScene::new("shaded-column");
        let (scene, plan, images) = (&fixture.scene, &fixture.plan, fixture.images());
        let truth = &scene.truth;
        let params = crate::depth::SweepParams::default();
        let median = crate::depth::median::weighted_median_twice(
            truth,
            images[0],
            params.median_radius,
            params.median_sigma as f32,
        );
        // Another surface's value: more than 3 planes off (the median also moves a slanted
        // floor by a fraction of a plane, which is not the concern here).
        let jump = 3.0 * plan.step().abs() as f32;
        let wrong: Vec<usize> = (0..truth.len())
            .filter(|&i| (median[i] - truth[i]).abs() > jump)
            .collect();
        assert!(
            wrong.len() > 50,
            "{} pixels the median got wrong",
            wrong.len()
        );
        let (out, back) = arbitrate(plan, &images, truth, &median);
        let restored = wrong.iter().filter(|&&i| out[i] == truth[i]).count();
        eprintln!("{restored} of {} restored ({back} back)", wrong.len());
        // Measured: 103 of 196 (0 without the step); the rest agree with both values alike.
        assert!(
            restored * 5 >= wrong.len() * 2,
            "{restored} of {}",
            wrong.len()
        );
        let (right, changed) = (0..truth.len())
            .filter(|&i| (median[i] - truth[i]).abs() <= 0.07)
            .fold((0, 0), |(n, c), i| {
                (n + 1, c + usize::from(out[i] != median[i]))
            });
        assert!(
            changed * 100 <= right,
            "{changed} of {right} right pixels changed"
        );
        // A median that agrees with the winner is left alone.
        assert_eq!(arbitrate(plan, &images, truth, truth), (truth.to_vec(), 0));
        // Maps of the wrong size come back unchanged.
        assert_eq!(
            arbitrate(plan, &images, &truth[1..], truth).0,
            truth.to_vec()
        );
    }

    /// A smooth dome (a paraboloid of values) that a median flattened by half a plane keeps
    /// its own values; where the winner is rough (every other pixel half a plane off), where
    /// the median moved it by more than a plane, or on noisy views, the median's value stays.
    #[test]
    fn a_smooth_winner_keeps_its_value_against_a_small_median_move() {
        let (w, h, step) = (32usize, 24usize, 0.5f64);
        let dome: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 - 16.0, (i / w) as f32 - 12.0);
                3.0 - 0.002 * (x * x + y * y)
            })
            .collect();
        let flattened: Vec<f32> = dome.iter().map(|v| v - 0.25).collect();
        let (out, kept) = keep_smooth_winners(w, step, &dome, flattened.clone(), false);
        // The paraboloid's Laplacian is uniform: the dome is smooth at every pixel inside,
        // and at the clamped border the neighbour mean moves by at most a fraction.
        assert!(kept >= (w - 2) * (h - 2), "{kept} kept");
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                assert_eq!(out[y * w + x], dome[y * w + x], "({x}, {y})");
            }
        }
        // Rough: a checkerboard of ±0.25 planes on the dome.
        let rough: Vec<f32> = dome
            .iter()
            .enumerate()
            .map(|(i, v)| {
                v + if (i % w + i / w) % 2 == 0 {
                    0.125
                } else {
                    -0.125
                }
            })
            .collect();
        let (out, kept) = keep_smooth_winners(w, step, &rough, flattened.clone(), false);
        assert_eq!((out, kept), (flattened.clone(), 0));
        // Moved by more than a plane: step 6b's business, not this step's.
        let far: Vec<f32> = dome.iter().map(|v| v - 0.6).collect();
        assert_eq!(
            keep_smooth_winners(w, step, &dome, far.clone(), false),
            (far, 0)
        );
        // Noisy views, or maps of the wrong size: the median unchanged.
        assert_eq!(
            keep_smooth_winners(w, step, &dome, flattened.clone(), true),
            (flattened.clone(), 0)
        );
        assert_eq!(
            keep_smooth_winners(w, step, &dome[1..], flattened.clone(), false),
            (flattened.clone(), 0)
        );
        // A non-finite winner next to a pixel makes that pixel's neighbour mean non-finite.
        let mut holed = dome.clone();
        holed[5 * w + 5] = f32::NAN;
        let (out, _) = keep_smooth_winners(w, step, &holed, flattened.clone(), false);
        assert_eq!(out[5 * w + 5], flattened[5 * w + 5]);
        assert_eq!(out[5 * w + 6], flattened[5 * w + 6]);
        assert_eq!(out[5 * w + 8], dome[5 * w + 8]);
    }

    /// The dark, faint wall behind the bust (`bust`): a winner fattened into the wall by
    /// 2 px agrees almost as well as the wall's own depth, so the median's (true) value
    /// stays on nearly all of it.
    #[test]
    fn fattening_into_a_faint_wall_is_not_given_back() {
        let fixture = SetScene::new("bust");
        let (scene, plan, images) = (&fixture.scene, &fixture.plan, fixture.images());
        let (w, truth) = (plan.width as usize, &scene.truth);
        let (fattened, band) = widened(truth, w, 2, 0.3);
        assert!(band.len() > 100, "{} band pixels", band.len());
        let (out, back) = arbitrate(plan, &images, &fattened, truth);
        eprintln!("{back} of {} fattened pixels given back", band.len());
        assert!(back * 20 <= band.len(), "{back} of {}", band.len());
        assert!(band.iter().filter(|&&i| out[i] != truth[i]).count() == back);
    }
}
