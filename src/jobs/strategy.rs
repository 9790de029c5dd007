//! `--strategy auto`: which way of summing the views (fragment, compute, batched draws) is
//! fastest on this device, measured once and remembered.
//!
//! The strategies differ by an order of magnitude between devices, in opposite directions: on
//! Mesa's llvmpipe one fullscreen fragment draw sums 81 views of 512² in half the time of the
//! compute dispatch, while on an NVIDIA H200 (a data-centre part that runs fragment shaders on
//! a small share of the chip) compute is 20× faster than fragment. No rule from the device's
//! name or type predicts that reliably, so the first use on a device times every candidate on a
//! built-in light field of 5×5 views of 512² ([`calibrate`], a second or two on llvmpipe) and keeps the result in
//! the cache folder, keyed by device name, driver version, Vulkan version, this method and the
//! program's version: a driver update measures again. Every later run reads the file.
//!
//! The timed frames go round-robin over the candidates, one frame of each per round, so a
//! change of load while calibrating (other processes on a CPU driver, clocks on a GPU) slows
//! every candidate alike; each candidate's median over the rounds decides.
//!
//! The cache file is plain JSON (device facts, the medians, the choice). One that does not
//! parse, belongs to another device or names no known candidate is measured again and
//! replaced; a cache folder that cannot be written costs a calibration per process, never an
//! error.

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use crate::error::{Error, Result};
use crate::geometry::aperture::Aperture;
use crate::gpu::GpuContext;
use crate::jobs::refocus::{HeadlessRenderer, RenderSettings};
use crate::lightfield::{GridCameraOptions, GridSize, LightField};
use crate::refocus::settings::Strategy;
use crate::refocus::settings::ViewStorage;
use crate::refocus::{FocusSpec, RefocusRequest};

/// The strategies `auto` chooses between (the batch size is the bench's best on llvmpipe).
pub const CANDIDATES: [Strategy; 3] = [
    Strategy::Fragment,
    Strategy::Compute,
    Strategy::Batched { views_per_draw: 16 },
];

/// What the calibration measures; part of the cache key, so a change of method measures again.
pub const METHOD: &str =
    "plain sum of 5x5 views of 512x512 at disparity 0.5, linear16 views, hardware bilinear, \
                          rgba32f; 1 warm-up frame each, then 7 rounds of one frame each; \
                          GPU timestamp medians";

/// Views of a real light field's size: on llvmpipe compute beats fragment on 128² views and
/// loses on 512² ones (the texture cache sees a different pattern), so the calibration must
/// not be smaller than what users render; 25 views keep it near a second there.
const GRID: usize = 5;
const SIDE: u32 = 512;
const WARMUP: usize = 1;
const ROUNDS: usize = 7;
/// Largest cache file read back (a real one is well under 1 KiB).
const MAX_CACHE_BYTES: u64 = 64 * 1024;

/// Where the strategy of a render came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StrategySource {
    /// Chosen for the device by [`choose`].
    Auto,
    /// Given by the user (`--strategy`, `--views-per-draw`, Python's `strategy=`).
    Option,
}

/// A strategy as asked for: `auto`, or one given.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StrategyChoice(pub Option<Strategy>);

impl std::str::FromStr for StrategyChoice {
    type Err = Error;
    /// `auto`, or any [`Strategy`] name.
    fn from_str(s: &str) -> Result<Self> {
        if s.trim() == "auto" {
            return Ok(StrategyChoice(None));
        }
        s.parse::<Strategy>()
            .map(|s| StrategyChoice(Some(s)))
            .map_err(|_| {
                Error::Invalid(format!(
                    "unknown strategy '{s}': expected auto (measured per device), fragment, \
                     batched, batched:N (N ≥ 1) or compute"
                ))
            })
    }
}

/// The strategy a render uses and where it came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chosen {
    pub strategy: Strategy,
    pub source: StrategySource,
}

/// One device's calibration, as cached.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Calibration {
    pub device: String,
    pub driver: String,
    pub api_version: String,
    pub program_version: String,
    pub method: String,
    /// GPU median per candidate (milliseconds), by strategy name.
    pub medians_ms: BTreeMap<String, f64>,
    /// The fastest candidate's name.
    pub chosen: String,
    /// Wall time the calibration took (milliseconds).
    pub wall_ms: f64,
}

impl Calibration {
    /// The chosen strategy, if this calibration is valid for `ctx`'s device.
    fn strategy_for(&self, ctx: &GpuContext) -> Option<Strategy> {
        let info = &ctx.info;
        let same = self.device == info.name
            && self.driver == info.driver
            && self.api_version == info.api_version
            && self.program_version == env!("CARGO_PKG_VERSION")
            && self.method == METHOD;
        let s = self.chosen.parse::<Strategy>().ok()?;
        (same && CANDIDATES.contains(&s)).then_some(s)
    }
}

/// `asked` when given, else the device's fastest candidate (from the cache, else measured).
pub fn choose(ctx: &Arc<GpuContext>, asked: Option<Strategy>) -> Result<Chosen> {
    if let Some(strategy) = asked {
        return Ok(Chosen {
            strategy,
            source: StrategySource::Option,
        });
    }
    let key = cache_key(ctx);
    // One calibration per device however many threads and processes ask at once (a test
    // suite's, a Python pool's): a lock within the process, a file lock between processes;
    // whoever waited finds the choice made.
    static CHOSEN: OnceLock<Mutex<HashMap<String, Strategy>>> = OnceLock::new();
    let memo = CHOSEN.get_or_init(|| Mutex::new(HashMap::new()));
    let mut memo = memo.lock().map_err(|_| {
        Error::Internal("the strategy calibration panicked in another thread".into())
    })?;
    let strategy = match memo.get(&key).copied() {
        Some(s) => s,
        None => {
            let _lock = FileLock::acquire(&key);
            match cached(ctx, &key) {
                Some(s) => s,
                None => {
                    let c = calibrate(ctx)?;
                    store(&key, &c);
                    c.chosen.parse::<Strategy>()?
                }
            }
        }
    };
    memo.insert(key, strategy);
    Ok(Chosen {
        strategy,
        source: StrategySource::Auto,
    })
}

/// Times every candidate on the built-in calibration light field (see the module docs).
pub fn calibrate(ctx: &Arc<GpuContext>) -> Result<Calibration> {
    let started = Instant::now();
    log::info!(
        "measuring the fastest refocus strategy on {} (once per device and driver)",
        ctx.info.name
    );
    let lf = calibration_light_field()?;
    let request = RefocusRequest {
        focus: FocusSpec::Disparity(0.5),
        aperture: Aperture::default(),
        reference: None,
    };
    let plan = crate::refocus::plan(&lf, &request, &vec![false; lf.views.len()])?;
    let mut renderer =
        HeadlessRenderer::with_context(Arc::clone(ctx), &lf, ViewStorage::default())?;
    let settings = |strategy| RenderSettings {
        strategy,
        ..RenderSettings::default()
    };
    let mut frame = |strategy| -> Result<f64> {
        let t = Instant::now();
        let gpu = renderer.render_timed(&plan, &settings(strategy))?;
        // Without timestamp queries the submission's wall time (it is waited for) stands in.
        Ok(gpu.map_or(t.elapsed().as_secs_f64() * 1e3, |g| g.refocus_ms))
    };
    for s in CANDIDATES {
        for _ in 0..WARMUP {
            frame(s)?;
        }
    }
    let mut times = vec![Vec::with_capacity(ROUNDS); CANDIDATES.len()];
    for _ in 0..ROUNDS {
        for (i, s) in CANDIDATES.into_iter().enumerate() {
            times[i].push(frame(s)?);
        }
    }
    let medians: Vec<f64> = times.iter_mut().map(|t| median(t)).collect();
    let best = preferred(&medians);
    let info = &ctx.info;
    Ok(Calibration {
        device: info.name.clone(),
        driver: info.driver.clone(),
        api_version: info.api_version.clone(),
        program_version: env!("CARGO_PKG_VERSION").into(),
        method: METHOD.into(),
        medians_ms: CANDIDATES
            .iter()
            .zip(&medians)
            .map(|(s, &m)| (s.name(), m))
            .collect(),
        chosen: CANDIDATES[best].name(),
        wall_ms: started.elapsed().as_secs_f64() * 1e3,
    })
}

/// Measures again and replaces the cached choice (`tiltfield devices --calibrate`).
pub fn recalibrate(ctx: &Arc<GpuContext>) -> Result<(Calibration, Option<PathBuf>)> {
    let c = calibrate(ctx)?;
    let key = cache_key(ctx);
    Ok((c.clone(), store(&key, &c)))
}

/// How much faster than fragment another candidate must be to be chosen: frame times on a
/// CPU driver wander by 5-10 % between runs, and a choice that flips between runs would make
/// the same command give different (if equally accurate) images on one machine. Fragment is
/// the first candidate: the path every device has run longest.
pub const MARGIN: f64 = 1.1;

/// The index of the candidate to use given their medians: the fastest, unless fragment
/// (index 0) is within [`MARGIN`] of it.
pub fn preferred(medians: &[f64]) -> usize {
    let best = (0..medians.len())
        .min_by(|&a, &b| medians[a].total_cmp(&medians[b]))
        .unwrap_or(0);
    match medians.first() {
        Some(&fragment) if fragment <= MARGIN * medians[best] => 0,
        _ => best,
    }
}

/// An exclusive lock on the cache entry `key` between processes (flock on `KEY.lock` in the
/// cache folder); none where the folder cannot be made (each process then measures).
struct FileLock {
    /// Held open for the lock's lifetime (closing it unlocks).
    _file: Option<std::fs::File>,
}

impl FileLock {
    fn acquire(key: &str) -> FileLock {
        let file = cache_dir().and_then(|dir| {
            std::fs::create_dir_all(&dir).ok()?;
            let file = std::fs::OpenOptions::new()
                .create(true)
                .truncate(false)
                .write(true)
                .open(dir.join(format!("{key}.lock")))
                .ok()?;
            use std::os::fd::AsRawFd;
            // SAFETY: flock on an open descriptor we own; it blocks until the lock is ours
            // (released when the file closes, also if this process dies).
            let locked = unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX) } == 0;
            locked.then_some(file)
        });
        FileLock { _file: file }
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::INFINITY,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// A 5×5 grid of 512² views of a detailed pattern (blocks of 16² with finer detail): every
/// strategy reads the same texels, and the texture cache sees what a photograph gives it.
fn calibration_light_field() -> Result<LightField> {
    let hash = |x: u32, y: u32, k: u32| -> u8 {
        let mut h = x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77) ^ k;
        h ^= h >> 15;
        h = h.wrapping_mul(0x2C1B_3C6D);
        h ^= h >> 12;
        (h & 0xFF) as u8
    };
    let images = (0..GRID * GRID)
        .map(|v| {
            image::RgbaImage::from_fn(SIDE, SIDE, |x, y| {
                // Mostly coarse structure with some fine detail, as a photograph has.
                let c = |k| {
                    hash((x + 3 * v as u32) / 16, y / 16, k) / 4 * 3 + hash(x / 2, y / 2, k + 3) / 4
                };
                image::Rgba([c(0), c(1), c(2), 255])
            })
        })
        .collect();
    let grid = GridSize {
        cols: GRID,
        rows: GRID,
    };
    crate::lightfield::grid_folder::from_images(
        "strategy calibration",
        grid,
        images,
        &GridCameraOptions::default(),
    )
}

/// The cache file name of `ctx`'s device (32 hex digits of its facts and the method).
fn cache_key(ctx: &GpuContext) -> String {
    let info = &ctx.info;
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    for part in [
        info.name.as_str(),
        info.driver.as_str(),
        info.api_version.as_str(),
        env!("CARGO_PKG_VERSION"),
        METHOD,
    ] {
        h.update(&(part.len() as u64).to_le_bytes());
        h.update(part.as_bytes());
    }
    format!("{:032x}", h.digest128())
}

/// The folder of calibrations: `$TILTFIELD_STRATEGY_CACHE_DIR`, else `strategy/` beside the
/// depth cache's default folder (`$XDG_CACHE_HOME/tiltfield/strategy`, else
/// `~/.cache/tiltfield/strategy`). Not under `$TILTFIELD_CACHE_DIR`: a depth cache of its own
/// (a test's, a project's) should not cost a calibration.
pub fn cache_dir() -> Option<PathBuf> {
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    env("TILTFIELD_STRATEGY_CACHE_DIR")
        .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("tiltfield").join("strategy")))
        .or_else(|| env("HOME").map(|d| d.join(".cache").join("tiltfield").join("strategy")))
}

fn cached(ctx: &GpuContext, key: &str) -> Option<Strategy> {
    let path = cache_dir()?.join(format!("{key}.json"));
    if std::fs::symlink_metadata(&path).is_err() {
        return None;
    }
    let read = crate::io::read_file(&path, "strategy calibration", MAX_CACHE_BYTES)
        .ok()
        .and_then(|bytes| serde_json::from_slice::<Calibration>(&bytes).ok());
    match read.as_ref().and_then(|c| c.strategy_for(ctx)) {
        Some(s) => Some(s),
        None => {
            log::warn!(
                "{}: not a calibration of this device; measuring again",
                path.display()
            );
            None
        }
    }
}

/// Writes `c` to the cache (atomically); a failure is logged, never an error.
fn store(key: &str, c: &Calibration) -> Option<PathBuf> {
    let dir = cache_dir()?;
    let path = dir.join(format!("{key}.json"));
    let written = std::fs::create_dir_all(&dir)
        .map_err(|source| Error::Io {
            path: dir.clone(),
            source,
        })
        .and_then(|_| {
            let text = serde_json::to_vec_pretty(c).map_err(|e| Error::Invalid(e.to_string()))?;
            crate::io::write_bytes(&path, "strategy calibration", &text)
        });
    match written {
        Ok(()) => Some(path),
        Err(e) => {
            log::warn!("the strategy calibration is not kept: {e}");
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn choices_parse_with_auto_and_name_every_option_when_wrong() {
        assert_eq!("auto".parse::<StrategyChoice>().unwrap().0, None);
        assert_eq!(
            "compute".parse::<StrategyChoice>().unwrap().0,
            Some(Strategy::Compute)
        );
        assert_eq!(
            "batched:4".parse::<StrategyChoice>().unwrap().0,
            Some(Strategy::Batched { views_per_draw: 4 })
        );
        let e = "fast".parse::<StrategyChoice>().unwrap_err().to_string();
        assert!(
            e.contains("'fast'") && e.contains("auto") && e.contains("compute"),
            "{e}"
        );
    }

    #[test]
    fn candidates_round_trip_through_their_names() {
        for s in CANDIDATES {
            assert_eq!(s.name().parse::<Strategy>().unwrap(), s);
        }
        let mut v = vec![3.0, 1.0, 2.0];
        assert_eq!(median(&mut v), 2.0);
        let mut v = vec![4.0, 1.0, 2.0, 3.0];
        assert_eq!(median(&mut v), 2.5);
    }

    #[test]
    fn fragment_stays_unless_another_is_clearly_faster() {
        // llvmpipe-like: batched 5 % faster, within the margin.
        assert_eq!(preferred(&[100.0, 120.0, 95.0]), 0);
        // H200-like: compute 20× faster.
        assert_eq!(preferred(&[1.81, 0.09, 21.5]), 1);
        assert_eq!(preferred(&[100.0, 95.0, 80.0]), 2);
        assert_eq!(preferred(&[]), 0);
    }
}
