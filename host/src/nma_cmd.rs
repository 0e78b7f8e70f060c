//! `host nma` and `host frf`: the nonlinear mode (table, backbone plots) and
//! the steady-state frequency responses of the single-nonlinear-mode model.
use crate::methods;
use crate::model::Setup;
use crate::plot::{self, Curve};
use crate::results::write_csv;
use crate::run::load_scenario;
use anyhow::{Context, Result};
use nlmode::nma::NmaResult;
use std::path::Path;

fn branch_csv(out: &Path, name: &str, r: &NmaResult, point: &str) -> Result<()> {
    let tip = r
        .point_fundamental_amplitude(point)
        .context("branch has no response point")?;
    let a: Vec<f64> = r.branch.iter().map(|b| b.amplitude).collect();
    let w: Vec<f64> = r.branch.iter().map(|b| b.omega_rad_s).collect();
    let d: Vec<f64> = r.branch.iter().map(|b| b.damping_ratio).collect();
    write_csv(
        &out.join(format!("{name}_branch.csv")),
        &[
            "amplitude".into(),
            "tip_amplitude_m".into(),
            "omega_rad_s".into(),
            "damping_ratio".into(),
        ],
        &[&a, &tip, &w, &d],
    )
}

fn report(label: &str, r: &NmaResult, table: &nlmode::nma::ModalTable, wall: f64) {
    let a0 = table.amplitude[0];
    let a1 = *table.amplitude.last().unwrap();
    println!(
        "{label}: H = {}, {} branch points ({} Newton iterations), {:.1} ms; table: {} points, a = {:.3e} .. {:.3e}",
        r.harmonics,
        r.branch.len(),
        r.newton_iterations,
        1e3 * wall,
        table.amplitude.len(),
        a0,
        a1
    );
    match r.first_fold() {
        Some(f) => println!(
            "  first fold of a at a = {:.4e}, omega = {:.2} rad/s ({:.3} omega0): the table keeps the primary branch up to it",
            f.amplitude,
            f.omega_rad_s,
            f.omega_rad_s / r.linear_omega_rad_s
        ),
        None => println!("  no fold of a on the computed branch"),
    }
    for (i, f) in r.folds.iter().enumerate().skip(1) {
        println!(
            "  fold {}: {:?} at a = {:.4e}, omega = {:.2} rad/s",
            i + 1,
            f.kind,
            f.amplitude,
            f.omega_rad_s
        );
    }
    for w in &r.warnings {
        println!("  warning: {w}");
    }
}

/// `host nma [SCENARIO] -o DIR`.
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
    let (damped, dres) = methods::nma_table(&setup, &sc, false)?;
    let dres = dres.context("nma: a table file was given (nma.table); nothing to compute")?;
    report("damped", &dres, &damped.table, damped.wall_time_s);
    let table_path = out.join("modal_table.json");
    damped.table.write(&table_path)?;
    branch_csv(out, "damped", &dres, &setup.response_point)?;
    let mut curves_w = vec![];
    let mut curves_d = vec![];
    let tip_d = dres
        .point_fundamental_amplitude(&setup.response_point)
        .unwrap_or_default();
    let w_d: Vec<f64> = dres
        .branch
        .iter()
        .map(|b| b.omega_rad_s / setup.omega0_rad_s)
        .collect();
    let d_d: Vec<f64> = dres
        .branch
        .iter()
        .map(|b| 100.0 * b.damping_ratio)
        .collect();
    let cons = if sc.nma.conservative {
        let (c, cres) = methods::nma_table(&setup, &sc, true)?;
        let cres = cres.expect("computed");
        report("conservative", &cres, &c.table, c.wall_time_s);
        branch_csv(out, "conservative", &cres, &setup.response_point)?;
        Some(cres)
    } else {
        None
    };
    let tip_c = cons
        .as_ref()
        .and_then(|c| c.point_fundamental_amplitude(&setup.response_point))
        .unwrap_or_default();
    let w_c: Vec<f64> = cons
        .as_ref()
        .map(|c| {
            c.branch
                .iter()
                .map(|b| b.omega_rad_s / setup.omega0_rad_s)
                .collect()
        })
        .unwrap_or_default();
    if cons.is_some() {
        curves_w.push(Curve {
            label: "conservative".into(),
            x: &tip_c,
            y: &w_c,
        });
    }
    curves_w.push(Curve {
        label: format!("damped (D0 = {:.2} %)", 100.0 * setup.d0),
        x: &tip_d,
        y: &w_d,
    });
    curves_d.push(Curve {
        label: "damped".into(),
        x: &tip_d,
        y: &d_d,
    });
    plot::xy_plot(
        &out.join("backbone.svg"),
        &format!("Modal frequency vs amplitude (H = {})", dres.harmonics),
        "|q_tip,1| [m]",
        "omega / omega0 [-]",
        &curves_w,
        plot::Style::LinesLogX,
    )?;
    plot::xy_plot(
        &out.join("damping.svg"),
        "Modal damping ratio vs amplitude",
        "|q_tip,1| [m]",
        "D [%]",
        &curves_d,
        plot::Style::LinesLogX,
    )?;
    println!(
        "wrote {}, backbone.svg, damping.svg, *_branch.csv to {}",
        table_path.display(),
        out.display()
    );
    Ok(())
}

/// `host frf [SCENARIO] -o DIR`: steady state of `eq:NM` at the scenario's
/// voltage (all roots, stability), with the linear single-mode steady state.
pub fn frf(path: Option<&Path>, out: &Path) -> Result<()> {
    let (sc, source) = load_scenario(path)?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let setup = Setup::new(&sc).with_context(|| format!("scenario {source}"))?;
    let (nma, _) = methods::nma_table(&setup, &sc, false)?;
    println!("{}", nma.note);
    let model = methods::reduced_model(&setup, &nma.table, None)?;
    let omegas = methods::frf_omegas(&setup, sc.run.frf_points);
    let t0 = std::time::Instant::now();
    let ss = model
        .steady_state(&omegas, setup.sweep.amplitude)
        .context("frf: steady state")?;
    let wall = t0.elapsed().as_secs_f64();
    let (mut w, mut a, mut tip, mut f, mut st) = (vec![], vec![], vec![], vec![], vec![]);
    let mut multi = 0;
    let mut above = 0;
    for p in &ss {
        if p.solutions.len() > 1 {
            multi += 1;
        }
        if p.exceeds_table {
            above += 1;
        }
        for s in &p.solutions {
            w.push(p.omega_rad_s);
            a.push(s.a);
            tip.push(s.tip_amplitude_m);
            f.push(s.force_amplitude_n);
            st.push(if s.stable { 1.0 } else { 0.0 });
        }
    }
    write_csv(
        &out.join("frf.csv"),
        &[
            "omega_rad_s".into(),
            "modal_amplitude".into(),
            "tip_amplitude_m".into(),
            "force_amplitude_N".into(),
            "stable".into(),
        ],
        &[&w, &a, &tip, &f, &st],
    )?;
    let split = |stable: bool| {
        let idx: Vec<usize> = (0..w.len()).filter(|&i| (st[i] == 1.0) == stable).collect();
        (
            idx.iter()
                .map(|&i| w[i] / setup.omega0_rad_s)
                .collect::<Vec<f64>>(),
            idx.iter().map(|&i| tip[i] * 1e3).collect::<Vec<f64>>(),
            idx.iter().map(|&i| f[i]).collect::<Vec<f64>>(),
        )
    };
    let (xs, ys, fs) = split(true);
    let (xu, yu, fu) = split(false);
    plot::xy_plot(
        &out.join("frf_tip.svg"),
        "Steady state of eq:NM: tip amplitude",
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
        "Steady state of eq:NM: force amplitude",
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
    println!(
        "steady state at {} frequencies in {:.2} ms: {} with several solutions, {} possibly above the table's range",
        ss.len(),
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
