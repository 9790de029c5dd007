//! The GPU half of depth estimation: the plane sweep of [`crate::depth`]'s plan run on a
//! device ([`crate::passes::depth`]), and `ensure_depth` with the cache of
//! [`crate::depth::cache`].

use image::RgbaImage;
use indicatif::ProgressBar;
use std::collections::HashMap;
use std::path::PathBuf;
use std::time::Instant;

use crate::depth::cache::{cache_dir, ensure_depth_in as ensure_with, DepthOrigin};
use crate::depth::refine::{refine_with_precision, RefineParams};
use crate::depth::smooth::{smooth, SmoothParams};
use crate::depth::{
    self, coarse_plan, downscale, plane_count, range_from_coarse, DepthEstimate, DepthOptions,
    DepthTimings,
};
use crate::depth::{photometric, RangeOrigin};
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::lightfield::LightField;
use crate::passes::depth::run_sweep;
use rayon::prelude::*;

/// Estimates the depth of `lf`'s reference view on `ctx`'s device (see the module docs).
/// `progress` gets the number of planes to sweep as its length and advances by planes.
pub fn estimate(
    ctx: &GpuContext,
    lf: &LightField,
    options: &DepthOptions,
    progress: &ProgressBar,
) -> Result<DepthEstimate> {
    let t0 = Instant::now();
    let mut plan = depth::plan(lf, options)?;
    // Vignetted views (plenoptic cameras) are brought to the reference's brightness first,
    // once for the sweep's views and the fit's together (the sets overlap, on large grids
    // they are the same).
    let reference = &lf.views[plan.reference].image;
    // The fit's views, chosen once (choosing scans every image for dark views); its plan
    // takes the sweep's final range and plane count after the sweep.
    let fit_matched =
        depth::with_views(lf, &plan, fit_views(lf, options), options.include_dark).views;
    let mut matched: Vec<usize> = plan.views.iter().map(|v| v.index).collect();
    matched.extend(fit_matched.iter().map(|v| v.index));
    matched.sort_unstable();
    matched.dedup();
    let t = Instant::now();
    let equaliser = photometric::Equaliser::new(reference);
    let equalised: HashMap<usize, photometric::Equalised> = matched
        .into_par_iter()
        .filter_map(|i| Some((i, equaliser.as_ref()?.equalise(&lf.views[i].image)?)))
        .collect();
    log::info!(
        "brightness check of the matched views: {:.0} ms",
        t.elapsed().as_secs_f64() * 1e3
    );
    if !equalised.is_empty() {
        log::info!(
            "{} matched views equalised to the reference's brightness (vignetting)",
            equalised.len()
        );
    }
    let image_of = |i: usize| equalised.get(&i).map_or(&lf.views[i].image, |e| &e.image);
    let images: Vec<&RgbaImage> = std::iter::once(reference)
        .chain(plan.views.iter().map(|v| image_of(v.index)))
        .collect();
    let auto = plan.range_origin == RangeOrigin::Automatic;
    let coarse = auto.then(|| coarse_plan(&plan));
    progress.set_length((plan.planes + coarse.as_ref().map_or(0, |(c, _)| c.planes)) as u64);
    let mut coarse_ms = None;
    if let Some((coarse, factor)) = coarse {
        let small: Vec<RgbaImage> = images.iter().map(|i| downscale(i, factor)).collect();
        let small_refs: Vec<&RgbaImage> = small.iter().collect();
        let (out, ms) = run_sweep(ctx, &coarse, &small_refs, &options.params, progress)?;
        plan.range = range_from_coarse(&coarse, &out);
        plan.planes = plane_count(&plan, options);
        log::info!(
            "automatic range {:.4} … {:.4} from a coarse sweep over {:.4} … {:.4}; {} planes",
            plan.range.0,
            plan.range.1,
            coarse.range.0,
            coarse.range.1,
            plan.planes
        );
        progress.set_length((coarse.planes + plan.planes) as u64);
        coarse_ms = ms;
    }
    let (out, gpu_ms) = run_sweep(ctx, &plan, &images, &options.params, progress)?;
    let mut param: Vec<f32> = out
        .index
        .iter()
        .map(|&k| plan.param(k as f64) as f32)
        .collect();
    let fit_plan = crate::depth::sweep::SweepPlan {
        views: fit_matched,
        ..plan.clone()
    };
    // The fit's and the edge snapping's images: the reference, then the fit's views equalised
    // like the sweep's (every view where the grid is small).
    let fit_images: Vec<&RgbaImage> = std::iter::once(reference)
        .chain(fit_plan.views.iter().map(|v| image_of(v.index)))
        .collect();
    if options.params.median_radius > 0 {
        let t = Instant::now();
        let median = crate::depth::median::weighted_median_twice(
            &param,
            reference,
            options.params.median_radius,
            options.params.median_sigma as f32,
        );
        log::info!(
            "colour-weighted median: {:.0} ms",
            t.elapsed().as_secs_f64() * 1e3
        );
        let t = Instant::now();
        let winner = std::mem::take(&mut param);
        let (arbitrated, back) =
            crate::depth::arbitrate::arbitrate(&fit_plan, &fit_images, &winner, &median);
        let kept;
        (param, kept) = crate::depth::arbitrate::keep_smooth_winners(
            plan.width as usize,
            plan.step(),
            &winner,
            arbitrated,
            photometric::is_noisy(&out.best_cost),
        );
        log::info!(
            "winner against median: {back} pixels back to the sweep's winner, {kept} smooth \
             winners kept, {:.0} ms",
            t.elapsed().as_secs_f64() * 1e3
        );
    }
    let mut precision = Vec::new();
    if options.params.fit || options.params.smooth {
        let inputs = FitInputs::new(&fit_plan, &fit_images, &equalised, &out.best_cost);
        let images = inputs.images(&fit_images);
        if options.params.fit {
            let t = Instant::now();
            (param, precision) = refine_with_precision(
                &fit_plan,
                &images,
                &inputs.weights,
                &param,
                &RefineParams::default(),
            );
            log::info!("continuous fit: {:.0} ms", t.elapsed().as_secs_f64() * 1e3);
        }
        if options.params.smooth {
            let t = Instant::now();
            param = smooth(
                &fit_plan,
                &images,
                &inputs.weights,
                &param,
                &precision,
                &SmoothParams::default(),
            );
            log::info!(
                "smoothness-weighted refinement: {:.0} ms",
                t.elapsed().as_secs_f64() * 1e3
            );
        }
    }
    if options.params.plane_fill {
        let t = Instant::now();
        let planes;
        (param, planes) = crate::depth::plane_fill::plane_fill(
            &fit_plan,
            &fit_images,
            &param,
            &precision,
            SmoothParams::default().anchor_precision,
        );
        log::info!(
            "plane fill: {} planes, {:.0} ms",
            planes.len(),
            t.elapsed().as_secs_f64() * 1e3
        );
    }
    if options.params.edge_snap {
        let t = Instant::now();
        param = crate::depth::edges::snap_edges(&fit_plan, &fit_images, &param);
        param = crate::depth::edges::unmix_outlines(&fit_plan, reference, &param);
        log::info!(
            "edge snapping and mixed outline pixels: {:.0} ms",
            t.elapsed().as_secs_f64() * 1e3
        );
    }
    Ok(DepthEstimate {
        width: plan.width,
        height: plan.height,
        reference: plan.reference,
        reference_st: plan.reference_st,
        convention: plan.convention,
        range: plan.range,
        range_origin: plan.range_origin,
        planes: plan.planes,
        views: plan.views.iter().map(|v| (v.s, v.t)).collect(),
        params: options.params,
        param,
        confidence: out.confidence,
        timings: DepthTimings {
            gpu_ms: match (gpu_ms, coarse_ms, auto) {
                (Some(a), Some(b), true) => Some(a + b),
                (Some(a), _, false) => Some(a),
                _ => None,
            },
            coarse_gpu_ms: coarse_ms,
            total_ms: t0.elapsed().as_secs_f64() * 1e3,
        },
        device: ctx.info.name.clone(),
    })
}

/// The views the continuous fit matches: every usable view of light fields of up to
/// [`FIT_ALL_VIEWS`] views, the sweep's own set beyond.
fn fit_views(lf: &LightField, options: &DepthOptions) -> crate::depth::ViewSet {
    if lf.views.len() <= FIT_ALL_VIEWS {
        crate::depth::ViewSet::All
    } else {
        options.views
    }
}

/// What the continuous fit and the global refinement match on `fit_plan`'s views: each view
/// weighted by 1/gain² of its equalisation, and on noisy views ([`photometric::is_noisy`])
/// every image smoothed once first.
struct FitInputs {
    weights: Vec<f64>,
    smoothed: Option<Vec<RgbaImage>>,
}

impl FitInputs {
    fn new(
        fit_plan: &crate::depth::sweep::SweepPlan,
        images: &[&RgbaImage],
        equalised: &HashMap<usize, photometric::Equalised>,
        best_cost: &[f32],
    ) -> Self {
        let weights: Vec<f64> = fit_plan
            .views
            .iter()
            .map(|v| {
                equalised
                    .get(&v.index)
                    .map_or(1.0, |e| 1.0 / (e.gain * e.gain).max(1e-6))
            })
            .collect();
        let passes = u32::from(photometric::is_noisy(best_cost));
        log::info!(
            "continuous fit on {} views{}",
            fit_plan.views.len(),
            if passes > 0 {
                ", smoothed (noisy views)"
            } else {
                ""
            }
        );
        let smoothed = (passes > 0).then(|| {
            images
                .iter()
                .map(|i| photometric::smooth(i, passes))
                .collect()
        });
        FitInputs { weights, smoothed }
    }

    /// The images to match: the smoothed ones, else `images` (the reference, then one per
    /// view, equalised like the sweep's).
    fn images<'a>(&'a self, images: &[&'a RgbaImage]) -> Vec<&'a RgbaImage> {
        match &self.smoothed {
            Some(s) => s.iter().collect(),
            None => images.to_vec(),
        }
    }
}

/// Light fields of at most this many views are fitted on all of them (more views, more
/// precision under noise); larger ones on the sweep's views, which bounds the fit's time.
pub const FIT_ALL_VIEWS: usize = 25;

/// Makes sure `lf` has a depth map, estimating it on `ctx` (with `progress`) when it has none
/// and the default cache folder holds no estimate ([`crate::depth::cache::ensure_depth_in`]).
pub fn ensure_depth(
    ctx: &GpuContext,
    lf: &mut LightField,
    options: &DepthOptions,
    progress: &ProgressBar,
) -> Result<DepthOrigin> {
    ensure_depth_in(ctx, lf, options, progress, cache_dir())
}

/// The estimate [`ensure_depth`] would install on `lf` (cached or made on `ctx` now), not
/// installed: `lf` stays as it is ([`crate::depth::cache::estimated_origin`]).
pub fn estimate_cached(
    ctx: &GpuContext,
    lf: &LightField,
    options: &DepthOptions,
    progress: &ProgressBar,
) -> Result<DepthOrigin> {
    crate::depth::cache::estimated_origin(lf, options, cache_dir(), |lf, options| {
        estimate(ctx, lf, options, progress)
    })
}

/// [`ensure_depth`] with the cache in `dir` (`None`: no cache).
pub fn ensure_depth_in(
    ctx: &GpuContext,
    lf: &mut LightField,
    options: &DepthOptions,
    progress: &ProgressBar,
    dir: Option<PathBuf>,
) -> Result<DepthOrigin> {
    ensure_with(lf, options, dir, |lf, options| {
        estimate(ctx, lf, options, progress)
    })
}

/// For a render or a pick that needs the scene's depth: the light field's own map, or the
/// estimate of its views with the default options (from the cache when there is one;
/// `progress` counts the swept planes). Returns where the depth came from and the default
/// normal window of a click on it; validation errors of the sweep fail it, so no front end
/// renders on a depth the validation layer objected to.
pub fn ensure_for(
    ctx: &GpuContext,
    lf: &mut LightField,
    progress: &ProgressBar,
) -> Result<(DepthOrigin, u32)> {
    let had_depth = !lf.depth.is_empty();
    let origin = ensure_depth(ctx, lf, &DepthOptions::default(), progress)?;
    if had_depth {
        // A map the estimator made (installed by an earlier request on a session's copy of
        // the light field) keeps the estimate's window, so the same click gives the same
        // plane on every call, not only on the one that estimated.
        let estimated = lf.depth.first().is_some_and(|(_, d)| d.estimated);
        let window = match estimated {
            true => crate::geometry::normals::ESTIMATED_DEPTH_WINDOW,
            false => origin.normal_window(),
        };
        return Ok((origin, window));
    }
    if let DepthOrigin::Estimated {
        cached, estimate, ..
    } = &origin
    {
        log::info!(
            "'{}' has no depth map: {} the depth of view ({}, {}) from its views",
            lf.name,
            if *cached {
                "using the cached estimate of"
            } else {
                "estimated"
            },
            estimate.reference_st.0,
            estimate.reference_st.1
        );
    }
    ctx.check_validation("while estimating depth")?;
    let window = origin.normal_window();
    Ok((origin, window))
}
