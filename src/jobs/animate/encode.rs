//! Writing an animation's frames: an animated PNG (lossless, the exact frames), a GIF (256
//! colours a frame) or an H.264 MP4 through `ffmpeg`. Frames are encoded as they are rendered
//! ([`write`] hands the producer a sink), and the file appears only once it is complete
//! ([`crate::io::write_bytes`]: a temporary file renamed into place).

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use image::RgbaImage;

use crate::error::{Error, Result};

/// Frame rates an animation may have: slower than 0.1 frames/s is a slide show, and no
/// display shows more than 120.
pub const FPS_RANGE: (f64, f64) = (0.1, 120.0);

/// GIF frame delays are whole centiseconds and browsers play delays under 2 cs as 10 cs, so a
/// GIF faster than 50 frames/s would play slower than asked.
pub const MAX_GIF_FPS: f64 = 50.0;

/// NeuQuant's sampling factor for GIF palettes (1: every pixel, slowest; 10: every tenth, the
/// gif crate's recommended balance): on backgammon it costs well under 0.5 dB of PSNR
/// against 1 and is several times faster.
const GIF_SPEED: i32 = 10;

/// The file formats of an animation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Animated PNG: lossless RGBA, every frame exactly as rendered.
    Apng,
    /// GIF: a palette of 256 colours per frame (NeuQuant, no dithering), 1-bit transparency.
    Gif,
    /// MP4: H.264, yuv420p, even sides, through `ffmpeg`.
    Mp4,
}

impl Format {
    /// The format of `path` by its extension (case-insensitive): `.png` (or `.apng`), `.gif`,
    /// `.mp4`.
    pub fn from_path(path: &Path) -> Result<Self> {
        match crate::io::extension_lower(path).as_deref() {
            Some("png" | "apng") => Ok(Format::Apng),
            Some("gif") => Ok(Format::Gif),
            Some("mp4") => Ok(Format::Mp4),
            _ => Err(Error::Invalid(format!(
                "{}: an animation is written as .gif, .png (animated PNG) or .mp4 (H.264 \
                 through ffmpeg)",
                path.display()
            ))),
        }
    }

    /// How messages name the format.
    pub fn name(self) -> &'static str {
        match self {
            Format::Apng => "animated PNG",
            Format::Gif => "GIF",
            Format::Mp4 => "MP4",
        }
    }

    /// Checks `fps` for this format (see [`FPS_RANGE`] and [`MAX_GIF_FPS`]).
    pub fn check_fps(self, fps: f64) -> Result<()> {
        let (lo, hi) = FPS_RANGE;
        if !(fps.is_finite() && (lo..=hi).contains(&fps)) {
            return Err(Error::Invalid(format!(
                "--fps {fps}: give a frame rate from {lo} to {hi} frames per second"
            )));
        }
        if self == Format::Gif && fps > MAX_GIF_FPS {
            return Err(Error::Invalid(format!(
                "--fps {fps}: a GIF plays at most {MAX_GIF_FPS} frames per second (its delays \
                 are whole centiseconds, and browsers slow shorter ones down to 10 cs); write \
                 .png or .mp4 for more"
            )));
        }
        Ok(())
    }

    /// Checks before rendering that the format can be written here: an MP4 needs `ffmpeg`.
    pub fn check_available(self) -> Result<()> {
        match self {
            Format::Mp4 => ffmpeg().map(|_| ()),
            _ => Ok(()),
        }
    }
}

/// What [`write`] wrote.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Written {
    pub format: Format,
    pub bytes: u64,
    /// Frames written.
    pub frames: usize,
    /// The size written, when it differs from the frames' (an MP4's odd side cropped).
    pub cropped_to: Option<(u32, u32)>,
}

/// The frame sink [`write`] hands its producer: called with every frame in playback order.
pub type Sink<'a> = dyn FnMut(&RgbaImage) -> Result<()> + 'a;

/// Runs `produce`, encoding every frame it hands the sink as `format` at `fps` frames per
/// second (`frames`: how many it will hand, in playback order), and writes `path` once all are
/// encoded. The animation loops forever (GIF, animated PNG).
pub fn write<T>(
    format: Format,
    path: &Path,
    fps: f64,
    frames: usize,
    produce: impl FnOnce(&mut Sink) -> Result<T>,
) -> Result<(T, Written)> {
    format.check_fps(fps)?;
    let mut bytes = Vec::new();
    let (out, count, cropped_to) = match format {
        Format::Apng => apng(&mut bytes, fps, frames, produce)?,
        Format::Gif => gif(&mut bytes, fps, produce)?,
        Format::Mp4 => mp4(&mut bytes, fps, produce)?,
    };
    crate::io::write_bytes(path, format.name(), &bytes)?;
    Ok((
        out,
        Written {
            format,
            bytes: bytes.len() as u64,
            frames: count,
            cropped_to,
        },
    ))
}

type Encoded<T> = (T, usize, Option<(u32, u32)>);

fn encoding_error(format: Format, e: impl std::fmt::Display) -> Error {
    Error::Invalid(format!("cannot encode the {}: {e}", format.name()))
}

/// An animated PNG: RGBA, 8 bits, every frame whole (blend "source"), looping.
fn apng<T>(
    bytes: &mut Vec<u8>,
    fps: f64,
    frames: usize,
    produce: impl FnOnce(&mut Sink) -> Result<T>,
) -> Result<Encoded<T>> {
    let fail = |e: png::EncodingError| encoding_error(Format::Apng, e);
    let total =
        u32::try_from(frames).map_err(|_| encoding_error(Format::Apng, "too many frames"))?;
    // The writer is made on the first frame (its size); the buffer moves into it then.
    let mut target = Some(bytes);
    let mut writer: Option<png::Writer<&mut Vec<u8>>> = None;
    let mut count = 0;
    let mut size = (0, 0);
    let out = produce(&mut |frame: &RgbaImage| {
        if writer.is_none() {
            size = frame.dimensions();
            let buffer = target
                .take()
                .ok_or_else(|| encoding_error(Format::Apng, "no output buffer"))?;
            let mut encoder = png::Encoder::new(buffer, size.0, size.1);
            encoder.set_color(png::ColorType::Rgba);
            encoder.set_depth(png::BitDepth::Eight);
            // The frames are sRGB-encoded, as every PNG tiltfield writes.
            encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
            encoder.set_animated(total, 0).map_err(fail)?;
            let (numerator, denominator) = apng_delay(fps);
            encoder
                .set_frame_delay(numerator, denominator)
                .map_err(fail)?;
            writer = Some(encoder.write_header().map_err(fail)?);
        }
        if frame.dimensions() != size {
            return Err(encoding_error(Format::Apng, "frames of different sizes"));
        }
        let w = writer
            .as_mut()
            .ok_or_else(|| encoding_error(Format::Apng, "no writer"))?;
        w.write_image_data(frame.as_raw()).map_err(fail)?;
        count += 1;
        Ok(())
    })?;
    writer
        .ok_or_else(|| encoding_error(Format::Apng, "no frames"))?
        .finish()
        .map_err(fail)?;
    Ok((out, count, None))
}

/// An APNG frame delay of 1/`fps` s as the fraction of u16s it is stored as: exact for whole
/// frame rates, to the millisecond otherwise.
fn apng_delay(fps: f64) -> (u16, u16) {
    if fps.fract() == 0.0 && fps >= 1.0 {
        (1, fps as u16)
    } else {
        (
            (1000.0 / fps).round().clamp(1.0, u16::MAX as f64) as u16,
            1000,
        )
    }
}

/// A GIF: each frame quantised to its own 256-colour palette without dithering, looping.
fn gif<T>(
    bytes: &mut Vec<u8>,
    fps: f64,
    produce: impl FnOnce(&mut Sink) -> Result<T>,
) -> Result<Encoded<T>> {
    use image::codecs::gif::{GifEncoder, Repeat};
    use image::{Delay, Frame};
    let mut encoder = GifEncoder::new_with_speed(bytes, GIF_SPEED);
    encoder
        .set_repeat(Repeat::Infinite)
        .map_err(|e| encoding_error(Format::Gif, e))?;
    // GIF stores whole centiseconds: the nearest, at least the 2 cs browsers honour.
    let centis = (100.0 / fps).round().max(2.0) as u32;
    let delay = Delay::from_saturating_duration(Duration::from_millis(10 * centis as u64));
    let mut count = 0;
    let out = produce(&mut |frame: &RgbaImage| {
        encoder
            .encode_frame(Frame::from_parts(frame.clone(), 0, 0, delay))
            .map_err(|e| encoding_error(Format::Gif, e))?;
        count += 1;
        Ok(())
    })?;
    Ok((out, count, None))
}

/// The `ffmpeg` on PATH, or an error naming it.
pub fn ffmpeg() -> Result<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .map(|dir| dir.join("ffmpeg"))
        .find(|p| is_executable(p))
        .ok_or_else(|| {
            Error::Invalid(
                "writing .mp4 needs ffmpeg (it encodes the H.264), and no ffmpeg is on PATH; \
                 install it (Debian: apt-get install ffmpeg; tools/setup.sh does) or write .gif \
                 or .png (animated PNG)"
                    .into(),
            )
        })
}

fn is_executable(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

/// A folder of this process's own under the system's temporary folder, removed when dropped
/// (ffmpeg writes the MP4 there: an MP4 needs a seekable output to put its index first).
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> Result<Self> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let base = std::env::temp_dir();
        let mut last = None;
        for _ in 0..16 {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let dir = base.join(format!("tiltfield-animate-{}-{n}", std::process::id()));
            match std::fs::create_dir(&dir) {
                Ok(()) => return Ok(TempDir(dir)),
                Err(e) => last = Some(Error::io(&dir, e)),
            }
        }
        Err(last.unwrap_or_else(|| Error::Invalid("no temporary folder".into())))
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A running ffmpeg and the thread that collects its messages.
struct Ffmpeg {
    child: Child,
    stdin: Option<ChildStdin>,
    messages: std::thread::JoinHandle<String>,
}

impl Ffmpeg {
    fn start(program: &Path, (w, h): (u32, u32), fps: f64, out: &Path) -> Result<Self> {
        let mut child = Command::new(program)
            .args(["-hide_banner", "-loglevel", "error", "-nostats"])
            .args(["-f", "rawvideo", "-pix_fmt", "rgb24"])
            .args(["-s", &format!("{w}x{h}"), "-framerate", &fps.to_string()])
            .args(["-i", "pipe:0", "-an"])
            // H.264 in yuv420p: what every player and sharing site takes; CRF 18 looks
            // lossless at normal viewing.
            .args(["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "18"])
            .args(["-movflags", "+faststart", "-y"])
            .arg(out)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| Error::Invalid(format!("cannot start {}: {e}", program.display())))?;
        let stdin = child.stdin.take();
        let mut stderr = child.stderr.take();
        // Read its messages as they come, so a chatty ffmpeg never blocks on a full pipe.
        let messages = std::thread::spawn(move || {
            let mut text = String::new();
            if let Some(s) = stderr.as_mut() {
                let _ = s.read_to_string(&mut text);
            }
            text
        });
        Ok(Ffmpeg {
            child,
            stdin,
            messages,
        })
    }

    /// Closes its input and waits: an error with ffmpeg's own message when it failed.
    fn finish(mut self) -> Result<()> {
        drop(self.stdin.take());
        let status = self
            .child
            .wait()
            .map_err(|e| Error::Invalid(format!("ffmpeg: {e}")))?;
        let messages = self.messages.join().unwrap_or_default();
        if !status.success() {
            return Err(Error::Invalid(format!(
                "ffmpeg failed ({status}) encoding the MP4: {}",
                messages.trim()
            )));
        }
        Ok(())
    }
}

/// An MP4 through ffmpeg: H.264, yuv420p (whose chroma halves need even sides: an odd side
/// loses its last column or row), alpha composited over black.
fn mp4<T>(
    bytes: &mut Vec<u8>,
    fps: f64,
    produce: impl FnOnce(&mut Sink) -> Result<T>,
) -> Result<Encoded<T>> {
    let program = ffmpeg()?;
    let dir = TempDir::new()?;
    let out = dir.0.join("animation.mp4");
    let mut running: Option<Ffmpeg> = None;
    let mut size = (0, 0);
    let mut count = 0;
    let mut cropped_to = None;
    let produced = produce(&mut |frame: &RgbaImage| {
        let (w, h) = frame.dimensions();
        let even = (w & !1, h & !1);
        if running.is_none() {
            if even.0 == 0 || even.1 == 0 {
                return Err(Error::Invalid(format!(
                    "an MP4 needs frames of at least 2×2 pixels, got {w}×{h}"
                )));
            }
            if even != (w, h) {
                log::warn!(
                    "H.264 in yuv420p needs even sides: the MP4 is {}×{} (the frames' last {} \
                     cropped)",
                    even.0,
                    even.1,
                    match (even.0 != w, even.1 != h) {
                        (true, true) => "column and row",
                        (true, false) => "column",
                        _ => "row",
                    }
                );
                cropped_to = Some(even);
            }
            size = (w, h);
            running = Some(Ffmpeg::start(&program, even, fps, &out)?);
        }
        if (w, h) != size {
            return Err(encoding_error(Format::Mp4, "frames of different sizes"));
        }
        let mut rgb = Vec::with_capacity(even.0 as usize * even.1 as usize * 3);
        for y in 0..even.1 {
            for x in 0..even.0 {
                let [r, g, b, a] = frame.get_pixel(x, y).0;
                let over_black = |c: u8| ((c as u32 * a as u32 + 127) / 255) as u8;
                rgb.extend_from_slice(&[over_black(r), over_black(g), over_black(b)]);
            }
        }
        let f = running
            .as_mut()
            .ok_or_else(|| encoding_error(Format::Mp4, "ffmpeg is not running"))?;
        let written = f
            .stdin
            .as_mut()
            .map(|s| s.write_all(&rgb))
            .unwrap_or_else(|| Err(std::io::ErrorKind::BrokenPipe.into()));
        if let Err(e) = written {
            // ffmpeg stopped: its own message says why.
            if let Some(f) = running.take() {
                f.finish()?;
            }
            return Err(Error::Invalid(format!(
                "ffmpeg stopped reading frames: {e}"
            )));
        }
        count += 1;
        Ok(())
    });
    let out_value = match produced {
        Ok(v) => v,
        Err(e) => {
            if let Some(mut f) = running.take() {
                let _ = f.child.kill();
                let _ = f.child.wait();
            }
            return Err(e);
        }
    };
    running
        .ok_or_else(|| encoding_error(Format::Mp4, "no frames"))?
        .finish()?;
    *bytes = std::fs::read(&out).map_err(|e| Error::io(&out, e))?;
    Ok((out_value, count, cropped_to))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_follow_the_extension() {
        assert_eq!(Format::from_path(Path::new("a.GIF")).unwrap(), Format::Gif);
        assert_eq!(Format::from_path(Path::new("a.png")).unwrap(), Format::Apng);
        assert_eq!(Format::from_path(Path::new("a.mp4")).unwrap(), Format::Mp4);
        let e = Format::from_path(Path::new("a.webm"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("a.webm") && e.contains(".gif"), "{e}");
    }

    #[test]
    fn frame_rates_are_checked_per_format() {
        Format::Gif.check_fps(50.0).unwrap();
        assert!(Format::Gif
            .check_fps(60.0)
            .unwrap_err()
            .to_string()
            .contains("centiseconds"));
        Format::Apng.check_fps(60.0).unwrap();
        for bad in [0.0, -1.0, f64::NAN, 1000.0] {
            assert!(Format::Mp4.check_fps(bad).is_err());
        }
        assert_eq!(apng_delay(20.0), (1, 20));
        assert_eq!(apng_delay(12.5), (80, 1000));
    }
}
