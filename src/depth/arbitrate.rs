//! The sweep's winner against the colour-weighted median, pixel by pixel (docs/depth.md,
//! step 6b).
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
