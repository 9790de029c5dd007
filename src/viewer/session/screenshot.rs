//! Screenshots (`P`, or a script's `screenshot PREFIX`): the refocus image at full quality
//! exactly as `render` computes it, the scene panel, the composed window, and a JSON record of
//! the state that `render` can reproduce `PREFIX_refocus.png` from.

use std::path::{Path, PathBuf};

use image::RgbaImage;

use super::super::gpu::ViewerGpu;
use super::super::state::ViewerState;
use crate::depth::DepthOrigin;
use crate::error::Result;
use crate::geometry::plane::Plane;
use crate::lightfield::LightField;
use crate::refocus::antialias::AntialiasPlan;
use crate::refocus::surface::SurfacePlan;

/// Screenshots asked for and taken.
pub struct Screenshots {
    /// Where `P` writes (a counter is appended).
    prefix: PathBuf,
    /// `P` presses so far.
    taken: u32,
    /// The prefix of the screenshot the next frame takes.
    pub next: Option<PathBuf>,
    /// The next screenshot is a `P` press: the strip says where it went (a script's
    /// screenshots are the script's business).
    pub announce: bool,
}

impl Screenshots {
    pub fn new(prefix: PathBuf) -> Self {
        Screenshots {
            prefix,
            taken: 0,
            next: None,
            announce: false,
        }
    }

    /// A `P` press: the next numbered screenshot.
    pub fn numbered(&mut self) {
        self.taken += 1;
        self.next = Some(with_suffix(&self.prefix, &format!("-{}", self.taken)));
        self.announce = true;
    }
}

fn with_suffix(prefix: &Path, suffix: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// The state of a screenshot: the plan as `render --json` reports it, with the focus method,
/// aperture, averaging, anti-aliasing (`aa`: its plan when on) and the focus surface
/// (`surface`: resolved with the depth, when more than one plane; as `render --json`'s
/// `surface`), so `render` can reproduce `PREFIX_refocus.png`.
pub fn screenshot_json(
    state: &ViewerState,
    aa: Option<&AntialiasPlan>,
    surface: Option<&SurfacePlan>,
    depth: Option<&DepthOrigin>,
    filter: crate::refocus::settings::Filter,
) -> serde_json::Value {
    let mut v = crate::refocus::plan_json(aa.map_or(&state.plan, |a| &a.plan));
    if let Some(obj) = v.as_object_mut() {
        obj.insert("focus_how".into(), state.resolved.how.into());
        obj.insert(
            "aperture".into(),
            serde_json::json!({"shape": state.aperture().shape, "radius": state.aperture().radius}),
        );
        obj.insert(
            "averaging".into(),
            serde_json::to_value(state.averaging()).unwrap_or_default(),
        );
        obj.insert(
            "antialias".into(),
            crate::refocus::antialias::antialias_json(aa, None),
        );
        obj.insert("filter".into(), filter.name().into());
        obj.insert("surface".into(), surface_json(state, surface, depth));
        // What the panel says (a refusal, a pick in progress): scripts can check it.
        obj.insert("message".into(), state.message.clone().into());
    }
    v
}

/// The focus surface as `render --json` reports it (`kind`, `planes`, `slab_half_width`, …);
/// a single plane without depth as `{"kind": "plane", "planes": [the plane]}`.
pub fn surface_json(
    state: &ViewerState,
    surface: Option<&SurfacePlan>,
    depth: Option<&DepthOrigin>,
) -> serde_json::Value {
    match surface {
        Some(sp) => sp.json(depth.map(DepthOrigin::brief_json)),
        None => {
            let planes: Vec<_> = state.plan.plane.iter().map(Plane::json).collect();
            serde_json::json!({"kind": "plane", "planes": planes})
        }
    }
}

/// Writes `PREFIX_refocus.png`, `PREFIX_scene.png`, `PREFIX_window.png` (the composed `window`
/// of this frame) and `PREFIX.json`; `frames` is the number of frames presented so far.
#[allow(clippy::too_many_arguments)]
pub fn save(
    gpu: &mut ViewerGpu,
    lf: &LightField,
    state: &ViewerState,
    aa: Option<&AntialiasPlan>,
    surface: Option<&SurfacePlan>,
    depth: Option<&DepthOrigin>,
    prefix: &Path,
    window: Option<&RgbaImage>,
    frames: usize,
    (cursor, notice, peaking): (Option<&str>, Option<&str>, serde_json::Value),
) -> Result<()> {
    let full = state.plan.clone();
    let refocus =
        gpu.capture_refocus(&full, aa, surface, state.averaging(), (lf.width, lf.height))?;
    crate::io::save_png(&refocus, &with_suffix(prefix, "_refocus.png"))?;
    let scene = gpu.capture_scene()?;
    crate::io::save_png(&scene, &with_suffix(prefix, "_scene.png"))?;
    if let Some(w) = window {
        crate::io::save_png(w, &with_suffix(prefix, "_window.png"))?;
    }
    let mut json = screenshot_json(state, aa, surface, depth, gpu.filter);
    if let Some(obj) = json.as_object_mut() {
        // The views stay in one storage whatever E does: `render --average encoded` defaults
        // to srgb8, so reproducing an encoded screenshot needs `--storage` as recorded here.
        obj.insert(
            "storage".into(),
            serde_json::to_value(gpu.storage).unwrap_or_default(),
        );
        if let Some(f) = state.frame {
            obj.insert("frame".into(), f.into());
        }
        // Frames presented so far (this one included): scripts can check that an idle
        // viewer renders nothing.
        obj.insert("frames_presented".into(), frames.into());
        // The status strip's reading of the depth under the cursor (null off the image).
        obj.insert("cursor_depth".into(), cursor.into());
        // The notice in the strip (where the last `P` screenshot went), null without one.
        obj.insert("notice".into(), notice.into());
        // Focus peaking: shown or not, and the share of the refocus panel it tints (null
        // while its mask is not up to date).
        obj.insert("peaking".into(), peaking);
    }
    let path = with_suffix(prefix, ".json");
    crate::io::write_bytes(&path, "JSON", format!("{json:#}\n").as_bytes())?;
    log::info!("screenshot {}", prefix.display());
    eprintln!(
        "wrote {0}_refocus.png, {0}_scene.png, {0}_window.png and {0}.json",
        prefix.display()
    );
    Ok(())
}
