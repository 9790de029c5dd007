//! Synthetic aperture weights over the camera grid, centred on the (possibly fractional)
//! reference view (s_r, t_r). Distances are in grid steps.
//!
//! - `disk`: weight 1 when √(Δs² + Δt²) ≤ R, else 0. Default R: unbounded (all views).
//! - `square`: weight 1 when max(|Δs|, |Δt|) ≤ R, else 0. Default R: unbounded.
//! - `gaussian`: weight exp(−(Δs² + Δt²) / (2σ²)) with σ = R, cut off beyond 3σ where weights
//!   fall below 1.1 % and views only cost time. Default σ: half the larger grid extent, so the
//!   outermost views of the grid sit at about 1σ.
//!
//! A small tolerance (1e-9 grid steps) keeps views exactly on the rim inside despite rounding.

use glam::DVec2;

use crate::error::{Error, Result};

/// Aperture shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ApertureShape {
    Disk,
    Square,
    Gaussian,
}

impl std::str::FromStr for ApertureShape {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "disk" => Ok(Self::Disk),
            "square" => Ok(Self::Square),
            "gaussian" => Ok(Self::Gaussian),
            _ => Err(Error::Invalid(format!(
                "unknown aperture '{s}': expected disk, square or gaussian"
            ))),
        }
    }
}

/// A synthetic aperture: shape and radius in grid steps (`None` = the default of the shape).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Aperture {
    pub shape: ApertureShape,
    pub radius: Option<f64>,
}

impl Default for Aperture {
    fn default() -> Self {
        Aperture {
            shape: ApertureShape::Disk,
            radius: None,
        }
    }
}

const RIM: f64 = 1e-9;

impl Aperture {
    /// Checks the radius.
    pub fn validate(&self) -> Result<()> {
        if let Some(r) = self.radius {
            if !(r.is_finite() && r >= 0.0) {
                return Err(Error::Invalid(format!(
                    "--aperture-radius (the aperture radius) must be a finite number ≥ 0 (grid \
                     steps), got {}",
                    crate::error::compact(r)
                )));
            }
            if self.shape == ApertureShape::Gaussian && r == 0.0 {
                return Err(Error::Invalid(
                    "a gaussian aperture needs a radius (σ) > 0".into(),
                ));
            }
        }
        Ok(())
    }

    /// Weight of the view at grid position `view` for an aperture centred on `centre`, in a grid
    /// of `cols × rows` views.
    pub fn weight(&self, view: DVec2, centre: DVec2, cols: usize, rows: usize) -> f64 {
        let d = view - centre;
        match self.shape {
            ApertureShape::Disk => {
                let r = self.radius.unwrap_or(f64::INFINITY);
                f64::from(d.length() <= r + RIM)
            }
            ApertureShape::Square => {
                let r = self.radius.unwrap_or(f64::INFINITY);
                f64::from(d.x.abs().max(d.y.abs()) <= r + RIM)
            }
            ApertureShape::Gaussian => {
                let extent = (cols.max(rows) as f64 - 1.0) / 2.0;
                let sigma = self.radius.unwrap_or(extent.max(0.5));
                if d.length() > 3.0 * sigma + RIM {
                    0.0
                } else {
                    // (|d| / σ)² rather than |d|² / σ²: σ² underflows to 0 for tiny radii,
                    // and 0/0 would give the centre view a NaN weight instead of 1.
                    let x = d.length() / sigma;
                    (-0.5 * x * x).exp()
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(a: Aperture, centre: DVec2, n: usize) -> usize {
        let mut k = 0;
        for t in 0..n {
            for s in 0..n {
                if a.weight(DVec2::new(s as f64, t as f64), centre, n, n) > 0.0 {
                    k += 1;
                }
            }
        }
        k
    }

    #[test]
    fn default_apertures_use_every_view() {
        let c = DVec2::new(4.0, 4.0);
        for shape in [
            ApertureShape::Disk,
            ApertureShape::Square,
            ApertureShape::Gaussian,
        ] {
            assert_eq!(
                count(
                    Aperture {
                        shape,
                        radius: None
                    },
                    c,
                    9
                ),
                81,
                "{shape:?}"
            );
        }
    }

    #[test]
    fn disk_and_square_select_the_expected_views() {
        let c = DVec2::new(4.0, 4.0);
        let disk = Aperture {
            shape: ApertureShape::Disk,
            radius: Some(1.0),
        };
        assert_eq!(count(disk, c, 9), 5);
        let square = Aperture {
            shape: ApertureShape::Square,
            radius: Some(1.0),
        };
        assert_eq!(count(square, c, 9), 9);
        let disk0 = Aperture {
            shape: ApertureShape::Disk,
            radius: Some(0.0),
        };
        assert_eq!(count(disk0, c, 9), 1);
        assert_eq!(
            count(disk0, DVec2::new(4.5, 4.0), 9),
            0,
            "radius 0 between views is empty"
        );
    }

    #[test]
    fn gaussian_decays_and_is_cut_at_three_sigma() {
        let g = Aperture {
            shape: ApertureShape::Gaussian,
            radius: Some(1.0),
        };
        let c = DVec2::ZERO;
        let w0 = g.weight(DVec2::ZERO, c, 9, 9);
        let w1 = g.weight(DVec2::new(1.0, 0.0), c, 9, 9);
        assert!((w0 - 1.0).abs() < 1e-15);
        assert!((w1 - (-0.5f64).exp()).abs() < 1e-15);
        assert_eq!(g.weight(DVec2::new(3.1, 0.0), c, 9, 9), 0.0);
    }

    #[test]
    fn bad_radius_is_refused() {
        assert!(Aperture {
            shape: ApertureShape::Disk,
            radius: Some(-1.0)
        }
        .validate()
        .is_err());
        assert!(Aperture {
            shape: ApertureShape::Disk,
            radius: Some(f64::NAN)
        }
        .validate()
        .is_err());
        assert!(Aperture {
            shape: ApertureShape::Gaussian,
            radius: Some(0.0)
        }
        .validate()
        .is_err());
        assert!(Aperture {
            shape: ApertureShape::Square,
            radius: Some(2.0)
        }
        .validate()
        .is_ok());
    }
}
