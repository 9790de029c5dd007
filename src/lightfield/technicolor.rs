//! Camera-array video in the layout of the Technicolor light field dataset (Sabater et al.,
//! "Dataset and Pipeline for Multi-View Light-Field Video", CVPR Workshops 2017).
//!
//! # Layout
//!
//! A folder holding `cameras_parameters.txt` ([`PARAMETERS_NAME`]) and the frames, either
//! directly in it or in its only sub-folder with image files:
//!
//! - `cameras_parameters.txt`: one header line, then one line per camera, values separated by
//!   spaces or tabs, either 12 values `f cu cv ar sk qw qx qy qz tx ty tz` (the pseudo-rectified
//!   "undist" frames) or 14 values `f cu cv ar sk d1 d2 qw qx qy qz tx ty tz` (the original
//!   frames with radial distortion). Every line has the same count. A first line that is all
//!   numbers is read as a camera (with a warning), blank lines and lines starting with `#` are
//!   skipped.
//!   - intrinsics in pixels: `K = [[f, sk, cu], [0, ar·f, cv], [0, 0, 1]]`, used as
//!     pixel-index coordinates (docs/conventions.md §1);
//!   - the rotation is the quaternion `(qw, qx, qy, qz)` (Hamilton convention, as COLMAP
//!     writes it) and with `t` it maps world to camera: `X_c = R X + t`. A quaternion whose
//!     norm is within [`QUATERNION_TOLERANCE`] of 1 is normalised (files print a limited
//!     number of digits); a zero quaternion or one further from unit norm is refused, since it
//!     usually means shifted columns;
//!   - `d1, d2`: radial distortion, undone on load ([`super::distortion`]).
//! - frames `<Scene>_undist_<frame>_<cam>.png` or `<Scene>_<frame>_<cam>.png` (the dataset
//!   writes 5 and 2 digits; any number of digits is read), `<cam>` the camera's line in the
//!   parameter file counted from 0 after the header. Frame numbers are taken as written (the
//!   dataset starts some scenes at 0, some at 1); `--frame N` names a frame by its number.
//!   `.jpg`, `.jpeg` and `.bmp` frames are read too. Any other image file in the frame folder
//!   is an error naming it; when both `_undist_` and plain frames are present, the ones that
//!   match the parameter file are used (12 values: undist, 14: original) and the others are
//!   ignored with a warning.
//!
//! # The rig grid
//!
//! Camera k sits at row `k div w` and column `k mod w` of the rig (row-major, as the dataset
//! numbers its 4 × 4 rig). The width `w` is not in the file, so it is inferred from the
//! calibrated camera centres: for every divisor `w` of the camera count, the centres in file
//! order are fitted by a regular grid `O + col·u + row·v` (least squares); a width fits when
//! the RMS residual is at most [`GRID_FIT_TOLERANCE`] of the smaller spacing and, for a 2-D
//! grid, u and v are at least 30° apart. Among the widths that fit, the one whose column
//! direction lies closest to the cameras' mean x axis wins (a single row is told from a
//! single column that way). A rig that fits no width is refused, naming the best fit. The
//! world frame is the calibration's; the grid position of camera k is (s, t) = (k mod w,
//! k div w), which is all the aperture and the virtual reference view need
//! (docs/conventions.md §2).
//!
//! The light field of one frame has no [`super::ParallelRig`] (the cameras are calibrated and
//! rotated), so `--disparity` means classic shift-and-sum; place the plane with `--plane` or
//! `--focus/--tilt/--swing` for a geometric refocus.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3};
use rayon::prelude::*;

use super::distortion::{undistort_image, RadialDistortion};
use super::grid_folder::{image_names, subfolders};
use super::images::{decode_views_opts, probe_view, LoadLimits};
use super::{GridSize, LightField, Source, MAX_COORDINATE};
use crate::error::{Error, Result};
use crate::geometry::camera::Camera;

/// The parameter file that marks a Technicolor-layout folder.
pub const PARAMETERS_NAME: &str = "cameras_parameters.txt";

/// How far the norm of a quaternion may be from 1 and still be normalised.
pub const QUATERNION_TOLERANCE: f64 = 1e-3;

/// Largest RMS residual of the grid fit of the camera centres, as a fraction of the spacing.
pub const GRID_FIT_TOLERANCE: f64 = 0.2;

/// Largest magnitude of an intrinsic value in pixels (as the manifest's limit).
const MAX_INTRINSIC: f64 = 1e8;

/// The columns of the two layouts, for messages.
const COLUMNS_12: &str = "f cu cv ar sk qw qx qy qz tx ty tz";
const COLUMNS_14: &str = "f cu cv ar sk d1 d2 qw qx qy qz tx ty tz";

/// The parsed `cameras_parameters.txt`.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    pub path: PathBuf,
    /// 12 (no distortion) or 14 (with d1, d2).
    pub columns: usize,
    /// Camera k of the file, in file order (= row-major grid order).
    pub cameras: Vec<Camera>,
    /// Per camera; all zero for 12-value files.
    pub distortion: Vec<RadialDistortion>,
    /// The rig grid inferred from the camera centres (see the module docs).
    pub grid: GridSize,
}

impl Calibration {
    /// True when some camera has non-zero distortion.
    pub fn has_distortion(&self) -> bool {
        self.distortion.iter().any(|d| !d.is_none())
    }
}

/// Reads and checks `cameras_parameters.txt`.
pub fn read_parameters(path: &Path) -> Result<Calibration> {
    let text = crate::io::read_text(path, "the camera parameters file")?;
    parse_parameters(&text, path)
}

/// Parses the text of a parameter file (`path` for messages); see the module docs.
pub fn parse_parameters(text: &str, path: &Path) -> Result<Calibration> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let bad = |m: String| Error::bad_file(path, m);
    let mut rows: Vec<(usize, Vec<f64>)> = Vec::new();
    let mut first = true;
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let parsed: std::result::Result<Vec<f64>, &str> = trimmed
            .split_whitespace()
            .map(|tok| tok.parse::<f64>().map_err(|_| tok))
            .collect();
        if first {
            first = false;
            match &parsed {
                // The header names the columns; the dataset always has one.
                Err(_) => continue,
                Ok(_) => log::warn!(
                    "{}: line {line_no} is all numbers, so it is read as camera 0, not as the \
                     header line",
                    path.display()
                ),
            }
        }
        let values = parsed.map_err(|tok| {
            let shown: String = tok.chars().take(24).collect();
            bad(format!("line {line_no}: '{shown}' is not a number"))
        })?;
        if !(values.len() == 12 || values.len() == 14) {
            return Err(bad(format!(
                "line {line_no} has {} values; each camera needs 12 ({COLUMNS_12}) or 14 \
                 ({COLUMNS_14})",
                values.len()
            )));
        }
        if let Some((first_line, v)) = rows.first() {
            if v.len() != values.len() {
                return Err(bad(format!(
                    "line {line_no} has {} values but line {first_line} has {}; every camera \
                     line must have the same count",
                    values.len(),
                    v.len()
                )));
            }
        }
        rows.push((line_no, values));
    }
    if rows.len() < 2 {
        return Err(bad(format!(
            "{} camera line{} found; a camera array needs at least two",
            if rows.is_empty() {
                "no".to_string()
            } else {
                "only one".to_string()
            },
            if rows.is_empty() { "s" } else { "" }
        )));
    }
    let columns = rows[0].1.len();
    let mut cameras = Vec::with_capacity(rows.len());
    let mut distortion = Vec::with_capacity(rows.len());
    for (k, (line_no, values)) in rows.iter().enumerate() {
        let (cam, d) = camera_from_values(values)
            .map_err(|m| bad(format!("line {line_no} (camera {k}): {m}")))?;
        cameras.push(cam);
        distortion.push(d);
    }
    let grid = infer_grid(&cameras).map_err(bad)?;
    Ok(Calibration {
        path: path.to_path_buf(),
        columns,
        cameras,
        distortion,
        grid,
    })
}

/// One camera line (12 or 14 values) → camera and distortion.
fn camera_from_values(v: &[f64]) -> std::result::Result<(Camera, RadialDistortion), String> {
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(format!("the value {x} is not finite"));
    }
    let (f, cu, cv, ar, sk) = (v[0], v[1], v[2], v[3], v[4]);
    let (d, rest) = if v.len() == 14 {
        (RadialDistortion { d1: v[5], d2: v[6] }, &v[7..])
    } else {
        (RadialDistortion::default(), &v[5..])
    };
    let (q, t) = (
        [rest[0], rest[1], rest[2], rest[3]],
        [rest[4], rest[5], rest[6]],
    );
    if !(f > 0.0 && ar > 0.0) {
        return Err(format!(
            "the focal length f = {f} and the aspect ratio ar = {ar} must be positive"
        ));
    }
    if let Some(x) = [f, cu, cv, sk, ar * f]
        .iter()
        .find(|x| x.abs() > MAX_INTRINSIC)
    {
        return Err(format!(
            "the intrinsic value {x:e} is beyond ±{MAX_INTRINSIC:e} px: not a camera"
        ));
    }
    if let Some(x) = t.iter().find(|x| x.abs() > MAX_COORDINATE) {
        return Err(format!(
            "the translation has the value {x:e}, beyond ±{MAX_COORDINATE:e}"
        ));
    }
    let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    let shown = format!(
        "(qw, qx, qy, qz) = ({}, {}, {}, {})",
        q[0], q[1], q[2], q[3]
    );
    if norm < 1e-12 {
        return Err(format!(
            "the quaternion {shown} is zero: no rotation; the columns are {COLUMNS_12} or \
             {COLUMNS_14}"
        ));
    }
    if (norm - 1.0).abs() > QUATERNION_TOLERANCE {
        return Err(format!(
            "the quaternion {shown} has norm {norm:.6}, not 1 (tolerance {QUATERNION_TOLERANCE:e}): \
             not a rotation; are the columns {COLUMNS_12} or {COLUMNS_14}?"
        ));
    }
    let r = DMat3::from_quat(DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize());
    let k = DMat3::from_cols(
        DVec3::new(f, 0.0, 0.0),
        DVec3::new(sk, ar * f, 0.0),
        DVec3::new(cu, cv, 1.0),
    );
    Ok((
        Camera {
            k,
            r,
            t: DVec3::from_array(t),
        },
        d,
    ))
}

/// A least-squares fit of camera centres by a regular grid of width `w`.
#[derive(Debug, Clone, Copy)]
struct GridFit {
    w: usize,
    /// RMS residual divided by the smaller spacing.
    relative_rms: f64,
    /// |cos| of the angle between the column direction and the cameras' mean x axis (or the
    /// row direction and their mean y axis, for a single column).
    alignment: f64,
    /// Both directions present and at least 30° apart (always true for one row or column).
    non_degenerate: bool,
}

fn fit_width(centres: &[DVec3], w: usize, x_axis: DVec3, y_axis: DVec3) -> Option<GridFit> {
    let n = centres.len();
    let rows = n / w;
    // Design [1, col, row] (dropping the axis of size 1); solve the normal equations.
    let coords = |k: usize| ((k % w) as f64, (k / w) as f64);
    let predict: Box<dyn Fn(usize) -> DVec3>;
    let (u, v);
    if w > 1 && rows > 1 {
        let mut m = DMat3::ZERO;
        let mut b = [DVec3::ZERO; 3];
        for (k, c) in centres.iter().enumerate() {
            let (s, t) = coords(k);
            let a = DVec3::new(1.0, s, t);
            m += DMat3::from_cols(a * a.x, a * a.y, a * a.z);
            for (bi, ai) in b.iter_mut().zip(a.to_array()) {
                *bi += *c * ai;
            }
        }
        if m.determinant().abs() < 1e-12 {
            return None;
        }
        let inv = m.inverse();
        // Row i of the solution is Σ_j inv[i][j] · b[j] (inv is symmetric).
        let sol: Vec<DVec3> = (0..3)
            .map(|i| (0..3).map(|j| b[j] * inv.col(j)[i]).sum())
            .collect();
        let (o, uu, vv) = (sol[0], sol[1], sol[2]);
        u = uu;
        v = vv;
        predict = Box::new(move |k| {
            let (s, t) = coords(k);
            o + uu * s + vv * t
        });
    } else {
        // One row (w = n) or one column (w = 1): a line through the centres in index order.
        let idx = |k: usize| {
            if w > 1 {
                (k % w) as f64
            } else {
                (k / w) as f64
            }
        };
        let mean_i = (0..n).map(idx).sum::<f64>() / n as f64;
        let mean_c = centres.iter().copied().sum::<DVec3>() / n as f64;
        let var: f64 = (0..n).map(|k| (idx(k) - mean_i).powi(2)).sum();
        let slope: DVec3 = centres
            .iter()
            .enumerate()
            .map(|(k, c)| (*c - mean_c) * (idx(k) - mean_i))
            .sum::<DVec3>()
            / var;
        if w > 1 {
            u = slope;
            v = DVec3::ZERO;
        } else {
            u = DVec3::ZERO;
            v = slope;
        }
        predict = Box::new(move |k| mean_c + slope * (idx(k) - mean_i));
    }
    let spacing = match (w > 1, rows > 1) {
        (true, true) => u.length().min(v.length()),
        (true, false) => u.length(),
        _ => v.length(),
    };
    if !(spacing.is_finite() && spacing > 0.0) {
        return None;
    }
    let rms = (centres
        .iter()
        .enumerate()
        .map(|(k, c)| (predict(k) - *c).length_squared())
        .sum::<f64>()
        / n as f64)
        .sqrt();
    let non_degenerate = !(w > 1 && rows > 1) || u.normalize().cross(v.normalize()).length() >= 0.5;
    let alignment = if w > 1 {
        u.normalize().dot(x_axis).abs()
    } else {
        v.normalize().dot(y_axis).abs()
    };
    Some(GridFit {
        w,
        relative_rms: rms / spacing,
        alignment,
        non_degenerate,
    })
}

/// The rig grid of `cameras` in file order (see the module docs), or why there is none.
pub fn infer_grid(cameras: &[Camera]) -> std::result::Result<GridSize, String> {
    let n = cameras.len();
    let centres: Vec<DVec3> = cameras.iter().map(Camera::centre).collect();
    // Rows of R are the camera axes in world coordinates.
    let x_axis = cameras
        .iter()
        .map(|c| c.r.row(0))
        .sum::<DVec3>()
        .normalize_or_zero();
    let y_axis = cameras
        .iter()
        .map(|c| c.r.row(1))
        .sum::<DVec3>()
        .normalize_or_zero();
    let fits: Vec<GridFit> = (1..=n)
        .filter(|w| n % w == 0)
        .filter_map(|w| fit_width(&centres, w, x_axis, y_axis))
        .collect();
    let good = fits
        .iter()
        .filter(|f| f.non_degenerate && f.relative_rms <= GRID_FIT_TOLERANCE)
        .max_by(|a, b| {
            a.alignment
                .total_cmp(&b.alignment)
                .then(b.relative_rms.total_cmp(&a.relative_rms))
        });
    match good {
        Some(f) => Ok(GridSize {
            cols: f.w,
            rows: n / f.w,
        }),
        None => {
            let best = fits
                .iter()
                .filter(|f| f.non_degenerate)
                .min_by(|a, b| a.relative_rms.total_cmp(&b.relative_rms));
            let why = match best {
                Some(f) => format!(
                    "the best, {} cameras wide, is off by {:.0} % of a camera spacing (at most \
                     {:.0} % accepted)",
                    f.w,
                    100.0 * f.relative_rms,
                    100.0 * GRID_FIT_TOLERANCE
                ),
                None => "all camera centres coincide or lie on one line out of order".into(),
            };
            Err(format!(
                "the {n} camera centres do not form a regular grid in row-major order (camera k \
                 at row k div w, column k mod w) for any width w that divides {n}: {why}"
            ))
        }
    }
}

/// A frame file name, parsed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameName {
    pub scene: String,
    /// `_undist_` in the name.
    pub undist: bool,
    pub frame: u64,
    pub camera: usize,
}

/// Parses `<Scene>[_undist]_<frame>_<cam>.<ext>`; `None` for any other name.
pub fn parse_frame_name(name: &str) -> Option<FrameName> {
    let stem = &name[..name.rfind('.')?];
    let mut parts = stem.rsplitn(3, '_');
    let cam = parts.next()?;
    let frame = parts.next()?;
    let prefix = parts.next()?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !(digits(cam) && digits(frame)) || prefix.is_empty() {
        return None;
    }
    let (scene, undist) = match prefix.strip_suffix("_undist") {
        Some(s) if !s.is_empty() => (s, true),
        _ => (prefix, false),
    };
    Some(FrameName {
        scene: scene.to_string(),
        undist,
        frame: frame.parse().ok()?,
        camera: cam.parse().ok()?,
    })
}

/// What `info` and reports say about the frame a light field came from.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct VideoFrameInfo {
    /// The video folder (holding `cameras_parameters.txt`).
    pub path: PathBuf,
    pub scene: String,
    /// This frame's number.
    pub frame: u64,
    /// How many frames the video has, and the first and last frame numbers.
    pub frames: usize,
    pub first_frame: u64,
    pub last_frame: u64,
    /// 12 or 14 values per camera.
    pub parameter_columns: usize,
    /// Radial distortion was removed on load.
    pub undistorted_on_load: bool,
    /// Frames named `_undist_`.
    pub undist_names: bool,
}

/// A Technicolor-layout video: calibration and the frame files (no pixels).
#[derive(Debug, Clone)]
pub struct TechnicolorVideo {
    /// The folder holding `cameras_parameters.txt`.
    pub folder: PathBuf,
    /// The folder holding the frames (the same or its sub-folder).
    pub image_folder: PathBuf,
    pub scene: String,
    pub undist_names: bool,
    pub calibration: Calibration,
    /// View size (of the first frame's first file).
    pub width: u32,
    pub height: u32,
    /// Frame numbers in increasing order.
    pub frame_numbers: Vec<u64>,
    /// Per frame number, the file of each camera (`None`: missing).
    files: BTreeMap<u64, Vec<Option<PathBuf>>>,
}

/// True when `path` is a folder in the Technicolor layout: it has an entry named
/// `cameras_parameters.txt`, whatever it is. A parameters file that is a folder, a FIFO or a
/// dangling link still makes the folder a video, so reading it names the real problem instead
/// of loading the views as a plain grid.
pub fn is_technicolor(path: &Path) -> bool {
    path.is_dir() && std::fs::symlink_metadata(path.join(PARAMETERS_NAME)).is_ok()
}

/// Frame numbers as compact ranges ("1–100, 102–300").
pub fn describe_frames(frames: &[u64]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < frames.len() {
        let mut j = i;
        while j + 1 < frames.len() && frames[j].checked_add(1) == Some(frames[j + 1]) {
            j += 1;
        }
        parts.push(if i == j {
            frames[i].to_string()
        } else {
            format!("{}–{}", frames[i], frames[j])
        });
        i = j + 1;
    }
    if parts.len() > 6 {
        let n = parts.len();
        format!("{}, … , {} ({n} runs)", parts[..3].join(", "), parts[n - 1])
    } else {
        parts.join(", ")
    }
}

impl TechnicolorVideo {
    /// Reads the calibration and lists the frames of the video in `folder`.
    pub fn open(folder: &Path) -> Result<Self> {
        let calibration = read_parameters(&folder.join(PARAMETERS_NAME))?;
        let n = calibration.cameras.len();
        let mut image_folder = folder.to_path_buf();
        let mut names = image_names(folder)?;
        if names.is_empty() {
            let mut with_images = Vec::new();
            for sub in subfolders(folder)? {
                let sub_names = image_names(&sub)?;
                if !sub_names.is_empty() {
                    with_images.push((sub, sub_names));
                }
            }
            match with_images.len() {
                0 => {
                    return Err(Error::LightField(format!(
                        "{}: no frames found next to {PARAMETERS_NAME} or in a sub-folder; \
                         frames are named <Scene>_undist_<frame:05d>_<cam:02d>.png or \
                         <Scene>_<frame:05d>_<cam:02d>.png",
                        folder.display()
                    )))
                }
                1 => {
                    let (sub, sub_names) = with_images.pop().expect("one sub-folder");
                    image_folder = sub;
                    names = sub_names;
                }
                _ => {
                    return Err(Error::LightField(format!(
                        "{}: the frames must be next to {PARAMETERS_NAME} or in one sub-folder, \
                         but {} sub-folders hold images: {}",
                        folder.display(),
                        with_images.len(),
                        with_images
                            .iter()
                            .map(|(p, _)| p.file_name().unwrap_or_default().to_string_lossy())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )))
                }
            }
        }
        let mut parsed = Vec::with_capacity(names.len());
        for name in &names {
            let f = parse_frame_name(name).ok_or_else(|| {
                Error::bad_file(
                    image_folder.join(name),
                    "not a frame of a Technicolor-layout video: frames are named \
                     <Scene>_undist_<frame:05d>_<cam:02d>.png or \
                     <Scene>_<frame:05d>_<cam:02d>.png; move other images out of the folder",
                )
            })?;
            parsed.push((name, f));
        }
        let scenes: BTreeSet<&str> = parsed.iter().map(|(_, f)| f.scene.as_str()).collect();
        if scenes.len() > 1 {
            return Err(Error::LightField(format!(
                "{}: frames of {} scenes in one folder ({}); give each scene its own folder",
                image_folder.display(),
                scenes.len(),
                scenes.into_iter().collect::<Vec<_>>().join(", ")
            )));
        }
        let scene = scenes.into_iter().next().unwrap_or_default().to_string();
        let kinds: BTreeSet<bool> = parsed.iter().map(|(_, f)| f.undist).collect();
        let undist = if kinds.len() > 1 {
            // The parameter file says which frames it describes.
            let undist = calibration.columns == 12;
            log::warn!(
                "{}: both _undist_ and original frames are present; using the {} ones, which \
                 {PARAMETERS_NAME} ({} values per camera) describes",
                image_folder.display(),
                if undist { "_undist_" } else { "original" },
                calibration.columns
            );
            undist
        } else {
            kinds.into_iter().next().unwrap_or(false)
        };
        let mut files: BTreeMap<u64, Vec<Option<PathBuf>>> = BTreeMap::new();
        for (name, f) in parsed.iter().filter(|(_, f)| f.undist == undist) {
            if f.camera >= n {
                return Err(Error::bad_file(
                    image_folder.join(name),
                    format!(
                        "camera {} of frame {}, but {PARAMETERS_NAME} describes {n} cameras \
                         (0–{})",
                        f.camera,
                        f.frame,
                        n - 1
                    ),
                ));
            }
            let slot = &mut files.entry(f.frame).or_insert_with(|| vec![None; n])[f.camera];
            if let Some(other) = slot {
                return Err(Error::LightField(format!(
                    "{}: {} and {name} are both camera {} of frame {}",
                    image_folder.display(),
                    other.file_name().unwrap_or_default().to_string_lossy(),
                    f.camera,
                    f.frame
                )));
            }
            *slot = Some(image_folder.join(name));
        }
        let first_file = files
            .values()
            .flat_map(|v| v.iter().flatten())
            .next()
            .cloned()
            .ok_or_else(|| {
                Error::LightField(format!("{}: no frames found", image_folder.display()))
            })?;
        let (width, height) = probe_view(&first_file)?;
        for (k, (cam, d)) in calibration
            .cameras
            .iter()
            .zip(&calibration.distortion)
            .enumerate()
        {
            d.check(cam.k, width, height)
                .map_err(|m| Error::bad_file(&calibration.path, format!("camera {k}: {m}")))?;
        }
        Ok(TechnicolorVideo {
            folder: folder.to_path_buf(),
            image_folder,
            scene,
            undist_names: undist,
            frame_numbers: files.keys().copied().collect(),
            calibration,
            width,
            height,
            files,
        })
    }

    /// The cameras missing from `frame`; `None` when the video has no such frame.
    pub fn missing_cameras(&self, frame: u64) -> Option<Vec<usize>> {
        self.files.get(&frame).map(|v| {
            v.iter()
                .enumerate()
                .filter(|(_, p)| p.is_none())
                .map(|(k, _)| k)
                .collect()
        })
    }

    /// Checks that `frame` exists and has every camera.
    pub fn check_frame(&self, frame: u64) -> Result<()> {
        match self.missing_cameras(frame) {
            None => Err(Error::Invalid(format!(
                "{}: there is no frame {frame}; the video has frames {}",
                self.folder.display(),
                describe_frames(&self.frame_numbers)
            ))),
            Some(missing) if !missing.is_empty() => {
                // A frame's file that is there but is no image file (a folder, a FIFO, a
                // device, a dangling link) is named as what it is, not as missing.
                let not_files: Vec<String> = missing
                    .iter()
                    .filter_map(|&k| {
                        let name = format!(
                            "{}{}_{frame:05}_{k:02}.png",
                            self.scene,
                            if self.undist_names { "_undist" } else { "" }
                        );
                        let path = self.image_folder.join(&name);
                        let meta = std::fs::symlink_metadata(&path).ok()?;
                        let kind = if meta.file_type().is_symlink() && !path.exists() {
                            "a dangling link"
                        } else {
                            crate::io::kind_of(&std::fs::metadata(&path).unwrap_or(meta))
                        };
                        Some(format!("{name} is {kind}, not an image file"))
                    })
                    .collect();
                Err(Error::LightField(format!(
                    "{}: frame {frame} lacks camera{} {} (of 0–{}){}",
                    self.image_folder.display(),
                    if missing.len() == 1 { "" } else { "s" },
                    missing
                        .iter()
                        .map(|k| k.to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                    self.calibration.cameras.len() - 1,
                    if not_files.is_empty() {
                        String::new()
                    } else {
                        format!(": {}", not_files.join("; "))
                    }
                )))
            }
            Some(_) => Ok(()),
        }
    }

    /// Decodes frame `frame` (progress bar on stderr when `progress`), undoes the radial
    /// distortion, and returns it as a light field.
    pub fn load_frame(
        &self,
        frame: u64,
        limits: &LoadLimits,
        progress: bool,
    ) -> Result<LightField> {
        self.check_frame(frame)?;
        let paths: Vec<PathBuf> = self.files[&frame].iter().flatten().cloned().collect();
        let what = format!("{} frame {frame}", self.scene);
        let mut images = decode_views_opts(&paths, &what, limits, progress)?;
        if let Some((img, p)) = images
            .iter()
            .zip(&paths)
            .find(|(img, _)| img.dimensions() != (self.width, self.height))
        {
            return Err(Error::LightField(format!(
                "{}: {} is {}×{}, but the video's views are {}×{}",
                what,
                p.display(),
                img.width(),
                img.height(),
                self.width,
                self.height
            )));
        }
        let cal = &self.calibration;
        if cal.has_distortion() {
            let outside: usize = images
                .par_iter_mut()
                .zip(cal.cameras.par_iter().zip(&cal.distortion))
                .map(|(img, (cam, d))| {
                    let (out, outside) = undistort_image(img, cam.k, *d);
                    *img = out;
                    outside
                })
                .sum();
            if outside > 0 {
                log::debug!(
                    "{what}: {outside} undistorted pixels lie beyond their view's edge and \
                     repeat the edge pixel"
                );
            }
        }
        let views = super::grid_views(cal.grid, images, cal.cameras.clone(), &paths);
        Ok(LightField {
            name: what,
            grid: cal.grid,
            width: self.width,
            height: self.height,
            views,
            depth: Vec::new(),
            rig: None,
            disparity_range: None,
            source: Source::TechnicolorVideo(self.frame_info(frame)),
        })
    }

    /// The report of frame `frame`.
    pub fn frame_info(&self, frame: u64) -> VideoFrameInfo {
        VideoFrameInfo {
            path: self.folder.clone(),
            scene: self.scene.clone(),
            frame,
            frames: self.frame_numbers.len(),
            first_frame: self.frame_numbers.first().copied().unwrap_or(0),
            last_frame: self.frame_numbers.last().copied().unwrap_or(0),
            parameter_columns: self.calibration.columns,
            undistorted_on_load: self.calibration.has_distortion(),
            undist_names: self.undist_names,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 12-value line for a camera at `centre` with rotation `q` (w, x, y, z).
    fn line(f: f64, q: [f64; 4], centre: DVec3) -> String {
        let r = DMat3::from_quat(DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize());
        let t = -(r * centre);
        format!(
            "{f} 31.5 23.5 1 0 {} {} {} {} {} {} {}",
            q[0], q[1], q[2], q[3], t.x, t.y, t.z
        )
    }

    fn rig(w: usize, h: usize) -> Vec<String> {
        let mut lines = vec!["f cu cv ar sk qw qx qy qz tx ty tz".to_string()];
        for k in 0..w * h {
            let c = DVec3::new((k % w) as f64 * 0.1, (k / w) as f64 * 0.1, 0.0);
            lines.push(line(50.0, [1.0, 0.0, 0.0, 0.0], c));
        }
        lines
    }

    fn parse(lines: &[String]) -> Result<Calibration> {
        parse_parameters(&lines.join("\n"), Path::new("cameras_parameters.txt"))
    }

    #[test]
    fn grid_width_comes_from_the_camera_centres() {
        for (w, h) in [(4, 4), (3, 2), (2, 3), (5, 1), (1, 4), (2, 2)] {
            let cal = parse(&rig(w, h)).unwrap();
            assert_eq!(cal.grid, GridSize { cols: w, rows: h }, "{w}×{h}");
        }
    }

    #[test]
    fn scattered_centres_are_refused() {
        let mut lines = rig(2, 2);
        // Camera 3 far off the grid.
        lines[4] = line(50.0, [1.0, 0.0, 0.0, 0.0], DVec3::new(0.5, -0.3, 0.2));
        let e = parse(&lines).unwrap_err().to_string();
        assert!(e.contains("do not form a regular grid"), "{e}");
    }

    #[test]
    fn intrinsics_follow_the_documented_layout() {
        let text = "hdr\n100 30 20 1.5 0.25 1 0 0 0 1 2 3\n100 30 20 1.5 0.25 1 0 0 0 2 2 3\n";
        let cal = parse_parameters(text, Path::new("p.txt")).unwrap();
        let k = cal.cameras[0].k;
        assert_eq!(k.row(0), DVec3::new(100.0, 0.25, 30.0));
        assert_eq!(k.row(1), DVec3::new(0.0, 150.0, 20.0));
        assert_eq!(k.row(2), DVec3::new(0.0, 0.0, 1.0));
        assert_eq!(cal.cameras[1].t, DVec3::new(2.0, 2.0, 3.0));
        assert_eq!(cal.columns, 12);
    }

    #[test]
    fn quaternions_near_unit_are_normalised_others_refused() {
        let mut lines = rig(2, 1);
        // Printed with few digits: norm 1.0004 → normalised.
        lines[1] = line(50.0, [0.7074, 0.0, 0.7074, 0.0], DVec3::ZERO);
        let cal = parse(&lines).unwrap();
        let r = cal.cameras[0].r;
        assert!((r.transpose() * r - DMat3::IDENTITY).abs_diff_eq(DMat3::ZERO, 1e-12));
        // Norm 2: refused.
        let mut bad = rig(2, 1);
        bad[2] = "50 31.5 23.5 1 0 2 0 0 0 -0.1 0 0".into();
        let e = parse(&bad).unwrap_err().to_string();
        assert!(
            e.contains("line 3 (camera 1)") && e.contains("norm 2.000000"),
            "{e}"
        );
        bad[2] = "50 31.5 23.5 1 0 0 0 0 0 -0.1 0 0".into();
        let e = parse(&bad).unwrap_err().to_string();
        assert!(e.contains("is zero"), "{e}");
    }

    #[test]
    fn short_rows_and_mixed_counts_are_refused() {
        let mut lines = rig(2, 1);
        lines[2] = "50 31.5 23.5 1 0 1 0 0 0 -0.1 0".into();
        let e = parse(&lines).unwrap_err().to_string();
        assert!(
            e.contains("line 3 has 11 values") && e.contains("14"),
            "{e}"
        );
        let mut lines = rig(2, 1);
        lines[2] = "50 31.5 23.5 1 0 0 0 1 0 0 0 -0.1 0 0".into();
        let e = parse(&lines).unwrap_err().to_string();
        assert!(e.contains("line 3 has 14 values but line 2 has 12"), "{e}");
        let mut lines = rig(2, 1);
        lines[1] = lines[1].replacen("50", "fifty", 1);
        let e = parse(&lines).unwrap_err().to_string();
        assert!(e.contains("line 2: 'fifty' is not a number"), "{e}");
        let e = parse(&rig(1, 1)).unwrap_err().to_string();
        assert!(e.contains("only one camera line"), "{e}");
    }

    #[test]
    fn frame_names_parse_both_spellings() {
        assert_eq!(
            parse_frame_name("Birthday_undist_00001_03.png"),
            Some(FrameName {
                scene: "Birthday".into(),
                undist: true,
                frame: 1,
                camera: 3
            })
        );
        assert_eq!(
            parse_frame_name("My_Scene_00000_15.png"),
            Some(FrameName {
                scene: "My_Scene".into(),
                undist: false,
                frame: 0,
                camera: 15
            })
        );
        assert_eq!(parse_frame_name("Birthday_00001.png"), None);
        assert_eq!(parse_frame_name("Birthday_00001_03_mask.png"), None);
        assert_eq!(parse_frame_name("_00001_03.png"), None);
    }

    #[test]
    fn frame_ranges_are_described_compactly() {
        assert_eq!(describe_frames(&[1, 2, 3, 5, 7, 8]), "1–3, 5, 7–8");
        assert_eq!(describe_frames(&[]), "");
    }
}
