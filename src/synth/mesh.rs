//! Triangle-mesh scenes for the Vulkan rasterizer ([`crate::passes::raster`]).
//!
//! Model (no more than the light fields need): albedo only, no lighting. A triangle's colour is
//! `texture(uv) · vertex colour`, where the texture is an optional RGBA8 sRGB image (decoded to
//! linear light by the sampler) and the vertex colour is linear RGBA that already includes the
//! material's base colour factor. Alpha is ignored (every surface is opaque).
//!
//! Coordinates: vertices are stored in the scene's world frame, after node transforms. The
//! synthetic light fields use the reference (centre) camera's frame as world frame: x right,
//! y down, z forward, metres (see [`MeshScene::transform`]).
//!
//! Built-in quad scenes ([`super::scene::Scene`]) become meshes with [`MeshScene::from_quads`]:
//! each quad is two triangles and its procedural texture is baked into an image, so the ray
//! tracer and the rasterizer render the same scenes.

use glam::{DMat3, DVec2, DVec3};
use rayon::prelude::*;

use super::scene::{Quad, Scene};
use super::texture::{Rgb, Texture};
use crate::color::encode_srgb8;

/// One vertex as the GPU reads it (48 bytes, `mesh.vert` locations 0–3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshVertex {
    pub position: [f32; 3],
    /// Unit normal in the world frame (any orientation; the geometry pass faces it to the
    /// camera).
    pub normal: [f32; 3],
    pub uv: [f32; 2],
    /// Linear RGBA multiplied with the texture (base colour factor × COLOR_0).
    pub color: [f32; 4],
}

/// Bytes per vertex in the vertex buffer.
pub const VERTEX_BYTES: usize = 48;

impl MeshVertex {
    /// The vertex as the 12 native-endian f32 of the vertex buffer.
    pub fn to_floats(&self) -> [f32; 12] {
        let (p, n, t, c) = (self.position, self.normal, self.uv, self.color);
        [
            p[0], p[1], p[2], n[0], n[1], n[2], t[0], t[1], c[0], c[1], c[2], c[3],
        ]
    }
}

/// An RGBA8 sRGB-encoded texture, rows top to bottom (texture v grows downwards).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshTexture {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
    /// Repeat outside [0, 1] (glTF's default) instead of clamping to the edge.
    pub repeat: bool,
    /// For messages and Vulkan object names.
    pub name: String,
}

/// A range of indices drawn with one texture (`None`: untextured, vertex colour only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeshDraw {
    pub first_index: u32,
    pub index_count: u32,
    pub texture: Option<usize>,
}

/// An indexed triangle list with textures.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshScene {
    pub name: String,
    pub vertices: Vec<MeshVertex>,
    /// Triangle list, three indices per triangle.
    pub indices: Vec<u32>,
    pub draws: Vec<MeshDraw>,
    pub textures: Vec<MeshTexture>,
    /// Linear-light colour where no surface is hit.
    pub background: Rgb,
}

impl MeshScene {
    /// An empty scene.
    pub fn new(name: &str, background: Rgb) -> Self {
        MeshScene {
            name: name.to_string(),
            vertices: Vec::new(),
            indices: Vec::new(),
            draws: Vec::new(),
            textures: Vec::new(),
            background,
        }
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Appends a triangle list (indices relative to `vertices`) drawn with `texture`.
    pub fn push(&mut self, vertices: &[MeshVertex], indices: &[u32], texture: Option<usize>) {
        let base = self.vertices.len() as u32;
        let first = self.indices.len() as u32;
        self.vertices.extend_from_slice(vertices);
        self.indices.extend(indices.iter().map(|i| base + i));
        let count = self.indices.len() as u32 - first;
        // Consecutive ranges with the same texture share one draw.
        match self.draws.last_mut() {
            Some(d) if d.texture == texture && d.first_index + d.index_count == first => {
                d.index_count += count;
            }
            _ => self.draws.push(MeshDraw {
                first_index: first,
                index_count: count,
                texture,
            }),
        }
    }

    /// Moves every vertex by `X' = r X + t` (normals by `r`), e.g. into a camera's frame.
    pub fn transform(&mut self, r: DMat3, t: DVec3) {
        self.vertices.par_iter_mut().for_each(|v| {
            let p = r * DVec3::from(v.position.map(f64::from)) + t;
            let n = (r * DVec3::from(v.normal.map(f64::from))).normalize_or_zero();
            v.position = p.as_vec3().to_array();
            v.normal = n.as_vec3().to_array();
        });
    }

    /// Axis-aligned bounds (min, max) of the vertices that triangles use; `None` without
    /// triangles.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let mut it = self
            .indices
            .iter()
            .filter_map(|&i| self.vertices.get(i as usize))
            .map(|v| DVec3::from(v.position.map(f64::from)));
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }

    /// The mesh of a quad scene: two triangles per quad (uv as [`Quad`] defines them), each
    /// non-solid texture baked into an sRGB image of [`bake_size`] texels per side (texel
    /// centres sampled, like the ray tracer's point sampling), solid colours as vertex colours.
    pub fn from_quads(name: &str, scene: &Scene) -> Self {
        let mut mesh = MeshScene::new(name, scene.background);
        for (i, q) in scene.quads.iter().enumerate() {
            let (texture, color) = match &q.texture {
                Texture::Solid(c) => (None, [c[0], c[1], c[2], 1.0]),
                t => {
                    let n = bake_size(t);
                    mesh.textures.push(bake(t, n, &format!("{name} quad {i}")));
                    (Some(mesh.textures.len() - 1), [1.0; 4])
                }
            };
            mesh.push(&quad_vertices(q, color), &[0, 1, 2, 0, 2, 3], texture);
        }
        mesh
    }
}

/// Texels per side used to bake a procedural texture: enough that a texel is smaller than a
/// pixel of a 512-pixel view for the built-in scenes, far fewer for coarse checkers.
pub fn bake_size(t: &Texture) -> u32 {
    match t {
        Texture::Solid(_) => 1,
        Texture::Checker {
            cells_u, cells_v, ..
        } => ((*cells_u).max(*cells_v).max(1) * 32).clamp(64, 1024),
        _ => 1024,
    }
}

/// Bakes `t` at the centres of an `n × n` texel grid.
pub fn bake(t: &Texture, n: u32, name: &str) -> MeshTexture {
    let n = n.max(1);
    let mut rgba = vec![0u8; (n * n * 4) as usize];
    rgba.par_chunks_mut((n * 4) as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..n as usize {
                let uv = DVec2::new((x as f64 + 0.5) / n as f64, (y as f64 + 0.5) / n as f64);
                let c = t.eval(uv);
                for k in 0..3 {
                    row[4 * x + k] = encode_srgb8(c[k]);
                }
                row[4 * x + 3] = 255;
            }
        });
    MeshTexture {
        width: n,
        height: n,
        rgba,
        repeat: false,
        name: name.to_string(),
    }
}

fn quad_vertices(q: &Quad, color: [f32; 4]) -> [MeshVertex; 4] {
    let n = q.normal().as_vec3().to_array();
    let uvs = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let corners = q.corners();
    std::array::from_fn(|k| MeshVertex {
        position: corners[k].as_vec3().to_array(),
        normal: n,
        uv: uvs[k],
        color,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quads_become_two_triangles_with_baked_textures() {
        let b = crate::synth::builtin("planes").unwrap();
        let m = MeshScene::from_quads("planes", &b.scene);
        assert_eq!(m.triangle_count(), 4);
        assert_eq!(m.textures.len(), 2);
        assert_eq!(m.draws.len(), 2);
        let (lo, hi) = m.bounds().unwrap();
        assert!((lo.z - 2.0).abs() < 1e-6 && (hi.z - 4.0).abs() < 1e-6);
        // A texel centre carries the procedural texture there, sRGB-encoded.
        let t = &m.textures[1];
        let c = b.scene.quads[1]
            .texture
            .eval(DVec2::new(0.5 / t.width as f64, 0.5 / t.height as f64));
        assert_eq!(t.rgba[0], encode_srgb8(c[0]));
    }

    #[test]
    fn solid_quads_use_vertex_colour_and_transform_moves_vertices() {
        let scene = crate::synth::plane_scene(DVec3::Z, DVec3::new(0.0, 0.0, 2.0), 1.0, {
            Texture::Solid([0.25, 0.5, 0.75])
        });
        let mut m = MeshScene::from_quads("solid", &scene);
        assert!(m.textures.is_empty() && m.draws[0].texture.is_none());
        assert_eq!(m.vertices[0].color, [0.25, 0.5, 0.75, 1.0]);
        m.transform(
            DMat3::from_rotation_y(std::f64::consts::FRAC_PI_2),
            DVec3::X,
        );
        let (lo, hi) = m.bounds().unwrap();
        assert!((lo.x - 3.0).abs() < 1e-6 && (hi.x - 3.0).abs() < 1e-6);
    }
}
