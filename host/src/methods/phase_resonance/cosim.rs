//! `phase-resonance` with `[phase_resonance] model = "cosim"`: the
//! phase-locked loop as the controller FMU (`controller.fmu`, crate
//! `fmu-controller`) closing the loop around the structure FMU (the single
//! nonlinear mode of the scenario's modal table) and the shaker FMU
//! (`use_external_voltage = true`), co-simulated by the master of
//! [`cosim::master`] with `[cosim] algorithm` and `macro_step_s` (the
//! iterative one with rollback for the stiff stinger at larger steps):
//!
//! ```text
//! structure.x -> shaker.x, structure.v -> shaker.v, shaker.F -> structure.F,
//! structure.x -> controller.x_drive, shaker.F -> controller.F_meas,
//! structure.x_tip -> controller.x_tip, shaker.I -> controller.I_meas,
//! controller.u_ext -> shaker.u_ext.
//! ```
//!
//! The host steps the voltage levels: it sets the controller's tunable
//! `u_hat` to the next level at the communication point where `level_done`
//! becomes true (the new voltage applies from the next period start) and
//! records the level from the controller's outputs of that point (the last
//! period's harmonics, frequency, damping). The FMUs are packaged from the
//! built libraries (beside the executable or in `NLMODE_FMU_DIR`) into
//! `DIR/phase_resonance_fmus/`, with the scenario's modal table in the
//! structure FMU. `phase_resonance.csv` and the plots are those of
//! [`super`].
use crate::fmus::structure_shaker::{connections, parameters, CosimParams};
use crate::fmus::{locate_libraries, locate_library, package_controller_fmu, package_repo_fmus};
use crate::model::Setup;
use crate::results::MethodResult;
use crate::scenario::{CosimAlgorithm, Scenario};
use anyhow::{anyhow, bail, Context, Result};
use controller_vr::*;
use cosim::import::Fmu;
use cosim::master::{Algorithm, Master, MasterOptions, ParamValue};
use nlmode::control::PllLevel;
use nlmode::nma::ModalTable;
use nlmode::Complex64;
use std::path::Path;
use std::time::Instant;

/// The controller FMU's value references used here (its
/// `modelDescription/controller/modelDescription.xml`, tested against the
/// FMU crate; the host reads them by name at load time).
mod controller_vr {
    pub const OUTPUTS: [&str; 10] = [
        "phase_error",
        "amplitude_change",
        "damping_ratio",
        "power",
        "I_amplitude",
        "record_voltage",
        "record_Omega",
        "record_time",
        "Omega",
        "u_ext",
    ];
    /// Highest harmonic the controller FMU outputs.
    pub const MAX_HARMONICS: usize = 5;
}

/// What the co-simulated test measured: the levels, the failure that ended
/// it early, the master's counters.
pub struct CosimPll {
    pub levels: Vec<PllLevel>,
    /// `(voltage of the failing level, message)`.
    pub failure: Option<(f64, String)>,
    pub macro_steps: usize,
    pub wall_time_s: f64,
}

/// The connections of the closed loop (module docs).
pub fn loop_connections() -> Vec<(String, String)> {
    let mut c = connections();
    for (a, b) in [
        ("structure.x", "controller.x_drive"),
        ("shaker.F", "controller.F_meas"),
        ("structure.x_tip", "controller.x_tip"),
        ("shaker.I", "controller.I_meas"),
        ("controller.u_ext", "shaker.u_ext"),
    ] {
        c.push((a.into(), b.into()));
    }
    c
}

/// `host run`'s `phase-resonance` for `model = "cosim"`: packages the three
/// FMUs, runs the loop through the levels, writes `phase_resonance.csv` and
/// the plots into `out`, returns the method's envelope and summary.
pub fn phase_resonance(
    setup: &Setup,
    sc: &Scenario,
    table: &ModalTable,
    out: &Path,
) -> Result<MethodResult> {
    let run = run_levels(setup, sc, table, out).context("phase-resonance (model = \"cosim\")")?;
    let mut r = super::levels::measured_levels_result(
        setup,
        sc,
        table,
        out,
        &run.levels,
        run.failure.as_ref(),
        run.wall_time_s,
        "phase-resonance (cosim)",
    )?;
    r.summary.set("steps", run.macro_steps as u64);
    r.summary.set("algorithm", sc.cosim.algorithm);
    if sc.cosim.harmonic_force_projection {
        r.summary.set("harmonic_force_projection", true);
    } else {
        r.summary
            .warnings
            .extend(run.levels.iter().filter_map(harmonic_power_warning));
    }
    Ok(r)
}

/// Share of the input power above which [`harmonic_power_warning`] names
/// the remedy: the force fundamental of the default projection reads low
/// by about this share (1 % is the accuracy the test is held to).
const HARMONIC_POWER_SHARE: f64 = 0.01;

/// A warning when the force's higher harmonics do work on the drive
/// point's higher harmonics (`P_h = Re(F_h conj(i h Omega X_h))/2`, `h >=
/// 2`) worth more than [`HARMONIC_POWER_SHARE`] of the fundamental's: the
/// structure FMU's default projection on the mode's fundamental (`eq:NM`)
/// does not take that power, so its force fundamental at phase resonance
/// is low by about the share; `[cosim] harmonic_force_projection` takes it.
fn harmonic_power_warning(level: &nlmode::control::PllLevel) -> Option<String> {
    let h = &level.harmonics;
    let power = |k: usize| {
        let (f, x) = (h.force_n.get(k)?, h.drive_m.get(k)?);
        let v = nlmode::Complex64::new(0.0, k as f64 * level.omega_rad_s) * x;
        Some(0.5 * (f * v.conj()).re)
    };
    let p1 = power(1)?.abs();
    let higher: f64 = (2..h.force_n.len()).filter_map(power).sum();
    let share = higher.abs() / p1;
    (p1 > 0.0 && share > HARMONIC_POWER_SHARE).then(|| {
        format!(
            "phase-resonance (cosim) at {} V: the force's harmonics h >= 2 work on the drive point's \
             ({:.1} % of the fundamental's power), which the structure FMU's projection on the mode's \
             fundamental does not take: its force fundamental reads low by about that share; set \
             [cosim] harmonic_force_projection = true",
            level.voltage_v,
            100.0 * share
        )
    })
}

/// Packages the FMUs into `out/phase_resonance_fmus/` and runs the closed
/// loop through `[phase_resonance] voltage_levels_v`. A master failure ends
/// the test with the levels measured so far (`CosimPll::failure`).
pub fn run_levels(
    setup: &Setup,
    sc: &Scenario,
    table: &ModalTable,
    out: &Path,
) -> Result<CosimPll> {
    let spec = &sc.phase_resonance;
    setup.check_cosim()?;
    let h_max = spec.pll.harmonics;
    if h_max > MAX_HARMONICS {
        bail!(
            "phase_resonance.pll.harmonics = {h_max}: the controller FMU demodulates at most \
             {MAX_HARMONICS} harmonics (model = \"cosim\")"
        );
    }
    // the FMUs, with the scenario's modal table in the structure FMU
    let dir = out.join("phase_resonance_fmus");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let table_path = dir.join("modal_table.json");
    tip_aliased(table, setup)?.write(&table_path)?;
    let libs = locate_libraries(None)?;
    let controller_lib = locate_library(None, &crate::fmus::CONTROLLER)?;
    let (structure_fmu, shaker_fmu) = package_repo_fmus(&libs, &dir, Some(&table_path))?;
    let controller_fmu = package_controller_fmu(&controller_lib, &dir)?;
    let _ = std::fs::remove_file(&table_path);

    let load = |p: &Path| Fmu::load(p).with_context(|| format!("loading {}", p.display()));
    let h = sc.cosim.macro_step_s;
    let opts = MasterOptions {
        algorithm: master_algorithm(sc.cosim.algorithm),
        macro_step_s: h,
        ..Default::default()
    };
    let mut m = Master::new(
        vec![
            ("structure".into(), load(&structure_fmu)?),
            ("shaker".into(), load(&shaker_fmu)?),
            ("controller".into(), load(&controller_fmu)?),
        ],
        &loop_connections(),
        opts,
    )?;
    set_parameters(&mut m, setup, sc)?;
    let o = &spec.pll;
    let omega_start = spec.eta_start * setup.omega0_rad_s;
    m.initialize(0.0, None)?;

    let c = m.unit_index("controller").expect("controller unit");
    let md = &m.units[c].fmu.md;
    let vr = |name: &str| -> Result<u32> {
        Ok(md
            .variable(name)
            .with_context(|| format!("controller FMU variable {name}"))?
            .value_reference)
    };
    let out_vrs: Vec<u32> = OUTPUTS.iter().map(|n| vr(n)).collect::<Result<_>>()?;
    let mut harm_vrs = Vec::new();
    for sig in ["F", "x_drive", "x_tip"] {
        for k in 0..=h_max {
            harm_vrs.push(vr(&format!("{sig}_h{k}_re"))?);
            harm_vrs.push(vr(&format!("{sig}_h{k}_im"))?);
        }
    }
    let (vr_done, vr_settled, vr_periods, vr_u_hat) = (
        vr("level_done")?,
        vr("settled")?,
        vr("periods")?,
        vr("u_hat")?,
    );

    let wall = Instant::now();
    let mut levels = Vec::new();
    let mut failure = None;
    let mut steps = 0usize;
    // a level ends within max_periods_per_level periods (the controller's own
    // cap); the time cap guards against a loop that drifted far below omega_start
    let per_level_s =
        (o.max_periods_per_level as f64 + 2.0) * std::f64::consts::TAU / (0.25 * omega_start);
    'levels: for (i, &u) in spec.voltage_levels_v.iter().enumerate() {
        if i > 0 {
            m.units[c].inst.set_real(&[vr_u_hat], &[u])?;
        }
        let t_end = m.time() + per_level_s;
        loop {
            if let Err(e) = m.step() {
                failure = Some((u, format!("at t = {} s: {e}", m.time())));
                break 'levels;
            }
            steps += 1;
            let mut done = [false];
            m.units[c].inst.get_boolean(&[vr_done], &mut done)?;
            if done[0] {
                break;
            }
            if m.time() > t_end {
                failure = Some((
                    u,
                    format!(
                        "the level did not end within {per_level_s:.3} s of simulated time \
                         (Omega dropped below omega_start / 4?)"
                    ),
                ));
                break 'levels;
            }
        }
        let mut v = vec![0.0; out_vrs.len()];
        m.units[c].inst.get_real(&out_vrs, &mut v)?;
        let mut hv = vec![0.0; harm_vrs.len()];
        m.units[c].inst.get_real(&harm_vrs, &mut hv)?;
        let mut settled = [false];
        m.units[c].inst.get_boolean(&[vr_settled], &mut settled)?;
        let mut periods = [0i32];
        m.units[c].inst.get_integer(&[vr_periods], &mut periods)?;
        let sig = |s: usize| -> Vec<Complex64> {
            (0..=h_max)
                .map(|k| {
                    let j = 2 * (s * (h_max + 1) + k);
                    Complex64::new(hv[j], hv[j + 1])
                })
                .collect()
        };
        levels.push(PllLevel {
            voltage_v: v[5],
            settled: settled[0],
            periods: periods[0].max(0) as usize,
            time_s: v[7],
            omega_rad_s: v[6],
            phase_error_rad: v[0],
            amplitude_change: v[1],
            damping_ratio: v[2],
            power_w: v[3],
            harmonics: nlmode::control::PeriodHarmonics {
                force_n: sig(0),
                drive_m: sig(1),
                tip_m: sig(2),
                current_amplitude_a: v[4],
            },
        });
    }
    Ok(CosimPll {
        levels,
        failure,
        macro_steps: steps,
        wall_time_s: wall.elapsed().as_secs_f64(),
    })
}

/// The parameters of the three units: the paper's pairing with the shaker
/// on the external voltage and the controller's loop settings.
fn set_parameters(m: &mut Master, setup: &Setup, sc: &Scenario) -> Result<()> {
    let spec = &sc.phase_resonance;
    let mut p = CosimParams::new(setup.shakers[0], setup.sweep);
    p.drive_point = setup.exciter_points[0].clone();
    p.residual_modes = sc.cosim.residual_modes;
    p.harmonic_force_projection = sc.cosim.harmonic_force_projection;
    let mut params = parameters(&p)?;
    params.retain(|(n, _)| n != "shaker.use_external_voltage");
    params.push((
        "shaker.use_external_voltage".into(),
        ParamValue::Boolean(true),
    ));
    let o = &spec.pll;
    let u0 = spec.voltage_levels_v[0];
    let omega_start = spec.eta_start * setup.omega0_rad_s;
    for (n, v) in [
        ("u_hat", u0),
        ("omega_start", omega_start),
        ("kp", o.kp),
        ("ki", o.ki),
        ("max_step_ratio", o.max_step_ratio),
        ("phase_tolerance", o.phase_tolerance_rad),
        ("amplitude_tolerance", o.amplitude_tolerance),
        ("drive_modal_mass", setup.modal_masses[0].0),
    ] {
        params.push((format!("controller.{n}"), ParamValue::Real(v)));
    }
    let int = |name: &str, v: usize| -> Result<(String, ParamValue)> {
        let v = i32::try_from(v).map_err(|_| {
            anyhow!("phase_resonance: {name} = {v} exceeds the controller FMU's Integer")
        })?;
        Ok((format!("controller.{name}"), ParamValue::Integer(v)))
    };
    params.push(int("settle_periods", o.settle_periods)?);
    params.push(int("max_periods_per_level", o.max_periods_per_level)?);
    params.push(int("harmonics", o.harmonics)?);
    params.push(int("samples_per_period", spec.samples_per_period)?);
    for (ep, v) in &params {
        let (u, name) = ep.split_once('.').expect("unit.variable");
        let ui = m.unit_index(u).expect("the three units");
        m.set_parameter(ui, name, v)
            .with_context(|| format!("setting {ep}"))?;
    }
    Ok(())
}

/// The master algorithm of `[cosim] algorithm`.
fn master_algorithm(a: CosimAlgorithm) -> Algorithm {
    match a {
        CosimAlgorithm::Jacobi => Algorithm::Jacobi,
        CosimAlgorithm::GaussSeidel => Algorithm::GaussSeidel,
        CosimAlgorithm::Iterative => Algorithm::Iterative,
    }
}

/// The table with the response point also under the structure FMU's tip
/// name (its `x_tip` output), as `host run`'s `cosim` method writes it.
fn tip_aliased(table: &ModalTable, setup: &Setup) -> Result<ModalTable> {
    let mut t = table.clone();
    let tip = nlmode::structure::paper::TIP;
    if t.points.iter().all(|q| q.name != tip) {
        let mut alias = t
            .points
            .iter()
            .find(|q| q.name == setup.response_point)
            .context("the modal table lacks the response point")?
            .clone();
        alias.name = tip.into();
        t.points.push(alias);
    }
    Ok(t)
}
