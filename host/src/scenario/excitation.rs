//! `[excitation]`: the sine sweep.
use super::*;

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExcitationSpec {
    /// Voltage amplitude `u_hat` [V].
    pub voltage_v: f64,
    pub eta_start: f64,
    pub eta_end: f64,
    /// The paper's `r`: `dOmega/dt = r omega0^2/(2 pi)`.
    pub rate_per_pseudo_period: f64,
}

impl Default for ExcitationSpec {
    fn default() -> Self {
        Self {
            voltage_v: 10.0,
            eta_start: 0.8,
            eta_end: 1.8,
            rate_per_pseudo_period: 0.02,
        }
    }
}

impl ExcitationSpec {
    /// Check the sweep; the error names the key.
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        let e = self;
        // 0 V (or -0.0) has no response: every ratio (force drop) would be 0/0
        if !(e.voltage_v.is_finite() && e.voltage_v > 0.0) {
            return Err(bad(
                "excitation.voltage_v",
                format!("expected a finite voltage > 0, got {}", e.voltage_v),
            ));
        }
        for (key, eta) in [
            ("excitation.eta_start", e.eta_start),
            ("excitation.eta_end", e.eta_end),
        ] {
            eta_in_range(key, eta)?;
        }
        if e.eta_start == e.eta_end {
            return Err(bad(
                "excitation.eta_end",
                format!("expected eta_end != eta_start (both {})", e.eta_start),
            ));
        }
        let r = e.rate_per_pseudo_period;
        if !(r.is_finite() && r >= MIN_RATE_PER_PSEUDO_PERIOD) {
            return Err(bad(
                "excitation.rate_per_pseudo_period",
                format!(
                    "expected a rate >= {MIN_RATE_PER_PSEUDO_PERIOD:e} (the sweep lasts |eta_end - eta_start| / r pseudo periods), got {r:e}"
                ),
            ));
        }
        Ok(())
    }
}
