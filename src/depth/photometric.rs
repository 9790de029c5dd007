//! Photometric equalisation of the matched views before the sweep.
//!
//! The cost compares colours, so it assumes every view records a surface point as equally
//! bright as the reference does. Plenoptic cameras break that: their sub-aperture views are
//! vignetted, darker the farther the view is from the middle of the grid and darker towards
//! their own image corners. A view 25 % darker than the reference differs from it by more than
//! the cost's truncation at every depth, and the sweep has nothing left to choose by.
//!
//! Vignetting varies slowly across an image while parallax moves content by a few pixels, so
//! the ratio of heavily blurred images (box means over a sixth of the image) is the view's gain
//! relative to the reference, per channel. A view is multiplied by that ratio when its median
//! gain differs from 1 by more than [`MIN_GAIN_CHANGE`]; views of an evenly lit light field are
//! left bit for bit as they are.

use image::RgbaImage;

use super::guide::box_mean;

/// Median gain deviation below which a view is left as it is.
pub const MIN_GAIN_CHANGE: f64 = 0.02;

/// An equalised view.
pub struct Equalised {
    pub image: RgbaImage,
    /// The median gain applied: its noise is amplified by as much, so a fit weighs the view
    /// by `1/gain²`.
    pub gain: f64,
}

/// `view` scaled by its smooth gain relative to `reference` (same size), or `None` when the
/// gains are within [`MIN_GAIN_CHANGE`] of 1 (or the images differ in size).
pub fn equalise(reference: &RgbaImage, view: &RgbaImage) -> Option<Equalised> {
    if reference.dimensions() != view.dimensions() {
        return None;
    }
    let (w, h) = (view.width() as usize, view.height() as usize);
    if w == 0 || h == 0 {
        return None;
    }
    let r = (w.max(h) / 12).max(2);
    let channels = |img: &RgbaImage| -> Vec<f64> {
        img.pixels()
            .flat_map(|p| [p.0[0] as f64, p.0[1] as f64, p.0[2] as f64])
            .collect()
    };
    let (mr, mv) = (
        box_mean(&channels(reference), 3, w, h, r),
        box_mean(&channels(view), 3, w, h, r),
    );
    // Where either image is almost black the ratio means nothing: gain 1 there.
    let gain: Vec<f64> = mr
        .iter()
        .zip(&mv)
        .map(|(&a, &b)| {
            if a < 4.0 || b < 4.0 {
                1.0
            } else {
                (a / b).clamp(0.25, 4.0)
            }
        })
        .collect();
    let mut sorted = gain.clone();
    let mid = sorted.len() / 2;
    let median = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
    let mut deviation: Vec<f64> = gain.iter().map(|g| (g - 1.0).abs()).collect();
    deviation.select_nth_unstable_by(mid, f64::total_cmp);
    if deviation[mid] <= MIN_GAIN_CHANGE {
        return None;
    }
    let mut out = view.clone();
    for (i, p) in out.pixels_mut().enumerate() {
        for c in 0..3 {
            p.0[c] = (p.0[c] as f64 * gain[3 * i + c]).round().clamp(0.0, 255.0) as u8;
        }
    }
    Some(Equalised {
        image: out,
        gain: median,
    })
}

/// Median aggregated cost of the sweep's winners at or above which the views are noisy: on
/// clean views (renders, backgammon) the winner matches to within a fraction of a level
/// (medians 0.001–0.005), under Gaussian noise of σ = 3 levels 0.009–0.014. A single-image
/// estimate (Immerkær's Laplacian-difference estimator) cannot tell fine texture from noise
/// (it reads backgammon's texture as σ ≈ 2.8); the views' disagreement at their best depth can.
pub const NOISY_COST: f32 = 0.0065;

/// Whether the sweep's best costs (one per pixel) say the views are noisy ([`NOISY_COST`]).
pub fn is_noisy(best_cost: &[f32]) -> bool {
    let mut c: Vec<f32> = best_cost
        .iter()
        .copied()
        .filter(|c| c.is_finite())
        .collect();
    if c.is_empty() {
        return false;
    }
    let mid = c.len() / 2;
    *c.select_nth_unstable_by(mid, f32::total_cmp).1 >= NOISY_COST
}

/// `img` smoothed `passes` times by the 3 × 3 binomial kernel (σ ≈ 0.7 px a pass; edges
/// clamped, alpha kept).
pub fn smooth(img: &RgbaImage, passes: u32) -> RgbaImage {
    let mut cur = img.clone();
    let (w, h) = (img.width() as i64, img.height() as i64);
    for _ in 0..passes {
        let src = cur.clone();
        let at = |x: i64, y: i64, c: usize| {
            src.get_pixel(x.clamp(0, w - 1) as u32, y.clamp(0, h - 1) as u32)
                .0[c] as u32
        };
        for (x, y, p) in cur.enumerate_pixels_mut() {
            let (x, y) = (x as i64, y as i64);
            for c in 0..3 {
                let s = 4 * at(x, y, c)
                    + 2 * (at(x - 1, y, c) + at(x + 1, y, c) + at(x, y - 1, c) + at(x, y + 1, c))
                    + at(x - 1, y - 1, c)
                    + at(x + 1, y - 1, c)
                    + at(x - 1, y + 1, c)
                    + at(x + 1, y + 1, c);
                p.0[c] = ((s + 8) / 16) as u8;
            }
        }
    }
    cur
}

#[cfg(test)]
mod tests {
    use super::*;

    fn textured(gain: impl Fn(u32, u32) -> f64) -> RgbaImage {
        RgbaImage::from_fn(64, 48, |x, y| {
            let v = 120.0 + 60.0 * (((x * 7 + y * 13) % 11) as f64 / 10.0 - 0.5);
            let g = (v * gain(x, y)).round() as u8;
            image::Rgba([g, g, g, 255])
        })
    }

    #[test]
    fn a_vignetted_view_is_brought_back_to_the_reference_and_an_even_one_is_left_alone() {
        let reference = textured(|_, _| 1.0);
        assert!(equalise(&reference, &reference).is_none());
        let dark = textured(|x, y| {
            let r2 = ((x as f64 - 32.0).powi(2) + (y as f64 - 24.0).powi(2)) / (40.0 * 40.0);
            0.7 * (1.0 - 0.2 * r2)
        });
        let fixed = equalise(&reference, &dark).expect("a 30 % darker view is equalised");
        assert!((fixed.gain - 1.0 / 0.7).abs() < 0.1, "{}", fixed.gain);
        let fixed = fixed.image;
        let err = |a: &RgbaImage| {
            a.pixels()
                .zip(reference.pixels())
                .map(|(p, q)| (p.0[0] as f64 - q.0[0] as f64).abs())
                .sum::<f64>()
                / (64.0 * 48.0)
        };
        assert!(err(&dark) > 30.0, "{}", err(&dark));
        assert!(err(&fixed) < 4.0, "{}", err(&fixed));
        // Alpha is kept; mismatched sizes are left alone.
        assert!(fixed.pixels().all(|p| p.0[3] == 255));
        assert!(equalise(&reference, &RgbaImage::new(8, 8)).is_none());
    }
}
