//! `[nma]`: the nonlinear modal analysis feeding the single-mode methods.
use super::*;

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct NmaSpec {
    /// Harmonic order `H` of the modal table (default
    /// [`nlmode::nma::SWEEP_TABLE_HARMONICS`] = 7: agrees with `H = 13` within
    /// the refined table's accuracy up to `a = 2.5e-3`).
    pub harmonics: usize,
    /// Largest tip amplitude |q_tip,1| the NMA continues to [m].
    pub max_tip_amplitude_m: f64,
    /// Modal table to use instead of computing one (JSON, `nlmode-modal-table`).
    pub table: Option<String>,
    /// Compute the conservative branch too (for the backbone plot).
    pub conservative: bool,
}

impl Default for NmaSpec {
    fn default() -> Self {
        Self {
            harmonics: nlmode::nma::SWEEP_TABLE_HARMONICS,
            max_tip_amplitude_m: 0.02,
            table: None,
            conservative: true,
        }
    }
}

impl NmaSpec {
    /// Check the NMA options; the error names the key.
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        if !(1..=64).contains(&self.harmonics) {
            return Err(bad(
                "nma.harmonics",
                format!("expected 1 <= H <= 64, got {}", self.harmonics),
            ));
        }
        let a = self.max_tip_amplitude_m;
        if !(a.is_finite() && a > NMA_START_TIP_AMPLITUDE_M) {
            return Err(bad(
                "nma.max_tip_amplitude_m",
                format!(
                    "expected an amplitude above the NMA's start {NMA_START_TIP_AMPLITUDE_M:e} m, got {a:e}"
                ),
            ));
        }
        Ok(())
    }
}
