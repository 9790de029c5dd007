//! The f64 CPU reference of the sweep: the same cost, aggregation and winner-take-all as the
//! GPU pass ([`crate::passes::depth`]), written plainly, for tests on small light fields.
//! Sampling is bilinear with clamp-to-edge on the 8-bit sRGB-encoded texels, as the shader's.

use image::RgbaImage;

use super::guide::{box_mean, colours, statistics};
use super::sweep::SweepPlan;
use super::{Aggregation, CostKind, Refine, SweepOutput, SweepParams};

/// A sample of `img` at pixel position (x, y), bilinear, clamp to edge, encoded [0, 1].
pub(crate) fn bilinear(img: &RgbaImage, x: f64, y: f64) -> [f64; 3] {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let texel = |i: i64, j: i64| {
        let p = img
            .get_pixel(i.clamp(0, w - 1) as u32, j.clamp(0, h - 1) as u32)
            .0;
        [
            p[0] as f64 / 255.0,
            p[1] as f64 / 255.0,
            p[2] as f64 / 255.0,
        ]
    };
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (i, j) = (x0 as i64, y0 as i64);
    let lerp = |a: [f64; 3], b: [f64; 3], f: f64| std::array::from_fn(|c| a[c] + (b[c] - a[c]) * f);
    lerp(
        lerp(texel(i, j), texel(i + 1, j), fx),
        lerp(texel(i, j + 1), texel(i + 1, j + 1), fx),
        fy,
    )
}

/// The photo-consistency cost of every plane, `planes × pixels` (plane-major).
pub fn cost_volume(plan: &SweepPlan, images: &[&RgbaImage], params: &SweepParams) -> Vec<f64> {
    let (w, h) = (plan.width as usize, plan.height as usize);
    let reference = colours(images[0]);
    let (wf, hf) = (w as f64 - 0.5, h as f64 - 0.5);
    let mut out = vec![0.0; plan.planes * w * h];
    for k in 0..plan.planes {
        let p = plan.param(k as f64);
        for y in 0..h {
            for x in 0..w {
                let r = reference[y * w + x];
                // Second differences of the reference (clamped): the interpolation-matched
                // reference of the shader (depth_cost.comp).
                let at = |i: i64, j: i64| {
                    reference[(j.clamp(0, h as i64 - 1) as usize) * w
                        + i.clamp(0, w as i64 - 1) as usize]
                };
                let (xi, yi) = (x as i64, y as i64);
                let ddx: [f64; 3] =
                    std::array::from_fn(|c| at(xi - 1, yi)[c] + at(xi + 1, yi)[c] - 2.0 * r[c]);
                let ddy: [f64; 3] =
                    std::array::from_fn(|c| at(xi, yi - 1)[c] + at(xi, yi + 1)[c] - 2.0 * r[c]);
                let (mut sum, mut count) = ([0.0; 4], [0.0; 4]);
                let (mut total, mut used) = (0.0, 0.0);
                for (v, img) in plan.views.iter().zip(&images[1..]) {
                    let q = v.sample(glam::DVec2::new(x as f64, y as f64), p);
                    if q.z <= 0.0 {
                        continue;
                    }
                    let (qx, qy) = (q.x / q.z, q.y / q.z);
                    if qx < -0.5 || qy < -0.5 || qx > wf || qy > hf {
                        continue;
                    }
                    let c = bilinear(img, qx, qy);
                    let (fx, fy) = (qx - qx.floor(), qy - qy.floor());
                    let (ax, ay) = (0.5 * fx * (1.0 - fx), 0.5 * fy * (1.0 - fy));
                    let rb: [f64; 3] = std::array::from_fn(|k| r[k] + ax * ddx[k] + ay * ddy[k]);
                    let e =
                        ((c[0] - rb[0]).abs() + (c[1] - rb[1]).abs() + (c[2] - rb[2]).abs()) / 3.0;
                    let e = e.min(params.truncation);
                    for (half, inside) in v.halves.iter().enumerate() {
                        if *inside {
                            sum[half] += e;
                            count[half] += 1.0;
                        }
                    }
                    total += e;
                    used += 1.0;
                }
                out[k * w * h + y * w + x] = match params.cost {
                    CostKind::Mean if used > 0.0 => total / used,
                    CostKind::Mean => params.truncation,
                    CostKind::Robust => {
                        let mut means: Vec<f64> = (0..4)
                            .filter(|&i| count[i] > 0.0)
                            .map(|i| sum[i] / count[i])
                            .collect();
                        means.sort_by(f64::total_cmp);
                        match means.len() {
                            0 => params.truncation,
                            1 => means[0],
                            _ => 0.5 * (means[0] + means[1]),
                        }
                    }
                    CostKind::DropWorst => {
                        let mut means: Vec<f64> = (0..4)
                            .filter(|&i| count[i] > 0.0)
                            .map(|i| sum[i] / count[i])
                            .collect();
                        means.sort_by(f64::total_cmp);
                        match means.len() {
                            0 => params.truncation,
                            1 => means[0],
                            2 => 0.5 * (means[0] + means[1]),
                            _ => (means[0] + means[1] + means[2]) / 3.0,
                        }
                    }
                };
            }
        }
    }
    out
}

/// Aggregates every plane of `volume` with `params.aggregation`, guided by `guide`.
pub fn aggregate(
    volume: &[f64],
    guide: &RgbaImage,
    planes: usize,
    params: &SweepParams,
) -> Vec<f64> {
    let (w, h) = (guide.width() as usize, guide.height() as usize);
    let n = w * h;
    let r = params.radius as usize;
    match params.aggregation {
        Aggregation::None => volume.to_vec(),
        Aggregation::Box => volume
            .chunks(n)
            .flat_map(|p| box_mean(p, 1, w, h, r))
            .collect(),
        Aggregation::Guided => {
            let colour = colours(guide);
            let (mu, inv) = statistics(&colour, w, h, r, params.eps);
            let mut out = Vec::with_capacity(planes * n);
            for p in volume.chunks(n) {
                let ip: Vec<f64> = p
                    .iter()
                    .zip(&colour)
                    .flat_map(|(v, c)| [*v, v * c[0], v * c[1], v * c[2]])
                    .collect();
                let m = box_mean(&ip, 4, w, h, r);
                let mut ab = Vec::with_capacity(4 * n);
                for i in 0..n {
                    let mp = m[4 * i];
                    let cov = [0, 1, 2].map(|c| m[4 * i + 1 + c] - mu[i][c] * mp);
                    let s = inv[i];
                    let a = [
                        s[0] * cov[0] + s[1] * cov[1] + s[2] * cov[2],
                        s[1] * cov[0] + s[3] * cov[1] + s[4] * cov[2],
                        s[2] * cov[0] + s[4] * cov[1] + s[5] * cov[2],
                    ];
                    let b = mp - (a[0] * mu[i][0] + a[1] * mu[i][1] + a[2] * mu[i][2]);
                    ab.extend([a[0], a[1], a[2], b]);
                }
                let mab = box_mean(&ab, 4, w, h, r);
                for i in 0..n {
                    let c = colour[i];
                    out.push(
                        mab[4 * i] * c[0]
                            + mab[4 * i + 1] * c[1]
                            + mab[4 * i + 2] * c[2]
                            + mab[4 * i + 3],
                    );
                }
            }
            out
        }
    }
}

/// Winner-take-all with parabola refinement and the peak-ratio confidence (see
/// [`super::SweepOutput`]); the rival c₂ is the best cost at least `gap` planes away.
pub fn winner_take_all(
    volume: &[f64],
    planes: usize,
    n: usize,
    gap: usize,
    params: &SweepParams,
) -> SweepOutput {
    let conf_eps = params.conf_eps;
    let mut out = SweepOutput {
        index: Vec::with_capacity(n),
        confidence: Vec::with_capacity(n),
        best_cost: Vec::with_capacity(n),
    };
    for i in 0..n {
        let c = |k: usize| volume[k * n + i];
        let mut k1 = 0;
        for k in 1..planes {
            if c(k) < c(k1) {
                k1 = k;
            }
        }
        let c1 = c(k1);
        let second = (0..planes)
            .filter(|&k| k.abs_diff(k1) >= gap)
            .map(c)
            .fold(f64::INFINITY, f64::min);
        let mut index = k1 as f64;
        if k1 > 0 && k1 + 1 < planes {
            let (l, r) = (c(k1 - 1), c(k1 + 1));
            let denom = match params.refine {
                Refine::Parabola => l - 2.0 * c1 + r,
                Refine::Equiangular => l.max(r) - c1,
            };
            if denom > 0.0 {
                index += (0.5 * (l - r) / denom).clamp(-0.5, 0.5);
            }
        }
        let conf = if second.is_finite() {
            ((second - c1) / (second + conf_eps)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.index.push(index as f32);
        out.confidence.push(conf as f32);
        out.best_cost.push(c1 as f32);
    }
    out
}

/// The whole sweep on the CPU: cost, aggregation, winner-take-all. `images[0]` is the
/// reference view, `images[1..]` the matched views in plan order.
pub fn sweep(plan: &SweepPlan, images: &[&RgbaImage], params: &SweepParams) -> SweepOutput {
    let n = plan.width as usize * plan.height as usize;
    let raw = cost_volume(plan, images, params);
    let agg = aggregate(&raw, images[0], plan.planes, params);
    winner_take_all(&agg, plan.planes, n, plan.confidence_gap(), params)
}
