//! The reshaped GPU layer against the f64 reference: every strategy (one draw, batched draws,
//! compute), every filter and view storage, output sizes other than the views', progressive
//! accumulation over several submissions, the exactness of the default 8-bit output, and that
//! moving the plane alone uploads no warps. Validation layer on, zero errors asserted.

mod common;

use std::sync::Arc;

use common::*;
use tiltfield::gpu::GpuContext;
use tiltfield::jobs::refocus::{GpuImage, HeadlessRenderer, RenderSettings};
use tiltfield::lightfield::LightField;
use tiltfield::passes::refocus::{ComputeShape, RefocusPass};
use tiltfield::passes::texture::LightFieldTexture;
use tiltfield::refocus::settings::ViewStorage;
use tiltfield::refocus::settings::{Filter, OutputFormat, Strategy};
use tiltfield::refocus::{self, cpu, Averaging, FocusSpec, RefocusImage, RefocusPlan};

const STRATEGIES: [Strategy; 3] = [
    Strategy::Fragment,
    Strategy::Batched { views_per_draw: 4 },
    Strategy::Compute,
];

fn renderer_with(lf: &LightField, storage: ViewStorage) -> HeadlessRenderer {
    let ctx = Arc::new(GpuContext::new(&gpu_options()).expect("validated context"));
    HeadlessRenderer::with_context(ctx, lf, storage).expect("renderer")
}

fn float(r: &mut HeadlessRenderer, plan: &RefocusPlan, settings: RenderSettings) -> RefocusImage {
    let settings = RenderSettings {
        output: OutputFormat::Float,
        ..settings
    };
    match r.render(plan, &settings).expect("render").0 {
        GpuImage::Float(img) => img,
        GpuImage::Srgb8(_) => panic!("asked for float"),
    }
}

fn tilted_plan(lf: &LightField) -> RefocusPlan {
    let req = request(FocusSpec::FocusTiltSwing {
        distance: 2.5,
        tilt_deg: 35.0,
        swing_deg: -10.0,
    });
    refocus::plan(lf, &req, &[]).expect("plan")
}

#[test]
fn every_strategy_filter_and_storage_matches_the_f64_reference() {
    let lf = builtin("tilted");
    let plan = tilted_plan(&lf);
    let reference = cpu::render(&lf, &plan, Averaging::Linear);
    for storage in [ViewStorage::Srgb8, ViewStorage::Linear16] {
        let mut r = renderer_with(&lf, storage);
        for strategy in STRATEGIES {
            // Hardware bilinear snaps positions to 8 fractional bits; the shader's f32
            // bilinear does not, so it is held to a tighter bound.
            for (filter, min_psnr, max_levels) in
                [(Filter::Hardware, 55.0, 2.0), (Filter::Shader, 62.0, 1.0)]
            {
                let settings = RenderSettings {
                    strategy,
                    filter,
                    ..RenderSettings::default()
                };
                let gpu = float(&mut r, &plan, settings);
                assert!(gpu.is_finite());
                let d = diff(&gpu, &reference, None);
                let name = format!("{storage:?} {} {filter:?}", strategy.name());
                eprintln!(
                    "{name}: PSNR {:.1} dB, max {:.2} levels, {} coverage mismatches",
                    d.psnr_db, d.max_levels, d.coverage_mismatch
                );
                assert!(d.psnr_db >= min_psnr, "{name}: PSNR {:.1} dB", d.psnr_db);
                assert!(
                    d.max_levels <= max_levels,
                    "{name}: {:.2} levels",
                    d.max_levels
                );
                assert!(
                    d.coverage_mismatch <= gpu.pixels.len() / 500,
                    "{name}: coverage"
                );
            }
        }
        assert_no_validation_errors(&r);
    }
}

#[test]
fn encoded_averaging_works_with_every_strategy_and_storage() {
    let lf = builtin("tilted");
    let plan = tilted_plan(&lf);
    let reference = cpu::render(&lf, &plan, Averaging::Encoded);
    for storage in [ViewStorage::Srgb8, ViewStorage::Linear16] {
        let mut r = renderer_with(&lf, storage);
        for strategy in STRATEGIES {
            // Linear storage re-encodes texels in the shader, which then filters itself.
            for filter in [Filter::Hardware, Filter::Shader] {
                let settings = RenderSettings {
                    strategy,
                    averaging: Averaging::Encoded,
                    filter,
                    ..RenderSettings::default()
                };
                let d = diff(&float(&mut r, &plan, settings), &reference, None);
                let name = format!("{storage:?} {} {filter:?}", strategy.name());
                eprintln!("encoded {name}: {d:?}");
                assert!(d.psnr_db >= 55.0 && d.max_levels <= 2.0, "{name}: {d:?}");
            }
        }
        assert_no_validation_errors(&r);
    }
}

#[test]
fn nearest_filter_is_exact_where_samples_land_on_texel_centres() {
    // An integer HCI disparity shifts every view by whole pixels: nearest and bilinear sample
    // the same texels, so both must equal the reference up to float rounding.
    let lf = builtin("planes");
    let plan = refocus::plan(&lf, &request(FocusSpec::Disparity(1.0)), &[]).expect("plan");
    let reference = cpu::render(&lf, &plan, Averaging::Linear);
    let mut r = renderer_with(&lf, ViewStorage::Srgb8);
    for strategy in [Strategy::Fragment, Strategy::Compute] {
        let settings = RenderSettings {
            strategy,
            filter: Filter::Nearest,
            ..RenderSettings::default()
        };
        let d = diff(&float(&mut r, &plan, settings), &reference, None);
        assert!(d.max_levels <= 0.5, "{}: {d:?}", strategy.name());
    }
    // Half-pixel shifts are where nearest differs from bilinear: it must, visibly.
    let plan = refocus::plan(&lf, &request(FocusSpec::Disparity(0.5)), &[]).expect("plan");
    let reference = cpu::render(&lf, &plan, Averaging::Linear);
    let settings = RenderSettings {
        filter: Filter::Nearest,
        ..RenderSettings::default()
    };
    let d = diff(&float(&mut r, &plan, settings), &reference, None);
    assert!(
        d.max_levels > 2.0,
        "nearest should differ from bilinear here: {d:?}"
    );
    assert_no_validation_errors(&r);
}

#[test]
fn output_sizes_other_than_the_views_map_pixel_centres_exactly() {
    let lf = builtin("tilted");
    let plan = tilted_plan(&lf);
    let mut r = renderer_with(&lf, ViewStorage::Srgb8);
    let (w, h) = (lf.width, lf.height);
    for (ow, oh) in [
        (w / 2, h / 2),
        (w * 3 / 2, h * 3 / 2),
        (w * 2 / 3 + 1, h / 3 + 1),
    ] {
        let reference = cpu::render_scaled(&lf, &plan, Averaging::Linear, ow, oh);
        for strategy in [Strategy::Fragment, Strategy::Compute] {
            let settings = RenderSettings {
                strategy,
                filter: Filter::Shader,
                size: Some((ow, oh)),
                ..RenderSettings::default()
            };
            let gpu = float(&mut r, &plan, settings);
            assert_eq!((gpu.width, gpu.height), (ow, oh));
            let d = diff(&gpu, &reference, None);
            // Where a sample lands within float rounding of a view's border, the f32 mask and
            // the f64 one may disagree about that view: a few pixels then differ by a
            // fraction of one view's weight. Everywhere else the scaled image is exact.
            let (a, b) = (encoded(&gpu), encoded(&reference));
            let off = a
                .iter()
                .zip(&b)
                .filter(|(p, q)| (0..3).any(|k| (p[k] - q[k]).abs() * 255.0 > 0.5))
                .count();
            eprintln!(
                "{ow}×{oh} {}: {d:?}, {off} pixels off by > 0.5 level",
                strategy.name()
            );
            assert!(d.psnr_db >= 60.0, "{ow}×{oh}: {d:?}");
            assert!(
                off * 200 <= a.len(),
                "{ow}×{oh}: {off} of {} pixels off",
                a.len()
            );
            assert!(d.max_levels <= 4.0, "{ow}×{oh}: {d:?}");
        }
    }
    assert_no_validation_errors(&r);
}

#[test]
fn progressive_batches_sum_to_the_full_image_and_partials_are_normalised() {
    let lf = builtin("planes");
    let plan = tilted_plan(&lf);
    let n = plan.views.len();
    assert!(n >= 9, "need several batches");
    let mut r = renderer_with(&lf, ViewStorage::Srgb8);
    for strategy in [Strategy::Fragment, Strategy::Compute] {
        let settings = RenderSettings {
            strategy,
            filter: Filter::Shader,
            output: OutputFormat::Float,
            ..RenderSettings::default()
        };
        let cuts = [0, 3, 7, n];
        let mut last = None;
        for (k, w) in cuts.windows(2).enumerate() {
            let img = match r
                .accumulate(&plan, &settings, w[0]..w[1], k == 0)
                .expect("accumulate")
            {
                GpuImage::Float(img) => img,
                GpuImage::Srgb8(_) => panic!("asked for float"),
            };
            // The partial sum, normalised, is the refocus of the views added so far.
            let mut partial = plan.clone();
            partial.views.truncate(w[1]);
            let reference = cpu::render(&lf, &partial, Averaging::Linear);
            let d = diff(&img, &reference, None);
            assert!(
                d.psnr_db >= 60.0 && d.max_levels <= 1.0,
                "{} after {} views: {d:?}",
                strategy.name(),
                w[1]
            );
            last = Some(img);
        }
        let full = float(&mut r, &plan, settings);
        let d = diff(&last.unwrap(), &full, None);
        assert!(d.max_levels <= 0.01, "{}: {d:?}", strategy.name());
    }
    assert_no_validation_errors(&r);
}

/// Mean signed error (levels) and PSNR of 8-bit `a` against 8-bit reference `b`, RGB only.
fn bias_and_psnr(a: &image::RgbaImage, b: &image::RgbaImage) -> (f64, f64) {
    let (mut sum, mut se, mut n) = (0.0, 0.0, 0.0);
    for (pa, pb) in a.pixels().zip(b.pixels()) {
        for k in 0..3 {
            let d = pa.0[k] as f64 - pb.0[k] as f64;
            sum += d;
            se += d * d;
            n += 1.0;
        }
    }
    let mse = se / n / (255.0 * 255.0);
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    };
    (sum / n, psnr)
}

#[test]
fn default_8bit_output_is_unbiased_against_the_exactly_rounded_reference() {
    let lf = builtin("tilted");
    let mut r = renderer(&lf);
    for plan in [
        tilted_plan(&lf),
        refocus::plan(&lf, &request(FocusSpec::Disparity(0.37)), &[]).expect("plan"),
    ] {
        let gpu8 = render_srgb8(&mut r, &plan, Averaging::Linear);
        let ref8 = cpu::render(&lf, &plan, Averaging::Linear).to_srgb8();
        let (bias, psnr) = bias_and_psnr(&gpu8, &ref8);
        eprintln!("default 8-bit output: mean signed error {bias:+.4} levels, PSNR {psnr:.1} dB");
        assert!(bias.abs() <= 0.02, "mean signed error {bias:+.4} levels");
        assert!(psnr >= 60.0, "PSNR {psnr:.1} dB");
    }
    assert_no_validation_errors(&r);
}

#[test]
fn moving_the_plane_alone_uploads_no_warps() {
    let lf = builtin("planes");
    let ctx = GpuContext::new(&gpu_options()).expect("validated context");
    let texture = LightFieldTexture::upload(&ctx, &lf, ViewStorage::Srgb8).expect("upload");
    let mut pass = RefocusPass::new(&ctx, &texture).expect("pass");
    let at = |d: f64| refocus::plan(&lf, &request(FocusSpec::Disparity(d)), &[]).expect("plan");
    let near = at(1.2);
    let far = at(-0.4);
    assert_ne!(near.m, far.m, "the planes differ");
    assert!(pass.set_views(&near).unwrap(), "first upload writes");
    assert!(
        !pass.set_views(&far).unwrap(),
        "a new plane alone writes nothing"
    );
    let mut smaller = near.clone();
    smaller.views.truncate(4);
    assert!(pass.set_views(&smaller).unwrap(), "a new view set writes");
    assert_eq!(pass.view_count(), 4);
    drop((pass, texture));
    assert_eq!(
        ctx.validation().errors(),
        0,
        "{:#?}",
        ctx.validation().messages()
    );
}

#[test]
fn one_context_serves_several_renderers() {
    let lf = builtin("planes");
    let ctx = Arc::new(GpuContext::new(&gpu_options()).expect("validated context"));
    let mut a = HeadlessRenderer::with_context(Arc::clone(&ctx), &lf, ViewStorage::Srgb8)
        .expect("first renderer");
    let mut b = HeadlessRenderer::with_context(Arc::clone(&ctx), &lf, ViewStorage::Linear16)
        .expect("second renderer");
    let plan = refocus::plan(&lf, &request(FocusSpec::Disparity(0.3)), &[]).expect("plan");
    let settings = RenderSettings {
        filter: Filter::Shader,
        ..RenderSettings::default()
    };
    let ia = float(&mut a, &plan, settings);
    let ib = float(&mut b, &plan, settings);
    assert!(diff(&ia, &ib, None).max_levels <= 1.0);
    drop(a);
    drop(b);
    assert_eq!(Arc::strong_count(&ctx), 1);
    assert_eq!(
        ctx.validation().errors(),
        0,
        "{:#?}",
        ctx.validation().messages()
    );
}

#[test]
fn frames_in_flight_keep_each_slots_image() {
    use tiltfield::gpu::commands::{color_copy, image_barrier, stage, ImageTransition};
    use tiltfield::gpu::frames::Frames;
    use tiltfield::gpu::resources::{rgba_f32, Buffer};
    use tiltfield::passes::refocus::Accumulate;

    let lf = builtin("planes");
    let ctx = GpuContext::new(&gpu_options()).expect("validated context");
    let texture = LightFieldTexture::upload(&ctx, &lf, ViewStorage::Srgb8).expect("upload");
    let mut pass = RefocusPass::new(&ctx, &texture).expect("pass");
    let mut frames = Frames::new(&ctx, 2).expect("frames");
    let (w, h) = (lf.width, lf.height);
    let mut targets: Vec<_> = (0..2)
        .map(|_| pass.create_target(&ctx, w, h).expect("target"))
        .collect();
    let mut readbacks: Vec<_> = (0..2)
        .map(|_| Buffer::readback(&ctx, w as u64 * h as u64 * 16, "test readback").unwrap())
        .collect();
    let disparities = [-0.5, 0.0, 0.4, 0.9, 1.3];
    let mut plans = Vec::new();
    for &d in &disparities {
        let plan = refocus::plan(&lf, &request(FocusSpec::Disparity(d)), &[]).expect("plan");
        let frame = frames.begin(&ctx).expect("begin");
        // Same view set every frame: only m changes, so nothing in flight is overwritten.
        pass.set_views(&plan).expect("views");
        let target = &mut targets[frame.slot];
        let m = plan.m.as_vec3();
        let a = Accumulate {
            m: [m.x, m.y, m.z],
            views: 0..plan.views.len(),
            clear: true,
            strategy: Strategy::Fragment,
            filter: Filter::Shader,
            averaging: Averaging::Linear,
            antialias: 0,
            surface: false,
        };
        pass.record_accumulate(&ctx, frame.cmd, target, &a).unwrap();
        pass.record_resolve(
            &ctx,
            frame.cmd,
            target,
            OutputFormat::Float,
            Averaging::Linear,
        )
        .unwrap();
        let out = target.outf.image;
        let to_copy = ImageTransition {
            from: stage::COLOR_WRITE,
            to: stage::TRANSFER_SRC,
        };
        image_barrier(&ctx.device, frame.cmd, out, 1, to_copy);
        // SAFETY: recording; the buffer holds w·h·16 bytes.
        unsafe {
            ctx.device.cmd_copy_image_to_buffer(
                frame.cmd,
                out,
                ash::vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                readbacks[frame.slot].buffer,
                &[color_copy(0, w, h, 1)],
            )
        };
        frames.submit(&ctx, &[], &[]).expect("submit");
        plans.push(plan);
    }
    frames.wait_all(&ctx).expect("wait");
    // The last two frames' images are intact in their slots' buffers.
    for (k, plan) in plans.iter().enumerate().skip(disparities.len() - 2) {
        let buffer = &mut readbacks[k % 2];
        buffer.invalidate(&ctx).unwrap();
        let pixels = rgba_f32(&buffer.bytes_mut()[..(w * h * 16) as usize], 1.0);
        let gpu = RefocusImage {
            width: w,
            height: h,
            averaging: Averaging::Linear,
            pixels,
        };
        let d = diff(&gpu, &cpu::render(&lf, plan, Averaging::Linear), None);
        assert!(d.psnr_db >= 60.0, "frame {k}: {d:?}");
    }
    // Freed before the count, so teardown is checked too.
    drop((frames, targets, readbacks, pass, texture));
    assert_eq!(
        ctx.validation().errors(),
        0,
        "{:#?}",
        ctx.validation().messages()
    );
}

/// The compute strategy's plain sum in every shape (output pixels per invocation, views per
/// iteration, workgroup shape) gives the per-pixel loop's numbers, bit for bit: every filter,
/// an output whose width no tile divides, a tilted plane whose views miss some pixels, and
/// batches added to a running sum. It also equals the fragment strategy's image (the same
/// arithmetic per sample).
#[test]
fn every_compute_shape_gives_the_per_pixel_sums_exactly() {
    let lf = builtin("tilted");
    let plan = tilted_plan(&lf);
    let n = plan.views.len();
    let mut r = renderer_with(&lf, ViewStorage::Linear16);
    let base = ComputeShape::default();
    let shape = |pixels, unroll, tile| ComputeShape {
        pixels,
        unroll,
        tile,
    };
    let shapes = [
        shape(1, 1, (8, 8)),
        shape(2, 1, (8, 8)),
        shape(4, 1, (8, 8)),
        shape(1, 4, (8, 8)),
        shape(3, 3, (8, 8)),
        shape(1, 8, (16, 16)),
        shape(2, 2, (32, 4)),
        shape(0, 1, (16, 4)),
    ];
    for filter in [
        Filter::Hardware,
        Filter::Shader,
        Filter::Bicubic,
        Filter::Nearest,
    ] {
        for size in [None, Some((61, 37))] {
            let settings = RenderSettings {
                strategy: Strategy::Compute,
                filter,
                size,
                output: OutputFormat::Float,
                ..RenderSettings::default()
            };
            let run = |r: &mut HeadlessRenderer, s: ComputeShape| -> Vec<Vec<[f32; 4]>> {
                r.set_compute_shape(s).unwrap();
                let mut images = vec![float(r, &plan, settings).pixels];
                // Batches: the later ones add to the stored sum.
                for (k, w) in [0, 5, n].windows(2).enumerate() {
                    match r.accumulate(&plan, &settings, w[0]..w[1], k == 0).unwrap() {
                        GpuImage::Float(img) => images.push(img.pixels),
                        GpuImage::Srgb8(_) => panic!("asked for float"),
                    }
                }
                images
            };
            let per_pixel = run(&mut r, ComputeShape { pixels: 0, ..base });
            for s in shapes {
                assert!(
                    run(&mut r, s) == per_pixel,
                    "{filter:?} {size:?}: {s:?} differs from the per-pixel loop"
                );
            }
            r.set_compute_shape(base).unwrap();
            let fragment = float(
                &mut r,
                &plan,
                RenderSettings {
                    strategy: Strategy::Fragment,
                    ..settings
                },
            );
            assert!(
                fragment.pixels == per_pixel[0],
                "{filter:?} {size:?}: compute ≠ fragment"
            );
        }
    }
    for bad in [
        shape(5, 1, (8, 8)),
        shape(1, 9, (8, 8)),
        shape(1, 1, (64, 32)),
    ] {
        assert!(r.set_compute_shape(bad).is_err(), "{bad:?}");
    }
    assert_no_validation_errors(&r);
}
