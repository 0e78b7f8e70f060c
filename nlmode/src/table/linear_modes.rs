//! The structure's other linear modes stored in a modal table (`linear_modes`),
//! for residual modes ([`crate::reduced::ResidualModes`]).
use super::{PointShape, TableError};
use serde::{Deserialize, Serialize};

/// Linear modes of the structure other than the one the nonlinear mode
/// continues (mass-normalised, ascending frequency): what residual modes
/// are made of ([`crate::reduced::ResidualModes`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearModes {
    /// Natural frequencies `omega_r` \[rad/s\], ascending.
    pub omega_rad_s: Vec<f64>,
    /// Modal damping ratios `zeta_r = (Phi^T C Phi)_rr / (2 omega_r)` \[-\]
    /// (the diagonal of the modal damping matrix).
    pub damping_ratio: Vec<f64>,
    /// Mass-normalised shapes at the table's points (`shape[r]`, mode `r`)
    /// \[m / (sqrt(kg) m)\]; the same names as [`ModalTable::points`].
    pub points: Vec<LinearModeShape>,
}

/// The linear modes' shapes at one named point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearModeShape {
    pub name: String,
    /// Shape of each mode at the point, in the order of [`LinearModes::omega_rad_s`].
    pub shape: Vec<f64>,
}

/// Most linear modes a table stores ([`LinearModes`]): residual modes beyond
/// this many add nothing a quasi-static term would not (their frequencies are
/// far above any band a single nonlinear mode describes).
pub const MAX_LINEAR_MODES: usize = 50;

/// Largest natural frequency of a stored linear mode \[rad/s\] (far above any
/// structural mode; bounds `omega^2 zeta^2` in the residual modes' exact
/// stepping, so that no input overflows it to NaN).
pub const MAX_OMEGA_RAD_S: f64 = 1e9;
/// Largest damping ratio of a stored linear mode (an over-damped mode beyond it
/// is a static flexibility; the bound keeps the stepping finite).
pub const MAX_DAMPING_RATIO: f64 = 1e3;

impl LinearModes {
    /// Number of modes.
    pub fn len(&self) -> usize {
        self.omega_rad_s.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.omega_rad_s.is_empty()
    }

    /// Lengths, finiteness, positive ascending frequencies, non-negative
    /// damping, one shape per table point.
    pub fn validate(&self, points: &[PointShape]) -> Result<(), TableError> {
        let n = self.len();
        let len = |field: String, got: usize| {
            if got != n {
                Err(TableError::Length {
                    field,
                    got,
                    expected: n,
                })
            } else {
                Ok(())
            }
        };
        len(
            "linear_modes.damping_ratio".into(),
            self.damping_ratio.len(),
        )?;
        let bad = |field: &str, index: usize, value: f64, positive: &'static str| {
            Err(TableError::BadValue {
                field: field.into(),
                index,
                value,
                positive,
            })
        };
        for (r, &w) in self.omega_rad_s.iter().enumerate() {
            let prev = if r == 0 { 0.0 } else { self.omega_rad_s[r - 1] };
            if !(w.is_finite() && w > 0.0 && w >= prev && w <= MAX_OMEGA_RAD_S) {
                return bad(
                    "linear_modes.omega_rad_s (ascending)",
                    r,
                    w,
                    " positive (at most 1e9 rad/s)",
                );
            }
        }
        for (r, &z) in self.damping_ratio.iter().enumerate() {
            if !(z.is_finite() && (0.0..=MAX_DAMPING_RATIO).contains(&z)) {
                return bad(
                    "linear_modes.damping_ratio",
                    r,
                    z,
                    " non-negative (at most 1e3)",
                );
            }
        }
        if self.points.len() != points.len()
            || self
                .points
                .iter()
                .zip(points)
                .any(|(l, p)| l.name != p.name)
        {
            return Err(TableError::Length {
                field: "linear_modes.points (the table's points, same names and order)".into(),
                got: self.points.len(),
                expected: points.len(),
            });
        }
        for p in &self.points {
            len(
                format!("linear_modes.points[{}].shape", p.name),
                p.shape.len(),
            )?;
            if let Some((r, v)) = p.shape.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return bad(&format!("linear_modes.points[{}].shape", p.name), r, *v, "");
            }
        }
        Ok(())
    }
}
