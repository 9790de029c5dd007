//! One refocus render as a front end asks for it: open a light field by name, check the
//! options, make sure the scene's depth is there when the focus or the render needs it,
//! resolve the focus, plan (plain, anti-aliased or on a focus surface) and render on an
//! uploaded light field. `tiltfield render` and the Python module both go through here, so
//! that the same request gives the same bytes and fails with the same message in either.
//!
//! Front ends parse their input into [`RenderOptions`] (numbers and enums, no text) and
//! report the [`Prepared`] plan and the image; every decision — which focus, whether to
//! anti-alias, which depth, which pass — is made here.

use std::path::Path;
use std::sync::Arc;

use glam::DVec2;
use indicatif::ProgressBar;

use crate::depth::DepthOrigin;
use crate::error::{Error, Result};
use crate::geometry::aperture::Aperture;
use crate::gpu::GpuContext;
use crate::jobs::refocus::{GpuImage, HeadlessRenderer, PassTimings, RenderSettings};
use crate::jobs::strategy::StrategySource;
use crate::lightfield::{self, GridCameraOptions, LightField, LoadLimits};
use crate::passes::texture::TextureLimits;
use crate::refocus::antialias::{AntialiasPlan, AntialiasSettings};
use crate::refocus::options::FocusOptions;
use crate::refocus::settings::ViewStorage;
use crate::refocus::settings::{Accumulation, Filter, OutputFormat, Strategy, WarpMemory};
use crate::refocus::surface::{FocusSurface, SurfacePlan};
use crate::refocus::{self, Averaging, FocusSpec, RefocusPlan, ResolvedFocus};

/// Largest `--size` side: a float accumulation target of 8192² takes 1 GiB, which every
/// device tiltfield runs on can hold; larger requests failed deep inside Vulkan.
pub const MAX_OUTPUT_SIDE: u32 = 8192;
/// Bytes per output pixel the refocus pass holds at most (RGBA32F accumulation).
const OUTPUT_BYTES_PER_PIXEL: u64 = 16;

/// How a light field is read: the cameras of camera-less grid folders and a video's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// Grid folders: focal length in pixels (`None`: max(width, height)).
    pub focal_px: Option<f64>,
    /// Grid folders: distance between neighbouring views, world units.
    pub baseline: f64,
    /// Camera-array videos: the frame by its number (`None`: the first).
    pub frame: Option<u64>,
}

/// Largest `--baseline` (world units between neighbouring views).
pub const MAX_BASELINE: f64 = 1e9;
/// `--focal-px` bounds (pixels).
pub const FOCAL_PX_RANGE: (f64, f64) = (1e-3, 1e8);

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            focal_px: None,
            baseline: 1.0,
            frame: None,
        }
    }
}

impl ReadOptions {
    /// Checks the grid folder cameras' numbers (also where a source ignores them, so a typo
    /// is never silently dropped).
    pub fn validate(&self) -> Result<()> {
        // Bounds that keep every nominal camera a finite, invertible one: positions within
        // the ±1e12 world units the geometry accepts for any grid of up to 1000 views a side,
        // and a focal length a 32-bit float holds with room for the image's size.
        if !(self.baseline > 0.0 && self.baseline <= MAX_BASELINE) {
            return Err(Error::Invalid(format!(
                "--baseline must be positive and at most {} world units, got {}",
                crate::error::compact(MAX_BASELINE),
                crate::error::compact(self.baseline)
            )));
        }
        if let Some(f) = self.focal_px {
            if !(FOCAL_PX_RANGE.0..=FOCAL_PX_RANGE.1).contains(&f) {
                return Err(Error::Invalid(format!(
                    "--focal-px must lie in {}..{} pixels, got {}",
                    crate::error::compact(FOCAL_PX_RANGE.0),
                    crate::error::compact(FOCAL_PX_RANGE.1),
                    crate::error::compact(f)
                )));
            }
        }
        Ok(())
    }

    /// The cameras of a grid folder.
    pub fn grid_cameras(&self) -> GridCameraOptions {
        GridCameraOptions {
            focal_px: self.focal_px,
            baseline: self.baseline,
        }
    }
}

/// Opens `source` — an HCI folder, a manifest, a grid folder, a camera-array video (with
/// `read.frame`) or `builtin:NAME` — refusing a light field beyond `limits` before its views
/// are decoded.
pub fn open_light_field(
    source: &str,
    read: &ReadOptions,
    limits: &LoadLimits,
) -> Result<LightField> {
    if let Some(name) = source.strip_prefix("builtin:") {
        if let Some(n) = read.frame {
            return Err(Error::Invalid(format!(
                "--frame {n}: builtin:{name} is a single light field, not a video"
            )));
        }
        return builtin_light_field(name);
    }
    read.validate()?;
    lightfield::open_frame_within(Path::new(source), &read.grid_cameras(), limits, read.frame)
}

/// What [`open_light_field`] would refuse before reading anything: an unknown built-in scene
/// (or a frame of one), bad read options, a path that does not exist. The viewer checks this
/// before its window opens, and reads the light field while the window shows the loading
/// screen.
pub fn check_source(source: &str, read: &ReadOptions) -> Result<()> {
    if let Some(name) = source.strip_prefix("builtin:") {
        if let Some(n) = read.frame {
            return Err(Error::Invalid(format!(
                "--frame {n}: builtin:{name} is a single light field, not a video"
            )));
        }
        if crate::synth::builtin(name).is_none() {
            return Err(Error::Invalid(format!(
                "no built-in scene '{name}'; available: {}",
                crate::synth::builtin_names().join(", ")
            )));
        }
        return Ok(());
    }
    read.validate()?;
    std::fs::metadata(source).map_err(|e| Error::io(Path::new(source), e))?;
    Ok(())
}

/// Renders built-in scene `name` (2×2 supersampling).
pub fn builtin_light_field(name: &str) -> Result<LightField> {
    let scene = crate::synth::builtin(name).ok_or_else(|| {
        Error::Invalid(format!(
            "no built-in scene '{name}'; available: {}",
            crate::synth::builtin_names().join(", ")
        ))
    })?;
    Ok(scene.light_field(2))
}

/// The limits of the device `ctx` for a light field texture, for checking a light field
/// before its views are decoded.
pub fn device_load_limits(ctx: &GpuContext) -> LoadLimits {
    let t = TextureLimits::of(ctx);
    LoadLimits::for_device(
        t.max_layers,
        t.max_dimension,
        t.heap_bytes.min(t.max_allocation),
        &ctx.info.name,
    )
}

/// Everything a refocus render is asked for (see the module docs). Unset choices take the
/// library's defaults, as the CLI's options do.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    pub focus: FocusOptions,
    /// Focus slab half-width (world units along the plane's normal).
    pub slab: Option<f64>,
    pub all_in_focus: bool,
    pub aperture: Aperture,
    /// Reference (virtual) view in grid units; `None`: the grid centre.
    pub reference: Option<DVec2>,
    pub averaging: Averaging,
    /// Keep (almost) black views in the aperture.
    pub include_dark: bool,
    /// `Some(on)`: anti-aliasing asked for or refused; `None`: on exactly when the light
    /// field ships depth.
    pub antialias: Option<bool>,
    /// How anti-aliasing samples the footprints, as given (checked by
    /// [`RenderOptions::antialias_settings`]).
    pub antialias_sampling: AntialiasSettings,
    pub strategy: Option<Strategy>,
    /// `batched:N` when no strategy is given (0: one draw).
    pub views_per_draw: usize,
    pub filter: Option<Filter>,
    pub accumulation: Option<Accumulation>,
    pub warps: Option<WarpMemory>,
    /// `None`: the storage that suits `averaging`.
    pub storage: Option<ViewStorage>,
    /// Output size; `None`: the views' size.
    pub size: Option<(u32, u32)>,
    /// 8-bit sRGB (a PNG's bytes) or float linear RGBA (an EXR's values).
    pub output: OutputFormat,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            focus: FocusOptions::default(),
            slab: None,
            all_in_focus: false,
            aperture: Aperture::default(),
            reference: None,
            averaging: Averaging::Linear,
            include_dark: false,
            antialias: None,
            antialias_sampling: AntialiasSettings::default(),
            strategy: None,
            views_per_draw: 0,
            filter: None,
            accumulation: None,
            warps: None,
            storage: None,
            size: None,
            output: OutputFormat::Srgb8,
        }
    }
}

impl RenderOptions {
    /// The strategy asked for: `--strategy`, else `batched:N` from `--views-per-draw N`, else
    /// `None` (auto: [`crate::jobs::strategy::choose`] measures the device's fastest).
    pub fn strategy_asked(&self) -> Option<Strategy> {
        match (self.strategy, self.views_per_draw) {
            (Some(s), _) => Some(s),
            (None, 0) => None,
            (None, n) => Some(Strategy::Batched { views_per_draw: n }),
        }
    }

    /// [`RenderOptions::settings`] with the strategy chosen for `ctx`'s device where none was
    /// asked for, and where it came from.
    pub fn settings_on(&self, ctx: &Arc<GpuContext>) -> Result<(RenderSettings, StrategySource)> {
        let settings = self.check()?;
        let chosen = crate::jobs::strategy::choose(ctx, self.strategy_asked())?;
        Ok((
            RenderSettings {
                strategy: chosen.strategy,
                ..settings
            },
            chosen.source,
        ))
    }

    /// The GPU settings without a device (checks the output size against
    /// [`MAX_OUTPUT_SIDE`]); the strategy is the one asked for, else a stand-in that
    /// [`RenderOptions::settings_on`] replaces by the device's choice.
    pub fn settings(&self) -> Result<RenderSettings> {
        let strategy = self.strategy_asked().unwrap_or_default();
        if let Some((w, h)) = self.size {
            if w > MAX_OUTPUT_SIDE || h > MAX_OUTPUT_SIDE {
                return Err(Error::Invalid(format!(
                    "--size {w}x{h}: at most {MAX_OUTPUT_SIDE} pixels a side (the float \
                     accumulation target alone would take {:.1} GiB)",
                    (w as u64 * h as u64 * OUTPUT_BYTES_PER_PIXEL) as f64 / (1u64 << 30) as f64
                )));
            }
        }
        Ok(RenderSettings {
            averaging: self.averaging,
            output: self.output,
            strategy,
            filter: self.filter.unwrap_or_default(),
            size: self.size,
            accumulation: self.accumulation.unwrap_or_default(),
            warps: self.warps,
        })
    }

    /// The anti-aliasing sample settings (validated).
    pub fn antialias_settings(&self) -> Result<AntialiasSettings> {
        self.antialias_sampling.validate()?;
        Ok(self.antialias_sampling)
    }

    /// The focus surface as asked for (validated; the plane alone unless several planes, a
    /// slab or all-in-focus are given), its planes placed by [`prepare`].
    pub fn surface(&self) -> Result<FocusSurface<FocusSpec>> {
        self.focus.surface(self.slab, self.all_in_focus)
    }

    /// How the views are stored on the GPU.
    pub fn storage(&self) -> ViewStorage {
        self.storage
            .unwrap_or_else(|| ViewStorage::for_averaging(self.averaging))
    }

    /// Every check that needs no light field, in the CLI's order: the GPU settings, the
    /// anti-aliasing samples, the focus surface, the aperture's radius. The focus itself is
    /// checked by [`FocusOptions::validate`] (the CLI's parser does it there).
    pub fn check(&self) -> Result<RenderSettings> {
        let settings = self.settings()?;
        // A bad radius is refused before loading, not after decoding every view.
        self.aperture.validate()?;
        self.antialias_settings()?;
        self.surface()?;
        Ok(settings)
    }
}

/// An output size given as two integers (the Python module's `size=(w, h)`): refused unless
/// both are positive, in the words of the CLI's `--size WxH`.
pub fn output_size(w: i64, h: i64) -> Result<(u32, u32)> {
    match (u32::try_from(w), u32::try_from(h)) {
        (Ok(a), Ok(b)) if a > 0 && b > 0 => Ok((a, b)),
        _ => Err(Error::Invalid(format!(
            "--size: expected AxB with positive integers, got '{w}x{h}'"
        ))),
    }
}

/// Refuses an output size the device cannot hold (its image size limit, or its largest
/// allocation for the float accumulation target), naming `--size`.
pub fn check_output_fits(ctx: &GpuContext, (w, h): (u32, u32)) -> Result<()> {
    let t = TextureLimits::of(ctx);
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

/// A render ready to run: every plan, and what the report needs about how they were made.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub settings: RenderSettings,
    pub plan: RefocusPlan,
    pub focus: ResolvedFocus,
    /// Set when anti-aliasing is on (its plan then replaces `plan`'s views).
    pub antialias: Option<AntialiasPlan>,
    pub surface: FocusSurface,
    pub surface_plan: SurfacePlan,
    /// Where the scene's depth came from, when the render used it.
    pub depth: Option<DepthOrigin>,
    /// Whether `settings.strategy` was asked for or chosen for the device.
    pub strategy_source: StrategySource,
}

impl Prepared {
    /// The plan whose views are summed (anti-aliasing's when it is on).
    pub fn views_plan(&self) -> &RefocusPlan {
        self.antialias.as_ref().map_or(&self.plan, |a| &a.plan)
    }

    /// The output size.
    pub fn output_size(&self) -> (u32, u32) {
        self.settings
            .size
            .unwrap_or((self.plan.width, self.plan.height))
    }
}

/// Indices of views to leave out of the aperture (vignetted black views), with a warning when
/// there are any.
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

/// The plan of `options` on `lf`, and how its focus was set; `default_window` is a click's
/// default normal window (larger on estimated depth).
pub fn make_plan(
    lf: &LightField,
    options: &RenderOptions,
    default_window: u32,
) -> Result<(RefocusPlan, ResolvedFocus)> {
    let excluded = dark_views(lf, options.include_dark);
    make_plan_excluding(lf, options, default_window, &excluded)
}

/// [`make_plan`] leaving out the views `excluded` marks (the dark views, found once).
fn make_plan_excluding(
    lf: &LightField,
    options: &RenderOptions,
    default_window: u32,
    excluded: &[bool],
) -> Result<(RefocusPlan, ResolvedFocus)> {
    let request = match options.focus.request(default_window)? {
        Some(r) => r,
        // All-in-focus alone: the plane only serves where the depth is unknown, and
        // `no_fallback_needed` refuses the render if there is any such pixel; the
        // zero-disparity plane stands in (the rig's focus distance, or no shift).
        None if options.all_in_focus => FocusSpec::Disparity(0.0).into(),
        None => {
            return Err(Error::Invalid(
                "give one of --disparity, --plane, --focus, --click, --points or --points-3d"
                    .into(),
            ))
        }
    };
    let (focus, plan) =
        refocus::resolve_and_plan(lf, &request, options.aperture, options.reference, excluded)?;
    Ok((plan, focus))
}

/// The anti-aliasing plan of `options` for `plan` on `lf`, when it is on (`aa_on`); `lf` must
/// then carry depth. When anti-aliasing was not asked for but is on by default (the light
/// field ships depth), a render it cannot anti-alias (classic shift-and-sum, more than 256
/// views in the aperture) is the plain sum, with a warning.
pub fn antialias_plan(
    lf: &LightField,
    options: &RenderOptions,
    plan: &RefocusPlan,
    aa_on: bool,
) -> Result<Option<AntialiasPlan>> {
    if !aa_on {
        return Ok(None);
    }
    antialias_plan_excluding(
        lf,
        options,
        plan,
        &lf.excluded_views(options.include_dark),
        None,
    )
}

/// [`antialias_plan`], on, leaving out the views `excluded` marks, taking the views' maps from
/// `previous` where they are the same.
fn antialias_plan_excluding(
    lf: &LightField,
    options: &RenderOptions,
    plan: &RefocusPlan,
    excluded: &[bool],
    previous: Option<&AntialiasPlan>,
) -> Result<Option<AntialiasPlan>> {
    let views_size = (lf.width, lf.height);
    let one_plane = !options.surface()?.needs_depth();
    let at_views_size = options.size.map_or(true, |s| s == views_size);
    let settings = options
        .antialias_settings()?
        .for_output(one_plane && at_views_size);
    let made = refocus::antialias::plan_for_reusing(
        lf,
        plan,
        options.aperture,
        excluded,
        settings,
        previous,
    );
    match made {
        // Asked for layered footprints (`--antialias-layered on`) where they cannot integrate.
        Ok(aa) if aa.settings.layered.on() && !one_plane => Err(Error::Invalid(
            "layered anti-aliasing focuses on one plane; a focus surface needs \
             --antialias-layered off or auto"
                .into(),
        )),
        Ok(aa) if aa.settings.layered.on() && !at_views_size => {
            let (w, h) = options.size.unwrap_or(views_size);
            Err(Error::Invalid(format!(
                "layered anti-aliasing renders at the views' size ({}×{}), not {w}×{h}: use \
                 --antialias-layered off or auto",
                views_size.0, views_size.1
            )))
        }
        Ok(aa) => Ok(Some(aa)),
        Err(e) if options.antialias.is_none() => {
            log::warn!("rendering without anti-aliasing: {e}");
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// Makes every plan of `options` on `lf` (see the module docs). When the focus (a click), the
/// anti-aliasing or the focus surface needs the scene's depth and `lf` has none, it is
/// estimated on `ctx` (`progress` counts the planes) and installed in `lf`.
pub fn prepare(
    ctx: &Arc<GpuContext>,
    lf: &mut LightField,
    options: &RenderOptions,
    progress: &ProgressBar,
) -> Result<Prepared> {
    prepare_excluding(ctx, lf, options, progress, None, None)
}

/// [`prepare`] with the views to leave out given (`None`: found here; a [`Session`] finds
/// them once, since scanning every view for darkness costs more than planning), and the
/// anti-aliasing plan of the request before, whose views' maps serve again where the depth and
/// the views are the same (a focal stack: only the plane moves).
fn prepare_excluding(
    ctx: &Arc<GpuContext>,
    lf: &mut LightField,
    options: &RenderOptions,
    progress: &ProgressBar,
    excluded: Option<&[bool]>,
    previous: Option<&AntialiasPlan>,
) -> Result<Prepared> {
    let (settings, strategy_source) = options.settings_on(ctx)?;
    // The surface's planes as given: placed in the world once the plan's reference camera
    // is known (after any depth estimate, which may give a grid folder's cameras their
    // nominal model).
    let asked = options.surface()?;
    // Clicks need depth: the light field's own map, or one estimated from its views.
    let (depth, window) = if options.focus.needs_depth() {
        let (origin, window) = crate::jobs::depth::ensure_for(ctx, lf, progress)?;
        (Some(origin), window)
    } else {
        (None, crate::geometry::normals::GIVEN_DEPTH_WINDOW)
    };
    // Anti-aliasing needs the scene's depth too: given, or estimated when asked for.
    let aa_on = refocus::antialias::wanted(options.antialias, lf);
    let depth = match depth {
        None if aa_on => Some(crate::jobs::depth::ensure_for(ctx, lf, progress)?.0),
        // A focus surface chooses its focus from the scene's depth at every pixel.
        None if asked.needs_depth() => Some(
            crate::jobs::depth::ensure_for(ctx, lf, progress)
                .map_err(|e| surface_without_depth(asked.name(), e))?
                .0,
        ),
        d => d,
    };
    let found;
    let excluded = match excluded {
        Some(e) => e,
        None => {
            found = dark_views(lf, options.include_dark);
            &found
        }
    };
    let (plan, focus) = make_plan_excluding(lf, options, window, excluded)?;
    // A surface chooses between the inverse depths of planes: classic shift-and-sum becomes
    // the plane it stands for (its plain sum is the classic one up to rounding).
    let plan = match asked.needs_depth() {
        true => refocus::plan::with_plane(lf, &plan, options.aperture, excluded)
            .map_err(|e| refocus::surface::in_surface(asked.name(), e))?
            .into_owned(),
        false => plan,
    };
    let surface = asked.resolve(lf, plan.reference)?;
    let antialias = match aa_on {
        true => antialias_plan_excluding(lf, options, &plan, excluded, previous)?,
        false => None,
    };
    let surface_plan = refocus::surface::surface_for(lf, &plan, &surface, antialias.as_ref())?;
    no_fallback_needed(options, &surface_plan)?;
    Ok(Prepared {
        settings,
        plan,
        focus,
        antialias,
        surface,
        surface_plan,
        depth,
        strategy_source,
    })
}

/// Refuses `--all-in-focus` without a focus option where the depth leaves pixels unknown:
/// their focus would be a plane nobody chose.
fn no_fallback_needed(options: &RenderOptions, surface: &SurfacePlan) -> Result<()> {
    let given = options
        .focus
        .request(crate::geometry::normals::GIVEN_DEPTH_WINDOW)?;
    match (&surface.depth, given) {
        (Some(d), None) if options.all_in_focus && d.unknown > 0 => Err(Error::Invalid(format!(
            "--all-in-focus: the depth ({}) is unknown at {} of {} pixels; give a focus option \
             (--disparity, --plane, --focus, --click, --points or --points-3d) for them",
            d.source,
            d.unknown,
            d.width as usize * d.height as usize
        ))),
        _ => Ok(()),
    }
}

/// The error of a focus surface whose light field (or video frame) has no depth and cannot
/// get an estimate: `e` says why.
fn surface_without_depth(surface: &str, e: Error) -> Error {
    Error::Invalid(format!(
        "the focus surface '{surface}' needs the scene's depth, which this light field lacks \
         and cannot be estimated: {e}"
    ))
}

/// The plans of a frame range (`render --frames`): the first frame's plane (or focus
/// surface's planes) for every frame, and with anti-aliasing or a focus surface each frame's
/// own depth (the video's, or estimated per frame and cached): things move between frames, and
/// the first frame's depth blurred a moving card where it had been, or focused it where it had
/// been. [`FramePlanner::plan_frame`] is what [`crate::jobs::batch::render_frames`]
/// calls per frame.
pub struct FramePlanner<'a> {
    options: &'a RenderOptions,
    /// The plan anti-aliasing and a focus surface start from, made on the first frame with
    /// its depth.
    depth_base: Option<RefocusPlan>,
    /// The first frame's focus.
    pub focus: Option<ResolvedFocus>,
    /// Where the first frame's depth came from (with anti-aliasing).
    pub depth_origin: Option<DepthOrigin>,
    /// Frames planned on their own depth.
    pub depth_frames: usize,
}

impl<'a> FramePlanner<'a> {
    pub fn new(options: &'a RenderOptions) -> Self {
        FramePlanner {
            options,
            depth_base: None,
            focus: None,
            depth_origin: None,
            depth_frames: 0,
        }
    }

    /// The plan of frame `lf`, given the frame before's (`None` for the first); `None` keeps
    /// the one before (nothing depends on the frame). `progress` counts the planes of the
    /// frame's depth estimate, if one is made.
    pub fn plan_frame(
        &mut self,
        ctx: &GpuContext,
        lf: &LightField,
        previous: Option<&crate::jobs::batch::FramePlan>,
        progress: &ProgressBar,
    ) -> Result<Option<crate::jobs::batch::FramePlan>> {
        let options = self.options;
        let aa_on = refocus::antialias::wanted(options.antialias, lf);
        let asked = options.surface()?;
        // Anti-aliasing and a focus surface read the frame's own depth; a plain plane reads
        // none, so its first frame's plan serves every frame.
        let per_frame = aa_on || asked.needs_depth();
        let plan = match previous {
            // The plane is fixed from the first frame.
            None if options.focus.needs_depth() => {
                // A click picks on the first frame's depth, estimated (and cached) when the
                // video has none, as `render --frame N --click` does on frame N; the plane it
                // finds then serves the whole range, as any other plane does.
                let mut first = lf.clone();
                let (_, window) = crate::jobs::depth::ensure_for(ctx, &mut first, progress)?;
                let (plan, f) = make_plan(&first, options, window)?;
                self.focus = Some(f);
                plan
            }
            None => {
                let (plan, f) =
                    make_plan(lf, options, crate::geometry::normals::GIVEN_DEPTH_WINDOW)?;
                self.focus = Some(f);
                plan
            }
            Some(_) if !per_frame => return Ok(None),
            Some(p) => p.plan.clone(),
        };
        if !per_frame {
            return Ok(Some(crate::jobs::batch::FramePlan {
                plan,
                antialias: None,
                surface: None,
            }));
        }
        let mut frame = lf.clone();
        let origin = crate::jobs::depth::ensure_for(ctx, &mut frame, progress)
            .map_err(|e| match asked.needs_depth() {
                true => surface_without_depth(asked.name(), e),
                false => e,
            })?
            .0;
        self.depth_frames += 1;
        self.depth_origin.get_or_insert(origin);
        let base = match &self.depth_base {
            Some(b) => b,
            None => {
                let (b, _) = make_plan(
                    &frame,
                    options,
                    crate::geometry::normals::GIVEN_DEPTH_WINDOW,
                )?;
                // A surface chooses between the inverse depths of planes: classic
                // shift-and-sum becomes the plane it stands for (as `prepare` does).
                let b = match asked.needs_depth() {
                    true => refocus::plan::with_plane(
                        &frame,
                        &b,
                        options.aperture,
                        &frame.excluded_views(options.include_dark),
                    )
                    .map_err(|e| refocus::surface::in_surface(asked.name(), e))?
                    .into_owned(),
                    false => b,
                };
                self.depth_base.insert(b)
            }
        };
        let antialias = antialias_plan(&frame, options, base, aa_on)?;
        if !asked.needs_depth() {
            return Ok(Some(crate::jobs::batch::FramePlan {
                plan,
                antialias,
                surface: None,
            }));
        }
        // The surface's planes are the first frame's; where each pixel focuses among them
        // follows this frame's depth.
        let surface = asked.resolve(&frame, base.reference)?;
        let surface_plan =
            refocus::surface::surface_for(&frame, base, &surface, antialias.as_ref())?;
        no_fallback_needed(options, &surface_plan)?;
        Ok(Some(crate::jobs::batch::FramePlan {
            plan: base.clone(),
            antialias,
            surface: Some(surface_plan),
        }))
    }
}

/// Renders `prepared` on `renderer` (which holds its light field's views) and reads the image
/// back: on the focus surface, anti-aliased or the plain sum, as planned.
pub fn render(
    renderer: &mut HeadlessRenderer,
    prepared: &Prepared,
) -> Result<(GpuImage, Option<PassTimings>)> {
    let p = prepared;
    match &p.antialias {
        _ if p.surface.needs_depth() => {
            renderer.render_surface(&p.plan, p.antialias.as_ref(), &p.surface_plan, &p.settings)
        }
        Some(aa) => renderer.render_antialiased(aa, &p.settings),
        None => renderer.render(&p.plan, &p.settings),
    }
}

/// [`render`] for timing: the GPU times, without reading the image back where the pass
/// allows it.
pub fn render_timed(
    renderer: &mut HeadlessRenderer,
    prepared: &Prepared,
) -> Result<Option<PassTimings>> {
    let p = prepared;
    match &p.antialias {
        _ if p.surface.needs_depth() => Ok(render(renderer, p)?.1),
        Some(aa) => renderer.render_timed_antialiased(aa, &p.settings),
        None => renderer.render_timed(&p.plan, &p.settings),
    }
}

/// A light field held for many renders (the Python module's `LightField`): its views are
/// uploaded once, on the first render, and every later render costs the GPU time and a
/// readback.
///
/// Each render sees the light field as `tiltfield render` would have loaded it: a render whose
/// focus, anti-aliasing or focus surface needs depth the light field lacks runs on a copy
/// made once with the estimate installed (on a grid folder that also gives the cameras their
/// nominal sensor shift, docs/conventions.md §10), while every other render runs on the light
/// field as loaded, so an earlier click never changes a later render's cameras or its default
/// anti-aliasing. The copy's views are the same pixels, so one upload serves both.
pub struct Session {
    ctx: std::sync::Arc<GpuContext>,
    lf: LightField,
    /// `lf` with the scene's depth ensured, made on the first render that needs it.
    with_depth: Option<LightField>,
    renderer: Option<HeadlessRenderer>,
    /// Which views are (almost) black, found on the first request that leaves them out.
    dark: Option<Vec<bool>>,
    /// The last request's anti-aliasing plan: its views' maps serve the next one on the same
    /// depth and views (about 0.3 s a call on backgammon's 81 views of 512²).
    last_antialias: Option<AntialiasPlan>,
}

impl Session {
    /// Holds `lf` for renders on `ctx` (nothing is uploaded yet).
    pub fn new(ctx: std::sync::Arc<GpuContext>, lf: LightField) -> Self {
        Session {
            ctx,
            lf,
            with_depth: None,
            renderer: None,
            dark: None,
            last_antialias: None,
        }
    }

    /// The light field as loaded.
    pub fn light_field(&self) -> &LightField {
        &self.lf
    }

    /// The device.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Whether a render of `options` reads the scene's depth (the focus picks pixels,
    /// anti-aliasing is on, or the surface is not a plane).
    fn needs_depth(&self, options: &RenderOptions) -> Result<bool> {
        Ok(options.focus.needs_depth()
            || refocus::antialias::wanted(options.antialias, &self.lf)
            || options.surface()?.needs_depth())
    }

    /// The light field a request sees (see the type docs): the loaded one, or the copy with
    /// depth when the request needs depth that the loaded one lacks.
    fn light_field_for(&mut self, depth: bool) -> &mut LightField {
        if !depth || !self.lf.depth.is_empty() {
            return &mut self.lf;
        }
        self.with_depth.get_or_insert_with(|| self.lf.clone())
    }

    /// The views a request leaves out: none with `include_dark`, else the dark ones (the
    /// same in the copy with depth: its views are the same pixels).
    fn excluded(&mut self, include_dark: bool) -> Vec<bool> {
        if include_dark {
            return vec![false; self.lf.views.len()];
        }
        let lf = &self.lf;
        self.dark
            .get_or_insert_with(|| dark_views(lf, false))
            .clone()
    }

    /// Plans `options` ([`prepare`]) on the light field the request sees. Anti-aliasing's
    /// default is what `render` decides from the light field as loaded: on where it ships
    /// depth, and where the request's focus is picked in the depth (a click estimates it
    /// first). A depth an earlier request estimated is kept for the requests that need depth
    /// but decides nothing, so the same request always gives the same image, `render`'s.
    pub fn prepare(&mut self, options: &RenderOptions, progress: &ProgressBar) -> Result<Prepared> {
        let resolved;
        let options = match options.antialias {
            Some(_) => options,
            None => {
                let on = refocus::antialias::wanted(None, &self.lf) || options.focus.needs_depth();
                resolved = RenderOptions {
                    antialias: Some(on),
                    ..options.clone()
                };
                &resolved
            }
        };
        let depth = self.needs_depth(options)?;
        let excluded = self.excluded(options.include_dark);
        let ctx = Arc::clone(&self.ctx);
        let previous = self.last_antialias.take();
        let prepared = prepare_excluding(
            &ctx,
            self.light_field_for(depth),
            options,
            progress,
            Some(&excluded),
            previous.as_ref(),
        )?;
        self.last_antialias = prepared.antialias.clone().or(previous);
        Ok(prepared)
    }

    /// Resolves the focus of `options` alone (a click estimates depth when the light field
    /// has none), checking the aperture first as a render does.
    pub fn resolve(
        &mut self,
        options: &RenderOptions,
        progress: &ProgressBar,
    ) -> Result<ResolvedFocus> {
        let ctx = std::sync::Arc::clone(&self.ctx);
        let excluded = self.excluded(options.include_dark);
        let lf = self.light_field_for(options.focus.needs_depth());
        let window = if options.focus.needs_depth() {
            crate::jobs::depth::ensure_for(&ctx, lf, progress)?.1
        } else {
            crate::geometry::normals::GIVEN_DEPTH_WINDOW
        };
        Ok(make_plan_excluding(lf, options, window, &excluded)?.1)
    }

    /// The point cloud of `req` ([`crate::jobs::cloud`]) on the light field with depth (a
    /// depth estimated here, or by an earlier request, is kept for the later ones).
    pub fn cloud(
        &mut self,
        req: &crate::jobs::cloud::CloudRequest,
        progress: &ProgressBar,
    ) -> Result<crate::jobs::cloud::Cloud> {
        let ctx = Arc::clone(&self.ctx);
        crate::jobs::cloud::cloud(self.light_field_for(true), req, Some(&ctx), progress)
    }

    /// Renders `options` and reads the image back, uploading the views first when no render
    /// has yet (or when `options` stores them differently: a change of averaging uploads
    /// them again in the storage that suits it).
    pub fn render(
        &mut self,
        options: &RenderOptions,
        progress: &ProgressBar,
    ) -> Result<(GpuImage, Option<PassTimings>, Prepared)> {
        let prepared = self.prepare(options, progress)?;
        if let Some(size) = prepared.settings.size {
            check_output_fits(&self.ctx, size)?;
        }
        let storage = options.storage();
        if self.renderer.as_ref().map(|r| r.storage()) != Some(storage) {
            // The old texture goes before the new one is made: one light field's views on
            // the device at a time.
            self.renderer = None;
            self.renderer = Some(HeadlessRenderer::with_context(
                std::sync::Arc::clone(&self.ctx),
                &self.lf,
                storage,
            )?);
        }
        let Some(renderer) = self.renderer.as_mut() else {
            return Err(Error::Internal("no renderer".into()));
        };
        let (image, timings) = render(renderer, &prepared)?;
        Ok((image, timings, prepared))
    }

    /// Whether the views are on the device.
    pub fn uploaded(&self) -> bool {
        self.renderer.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_from_numbers_are_refused_in_the_words_of_the_cli() {
        assert_eq!(output_size(96, 80).unwrap(), (96, 80));
        for (w, h) in [(0, 10), (-3, 5), (5, 1 << 40)] {
            let e = output_size(w, h).unwrap_err().to_string();
            assert_eq!(
                e,
                format!("--size: expected AxB with positive integers, got '{w}x{h}'")
            );
        }
        let big = RenderOptions {
            size: Some((MAX_OUTPUT_SIDE + 1, 8)),
            ..RenderOptions::default()
        };
        assert!(big
            .settings()
            .unwrap_err()
            .to_string()
            .contains("at most 8192"));
    }

    #[test]
    fn read_options_refuse_cameras_that_cannot_be() {
        let bad = |o: ReadOptions| o.validate().unwrap_err().to_string();
        let base = ReadOptions::default();
        base.validate().unwrap();
        assert_eq!(
            bad(ReadOptions {
                baseline: f64::INFINITY,
                ..base.clone()
            }),
            "--baseline must be positive and at most 1.0000e9 world units, got inf"
        );
        assert_eq!(
            bad(ReadOptions {
                focal_px: Some(-2.0),
                ..base.clone()
            }),
            "--focal-px must lie in 0.001..1.0000e8 pixels, got -2"
        );
        // The campaign's extremes: cameras that would lie beyond the geometry's reach, or a
        // focal length that makes K singular, name the option.
        for (baseline, focal) in [(1e308, None), (1.845e19, None), (1.0, Some(1e-308))] {
            let e = bad(ReadOptions {
                baseline,
                focal_px: focal,
                ..base.clone()
            });
            let option = if focal.is_some() {
                "--focal-px"
            } else {
                "--baseline"
            };
            assert!(e.starts_with(option), "{e}");
        }
    }

    #[test]
    fn the_storage_follows_the_averaging_unless_given() {
        let encoded = RenderOptions {
            averaging: Averaging::Encoded,
            ..RenderOptions::default()
        };
        assert_eq!(
            encoded.storage(),
            ViewStorage::for_averaging(Averaging::Encoded)
        );
        let given = RenderOptions {
            storage: Some(ViewStorage::Linear16),
            ..encoded
        };
        assert_eq!(given.storage(), ViewStorage::Linear16);
    }
}
