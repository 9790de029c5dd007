//! Generated camera-array videos written in the Technicolor dataset layout, for the real-world
//! tests and the throughput example (`examples/technicolor_video.rs`).
//!
//! The rig: `cols × rows` cameras on a plane, converging on a point 2.5 m ahead, each with a
//! small extra roll, the whole rig turned and moved in the world (so the world frame is not a
//! camera's). The scene: a textured back wall whose texture changes with the frame and a
//! checkered card that moves across it. The parameter file is written here by hand from the
//! dataset's documented columns (quaternions by the textbook Hamilton formula), independently
//! of the loader under test.
#![allow(dead_code)] // each user needs a different subset

use std::path::Path;

use glam::{DMat3, DVec2, DVec3};
use image::RgbaImage;
use tiltfield::geometry::camera::{intrinsics, Camera};
use tiltfield::lightfield::GridSize;
use tiltfield::synth::{render_view, trace_pixel, Quad, Scene, Texture};

/// A generated rig.
#[derive(Debug, Clone)]
pub struct Rig {
    pub grid: GridSize,
    pub width: u32,
    pub height: u32,
    /// Row-major (camera k at row k div cols, column k mod cols).
    pub cameras: Vec<Camera>,
    /// The rig's own frame in the world: X_world = m · X_rig + offset.
    pub m: DMat3,
    pub offset: DVec3,
}

/// The rig of `grid` with `width × height` views: f = 0.9·W px, principal points near the
/// centre (each camera a little off), baseline 0.08 m, converging on (0, 0, 2.5) in the rig
/// frame.
pub fn rig(grid: GridSize, width: u32, height: u32) -> Rig {
    let m = DMat3::from_euler(glam::EulerRot::YXZ, 0.35, -0.2, 0.1);
    let offset = DVec3::new(0.3, -0.2, 1.0);
    let f = 0.9 * width as f64;
    let b = 0.08;
    let target = DVec3::new(0.0, 0.0, 2.5);
    let c = grid.centre();
    let mut cameras = Vec::new();
    for k in 0..grid.len() {
        let (s, t) = ((k % grid.cols) as f64, (k / grid.cols) as f64);
        let centre = DVec3::new((s - c.x) * b, (t - c.y) * b, 0.0);
        let z = (target - centre).normalize();
        let x = DVec3::Y.cross(z).normalize();
        let y = z.cross(x);
        let roll = DMat3::from_rotation_z(0.01 * (k as f64 - 7.0));
        // Rows of the rig → camera rotation are the camera axes.
        let r_rig = roll * DMat3::from_cols(x, y, z).transpose();
        let k_mat = intrinsics(
            f,
            f * 1.002,
            (width as f64 - 1.0) / 2.0 + 0.3 * (s - c.x),
            (height as f64 - 1.0) / 2.0 - 0.2 * (t - c.y),
        );
        let r = r_rig * m.transpose();
        cameras.push(Camera::from_centre(k_mat, r, m * centre + offset));
    }
    Rig {
        grid,
        width,
        height,
        cameras,
        m,
        offset,
    }
}

impl Rig {
    /// A quad given in the rig frame, placed in the world.
    fn quad(&self, centre: DVec3, half_u: DVec3, half_v: DVec3, texture: Texture) -> Quad {
        Quad {
            centre: self.m * centre + self.offset,
            half_u: self.m * half_u,
            half_v: self.m * half_v,
            texture,
        }
    }

    /// The back wall (a plane at z = 3 m in the rig frame, its texture seeded by the frame).
    pub fn wall(&self, frame: u64) -> Quad {
        self.quad(
            DVec3::new(0.0, 0.0, 3.0),
            DVec3::new(2.2, 0.0, 0.0),
            DVec3::new(0.0, 2.2, 0.0),
            Texture::Detail {
                // Detail of 10–40 px in the views: fine enough to show focus, coarse enough
                // that bilinear resampling keeps it (pixel-scale grain would not survive).
                seed: 7 + frame as u32,
                grain: 6,
                rings: 3,
                text: "TF".into(),
                paper: [0.75, 0.7, 0.6],
                ink: [0.05, 0.05, 0.1],
            },
        )
    }

    /// The scene of `frame`: the wall and a card at z = 1.8 m that moves right by 0.12 m per
    /// frame, starting over every 6 frames.
    pub fn scene(&self, frame: u64) -> Scene {
        let card = self.quad(
            DVec3::new(-0.25 + 0.12 * (frame % 6) as f64, 0.1, 1.8),
            DVec3::new(0.15, 0.0, 0.0),
            DVec3::new(0.0, 0.15, 0.0),
            Texture::Checker {
                cells_u: 4,
                cells_v: 4,
                a: [0.9, 0.3, 0.05],
                b: [0.05, 0.3, 0.5],
            },
        );
        Scene {
            quads: vec![self.wall(frame), card],
            background: [0.0; 3],
            solids: Vec::new(),
            lighting: None,
        }
    }

    /// The wall plane in the world: (point, unit normal).
    pub fn wall_plane(&self) -> (DVec3, DVec3) {
        (
            self.m * DVec3::new(0.0, 0.0, 3.0) + self.offset,
            self.m * DVec3::Z,
        )
    }

    /// Pinhole views of `frame` (2×2 samples per pixel), row-major.
    pub fn render(&self, frame: u64) -> Vec<RgbaImage> {
        let scene = self.scene(frame);
        self.cameras
            .iter()
            .map(|c| render_view(&scene, c, self.width, self.height, 2).0)
            .collect()
    }

    /// Views of `frame` through lenses with radial distortion `(d1, d2)` (camera k's from
    /// `distortion(k)`): the distorted pixel p_d shows what the pinhole pixel K·x sees, where
    /// K⁻¹p_d = x·(1 + d1 r² + d2 r⁴) (x found by bisection on the radius). 2×2 samples per
    /// pixel, averaged in linear light.
    pub fn render_distorted(
        &self,
        frame: u64,
        distortion: impl Fn(usize) -> (f64, f64),
    ) -> Vec<RgbaImage> {
        let scene = self.scene(frame);
        self.cameras
            .iter()
            .enumerate()
            .map(|(k, cam)| {
                let (d1, d2) = distortion(k);
                let k_inv = cam.k.inverse();
                RgbaImage::from_fn(self.width, self.height, |i, j| {
                    let mut sum = [0.0f32; 3];
                    for (ox, oy) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                        let pd = DVec2::new(i as f64 + ox, j as f64 + oy);
                        let xd = (k_inv * pd.extend(1.0)).truncate();
                        let x = undistort_point(xd, d1, d2);
                        let pu = (cam.k * x.extend(1.0)).truncate();
                        let hit = trace_pixel(&scene, cam, pu);
                        let c = scene.radiance(hit.as_ref().map(|(h, _)| h));
                        for (s, v) in sum.iter_mut().zip(c) {
                            *s += v / 4.0;
                        }
                    }
                    let e = |v: f32| tiltfield::color::encode_srgb8(v);
                    image::Rgba([e(sum[0]), e(sum[1]), e(sum[2]), 255])
                })
            })
            .collect()
    }
}

/// The undistorted normalised point x with x·(1 + d1 r² + d2 r⁴) = xd (bisection on r).
pub fn undistort_point(xd: DVec2, d1: f64, d2: f64) -> DVec2 {
    let rd = xd.length();
    if rd == 0.0 {
        return xd;
    }
    let g = |r: f64| r * (1.0 + d1 * r * r + d2 * r.powi(4));
    let (mut lo, mut hi) = (0.0, 4.0 * rd);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if g(mid) < rd {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    xd * (0.5 * (lo + hi) / rd)
}

/// The unit quaternion (w, x, y, z) of rotation `r` (Hamilton convention, the textbook formula
/// for rotations with trace > −1).
pub fn quaternion(r: DMat3) -> [f64; 4] {
    let e = |i: usize, j: usize| r.col(j)[i];
    let trace = e(0, 0) + e(1, 1) + e(2, 2);
    assert!(trace > 0.0, "the generated rotations are small");
    let w = (1.0 + trace).sqrt() / 2.0;
    [
        w,
        (e(2, 1) - e(1, 2)) / (4.0 * w),
        (e(0, 2) - e(2, 0)) / (4.0 * w),
        (e(1, 0) - e(0, 1)) / (4.0 * w),
    ]
}

/// One line of `cameras_parameters.txt` for `cam`: 12 values, or 14 with `distortion`.
pub fn parameter_line(cam: &Camera, distortion: Option<(f64, f64)>) -> String {
    let k = cam.k;
    let f = k.col(0)[0];
    let (sk, fy, cu, cv) = (k.col(1)[0], k.col(1)[1], k.col(2)[0], k.col(2)[1]);
    let q = quaternion(cam.r);
    let t = cam.t;
    let d = match distortion {
        Some((d1, d2)) => format!(" {d1} {d2}"),
        None => String::new(),
    };
    format!(
        "{f} {cu} {cv} {} {sk}{d} {} {} {} {} {} {} {}",
        fy / f,
        q[0],
        q[1],
        q[2],
        q[3],
        t.x,
        t.y,
        t.z
    )
}

/// Writes `cameras_parameters.txt` for `cameras` into `dir` (14 columns when `distortion` is
/// given).
pub fn write_parameters(
    dir: &Path,
    cameras: &[Camera],
    distortion: Option<&dyn Fn(usize) -> (f64, f64)>,
) {
    let mut text = String::from(match distortion {
        Some(_) => "f cu cv ar sk d1 d2 qw qx qy qz tx ty tz\n",
        None => "f cu cv ar sk qw qx qy qz tx ty tz\n",
    });
    for (k, cam) in cameras.iter().enumerate() {
        text.push_str(&parameter_line(cam, distortion.map(|d| d(k))));
        text.push('\n');
    }
    std::fs::write(dir.join("cameras_parameters.txt"), text).unwrap();
}

/// The file name of camera `cam` of `frame`.
pub fn frame_name(scene: &str, undist: bool, frame: u64, cam: usize) -> String {
    if undist {
        format!("{scene}_undist_{frame:05}_{cam:02}.png")
    } else {
        format!("{scene}_{frame:05}_{cam:02}.png")
    }
}

/// Writes the views of one frame into `dir`.
pub fn write_frame(dir: &Path, scene: &str, undist: bool, frame: u64, views: &[RgbaImage]) {
    for (k, v) in views.iter().enumerate() {
        v.save(dir.join(frame_name(scene, undist, frame, k)))
            .unwrap();
    }
}

/// A complete undist-named video of `frames` in `dir` (12-column parameters).
pub fn write_video(dir: &Path, rig: &Rig, scene: &str, frames: &[u64]) {
    write_parameters(dir, &rig.cameras, None);
    for &f in frames {
        write_frame(dir, scene, true, f, &rig.render(f));
    }
}
