//! Scenes of textured parallelograms ("quads") and smooth solids (ellipsoids, open cylinders:
//! the curved surfaces of the depth test set) and their exact ray intersection.
//!
//! A [`Quad`] is the parallelogram `centre + a·half_u + b·half_v`, a, b ∈ [−1, 1], with texture
//! coordinates u = (a + 1)/2, v = (b + 1)/2 and plane normal `normalize(half_u × half_v)`.
//! Coordinates are world coordinates (for the built-in scenes the world frame is the centre
//! camera's frame: x right, y down, z forward).

use glam::{DVec2, DVec3};

use super::texture::{Rgb, Texture};

/// A textured parallelogram.
#[derive(Debug, Clone, PartialEq)]
pub struct Quad {
    pub centre: DVec3,
    /// Half of the edge along which texture u grows.
    pub half_u: DVec3,
    /// Half of the edge along which texture v grows.
    pub half_v: DVec3,
    pub texture: Texture,
}

/// The nearest intersection of a ray with a scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter: `point = origin + t·dir`, in units of the (not necessarily unit) `dir`.
    pub t: f64,
    /// World position of the hit.
    pub point: DVec3,
    /// Index into [`Scene::quads`], or `quads.len() + k` for [`Scene::solids`]`[k]`.
    pub quad_index: usize,
    /// Texture coordinates in [0, 1]².
    pub uv: DVec2,
}

/// Quads and solids plus a background colour for rays that hit nothing.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scene {
    pub quads: Vec<Quad>,
    /// Linear-light background colour.
    pub background: Rgb,
    /// Curved surfaces, traced by the CPU ray tracer only (the rasterizer's meshes are baked
    /// from the quads: [`crate::synth::mesh`]).
    pub solids: Vec<Solid>,
    /// Shading by an area light (CPU ray tracer only); `None`: every surface shows its albedo,
    /// as the rasterizer's views do.
    pub lighting: Option<Lighting>,
}

/// An area light over the scene, so that views look like renderer output rather than flat
/// albedo: Lambertian shading, soft shadows (stratified shadow rays to the light), an ambient
/// term and a mild Blinn-Phong highlight. The light samples are the same for every shading
/// point and every view, so the diffuse part is the same radiance from every camera (only the
/// highlight depends on the view, as on real surfaces).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lighting {
    /// The light's centre and half edges (a parallelogram emitting on both sides).
    pub centre: DVec3,
    pub half_u: DVec3,
    pub half_v: DVec3,
    /// Linear-light irradiance of a surface facing the light squarely at distance 1 per unit
    /// of light area, per channel.
    pub power: Rgb,
    /// Light reaching every surface whatever it faces (a stand-in for interreflection).
    pub ambient: f32,
    /// Shadow rays per axis of the light (n² in all).
    pub samples: u32,
    /// Strength and exponent of the Blinn-Phong highlight (0: none).
    pub specular: f32,
    pub shininess: f32,
}

/// A smooth textured solid.
#[derive(Debug, Clone, PartialEq)]
pub enum Solid {
    /// The ellipsoid `Σ ((x − centre)ᵢ / radiiᵢ)² = 1` (axis-aligned; a sphere for equal radii).
    /// Texture u runs once around the vertical (y) axis, v from top (0) to bottom (1).
    Ellipsoid {
        centre: DVec3,
        radii: DVec3,
        texture: Texture,
    },
    /// The open tube of `radius` around the segment `centre ± half_height·axis` (no caps: a ray
    /// past the near wall sees the inside of the far wall). Texture u runs around the axis, v
    /// along it.
    Cylinder {
        centre: DVec3,
        axis: DVec3,
        radius: f64,
        half_height: f64,
        texture: Texture,
    },
}

impl Solid {
    pub fn texture(&self) -> &Texture {
        match self {
            Solid::Ellipsoid { texture, .. } | Solid::Cylinder { texture, .. } => texture,
        }
    }

    /// The nearest `(t, uv)` with t > 0 of the ray `origin + t·dir` on this surface.
    pub fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<(f64, DVec2)> {
        match *self {
            Solid::Ellipsoid { centre, radii, .. } => {
                if radii.min_element().is_nan() || radii.min_element() <= 0.0 {
                    return None;
                }
                // In the frame scaled by the radii the ellipsoid is the unit sphere.
                let o = (origin - centre) / radii;
                let d = dir / radii;
                let q = o + first_root(
                    d.length_squared(),
                    o.dot(d),
                    o.length_squared() - 1.0,
                    |_| true,
                )? * d;
                let t = (q * radii + centre - origin).dot(dir) / dir.length_squared();
                let u = 0.5 + q.x.atan2(-q.z) / std::f64::consts::TAU;
                let v = q.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
                Some((t, DVec2::new(u, v)))
            }
            Solid::Cylinder {
                centre,
                axis,
                radius,
                half_height,
                ..
            } => {
                let a = axis.normalize_or_zero();
                if a == DVec3::ZERO || !(radius > 0.0 && half_height > 0.0) {
                    return None;
                }
                let e1 = a.any_orthonormal_vector();
                let e2 = a.cross(e1);
                let rel = origin - centre;
                // The ray's component across the axis, in units of the radius.
                let o = DVec2::new(rel.dot(e1), rel.dot(e2)) / radius;
                let d = DVec2::new(dir.dot(e1), dir.dot(e2)) / radius;
                let height = |t: f64| (rel + t * dir).dot(a);
                let t = first_root(
                    d.length_squared(),
                    o.dot(d),
                    o.length_squared() - 1.0,
                    |t| height(t).abs() <= half_height,
                )?;
                let p = o + t * d;
                let u = 0.5 + p.y.atan2(p.x) / std::f64::consts::TAU;
                let v = (height(t) / half_height + 1.0) / 2.0;
                Some((t, DVec2::new(u, v)))
            }
        }
    }
}

/// The smaller root t > 0 of `a t² + 2 b t + c = 0` that `keep` accepts, else the larger.
fn first_root(a: f64, b: f64, c: f64, keep: impl Fn(f64) -> bool) -> Option<f64> {
    let disc = b * b - a * c;
    if !(a > 0.0 && disc >= 0.0 && disc.is_finite()) {
        return None;
    }
    let r = disc.sqrt();
    [(-b - r) / a, (-b + r) / a]
        .into_iter()
        .find(|&t| t > 0.0 && t.is_finite() && keep(t))
}

impl Quad {
    /// Unit normal `normalize(half_u × half_v)`; zero for a degenerate quad.
    pub fn normal(&self) -> DVec3 {
        self.half_u.cross(self.half_v).normalize_or_zero()
    }

    /// World point at texture coordinates `uv`.
    pub fn point_at(&self, uv: DVec2) -> DVec3 {
        self.centre + (2.0 * uv.x - 1.0) * self.half_u + (2.0 * uv.y - 1.0) * self.half_v
    }

    /// The corners at uv = (0,0), (1,0), (1,1), (0,1), in that order (a closed outline).
    pub fn corners(&self) -> [DVec3; 4] {
        [
            self.centre - self.half_u - self.half_v,
            self.centre + self.half_u - self.half_v,
            self.centre + self.half_u + self.half_v,
            self.centre - self.half_u + self.half_v,
        ]
    }

    /// Intersection of the ray `origin + t·dir` with this quad: `(t, uv)` for t > 0, or `None`
    /// (miss, ray parallel to the plane, degenerate quad, non-finite input).
    pub fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<(f64, DVec2)> {
        Prepared::new(self).and_then(|p| p.intersect(origin, dir))
    }
}

/// A quad's intersection data, derived once per render instead of once per ray. Every
/// intersection in this module goes through it, so the renderer and [`Quad::intersect`] agree
/// bit for bit.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Prepared {
    centre: DVec3,
    /// Unit normal `normalize(half_u × half_v)`.
    n: DVec3,
    /// Dual basis of (half_u, half_v) within the plane: `rel·du = a`, `rel·dv = b`.
    du: DVec3,
    dv: DVec3,
}

impl Prepared {
    /// `None` for a degenerate (zero-area or non-finite) quad, which no ray hits.
    pub(crate) fn new(q: &Quad) -> Option<Self> {
        let m = q.half_u.cross(q.half_v);
        let mm = m.length_squared();
        if !(mm > 0.0 && mm.is_finite() && q.centre.is_finite()) {
            return None;
        }
        // (hv × m)·hu = (m × hu)·hv = |m|², and both are orthogonal to the other edge.
        Some(Prepared {
            centre: q.centre,
            n: m / mm.sqrt(),
            du: q.half_v.cross(m) / mm,
            dv: m.cross(q.half_u) / mm,
        })
    }

    pub(crate) fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<(f64, DVec2)> {
        let denom = self.n.dot(dir);
        if denom == 0.0 {
            return None;
        }
        let t = self.n.dot(self.centre - origin) / denom;
        if !(t > 0.0 && t.is_finite()) {
            return None;
        }
        let rel = origin + t * dir - self.centre;
        let (a, b) = (rel.dot(self.du), rel.dot(self.dv));
        (a.abs() <= 1.0 && b.abs() <= 1.0)
            .then(|| (t, DVec2::new((a + 1.0) / 2.0, (b + 1.0) / 2.0)))
    }
}

/// A scene with its quads prepared for many rays; `prepared[i]` is `None` for a degenerate quad.
pub(crate) struct PreparedScene<'a> {
    prepared: Vec<Option<Prepared>>,
    solids: &'a [Solid],
}

impl<'a> PreparedScene<'a> {
    pub(crate) fn new(scene: &'a Scene) -> Self {
        PreparedScene {
            prepared: scene.quads.iter().map(Prepared::new).collect(),
            solids: &scene.solids,
        }
    }

    /// See [`Scene::intersect`].
    pub(crate) fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<Hit> {
        let hit = nearest(origin, dir, self.prepared.iter().copied());
        nearest_solid(hit, self.prepared.len(), self.solids, origin, dir)
    }
}

/// `hit` or a nearer hit on one of `solids` (indices after the `quads` quads).
fn nearest_solid(
    hit: Option<Hit>,
    quads: usize,
    solids: &[Solid],
    origin: DVec3,
    dir: DVec3,
) -> Option<Hit> {
    let mut best = hit;
    for (k, solid) in solids.iter().enumerate() {
        if let Some((t, uv)) = solid.intersect(origin, dir) {
            if best.map_or(true, |b| t < b.t) {
                best = Some(Hit {
                    t,
                    point: origin + t * dir,
                    quad_index: quads + k,
                    uv,
                });
            }
        }
    }
    best
}

/// The nearest hit among `quads` (in scene order, `None` = degenerate).
fn nearest(
    origin: DVec3,
    dir: DVec3,
    quads: impl Iterator<Item = Option<Prepared>>,
) -> Option<Hit> {
    let mut best: Option<(f64, usize, DVec2)> = None;
    for (i, p) in quads.enumerate() {
        if let Some((t, uv)) = p.and_then(|p| p.intersect(origin, dir)) {
            // `Option::is_none_or` needs Rust 1.82; the crate supports 1.80.
            if best.map_or(true, |(bt, _, _)| t < bt) {
                best = Some((t, i, uv));
            }
        }
    }
    best.map(|(t, quad_index, uv)| Hit {
        t,
        point: origin + t * dir,
        quad_index,
        uv,
    })
}

impl Scene {
    /// The nearest hit with t > 0 of the ray `origin + t·dir`, or `None`. Ties (coincident
    /// quads) go to the quad listed first, so results are deterministic. For many rays the
    /// renderer prepares the quads once; the arithmetic is the same.
    pub fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<Hit> {
        let hit = nearest(origin, dir, self.quads.iter().map(Prepared::new));
        nearest_solid(hit, self.quads.len(), &self.solids, origin, dir)
    }

    /// The unit normal of the surface at `hit`, facing the ray's origin `origin`.
    pub fn normal_at(&self, hit: &Hit, origin: DVec3) -> DVec3 {
        let n = match self.quads.get(hit.quad_index) {
            Some(q) => q.normal(),
            None => match self.solids.get(hit.quad_index - self.quads.len()) {
                Some(Solid::Ellipsoid { centre, radii, .. }) => {
                    ((hit.point - *centre) / (*radii * *radii)).normalize_or_zero()
                }
                Some(Solid::Cylinder { centre, axis, .. }) => {
                    let a = axis.normalize_or_zero();
                    let rel = hit.point - *centre;
                    (rel - a * rel.dot(a)).normalize_or_zero()
                }
                None => DVec3::ZERO,
            },
        };
        if n.dot(origin - hit.point) < 0.0 {
            -n
        } else {
            n
        }
    }

    /// Linear-light colour seen from `origin` at `hit` (or the background): the albedo alone
    /// without [`Scene::lighting`], else the albedo times the ambient term plus the light's
    /// irradiance over its unshadowed samples, and the highlight. `occluded(from, to)` says
    /// whether anything lies on the segment (the renderer's prepared scene).
    pub fn shade(
        &self,
        hit: Option<&Hit>,
        origin: DVec3,
        occluded: impl Fn(DVec3, DVec3) -> bool,
    ) -> Rgb {
        let albedo = self.radiance(hit);
        let (Some(h), Some(l)) = (hit, self.lighting) else {
            return albedo;
        };
        let n = self.normal_at(h, origin);
        let view = (origin - h.point).normalize_or_zero();
        let light_normal = l.half_u.cross(l.half_v);
        let area = 4.0 * light_normal.length();
        let light_normal = light_normal.normalize_or_zero();
        let count = l.samples.max(1);
        // Off the surface by a hair so the shadow ray does not hit its own start.
        let start = h.point + n * 1e-6 * (1.0 + h.point.length());
        let (mut diffuse, mut highlight) = (0f64, 0f64);
        for j in 0..count {
            for i in 0..count {
                let a = (i as f64 + 0.5) / count as f64 * 2.0 - 1.0;
                let b = (j as f64 + 0.5) / count as f64 * 2.0 - 1.0;
                let p = l.centre + a * l.half_u + b * l.half_v;
                let to = p - h.point;
                let d2 = to.length_squared();
                let dir = to / d2.sqrt();
                let cos_s = n.dot(dir);
                let cos_l = light_normal.dot(dir).abs();
                if cos_s <= 0.0 || occluded(start, p) {
                    continue;
                }
                let g = cos_s * cos_l / d2;
                diffuse += g;
                let half = (dir + view).normalize_or_zero();
                highlight += g * n.dot(half).max(0.0).powf(l.shininess as f64);
            }
        }
        let scale = area / (count * count) as f64;
        let (diffuse, highlight) = ((diffuse * scale) as f32, (highlight * scale) as f32);
        std::array::from_fn(|k| {
            albedo[k] * (l.ambient + l.power[k] * diffuse) + l.specular * l.power[k] * highlight
        })
    }

    /// Linear-light colour seen along the ray: the hit surface's texture, or the background.
    pub fn radiance(&self, hit: Option<&Hit>) -> Rgb {
        let Some(h) = hit else {
            return self.background;
        };
        let texture = match self.quads.get(h.quad_index) {
            Some(q) => Some(&q.texture),
            None => self
                .solids
                .get(h.quad_index - self.quads.len())
                .map(Solid::texture),
        };
        texture.map_or(self.background, |t| t.eval(h.uv))
    }
}

/// A scene of one square quad of side `2·half_size` centred at `point` in the plane with normal
/// `normal`, on a black background — the building block of plane-focus tests.
///
/// The texture's u axis follows world x projected into the plane (world y when the plane is
/// perpendicular to x), and the quad's normal (`half_u × half_v`) is `normal` flipped, if
/// needed, to point away from the world origin (the centre camera), like every quad of the
/// built-in scenes; with that orientation v follows world y (down), so textures read upright.
/// A zero normal or size gives a degenerate quad that no ray hits.
pub fn plane_scene(normal: DVec3, point: DVec3, half_size: f64, texture: Texture) -> Scene {
    let mut n = normal.normalize_or_zero();
    if n.dot(point) < 0.0 {
        n = -n;
    }
    let along = |axis: DVec3| (axis - n * n.dot(axis)).normalize_or_zero();
    let mut u = along(DVec3::X);
    if u.length_squared() < 0.5 {
        u = along(DVec3::Y);
    }
    // hu × (n × hu) = n |hu|², so the quad's normal is n.
    let v = n.cross(u);
    Scene {
        quads: vec![Quad {
            centre: point,
            half_u: u * half_size,
            half_v: v * half_size,
            texture,
        }],
        background: [0.0; 3],
        solids: Vec::new(),
        lighting: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn white(centre: DVec3, hu: DVec3, hv: DVec3) -> Quad {
        Quad {
            centre,
            half_u: hu,
            half_v: hv,
            texture: Texture::Solid([1.0; 3]),
        }
    }

    #[test]
    fn hits_inside_misses_outside() {
        let q = white(DVec3::new(0.0, 0.0, 2.0), DVec3::X, DVec3::Y * 0.5);
        let (t, uv) = q
            .intersect(DVec3::ZERO, DVec3::new(0.25, 0.1, 1.0))
            .unwrap();
        assert!((t - 2.0).abs() < 1e-15);
        assert!((uv - DVec2::new(0.75, 0.7)).length() < 1e-12);
        assert!(q
            .intersect(DVec3::ZERO, DVec3::new(0.6, 0.0, 1.0))
            .is_none());
        assert!(q
            .intersect(DVec3::ZERO, DVec3::new(0.0, 0.3, 1.0))
            .is_none());
        // Behind the origin and parallel rays miss.
        assert!(q
            .intersect(DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0))
            .is_none());
        assert!(q.intersect(DVec3::ZERO, DVec3::X).is_none());
        // Degenerate quads and NaN rays miss instead of producing garbage.
        let flat = white(DVec3::Z, DVec3::X, DVec3::X * 2.0);
        assert!(flat.intersect(DVec3::ZERO, DVec3::Z).is_none());
        assert!(q.intersect(DVec3::ZERO, DVec3::NAN).is_none());
    }

    #[test]
    fn uv_round_trips_through_point_at_on_a_skew_quad() {
        let q = white(
            DVec3::new(0.3, -0.2, 3.0),
            DVec3::new(0.8, 0.1, -0.4),
            DVec3::new(0.2, 0.7, 0.3),
        );
        let origin = DVec3::new(0.1, 0.05, -0.2);
        // Not exactly on the border: rounding may put a corner a hair outside.
        for &(u, v) in &[(0.1, 0.2), (0.5, 0.5), (0.93, 0.07), (1e-9, 1.0 - 1e-9)] {
            let p = q.point_at(DVec2::new(u, v));
            let (t, uv) = q.intersect(origin, p - origin).unwrap();
            assert!((t - 1.0).abs() < 1e-12);
            assert!(
                (uv - DVec2::new(u, v)).length() < 1e-12,
                "{uv} vs ({u}, {v})"
            );
        }
    }

    #[test]
    fn nearest_hit_wins() {
        let scene = Scene {
            quads: vec![
                white(DVec3::new(0.0, 0.0, 5.0), DVec3::X, DVec3::Y),
                white(DVec3::new(0.0, 0.0, 2.0), DVec3::X, DVec3::Y),
            ],
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: None,
        };
        let h = scene.intersect(DVec3::ZERO, DVec3::Z).unwrap();
        assert_eq!(h.quad_index, 1);
        assert_eq!(h.point, DVec3::new(0.0, 0.0, 2.0));
        assert!(scene
            .intersect(DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0))
            .is_none());
        assert_eq!(scene.radiance(None), [0.0; 3]);
        assert_eq!(scene.radiance(Some(&h)), [1.0; 3]);
    }

    #[test]
    fn solids_are_hit_at_their_surface_and_the_nearest_surface_wins() {
        let ball = Solid::Ellipsoid {
            centre: DVec3::new(0.0, 0.0, 3.0),
            radii: DVec3::new(1.0, 2.0, 0.5),
            texture: Texture::Solid([0.5; 3]),
        };
        let (t, _) = ball.intersect(DVec3::ZERO, DVec3::Z).unwrap();
        assert!((t - 2.5).abs() < 1e-12, "{t}");
        // Every hit lies on the surface.
        for dir in [DVec3::new(0.2, 0.3, 1.0), DVec3::new(-0.1, 0.5, 1.0)] {
            let (t, _) = ball.intersect(DVec3::ZERO, dir).unwrap();
            let q = (t * dir - DVec3::new(0.0, 0.0, 3.0)) / DVec3::new(1.0, 2.0, 0.5);
            assert!((q.length() - 1.0).abs() < 1e-12);
        }
        assert!(ball
            .intersect(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0))
            .is_none());
        let tube = Solid::Cylinder {
            centre: DVec3::new(0.0, 0.0, 4.0),
            axis: DVec3::Y,
            radius: 0.5,
            half_height: 1.0,
            texture: Texture::Solid([0.25; 3]),
        };
        let (t, uv) = tube.intersect(DVec3::ZERO, DVec3::Z).unwrap();
        assert!((t - 3.5).abs() < 1e-12 && (uv.y - 0.5).abs() < 1e-12);
        // Above the tube's top: a miss; degenerate solids miss.
        assert!(tube
            .intersect(DVec3::ZERO, DVec3::new(0.0, 0.5, 1.0))
            .is_none());
        let flat = Solid::Ellipsoid {
            centre: DVec3::Z,
            radii: DVec3::new(1.0, 0.0, 1.0),
            texture: Texture::Solid([1.0; 3]),
        };
        assert!(flat.intersect(DVec3::ZERO, DVec3::Z).is_none());
        let scene = Scene {
            quads: vec![white(DVec3::new(0.0, 0.0, 3.2), DVec3::X, DVec3::Y)],
            solids: vec![ball, tube],
            ..Default::default()
        };
        let h = scene.intersect(DVec3::ZERO, DVec3::Z).unwrap();
        assert_eq!(h.quad_index, 1);
        assert_eq!(scene.radiance(Some(&h)), [0.5; 3]);
        // Without the ball the quad (z = 3.2) is nearer than the tube (z = 3.5); the prepared
        // scene the renderer uses agrees.
        let scene = Scene {
            solids: scene.solids[1..].to_vec(),
            ..scene
        };
        let h = PreparedScene::new(&scene)
            .intersect(DVec3::ZERO, DVec3::Z)
            .unwrap();
        assert_eq!(h.quad_index, 0);
        let far = Scene {
            quads: vec![white(DVec3::new(0.0, 0.0, 9.0), DVec3::X, DVec3::Y)],
            ..scene
        };
        assert_eq!(far.intersect(DVec3::ZERO, DVec3::Z).unwrap().quad_index, 1);
    }

    #[test]
    fn plane_scene_has_the_requested_plane_and_upright_texture() {
        let n = DVec3::new(0.0, -0.5, -1.0).normalize();
        let p = DVec3::new(0.1, 0.2, 3.0);
        let s = plane_scene(n, p, 2.0, Texture::Solid([1.0; 3]));
        let q = &s.quads[0];
        // Same plane, normal flipped to point away from the origin.
        assert!((q.normal() + n).length() < 1e-12);
        assert!(q.half_u.dot(n).abs() < 1e-12 && q.half_v.dot(n).abs() < 1e-12);
        assert!((q.half_u.length() - 2.0).abs() < 1e-12);
        assert!((q.half_v.length() - 2.0).abs() < 1e-12);
        assert!(q.half_u.x > 0.0 && q.half_v.y > 0.0);
        // A plane perpendicular to x still gets a valid basis.
        let s = plane_scene(
            DVec3::X,
            DVec3::new(1.0, 0.0, 0.0),
            1.0,
            Texture::Solid([1.0; 3]),
        );
        assert!((s.quads[0].normal() - DVec3::X).length() < 1e-12);
        // Degenerate input: no panic, nothing is hit.
        let s = plane_scene(DVec3::ZERO, DVec3::Z, 1.0, Texture::Solid([1.0; 3]));
        assert!(s.intersect(DVec3::ZERO, DVec3::Z).is_none());
    }

    /// A white square of side 2 at z = 3 facing the cameras, a small square light 1 above it
    /// shining down, nothing else.
    fn lit(occluder: bool, specular: f32) -> Scene {
        let mut quads = vec![white(DVec3::new(0.0, 0.0, 3.0), DVec3::X, DVec3::Z)];
        if occluder {
            quads.push(white(
                DVec3::new(0.0, -0.5, 3.0),
                DVec3::X * 0.3,
                DVec3::Z * 0.3,
            ));
        }
        Scene {
            quads,
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: Some(Lighting {
                centre: DVec3::new(0.0, -1.0, 3.0),
                half_u: DVec3::X * 0.01,
                half_v: DVec3::Z * 0.01,
                power: [2.0, 2.0, 2.0],
                ambient: 0.1,
                samples: 2,
                specular,
                shininess: 10.0,
            }),
        }
    }

    fn shade_at(scene: &Scene, origin: DVec3, p: DVec3) -> Rgb {
        let h = scene.intersect(origin, p - origin).unwrap();
        scene.shade(Some(&h), origin, |a, b| {
            scene.intersect(a, b - a).is_some_and(|h| h.t < 1.0)
        })
    }

    #[test]
    fn a_lit_surface_is_lambertian_and_a_shadowed_one_gets_the_ambient_term() {
        // The floor quad (normal ±y) under a light 1 above: E = area · cos · cos / d² with
        // both cosines 1 below the light's centre, and cos³/d² off to the side.
        let scene = lit(false, 0.0);
        let area = 4.0 * 0.01 * 0.01;
        let below = shade_at(
            &scene,
            DVec3::new(0.0, -0.5, 0.0),
            DVec3::new(0.0, 0.0, 3.0),
        );
        let want = 0.1 + 2.0 * area;
        assert!(
            (below[0] as f64 - want).abs() < 1e-4 * want,
            "{below:?} vs {want}"
        );
        let side = shade_at(
            &scene,
            DVec3::new(0.0, -0.5, 0.0),
            DVec3::new(0.8, 0.0, 3.0),
        );
        let d2: f64 = 1.0 + 0.64;
        let want_side = 0.1 + 2.0 * area * (1.0 / d2.sqrt()).powi(2) / d2;
        assert!(
            (side[0] as f64 - want_side).abs() < 1e-3 * want_side,
            "{side:?}"
        );
        // The same point seen from elsewhere: the diffuse radiance does not depend on the view.
        let other = shade_at(
            &scene,
            DVec3::new(0.7, -0.9, 0.5),
            DVec3::new(0.0, 0.0, 3.0),
        );
        assert!((other[0] - below[0]).abs() < 1e-6);
        // A card between the light and the point leaves only the ambient term.
        let shadowed = shade_at(
            &lit(true, 0.0),
            DVec3::new(0.0, -0.2, 2.0),
            DVec3::new(0.0, 0.0, 3.0),
        );
        assert!((shadowed[0] - 0.1).abs() < 1e-6, "{shadowed:?}");
        // Without lighting the albedo is what is seen.
        let flat = Scene {
            lighting: None,
            ..lit(false, 0.0)
        };
        assert_eq!(
            shade_at(&flat, DVec3::new(0.0, -0.5, 0.0), DVec3::new(0.0, 0.0, 3.0)),
            [1.0; 3]
        );
    }

    #[test]
    fn the_highlight_depends_on_the_view_and_peaks_at_the_mirror_direction() {
        let scene = lit(false, 1.0);
        let p = DVec3::new(0.0, 0.0, 3.0);
        // Seen from straight above (the mirror direction of the light) and from the side.
        let mirror = shade_at(&scene, DVec3::new(0.0, -0.5, 3.0), p);
        let side = shade_at(&scene, DVec3::new(0.0, -0.5, 0.0), p);
        assert!(mirror[0] > side[0] + 1e-4, "{mirror:?} vs {side:?}");
    }
}
