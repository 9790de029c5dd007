//! Synthetic light fields rendered by the Vulkan mesh rasterizer ([`crate::passes::raster`]):
//! views with exact depth, disparity and normals, parallel (HCI, sensor shift) or converging
//! rigs, and the optical ground truth of a tilt-shift lens.
//!
//! Anti-aliasing: each pixel is the linear-light mean of an n×n stratified grid of jittered
//! pinhole renders (offsets (k + ½)/n − ½ pixels, like the ray tracer's samples), encoded to
//! 8-bit sRGB once. Depth and normals come from one render through the pixel centres.
//!
//! Optical ground truth ([`Rasterizer::optical_ground_truth`]): a thin lens focused on plane Λ
//! is approximated by a dense grid of pinholes A on the reference camera's plane (z = 0 of its
//! frame) inside a disk of radius ρ. Pinhole A projects with
//! `P_A = K_r M_A [R_r | t_r − A]`, `M_A = I + A n_rᵀ / d_A`, where n_r is Λ's normal and
//! d_A = n_r·(p_r − A) its distance from A, both in the reference frame. M_A maps every point of
//! Λ to where the reference camera sees it (so Λ is sharp) while every other point is seen from
//! A; the third row of P_A is still the depth, so the same reverse-Z rasterization applies, with
//! no image resampling. The renders are averaged in linear light.

use std::sync::Arc;

use glam::{DMat3, DVec2, DVec3};
use image::RgbaImage;
use indicatif::{ProgressBar, ProgressStyle};

use crate::error::{Error, Result};
use crate::geometry::camera::Camera;
use crate::geometry::plane::Plane;
use crate::gpu::{GpuContext, GpuOptions};
use crate::lightfield::{DepthKind, DepthMap, LightField, Source, View};
use crate::passes::raster::{camera_from_world, projection_rows, Projection, RasterPass};
use crate::scene::mesh::MeshScene;
use crate::synth::rig::{encode, SynthLightField, SynthRig};

/// Linear RGBA pixels, row-major.
type Pixels = Vec<[f32; 4]>;

/// Samples per submission: keeps command buffers short on real GPUs.
const SAMPLES_PER_SUBMISSION: usize = 128;

/// One rendered view.
#[derive(Debug, Clone)]
pub struct RenderedView {
    /// sRGB-encoded, alpha 255.
    pub image: RgbaImage,
    /// Linear RGB with the background composed in, alpha 1.
    pub linear: Vec<[f32; 4]>,
    /// Camera-frame depth at pixel centres (NaN where nothing is hit), when asked.
    pub depth: Option<DepthMap>,
    /// Camera-frame unit normals facing the camera (NaN where nothing is hit), when asked.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Pixels whose centre sees a surface.
    pub covered: usize,
}

/// A mesh uploaded to a (shared) Vulkan context.
pub struct Rasterizer {
    pass: RasterPass,
    background: [f32; 3],
    name: String,
    ctx: Arc<GpuContext>,
}

/// Stratified sub-pixel offsets (k + ½)/n − ½.
fn offsets(n: u32) -> Vec<f64> {
    let n = n.max(1);
    (0..n).map(|k| (k as f64 + 0.5) / n as f64 - 0.5).collect()
}

impl Rasterizer {
    /// Creates a context and uploads `mesh`.
    pub fn new(mesh: &MeshScene, options: &GpuOptions) -> Result<Self> {
        Self::with_context(Arc::new(GpuContext::new(options)?), mesh)
    }

    /// Uploads `mesh` to a context shared with other passes of the process.
    pub fn with_context(ctx: Arc<GpuContext>, mesh: &MeshScene) -> Result<Self> {
        let pass = RasterPass::new(&ctx, mesh)?;
        Ok(Rasterizer {
            pass,
            background: mesh.background,
            name: mesh.name.clone(),
            ctx,
        })
    }

    /// The Vulkan context (device name, validation counts).
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The mean of `samples` (linear, alpha = coverage), rendered in chunks.
    fn mean(
        &mut self,
        width: u32,
        height: u32,
        samples: &[Projection],
        geometry: Option<&Projection>,
    ) -> Result<(Pixels, Option<Pixels>)> {
        let pass = &mut self.pass;
        let mut sum = vec![[0f32; 4]; (width * height) as usize];
        let mut geom = None;
        // Only renders of several submissions (the optical ground truth) get a progress bar.
        let chunks = samples.len().div_ceil(SAMPLES_PER_SUBMISSION);
        let progress = if chunks > 1 {
            ProgressBar::new(samples.len() as u64).with_style(
                ProgressStyle::with_template("rasterizing {msg} {bar:30} {pos}/{len} pinholes")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            )
        } else {
            ProgressBar::hidden()
        };
        progress.set_message(self.name.clone());
        for (k, chunk) in samples.chunks(SAMPLES_PER_SUBMISSION).enumerate() {
            let img = pass.render(
                &self.ctx,
                width,
                height,
                chunk,
                if k == 0 { geometry } else { None },
            )?;
            let w = chunk.len() as f32 / samples.len() as f32;
            for (s, c) in sum.iter_mut().zip(&img.color) {
                for i in 0..4 {
                    s[i] += c[i] * w;
                }
            }
            if img.geometry.is_some() {
                geom = img.geometry;
            }
            progress.inc(chunk.len() as u64);
        }
        progress.finish_and_clear();
        Ok((sum, geom))
    }

    /// Renders `camera`'s `width × height` view with `samples_per_axis`² jittered samples per
    /// pixel; with `geometry`, also its depth and normals.
    pub fn render_view(
        &mut self,
        camera: &Camera,
        width: u32,
        height: u32,
        samples_per_axis: u32,
        geometry: bool,
    ) -> Result<RenderedView> {
        let offs = offsets(samples_per_axis);
        let samples: Vec<Projection> = offs
            .iter()
            .flat_map(|&oy| offs.iter().map(move |&ox| DVec2::new(ox, oy)))
            .map(|o| Projection::of_camera(camera, width, height, o))
            .collect();
        let centre = Projection::of_camera(camera, width, height, DVec2::ZERO);
        let (color, geom) = self.mean(width, height, &samples, geometry.then_some(&centre))?;
        let linear = self.compose(&color);
        let image = encode(&linear, width, height);
        let mut out = RenderedView {
            image,
            linear,
            depth: None,
            normals: None,
            covered: 0,
        };
        if let Some(g) = geom {
            let hit = |p: &[f32; 4]| p[3] > 0.0 && p[3].is_finite();
            out.covered = g.iter().filter(|p| hit(p)).count();
            out.depth = Some(DepthMap {
                width,
                height,
                kind: DepthKind::Depth,
                values: g
                    .iter()
                    .map(|p| if hit(p) { p[3] } else { f32::NAN })
                    .collect(),
                source: "generated".into(),
                estimated: false,
            });
            out.normals = Some(
                g.iter()
                    .map(|p| {
                        if hit(p) {
                            [p[0], p[1], p[2]]
                        } else {
                            [f32::NAN; 3]
                        }
                    })
                    .collect(),
            );
        }
        Ok(out)
    }

    /// The image a thin lens at the `reference` camera focused on `plane` would take: the
    /// linear-light mean of pinhole renders from an `aperture_samples × aperture_samples` grid
    /// over [−ρ, ρ]² on the reference camera plane, kept inside the disk of radius
    /// `aperture_radius` ρ (world units), the `samples_per_axis`² sub-pixel jitters shared
    /// out among the pinholes (each jitter equally often, in a fixed shuffled order:
    /// [`balanced_jitters`]).
    /// Returns linear RGBA (alpha 1) and the number of pinholes used.
    pub fn optical_ground_truth(
        &mut self,
        reference: &Camera,
        plane: &Plane,
        aperture_radius: f64,
        aperture_samples: u32,
        (width, height): (u32, u32),
        samples_per_axis: u32,
    ) -> Result<(Vec<[f32; 4]>, usize)> {
        if !(aperture_radius.is_finite() && aperture_radius >= 0.0) {
            return Err(Error::Invalid(format!(
                "the aperture radius must be finite and ≥ 0, got {aperture_radius}"
            )));
        }
        let n_r = reference.r * plane.normal;
        let p_r = reference.to_camera(plane.point);
        let grid = aperture_samples.max(1);
        let offs = offsets(samples_per_axis);
        let m = offs.len();
        let mut apertures = Vec::new();
        for j in 0..grid {
            for i in 0..grid {
                let coord = |k: u32| {
                    if grid == 1 {
                        0.0
                    } else {
                        aperture_radius * (2.0 * k as f64 / (grid - 1) as f64 - 1.0)
                    }
                };
                let a = DVec3::new(coord(i), coord(j), 0.0);
                if a.length() > aperture_radius * (1.0 + 1e-9) {
                    continue;
                }
                let d_a = n_r.dot(p_r - a);
                if d_a.abs() < 1e-9 {
                    return Err(Error::Geometry(
                        "the focus plane passes through the lens aperture".into(),
                    ));
                }
                apertures.push((a, d_a));
            }
        }
        let jitters = balanced_jitters(apertures.len(), m * m);
        let samples: Vec<Projection> = apertures
            .iter()
            .zip(jitters)
            .map(|(&(a, d_a), k)| {
                let mm = DMat3::IDENTITY + outer(a, n_r) / d_a;
                let rows = projection_rows(reference.k * mm, reference.r, reference.t - a);
                let jitter = DVec2::new(offs[k % m], offs[k / m]);
                Projection::new(
                    rows,
                    camera_from_world(reference.r, reference.t - a),
                    width,
                    height,
                    jitter,
                )
            })
            .collect();
        let (color, _) = self.mean(width, height, &samples, None)?;
        Ok((self.compose(&color), samples.len()))
    }

    /// Composes the background into a mean of samples; alpha becomes 1.
    fn compose(&self, color: &[[f32; 4]]) -> Vec<[f32; 4]> {
        let b = self.background;
        color
            .iter()
            .map(|c| {
                let a = 1.0 - c[3].clamp(0.0, 1.0);
                [c[0] + b[0] * a, c[1] + b[1] * a, c[2] + b[2] * a, 1.0]
            })
            .collect()
    }

    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Fails, naming the limit, unless views of `width × height` fit the device as render
    /// targets (RGBA32F colour and geometry, 16 bytes a pixel each): checked before anything
    /// is allocated for them.
    pub fn check_view_size(&self, width: u32, height: u32) -> Result<()> {
        let limits = crate::passes::texture::TextureLimits::of(&self.ctx);
        let bytes = width as u64 * height as u64 * 16;
        crate::passes::texture::check_fits(1, width, height, bytes, &limits, &self.ctx.info.name)
    }
}

/// Which of `jitters` sub-pixel jitters each of `count` pinholes takes: every jitter equally
/// often (to within one), in an order shuffled by a fixed seed.
///
/// Why shuffled: with the jitter a function of the pinhole's place on the aperture grid (the
/// earlier (i mod n, j mod n)), an out-of-focus point's image position (jitter plus residual
/// disparity times aperture position) ran over a lattice rather than the whole disc, and the
/// truth aliased: scores against it moved by up to 1.4 dB, not monotonically, with the views'
/// supersampling (`layers-near` 38.3 dB at 3 jitters a side, 36.9 at 6). Why balanced: on the
/// focus plane every pinhole sees the same point, so the lens must average the jitters exactly
/// as a view's supersampling does.
pub fn balanced_jitters(count: usize, jitters: usize) -> Vec<usize> {
    let jitters = jitters.max(1);
    let mut order: Vec<usize> = (0..count).map(|k| k % jitters).collect();
    // Fisher-Yates with splitmix64: deterministic, so the truth is the same on every run.
    let mut state = 0x5eed_u64;
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    for i in (1..order.len()).rev() {
        let j = (next() % (i as u64 + 1)) as usize;
        order.swap(i, j);
    }
    order
}

fn outer(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x, u * v.y, u * v.z)
}

/// Renders every view of `rig` (with a progress bar on stderr). The reference view
/// (`grid.index(cols / 2, rows / 2)`) gets depth and, for parallel rigs, HCI disparity;
/// with `depth_all_views` every view gets its depth. Fails when the reference view sees no
/// surface at all.
pub fn render_light_field(
    r: &mut Rasterizer,
    rig: &SynthRig,
    samples_per_axis: u32,
    depth_all_views: bool,
) -> Result<SynthLightField> {
    let cameras = rig.cameras();
    let grid = rig.grid;
    let name = r.name().to_string();
    let progress = ProgressBar::new(cameras.len() as u64).with_style(
        ProgressStyle::with_template("rasterizing {msg} {bar:30} {pos}/{len} views")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    progress.set_message(name.clone());
    let reference = grid.index(grid.cols / 2, grid.rows / 2);
    let mut views = Vec::with_capacity(cameras.len());
    let mut depth = Vec::new();
    let mut normals = Vec::new();
    for (index, camera) in cameras.into_iter().enumerate() {
        let (s, t) = (index % grid.cols, index / grid.cols);
        let want = depth_all_views || index == reference;
        let v = r.render_view(&camera, rig.width, rig.height, samples_per_axis, want)?;
        if index == reference {
            if v.covered == 0 {
                progress.finish_and_clear();
                return Err(Error::Invalid(format!(
                    "{name}: nothing in view: the reference camera sees no triangle (check the \
                     camera placement, --focal-mm and the scene's scale)"
                )));
            }
            normals = v.normals.clone().unwrap_or_default();
        }
        if let Some(z) = v.depth {
            let z = DepthMap {
                source: format!("{name} generated depth of view ({s},{t})"),
                ..z
            };
            if index == reference {
                if let Some(p) = rig.parallel() {
                    depth.push((
                        index,
                        z.to_disparity(&p, format!("{name} generated disparity of view ({s},{t})")),
                    ));
                }
            }
            depth.push((index, z));
        }
        views.push(View {
            s,
            t,
            camera,
            image: v.image,
            source: format!("{name} view ({s},{t})"),
        });
        progress.inc(1);
    }
    progress.finish_and_clear();
    let light_field = LightField {
        name: name.clone(),
        grid,
        width: rig.width,
        height: rig.height,
        views,
        depth,
        rig: rig.parallel(),
        disparity_range: None,
        source: Source::Generated { scene: name },
    };
    light_field.validate()?;
    Ok(SynthLightField {
        light_field,
        reference,
        normals,
    })
}

#[cfg(test)]
mod tests {
    use super::balanced_jitters;

    #[test]
    fn jitters_are_balanced_fixed_and_not_tied_to_the_pinholes_order() {
        let (count, m) = (12_853, 64);
        let a = balanced_jitters(count, m);
        assert_eq!(a, balanced_jitters(count, m), "the same on every call");
        let mut uses = vec![0usize; m];
        for &k in &a {
            uses[k] += 1;
        }
        let (lo, hi) = (count / m, count.div_ceil(m));
        assert!(uses.iter().all(|&u| u == lo || u == hi), "{uses:?}");
        // Shuffled: the pinholes' order no longer decides the jitter (about 1 in m agree).
        let same = a.iter().enumerate().filter(|&(i, &k)| k == i % m).count();
        assert!(same < 3 * count / m, "{same} of {count} in order");
        assert_eq!(balanced_jitters(0, m), Vec::<usize>::new());
        assert_eq!(balanced_jitters(5, 0), vec![0; 5]);
    }
}
