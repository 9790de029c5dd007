//! Rendering a range of frames of a camera-array video with one GPU set-up
//! (`tiltfield render LF --frames A..B -o 'out_{frame}.png'`).
//!
//! Three threads form a pipeline:
//! - a [`FrameLoader`] decodes frame k + 1 (its views in parallel on rayon's pool, distortion
//!   removed) while
//! - the calling thread uploads frame k into the light field texture **in place**
//!   ([`HeadlessRenderer::replace_views`]: the pass, its descriptors, the target and the plan
//!   stay), refocuses it and reads it back, and
//! - a writer thread encodes and writes frame k − 1.
//!
//! The refocus plan — plane, aperture, reference view, views left out — is made once, from the
//! first frame: every frame of a video has the same cameras, so the same plan is exact for all
//! of them. The scene is not the same: anti-aliasing follows each frame's own depth (the
//! planner may replace the frame plan's anti-aliasing for every frame). Each frame's times
//! are recorded ([`FrameTimes`]) so a report can say where the time goes.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, sync_channel};
use std::sync::Arc;
use std::time::Instant;

use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::jobs::refocus::{GpuImage, HeadlessRenderer, RenderSettings};
use crate::lightfield::video::{FrameLoader, FrameSequence};
use crate::lightfield::{LightField, LoadLimits};
use crate::refocus::antialias::AntialiasPlan;
use crate::refocus::settings::ViewStorage;
use crate::refocus::surface::SurfacePlan;
use crate::refocus::RefocusPlan;

/// An output path with the frame number in it: `{frame}` (the number as is) or `{frame:0N}`
/// (zero-padded to N digits), e.g. `out/refocus_{frame:05}.png`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputPattern {
    before: String,
    after: String,
    width: usize,
}

impl OutputPattern {
    /// Parses a pattern; exactly one `{frame}` or `{frame:0N}` is required, so that frames
    /// never overwrite each other.
    pub fn parse(text: &str) -> Result<Self> {
        let bad = |why: &str| {
            Error::Invalid(format!(
                "output '{text}': {why}; with --frames the output names each frame's file with \
                 {{frame}} or {{frame:05}}, e.g. 'out_{{frame}}.png'"
            ))
        };
        let Some(start) = text.find("{frame") else {
            return Err(bad("no {frame} in it"));
        };
        let Some(len) = text[start..].find('}') else {
            return Err(bad("{frame is not closed"));
        };
        let spec = &text[start + 6..start + len];
        let width = match spec {
            "" => 0,
            _ => spec
                .strip_prefix(":0")
                .and_then(|n| n.parse::<usize>().ok())
                .filter(|&n| n <= 20)
                .ok_or_else(|| bad("the frame field must be {frame} or {frame:0N}, N ≤ 20"))?,
        };
        let after = &text[start + len + 1..];
        if after.contains("{frame") {
            return Err(bad("{frame} appears more than once"));
        }
        Ok(OutputPattern {
            before: text[..start].to_string(),
            after: after.to_string(),
            width,
        })
    }

    /// The output path of `frame`.
    pub fn path(&self, frame: u64) -> PathBuf {
        PathBuf::from(format!(
            "{}{:0width$}{}",
            self.before,
            frame,
            self.after,
            width = self.width
        ))
    }
}

/// Where one frame's time went, milliseconds of wall time (GPU time from timestamps).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FrameTimes {
    pub frame: u64,
    /// Decoding the views and removing distortion (on the loader thread, overlapped).
    pub decode_ms: f64,
    /// How long the render thread waited for the decoded frame.
    pub wait_ms: f64,
    /// Planning the frame (the first: the refocus plan; with anti-aliasing, every frame: its
    /// depth, estimated or read from the cache, and the footprints and visibility on it).
    pub plan_ms: f64,
    /// Converting and uploading the views into the texture (the first frame: the whole set-up
    /// of texture, pass and target).
    pub upload_ms: f64,
    /// Recording, submitting and waiting for the refocus, and reading the image back.
    pub render_ms: f64,
    /// The refocus pass on the GPU (timestamps), when the device has timers.
    pub gpu_refocus_ms: Option<f64>,
    /// Encoding and writing the output file (on the writer thread, overlapped).
    pub encode_ms: f64,
    /// Output pixels no view reached.
    pub uncovered_pixels: usize,
}

/// The result of [`render_frames`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct BatchReport {
    pub frames: Vec<FrameTimes>,
    /// From the start of [`render_frames`] until the last file was written.
    pub wall_s: f64,
    /// Frames per second over `wall_s`.
    pub frames_per_second: f64,
    pub device: String,
}

/// Mean per-frame times of a range (`None`: no frame has that time), as reports show them.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MeanTimes {
    pub decode: Option<f64>,
    pub wait_for_decode: Option<f64>,
    pub planning: Option<f64>,
    /// The steady state: the first frame's upload includes the whole set-up and is left out
    /// (unless it is the only frame).
    pub upload: f64,
    pub render_and_readback: Option<f64>,
    pub gpu_refocus: Option<f64>,
    pub encode: Option<f64>,
}

impl BatchReport {
    /// Mean of one timing over the frames (`None` when no frame has it).
    pub fn mean(&self, f: impl Fn(&FrameTimes) -> Option<f64>) -> Option<f64> {
        let v: Vec<f64> = self.frames.iter().filter_map(f).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    }

    /// The mean of every per-frame time.
    pub fn means(&self) -> MeanTimes {
        let skip = usize::from(self.frames.len() > 1);
        let uploads = self.frames.iter().skip(skip).map(|t| t.upload_ms);
        MeanTimes {
            decode: self.mean(|t| Some(t.decode_ms)),
            wait_for_decode: self.mean(|t| Some(t.wait_ms)),
            planning: self.mean(|t| Some(t.plan_ms)),
            upload: uploads.sum::<f64>() / (self.frames.len() - skip).max(1) as f64,
            render_and_readback: self.mean(|t| Some(t.render_ms)),
            gpu_refocus: self.mean(|t| t.gpu_refocus_ms),
            encode: self.mean(|t| Some(t.encode_ms)),
        }
    }
}

/// Writes a GPU result to `path` (PNG or EXR by extension) through [`crate::io`] (folder
/// created on success only). Returns the number of uncovered pixels. An image no view reaches
/// (a plane so near that every sample lands outside the views) is fully transparent: it is
/// refused naming the cause, for a single render and every frame of a range alike, instead of
/// written as a "result".
pub fn save_image(image: &GpuImage, path: &Path) -> Result<usize> {
    let (total, uncovered) = (image.pixel_count(), image.uncovered());
    if uncovered == total && total > 0 {
        return Err(Error::Geometry(format!(
            "no view reaches any of the {total} output pixels with this focus; nothing was \
             written to {}. The plane is probably too near or beyond the views' overlap",
            path.display()
        )));
    }
    match image {
        GpuImage::Srgb8(img) => crate::io::save_png(img, path)?,
        GpuImage::Float(img) => crate::io::save_exr(img.width, img.height, &img.linear(), path)?,
    }
    Ok(uncovered)
}

/// What to render.
pub struct BatchJob<'a> {
    pub sequence: &'a FrameSequence,
    /// Frame numbers in output order (checked with [`FrameSequence::select`]).
    pub frames: &'a [u64],
    pub settings: RenderSettings,
    pub storage: ViewStorage,
    pub output: &'a OutputPattern,
    /// Refused before decoding a frame beyond them (the device's).
    pub limits: LoadLimits,
}

/// The plan of a frame: the refocus plan (the first frame's, for all), and the anti-aliasing
/// plan when it is on (on the frame's own scene depth).
#[derive(Debug, Clone)]
pub struct FramePlan {
    pub plan: RefocusPlan,
    pub antialias: Option<AntialiasPlan>,
    /// A focus surface on this frame's depth (several planes, a slab, all in focus).
    pub surface: Option<SurfacePlan>,
}

/// Renders every frame of `job` (see the module docs). `plan_frame` is called with each frame
/// and the plan of the frame before (`None` for the first, which must get a plan): it returns
/// the frame's plan, or `None` to keep the one before. `progress` is called after each frame
/// is rendered. Returns the report and the first frame's plan.
pub fn render_frames(
    ctx: Arc<GpuContext>,
    job: &BatchJob,
    mut plan_frame: impl FnMut(&LightField, Option<&FramePlan>) -> Result<Option<FramePlan>>,
    mut progress: impl FnMut(u64),
) -> Result<(BatchReport, FramePlan)> {
    let t0 = Instant::now();
    if job.frames.is_empty() {
        return Err(Error::Invalid("no frames to render".into()));
    }
    let loader = FrameLoader::new(job.sequence.clone(), job.limits.clone(), 1);
    loader.request_all(job.frames.iter().copied());

    // The writer: encodes and writes while the next frame renders.
    let (to_writer, writer_rx) = sync_channel::<(u64, PathBuf, GpuImage)>(1);
    let (from_writer, written) = channel::<Result<(u64, f64, usize)>>();
    let writer = std::thread::Builder::new()
        .name("tiltfield frame writer".into())
        .spawn(move || {
            for (frame, path, image) in writer_rx {
                let t = Instant::now();
                let r =
                    save_image(&image, &path).map(|u| (frame, t.elapsed().as_secs_f64() * 1e3, u));
                let failed = r.is_err();
                if from_writer.send(r).is_err() || failed {
                    return;
                }
            }
        })
        .map_err(|e| Error::Invalid(format!("cannot start the writer thread: {e}")))?;

    let mut times: Vec<FrameTimes> = Vec::with_capacity(job.frames.len());
    let mut renderer: Option<HeadlessRenderer> = None;
    let mut first: Option<FramePlan> = None;
    let mut plan: Option<FramePlan> = None;
    let mut done: Vec<(u64, f64, usize)> = Vec::new();
    let result: Result<()> = (|| {
        for &expected in job.frames {
            let tw = Instant::now();
            let decoded = loader.recv().ok_or_else(|| {
                Error::Invalid(format!("the frame decoder stopped before frame {expected}"))
            })?;
            let wait_ms = tw.elapsed().as_secs_f64() * 1e3;
            if decoded.frame != expected {
                return Err(Error::Invalid(format!(
                    "the frame decoder delivered frame {} instead of {expected}",
                    decoded.frame
                )));
            }
            let lf = decoded.light_field?;
            let tp = Instant::now();
            match plan_frame(&lf, plan.as_ref())? {
                Some(p) => plan = Some(p),
                None if plan.is_none() => {
                    return Err(Error::Invalid("the first frame got no plan".into()))
                }
                None => {}
            }
            if first.is_none() {
                first = plan.clone();
            }
            let plan_ms = tp.elapsed().as_secs_f64() * 1e3;
            let tu = Instant::now();
            match renderer.as_mut() {
                None => {
                    renderer = Some(HeadlessRenderer::with_context(
                        Arc::clone(&ctx),
                        &lf,
                        job.storage,
                    )?);
                }
                Some(r) => r.replace_views(&lf)?,
            }
            let upload_ms = tu.elapsed().as_secs_f64() * 1e3;
            drop(lf);
            let (Some(r), Some(p)) = (renderer.as_mut(), plan.as_ref()) else {
                return Err(Error::Internal("no renderer".into()));
            };
            let tr = Instant::now();
            let (image, gpu) = match (&p.surface, &p.antialias) {
                (Some(s), aa) => r.render_surface(&p.plan, aa.as_ref(), s, &job.settings)?,
                (None, Some(aa)) => r.render_antialiased(aa, &job.settings)?,
                (None, None) => r.render(&p.plan, &job.settings)?,
            };
            let render_ms = tr.elapsed().as_secs_f64() * 1e3;
            times.push(FrameTimes {
                frame: expected,
                decode_ms: decoded.decode_ms,
                wait_ms,
                plan_ms,
                upload_ms,
                render_ms,
                gpu_refocus_ms: gpu.map(|g| g.refocus_ms),
                encode_ms: 0.0,
                uncovered_pixels: 0,
            });
            // A failed write stops the batch at once rather than after every frame.
            for r in written.try_iter() {
                done.push(r?);
            }
            to_writer
                .send((expected, job.output.path(expected), image))
                .map_err(|_| Error::Invalid("the frame writer stopped".into()))?;
            progress(expected);
        }
        Ok(())
    })();
    drop(to_writer);
    let joined = writer.join();
    drop(loader);
    // Collect what was written (also after a failure, to report the writer's own error).
    for r in written.try_iter() {
        done.push(r?);
    }
    for (frame, encode_ms, uncovered) in done {
        if let Some(t) = times.iter_mut().find(|t| t.frame == frame) {
            t.encode_ms = encode_ms;
            t.uncovered_pixels = uncovered;
        }
    }
    result?;
    if joined.is_err() {
        return Err(Error::Invalid("the frame writer panicked".into()));
    }
    let wall_s = t0.elapsed().as_secs_f64();
    let report = BatchReport {
        frames_per_second: times.len() as f64 / wall_s,
        frames: times,
        wall_s,
        device: ctx.info.name.clone(),
    };
    drop(renderer);
    let first = first.ok_or_else(|| Error::Invalid("no frame was rendered".into()))?;
    Ok((report, first))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_patterns_put_the_frame_number_in() {
        let p = OutputPattern::parse("out/f_{frame}.png").unwrap();
        assert_eq!(p.path(7), PathBuf::from("out/f_7.png"));
        let p = OutputPattern::parse("{frame:05}/refocus.exr").unwrap();
        assert_eq!(p.path(42), PathBuf::from("00042/refocus.exr"));
        for bad in [
            "out.png",
            "out_{frame.png",
            "out_{frame:5}.png",
            "{frame}_{frame}.png",
        ] {
            let e = OutputPattern::parse(bad).unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains("{frame}"), "{e}");
        }
    }
}
