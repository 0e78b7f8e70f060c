//! `[run]`: the methods of `host run` and the steady-state methods' frequency points.
use super::*;

/// A sweep method of `host run` (`[run] methods`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Time integration of the assembled full-order model.
    Reference,
    /// Assembled linear frequency response (with `closed-form` beside it).
    LinearFrf,
    /// Slow flow of the single nonlinear modal oscillator with the shaker (`eq:NM`).
    Nlmode,
    /// The same with constant linear modal properties.
    LinearSlowflow,
    /// Its algebraic linear steady state.
    LinearSteady,
    /// The FMUs co-simulated by the host's master.
    Cosim,
    /// The modal oscillator driven by a prescribed force (paper Section 5.3).
    ImposedForce,
    /// Phase-resonance test: phase-locked loop stepped through voltage levels
    /// (`[phase_resonance]`, `phase_resonance.csv`).
    PhaseResonance,
    /// Force-controlled stepped sine (`[force_control]`, `force_control.csv`).
    ForceControlled,
    /// Response-controlled stepped sine (`[response_control]`,
    /// `response_control.csv`).
    ResponseControlled,
    /// Test planning on the single-nonlinear-mode model (`[test_plan]`,
    /// `test_plan.csv`).
    TestPlan,
    /// Harmonic balance of the full model with every attachment, stability
    /// and bifurcations (`[hb]`, `hb_frc.csv`).
    Hb,
}

impl Method {
    /// Every method, in the order of the docs.
    pub const ALL: [Method; 12] = [
        Method::Reference,
        Method::LinearFrf,
        Method::Nlmode,
        Method::LinearSlowflow,
        Method::LinearSteady,
        Method::ImposedForce,
        Method::Cosim,
        Method::PhaseResonance,
        Method::ForceControlled,
        Method::ResponseControlled,
        Method::TestPlan,
        Method::Hb,
    ];

    /// The name in scenarios and output files (`linear-frf`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Reference => "reference",
            Method::LinearFrf => "linear-frf",
            Method::Nlmode => "nlmode",
            Method::LinearSlowflow => "linear-slowflow",
            Method::LinearSteady => "linear-steady",
            Method::Cosim => "cosim",
            Method::ImposedForce => "imposed-force",
            Method::PhaseResonance => "phase-resonance",
            Method::ForceControlled => "force-controlled",
            Method::ResponseControlled => "response-controlled",
            Method::TestPlan => "test-plan",
            Method::Hb => "hb",
        }
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RunSpec {
    pub methods: Vec<Method>,
    /// Number of excitation frequencies of `linear-frf` / `linear-steady`.
    pub frf_points: usize,
}

impl Default for RunSpec {
    fn default() -> Self {
        Self {
            methods: vec![
                Method::Reference,
                Method::Nlmode,
                Method::LinearSlowflow,
                Method::LinearSteady,
                Method::LinearFrf,
                Method::Cosim,
            ],
            frf_points: 500,
        }
    }
}

impl RunSpec {
    /// Check the method list and the frequency points.
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        if self.methods.is_empty() {
            let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
            return Err(bad(
                "run.methods",
                format!("expected a non-empty list from {names:?}"),
            ));
        }
        if self.frf_points < 2 {
            return Err(bad(
                "run.frf_points",
                format!("expected at least 2, got {}", self.frf_points),
            ));
        }
        Ok(())
    }
}
