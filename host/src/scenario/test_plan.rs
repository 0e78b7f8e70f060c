//! `[test_plan]` (method `test-plan`).
use super::*;

// ---- [test_plan] (method `test-plan`) ----

/// Most target amplitudes of `[test_plan]`.
pub const MAX_TEST_PLAN_TARGETS: usize = 200;

/// `[test_plan]`: the voltage, current and stroke the shaker needs to hold
/// the structure at phase resonance at each target amplitude, and the force
/// drop of an open-loop sweep at that voltage (docs/scenario.md).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct TestPlanSpec {
    /// Target fundamental amplitudes `|q_tip,1|` of the response point \[m\]
    /// (default `[0.5e-3, 1e-3, 2e-3, 3e-3]`).
    pub target_amplitudes_m: Vec<f64>,
    /// Voltage amplitude the amplifier gives \[V\] (default 40).
    pub voltage_limit_v: f64,
    /// Coil current amplitude allowed \[A\] (default 10).
    pub current_limit_a: f64,
    /// Armature displacement amplitude allowed \[m\] (default 6.35e-3, half
    /// of a 12.7 mm peak-to-peak stroke).
    pub stroke_limit_m: f64,
    /// Whether to run the open-loop sweep (the scenario's `[excitation]` at the
    /// planned voltage) per target for its force drop (default true).
    pub open_loop_sweep: bool,
}

impl Default for TestPlanSpec {
    fn default() -> Self {
        Self {
            target_amplitudes_m: vec![0.5e-3, 1e-3, 2e-3, 3e-3],
            voltage_limit_v: 40.0,
            current_limit_a: 10.0,
            stroke_limit_m: 6.35e-3,
            open_loop_sweep: true,
        }
    }
}

impl TestPlanSpec {
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        let n = self.target_amplitudes_m.len();
        if n == 0 || n > MAX_TEST_PLAN_TARGETS {
            return Err(bad(
                "test_plan.target_amplitudes_m",
                format!("expected 1 ..= {MAX_TEST_PLAN_TARGETS} amplitudes, got {n}"),
            ));
        }
        for (i, v) in self.target_amplitudes_m.iter().enumerate() {
            positive(&format!("test_plan.target_amplitudes_m[{i}]"), *v)?;
        }
        positive("test_plan.voltage_limit_v", self.voltage_limit_v)?;
        positive("test_plan.current_limit_a", self.current_limit_a)?;
        positive("test_plan.stroke_limit_m", self.stroke_limit_m)
    }
}
