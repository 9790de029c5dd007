//! HCI 4D Light Field Benchmark folders (Honauer et al. 2016).
//!
//! Layout of a scene folder:
//! ```text
//! parameters.cfg          INI: [intrinsics], [extrinsics], [meta]
//! input_Cam000.png        views, row-major: index = t · num_cams_x + s, Cam000 top-left
//! …
//! input_Cam080.png        (3-digit zero-padded; more digits when there are more than 1000)
//! gt_disp_lowres.pfm      optional: disparity of the centre view (pixels per grid step)
//! gt_depth_lowres.pfm     optional: depth of the centre view
//! ```
//! `parameters.cfg` (keys as the benchmark writes them):
//! ```text
//! [intrinsics]
//! focal_length_mm = 100.0
//! image_resolution_x_px = 512
//! image_resolution_y_px = 512
//! sensor_size_mm = 35.0
//! fstop = 100.0
//!
//! [extrinsics]
//! num_cams_x = 9
//! num_cams_y = 9
//! baseline_mm = 30.0
//! focus_distance_m = 8.3
//! center_cam_x_m = -0.0895…       (and _y_m, _z_m, _rx_rad, _ry_rad, _rz_rad; sometimes offset)
//!
//! [meta]
//! scene = backgammon
//! category = stratified
//! disp_min = -1.7
//! …
//! ```
//! The INI dialect: `[section]` headers, `key = value` lines, full-line comments starting with
//! `#` or `;`, blank lines. Keys and values are trimmed; a key outside a section, a line that is
//! none of these, or a key given twice is an error naming the file and line. Required: the four
//! `[intrinsics]` keys except `fstop` (optional) and the four `[extrinsics]` keys shown above;
//! all must be positive numbers. The `center_cam_*` pose only places the rig in the Blender
//! scene; tiltfield's world frame is the centre camera's own, so those keys are kept verbatim
//! (for writing the file back) but not used.
//!
//! Cameras ([`HciConfig::rig`]): a parallel grid with sensor shift, `f_px = focal_length_mm ·
//! max(W, H) / sensor_size_mm`, baseline `baseline_mm / 1000` metres, zero disparity at
//! `focus_distance_m`; see [`ParallelRig`] for the camera construction and the disparity sign
//! (positive = nearer than the focus distance). World units are metres.
//!
//! The ground-truth maps are attached to the centre view, index `grid.index(cols / 2, rows / 2)`.
//! `gt_depth_lowres.pfm` is read as stored (the benchmark's depth along the optical axis);
//! `[meta] depth_map_scale` is kept in `meta` but not applied. High-resolution maps
//! (`*_highres.pfm`) and per-view maps of some scenes are not read.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use image::buffer::ConvertBuffer;
use image::RgbImage;
use rayon::prelude::*;

use super::images::{check_regular_file, decode_views_within, LoadLimits};
use super::pfm::{encode_pfm, read_pfm_depth};
use super::{DepthKind, GridSize, LightField, ParallelRig, Source};
use crate::error::{Error, Result};

/// Name of the configuration file inside an HCI folder.
pub const CONFIG_NAME: &str = "parameters.cfg";
/// Ground-truth disparity of the centre view.
pub const DISPARITY_NAME: &str = "gt_disp_lowres.pfm";
/// Ground-truth depth of the centre view.
pub const DEPTH_NAME: &str = "gt_depth_lowres.pfm";

/// More views than any real camera grid has; guards against a corrupt `num_cams_*`.
const MAX_VIEWS: usize = 100_000;

/// Parsed `parameters.cfg`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct HciConfig {
    pub focal_length_mm: f64,
    pub image_resolution_x_px: u32,
    pub image_resolution_y_px: u32,
    pub sensor_size_mm: f64,
    pub fstop: Option<f64>,
    pub num_cams_x: usize,
    pub num_cams_y: usize,
    pub baseline_mm: f64,
    pub focus_distance_m: f64,
    /// `[meta]` entries as written (scene, category, disp_min, ...).
    pub meta: BTreeMap<String, String>,
    /// Other `[intrinsics]` entries, verbatim (none in the benchmark's own files).
    pub intrinsics_extra: BTreeMap<String, String>,
    /// Other `[extrinsics]` entries, verbatim: `center_cam_{x,y,z}_m`,
    /// `center_cam_{rx,ry,rz}_rad`, sometimes `offset`. Kept for [`write()`], unused otherwise.
    pub extrinsics_extra: BTreeMap<String, String>,
}

impl HciConfig {
    /// The camera grid this configuration describes (see the module docs).
    pub fn rig(&self) -> ParallelRig {
        let max_px = self.image_resolution_x_px.max(self.image_resolution_y_px) as f64;
        ParallelRig {
            focal_px: self.focal_length_mm * max_px / self.sensor_size_mm,
            baseline: self.baseline_mm / 1000.0,
            focus_distance: self.focus_distance_m,
        }
    }

    /// The grid of views.
    pub fn grid(&self) -> GridSize {
        GridSize {
            cols: self.num_cams_x,
            rows: self.num_cams_y,
        }
    }
}

/// One `key = value` line of the INI file.
struct Entry {
    value: String,
    line: usize,
}

/// Sections → keys → entries.
type Ini = BTreeMap<String, BTreeMap<String, Entry>>;

fn parse_ini(text: &str, path: &Path) -> Result<Ini> {
    let mut ini = Ini::new();
    let mut section: Option<String> = None;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim_start_matches('\u{feff}').trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with(';') {
            continue;
        }
        if let Some(rest) = line.strip_prefix('[') {
            let name = rest.strip_suffix(']').ok_or_else(|| {
                Error::bad_file(
                    path,
                    format!(
                        "line {line_no}: section header `{}` lacks its closing `]`",
                        shown(line)
                    ),
                )
            })?;
            let name = name.trim().to_string();
            ini.entry(name.clone()).or_default();
            section = Some(name);
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(Error::bad_file(
                path,
                format!(
                    "line {line_no}: expected `key = value`, `[section]` or a comment, found \
                     `{}`",
                    shown(line)
                ),
            ));
        };
        let key = key.trim();
        if key.is_empty() {
            return Err(Error::bad_file(
                path,
                format!("line {line_no}: `{line}` has no key before `=`"),
            ));
        }
        let Some(sec) = &section else {
            return Err(Error::bad_file(
                path,
                format!("line {line_no}: key `{key}` is outside any [section]"),
            ));
        };
        let keys = ini.entry(sec.clone()).or_default();
        if let Some(prev) = keys.get(key) {
            return Err(Error::bad_file(
                path,
                format!(
                    "line {line_no}: key `{key}` in [{sec}] is given twice (first on line {})",
                    prev.line
                ),
            ));
        }
        keys.insert(
            key.to_string(),
            Entry {
                value: value.trim().to_string(),
                line: line_no,
            },
        );
    }
    Ok(ini)
}

/// A line quoted in a message: control characters escaped and at most 60 characters, so a
/// file that is not a parameters.cfg at all is not echoed into the terminal.
fn shown(line: &str) -> String {
    let mut s: String = line
        .chars()
        .take(60)
        .collect::<String>()
        .escape_debug()
        .collect();
    if line.chars().count() > 60 {
        s.push('…');
    }
    s
}

/// Typed access to the required keys, with errors naming the file, section and key.
struct Keys<'a> {
    ini: &'a mut Ini,
    path: &'a Path,
}

impl Keys<'_> {
    /// Removes and returns `[section] key`, if present.
    fn take(&mut self, section: &str, key: &str) -> Option<Entry> {
        self.ini.get_mut(section).and_then(|s| s.remove(key))
    }

    fn require(&mut self, section: &str, key: &str) -> Result<Entry> {
        if let Some(e) = self.take(section, key) {
            return Ok(e);
        }
        let elsewhere = self
            .ini
            .iter()
            .find(|(_, keys)| keys.contains_key(key))
            .map(|(s, _)| format!(" (it is in [{s}])"))
            .unwrap_or_default();
        Err(Error::bad_file(
            self.path,
            format!("missing key `{key}` in [{section}]{elsewhere}"),
        ))
    }

    /// A finite, positive real number.
    fn positive(&self, key: &str, e: &Entry) -> Result<f64> {
        match e.value.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
            Ok(_) => Err(Error::bad_file(
                self.path,
                format!(
                    "line {}: `{key}` must be a positive number, found `{}`",
                    e.line, e.value
                ),
            )),
            Err(_) => Err(Error::bad_file(
                self.path,
                format!("line {}: `{key}` = `{}` is not a number", e.line, e.value),
            )),
        }
    }

    /// A positive whole number; `512` and `512.0` are both accepted.
    fn count(&self, key: &str, e: &Entry) -> Result<usize> {
        let v = self.positive(key, e)?;
        if v.fract() != 0.0 || v > u32::MAX as f64 {
            return Err(Error::bad_file(
                self.path,
                format!(
                    "line {}: `{key}` must be a positive whole number, found `{}`",
                    e.line, e.value
                ),
            ));
        }
        Ok(v as usize)
    }

    fn req_positive(&mut self, section: &str, key: &str) -> Result<f64> {
        let e = self.require(section, key)?;
        self.positive(key, &e)
    }

    fn req_count(&mut self, section: &str, key: &str) -> Result<usize> {
        let e = self.require(section, key)?;
        self.count(key, &e)
    }

    /// What is left of a section: the keys nobody asked for.
    fn rest(&mut self, section: &str) -> BTreeMap<String, String> {
        self.ini
            .remove(section)
            .unwrap_or_default()
            .into_iter()
            .map(|(k, e)| (k, e.value))
            .collect()
    }
}

/// Parses the text of a `parameters.cfg`; `path` is only for messages.
pub fn parse_config(text: &str, path: &Path) -> Result<HciConfig> {
    let mut ini = parse_ini(text, path)?;
    let mut keys = Keys {
        ini: &mut ini,
        path,
    };
    const I: &str = "intrinsics";
    const E: &str = "extrinsics";
    let focal_length_mm = keys.req_positive(I, "focal_length_mm")?;
    let image_resolution_x_px = keys.req_count(I, "image_resolution_x_px")? as u32;
    let image_resolution_y_px = keys.req_count(I, "image_resolution_y_px")? as u32;
    let sensor_size_mm = keys.req_positive(I, "sensor_size_mm")?;
    let fstop = match keys.take(I, "fstop") {
        Some(e) => Some(keys.positive("fstop", &e)?),
        None => None,
    };
    let num_cams_x = keys.req_count(E, "num_cams_x")?;
    let num_cams_y = keys.req_count(E, "num_cams_y")?;
    let baseline_mm = keys.req_positive(E, "baseline_mm")?;
    let focus_distance_m = keys.req_positive(E, "focus_distance_m")?;
    let views = num_cams_x.saturating_mul(num_cams_y);
    if views > MAX_VIEWS {
        return Err(Error::bad_file(
            path,
            format!("num_cams_x × num_cams_y = {num_cams_x} × {num_cams_y} views is implausible"),
        ));
    }
    let intrinsics_extra = keys.rest(I);
    let extrinsics_extra = keys.rest(E);
    let meta = keys.rest("meta");
    for other in ini.keys() {
        log::debug!("{}: ignoring section [{other}]", path.display());
    }
    Ok(HciConfig {
        focal_length_mm,
        image_resolution_x_px,
        image_resolution_y_px,
        sensor_size_mm,
        fstop,
        num_cams_x,
        num_cams_y,
        baseline_mm,
        focus_distance_m,
        meta,
        intrinsics_extra,
        extrinsics_extra,
    })
}

/// File name of view `index` in a grid of `count` views: `input_Cam005.png`; at least three
/// digits, more when the largest index needs them.
pub fn view_file_name(index: usize, count: usize) -> String {
    let digits = count.saturating_sub(1).to_string().len().max(3);
    format!("input_Cam{index:0digits$}.png")
}

/// Loads an HCI scene folder (see the module docs).
pub fn load(dir: &Path) -> Result<LightField> {
    load_within(dir, &LoadLimits::default())
}

/// [`load`], refusing before decoding a light field beyond `limits`.
pub fn load_within(dir: &Path, limits: &LoadLimits) -> Result<LightField> {
    let cfg_path = dir.join(CONFIG_NAME);
    let text = crate::io::read_text(&cfg_path, "the HCI parameters file")?;
    let cfg = parse_config(&text, &cfg_path)?;
    let grid = cfg.grid();
    let count = grid.len();
    let paths: Vec<PathBuf> = (0..count)
        .map(|i| dir.join(view_file_name(i, count)))
        .collect();
    // Check presence before decoding anything, so a missing view is reported at once.
    if let Some(missing) = paths.iter().find(|p| std::fs::symlink_metadata(p).is_err()) {
        return Err(Error::io(
            missing,
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!(
                    "missing view: {} declares {}×{} views {} … {}",
                    cfg_path.display(),
                    grid.cols,
                    grid.rows,
                    view_file_name(0, count),
                    view_file_name(count - 1, count)
                ),
            ),
        ));
    }
    let name = match cfg.meta.get("scene") {
        Some(s) if !s.is_empty() => s.clone(),
        _ => dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| super::path_string(dir)),
    };
    // A folder, device or symlink loop in a view's place gets its own message, not "missing".
    for p in &paths {
        check_regular_file(p)?;
    }
    warn_extra_views(dir, count);
    let images = decode_views_within(&paths, &name, limits)?;
    let (width, height) = images[0].dimensions();
    if (width, height) != (cfg.image_resolution_x_px, cfg.image_resolution_y_px) {
        return Err(Error::bad_file(
            &paths[0],
            format!(
                "the view is {width}×{height}, but {} declares image_resolution {}×{}",
                cfg_path.display(),
                cfg.image_resolution_x_px,
                cfg.image_resolution_y_px
            ),
        ));
    }
    let rig = cfg.rig();
    let cameras = rig.cameras(grid, width, height);
    let views = super::grid_views(grid, images, cameras, &paths);

    let centre = grid.index(grid.cols / 2, grid.rows / 2);
    let mut depth = Vec::new();
    for (file, kind) in [
        (DISPARITY_NAME, DepthKind::Disparity),
        (DEPTH_NAME, DepthKind::Depth),
    ] {
        let p = dir.join(file);
        // Absent: the folder has no such map. Present as anything but a regular file (a
        // folder, a FIFO, a device, a dangling link): refused by name when read, not skipped
        // in silence as it was.
        if let Err(e) = std::fs::symlink_metadata(&p) {
            if e.kind() == std::io::ErrorKind::NotFound {
                continue;
            }
        }
        let map = read_pfm_depth(&p, kind)?;
        if (map.width, map.height) != (width, height) {
            return Err(Error::bad_file(
                &p,
                format!(
                    "the map is {}×{}, but the views are {width}×{height}",
                    map.width, map.height
                ),
            ));
        }
        depth.push((centre, map));
    }

    Ok(LightField {
        name,
        grid,
        width,
        height,
        views,
        depth,
        rig: Some(rig),
        disparity_range: meta_disparity_range(&cfg),
        source: Source::Hci(cfg),
    })
}

/// `[meta] disp_min`/`disp_max` when both parse as finite numbers with min ≤ max.
fn meta_disparity_range(cfg: &HciConfig) -> Option<(f64, f64)> {
    let get = |k: &str| cfg.meta.get(k).and_then(|v| v.trim().parse::<f64>().ok());
    match (get("disp_min"), get("disp_max")) {
        (Some(a), Some(b)) if a.is_finite() && b.is_finite() && a <= b => Some((a, b)),
        _ => None,
    }
}

/// Warns about `input_Cam*` files beyond the `count` views `parameters.cfg` declares: a
/// num_cams typo would otherwise render a subset of the views without a word.
fn warn_extra_views(dir: &Path, count: usize) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut extra: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .filter(|n| {
            n.strip_prefix("input_Cam")
                .and_then(|r| r.strip_suffix(".png"))
                .and_then(|d| d.parse::<usize>().ok())
                .is_some_and(|i| i >= count || *n != view_file_name(i, count))
        })
        .collect();
    if extra.is_empty() {
        return;
    }
    extra.sort();
    let shown = extra.iter().take(8).cloned().collect::<Vec<_>>().join(", ");
    let more = if extra.len() > 8 { ", …" } else { "" };
    log::warn!(
        "{}: {} view files beyond the {count} that {CONFIG_NAME} declares are ignored: \
         {shown}{more}",
        dir.display(),
        extra.len()
    );
}

/// The configuration that describes `lf` as an HCI scene taken by `rig` (world units metres)
/// with a sensor `sensor_mm` wide: `focal_length_mm = f_px · sensor_mm / max(W, H)`, so that
/// [`HciConfig::rig`] gives back `rig` (up to rounding). `fstop` is left unset; `[meta] scene`
/// is the light field's name.
pub fn config_for(lf: &LightField, rig: &ParallelRig, sensor_mm: f64) -> HciConfig {
    let max_px = lf.width.max(lf.height) as f64;
    let mut meta = BTreeMap::new();
    meta.insert("scene".to_string(), lf.name.clone());
    HciConfig {
        focal_length_mm: rig.focal_px * sensor_mm / max_px,
        image_resolution_x_px: lf.width,
        image_resolution_y_px: lf.height,
        sensor_size_mm: sensor_mm,
        fstop: None,
        num_cams_x: lf.grid.cols,
        num_cams_y: lf.grid.rows,
        baseline_mm: rig.baseline * 1000.0,
        focus_distance_m: rig.focus_distance,
        meta,
        intrinsics_extra: BTreeMap::new(),
        extrinsics_extra: BTreeMap::new(),
    }
}

/// Key order of the benchmark's own files; other keys follow alphabetically.
const EXTRINSICS_ORDER: [&str; 7] = [
    "center_cam_x_m",
    "center_cam_y_m",
    "center_cam_z_m",
    "center_cam_rx_rad",
    "center_cam_ry_rad",
    "center_cam_rz_rad",
    "offset",
];
const META_ORDER: [&str; 11] = [
    "scene",
    "category",
    "date",
    "version",
    "authors",
    "contact",
    "disp_min",
    "disp_max",
    "frustum_disp_min",
    "frustum_disp_max",
    "depth_map_scale",
];

/// The text of `parameters.cfg` for `cfg`, in the benchmark's section and key order.
/// Reals are written with Rust's shortest round-trip form (`100.0`, `8.300000190734863`).
pub fn format_config(cfg: &HciConfig) -> String {
    // One line per value: a newline inside a value would corrupt the file.
    fn put(out: &mut String, key: &str, value: &str) {
        let _ = writeln!(out, "{key} = {}", value.replace(['\n', '\r'], " "));
    }
    fn put_ordered(out: &mut String, map: &BTreeMap<String, String>, order: &[&str]) {
        for key in order {
            if let Some(v) = map.get(*key) {
                put(out, key, v);
            }
        }
        for (k, v) in map {
            if !order.contains(&k.as_str()) {
                put(out, k, v);
            }
        }
    }
    let mut out = String::from("[intrinsics]\n");
    put(
        &mut out,
        "focal_length_mm",
        &format!("{:?}", cfg.focal_length_mm),
    );
    put(
        &mut out,
        "image_resolution_x_px",
        &cfg.image_resolution_x_px.to_string(),
    );
    put(
        &mut out,
        "image_resolution_y_px",
        &cfg.image_resolution_y_px.to_string(),
    );
    put(
        &mut out,
        "sensor_size_mm",
        &format!("{:?}", cfg.sensor_size_mm),
    );
    if let Some(f) = cfg.fstop {
        put(&mut out, "fstop", &format!("{f:?}"));
    }
    put_ordered(&mut out, &cfg.intrinsics_extra, &[]);
    out.push_str("\n[extrinsics]\n");
    put(&mut out, "num_cams_x", &cfg.num_cams_x.to_string());
    put(&mut out, "num_cams_y", &cfg.num_cams_y.to_string());
    put(&mut out, "baseline_mm", &format!("{:?}", cfg.baseline_mm));
    put(
        &mut out,
        "focus_distance_m",
        &format!("{:?}", cfg.focus_distance_m),
    );
    put_ordered(&mut out, &cfg.extrinsics_extra, &EXTRINSICS_ORDER);
    out.push_str("\n[meta]\n");
    put_ordered(&mut out, &cfg.meta, &META_ORDER);
    out
}

/// Writes `lf` as an HCI folder in `dir` (created if needed): `parameters.cfg` from `cfg`,
/// the views as 8-bit RGB PNGs `input_CamNNN.png`, and the depth maps of the centre view as
/// `gt_disp_lowres.pfm` / `gt_depth_lowres.pfm`. Depth maps of other views have no place in
/// the layout and are skipped with a warning. `cfg` must match the light field's grid and size.
pub fn write(lf: &LightField, cfg: &HciConfig, dir: &Path) -> Result<()> {
    if cfg.grid() != lf.grid
        || (cfg.image_resolution_x_px, cfg.image_resolution_y_px) != (lf.width, lf.height)
    {
        return Err(Error::Invalid(format!(
            "HCI config for {}×{} views of {}×{} does not match light field {} ({}×{} views of \
             {}×{})",
            cfg.num_cams_x,
            cfg.num_cams_y,
            cfg.image_resolution_x_px,
            cfg.image_resolution_y_px,
            lf.name,
            lf.grid.cols,
            lf.grid.rows,
            lf.width,
            lf.height
        )));
    }
    if lf.views.len() != lf.grid.len() {
        return Err(Error::LightField(format!(
            "{}: {} views for a {}×{} grid",
            lf.name,
            lf.views.len(),
            lf.grid.cols,
            lf.grid.rows
        )));
    }
    let folder = crate::io::OutputFolder::create(dir)?;
    write_into(lf, cfg, &folder)?;
    folder.finish();
    Ok(())
}

/// [`write`] into an output folder that the caller finishes (or drops, removing every file).
pub fn write_into(
    lf: &LightField,
    cfg: &HciConfig,
    folder: &crate::io::OutputFolder,
) -> Result<()> {
    folder.write_bytes(CONFIG_NAME, "HCI parameters", format_config(cfg).as_bytes())?;
    let count = lf.views.len();
    lf.views.par_iter().enumerate().try_for_each(|(i, v)| {
        let rgb: RgbImage = v.image.convert();
        folder.write_with(view_file_name(i, count), "PNG", |w| {
            crate::io::encode_png(&rgb, w)
        })?;
        Ok::<_, Error>(())
    })?;
    let centre = lf.grid.index(lf.grid.cols / 2, lf.grid.rows / 2);
    for (i, map) in &lf.depth {
        if *i != centre {
            log::warn!(
                "{}: the HCI layout holds depth for the centre view only; skipping {}",
                lf.name,
                map.source
            );
            continue;
        }
        let file = match map.kind {
            DepthKind::Disparity => DISPARITY_NAME,
            DepthKind::Depth => DEPTH_NAME,
        };
        let bytes = encode_pfm(
            &folder.path().join(file),
            map.width,
            map.height,
            1,
            &map.values,
        )?;
        folder.write_bytes(file, "PFM", &bytes)?;
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::lightfield::DepthMap;
    use crate::lightfield::View;
    use image::{Rgba, RgbaImage};

    /// The backgammon file, verbatim.
    const BACKGAMMON: &str = "[intrinsics]
focal_length_mm = 100.0
image_resolution_x_px = 512
image_resolution_y_px = 512
sensor_size_mm = 35.0
fstop = 100.0

[extrinsics]
num_cams_x = 9
num_cams_y = 9
baseline_mm = 30.0
focus_distance_m = 8.300000190734863
center_cam_x_m = -0.08955532312393188
center_cam_y_m = 0.043219193816185
center_cam_z_m = 11.381952285766602
center_cam_rx_rad = 0.0
center_cam_ry_rad = 0.0
center_cam_rz_rad = 1.5707963705062866

[meta]
scene = backgammon
category = stratified
date = 2016-09-25
version = v2.0
authors = Katrin Honauer, Ole Johannsen, Daniel Kondermann, Bastian Goldluecke
contact = contact@lightfield-analysis.net
disp_min = -1.7
disp_max = 0.7
frustum_disp_min = -2.0
frustum_disp_max = 2.0
depth_map_scale = 10.0
";

    /// Pixel colour that encodes the view and the position, so order mix-ups show.
    pub(crate) fn pixel(s: usize, t: usize, x: u32, y: u32) -> Rgba<u8> {
        Rgba([
            (s * 40 + x as usize) as u8,
            (t * 40 + y as usize) as u8,
            (s * 7 + t * 31 + (x * y) as usize) as u8,
            255,
        ])
    }

    /// A generated `cols × rows` light field of `w × h` views taken by `rig`, with a disparity
    /// map and a depth map on the centre view.
    pub(crate) fn synthetic(
        cols: usize,
        rows: usize,
        w: u32,
        h: u32,
        rig: ParallelRig,
    ) -> LightField {
        let grid = GridSize { cols, rows };
        let cams = rig.cameras(grid, w, h);
        let views = cams
            .into_iter()
            .enumerate()
            .map(|(i, camera)| {
                let (s, t) = (i % cols, i / cols);
                View {
                    s,
                    t,
                    camera,
                    image: RgbaImage::from_fn(w, h, |x, y| pixel(s, t, x, y)),
                    source: "generated".into(),
                }
            })
            .collect();
        let n = (w * h) as usize;
        let disp = DepthMap {
            width: w,
            height: h,
            kind: DepthKind::Disparity,
            values: (0..n)
                .map(|i| {
                    if i == 5 {
                        f32::NAN
                    } else {
                        i as f32 * 0.01 - 0.3
                    }
                })
                .collect(),
            source: "generated".into(),
            estimated: false,
        };
        let depth = DepthMap {
            kind: DepthKind::Depth,
            values: (0..n).map(|i| 1.0 + i as f32 * 0.125).collect(),
            ..disp.clone()
        };
        let centre = grid.index(cols / 2, rows / 2);
        LightField {
            name: "synthetic".into(),
            grid,
            width: w,
            height: h,
            views,
            depth: vec![(centre, disp), (centre, depth)],
            rig: Some(rig),
            disparity_range: None,
            source: Source::Generated {
                scene: "synthetic".into(),
            },
        }
    }

    fn rig() -> ParallelRig {
        ParallelRig {
            focal_px: 20.0,
            baseline: 0.05,
            focus_distance: 2.0,
        }
    }

    fn p() -> &'static Path {
        Path::new("scene/parameters.cfg")
    }

    #[test]
    fn parses_the_benchmark_file() {
        let cfg = parse_config(BACKGAMMON, p()).unwrap();
        assert_eq!(cfg.focal_length_mm, 100.0);
        assert_eq!(
            (cfg.image_resolution_x_px, cfg.image_resolution_y_px),
            (512, 512)
        );
        assert_eq!(cfg.sensor_size_mm, 35.0);
        assert_eq!(cfg.fstop, Some(100.0));
        assert_eq!((cfg.num_cams_x, cfg.num_cams_y), (9, 9));
        assert_eq!(cfg.baseline_mm, 30.0);
        assert_eq!(cfg.focus_distance_m, 8.300000190734863);
        assert_eq!(cfg.meta["scene"], "backgammon");
        assert_eq!(
            cfg.meta["authors"],
            "Katrin Honauer, Ole Johannsen, Daniel Kondermann, Bastian Goldluecke"
        );
        assert_eq!(
            cfg.extrinsics_extra["center_cam_rz_rad"],
            "1.5707963705062866"
        );
        assert_eq!(cfg.extrinsics_extra.len(), 6);
        assert!(cfg.intrinsics_extra.is_empty());
        let rig = cfg.rig();
        assert!((rig.focal_px - 100.0 * 512.0 / 35.0).abs() < 1e-12);
        assert_eq!(rig.baseline, 0.03);
        assert_eq!(rig.focus_distance, 8.300000190734863);
    }

    #[test]
    fn format_then_parse_is_identity_and_keeps_key_order() {
        let cfg = parse_config(BACKGAMMON, p()).unwrap();
        let text = format_config(&cfg);
        assert_eq!(parse_config(&text, p()).unwrap(), cfg);
        // The benchmark's own order: the formatted text equals the original file.
        assert_eq!(text, BACKGAMMON);
    }

    #[test]
    fn tolerates_comments_blank_lines_and_spacing() {
        let text = "# made by hand\n; another comment\n\n  [intrinsics]  \n\
                    focal_length_mm=50\nimage_resolution_x_px = 640\n\
                    image_resolution_y_px = 480.0\nsensor_size_mm\t=\t36\n\
                    [extrinsics]\nnum_cams_x = 5\nnum_cams_y = 3\nbaseline_mm = 10\n\
                    focus_distance_m = 2\noffset = 0.5\n";
        let cfg = parse_config(text, p()).unwrap();
        assert_eq!(cfg.fstop, None);
        assert_eq!(
            (cfg.image_resolution_x_px, cfg.image_resolution_y_px),
            (640, 480)
        );
        assert_eq!((cfg.num_cams_x, cfg.num_cams_y), (5, 3));
        assert_eq!(cfg.extrinsics_extra["offset"], "0.5");
        assert!(cfg.meta.is_empty());
        // f_px uses max(W, H).
        assert!((cfg.rig().focal_px - 50.0 * 640.0 / 36.0).abs() < 1e-12);
    }

    fn err_of(text: &str) -> String {
        parse_config(text, p()).unwrap_err().to_string()
    }

    #[test]
    fn missing_key_names_file_and_key() {
        let text = BACKGAMMON.replace("baseline_mm = 30.0\n", "");
        let msg = err_of(&text);
        assert!(msg.contains("scene/parameters.cfg"), "{msg}");
        assert!(
            msg.contains("missing key `baseline_mm` in [extrinsics]"),
            "{msg}"
        );
        // A key in the wrong section is pointed out.
        let text = BACKGAMMON
            .replace("sensor_size_mm = 35.0\n", "")
            .replace("[meta]\n", "[meta]\nsensor_size_mm = 35.0\n");
        let msg = err_of(&text);
        assert!(
            msg.contains("`sensor_size_mm` in [intrinsics] (it is in [meta])"),
            "{msg}"
        );
    }

    #[test]
    fn bad_numbers_show_key_and_text() {
        let msg = err_of(&BACKGAMMON.replace("= 100.0\nimage", "= 10O.0\nimage"));
        assert!(msg.contains("scene/parameters.cfg"), "{msg}");
        assert!(
            msg.contains("`focal_length_mm` = `10O.0` is not a number"),
            "{msg}"
        );
        assert!(msg.contains("line 2"), "{msg}");
        let msg = err_of(&BACKGAMMON.replace("num_cams_x = 9", "num_cams_x = 0"));
        assert!(
            msg.contains("`num_cams_x` must be a positive number, found `0`"),
            "{msg}"
        );
        let msg = err_of(&BACKGAMMON.replace("focus_distance_m = 8.3", "focus_distance_m = -8.3"));
        assert!(
            msg.contains("`focus_distance_m` must be a positive"),
            "{msg}"
        );
        let msg = err_of(&BACKGAMMON.replace("_x_px = 512", "_x_px = 512.5"));
        assert!(
            msg.contains("`image_resolution_x_px` must be a positive whole"),
            "{msg}"
        );
        let msg = err_of(&BACKGAMMON.replace("fstop = 100.0", "fstop = inf"));
        assert!(msg.contains("`fstop` must be a positive number"), "{msg}");
    }

    #[test]
    fn structural_errors_name_the_line() {
        let msg = err_of(&format!("focal_length_mm = 1\n{BACKGAMMON}"));
        assert!(
            msg.contains("line 1: key `focal_length_mm` is outside any [section]"),
            "{msg}"
        );
        let msg = err_of(&BACKGAMMON.replace("fstop = 100.0", "fstop 100.0"));
        assert!(msg.contains("line 6: expected `key = value`"), "{msg}");
        let msg = err_of(&BACKGAMMON.replace("[meta]", "[meta"));
        assert!(msg.contains("lacks its closing `]`"), "{msg}");
        let msg = err_of(&format!("{BACKGAMMON}scene = again\n"));
        assert!(
            msg.contains("`scene` in [meta] is given twice (first on line 21)"),
            "{msg}"
        );
        let msg = err_of(&BACKGAMMON.replace("num_cams_y = 9", "num_cams_y = 100000"));
        assert!(msg.contains("implausible"), "{msg}");
    }

    #[test]
    fn view_names_have_at_least_three_digits() {
        assert_eq!(view_file_name(0, 81), "input_Cam000.png");
        assert_eq!(view_file_name(80, 81), "input_Cam080.png");
        assert_eq!(view_file_name(999, 1000), "input_Cam999.png");
        assert_eq!(view_file_name(7, 1001), "input_Cam0007.png");
    }

    #[test]
    fn write_then_load_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        // 3 columns × 2 rows: non-square, so a row/column mix-up cannot pass.
        let lf = synthetic(3, 2, 16, 12, rig());
        let mut cfg = config_for(&lf, &rig(), 36.0);
        cfg.fstop = Some(2.8);
        cfg.extrinsics_extra.insert("offset".into(), "0.25".into());
        write(&lf, &cfg, dir.path()).unwrap();
        assert!(dir.path().join("input_Cam005.png").is_file());
        assert!(!dir.path().join("input_Cam006.png").exists());

        let back = load(dir.path()).unwrap();
        back.validate().unwrap();
        assert_eq!(back.name, "synthetic");
        assert_eq!(back.grid, GridSize { cols: 3, rows: 2 });
        assert_eq!((back.width, back.height), (16, 12));
        let Source::Hci(bcfg) = &back.source else {
            panic!("source {:?}", back.source)
        };
        assert_eq!(bcfg, &cfg);
        let brig = back.rig.unwrap();
        assert!((brig.focal_px - 20.0).abs() < 1e-12);
        assert!((brig.baseline - 0.05).abs() < 1e-15);
        assert_eq!(brig.focus_distance, 2.0);
        for t in 0..2 {
            for s in 0..3 {
                let v = &back.views[t * 3 + s];
                assert_eq!((v.s, v.t), (s, t));
                assert!(v.source.ends_with(&view_file_name(t * 3 + s, 6)));
                for (x, y, px) in v.image.enumerate_pixels() {
                    assert_eq!(*px, pixel(s, t, x, y), "view ({s},{t}) pixel ({x},{y})");
                }
                let orig = &lf.views[t * 3 + s].camera;
                assert!((v.camera.k - orig.k).abs_diff_eq(glam::DMat3::ZERO, 1e-9));
                assert!((v.camera.centre() - orig.centre()).length() < 1e-12);
            }
        }
        // Sensor shift sign: the right-hand camera's principal point moves right by f·b/Z.
        let shift = 20.0 * 0.05 / 2.0;
        let cx = |s: usize| back.view(s, 0).camera.k.z_axis.x;
        assert!((cx(2) - (7.5 + shift)).abs() < 1e-9);
        assert!((cx(0) - (7.5 - shift)).abs() < 1e-9);
        // Grid centre of a 3×2 grid is (1, 0.5): row 0 shifts up, its camera sits at y < 0.
        assert!((back.view(1, 0).camera.k.z_axis.y - (5.5 - 0.5 * shift)).abs() < 1e-9);
        assert!((back.view(1, 0).camera.centre().y + 0.5 * 0.05).abs() < 1e-12);

        assert_eq!(back.depth.len(), 2);
        for (i, d) in &back.depth {
            assert_eq!(*i, 4, "depth belongs to the centre view (1, 1)");
            let orig = &lf.depth.iter().find(|(_, o)| o.kind == d.kind).unwrap().1;
            assert_eq!(d.values.len(), orig.values.len());
            for (a, b) in d.values.iter().zip(&orig.values) {
                assert!(a == b || (a.is_nan() && b.is_nan()), "{a} vs {b}");
            }
        }
        assert!(back
            .depth
            .iter()
            .any(|(_, d)| d.kind == DepthKind::Disparity));
        assert!(back.depth.iter().any(|(_, d)| d.kind == DepthKind::Depth));
    }

    #[test]
    fn config_for_reproduces_focal_px() {
        let lf = synthetic(3, 3, 16, 12, rig());
        let r = ParallelRig {
            focal_px: 1234.5678,
            baseline: 0.02,
            focus_distance: 3.5,
        };
        let cfg = config_for(&lf, &r, 35.0);
        let back = cfg.rig();
        assert!((back.focal_px - r.focal_px).abs() < 1e-9);
        assert!((back.baseline - r.baseline).abs() < 1e-15);
        assert_eq!(back.focus_distance, r.focus_distance);
        assert_eq!(cfg.meta["scene"], "synthetic");
    }

    fn written() -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        let lf = synthetic(3, 3, 16, 12, rig());
        write(&lf, &config_for(&lf, &rig(), 35.0), dir.path()).unwrap();
        dir
    }

    #[test]
    fn missing_view_is_named() {
        let dir = written();
        std::fs::remove_file(dir.path().join("input_Cam004.png")).unwrap();
        let err = load(dir.path()).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains("input_Cam004.png"), "{msg}");
        assert!(
            msg.contains("3×3 views input_Cam000.png … input_Cam008.png"),
            "{msg}"
        );
    }

    #[test]
    fn missing_config_is_an_io_error() {
        let dir = written();
        std::fs::remove_file(dir.path().join(CONFIG_NAME)).unwrap();
        let err = load(dir.path()).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err:?}");
        assert!(err.to_string().contains("parameters.cfg"));
    }

    #[test]
    fn views_of_the_wrong_size_are_named() {
        let dir = written();
        let cfg_path = dir.path().join(CONFIG_NAME);
        let text = std::fs::read_to_string(&cfg_path).unwrap();
        std::fs::write(&cfg_path, text.replace("_x_px = 16", "_x_px = 17")).unwrap();
        let msg = load(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("input_Cam000.png"), "{msg}");
        assert!(msg.contains("16×12") && msg.contains("17×12"), "{msg}");

        let dir = written();
        RgbaImage::new(16, 13)
            .save(dir.path().join("input_Cam007.png"))
            .unwrap();
        let msg = load(dir.path()).unwrap_err().to_string();
        assert!(
            msg.contains("input_Cam007.png") && msg.contains("16×13"),
            "{msg}"
        );
    }

    #[test]
    fn depth_map_of_the_wrong_size_is_named() {
        let dir = written();
        crate::lightfield::pfm::write_pfm(&dir.path().join(DEPTH_NAME), 12, 16, 1, &[1.0; 192])
            .unwrap();
        let msg = load(dir.path()).unwrap_err().to_string();
        assert!(msg.contains(DEPTH_NAME), "{msg}");
        assert!(msg.contains("12×16") && msg.contains("16×12"), "{msg}");
    }

    #[test]
    fn write_rejects_a_mismatched_config() {
        let dir = tempfile::tempdir().unwrap();
        let lf = synthetic(3, 3, 16, 12, rig());
        let mut cfg = config_for(&lf, &rig(), 35.0);
        cfg.num_cams_x = 4;
        assert!(matches!(
            write(&lf, &cfg, dir.path()),
            Err(Error::Invalid(_))
        ));
    }
}
