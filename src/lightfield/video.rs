//! Camera-array video as a sequence of light fields, and decoding frames in the background.
//!
//! A [`FrameSequence`] knows a video's frame numbers, its rig and its view size without
//! decoding anything, and loads frame k as a [`LightField`]. It is cheap to clone and `Send +
//! Sync`, and contains no GPU objects, so frames can be decoded on any thread. Every frame of a
//! video has the same cameras, grid and view size, so a renderer set up for one frame can take
//! the next one's views in place (`HeadlessRenderer::replace_views`).
//!
//! A [`FrameLoader`] owns one background thread that decodes requested frames in request order
//! (each frame's views in parallel on rayon's pool) and hands them over through a bounded
//! channel, so at most `ahead` decoded frames wait beyond the one being decoded. A batch render
//! requests a whole range up front ([`FrameLoader::request_all`]); an interactive viewer
//! requests the next frame while showing the current one and drops stale requests with
//! [`FrameLoader::replace_requests`]. Frame numbers are the numbers in the file names.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::mpsc::{sync_channel, Receiver, TryRecvError};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use super::images::LoadLimits;
use super::technicolor::{describe_frames, is_technicolor, TechnicolorVideo, PARAMETERS_NAME};
use super::{GridSize, LightField};
use crate::error::{Error, Result};
use crate::geometry::camera::Camera;

/// A camera-array video: frame numbers, rig and view size; loads frames as light fields.
#[derive(Debug, Clone)]
pub struct FrameSequence {
    video: Arc<TechnicolorVideo>,
}

impl FrameSequence {
    /// True when `path` is a video this module reads (a folder with `cameras_parameters.txt`).
    pub fn is_video(path: &Path) -> bool {
        is_technicolor(path)
    }

    /// Opens the video at `path`: reads the calibration and lists the frames (no decoding).
    pub fn open(path: &Path) -> Result<Self> {
        if !is_technicolor(path) {
            return Err(Error::Invalid(format!(
                "{} is not a video: camera-array videos are folders with {PARAMETERS_NAME} (the \
                 Technicolor layout)",
                path.display()
            )));
        }
        Ok(FrameSequence {
            video: Arc::new(TechnicolorVideo::open(path)?),
        })
    }

    /// The scene name from the file names.
    pub fn name(&self) -> &str {
        &self.video.scene
    }

    /// The layout details (calibration, folders).
    pub fn technicolor(&self) -> &TechnicolorVideo {
        &self.video
    }

    /// Frame numbers, increasing.
    pub fn frames(&self) -> &[u64] {
        &self.video.frame_numbers
    }

    /// The first frame's number.
    pub fn first(&self) -> u64 {
        self.frames().first().copied().unwrap_or(0)
    }

    /// The frame after `frame` (`None` at the end or for an unknown frame).
    pub fn next(&self, frame: u64) -> Option<u64> {
        let i = self.frames().binary_search(&frame).ok()?;
        self.frames().get(i + 1).copied()
    }

    /// The frame before `frame` (`None` at the start or for an unknown frame).
    pub fn previous(&self, frame: u64) -> Option<u64> {
        let i = self.frames().binary_search(&frame).ok()?;
        i.checked_sub(1).map(|i| self.frames()[i])
    }

    /// The rig grid (the same for every frame).
    pub fn grid(&self) -> GridSize {
        self.video.calibration.grid
    }

    /// The cameras in row-major grid order (the same for every frame).
    pub fn cameras(&self) -> &[Camera] {
        &self.video.calibration.cameras
    }

    /// View width and height.
    pub fn view_size(&self) -> (u32, u32) {
        (self.video.width, self.video.height)
    }

    /// Checks that frame `frame` exists and has every camera (an error naming it otherwise).
    pub fn check_frame(&self, frame: u64) -> Result<()> {
        self.video.check_frame(frame)
    }

    /// Loads frame `frame` with a progress bar on stderr.
    pub fn load(&self, frame: u64) -> Result<LightField> {
        self.load_within(frame, &LoadLimits::default())
    }

    /// [`Self::load`], refusing before decoding a frame beyond `limits`.
    pub fn load_within(&self, frame: u64, limits: &LoadLimits) -> Result<LightField> {
        let lf = self.video.load_frame(frame, limits, true)?;
        lf.validate()?;
        Ok(lf)
    }

    /// [`Self::load_within`] without a progress bar, for background threads.
    pub fn load_quiet(&self, frame: u64, limits: &LoadLimits) -> Result<LightField> {
        let lf = self.video.load_frame(frame, limits, false)?;
        lf.validate()?;
        Ok(lf)
    }

    /// The frames of `range` in order, each checked to exist and be complete. An empty
    /// selection is an error naming the video's frames.
    pub fn select(&self, range: FrameRange) -> Result<Vec<u64>> {
        let all = self.frames();
        let lo = range.first.unwrap_or(0);
        let hi = range.last.unwrap_or(u64::MAX);
        if lo > hi {
            return Err(Error::Invalid(format!(
                "the frame range {range} is empty: its first frame comes after its last"
            )));
        }
        let chosen: Vec<u64> = all
            .iter()
            .copied()
            .filter(|f| (lo..=hi).contains(f))
            .collect();
        if chosen.is_empty() {
            return Err(Error::Invalid(format!(
                "{}: no frames in {range}; the video has frames {}",
                self.video.folder.display(),
                describe_frames(all)
            )));
        }
        // Inside a closed range every number must be a frame: a gap means missing files.
        let expected_first = range.first.unwrap_or(chosen[0]);
        let expected_last = range.last.unwrap_or(chosen[chosen.len() - 1]);
        // Saturating: frame numbers may sit at the top of u64 (they come from file names).
        let scan_last = expected_last.min(expected_first.saturating_add(1_000_000));
        let missing: Vec<u64> = (expected_first..=scan_last)
            .filter(|f| chosen.binary_search(f).is_err())
            .take(10)
            .collect();
        if !missing.is_empty() {
            return Err(Error::Invalid(format!(
                "{}: {range} asks for frame{} {} that the video does not have (it has frames {})",
                self.video.folder.display(),
                if missing.len() == 1 { "" } else { "s" },
                missing
                    .iter()
                    .map(|f| f.to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
                describe_frames(all)
            )));
        }
        for &f in &chosen {
            self.check_frame(f)?;
        }
        Ok(chosen)
    }
}

/// An inclusive range of frame numbers: `A..B`, `A..` (to the last frame), `..B` (from the
/// first) or a single frame `N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameRange {
    pub first: Option<u64>,
    pub last: Option<u64>,
}

impl std::fmt::Display for FrameRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let show = |x: Option<u64>| x.map(|v| v.to_string()).unwrap_or_default();
        if self.first.is_some() && self.first == self.last {
            return write!(f, "frame {}", show(self.first));
        }
        write!(f, "frames {}..{}", show(self.first), show(self.last))
    }
}

impl std::str::FromStr for FrameRange {
    type Err = Error;
    fn from_str(text: &str) -> Result<Self> {
        let bad = || {
            Error::Invalid(format!(
                "--frames '{text}': expected A..B (frames A to B inclusive), A.., ..B or N, with \
                 frame numbers as in the file names"
            ))
        };
        let num = |s: &str| -> Result<Option<u64>> {
            let s = s.trim();
            if s.is_empty() {
                Ok(None)
            } else {
                s.parse().map(Some).map_err(|_| bad())
            }
        };
        match text.split_once("..") {
            Some((a, b)) => Ok(FrameRange {
                first: num(a)?,
                last: num(b.strip_prefix('=').unwrap_or(b))?,
            }),
            None => {
                let n = num(text)?.ok_or_else(bad)?;
                Ok(FrameRange {
                    first: Some(n),
                    last: Some(n),
                })
            }
        }
    }
}

/// A frame decoded by a [`FrameLoader`].
#[derive(Debug)]
pub struct DecodedFrame {
    pub frame: u64,
    pub light_field: Result<LightField>,
    /// Wall time of decoding (and undistorting) the frame, milliseconds.
    pub decode_ms: f64,
}

struct LoaderState {
    queue: VecDeque<u64>,
    /// Requested and not yet received (queued, decoding, or waiting in the channel).
    outstanding: usize,
    stop: bool,
}

type Shared = Arc<(Mutex<LoaderState>, Condvar)>;

/// Decodes requested frames of a [`FrameSequence`] on a background thread (see the module
/// docs). Dropping it stops the thread after the frame it is decoding.
pub struct FrameLoader {
    shared: Shared,
    results: Option<Receiver<DecodedFrame>>,
    worker: Option<JoinHandle<()>>,
}

impl FrameLoader {
    /// Starts the decoding thread. At most `ahead` decoded frames wait to be received (0: the
    /// thread finishes a frame and waits until it is taken).
    pub fn new(sequence: FrameSequence, limits: LoadLimits, ahead: usize) -> Self {
        let shared: Shared = Arc::new((
            Mutex::new(LoaderState {
                queue: VecDeque::new(),
                outstanding: 0,
                stop: false,
            }),
            Condvar::new(),
        ));
        let (tx, rx) = sync_channel(ahead);
        let state = Arc::clone(&shared);
        let worker = std::thread::Builder::new()
            .name("tiltfield frame decoder".into())
            .spawn(move || loop {
                let frame = {
                    let (lock, wake) = &*state;
                    let Ok(mut s) = lock.lock() else { return };
                    loop {
                        if s.stop {
                            return;
                        }
                        if let Some(f) = s.queue.pop_front() {
                            break f;
                        }
                        s = match wake.wait(s) {
                            Ok(s) => s,
                            Err(_) => return,
                        };
                    }
                };
                let t0 = Instant::now();
                let light_field = sequence.load_quiet(frame, &limits);
                let decoded = DecodedFrame {
                    frame,
                    light_field,
                    decode_ms: t0.elapsed().as_secs_f64() * 1e3,
                };
                if tx.send(decoded).is_err() {
                    return;
                }
            })
            .ok();
        FrameLoader {
            shared,
            results: Some(rx),
            worker,
        }
    }

    fn with_state<T>(&self, f: impl FnOnce(&mut LoaderState) -> T) -> Option<T> {
        let (lock, wake) = &*self.shared;
        let mut s = lock.lock().ok()?;
        let r = f(&mut s);
        wake.notify_all();
        Some(r)
    }

    /// Queues `frame` for decoding after the frames already requested.
    pub fn request(&self, frame: u64) {
        self.request_all([frame]);
    }

    /// Queues `frames` in order.
    pub fn request_all(&self, frames: impl IntoIterator<Item = u64>) {
        let frames: Vec<u64> = frames.into_iter().collect();
        self.with_state(|s| {
            s.outstanding += frames.len();
            s.queue.extend(frames);
        });
    }

    /// Drops the requests whose decoding has not started and queues `frames` instead (a viewer
    /// that jumped elsewhere). Frames already decoded or being decoded are still delivered.
    pub fn replace_requests(&self, frames: impl IntoIterator<Item = u64>) {
        let frames: Vec<u64> = frames.into_iter().collect();
        self.with_state(|s| {
            s.outstanding -= s.queue.len();
            s.queue.clear();
            s.outstanding += frames.len();
            s.queue.extend(frames);
        });
    }

    /// Frames requested and not yet received.
    pub fn outstanding(&self) -> usize {
        self.with_state(|s| s.outstanding).unwrap_or(0)
    }

    fn received(&self) {
        self.with_state(|s| s.outstanding = s.outstanding.saturating_sub(1));
    }

    /// Waits for the next decoded frame, in request order. `None` when nothing is outstanding
    /// (so it never waits forever) or the thread is gone.
    pub fn recv(&self) -> Option<DecodedFrame> {
        if self.outstanding() == 0 {
            return None;
        }
        let frame = self.results.as_ref()?.recv().ok()?;
        self.received();
        Some(frame)
    }

    /// The next decoded frame if one is ready (never waits).
    pub fn try_recv(&self) -> Option<DecodedFrame> {
        match self.results.as_ref()?.try_recv() {
            Ok(frame) => {
                self.received();
                Some(frame)
            }
            Err(TryRecvError::Empty | TryRecvError::Disconnected) => None,
        }
    }
}

impl Drop for FrameLoader {
    fn drop(&mut self) {
        self.with_state(|s| {
            s.stop = true;
            s.queue.clear();
        });
        // Dropping the receiver wakes a thread blocked on a full channel.
        self.results.take();
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges_parse() {
        let r = |s: &str| s.parse::<FrameRange>().unwrap();
        assert_eq!(
            r("3..7"),
            FrameRange {
                first: Some(3),
                last: Some(7)
            }
        );
        assert_eq!(
            r("3..=7"),
            FrameRange {
                first: Some(3),
                last: Some(7)
            }
        );
        assert_eq!(
            r("10.."),
            FrameRange {
                first: Some(10),
                last: None
            }
        );
        assert_eq!(
            r("..4"),
            FrameRange {
                first: None,
                last: Some(4)
            }
        );
        assert_eq!(
            r("5"),
            FrameRange {
                first: Some(5),
                last: Some(5)
            }
        );
        for bad in ["", "a..b", "1..2..3", "-1..4", ".."] {
            let parsed = bad.parse::<FrameRange>();
            // ".." parses as the whole video; the others are errors naming the input.
            if bad == ".." {
                assert_eq!(
                    parsed.unwrap(),
                    FrameRange {
                        first: None,
                        last: None
                    }
                );
            } else {
                let e = parsed.unwrap_err().to_string();
                assert!(e.contains(&format!("'{bad}'")), "{e}");
            }
        }
    }

    #[test]
    fn frame_sequences_are_send_and_sync() {
        fn check<T: Send + Sync>() {}
        check::<FrameSequence>();
        check::<DecodedFrame>();
        fn check_send<T: Send>() {}
        check_send::<FrameLoader>();
    }
}
