//! `[reference]` (method `reference`).
use super::*;

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceSpec {
    /// Integrator of the full-order reference: `exponential` or
    /// `dormand-prince`; the library default when omitted or `""`.
    #[serde(deserialize_with = "integrator_or_empty")]
    pub integrator: Option<Integrator>,
    pub rtol: f64,
    /// Output sample interval of the time series [s] (0 = a library default).
    pub output_interval_s: f64,
}

/// `""` (the library default) or an [`Integrator`] name.
pub(crate) fn integrator_or_empty<'de, D: Deserializer<'de>>(
    d: D,
) -> Result<Option<Integrator>, D::Error> {
    let s = String::deserialize(d)?;
    if s.is_empty() {
        return Ok(None);
    }
    Integrator::deserialize(serde::de::value::StrDeserializer::<D::Error>::new(&s)).map(Some)
}

impl Default for ReferenceSpec {
    fn default() -> Self {
        Self {
            integrator: None,
            rtol: 1e-6,
            output_interval_s: 0.0,
        }
    }
}

impl ReferenceSpec {
    /// Check the reference's options.
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        positive("reference.rtol", self.rtol)?;
        if !(self.output_interval_s.is_finite() && self.output_interval_s >= 0.0) {
            return Err(bad(
                "reference.output_interval_s",
                "expected a finite number >= 0",
            ));
        }
        Ok(())
    }
}
