//! The sweep methods of `host run`: each returns a [`MethodResult`] following
//! the output contract. The physics is in `nlmode`; this is orchestration.
use crate::model::{Setup, TIP};
use crate::results::{Envelope, MethodResult};
use anyhow::{Context, Result};
use nalgebra::DVector;
use nlmode::frf;
use nlmode::Complex64;
use serde_json::json;
use std::time::Instant;

/// Excitation frequencies of the steady-state methods: the sweep's range.
pub fn frf_omegas(setup: &Setup, n: usize) -> Vec<f64> {
    let (a, b) = (setup.sweep.omega_start_rad_s, setup.sweep.omega_end_rad_s);
    (0..n).map(|i| a + (b - a) * i as f64 / (n - 1) as f64).collect()
}

/// `linear-frf`: the assembled linear frequency response (structure + all
/// attachments, all modes of the model), force drop at `omega0` from it and from
/// the closed form `eq:forcedrop`.
pub fn linear_frf(setup: &Setup, n: usize) -> Result<MethodResult> {
    let t0 = Instant::now();
    let omegas = frf_omegas(setup, n);
    let u = DVector::from_element(1, Complex64::new(setup.sweep.amplitude, 0.0));
    let inputs = vec![u; setup.attachments.len()];
    let pts = frf::assembled_frf(&setup.model, &setup.attachments, &inputs, &omegas).context("linear-frf")?;
    let tip = setup.model.points.iter().position(|p| p.name == TIP).context("tip point")?;
    let drive = setup.model.points.iter().position(|p| p.name == setup.exciter_points[0]).context("drive point")?;
    let env = Envelope {
        omega_rad_s: omegas.clone(),
        force_amplitude_n: pts.iter().map(|p| p.force_n[0].norm()).collect(),
        tip_amplitude_m: pts.iter().map(|p| p.points[tip].norm()).collect(),
        extra: vec![
            ("force_phase_rad".into(), pts.iter().map(|p| p.force_n[0].arg()).collect()),
            ("drive_amplitude_m".into(), pts.iter().map(|p| p.points[drive].norm()).collect()),
        ],
    };
    let wall = t0.elapsed().as_secs_f64();
    let mut r = MethodResult::new("linear-frf", wall, env, false);
    let shaker = &setup.shakers[0];
    let drop = frf::linear_force_drop(&setup.model, shaker, &setup.exciter_points[0], setup.omega0_rad_s)
        .context("linear-frf: force drop")?;
    let (m_mod, mu) = setup.modal_masses()?[0];
    let closed = 1.0
        - frf::force_drop_closed_form(
            setup.d0,
            mu,
            shaker.omega_a() / setup.omega0_rad_s,
            shaker.damping_ratio(),
        );
    r.extra.insert("force_drop".into(), json!(drop));
    r.extra.insert("force_drop_closed_form".into(), json!(closed));
    r.extra.insert("modal_mass_kg".into(), json!(m_mod));
    r.extra.insert("mass_ratio".into(), json!(mu));
    Ok(r)
}
