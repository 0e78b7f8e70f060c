//! `[cosim]` (method `cosim`).
use super::*;

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct CosimSpec {
    /// Co-simulation master algorithm.
    pub algorithm: CosimAlgorithm,
    /// Macro (communication) step [s].
    pub macro_step_s: f64,
    pub structure_fmu: Option<String>,
    pub shaker_fmu: Option<String>,
    /// The structure FMU's `residual_modes` (its linear modes beside the
    /// nonlinear mode) in `cosim` and `phase-resonance` with `model = "cosim"`.
    pub residual_modes: usize,
    /// The structure FMU's `harmonic_force_projection` (the stinger force
    /// on every harmonic of the mode, `nlmode::oscillator` module
    /// `projection`) in the same methods.
    pub harmonic_force_projection: bool,
}

/// Co-simulation master algorithm (`cosim.algorithm`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CosimAlgorithm {
    /// Both units stepped on the inputs of the last communication point.
    #[default]
    Jacobi,
    /// Units stepped in sequence, each on the new outputs of the one before.
    GaussSeidel,
    /// Quasi-Newton iteration of the coupling with rollback.
    Iterative,
}

impl Default for CosimSpec {
    fn default() -> Self {
        Self {
            algorithm: CosimAlgorithm::Jacobi,
            macro_step_s: 1e-5,
            structure_fmu: None,
            shaker_fmu: None,
            residual_modes: 0,
            harmonic_force_projection: false,
        }
    }
}

impl CosimSpec {
    /// Check the co-simulation options.
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        positive("cosim.macro_step_s", self.macro_step_s)?;
        if self.residual_modes > nlmode::table::MAX_LINEAR_MODES {
            return Err(bad(
                "cosim.residual_modes",
                format!(
                    "expected 0 to {} (the linear modes a modal table carries), got {}",
                    nlmode::table::MAX_LINEAR_MODES,
                    self.residual_modes
                ),
            ));
        }
        Ok(())
    }
}
