//! The numbers of a benchmark: summaries of frame times, the least-squares cost model of the
//! scaling sweep, and image accuracy (PSNR and maximum error in 8-bit levels of the
//! sRGB-encoded image, the space people look at).

use crate::color;
use crate::refocus::{Averaging, RefocusImage};

/// Median, minimum and maximum of a set of frame times (ms).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Summary {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

/// `None` for an empty set. The median of an even count is the mean of the middle two.
pub fn summarize(values: &[f64]) -> Option<Summary> {
    Some(Summary {
        median: crate::gpu::timing::median(values)?,
        min: values.iter().copied().fold(f64::INFINITY, f64::min),
        max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    })
}

/// Frame time modelled as `fixed_ms + ns_per_sample · samples / 1e6` (samples = active
/// views × output pixels), fitted by least squares.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CostModel {
    /// Cost of a frame that samples nothing (ms): submission, clears, the resolve's share.
    pub fixed_ms: f64,
    /// Cost of one view-sample (ns).
    pub ns_per_sample: f64,
    /// Coefficient of determination of the fit.
    pub r_squared: f64,
}

impl CostModel {
    /// Predicted frame time (ms) for `samples` view-samples.
    pub fn predict_ms(&self, samples: f64) -> f64 {
        self.fixed_ms + self.ns_per_sample * samples / 1e6
    }
}

/// Least-squares fit of `(samples, ms)` points; `None` with fewer than two distinct sample
/// counts.
pub fn fit_cost(points: &[(f64, f64)]) -> Option<CostModel> {
    let n = points.len() as f64;
    if points.len() < 2 {
        return None;
    }
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= 0.0 || !sxx.is_finite() {
        return None;
    }
    let slope = sxy / sxx; // ms per sample
    let fixed = my - slope * mx;
    let ss_tot: f64 = points.iter().map(|p| (p.1 - my).powi(2)).sum();
    let ss_res: f64 = points
        .iter()
        .map(|p| (p.1 - (fixed + slope * p.0)).powi(2))
        .sum();
    Some(CostModel {
        fixed_ms: fixed,
        ns_per_sample: slope * 1e6,
        r_squared: if ss_tot > 0.0 {
            1.0 - ss_res / ss_tot
        } else {
            1.0
        },
    })
}

/// Accuracy of an image against another.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Accuracy {
    /// PSNR (dB) of the sRGB-encoded RGB over every pixel; infinite when identical.
    pub psnr_db: f64,
    /// Largest difference of any channel of any pixel not excluded, in 8-bit levels of the
    /// encoded value.
    pub max_levels: f64,
    /// PSNR (dB) over the pixels not excluded: what an accuracy bound is checked against,
    /// together with `max_levels`. An excluded pixel (f32 and f64 disagree on whether a sample
    /// lands inside a view) may legitimately differ by a whole view's weight, and at some
    /// focus settings a few hundred of them pulled the all-pixel PSNR below the bound while
    /// every other pixel was within 0.01 levels.
    pub psnr_counted_db: f64,
}

/// Encoded [0, 1] RGB of a float refocus image.
fn encoded(img: &RefocusImage) -> impl Iterator<Item = [f64; 3]> + '_ {
    img.pixels.iter().map(move |p| {
        let e = |c: f32| match img.averaging {
            Averaging::Linear => color::linear_to_srgb((c as f64).clamp(0.0, 1.0)),
            Averaging::Encoded => (c as f64).clamp(0.0, 1.0),
        };
        [e(p[0]), e(p[1]), e(p[2])]
    })
}

/// Compares `a` with `reference` (same size, else `None`): PSNR over every pixel, the maximum
/// error over the pixels `exclude` does not mark.
pub fn accuracy(
    a: &RefocusImage,
    reference: &RefocusImage,
    exclude: Option<&[bool]>,
) -> Option<Accuracy> {
    if (a.width, a.height) != (reference.width, reference.height) {
        return None;
    }
    let (mut se, mut n, mut max) = (0.0, 0usize, 0f64);
    let (mut se_counted, mut n_counted) = (0.0, 0usize);
    for (i, (p, q)) in encoded(a).zip(encoded(reference)).enumerate() {
        let counted = !exclude.is_some_and(|e| e.get(i).copied().unwrap_or(false));
        for k in 0..3 {
            let d = p[k] - q[k];
            se += d * d;
            if counted {
                max = max.max(d.abs());
                se_counted += d * d;
            }
        }
        n += 3;
        if counted {
            n_counted += 3;
        }
    }
    let psnr = |se: f64, n: usize| {
        let mse = se / n.max(1) as f64;
        if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * (1.0 / mse).log10()
        }
    };
    Some(Accuracy {
        psnr_db: psnr(se, n),
        max_levels: max * 255.0,
        psnr_counted_db: psnr(se_counted, n_counted),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_of_odd_and_even_counts() {
        let s = summarize(&[5.0, 1.0, 3.0]).unwrap();
        assert_eq!((s.median, s.min, s.max), (3.0, 1.0, 5.0));
        assert_eq!(summarize(&[4.0, 1.0, 2.0, 3.0]).unwrap().median, 2.5);
        assert!(summarize(&[]).is_none());
    }

    #[test]
    fn cost_fit_recovers_a_line_and_reports_its_quality() {
        // 2 ms fixed, 3 ns per sample.
        let pts: Vec<(f64, f64)> = [1e5, 4e5, 1.6e6, 6.4e6]
            .iter()
            .map(|&x| (x, 2.0 + 3.0 * x / 1e6))
            .collect();
        let m = fit_cost(&pts).unwrap();
        assert!((m.fixed_ms - 2.0).abs() < 1e-9 && (m.ns_per_sample - 3.0).abs() < 1e-9);
        assert!((m.r_squared - 1.0).abs() < 1e-12);
        assert!((m.predict_ms(1e6) - 5.0).abs() < 1e-9);
        let noisy = [(1.0, 1.0), (2.0, 3.0), (3.0, 2.0)];
        assert!(fit_cost(&noisy).unwrap().r_squared < 0.9);
        assert!(fit_cost(&[(1.0, 1.0)]).is_none());
        assert!(fit_cost(&[(1.0, 1.0), (1.0, 2.0)]).is_none());
    }

    #[test]
    fn accuracy_in_encoded_levels() {
        let img = |v: f32| RefocusImage {
            width: 2,
            height: 1,
            averaging: Averaging::Encoded,
            pixels: vec![[v, v, v, 1.0], [0.5, 0.5, 0.5, 1.0]],
        };
        let a = accuracy(&img(0.5), &img(0.5), None).unwrap();
        assert_eq!(a.psnr_db, f64::INFINITY);
        let b = accuracy(&img(0.5 + 2.0 / 255.0), &img(0.5), None).unwrap();
        assert!((b.max_levels - 2.0).abs() < 1e-4);
        // Half the channels off by 2/255: MSE = (2/255)²/2.
        let want = 10.0 * (2.0 / (2.0f64 / 255.0).powi(2)).log10();
        assert!((b.psnr_db - want).abs() < 1e-3, "{}", b.psnr_db);
        // Excluding the differing pixel removes it from the maximum and the counted PSNR, not
        // from the all-pixel PSNR.
        let e = accuracy(&img(0.5 + 2.0 / 255.0), &img(0.5), Some(&[true, false])).unwrap();
        assert_eq!((e.max_levels, e.psnr_db), (0.0, b.psnr_db));
        assert_eq!(e.psnr_counted_db, f64::INFINITY);
        assert_eq!(b.psnr_counted_db, b.psnr_db);
        let mut c = img(0.5);
        c.width = 1;
        c.pixels.truncate(1);
        assert!(accuracy(&c, &img(0.5), None).is_none());
    }
}
