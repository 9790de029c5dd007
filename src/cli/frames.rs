//! `tiltfield render LF --frames A..B -o 'out_{frame}.png'`: a frame range of a camera-array
//! video with one GPU set-up ([`crate::jobs::batch`] does the work; this parses and reports).

use std::path::Path;
use std::sync::Arc;

use serde_json::json;

use super::focus::focus_summary;
use super::render::{plan_json, RenderArgs};
use super::{check_output, device_load_limits};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::io::OutputKind;
use crate::jobs::batch::{render_frames, BatchJob, OutputPattern};
use crate::jobs::render::{check_output_fits, FramePlanner};
use crate::lightfield::technicolor::describe_frames;
use crate::lightfield::video::{FrameRange, FrameSequence};

pub fn run(args: &RenderArgs, spec: &str) -> Result<()> {
    // Options and outputs first, then the video's listing, then the device: nothing is
    // decoded before everything that can be checked cheaply has been.
    let range: FrameRange = spec.parse()?;
    let output_text = crate::io::utf8_path(&args.output, "the -o pattern")?;
    let pattern = OutputPattern::parse(output_text)?;
    let sequence = FrameSequence::open(Path::new(&args.lf.light_field))?;
    let frames = sequence.select(range)?;
    let kind = OutputKind::from_path(&pattern.path(frames[0]))?;
    // Every frame's output, not only the first: a run must not stop at frame 300 because
    // its file cannot be written, after writing 299 others.
    for &f in &frames {
        check_output(&pattern.path(f))?;
    }
    let options = super::render::options(args, kind)?;
    options.check()?;
    let storage = options.storage();
    let ctx = Arc::new(GpuContext::new(&args.gpu.options())?);
    let (settings, strategy_source) = options.settings_on(&ctx)?;
    if let Some(size) = settings.size {
        check_output_fits(&ctx, size)?;
    }
    let job = BatchJob {
        sequence: &sequence,
        frames: &frames,
        settings,
        storage,
        output: &pattern,
        limits: device_load_limits(&ctx),
    };

    let bar = indicatif::ProgressBar::new(frames.len() as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{msg} [{bar:30}] {pos}/{len} frames, {per_sec}, ETA {eta}",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(format!("refocusing {}", sequence.name()));
    let mut planner = FramePlanner::new(&options);
    let (report, frame_plan) = render_frames(
        Arc::clone(&ctx),
        &job,
        |lf, previous| {
            // The first frame's depth estimate shows its planes; later frames' run silently
            // (the range's bar counts frames).
            let first_depth = match previous {
                None => super::depth::progress_bar_for(lf),
                Some(_) => indicatif::ProgressBar::hidden(),
            };
            let planned = planner.plan_frame(&ctx, lf, previous, &first_depth);
            first_depth.finish_and_clear();
            planned
        },
        |_| bar.inc(1),
    )?;
    bar.finish_and_clear();
    ctx.check_validation("while rendering")?;
    let plan = frame_plan
        .antialias
        .as_ref()
        .map_or(&frame_plan.plan, |a| &a.plan);
    let (out_w, out_h) = settings.size.unwrap_or((plan.width, plan.height));
    let means = report.means();
    if args.json {
        let mut out = plan_json(plan);
        let extra = json!({
            "light_field": {
                "name": sequence.name(),
                "grid": [sequence.grid().cols, sequence.grid().rows],
                "size": [sequence.view_size().0, sequence.view_size().1],
            },
            "focus": planner.focus.as_ref().map(crate::refocus::ResolvedFocus::json),
            "frames": frames,
            "outputs": frames.iter().map(|&f| pattern.path(f)).collect::<Vec<_>>(),
            "averaging": args.aperture.average,
            "surface": frame_plan.surface.as_ref().map(|s| {
                s.json(planner.depth_origin.as_ref().map(crate::depth::DepthOrigin::json))
            }),
            "antialias": with_depth_frames(
                crate::refocus::antialias::antialias_json(
                    frame_plan.antialias.as_ref(),
                    planner.depth_origin.as_ref().map(crate::depth::DepthOrigin::json),
                ),
                planner.depth_frames,
            ),
            "strategy": settings.strategy.name(),
            "strategy_source": strategy_source,
            "filter": settings.filter,
            "storage": storage,
            "size": [out_w, out_h],
            "device": report.device,
            "wall_s": report.wall_s,
            "frames_per_second": report.frames_per_second,
            "mean_ms": means,
            "per_frame": report.frames,
        });
        if let (Some(obj), Some(extra)) = (out.as_object_mut(), extra.as_object()) {
            obj.extend(extra.clone());
        }
        println!(
            "{}",
            serde_json::to_string_pretty(&out).map_err(|e| Error::Invalid(e.to_string()))?
        );
        return Ok(());
    }
    if let Some(line) = planner.focus.as_ref().and_then(focus_summary) {
        eprintln!("{line}");
    }
    let ms = |v: Option<f64>| v.map_or("–".to_string(), |x| format!("{x:.0} ms"));
    eprintln!(
        "wrote {} frames ({}) to {} ({out_w}×{out_h}, {} views) in {:.1} s: {:.2} frames/s on {}",
        report.frames.len(),
        describe_frames(&frames),
        output_text,
        plan.views.len(),
        report.wall_s,
        report.frames_per_second,
        report.device
    );
    if planner.depth_frames > 0 {
        let what = match (&frame_plan.surface, &frame_plan.antialias) {
            (Some(_), Some(_)) => "focus surface and anti-aliasing",
            (Some(_), None) => "focus surface",
            _ => "anti-aliasing",
        };
        eprintln!(
            "{what}: each frame's own depth ({} frames)",
            planner.depth_frames
        );
    }
    eprintln!(
        "per frame: decode {} (background), waiting for it {}, planning {}, upload {:.0} ms, \
         render and readback {} (GPU refocus {}), encode {} (background)",
        ms(means.decode),
        ms(means.wait_for_decode),
        ms(means.planning),
        means.upload,
        ms(means.render_and_readback),
        ms(means.gpu_refocus),
        ms(means.encode),
    );
    Ok(())
}

/// The anti-aliasing report of a frame range with the number of frames anti-aliased on their
/// own depth (`depth_frames`; the origin reported is the first frame's).
fn with_depth_frames(mut report: serde_json::Value, depth_frames: usize) -> serde_json::Value {
    if let Some(obj) = report.as_object_mut() {
        obj.insert("depth_frames".into(), json!(depth_frames));
    }
    report
}
