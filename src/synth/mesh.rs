//! Built-in quad scenes ([`super::scene::Scene`]) as triangle meshes for the rasterizer
//! ([`MeshScene::from_quads`]): each quad is two triangles and its procedural texture is baked
//! into an image, so the ray tracer and the rasterizer render the same scenes. The mesh types
//! themselves live in [`crate::scene::mesh`].

use glam::DVec2;
use rayon::prelude::*;

use super::scene::{Quad, Scene};
use super::texture::Texture;
use crate::color::encode_srgb8;
use crate::scene::mesh::{MeshScene, MeshTexture, MeshVertex};

impl MeshScene {
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
    use glam::{DMat3, DVec3};

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
