//! The computation of `host run` in memory: a scenario's methods run into
//! their [`MethodResult`]s and the typed `summary.json` ([`Summary`]), which
//! `host run` ([`crate::run::run`]) then writes and the Python package
//! returns as arrays. The numbers are those of `host run`, which is this
//! function followed by the file writers.
use crate::methods;
use crate::model::Setup;
use crate::results::FailedMethods;
use crate::results::{ExciterSummary, MethodResult, Summary, SweepSettings};
use crate::scenario::{Method, Scenario};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

pub use crate::methods::{load_scenario, load_scenario_with_matrices};
pub use crate::scenario::InMemoryMatrices;
pub use crate::scenario::ScenarioSource;

/// How [`compute`] runs.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Where the FMU libraries are (`--fmu-dir`; else `$NLMODE_FMU_DIR`, else
    /// beside the executable, see [`crate::fmus::locate_libraries`]).
    pub fmu_dir: Option<PathBuf>,
    /// Print what `host run` prints (the scenario, the NMA note, warnings) and
    /// show progress bars on long methods.
    pub echo: bool,
    /// Package the FMUs into `out/fmus` when the scenario's `output.fmus`
    /// asks for it (`host run`); `cosim` packages them in any case.
    pub package_fmus: bool,
}

/// What a run computed: every method's result, the summary and the methods
/// that could not run.
pub struct Computed {
    pub setup: Setup,
    pub results: Vec<MethodResult>,
    /// `summary.json`.
    pub summary: Summary,
    pub failed: FailedMethods,
}

/// Print like `host run` when the options say so.
macro_rules! say {
    ($opts:expr, $($arg:tt)*) => {
        if $opts.echo {
            println!($($arg)*)
        }
    };
}

/// Run every method `sc` lists, in [`methods::run_order`] through the
/// registry. `source` names the scenario in messages; `out` receives the
/// files some methods need besides their results (the packaged FMUs of
/// `cosim`, `phase_resonance.csv`). A method that cannot run for want of
/// something outside the scenario (`cosim` without the FMU libraries) is
/// listed in [`Computed::failed`] rather than failing the run.
pub fn compute(sc: &Scenario, source: &str, out: &Path, opts: &Options) -> Result<Computed> {
    let setup = Setup::new(sc).with_context(|| format!("scenario {source}"))?;
    setup
        .check_driven()
        .with_context(|| format!("scenario {source}"))?;
    echo_setup(sc, &setup, source, opts);
    let listed: Vec<&dyn methods::Method> = methods::REGISTRY
        .iter()
        .copied()
        .filter(|m| sc.run.methods.contains(&m.id()))
        .collect();
    for m in &listed {
        m.check(sc, &setup)
            .with_context(|| format!("scenario {source}"))?;
    }
    let mut ctx = methods::RunContext::new(sc, &setup, out, opts.echo);
    if listed.iter().any(|m| m.needs_mode(sc)) {
        let (n, _) = methods::nma_table(&setup, sc, false)?;
        sc.slowflow
            .check_residual_modes(&n.table)
            .with_context(|| format!("scenario {source}"))?;
        say!(opts, "{}", n.note);
        ctx.nma = Some(n);
    }
    let table_omega = ctx.nma.as_ref().map(|n| {
        let w = &n.table.omega_rad_s;
        (
            w.iter().cloned().fold(f64::INFINITY, f64::min),
            w.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        )
    });
    let harmonics = ctx
        .nma
        .as_ref()
        .map(|n| n.table.harmonics)
        .unwrap_or(sc.nma.harmonics_or_min());
    let checked = setup
        .validity(harmonics, table_omega, sc.slowflow.attachments)
        .without_applied(&sc.slowflow);
    ctx.remedies = checked.distinct_kinds();
    let remedies_found = checked.remedies;
    let mut validity = checked.warnings;
    for w in &validity {
        say!(opts, "warning: {w}");
    }
    // the modal table's own warnings (accuracy missed, gap, truncation) are
    // printed with its note and listed with the validity warnings
    if let Some(n) = &ctx.nma {
        for w in &n.warnings {
            say!(opts, "warning: {w}");
        }
        validity.extend(n.warnings.iter().cloned());
    }
    let mut failed = FailedMethods::new();
    ctx.fmus = fmus(sc, out, opts, &mut failed);
    let order = methods::run_order(sc);
    for &m in &order {
        ctx.output(m)?;
    }
    let done = ctx.into_results(&order);
    for r in &done {
        for w in &r.summary.warnings {
            say!(opts, "warning: {w}");
        }
    }
    let mut summary = summary(sc, &setup, &done, &failed);
    summary.warnings = validity;
    summary.remedies = remedies_found
        .iter()
        .map(|r| crate::validity::RemedyEntry {
            remedy: r.clone(),
            setting: r.setting(),
            result: done
                .iter()
                .any(|d| d.name == r.result_name())
                .then(|| r.result_name()),
        })
        .collect();
    Ok(Computed {
        setup,
        results: done,
        summary,
        failed,
    })
}

/// Print the scenario, the structure, the exciters, the attachments and the
/// sweep (`host run`).
fn echo_setup(sc: &Scenario, setup: &Setup, source: &str, opts: &Options) {
    say!(opts, "scenario: {source}");
    if !sc.title.is_empty() {
        say!(opts, "  {}", sc.title);
    }
    say!(
        opts,
        "structure: {} DOFs ({} full), omega0 = {:.2} rad/s ({:.2} Hz), D0 = {:.3} %",
        setup.model.ndof(),
        setup.full_ndof,
        setup.omega0_rad_s,
        setup.omega0_rad_s / (2.0 * std::f64::consts::PI),
        100.0 * setup.d0
    );
    if let Some(t) = &setup.structure_timings {
        say!(
            opts,
            "  sparse reduction: read {:.2} s, check {:.2} s, ordering ({}) {:.2} s, factor {:.2} s ({} non-zeros), eigen {:.2} s, constraint modes {:.2} s, projection {:.2} s; memory estimate {:.2} GB",
            t.read_s,
            t.check_s,
            t.ordering,
            t.order_s,
            t.factor_s,
            t.factor_nnz,
            t.eigen_s,
            t.constraint_modes_s,
            t.project_s,
            t.memory_estimate_bytes as f64 / 1e9
        );
    }
    for (i, (m, mu)) in setup.modal_masses.iter().enumerate() {
        say!(
            opts,
            "exciter '{}' at {}: modal mass {:.3} kg, mass ratio mu = {:.2} %",
            sc.exciter[i].name,
            setup.exciter_points[i],
            m,
            100.0 * mu
        );
        let u = setup.inputs[i][0];
        if u != nlmode::Complex64::new(1.0, 0.0) {
            say!(
                opts,
                "  voltage {:.3} V, phase {:.4} rad",
                u.norm() * setup.sweep.amplitude,
                u.arg()
            );
        }
    }
    for att in &setup.attachments[setup.shakers.len()..] {
        say!(
            opts,
            "attachment '{}' at {:?}: {} states",
            att.name,
            att.interface_points,
            att.ndim()
        );
    }
    let s = &setup.sweep;
    say!(
        opts,
        "sweep: {:.1} V, Omega {:.1} -> {:.1} rad/s at {:.1} rad/s^2 ({} s)",
        s.amplitude,
        s.omega_start_rad_s,
        s.omega_end_rad_s,
        s.signed_rate_rad_s2(),
        format!("{:.3}", s.duration_s())
    );
}

/// The structure and shaker FMUs: packaged into `out/fmus` when `cosim` runs
/// or `[output] fmus` asks for them (`host run`), else those the scenario
/// names. `cosim` without either is recorded in `failed`.
fn fmus(
    sc: &Scenario,
    out: &Path,
    opts: &Options,
    failed: &mut FailedMethods,
) -> Option<(PathBuf, PathBuf)> {
    let wants_cosim = sc.run.methods.contains(&Method::Cosim);
    let given = match (&sc.cosim.structure_fmu, &sc.cosim.shaker_fmu) {
        (Some(a), Some(b)) => Some((a.into(), b.into())),
        _ => None,
    };
    if !(wants_cosim || (sc.output.fmus && opts.package_fmus)) {
        return given;
    }
    // both versions: structure.fmu, shaker.fmu, ... first (cosim takes
    // those), then structure_fmi3.fmu, ...
    match crate::package::package_versions(
        &out.join("fmus"),
        opts.fmu_dir.as_deref(),
        crate::fmus::FmiVersions::All,
    ) {
        Ok(paths) => {
            say!(
                opts,
                "FMUs: {}",
                paths
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            Some((paths[0].clone(), paths[1].clone()))
        }
        // cosim with FMUs given by the scenario does not need the packaged ones
        Err(e) if !wants_cosim || given.is_some() => {
            say!(opts, "warning: FMUs not packaged: {e:#}");
            given
        }
        Err(e) => {
            let msg = format!("cosim needs the FMUs: {e:#}");
            say!(opts, "error: {msg}; the other methods run");
            failed.push(("cosim".into(), msg));
            None
        }
    }
}

/// The typed `summary.json` of a run.
pub fn summary(
    sc: &Scenario,
    setup: &Setup,
    done: &[MethodResult],
    failed: &FailedMethods,
) -> Summary {
    Summary {
        title: sc.title.clone(),
        omega0_rad_s: setup.omega0_rad_s,
        damping_ratio: setup.d0,
        model_ndof: setup.model.ndof(),
        full_ndof: setup.full_ndof,
        exciters: setup
            .exciter_points
            .iter()
            .zip(&setup.modal_masses)
            .map(|(p, &(m, mu))| ExciterSummary {
                point: p.clone(),
                modal_mass_kg: m,
                mass_ratio: mu,
            })
            .collect(),
        sweep: SweepSettings {
            voltage_v: setup.sweep.amplitude,
            omega_start_rad_s: setup.sweep.omega_start_rad_s,
            omega_end_rad_s: setup.sweep.omega_end_rad_s,
            rate_rad_s2: setup.sweep.signed_rate_rad_s2(),
            duration_s: setup.sweep.duration_s(),
        },
        methods: done
            .iter()
            .map(|r| (r.name.clone(), r.summary.clone()))
            .collect(),
        speedup_nlmode_over_reference: speedup(done),
        structure_stages: setup.structure_timings.clone(),
        failed_methods: failed.iter().cloned().collect(),
        warnings: Vec::new(),
        remedies: Vec::new(),
    }
}

fn speedup(done: &[MethodResult]) -> Option<f64> {
    let t = |m: Method| {
        done.iter()
            .find(|r| r.name == m.name())
            .map(|r| r.wall_time_s())
    };
    match (t(Method::Reference), t(Method::Nlmode)) {
        (Some(a), Some(b)) if b > 0.0 => Some(a / b),
        _ => None,
    }
}

/// The steady-state branches of `eq:NM` at the scenario's voltage, as `host
/// frf` computes them: one entry per solution (several per frequency where the
/// response is multivalued).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Frf {
    pub omega_rad_s: Vec<f64>,
    /// Modal amplitude `a` [sqrt(kg) m].
    pub modal_amplitude: Vec<f64>,
    pub tip_amplitude_m: Vec<f64>,
    pub force_amplitude_n: Vec<f64>,
    pub stable: Vec<bool>,
    /// Piezo shunts: `(name, mean harvested power [W] per solution)`.
    pub harvested_power_w: Vec<(String, Vec<f64>)>,
    /// Frequencies with several solutions.
    pub multivalued: usize,
    /// Frequencies whose response may lie above the table's range.
    pub above_table: usize,
    /// Computing the steady state (the table excluded) [s].
    pub wall_time_s: f64,
}

/// `host frf`'s computation: the modal table (`note` says how it was made),
/// the single-mode model with the attachments and its steady state over
/// `[run] frf_points` frequencies.
pub fn frf(setup: &Setup, sc: &Scenario) -> Result<(methods::Nma, Frf)> {
    setup.check_driven()?;
    let (nma, _) = methods::nma_table(setup, sc, false)?;
    let model = methods::reduced_model(setup, &nma.table, None)?;
    let omegas = methods::frf_omegas(setup, sc.run.frf_points);
    let t0 = std::time::Instant::now();
    let ss = model
        .steady_state(&omegas, setup.sweep.amplitude)
        .context("frf: steady state")?;
    let mut r = Frf {
        wall_time_s: t0.elapsed().as_secs_f64(),
        ..Default::default()
    };
    let mut modal: Vec<(f64, nlmode::Complex64)> = Vec::new();
    for p in &ss {
        r.multivalued += usize::from(p.solutions.len() > 1);
        r.above_table += usize::from(p.exceeds_table);
        for s in &p.solutions {
            r.omega_rad_s.push(p.omega_rad_s);
            r.modal_amplitude.push(s.a);
            r.tip_amplitude_m.push(s.tip_amplitude_m);
            r.force_amplitude_n.push(s.force_amplitude_n);
            r.stable.push(s.stable);
            modal.push((
                p.omega_rad_s,
                nlmode::Complex64::from_polar(s.a, s.theta_rad),
            ));
        }
    }
    // piezo shunts: `<name>_harvested_power_W` per solution (as `nlmode`)
    r.harvested_power_w = methods::modal_harvested_power(setup, &model, &modal).context("frf")?;
    Ok((nma, r))
}
