//! `[nma]`: the nonlinear modal analysis feeding the single-mode methods.
use super::*;

/// `[nma] harmonics`: a fixed order `H`, or `"auto"` (the smallest `H` whose
/// refined table agrees with that of `H + 4`, [`nlmode::nma::auto_harmonics`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Harmonics {
    Fixed(usize),
    Auto,
}

impl Harmonics {
    /// The fixed order, `None` for `"auto"`.
    pub fn fixed(self) -> Option<usize> {
        match self {
            Harmonics::Fixed(h) => Some(h),
            Harmonics::Auto => None,
        }
    }
}

impl std::fmt::Display for Harmonics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Harmonics::Fixed(h) => write!(f, "{h}"),
            Harmonics::Auto => f.write_str("auto"),
        }
    }
}

impl Serialize for Harmonics {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Harmonics::Fixed(h) => s.serialize_u64(*h as u64),
            Harmonics::Auto => s.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for Harmonics {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Harmonics;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an integer 1 <= H <= 64 or \"auto\"")
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Harmonics, E> {
                usize::try_from(v)
                    .map(Harmonics::Fixed)
                    .map_err(|_| E::custom(format!("expected 1 <= H <= 64, got {v}")))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Harmonics, E> {
                usize::try_from(v)
                    .map(Harmonics::Fixed)
                    .map_err(|_| E::custom(format!("expected 1 <= H <= 64, got {v}")))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Harmonics, E> {
                match v {
                    "auto" => Ok(Harmonics::Auto),
                    _ => Err(E::custom(format!(
                        "expected an integer 1 <= H <= 64 or \"auto\", got \"{v}\""
                    ))),
                }
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct NmaSpec {
    /// Harmonic order `H` of the modal table (default
    /// [`nlmode::nma::SWEEP_TABLE_HARMONICS`] = 7: agrees with `H = 13` within
    /// the refined table's accuracy up to `a = 2.5e-3`), or `"auto"`.
    pub harmonics: Harmonics,
    /// Largest tip amplitude |q_tip,1| the NMA continues to [m].
    pub max_tip_amplitude_m: f64,
    /// Tip amplitude |q_tip,1| the NMA starts from [m] (default
    /// [`NMA_START_TIP_AMPLITUDE_M`]).
    pub start_amplitude_m: f64,
    /// AFT time samples per period (`NmaOptions::samples`; default `4H+1`, 256
    /// with a hysteretic element).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// The linear mode the backbone starts from and the single-mode methods
    /// follow, 1 = the lowest elastic mode (rigid-body modes are skipped).
    pub mode: usize,
    /// Modal table to use instead of computing one (JSON, `nlmode-modal-table`).
    pub table: Option<String>,
    /// Compute the conservative branch too (for the backbone plot).
    pub conservative: bool,
}

impl Default for NmaSpec {
    fn default() -> Self {
        Self {
            harmonics: Harmonics::Fixed(nlmode::nma::SWEEP_TABLE_HARMONICS),
            max_tip_amplitude_m: 0.02,
            start_amplitude_m: NMA_START_TIP_AMPLITUDE_M,
            samples: None,
            mode: 1,
            table: None,
            conservative: true,
        }
    }
}

/// Largest `[nma] mode` accepted (the modal analysis of the model computes
/// this many modes at most for the start).
pub const MAX_NMA_MODE: usize = 1000;

impl NmaSpec {
    /// The harmonic order for the checks that need one before the NMA ran
    /// (`"auto"`: its smallest candidate, 1).
    pub fn harmonics_or_min(&self) -> usize {
        self.harmonics.fixed().unwrap_or(1)
    }

    /// Check the NMA options; the error names the key. The mode against the
    /// model's modes and the samples against the hysteretic default are
    /// checked when the NMA runs (`nma.mode`, `nma.samples`).
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        if let Harmonics::Fixed(h) = self.harmonics {
            if !(1..=64).contains(&h) {
                return Err(bad(
                    "nma.harmonics",
                    format!("expected 1 <= H <= 64 or \"auto\", got {h}"),
                ));
            }
        }
        let s = self.start_amplitude_m;
        if !(s.is_finite() && s > 0.0) {
            return Err(bad(
                "nma.start_amplitude_m",
                format!("expected a positive amplitude, got {s:e}"),
            ));
        }
        let a = self.max_tip_amplitude_m;
        if !(a.is_finite() && a > 0.0) {
            return Err(bad(
                "nma.max_tip_amplitude_m",
                format!("expected a positive amplitude, got {a:e}"),
            ));
        }
        if s >= a {
            // the key the user moved from its default is the one at fault
            let key = if self.start_amplitude_m != NMA_START_TIP_AMPLITUDE_M {
                "nma.start_amplitude_m"
            } else {
                "nma.max_tip_amplitude_m"
            };
            return Err(bad(
                key,
                format!(
                    "the NMA's amplitude range is empty: start_amplitude_m = {s:e} m must lie below max_tip_amplitude_m = {a:e} m"
                ),
            ));
        }
        if !(1..=MAX_NMA_MODE).contains(&self.mode) {
            return Err(bad(
                "nma.mode",
                format!(
                    "expected 1 <= mode <= {MAX_NMA_MODE} (1 = the lowest elastic mode), got {}",
                    self.mode
                ),
            ));
        }
        if let Some(n) = self.samples {
            let h = self.harmonics_or_min();
            let (lo, hi) = (4 * h + 1, nlmode::nma::max_aft_samples(h));
            if n < lo {
                return Err(bad(
                    "nma.samples",
                    format!(
                        "{n} AFT samples are too few for H = {h} harmonics (need at least 4H+1 = {lo})"
                    ),
                ));
            }
            if n > hi {
                return Err(bad(
                    "nma.samples",
                    format!(
                        "{n} AFT samples are more than the {hi} per period supported at H = {h}"
                    ),
                ));
            }
        }
        Ok(())
    }
}
