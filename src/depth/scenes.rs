//! Small synthetic light fields with exact disparity for the depth tests and the accuracy
//! study (docs/depth.md): the analytic quad ray tracer of [`crate::synth`] on a regular rig
//! (or a rotated one), every surface covered with fine value noise unless it is meant to be
//! textureless. The centre view carries its exact depth and HCI disparity maps, as for every
//! generated light field.
//!
//! The rig: `grid × grid` views of `size × size` px, f = 1.25·size px, baseline 0.04 m, focus
//! (zero disparity) at 2 m, so `d = 0.05·size·(1/Z − 1/2)` px per grid step.

use glam::{DMat3, DVec3};

use crate::geometry::camera::Camera;
use crate::lightfield::{DepthKind, GridSize, LightField, ParallelRig, Source, View};
use crate::synth::{render_light_field, render_view, Quad, Scene, Texture};

/// The rig of the scenes (see the module docs).
pub fn rig(size: u32) -> ParallelRig {
    ParallelRig {
        focal_px: 1.25 * size as f64,
        baseline: 0.04,
        focus_distance: 2.0,
    }
}

/// Fine noise: value noise about four pixels a cell on a quad `pixels` wide, in `colour`
/// (finer noise aliases at the renderer's 2×2 supersampling, and views that alias differently
/// are not shifted copies of each other).
pub fn noise(seed: u32, pixels: f64, colour: [f32; 3]) -> Texture {
    Texture::Detail {
        seed,
        grain: (pixels / 4.0).max(1.0) as u32,
        rings: 0,
        text: String::new(),
        paper: colour,
        ink: [0.02, 0.02, 0.02],
    }
}

/// A frontoparallel quad at HCI disparity `d` covering the centre view's pixel rectangle
/// `[x0, x1] × [y0, y1]` (pixel-index coordinates, may reach beyond the image).
pub fn card(rig: &ParallelRig, size: u32, d: f64, rect: [f64; 4], texture: Texture) -> Quad {
    let z = rig
        .depth_of_disparity(d)
        .expect("a disparity in front of infinity");
    let c = (size as f64 - 1.0) / 2.0;
    let at = |p: f64| (p - c) * z / rig.focal_px;
    let (x0, x1, y0, y1) = (at(rect[0]), at(rect[1]), at(rect[2]), at(rect[3]));
    Quad {
        centre: DVec3::new((x0 + x1) / 2.0, (y0 + y1) / 2.0, z),
        half_u: DVec3::new((x1 - x0) / 2.0, 0.0, 0.0),
        half_v: DVec3::new(0.0, (y1 - y0) / 2.0, 0.0),
        texture,
    }
}

/// Which scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DepthScene {
    /// A noise-textured back plane at d = −0.6 and a noise-textured card at d = +0.8 over the
    /// right half of the lower half: frontoparallel planes and an occlusion edge (L-shaped).
    Planes,
    /// One noise-textured plane tilted 30° and swung 20° through the axis at 2 m (disparity
    /// varying across the image).
    Tilted,
    /// The back plane of `Planes` with a uniformly coloured (textureless) card at d = +0.5
    /// over the centre third of the image.
    Textureless,
}

impl DepthScene {
    /// All scenes, for studies.
    pub const ALL: [DepthScene; 3] = [
        DepthScene::Planes,
        DepthScene::Tilted,
        DepthScene::Textureless,
    ];

    /// A short name.
    pub fn name(&self) -> &'static str {
        match self {
            DepthScene::Planes => "planes",
            DepthScene::Tilted => "tilted",
            DepthScene::Textureless => "textureless",
        }
    }

    /// The quads of the scene for views of `size` px.
    pub fn scene(&self, size: u32) -> Scene {
        let rig = rig(size);
        let s = size as f64;
        let big = [-s, 2.0 * s, -s, 2.0 * s];
        let back = card(&rig, size, -0.6, big, noise(11, 3.0 * s, [0.75, 0.7, 0.6]));
        let quads = match self {
            DepthScene::Planes => vec![
                back,
                card(
                    &rig,
                    size,
                    0.8,
                    [s * 0.5, 2.0 * s, s * 0.5, 2.0 * s],
                    noise(23, 1.5 * s, [0.3, 0.55, 0.8]),
                ),
            ],
            DepthScene::Tilted => {
                let n = -crate::geometry::plane::tilt_swing_normal(30.0, 20.0);
                let texture = noise(5, 4.0 * s, [0.7, 0.6, 0.5]);
                crate::synth::plane_scene(n, DVec3::new(0.0, 0.0, 2.0), 4.0, texture).quads
            }
            DepthScene::Textureless => vec![
                back,
                card(
                    &rig,
                    size,
                    0.5,
                    [s / 3.0, 2.0 * s / 3.0, s / 3.0, 2.0 * s / 3.0],
                    Texture::Solid([0.4, 0.45, 0.5]),
                ),
            ],
        };
        Scene {
            quads,
            background: [0.0; 3],
        }
    }

    /// The light field on the regular rig: `grid × grid` views of `size²` px.
    pub fn light_field(&self, grid: usize, size: u32) -> LightField {
        let rig = rig(size);
        let g = GridSize {
            cols: grid,
            rows: grid,
        };
        render_light_field(&self.scene(size), self.name(), g, size, size, &rig, 2)
    }

    /// The same scene seen by a rotated (converging) rig without a regular-grid declaration:
    /// the regular rig's camera centres, every camera turned by `toe_deg` per grid step
    /// towards the grid centre's line of sight (about y for columns, x for rows). The centre
    /// view carries its exact depth map.
    pub fn rotated_light_field(&self, grid: usize, size: u32, toe_deg: f64) -> LightField {
        let rig = rig(size);
        let g = GridSize {
            cols: grid,
            rows: grid,
        };
        let scene = self.scene(size);
        let c = g.centre();
        let regular = rig.cameras(g, size, size);
        let mut views = Vec::new();
        let mut depth = Vec::new();
        for (i, cam) in regular.iter().enumerate() {
            let (s, t) = (i % grid, i / grid);
            let (ds, dt) = (s as f64 - c.x, t as f64 - c.y);
            // Toe in: a camera right of the centre turns left (negative rotation about y).
            let r = DMat3::from_rotation_x(dt * toe_deg.to_radians())
                * DMat3::from_rotation_y(-ds * toe_deg.to_radians());
            let centre = cam.centre();
            let k = crate::geometry::camera::intrinsics(
                rig.focal_px,
                rig.focal_px,
                (size as f64 - 1.0) / 2.0,
                (size as f64 - 1.0) / 2.0,
            );
            let camera = Camera::from_centre(k, r, centre);
            let (image, z) = render_view(&scene, &camera, size, size, 2);
            if i == g.index(grid / 2, grid / 2) {
                depth.push((
                    i,
                    crate::lightfield::DepthMap {
                        kind: DepthKind::Depth,
                        source: format!("{} exact depth", self.name()),
                        ..z
                    },
                ));
            }
            views.push(View {
                s,
                t,
                camera,
                image,
                source: format!("{} rotated view ({s},{t})", self.name()),
            });
        }
        LightField {
            name: format!("{}-rotated", self.name()),
            grid: g,
            width: size,
            height: size,
            views,
            depth,
            rig: None,
            disparity_range: None,
            source: Source::Generated {
                scene: self.name().into(),
            },
        }
    }
}

/// The exact map of `kind` that a generated light field carries for its centre view.
pub fn truth(lf: &LightField, kind: DepthKind) -> Vec<f32> {
    lf.depth
        .iter()
        .find(|(_, m)| m.kind == kind)
        .map(|(_, m)| m.values.clone())
        .unwrap_or_default()
}
