//! The stability study of the scene-based plane placement: writes docs/stability.md.
//!
//! ```sh
//! cargo run --example stability -- docs/stability.md
//! ```
//!
//! Every scene is an analytic depth view with exact normals ([`tiltfield::synth::surfaces`]);
//! depth noise is multiplicative Gaussian from a seeded generator, so the tables are
//! reproducible bit for bit. `tests/geometry_stability.rs` asserts the bounds quoted here.

use std::fmt::Write as _;
use std::time::Instant;

use glam::{DMat3, DVec2, DVec3};
use tiltfield::geometry::camera::{intrinsics, Camera};
use tiltfield::geometry::depth::ViewDepth;
use tiltfield::geometry::normals::{estimate_normal, estimate_normals, NormalMethod, NormalParams};
use tiltfield::geometry::picking::{self, triangle_min_angle_deg, Nudge};
use tiltfield::geometry::plane::{tilt_swing_normal, Plane};
use tiltfield::lightfield::{DepthKind, DepthMap, ParallelRig};
use tiltfield::synth::surfaces::{angle_deg, depth_edge, quantile, AnalyticView, Rng, Surface};

const NOISES: [f64; 5] = [0.0, 0.005, 0.01, 0.02, 0.05];
const WINDOWS: [u32; 5] = [5, 9, 15, 21, 31];
const SAMPLES: usize = 400;

struct Cam {
    label: &'static str,
    size: u32,
    f: f64,
    distance: f64,
}

const CAMERAS: [Cam; 2] = [
    Cam {
        label: "HCI-like: 512² px, f = 1463 px (20° field of view), surface at 8 m",
        size: 512,
        f: 100.0 * 512.0 / 35.0,
        distance: 8.0,
    },
    Cam {
        label: "wide: 256² px, f = 307 px (45° field of view), surface at 2.5 m",
        size: 256,
        f: 1.2 * 256.0,
        distance: 2.5,
    },
];

fn camera(c: &Cam) -> Camera {
    let cc = (c.size as f64 - 1.0) / 2.0;
    Camera::from_centre(intrinsics(c.f, c.f, cc, cc), DMat3::IDENTITY, DVec3::ZERO)
}

/// The generic test plane: tilt 30°, swing 20°, through the optical axis at `distance`.
fn test_plane(c: &Cam) -> (DVec3, DVec3) {
    let n = -tilt_swing_normal(30.0, 20.0);
    (DVec3::new(0.0, 0.0, c.distance), n)
}

fn fmt_deg(v: f64) -> String {
    if v.is_nan() {
        "–".into()
    } else if v < 0.01 {
        format!("{v:.0e}")
    } else if v < 10.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.1}")
    }
}

/// Random pixels whose full window of side 21 lies inside the image.
fn sample_pixels(size: u32, n: usize, seed: u64) -> Vec<(u32, u32)> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| (rng.range(10, size - 10), rng.range(10, size - 10)))
        .collect()
}

struct Stats {
    median: f64,
    p95: f64,
    refused: f64,
    all_median: f64,
    all_p95: f64,
}

/// Angular errors of the normals at `pixels` (only pixels with a true normal count).
fn normal_stats(
    view: &AnalyticView,
    depth: &ViewDepth,
    pixels: &[(u32, u32)],
    params: &NormalParams,
) -> Stats {
    let mut errors = Vec::new();
    let mut all = Vec::new();
    let mut refused = 0usize;
    let mut total = 0usize;
    for &(x, y) in pixels {
        let Some(truth) = view.normal(x, y) else {
            continue;
        };
        total += 1;
        match estimate_normal(depth, x, y, params) {
            Ok(e) => {
                all.push(angle_deg(e.normal, truth));
                if e.check(params).is_ok() {
                    errors.push(angle_deg(e.normal, truth));
                } else {
                    refused += 1;
                }
            }
            Err(_) => refused += 1,
        }
    }
    Stats {
        median: quantile(&errors, 0.5),
        p95: quantile(&errors, 0.95),
        refused: refused as f64 / total.max(1) as f64,
        all_median: quantile(&all, 0.5),
        all_p95: quantile(&all, 0.95),
    }
}

fn noise_table(out: &mut String, c: &Cam) {
    let (p, n) = test_plane(c);
    let view = AnalyticView::new(camera(c), c.size, c.size, &[Surface::plane(n, p, 50.0)]);
    let pixels = sample_pixels(c.size, SAMPLES, 1);
    for (method, label) in [
        (
            NormalMethod::InverseDepth,
            "inverse-depth fit (the default)",
        ),
        (NormalMethod::Pca, "PCA (Hoppe 1992, `--normal-method pca`)"),
    ] {
        writeln!(
            out,
            "\n**{}**, plane tilted 30° and swung 20°: **{label}**.\n",
            c.label
        )
        .ok();
        write!(out, "| depth noise σ |").ok();
        for w in WINDOWS {
            write!(out, " window {w} |").ok();
        }
        writeln!(out).ok();
        write!(out, "|---|").ok();
        for _ in WINDOWS {
            write!(out, "---|").ok();
        }
        writeln!(out).ok();
        for (k, sigma) in NOISES.iter().enumerate() {
            let depth = view.noisy_depth(*sigma, 100 + k as u64);
            write!(out, "| {:.1} % |", sigma * 100.0).ok();
            for w in WINDOWS {
                let params = NormalParams::default().with_window(w).with_method(method);
                let s = normal_stats(&view, &depth, &pixels, &params);
                write!(
                    out,
                    " {}° / {}° · {:.0} % · {}° / {}° |",
                    fmt_deg(s.all_median),
                    fmt_deg(s.all_p95),
                    100.0 * s.refused,
                    fmt_deg(s.median),
                    fmt_deg(s.p95),
                )
                .ok();
            }
            writeln!(out).ok();
        }
    }
}

fn edge_table(out: &mut String) {
    let c = &CAMERAS[1];
    let w = 15u32;
    let half = w / 2;
    writeln!(
        out,
        "\n**Depth edges** ({}): a frontoparallel card covering the left half of the image \
         (depth {} m) in front of a plane swung 30° whose depth at the edge is larger by the \
         jump. Pixels 0…{} px from the edge on either side (their {w}×{w} windows straddle it), \
         400 per cell. τ is `max_depth_jump`, the floor of the guard's relative threshold \
         (which is max(τ, 4σ̂) with σ̂ the window's estimated noise); τ = ∞ turns the guard off.\n",
        c.label, c.distance, half
    )
    .ok();
    let taus = [1e9, 0.01, 0.02, 0.05, 0.1];
    writeln!(
        out,
        "Each cell: error of all fits, median / p95 · share refused as unreliable · p95 of the \
         accepted normals.\n"
    )
    .ok();
    writeln!(
        out,
        "| depth jump | noise | τ = ∞ (no guard) | τ = 1 % | τ = 2 % (default) | τ = 5 % | τ = 10 % |"
    )
    .ok();
    writeln!(out, "|---|---|---|---|---|---|---|").ok();
    let edge_x = c.size as f64 / 2.0 - 0.5;
    let cam = camera(c);
    for jump in [0.01, 0.02, 0.05, 0.1, 0.3] {
        let view = AnalyticView::new(
            cam,
            c.size,
            c.size,
            &depth_edge(&cam, edge_x, c.distance, jump),
        );
        let mut rng = Rng::new(7);
        let pixels: Vec<(u32, u32)> = (0..SAMPLES)
            .map(|_| {
                let d = rng.range(0, half + 1);
                let left = rng.uniform() < 0.5;
                let x = if left {
                    c.size / 2 - 1 - d
                } else {
                    c.size / 2 + d
                };
                (x, rng.range(10, c.size - 10))
            })
            .collect();
        for sigma in [0.0, 0.005] {
            let depth = view.noisy_depth(sigma, 5);
            write!(out, "| {:.0} % | {:.1} % |", jump * 100.0, sigma * 100.0).ok();
            for tau in taus {
                let p = NormalParams {
                    max_depth_jump: tau,
                    ..NormalParams::default().with_window(w)
                };
                let st = normal_stats(&view, &depth, &pixels, &p);
                write!(
                    out,
                    " {}° / {}° · {:.0} % · {}° |",
                    fmt_deg(st.all_median),
                    fmt_deg(st.all_p95),
                    100.0 * st.refused,
                    fmt_deg(st.p95)
                )
                .ok();
            }
            writeln!(out).ok();
        }
    }
}

fn sphere_table(out: &mut String) {
    let c = &CAMERAS[1];
    let radius = 0.5;
    let centre = DVec3::new(0.0, 0.0, c.distance);
    let view = AnalyticView::new(
        camera(c),
        c.size,
        c.size,
        &[Surface::Sphere { centre, radius }],
    );
    // Pixels whose 21-px window lies on the sphere.
    let mut rng = Rng::new(3);
    let mut pixels = Vec::new();
    while pixels.len() < SAMPLES {
        let (x, y) = (rng.range(10, c.size - 10), rng.range(10, c.size - 10));
        let inside = (-10i32..=10).all(|d| {
            view.surface_at((x as i32 + d) as u32, y).is_some()
                && view.surface_at(x, (y as i32 + d) as u32).is_some()
                && view
                    .surface_at((x as i32 + d) as u32, (y as i32 + d) as u32)
                    .is_some()
                && view
                    .surface_at((x as i32 + d) as u32, (y as i32 - d) as u32)
                    .is_some()
        });
        if inside {
            pixels.push((x, y));
        }
    }
    let diameter_px = 2.0 * radius * c.f / c.distance;
    writeln!(
        out,
        "\n**Curved surface** ({}): a sphere of radius {radius} m at {} m ({diameter_px:.0} px \
         across), pixels whose 21-px window lies on it. A window of w px spans about \
         w·{:.1} mm of the surface.\n",
        c.label,
        c.distance,
        1000.0 * c.distance / c.f
    )
    .ok();
    write!(out, "| depth noise σ |").ok();
    for &w in &WINDOWS[..4] {
        write!(out, " window {w}: median / p95 · refused |").ok();
    }
    writeln!(out).ok();
    write!(out, "|---|").ok();
    for _ in &WINDOWS[..4] {
        write!(out, "---|").ok();
    }
    writeln!(out).ok();
    for (k, sigma) in [0.0, 0.001, 0.005, 0.01].iter().enumerate() {
        let depth = view.noisy_depth(*sigma, 200 + k as u64);
        write!(out, "| {:.1} % |", sigma * 100.0).ok();
        for &w in &WINDOWS[..4] {
            let s = normal_stats(
                &view,
                &depth,
                &pixels,
                &NormalParams::default().with_window(w),
            );
            write!(
                out,
                " {}° / {}° · {:.0} % |",
                fmt_deg(s.median),
                fmt_deg(s.p95),
                100.0 * s.refused
            )
            .ok();
        }
        writeln!(out).ok();
    }
}

/// Equilateral triangles of circumradius `rho` px at random positions and rotations.
fn triangles(c: &Cam, rho: f64, n: usize, seed: u64) -> Vec<[DVec2; 3]> {
    let mut rng = Rng::new(seed);
    let margin = rho + 2.0;
    (0..n)
        .map(|_| {
            let cx = margin + rng.uniform() * (c.size as f64 - 2.0 * margin);
            let cy = margin + rng.uniform() * (c.size as f64 - 2.0 * margin);
            let a0 = rng.uniform() * std::f64::consts::TAU;
            let v = |k: f64| {
                let a = a0 + k * std::f64::consts::TAU / 3.0;
                DVec2::new((cx + rho * a.cos()).round(), (cy + rho * a.sin()).round())
            };
            [v(0.0), v(1.0), v(2.0)]
        })
        .collect()
}

fn three_click_errors(depth: &ViewDepth, truth: DVec3, tris: &[[DVec2; 3]]) -> (Vec<f64>, usize) {
    let mut errors = Vec::new();
    let mut refused = 0;
    for t in tris {
        match picking::three_clicks(depth, *t) {
            Ok(p) => errors.push(angle_deg(p.plane.normal, truth)),
            Err(_) => refused += 1,
        }
    }
    (errors, refused)
}

fn three_click_tables(out: &mut String) {
    for c in &CAMERAS {
        let (p, n) = test_plane(c);
        let view = AnalyticView::new(camera(c), c.size, c.size, &[Surface::plane(n, p, 50.0)]);
        writeln!(
            out,
            "\n**Three clicks** ({}), same plane; equilateral triangles of pixels (rounded to \
             whole pixels), random position and rotation, {SAMPLES} per cell.\n",
            c.label
        )
        .ok();
        let radii = [25.0, 50.0, 100.0];
        write!(out, "| depth noise σ |").ok();
        for r in radii {
            write!(out, " side {:.0} px: median / p95 |", r * 3f64.sqrt()).ok();
        }
        writeln!(out).ok();
        writeln!(out, "|---|---|---|---|").ok();
        for (k, sigma) in NOISES.iter().enumerate() {
            let depth = view.noisy_depth(*sigma, 300 + k as u64);
            write!(out, "| {:.1} % |", sigma * 100.0).ok();
            for r in radii {
                let tris = triangles(c, r, SAMPLES, 11);
                let (e, _) = three_click_errors(&depth, n, &tris);
                write!(
                    out,
                    " {}° / {}° |",
                    fmt_deg(quantile(&e, 0.5)),
                    fmt_deg(quantile(&e, 0.95))
                )
                .ok();
            }
            writeln!(out).ok();
        }
    }

    // Near-collinear picks: isosceles triangles with a 300-px base and base angles θ.
    let c = &CAMERAS[0];
    let (p, n) = test_plane(c);
    let view = AnalyticView::new(camera(c), c.size, c.size, &[Surface::plane(n, p, 50.0)]);
    writeln!(
        out,
        "\n**Near-collinear picks** ({}): isosceles triangles with a 300-px base and base \
         angles θ (apex rounded to whole pixels, so the realised smallest angle is given), \
         {SAMPLES} random positions and rotations per row. \"confidence\" is the reported \
         `sin(smallest angle)/sin 60°`.\n",
        c.label
    )
    .ok();
    writeln!(
        out,
        "| θ nominal | smallest angle (median) | confidence | σ = 0: median / max | σ = 0.5 %: median / p95 | σ = 1 %: median / p95 |"
    )
    .ok();
    writeln!(out, "|---|---|---|---|---|---|").ok();
    let exact = view.depth();
    let noisy05 = view.noisy_depth(0.005, 400);
    let noisy1 = view.noisy_depth(0.01, 401);
    for theta in [60.0f64, 20.0, 5.0, 2.0, 1.0, 0.5] {
        let mut rng = Rng::new(13);
        let tris: Vec<[DVec2; 3]> = (0..SAMPLES)
            .map(|_| {
                let base = 300.0;
                let h = (base / 2.0 * theta.to_radians().tan()).max(1.0);
                let a = rng.uniform() * std::f64::consts::TAU;
                let (s, co) = a.sin_cos();
                let rot = |v: DVec2| DVec2::new(v.x * co - v.y * s, v.x * s + v.y * co);
                let ctr = DVec2::new(256.0, 256.0)
                    + DVec2::new(rng.uniform() - 0.5, rng.uniform() - 0.5) * 60.0;
                let pts = [
                    DVec2::new(-base / 2.0, -h / 3.0),
                    DVec2::new(base / 2.0, -h / 3.0),
                    DVec2::new(0.0, 2.0 * h / 3.0),
                ];
                pts.map(|q| (ctr + rot(q)).round())
            })
            .collect();
        let angles: Vec<f64> = tris
            .iter()
            .map(|t| triangle_min_angle_deg(t[0].extend(0.0), t[1].extend(0.0), t[2].extend(0.0)))
            .collect();
        let conf = quantile(&angles, 0.5).to_radians().sin() / 60f64.to_radians().sin();
        let (e0, r0) = three_click_errors(&exact, n, &tris);
        let (e05, _) = three_click_errors(&noisy05, n, &tris);
        let (e1, _) = three_click_errors(&noisy1, n, &tris);
        writeln!(
            out,
            "| {theta}° | {:.2}° | {:.3} | {}° / {}°{} | {}° / {}° | {}° / {}° |",
            quantile(&angles, 0.5),
            conf,
            fmt_deg(quantile(&e0, 0.5)),
            fmt_deg(quantile(&e0, 1.0)),
            if r0 > 0 {
                format!(" ({r0} refused)")
            } else {
                String::new()
            },
            fmt_deg(quantile(&e05, 0.5)),
            fmt_deg(quantile(&e05, 0.95)),
            fmt_deg(quantile(&e1, 0.5)),
            fmt_deg(quantile(&e1, 0.95)),
        )
        .ok();
    }
}

fn keyboard_section(out: &mut String) {
    let cam = Camera::from_centre(
        intrinsics(1463.0, 1463.0, 255.5, 255.5),
        DMat3::from_euler(glam::EulerRot::XYZ, 0.2, -0.3, 0.1),
        DVec3::new(0.3, -0.2, 1.0),
    );
    let (mut e_dist, mut e_tilt, mut e_swing, mut e_normal, mut e_point) =
        (0f64, 0f64, 0f64, 0f64, 0f64);
    let mut count = 0;
    let angles = [-89.9, -75.0, -45.0, -10.0, 0.0, 10.0, 45.0, 75.0, 89.9];
    for z in [0.1, 1.0, 8.3, 100.0, 1e4] {
        for t in angles {
            for s in angles {
                let Ok(plane) = Plane::from_focus_tilt_swing(&cam, z, t, s) else {
                    continue;
                };
                let Some((z2, t2, s2)) = plane.to_focus_tilt_swing(&cam) else {
                    continue;
                };
                count += 1;
                e_dist = e_dist.max((z2 - z).abs() / z);
                e_tilt = e_tilt.max((t2 - t).abs());
                e_swing = e_swing.max((s2 - s).abs());
                // Nudge there and back again.
                let nudge = Nudge {
                    distance: 0.37 * z,
                    tilt_deg: -0.05,
                    swing_deg: 0.05,
                };
                let back = Nudge {
                    distance: -nudge.distance,
                    tilt_deg: -nudge.tilt_deg,
                    swing_deg: -nudge.swing_deg,
                };
                if let Ok((p1, _)) = picking::nudge_plane(&plane, &cam, nudge) {
                    if let Ok((p2, _)) = picking::nudge_plane(&p1, &cam, back) {
                        e_normal = e_normal.max(angle_deg(p2.normal, plane.normal));
                        e_point = e_point.max(plane.signed_distance(p2.point).abs() / z);
                    }
                }
            }
        }
    }
    writeln!(
        out,
        "\n**Keyboard definition** (a rotated, translated camera; {count} planes: distances \
         0.1 … 10⁴, tilt and swing −89.9° … 89.9°): largest round-trip error of (distance, \
         tilt, swing) → plane → (distance, tilt, swing): distance {e_dist:.1e} (relative), tilt \
         {e_tilt:.1e}°, swing {e_swing:.1e}°. Nudging a plane by (+0.37·z, −0.05°, +0.05°) and \
         back: normal {e_normal:.1e}°, point off the original plane by {e_point:.1e}·z.\n"
    )
    .ok();
}

fn refusal_section(out: &mut String) {
    writeln!(
        out,
        "\n## Refusals\n\nEvery failure is an error with a message, never NaN or a panic \
         (each is a test in `tests/geometry_stability.rs` or the unit tests). Messages as \
         printed by the library:\n"
    )
    .ok();
    writeln!(out, "| case | message |").ok();
    writeln!(out, "|---|---|").ok();
    let cam = camera(&CAMERAS[1]);
    let values: Vec<f32> = (0..64 * 64)
        .map(|i| match i {
            0 => f32::NAN,
            1 => f32::INFINITY,
            2 => -10.0,
            3 => 2.0,
            _ => 0.0,
        })
        .collect();
    let rig = ParallelRig {
        focal_px: 307.2,
        baseline: 0.05,
        focus_distance: 2.5,
    };
    let mut small = cam;
    small.k = intrinsics(60.0, 60.0, 31.5, 31.5);
    let map = DepthMap {
        width: 64,
        height: 64,
        kind: DepthKind::Disparity,
        values,
        source: "disp.pfm".into(),
        estimated: false,
    };
    let depth = ViewDepth::new(small, &map, Some(rig), Some((-1.0, 1.0)), 0).unwrap();
    let p = NormalParams::default();
    let mut row = |case: &str, r: tiltfield::Result<()>| {
        let msg = match r {
            Ok(()) => "(accepted)".to_string(),
            Err(e) => e.to_string(),
        };
        writeln!(out, "| {case} | {} |", msg.replace('|', "\\|")).ok();
    };
    row(
        "click outside the image",
        picking::click(&depth, 64.0, 3.0, &p).map(|_| ()),
    );
    row(
        "click on NaN depth",
        picking::click(&depth, 0.0, 0.0, &p).map(|_| ()),
    );
    row(
        "click on infinite depth",
        picking::click(&depth, 1.0, 0.0, &p).map(|_| ()),
    );
    row(
        "click on a disparity beyond infinity",
        picking::click(&depth, 2.0, 0.0, &p).map(|_| ()),
    );
    row(
        "click on a disparity outside disp_min…disp_max",
        picking::click(&depth, 3.0, 0.0, &p).map(|_| ()),
    );
    // Depth-kind map with zero / negative depth.
    let neg = DepthMap {
        kind: DepthKind::Depth,
        values: vec![-1.0; 64 * 64],
        source: "depth.exr".into(),
        estimated: false,
        ..map.clone()
    };
    let neg = ViewDepth::new(small, &neg, None, None, 0).unwrap();
    row(
        "click on depth ≤ 0",
        picking::click(&neg, 10.0, 10.0, &p).map(|_| ()),
    );
    // A lone valid pixel.
    let mut lone = vec![f32::NAN; 64 * 64];
    lone[20 * 64 + 20] = 2.0;
    lone[20 * 64 + 21] = 2.0;
    let lone = ViewDepth::new(
        small,
        &DepthMap {
            kind: DepthKind::Depth,
            values: lone,
            source: "sparse.pfm".into(),
            estimated: false,
            ..map.clone()
        },
        None,
        None,
        0,
    )
    .unwrap();
    row(
        "click where too few neighbours are valid",
        picking::click(&lone, 20.0, 20.0, &p).map(|_| ()),
    );
    // Strong noise: low planarity.
    let c = &CAMERAS[0];
    let (pp, n) = test_plane(c);
    let view = AnalyticView::new(camera(c), c.size, c.size, &[Surface::plane(n, pp, 50.0)]);
    let noisy = view.noisy_depth(0.05, 9);
    let mut low = None;
    for x in 100..200 {
        if let Err(e) = picking::click(&noisy, x as f64, 200.0, &p) {
            low = Some(e);
            break;
        }
    }
    row(
        "click on noisy depth (5 %, window 9): unreliable normal",
        low.map_or(Ok(()), Err),
    );
    let wcam = camera(&CAMERAS[0]);
    let a = DVec3::new(0.0, 0.0, 8.0);
    let b = DVec3::new(1.0, 0.0, 8.0);
    row(
        "three coincident points",
        picking::three_points([a, a, b], &wcam).map(|_| ()),
    );
    row(
        "three collinear points",
        picking::three_points([a, b, DVec3::new(3.0, 1e-7, 8.0)], &wcam).map(|_| ()),
    );
    let plane = Plane::from_focus_tilt_swing(&wcam, 8.0, 80.0, 0.0).unwrap();
    row(
        "nudge to tilt ≥ 90°",
        picking::nudge_plane(
            &plane,
            &wcam,
            Nudge {
                tilt_deg: 12.0,
                ..Default::default()
            },
        )
        .map(|_| ()),
    );
    row(
        "nudge to a distance ≤ 0",
        picking::nudge_plane(
            &plane,
            &wcam,
            Nudge {
                distance: -9.0,
                ..Default::default()
            },
        )
        .map(|_| ()),
    );
    let edge_on = Plane::new(DVec3::ZERO, DVec3::X).unwrap();
    row(
        "nudge of a plane that contains the optical axis",
        picking::nudge_plane(&edge_on, &wcam, Nudge::default()).map(|_| ()),
    );
    row(
        "disparity map without a rig",
        ViewDepth::new(small, &map, None, None, 0).map(|_| ()),
    );
}

fn timing_section(out: &mut String) {
    let c = &CAMERAS[0];
    let (p, n) = test_plane(c);
    let view = AnalyticView::new(camera(c), c.size, c.size, &[Surface::plane(n, p, 50.0)]);
    let depth = view.noisy_depth(0.01, 1);
    writeln!(
        out,
        "\n**Cost of the image-space window** (this machine, `cargo run --example stability`, \
         i.e. the dev profile at opt-level 1; {} threads for whole images):\n",
        rayon::current_num_threads()
    )
    .ok();
    writeln!(out, "| window | one click (µs) | whole 512² image (ms) |").ok();
    writeln!(out, "|---|---|---|").ok();
    for w in WINDOWS {
        let params = NormalParams::default().with_window(w);
        let t = Instant::now();
        let mut k = 0;
        for y in (100..400).step_by(10) {
            for x in (100..400).step_by(10) {
                if estimate_normal(&depth, x, y, &params).is_ok() {
                    k += 1;
                }
            }
        }
        let click_us = t.elapsed().as_secs_f64() * 1e6 / 900.0;
        let t = Instant::now();
        let all = estimate_normals(&depth, &params);
        let whole_ms = t.elapsed().as_secs_f64() * 1e3;
        assert!(k > 0 && all.len() == 512 * 512);
        writeln!(out, "| {w} | {click_us:.0} | {whole_ms:.0} |").ok();
    }
}

fn main() {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "docs/stability.md".into());
    let t0 = Instant::now();
    let mut out = String::new();
    out.push_str(include_str!("stability_intro.md"));
    writeln!(
        out,
        "\n## Single click: normal error against depth noise and window size"
    )
    .ok();
    for c in &CAMERAS {
        noise_table(&mut out, c);
    }
    writeln!(out, "\n## Single click near depth edges").ok();
    edge_table(&mut out);
    writeln!(out, "\n## Single click on a curved surface").ok();
    sphere_table(&mut out);
    writeln!(out, "\n## Three clicks").ok();
    three_click_tables(&mut out);
    writeln!(out, "\n## Keyboard definition").ok();
    keyboard_section(&mut out);
    refusal_section(&mut out);
    writeln!(out, "\n## Neighbourhood search").ok();
    timing_section(&mut out);
    out.push_str(include_str!("stability_outro.md"));
    std::fs::write(&path, &out).unwrap_or_else(|e| panic!("{path}: {e}"));
    eprintln!("wrote {path} in {:.1} s", t0.elapsed().as_secs_f64());
}
