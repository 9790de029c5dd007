//! Writing images: 8-bit sRGB PNG and linear-light float OpenEXR, and the choice between them
//! by file extension.
//!
//! Invariants: a PNG holds sRGB-encoded 8-bit values exactly as given (no colour conversion
//! here); an EXR holds linear-light RGBA as 32-bit floats, rows top to bottom. Every failure
//! is an error naming the file.

use std::path::Path;

use image::RgbaImage;

use crate::error::{Error, Result};

/// Writes an 8-bit sRGB image as PNG.
pub fn save_png(img: &RgbaImage, path: &Path) -> Result<()> {
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| Error::bad_file(path, format!("cannot write PNG: {e}")))
}

/// Writes linear-light RGBA (`width × height`, row-major) as a 32-bit float OpenEXR file.
pub fn save_exr(width: u32, height: u32, linear: &[[f32; 4]], path: &Path) -> Result<()> {
    let w = width as usize;
    exr::prelude::write_rgba_file(path, w, height as usize, |x, y| {
        let p = linear[y * w + x];
        (p[0], p[1], p[2], p[3])
    })
    .map_err(|e| Error::bad_file(path, format!("cannot write EXR: {e}")))
}

/// Writes one float channel named `channel` (`width × height`, row-major, NaN allowed) as an
/// OpenEXR file: depth maps as `Z`, disparity maps as `Y`, the names tiltfield's own manifest
/// reader looks for.
pub fn save_exr_channel(
    width: u32,
    height: u32,
    channel: &str,
    values: &[f32],
    path: &Path,
) -> Result<()> {
    use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, Image, SmallVec, WritableImage};
    let list = SmallVec::from_vec(vec![AnyChannel::new(
        channel,
        FlatSamples::F32(values.to_vec()),
    )]);
    Image::from_channels((width as usize, height as usize), AnyChannels::sort(list))
        .write()
        .to_file(path)
        .map_err(|e| Error::bad_file(path, format!("cannot write EXR: {e}")))
}

/// Output file kind, from the extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    Png,
    Exr,
}

impl OutputKind {
    /// `.png` or `.exr` (case-insensitive); anything else is an error naming the path.
    pub fn from_path(path: &Path) -> Result<Self> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("png") => Ok(Self::Png),
            Some("exr") => Ok(Self::Exr),
            _ => Err(Error::Invalid(format!(
                "{}: output must end in .png (8-bit sRGB) or .exr (linear float)",
                path.display()
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_kind_follows_the_extension_case_insensitively() {
        assert_eq!(
            OutputKind::from_path(Path::new("a/b.PNG")).unwrap(),
            OutputKind::Png
        );
        assert_eq!(
            OutputKind::from_path(Path::new("b.exr")).unwrap(),
            OutputKind::Exr
        );
        let e = OutputKind::from_path(Path::new("b.tiff")).unwrap_err();
        assert!(e.to_string().contains("b.tiff"), "{e}");
    }
}
