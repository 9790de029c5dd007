//! Built-in scenes: light fields that need no files (`demo`) and small ones with exact ground
//! truth for tests (`planes`, `tilted`).
//!
//! World frame = centre camera frame (x right, y down, z forward, metres). Every quad's own
//! normal (`half_u × half_v`) points away from the cameras; [`BuiltinScene::planes`] reports
//! normals flipped to face the centre camera (the orientation the refocus UI uses).
//!
//! | scene    | grid | view    | f (px) | baseline | focus  | planes (point; camera-facing unit normal) |
//! |----------|------|---------|--------|----------|--------|-------------------------------------------|
//! | `demo`   | 7×7  | 192×192 | 230.4  | 0.055 m  | 2.5 m  | floor (0, 0.2006, 4.0453) n (0, −cos 10°, −sin 10°), i.e. a plane 0.9 m below the camera pitched 10° towards it; back wall (0, −1.3, 6) n (0, 0, −1); painting (−0.5, −0.15, 2.7) n (−sin 35°, 0, −cos 35°); card (0.32, 0.12, 1.6) n (0, 0, −1) |
//! | `planes` | 5×5  | 64×64   | 80     | 0.1 m    | 3 m    | back (0, 0, 4) n (0, 0, −1); near (0.35, 0.25, 2) n (0, 0, −1) |
//! | `tilted` | 5×5  | 64×64   | 80     | 0.1 m    | 3 m    | (0, 0, 3) n (0, −sin 40°, −cos 40°): z = 3 − tan 40°·y, farther towards the top |
//!
//! Disparities (px per grid step, HCI sign: positive = nearer than focus). The centre view's
//! disparity map spans, exactly (f32-rounded), and [`BuiltinScene::disparity_range`] bounds it
//! with ≤ 0.05 px padding:
//!
//! | scene    | centre view (exact)     | `disparity_range` | all views    |
//! |----------|-------------------------|-------------------|--------------|
//! | `demo`   | −2.9568 … +3.1236       | (−2.96, 3.13)     | −2.957 … +3.812 |
//! | `planes` | −2/3 (back), +4/3 (near) | (−0.67, 1.34)    | same         |
//! | `tilted` | −0.8811 … +0.8811       | (−0.89, 0.89)     | −0.933 … +0.933 |
//!
//! (Edge views reach further because sensor shift moves their frusta: the bottom-row views of
//! `demo` see the floor nearer at their bottom edge.) Per plane in `demo`: back wall −2.957;
//! painting +0.18 (right edge, z 2.413 m) … −0.83 (left edge, z 2.987 m); card +2.851; floor
//! −2.957 (at the wall) … +3.124 (centre view's bottom edge, z 1.547 m).
//!
//! Every plane's reported point is visible in the centre view, and no view of any built-in
//! scene shows background.

use glam::DVec3;

use super::raytrace::render_light_field;
use super::scene::{Quad, Scene};
use super::texture::Texture;
use crate::lightfield::{GridSize, LightField, ParallelRig};

/// A ready-to-render built-in scene with its camera rig.
#[derive(Debug, Clone, PartialEq)]
pub struct BuiltinScene {
    pub name: &'static str,
    pub scene: Scene,
    pub rig: ParallelRig,
    pub grid: GridSize,
    pub width: u32,
    pub height: u32,
    pub description: &'static str,
    /// One label per quad of `scene.quads`, same order.
    pub labels: Vec<&'static str>,
    /// Bounds (min, max) of the centre view's disparity map (px per grid step), padded by at
    /// most 0.05 px beyond the exact extremes. Edge views see slightly different depth ranges
    /// (their frusta differ); the disparity of a surface point is the same in every view.
    pub disparity_range: (f64, f64),
}

/// Names accepted by [`builtin`].
pub fn builtin_names() -> &'static [&'static str] {
    &["demo", "planes", "tilted"]
}

/// The built-in scene called `name`, or `None`.
pub fn builtin(name: &str) -> Option<BuiltinScene> {
    match name {
        "demo" => Some(demo()),
        "planes" => Some(planes()),
        "tilted" => Some(tilted()),
        _ => None,
    }
}

impl BuiltinScene {
    /// Each quad's plane as (label, point, unit normal) in the world frame (= centre camera
    /// frame). The point is the quad's centre, which is visible in the centre view; the normal
    /// faces the centre camera (n·(C − p) > 0 with C the origin).
    pub fn planes(&self) -> Vec<(String, DVec3, DVec3)> {
        self.scene
            .quads
            .iter()
            .enumerate()
            .map(|(i, q)| {
                let n = q.normal();
                let n = if n.dot(-q.centre) < 0.0 { -n } else { n };
                let label = self.labels.get(i).copied().unwrap_or("quad");
                (label.to_string(), q.centre, n)
            })
            .collect()
    }

    /// Renders the full light field with `samples_per_axis`² samples per pixel.
    pub fn light_field(&self, samples_per_axis: u32) -> LightField {
        let mut lf = render_light_field(
            &self.scene,
            self.name,
            self.grid,
            self.width,
            self.height,
            &self.rig,
            samples_per_axis,
        );
        lf.disparity_range = Some(self.disparity_range);
        lf
    }
}

/// Linear-light colours of the scenes.
mod colours {
    use super::super::texture::Rgb;
    pub const SAND: Rgb = [0.62, 0.52, 0.36];
    pub const SLATE: Rgb = [0.045, 0.085, 0.12];
    pub const BRICK: Rgb = [0.42, 0.13, 0.07];
    pub const MORTAR: Rgb = [0.50, 0.48, 0.44];
    pub const CREAM: Rgb = [0.88, 0.80, 0.60];
    pub const NAVY: Rgb = [0.015, 0.03, 0.20];
    pub const SKY: Rgb = [0.35, 0.55, 0.85];
    pub const PAPER: Rgb = [0.80, 0.80, 0.78];
    pub const INK: Rgb = [0.02, 0.02, 0.02];
    pub const TEAL: Rgb = [0.05, 0.35, 0.35];
    pub const ORANGE: Rgb = [0.9, 0.35, 0.05];
}

/// The demo: a checkered floor receding to a brick wall, a painting turned 35° towards the
/// viewer at mid distance and a colour-bar card close to the camera.
///
/// Disparity (b·f = 12.672 px·m, focus 2.5 m): wall at 6 m −2.957 px; painting +0.18 (right
/// edge, z 2.413 m) … −0.83 px (left edge, z 2.987 m); card at 1.6 m +2.851 px; floor in the
/// centre view from −2.957 (where it meets the wall) to +3.124 px (bottom edge, z 1.547 m).
/// Edge views see the floor slightly nearer at their bottom edge (up to ≈ +3.8 px in the
/// bottom row) because sensor shift moves their frusta.
fn demo() -> BuiltinScene {
    let (w, h) = (192u32, 192u32);
    let rig = ParallelRig {
        focal_px: 1.2 * w as f64,
        baseline: 0.055,
        focus_distance: 2.5,
    };

    // Floor: the plane y·cos α + z·sin α = 0.9, i.e. 0.9 m below the camera and pitched by
    // α = 10° so its horizon would sit above the image centre (hidden by the wall). Its points
    // are 0.9·n' + λ·d with n' = (0, cos α, sin α) and d = (0, −sin α, cos α) running away
    // from the camera; λ ∈ [λ0, λ0 + 7.2] spans z from 0.5 m to past the wall.
    let alpha = 10f64.to_radians();
    let (sa, ca) = alpha.sin_cos();
    let drop = 0.9;
    let n_down = DVec3::new(0.0, ca, sa);
    let away = DVec3::new(0.0, -sa, ca);
    let lambda0 = (0.5 - drop * sa) / ca;
    let floor_centre = drop * n_down + (lambda0 + 3.6) * away;
    let floor = Quad {
        centre: floor_centre,
        half_u: DVec3::new(3.6, 0.0, 0.0),
        // v grows towards the camera (down the image), so the normal hu × hv = n' points down.
        half_v: -3.6 * away,
        texture: Texture::Checker {
            cells_u: 24,
            cells_v: 24,
            a: colours::SAND,
            b: colours::SLATE,
        },
    };

    let wall = Quad {
        centre: DVec3::new(0.0, -1.3, 6.0),
        half_u: DVec3::new(3.6, 0.0, 0.0),
        half_v: DVec3::new(0.0, 1.8, 0.0),
        texture: Texture::Bricks {
            rows: 18,
            cols: 18,
            seed: 7,
            brick: colours::BRICK,
            mortar: colours::MORTAR,
        },
    };

    // Rotated about y by 35°: the right edge is nearer than the left one.
    let (sb, cb) = 35f64.to_radians().sin_cos();
    let painting = Quad {
        centre: DVec3::new(-0.5, -0.15, 2.7),
        half_u: 0.5 * DVec3::new(cb, 0.0, -sb),
        half_v: DVec3::new(0.0, 0.38, 0.0),
        texture: Texture::Detail {
            seed: 11,
            grain: 160,
            // ~4 px per ring pair at the painting's distance: fine, but above Nyquist.
            rings: 7,
            text: "TILT".into(),
            paper: colours::CREAM,
            ink: colours::NAVY,
        },
    };

    let card = Quad {
        centre: DVec3::new(0.32, 0.12, 1.6),
        half_u: DVec3::new(0.15, 0.0, 0.0),
        half_v: DVec3::new(0.0, 0.1, 0.0),
        texture: Texture::ColourBars { stripes: 12 },
    };

    BuiltinScene {
        name: "demo",
        scene: Scene {
            quads: vec![floor, wall, painting, card],
            background: colours::SKY,
            solids: Vec::new(),
            lighting: None,
        },
        rig,
        grid: GridSize { cols: 7, rows: 7 },
        width: w,
        height: h,
        description: "checkered floor receding to a brick wall at 6 m, a painting turned 35° \
                      at 2.7 m, a colour-bar card at 1.6 m; 7×7 views of 192×192, focus 2.5 m",
        labels: vec!["floor", "back wall", "painting", "card"],
        disparity_range: (-2.96, 3.13),
    }
}

/// Two frontoparallel planes: a textured back plane at z = 4 filling every view (disparity
/// −2/3 px) and a checkered square at z = 2 (disparity +4/3 px). b·f = 8 px·m, focus 3 m.
fn planes() -> BuiltinScene {
    let rig = ParallelRig {
        focal_px: 80.0,
        baseline: 0.1,
        focus_distance: 3.0,
    };
    let back = Quad {
        centre: DVec3::new(0.0, 0.0, 4.0),
        half_u: DVec3::new(2.5, 0.0, 0.0),
        half_v: DVec3::new(0.0, 2.5, 0.0),
        texture: Texture::Detail {
            seed: 1,
            grain: 96,
            rings: 8,
            text: "FAR".into(),
            paper: colours::PAPER,
            ink: colours::INK,
        },
    };
    let near = Quad {
        centre: DVec3::new(0.35, 0.25, 2.0),
        half_u: DVec3::new(0.3, 0.0, 0.0),
        half_v: DVec3::new(0.0, 0.3, 0.0),
        texture: Texture::Checker {
            cells_u: 6,
            cells_v: 6,
            a: colours::ORANGE,
            b: colours::TEAL,
        },
    };
    BuiltinScene {
        name: "planes",
        scene: Scene {
            quads: vec![back, near],
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: None,
        },
        rig,
        grid: GridSize { cols: 5, rows: 5 },
        width: 64,
        height: 64,
        description: "frontoparallel textured plane at 4 m and a checkered square at 2 m; \
                      5×5 views of 64×64, focus 3 m",
        labels: vec!["back", "near"],
        disparity_range: (-0.67, 1.34),
    }
}

/// One plane through (0, 0, 3) tilted 40° about the x axis, farther towards the top of the
/// image (z = 3 − tan 40°·y). Centre-view depth spans 2.255…4.480 m, disparity +0.881…−0.881 px.
fn tilted() -> BuiltinScene {
    let rig = ParallelRig {
        focal_px: 80.0,
        baseline: 0.1,
        focus_distance: 3.0,
    };
    let (s, c) = 40f64.to_radians().sin_cos();
    let plane = Quad {
        centre: DVec3::new(0.0, 0.0, 3.0),
        half_u: DVec3::new(3.0, 0.0, 0.0),
        // Down the image the plane comes nearer; normal hu × hv ∝ (0, sin 40°, cos 40°).
        half_v: 3.6 * DVec3::new(0.0, c, -s),
        texture: Texture::Detail {
            seed: 5,
            grain: 128,
            rings: 10,
            text: "TILT".into(),
            paper: colours::PAPER,
            ink: colours::INK,
        },
    };
    BuiltinScene {
        name: "tilted",
        scene: Scene {
            quads: vec![plane],
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: None,
        },
        rig,
        grid: GridSize { cols: 5, rows: 5 },
        width: 64,
        height: 64,
        description: "one textured plane through (0, 0, 3 m) tilted 40° about x like a floor; \
                      5×5 views of 64×64, focus 3 m",
        labels: vec!["tilted plane"],
        disparity_range: (-0.89, 0.89),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::raytrace::trace_pixel;
    use glam::DVec2;

    #[test]
    fn names_resolve() {
        for name in builtin_names() {
            let b = builtin(name).unwrap();
            assert_eq!(b.name, *name);
            assert_eq!(b.labels.len(), b.scene.quads.len());
            assert!(!b.description.is_empty());
        }
        assert!(builtin("nope").is_none());
    }

    #[test]
    fn reported_planes_are_visible_unit_and_camera_facing() {
        for name in builtin_names() {
            let b = builtin(name).unwrap();
            let cams = b.rig.cameras(b.grid, b.width, b.height);
            let centre = &cams[b.grid.index(b.grid.cols / 2, b.grid.rows / 2)];
            for (i, (label, p, n)) in b.planes().into_iter().enumerate() {
                assert!((n.length() - 1.0).abs() < 1e-12, "{name} {label}");
                assert!(n.dot(-p) > 0.0, "{name} {label} faces away");
                let q = &b.scene.quads[i];
                assert!(q.half_u.dot(n).abs() < 1e-12 && q.half_v.dot(n).abs() < 1e-12);
                let px = centre.project(p).unwrap();
                let (hit, _) = trace_pixel(&b.scene, centre, px).unwrap();
                assert_eq!(hit.quad_index, i, "{name} {label}: its point is hidden");
                assert!((hit.point - p).length() < 1e-9);
            }
        }
    }

    #[test]
    fn documented_plane_parameters() {
        let close = |a: DVec3, b: DVec3| (a - b).length() < 1e-9;
        let (s10, c10) = 10f64.to_radians().sin_cos();
        let (s35, c35) = 35f64.to_radians().sin_cos();
        let (s40, c40) = 40f64.to_radians().sin_cos();
        let demo = builtin("demo").unwrap().planes();
        assert!(close(demo[0].2, DVec3::new(0.0, -c10, -s10)));
        // The floor is 0.9 m below the camera along its normal, its point where documented.
        assert!((demo[0].1.dot(-demo[0].2) - 0.9).abs() < 1e-12);
        assert!((demo[0].1.y - 0.2).abs() < 1e-3 && (demo[0].1.z - 4.045).abs() < 1e-3);
        assert!(close(demo[1].1, DVec3::new(0.0, -1.3, 6.0)) && close(demo[1].2, -DVec3::Z));
        assert!(close(demo[2].1, DVec3::new(-0.5, -0.15, 2.7)));
        assert!(close(demo[2].2, DVec3::new(-s35, 0.0, -c35)));
        assert!(close(demo[3].1, DVec3::new(0.32, 0.12, 1.6)) && close(demo[3].2, -DVec3::Z));
        let planes = builtin("planes").unwrap().planes();
        assert!(close(planes[0].1, DVec3::new(0.0, 0.0, 4.0)) && close(planes[0].2, -DVec3::Z));
        assert!(close(planes[1].1, DVec3::new(0.35, 0.25, 2.0)) && close(planes[1].2, -DVec3::Z));
        let tilted = builtin("tilted").unwrap().planes();
        assert!(close(tilted[0].1, DVec3::new(0.0, 0.0, 3.0)));
        assert!(close(tilted[0].2, DVec3::new(0.0, -s40, -c40)));
    }

    /// Every view: alpha 255, real content (many colours), every quad visible, no background;
    /// the centre maps finite, consistent with the tracer and within the documented range,
    /// which is tight (its ends within 0.06 px of the observed extremes).
    #[test]
    fn every_builtin_renders_completely_within_its_disparity_range() {
        for name in builtin_names() {
            let b = builtin(name).unwrap();
            let lf = b.light_field(1);
            lf.validate().unwrap();
            let min_quad_px = (b.width * b.height / 200) as usize;
            for v in &lf.views {
                let mut colours = std::collections::BTreeSet::new();
                let mut per_quad = vec![0usize; b.scene.quads.len()];
                for (i, j, p) in v.image.enumerate_pixels() {
                    assert_eq!(p.0[3], 255);
                    colours.insert(p.0);
                    let hit = trace_pixel(&b.scene, &v.camera, DVec2::new(i as f64, j as f64));
                    let (hit, _) = hit
                        .unwrap_or_else(|| panic!("{name} {}: background at ({i},{j})", v.source));
                    per_quad[hit.quad_index] += 1;
                }
                assert!(
                    colours.len() > 20,
                    "{name} {}: {} colours",
                    v.source,
                    colours.len()
                );
                for (q, &count) in per_quad.iter().enumerate() {
                    assert!(
                        count >= min_quad_px,
                        "{name} {}: {} covers {count} px",
                        v.source,
                        b.labels[q]
                    );
                }
            }
            assert_eq!(lf.depth.len(), 2);
            let centre = b.grid.index(b.grid.cols / 2, b.grid.rows / 2);
            let cam = &lf.views[centre].camera;
            let (depth, disp) = (&lf.depth[0].1, &lf.depth[1].1);
            assert_eq!(
                (depth.kind, disp.kind),
                (
                    crate::lightfield::DepthKind::Depth,
                    crate::lightfield::DepthKind::Disparity
                )
            );
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for j in 0..b.height {
                for i in 0..b.width {
                    let (_, z) =
                        trace_pixel(&b.scene, cam, DVec2::new(i as f64, j as f64)).unwrap();
                    assert!(depth.at(i, j).is_finite());
                    assert_eq!(depth.at(i, j), z as f32);
                    let d = disp.at(i, j) as f64;
                    lo = lo.min(d);
                    hi = hi.max(d);
                }
            }
            let (rlo, rhi) = b.disparity_range;
            assert!(
                rlo <= lo && hi <= rhi,
                "{name}: observed {lo}…{hi}, documented {rlo}…{rhi}"
            );
            assert!(
                lo - rlo < 0.06 && rhi - hi < 0.06,
                "{name}: observed {lo}…{hi}, documented {rlo}…{rhi}"
            );
        }
    }
}
