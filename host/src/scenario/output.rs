//! `[output]`: what `host run` writes.
use super::*;

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSpec {
    pub time_series: bool,
    pub plots: bool,
    /// Package structure.fmu and shaker.fmu into `<out>/fmus`.
    pub fmus: bool,
    /// The point whose displacement the envelopes call `tip_amplitude_m`
    /// (default `tip` for beams; required for matrices).
    pub response_point: Option<String>,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            time_series: true,
            plots: true,
            fmus: true,
            response_point: None,
        }
    }
}
