//! Radial lens distortion and its removal on load.
//!
//! Model (the Technicolor dataset's, two radial coefficients): a point with **normalised**
//! undistorted coordinates `x = (x, y)` — camera-frame `X/Z, Y/Z`, i.e. `K⁻¹ p` for pixel
//! position `p` — is imaged at the normalised distorted position
//!
//! ```text
//! x_d = x · (1 + d1·r² + d2·r⁴),   r² = x² + y²
//! ```
//!
//! and then at pixel `K x_d`. Removing the distortion therefore needs no iteration: pixel `p`
//! of the undistorted image (same size, same K) takes the colour of the distorted image at
//! `K · distort(K⁻¹ p)`, sampled bilinearly **in linear light** (views are sRGB) and encoded
//! again with rounding. A position beyond the distorted image's edge takes the nearest edge
//! pixel (as the GPU's clamp-to-edge sampler would) and is counted.
//!
//! The model must be one-to-one over the image: the radial map `r ↦ r·(1 + d1 r² + d2 r⁴)`
//! must increase up to the largest radius of the image's corners, otherwise two directions
//! land on the same pixel and no undistorted image exists. [`RadialDistortion::check`]
//! refuses such coefficients.

use glam::{DMat3, DVec2, DVec3};
use image::RgbaImage;
use rayon::prelude::*;

use crate::color;

/// Two-coefficient radial distortion on normalised coordinates (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct RadialDistortion {
    pub d1: f64,
    pub d2: f64,
}

impl RadialDistortion {
    /// True when both coefficients are zero.
    pub fn is_none(&self) -> bool {
        self.d1 == 0.0 && self.d2 == 0.0
    }

    /// The radial factor `1 + d1 r² + d2 r⁴` at `r²`.
    pub fn factor(&self, r2: f64) -> f64 {
        1.0 + self.d1 * r2 + self.d2 * r2 * r2
    }

    /// Normalised undistorted → normalised distorted coordinates.
    pub fn distort(&self, x: DVec2) -> DVec2 {
        x * self.factor(x.length_squared())
    }

    /// Checks that the model is one-to-one for a `width × height` image with intrinsics `k`:
    /// `d(r·factor)/dr = 1 + 3 d1 r² + 5 d2 r⁴ > 0` for every radius up to the corners'.
    /// Returns the radius where it folds over when it does.
    pub fn check(&self, k: DMat3, width: u32, height: u32) -> Result<(), String> {
        if !(self.d1.is_finite() && self.d2.is_finite()) {
            return Err(format!(
                "distortion d1 = {}, d2 = {} is not finite",
                self.d1, self.d2
            ));
        }
        let k_inv = k.inverse();
        let corners = [
            (-0.5, -0.5),
            (width as f64 - 0.5, -0.5),
            (-0.5, height as f64 - 0.5),
            (width as f64 - 0.5, height as f64 - 0.5),
        ];
        let r_max = corners
            .iter()
            .map(|&(u, v)| {
                let x = k_inv * DVec3::new(u, v, 1.0);
                (x.truncate() / x.z).length()
            })
            .fold(0.0, f64::max);
        // The derivative is a quadratic in r²; checking 1000 radii up to the corners finds any
        // fold (its minimum is smooth).
        for i in 0..=1000 {
            let r = r_max * i as f64 / 1000.0;
            let r2 = r * r;
            if 1.0 + 3.0 * self.d1 * r2 + 5.0 * self.d2 * r2 * r2 <= 0.0 {
                return Err(format!(
                    "distortion d1 = {}, d2 = {} folds the image over at radius {r:.3} (normalised), \
                     inside the image (corners at {r_max:.3}): it cannot be undone",
                    self.d1, self.d2
                ));
            }
        }
        Ok(())
    }
}

/// The undistorted image of `distorted` (see the module docs) and the number of its pixels
/// that came from beyond the distorted image's edge. `k` is the camera's intrinsics, shared
/// by both images.
pub fn undistort_image(
    distorted: &RgbaImage,
    k: DMat3,
    distortion: RadialDistortion,
) -> (RgbaImage, usize) {
    let (w, h) = distorted.dimensions();
    if distortion.is_none() || w == 0 || h == 0 {
        return (distorted.clone(), 0);
    }
    let decode = color::decode_table();
    let k_inv = k.inverse();
    let src = distorted.as_raw();
    let (wi, hi) = (w as usize, h as usize);
    let texel = |x: usize, y: usize, c: usize| decode[src[(y * wi + x) * 4 + c] as usize];
    let mut out = vec![0u8; wi * hi * 4];
    let outside: usize = out
        .par_chunks_mut(wi * 4)
        .enumerate()
        .map(|(j, row)| {
            let mut outside = 0;
            for i in 0..wi {
                let x = k_inv * DVec3::new(i as f64, j as f64, 1.0);
                let xd = distortion.distort(x.truncate() / x.z);
                let p = k * xd.extend(1.0);
                let (px, py) = (p.x / p.z, p.y / p.z);
                let inside =
                    (-0.5..=w as f64 - 0.5).contains(&px) && (-0.5..=h as f64 - 0.5).contains(&py);
                if !inside {
                    outside += 1;
                }
                // Bilinear between the four nearest pixel centres, clamped to the edge.
                let fx = px.clamp(0.0, w as f64 - 1.0);
                let fy = py.clamp(0.0, h as f64 - 1.0);
                let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
                let (x1, y1) = ((x0 + 1).min(wi - 1), (y0 + 1).min(hi - 1));
                let (ax, ay) = (fx - x0 as f64, fy - y0 as f64);
                for c in 0..3 {
                    let top = texel(x0, y0, c) * (1.0 - ax) + texel(x1, y0, c) * ax;
                    let bottom = texel(x0, y1, c) * (1.0 - ax) + texel(x1, y1, c) * ax;
                    let v = top * (1.0 - ay) + bottom * ay;
                    row[4 * i + c] = color::to_u8(color::linear_to_srgb(v));
                }
                row[4 * i + 3] = 255;
            }
            outside
        })
        .sum();
    let image = RgbaImage::from_raw(w, h, out)
        // Unreachable: the buffer has exactly w·h·4 bytes.
        .unwrap_or_else(|| distorted.clone());
    (image, outside)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::intrinsics;

    #[test]
    fn zero_distortion_is_the_identity() {
        let img = RgbaImage::from_fn(8, 6, |x, y| {
            image::Rgba([x as u8 * 30, y as u8 * 40, 7, 255])
        });
        let (out, outside) = undistort_image(
            &img,
            intrinsics(10.0, 10.0, 3.5, 2.5),
            RadialDistortion::default(),
        );
        assert_eq!(out, img);
        assert_eq!(outside, 0);
    }

    #[test]
    fn undistortion_moves_a_dot_back_to_its_pinhole_position() {
        // A dot at distorted pixel q of a 64×48 view (f = 40, barrel distortion): its pinhole
        // position p solves x_d = x·(1 + d1 r² + d2 r⁴), found here by bisection on the radius,
        // independently of the code under test.
        let k = intrinsics(40.0, 40.0, 31.5, 23.5);
        let (d1, d2) = (-0.3, 0.02);
        let q = DVec2::new(52.0, 10.0);
        let xd = (k.inverse() * q.extend(1.0)).truncate();
        let rd = xd.length();
        let (mut lo, mut hi) = (rd, 2.0 * rd);
        for _ in 0..100 {
            let r = 0.5 * (lo + hi);
            if r * (1.0 + d1 * r * r + d2 * r.powi(4)) < rd {
                lo = r;
            } else {
                hi = r;
            }
        }
        let x = xd * (lo / rd);
        let p = (k * x.extend(1.0)).truncate();
        assert!(
            (p - q).length() >= 3.0,
            "the test needs a visible shift: {p}"
        );
        let mut img = RgbaImage::from_pixel(64, 48, image::Rgba([0, 0, 0, 255]));
        img.put_pixel(q.x as u32, q.y as u32, image::Rgba([255, 255, 255, 255]));
        let (out, _) = undistort_image(&img, k, RadialDistortion { d1, d2 });
        let brightest = out
            .enumerate_pixels()
            .max_by_key(|(_, _, px)| px.0[0])
            .map(|(x, y, _)| DVec2::new(x as f64, y as f64))
            .unwrap();
        // The nearest pixel centre to p (the dot spreads over the pixels around p).
        assert!((brightest - p).length() <= 0.75, "{brightest} vs {p}");
    }

    #[test]
    fn folding_distortion_is_refused() {
        let k = intrinsics(40.0, 40.0, 31.5, 23.5);
        // Corners at r ≈ 0.98: 1 + 3·d1·r² ≤ 0 for d1 = −0.5.
        let e = RadialDistortion { d1: -0.5, d2: 0.0 }
            .check(k, 64, 48)
            .unwrap_err();
        assert!(e.contains("folds the image over"), "{e}");
        assert!(RadialDistortion { d1: -0.2, d2: 0.0 }
            .check(k, 64, 48)
            .is_ok());
        assert!(RadialDistortion {
            d1: f64::NAN,
            d2: 0.0
        }
        .check(k, 64, 48)
        .is_err());
    }
}
