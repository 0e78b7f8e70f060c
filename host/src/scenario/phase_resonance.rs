//! `[phase_resonance]` (method `phase-resonance`).
use super::*;

// ---- [phase_resonance] (method `phase-resonance`) ----

/// The model the phase-resonance test runs on (`phase_resonance.model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PhaseResonanceModel {
    /// The full-order assembly with the shaker, integrated period by period.
    #[default]
    Reference,
    /// The slow flow of `eq:NM` with the shakers (the loop sees its fundamental).
    Nlmode,
    /// The structure, shaker and controller FMUs co-simulated
    /// (`host/src/methods/phase_resonance/cosim.rs`).
    Cosim,
}

impl PhaseResonanceModel {
    /// The spelling in scenarios.
    pub fn name(self) -> &'static str {
        match self {
            PhaseResonanceModel::Reference => "reference",
            PhaseResonanceModel::Nlmode => "nlmode",
            PhaseResonanceModel::Cosim => "cosim",
        }
    }
}

/// The default voltage levels \[V\]: the paper beam at 2l/3 from the linear
/// range (0.5 V: |q_tip,1| = 0.14 mm, omega = 1.001 omega0) along the backbone
/// to 40 V (|q_tip,1| = 5.0 mm, omega = 1.93 omega0), below the loop of the
/// 1:3 internal resonance with mode 2 (omega near 2.09 omega0).
pub const DEFAULT_VOLTAGE_LEVELS_V: [f64; 12] = [
    0.5, 1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 14.0, 20.0, 25.0, 32.0, 40.0,
];

/// `[phase_resonance]`: the phase-locked-loop test (docs/scenario.md).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct PhaseResonanceSpec {
    pub model: PhaseResonanceModel,
    /// Voltage amplitudes, in the order they are applied \[V\].
    pub voltage_levels_v: Vec<f64>,
    /// Start frequency of the loop, in units of omega0 (default 1).
    pub eta_start: f64,
    /// Samples per excitation period (demodulation and largest step; default 40).
    pub samples_per_period: usize,
    /// Loop tuning and settle criterion ([`nlmode::control::PllOptions`]).
    pub pll: nlmode::control::PllOptions,
}

impl Default for PhaseResonanceSpec {
    fn default() -> Self {
        Self {
            model: PhaseResonanceModel::Reference,
            voltage_levels_v: DEFAULT_VOLTAGE_LEVELS_V.to_vec(),
            eta_start: 1.0,
            samples_per_period: 40,
            pll: nlmode::control::PllOptions::default(),
        }
    }
}

impl PhaseResonanceSpec {
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        if self.voltage_levels_v.is_empty() {
            return Err(bad(
                "phase_resonance.voltage_levels_v",
                "expected a non-empty list of voltage amplitudes",
            ));
        }
        for (i, v) in self.voltage_levels_v.iter().enumerate() {
            positive(&format!("phase_resonance.voltage_levels_v[{i}]"), *v)?;
        }
        eta_in_range("phase_resonance.eta_start", self.eta_start)?;
        if !(8..=1000).contains(&self.samples_per_period) {
            return Err(bad(
                "phase_resonance.samples_per_period",
                format!("expected 8 ..= 1000, got {}", self.samples_per_period),
            ));
        }
        // 2 (H + 1) <= N, written so that no H overflows (9223372036854775807)
        if self.pll.harmonics > self.samples_per_period / 2 - 1 {
            return Err(bad(
                "phase_resonance.pll.harmonics",
                format!(
                    "expected at most samples_per_period / 2 - 1 = {}, got {}",
                    self.samples_per_period / 2 - 1,
                    self.pll.harmonics
                ),
            ));
        }
        self.pll.validate().map_err(|e| match e {
            nlmode::control::ControlError::BadOption {
                name,
                value,
                expected,
            } => bad(
                &format!("phase_resonance.pll.{name}"),
                format!("expected {expected}, got {value}"),
            ),
            other => bad("phase_resonance.pll", other.to_string()),
        })
    }
}
