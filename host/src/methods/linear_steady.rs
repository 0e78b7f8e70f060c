//! `linear-steady`: the paper's single-mode linear steady state.
use super::common::{frf_omegas, modal_harvested_power, reduced_model};
use super::{MethodOutput, RunContext};
use crate::model::Setup;
use crate::results::{Envelope, MethodResult};
use crate::scenario::Method;
use anyhow::{Context, Result};
use nlmode::Complex64;
use std::time::Instant;

/// `linear-steady`: the paper's single-mode linear steady state.
pub fn linear_steady(
    setup: &Setup,
    model: &nlmode::reduced::ReducedModel,
    n: usize,
) -> Result<MethodResult> {
    let t0 = Instant::now();
    let omegas = frf_omegas(setup, n);
    let ls = model
        .linear_steady(&omegas, setup.sweep.amplitude)
        .context("linear-steady")?;
    let wall = t0.elapsed().as_secs_f64();
    let env = Envelope::from(&ls);
    let mut r = MethodResult::new(Method::LinearSteady.name(), wall, env, false);
    // harvested power at the linear model's fundamentals A phi0
    if !setup.outputs.is_empty() {
        let lin = model.linear().context("linear-steady")?;
        let pts: Vec<(f64, Complex64)> = ls
            .points
            .iter()
            .map(|p| (p.omega_rad_s, Complex64::from_polar(p.a, p.theta_rad)))
            .collect();
        for (name, power) in modal_harvested_power(setup, &lin, &pts).context("linear-steady")? {
            r.add_harvested_power(&name, power);
        }
    }
    r.summary.set("force_drop", ls.force_drop);
    r.summary.set("omega0_single_mode_rad_s", ls.omega0_rad_s);
    Ok(r)
}

/// `linear-steady` (options: `[run] frf_points`).
pub struct LinearSteady;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const LinearSteady: Self = Self::new("linear-steady");
}

impl super::Method for LinearSteady {
    fn id(&self) -> Method {
        Method::LinearSteady
    }

    fn section(&self) -> Option<&'static str> {
        Some("run")
    }

    fn needs_mode(&self, _sc: &crate::scenario::Scenario) -> bool {
        true
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        let model = reduced_model(ctx.setup, ctx.table(), None)?;
        Ok(MethodOutput::one(linear_steady(
            ctx.setup,
            &model,
            ctx.sc.run.frf_points,
        )?))
    }
}
