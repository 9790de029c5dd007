//! Analytic depth views with exact normals, and seeded depth noise: the ground truth of the
//! geometry studies (docs/stability.md, `examples/stability.rs`, `tests/geometry_stability.rs`).
//!
//! No colour is rendered: each pixel centre's ray is intersected with the surfaces exactly
//! (quads through [`Quad::intersect`], spheres in closed form), giving the camera-frame depth
//! ([`DepthKind::Depth`], NaN where nothing is hit) and the true unit normal of the surface
//! there, facing the camera.
//!
//! Noise is multiplicative and Gaussian, `z' = z · (1 + σ·g)` with g ~ N(0, 1) drawn from a
//! xorshift64* generator and the Box–Muller transform, so every study is reproducible from
//! its seed.

use glam::{DVec2, DVec3};

use super::raytrace::pixel_ray;
use super::scene::{plane_scene, Quad};
use super::texture::Texture;
use crate::geometry::camera::Camera;
use crate::geometry::depth::ViewDepth;
use crate::geometry::plane::tilt_swing_normal;
use crate::lightfield::{DepthKind, DepthMap};

/// The depth-edge scene of the stability study: a frontoparallel card at depth `z_front`
/// covering everything left of image column `edge_x` (fractional: between two pixel columns),
/// in front of a plane swung 30° whose depth at the edge is `z_front · (1 + jump)`.
pub fn depth_edge(camera: &Camera, edge_x: f64, z_front: f64, jump: f64) -> [Surface; 2] {
    // World x of the edge column at depth z (parallel camera at the origin).
    let x_at = |z: f64| (edge_x - camera.k.z_axis.x) * z / camera.focal_px();
    let card = Surface::Quad(Quad {
        centre: DVec3::new(x_at(z_front) - 25.0, 0.0, z_front),
        half_u: DVec3::new(25.0, 0.0, 0.0),
        half_v: DVec3::new(0.0, 25.0, 0.0),
        texture: Texture::Solid([1.0; 3]),
    });
    let z_back = z_front * (1.0 + jump);
    let back = Surface::plane(
        -tilt_swing_normal(0.0, 30.0),
        DVec3::new(x_at(z_back), 0.0, z_back),
        100.0,
    );
    [card, back]
}

/// A surface of an analytic depth view.
#[derive(Debug, Clone, PartialEq)]
pub enum Surface {
    /// A textured quad (only its geometry is used).
    Quad(Quad),
    /// A sphere.
    Sphere { centre: DVec3, radius: f64 },
}

impl Surface {
    /// An untextured square of half-side `half` on the plane through `point` with normal
    /// `normal` (the normal may be flipped to face away, as [`plane_scene`] does; only the
    /// plane matters here).
    pub fn plane(normal: DVec3, point: DVec3, half: f64) -> Surface {
        Surface::Quad(plane_scene(normal, point, half, Texture::Solid([1.0; 3])).quads[0].clone())
    }

    /// Nearest hit `t > 0` of the ray `origin + t·dir` and the outward unit normal there.
    fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<(f64, DVec3)> {
        match self {
            Surface::Quad(q) => q.intersect(origin, dir).map(|(t, _)| (t, q.normal())),
            Surface::Sphere { centre, radius } => {
                // |o + t d − c|² = r²  ⇔  a t² + 2 b t + c0 = 0.
                let oc = origin - *centre;
                let a = dir.length_squared();
                let b = oc.dot(dir);
                let c0 = oc.length_squared() - radius * radius;
                let disc = b * b - a * c0;
                if !(disc >= 0.0 && a > 0.0) {
                    return None;
                }
                let sq = disc.sqrt();
                let t = [(-b - sq) / a, (-b + sq) / a]
                    .into_iter()
                    .find(|t| *t > 0.0)?;
                let n = (origin + t * dir - *centre) / *radius;
                Some((t, n))
            }
        }
    }
}

/// An analytic depth view: the depth and, per pixel, the true camera-facing normal and the
/// index of the surface seen.
#[derive(Debug, Clone)]
pub struct AnalyticView {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    /// Exact depth (f32 like every depth map), NaN where no surface is hit.
    pub map: DepthMap,
    /// True unit normal (world frame, facing the camera) per pixel.
    pub normals: Vec<Option<DVec3>>,
    /// Index into the surfaces of the nearest surface per pixel.
    pub surface: Vec<Option<usize>>,
}

impl AnalyticView {
    /// Traces the pixel centres of a `width × height` view of `camera` against `surfaces`.
    pub fn new(camera: Camera, width: u32, height: u32, surfaces: &[Surface]) -> Self {
        let n = width as usize * height as usize;
        let mut values = vec![f32::NAN; n];
        let mut normals = vec![None; n];
        let mut surface = vec![None; n];
        for y in 0..height {
            for x in 0..width {
                let (origin, dir) = pixel_ray(&camera, DVec2::new(x as f64, y as f64));
                let best = surfaces
                    .iter()
                    .enumerate()
                    .filter_map(|(i, s)| s.intersect(origin, dir).map(|(t, n)| (t, n, i)))
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                if let Some((t, nrm, i)) = best {
                    let k = y as usize * width as usize + x as usize;
                    // `dir` has camera-frame z = 1, so t is the depth.
                    values[k] = t as f32;
                    normals[k] = Some(if nrm.dot(origin - (origin + t * dir)) < 0.0 {
                        -nrm
                    } else {
                        nrm
                    });
                    surface[k] = Some(i);
                }
            }
        }
        AnalyticView {
            camera,
            width,
            height,
            map: DepthMap {
                width,
                height,
                kind: DepthKind::Depth,
                values,
                source: "analytic".into(),
                estimated: false,
            },
            normals,
            surface,
        }
    }

    /// The exact depth as a [`ViewDepth`].
    pub fn depth(&self) -> ViewDepth {
        self.noisy_depth(0.0, 0)
    }

    /// The depth with multiplicative Gaussian noise of relative standard deviation `sigma`
    /// (seeded; σ = 0 gives the exact depth).
    pub fn noisy_depth(&self, sigma: f64, seed: u64) -> ViewDepth {
        let mut map = self.map.clone();
        if sigma > 0.0 {
            let mut rng = Rng::new(seed);
            for v in map.values.iter_mut() {
                let g = rng.gaussian();
                if v.is_finite() {
                    *v = (*v as f64 * (1.0 + sigma * g)) as f32;
                }
            }
            map.source = format!("analytic, {:.2} % noise, seed {seed}", 100.0 * sigma);
        }
        // Infallible for a well-formed depth map; an empty view is the only failure mode.
        ViewDepth::new(self.camera, &map, None, None, 0)
            .unwrap_or_else(|e| panic!("analytic view: {e}"))
    }

    /// True normal at pixel (x, y).
    pub fn normal(&self, x: u32, y: u32) -> Option<DVec3> {
        self.normals[y as usize * self.width as usize + x as usize]
    }

    /// Surface index at pixel (x, y).
    pub fn surface_at(&self, x: u32, y: u32) -> Option<usize> {
        self.surface[y as usize * self.width as usize + x as usize]
    }
}

/// xorshift64* with Box–Muller Gaussians: small, fast, deterministic. Not for cryptography.
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
    spare: Option<f64>,
}

impl Rng {
    /// A generator from `seed` (any value, 0 included).
    pub fn new(seed: u64) -> Self {
        // SplitMix64 of the seed: never zero state, well-mixed for nearby seeds.
        let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        Rng {
            state: if z == 0 { 0x2545_F491_4F6C_DD1D } else { z },
            spare: None,
        }
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.state;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.state = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform integer in [lo, hi).
    pub fn range(&mut self, lo: u32, hi: u32) -> u32 {
        lo + (self.uniform() * (hi - lo) as f64) as u32
    }

    /// Standard normal N(0, 1) (Box–Muller, the second value kept for the next call).
    pub fn gaussian(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        // 1 − u ∈ (0, 1]: the logarithm stays finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
        self.spare = Some(r * s);
        r * c
    }
}

/// Angle between two unit normals in degrees, ignoring orientation.
pub fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    a.dot(b).abs().clamp(0.0, 1.0).acos().to_degrees()
}

/// The `q`-quantile (0 ≤ q ≤ 1, nearest rank) of `values`; NaN for an empty set.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    v[k]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::intrinsics;
    use crate::synth::plane_scene;
    use crate::synth::texture::Texture;
    use glam::DMat3;

    fn cam() -> Camera {
        Camera::from_centre(
            intrinsics(40.0, 40.0, 15.5, 15.5),
            DMat3::IDENTITY,
            DVec3::ZERO,
        )
    }

    #[test]
    fn sphere_depth_and_normals_are_exact() {
        let c = DVec3::new(0.0, 0.0, 5.0);
        let v = AnalyticView::new(
            cam(),
            32,
            32,
            &[Surface::Sphere {
                centre: c,
                radius: 1.0,
            }],
        );
        let d = v.depth();
        let p = d.point(15, 15).unwrap();
        assert!(((p - c).length() - 1.0).abs() < 1e-5);
        let n = v.normal(15, 15).unwrap();
        assert!((n - (p - c).normalize()).length() < 1e-5);
        assert!(n.z < 0.0, "faces the camera");
        assert!(v.normal(0, 0).is_none() && d.depth(0, 0).is_none());
    }

    #[test]
    fn quad_normals_face_the_camera() {
        let n = DVec3::new(0.2, -0.3, -1.0).normalize();
        let scene = plane_scene(n, DVec3::new(0.0, 0.0, 3.0), 10.0, Texture::Solid([1.0; 3]));
        let v = AnalyticView::new(cam(), 32, 32, &[Surface::Quad(scene.quads[0].clone())]);
        for (x, y) in [(0, 0), (31, 31)] {
            assert!((v.normal(x, y).unwrap() - n).length() < 1e-12);
        }
    }

    #[test]
    fn noise_is_seeded_and_has_the_requested_spread() {
        let mut a = Rng::new(7);
        let mut b = Rng::new(7);
        let xs: Vec<f64> = (0..20000).map(|_| a.gaussian()).collect();
        assert!(xs
            .iter()
            .zip((0..).map(|_| b.gaussian()))
            .all(|(x, y)| *x == y));
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
        assert!(Rng::new(1).next_u64() != Rng::new(2).next_u64());
        let q = quantile(&[3.0, 1.0, 2.0, 4.0], 0.5);
        assert_eq!(q, 2.0);
        assert!(quantile(&[], 0.5).is_nan());
    }
}
