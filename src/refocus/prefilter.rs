//! The prefiltered lookup of anti-aliasing (docs/conventions.md §11): every view also as a
//! box-filtered pyramid (mip levels), so one sub-sample of a footprint can stand for a box of
//! several pixels in one trilinear fetch instead of one bilinear fetch per pixel.
//!
//! Level `l` is `max(1, W >> l) × max(1, H >> l)`; its texel (i, j) is the mean of the finer
//! level's texels (2i … 2i+1, 2j … 2j+1), clamped to that level (an odd size drops its last
//! row or column, as halving by a floor must). The GPU texture's levels are made by the same
//! rule on the CPU at upload ([`halve`]), in the values the texture stores (linear light for
//! the default 16-bit storage), so the f64 model ([`Pyramid`]) and the GPU read the same
//! pyramid and sample it with the same normalised coordinates.
//!
//! **The level of a sub-sample.** A view's footprint is sampled on an `n_s × n_t` grid
//! (`antialias::samples`); the sub-samples are `len/n` pixels apart along each side. A box of
//! width `w` has variance `w²/12`; a level-`l` texel sampled bilinearly is a box of `2^l` pixels
//! convolved with a tent of half-width `2^l`, variance `4^l/4`. Equal variances give
//! `l = log2(w) − log2 √3`: [`lod`]. Up to `w = √3` pixels that is level 0, the plain bilinear
//! fetch; beyond it the fetch blurs over its own share of the footprint, so a cap of 2
//! sub-samples per axis integrates a footprint of any length without aliasing.

use glam::DVec2;

/// At most this many levels (level 6 is 1/64 of the view a side: a box of 64 pixels, the
/// longest footprint `antialias` lets a view's parallax reach).
pub const MAX_LEVELS: u32 = 7;

/// `log2 √3`: the level offset that matches a bilinear fetch of a level's variance to a box's
/// (module docs).
pub const LOD_BIAS: f64 = 0.792_481_250_360_578_1;

/// Levels of a `w × h` view's pyramid: down to one texel along the shorter side, at most
/// [`MAX_LEVELS`].
pub fn level_count(w: u32, h: u32) -> u32 {
    let shorter = w.min(h).max(1);
    (32 - shorter.leading_zeros()).min(MAX_LEVELS)
}

/// Size of level `l` of a `w × h` view.
pub fn level_size(w: u32, h: u32, l: u32) -> (u32, u32) {
    ((w >> l).max(1), (h >> l).max(1))
}

/// The pyramid level for sub-samples `spacing` pixels apart: `log2(spacing) − LOD_BIAS`, at
/// least 0 (the shader computes the same in f32).
pub fn lod(spacing: f64) -> f64 {
    if spacing > 0.0 {
        (spacing.log2() - LOD_BIAS).max(0.0)
    } else {
        0.0
    }
}

/// One level down from `src` (`w × h` texels of `N` channels): each texel the mean of its
/// 2 × 2 finer texels, through `to`/`from` (the storage's integer levels, rounded by `from`).
pub fn halve<T: Copy + Default, const N: usize>(
    src: &[[T; N]],
    (w, h): (u32, u32),
    to: impl Fn(T) -> f64,
    from: impl Fn(f64) -> T,
) -> Vec<[T; N]> {
    let (w2, h2) = ((w / 2).max(1), (h / 2).max(1));
    let mut out = vec![[T::default(); N]; (w2 * h2) as usize];
    for j in 0..h2 {
        for i in 0..w2 {
            let mut acc = [0f64; N];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let x = (2 * i + dx).min(w - 1);
                let y = (2 * j + dy).min(h - 1);
                let t = src[(y * w + x) as usize];
                for k in 0..N {
                    acc[k] += to(t[k]);
                }
            }
            let o = &mut out[(j * w2 + i) as usize];
            for k in 0..N {
                o[k] = from(acc[k] / 4.0);
            }
        }
    }
    out
}

/// One level of a [`Pyramid`]: its size and row-major texels.
type Level = ((u32, u32), Vec<[f64; 3]>);

/// Exact bilinear interpolation of f64 texels (`w × h`, row-major) at pixel position `p`
/// (pixel centres at integers), clamp to edge.
pub fn bilinear_texels(texels: &[[f64; 3]], (w, h): (u32, u32), p: DVec2) -> [f64; 3] {
    let (wi, hi) = (w as i64, h as i64);
    let (x0, y0) = (p.x.floor(), p.y.floor());
    let (fx, fy) = (p.x - x0, p.y - y0);
    let mut c = [0f64; 3];
    for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
        for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
            let x = (x0 as i64 + dx).clamp(0, wi - 1);
            let y = (y0 as i64 + dy).clamp(0, hi - 1);
            let t = texels[(y * wi + x) as usize];
            for k in 0..3 {
                c[k] += wx * wy * t[k];
            }
        }
    }
    c
}

/// One view's pyramid in f64 (the model's copy of the GPU's levels).
pub struct Pyramid {
    /// Finest first.
    levels: Vec<Level>,
}

impl Pyramid {
    /// The pyramid of a `w × h` level 0 (row-major texels in the averaging space).
    pub fn new(level0: Vec<[f64; 3]>, (w, h): (u32, u32)) -> Self {
        let mut levels = vec![((w, h), level0)];
        for l in 1..level_count(w, h) {
            let ((pw, ph), prev) = levels.last().expect("level 0 is there");
            let next = halve(prev, (*pw, *ph), |v| v, |v| v);
            levels.push((level_size(w, h, l), next));
        }
        Pyramid { levels }
    }

    /// Exact bilinear interpolation of level `l` at level-0 pixel position `p` (pixel centres
    /// at integers, clamp to edge), through normalised coordinates as a sampler reads it.
    fn bilinear(&self, l: usize, p: DVec2) -> [f64; 3] {
        let ((w0, h0), _) = &self.levels[0];
        let ((w, h), texels) = &self.levels[l];
        let q = (p + 0.5) * DVec2::new(*w as f64 / *w0 as f64, *h as f64 / *h0 as f64) - 0.5;
        bilinear_texels(texels, (*w, *h), q)
    }

    /// Trilinear lookup at level-0 position `p` and level `lod` ≥ 0: the two levels around it
    /// mixed by its fraction (the last level beyond the pyramid).
    pub fn trilinear(&self, p: DVec2, lod: f64) -> [f64; 3] {
        let last = self.levels.len() - 1;
        let l0 = (lod.floor() as usize).min(last);
        let f = if l0 == last { 0.0 } else { lod - l0 as f64 };
        let a = self.bilinear(l0, p);
        if f == 0.0 {
            return a;
        }
        let b = self.bilinear(l0 + 1, p);
        std::array::from_fn(|k| a[k] + f * (b[k] - a[k]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_halve_down_to_one_texel() {
        assert_eq!(level_count(1, 1), 1);
        assert_eq!(level_count(128, 128), 7);
        assert_eq!(level_count(64, 48), 6);
        assert_eq!(level_count(5, 300), 3);
        assert_eq!(level_size(5, 300, 2), (1, 75));
    }

    #[test]
    fn halving_averages_each_block_and_drops_an_odd_edge() {
        // 3 × 2 texels of one channel: the last column is left out of the 1 × 1 level.
        let src: Vec<[u16; 1]> = [10u16, 20, 99, 30, 40, 99].iter().map(|&v| [v]).collect();
        let out = halve(&src, (3, 2), f64::from, |v| v.round() as u16);
        assert_eq!(out, vec![[25u16]]);
        // 2 × 2 of two channels, rounded half up.
        let src = vec![[0u8, 1], [1, 1], [0, 2], [0, 1]];
        assert_eq!(
            halve(&src, (2, 2), f64::from, |v| v.round() as u8),
            vec![[0u8, 1]]
        );
    }

    #[test]
    fn level_bias_matches_a_box_variance() {
        // At spacing √3 the level is 0; twice the spacing is one level up.
        assert!(lod(3f64.sqrt()).abs() < 1e-12);
        assert!((lod(2.0 * 3f64.sqrt()) - 1.0).abs() < 1e-12);
        assert_eq!(lod(0.5), 0.0);
        assert_eq!(lod(0.0), 0.0);
    }

    #[test]
    fn trilinear_reads_levels_at_the_same_place() {
        // A horizontal ramp keeps its value at every level where its texel centres line up.
        let (w, h) = (8u32, 8u32);
        let level0 = (0..w * h).map(|i| [(i % w) as f64; 3]).collect();
        let p = Pyramid::new(level0, (w, h));
        for lod in [0.0, 0.5, 1.0, 1.7, 2.0] {
            let c = p.trilinear(DVec2::new(3.5, 2.0), lod);
            assert!((c[0] - 3.5).abs() < 1e-12, "lod {lod}: {c:?}");
        }
        // A constant stays constant at any level, far past the pyramid too.
        let flat = Pyramid::new(vec![[0.25; 3]; 64], (8, 8));
        assert!((flat.trilinear(DVec2::new(-3.0, 9.0), 9.0)[1] - 0.25).abs() < 1e-15);
    }
}
