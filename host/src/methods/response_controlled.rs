//! `response-controlled`: response-controlled stepped sine (`response_control.csv`).
use super::{MethodId, MethodOutput, RunContext};
use anyhow::Result;

/// `response-controlled` (options: `[response_control]`).
pub struct ResponseControlled;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const ResponseControlled: Self = Self::new("response-controlled");
}

impl super::Method for ResponseControlled {
    fn id(&self) -> MethodId {
        MethodId::ResponseControlled
    }

    fn section(&self) -> Option<&'static str> {
        Some("response_control")
    }

    fn needs_mode(&self, _sc: &crate::scenario::Scenario) -> bool {
        true
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        Ok(MethodOutput::one(super::stepped::response_controlled(
            ctx.setup,
            ctx.sc,
            ctx.table(),
            ctx.out,
        )?))
    }
}
