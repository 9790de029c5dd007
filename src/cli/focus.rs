//! The focus options shared by `render` and `cloud`: the keyboard and plane definitions
//! (`--disparity`, `--plane`, `--focus/--tilt/--swing`) and the scene-based ones (`--click`,
//! `--points`, `--points-3d`) with keyboard fine adjustment (`--nudge-*`). This module only
//! parses them into a [`FocusRequest`] and reports the result; the library resolves it
//! ([`crate::refocus::focus`]).
//!
//! Pixels given to `--click` and `--points` are pixels of the view that carries the depth map
//! (normally the centre view), also when `--view` renders from another viewpoint: the plane
//! found is a world-frame plane. Nudges act in the keyboard definition relative to the
//! reference camera of the render (`--view`, default the grid centre).

use clap::Args;
use glam::{DVec2, DVec3};

use super::parse_numbers;
use crate::error::Result;
use crate::geometry::normals::NormalMethod;
use crate::geometry::picking::Nudge;
use crate::geometry::plane::Plane;
use crate::lightfield::LightField;
use crate::refocus::options::{plane_of, FocusOptions};
use crate::refocus::{resolve_focus, FocusRequest, FocusSpec, ResolvedFocus};

/// Ids of all focus options, for the parent command's mutually exclusive group.
pub const FOCUS_OPTIONS: [&str; 6] = [
    "disparity",
    "plane",
    "focus",
    "click",
    "points",
    "points_3d",
];

/// The keyboard and plane definitions of the refocus plane (shared by `render`, `cloud` and
/// `synth`'s optical ground truth). Mutual exclusion is the parent command's group.
///
/// `render` and `cloud` take each plane form 2 to 8 times, a focus surface of several planes
/// (the first is the render's focus); the forms do not mix. Other commands take one plane.
#[derive(Debug, Clone, Args)]
pub struct PlaneArgs {
    /// Frontoparallel focus by disparity in pixels per grid step. HCI convention on HCI data,
    /// rig manifests and built-in scenes (positive = nearer than the focus distance); classic
    /// shift-and-sum elsewhere (view (s,t) sampled at u + (s − s_r)·D, v + (t − t_r)·D).
    /// `render` and `cloud` take it 2 to 8 times: a focus surface of frontoparallel planes
    /// (without a rig, the planes the classic shifts stand for on parallel cameras).
    #[arg(
        long,
        value_name = "D",
        allow_hyphen_values = true,
        action = clap::ArgAction::Append
    )]
    pub disparity: Vec<f64>,
    /// Refocus plane: world point and normal. `render` and `cloud` take it 2 to 8 times: a
    /// focus surface of several planes (each pixel focused on the plane nearest the scene
    /// there; the first is the render's focus). One form per surface: --plane, --focus or
    /// --disparity repeated, not mixed.
    #[arg(
        long,
        value_name = "PX,PY,PZ,NX,NY,NZ",
        allow_hyphen_values = true,
        action = clap::ArgAction::Append
    )]
    pub plane: Vec<String>,
    /// Refocus plane through the reference optical axis at distance Z (world units).
    /// `render` and `cloud` take it 2 to 8 times: a focus surface of several planes, each
    /// turned by --tilt and --swing.
    #[arg(
        long,
        value_name = "Z",
        allow_hyphen_values = true,
        action = clap::ArgAction::Append
    )]
    pub focus: Vec<f64>,
    /// Tilt of the --focus plane in degrees (positive: top of the image farther; default 0).
    /// With several --focus: once (every plane) or once per --focus (paired by order).
    #[arg(
        long,
        value_name = "DEG",
        requires = "focus",
        allow_hyphen_values = true,
        action = clap::ArgAction::Append
    )]
    pub tilt: Vec<f64>,
    /// Swing of the --focus plane in degrees (positive: right side farther; default 0).
    /// With several --focus: once (every plane) or once per --focus (paired by order).
    #[arg(
        long,
        value_name = "DEG",
        requires = "focus",
        allow_hyphen_values = true,
        action = clap::ArgAction::Append
    )]
    pub swing: Vec<f64>,
}

impl PlaneArgs {
    /// The focus these options give, with its name for reports; `None` when none is given.
    /// A plane form given more than once is a focus surface, which only `render` and `cloud`
    /// take ([`FocusOptions::one_spec`]).
    pub fn spec(&self) -> Result<Option<(&'static str, FocusSpec)>> {
        Ok(self.options()?.one_spec()?.map(|spec| {
            let name = FocusRequest::from(spec).name();
            (name, spec)
        }))
    }

    /// Every `--plane`, in order (empty when none is given).
    pub fn planes(&self) -> Result<Vec<Plane>> {
        self.plane
            .iter()
            .map(|text| plane_of(&parse_numbers(text, 6, "--plane")?))
            .collect()
    }

    /// The plane options as numbers for the library (parsing only).
    fn options(&self) -> Result<FocusOptions> {
        Ok(FocusOptions {
            disparity: self.disparity.clone(),
            planes: self.planes()?,
            focus: self.focus.clone(),
            tilt: self.tilt.clone(),
            swing: self.swing.clone(),
            ..FocusOptions::default()
        })
    }
}

/// Focus options. The parent command defines the group `focus_plane` over [`FOCUS_OPTIONS`].
#[derive(Debug, Clone, Args)]
#[command(group(clap::ArgGroup::new("pick").args(["click", "points", "points_3d"])))]
pub struct FocusArgs {
    #[command(flatten)]
    pub keyboard: PlaneArgs,
    /// Single click: the plane through pixel U,V of the depth map's view (normally the centre
    /// view) with the surface normal there (local PCA of the depth map).
    #[arg(long, value_name = "U,V")]
    pub click: Option<String>,
    /// Three clicks: the plane through three pixels of the depth map's view.
    #[arg(long, value_name = "U1,V1,U2,V2,U3,V3")]
    pub points: Option<String>,
    /// The plane through three world points.
    #[arg(
        long = "points-3d",
        value_name = "X1,Y1,Z1,X2,Y2,Z2,X3,Y3,Z3",
        allow_hyphen_values = true
    )]
    pub points_3d: Option<String>,
    /// After --click/--points/--points-3d: add DZ to the plane's distance along the reference
    /// optical axis (world units).
    #[arg(long, value_name = "DZ", requires = "pick", allow_hyphen_values = true)]
    pub nudge_distance: Option<f64>,
    /// After --click/--points/--points-3d: add DEG to the plane's tilt (as --tilt).
    #[arg(
        long,
        value_name = "DEG",
        requires = "pick",
        allow_hyphen_values = true
    )]
    pub nudge_tilt: Option<f64>,
    /// After --click/--points/--points-3d: add DEG to the plane's swing (as --swing).
    #[arg(
        long,
        value_name = "DEG",
        requires = "pick",
        allow_hyphen_values = true
    )]
    pub nudge_swing: Option<f64>,
    /// Side of the image window (odd, pixels) of the --click normal estimate; default 9 on a
    /// depth map the light field carries, 31 on depth estimated from its views (noisier).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub normal_window: Option<u32>,
    /// How the --click normal is fitted: inverse-depth (a plane fitted to 1/z, the default)
    /// or pca (the paper's Hoppe normals).
    #[arg(long, value_name = "METHOD", default_value = "inverse-depth")]
    pub normal_method: NormalMethod,
}

pub use crate::geometry::normals::GIVEN_DEPTH_WINDOW;

impl FocusArgs {
    /// True when any focus option is given.
    pub fn any(&self) -> bool {
        !self.keyboard.disparity.is_empty()
            || !self.keyboard.plane.is_empty()
            || !self.keyboard.focus.is_empty()
            || self.click.is_some()
            || self.points.is_some()
            || self.points_3d.is_some()
    }

    /// The nudge, when any `--nudge-*` is given.
    pub fn nudge(&self) -> Option<Nudge> {
        if self.nudge_distance.is_none() && self.nudge_tilt.is_none() && self.nudge_swing.is_none()
        {
            return None;
        }
        Some(Nudge {
            distance: self.nudge_distance.unwrap_or(0.0),
            tilt_deg: self.nudge_tilt.unwrap_or(0.0),
            swing_deg: self.nudge_swing.unwrap_or(0.0),
        })
    }

    /// The focus request these options give (parsing only), or `None` when no focus option
    /// is given; a click's window defaults to `GIVEN_DEPTH_WINDOW`.
    pub fn request(&self) -> Result<Option<FocusRequest>> {
        self.request_with_window(GIVEN_DEPTH_WINDOW)
    }

    /// [`FocusArgs::request`] with `default_window` for a click's normal (one plane: a
    /// plane form given several times is refused, [`FocusOptions::one_spec`]).
    pub fn request_with_window(&self, default_window: u32) -> Result<Option<FocusRequest>> {
        self.keyboard.spec()?;
        self.request_of_first(default_window)
    }

    /// [`FocusArgs::request_with_window`] that takes a plane form several times (a focus
    /// surface, [`FocusOptions::surface`]) and focuses on the first.
    pub fn request_of_first(&self, default_window: u32) -> Result<Option<FocusRequest>> {
        self.options()?.request(default_window)
    }

    /// The options as numbers for the library ([`FocusOptions`]); parsing only.
    pub fn options(&self) -> Result<FocusOptions> {
        let pixels = |v: Vec<f64>| {
            [
                DVec2::new(v[0], v[1]),
                DVec2::new(v[2], v[3]),
                DVec2::new(v[4], v[5]),
            ]
        };
        Ok(FocusOptions {
            click: self
                .click
                .as_deref()
                .map(|t| parse_numbers(t, 2, "--click").map(|v| DVec2::new(v[0], v[1])))
                .transpose()?,
            points: self
                .points
                .as_deref()
                .map(|t| parse_numbers(t, 6, "--points").map(pixels))
                .transpose()?,
            points_3d: self
                .points_3d
                .as_deref()
                .map(|t| {
                    parse_numbers(t, 9, "--points-3d").map(|v| {
                        [
                            DVec3::new(v[0], v[1], v[2]),
                            DVec3::new(v[3], v[4], v[5]),
                            DVec3::new(v[6], v[7], v[8]),
                        ]
                    })
                })
                .transpose()?,
            nudge: self.nudge(),
            normal_window: self.normal_window,
            normal_method: self.normal_method,
            ..self.keyboard.options()?
        })
    }

    /// The focus of these options on `lf` for the reference view `reference` (grid units), or
    /// `None` when no focus option is given.
    pub fn resolve(
        &self,
        lf: &LightField,
        reference: DVec2,
        default_window: u32,
    ) -> Result<Option<ResolvedFocus>> {
        self.request_with_window(default_window)?
            .map(|req| resolve_focus(lf, &req, reference))
            .transpose()
    }
}

/// One human-readable line about a pick (`None` for the plain options).
pub fn focus_summary(focus: &ResolvedFocus) -> Option<String> {
    let pick = focus.pick.as_ref()?;
    let p = pick.plane;
    let mut s = format!(
        "{}{} → plane through ({:.4}, {:.4}, {:.4}) with normal ({:.4}, {:.4}, {:.4}), \
         confidence {:.3}",
        focus.how,
        match pick.pixels.as_slice() {
            [] => String::new(),
            px => format!(
                " at {}",
                px.iter()
                    .map(|(x, y)| format!("({x}, {y})"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        },
        p.point.x,
        p.point.y,
        p.point.z,
        p.normal.x,
        p.normal.y,
        p.normal.z,
        pick.confidence
    );
    if let Some(n) = &pick.nudge {
        s.push_str(&format!(
            "; nudged from distance {:.4}, tilt {:.2}°, swing {:.2}° to {:.4}, {:.2}°, {:.2}°",
            n.before.distance,
            n.before.tilt_deg,
            n.before.swing_deg,
            n.after.distance,
            n.after.tilt_deg,
            n.after.swing_deg
        ));
    }
    Some(s)
}
