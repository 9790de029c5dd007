//! `tiltfield render`: refocus onto one plane and write PNG (8-bit sRGB) or EXR (linear float).

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use serde_json::json;

use super::focus::{focus_summary, FocusArgs, FOCUS_OPTIONS};
use super::{
    check_output, device_load_limits, load_light_field_within, AntialiasArgs, ApertureArgs,
    GpuArgs, LightFieldArgs,
};
use crate::error::{Error, Result};
use crate::gpu::timing::median;
use crate::gpu::GpuContext;
use crate::io::OutputKind;
use crate::jobs::refocus::{GpuImage, HeadlessRenderer};
use crate::jobs::render::{check_output_fits, prepare, render, render_timed, RenderOptions};
use crate::jobs::strategy::StrategyChoice;
use crate::refocus;
use crate::refocus::antialias::antialias_json;
use crate::refocus::settings::ViewStorage;
use crate::refocus::settings::{Accumulation, Filter, OutputFormat, WarpMemory};

/// Most `--repeat` timing frames.
const MAX_REPEAT: usize = 10_000;

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("focus_plane").args(FOCUS_OPTIONS)))]
// A focus option is required unless --all-in-focus is given, whose depth focuses every pixel
// (the library refuses it alone where the depth leaves pixels unknown).
#[command(group(
    clap::ArgGroup::new("focus_or_all")
        .required(true)
        .multiple(true)
        .args(FOCUS_OPTIONS)
        .arg("all_in_focus")
))]
pub struct RenderArgs {
    #[command(flatten)]
    pub lf: LightFieldArgs,
    /// Output image: .png (8-bit sRGB) or .exr (linear float RGBA).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    #[command(flatten)]
    pub focus: FocusArgs,
    #[command(flatten)]
    pub aperture: ApertureArgs,
    #[command(flatten)]
    pub antialias: AntialiasArgs,
    /// Focus slab: keep everything within W (world units, as --plane; measured along the
    /// plane's normal) of the one focus plane sharp. Needs the scene's depth (the light
    /// field's own map, else estimated).
    #[arg(long, value_name = "W", allow_hyphen_values = true)]
    pub slab: Option<f64>,
    /// Focus every pixel on the scene point it sees (needs the scene's depth; a focus
    /// option is then the fallback where the depth is unknown, needed only if it is).
    #[arg(long)]
    pub all_in_focus: bool,
    /// How views are summed: auto (the fastest on this device, measured on first use and
    /// cached), fragment (one draw), batched[:N] (draws of N views) or compute.
    #[arg(long, value_name = "STRATEGY", default_value = "auto")]
    pub strategy: StrategyChoice,
    /// Same as --strategy batched:N (0: one draw).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 0,
        conflicts_with = "strategy",
        allow_negative_numbers = true
    )]
    pub views_per_draw: usize,
    /// How views are sampled: hardware (bilinear), shader (exact bilinear), bicubic
    /// (Catmull-Rom in the shader) or nearest.
    #[arg(long, value_name = "FILTER")]
    pub filter: Option<Filter>,
    /// The float format views are summed in: rgba32f (default) or rgba16f.
    #[arg(long, value_name = "FORMAT")]
    pub accumulation: Option<Accumulation>,
    /// Where the shaders read the per-view warps: ubo (default up to 256 views) or ssbo.
    #[arg(long, value_name = "MEMORY")]
    pub warps: Option<WarpMemory>,
    /// How views are stored on the GPU: srgb8 or linear16 (exactly decoded linear light).
    #[arg(long, value_name = "STORAGE")]
    pub storage: Option<ViewStorage>,
    /// Output size WxH (default: the views' size); pixel centres map exactly to the views.
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Render N more frames for timing and report the median GPU time.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 0,
        allow_negative_numbers = true
    )]
    pub repeat: usize,
    /// Camera-array videos: render frames A..B (inclusive; A.. to the end, ..B from the start)
    /// with one GPU set-up; the output names each file with {frame} or {frame:05}.
    #[arg(long, value_name = "A..B", conflicts_with_all = ["frame", "repeat"])]
    pub frames: Option<String>,
    /// Print the resolved plane, views used and timings as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

pub use crate::jobs::render::dark_views;
pub use crate::refocus::plan_json;

/// The library request of `args` for an output of `kind` (parsing only: the library checks
/// and decides, [`crate::jobs::render`]).
pub fn options(args: &RenderArgs, kind: OutputKind) -> Result<RenderOptions> {
    let size = args
        .size
        .as_deref()
        .map(|text| super::synth::parse_pair(text, "--size"))
        .transpose()?;
    Ok(RenderOptions {
        focus: args.focus.options()?,
        slab: args.slab,
        all_in_focus: args.all_in_focus,
        aperture: args.aperture.aperture(),
        reference: args.aperture.reference()?,
        averaging: args.aperture.average,
        include_dark: args.aperture.include_dark,
        antialias: args.antialias.requested(),
        antialias_sampling: args.antialias.settings()?,
        strategy: args.strategy.0,
        views_per_draw: args.views_per_draw,
        filter: args.filter,
        accumulation: args.accumulation,
        warps: args.warps,
        storage: args.storage,
        size,
        output: match kind {
            OutputKind::Png => OutputFormat::Srgb8,
            OutputKind::Exr => OutputFormat::Float,
        },
    })
}

/// Writes a GPU result to `path` (PNG or EXR by extension). Returns the uncovered pixel count.
pub fn save(image: &GpuImage, path: &std::path::Path) -> Result<usize> {
    crate::jobs::batch::save_image(image, path)
}

pub fn run(args: &RenderArgs) -> Result<()> {
    if let Some(spec) = &args.frames {
        return super::frames::run(args, spec);
    }
    let t0 = Instant::now();
    let kind = OutputKind::from_path(&args.output)?;
    // Bad options and an unwritable output fail before any loading or rendering.
    if args.repeat > MAX_REPEAT {
        return Err(Error::Invalid(format!(
            "--repeat {} is more than {MAX_REPEAT} timing frames; the median of 20 to 100 is \
             plenty",
            args.repeat
        )));
    }
    let options = options(args, kind)?;
    let settings = options.check()?;
    check_output(&args.output)?;
    // The device first, so a light field it cannot hold is refused before decoding its views.
    let ctx = std::sync::Arc::new(GpuContext::new(&args.gpu.options())?);
    if let Some(size) = settings.size {
        check_output_fits(&ctx, size)?;
    }
    let mut lf = load_light_field_within(&args.lf, &device_load_limits(&ctx))?;
    let t_load = t0.elapsed().as_secs_f64() * 1e3;
    let bar = super::depth::progress_bar_for(&lf);
    let prepared = prepare(&ctx, &mut lf, &options, &bar);
    bar.finish_and_clear();
    let prepared = prepared?;
    let (focus, aa) = (&prepared.focus, &prepared.antialias);
    let (depth, surface, surface_plan) =
        (&prepared.depth, &prepared.surface, &prepared.surface_plan);
    if !args.json {
        if let Some(line) = focus_summary(focus) {
            eprintln!("{line}");
        }
    }
    let t1 = Instant::now();
    let mut renderer = HeadlessRenderer::with_context(ctx, &lf, options.storage())?;
    let t_upload = t1.elapsed().as_secs_f64() * 1e3;
    let t2 = Instant::now();
    let (image, timings) = render(&mut renderer, &prepared)?;
    let t_render = t2.elapsed().as_secs_f64() * 1e3;
    let mut gpu_times: Vec<f64> = timings.iter().map(|t| t.refocus_ms).collect();
    if args.repeat > 0 {
        // indicatif draws only on a terminal; say up front what a long run is doing.
        if args.repeat >= 100 {
            eprintln!("timing {} frames…", args.repeat);
        }
        let bar = indicatif::ProgressBar::new(args.repeat as u64).with_message("timing frames");
        for _ in 0..args.repeat {
            let t = render_timed(&mut renderer, &prepared)?;
            if let Some(t) = t {
                gpu_times.push(t.refocus_ms);
            }
            bar.inc(1);
        }
        bar.finish_and_clear();
    }
    let uncovered = save(&image, &args.output)?;
    let validated = renderer.context().check_validation("while rendering");
    let renderer_storage = renderer.storage();
    let device = renderer.context().info.name.clone();
    drop(renderer);
    validated?;
    let gpu_median = median(&gpu_times);
    let views_used = prepared.views_plan().views.len();
    let (out_w, out_h) = prepared.output_size();
    let pixels = out_w as f64 * out_h as f64;
    if args.json {
        let mut report = plan_json(prepared.views_plan());
        let extra = json!({
            "light_field": {
                "name": lf.name,
                "grid": [lf.grid.cols, lf.grid.rows],
                "size": [lf.width, lf.height],
            },
            "focus": focus.json(),
            "depth": depth.as_ref().map(crate::depth::DepthOrigin::json),
            "antialias": antialias_json(aa.as_ref(), depth.as_ref().map(crate::depth::DepthOrigin::json)),
            "surface": surface_plan.json(depth.as_ref().map(crate::depth::DepthOrigin::json)),
            "output": args.output,
            "averaging": args.aperture.average,
            "strategy": prepared.settings.strategy.name(),
            "strategy_source": prepared.strategy_source,
            "filter": settings.filter,
            "accumulation": settings.accumulation,
            "storage": renderer_storage,
            "size": [out_w, out_h],
            "aperture": {"shape": args.aperture.aperture, "radius": args.aperture.aperture_radius},
            "device": device,
            "uncovered_pixels": uncovered,
            "timings_ms": {
                "load": t_load,
                "upload": t_upload,
                "render_and_readback": t_render,
                "gpu_refocus_first": timings.map(|t| t.refocus_ms),
                "gpu_resolve_first": timings.map(|t| t.resolve_ms),
                "gpu_refocus_median": gpu_median,
                "frames": gpu_times.len(),
            },
            "view_samples_per_second": gpu_median.map(|ms| views_used as f64 * pixels / (ms / 1e3)),
        });
        if let (Some(obj), Some(extra)) = (report.as_object_mut(), extra.as_object()) {
            obj.extend(extra.clone());
        }
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| Error::Invalid(e.to_string()))?
        );
    } else {
        eprintln!(
            "wrote {} ({}×{}, {} views{}, {}{})",
            args.output.display(),
            out_w,
            out_h,
            views_used,
            match (surface, aa.is_some()) {
                (refocus::surface::FocusSurface::Plane, true) => ", anti-aliased".to_string(),
                (refocus::surface::FocusSurface::Plane, false) => String::new(),
                (s, a) => format!(
                    ", focus surface {}{}",
                    s.name(),
                    if a { ", anti-aliased" } else { "" }
                ),
            },
            gpu_median.map_or("no GPU timer".to_string(), |ms| format!(
                "GPU refocus {ms:.2} ms on {device}"
            )),
            if uncovered > 0 {
                format!(", {uncovered} pixels with no contributing view")
            } else {
                String::new()
            }
        );
    }
    Ok(())
}
