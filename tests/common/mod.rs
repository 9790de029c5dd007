//! Shared helpers of the integration tests: validated GPU renderers, small generated light
//! fields, image metrics.
#![allow(dead_code)] // each test binary uses a different subset

use tiltfield::color;
use tiltfield::gpu::GpuOptions;
use tiltfield::jobs::refocus::{GpuImage, HeadlessRenderer, RenderSettings};
use tiltfield::lightfield::LightField;
use tiltfield::refocus::settings::{OutputFormat, Strategy};
use tiltfield::refocus::{Averaging, RefocusImage, RefocusPlan};

/// A request with the default aperture (all views) at the grid centre.
pub fn request(focus: tiltfield::refocus::FocusSpec) -> tiltfield::refocus::RefocusRequest {
    tiltfield::refocus::RefocusRequest {
        focus,
        aperture: tiltfield::geometry::aperture::Aperture::default(),
        reference: None,
    }
}

/// Every GPU test runs with the Khronos validation layer; a missing layer or driver fails.
pub fn gpu_options() -> GpuOptions {
    GpuOptions {
        device: std::env::var("TILTFIELD_DEVICE")
            .ok()
            .filter(|s| !s.is_empty()),
        validation: true,
        ..GpuOptions::default()
    }
}

/// A validated renderer for `lf`; panics (fails the test) when Vulkan is unusable.
pub fn renderer(lf: &LightField) -> HeadlessRenderer {
    HeadlessRenderer::new(lf, &gpu_options())
        .unwrap_or_else(|e| panic!("cannot create a validated Vulkan renderer: {e}"))
}

/// Fails the test if the context logged any validation error.
pub fn assert_no_validation_errors(r: &HeadlessRenderer) {
    let log = r.context().validation();
    assert_eq!(
        log.errors(),
        0,
        "validation errors on {}: {:#?}",
        r.context().info.name,
        log.messages()
    );
}

/// A built-in scene's light field (2×2 supersampled).
pub fn builtin(name: &str) -> LightField {
    tiltfield::synth::builtin(name)
        .unwrap_or_else(|| panic!("no builtin {name}"))
        .light_field(2)
}

/// Renders `plan` as float.
pub fn render_float(
    r: &mut HeadlessRenderer,
    plan: &RefocusPlan,
    averaging: Averaging,
) -> RefocusImage {
    render_float_split(r, plan, averaging, 0)
}

/// Renders `plan` as float with `views_per_draw` views per draw.
pub fn render_float_split(
    r: &mut HeadlessRenderer,
    plan: &RefocusPlan,
    averaging: Averaging,
    views_per_draw: usize,
) -> RefocusImage {
    let settings = RenderSettings {
        averaging,
        output: OutputFormat::Float,
        strategy: if views_per_draw == 0 {
            Strategy::Fragment
        } else {
            Strategy::Batched { views_per_draw }
        },
        ..RenderSettings::default()
    };
    match r.render(plan, &settings).expect("render").0 {
        GpuImage::Float(img) => img,
        GpuImage::Srgb8(_) => panic!("asked for float output"),
    }
}

/// Renders `plan` as 8-bit sRGB.
pub fn render_srgb8(
    r: &mut HeadlessRenderer,
    plan: &RefocusPlan,
    averaging: Averaging,
) -> image::RgbaImage {
    let settings = RenderSettings {
        averaging,
        output: OutputFormat::Srgb8,
        ..RenderSettings::default()
    };
    match r.render(plan, &settings).expect("render").0 {
        GpuImage::Srgb8(img) => img,
        GpuImage::Float(_) => panic!("asked for 8-bit output"),
    }
}

/// sRGB-encoded [0, 1] RGB of a float refocus image (the space people look at).
pub fn encoded(img: &RefocusImage) -> Vec<[f64; 3]> {
    img.pixels
        .iter()
        .map(|p| {
            let e = |c: f32| match img.averaging {
                Averaging::Linear => color::linear_to_srgb((c as f64).clamp(0.0, 1.0)),
                Averaging::Encoded => c as f64,
            };
            [e(p[0]), e(p[1]), e(p[2])]
        })
        .collect()
}

/// Error statistics between two images in 8-bit levels of the encoded values.
#[derive(Debug, Clone, Copy)]
pub struct Diff {
    pub psnr_db: f64,
    pub max_levels: f64,
    /// Number of pixels whose coverage (alpha) differs.
    pub coverage_mismatch: usize,
}

/// Compares `a` to reference `b` over pixels where `mask` holds (all when `None`).
pub fn diff(a: &RefocusImage, b: &RefocusImage, mask: Option<&[bool]>) -> Diff {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let (ea, eb) = (encoded(a), encoded(b));
    let mut se = 0.0;
    let mut n = 0usize;
    let mut max = 0f64;
    let mut coverage_mismatch = 0;
    for i in 0..ea.len() {
        if mask.is_some_and(|m| !m[i]) {
            continue;
        }
        if a.pixels[i][3] != b.pixels[i][3] {
            coverage_mismatch += 1;
        }
        for k in 0..3 {
            let d = ea[i][k] - eb[i][k];
            se += d * d;
            max = max.max(d.abs());
        }
        n += 3;
    }
    let mse = se / n.max(1) as f64;
    Diff {
        psnr_db: if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * (1.0 / mse).log10()
        },
        max_levels: max * 255.0,
        coverage_mismatch,
    }
}

/// Mean squared horizontal + vertical gradient of the luma of encoded RGB inside `mask`: a
/// sharpness measure (blur lowers it).
pub fn gradient_energy(rgb: &[[f64; 3]], width: usize, mask: &[bool]) -> f64 {
    let luma = |p: [f64; 3]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let height = rgb.len() / width;
    let mut sum = 0.0;
    let mut n = 0;
    for y in 0..height - 1 {
        for x in 0..width - 1 {
            let i = y * width + x;
            if !(mask[i] && mask[i + 1] && mask[i + width]) {
                continue;
            }
            let gx = luma(rgb[i + 1]) - luma(rgb[i]);
            let gy = luma(rgb[i + width]) - luma(rgb[i]);
            sum += gx * gx + gy * gy;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

/// Encoded [0, 1] RGB of an 8-bit view.
pub fn view_rgb(img: &image::RgbaImage) -> Vec<[f64; 3]> {
    img.pixels()
        .map(|p| {
            [
                p.0[0] as f64 / 255.0,
                p.0[1] as f64 / 255.0,
                p.0[2] as f64 / 255.0,
            ]
        })
        .collect()
}

/// PSNR (dB) between two encoded RGB images inside `mask`.
pub fn psnr_rgb(a: &[[f64; 3]], b: &[[f64; 3]], mask: &[bool]) -> f64 {
    let mut se = 0.0;
    let mut n = 0;
    for i in 0..a.len() {
        if mask[i] {
            for k in 0..3 {
                se += (a[i][k] - b[i][k]).powi(2);
            }
            n += 3;
        }
    }
    10.0 * (n as f64 / se).log10()
}

/// The rig of the two-plane test scene: 5×5 views of 64×64, f = 80 px, b = 0.1, Z_focus = 3.
pub const TWO_PLANE_RIG: tiltfield::lightfield::ParallelRig = tiltfield::lightfield::ParallelRig {
    focal_px: 80.0,
    baseline: 0.1,
    focus_distance: 3.0,
};

/// A light field with exact ground truth: a textured back plane filling the view at HCI
/// disparity `d_back` and a checkered card at `d_near` covering the lower right quarter of the
/// centre view. With integer disparities every view sees the planes on the same pixel grid, so
/// refocusing onto a plane must reproduce the pinhole centre view there.
pub fn two_planes(d_back: f64, d_near: f64) -> LightField {
    use glam::DVec3;
    use tiltfield::synth::{Quad, Scene, Texture};
    let rig = TWO_PLANE_RIG;
    let z_back = rig.depth_of_disparity(d_back).expect("finite back depth");
    let z_near = rig.depth_of_disparity(d_near).expect("finite near depth");
    // Pixel x ↔ world x = (x − 31.5)·z / f in the centre camera.
    let at = |px: f64, z: f64| (px - 31.5) * z / rig.focal_px;
    let back = Quad {
        centre: DVec3::new(0.0, 0.0, z_back),
        half_u: DVec3::new(3.0 * z_back, 0.0, 0.0),
        half_v: DVec3::new(0.0, 3.0 * z_back, 0.0),
        texture: Texture::Detail {
            seed: 3,
            grain: 64,
            rings: 6,
            text: "AB".into(),
            paper: [0.8, 0.8, 0.78],
            ink: [0.02, 0.02, 0.02],
        },
    };
    let (lo, hi) = (at(36.0, z_near), at(80.0, z_near));
    let near = Quad {
        centre: DVec3::new((lo + hi) / 2.0, (lo + hi) / 2.0, z_near),
        half_u: DVec3::new((hi - lo) / 2.0, 0.0, 0.0),
        half_v: DVec3::new(0.0, (hi - lo) / 2.0, 0.0),
        texture: Texture::Checker {
            cells_u: 5,
            cells_v: 5,
            a: [0.9, 0.35, 0.05],
            b: [0.05, 0.35, 0.35],
        },
    };
    let scene = Scene {
        quads: vec![back, near],
        background: [0.0; 3],
        solids: Vec::new(),
        lighting: None,
    };
    let grid = tiltfield::lightfield::GridSize { cols: 5, rows: 5 };
    tiltfield::synth::render_light_field(&scene, "two-planes", grid, 64, 64, &rig, 2)
}

/// Pixels of a 64×64 centre view inside `[x0, x1) × [y0, y1)`.
pub fn rect_mask(x0: usize, y0: usize, x1: usize, y1: usize) -> Vec<bool> {
    (0..64 * 64)
        .map(|i| {
            let (x, y) = (i % 64, i / 64);
            x >= x0 && x < x1 && y >= y0 && y < y1
        })
        .collect()
}

/// Copies the views of the HCI folder `hci` (a `cols × rows` grid, `input_CamNNN.png`) into a
/// new grid folder `grid` named by row and column (`RR_CC.png`): the same views with nominal
/// cameras, no rig and no depth.
pub fn hci_as_grid_folder(hci: &std::path::Path, grid: &std::path::Path, cols: usize, rows: usize) {
    std::fs::create_dir(grid).unwrap();
    for k in 0..cols * rows {
        std::fs::copy(
            hci.join(format!("input_Cam{k:03}.png")),
            grid.join(format!("{:02}_{:02}.png", k / cols, k % cols)),
        )
        .unwrap();
    }
}

/// Runs the `tiltfield` binary with the validation layer on (commands that touch the GPU then
/// fail on any validation error).
pub fn tiltfield(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_tiltfield"))
        .args(args)
        .env("TILTFIELD_VALIDATION", "1")
        .env_remove("RUST_LOG")
        .output()
        .expect("run tiltfield")
}

/// [`tiltfield`] with the depth cache in `cache` (a test's own folder, not the user's).
pub fn tiltfield_cached(args: &[&str], cache: &std::path::Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_tiltfield"))
        .args(args)
        .env("TILTFIELD_VALIDATION", "1")
        .env("TILTFIELD_CACHE_DIR", cache)
        .env_remove("RUST_LOG")
        .output()
        .expect("run tiltfield")
}

/// A command's stderr as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The JSON a successful command printed on stdout.
pub fn json_of(o: &std::process::Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
}

/// Asserts that `tiltfield args` fails with a message containing every `needle`, without a
/// panic or backtrace.
pub fn fails_with(args: &[&str], needles: &[&str]) {
    let o = tiltfield(args);
    let err = stderr(&o);
    assert!(!o.status.success(), "{args:?} should fail; stderr: {err}");
    assert!(
        !err.contains("panicked") && !err.contains("RUST_BACKTRACE"),
        "{args:?} panicked: {err}"
    );
    for n in needles {
        assert!(err.contains(n), "{args:?}: expected '{n}' in: {err}");
    }
}

/// Standard base64 with padding (for glTF data URIs written by tests).
pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}
