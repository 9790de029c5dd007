//! Boxed footprints: the default anti-aliasing's fast path (docs/antialias.md, "Boxed
//! footprints") and its f64 model. The GPU stage is `passes::refocus`'s boxed stage.
//!
//! **A box of the plain sum is the footprint integral.** For a parallel rig the footprint that
//! view i's aperture cell sweeps at output pixel x is the cell's rectangle times the residual
//! `d = s − σ` around the view's sample `y_i = H_i x`, and `H_i(x + v) = H_i x + v`: so the
//! integral of view i over its footprint is the mean of its plain samples over the box
//! `x + d·R_i` of output pixels. Views whose cells have one shape share the box: the box of
//! their plain sum. So a pixel away from occlusion edges needs no sample beyond the plain
//! sum's: one pass sums the views per cell shape ([`super::layered::cell_groups`]; a rim
//! cell's view is sampled at its part's centroid for the pixel's own residual), a summed-area
//! table of each shape's sums gives any box in a constant number of reads, and the pixel is
//! the boxes' sum at its own residual ([`box_size`]: the footprint's own width, whose zeros
//! cancel the lattice of the neighbouring cells' copies).
//!
//! **Small footprints take the sub-samples.** Under [`MIN_BOX_PX`] the copies' lattice lies
//! near the pixel grid's Nyquist frequency: the plain samples no longer carry it for a box to
//! cancel, while a view's sub-samples integrate it before the grid samples it.
//!
//! **Occlusion only at depth edges.** A nearer surface matters to a pixel only where it can
//! cut one of the rays its sub-samples follow: within the rays' reach (the longest ray's
//! parallax times the residuals) and with a step in depth steeper than the rays (a smooth
//! surface whose inverse depth changes by less than a ray travels cannot cross it twice).
//! [`needs_tests`] decides that from the nearest surface within 1, 2, 4, … 64 pixels
//! ([`SceneDepth::fronts`], made once per depth map); such pixels, and pixels whose own
//! surface is in focus (Catmull-Rom per view), take the per-sample integral of
//! [`super::antialias`] as before. Where the views agree at the focus surface (the focus
//! test) the pixel is their plain sum, as before.
//!
//! **Where it is approximate.** A converging rig or a tilted plane makes `H_i` projective, so
//! the box in output pixels is the footprint to first order; the box takes the pixel's own
//! residual while a neighbour's plain sample may lie on a surface of another depth (only a
//! farther one: nearer ones are [`needs_tests`]'s edges).

use glam::DVec2;
use rayon::prelude::*;

use super::antialias::{AntialiasPlan, SceneDepth};
use super::cpu;
use super::Averaging;
use crate::lightfield::LightField;

/// Radii of the nearest-surface maps: 1, 2, 4, … 64 px (the front search's own limit).
pub const FRONT_LEVELS: usize = 7;

/// The widest box, in pixels per axis: the GPU's integer tables are exact while a box holds
/// at most 65 536 pixels of 16-bit values.
pub const MAX_BOX_PX: f64 = 255.0;

/// The GPU's tables hold a group's sums over the plan's total weight in units of 1/QUANT
/// (16-bit: room for colours up to 4 in the averaging space; the views' 8-bit values reach 1).
pub const QUANT: f64 = 16384.0;

/// The smallest footprint (px, of a full cell) the box stands for; smaller ones take the
/// sub-samples. Below about two and a half pixels the lattice of the plain sum's copies lies
/// near the pixel grid's Nyquist frequency, where the plain samples no longer carry it for a
/// box to cancel: over the anti-aliasing set, boxes from 2 px lost 0.7 dB on `layers-small`
/// and from 0 px 0.3–1.1 dB on `layers-tilted`, `layers-small` and `room`; from 2.5 px no
/// case lost.
pub const MIN_BOX_PX: f64 = 2.5;

/// The nearest surface (largest σ) within `2^j` px of every pixel, level after level
/// (`FRONT_LEVELS × w × h`; −1 where none), by doubling: the window of radius 2r is the
/// union of the radius-r windows at ±r.
pub fn front_levels(sigma: &[f32], (w, h): (usize, usize)) -> Vec<f32> {
    let mut out = Vec::with_capacity(FRONT_LEVELS * w * h);
    let pass = |src: &[f32], r: usize, along_x: bool| -> Vec<f32> {
        let mut dst = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let at = |dx: i64| {
                    if along_x {
                        src[y * w + (x as i64 + dx).clamp(0, w as i64 - 1) as usize]
                    } else {
                        src[(y as i64 + dx).clamp(0, h as i64 - 1) as usize * w + x]
                    }
                };
                dst[y * w + x] = if r == 1 {
                    at(-1).max(at(0)).max(at(1))
                } else {
                    at(-(r as i64) / 2).max(at(r as i64 / 2))
                };
            }
        }
        dst
    };
    let mut level = sigma.to_vec();
    for j in 0..FRONT_LEVELS {
        // Level j from level j − 1 (radius 2^(j−1) → 2^j), or the depth itself (0 → 1).
        level = pass(&pass(&level, 1 << j, true), 1 << j, false);
        out.extend_from_slice(&level);
    }
    out
}

/// The pixel's own surface's slope along x plus along y (σ per pixel): per axis the smaller
/// of the two one-sided differences, so that a step next to the pixel does not count as its
/// slope; the one there is where a neighbour is unknown or outside, 0 where both are.
pub fn own_slope(sigma: &[f32], (w, h): (usize, usize), i: usize) -> f64 {
    let (x, y) = ((i % w) as i64, (i / w) as i64);
    let at = |dx: i64, dy: i64| {
        let (xx, yy) = (x + dx, y + dy);
        if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
            return None;
        }
        let v = sigma[yy as usize * w + xx as usize];
        (v >= 0.0).then_some(v as f64)
    };
    let c = sigma[i] as f64;
    let axis = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => (a - c).abs().min((c - b).abs()),
        (Some(v), None) | (None, Some(v)) => (v - c).abs(),
        (None, None) => 0.0,
    };
    axis(at(1, 0), at(-1, 0)) + axis(at(0, 1), at(0, -1))
}

/// Whether pixel `i` (focus inverse depth `s`, own σ) needs the per-sample occlusion tests:
/// within one of [`FRONT_LEVELS`]' windows a nearer surface stands out of the pixel's own
/// (the nearest σ lies above σ by more than the own slope accounts for over the window, by
/// at least a pixel of ray travel: a smooth surface never crosses a ray twice) and a ray of
/// the pixel's aperture can reach it (`ray_px`: the longest ray's parallax, px per unit of
/// inverse depth; a ray meets the nearer surface `ray_px·|s − f|` away, and a view's
/// footprint sees it up to `ray_px·(|s − σ| + f − σ)` away). Window j's pixels outside window
/// j − 1 lie at least `2^(j−1) + 1` px away (1 px for window 0), and its nearer surfaces'
/// σ are at most level j's: both bounds are conservative. False where the depth has no front
/// maps (occlusion tests off).
pub fn needs_tests(depth: &SceneDepth, i: usize, s: f64, sigma: f64, ray_px: f64) -> bool {
    let n = depth.inverse_depth.len();
    if depth.fronts.len() != FRONT_LEVELS * n || ray_px <= 0.0 {
        return false;
    }
    let size = (depth.width as usize, depth.height as usize);
    let slope = own_slope(&depth.inverse_depth, size, i);
    (0..FRONT_LEVELS).any(|j| {
        let near = depth.fronts[j * n + i] as f64;
        let step = near - sigma - slope * (1u32 << j) as f64;
        let dmin = if j == 0 {
            1.0
        } else {
            (1u32 << (j - 1)) as f64 + 1.0
        };
        let reach = ray_px * (s - near).abs().max((s - sigma).abs() + near - sigma) + 2.0;
        step * ray_px >= 1.0 && reach >= dmin
    })
}

/// The rays' longest parallax of `aa`'s cells, in px per unit of inverse depth: over every
/// view and the corners of its cell, the reference-image offset per unit of `s − c` of the
/// ray through that aperture point (the occlusion tests' `ray`, docs/conventions.md §11).
pub fn ray_px(aa: &AntialiasPlan) -> f64 {
    aa.footprints
        .iter()
        .flat_map(|f| {
            [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .map(|(u, v)| (f.parallax + f.offset(u, v, 1.0)).truncate().length())
        })
        .fold(0.0, f64::max)
}

/// Whether any pixel of `aa` at the views' size `(w, h)` can take a box: on a depth handed over
/// with the light field (an estimate's silhouettes are not where its map puts them, and the
/// edge test trusts the map: on estimated depth boxes cost 0.3 dB of the set's focused mean,
/// `layers-small`'s card 45.6 → 43.0 dB), where the largest residual between the plane (its
/// extremes lie at the image's corners) and the depth's range reaches [`MIN_BOX_PX`] of a full
/// cell's footprint. Where it cannot (an estimate, a dense light field, a shallow scene) the
/// pass skips the boxed stage, whose result would be the sub-samples'.
pub fn can_box(aa: &AntialiasPlan, (w, h): (u32, u32)) -> bool {
    if aa.guard_px > 0.0 {
        return false;
    }
    let (groups, _, _) = super::layered::cell_groups(aa, (w, h));
    let (slo, shi) = super::layered::focus_range(aa, (w, h));
    let valid = aa.depth.inverse_depth.iter().filter(|v| **v >= 0.0);
    let (dlo, dhi) = valid.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
        (a.min(v as f64), b.max(v as f64))
    });
    // No valid depth leaves the fold at (inf, -inf).
    if dhi < dlo {
        return false;
    }
    let reach = (shi - dlo).abs().max((slo - dhi).abs());
    reach * full_px(&groups) >= MIN_BOX_PX
}

/// Per output pixel of the boxed model at the views' size: the pixel's (sum, weight) where
/// the fast path decides it (the box, the focus test's plain sum, or the plain sum where the
/// pixel has no depth), `None` where the per-sample integral does (edges, focused pixels).
pub fn boxed_pixels(
    lf: &LightField,
    aa: &AntialiasPlan,
    averaging: Averaging,
    s_of: &(impl Fn(DVec2) -> f64 + Sync),
) -> Vec<Option<([f64; 3], f64)>> {
    let (w, h) = (lf.width as usize, lf.height as usize);
    let table = cpu::averaging_table(averaging);
    let (groups, group_of, _) = super::layered::cell_groups(aa, (lf.width, lf.height));
    let ng = groups.len();
    let rays = if aa.settings.occlusion {
        ray_px(aa)
    } else {
        0.0
    };
    let focused_reach = aa.focused_reach();
    let full = full_px(&groups);
    let pixel = |i: usize| DVec2::new((i % w) as f64, (i / w) as f64);
    // Per pixel: each group's sum of centroid samples (colour·weight, weight), and what the
    // pixel is when the fast path decides it without a box.
    enum Kind {
        Done(([f64; 3], f64)),
        Boxed(f64),
        Tested,
    }
    let per: Vec<(Vec<[f64; 4]>, Kind)> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let px = pixel(i);
            let s = s_of(px);
            let mut sums = vec![[0f64; 4]; ng];
            let sigma = aa.depth.at(px);
            // Every pixel's sums, whatever decides the pixel itself: its neighbours' boxes
            // read them.
            let d = sigma.map_or(0.0, |sg| s - sg);
            for (k, (v, fp)) in aa.plan.views.iter().zip(&aa.footprints).enumerate() {
                let y0 = v.warp.a * px.extend(1.0) + v.warp.b * s;
                if y0.z.is_nan() || y0.z <= 0.0 {
                    continue;
                }
                let Some(p) = cpu::inside(lf, y0 + fp.offset(0.5, 0.5, d)) else {
                    continue;
                };
                let c = cpu::bilinear(&lf.views[v.index].image, &table, p);
                let g = &mut sums[group_of[k]];
                for ch in 0..3 {
                    g[ch] += v.weight * c[ch];
                }
                g[3] += v.weight;
            }
            if let Some(agreed) = cpu::focus_test(lf, aa, &table, px, s) {
                return (sums, Kind::Done(agreed));
            }
            let tested = sigma.is_some_and(|sg| {
                let r = (s - sg).abs();
                r < focused_reach || r * full < MIN_BOX_PX || needs_tests(&aa.depth, i, s, sg, rays)
            });
            if tested {
                return (sums, Kind::Tested);
            }
            if sigma.is_none() {
                let total = sums
                    .iter()
                    .fold([0f64; 4], |a, g| std::array::from_fn(|k| a[k] + g[k]));
                return (sums, Kind::Done(([total[0], total[1], total[2]], total[3])));
            }
            (sums, Kind::Boxed(d))
        })
        .collect();
    let sums: Vec<Vec<[f64; 4]>> = (0..ng)
        .map(|g| per.iter().map(|(s, _)| s[g]).collect())
        .collect();
    per.par_iter()
        .enumerate()
        .map(|(i, (_, kind))| match kind {
            Kind::Done(r) => Some(*r),
            Kind::Tested => None,
            Kind::Boxed(d) => {
                let px = pixel(i);
                let mut total = [0f64; 4];
                for (unit, img) in groups.iter().zip(&sums) {
                    let m = nearest_box(img, (w, h), px, box_size(*unit, *d));
                    for k in 0..4 {
                        total[k] += m[k];
                    }
                }
                Some(([total[0], total[1], total[2]], total[3]))
            }
        })
        .collect()
}

/// The box of group `unit` (footprint px per unit residual along x and y) at residual `d`:
/// the footprint itself, at most [`MAX_BOX_PX`]. Its exact width, not one solved for the
/// footprint's variance: a box as wide as a cell's footprint cancels the lattice of the
/// neighbouring cells' copies (its zeros lie at their spacing), and a narrowed one left part
/// of it (the same scores at 2.5 px and up within 0.1 dB, 0.3 dB lower on `layers-small`).
pub fn box_size(unit: DVec2, d: f64) -> DVec2 {
    (unit * d.abs()).min(DVec2::splat(MAX_BOX_PX))
}

/// A full cell's footprint, px per unit residual: the longest side of any group's.
pub fn full_px(groups: &[DVec2]) -> f64 {
    groups.iter().fold(0.0, |a, g| a.max(g.x).max(g.y))
}

/// The mean of the nearest reconstruction of `img` (texels as squares) over the box of `size`
/// centred on pixel `px`, clipped to the image.
pub fn nearest_box(img: &[[f64; 4]], (w, h): (usize, usize), px: DVec2, size: DVec2) -> [f64; 4] {
    let axis = |n: usize, c: f64, e: f64| -> (usize, Vec<f64>) {
        let (a, b) = ((c - e / 2.0).max(-0.5), (c + e / 2.0).min(n as f64 - 0.5));
        if b.partial_cmp(&a) != Some(std::cmp::Ordering::Greater) {
            return (
                ((c + 0.5).floor().clamp(0.0, n as f64 - 1.0)) as usize,
                vec![1.0],
            );
        }
        let (i0, i1) = (
            ((a + 0.5).floor() as usize).min(n - 1),
            ((b + 0.5).ceil() as usize - 1).min(n - 1),
        );
        let w = (i0..=i1)
            .map(|i| ((b.min(i as f64 + 0.5) - a.max(i as f64 - 0.5)).max(0.0)) / (b - a))
            .collect();
        (i0, w)
    };
    let (x0, wx) = axis(w, px.x, size.x);
    let (y0, wy) = axis(h, px.y, size.y);
    let mut out = [0f64; 4];
    for (j, vy) in wy.iter().enumerate() {
        for (i, vx) in wx.iter().enumerate() {
            let f = img[(y0 + j) * w + x0 + i];
            for k in 0..4 {
                out[k] += vx * vy * f[k];
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn depth_of(sigma: Vec<f32>, (w, h): (usize, usize)) -> SceneDepth {
        SceneDepth {
            width: w as u32,
            height: h as u32,
            fronts: front_levels(&sigma, (w, h)),
            front: sigma.clone(),
            inverse_depth: sigma,
            front_radius: 0,
            unknown: 0,
            source: "test".into(),
        }
    }

    /// Every level is the brute-force maximum over its square window.
    #[test]
    fn front_levels_are_the_window_maxima() {
        let (w, h) = (37, 23);
        let sigma: Vec<f32> = (0..w * h)
            .map(|i| ((i * 7919 % 101) as f32 / 50.0) - 0.3)
            .collect();
        let levels = front_levels(&sigma, (w, h));
        for j in 0..FRONT_LEVELS {
            let r = 1i64 << j;
            for y in 0..h as i64 {
                for x in 0..w as i64 {
                    let mut m = -1f32;
                    for yy in (y - r).max(0)..=(y + r).min(h as i64 - 1) {
                        for xx in (x - r).max(0)..=(x + r).min(w as i64 - 1) {
                            m = m.max(sigma[(yy * w as i64 + xx) as usize]);
                        }
                    }
                    let i = (y * w as i64 + x) as usize;
                    assert_eq!(levels[j * w * h + i], m, "level {j} at ({x}, {y})");
                }
            }
        }
    }

    /// A smooth slope is no edge however far out of focus; a step nearer is one where the
    /// rays reach it, and not where they fall short of it.
    #[test]
    fn only_reachable_steps_need_the_tests() {
        let (w, h) = (64, 8);
        let ray = 4.0;
        let slope = depth_of(
            (0..w * h).map(|i| 1.0 + 0.05 * (i % w) as f32).collect(),
            (w, h),
        );
        for s in [0.0, 1.0, 5.0, 40.0] {
            assert!((0..w * h).all(|i| !needs_tests(
                &slope,
                i,
                s,
                slope.inverse_depth[i] as f64,
                ray
            )));
        }
        // A step: the right half nearer by 1 (4 px of ray travel).
        let step = depth_of(
            (0..w * h)
                .map(|i| if i % w >= 32 { 2.0 } else { 1.0 })
                .collect(),
            (w, h),
        );
        let at = |x: usize| 4 * w + x;
        // Next to the step: always (it is 1 px away).
        assert!(needs_tests(&step, at(31), 1.0, 1.0, ray));
        // 21 px away (window 5, at least 17 px): in focus on the background (s = 1) the rays
        // reach 4·(0 + 1) + 2 px; at s = 5 a footprint reaches 4·(4 + 1) + 2 = 22 px.
        assert!(!needs_tests(&step, at(11), 1.0, 1.0, ray));
        assert!(needs_tests(&step, at(11), 5.0, 1.0, ray));
        // The nearer side never tests: nothing is nearer than it.
        assert!(!needs_tests(&step, at(40), 5.0, 2.0, ray));
        // A step under a pixel of ray travel is the same surface.
        let small = depth_of(
            (0..w * h)
                .map(|i| if i % w >= 32 { 1.2 } else { 1.0 })
                .collect(),
            (w, h),
        );
        assert!(!needs_tests(&small, at(31), 5.0, 1.0, ray));
        // Without front maps (occlusion tests off) nothing tests.
        let mut none = step.clone();
        none.fronts.clear();
        assert!(!needs_tests(&none, at(31), 1.0, 1.0, ray));
    }

    /// The box over texels as squares equals a brute-force integral (fine quadrature) for
    /// fractional bounds, boxes cut by the image's border, and an empty box (the texel).
    #[test]
    fn the_box_is_the_integral_of_the_texels_as_squares() {
        let (w, h) = (9usize, 7usize);
        let img: Vec<[f64; 4]> = (0..w * h)
            .map(|i| {
                let v = ((i * 37 % 11) as f64) / 10.0;
                [v, 1.0 - v, v * v, 1.0]
            })
            .collect();
        let brute = |px: DVec2, size: DVec2| -> [f64; 4] {
            let n = 400;
            let (mut sum, mut count) = ([0f64; 4], 0.0);
            for b in 0..n {
                for a in 0..n {
                    let p =
                        px + (DVec2::new(a as f64, b as f64) + 0.5) / n as f64 * size - size / 2.0;
                    if p.x < -0.5 || p.y < -0.5 || p.x >= w as f64 - 0.5 || p.y >= h as f64 - 0.5 {
                        continue;
                    }
                    let (i, j) = ((p.x + 0.5).floor() as usize, (p.y + 0.5).floor() as usize);
                    for k in 0..4 {
                        sum[k] += img[j * w + i][k];
                    }
                    count += 1.0;
                }
            }
            sum.map(|v| v / count)
        };
        for (px, size) in [
            (DVec2::new(4.0, 3.0), DVec2::new(2.6, 3.3)),
            (DVec2::new(0.0, 6.0), DVec2::new(5.2, 4.7)),
            (DVec2::new(8.0, 0.0), DVec2::new(1.7, 12.5)),
        ] {
            let got = nearest_box(&img, (w, h), px, size);
            let want = brute(px, size);
            for k in 0..4 {
                assert!(
                    (got[k] - want[k]).abs() < 5e-3,
                    "{px} {size}: {got:?} vs {want:?}"
                );
            }
        }
        let texel = nearest_box(&img, (w, h), DVec2::new(3.0, 2.0), DVec2::ZERO);
        assert_eq!(texel, img[2 * w + 3]);
    }

    #[test]
    fn boxes_follow_the_residual_and_stop_at_the_limit() {
        let unit = DVec2::new(2.0, 1.0);
        assert_eq!(box_size(unit, 0.0), DVec2::ZERO);
        assert_eq!(box_size(unit, -3.0), DVec2::new(6.0, 3.0));
        assert_eq!(box_size(unit, 1e6), DVec2::splat(MAX_BOX_PX));
        assert_eq!(full_px(&[unit, DVec2::new(0.5, 2.5)]), 2.5);
    }
}
