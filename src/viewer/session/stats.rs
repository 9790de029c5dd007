//! Frame statistics of a session: frame rates from the wall time between presented frames
//! (what the user saw: a slow frame counts with all its time; only a gap in which the viewer
//! waited with nothing to render — converged, a script's pause — does not), GPU times of
//! interactive frames, and per refinement the GPU and wall time from a full-size restart to
//! full quality.

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
    /// Frames presented per wall second while rendering (idle waits excluded).
    pub fps: Option<f64>,
}

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
    /// The viewer waited with nothing to render since the last frame.
    idled: bool,
    /// Frames whose gap to the one before counts (the frame rates' numerators).
    counted_frames: usize,
    /// GPU times of frames recorded while interacting.
    pub interactive_ms: Vec<f64>,
    /// Per refinement that reached full quality: its GPU and wall milliseconds.
    pub full_gpu_ms: Vec<f64>,
    pub full_wall_ms: Vec<f64>,
}

impl Stats {
    /// The viewer is about to wait with nothing to render: the gap to the next frame is
    /// idle time, not frame time.
    pub fn idle(&mut self) {
        self.idled = true;
    }

    /// A frame was presented now.
    pub fn presented(&mut self, interactive: bool) {
        self.presented_at(interactive, Instant::now());
    }

    /// A frame was presented at `now`.
    fn presented_at(&mut self, interactive: bool, now: Instant) {
        if let Some(prev) = self.last_frame_at {
            let dt = now - prev;
            if !std::mem::take(&mut self.idled) {
                self.counted_frames += 1;
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
            fps: (self.counted_frames > 0)
                .then(|| self.counted_frames as f64 / self.render_time.as_secs_f64().max(1e-9)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slow_frames_count_with_their_time_and_idle_waits_do_not() {
        let t0 = Instant::now();
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        let mut s = Stats::default();
        s.presented_at(false, at(0));
        // Two slow frames of 0.6 s (full-size anti-aliased frames): 1.67 frames per second,
        // not the frame count over the fast frames' time alone.
        s.presented_at(false, at(600));
        s.presented_at(false, at(1200));
        // Idle for five seconds, then a frame: the wait is not frame time.
        s.idle();
        s.presented_at(true, at(6200));
        // Then interaction at 20 frames per second.
        for k in 1..=4 {
            s.presented_at(true, at(6200 + 50 * k));
        }
        let r = s.report();
        assert_eq!(r.count, 8);
        let fps = r.fps.unwrap();
        assert!((fps - 6.0 / 1.4).abs() < 1e-9, "{fps}");
        assert!((r.interactive_fps.unwrap() - 20.0).abs() < 1e-9);
    }
}
