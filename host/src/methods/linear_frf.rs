//! `linear-frf`: the assembled linear frequency response (all modes, every
//! attachment) and, beside it with one exciter alone, `closed-form` (`eq:fhfhNull`).
use super::common::{attachment_output, frf_omegas};
use super::{MethodOutput, RunContext};
use crate::model::Setup;
use crate::results::{Envelope, MethodResult};
use crate::scenario::Method;
use anyhow::{Context, Result};
use nalgebra::DVector;
use nlmode::frf;
use nlmode::Complex64;
use std::time::Instant;

/// `linear-frf`: the assembled linear frequency response (structure + all
/// attachments, all modes of the model), force drop at `omega0` from it and from
/// the closed form `eq:forcedrop`.
pub fn linear_frf(setup: &Setup, n: usize) -> Result<MethodResult> {
    let t0 = Instant::now();
    let omegas = frf_omegas(setup, n);
    let inputs = setup.input_amplitudes();
    let pts = frf::assembled_frf(&setup.model, &setup.attachments, &inputs, &omegas)
        .context("linear-frf")?;
    let tip = setup
        .model
        .points
        .iter()
        .position(|p| p.name == setup.response_point)
        .context("response point")?;
    let drive = setup
        .model
        .points
        .iter()
        .position(|p| p.name == setup.exciter_points[0])
        .context("drive point")?;
    let env = Envelope {
        omega_rad_s: omegas.clone(),
        force_amplitude_n: pts.iter().map(|p| p.force_n[0].norm()).collect(),
        tip_amplitude_m: pts.iter().map(|p| p.points[tip].norm()).collect(),
        force_phase_rad: Some(pts.iter().map(|p| p.force_n[0].arg()).collect()),
        drive_amplitude_m: Some(pts.iter().map(|p| p.points[drive].norm()).collect()),
        ..Default::default()
    };
    let wall = t0.elapsed().as_secs_f64();
    let mut r = MethodResult::new(Method::LinearFrf.name(), wall, env, false);
    // several exciters: each one's force (attachments in order, one constraint each)
    if setup.shakers.len() > 1 {
        let forces: Vec<Vec<Complex64>> = (0..setup.shakers.len())
            .map(|i| pts.iter().map(|p| p.force_n[i]).collect())
            .collect();
        r.add_exciter_forces(&setup.exciter_names, &forces);
    }
    // harvested power of every piezo shunt: mean v^2/R = |v_hat|^2 / (2 R)
    for &(a, out) in &setup.outputs {
        let att = &setup.attachments[a];
        let idx: Vec<usize> = att
            .interface_points
            .iter()
            .map(|n| setup.model.points.iter().position(|p| &p.name == n))
            .collect::<Option<_>>()
            .context("piezo point")?;
        let power = pts
            .iter()
            .map(|p| {
                let u_g = DVector::from_iterator(idx.len(), idx.iter().map(|&j| p.points[j]));
                attachment_output(att, &out, p.omega_rad_s, &u_g, &inputs[a])
            })
            .collect::<Result<Vec<f64>>>()
            .context("linear-frf: harvested power")?;
        r.add_output(&att.name, out.kind, power);
    }
    let shaker = &setup.shakers[0];
    let drop = if setup.attachments.len() == 1 {
        frf::linear_force_drop(
            &setup.model,
            shaker,
            &setup.exciter_points[0],
            setup.omega0_rad_s,
        )
        .context("linear-frf: force drop")?
    } else {
        // the first exciter with every attachment on: 1 - |F| / |F0|, F0 = G |u_hat| / R
        let at = frf::assembled_frf(
            &setup.model,
            &setup.attachments,
            &inputs,
            &[setup.omega0_rad_s],
        )
        .context("linear-frf: force drop")?;
        let f0 = shaker.force_constant_n_per_a * inputs[0][0].norm() / shaker.resistance_ohm;
        1.0 - at[0].force_n[0].norm() / f0
    };
    let (m_mod, mu) = setup.modal_masses[0];
    let closed = 1.0
        - frf::force_drop_closed_form(
            setup.d0,
            mu,
            shaker.omega_a() / setup.omega0_rad_s,
            shaker.damping_ratio(),
        );
    r.summary.set("force_drop", drop);
    r.summary.set("force_drop_closed_form", closed);
    r.summary.set("modal_mass_kg", m_mod);
    r.summary.set("mass_ratio", mu);
    Ok(r)
}

/// `closed-form`: the applied force of `eq:fhfhNull` (linear, single mode,
/// `omega_c >> omega0`, `k_s >> k_a`), `|F| = |F/F0| G u_hat / R`, beside the
/// assembled FRF; the tip follows from the structure's own single-mode FRF.
pub fn closed_form(setup: &Setup, n: usize) -> Result<MethodResult> {
    let t0 = Instant::now();
    let omegas = frf_omegas(setup, n);
    let shaker = &setup.shakers[0];
    let (m_mod, mu) = setup.modal_masses[0];
    let f0 = shaker.force_constant_n_per_a * setup.sweep.amplitude / shaker.resistance_ohm;
    let ra = shaker.omega_a() / setup.omega0_rad_s;
    let j = setup.mode_index;
    let modes = nlmode::structure::modal_analysis(&setup.model, j + 1)?;
    let phi_tip = modes.deflection(j, &setup.model.point(&setup.response_point)?.direction);
    let phi_ex = modes.deflection(j, &setup.model.point(&setup.exciter_points[0])?.direction);
    let (mut f, mut tip) = (Vec::new(), Vec::new());
    for &w in &omegas {
        let eta = w / setup.omega0_rad_s;
        let ratio = frf::force_ratio_closed_form(eta, setup.d0, mu, ra, shaker.damping_ratio());
        let force = ratio * f0;
        // single-mode FRF of the structure: q_tip = phi_tip phi_ex F / (omega0^2 (1 - eta^2 + 2 i D0 eta))
        let h = Complex64::new(1.0 - eta * eta, 2.0 * setup.d0 * eta) * setup.omega0_rad_s.powi(2);
        f.push(force.norm());
        tip.push((force * phi_tip * phi_ex / h).norm());
    }
    let env = Envelope {
        omega_rad_s: omegas,
        force_amplitude_n: f,
        tip_amplitude_m: tip,
        ..Default::default()
    };
    let mut r = MethodResult::new("closed-form", t0.elapsed().as_secs_f64(), env, false);
    let drop = 1.0 - frf::force_drop_closed_form(setup.d0, mu, ra, shaker.damping_ratio());
    r.summary.set("force_drop", drop);
    r.summary.set("modal_mass_kg", m_mod);
    r.summary.set("mass_ratio", mu);
    Ok(r)
}

/// `linear-frf` (options: `[run] frf_points`).
pub struct LinearFrf;

/// Its name in scenarios and output files.
impl super::MethodId {
    #[allow(non_upper_case_globals)]
    pub const LinearFrf: Self = Self::new("linear-frf");
}

impl super::Method for LinearFrf {
    fn id(&self) -> Method {
        Method::LinearFrf
    }

    fn section(&self) -> Option<&'static str> {
        Some("run")
    }

    fn run(&self, ctx: &RunContext) -> Result<MethodOutput> {
        let n = ctx.sc.run.frf_points;
        let mut out = MethodOutput::one(linear_frf(ctx.setup, n)?);
        // eq:fhfhNull beside the assembled FRF (the paper's force-drop figure):
        // its single-shaker closed form only fits one exciter alone
        if ctx.setup.attachments.len() == 1 {
            out.results.push(closed_form(ctx.setup, n)?);
        }
        Ok(out)
    }
}
