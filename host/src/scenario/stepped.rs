//! `[force_control]`, `[response_control]` (methods `force-controlled`, `response-controlled`).
use super::*;

/// Most frequency steps of a controlled stepped sine, and most response levels.
pub const MAX_CONTROL_STEPS: usize = 2000;
/// Most response levels of `[response_control]`.
pub const MAX_RESPONSE_LEVELS: usize = 50;
/// Most periods per step of a controlled stepped sine.
pub const MAX_PERIODS_PER_STEP: usize = 1_000_000;

/// Default set value of `[force_control] force_set_n` \[N\].
pub const DEFAULT_FORCE_SET_N: f64 = 0.1;
/// Default set values of `[response_control] response_levels_m` \[m\].
pub const DEFAULT_RESPONSE_LEVELS_M: [f64; 3] = [1e-4, 3e-4, 6e-4];

/// `[force_control]` (method `force-controlled`, the force-controlled stepped
/// sine) and `[response_control]` (method `response-controlled`, one stepped
/// sine per response level): the frequency steps, model and controller they
/// share, and the set value of each (every key of both sections is read into
/// this one table; [`SteppedSpec::validate`] rejects the other section's set
/// value by name).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SteppedSpec {
    /// `[force_control]` only: set value of the force fundamental at the
    /// structure \[N\] (default [`DEFAULT_FORCE_SET_N`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_set_n: Option<f64>,
    /// `[response_control]` only: set values of the drive-point response
    /// amplitude \[m\] (default [`DEFAULT_RESPONSE_LEVELS_M`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub response_levels_m: Option<Vec<f64>>,
    /// `reference` or `nlmode` (`cosim` is refused).
    pub model: PhaseResonanceModel,
    /// First and last frequency, in units of omega0 (defaults 0.9, 1.1).
    pub eta_start: f64,
    pub eta_end: f64,
    /// Number of frequency steps, uniform in `Omega` (default 21).
    pub steps: usize,
    /// Voltage amplitude of the first step \[V\] (default 0.5).
    pub voltage_start_v: f64,
    /// Samples per excitation period (default 40).
    pub samples_per_period: usize,
    /// Tolerances and limits ([`nlmode::control::ForceControlOptions`]).
    pub control: nlmode::control::ForceControlOptions,
}

/// `[force_control]`: [`SteppedSpec`] with `force_set_n`.
pub type ForceControlSpec = SteppedSpec;
/// `[response_control]`: [`SteppedSpec`] with `response_levels_m`.
pub type ResponseControlSpec = SteppedSpec;

impl Default for SteppedSpec {
    fn default() -> Self {
        Self {
            force_set_n: None,
            response_levels_m: None,
            model: PhaseResonanceModel::Reference,
            eta_start: 0.9,
            eta_end: 1.1,
            steps: 21,
            voltage_start_v: 0.5,
            samples_per_period: 40,
            control: nlmode::control::ForceControlOptions::default(),
        }
    }
}

/// The two sections of [`SteppedSpec`] and the set-value key each has.
const STEPPED_SECTIONS: [(&str, &str); 2] = [
    ("force_control", "force_set_n"),
    ("response_control", "response_levels_m"),
];

impl SteppedSpec {
    /// `[force_control] force_set_n` \[N\], or its default.
    pub fn force_set_n(&self) -> f64 {
        self.force_set_n.unwrap_or(DEFAULT_FORCE_SET_N)
    }

    /// `[response_control] response_levels_m` \[m\], or their default.
    pub fn response_levels_m(&self) -> &[f64] {
        self.response_levels_m
            .as_deref()
            .unwrap_or(&DEFAULT_RESPONSE_LEVELS_M)
    }

    /// Checks the section `section` (`force_control` or `response_control`):
    /// its set value, no set value of the other section, and the shared keys.
    pub(crate) fn validate(&self, section: &str) -> Result<(), ScenarioError> {
        let set_value = |name: &str| match name {
            "force_set_n" => self.force_set_n.is_some(),
            _ => self.response_levels_m.is_some(),
        };
        for (other, key) in STEPPED_SECTIONS {
            if other != section && set_value(key) {
                return Err(bad(
                    &format!("{section}.{key}"),
                    format!("not a key of [{section}] (it belongs to [{other}])"),
                ));
            }
        }
        if section == "force_control" {
            positive("force_control.force_set_n", self.force_set_n())?;
        } else {
            let levels = self.response_levels_m();
            let n = levels.len();
            if n == 0 || n > MAX_RESPONSE_LEVELS {
                return Err(bad(
                    "response_control.response_levels_m",
                    format!("expected 1 ..= {MAX_RESPONSE_LEVELS} response amplitudes, got {n}"),
                ));
            }
            for (i, v) in levels.iter().enumerate() {
                positive(&format!("response_control.response_levels_m[{i}]"), *v)?;
            }
        }
        eta_in_range(&format!("{section}.eta_start"), self.eta_start)?;
        eta_in_range(&format!("{section}.eta_end"), self.eta_end)?;
        if !(2..=MAX_CONTROL_STEPS).contains(&self.steps) {
            return Err(bad(
                &format!("{section}.steps"),
                format!("expected 2 ..= {MAX_CONTROL_STEPS}, got {}", self.steps),
            ));
        }
        positive(&format!("{section}.voltage_start_v"), self.voltage_start_v)?;
        if !(8..=1000).contains(&self.samples_per_period) {
            return Err(bad(
                &format!("{section}.samples_per_period"),
                format!("expected 8 ..= 1000, got {}", self.samples_per_period),
            ));
        }
        let c = &self.control;
        // 2 (H + 1) <= N, written so that no H overflows (9223372036854775807)
        if c.harmonics > self.samples_per_period / 2 - 1 {
            return Err(bad(
                &format!("{section}.control.harmonics"),
                format!(
                    "expected at most samples_per_period / 2 - 1 = {}, got {}",
                    self.samples_per_period / 2 - 1,
                    c.harmonics
                ),
            ));
        }
        for (name, v) in [
            ("settle_periods", c.settle_periods),
            ("max_periods_per_step", c.max_periods_per_step),
        ] {
            if v > MAX_PERIODS_PER_STEP {
                return Err(bad(
                    &format!("{section}.control.{name}"),
                    format!("expected at most {MAX_PERIODS_PER_STEP}, got {v}"),
                ));
            }
        }
        c.validate().map_err(|e| match e {
            nlmode::control::ControlError::BadOption {
                name,
                value,
                expected,
            } => bad(
                &format!("{section}.control.{name}"),
                format!("expected {expected}, got {value}"),
            ),
            other => bad(&format!("{section}.control"), other.to_string()),
        })
    }
}
