//! Small synthetic light fields with exact disparity for the depth tests and the accuracy
//! study (docs/depth.md): the analytic ray tracer of [`crate::synth`] (quads, ellipsoids,
//! cylinders) on a regular rig (or a rotated one), every surface covered with fine value noise
//! unless it is meant to be textureless. The centre view carries its exact depth and HCI
//! disparity maps, as for every generated light field.
//!
//! [`DepthScene::SET`] is the depth test set: one scene per known failure mode of depth
//! estimation (occlusion edges, slanted and curved surfaces, weak texture and low contrast,
//! a large disparity range, thin structures, sensor noise with vignetting), scored together by
//! `tiltfield depth --test-set` so that no change is judged on one scene.
//!
//! The rig: `grid × grid` views of `size × size` px, f = 1.25·size px, baseline 0.04 m, focus
//! (zero disparity) at 2 m, so `d = 0.05·size·(1/Z − 1/2)` px per grid step.

use glam::{DMat3, DVec3};

use crate::geometry::camera::Camera;
use crate::lightfield::{DepthKind, GridSize, LightField, ParallelRig, Source, View};
use crate::synth::scene::{Lighting, Solid};
use crate::synth::surfaces::Rng;
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
    value_noise(
        seed,
        (pixels / 4.0).max(1.0) as u32,
        colour,
        [0.02, 0.02, 0.02],
    )
}

/// Value noise of `grain` pixels a cell between `paper` and `ink` (no rings, no text): the
/// texture of every surface of the set.
pub fn value_noise(seed: u32, grain: u32, paper: [f32; 3], ink: [f32; 3]) -> Texture {
    Texture::Detail {
        seed,
        grain,
        rings: 0,
        text: String::new(),
        paper,
        ink,
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
    /// A noise-textured ball (d ≈ +0.6 … +1.3) in front of the back plane: a smooth curved
    /// surface and a round occlusion edge.
    Sphere,
    /// A vertical noise-textured column (d ≈ +0.7 … +0.9 across its width) in front of a
    /// tilted floor and the back plane: curvature in one direction, straight silhouettes.
    Cylinder,
    /// A weakly textured, low-contrast "bust" (a head-and-shoulders blob of ellipsoids, pale
    /// marble with faint veins) in front of a dark wall of very low contrast, a floor at the
    /// bottom; disparities about −1.6 … +1.4 (the failure mode of smooth, weakly textured HCI
    /// scenes).
    Bust,
    /// Cards from d = −2.0 to +3.2 (at 96 px; scaled with the size) over one another: a large disparity range (sweeps whose
    /// plane spacing or window assumptions only hold near zero fail here).
    Wide,
    /// Thin vertical and horizontal bars (2–4 px) in front of the back plane: thin
    /// structures, where aggregation windows fatten the foreground.
    Thin,
    /// The `Sphere` scene as a plenoptic camera records it: views darker towards the grid's
    /// rim (vignetting, corner views at about half brightness, with a radial falloff inside
    /// each view) and Gaussian sensor noise of σ = 3 levels.
    Plenoptic,
    /// The `Wide` cards, the nearest at d = +4.5, seen by a calibrated converging rig: the
    /// regular rig's camera centres, every camera turned towards the point 2 m away on the
    /// centre axis (where the regular rig has zero disparity), no regular-grid declaration. The depth search has no dataset
    /// range and no disparity convention there: its automatic range must centre on the point
    /// the cameras look at (anchored at infinity, it stopped at d = +3.6 and lost the nearest
    /// card). Scored as the regular rig's disparity of the estimated depth
    /// ([`DepthScene::scored_as`]).
    Converging,
    /// The `Bust` under an area light above and to the left: Lambertian shading across the
    /// smooth ellipsoids (the brightness changes with the surface's slope, not with a texture),
    /// soft shadows on the wall and the floor, a mild highlight on the marble.
    ShadedBust,
    /// A reclining figure of overlapping ellipsoids (torso, hip, head, arm) in pale, nearly
    /// textureless stone under an area light, with mild highlights, in front of a dark wall:
    /// smooth curvature that a fronto-parallel prior turns into staircases, silhouettes
    /// against a dark low-contrast background.
    Sculpture,
    /// A faintly textured column and a ball lit from the side, their soft shadows falling on a
    /// pale wall: shading gradients and penumbrae as the only image structure over most of
    /// the curved surfaces.
    ShadedColumn,
}

impl DepthScene {
    /// The scenes of the first study.
    pub const ALL: [DepthScene; 3] = [
        DepthScene::Planes,
        DepthScene::Tilted,
        DepthScene::Textureless,
    ];

    /// The depth test set (module docs).
    pub const SET: [DepthScene; 13] = [
        DepthScene::Planes,
        DepthScene::Tilted,
        DepthScene::Textureless,
        DepthScene::Sphere,
        DepthScene::Cylinder,
        DepthScene::Bust,
        DepthScene::Wide,
        DepthScene::Thin,
        DepthScene::Plenoptic,
        DepthScene::Converging,
        DepthScene::ShadedBust,
        DepthScene::Sculpture,
        DepthScene::ShadedColumn,
    ];

    /// The scenes shaded by an area light ([`crate::synth::scene::Lighting`]): the part of the
    /// set that looks like renderer output.
    pub fn shaded(&self) -> bool {
        matches!(
            self,
            DepthScene::ShadedBust | DepthScene::Sculpture | DepthScene::ShadedColumn
        )
    }

    /// A short name.
    pub fn name(&self) -> &'static str {
        match self {
            DepthScene::Planes => "planes",
            DepthScene::Tilted => "tilted",
            DepthScene::Textureless => "textureless",
            DepthScene::Sphere => "sphere",
            DepthScene::Cylinder => "cylinder",
            DepthScene::Bust => "bust",
            DepthScene::Wide => "wide",
            DepthScene::Thin => "thin",
            DepthScene::Plenoptic => "plenoptic",
            DepthScene::Converging => "converging",
            DepthScene::ShadedBust => "shaded-bust",
            DepthScene::Sculpture => "sculpture",
            DepthScene::ShadedColumn => "shaded-column",
        }
    }

    /// The scene of `name` ([`DepthScene::SET`]).
    pub fn from_name(name: &str) -> Option<DepthScene> {
        Self::SET.into_iter().find(|s| s.name() == name)
    }

    /// What the scene tests, in a few words (the test-set table's column).
    pub fn failure_mode(&self) -> &'static str {
        match self {
            DepthScene::Planes => "occlusion edge",
            DepthScene::Tilted => "slanted plane",
            DepthScene::Textureless => "textureless card",
            DepthScene::Sphere => "curved surface, round silhouette",
            DepthScene::Cylinder => "curved surface, tilted floor",
            DepthScene::Bust => "smooth, weak texture, dark low-contrast wall",
            DepthScene::Wide => "large disparity range",
            DepthScene::Thin => "thin structures",
            DepthScene::Plenoptic => "sensor noise and vignetting",
            DepthScene::Converging => "converging calibrated rig, no disparity convention",
            DepthScene::ShadedBust => "shading, soft shadows, highlights on a smooth bust",
            DepthScene::Sculpture => "smooth shaded curvature, nearly textureless, dark wall",
            DepthScene::ShadedColumn => "shading gradients and penumbrae, faint texture",
        }
    }

    /// The quads of the scene for views of `size` px.
    pub fn scene(&self, size: u32) -> Scene {
        let frame = Frame::new(size);
        let (rig, s, k, big) = (frame.rig, frame.s, frame.k, frame.big);
        let back = card(&rig, size, -0.6, big, noise(11, 3.0 * s, [0.75, 0.7, 0.6]));
        let point = |x: f64, y: f64, d: f64| frame.point(x, y, d);
        let mut solids = Vec::new();
        let quads = match self {
            DepthScene::Sphere | DepthScene::Plenoptic => {
                let centre = point(s * 0.5, s * 0.5, 0.6);
                solids.push(Solid::Ellipsoid {
                    centre,
                    radii: DVec3::splat(0.3),
                    texture: noise(31, 2.0 * s, [0.8, 0.45, 0.3]),
                });
                vec![back]
            }
            DepthScene::Cylinder => {
                let centre = point(s * 0.45, s * 0.5, 0.7);
                solids.push(Solid::Cylinder {
                    centre,
                    axis: DVec3::Y,
                    radius: 0.12,
                    half_height: 2.0,
                    texture: noise(41, 1.5 * s, [0.35, 0.7, 0.45]),
                });
                vec![back, floor(&rig, s, noise(43, 4.0 * s, [0.6, 0.6, 0.65]))]
            }
            DepthScene::Bust | DepthScene::ShadedBust => bust(&frame, &mut solids),
            DepthScene::Wide | DepthScene::Converging => vec![
                card(
                    &rig,
                    size,
                    -2.0 * k,
                    big,
                    noise(61, 3.0 * s, [0.7, 0.65, 0.55]),
                ),
                card(
                    &rig,
                    size,
                    -k,
                    [-s, 0.45 * s, -s, 0.55 * s],
                    noise(62, 1.5 * s, [0.5, 0.7, 0.5]),
                ),
                card(
                    &rig,
                    size,
                    1.2 * k,
                    [0.55 * s, 2.0 * s, -s, 0.45 * s],
                    noise(63, 1.5 * s, [0.75, 0.5, 0.6]),
                ),
                card(
                    &rig,
                    size,
                    // The converging rig's nearest card lies beyond the reach of a range
                    // anchored at infinity (w ≤ 1.25/m, d ≤ +3.6·k) and inside the one centred
                    // on the point the cameras look at.
                    if *self == DepthScene::Converging {
                        4.5 * k
                    } else {
                        3.2 * k
                    },
                    [0.3 * s, 0.7 * s, 0.6 * s, 2.0 * s],
                    noise(64, 0.6 * s, [0.4, 0.5, 0.8]),
                ),
            ],
            DepthScene::Thin => {
                let mut quads = vec![back];
                for (k, x) in [0.2, 0.42, 0.66].into_iter().enumerate() {
                    let w = 2.0 + k as f64;
                    quads.push(card(
                        &rig,
                        size,
                        0.6 + 0.3 * k as f64,
                        [s * x, s * x + w, -s, 2.0 * s],
                        noise(71 + k as u32, 0.3 * s, [0.85, 0.8, 0.3]),
                    ));
                }
                quads.push(card(
                    &rig,
                    size,
                    1.0,
                    [-s, 2.0 * s, s * 0.7, s * 0.7 + 3.0],
                    noise(75, 3.0 * s, [0.3, 0.75, 0.85]),
                ));
                quads
            }
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
            DepthScene::Sculpture => sculpture(&frame, &mut solids),
            DepthScene::ShadedColumn => shaded_column(&frame, &mut solids),
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
            solids,
            lighting: self.lighting(),
        }
    }

    /// The area light of a shaded scene: above, in front and to the left of the subject
    /// (the shaded column's from the left only, low, for long shadows); `None` otherwise.
    fn lighting(&self) -> Option<Lighting> {
        let (centre, specular) = match self {
            DepthScene::ShadedBust => (DVec3::new(-0.9, -1.4, 1.2), 0.12),
            DepthScene::Sculpture => (DVec3::new(-0.7, -1.5, 1.4), 0.2),
            DepthScene::ShadedColumn => (DVec3::new(-1.6, -0.5, 1.6), 0.05),
            _ => return None,
        };
        Some(Lighting {
            centre,
            half_u: DVec3::new(0.35, 0.0, 0.0),
            half_v: DVec3::new(0.0, 0.1, 0.35),
            power: [5.0, 4.8, 4.5],
            ambient: 0.12,
            samples: 6,
            specular,
            shininess: 40.0,
        })
    }

    /// The light field on the regular rig (the converging one for
    /// [`DepthScene::Converging`]): `grid × grid` views of `size²` px.
    pub fn light_field(&self, grid: usize, size: u32) -> LightField {
        if *self == DepthScene::Converging {
            // Turned by the angle the grid step subtends at the focus distance, per step.
            let r = rig(size);
            let toe = (r.baseline / r.focus_distance).atan().to_degrees();
            let mut lf = self.rotated_light_field(grid, size, toe);
            lf.name = self.name().into();
            return lf;
        }
        let rig = rig(size);
        let g = GridSize {
            cols: grid,
            rows: grid,
        };
        let mut lf = render_light_field(&self.scene(size), self.name(), g, size, size, &rig, 2);
        if *self == DepthScene::Plenoptic {
            plenoptic_degrade(&mut lf, 3.0, 0xC0FFEE);
        }
        lf
    }

    /// The regular rig whose disparity scores the scene when it has no disparity convention
    /// of its own (a calibrated rotated rig: the estimate's depth and the exact depth become
    /// that rig's disparities, same camera centres); `None` where the scene's own HCI
    /// disparity is scored.
    pub fn scored_as(&self, size: u32) -> Option<ParallelRig> {
        (*self == DepthScene::Converging).then(|| rig(size))
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
            // Toe in: a camera right of the centre (world +x) turns its optical axis, the
            // world direction Rᵀ·ẑ of the world-to-camera rotation R, towards −x, and one
            // below (+y) towards −y. (The signs were once the other way round: the cameras
            // diverged, and the converging test scene was a diverging one.)
            let r = DMat3::from_rotation_x(-dt * toe_deg.to_radians())
                * DMat3::from_rotation_y(ds * toe_deg.to_radians());
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

/// What every scene is laid out in: the rig of `size`-px views, the size as a float, the
/// factor far disparities scale with (d = 0.05·size·(1/Z − 1/2): the same scene at any size,
/// never beyond infinity) and a rectangle beyond the image on every side.
struct Frame {
    rig: ParallelRig,
    size: u32,
    s: f64,
    k: f64,
    big: [f64; 4],
}

impl Frame {
    fn new(size: u32) -> Self {
        let s = size as f64;
        Frame {
            rig: rig(size),
            size,
            s,
            k: s / 96.0,
            big: [-s, 2.0 * s, -s, 2.0 * s],
        }
    }

    /// A point at disparity d seen at centre-view pixel (x, y).
    fn point(&self, x: f64, y: f64, d: f64) -> DVec3 {
        let z = self
            .rig
            .depth_of_disparity(d)
            .expect("in front of infinity");
        let c = (self.s - 1.0) / 2.0;
        DVec3::new(
            (x - c) * z / self.rig.focal_px,
            (y - c) * z / self.rig.focal_px,
            z,
        )
    }
}

/// The bust (lit or not): head and shoulders of pale marble before a dark wall, a floor.
fn bust(frame: &Frame, solids: &mut Vec<Solid>) -> Vec<Quad> {
    let (rig, size, s, k, big) = (frame.rig, frame.size, frame.s, frame.k, frame.big);
    let point = |x: f64, y: f64, d: f64| frame.point(x, y, d);
    // Pale marble: faint dark veins (low contrast) on a near-white stone.
    let marble = |seed| {
        value_noise(
            seed,
            (s / 8.0).max(1.0) as u32,
            [0.72, 0.7, 0.66],
            [0.6, 0.58, 0.55],
        )
    };
    let head = point(s * 0.5, s * 0.36, 0.7);
    solids.push(Solid::Ellipsoid {
        centre: head,
        radii: DVec3::new(0.16, 0.21, 0.17),
        texture: marble(51),
    });
    solids.push(Solid::Ellipsoid {
        centre: head + DVec3::new(0.0, 0.42, 0.12),
        radii: DVec3::new(0.36, 0.2, 0.22),
        texture: marble(52),
    });
    // A dark wall with very little contrast.
    let wall = value_noise(
        53,
        (s * 0.75) as u32,
        [0.035, 0.03, 0.03],
        [0.02, 0.018, 0.018],
    );
    vec![
        card(&rig, size, -1.6 * k, big, wall),
        floor(&rig, s, noise(54, 4.0 * s, [0.3, 0.27, 0.22])),
    ]
}

/// The reclining figure of [`DepthScene::Sculpture`].
fn sculpture(frame: &Frame, solids: &mut Vec<Solid>) -> Vec<Quad> {
    let (rig, size, s, k, big) = (frame.rig, frame.size, frame.s, frame.k, frame.big);
    let point = |x: f64, y: f64, d: f64| frame.point(x, y, d);
    // Pale stone with faint grain: nearly textureless at this size.
    let stone = |seed| {
        value_noise(
            seed,
            (s / 6.0).max(1.0) as u32,
            [0.62, 0.6, 0.56],
            [0.57, 0.55, 0.52],
        )
    };
    let torso = point(s * 0.45, s * 0.55, 0.5 * k);
    let parts = [
        (torso, DVec3::new(0.34, 0.14, 0.16)),
        (
            torso + DVec3::new(0.3, -0.04, 0.06),
            DVec3::new(0.18, 0.16, 0.17),
        ),
        (
            torso + DVec3::new(-0.38, -0.12, -0.05),
            DVec3::new(0.11, 0.12, 0.11),
        ),
        (
            torso + DVec3::new(-0.12, -0.13, -0.1),
            DVec3::new(0.2, 0.05, 0.06),
        ),
    ];
    for (i, (centre, radii)) in parts.into_iter().enumerate() {
        solids.push(Solid::Ellipsoid {
            centre,
            radii,
            texture: stone(81 + i as u32),
        });
    }
    let wall = value_noise(
        85,
        (s * 0.5) as u32,
        [0.05, 0.045, 0.04],
        [0.035, 0.03, 0.03],
    );
    vec![
        card(&rig, size, -1.4 * k, big, wall),
        floor(&rig, s, noise(86, 2.0 * s, [0.25, 0.23, 0.2])),
    ]
}

/// The column and ball of [`DepthScene::ShadedColumn`].
fn shaded_column(frame: &Frame, solids: &mut Vec<Solid>) -> Vec<Quad> {
    let (rig, size, s, k, big) = (frame.rig, frame.size, frame.s, frame.k, frame.big);
    let point = |x: f64, y: f64, d: f64| frame.point(x, y, d);
    let faint = |seed, colour: [f32; 3]| {
        value_noise(
            seed,
            (s / 10.0).max(1.0) as u32,
            colour,
            colour.map(|c| c * 0.93),
        )
    };
    solids.push(Solid::Cylinder {
        centre: point(s * 0.35, s * 0.5, 0.6 * k),
        axis: DVec3::Y,
        radius: 0.13,
        half_height: 2.0,
        texture: faint(91, [0.7, 0.66, 0.6]),
    });
    solids.push(Solid::Ellipsoid {
        centre: point(s * 0.68, s * 0.62, 1.0 * k),
        radii: DVec3::splat(0.14),
        texture: faint(92, [0.55, 0.62, 0.7]),
    });
    vec![
        card(&rig, size, -0.8 * k, big, faint(93, [0.8, 0.78, 0.74])),
        floor(&rig, s, faint(94, [0.5, 0.47, 0.42])),
    ]
}

/// A floor: the plane through the image's bottom rows at d = +1.0 (near) rising to the back
/// plane's depth, tilted about the camera's x axis.
fn floor(rig: &ParallelRig, s: f64, texture: Texture) -> Quad {
    let c = (s - 1.0) / 2.0;
    let at = |y: f64, d: f64| {
        let z = rig.depth_of_disparity(d).expect("in front of infinity");
        DVec3::new(0.0, (y - c) * z / rig.focal_px, z)
    };
    // Near edge below the image bottom, far edge at the three-quarter line.
    let (near, far) = (at(1.3 * s, 1.0), at(0.75 * s, -0.6));
    let half_v = (far - near) / 2.0;
    Quad {
        centre: (near + far) / 2.0,
        half_u: DVec3::new(3.0, 0.0, 0.0),
        half_v,
        texture,
    }
}

/// What a plenoptic camera does to its sub-aperture views: a brightness falling with the
/// view's distance from the grid centre (the microlens vignetting: 1 − 0.5·ρ², ρ = 1 at the
/// grid's corners), a radial falloff inside each view that grows with ρ (up to 25 % at the
/// image corners of a corner view), and Gaussian noise of `sigma` 8-bit levels, seeded.
/// Applied to the encoded values, as a camera's gain and read noise are before its curve is
/// inverted by a viewer; the depth maps are untouched.
pub fn plenoptic_degrade(lf: &mut LightField, sigma: f64, seed: u64) {
    let c = lf.grid.centre();
    let rho_max = (c.x * c.x + c.y * c.y).sqrt().max(1e-9);
    let (w, h) = (lf.width as f64, lf.height as f64);
    let r_max = ((w * w + h * h) / 4.0).sqrt();
    let mut rng = Rng::new(seed);
    for view in &mut lf.views {
        let rho = ((view.s as f64 - c.x).powi(2) + (view.t as f64 - c.y).powi(2)).sqrt() / rho_max;
        let gain = 1.0 - 0.5 * rho * rho;
        for (x, y, p) in view.image.enumerate_pixels_mut() {
            let r = ((x as f64 - w / 2.0).powi(2) + (y as f64 - h / 2.0).powi(2)).sqrt() / r_max;
            let g = gain * (1.0 - 0.25 * rho * r * r);
            for v in &mut p.0[..3] {
                let x = *v as f64 * g + sigma * rng.gaussian();
                *v = x.round().clamp(0.0, 255.0) as u8;
            }
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
