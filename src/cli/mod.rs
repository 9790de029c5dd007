//! The `tiltfield` command line: argument parsing and the subcommands.

mod animate;
mod bench;
mod cloud;
mod demo;
mod depth;
mod focus;
mod frames;
mod info;
mod render;
mod synth;
mod view;

use std::path::{Path, PathBuf};

use clap::{Args, Parser, Subcommand};

use glam::DVec2;

use crate::error::Result;
use crate::geometry::aperture::{Aperture, ApertureShape};
use crate::gpu::GpuOptions;
use crate::lightfield::{LightField, LoadLimits};
use crate::refocus::Averaging;

/// Light field tilt-shift refocus with generalized shift-and-sum (Vulkan).
#[derive(Debug, Parser)]
#[command(name = "tiltfield", version, about, long_about = None)]
pub struct Cli {
    /// More log output (-v info, -vv debug). RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Describe a light field: grid, view size, cameras, depth.
    Info(info::InfoArgs),
    /// Refocus a light field onto a plane and write PNG or EXR.
    Render(Box<render::RenderArgs>),
    /// Animate a refocus as an animated PNG, GIF or MP4: a focus pull, a tilt or swing sweep,
    /// an aperture opening (--sweep KEY=A..B) or the viewpoint circling the grid centre
    /// (--orbit R), with every render option.
    Animate(Box<animate::AnimateArgs>),
    /// Render a synthetic light field with ground truth (depth, disparity, normals, optical
    /// tilt-shift image) from a glTF scene or a built-in scene.
    Synth(Box<synth::SynthArgs>),
    /// Write the point cloud of the depth map's view as binary PLY (positions, colours,
    /// normals), optionally with the refocus plane and the camera centres.
    Cloud(Box<cloud::CloudArgs>),
    /// Measure GPU time and accuracy of every refocus variant (strategy, filter, storage,
    /// accumulation, aperture, output size), a scaling sweep, and chart speed against
    /// accuracy (JSON, CSV, SVG and PNG).
    Bench(Box<bench::BenchArgs>),
    /// Interactive tilt-shift refocus in a window: refocus image and 3-D scene with the plane.
    View(Box<view::ViewArgs>),
    /// Estimate the reference view's disparity or depth from the light field (GPU plane sweep)
    /// and write it as PFM or EXR.
    Depth(Box<depth::DepthArgs>),
    /// Score depth estimation over the depth test set (synthetic scenes, one per failure
    /// mode, plus HCI folders given with --hci) and print a Markdown table.
    DepthSet(Box<depth::DepthSetArgs>),
    /// Score anti-aliased refocus against the lens over the anti-aliasing test set (synthetic
    /// cases, one per failure mode) and print a Markdown table.
    AntialiasSet(Box<bench::AntialiasSetArgs>),
    /// Render refocus images of the built-in demo scene (no files needed).
    Demo(demo::DemoArgs),
    /// List the Vulkan devices and whether tiltfield can use them; --calibrate measures the
    /// refocus strategies on one (what `--strategy auto` uses) and caches the choice again.
    Devices(info::DevicesArgs),
}

/// Where the light field comes from and how to read camera-less folders.
#[derive(Debug, Clone, Args)]
pub struct LightFieldArgs {
    /// A light field: an HCI folder, a manifest (.json or a folder with tiltfield.json), a
    /// folder of views named by row and column, or builtin:NAME (see `tiltfield demo --list`).
    pub light_field: String,
    #[command(flatten)]
    pub read: ReadArgs,
}

impl LightFieldArgs {
    /// The light field at `path` (or `builtin:NAME`) read with `read`.
    pub fn new(path: impl Into<String>, read: &ReadArgs) -> Self {
        LightFieldArgs {
            light_field: path.into(),
            read: read.clone(),
        }
    }
}

/// How a light field is read: the cameras of camera-less folders and the frame of a video.
/// Declared once and flattened into every command that opens a light field.
#[derive(Debug, Clone, Args)]
pub struct ReadArgs {
    /// Grid folders only: focal length in pixels (default: max(width, height)).
    #[arg(long, value_name = "PX", allow_negative_numbers = true)]
    pub focal_px: Option<f64>,
    /// Grid folders only: distance between neighbouring views in world units.
    #[arg(
        long,
        value_name = "B",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub baseline: f64,
    /// Camera-array videos only: the frame, by its number in the file names (default: the
    /// first frame; the viewer steps through frames with , and . and plays with Space).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub frame: Option<u64>,
}

impl ReadArgs {
    /// The library's read options.
    pub fn options(&self) -> crate::jobs::render::ReadOptions {
        crate::jobs::render::ReadOptions {
            focal_px: self.focal_px,
            baseline: self.baseline,
            frame: self.frame,
        }
    }
}

/// The synthetic aperture and the viewpoint: shape, radius, reference view, averaging and dark
/// views. Declared once and flattened into `render` and `view`.
#[derive(Debug, Clone, Args)]
pub struct ApertureArgs {
    /// Aperture shape: disk, square or gaussian.
    #[arg(long, default_value = "disk")]
    pub aperture: ApertureShape,
    /// Aperture radius in grid steps (σ for gaussian); default: all views.
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    pub aperture_radius: Option<f64>,
    /// Reference (virtual) view S,T in grid units, fractional allowed; default: grid centre.
    #[arg(long, value_name = "S,T")]
    pub view: Option<String>,
    /// Average linear light (default) or the sRGB-encoded values (the viewer's E toggles).
    #[arg(long, default_value = "linear")]
    pub average: Averaging,
    /// Use views that are (almost) entirely black too (vignetted corners are skipped by default).
    #[arg(long)]
    pub include_dark: bool,
}

impl ApertureArgs {
    /// The aperture (not yet validated: the plan validates it, before the focus).
    pub fn aperture(&self) -> Aperture {
        Aperture {
            shape: self.aperture,
            radius: self.aperture_radius,
        }
    }

    /// The reference view of `--view` (`None`: the grid centre).
    pub fn reference(&self) -> Result<Option<DVec2>> {
        match &self.view {
            Some(text) => {
                let v = parse_numbers(text, 2, "--view")?;
                Ok(Some(DVec2::new(v[0], v[1])))
            }
            None => Ok(None),
        }
    }
}

/// Anti-aliased refocus options, flattened into `render`, `view` and `bench`.
#[derive(Debug, Clone, Args)]
pub struct AntialiasArgs {
    /// Anti-aliased refocus, on or off: each view is integrated over its cell of the aperture
    /// along the scene's depth, so out-of-focus content blurs into smooth discs instead of a
    /// lattice of copies. Default: on when the light field ships a depth map, else off; `on`
    /// estimates the depth where it is missing (cached).
    #[arg(long, value_name = "on|off")]
    pub antialias: Option<Switch>,
    #[command(flatten)]
    pub sampling: AntialiasSamplingArgs,
}

/// How anti-aliasing samples the footprints: in [`AntialiasArgs`], and alone in
/// `antialias-set`, which scores whatever settings it is given.
#[derive(Debug, Clone, Args)]
pub struct AntialiasSamplingArgs {
    /// Anti-aliasing: most sub-samples per axis of each view's aperture cell (1 to 16; more
    /// is smoother and slower).
    #[arg(long, value_name = "N", default_value_t = crate::refocus::antialias::AntialiasSettings::default().max_samples, allow_negative_numbers = true)]
    pub antialias_samples: u32,
    /// Anti-aliasing: sub-samples of a long footprint read the views' box-filtered pyramid
    /// (mip levels) at the level of their spacing, on (default) or off (full-resolution
    /// fetches only: a long footprint then needs more sub-samples to look smooth).
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub antialias_prefilter: Switch,
    /// Anti-aliasing: a pixel whose views agree at the focus surface (within 2 levels) is
    /// taken as in focus, the plain sum, whatever the depth says: on (default) or off (the
    /// depth map alone decides).
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub antialias_focus_test: Switch,
    /// Anti-aliasing: where the pixel's own surface is in focus, sub-samples with footprints
    /// under half a pixel read the views with Catmull-Rom instead of bilinear (with the
    /// hardware or shader filter), so a tilted plane that cuts the views between their pixels
    /// stays sharp: on (default) or off (every sub-sample bilinear).
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub antialias_focused_bicubic: Switch,
    /// Anti-aliasing: sub-samples near a nearer surface follow their own rays and are tested
    /// against what their view sees, on (default) or off (every sub-sample takes the pixel's
    /// own depth: faster, and wrong at occlusion edges).
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub antialias_occlusion: Switch,
    /// Anti-aliasing: defocus each view once, box-filtering it over its footprints with a
    /// summed-area table, and read it once per view (constant cost whatever the blur; the
    /// occlusion tests do not run, each aperture cell takes the depth its view sees): on, or
    /// off (default: layered footprints where they apply, else sub-samples).
    #[arg(long, value_name = "on|off", default_value = "off")]
    pub antialias_defocus: Switch,
    /// Anti-aliasing: layered footprints: each view's sample binned by the depth its view sees
    /// into layers, each layer box-filtered once by its footprint, the layers composited front
    /// to back (constant cost whatever the blur, occlusion without a test per sample). auto
    /// (default): on one focus plane at the views' size with a depth shipped with the light
    /// field, else boxed footprints and sub-samples; on: always (a focus surface or another
    /// output size is refused); off: never.
    #[arg(long, value_name = "auto|on|off", default_value = "auto")]
    pub antialias_layered: AutoSwitch,
    /// Anti-aliasing: boxed footprints: away from occlusion edges a pixel out of focus is the
    /// box of its views' plain sums over its footprint (summed-area tables: constant cost
    /// whatever the blur); next to a nearer surface and in focus the sub-samples run as
    /// before: on (default), or off (sub-samples at every pixel: the earlier default).
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub antialias_box: Switch,
}

impl AntialiasArgs {
    /// `--antialias` as a request (`None`: the light field's default).
    pub fn requested(&self) -> Option<bool> {
        self.antialias.map(|s| s == Switch::On)
    }

    /// The sampling settings (validated).
    pub fn settings(&self) -> Result<crate::refocus::antialias::AntialiasSettings> {
        self.sampling.settings()
    }
}

impl AntialiasSamplingArgs {
    /// The sampling settings (validated).
    pub fn settings(&self) -> Result<crate::refocus::antialias::AntialiasSettings> {
        use crate::refocus::antialias::Layered;
        let s = crate::refocus::antialias::AntialiasSettings {
            max_samples: self.antialias_samples,
            prefilter: self.antialias_prefilter == Switch::On,
            focus_test: self.antialias_focus_test == Switch::On,
            focused_bicubic: self.antialias_focused_bicubic == Switch::On,
            occlusion: self.antialias_occlusion == Switch::On,
            defocus: self.antialias_defocus == Switch::On,
            layered: match self.antialias_layered {
                AutoSwitch::Auto => Layered::Auto,
                AutoSwitch::On => Layered::On,
                AutoSwitch::Off => Layered::Off,
            },
            boxed: self.antialias_box == Switch::On,
        };
        s.validate()?;
        Ok(s)
    }
}

/// `on` or `off`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Switch {
    On,
    Off,
}

/// `auto`, `on` or `off`: a switch whose default the library decides case by case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AutoSwitch {
    Auto,
    On,
    Off,
}

/// Vulkan device options.
#[derive(Debug, Clone, Args)]
pub struct GpuArgs {
    /// Vulkan device by index or part of its name (see `tiltfield devices`; also TILTFIELD_DEVICE).
    #[arg(long, value_name = "INDEX|NAME")]
    pub device: Option<String>,
    /// Enable the Khronos validation layer (also TILTFIELD_VALIDATION=1).
    #[arg(long)]
    pub validate: bool,
}

impl GpuArgs {
    pub(crate) fn options(&self) -> GpuOptions {
        let env = GpuOptions::from_env();
        GpuOptions {
            device: self.device.clone().or(env.device),
            validation: self.validate || env.validation,
            ..GpuOptions::default()
        }
    }
}

/// Loads a light field from a path or `builtin:NAME`.
pub fn load_light_field(args: &LightFieldArgs) -> Result<LightField> {
    load_light_field_within(args, &LoadLimits::default())
}

pub use crate::jobs::render::{builtin_light_field, device_load_limits};

/// [`load_light_field`], refusing a light field beyond `limits` before decoding its views.
pub fn load_light_field_within(args: &LightFieldArgs, limits: &LoadLimits) -> Result<LightField> {
    crate::jobs::render::open_light_field(&args.light_field, &args.read.options(), limits)
}

pub use crate::refocus::options::parse_numbers;

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info(a) => info::run(&a),
        Command::Render(a) => render::run(&a),
        Command::Animate(a) => animate::run(&a),
        Command::Synth(a) => synth::run(&a),
        Command::Cloud(a) => cloud::run(&a),
        Command::Bench(a) => bench::run(&a),
        Command::View(a) => view::run(&a),
        Command::Depth(a) => depth::run(&a),
        Command::DepthSet(a) => depth::run_set(&a),
        Command::AntialiasSet(a) => bench::run_antialias_set(&a),
        Command::Demo(a) => demo::run(&a),
        Command::Devices(args) => info::devices(&args),
    }
}

/// Checks before any work that `path` can be written as an output file (see
/// [`crate::io::check_writable`]); creates nothing.
pub(crate) fn check_output(path: &Path) -> Result<()> {
    crate::io::check_writable(path)
}

/// The report of a test-set command (`depth-set`, `antialias-set`): `table` also to
/// `markdown` when given, then on stdout the `json` document with `--json`, else the table
/// with the device on stderr.
pub(crate) fn report_set(
    table: &str,
    markdown: Option<&Path>,
    json: Option<serde_json::Value>,
    device: &str,
) -> Result<()> {
    if let Some(md) = markdown {
        crate::io::write_bytes(md, "Markdown table", table.as_bytes())?;
    }
    match json {
        Some(doc) => println!(
            "{}",
            serde_json::to_string_pretty(&doc)
                .map_err(|e| crate::error::Error::Invalid(e.to_string()))?
        ),
        None => {
            println!("{table}");
            eprintln!("device: {device}");
        }
    }
    Ok(())
}

/// Default output folder of `demo`.
pub(crate) fn default_demo_dir() -> PathBuf {
    PathBuf::from("tiltfield-demo")
}
