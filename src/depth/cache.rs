//! The depth cache and [`ensure_depth`], which gives a light field without a depth map its
//! estimate wherever depth is needed (clicks, point clouds, the viewer's scene).
//!
//! Estimates are cached in the user's cache folder — `$TILTFIELD_CACHE_DIR`, else
//! `$XDG_CACHE_HOME/tiltfield/depth`, else `~/.cache/tiltfield/depth` — not next to the light
//! field, since data folders are often shared or read-only. The key is a 128-bit xxh3 hash of
//! everything the estimate depends on: an algorithm version and a digest of the estimator's
//! source (build.rs), the grid, every view's pixels and camera, the rig, the dataset's
//! disparity range, the sweep convention and the options. Any change of content gives another
//! key, so a stale estimate is never reused. Per key two files: `KEY.json` (what was estimated,
//! how, on which device, and a content hash of the key, the metadata and the data) and
//! `KEY.pfm` (three channels: the sweep parameter, the confidence, 0). Both are written through
//! [`crate::io`]: temporary files created exclusively (never through a link planted in the
//! folder), checked writes, then renamed, so a crash leaves no half file. Reading takes only
//! regular files in the folder itself and checks the hash first; a damaged, edited, older or
//! planted entry is estimated again (with a warning) and replaced, and a cache folder that
//! cannot be written only costs the reuse.
//!
//! Trust model: the cache may be shared. Whatever others put in it cannot make tiltfield write
//! or read outside it, block on a FIFO or device, or use an entry whose content does not match
//! its hash. The hash (xxh3) detects damage and edits, not forgery: someone who can write the
//! folder can compute a matching hash, so share a cache only with people whose estimates you
//! would accept.

use std::path::{Path, PathBuf};

use super::{sweep, DepthEstimate, DepthOptions};
use crate::error::{Error, Result};
use crate::lightfield::pfm::{decode_pfm, encode_pfm};
use crate::lightfield::LightField;

/// Bumped whenever the estimator's output for the same input changes. The key also holds
/// [`SOURCE_DIGEST`], so a change of the estimator's code alone already misses the cache.
const ALGORITHM_VERSION: &str = "tiltfield-depth-12";

/// A digest of the estimator's source (`src/depth/`, `src/passes/depth/`, `src/jobs/depth.rs`,
/// `shaders/depth_*`; build.rs).
const SOURCE_DIGEST: &str = env!("TILTFIELD_DEPTH_SOURCE_DIGEST");

/// Pixels whose confidence is below this are left out of the map installed by
/// [`ensure_depth`] (NaN: a click there is refused naming the cause; the cloud skips them).
pub const MIN_CONFIDENCE: f32 = 0.01;

/// Where the depth used by a command came from (reported by `--json` as `depth`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "origin", rename_all = "lowercase")]
pub enum DepthOrigin {
    /// The light field's own map.
    Given { source: String },
    /// Estimated from the views now, or taken from the cache.
    Estimated {
        cached: bool,
        /// The cache entry (`None` when the cache could not be written).
        cache_file: Option<PathBuf>,
        /// What was estimated (boxed: it is large next to the other variant).
        estimate: Box<DepthEstimate>,
        /// Pixels below this confidence were left out of the installed map.
        min_confidence: f32,
    },
}

impl DepthOrigin {
    /// The `depth` object of a command's `--json`: where the depth came from (the estimate
    /// in full).
    pub fn json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or_default()
    }

    /// Where the depth came from, by name only (a screenshot's sidecar: the full origin
    /// carries the whole estimate).
    pub fn brief_json(&self) -> serde_json::Value {
        match self {
            DepthOrigin::Given { source } => {
                serde_json::json!({"origin": "given", "source": source})
            }
            DepthOrigin::Estimated { cached, .. } => {
                serde_json::json!({"origin": "estimated", "cached": cached})
            }
        }
    }

    /// The default window of a click's normal on this depth: 9 px on the light field's own
    /// map, 31 px on an estimate ([`crate::geometry::normals::ESTIMATED_DEPTH_WINDOW`]).
    pub fn normal_window(&self) -> u32 {
        match self {
            DepthOrigin::Given { .. } => crate::geometry::normals::GIVEN_DEPTH_WINDOW,
            DepthOrigin::Estimated { .. } => crate::geometry::normals::ESTIMATED_DEPTH_WINDOW,
        }
    }
}

/// The cache folder (see the module docs).
pub fn cache_dir() -> Option<PathBuf> {
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    env("TILTFIELD_CACHE_DIR")
        .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("tiltfield").join("depth")))
        .or_else(|| env("HOME").map(|d| d.join(".cache").join("tiltfield").join("depth")))
}

/// The content key of estimating `lf` with `options` (32 hex digits).
pub fn cache_key(lf: &LightField, options: &DepthOptions) -> String {
    key_of(lf, options, SOURCE_DIGEST)
}

/// [`cache_key`] with the estimator's source digest given.
fn key_of(lf: &LightField, options: &DepthOptions, source_digest: &str) -> String {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    let mut text = |s: &str| {
        h.update(&(s.len() as u64).to_le_bytes());
        h.update(s.as_bytes());
    };
    text(ALGORITHM_VERSION);
    text(source_digest);
    let meta = serde_json::json!({
        "grid": [lf.grid.cols, lf.grid.rows],
        "size": [lf.width, lf.height],
        "rig": lf.rig,
        "disparity_range": lf.disparity_range,
        "convention": sweep::convention_of(lf),
        "options": options,
    });
    text(&meta.to_string());
    for v in &lf.views {
        let c = &v.camera;
        for m in [c.k, c.r] {
            for x in m.to_cols_array() {
                h.update(&x.to_le_bytes());
            }
        }
        for x in c.t.to_array() {
            h.update(&x.to_le_bytes());
        }
        h.update(&(v.s as u64).to_le_bytes());
        h.update(&(v.t as u64).to_le_bytes());
        h.update(v.image.as_raw());
    }
    format!("{:032x}", h.digest128())
}

/// Name of the metadata field holding the entry's content hash.
const HASH_FIELD: &str = "entry_xxh3";

/// The content hash of an entry: its key, its metadata text (every byte, so any edited field
/// changes it) and its data file's bytes.
fn entry_hash(key: &str, meta: &str, data: &[u8]) -> String {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    for part in [key.as_bytes(), meta.as_bytes(), data] {
        h.update(&(part.len() as u64).to_le_bytes());
        h.update(part);
    }
    format!("{:032x}", h.digest128())
}

/// The metadata file's text: `meta` (pretty JSON of the estimate, ending in `\n}`) with the
/// hash as its last field. The hash covers `meta`'s exact text, recovered by [`split_hash`],
/// so no float has to survive a parse and a print unchanged.
fn join_hash(meta: &str, hash: &str) -> Option<String> {
    let body = meta.strip_suffix("\n}")?;
    Some(format!("{body},\n  \"{HASH_FIELD}\": \"{hash}\"\n}}\n"))
}

/// The inverse of [`join_hash`]: the hashed text and the hash; `None` for any other shape.
fn split_hash(text: &str) -> Option<(String, String)> {
    let head = format!(",\n  \"{HASH_FIELD}\": \"");
    let at = text.rfind(&head)?;
    let hash = text[at + head.len()..].strip_suffix("\"\n}\n")?;
    if hash.len() != 32 || !hash.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    Some((format!("{}\n}}", &text[..at]), hash.to_string()))
}

/// Reads the entry `key` from `dir`; `None` when there is none, or when it is damaged or not
/// what it claims (with a warning naming the file): then it is estimated again and replaced.
/// Only regular files in the folder itself are read (a link planted in the cache folder is
/// never followed), and the content hash in the metadata must match before anything is used.
pub fn load(dir: &Path, key: &str) -> Option<DepthEstimate> {
    let meta_path = dir.join(format!("{key}.json"));
    let data_path = dir.join(format!("{key}.pfm"));
    if std::fs::symlink_metadata(&meta_path).is_err() {
        return None;
    }
    let read = || -> std::result::Result<DepthEstimate, String> {
        for p in [&meta_path, &data_path] {
            match std::fs::symlink_metadata(p) {
                Ok(m) if m.is_file() => {}
                Ok(m) => {
                    return Err(format!(
                        "{} is {}, not a regular file",
                        p.display(),
                        crate::io::kind_of(&m)
                    ))
                }
                Err(e) => return Err(format!("{}: {e}", p.display())),
            }
        }
        let text =
            crate::io::read_text(&meta_path, "a depth cache entry").map_err(|e| e.to_string())?;
        let (meta, stored) = split_hash(&text).ok_or_else(|| {
            format!("the metadata does not end in its {HASH_FIELD} (an older or edited entry)")
        })?;
        let bytes = crate::io::read_file(
            &data_path,
            "a depth cache entry",
            crate::lightfield::pfm::MAX_PFM_BYTES,
        )
        .map_err(|e| e.to_string())?;
        if entry_hash(key, &meta, &bytes) != stored {
            return Err("its content does not match the hash in its metadata".into());
        }
        // Unknown fields (the hash) are ignored by the estimate's deserialisation.
        let mut est: DepthEstimate = serde_json::from_str(&text).map_err(|e| e.to_string())?;
        let (w, h, channels, data) = decode_pfm(&bytes, &data_path).map_err(|e| e.to_string())?;
        if (w, h, channels) != (est.width, est.height, 3) {
            return Err(format!(
                "{} does not match its metadata",
                data_path.display()
            ));
        }
        est.param = data.iter().step_by(3).copied().collect();
        est.confidence = data.iter().skip(1).step_by(3).copied().collect();
        Ok(est)
    };
    match read() {
        Ok(est) => Some(est),
        Err(e) => {
            log::warn!(
                "depth cache entry {} is unusable ({e}); estimating again",
                meta_path.display()
            );
            None
        }
    }
}

/// Writes `est` as entry `key` in `dir` (creating it); returns the metadata file. Both files
/// go through [`crate::io::write_bytes`] (exclusive temporary file, checked writes, rename);
/// an entry that is a link or another non-file is removed first (never followed), so a damaged
/// or planted entry is replaced rather than blocking the cache.
pub fn store(dir: &Path, key: &str, est: &DepthEstimate) -> Result<PathBuf> {
    let meta_path = dir.join(format!("{key}.json"));
    let data_path = dir.join(format!("{key}.pfm"));
    for p in [&meta_path, &data_path] {
        if let Ok(m) = std::fs::symlink_metadata(p) {
            if !m.is_file() && !m.is_dir() {
                // `remove_file` on a link removes the link, never its target.
                std::fs::remove_file(p).map_err(|e| Error::io(p, e))?;
            }
        }
    }
    let data: Vec<f32> = est
        .param
        .iter()
        .zip(&est.confidence)
        .flat_map(|(&p, &c)| [p, c, 0.0])
        .collect();
    let bytes = encode_pfm(&data_path, est.width, est.height, 3, &data)?;
    let meta = serde_json::to_string_pretty(est).map_err(|e| Error::Invalid(e.to_string()))?;
    let text = join_hash(&meta, &entry_hash(key, &meta, &bytes)).ok_or_else(|| {
        Error::Invalid("the depth estimate's metadata is not a JSON object".into())
    })?;
    // Data first: a metadata file only ever names complete data.
    crate::io::write_bytes(&data_path, "depth cache data", &bytes)?;
    crate::io::write_bytes(&meta_path, "depth cache metadata", text.as_bytes())?;
    Ok(meta_path)
}

/// The cached estimate of `lf` with `options` in cache folder `dir`, or a new one from
/// `estimate` (stored there; `None`: no cache). The estimator is passed in so that the cache
/// stays GPU-free: the driver [`crate::jobs::depth`] hands it the GPU sweep.
pub fn cached_estimate(
    lf: &LightField,
    options: &DepthOptions,
    dir: Option<PathBuf>,
    estimate: impl FnOnce(&LightField, &DepthOptions) -> Result<DepthEstimate>,
) -> Result<(DepthEstimate, bool, Option<PathBuf>)> {
    options.validate()?;
    let key = cache_key(lf, options);
    if let Some(dir) = &dir {
        if let Some(est) = load(dir, &key) {
            let file = dir.join(format!("{key}.json"));
            // An entry with a matching hash may still be forged (the hash detects damage, not
            // forgery): one that cannot be this light field's is named and estimated again,
            // like a damaged one, instead of failing later without naming the file.
            if fits(lf, &est) {
                return Ok((est, true, Some(file)));
            }
            log::warn!(
                "{}: the cached depth estimate is {}×{} of view {}, but the light field's \
                 views are {}×{} ({} views); estimating again",
                file.display(),
                est.width,
                est.height,
                est.reference,
                lf.width,
                lf.height,
                lf.views.len()
            );
        }
    }
    let est = estimate(lf, options)?;
    let file = match &dir {
        Some(dir) => match store(dir, &key, &est) {
            Ok(p) => Some(p),
            Err(e) => {
                log::warn!("cannot cache the depth estimate: {e}");
                None
            }
        },
        None => {
            log::warn!(
                "no cache folder (set TILTFIELD_CACHE_DIR or HOME); the estimate is not kept"
            );
            None
        }
    };
    Ok((est, false, file))
}

/// Makes sure `lf` has a depth map: its own when it has one, else the estimate of its
/// reference view from the cache in `dir` (`None`: no cache) or from `estimate`. The estimate is
/// installed as the light field's map with pixels of confidence below [`MIN_CONFIDENCE`] left
/// out. On a grid folder the nominal cameras get the sensor shift of
/// [`DepthEstimate::nominal_rig`], so that every estimated surface has a depth and a plane
/// picked on it refocuses exactly there (classic `--disparity` does not use the cameras and is
/// unchanged). [`crate::jobs::depth::ensure_depth`] is this with the GPU sweep and the default
/// cache folder.
pub fn ensure_depth_in(
    lf: &mut LightField,
    options: &DepthOptions,
    dir: Option<PathBuf>,
    estimate: impl FnOnce(&LightField, &DepthOptions) -> Result<DepthEstimate>,
) -> Result<DepthOrigin> {
    if let Some(origin) = given_origin(lf) {
        return Ok(origin);
    }
    let origin = estimated_origin(lf, options, dir, estimate)?;
    if let DepthOrigin::Estimated { estimate, .. } = &origin {
        install(lf, estimate)?;
    }
    Ok(origin)
}

/// The origin of `lf`'s own depth map, when it has one.
pub fn given_origin(lf: &LightField) -> Option<DepthOrigin> {
    lf.depth.first().map(|(_, map)| DepthOrigin::Given {
        source: map.source.clone(),
    })
}

/// The estimate of [`ensure_depth_in`] (from the cache in `dir`, else made by `estimate` and
/// stored there) without installing it: the viewer estimates on a background thread from a
/// light field it keeps drawing, and installs the result ([`install`]) when it arrives.
pub fn estimated_origin(
    lf: &LightField,
    options: &DepthOptions,
    dir: Option<PathBuf>,
    estimate: impl FnOnce(&LightField, &DepthOptions) -> Result<DepthEstimate>,
) -> Result<DepthOrigin> {
    let (est, cached, cache_file) = cached_estimate(lf, options, dir, estimate)?;
    Ok(DepthOrigin::Estimated {
        cached,
        cache_file,
        estimate: Box::new(est),
        min_confidence: MIN_CONFIDENCE,
    })
}

/// Whether `est` can be `lf`'s estimate: its size and reference view.
fn fits(lf: &LightField, est: &DepthEstimate) -> bool {
    (est.width, est.height) == (lf.width, lf.height) && est.reference < lf.views.len()
}

/// Installs `est` as `lf`'s depth map (see [`ensure_depth`]).
pub fn install(lf: &mut LightField, est: &DepthEstimate) -> Result<()> {
    if !fits(lf, est) {
        return Err(Error::Invalid(
            "the depth estimate does not belong to this light field".into(),
        ));
    }
    if let Some(rig) = est.nominal_rig() {
        for (v, camera) in lf
            .views
            .iter_mut()
            .zip(rig.cameras(lf.grid, lf.width, lf.height))
        {
            v.camera = camera;
        }
    }
    let mut map = est.depth_map(MIN_CONFIDENCE);
    // The sweep reaches one plane beyond a dataset's range; the map stays inside it (values
    // outside would read as invalid).
    if let (crate::lightfield::DepthKind::Disparity, Some((lo, hi))) =
        (map.kind, lf.disparity_range)
    {
        for v in map.values.iter_mut().filter(|v| v.is_finite()) {
            *v = v.clamp(lo as f32, hi as f32);
        }
    }
    lf.depth.push((est.reference, map));
    lf.validate()
}

/// Installs a classic shift-and-sum disparity map of the middle view `(cols/2, rows/2)`,
/// handed over with a grid of views (the Python module's `from_array(depth=…)`), as
/// [`install`] installs an estimate of a grid folder: the grid's cameras take the nominal
/// sensor shift of the map's range ([`super::nominal_rig`]) and the map becomes depth under
/// it, so a plane picked on it refocuses exactly there. NaN marks pixels without a value.
pub fn install_classic_disparity(
    lf: &mut LightField,
    values: Vec<f32>,
    focal_px: f64,
    baseline: f64,
) -> Result<()> {
    if values.len() != lf.width as usize * lf.height as usize {
        return Err(Error::Invalid(format!(
            "the disparity map has {} values, the views {}×{} pixels",
            values.len(),
            lf.width,
            lf.height
        )));
    }
    let finite = values.iter().filter(|v| v.is_finite()).map(|&v| v as f64);
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if lo > hi {
        return Err(Error::Invalid(
            "the disparity map has no finite value; pass depth=None for a light field without \
             depth"
                .into(),
        ));
    }
    // A flat map has no range to place infinity beyond: give it one pixel per grid step.
    let range = if lo < hi {
        (lo, hi)
    } else {
        (lo - 0.5, hi + 0.5)
    };
    let rig = super::nominal_rig(focal_px, baseline, range);
    for (v, camera) in lf
        .views
        .iter_mut()
        .zip(rig.cameras(lf.grid, lf.width, lf.height))
    {
        v.camera = camera;
    }
    let depth = values
        .iter()
        .map(|&d| {
            rig.depth_of_disparity(-(d as f64))
                .map_or(f32::NAN, |z| z as f32)
        })
        .collect();
    let reference = lf.grid.index(lf.grid.cols / 2, lf.grid.rows / 2);
    let map = crate::lightfield::DepthMap {
        width: lf.width,
        height: lf.height,
        kind: crate::lightfield::DepthKind::Depth,
        values: depth,
        source: format!("{} disparity map", lf.name),
        estimated: false,
    };
    lf.depth.push((reference, map));
    lf.validate()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_installed_classic_disparity_map_puts_larger_disparity_farther() {
        use crate::lightfield::{grid_folder, DepthKind, GridCameraOptions, GridSize};
        let grid = GridSize { cols: 3, rows: 3 };
        let images = vec![image::RgbaImage::new(4, 2); 9];
        let opts = GridCameraOptions {
            focal_px: Some(100.0),
            baseline: 0.5,
        };
        let mut lf = grid_folder::from_images("t", grid, images, &opts).unwrap();
        let values = vec![-1.0, 0.0, 0.5, 1.0, f32::NAN, -1.0, 0.0, 1.0];
        install_classic_disparity(&mut lf, values, 100.0, 0.5).unwrap();
        let (view, map) = &lf.depth[0];
        assert_eq!(
            (*view, map.kind),
            (4, DepthKind::Depth),
            "the middle view's depth"
        );
        let z = &map.values;
        assert!(z[0] < z[1] && z[1] < z[2] && z[2] < z[3], "{z:?}");
        assert!(z[4].is_nan() && z[..4].iter().all(|v| v.is_finite() && *v > 0.0));
        // The cameras took the nominal sensor shift: the principal points moved.
        assert_ne!(lf.views[0].camera.k, lf.views[4].camera.k);
        let e = install_classic_disparity(&mut lf, vec![1.0; 3], 100.0, 0.5).unwrap_err();
        assert!(e.to_string().contains("3 values"), "{e}");
        let flat = grid_folder::from_images("t", grid, vec![image::RgbaImage::new(2, 1); 9], &opts);
        let mut flat = flat.unwrap();
        install_classic_disparity(&mut flat, vec![0.0, 0.0], 100.0, 0.5).unwrap();
        assert!(flat.depth[0]
            .1
            .values
            .iter()
            .all(|v| v.is_finite() && *v > 0.0));
    }

    /// The key follows the estimator's source: another build's estimator misses the cache
    /// even where nobody bumped the version; the same source keeps the key.
    #[test]
    fn the_key_changes_with_the_estimators_source() {
        use crate::lightfield::{grid_folder, GridCameraOptions, GridSize};
        let grid = GridSize { cols: 3, rows: 3 };
        let opts = GridCameraOptions {
            focal_px: Some(100.0),
            baseline: 0.5,
        };
        let lf = grid_folder::from_images("t", grid, vec![image::RgbaImage::new(4, 2); 9], &opts)
            .unwrap();
        let options = DepthOptions::default();
        assert_eq!(SOURCE_DIGEST.len(), 16, "{SOURCE_DIGEST}");
        assert_eq!(
            cache_key(&lf, &options),
            key_of(&lf, &options, SOURCE_DIGEST)
        );
        assert_ne!(
            key_of(&lf, &options, "0000000000000000"),
            key_of(&lf, &options, "0000000000000001")
        );
    }

    #[test]
    fn the_hash_rides_on_the_metadata_text_and_any_edit_breaks_it() {
        let meta = "{\n  \"width\": 3,\n  \"range\": [0.1, 0.30000000000000004]\n}";
        let h = entry_hash("k", meta, b"data");
        let text = join_hash(meta, &h).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(
            v[HASH_FIELD],
            h.as_str(),
            "still JSON, with the hash as a field"
        );
        assert_eq!(split_hash(&text), Some((meta.to_string(), h.clone())));
        // An edited value, another key or other data give another hash; a file without the
        // hash in its place is not an entry.
        let edited = text.replace("0.1", "0.2");
        let (m, stored) = split_hash(&edited).unwrap();
        assert_ne!(entry_hash("k", &m, b"data"), stored);
        assert_ne!(entry_hash("other", meta, b"data"), h);
        assert_ne!(entry_hash("k", meta, b"datA"), h);
        assert_eq!(split_hash(meta), None);
        assert_eq!(split_hash(&text.replace(&h, "zz")), None);
    }
}
