//! Kernels shared by the single-mode methods: the frequency grid of the
//! steady-state methods, the piezo shunts' harvested power, the
//! single-nonlinear-mode model with the scenario's attachments and its slow flow.
use crate::model::Setup;
use crate::results::{Envelope, MethodResult};
use crate::scenario::AttachmentOutput;
use anyhow::{Context, Result};
use nalgebra::DVector;
use nlmode::Complex64;
use std::time::Instant;

/// Excitation frequencies of the steady-state methods: the sweep's range.
pub fn frf_omegas(setup: &Setup, n: usize) -> Vec<f64> {
    let (a, b) = (setup.sweep.omega_start_rad_s, setup.sweep.omega_end_rad_s);
    (0..n)
        .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
        .collect()
}

/// The output `out` of the attachment `att` ([`AttachmentOutput`], e.g. a
/// piezo shunt's mean harvested power `|v_hat|^2 / (2 R)`) at the steady
/// fundamental with interface displacements `u_g` [m] and inputs `u_hat` at
/// `omega_rad_s`, from the attachment states recovered by
/// [`nlmode::attachment::LinearAttachment::states`].
pub fn attachment_output(
    att: &nlmode::attachment::LinearAttachment,
    out: &AttachmentOutput,
    omega_rad_s: f64,
    u_g: &DVector<Complex64>,
    u_hat: &DVector<Complex64>,
) -> Result<f64> {
    let x = att.states(omega_rad_s, u_g, u_hat)?;
    Ok(out.of_state(x[out.state]))
}

/// Harvested power of every piezo shunt of `setup` from the single-mode model
/// `model` at the points `(Omega, A)` (complex modal amplitude `A = a e^{i
/// theta}`): the shunt's interface displacements are the fundamentals
/// `A phi_1(a)` of the model (`eq:ansatz`; harmonics neglected) -> one
/// `(attachment name, power [W] per point)` per shunt (every output the
/// attachments declare is a harvested power today).
pub fn modal_harvested_power(
    setup: &Setup,
    model: &nlmode::reduced::ReducedModel,
    points: &[(f64, Complex64)],
) -> Result<Vec<(String, Vec<f64>)>> {
    let mut powers = Vec::new();
    for (a_idx, out) in &setup.outputs {
        let att = &setup.attachments[*a_idx];
        let power = points
            .iter()
            .map(|&(w, amp)| {
                let u_g = att
                    .interface_points
                    .iter()
                    .map(|p| Ok(model.displacement_harmonics(p, amp)?[1]))
                    .collect::<Result<Vec<Complex64>>>()?;
                attachment_output(att, out, w, &DVector::from_vec(u_g), &DVector::zeros(0))
            })
            .collect::<Result<Vec<f64>>>()
            .with_context(|| format!("harvested power of '{}'", att.name))?;
        powers.push((att.name.clone(), power));
    }
    Ok(powers)
}

/// The single-nonlinear-mode model with the scenario's shakers (`eq:NM`).
pub fn reduced_model(
    setup: &Setup,
    table: &nlmode::nma::ModalTable,
    error: Option<nlmode::reduced::FrequencyError>,
) -> Result<nlmode::reduced::ReducedModel> {
    let m =
        nlmode::reduced::ReducedModel::new(table, &setup.response_point, &setup.exciter_points[0])?;
    with_attachments(m, setup, error)
}

/// `base`, the model of the modal table at the setup's response and first
/// exciter points without attachments ([`nlmode::reduced::ReducedModel::new`]),
/// with the scenario's shakers and the frequency error: [`reduced_model`]
/// with the table's interpolant built once (a study's samples share it).
pub fn with_attachments(
    base: nlmode::reduced::ReducedModel,
    setup: &Setup,
    error: Option<nlmode::reduced::FrequencyError>,
) -> Result<nlmode::reduced::ReducedModel> {
    let mut m = base;
    // the single-mode model's limit, named by the scenario's keys (the
    // model's own error names the attachment at which the count overflowed)
    let points: usize = setup
        .attachments
        .iter()
        .map(|a| a.interface_points.len())
        .sum();
    if points > nlmode::reduced::MAX_INTERFACE_POINTS {
        let exciters = setup.exciter_names.len();
        anyhow::bail!(
            "exciter: {exciters} [[exciter]] and {} [[attachment]] tables attach at {points} structure points \
             in total; expected at most {} for the single-nonlinear-mode model (methods nlmode, \
             linear-slowflow, linear-steady, imposed-force and the controllers' nlmode plant): \
             use fewer exciters or attachments",
            setup.attachments.len() - exciters,
            nlmode::reduced::MAX_INTERFACE_POINTS
        );
    }
    for (att, u) in setup.attachments.iter().zip(&setup.inputs) {
        m = m.with_linear_attachment(att, u)?;
    }
    if let Some(e) = error {
        m = m.with_frequency_error(e)?;
    }
    Ok(m)
}

fn slowflow_result(name: &str, wall: f64, res: &nlmode::reduced::SlowFlowResult) -> MethodResult {
    let s = &res.samples;
    let col =
        |f: fn(&nlmode::reduced::SlowFlowSample) -> f64| s.iter().map(f).collect::<Vec<f64>>();
    let env = Envelope::from(res);
    let mut r = MethodResult::new(name, wall, env, true);
    r.time_series = Some(crate::results::TimeSeries {
        columns: vec![
            ("t_s".into(), col(|x| x.t_s)),
            ("omega_rad_s".into(), col(|x| x.omega_rad_s)),
            ("a".into(), col(|x| x.a)),
            ("theta_rad".into(), col(|x| x.theta_rad())),
            (
                "modal_frequency_rad_s".into(),
                col(|x| x.modal_frequency_rad_s),
            ),
            ("tip_amplitude_m".into(), col(|x| x.tip_amplitude_m)),
            ("force_amplitude_N".into(), col(|x| x.force_amplitude_n)),
            ("force_phase_rad".into(), col(|x| x.force_phase_rad())),
        ],
    });
    r.summary.set("steps", res.stats.accepted_steps as u64);
    r.summary.set("status", format!("{:?}", res.status));
    if !matches!(res.status, nlmode::reduced::SweepStatus::Completed) {
        r.summary
            .warnings
            .push(format!("{name}: sweep stopped early: {:?}", res.status));
    }
    r
}

/// `nlmode` / `linear-slowflow` / `imposed-force`: slow flow of `eq:NM`.
pub fn slow_flow(
    name: &str,
    setup: &Setup,
    model: &nlmode::reduced::ReducedModel,
    options: &nlmode::reduced::SlowFlowOptions,
) -> Result<(MethodResult, nlmode::reduced::SlowFlowResult)> {
    let t0 = Instant::now();
    let res = model
        .simulate_sweep(&setup.sweep, options)
        .with_context(|| name.to_string())?;
    let wall = t0.elapsed().as_secs_f64();
    let mut r = slowflow_result(name, wall, &res);
    // harvested power of every piezo shunt from the quasi-steady attachment
    // states at the fundamental u_G = A phi_1(a) (eq:ansatz; harmonics neglected)
    let tab = model.table();
    for (a_idx, out) in &setup.outputs {
        let att = &setup.attachments[*a_idx];
        let pts = att
            .interface_points
            .iter()
            .map(|p| tab.point_index(p))
            .collect::<Result<Vec<_>, _>>()
            .with_context(|| format!("{name}: harvested power of '{}'", att.name))?;
        let power = res
            .samples
            .iter()
            .map(|x| {
                let u_g = pts
                    .iter()
                    .map(|&j| Ok(x.amplitude * tab.shape(j, 1, x.a)?))
                    .collect::<Result<Vec<Complex64>>>()?;
                attachment_output(
                    att,
                    out,
                    x.omega_rad_s,
                    &DVector::from_vec(u_g),
                    &DVector::zeros(0),
                )
            })
            .collect::<Result<Vec<f64>>>()
            .with_context(|| format!("{name}: harvested power of '{}'", att.name))?;
        r.add_output(&att.name, out.kind, power);
    }
    Ok((r, res))
}

/// [`slow_flow`] of a model with the scenario's exciters as its first
/// attachments (`nlmode`, `linear-slowflow`: [`reduced_model`]), with each
/// exciter's force as envelope columns ([`add_slowflow_exciter_forces`]).
pub fn exciter_slow_flow(
    name: &str,
    setup: &Setup,
    model: &nlmode::reduced::ReducedModel,
    options: &nlmode::reduced::SlowFlowOptions,
) -> Result<(MethodResult, nlmode::reduced::SlowFlowResult)> {
    let (mut r, res) = slow_flow(name, setup, model, options)?;
    add_slowflow_exciter_forces(&mut r, setup, model, &res)?;
    Ok((r, res))
}

/// With several exciters, each one's fundamental force on the structure along
/// the slow flow `res` of `model` (whose first ports are the exciters'
/// shakers, as [`reduced_model`] builds it: `eq:fc1`, `F = -Z_G u_G + T_G
/// u_hat` at the sample's `Omega` and modal amplitude) as the envelope columns
/// of [`MethodResult::add_exciter_forces`]; one exciter: nothing (its force is
/// `force_amplitude_N`).
pub fn add_slowflow_exciter_forces(
    r: &mut MethodResult,
    setup: &Setup,
    model: &nlmode::reduced::ReducedModel,
    res: &nlmode::reduced::SlowFlowResult,
) -> Result<()> {
    let n = setup.shakers.len();
    if n < 2 {
        return Ok(());
    }
    let mut forces = vec![Vec::with_capacity(res.samples.len()); n];
    for x in &res.samples {
        let f = model
            .interface_forces(x.omega_rad_s, setup.sweep.amplitude, x.amplitude)
            .with_context(|| format!("{}: exciter forces", r.name))?;
        for (out, fi) in forces.iter_mut().zip(&f) {
            out.push(fi[0]);
        }
    }
    r.add_exciter_forces(&setup.exciter_names, &forces);
    Ok(())
}

/// With the first-order terms (`[slowflow] rate_terms`): `rate_terms = true`
/// in the summary.
pub fn note_rate_terms(r: &mut MethodResult, opts: &nlmode::reduced::SlowFlowOptions) {
    if opts.rate_terms {
        r.summary.set("rate_terms", true);
    }
}

/// With residual modes (`[slowflow] residual_modes`): their number in the
/// summary (`residual_modes`) and a warning for each residual mode near an
/// integer multiple `k >= 2` of the sweep band: through the nonlinear element
/// it would exchange energy with the nonlinear mode (a `k:1` internal
/// resonance), which a linear residual mode does not carry.
pub fn note_residual_modes(
    r: &mut MethodResult,
    setup: &Setup,
    model: &nlmode::reduced::ReducedModel,
) {
    let Some(m) = model.residual_modes() else {
        return;
    };
    r.summary.set("residual_modes", m.len() as u64);
    let (a, b) = (setup.sweep.omega_start_rad_s, setup.sweep.omega_end_rad_s);
    let harmonics = model.table().harmonics().max(3);
    for (mode, k) in m.internal_resonances(a.min(b), a.max(b), harmonics, 0.05) {
        r.summary.warnings.push(format!(
            "{}: residual mode {} ({:.1} rad/s) lies within 5 % of {k} x the sweep band: a {k}:1 internal \
             resonance through the nonlinear element needs a second nonlinear mode; the residual \
             mode carries only its linear forced response",
            r.name,
            mode + 1,
            m.omega_rad_s()[mode]
        ));
    }
}
