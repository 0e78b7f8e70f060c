//! `imposed-force`: the single-mode model driven by a given force instead of
//! the shaker model (the paper's frequency-error study, Section 5.3): the
//! force of another method of the run (its dependency, `nlmode` or
//! `reference`) or of a CSV file, one force per exciter at its point; the
//! passive attachments stay as impedances.
use super::common::slow_flow;
use super::{MethodId, MethodOutput, RunContext};
use crate::results::{self, MethodResult};
use crate::scenario::{ForceSource, Scenario};
use anyhow::{Context, Result};
use nlmode::reduced::ForceEnvelope;

/// `imposed-force` (options: `[imposed_force]`).
pub struct ImposedForce;

impl super::Method for ImposedForce {
    fn id(&self) -> MethodId {
        MethodId::ImposedForce
    }

    fn section(&self) -> Option<&'static str> {
        Some("imposed_force")
    }

    fn depends_on(&self, sc: &Scenario) -> Vec<MethodId> {
        match sc.imposed_force.source {
            ForceSource::Nlmode => vec![MethodId::Nlmode],
            ForceSource::Reference => vec![MethodId::Reference],
            ForceSource::Csv(_) => Vec::new(),
        }
    }

    fn needs_mode(&self, _sc: &Scenario) -> bool {
        true
    }

    fn check(&self, sc: &crate::scenario::Scenario, setup: &crate::model::Setup) -> Result<()> {
        sc.slowflow.check_sweep_projection(self.id().name())?;
        setup.check_imposed_force()
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        let setup = ctx.setup;
        let envelopes = forces(ctx)?;
        let forces = setup
            .exciter_points
            .iter()
            .map(String::as_str)
            .zip(envelopes.iter().cloned())
            .collect();
        let mut model = nlmode::reduced::ReducedModel::imposed_forces(
            ctx.table(),
            &setup.response_point,
            &setup.exciter_points[0],
            forces,
        )?;
        // the passive attachments stay as impedances
        for (att, u) in setup
            .attachments
            .iter()
            .zip(&setup.inputs)
            .skip(setup.shakers.len())
        {
            model = model.with_linear_attachment(att, u)?;
        }
        let model = model
            .with_frequency_error(ctx.frequency_error())?
            .with_residual_modes(ctx.table(), ctx.sc.slowflow.residual_modes)?;
        let id = MethodId::ImposedForce;
        let opts = ctx.sc.slowflow.options(id);
        let (mut r, res) = slow_flow(id.name(), setup, &model, &opts)?;
        super::common::note_residual_modes(&mut r, setup, &model);
        super::common::note_rate_terms(&mut r, &opts);
        // several exciters: the forces imposed, per exciter
        if setup.shakers.len() > 1 {
            let forces = envelopes
                .iter()
                .map(|e| {
                    res.samples
                        .iter()
                        .map(|x| e.eval(x.omega_rad_s))
                        .collect::<Result<Vec<_>, _>>()
                })
                .collect::<Result<Vec<_>, _>>()
                .context("imposed-force")?;
            r.add_exciter_forces(&setup.exciter_names, &forces);
        }
        Ok(MethodOutput {
            results: vec![r],
            flow: Some(res),
        })
    }
}

/// The force envelope of each exciter: from the source method's output (one
/// exciter: its drive-point force; several: its per-exciter columns) or the
/// CSV file.
fn forces(ctx: &RunContext) -> Result<Vec<ForceEnvelope>> {
    let setup = ctx.setup;
    let several = setup.shakers.len() > 1;
    let columns = results::exciter_force_columns(&setup.exciter_names);
    let per_exciter = |r: &MethodResult, key: &str| -> Result<Vec<ForceEnvelope>> {
        let cols = results::envelope_columns(r);
        let picked = results::pick_columns(&cols, &columns).context(key.to_string())?;
        results::exciter_force_envelopes(&picked).context(key.to_string())
    };
    match &ctx.sc.imposed_force.source {
        ForceSource::Nlmode => {
            let o = ctx.output(MethodId::Nlmode)?;
            if several {
                per_exciter(o.first()?, "imposed_force.source = nlmode")
            } else {
                let flow = o.flow.as_ref().context("nlmode: no slow flow")?;
                Ok(vec![
                    nlmode::envelope::Envelope::from(flow).to_force_envelope()?
                ])
            }
        }
        ForceSource::Reference => {
            let o = ctx.output(MethodId::Reference)?;
            let r = o.first()?;
            let envelopes = if several {
                per_exciter(r, "imposed_force.source = reference")?
            } else {
                vec![r
                    .envelope
                    .to_force_envelope()
                    .context("imposed_force.source = reference")?]
            };
            // the windowed envelope lacks half a period at each end
            let s = &setup.sweep;
            Ok(envelopes
                .into_iter()
                .map(|e| {
                    e.with_held_ends(
                        s.omega_start_rad_s.min(s.omega_end_rad_s),
                        s.omega_start_rad_s.max(s.omega_end_rad_s),
                    )
                })
                .collect())
        }
        ForceSource::Csv(path) => {
            let read = || -> Result<Vec<ForceEnvelope>> {
                if several {
                    let picked = results::read_csv_columns(path, &columns)?;
                    Ok(results::exciter_force_envelopes(&picked)?)
                } else {
                    Ok(vec![results::read_envelope(path)?.to_force_envelope()?])
                }
            };
            read().with_context(|| format!("imposed_force.source: CSV file '{}'", path.display()))
        }
    }
}
