//! The stepped-sine controlled tests of `host run` (issue 16):
//! `force-controlled` (`[force_control]`: the voltage holds the fundamental of
//! the force at the structure at `force_set_n`, [`nlmode::control::force`])
//! and `response-controlled` (`[response_control]`: the voltage holds the
//! drive-point response amplitude at each of `response_levels_m`,
//! [`nlmode::control::response`]), on the reference or the nlmode model.
//!
//! Outputs: `force_control.csv` / `response_control.csv`, one row per
//! frequency step (columns [`STEP_COLUMNS`], `response_control.csv` with
//! `response_set_m` first), `force_control.svg` (force and voltage against
//! `Omega/omega0`) and `response_control.svg` (the constant-response FRFs
//! `|x_drive,1| / |F_1|` against `Omega/omega0`, one curve per level).
use super::phase_resonance::plant;
use crate::model::Setup;
use crate::plot;
use crate::results::{Envelope, MethodResult};
use crate::scenario::{Method, Scenario, SteppedSpec};
use anyhow::{Context, Result};
use nlmode::control::{
    constant_response_peak, force_controlled_stepped_sine, response_controlled_stepped_sine,
    ForceControlResult, ForceStep,
};
use nlmode::nma::ModalTable;
use std::path::Path;
use std::time::Instant;

/// The columns of one step in `force_control.csv` and `response_control.csv`.
pub const STEP_COLUMNS: [&str; 11] = [
    "omega_rad_s",
    "eta",
    "voltage_v",
    "force_amplitude_N",
    "drive_amplitude_m",
    "tip_amplitude_m",
    "settled",
    "saturated",
    "periods",
    "corrections",
    "current_amplitude_A",
];

/// The frequencies' range (the band the plant's carried attachment states
/// are selected for).
fn band(omegas: &[f64]) -> (f64, f64) {
    omegas
        .iter()
        .fold((f64::INFINITY, 0.0), |(lo, hi), &w| (lo.min(w), hi.max(w)))
}

fn omegas(spec: &SteppedSpec, omega0: f64) -> Vec<f64> {
    let n = spec.steps;
    (0..n)
        .map(|i| {
            omega0 * (spec.eta_start + (spec.eta_end - spec.eta_start) * i as f64 / (n - 1) as f64)
        })
        .collect()
}

fn step_row(s: &ForceStep, omega0: f64) -> Vec<String> {
    let h = &s.harmonics;
    let f = |v: f64| v.to_string();
    vec![
        f(s.omega_rad_s),
        f(s.omega_rad_s / omega0),
        f(s.voltage_v),
        f(h.force_amplitude_n()),
        f(h.drive_amplitude_m()),
        f(h.tip_amplitude_m()),
        s.settled.to_string(),
        s.saturated.to_string(),
        s.periods.to_string(),
        s.corrections.to_string(),
        f(h.current_amplitude_a),
    ]
}

fn write_rows(path: &Path, header: &[&str], rows: &[Vec<String>]) -> Result<()> {
    let mut w = csv::Writer::from_path(path)
        .with_context(|| format!("cannot create {}", path.display()))?;
    let mut write = || -> Result<(), csv::Error> {
        w.write_record(header)?;
        for r in rows {
            w.write_record(r)?;
        }
        w.flush()?;
        Ok(())
    };
    write().with_context(|| format!("cannot write {}", path.display()))
}

/// The warnings of one controlled sweep: steps not settled or saturated, and
/// a failure that stopped it (the steps before it are kept).
fn warnings(
    method: &str,
    what: &str,
    res: &ForceControlResult,
    omega0: f64,
    out: &mut Vec<String>,
) {
    for s in &res.steps {
        if s.saturated {
            out.push(format!(
                "{method}{what}: step Omega/omega0 = {:.4} saturated at the voltage limit {} V \
                 (force {:.4e} N, drive amplitude {:.4e} m reached)",
                s.omega_rad_s / omega0,
                s.voltage_v,
                s.harmonics.force_amplitude_n(),
                s.harmonics.drive_amplitude_m()
            ));
        } else if !s.settled {
            out.push(format!(
                "{method}{what}: step Omega/omega0 = {:.4} did not reach its set value within {} \
                 periods ({} corrections, last voltage {} V); recorded with settled = false",
                s.omega_rad_s / omega0,
                s.periods,
                s.corrections,
                s.voltage_v
            ));
        }
    }
    if let Some((w, e)) = &res.failure {
        out.push(format!(
            "{method}{what}: stopped at Omega/omega0 = {:.4}: {e}; the {} steps before it are kept",
            w / omega0,
            res.steps.len()
        ));
    }
}

fn envelope(steps: &[&ForceStep]) -> Envelope {
    Envelope {
        omega_rad_s: steps.iter().map(|s| s.omega_rad_s).collect(),
        force_amplitude_n: steps
            .iter()
            .map(|s| s.harmonics.force_amplitude_n())
            .collect(),
        tip_amplitude_m: steps
            .iter()
            .map(|s| s.harmonics.tip_amplitude_m())
            .collect(),
        force_phase_rad: Some(steps.iter().map(|s| s.harmonics.force_n[1].arg()).collect()),
        drive_amplitude_m: Some(
            steps
                .iter()
                .map(|s| s.harmonics.drive_amplitude_m())
                .collect(),
        ),
        modal_amplitude: None,
        modal_frequency_rad_s: None,
    }
}

/// `host run`'s `force-controlled`: writes `force_control.csv` and the plot.
pub fn force_controlled(
    setup: &Setup,
    sc: &Scenario,
    table: &ModalTable,
    out: &Path,
) -> Result<MethodResult> {
    let stepped = &sc.force_control;
    let force_set_n = stepped.force_set_n();
    let w0 = setup.omega0_rad_s;
    let t0 = Instant::now();
    let ws = omegas(stepped, w0);
    let mut p = plant(
        setup,
        sc,
        table,
        stepped.model,
        stepped.samples_per_period,
        band(&ws),
    )?;
    let res = force_controlled_stepped_sine(
        p.as_plant(),
        &ws,
        force_set_n,
        stepped.voltage_start_v,
        &stepped.control,
    )
    .context("force-controlled")?;
    let wall = t0.elapsed().as_secs_f64();
    let rows: Vec<Vec<String>> = res.steps.iter().map(|s| step_row(s, w0)).collect();
    write_rows(&out.join("force_control.csv"), &STEP_COLUMNS, &rows)?;
    if sc.output.plots && !res.steps.is_empty() {
        let eta: Vec<f64> = res.steps.iter().map(|s| s.omega_rad_s / w0).collect();
        let f: Vec<f64> = res
            .steps
            .iter()
            .map(|s| s.harmonics.force_amplitude_n() / force_set_n)
            .collect();
        let u: Vec<f64> = res.steps.iter().map(|s| s.voltage_v).collect();
        plot::xy_plot(
            &out.join("force_control.svg"),
            &format!("Force control at {force_set_n} N: force held, voltage needed"),
            "Omega / omega0 [-]",
            "|F_1| / F_set [-], voltage [V]",
            &[
                plot::Curve {
                    label: "|F_1| / F_set".into(),
                    x: &eta,
                    y: &f,
                },
                plot::Curve {
                    label: "voltage amplitude [V]".into(),
                    x: &eta,
                    y: &u,
                },
            ],
            plot::Style::Dots,
        )?;
    }
    let steps: Vec<&ForceStep> = res.steps.iter().collect();
    let mut r = MethodResult::new(
        Method::ForceControlled.name(),
        wall,
        envelope(&steps),
        false,
    );
    warnings("force-controlled", "", &res, w0, &mut r.summary.warnings);
    Ok(r)
}

/// `host run`'s `response-controlled`: one stepped sine per level of
/// `response_levels_m`, from rest each; writes `response_control.csv` and the
/// plot; a warning names each level whose constant-response peak is not
/// inside its frequency range.
pub fn response_controlled(
    setup: &Setup,
    sc: &Scenario,
    table: &ModalTable,
    out: &Path,
) -> Result<MethodResult> {
    let stepped = &sc.response_control;
    let w0 = setup.omega0_rad_s;
    let t0 = Instant::now();
    let mut results = Vec::with_capacity(stepped.response_levels_m().len());
    let mut warns = Vec::new();
    for &x in stepped.response_levels_m() {
        let ws = omegas(stepped, w0);
        let mut p = plant(
            setup,
            sc,
            table,
            stepped.model,
            stepped.samples_per_period,
            band(&ws),
        )?;
        let res = response_controlled_stepped_sine(
            p.as_plant(),
            &ws,
            x,
            stepped.voltage_start_v,
            &stepped.control,
        )
        .context("response-controlled")?;
        warnings(
            "response-controlled",
            &format!(" at {x:e} m"),
            &res,
            w0,
            &mut warns,
        );
        if constant_response_peak(&res).is_none() {
            warns.push(format!(
                "response-controlled at {x:e} m: the least force is at an end of \
                 Omega/omega0 = {} ..= {} (or fewer than 3 steps settled): no peak of the \
                 constant-response FRF inside the range",
                stepped.eta_start, stepped.eta_end
            ));
        }
        results.push((x, res));
    }
    let wall = t0.elapsed().as_secs_f64();
    let mut header = vec!["response_set_m"];
    header.extend(STEP_COLUMNS);
    let rows: Vec<Vec<String>> = results
        .iter()
        .flat_map(|(x, res)| {
            res.steps.iter().map(move |s| {
                let mut r = vec![x.to_string()];
                r.extend(step_row(s, w0));
                r
            })
        })
        .collect();
    write_rows(&out.join("response_control.csv"), &header, &rows)?;
    if sc.output.plots {
        let data: Vec<(String, Vec<f64>, Vec<f64>)> = results
            .iter()
            .map(|(x, res)| {
                let eta = res.steps.iter().map(|s| s.omega_rad_s / w0).collect();
                let frf = res
                    .steps
                    .iter()
                    .map(|s| s.harmonics.drive_amplitude_m() / s.harmonics.force_amplitude_n())
                    .collect();
                (format!("|x_drive,1| = {x:e} m"), eta, frf)
            })
            .collect();
        let curves: Vec<plot::Curve> = data
            .iter()
            .map(|(l, x, y)| plot::Curve {
                label: l.clone(),
                x,
                y,
            })
            .collect();
        plot::xy_plot(
            &out.join("response_control.svg"),
            "Constant-response FRFs (response-controlled stepped sine)",
            "Omega / omega0 [-]",
            "|x_drive,1| / |F_1| [m/N]",
            &curves,
            plot::Style::Dots,
        )?;
    }
    let steps: Vec<&ForceStep> = results.iter().flat_map(|(_, r)| r.steps.iter()).collect();
    let mut r = MethodResult::new(
        Method::ResponseControlled.name(),
        wall,
        envelope(&steps),
        false,
    );
    r.summary.warnings = warns;
    Ok(r)
}
