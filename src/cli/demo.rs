//! `tiltfield demo`: renders the built-in demo scene (generated in code, exact depth) and
//! refocuses it onto each of its planes, with one virtual-viewpoint render, so the product can
//! be seen working with no files at all.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use glam::DVec2;
use serde_json::json;

use super::render::{plan_json, save};
use super::{default_demo_dir, AntialiasArgs, GpuArgs};
use crate::error::{Error, Result};
use crate::geometry::aperture::{Aperture, ApertureShape};
use crate::geometry::plane::Plane;
use crate::jobs::refocus::HeadlessRenderer;
use crate::jobs::refocus::RenderSettings;
use crate::refocus::settings::OutputFormat;
use crate::refocus::{self, FocusSpec, RefocusRequest};
use crate::synth;

#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output folder.
    #[arg(short, long, value_name = "DIR")]
    pub output: Option<PathBuf>,
    /// Built-in scene to use.
    #[arg(long, default_value = "demo")]
    pub scene: String,
    /// List the built-in scenes and exit.
    #[arg(long)]
    pub list: bool,
    /// Anti-aliased refocus (default on: the built-in scenes have exact depth).
    #[command(flatten)]
    pub antialias: AntialiasArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

pub fn run(args: &DemoArgs) -> Result<()> {
    if args.list {
        for name in synth::builtin_names() {
            if let Some(b) = synth::builtin(name) {
                println!(
                    "builtin:{name:<8} {}×{} views of {}×{}: {}",
                    b.grid.cols, b.grid.rows, b.width, b.height, b.description
                );
            }
        }
        return Ok(());
    }
    let dir = args.output.clone().unwrap_or_else(default_demo_dir);
    crate::io::utf8_path(&dir, "-o")?;
    let aa_settings = args.antialias.settings()?;
    // Checked now, made when the first image is written (and removed again on failure).
    crate::io::check_writable_folder(&dir, "demo.json")?;
    let scene = synth::builtin(&args.scene).ok_or_else(|| {
        Error::Invalid(format!(
            "no built-in scene '{}'; available: {}",
            args.scene,
            synth::builtin_names().join(", ")
        ))
    })?;
    let t0 = Instant::now();
    let lf = super::builtin_light_field(&args.scene)?;
    eprintln!(
        "generated builtin:{} ({}×{} views of {}×{}) in {:.2} s",
        args.scene,
        lf.grid.cols,
        lf.grid.rows,
        lf.width,
        lf.height,
        t0.elapsed().as_secs_f64()
    );
    let mut renderer = HeadlessRenderer::new(&lf, &args.gpu.options())?;
    let device = renderer.context().info.name.clone();
    let centre = lf.grid.centre();
    let centre_view = &lf.views[lf.grid.index(lf.grid.cols / 2, lf.grid.rows / 2)];
    let folder = crate::io::OutputFolder::create(&dir)?;
    let mut written = Vec::new();
    let view_path = folder.write_with("centre_view.png", "PNG", |w| {
        crate::io::encode_png(&centre_view.image, w)
    })?;
    written
        .push(json!({"file": view_path, "what": "the centre view (a pinhole image, all sharp)"}));

    // One refocus per scene plane, all views, then a virtual viewpoint with a small aperture.
    let mut jobs: Vec<(String, String, RefocusRequest)> = Vec::new();
    for (name, point, normal) in scene.planes() {
        jobs.push((
            format!("refocus_{}.png", name.replace(' ', "_")),
            format!("all views focused on the {name} plane"),
            RefocusRequest {
                focus: FocusSpec::Plane(Plane::new(point, normal)?),
                aperture: Aperture::default(),
                reference: None,
            },
        ));
    }
    if let Some((name, point, normal)) = scene.planes().into_iter().last() {
        jobs.push((
            "virtual_view.png".into(),
            format!(
                "virtual viewpoint between the cameras, disk aperture of radius 1.5, focused on {name}"
            ),
            RefocusRequest {
                focus: FocusSpec::Plane(Plane::new(point, normal)?),
                aperture: Aperture {
                    shape: ApertureShape::Disk,
                    radius: Some(1.5),
                },
                reference: Some(centre + DVec2::new(-1.5, 0.75)),
            },
        ));
    }
    let settings = RenderSettings {
        output: OutputFormat::Srgb8,
        ..RenderSettings::default()
    };
    let aa_on = refocus::antialias::wanted(args.antialias.requested(), &lf);
    for (file, what, req) in jobs {
        let plain = refocus::plan(&lf, &req, &[])?;
        let aa = if aa_on {
            Some(refocus::antialias::plan_for(
                &lf,
                &plain,
                req.aperture,
                &[],
                aa_settings,
            )?)
        } else {
            None
        };
        let (image, timings) = match &aa {
            Some(aa) => renderer.render_antialiased(aa, &settings)?,
            None => renderer.render(&plain, &settings)?,
        };
        let plan = aa.as_ref().map_or(&plain, |a| &a.plan);
        let path = dir.join(&file);
        folder.track(&path, |p| save(&image, p))?;
        let ms = timings.map(|t| t.refocus_ms);
        eprintln!(
            "  {:<28} {what}{}",
            file,
            ms.map_or(String::new(), |ms| format!(" ({ms:.1} ms GPU)"))
        );
        let mut entry = plan_json(plan);
        if let Some(o) = entry.as_object_mut() {
            o.insert(
                "antialias".into(),
                refocus::antialias::antialias_json(aa.as_ref(), None),
            );
            o.insert("file".into(), json!(path));
            o.insert("what".into(), json!(what));
            o.insert("gpu_refocus_ms".into(), json!(ms));
            o.remove("views");
        }
        written.push(entry);
    }
    // Counted before the renderer is freed, as every command does.
    let validated = renderer.context().check_validation("during the demo");
    drop(renderer);
    validated?;
    let summary = json!({"scene": args.scene, "device": device, "images": written});
    let summary_path = folder.write_bytes(
        "demo.json",
        "JSON",
        serde_json::to_string_pretty(&summary)
            .map_err(|e| Error::Invalid(e.to_string()))?
            .as_bytes(),
    )?;
    folder.finish();
    println!(
        "wrote {} refocus images of builtin:{} to {} (summary: {}; device: {device})",
        written.len(),
        args.scene,
        dir.display(),
        summary_path.display()
    );
    Ok(())
}
