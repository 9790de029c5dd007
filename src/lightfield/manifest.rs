//! The tiltfield manifest: a JSON file describing a calibrated camera array.
//!
//! This is how rigs with arbitrary, calibrated cameras (rotated cameras, different intrinsics,
//! camera-array video such as the Technicolor rig) come in. A folder holding a file named
//! `tiltfield.json` ([`DEFAULT_NAME`]) opens as a manifest, as does any `.json` file given
//! directly.
//!
//! # Example
//!
//! A 2 × 2 grid (two columns, two rows), the right-hand cameras toed in by 2°:
//!
//! ```json
//! {
//!   "version": 1,
//!   "name": "desk",
//!   "views": [
//!     {
//!       "image": "cam_0_0.png",
//!       "grid": { "s": 0, "t": 0 },
//!       "K": [[1000.0, 0.0, 639.5], [0.0, 1000.0, 359.5], [0.0, 0.0, 1.0]],
//!       "R": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
//!       "t": [0.05, 0.05, 0.0],
//!       "depth": "depth_0_0.exr"
//!     },
//!     {
//!       "image": "cam_1_0.png",
//!       "grid": { "s": 1, "t": 0 },
//!       "K": [[1000.0, 0.0, 639.5], [0.0, 1000.0, 359.5], [0.0, 0.0, 1.0]],
//!       "R": [[0.99939083, 0.0, 0.0348995], [0.0, 1.0, 0.0], [-0.0348995, 0.0, 0.99939083]],
//!       "centre": [0.05, -0.05, 0.0]
//!     },
//!     {
//!       "image": "cam_0_1.png",
//!       "grid": { "s": 0, "t": 1 },
//!       "K": [[1000.0, 0.0, 639.5], [0.0, 1000.0, 359.5], [0.0, 0.0, 1.0]],
//!       "R": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
//!       "t": [0.05, -0.05, 0.0],
//!       "disparity": "disp_0_1.pfm"
//!     },
//!     {
//!       "image": "cam_1_1.png",
//!       "grid": { "s": 1, "t": 1 },
//!       "K": [[1000.0, 0.0, 639.5], [0.0, 1000.0, 359.5], [0.0, 0.0, 1.0]],
//!       "R": [[0.99939083, 0.0, 0.0348995], [0.0, 1.0, 0.0], [-0.0348995, 0.0, 0.99939083]],
//!       "centre": [0.05, 0.05, 0.0]
//!     }
//!   ]
//! }
//! ```
//!
//! # Fields
//!
//! Top level (unknown keys are an error, so a typo never passes silently):
//! - `version` (required): `1`. Other versions are refused with a message saying so.
//! - `name` (optional): a short name for messages; default: the manifest's file stem, or its
//!   folder's name for `tiltfield.json`.
//! - `views` (required): one entry per view, in any order; tiltfield sorts them.
//! - `rig` (optional): `{"focal_px": f, "baseline": b, "focus_distance": z}` declares that the
//!   views form a regular, parallel grid with sensor shift as in the HCI benchmark, so that
//!   `--disparity` and disparity maps follow the HCI convention (`1/Z = d/(b·f) + 1/Z_focus`,
//!   positive disparity nearer than `focus_distance`). All three must be positive. The cameras
//!   given per view are still the ones used for rendering; when they deviate from the declared
//!   rig (beyond 0.5 px in K, 1 % of the baseline in position or 10⁻³ in rotation) a warning
//!   says so. Without `rig`, `--disparity` means classic shift-and-sum.
//!
//! Per view:
//! - `image` (required): the view's image file (PNG 8/16 bit, JPEG, BMP). All views must have
//!   the same size.
//! - `grid` (required): `{"s": column, "t": row}`, 0-based. The grid is `cols = max s + 1` by
//!   `rows = max t + 1` and must be complete: every (s, t) exactly once.
//! - `K` (required): intrinsics `[[fx, skew, cx], [0, fy, cy], [0, 0, 1]]` in pixel-index
//!   coordinates: the centre of the top-left pixel is (0, 0), as in OpenCV, so the image centre
//!   of a W × H view is ((W−1)/2, (H−1)/2). (MATLAB calibrations count pixels from 1: subtract 1
//!   from their cx and cy.) fx, fy > 0; the last row must be `[0, 0, 1]` and `K[1][0]` must
//!   be 0; a skew `K[0][1]` is allowed.
//! - `R` (required): the world → camera rotation, a proper rotation matrix
//!   (‖RᵀR − I‖ ≤ 10⁻⁶, det R = +1). Print it with enough digits.
//! - exactly one of `t`, the world → camera translation (`X_c = R X + t`), or `centre`, the
//!   camera centre in world coordinates (`C = −Rᵀ t`).
//! - `depth` (optional): a depth map of this view (distance along the optical axis, world
//!   units), and/or `disparity` (optional): a disparity map (pixels per grid step, HCI sign).
//!   `.pfm` (see [`super::pfm`]; rows are flipped to top-down) or `.exr` (the channel named `Z`,
//!   else `Y`, else `R` — also as `layer.Z` and so on — else the only channel; f16, f32 and u32
//!   samples are read as f32). Same size as the views; non-finite values mean "no value".
//!
//! Matrices are row-major nested arrays, as written on paper: `K[0]` is the first row. Camera
//! axes: x right, y down, z forward. The world frame is whatever the calibration used. Relative
//! paths are relative to the manifest's folder. All numbers must be finite.
//!
//! Errors name the manifest and the offending view by index and image name, e.g.
//! `rig/tiltfield.json: view 3 (cam_1_1.png): R is not a rotation (‖RᵀR − I‖ = 2.1e-2)`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{DMat3, DVec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::images::{decode_views_within, LoadLimits};
use super::pfm::{encode_pfm, read_pfm_depth};
use super::{relative_to, DepthKind, DepthMap, GridSize, LightField, ParallelRig, Source, View};
use crate::error::{Error, Result};
use crate::geometry::camera::Camera;

/// File name looked for inside a folder.
pub const DEFAULT_NAME: &str = "tiltfield.json";

/// The manifest version this build reads and writes.
pub const VERSION: u32 = 1;

/// Largest grid coordinate accepted; guards against typos like `"s": 1000000`.
const MAX_GRID: usize = 10_000;

/// Largest magnitude of an entry of K, in pixels (a focal length of 10⁸ px is a 1000 m lens on
/// a 10 µm pixel).
const MAX_INTRINSIC: f64 = 1e8;

/// Largest magnitude of a camera coordinate, in world units.
const MAX_COORDINATE: f64 = 1e12;

/// Tolerance for ‖RᵀR − I‖ (Frobenius).
const ROTATION_TOLERANCE: f64 = 1e-6;

/// The manifest file, as serialised.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManifestFile {
    pub version: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub views: Vec<ViewEntry>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig: Option<RigEntry>,
}

/// One view of the manifest.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewEntry {
    pub image: String,
    pub grid: GridPos,
    /// Intrinsics, row-major.
    #[serde(rename = "K")]
    pub k: [[f64; 3]; 3],
    /// World → camera rotation, row-major.
    #[serde(rename = "R")]
    pub r: [[f64; 3]; 3],
    /// World → camera translation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t: Option<[f64; 3]>,
    /// Camera centre in world coordinates (alternative to `t`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centre: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disparity: Option<String>,
}

/// Grid position: column `s`, row `t`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridPos {
    pub s: usize,
    pub t: usize,
}

/// The optional regular-rig declaration.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigEntry {
    pub focal_px: f64,
    pub baseline: f64,
    pub focus_distance: f64,
}

/// Row-major nested array (as written on paper) → glam's column-major matrix.
pub fn mat_from_rows(m: &[[f64; 3]; 3]) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(m[0][0], m[1][0], m[2][0]),
        DVec3::new(m[0][1], m[1][1], m[2][1]),
        DVec3::new(m[0][2], m[1][2], m[2][2]),
    )
}

/// glam matrix → row-major nested array.
pub fn mat_to_rows(m: DMat3) -> [[f64; 3]; 3] {
    [
        m.row(0).to_array(),
        m.row(1).to_array(),
        m.row(2).to_array(),
    ]
}

/// Checks one view's numbers and builds its camera. Errors are messages without the manifest
/// path; the caller prefixes it and the view's label.
fn view_camera(v: &ViewEntry) -> std::result::Result<Camera, String> {
    let all_finite = |m: &[[f64; 3]; 3]| m.iter().flatten().all(|x| x.is_finite());
    if !all_finite(&v.k) {
        return Err("K has a non-finite entry".into());
    }
    if !all_finite(&v.r) {
        return Err("R has a non-finite entry".into());
    }
    let k = v.k;
    // Beyond these magnitudes no real camera exists and the homographies lose all precision
    // (1e300 squared is infinite): refuse rather than render nonsense.
    if let Some(x) = v.k.iter().flatten().find(|x| x.abs() > MAX_INTRINSIC) {
        return Err(format!(
            "K has the entry {x:e}, beyond ±{MAX_INTRINSIC:e} px: not a camera"
        ));
    }
    if let Some(x) =
        v.t.iter()
            .chain(&v.centre)
            .flatten()
            .find(|x| x.abs() > MAX_COORDINATE)
    {
        return Err(format!(
            "the camera position has the coordinate {x:e}, beyond ±{MAX_COORDINATE:e}"
        ));
    }
    if !(k[0][0] > 0.0 && k[1][1] > 0.0) {
        return Err(format!(
            "K must have positive focal lengths, found fx = {}, fy = {}",
            k[0][0], k[1][1]
        ));
    }
    let exact = |a: f64, b: f64| (a - b).abs() <= 1e-12;
    if !(exact(k[2][0], 0.0) && exact(k[2][1], 0.0) && exact(k[2][2], 1.0)) {
        return Err(format!("K's last row must be [0, 0, 1], found {:?}", k[2]));
    }
    if !exact(k[1][0], 0.0) {
        return Err(format!("K[1][0] must be 0, found {}", k[1][0]));
    }
    let r = mat_from_rows(&v.r);
    let d = r.transpose() * r - DMat3::IDENTITY;
    let dev =
        (d.x_axis.length_squared() + d.y_axis.length_squared() + d.z_axis.length_squared()).sqrt();
    if dev > ROTATION_TOLERANCE {
        return Err(format!(
            "R is not a rotation (‖RᵀR − I‖ = {dev:.1e}, tolerance {ROTATION_TOLERANCE:.0e}; \
             write it with more digits if it is one)"
        ));
    }
    if r.determinant() < 0.0 {
        return Err("R is a reflection (det R = −1), not a rotation".into());
    }
    let k = mat_from_rows(&v.k);
    match (v.t, v.centre) {
        (Some(t), None) if t.iter().all(|x| x.is_finite()) => Ok(Camera {
            k,
            r,
            t: DVec3::from_array(t),
        }),
        (None, Some(c)) if c.iter().all(|x| x.is_finite()) => {
            Ok(Camera::from_centre(k, r, DVec3::from_array(c)))
        }
        (Some(_), None) => Err("t has a non-finite entry".into()),
        (None, Some(_)) => Err("centre has a non-finite entry".into()),
        (Some(_), Some(_)) => Err("give either `t` or `centre`, not both".into()),
        (None, None) => Err("missing the camera position: give `t` or `centre`".into()),
    }
}

/// Loads a manifest (see the module docs).
pub fn load(path: &Path) -> Result<LightField> {
    load_within(path, &LoadLimits::default())
}

/// [`load`], refusing before decoding a light field beyond `limits`.
pub fn load_within(path: &Path, limits: &LoadLimits) -> Result<LightField> {
    // `read_text` drops a UTF-8 byte-order mark (editors on Windows write one).
    let text = crate::io::read_text(path, "the manifest")?;
    let text = text.as_str();
    let bad = |m: String| Error::bad_file(path, m);

    let file = parse(text).map_err(bad)?;
    let label = |i: usize| format!("view {i} ({})", file.views[i].image);

    // Cameras and grid positions.
    let mut cameras = Vec::with_capacity(file.views.len());
    for (i, v) in file.views.iter().enumerate() {
        let cam = view_camera(v).map_err(|m| bad(format!("{}: {m}", label(i))))?;
        if v.grid.s > MAX_GRID || v.grid.t > MAX_GRID {
            return Err(bad(format!(
                "{}: grid position (s = {}, t = {}) is out of range (at most {MAX_GRID})",
                label(i),
                v.grid.s,
                v.grid.t
            )));
        }
        cameras.push(cam);
    }
    let (grid, order) = grid_order(&file.views).map_err(bad)?;

    let name = match file.name.as_deref() {
        Some(n) if !n.is_empty() => n.to_string(),
        _ => default_name(path),
    };

    let paths: Vec<PathBuf> = order
        .iter()
        .map(|&i| relative_to(path, &file.views[i].image))
        .collect();
    let images = decode_views_within(&paths, &name, limits)?;
    let (width, height) = images[0].dimensions();

    let mut views = Vec::with_capacity(order.len());
    let mut depth = Vec::new();
    for (n, (&i, (image, img_path))) in order.iter().zip(images.into_iter().zip(&paths)).enumerate()
    {
        let v = &file.views[i];
        for (rel, kind) in [
            (&v.depth, DepthKind::Depth),
            (&v.disparity, DepthKind::Disparity),
        ] {
            let Some(rel) = rel else { continue };
            let dpath = relative_to(path, rel);
            let map = read_depth_map(&dpath, kind).map_err(|e| {
                let ctx = format!("{} of {} in {}", key_name(kind), label(i), path.display());
                annotate(e, &ctx)
            })?;
            if (map.width, map.height) != (width, height) {
                return Err(Error::bad_file(
                    &dpath,
                    format!(
                        "the {} map of {} in {} is {}×{}, but the views are {width}×{height}",
                        key_name(kind),
                        label(i),
                        path.display(),
                        map.width,
                        map.height
                    ),
                ));
            }
            depth.push((n, map));
        }
        views.push(View {
            s: v.grid.s,
            t: v.grid.t,
            camera: cameras[i],
            image,
            source: super::path_string(img_path),
        });
    }

    let rig = match file.rig {
        None => None,
        Some(r) => {
            let ok = |x: f64| x.is_finite() && x > 0.0;
            if !(ok(r.focal_px) && ok(r.baseline) && ok(r.focus_distance)) {
                return Err(bad(format!(
                    "`rig` needs positive focal_px, baseline and focus_distance, found {}, {}, {}",
                    r.focal_px, r.baseline, r.focus_distance
                )));
            }
            let rig = ParallelRig {
                focal_px: r.focal_px,
                baseline: r.baseline,
                focus_distance: r.focus_distance,
            };
            if let Some(why) = rig_deviation(&rig, grid, width, height, &views) {
                log::warn!(
                    "{}: the cameras do not form the declared rig ({why}); disparities will \
                     still follow the rig's HCI convention",
                    path.display()
                );
            }
            Some(rig)
        }
    };

    Ok(LightField {
        name,
        grid,
        width,
        height,
        views,
        depth,
        rig,
        disparity_range: None,
        source: Source::Manifest {
            path: path.to_path_buf(),
        },
    })
}

/// The manifest in `text`, its version checked first so that a newer manifest gets a version
/// message rather than complaints about fields this version does not know.
fn parse(text: &str) -> std::result::Result<ManifestFile, String> {
    let probe: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| format!("not a valid manifest (invalid JSON): {e}"))?;
    let Some(top) = probe.as_object() else {
        let found = match probe {
            serde_json::Value::Array(_) => "an array",
            serde_json::Value::String(_) => "a string",
            serde_json::Value::Number(_) => "a number",
            serde_json::Value::Bool(_) => "a boolean",
            _ => "null",
        };
        return Err(format!(
            "not a manifest: the top level must be a JSON object with `version` and `views`, \
             found {found}"
        ));
    };
    match top.get("version") {
        None => return Err("missing `version` (expected \"version\": 1)".into()),
        Some(v) if v.as_u64() == Some(VERSION as u64) => {}
        Some(v) => {
            return Err(format!(
                "unsupported manifest version {v}; this tiltfield reads version {VERSION}"
            ))
        }
    }
    let file: ManifestFile =
        serde_json::from_str(text).map_err(|e| format!("not a valid manifest: {e}"))?;
    if file.views.is_empty() {
        return Err("`views` is empty".into());
    }
    Ok(file)
}

/// The grid the views' positions span and the views' indices in row-major order of their
/// positions; an error for two views at one position or a position without a view.
fn grid_order(views: &[ViewEntry]) -> std::result::Result<(GridSize, Vec<usize>), String> {
    let label = |i: usize| format!("view {i} ({})", views[i].image);
    let cols = views.iter().map(|v| v.grid.s).max().unwrap_or(0) + 1;
    let rows = views.iter().map(|v| v.grid.t).max().unwrap_or(0) + 1;
    let grid = GridSize { cols, rows };
    let mut order: Vec<usize> = (0..views.len()).collect();
    order.sort_by_key(|&i| (views[i].grid.t, views[i].grid.s));
    for pair in order.windows(2) {
        if views[pair[0]].grid == views[pair[1]].grid {
            let g = views[pair[0]].grid;
            return Err(format!(
                "{} and {} both claim grid position (s = {}, t = {})",
                label(pair[0].min(pair[1])),
                label(pair[0].max(pair[1])),
                g.s,
                g.t
            ));
        }
    }
    // Sorted and unique: the first position where the list departs from the row-major
    // sequence 0, 1, 2, … is the first missing view.
    let missing = (0..grid.len()).find(|&n| {
        order
            .get(n)
            .map_or(true, |&i| grid.index(views[i].grid.s, views[i].grid.t) != n)
    });
    if let Some(n) = missing {
        return Err(format!(
            "the grid of {cols}×{rows} views (from the largest s and t) is incomplete: no view \
             at (s = {}, t = {}); {} views given",
            n % cols,
            n / cols,
            views.len()
        ));
    }
    Ok((grid, order))
}

/// A name for a manifest without `name`: the folder's for `tiltfield.json`, else the stem.
fn default_name(path: &Path) -> String {
    let os = |s: &std::ffi::OsStr| s.to_string_lossy().into_owned();
    let folder = path.parent().and_then(|p| p.file_name()).map(os);
    match folder {
        Some(f) if path.file_name().is_some_and(|n| n == DEFAULT_NAME) => f,
        _ => path
            .file_stem()
            .map(os)
            .unwrap_or_else(|| "manifest".into()),
    }
}

fn key_name(kind: DepthKind) -> &'static str {
    match kind {
        DepthKind::Depth => "depth",
        DepthKind::Disparity => "disparity",
    }
}

/// Adds context (which view a depth map belongs to) to a file error.
fn annotate(e: Error, context: &str) -> Error {
    match e {
        Error::BadFile { path, message } => Error::BadFile {
            path,
            message: format!("{message} ({context})"),
        },
        Error::Io { path, source } => Error::Io {
            path,
            source: std::io::Error::new(source.kind(), format!("{source} ({context})")),
        },
        other => other,
    }
}

/// The largest deviation of the views' cameras from the declared rig, if beyond tolerance.
/// The manifest's world frame is arbitrary, so positions are compared relative to view 0 and
/// in view 0's camera frame.
fn rig_deviation(
    rig: &ParallelRig,
    grid: GridSize,
    width: u32,
    height: u32,
    views: &[View],
) -> Option<String> {
    let expected = rig.cameras(grid, width, height);
    let (c0, r0) = (views[0].camera.centre(), views[0].camera.r);
    let e0 = expected[0].centre();
    for (v, e) in views.iter().zip(&expected) {
        let dk = (v.camera.k - e.k)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        if dk > 0.5 {
            return Some(format!("{}: K differs by {dk:.2} px", v.source));
        }
        let rel = v.camera.r * r0.transpose() - DMat3::IDENTITY;
        let dr = rel
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        if dr > 1e-3 {
            return Some(format!("{}: not parallel to the first view", v.source));
        }
        let dc = (r0 * (v.camera.centre() - c0) - (e.centre() - e0)).length();
        if dc > 0.01 * rig.baseline {
            return Some(format!(
                "{}: position differs by {:.1} % of the baseline",
                v.source,
                100.0 * dc / rig.baseline
            ));
        }
    }
    None
}

/// Reads a depth or disparity map, `.pfm` or `.exr` by extension.
pub fn read_depth_map(path: &Path, kind: DepthKind) -> Result<DepthMap> {
    let ext = crate::io::extension_lower(path);
    match ext.as_deref() {
        Some("pfm") => read_pfm_depth(path, kind),
        Some("exr") => read_exr_depth(path, kind),
        _ => Err(Error::bad_file(
            path,
            "unsupported depth map format: expected a .pfm or .exr file",
        )),
    }
}

/// Reads one channel of an OpenEXR file as a depth or disparity map: `Z`, else `Y`, else `R`
/// (also layer-qualified as `something.Z`), else the only channel. Non-finite values → NaN.
pub fn read_exr_depth(path: &Path, kind: DepthKind) -> Result<DepthMap> {
    // Opened as a regular file first: a FIFO or device named as a depth map is refused
    // instead of blocking or reading without end.
    let (file, _) = crate::io::open_regular(path, "a depth map", super::pfm::MAX_PFM_BYTES)?;
    use exr::prelude::{ReadChannels, ReadLayers};
    let img = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::BufReader::new(file))
        .map_err(|e| match e {
            exr::error::Error::Io(io) => Error::io(path, io),
            other => Error::bad_file(path, format!("cannot read EXR: {other}")),
        })?;
    let layer = &img.layer_data;
    let channels = &layer.channel_data.list;
    let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    let matches = |name: &str, want: &str| {
        name == want || name.rsplit_once('.').is_some_and(|(_, last)| last == want)
    };
    let pick = ["Z", "Y", "R"]
        .iter()
        .find_map(|want| names.iter().position(|n| matches(n, want)))
        .or(if names.len() == 1 { Some(0) } else { None });
    let Some(ci) = pick else {
        return Err(Error::bad_file(
            path,
            format!(
                "no depth channel: expected a channel named Z, Y or R (or a single channel), \
                 found {}",
                names.join(", ")
            ),
        ));
    };
    let (w, h) = (layer.size.width(), layer.size.height());
    let (Ok(width), Ok(height)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(Error::bad_file(
            path,
            format!("EXR size {w}×{h} is too large"),
        ));
    };
    let values: Vec<f32> = channels[ci]
        .sample_data
        .values_as_f32()
        .map(|v| if v.is_finite() { v } else { f32::NAN })
        .collect();
    if values.len() != w * h || w == 0 || h == 0 {
        return Err(Error::bad_file(
            path,
            format!(
                "EXR channel {} has {} samples for {w}×{h} pixels",
                names[ci],
                values.len()
            ),
        ));
    }
    Ok(DepthMap {
        width,
        height,
        kind,
        values,
        source: super::path_string(path),
        estimated: false,
    })
}

/// Writes `lf` as a manifest at `path` with its views as `view_S_T.png` (8-bit RGB) and depth
/// maps as `depth_S_T.pfm` / `disparity_S_T.pfm` in the same folder (created if needed).
/// Cameras are written as `K`, `R`, `t`; `rig` is written when the light field has one.
pub fn write(lf: &LightField, path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let folder = crate::io::OutputFolder::create(dir)?;
    let name = path
        .file_name()
        .ok_or_else(|| Error::bad_file(path, "the manifest path has no file name"))?;
    write_into(lf, &folder, name)?;
    folder.finish();
    Ok(())
}

/// [`write`] into an output folder (the manifest as `name` in it) that the caller finishes
/// (or drops, removing every file).
pub fn write_into(
    lf: &LightField,
    folder: &crate::io::OutputFolder,
    name: impl AsRef<Path>,
) -> Result<()> {
    if lf.views.len() != lf.grid.len() || lf.views.is_empty() {
        return Err(Error::LightField(format!(
            "{}: {} views for a {}×{} grid",
            lf.name,
            lf.views.len(),
            lf.grid.cols,
            lf.grid.rows
        )));
    }
    let mut maps: BTreeMap<(usize, &'static str), &DepthMap> = BTreeMap::new();
    for (i, m) in &lf.depth {
        if *i >= lf.views.len() {
            return Err(Error::LightField(format!(
                "{}: depth map {} belongs to view {i}, which does not exist",
                lf.name, m.source
            )));
        }
        if maps.insert((*i, key_name(m.kind)), m).is_some() {
            log::warn!(
                "{}: view {i} has two {} maps; writing the last",
                lf.name,
                key_name(m.kind)
            );
        }
    }
    let entries: Vec<ViewEntry> = lf
        .views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let file = |key: &str| {
                maps.contains_key(&(i, key))
                    .then(|| format!("{key}_{}_{}.pfm", v.s, v.t))
            };
            ViewEntry {
                image: format!("view_{}_{}.png", v.s, v.t),
                grid: GridPos { s: v.s, t: v.t },
                k: mat_to_rows(v.camera.k),
                r: mat_to_rows(v.camera.r),
                t: Some(v.camera.t.to_array()),
                centre: None,
                depth: file("depth"),
                disparity: file("disparity"),
            }
        })
        .collect();
    lf.views.par_iter().zip(&entries).try_for_each(|(v, e)| {
        let rgb: image::RgbImage = image::buffer::ConvertBuffer::convert(&v.image);
        folder.write_with(&e.image, "PNG", |w| crate::io::encode_png(&rgb, w))?;
        Ok::<_, Error>(())
    })?;
    for ((i, key), m) in &maps {
        let v = &lf.views[*i];
        let file = format!("{key}_{}_{}.pfm", v.s, v.t);
        let bytes = encode_pfm(&folder.path().join(&file), m.width, m.height, 1, &m.values)?;
        folder.write_bytes(&file, "PFM", &bytes)?;
    }
    let file = ManifestFile {
        version: VERSION,
        name: Some(lf.name.clone()),
        views: entries,
        rig: lf.rig.map(|r| RigEntry {
            focal_px: r.focal_px,
            baseline: r.baseline,
            focus_distance: r.focus_distance,
        }),
    };
    let text = serde_json::to_string_pretty(&file)
        .map_err(|e| Error::Invalid(format!("{}: cannot serialise manifest: {e}", lf.name)))?;
    folder.write_bytes(name, "manifest", (text + "\n").as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::hci::tests::{pixel, synthetic};
    use crate::lightfield::pfm::write_pfm;
    use glam::EulerRot;
    use image::RgbaImage;

    const W: u32 = 16;
    const H: u32 = 12;

    fn rig() -> ParallelRig {
        ParallelRig {
            focal_px: 20.0,
            baseline: 0.05,
            focus_distance: 2.0,
        }
    }

    /// A light field of rotated cameras with differing intrinsics.
    fn rotated(cols: usize, rows: usize) -> LightField {
        let mut lf = synthetic(cols, rows, W, H, rig());
        for v in &mut lf.views {
            let (s, t) = (v.s as f64, v.t as f64);
            let k = crate::geometry::camera::intrinsics(
                30.0 + s,
                31.5 + t,
                7.25 + 0.5 * s,
                5.75 - 0.25 * t,
            );
            let r = DMat3::from_euler(EulerRot::YXZ, 0.05 * s - 0.1, 0.03 * t, 0.01 * (s + t));
            let c = DVec3::new(0.1 * s, 0.12 * t, 0.01 * s * t);
            v.camera = Camera::from_centre(k, r, c);
        }
        lf.rig = None;
        lf
    }

    fn same_depth(a: &DepthMap, b: &DepthMap) -> bool {
        a.kind == b.kind
            && (a.width, a.height) == (b.width, b.height)
            && a.values
                .iter()
                .zip(&b.values)
                .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
    }

    #[test]
    fn write_then_load_round_trips_rotated_cameras() {
        let dir = tempfile::tempdir().unwrap();
        let lf = rotated(3, 2);
        let path = dir.path().join("out").join("rig.json");
        write(&lf, &path).unwrap();
        let back = load(&path).unwrap();
        back.validate().unwrap();
        assert_eq!(back.name, "synthetic");
        assert_eq!(back.grid, GridSize { cols: 3, rows: 2 });
        assert_eq!((back.width, back.height), (W, H));
        assert_eq!(back.source, Source::Manifest { path: path.clone() });
        assert!(back.rig.is_none());
        for (i, (a, b)) in lf.views.iter().zip(&back.views).enumerate() {
            assert_eq!((b.s, b.t), (a.s, a.t));
            assert_eq!(i, b.t * 3 + b.s);
            assert!(b.source.ends_with(&format!("view_{}_{}.png", a.s, a.t)));
            assert!((b.camera.k - a.camera.k).abs_diff_eq(DMat3::ZERO, 1e-12));
            assert!((b.camera.r - a.camera.r).abs_diff_eq(DMat3::ZERO, 1e-12));
            assert!((b.camera.t - a.camera.t).length() < 1e-12);
            for (x, y, p) in b.image.enumerate_pixels() {
                assert_eq!(*p, pixel(a.s, a.t, x, y));
            }
        }
        assert_eq!(back.depth.len(), 2);
        for (i, d) in &back.depth {
            assert_eq!(*i, 4);
            assert!(lf.depth.iter().any(|(j, o)| j == i && same_depth(o, d)));
        }
        // The file is row-major, as written on paper: K[0] = [fx, 0, cx].
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let v5 = &json["views"][5];
        assert_eq!(v5["grid"]["s"], 2);
        assert_eq!(v5["grid"]["t"], 1);
        assert_eq!(v5["K"][0][2].as_f64(), Some(7.25 + 1.0));
        assert_eq!(v5["K"][1][2].as_f64(), Some(5.75 - 0.25));
        assert_eq!(v5["K"][2][2].as_f64(), Some(1.0));
        let r = lf.views[5].camera.r;
        assert_eq!(
            v5["R"][0][1].as_f64(),
            Some(r.y_axis.x),
            "R[0][1] is row 0, column 1"
        );
        assert_eq!(v5["R"][1][0].as_f64(), Some(r.x_axis.y));
    }

    #[test]
    fn rig_round_trips_and_default_name_is_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let mut lf = synthetic(3, 3, W, H, rig());
        lf.name = String::new();
        let path = dir.path().join("my_scene").join(DEFAULT_NAME);
        write(&lf, &path).unwrap();
        let back = load(&path).unwrap();
        assert_eq!(back.name, "my_scene");
        assert_eq!(back.rig, Some(rig()));
        let other = dir.path().join("other.json");
        std::fs::copy(&path, &other).unwrap();
        let err = load(&other).unwrap_err().to_string();
        // Image paths are relative to the manifest's folder, so the copy cannot find them.
        assert!(err.contains("view_0_0.png"), "{err}");
    }

    /// Images `cam_S_T.png` and a matching manifest for a `cols × rows` parallel grid.
    fn fixture(dir: &Path, cols: usize, rows: usize) -> ManifestFile {
        let mut views = Vec::new();
        for t in 0..rows {
            for s in 0..cols {
                let image = format!("cam_{s}_{t}.png");
                RgbaImage::from_fn(W, H, |x, y| pixel(s, t, x, y))
                    .save(dir.join(&image))
                    .unwrap();
                views.push(ViewEntry {
                    image,
                    grid: GridPos { s, t },
                    k: [[20.0, 0.0, 7.5], [0.0, 20.0, 5.5], [0.0, 0.0, 1.0]],
                    r: mat_to_rows(DMat3::IDENTITY),
                    t: Some([-(s as f64), -(t as f64), 0.0]),
                    centre: None,
                    depth: None,
                    disparity: None,
                });
            }
        }
        ManifestFile {
            version: 1,
            name: None,
            views,
            rig: None,
        }
    }

    fn save(dir: &Path, m: &ManifestFile) -> PathBuf {
        let p = dir.join("m.json");
        std::fs::write(&p, serde_json::to_string(m).unwrap()).unwrap();
        p
    }

    fn load_err(dir: &Path, m: &ManifestFile) -> String {
        let msg = load(&save(dir, m)).unwrap_err().to_string();
        assert!(msg.contains("m.json"), "the manifest is named: {msg}");
        msg
    }

    #[test]
    fn views_are_sorted_into_row_major_order() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = fixture(dir.path(), 3, 2);
        m.views.reverse();
        m.views.swap(1, 4);
        m.views[2].t = None;
        m.views[2].centre = Some([m.views[2].grid.s as f64, m.views[2].grid.t as f64, 0.0]);
        let lf = load(&save(dir.path(), &m)).unwrap();
        assert_eq!(lf.name, "m");
        for t in 0..2 {
            for s in 0..3 {
                let v = &lf.views[t * 3 + s];
                assert_eq!((v.s, v.t), (s, t));
                assert!(v.source.ends_with(&format!("cam_{s}_{t}.png")));
                assert_eq!(*v.image.get_pixel(3, 2), pixel(s, t, 3, 2));
                // `t` and `centre` describe the same cameras here.
                assert!((v.camera.centre() - DVec3::new(s as f64, t as f64, 0.0)).length() < 1e-12);
            }
        }
    }

    #[test]
    fn incomplete_grid_names_the_first_missing_position() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = fixture(dir.path(), 3, 2);
        m.views.remove(4); // (s = 1, t = 1)
        let msg = load_err(dir.path(), &m);
        assert!(
            msg.contains("incomplete: no view at (s = 1, t = 1)"),
            "{msg}"
        );
        let mut m = fixture(dir.path(), 3, 2);
        m.views[5].grid = GridPos { s: 3, t: 1 }; // cols becomes 4; (2, 1) and (3, 0) missing
        let msg = load_err(dir.path(), &m);
        assert!(msg.contains("4×2 views"), "{msg}");
        assert!(msg.contains("no view at (s = 3, t = 0)"), "{msg}");
    }

    #[test]
    fn duplicate_grid_position_names_both_views() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = fixture(dir.path(), 2, 2);
        m.views[3].grid = GridPos { s: 1, t: 0 };
        let msg = load_err(dir.path(), &m);
        assert!(
            msg.contains("view 1 (cam_1_0.png) and view 3 (cam_1_1.png)"),
            "{msg}"
        );
        assert!(msg.contains("(s = 1, t = 0)"), "{msg}");
    }

    #[test]
    fn bad_rotations_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = fixture(dir.path(), 2, 2);
        m.views[2].r = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.001], [0.0, 0.0, 1.0]];
        let msg = load_err(dir.path(), &m);
        assert!(
            msg.contains("view 2 (cam_0_1.png): R is not a rotation"),
            "{msg}"
        );
        let mut m = fixture(dir.path(), 2, 2);
        m.views[1].r = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let msg = load_err(dir.path(), &m);
        assert!(
            msg.contains("view 1 (cam_1_0.png): R is a reflection"),
            "{msg}"
        );
        // A rotation printed with 9 digits passes.
        let mut m = fixture(dir.path(), 2, 2);
        let (c, s) = (0.999390827f64, 0.034899497f64);
        m.views[0].r = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]];
        assert!(load(&save(dir.path(), &m)).is_ok());
    }

    #[test]
    fn bad_intrinsics_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = fixture(dir.path(), 2, 1);
        m.views[1].k[1][1] = 0.0;
        let msg = load_err(dir.path(), &m);
        assert!(
            msg.contains("view 1 (cam_1_0.png): K must have positive focal"),
            "{msg}"
        );
        let mut m = fixture(dir.path(), 2, 1);
        m.views[0].k[2] = [0.0, 0.0, 2.0];
        let msg = load_err(dir.path(), &m);
        assert!(
            msg.contains("view 0 (cam_0_0.png): K's last row must be [0, 0, 1]"),
            "{msg}"
        );
        let mut m = fixture(dir.path(), 2, 1);
        m.views[0].k[1][0] = 3.0;
        let msg = load_err(dir.path(), &m);
        assert!(msg.contains("K[1][0] must be 0"), "{msg}");
    }

    #[test]
    fn position_needs_exactly_one_of_t_and_centre() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = fixture(dir.path(), 2, 1);
        m.views[1].centre = Some([0.0; 3]);
        let msg = load_err(dir.path(), &m);
        assert!(
            msg.contains("view 1 (cam_1_0.png): give either `t` or `centre`"),
            "{msg}"
        );
        let mut m = fixture(dir.path(), 2, 1);
        m.views[0].t = None;
        let msg = load_err(dir.path(), &m);
        assert!(
            msg.contains("view 0 (cam_0_0.png): missing the camera position"),
            "{msg}"
        );
    }

    #[test]
    fn non_finite_numbers_are_refused() {
        // JSON cannot spell them, but the check guards the struct API too.
        let dir = tempfile::tempdir().unwrap();
        let m = fixture(dir.path(), 1, 1);
        let mut v = m.views[0].clone();
        v.t = Some([0.0, f64::NAN, 0.0]);
        assert!(view_camera(&v).unwrap_err().contains("t has a non-finite"));
        let mut v = m.views[0].clone();
        v.r[1][1] = f64::INFINITY;
        assert!(view_camera(&v).unwrap_err().contains("R has a non-finite"));
        let mut v = m.views[0].clone();
        v.k[0][2] = f64::NAN;
        assert!(view_camera(&v).unwrap_err().contains("K has a non-finite"));
        // An out-of-range literal is a parse error, not an infinity.
        let p = save(dir.path(), &m);
        let text = std::fs::read_to_string(&p).unwrap().replace("7.5", "1e999");
        std::fs::write(&p, text).unwrap();
        assert!(load(&p).unwrap_err().to_string().contains("m.json"));
    }

    #[test]
    fn version_unknown_fields_and_syntax_are_reported() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = fixture(dir.path(), 1, 1);
        m.version = 2;
        let msg = load_err(dir.path(), &m);
        assert!(msg.contains("unsupported manifest version 2"), "{msg}");
        let p = save(dir.path(), &fixture(dir.path(), 1, 1));
        let text = std::fs::read_to_string(&p).unwrap();
        std::fs::write(&p, text.replace("\"K\"", "\"k\"")).unwrap();
        let msg = load(&p).unwrap_err().to_string();
        assert!(
            msg.contains("m.json") && msg.contains("unknown field `k`"),
            "{msg}"
        );
        std::fs::write(&p, "{\"version\": 1, \"views\": [").unwrap();
        let msg = load(&p).unwrap_err().to_string();
        assert!(
            msg.contains("m.json") && msg.contains("not a valid manifest"),
            "{msg}"
        );
        std::fs::write(&p, "{\"views\": []}").unwrap();
        let msg = load(&p).unwrap_err().to_string();
        assert!(msg.contains("missing `version`"), "{msg}");
        std::fs::write(&p, "{\"version\": 1, \"views\": []}").unwrap();
        let msg = load(&p).unwrap_err().to_string();
        assert!(msg.contains("`views` is empty"), "{msg}");
    }

    fn write_exr(path: &Path, channels: &[(&str, Vec<f32>)]) {
        use exr::prelude::*;
        let list: Vec<AnyChannel<FlatSamples>> = channels
            .iter()
            .map(|(n, v)| AnyChannel::new(*n, FlatSamples::F32(v.clone())))
            .collect();
        let img = Image::from_channels(
            (W as usize, H as usize),
            AnyChannels::sort(SmallVec::from_vec(list)),
        );
        img.write().to_file(path).unwrap();
    }

    #[test]
    fn exr_depth_channel_selection() {
        let dir = tempfile::tempdir().unwrap();
        let n = (W * H) as usize;
        let ramp: Vec<f32> = (0..n).map(|i| i as f32 * 0.5).collect();
        let other = vec![-1.0f32; n];
        let p = dir.path().join("rgbz.exr");
        write_exr(
            &p,
            &[
                ("R", other.clone()),
                ("G", other.clone()),
                ("Z", ramp.clone()),
            ],
        );
        let d = read_exr_depth(&p, DepthKind::Depth).unwrap();
        assert_eq!((d.width, d.height), (W, H));
        assert_eq!(d.values, ramp, "Z wins over R; rows top-down");
        assert_eq!(d.at(3, 2), (2 * W + 3) as f32 * 0.5);

        let p = dir.path().join("rgb.exr");
        write_exr(
            &p,
            &[
                ("B", other.clone()),
                ("G", other.clone()),
                ("R", ramp.clone()),
            ],
        );
        assert_eq!(read_exr_depth(&p, DepthKind::Depth).unwrap().values, ramp);

        let mut with_inf = ramp.clone();
        with_inf[7] = f32::INFINITY;
        let p = dir.path().join("single.exr");
        write_exr(&p, &[("distance", with_inf)]);
        let d = read_exr_depth(&p, DepthKind::Disparity).unwrap();
        assert!(d.values[7].is_nan());
        assert_eq!(d.values[8], 4.0);

        let p = dir.path().join("layered.exr");
        write_exr(&p, &[("depth.Z", ramp.clone()), ("rgba.R", other.clone())]);
        assert_eq!(read_exr_depth(&p, DepthKind::Depth).unwrap().values, ramp);

        let p = dir.path().join("ambiguous.exr");
        write_exr(&p, &[("A", other.clone()), ("B", other.clone())]);
        let msg = read_exr_depth(&p, DepthKind::Depth)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("ambiguous.exr") && msg.contains("found A, B"),
            "{msg}"
        );

        let p = dir.path().join("broken.exr");
        std::fs::write(&p, b"not an exr").unwrap();
        let msg = read_exr_depth(&p, DepthKind::Depth)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("broken.exr") && msg.contains("cannot read EXR"),
            "{msg}"
        );
    }

    #[test]
    fn depth_maps_are_attached_and_checked() {
        let dir = tempfile::tempdir().unwrap();
        let n = (W * H) as usize;
        let ramp: Vec<f32> = (0..n).map(|i| i as f32).collect();
        write_exr(&dir.path().join("d.exr"), &[("Z", ramp.clone())]);
        write_pfm(&dir.path().join("disp.pfm"), W, H, 1, &ramp).unwrap();
        let mut m = fixture(dir.path(), 2, 2);
        m.views[3].depth = Some("d.exr".into());
        m.views[3].disparity = Some("disp.pfm".into());
        m.views.swap(0, 3);
        let lf = load(&save(dir.path(), &m)).unwrap();
        assert_eq!(lf.depth.len(), 2);
        for (i, d) in &lf.depth {
            assert_eq!(*i, 3, "the map follows its view into row-major order");
            assert_eq!(d.values, ramp);
        }
        assert!(lf.depth.iter().any(|(_, d)| d.kind == DepthKind::Depth));
        assert!(lf.depth.iter().any(|(_, d)| d.kind == DepthKind::Disparity));

        write_pfm(
            &dir.path().join("small.pfm"),
            W - 1,
            H,
            1,
            &ramp[..n - H as usize],
        )
        .unwrap();
        m.views[0].disparity = Some("small.pfm".into());
        let msg = load_err(dir.path(), &m);
        assert!(
            msg.contains("small.pfm") && msg.contains("cam_1_1.png"),
            "{msg}"
        );
        assert!(msg.contains("15×12") && msg.contains("16×12"), "{msg}");

        m.views[0].disparity = Some("disp.png".into());
        let msg = load(&save(dir.path(), &m)).unwrap_err().to_string();
        assert!(
            msg.contains("disp.png") && msg.contains("unsupported depth map"),
            "{msg}"
        );

        m.views[0].disparity = Some("gone.pfm".into());
        let err = load(&save(dir.path(), &m)).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(
            msg.contains("gone.pfm") && msg.contains("cam_1_1.png"),
            "{msg}"
        );
    }

    #[test]
    fn rig_must_be_positive() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = fixture(dir.path(), 2, 1);
        m.rig = Some(RigEntry {
            focal_px: 20.0,
            baseline: 0.0,
            focus_distance: 1.0,
        });
        let msg = load_err(dir.path(), &m);
        assert!(msg.contains("`rig` needs positive"), "{msg}");
    }

    #[test]
    fn rig_deviation_is_detected() {
        let lf = synthetic(3, 3, W, H, rig());
        assert_eq!(rig_deviation(&rig(), lf.grid, W, H, &lf.views), None);
        let mut moved = lf.views.clone();
        moved[4].camera.t.x += 0.01; // 20 % of the baseline
        assert!(rig_deviation(&rig(), lf.grid, W, H, &moved).is_some());
        let rotated = rotated(3, 3);
        assert!(rig_deviation(&rig(), lf.grid, W, H, &rotated.views).is_some());
    }

    /// The example in the module docs is a valid manifest that means what the text says.
    #[test]
    fn documented_example_loads() {
        let src = include_str!("manifest.rs");
        let start = src.find("//! ```json\n").unwrap() + "//! ```json\n".len();
        let end = start + src[start..].find("//! ```\n").unwrap();
        let json: String = src[start..end]
            .lines()
            .map(|l| l.strip_prefix("//!").unwrap_or(l))
            .collect::<Vec<_>>()
            .join("\n");
        let dir = tempfile::tempdir().unwrap();
        for (s, t) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            RgbaImage::from_fn(W, H, |x, y| pixel(s, t, x, y))
                .save(dir.path().join(format!("cam_{s}_{t}.png")))
                .unwrap();
        }
        let n = (W * H) as usize;
        write_exr(&dir.path().join("depth_0_0.exr"), &[("Z", vec![2.0; n])]);
        write_pfm(&dir.path().join("disp_0_1.pfm"), W, H, 1, &vec![0.5; n]).unwrap();
        let path = dir.path().join(DEFAULT_NAME);
        std::fs::write(&path, json).unwrap();
        let lf = load(&path).unwrap();
        assert_eq!(lf.name, "desk");
        assert_eq!(lf.grid, GridSize { cols: 2, rows: 2 });
        // Top-left camera is left (x < 0) and up (y < 0); bottom-right is right and down.
        // (1e-7: the example's rotation has 8 digits.)
        assert!((lf.view(0, 0).camera.centre() - DVec3::new(-0.05, -0.05, 0.0)).length() < 1e-7);
        assert!((lf.view(1, 1).camera.centre() - DVec3::new(0.05, 0.05, 0.0)).length() < 1e-7);
        // "Toed in": the right-hand cameras look slightly left (−x).
        let forward = lf.view(1, 0).camera.r.transpose() * DVec3::Z;
        assert!(forward.x < -0.03 && forward.z > 0.99, "{forward}");
        assert_eq!(lf.view(0, 0).camera.k.z_axis.x, 639.5);
        let kinds: Vec<(usize, DepthKind)> = lf.depth.iter().map(|(i, d)| (*i, d.kind)).collect();
        assert_eq!(
            kinds,
            vec![(0, DepthKind::Depth), (2, DepthKind::Disparity)]
        );
    }
}
