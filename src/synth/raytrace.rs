//! The analytic CPU ray tracer: renders views (colour and exact depth) and whole light fields.
//!
//! Rays follow the camera conventions of [`crate::geometry::camera`]: the ray through pixel
//! position p starts at the camera centre `C = −Rᵀ t` and has world direction `Rᵀ K⁻¹ [p, 1]ᵀ`.
//! Because `K⁻¹ [p, 1]ᵀ` has camera-frame z = 1, the ray parameter of a hit is its camera-frame
//! depth.
//!
//! Colour: each pixel (i, j) averages an n×n stratified grid of rays inside its footprint
//! [i − ½, i + ½] × [j − ½, j + ½] (sample k of n at offset (k + ½)/n − ½) in linear light,
//! then encodes to 8-bit sRGB with rounding. Depth: the ray through the pixel centre only, so
//! it is exact ground truth for that pixel position (NaN where the ray hits nothing).

use glam::{DMat3, DVec2, DVec3};
use image::RgbaImage;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use super::scene::{Hit, PreparedScene, Scene};
use crate::color::encode_srgb8;
use crate::geometry::camera::Camera;
use crate::lightfield::{DepthKind, DepthMap, GridSize, LightField, ParallelRig, Source, View};

/// Per-camera ray generation with `K⁻¹` and `Rᵀ` computed once. `Camera::ray_camera` inverts K
/// per call; the same `DMat3::inverse` computed once gives bit-identical directions.
struct Rays {
    origin: DVec3,
    rt: DMat3,
    k_inv: DMat3,
}

impl Rays {
    fn new(camera: &Camera) -> Self {
        Rays {
            origin: camera.centre(),
            rt: camera.r.transpose(),
            k_inv: camera.k.inverse(),
        }
    }

    /// (camera-frame direction, world direction) of the ray through pixel position `p`.
    fn dirs(&self, p: DVec2) -> (DVec3, DVec3) {
        let dc = self.k_inv * p.extend(1.0);
        (dc, self.rt * dc)
    }
}

/// The world ray through pixel position `pixel` (pixel-index coordinates): `(origin, dir)` with
/// `dir = Rᵀ K⁻¹ [pixel, 1]ᵀ` (not normalised: camera-frame z = 1).
pub fn pixel_ray(camera: &Camera, pixel: DVec2) -> (DVec3, DVec3) {
    let rays = Rays::new(camera);
    (rays.origin, rays.dirs(pixel).1)
}

/// What the ray through pixel position `pixel` sees: the nearest hit and its camera-frame depth
/// z, exactly as [`render_view`] computes its depth map (in f64, before the f32 store).
pub fn trace_pixel(scene: &Scene, camera: &Camera, pixel: DVec2) -> Option<(Hit, f64)> {
    trace(&PreparedScene::new(scene), &Rays::new(camera), pixel)
}

fn trace(scene: &PreparedScene, rays: &Rays, pixel: DVec2) -> Option<(Hit, f64)> {
    let (dc, dw) = rays.dirs(pixel);
    scene.intersect(rays.origin, dw).map(|h| (h, h.t * dc.z))
}

/// Renders one `width × height` view: sRGB-encoded RGBA8 (alpha 255) with `samples_per_axis`²
/// stratified samples per pixel (0 is treated as 1), and the camera-frame depth of the surface
/// seen at each pixel centre ([`DepthKind::Depth`], NaN for background). Rows render in
/// parallel; the result is deterministic.
pub fn render_view(
    scene: &Scene,
    camera: &Camera,
    width: u32,
    height: u32,
    samples_per_axis: u32,
) -> (RgbaImage, DepthMap) {
    let n = samples_per_axis.max(1);
    let (w, h) = (width as usize, height as usize);
    let mut rgba = vec![0u8; w * h * 4];
    let mut depth = vec![f32::NAN; w * h];
    // `par_chunks_mut(0)` would panic; an empty view has nothing to render anyway.
    if w > 0 && h > 0 {
        let rays = Rays::new(camera);
        let prepared = PreparedScene::new(scene);
        let offsets: Vec<f64> = (0..n).map(|k| (k as f64 + 0.5) / n as f64 - 0.5).collect();
        let inv_count = 1.0 / (n * n) as f32;
        rgba.par_chunks_mut(w * 4)
            .zip(depth.par_chunks_mut(w))
            .enumerate()
            .for_each(|(j, (row, zrow))| {
                for i in 0..w {
                    let centre = DVec2::new(i as f64, j as f64);
                    let mut sum = [0.0f32; 3];
                    // For odd n the middle sample is the pixel centre (offset exactly 0), so
                    // its hit gives the depth without tracing the centre ray again.
                    let mut centre_hit = None;
                    for &oy in &offsets {
                        for &ox in &offsets {
                            let hit = trace(&prepared, &rays, centre + DVec2::new(ox, oy));
                            let c =
                                scene.shade(hit.as_ref().map(|(h, _)| h), rays.origin, |a, b| {
                                    prepared.intersect(a, b - a).is_some_and(|h| h.t < 1.0)
                                });
                            for (s, v) in sum.iter_mut().zip(c) {
                                *s += v;
                            }
                            if ox == 0.0 && oy == 0.0 {
                                centre_hit = Some(hit);
                            }
                        }
                    }
                    for (k, s) in sum.iter().enumerate() {
                        row[4 * i + k] = encode_srgb8(s * inv_count);
                    }
                    row[4 * i + 3] = 255;
                    let hit = centre_hit.unwrap_or_else(|| trace(&prepared, &rays, centre));
                    if let Some((_, z)) = hit {
                        zrow[i] = z as f32;
                    }
                }
            });
    }
    let image = RgbaImage::from_raw(width, height, rgba)
        // Unreachable (the buffer has exactly w·h·4 bytes); a blank image beats a panic.
        .unwrap_or_else(|| RgbaImage::new(width, height));
    let depth = DepthMap {
        width,
        height,
        kind: DepthKind::Depth,
        values: depth,
        source: "generated".into(),
        estimated: false,
    };
    (image, depth)
}

/// Renders a complete light field of `scene` with the cameras of `rig` (`rig.cameras(grid,
/// width, height)`, world frame = centre camera frame). Views render one after another (each in
/// parallel over rows) with a progress bar on stderr (hidden when stderr is not a terminal).
///
/// The view at `grid.index(cols / 2, rows / 2)` (the centre view for odd grids) gets two maps:
/// its depth ([`DepthKind::Depth`]) and its HCI disparity ([`DepthKind::Disparity`],
/// `rig.disparity_of_depth(z)`), both NaN on background.
pub fn render_light_field(
    scene: &Scene,
    name: &str,
    grid: GridSize,
    width: u32,
    height: u32,
    rig: &ParallelRig,
    samples_per_axis: u32,
) -> LightField {
    let cameras = rig.cameras(grid, width, height);
    let progress = ProgressBar::new(cameras.len() as u64).with_style(
        ProgressStyle::with_template("rendering {msg} {bar:30} {pos}/{len} views")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    progress.set_message(name.to_string());
    let centre_index = grid.index(grid.cols / 2, grid.rows / 2);
    let mut views = Vec::with_capacity(cameras.len());
    let mut depth = Vec::new();
    for (index, camera) in cameras.into_iter().enumerate() {
        let (s, t) = (index % grid.cols.max(1), index / grid.cols.max(1));
        let (image, z) = render_view(scene, &camera, width, height, samples_per_axis);
        if index == centre_index {
            let disparity =
                z.to_disparity(rig, format!("{name} generated disparity of view ({s},{t})"));
            let z = DepthMap {
                source: format!("{name} generated depth of view ({s},{t})"),
                ..z
            };
            depth.push((index, z));
            depth.push((index, disparity));
        }
        views.push(View {
            s,
            t,
            camera,
            image,
            source: format!("{name} view ({s},{t})"),
        });
        progress.inc(1);
    }
    progress.finish_and_clear();
    LightField {
        name: name.to_string(),
        grid,
        width,
        height,
        views,
        depth,
        rig: Some(*rig),
        disparity_range: None,
        source: Source::Generated { scene: name.into() },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::intrinsics;
    use crate::synth::builtin::builtin;
    use crate::synth::scene::{plane_scene, Quad};
    use crate::synth::texture::Texture;

    fn rig() -> ParallelRig {
        ParallelRig {
            focal_px: 40.0,
            baseline: 0.2,
            focus_distance: 3.0,
        }
    }

    /// A camera with a non-trivial rotation and centre, to exercise `Rᵀ` and `C`.
    fn rotated_camera() -> Camera {
        Camera::from_centre(
            intrinsics(50.0, 55.0, 20.3, 14.8),
            glam::DMat3::from_euler(glam::EulerRot::XYZ, 0.12, -0.2, 0.07),
            DVec3::new(0.3, -0.2, -0.5),
        )
    }

    #[test]
    fn frontoparallel_depth_is_exact_in_every_view() {
        let scene = plane_scene(
            DVec3::Z,
            DVec3::new(0.0, 0.0, 2.5),
            10.0,
            Texture::Solid([1.0; 3]),
        );
        let grid = GridSize { cols: 5, rows: 5 };
        for cam in rig().cameras(grid, 32, 24) {
            let (_, depth) = render_view(&scene, &cam, 32, 24, 1);
            assert_eq!(depth.values.len(), 32 * 24);
            for &z in &depth.values {
                assert!((z as f64 - 2.5).abs() <= 2.5e-9, "depth {z}");
            }
            for p in [
                DVec2::new(0.0, 0.0),
                DVec2::new(31.0, 23.0),
                DVec2::new(7.3, 11.9),
            ] {
                let (_, z) = trace_pixel(&scene, &cam, p).unwrap();
                assert!((z - 2.5).abs() <= 2.5e-9, "depth {z} at {p}");
            }
        }
    }

    #[test]
    fn tilted_depth_matches_closed_form_ray_plane_intersection() {
        let n = DVec3::new(0.2, -0.5, -1.0).normalize();
        let p = DVec3::new(0.1, 0.2, 3.0);
        let scene = plane_scene(n, p, 20.0, Texture::Solid([0.5; 3]));
        let grid = GridSize { cols: 3, rows: 3 };
        let mut cams = rig().cameras(grid, 40, 30);
        cams.push(rotated_camera());
        for cam in &cams {
            let (_, depth) = render_view(&scene, cam, 40, 30, 2);
            let (k, c, rt) = (cam.k, cam.centre(), cam.r.transpose());
            let (fx, fy, cx, cy) = (k.x_axis.x, k.y_axis.y, k.z_axis.x, k.z_axis.y);
            for j in 0..30 {
                for i in 0..40 {
                    // Independent closed form: K⁻¹ written out, λ = n·(p − C)/(n·w).
                    let dc = DVec3::new((i as f64 - cx) / fx, (j as f64 - cy) / fy, 1.0);
                    let w = rt * dc;
                    let z = n.dot(p - c) / n.dot(w) * dc.z;
                    let got = depth.at(i, j) as f64;
                    assert!((got - z).abs() <= 1e-6 * z, "({i},{j}): {got} vs {z}");
                    let (_, exact) =
                        trace_pixel(&scene, cam, DVec2::new(i as f64, j as f64)).unwrap();
                    assert!((exact - z).abs() <= 1e-9 * z, "({i},{j}): {exact} vs {z}");
                }
            }
        }
    }

    /// Signed distance (px) of `x` inside the convex polygon `poly` (positive inside).
    fn inside_distance(poly: &[DVec2], x: DVec2) -> f64 {
        let area: f64 = (0..poly.len())
            .map(|k| poly[k].perp_dot(poly[(k + 1) % poly.len()]))
            .sum();
        let orient = area.signum();
        (0..poly.len())
            .map(|k| {
                let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                orient * (b - a).perp_dot(x - a) / (b - a).length()
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn projected_corners_bound_the_rendered_quad() {
        let white = Quad {
            centre: DVec3::new(0.4, 0.1, 3.2),
            half_u: DVec3::new(0.7, 0.1, 0.3),
            half_v: DVec3::new(-0.05, 0.5, 0.2),
            texture: Texture::Solid([1.0; 3]),
        };
        let scene = Scene {
            quads: vec![white.clone()],
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: None,
        };
        let grid = GridSize { cols: 3, rows: 3 };
        let mut cams = rig().cameras(grid, 40, 30);
        cams.push(rotated_camera());
        for cam in &cams {
            let poly: Vec<DVec2> = white
                .corners()
                .iter()
                .map(|&x| cam.project(x).unwrap())
                .collect();
            for n in [1, 3] {
                let (img, _) = render_view(&scene, cam, 40, 30, n);
                let (mut white_px, mut black_px, mut partial) = (0, 0, 0);
                for j in 0..30 {
                    for i in 0..40 {
                        let d = inside_distance(&poly, DVec2::new(i as f64, j as f64));
                        let v = img.get_pixel(i, j).0;
                        assert_eq!(v[3], 255);
                        if d > 1.0 {
                            assert_eq!(v[0], 255, "({i},{j}) is {d} px inside but {v:?}");
                            white_px += 1;
                        } else if d < -1.0 {
                            assert_eq!(v[0], 0, "({i},{j}) is {} px outside but {v:?}", -d);
                            black_px += 1;
                        } else if v[0] != 0 && v[0] != 255 {
                            partial += 1;
                        }
                        // Exactly: the value is the fraction of the n×n stratified sample
                        // points of the footprint that fall inside the projected outline
                        // (pixels with a sample within 1e-7 px of an edge are ambiguous).
                        let samples: Vec<f64> = (0..n * n)
                            .map(|k| {
                                let o = |k: u32| (k as f64 + 0.5) / n as f64 - 0.5;
                                let p = DVec2::new(i as f64 + o(k % n), j as f64 + o(k / n));
                                inside_distance(&poly, p)
                            })
                            .collect();
                        if samples.iter().all(|d| d.abs() > 1e-7) {
                            let inside = samples.iter().filter(|&&d| d > 0.0).count();
                            let expect = encode_srgb8(inside as f32 / (n * n) as f32);
                            assert_eq!(v[0], expect, "({i},{j}): {inside}/{} inside", n * n);
                        }
                    }
                }
                assert!(
                    white_px > 50 && black_px > 50,
                    "{white_px} white, {black_px} black"
                );
                // Supersampling produces intermediate values only along the edges.
                assert_eq!(
                    partial > 0,
                    n > 1,
                    "{partial} partially covered pixels, n = {n}"
                );
            }
        }
    }

    #[test]
    fn supersamples_average_in_linear_light() {
        // A white half-plane whose left edge passes exactly through the centres of column 10:
        // with 2×2 samples, pixels of column 10 are half covered, i.e. linear 0.5.
        let cam = Camera::from_centre(
            intrinsics(20.0, 20.0, 9.5, 9.5),
            glam::DMat3::IDENTITY,
            DVec3::ZERO,
        );
        let z = 2.0;
        let edge_x = (10.0 - 9.5) / 20.0 * z;
        let scene = Scene {
            quads: vec![Quad {
                centre: DVec3::new(edge_x + 5.0, 0.0, z),
                half_u: DVec3::new(5.0, 0.0, 0.0),
                half_v: DVec3::new(0.0, 5.0, 0.0),
                texture: Texture::Solid([1.0; 3]),
            }],
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: None,
        };
        let (img, _) = render_view(&scene, &cam, 20, 20, 2);
        assert_eq!(img.get_pixel(9, 5).0, [0, 0, 0, 255]);
        // encode(0.5) = 0.7354 · 255 = 187.5… → 188, not the 128 of averaging encoded values.
        assert_eq!(img.get_pixel(10, 5).0, [188, 188, 188, 255]);
        assert_eq!(img.get_pixel(11, 5).0, [255, 255, 255, 255]);
    }

    #[test]
    fn background_is_nan_depth_and_background_colour() {
        let scene = Scene {
            background: [0.25, 0.5, 1.0],
            ..plane_scene(
                DVec3::Z,
                DVec3::new(0.0, 0.0, 2.0),
                0.3,
                Texture::Solid([1.0; 3]),
            )
        };
        let cam = Camera::from_centre(
            intrinsics(30.0, 30.0, 15.5, 15.5),
            glam::DMat3::IDENTITY,
            DVec3::ZERO,
        );
        let (img, depth) = render_view(&scene, &cam, 32, 32, 2);
        let (mut hits, mut misses) = (0, 0);
        for j in 0..32 {
            for i in 0..32 {
                let z = depth.at(i, j);
                match trace_pixel(&scene, &cam, DVec2::new(i as f64, j as f64)) {
                    Some(_) => {
                        assert_eq!(z, 2.0);
                        hits += 1;
                    }
                    None => {
                        assert!(z.is_nan());
                        misses += 1;
                        if (i as f64 - 15.5).abs() > 6.0 || (j as f64 - 15.5).abs() > 6.0 {
                            assert_eq!(img.get_pixel(i, j).0, [137, 188, 255, 255]);
                        }
                    }
                }
            }
        }
        assert!(hits > 50 && misses > 50);
        // Zero-sized views and zero samples: no panic.
        let (img, depth) = render_view(&scene, &cam, 0, 5, 0);
        assert_eq!((img.width(), img.height(), depth.values.len()), (0, 5, 0));
        let (img, _) = render_view(&scene, &cam, 3, 3, 0);
        assert_eq!(img.dimensions(), (3, 3));
    }

    /// A centre-view pixel x with disparity d is seen in view (s, t) at x − d·(s − s_c, t − t_c):
    /// the point hit at x projects there, and the ray through that position hits the same point.
    fn check_disparity_consistency(name: &str, min_visible: f64) {
        let b = builtin(name).unwrap();
        let cams = b.rig.cameras(b.grid, b.width, b.height);
        let sc = b.grid.centre();
        let centre = &cams[b.grid.index(b.grid.cols / 2, b.grid.rows / 2)];
        let (mut checked, mut visible) = (0usize, 0usize);
        for j in (0..b.height).step_by(5) {
            for i in (0..b.width).step_by(5) {
                let x = DVec2::new(i as f64, j as f64);
                let (hit, z) = trace_pixel(&b.scene, centre, x).unwrap();
                let d = b.rig.disparity_of_depth(z);
                for (s, t) in [
                    (0, 0),
                    (b.grid.cols - 1, 0),
                    (0, b.grid.rows - 1),
                    (b.grid.cols - 1, b.grid.rows - 1),
                    (1, b.grid.rows / 2),
                ] {
                    let cam = &cams[b.grid.index(s, t)];
                    let expected = x - d * (DVec2::new(s as f64, t as f64) - sc);
                    let projected = cam.project(hit.point).unwrap();
                    assert!(
                        (projected - expected).length() < 1e-6,
                        "{name} ({i},{j}) in ({s},{t}): {projected} vs {expected}"
                    );
                    checked += 1;
                    if let Some((h2, _)) = trace_pixel(&b.scene, cam, expected) {
                        if h2.quad_index == hit.quad_index {
                            assert!(
                                (h2.point - hit.point).length() < 1e-9 * z,
                                "{name} ({i},{j}) in ({s},{t})"
                            );
                            assert!((h2.uv - hit.uv).length() < 1e-9);
                            visible += 1;
                        } else {
                            // Occluded in that view: something nearer covers it. The ray
                            // parameter is camera-frame depth (direction z = 1).
                            assert!(
                                h2.t < cam.to_camera(hit.point).z,
                                "{name} ({i},{j}) in ({s},{t})"
                            );
                        }
                    }
                }
            }
        }
        assert!(
            visible as f64 >= min_visible * checked as f64,
            "{name}: {visible}/{checked} visible"
        );
    }

    #[test]
    fn disparity_predicts_positions_in_other_views() {
        check_disparity_consistency("tilted", 1.0);
        check_disparity_consistency("planes", 0.9);
        check_disparity_consistency("demo", 0.9);
    }

    #[test]
    fn rendering_is_deterministic() {
        let b = builtin("demo").unwrap();
        let cam = b.rig.cameras(b.grid, b.width, b.height)[b.grid.index(3, 3)];
        let (a1, d1) = render_view(&b.scene, &cam, b.width, b.height, 2);
        let (a2, d2) = render_view(&b.scene, &cam, b.width, b.height, 2);
        assert_eq!(a1.as_raw(), a2.as_raw());
        let bits = |d: &DepthMap| d.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&d1), bits(&d2));
        let p = builtin("planes").unwrap();
        let (l1, l2) = (p.light_field(2), p.light_field(2));
        for (v1, v2) in l1.views.iter().zip(&l2.views) {
            assert_eq!(v1.image.as_raw(), v2.image.as_raw());
        }
    }

    #[test]
    fn light_field_has_views_maps_rig_and_source() {
        let p = builtin("planes").unwrap();
        let lf = p.light_field(1);
        lf.validate().unwrap();
        assert_eq!(lf.name, "planes");
        assert_eq!(lf.views.len(), 25);
        assert_eq!(lf.view(3, 1).source, "planes view (3,1)");
        assert_eq!((lf.view(3, 1).s, lf.view(3, 1).t), (3, 1));
        assert_eq!(lf.rig, Some(p.rig));
        assert_eq!(
            lf.source,
            Source::Generated {
                scene: "planes".into()
            }
        );
        let kinds: Vec<(usize, DepthKind)> = lf.depth.iter().map(|(i, d)| (*i, d.kind)).collect();
        assert_eq!(
            kinds,
            vec![(12, DepthKind::Depth), (12, DepthKind::Disparity)]
        );
        let (z, d) = (&lf.depth[0].1, &lf.depth[1].1);
        for (zv, dv) in z.values.iter().zip(&d.values) {
            let expect = p.rig.disparity_of_depth(*zv as f64);
            assert!((*dv as f64 - expect).abs() < 1e-5);
        }
        // The centre view's own render matches the attached depth.
        let (_, own) = render_view(&p.scene, &lf.view(2, 2).camera, 64, 64, 1);
        assert_eq!(own.values, z.values);
        // An even grid still attaches maps to view (cols/2, rows/2).
        let lf = render_light_field(
            &p.scene,
            "even",
            GridSize { cols: 2, rows: 2 },
            8,
            8,
            &p.rig,
            1,
        );
        lf.validate().unwrap();
        assert_eq!(lf.depth[0].0, 3);
    }
}
