//! `nlmode`: the slow flow of the single nonlinear modal oscillator with the
//! scenario's shakers and attachments (`eq:NM`, `eq:fc1`), the paper's
//! contribution; with `[imposed_force] apply_to_nlmode` also detuned
//! (`nlmode-freq-error`).
use super::common::{exciter_slow_flow, reduced_model};
use super::{MethodId, MethodOutput, RunContext};
use crate::results::MethodResult;
use crate::scenario::{RemedyPolicy, REMEDY_RESIDUAL_MODES};
use crate::validity::Remedy;
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

    fn check(&self, sc: &crate::scenario::Scenario, _setup: &crate::model::Setup) -> Result<()> {
        Ok(sc.slowflow.check_sweep_projection(self.id().name())?)
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        let opts = ctx.sc.slowflow.options(MethodId::Nlmode);
        let n_res = ctx.sc.slowflow.residual_modes;
        let model =
            reduced_model(ctx.setup, ctx.table(), None)?.with_residual_modes(ctx.table(), n_res)?;
        let (mut r, flow) = exciter_slow_flow(MethodId::Nlmode.name(), ctx.setup, &model, &opts)?;
        super::common::note_residual_modes(&mut r, ctx.setup, &model);
        super::common::note_rate_terms(&mut r, &opts);
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
        if ctx.sc.slowflow.remedies == RemedyPolicy::Run && ctx.published(MethodId::Nlmode) {
            for remedy in &ctx.remedies {
                if let Some(r) = run_remedy(ctx, remedy, &opts)? {
                    out.results.push(r);
                }
            }
        }
        Ok(out)
    }
}

/// `nlmode` with `remedy` applied, as the result [`Remedy::result_name`];
/// `None` for residual modes when the table carries no linear modes.
fn run_remedy(
    ctx: &RunContext,
    remedy: &Remedy,
    opts: &nlmode::reduced::SlowFlowOptions,
) -> Result<Option<MethodResult>> {
    let name = remedy.result_name();
    let base = reduced_model(ctx.setup, ctx.table(), None)?;
    let (model, opts) = match remedy {
        Remedy::DynamicAttachments { .. } => (
            base,
            nlmode::reduced::SlowFlowOptions {
                attachments: nlmode::reduced::AttachmentStates::Dynamic,
                ..*opts
            },
        ),
        Remedy::ResidualModes { .. } => {
            let available = ctx.table().linear_modes.as_ref().map_or(0, |m| m.len());
            let n = available.min(REMEDY_RESIDUAL_MODES);
            if n == 0 {
                return Ok(None);
            }
            (base.with_residual_modes(ctx.table(), n)?, *opts)
        }
    };
    let (mut r, _) = exciter_slow_flow(name, ctx.setup, &model, &opts)?;
    super::common::note_residual_modes(&mut r, ctx.setup, &model);
    super::common::note_rate_terms(&mut r, &opts);
    Ok(Some(r))
}
