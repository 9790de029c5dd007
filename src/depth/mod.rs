//! Depth from the light field itself: a plane sweep on the GPU.
//!
//! Sweeping a family of frontoparallel planes through the scene is refocusing at many depths;
//! where a plane passes through a surface the views agree about its colour. For the reference
//! view (normally the middle one) and planes uniform in inverse depth ([`sweep`]), every
//! matched view is warped by the same per-view homography the refocus uses
//! ([`crate::geometry::homography`]), so calibrated rotated rigs work too. Per pixel and plane:
//!
//! 1. **cost** ([`CostKind`]): the mean absolute difference of the sRGB-encoded colours of each
//!    matched view's sample and the reference pixel, truncated at `truncation`; `robust`
//!    (default) averages the two best of the four half-apertures (left, right, upper, lower
//!    views), because an occluder next to a pixel hides it from the views on one side only;
//!    `mean` averages all views (plain SAD);
//! 2. **aggregation** ([`Aggregation`]) over a `(2r + 1)²` window: the guided filter (He et al.
//!    2010, guided by the reference view's colours: edge-aware, cost-volume filtering as in
//!    Hosni et al. 2013) by default, or a box filter, or none;
//! 3. **winner-take-all** over the planes, refined by the parabola through the winner's
//!    neighbours (sub-plane precision), and a **confidence** `(c₂ − c₁)/(c₂ + ε)`, c₁ the
//!    winner's cost and c₂ the best cost of the planes more than 1 px of motion (farthest
//!    view) away from it: near 0 where the views look alike at every depth (no texture) or
//!    another depth fits as well (repetition).
//!
//! The sweep parameter and the output follow the light field's convention ([`Convention`]):
//! HCI disparity on regular parallel rigs (HCI folders, built-in scenes, rig manifests),
//! classic shift-and-sum disparity on grid folders, inverse depth on other calibrated rigs;
//! [`DepthEstimate::values`] gives disparity or metric depth. The range is the one given, else
//! the dataset's `disp_min … disp_max`, else found automatically ([`RangeOrigin::Automatic`]):
//! a coarse sweep at a quarter of the resolution over a wide range (the image centre moving by
//! up to an eighth of the image per two grid steps of the farthest matched view), whose
//! confident pixels' 1st to 99th percentiles, widened by 5 % and one coarse plane, become the
//! range.
//!
//! [`ensure_depth`] gives a light field without a depth map its estimate, cached on disk keyed
//! by content ([`cache`]); clicks, point clouds and the viewer call it.

pub mod arbitrate;
pub mod cache;
pub mod cpu;
pub mod edges;
pub mod guide;
pub mod median;
pub mod metrics;
pub mod photometric;
pub mod plane_fill;
pub mod refine;
pub mod request;
pub mod smooth;
pub mod sweep;

use image::RgbaImage;

pub use crate::lightfield::DepthKind;
pub use cache::{ensure_depth_in, DepthOrigin};
use sweep::SweepPlan;

use crate::error::{Error, Result};
use crate::lightfield::{DepthMap, LightField, ParallelRig};

/// What the sweep parameter p means (see [`sweep`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "convention", rename_all = "kebab-case")]
pub enum Convention {
    /// HCI disparity on a regular parallel rig with sensor shift (px per grid step, positive
    /// nearer than the focus distance).
    Hci(ParallelRig),
    /// Classic shift-and-sum disparity of a grid folder: view (s, t) sees reference pixel x at
    /// x + (s − s_r, t − t_r)·D. `focal_px` and `baseline` are the folder's nominal cameras.
    Classic { focal_px: f64, baseline: f64 },
    /// Inverse depth 1/Z of the reference camera (calibrated rigs without a regular grid).
    InverseDepth,
}

/// Which views are matched against the reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ViewSet {
    /// Every view.
    All,
    /// The reference's row and column, up to N steps away (`usize::MAX`: all of them).
    Cross(usize),
    /// The (2N + 1)² block around the reference.
    Square(usize),
}

impl ViewSet {
    /// `all`, `cross`, `cross:N`, `square:N`.
    pub fn name(&self) -> String {
        match self {
            ViewSet::All => "all".into(),
            ViewSet::Cross(usize::MAX) => "cross".into(),
            ViewSet::Cross(n) => format!("cross:{n}"),
            ViewSet::Square(n) => format!("square:{n}"),
        }
    }
}

impl std::str::FromStr for ViewSet {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        let bad = || {
            Error::Invalid(format!(
                "unknown view set '{s}': expected all, cross, cross:N or square:N (N ≥ 1 grid steps)"
            ))
        };
        let count = |n: &str| match n.parse::<usize>() {
            Ok(n) if n >= 1 => Ok(n),
            _ => Err(bad()),
        };
        match s.split_once(':') {
            None if s == "all" => Ok(ViewSet::All),
            None if s == "cross" => Ok(ViewSet::Cross(usize::MAX)),
            Some(("cross", n)) => Ok(ViewSet::Cross(count(n)?)),
            Some(("square", n)) => Ok(ViewSet::Square(count(n)?)),
            _ => Err(bad()),
        }
    }
}

/// The photo-consistency cost (module docs, step 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CostKind {
    /// Mean of the two best half-aperture means (occlusion-aware).
    Robust,
    /// Mean over all matched views (SAD).
    Mean,
    /// Mean of the three best half-aperture means (drops the worst side).
    DropWorst,
}

/// The cost aggregation (module docs, step 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Aggregation {
    Guided,
    Box,
    None,
}

macro_rules! parse_enum {
    ($ty:ty, $what:literal, $($name:literal => $v:expr),+) => {
        impl std::str::FromStr for $ty {
            type Err = Error;
            fn from_str(s: &str) -> Result<Self> {
                match s {
                    $($name => Ok($v),)+
                    _ => Err(Error::Invalid(format!(
                        concat!("unknown ", $what, " '{}': expected ", $($name, " "),+), s
                    ))),
                }
            }
        }
    };
}
parse_enum!(CostKind, "cost", "robust" => CostKind::Robust, "mean" => CostKind::Mean,
    "drop-worst" => CostKind::DropWorst);
parse_enum!(Aggregation, "aggregation", "guided" => Aggregation::Guided,
    "box" => Aggregation::Box, "none" => Aggregation::None);

/// Sub-plane refinement of the winning plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Refine {
    /// The parabola through the winner and its two neighbours.
    Parabola,
    /// Two lines of equal and opposite slope (Shimizu & Okutomi 2001), the model of an
    /// absolute-difference cost's V-shaped minimum.
    Equiangular,
}
parse_enum!(Refine, "refinement", "parabola" => Refine::Parabola,
    "equiangular" => Refine::Equiangular);

/// Where the swept range came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RangeOrigin {
    /// `--range`.
    Given,
    /// The dataset's documented disparity range (HCI `disp_min/disp_max`, built-in scenes).
    Dataset,
    /// A coarse sweep over a wide range (module docs).
    Automatic,
}

/// The tunable parts of the sweep.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SweepParams {
    pub cost: CostKind,
    /// Largest cost of one view (mean absolute difference of encoded channels in [0, 1]).
    pub truncation: f64,
    pub aggregation: Aggregation,
    /// Window radius r of the aggregation, pixels.
    pub radius: u32,
    /// Regulariser ε of the guided filter (squared encoded intensity).
    pub eps: f64,
    /// Noise floor ε of the confidence ratio.
    pub conf_eps: f64,
    pub refine: Refine,
    /// The continuous fit after the sweep ([`refine`]); off: the sweep's sub-plane winner.
    #[serde(default = "yes")]
    pub fit: bool,
    /// Window radius of the colour-weighted median of the sweep's winners ([`median`]), px;
    /// 0: none.
    #[serde(default)]
    pub median_radius: u32,
    /// Colour σ of the median's weights, 8-bit levels (RGB distance).
    #[serde(default = "median_sigma")]
    pub median_sigma: f64,
    /// Depth edges placed to the pixel after the other steps ([`edges`]).
    #[serde(default = "yes")]
    pub edge_snap: bool,
    /// The global refinement after the fit: the views' evidence against a second-order
    /// smoothness prior ([`smooth`]).
    #[serde(default = "yes")]
    pub smooth: bool,
    /// The dominant planes of the estimate given to their weakly textured pixels after the
    /// refinement ([`plane_fill`]).
    #[serde(default = "yes")]
    pub plane_fill: bool,
}

fn median_sigma() -> f64 {
    16.0
}

fn yes() -> bool {
    true
}

impl Default for SweepParams {
    fn default() -> Self {
        SweepParams {
            cost: CostKind::Robust,
            truncation: 0.12,
            aggregation: Aggregation::Guided,
            radius: 5,
            eps: 1e-4,
            conf_eps: 2e-3,
            refine: Refine::Parabola,
            fit: true,
            median_radius: 14,
            median_sigma: median_sigma(),
            edge_snap: true,
            smooth: true,
            plane_fill: true,
        }
    }
}

impl SweepParams {
    /// The naive baseline tiltfield is measured against: SAD over the views, box aggregation.
    pub fn baseline() -> Self {
        SweepParams {
            cost: CostKind::Mean,
            truncation: 1.0,
            aggregation: Aggregation::Box,
            fit: false,
            median_radius: 0,
            edge_snap: false,
            smooth: false,
            plane_fill: false,
            ..SweepParams::default()
        }
    }

    /// Checks the parameters; the message names the offending one.
    pub fn validate(&self) -> Result<()> {
        if !(self.truncation.is_finite() && self.truncation > 0.0) {
            return Err(Error::Invalid(format!(
                "the cost truncation must be positive, got {}",
                self.truncation
            )));
        }
        if self.radius > MAX_RADIUS {
            return Err(Error::Invalid(format!(
                "the aggregation radius must be at most {MAX_RADIUS} px, got {}",
                self.radius
            )));
        }
        if self.median_radius > MAX_RADIUS {
            return Err(Error::Invalid(format!(
                "the median's radius must be at most {MAX_RADIUS} px, got {}",
                self.median_radius
            )));
        }
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(self.median_sigma) {
            return Err(Error::Invalid(format!(
                "the median's colour σ must be positive, got {}",
                self.median_sigma
            )));
        }
        if !(positive(self.eps) && positive(self.conf_eps)) {
            return Err(Error::Invalid(format!(
                "the guided filter's ε ({}) and the confidence floor ({}) must be positive",
                self.eps, self.conf_eps
            )));
        }
        Ok(())
    }
}

/// Largest aggregation (and median) radius.
pub const MAX_RADIUS: u32 = 64;

/// Automatic plane count: one plane per this many pixels of motion in the farthest view.
pub const AUTO_PLANE_MOTION: f64 = 1.0;
/// Fewest planes of the automatic count.
pub const AUTO_MIN_PLANES: usize = 8;
/// Most planes of the automatic count.
pub const AUTO_MAX_PLANES: usize = 256;

/// The plane count of `options` for `plan`'s views and range.
pub fn plane_count(plan: &SweepPlan, options: &DepthOptions) -> usize {
    options.planes.unwrap_or_else(|| {
        let motion = plan.centre_motion(plan.range.0, plan.range.1);
        ((motion / AUTO_PLANE_MOTION).ceil() as usize).clamp(AUTO_MIN_PLANES, AUTO_MAX_PLANES)
    })
}

/// The nominal rig of a grid folder whose classic disparities span `range` (see
/// [`DepthEstimate::nominal_rig`]); `lo < hi`.
pub fn nominal_rig(focal_px: f64, baseline: f64, (lo, hi): (f64, f64)) -> ParallelRig {
    let at_infinity = hi.max(0.0) + (hi - lo);
    ParallelRig {
        focal_px,
        baseline,
        focus_distance: focal_px * baseline / at_infinity,
    }
}

/// Everything an estimate needs besides the light field.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DepthOptions {
    /// Number of planes (≥ 3); `None`: one per [`AUTO_PLANE_MOTION`] px of motion of the
    /// reference image centre over the range in the farthest matched view, at least
    /// [`AUTO_MIN_PLANES`] and at most [`AUTO_MAX_PLANES`].
    pub planes: Option<usize>,
    /// The swept range, in `range_kind` units (disparity: MIN,MAX px per grid step; depth:
    /// NEAR,FAR world units); `None`: the dataset's, else automatic.
    pub range: Option<(f64, f64)>,
    pub range_kind: DepthKind,
    pub views: ViewSet,
    /// Reference view (s, t); `None`: the middle view (cols/2, rows/2).
    pub reference: Option<(usize, usize)>,
    pub params: SweepParams,
    /// Match (almost) black views too (vignetted corners are left out by default).
    pub include_dark: bool,
}

impl Default for DepthOptions {
    fn default() -> Self {
        DepthOptions {
            planes: None,
            range: None,
            range_kind: DepthKind::Disparity,
            views: ViewSet::Cross(usize::MAX),
            reference: None,
            params: SweepParams::default(),
            include_dark: false,
        }
    }
}

impl DepthOptions {
    /// Checks the options that need no light field.
    pub fn validate(&self) -> Result<()> {
        if let Some(planes) = self.planes {
            if !(sweep::MIN_PLANES..=sweep::MAX_PLANES).contains(&planes) {
                return Err(Error::Invalid(format!(
                    "--planes must be from {} to {}, got {planes} (sub-plane refinement needs a \
                     neighbour on each side of the best plane)",
                    sweep::MIN_PLANES,
                    sweep::MAX_PLANES,
                )));
            }
        }
        self.params.validate()
    }
}

/// The per-pixel result of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepOutput {
    /// Winning plane, refined to a fraction (0 … planes − 1).
    pub index: Vec<f32>,
    /// Confidence in [0, 1] (module docs, step 3).
    pub confidence: Vec<f32>,
    /// Aggregated cost of the winning plane.
    pub best_cost: Vec<f32>,
}

/// Times of an estimate.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct DepthTimings {
    /// GPU time of the sweep (timestamps, all submissions), ms; `None` without timestamps.
    pub gpu_ms: Option<f64>,
    /// Of it, the automatic range's coarse sweep, ms.
    pub coarse_gpu_ms: Option<f64>,
    /// Wall-clock time of the whole estimate, ms.
    pub total_ms: f64,
}

/// A depth estimate of the reference view.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DepthEstimate {
    pub width: u32,
    pub height: u32,
    /// Index of the reference view in `lf.views` and its grid position.
    pub reference: usize,
    pub reference_st: (usize, usize),
    pub convention: Convention,
    /// Swept range of p and where it came from.
    pub range: (f64, f64),
    pub range_origin: RangeOrigin,
    pub planes: usize,
    /// Grid positions of the matched views.
    pub views: Vec<(usize, usize)>,
    pub params: SweepParams,
    /// The sweep parameter p per pixel, row-major (see [`Convention`]).
    #[serde(skip)]
    pub param: Vec<f32>,
    /// Confidence per pixel in [0, 1].
    #[serde(skip)]
    pub confidence: Vec<f32>,
    pub timings: DepthTimings,
    pub device: String,
}

impl DepthEstimate {
    /// The kind of output the light field's convention has natively.
    pub fn natural_kind(&self) -> DepthKind {
        match self.convention {
            Convention::InverseDepth => DepthKind::Depth,
            _ => DepthKind::Disparity,
        }
    }

    /// For grid folders: the nominal parallel rig with sensor shift under which the classic
    /// disparity D is an HCI disparity −D. Its focus distance Z₀ puts infinity one range width
    /// beyond the farthest swept disparity, `f·b/Z₀ = max(D_max, 0) + (D_max − D_min)`, so
    /// every estimate has a depth; the folder carries no calibration, so any Z₀ is as true.
    pub fn nominal_rig(&self) -> Option<ParallelRig> {
        match self.convention {
            Convention::Classic { focal_px, baseline } => {
                Some(nominal_rig(focal_px, baseline, self.range))
            }
            _ => None,
        }
    }

    /// Depth (camera z, world units) of sweep parameter `p`; NaN at or beyond infinity.
    pub fn depth_of(&self, p: f64) -> f64 {
        let z = match self.convention {
            Convention::Hci(rig) => rig.depth_of_disparity(p),
            Convention::Classic { .. } => self
                .nominal_rig()
                .and_then(|rig| rig.depth_of_disparity(-p)),
            Convention::InverseDepth => (p > 0.0).then(|| 1.0 / p),
        };
        z.unwrap_or(f64::NAN)
    }

    /// The estimate as disparity (the convention's) or depth, row-major; NaN where there is
    /// none. Disparity of a calibrated rig without a grid is an error naming why.
    pub fn values(&self, kind: DepthKind) -> Result<Vec<f32>> {
        match (kind, self.convention) {
            (DepthKind::Disparity, Convention::InverseDepth) => Err(Error::Invalid(
                "this light field is a calibrated rig without a regular grid, so it has no \
                 disparity convention: use --kind depth"
                    .into(),
            )),
            (DepthKind::Disparity, _) => Ok(self.param.clone()),
            (DepthKind::Depth, _) => Ok(self
                .param
                .iter()
                .map(|&p| self.depth_of(p as f64) as f32)
                .collect()),
        }
    }

    /// The map installed in a light field without one: HCI disparity on rigs (so the
    /// dataset's range check applies), depth elsewhere. `min_confidence`: pixels below it are
    /// left out (NaN).
    pub fn depth_map(&self, min_confidence: f32) -> DepthMap {
        let (kind, values) = match self.convention {
            Convention::Hci(_) => (DepthKind::Disparity, self.param.clone()),
            _ => (
                DepthKind::Depth,
                self.values(DepthKind::Depth).unwrap_or_default(),
            ),
        };
        let values = values
            .iter()
            .zip(&self.confidence)
            .map(|(&v, &c)| if c >= min_confidence { v } else { f32::NAN })
            .collect();
        DepthMap {
            width: self.width,
            height: self.height,
            kind,
            values,
            source: format!(
                "the estimated depth of view ({}, {}) (pixels of confidence below \
                 {min_confidence}, where the views show too little texture, have no value)",
                self.reference_st.0, self.reference_st.1
            ),
            estimated: true,
        }
    }
}

/// The sweep plan of `options` on `lf`; with no range given or documented its range is the
/// wide range of the automatic search ([`RangeOrigin::Automatic`]).
pub fn plan(lf: &LightField, options: &DepthOptions) -> Result<SweepPlan> {
    options.validate()?;
    if lf.views.len() < 2 {
        return Err(Error::Invalid(format!(
            "depth from a light field needs at least two views; '{}' has {}",
            lf.name,
            lf.views.len()
        )));
    }
    let reference = sweep::reference_view(lf, options.reference)?;
    let excluded = lf.excluded_views(options.include_dark);
    if excluded[reference] {
        return Err(Error::Invalid(format!(
            "the reference view ({}, {}) is (almost) entirely black; pick another with --view",
            lf.views[reference].s, lf.views[reference].t
        )));
    }
    let convention = sweep::convention_of(lf);
    let chosen = sweep::select_views(lf, reference, options.views, &excluded);
    if chosen.is_empty() {
        return Err(Error::Invalid(format!(
            "the view set {} around view ({}, {}) holds no other usable view",
            options.views.name(),
            lf.views[reference].s,
            lf.views[reference].t
        )));
    }
    let dark = excluded.iter().filter(|&&d| d).count();
    if dark > 0 {
        log::warn!("{dark} (almost) black views are not matched (--include-dark matches them)");
    }
    let views = chosen
        .iter()
        .map(|&i| sweep::sweep_view(lf, reference, i, convention))
        .collect();
    let r = &lf.views[reference];
    let mut plan = SweepPlan {
        reference,
        reference_st: (r.s, r.t),
        reference_camera: r.camera,
        width: lf.width,
        height: lf.height,
        views,
        convention,
        range: (0.0, 1.0),
        range_origin: RangeOrigin::Automatic,
        planes: AUTO_MIN_PLANES,
    };
    match (options.range, lf.disparity_range, convention) {
        (Some(given), _, _) => {
            plan.range = sweep::param_range(convention, options.range_kind, given)?;
            plan.range_origin = RangeOrigin::Given;
        }
        (None, Some(range), Convention::Hci(_)) if range.0 < range.1 => {
            plan.range = sweep::param_range_from(
                convention,
                DepthKind::Disparity,
                range,
                "the dataset's [meta] disp_min, disp_max",
            )?;
            plan.range_origin = RangeOrigin::Dataset;
        }
        _ => plan.range = sweep::wide_range(&plan),
    }
    plan.planes = plane_count(&plan, options);
    if plan.range_origin == RangeOrigin::Dataset {
        // A dataset's range is tight (HCI: the extremes of its ground truth), and a winner on
        // the first or last plane cannot be refined: one more plane at each end, same spacing,
        // kept in front of infinity.
        let step = plan.step();
        let lo = plan.range.0 - step;
        let in_front = match convention {
            Convention::Hci(rig) => lo > rig.disparity_at_infinity(),
            _ => true,
        };
        if in_front && plan.planes + 2 <= sweep::MAX_PLANES {
            plan.range = (lo, plan.range.1 + step);
            plan.planes += 2;
        }
    }
    Ok(plan)
}

/// `plan` with the views of `set` (the same reference, range and planes): the views the
/// continuous refinement ([`refine`]) fits on.
pub fn with_views(
    lf: &LightField,
    plan: &SweepPlan,
    set: ViewSet,
    include_dark: bool,
) -> SweepPlan {
    let excluded = lf.excluded_views(include_dark);
    let views = sweep::select_views(lf, plan.reference, set, &excluded)
        .into_iter()
        .map(|i| sweep::sweep_view(lf, plan.reference, i, plan.convention))
        .collect();
    SweepPlan {
        views,
        ..plan.clone()
    }
}

/// The coarse sweep of the automatic range: a quarter of the resolution (less for small
/// views: at least 32 px a side), the wide range, two planes per coarse pixel of motion of the
/// image centre in the farthest view (32 to 256 planes).
pub fn coarse_plan(plan: &SweepPlan) -> (SweepPlan, u32) {
    let side = plan.width.min(plan.height);
    let factor = [4u32, 2, 1]
        .into_iter()
        .find(|f| side / f >= 32)
        .unwrap_or(1);
    let range = plan.range;
    let motion = plan.centre_motion(range.0, range.1) / factor as f64;
    let planes = ((2.0 * motion).ceil() as usize).clamp(32, 256);
    (plan.scaled(factor, planes, range), factor)
}

/// The range of the fine sweep from the coarse one. Every pixel votes for its winning coarse
/// plane with its confidence; planes holding at least [`RANGE_MIN_MASS`] of the votes are
/// surfaces, and the range spans the first to the last of them, widened by 5 % of that span
/// and one coarse plane on each side, inside the wide range. Votes rather than percentiles of
/// the confident pixels: a dark or weakly textured surface is less confident than its
/// neighbours everywhere, and a cut at the median confidence drops it whole (a dark wall
/// behind a bust, the far card of a deep scene), while scattered wrong winners spread their
/// few votes over many planes and stay below the cut.
pub fn range_from_coarse(coarse: &SweepPlan, out: &SweepOutput) -> (f64, f64) {
    let planes = coarse.planes.max(1);
    let mut votes = vec![0.0f64; planes];
    for (&k, &c) in out.index.iter().zip(&out.confidence) {
        if k.is_finite() && c.is_finite() && c > 0.0 {
            votes[(k.round().max(0.0) as usize).min(planes - 1)] += c as f64;
        }
    }
    let total: f64 = votes.iter().sum();
    let kept: Vec<usize> = (0..planes)
        .filter(|&k| total > 0.0 && votes[k] >= RANGE_MIN_MASS * total)
        .collect();
    let (Some(&first), Some(&last)) = (kept.first(), kept.last()) else {
        return coarse.range;
    };
    let (a, b) = (coarse.param(first as f64), coarse.param(last as f64));
    let (lo, hi) = (a.min(b), a.max(b));
    let pad = 0.05 * (hi - lo) + coarse.step();
    (
        (lo - pad).max(coarse.range.0),
        (hi + pad).min(coarse.range.1),
    )
}

/// Share of the confidence votes a coarse plane needs to count as a surface
/// ([`range_from_coarse`]).
pub const RANGE_MIN_MASS: f64 = 0.01;

/// `img` downscaled by `factor` (box average of the encoded values, rounded); the last
/// partial rows and columns are dropped, matching [`SweepPlan::scaled`].
pub fn downscale(img: &RgbaImage, factor: u32) -> RgbaImage {
    if factor <= 1 {
        return img.clone();
    }
    let (w, h) = (
        (img.width() / factor).max(1),
        (img.height() / factor).max(1),
    );
    let n = factor * factor;
    RgbaImage::from_fn(w, h, |x, y| {
        let mut sum = [0u32; 4];
        for j in 0..factor {
            for i in 0..factor {
                let sx = (x * factor + i).min(img.width() - 1);
                let sy = (y * factor + j).min(img.height() - 1);
                let p = img.get_pixel(sx, sy).0;
                for c in 0..4 {
                    sum[c] += p[c] as u32;
                }
            }
        }
        image::Rgba(sum.map(|s| ((s + n / 2) / n) as u8))
    })
}

/// What the refinement steps' tests start from: the depth set's tilted plane (3 × 3 views of
/// 64²), all views matched over 9 planes of [−1, 1], and its exact disparity.
#[cfg(test)]
pub(crate) mod fixtures {
    use super::*;

    pub(crate) struct Tilted {
        pub lf: LightField,
        pub plan: SweepPlan,
        pub exact: Vec<f32>,
    }

    impl Tilted {
        pub(crate) fn new() -> Tilted {
            let lf = crate::bench::depth_scenes::DepthScene::Tilted.light_field(3, 64);
            let options = DepthOptions {
                views: ViewSet::All,
                range: Some((-1.0, 1.0)),
                planes: Some(9),
                ..Default::default()
            };
            let plan = plan(&lf, &options).unwrap();
            let exact = crate::bench::depth_scenes::truth(&lf, DepthKind::Disparity);
            Tilted { lf, plan, exact }
        }

        /// The reference, then the plan's views.
        pub(crate) fn images(&self) -> Vec<&RgbaImage> {
            reference_and_views(&self.lf, &self.plan)
        }
    }

    /// A scene of the depth set (5 × 5 views of 64²) with every view matched at the default
    /// range and planes, and its exact disparity (`scene.truth`).
    pub(crate) struct SetScene {
        pub scene: crate::bench::depth_set::SetScene,
        pub plan: SweepPlan,
    }

    impl SetScene {
        pub(crate) fn new(name: &str) -> SetScene {
            let scene = crate::bench::depth_set::synthetic(5, 64, Some(&[name.to_string()]))
                .unwrap()
                .remove(0);
            let options = DepthOptions {
                views: ViewSet::All,
                ..DepthOptions::default()
            };
            let plan = plan(&scene.light_field, &options).unwrap();
            SetScene { scene, plan }
        }

        /// The reference, then the plan's views.
        pub(crate) fn images(&self) -> Vec<&RgbaImage> {
            reference_and_views(&self.scene.light_field, &self.plan)
        }
    }

    fn reference_and_views<'a>(lf: &'a LightField, plan: &SweepPlan) -> Vec<&'a RgbaImage> {
        std::iter::once(plan.reference)
            .chain(plan.views.iter().map(|v| v.index))
            .map(|i| &lf.views[i].image)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_light_field_of_one_view_is_refused() {
        let mut lf = crate::synth::builtin("planes").unwrap().light_field(1);
        let centre = lf.views[lf.grid.index(2, 2)].clone();
        lf.views = vec![crate::lightfield::View {
            s: 0,
            t: 0,
            ..centre
        }];
        lf.grid = crate::lightfield::GridSize { cols: 1, rows: 1 };
        lf.depth.clear();
        let e = plan(&lf, &DepthOptions::default()).unwrap_err().to_string();
        assert!(
            e.contains("at least two views") && e.contains("has 1"),
            "{e}"
        );
    }

    #[test]
    fn view_sets_parse_and_name_round_trip() {
        for s in ["all", "cross", "cross:2", "square:1"] {
            assert_eq!(s.parse::<ViewSet>().unwrap().name(), s);
        }
        for bad in ["cross:0", "square", "ring:2", "cross:x"] {
            let e = bad.parse::<ViewSet>().unwrap_err().to_string();
            assert!(e.contains(bad), "{e}");
        }
        assert!("box".parse::<Aggregation>().is_ok());
        let e = "median".parse::<Aggregation>().unwrap_err().to_string();
        assert!(e.contains("median") && e.contains("guided"), "{e}");
    }

    #[test]
    fn options_refuse_too_few_or_too_many_planes_and_bad_parameters() {
        for planes in [0, 1, 2, 5000] {
            let o = DepthOptions {
                planes: Some(planes),
                ..Default::default()
            };
            let e = o.validate().unwrap_err().to_string();
            assert!(e.contains("--planes"), "{e}");
        }
        let o = DepthOptions {
            params: SweepParams {
                truncation: -1.0,
                ..Default::default()
            },
            ..Default::default()
        };
        assert!(o.validate().unwrap_err().to_string().contains("truncation"));
    }

    #[test]
    fn the_nominal_rig_puts_every_swept_classic_disparity_in_front() {
        let est = DepthEstimate {
            width: 1,
            height: 1,
            reference: 0,
            reference_st: (0, 0),
            convention: Convention::Classic {
                focal_px: 100.0,
                baseline: 0.5,
            },
            range: (-2.0, 1.0),
            range_origin: RangeOrigin::Given,
            planes: 3,
            views: vec![],
            params: SweepParams::default(),
            param: vec![-2.0, 1.0],
            confidence: vec![1.0, 1.0],
            timings: DepthTimings::default(),
            device: String::new(),
        };
        let rig = est.nominal_rig().unwrap();
        // Infinity at D = 1 + 3 = 4: f·b/Z₀ = 4.
        assert!((rig.focal_px * rig.baseline / rig.focus_distance - 4.0).abs() < 1e-12);
        let z = est.values(DepthKind::Depth).unwrap();
        assert!(z.iter().all(|z| z.is_finite() && *z > 0.0));
        // Larger classic disparity is farther (camera s to the right of the reference).
        assert!(z[1] > z[0]);
        // Depth 1/((4 − D)/(f b)) exactly.
        assert!((z[0] as f64 - 50.0 / 6.0).abs() < 1e-4, "{}", z[0]);
    }

    #[test]
    fn downscaling_averages_blocks() {
        let img = RgbaImage::from_fn(4, 2, |x, _| image::Rgba([x as u8 * 10, 0, 255, 255]));
        let s = downscale(&img, 2);
        assert_eq!(s.dimensions(), (2, 1));
        assert_eq!(s.get_pixel(0, 0).0, [5, 0, 255, 255]);
        assert_eq!(s.get_pixel(1, 0).0, [25, 0, 255, 255]);
    }
}
