//! A depth estimate as a front end asks for it (the `tiltfield depth` options, the Python
//! module's `LightField.depth` keywords), checked into [`DepthOptions`] in one place so that
//! both report a bad value in the same words.

use super::{Aggregation, CostKind, DepthKind, DepthOptions, SweepParams, ViewSet};
use crate::error::{Error, Result};

/// Parses a `--kind`: `disparity` or `depth`.
pub fn parse_kind(text: &str) -> Result<DepthKind> {
    match text {
        "disparity" => Ok(DepthKind::Disparity),
        "depth" => Ok(DepthKind::Depth),
        _ => Err(Error::Invalid(format!(
            "unknown --kind '{text}': expected disparity or depth"
        ))),
    }
}

/// The options of an estimate, as given; `None` takes the default.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthRequest {
    /// The output's kind; also the units of `range` (default disparity).
    pub kind: Option<DepthKind>,
    pub planes: Option<usize>,
    pub range: Option<(f64, f64)>,
    pub views: ViewSet,
    /// Reference view S,T: whole grid positions.
    pub reference: Option<(f64, f64)>,
    pub cost: Option<CostKind>,
    pub aggregation: Option<Aggregation>,
    pub radius: Option<u32>,
    /// The naive baseline (SAD with box aggregation); excludes `cost` and `aggregation`.
    pub naive: bool,
    /// Skip the continuous fit after the sweep.
    pub no_fit: bool,
    /// Leave depth edges where the windows put them (no [`crate::depth::edges`] step).
    pub no_snap: bool,
    /// Skip the global refinement after the fit ([`crate::depth::smooth`]).
    pub no_smooth: bool,
    /// Skip the plane fill after the refinement ([`crate::depth::plane_fill`]).
    pub no_plane_fill: bool,
    /// Radius of the colour-weighted median (0: none; default: the params').
    pub median: Option<u32>,
    pub include_dark: bool,
}

impl Default for DepthRequest {
    fn default() -> Self {
        DepthRequest {
            kind: None,
            planes: None,
            range: None,
            views: ViewSet::Cross(usize::MAX),
            reference: None,
            cost: None,
            aggregation: None,
            radius: None,
            naive: false,
            no_fit: false,
            no_snap: false,
            no_smooth: false,
            no_plane_fill: false,
            median: None,
            include_dark: false,
        }
    }
}

impl DepthRequest {
    /// The checked options.
    pub fn options(&self) -> Result<DepthOptions> {
        if self.naive && (self.cost.is_some() || self.aggregation.is_some()) {
            return Err(Error::Invalid(
                "--naive is the SAD cost with box aggregation; give it without --cost and \
                 --aggregation"
                    .into(),
            ));
        }
        let reference = self
            .reference
            .map(|(s, t)| {
                if [s, t]
                    .iter()
                    .any(|x| !x.is_finite() || *x < 0.0 || x.fract() != 0.0 || *x > 1e6)
                {
                    return Err(Error::Invalid(format!(
                        "--view {s},{t}: the reference of a depth estimate is a real view: give \
                         whole grid positions S,T"
                    )));
                }
                Ok((s as usize, t as usize))
            })
            .transpose()?;
        let base = if self.naive {
            SweepParams::baseline()
        } else {
            SweepParams::default()
        };
        let params = SweepParams {
            cost: self.cost.unwrap_or(base.cost),
            aggregation: self.aggregation.unwrap_or(base.aggregation),
            radius: self.radius.unwrap_or(base.radius),
            fit: base.fit && !self.no_fit,
            edge_snap: base.edge_snap && !self.no_snap,
            smooth: base.smooth && !self.no_smooth,
            plane_fill: base.plane_fill && !self.no_plane_fill,
            median_radius: self.median.unwrap_or(base.median_radius),
            ..base
        };
        let options = DepthOptions {
            planes: self.planes,
            range: self.range,
            range_kind: self.kind.unwrap_or(DepthKind::Disparity),
            views: self.views,
            reference,
            params,
            include_dark: self.include_dark,
        };
        options.validate()?;
        Ok(options)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_are_checked_as_the_cli_checks_its_options() {
        let ok = DepthRequest::default().options().unwrap();
        assert_eq!(ok, DepthOptions::default());
        let view = DepthRequest {
            reference: Some((1.5, 2.0)),
            ..DepthRequest::default()
        };
        let e = view.options().unwrap_err().to_string();
        assert!(e.starts_with("--view 1.5,2: the reference"), "{e}");
        let naive = DepthRequest {
            naive: true,
            cost: Some(CostKind::Mean),
            ..DepthRequest::default()
        };
        assert!(naive.options().unwrap_err().to_string().contains("--naive"));
        assert_eq!(
            parse_kind("height").unwrap_err().to_string(),
            "unknown --kind 'height': expected disparity or depth"
        );
        let no_fit = DepthRequest {
            no_fit: true,
            ..DepthRequest::default()
        };
        assert!(!no_fit.options().unwrap().params.fit);
        assert!(no_fit.options().unwrap().params.edge_snap);
        let no_snap = DepthRequest {
            no_snap: true,
            ..DepthRequest::default()
        };
        assert!(!no_snap.options().unwrap().params.edge_snap);
        assert!(DepthRequest::default().options().unwrap().params.edge_snap);
        let no_smooth = DepthRequest {
            no_smooth: true,
            ..DepthRequest::default()
        };
        assert!(!no_smooth.options().unwrap().params.smooth);
        assert!(no_smooth.options().unwrap().params.fit);
        assert!(DepthRequest::default().options().unwrap().params.smooth);
    }
}
