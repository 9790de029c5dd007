//! Built-in scenes of `tiltfield synth` (`builtin:NAME`): quad scenes shared with the ray
//! tracer, turned into meshes for the rasterizer
//! ([`crate::scene::mesh::MeshScene::from_quads`]), each with a default camera rig (focal length relative to the image width, baseline, focus
//! distance; the grid and size come from the command line).
//!
//! World frame = centre camera frame (x right, y down, z forward, metres).
//!
//! | scene    | content | f / W | baseline | focus |
//! |----------|---------|-------|----------|-------|
//! | `demo`   | checkered floor, brick wall at 6 m, painting turned 35° at 2.7 m, colour-bar card at 1.6 m ([`mod@super::builtin`]) | 1.2 | 0.02 m | 2.5 m |
//! | `room`   | a room 2.4 m wide: floor, ceiling, back wall at 5 m, two side walls each with two paintings hung flat on them (planes through a side wall span two paintings and the wall) | 1.0 | 0.02 m | 3.5 m |
//! | `tower`  | three boxes stacked and turned (25°, 50°, 10°) on a checkered floor in front of a wall at 7 m: flat faces for single-click normals | 1.1 | 0.03 m | 3.5 m |
//! | `depths` | seven cards with fine texture (grain, rings, stripes) from 1.2 m to 6 m in front of a finely checkered wall at 9 m: aliasing at many depths | 1.1 | 0.03 m | 2.5 m |
//! | `layers` | four textured frontoparallel layers at HCI disparities −3, 0, +2 and +6 px per grid step for a 128-pixel-wide view (back wall 3.765 m, a panel at 2 m on the left, a panel at 1.52 m lower right, a card at 1.03 m): a sparse light field's angular aliasing and occlusion edges ([`layers`]) | 1.0 | 0.1 m | 2 m |
//! | `planes` | two frontoparallel planes at 4 m and 2 m ([`mod@super::builtin`]) | 1.25 | 0.1 m | 3 m |
//! | `tilted` | one plane tilted 40° about x through (0, 0, 3 m) ([`mod@super::builtin`]) | 1.25 | 0.1 m | 3 m |

use glam::DVec3;

use super::scene::{Quad, Scene};
use super::texture::{Rgb, Texture};
use crate::scene::mesh::MeshScene;

/// A built-in synth scene with its default rig.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthScene {
    pub name: &'static str,
    pub description: &'static str,
    pub scene: Scene,
    /// Focal length in pixels divided by the view width.
    pub focal_per_width: f64,
    pub baseline: f64,
    pub focus_distance: f64,
}

impl SynthScene {
    /// The scene as a mesh (textures baked).
    pub fn mesh(&self) -> MeshScene {
        MeshScene::from_quads(self.name, &self.scene)
    }
}

/// Names accepted by [`synth_scene`].
pub fn synth_scene_names() -> &'static [&'static str] {
    &[
        "demo", "room", "tower", "depths", "layers", "planes", "tilted",
    ]
}

/// The built-in synth scene called `name`.
pub fn synth_scene(name: &str) -> Option<SynthScene> {
    let from_builtin = |b: super::BuiltinScene| SynthScene {
        name: b.name,
        description: b.description,
        focal_per_width: b.rig.focal_px / b.width as f64,
        // The demo's 0.055 m suits its own 192-pixel 7×7 grid; 0.02 m keeps the disparities
        // of a 512-pixel 9×9 synth render within about ±3 px.
        baseline: if b.name == "demo" {
            0.02
        } else {
            b.rig.baseline
        },
        focus_distance: b.rig.focus_distance,
        scene: b.scene,
    };
    match name {
        "demo" | "planes" | "tilted" => super::builtin(name).map(from_builtin),
        "room" => Some(room()),
        "tower" => Some(tower()),
        "depths" => Some(depths()),
        "layers" => Some(layers()),
        _ => None,
    }
}

const PAPER: Rgb = [0.80, 0.80, 0.78];
const INK: Rgb = [0.02, 0.02, 0.02];

fn detail(seed: u32, text: &str, paper: Rgb, ink: Rgb) -> Texture {
    Texture::Detail {
        seed,
        grain: 128,
        rings: 8,
        text: text.into(),
        paper,
        ink,
    }
}

fn quad(centre: DVec3, half_u: DVec3, half_v: DVec3, texture: Texture) -> Quad {
    Quad {
        centre,
        half_u,
        half_v,
        texture,
    }
}

/// A room: walls at x = ±1.2, floor at y = 0.9, ceiling at y = −1.1, back wall at z = 5; two
/// paintings on each side wall, 1 cm in front of it.
fn room() -> SynthScene {
    let (hx, floor, ceil, back) = (1.2, 0.9, -1.1, 5.0);
    let (z0, z1) = (0.5, back);
    let zc = (z0 + z1) / 2.0;
    let hz = (z1 - z0) / 2.0;
    let yc = (floor + ceil) / 2.0;
    let hy = (floor - ceil) / 2.0;
    let mut quads = vec![
        quad(
            DVec3::new(0.0, floor, zc),
            DVec3::new(hx, 0.0, 0.0),
            DVec3::new(0.0, 0.0, -hz),
            Texture::Checker {
                cells_u: 6,
                cells_v: 12,
                a: [0.55, 0.45, 0.32],
                b: [0.20, 0.14, 0.09],
            },
        ),
        quad(
            DVec3::new(0.0, ceil, zc),
            DVec3::new(hx, 0.0, 0.0),
            DVec3::new(0.0, 0.0, hz),
            Texture::Solid([0.7, 0.7, 0.68]),
        ),
        quad(
            DVec3::new(0.0, yc, back),
            DVec3::new(hx, 0.0, 0.0),
            DVec3::new(0.0, hy, 0.0),
            Texture::Bricks {
                rows: 14,
                cols: 8,
                seed: 3,
                brick: [0.42, 0.13, 0.07],
                mortar: [0.5, 0.48, 0.44],
            },
        ),
    ];
    for side in [-1.0, 1.0] {
        quads.push(quad(
            DVec3::new(side * hx, yc, zc),
            DVec3::new(0.0, 0.0, -side * hz),
            DVec3::new(0.0, hy, 0.0),
            Texture::Bricks {
                rows: 10,
                cols: 12,
                seed: if side < 0.0 { 5 } else { 6 },
                brick: [0.55, 0.52, 0.45],
                mortar: [0.35, 0.34, 0.32],
            },
        ));
        for (k, (z, text)) in [(3.0, "ART"), (4.1, "OIL")].into_iter().enumerate() {
            let ink: Rgb = if k == 0 {
                [0.02, 0.05, 0.25]
            } else {
                [0.3, 0.02, 0.02]
            };
            quads.push(quad(
                DVec3::new(side * (hx - 0.01), -0.1, z),
                DVec3::new(0.0, 0.0, -side * 0.35),
                DVec3::new(0.0, 0.27, 0.0),
                detail(20 + k as u32 + (side > 0.0) as u32 * 2, text, PAPER, ink),
            ));
        }
    }
    SynthScene {
        name: "room",
        description: "a room: checkered floor, ceiling, brick back wall at 5 m, side walls at \
                      x = ±1.2 m with two paintings each (planes through a side wall span two \
                      paintings)",
        scene: Scene {
            quads,
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: None,
        },
        focal_per_width: 1.0,
        baseline: 0.02,
        focus_distance: 3.5,
    }
}

/// The five visible faces (no bottom) of a box standing on y = `base` (y down), centre
/// (x, z), half size h, turned by `yaw` degrees about the vertical.
fn boxed(x: f64, z: f64, base: f64, h: f64, yaw: f64, texture: &Texture) -> Vec<Quad> {
    let (s, c) = yaw.to_radians().sin_cos();
    let ex = DVec3::new(c, 0.0, -s) * h;
    let ez = DVec3::new(s, 0.0, c) * h;
    let ey = DVec3::new(0.0, h, 0.0);
    let centre = DVec3::new(x, base - h, z);
    vec![
        quad(centre - ez, ex, ey, texture.clone()),
        quad(centre + ez, -ex, ey, texture.clone()),
        quad(centre - ex, -ez, ey, texture.clone()),
        quad(centre + ex, ez, ey, texture.clone()),
        quad(centre - ey, ex, ez, texture.clone()),
    ]
}

/// Three boxes stacked on a floor at y = 0.8 in front of a wall at z = 7.
fn tower() -> SynthScene {
    let floor = 0.8;
    let mut quads = vec![
        quad(
            DVec3::new(0.0, floor, 4.5),
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, -4.0),
            Texture::Checker {
                cells_u: 12,
                cells_v: 16,
                a: [0.62, 0.52, 0.36],
                b: [0.045, 0.085, 0.12],
            },
        ),
        quad(
            DVec3::new(0.0, -1.0, 7.0),
            DVec3::new(4.0, 0.0, 0.0),
            DVec3::new(0.0, 1.8, 0.0),
            Texture::Bricks {
                rows: 16,
                cols: 12,
                seed: 9,
                brick: [0.42, 0.13, 0.07],
                mortar: [0.5, 0.48, 0.44],
            },
        ),
    ];
    let (h1, h2, h3) = (0.4, 0.28, 0.17);
    quads.extend(boxed(
        0.0,
        3.5,
        floor,
        h1,
        25.0,
        &detail(31, "DICE", PAPER, [0.02, 0.05, 0.25]),
    ));
    quads.extend(boxed(
        0.05,
        3.45,
        floor - 2.0 * h1,
        h2,
        50.0,
        &Texture::ColourBars { stripes: 10 },
    ));
    quads.extend(boxed(
        -0.03,
        3.5,
        floor - 2.0 * (h1 + h2),
        h3,
        10.0,
        &Texture::Checker {
            cells_u: 4,
            cells_v: 4,
            a: [0.9, 0.35, 0.05],
            b: [0.05, 0.35, 0.35],
        },
    ));
    SynthScene {
        name: "tower",
        description: "three boxes stacked and turned 25°, 50°, 10° on a checkered floor, \
                      brick wall at 7 m (flat faces for single-click normals)",
        scene: Scene {
            quads,
            background: [0.35, 0.55, 0.85],
            solids: Vec::new(),
            lighting: None,
        },
        focal_per_width: 1.1,
        baseline: 0.03,
        focus_distance: 3.5,
    }
}

/// Seven finely textured cards from 1.2 m to 6 m, staggered left to right, in front of a
/// finely checkered wall at 9 m.
fn depths() -> SynthScene {
    let mut quads = vec![quad(
        DVec3::new(0.0, 0.0, 9.0),
        DVec3::new(6.0, 0.0, 0.0),
        DVec3::new(0.0, 6.0, 0.0),
        Texture::Checker {
            cells_u: 32,
            cells_v: 32,
            a: [0.8; 3],
            b: [0.05; 3],
        },
    )];
    let zs = [1.2, 1.6, 2.1, 2.8, 3.7, 4.8, 6.0];
    for (k, &z) in zs.iter().enumerate() {
        // Spread across the view: x from −0.38 to +0.38 of the depth (f/W = 1.1 sees ±0.45 z).
        let fx = -0.36 + 0.72 * k as f64 / (zs.len() - 1) as f64;
        let fy = if k % 2 == 0 { -0.12 } else { 0.12 };
        let half = 0.1 * z;
        let texture = if k % 3 == 2 {
            Texture::ColourBars { stripes: 24 }
        } else {
            Texture::Detail {
                seed: 40 + k as u32,
                grain: 256,
                rings: 16,
                text: "FINE".into(),
                paper: PAPER,
                ink: INK,
            }
        };
        quads.push(quad(
            DVec3::new(fx * z, fy * z, z),
            DVec3::new(half, 0.0, 0.0),
            DVec3::new(0.0, half, 0.0),
            texture,
        ));
    }
    SynthScene {
        name: "depths",
        description: "seven cards with fine texture from 1.2 m to 6 m before a fine checker \
                      wall at 9 m (aliasing at many depths)",
        scene: Scene {
            quads,
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: None,
        },
        focal_per_width: 1.1,
        baseline: 0.03,
        focus_distance: 2.5,
    }
}

/// Depths of [`layers`]' four planes (back to front): with f = W (f/W = 1), baseline 0.1 m and
/// focus at 2 m, disparity `d = 0.1·W·(1/z − 1/2)` is −3, 0, +2 and +6 px per grid step at
/// W = 128 (scaling with W).
pub const LAYER_DEPTHS: [f64; 4] = [
    1.0 / (0.5 - 3.0 / 12.8),
    2.0,
    1.0 / (0.5 + 2.0 / 12.8),
    1.0 / (0.5 + 6.0 / 12.8),
];

/// Four textured frontoparallel layers (see the module table): the anti-aliasing test scene.
/// Every view of a 5×5 rig at the default baseline sees only the scene (no background).
pub fn layers() -> SynthScene {
    let [zb, zm, zn, zc] = LAYER_DEPTHS;
    let quads = vec![
        quad(
            DVec3::new(0.0, 0.0, zb),
            DVec3::new(2.8, 0.0, 0.0),
            DVec3::new(0.0, 2.8, 0.0),
            Texture::Bricks {
                rows: 18,
                cols: 8,
                seed: 3,
                brick: [0.42, 0.13, 0.07],
                mortar: [0.50, 0.48, 0.44],
            },
        ),
        quad(
            DVec3::new(-0.55 * zm / 2.0, -0.05, zm),
            DVec3::new(0.45 * zm / 2.0, 0.0, 0.0),
            DVec3::new(0.0, 0.4 * zm, 0.0),
            Texture::Detail {
                seed: 11,
                grain: 48,
                rings: 6,
                text: "FOCUS".into(),
                paper: PAPER,
                ink: INK,
            },
        ),
        quad(
            DVec3::new(0.22 * zn, 0.24 * zn, zn),
            DVec3::new(0.2 * zn, 0.0, 0.0),
            DVec3::new(0.0, 0.17 * zn, 0.0),
            Texture::Checker {
                cells_u: 10,
                cells_v: 8,
                a: [0.85, 0.75, 0.2],
                b: [0.05, 0.15, 0.4],
            },
        ),
        quad(
            DVec3::new(0.12 * zc, -0.22 * zc, zc),
            DVec3::new(0.13 * zc, 0.0, 0.0),
            DVec3::new(0.0, 0.1 * zc, 0.0),
            Texture::ColourBars { stripes: 10 },
        ),
    ];
    SynthScene {
        name: "layers",
        description: "four textured frontoparallel layers at −3, 0, +2 and +6 px of disparity \
                      per grid step (128-pixel views): angular aliasing and occlusion edges",
        scene: Scene {
            quads,
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: None,
        },
        focal_per_width: 1.0,
        baseline: 0.1,
        focus_distance: 2.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_synth_scene_resolves_and_meshes() {
        for name in synth_scene_names() {
            let s = synth_scene(name).unwrap();
            assert_eq!(s.name, *name);
            assert!(s.focal_per_width > 0.0 && s.baseline > 0.0 && s.focus_distance > 0.0);
            let m = s.mesh();
            assert_eq!(m.triangle_count(), 2 * s.scene.quads.len());
        }
        assert!(synth_scene("nope").is_none());
    }
}
