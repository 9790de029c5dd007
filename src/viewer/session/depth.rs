//! The light field's depth in a session: the reference view's depth map and the point cloud
//! made from it, thinned by a stride to at most [`MAX_CLOUD_POINTS`] ([`DepthCache`]). Clicks
//! on the refocus image become depth-view pixels here, and clicks in the scene panel become
//! cloud points.
//!
//! A light field without its own map gets an estimate made on a background thread
//! ([`DepthJob`]) while the window already shows the refocus image (a video without depth: one
//! per frame shown, the session discarding estimates of frames no longer shown): the job has
//! its own GPU context (instance, device and queue), so its submissions never meet the
//! window's and need no locking; the session reads its progress and installs the result when
//! it is done. A job still running when the viewer quits is abandoned with the process (the
//! sweep cannot be cancelled; nothing is cached, `--json` reports no depth).

use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use glam::{DVec2, DVec3};
use indicatif::ProgressBar;

use super::super::orbit::{pick_point, OrbitCamera};
use crate::depth::{DepthOptions, DepthOrigin};
use crate::error::{Error, Result};
use crate::geometry::depth::ViewDepth;
use crate::gpu::{GpuContext, GpuOptions};
use crate::lightfield::LightField;
use crate::scene::PointCloud;

/// How often the estimate's progress is written to stderr at most.
pub const PROGRESS_PERIOD: Duration = Duration::from_secs(1);

/// Where the session's depth stands.
#[derive(Debug, Clone, PartialEq)]
pub enum DepthState {
    /// A depth map is loaded (the light field's own, or the estimate).
    Ready,
    /// Being estimated in the background: planes swept of all (0 of 0 while it starts).
    Estimating { done: u64, total: u64 },
    /// None, and none is coming: why.
    Unavailable(String),
}

impl DepthState {
    /// The status strip's field.
    pub fn field(&self) -> Option<String> {
        match self {
            DepthState::Ready => None,
            // The sweep's planes, then the sub-plane fit, which reports no progress of its own.
            DepthState::Estimating { done, total } if *total > 0 && done >= total => {
                Some("depth: refining the estimate".into())
            }
            DepthState::Estimating { done, total } => {
                Some(format!("depth: estimating {done}/{total} planes"))
            }
            DepthState::Unavailable(_) => Some("no depth".into()),
        }
    }
}

/// What a finished [`DepthJob`] hands over: where the estimate came from (it is in the
/// origin) and the validation errors of the job's own GPU context.
pub struct EstimatedDepth {
    pub origin: DepthOrigin,
    pub validation_errors: usize,
}

/// Depth estimated on a background thread with its own GPU context (see the module docs).
pub struct DepthJob {
    handle: Option<JoinHandle<Result<EstimatedDepth>>>,
    progress: ProgressBar,
    started: Instant,
    /// When progress was last written to stderr, and what it was.
    reported: (Instant, u64),
}

impl DepthJob {
    /// Starts estimating the depth of `lf` (the default options and cache, as `render`) on a
    /// new GPU context made with `gpu` (headless: no window extensions).
    pub fn start(lf: Arc<LightField>, gpu: GpuOptions) -> Result<Self> {
        let progress = ProgressBar::hidden();
        let bar = progress.clone();
        let handle = std::thread::Builder::new()
            .name("depth estimate".into())
            .spawn(move || {
                let ctx = GpuContext::new(&gpu)?;
                let origin =
                    crate::jobs::depth::estimate_cached(&ctx, &lf, &DepthOptions::default(), &bar);
                // The session installs the estimate into its light field: this thread's
                // reference must be gone by then (installing would otherwise copy every view).
                drop(lf);
                let validation_errors = ctx.validation().errors();
                Ok(EstimatedDepth {
                    origin: origin?,
                    validation_errors,
                })
            })
            .map_err(|e| Error::Invalid(format!("cannot start the depth estimate: {e}")))?;
        let now = Instant::now();
        Ok(DepthJob {
            handle: Some(handle),
            progress,
            started: now,
            reported: (now, 0),
        })
    }

    /// Planes swept so far, of all.
    pub fn progress(&self) -> (u64, u64) {
        (
            self.progress.position(),
            self.progress.length().unwrap_or(0),
        )
    }

    /// The result once the thread is done (once); progress on stderr meanwhile, at most every
    /// [`PROGRESS_PERIOD`] and only when it moved (scripts and terminals see it alike).
    pub fn poll(&mut self, name: &str) -> Option<Result<EstimatedDepth>> {
        let handle = self.handle.as_ref()?;
        if !handle.is_finished() {
            let (done, total) = self.progress();
            if done != self.reported.1 && self.reported.0.elapsed() >= PROGRESS_PERIOD {
                eprintln!(
                    "estimating the depth of '{name}': {done}/{total} planes, {:.1} s",
                    self.started.elapsed().as_secs_f64()
                );
                self.reported = (Instant::now(), done);
            }
            return None;
        }
        let handle = self.handle.take()?;
        Some(handle.join().unwrap_or_else(|_| {
            Err(Error::Invalid(
                "the depth estimate's thread panicked".into(),
            ))
        }))
    }

    /// Seconds since the job started.
    pub fn elapsed_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }
}

/// Most cloud points drawn (a stride thins larger depth maps).
const MAX_CLOUD_POINTS: usize = 100_000;
/// Pick tolerance in the scene panel, pixels.
const PICK_TOLERANCE: f64 = 6.0;

/// The depth map and its point cloud, when the light field has depth.
pub struct DepthCache {
    pub depth: Option<ViewDepth>,
    pub cloud: Option<PointCloud>,
    /// Every stride-th depth pixel (per axis) is a cloud point.
    stride: u32,
    /// Whether depth is here, coming, or not to be had.
    pub state: DepthState,
}

impl DepthCache {
    /// The point cloud of `depth`, the depth map of `lf` (none for a light field without).
    pub fn new(lf: &LightField, depth: Option<ViewDepth>) -> Result<Self> {
        let stride = depth.as_ref().map_or(1, |d| {
            let pixels = d.width as usize * d.height as usize;
            ((pixels as f64 / MAX_CLOUD_POINTS as f64).sqrt().ceil() as u32).max(1)
        });
        let cloud = match &depth {
            Some(d) => Some(PointCloud::colours_only(
                d,
                &lf.views[d.view].image,
                stride,
            )?),
            None => None,
        };
        let state = if depth.is_some() {
            DepthState::Ready
        } else {
            DepthState::Unavailable(format!("light field '{}' has no depth map", lf.name))
        };
        Ok(DepthCache {
            depth,
            cloud,
            stride,
            state,
        })
    }

    /// Why there is no depth to click on (the panel shows it where the user clicked).
    /// The status strip's reading of the depth under refocus-image position `p` (full-size
    /// reference pixels): the depth there and where it came from, with an estimate's
    /// confidence; `None` while depth is coming or where there is none to read.
    pub fn reading(
        &self,
        lf: &LightField,
        reference: &crate::geometry::camera::Camera,
        p: DVec2,
        origin: Option<&DepthOrigin>,
    ) -> Option<String> {
        let depth = self.depth.as_ref()?;
        let d = self.depth_pixel(lf, reference, p).ok()?;
        let (x, y) = (d.x.round().max(0.0) as u32, d.y.round().max(0.0) as u32);
        let Some(z) = depth.depth(x, y) else {
            return Some("cursor: no depth here".into());
        };
        let source = match origin {
            Some(DepthOrigin::Estimated { estimate, .. }) => {
                let i = (y * estimate.width + x) as usize;
                match estimate.confidence.get(i) {
                    Some(c) => format!("estimate, confidence {c:.3}"),
                    None => "estimate".into(),
                }
            }
            _ => "given".into(),
        };
        Some(format!("cursor: z {z:.3} ({source})"))
    }

    fn missing(&self, lf: &LightField, what: &str) -> String {
        match &self.state {
            DepthState::Estimating { done, total } => format!(
                "depth is still being estimated ({done}/{total} planes): {what} work once it is \
                 ready"
            ),
            DepthState::Unavailable(why) => {
                format!("{why}: {what} need depth (keys and scroll work)")
            }
            DepthState::Ready => format!("light field '{}' has no depth map", lf.name),
        }
    }

    /// The centre of the cloud's bounding box.
    pub fn centre(&self) -> Option<DVec3> {
        self.cloud
            .as_ref()
            .and_then(|c| c.bounds)
            .map(|b| b.centre())
    }

    /// The eight corners of the cloud's bounding box (none without a cloud).
    pub fn corners(&self) -> Vec<DVec3> {
        let Some(b) = self.cloud.as_ref().and_then(|c| c.bounds) else {
            return Vec::new();
        };
        (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { b.min.x } else { b.max.x },
                    if i & 2 == 0 { b.min.y } else { b.max.y },
                    if i & 4 == 0 { b.min.z } else { b.max.z },
                )
            })
            .collect()
    }

    /// The diagonal of the cloud's bounding box.
    pub fn diagonal(&self) -> Option<f64> {
        self.cloud
            .as_ref()
            .and_then(|c| c.bounds)
            .map(|b| b.diagonal())
    }

    /// Cloud points large enough to close the gaps between neighbouring depth pixels at the
    /// initial zoom: the panel's pixels per (thinned) depth pixel, with some overlap.
    pub fn point_size(&self, panel_height: f64) -> f32 {
        let Some(d) = &self.depth else { return 2.0 };
        let per_px = panel_height / d.height.max(1) as f64 * self.stride as f64;
        (1.3 * per_px).clamp(2.0, 8.0) as f32
    }

    /// The depth-view pixel under refocus-image position `p` (full-size pixels of the current
    /// reference view): the position itself when the reference camera is the depth view's,
    /// else the pixel of the cloud point seen there.
    pub fn depth_pixel(
        &self,
        lf: &LightField,
        reference: &crate::geometry::camera::Camera,
        p: DVec2,
    ) -> std::result::Result<DVec2, String> {
        let depth = self
            .depth
            .as_ref()
            .ok_or_else(|| self.missing(lf, "clicks"))?;
        if *reference == depth.camera {
            return Ok(p);
        }
        let cloud = self.cloud.as_ref().ok_or("no point cloud to pick from")?;
        let i = pick_point(reference, p, cloud.points.iter().map(|c| c.position), 1.5)
            .ok_or("no depth under the cursor from this viewpoint")?;
        let (x, y) = cloud.points[i].pixel;
        Ok(DVec2::new(x as f64, y as f64))
    }

    /// The world point of the cloud under pixel `p` of a scene panel of `size` seen by `orbit`.
    pub fn scene_pick(
        &self,
        lf: &LightField,
        orbit: &OrbitCamera,
        size: (u32, u32),
        p: DVec2,
    ) -> std::result::Result<DVec3, String> {
        let cloud = self
            .cloud
            .as_ref()
            .ok_or_else(|| self.missing(lf, "scene picks"))?;
        let cam = orbit.camera(size);
        let i = pick_point(
            &cam,
            p,
            cloud.points.iter().map(|c| c.position),
            PICK_TOLERANCE,
        )
        .ok_or("no cloud point within a few pixels of the cursor")?;
        Ok(cloud.points[i].position)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_strip_names_the_estimate_s_stage() {
        let f = |done, total| DepthState::Estimating { done, total }.field().unwrap();
        assert_eq!(f(0, 0), "depth: estimating 0/0 planes");
        assert_eq!(f(12, 51), "depth: estimating 12/51 planes");
        assert_eq!(f(51, 51), "depth: refining the estimate");
        assert_eq!(DepthState::Ready.field(), None);
        assert_eq!(
            DepthState::Unavailable("x".into()).field().as_deref(),
            Some("no depth")
        );
    }
}
