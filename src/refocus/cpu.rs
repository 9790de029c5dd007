//! The f64 CPU reference renderer: the same equations and masks as the GPU pass
//! (`shaders/refocus.frag`), with exact bilinear sampling (no 8-bit snapping of sample
//! positions) and clamp-to-edge addressing (docs/conventions.md §4). The tests compare the GPU
//! against it.
//!
//! [`render_with`] also models the GPU's other filters exactly ([`Kernel`]: nearest texel and
//! Catmull-Rom bicubic), so each filter can be held to a tight bound against its own model,
//! while the bilinear reference stays the one that defines the method.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::antialias::{
    cell_reach, focus_spread, focused_sub_sample, footprint_blur, footprint_lod, samples, span_px,
    sub_sample_residual, AntialiasPlan, Ties, FOCUSED_BLUR_PX, FOCUS_TEST_LEVELS,
};
use super::prefilter::{bilinear_texels, Pyramid};
use super::surface::SurfacePlan;
use super::{Averaging, RefocusImage, RefocusPlan};
use crate::color;
use crate::lightfield::LightField;

/// Renders `plan` on the CPU at the views' size.
pub fn render(lf: &LightField, plan: &RefocusPlan, averaging: Averaging) -> RefocusImage {
    render_scaled(lf, plan, averaging, lf.width, lf.height)
}

/// How a view is sampled at a warped position (pixel centres at integers, clamp to edge).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Kernel {
    /// Bilinear: the reference of the method.
    #[default]
    Bilinear,
    /// Catmull-Rom bicubic (a = −½), as the GPU's `bicubic` filter.
    Bicubic,
    /// The nearest texel (ties round up: floor(p + ½)), as the GPU's `nearest` filter.
    Nearest,
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
    render_with(lf, plan, averaging, w, h, Kernel::Bilinear)
}

/// [`render_scaled`] with the views sampled by `kernel`.
pub fn render_with(
    lf: &LightField,
    plan: &RefocusPlan,
    averaging: Averaging,
    w: u32,
    h: u32,
    kernel: Kernel,
) -> RefocusImage {
    // The plane's inverse depth along the pixel's ray, with the horizon rule (ViewWarp::apply).
    let m = plan.m;
    plain_with(lf, plan, averaging, (w, h), kernel, |px| {
        m.dot(px.extend(1.0)).max(0.0)
    })
}

/// The plain sum with the focus surface's inverse depth `s_of(x)` at each output pixel, the
/// views sampled by `kernel`.
fn plain_with(
    lf: &LightField,
    plan: &RefocusPlan,
    averaging: Averaging,
    (w, h): (u32, u32),
    kernel: Kernel,
    s_of: impl Fn(DVec2) -> f64 + Sync,
) -> RefocusImage {
    per_pixel(lf, averaging, (w, h), |px, table| {
        let s = s_of(px);
        let mut sum = [0f64; 3];
        let mut wsum = 0f64;
        for v in &plan.views {
            let Some(p) = inside(lf, v.warp.a * px.extend(1.0) + v.warp.b * s) else {
                continue;
            };
            let img = &lf.views[v.index].image;
            let c = match kernel {
                Kernel::Bilinear => bilinear(img, table, p),
                Kernel::Bicubic => bicubic(img, table, p),
                Kernel::Nearest => nearest(img, table, p),
            };
            for k in 0..3 {
                sum[k] += v.weight * c[k];
            }
            wsum += v.weight;
        }
        (sum, wsum)
    })
}

/// The frame every model shares: output pixel (i, j) of `w × h` at reference position
/// ((i + ½)·W/w − ½, (j + ½)·H/h − ½), `pixel(x, table)` its weighted colour sum and weight
/// (texels decoded through `table`, linear or encoded), resolved by [`normalised`].
fn per_pixel(
    lf: &LightField,
    averaging: Averaging,
    (w, h): (u32, u32),
    pixel: impl Fn(DVec2, &[f64; 256]) -> ([f64; 3], f64) + Sync,
) -> RefocusImage {
    let scale = DVec2::new(lf.width as f64 / w as f64, lf.height as f64 / h as f64);
    let table = averaging_table(averaging);
    let mut pixels = vec![[0f32; 4]; w as usize * h as usize];
    pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, out) in row.iter_mut().enumerate() {
                let px = (DVec2::new(x as f64, y as f64) + 0.5) * scale - 0.5;
                let (sum, wsum) = pixel(px, &table);
                *out = normalised(sum, wsum);
            }
        });
    RefocusImage {
        width: w,
        height: h,
        averaging,
        pixels,
    }
}

/// The value each 8-bit level is averaged as: linear light, or the encoded level itself.
pub(super) fn averaging_table(averaging: Averaging) -> [f64; 256] {
    match averaging {
        Averaging::Linear => color::decode_table(),
        Averaging::Encoded => std::array::from_fn(|i| i as f64 / 255.0),
    }
}

/// The prefilter pyramid of `img` with its texels mapped through `table` (the GPU's levels
/// average the stored values: linear light in 16-bit storage, `refocus::prefilter`).
fn view_pyramid(img: &image::RgbaImage, table: &[f64; 256]) -> Pyramid {
    let level0 = img
        .pixels()
        .map(|p| {
            [
                table[p[0] as usize],
                table[p[1] as usize],
                table[p[2] as usize],
            ]
        })
        .collect();
    Pyramid::new(level0, img.dimensions())
}

/// The sample position of the homogeneous point `q` in a view of `lf`, or `None` where the
/// mask drops it: behind the camera (or NaN), or outside the image's pixel footprints.
pub(super) fn inside(lf: &LightField, q: DVec3) -> Option<DVec2> {
    if q.z.is_nan() || q.z <= 0.0 {
        return None;
    }
    let p = DVec2::new(q.x / q.z, q.y / q.z);
    let (wf, hf) = (lf.width as f64, lf.height as f64);
    (p.x >= -0.5 && p.x <= wf - 0.5 && p.y >= -0.5 && p.y <= hf - 0.5).then_some(p)
}

/// A pixel's weighted colour sum divided by the weights used (opaque), or transparent black
/// where no view contributed: the resolve every model here ends with, as the GPU's does.
pub(super) fn normalised(sum: [f64; 3], wsum: f64) -> [f32; 4] {
    if wsum > 0.0 {
        [
            (sum[0] / wsum) as f32,
            (sum[1] / wsum) as f32,
            (sum[2] / wsum) as f32,
            1.0,
        ]
    } else {
        [0.0; 4]
    }
}

/// The f64 model of the anti-aliased sum (docs/conventions.md §11, [`super::antialias`]):
/// per view, `n_s × n_t` stratified sub-samples of its aperture cell at
/// `A_i x + b_i s + footprint(u, v)·(s − c)`, c what the sub-sample's ray hits
/// ([`sub_sample_residual`]; dropped where the view cannot see it), each masked like a plain
/// sample and weighing `weight / (n_s n_t)`; bilinear, as the GPU's default filter, except
/// in a pixel whose own surface is in focus, where sub-samples whose footprint is under half a
/// pixel take the cell's Catmull-Rom value at its centre ([`AntialiasPlan::focused_reach`]).
/// With [`AntialiasSettings::layered`](super::antialias::AntialiasSettings::layered) at the
/// views' size: the layered model ([`super::layered::render_layered`]); with
/// [`AntialiasSettings::boxed`](super::antialias::AntialiasSettings::boxed) at the views' size
/// the pixels away from occlusion edges and out of focus are boxes of the plain sums
/// ([`super::boxed::boxed_pixels`]).
pub fn render_antialiased(
    lf: &LightField,
    aa: &AntialiasPlan,
    averaging: Averaging,
    w: u32,
    h: u32,
) -> RefocusImage {
    if aa.settings.layered.on() && (w, h) == (lf.width, lf.height) {
        return super::layered::render_layered(lf, aa, averaging);
    }
    let m = aa.plan.m;
    antialiased_with(lf, aa, averaging, (w, h), true, |px| {
        m.dot(px.extend(1.0)).max(0.0)
    })
}

/// The f64 model of a focus surface's refocus (docs/conventions.md §12): the plain sum
/// (bilinear) or, with `aa`, the anti-aliased one, with the surface's inverse depth
/// [`SurfacePlan::inverse_depth`] per output pixel in place of the plane's. With `aa` the
/// surface must read `aa`'s scene depth, as the pass binds one for both.
pub fn render_surface(
    lf: &LightField,
    plan: &RefocusPlan,
    surface: &SurfacePlan,
    aa: Option<&AntialiasPlan>,
    averaging: Averaging,
    (w, h): (u32, u32),
) -> RefocusImage {
    match aa {
        Some(aa) => antialiased_with(lf, aa, averaging, (w, h), false, |px| {
            surface.inverse_depth(px)
        }),
        None => plain_with(lf, plan, averaging, (w, h), Kernel::Bilinear, |px| {
            surface.inverse_depth(px)
        }),
    }
}

/// Output pixels where f32 may legitimately differ from [`render_surface`]'s f64 model: the
/// surface's own ties ([`SurfacePlan::ambiguous`]) and, at the surface's `s`, a view's mask
/// decided within `eps` pixels of its border.
pub fn ambiguous_surface(
    lf: &LightField,
    plan: &RefocusPlan,
    surface: &SurfacePlan,
    (w, h): (u32, u32),
    eps: f64,
) -> Vec<bool> {
    let scale = DVec2::new(lf.width as f64 / w as f64, lf.height as f64 / h as f64);
    let (wf, hf) = (lf.width as f64, lf.height as f64);
    let near = |v: f64, edge: f64| (v - edge).abs() <= eps;
    (0..w as usize * h as usize)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w as usize) as f64, (i / w as usize) as f64);
            let px = (DVec2::new(x, y) + 0.5) * scale - 0.5;
            if surface.ambiguous(px, 1e-4) {
                return true;
            }
            let s = surface.inverse_depth(px);
            plan.views.iter().any(|v| {
                let q = v.warp.a * px.extend(1.0) + v.warp.b * s;
                if q.z.abs() <= eps * q.truncate().length().max(1.0) {
                    return true;
                }
                let p = DVec2::new(q.x / q.z, q.y / q.z);
                near(p.x, -0.5) || near(p.x, wf - 0.5) || near(p.y, -0.5) || near(p.y, hf - 0.5)
            })
        })
        .collect()
}

/// The anti-aliased sum with the focus surface's inverse depth `s_of(x)` at each output pixel;
/// `plane`: `s_of` is the plan's plane (boxed footprints apply to one plane only, as in the
/// pass).
fn antialiased_with(
    lf: &LightField,
    aa: &AntialiasPlan,
    averaging: Averaging,
    (w, h): (u32, u32),
    plane: bool,
    s_of: impl Fn(DVec2) -> f64 + Sync,
) -> RefocusImage {
    if aa.settings.defocus {
        return defocused_with(lf, aa, averaging, (w, h), s_of);
    }
    let plan = &aa.plan;
    let max = aa.settings.max_samples;
    let prefilter = aa.settings.prefilter;
    // Each view's pyramid in the averaging space, built once (the GPU's are made at upload).
    let table = averaging_table(averaging);
    let pyramids: Vec<Option<Pyramid>> = plan
        .views
        .par_iter()
        .map(|v| prefilter.then(|| view_pyramid(&lf.views[v.index].image, &table)))
        .collect();
    let focused_reach = aa.focused_reach();
    // Boxed footprints decide every pixel away from occlusion edges and out of focus; the
    // sub-samples below the rest.
    let boxed = (aa.settings.boxed
        && plane
        && (w, h) == (lf.width, lf.height)
        && super::boxed::can_box(aa, (w, h)))
    .then(|| super::boxed::boxed_pixels(lf, aa, averaging, &s_of));
    per_pixel(lf, averaging, (w, h), |px, table| {
        if let Some(boxed) = &boxed {
            if let Some(r) = boxed[px.y as usize * w as usize + px.x as usize] {
                return r;
            }
        }
        let s = s_of(px);
        let mut sum = [0f64; 3];
        let mut wsum = 0f64;
        let reach = cell_reach(&aa.depth, px, s);
        let sigma = aa.depth.at(px);
        // The pixel's own inverse depth where its surface is in focus.
        let focused = sigma.filter(|sigma| (s - sigma).abs() < focused_reach);
        if let Some(agreed) = focus_test(lf, aa, table, px, s) {
            return agreed;
        }
        let views = plan.views.iter().zip(&aa.footprints).zip(&pyramids);
        for (k, ((v, fp), pyramid)) in views.enumerate() {
            let y0 = v.warp.a * px.extend(1.0) + v.warp.b * s;
            let ns = samples(fp.span_s, reach, y0.z, max);
            let nt = samples(fp.span_t, reach, y0.z, max);
            let wk = v.weight / (ns * nt) as f64;
            let img = &lf.views[v.index].image;
            // In a focused pixel one Catmull-Rom read at the cell's centre, at the pixel's own
            // residual, serves every in-focus sub-sample of the cell (as the shader does).
            let sharp = focused.and_then(|sigma| {
                let c = y0 + fp.offset(0.5, 0.5, s - sigma);
                (c.z > 0.0).then(|| bicubic(img, table, DVec2::new(c.x / c.z, c.y / c.z)))
            });
            for b in 0..nt {
                let vv = (b as f64 + 0.5) / nt as f64;
                for a in 0..ns {
                    let u = (a as f64 + 0.5) / ns as f64;
                    let Some(d) = sub_sample_residual(aa, k, px, y0, s, (u, vv), &mut Ties::none())
                    else {
                        continue;
                    };
                    let Some(p) = inside(lf, y0 + fp.offset(u, vv, d)) else {
                        continue;
                    };
                    let lod = footprint_lod((fp.span_s, fp.span_t), d, y0.z, (ns, nt), prefilter);
                    let c = match (sharp, pyramid) {
                        (Some(c), _) if focused_sub_sample(fp, d, y0.z) => c,
                        (_, Some(pyr)) if lod > 0.0 => pyr.trilinear(p, lod),
                        _ => bilinear(img, table, p),
                    };
                    for k in 0..3 {
                        sum[k] += wk * c[k];
                    }
                    wsum += wk;
                }
            }
        }
        (sum, wsum)
    })
}

/// The f64 model of anti-aliasing by defocused views ([`super::defocus`]): every view
/// defocused once (its texels box-filtered over their footprints), then per output pixel the
/// focus test as in [`render_antialiased`], and per view one bilinear read of the defocused
/// view at the cell's centroid for the pixel's own residual (Catmull-Rom of the view itself
/// where the pixel's surface is in focus and the footprint is under half a pixel; the plain
/// sample where the pixel has no depth), masked like a plain sample.
fn defocused_with(
    lf: &LightField,
    aa: &AntialiasPlan,
    averaging: Averaging,
    (w, h): (u32, u32),
    s_of: impl Fn(DVec2) -> f64 + Sync,
) -> RefocusImage {
    let plan = &aa.plan;
    let table = averaging_table(averaging);
    let defocused = super::defocus::defocus_views(lf, aa, &table, &s_of);
    let focused_reach = aa.focused_reach();
    per_pixel(lf, averaging, (w, h), |px, table| {
        let s = s_of(px);
        let mut sum = [0f64; 3];
        let mut wsum = 0f64;
        let mut add = |wk: f64, c: [f64; 3]| {
            for k in 0..3 {
                sum[k] += wk * c[k];
            }
            wsum += wk;
        };
        if let Some(agreed) = focus_test(lf, aa, table, px, s) {
            return agreed;
        }
        let sigma = aa.depth.at(px);
        let focused = sigma.is_some_and(|sigma| (s - sigma).abs() < focused_reach);
        for ((v, fp), dv) in plan.views.iter().zip(&aa.footprints).zip(&defocused) {
            let y0 = v.warp.a * px.extend(1.0) + v.warp.b * s;
            let img = &lf.views[v.index].image;
            let Some(sigma) = sigma else {
                if let Some(p) = inside(lf, y0) {
                    add(v.weight, bilinear(img, table, p));
                }
                continue;
            };
            let d = s - sigma;
            let Some(p) = inside(lf, y0 + fp.offset(0.5, 0.5, d)) else {
                continue;
            };
            let c = if focused && focused_sub_sample(fp, d, y0.z) {
                bicubic(img, table, p)
            } else {
                bilinear_texels(&dv.texels, (dv.width, dv.height), p)
            };
            add(v.weight, c);
        }
        (sum, wsum)
    })
}

/// The focus test of anti-aliasing at output pixel `px` (focus-surface inverse depth `s`): where
/// the pixel has depth and the views' plain samples agree ([`focus_spread`] at most the plan's
/// threshold), they see the surface in focus and the pixel is their plain sum with the cells'
/// weights (sum, weight); `None` where the test is off or fails.
pub(super) fn focus_test(
    lf: &LightField,
    aa: &AntialiasPlan,
    table: &[f64; 256],
    px: DVec2,
    s: f64,
) -> Option<([f64; 3], f64)> {
    let threshold = aa.focus_threshold();
    if threshold <= 0.0 || aa.depth.at(px).is_none() {
        return None;
    }
    let plain: Vec<(f64, [f64; 3])> = plain_samples(lf, &aa.plan, table, px, s).collect();
    focus_spread(plain.iter().copied())
        .is_some_and(|v| v <= threshold)
        .then(|| {
            plain
                .iter()
                .fold(([0f64; 3], 0f64), |(sum, wsum), (wk, c)| {
                    (std::array::from_fn(|k| sum[k] + wk * c[k]), wsum + wk)
                })
        })
}

/// Focus peaking at the views' resolution: which reference pixels are in focus *and show it*.
/// In focus by the focus test's measure (the plain samples of `plan`'s views at the focus
/// surface `s_of(x)` agree: [`focus_spread`] at most [`FOCUS_TEST_LEVELS`] levels), and with
/// detail: the mean of those samples (square-root units, as the spread) differs from a
/// 4-neighbour's by at least [`PEAK_CONTRAST_LEVELS`]. Views agree trivially on a uniform
/// area, in focus or not, so without the second test peaking would tint every flat wall.
/// Row-major, `W × H`.
pub fn focus_peaks(
    lf: &LightField,
    plan: &RefocusPlan,
    averaging: Averaging,
    s_of: impl Fn(DVec2) -> f64 + Sync,
) -> Vec<bool> {
    let table = averaging_table(averaging);
    let (w, h) = (lf.width as usize, lf.height as usize);
    let threshold = FOCUS_TEST_LEVELS / 255.0;
    let agree_mean: Vec<(bool, f64)> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let px = DVec2::new((i % w) as f64, (i / w) as f64);
            let samples: Vec<(f64, [f64; 3])> =
                plain_samples(lf, plan, &table, px, s_of(px)).collect();
            let agree = focus_spread(samples.iter().copied()).is_some_and(|v| v <= threshold);
            let wsum: f64 = samples.iter().map(|(wk, _)| wk).sum();
            let mean = samples
                .iter()
                .map(|(wk, c)| wk * c.iter().map(|v| v.max(0.0).sqrt()).sum::<f64>() / 3.0)
                .sum::<f64>()
                / wsum.max(1e-12);
            (agree, mean)
        })
        .collect();
    let contrast = PEAK_CONTRAST_LEVELS / 255.0;
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (agree, m) = agree_mean[i];
            let (x, y) = (i % w, i / w);
            let near = [
                (x > 0).then(|| i - 1),
                (x + 1 < w).then(|| i + 1),
                (y > 0).then(|| i - w),
                (y + 1 < h).then(|| i + w),
            ];
            agree
                && near
                    .iter()
                    .flatten()
                    .any(|&n| (agree_mean[n].1 - m).abs() >= contrast)
        })
        .collect()
}

/// How far (square-root levels of 255) a pixel's plain mean must differ from a neighbour's for
/// focus peaking to count it as detail.
pub const PEAK_CONTRAST_LEVELS: f64 = 6.0;

/// Every view's plain sample at the focus surface's inverse depth `s` (weight, colour),
/// masked as §4 masks them (bilinear, the averaging space of `table`).
fn plain_samples<'a>(
    lf: &'a LightField,
    plan: &'a RefocusPlan,
    table: &'a [f64; 256],
    px: DVec2,
    s: f64,
) -> impl Iterator<Item = (f64, [f64; 3])> + 'a {
    plan.views.iter().filter_map(move |v| {
        let p = inside(lf, v.warp.a * px.extend(1.0) + v.warp.b * s)?;
        Some((v.weight, bilinear(&lf.views[v.index].image, table, p)))
    })
}

/// How close (square-root units) to the focus test's threshold a spread must be for f32 to
/// decide it the other way.
const FOCUS_TIE: f64 = 1e-4;

/// Output pixels where the anti-aliased model is ambiguous in f32: a view's sub-sample count
/// sits within `eps` (relative) of a step of its rounding, or a sub-sample lies within `eps`
/// pixels of a view's border. There the GPU may take one sub-sample more or fewer, a
/// different but equally valid quadrature of the same cell.
pub fn ambiguous_antialiased(
    lf: &LightField,
    aa: &AntialiasPlan,
    averaging: Averaging,
    (w, h): (u32, u32),
    eps: f64,
) -> Vec<bool> {
    let plan = &aa.plan;
    let scale = DVec2::new(lf.width as f64 / w as f64, lf.height as f64 / h as f64);
    let (wf, hf) = (lf.width as f64, lf.height as f64);
    let max = aa.settings.max_samples;
    let table = averaging_table(averaging);
    let threshold = aa.focus_threshold();
    let focused_reach = aa.focused_reach();
    let near = |v: f64, edge: f64| (v - edge).abs() <= eps * edge.abs().max(1.0);
    (0..w as usize * h as usize)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w as usize) as f64, (i / w as usize) as f64);
            let px = (DVec2::new(x, y) + 0.5) * scale - 0.5;
            let s = plan.m.dot(px.extend(1.0)).max(0.0);
            // The focus test decided within f32's reach of its threshold.
            if threshold > 0.0 && aa.depth.at(px).is_some() {
                let spread = focus_spread(plain_samples(lf, plan, &table, px, s));
                if spread.is_some_and(|v| (v - threshold).abs() <= FOCUS_TIE) {
                    return true;
                }
            }
            let reach = cell_reach(&aa.depth, px, s);
            // The pixel's own surface within f32's reach of the focused residual: f32 may
            // take the other interpolator for its in-focus sub-samples.
            let sigma = aa.depth.at(px);
            let gate_px = |sigma: f64| (s - sigma).abs() * FOCUSED_BLUR_PX / focused_reach;
            if focused_reach > 0.0
                && focused_reach.is_finite()
                && sigma.is_some_and(|sigma| near(gate_px(sigma), FOCUSED_BLUR_PX))
            {
                return true;
            }
            let focused = sigma.is_some_and(|sigma| (s - sigma).abs() < focused_reach);
            let views = plan.views.iter().zip(&aa.footprints).enumerate();
            views.into_iter().any(|(k, (v, fp))| {
                let y0 = v.warp.apply(plan.m, px);
                if y0.z <= eps {
                    return true;
                }
                let (ls, lt) = (
                    span_px(fp.span_s, reach, y0.z),
                    span_px(fp.span_t, reach, y0.z),
                );
                let step = |l: f64| l > 0.5 && l < max as f64 + 0.5 && near(l, l.round());
                if step(ls) || step(lt) {
                    return true;
                }
                let ns = samples(fp.span_s, reach, y0.z, max);
                let nt = samples(fp.span_t, reach, y0.z, max);
                (0..nt).any(|b| {
                    (0..ns).any(|a| {
                        let u = (a as f64 + 0.5) / ns as f64;
                        let vv = (b as f64 + 0.5) / nt as f64;
                        // The sub-sample's decisions round positions and compare depths:
                        // near a tie, f32 may decide the other way.
                        let mut ties = Ties { eps, found: false };
                        let d = sub_sample_residual(aa, k, px, y0, s, (u, vv), &mut ties);
                        if ties.found {
                            return true;
                        }
                        let Some(d) = d else {
                            return false;
                        };
                        if focused && near(footprint_blur(fp, d, y0.z), FOCUSED_BLUR_PX) {
                            return true;
                        }
                        let q = y0 + fp.offset(u, vv, d);
                        let p = DVec2::new(q.x / q.z, q.y / q.z);
                        q.z <= eps
                            || near(p.x, -0.5)
                            || near(p.x, wf - 0.5)
                            || near(p.y, -0.5)
                            || near(p.y, hf - 0.5)
                    })
                })
            })
        })
        .collect()
}

/// Exact bilinear interpolation at pixel position `p` (pixel centres at integers) with
/// clamp-to-edge, of texels mapped through `table` (decoding before filtering, as sRGB
/// textures do).
pub(super) fn bilinear(img: &image::RgbaImage, table: &[f64; 256], p: DVec2) -> [f64; 3] {
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

/// Output pixels (row-major, `w × h`) where some view's mask is decided within `eps` pixels of
/// its border (or its sample lies within `eps` relative of the view's camera plane): there an
/// f32 evaluation of the same warp may include a view that f64 excludes or vice versa, so the
/// pixel may legitimately differ by a fraction of one view's weight. Half-pixel disparities put
/// whole rows and columns exactly on a border (0 − 0.5·1 = −0.5). For [`Kernel::Nearest`] a
/// sample within `eps` of a rounding tie (a half-integer position) is ambiguous too: f32 may
/// pick the other texel.
pub fn ambiguous_pixels(
    lf: &LightField,
    plan: &RefocusPlan,
    (w, h): (u32, u32),
    kernel: Kernel,
    eps: f64,
) -> Vec<bool> {
    let scale = DVec2::new(lf.width as f64 / w as f64, lf.height as f64 / h as f64);
    let (wf, hf) = (lf.width as f64, lf.height as f64);
    let near = |v: f64, edge: f64| (v - edge).abs() <= eps;
    (0..w as usize * h as usize)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w as usize) as f64, (i / w as usize) as f64);
            let px = (DVec2::new(x, y) + 0.5) * scale - 0.5;
            plan.views.iter().any(|v| {
                let q = v.warp.apply(plan.m, px);
                if q.z.abs() <= eps * q.truncate().length().max(1.0) {
                    return true;
                }
                let p = DVec2::new(q.x / q.z, q.y / q.z);
                let tie = |v: f64| near(v + 0.5, (v + 0.5).round());
                near(p.x, -0.5)
                    || near(p.x, wf - 0.5)
                    || near(p.y, -0.5)
                    || near(p.y, hf - 0.5)
                    || (kernel == Kernel::Nearest && (tie(p.x) || tie(p.y)))
            })
        })
        .collect()
}

/// The texel at integer position (x, y), clamped to the image, through `table`.
fn texel(img: &image::RgbaImage, table: &[f64; 256], x: i64, y: i64) -> [f64; 3] {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let t = img
        .get_pixel(x.clamp(0, w - 1) as u32, y.clamp(0, h - 1) as u32)
        .0;
    [
        table[t[0] as usize],
        table[t[1] as usize],
        table[t[2] as usize],
    ]
}

/// The nearest texel to `p` (ties round up), clamp-to-edge.
fn nearest(img: &image::RgbaImage, table: &[f64; 256], p: DVec2) -> [f64; 3] {
    texel(
        img,
        table,
        (p.x + 0.5).floor() as i64,
        (p.y + 0.5).floor() as i64,
    )
}

/// Catmull-Rom weights (a = −½) of the texels at offsets −1, 0, 1, 2 from floor(p) for the
/// fraction `t` ∈ [0, 1): the same polynomials as `catmull_rom` in
/// `shaders/refocus_accumulate.glsl`.
pub fn catmull_rom(t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        -0.5 * t3 + t2 - 0.5 * t,
        1.5 * t3 - 2.5 * t2 + 1.0,
        -1.5 * t3 + 2.0 * t2 + 0.5 * t,
        0.5 * t3 - 0.5 * t2,
    ]
}

/// Catmull-Rom bicubic interpolation at `p` with clamp-to-edge (no clamping of the result:
/// it may overshoot near edges, as on the GPU).
pub(super) fn bicubic(img: &image::RgbaImage, table: &[f64; 256], p: DVec2) -> [f64; 3] {
    let (x0, y0) = (p.x.floor(), p.y.floor());
    let wx = catmull_rom(p.x - x0);
    let wy = catmull_rom(p.y - y0);
    let (xi, yi) = (x0 as i64, y0 as i64);
    let mut c = [0f64; 3];
    for (j, wyj) in wy.iter().enumerate() {
        for (i, wxi) in wx.iter().enumerate() {
            let t = texel(img, table, xi + i as i64 - 1, yi + j as i64 - 1);
            for k in 0..3 {
                c[k] += wxi * wyj * t[k];
            }
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catmull_rom_weights_partition_unity_and_interpolate() {
        assert_eq!(catmull_rom(0.0), [0.0, 1.0, 0.0, 0.0]);
        for k in 0..=16 {
            let t = k as f64 / 16.0;
            let w = catmull_rom(t);
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12, "t = {t}");
            // Linear functions are reproduced: Σ w_i (i − 1) = t.
            let lin: f64 = w
                .iter()
                .enumerate()
                .map(|(i, w)| w * (i as f64 - 1.0))
                .sum();
            assert!((lin - t).abs() < 1e-12, "t = {t}");
        }
        // Symmetric: the weights at 1 − t are the mirror image.
        let (a, b) = (catmull_rom(0.3), catmull_rom(0.7));
        for i in 0..4 {
            assert!((a[i] - b[3 - i]).abs() < 1e-12);
        }
    }

    #[test]
    fn every_kernel_reproduces_texel_centres() {
        let mut img = image::RgbaImage::new(5, 4);
        for (x, y, p) in img.enumerate_pixels_mut() {
            p.0 = [
                (x * 40 + y * 7) as u8,
                (y * y * 15) as u8,
                (x * y * 9) as u8,
                255,
            ];
        }
        let table: [f64; 256] = std::array::from_fn(|i| i as f64 / 255.0);
        for y in 0..4i64 {
            for x in 0..5i64 {
                let p = DVec2::new(x as f64, y as f64);
                let want = texel(&img, &table, x, y);
                for got in [
                    bilinear(&img, &table, p),
                    bicubic(&img, &table, p),
                    nearest(&img, &table, p),
                ] {
                    for k in 0..3 {
                        assert!((got[k] - want[k]).abs() < 1e-12, "({x},{y})");
                    }
                }
            }
        }
        // Off-centre they differ: bilinear does not reproduce the quadratic green channel.
        let p = DVec2::new(1.5, 1.5);
        assert_ne!(bicubic(&img, &table, p), bilinear(&img, &table, p));
        assert_eq!(nearest(&img, &table, p), texel(&img, &table, 2, 2));
    }
}
