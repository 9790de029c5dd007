//! `tiltfield bench`: GPU time and accuracy of every refocus variant on one device, a scaling
//! sweep, and the speed–accuracy and scaling charts. The library ([`crate::bench`]) measures;
//! this file parses, picks the scene and prints the summary.

use std::path::PathBuf;
use std::sync::Arc;

use clap::Args;

use super::focus::{focus_summary, FocusArgs};
use super::{device_load_limits, load_light_field_within, GpuArgs, LightFieldArgs, ReadArgs};
use crate::bench::{self, variant, BenchOptions, BenchReport, BenchScene};
use crate::error::{Error, Result};
use crate::geometry::aperture::ApertureShape;
use crate::gpu::GpuContext;
use crate::refocus::{resolve_focus, FocusSpec};

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// A light field (as for `render`); default: the built-in synthetic scene with optical
    /// ground truth (a 40°-tilted textured plane, refocused onto itself).
    pub light_field: Option<String>,
    #[command(flatten)]
    pub read: ReadArgs,
    #[command(flatten)]
    pub focus: FocusArgs,
    /// Timed frames per variant (after discarded warm-up frames); default 20 (--quick: 3).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub frames: Option<usize>,
    /// Output folder for bench.json, bench.csv, homographies.json and the charts.
    #[arg(long, value_name = "DIR", default_value = "tiltfield-bench")]
    pub out: PathBuf,
    /// Comma-separated variants, each `/`-separated tokens: fragment|batched:N|compute,
    /// hardware|shader|bicubic|nearest, srgb8|linear16, rgba32f|rgba16f, rR (disk aperture
    /// radius), WxH or xF (output size or scale); unnamed parts are render's defaults.
    /// Default: a catalogue that changes one thing at a time.
    #[arg(long, value_name = "LIST")]
    pub variants: Option<String>,
    /// A small scene and few frames: seconds on a CPU driver (the test suite runs this).
    #[arg(long)]
    pub quick: bool,
    /// Skip the scaling sweep (views × output size).
    #[arg(long)]
    pub no_scaling: bool,
    /// The device's bilinear texture rate in GTexel/s (default: a table of common GPUs).
    #[arg(long, value_name = "G", allow_negative_numbers = true)]
    pub peak_gtexels: Option<f64>,
    /// The device's memory bandwidth in GB/s (default: a table of common GPUs).
    #[arg(long, value_name = "G", allow_negative_numbers = true)]
    pub peak_gbps: Option<f64>,
    /// The anti-aliasing study (plain sum and anti-aliased refocus at several sub-sample caps
    /// on a layered synthetic scene, against its lens): on (default) or off.
    #[arg(long, value_name = "on|off")]
    pub antialias: Option<super::Switch>,
    /// Print the report as JSON on stdout too.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

/// Most timed frames per variant.
const MAX_FRAMES: usize = 1000;

/// Refuses variants whose output, resolved against the scene's view size (`xF` scales it),
/// is larger than [`variant::MAX_SIDE`] a side, naming the variant.
fn check_variant_sizes(options: &BenchOptions, width: u32, height: u32) -> Result<()> {
    for v in &options.variants {
        let (w, h) = v.size.resolve(width, height);
        if w > variant::MAX_SIDE || h > variant::MAX_SIDE {
            return Err(Error::Invalid(format!(
                "variant '{}': its output is {w}×{h} for views of {width}×{height}, larger than \
                 {} pixels a side",
                v.name(),
                variant::MAX_SIDE
            )));
        }
    }
    Ok(())
}

/// The options of `args` (checked before any GPU work).
pub fn options(args: &BenchArgs) -> Result<BenchOptions> {
    let mut o = if args.quick {
        BenchOptions::quick()
    } else {
        BenchOptions::full()
    };
    if let Some(n) = args.frames {
        if !(1..=MAX_FRAMES).contains(&n) {
            return Err(Error::Invalid(format!(
                "--frames {n}: timed frames per variant must be 1 to {MAX_FRAMES}"
            )));
        }
        o.frames = n;
        o.sweep_frames = o.sweep_frames.min(n).max(1);
    }
    if let Some(list) = &args.variants {
        o.variants = variant::parse_list(list)?;
    }
    if args.no_scaling {
        o.sweep_radii.clear();
    }
    for (what, v) in [
        ("--peak-gtexels", args.peak_gtexels),
        ("--peak-gbps", args.peak_gbps),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::Invalid(format!("{what} must be positive, got {v}")));
            }
        }
    }
    o.peak_gtexels = args.peak_gtexels;
    o.peak_gbps = args.peak_gbps;
    Ok(o)
}

fn scene(args: &BenchArgs, ctx: &Arc<GpuContext>) -> Result<BenchScene> {
    let request = args.focus.request()?;
    let Some(path) = &args.light_field else {
        if request.is_some() {
            return Err(Error::Invalid(
                "the built-in bench scene is refocused onto its own plane; focus options need a \
                 light field"
                    .into(),
            ));
        }
        if args.read.frame.is_some() {
            return Err(Error::Invalid(
                "--frame needs a camera-array video light field".into(),
            ));
        }
        return bench::synthetic_scene(Arc::clone(ctx), args.quick);
    };
    let lf_args = LightFieldArgs::new(path.as_str(), &args.read);
    let lf = load_light_field_within(&lf_args, &device_load_limits(ctx))?;
    let (spec, text) = match request {
        Some(req) => {
            let focus = resolve_focus(&lf, &req, lf.grid.centre())?;
            let text = focus_summary(&focus).unwrap_or_else(|| format!("{:?}", focus.spec));
            (focus.spec, text)
        }
        None => (FocusSpec::Disparity(0.0), "disparity 0".to_string()),
    };
    Ok(BenchScene {
        description: format!(
            "{} ({} views of {}×{})",
            lf.name,
            lf.views.len(),
            lf.width,
            lf.height
        ),
        lf,
        focus: spec,
        focus_text: text,
        truth: None,
    })
}

/// Fixed-width table of a report, for the terminal.
pub fn table(report: &BenchReport) -> String {
    let mut out = format!(
        "{} — {} ({}, Vulkan {})\n{:<44} {:>9} {:>9} {:>9} {:>8} {:>7} {:>8} {:>6}\n",
        report.light_field.description,
        report.device.name,
        report.device.driver,
        report.device.api_version,
        "variant",
        "median ms",
        "min ms",
        "Msamp/s",
        "PSNR dB",
        "max lv",
        "truth dB",
        "bound"
    );
    for v in &report.variants {
        out.push_str(&format!(
            "{:<44} {:>9.2} {:>9.2} {:>9.1} {:>8.1} {:>7.2} {:>8} {:>6}\n",
            format!("{}{}", v.name, if v.default { " *" } else { "" }),
            v.gpu_ms_median,
            v.gpu_ms_min,
            v.samples_per_s / 1e6,
            v.psnr_vs_reference_db,
            v.max_error_vs_reference,
            v.psnr_vs_truth_db
                .flatten()
                .map_or("-".to_string(), |p| format!("{p:.1}")),
            if v.within_bound { "ok" } else { "FAIL" }
        ));
    }
    if let Some(fit) = report.scaling_fit {
        out.push_str(&format!(
            "scaling ({} points): {:.2} ms per frame + {:.3} ns per view-sample (R² {:.3})\n",
            report.scaling.len(),
            fit.fixed_ms,
            fit.ns_per_sample,
            fit.r_squared
        ));
    }
    if let Some(f) = &report.fastest_full_quality {
        out.push_str(&format!("fastest at full quality: {f}\n"));
    }
    if let Some(aa) = &report.antialias {
        out.push_str(&format!(
            "anti-aliasing on {} ({} truth pinholes; PSNR overall / out of focus / focused):\n",
            aa.scene, aa.truth_pinholes
        ));
        let width = aa.points.iter().map(|p| p.name.len()).max().unwrap_or(0);
        for p in &aa.points {
            out.push_str(&format!(
                "  {:<width$} {:>3} views {:>9.2} ms  ×{:<5.2} {:>5.1} / {:>5.1} / {:>5.1} dB\n",
                p.name,
                p.views,
                p.gpu_ms_median,
                p.cost_ratio,
                p.psnr_vs_truth_db,
                p.psnr_out_of_focus_db,
                p.psnr_focused_db
            ));
        }
    }
    out
}

pub fn run(args: &BenchArgs) -> Result<()> {
    let options = options(args)?;
    // The folder is made only when the report is written; here only that it can be.
    crate::io::check_writable_folder(&args.out, "bench.json")?;
    let ctx = Arc::new(GpuContext::new(&args.gpu.options())?);
    let scene = scene(args, &ctx)?;
    check_variant_sizes(&options, scene.lf.width, scene.lf.height)?;
    let mut report = bench::run(Arc::clone(&ctx), &scene, &options)?;
    if args.antialias != Some(super::Switch::Off) {
        report.antialias = Some(bench::antialias::run(
            Arc::clone(&ctx),
            args.quick,
            options.frames,
        )?);
    }
    let plan = bench::plan_for(&scene, ApertureShape::Disk, None)?;
    let homographies = bench::homographies(&scene.lf, &plan);
    let written = bench::output::write_all(&report, &homographies, &args.out)?;
    eprint!("{}", table(&report));
    eprintln!(
        "wrote {}",
        written
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let failed: Vec<&str> = report
        .variants
        .iter()
        .filter(|v| !v.within_bound)
        .map(|v| v.name.as_str())
        .collect();
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| Error::Invalid(e.to_string()))?
        );
    }
    if !failed.is_empty() {
        return Err(Error::Invalid(format!(
            "variants outside their accuracy bound: {}",
            failed.join(", ")
        )));
    }
    Ok(())
}

#[derive(Debug, Args)]
pub struct AntialiasSetArgs {
    /// View size of the cases, px (48 to 512).
    #[arg(long, default_value_t = 128, allow_negative_numbers = true)]
    pub size: u32,
    /// Pinholes per side of the lens's aperture grid (about 0.8 × its square inside the disk;
    /// fewer leave the truth itself noisy on fine texture).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 129,
        allow_negative_numbers = true
    )]
    pub truth_grid: u32,
    /// Only these cases (comma-separated); default: the whole set.
    #[arg(long, value_name = "A,B,…", value_delimiter = ',')]
    pub cases: Option<Vec<String>>,
    /// Timed frames of each of the plain and the anti-aliased sum per case.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 10,
        allow_negative_numbers = true
    )]
    pub frames: usize,
    /// Skip anti-aliasing on estimated depth (the depth estimate takes most of the time).
    #[arg(long)]
    pub no_estimate: bool,
    /// Also score the f64 model of layered anti-aliasing (boxed layers composited front to
    /// back; docs/antialias.md) on the given and the estimated depth, beside what the set runs.
    #[arg(long)]
    pub layered_model: bool,
    /// How every image samples the views (as for `render`): hardware (bilinear), shader,
    /// bicubic or nearest.
    #[arg(long, value_name = "FILTER", default_value = "hardware")]
    pub filter: crate::refocus::settings::Filter,
    /// Jittered samples per pixel and axis of the rendered views (and of the lens).
    #[arg(long, value_name = "N", default_value_t = crate::bench::antialias_set::SUPERSAMPLES, allow_negative_numbers = true)]
    pub supersamples: u32,
    /// How the anti-aliased images sample their footprints (as for `render`).
    #[command(flatten)]
    pub sampling: super::AntialiasSamplingArgs,
    /// Also write the table to this Markdown file.
    #[arg(long, value_name = "FILE.md")]
    pub markdown: Option<PathBuf>,
    /// Write CASE.png per case into DIR: the lens, the plain sum, anti-aliased on the given
    /// depth and on the estimate (and with --layered-model the model on the given depth), side
    /// by side.
    #[arg(long, value_name = "DIR")]
    pub images: Option<PathBuf>,
    /// Print the rows as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

/// `tiltfield antialias-set`: every case, one table.
pub fn run_antialias_set(args: &AntialiasSetArgs) -> Result<()> {
    use crate::bench::antialias_set::{self as set, SetOptions};
    let cases = set::select(args.cases.as_deref())?;
    let options = SetOptions {
        size: args.size,
        truth_grid: args.truth_grid,
        frames: args.frames,
        estimate: !args.no_estimate,
        filter: args.filter,
        supersamples: args.supersamples,
        antialias: args.sampling.settings()?,
        layered_model: args.layered_model,
    };
    // Bad options fail before any folder is made or the GPU starts.
    options.validate()?;
    if let Some(md) = &args.markdown {
        super::check_output(md)?;
    }
    let images = args
        .images
        .as_deref()
        .map(crate::io::OutputFolder::create)
        .transpose()?;
    let ctx = Arc::new(GpuContext::new(&args.gpu.options())?);
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("anti-aliasing set {bar:30} {pos}/{len} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let rows = set::run(&ctx, &cases, &options, &bar)?;
    bar.finish_and_clear();
    if let Some(dir) = images {
        for r in &rows {
            let path = dir.path().join(format!("{}.png", r.name));
            dir.track(&path, |p| crate::io::save_png(&set::figure(r), p))?;
        }
        dir.finish();
    }
    super::report_set(
        &set::markdown(&rows),
        args.markdown.as_deref(),
        args.json.then(|| {
            serde_json::json!({
                "device": ctx.info.name,
                "size": args.size,
                "rows": rows,
            })
        }),
        &ctx.info.name,
    )
}
