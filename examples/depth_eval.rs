//! Runs depth-estimate variants side by side on one light field and one Vulkan device and
//! scores each against a ground-truth disparity map (HCI metrics, 15-px border): the numbers
//! behind the tables of docs/depth.md. Speed on a shared CPU varies between runs, so compare
//! the GPU times of one run only.
//!
//! ```sh
//! cargo run --example depth_eval -- LF GT.pfm [VARIANT …]
//! ```
//!
//! A variant is `key=value` pairs separated by commas: `planes=64`, `views=cross`,
//! `cost=robust|mean`, `agg=guided|box|none`, `r=5`, `eps=1e-4`, `trunc=0.12`, `range=lo:hi`,
//! `png=PATH` (writes the error map: grey = |error| × 10, red where above 0.07 px). With no
//! variant the defaults run.

use std::sync::Arc;

use tiltfield::depth::metrics::{score, HCI_BORDER};
use tiltfield::depth::{DepthKind, DepthOptions};
use tiltfield::gpu::{GpuContext, GpuOptions};
use tiltfield::jobs::depth::estimate;
use tiltfield::lightfield::pfm::read_pfm_depth;
use tiltfield::lightfield::{open, GridCameraOptions};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let lf_path = args
        .first()
        .expect("usage: depth_eval LF GT.pfm [VARIANT …]");
    let gt_path = args
        .get(1)
        .expect("usage: depth_eval LF GT.pfm [VARIANT …]");
    let lf = if let Some(name) = lf_path.strip_prefix("scene:") {
        let (name, size) = name.split_once('@').unwrap_or((name, "96"));
        let size: u32 = size.parse().unwrap();
        let scene = tiltfield::bench::depth_scenes::DepthScene::from_name(name).expect("scene");
        scene.light_field(5, size)
    } else if let Some(name) = lf_path.strip_prefix("builtin:") {
        tiltfield::synth::builtin(name)
            .expect("builtin")
            .light_field(2)
    } else {
        let mut lf = open(std::path::Path::new(lf_path), &GridCameraOptions::default())
            .expect("light field");
        lf.depth.clear();
        lf
    };
    let truth = if gt_path == "-" {
        lf.depth
            .iter()
            .find(|(_, m)| m.kind == DepthKind::Disparity)
            .expect("a disparity map")
            .1
            .values
            .clone()
    } else {
        read_pfm_depth(std::path::Path::new(gt_path), DepthKind::Disparity)
            .expect("ground truth")
            .values
    };
    if let Ok(path) = std::env::var("DEPTH_EVAL_VIEW") {
        let c = lf.grid.index(lf.grid.cols / 2, lf.grid.rows / 2);
        lf.views[c].image.save(&path).unwrap();
        lf.views[0]
            .image
            .save(format!("{path}.corner.png"))
            .unwrap();
    }
    let ctx = Arc::new(GpuContext::new(&GpuOptions::from_env()).expect("Vulkan"));
    let variants: Vec<String> = if args.len() > 2 {
        args[2..].to_vec()
    } else {
        vec![String::new()]
    };
    println!("| variant | BadPix 0.07 | 0.03 | 0.01 | MSE×100 | GPU ms | confident share | BadPix 0.07 there |");
    println!("|---|---|---|---|---|---|---|---|");
    for v in &variants {
        let mut o = DepthOptions::default();
        let mut png = None;
        let mut lf = lf.clone();
        let mut sign = 1.0f32;
        for kv in v.split(',').filter(|s| !s.is_empty()) {
            let (k, val) = kv.split_once('=').expect("key=value");
            match k {
                "planes" => o.planes = Some(val.parse().unwrap()),
                "views" => o.views = val.parse().unwrap(),
                "cost" => o.params.cost = val.parse().unwrap(),
                "agg" => o.params.aggregation = val.parse().unwrap(),
                "r" => o.params.radius = val.parse().unwrap(),
                "eps" => o.params.eps = val.parse().unwrap(),
                "trunc" => o.params.truncation = val.parse().unwrap(),
                "refine" => o.params.refine = val.parse().unwrap(),
                "range" => {
                    let (a, b) = val.split_once(':').unwrap();
                    o.range = Some((a.parse().unwrap(), b.parse().unwrap()));
                }
                "png" => png = Some(val.to_string()),
                // Gaussian noise of σ (8-bit levels) on every view, seeded.
                "noise" => {
                    let sigma: f64 = val.parse().unwrap();
                    let mut rng = tiltfield::synth::surfaces::Rng::new(7);
                    for view in &mut lf.views {
                        for p in view.image.pixels_mut() {
                            for c in 0..3 {
                                let x = p.0[c] as f64 + sigma * rng.gaussian();
                                p.0[c] = x.round().clamp(0.0, 255.0) as u8;
                            }
                        }
                    }
                }
                // Compare −estimate (classic disparity of a grid folder) with HCI truth.
                "sign" => sign = val.parse().unwrap(),
                _ => panic!("unknown key {k}"),
            }
        }
        let bar = indicatif::ProgressBar::hidden();
        let est = estimate(&ctx, &lf, &o, &bar).expect("estimate");
        let d: Vec<f32> = est
            .values(DepthKind::Disparity)
            .unwrap()
            .iter()
            .map(|v| sign * v)
            .collect();
        let s = score(&d, &truth, est.width, est.height, HCI_BORDER, None);
        let confident: Vec<bool> = est
            .confidence
            .iter()
            .map(|&c| c >= tiltfield::depth::cache::MIN_CONFIDENCE)
            .collect();
        let sc = score(
            &d,
            &truth,
            est.width,
            est.height,
            HCI_BORDER,
            Some(&confident),
        );
        println!(
            "| {} | {:.2} | {:.2} | {:.2} | {:.3} | {:.0} | {:.1} % | {:.2} |",
            if v.is_empty() { "default" } else { v },
            s.bad_pix_007,
            s.bad_pix_003,
            s.bad_pix_001,
            s.mse_x100,
            est.timings.gpu_ms.unwrap_or(f64::NAN),
            100.0 * sc.pixels as f64 / s.pixels.max(1) as f64,
            sc.bad_pix_007
        );
        eprintln!(
            "  range {:.4} … {:.4} ({:?}), {} planes, {} views",
            est.range.0,
            est.range.1,
            est.range_origin,
            est.planes,
            est.views.len()
        );
        {
            // Signed error statistics inside the 15-px border: bias and spread.
            let mut e: Vec<f64> = Vec::new();
            for y in 15..est.height - 15 {
                for x in 15..est.width - 15 {
                    let i = (y * est.width + x) as usize;
                    if truth[i].is_finite() && d[i].is_finite() {
                        e.push((d[i] - truth[i]) as f64);
                    }
                }
            }
            e.sort_by(f64::total_cmp);
            let q = |f: f64| e[((e.len() - 1) as f64 * f) as usize];
            eprintln!(
                "  signed error: p10 {:.3} p25 {:.3} median {:.3} p75 {:.3} p90 {:.3}",
                q(0.1),
                q(0.25),
                q(0.5),
                q(0.75),
                q(0.9)
            );
        }
        if std::env::var_os("DEPTH_EVAL_PROBE").is_some() {
            for (x, y) in [(20u32, 20u32), (70, 70), (80, 60), (60, 80), (50, 50)] {
                let i = (y * est.width + x) as usize;
                eprintln!(
                    "  ({x},{y}): est {:.3} truth {:.3} conf {:.3}",
                    d[i], truth[i], est.confidence[i]
                );
            }
        }
        // Clicks on the estimate against clicks on the truth (inverse-depth fit, 31 px).
        if let Ok(list) = std::env::var("DEPTH_EVAL_CLICKS") {
            use tiltfield::geometry::depth::ViewDepth;
            use tiltfield::geometry::normals::{reliable_normal, NormalParams};
            let rig = lf.rig.expect("clicks need a rig");
            let cam = lf.views[est.reference].camera;
            let truth_map = tiltfield::lightfield::DepthMap {
                width: est.width,
                height: est.height,
                kind: DepthKind::Disparity,
                values: truth.clone(),
                source: "truth".into(),
                estimated: false,
            };
            let t = ViewDepth::new(cam, &truth_map, Some(rig), None, est.reference).unwrap();
            let e = ViewDepth::new(
                cam,
                &est.depth_map(tiltfield::depth::cache::MIN_CONFIDENCE),
                Some(rig),
                None,
                est.reference,
            )
            .unwrap();
            let params = NormalParams::default().with_window(31);
            let mut errs = Vec::new();
            for xy in list.split(';') {
                let (x, y) = xy.split_once(',').unwrap();
                let (x, y): (u32, u32) = (x.parse().unwrap(), y.parse().unwrap());
                let nt = reliable_normal(&t, x, y, &params);
                let ne = reliable_normal(&e, x, y, &params);
                match (nt, ne) {
                    (Ok(a), Ok(b)) => {
                        let ang = a
                            .normal
                            .dot(b.normal)
                            .abs()
                            .clamp(0.0, 1.0)
                            .acos()
                            .to_degrees();
                        errs.push(ang);
                        eprintln!(
                            "  click ({x},{y}): {ang:.2}° (uncertainty {:.2}°)",
                            b.uncertainty_deg
                        );
                    }
                    (a, b) => eprintln!(
                        "  click ({x},{y}): truth {:?} estimate {:?}",
                        a.map(|_| ()),
                        b.map(|_| ())
                    ),
                }
            }
            errs.sort_by(f64::total_cmp);
            if !errs.is_empty() {
                eprintln!(
                    "  clicks: median {:.2}°, max {:.2}° over {}",
                    errs[errs.len() / 2],
                    errs[errs.len() - 1],
                    errs.len()
                );
            }
        }
        if let Some(path) = png {
            let img = image::RgbImage::from_fn(est.width, est.height, |x, y| {
                let i = (y * est.width + x) as usize;
                let e = (d[i] - truth[i]).abs();
                let g = (e * 10.0 * 255.0).min(255.0) as u8;
                if e > 0.07 {
                    image::Rgb([255, g / 2, g / 2])
                } else {
                    image::Rgb([g, g, g])
                }
            });
            img.save(&path).unwrap();
        }
    }
    assert_eq!(ctx.validation().errors(), 0);
}
