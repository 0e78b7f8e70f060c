//! What every model of the phase-resonance test does with its measured
//! levels: `phase_resonance.csv`, the plots, the measured modal table and the
//! method's result; the numerical NMA at a measured amplitude.
use super::PHASE_RESONANCE_COLUMNS;
use crate::model::Setup;
use crate::plot;
use crate::results::{Envelope, MethodResult};
use crate::scenario::{Method, Scenario};
use anyhow::{Context, Result};
use nlmode::control::PllLevel;
use nlmode::nma::ModalTable;
use std::path::Path;

/// `omega(a)` \[rad/s\] and `D(a)` of the modal table at the amplitude `a`
/// where the tip's fundamental `a |phi_tip,1(a)|` equals `tip_m`
/// ([`amplitude_at_tip`]); `None` outside the table.
pub fn nma_at_tip_amplitude(table: &ModalTable, tip: &str, tip_m: f64) -> Option<(f64, f64)> {
    let a = amplitude_at_tip(table, tip, tip_m)?;
    let m = table.interpolator().ok()?.eval(a).ok()?;
    Some((m.omega_rad_s, m.damping_ratio))
}

/// The modal amplitude `a` \[sqrt(kg) m\] where the fundamental
/// `a |phi_tip,1(a)|` of the point `tip` equals `tip_m` \[m\] (first crossing
/// along the table, bisection inside the PCHIP interval); `None` outside the
/// table.
pub fn amplitude_at_tip(table: &ModalTable, tip: &str, tip_m: f64) -> Option<f64> {
    let interp = table.interpolator().ok()?;
    let p = table.point_index(tip).ok()?;
    let tip_at = |a: f64| interp.shape(p, 1, a).ok().map(|phi| a * phi.norm());
    let a = &table.amplitude;
    let j = (0..a.len() - 1).find(|&j| {
        let (lo, hi) = (tip_at(a[j]), tip_at(a[j + 1]));
        matches!((lo, hi), (Some(lo), Some(hi)) if lo <= tip_m && tip_m <= hi)
    })?;
    let (mut lo, mut hi) = (a[j], a[j + 1]);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if tip_at(mid)? < tip_m {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// What every model of the phase-resonance test does with its measured
/// `levels`: writes `phase_resonance.csv` and the plots into `out` and makes
/// the method's result (one envelope point per level) with a warning per level
/// that did not settle or lies outside the modal table, and one for a
/// `failure` `(voltage, message)` that ended the test. `label` starts the
/// warnings (e.g. `phase-resonance (cosim)`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn measured_levels_result(
    setup: &Setup,
    sc: &Scenario,
    table: &ModalTable,
    out: &Path,
    levels: &[PllLevel],
    failure: Option<&(f64, String)>,
    wall_time_s: f64,
    label: &str,
) -> Result<MethodResult> {
    let spec = &sc.phase_resonance;
    let nma: Vec<Option<(f64, f64)>> = levels
        .iter()
        .map(|l| nma_at_tip_amplitude(table, &setup.response_point, l.tip_amplitude_m()))
        .collect();
    write_csv(
        &out.join("phase_resonance.csv"),
        levels,
        &nma,
        spec.pll.harmonics,
    )?;
    if sc.output.plots && !levels.is_empty() {
        plots(out, setup, table, levels)?;
    }
    let measured = write_measured_table(setup, out, levels, label)?;
    let env = Envelope {
        omega_rad_s: levels.iter().map(|l| l.omega_rad_s).collect(),
        force_amplitude_n: levels.iter().map(|l| l.force_amplitude_n()).collect(),
        tip_amplitude_m: levels.iter().map(|l| l.tip_amplitude_m()).collect(),
        force_phase_rad: Some(
            levels
                .iter()
                .map(|l| l.harmonics.force_n[1].arg())
                .collect(),
        ),
        drive_amplitude_m: Some(levels.iter().map(|l| l.drive_amplitude_m()).collect()),
        modal_amplitude: None,
        modal_frequency_rad_s: None,
    };
    let mut r = MethodResult::new(Method::PhaseResonance.name(), wall_time_s, env, false);
    r.summary.warnings.extend(measured);
    for l in levels.iter().filter(|l| !l.settled) {
        r.summary.warnings.push(format!(
            "{label}: level {} V did not settle within {} periods (phase error {:.3e} rad, \
             amplitude change {:.3e} per period; tolerances {:.1e} rad, {:.1e}); recorded with settled = false",
            l.voltage_v,
            l.periods,
            l.phase_error_rad,
            l.amplitude_change,
            spec.pll.phase_tolerance_rad,
            spec.pll.amplitude_tolerance
        ));
    }
    if let Some((u, e)) = failure {
        r.summary.warnings.push(format!(
            "{label}: stopped at level {u} V: {e}; the {} levels before it are kept",
            levels.len()
        ));
    }
    for (l, n) in levels.iter().zip(&nma) {
        if n.is_none() {
            r.summary.warnings.push(format!(
                "{label}: level {} V: |q_tip,1| = {:.4e} m lies outside the modal table \
                 (nma.max_tip_amplitude_m = {} m)",
                l.voltage_v,
                l.tip_amplitude_m(),
                sc.nma.max_tip_amplitude_m
            ));
        }
    }
    Ok(r)
}

/// The name of the measured modal table in the phase-resonance output folder.
pub const MEASURED_TABLE_FILE: &str = "modal_table.json";

/// Writes the measured modal table of `levels` to `out/modal_table.json`
/// (drive point: the first exciter's point; response point: the scenario's)
/// and returns the warnings: each level left out, or why no table could be
/// made (then no file is written; a stale one is removed).
fn write_measured_table(
    setup: &Setup,
    out: &Path,
    levels: &[PllLevel],
    label: &str,
) -> Result<Vec<String>> {
    let path = out.join(MEASURED_TABLE_FILE);
    let drive = &setup.exciter_points[0];
    match nlmode::control::modal_table_from_phase_resonance(levels, drive, &setup.response_point) {
        Ok(m) => {
            m.table
                .write(&path)
                .with_context(|| format!("{label}: measured modal table"))?;
            Ok(m.skipped
                .iter()
                .map(|s| {
                    format!(
                        "{label}: level {} V left out of {MEASURED_TABLE_FILE}: {}",
                        s.voltage_v, s.reason
                    )
                })
                .collect())
        }
        Err(e) => {
            if path.exists() {
                std::fs::remove_file(&path)
                    .with_context(|| format!("cannot remove stale {}", path.display()))?;
            }
            Ok(vec![format!(
                "{label}: no {MEASURED_TABLE_FILE} written: {e}"
            )])
        }
    }
}

pub(crate) fn write_csv(
    path: &Path,
    levels: &[PllLevel],
    nma: &[Option<(f64, f64)>],
    harmonics: usize,
) -> Result<()> {
    let mut header: Vec<String> = PHASE_RESONANCE_COLUMNS
        .iter()
        .map(|s| s.to_string())
        .collect();
    header.extend(
        [
            "nma_omega_rad_s",
            "nma_damping_ratio",
            "phase_error_rad",
            "periods",
            "current_amplitude_A",
        ]
        .map(String::from),
    );
    for sig in ["tip", "drive", "force"] {
        for n in 2..=harmonics {
            header.push(format!("{sig}_h{n}_ratio"));
        }
    }
    let mut w = csv::Writer::from_path(path)
        .with_context(|| format!("cannot create {}", path.display()))?;
    let write = |w: &mut csv::Writer<std::fs::File>| -> Result<(), csv::Error> {
        w.write_record(&header)?;
        for (l, n) in levels.iter().zip(nma) {
            let f = |v: f64| v.to_string();
            let mut row = vec![
                f(l.tip_amplitude_m()),
                f(l.drive_amplitude_m()),
                f(l.omega_rad_s),
                f(l.damping_ratio),
                f(l.force_amplitude_n()),
                f(l.voltage_v),
                l.settled.to_string(),
                n.map(|n| f(n.0)).unwrap_or_default(),
                n.map(|n| f(n.1)).unwrap_or_default(),
                f(l.phase_error_rad),
                l.periods.to_string(),
                f(l.harmonics.current_amplitude_a),
            ];
            for h in [
                &l.harmonics.tip_m,
                &l.harmonics.drive_m,
                &l.harmonics.force_n,
            ] {
                for n in 2..=harmonics {
                    row.push(f(h[n].norm() / h[1].norm()));
                }
            }
            w.write_record(&row)?;
        }
        w.flush()?;
        Ok(())
    };
    write(&mut w).with_context(|| format!("cannot write {}", path.display()))
}

/// The measured backbone and damping over the NMA's, against `|q_tip,1|`.
pub(crate) fn plots(
    out: &Path,
    setup: &Setup,
    table: &ModalTable,
    levels: &[PllLevel],
) -> Result<()> {
    let w0 = setup.omega0_rad_s;
    let tip_max = levels
        .iter()
        .map(|l| l.tip_amplitude_m())
        .fold(0.0, f64::max);
    let p = table.point_index(&setup.response_point)?;
    let shape = &table.points[p];
    let mut nma_tip = Vec::new();
    let (mut nma_w, mut nma_d) = (Vec::new(), Vec::new());
    for j in 0..table.amplitude.len() {
        let tip = table.amplitude[j] * shape.re[j][1].hypot(shape.im[j][1]);
        if tip > 1.5 * tip_max {
            break;
        }
        nma_tip.push(tip);
        nma_w.push(table.omega_rad_s[j] / w0);
        nma_d.push(100.0 * table.damping_ratio[j]);
    }
    let tip: Vec<f64> = levels.iter().map(|l| l.tip_amplitude_m()).collect();
    let w: Vec<f64> = levels.iter().map(|l| l.omega_rad_s / w0).collect();
    let d: Vec<f64> = levels.iter().map(|l| 100.0 * l.damping_ratio).collect();
    plot::xy_plot(
        &out.join("phase_resonance_backbone.svg"),
        "Phase-resonance backbone over the numerical NMA",
        "|q_tip,1| [m]",
        "omega / omega0 [-]",
        &curves(&nma_tip, &nma_w, &tip, &w),
        plot::Style::LinesLogX,
    )?;
    plot::xy_plot(
        &out.join("phase_resonance_damping.svg"),
        "Modal damping ratio from the power balance at phase resonance",
        "|q_tip,1| [m]",
        "D [%]",
        &curves(&nma_tip, &nma_d, &tip, &d),
        plot::Style::LinesLogX,
    )
}

/// The NMA's curve and the measured one.
fn curves<'a>(
    nma_x: &'a [f64],
    nma_y: &'a [f64],
    x: &'a [f64],
    y: &'a [f64],
) -> Vec<plot::Curve<'a>> {
    vec![
        plot::Curve {
            label: "numerical NMA".into(),
            x: nma_x,
            y: nma_y,
        },
        plot::Curve {
            label: "phase resonance (PLL), measured".into(),
            x,
            y,
        },
    ]
}
