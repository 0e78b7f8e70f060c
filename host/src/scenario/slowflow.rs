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
    /// Linear modes of the structure kept beside the nonlinear mode by
    /// `nlmode` and `imposed-force` (`nlmode::reduced::ResidualModes`); 0:
    /// the paper's model.
    pub residual_modes: usize,
    /// Keep the modulation terms `eq:NM` drops, to first order in the slow
    /// derivatives (`nlmode::reduced::SlowFlowOptions::rate_terms`): used by
    /// `nlmode`, `imposed-force` and `linear-slowflow`. Default `false`: the
    /// paper's model.
    pub rate_terms: bool,
    /// The attachments' forces on every harmonic of the mode in the
    /// controllers' `nlmode` plant (`nlmode::control::ReducedPlant::
    /// with_harmonic_force_projection`; `phase-resonance`, `force-controlled`,
    /// `response-controlled`, `test-plan` with `model = "nlmode"`). The
    /// slow-flow sweeps (`nlmode`, `imposed-force`, `linear-slowflow`) refuse
    /// it: they keep `eq:NM`'s projection. Default `false`.
    pub harmonic_force_projection: bool,
    /// What the remedies of fired validity checks do: `"name"` lists them in
    /// `summary.json` (`remedies`); `"run"` also runs `nlmode` with each
    /// beside the plain one (`nlmode-dynamic`, `nlmode-residual-modes`).
    pub remedies: RemedyPolicy,
}

/// `[slowflow] remedies`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RemedyPolicy {
    /// Name them in `summary.json`.
    #[default]
    Name,
    /// Name them and run `nlmode` with each beside the plain one.
    Run,
}

/// Residual modes `[slowflow] remedies = "run"` uses: all the table carries,
/// at most this many (on the paper beam the tenth changes the tip by 1e-5).
pub const REMEDY_RESIDUAL_MODES: usize = 10;

impl Default for SlowFlowSpec {
    fn default() -> Self {
        let lib = nlmode::reduced::SlowFlowOptions::default();
        Self {
            rtol: lib.rtol,
            imposed_force_rtol: 1e-5,
            output_samples: lib.output_samples,
            attachments: lib.attachments,
            residual_modes: 0,
            rate_terms: lib.rate_terms,
            harmonic_force_projection: false,
            remedies: RemedyPolicy::Name,
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
            rate_terms: self.rate_terms,
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
        if self.residual_modes > nlmode::table::MAX_LINEAR_MODES {
            return Err(bad(
                "slowflow.residual_modes",
                format!(
                    "expected 0 to {} (the linear modes a modal table carries), got {}",
                    nlmode::table::MAX_LINEAR_MODES,
                    self.residual_modes
                ),
            ));
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

impl SlowFlowSpec {
    /// The slow-flow sweep `method` (`nlmode`, `imposed-force`,
    /// `linear-slowflow`) refuses `harmonic_force_projection`, which only the
    /// controllers' plant applies (the key named).
    pub fn check_sweep_projection(&self, method: &str) -> Result<(), ScenarioError> {
        if !self.harmonic_force_projection {
            return Ok(());
        }
        Err(bad(
            "slowflow.harmonic_force_projection",
            format!(
                "true applies to the controllers' nlmode plant (phase-resonance, force-controlled, \
                 response-controlled, test-plan with model = \"nlmode\"); the {method} sweep keeps eq:NM's \
                 projection on the fundamental: remove {method} from [run] methods or set it to false"
            ),
        ))
    }

    /// `residual_modes` against the linear modes `table` carries (after the
    /// modal analysis; the key and the limit named).
    pub fn check_residual_modes(
        &self,
        table: &nlmode::nma::ModalTable,
    ) -> Result<(), ScenarioError> {
        let n = self.residual_modes;
        if n == 0 {
            return Ok(());
        }
        match &table.linear_modes {
            Some(lm) if n <= lm.len() => Ok(()),
            Some(lm) => Err(bad(
                "slowflow.residual_modes",
                format!(
                    "expected at most {} (the structure's linear modes besides the nonlinear mode that the \
                     modal table carries), got {n}",
                    lm.len()
                ),
            )),
            None => Err(bad(
                "slowflow.residual_modes",
                format!(
                    "{n} residual modes need the linear modes in the modal table (`linear_modes`), which \
                     this table does not carry (a measured table, or one written before they were \
                     stored: recompute it with `host nma`)"
                ),
            )),
        }
    }
}
