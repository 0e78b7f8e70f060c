//! The computation of `host run` in memory: a scenario's methods run into
//! their [`MethodResult`]s and the typed `summary.json` ([`Summary`]), which
//! `host run` ([`crate::run::run`]) then writes and the Python package
//! returns as arrays. The numbers are those of `host run`, which is this
//! function followed by the file writers.
use crate::methods;
use crate::model::Setup;
use crate::results::{self, ExciterSummary, MethodResult, Summary, SweepSummary};
use crate::run::FailedMethods;
use crate::scenario::{ForceSource, Method, Scenario};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// How [`compute`] runs.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Where the FMU libraries are (`--fmu-dir`; else `$NLMODE_FMU_DIR`, else
    /// beside the executable, see [`cosim::repo::locate_libraries`]).
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

/// Run every method `sc` lists. `source` names the scenario in messages;
/// `out` receives the files some methods need besides their results (the
/// packaged FMUs of `cosim`, `phase_resonance.csv`). A method that cannot run
/// for want of something outside the scenario (`cosim` without the FMU
/// libraries) is listed in [`Computed::failed`] rather than failing the run.
pub fn compute(sc: &Scenario, source: &str, out: &Path, opts: &Options) -> Result<Computed> {
    let setup = Setup::new(&sc).with_context(|| format!("scenario {source}"))?;
    let masses = &setup.modal_masses;
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
    for (i, (m, mu)) in masses.iter().enumerate() {
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
        say!(opts, "{}", n.note);
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
        say!(opts, "warning: {w}");
    }
    let error = nlmode::reduced::FrequencyError {
        eps: sc.imposed_force.frequency_error,
        offset_rad_s: sc.imposed_force.frequency_offset_rad_s
            + sc.imposed_force.frequency_offset_omega0 * setup.omega0_rad_s,
    };
    let has_error = error.eps != 0.0 || error.offset_rad_s != 0.0;
    let mut nlmode_flow = None;
    let mut reference_env = None;
    // several exciters: the envelope columns of nlmode / reference, whose
    // per-exciter forces imposed-force takes
    let several = setup.shakers.len() > 1;
    let mut nlmode_columns = None;
    let mut reference_columns = None;
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
    if wants(Method::Cosim) || (sc.output.fmus && opts.package_fmus) {
        match crate::package::package(&out.join("fmus"), opts.fmu_dir.as_deref()) {
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
                fmus = Some((paths[0].clone(), paths[1].clone()));
            }
            // cosim with FMUs given by the scenario does not need the packaged ones
            Err(e) if !wants(Method::Cosim) || given_fmus.is_some() => {
                say!(opts, "warning: FMUs not packaged: {e:#}")
            }
            Err(e) => {
                let msg = format!("cosim needs the FMUs: {e:#}");
                say!(opts, "error: {msg}; the other methods run");
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
                let mut bar = Progress::new("reference", opts.echo);
                let r = methods::reference(&setup, &sc, &mut |f| bar.set(f))?;
                bar.finish();
                reference_env = Some(r.envelope.clone());
                if several {
                    reference_columns = Some(results::envelope_columns(&r));
                }
                done.push(r);
            }
            Method::Nlmode => {
                let model = methods::reduced_model(&setup, table(), None)?;
                let (r, flow) = methods::exciter_slow_flow(
                    Method::Nlmode.name(),
                    &setup,
                    &model,
                    &sc.slowflow.options(Method::Nlmode),
                )?;
                if several {
                    nlmode_columns = Some(results::envelope_columns(&r));
                }
                done.push(r);
                nlmode_flow = Some(flow);
                if has_error && sc.imposed_force.apply_to_nlmode {
                    let model = methods::reduced_model(&setup, table(), Some(error))?;
                    let (r, _) = methods::exciter_slow_flow(
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
                let (r, _) = methods::exciter_slow_flow(
                    Method::LinearSlowflow.name(),
                    &setup,
                    &model,
                    &sc.slowflow.options(Method::LinearSlowflow),
                )?;
                done.push(r);
            }
            Method::LinearSteady => {
                let model = methods::reduced_model(&setup, table(), None)?;
                done.push(methods::linear_steady(&setup, &model, sc.run.frf_points)?);
            }
            Method::ImposedForce => {
                // one force per exciter, at its point: several exciters read the
                // per-exciter columns, one exciter the drive-point force as ever
                let columns = results::exciter_force_columns(&setup.exciter_names);
                let envelopes: Vec<nlmode::reduced::ForceEnvelope> = match &sc.imposed_force.source
                {
                    ForceSource::Nlmode if several => {
                        let cols = match nlmode_columns.take() {
                            Some(c) => c,
                            None => {
                                let model = methods::reduced_model(&setup, table(), None)?;
                                let (r, _) = methods::exciter_slow_flow(
                                    Method::Nlmode.name(),
                                    &setup,
                                    &model,
                                    &sc.slowflow.options(Method::Nlmode),
                                )?;
                                results::envelope_columns(&r)
                            }
                        };
                        let picked = results::pick_columns(&cols, &columns)
                            .context("imposed_force.source = nlmode")?;
                        results::exciter_force_envelopes(&picked)
                            .context("imposed_force.source = nlmode")?
                    }
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
                        vec![nlmode::envelope::Envelope::from(&flow).to_force_envelope()?]
                    }
                    ForceSource::Reference => {
                        let run_reference = || -> Result<MethodResult> {
                            let mut bar = Progress::new("reference (for imposed-force)", opts.echo);
                            let r = methods::reference(&setup, &sc, &mut |f| bar.set(f))?;
                            bar.finish();
                            Ok(r)
                        };
                        let envelopes = if several {
                            let cols = match reference_columns.take() {
                                Some(c) => c,
                                None => results::envelope_columns(&run_reference()?),
                            };
                            let picked = results::pick_columns(&cols, &columns)
                                .context("imposed_force.source = reference")?;
                            results::exciter_force_envelopes(&picked)
                                .context("imposed_force.source = reference")?
                        } else {
                            let env = match reference_env.take() {
                                Some(e) => e,
                                None => run_reference()?.envelope,
                            };
                            vec![env
                                .to_force_envelope()
                                .context("imposed_force.source = reference")?]
                        };
                        // the windowed envelope lacks half a period at each end
                        let s = &setup.sweep;
                        envelopes
                            .into_iter()
                            .map(|e| {
                                e.with_held_ends(
                                    s.omega_start_rad_s.min(s.omega_end_rad_s),
                                    s.omega_start_rad_s.max(s.omega_end_rad_s),
                                )
                            })
                            .collect()
                    }
                    ForceSource::Csv(path) => {
                        let read = || -> Result<Vec<nlmode::reduced::ForceEnvelope>> {
                            if several {
                                let picked = results::read_csv_columns(path, &columns)?;
                                Ok(results::exciter_force_envelopes(&picked)?)
                            } else {
                                Ok(vec![results::read_envelope(path)?.to_force_envelope()?])
                            }
                        };
                        read().with_context(|| {
                            format!("imposed_force.source: CSV file '{}'", path.display())
                        })?
                    }
                };
                let forces = setup
                    .exciter_points
                    .iter()
                    .map(String::as_str)
                    .zip(envelopes.iter().cloned())
                    .collect();
                let mut model = nlmode::reduced::ReducedModel::imposed_forces(
                    table(),
                    &setup.response_point,
                    &setup.exciter_points[0],
                    forces,
                )?;
                // the passive attachments stay as impedances
                for (att, u) in setup
                    .attachments
                    .iter()
                    .zip(&setup.inputs)
                    .skip(setup.shakers.len())
                {
                    model = model.with_linear_attachment(att, u)?;
                }
                let model = model.with_frequency_error(error)?;
                let (mut r, res) = methods::slow_flow(
                    Method::ImposedForce.name(),
                    &setup,
                    &model,
                    &sc.slowflow.options(Method::ImposedForce),
                )?;
                // several exciters: the forces imposed, per exciter
                if several {
                    let forces = envelopes
                        .iter()
                        .map(|e| {
                            res.samples
                                .iter()
                                .map(|x| e.eval(x.omega_rad_s))
                                .collect::<Result<Vec<_>, _>>()
                        })
                        .collect::<Result<Vec<_>, _>>()
                        .context("imposed-force")?;
                    r.add_exciter_forces(&setup.exciter_names, &forces);
                }
                done.push(r);
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
            Method::TestPlan => {
                done.push(crate::test_plan::test_plan(&setup, &sc, table(), out)?);
            }
            Method::Cosim => {
                let Some(f) = fmus.as_ref().or(given_fmus.as_ref()) else {
                    continue; // FMUs not packaged: recorded in `failed`
                };
                let mut bar = Progress::new("cosim", opts.echo);
                let table = own_table.then(|| (table(), out));
                done.push(methods::cosim(&setup, &sc, f, table, &mut |x| bar.set(x))?);
                bar.finish();
            }
        }
    }
    for r in &done {
        for w in &r.summary.warnings {
            say!(opts, "warning: {w}");
        }
    }
    let mut summary = summary(&sc, &setup, &done, &failed);
    summary.warnings = validity;
    Ok(Computed {
        setup,
        results: done,
        summary,
        failed,
    })
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

/// A progress bar that appears only when a method runs longer than a second.
struct Progress {
    /// Drawn at all (`host run`; not from the library API).
    enabled: bool,
    bar: indicatif::ProgressBar,
    start: std::time::Instant,
    shown: bool,
}

impl Progress {
    fn new(name: &str, show: bool) -> Self {
        let bar = indicatif::ProgressBar::hidden();
        bar.set_length(1000);
        bar.set_message(name.to_string());
        if let Ok(style) =
            indicatif::ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}% {elapsed}")
        {
            bar.set_style(style.progress_chars("=> "));
        }
        Self {
            enabled: show,
            bar,
            start: std::time::Instant::now(),
            shown: false,
        }
    }

    fn set(&mut self, fraction: f64) {
        if self.enabled && !self.shown && self.start.elapsed().as_secs_f64() > 1.0 {
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

/// Where a scenario comes from (the library's counterpart of `host run`'s
/// argument).
#[derive(Debug, Clone, Copy)]
pub enum ScenarioSource<'a> {
    /// The embedded default ([`crate::scenario::DEFAULT_SCENARIO`]).
    Default,
    /// TOML text; relative paths in it are taken from the working directory.
    Text(&'a str),
    /// A scenario file, read as `host run` reads it ([`crate::run::load_scenario`]).
    File(&'a Path),
}

/// Read a scenario (a file as [`crate::run::load_scenario`] reads it, with
/// the same messages), optionally with `[run] methods` replaced by `methods`
/// (checked by the scenario's own rules: an unknown method is named as
/// `run.methods[i]`). Returns the scenario and its name in messages. The
/// errors read as `host run`'s (`scenario NAME: key: message`), with the
/// [`crate::scenario::ScenarioError`] in their chain.
pub fn load_scenario(
    src: ScenarioSource,
    methods: Option<&[String]>,
) -> Result<(Scenario, String)> {
    use crate::scenario::{ScenarioError, DEFAULT_SCENARIO};
    let (text, name, dir) = match src {
        ScenarioSource::Default => (
            DEFAULT_SCENARIO.to_string(),
            "embedded default (sweep.toml)".to_string(),
            None,
        ),
        ScenarioSource::Text(t) => (t.to_string(), "(text)".to_string(), None),
        ScenarioSource::File(p) => (
            cosim::file::read_regular_to_string(p, crate::run::MAX_SCENARIO_BYTES)
                .with_context(|| format!("cannot read scenario file {}", p.display()))?,
            p.display().to_string(),
            p.parent().map(Path::to_path_buf),
        ),
    };
    let text = match methods {
        None => text,
        Some(m) => {
            let bad = |message: String| {
                anyhow::Error::new(ScenarioError {
                    key: "scenario".into(),
                    message,
                    line: None,
                })
                .context(format!("scenario {name}"))
            };
            let mut tree: toml::Value =
                toml::from_str(&text).map_err(|e| bad(e.message().to_string()))?;
            let list = toml::Value::Array(m.iter().cloned().map(toml::Value::String).collect());
            crate::study::set_path(&mut tree, "run.methods", list).map_err(bad)?;
            toml::to_string(&tree).map_err(|e| bad(e.to_string()))?
        }
    };
    let mut sc = Scenario::parse(&text).map_err(|e| {
        // with `methods` the text is regenerated: its line numbers mean nothing
        let e = if methods.is_some() {
            ScenarioError { line: None, ..e }
        } else {
            e
        };
        anyhow::Error::new(e).context(format!("scenario {name}"))
    })?;
    sc.resolve_paths(dir.as_deref().unwrap_or(Path::new("")));
    Ok((sc, name))
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
