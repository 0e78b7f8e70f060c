//! `[hb]` (method `hb`): the harmonic balance of the full model with every
//! attachment condensed per harmonic (`nlmode::hb`, docs/hb.md).
use super::*;

/// What the `hb` continuation holds along the curve (`[hb] control`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum HbControl {
    /// Every exciter at its voltage and phase (the sweep's level).
    #[default]
    Voltage,
    /// The fundamental force of the first exciter held at
    /// `force_amplitude_n` (a force-controlled stepped-sine test).
    Force,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct HbSpec {
    /// Harmonic order `H` (1..=64).
    pub harmonics: usize,
    /// AFT samples per period (default `4H+1`, exact for cubic laws).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// Initial scaled arc-length step, `(0, 1]`.
    pub ds: f64,
    /// Smallest and largest step (defaults `ds / 50`, `5 ds`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dsmin: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dsmax: Option<f64>,
    /// Largest number of points per branch.
    pub max_points: usize,
    /// Newton tolerance on the scaled residual.
    pub tolerance: f64,
    /// Floquet exponents by Hill's method at every point, and the
    /// Neimark-Sacker points.
    pub stability: bool,
    /// Harmonics of the Hill matrix, `1..=harmonics` (default `harmonics`):
    /// fewer is faster, the exponents less accurate (docs/hb.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stability_harmonics: Option<usize>,
    /// `"condensed"` (default) or `"full"`: how Hill's problem is solved.
    pub hill: nlmode::hb::HillMethod,
    /// Seed further branches (isolas) from every solution of the single-mode
    /// steady state (`host frf`) at frequencies where it has several.
    pub seeds: bool,
    pub control: HbControl,
    /// `control = "force"`: the held fundamental force amplitude [N].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_amplitude_n: Option<f64>,
}

impl Default for HbSpec {
    fn default() -> Self {
        let o = nlmode::hb::HbOptions::default();
        Self {
            harmonics: o.harmonics,
            samples: o.samples,
            ds: o.ds,
            dsmin: o.dsmin,
            dsmax: o.dsmax,
            max_points: o.max_points,
            tolerance: o.tolerance,
            stability: o.stability,
            stability_harmonics: o.stability_harmonics,
            hill: o.hill,
            seeds: true,
            control: HbControl::Voltage,
            force_amplitude_n: None,
        }
    }
}

impl HbSpec {
    /// The library's options over `[omega_start, omega_end]` rad/s.
    pub fn options(&self, omega_start_rad_s: f64, omega_end_rad_s: f64) -> nlmode::hb::HbOptions {
        nlmode::hb::HbOptions {
            harmonics: self.harmonics,
            samples: self.samples,
            omega_start_rad_s,
            omega_end_rad_s,
            ds: self.ds,
            dsmin: self.dsmin,
            dsmax: self.dsmax,
            max_points: self.max_points,
            tolerance: self.tolerance,
            stability: self.stability,
            stability_harmonics: self.stability_harmonics,
            hill: self.hill,
            bifurcations: true,
            control: match self.control {
                HbControl::Voltage => nlmode::hb::Control::Voltage,
                HbControl::Force => nlmode::hb::Control::Force {
                    column: 0,
                    amplitude_n: self.force_amplitude_n.unwrap_or(f64::NAN),
                },
            },
            ..Default::default()
        }
    }

    /// Check the options (by the library's own bounds); the error names the key.
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        match (self.control, self.force_amplitude_n) {
            (HbControl::Force, None) => {
                return Err(bad(
                    "hb.force_amplitude_n",
                    "missing: control = \"force\" holds this fundamental force amplitude [N]",
                ))
            }
            (HbControl::Voltage, Some(_)) => {
                return Err(bad("hb.force_amplitude_n", "only with control = \"force\""))
            }
            (_, Some(f)) => positive("hb.force_amplitude_n", f)?,
            _ => {}
        }
        // the frequency range is the sweep's, checked with [excitation]
        self.options(1.0, 2.0).validate().map_err(|e| match e {
            nlmode::hb::HbError::BadOption {
                name,
                value,
                expected,
            } => bad(
                &format!("hb.{name}"),
                format!("expected {expected}, got {value}"),
            ),
            other => bad("hb", other.to_string()),
        })
    }
}
