//! The GPU half of depth estimation: the plane sweep of [`crate::depth`]'s plan run on a
//! device ([`crate::passes::depth`]), and `ensure_depth` with the cache of
//! [`crate::depth::cache`].

use image::RgbaImage;
use indicatif::ProgressBar;
use std::path::PathBuf;
use std::time::Instant;

use crate::depth::cache::{cache_dir, ensure_depth_in as ensure_with, DepthOrigin};
use crate::depth::RangeOrigin;
use crate::depth::{
    self, coarse_plan, downscale, plane_count, range_from_coarse, DepthEstimate, DepthOptions,
    DepthTimings,
};
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::lightfield::LightField;
use crate::passes::depth::run_sweep;

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
    let images: Vec<&RgbaImage> = std::iter::once(plan.reference)
        .chain(plan.views.iter().map(|v| v.index))
        .map(|i| &lf.views[i].image)
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
        progress.set_length((coarse.planes + plan.planes) as u64);
        coarse_ms = ms;
    }
    let (out, gpu_ms) = run_sweep(ctx, &plan, &images, &options.params, progress)?;
    let param = out
        .index
        .iter()
        .map(|&k| plan.param(k as f64) as f32)
        .collect();
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
