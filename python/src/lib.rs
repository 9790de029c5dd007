//! `tiltfield._tiltfield`: the native half of the `tiltfield` Python package (the pure-Python
//! half, python/tiltfield/__init__.py, re-exports it and carries the package docs).
//!
//! This crate only converts: Python arguments into the library's requests
//! ([`tiltfield::jobs::render::RenderOptions`], [`tiltfield::depth::request::DepthRequest`],
//! [`tiltfield::jobs::render::ReadOptions`]), numpy arrays into views, and the library's images
//! and errors back. Every decision — which focus, validation, depth, which pass — is the
//! library's, exactly as `tiltfield render` and `tiltfield depth` make it, so a request gives
//! the bytes the CLI writes and fails with the message the CLI prints.
//!
//! Invariants:
//! - one Vulkan context per process ([`context`]), made on first use from the environment
//!   (`TILTFIELD_DEVICE`, `TILTFIELD_VALIDATION=1`) and kept until the process ends;
//! - a `LightField` uploads its views on its first render and keeps them
//!   ([`tiltfield::jobs::render::Session`]);
//! - the GIL is released for loading, estimating and rendering ([`gpu_work`]); work on the
//!   device runs one call at a time in the process (one queue and command pool, [`GPU`]);
//! - nothing panics into Python: errors map to `ValueError` (bad arguments), `OSError` (files)
//!   and `RuntimeError` (the GPU, validation errors), and a panic inside the library becomes
//!   a `RuntimeError` too.

use std::ops::RangeInclusive;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};
use std::time::Duration;

use glam::{DVec2, DVec3};
use numpy::ndarray::{s, Array2, Array3, Array4, ArrayView3, Ix5};
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyOSError, PyOverflowError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use tiltfield::depth::request::{parse_kind, DepthRequest};
use tiltfield::error::Error;
use tiltfield::geometry::aperture::Aperture;
use tiltfield::geometry::picking::Nudge;
use tiltfield::geometry::plane::Plane;
use tiltfield::gpu::{GpuContext, GpuOptions};
use tiltfield::jobs::animate::encode::{self, Format};
use tiltfield::jobs::animate::{self, Animation, Motion, SweepKey};
use tiltfield::jobs::refocus::GpuImage;
use tiltfield::jobs::render::{self, ReadOptions, RenderOptions, Session};
use tiltfield::jobs::strategy::{StrategyChoice, StrategySource};
use tiltfield::lightfield::images::LoadLimits;
use tiltfield::lightfield::{self, GridSize};
use tiltfield::refocus::antialias::{AntialiasSettings, Layered};
use tiltfield::refocus::options::{plane_of, FocusOptions};
use tiltfield::refocus::settings::OutputFormat;

/// The process's Vulkan context (see the module docs).
static CONTEXT: Mutex<Option<Arc<GpuContext>>> = Mutex::new(None);

/// Held while any work runs on the context: its one queue and its command pool are externally
/// synchronized objects (Vulkan), so two `LightField`s rendering from two Python threads take
/// turns on the device while the GIL is free for everything else.
static GPU: Mutex<()> = Mutex::new(());

/// A mutex guard whatever an earlier panic left: the data are handles and plain values, and
/// a render that panicked is reported, not retried with half its state.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The process's context, made on first use.
fn context() -> tiltfield::Result<Arc<GpuContext>> {
    let mut slot = lock(&CONTEXT);
    if let Some(ctx) = slot.as_ref() {
        return Ok(Arc::clone(ctx));
    }
    let ctx = Arc::new(GpuContext::new(&GpuOptions::from_env())?);
    *slot = Some(Arc::clone(&ctx));
    Ok(ctx)
}

/// The Python exception of a library error: the message the CLI prints after `error:`, with
/// the options it names spelled as this module's keywords ([`pythonic`]).
fn py_err(e: Error) -> PyErr {
    let message = e.to_string();
    match e {
        Error::Io { .. } | Error::BadFile { .. } | Error::LightField(_) => {
            PyOSError::new_err(message)
        }
        Error::Invalid(_) | Error::Geometry(_) | Error::DeviceLimit(_) => {
            PyValueError::new_err(pythonic(&message))
        }
        Error::Vulkan(_) | Error::Window(_) | Error::VkCall { .. } | Error::Internal(_) => {
            PyRuntimeError::new_err(message)
        }
    }
}

/// A library message in Python's words: the library checks every request with the CLI's
/// messages, which name options (`--aperture-radius`); a Python user gave keywords
/// (`aperture_radius`). An option's value that follows it is joined with `=`, and the CLI's
/// `A,B` and `AxB` spellings of a pair become the tuple a Python user wrote:
/// `--size 9000x10 does not fit` reads `size=(9000, 10) does not fit`.
fn pythonic(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(at) = rest.find("--") {
        out.push_str(&rest[..at]);
        let after = &rest[at + 2..];
        let end = after
            .find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-'))
            .unwrap_or(after.len());
        let name = after[..end].trim_end_matches('-');
        if !name.starts_with(|c: char| c.is_ascii_lowercase()) {
            out.push_str("--");
            rest = after;
            continue;
        }
        out.push_str(&name.replace('-', "_"));
        rest = &after[name.len()..];
        // `--frame 3:`, `--view 1.5,2:`, `--size 9000x10 does not fit`: a value follows.
        if let Some(value_text) = rest.strip_prefix(' ') {
            let len = value_text
                .find(|c: char| c.is_whitespace())
                .unwrap_or(value_text.len());
            let token = value_text[..len].trim_end_matches([':', ';']);
            let is_number = |t: &str| !t.is_empty() && t.parse::<f64>().is_ok();
            let parts: Vec<&str> = if token.contains(',') {
                token.split(',').collect()
            } else {
                token.splitn(2, 'x').collect()
            };
            // A lone number is a value only before a colon (`--frame 3:`, not `--focus 3
            // times`).
            let pair = parts.len() > 1;
            let colon = value_text[..len].ends_with(':');
            if parts.iter().all(|p| is_number(p)) && !token.is_empty() && (pair || colon) {
                out.push('=');
                if parts.len() > 1 {
                    out.push_str(&format!("({})", parts.join(", ")));
                } else {
                    out.push_str(token);
                }
                rest = &value_text[token.len()..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// How often a waiting call looks for signals (Ctrl-C): well within the second a user waits.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Runs `work` on a thread of its own while the calling thread waits with the GIL released,
/// looking for signals every [`SIGNAL_POLL`]; turns a library error into its Python
/// exception, a panic into a `RuntimeError`, and validation errors the work caused into a
/// `RuntimeError` naming `what` (as the CLI fails a render that drew any).
///
/// Ctrl-C raises `KeyboardInterrupt` in the caller at once. The library has no way to stop a
/// render half way (one submission can take seconds on a software device), so the work runs
/// to its end in the background, holding the device and the light field: a later call waits
/// for it, and everything stays usable. Its result is dropped.
fn gpu_work<T: Send + 'static>(
    py: Python<'_>,
    what: &str,
    work: impl FnOnce() -> tiltfield::Result<T> + Send + 'static,
) -> PyResult<T> {
    gpu_work_with(py, what, None, work)
}

/// [`gpu_work`] that also sets `cancel` when the caller is interrupted, for work that can
/// stop between steps (an animation's frames).
fn gpu_work_with<T: Send + 'static>(
    py: Python<'_>,
    what: &str,
    cancel: Option<Arc<AtomicBool>>,
    work: impl FnOnce() -> tiltfield::Result<T> + Send + 'static,
) -> PyResult<T> {
    let before = validation_count();
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        .name("tiltfield-gpu".into())
        .spawn(move || {
            let _device = lock(&GPU);
            // The receiver is gone when the caller was interrupted: nothing to report to.
            let _ = tx.send(catch_unwind(AssertUnwindSafe(work)));
        })
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start a thread for {what}: {e}")))?;
    let mut rx = rx;
    let result = loop {
        // The receiver goes into the GIL-free wait and comes back (it is not `Sync`).
        let (received, back) = py.allow_threads(move || (rx.recv_timeout(SIGNAL_POLL), rx));
        rx = back;
        match received {
            Ok(result) => break result,
            Err(RecvTimeoutError::Timeout) => {
                if let Err(interrupt) = py.check_signals() {
                    if let Some(cancel) = &cancel {
                        cancel.store(true, Ordering::Relaxed);
                    }
                    return Err(interrupt);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(PyRuntimeError::new_err(format!(
                    "tiltfield internal error while {what}: the worker ended without a result"
                )))
            }
        }
    };
    let value = match result {
        Ok(r) => r.map_err(py_err)?,
        Err(panic) => {
            let why = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("unknown cause");
            return Err(PyRuntimeError::new_err(format!(
                "tiltfield internal error while {what}: {why}"
            )));
        }
    };
    // Only this call's errors: the context and its count outlive every call.
    tiltfield::gpu::validation::check_errors(validation_count() - before, &format!("while {what}"))
        .map_err(py_err)?;
    Ok(value)
}

/// Validation errors of the process's context so far (0 before it exists).
fn validation_count() -> usize {
    lock(&CONTEXT)
        .as_ref()
        .map_or(0, |c| c.validation().errors())
}

/// `n` numbers from a Python sequence (a tuple, list or 1-D array) given as keyword `name`,
/// whose `fields` say what they are (`"(u, v)"`); counted and checked finite here, before the
/// library sees them, so the message names the keyword; `None` passes through.
fn numbers_of(
    value: Option<&Bound<'_, PyAny>>,
    n: usize,
    name: &str,
    fields: &str,
) -> PyResult<Option<Vec<f64>>> {
    let Some(value) = value else {
        return Ok(None);
    };
    let v: Vec<f64> = value.extract().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name} must be a sequence of {n} numbers {fields}, got {}",
            repr(value)
        ))
    })?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{name} must be {n} finite numbers {fields}, got {}",
            repr(value)
        )));
    }
    Ok(Some(v))
}

/// A keyword that takes one number or several (`focus=`, `tilt=`, `swing=`, `disparity=`,
/// each as its CLI option given once or repeated): none, one or every number, in order.
fn values_of(value: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Vec<f64>> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    if let Ok(one) = value.extract::<f64>() {
        return Ok(vec![one]);
    }
    value.extract::<Vec<f64>>().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name} must be a number or a sequence of numbers (one per plane), got {}",
            repr(value)
        ))
    })
}

/// A whole-number keyword, checked against `range` before it is converted to the library's
/// type, so `frame=-1` is a `ValueError` naming `frame` rather than an `OverflowError` of the
/// conversion; `None` passes through.
fn int_arg(
    value: Option<&Bound<'_, PyAny>>,
    name: &str,
    range: RangeInclusive<i64>,
) -> PyResult<Option<i64>> {
    let Some(value) = value else {
        return Ok(None);
    };
    let expected = if *range.end() == i64::MAX {
        format!("an integer of at least {}", range.start())
    } else {
        format!("an integer from {} to {}", range.start(), range.end())
    };
    match value.extract::<i64>() {
        Ok(v) if range.contains(&v) => Ok(Some(v)),
        Ok(_) => Err(PyValueError::new_err(format!(
            "{name} must be {expected}, got {}",
            repr(value)
        ))),
        Err(e) if e.is_instance_of::<PyOverflowError>(value.py()) => Err(PyValueError::new_err(
            format!("{name} must be {expected}, got {}", repr(value)),
        )),
        Err(_) => Err(PyTypeError::new_err(format!(
            "{name} must be {expected}, got {}",
            repr(value)
        ))),
    }
}

/// [`int_arg`] into an unsigned library type (its whole range).
fn u32_arg(value: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Option<u32>> {
    Ok(int_arg(value, name, 0..=u32::MAX as i64)?.map(|v| v as u32))
}

/// `antialias_layered`: "auto" (the library decides: layered footprints on one plane at the
/// views' size with the light field's own depth) or a [`switch`]'s on and off.
fn layered_arg(value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Layered>> {
    let auto = value.is_some_and(|v| v.extract::<String>().is_ok_and(|t| t == "auto"));
    if auto {
        return Ok(Some(Layered::Auto));
    }
    let allowed = "\"auto\", True, False, \"on\" or \"off\"";
    let on = switch_among(value, "antialias_layered", allowed)?;
    Ok(on.map(|on| if on { Layered::On } else { Layered::Off }))
}

/// An on/off keyword: `True`/`False` (numpy's too), or the CLI's `"on"`/`"off"`; `None`
/// passes through. Any other string is a `ValueError`, any other type a `TypeError`, both
/// naming the keyword and what it takes.
fn switch(value: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Option<bool>> {
    switch_among(value, name, "True, False, \"on\" or \"off\"")
}

/// [`switch`], whose errors list `allowed` as the words it takes.
fn switch_among(
    value: Option<&Bound<'_, PyAny>>,
    name: &str,
    allowed: &str,
) -> PyResult<Option<bool>> {
    let Some(value) = value else {
        return Ok(None);
    };
    if let Ok(on) = value.extract::<bool>() {
        return Ok(Some(on));
    }
    match value.extract::<String>() {
        Ok(text) if text == "on" => Ok(Some(true)),
        Ok(text) if text == "off" => Ok(Some(false)),
        Ok(_) => Err(PyValueError::new_err(format!(
            "{name} must be {allowed}, got {}",
            repr(value)
        ))),
        Err(_) => Err(PyTypeError::new_err(format!(
            "{name} must be {allowed}, got {}",
            repr(value)
        ))),
    }
}

/// `size=(w, h)` (any sequence of two integers) in pixels, checked before conversion.
fn size_of(value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<(u32, u32)>> {
    let Some(value) = value else {
        return Ok(None);
    };
    let what = "size must be (w, h), two integers of at least 1 (pixels)";
    let v: Vec<i64> = value
        .extract()
        .map_err(|_| PyTypeError::new_err(format!("{what}, got {}", repr(value))))?;
    match v[..] {
        [w, h] if (1..=u32::MAX as i64).contains(&w) && (1..=u32::MAX as i64).contains(&h) => {
            Ok(Some((w as u32, h as u32)))
        }
        _ => Err(PyValueError::new_err(format!(
            "{what}, got {}",
            repr(value)
        ))),
    }
}

fn repr(value: &Bound<'_, PyAny>) -> String {
    value
        .repr()
        .map_or_else(|_| "an object without repr".into(), |r| r.to_string())
}

/// A choice given by name, parsed as the CLI parses its option (`FromStr`, the same
/// message, in Python's words).
fn choice<T>(value: Option<&str>) -> PyResult<Option<T>>
where
    T: std::str::FromStr,
    T::Err: std::fmt::Display,
{
    value
        .map(|text| {
            text.parse::<T>()
                .map_err(|e| PyValueError::new_err(pythonic(&e.to_string())))
        })
        .transpose()
}

/// `plane=`: one plane (six numbers) or several (a sequence of six-number sequences, a focus
/// surface).
fn planes_of(value: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<Plane>> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    const FIELDS: &str = "(px, py, pz, nx, ny, nz)";
    let several = value.extract::<Vec<f64>>().is_err();
    let items: Vec<Bound<'_, PyAny>> = if several {
        value.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "plane must be 6 numbers {FIELDS} or a sequence of such planes, got {}",
                repr(value)
            ))
        })?
    } else {
        vec![value.clone()]
    };
    items
        .iter()
        .enumerate()
        .map(|(k, item)| {
            let name = if several {
                format!("plane[{k}]")
            } else {
                "plane".into()
            };
            let v = numbers_of(Some(item), 6, &name, FIELDS)?.unwrap_or_default();
            plane_of(&v).map_err(py_err)
        })
        .collect()
}

/// A pick keyword's value (`click`, `points`, `points_3d`): a sequence of numbers, or None.
type Pick<'a, 'py> = Option<&'a Bound<'py, PyAny>>;

/// The focus keywords of `refocus` and `plane` as the library's focus options (checked:
/// exactly one focus, refinements that belong to it).
#[allow(clippy::too_many_arguments)] // the focus keywords, grouped where they belong together
fn focus_options(
    disparity: Option<&Bound<'_, PyAny>>,
    plane: Option<&Bound<'_, PyAny>>,
    focus: Option<&Bound<'_, PyAny>>,
    (tilt, swing): (Option<&Bound<'_, PyAny>>, Option<&Bound<'_, PyAny>>),
    (click, points, points_3d): (Pick<'_, '_>, Pick<'_, '_>, Pick<'_, '_>),
    (nudge_distance, nudge_tilt, nudge_swing): (Option<f64>, Option<f64>, Option<f64>),
    normal_window: Option<&Bound<'_, PyAny>>,
    normal_method: &str,
) -> PyResult<FocusOptions> {
    let focus = focus_options_unchecked(
        disparity,
        plane,
        focus,
        (tilt, swing),
        (click, points, points_3d),
        (nudge_distance, nudge_tilt, nudge_swing),
        normal_window,
        normal_method,
    )?;
    focus.validate().map_err(py_err)?;
    Ok(focus)
}

/// [`focus_options`] without the check that one focus is given: an animation's sweep may
/// give the focus itself.
#[allow(clippy::too_many_arguments)] // the focus keywords, grouped where they belong together
fn focus_options_unchecked(
    disparity: Option<&Bound<'_, PyAny>>,
    plane: Option<&Bound<'_, PyAny>>,
    focus: Option<&Bound<'_, PyAny>>,
    (tilt, swing): (Option<&Bound<'_, PyAny>>, Option<&Bound<'_, PyAny>>),
    (click, points, points_3d): (Pick<'_, '_>, Pick<'_, '_>, Pick<'_, '_>),
    (nudge_distance, nudge_tilt, nudge_swing): (Option<f64>, Option<f64>, Option<f64>),
    normal_window: Option<&Bound<'_, PyAny>>,
    normal_method: &str,
) -> PyResult<FocusOptions> {
    Ok(FocusOptions {
        disparity: values_of(disparity, "disparity")?,
        planes: planes_of(plane)?,
        focus: values_of(focus, "focus")?,
        tilt: values_of(tilt, "tilt")?,
        swing: values_of(swing, "swing")?,
        click: numbers_of(click, 2, "click", "(u, v)")?.map(|v| DVec2::new(v[0], v[1])),
        points: numbers_of(points, 6, "points", "(u1, v1, u2, v2, u3, v3)")?.map(|v| {
            [
                DVec2::new(v[0], v[1]),
                DVec2::new(v[2], v[3]),
                DVec2::new(v[4], v[5]),
            ]
        }),
        points_3d: numbers_of(points_3d, 9, "points_3d", "(x1, y1, z1, ..., z3)")?.map(|v| {
            [
                DVec3::new(v[0], v[1], v[2]),
                DVec3::new(v[3], v[4], v[5]),
                DVec3::new(v[6], v[7], v[8]),
            ]
        }),
        nudge: (nudge_distance.is_some() || nudge_tilt.is_some() || nudge_swing.is_some()).then(
            || Nudge {
                distance: nudge_distance.unwrap_or(0.0),
                tilt_deg: nudge_tilt.unwrap_or(0.0),
                swing_deg: nudge_swing.unwrap_or(0.0),
            },
        ),
        normal_window: u32_arg(normal_window, "normal_window")?,
        normal_method: choice(Some(normal_method))?.unwrap_or_default(),
    })
}

/// A render request built from `refocus`'s keywords (what `animate` passes on): the
/// library's [`RenderOptions`] in a Python object, so `animate(**options)` is converted by
/// [`render_options`]'s one keyword list.
#[pyclass(module = "tiltfield", frozen)]
struct RenderRequest(RenderOptions);

/// The keywords of :meth:`LightField.refocus` (all but ``linear``) as the library's render
/// request: what `refocus` renders and what `animate` animates. The focus is not checked here
/// (an animation's sweep may give it); everything else is. Named `animate` for Python, whose
/// unknown-keyword errors then name the method that was called with it.
#[pyfunction]
#[pyo3(name = "animate", signature = (
    *, disparity=None, plane=None, focus=None, tilt=None, swing=None, click=None,
    points=None, points_3d=None, nudge_distance=None, nudge_tilt=None, nudge_swing=None,
    normal_window=None, normal_method="inverse-depth", slab=None, all_in_focus=false,
    aperture="disk", aperture_radius=None, view=None, size=None, average="linear",
    include_dark=false, antialias=None, antialias_samples=None, antialias_prefilter=None,
    antialias_focus_test=None, antialias_focused_bicubic=None, antialias_occlusion=None,
    antialias_defocus=None, antialias_layered=None, antialias_box=None, strategy=None,
    views_per_draw=None, filter=None, accumulation=None, warps=None, storage=None
))]
#[allow(clippy::too_many_arguments)] // one keyword per CLI option, as `refocus`
fn render_options(
    disparity: Option<&Bound<'_, PyAny>>,
    plane: Option<&Bound<'_, PyAny>>,
    focus: Option<&Bound<'_, PyAny>>,
    tilt: Option<&Bound<'_, PyAny>>,
    swing: Option<&Bound<'_, PyAny>>,
    click: Option<&Bound<'_, PyAny>>,
    points: Option<&Bound<'_, PyAny>>,
    points_3d: Option<&Bound<'_, PyAny>>,
    nudge_distance: Option<f64>,
    nudge_tilt: Option<f64>,
    nudge_swing: Option<f64>,
    normal_window: Option<&Bound<'_, PyAny>>,
    normal_method: &str,
    slab: Option<f64>,
    all_in_focus: bool,
    aperture: &str,
    aperture_radius: Option<f64>,
    view: Option<&Bound<'_, PyAny>>,
    size: Option<&Bound<'_, PyAny>>,
    average: &str,
    include_dark: bool,
    antialias: Option<&Bound<'_, PyAny>>,
    antialias_samples: Option<&Bound<'_, PyAny>>,
    antialias_prefilter: Option<&Bound<'_, PyAny>>,
    antialias_focus_test: Option<&Bound<'_, PyAny>>,
    antialias_focused_bicubic: Option<&Bound<'_, PyAny>>,
    antialias_occlusion: Option<&Bound<'_, PyAny>>,
    antialias_defocus: Option<&Bound<'_, PyAny>>,
    antialias_layered: Option<&Bound<'_, PyAny>>,
    antialias_box: Option<&Bound<'_, PyAny>>,
    strategy: Option<&str>,
    views_per_draw: Option<&Bound<'_, PyAny>>,
    filter: Option<&str>,
    accumulation: Option<&str>,
    warps: Option<&str>,
    storage: Option<&str>,
) -> PyResult<RenderRequest> {
    let focus = focus_options_unchecked(
        disparity,
        plane,
        focus,
        (tilt, swing),
        (click, points, points_3d),
        (nudge_distance, nudge_tilt, nudge_swing),
        normal_window,
        normal_method,
    )?;
    // The library's defaults for what was not given (as the CLI's option defaults).
    let aa = AntialiasSettings::default();
    let options = RenderOptions {
        focus,
        slab,
        all_in_focus,
        aperture: Aperture {
            shape: choice(Some(aperture))?.unwrap_or(Aperture::default().shape),
            radius: aperture_radius,
        },
        reference: numbers_of(view, 2, "view", "(s, t)")?.map(|v| DVec2::new(v[0], v[1])),
        averaging: choice(Some(average))?.unwrap_or_default(),
        include_dark,
        antialias: switch(antialias, "antialias")?,
        antialias_sampling: AntialiasSettings {
            max_samples: u32_arg(antialias_samples, "antialias_samples")?.unwrap_or(aa.max_samples),
            prefilter: switch(antialias_prefilter, "antialias_prefilter")?.unwrap_or(aa.prefilter),
            focus_test: switch(antialias_focus_test, "antialias_focus_test")?
                .unwrap_or(aa.focus_test),
            focused_bicubic: switch(antialias_focused_bicubic, "antialias_focused_bicubic")?
                .unwrap_or(aa.focused_bicubic),
            occlusion: switch(antialias_occlusion, "antialias_occlusion")?.unwrap_or(aa.occlusion),
            defocus: switch(antialias_defocus, "antialias_defocus")?.unwrap_or(aa.defocus),
            layered: layered_arg(antialias_layered)?.unwrap_or(aa.layered),
            boxed: switch(antialias_box, "antialias_box")?.unwrap_or(aa.boxed),
        },
        strategy: choice::<StrategyChoice>(strategy)?.and_then(|c| c.0),
        views_per_draw: int_arg(views_per_draw, "views_per_draw", 0..=u32::MAX as i64)?.unwrap_or(0)
            as usize,
        filter: choice(filter)?,
        accumulation: choice(accumulation)?,
        warps: choice(warps)?,
        storage: choice(storage)?,
        size: size_of(size)?,
        output: OutputFormat::Srgb8,
    };
    Ok(RenderRequest(options))
}

/// The render request of `kwargs` (refocus's keywords) for the method `method`: the one
/// keyword list, [`render_options`], called from Python, so keyword errors are Python's own;
/// they name `method` (the list is registered as `animate`).
fn request_for(
    py: Python<'_>,
    kwargs: Option<&Bound<'_, PyDict>>,
    method: &str,
) -> PyResult<RenderOptions> {
    let request = wrap_pyfunction!(render_options, py)?
        .call((), kwargs)
        .map_err(|e| match e.is_instance_of::<PyTypeError>(py) {
            true => PyTypeError::new_err(
                e.value(py)
                    .to_string()
                    .replace("animate()", &format!("{method}()")),
            ),
            false => e,
        })?;
    Ok(request.downcast_into::<RenderRequest>()?.get().0.clone())
}

/// The motion of `animate`'s `sweep` and `orbit` keywords: exactly one, as the CLI's options.
fn motion_of(sweep: Option<&Bound<'_, PyAny>>, orbit: Option<f64>) -> PyResult<Motion> {
    match (sweep, orbit) {
        (Some(sweep), None) => {
            if let Ok(text) = sweep.extract::<String>() {
                return Motion::parse_sweep(&text).map_err(py_err);
            }
            let bad = || {
                PyTypeError::new_err(format!(
                    "sweep must be \"KEY=A..B\" or (KEY, A, B), got {}",
                    repr(sweep)
                ))
            };
            // Any sequence of three, as (KEY, A, B).
            let items: Vec<Bound<'_, PyAny>> = sweep.extract().map_err(|_| bad())?;
            let [key, from, to] = &items[..] else {
                return Err(bad());
            };
            let (key, from, to): (String, f64, f64) = (
                key.extract().map_err(|_| bad())?,
                from.extract().map_err(|_| bad())?,
                to.extract().map_err(|_| bad())?,
            );
            Motion::sweep(SweepKey::parse(&key).map_err(py_err)?, from, to).map_err(py_err)
        }
        (None, Some(radius)) => Motion::orbit(radius).map_err(py_err),
        (Some(_), Some(_)) => Err(PyValueError::new_err(
            "give one motion, sweep= or orbit=, not both",
        )),
        (None, None) => Err(PyValueError::new_err(
            "give one motion: sweep=\"KEY=A..B\" or orbit=R",
        )),
    }
}

/// A [`Session`] that may move between threads (Python may hand a `LightField` to any thread,
/// and its renders run with the GIL released).
struct SendSession(Session);

// SAFETY: what keeps a Session from being Send is the host pointers of its mapped Vulkan
// buffers (staging, readback). Vulkan allows host access to mapped memory from any thread and
// requires only external synchronization of the objects, which the LightField's mutex gives:
// every use of the session is under it, so no two threads touch it at once.
unsafe impl Send for SendSession {}

/// A light field on the GPU: views uploaded once, refocused any number of times.
///
/// Made by :func:`tiltfield.open` or :func:`tiltfield.from_array`; see the package docs for
/// the conventions (grid positions, colour, arrays).
#[pyclass(module = "tiltfield", frozen)]
struct LightField {
    /// Shared with the worker thread of a call ([`gpu_work`]), which may outlive the call
    /// when it was interrupted.
    session: Arc<Mutex<SendSession>>,
    /// What made it, for pickling (`__reduce__`).
    source: Source,
    /// Facts that never change, read without waiting for a render in progress.
    grid: (usize, usize),
    view_size: (u32, u32),
    has_depth: bool,
    /// GPU time of the last render's passes, ms (`None`: no render yet or no timer).
    last_gpu_ms: Mutex<Option<f64>>,
    /// The strategy of the last refocus and whether it was chosen for the device.
    last_strategy: Mutex<Option<(String, &'static str)>>,
    #[pyo3(get)]
    /// Short name of the light field (its folder, or "array").
    name: String,
}

/// What a `LightField` was made from: pickling sends this, not the views on the GPU.
enum Source {
    /// `open(source, frame, focal_px=, baseline=)`; `source` made absolute when it is a path,
    /// so another process (multiprocessing) with another working folder finds it.
    Path {
        source: String,
        frame: Option<i64>,
        focal_px: Option<f64>,
        baseline: f64,
    },
    /// `from_array(views, focal_px=, baseline=, depth=)`: the views are the light field's own
    /// (exactly what the arrays were converted to), the depth as given, (H, W) row-major.
    Arrays {
        focal_px: Option<f64>,
        baseline: Option<f64>,
        depth: Option<Vec<f32>>,
    },
}

impl LightField {
    fn new(session: SendSession, source: Source) -> Self {
        let lf = session.0.light_field();
        LightField {
            name: lf.name.clone(),
            grid: (lf.grid.rows, lf.grid.cols),
            view_size: (lf.height, lf.width),
            has_depth: !lf.depth.is_empty(),
            source,
            session: Arc::new(Mutex::new(session)),
            last_gpu_ms: Mutex::new(None),
            last_strategy: Mutex::new(None),
        }
    }
}

#[pymethods]
impl LightField {
    /// The camera grid as ``(rows, cols)``.
    #[getter]
    fn grid(&self) -> (usize, usize) {
        self.grid
    }

    /// The size of one view as ``(H, W)`` (numpy's order).
    #[getter]
    fn view_size(&self) -> (u32, u32) {
        self.view_size
    }

    /// True when the light field carries a depth or disparity map (HCI ground truth, a
    /// manifest's maps, built-in scenes, ``from_array(depth=...)``). Without one, a click, a
    /// focus surface or ``antialias=True`` estimates depth from the views first (cached on
    /// disk), as ``tiltfield render`` does; and anti-aliasing is on by default exactly when
    /// this is true (and for a click, whose estimate it then uses, as the CLI does). An
    /// estimate made on the way is kept for later calls that need depth but changes neither
    /// this nor the anti-aliasing default: the same call on the same object always returns
    /// the same image, the one ``tiltfield render`` writes for it.
    #[getter]
    fn has_depth(&self) -> bool {
        self.has_depth
    }

    /// True once the views are on the GPU (after the first :meth:`refocus`).
    #[getter]
    fn uploaded(&self, py: Python<'_>) -> bool {
        py.allow_threads(|| lock(&self.session).0.uploaded())
    }

    /// GPU time in milliseconds of the last :meth:`refocus` call (its refocus and resolve
    /// passes, from timestamp queries), or ``None`` before the first call or on a device
    /// without timers. The call's wall time less this is its overhead: upload (first call),
    /// planning, submission, readback and conversion.
    #[getter]
    fn last_gpu_ms(&self) -> Option<f64> {
        *lock(&self.last_gpu_ms)
    }

    /// How the last :meth:`refocus` call summed the views, as ``(strategy, source)``:
    /// ``("compute", "auto")`` when ``strategy`` was left to the device (the fastest of
    /// fragment, compute and batched:16, measured once per device and driver and cached),
    /// ``(name, "option")`` when given; ``None`` before the first call.
    #[getter]
    fn last_strategy(&self) -> Option<(String, &'static str)> {
        lock(&self.last_strategy).clone()
    }

    /// The views as loaded, a ``uint8`` array (rows, cols, H, W, 4) of sRGB RGBA: what
    /// :func:`from_array` takes, so ``from_array(lf.views())`` renders as ``lf`` does when
    /// ``lf`` is a grid folder.
    fn views<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (rows, cols) = self.grid;
        let (h, w) = (self.view_size.0 as usize, self.view_size.1 as usize);
        // Without the GIL: an interrupted render may still hold the light field.
        let flat = py.allow_threads(|| {
            let s = &lock(&self.session).0;
            let mut flat = Vec::with_capacity(rows * cols * h * w * 4);
            for v in &s.light_field().views {
                flat.extend_from_slice(v.image.as_raw());
            }
            flat
        });
        let a = numpy::ndarray::Array5::from_shape_vec((rows, cols, h, w, 4), flat)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(a.into_pyarray(py).into_any())
    }

    fn __repr__(&self) -> String {
        format!(
            "<tiltfield.LightField '{}': {}×{} views of {}×{} px{}>",
            self.name,
            self.grid.0,
            self.grid.1,
            self.view_size.0,
            self.view_size.1,
            if self.has_depth { ", with depth" } else { "" }
        )
    }

    /// Pickling by source: a light field opened from a path is opened again from it (the
    /// file must be there for the process that unpickles), one made from arrays is made again
    /// from its views and depth. Nothing of the GPU state travels; the copy uploads on its
    /// first render.
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let package = py.import("tiltfield")?;
        match &self.source {
            Source::Path {
                source,
                frame,
                focal_px,
                baseline,
            } => Ok((
                package.getattr("_reopen")?,
                (source, *frame, *focal_px, *baseline).into_pyobject(py)?,
            )),
            Source::Arrays {
                focal_px,
                baseline,
                depth,
            } => {
                let depth = depth
                    .as_ref()
                    .map(|d| {
                        let (h, w) = (self.view_size.0 as usize, self.view_size.1 as usize);
                        Array2::from_shape_vec((h, w), d.clone())
                            .map(|a| a.into_pyarray(py))
                            .map_err(|e| PyRuntimeError::new_err(e.to_string()))
                    })
                    .transpose()?;
                Ok((
                    package.getattr("_rebuild")?,
                    (self.views(py)?, *focal_px, *baseline, depth).into_pyobject(py)?,
                ))
            }
        }
    }

    /// Refocus: the weighted average of the views in the synthetic aperture, each warped so
    /// that the focus surface lines up (``tiltfield render``; the same keyword, the same
    /// image, the same error message).
    ///
    /// Give exactly one focus:
    ///
    /// - ``disparity=D``: frontoparallel focus, px per grid step (HCI convention on HCI data,
    ///   manifests with a rig and built-in scenes, positive nearer; classic shift-and-sum on
    ///   grid folders and arrays);
    /// - ``plane=(px, py, pz, nx, ny, nz)``: a world point and normal;
    /// - ``focus=Z`` with ``tilt=`` and ``swing=`` (degrees): the plane through the
    ///   reference optical axis at distance Z, tilted about the camera's x axis (positive: top
    ///   farther) and swung about its y axis (positive: right farther);
    /// - a sequence of 2 to 8 values of ``plane``, ``focus`` or ``disparity`` (on a rig) is a
    ///   focus surface of several planes (each pixel focused on the plane nearest the scene;
    ///   the first is the render's focus), as the repeated CLI option; ``tilt`` and ``swing``
    ///   are then one number (every ``focus`` plane) or one per ``focus`` (paired by order);
    /// - ``click=(u, v)``: the plane through that pixel of the depth map's view with the
    ///   surface normal there (``normal_window``, ``normal_method``);
    /// - ``points=(u1, v1, u2, v2, u3, v3)``: through three pixels;
    ///   ``points_3d=(x1, y1, z1, ..., z3)``: through three world points; either pick, or a
    ///   click, may be adjusted by ``nudge_distance``, ``nudge_tilt``, ``nudge_swing``.
    ///
    /// Other options: ``slab=W`` (keep everything within W of the plane sharp),
    /// ``all_in_focus=True``, ``aperture`` ("disk", "square", "gaussian"),
    /// ``aperture_radius`` (grid steps; sigma for gaussian; default all views),
    /// ``view=(s, t)`` (reference view in grid units, fractional allowed; default the
    /// centre), ``size=(w, h)`` (output size), ``average`` ("linear" or "encoded"),
    /// ``include_dark``, ``antialias`` (True/False; default: on when the light field has
    /// depth), ``antialias_samples``, ``antialias_prefilter`` (True/False: long footprints
    /// read the views' box-filtered pyramid; default True), ``antialias_focus_test``
    /// (True/False: pixels whose views agree at the focus surface stay the plain sum whatever
    /// the depth says; default True), ``antialias_focused_bicubic`` (True/False: where the
    /// pixel's own surface is in focus, sub-samples under half a pixel read Catmull-Rom;
    /// default True), ``antialias_occlusion`` (True/False: sub-samples near a nearer surface
    /// follow their own rays and are tested against what their view sees; default True),
    /// ``antialias_defocus`` (True/False: defocus each view once with a summed-area table and
    /// read it once per view, constant cost whatever the blur, no occlusion tests; default
    /// False), ``antialias_layered`` ("auto", True/False: bin each view's sample by the depth its
    /// view sees into layers, box-filter each layer once and composite them front to back;
    /// default "auto": on one focus plane at the views' size with the light field's own depth,
    /// else off), ``antialias_box`` (True/False: away from occlusion edges an out-of-focus pixel
    /// is the box of its views' plain sums over its footprint, from summed-area tables; default
    /// True; False sub-samples every pixel), ``strategy`` ("auto", the default: the device's fastest, measured once and cached;
    /// "fragment", "batched:N", "compute"),
    /// ``views_per_draw``, ``filter`` ("hardware", "shader", "bicubic", "nearest"),
    /// ``accumulation`` ("rgba32f", "rgba16f"), ``warps`` ("ubo", "ssbo"), ``storage``
    /// ("srgb8", "linear16").
    ///
    /// Returns a ``uint8`` array of shape (H, W, 4), sRGB-encoded RGBA, byte for byte the
    /// PNG ``tiltfield render`` writes; with ``linear=True`` a ``float32`` array (H, W, 4) of
    /// linear-light RGBA, the values of its EXR. Alpha is 0 where no view reached the pixel.
    ///
    /// Raises ``ValueError`` for a bad argument or an impossible focus and ``TypeError`` for
    /// an argument of the wrong type, naming the keyword; ``RuntimeError`` for the GPU. Ctrl-C
    /// raises ``KeyboardInterrupt`` at once (the render finishes in the background; the next
    /// call waits for it). The views are uploaded on the first call; later calls cost the GPU
    /// time and a readback (:attr:`last_gpu_ms` is the GPU part).
    #[pyo3(signature = (*, linear=false, **options))]
    fn refocus<'py>(
        &self,
        py: Python<'py>,
        linear: bool,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mut options = request_for(py, options, "refocus")?;
        options.focus.validate().map_err(py_err)?;
        if linear {
            options.output = OutputFormat::Float;
        }
        options.check().map_err(py_err)?;
        let shared = Arc::clone(&self.session);
        let (image, timings) = gpu_work(py, "rendering", move || {
            let session = &mut lock(&shared).0;
            let progress = indicatif::ProgressBar::hidden();
            let (image, timings, prepared) = session.render(&options, &progress)?;
            Ok((image, timings, prepared))
        })
        .map(|(image, timings, prepared)| {
            let source = match prepared.strategy_source {
                StrategySource::Auto => "auto",
                StrategySource::Option => "option",
            };
            *lock(&self.last_strategy) = Some((prepared.settings.strategy.name(), source));
            (image, timings)
        })?;
        *lock(&self.last_gpu_ms) = timings.map(|t| t.refocus_ms + t.resolve_ms);
        image_to_numpy(py, image)
    }

    /// A focal stack: one :meth:`refocus` per value of ``disparity=`` or ``focus=`` (a
    /// sequence or 1-D array of numbers; ``focus`` planes take ``tilt``/``swing``), with one
    /// upload for all, each slice byte for byte the single call with that value. Every other
    /// keyword is :meth:`refocus`'s (``linear=True``: float32 linear light).
    ///
    /// ``progress``, if given, is called as ``progress(done, total)`` after each plane. Ctrl-C
    /// raises ``KeyboardInterrupt`` at once, between planes or within one (the plane in
    /// progress then finishes in the background), and the light field stays usable.
    ///
    /// Returns a ``uint8`` array (N, H, W, 4) of sRGB RGBA, or ``float32`` with ``linear=True``.
    /// Note that anti-aliasing is on by default where the light field has depth (several
    /// times the plain sum's time per plane); ``antialias=False`` gives the fast plain stack.
    #[pyo3(signature = (*, disparity=None, focus=None, progress=None, linear=false, **options))]
    fn focal_stack<'py>(
        &self,
        py: Python<'py>,
        disparity: Option<&Bound<'py, PyAny>>,
        focus: Option<&Bound<'py, PyAny>>,
        progress: Option<&Bound<'py, PyAny>>,
        linear: bool,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (values, is_disparity) =
            match (disparity, focus) {
                (Some(d), None) => (d, true),
                (None, Some(f)) => (f, false),
                _ => return Err(PyValueError::new_err(
                    "focal_stack: give exactly one of disparity= or focus= (a sequence of values)",
                )),
            };
        let name = if is_disparity { "disparity" } else { "focus" };
        let values: Vec<f64> = values.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "focal_stack: {name}= must be a sequence of numbers, got {}",
                repr(values)
            ))
        })?;
        if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "focal_stack: {name}= needs at least one value, all finite, got {values:?}"
            )));
        }
        let mut base = request_for(py, options, "focal_stack")?;
        if linear {
            base.output = OutputFormat::Float;
        }
        let planes: Vec<RenderOptions> = values
            .iter()
            .map(|&v| {
                let mut o = base.clone();
                if is_disparity {
                    o.focus.disparity = vec![v];
                } else {
                    o.focus.focus = vec![v];
                }
                o.focus.validate()?;
                o.check()?;
                Ok(o)
            })
            .collect::<tiltfield::Result<_>>()
            .map_err(py_err)?;
        let n = planes.len();
        let mut slices: Vec<Bound<'py, PyAny>> = Vec::with_capacity(n);
        for (k, options) in planes.into_iter().enumerate() {
            let shared = Arc::clone(&self.session);
            let (image, timings) = gpu_work(py, "rendering a focal stack", move || {
                let session = &mut lock(&shared).0;
                let hidden = indicatif::ProgressBar::hidden();
                let (image, timings, _) = session.render(&options, &hidden)?;
                Ok((image, timings))
            })?;
            *lock(&self.last_gpu_ms) = timings.map(|t| t.refocus_ms + t.resolve_ms);
            slices.push(image_to_numpy(py, image)?);
            if let Some(cb) = progress {
                cb.call1((k + 1, n))?;
            }
            py.check_signals()?;
        }
        let np = py.import("numpy")?;
        np.call_method1("stack", (slices,))
    }

    /// An animation (``tiltfield animate``): ``frames`` renders of one motion, with one
    /// upload for all, each frame byte for byte the :meth:`refocus` of its state.
    ///
    /// The motion is one of:
    ///
    /// - ``sweep="KEY=A..B"`` (or ``(KEY, A, B)``): one option from A to B, evenly over the
    ///   frames and both ends included (A > B runs backwards); KEY is ``disparity``, ``focus``
    ///   (with ``tilt``/``swing``), ``tilt`` or ``swing`` (with ``focus=Z``), or
    ///   ``aperture_radius`` (with a focus);
    /// - ``orbit=R``: the viewpoint on a circle of R grid steps around the grid centre, frame
    ///   k at angle 2πk/N from the +s (column) axis towards +t, i.e. ``view=(c_s + R cos θ,
    ///   c_t + R sin θ)``; needs a focus.
    ///
    /// ``bounce=True`` plays forward then backward without showing the ends twice. Every other
    /// keyword is :meth:`refocus`'s (not ``linear``: frames are 8-bit sRGB).
    ///
    /// Returns the frames in playback order as a ``uint8`` array (N, H, W, 4), or, with
    /// ``path=``, writes them (``.png``: animated PNG, ``.gif``, ``.mp4``: H.264 through
    /// ``ffmpeg``) at ``fps`` frames per second and returns ``None``. Raises ``ValueError``
    /// for a bad motion or keyword, with the CLI's message.
    #[pyo3(signature = (
        frames, *, sweep=None, orbit=None, bounce=false, fps=20.0, path=None, **options
    ))]
    #[allow(clippy::too_many_arguments)] // the animation's own keywords, as the CLI's options
    fn animate<'py>(
        &self,
        py: Python<'py>,
        frames: &Bound<'py, PyAny>,
        sweep: Option<&Bound<'py, PyAny>>,
        orbit: Option<f64>,
        bounce: bool,
        fps: f64,
        path: Option<std::path::PathBuf>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Option<Bound<'py, PyAny>>> {
        let base = request_for(py, options, "animate")?;
        let motion = motion_of(sweep, orbit)?;
        let frames = int_arg(Some(frames), "frames", 1..=animate::MAX_FRAMES as i64)?
            .unwrap_or_default() as usize;
        let animation = Animation::new(motion, frames, bounce).map_err(py_err)?;
        animation.states(&base, None).map_err(py_err)?;
        let format = path
            .as_deref()
            .map(|p| -> tiltfield::Result<Format> {
                let format = Format::from_path(p)?;
                format.check_fps(fps)?;
                format.check_available()?;
                tiltfield::io::check_writable(p)?;
                Ok(format)
            })
            .transpose()
            .map_err(py_err)?;
        let shown = animation.order().len();
        let shared = Arc::clone(&self.session);
        let cancel = Arc::new(AtomicBool::new(false));
        let cancelled = Arc::clone(&cancel);
        let rendered = gpu_work_with(py, "animating", Some(cancel), move || {
            let session = &mut lock(&shared).0;
            let states = animation.states(&base, Some(session.light_field().grid))?;
            let hidden = indicatif::ProgressBar::hidden();
            let mut run = |sink: &mut encode::Sink| {
                animate::render(session, &animation, &states, &hidden, |_| {}, sink)
            };
            match (&path, format) {
                (Some(path), Some(format)) => {
                    encode::write(format, path, fps, shown, run)?;
                    Ok(None)
                }
                _ => {
                    let mut all = Vec::new();
                    let report = run(&mut |frame| {
                        // Interrupted: stop after this frame (the caller has gone already).
                        if cancelled.load(Ordering::Relaxed) {
                            return Err(Error::Invalid("interrupted".into()));
                        }
                        all.extend_from_slice(frame.as_raw());
                        Ok(())
                    })?;
                    Ok(Some((all, report.size)))
                }
            }
        })?;
        let Some((all, (w, h))) = rendered else {
            return Ok(None);
        };
        let a = Array4::from_shape_vec((shown, h as usize, w as usize, 4), all)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(Some(a.into_pyarray(py).into_any()))
    }

    /// The focus plane a :meth:`refocus` call with the same focus keywords would use (the
    /// first of several: the render's own focus), as
    /// ``((px, py, pz), (nx, ny, nz))`` in the world frame (a unit normal), or ``None`` for
    /// classic shift-and-sum (``disparity=`` on a grid folder or array), which has no plane.
    /// A click or three pixels estimate the depth first when the light field has none.
    /// Takes the focus keywords of :meth:`refocus` and ``view``, ``aperture``,
    /// ``aperture_radius``, ``include_dark`` (the aperture is checked first, as a render does).
    ///
    /// With ``confidence=True`` the tuple has a third element: the pick's confidence in
    /// [0, 1] for ``click``, ``points`` and ``points_3d`` (what ``tiltfield render --json``
    /// reports as the focus's ``confidence``: the normal's for a click, the triangle's shape
    /// for three points), ``None`` for a focus given as numbers.
    #[pyo3(signature = (
        *, disparity=None, plane=None, focus=None, tilt=None, swing=None, click=None,
        points=None, points_3d=None, nudge_distance=None, nudge_tilt=None, nudge_swing=None,
        normal_window=None, normal_method="inverse-depth", aperture="disk",
        aperture_radius=None, view=None, include_dark=false, confidence=false
    ))]
    #[allow(clippy::too_many_arguments)] // the focus keywords of `refocus`
    fn plane<'py>(
        &self,
        py: Python<'py>,
        disparity: Option<&Bound<'py, PyAny>>,
        plane: Option<&Bound<'py, PyAny>>,
        focus: Option<&Bound<'py, PyAny>>,
        tilt: Option<&Bound<'py, PyAny>>,
        swing: Option<&Bound<'py, PyAny>>,
        click: Option<&Bound<'py, PyAny>>,
        points: Option<&Bound<'py, PyAny>>,
        points_3d: Option<&Bound<'py, PyAny>>,
        nudge_distance: Option<f64>,
        nudge_tilt: Option<f64>,
        nudge_swing: Option<f64>,
        normal_window: Option<&Bound<'_, PyAny>>,
        normal_method: &str,
        aperture: &str,
        aperture_radius: Option<f64>,
        view: Option<&Bound<'py, PyAny>>,
        include_dark: bool,
        confidence: bool,
    ) -> PyResult<Option<Bound<'py, PyTuple>>> {
        let focus = focus_options(
            disparity,
            plane,
            focus,
            (tilt, swing),
            (click, points, points_3d),
            (nudge_distance, nudge_tilt, nudge_swing),
            normal_window,
            normal_method,
        )?;
        let options = RenderOptions {
            focus,
            aperture: Aperture {
                shape: choice(Some(aperture))?.unwrap_or(Aperture::default().shape),
                radius: aperture_radius,
            },
            reference: numbers_of(view, 2, "view", "(s, t)")?.map(|v| DVec2::new(v[0], v[1])),
            include_dark,
            ..RenderOptions::default()
        };
        let shared = Arc::clone(&self.session);
        let resolved = gpu_work(py, "resolving the focus", move || {
            let progress = indicatif::ProgressBar::hidden();
            lock(&shared).0.resolve(&options, &progress)
        })?;
        let Some(p) = resolved.plane else {
            return Ok(None);
        };
        let point = (p.point.x, p.point.y, p.point.z);
        let normal = (p.normal.x, p.normal.y, p.normal.z);
        Ok(Some(if confidence {
            let pick_confidence = resolved.pick.map(|pick| pick.confidence);
            (point, normal, pick_confidence).into_pyobject(py)?
        } else {
            (point, normal).into_pyobject(py)?
        }))
    }

    /// The point cloud of the view that carries the depth map, as ``tiltfield cloud`` makes
    /// it (the depth estimated first, and kept, when the light field has none): a dict of
    /// ``positions`` (float32 (N, 3), world frame), ``normals`` (float32 (N, 3), zero where
    /// none was fitted), ``colours`` (uint8 (N, 3), sRGB), ``quality`` (float32 (N,), the
    /// normal's planarity in [0, 1]), ``points`` (how many of the N rows are the cloud: the
    /// rest are the focus planes' quad corners, four per plane, then the camera centres),
    /// ``faces`` (the quads, as lists of four row indices) and ``planes`` (each plane written
    /// as ``((px, py, pz), (nx, ny, nz))``). With ``path`` (a .ply file) it is also written
    /// there. Takes the focus keywords of :meth:`plane` (the plane to add; none: no quad),
    /// ``slab`` (a focus slab's half width: its boundary planes too), ``plane_size`` (half
    /// the quads' side; default half the cloud's diagonal), ``cameras`` and ``stride`` (every
    /// N-th pixel; default 1).
    #[pyo3(signature = (
        path=None, *, stride=None, cameras=false, plane_size=None, slab=None, disparity=None,
        plane=None, focus=None, tilt=None, swing=None, click=None, points=None, points_3d=None,
        nudge_distance=None, nudge_tilt=None, nudge_swing=None, normal_window=None,
        normal_method="inverse-depth", view=None
    ))]
    #[allow(clippy::too_many_arguments)] // `tiltfield cloud`'s options
    fn cloud<'py>(
        &self,
        py: Python<'py>,
        path: Option<std::path::PathBuf>,
        stride: Option<&Bound<'py, PyAny>>,
        cameras: bool,
        plane_size: Option<f64>,
        slab: Option<f64>,
        disparity: Option<&Bound<'py, PyAny>>,
        plane: Option<&Bound<'py, PyAny>>,
        focus: Option<&Bound<'py, PyAny>>,
        tilt: Option<&Bound<'py, PyAny>>,
        swing: Option<&Bound<'py, PyAny>>,
        click: Option<&Bound<'py, PyAny>>,
        points: Option<&Bound<'py, PyAny>>,
        points_3d: Option<&Bound<'py, PyAny>>,
        nudge_distance: Option<f64>,
        nudge_tilt: Option<f64>,
        nudge_swing: Option<f64>,
        normal_window: Option<&Bound<'_, PyAny>>,
        normal_method: &str,
        view: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let focus = focus_options_unchecked(
            disparity,
            plane,
            focus,
            (tilt, swing),
            (click, points, points_3d),
            (nudge_distance, nudge_tilt, nudge_swing),
            normal_window,
            normal_method,
        )?;
        let request = tiltfield::jobs::cloud::CloudRequest {
            focus,
            slab,
            reference: numbers_of(view, 2, "view", "(s, t)")?.map(|v| DVec2::new(v[0], v[1])),
            plane_size,
            cameras,
            stride: int_arg(stride, "stride", 1..=u32::MAX as i64)?.unwrap_or(1) as u32,
        };
        request.validate().map_err(py_err)?;
        if let Some(p) = &path {
            let ext = tiltfield::io::extension_lower(p);
            if ext.as_deref() != Some("ply") {
                return Err(PyValueError::new_err(format!(
                    "path={}: the cloud is written as PLY; give a file name ending in .ply",
                    p.display()
                )));
            }
        }
        let shared = Arc::clone(&self.session);
        let out = path.clone();
        let cloud = gpu_work(py, "making the point cloud", move || {
            let progress = indicatif::ProgressBar::hidden();
            let cloud = lock(&shared).0.cloud(&request, &progress)?;
            if let Some(p) = &out {
                cloud.mesh.write(p)?;
            }
            Ok(cloud)
        })?;
        let n = cloud.mesh.vertices.len();
        let flat3 = |f: &dyn Fn(&tiltfield::lightfield::ply::PlyVertex) -> [f32; 3]| {
            Array2::from_shape_vec((n, 3), cloud.mesh.vertices.iter().flat_map(f).collect())
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))
        };
        let colours = Array2::from_shape_vec(
            (n, 3),
            cloud.mesh.vertices.iter().flat_map(|v| v.colour).collect(),
        )
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        let quality: Vec<f32> = cloud.mesh.vertices.iter().map(|v| v.quality).collect();
        type PointNormal = ((f64, f64, f64), (f64, f64, f64));
        let planes: Vec<PointNormal> = cloud
            .plane
            .iter()
            .map(|p| p.plane)
            .chain(cloud.other_planes.iter().copied())
            .map(|p| {
                (
                    (p.point.x, p.point.y, p.point.z),
                    (p.normal.x, p.normal.y, p.normal.z),
                )
            })
            .collect();
        let d = PyDict::new(py);
        d.set_item("positions", flat3(&|v| v.position)?.into_pyarray(py))?;
        d.set_item("normals", flat3(&|v| v.normal)?.into_pyarray(py))?;
        d.set_item("colours", colours.into_pyarray(py))?;
        d.set_item(
            "quality",
            numpy::ndarray::Array1::from(quality).into_pyarray(py),
        )?;
        d.set_item("points", cloud.points)?;
        d.set_item("faces", cloud.mesh.faces.clone())?;
        d.set_item("planes", planes)?;
        Ok(d)
    }

    /// Estimates the reference view's disparity or depth from the views (a GPU plane sweep),
    /// as ``tiltfield depth`` does with the same options: ``kind`` ("disparity" or "depth";
    /// default: disparity where the light field has a convention, else depth), ``planes``,
    /// ``range=(min, max)`` (in ``kind`` units), ``views`` ("all", "cross", "cross:N",
    /// "square:N"), ``view=(s, t)`` (whole grid positions; default the middle view),
    /// ``cost`` ("robust", "mean"), ``aggregation`` ("guided", "box", "none"), ``radius``,
    /// ``naive``, ``no_fit``, ``no_snap`` (depth edges left where the windows put them),
    /// ``no_smooth`` (no global refinement of weakly textured pixels), ``no_plane_fill`` (the
    /// estimate's dominant planes not given to their weakly textured pixels), ``median`` (radius of
    /// the colour-weighted median; 0: none), ``include_dark``.
    ///
    /// Returns a ``float32`` array (H, W), NaN where there is no value; with
    /// ``confidence=True`` the tuple ``(depth, confidence)``, the confidence a ``float32``
    /// array (H, W) in [0, 1] (what ``tiltfield depth --confidence`` writes as a PNG). Does
    /// not install the estimate in the light field (renders that need depth estimate and
    /// cache their own).
    #[pyo3(signature = (
        *, kind=None, planes=None, range=None, views="cross", view=None, cost=None,
        aggregation=None, radius=None, naive=false, no_fit=false, no_snap=false,
        no_smooth=false, no_plane_fill=false, median=None, include_dark=false, confidence=false
    ))]
    #[allow(clippy::too_many_arguments)] // one keyword per `tiltfield depth` option
    fn depth<'py>(
        &self,
        py: Python<'py>,
        kind: Option<&str>,
        planes: Option<&Bound<'py, PyAny>>,
        range: Option<&Bound<'py, PyAny>>,
        views: &str,
        view: Option<&Bound<'py, PyAny>>,
        cost: Option<&str>,
        aggregation: Option<&str>,
        radius: Option<&Bound<'py, PyAny>>,
        naive: bool,
        no_fit: bool,
        no_snap: bool,
        no_smooth: bool,
        no_plane_fill: bool,
        median: Option<&Bound<'py, PyAny>>,
        include_dark: bool,
        confidence: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let request = DepthRequest {
            kind: kind.map(parse_kind).transpose().map_err(py_err)?,
            planes: int_arg(planes, "planes", 0..=u32::MAX as i64)?.map(|n| n as usize),
            range: numbers_of(range, 2, "range", "(min, max)")?.map(|v| (v[0], v[1])),
            views: choice(Some(views))?.unwrap_or(DepthRequest::default().views),
            reference: numbers_of(view, 2, "view", "(s, t)")?.map(|v| (v[0], v[1])),
            cost: choice(cost)?,
            aggregation: choice(aggregation)?,
            radius: u32_arg(radius, "radius")?,
            naive,
            no_fit,
            no_snap,
            no_smooth,
            no_plane_fill,
            median: u32_arg(median, "median")?,
            include_dark,
        };
        let options = request.options().map_err(py_err)?;
        let shared = Arc::clone(&self.session);
        let kind = request.kind;
        let (w, h, values, conf) = gpu_work(py, "estimating depth", move || {
            let session = &lock(&shared).0;
            let progress = indicatif::ProgressBar::hidden();
            let est = tiltfield::jobs::depth::estimate(
                session.context(),
                session.light_field(),
                &options,
                &progress,
            )?;
            let values = est.values(kind.unwrap_or_else(|| est.natural_kind()))?;
            Ok((est.width, est.height, values, est.confidence))
        })?;
        let shape = (h as usize, w as usize);
        let array = |v: Vec<f32>| {
            Array2::from_shape_vec(shape, v).map_err(|e| PyRuntimeError::new_err(e.to_string()))
        };
        let depth = array(values)?.into_pyarray(py);
        if !confidence {
            return Ok(depth.into_any());
        }
        let conf = array(conf)?.into_pyarray(py);
        Ok(PyTuple::new(py, [depth.into_any(), conf.into_any()])?.into_any())
    }
}

/// A refocus image as numpy: uint8 (H, W, 4) sRGB, or float32 (H, W, 4) linear light.
fn image_to_numpy(py: Python<'_>, image: GpuImage) -> PyResult<Bound<'_, PyAny>> {
    let shape_err = |e: numpy::ndarray::ShapeError| PyRuntimeError::new_err(e.to_string());
    match image {
        GpuImage::Srgb8(img) => {
            let (w, h) = img.dimensions();
            let a = Array3::from_shape_vec((h as usize, w as usize, 4), img.into_raw())
                .map_err(shape_err)?;
            Ok(a.into_pyarray(py).into_any())
        }
        GpuImage::Float(img) => {
            // What `save_exr` writes: encoded averages decoded to linear light.
            let (w, h) = (img.width, img.height);
            let flat: Vec<f32> = img.linear().into_iter().flatten().collect();
            let a = Array3::from_shape_vec((h as usize, w as usize, 4), flat).map_err(shape_err)?;
            Ok(a.into_pyarray(py).into_any())
        }
    }
}

/// Opens a light field: an HCI folder, a manifest (.json, or a folder with
/// tiltfield.json), a folder of views named by row and column, a camera-array video folder
/// (``frame``: the frame by its number in the file names; default the first), or
/// ``"builtin:NAME"`` (the built-in scenes of ``tiltfield demo --list``).
///
/// ``focal_px`` and ``baseline`` give the cameras of a grid folder (default: focal length
/// max(W, H) px, baseline 1), as ``--focal-px`` and ``--baseline`` do.
///
/// Raises ``OSError`` for a missing or unreadable file and ``ValueError`` for bad arguments,
/// naming the keyword. The GPU context is made on first use (one per process). A pickled
/// ``LightField`` from here is opened again from ``source`` (made absolute).
#[pyfunction]
#[pyo3(signature = (source, frame=None, *, focal_px=None, baseline=1.0))]
fn open(
    py: Python<'_>,
    source: std::path::PathBuf,
    frame: Option<&Bound<'_, PyAny>>,
    focal_px: Option<f64>,
    baseline: f64,
) -> PyResult<LightField> {
    let frame = int_arg(frame, "frame", 0..=i64::MAX)?;
    let read = ReadOptions {
        focal_px,
        baseline,
        frame: frame.map(|f| f as u64),
    };
    let text = source.to_string_lossy().into_owned();
    let loading = text.clone();
    let session = gpu_work(py, "loading", move || {
        let ctx = context()?;
        // The device first, so a light field it cannot hold is refused before decoding.
        let lf = render::open_light_field(&loading, &read, &render::device_load_limits(&ctx))?;
        Ok(SendSession(Session::new(ctx, lf)))
    })?;
    // A path (not `builtin:NAME`) absolute, for a process with another working folder.
    let source = std::fs::canonicalize(&source).map_or(text, |p| p.to_string_lossy().into_owned());
    Ok(LightField::new(
        session,
        Source::Path {
            source,
            frame,
            focal_px,
            baseline,
        },
    ))
}

/// Linear light to 8-bit sRGB exactly as the library's `color::encode_srgb8` (so arrays give
/// the bytes the CLI stores), at the cost of two table look-ups instead of a `powf` per value.
///
/// Each code's threshold, the smallest `f32` that encodes to it or more, is found by bisection
/// over the bit patterns with the library's own function (monotone on [0, 1]). The tables
/// hold, per bucket of 2^16 bit patterns, the code of the bucket's first value and the next
/// code's threshold. A bucket is at most 1/128 of its value wide, and codes lie at least
/// 1/113 of theirs apart (the steepest part of the curve, near 1; 1/k in the linear part near
/// 0), so a bucket holds at most one threshold: a value is its bucket's code, plus one if it
/// reaches that threshold. The two look-ups are independent (no chain of loads), and
/// tests/python checks every value around every threshold against the library.
struct SrgbEncoder {
    code: Box<[u8; TABLE]>,
    next: Box<[f32; TABLE]>,
}

const COARSE_SHIFT: u32 = 16;
/// The bits of 1.0f32, the last value in range.
const ONE_BITS: u32 = 0x3f80_0000;
/// Buckets up to 1.0 inclusive; a fixed size, so that indices clamped below it need no
/// bounds checks.
const TABLE: usize = (ONE_BITS >> COARSE_SHIFT) as usize + 1;

impl SrgbEncoder {
    fn get() -> &'static SrgbEncoder {
        static ENCODER: OnceLock<SrgbEncoder> = OnceLock::new();
        ENCODER.get_or_init(|| {
            let one = ONE_BITS;
            // thresholds[256] is infinite: no code above 255.
            let mut thresholds = [f32::INFINITY; 257];
            for (k, t) in thresholds.iter_mut().enumerate().take(256).skip(1) {
                let (mut lo, mut hi) = (0u32, one);
                while lo < hi {
                    let mid = lo + (hi - lo) / 2;
                    if usize::from(tiltfield::color::encode_srgb8(f32::from_bits(mid))) >= k {
                        hi = mid;
                    } else {
                        lo = mid + 1;
                    }
                }
                *t = f32::from_bits(lo);
            }
            let mut code = Box::new([0u8; TABLE]);
            let mut next = Box::new([0f32; TABLE]);
            for (i, (k, t)) in code.iter_mut().zip(next.iter_mut()).enumerate() {
                let v = f32::from_bits((i as u32) << COARSE_SHIFT);
                *k = thresholds[1..256].partition_point(|&t| t <= v) as u8;
                *t = thresholds[usize::from(*k) + 1];
            }
            SrgbEncoder { code, next }
        })
    }

    /// The tables as slices, held in registers by the conversion loop (through the static,
    /// every byte written would make the compiler reload them).
    fn tables(&self) -> Srgb<'_> {
        Srgb {
            code: &self.code,
            next: &self.next,
        }
    }
}

/// [`SrgbEncoder`]'s tables, borrowed for a conversion.
#[derive(Clone, Copy)]
struct Srgb<'a> {
    code: &'a [u8; TABLE],
    next: &'a [f32; TABLE],
}

impl Srgb<'_> {
    /// The code of `v` if it lies in [0, 1] (-0.0 included); any other value gives some code
    /// (the conversion checks values in the same pass and drops such a view).
    #[inline(always)]
    fn encode(self, v: f32) -> u8 {
        let i = (((v.to_bits() & 0x7fff_ffff) >> COARSE_SHIFT) as usize).min(TABLE - 1);
        // No overflow: the threshold after code 255 is infinite.
        self.code[i].wrapping_add(u8::from(v >= self.next[i]))
    }
}

/// How `convert_view` reads one dtype: which values it takes and how colour and alpha become
/// bytes. A trait with inlined methods rather than closures: called per value, a call would
/// cost more than the conversion, and closures were not inlined at the tests' opt-level.
trait Channels<T: Copy> {
    fn valid(&self, v: T) -> bool;
    fn colour(&self, v: T) -> u8;
    fn alpha(&self, v: T) -> u8;
}

/// sRGB bytes as given.
struct Bytes;

impl Channels<u8> for Bytes {
    #[inline(always)]
    fn valid(&self, _: u8) -> bool {
        true
    }
    #[inline(always)]
    fn colour(&self, v: u8) -> u8 {
        v
    }
    #[inline(always)]
    fn alpha(&self, v: u8) -> u8 {
        v
    }
}

/// Linear light in [0, 1]: colour encoded as sRGB, alpha (coverage) only quantised.
impl Channels<f32> for Srgb<'_> {
    #[inline(always)]
    fn valid(&self, v: f32) -> bool {
        (0.0..=1.0).contains(&v)
    }
    #[inline(always)]
    fn colour(&self, v: f32) -> u8 {
        self.encode(v)
    }
    #[inline(always)]
    fn alpha(&self, v: f32) -> u8 {
        tiltfield::color::to_u8(f64::from(v))
    }
}

/// One view (H, W, C) as an RGBA8 image: every value checked by `ch.valid` first
/// (`Err((y, x))` at the first pixel holding one it refuses), then colour channels through
/// `ch.colour`, alpha through `ch.alpha` (255 without one). Contiguous views (the usual case) are read as one slice,
/// in loops the compiler vectorises or keeps branch-free; strided ones (a transposed array)
/// pixel by pixel.
#[inline(always)]
fn convert_view<T: Copy>(
    view: ArrayView3<'_, T>,
    ch: impl Channels<T>,
) -> Result<image::RgbaImage, (usize, usize)> {
    let (h, w, c) = view.dim();
    let mut out = vec![255u8; h * w * 4];
    if let Some(flat) = view.as_slice() {
        let all_valid = if c == 4 {
            convert_flat::<T, 4>(flat, &mut out, &ch)
        } else {
            convert_flat::<T, 3>(flat, &mut out, &ch)
        };
        if !all_valid {
            let i = flat.iter().position(|&v| !ch.valid(v)).unwrap_or(0) / c;
            return Err((i / w, i % w));
        }
    } else {
        for (y, row) in view.outer_iter().enumerate() {
            for (x, src) in row.outer_iter().enumerate() {
                if !src.iter().all(|&v| ch.valid(v)) {
                    return Err((y, x));
                }
                let dst = &mut out[(y * w + x) * 4..][..4];
                dst[0] = ch.colour(src[0]);
                dst[1] = ch.colour(src[1]);
                dst[2] = ch.colour(src[2]);
                if c == 4 {
                    dst[3] = ch.alpha(src[3]);
                }
            }
        }
    }
    Ok(image::RgbaImage::from_raw(w as u32, h as u32, out)
        .unwrap_or_else(|| image::RgbaImage::new(w as u32, h as u32)))
}

/// The contiguous pixels of `flat` (C channels each) into RGBA `out`, converting and checking
/// in one pass without a branch (a second pass over the values would cost more than the
/// conversion); false if any value is invalid. C is a constant so that each pixel's channels
/// are fixed-size loads.
#[inline(always)]
fn convert_flat<T: Copy, const C: usize>(
    flat: &[T],
    out: &mut [u8],
    ch: &impl Channels<T>,
) -> bool {
    let mut all_valid = true;
    for (src, dst) in flat.chunks_exact(C).zip(out.chunks_exact_mut(4)) {
        // Element by element: `copy_from_slice` of three bytes is a memmove call at the
        // tests' opt-level.
        let mut px = [src[0]; 4];
        #[allow(clippy::manual_memcpy)]
        for k in 1..C {
            px[k] = src[k];
        }
        all_valid &= ch.valid(px[0]) & ch.valid(px[1]) & ch.valid(px[2]);
        dst[0] = ch.colour(px[0]);
        dst[1] = ch.colour(px[1]);
        dst[2] = ch.colour(px[2]);
        if C == 4 {
            all_valid &= ch.valid(px[3]);
            dst[3] = ch.alpha(px[3]);
        }
    }
    all_valid
}

/// `views` as a numpy array: an ndarray as it is, a DLPack producer (a torch or JAX array)
/// through `numpy.from_dlpack`, anything with `__array__` (or the array interfaces) through
/// `numpy.asarray`; neither copies where the layout allows.
fn as_ndarray<'py>(views: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let np = views.py().import("numpy")?;
    if views.is_instance(&np.getattr("ndarray")?)? {
        return Ok(views.clone());
    }
    if views.hasattr("__dlpack__")? {
        return np.call_method1("from_dlpack", (views,));
    }
    for protocol in ["__array__", "__array_interface__", "__array_struct__"] {
        if views.hasattr(protocol)? {
            return np.call_method1("asarray", (views,));
        }
    }
    Err(PyTypeError::new_err(format!(
        "views must be an array (numpy.ndarray, or an object with __array__ or __dlpack__) of \
         shape (rows, cols, H, W, 3 or 4), got {}",
        article(&type_name(views))
    )))
}

fn article(name: &str) -> String {
    let vowel = name.starts_with(['a', 'e', 'i', 'o', 'u']);
    format!("{} {name}", if vowel { "an" } else { "a" })
}

/// Memory this machine has free for new data (Linux: MemAvailable), `None` where unknown.
fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses a light field of `rows`×`cols` views of `h`×`w` px that the device (`limits`, as
/// `open` applies them to files) or this machine's memory cannot hold, from the shape alone:
/// nothing of the array is read, so a huge broadcast array fails at once.
fn check_view_limits(
    (rows, cols, h, w): (usize, usize, usize, usize),
    limits: &LoadLimits,
) -> PyResult<()> {
    let n = rows as u128 * cols as u128;
    if n > limits.max_views as u128 {
        return Err(PyValueError::new_err(format!(
            "views: {rows}×{cols} = {n} views, more than {} ({})",
            limits.max_views, limits.views_why
        )));
    }
    if h.max(w) as u128 > u128::from(limits.max_dimension) {
        return Err(PyValueError::new_err(format!(
            "views: each is {h}×{w} px, larger than {} px a side ({})",
            limits.max_dimension, limits.dimension_why
        )));
    }
    let bytes = n * h as u128 * w as u128 * 4;
    let mib = |b: u128| b >> 20;
    if bytes > u128::from(limits.max_bytes) {
        return Err(PyValueError::new_err(format!(
            "views: {} MiB as 8-bit RGBA, more than {} MiB ({})",
            mib(bytes),
            mib(u128::from(limits.max_bytes)),
            limits.bytes_why
        )));
    }
    if let Some(free) = available_memory() {
        if bytes > u128::from(free) {
            return Err(PyValueError::new_err(format!(
                "views: {} MiB as 8-bit RGBA, more than this machine's available memory \
                 ({} MiB)",
                mib(bytes),
                mib(u128::from(free))
            )));
        }
    }
    Ok(())
}

/// The views of an array of shape (rows, cols, H, W, C), C = 3 or 4, as sRGB images in
/// row-major grid order: the shape and dtype checked first, then the sizes against `limits`,
/// and only then the values (float32: each in [0, 1], refused with its index otherwise).
fn views_of(
    py: Python<'_>,
    views: &Bound<'_, PyAny>,
    limits: &LoadLimits,
) -> PyResult<(GridSize, Vec<image::RgbaImage>)> {
    let views = as_ndarray(views)?;
    let shape: Vec<usize> = views.getattr("shape")?.extract()?;
    let dims = match shape[..] {
        [rows, cols, h, w, c] if rows > 0 && cols > 0 && h > 0 && w > 0 && (c == 3 || c == 4) => {
            (rows, cols, h, w)
        }
        _ => {
            let text = match &shape[..] {
                [one] => format!("({one},)"),
                _ => format!(
                    "({})",
                    shape
                        .iter()
                        .map(usize::to_string)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            };
            return Err(PyValueError::new_err(format!(
                "views must have shape (rows, cols, H, W, 3 or 4), got shape {text}"
            )));
        }
    };
    let dtype = views.getattr("dtype")?.str()?.to_string();
    if dtype != "uint8" && dtype != "float32" {
        return Err(PyValueError::new_err(format!(
            "views must be of dtype uint8 (sRGB) or float32 (linear light, 0 to 1), got dtype \
             {dtype}"
        )));
    }
    check_view_limits(dims, limits)?;
    let (rows, cols, ..) = dims;
    let mut images = Vec::with_capacity(rows * cols);
    if dtype == "uint8" {
        let array = views.extract::<PyReadonlyArrayDyn<'_, u8>>()?;
        let a = array
            .as_array()
            .into_dimensionality::<Ix5>()
            .map_err(shape_err)?;
        for t in 0..rows {
            for s in 0..cols {
                let view = a.slice(s![t, s, .., .., ..]);
                let img = convert_view(view, Bytes)
                    .map_err(|_| PyRuntimeError::new_err("uint8 views cannot be refused"))?;
                images.push(img);
            }
            py.check_signals()?;
        }
    } else {
        let array = views.extract::<PyReadonlyArrayDyn<'_, f32>>()?;
        let a = array
            .as_array()
            .into_dimensionality::<Ix5>()
            .map_err(shape_err)?;
        let enc = SrgbEncoder::get().tables();
        for t in 0..rows {
            for s in 0..cols {
                let view = a.slice(s![t, s, .., .., ..]);
                // Colour channels are linear light; alpha is coverage and is not encoded.
                let img = convert_view(view, enc);
                match img {
                    Ok(img) => images.push(img),
                    Err((y, x)) => {
                        let pixel = view.slice(s![y, x, ..]);
                        let (ch, v) = pixel
                            .iter()
                            .enumerate()
                            .find(|(_, v)| !enc.valid(**v))
                            .map_or((0, f32::NAN), |(ch, v)| (ch, *v));
                        return Err(PyValueError::new_err(format!(
                            "views: float32 values are linear light from 0 to 1, got {v} at \
                             index ({t}, {s}, {y}, {x}, {ch})"
                        )));
                    }
                }
            }
            py.check_signals()?;
        }
    }
    Ok((GridSize { cols, rows }, images))
}

fn shape_err(e: numpy::ndarray::ShapeError) -> PyErr {
    PyRuntimeError::new_err(e.to_string())
}

/// `_tiltfield._srgb_table_mismatches(lo, hi)`: the `f32` bit patterns in `lo..hi` (within
/// [0, 1]) where the table encoder of `from_array` differs from the library's
/// `color::encode_srgb8`, for the tests (at most 16 reported).
#[pyfunction]
fn _srgb_table_mismatches(py: Python<'_>, lo: u32, hi: u32) -> Vec<u32> {
    let hi = hi.min(ONE_BITS + 1);
    py.allow_threads(|| {
        let enc = SrgbEncoder::get().tables();
        (lo..hi)
            .filter(|&bits| {
                let v = f32::from_bits(bits);
                enc.encode(v) != tiltfield::color::encode_srgb8(v)
            })
            .take(16)
            .collect()
    })
}

fn type_name(value: &Bound<'_, PyAny>) -> String {
    value
        .get_type()
        .name()
        .map_or_else(|_| "object".into(), |n| n.to_string())
}

/// Makes a light field from views in memory, read as a grid folder of the same images would
/// be: nominal parallel cameras (focal length ``focal_px``, default max(W, H) px; neighbours
/// ``baseline`` apart, default 1) and classic shift-and-sum ``disparity``.
///
/// ``views``: a numpy array of shape (rows, cols, H, W, C) with C = 3 (RGB) or 4 (RGBA):
/// ``uint8`` sRGB-encoded (as read from PNG files), or ``float32`` linear light in 0..1
/// (encoded to 8-bit sRGB with rounding to nearest, as tiltfield stores every view). Row t,
/// column s is the camera at grid row t (downwards) and column s (to the right), as in the
/// CLI's ``--view S,T``.
///
/// Other libraries' layouts are a transpose away (``numpy.transpose`` makes a view; strided
/// arrays are read as they are, no copy needed):
///
/// - plenpy's (u, v, s, t, ch): angular (u, v), then spatial (s, t), each pair in numpy's
///   (row, column) order, is already (rows, cols, H, W, C); an array with x before y in
///   both pairs, (cols, rows, W, H, C), is ``numpy.transpose(a, (1, 0, 3, 2, 4))``;
/// - the Light Field Toolbox's LF(t, s, v, u, c) (t, s: grid row and column; v, u: pixel row
///   and column) read with ``scipy.io.loadmat`` is already (rows, cols, H, W, C) — drop its
///   weight channel, ``LF[..., :3]``, when the 4th is a weight rather than alpha; a v7.3
///   file read with h5py comes reversed, (c, u, v, s, t): ``numpy.transpose(a, (4, 3, 2, 1, 0))``.
///
/// Any array will do: a numpy array, an object with ``__array__``, or a DLPack producer (a
/// torch or JAX array, read through ``numpy.from_dlpack``). The shape is checked against the
/// device's limits and the machine's free memory before any value is read (``ValueError``);
/// ``float32`` values outside [0, 1] (or not finite) are refused with their index.
///
/// ``depth``: an optional (H, W) ``float32`` classic disparity map of the middle view
/// (cols // 2, rows // 2), px per grid step (view (s, t) sees that view's pixel x at
/// x + (s - s_r, t - t_r) * D), NaN where unknown. With it the cameras take the nominal sensor
/// shift that gives every disparity a depth (docs/conventions.md §10), clicks and focus
/// surfaces use it, and anti-aliasing is on by default.
#[pyfunction]
#[pyo3(signature = (views, *, focal_px=None, baseline=None, depth=None))]
fn from_array(
    py: Python<'_>,
    views: &Bound<'_, PyAny>,
    focal_px: Option<f64>,
    baseline: Option<f64>,
    depth: Option<&Bound<'_, PyAny>>,
) -> PyResult<LightField> {
    let read = ReadOptions {
        focal_px,
        baseline: baseline.unwrap_or(1.0),
        frame: None,
    };
    read.validate().map_err(py_err)?;
    // The device's limits before anything of the array is read (as `open` checks files).
    let ctx = gpu_work(py, "starting Vulkan", context)?;
    let (grid, images) = views_of(py, views, &render::device_load_limits(&ctx))?;
    let (w, h) = images[0].dimensions();
    let depth = depth
        .map(|d| {
            let bad = || {
                PyValueError::new_err(format!(
                    "depth must be a float32 array of shape (H, W) = ({h}, {w}) (the views' \
                     size), got {}",
                    d.getattr("shape")
                        .map_or_else(|_| type_name(d), |s| format!("shape {s}"))
                ))
            };
            let a = d
                .extract::<PyReadonlyArrayDyn<'_, f32>>()
                .map_err(|_| bad())?;
            if a.shape() != [h as usize, w as usize] {
                return Err(bad());
            }
            Ok(a.as_array().iter().copied().collect::<Vec<f32>>())
        })
        .transpose()?;
    let kept = depth.clone();
    let session = gpu_work(py, "loading", move || {
        let mut lf =
            lightfield::grid_folder::from_images("array", grid, images, &read.grid_cameras())?;
        if let Some(values) = depth {
            let f = read.focal_px.unwrap_or(w.max(h) as f64);
            tiltfield::depth::cache::install_classic_disparity(&mut lf, values, f, read.baseline)?;
        }
        Ok(SendSession(Session::new(ctx, lf)))
    })?;
    Ok(LightField::new(
        session,
        Source::Arrays {
            focal_px,
            baseline,
            depth: kept,
        },
    ))
}

/// The Vulkan device the module renders on, as ``{"name", "kind", "driver", "api_version"}``
/// (makes the process's GPU context when there is none yet).
#[pyfunction]
fn device(py: Python<'_>) -> PyResult<std::collections::HashMap<&'static str, String>> {
    let ctx = gpu_work(py, "starting Vulkan", context)?;
    let i = &ctx.info;
    Ok([
        ("name", i.name.clone()),
        ("kind", i.kind.clone()),
        ("driver", i.driver.clone()),
        ("api_version", i.api_version.clone()),
    ]
    .into_iter()
    .collect())
}

/// Messages the Khronos validation layer has reported as errors in this process (0 when
/// validation is off: set ``TILTFIELD_VALIDATION=1`` before the first GPU call to turn it on).
/// Every call that caused one raises ``RuntimeError`` as well.
#[pyfunction]
fn validation_errors() -> usize {
    validation_count()
}

/// Whether the Khronos validation layer is on in this process's context.
#[pyfunction]
fn validation_enabled() -> bool {
    GpuOptions::from_env().validation
}

#[pymodule]
fn _tiltfield(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // The library's warnings (views left out as dark, anti-aliasing turned off) go to stderr
    // as the CLI prints them; RUST_LOG changes the level.
    let _ = env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
        .format_target(false)
        .try_init();
    // numpy's C API and rust-numpy's borrow checking are set up on first use, by importing
    // numpy modules; on the first call of a process a pending Ctrl-C made that import fail,
    // which rust-numpy reports as a panic. Set up here instead, where an interrupt is an
    // ordinary KeyboardInterrupt of `import tiltfield`.
    let py = m.py();
    numpy::PyArray1::<u8>::zeros(py, 0, false).readonly();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<LightField>()?;
    m.add_function(wrap_pyfunction!(open, m)?)?;
    m.add_function(wrap_pyfunction!(from_array, m)?)?;
    m.add_function(wrap_pyfunction!(device, m)?)?;
    m.add_function(wrap_pyfunction!(validation_errors, m)?)?;
    m.add_function(wrap_pyfunction!(validation_enabled, m)?)?;
    m.add_function(wrap_pyfunction!(_srgb_table_mismatches, m)?)?;
    Ok(())
}
