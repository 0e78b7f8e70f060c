//! `[slowflow]`: the slow-flow integration of the single-mode methods.
use super::*;

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlowFlowSpec {
    /// Relative tolerance of `nlmode` and `linear-slowflow`.
    pub rtol: f64,
    /// Relative tolerance of `imposed-force` (more sensitive near a force minimum).
    pub imposed_force_rtol: f64,
    /// Output samples along the sweep, uniform in time (both ends included).
    pub output_samples: usize,
    /// How the attachments enter the slow flow of `nlmode` and
    /// `imposed-force`: `"quasi-steady"` (`eq:NM`, the paper's model) or
    /// `"dynamic"` (their states carried beside the modal amplitude,
    /// `nlmode::reduced::dynamic`).
    pub attachments: nlmode::reduced::AttachmentStates,
}

impl Default for SlowFlowSpec {
    fn default() -> Self {
        let lib = nlmode::reduced::SlowFlowOptions::default();
        Self {
            rtol: lib.rtol,
            imposed_force_rtol: 1e-5,
            output_samples: lib.output_samples,
            attachments: lib.attachments,
        }
    }
}

impl SlowFlowSpec {
    /// The library options for `method`.
    pub fn options(&self, method: Method) -> nlmode::reduced::SlowFlowOptions {
        nlmode::reduced::SlowFlowOptions {
            rtol: if method == Method::ImposedForce {
                self.imposed_force_rtol
            } else {
                self.rtol
            },
            output_samples: self.output_samples,
            attachments: self.attachments,
            ..Default::default()
        }
    }
}

impl SlowFlowSpec {
    /// Check the slow-flow options.
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        for (k, v) in [
            ("slowflow.rtol", self.rtol),
            ("slowflow.imposed_force_rtol", self.imposed_force_rtol),
        ] {
            if !(v > 0.0 && v < 0.1) {
                return Err(bad(k, format!("expected a number in (0, 0.1), got {v}")));
            }
        }
        if self.output_samples < 2 {
            return Err(bad(
                "slowflow.output_samples",
                format!("expected at least 2, got {}", self.output_samples),
            ));
        }
        Ok(())
    }
}
