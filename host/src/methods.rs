//! The sweep methods of `host run`: each returns a [`MethodResult`] following
//! the output contract. The physics is in `nlmode`; this is orchestration.
use crate::model::Setup;
use crate::results::{Envelope, MethodResult};
use crate::scenario::{CosimAlgorithm, Method};
use anyhow::{Context, Result};
use nalgebra::DVector;
use nlmode::frf;
use nlmode::Complex64;
use std::time::Instant;

/// Excitation frequencies of the steady-state methods: the sweep's range.
pub fn frf_omegas(setup: &Setup, n: usize) -> Vec<f64> {
    let (a, b) = (setup.sweep.omega_start_rad_s, setup.sweep.omega_end_rad_s);
    (0..n)
        .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
        .collect()
}

/// Mean power [W] a piezo shunt (attachment `att`, shunt resistance
/// `resistance_ohm`) harvests at the steady fundamental with interface
/// displacements `u_g` [m] at `omega_rad_s`: `mean(v^2 / R) = |v_hat|^2 / (2 R)`
/// with the electrode voltage `v_hat` = attachment state 1 recovered by
/// [`nlmode::attachment::LinearAttachment::states`] (no inputs: the shunt is passive).
pub fn shunt_power(
    att: &nlmode::attachment::LinearAttachment,
    resistance_ohm: f64,
    omega_rad_s: f64,
    u_g: &DVector<Complex64>,
    u_hat: &DVector<Complex64>,
) -> Result<f64> {
    let x = att.states(omega_rad_s, u_g, u_hat)?;
    Ok(x[1].norm_sqr() / (2.0 * resistance_ohm))
}

/// Harvested power of every piezo shunt of `setup` from the single-mode model
/// `model` at the points `(Omega, A)` (complex modal amplitude `A = a e^{i
/// theta}`): the shunt's interface displacements are the fundamentals
/// `A phi_1(a)` of the model (`eq:ansatz`; harmonics neglected) -> one
/// `(attachment name, power [W] per point)` per shunt.
pub fn modal_harvested_power(
    setup: &Setup,
    model: &nlmode::reduced::ReducedModel,
    points: &[(f64, Complex64)],
) -> Result<Vec<(String, Vec<f64>)>> {
    let mut out = Vec::new();
    for &(a_idx, resistance) in &setup.harvesters {
        let att = &setup.attachments[a_idx];
        let power = points
            .iter()
            .map(|&(w, amp)| {
                let u_g = att
                    .interface_points
                    .iter()
                    .map(|p| Ok(model.displacement_harmonics(p, amp)?[1]))
                    .collect::<Result<Vec<Complex64>>>()?;
                shunt_power(
                    att,
                    resistance,
                    w,
                    &DVector::from_vec(u_g),
                    &DVector::zeros(0),
                )
            })
            .collect::<Result<Vec<f64>>>()
            .with_context(|| format!("harvested power of '{}'", att.name))?;
        out.push((att.name.clone(), power));
    }
    Ok(out)
}

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
    for &(a, resistance) in &setup.harvesters {
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
                shunt_power(att, resistance, p.omega_rad_s, &u_g, &inputs[a])
            })
            .collect::<Result<Vec<f64>>>()
            .context("linear-frf: harvested power")?;
        r.add_harvested_power(&att.name, power);
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
    r.summary.force_drop = Some(drop);
    r.summary.force_drop_closed_form = Some(closed);
    r.summary.modal_mass_kg = Some(m_mod);
    r.summary.mass_ratio = Some(mu);
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
    r.summary.force_drop = Some(drop);
    r.summary.modal_mass_kg = Some(m_mod);
    r.summary.mass_ratio = Some(mu);
    Ok(r)
}

/// The nonlinear mode used by the single-mode methods.
pub struct Nma {
    pub table: nlmode::nma::ModalTable,
    pub wall_time_s: f64,
    /// One line describing how the table was obtained.
    pub note: String,
}

/// NMA of the scenario's structure (or the table file it names) on the mode
/// `setup.mode_index`, amplitude range at the response point, every named point
/// of the model (response point, exciter points) in the table; the primary
/// branch refined to [`RefineOptions`]' default accuracy and ended its
/// `fold_margin` before the first fold ([`nlmode::nma::NmaResult::refined_table`]).
///
/// [`RefineOptions`]: nlmode::nma::RefineOptions
pub fn nma_table(
    setup: &Setup,
    sc: &crate::scenario::Scenario,
    conservative: bool,
) -> Result<(Nma, Option<nlmode::nma::NmaResult>)> {
    use nlmode::nma::epmc::ModalBasis;
    use nlmode::nma::{
        nonlinear_modal_analysis_with_basis, AmplitudeRange, NmaOptions, RefineOptions, TablePolicy,
    };
    let t0 = Instant::now();
    if let Some(path) = &sc.nma.table {
        let table = nlmode::nma::ModalTable::read(std::path::Path::new(path))
            .with_context(|| "nma.table".to_string())?;
        let note = format!(
            "modal table read from {path} ({} points)",
            table.amplitude.len()
        );
        return Ok((
            Nma {
                table,
                wall_time_s: t0.elapsed().as_secs_f64(),
                note,
            },
            None,
        ));
    }
    let opts = NmaOptions {
        harmonics: sc.nma.harmonics,
        mode_index: setup.mode_index,
        amplitude: AmplitudeRange::Point {
            name: setup.response_point.clone(),
            start_m: crate::scenario::NMA_START_TIP_AMPLITUDE_M,
            end_m: sc.nma.max_tip_amplitude_m,
        },
        conservative,
        points: setup.model.points.iter().map(|p| p.name.clone()).collect(),
        // the refinement's Newton guesses
        store_coordinates: true,
        // the table is the primary branch: the loops beyond its fold are not computed
        stop_at_first_fold: true,
        ..Default::default()
    };
    let basis = std::sync::Arc::new(
        ModalBasis::new(&setup.model, conservative).map_err(|e| anyhow::anyhow!("nma: {e}"))?,
    );
    // a continuation failure keeps the branch computed so far (the note says so)
    let (res, failure) = match nonlinear_modal_analysis_with_basis(
        &setup.model,
        basis.clone(),
        &opts,
    ) {
        Ok(r) => (r, String::new()),
        Err(e) => match e.partial() {
            Some(p) if p.branch.len() >= 2 => {
                let b = p.branch.last().expect("non-empty");
                let w = format!(
                    "; warning: {e}; table from the branch computed so far (last point a = {:.4e}, omega = {:.2} rad/s)",
                    b.amplitude, b.omega_rad_s
                );
                (p.clone(), w)
            }
            _ => return Err(anyhow::anyhow!("nma: {e}")),
        },
    };
    let table = res
        .refined_table(
            &setup.model,
            basis,
            &opts,
            TablePolicy::PrimaryBranch,
            &RefineOptions::default(),
        )
        .map_err(|e| anyhow::anyhow!("nma: {e}"))?;
    let wall = t0.elapsed().as_secs_f64();
    let fold = match table.truncated_at_fold {
        Some(a) => format!(
            ", primary branch to the first fold a = {a:.4e}, tabulated up to a = {:.4e}",
            table.amplitude.last().copied().unwrap_or(f64::NAN)
        ),
        None => String::new(),
    };
    let acc = match &table.accuracy {
        Some(acc) => format!(
            ", PCHIP within omega {:.1e}, D {:.1e}, shapes {:.1e} (relative; {} HB checks{})",
            acc.omega_rel,
            acc.damping_rel,
            acc.shape_rel,
            acc.checks,
            if acc.capped { ", capped" } else { "" }
        ),
        None => String::new(),
    };
    let note = format!(
        "NMA (H = {}, {}): {} branch points, {} in the refined table{acc}, {} Newton iterations, {:.1} ms{fold}",
        res.harmonics,
        if conservative { "conservative" } else { "damped" },
        res.branch.len(),
        table.amplitude.len(),
        res.newton_iterations,
        1e3 * wall
    ) + &failure;
    Ok((
        Nma {
            table,
            wall_time_s: wall,
            note,
        },
        Some(res),
    ))
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
    r.summary.steps = Some(res.stats.accepted_steps as u64);
    r.summary.status = Some(format!("{:?}", res.status));
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
        .with_context(|| format!("{name}"))?;
    let wall = t0.elapsed().as_secs_f64();
    let mut r = slowflow_result(name, wall, &res);
    // harvested power of every piezo shunt from the quasi-steady attachment
    // states at the fundamental u_G = A phi_1(a) (eq:ansatz; harmonics neglected)
    let tab = model.table();
    for &(a_idx, resistance) in &setup.harvesters {
        let att = &setup.attachments[a_idx];
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
                shunt_power(
                    att,
                    resistance,
                    x.omega_rad_s,
                    &DVector::from_vec(u_g),
                    &DVector::zeros(0),
                )
            })
            .collect::<Result<Vec<f64>>>()
            .with_context(|| format!("{name}: harvested power of '{}'", att.name))?;
        r.add_harvested_power(&att.name, power);
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
    if !setup.harvesters.is_empty() {
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
    r.summary.force_drop = Some(ls.force_drop);
    r.summary.omega0_single_mode_rad_s = Some(ls.omega0_rad_s);
    Ok(r)
}

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
    for &(a, resistance) in &setup.harvesters {
        let series = &res.attachments[a];
        let power = series.state_amplitudes[1]
            .iter()
            .map(|v| v * v / (2.0 * resistance))
            .collect();
        r.add_harvested_power(&series.name, power);
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
    r.summary.steps = Some(res.stats.steps as u64);
    r.summary.rejected_steps = Some(res.stats.rejected as u64);
    r.summary.integrator = Some(format!("{method:?}"));
    Ok(r)
}

/// `cosim`: the structure and shaker FMUs co-simulated by the host's master.
///
/// `table`: the modal table of the scenario's own structure (a matrices
/// structure), written to `out/cosim_modal_table.json` and given to the
/// structure FMU by its `modal_table` parameter; `None`: the FMU's own table
/// (the paper beam's, in its `resources/`). The FMU reports `x_tip` at the
/// table's point `tip`; the table written gets the response point's shape under
/// that name (replacing a user point `tip` that is not the response point).
pub fn cosim(
    setup: &Setup,
    sc: &crate::scenario::Scenario,
    fmus: &(std::path::PathBuf, std::path::PathBuf),
    table: Option<(&nlmode::nma::ModalTable, &std::path::Path)>,
    progress: &mut dyn FnMut(f64),
) -> Result<MethodResult> {
    use cosim::{run_cosim, Algorithm, CosimParams};
    setup.check_cosim()?;
    let structure = sc
        .cosim
        .structure_fmu
        .as_ref()
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| fmus.0.clone());
    let shaker = sc
        .cosim
        .shaker_fmu
        .as_ref()
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| fmus.1.clone());
    let mut p = CosimParams::new(setup.shakers[0], setup.sweep);
    p.algorithm = match sc.cosim.algorithm {
        CosimAlgorithm::Jacobi => Algorithm::Jacobi,
        CosimAlgorithm::GaussSeidel => Algorithm::GaussSeidel,
        CosimAlgorithm::Iterative => Algorithm::Iterative,
    };
    p.macro_step_s = sc.cosim.macro_step_s;
    p.drive_point = setup.exciter_points[0].clone();
    if let Some((table, out)) = table {
        let mut t = table.clone();
        let tip = nlmode::structure::paper::TIP;
        if setup.response_point != tip {
            // the FMU's x_tip is the table's point `tip`: the response point's
            // shape under that name (a user point named `tip` gives way to it)
            anyhow::ensure!(
                p.drive_point != tip,
                "cosim: the exciter's point is named '{tip}' but output.response_point = '{}'; the structure FMU reports x_tip at the table point '{tip}': rename the point",
                setup.response_point
            );
            let mut alias = t
                .points
                .iter()
                .find(|q| q.name == setup.response_point)
                .context("cosim: the modal table lacks the response point")?
                .clone();
            alias.name = tip.into();
            t.points.retain(|q| q.name != tip);
            t.points.push(alias);
        }
        let path = out.join("cosim_modal_table.json");
        t.write(&path)?;
        p.modal_table = Some(std::fs::canonicalize(&path).unwrap_or(path));
    }
    let out = run_cosim(&structure, &shaker, &p, progress).context("cosim")?;
    let env = out.envelope.clone();
    let mut r = MethodResult::new(Method::Cosim.name(), out.wall_time_s, env, true);
    r.time_series = Some(crate::results::TimeSeries {
        columns: vec![
            ("t_s".into(), out.time_s.clone()),
            ("omega_rad_s".into(), out.omega_rad_s.clone()),
            ("voltage_V".into(), out.voltage_v.clone()),
            ("tip_m".into(), out.x_tip_m.clone()),
            ("drive_m".into(), out.x_m.clone()),
            ("force_N".into(), out.force_n.clone()),
            ("current_A".into(), out.current_a.clone()),
        ],
    });
    r.summary.algorithm = Some(sc.cosim.algorithm);
    r.summary.macro_step_s = Some(p.macro_step_s);
    r.summary.macro_steps = Some(out.stats.steps as u64);
    if let Some((t, msg)) = &out.stopped {
        r.summary
            .warnings
            .push(format!("cosim stopped at t = {t} s: {msg}"));
        r.summary.stopped_at_s = Some(*t);
    }
    Ok(r)
}
