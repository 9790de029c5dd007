//! `tiltfield render`: refocus onto one plane and write PNG (8-bit sRGB) or EXR (linear float).

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use serde_json::json;

use super::focus::{focus_json, focus_summary, FocusArgs, FOCUS_OPTIONS};
use super::{
    check_output, device_load_limits, load_light_field_within, AntialiasArgs, ApertureArgs,
    GpuArgs, LightFieldArgs,
};
use crate::error::{Error, Result};
use crate::gpu::timing::median;
use crate::gpu::GpuContext;
use crate::io::OutputKind;
use crate::jobs::refocus::{GpuImage, HeadlessRenderer, RenderSettings};
use crate::lightfield::LightField;
use crate::passes::refocus::{Accumulation, Filter, OutputFormat, Strategy, WarpMemory};
use crate::passes::texture::ViewStorage;
use crate::refocus::antialias::{antialias_json, AntialiasPlan};
use crate::refocus::{self, RefocusPlan, ResolvedFocus};

/// Most `--repeat` timing frames.
const MAX_REPEAT: usize = 10_000;
/// Largest `--size` side: a float accumulation target of 8192² takes 1 GiB, which every
/// device tiltfield runs on can hold; larger requests failed deep inside Vulkan.
pub const MAX_OUTPUT_SIDE: u32 = 8192;
/// Bytes per output pixel the refocus pass holds at most (RGBA32F accumulation).
const OUTPUT_BYTES_PER_PIXEL: u64 = 16;

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("focus_plane").required(true).args(FOCUS_OPTIONS)))]
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
    /// Focus every pixel on the scene point it sees (needs the scene's depth; the focus
    /// option is then the fallback where the depth is unknown).
    #[arg(long)]
    pub all_in_focus: bool,
    /// How views are summed: fragment (one draw), batched[:N] (draws of N views) or compute.
    #[arg(long, value_name = "STRATEGY")]
    pub strategy: Option<Strategy>,
    /// Same as --strategy batched:N (0: one draw).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 0,
        conflicts_with = "strategy"
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
    #[arg(long, value_name = "N", default_value_t = 0)]
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

/// Indices of views to leave out of the aperture (vignetted black views).
pub fn dark_views(lf: &LightField, include_dark: bool) -> Vec<bool> {
    let dark = lf.excluded_views(include_dark);
    let n = dark.iter().filter(|&&d| d).count();
    if n > 0 {
        log::warn!(
            "{n} (almost) black views are left out of the aperture (--include-dark keeps them)"
        );
    }
    dark
}

/// The plan for `args` on `lf`, and how its focus was set; `default_window` is a click's
/// default normal window (larger on estimated depth).
pub fn make_plan_with_window(
    lf: &LightField,
    args: &RenderArgs,
    default_window: u32,
) -> Result<(RefocusPlan, ResolvedFocus)> {
    let reference = args.aperture.reference()?;
    let request = args
        .focus
        .request_of_first(default_window)?
        .ok_or_else(|| {
            Error::Invalid(
                "give one of --disparity, --plane, --focus, --click, --points or --points-3d"
                    .into(),
            )
        })?;
    let excluded = dark_views(lf, args.aperture.include_dark);
    let (focus, plan) =
        refocus::resolve_and_plan(lf, &request, args.aperture.aperture(), reference, &excluded)?;
    Ok((plan, focus))
}

pub use crate::refocus::plan_json;

/// The focus surface of `args` (parsing only; the library validates the combination).
pub fn focus_surface(args: &RenderArgs) -> Result<refocus::surface::FocusSurface> {
    let planes = args.focus.keyboard.planes()?;
    refocus::surface::FocusSurface::from_request(&planes, args.slab, args.all_in_focus)
}

/// The anti-aliasing plan of `args` for `plan` on `lf`, when it is on (`aa_on`); `lf` must
/// then carry depth (the caller ensured it). When anti-aliasing was not asked for but is on
/// by default (the light field ships depth), a render it cannot anti-alias (classic
/// shift-and-sum, more than 256 views in the aperture) is the plain sum, with a warning.
pub fn antialias_plan(
    lf: &LightField,
    args: &RenderArgs,
    plan: &RefocusPlan,
    aa_on: bool,
) -> Result<Option<AntialiasPlan>> {
    if !aa_on {
        return Ok(None);
    }
    let excluded = lf.excluded_views(args.aperture.include_dark);
    let made = refocus::antialias::plan_for(
        lf,
        plan,
        args.aperture.aperture(),
        &excluded,
        args.antialias.settings()?,
    );
    match made {
        Ok(aa) => Ok(Some(aa)),
        Err(e) if args.antialias.requested().is_none() => {
            log::warn!("rendering without anti-aliasing: {e}");
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// Refuses an output size the device cannot hold (its image size limit, or its largest
/// allocation for the float accumulation target), naming `--size`.
pub(crate) fn check_output_fits(ctx: &GpuContext, (w, h): (u32, u32)) -> Result<()> {
    let t = crate::passes::texture::TextureLimits::of(ctx);
    let bytes = w as u64 * h as u64 * OUTPUT_BYTES_PER_PIXEL;
    if w.max(h) > t.max_dimension || bytes > t.max_allocation.min(t.heap_bytes) {
        return Err(Error::DeviceLimit(format!(
            "--size {w}x{h} does not fit {}: at most {} pixels a side and {} MiB per image \
             ({} MiB needed)",
            ctx.info.name,
            t.max_dimension,
            t.max_allocation.min(t.heap_bytes) >> 20,
            bytes >> 20
        )));
    }
    Ok(())
}

/// Writes a GPU result to `path` (PNG or EXR by extension). Returns the uncovered pixel count.
pub fn save(image: &GpuImage, path: &std::path::Path) -> Result<usize> {
    crate::jobs::batch::save_image(image, path)
}

/// The GPU settings of `args` for an output of `kind`.
pub fn render_settings(args: &RenderArgs, kind: OutputKind) -> Result<RenderSettings> {
    let strategy = match (args.strategy, args.views_per_draw) {
        (Some(s), _) => s,
        (None, 0) => Strategy::default(),
        (None, n) => Strategy::Batched { views_per_draw: n },
    };
    let size = args
        .size
        .as_deref()
        .map(|text| super::synth::parse_pair(text, "--size"))
        .transpose()?;
    if let Some((w, h)) = size {
        if w > MAX_OUTPUT_SIDE || h > MAX_OUTPUT_SIDE {
            return Err(Error::Invalid(format!(
                "--size {w}x{h}: at most {MAX_OUTPUT_SIDE} pixels a side (the float accumulation \
                 target alone would take {:.1} GiB)",
                (w as u64 * h as u64 * OUTPUT_BYTES_PER_PIXEL) as f64 / (1u64 << 30) as f64
            )));
        }
    }
    Ok(RenderSettings {
        averaging: args.aperture.average,
        output: match kind {
            OutputKind::Png => OutputFormat::Srgb8,
            OutputKind::Exr => OutputFormat::Float,
        },
        strategy,
        filter: args.filter.unwrap_or_default(),
        size,
        accumulation: args.accumulation.unwrap_or_default(),
        warps: args.warps,
    })
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
    let settings = render_settings(args, kind)?;
    args.antialias.settings()?;
    let surface = focus_surface(args)?;
    check_output(&args.output)?;
    // The device first, so a light field it cannot hold is refused before decoding its views.
    let ctx = GpuContext::new(&args.gpu.options())?;
    if let Some(size) = settings.size {
        check_output_fits(&ctx, size)?;
    }
    let mut lf = load_light_field_within(&args.lf, &device_load_limits(&ctx))?;
    let t_load = t0.elapsed().as_secs_f64() * 1e3;
    // Clicks need depth: the light field's own map, or one estimated from its views.
    let (depth, window) = if args.focus.needs_depth() {
        let (origin, window) = super::depth::ensure_for(&ctx, &mut lf)?;
        (Some(origin), window)
    } else {
        (None, super::focus::GIVEN_DEPTH_WINDOW)
    };
    // Anti-aliasing needs the scene's depth too: given, or estimated when asked for.
    let aa_on = refocus::antialias::wanted(args.antialias.requested(), &lf);
    let depth = match depth {
        None if aa_on => Some(super::depth::ensure_for(&ctx, &mut lf)?.0),
        // A focus surface chooses its focus from the scene's depth at every pixel.
        None if surface.needs_depth() => Some(
            super::depth::ensure_for(&ctx, &mut lf)
                .map_err(|e| {
                    Error::Invalid(format!(
                        "the focus surface '{}' needs the scene's depth, which this light \
                         field lacks and cannot be estimated: {e}",
                        surface.name()
                    ))
                })?
                .0,
        ),
        d => d,
    };
    let (plan, focus) = make_plan_with_window(&lf, args, window)?;
    let aa = antialias_plan(&lf, args, &plan, aa_on)?;
    let surface_plan = refocus::surface::surface_for(&lf, &plan, &surface, aa.as_ref())?;
    if !args.json {
        if let Some(line) = focus_summary(&focus) {
            eprintln!("{line}");
        }
    }
    let t1 = Instant::now();
    let storage = args
        .storage
        .unwrap_or_else(|| ViewStorage::for_averaging(args.aperture.average));
    let mut renderer = HeadlessRenderer::with_context(std::sync::Arc::new(ctx), &lf, storage)?;
    let t_upload = t1.elapsed().as_secs_f64() * 1e3;
    let t2 = Instant::now();
    let (image, timings) = match &aa {
        _ if surface.needs_depth() => {
            renderer.render_surface(&plan, aa.as_ref(), &surface_plan, &settings)?
        }
        Some(aa) => renderer.render_antialiased(aa, &settings)?,
        None => renderer.render(&plan, &settings)?,
    };
    let t_render = t2.elapsed().as_secs_f64() * 1e3;
    let mut gpu_times: Vec<f64> = timings.iter().map(|t| t.refocus_ms).collect();
    if args.repeat > 0 {
        // indicatif draws only on a terminal; say up front what a long run is doing.
        if args.repeat >= 100 {
            eprintln!("timing {} frames…", args.repeat);
        }
        let bar = indicatif::ProgressBar::new(args.repeat as u64).with_message("timing frames");
        for _ in 0..args.repeat {
            let t = match &aa {
                _ if surface.needs_depth() => {
                    renderer
                        .render_surface(&plan, aa.as_ref(), &surface_plan, &settings)?
                        .1
                }
                Some(aa) => renderer.render_timed_antialiased(aa, &settings)?,
                None => renderer.render_timed(&plan, &settings)?,
            };
            if let Some(t) = t {
                gpu_times.push(t.refocus_ms);
            }
            bar.inc(1);
        }
        bar.finish_and_clear();
    }
    let uncovered = save(&image, &args.output)?;
    let errors = renderer.context().validation().errors();
    let renderer_storage = renderer.storage();
    let device = renderer.context().info.name.clone();
    drop(renderer);
    if errors > 0 {
        return Err(Error::Vulkan(format!(
            "{errors} validation errors while rendering (see the log above)"
        )));
    }
    let gpu_median = median(&gpu_times);
    let views_used = aa.as_ref().map_or(plan.views.len(), |a| a.plan.views.len());
    let (out_w, out_h) = settings.size.unwrap_or((plan.width, plan.height));
    let pixels = out_w as f64 * out_h as f64;
    if args.json {
        let mut report = plan_json(aa.as_ref().map_or(&plan, |a| &a.plan));
        let extra = json!({
            "light_field": {
                "name": lf.name,
                "grid": [lf.grid.cols, lf.grid.rows],
                "size": [lf.width, lf.height],
            },
            "focus": focus_json(&focus),
            "depth": depth.as_ref().map(super::depth::origin_json),
            "antialias": antialias_json(aa.as_ref(), depth.as_ref().map(super::depth::origin_json)),
            "surface": surface_plan.json(depth.as_ref().map(super::depth::origin_json)),
            "output": args.output,
            "averaging": args.aperture.average,
            "strategy": settings.strategy.name(),
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
            match (&surface, aa.is_some()) {
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
