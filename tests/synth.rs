//! `tiltfield synth`: the Vulkan mesh rasterizer, built-in and glTF scenes, the HCI and manifest
//! layouts read back through the loaders, and the optical ground truth. Every GPU test runs with
//! the validation layer and asserts zero errors; the CLI runs use TILTFIELD_VALIDATION=1, under
//! which `synth` and `render` fail on any validation error.

mod common;

use common::{fails_with, stderr, tiltfield};
use std::path::Path;

use glam::{DVec2, DVec3};
use tiltfield::geometry::aperture::{Aperture, ApertureShape};
use tiltfield::geometry::plane::Plane;
use tiltfield::jobs::raster::Rasterizer;
use tiltfield::lightfield::{self, DepthKind, GridSize, LightField};
use tiltfield::refocus::{self, Averaging, FocusSpec, RefocusRequest};
use tiltfield::synth::{synth_scene, MeshScene, RigKind, SynthRig};

const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/example.gltf");

fn rasterizer(mesh: &MeshScene) -> Rasterizer {
    Rasterizer::new(mesh, &common::gpu_options())
        .unwrap_or_else(|e| panic!("cannot create a validated rasterizer: {e}"))
}

fn assert_clean(r: &Rasterizer) {
    let log = r.context().validation();
    assert_eq!(log.errors(), 0, "validation errors: {:#?}", log.messages());
}

/// A parallel rig with the scene's defaults at the given grid and size.
fn rig(name: &str, n: usize, size: u32) -> SynthRig {
    let s = synth_scene(name).unwrap();
    SynthRig {
        grid: GridSize { cols: n, rows: n },
        width: size,
        height: size,
        focal_px: s.focal_per_width * size as f64,
        baseline: s.baseline,
        focus_distance: s.focus_distance,
        kind: RigKind::Parallel,
    }
}

fn depth_map(lf: &LightField, index: usize, kind: DepthKind) -> &lightfield::DepthMap {
    &lf.depth
        .iter()
        .find(|(i, d)| *i == index && d.kind == kind)
        .unwrap_or_else(|| panic!("no {kind:?} map for view {index}"))
        .1
}

/// Encoded [0, 1] RGB of a linear RGBA image.
fn encoded_linear(px: &[[f32; 4]]) -> Vec<[f64; 3]> {
    px.iter()
        .map(|p| std::array::from_fn(|k| tiltfield::color::linear_to_srgb(p[k] as f64)))
        .collect()
}

fn inner_mask(size: usize, border: usize) -> Vec<bool> {
    (0..size * size)
        .map(|i| {
            let (x, y) = (i % size, i / size);
            x >= border && y >= border && x < size - border && y < size - border
        })
        .collect()
}

/// Rendered depth and disparity of analytic planes equal the closed form: z of the pixel
/// centre's ray on the plane, d = b·f·(1/z − 1/Z_focus).
#[test]
fn rendered_depth_and_disparity_of_analytic_planes_equal_the_closed_form() {
    for name in ["tilted", "planes"] {
        let s = synth_scene(name).unwrap();
        let mut r = rasterizer(&s.mesh());
        let rig = rig(name, 3, 64);
        let out = tiltfield::jobs::raster::render_light_field(&mut r, &rig, 2, true).unwrap();
        assert_clean(&r);
        let lf = &out.light_field;
        let p = rig.parallel().unwrap();
        let mut checked = 0;
        for (vi, v) in lf.views.iter().enumerate() {
            let z = depth_map(lf, vi, DepthKind::Depth);
            for y in 0..64 {
                for x in 0..64 {
                    let pix = DVec2::new(x as f64, y as f64);
                    let Some((hit, zt)) = tiltfield::synth::trace_pixel(&s.scene, &v.camera, pix)
                    else {
                        continue;
                    };
                    // Away from the quads' outlines, where a pixel centre may fall either way.
                    let q = &s.scene.quads[hit.quad_index];
                    let inside = hit.uv.min_element() > 0.01 && hit.uv.max_element() < 0.99;
                    let occluded_edge = s.scene.quads.len() > 1 && q.centre.z > 3.0 && {
                        let near = &s.scene.quads[1];
                        near.corners().iter().any(|c| {
                            v.camera
                                .project(*c)
                                .is_some_and(|c| (c - pix).abs().max_element() < 1.5)
                        })
                    };
                    if !inside || occluded_edge {
                        continue;
                    }
                    let zr = z.at(x, y) as f64;
                    assert!(
                        (zr - zt).abs() < 2e-5 * zt,
                        "{name} view {vi} ({x},{y}): raster z {zr} vs exact {zt}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(
            checked > 9 * 64 * 64 / 2,
            "{name}: only {checked} pixels checked"
        );
        let c = out.reference;
        let z = depth_map(lf, c, DepthKind::Depth);
        let d = depth_map(lf, c, DepthKind::Disparity);
        for (zv, dv) in z.values.iter().zip(&d.values) {
            let want = p.disparity_of_depth(*zv as f64);
            assert!((*dv as f64 - want).abs() < 1e-5, "disparity {dv} vs {want}");
        }
        if name == "planes" {
            // The back plane at 4 m: disparity −2/3 exactly; the card at 2 m: +4/3.
            assert!((z.at(5, 5) - 4.0).abs() < 1e-5 && (d.at(5, 5) + 2.0 / 3.0).abs() < 1e-5);
            assert!((z.at(45, 45) - 2.0).abs() < 1e-5 && (d.at(45, 45) - 4.0 / 3.0).abs() < 1e-5);
        }
        // True normals of the reference view face the camera and are the plane's.
        let n = out.normals[32 * 64 + 32];
        let want = s.scene.quads[0].normal();
        assert!(
            (DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64) + want).length() < 1e-5,
            "{name}: normal {n:?} vs −{want}"
        );
    }
}

/// The rasterizer and the ray tracer render the same built-in scene alike: equal depth at
/// pixel centres away from edges, close colours.
#[test]
fn rasterized_demo_matches_the_ray_traced_demo() {
    let b = tiltfield::synth::builtin("demo").unwrap();
    let mut r = rasterizer(&MeshScene::from_quads("demo", &b.scene));
    let cams = b.rig.cameras(b.grid, b.width, b.height);
    let cam = &cams[b.grid.index(3, 3)];
    let v = r.render_view(cam, b.width, b.height, 3, true).unwrap();
    assert_clean(&r);
    let (img, z) = tiltfield::synth::render_view(&b.scene, cam, b.width, b.height, 3);
    let zr = v.depth.unwrap();
    let n = (b.width * b.height) as usize;
    let mut close = 0;
    for i in 0..n {
        let (a, e) = (zr.values[i], z.values[i]);
        if (a - e).abs() <= 1e-4 * e {
            close += 1;
        }
    }
    assert!(
        close as f64 > 0.99 * n as f64,
        "{close} of {n} depths agree"
    );
    let psnr = common::psnr_rgb(
        &common::view_rgb(&v.image),
        &common::view_rgb(&img),
        &vec![true; n],
    );
    eprintln!("raster vs ray tracer, demo centre view: {psnr:.1} dB");
    assert!(psnr > 28.0, "{psnr} dB");
}

/// `synth --layout hci` writes the exact HCI layout, the loader reads it back, and
/// `render --disparity d` focuses the content whose ground-truth disparity is d.
#[test]
fn synth_hci_layout_round_trips_and_disparity_d_focuses_gt_disparity_d_content() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("planes");
    let o = tiltfield(&[
        "synth",
        "builtin:planes",
        "--out",
        dir.to_str().unwrap(),
        "--grid",
        "5x5",
        "--size",
        "64x64",
        // Zero disparity at the back plane (4 m), +2 px at the card (2 m): integer shifts, so
        // refocusing must reproduce the pinhole view there.
        "--focus-distance",
        "4",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["layout"], "hci");
    for i in 0..25 {
        assert!(dir.join(format!("input_Cam{i:03}.png")).is_file());
    }
    for f in [
        "parameters.cfg",
        "gt_disp_lowres.pfm",
        "gt_depth_lowres.pfm",
        "gt_normals_centre.exr",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    let lf = lightfield::open(&dir, &Default::default()).unwrap();
    let rig = lf.rig.expect("HCI rig");
    assert!((rig.focal_px - 80.0).abs() < 1e-9 && (rig.baseline - 0.1).abs() < 1e-12);
    assert!((rig.focus_distance - 4.0).abs() < 1e-12);
    let disp = depth_map(&lf, 12, DepthKind::Disparity).clone();
    let centre = common::view_rgb(&lf.views[12].image);
    let mut r = common::renderer(&lf);
    let mut psnr = |d: f64, target: f64| {
        let mask: Vec<bool> = (0..64 * 64)
            .map(|i| {
                let (x, y) = (i % 64, i / 64);
                // Content at disparity `target`, away from borders and the card's outline.
                (4..60).contains(&x)
                    && (4..60).contains(&y)
                    && (-3..=3).all(|k: i32| {
                        let (xx, yy) = ((x + k) as u32, (y + k) as u32);
                        (disp.at(xx, y as u32) as f64 - target).abs() < 1e-3
                            && (disp.at(x as u32, yy) as f64 - target).abs() < 1e-3
                    })
            })
            .collect();
        assert!(mask.iter().filter(|&&m| m).count() > 200);
        let req = RefocusRequest {
            focus: FocusSpec::Disparity(d),
            aperture: Aperture::default(),
            reference: None,
        };
        let plan = refocus::plan(&lf, &req, &[]).unwrap();
        let img = common::render_srgb8(&mut r, &plan, Averaging::Linear);
        common::psnr_rgb(&common::view_rgb(&img), &centre, &mask)
    };
    let (back, near) = (0.0, 2.0);
    let (back_on, back_off) = (psnr(back, back), psnr(near, back));
    let (near_on, near_off) = (psnr(near, near), psnr(back, near));
    eprintln!(
        "HCI round trip: back plane {back_on:.1} dB focused vs {back_off:.1} dB; card \
         {near_on:.1} dB vs {near_off:.1} dB"
    );
    assert!(back_on > 30.0 && back_on > back_off + 8.0);
    assert!(near_on > 30.0 && near_on > near_off + 8.0);
    common::assert_no_validation_errors(&r);
}

/// The manifest layout carries K, R, t and a depth map per view; a converging rig (rotated
/// cameras) round-trips through it and refocusing onto a plane focuses that plane's content.
#[test]
fn synth_manifest_layout_with_parallel_and_converging_rigs_focuses_planes() {
    let tmp = tempfile::tempdir().unwrap();
    for rig_arg in ["parallel", "converging"] {
        let dir = tmp.path().join(rig_arg);
        let o = tiltfield(&[
            "synth",
            "builtin:planes",
            "--out",
            dir.to_str().unwrap(),
            "--grid",
            "5x5",
            "--size",
            "64x64",
            "--layout",
            "manifest",
            "--rig",
            rig_arg,
            "--converge-distance",
            "3",
            "--focus-distance",
            "4",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let lf = lightfield::open(&dir, &Default::default()).unwrap();
        assert_eq!(lf.views.len(), 25);
        let depth_maps = lf
            .depth
            .iter()
            .filter(|(_, d)| d.kind == DepthKind::Depth)
            .count();
        assert_eq!(depth_maps, 25, "a depth map per view");
        let corner = &lf.views[0];
        if rig_arg == "converging" {
            assert!(lf.rig.is_none());
            // The corner camera looks at (0, 0, 3).
            let p = corner.camera.project(DVec3::new(0.0, 0.0, 3.0)).unwrap();
            assert!((p - DVec2::new(31.5, 31.5)).length() < 1e-6, "{p}");
        } else {
            assert!(lf.rig.is_some());
            assert_eq!(corner.camera.r, glam::DMat3::IDENTITY);
        }
        // Per-view depth is the true depth in that view: a back-plane pixel of view 0.
        let z0 = depth_map(&lf, 0, DepthKind::Depth);
        let ray_z = {
            let c = &corner.camera;
            let dir = c.r.transpose() * c.ray_camera(DVec2::new(4.0, 4.0));
            (4.0 - c.centre().z) / dir.z
        };
        assert!((z0.at(4, 4) as f64 - ray_z).abs() < 1e-4 * ray_z);

        let centre = common::view_rgb(&lf.views[12].image);
        let mut r = common::renderer(&lf);
        let mut psnr = |z: f64, mask: &[bool]| {
            let req = RefocusRequest {
                focus: FocusSpec::Plane(
                    Plane::new(DVec3::new(0.0, 0.0, z), DVec3::new(0.0, 0.0, -1.0)).unwrap(),
                ),
                aperture: Aperture::default(),
                reference: None,
            };
            let plan = refocus::plan(&lf, &req, &[]).unwrap();
            let img = common::render_srgb8(&mut r, &plan, Averaging::Linear);
            common::psnr_rgb(&common::view_rgb(&img), &centre, mask)
        };
        // Back plane: the upper left; the card at 2 m covers (36..60)² of the centre view.
        let back = common::rect_mask(4, 4, 28, 28);
        let card = common::rect_mask(38, 33, 54, 50);
        let (b_on, b_off) = (psnr(4.0, &back), psnr(2.0, &back));
        let (c_on, c_off) = (psnr(2.0, &card), psnr(4.0, &card));
        eprintln!(
            "manifest {rig_arg}: back {b_on:.1} vs {b_off:.1} dB, card {c_on:.1} vs {c_off:.1} dB"
        );
        // Parallel: integer shifts, the pinhole view is reproduced. Converging: the rotated
        // views are resampled bilinearly, which softens the fine texture (measured ≈ 20 dB).
        let floor = if rig_arg == "parallel" { 30.0 } else { 17.0 };
        assert!(b_on > floor && b_on > b_off + 6.0);
        assert!(c_on > floor && c_on > c_off + 4.0);
        common::assert_no_validation_errors(&r);
    }
    fails_with(
        &[
            "synth",
            "builtin:planes",
            "--out",
            tmp.path().join("x").to_str().unwrap(),
            "--rig",
            "converging",
        ],
        &["--layout hci needs parallel cameras", "--layout manifest"],
    );
}

/// A light field of `name` with an n×n grid spanning the same aperture (half extent `extent`
/// metres), refocused onto `plane` with a disk of the whole extent, against the optical ground
/// truth of the same lens. Returns the PSNR (dB, encoded values) inside `mask`.
#[allow(clippy::too_many_arguments)]
fn psnr_against_optical_gt(
    r: &mut Rasterizer,
    name: &str,
    n: usize,
    size: u32,
    extent: f64,
    plane: Plane,
    gt: &[[f32; 4]],
    mask: &[bool],
) -> f64 {
    let mut rig = rig(name, n, size);
    let steps = (n - 1) as f64 / 2.0;
    rig.baseline = extent / steps;
    // Zero disparity on the plane's point: a frontoparallel focus plane then needs no
    // resampling in any grid, so the comparison measures the aperture sampling alone.
    rig.focus_distance = plane.point.z;
    let lf = tiltfield::jobs::raster::render_light_field(r, &rig, 3, false)
        .unwrap()
        .light_field;
    let req = RefocusRequest {
        focus: FocusSpec::Plane(plane),
        aperture: Aperture {
            shape: ApertureShape::Disk,
            radius: Some(steps),
        },
        reference: None,
    };
    let plan = refocus::plan(&lf, &req, &[]).unwrap();
    let mut h = common::renderer(&lf);
    let img = common::render_float(&mut h, &plan, Averaging::Linear);
    common::assert_no_validation_errors(&h);
    common::psnr_rgb(&common::encoded(&img), &encoded_linear(gt), mask)
}

/// A textured plane refocused onto itself matches the optical ground truth of a lens focused
/// on it (both are the sharp texture there). The plane is tilted 40° like a floor; its texture
/// is coarse enough (≥ 2 px per feature) that bilinear resampling in the refocus costs little.
#[test]
fn textured_plane_refocused_onto_itself_matches_the_optical_ground_truth() {
    let (s40, c40) = 40f64.to_radians().sin_cos();
    let normal = DVec3::new(0.0, -s40, -c40);
    let point = DVec3::new(0.0, 0.0, 3.0);
    let scene = tiltfield::synth::plane_scene(
        normal,
        point,
        3.0,
        tiltfield::synth::Texture::Detail {
            seed: 9,
            grain: 10,
            rings: 4,
            text: "TILT".into(),
            paper: [0.8, 0.78, 0.7],
            ink: [0.05, 0.05, 0.2],
        },
    );
    let mut r = rasterizer(&MeshScene::from_quads("tilted-coarse", &scene));
    let plane = Plane::new(point, normal).unwrap();
    let mut rig = rig("tilted", 5, 96);
    rig.focus_distance = 3.0;
    let reference = rig.cameras()[12];
    let (gt, pinholes) = r
        .optical_ground_truth(&reference, &plane, 0.2, 33, (96, 96), 3)
        .unwrap();
    assert!(pinholes > 750, "{pinholes} pinholes in a 33×33 disk");
    let mask = inner_mask(96, 3);
    let psnr = psnr_against_optical_gt(&mut r, "tilted", 5, 96, 0.2, plane, &gt, &mask);
    // The pinhole centre view is the same sharp image.
    let centre = r.render_view(&reference, 96, 96, 3, false).unwrap();
    let psnr_view = common::psnr_rgb(&encoded_linear(&centre.linear), &encoded_linear(&gt), &mask);
    eprintln!(
        "tilted plane onto itself: refocus {psnr:.1} dB, pinhole view {psnr_view:.1} dB vs \
         optical GT"
    );
    assert!(psnr > 30.0, "{psnr} dB");
    assert!(psnr_view > 45.0, "{psnr_view} dB");
    assert_clean(&r);
}

/// Sparse light fields approximate the lens better as the grid gets denser (same aperture):
/// the out-of-focus card ghosts in a 3×3 grid and blurs smoothly in 9×9.
#[test]
fn refocus_psnr_against_optical_ground_truth_rises_with_grid_density() {
    let s = synth_scene("planes").unwrap();
    let mut r = rasterizer(&s.mesh());
    let plane = Plane::new(DVec3::new(0.0, 0.0, 4.0), DVec3::new(0.0, 0.0, -1.0)).unwrap();
    let size = 96;
    let extent = 0.2;
    let reference = rig("planes", 9, size).cameras()[40];
    let t = std::time::Instant::now();
    let (gt, pinholes) = r
        .optical_ground_truth(&reference, &plane, extent, 33, (size, size), 3)
        .unwrap();
    eprintln!(
        "optical GT: {pinholes} pinholes × 1 jitter at {size}² in {:.2} s",
        t.elapsed().as_secs_f64()
    );
    let mask = inner_mask(size as usize, 4);
    let psnr: Vec<f64> = [3, 5, 9]
        .iter()
        .map(|&n| psnr_against_optical_gt(&mut r, "planes", n, size, extent, plane, &gt, &mask))
        .collect();
    eprintln!(
        "PSNR vs optical ground truth: 3×3 {:.2} dB, 5×5 {:.2} dB, 9×9 {:.2} dB",
        psnr[0], psnr[1], psnr[2]
    );
    assert!(psnr[0] < psnr[1] && psnr[1] < psnr[2], "{psnr:?}");
    assert_clean(&r);
}

/// The example glTF in the repository: node transforms, a camera, textures and vertex colours.
#[test]
fn example_gltf_loads_and_synthesises() {
    let g = tiltfield::synth::gltf::load(Path::new(EXAMPLE)).unwrap();
    assert_eq!(g.mesh.triangle_count(), 2 + 12 + 2);
    assert_eq!(g.mesh.textures.len(), 2);
    assert!(g.mesh.textures[0].repeat && !g.mesh.textures[1].repeat);
    let cam = g.camera.expect("camera node");
    assert!((cam.centre - DVec3::new(0.0, 1.2, 4.0)).length() < 1e-6);
    assert!((cam.yfov - 0.8).abs() < 1e-6);
    // The camera is pitched down: the world origin is below the image centre (y down).
    let c = tiltfield::geometry::camera::Camera::from_centre(
        tiltfield::geometry::camera::intrinsics(100.0, 100.0, 50.0, 50.0),
        cam.r,
        cam.centre,
    );
    let o = c.project(DVec3::ZERO).unwrap();
    assert!(o.y > 50.0 && (o.x - 50.0).abs() < 1e-6, "{o}");
    // Vertex colours carry the base colour factor (0.9).
    assert!(g
        .mesh
        .vertices
        .iter()
        .any(|v| (v.color[0] - 0.9).abs() < 1e-6 && v.color[1] < 0.3));

    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("example");
    let o = tiltfield(&[
        "synth",
        EXAMPLE,
        "--out",
        dir.to_str().unwrap(),
        "--grid",
        "3x3",
        "--size",
        "96x96",
        "--focus",
        "4",
        "--gt-samples",
        "9",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["camera"], "from the file");
    assert!(dir.join("optical_gt.png").is_file() && dir.join("input_Cam004.png").is_file());
    let lf = lightfield::open(&dir, &Default::default()).unwrap();
    let z = depth_map(&lf, 4, DepthKind::Depth);
    let valid = z.values.iter().filter(|v| v.is_finite()).count();
    assert!(valid > 96 * 96 / 3, "{valid} pixels see geometry");
}

/// The binary form of the example (buffer in the GLB's BIN chunk) loads to the same mesh.
#[test]
fn example_glb_loads_like_the_gltf() {
    let a = tiltfield::synth::gltf::load(Path::new(EXAMPLE)).unwrap();
    let glb = EXAMPLE.replace(".gltf", ".glb");
    let b = tiltfield::synth::gltf::load(Path::new(&glb)).unwrap();
    assert_eq!(a.mesh.vertices, b.mesh.vertices);
    assert_eq!(a.mesh.indices, b.mesh.indices);
    assert_eq!(a.mesh.textures, b.mesh.textures);
    assert_eq!(a.camera, b.camera);
}

/// Writes a one-triangle glTF (`mode` 4 = TRIANGLES, 1 = LINES) into `dir`, the triangle at
/// z = −5 in front of a default glTF camera; `camera_yaw_deg` turns the camera node.
fn write_gltf(dir: &Path, mode: u32, write_buffer: bool, camera_yaw_deg: Option<f64>) -> String {
    let floats: [f32; 9] = [-1.0, -1.0, -5.0, 1.0, -1.0, -5.0, 0.0, 1.0, -5.0];
    if write_buffer {
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
        std::fs::write(dir.join("tri.bin"), bytes).unwrap();
    }
    let camera = camera_yaw_deg.map_or(String::new(), |yaw| {
        let h = yaw.to_radians() / 2.0;
        format!(
            r#", {{"camera": 0, "rotation": [0, {}, 0, {}]}}"#,
            h.sin(),
            h.cos()
        )
    });
    let nodes = if camera_yaw_deg.is_some() {
        "[0, 1]"
    } else {
        "[0]"
    };
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": {nodes}}}],
  "nodes": [{{"mesh": 0}}{camera}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.7, "znear": 0.1}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "mode": {mode}}}]}}],
  "accessors": [{{"bufferView": 0, "count": 3, "componentType": 5126, "type": "VEC3",
                 "min": [-1, -1, -5], "max": [1, 1, -5]}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
  "buffers": [{{"byteLength": 36, "uri": "tri.bin"}}]}}"#
    );
    let path = dir.join(format!("scene_{mode}_{write_buffer}.gltf"));
    std::fs::write(&path, json).unwrap();
    path.to_string_lossy().into_owned()
}

/// Unreadable or unsupported glTF input fails with a message naming the file and the cause.
#[test]
fn gltf_error_cases_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let load = |p: &str| {
        tiltfield::synth::gltf::load(Path::new(p))
            .err()
            .unwrap_or_else(|| panic!("{p} should fail"))
            .to_string()
    };
    let missing = d.join("nope.gltf");
    let e = load(missing.to_str().unwrap());
    assert!(
        e.contains("nope.gltf") && e.contains("no such glTF file"),
        "{e}"
    );
    std::fs::write(d.join("model.obj"), "v 0 0 0").unwrap();
    let e = load(d.join("model.obj").to_str().unwrap());
    assert!(e.contains("expected a .gltf or .glb"), "{e}");
    std::fs::write(d.join("broken.gltf"), "{ not json").unwrap();
    let e = load(d.join("broken.gltf").to_str().unwrap());
    assert!(
        e.contains("broken.gltf") && e.contains("not a readable glTF"),
        "{e}"
    );
    let e = load(&write_gltf(d, 4, false, None));
    assert!(
        e.contains("buffer 0 refers to 'tri.bin'") && e.contains("cannot be read"),
        "{e}"
    );
    let e = load(&write_gltf(d, 1, true, None));
    assert!(
        e.contains("unsupported primitive mode") && e.contains("TRIANGLES"),
        "{e}"
    );
    // A scene of points only has no triangles.
    let e = load(&write_gltf(d, 0, true, None));
    assert!(e.contains("unsupported primitive mode"), "{e}");
    let empty = d.join("empty.gltf");
    std::fs::write(
        &empty,
        r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"name": "nothing"}]}"#,
    )
    .unwrap();
    let e = load(empty.to_str().unwrap());
    assert!(e.contains("no triangles"), "{e}");

    // Through the CLI: a valid triangle, seen (camera looking down −z) and not (turned 180°).
    let out = d.join("out");
    let seen = write_gltf(d, 4, true, Some(0.0));
    let o = tiltfield(&[
        "synth",
        &seen,
        "--out",
        out.to_str().unwrap(),
        "--grid",
        "3x3",
        "--size",
        "32x32",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Without a camera in the file, one is placed to look at the scene.
    let auto_dir = d.join("auto");
    std::fs::create_dir_all(&auto_dir).unwrap();
    let auto = write_gltf(&auto_dir, 4, true, None);
    let o = tiltfield(&[
        "synth",
        &auto,
        "--out",
        d.join("auto_out").to_str().unwrap(),
        "--grid",
        "3x3",
        "--size",
        "32x32",
        "--layout",
        "manifest",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["camera"], "placed automatically (none in the file)");
    let lf = lightfield::open(&d.join("auto_out"), &Default::default()).unwrap();
    let z = depth_map(&lf, 4, DepthKind::Depth);
    // The triangle faces the camera squarely at the focus distance.
    let zc = z.at(16, 16) as f64;
    assert!(
        (zc - report["focus_distance"].as_f64().unwrap()).abs() < 1e-4,
        "{zc}"
    );
    let away = d.join("away");
    std::fs::create_dir_all(&away).unwrap();
    let away_scene = write_gltf(&away, 4, true, Some(180.0));
    fails_with(
        &[
            "synth",
            &away_scene,
            "--out",
            out.to_str().unwrap(),
            "--size",
            "32x32",
        ],
        &["nothing in view"],
    );
    fails_with(
        &[
            "synth",
            missing.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["nope.gltf", "no such glTF file"],
    );
    let o = tiltfield(&["synth", "--list"]);
    let listed = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    for name in tiltfield::synth::synth_scene_names() {
        assert!(listed.contains(&format!("builtin:{name}")), "{listed}");
    }
    fails_with(
        &["synth", "builtin:castle", "--out", out.to_str().unwrap()],
        &["no built-in synth scene 'castle'", "room"],
    );
    fails_with(
        &[
            "synth",
            "builtin:room",
            "--out",
            out.to_str().unwrap(),
            "--grid",
            "0x3",
        ],
        &["--grid"],
    );
}
