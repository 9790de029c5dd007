//! Reading input files and writing output files: the one place where tiltfield touches the
//! file system for whole files.
//!
//! Reading: only regular files are read where a file is expected. A FIFO, a device such as
//! /dev/zero, a folder or a socket is refused with a message naming the file and what it is,
//! before a byte is read (the file is opened non-blocking and checked with `fstat`, so a FIFO
//! cannot block the open and nothing can be swapped in between the check and the read), and
//! the size is checked against a limit before reading, so no input costs memory its kind does
//! not justify.
//!
//! Writing ([`write_with`], and [`save_png`], [`save_exr`], [`save_exr_channel`],
//! [`write_bytes`] on top of it): every output is written to a temporary file created
//! exclusively (`O_CREAT | O_EXCL | O_NOFOLLOW`: never through a planted link, never over
//! another file) in the destination's folder, flushed, `fsync`ed and closed with every error
//! checked, then renamed over the destination. A destination that exists must be a regular
//! file: a link, a folder, a device or a FIFO is refused, so an output never lands outside the
//! path given. Missing parent folders are created for the write and removed again when it
//! fails, so a failed run leaves nothing behind: no folder, no partial file.
//!
//! Image invariants: a PNG holds sRGB-encoded 8-bit values exactly as given (no colour
//! conversion here); an EXR holds linear-light RGBA as 32-bit floats, rows top to bottom.

use std::fs::{File, Metadata};
use std::io::{BufWriter, Read, Write};
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use image::{EncodableLayout, ImageBuffer, Pixel, PixelWithColorType};

use crate::error::{Error, Result};

/// Largest text input (configuration files, manifests, scripts, camera lists): far beyond any
/// real one, small enough that a wrong file costs no memory.
pub const MAX_TEXT_BYTES: u64 = 64 * 1024 * 1024;

/// What a file that is not a regular file is, for messages ("a FIFO (named pipe)").
pub fn kind_of(meta: &Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        "a folder"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_symlink() {
        "a symbolic link"
    } else {
        "a regular file"
    }
}

/// What `path` is when it is not a regular file, links followed: "a folder", "a FIFO (named
/// pipe)", "a dangling link to TARGET", ...; `None` for a regular file or a path that does not
/// exist at all.
pub fn describe_irregular(path: &Path) -> Option<String> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => None,
        Ok(m) => Some(kind_of(&m).to_string()),
        Err(_) => std::fs::read_link(path)
            .ok()
            .map(|t| format!("a dangling link to {}", t.display())),
    }
}

/// The refusal of `path`, which is `meta`'s kind where `what` (for example "the --score
/// ground truth") must be a regular file.
fn not_regular(path: &Path, meta: &Metadata, what: &str) -> Error {
    Error::bad_file(
        path,
        format!(
            "{what} must be a regular file, but this is {}",
            kind_of(meta)
        ),
    )
}

/// Checks without opening it that `path` (links followed) is a regular file; a folder, FIFO,
/// device or socket is refused naming `what` and what it is, a missing or dangling path with
/// the system's message.
pub fn check_regular(path: &Path, what: &str) -> Result<u64> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_regular(path, &meta, what));
    }
    Ok(meta.len())
}

/// Opens `path` for reading when it is a regular file of at most `max_bytes`; returns the file
/// and its size. Opened non-blocking, so a FIFO is refused instead of waiting for a writer.
pub fn open_regular(path: &Path, what: &str, max_bytes: u64) -> Result<(File, u64)> {
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_CLOEXEC)
        .open(path)
        .map_err(|e| Error::io(path, e))?;
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_regular(path, &meta, what));
    }
    if meta.len() > max_bytes {
        return Err(Error::bad_file(
            path,
            format!(
                "{what} is {} bytes, more than the {} bytes such a file may have",
                meta.len(),
                max_bytes
            ),
        ));
    }
    Ok((file, meta.len()))
}

/// Reads the whole of `path` (a regular file of at most `max_bytes`, see [`open_regular`]).
pub fn read_file(path: &Path, what: &str, max_bytes: u64) -> Result<Vec<u8>> {
    let (file, len) = open_regular(path, what, max_bytes)?;
    let mut bytes = Vec::with_capacity(len as usize);
    // `take`: a file that grows while it is read still stops at the limit.
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > max_bytes {
        return Err(Error::bad_file(
            path,
            format!("{what} grew beyond {max_bytes} bytes while it was read"),
        ));
    }
    Ok(bytes)
}

/// Reads `path` as UTF-8 text (a regular file of at most [`MAX_TEXT_BYTES`]); a leading
/// byte-order mark is dropped, since editors on Windows write one and it is not content.
pub fn read_text(path: &Path, what: &str) -> Result<String> {
    let bytes = read_file(path, what, MAX_TEXT_BYTES)?;
    let text = String::from_utf8(bytes)
        .map_err(|e| Error::bad_file(path, format!("{what} is not UTF-8 text: {e}")))?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// Checks before any work that `path` can be written as an output: when it exists it is a
/// regular file (not a folder, link, device or FIFO), and its nearest existing folder accepts
/// a new file (a probe file is created exclusively there and removed again). Creates nothing
/// that stays.
pub fn check_writable(path: &Path) -> Result<()> {
    check_destination(path)?;
    let (existing, _) = split_existing(path)?;
    let (probe, file) = create_temp(&existing, path)?;
    drop(file);
    std::fs::remove_file(&probe).map_err(|e| Error::io(&probe, e))
}

/// [`check_writable`] for an output folder `dir` that will receive `first` (a file name): a
/// `dir` that exists must be a folder ("the output folder is a file" otherwise).
/// `path` as text, or an error naming `what` when it is not valid UTF-8: outputs whose paths
/// are reported in JSON (a folder of many files, a frame pattern) must be representable there,
/// and a pattern's `{frame}` must be found and replaced in text, not in lossy copies of it.
pub fn utf8_path<'a>(path: &'a Path, what: &str) -> Result<&'a str> {
    path.to_str().ok_or_else(|| {
        Error::Invalid(format!(
            "{what} '{}' is not valid UTF-8; give a name in UTF-8",
            path.display()
        ))
    })
}

pub fn check_writable_folder(dir: &Path, first: &str) -> Result<()> {
    if let Ok(m) = std::fs::metadata(dir) {
        if !m.is_dir() {
            let what = if m.is_file() { "a file" } else { kind_of(&m) };
            return Err(Error::bad_file(
                dir,
                format!("the output folder is {what}; give a folder"),
            ));
        }
    }
    check_writable(&dir.join(first))
}

/// A destination that exists must be a regular file; it is never followed if it is a link.
fn check_destination(path: &Path) -> Result<()> {
    if path.file_name().is_none() {
        return Err(Error::bad_file(
            path,
            "the output has no file name; give a file name",
        ));
    }
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(m) if m.is_dir() => Err(Error::bad_file(
            path,
            "the output is a folder; give a file name",
        )),
        Ok(m) => Err(Error::bad_file(
            path,
            format!(
                "the output is {}; outputs are only written as regular files (never through \
                 links or into devices)",
                kind_of(&m)
            ),
        )),
        // Missing, or a file where a folder of the path should be: `split_existing` then
        // names the part of the path that is in the way.
        Err(e)
            if e.kind() == std::io::ErrorKind::NotFound
                || e.raw_os_error() == Some(libc::ENOTDIR) =>
        {
            Ok(())
        }
        Err(e) => Err(Error::io(path, e)),
    }
}

/// The folder of output `path`: its nearest existing ancestor (which must be a folder) and the
/// missing folders below it, outermost first.
fn split_existing(path: &Path) -> Result<(PathBuf, Vec<PathBuf>)> {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut missing = Vec::new();
    let mut dir = parent;
    loop {
        match std::fs::metadata(&dir) {
            Ok(m) if m.is_dir() => break,
            Ok(m) => {
                return Err(Error::bad_file(
                    &dir,
                    format!(
                        "cannot write {} inside it: it is {}, not a folder",
                        path.display(),
                        kind_of(&m)
                    ),
                ))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                missing.push(dir.clone());
                dir = match dir.parent() {
                    Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                    _ => PathBuf::from("."),
                };
            }
            Err(e) => return Err(Error::io(&dir, e)),
        }
    }
    missing.reverse();
    Ok((dir, missing))
}

/// Creates a new temporary file for `target` in folder `dir`: exclusively and without following
/// links, under a name no other process or call uses (a name taken by anything, a planted link
/// included, is skipped).
fn create_temp(dir: &Path, target: &Path) -> Result<(PathBuf, File)> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let stem = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut last = None;
    for _ in 0..16 {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".{stem}.tmp-{}-{n}", std::process::id()));
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
            .open(&tmp)
        {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => {
                return Err(Error::bad_file(
                    target,
                    format!("cannot create a file in {}: {e}", dir.display()),
                ))
            }
        }
    }
    Err(Error::bad_file(
        target,
        format!(
            "cannot create a temporary file in {}: {}",
            dir.display(),
            last.map(|e| e.to_string()).unwrap_or_default()
        ),
    ))
}

/// Closes `file`, returning the error `close` reports (a deferred write error on network and
/// some local file systems), which dropping a `File` ignores.
fn close_checked(file: File) -> std::io::Result<()> {
    use std::os::fd::IntoRawFd;
    let fd = file.into_raw_fd();
    // SAFETY: `fd` was just released by the `File`, so it is open and owned here alone.
    if unsafe { libc::close(fd) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// Writes output `path` through `write` (see the module docs): a temporary file in its
/// folder, every write, flush, sync and close checked, then renamed over `path`. Missing parent
/// folders are created and, when anything fails, removed again together with the temporary
/// file. `what` names the content in messages ("PNG", "depth cache entry").
pub fn write_with<F>(path: &Path, what: &str, write: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> std::result::Result<(), String>,
{
    check_destination(path)?;
    let (_, missing) = split_existing(path)?;
    let mut created: Vec<PathBuf> = Vec::new();
    let mut tmp: Option<PathBuf> = None;
    let result = (|| -> Result<()> {
        for dir in &missing {
            match std::fs::create_dir(dir) {
                Ok(()) => created.push(dir.clone()),
                // Another process made it meanwhile: not ours to remove.
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && dir.is_dir() => {}
                Err(e) => return Err(Error::io(dir, e)),
            }
        }
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let (t, file) = create_temp(dir, path)?;
        tmp = Some(t.clone());
        let fail = |e: String| Error::bad_file(path, format!("cannot write {what}: {e}"));
        let mut w = BufWriter::new(file);
        write(&mut w).map_err(fail)?;
        let file = w.into_inner().map_err(|e| fail(e.error().to_string()))?;
        file.sync_all().map_err(|e| fail(e.to_string()))?;
        close_checked(file).map_err(|e| fail(e.to_string()))?;
        std::fs::rename(&t, path)
            .map_err(|e| fail(format!("cannot rename the finished file: {e}")))?;
        tmp = None;
        Ok(())
    })();
    if result.is_err() {
        if let Some(t) = &tmp {
            let _ = std::fs::remove_file(t);
        }
        for dir in created.iter().rev() {
            // Only empty folders go: anything another process put there stays.
            let _ = std::fs::remove_dir(dir);
        }
    }
    result
}

/// A folder of outputs written together (a synthetic light field, a benchmark report, the
/// demo's images). Missing folders are created when it is made; files are written through
/// [`write_with`]. Unless [`OutputFolder::finish`] is called, dropping it removes every file it
/// created and then the folders it created, so a run that fails half way leaves nothing behind.
pub struct OutputFolder {
    dir: PathBuf,
    created_dirs: Vec<PathBuf>,
    new_files: std::sync::Mutex<Vec<PathBuf>>,
    finished: bool,
}

impl OutputFolder {
    /// Makes sure `dir` is a folder (creating it and missing parents); a path that exists but
    /// is not a folder is refused naming what it is.
    pub fn create(dir: &Path) -> Result<Self> {
        let mut out = Self {
            dir: dir.to_path_buf(),
            created_dirs: Vec::new(),
            new_files: Default::default(),
            finished: false,
        };
        match std::fs::metadata(dir) {
            Ok(m) if m.is_dir() => return Ok(out),
            Ok(m) => {
                let what = if m.is_file() { "a file" } else { kind_of(&m) };
                return Err(Error::bad_file(
                    dir,
                    format!("the output folder is {what}; give a folder"),
                ));
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(Error::io(dir, e)),
        }
        // `split_existing` looks at the parent of its argument: give it a child of `dir`.
        let (_, mut missing) = split_existing(&dir.join("x"))?;
        missing.retain(|d| d.as_path() != Path::new("."));
        for d in missing {
            std::fs::create_dir(&d).map_err(|e| Error::io(&d, e))?;
            out.created_dirs.push(d);
        }
        Ok(out)
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// Writes `name` (relative to the folder) through [`write_with`]; returns its path.
    /// Safe to call from several threads at once.
    pub fn write_with<F>(&self, name: impl AsRef<Path>, what: &str, write: F) -> Result<PathBuf>
    where
        F: FnOnce(&mut BufWriter<File>) -> std::result::Result<(), String>,
    {
        let path = self.dir.join(name);
        self.track(&path, |p| write_with(p, what, write))?;
        Ok(path)
    }

    /// Writes `bytes` as `name` (see [`OutputFolder::write_with`]).
    pub fn write_bytes(&self, name: impl AsRef<Path>, what: &str, bytes: &[u8]) -> Result<PathBuf> {
        self.write_with(name, what, |w| {
            w.write_all(bytes).map_err(|e| e.to_string())
        })
    }

    /// Runs `write` (which writes `path`, inside the folder, through this module), recording
    /// `path` as this folder's to remove on failure when it did not exist before.
    pub fn track<T>(&self, path: &Path, write: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
        let existed = std::fs::symlink_metadata(path).is_ok();
        let out = write(path)?;
        if !existed {
            self.new_files
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(path.to_path_buf());
        }
        Ok(out)
    }

    /// Keeps everything written.
    pub fn finish(mut self) {
        self.finished = true;
    }
}

impl Drop for OutputFolder {
    fn drop(&mut self) {
        if self.finished {
            return;
        }
        let files = self.new_files.get_mut().unwrap_or_else(|p| p.into_inner());
        for f in files.iter().rev() {
            let _ = std::fs::remove_file(f);
        }
        for d in self.created_dirs.iter().rev() {
            let _ = std::fs::remove_dir(d);
        }
    }
}

/// Writes `bytes` to output `path` (see [`write_with`]).
pub fn write_bytes(path: &Path, what: &str, bytes: &[u8]) -> Result<()> {
    write_with(path, what, |w| {
        w.write_all(bytes).map_err(|e| e.to_string())
    })
}

/// Writes an 8-bit image (RGBA, RGB or grey; sRGB-encoded as given) as PNG.
pub fn save_png<P, C>(img: &ImageBuffer<P, C>, path: &Path) -> Result<()>
where
    P: Pixel + PixelWithColorType,
    [P::Subpixel]: EncodableLayout,
    C: std::ops::Deref<Target = [P::Subpixel]>,
{
    write_with(path, "PNG", |w| encode_png(img, w))
}

/// Encodes an 8-bit image as PNG into `w` (the body of [`save_png`], for
/// [`OutputFolder::write_with`]).
pub fn encode_png<P, C>(
    img: &ImageBuffer<P, C>,
    w: &mut BufWriter<File>,
) -> std::result::Result<(), String>
where
    P: Pixel + PixelWithColorType,
    [P::Subpixel]: EncodableLayout,
    C: std::ops::Deref<Target = [P::Subpixel]>,
{
    img.write_to(w, image::ImageFormat::Png)
        .map_err(|e| e.to_string())
}

/// Writes linear-light RGBA (`width × height`, row-major) as a 32-bit float OpenEXR file.
pub fn save_exr(width: u32, height: u32, linear: &[[f32; 4]], path: &Path) -> Result<()> {
    use exr::prelude::{Image, SpecificChannels, Vec2, WritableImage};
    let w = width as usize;
    write_with(path, "EXR", |out| {
        let channels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
            let p = linear[y * w + x];
            (p[0], p[1], p[2], p[3])
        });
        Image::from_channels((w, height as usize), channels)
            .write()
            .to_buffered(out)
            .map_err(|e| e.to_string())
    })
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
    let image = Image::from_channels((width as usize, height as usize), AnyChannels::sort(list));
    write_with(path, "EXR", |out| {
        image.write().to_buffered(out).map_err(|e| e.to_string())
    })
}

/// Output file kind, from the extension.
/// `path`'s extension in lower case (`None` without one or when it is not UTF-8): how every
/// file format here is chosen, so `X.PNG` and `x.png` are read and written alike.
pub fn extension_lower(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    Png,
    Exr,
}

impl OutputKind {
    /// `.png` or `.exr` (case-insensitive); anything else is an error naming the path.
    pub fn from_path(path: &Path) -> Result<Self> {
        match extension_lower(path).as_deref() {
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
