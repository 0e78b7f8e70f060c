//! `[imposed_force]` (method `imposed-force`).
use super::*;

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImposedForceSpec {
    /// Where the imposed force envelope comes from: a method of this run
    /// (`nlmode`, `reference`) or a CSV file (columns `omega_rad_s`,
    /// `force_amplitude_N`, `force_phase_rad`).
    pub source: ForceSource,
    /// Relative natural-frequency error `eps`: omega(a) -> (1 + eps) omega(a).
    pub frequency_error: f64,
    /// Additive natural-frequency offset [rad/s].
    pub frequency_offset_rad_s: f64,
    /// Additive natural-frequency offset as a fraction of omega0 (the paper's
    /// "+5 %" amplitude-independent offset is 0.05); added to `frequency_offset_rad_s`.
    pub frequency_offset_omega0: f64,
    /// Apply the same frequency error to `nlmode` (the paper's "NM with shaker, +5 %").
    pub apply_to_nlmode: bool,
}

/// Source of the imposed force envelope (`imposed_force.source`): `"nlmode"`,
/// `"reference"` or the path of a CSV file.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, Serialize)]
#[serde(from = "String", into = "String")]
pub enum ForceSource {
    /// The drive-point force of `nlmode` of this run.
    Nlmode,
    /// The windowed force envelope of `reference` of this run.
    Reference,
    /// A CSV file in the `<method>_envelope.csv` format.
    Csv(PathBuf),
}

impl From<String> for ForceSource {
    fn from(s: String) -> Self {
        match s.as_str() {
            "nlmode" => ForceSource::Nlmode,
            "reference" => ForceSource::Reference,
            _ => ForceSource::Csv(s.into()),
        }
    }
}

impl From<ForceSource> for String {
    fn from(s: ForceSource) -> Self {
        match s {
            ForceSource::Nlmode => "nlmode".into(),
            ForceSource::Reference => "reference".into(),
            ForceSource::Csv(p) => p.display().to_string(),
        }
    }
}

impl Default for ImposedForceSpec {
    fn default() -> Self {
        Self {
            source: ForceSource::Nlmode,
            frequency_error: 0.0,
            frequency_offset_rad_s: 0.0,
            frequency_offset_omega0: 0.0,
            apply_to_nlmode: false,
        }
    }
}

impl ImposedForceSpec {
    /// Check the imposed force's options.
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        if !self.frequency_error.is_finite() || self.frequency_error <= -1.0 {
            return Err(bad(
                "imposed_force.frequency_error",
                "expected a finite number > -1",
            ));
        }
        for (k, v) in [
            (
                "imposed_force.frequency_offset_rad_s",
                self.frequency_offset_rad_s,
            ),
            (
                "imposed_force.frequency_offset_omega0",
                self.frequency_offset_omega0,
            ),
        ] {
            if !v.is_finite() {
                return Err(bad(k, format!("expected a finite number, got {v}")));
            }
        }
        if let ForceSource::Csv(p) = &self.source {
            if p.as_os_str().is_empty() {
                return Err(bad(
                    "imposed_force.source",
                    "expected \"nlmode\", \"reference\" or the path of a CSV file, got \"\"",
                ));
            }
        }
        Ok(())
    }
}
