//! The HCI 4D light field benchmark's disparity metrics (Honauer et al. 2016): BadPix(τ), the
//! percentage of pixels whose disparity error exceeds τ px (0.07 is the headline threshold),
//! and MSE × 100, over the image without a border (15 px in the benchmark). A pixel without an
//! estimate (NaN) counts as bad with an error of 1 px in the MSE; pixels without ground truth
//! are skipped. Against a reference that is itself an estimate (a learned network's map of a
//! real capture, where no ground truth exists) the agreement measures are the share of pixels
//! off by more than 0.1 px and Pearson's r of the two maps.

/// Scores of one disparity map against ground truth.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct DisparityScores {
    /// % of pixels with |error| > 0.07 px.
    pub bad_pix_007: f64,
    /// % with |error| > 0.03 px.
    pub bad_pix_003: f64,
    /// % with |error| > 0.01 px.
    pub bad_pix_001: f64,
    /// % with |error| > 0.1 px (agreement with a reference estimate).
    pub off_01: f64,
    /// Pearson correlation of estimate and truth over the scored pixels with an estimate
    /// (NaN with fewer than two, or when either is constant).
    pub pearson_r: f64,
    /// Mean squared error × 100.
    pub mse_x100: f64,
    /// Pixels scored.
    pub pixels: usize,
}

/// The HCI benchmark's border, px.
pub const HCI_BORDER: u32 = 15;

/// Scores `estimate` against `truth` (both `width × height`, row-major) over the pixels at
/// least `border` px from the image edge where `mask` (if given) holds.
pub fn score(
    estimate: &[f32],
    truth: &[f32],
    width: u32,
    height: u32,
    border: u32,
    mask: Option<&[bool]>,
) -> DisparityScores {
    let (mut n, mut se) = (0usize, 0.0f64);
    let mut bad = [0usize; 4];
    // Sums for Pearson's r over the pixels with an estimate.
    let (mut m, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0usize, 0.0, 0.0, 0.0, 0.0, 0.0);
    for y in border..height.saturating_sub(border) {
        for x in border..width.saturating_sub(border) {
            let i = (y * width + x) as usize;
            if mask.is_some_and(|m| !m[i]) || !truth[i].is_finite() {
                continue;
            }
            let e = if estimate[i].is_finite() {
                let (x, y) = (estimate[i] as f64, truth[i] as f64);
                m += 1;
                (sx, sy) = (sx + x, sy + y);
                (sxx, syy, sxy) = (sxx + x * x, syy + y * y, sxy + x * y);
                (x - y).abs()
            } else {
                1.0
            };
            n += 1;
            se += e * e;
            for (b, t) in bad.iter_mut().zip([0.07, 0.03, 0.01, 0.1]) {
                if e > t {
                    *b += 1;
                }
            }
        }
    }
    let pct = |b: usize| 100.0 * b as f64 / n.max(1) as f64;
    let mf = m as f64;
    let (vx, vy) = (sxx - sx * sx / mf, syy - sy * sy / mf);
    let pearson_r = if m >= 2 && vx > 0.0 && vy > 0.0 {
        (sxy - sx * sy / mf) / (vx * vy).sqrt()
    } else {
        f64::NAN
    };
    DisparityScores {
        bad_pix_007: pct(bad[0]),
        bad_pix_003: pct(bad[1]),
        bad_pix_001: pct(bad[2]),
        off_01: pct(bad[3]),
        pearson_r,
        mse_x100: 100.0 * se / n.max(1) as f64,
        pixels: n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scores_count_errors_above_the_thresholds_inside_the_border() {
        let (w, h) = (4, 3);
        let truth = vec![0.0f32; 12];
        let mut est = vec![0.0f32; 12];
        // Inside a 1-px border only pixels (1, 1) and (2, 1) count.
        est[5] = 0.05;
        est[6] = 0.2;
        est[0] = 9.0; // in the border: ignored
        let s = score(&est, &truth, w, h, 1, None);
        assert_eq!(s.pixels, 2);
        assert_eq!(s.bad_pix_007, 50.0);
        assert_eq!(s.bad_pix_003, 100.0);
        assert!((s.mse_x100 - 100.0 * (0.05f64.powi(2) + 0.2f64.powi(2)) / 2.0).abs() < 1e-6);
        // NaN estimates are bad; NaN truth is skipped.
        est[5] = f32::NAN;
        let mut t = truth.clone();
        t[6] = f32::NAN;
        let s = score(&est, &t, w, h, 1, None);
        assert_eq!((s.pixels, s.bad_pix_001), (1, 100.0));
    }

    #[test]
    fn agreement_counts_pixels_off_by_a_tenth_and_correlates_the_maps() {
        let truth: Vec<f32> = (0..10).map(|i| i as f32 * 0.5).collect();
        // An affine copy correlates perfectly however far off it is.
        let scaled: Vec<f32> = truth.iter().map(|t| 2.0 * t - 1.0).collect();
        let s = score(&scaled, &truth, 10, 1, 0, None);
        assert!((s.pearson_r - 1.0).abs() < 1e-12, "{}", s.pearson_r);
        assert_eq!(s.off_01, 90.0); // only 2·1 − 1 = 1 lands on its truth
                                    // Reversed: r = −1; two pixels 0.05 and 0.15 off: one of ten beyond 0.1 px.
        let reversed: Vec<f32> = truth.iter().rev().copied().collect();
        assert!((score(&reversed, &truth, 10, 1, 0, None).pearson_r + 1.0).abs() < 1e-12);
        let mut near = truth.clone();
        near[3] += 0.05;
        near[7] -= 0.15;
        let s = score(&near, &truth, 10, 1, 0, None);
        assert_eq!(s.off_01, 10.0);
        assert!(s.pearson_r > 0.99 && s.pearson_r < 1.0);
        // A constant map has no correlation to speak of.
        assert!(score(&[1.0; 10], &truth, 10, 1, 0, None).pearson_r.is_nan());
    }
}
