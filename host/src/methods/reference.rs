//! `reference`: direct time integration of the assembled full-order model
//! (`eq:finalassembly1`-`eq:finalassembly2`).
use super::{MethodOutput, RunContext};
use crate::model::Setup;
use crate::results::{Envelope, MethodResult};
use crate::scenario::Method;
use anyhow::{Context, Result};
use nlmode::Complex64;
use std::time::Instant;

/// `reference`: direct time integration of the assembled full-order model; its
/// envelope has the force phase (for `imposed-force`).
pub fn reference(
    setup: &Setup,
    sc: &crate::scenario::Scenario,
    progress: &mut dyn FnMut(f64),
) -> Result<MethodResult> {
    use nlmode::reference::{simulate_phased_sweep_with_progress, ReferenceOptions};
    let method = sc.reference.integrator.unwrap_or_default();
    let opts = ReferenceOptions {
        method,
        rtol: sc.reference.rtol,
        output_interval_s: (sc.reference.output_interval_s > 0.0)
            .then_some(sc.reference.output_interval_s),
        tip_point: setup.response_point.clone(),
        ..Default::default()
    };
    let t0 = Instant::now();
    // each exciter's voltage ratio and phase: the in-phase and quadrature sweeps
    let res = simulate_phased_sweep_with_progress(
        &setup.model,
        &setup.attachments,
        Some(&setup.inputs),
        &setup.sweep,
        &opts,
        progress,
    )
    .context("reference")?;
    let wall = t0.elapsed().as_secs_f64();
    let env = Envelope::from(res.envelope.clone());
    let mut r = MethodResult::new(Method::Reference.name(), wall, env, true);
    // harvested power of every piezo shunt: |v_hat|^2 / (2 R) from the electrode
    // voltage's (state 1) fundamental envelope, on the envelope's windows
    for &(a, out) in &setup.outputs {
        let series = &res.attachments[a];
        let power = series.state_amplitudes[out.state]
            .iter()
            .map(|&v| out.of_amplitude(v))
            .collect();
        r.add_output(&series.name, out.kind, power);
    }
    // several exciters: each one's force (the shakers are the first attachments)
    if setup.shakers.len() > 1 {
        let forces: Vec<Vec<Complex64>> = res.attachments[..setup.shakers.len()]
            .iter()
            .map(|a| a.force_envelopes[0].clone())
            .collect();
        r.add_exciter_forces(&setup.exciter_names, &forces);
    }
    r.time_series = Some(crate::results::TimeSeries {
        columns: vec![
            ("t_s".into(), res.time_s.clone()),
            ("omega_rad_s".into(), res.omega_rad_s.clone()),
            ("voltage_V".into(), res.input.clone()),
            ("tip_m".into(), res.tip_m.clone()),
            ("drive_m".into(), res.drive_m.clone()),
            ("force_N".into(), res.force_n.clone()),
        ],
    });
    r.summary.set("steps", res.stats.steps as u64);
    r.summary.set("rejected_steps", res.stats.rejected as u64);
    r.summary.set("integrator", format!("{method:?}"));
    Ok(r)
}

/// `reference` (options: `[reference]`).
pub struct Reference;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const Reference: Self = Self::new("reference");
}

impl super::Method for Reference {
    fn id(&self) -> Method {
        Method::Reference
    }

    fn section(&self) -> Option<&'static str> {
        Some("reference")
    }

    fn in_studies(&self) -> bool {
        true
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        let label = if ctx.published(Method::Reference) {
            "reference"
        } else {
            "reference (for imposed-force)"
        };
        let mut bar = ctx.progress(label);
        let r = reference(ctx.setup, ctx.sc, &mut |f| bar.set(f))?;
        bar.finish();
        Ok(MethodOutput::one(r))
    }
}
