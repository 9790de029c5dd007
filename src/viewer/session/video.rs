//! Video playback: the frame sequence, the background decoder, the frame shown and the frame
//! wanted. Stepping (`,` `.`) asks for one frame and stops playing; playing (Space) keeps two
//! frames decoded ahead of the one shown, wrapping to the first at the end. A decoded frame is
//! shown only while it is still wanted (a newer one while playing, the asked-for one while
//! paused); the session turns it into [`super::super::state::Action::ShowFrame`].

use crate::lightfield::video::{DecodedFrame, FrameLoader, FrameSequence};
use crate::lightfield::LoadLimits;

/// Frames decoded ahead of the one shown while playing.
const AHEAD: usize = 2;

/// What a video key asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VideoStep {
    Previous,
    Next,
    PlayPause,
}

/// Video playback state.
pub struct Video {
    pub sequence: FrameSequence,
    loader: FrameLoader,
    /// The frame whose views are on the GPU.
    pub shown: u64,
    /// The frame asked for (equals `shown` once it arrived).
    pub wanted: u64,
    pub playing: bool,
}

impl Video {
    /// Playback of `sequence`, paused at `frame` (already on the GPU).
    pub fn new(sequence: FrameSequence, frame: u64) -> Self {
        Video {
            loader: FrameLoader::new(sequence.clone(), LoadLimits::default(), AHEAD),
            sequence,
            shown: frame,
            wanted: frame,
            playing: false,
        }
    }

    /// Applies a video key: a step asks for that frame (and pauses), play/pause toggles.
    pub fn step(&mut self, step: VideoStep) {
        let target = match step {
            VideoStep::Previous => self.sequence.previous(self.wanted),
            VideoStep::Next => self.sequence.next(self.wanted),
            VideoStep::PlayPause => {
                self.playing = !self.playing;
                None
            }
        };
        if let Some(f) = target {
            self.playing = false;
            self.wanted = f;
            self.loader.replace_requests([f]);
        } else if self.playing {
            self.request_ahead();
        }
    }

    /// The next decoded frame that is still wanted, if one has arrived (older ones are
    /// dropped).
    pub fn receive(&mut self) -> Option<DecodedFrame> {
        while let Some(decoded) = self.loader.try_recv() {
            let keep = if self.playing {
                decoded.frame > self.shown
            } else {
                decoded.frame == self.wanted
            };
            if keep {
                return Some(decoded);
            }
        }
        None
    }

    /// `frame` is on the GPU now.
    pub fn shown(&mut self, frame: u64) {
        self.shown = frame;
        self.wanted = frame;
    }

    /// Keeps the decoder busy while playing.
    pub fn keep_playing(&mut self) {
        if self.playing && self.loader.outstanding() == 0 {
            self.request_ahead();
        }
    }

    /// Nothing asked for is still on its way (`wait-converged` waits for this).
    pub fn settled(&self) -> bool {
        self.playing || (self.shown == self.wanted && self.loader.outstanding() == 0)
    }

    /// A frame is being decoded or will be soon: the idle loop looks for it.
    pub fn decoding(&self) -> bool {
        self.playing || self.loader.outstanding() > 0
    }

    /// Asks for the next few frames after the one shown (wrapping to the first at the end).
    fn request_ahead(&mut self) {
        let mut f = self.shown;
        let mut next = Vec::new();
        for _ in 0..AHEAD {
            f = self
                .sequence
                .next(f)
                .unwrap_or_else(|| self.sequence.first());
            next.push(f);
        }
        self.loader.replace_requests(next);
    }
}
