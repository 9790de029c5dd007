//! Depth edges placed to the pixel.
//!
//! The sweep's windows and the median place a silhouette to within a pixel: a window that
//! straddles the edge takes the side with more texture, and the median's window the side with
//! more pixels. One pixel is a lot to what stands on the map: anti-aliased refocus blurs a
//! focused card's last column into the background's blur, or leaves a background column sharp
//! next to it (synth `layers` with the estimate: 30 levels of error along the card's edges,
//! most of the gap to the true depth's score).
//!
//! Each pixel next to a depth jump (a neighbour more than [`JUMP_PLANES`] plane steps away)
//! chooses between its own value and the sides of the jump (the median of the neighbours
//! nearer, and of those farther, where [`SIDE_SUPPORT`] of the 8 are) by how well the views
//! agree *at that pixel alone*: the mean colour difference between the reference's pixel and
//! the views' samples at the candidate, over the [`AGREEING_SHARE`] of the views that agree
//! best (an occluder hides the pixel from some views). It moves only when the other side
//! agrees clearly better ([`NEARER_RATIO`], [`FARTHER_RATIO`], [`SWITCH_MARGIN`]) and its own
//! side shows texture ([`MIN_TEXTURE`]): on a flat surface one pixel cannot tell, and the
//! value stays.
//!
//! Measured on the depth test set (`tiltfield depth-set --variants default,no-snap` with
//! backgammon and `layers`, docs/depth.md): mean BadPix 0.07 8.69 → 8.50 %, MSE × 100 13.0 →
//! 10.8 (planes 2.30 → 1.48 %, wide 9.08 → 8.33 %, MSE 49.7 → 32.2, layers 3.11 → 2.32 %,
//! thin 9.61 → 9.47 %), and the anti-aliased refocus on `layers`' estimate 37.1 → 40.9 dB
//! against the lens. Where it fails: the curved outline of `sphere` 6.48 → 6.80 % (MSE 0.68
//! → 1.46): an outline is not a fixed surface point, its edge pixels agree with no depth
//! across the views; `bust` 13.27 → 13.31 % (MSE 4.8 → 5.1). Without the texture test the
//! mean was 8.33 % and `layers` 1.45 %, but the dark wall in the bust's neck went to the bust
//! (MSE 6.1; at 64 px 5.6, over the 5 the set's test allows). Also without it, and with one
//! ratio of 0.4 both ways: half-apertures instead of the best share of the views 8.43 %,
//! with the bust's MSE at 7.4.

use glam::{DVec2, DVec3};
use image::RgbaImage;
use rayon::prelude::*;

use super::cpu::bilinear;
use super::sweep::SweepPlan;

/// A pixel is at a depth edge when a neighbour's value is more than this many plane steps
/// away from its own (the fit's own edge test, `RefineParams::edge_planes`).
pub const JUMP_PLANES: f64 = 3.0;
/// A side of the jump is a candidate when at least this many of the 8 neighbours lie on it
/// (one or two are more often the estimate's stray values than a surface).
pub const SIDE_SUPPORT: usize = 3;
/// The cost of a candidate: the mean colour difference over this share of the views, those
/// that agree best (the fit's occlusion quantile, [`super::refine::OCCLUSION_QUANTILE`]: next
/// to a nearer surface, or in a concave corner of the background, most views can be
/// occluded, on more than one side).
pub const AGREEING_SHARE: f64 = super::refine::OCCLUSION_QUANTILE;
/// A nearer side's cost must be below this fraction of the pixel's own to take it...
pub const NEARER_RATIO: f64 = 0.4;
/// ...a farther side's below this (a curved silhouette's edge pixels agree with no depth and
/// were taken for the wall behind at 0.4; measured without the texture test: `bust` 13.6 →
/// 13.5 %, `wide` 7.4 → 7.1 %)...
pub const FARTHER_RATIO: f64 = 0.2;
/// ...and lower by at least this much (mean absolute difference of encoded channels).
pub const SWITCH_MARGIN: f64 = 2.0 / 255.0;
/// The pixel's own side must show texture: its colour range (largest channel's, 8-bit levels)
/// over the pixel and its neighbours on its own side of the jump. On a flat wall one pixel
/// agrees with many depths (the dark wall in a bust's neck went to the bust).
pub const MIN_TEXTURE: u8 = 8;

/// The mean of the [`AGREEING_SHARE`] of `costs` that are lowest (the views that agree best;
/// at least one); `None` when there are none. Reorders `costs`.
pub(super) fn mean_of_agreeing(costs: &mut [f64]) -> Option<f64> {
    if costs.is_empty() {
        return None;
    }
    costs.sort_by(f64::total_cmp);
    let k = ((AGREEING_SHARE * costs.len() as f64).ceil() as usize).clamp(1, costs.len());
    Some(costs[..k].iter().sum::<f64>() / k as f64)
}

/// The 8 neighbours of pixel `(x, y)` inside a `w × h` image, row by row.
fn neighbours(
    (x, y): (usize, usize),
    (w, h): (usize, usize),
) -> impl Iterator<Item = (usize, usize)> {
    (y.saturating_sub(1)..(y + 2).min(h))
        .flat_map(move |yy| (x.saturating_sub(1)..(x + 2).min(w)).map(move |xx| (xx, yy)))
        .filter(move |&p| p != (x, y))
}

/// The mean absolute colour difference between the reference's colour `c` at pixel `x` and
/// the views sampled at parameter `p` (`images[k + 1]` is `plan.views[k]`'s), over the
/// [`AGREEING_SHARE`] of the views inside their images that agree best; `None` without any.
fn cost(plan: &SweepPlan, images: &[&RgbaImage], c: [f64; 3], x: DVec2, p: f64) -> Option<f64> {
    let (wf, hf) = (plan.width as f64 - 0.5, plan.height as f64 - 0.5);
    let mut d: Vec<f64> = plan
        .views
        .iter()
        .zip(&images[1..])
        .filter_map(|(view, img)| {
            let q = view.sample(x, p);
            let (u, v) = (q.x / q.z, q.y / q.z);
            if q.z <= 0.0 || u < -0.5 || v < -0.5 || u > wf || v > hf {
                return None;
            }
            let s = bilinear(img, u, v);
            Some(((s[0] - c[0]).abs() + (s[1] - c[1]).abs() + (s[2] - c[2]).abs()) / 3.0)
        })
        .collect();
    mean_of_agreeing(&mut d)
}

/// `param` (the sweep parameter of `plan` per reference pixel, row-major; non-finite where
/// unknown) with each pixel at a depth edge moved to the side of the edge its views agree on
/// (module docs). `images` are the reference, then one per `plan.views`, all of the plan's
/// size; anything else returns `param` unchanged.
pub fn snap_edges(plan: &SweepPlan, images: &[&RgbaImage], param: &[f32]) -> Vec<f32> {
    let (w, h) = (plan.width as usize, plan.height as usize);
    if images.len() != plan.views.len() + 1
        || param.len() != w * h
        || images
            .iter()
            .any(|i| (i.width() as usize, i.height() as usize) != (w, h))
    {
        return param.to_vec();
    }
    let jump = JUMP_PLANES * plan.step().abs();
    let reference = images[0];
    let mut out = param.to_vec();
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, value) in row.iter_mut().enumerate() {
            let p0 = param[y * w + x] as f64;
            if !p0.is_finite() {
                continue;
            }
            let px = reference.get_pixel(x as u32, y as u32).0;
            // The neighbours across a jump, nearer and farther, and the colour range of the
            // pixel's own side.
            let (mut nearer, mut farther) = (Vec::with_capacity(8), Vec::with_capacity(8));
            let (mut lo, mut hi) = ([px[0], px[1], px[2]], [px[0], px[1], px[2]]);
            for (xx, yy) in neighbours((x, y), (w, h)) {
                let q = param[yy * w + xx] as f64;
                if q > p0 + jump {
                    nearer.push(q);
                } else if q < p0 - jump {
                    farther.push(q);
                } else if q.is_finite() {
                    let n = reference.get_pixel(xx as u32, yy as u32).0;
                    for k in 0..3 {
                        lo[k] = lo[k].min(n[k]);
                        hi[k] = hi[k].max(n[k]);
                    }
                }
            }
            if (0..3).all(|k| hi[k] - lo[k] < MIN_TEXTURE) {
                continue;
            }
            // Each side must be a region (SIDE_SUPPORT of the 8), not a stray value, and
            // offers its median.
            let side = |mut v: Vec<f64>| {
                (v.len() >= SIDE_SUPPORT).then(|| {
                    v.sort_by(f64::total_cmp);
                    v[v.len() / 2]
                })
            };
            let candidates = [side(nearer), side(farther)];
            if candidates.iter().all(Option::is_none) {
                continue;
            }
            let c = std::array::from_fn(|k| px[k] as f64 / 255.0);
            let at = DVec2::new(x as f64, y as f64);
            let Some(own) = cost(plan, images, c, at, p0) else {
                continue;
            };
            let mut best = (own, p0);
            for p in candidates.into_iter().flatten() {
                let ratio = if p > p0 { NEARER_RATIO } else { FARTHER_RATIO };
                if let Some(e) = cost(plan, images, c, at, p) {
                    if e < best.0 && e < ratio * own && own - e >= SWITCH_MARGIN {
                        best = (e, p);
                    }
                }
            }
            *value = best.1 as f32;
        }
    });
    out
}

/// Mixed outline pixels go to the side their colour belongs to: the pixel straddling a
/// silhouette averages the two surfaces' light over its footprint, while its true depth is
/// that of the surface under its centre, which is the farther one when the nearer covers
/// less than half of it. The sweep and the fit give such a pixel the nearer surface (its
/// colour differs from the wall's, and the nearer surface's texture carries the windows): a
/// one-pixel halo of the full depth jump, most of the squared error of smooth shaded objects
/// before a dark wall.
///
/// A pixel next to a farther side (at least [`UNMIX_SUPPORT`] of its 8 neighbours more than
/// [`JUMP_PLANES`] plane steps farther, and as many on its own side) takes the median of the
/// farther neighbours when its colour c, in linear light, is a mix of the two sides' colours
/// with clearly less than half of its own: with `b` the farther neighbours' mean colour and
/// `f` the own-side neighbour least like `b` (the nearer surface's interior), the coverage
/// `α = (c − b)·(f − b) / |f − b|²` below [`UNMIX_COVERAGE`], c within [`UNMIX_RESIDUAL`] ·
/// |f − b| of the line through b and f, the sides at least [`UNMIX_SEPARATION`] levels apart
/// and the farther side flat (every farther neighbour within [`UNMIX_SPREAD`] · |f − b| of
/// `b`, channel by channel). One pass, each pixel judged on the map as it came in.
///
/// Measured (`depth-set`, 96², 5 × 5, against the map before this step; docs/depth.md): the
/// MSE × 100 of the three shaded scenes and the unlit bust fell by a third or more, while the
/// dark card on a bright wall (`wide`, `converging`) lost a few percent: there the outlines
/// run through pixel centres, coverage is one half and the centre ray's side is a tie. In
/// encoded sRGB values instead of linear light, a dark card's mixed pixels looked mostly
/// wall and went to it (`converging` 21.4 → 28.1); coverage up to 0.5 instead of 0.4 sent
/// those ties to the wall too.
pub fn unmix_outlines(plan: &SweepPlan, reference: &RgbaImage, param: &[f32]) -> Vec<f32> {
    let (w, h) = (plan.width as usize, plan.height as usize);
    if param.len() != w * h || (reference.width() as usize, reference.height() as usize) != (w, h) {
        return param.to_vec();
    }
    let jump = JUMP_PLANES * plan.step().abs();
    // Coverage mixes light, not encoded values: linear light, in 8-bit levels.
    let decode = crate::color::decode_table().map(|v| 255.0 * v);
    let colour = |x: usize, y: usize| {
        let p = reference.get_pixel(x as u32, y as u32).0;
        DVec3::new(
            decode[p[0] as usize],
            decode[p[1] as usize],
            decode[p[2] as usize],
        )
    };
    let mut out = param.to_vec();
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, value) in row.iter_mut().enumerate() {
            let p0 = param[y * w + x] as f64;
            if !p0.is_finite() {
                continue;
            }
            let (mut farther, mut own) = (Vec::with_capacity(8), Vec::with_capacity(8));
            for (xx, yy) in neighbours((x, y), (w, h)) {
                let q = param[yy * w + xx] as f64;
                if q < p0 - jump {
                    farther.push((q, colour(xx, yy)));
                } else if (q - p0).abs() <= jump {
                    own.push(colour(xx, yy));
                }
            }
            if farther.len() < UNMIX_SUPPORT || own.len() < UNMIX_SUPPORT {
                continue;
            }
            let b = farther.iter().map(|f| f.1).sum::<DVec3>() / farther.len() as f64;
            let l1 = |v: DVec3| v.x.abs() + v.y.abs() + v.z.abs();
            let f = own
                .iter()
                .copied()
                .max_by(|m, n| l1(*m - b).total_cmp(&l1(*n - b)))
                .unwrap_or(b);
            let d = f - b;
            let sep = d.length();
            if sep < UNMIX_SEPARATION {
                continue;
            }
            let flat = farther
                .iter()
                .all(|(_, n)| (*n - b).abs().max_element() <= UNMIX_SPREAD * sep);
            let c = colour(x, y);
            let alpha = (c - b).dot(d) / (sep * sep);
            let residual = (c - (b + alpha * d)).length();
            if flat
                && (-UNMIX_BELOW..UNMIX_COVERAGE).contains(&alpha)
                && residual <= UNMIX_RESIDUAL * sep
            {
                let mut values: Vec<f64> = farther.iter().map(|f| f.0).collect();
                values.sort_by(f64::total_cmp);
                *value = values[values.len() / 2] as f32;
            }
        }
    });
    out
}

/// [`unmix_outlines`]: the fewest neighbours on each side.
pub const UNMIX_SUPPORT: usize = 2;
/// ... the largest share of the nearer surface's light a pixel given the farther side may
/// hold (its centre lies on the farther surface when the nearer covers less than half of it;
/// 0.4 leaves the ties at one half alone) ...
pub const UNMIX_COVERAGE: f64 = 0.4;
/// ... how far beyond the farther colour α may lie (noise on a flat wall) ...
pub const UNMIX_BELOW: f64 = 0.25;
/// ... the largest distance of the pixel's colour from the line between the sides' colours,
/// relative to their distance ...
pub const UNMIX_RESIDUAL: f64 = 0.2;
/// ... the largest spread of the farther side's colours, relative to the same ...
pub const UNMIX_SPREAD: f64 = 0.1;
/// ... and the sides' least colour distance (RGB, linear light in 8-bit levels): below it a
/// textured surface's own variation passes for a mix.
pub const UNMIX_SEPARATION: f64 = 20.0;

#[cfg(test)]
mod tests {
    use super::*;

    /// The `planes` scene (a textured card before a textured back plane) with its exact
    /// disparity: of the card narrowed or widened by one pixel along its edges, the pixels
    /// the views clearly tell are put back, and the exact map is left as it is.
    #[test]
    fn a_silhouette_one_pixel_off_is_put_back() {
        let fixture = crate::depth::fixtures::SetScene::new("planes");
        let (scene, plan, images) = (&fixture.scene, &fixture.plan, fixture.images());
        let lf = &scene.light_field;
        let (w, h) = (lf.width as usize, lf.height as usize);
        // HCI convention: the sweep parameter is the disparity.
        let truth = &scene.truth;
        let step = JUMP_PLANES * plan.step().abs();
        // One pixel off either way: the background pixels next to the (nearer, larger
        // disparity) card take the card's value (it is widened), or the card's edge pixels
        // take the background's (it is narrowed).
        let mut widened = truth.clone();
        let mut narrowed = truth.clone();
        let (mut outside, mut inside) = (Vec::new(), Vec::new());
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let i = y * w + x;
                let around = [i - 1, i + 1, i - w, i + w].map(|j| truth[j]);
                let near = around.into_iter().fold(f32::NEG_INFINITY, f32::max);
                let far = around.into_iter().fold(f32::INFINITY, f32::min);
                if (near - truth[i]) as f64 > step {
                    widened[i] = near;
                    outside.push(i);
                }
                if (truth[i] - far) as f64 > step {
                    narrowed[i] = far;
                    inside.push(i);
                }
            }
        }
        assert!(outside.len() > 40 && inside.len() > 40);
        let restored = |map: &[f32], moved: &[usize]| {
            let snapped = snap_edges(plan, &images, map);
            let n = moved
                .iter()
                .filter(|&&i| (snapped[i] - truth[i]).abs() < 0.1)
                .count();
            eprintln!("{n} of {} restored", moved.len());
            n as f64 / moved.len() as f64
        };
        // Measured: 24 of 61 narrowed pixels and 10 of 62 widened ones (a move to the farther
        // side must agree five times better, FARTHER_RATIO); none without the step. Only
        // the pixels whose views clearly tell move: the rest stay as they were given.
        assert!(restored(&narrowed, &inside) >= 0.3);
        assert!(restored(&widened, &outside) >= 0.1);
        let moved = outside.len();
        let kept = snap_edges(plan, &images, truth);
        let changed = (0..w * h).filter(|&i| kept[i] != truth[i]).count();
        assert!(changed * 20 <= moved, "{changed} exact values changed");
        // A map of the wrong size is returned unchanged.
        assert_eq!(snap_edges(plan, &images, &truth[1..]), truth[1..].to_vec());
    }

    /// A bright disc before a dark flat wall whose map holds the disc one pixel too wide (the
    /// sweep's halo): the ring's pixels, a quarter covered by the disc, go back to the wall;
    /// edge pixels three quarters covered, and a disc too like the wall to tell, stay.
    #[test]
    fn mixed_outline_pixels_go_to_the_surface_under_their_centre() {
        let fixture = crate::depth::fixtures::SetScene::new("planes");
        let plan = &fixture.plan;
        let (w, h) = (plan.width as usize, plan.height as usize);
        let (wall, disc) = (0.0f32, (10.0 * plan.step().abs()) as f32);
        let r = |x: usize, y: usize| (x as f64 - 32.0).hypot(y as f64 - 32.0);
        // Inside radius 10 the disc, the ring out to 11 three quarters disc, out to 12 one
        // quarter: mixed in linear light and stored as sRGB.
        let cover = |x: usize, y: usize| match r(x, y) {
            d if d < 10.0 => 1.0,
            d if d < 11.0 => 0.75,
            d if d < 12.0 => 0.25,
            _ => 0.0,
        };
        let image = |bright: f64| {
            let dark = crate::color::srgb_to_linear(20.0 / 255.0);
            RgbaImage::from_fn(w as u32, h as u32, |x, y| {
                let a = cover(x as usize, y as usize);
                let v = crate::color::encode_srgb8((a * bright + (1.0 - a) * dark) as f32);
                image::Rgba([v, v, v, 255])
            })
        };
        let map: Vec<f32> = (0..w * h)
            .map(|i| {
                if cover(i % w, i / w) > 0.0 {
                    disc
                } else {
                    wall
                }
            })
            .collect();
        let out = unmix_outlines(plan, &image(0.6), &map);
        let (mut ring, mut back) = (0, 0);
        for i in 0..w * h {
            let a = cover(i % w, i / w);
            if a == 0.25 {
                ring += 1;
                back += usize::from(out[i] == wall);
            } else {
                assert_eq!(out[i], map[i], "pixel {i} of coverage {a} moved");
            }
        }
        // Pixels of the quarter ring with fewer than two wall or disc neighbours stay.
        assert!(
            ring > 40 && back * 10 >= ring * 8,
            "{back} of {ring} back to the wall"
        );
        // A disc of nearly the wall's colour: nothing to tell a mix by.
        let faint = unmix_outlines(
            plan,
            &image(crate::color::srgb_to_linear(26.0 / 255.0)),
            &map,
        );
        assert_eq!(faint, map);
        // A map of the wrong size is returned unchanged.
        assert_eq!(
            unmix_outlines(plan, &image(0.6), &map[1..]),
            map[1..].to_vec()
        );
    }
}
