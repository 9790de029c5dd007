//! `tiltfield view`: parses the options into [`ViewerOptions`], runs the window
//! ([`crate::viewer::run`]) and prints the final state as `render --json` does, plus the frame
//! statistics.

use std::path::PathBuf;

use clap::Args;
use serde_json::json;

use super::focus::FocusArgs;
use super::render::{dark_views, plan_json};
use super::{load_light_field, AntialiasArgs, ApertureArgs, GpuArgs, LightFieldArgs, ReadArgs};
use crate::error::{Error, Result};
use crate::gpu::swapchain::PresentMode;
use crate::lightfield::video::FrameSequence;
use crate::refocus::settings::ViewStorage;
use crate::viewer::{self, script, ViewerOptions};

/// The light field `view` opens without one.
pub const DEFAULT_SCENE: &str = "builtin:demo";

#[derive(Debug, Args)]
pub struct ViewArgs {
    /// A light field (as for render); default: the built-in demo scene.
    pub light_field: Option<String>,
    #[command(flatten)]
    pub read: ReadArgs,
    #[command(flatten)]
    pub focus: FocusArgs,
    #[command(flatten)]
    pub aperture: ApertureArgs,
    /// Anti-aliasing (the X key toggles it); default: on wherever depth is available (the
    /// light field's own map or an estimate).
    #[command(flatten)]
    pub antialias: AntialiasArgs,
    /// How views are sampled, as for `render`: hardware (bilinear), shader (exact bilinear),
    /// bicubic (Catmull-Rom in the shader: sharper on a tilted plane, at several times the
    /// GPU time) or nearest.
    #[arg(long, value_name = "FILTER", default_value = "hardware")]
    pub filter: crate::refocus::settings::Filter,
    /// How views are summed, as for `render`: auto (the device's fastest, measured once and
    /// cached), fragment, batched[:N] or compute.
    #[arg(long, value_name = "STRATEGY", default_value = "auto")]
    pub strategy: crate::jobs::strategy::StrategyChoice,
    /// Presentation: fifo (vsync), mailbox or immediate (for profiling).
    #[arg(long, default_value = "fifo")]
    pub present: PresentMode,
    /// Frame budget in milliseconds for progressive refinement.
    #[arg(
        long,
        value_name = "MS",
        default_value_t = 33.0,
        allow_negative_numbers = true
    )]
    pub frame_budget_ms: f64,
    /// Initial window size WxH.
    #[arg(long, value_name = "WxH", default_value = "1280x720")]
    pub window: String,
    /// Replay commands from FILE (see the README for the format).
    #[arg(long, value_name = "FILE")]
    pub script: Option<PathBuf>,
    /// Prefix of the screenshots P writes (a number is appended).
    #[arg(long, value_name = "PREFIX", default_value = "tiltfield-shot")]
    pub screenshot_prefix: PathBuf,
    /// Print the final state and the frame statistics as JSON on exit.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

pub fn run(args: &ViewArgs) -> Result<()> {
    let launched = std::time::Instant::now();
    // Everything that can be checked without the light field and the window comes first.
    let window = super::synth::parse_pair(&args.window, "--window")?;
    if !script::WINDOW_SIZES.contains(&window.0) || !script::WINDOW_SIZES.contains(&window.1) {
        return Err(Error::Invalid(format!(
            "--window must be {} to {} pixels each way, got {}×{}",
            script::WINDOW_SIZES.start(),
            script::WINDOW_SIZES.end(),
            window.0,
            window.1
        )));
    }
    let lines = match &args.script {
        Some(path) => script::load(path)?,
        None => Vec::new(),
    };
    // The P key writes PREFIX-1_refocus.png and so on. A viewer is useful without
    // screenshots, so a prefix that cannot be written is a warning now (and P then fails
    // naming the file), not a refusal to start.
    let mut first_shot = args.screenshot_prefix.as_os_str().to_owned();
    first_shot.push("-1");
    if let Err(e) = script::check_screenshot_prefix(std::path::Path::new(&first_shot)) {
        log::warn!("--screenshot-prefix: {e}; the P key will not be able to save");
    }
    let reference = args.aperture.reference()?;
    let antialias = args.antialias.settings()?;
    let aperture = args.aperture.aperture();
    aperture.validate()?;
    let focus = args.focus.request()?;
    let path = args
        .light_field
        .as_deref()
        .unwrap_or(DEFAULT_SCENE)
        .to_string();
    crate::jobs::render::check_source(&path, &args.read.options())?;
    // On by default wherever there is depth; with an estimate, once it arrives.
    let antialias_on = args.antialias.requested().unwrap_or(true);
    // The window opens at once; the light field is read on a thread meanwhile (the loading
    // screen shows its progress) and what depends on it comes back with it.
    let load: viewer::Loader = {
        let (path, read, include_dark) =
            (path.clone(), args.read.clone(), args.aperture.include_dark);
        Box::new(move || {
            let lf = load_light_field(&LightFieldArgs::new(&path, &read))?;
            let video = if FrameSequence::is_video(std::path::Path::new(&path)) {
                let sequence = FrameSequence::open(std::path::Path::new(&path))?;
                let frame = read.frame.unwrap_or_else(|| sequence.first());
                Some((sequence, frame))
            } else {
                None
            };
            // The scene panel, clicks and anti-aliasing need depth: the light field's own
            // map, else an estimate from its views (cached) that the viewer makes in the
            // background while the window already shows the refocus image. Without depth the
            // viewer still works (keys, scroll, scene without points), so a failed estimate
            // is a message, not an error.
            let depth = crate::depth::cache::given_origin(&lf);
            let normal_window = depth
                .as_ref()
                .map_or(super::focus::GIVEN_DEPTH_WINDOW, |o| o.normal_window());
            let excluded = dark_views(&lf, include_dark);
            Ok(viewer::Loaded {
                lf,
                excluded,
                normal_window,
                depth,
                video,
            })
        })
    };
    let opts = ViewerOptions {
        focus,
        aperture,
        reference,
        averaging: args.aperture.average,
        excluded: Vec::new(),
        present: args.present,
        frame_budget_ms: args.frame_budget_ms,
        window,
        script: lines,
        gpu: args.gpu.options(),
        storage: ViewStorage::default(),
        filter: args.filter,
        strategy: args.strategy.0,
        screenshot_prefix: args.screenshot_prefix.clone(),
        video: None,
        normal_window: super::focus::GIVEN_DEPTH_WINDOW,
        antialias,
        antialias_on,
        depth: None,
        launched,
    };
    let source = if args.light_field.is_some() {
        path
    } else {
        "the demo scene".to_string()
    };
    let report = viewer::run(load, &source, opts)?;
    let (name, grid, size) = report.light_field.clone();
    let depth_origin = report.depth.as_ref();
    let state = &report.state;
    if args.json {
        let mut out = plan_json(&state.plan);
        let extra = json!({
            "light_field": {
                "name": name,
                "grid": [grid.cols, grid.rows],
                "size": [size.0, size.1],
            },
            "focus": state.resolved.json(),
            "depth": depth_origin.map(crate::depth::DepthOrigin::json),
            "window_ms": report.milestones.window_ms,
            "first_frame_ms": report.milestones.first_frame_ms,
            "depth_ready_ms": report.milestones.depth_ready_ms,
            "averaging": state.averaging(),
            "surface": report.surface,
            "antialias": report.antialias,
            "aperture": {"shape": state.aperture().shape, "radius": state.aperture().radius},
            "storage": ViewStorage::default(),
            "filter": args.filter,
            "strategy": report.strategy.strategy.name(),
            "strategy_source": report.strategy.source,
            "size": [size.0, size.1],
            "device": report.device,
            "present_mode": report.present_mode,
            "window": [report.window.0, report.window.1],
            "frames": report.frames,
            "validation_errors": report.validation_errors,
        });
        if let (Some(obj), Some(extra)) = (out.as_object_mut(), extra.as_object()) {
            obj.extend(extra.clone());
        }
        println!(
            "{}",
            serde_json::to_string_pretty(&out).map_err(|e| Error::Invalid(e.to_string()))?
        );
    }
    // The viewer's and its depth jobs' contexts together (the report sums them).
    crate::gpu::validation::check_errors(report.validation_errors, "in the viewer")
}
