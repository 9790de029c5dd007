//! Frame statistics of a session: frame rates from the wall time between presented frames
//! (gaps of half a second or more — idle, waits — do not count), GPU times of interactive
//! frames, and per refinement the GPU and wall time from a full-size restart to full quality.

use std::time::{Duration, Instant};

use crate::gpu::timing::median;

/// Frame statistics of a session.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct FrameStats {
    /// Frames presented.
    pub count: usize,
    /// Median GPU time of frames rendered while input was arriving.
    pub interactive_gpu_ms_median: Option<f64>,
    /// Frames per second while input was arriving (wall clock).
    pub interactive_fps: Option<f64>,
    /// Median over refinements of the GPU time from a full-size restart to full quality.
    pub full_quality_gpu_ms_median: Option<f64>,
    /// Median over refinements of the wall time from a full-size restart to full quality.
    pub full_quality_wall_ms_median: Option<f64>,
    /// Frames per second over all rendering (wall clock, idle time excluded).
    pub fps: Option<f64>,
}

/// Longest gap between frames that still counts as rendering.
const MAX_FRAME_GAP: Duration = Duration::from_millis(500);

/// What the session has measured so far.
#[derive(Debug, Default)]
pub struct Stats {
    /// Frames presented.
    pub frames: usize,
    /// Smoothed frames per second (the status line's).
    pub fps: f64,
    render_time: Duration,
    interactive_frames: usize,
    interactive_time: Duration,
    last_frame_at: Option<Instant>,
    /// GPU times of frames recorded while interacting.
    pub interactive_ms: Vec<f64>,
    /// Per refinement that reached full quality: its GPU and wall milliseconds.
    pub full_gpu_ms: Vec<f64>,
    pub full_wall_ms: Vec<f64>,
}

impl Stats {
    /// A frame was presented now.
    pub fn presented(&mut self, interactive: bool) {
        let now = Instant::now();
        if let Some(prev) = self.last_frame_at {
            let dt = now - prev;
            if dt < MAX_FRAME_GAP {
                self.render_time += dt;
                self.fps = 0.8 * self.fps + 0.2 / dt.as_secs_f64().max(1e-6);
                if interactive {
                    self.interactive_frames += 1;
                    self.interactive_time += dt;
                }
            }
        }
        self.last_frame_at = Some(now);
        self.frames += 1;
    }

    pub fn report(&self) -> FrameStats {
        FrameStats {
            count: self.frames,
            interactive_gpu_ms_median: median(&self.interactive_ms),
            interactive_fps: (self.interactive_frames > 0).then(|| {
                self.interactive_frames as f64 / self.interactive_time.as_secs_f64().max(1e-9)
            }),
            full_quality_gpu_ms_median: median(&self.full_gpu_ms),
            full_quality_wall_ms_median: median(&self.full_wall_ms),
            fps: (self.frames > 0)
                .then(|| self.frames as f64 / self.render_time.as_secs_f64().max(1e-9)),
        }
    }
}
