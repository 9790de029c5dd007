//! Anti-aliased refocus (docs/conventions.md §11): each view stands for a cell of the
//! synthetic aperture, and instead of sampling the view once at its homography the pass
//! integrates it over the footprint that cell sweeps for the scene point seen at the pixel.
//!
//! For output pixel x with focus-surface inverse depth `s = max(m·x, 0)` and scene inverse depth
//! `σ(x)` (from the reference view's depth map, [`SceneDepth`]), a pinhole at grid offset
//! `(Δs, Δt)` from view i sees, in view i's homogeneous image coordinates,
//!
//! ```text
//!     y(Δs, Δt) = A_i x + b_i s + (Δs e_s,i + Δt e_t,i) (s − σ)
//!     e_s,i = −K_i R_i ∂C/∂s,   e_t,i = −K_i R_i ∂C/∂t
//! ```
//!
//! (∂C/∂s: how the camera centre moves per grid step, from the grid neighbours; exact for a
//! parallel rig, a first-order model for a calibrated rotated rig, whose footprint is then a
//! parallelogram that is not axis-aligned). The cell is the unit square around the view
//! clipped to the aperture ([`Footprint`]); the pass averages `n_s × n_t` stratified
//! sub-samples of it, with n per axis the footprint's length in pixels rounded up and capped at
//! [`AntialiasSettings::max_samples`].
//!
//! Views weigh by the area of their cell inside the aperture (a partial rim view by the part
//! inside), so an aperture of radius R integrates exactly the disk of radius R.
//!
//! Occlusion, per sub-sample ([`sub_sample_residual`]): each sub-sample's aperture point has
//! its own ray through the focus surface; next to a nearer surface it takes that surface's
//! residual where the ray meets it, so the occluder's copies blur while a focused background
//! stays sharp; and a sub-sample whose view sees a nearer surface where the ray's point should
//! be (from each view's visibility map, [`ViewVisibility`]: the depth forward-warped into the
//! view) is dropped, so a focused edge is not smeared into the blur behind it.
//!
//! Pixels without a valid scene depth (NaN, ≤ 0, unreachable by the reprojection) get no
//! footprint: they are the plain sum there, with the area weights.

use glam::{DMat3, DVec2, DVec3};

use super::plan::{PlannedView, RefocusPlan};
use crate::error::{Error, Result};
use crate::geometry::aperture::{Aperture, ApertureShape};
use crate::geometry::camera::Camera;
use crate::geometry::depth::ViewDepth;
use crate::geometry::homography::ViewWarp;
use crate::lightfield::LightField;

/// Largest `max_samples` (per axis): 16² fetches per view is already far beyond what an
/// interactive frame can afford.
pub const MAX_SAMPLES_LIMIT: u32 = 16;

/// Most views an anti-aliased aperture may hold: the pass reads the footprints from a
/// uniform buffer of this many records (`refocus::settings::UBO_WARPS`).
pub const MAX_VIEWS: usize = 256;

/// Sub-samples of the aperture cells per grid step of the area weights' quadrature.
const AREA_GRID: usize = 64;

/// How the footprint is sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct AntialiasSettings {
    /// Most sub-samples per axis of a view's cell (1: area weights only, no footprint).
    pub max_samples: u32,
    /// Sub-samples farther apart than √3 pixels read the views' box-filtered pyramid at the
    /// level of their spacing (`refocus::prefilter`), so each stands for its share of the
    /// footprint; off: every sub-sample is one bilinear fetch at full resolution.
    pub prefilter: bool,
    /// A pixel whose views agree at the focus surface ([`focus_spread`] at most
    /// [`FOCUS_TEST_LEVELS`]) is in focus whatever the depth map says: the plain sum with the
    /// cells' weights, no footprint. Off: the depth map alone decides.
    pub focus_test: bool,
    /// In a pixel whose own surface is in focus ([`AntialiasPlan::focused_reach`]) the
    /// sub-samples whose footprint is under half a pixel take the view's Catmull-Rom value at
    /// their cell's centre instead of their bilinear fetch (with the bilinear filters only:
    /// `hardware`, `shader`), so that a focus plane that cuts the views between their pixels
    /// (a tilted plane) stays as sharp as the views. Off: every sub-sample is bilinear.
    pub focused_bicubic: bool,
    /// Each sub-sample follows its own ray past a nearer surface around the pixel and is
    /// tested against its view's visibility map ([`sub_sample_residual`]). Off: no front is
    /// searched and no map is built, so every sub-sample takes the pixel's own residual, as on
    /// a scene without occluders: cheaper, and wrong at occlusion edges (a nearer surface's
    /// blur does not spread over the focused background, a focused edge gathers the blur).
    pub occlusion: bool,
    /// Defocused views ([`super::defocus`]): every view box-filtered once over the footprints
    /// of its own pixels (a summed-area table: constant cost whatever the footprint's length),
    /// then one fetch per view at the cell's centroid. `max_samples`, `prefilter` and
    /// `occlusion` then do not apply: each cell takes the depth its view sees at its sample.
    /// Off: sub-samples of every footprint at every output pixel.
    pub defocus: bool,
    /// Layered footprints ([`super::layered`]): each view's plain sample binned by the depth
    /// its view sees into layers by residual, each layer box-filtered once by its footprint
    /// (constant cost whatever the blur), the layers composited front to back (occlusion
    /// without a test per sample). Where they are used, `max_samples`, `prefilter` and
    /// `occlusion` do not apply; the focus test and Catmull-Rom in focus do. A plan holds
    /// [`Layered::On`] or [`Layered::Off`] only: planning decides [`Layered::Auto`].
    pub layered: Layered,
    /// Boxed footprints ([`super::boxed`]; with neither `defocus` nor `layered`, at the views'
    /// size): a pixel away from occlusion edges whose own surface is out of focus is the box of
    /// the plain sums of its views by cell shape over its footprint (summed-area tables:
    /// constant cost whatever the blur); only pixels next to a nearer surface the rays can
    /// reach and focused pixels take the sub-samples. Off: sub-samples at every pixel.
    pub boxed: bool,
}

impl Default for AntialiasSettings {
    fn default() -> Self {
        AntialiasSettings {
            max_samples: 4,
            prefilter: true,
            focus_test: true,
            focused_bicubic: true,
            occlusion: true,
            defocus: false,
            layered: Layered::Auto,
            boxed: true,
        }
    }
}

/// When anti-aliasing takes layered footprints ([`AntialiasSettings::layered`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Layered {
    /// Never: boxed footprints and sub-samples.
    Off,
    /// The default: where they are exact and cheapest, which is one focus plane at the views'
    /// size with a depth handed over with the light field (not an estimate: its silhouettes
    /// are not where the map puts them, and the views' maps would carry its errors into the
    /// focused pixels), without defocused views, within the layer and depth-map budgets.
    /// Elsewhere [`Layered::Off`]. On `antialias-set` at 128 px they score what the
    /// sub-samples score (39.5 / 40.8 / 44.1 dB against 39.4 / 40.7 / 44.1) at about 0.6×
    /// their time, on a 9×9 light field about 0.27× (docs/antialias.md).
    Auto,
    /// Always; what they cannot do (a focus surface, an output of another size, an estimate's
    /// budget) is refused, naming the cause.
    On,
}

impl Layered {
    /// Whether a plan's setting takes layered footprints (planning made `Auto` `On` or `Off`).
    pub fn on(self) -> bool {
        self == Layered::On
    }
}

/// The focus test's threshold in 8-bit levels: the views' plain samples at the focus surface
/// agree when their weighted standard deviation, in square-root units (which follow the sRGB
/// curve's levels closely, dark and bright alike), is at most this many levels in every
/// channel. Measured over the anti-aliasing test set (README): 2 levels take every focused
/// textureless stripe an estimate got wrong back to its sharp plain sum while leaving every
/// out-of-focus score unchanged.
pub const FOCUS_TEST_LEVELS: f64 = 2.0;

impl AntialiasSettings {
    /// The cheapest footprint integral: one prefiltered fetch per cell at its footprint's
    /// level, and none of the refinements (no focus test, no Catmull-Rom in focus, no
    /// occlusion tests). The lattice is gone, but occlusion edges and a wrong depth go
    /// uncorrected (README, "Anti-aliased refocus": its cost and scores against the default).
    pub const FASTEST: AntialiasSettings = AntialiasSettings {
        max_samples: 1,
        prefilter: true,
        focus_test: false,
        focused_bicubic: false,
        occlusion: false,
        defocus: false,
        layered: Layered::Off,
        boxed: false,
    };

    /// The settings for an output that is (`one_plane_at_views_size`) or is not one focus
    /// plane at the views' size: layered footprints integrate at the views' pixels and on a
    /// plane's residuals, so [`Layered::Auto`] is [`Layered::Off`] for a focus surface or a
    /// scaled output (boxed footprints and sub-samples take it); what was asked stays.
    pub fn for_output(self, one_plane_at_views_size: bool) -> Self {
        match self.layered {
            Layered::Auto if !one_plane_at_views_size => AntialiasSettings {
                layered: Layered::Off,
                ..self
            },
            _ => self,
        }
    }

    /// Whether every view's own depth map is needed (defocused views or layered footprints):
    /// those routes take the depth each view sees and test no sample for occlusion.
    pub fn per_view_maps(&self) -> bool {
        self.defocus || self.layered.on()
    }

    /// Whether boxed footprints are asked for and no other route takes their place (they
    /// still apply only where [`super::boxed::can_box`] says).
    pub fn boxes(&self) -> bool {
        self.boxed && !self.per_view_maps()
    }

    /// Whether the sub-samples' occlusion tests run (asked for, and sub-samples taken).
    pub fn occlusion_tests(&self) -> bool {
        self.occlusion && !self.per_view_maps()
    }

    /// Checks the settings of a request (the sample cap; the switches take any value).
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_SAMPLES_LIMIT).contains(&self.max_samples) {
            return Err(Error::Invalid(format!(
                "anti-aliasing samples per axis must be 1 to {MAX_SAMPLES_LIMIT}, got {}",
                self.max_samples
            )));
        }
        if self.layered == Layered::On && self.defocus {
            return Err(Error::Invalid(
                "--antialias-layered and --antialias-defocus are two ways to integrate the \
                 footprints: turn one of them off"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// Whether to anti-alias: `requested` (`--antialias on|off`) or, when not given, on exactly
/// when the light field ships a depth map, so a plain render never starts a depth estimate.
pub fn wanted(requested: Option<bool>, lf: &LightField) -> bool {
    requested.unwrap_or(!lf.depth.is_empty())
}

/// One view's aperture cell as homogeneous image offsets per unit of residual inverse depth
/// `s − σ`: the cell's sub-sample at `(u, v) ∈ [0, 1]²` lies at
/// `origin + u·span_s + v·span_t` (times `s − σ`) from the view's plain sample `A_i x + b_i s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    pub origin: DVec3,
    pub span_s: DVec3,
    pub span_t: DVec3,
    /// `K_r R_r (C_r − C_i)`: where the reference sees a point that view i sees at its plain
    /// sample, per unit of inverse depth off the focus surface (the occlusion test of
    /// [`sub_sample_residual`]).
    pub parallax: DVec3,
    /// Which of [`ViewVisibility`]'s maps is this view's (its place in the plan as made; a
    /// reordering of the views, as the viewer's refinement does, keeps it).
    pub map: usize,
}

impl Footprint {
    /// The homogeneous offset of cell coordinate (u, v) for residual `d = s − σ`.
    pub fn offset(&self, u: f64, v: f64, d: f64) -> DVec3 {
        (self.origin + u * self.span_s + v * self.span_t) * d
    }

    /// Whether the cell's centroid is the view itself (a full cell: its sample at the centroid
    /// is the view's plain sample), to rounding: the f32 copies the GPU reads leave most full
    /// cells' centroids a rounding error off zero (8 of 13 on a disk of radius 2).
    pub fn is_centred(&self) -> bool {
        let scale = self.origin.length() + self.span_s.length() + self.span_t.length();
        self.offset(0.5, 0.5, 1.0).length() <= 1e-9 * scale
    }
}

/// The scene's inverse depth along each reference pixel's ray, `σ = 1/z` in the reference
/// camera's frame (the same parameter as the plane term's `m·x`), at the views' size. Unknown
/// pixels hold −1.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneDepth {
    pub width: u32,
    pub height: u32,
    pub inverse_depth: Vec<f32>,
    /// The nearest surface (largest σ) within [`SceneDepth::front_radius`] pixels, −1 where
    /// none: the occluder whose blur may reach the pixel.
    pub front: Vec<f32>,
    pub front_radius: u32,
    /// The nearest surface within 1, 2, 4, … 64 px ([`super::boxed::front_levels`]), where
    /// the front was searched: which pixels need the occlusion tests
    /// ([`super::boxed::needs_tests`]). Empty otherwise.
    pub fronts: Vec<f32>,
    /// Pixels without a valid depth (no footprint there).
    pub unknown: usize,
    /// Where the depth came from, for reports.
    pub source: String,
}

impl SceneDepth {
    /// σ at output pixel position `x` (reference pixel coordinates): the nearest texel,
    /// never interpolated across a depth edge; `None` where unknown.
    pub fn at(&self, x: DVec2) -> Option<f64> {
        let v = self.inverse_depth[self.index(x)];
        (v >= 0.0).then_some(v as f64)
    }

    /// The nearest surface's σ around `x` ([`SceneDepth::front`]).
    pub fn front_at(&self, x: DVec2) -> Option<f64> {
        let v = self.front[self.index(x)];
        (v >= 0.0).then_some(v as f64)
    }

    fn index(&self, x: DVec2) -> usize {
        let i = ((x.x + 0.5).floor() as i64).clamp(0, self.width as i64 - 1) as usize;
        let j = ((x.y + 0.5).floor() as i64).clamp(0, self.height as i64 - 1) as usize;
        j * self.width as usize + i
    }

    /// σ and the front σ interleaved per pixel, as the pass's storage buffer holds them.
    pub fn interleaved(&self) -> Vec<f32> {
        self.inverse_depth
            .iter()
            .zip(&self.front)
            .flat_map(|(a, b)| [*a, *b])
            .collect()
    }
}

/// The scene inverse depth seen from `reference` at the views' size `(width, height)`.
///
/// When `reference` is the camera that owns `depth`, it is `1/z` per pixel. Otherwise (a
/// virtual or other reference view) every valid depth pixel is reprojected into the reference
/// and the nearest surface kept per pixel (a z-buffer); one-pixel cracks of the splat are filled
/// from the farthest valid neighbour (disocclusions show background), and what remains is
/// unknown.
pub fn scene_depth(
    depth: &ViewDepth,
    reference: &Camera,
    (width, height): (u32, u32),
) -> Result<SceneDepth> {
    if (depth.width, depth.height) != (width, height) {
        return Err(Error::Invalid(format!(
            "the depth map {} is {}×{} but the views are {width}×{height}; anti-aliasing needs \
             the depth of every reference pixel",
            depth.source, depth.width, depth.height
        )));
    }
    let (w, h) = (width as usize, height as usize);
    let same = (depth.camera.centre() - reference.centre()).length()
        <= 1e-9 * (1.0 + reference.centre().length())
        && (depth.camera.k - reference.k).abs_diff_eq(DMat3::ZERO, 1e-9)
        && (depth.camera.r - reference.r).abs_diff_eq(DMat3::ZERO, 1e-12);
    let mut sigma = vec![-1f32; w * h];
    if same {
        for y in 0..h {
            for x in 0..w {
                if let Some(z) = depth.depth(x as u32, y as u32) {
                    if z.is_finite() && z > 0.0 {
                        sigma[y * w + x] = (1.0 / z) as f32;
                    }
                }
            }
        }
    } else {
        let mut zbuf = vec![f64::INFINITY; w * h];
        for y in 0..h {
            for x in 0..w {
                let Some(p) = depth.point(x as u32, y as u32) else {
                    continue;
                };
                let pc = reference.to_camera(p);
                if !(pc.z > 0.0 && pc.is_finite()) {
                    continue;
                }
                let q = reference.k * (pc / pc.z);
                let (i, j) = ((q.x + 0.5).floor(), (q.y + 0.5).floor());
                if i < 0.0 || j < 0.0 || i >= w as f64 || j >= h as f64 {
                    continue;
                }
                let k = j as usize * w + i as usize;
                zbuf[k] = zbuf[k].min(pc.z);
            }
        }
        for k in 0..w * h {
            if zbuf[k].is_finite() {
                sigma[k] = (1.0 / zbuf[k]) as f32;
            }
        }
        fill_cracks(&mut sigma, w, h);
    }
    let unknown = sigma.iter().filter(|&&v| v < 0.0).count();
    Ok(SceneDepth {
        width,
        height,
        front: sigma.clone(),
        front_radius: 0,
        fronts: Vec::new(),
        inverse_depth: sigma,
        unknown,
        source: depth.source.clone(),
    })
}

/// Fills one-pixel cracks of a splatted σ map (−1 = empty) from the farthest valid 4-neighbour:
/// a crack between splats of one surface takes that surface, and at a disocclusion the
/// background shows.
fn fill_cracks(sigma: &mut [f32], w: usize, h: usize) {
    let holes: Vec<usize> = (0..w * h).filter(|&k| sigma[k] < 0.0).collect();
    fill_ring(sigma, (w, h), &holes);
}

/// One ring of hole filling: each of `holes` (−1 in `sigma`, `w × h`) with a valid 4-neighbour
/// takes the farthest of them (read before any is filled); returns the holes left.
pub(super) fn fill_ring(sigma: &mut [f32], (w, h): (usize, usize), holes: &[usize]) -> Vec<usize> {
    let source = sigma.to_vec();
    let mut left = Vec::new();
    for &k in holes {
        let mut far: Option<f32> = None;
        for (nx, ny) in neighbours4(k % w, k / w, w, h) {
            let v = source[ny * w + nx];
            if v >= 0.0 {
                far = Some(far.map_or(v, |f| f.min(v)));
            }
        }
        match far {
            Some(v) => sigma[k] = v,
            None => left.push(k),
        }
    }
    left
}

/// Most bytes the views' visibility maps may take (a 16-bit float per pixel per view in the
/// aperture); beyond it anti-aliasing goes without the visibility test (81 views of 512²
/// take 42 MB).
pub const MAX_VISIBILITY_BYTES: usize = 256 << 20;

/// What each view of the aperture sees: the reference's σ forward-warped into every planned
/// view (each reference pixel splatted at `A_i x + b_i σ`, its own depth's warp, to the
/// nearest pixel; a z-buffer keeps the nearest surface; one-pixel cracks filled as in
/// [`scene_depth`]; −1 where no surface lands). The sub-samples' visibility test reads it
/// ([`sub_sample_residual`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ViewVisibility {
    pub width: u32,
    pub height: u32,
    /// σ per pixel, view after view in the order of the plan's views.
    pub sigma: Vec<f32>,
    /// Which computation of the maps this is (unique per process), so a pass can tell an
    /// unchanged upload without comparing or hashing them; a plan that reuses the maps
    /// ([`plan_antialias_reusing`]) shares them and their id.
    pub id: u64,
    /// [`ViewVisibility::hash_of`] the depth the maps were warped from: a later plan on the
    /// same depth and views reuses them.
    pub depth_hash: u64,
}

/// The next [`ViewVisibility::id`].
static NEXT_VISIBILITY_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

impl ViewVisibility {
    /// Warps `depth` into each of `views` (their warps from the reference).
    pub fn new(depth: &SceneDepth, views: &[PlannedView]) -> Self {
        use rayon::prelude::*;
        let (w, h) = (depth.width as usize, depth.height as usize);
        // One buffer, each view's map written in place (no per-view maps to concatenate).
        let mut sigma = vec![-1f32; views.len() * w * h];
        sigma
            .par_chunks_mut((w * h).max(1))
            .zip(views)
            .for_each(|(map, v)| {
                for y in 0..h {
                    for x in 0..w {
                        let sigma = depth.inverse_depth[y * w + x];
                        if sigma < 0.0 {
                            continue;
                        }
                        let q = v.warp.a * DVec3::new(x as f64, y as f64, 1.0)
                            + v.warp.b * sigma as f64;
                        if q.z.is_nan() || q.z <= 0.0 {
                            continue;
                        }
                        let (i, j) = ((q.x / q.z + 0.5).floor(), (q.y / q.z + 0.5).floor());
                        if i < 0.0 || j < 0.0 || i >= w as f64 || j >= h as f64 {
                            continue;
                        }
                        let k = j as usize * w + i as usize;
                        map[k] = map[k].max(sigma);
                    }
                }
                fill_cracks(map, w, h);
                round_to_half(map);
            });
        ViewVisibility {
            width: depth.width,
            height: depth.height,
            sigma,
            id: NEXT_VISIBILITY_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            depth_hash: Self::hash_of(depth),
        }
    }

    /// A hash of `depth`'s size and σ (xxh3): which depth maps were warped from.
    pub fn hash_of(depth: &SceneDepth) -> u64 {
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        h.update(&depth.width.to_le_bytes());
        h.update(&depth.height.to_le_bytes());
        let bytes: Vec<u8> = depth
            .inverse_depth
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        h.update(&bytes);
        h.digest()
    }

    /// [`ViewVisibility::new`] with every hole filled ([`super::defocus::fill_holes`]): the
    /// depth each view sees at every pixel, which sizes its defocus box. A hole is where
    /// nothing of the reference landed (a disocclusion), so it takes the farthest surface
    /// around it.
    pub fn filled(depth: &SceneDepth, views: &[PlannedView]) -> Self {
        use rayon::prelude::*;
        let mut v = Self::new(depth, views);
        let (w, h) = (v.width as usize, v.height as usize);
        v.sigma.par_chunks_mut((w * h).max(1)).for_each(|map| {
            super::defocus::fill_holes(map, (w, h));
            round_to_half(map);
        });
        v
    }

    /// The maps as the GPU reads them: 16-bit floats (each σ already one, [`round_to_half`]),
    /// two to a 32-bit word, the even entry in the low half (GLSL's `unpackHalf2x16`).
    pub fn half_words(&self) -> Vec<u32> {
        let bits = |v: f32| u32::from(half::f16::from_f32(v).to_bits());
        self.sigma
            .chunks(2)
            .map(|p| bits(p[0]) | p.get(1).map_or(0, |&v| bits(v) << 16))
            .collect()
    }

    /// σ that planned view `k` sees at image position `p` (nearest pixel, as the shader's
    /// `depth_index`); `None` outside the image or where nothing landed.
    pub fn at(&self, k: usize, p: DVec2) -> Option<f64> {
        let (w, h) = (self.width as i64, self.height as i64);
        let (i, j) = ((p.x + 0.5).floor(), (p.y + 0.5).floor());
        if !(i >= 0.0 && j >= 0.0 && i < w as f64 && j < h as f64) {
            return None;
        }
        let v = self.sigma[k * (w * h) as usize + j as usize * w as usize + i as usize];
        (v >= 0.0).then_some(v as f64)
    }
}

/// Rounds every σ of `map` to the nearest 16-bit float, what the GPU stores (so the f64
/// models read the values the shaders do). σ moves by 2⁻¹¹ of itself at most, so a residual's
/// footprint by 2⁻¹¹ of σ's own (against infinity): hundredths of a pixel on the test set and
/// backgammon, where the layers' nodes are 1 px apart.
fn round_to_half(map: &mut [f32]) {
    for v in map.iter_mut() {
        *v = half::f16::from_f32(*v).to_f32();
    }
}

/// Records rounding ties of the sub-sample decisions (`eps` > 0), where f32 may decide the
/// other way ([`super::cpu::ambiguous_antialiased`]).
#[derive(Debug, Clone, Copy)]
pub struct Ties {
    pub eps: f64,
    pub found: bool,
}

impl Ties {
    /// No tie detection.
    pub fn none() -> Ties {
        Ties {
            eps: -1.0,
            found: false,
        }
    }

    fn position(&mut self, p: DVec2) {
        let tie = |v: f64| ((v + 0.5) - (v + 0.5).round()).abs() <= self.eps;
        if tie(p.x) || tie(p.y) {
            self.found = true;
        }
    }

    fn compare(&mut self, a: f64, b: f64) {
        if (a - b).abs() <= self.eps * a.abs().max(b.abs()).max(1.0) {
            self.found = true;
        }
    }
}

/// The residual `s − σ_hit` that sub-sample `(u, v)` of planned view `k`'s cell takes at
/// output pixel `x` (plain sample `y0`, focus-surface inverse depth `s`), or `None` when view
/// k cannot see what that sub-aperture ray hits (the sub-sample is dropped). §11:
///
/// 1. The ray from the sub-sample's aperture point through the focus surface at x meets a
///    surface of inverse depth c where the reference sees c at that point,
///    `x + (g_i + offset(u, v))·(s − c)` (`g_i` the view's parallax). It hits the nearer
///    surface around x ([`SceneDepth::front`]) if the reference sees it there, else the pixel's
///    own surface σ(x).
/// 2. View k samples the hit at `y0 + offset(u, v)·(s − c)`. If view k sees a nearer surface
///    σ_v there ([`ViewVisibility`]), the sub-sample would read that surface's colour: if the
///    ray hits σ_v too (step 1's test), it takes σ_v's residual; else the view cannot see the
///    ray's point and the sub-sample is dropped, so a focused edge is not smeared into the
///    blur behind it. On an estimated depth a sub-sample within
///    [`AntialiasPlan::guard_px`] of the plain sample is not tested: it reads what the view's
///    own ray sees (the estimate's noise would drop in-focus views).
///
/// The tolerance is half a pixel of residual disparity per grid step, at most 5 % of c.
/// Without depth at x: 0 (the plain sample); without a nearer surface around x
/// ([`SceneDepth::front`]) nothing can occlude, and every sub-sample takes σ(x).
#[allow(clippy::too_many_arguments)]
pub fn sub_sample_residual(
    aa: &AntialiasPlan,
    k: usize,
    x: DVec2,
    y0: DVec3,
    s: f64,
    (u, v): (f64, f64),
    ties: &mut Ties,
) -> Option<f64> {
    let depth = &aa.depth;
    let fp = &aa.footprints[k];
    let Some(sigma) = depth.at(x) else {
        return Some(0.0);
    };
    let reach = 0.5 / fp.parallax.truncate().length().max(1e-9);
    let tol = |c: f64| reach.min(0.05 * c);
    let ray = fp.parallax + fp.offset(u, v, 1.0);
    let hits = |c: f64, ties: &mut Ties| {
        let q = x.extend(1.0) + ray * (s - c);
        if q.z <= 0.0 {
            return false;
        }
        let p = DVec2::new(q.x / q.z, q.y / q.z);
        ties.position(p);
        depth.at(p).is_some_and(|r| {
            ties.compare((r - c).abs(), tol(c));
            (r - c).abs() <= tol(c)
        })
    };
    // Without a nearer surface around, nothing can occlude the ray or the view.
    let Some(front) = depth.front_at(x).filter(|&f| f > sigma + 1e-6) else {
        return Some(s - sigma);
    };
    let mut c = sigma;
    if hits(front, ties) {
        c = front;
    }
    if let Some(vis) = &aa.visibility {
        let q = y0 + fp.offset(u, v, s - c);
        // Within the guard of the plain sample the sub-sample reads what the view's own ray
        // sees: no test (noise in an estimated depth would otherwise drop in-focus views).
        let moved = (q.truncate() / q.z - y0.truncate() / y0.z).length();
        let tested = aa.guard_px <= 0.0 || {
            ties.compare(moved, aa.guard_px);
            moved >= aa.guard_px
        };
        if q.z > 0.0 && y0.z > 0.0 && tested {
            let p = DVec2::new(q.x / q.z, q.y / q.z);
            ties.position(p);
            if let Some(seen) = vis.at(fp.map, p) {
                ties.compare(seen, c + tol(c));
                if seen > c + tol(c) {
                    if !hits(seen, ties) {
                        return None;
                    }
                    c = seen;
                }
            }
        }
    }
    Some(s - c)
}

/// The largest residual any sub-sample of a cell at `x` takes by step 1 of
/// [`sub_sample_residual`] (the pixel's own or the nearer surface's around it): the count of
/// sub-samples follows it, so a cell that an occluder's edge crosses is sampled finely enough
/// to split. 0 without depth.
pub fn cell_reach(depth: &SceneDepth, x: DVec2, s: f64) -> f64 {
    let Some(sigma) = depth.at(x) else {
        return 0.0;
    };
    let own = (s - sigma).abs();
    match depth.front_at(x) {
        Some(front) if front > sigma + 1e-6 => own.max((s - front).abs()),
        _ => own,
    }
}

/// Most pixels the front search reaches (the window is (2r + 1)² px).
const MAX_FRONT_RADIUS: u32 = 64;

/// The largest σ within `r` pixels (a square window; −1 where none is valid), separable.
fn max_filter(v: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let mut rows = vec![-1f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (x.saturating_sub(r), (x + r).min(w - 1));
            rows[y * w + x] = v[y * w + a..=y * w + b]
                .iter()
                .fold(-1f32, |m, &s| m.max(s));
        }
    }
    let mut out = vec![-1f32; w * h];
    for y in 0..h {
        let (a, b) = (y.saturating_sub(r), (y + r).min(h - 1));
        for x in 0..w {
            out[y * w + x] = (a..=b).fold(-1f32, |m, j| m.max(rows[j * w + x]));
        }
    }
    out
}

/// A refocus plan whose views are the aperture cells: every view whose cell overlaps the
/// aperture, weighted by the overlap's area, with its footprint; and the scene depth.
#[derive(Debug, Clone, PartialEq)]
pub struct AntialiasPlan {
    /// The plan the pass uploads (views and weights by cell; the same plane term).
    pub plan: RefocusPlan,
    /// Parallel to `plan.views`.
    pub footprints: Vec<Footprint>,
    pub depth: SceneDepth,
    /// What each view sees (the sub-samples' visibility test); `None` past
    /// [`MAX_VISIBILITY_BYTES`].
    pub visibility: Option<std::sync::Arc<ViewVisibility>>,
    /// Sub-samples within this many pixels of their view's plain sample skip the visibility
    /// test: 0 on a depth map handed over with the light field, [`ESTIMATED_DEPTH_GUARD_PX`]
    /// on an estimate.
    pub guard_px: f64,
    pub settings: AntialiasSettings,
}

impl AntialiasPlan {
    /// The focus test's threshold in the views' values (square-root units of 0–1), 0 when
    /// [`AntialiasSettings::focus_test`] is off.
    pub fn focus_threshold(&self) -> f64 {
        if self.settings.focus_test {
            FOCUS_TEST_LEVELS / 255.0
        } else {
            0.0
        }
    }

    /// The residual `|s − σ|` below which a pixel's own surface counts as in focus and its
    /// sub-samples with footprints under [`FOCUSED_BLUR_PX`] read Catmull-Rom: the residual at
    /// which the longest footprint span of any view (at unit homogeneous depth) reaches
    /// [`FOCUSED_BLUR_PX`]. 0 when [`AntialiasSettings::focused_bicubic`] is off; infinite
    /// without footprints (a pinhole's cells: everything is in focus).
    pub fn focused_reach(&self) -> f64 {
        if !self.settings.focused_bicubic {
            return 0.0;
        }
        focus_reach(&self.footprints)
    }
}

/// The residual at which the longest footprint span of `footprints` (at unit homogeneous
/// depth) reaches [`FOCUSED_BLUR_PX`]: under it a surface is in focus. Infinite without
/// footprints.
fn focus_reach(footprints: &[Footprint]) -> f64 {
    let longest = footprints
        .iter()
        .flat_map(|f| [f.span_s, f.span_t])
        .map(|span| span.truncate().length())
        .fold(0.0, f64::max);
    if longest > 0.0 {
        FOCUSED_BLUR_PX / longest
    } else {
        f64::INFINITY
    }
}

/// On an estimated depth, the outline of a surface in focus: a pixel out of focus next to one
/// (4-neighbourhood) whose surface is nearer and in focus (`|s − σ| < reach`, `s = max(m·x, 0)`
/// at that neighbour) takes that surface's σ; unknown pixels stay unknown. Why: the estimator
/// gives a mixed outline pixel the farther side's depth when its colour is mostly that side's
/// (docs/depth.md, step 8b), which is the depth under the pixel's centre, but the footprint of
/// that depth blurs the focused surface's part of the pixel into the background, where the lens
/// keeps it sharp: on `antialias-set`'s `layers-near` the focused card scored 33.3 dB on the
/// estimate this way, 49.3 before that step. Measured over the set (128 px, the estimated
/// column's means overall / out of focus / focused): without this 37.69 / 39.51 / 40.48 dB,
/// with it 38.01 / 39.45 / 43.08; with 8-neighbours 37.92 / 39.29 / 43.08 (a ring of
/// background around focused surfaces loses its blur), at a quarter of the reach 37.96 / 39.48
/// / 42.83. Returns the pixels changed; `front` follows while it is the pixels' own σ (before
/// the fronts are searched).
pub fn keep_focused_outlines(scene: &mut SceneDepth, m: DVec3, reach: f64) -> usize {
    let (w, h) = (scene.width as usize, scene.height as usize);
    let sigma = &scene.inverse_depth;
    let focused = |x: usize, y: usize| {
        let v = sigma[y * w + x];
        let s = m.dot(DVec3::new(x as f64, y as f64, 1.0)).max(0.0);
        v >= 0.0 && (s - v as f64).abs() < reach
    };
    let mut changed = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let own = sigma[y * w + x];
            if own < 0.0 || focused(x, y) {
                continue;
            }
            let mut nearest = own;
            for (nx, ny) in neighbours4(x, y, w, h) {
                let v = sigma[ny * w + nx];
                if v > nearest && focused(nx, ny) {
                    nearest = v;
                }
            }
            if nearest > own {
                changed.push((y * w + x, nearest));
            }
        }
    }
    for &(i, v) in &changed {
        scene.inverse_depth[i] = v;
        scene.front[i] = scene.front[i].max(v);
    }
    changed.len()
}

/// The 4-neighbours of (x, y) inside a `w × h` image.
fn neighbours4(x: usize, y: usize, w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)]
        .into_iter()
        .map(move |(dx, dy)| (x as i64 + dx, y as i64 + dy))
        .filter(move |&(nx, ny)| nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64)
        .map(|(nx, ny)| (nx as usize, ny as usize))
}

/// Most footprint, in pixels, a sub-sample may stand for and still read Catmull-Rom in a pixel
/// whose own surface is in focus ([`AntialiasSettings::focused_bicubic`]): under half a pixel
/// the sub-sample's box is narrower than the interpolator's own support, so a sharp point
/// sample is what it stands for.
pub const FOCUSED_BLUR_PX: f64 = 0.5;

/// Whether a sub-sample of a pixel whose surface is in focus reads Catmull-Rom: its footprint
/// for residual `d` (the longer span, in pixels at homogeneous depth `yz`) is under
/// [`FOCUSED_BLUR_PX`]. The shader decides the same in f32 (`sub_sample`).
pub fn focused_sub_sample(fp: &Footprint, d: f64, yz: f64) -> bool {
    yz > 0.0 && footprint_blur(fp, d, yz) < FOCUSED_BLUR_PX
}

/// The longer of a footprint's two spans for residual `d`, in pixels at homogeneous depth `yz`.
pub fn footprint_blur(fp: &Footprint, d: f64, yz: f64) -> f64 {
    span_px(fp.span_s, d, yz).max(span_px(fp.span_t, d, yz))
}

/// The length in pixels of a footprint span for residual `d` at a plain sample with
/// homogeneous depth `yz` (the sub-sample count, the pyramid level and the Catmull-Rom choice
/// all follow it).
pub fn span_px(span: DVec3, d: f64, yz: f64) -> f64 {
    (span.truncate() * d).length() / yz
}

/// The spread of plain samples `(weight, colour)` (colour in the averaging space, 0–1): the
/// largest over the channels of their weighted standard deviation in square-root units,
/// `√(E[c] − E[√c]²)`; `None` without samples. The focus test compares it with
/// [`AntialiasPlan::focus_threshold`]; the shader computes the same in f32 (`views_agree`).
pub fn focus_spread(samples: impl Iterator<Item = (f64, [f64; 3])>) -> Option<f64> {
    let (mut lin, mut root, mut wsum) = ([0f64; 3], [0f64; 3], 0f64);
    for (w, c) in samples {
        for k in 0..3 {
            let c = c[k].max(0.0);
            lin[k] += w * c;
            root[k] += w * c.sqrt();
        }
        wsum += w;
    }
    (wsum > 0.0).then(|| {
        (0..3)
            .map(|k| {
                let mean = root[k] / wsum;
                (lin[k] / wsum - mean * mean).max(0.0).sqrt()
            })
            .fold(0.0, f64::max)
    })
}

/// The visibility test's guard on an estimated depth map: sub-samples within half a pixel of
/// their view's plain sample read what the view's own ray sees. The estimate's errors at
/// silhouettes (a pixel or two of a wrong, nearer depth) would otherwise hide in-focus
/// sub-samples and drop them (measured: up to 30 levels of change in the viewer's video
/// test). A given map is trusted to the pixel: without the guard the focused wall's edges
/// next to nearer layers score 40.4 dB against the lens instead of 33.9 (synth `layers`).
pub const ESTIMATED_DEPTH_GUARD_PX: f64 = 0.5;

/// Cell rectangle `[u0, u1] × [v0, v1]` (grid steps around the view) for the part of the unit
/// cell inside the aperture: the size of that part's bounding box, centred on its centroid
/// (so a rim cell's sub-samples, a single one included, have the part's mean position; the
/// bounding box's own centre lies outwards, towards what the disk cuts off), and the
/// area-weighted aperture weight of the cell (its mean over the cell: the area inside for disk
/// and square apertures).
fn cell(
    aperture: &Aperture,
    pos: DVec2,
    centre: DVec2,
    cols: usize,
    rows: usize,
) -> (f64, [f64; 4]) {
    let step = 1.0 / AREA_GRID as f64;
    let mut sum = 0.0;
    let (mut u0, mut u1, mut v0, mut v1) =
        (f64::INFINITY, -f64::INFINITY, f64::INFINITY, -f64::INFINITY);
    let (mut cu, mut cv) = (0.0, 0.0);
    for j in 0..AREA_GRID {
        let v = (j as f64 + 0.5) * step - 0.5;
        for i in 0..AREA_GRID {
            let u = (i as f64 + 0.5) * step - 0.5;
            let w = aperture.weight(pos + DVec2::new(u, v), centre, cols, rows);
            if w > 0.0 {
                sum += w;
                cu += u * w;
                cv += v * w;
                u0 = u0.min(u - 0.5 * step);
                u1 = u1.max(u + 0.5 * step);
                v0 = v0.min(v - 0.5 * step);
                v1 = v1.max(v + 0.5 * step);
            }
        }
    }
    if sum > 0.0 {
        let (cu, cv) = (cu / sum, cv / sum);
        let (hu, hv) = ((u1 - u0) / 2.0, (v1 - v0) / 2.0);
        return (sum * step * step, [cu - hu, cu + hu, cv - hv, cv + hv]);
    }
    (sum * step * step, [u0, u1, v0, v1])
}

/// How view (s, t)'s camera centre moves per grid step along s and t: central differences of
/// the neighbours' centres (one-sided on the grid's border, zero along an axis of one view).
fn centre_steps(lf: &LightField, s: usize, t: usize) -> (DVec3, DVec3) {
    let c = |s: usize, t: usize| lf.view(s, t).camera.centre();
    let diff = |lo: (usize, usize), hi: (usize, usize), steps: usize| {
        if steps == 0 {
            DVec3::ZERO
        } else {
            (c(hi.0, hi.1) - c(lo.0, lo.1)) / steps as f64
        }
    };
    let (cols, rows) = (lf.grid.cols, lf.grid.rows);
    let (s0, s1) = (s.saturating_sub(1), (s + 1).min(cols - 1));
    let (t0, t1) = (t.saturating_sub(1), (t + 1).min(rows - 1));
    (
        diff((s0, t), (s1, t), s1 - s0),
        diff((s, t0), (s, t1), t1 - t0),
    )
}

/// Plans the anti-aliased refocus of `base` (a plan from [`super::plan`] with the same
/// `aperture`): views by aperture cell, footprints, and the scene depth of `depth` seen from
/// the plan's reference camera. Classic shift-and-sum (no camera model) is refused: its
/// warps have no parallax term to move along.
pub fn plan_antialias(
    lf: &LightField,
    base: &RefocusPlan,
    aperture: Aperture,
    excluded: &[bool],
    depth: &ViewDepth,
    settings: AntialiasSettings,
) -> Result<AntialiasPlan> {
    plan_antialias_reusing(lf, base, aperture, excluded, depth, settings, None)
}

/// [`plan_antialias`], taking the views' visibility maps from `previous` when they are the
/// same (same scene depth and view warps: moving the focus plane changes neither), as the
/// viewer does on every change of the plane.
pub fn plan_antialias_reusing(
    lf: &LightField,
    base: &RefocusPlan,
    aperture: Aperture,
    excluded: &[bool],
    depth: &ViewDepth,
    settings: AntialiasSettings,
    previous: Option<&AntialiasPlan>,
) -> Result<AntialiasPlan> {
    settings.validate()?;
    aperture.validate()?;
    let base = &*super::plan::with_plane(lf, base, aperture, excluded).map_err(|e| match e {
        Error::Invalid(m) => Error::Invalid(format!(
            "anti-aliasing needs the cameras' geometry: {m}; focus with --plane or --focus, \
             or use --antialias off"
        )),
        e => e,
    })?;
    let scene = scene_depth(depth, &base.reference_camera, (lf.width, lf.height))?;
    let cells = aperture_cells(lf, base, aperture, excluded);
    let mut views = Vec::new();
    let mut footprints = Vec::new();
    for (index, weight, [u0, u1, v0, v1]) in cells {
        let v = &lf.views[index];
        let warp = ViewWarp::new(&v.camera, &base.reference_camera);
        let (ds, dt) = centre_steps(lf, v.s, v.t);
        let kr = v.camera.k * v.camera.r;
        let (es, et) = (-(kr * ds), -(kr * dt));
        let rc = &base.reference_camera;
        let fp = Footprint {
            origin: u0 * es + v0 * et,
            span_s: (u1 - u0) * es,
            span_t: (v1 - v0) * et,
            parallax: rc.k * (rc.r * (rc.centre() - v.camera.centre())),
            map: views.len(),
        };
        if !(warp.a.is_finite() && warp.b.is_finite() && fp.origin.is_finite()) {
            return Err(Error::Geometry(format!(
                "the warp of view ({}, {}) is not finite",
                v.s, v.t
            )));
        }
        views.push(PlannedView {
            index,
            s: v.s,
            t: v.t,
            weight,
            warp,
        });
        footprints.push(fp);
    }
    if views.len() > MAX_VIEWS {
        return Err(Error::Invalid(format!(
            "anti-aliasing handles at most {MAX_VIEWS} views in the aperture, this one has {}; \
             use a smaller --aperture-radius or --antialias off",
            views.len()
        )));
    }
    // The views' maps are what they see of the depth as it is; on an estimate the focused
    // outlines change only the pixels' own surface (and depend on the plane, which the maps
    // must not, so that moving the plane reuses them).
    let maps_from = depth.estimated.then(|| scene.clone());
    let mut scene = scene;
    if depth.estimated {
        keep_focused_outlines(&mut scene, base.m, focus_reach(&footprints));
    }
    let map_bytes = views.len() * scene.inverse_depth.len() * 2;
    let mut aa = AntialiasPlan {
        plan: RefocusPlan {
            views,
            ..base.clone()
        },
        footprints,
        depth: scene,
        visibility: None,
        guard_px: if depth.estimated {
            ESTIMATED_DEPTH_GUARD_PX
        } else {
            0.0
        },
        settings,
    };
    aa.settings.layered = layered_route(&aa, depth.estimated, map_bytes);
    let settings = aa.settings;
    let per_view_maps = settings.per_view_maps();
    if per_view_maps && map_bytes > MAX_VISIBILITY_BYTES {
        let (route, switch) = match settings.defocus {
            true => ("defocused views", "--antialias-defocus"),
            false => ("layered footprints", "--antialias-layered"),
        };
        return Err(Error::Invalid(format!(
            "{route} need every view's depth map: {} MiB for {} views, over the {} MiB \
             budget; use a smaller --aperture-radius or {switch} off",
            map_bytes >> 20,
            aa.plan.views.len(),
            MAX_VISIBILITY_BYTES >> 20
        )));
    }
    // Without the occlusion tests the front stays the pixel's own σ: nothing is nearer, and
    // the shader's and the model's tests never run.
    if settings.occlusion_tests() {
        search_fronts(&mut aa.depth, &aa.footprints);
    }
    let (scene, views) = (maps_from.as_ref().unwrap_or(&aa.depth), &aa.plan.views);
    aa.visibility = match previous {
        Some(p)
            if p.settings.per_view_maps() == per_view_maps
                && p.plan.views.len() == views.len()
                && p.plan
                    .views
                    .iter()
                    .zip(views)
                    .all(|(a, b)| a.index == b.index && a.warp == b.warp)
                && p.visibility.as_ref().map(|v| v.depth_hash)
                    == Some(ViewVisibility::hash_of(scene)) =>
        {
            p.visibility.clone()
        }
        _ if per_view_maps => Some(std::sync::Arc::new(ViewVisibility::filled(scene, views))),
        _ => (settings.occlusion && map_bytes <= MAX_VISIBILITY_BYTES)
            .then(|| std::sync::Arc::new(ViewVisibility::new(scene, views))),
    };
    Ok(aa)
}

/// What `aa.settings.layered` comes to once planned ([`Layered`]): [`Layered::Auto`] takes
/// layered footprints on a depth handed over with the light field (`estimated` false), without
/// defocused views, where every view's depth map fits the budget (`map_bytes`) and the pass
/// holds the layers the plane's focus range reaches; else [`Layered::Off`]. (One plane at the
/// views' size is the caller's to know: [`AntialiasSettings::for_output`].)
fn layered_route(aa: &AntialiasPlan, estimated: bool, map_bytes: usize) -> Layered {
    match aa.settings.layered {
        Layered::Auto => {
            let size = (aa.depth.width, aa.depth.height);
            let fits = !estimated
                && !aa.settings.defocus
                && map_bytes <= MAX_VISIBILITY_BYTES
                && super::layered::LayerPlan::new(aa, size).check().is_ok();
            if fits {
                Layered::On
            } else {
                Layered::Off
            }
        }
        asked => asked,
    }
}

/// Each view's aperture cell: `(view index, weight, [u0, u1, v0, v1])`, the part of its cell
/// inside `aperture` in grid steps around the view. An aperture smaller than the quadrature's
/// resolution (radius ≈ 0: a pinhole) has no measurable cell: then the plain plan's views, each
/// a point (no footprint).
fn aperture_cells(
    lf: &LightField,
    base: &RefocusPlan,
    aperture: Aperture,
    excluded: &[bool],
) -> Vec<(usize, f64, [f64; 4])> {
    let mut cells = Vec::new();
    for (index, v) in lf.views.iter().enumerate() {
        if excluded.get(index).copied().unwrap_or(false) {
            continue;
        }
        let pos = DVec2::new(v.s as f64, v.t as f64);
        let (area, rect) = cell(&aperture, pos, base.reference, lf.grid.cols, lf.grid.rows);
        // A gaussian has no rim: its views keep their point weights over whole cells.
        let (weight, rect) = match aperture.shape {
            ApertureShape::Gaussian => (
                base.views
                    .iter()
                    .find(|p| p.index == index)
                    .map_or(0.0, |p| p.weight),
                [-0.5, 0.5, -0.5, 0.5],
            ),
            _ => (area, rect),
        };
        if weight > 0.0 {
            cells.push((index, weight, rect));
        }
    }
    if cells.is_empty() {
        cells = base
            .views
            .iter()
            .map(|p| (p.index, p.weight, [0.0; 4]))
            .collect();
    }
    cells
}

/// Sets `scene`'s front (the nearest σ around each pixel) for the occlusion tests. The search
/// reaches as far as any view's parallax over the scene's depth range: farther than that, no
/// view can see an occluder at a pixel.
fn search_fronts(scene: &mut SceneDepth, footprints: &[Footprint]) {
    let valid = scene.inverse_depth.iter().filter(|&&v| v >= 0.0);
    let (lo, hi) = valid.fold((f32::INFINITY, -1f32), |(a, b), &v| (a.min(v), b.max(v)));
    if hi <= lo {
        return;
    }
    let reach = footprints
        .iter()
        .map(|f| f.parallax.truncate().length())
        .fold(0.0, f64::max)
        * (hi - lo) as f64;
    let r = (reach.ceil() as u32 + 1).min(MAX_FRONT_RADIUS);
    scene.front = max_filter(
        &scene.inverse_depth,
        scene.width as usize,
        scene.height as usize,
        r as usize,
    );
    scene.front_radius = r;
    scene.fronts = super::boxed::front_levels(
        &scene.inverse_depth,
        (scene.width as usize, scene.height as usize),
    );
}

/// [`plan_antialias`] with the depth of `lf`'s map-carrying view ([`LightField::view_depth`]);
/// an error naming the light field when it has no depth.
pub fn plan_for(
    lf: &LightField,
    base: &RefocusPlan,
    aperture: Aperture,
    excluded: &[bool],
    settings: AntialiasSettings,
) -> Result<AntialiasPlan> {
    plan_for_reusing(lf, base, aperture, excluded, settings, None)
}

/// [`plan_for`], taking the views' maps from `previous` where they are the same
/// ([`plan_antialias_reusing`]).
pub fn plan_for_reusing(
    lf: &LightField,
    base: &RefocusPlan,
    aperture: Aperture,
    excluded: &[bool],
    settings: AntialiasSettings,
    previous: Option<&AntialiasPlan>,
) -> Result<AntialiasPlan> {
    let depth = lf
        .view_depth()
        .map_err(|e| Error::Invalid(format!("anti-aliasing needs the scene's depth: {e}")))?;
    plan_antialias_reusing(lf, base, aperture, excluded, &depth, settings, previous)
}

/// Sub-samples per axis of a footprint span for residual `d` at a plain sample with
/// homogeneous depth `yz`: its length in pixels rounded up, at least 1, at most `max`. The
/// shader computes the same in f32 (`samples` in refocus_accumulate.glsl).
pub fn samples(span: DVec3, d: f64, yz: f64, max: u32) -> u32 {
    if yz <= 0.0 {
        return 1;
    }
    span_px(span, d, yz).ceil().clamp(1.0, max as f64) as u32
}

/// The pyramid level every sub-sample of a footprint reads with the prefilter on: that of the
/// larger spacing of the `ns × nt` grid along the two spans (`prefilter::lod`); 0 without the
/// prefilter or behind the camera. The shader computes the same in f32 (`footprint_lod`).
pub fn footprint_lod(
    (span_s, span_t): (DVec3, DVec3),
    d: f64,
    yz: f64,
    (ns, nt): (u32, u32),
    prefilter: bool,
) -> f64 {
    if !prefilter || yz <= 0.0 {
        return 0.0;
    }
    let spacing = (span_px(span_s, d, yz) / ns as f64).max(span_px(span_t, d, yz) / nt as f64);
    super::prefilter::lod(spacing)
}

/// The JSON description of anti-aliasing for reports.
pub fn antialias_json(
    aa: Option<&AntialiasPlan>,
    depth_origin: Option<serde_json::Value>,
) -> serde_json::Value {
    match aa {
        None => serde_json::json!({"used": false}),
        Some(aa) => serde_json::json!({
            "used": true,
            "max_samples": aa.settings.max_samples,
            "prefilter": aa.settings.prefilter,
            "focus_test": aa.settings.focus_test,
            "focused_bicubic": aa.settings.focused_bicubic,
            "occlusion": aa.settings.occlusion_tests(),
            "defocus": aa.settings.defocus,
            "layered": aa.settings.layered.on(),
            "boxed": aa.settings.boxes(),
            "views_by_cell": aa.plan.views.len(),
            "depth_source": aa.depth.source,
            "depth_origin": depth_origin,
            "pixels_without_depth": aa.depth.unknown,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::{GridSize, ParallelRig, Source, View};
    use crate::refocus::FocusMethod;

    #[test]
    fn layered_and_defocused_footprints_are_not_asked_for_together() {
        let both = AntialiasSettings {
            layered: Layered::On,
            defocus: true,
            ..AntialiasSettings::default()
        };
        let err = both.validate().unwrap_err().to_string();
        assert!(
            err.contains("--antialias-layered") && err.contains("--antialias-defocus"),
            "{err}"
        );
        let layered = AntialiasSettings {
            layered: Layered::On,
            ..AntialiasSettings::default()
        };
        assert!(layered.validate().is_ok());
    }

    const RIG: ParallelRig = ParallelRig {
        focal_px: 40.0,
        baseline: 0.1,
        focus_distance: 2.0,
    };

    /// A 5×5 grid of 16×12 blank views on `RIG`, with a depth map of z = 4 (the centre view).
    fn grid() -> LightField {
        let grid = GridSize { cols: 5, rows: 5 };
        let (w, h) = (16, 12);
        let views = RIG
            .cameras(grid, w, h)
            .into_iter()
            .enumerate()
            .map(|(i, camera)| View {
                s: i % 5,
                t: i / 5,
                camera,
                image: image::RgbaImage::new(w, h),
                source: format!("view {i}"),
            })
            .collect();
        let depth = crate::lightfield::DepthMap {
            width: w,
            height: h,
            kind: crate::lightfield::DepthKind::Depth,
            values: vec![4.0; (w * h) as usize],
            source: "test depth".into(),
            estimated: false,
        };
        LightField {
            name: "grid".into(),
            grid,
            width: w,
            height: h,
            views,
            depth: vec![(12, depth)],
            rig: Some(RIG),
            disparity_range: None,
            source: Source::Generated {
                scene: "grid".into(),
            },
        }
    }

    /// A grid folder focused by `--disparity D` (classic shift-and-sum) anti-aliases on the
    /// frontoparallel plane of its parallel cameras that shifts every view by the same D per
    /// grid step; a D at or beyond the cameras' infinity, and cameras that are not a parallel
    /// grid, are refused naming the cause.
    #[test]
    fn a_classic_disparity_on_parallel_cameras_is_their_frontoparallel_plane() {
        // No rig: `--disparity` is classic shift-and-sum on the grid's (sensor-shifted)
        // cameras.
        let mut lf = grid();
        lf.rig = None;
        // RIG (f·b = 4 px, focus 2 m) puts infinity at classic D = f·b/Z₀ = 2.
        let plan_at = |lf: &LightField, d: f64| {
            let req = super::super::RefocusRequest {
                focus: super::super::FocusSpec::Disparity(d),
                aperture: Aperture::default(),
                reference: None,
            };
            let base = super::super::plan(lf, &req, &[]).unwrap();
            assert_eq!(base.method, FocusMethod::ClassicShift);
            plan_for(
                lf,
                &base,
                Aperture::default(),
                &[],
                AntialiasSettings::default(),
            )
        };
        for d in [-1.5, 0.0, 1.5] {
            let aa = plan_at(&lf, d).unwrap();
            assert_ne!(aa.plan.method, FocusMethod::ClassicShift);
            for v in &aa.plan.views {
                let off = DVec2::new(v.s as f64 - 2.0, v.t as f64 - 2.0);
                for x in [
                    DVec2::new(0.0, 0.0),
                    DVec2::new(15.0, 11.0),
                    DVec2::new(7.5, 3.0),
                ] {
                    let y = v.warp.apply(aa.plan.m, x);
                    let y = DVec2::new(y.x / y.z, y.y / y.z);
                    assert!(
                        (y - (x + d * off)).length() < 1e-9,
                        "D {d}: {y} vs {x} + {off}"
                    );
                }
            }
        }
        let e = plan_at(&lf, 2.0).unwrap_err().to_string();
        assert!(
            e.contains("--disparity 2 lies at or beyond the cameras' infinity (2.000"),
            "{e}"
        );
        // A camera turned a degree: not a parallel grid.
        let c = lf.views[3].camera;
        lf.views[3].camera = Camera::from_centre(
            c.k,
            DMat3::from_rotation_y(1f64.to_radians()) * c.r,
            c.centre(),
        );
        let e = plan_at(&lf, 0.0).unwrap_err().to_string();
        assert!(
            e.contains("not a parallel grid") && e.contains("--antialias off"),
            "{e}"
        );
    }

    fn aa_plan(lf: &LightField, aperture: Aperture, reference: Option<DVec2>) -> AntialiasPlan {
        let req = super::super::RefocusRequest {
            focus: super::super::FocusSpec::Disparity(0.0),
            aperture,
            reference,
        };
        let base = super::super::plan(lf, &req, &[]).unwrap();
        plan_for(lf, &base, aperture, &[], AntialiasSettings::default()).unwrap()
    }

    /// The focused reach is where the longest span (a whole cell of RIG: f·b = 4 px per unit
    /// of inverse depth) reaches half a pixel; 0 when Catmull-Rom is off. A sub-sample reads
    /// Catmull-Rom below half a pixel of footprint, not at it, and never behind the camera.
    #[test]
    fn the_focused_reach_is_half_a_pixel_of_the_longest_span() {
        let lf = grid();
        let mut aa = aa_plan(&lf, Aperture::default(), None);
        let longest = 4.0;
        assert!((aa.focused_reach() - FOCUSED_BLUR_PX / longest).abs() < 1e-9);
        let fp = aa.footprints[0];
        let at = |px: f64| {
            px / fp
                .span_s
                .truncate()
                .length()
                .max(fp.span_t.truncate().length())
        };
        assert!(focused_sub_sample(&fp, at(0.49), 1.0));
        assert!(!focused_sub_sample(&fp, at(0.51), 1.0));
        assert!(focused_sub_sample(&fp, -at(0.49), 1.0));
        assert!(!focused_sub_sample(&fp, 0.0, -1.0));
        aa.settings.focused_bicubic = false;
        assert_eq!(aa.focused_reach(), 0.0);
        // Without footprints (a pinhole) everything is in focus.
        aa.settings.focused_bicubic = true;
        for f in &mut aa.footprints {
            f.span_s = DVec3::ZERO;
            f.span_t = DVec3::ZERO;
        }
        assert_eq!(aa.focused_reach(), f64::INFINITY);
    }

    #[test]
    fn the_spread_is_the_standard_deviation_of_square_roots() {
        assert_eq!(focus_spread(std::iter::empty()), None);
        // Identical samples: zero up to the cancellation in E[c] − E[√c]².
        let same = focus_spread([(1.0, [0.3; 3]), (2.0, [0.3; 3])].into_iter()).unwrap();
        assert!(same.abs() < 1e-6, "{same}");
        // √(E[c] − E[√c]²) of 0 and 1, equal weights: √(½ − ¼).
        let v = focus_spread([(1.0, [0.0, 0.5, 0.5]), (1.0, [1.0, 0.5, 0.5])].into_iter());
        assert!((v.unwrap() - 0.5).abs() < 1e-12);
        // The largest channel counts; weights weigh.
        let v = focus_spread([(3.0, [0.2, 0.0, 0.0]), (1.0, [0.2, 0.0, 0.8])].into_iter());
        let (r0, r1) = (0.0f64, 0.8f64.sqrt());
        let m = (3.0 * r0 + r1) / 4.0;
        assert!((v.unwrap() - (0.8 / 4.0 - m * m).sqrt()).abs() < 1e-12);
    }

    /// A white stripe on the focus plane whose depth map says it is far away (an estimate's
    /// error on a textureless stripe): its views agree at the plane, so the focus test keeps it
    /// exactly the plain sum; without the test the wrong depth's footprint blurs its edges.
    #[test]
    fn views_that_agree_at_the_focus_plane_keep_a_wrongly_deep_stripe_sharp() {
        let mut lf = grid();
        // The map puts everything 1 km away: 2 px per grid step from the plane.
        lf.depth[0].1.values.fill(1000.0);
        // Zero disparity at the rig's focus distance: every view sees the stripe at the same
        // columns.
        for v in &mut lf.views {
            for (x, _, p) in v.image.enumerate_pixels_mut() {
                let c = if (6..10).contains(&x) { 255 } else { 0 };
                *p = image::Rgba([c, c, c, 255]);
            }
        }
        let req = super::super::RefocusRequest {
            focus: super::super::FocusSpec::Disparity(0.0),
            aperture: Aperture::default(),
            reference: None,
        };
        let base = super::super::plan(&lf, &req, &[]).unwrap();
        let render = |focus_test: bool| {
            let settings = AntialiasSettings {
                focus_test,
                ..AntialiasSettings::default()
            };
            let aa = plan_for(&lf, &base, Aperture::default(), &[], settings).unwrap();
            assert_eq!(aa.focus_threshold() > 0.0, focus_test);
            let img = crate::refocus::cpu::render_antialiased(
                &lf,
                &aa,
                crate::refocus::Averaging::Linear,
                16,
                12,
            );
            img.pixels
        };
        let (tested, untested) = (render(true), render(false));
        let row = 6 * 16;
        for x in 0..16 {
            let want = if (6..10).contains(&x) { 1.0 } else { 0.0 };
            assert!(
                (tested[row + x][0] - want).abs() < 1e-6,
                "x {x}: {}",
                tested[row + x][0]
            );
        }
        // Without the test the wrong depth's footprint (2 px per grid step) blurs the stripe's
        // edge columns.
        assert!((untested[row + 6][0] - 1.0).abs() > 0.05 && untested[row + 5][0] > 0.05);
    }

    #[test]
    fn a_rim_cell_is_centred_on_the_centroid_of_its_part_inside_the_disk() {
        let disk = Aperture {
            shape: ApertureShape::Disk,
            radius: Some(2.0),
        };
        let centre = DVec2::new(2.0, 2.0);
        // View (4, 3): 2.24 grid steps out, only the corner of its cell nearest the centre
        // inside. The centroid by a finer quadrature (256²), independently of `cell`.
        let pos = DVec2::new(4.0, 3.0);
        let (mut n, mut c) = (0.0, DVec2::ZERO);
        for j in 0..256 {
            for i in 0..256 {
                let o = DVec2::new(i as f64 + 0.5, j as f64 + 0.5) / 256.0 - 0.5;
                if (pos + o - centre).length() <= 2.0 {
                    n += 1.0;
                    c += o;
                }
            }
        }
        let c = c / n;
        let (_, [u0, u1, v0, v1]) = cell(&disk, pos, centre, 5, 5);
        let mid = DVec2::new(u0 + u1, v0 + v1) / 2.0;
        assert!((mid - c).length() < 0.01, "{mid} vs {c}");
        // Towards the disk's centre (−u, −v), and nearer to it than the middle of the part's
        // bounding box (which starts at the cell's corner (−½, −½) and has the rectangle's
        // size): the rectangle used to be that box.
        assert!(c.x < -0.2 && c.y < -0.1, "{c}");
        let boxed = DVec2::new(-0.5 + (u1 - u0) / 2.0, -0.5 + (v1 - v0) / 2.0);
        assert!(
            c.x < boxed.x - 0.02 && c.y < boxed.y - 0.02,
            "{c} vs {boxed}"
        );
        // An interior cell stays the unit square.
        let (a, r) = cell(&disk, centre, centre, 5, 5);
        assert!((a - 1.0).abs() < 1e-12);
        for (got, want) in r.iter().zip([-0.5, 0.5, -0.5, 0.5]) {
            assert!((got - want).abs() < 1e-12, "{r:?}");
        }
    }

    #[test]
    fn cells_of_a_disk_weigh_by_their_area_inside_it() {
        let lf = grid();
        let disk = |r| Aperture {
            shape: ApertureShape::Disk,
            radius: Some(r),
        };
        let aa = aa_plan(&lf, disk(2.0), None);
        let total: f64 = aa.plan.views.iter().map(|v| v.weight).sum();
        // The cells tile the plane, so their areas inside the disk add up to π R².
        let pi4 = std::f64::consts::PI * 4.0;
        assert!((total - pi4).abs() < 0.01, "{total}");
        // Rim views count partly; (4, 3) is 2.24 from the centre, outside the disk, yet part
        // of its cell is inside; the corner (4, 4) has nothing inside.
        let w = |s, t| {
            aa.plan
                .views
                .iter()
                .find(|v| (v.s, v.t) == (s, t))
                .map(|v| v.weight)
        };
        assert_eq!(w(2, 2), Some(1.0));
        assert!(w(4, 2).unwrap() > 0.3 && w(4, 2).unwrap() < 0.6);
        assert!(w(4, 3).unwrap() > 0.1 && w(4, 3).unwrap() < 0.3);
        assert_eq!(w(4, 4), None);
        // The rim cell's rectangle is clipped on the far side: as wide as the part inside
        // (under half the cell), centred on that part's centroid, so it starts about at the
        // cell's near edge (a hair before it: the part is thinner at its ends).
        let i = aa
            .plan
            .views
            .iter()
            .position(|v| (v.s, v.t) == (4, 2))
            .unwrap();
        let f = aa.footprints[i];
        let fb = RIG.focal_px * RIG.baseline;
        assert!((f.origin.x / fb - 0.5).abs() < 0.03, "{}", f.origin);
        assert!(
            f.span_s.x < 0.0 && -f.span_s.x <= 0.5 * fb + 1e-9,
            "{}",
            f.span_s
        );
    }

    #[test]
    fn a_parallel_rig_moves_one_baseline_times_focal_length_per_grid_step() {
        let lf = grid();
        let aa = aa_plan(&lf, Aperture::default(), None);
        let fb = RIG.focal_px * RIG.baseline;
        for f in &aa.footprints {
            // Full cells: from −½ to +½ grid step; e_s = −K ∂C/∂s = (−f b, 0, 0).
            assert!(
                (f.span_s - DVec3::new(-fb, 0.0, 0.0)).length() < 1e-9,
                "{}",
                f.span_s
            );
            assert!(
                (f.span_t - DVec3::new(0.0, -fb, 0.0)).length() < 1e-9,
                "{}",
                f.span_t
            );
            assert!((f.origin - DVec3::new(0.5 * fb, 0.5 * fb, 0.0)).length() < 1e-9);
        }
        // Scene inverse depth: 1/4 at every pixel, at the centre and (reprojected) between
        // views, where the frontoparallel wall covers all but the splat's border.
        assert!(aa
            .depth
            .inverse_depth
            .iter()
            .all(|&v| (v - 0.25).abs() < 1e-7));
        let aa = aa_plan(&lf, Aperture::default(), Some(DVec2::new(1.5, 2.5)));
        let known: Vec<f32> = aa
            .depth
            .inverse_depth
            .iter()
            .copied()
            .filter(|&v| v >= 0.0)
            .collect();
        assert!(known.len() >= 16 * 12 - 2 * 12, "{}", known.len());
        assert!(known.iter().all(|&v| (v - 0.25).abs() < 1e-6));
        // Sub-samples per axis follow the footprint's length in pixels.
        let span = DVec3::new(-fb, 0.0, 0.0);
        assert_eq!(samples(span, 0.0, 1.0, 4), 1);
        assert_eq!(samples(span, 0.3 / fb, 1.0, 4), 1);
        assert_eq!(samples(span, 2.5 / fb, 1.0, 4), 3);
        assert_eq!(samples(span, 100.0, 1.0, 4), 4);
        assert_eq!(samples(span, 100.0, -1.0, 4), 1);
    }

    /// A 20×1 scene: background σ = 0.25 on the left, a nearer surface σ = 0.5 from x = 12;
    /// one view at parallax `g` (per unit of s − σ) whose cell spans `span` per unit.
    fn edge_plan(g: f64, span: f64, visibility: bool) -> AntialiasPlan {
        let (w, h) = (20u32, 1u32);
        let sigma: Vec<f32> = (0..w).map(|x| if x >= 12 { 0.5 } else { 0.25 }).collect();
        let depth = SceneDepth {
            width: w,
            height: h,
            front: max_filter(&sigma, w as usize, 1, 6),
            front_radius: 6,
            fronts: Vec::new(),
            inverse_depth: sigma,
            unknown: 0,
            source: "test".into(),
        };
        // The view's warp: a parallel camera that sees reference pixel x at x + g·σ (so a
        // point it sees at its plain sample x + g·s lies at x + g·(s − c) in the reference).
        let warp = ViewWarp {
            a: glam::DMat3::IDENTITY,
            b: DVec3::new(g, 0.0, 0.0),
        };
        let views = vec![PlannedView {
            index: 0,
            s: 0,
            t: 0,
            weight: 1.0,
            warp,
        }];
        let visibility =
            visibility.then(|| std::sync::Arc::new(ViewVisibility::new(&depth, &views)));
        let lf = grid();
        let base = aa_plan(&lf, Aperture::default(), None).plan;
        AntialiasPlan {
            plan: RefocusPlan { views, ..base },
            footprints: vec![Footprint {
                origin: DVec3::new(-0.5 * span, 0.0, 0.0),
                span_s: DVec3::new(span, 0.0, 0.0),
                span_t: DVec3::ZERO,
                parallax: DVec3::new(g, 0.0, 0.0),
                map: 0,
            }],
            depth,
            visibility,
            guard_px: 0.0,
            settings: AntialiasSettings::default(),
        }
    }

    /// The views' maps hold what the GPU stores, 16-bit floats: every σ is its own rounding,
    /// within half a step (2⁻¹¹ relative) of the depth's, and the GPU's words decode to the same
    /// numbers.
    #[test]
    fn the_views_maps_are_what_the_gpu_reads() {
        let mut plan = edge_plan(2.0, 1.0, true);
        let (w, h) = (plan.depth.width as usize, plan.depth.height as usize);
        // σ that 16 bits do not hold.
        plan.depth.inverse_depth = (0..w * h).map(|x| 1.0 / (3.0 + x as f32)).collect();
        plan.depth.inverse_depth[3] = -1.0;
        for vis in [
            ViewVisibility::new(&plan.depth, &plan.plan.views),
            ViewVisibility::filled(&plan.depth, &plan.plan.views),
        ] {
            let mut seen = 0;
            for &v in &vis.sigma {
                assert_eq!(half::f16::from_f32(v).to_f32(), v);
                if v >= 0.0 {
                    let nearest = plan
                        .depth
                        .inverse_depth
                        .iter()
                        .map(|&d| ((d - v) / d).abs())
                        .fold(f32::INFINITY, f32::min);
                    assert!(nearest <= 1.0 / 2048.0, "{v}: {nearest}");
                    seen += 1;
                }
            }
            assert!(seen > w / 2, "{seen} of {w} pixels hold a surface");
            let words = vis.half_words();
            assert_eq!(words.len(), vis.sigma.len().div_ceil(2));
            for (i, v) in vis.sigma.iter().enumerate() {
                let bits = (words[i / 2] >> (16 * (i % 2))) as u16;
                assert_eq!(half::f16::from_bits(bits).to_f32(), *v);
            }
        }
    }

    /// A given map is trusted to the pixel; an estimate keeps the half-pixel guard.
    #[test]
    fn only_an_estimated_depth_guards_the_visibility_test() {
        let mut lf = grid();
        assert_eq!(aa_plan(&lf, Aperture::default(), None).guard_px, 0.0);
        lf.depth[0].1.estimated = true;
        let aa = aa_plan(&lf, Aperture::default(), None);
        assert_eq!(aa.guard_px, ESTIMATED_DEPTH_GUARD_PX);
        assert!(aa.depth.unknown == 0 && aa.visibility.is_some());
    }

    /// On an estimate, an out-of-focus pixel next to a nearer surface in focus takes that
    /// surface (the outline the estimator gave the background); nothing else changes: not a
    /// pixel next to a nearer surface out of focus, not a focused pixel, not an unknown one.
    #[test]
    fn a_focused_surfaces_outline_keeps_it_on_an_estimate() {
        let (w, h) = (6usize, 3usize);
        // Columns 0-2 near (σ 0.5), 3-5 far (0.25); one unknown far pixel at (3, 2).
        let mut sigma: Vec<f32> = (0..w * h)
            .map(|i| if i % w < 3 { 0.5 } else { 0.25 })
            .collect();
        sigma[2 * w + 3] = -1.0;
        let scene = SceneDepth {
            width: w as u32,
            height: h as u32,
            front: sigma.clone(),
            front_radius: 0,
            fronts: Vec::new(),
            inverse_depth: sigma.clone(),
            unknown: 1,
            source: "test".into(),
        };
        // Focused on the near side (s = 0.5 everywhere): column 3 takes it, but the unknown.
        let mut near = scene.clone();
        let changed = keep_focused_outlines(&mut near, DVec3::new(0.0, 0.0, 0.5), 0.01);
        assert_eq!(changed, 2);
        for (i, (&before, &after)) in sigma.iter().zip(&near.inverse_depth).enumerate() {
            let expect = if i % w == 3 && i != 2 * w + 3 {
                0.5
            } else {
                before
            };
            assert_eq!(after, expect, "pixel {i}");
            assert_eq!(near.front[i], expect, "front {i}");
        }
        // Focused on the far side, or on neither: nothing to keep.
        for s in [0.25, 0.4] {
            let mut other = scene.clone();
            assert_eq!(
                keep_focused_outlines(&mut other, DVec3::new(0.0, 0.0, s), 0.01),
                0
            );
            assert_eq!(other, scene);
        }
        // Only an estimate's plan changes its depth, and the maps stay the depth's own.
        let mut lf = grid();
        let given = aa_plan(&lf, Aperture::default(), None);
        lf.depth[0].1.estimated = true;
        let estimated = aa_plan(&lf, Aperture::default(), None);
        assert_eq!(given.depth.inverse_depth, estimated.depth.inverse_depth);
        let maps = |aa: &AntialiasPlan| aa.visibility.as_ref().unwrap().depth_hash;
        assert_eq!(maps(&estimated), ViewVisibility::hash_of(&given.depth));
    }

    /// `Layered::Auto` takes layered footprints on a given depth and nowhere else: not on an
    /// estimate (which keeps the sub-samples' fronts and maps), not with defocused views, not
    /// for a focus surface or a scaled output (`for_output`); an explicit setting stays.
    #[test]
    fn automatic_layers_take_a_given_depth_on_one_plane_at_the_views_size() {
        let plan_with = |lf: &LightField, settings: AntialiasSettings| {
            let req = super::super::RefocusRequest {
                focus: super::super::FocusSpec::Disparity(0.0),
                aperture: Aperture::default(),
                reference: None,
            };
            let base = super::super::plan(lf, &req, &[]).unwrap();
            plan_for(lf, &base, Aperture::default(), &[], settings).unwrap()
        };
        let auto = AntialiasSettings::default();
        assert_eq!(auto.layered, Layered::Auto);
        let mut lf = grid();
        let given = plan_with(&lf, auto);
        assert_eq!(given.settings.layered, Layered::On);
        // Every view's own map, and no sub-sample fronts (nothing is searched).
        let maps = given.visibility.as_ref().expect("the views' maps");
        assert_eq!(maps.sigma.len(), given.plan.views.len() * 16 * 12);
        let off = AntialiasSettings {
            layered: Layered::Off,
            ..auto
        };
        assert_eq!(plan_with(&lf, off).settings.layered, Layered::Off);
        let defocus = AntialiasSettings {
            defocus: true,
            ..auto
        };
        assert_eq!(plan_with(&lf, defocus).settings.layered, Layered::Off);
        // A surface or a scaled output: boxed footprints and sub-samples, unless asked for.
        assert_eq!(auto.for_output(false).layered, Layered::Off);
        assert_eq!(auto.for_output(true).layered, Layered::Auto);
        let on = AntialiasSettings {
            layered: Layered::On,
            ..auto
        };
        assert_eq!(on.for_output(false).layered, Layered::On);
        assert_eq!(off.for_output(true).layered, Layered::Off);
        lf.depth[0].1.estimated = true;
        let estimated = plan_with(&lf, auto);
        assert_eq!(estimated.settings.layered, Layered::Off);
        assert_eq!(plan_with(&lf, on).settings.layered, Layered::On);
    }

    #[test]
    fn sub_samples_take_what_their_ray_hits() {
        let s = 0.25;
        let g = 5.0 / (s - 0.5);
        let aa = edge_plan(g, 0.0, false);
        assert_eq!(aa.depth.front_at(DVec2::new(6.0, 0.0)), Some(0.5));
        assert_eq!(aa.depth.front_at(DVec2::new(5.0, 0.0)), Some(0.25));
        let x = DVec2::new(8.0, 0.0);
        let hit = |aa: &AntialiasPlan, x: DVec2, u: f64| {
            let y0 = aa.plan.views[0].warp.a * x.extend(1.0) + aa.plan.views[0].warp.b * s;
            sub_sample_residual(aa, 0, x, y0, s, (u, 0.5), &mut Ties::none())
        };
        // Focus on the background (s = σ = 0.25) at x = 8: the view's ray meets the nearer
        // surface 5 px right of x, and blurs it.
        assert_eq!(hit(&aa, x, 0.5), Some(s - 0.5));
        // The opposite view sees the background: in focus, residual 0.
        assert_eq!(hit(&edge_plan(-g, 0.0, false), x, 0.5), Some(0.0));
        // On the nearer surface itself: its own residual.
        assert_eq!(hit(&aa, DVec2::new(14.0, 0.0), 0.5), Some(s - 0.5));
        // A cell that spans 4 px of parallax per unit: its sub-samples split at the edge. The
        // ray of u meets σ = 0.5 at x + (g + 4(u − ½))(s − 0.5) = 13 − (u − ½): on the surface
        // (≥ 11.5) for every u, so all take its residual; with the view 3 px farther left
        // (x = 5) they land at 10 − (u − ½): none does.
        let wide = edge_plan(g, 4.0, false);
        for u in [0.1, 0.5, 0.9] {
            assert_eq!(hit(&wide, x, u), Some(s - 0.5), "u = {u}");
            assert_eq!(hit(&wide, DVec2::new(5.0, 0.0), u), Some(0.0), "u = {u}");
        }
    }

    #[test]
    fn a_sub_sample_the_view_cannot_see_is_dropped() {
        // Focus on the nearer surface (s = 0.5); the background pixel x = 11, next to its
        // edge, blurs with residual 0.25 over a cell 8 px per unit wide (2 px).
        let s = 0.5;
        let x = DVec2::new(11.0, 0.0);
        let g = -8.0;
        let aa = edge_plan(g, 8.0, true);
        let vis = aa.visibility.as_ref().unwrap();
        // The view sees the nearer surface from 12 − 8·0.5 = 8 on (hiding the background's
        // 10 and 11, which land on 8 and 9), the background left of it.
        assert_eq!(vis.at(0, DVec2::new(8.0, 0.0)), Some(0.5));
        assert_eq!(vis.at(0, DVec2::new(5.0, 0.0)), Some(0.25));
        let y0 = aa.plan.views[0].warp.a * x.extend(1.0) + aa.plan.views[0].warp.b * s;
        let hit = |aa: &AntialiasPlan, u: f64| {
            sub_sample_residual(aa, 0, x, y0, s, (u, 0.5), &mut Ties::none())
        };
        // The plain sample is 11 − 4 = 7; sub-sample u lands at 7 + 2(u − ½). Those on the
        // background in the view keep its residual; those the nearer (focused) surface hides
        // in the view (u = 0.9: 7.8, pixel 8) are dropped, where without the visibility test
        // they would read the focused edge's colour into the blur.
        assert_eq!(hit(&aa, 0.1), Some(s - 0.25));
        assert_eq!(hit(&aa, 0.9), None);
        let blind = edge_plan(g, 8.0, false);
        assert_eq!(hit(&blind, 0.9), Some(s - 0.25));
        // Inside a guard (0.8 px from the plain sample, a 1-px guard) it is not tested.
        let mut guarded = edge_plan(g, 8.0, true);
        guarded.guard_px = 1.0;
        assert_eq!(hit(&guarded, 0.9), Some(s - 0.25));
        guarded.guard_px = 0.75;
        assert_eq!(hit(&guarded, 0.9), None);
        assert_eq!(cell_reach(&aa.depth, x, s), 0.25);
    }

    #[test]
    fn wanted_defaults_to_the_light_fields_own_depth() {
        let mut lf = grid();
        assert!(wanted(None, &lf));
        assert!(!wanted(Some(false), &lf));
        lf.depth.clear();
        assert!(!wanted(None, &lf));
        assert!(wanted(Some(true), &lf));
        let e = plan_for(
            &lf,
            &super::super::plan(
                &lf,
                &super::super::RefocusRequest {
                    focus: super::super::FocusSpec::Disparity(0.0),
                    aperture: Aperture::default(),
                    reference: None,
                },
                &[],
            )
            .unwrap(),
            Aperture::default(),
            &[],
            AntialiasSettings::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("needs the scene's depth"), "{e}");
    }
}
