//! Box means and the per-pixel statistics of the guided filter (He, Sun, Tang 2010) that
//! aggregates the sweep's costs, guided by the reference view's colours.
//!
//! Windows are `(2r + 1)²` squares truncated at the image border; a mean divides by the
//! number of pixels actually in the window (`count = cx · cy`, the "box of ones" of He et al.),
//! the convention the GPU passes follow too.
//!
//! Guided filter of a cost slice p with colour guide I (3-vectors), per window k:
//! `a_k = (Σ_k + εU)⁻¹ (mean(I p) − μ_k mean(p))`, `b_k = mean(p) − a_kᵀ μ_k`, and the output
//! `q = mean(a)ᵀ I + mean(b)`. μ, Σ and the inverse depend on the guide only, so they are
//! computed once here (f64) and uploaded; the per-plane work is in the GPU pass.

use image::RgbaImage;

/// Guide data of one pixel as the GPU reads it (`GuidePixel` in `depth_interface.glsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GuidePixel {
    /// sRGB-encoded colour I in [0, 1] (rgb), 0 in w.
    pub colour: [f32; 4],
    /// Window mean μ of I (rgb).
    pub mean: [f32; 4],
    /// `(Σ + εU)⁻¹` entries xx, xy, xz, yy.
    pub inv0: [f32; 4],
    /// `(Σ + εU)⁻¹` entries yz, zz (then 0, 0).
    pub inv1: [f32; 4],
}

/// Number of pixels of the window of radius `r` around coordinate `i` in `0..n`.
pub fn window_count(i: usize, n: usize, r: usize) -> usize {
    (i + r).min(n - 1) - i.saturating_sub(r) + 1
}

/// Means of `channels`-interleaved `values` (`w × h`) over windows of radius `r`.
pub fn box_mean(values: &[f64], channels: usize, w: usize, h: usize, r: usize) -> Vec<f64> {
    // Integral image with a zero row and column: sum over [x0, x1) × [y0, y1).
    let stride = w + 1;
    let mut integral = vec![0.0; stride * (h + 1) * channels];
    for y in 0..h {
        let mut row = vec![0.0; channels];
        for x in 0..w {
            for c in 0..channels {
                row[c] += values[(y * w + x) * channels + c];
                integral[((y + 1) * stride + x + 1) * channels + c] =
                    integral[(y * stride + x + 1) * channels + c] + row[c];
            }
        }
    }
    let mut out = vec![0.0; w * h * channels];
    for y in 0..h {
        let (y0, y1) = (y.saturating_sub(r), (y + r).min(h - 1) + 1);
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(r), (x + r).min(w - 1) + 1);
            let n = ((y1 - y0) * (x1 - x0)) as f64;
            for c in 0..channels {
                let at = |yy: usize, xx: usize| integral[(yy * stride + xx) * channels + c];
                out[(y * w + x) * channels + c] =
                    (at(y1, x1) - at(y0, x1) - at(y1, x0) + at(y0, x0)) / n;
            }
        }
    }
    out
}

/// The reference colours, sRGB-encoded in [0, 1], row-major.
pub fn colours(image: &RgbaImage) -> Vec<[f64; 3]> {
    image
        .pixels()
        .map(|p| std::array::from_fn(|c| p.0[c] as f64 / 255.0))
        .collect()
}

/// Window means μ and the symmetric inverses `(Σ + εU)⁻¹` (xx, xy, xz, yy, yz, zz) of the guide.
pub fn statistics(
    colour: &[[f64; 3]],
    w: usize,
    h: usize,
    r: usize,
    eps: f64,
) -> (Vec<[f64; 3]>, Vec<[f64; 6]>) {
    let flat: Vec<f64> = colour.iter().flatten().copied().collect();
    let products: Vec<f64> = colour
        .iter()
        .flat_map(|c| {
            [
                c[0] * c[0],
                c[0] * c[1],
                c[0] * c[2],
                c[1] * c[1],
                c[1] * c[2],
                c[2] * c[2],
            ]
        })
        .collect();
    let mean = box_mean(&flat, 3, w, h, r);
    let second = box_mean(&products, 6, w, h, r);
    let mut means = Vec::with_capacity(w * h);
    let mut inverses = Vec::with_capacity(w * h);
    for i in 0..w * h {
        let m = [mean[3 * i], mean[3 * i + 1], mean[3 * i + 2]];
        let s = &second[6 * i..6 * i + 6];
        // Σ + εU, then its inverse by cofactors (symmetric positive definite for ε > 0).
        let xx = s[0] - m[0] * m[0] + eps;
        let xy = s[1] - m[0] * m[1];
        let xz = s[2] - m[0] * m[2];
        let yy = s[3] - m[1] * m[1] + eps;
        let yz = s[4] - m[1] * m[2];
        let zz = s[5] - m[2] * m[2] + eps;
        let c_xx = yy * zz - yz * yz;
        let c_xy = xz * yz - xy * zz;
        let c_xz = xy * yz - xz * yy;
        let c_yy = xx * zz - xz * xz;
        let c_yz = xy * xz - xx * yz;
        let c_zz = xx * yy - xy * xy;
        let det = xx * c_xx + xy * c_xy + xz * c_xz;
        means.push(m);
        inverses.push([c_xx, c_xy, c_xz, c_yy, c_yz, c_zz].map(|c| c / det));
    }
    (means, inverses)
}

/// The guide data of every pixel of `image` for windows of radius `r` and regulariser `eps`.
pub fn guide_pixels(image: &RgbaImage, r: usize, eps: f64) -> Vec<GuidePixel> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let colour = colours(image);
    let (means, inverses) = statistics(&colour, w, h, r, eps);
    colour
        .iter()
        .zip(means.iter().zip(&inverses))
        .map(|(c, (m, inv))| GuidePixel {
            colour: [c[0] as f32, c[1] as f32, c[2] as f32, 0.0],
            mean: [m[0] as f32, m[1] as f32, m[2] as f32, 0.0],
            inv0: [inv[0] as f32, inv[1] as f32, inv[2] as f32, inv[3] as f32],
            inv1: [inv[4] as f32, inv[5] as f32, 0.0, 0.0],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_means_divide_by_the_pixels_in_the_truncated_window() {
        let (w, h) = (5, 4);
        let values: Vec<f64> = (0..w * h).map(|i| (i * i % 7) as f64).collect();
        for r in [0, 1, 2, 7] {
            let m = box_mean(&values, 1, w, h, r);
            for y in 0..h {
                for x in 0..w {
                    let (mut s, mut n) = (0.0, 0);
                    for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                        for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                            s += values[yy * w + xx];
                            n += 1;
                        }
                    }
                    assert!((m[y * w + x] - s / n as f64).abs() < 1e-12);
                    assert_eq!(n, window_count(x, w, r) * window_count(y, h, r));
                }
            }
        }
    }

    #[test]
    fn the_inverse_is_the_inverse_of_the_regularised_covariance() {
        let (w, h) = (6, 5);
        let colour: Vec<[f64; 3]> = (0..w * h)
            .map(|i| {
                let f = i as f64;
                [
                    (f * 0.37).sin().abs(),
                    (f * 0.11).cos().abs(),
                    (f * 0.05) % 1.0,
                ]
            })
            .collect();
        let eps = 1e-3;
        let (means, inverses) = statistics(&colour, w, h, 1, eps);
        let i = 2 * w + 3;
        // Direct covariance of the 3×3 window around (3, 2).
        let mut cov = [[0.0; 3]; 3];
        let mut n = 0.0;
        for y in 1..=3 {
            for x in 2..=4 {
                let c = colour[y * w + x];
                for a in 0..3 {
                    for b in 0..3 {
                        cov[a][b] += (c[a] - means[i][a]) * (c[b] - means[i][b]);
                    }
                }
                n += 1.0;
            }
        }
        let inv = inverses[i];
        let m = glam::DMat3::from_cols_array_2d(&[
            [inv[0], inv[1], inv[2]],
            [inv[1], inv[3], inv[4]],
            [inv[2], inv[4], inv[5]],
        ]);
        let sigma = glam::DMat3::from_cols_array_2d(&cov.map(|row| row.map(|v| v / n)))
            + glam::DMat3::IDENTITY * eps;
        assert!((m * sigma - glam::DMat3::IDENTITY).abs_diff_eq(glam::DMat3::ZERO, 1e-9));
    }
}
