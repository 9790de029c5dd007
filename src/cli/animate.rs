//! `tiltfield animate`: a focus pull, a tilt or swing sweep, an aperture opening or an orbit of
//! the viewpoint, written as an animated PNG, a GIF or an MP4 ([`crate::jobs::animate`] does
//! the work; this parses and reports).
//!
//! Every `render` option is an `animate` option: [`AnimateArgs`] flattens [`RenderArgs`]
//! itself, so an option added to `render` reaches `animate` too and parses into the same
//! [`crate::jobs::render::RenderOptions`]. Four of render's arguments are adjusted for it: the
//! focus is not required (a disparity or focus sweep gives it), `--tilt`/`--swing` may come
//! without `--focus` (with `--sweep focus=A..B`), render's `--frames A..B` (a video's frame
//! range) becomes the number of frames, and render's `--repeat` is hidden and refused.

use std::sync::Arc;

use clap::Args;
use serde_json::json;

use super::focus::focus_summary;
use super::render::RenderArgs;
use super::{check_output, device_load_limits, load_light_field_within};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::io::OutputKind;
use crate::jobs::animate::encode::{self, Format};
use crate::jobs::animate::{self, Animation, Motion};
use crate::jobs::render::{check_output_fits, Session};

#[derive(Debug, Args)]
#[command(
    group(clap::ArgGroup::new("motion").required(true).args(["sweep", "orbit"])),
    mut_group("focus_or_all", |g| g.required(false)),
    mut_arg("tilt", |a| a.requires(clap::builder::Resettable::<clap::Id>::Reset)),
    mut_arg("swing", |a| a.requires(clap::builder::Resettable::<clap::Id>::Reset)),
    mut_arg("frames", |a| a
        .value_name("N")
        .required(true)
        .conflicts_with(clap::builder::Resettable::<clap::Id>::Reset)
        .help("Number of frames rendered (the sweep's values are spaced evenly over them, both \
               ends included; an orbit's angles by 360°/N)")),
    mut_arg("output", |a| a
        .help("Output animation: .png (animated PNG, lossless), .gif (256 colours a frame) or \
               .mp4 (H.264 through ffmpeg, which must be on PATH)")),
    mut_arg("repeat", |a| a.hide(true)),
    mut_arg("json", |a| a
        .help("Print the motion, each frame's value and timings as JSON on stdout")),
)]
pub struct AnimateArgs {
    #[command(flatten)]
    pub render: RenderArgs,
    /// Sweep one option from A to B (inclusive, evenly over the frames; A > B runs backwards):
    /// disparity=A..B, focus=A..B (with --tilt/--swing), tilt=A..B or swing=A..B (with
    /// --focus Z), aperture-radius=A..B (with a focus).
    #[arg(long, value_name = "KEY=A..B", allow_hyphen_values = true)]
    pub sweep: Option<String>,
    /// Circle the viewpoint R grid steps around the grid centre (frame k at angle 360°·k/N,
    /// starting on the +s, column, axis); needs a focus option.
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    pub orbit: Option<f64>,
    /// Frames per second (GIF: at most 50, delays are whole centiseconds).
    #[arg(long, value_name = "F", default_value_t = 20.0)]
    pub fps: f64,
    /// Play forward then backward (the end frames are not shown twice): a seamless loop.
    #[arg(long)]
    pub bounce: bool,
}

/// The number of frames of `--frames N`.
fn frame_count(text: Option<&str>) -> Result<usize> {
    let text = text.unwrap_or_default();
    text.trim().parse::<usize>().map_err(|_| {
        Error::Invalid(format!(
            "--frames: expected a whole number of frames, got '{text}'"
        ))
    })
}

pub fn run(args: &AnimateArgs) -> Result<()> {
    let r = &args.render;
    // Everything that can be checked without the device or the light field first.
    let format = Format::from_path(&r.output)?;
    format.check_fps(args.fps)?;
    if r.repeat > 0 {
        return Err(Error::Invalid(
            "--repeat times single renders (tiltfield render --repeat); animate --json reports \
             every frame's time"
                .into(),
        ));
    }
    let motion = match (&args.sweep, args.orbit) {
        (Some(text), None) => Motion::parse_sweep(text)?,
        (None, Some(radius)) => Motion::orbit(radius)?,
        _ => {
            return Err(Error::Invalid(
                "give one motion: --sweep KEY=A..B or --orbit R".into(),
            ))
        }
    };
    let animation = Animation::new(motion, frame_count(r.frames.as_deref())?, args.bounce)?;
    let base = super::render::options(r, OutputKind::Png)?;
    animation.states(&base, None)?;
    format.check_available()?;
    check_output(&r.output)?;
    let ctx = Arc::new(GpuContext::new(&r.gpu.options())?);
    if let Some(size) = base.size {
        check_output_fits(&ctx, size)?;
    }
    let lf = load_light_field_within(&r.lf, &device_load_limits(&ctx))?;
    let states = animation.states(&base, Some(lf.grid))?;
    let (name, grid, view_size) = (lf.name.clone(), lf.grid, (lf.width, lf.height));
    let depth_bar = super::depth::progress_bar_for(&lf);
    let mut session = Session::new(Arc::clone(&ctx), lf);
    let bar = indicatif::ProgressBar::new(animation.frames as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{msg} [{bar:30}] {pos}/{len} frames, {per_sec}, ETA {eta}",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    let shown = animation.order().len();
    let result = encode::write(format, &r.output, args.fps, shown, |sink| {
        animate::render(
            &mut session,
            &animation,
            &states,
            &depth_bar,
            |k| {
                if k == 0 {
                    // The first frame's depth estimate, if any, has finished: the frames'
                    // bar takes the line.
                    depth_bar.finish_and_clear();
                    bar.set_message(format!("animating {name}"));
                }
                bar.inc(1);
            },
            sink,
        )
    });
    depth_bar.finish_and_clear();
    bar.finish_and_clear();
    let (report, written) = result?;
    ctx.check_validation("while rendering")?;
    drop(session);
    let first = &report.first;
    let views = first.views_plan().views.len();
    let (w, h) = report.size;
    let (mean_ms, gpu_mean) = (report.mean_frame_ms(), report.mean_gpu_ms());
    if r.json {
        let motion = match animation.motion {
            Motion::Sweep { key, from, to } => {
                json!({"kind": "sweep", "key": key.name(), "from": from, "to": to})
            }
            Motion::Orbit { radius } => json!({"kind": "orbit", "radius": radius}),
        };
        let doc = json!({
            "light_field": {
                "name": name,
                "grid": [grid.cols, grid.rows],
                "size": [view_size.0, view_size.1],
            },
            "motion": motion,
            "frames": animation.frames,
            "shown": report.shown,
            "bounce": animation.bounce,
            "order": animation.order(),
            "fps": args.fps,
            "values": report.values,
            "views": states.iter().map(|s| s.view.map(|v| [v.x, v.y])).collect::<Vec<_>>(),
            "output": r.output,
            "format": written.format,
            "bytes": written.bytes,
            "size": [w, h],
            "cropped_to": written.cropped_to,
            "focus": first.focus.json(),
            "views_used": views,
            "strategy": first.settings.strategy.name(),
            "strategy_source": first.strategy_source,
            "device": ctx.info.name,
            "uncovered_pixels": report.uncovered,
            "timings_ms": {
                "wall": report.wall_s * 1e3,
                "first_frame": report.frame_ms.first(),
                "mean_frame": mean_ms,
                "per_frame": report.frame_ms,
                "gpu_refocus_mean": gpu_mean,
                "gpu_refocus_per_frame": report.gpu_ms,
            },
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&doc).map_err(|e| Error::Invalid(e.to_string()))?
        );
        return Ok(());
    }
    if let Some(line) = focus_summary(&first.focus) {
        eprintln!("{line}");
    }
    eprintln!(
        "wrote {} ({}, {} frames{} of {w}×{h}{}, {}, {views} views, {} fps, {} KiB) in {:.1} s: \
         first frame {:.0} ms (with the upload){}",
        r.output.display(),
        format.name(),
        report.shown,
        if animation.bounce && report.shown > report.rendered {
            format!(" from {} rendered", report.rendered)
        } else {
            String::new()
        },
        written
            .cropped_to
            .map_or(String::new(), |(cw, ch)| format!(" cropped to {cw}×{ch}")),
        animation.motion.describe(),
        args.fps,
        written.bytes.div_ceil(1024),
        report.wall_s,
        report.frame_ms.first().copied().unwrap_or(0.0),
        match (mean_ms, gpu_mean) {
            (Some(m), Some(g)) => format!(", then {m:.0} ms a frame (GPU refocus {g:.2} ms)"),
            (Some(m), None) => format!(", then {m:.0} ms a frame"),
            _ => String::new(),
        }
    );
    Ok(())
}
