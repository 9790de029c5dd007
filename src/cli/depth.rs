//! `tiltfield depth`: estimate the reference view's disparity or depth from the light field
//! itself (a GPU plane sweep, [`crate::depth`]) and write it as PFM or EXR, with an optional
//! confidence image and, against a ground-truth disparity map, the HCI benchmark's scores.

use std::path::{Path, PathBuf};

use clap::Args;
use serde_json::json;

use super::{
    check_output, device_load_limits, load_light_field_within, parse_numbers, GpuArgs,
    LightFieldArgs,
};
use crate::depth::metrics::{score, HCI_BORDER};
use crate::depth::{Aggregation, CostKind, DepthEstimate, DepthKind, DepthOptions, ViewSet};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::jobs::depth::estimate;
use crate::lightfield::pfm::{read_pfm_depth, write_pfm};

#[derive(Debug, Args)]
pub struct DepthArgs {
    #[command(flatten)]
    pub lf: LightFieldArgs,
    /// Output map: .pfm (one channel, rows bottom-up as HCI's) or .exr (channel Y for
    /// disparity, Z for depth). NaN where there is no value.
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// disparity (the light field's convention: HCI on HCI folders, rig manifests and built-in
    /// scenes, classic shift-and-sum on grid folders) or depth (camera z, world units).
    /// Default: disparity where the light field has a convention, else depth.
    #[arg(long, value_name = "KIND")]
    pub kind: Option<String>,
    /// Number of planes, uniform in inverse depth; default: one per half pixel of motion in
    /// the farthest matched view over the range (16 to 256).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub planes: Option<usize>,
    /// Swept range MIN,MAX in --kind units (depth: NEAR,FAR); default: the dataset's
    /// disp_min,disp_max, else found by a coarse sweep.
    #[arg(long, value_name = "MIN,MAX", allow_hyphen_values = true)]
    pub range: Option<String>,
    /// Views matched against the reference: all, cross (its row and column), cross:N (N steps
    /// along them), square:N (the (2N+1)² block).
    #[arg(long, value_name = "SET", default_value = "cross")]
    pub views: ViewSet,
    /// Reference view S,T (whole grid positions); default: the middle view.
    #[arg(long, value_name = "S,T")]
    pub view: Option<String>,
    /// Write the confidence (0 … 1) as an 8-bit grey PNG.
    #[arg(long, value_name = "CONF.png")]
    pub confidence: Option<PathBuf>,
    /// Photo-consistency cost: robust (two best half-apertures) or mean (SAD over the views).
    #[arg(long, value_name = "COST")]
    pub cost: Option<CostKind>,
    /// Cost aggregation: guided (edge-aware, by the reference view), box or none.
    #[arg(long, value_name = "AGG")]
    pub aggregation: Option<Aggregation>,
    /// Aggregation window radius, pixels.
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    pub radius: Option<u32>,
    /// The naive baseline: SAD over the views with box aggregation (same planes and views).
    #[arg(long, conflicts_with_all = ["cost", "aggregation"])]
    pub naive: bool,
    /// Skip the continuous fit after the sweep (the sweep's sub-plane winner; faster).
    #[arg(long)]
    pub no_fit: bool,
    /// Leave depth edges where the windows put them: no per-pixel choice between the two
    /// sides of each depth jump (docs/depth.md, step 8)
    #[arg(long)]
    pub no_snap: bool,
    /// Skip the global refinement after the fit: no second-order smoothness prior filling
    /// weakly textured pixels from the surface around them (docs/depth.md, step 7b)
    #[arg(long)]
    pub no_smooth: bool,
    /// Skip the plane fill: the dominant planes of the estimate (walls, floors) are not given
    /// to their weakly textured pixels (docs/depth.md, step 7c)
    #[arg(long)]
    pub no_plane_fill: bool,
    /// Window radius of the colour-weighted median of the sweep's winners (0: none; default
    /// 14, none with --naive; above 6 the window is sampled every other pixel and an odd
    /// radius rounds up): gives pixels of a faint surface back the depth of their own colour
    /// region where a nearer object was fattened into them.
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    pub median: Option<u32>,
    /// Match (almost) black views too (vignetted corners are left out by default).
    #[arg(long)]
    pub include_dark: bool,
    /// Score the disparity against this ground-truth disparity map (PFM, e.g. HCI's
    /// gt_disp_lowres.pfm) or another estimate of it (a learned network's, on a real capture):
    /// BadPix 0.07/0.03/0.01, MSE×100, the share of pixels off by more than 0.1 px and
    /// Pearson's r, with a 15-px border.
    #[arg(long, value_name = "GT.pfm")]
    pub score: Option<PathBuf>,
    /// Print what was estimated, the timings and any scores as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

#[derive(Debug, Args)]
pub struct DepthSetArgs {
    /// Views a side of the synthetic scenes (odd, 3 to 9).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true)]
    pub grid: usize,
    /// Size of the synthetic views, px (48 to 512).
    #[arg(long, default_value_t = 96, allow_negative_numbers = true)]
    pub size: u32,
    /// Only these synthetic scenes (comma-separated); default: the whole set.
    #[arg(long, value_name = "A,B,…", value_delimiter = ',')]
    pub scenes: Option<Vec<String>>,
    /// An HCI folder with gt_disp_lowres.pfm to add to the set (repeatable).
    #[arg(long, value_name = "DIR")]
    pub hci: Vec<PathBuf>,
    /// Estimator variants to compare (comma-separated): default; no-fit, no-median,
    /// no-smooth, no-plane-fill, no-snap (the default without that step); sweep (the sweep
    /// alone, none of those steps); naive (SAD over the same views, box aggregation).
    #[arg(
        long,
        value_name = "A,B,…",
        value_delimiter = ',',
        default_value = "default,sweep,naive"
    )]
    pub variants: Vec<String>,
    /// Also write the table to this Markdown file.
    #[arg(long, value_name = "FILE.md")]
    pub markdown: Option<PathBuf>,
    /// Write a figure per scene and variant into DIR (SCENE-VARIANT.png: estimate, truth and
    /// error side by side; error black within 0.03 px, yellow within 0.07, red beyond), the
    /// estimate itself (SCENE-VARIANT.pfm, disparity) and the truth (SCENE-truth.pfm).
    #[arg(long, value_name = "DIR")]
    pub maps: Option<PathBuf>,
    /// Print the rows as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

/// `tiltfield depth-set`: the whole test set, every variant, one table.
pub fn run_set(args: &DepthSetArgs) -> Result<()> {
    use crate::bench::depth_set as testset;
    let variants = args
        .variants
        .iter()
        .map(|v| Ok((v.clone(), testset::variant(v)?)))
        .collect::<Result<Vec<_>>>()?;
    if let Some(md) = &args.markdown {
        check_output(md)?;
    }
    let mut set = testset::synthetic(args.grid, args.size, args.scenes.as_deref())?;
    for dir in &args.hci {
        set.push(testset::hci(dir)?);
    }
    let ctx = GpuContext::new(&args.gpu.options())?;
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("scoring {bar:30} {pos}/{len} estimates {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let maps = args
        .maps
        .as_deref()
        .map(crate::io::OutputFolder::create)
        .transpose()?;
    let rows = testset::score_set(&ctx, &set, &variants, &bar, |scene, variant, d| {
        let Some(dir) = &maps else { return Ok(()) };
        let stem = format!("{}-{variant}", scene.name);
        let figure = testset::error_figure(scene, d);
        dir.track(&dir.path().join(format!("{stem}.png")), |p| {
            crate::io::save_png(&figure, p)
        })?;
        let (w, h) = (scene.light_field.width, scene.light_field.height);
        dir.track(&dir.path().join(format!("{stem}.pfm")), |p| {
            write_pfm(p, w, h, 1, d)
        })?;
        // The truth beside the estimates (once per scene, with its first variant), for
        // anyone's own analysis of the errors.
        if args.variants.first().map(String::as_str) != Some(variant) {
            return Ok(());
        }
        let truth = dir.path().join(format!("{}-truth.pfm", scene.name));
        dir.track(&truth, |p| write_pfm(p, w, h, 1, &scene.truth))
    })?;
    bar.finish_and_clear();
    if let Some(dir) = maps {
        dir.finish();
    }
    ctx.check_validation("while scoring the set")?;
    let table = format!(
        "{}\nConfidence calibration (pooled over the scenes):\n\n{}\nBadPix 0.07 by confidence \
         decile (pooled over the scenes):\n\n{}",
        testset::markdown(&rows),
        testset::calibration_markdown(&rows),
        testset::decile_markdown(&rows)
    );
    super::report_set(
        &table,
        args.markdown.as_deref(),
        args.json
            .then(|| json!({"device": ctx.info.name, "rows": rows})),
        &ctx.info.name,
    )
}

use crate::depth::request::{parse_kind, DepthRequest};

/// The library options of `args` (parsing only; [`DepthRequest::options`] checks them).
pub fn options(args: &DepthArgs) -> Result<DepthOptions> {
    DepthRequest {
        kind: args.kind.as_deref().map(parse_kind).transpose()?,
        planes: args.planes,
        range: args
            .range
            .as_deref()
            .map(|t| parse_numbers(t, 2, "--range").map(|v| (v[0], v[1])))
            .transpose()?,
        views: args.views,
        reference: args
            .view
            .as_deref()
            .map(|t| parse_numbers(t, 2, "--view").map(|v| (v[0], v[1])))
            .transpose()?,
        cost: args.cost,
        aggregation: args.aggregation,
        radius: args.radius,
        naive: args.naive,
        no_fit: args.no_fit,
        no_snap: args.no_snap,
        no_smooth: args.no_smooth,
        no_plane_fill: args.no_plane_fill,
        median: args.median,
        include_dark: args.include_dark,
    }
    .options()
}

/// Writes `values` as PFM or EXR by the extension of `path`.
fn write_map(path: &Path, est: &DepthEstimate, kind: DepthKind, values: &[f32]) -> Result<()> {
    let ext = crate::io::extension_lower(path);
    match ext.as_deref() {
        Some("pfm") => write_pfm(path, est.width, est.height, 1, values),
        Some("exr") => {
            let channel = match kind {
                DepthKind::Depth => "Z",
                DepthKind::Disparity => "Y",
            };
            crate::io::save_exr_channel(est.width, est.height, channel, values, path)
        }
        _ => Err(Error::Invalid(format!(
            "{}: the map is written as .pfm or .exr",
            path.display()
        ))),
    }
}

/// Checks an output's extension among `allowed` before any work.
fn check_extension(path: &Path, allowed: &[&str], what: &str) -> Result<()> {
    let ext = crate::io::extension_lower(path);
    if ext.as_deref().is_some_and(|e| allowed.contains(&e)) {
        return Ok(());
    }
    Err(Error::Invalid(format!(
        "{}: {what} must end in {}",
        path.display(),
        allowed
            .iter()
            .map(|e| format!(".{e}"))
            .collect::<Vec<_>>()
            .join(" or ")
    )))
}

pub fn run(args: &DepthArgs) -> Result<()> {
    // Options and outputs first: bad input fails before any loading or GPU work.
    let options = options(args)?;
    check_extension(&args.output, &["pfm", "exr"], "the depth map")?;
    check_output(&args.output)?;
    if let Some(c) = &args.confidence {
        check_extension(c, &["png"], "--confidence")?;
        check_output(c)?;
    }
    let truth = args
        .score
        .as_deref()
        .map(|p| {
            let t = read_pfm_depth(p, DepthKind::Disparity)
                .map_err(|e| Error::Invalid(format!("--score: {e}")))?;
            // A truth without a single finite pixel inside the scored area would score a
            // perfect 0 on zero pixels.
            // Too small to have an inside at all: say so, not that its values are missing.
            if t.width <= 2 * HCI_BORDER || t.height <= 2 * HCI_BORDER {
                return Err(Error::bad_file(
                    p,
                    format!(
                        "--score: the ground truth is {}×{} px, too small to score: the HCI \
                         metrics leave out a {HCI_BORDER} px border, so it needs more than {} px \
                         a side",
                        t.width,
                        t.height,
                        2 * HCI_BORDER
                    ),
                ));
            }
            let inside = score(&t.values, &t.values, t.width, t.height, HCI_BORDER, None).pixels;
            if inside == 0 {
                return Err(Error::bad_file(
                    p,
                    format!(
                        "--score: the ground truth has no finite disparity inside its {HCI_BORDER} \
                         px border, so there is nothing to score"
                    ),
                ));
            }
            Ok(t)
        })
        .transpose()?;
    let ctx = GpuContext::new(&args.gpu.options())?;
    let lf = load_light_field_within(&args.lf, &device_load_limits(&ctx))?;
    if let Some(t) = &truth {
        if (t.width, t.height) != (lf.width, lf.height) {
            return Err(Error::bad_file(
                args.score.clone().unwrap_or_default(),
                format!(
                    "the ground truth is {}×{}, the views {}×{}",
                    t.width, t.height, lf.width, lf.height
                ),
            ));
        }
    }
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("sweeping {bar:30} {pos}/{len} planes {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let est = estimate(&ctx, &lf, &options, &bar)?;
    bar.finish_and_clear();
    ctx.check_validation("during the sweep")?;
    let kind = match &args.kind {
        Some(k) => parse_kind(k)?,
        None => est.natural_kind(),
    };
    let values = est.values(kind)?;
    if !values.iter().any(|v| v.is_finite()) {
        // Writing it would report success for a map with no value at all.
        return Err(Error::Invalid(format!(
            "the estimate has no finite {kind:?} value in any pixel (range {} … {} from {:?}); \
             nothing was written to {}",
            est.range.0,
            est.range.1,
            est.range_origin,
            args.output.display()
        )));
    }
    write_map(&args.output, &est, kind, &values)?;
    if let Some(path) = &args.confidence {
        let img = image::GrayImage::from_fn(est.width, est.height, |x, y| {
            let c = est.confidence[(y * est.width + x) as usize];
            image::Luma([(c.clamp(0.0, 1.0) * 255.0).round() as u8])
        });
        crate::io::save_png(&img, path)?;
    }
    let scores = truth.as_ref().map(|t| {
        let disparity = est.values(DepthKind::Disparity).unwrap_or_default();
        score(
            &disparity, &t.values, est.width, est.height, HCI_BORDER, None,
        )
    });
    if args.json {
        let report = json!({
            "output": args.output,
            "kind": kind,
            "light_field": {"name": lf.name, "grid": [lf.grid.cols, lf.grid.rows], "size": [lf.width, lf.height]},
            "estimate": est,
            "confidence_output": args.confidence,
            "scores": scores,
            "ground_truth": args.score,
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| Error::Invalid(e.to_string()))?
        );
    } else {
        let (lo, hi) = est.range;
        eprintln!(
            "wrote {} ({}×{} {kind:?} of view ({}, {}); {} planes over {lo:.4} … {hi:.4} ({:?}), \
             {} views; {} on {}){}",
            args.output.display(),
            est.width,
            est.height,
            est.reference_st.0,
            est.reference_st.1,
            est.planes,
            est.range_origin,
            est.views.len(),
            est.timings
                .gpu_ms
                .map_or("no GPU timer".into(), |ms| format!("GPU {ms:.0} ms")),
            est.device,
            scores.map_or(String::new(), |s| format!(
                "; BadPix0.07 {:.2} %, MSE×100 {:.3}, {:.1} % off by > 0.1 px, r {:.3}",
                s.bad_pix_007, s.mse_x100, s.off_01, s.pearson_r
            ))
        );
    }
    Ok(())
}

/// The progress bar of a depth estimate on `lf`: hidden when `lf` has depth (nothing will be
/// swept).
pub(crate) fn progress_bar_for(lf: &crate::lightfield::LightField) -> indicatif::ProgressBar {
    if !lf.depth.is_empty() {
        return indicatif::ProgressBar::hidden();
    }
    indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template(
            "estimating depth {bar:30} {pos}/{len} planes {elapsed}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    )
}
