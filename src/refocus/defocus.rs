//! Defocused views (docs/conventions.md §11): anti-aliasing as one prefilter pass per view
//! and then one fetch per view, instead of sub-samples of every footprint at every output
//! pixel.
//!
//! **Why it is exact where nothing occludes.** At output pixel x the footprint of view k's
//! aperture cell is centred on the view's sample `y = A_k x + b_k s` and its size is the
//! cell's spans times the residual `s − σ`, σ the inverse depth of the scene point that the
//! view's ray through the focus surface meets. That point is what view k sees at y, so σ is
//! view k's own depth at y: the footprint of every output pixel that samples view k at y is
//! known from view k's image position alone. Each view can therefore be box-filtered once, in
//! its own image, with a box that varies per pixel (its width from the view's depth there) —
//! a *defocused view* — and the refocus pass reads it with one bilinear fetch per view at the
//! cell's centroid, as the plain sum reads the views. The box takes four reads of a
//! summed-area table ([`SummedArea`]) whatever its size, so the cost does not grow with the
//! footprint.
//!
//! **The box.** The summed-area table integrates the view's texels as pixel-sized squares
//! (nearest reconstruction), exactly for fractional bounds: bilinear interpolation of the
//! table between its integer corners is the integral of that piecewise-constant image. A box
//! centred on a texel gives that texel back up to a width of one pixel, and its discrete
//! weights do not have a continuous box's variance; the refocus pass's bilinear fetch adds a
//! tent as the plain sum's does. So the box's width is solved for discrete weights of the
//! footprint's own variance `extent²/12` ([`box_width`]; extent from [`footprint_extent`]).
//!
//! **Occlusion.** Each cell takes the depth of what its central ray meets (the view's depth
//! at its sample), so an occluder's blur is drawn by the views whose rays meet it, a lattice
//! of soft copies at its edges rather than the per-sub-sample split of §11; near a depth
//! discontinuity in the view the box averages across it.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::antialias::{AntialiasPlan, Footprint};
use crate::geometry::homography::ViewWarp;
use crate::lightfield::LightField;

/// A view's summed-area table in f64: texel (i, j) of the `(w + 1) × (h + 1)` table holds the
/// sum of the image's texels `[0, i) × [0, j)`, per channel.
#[derive(Debug, Clone)]
pub struct SummedArea {
    pub width: u32,
    pub height: u32,
    table: Vec<[f64; 3]>,
}

impl SummedArea {
    /// The table of `texels` (`w × h`, row-major).
    pub fn new(texels: &[[f64; 3]], (w, h): (u32, u32)) -> Self {
        let (w, h) = (w as usize, h as usize);
        let tw = w + 1;
        let mut table = vec![[0f64; 3]; tw * (h + 1)];
        for y in 0..h {
            let mut row = [0f64; 3];
            for x in 0..w {
                let t = texels[y * w + x];
                for c in 0..3 {
                    row[c] += t[c];
                    table[(y + 1) * tw + x + 1][c] = table[y * tw + x + 1][c] + row[c];
                }
            }
        }
        SummedArea {
            width: w as u32,
            height: h as u32,
            table,
        }
    }

    /// The table at edge coordinates (e_x, e_y) ∈ [0, w] × [0, h], bilinear between its
    /// corners: the exact integral of the texels as squares over `[0, e_x] × [0, e_y]`.
    pub fn integral(&self, e: DVec2) -> [f64; 3] {
        let (w, h) = (self.width as f64, self.height as f64);
        let ex = e.x.clamp(0.0, w);
        let ey = e.y.clamp(0.0, h);
        let (x0, y0) = (
            ex.floor().min(w - 1.0).max(0.0),
            ey.floor().min(h - 1.0).max(0.0),
        );
        let (fx, fy) = (ex - x0, ey - y0);
        let tw = self.width as usize + 1;
        let (i, j) = (x0 as usize, y0 as usize);
        let at = |di: usize, dj: usize| self.table[(j + dj) * tw + i + di];
        let (a, b, c, d) = (at(0, 0), at(1, 0), at(0, 1), at(1, 1));
        std::array::from_fn(|k| {
            (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
        })
    }

    /// The mean of the texels over the box `[lo, hi]` in pixel-centre coordinates (pixel
    /// (i, j) covers `[i − ½, i + ½] × [j − ½, j + ½]`), clipped to the image; `None` where
    /// nothing of it lies inside.
    pub fn mean(&self, lo: DVec2, hi: DVec2) -> Option<[f64; 3]> {
        let size = DVec2::new(self.width as f64, self.height as f64);
        let a = (lo + 0.5).clamp(DVec2::ZERO, size);
        let b = (hi + 0.5).clamp(DVec2::ZERO, size);
        let area = (b.x - a.x) * (b.y - a.y);
        if area.is_nan() || area <= 0.0 {
            return None;
        }
        let (s11, s01, s10, s00) = (
            self.integral(b),
            self.integral(DVec2::new(a.x, b.y)),
            self.integral(DVec2::new(b.x, a.y)),
            self.integral(a),
        );
        Some(std::array::from_fn(|k| {
            (s11[k] - s01[k] - s10[k] + s00[k]) / area
        }))
    }
}

/// The width of the texel box that stands for a footprint `extent` pixels long: the box,
/// centred on a texel and integrating the texels as squares, whose discrete weights have the
/// footprint's variance `extent²/12` (module docs). For a width b between `2m − 1` and
/// `2m + 1` the texels `|k| < m` weigh `1/b` and the two at `±m` the rest, so the variance is
/// `(C_m + m²(b − 2m + 1))/b` with `C_m = (m − 1)m(2m − 1)/3`; solved for b. 0 (the texel
/// itself) for a footprint of no length.
pub fn box_width(extent: f64) -> f64 {
    let v = extent * extent / 12.0;
    if v.is_nan() || v <= 0.0 {
        return 0.0;
    }
    // The continuous box's width √(12v + 1) is within a texel of the answer: start at its
    // interval and step once either way (the shader does the same in f32).
    let width = |m: f64| {
        let c = (m - 1.0) * m * (2.0 * m - 1.0) / 3.0;
        (m * m * (2.0 * m - 1.0) - c) / (m * m - v)
    };
    let mut m = (((12.0 * v + 1.0).sqrt() + 1.0) * 0.5).floor().max(1.0);
    if m * m <= v || width(m) > 2.0 * m + 1.0 {
        m += 1.0;
    } else if m > 1.0 && width(m - 1.0) <= 2.0 * m - 1.0 && (m - 1.0) * (m - 1.0) > v {
        m -= 1.0;
    }
    width(m).clamp(2.0 * m - 1.0, 2.0 * m + 1.0)
}

/// The footprint of view `fp` at homogeneous sample `y0` for residual `d`: its extent along
/// the image axes in pixels (the bounding box of the cell's four corners; exact for a
/// parallel rig, whose footprints are axis-aligned rectangles).
pub fn footprint_extent(fp: &Footprint, y0: DVec3, d: f64) -> DVec2 {
    if y0.z <= 0.0 {
        return DVec2::ZERO;
    }
    let p0 = y0.truncate() / y0.z;
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(-f64::INFINITY);
    for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        let q = y0 + fp.offset(u, v, d);
        let p = if q.z > 0.0 { q.truncate() / q.z } else { p0 };
        lo = lo.min(p);
        hi = hi.max(p);
    }
    hi - lo
}

/// One defocused view: per texel the mean of the view over its footprint box, in the
/// averaging space of the texels given.
#[derive(Debug, Clone)]
pub struct DefocusedView {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f64; 3]>,
}

/// Fills the holes (−1: nothing of the reference landed there, a disocclusion) of one view's
/// inverse-depth map from the farthest valid 4-neighbour, ring by ring until none is left, so
/// every texel has a footprint (what a disocclusion shows is background). A map without any
/// valid pixel stays as it is.
pub fn fill_holes(map: &mut [f32], (w, h): (usize, usize)) {
    let mut holes: Vec<usize> = (0..w * h).filter(|&k| map[k] < 0.0).collect();
    while !holes.is_empty() {
        let left = super::antialias::fill_ring(map, (w, h), &holes);
        if left.len() == holes.len() {
            return; // nothing valid to fill from
        }
        holes = left;
    }
}

/// Defocuses one view (`texels` in the averaging space, `w × h`): texel y becomes the mean of
/// the view over the box of the footprint that its cell sweeps at y ([`box_width`] of
/// [`footprint_extent`]), for the residual between the focus surface `s_of(x)` along the
/// reference ray x that samples the view at y (`x = H⁻¹ y`, H the view's homography for the
/// plane term `m`) and the inverse depth `sigma` the view sees at y. Texels without depth, or
/// whose ray misses the reference's image plane, keep their value.
#[allow(clippy::too_many_arguments)]
pub fn defocus_view(
    texels: &[[f64; 3]],
    (w, h): (u32, u32),
    warp: &ViewWarp,
    m: DVec3,
    fp: &Footprint,
    sigma: &[f32],
    s_of: &(impl Fn(DVec2) -> f64 + Sync),
) -> DefocusedView {
    let sat = SummedArea::new(texels, (w, h));
    let inv = warp.homography(m).inverse();
    let out: Vec<[f64; 3]> = (0..(w * h) as usize)
        .into_par_iter()
        .map(|k| {
            let (i, j) = ((k % w as usize) as f64, (k / w as usize) as f64);
            let own = texels[k];
            let sg = sigma[k];
            if sg < 0.0 {
                return own;
            }
            let xh = inv * DVec3::new(i, j, 1.0);
            if !(xh.z != 0.0 && xh.is_finite()) {
                return own;
            }
            let x = DVec2::new(xh.x / xh.z, xh.y / xh.z);
            let s = s_of(x);
            let y0 = warp.a * x.extend(1.0) + warp.b * s;
            let ext = footprint_extent(fp, y0, s - sg as f64);
            let half = DVec2::new(box_width(ext.x), box_width(ext.y)) / 2.0;
            if half == DVec2::ZERO {
                return own;
            }
            let c = DVec2::new(i, j);
            sat.mean(c - half, c + half).unwrap_or(own)
        })
        .collect();
    DefocusedView {
        width: w,
        height: h,
        texels: out,
    }
}

/// Every planned view of `aa` defocused (its texels through `table`, the averaging space),
/// with the focus surface `s_of`; `aa` must carry the filled depth maps
/// ([`AntialiasSettings::defocus`](super::antialias::AntialiasSettings::defocus)).
pub fn defocus_views(
    lf: &LightField,
    aa: &AntialiasPlan,
    table: &[f64; 256],
    s_of: &(impl Fn(DVec2) -> f64 + Sync),
) -> Vec<DefocusedView> {
    let (w, h) = (lf.width, lf.height);
    let n = (w * h) as usize;
    let unknown = vec![-1f32; n];
    aa.plan
        .views
        .iter()
        .zip(&aa.footprints)
        .map(|(v, fp)| {
            let texels: Vec<[f64; 3]> = lf.views[v.index]
                .image
                .pixels()
                .map(|p| std::array::from_fn(|c| table[p[c] as usize]))
                .collect();
            let sigma = aa
                .visibility
                .as_ref()
                .map_or(&unknown[..], |vis| &vis.sigma[fp.map * n..(fp.map + 1) * n]);
            defocus_view(&texels, (w, h), &v.warp, aa.plan.m, fp, sigma, s_of)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute_mean(t: &[[f64; 3]], (w, h): (usize, usize), lo: DVec2, hi: DVec2) -> [f64; 3] {
        // Dense midpoint quadrature of the nearest-texel image over the clipped box.
        let n = 400;
        let a = (lo + 0.5).clamp(DVec2::ZERO, DVec2::new(w as f64, h as f64));
        let b = (hi + 0.5).clamp(DVec2::ZERO, DVec2::new(w as f64, h as f64));
        let mut s = [0f64; 3];
        for jy in 0..n {
            for ix in 0..n {
                let ex = a.x + (ix as f64 + 0.5) / n as f64 * (b.x - a.x);
                let ey = a.y + (jy as f64 + 0.5) / n as f64 * (b.y - a.y);
                let p = t[(ey.floor() as usize).min(h - 1) * w + (ex.floor() as usize).min(w - 1)];
                for c in 0..3 {
                    s[c] += p[c] / (n * n) as f64;
                }
            }
        }
        s
    }

    #[test]
    fn summed_area_box_equals_brute_force_for_fractional_bounds_and_borders() {
        let (w, h) = (13usize, 9usize);
        let t: Vec<[f64; 3]> = (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f64, (k / w) as f64);
                [
                    (x * 0.37 + y * 0.11).sin().abs(),
                    ((x * y) % 7.0) / 7.0,
                    0.5,
                ]
            })
            .collect();
        let sat = SummedArea::new(&t, (w as u32, h as u32));
        for (lo, hi) in [
            (DVec2::new(2.3, 1.7), DVec2::new(6.9, 4.2)),
            (DVec2::new(-3.0, -1.2), DVec2::new(2.25, 3.5)),
            (DVec2::new(10.4, 6.6), DVec2::new(15.0, 11.0)),
            (DVec2::new(4.1, 4.1), DVec2::new(4.3, 4.35)),
        ] {
            let got = sat.mean(lo, hi).unwrap();
            let want = brute_mean(&t, (w, h), lo, hi);
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 2e-3,
                    "{lo} {hi}: {got:?} vs {want:?}"
                );
            }
        }
        assert!(sat
            .mean(DVec2::new(20.0, 1.0), DVec2::new(25.0, 2.0))
            .is_none());
    }

    /// The discrete weights of a texel-centred box of width b (the overlap of each texel's
    /// square with the box, over b).
    fn discrete_variance(b: f64) -> f64 {
        (-40i32..=40)
            .map(|k| {
                let k = k as f64;
                let overlap = ((k + 0.5).min(b / 2.0) - (k - 0.5).max(-b / 2.0)).max(0.0);
                overlap / b * k * k
            })
            .sum()
    }

    #[test]
    fn box_width_gives_the_footprints_variance_and_grows_with_it() {
        assert_eq!(box_width(0.0), 0.0);
        let mut last = 0.0;
        for i in 1..=400 {
            let extent = i as f64 * 0.1;
            let b = box_width(extent);
            let v = discrete_variance(b);
            assert!(
                (v - extent * extent / 12.0).abs() < 1e-9 * (1.0 + v),
                "extent {extent}: width {b}, variance {v}"
            );
            assert!(b > last, "extent {extent}: {b} after {last}");
            last = b;
        }
    }

    #[test]
    fn holes_take_the_farthest_surface_around_them_and_all_fill() {
        // A near half (0.5) beside a far one (0.1): a hole on their border, a wide hole inside
        // the near half (filled ring by ring) and one in the far corner.
        let (w, h) = (8usize, 6usize);
        let mut map: Vec<f32> = (0..w * h)
            .map(|k| if (k % w) < 4 { 0.5 } else { 0.1 })
            .collect();
        for k in [2 * w + 4, 4 * w, 4 * w + 1, 4 * w + 2, 5 * w + 7] {
            map[k] = -1.0;
        }
        fill_holes(&mut map, (w, h));
        assert!(map.iter().all(|&v| v >= 0.0));
        assert_eq!(map[2 * w + 4], 0.1, "the border hole shows the background");
        assert_eq!(
            map[4 * w + 1],
            0.5,
            "inside a surface the hole takes that surface"
        );
        assert_eq!(map[5 * w + 7], 0.1);
        let mut empty = vec![-1f32; 4];
        fill_holes(&mut empty, (2, 2));
        assert!(empty.iter().all(|&v| v < 0.0), "nothing to fill from");
    }
}
