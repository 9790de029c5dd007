//! `tiltfield bench`: GPU throughput and accuracy of the refocus pass, side by side.
//!
//! Every [`Variant`] (strategy, filter, view storage, accumulation format, aperture, output
//! size) is measured for speed **and** accuracy in one run on one device:
//! - speed: GPU time of the refocus pass from timestamp queries, after warm-up frames that are
//!   discarded (the first frame of a pipeline includes the driver's shader compilation), as
//!   median, minimum and maximum of N frames; throughput in view-samples per second (active
//!   views × output pixels / time) and, where the device's peaks are known ([`roof`]), the
//!   fraction of its texture-rate and bandwidth roofs;
//! - accuracy: PSNR and maximum error (8-bit levels of the sRGB-encoded float output) against
//!   the f64 CPU reference of the same equations (bilinear), against the f64 model of the
//!   variant's own filter, with the bound the variant promises ([`Variant::bound`]), and for
//!   synthetic scenes against the optical ground truth.
//!
//! A scaling sweep times render's default over apertures × output sizes and fits
//! `time = fixed + cost · views · pixels` ([`stats::fit_cost`]).
//!
//! The anti-aliasing study ([`antialias`]) times the plain sum and anti-aliased refocus at
//! several sub-sample caps on a layered synthetic scene and scores them against its lens.
//!
//! Benchmarks measure; they never assert speed.

pub mod antialias;
pub mod antialias_set;
pub mod chart;
pub mod depth_scenes;
pub mod depth_set;
pub mod output;
pub mod roof;
pub mod stats;
pub mod variant;

use std::collections::HashMap;
use std::sync::Arc;

use glam::DVec3;
use indicatif::{ProgressBar, ProgressStyle};

use crate::error::{Error, Result};
use crate::geometry::aperture::{Aperture, ApertureShape};
use crate::geometry::plane::Plane;
use crate::gpu::GpuContext;
use crate::jobs::refocus::{GpuImage, HeadlessRenderer, RenderSettings};
use crate::lightfield::LightField;
use crate::refocus::cpu::{self, Kernel};
use crate::refocus::settings::ViewStorage;
use crate::refocus::settings::{Accumulation, Filter, OutputFormat};
use crate::refocus::{self as rf, Averaging, FocusSpec, RefocusImage, RefocusPlan, RefocusRequest};

pub use roof::Peak;
pub use stats::{Accuracy, CostModel, Summary};
pub use variant::{Bound, OutputSize, Variant};

/// What to measure.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchOptions {
    /// Timed frames per variant (≥ 1).
    pub frames: usize,
    /// Discarded frames before timing (≥ 1: the first frame compiles the pipeline).
    pub warmup: usize,
    pub variants: Vec<Variant>,
    /// Square-aperture radii (grid steps) of the scaling sweep: (2r + 1)² views, clipped to the
    /// grid. Empty: no sweep.
    pub sweep_radii: Vec<f64>,
    /// Output widths of the sweep (heights keep the views' aspect).
    pub sweep_widths: Vec<u32>,
    /// Timed frames per sweep point.
    pub sweep_frames: usize,
    pub peak_gtexels: Option<f64>,
    pub peak_gbps: Option<f64>,
}

impl BenchOptions {
    /// The full benchmark: the variant catalogue, 20 frames, a sweep of 9–81 views × 128–1024
    /// pixel wide outputs.
    pub fn full() -> Self {
        BenchOptions {
            frames: 20,
            warmup: 2,
            variants: variant::catalogue(),
            sweep_radii: vec![1.0, 2.0, 3.0, 4.0],
            sweep_widths: vec![128, 256, 512, 1024],
            sweep_frames: 5,
            peak_gtexels: None,
            peak_gbps: None,
        }
    }

    /// A quick run (seconds on a CPU driver): every variant of the catalogue, 3 frames, a
    /// 2 × 2 sweep.
    pub fn quick() -> Self {
        BenchOptions {
            frames: 3,
            warmup: 1,
            sweep_radii: vec![0.0, 1.0],
            sweep_widths: vec![16, 32],
            sweep_frames: 2,
            ..Self::full()
        }
    }

    fn check(&self) -> Result<()> {
        if self.frames == 0 || self.frames > 10_000 {
            return Err(Error::Invalid(format!(
                "--frames {} must lie in 1..=10000",
                self.frames
            )));
        }
        if self.variants.is_empty() {
            return Err(Error::Invalid("no variants to measure".into()));
        }
        for (what, v) in [
            ("--peak-gtexels", self.peak_gtexels),
            ("--peak-gbps", self.peak_gbps),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return Err(Error::Invalid(format!("{what} must be positive, got {v}")));
                }
            }
        }
        Ok(())
    }
}

/// The optical ground truth of a synthetic scene (linear RGBA at the views' size, from the
/// grid centre). The bench's built-in scene lies entirely on its focus plane, so the truth is
/// the same for every aperture.
#[derive(Debug, Clone)]
pub struct Truth {
    pub image: RefocusImage,
    pub pinholes: usize,
    pub aperture_radius_steps: f64,
}

/// A light field to benchmark, its focus, and (synthetic scenes) its ground truth.
#[derive(Debug, Clone)]
pub struct BenchScene {
    pub lf: LightField,
    pub focus: FocusSpec,
    /// Human-readable focus, for the report.
    pub focus_text: String,
    pub truth: Option<Truth>,
    pub description: String,
}

/// Distance (pixels) from a view's border within which a sample's mask counts as ambiguous
/// between f32 and f64 ([`cpu::ambiguous_pixels`]); f32 positions of a 512-pixel view are
/// within about 1e-4 px of the f64 ones.
pub const AMBIGUITY_PX: f64 = 1e-3;

/// Name of the bench's built-in synthetic scene.
pub const SYNTHETIC_SCENE: &str = "tilted";

/// The built-in synthetic scene: one textured plane tilted 40° (`synth` scene `tilted`),
/// rasterised into a 9×9 grid of 256² views (quick: 5×5 of 48²), refocused onto its own
/// plane — a tilt-shift refocus whose optical ground truth (a dense thin-lens aperture of
/// pinhole renders) is the plane's texture seen sharp from the grid centre.
pub fn synthetic_scene(ctx: Arc<GpuContext>, quick: bool) -> Result<BenchScene> {
    use crate::jobs::raster::Rasterizer;
    use crate::lightfield::GridSize;
    use crate::synth::{synth_scene, RigKind, SynthRig};
    let scene = synth_scene(SYNTHETIC_SCENE)
        .ok_or_else(|| Error::Invalid(format!("no synth scene {SYNTHETIC_SCENE}")))?;
    let (grid, size, samples, gt_pinholes) = if quick { (5, 48, 2, 7) } else { (9, 256, 3, 9) };
    let rig = SynthRig {
        grid: GridSize {
            cols: grid,
            rows: grid,
        },
        width: size,
        height: size,
        focal_px: scene.focal_per_width * size as f64,
        baseline: scene.baseline,
        focus_distance: scene.focus_distance,
        kind: RigKind::Parallel,
    };
    let builtin = crate::synth::builtin(SYNTHETIC_SCENE)
        .ok_or_else(|| Error::Invalid(format!("no built-in scene {SYNTHETIC_SCENE}")))?;
    let (_, point, normal) = builtin
        .planes()
        .into_iter()
        .next()
        .ok_or_else(|| Error::Invalid(format!("the {SYNTHETIC_SCENE} scene has no plane")))?;
    let plane = Plane::new(point, normal)?;
    let mut r = Rasterizer::with_context(ctx, &scene.mesh())?;
    let synth = crate::jobs::raster::render_light_field(&mut r, &rig, samples, false)?;
    let lf = synth.light_field;
    let radius = (grid as f64 - 1.0) / 2.0;
    let centre = lf.camera_at(lf.grid.centre())?;
    let (linear, pinholes) = r.optical_ground_truth(
        &centre,
        &plane,
        radius * rig.baseline,
        gt_pinholes,
        (size, size),
        samples,
    )?;
    let v3 = |v: DVec3| format!("({:.4}, {:.4}, {:.4})", v.x, v.y, v.z);
    Ok(BenchScene {
        focus: FocusSpec::Plane(plane),
        focus_text: format!(
            "plane through {} with normal {}",
            v3(point),
            v3(plane.normal)
        ),
        truth: Some(Truth {
            image: RefocusImage {
                width: size,
                height: size,
                averaging: Averaging::Linear,
                pixels: linear,
            },
            pinholes,
            aperture_radius_steps: radius,
        }),
        description: format!(
            "synthetic '{SYNTHETIC_SCENE}': a textured plane tilted 40°, {grid}×{grid} views of \
             {size}², refocused onto its own plane"
        ),
        lf,
    })
}

/// Device facts of a report.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DeviceReport {
    pub name: String,
    pub kind: String,
    pub driver: String,
    pub api_version: String,
    pub timestamp_period_ns: f64,
    pub peak: Peak,
    /// `LP_NUM_THREADS` as set for this run (lavapipe's thread count), if set.
    pub lp_num_threads: Option<String>,
}

/// Light field facts of a report.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LightFieldReport {
    pub name: String,
    pub description: String,
    pub grid: [usize; 2],
    pub view_size: [u32; 2],
    pub views: usize,
    /// Views the default aperture uses.
    pub views_used: usize,
    pub focus: String,
    pub synthetic: bool,
    /// Pinholes of the optical ground truth (synthetic scenes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth_pinholes: Option<usize>,
}

/// One measured variant.
#[derive(Debug, Clone, serde::Serialize)]
pub struct VariantReport {
    pub name: String,
    pub label: String,
    pub strategy: String,
    pub filter: Filter,
    pub storage: ViewStorage,
    pub accumulation: Accumulation,
    /// Disk aperture radius (grid steps); `null`: every view.
    pub aperture_radius: Option<f64>,
    pub views: usize,
    pub width: u32,
    pub height: u32,
    pub default: bool,
    pub frames: usize,
    pub gpu_ms_median: f64,
    pub gpu_ms_min: f64,
    pub gpu_ms_max: f64,
    /// View-samples per second: views × output pixels / median time.
    pub samples_per_s: f64,
    /// Minimum memory traffic (each used view read once, the accumulation written once) per
    /// second, in GB/s.
    pub gbps: f64,
    /// Texel fetches per second over the device's nominal texture rate (hardware bilinear
    /// and nearest: one fetch per sample; shader bilinear four; bicubic sixteen).
    pub texture_roof_fraction: Option<f64>,
    /// Minimum memory traffic (each used view read once, the accumulation written once) per
    /// second over the device's nominal bandwidth.
    pub bandwidth_roof_fraction: Option<f64>,
    /// Against the f64 bilinear reference of the same plan and output size: PSNR over every
    /// pixel; maximum error (8-bit levels) over the pixels whose masks are unambiguous.
    pub psnr_vs_reference_db: f64,
    pub max_error_vs_reference: f64,
    /// Pixels left out of the maximum errors: some view's sample lies within
    /// [`AMBIGUITY_PX`] of its border, where f32 and f64 may decide its mask differently (for
    /// nearest also of a rounding tie).
    pub ambiguous_pixels: usize,
    /// The f64 model of this variant's filter (bilinear, bicubic or nearest).
    pub model: &'static str,
    pub psnr_vs_model_db: f64,
    pub max_error_vs_model: f64,
    /// PSNR against the model over the unambiguous pixels only: with `max_error_vs_model`,
    /// what `within_bound` checks (the all-pixel PSNR counts mask decisions f32 and f64 may
    /// legitimately make differently).
    pub psnr_vs_model_unambiguous_db: f64,
    pub bound: Bound,
    pub within_bound: bool,
    /// Synthetic scenes only (`null` for outputs not at the views' size).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub psnr_vs_truth_db: Option<Option<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_error_vs_truth: Option<Option<f64>>,
}

/// One point of the scaling sweep.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ScalingPoint {
    pub views: usize,
    pub width: u32,
    pub height: u32,
    pub view_samples: f64,
    pub frames: usize,
    pub gpu_ms_median: f64,
    pub gpu_ms_min: f64,
    pub gpu_ms_max: f64,
    pub samples_per_s: f64,
}

/// Everything a run measured.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BenchReport {
    pub device: DeviceReport,
    pub light_field: LightFieldReport,
    pub warmup_frames: usize,
    pub variants: Vec<VariantReport>,
    /// The variant the sweep times (render's default).
    pub scaling_variant: String,
    /// The strategy of render's default on this device (`--strategy auto`) and where it came
    /// from ("auto"; "option" never here): the sweep's and the `default` variant's.
    pub scaling_strategy: String,
    pub scaling: Vec<ScalingPoint>,
    pub scaling_fit: Option<CostModel>,
    /// The fastest variant that uses every view at full size and keeps the default's bound
    /// against the f64 bilinear reference.
    pub fastest_full_quality: Option<String>,
    /// The anti-aliasing study ([`antialias`]; `bench --antialias off` leaves it out).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub antialias: Option<antialias::AntialiasReport>,
}

/// Per-view homographies of a plan, for tools that redo the same work (tools/opencv_shift_sum.py).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Homographies {
    pub light_field: String,
    pub width: u32,
    pub height: u32,
    pub averaging: Averaging,
    /// True when every output pixel's ray meets the plane in front of the reference camera,
    /// so each view's map is exactly one homography (no horizon clamp anywhere).
    pub exact: bool,
    pub views: Vec<HomographyView>,
}

/// One view's homography: output pixel (x, y, 1) → view pixel (homogeneous), row-major,
/// pixel-index coordinates (pixel centres at integers); sample where the result's z > 0 and
/// the position lies in [−0.5, W − 0.5] × [−0.5, H − 0.5].
#[derive(Debug, Clone, serde::Serialize)]
pub struct HomographyView {
    pub index: usize,
    pub s: usize,
    pub t: usize,
    pub weight: f64,
    /// The view's image file, when it came from one.
    pub image: Option<String>,
    pub h: [[f64; 3]; 3],
}

/// The homographies of `plan` for an output at the views' size.
pub fn homographies(lf: &LightField, plan: &RefocusPlan) -> Homographies {
    let m = plan.m;
    let (w, h) = (plan.width as f64, plan.height as f64);
    let corners = [
        (0.0, 0.0),
        (w - 1.0, 0.0),
        (0.0, h - 1.0),
        (w - 1.0, h - 1.0),
    ];
    let exact = m == DVec3::ZERO
        || corners
            .iter()
            .all(|&(x, y)| m.dot(DVec3::new(x, y, 1.0)) > 0.0);
    let views = plan
        .views
        .iter()
        .map(|v| {
            let hm =
                v.warp.a + glam::DMat3::from_cols(v.warp.b * m.x, v.warp.b * m.y, v.warp.b * m.z);
            let row = |r: usize| [hm.col(0)[r], hm.col(1)[r], hm.col(2)[r]];
            let src = &lf.views[v.index].source;
            HomographyView {
                index: v.index,
                s: v.s,
                t: v.t,
                weight: v.weight,
                image: std::path::Path::new(src).is_file().then(|| src.clone()),
                h: [row(0), row(1), row(2)],
            }
        })
        .collect();
    Homographies {
        light_field: lf.name.clone(),
        width: plan.width,
        height: plan.height,
        averaging: Averaging::Linear,
        exact,
        views,
    }
}

/// Texel fetches per view-sample of a filter.
fn fetches(filter: Filter) -> f64 {
    match filter {
        Filter::Hardware | Filter::Nearest => 1.0,
        Filter::Shader => 4.0,
        Filter::Bicubic => 16.0,
    }
}

fn kernel_name(k: Kernel) -> &'static str {
    match k {
        Kernel::Bilinear => "bilinear",
        Kernel::Bicubic => "bicubic",
        Kernel::Nearest => "nearest",
    }
}

/// The plan of `scene` with a `shape` aperture of `radius` (None: every view).
pub fn plan_for(
    scene: &BenchScene,
    shape: ApertureShape,
    radius: Option<f64>,
) -> Result<RefocusPlan> {
    let dark = scene.lf.dark_views();
    let req = RefocusRequest {
        focus: scene.focus,
        aperture: Aperture { shape, radius },
        reference: None,
    };
    rf::plan(&scene.lf, &req, &dark)
}

/// The render settings of a variant (linear averaging, float output).
pub fn settings_of(v: &Variant, lf: &LightField) -> RenderSettings {
    RenderSettings {
        averaging: Averaging::Linear,
        output: OutputFormat::Float,
        strategy: v.strategy,
        filter: v.filter,
        size: Some(v.size.resolve(lf.width, lf.height)),
        accumulation: v.accumulation,
        warps: v.warps,
    }
}

/// Renders `v` once as float output (for accuracy checks and `bench` itself).
pub fn render_variant(
    r: &mut HeadlessRenderer,
    scene: &BenchScene,
    plan: &RefocusPlan,
    v: &Variant,
) -> Result<RefocusImage> {
    match r.render(plan, &settings_of(v, &scene.lf))?.0 {
        GpuImage::Float(img) => Ok(img),
        GpuImage::Srgb8(_) => Err(Error::Internal("asked for float output".into())),
    }
}

/// Times `frames` frames of `settings` after `warmup` discarded ones.
fn time_frames(
    r: &mut HeadlessRenderer,
    plan: &RefocusPlan,
    settings: &RenderSettings,
    warmup: usize,
    frames: usize,
    bar: &ProgressBar,
) -> Result<Summary> {
    let mut times = Vec::with_capacity(frames);
    for i in 0..warmup + frames {
        let t = r.render_timed(plan, settings)?.ok_or_else(|| {
            Error::Vulkan(format!(
                "{} has no timestamp queries on its queue: GPU times cannot be measured",
                r.context().info.name
            ))
        })?;
        if i >= warmup {
            times.push(t.refocus_ms);
        }
        bar.inc(1);
    }
    stats::summarize(&times).ok_or_else(|| Error::Invalid("no frames timed".into()))
}

/// A reference image: (aperture radius bits, output size, kernel).
type RefKey = (Option<u64>, (u32, u32), Kernel);
/// An ambiguity map: (aperture radius bits, output size, nearest or not).
type AmbiguityKey = (Option<u64>, (u32, u32), bool);

/// The renderer of `storage` in `list`, uploading the light field on first use.
fn renderer_for<'a>(
    list: &'a mut Vec<(ViewStorage, HeadlessRenderer)>,
    ctx: &Arc<GpuContext>,
    lf: &LightField,
    storage: ViewStorage,
) -> Result<&'a mut HeadlessRenderer> {
    let i = match list.iter().position(|(s, _)| *s == storage) {
        Some(i) => i,
        None => {
            let r = HeadlessRenderer::with_context(Arc::clone(ctx), lf, storage)?;
            list.push((storage, r));
            list.len() - 1
        }
    };
    Ok(&mut list[i].1)
}

/// Plans of the variants by aperture radius key.
type Plans = HashMap<Option<u64>, RefocusPlan>;
/// The scaling sweep's plans (one per distinct view count) and output sizes.
type SweepSet = (Vec<RefocusPlan>, Vec<(u32, u32)>);

/// The radius key of a disk aperture (`None`: every view).
fn radius_key(r: Option<f64>) -> Option<u64> {
    r.map(f64::to_bits)
}

/// The ambiguity map a variant's accuracy excludes: (aperture, output size, nearest or not).
fn ambiguity_key(lf: &LightField, v: &Variant) -> AmbiguityKey {
    (
        radius_key(v.aperture_radius),
        v.size.resolve(lf.width, lf.height),
        v.model() == Kernel::Nearest,
    )
}

/// What the measurements share: plans by aperture radius (disk), f64 references by
/// (radius, size, kernel), ambiguity maps, and the scaling sweep's plans and sizes.
struct Prepared {
    plans: Plans,
    references: HashMap<RefKey, RefocusImage>,
    /// Pixels whose masks (nearest: texels) f32 and f64 may decide differently.
    ambiguous: HashMap<AmbiguityKey, Vec<bool>>,
    sweep_plans: Vec<RefocusPlan>,
    sizes: Vec<(u32, u32)>,
}

/// A variant's accuracy: against the bilinear f64 reference, against its own kernel's model,
/// against the optical truth (synthetic scenes), and the pixels left out as ambiguous.
type VariantAccuracy = (
    stats::Accuracy,
    stats::Accuracy,
    Option<Option<stats::Accuracy>>,
    usize,
);

/// The plans of the variants (by aperture radius) and of the scaling sweep (one per distinct
/// view count) and the sweep's output sizes.
fn plans_of(scene: &BenchScene, options: &BenchOptions) -> Result<(Plans, SweepSet)> {
    let lf = &scene.lf;
    let mut plans: Plans = HashMap::new();
    for v in &options.variants {
        if let std::collections::hash_map::Entry::Vacant(e) =
            plans.entry(radius_key(v.aperture_radius))
        {
            e.insert(plan_for(scene, ApertureShape::Disk, v.aperture_radius)?);
        }
    }
    let sizes: Vec<(u32, u32)> = options
        .sweep_widths
        .iter()
        .map(|&w| {
            (
                w,
                ((w as u64 * lf.height as u64 + lf.width as u64 / 2) / lf.width as u64).max(1)
                    as u32,
            )
        })
        .collect();
    let mut sweep_plans = Vec::new();
    for &r in &options.sweep_radii {
        let plan = plan_for(scene, ApertureShape::Square, Some(r))?;
        if !sweep_plans
            .iter()
            .any(|p: &RefocusPlan| p.views.len() == plan.views.len())
        {
            sweep_plans.push(plan);
        }
    }
    Ok((plans, (sweep_plans, sizes)))
}

/// The (radius, size, kernel) keys of the f64 references the variants are scored against.
fn reference_keys(lf: &LightField, options: &BenchOptions) -> Vec<RefKey> {
    let mut keys: Vec<RefKey> = Vec::new();
    for v in &options.variants {
        let size = v.size.resolve(lf.width, lf.height);
        for k in [Kernel::Bilinear, v.model()] {
            let key = (radius_key(v.aperture_radius), size, k);
            if !keys.contains(&key) {
                keys.push(key);
            }
        }
    }
    keys
}

/// The f64 references of `ref_keys` (CPU work, no device) and the ambiguity maps beside the
/// plans, advancing `bar` by reference.
fn prepare(
    lf: &LightField,
    options: &BenchOptions,
    (plans, (sweep_plans, sizes)): (Plans, SweepSet),
    ref_keys: Vec<RefKey>,
    bar: &ProgressBar,
) -> Prepared {
    let mut references: HashMap<RefKey, RefocusImage> = HashMap::new();
    for key in ref_keys {
        bar.set_message(format!(
            "f64 {} reference {}×{}",
            kernel_name(key.2),
            key.1 .0,
            key.1 .1
        ));
        let plan = &plans[&key.0];
        let img = cpu::render_with(lf, plan, Averaging::Linear, key.1 .0, key.1 .1, key.2);
        references.insert(key, img);
        bar.inc(1);
    }
    let mut ambiguous: HashMap<AmbiguityKey, Vec<bool>> = HashMap::new();
    for v in &options.variants {
        let key = ambiguity_key(lf, v);
        if let std::collections::hash_map::Entry::Vacant(e) = ambiguous.entry(key) {
            let kernel = if key.2 {
                Kernel::Nearest
            } else {
                Kernel::Bilinear
            };
            e.insert(cpu::ambiguous_pixels(
                lf,
                &plans[&key.0],
                key.1,
                kernel,
                AMBIGUITY_PX,
            ));
        }
    }
    Prepared {
        plans,
        references,
        ambiguous,
        sweep_plans,
        sizes,
    }
}

/// Renders variant `v` once for accuracy (also its first warm-up frame: it compiles the
/// pipeline), then the rest of the warm-up, and scores the image.
fn measure_accuracy(
    r: &mut HeadlessRenderer,
    scene: &BenchScene,
    prep: &Prepared,
    v: &Variant,
    warmup: usize,
    bar: &ProgressBar,
) -> Result<VariantAccuracy> {
    let lf = &scene.lf;
    let plan = &prep.plans[&radius_key(v.aperture_radius)];
    let size = v.size.resolve(lf.width, lf.height);
    let image = render_variant(r, scene, plan, v)?;
    bar.inc(1);
    for _ in 1..warmup {
        r.render_timed(plan, &settings_of(v, lf))?;
        bar.inc(1);
    }
    let key = |k| (radius_key(v.aperture_radius), size, k);
    let exclude = prep.ambiguous[&ambiguity_key(lf, v)].as_slice();
    let mismatch = || Error::Invalid("reference size mismatch".into());
    let vs_ref = stats::accuracy(
        &image,
        &prep.references[&key(Kernel::Bilinear)],
        Some(exclude),
    )
    .ok_or_else(mismatch)?;
    let vs_model = stats::accuracy(&image, &prep.references[&key(v.model())], Some(exclude))
        .ok_or_else(mismatch)?;
    let truth = scene
        .truth
        .as_ref()
        .map(|t| stats::accuracy(&image, &t.image, None));
    let ambiguous_count = exclude.iter().filter(|&&a| a).count();
    Ok((vs_ref, vs_model, truth, ambiguous_count))
}

/// The report of variant `v` from its frame times and accuracy, with its roofline fractions.
fn variant_report(
    v: &Variant,
    default: &Variant,
    lf: &LightField,
    plan: &RefocusPlan,
    frame_times: &[f64],
    accuracy: VariantAccuracy,
    peak: &roof::Peak,
) -> Result<VariantReport> {
    let (w, h) = v.size.resolve(lf.width, lf.height);
    let times =
        stats::summarize(frame_times).ok_or_else(|| Error::Invalid("no frames timed".into()))?;
    let (vs_ref, vs_model, truth, ambiguous_count) = accuracy;
    let views = plan.views.len();
    let bound = v.bound(views);
    let samples = views as f64 * w as f64 * h as f64;
    let samples_per_s = samples / (times.median / 1e3);
    let texel_bytes = match v.storage {
        ViewStorage::Srgb8 => 4.0,
        ViewStorage::Linear16 => 8.0,
    };
    let accum_bytes = match v.accumulation {
        Accumulation::Rgba32f => 16.0,
        Accumulation::Rgba16f => 8.0,
    };
    let traffic = views as f64 * lf.width as f64 * lf.height as f64 * texel_bytes
        + w as f64 * h as f64 * accum_bytes;
    Ok(VariantReport {
        name: v.name(),
        label: v.label(),
        strategy: v.strategy.name(),
        filter: v.filter,
        storage: v.storage,
        accumulation: v.accumulation,
        aperture_radius: v.aperture_radius,
        views,
        width: w,
        height: h,
        default: v == default,
        frames: frame_times.len(),
        gpu_ms_median: times.median,
        gpu_ms_min: times.min,
        gpu_ms_max: times.max,
        samples_per_s,
        gbps: traffic / (times.median / 1e3) / 1e9,
        texture_roof_fraction: peak
            .gtexels
            .map(|g| samples_per_s * fetches(v.filter) / (g * 1e9)),
        bandwidth_roof_fraction: peak
            .gbps
            .map(|g| traffic / (times.median / 1e3) / (g * 1e9)),
        psnr_vs_reference_db: vs_ref.psnr_db,
        max_error_vs_reference: vs_ref.max_levels,
        ambiguous_pixels: ambiguous_count,
        model: kernel_name(v.model()),
        psnr_vs_model_db: vs_model.psnr_db,
        max_error_vs_model: vs_model.max_levels,
        psnr_vs_model_unambiguous_db: vs_model.psnr_counted_db,
        within_bound: vs_model.psnr_counted_db >= bound.min_psnr_db
            && vs_model.max_levels <= bound.max_levels,
        bound,
        psnr_vs_truth_db: truth.map(|a| a.map(|a| a.psnr_db)),
        max_error_vs_truth: truth.map(|a| a.map(|a| a.max_levels)),
    })
}

/// Times render's default variant on `r` over every (plan, size) point of the sweep.
fn scaling_points(
    r: &mut HeadlessRenderer,
    lf: &LightField,
    prep: &Prepared,
    default: &Variant,
    (warmup, frames): (usize, usize),
    bar: &ProgressBar,
) -> Result<Vec<ScalingPoint>> {
    let mut scaling = Vec::new();
    for plan in &prep.sweep_plans {
        for &(w, h) in &prep.sizes {
            bar.set_message(format!("scaling: {} views, {w}×{h}", plan.views.len()));
            let settings = RenderSettings {
                size: Some((w, h)),
                ..settings_of(default, lf)
            };
            let t = time_frames(r, plan, &settings, warmup, frames, bar)?;
            let samples = plan.views.len() as f64 * w as f64 * h as f64;
            scaling.push(ScalingPoint {
                views: plan.views.len(),
                width: w,
                height: h,
                view_samples: samples,
                frames,
                gpu_ms_median: t.median,
                gpu_ms_min: t.min,
                gpu_ms_max: t.max,
                samples_per_s: samples / (t.median / 1e3),
            });
        }
    }
    Ok(scaling)
}

/// Measures every variant of `options` and the scaling sweep on `ctx`'s device.
pub fn run(
    ctx: Arc<GpuContext>,
    scene: &BenchScene,
    options: &BenchOptions,
) -> Result<BenchReport> {
    options.check()?;
    let lf = &scene.lf;
    let warmup = options.warmup.max(1);
    let (plans, (sweep_plans, sizes)) = plans_of(scene, options)?;
    // Radii with the same view count share a sweep plan: the bar counts the points timed.
    let sweep_points = sweep_plans.len() * sizes.len();
    let ref_keys = reference_keys(lf, options);
    let total = ref_keys.len()
        + options.variants.len() * (warmup + options.frames)
        + sweep_points * (warmup + options.sweep_frames);
    let bar = ProgressBar::new(total as u64).with_style(
        ProgressStyle::with_template("bench {bar:30} {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let prep = prepare(lf, options, (plans, (sweep_plans, sizes)), ref_keys, &bar);
    let mut renderers: Vec<(ViewStorage, HeadlessRenderer)> = Vec::new();
    let peak = roof::peak_of(&ctx.info.name, options.peak_gtexels, options.peak_gbps);
    // Render's default is `--strategy auto`: the device's fastest, measured once and cached.
    let default = Variant {
        strategy: crate::jobs::strategy::choose(&ctx, None)?.strategy,
        ..Variant::default()
    };
    // Accuracy and warm-up of every variant first; then the timed frames round-robin, one
    // frame of each variant per round, so that a change of machine load (other processes on a
    // CPU driver, clocks on a GPU) affects every variant alike.
    let mut accuracy = Vec::with_capacity(options.variants.len());
    for v in &options.variants {
        bar.set_message(format!("{} (accuracy, warm-up)", v.name()));
        let r = renderer_for(&mut renderers, &ctx, lf, v.storage)?;
        accuracy.push(measure_accuracy(r, scene, &prep, v, warmup, &bar)?);
    }
    let mut times: Vec<Vec<f64>> = vec![Vec::with_capacity(options.frames); options.variants.len()];
    for round in 0..options.frames {
        bar.set_message(format!("timing round {}/{}", round + 1, options.frames));
        for (i, v) in options.variants.iter().enumerate() {
            let r = renderer_for(&mut renderers, &ctx, lf, v.storage)?;
            let plan = &prep.plans[&radius_key(v.aperture_radius)];
            times[i].push(time_frames(r, plan, &settings_of(v, lf), 0, 1, &bar)?.median);
        }
    }
    let mut variants = Vec::new();
    for (i, v) in options.variants.iter().enumerate() {
        let plan = &prep.plans[&radius_key(v.aperture_radius)];
        variants.push(variant_report(
            v,
            &default,
            lf,
            plan,
            &times[i],
            accuracy[i],
            &peak,
        )?);
    }
    // The sweep times render's default on the renderer of its storage.
    let mut scaling = Vec::new();
    if sweep_points > 0 {
        let r = renderer_for(&mut renderers, &ctx, lf, default.storage)?;
        let frames = (warmup, options.sweep_frames);
        scaling = scaling_points(r, lf, &prep, &default, frames, &bar)?;
    }
    bar.finish_and_clear();
    let validated = ctx.check_validation("while benchmarking");
    drop(renderers);
    validated?;
    Ok(report(
        &ctx, scene, &prep, &default, warmup, peak, variants, scaling,
    ))
}

/// The report: device, light field, variants, the scaling sweep with its cost fit, and the
/// fastest variant that meets render's default accuracy bound at full size.
#[allow(clippy::too_many_arguments)]
fn report(
    ctx: &GpuContext,
    scene: &BenchScene,
    prep: &Prepared,
    default: &Variant,
    warmup: usize,
    peak: roof::Peak,
    variants: Vec<VariantReport>,
    scaling: Vec<ScalingPoint>,
) -> BenchReport {
    let lf = &scene.lf;
    let scaling_fit = stats::fit_cost(
        &scaling
            .iter()
            .map(|p| (p.view_samples, p.gpu_ms_median))
            .collect::<Vec<_>>(),
    );
    let default_bound = default.bound(1);
    let all_views = prep
        .plans
        .get(&None)
        .map(|p| p.views.len())
        .unwrap_or_else(|| lf.views.len());
    let fastest_full_quality = variants
        .iter()
        .filter(|v| {
            v.aperture_radius.is_none()
                && (v.width, v.height) == (lf.width, lf.height)
                && v.psnr_vs_reference_db >= default_bound.min_psnr_db
                && v.max_error_vs_reference <= default_bound.max_levels
        })
        .min_by(|a, b| a.gpu_ms_median.total_cmp(&b.gpu_ms_median))
        .map(|v| v.name.clone());
    BenchReport {
        device: DeviceReport {
            name: ctx.info.name.clone(),
            kind: ctx.info.kind.clone(),
            driver: ctx.info.driver.clone(),
            api_version: ctx.info.api_version.clone(),
            timestamp_period_ns: ctx.properties.limits.timestamp_period as f64,
            peak,
            lp_num_threads: std::env::var("LP_NUM_THREADS").ok(),
        },
        light_field: LightFieldReport {
            name: lf.name.clone(),
            description: scene.description.clone(),
            grid: [lf.grid.cols, lf.grid.rows],
            view_size: [lf.width, lf.height],
            views: lf.views.len(),
            views_used: all_views,
            focus: scene.focus_text.clone(),
            synthetic: scene.truth.is_some(),
            truth_pinholes: scene.truth.as_ref().map(|t| t.pinholes),
        },
        warmup_frames: warmup,
        variants,
        scaling_variant: default.name(),
        scaling_strategy: default.strategy.name(),
        scaling,
        scaling_fit,
        fastest_full_quality,
        antialias: None,
    }
}
