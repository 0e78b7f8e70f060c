//! `force-controlled`: force-controlled stepped sine (`force_control.csv`).
use super::{MethodId, MethodOutput, RunContext};
use anyhow::Result;

/// `force-controlled` (options: `[force_control]`).
pub struct ForceControlled;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const ForceControlled: Self = Self::new("force-controlled");
}

impl super::Method for ForceControlled {
    fn id(&self) -> MethodId {
        MethodId::ForceControlled
    }

    fn section(&self) -> Option<&'static str> {
        Some("force_control")
    }

    fn needs_mode(&self, _sc: &crate::scenario::Scenario) -> bool {
        true
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        Ok(MethodOutput::one(super::stepped::force_controlled(
            ctx.setup,
            ctx.sc,
            ctx.table(),
            ctx.out,
        )?))
    }
}
