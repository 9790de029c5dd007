//! The colour-weighted median of the sweep's winners (docs/depth.md, step 4): each pixel takes
//! the weighted median of the values in a window around it, a neighbour weighing by how close
//! its reference colour is to the pixel's. Where a surface has too little texture of its own
//! (a dark, faint wall), every hypothesis that keeps a nearer object's silhouette consistent
//! costs about as little as its true depth, and the sweep fattens the nearer object into it
//! by a few pixels; the median hands those pixels the value most of their own colour region
//! holds, which snaps a depth edge back to the colour edge. A median, not a mean: values are
//! never blended across an edge, so no depth between two surfaces is invented.

use image::RgbaImage;
use rayon::prelude::*;

/// The second pass's window radius relative to the first's ([`weighted_median_twice`]).
pub const SECOND_PASS_RADIUS: f64 = 0.75;

/// [`weighted_median`] twice: radius `radius`, then on its result radius
/// `radius · SECOND_PASS_RADIUS` (rounded; the default 14 gives 11, sampled as 12). Where an
/// object was fattened into a concave corner of the background (a dark wall between a bust's
/// head and shoulders), the fattened band is a majority of the corner's background-coloured
/// pixels and one pass keeps it; the second pass sees the band thinned by the first and hands
/// the rest back. Measured on the test set with backgammon and `layers` (docs/depth.md): the
/// bust's MSE×100 6.8 → 4.8; a third pass spread foreground into thin gaps again.
pub fn weighted_median_twice(
    values: &[f32],
    guide: &RgbaImage,
    radius: u32,
    sigma: f32,
) -> Vec<f32> {
    let once = weighted_median(values, guide, radius, sigma);
    let second = (radius as f64 * SECOND_PASS_RADIUS).round() as u32;
    weighted_median(&once, guide, second, sigma)
}

/// Windows of a larger radius are sampled every other pixel each way.
const SPARSE_ABOVE: u32 = 6;

/// Bins of the histogram each window's median is read from, over the values' range. With a
/// continuous fit afterwards the bin width (a 256th of the range) is refined away.
const BINS: usize = 256;

/// The weighted median of `values` (row-major, `guide`'s size) in windows of `radius` around
/// each pixel, a neighbour weighing `exp(−|Δc|² / (2 σ²))` with Δc the RGB difference of the
/// guide's 8-bit colours and σ = `sigma`. Non-finite values take no part and stay as they are.
/// The result is the centre of the median's bin, or the pixel's own value when that lies in
/// the same bin (so a pixel the median agrees with keeps its precision).
pub fn weighted_median(values: &[f32], guide: &RgbaImage, radius: u32, sigma: f32) -> Vec<f32> {
    let (w, h) = (guide.width() as usize, guide.height() as usize);
    assert_eq!(values.len(), w * h, "one value per guide pixel");
    let (lo, hi) = values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    if radius == 0 || lo >= hi {
        return values.to_vec();
    }
    let scale = (BINS - 1) as f32 / (hi - lo);
    let bin = |v: f32| ((v - lo) * scale).round() as usize;
    // Every value's bin once (NO_BIN where it takes no part): a rounding per neighbour was a
    // library call each.
    const NO_BIN: u16 = u16::MAX;
    let bins: Vec<u16> = values
        .iter()
        .map(|&v| if v.is_finite() { bin(v) as u16 } else { NO_BIN })
        .collect();
    // Weight by squared colour distance, tabulated (at most 3 · 255²): an exp per neighbour
    // was most of the time. The whole range: where every sampled neighbour differs strongly
    // from the centre, their weights of e^−20 to e^−80 still rank them (cutting the table at
    // e^−18 cost 0.8 % BadPix on the occlusion-edge scene).
    let inv = -1.0 / (2.0 * sigma * sigma);
    let mut table: Vec<f32> = (0..=3 * 255 * 255)
        .map(|d2| (d2 as f32 * inv).exp())
        .collect();
    // The weights underflow to zero beyond some distance (e^−104 for f32; about a quarter of
    // the range at σ = 16): a neighbour there adds nothing, so it is skipped, and the table
    // ends there, small enough to stay in cache.
    if let Some(zero) = table.iter().position(|&t| t == 0.0) {
        table.truncate(zero);
    }
    // Wide windows are sampled every other pixel each way: a median needs the proportions of
    // the window's values, not every pixel (a quarter of the work at the same scores).
    let step = if radius > SPARSE_ABOVE { 2 } else { 1 };
    // A window sampled every other pixel reaches an even radius, so that it holds the
    // pixel's own row and column: from an odd radius it held neither, and a thin line of a
    // background colour (a panel's grey frame before a brick wall's mortar) had no support of
    // its own and went to the wall (`layers`: BadPix 7.4 → 6.1 %, MSE×100 106 → 59; the
    // anti-aliased refocus on its estimated depth 39.7 → 57.7 dB on the focused panel).
    let radius = if step == 2 {
        radius + radius % 2
    } else {
        radius
    };
    let colour = |i: usize| {
        let p = guide.as_raw();
        [p[4 * i] as i32, p[4 * i + 1] as i32, p[4 * i + 2] as i32]
    };
    let r = radius as i64;
    let mut out = values.to_vec();
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let mut hist = [0f32; BINS];
        for (x, o) in row.iter_mut().enumerate() {
            let i = y * w + x;
            if bins[i] == NO_BIN {
                continue;
            }
            let c = colour(i);
            let mut total = 0f32;
            // The bins this window touched: only they are scanned and cleared (the others
            // hold zeros, which leave the running sum as it is).
            let (mut first, mut last) = (BINS, 0);
            // The window's sampled rows and columns inside the image, in the same order as
            // the stepped offsets −r, −r + step, … , r (the sums, and so the medians, are
            // the same as with a bounds test per neighbour).
            let (ys, ye) = (first_inside(y, r, step), (y + r as usize).min(h - 1));
            let (xs, xe) = (first_inside(x, r, step), (x + r as usize).min(w - 1));
            for yy in (ys..=ye).step_by(step) {
                for j in (yy * w + xs..=yy * w + xe).step_by(step) {
                    let b = bins[j];
                    if b == NO_BIN {
                        continue;
                    }
                    let n = colour(j);
                    let d2 = ((c[0] - n[0]).pow(2) + (c[1] - n[1]).pow(2) + (c[2] - n[2]).pow(2))
                        as usize;
                    let Some(&wt) = table.get(d2) else {
                        continue;
                    };
                    hist[b as usize] += wt;
                    total += wt;
                    first = first.min(b as usize);
                    last = last.max(b as usize);
                }
            }
            // No neighbour of a colour near enough to weigh (the window is sampled every
            // other pixel, the centre itself left out): the pixel keeps its value.
            if total <= 0.0 {
                continue;
            }
            let half = 0.5 * total;
            let mut acc = 0f32;
            let mut median = BINS - 1;
            for (k, &hk) in hist.iter().enumerate().take(last + 1).skip(first) {
                acc += hk;
                if acc >= half {
                    median = k;
                    break;
                }
            }
            hist[first..=last].fill(0.0);
            if median != bins[i] as usize {
                *o = lo + median as f32 / scale;
            }
        }
    });
    out
}

/// The first of the offsets −r, −r + step, … from `at` that lies inside the image (≥ 0).
fn first_inside(at: usize, r: i64, step: usize) -> usize {
    let start = at as i64 - r;
    if start >= 0 {
        start as usize
    } else {
        // The smallest multiple of `step` that brings `start` to 0 or above.
        let k = ((-start) as usize).div_ceil(step);
        (start + (k * step) as i64) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bright disc on a dark ground, its value 2 against 0, and the value fattened into the
    /// ground by a 2-px band: the median gives the band back to the ground and keeps the disc.
    #[test]
    fn a_fattened_band_returns_to_its_colour_region() {
        let (w, h) = (40u32, 40u32);
        let inside = |x: u32, y: u32| (x as f32 - 20.0).hypot(y as f32 - 20.0) < 8.0;
        let band = |x: u32, y: u32| (x as f32 - 20.0).hypot(y as f32 - 20.0) < 10.0;
        let guide = RgbaImage::from_fn(w, h, |x, y| {
            let g = if inside(x, y) {
                200
            } else {
                30 + ((x * 7 + y * 3) % 5) as u8
            };
            image::Rgba([g, g, g, 255])
        });
        let values: Vec<f32> = (0..w * h)
            .map(|i| if band(i % w, i / w) { 2.0 } else { 0.0 })
            .collect();
        let out = weighted_median(&values, &guide, 5, 10.0);
        for y in 0..h {
            for x in 0..w {
                let v = out[(y * w + x) as usize];
                let want = if inside(x, y) { 2.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-6, "({x}, {y}): {v}");
            }
        }
    }

    /// A one-pixel line of its own colour in a wide window sampled every other pixel: the
    /// window holds the line's own row whatever the radius, so the line keeps its value (from
    /// an odd radius the window held none of it and the line took its surroundings' value).
    #[test]
    fn a_thin_line_keeps_its_value_in_a_sparse_window() {
        let (w, h) = (48u32, 48u32);
        let guide = RgbaImage::from_fn(w, h, |x, y| {
            if y == 24 {
                image::Rgba([40, 200, 40, 255])
            } else {
                let g = 100 + ((x * 5 + y * 3) % 7) as u8;
                image::Rgba([g, g, g + 10, 255])
            }
        });
        let values: Vec<f32> = (0..w * h)
            .map(|i| if i / w == 24 { 2.0 } else { 0.0 })
            .collect();
        for radius in [13, 14] {
            let out = weighted_median(&values, &guide, radius, 16.0);
            for x in 0..w {
                assert_eq!(out[(24 * w + x) as usize], 2.0, "radius {radius}, x {x}");
                assert_eq!(out[(23 * w + x) as usize], 0.0, "radius {radius}, x {x}");
            }
        }
    }

    #[test]
    fn agreeing_pixels_keep_their_value_and_gaps_stay() {
        let guide = RgbaImage::from_pixel(8, 8, image::Rgba([50, 60, 70, 255]));
        let mut values: Vec<f32> = (0..64).map(|i| 1.0 + 1e-4 * (i % 3) as f32).collect();
        values[9] = f32::NAN;
        values[0] = 3.0; // range for the bins
        let out = weighted_median(&values, &guide, 2, 10.0);
        assert!(out[9].is_nan());
        assert_eq!(out[20], values[20]);
        // The outlier takes the majority's value.
        assert!((out[0] - 1.0).abs() < 0.01, "{}", out[0]);
        // Radius 0 is the identity.
        let same = weighted_median(&values, &guide, 0, 10.0);
        assert_eq!(same[0], 3.0);
    }

    /// The window walk (sampled rows and columns clamped to the image, zero weights skipped,
    /// only the touched bins scanned) against a brute-force histogram median that tests every
    /// offset against the image's bounds and scans all bins: the same values bit for bit, at
    /// the borders, with gaps, for a dense and a sparse (every other pixel) window.
    #[test]
    fn the_window_walk_equals_a_brute_force_median() {
        let (w, h) = (23usize, 17usize);
        let mut seed = 7u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) as u32
        };
        // Colours from near-equal to far apart (weights from 1 down to underflow).
        let guide = RgbaImage::from_fn(w as u32, h as u32, |_, _| {
            let k = (next() % 4) as u8;
            image::Rgba([k * 80 + (next() % 9) as u8, k * 60, 255 - k * 70, 255])
        });
        let mut values: Vec<f32> = (0..w * h).map(|_| (next() % 1000) as f32 / 250.0).collect();
        values[3] = f32::NAN;
        values[w * 8 + 11] = f32::INFINITY;
        let sigma = 16f32;
        let brute = |radius: u32| -> Vec<f32> {
            let finite = values.iter().filter(|v| v.is_finite());
            let lo = finite.clone().fold(f32::INFINITY, |a, &v| a.min(v));
            let hi = finite.fold(f32::NEG_INFINITY, |a, &v| a.max(v));
            let scale = (BINS - 1) as f32 / (hi - lo);
            let bin = |v: f32| ((v - lo) * scale).round() as usize;
            let step = if radius > SPARSE_ABOVE { 2 } else { 1 };
            let r = if step == 2 {
                radius + radius % 2
            } else {
                radius
            } as i64;
            let inv = -1.0 / (2.0 * sigma * sigma);
            let px = |i: usize| guide.as_raw()[4 * i..4 * i + 3].to_vec();
            let mut out = values.clone();
            for i in (0..w * h).filter(|&i| values[i].is_finite()) {
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                let mut hist = [0f32; BINS];
                let mut total = 0f32;
                for dy in (-r..=r).step_by(step) {
                    for dx in (-r..=r).step_by(step) {
                        let (xx, yy) = (x + dx, y + dy);
                        if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                            continue;
                        }
                        let j = yy as usize * w + xx as usize;
                        if !values[j].is_finite() {
                            continue;
                        }
                        let d2: i32 = px(i)
                            .iter()
                            .zip(px(j))
                            .map(|(&a, b)| (a as i32 - b as i32).pow(2))
                            .sum();
                        let wt = (d2 as f32 * inv).exp();
                        hist[bin(values[j])] += wt;
                        total += wt;
                    }
                }
                if total <= 0.0 {
                    continue;
                }
                let mut acc = 0f32;
                let median = (0..BINS)
                    .find(|&k| {
                        acc += hist[k];
                        acc >= 0.5 * total
                    })
                    .unwrap_or(BINS - 1);
                if median != bin(values[i]) {
                    out[i] = lo + median as f32 / scale;
                }
            }
            out
        };
        for radius in [1, 3, 7, 8] {
            let (got, want) = (
                weighted_median(&values, &guide, radius, sigma),
                brute(radius),
            );
            for (i, (g, b)) in got.iter().zip(&want).enumerate() {
                assert_eq!(
                    g.to_bits(),
                    b.to_bits(),
                    "radius {radius}, pixel {i}: {g} vs {b}"
                );
            }
        }
    }
}
