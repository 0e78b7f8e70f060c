//! `linear-slowflow`: the slow flow of `eq:NM` with constant linear modal
//! properties (to separate nonlinear from transient effects).
use super::common::{exciter_slow_flow, reduced_model};
use super::{MethodId, MethodOutput, RunContext};
use anyhow::Result;

/// `linear-slowflow` (options: `[slowflow]`).
pub struct LinearSlowflow;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const LinearSlowflow: Self = Self::new("linear-slowflow");
}

impl super::Method for LinearSlowflow {
    fn id(&self) -> MethodId {
        MethodId::LinearSlowflow
    }

    fn section(&self) -> Option<&'static str> {
        Some("slowflow")
    }

    fn needs_mode(&self, _sc: &crate::scenario::Scenario) -> bool {
        true
    }

    fn in_studies(&self) -> bool {
        true
    }

    fn check(&self, sc: &crate::scenario::Scenario, _setup: &crate::model::Setup) -> Result<()> {
        Ok(sc.slowflow.check_sweep_projection(self.id().name())?)
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        let id = MethodId::LinearSlowflow;
        let model = reduced_model(ctx.setup, ctx.table(), None)?.linear()?;
        let opts = ctx.sc.slowflow.options(id);
        let (mut r, flow) = exciter_slow_flow(id.name(), ctx.setup, &model, &opts)?;
        super::common::note_rate_terms(&mut r, &opts);
        Ok(MethodOutput {
            results: vec![r],
            flow: Some(flow),
        })
    }
}
