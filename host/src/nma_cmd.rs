//! `host nma` and `host frf`: the nonlinear mode (table, backbone plots) and
//! the steady-state frequency responses of the single-nonlinear-mode model.
use crate::methods;
use crate::model::Setup;
use crate::plot::{self, Curve};
use crate::results::write_csv;
use crate::run::load_scenario;
use anyhow::{Context, Result};
use nlmode::nma::modal_basis::ModalBasis;
use nlmode::nma::{
    nonlinear_modal_analysis_with_basis, BackboneOptions, FoldKind, NmaOptions, NmaResult,
};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// Loop label of every branch point: `1:n with mode k` inside a loop (from an
/// amplitude maximum to the next minimum), empty elsewhere.
fn loop_labels(r: &NmaResult) -> Vec<String> {
    let mut labels = vec![String::new(); r.branch.len()];
    for (i, f) in r.folds.iter().enumerate() {
        if let Some(ir) = &f.internal_resonance {
            let end = r.folds[i + 1..]
                .iter()
                .find(|g| g.kind == FoldKind::AmplitudeMinimum)
                .map(|g| g.index)
                .unwrap_or(r.branch.len() - 1);
            for l in &mut labels[f.index..=end] {
                *l = format!("1:{} mode {}", ir.harmonic, ir.mode_index + 1);
            }
        }
    }
    labels
}

/// `<name>_branch.csv`: every branch point with the energy shares and the
/// loop it belongs to.
fn branch_csv(out: &Path, name: &str, r: &NmaResult, point: &str) -> Result<()> {
    use std::io::Write;
    let tip = r
        .point_fundamental_amplitude(point)
        .context("branch has no response point")?;
    let path = out.join(format!("{name}_branch.csv"));
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(&path)
            .with_context(|| format!("cannot create {}", path.display()))?,
    );
    let h = r.harmonics;
    write!(f, "amplitude,tip_amplitude_m,omega_rad_s,omega_over_omega0,damping_ratio,secondary_harmonic,secondary_mode,loop")?;
    for n in 1..=h {
        write!(f, ",energy_share_h{n}")?;
    }
    writeln!(f)?;
    let labels = loop_labels(r);
    for (i, b) in r.branch.iter().enumerate() {
        write!(
            f,
            "{:e},{:e},{},{},{:e},{},{},{}",
            b.amplitude,
            tip[i],
            b.omega_rad_s,
            b.omega_rad_s / r.linear_omega_rad_s,
            b.damping_ratio,
            b.secondary.harmonic,
            b.secondary.mode_index + 1,
            labels[i]
        )?;
        for n in 1..=h {
            write!(
                f,
                ",{:e}",
                b.harmonic_energy_shares.get(n).copied().unwrap_or(0.0)
            )?;
        }
        writeln!(f)?;
    }
    f.flush()?;
    Ok(())
}

fn report(label: &str, r: &NmaResult, wall: f64) {
    println!(
        "{label}: H = {}, {} branch points ({} Newton iterations, {} rejected steps), {:.1} ms, omega up to {:.3} omega0",
        r.harmonics,
        r.branch.len(),
        r.newton_iterations,
        r.rejected_steps,
        1e3 * wall,
        r.branch
            .iter()
            .map(|b| b.omega_rad_s)
            .fold(0.0, f64::max)
            / r.linear_omega_rad_s
    );
    let mut n = 0;
    for (i, f) in r.folds.iter().enumerate() {
        if let Some(ir) = &f.internal_resonance {
            n += 1;
            let min = r.folds[i + 1..]
                .iter()
                .find(|g| g.kind == FoldKind::AmplitudeMinimum);
            println!(
                "  loop {n}: {ir}; a from {:.4e} (omega = {:.2} rad/s) down to {}",
                f.amplitude,
                f.omega_rad_s,
                match min {
                    Some(m) => format!(
                        "{:.4e} (omega = {:.2} rad/s) and back",
                        m.amplitude, m.omega_rad_s
                    ),
                    None => "the end of the branch".to_string(),
                }
            );
        }
    }
    if n == 0 {
        println!("  no loop on the computed branch");
    }
    for w in &r.warnings {
        println!("  warning: {w}");
    }
}

/// Run an analysis; on a continuation failure print the warning with its
/// numbers and go on with the branch computed so far.
fn analyse(
    model: &nlmode::structure::StructuralModel,
    basis: Arc<ModalBasis>,
    opts: &NmaOptions,
    label: &str,
) -> Result<NmaResult> {
    match nonlinear_modal_analysis_with_basis(model, basis, opts) {
        Ok(r) => Ok(r),
        Err(e) => match e.partial() {
            Some(p) if !p.branch.is_empty() => {
                let b = p.branch.last().expect("non-empty");
                println!(
                    "warning: {label}: {e}; last point a = {:.4e}, omega = {:.2} rad/s, fundamental energy share {:.3e}, secondary {}:{} with mode {} ({:.3e}); the branch so far is written and plotted",
                    b.amplitude,
                    b.omega_rad_s,
                    b.fundamental_energy_share,
                    1,
                    b.secondary.harmonic,
                    b.secondary.mode_index + 1,
                    b.secondary.share
                );
                Ok(p.clone())
            }
            _ => Err(anyhow::anyhow!("nma ({label}): {e}")),
        },
    }
}

/// `host nma [SCENARIO] -o DIR`: the refined modal table (damped primary
/// branch to the first fold), and the backbones through the internal-resonance
/// loops (damped, and conservative if `nma.conservative`) with plots.
pub fn nma(path: Option<&Path>, out: &Path) -> Result<()> {
    let (sc, source) = load_scenario(path)?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let setup = Setup::new(&sc).with_context(|| format!("scenario {source}"))?;
    println!("scenario: {source}");
    println!(
        "structure: {} DOFs, omega0 = {:.2} rad/s",
        setup.model.ndof(),
        setup.omega0_rad_s
    );
    let points: Vec<String> = setup.model.points.iter().map(|p| p.name.clone()).collect();
    // the modal table: damped primary branch, refined (as `host run` makes it)
    let table_sc = crate::scenario::Scenario {
        nma: crate::scenario::NmaSpec {
            table: None,
            ..sc.nma.clone()
        },
        ..sc.clone()
    };
    let (nma, _) = methods::nma_table(&setup, &table_sc, false)?;
    println!("modal table: {}", nma.note);
    for w in &nma.warnings {
        println!("  warning: {w}");
    }
    let table = nma.table;
    // the backbones at the table's order (`harmonics = "auto"`: the chosen one)
    let h = table.harmonics;
    let basis_d =
        Arc::new(ModalBasis::new(&setup.model, false).map_err(|e| anyhow::anyhow!("nma: {e}"))?);
    let table_path = out.join("modal_table.json");
    write_table(&table, &table_path, &setup)?;
    // backbones through the loops
    let bb = BackboneOptions {
        harmonics: h,
        ..Default::default()
    };
    let mut branches: Vec<(&str, NmaResult)> = vec![];
    let kinds: &[(&str, bool)] = if sc.nma.conservative {
        &[("conservative", true), ("damped", false)]
    } else {
        &[("damped", false)]
    };
    for &(label, conservative) in kinds {
        let basis = if conservative {
            Arc::new(ModalBasis::new(&setup.model, true).map_err(|e| anyhow::anyhow!("nma: {e}"))?)
        } else {
            basis_d.clone()
        };
        let opts = NmaOptions {
            points: points.clone(),
            store_coordinates: false,
            mode_index: setup.mode_index,
            samples: sc.nma.samples,
            ..bb.nma_options(conservative)
        };
        let t0 = Instant::now();
        let r = analyse(&setup.model, basis, &opts, label)?;
        report(label, &r, t0.elapsed().as_secs_f64());
        branch_csv(out, label, &r, &setup.response_point)?;
        branches.push((label, r));
    }
    /// (label, tip amplitude, Omega / omega0, damping ratio [%]) of a branch.
    type Series = (String, Vec<f64>, Vec<f64>, Vec<f64>);
    let series: Vec<Series> = branches
        .iter()
        .map(|(label, r)| {
            let tip = r
                .point_fundamental_amplitude(&setup.response_point)
                .unwrap_or_default();
            let w = r
                .branch
                .iter()
                .map(|b| b.omega_rad_s / setup.omega0_rad_s)
                .collect();
            let d = r.branch.iter().map(|b| 100.0 * b.damping_ratio).collect();
            let label = if *label == "damped" {
                format!("damped (D0 = {:.2} %)", 100.0 * setup.d0)
            } else {
                label.to_string()
            };
            (label, tip, w, d)
        })
        .collect();
    let curves_w: Vec<Curve> = series
        .iter()
        .map(|(l, tip, w, _)| Curve {
            label: l.clone(),
            x: tip,
            y: w,
        })
        .collect();
    plot::xy_plot(
        &out.join("backbone.svg"),
        &format!("Modal frequency vs amplitude (H = {h}), internal-resonance loops"),
        "|q_tip,1| [m]",
        "omega / omega0 [-]",
        &curves_w,
        plot::Style::LinesLogX,
    )?;
    let curves_d: Vec<Curve> = series
        .iter()
        .filter(|(l, ..)| l.starts_with("damped"))
        .map(|(l, tip, _, d)| Curve {
            label: l.clone(),
            x: tip,
            y: d,
        })
        .collect();
    plot::xy_plot(
        &out.join("damping.svg"),
        "Modal damping ratio vs amplitude",
        "|q_tip,1| [m]",
        "D [%]",
        &curves_d,
        plot::Style::LinesLogX,
    )?;
    energy_share_plot(out, &setup, &branches, h)?;
    println!(
        "wrote {}, backbone.svg, damping.svg, energy_shares.svg, *_branch.csv to {}",
        table_path.display(),
        out.display()
    );
    Ok(())
}

/// `modal_table.json`: the table, and for FE matrices reduced on the sparse
/// path a `provenance` object with the structure's stage times
/// (`structure_stages`, as in `summary.json`), a field that the table's
/// readers ignore.
fn write_table(table: &nlmode::nma::ModalTable, path: &Path, setup: &Setup) -> Result<()> {
    let Some(t) = &setup.structure_timings else {
        return Ok(table.write(path)?);
    };
    let mut v = serde_json::to_value(table)?;
    v["provenance"] = serde_json::json!({
        "full_ndof": setup.full_ndof,
        "omega0_rad_s": setup.omega0_rad_s,
        "structure_stages": t,
    });
    std::fs::write(path, serde_json::to_string_pretty(&v)?)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// The kinetic-energy share of each harmonic along the first branch
/// (conservative if computed): `energy_shares.svg`.
fn energy_share_plot(
    out: &Path,
    setup: &Setup,
    branches: &[(&str, NmaResult)],
    h: usize,
) -> Result<()> {
    let (label, r) = &branches[0];
    let w: Vec<f64> = r
        .branch
        .iter()
        .map(|b| b.omega_rad_s / setup.omega0_rad_s)
        .collect();
    let shares: Vec<(usize, Vec<f64>)> = (1..=h)
        .map(|n| {
            (
                n,
                r.branch
                    .iter()
                    .map(|b| b.harmonic_energy_shares.get(n).copied().unwrap_or(0.0))
                    .collect::<Vec<f64>>(),
            )
        })
        .filter(|(n, s)| *n == 1 || s.iter().cloned().fold(0.0, f64::max) > 0.01)
        .collect();
    let curves_e: Vec<Curve> = shares
        .iter()
        .map(|(n, s)| Curve {
            label: format!("harmonic {n}"),
            x: &w,
            y: s,
        })
        .collect();
    plot::xy_plot(
        &out.join("energy_shares.svg"),
        &format!("Kinetic-energy share of each harmonic along the {label} branch"),
        "omega / omega0 [-]",
        "energy share [-]",
        &curves_e,
        plot::Style::Dots,
    )?;
    Ok(())
}

/// `host frf [SCENARIO] -o DIR`: steady state of `eq:NM` at the scenario's
/// voltage (all roots, stability), with the linear single-mode steady state.
/// `frf_tip.svg` and `frf_force.svg`: the steady-state solutions `(w, tip,
/// f)` as dots, stable and unstable apart (`st` 1 or 0), titled `what`.
fn steady_plots(
    out: &Path,
    what: &str,
    omega0: f64,
    w: &[f64],
    tip: &[f64],
    f: &[f64],
    st: &[f64],
) -> Result<()> {
    let split = |stable: bool| {
        let idx: Vec<usize> = (0..w.len()).filter(|&i| (st[i] == 1.0) == stable).collect();
        (
            idx.iter().map(|&i| w[i] / omega0).collect::<Vec<f64>>(),
            idx.iter().map(|&i| tip[i] * 1e3).collect::<Vec<f64>>(),
            idx.iter().map(|&i| f[i]).collect::<Vec<f64>>(),
        )
    };
    let (xs, ys, fs) = split(true);
    let (xu, yu, fu) = split(false);
    plot::xy_plot(
        &out.join("frf_tip.svg"),
        &format!("Steady state of {what}: tip amplitude"),
        "Omega/omega0 [-]",
        "|q_tip,1| [mm]",
        &[
            Curve {
                label: "stable".into(),
                x: &xs,
                y: &ys,
            },
            Curve {
                label: "unstable".into(),
                x: &xu,
                y: &yu,
            },
        ],
        plot::Style::Dots,
    )?;
    plot::xy_plot(
        &out.join("frf_force.svg"),
        &format!("Steady state of {what}: force amplitude"),
        "Omega/omega0 [-]",
        "|F| [N]",
        &[
            Curve {
                label: "stable".into(),
                x: &xs,
                y: &fs,
            },
            Curve {
                label: "unstable".into(),
                x: &xu,
                y: &fu,
            },
        ],
        plot::Style::Dots,
    )?;
    Ok(())
}

pub fn frf(path: Option<&Path>, out: &Path) -> Result<()> {
    let (sc, source) = load_scenario(path)?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let setup = Setup::new(&sc).with_context(|| format!("scenario {source}"))?;
    if sc.frf.model == crate::scenario::FrfModel::Hb {
        return frf_hb(&sc, &setup, out);
    }
    let (nma, r) = crate::api::frf(&setup, &sc)?;
    println!(
        "{} (table ready after {:.1} ms)",
        nma.note,
        1e3 * nma.wall_time_s
    );
    let (w, a, tip, f) = (
        r.omega_rad_s,
        r.modal_amplitude,
        r.tip_amplitude_m,
        r.force_amplitude_n,
    );
    let st: Vec<f64> = r
        .stable
        .iter()
        .map(|&s| if s { 1.0 } else { 0.0 })
        .collect();
    let (multi, above, wall) = (r.multivalued, r.above_table, r.wall_time_s);
    let mut header: Vec<String> = vec![
        "omega_rad_s".into(),
        "modal_amplitude".into(),
        "tip_amplitude_m".into(),
        "force_amplitude_N".into(),
        "stable".into(),
    ];
    let mut cols: Vec<&[f64]> = vec![&w, &a, &tip, &f, &st];
    for (name, p) in &r.harvested_power_w {
        header.push(format!("{name}_harvested_power_W"));
        cols.push(p);
    }
    write_csv(&out.join("frf.csv"), &header, &cols)?;
    steady_plots(out, "eq:NM", setup.omega0_rad_s, &w, &tip, &f, &st)?;
    println!(
        "steady state at {} frequencies in {:.2} ms: {} with several solutions, {} possibly above the table's range",
        sc.run.frf_points,
        1e3 * wall,
        multi,
        above
    );
    println!(
        "wrote frf.csv, frf_tip.svg, frf_force.svg to {}",
        out.display()
    );
    Ok(())
}

/// `host frf` with `[frf] model = "hb"`: the harmonic balance of the full
/// model (`[hb]` options, seeds from the single-mode steady state if
/// `hb.seeds`), `hb_frc.csv` and the plots of every branch.
fn frf_hb(sc: &crate::scenario::Scenario, setup: &Setup, out: &Path) -> Result<()> {
    setup.check_driven()?;
    let t0 = Instant::now();
    let nma = if sc.hb.seeds {
        let (nma, _) = methods::nma_table(setup, sc, false)?;
        println!("{}", nma.note);
        Some(nma)
    } else {
        None
    };
    let r = methods::hb_response(setup, sc, nma.as_ref().map(|n| &n.table))?;
    let wall = t0.elapsed().as_secs_f64();
    methods::hb_table(&r).write_csv(&out.join("hb_frc.csv"))?;
    let pts: Vec<&nlmode::hb::HbPoint> = r.branches.iter().flat_map(|b| &b.points).collect();
    let w: Vec<f64> = pts.iter().map(|p| p.omega_rad_s).collect();
    let tip: Vec<f64> = pts.iter().map(|p| p.tip_amplitude_m()).collect();
    let f: Vec<f64> = pts
        .iter()
        .map(|p| p.force_amplitudes_n().first().copied().unwrap_or(0.0))
        .collect();
    let st: Vec<f64> = pts
        .iter()
        .map(|p| if p.stable() == Some(false) { 0.0 } else { 1.0 })
        .collect();
    steady_plots(
        out,
        "the full model (hb)",
        setup.omega0_rad_s,
        &w,
        &tip,
        &f,
        &st,
    )?;
    let summary = methods::hb_result(&r, wall).summary;
    println!(
        "hb (H = {}): {} branches, {} points in {:.2} s (seeds {}); {}",
        r.harmonics,
        r.branches.len(),
        pts.len(),
        wall,
        if nma.is_some() {
            "from the single-mode steady state and the main branch's folds"
        } else {
            "off"
        },
        summary
            .get::<String>(methods::hb::STATUS)
            .unwrap_or_default()
    );
    let folds: Option<Vec<methods::hb::FoldSummary>> = summary.get(methods::hb::FOLDS);
    for fold in folds.iter().flatten() {
        println!(
            "  fold at Omega = {:.4} rad/s, tip {:.4e} m",
            fold.omega_rad_s, fold.tip_amplitude_m
        );
    }
    let ranges: Option<Vec<[f64; 2]>> = summary.get(methods::hb::UNSTABLE_RANGES);
    for rg in ranges.iter().flatten() {
        println!("  unstable from {:.4} to {:.4} rad/s", rg[0], rg[1]);
    }
    for w in &summary.warnings {
        println!("  warning: {w}");
    }
    println!(
        "wrote hb_frc.csv, frf_tip.svg, frf_force.svg to {}",
        out.display()
    );
    Ok(())
}
