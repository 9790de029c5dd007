//! The light field data model and its loaders.
//!
//! A [`LightField`] is a complete `cols × rows` grid of views of equal size. View (s, t) — s the
//! column (horizontal), t the row — is stored at index `t · cols + s`. Every view carries a full
//! pinhole camera (see [`crate::geometry::camera`] for the conventions) and its pixels as
//! sRGB-encoded RGBA8. Depth or disparity maps are optional and belong to one view.
//!
//! Loaders: [`hci`] (HCI 4D Light Field Benchmark folders), [`manifest`] (our JSON manifest for
//! calibrated arrays), [`grid_folder`] (rectified views named by row and column, read by the
//! rule of [`grid_naming`]), [`technicolor`] (camera-array video; one frame is one light field,
//! [`video`] steps through the frames and decodes them in the background). [`open`] picks one
//! from the path, [`open_frame_within`] a frame of a video. [`ply`] writes point clouds
//! (`tiltfield cloud`).

pub mod distortion;
pub mod grid_folder;
pub mod grid_naming;
pub mod hci;
pub mod images;
pub mod manifest;
pub mod pfm;
pub mod ply;
pub mod summary;
pub mod technicolor;
pub mod video;

pub use images::LoadLimits;

use std::path::{Path, PathBuf};

use glam::DVec2;
use image::RgbaImage;

use crate::error::{Error, Result};
use crate::geometry::camera::{interpolate_cameras, Camera};
use crate::geometry::depth::ViewDepth;
pub use crate::geometry::depth::{DepthKind, DepthMap};
pub use crate::geometry::rig::{GridSize, ParallelRig};

/// One view of the grid.
#[derive(Debug, Clone)]
pub struct View {
    /// Grid column.
    pub s: usize,
    /// Grid row.
    pub t: usize,
    pub camera: Camera,
    /// sRGB-encoded pixels.
    pub image: RgbaImage,
    /// Where the pixels came from (file path or "generated"), for messages.
    pub source: String,
}

/// Which loader produced a light field.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "format", rename_all = "snake_case")]
pub enum Source {
    /// HCI benchmark folder; the parsed `parameters.cfg`.
    Hci(hci::HciConfig),
    /// Our JSON manifest.
    Manifest { path: PathBuf },
    /// A folder of views named by row and column, and how the names were read.
    GridFolder {
        path: PathBuf,
        naming: grid_naming::GridNaming,
    },
    /// One frame of a camera-array video in the Technicolor layout.
    TechnicolorVideo(technicolor::VideoFrameInfo),
    /// Generated in code (built-in scenes, tests).
    Generated { scene: String },
    /// Views handed over in memory as a grid (the Python module's `from_array`): read with
    /// a grid folder's conventions (nominal parallel cameras, classic disparity).
    Arrays,
}

/// A complete grid of views.
#[derive(Debug, Clone)]
pub struct LightField {
    /// Short name for messages and reports.
    pub name: String,
    pub grid: GridSize,
    pub width: u32,
    pub height: u32,
    /// Row-major views, `views[t · cols + s]`.
    pub views: Vec<View>,
    /// Depth or disparity maps, each for the view at the given index.
    pub depth: Vec<(usize, DepthMap)>,
    /// Set for regular parallel rigs with sensor shift (HCI convention for `--disparity`).
    pub rig: Option<ParallelRig>,
    /// The dataset's documented range of valid disparities (min ≤ max, both finite): `[meta]
    /// disp_min`/`disp_max` of HCI folders, the range of built-in scenes; `None` when the data
    /// states none. Disparity samples outside it are invalid ([`crate::geometry::depth`]).
    pub disparity_range: Option<(f64, f64)>,
    pub source: Source,
}

impl LightField {
    /// Which views are (almost) entirely black: the vignetted corner views of plenoptic
    /// captures ([`images::is_dark`]), by view index.
    pub fn dark_views(&self) -> Vec<bool> {
        self.views
            .iter()
            .map(|v| images::is_dark(&v.image))
            .collect()
    }

    /// The views to leave out of an aperture or a depth sweep: the dark ones, or none when
    /// `include_dark` (the `--include-dark` option).
    pub fn excluded_views(&self, include_dark: bool) -> Vec<bool> {
        if include_dark {
            vec![false; self.views.len()]
        } else {
            self.dark_views()
        }
    }

    /// The depth of this light field's map-carrying view. Among the views with maps it takes the one
    /// nearest the grid centre; for that view a depth map is preferred over a disparity map
    /// (no conversion, no rig needed). Errors name the light field when it has no map at all,
    /// and the map when a disparity map has no rig to convert it.
    pub fn view_depth(&self) -> Result<ViewDepth> {
        let centre = self.grid.centre();
        let dist = |i: usize| {
            let v = &self.views[i];
            (DVec2::new(v.s as f64, v.t as f64) - centre).length_squared()
        };
        let best = self
            .depth
            .iter()
            .filter(|(i, _)| *i < self.views.len())
            .min_by(|(ia, a), (ib, b)| {
                dist(*ia)
                    .total_cmp(&dist(*ib))
                    .then_with(|| kind_rank(a.kind).cmp(&kind_rank(b.kind)))
            });
        let Some((index, map)) = best else {
            return Err(Error::Invalid(format!(
                "light field '{}' has no depth or disparity map, so a pixel cannot be turned \
                 into a 3D point; --click and --points need one (--points-3d, --plane, --focus \
                 and --disparity work without)",
                self.name
            )));
        };
        self.view_depth_of(*index, map)
    }

    /// The depth of view `index` from `map`, with the dataset's disparity range.
    pub fn view_depth_of(&self, index: usize, map: &DepthMap) -> Result<ViewDepth> {
        let view = self.views.get(index).ok_or_else(|| {
            Error::LightField(format!(
                "{}: depth map {} belongs to view {index}, which does not exist",
                self.name, map.source
            ))
        })?;
        let mut d = ViewDepth::new(view.camera, map, self.rig, self.disparity_range, index)?;
        d.grid_position = (view.s, view.t);
        Ok(d)
    }

    /// View (s, t).
    pub fn view(&self, s: usize, t: usize) -> &View {
        &self.views[self.grid.index(s, t)]
    }

    /// The camera at fractional grid position `st` = (s, t): bilinear between the four
    /// neighbouring cameras ([`interpolate_cameras`]), exactly the real camera at integer
    /// positions. This is how a virtual reference view between real views gets its camera.
    /// An error when `st` is not finite or lies outside `[0, cols − 1] × [0, rows − 1]`.
    pub fn camera_at(&self, st: DVec2) -> Result<Camera> {
        let (cols, rows) = (self.grid.cols, self.grid.rows);
        let max = DVec2::new(cols as f64 - 1.0, rows as f64 - 1.0);
        if !st.is_finite() || st.x < 0.0 || st.y < 0.0 || st.x > max.x || st.y > max.y {
            return Err(Error::Invalid(format!(
                "reference view ({}, {}) lies outside the grid: s must be in [0, {}], t in [0, {}]",
                crate::error::compact(st.x),
                crate::error::compact(st.y),
                max.x,
                max.y
            )));
        }
        // A single row or column has no second neighbour: s1 = s0 (weights then irrelevant).
        let s0 = (st.x.floor() as usize).min(cols.saturating_sub(2));
        let t0 = (st.y.floor() as usize).min(rows.saturating_sub(2));
        let s1 = (s0 + 1).min(cols - 1);
        let t1 = (t0 + 1).min(rows - 1);
        let cam = |s, t| &self.view(s, t).camera;
        Ok(interpolate_cameras(
            cam(s0, t0),
            cam(s1, t0),
            cam(s0, t1),
            cam(s1, t1),
            st.x - s0 as f64,
            st.y - t0 as f64,
        ))
    }

    /// Checks the invariants every consumer relies on: a complete grid in row-major order,
    /// equal view sizes, finite cameras, depth maps of matching size.
    pub fn validate(&self) -> Result<()> {
        if self.grid.is_empty() {
            return Err(Error::LightField(format!(
                "{}: the grid has no views",
                self.name
            )));
        }
        if self.views.len() != self.grid.len() {
            return Err(Error::LightField(format!(
                "{}: expected {}×{} = {} views, found {}",
                self.name,
                self.grid.cols,
                self.grid.rows,
                self.grid.len(),
                self.views.len()
            )));
        }
        if self.width == 0 || self.height == 0 {
            return Err(Error::LightField(format!(
                "{}: views are empty (0 pixels)",
                self.name
            )));
        }
        for (i, v) in self.views.iter().enumerate() {
            if self.grid.index(v.s, v.t) != i {
                return Err(Error::LightField(format!(
                    "{}: view {} is stored at index {i}, expected grid order",
                    self.name, v.source
                )));
            }
            if v.image.dimensions() != (self.width, self.height) {
                return Err(Error::LightField(format!(
                    "{}: {} is {}×{}, but the light field's views are {}×{}",
                    self.name,
                    v.source,
                    v.image.width(),
                    v.image.height(),
                    self.width,
                    self.height
                )));
            }
            let c = &v.camera;
            let finite = c.k.is_finite() && c.r.is_finite() && c.t.is_finite();
            if !finite || c.k.determinant().abs() < 1e-12 {
                return Err(Error::LightField(format!(
                    "{}: camera of {} is not finite or has a singular K",
                    self.name, v.source
                )));
            }
        }
        self.check_calibration()?;
        for (i, d) in &self.depth {
            if *i >= self.views.len() {
                return Err(Error::LightField(format!(
                    "{}: depth map {} belongs to a view that does not exist",
                    self.name, d.source
                )));
            }
            if (d.width, d.height) != (self.width, self.height) {
                return Err(Error::LightField(format!(
                    "{}: depth map {} is {}×{}, views are {}×{}",
                    self.name, d.source, d.width, d.height, self.width, self.height
                )));
            }
        }
        Ok(())
    }
}

impl LightField {
    /// Refuses calibrations that cannot describe a camera array: centres so far out that the
    /// homographies overflow, views whose centres all coincide (a 1e-300 baseline), or a rig
    /// whose disparities cannot be told from zero. Without this, such input reaches the
    /// refocus maths and fails there with a message about the plane instead of the cause.
    fn check_calibration(&self) -> Result<()> {
        let centres: Vec<glam::DVec3> = self.views.iter().map(|v| v.camera.centre()).collect();
        if let Some((v, c)) = self
            .views
            .iter()
            .zip(&centres)
            .find(|(_, c)| !(c.is_finite() && c.abs().max_element() <= MAX_COORDINATE))
        {
            return Err(Error::LightField(format!(
                "{}: degenerate calibration: the camera of {} sits at ({:.3e}, {:.3e}, {:.3e}), beyond \
                 ±{MAX_COORDINATE:e} world units",
                self.name, v.source, c.x, c.y, c.z
            )));
        }
        if centres.len() > 1 {
            let scale = centres.iter().map(|c| c.length()).fold(1e-300, f64::max);
            let spread = centres
                .iter()
                .map(|c| c.distance(centres[0]))
                .fold(0.0, f64::max);
            if spread <= 1e-12 * scale || spread < 1e-200 {
                return Err(Error::LightField(format!(
                    "{}: degenerate calibration: all {} camera centres coincide (they are at most \
                     {spread:.1e} apart); a light field needs a baseline",
                    self.name,
                    centres.len()
                )));
            }
        }
        if let Some(rig) = &self.rig {
            let at_infinity = -rig.disparity_at_infinity();
            if !(at_infinity.is_finite() && (1e-9..=1e9).contains(&at_infinity)) {
                return Err(Error::LightField(format!(
                    "{}: degenerate calibration: focal length {:e} px, baseline {:e} and focus \
                     distance {:e} give a disparity at infinity of {:.1e} px per view",
                    self.name, rig.focal_px, rig.baseline, rig.focus_distance, -at_infinity
                )));
            }
        }
        Ok(())
    }
}

/// Largest magnitude of a camera centre coordinate, world units.
pub const MAX_COORDINATE: f64 = 1e12;

/// Options for loaders that cannot read camera parameters from the data itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridCameraOptions {
    /// Focal length in pixels; default `max(W, H)`.
    pub focal_px: Option<f64>,
    /// Baseline between neighbouring views in world units; default 1.
    pub baseline: f64,
}

impl Default for GridCameraOptions {
    fn default() -> Self {
        GridCameraOptions {
            focal_px: None,
            baseline: 1.0,
        }
    }
}

/// Opens a light field, choosing the loader from the path:
/// a `.json` file → manifest; a folder with `parameters.cfg` → HCI; a folder with
/// `tiltfield.json` → manifest; a folder with `cameras_parameters.txt` → the first frame of a
/// Technicolor-layout video; any other folder → grid of views named by row and column.
pub fn open(path: &Path, grid_opts: &GridCameraOptions) -> Result<LightField> {
    open_within(path, grid_opts, &LoadLimits::default())
}

/// [`open`], refusing a light field beyond `limits` (views, view size, decoded bytes) after
/// reading the image headers and before decoding any view.
pub fn open_within(
    path: &Path,
    grid_opts: &GridCameraOptions,
    limits: &LoadLimits,
) -> Result<LightField> {
    open_frame_within(path, grid_opts, limits, None)
}

/// [`open_within`], choosing frame `frame` (its number in the file names) of a camera-array
/// video; `None` is the first frame. Asking for a frame of a light field that is not a video
/// is an error.
pub fn open_frame_within(
    path: &Path,
    grid_opts: &GridCameraOptions,
    limits: &LoadLimits,
    frame: Option<u64>,
) -> Result<LightField> {
    if let Some(n) = frame {
        if path.exists() && !technicolor::is_technicolor(path) {
            return Err(Error::Invalid(format!(
                "frame {n} asked of {}, which is a single light field, not a video (videos are \
                 folders with {})",
                path.display(),
                technicolor::PARAMETERS_NAME
            )));
        }
    }
    if !path.exists() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or folder"),
        ));
    }
    if let Ok(m) = std::fs::metadata(path) {
        if !m.is_file() && !m.is_dir() {
            return Err(Error::bad_file(
                path,
                format!(
                    "not a light field: it is {}; expected a folder (HCI, grid of views or \
                     video) or a .json manifest",
                    crate::io::kind_of(&m)
                ),
            ));
        }
    }
    let manifest_in_folder = path.join(manifest::DEFAULT_NAME);
    let lf = if path.is_file() {
        if path.extension().and_then(|e| e.to_str()) == Some("json") {
            manifest::load_within(path, limits)?
        } else {
            return Err(Error::bad_file(
                path,
                "not a light field: expected a folder (HCI or grid of views) or a .json manifest",
            ));
        }
    } else if std::fs::symlink_metadata(path.join(hci::CONFIG_NAME)).is_ok() {
        // Any entry named parameters.cfg makes the folder HCI: one that is a folder, a FIFO or
        // a dangling link is then refused naming what it is, not reported as missing.
        hci::load_within(path, limits)?
    } else if std::fs::symlink_metadata(&manifest_in_folder).is_ok() {
        // A tiltfield.json that exists but is a folder, a dangling or looping link or
        // unreadable is an error, not a reason to read the folder as a grid of views.
        if !manifest_in_folder.is_file() {
            let why = match std::fs::metadata(&manifest_in_folder) {
                Err(e) => e.to_string(),
                Ok(m) if m.is_dir() => "it is a folder, not a file".to_string(),
                Ok(_) => "it is not a regular file".to_string(),
            };
            return Err(Error::bad_file(
                &manifest_in_folder,
                format!("the manifest cannot be read: {why}"),
            ));
        }
        manifest::load_within(&manifest_in_folder, limits)?
    } else if technicolor::is_technicolor(path) {
        let video = video::FrameSequence::open(path)?;
        video.load_within(frame.unwrap_or_else(|| video.first()), limits)?
    } else {
        grid_folder::load_within(path, grid_opts, limits)?
    };
    let mut lf = lf;
    screen_depth_maps(&mut lf);
    lf.validate()?;
    Ok(lf)
}

/// Values of the light field's own depth maps that no camera could have measured become
/// unknown (NaN), with a warning naming the file: a disparity larger than the views (a point
/// displaced by more than a whole view between neighbouring views, which no two views can
/// both see) or a depth ≤ 0 (at or behind the camera). A map left without any value is
/// dropped. Kept, a map of 1e30 px made 84–91 % of a plain `render --disparity 0` transparent
/// (anti-aliasing, on by default with a map, spread each pixel over the whole aperture) without
/// a word about the map.
pub fn screen_depth_maps(lf: &mut LightField) {
    let limit = lf.width.max(lf.height) as f32;
    lf.depth.retain_mut(|(_, map)| {
        let absurd = |v: f32| match map.kind {
            DepthKind::Disparity => v.abs() > limit,
            DepthKind::Depth => v <= 0.0,
        };
        let bad = map.values.iter().filter(|&&v| absurd(v)).count();
        if bad == 0 {
            return true;
        }
        let example = map.values.iter().copied().find(|&v| absurd(v));
        for v in map.values.iter_mut().filter(|v| absurd(**v)) {
            *v = f32::NAN;
        }
        let what = match map.kind {
            DepthKind::Disparity => format!("disparities beyond ±{limit} px per grid step"),
            DepthKind::Depth => "depths ≤ 0 (at or behind the camera)".to_string(),
        };
        let kept = map.values.iter().any(|v| v.is_finite());
        log::warn!(
            "{}: {bad} of {} values are {what} (e.g. {}), which no camera measures; {}",
            map.source,
            map.values.len(),
            crate::error::compact(example.unwrap_or(f32::NAN) as f64),
            if kept {
                "they are taken as unknown"
            } else {
                "the map is ignored"
            }
        );
        kept
    });
}

/// Views in row-major grid order from decoded images, their cameras and files (all three in
/// the same row-major order).
pub(crate) fn grid_views(
    grid: GridSize,
    images: Vec<RgbaImage>,
    cameras: Vec<Camera>,
    paths: &[PathBuf],
) -> Vec<View> {
    images
        .into_iter()
        .zip(cameras)
        .zip(paths)
        .enumerate()
        .map(|(i, ((image, camera), path))| View {
            s: i % grid.cols,
            t: i / grid.cols,
            camera,
            image,
            source: path_string(path),
        })
        .collect()
}

/// Display helper: a path as a String.
pub(crate) fn path_string(p: &Path) -> String {
    p.display().to_string()
}

/// Resolves `rel` against the folder of `base_file`.
pub(crate) fn relative_to(base_file: &Path, rel: &str) -> PathBuf {
    let rel = Path::new(rel);
    if rel.is_absolute() {
        rel.to_path_buf()
    } else {
        base_file.parent().unwrap_or(Path::new(".")).join(rel)
    }
}

/// Depth maps before disparity maps of the same view: no conversion, no rig needed.
fn kind_rank(k: DepthKind) -> u8 {
    match k {
        DepthKind::Depth => 0,
        DepthKind::Disparity => 1,
    }
}
