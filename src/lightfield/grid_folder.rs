//! Folders of rectified views named by row and column.
//!
//! This covers sub-aperture exports of plenoptic cameras (Lytro toolboxes, EPFL `R_C.bmp`
//! exports with black vignetted corner views) and the Stanford light field archive. The row
//! and the column are read from the numbers in the file names by the rule of
//! [`super::grid_naming`]: the two whole numbers that vary across the files and together form
//! a complete grid; numbers that are the same in every name (scene, frame or camera numbers)
//! and numbers with a sign or decimals (Stanford camera positions) are not indices.
//!
//! | file names                                   | row    | column |
//! |----------------------------------------------|--------|--------|
//! | `2067_01_01.png` … `2067_09_09.png` (Lytro)  | 2nd    | 3rd    |
//! | `out_00_00_-381.909271_1103.376221_.png`     | 1st    | 2nd    |
//! | `1_1.bmp` … `15_15.bmp` (EPFL)               | 1st    | 2nd    |
//! | `row_3_col_7.png`, `col_7_row_3.png`         | by label | by label |
//! | `Sub_03_07.jpg`, `03_07.bmp`, `img-3-7.png`  | 1st    | 2nd    |
//!
//! Image files are `.png` (8 or 16 bit), `.jpg`, `.jpeg` and `.bmp` in any letter case; names
//! starting with `.` are never views. The views are read from the folder itself when it holds
//! image files with numbers in their names, otherwise from its only sub-folder that does (an
//! archive that unpacks into `rectified/`). The smallest row and column become t = 0 and
//! s = 0 (exports count from 0 or 1). Image files that are not part of the grid are ignored
//! with one warning naming them. A folder that can be read as no grid or as several (a missing
//! view, a duplicate, two complete grids) and views of different sizes are errors that list
//! what was found. `tiltfield info` reports which numbers gave the row and the column
//! ([`GridNaming`]).
//!
//! The folder carries no calibration, so the cameras come from [`GridCameraOptions`]: a
//! parallel rig (R = I) without sensor shift, focal length `focal_px` (default max(W, H)),
//! principal point at the image centre, baseline `baseline` (default 1), centred on the grid
//! centre. Such views are usually rectified so that the zero-disparity plane is somewhere in
//! the scene rather than at infinity, so these cameras are only a nominal model; the light
//! field has no [`super::ParallelRig`] and `--disparity` means classic shift-and-sum.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{DMat3, DVec3};

use super::grid_naming::{read_grid, NamingError};
use super::images::{decode_views_within, probe_view, LoadLimits};
use super::{GridCameraOptions, GridSize, LightField, Source};
use crate::error::{Error, Result};
use crate::geometry::camera::{intrinsics, Camera};

/// Extensions (lower case) of the image files considered.
pub const EXTENSIONS: [&str; 4] = ["png", "jpg", "jpeg", "bmp"];

/// True for a file name with an image extension that is not hidden.
pub fn is_image_name(name: &str) -> bool {
    !name.starts_with('.')
        && crate::io::extension_lower(Path::new(name))
            .is_some_and(|e| EXTENSIONS.contains(&e.as_str()))
}

/// The names of the image files directly in `dir` (see [`is_image_name`]), sorted.
pub fn image_names(dir: &Path) -> Result<Vec<String>> {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if is_image_name(&name) && entry.path().is_file() {
            names.push(name);
        }
    }
    names.sort();
    Ok(names)
}

/// Refuses an entry of the views' folder `dir` named as an image that is not a regular file,
/// naming it and what it is: skipped, it was reported as a missing view of the grid.
fn refuse_irregular_views(dir: &Path) -> Result<()> {
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        if !is_image_name(&entry.file_name().to_string_lossy()) {
            continue;
        }
        if let Some(what) = crate::io::describe_irregular(&entry.path()) {
            return Err(Error::bad_file(
                entry.path(),
                format!("a view of the grid folder must be an image file, but this is {what}"),
            ));
        }
    }
    Ok(())
}

/// The sub-folders of `dir` (not hidden), sorted.
pub fn subfolders(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let hidden = entry.file_name().to_string_lossy().starts_with('.');
        if !hidden && entry.path().is_dir() {
            out.push(entry.path());
        }
    }
    out.sort();
    Ok(out)
}

/// True when some name holds a number (a candidate view).
fn has_numbered(names: &[String]) -> bool {
    names.iter().any(|n| n.bytes().any(|b| b.is_ascii_digit()))
}

/// The folder holding the views: `dir` itself when it has numbered image files, otherwise its
/// only sub-folder that has them (with its name). Several such sub-folders are an error.
fn locate(dir: &Path) -> Result<(PathBuf, Vec<String>, Option<String>)> {
    let names = image_names(dir)?;
    if has_numbered(&names) {
        return Ok((dir.to_path_buf(), names, None));
    }
    let mut found = Vec::new();
    for sub in subfolders(dir)? {
        let sub_names = image_names(&sub)?;
        if has_numbered(&sub_names) {
            found.push((sub, sub_names));
        }
    }
    match found.len() {
        0 => Ok((dir.to_path_buf(), names, None)),
        1 => {
            let (sub, sub_names) = found.pop().expect("one sub-folder");
            let label = sub
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            Ok((sub, sub_names, Some(label)))
        }
        _ => Err(Error::LightField(format!(
            "{}: has no views of its own and {} sub-folders with numbered images ({}); give \
             the one that holds the light field",
            dir.display(),
            found.len(),
            found
                .iter()
                .map(|(p, n)| format!(
                    "{} ({} images)",
                    p.file_name().unwrap_or_default().to_string_lossy(),
                    n.len()
                ))
                .collect::<Vec<_>>()
                .join(", ")
        ))),
    }
}

/// Loads a grid folder (see the module docs).
pub fn load(dir: &Path, opts: &GridCameraOptions) -> Result<LightField> {
    load_within(dir, opts, &LoadLimits::default())
}

/// What the folder is not, for messages when no grid is found.
const NOT_OTHER_FORMATS: &str = "the folder has no parameters.cfg (HCI), no \
    cameras_parameters.txt (Technicolor video) and no tiltfield.json (manifest)";

/// How grid folders must be named, for messages.
const NAMING_HINT: &str = "grid folders need image files (.png, .jpg, .jpeg, .bmp) whose names \
    hold a row and a column, e.g. 03_07.png, 2067_03_07.png, row_3_col_7.png, Sub_03_07.jpg or \
    out_03_07_-859.7_1022.8_.png";

/// [`load`], refusing before decoding a light field beyond `limits`.
pub fn load_within(
    dir: &Path,
    opts: &GridCameraOptions,
    limits: &LoadLimits,
) -> Result<LightField> {
    let (folder, names, subfolder) = locate(dir)?;
    refuse_irregular_views(&folder)?;
    let reading = read_grid(&names, subfolder).map_err(|e| match e {
        NamingError::NoNumberedViews => {
            // One message for the folder, not one warning per file: most likely this is an
            // HCI folder without its parameters.cfg, or not a light field at all.
            let seen = match names.first() {
                Some(first) => format!(
                    "; of its {} image files no two share a naming rule with numbers, e.g. {first}",
                    names.len()
                ),
                None => "; it holds no image files".to_string(),
            };
            Error::bad_file(
                dir,
                format!("no views found: {NOT_OTHER_FORMATS}{seen}; {NAMING_HINT}"),
            )
        }
        NamingError::OneIndex(m) => Error::bad_file(
            &folder,
            format!("no grid of views found: {NOT_OTHER_FORMATS}, and {m}; {NAMING_HINT}"),
        ),
        NamingError::Incomplete(m) | NamingError::Ambiguous(m) => {
            Error::LightField(format!("{}: {m}", folder.display()))
        }
    })?;
    if !reading.ignored.is_empty() {
        let shown: Vec<&str> = reading
            .ignored
            .iter()
            .take(3)
            .map(|&i| names[i].as_str())
            .collect();
        log::warn!(
            "{}: ignored {} image file{} that are not part of the grid of {} (e.g. {})",
            folder.display(),
            reading.ignored.len(),
            if reading.ignored.len() == 1 { "" } else { "s" },
            reading.naming.pattern,
            shown.join(", ")
        );
    }
    let grid = reading.grid;
    let paths: Vec<PathBuf> = reading
        .order
        .iter()
        .map(|&i| folder.join(&names[i]))
        .collect();
    check_sizes(&paths, &folder)?;

    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| super::path_string(dir));
    let images = decode_views_within(&paths, &name, limits)?;
    let (width, height) = images[0].dimensions();
    let cameras = cameras(grid, width, height, opts)?;
    let views = super::grid_views(grid, images, cameras, &paths);
    log::info!("{}: {}", dir.display(), reading.naming.describe());
    Ok(LightField {
        name,
        grid,
        width,
        height,
        views,
        depth: Vec::new(),
        rig: None,
        disparity_range: None,
        source: Source::GridFolder {
            path: dir.to_path_buf(),
            naming: reading.naming,
        },
    })
}

/// A light field of `images` in row-major grid order (`images[t · cols + s]`), handed over in
/// memory: the Python module's `from_array`. It is read exactly as a grid folder of the same
/// views would be (the nominal cameras of [`cameras`], classic disparity), so the same request
/// renders the same image from either.
pub fn from_images(
    name: &str,
    grid: GridSize,
    images: Vec<image::RgbaImage>,
    opts: &GridCameraOptions,
) -> Result<LightField> {
    let Some(first) = images.first() else {
        return Err(Error::Invalid(format!("{name}: the grid has no views")));
    };
    let (width, height) = first.dimensions();
    let cameras = cameras(grid, width, height, opts)?;
    let views = images
        .into_iter()
        .zip(cameras)
        .enumerate()
        .map(|(i, (image, camera))| super::View {
            s: i % grid.cols,
            t: i / grid.cols,
            camera,
            image,
            source: format!("{name} view (s {}, t {})", i % grid.cols, i / grid.cols),
        })
        .collect();
    let lf = LightField {
        name: name.to_string(),
        grid,
        width,
        height,
        views,
        depth: Vec::new(),
        rig: None,
        disparity_range: None,
        source: Source::Arrays,
    };
    lf.validate()?;
    Ok(lf)
}

/// Reads every view's header; views of different sizes are an error listing each size with
/// its count and an example file (mixed exports, thumbnails named like views).
fn check_sizes(paths: &[PathBuf], folder: &Path) -> Result<()> {
    let mut sizes: BTreeMap<(u32, u32), Vec<&PathBuf>> = BTreeMap::new();
    for p in paths {
        sizes.entry(probe_view(p)?).or_default().push(p);
    }
    if sizes.len() <= 1 {
        return Ok(());
    }
    let mut list: Vec<_> = sizes.into_iter().collect();
    list.sort_by_key(|(_, files)| std::cmp::Reverse(files.len()));
    let described: Vec<String> = list
        .iter()
        .map(|((w, h), files)| {
            format!(
                "{w}×{h} ({} view{}, e.g. {})",
                files.len(),
                if files.len() == 1 { "" } else { "s" },
                files[0].file_name().unwrap_or_default().to_string_lossy()
            )
        })
        .collect();
    Err(Error::LightField(format!(
        "{}: the views have {} different sizes: {}; all views of a light field must have one size",
        folder.display(),
        list.len(),
        described.join(", ")
    )))
}

/// The nominal parallel cameras of a grid folder (see the module docs), row-major.
pub fn cameras(
    grid: GridSize,
    width: u32,
    height: u32,
    opts: &GridCameraOptions,
) -> Result<Vec<Camera>> {
    let f = opts.focal_px.unwrap_or(width.max(height) as f64);
    if !(f.is_finite() && f > 0.0) {
        return Err(Error::Invalid(format!(
            "the focal length must be a positive number of pixels, not {f}"
        )));
    }
    if !(opts.baseline.is_finite() && opts.baseline > 0.0) {
        return Err(Error::Invalid(format!(
            "the baseline must be a positive number, not {}",
            opts.baseline
        )));
    }
    let k = intrinsics(
        f,
        f,
        (width as f64 - 1.0) / 2.0,
        (height as f64 - 1.0) / 2.0,
    );
    let c = grid.centre();
    Ok((0..grid.len())
        .map(|i| {
            let (s, t) = ((i % grid.cols) as f64, (i / grid.cols) as f64);
            let centre = DVec3::new((s - c.x) * opts.baseline, (t - c.y) * opts.baseline, 0.0);
            Camera::from_centre(k, DMat3::IDENTITY, centre)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::hci::tests::pixel;
    use image::RgbaImage;

    const W: u32 = 16;
    const H: u32 = 12;

    /// Writes a `rows × cols` grid with `name(row, col)` file names; the pixels encode (s, t)
    /// counted from 0.
    fn make(
        dir: &Path,
        rows: std::ops::Range<usize>,
        cols: std::ops::Range<usize>,
        name: impl Fn(usize, usize) -> String,
    ) {
        for r in rows.clone() {
            for c in cols.clone() {
                let (s, t) = (c - cols.start, r - rows.start);
                let img = RgbaImage::from_fn(W, H, |x, y| pixel(s, t, x, y));
                // RGB: JPEG cannot hold alpha.
                image::DynamicImage::ImageRgba8(img)
                    .to_rgb8()
                    .save(dir.join(name(r, c)))
                    .unwrap();
            }
        }
    }

    #[test]
    fn loads_stanford_names_in_row_major_order() {
        let dir = tempfile::tempdir().unwrap();
        // 2 rows × 3 columns, counted from 1 as some exports do.
        make(dir.path(), 1..3, 1..4, |r, c| {
            format!("out_{r:02}_{c:02}_-{}.5_{}.25_.png", 800 + c, 1000 + r)
        });
        std::fs::write(dir.path().join("readme.txt"), "not a view").unwrap();
        RgbaImage::new(4, 4)
            .save(dir.path().join("thumbnail.png"))
            .unwrap();
        let opts = GridCameraOptions::default();
        let lf = load(dir.path(), &opts).unwrap();
        lf.validate().unwrap();
        assert_eq!(lf.grid, GridSize { cols: 3, rows: 2 });
        assert_eq!((lf.width, lf.height), (W, H));
        assert!(lf.rig.is_none());
        assert!(lf.depth.is_empty());
        let Source::GridFolder { path, naming } = &lf.source else {
            panic!("not a grid folder: {:?}", lf.source);
        };
        assert_eq!(path, dir.path());
        assert!(
            naming.pattern.starts_with("out_{row}_{col}_{pos}_{pos}_"),
            "{naming:?}"
        );
        assert_eq!(naming.files, 6);
        for t in 0..2 {
            for s in 0..3 {
                let v = &lf.views[t * 3 + s];
                assert_eq!((v.s, v.t), (s, t));
                assert!(v
                    .source
                    .contains(&format!("out_{:02}_{:02}_", t + 1, s + 1)));
                assert_eq!(*v.image.get_pixel(5, 4), pixel(s, t, 5, 4));
            }
        }
        // Cameras: f = max(W, H), principal point at the centre, no sensor shift, baseline 1,
        // grid centre (1, 0.5).
        let cam = lf.view(2, 1).camera;
        assert_eq!(cam.k, intrinsics(16.0, 16.0, 7.5, 5.5));
        assert_eq!(cam.r, DMat3::IDENTITY);
        assert!((cam.centre() - DVec3::new(1.0, 0.5, 0.0)).length() < 1e-12);
        assert_eq!(lf.view(0, 0).camera.k, cam.k);
        assert!((lf.view(0, 0).camera.centre() - DVec3::new(-1.0, -0.5, 0.0)).length() < 1e-12);
    }

    #[test]
    fn options_set_focal_and_baseline() {
        let dir = tempfile::tempdir().unwrap();
        make(dir.path(), 0..3, 0..3, |r, c| {
            format!("Sub_{r:02}_{c:02}.JPG")
        });
        let opts = GridCameraOptions {
            focal_px: Some(40.0),
            baseline: 0.25,
        };
        let lf = load(dir.path(), &opts).unwrap();
        assert_eq!(lf.grid, GridSize { cols: 3, rows: 3 });
        let cam = lf.view(0, 2).camera;
        assert_eq!(cam.focal_px(), 40.0);
        assert!((cam.centre() - DVec3::new(-0.25, 0.25, 0.0)).length() < 1e-12);
        assert!((lf.view(1, 1).camera.centre()).length() < 1e-12);
        let bad = GridCameraOptions {
            focal_px: Some(-1.0),
            baseline: 1.0,
        };
        assert!(matches!(load(dir.path(), &bad), Err(Error::Invalid(_))));
        let bad = GridCameraOptions {
            focal_px: None,
            baseline: 0.0,
        };
        assert!(matches!(load(dir.path(), &bad), Err(Error::Invalid(_))));
    }

    #[test]
    fn no_views_explains_the_naming() {
        let dir = tempfile::tempdir().unwrap();
        RgbaImage::new(4, 4)
            .save(dir.path().join("image.png"))
            .unwrap();
        std::fs::write(dir.path().join("3_4.txt"), "").unwrap();
        let msg = load(dir.path(), &GridCameraOptions::default())
            .unwrap_err()
            .to_string();
        assert!(msg.contains(&dir.path().display().to_string()), "{msg}");
        assert!(
            msg.contains("no views found") && msg.contains("row_3_col_7.png"),
            "{msg}"
        );
    }

    #[test]
    fn incomplete_grid_names_the_first_missing_view() {
        let dir = tempfile::tempdir().unwrap();
        make(dir.path(), 2..5, 0..3, |r, c| {
            format!("row_{r}_col_{c}.png")
        });
        std::fs::remove_file(dir.path().join("row_3_col_1.png")).unwrap();
        std::fs::remove_file(dir.path().join("row_4_col_0.png")).unwrap();
        let msg = load(dir.path(), &GridCameraOptions::default())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("the first at row 3, column 1"), "{msg}");
        assert!(
            msg.contains("rows 2–4 (number 1) × columns 0–2 (number 2)"),
            "{msg}"
        );
        assert!(msg.contains("7 of 9 views"), "{msg}");
    }

    #[test]
    fn duplicate_view_names_both_files() {
        let dir = tempfile::tempdir().unwrap();
        make(dir.path(), 0..2, 0..2, |r, c| format!("{r:02}_{c:02}.png"));
        // The same rule, row 1 column 0 again without zero padding.
        RgbaImage::from_pixel(W, H, image::Rgba([1, 2, 3, 255]))
            .save(dir.path().join("1_0.png"))
            .unwrap();
        let msg = load(dir.path(), &GridCameraOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("01_00.png and 1_0.png are both row 1, column 0"),
            "{msg}"
        );
    }

    #[test]
    fn mismatched_view_size_is_named() {
        let dir = tempfile::tempdir().unwrap();
        make(dir.path(), 0..2, 0..2, |r, c| format!("{r}_{c}.png"));
        RgbaImage::new(W, H + 1)
            .save(dir.path().join("1_1.png"))
            .unwrap();
        let msg = load(dir.path(), &GridCameraOptions::default())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("1_1.png") && msg.contains("16×13"), "{msg}");
    }

    #[test]
    fn missing_folder_is_an_io_error() {
        let dir = tempfile::tempdir().unwrap();
        let err = load(&dir.path().join("nowhere"), &GridCameraOptions::default()).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err:?}");
        assert!(err.to_string().contains("nowhere"));
    }

    #[test]
    fn implausible_numbers_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["IMG_20240101_123456.png", "IMG_20250101_000001.png"] {
            RgbaImage::new(W, H).save(dir.path().join(name)).unwrap();
        }
        let msg = load(dir.path(), &GridCameraOptions::default())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("not a row and a column"), "{msg}");
    }

    #[test]
    fn a_stray_numbered_file_is_ignored_with_the_grid_loaded() {
        let dir = tempfile::tempdir().unwrap();
        make(dir.path(), 0..2, 0..2, |r, c| format!("{r:02}_{c:02}.png"));
        RgbaImage::new(W, H)
            .save(dir.path().join("thumbnail_512.png"))
            .unwrap();
        let lf = load(dir.path(), &GridCameraOptions::default()).unwrap();
        assert_eq!(lf.grid, GridSize { cols: 2, rows: 2 });
    }
}
