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
//! relative to the reference, per channel. A view is multiplied by that ratio when it is darker
//! (or brighter) than the reference by more than [`MIN_GAIN_CHANGE`] in each block of a 3 × 3
//! partition of the image, all the same way; parallax moves content, which changes the ratio
//! one way on one side of an object and the other way on the other, so views of an evenly lit
//! light field are left bit for bit as they are.

use image::RgbaImage;

use super::guide::box_mean;

/// Gain deviation (in every block of the image, the same way) at or below which a view is left
/// as it is.
pub const MIN_GAIN_CHANGE: f64 = 0.02;

/// An equalised view.
pub struct Equalised {
    pub image: RgbaImage,
    /// The median gain applied: its noise is amplified by as much, so a fit weighs the view
    /// by `1/gain²`.
    pub gain: f64,
}

/// The reference's side of [`equalise`]: its blurred colours, computed once for all the views
/// it equalises (they were a third of the time of equalising 16 views).
pub struct Equaliser {
    width: u32,
    height: u32,
    /// Blur radius, px.
    radius: usize,
    /// Box means of the reference's RGB, interleaved, row-major.
    means: Vec<f64>,
    /// The same at a [`CHECK_FACTOR`]th of the size, with that size and blur radius
    /// ([`Equaliser::small_size`]), for the check whether a view needs equalising at all.
    small: Option<(Vec<f64>, (usize, usize, usize))>,
}

/// The check whether a view needs equalising runs on images downscaled by this factor (box
/// means over a sixth of the image hardly change; a sixteenth of the work on the views of an
/// evenly lit light field, which all pass it).
const CHECK_FACTOR: u32 = 4;

impl Equaliser {
    /// The equaliser of views against `reference`; `None` for an empty image.
    pub fn new(reference: &RgbaImage) -> Option<Equaliser> {
        let (w, h) = (reference.width() as usize, reference.height() as usize);
        if w == 0 || h == 0 {
            return None;
        }
        let radius = (w.max(h) / 12).max(2);
        let small = Self::small_size(reference).map(|(sw, sh, sr)| {
            let img = super::downscale(reference, CHECK_FACTOR);
            (box_mean(&channels(&img), 3, sw, sh, sr), (sw, sh, sr))
        });
        Some(Equaliser {
            width: reference.width(),
            height: reference.height(),
            radius,
            means: box_mean(&channels(reference), 3, w, h, radius),
            small,
        })
    }

    /// Size and blur radius of the downscaled check, where the images are large enough for
    /// one (a blur radius of at least 2 px there).
    fn small_size(img: &RgbaImage) -> Option<(usize, usize, usize)> {
        let (w, h) = (img.width() / CHECK_FACTOR, img.height() / CHECK_FACTOR);
        let r = (w.max(h) / 12) as usize;
        (r >= 2).then_some((w as usize, h as usize, r))
    }

    /// The per-channel gains of view means `mv` against reference means `mr` (interleaved
    /// RGB, rows of `width` pixels; gain 1 where either is almost black: the ratio means
    /// nothing there), and whether the view is darker or brighter than the reference as a
    /// whole: by more than [`MIN_GAIN_CHANGE`] in every ninth of the image, the same way.
    fn gains(mr: &[f64], mv: &[f64], width: usize) -> (Vec<f64>, bool) {
        let gain: Vec<f64> = mr
            .iter()
            .zip(mv)
            .map(|(&a, &b)| {
                if a < 4.0 || b < 4.0 {
                    1.0
                } else {
                    (a / b).clamp(0.25, 4.0)
                }
            })
            .collect();
        // A view too thin for the downscaled check (1 px wide) has no gains: nothing to change
        // (the median of nothing panicked).
        if gain.is_empty() {
            return (gain, false);
        }
        // Vignetting and exposure make a view darker (or brighter) everywhere; parallax only
        // moves its content, so where it changes the blurred means it changes them one way
        // on one side of a moving object and the other way on the other side, or where a
        // large object crosses the image's border. So a view needs equalising only when every
        // block of a 3 × 3 partition of the image (that has bright enough means) has its gain
        // off 1 by more than the threshold, all in the same direction. Tests that were fooled:
        // the median deviation from 1 (parallax of a lit bust before a dark wall made 16 and
        // 18 of the 24 views of the depth set's shaded-bust and sculpture "vignetted"), and
        // the gain of the whole image (a near card crossing the border of the two-plane
        // scene's small views changed it by up to 7 %).
        let width = width.max(1);
        let height = (mr.len() / 3 / width).max(1);
        let mut sums = [[0.0f64; 2]; 9];
        for (i, (&a, &b)) in mr.iter().zip(mv).enumerate() {
            if a >= 4.0 && b >= 4.0 {
                let (x, y) = ((i / 3) % width, (i / 3) / width);
                let block = (3 * y / height).min(2) * 3 + (3 * x / width).min(2);
                sums[block][0] += a;
                sums[block][1] += b;
            }
        }
        let block_gains: Vec<f64> = sums
            .iter()
            .filter(|s| s[1] > 0.0)
            .map(|s| s[0] / s[1])
            .collect();
        let changed = !block_gains.is_empty()
            && (block_gains.iter().all(|g| *g > 1.0 + MIN_GAIN_CHANGE)
                || block_gains.iter().all(|g| *g < 1.0 - MIN_GAIN_CHANGE));
        (gain, changed)
    }

    /// `view` scaled by its smooth gain relative to the reference, or `None` when the gains
    /// are within [`MIN_GAIN_CHANGE`] of 1 (or the view's size differs from the reference's).
    pub fn equalise(&self, view: &RgbaImage) -> Option<Equalised> {
        if view.dimensions() != (self.width, self.height) {
            return None;
        }
        if let Some((small, (sw, sh, sr))) = &self.small {
            let img = super::downscale(view, CHECK_FACTOR);
            if !Self::gains(small, &box_mean(&channels(&img), 3, *sw, *sh, *sr), *sw).1 {
                return None;
            }
        }
        let (w, h) = (self.width as usize, self.height as usize);
        let (gain, changed) = Self::gains(
            &self.means,
            &box_mean(&channels(view), 3, w, h, self.radius),
            w,
        );
        if !changed {
            return None;
        }
        let mid = gain.len() / 2;
        let mut sorted = gain.clone();
        let median = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
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
}

/// `view` scaled by its smooth gain relative to `reference` (same size), or `None` when the
/// gains are within [`MIN_GAIN_CHANGE`] of 1 (or the images differ in size). To equalise
/// several views against one reference, make one [`Equaliser`].
pub fn equalise(reference: &RgbaImage, view: &RgbaImage) -> Option<Equalised> {
    Equaliser::new(reference)?.equalise(view)
}

/// An image's RGB as f64, interleaved.
fn channels(img: &RgbaImage) -> Vec<f64> {
    img.pixels()
        .flat_map(|p| [p.0[0] as f64, p.0[1] as f64, p.0[2] as f64])
        .collect()
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

    #[test]
    fn no_pixels_means_no_gain_change() {
        let (gain, changed) = Equaliser::gains(&[], &[], 1);
        assert!(gain.is_empty() && !changed);
    }

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

    /// Bright balls before a dark wall, seen from a view a few pixels to the side: the
    /// blurred means differ on both sides of each ball (brighter on one, darker on the other),
    /// by far more than 2 % over most of the dark image, but not the same way everywhere: no
    /// vignetting, and the view is left as it is (the median deviation from 1 equalised it).
    #[test]
    fn a_bright_object_moved_by_parallax_over_a_dark_wall_is_no_vignetting() {
        let scene = |shift: f64| {
            RgbaImage::from_fn(64, 48, |x, y| {
                // Two balls 24 px apart, each 11 px in radius.
                let ball = |cx: f64| (x as f64 - shift - cx).powi(2) + (y as f64 - 24.0).powi(2);
                let wall = 12.0 + 4.0 * (((x * 7 + y * 13) % 11) as f64 / 10.0);
                let v = if ball(20.0).min(ball(44.0)) < 11.0 * 11.0 {
                    200.0
                } else {
                    wall
                };
                image::Rgba([v as u8, v as u8, v as u8, 255])
            })
        };
        let reference = scene(0.0);
        let moved = scene(5.0);
        let eq = Equaliser::new(&reference).unwrap();
        let mv = box_mean(&channels(&moved), 3, 64, 48, eq.radius);
        let (gain, _) = Equaliser::gains(&eq.means, &mv, 64);
        let off = gain.iter().filter(|g| (*g - 1.0).abs() > 0.02).count();
        assert!(
            off * 2 > gain.len(),
            "{off} of {} gains off by > 2 %",
            gain.len()
        );
        assert!(equalise(&reference, &moved).is_none());
        // A view 10 % darker where parallax moved nothing is equalised. (Darker *and* with
        // the balls moved, the blocks the balls entered are brighter than the reference's:
        // that view is left alone, a limit of telling gain from parallax by blocks.)
        let darker = RgbaImage::from_fn(64, 48, |x, y| {
            let p = reference.get_pixel(x, y).0;
            image::Rgba(p.map(|c| (c as f64 * 0.9).round() as u8))
        });
        assert!(equalise(&reference, &darker).is_some());
    }

    /// A bright card half outside the image, moved 4 px towards the border by parallax (the
    /// two-plane scene of the picking tests): the whole image's mean changes by several per
    /// cent, as did the median gain, but the blocks the card does not reach keep theirs: no
    /// vignetting. The same view 10 % darker everywhere is equalised.
    #[test]
    fn a_card_crossing_the_border_is_no_vignetting() {
        let scene = |shift: u32| {
            RgbaImage::from_fn(64, 64, |x, y| {
                let v = if x >= 36 + shift && y >= 36 {
                    230.0
                } else {
                    60.0 + 40.0 * (((x * 7 + y * 13) % 11) as f64 / 10.0)
                };
                image::Rgba([v as u8, v as u8, v as u8, 255])
            })
        };
        let (reference, moved) = (scene(0), scene(4));
        let sum = |img: &RgbaImage| img.pixels().map(|p| p.0[0] as f64).sum::<f64>();
        let whole = sum(&reference) / sum(&moved);
        assert!(whole > 1.02, "whole-image gain {whole}");
        assert!(equalise(&reference, &moved).is_none());
        let darker = RgbaImage::from_fn(64, 64, |x, y| {
            let p = moved.get_pixel(x, y).0;
            image::Rgba(p.map(|c| (c as f64 * 0.9).round() as u8))
        });
        assert!(equalise(&reference, &darker).is_some());
    }

    /// Views large enough for the downscaled check: an even view passes it untouched, a
    /// vignetted one is equalised at full size like a small one.
    #[test]
    fn the_downscaled_check_passes_even_views_and_catches_vignetted_ones() {
        let big = |gain: &dyn Fn(u32, u32) -> f64| {
            RgbaImage::from_fn(160, 120, |x, y| {
                let v = 120.0 + 60.0 * (((x * 7 + y * 13) % 11) as f64 / 10.0 - 0.5);
                let g = (v * gain(x, y)).round() as u8;
                image::Rgba([g, g / 2, 255 - g, 255])
            })
        };
        let reference = big(&|_, _| 1.0);
        let eq = Equaliser::new(&reference).unwrap();
        assert!(eq.small.is_some(), "160 × 120 is checked downscaled");
        assert!(eq.equalise(&big(&|_, _| 1.01)).is_none());
        let dark = big(&|x, _| 0.8 - 0.1 * x as f64 / 160.0);
        let fixed = eq
            .equalise(&dark)
            .expect("a 20–30 % darker view is equalised");
        assert!((fixed.gain - 1.0 / 0.75).abs() < 0.1, "{}", fixed.gain);
        let err = fixed
            .image
            .pixels()
            .zip(reference.pixels())
            .map(|(p, q)| (p.0[0] as f64 - q.0[0] as f64).abs())
            .sum::<f64>()
            / (160.0 * 120.0);
        assert!(err < 4.0, "{err}");
    }
}
