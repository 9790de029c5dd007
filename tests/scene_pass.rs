//! The scene pass headless, under validation: the plane quad appears where the plane is, blends
//! over points behind it, is hidden by points in front of it; lines and markers are drawn.
//! Pixels are checked at positions computed from the camera, not against a golden image.

mod common;

use glam::{DMat3, DVec2, DVec3};
use tiltfield::color::srgb_to_linear;
use tiltfield::geometry::camera::{intrinsics, Camera};
use tiltfield::gpu::commands::{stage, Submission};
use tiltfield::gpu::GpuContext;
use tiltfield::passes::raster::{camera_from_world, projection_rows, Projection};
use tiltfield::passes::scene::{SceneOverlay, ScenePass, SceneTarget, SceneView};
use tiltfield::scene::ColourVertex;

const W: u32 = 128;
const H: u32 = 96;

fn camera() -> Camera {
    Camera::from_centre(
        intrinsics(100.0, 100.0, W as f64 / 2.0 - 0.5, H as f64 / 2.0 - 0.5),
        DMat3::IDENTITY,
        DVec3::ZERO,
    )
}

/// The world point seen at pixel (x, y) at depth z.
fn at(x: f64, y: f64, z: f64) -> DVec3 {
    camera().back_project(DVec2::new(x, y), z)
}

/// A filled rectangle of points, one per pixel, at depth z.
fn patch(x0: u32, y0: u32, x1: u32, y1: u32, z: f64, c: [u8; 3]) -> Vec<ColourVertex> {
    let mut v = Vec::new();
    for y in y0..=y1 {
        for x in x0..=x1 {
            v.push(ColourVertex::new(at(x as f64, y as f64, z), c, 1.0));
        }
    }
    v
}

fn encode(l: f64) -> f64 {
    let c = l.clamp(0.0, 1.0);
    255.0
        * if c <= 0.0031308 {
            12.92 * c
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        }
}

fn lin(c: u8) -> f64 {
    srgb_to_linear(c as f64 / 255.0)
}

fn assert_pixel(img: &image::RgbaImage, x: u32, y: u32, want: [f64; 3], what: &str) {
    let p = img.get_pixel(x, y).0;
    for k in 0..3 {
        assert!(
            (p[k] as f64 - want[k]).abs() <= 2.0,
            "{what} at ({x}, {y}): got {:?}, want {want:?}",
            &p[..3]
        );
    }
}

#[test]
fn quad_blends_over_points_behind_and_hides_behind_points_in_front() {
    let ctx = GpuContext::new(&common::gpu_options()).expect("Vulkan context");
    let mut pass = ScenePass::new(&ctx, 1).unwrap();
    let mut target = SceneTarget::new(&ctx, W, H).unwrap();
    let red = [255, 0, 0];
    let green = [0, 255, 0];
    let blue = [0, 0, 255];
    let white = [255, 255, 255];
    let marker = [255, 255, 0];
    // Red points behind the plane (z = 5), green in front (z = 2); the plane at z = 3.
    let mut cloud = patch(10, 10, 30, 30, 5.0, red);
    cloud.extend(patch(40, 10, 60, 30, 2.0, green));
    pass.set_cloud(&ctx, &cloud).unwrap();
    let quad = [
        at(5.0, 5.0, 3.0),
        at(70.0, 5.0, 3.0),
        at(70.0, 40.0, 3.0),
        at(5.0, 40.0, 3.0),
    ];
    let alpha = 0.5f32;
    let mut overlay = SceneOverlay::default();
    for i in [0, 1, 2, 0, 2, 3] {
        overlay
            .triangles
            .push(ColourVertex::new(quad[i], blue, alpha));
    }
    overlay
        .lines
        .push(ColourVertex::new(at(80.0, 70.0, 4.0), white, 1.0));
    overlay
        .lines
        .push(ColourVertex::new(at(120.0, 70.0, 4.0), white, 1.0));
    // A marker behind the red points still shows (picks are always visible).
    overlay
        .markers
        .push(ColourVertex::new(at(20.0, 20.0, 6.0), marker, 1.0));
    // A camera-centre point far off to the right, depth-tested, larger than cloud points.
    overlay
        .points
        .push(ColourVertex::new(at(100.0, 20.0, 1.0), white, 1.0));
    let c = camera();
    let view = SceneView {
        clip_from_world: Projection::new(
            projection_rows(c.k, c.r, c.t),
            camera_from_world(c.r, c.t),
            W,
            H,
            DVec2::ZERO,
        )
        .clip_from_world,
        point_size: 1.0,
        marker_size: 5.0,
    };
    let submission = Submission::new(&ctx, "scene test").unwrap();
    let mut recorded = Ok(());
    submission
        .run(&ctx, |_, cmd| {
            recorded = pass.record(&ctx, cmd, 0, &mut target, &view, &overlay, true);
        })
        .unwrap();
    recorded.unwrap();
    let img = target.read(&ctx, stage::COLOR_WRITE).unwrap();

    let over = |bg: [u8; 3]| {
        [0, 1, 2].map(|k| {
            let a = alpha as f64;
            encode(a * lin(blue[k]) + (1.0 - a) * lin(bg[k]))
        })
    };
    // Quad alone, over the black background.
    assert_pixel(&img, 8, 36, over([0, 0, 0]), "quad over background");
    // Red points behind the quad: tinted.
    assert_pixel(&img, 25, 25, over(red), "quad over points behind it");
    // Green points in front of the quad: untouched.
    assert_pixel(
        &img,
        50,
        20,
        [0.0, 255.0, 0.0],
        "points in front of the quad",
    );
    // Outside the quad: nothing.
    assert_pixel(&img, 100, 50, [0.0; 3], "background");
    // The line at y = 70 from x = 80 to 120.
    assert_pixel(&img, 100, 70, [255.0; 3], "line");
    assert_pixel(&img, 100, 75, [0.0; 3], "beside the line");
    // The marker over the red points it lies behind.
    assert_pixel(&img, 20, 20, [255.0, 255.0, 0.0], "marker");
    // The camera point is larger than one pixel where the device has large points.
    assert_pixel(&img, 100, 20, [255.0; 3], "camera point");
    if ctx.large_points && pass.max_point_size() >= 2.5 {
        assert_pixel(&img, 101, 21, [255.0; 3], "camera point is enlarged");
    }

    // Next frame: the plane moved behind the red points (z = 6). The cloud is not redrawn but
    // comes from the cached layer — even after the pass's cloud was replaced by an empty one.
    pass.set_cloud(&ctx, &[]).unwrap();
    let mut moved = SceneOverlay::default();
    let far = quad.map(|p| p * 2.0);
    for i in [0, 1, 2, 0, 2, 3] {
        moved.triangles.push(ColourVertex::new(far[i], blue, alpha));
    }
    let mut frame = |overlay: &SceneOverlay, cloud_changed: bool| {
        let mut recorded = Ok(());
        submission
            .run(&ctx, |_, cmd| {
                recorded = pass.record(&ctx, cmd, 0, &mut target, &view, overlay, cloud_changed);
            })
            .unwrap();
        recorded.unwrap();
        target.read(&ctx, stage::COLOR_WRITE).unwrap()
    };
    let img = frame(&moved, false);
    assert_pixel(
        &img,
        25,
        25,
        [255.0, 0.0, 0.0],
        "points now in front of the quad",
    );
    assert_pixel(&img, 8, 36, over([0, 0, 0]), "quad over background");
    assert_pixel(&img, 50, 20, [0.0, 255.0, 0.0], "cached green points");
    assert_pixel(&img, 100, 70, [0.0; 3], "the old line is gone");
    // When the view changes the cloud is redrawn: now without points.
    let img = frame(&moved, true);
    assert_pixel(&img, 25, 25, over([0, 0, 0]), "no points after a redraw");

    // Freed before the count, so teardown is checked too.
    drop((submission, target, pass));
    assert_eq!(ctx.validation().errors(), 0, "validation errors");
}
