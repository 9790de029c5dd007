//! Layered anti-aliasing: an anti-aliased refocus whose cost does not grow with the footprints
//! and that needs no per-sample occlusion test (docs/antialias.md, "Layered footprints"), and
//! its f64 model. The GPU pass is `passes::refocus`'s layered stage: the default on one focus
//! plane at the views' size with a depth handed over with the light field
//! ([`Layered::Auto`](super::antialias::Layered::Auto)), and wherever `--antialias-layered on`;
//! `antialias-set --layered-model` scores this model beside whatever the set runs.
//!
//! **Why a box of the plain sum is the footprint integral.** For a parallel rig the footprint
//! that view i's aperture cell sweeps at output pixel x is the cell's rectangle `R_i` (grid
//! steps, around the view) times the residual `d = s − σ` (focus-surface minus scene inverse
//! depth) times the rig's parallax per grid step, centred on the view's plain sample
//! `y_i = H_i x` (docs/conventions.md §11). Because `H_i(x + v) = H_i x + v` for a translation,
//! the integral of view i over that footprint is the mean of its *plain* samples over the box
//! `x + d·R_i` of output pixels. So views whose cells have the same rectangle and whose samples
//! have the same residual share one box: the box of their plain sum. A box over any rectangle
//! costs the same whatever its size (running sums along the rows, then the columns).
//!
//! **Layers.** The residual is not constant, so each view's plain sample is binned by the
//! residual of what *that view* sees at it (its visibility map with the holes filled,
//! [`ViewVisibility::filled`]) into layers at nodes of footprint ([`node_px`]: a pixel apart
//! up to 3 px, then geometric; soft: the two nearest nodes, linear weights; node 0 is the
//! focus, so an in-focus sample stays unfiltered; only nodes a sample can reach are kept,
//! [`LayerPlan::slots`]; the GPU stage also skips a layer's 8×8 tiles that no binned sample's
//! box reaches: they are zero), and by the shape of its cell ([`LayerPlan::groups`]: full cells, and the rim cells of a disk by the
//! size of their part inside it, rounded to [`SHAPE_STEP`]). Every layer image, colour and
//! weight, is box-filtered by its node's footprint: along its rows, then its columns, the
//! mean of its linear interpolation over the footprint narrowed by that interpolation's own
//! variance (1/6 px²), from running sums ([`box_filter`]: f32-safe on the GPU, whatever the
//! width).
//!
//! **Occlusion by compositing.** The layers are composited front to back (ascending d is
//! nearer first): each takes the share `a = W_j / (T·W)` of what is still uncovered `T`, its
//! boxed weight `W_j` over the weight of the views at the pixel `W`, with the colour
//! `C_j / W_j`; whatever is left uncovered at the end is shared in proportion. For the
//! frontmost surface this is exact: its boxed weight is the share of the aperture whose rays
//! meet it (a view sees it at a sample exactly where the lens's ray through that part of the
//! cell meets it). Behind it, the views that see a layer stand for it wherever the lens
//! sees past the nearer ones, so a focused background behind an out-of-focus occluder keeps
//! its own sharp colour under the occluder's blur, with no test per sample.
//!
//! **What stays as in the sub-samples.** The focus test (a pixel whose views agree at the focus
//! surface is their plain sum), Catmull-Rom for samples whose footprint is under half a pixel
//! in a pixel whose own surface is in focus ([`AntialiasPlan::focused_reach`]),
//! the cells' area weights, and on an estimated depth the guard: a pixel whose own surface is
//! in focus keeps its own depth for every view that sees something farther there (an
//! estimate's silhouettes would otherwise blur it).
//!
//! **Where it is approximate.** A converging rig or a tilted plane makes `H_i` projective, so
//! the box in output pixels is the footprint only to first order; a layer's nodes quantise the
//! residual (a sample between two nodes is blurred by a mix of their boxes); a rim cell's
//! part inside the disk is a rectangle of its size; and behind the frontmost surface the
//! views' visibility stands for the lens's.

use glam::DVec2;
use rayon::prelude::*;

use super::antialias::{AntialiasPlan, ViewVisibility, FOCUSED_BLUR_PX};
use super::cpu;
use super::defocus::footprint_extent;
use super::{Averaging, RefocusImage};
use crate::lightfield::LightField;

/// The nodes lie this many pixels of footprint (of a full cell) apart up to
/// [`NODE_LINEAR_PX`], where a box is hardly wider than the texel itself, and farther out
/// [`NODE_RATIO`] times farther than the one before, so that neighbouring boxes differ by a
/// bounded fraction of their width and the node count grows with the logarithm of the blur.
pub const NODE_STEP_PX: f64 = 1.0;
pub const NODE_LINEAR_PX: f64 = 3.0;
pub const NODE_RATIO: f64 = 1.4;

/// Node j's footprint in pixels, signed as the residual (node 0: the focus).
pub fn node_px(j: i64) -> f64 {
    let k = j.unsigned_abs() as f64;
    let linear = NODE_LINEAR_PX / NODE_STEP_PX;
    let g = if k <= linear {
        k * NODE_STEP_PX
    } else {
        NODE_LINEAR_PX * NODE_RATIO.powf(k - linear)
    };
    if j < 0 {
        -g
    } else {
        g
    }
}

/// The node below footprint `px` (signed) and the share of the node above: `px` is
/// `(1 − f)·node_px(j) + f·node_px(j + 1)`, so the two nodes' boxes have the footprint's mean
/// width.
pub fn node_of(px: f64) -> (i64, f64) {
    let k = px.abs();
    let linear = NODE_LINEAR_PX / NODE_STEP_PX;
    let t = if k <= NODE_LINEAR_PX {
        k / NODE_STEP_PX
    } else {
        linear + (k / NODE_LINEAR_PX).ln() / NODE_RATIO.ln()
    };
    let t = if px < 0.0 { -t } else { t };
    let j = t.floor() as i64;
    let (a, b) = (node_px(j), node_px(j + 1));
    let f = if b > a {
        ((px - a) / (b - a)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (j, f)
}

/// Rim cells are grouped by the size of their part inside the aperture (relative to a full
/// cell, per axis) rounded to this step: halves keep three groups on a disk of radius 2
/// (full, half-wide, half-tall) at 0.04 dB from tenths' five.
pub const SHAPE_STEP: f64 = 0.5;

/// How the views of an anti-aliasing plan fall into layers.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerPlan {
    /// Each group's footprint per unit of residual inverse depth, px along x and y (the mean
    /// of its views').
    pub groups: Vec<DVec2>,
    /// The group of each of the plan's views.
    pub group_of: Vec<usize>,
    /// Pixels of a full cell's footprint per unit of residual inverse depth (the nodes'
    /// scale).
    pub px_per_residual: f64,
    /// The first node and the number of nodes: every residual a view can see, from the focus
    /// surface's range over the image against the scene depth's.
    pub first: i64,
    pub nodes: usize,
    /// The nodes some sample can reach (ascending, so front to back), each a layer per group;
    /// the others stay empty and are never stored, boxed or composited.
    pub slots: Vec<i64>,
    /// Per node of the range (`node − first`): its place in `slots`, −1 where unreachable.
    pub slot_of: Vec<i32>,
}

/// Most cell groups a plan may have (the pass's parameter block holds this many).
pub const MAX_GROUPS: usize = 8;

/// Most nodes the residual range may span (the pass's node table holds this many).
pub const MAX_NODES: usize = 128;

/// Most layers (reachable nodes × groups) a plan may have: each takes four floats a pixel
/// three times on the GPU (sums, rows, boxes).
pub const MAX_LAYERS: usize = 96;

impl LayerPlan {
    /// The groups, the nodes' scale and the reachable nodes of `aa` for an output of `w × h`
    /// (the footprints are measured at the image's centre).
    pub fn new(aa: &AntialiasPlan, (w, h): (u32, u32)) -> LayerPlan {
        let (groups, group_of, full) = cell_groups(aa, (w, h));
        let scale = full.x.max(full.y);
        let (lo, hi) = focus_range(aa, (w, h));
        // A sample's residual is s − σ for some σ of the depth (every view's map holds the
        // reference's values) or 0.
        let mut sigmas: Vec<f32> = aa
            .depth
            .inverse_depth
            .iter()
            .copied()
            .filter(|v| *v >= 0.0)
            .collect();
        sigmas.sort_by(f32::total_cmp);
        sigmas.dedup();
        let (dlo, dhi) = match (sigmas.first(), sigmas.last()) {
            (Some(&slo), Some(&shi)) => (lo - shi as f64, hi - slo as f64),
            _ => (0.0, 0.0),
        };
        let first = node_of(dlo.min(0.0) * scale).0;
        let nodes = (node_of(dhi.max(0.0) * scale).0 + 2 - first) as usize;
        // Mark the nodes each σ reaches over the focus's range, and their upper neighbours (a
        // sample's second share).
        let mut reached = vec![false; nodes];
        let mut mark = |a: i64, b: i64| {
            for j in a.max(first)..=(b + 1).min(first + nodes as i64 - 1) {
                reached[(j - first) as usize] = true;
            }
        };
        mark(0, 0);
        for &v in &sigmas {
            let v = v as f64;
            mark(node_of((lo - v) * scale).0, node_of((hi - v) * scale).0);
        }
        let slots: Vec<i64> = (0..nodes)
            .filter(|&j| reached[j])
            .map(|j| first + j as i64)
            .collect();
        let mut slot_of = vec![-1i32; nodes];
        for (k, &j) in slots.iter().enumerate() {
            slot_of[(j - first) as usize] = k as i32;
        }
        LayerPlan {
            groups,
            group_of,
            px_per_residual: scale,
            first,
            nodes,
            slots,
            slot_of,
        }
    }

    /// The layers: reachable nodes × groups.
    pub fn layers(&self) -> usize {
        self.slots.len() * self.groups.len()
    }

    /// Checks what the pass can hold: [`MAX_GROUPS`], [`MAX_LAYERS`] and [`MAX_NODES`].
    pub fn check(&self) -> crate::error::Result<()> {
        let layers = self.layers();
        if self.groups.len() > MAX_GROUPS || layers > MAX_LAYERS || self.nodes > MAX_NODES {
            return Err(crate::error::Error::Invalid(format!(
                "layered anti-aliasing holds at most {MAX_GROUPS} cell shapes and {MAX_LAYERS} \
                 layers; this plan needs {} shapes and {layers} layers (its depth range is too \
                 deep for the aperture): use --antialias-layered off",
                self.groups.len()
            )));
        }
        Ok(())
    }
}

/// The least and greatest focus inverse depth `s = max(m·x, 0)` of `aa`'s plane over an output
/// of `w × h`: linear in x before the clamp, so its extremes lie at the corners.
pub fn focus_range(aa: &AntialiasPlan, (w, h): (u32, u32)) -> (f64, f64) {
    let (wl, hl) = (w as f64 - 1.0, h as f64 - 1.0);
    [(0.0, 0.0), (wl, 0.0), (0.0, hl), (wl, hl)]
        .iter()
        .map(|&(x, y)| aa.plan.m.dot(glam::DVec3::new(x, y, 1.0)).max(0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), s| {
            (a.min(s), b.max(s))
        })
}

/// The views of `aa` grouped by the shape of their aperture cell, for an output of `w × h`
/// (footprints measured at the image's centre): each group's footprint per unit of residual
/// inverse depth, px along x and y (the mean of its views'), and each view's group. Rim cells
/// of a disk are grouped by the size of their part inside it relative to a full cell, per
/// axis, rounded to [`SHAPE_STEP`]. Last, the largest footprint per unit residual of any view.
pub fn cell_groups(aa: &AntialiasPlan, (w, h): (u32, u32)) -> (Vec<DVec2>, Vec<usize>, DVec2) {
    let centre = DVec2::new(w as f64, h as f64) / 2.0;
    let s = aa.plan.m.dot(centre.extend(1.0)).max(0.0);
    let unit: Vec<DVec2> = aa
        .plan
        .views
        .iter()
        .zip(&aa.footprints)
        .map(|(v, fp)| footprint_extent(fp, v.warp.a * centre.extend(1.0) + v.warp.b * s, 1.0))
        .collect();
    let full = unit.iter().fold(DVec2::ZERO, |a, &b| a.max(b));
    let mut keys: Vec<DVec2> = Vec::new();
    let mut group_of = Vec::with_capacity(unit.len());
    for u in &unit {
        let key = (*u / full.max(DVec2::splat(1e-12)) / SHAPE_STEP).round() * SHAPE_STEP;
        let g = keys.iter().position(|k| *k == key).unwrap_or_else(|| {
            keys.push(key);
            keys.len() - 1
        });
        group_of.push(g);
    }
    let groups = (0..keys.len())
        .map(|g| {
            let members = unit.iter().zip(&group_of).filter(|(_, &k)| k == g);
            let (sum, n) = members.fold((DVec2::ZERO, 0.0), |(a, n), (u, _)| (a + *u, n + 1.0));
            sum / n
        })
        .collect();
    (groups, group_of, full)
}

/// One view's plain sample binned: its group, residual, weight and colour.
struct Binned {
    group: usize,
    d: f64,
    weight: f64,
    colour: [f64; 3],
}

/// The f64 model of layered anti-aliasing of `aa` at the views' size (module docs), the focus
/// surface the plan's plane.
pub fn render_layered(lf: &LightField, aa: &AntialiasPlan, averaging: Averaging) -> RefocusImage {
    let (w, h) = (lf.width as usize, lf.height as usize);
    let m = aa.plan.m;
    let s_of = |px: DVec2| m.dot(px.extend(1.0)).max(0.0);
    let table = cpu::averaging_table(averaging);
    let layers = LayerPlan::new(aa, (lf.width, lf.height));
    // The plan's own maps are the filled ones when it is layered; any other plan (scored
    // beside the sub-samples) gets them here.
    let vis = match &aa.visibility {
        Some(v) if aa.settings.layered.on() => std::sync::Arc::clone(v),
        _ => std::sync::Arc::new(ViewVisibility::filled(&aa.depth, &aa.plan.views)),
    };
    let guard = aa.guard_px;
    let scale = layers.px_per_residual;
    let focused_reach = aa.focused_reach();
    let pixel = |i: usize| DVec2::new((i % w) as f64, (i / w) as f64);
    let samples = |px: DVec2| -> Vec<Binned> {
        let s = s_of(px);
        let sigma = aa.depth.at(px);
        let own = sigma.filter(|sg| guard > 0.0 && ((s - sg) * scale).abs() < guard);
        // Catmull-Rom for footprints under half a pixel in a pixel whose own surface is in
        // focus, as the sub-samples do (the GPU runs such pixels in a loop of their own).
        let focused = sigma.is_some_and(|sg| (s - sg).abs() < focused_reach);
        let mut out = Vec::with_capacity(aa.plan.views.len());
        for (k, (v, fp)) in aa.plan.views.iter().zip(&aa.footprints).enumerate() {
            let y0 = v.warp.a * px.extend(1.0) + v.warp.b * s;
            if y0.z.is_nan() || y0.z <= 0.0 {
                continue;
            }
            let p0 = y0.truncate() / y0.z;
            let seen = vis.at(k, p0);
            let d = match (own, seen) {
                // A farther surface (or none) where an estimate puts the pixel's own in focus
                // is the estimate's silhouette error: the view keeps the pixel's depth. A
                // nearer one is an occluder whose blur crosses the focused surface.
                (Some(o), Some(v)) if v > o => s - v,
                (Some(o), _) => s - o,
                (None, v) => v.map_or(0.0, |sg| s - sg),
            };
            // The cell's centroid: a rim cell's part inside the aperture is off its centre.
            let Some(p) = cpu::inside(lf, y0 + fp.offset(0.5, 0.5, d)) else {
                continue;
            };
            let img = &lf.views[v.index].image;
            // The footprint's longer side from its group's extent per unit residual.
            let unit = layers.groups[layers.group_of[k]];
            let colour = if focused && d.abs() * unit.x.max(unit.y) < FOCUSED_BLUR_PX {
                cpu::bicubic(img, &table, p)
            } else {
                cpu::bilinear(img, &table, p)
            };
            out.push(Binned {
                group: layers.group_of[k],
                d,
                weight: v.weight,
                colour,
            });
        }
        out
    };
    let (first, nodes) = (layers.first, layers.nodes);
    let ng = layers.groups.len();
    let per_px = layers.layers();
    // Per pixel: every layer's (colour·weight, weight), and the weight of the views used.
    let mut layer_px = vec![[0f64; 4]; w * h * per_px];
    let mut total = vec![0f64; w * h];
    layer_px
        .par_chunks_mut(per_px)
        .zip(total.par_iter_mut())
        .enumerate()
        .for_each(|(i, (cells, total))| {
            let binned = samples(pixel(i));
            for b in binned {
                let (j, f) = node_of(b.d * scale);
                let j = (j - first).clamp(0, nodes as i64 - 1) as usize;
                for (node, share) in [(j, 1.0 - f), (j + 1, f)] {
                    if share <= 0.0 || node >= nodes {
                        continue;
                    }
                    // Reachable by construction (LayerPlan::slots).
                    let Ok(slot) = usize::try_from(layers.slot_of[node]) else {
                        continue;
                    };
                    let cell = &mut cells[slot * ng + b.group];
                    let wt = b.weight * share;
                    for (c, v) in cell.iter_mut().zip(b.colour) {
                        *c += wt * v;
                    }
                    cell[3] += wt;
                }
                *total += b.weight;
            }
        });
    // Every layer box-filtered once: its node's footprint is one box for the whole image.
    let boxed: Vec<Option<Vec<[f64; 4]>>> = (0..per_px)
        .into_par_iter()
        .map(|l| {
            let img: Vec<[f64; 4]> = (0..w * h).map(|i| layer_px[i * per_px + l]).collect();
            if !img.iter().any(|v| v[3] > 0.0) {
                return None;
            }
            let (slot, g) = (l / ng, l % ng);
            let d = node_px(layers.slots[slot]) / scale.max(1e-12);
            let e = layers.groups[g] * d.abs();
            // The views are read bilinearly and the layer between its pixels linearly: the
            // box is narrowed by the tent's variance (1/6 px²), so the blur is the footprint's.
            let narrow = |x: f64| (x * x - 2.0).max(0.0).sqrt();
            Some(box_filter(
                &img,
                (w, h),
                DVec2::new(narrow(e.x), narrow(e.y)),
            ))
        })
        .collect();
    let mut pixels = vec![[0f32; 4]; w * h];
    pixels.par_iter_mut().enumerate().for_each(|(i, out)| {
        let px = pixel(i);
        if let Some((sum, wsum)) = cpu::focus_test(lf, aa, &table, px, s_of(px)) {
            *out = cpu::normalised(sum, wsum);
            return;
        }
        let layer = |node: usize| -> [f64; 4] {
            let mut cw = [0f64; 4];
            for img in (0..ng).filter_map(|g| boxed[node * ng + g].as_ref()) {
                for c in 0..4 {
                    cw[c] += img[i][c];
                }
            }
            cw
        };
        *out = composite((0..layers.slots.len()).map(layer), total[i]);
    });
    RefocusImage {
        width: w as u32,
        height: h as u32,
        averaging,
        pixels,
    }
}

/// The mean of `row` (samples at integer positions, linearly interpolated between them, as
/// a bilinear fetch reads a view) over `[x − width/2, x + width/2]` clipped to the samples'
/// span, at every x; `width` 0 gives the row back. The integral of the piecewise-linear row is
/// a running sum of trapezoids, so the cost does not depend on the width.
pub fn tent_box_1d<const N: usize>(row: &[[f64; N]], width: f64) -> Vec<[f64; N]> {
    let n = row.len();
    if n < 2 || width.is_nan() || width <= 0.0 {
        return row.to_vec();
    }
    // trapezoids[k]: the integral over [0, k].
    let mut trapezoids = vec![[0f64; N]; n];
    for k in 1..n {
        for c in 0..N {
            trapezoids[k][c] = trapezoids[k - 1][c] + 0.5 * (row[k - 1][c] + row[k][c]);
        }
    }
    let last = (n - 1) as f64;
    let integral = |t: f64| -> [f64; N] {
        let t = t.clamp(0.0, last);
        let k = (t.floor() as usize).min(n - 2);
        let f = t - k as f64;
        std::array::from_fn(|c| {
            trapezoids[k][c] + f * row[k][c] + 0.5 * f * f * (row[k + 1][c] - row[k][c])
        })
    };
    (0..n)
        .map(|x| {
            let (a, b) = (
                (x as f64 - width / 2.0).max(0.0),
                (x as f64 + width / 2.0).min(last),
            );
            let (ia, ib) = (integral(a), integral(b));
            std::array::from_fn(|c| (ib[c] - ia[c]) / (b - a))
        })
        .collect()
}

/// [`tent_box_1d`] along the rows (width `e.x`), then along the columns (`e.y`), of a `w × h`
/// image: the mean of its bilinear interpolation over an `e.x × e.y` box at every pixel.
pub fn box_filter<const N: usize>(
    img: &[[f64; N]],
    (w, h): (usize, usize),
    e: DVec2,
) -> Vec<[f64; N]> {
    let mut rows: Vec<[f64; N]> = Vec::with_capacity(w * h);
    for y in 0..h {
        rows.extend(tent_box_1d(&img[y * w..(y + 1) * w], e.x));
    }
    let mut out = rows.clone();
    for x in 0..w {
        let column: Vec<[f64; N]> = (0..h).map(|y| rows[y * w + x]).collect();
        for (y, v) in tent_box_1d(&column, e.y).into_iter().enumerate() {
            out[y * w + x] = v;
        }
    }
    out
}

/// Composites boxed layers `(colour·weight, weight)`, front to back, over a pixel whose views
/// weigh `total` (module docs): opaque, or transparent black where nothing contributes.
pub fn composite(layers: impl Iterator<Item = [f64; 4]>, total: f64) -> [f32; 4] {
    if total.is_nan() || total <= 0.0 {
        return [0.0; 4];
    }
    let (mut acc, mut uncovered) = ([0f64; 3], 1f64);
    for cw in layers {
        if cw[3] <= 1e-12 {
            continue;
        }
        let a = (cw[3] / (uncovered * total)).min(1.0);
        for c in 0..3 {
            acc[c] += uncovered * a * cw[c] / cw[3];
        }
        uncovered *= 1.0 - a;
        if uncovered <= 1e-12 {
            break;
        }
    }
    let covered = 1.0 - uncovered;
    if covered <= 0.0 {
        return [0.0; 4];
    }
    [
        (acc[0] / covered) as f32,
        (acc[1] / covered) as f32,
        (acc[2] / covered) as f32,
        1.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_layer_that_covers_the_pixel_hides_everything_behind_it() {
        let front = [0.2 * 3.0, 0.4 * 3.0, 0.6 * 3.0, 3.0];
        let back = [0.9 * 2.0, 0.9 * 2.0, 0.9 * 2.0, 2.0];
        let got = composite([front, back].into_iter(), 3.0);
        assert_eq!(got, [0.2, 0.4, 0.6, 1.0]);
    }

    #[test]
    fn a_partial_front_lets_the_rest_of_the_aperture_see_the_back_in_its_own_colour() {
        // The front covers 30 % of the aperture; the views that see the back (any number of
        // them) give its colour for the remaining 70 %.
        let front = [1.0 * 0.3, 0.0, 0.0, 0.3];
        for seen in [0.5, 0.7, 1.0] {
            let back = [0.0, 1.0 * seen, 0.0, seen];
            let got = composite([front, back].into_iter(), 1.0);
            let want_back = if seen >= 0.7 { 0.7 } else { seen };
            let want = [0.3 / (0.3 + want_back), want_back / (0.3 + want_back)];
            assert!((got[0] as f64 - want[0]).abs() < 1e-6, "{seen}: {got:?}");
            assert!((got[1] as f64 - want[1]).abs() < 1e-6, "{seen}: {got:?}");
        }
    }

    #[test]
    fn one_surface_split_between_two_nodes_keeps_its_coverage() {
        // A front covering 40 % split 50/50 between two nodes still covers 40 %.
        let half = [0.2, 0.0, 0.0, 0.2];
        let back = [0.0, 0.6, 0.0, 0.6];
        let got = composite([half, half, back].into_iter(), 1.0);
        assert!(
            (got[0] - 0.4).abs() < 1e-6 && (got[1] - 0.6).abs() < 1e-6,
            "{got:?}"
        );
    }

    /// The piecewise-linear row's mean over [a, b] by dense midpoint quadrature.
    fn brute_mean(row: &[[f64; 1]], a: f64, b: f64) -> f64 {
        let last = (row.len() - 1) as f64;
        let (a, b) = (a.max(0.0), b.min(last));
        let n = 20000;
        let value = |t: f64| {
            let k = (t.floor() as usize).min(row.len() - 2);
            let f = t - k as f64;
            row[k][0] * (1.0 - f) + row[k + 1][0] * f
        };
        (0..n)
            .map(|i| value(a + (i as f64 + 0.5) / n as f64 * (b - a)))
            .sum::<f64>()
            / n as f64
    }

    #[test]
    fn the_running_box_equals_the_integral_of_the_interpolated_row_for_fractional_widths_and_borders(
    ) {
        let row: Vec<[f64; 1]> = (0..17).map(|i| [((i * 7919) % 13) as f64 / 13.0]).collect();
        for width in [0.3, 1.0, 2.7, 5.25, 40.0] {
            let boxed = tent_box_1d(&row, width);
            for (x, v) in boxed.iter().enumerate() {
                let want = brute_mean(&row, x as f64 - width / 2.0, x as f64 + width / 2.0);
                assert!(
                    (v[0] - want).abs() < 1e-6,
                    "width {width} at {x}: {} vs {want}",
                    v[0]
                );
            }
        }
        // No width gives the row back; a constant row stays constant at the borders.
        assert_eq!(tent_box_1d(&row, 0.0), row);
        let flat = vec![[0.25f64; 1]; 9];
        assert!(tent_box_1d(&flat, 6.5)
            .iter()
            .all(|v| (v[0] - 0.25).abs() < 1e-12));
    }

    #[test]
    fn the_box_filter_runs_the_rows_then_the_columns() {
        let (w, h) = (6usize, 5usize);
        let img: Vec<[f64; 1]> = (0..w * h).map(|i| [(i % 7) as f64]).collect();
        let e = DVec2::new(2.5, 1.5);
        let got = box_filter(&img, (w, h), e);
        let rows: Vec<[f64; 1]> = (0..h)
            .flat_map(|y| tent_box_1d(&img[y * w..(y + 1) * w], e.x))
            .collect();
        for x in 0..w {
            let col: Vec<[f64; 1]> = (0..h).map(|y| rows[y * w + x]).collect();
            for (y, v) in tent_box_1d(&col, e.y).iter().enumerate() {
                assert!((got[y * w + x][0] - v[0]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn nodes_are_a_pixel_apart_near_the_focus_and_geometric_beyond() {
        assert_eq!(node_px(0), 0.0);
        assert_eq!(node_px(2), 2.0);
        assert_eq!(node_px(-3), -3.0);
        assert!((node_px(5) / node_px(4) - NODE_RATIO).abs() < 1e-12);
        for px in [-17.3, -3.2, -0.4, 0.0, 0.7, 2.0, 3.1, 6.9, 41.0] {
            let (j, f) = node_of(px);
            let back = (1.0 - f) * node_px(j) + f * node_px(j + 1);
            assert!(
                (back - px).abs() < 1e-9 && (0.0..=1.0).contains(&f),
                "{px}: {j} {f}"
            );
        }
    }

    #[test]
    fn nothing_seen_is_transparent_black_never_nan() {
        assert_eq!(composite(std::iter::empty(), 0.0), [0.0; 4]);
        assert_eq!(composite([[0.0; 4]].into_iter(), 1.0), [0.0; 4]);
        assert_eq!(
            composite([[1.0, 1.0, 1.0, 1.0]].into_iter(), f64::NAN),
            [0.0; 4]
        );
    }
}
