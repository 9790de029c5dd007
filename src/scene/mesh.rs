//! Triangle meshes as plain CPU data: what the Vulkan rasterizer ([`crate::passes::raster`])
//! draws and what the synthetic scenes ([`crate::synth`]) produce. It sits below both, so the
//! GPU passes do not depend on the scene generators.
//!
//! Model (no more than the light fields need): albedo only, no lighting. A triangle's colour is
//! `texture(uv) · vertex colour`, where the texture is an optional RGBA8 sRGB image (decoded to
//! linear light by the sampler) and the vertex colour is linear RGBA that already includes the
//! material's base colour factor. Alpha is ignored (every surface is opaque).
//!
//! Invariants: `indices` is a triangle list (length a multiple of 3) of valid vertex indices;
//! `draws` cover `indices` in order without overlap; a draw's `texture` indexes `textures`.
//!
//! Coordinates: vertices are stored in the scene's world frame, after node transforms. The
//! synthetic light fields use the reference (centre) camera's frame as world frame: x right,
//! y down, z forward, metres (see [`MeshScene::transform`]; docs/conventions.md §1).

use glam::{DMat3, DVec3};
use rayon::prelude::*;

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
    pub background: [f32; 3],
}

impl MeshScene {
    /// An empty scene.
    pub fn new(name: &str, background: [f32; 3]) -> Self {
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
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vertex(p: [f32; 3]) -> MeshVertex {
        MeshVertex {
            position: p,
            normal: [0.0, 0.0, 1.0],
            uv: [0.0; 2],
            color: [1.0; 4],
        }
    }

    #[test]
    fn push_offsets_indices_and_merges_draws_with_the_same_texture() {
        let mut m = MeshScene::new("t", [0.0; 3]);
        let tri = [
            vertex([0.0; 3]),
            vertex([1.0, 0.0, 0.0]),
            vertex([0.0, 1.0, 0.0]),
        ];
        m.push(&tri, &[0, 1, 2], None);
        m.push(&tri, &[0, 1, 2], None);
        m.push(&tri, &[0, 1, 2], Some(0));
        assert_eq!(m.indices[3..6], [3, 4, 5]);
        assert_eq!(m.triangle_count(), 3);
        assert_eq!(m.draws.len(), 2);
        assert_eq!((m.draws[0].first_index, m.draws[0].index_count), (0, 6));
        assert_eq!((m.draws[1].first_index, m.draws[1].index_count), (6, 3));
    }

    #[test]
    fn vertex_floats_match_the_declared_stride() {
        assert_eq!(vertex([0.0; 3]).to_floats().len() * 4, VERTEX_BYTES);
    }
}
