//! Parallel decoding of view images.
//!
//! Every loader hands its list of view files to [`decode_views`], which decodes them on all
//! cores (rayon) behind a progress bar on stderr (indicatif hides it when stderr is not a
//! terminal) and returns them in the order given.
//!
//! Accepted: PNG (8 and 16 bit), JPEG, BMP; grey, grey + alpha, RGB and RGBA. The format is
//! recognised from the file's content first and its extension second, so a misnamed file still
//! decodes. Every image becomes sRGB-encoded RGBA8:
//! - the samples are taken as sRGB-encoded as stored (no colour management: embedded ICC
//!   profiles and gamma chunks are ignored, which is right for the sRGB data light field
//!   datasets ship);
//! - 16-bit samples are rounded to the nearest 8-bit level, `round(v · 255 / 65535)` (truncation
//!   would darken every image by half a level on average);
//! - grey is replicated into R, G and B;
//! - alpha is forced to 255: tiltfield weights views by its aperture, never by alpha, and a
//!   transparent source pixel must not leak into the average as a darker one.
//!
//! Failures name the file: a missing or unreadable file is [`Error::Io`], a truncated or corrupt
//! image or an unsupported format is [`Error::BadFile`] carrying the decoder's message, and a view
//! whose size differs from the first view's is [`Error::LightField`] naming both sizes.

use std::path::{Path, PathBuf};

use image::{ColorType, DynamicImage, ImageError, RgbaImage};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use crate::error::{Error, Result};

/// How far the latest decode of views has come: views decoded and views in all. Process-wide,
/// so that a front end can show it elsewhere than on the terminal (the viewer's loading
/// screen, which opens before the light field is read) without a progress parameter through
/// every loader. Concurrent decodes (two light fields opened at once) share it; it is for
/// display only.
#[derive(Debug, Default)]
pub struct DecodeProgress {
    done: std::sync::atomic::AtomicU64,
    total: std::sync::atomic::AtomicU64,
}

impl DecodeProgress {
    /// (views decoded, views in all) of the latest decode; (0, 0) before any.
    pub fn get(&self) -> (u64, u64) {
        use std::sync::atomic::Ordering::Relaxed;
        (self.done.load(Relaxed), self.total.load(Relaxed))
    }

    fn start(&self, total: usize) {
        use std::sync::atomic::Ordering::Relaxed;
        self.done.store(0, Relaxed);
        self.total.store(total as u64, Relaxed);
    }

    fn inc(&self) {
        self.done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }
}

/// The decode progress of this process ([`DecodeProgress`]).
pub static DECODE_PROGRESS: DecodeProgress = DecodeProgress {
    done: std::sync::atomic::AtomicU64::new(0),
    total: std::sync::atomic::AtomicU64::new(0),
};

/// [`check_views`] against `limits`, then [`decode_views`].
pub fn decode_views_within(
    paths: &[PathBuf],
    what: &str,
    limits: &LoadLimits,
) -> Result<Vec<RgbaImage>> {
    decode_views_opts(paths, what, limits, true)
}

/// [`decode_views_within`], with the progress bar only when `progress` (a video decoded in the
/// background must not draw over its caller's own progress bar).
pub fn decode_views_opts(
    paths: &[PathBuf],
    what: &str,
    limits: &LoadLimits,
    progress: bool,
) -> Result<Vec<RgbaImage>> {
    check_views(paths, what, limits)?;
    decode_with_progress(paths, what, progress)
}

/// Decodes `paths` in parallel into sRGB-encoded, opaque RGBA8 images, in the order given.
///
/// `what` names the light field for the progress message ("decoding 81 views of backgammon")
/// and for the size-mismatch error. All images must have the size of the first one; the first
/// file (in the order given) that fails to decode or has another size is reported, so the error
/// does not depend on thread scheduling. An empty list gives an empty result.
pub fn decode_views(paths: &[PathBuf], what: &str) -> Result<Vec<RgbaImage>> {
    decode_with_progress(paths, what, true)
}

fn decode_with_progress(paths: &[PathBuf], what: &str, progress: bool) -> Result<Vec<RgbaImage>> {
    if paths.is_empty() {
        return Ok(Vec::new());
    }
    let bar = if progress {
        ProgressBar::new(paths.len() as u64)
    } else {
        ProgressBar::hidden()
    };
    if let Ok(style) = ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(format!("decoding {} views of {what}", paths.len()));
    DECODE_PROGRESS.start(paths.len());
    let decoded: Vec<Result<RgbaImage>> = paths
        .par_iter()
        .map(|p| {
            let r = decode_view(p);
            bar.inc(1);
            DECODE_PROGRESS.inc();
            r
        })
        .collect();
    bar.finish_and_clear();

    let mut images = Vec::with_capacity(decoded.len());
    for (path, result) in paths.iter().zip(decoded) {
        let img = result?;
        if let Some(first) = images.first() {
            let first: &RgbaImage = first;
            if img.dimensions() != first.dimensions() {
                return Err(Error::LightField(format!(
                    "{what}: {} is {}×{}, expected {}×{} like {}",
                    path.display(),
                    img.width(),
                    img.height(),
                    first.width(),
                    first.height(),
                    paths[0].display()
                )));
            }
        }
        images.push(img);
    }
    Ok(images)
}

/// Decodes one image file into opaque sRGB-encoded RGBA8 (see the module docs).
pub fn decode_view(path: &Path) -> Result<RgbaImage> {
    let (width, height) = probe_view(path)?;
    let reader = image::ImageReader::open(path).map_err(|e| Error::io(path, e))?;
    let reader = reader
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))?;
    let img = reader.decode().map_err(|e| match e {
        // The decoder only says "Memory limit exceeded"; the declared size is the cause.
        ImageError::Limits(_) => too_large(path, width, height),
        e => decode_error(path, e),
    })?;
    Ok(to_opaque_rgba8(img))
}

/// Most bytes one decoded view may take (RGBA8): the image crate's own default decoding
/// limit, stated here so the refusal can name it.
pub const MAX_VIEW_BYTES: u64 = 512 * 1024 * 1024;

fn too_large(path: &Path, width: u32, height: u32) -> Error {
    let mib = width as f64 * height as f64 * 4.0 / (1024.0 * 1024.0);
    Error::bad_file(
        path,
        format!(
            "the image declares {width}×{height} pixels ({mib:.0} MiB decoded), more than the \
             {} MiB one view may take",
            MAX_VIEW_BYTES / (1024 * 1024)
        ),
    )
}

/// Checks that `path` is a regular file (not a folder, a device such as /dev/zero, a FIFO or a
/// dangling or looping symlink), so each gets its own message rather than "missing".
pub fn check_regular_file(path: &Path) -> Result<()> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        return Err(Error::bad_file(path, "is a folder, not an image file"));
    }
    if !meta.is_file() {
        return Err(Error::bad_file(
            path,
            "is not a regular file (a device, pipe or socket)",
        ));
    }
    Ok(())
}

/// The size an image file declares in its header, without decoding its pixels. Refuses views
/// that could not be decoded within [`MAX_VIEW_BYTES`], naming the declared size.
pub fn probe_view(path: &Path) -> Result<(u32, u32)> {
    check_regular_file(path)?;
    let reader = image::ImageReader::open(path).map_err(|e| Error::io(path, e))?;
    let reader = reader
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))?;
    let (width, height) = reader
        .into_dimensions()
        .map_err(|e| decode_error(path, e))?;
    if width == 0 || height == 0 {
        return Err(Error::bad_file(
            path,
            format!("the image declares {width}×{height} pixels"),
        ));
    }
    if width as u64 * height as u64 * 4 > MAX_VIEW_BYTES {
        return Err(too_large(path, width, height));
    }
    Ok((width, height))
}

/// Checks the views' count and declared sizes against `limits` before anything is decoded:
/// every header is read (cheap), so a light field that cannot fit is refused without holding
/// its pixels, and a view of another size is named without decoding the others.
pub fn check_views(paths: &[PathBuf], what: &str, limits: &LoadLimits) -> Result<()> {
    if paths.len() > limits.max_views {
        return Err(limits.refuse(format!(
            "{what} has {} views, more than {} ({})",
            paths.len(),
            limits.max_views,
            limits.views_why
        )));
    }
    let Some(first) = paths.first() else {
        return Ok(());
    };
    let (w, h) = probe_view(first)?;
    if w.max(h) > limits.max_dimension {
        return Err(limits.refuse(format!(
            "{what}: {} is {w}×{h}, larger than {} px ({})",
            first.display(),
            limits.max_dimension,
            limits.dimension_why
        )));
    }
    let bytes = paths.len() as u64 * w as u64 * h as u64 * 4;
    if bytes > limits.max_bytes {
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        return Err(limits.refuse(format!(
            "{what}: {} views of {w}×{h} need {:.1} MiB, more than {:.1} MiB ({})",
            paths.len(),
            mib(bytes),
            mib(limits.max_bytes),
            limits.bytes_why
        )));
    }
    for p in &paths[1..] {
        let (pw, ph) = probe_view(p)?;
        if (pw, ph) != (w, h) {
            return Err(Error::LightField(format!(
                "{what}: {} is {pw}×{ph}, expected {w}×{h} like {}",
                p.display(),
                first.display()
            )));
        }
    }
    Ok(())
}

/// How many views of what size a loader may decode. The defaults only guard against input
/// that no machine could hold; a GPU command passes its device's limits
/// ([`LoadLimits::for_device`]) so a light field the device cannot hold is refused before any
/// view is decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadLimits {
    pub max_views: usize,
    pub max_dimension: u32,
    /// Decoded RGBA8 bytes of all views together.
    pub max_bytes: u64,
    /// Why each limit is what it is, for the message.
    pub views_why: String,
    pub dimension_why: String,
    pub bytes_why: String,
    /// Refusals are device-limit errors when the limits are a device's.
    pub device: bool,
}

impl Default for LoadLimits {
    fn default() -> Self {
        LoadLimits {
            max_views: 100_000,
            max_dimension: 65_536,
            max_bytes: 64 << 30,
            views_why: "tiltfield's limit on views".into(),
            dimension_why: "tiltfield's limit on view size".into(),
            bytes_why: "tiltfield's limit on a light field's decoded size".into(),
            device: false,
        }
    }
}

impl LoadLimits {
    /// The limits of a device holding all views in one RGBA8 array texture.
    pub fn for_device(
        max_layers: u32,
        max_dimension: u32,
        max_texture_bytes: u64,
        device: &str,
    ) -> Self {
        LoadLimits {
            max_views: max_layers as usize,
            max_dimension,
            max_bytes: max_texture_bytes,
            views_why: format!("{device} holds at most {max_layers} layers in one array texture"),
            dimension_why: format!("{device}'s maximum image size"),
            bytes_why: format!("what {device} can allocate for the light field texture"),
            device: true,
        }
    }

    fn refuse(&self, message: String) -> Error {
        if self.device {
            Error::DeviceLimit(message)
        } else {
            Error::LightField(message)
        }
    }
}

fn decode_error(path: &Path, e: ImageError) -> Error {
    match e {
        ImageError::Unsupported(u) => Error::bad_file(
            path,
            format!("unsupported image format ({u}); tiltfield reads PNG, JPEG and BMP"),
        ),
        // An I/O error while decoding an opened file is almost always a file that ends early.
        ImageError::IoError(io) => {
            Error::bad_file(path, format!("cannot decode image (truncated file?): {io}"))
        }
        other => Error::bad_file(path, format!("cannot decode image: {other}")),
    }
}

/// Converts any decoded image to RGBA8 with alpha 255, rounding 16-bit samples.
fn to_opaque_rgba8(img: DynamicImage) -> RgbaImage {
    let mut out = match img.color() {
        ColorType::L16 | ColorType::La16 | ColorType::Rgb16 | ColorType::Rgba16 => {
            let wide = img.to_rgba16();
            let (w, h) = wide.dimensions();
            let narrow: Vec<u8> = wide.as_raw().iter().map(|&v| u16_to_u8(v)).collect();
            // Same dimensions and channel count as the source buffer, so this cannot fail;
            // fall back to the image crate's own (also rounding) conversion regardless.
            RgbaImage::from_raw(w, h, narrow).unwrap_or_else(|| img.to_rgba8())
        }
        _ => img.to_rgba8(),
    };
    for p in out.pixels_mut() {
        p.0[3] = 255;
    }
    out
}

/// `round(v · 255 / 65535)` in integers.
fn u16_to_u8(v: u16) -> u8 {
    ((v as u32 * 255 + 32767) / 65535) as u8
}

/// True when at least 99 % of the pixels have a maximum colour channel ≤ 2/255: the vignetted,
/// black corner views of plenoptic cameras, which must not enter the synthetic aperture (they
/// would darken the average). An empty image is not dark.
pub fn is_dark(img: &RgbaImage) -> bool {
    let total = img.width() as u64 * img.height() as u64;
    if total == 0 {
        return false;
    }
    let dark = img
        .pixels()
        .filter(|p| p.0[0].max(p.0[1]).max(p.0[2]) <= 2)
        .count() as u64;
    dark * 100 >= total * 99
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{ImageBuffer, Luma, LumaA, Rgb, Rgba};

    fn pattern(w: u32, h: u32, seed: u8) -> image::RgbImage {
        ImageBuffer::from_fn(w, h, |x, y| {
            Rgb([
                (x * 13 + seed as u32) as u8,
                (y * 29 + seed as u32) as u8,
                ((x + y) * 7) as u8,
            ])
        })
    }

    #[test]
    fn decodes_views_in_order_with_formats_mixed() {
        let dir = tempfile::tempdir().unwrap();
        let a = pattern(16, 12, 0);
        let b = pattern(16, 12, 100);
        let pa = dir.path().join("a.png");
        let pb = dir.path().join("b.bmp");
        a.save(&pa).unwrap();
        b.save(&pb).unwrap();
        let out = decode_views(&[pb.clone(), pa.clone()], "test").unwrap();
        assert_eq!(out.len(), 2);
        for (img, src) in out.iter().zip([&b, &a]) {
            assert_eq!(img.dimensions(), (16, 12));
            for (x, y, p) in img.enumerate_pixels() {
                let q = src.get_pixel(x, y).0;
                assert_eq!(p.0, [q[0], q[1], q[2], 255]);
            }
        }
    }

    #[test]
    fn jpeg_decodes_approximately() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.jpg");
        let flat: image::RgbImage = ImageBuffer::from_pixel(16, 16, Rgb([200, 100, 50]));
        flat.save(&p).unwrap();
        let img = decode_view(&p).unwrap();
        let c = img.get_pixel(8, 8).0;
        assert!((c[0] as i32 - 200).abs() <= 3, "{c:?}");
        assert!((c[1] as i32 - 100).abs() <= 3, "{c:?}");
        assert!((c[2] as i32 - 50).abs() <= 3, "{c:?}");
        assert_eq!(c[3], 255);
    }

    #[test]
    fn sixteen_bit_png_rounds_not_truncates() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("wide.png");
        // 25900/257 = 100.78 → 101 (truncation would give 100); 128/257 = 0.498 → 0;
        // 129/257 = 0.502 → 1; 65535 → 255.
        let img: ImageBuffer<Rgb<u16>, Vec<u16>> = ImageBuffer::from_fn(3, 2, |x, _| match x {
            0 => Rgb([25900, 128, 129]),
            1 => Rgb([65535, 0, 257]),
            _ => Rgb([32767, 32768, 65534]),
        });
        img.save(&p).unwrap();
        let out = decode_view(&p).unwrap();
        assert_eq!(out.get_pixel(0, 1).0, [101, 0, 1, 255]);
        assert_eq!(out.get_pixel(1, 0).0, [255, 0, 1, 255]);
        assert_eq!(out.get_pixel(2, 0).0, [127, 128, 255, 255]);
    }

    #[test]
    fn grey_and_alpha_become_opaque_rgb() {
        let dir = tempfile::tempdir().unwrap();
        let g = dir.path().join("g.png");
        let ga = dir.path().join("ga.png");
        let g16 = dir.path().join("g16.png");
        let rgba = dir.path().join("rgba.png");
        ImageBuffer::<Luma<u8>, Vec<u8>>::from_pixel(4, 4, Luma([77]))
            .save(&g)
            .unwrap();
        ImageBuffer::<LumaA<u8>, Vec<u8>>::from_pixel(4, 4, LumaA([90, 0]))
            .save(&ga)
            .unwrap();
        ImageBuffer::<Luma<u16>, Vec<u16>>::from_pixel(4, 4, Luma([25900]))
            .save(&g16)
            .unwrap();
        ImageBuffer::<Rgba<u8>, Vec<u8>>::from_pixel(4, 4, Rgba([1, 2, 3, 10]))
            .save(&rgba)
            .unwrap();
        let out = decode_views(&[g, ga, g16, rgba], "test").unwrap();
        assert_eq!(out[0].get_pixel(1, 1).0, [77, 77, 77, 255]);
        assert_eq!(out[1].get_pixel(1, 1).0, [90, 90, 90, 255]);
        assert_eq!(out[2].get_pixel(1, 1).0, [101, 101, 101, 255]);
        assert_eq!(out[3].get_pixel(1, 1).0, [1, 2, 3, 255]);
    }

    #[test]
    fn missing_file_is_an_io_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let good = dir.path().join("good.png");
        pattern(4, 4, 0).save(&good).unwrap();
        let missing = dir.path().join("missing_view.png");
        let err = decode_views(&[good, missing], "test").unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err:?}");
        assert!(err.to_string().contains("missing_view.png"), "{err}");
    }

    #[test]
    fn truncated_png_is_a_bad_file_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let full = dir.path().join("full.png");
        pattern(16, 12, 3).save(&full).unwrap();
        let bytes = std::fs::read(&full).unwrap();
        let cut = dir.path().join("cut_view.png");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        let err = decode_views(&[full, cut], "test").unwrap_err();
        assert!(matches!(err, Error::BadFile { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains("cut_view.png"), "{msg}");
        assert!(msg.contains("cannot decode"), "{msg}");
    }

    #[test]
    fn unsupported_format_is_a_bad_file_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("notes.xyz");
        std::fs::write(&p, b"this is not an image at all").unwrap();
        let err = decode_view(&p).unwrap_err();
        assert!(matches!(err, Error::BadFile { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains("notes.xyz"), "{msg}");
        assert!(msg.contains("unsupported"), "{msg}");
    }

    #[test]
    fn size_mismatch_names_file_and_both_sizes() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.png");
        let b = dir.path().join("b.png");
        let c = dir.path().join("odd_one.png");
        pattern(16, 12, 0).save(&a).unwrap();
        pattern(16, 12, 1).save(&b).unwrap();
        pattern(15, 12, 2).save(&c).unwrap();
        let err = decode_views(&[a, b, c], "scene").unwrap_err();
        assert!(matches!(err, Error::LightField(_)), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains("odd_one.png"), "{msg}");
        assert!(msg.contains("15×12"), "{msg}");
        assert!(msg.contains("16×12"), "{msg}");
    }

    #[test]
    fn dark_threshold_is_99_percent() {
        // 10×10: 99 black pixels and one bright one → dark; 98 black → not dark.
        let mut img: RgbaImage = ImageBuffer::from_pixel(10, 10, Rgba([2, 1, 0, 255]));
        img.put_pixel(0, 0, Rgba([0, 3, 0, 255]));
        assert!(is_dark(&img));
        img.put_pixel(1, 0, Rgba([200, 200, 200, 255]));
        assert!(!is_dark(&img));
        let bright: RgbaImage = ImageBuffer::from_pixel(4, 4, Rgba([50, 60, 70, 255]));
        assert!(!is_dark(&bright));
    }
}
