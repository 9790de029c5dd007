//! The f64 CPU reference renderer: the same equations and masks as the GPU pass
//! (`shaders/refocus.frag`), with exact bilinear sampling (no 8-bit snapping of sample
//! positions) and clamp-to-edge addressing (docs/conventions.md §4). The tests compare the GPU
//! against it.

use glam::DVec2;
use rayon::prelude::*;

use super::{Averaging, RefocusImage, RefocusPlan};
use crate::color;
use crate::lightfield::LightField;

/// Renders `plan` on the CPU at the views' size.
pub fn render(lf: &LightField, plan: &RefocusPlan, averaging: Averaging) -> RefocusImage {
    render_scaled(lf, plan, averaging, lf.width, lf.height)
}

/// Renders `plan` on the CPU at `w × h`: output pixel (i, j) has its centre at reference-view
/// pixel position ((i + ½)·W/w − ½, (j + ½)·H/h − ½), as on the GPU.
pub fn render_scaled(
    lf: &LightField,
    plan: &RefocusPlan,
    averaging: Averaging,
    w: u32,
    h: u32,
) -> RefocusImage {
    let scale = DVec2::new(lf.width as f64 / w as f64, lf.height as f64 / h as f64);
    let table: [f64; 256] = match averaging {
        Averaging::Linear => color::decode_table(),
        Averaging::Encoded => std::array::from_fn(|i| i as f64 / 255.0),
    };
    let (wf, hf) = (lf.width as f64, lf.height as f64);
    let mut pixels = vec![[0f32; 4]; (w * h) as usize];
    pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, out) in row.iter_mut().enumerate() {
                let px = (DVec2::new(x as f64, y as f64) + 0.5) * scale - 0.5;
                let mut sum = [0f64; 3];
                let mut wsum = 0f64;
                for v in &plan.views {
                    let q = v.warp.apply(plan.m, px);
                    if q.z.is_nan() || q.z <= 0.0 {
                        continue;
                    }
                    let p = DVec2::new(q.x / q.z, q.y / q.z);
                    if !(p.x >= -0.5 && p.x <= wf - 0.5 && p.y >= -0.5 && p.y <= hf - 0.5) {
                        continue;
                    }
                    let c = bilinear(&lf.views[v.index].image, &table, p);
                    for k in 0..3 {
                        sum[k] += v.weight * c[k];
                    }
                    wsum += v.weight;
                }
                *out = if wsum > 0.0 {
                    [
                        (sum[0] / wsum) as f32,
                        (sum[1] / wsum) as f32,
                        (sum[2] / wsum) as f32,
                        1.0,
                    ]
                } else {
                    [0.0; 4]
                };
            }
        });
    RefocusImage {
        width: w,
        height: h,
        averaging,
        pixels,
    }
}

/// Exact bilinear interpolation at pixel position `p` (pixel centres at integers) with
/// clamp-to-edge, of texels mapped through `table` (decoding before filtering, as sRGB
/// textures do).
fn bilinear(img: &image::RgbaImage, table: &[f64; 256], p: DVec2) -> [f64; 3] {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let x0 = p.x.floor();
    let y0 = p.y.floor();
    let (fx, fy) = (p.x - x0, p.y - y0);
    let xi = [
        (x0 as i64).clamp(0, w - 1) as u32,
        (x0 as i64 + 1).clamp(0, w - 1) as u32,
    ];
    let yi = [
        (y0 as i64).clamp(0, h - 1) as u32,
        (y0 as i64 + 1).clamp(0, h - 1) as u32,
    ];
    let mut c = [0f64; 3];
    for (j, &yy) in yi.iter().enumerate() {
        let wy = if j == 0 { 1.0 - fy } else { fy };
        for (i, &xx) in xi.iter().enumerate() {
            let wx = if i == 0 { 1.0 - fx } else { fx };
            let t = img.get_pixel(xx, yy).0;
            for k in 0..3 {
                c[k] += wx * wy * table[t[k] as usize];
            }
        }
    }
    c
}
