//! `nlmode`: the slow flow of the single nonlinear modal oscillator with the
//! scenario's shakers and attachments (`eq:NM`, `eq:fc1`), the paper's
//! contribution; with `[imposed_force] apply_to_nlmode` also detuned
//! (`nlmode-freq-error`).
use super::common::{exciter_slow_flow, reduced_model};
use super::{MethodId, MethodOutput, RunContext};
use anyhow::Result;

/// `nlmode` (options: `[slowflow]`).
pub struct Nlmode;

impl super::Method for Nlmode {
    fn id(&self) -> MethodId {
        MethodId::Nlmode
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

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        let opts = ctx.sc.slowflow.options(MethodId::Nlmode);
        let n_res = ctx.sc.slowflow.residual_modes;
        let model =
            reduced_model(ctx.setup, ctx.table(), None)?.with_residual_modes(ctx.table(), n_res)?;
        let (mut r, flow) = exciter_slow_flow(MethodId::Nlmode.name(), ctx.setup, &model, &opts)?;
        super::common::note_residual_modes(&mut r, ctx.setup, &model);
        let mut out = MethodOutput {
            results: vec![r],
            flow: Some(flow),
        };
        let error = ctx.frequency_error();
        let has_error = error.eps != 0.0 || error.offset_rad_s != 0.0;
        if has_error && ctx.sc.imposed_force.apply_to_nlmode && ctx.published(MethodId::Nlmode) {
            let model = reduced_model(ctx.setup, ctx.table(), Some(error))?
                .with_residual_modes(ctx.table(), n_res)?;
            let (r, _) = exciter_slow_flow("nlmode-freq-error", ctx.setup, &model, &opts)?;
            out.results.push(r);
        }
        Ok(out)
    }
}
