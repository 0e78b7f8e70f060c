//! `host run`: scenario -> setup -> methods -> output contract, plots, summary.
use crate::methods;
use crate::model::Setup;
use crate::plot;
use crate::results::{self, ExciterSummary, MethodResult, Summary, SweepSummary};
use crate::scenario::{ForceSource, Method, Scenario};
use anyhow::{Context, Result};
use std::path::Path;

/// Largest scenario file read [bytes] (a real one is a few kB): `host run
/// /dev/zero` or a huge file fails at once instead of reading without bound.
pub const MAX_SCENARIO_BYTES: u64 = 1 << 20;

/// Read a scenario file (a regular file of at most [`MAX_SCENARIO_BYTES`]: a
/// named pipe or device is refused without blocking) or take the embedded
/// default.
pub fn load_scenario(path: Option<&Path>) -> Result<(Scenario, String)> {
    match path {
        None => Ok((
            Scenario::default_scenario(),
            "embedded default (sweep.toml)".into(),
        )),
        Some(p) => {
            let text = cosim::file::read_regular_to_string(p, MAX_SCENARIO_BYTES)
                .with_context(|| format!("cannot read scenario file {}", p.display()))?;
            let mut sc = Scenario::parse(&text)
                .map_err(|e| anyhow::anyhow!("scenario {}: {e}", p.display()))?;
            // paths in the scenario (the Matrix Market files) are relative to its folder
            sc.resolve_paths(p.parent().unwrap_or(Path::new("")));
            Ok((sc, p.display().to_string()))
        }
    }
}

/// Methods of a `host run` that could not run: (method, reason).
pub type FailedMethods = Vec<(String, String)>;

/// `host run`: every method the scenario lists that can run is run and its
/// outputs written. A method that cannot run for want of something outside
/// the scenario (today: `cosim` without the FMU libraries, see
/// [`cosim::repo::locate_libraries`]) does not stop the others; it is
/// returned (and listed under `failed_methods` in summary.json), so that the
/// command line can exit non-zero. `fmu_dir`: where the FMU libraries are
/// (`--fmu-dir`).
pub fn run(path: Option<&Path>, out: &Path, fmu_dir: Option<&Path>) -> Result<FailedMethods> {
    let (sc, source) = load_scenario(path)?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let setup = Setup::new(&sc).with_context(|| format!("scenario {source}"))?;
    let masses = &setup.modal_masses;
    println!("scenario: {source}");
    if !sc.title.is_empty() {
        println!("  {}", sc.title);
    }
    println!(
        "structure: {} DOFs ({} full), omega0 = {:.2} rad/s ({:.2} Hz), D0 = {:.3} %",
        setup.model.ndof(),
        setup.full_ndof,
        setup.omega0_rad_s,
        setup.omega0_rad_s / (2.0 * std::f64::consts::PI),
        100.0 * setup.d0
    );
    for (i, (m, mu)) in masses.iter().enumerate() {
        println!(
            "exciter '{}' at {}: modal mass {:.3} kg, mass ratio mu = {:.2} %",
            sc.exciter[i].name,
            setup.exciter_points[i],
            m,
            100.0 * mu
        );
        let u = setup.inputs[i][0];
        if u != nlmode::Complex64::new(1.0, 0.0) {
            println!(
                "  voltage {:.3} V, phase {:.4} rad",
                u.norm() * setup.sweep.amplitude,
                u.arg()
            );
        }
    }
    for att in &setup.attachments[setup.shakers.len()..] {
        println!(
            "attachment '{}' at {:?}: {} states",
            att.name,
            att.interface_points,
            att.ndim()
        );
    }
    let s = &setup.sweep;
    println!(
        "sweep: {:.1} V, Omega {:.1} -> {:.1} rad/s at {:.1} rad/s^2 ({} s)",
        s.amplitude,
        s.omega_start_rad_s,
        s.omega_end_rad_s,
        s.signed_rate_rad_s2(),
        format!("{:.3}", s.duration_s())
    );
    let mut done: Vec<MethodResult> = Vec::new();
    let wants = |m: Method| sc.run.methods.contains(&m);
    if wants(Method::Cosim) {
        setup.check_cosim()?;
    }
    if wants(Method::ImposedForce) {
        setup.check_imposed_force()?;
    }
    // cosim of a matrices structure needs its modal table for the structure FMU
    let own_table = sc.structure.matrices().is_some() && wants(Method::Cosim);
    let needs_mode = own_table || sc.run.methods.iter().any(|m| m.needs_mode());
    let mut nma = None;
    if needs_mode {
        let (n, _) = methods::nma_table(&setup, &sc, false)?;
        println!("{}", n.note);
        nma = Some(n);
    }
    let table_omega = nma.as_ref().map(|n| {
        let w = &n.table.omega_rad_s;
        (
            w.iter().cloned().fold(f64::INFINITY, f64::min),
            w.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        )
    });
    let validity = setup.validity_warnings(sc.nma.harmonics, table_omega);
    for w in &validity {
        println!("warning: {w}");
    }
    let error = nlmode::reduced::FrequencyError {
        eps: sc.imposed_force.frequency_error,
        offset_rad_s: sc.imposed_force.frequency_offset_rad_s
            + sc.imposed_force.frequency_offset_omega0 * setup.omega0_rad_s,
    };
    let has_error = error.eps != 0.0 || error.offset_rad_s != 0.0;
    let mut nlmode_flow = None;
    let mut reference_env = None;
    // Dependencies first: imposed-force takes its force from nlmode or reference.
    let mut order: Vec<Method> = sc.run.methods.clone();
    order.sort_by_key(|m| usize::from(*m == Method::ImposedForce));
    // The FMUs: packaged before the methods when cosim needs them.
    let mut fmus = None;
    let mut failed = FailedMethods::new();
    let given_fmus = match (&sc.cosim.structure_fmu, &sc.cosim.shaker_fmu) {
        (Some(a), Some(b)) => Some((a.into(), b.into())),
        _ => None,
    };
    if wants(Method::Cosim) || sc.output.fmus {
        match crate::package::package(&out.join("fmus"), fmu_dir) {
            Ok(paths) => {
                println!(
                    "FMUs: {}",
                    paths
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
                fmus = Some((paths[0].clone(), paths[1].clone()));
            }
            // cosim with FMUs given by the scenario does not need the packaged ones
            Err(e) if !wants(Method::Cosim) || given_fmus.is_some() => {
                println!("warning: FMUs not packaged: {e:#}")
            }
            Err(e) => {
                let msg = format!("cosim needs the FMUs: {e:#}");
                println!("error: {msg}; the other methods run");
                failed.push(("cosim".into(), msg));
            }
        }
    }
    for m in order {
        let table = || &nma.as_ref().expect("mode computed").table;
        match m {
            Method::LinearFrf => {
                done.push(methods::linear_frf(&setup, sc.run.frf_points)?);
                // eq:fhfhNull beside the assembled FRF (the paper's force-drop figure):
                // its single-shaker closed form only fits one exciter alone
                if setup.attachments.len() == 1 {
                    done.push(methods::closed_form(&setup, sc.run.frf_points)?);
                }
            }
            Method::Reference => {
                let mut bar = Progress::new("reference");
                let r = methods::reference(&setup, &sc, &mut |f| bar.set(f))?;
                bar.finish();
                reference_env = Some(r.envelope.clone());
                done.push(r);
            }
            Method::Nlmode => {
                let model = methods::reduced_model(&setup, table(), None)?;
                let (r, flow) = methods::slow_flow(
                    Method::Nlmode.name(),
                    &setup,
                    &model,
                    &sc.slowflow.options(Method::Nlmode),
                )?;
                done.push(r);
                nlmode_flow = Some(flow);
                if has_error && sc.imposed_force.apply_to_nlmode {
                    let model = methods::reduced_model(&setup, table(), Some(error))?;
                    let (r, _) = methods::slow_flow(
                        "nlmode-freq-error",
                        &setup,
                        &model,
                        &sc.slowflow.options(Method::Nlmode),
                    )?;
                    done.push(r);
                }
            }
            Method::LinearSlowflow => {
                let model = methods::reduced_model(&setup, table(), None)?.linear()?;
                done.push(
                    methods::slow_flow(
                        Method::LinearSlowflow.name(),
                        &setup,
                        &model,
                        &sc.slowflow.options(Method::LinearSlowflow),
                    )?
                    .0,
                );
            }
            Method::LinearSteady => {
                let model = methods::reduced_model(&setup, table(), None)?;
                done.push(methods::linear_steady(&setup, &model, sc.run.frf_points)?);
            }
            Method::ImposedForce => {
                let envelope = match &sc.imposed_force.source {
                    ForceSource::Nlmode => {
                        let flow = match &nlmode_flow {
                            Some(f) => f.clone(),
                            None => {
                                let model = methods::reduced_model(&setup, table(), None)?;
                                methods::slow_flow(
                                    Method::Nlmode.name(),
                                    &setup,
                                    &model,
                                    &sc.slowflow.options(Method::Nlmode),
                                )?
                                .1
                            }
                        };
                        nlmode::envelope::Envelope::from(&flow).to_force_envelope()?
                    }
                    ForceSource::Reference => {
                        let env = match reference_env.take() {
                            Some(e) => e,
                            None => {
                                let mut bar = Progress::new("reference (for imposed-force)");
                                let r = methods::reference(&setup, &sc, &mut |f| bar.set(f))?;
                                bar.finish();
                                r.envelope
                            }
                        };
                        // the windowed envelope lacks half a period at each end
                        let s = &setup.sweep;
                        env.to_force_envelope()
                            .context("imposed_force.source = reference")?
                            .with_held_ends(
                                s.omega_start_rad_s.min(s.omega_end_rad_s),
                                s.omega_start_rad_s.max(s.omega_end_rad_s),
                            )
                    }
                    ForceSource::Csv(path) => {
                        let read = || -> Result<nlmode::reduced::ForceEnvelope> {
                            Ok(results::read_envelope(path)?.to_force_envelope()?)
                        };
                        read().with_context(|| {
                            format!("imposed_force.source: CSV file '{}'", path.display())
                        })?
                    }
                };
                let mut model = nlmode::reduced::ReducedModel::imposed_force(
                    table(),
                    &setup.response_point,
                    &setup.exciter_points[0],
                    envelope,
                )?;
                // the passive attachments stay as impedances
                for (att, u) in setup.attachments.iter().zip(&setup.inputs).skip(1) {
                    model = model.with_linear_attachment(att, u)?;
                }
                let model = model.with_frequency_error(error)?;
                done.push(
                    methods::slow_flow(
                        Method::ImposedForce.name(),
                        &setup,
                        &model,
                        &sc.slowflow.options(Method::ImposedForce),
                    )?
                    .0,
                );
            }
            Method::PhaseResonance => {
                done.push(crate::controlled::phase_resonance(
                    &setup,
                    &sc,
                    table(),
                    out,
                )?);
            }
            Method::ForceControlled => {
                done.push(crate::stepped::force_controlled(&setup, &sc, table(), out)?);
            }
            Method::ResponseControlled => {
                done.push(crate::stepped::response_controlled(
                    &setup,
                    &sc,
                    table(),
                    out,
                )?);
            }
            Method::Cosim => {
                let Some(f) = fmus.as_ref().or(given_fmus.as_ref()) else {
                    continue; // FMUs not packaged: recorded in `failed`
                };
                let mut bar = Progress::new("cosim");
                let table = own_table.then(|| (table(), out));
                done.push(methods::cosim(&setup, &sc, f, table, &mut |x| bar.set(x))?);
                bar.finish();
            }
        }
    }
    for r in &done {
        for w in &r.summary.warnings {
            println!("warning: {w}");
        }
    }
    let mut summary = summary(&sc, &setup, &done, &failed);
    summary.warnings = validity;
    write_outputs(&sc, &setup, out, &done, &summary)?;
    print_summary(&setup, &done, &summary);
    Ok(failed)
}

/// The typed `summary.json` of a run.
fn summary(sc: &Scenario, setup: &Setup, done: &[MethodResult], failed: &FailedMethods) -> Summary {
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
        sweep: SweepSummary {
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
        failed_methods: failed.iter().cloned().collect(),
        warnings: Vec::new(),
    }
}

fn write_outputs(
    sc: &Scenario,
    setup: &Setup,
    out: &Path,
    done: &[MethodResult],
    summary: &Summary,
) -> Result<()> {
    for r in done {
        results::write_envelope(out, r)?;
        if sc.output.time_series {
            results::write_time_series(out, r)?;
        }
    }
    let path = out.join("summary.json");
    std::fs::write(&path, serde_json::to_string_pretty(summary)?)
        .with_context(|| format!("cannot write {}", path.display()))?;
    if sc.output.plots {
        let refs: Vec<&MethodResult> = done.iter().collect();
        let title = if sc.title.is_empty() {
            "sweep".to_string()
        } else {
            sc.title.clone()
        };
        // The reference's time signals in grey under the envelopes, as in the paper's figures.
        let signal_cols = done
            .iter()
            .find(|r| r.name == Method::Reference.name())
            .and_then(|r| r.time_series.as_ref())
            .map(|ts| {
                let col = |n: &str| {
                    ts.columns
                        .iter()
                        .find(|(c, _)| c == n)
                        .map(|(_, v)| v.clone())
                        .unwrap_or_default()
                };
                let eta: Vec<f64> = col("omega_rad_s")
                    .iter()
                    .map(|w| w / setup.omega0_rad_s)
                    .collect();
                (eta, col("force_N"), col("tip_m"))
            });
        let signal = signal_cols.as_ref().map(|(eta, f, x)| plot::Signal {
            eta,
            force_n: f,
            tip_m: x,
        });
        plot::sweep_plot(
            &out.join("sweep.svg"),
            &title,
            setup.omega0_rad_s,
            &refs,
            signal,
        )?;
    }
    Ok(())
}

/// A progress bar that appears only when a method runs longer than a second.
struct Progress {
    bar: indicatif::ProgressBar,
    start: std::time::Instant,
    shown: bool,
}

impl Progress {
    fn new(name: &str) -> Self {
        let bar = indicatif::ProgressBar::hidden();
        bar.set_length(1000);
        bar.set_message(name.to_string());
        if let Ok(style) =
            indicatif::ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}% {elapsed}")
        {
            bar.set_style(style.progress_chars("=> "));
        }
        Self {
            bar,
            start: std::time::Instant::now(),
            shown: false,
        }
    }

    fn set(&mut self, fraction: f64) {
        if !self.shown && self.start.elapsed().as_secs_f64() > 1.0 {
            self.bar
                .set_draw_target(indicatif::ProgressDrawTarget::stderr());
            self.shown = true;
        }
        self.bar
            .set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
    }

    fn finish(&self) {
        if self.shown {
            self.bar.finish_and_clear();
        }
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

fn print_summary(setup: &Setup, done: &[MethodResult], summary: &Summary) {
    println!();
    println!(
        "{:<18} {:>10} {:>14} {:>12} {:>12} {:>12} {:>10}",
        "method",
        "wall [s]",
        "peak tip [mm]",
        "at Omega/w0",
        "min |F| [N]",
        "max |F| [N]",
        "drop [%]"
    );
    for r in done {
        let s = &summary.methods[&r.name];
        let g = |v: Option<f64>| v.unwrap_or(f64::NAN);
        let drop = s
            .force_drop
            .map(|d| format!("{:.1}", 100.0 * d))
            .unwrap_or_default();
        println!(
            "{:<18} {:>10.4} {:>14.4} {:>12.4} {:>12.4} {:>12.4} {:>10}",
            r.name,
            s.wall_time_s,
            1e3 * g(s.peak_tip_amplitude_m),
            g(s.peak_omega_rad_s) / setup.omega0_rad_s,
            g(s.min_force_amplitude_n),
            g(s.max_force_amplitude_n),
            drop
        );
    }
    if let Some(x) = summary.speedup_nlmode_over_reference {
        println!("nlmode is {x:.0} times faster than reference");
    }
}
