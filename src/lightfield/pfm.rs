//! PFM (Portable Float Map) reading and writing.
//!
//! Format: an ASCII header of three whitespace-separated fields, then raw IEEE-754 f32 samples.
//! ```text
//! Pf            magic: `Pf` = 1 channel (grey), `PF` = 3 channels (RGB, interleaved)
//! 512 512       width height (positive integers)
//! -1            scale: its sign is the byte order (negative = little-endian, positive =
//!               big-endian); its magnitude is a nominal scale that readers, like HCI's own
//!               tools, ignore
//! <data>        after exactly one whitespace byte: width·height·channels f32 samples,
//!               rows stored BOTTOM-UP (the first row in the file is the bottom image row)
//! ```
//! Everything in tiltfield holds images top-down (row 0 at the top), so [`read_pfm`] flips rows
//! on the way in and [`write_pfm`] on the way out. The header may use any ASCII whitespace
//! (spaces, tabs, newlines, `\r\n`) between fields. A file with more data than the header
//! announces is read (with a warning); one with less is an error that says how many bytes were
//! expected and found. Sizes are checked against the data actually present before anything is
//! allocated, so a corrupt header cannot trigger a huge allocation.

use std::path::Path;

use super::{DepthKind, DepthMap};
use crate::error::{Error, Result};

/// Upper bound on the header's length: three short fields and their separators.
const MAX_HEADER: usize = 256;

/// Largest PFM file read (1 GiB: a 16384² one-channel map); checked before reading, so a
/// device or a huge wrong file costs no memory.
pub const MAX_PFM_BYTES: u64 = (1 << 30) + MAX_HEADER as u64;

/// Reads a PFM file: `(width, height, channels, samples)` with samples interleaved by channel
/// and rows top-down (`samples[(y · width + x) · channels + c]`, y = 0 the top row).
pub fn read_pfm(path: &Path) -> Result<(u32, u32, usize, Vec<f32>)> {
    let bytes = crate::io::read_file(path, "a PFM map", MAX_PFM_BYTES)?;
    decode_pfm(&bytes, path)
}

/// [`read_pfm`] of bytes already in memory (`path` names them in errors).
pub fn decode_pfm(bytes: &[u8], path: &Path) -> Result<(u32, u32, usize, Vec<f32>)> {
    parse_pfm(bytes, path).map_err(|m| Error::bad_file(path, format!("PFM: {m}")))
}

/// Reads a PFM depth or disparity map (one channel, or the first channel of three), mapping
/// non-finite samples (infinities, NaN) to NaN, tiltfield's marker for "no value".
pub fn read_pfm_depth(path: &Path, kind: DepthKind) -> Result<DepthMap> {
    let (width, height, channels, data) = read_pfm(path)?;
    let values = data
        .iter()
        .step_by(channels)
        .map(|&v| if v.is_finite() { v } else { f32::NAN })
        .collect();
    Ok(DepthMap {
        width,
        height,
        kind,
        values,
        source: super::path_string(path),
        estimated: false,
    })
}

/// Writes a little-endian PFM (scale −1) from top-down samples interleaved by channel
/// (see [`encode_pfm`]) through [`crate::io::write_bytes`].
pub fn write_pfm(
    path: &Path,
    width: u32,
    height: u32,
    channels: usize,
    data_top_down: &[f32],
) -> Result<()> {
    let bytes = encode_pfm(path, width, height, channels, data_top_down)?;
    crate::io::write_bytes(path, "PFM", &bytes)
}

/// The bytes of a little-endian PFM (scale −1) from top-down samples interleaved by channel.
/// `channels` must be 1 (`Pf`) or 3 (`PF`) and `data_top_down.len()` must equal
/// `width · height · channels`; `path` only names the file in errors.
pub fn encode_pfm(
    path: &Path,
    width: u32,
    height: u32,
    channels: usize,
    data_top_down: &[f32],
) -> Result<Vec<u8>> {
    let magic = match channels {
        1 => "Pf",
        3 => "PF",
        _ => {
            return Err(Error::Invalid(format!(
                "{}: PFM holds 1 or 3 channels, not {channels}",
                path.display()
            )))
        }
    };
    let row_len = width as usize * channels;
    if width == 0 || height == 0 || data_top_down.len() != row_len * height as usize {
        return Err(Error::Invalid(format!(
            "{}: PFM of {width}×{height}×{channels} needs {} samples, got {}",
            path.display(),
            row_len * height as usize,
            data_top_down.len()
        )));
    }
    let mut bytes = Vec::with_capacity(32 + data_top_down.len() * 4);
    bytes.extend_from_slice(format!("{magic}\n{width} {height}\n-1\n").as_bytes());
    for row in data_top_down.chunks_exact(row_len).rev() {
        for v in row {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(bytes)
}

/// Parses a whole PFM file held in memory (`path` only for the warning); errors are messages
/// without the path.
fn parse_pfm(
    bytes: &[u8],
    path: &Path,
) -> std::result::Result<(u32, u32, usize, Vec<f32>), String> {
    // The magic: `PF` or `Pf` followed by whitespace.
    let channels = match bytes.get(..3) {
        Some([b'P', b'F', ws]) if ws.is_ascii_whitespace() => 3,
        Some([b'P', b'f', ws]) if ws.is_ascii_whitespace() => 1,
        _ => {
            // Name the format when it is a common one, but never echo the bytes of a file
            // that is not what it should be.
            let what = match bytes {
                [0x89, b'P', b'N', b'G', ..] => " (it is a PNG image)",
                [0x76, 0x2f, 0x31, 0x01, ..] => " (it is an OpenEXR image)",
                [0xff, 0xd8, ..] => " (it is a JPEG image)",
                [] => " (it is empty)",
                _ => "",
            };
            return Err(format!(
                "not a PFM file{what}: expected the magic `Pf` (1 channel) or `PF` (3 channels) \
                 at its start"
            ));
        }
    };
    // Three more whitespace-separated fields: width, height, scale.
    let mut pos = 2;
    let mut fields: Vec<&str> = Vec::with_capacity(3);
    while fields.len() < 3 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
            if pos > MAX_HEADER {
                return Err(
                    "header is too long or malformed (expected `Pf`/`PF`, width, \
                            height, scale)"
                        .to_string(),
                );
            }
        }
        // A field must be followed by whitespace: the byte that ends the header.
        if pos == start || pos >= bytes.len() {
            return Err(
                "header is truncated or malformed (expected `Pf`/`PF`, width, height, \
                        scale)"
                    .to_string(),
            );
        }
        let field = std::str::from_utf8(&bytes[start..pos])
            .map_err(|_| "header is not ASCII (not a PFM file?)".to_string())?;
        fields.push(field);
    }
    let dim = |name: &str, text: &str| -> std::result::Result<u32, String> {
        match text.parse::<u32>() {
            Ok(0) => Err(format!("{name} is 0: the image is empty")),
            Ok(v) => Ok(v),
            Err(_) => Err(format!(
                "{name} `{text}` in the header is not a positive integer"
            )),
        }
    };
    let width = dim("width", fields[0])?;
    let height = dim("height", fields[1])?;
    let scale: f32 = fields[2]
        .parse()
        .map_err(|_| format!("scale `{}` in the header is not a number", fields[2]))?;
    if scale == 0.0 || !scale.is_finite() {
        return Err(format!(
            "scale `{}` must be a non-zero number (its sign gives the byte order)",
            fields[2]
        ));
    }
    let little_endian = scale < 0.0;
    // Exactly one whitespace byte ends the header; tolerate a Windows `\r\n`.
    let mut data_start = pos + 1;
    // u128: 2³² · 2³² · 3 · 4 overflows u64.
    let expected = (width as u128) * (height as u128) * (channels as u128) * 4;
    if bytes[pos] == b'\r'
        && bytes.get(pos + 1) == Some(&b'\n')
        && (bytes.len() - data_start) as u128 == expected + 1
    {
        data_start += 1;
    }
    let found = (bytes.len() - data_start) as u128;
    // Compare with the data present before allocating anything of the header's size.
    if found < expected {
        return Err(format!(
            "data is truncated: {width}×{height}×{channels} f32 samples need {expected} bytes, \
             found {found}"
        ));
    }
    if found > expected {
        log::warn!(
            "{}: {} bytes after the {width}×{height}×{channels} PFM samples; ignoring them",
            path.display(),
            found - expected
        );
    }
    let data = &bytes[data_start..data_start + expected as usize];
    let row_len = width as usize * channels;
    let mut out = Vec::with_capacity(row_len * height as usize);
    // File rows are bottom-up: emit them in reverse order.
    for row in data.chunks_exact(row_len * 4).rev() {
        out.extend(row.chunks_exact(4).map(|b| {
            let b = [b[0], b[1], b[2], b[3]];
            if little_endian {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            }
        }));
    }
    Ok((width, height, channels, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_raw(dir: &Path, name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    #[test]
    fn round_trip_one_and_three_channels() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (5u32, 3u32);
        let grey: Vec<f32> = (0..w * h).map(|i| i as f32 * 0.5 - 3.0).collect();
        let p = dir.path().join("grey.pfm");
        write_pfm(&p, w, h, 1, &grey).unwrap();
        assert_eq!(read_pfm(&p).unwrap(), (w, h, 1, grey));

        let rgb: Vec<f32> = (0..w * h * 3).map(|i| (i as f32).sqrt()).collect();
        let p = dir.path().join("rgb.pfm");
        write_pfm(&p, w, h, 3, &rgb).unwrap();
        assert_eq!(read_pfm(&p).unwrap(), (w, h, 3, rgb));
    }

    #[test]
    fn file_rows_are_bottom_up_and_little_endian() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("rows.pfm");
        // 2×2 top-down: top row [1, 2], bottom row [3, 4].
        write_pfm(&p, 2, 2, 1, &[1.0, 2.0, 3.0, 4.0]).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let header = b"Pf\n2 2\n-1\n";
        assert_eq!(&bytes[..header.len()], header);
        let first = f32::from_le_bytes(bytes[header.len()..header.len() + 4].try_into().unwrap());
        assert_eq!(first, 3.0, "the file's first row must be the bottom row");
    }

    #[test]
    fn reads_big_endian_and_tolerates_header_whitespace() {
        let dir = tempfile::tempdir().unwrap();
        let mut bytes = b"PF \t\r\n 1   2\n\n 1.0\n".to_vec();
        // Bottom row (file first): (7, 8, 9); top row: (1.5, -2, 1e30).
        for v in [7.0f32, 8.0, 9.0, 1.5, -2.0, 1e30] {
            bytes.extend_from_slice(&v.to_be_bytes());
        }
        let p = write_raw(dir.path(), "be.pfm", &bytes);
        let (w, h, c, data) = read_pfm(&p).unwrap();
        assert_eq!((w, h, c), (1, 2, 3));
        assert_eq!(data, vec![1.5, -2.0, 1e30, 7.0, 8.0, 9.0]);
    }

    #[test]
    fn depth_takes_first_channel_and_maps_non_finite_to_nan() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("d.pfm");
        let data = [
            1.0,
            10.0,
            10.0,
            f32::INFINITY,
            10.0,
            10.0,
            -2.5,
            10.0,
            10.0,
            f32::NEG_INFINITY,
            0.0,
            0.0,
        ];
        write_pfm(&p, 2, 2, 3, &data).unwrap();
        let d = read_pfm_depth(&p, DepthKind::Disparity).unwrap();
        assert_eq!((d.width, d.height, d.kind), (2, 2, DepthKind::Disparity));
        assert_eq!(d.at(0, 0), 1.0);
        assert!(d.at(1, 0).is_nan());
        assert_eq!(d.at(0, 1), -2.5);
        assert!(d.at(1, 1).is_nan());
        assert!(d.source.contains("d.pfm"));
    }

    #[test]
    fn truncated_data_says_expected_and_found_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let mut bytes = b"Pf\n4 3\n-1\n".to_vec();
        bytes.extend_from_slice(&[0u8; 40]);
        let p = write_raw(dir.path(), "short_disp.pfm", &bytes);
        let err = read_pfm(&p).unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, Error::BadFile { .. }), "{err:?}");
        assert!(msg.contains("short_disp.pfm"), "{msg}");
        assert!(msg.contains("truncated"), "{msg}");
        assert!(msg.contains("48 bytes"), "{msg}");
        assert!(msg.contains("found 40"), "{msg}");
    }

    #[test]
    fn absurd_size_is_rejected_without_allocating() {
        let dir = tempfile::tempdir().unwrap();
        let mut bytes = b"PF\n4294967295 4294967295\n-1\n".to_vec();
        bytes.extend_from_slice(&[0u8; 16]);
        let p = write_raw(dir.path(), "huge.pfm", &bytes);
        let msg = read_pfm(&p).unwrap_err().to_string();
        assert!(
            msg.contains("huge.pfm") && msg.contains("truncated"),
            "{msg}"
        );
    }

    #[test]
    fn header_errors_are_specific() {
        let dir = tempfile::tempdir().unwrap();
        let cases: [(&str, &[u8], &str); 7] = [
            (
                "magic.pfm",
                b"P6\n2 2\n255\n........",
                "expected the magic `Pf`",
            ),
            ("width.pfm", b"Pf\nabc 2\n-1\n........", "width `abc`"),
            ("neg.pfm", b"Pf\n2 -2\n-1\n........", "height `-2`"),
            ("zero.pfm", b"Pf\n0 2\n-1\n", "width is 0"),
            ("scale.pfm", b"Pf\n1 1\nx\n....", "scale `x`"),
            ("scale0.pfm", b"Pf\n1 1\n0\n....", "non-zero"),
            ("cut.pfm", b"Pf\n1", "truncated or malformed"),
        ];
        for (name, bytes, needle) in cases {
            let p = write_raw(dir.path(), name, bytes);
            let msg = read_pfm(&p).unwrap_err().to_string();
            assert!(msg.contains(name), "{msg}");
            assert!(msg.contains(needle), "{name}: {msg}");
        }
        let p = write_raw(dir.path(), "text.pfm", b"hello world, this is text");
        let msg = read_pfm(&p).unwrap_err().to_string();
        assert!(msg.contains("not a PFM file"), "{msg}");
        assert!(
            !msg.contains("hello"),
            "the file's bytes are not echoed: {msg}"
        );
    }

    #[test]
    fn missing_file_is_io_error() {
        let dir = tempfile::tempdir().unwrap();
        let err = read_pfm(&dir.path().join("nope.pfm")).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err:?}");
        assert!(err.to_string().contains("nope.pfm"));
    }

    #[test]
    fn write_rejects_wrong_lengths() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("w.pfm");
        assert!(write_pfm(&p, 2, 2, 1, &[0.0; 3]).is_err());
        assert!(write_pfm(&p, 2, 2, 2, &[0.0; 8]).is_err());
        assert!(!p.exists());
    }
}
