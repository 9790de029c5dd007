//! Folders of rectified views named by row and column.
//!
//! This covers sub-aperture exports of plenoptic cameras (Lytro toolboxes) and the Stanford
//! light field archive. Every image file (`.png`, `.jpg`, `.jpeg`, `.bmp`, any letter case)
//! directly inside the folder whose name stem contains at least two runs of ASCII digits is a
//! view; the first run is the row t, the second the column s:
//!
//! | file name                          | row | column |
//! |------------------------------------|-----|--------|
//! | `out_03_07_-859.7_1022.8_.png`     | 3   | 7      |
//! | `row_3_col_7.png`                  | 3   | 7      |
//! | `Sub_03_07.jpg`                    | 3   | 7      |
//! | `03_07.bmp`                        | 3   | 7      |
//!
//! Other files are ignored; an image file with fewer than two digit runs is ignored with a
//! warning. The smallest row and column found become t = 0 and s = 0 (exports often count
//! from 1), and the rows × columns grid must then be complete, one file per (row, column).
//!
//! The folder carries no calibration, so the cameras come from [`GridCameraOptions`]: a
//! parallel rig (R = I) without sensor shift, focal length `focal_px` (default max(W, H)),
//! principal point at the image centre ((W−1)/2, (H−1)/2), camera (s, t) centred at
//! ((s − s_c)·b, (t − t_c)·b, 0) with b = `baseline` (default 1) and (s_c, t_c) the grid
//! centre. Such views are usually rectified so that the zero-disparity plane is somewhere in
//! the scene rather than at infinity, so these cameras are only a nominal model; the light
//! field has no [`super::ParallelRig`] and `--disparity` means classic shift-and-sum.

use std::path::{Path, PathBuf};

use glam::{DMat3, DVec3};

use super::images::{decode_views_within, LoadLimits};
use super::{GridCameraOptions, GridSize, LightField, Source};
use crate::error::{Error, Result};
use crate::geometry::camera::{intrinsics, Camera};

/// Extensions (lower case) of the image files considered.
const EXTENSIONS: [&str; 4] = ["png", "jpg", "jpeg", "bmp"];

/// Largest grid extent accepted; guards against names like `IMG_20240101_123456.png`.
const MAX_GRID: usize = 10_000;

/// The first two maximal runs of ASCII digits of `stem` as (row, column); `None` when there are
/// fewer than two (or a run does not fit a `usize`).
pub fn row_col(stem: &str) -> Option<(usize, usize)> {
    let mut runs = stem
        .split(|c: char| !c.is_ascii_digit())
        .filter(|r| !r.is_empty());
    let row = runs.next()?.parse().ok()?;
    let col = runs.next()?.parse().ok()?;
    Some((row, col))
}

/// Loads a grid folder (see the module docs).
pub fn load(dir: &Path, opts: &GridCameraOptions) -> Result<LightField> {
    load_within(dir, opts, &LoadLimits::default())
}

/// [`load`], refusing before decoding a light field beyond `limits`.
pub fn load_within(
    dir: &Path,
    opts: &GridCameraOptions,
    limits: &LoadLimits,
) -> Result<LightField> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    // (row, col, path), in file-name order so messages do not depend on the file system.
    let mut found: Vec<(usize, usize, PathBuf)> = Vec::new();
    let mut files: Vec<PathBuf> = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        files.push(entry.path());
    }
    files.sort();
    let mut ignored: Vec<PathBuf> = Vec::new();
    for path in files {
        let is_image = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()));
        if !is_image || !path.is_file() {
            continue;
        }
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        match row_col(&stem) {
            Some((row, col)) => found.push((row, col, path)),
            None => ignored.push(path),
        }
    }
    if found.is_empty() {
        // One message for the folder, not one warning per file: most likely this is an HCI
        // folder without its parameters.cfg, or not a light field at all.
        let seen = match ignored.first() {
            Some(first) => format!(
                "; {} image files have no row and column in their names, e.g. {}",
                ignored.len(),
                first.file_name().unwrap_or_default().to_string_lossy()
            ),
            None => String::new(),
        };
        return Err(Error::bad_file(
            dir,
            format!(
                "no views found: the folder has no parameters.cfg (HCI), no tiltfield.json \
                 (manifest) and no views named by row and column{seen}; grid folders need image \
                 files (.png, .jpg, .jpeg, .bmp) whose names hold the row and the column as \
                 their first two numbers, e.g. 03_07.png, row_3_col_7.png, Sub_03_07.jpg or \
                 out_03_07_-859.7_1022.8_.png"
            ),
        ));
    }
    for path in &ignored {
        log::warn!(
            "{}: ignored: its name does not contain a row and a column number",
            path.display()
        );
    }

    let row0 = found.iter().map(|f| f.0).min().unwrap_or(0);
    let col0 = found.iter().map(|f| f.1).min().unwrap_or(0);
    let rows = found.iter().map(|f| f.0).max().unwrap_or(0) - row0 + 1;
    let cols = found.iter().map(|f| f.1).max().unwrap_or(0) - col0 + 1;
    if rows > MAX_GRID || cols > MAX_GRID {
        return Err(Error::LightField(format!(
            "{}: the file names span rows {row0}–{} and columns {col0}–{}, more than {MAX_GRID}; \
             are the first two numbers in the names really the row and the column?",
            dir.display(),
            row0 + rows - 1,
            col0 + cols - 1
        )));
    }
    let grid = GridSize { cols, rows };
    // Stable sort: among duplicates the file-name order is kept.
    found.sort_by_key(|f| (f.0, f.1));
    for pair in found.windows(2) {
        if (pair[0].0, pair[0].1) == (pair[1].0, pair[1].1) {
            return Err(Error::LightField(format!(
                "{}: {} and {} are both row {}, column {}",
                dir.display(),
                pair[0].2.display(),
                pair[1].2.display(),
                pair[0].0,
                pair[0].1
            )));
        }
    }
    // Sorted and unique: where the list departs from row-major order is the first gap.
    let missing = (0..grid.len()).find(|&n| {
        found
            .get(n)
            .map_or(true, |f| (f.0 - row0) * cols + (f.1 - col0) != n)
    });
    if let Some(n) = missing {
        return Err(Error::LightField(format!(
            "{}: the grid of rows {row0}–{} × columns {col0}–{} is incomplete: no view for row \
             {}, column {} ({} of {} views found)",
            dir.display(),
            row0 + rows - 1,
            col0 + cols - 1,
            row0 + n / cols,
            col0 + n % cols,
            found.len(),
            grid.len()
        )));
    }

    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| super::path_string(dir));
    let paths: Vec<PathBuf> = found.into_iter().map(|f| f.2).collect();
    let images = decode_views_within(&paths, &name, limits)?;
    let (width, height) = images[0].dimensions();
    let cameras = cameras(grid, width, height, opts)?;
    let views = super::grid_views(grid, images, cameras, &paths);
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
        },
    })
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
    fn parses_row_and_column_from_names() {
        assert_eq!(row_col("out_03_07_-859.7_1022.8_"), Some((3, 7)));
        assert_eq!(row_col("row_3_col_7"), Some((3, 7)));
        assert_eq!(row_col("Sub_03_07"), Some((3, 7)));
        assert_eq!(row_col("03_07"), Some((3, 7)));
        assert_eq!(row_col("12x4"), Some((12, 4)));
        assert_eq!(row_col("IMG_0001"), None);
        assert_eq!(row_col("centre"), None);
        assert_eq!(row_col("99999999999999999999999_1"), None);
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
        assert_eq!(
            lf.source,
            Source::GridFolder {
                path: dir.path().to_path_buf()
            }
        );
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
        assert!(msg.contains("no view for row 3, column 1"), "{msg}");
        assert!(msg.contains("rows 2–4 × columns 0–2"), "{msg}");
        assert!(msg.contains("7 of 9 views"), "{msg}");
    }

    #[test]
    fn duplicate_view_names_both_files() {
        let dir = tempfile::tempdir().unwrap();
        make(dir.path(), 0..2, 0..2, |r, c| format!("{r:02}_{c:02}.png"));
        RgbaImage::from_pixel(W, H, image::Rgba([1, 2, 3, 255]))
            .save(dir.path().join("row_1_col_0.bmp"))
            .unwrap();
        let msg = load(dir.path(), &GridCameraOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("01_00.png") && msg.contains("row_1_col_0.bmp"),
            "{msg}"
        );
        assert!(msg.contains("row 1, column 0"), "{msg}");
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
        make(dir.path(), 0..1, 0..1, |r, c| format!("{r}_{c}.png"));
        RgbaImage::new(W, H)
            .save(dir.path().join("IMG_20240101_123456.png"))
            .unwrap();
        let msg = load(dir.path(), &GridCameraOptions::default())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("really the row and the column"), "{msg}");
    }
}
