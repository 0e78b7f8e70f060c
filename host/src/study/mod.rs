//! `host study STUDY.toml -o DIR`: a parameter study over any scenario keys.
//!
//! A study names a base scenario, parameters by their dotted scenario keys,
//! a design ([`design`]), a method and a validation subset run by
//! `reference`. Each sample's scenario is the base scenario's TOML value tree
//! with the parameters set at their paths, read by the same parser and
//! checks as a scenario file ([`Scenario::parse`]): every key keeps its own
//! validation, and every sample is checked before the study starts (an
//! unknown key or a value out of a key's range is an error naming the key
//! and the sample, nothing written).
//!
//! Samples run on a rayon pool. The structure (FE model, Craig-Bampton
//! reduction) and its modal table are built once per distinct structure and
//! shared by all threads: the cache is keyed by the serialized `[structure]`,
//! `[[nonlinearity]]` and `[nma]` sections, the exciters' and attachments'
//! points and the response point, which is everything they depend on
//! ([`structure_key`]); so is the
//! table's interpolant (the reduced model without attachments). Samples
//! that differ only in the sweep's voltage and rate ([`SWEEP_KEYS`]) form a
//! group ([`Study::groups`]) sharing one setup and one slow-flow model with
//! its attachments, whose condensation `Z_G`, `T_G` is remembered by
//! frequency ([`memo::Memo`]): per sample only the sweep is built,
//! integrated and folded. The figures of merit are folded as the sweep integrates: the
//! slow flow hands its output samples to a [`fom::Fold`] in batches of
//! [`nlmode::reduced::SWEEP_BATCH`]
//! ([`nlmode::reduced::ReducedModel::simulate_sweep_folded`], the one sweep
//! kernel; `host run` stores the same samples through it), so no envelope is
//! kept or written. The numbers stay bit-identical to `host run`'s
//! `summary.json`: the same samples (same integration, same output
//! expressions, element-wise, so batching changes nothing) are folded in the
//! same order by the same expressions as its summary ([`fom`]). A sweep that
//! stops early with a sample count in another jump-down window than
//! announced is run again storing its samples (exact, rare).
//! Rows are appended to `DIR/results.csv` in batches as samples finish
//! ([`output::RowWriter`]: at most the rows finished in the last half
//! second, fewer than 64, are lost to an interruption); `--resume` skips the
//! samples already there. At the end the rows are sorted by sample (the files do not depend
//! on the thread count), `results.parquet` is rebuilt from the sorted CSV,
//! and `study_summary.json` and the plots are written ([`output`]).
pub mod bench;
pub mod design;
pub mod fom;
pub mod memo;
pub mod output;

use crate::methods;
use crate::model::Setup;
use crate::scenario::{Method, Scenario, DEFAULT_SCENARIO};
use anyhow::{Context, Result};
use design::{DesignKind, ParameterSpec};
use fom::Figures;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

/// A bad study file or a sample it produces (`host study` exits 2, nothing written).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StudyError {
    /// A top-level key of STUDY.toml.
    #[error("study: {key}: {message}")]
    Study { key: String, message: String },
    /// A `[[parameter]]` (its scenario key).
    #[error("study: parameter {key}: {message}")]
    Parameter { key: String, message: String },
    /// A sample whose scenario is invalid.
    #[error("study: sample {sample} ({values}): {message}")]
    Sample {
        sample: usize,
        /// `key = value, ...` of the sample.
        values: String,
        message: String,
    },
}

/// STUDY.toml as written.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StudySpec {
    /// Base scenario file, relative to the study file; the embedded default if omitted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scenario: Option<String>,
    /// `nlmode` (default), `linear-slowflow` or `reference`.
    #[serde(default = "default_method")]
    pub method: String,
    pub design: DesignKind,
    /// Random and lhs designs: the number of samples (grids: the product of the values' lengths).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    #[serde(default)]
    pub seed: u64,
    /// Samples also run by `reference` (evenly spread over the design).
    #[serde(default)]
    pub reference_subset: usize,
    #[serde(default)]
    pub parameter: Vec<ParameterSpec>,
}

fn default_method() -> String {
    Method::Nlmode.name().into()
}

/// Whether a study can run `method` per sample (the registry's
/// [`methods::Method::in_studies`]).
fn study_method(method: Method) -> bool {
    methods::get(method).in_studies()
}

/// A study ready to run: every sample's scenario parsed and checked.
pub struct Study {
    pub spec: StudySpec,
    pub method: Method,
    /// Parameter keys in order (the columns after `sample`).
    pub keys: Vec<String>,
    /// `values[sample][parameter]`.
    pub values: Vec<Vec<toml::Value>>,
    pub scenarios: Vec<Scenario>,
    /// Samples also run by `reference`, increasing.
    pub reference_samples: Vec<usize>,
    /// The text identifying this study (`study_fingerprint.json`).
    pub fingerprint: String,
    /// `groups[sample]`: samples of one group differ only in the sweep's
    /// voltage and rate ([`SWEEP_KEYS`]), so they share the structure's
    /// setup and the slow-flow model with its attachments ([`group_key`]).
    pub groups: Vec<usize>,
}

/// Parameters that change only the sweep (`LinearSweep`) of a sample: its
/// setup and its model with attachments are those of any other sample with
/// the same other values ([`Study::groups`]), as long as no exciter has its
/// own `voltage_v` (its input is then the ratio to `excitation.voltage_v`).
pub const SWEEP_KEYS: [&str; 2] = ["excitation.voltage_v", "excitation.rate_per_pseudo_period"];

/// The values of a sample that its setup and slow-flow model depend on:
/// every parameter except [`SWEEP_KEYS`] (the voltage too when an exciter
/// has its own), as text.
fn group_key(keys: &[String], values: &[toml::Value], sc: &Scenario) -> String {
    let exciter_voltage = sc.exciter.iter().any(|e| e.voltage_v.is_some());
    let mut k = String::new();
    for (key, v) in keys.iter().zip(values) {
        let free = SWEEP_KEYS.contains(&key.as_str())
            && !(exciter_voltage && key == "excitation.voltage_v");
        if !free {
            k.push_str(&v.to_string());
        }
        k.push('\u{1f}');
    }
    k
}

impl Study {
    /// Read STUDY.toml and check it and every sample.
    pub fn load(path: &Path) -> Result<Self> {
        let text = cosim::file::read_regular_to_string(path, crate::scenario::MAX_SCENARIO_BYTES)
            .with_context(|| format!("cannot read study file {}", path.display()))?;
        let base_dir = path.parent().unwrap_or(Path::new(""));
        Self::from_text(&text, base_dir)
    }

    /// A study from its TOML text; `base_dir`: where a relative `scenario` is.
    pub fn from_text(text: &str, base_dir: &Path) -> Result<Self> {
        let spec: StudySpec = serde_path_to_error::deserialize(toml::Deserializer::new(text))
            .map_err(|e| {
                let path = e.path().to_string();
                StudyError::Study {
                    key: if path == "." { "study".into() } else { path },
                    message: e.into_inner().message().trim().to_string(),
                }
            })?;
        let method = methods::by_name(&spec.method)
            .map(|m| m.id())
            .filter(|&m| study_method(m))
            .ok_or_else(|| StudyError::Study {
                key: "method".into(),
                message: format!(
                    "\"{}\" is not a study method (nlmode | linear-slowflow | reference)",
                    spec.method
                ),
            })?;
        if spec.parameter.is_empty() {
            return Err(StudyError::Study {
                key: "parameter".into(),
                message: "a study needs at least one [[parameter]]".into(),
            }
            .into());
        }
        let mut keys: Vec<String> = Vec::new();
        for p in &spec.parameter {
            if keys.contains(&p.key) {
                return Err(StudyError::Parameter {
                    key: p.key.clone(),
                    message: "given twice".into(),
                }
                .into());
            }
            keys.push(p.key.clone());
        }
        let (base_text, scenario_dir) = match &spec.scenario {
            None => (DEFAULT_SCENARIO.to_string(), None),
            Some(rel) => {
                let p = base_dir.join(rel);
                let t =
                    cosim::file::read_regular_to_string(&p, crate::scenario::MAX_SCENARIO_BYTES)
                        .with_context(|| format!("study: scenario: cannot read {}", p.display()))?;
                (t, Some(p.parent().unwrap_or(Path::new("")).to_path_buf()))
            }
        };
        // the base scenario itself must be valid
        Scenario::parse(&base_text).map_err(|e| StudyError::Study {
            key: "scenario".into(),
            message: e.to_string(),
        })?;
        let base: toml::Value = toml::from_str(&base_text).map_err(|e| StudyError::Study {
            key: "scenario".into(),
            message: e.message().to_string(),
        })?;
        let values = design::samples(spec.design, &spec.parameter, spec.samples, spec.seed)?;
        let n = values.len();
        if spec.reference_subset > n {
            return Err(StudyError::Study {
                key: "reference_subset".into(),
                message: format!(
                    "{} samples asked of a study of {n} samples",
                    spec.reference_subset
                ),
            }
            .into());
        }
        let reference_samples: Vec<usize> = (0..spec.reference_subset)
            .map(|k| k * n / spec.reference_subset)
            .collect();
        // every sample through the scenario parser, before anything runs; a
        // slow-flow method's sweep refuses what only the controllers apply
        let slow_flow = methods::get(method).section() == Some("slowflow");
        let scenarios = {
            use rayon::prelude::*;
            values
                .par_iter()
                .enumerate()
                .map(|(i, v)| {
                    sample_scenario(&base, &keys, v, scenario_dir.as_deref())
                        .and_then(|sc| {
                            if slow_flow {
                                let name = method.name();
                                let check = sc.slowflow.check_sweep_projection(name);
                                check.map_err(|e| e.to_string())?;
                            }
                            Ok(sc)
                        })
                        .map_err(|message| StudyError::Sample {
                            sample: i,
                            values: describe(&keys, v),
                            message,
                        })
                })
                .collect::<Result<Vec<_>, _>>()?
        };
        let groups = {
            let mut index: HashMap<String, usize> = HashMap::new();
            values
                .iter()
                .zip(&scenarios)
                .map(|(v, sc)| {
                    let next = index.len();
                    *index.entry(group_key(&keys, v, sc)).or_insert(next)
                })
                .collect()
        };
        let fingerprint = serde_json::to_string_pretty(&serde_json::json!({
            "format": "nlmode-study",
            "version": 1,
            "study": &spec,
            "scenario": base_text,
        }))?;
        Ok(Self {
            spec,
            method,
            keys,
            values,
            scenarios,
            reference_samples,
            fingerprint,
            groups,
        })
    }

    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }
}

/// `key = value, ...`.
fn describe(keys: &[String], v: &[toml::Value]) -> String {
    keys.iter()
        .zip(v)
        .map(|(k, x)| format!("{k} = {x}"))
        .collect::<Vec<_>>()
        .join(", ")
}

pub use crate::scenario::set_path;

/// The scenario of one sample: parameters set in the base tree, read and
/// checked as [`Scenario::parse`] reads a file.
fn sample_scenario(
    base: &toml::Value,
    keys: &[String],
    values: &[toml::Value],
    scenario_dir: Option<&Path>,
) -> Result<Scenario, String> {
    let mut tree = base.clone();
    for (k, v) in keys.iter().zip(values) {
        set_path(&mut tree, k, v.clone())?;
    }
    // Deserialized from the tree itself, then checked as [`Scenario::parse`]
    // does: writing the tree out as TOML text and parsing that again cost
    // ~550 k instructions per sample, most of loading a large study (the
    // method names: the registry's catalog, as `Scenario::parse` reads).
    let read = || serde_path_to_error::deserialize::<_, Scenario>(tree);
    let mut sc: Scenario = crate::methods::catalog().scope(read).map_err(|e| {
        let path = e.path().to_string();
        crate::scenario::ScenarioError {
            key: if path == "." { "scenario".into() } else { path },
            message: e.into_inner().message().trim().to_string(),
            line: None,
        }
        .to_string()
    })?;
    sc.validate().map_err(|e| e.to_string())?;
    if let Some(d) = scenario_dir {
        sc.resolve_paths(d);
    }
    Ok(sc)
}

/// What the structure and its modal table depend on: `[structure]`, `[nma]`,
/// the exciter locations and the response point, serialized.
pub fn structure_key(sc: &Scenario) -> String {
    let locations: Vec<_> = sc
        .exciter
        .iter()
        .map(|e| (&e.location, &e.location_m, &e.point))
        .collect();
    // attachments' points become structure points (beam nodes, Craig-Bampton masters)
    let attached: Vec<_> = sc
        .attachment
        .iter()
        .map(|a| (&a.location, &a.location_m, &a.point, &a.points))
        .collect();
    serde_json::to_string(&(
        &sc.structure,
        &sc.nonlinearity,
        &sc.nma,
        locations,
        attached,
        sc.response_point(),
    ))
    .unwrap_or_default()
}

/// A structure shared by the samples that have it.
struct Prepared {
    setup: Setup,
    /// The modal table, computed on first use.
    table: OnceLock<Result<nlmode::nma::ModalTable, String>>,
    /// The reduced model of the table without attachments (its interpolant), built once.
    base_model: OnceLock<Result<nlmode::reduced::ReducedModel, String>>,
}

impl Prepared {
    /// The modal table of this structure (`sc`: a scenario having it), computed once.
    fn table(&self, sc: &Scenario) -> Result<&nlmode::nma::ModalTable, String> {
        self.table
            .get_or_init(|| {
                methods::nma_table(&self.setup, sc, false)
                    .map(|(n, _)| n.table)
                    .map_err(|e| format!("{e:#}"))
            })
            .as_ref()
            .map_err(|e| e.clone())
    }

    /// The single-mode model of the table at the response and first exciter
    /// points, without attachments ([`methods::reduced_model`] adds them).
    fn base_model(&self, sc: &Scenario) -> Result<&nlmode::reduced::ReducedModel, String> {
        let table = self.table(sc)?;
        self.base_model
            .get_or_init(|| {
                let s = &self.setup;
                nlmode::reduced::ReducedModel::new(table, &s.response_point, &s.exciter_points[0])
                    .map_err(|e| e.to_string())
            })
            .as_ref()
            .map_err(|e| e.clone())
    }
}

/// The per-structure cache: one entry per [`structure_key`], built once by
/// the first sample that needs it while the others wanting the same
/// structure wait. A failed build is not kept: it may be the sample's own
/// fault (e.g. its exciter), so the next sample tries again.
#[derive(Default)]
struct Cache {
    map: Mutex<HashMap<String, Slot<Prepared>>>,
    /// The slow-flow plans by ([`Study::groups`] index, method).
    plans: Mutex<HashMap<(usize, Method), Slot<Plan>>>,
}

/// A value built once and shared, or `None` while (or after failing) to be built.
type Slot<T> = Arc<Mutex<Option<Arc<T>>>>;

/// What the samples of one group ([`Study::groups`]) share for a slow-flow
/// method: from the setup of the first of them (the others differ only in
/// the sweep, [`crate::model::sweep_of`]) the single-mode model with its
/// attachments (their condensation remembered, [`memo::Memo`]), the
/// frequency error and, for `linear-slowflow`, linearized: per sample only
/// the sweep is built and integrated. Every number is the one the sample
/// would get from its own setup and model.
struct Plan {
    /// `omega0` of the structure \[rad/s\] (the sweep's reference).
    omega0_rad_s: f64,
    model: nlmode::reduced::ReducedModel,
    /// A copy of `model` per worker thread: the model's table lookup keeps
    /// the segment of its last call as a search hint (`nlmode::reduced`'s
    /// fast table), which samples sweeping in two threads at once would
    /// overwrite for each other at every evaluation (the cache line moving
    /// between the cores, the hint useless): 6,000 samples/s on 2 threads
    /// against 12,000 for two processes. The copies share the attachments'
    /// memo ([`memo::Memo`], behind an `Arc`).
    per_thread: thread_local::ThreadLocal<nlmode::reduced::ReducedModel>,
}

/// Plans a [`Cache`] keeps (a study of more groups builds the others per
/// sample): each holds a model with its table interpolant (~100 kB).
const MAX_PLANS: usize = 256;

impl Plan {
    fn new(prepared: &Prepared, sc: &Scenario, method: Method) -> Result<Self, String> {
        let setup = prepared
            .setup
            .with_scenario(sc)
            .map_err(|e| format!("{e:#}"))?;
        let base = prepared.base_model(sc)?.clone();
        let f = &sc.imposed_force;
        let error = nlmode::reduced::FrequencyError {
            eps: f.frequency_error,
            offset_rad_s: f.frequency_offset_rad_s + f.frequency_offset_omega0 * setup.omega0_rad_s,
        };
        // as `host run`: `nlmode-freq-error` when the scenario detunes nlmode
        let detuned = method == Method::Nlmode
            && f.apply_to_nlmode
            && (error.eps != 0.0 || error.offset_rad_s != 0.0);
        // methods::with_attachments, the attachments' condensation remembered
        let model = (|| -> Result<nlmode::reduced::ReducedModel> {
            let mut m = base;
            for (att, u) in setup.attachments.iter().zip(&setup.inputs) {
                let prepared =
                    nlmode::reduced::PreparedAttachment::new(att.clone()).map_err(|e| {
                        nlmode::reduced::ReducedError::Attachment {
                            attachment: att.name.clone(),
                            omega_rad_s: f64::NAN,
                            source: Box::new(e),
                        }
                    })?;
                m = m.with_attachment(Arc::new(memo::Memo::new(prepared)), u)?;
            }
            if detuned {
                m = m.with_frequency_error(error)?;
            }
            Ok(m)
        })()
        .map_err(|e| format!("{e:#}"))?;
        let model = if method == Method::LinearSlowflow {
            model.linear().map_err(|e| format!("{e}"))?
        } else {
            model
        };
        Ok(Self {
            omega0_rad_s: setup.omega0_rad_s,
            model,
            per_thread: thread_local::ThreadLocal::new(),
        })
    }

    /// This thread's copy of the model (the same numbers: a clone).
    fn model(&self) -> &nlmode::reduced::ReducedModel {
        self.per_thread.get_or(|| self.model.clone())
    }
}

impl Cache {
    /// The plan of `group` for `method` (`sc`: a sample of the group), built
    /// once; a failed build is not kept (as [`Cache::get`]).
    fn plan(&self, group: usize, sc: &Scenario, method: Method) -> Result<Arc<Plan>, String> {
        let cell = {
            let mut m = self.plans.lock().unwrap_or_else(|e| e.into_inner());
            if m.len() >= MAX_PLANS && !m.contains_key(&(group, method)) {
                None
            } else {
                Some(m.entry((group, method)).or_default().clone())
            }
        };
        let Some(cell) = cell else {
            // not kept (bounded memory)
            return Ok(Arc::new(Plan::new(&*self.get(sc)?, sc, method)?));
        };
        let mut slot = cell.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = slot.as_ref() {
            return Ok(p.clone());
        }
        let prepared = self.get(sc)?;
        let p = Arc::new(Plan::new(&prepared, sc, method)?);
        *slot = Some(p.clone());
        Ok(p)
    }

    fn get(&self, sc: &Scenario) -> Result<Arc<Prepared>, String> {
        let cell = {
            let mut m = self.map.lock().unwrap_or_else(|e| e.into_inner());
            m.entry(structure_key(sc)).or_default().clone()
        };
        let mut slot = cell.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = slot.as_ref() {
            return Ok(p.clone());
        }
        let setup = Setup::new(sc).map_err(|e| format!("{e:#}"))?;
        setup.check_driven().map_err(|e| format!("{e:#}"))?;
        let p = Arc::new(Prepared {
            setup,
            table: OnceLock::new(),
            base_model: OnceLock::new(),
        });
        *slot = Some(p.clone());
        Ok(p)
    }

    /// Structures built.
    fn distinct(&self) -> usize {
        let m = self.map.lock().unwrap_or_else(|e| e.into_inner());
        m.values()
            .filter(|c| c.lock().map(|s| s.is_some()).unwrap_or(false))
            .count()
    }
}

/// One finished sample: a row of `results.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub sample: usize,
    pub figures: Figures,
    pub left_table: bool,
    /// `ok` or the error.
    pub status: String,
}

/// How [`run_sample_with`] takes a slow-flow sweep's figures of merit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SweepPath {
    /// Folded as the sweep integrates ([`fom::Fold`] as the sweep's sink): no envelope.
    Fold,
    /// The sweep's samples stored, then folded (the path before the sink; the bench's baseline).
    Stored,
}

/// Run `method` on one sample's scenario (`group`: its [`Study::groups`] entry).
fn run_sample(cache: &Cache, sample: usize, group: usize, sc: &Scenario, method: Method) -> Row {
    run_sample_with(cache, sample, group, sc, method, SweepPath::Fold)
}

/// [`run_sample`] by either [`SweepPath`]: the rows are identical, bit for
/// bit (the same samples folded in the same order by the same expressions).
// (never inlined: the per-sample cost is measured on this function,
// `valgrind --tool=callgrind --toggle-collect='*run_sample_with*'`, and a
// call per sample is nothing against its sweep)
#[inline(never)]
fn run_sample_with(
    cache: &Cache,
    sample: usize,
    group: usize,
    sc: &Scenario,
    method: Method,
    path: SweepPath,
) -> Row {
    let row = |figures, left_table, status: String| Row {
        sample,
        figures,
        left_table,
        status,
    };
    let result = (|| -> Result<Row, String> {
        match method {
            Method::Reference => {
                let prepared = cache.get(sc)?;
                let setup = prepared
                    .setup
                    .with_scenario(sc)
                    .map_err(|e| format!("{e:#}"))?;
                let r =
                    methods::reference(&setup, sc, &mut |_| {}).map_err(|e| format!("{e:#}"))?;
                Ok(row(
                    Figures::of_envelope(&r.envelope, true),
                    false,
                    "ok".into(),
                ))
            }
            _ => {
                let plan = cache.plan(group, sc, method)?;
                // the sample's own sweep (the rest of its setup is the group's)
                let sweep =
                    crate::model::sweep_of(sc, plan.omega0_rad_s).map_err(|e| format!("{e:#}"))?;
                let model = plan.model();
                let opts = sc.slowflow.options(method);
                let stored = || {
                    model
                        .simulate_sweep(&sweep, &opts)
                        .map(|res| (Figures::of_slow_flow(&res), res.status))
                };
                let (figures, status) = match path {
                    SweepPath::Stored => stored(),
                    SweepPath::Fold => {
                        let mut fold = fom::Fold::new(opts.output_samples);
                        let zero = num_complex::Complex64::new(0.0, 0.0);
                        model
                            .simulate_sweep_folded(&sweep, &opts, zero, &mut fold)
                            .and_then(|run| {
                                if fold.is_exact() {
                                    Ok((fold.finish(true), run.status))
                                } else {
                                    // stopped early with another jump-down window
                                    // than announced: the stored path, exact
                                    stored()
                                }
                            })
                    }
                }
                .map_err(|e| format!("{method}: {e}"))?;
                use nlmode::reduced::SweepStatus;
                let (left, status) = match status {
                    SweepStatus::Completed => (false, "ok".to_string()),
                    SweepStatus::LeftTableRange { .. } => (true, "ok".to_string()),
                    other => (false, format!("sweep stopped early: {other:?}")),
                };
                Ok(row(figures, left, status))
            }
        }
    })();
    result.unwrap_or_else(|e| row(Figures::default(), false, e.replace(['\n', '\r'], " ")))
}

/// What a study did.
#[derive(Debug, Clone, Serialize)]
pub struct Outcome {
    pub samples: usize,
    /// Samples computed by this invocation (the others were in the folder: `--resume`).
    pub computed: usize,
    pub failed: usize,
    pub distinct_structures: usize,
    pub threads: usize,
    /// Whole study [s].
    pub wall_time_s: f64,
    /// Building the distinct structures and their modal tables [s].
    pub structures_s: f64,
    /// Running the samples, results written [s].
    pub samples_s: f64,
    /// Samples computed per second of `samples_s`.
    pub samples_per_s: f64,
    pub files: Vec<PathBuf>,
}

/// Options of [`study`].
#[derive(Debug, Clone, Default)]
pub struct Options {
    pub resume: bool,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// Show the progress bar (on a terminal).
    pub progress: bool,
}

/// `host study STUDY.toml -o DIR`.
pub fn study(path: &Path, out: &Path, opts: &Options) -> Result<Outcome> {
    let st = Study::load(path)?;
    run_study(&st, out, opts)
}

/// Run a loaded study into `out`.
pub fn run_study(st: &Study, out: &Path, opts: &Options) -> Result<Outcome> {
    run_study_with(st, out, opts, SweepPath::Fold)
}

/// [`run_study`] with the slow-flow figures of merit taken by `path`.
pub(crate) fn run_study_with(
    st: &Study,
    out: &Path,
    opts: &Options,
    path: SweepPath,
) -> Result<Outcome> {
    use rayon::prelude::*;
    let t0 = std::time::Instant::now();
    if opts.threads == Some(0) {
        anyhow::bail!("--threads must be at least 1");
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;
    let threads = pool.current_num_threads();
    let files = output::StudyFiles::open(out, st, opts.resume)?;
    let cache = Cache::default();
    let mut computed = 0;
    // main method, then the reference subset
    let mut jobs: Vec<(output::Table, Method, Vec<usize>)> =
        vec![(output::Table::Main, st.method, (0..st.len()).collect())];
    if !st.reference_samples.is_empty() {
        jobs.push((
            output::Table::Reference,
            Method::Reference,
            st.reference_samples.clone(),
        ));
    }
    let mut structures_s = 0.0;
    let mut samples_s = 0.0;
    for (table, method, samples) in jobs {
        let todo: Vec<usize> = samples
            .into_iter()
            .filter(|i| !files.done(table, *i))
            .collect();
        // the distinct structures (and modal tables) first, in parallel; a
        // failure is left to the samples to record
        let t1 = std::time::Instant::now();
        // (a group has one structure: the first sample of each group is enough)
        let mut firsts: Vec<usize> = Vec::new();
        let (mut groups, mut structures) = (HashSet::new(), HashSet::new());
        for &i in &todo {
            if groups.insert(st.groups[i]) && structures.insert(structure_key(&st.scenarios[i])) {
                firsts.push(i);
            }
        }
        pool.install(|| {
            firsts.par_iter().for_each(|&i| {
                let sc = &st.scenarios[i];
                if let Ok(p) = cache.get(sc) {
                    if methods::get(method).needs_mode(sc) {
                        let _ = p.base_model(sc);
                    }
                }
            })
        });
        structures_s += t1.elapsed().as_secs_f64();
        let t2 = std::time::Instant::now();
        let bar = progress_bar(todo.len(), table.label(method), opts.progress);
        let writer = files.writer(table);
        let failed: Result<()> = pool.install(|| {
            todo.par_iter().try_for_each(|&i| {
                let r = match path {
                    SweepPath::Fold => {
                        run_sample(&cache, i, st.groups[i], &st.scenarios[i], method)
                    }
                    other => {
                        run_sample_with(&cache, i, st.groups[i], &st.scenarios[i], method, other)
                    }
                };
                writer.append(st, &r)?;
                bar.inc(1);
                Ok(())
            })
        });
        bar.finish_and_clear();
        failed.and_then(|()| writer.flush())?;
        samples_s += t2.elapsed().as_secs_f64();
        computed += todo.len();
    }
    let wall = t0.elapsed().as_secs_f64();
    let stats = output::RunStats {
        threads,
        wall_time_s: wall,
        structures_s,
        samples_s,
        computed,
        distinct_structures: cache.distinct(),
    };
    let summary = files.finish(st, &stats)?;
    Ok(Outcome {
        samples: st.len(),
        computed,
        failed: summary.failed,
        distinct_structures: cache.distinct(),
        threads,
        wall_time_s: wall,
        structures_s,
        samples_s,
        samples_per_s: stats.samples_per_s(),
        files: summary.files,
    })
}

fn progress_bar(n: usize, label: String, show: bool) -> indicatif::ProgressBar {
    if !show {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(n as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{msg:>10} [{bar:40}] {pos}/{len} {per_sec} ETA {eta}",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(label);
    bar
}

/// The per-structure cache of a study (structures, modal tables and their
/// interpolants, built once each) for callers that run samples themselves:
/// the Python package keeps one per study in its process, so that each Dask
/// worker builds a structure once for all the batches it is given.
#[derive(Default)]
pub struct StructureCache(Cache);

impl StructureCache {
    pub fn new() -> Self {
        Self::default()
    }

    /// Structures built so far.
    pub fn distinct(&self) -> usize {
        self.0.distinct()
    }
}

/// Run the study's method on the given samples (indices into the design) on
/// the current rayon pool, rows in the order of `samples`: the same rows
/// `host study` writes for them (a failing sample is a row with its error).
/// An index outside the design is an error naming it.
pub fn evaluate_samples(
    st: &Study,
    cache: &StructureCache,
    samples: &[usize],
) -> Result<Vec<Row>, StudyError> {
    evaluate_samples_by(st, cache, samples, st.method)
}

/// [`evaluate_samples`] by `method`: the study's own, or
/// [`Method::Reference`] for the rows of `results_reference.csv` (the
/// `reference_subset`, [`Study::reference_samples`]; any sample may be asked).
pub fn evaluate_samples_by(
    st: &Study,
    cache: &StructureCache,
    samples: &[usize],
    method: Method,
) -> Result<Vec<Row>, StudyError> {
    use rayon::prelude::*;
    if !study_method(method) {
        return Err(StudyError::Study {
            key: "method".into(),
            message: format!("\"{method}\" is not a study method"),
        });
    }
    if let Some(&i) = samples.iter().find(|&&i| i >= st.len()) {
        return Err(StudyError::Study {
            key: "samples".into(),
            message: format!("sample {i} asked of a study of {} samples", st.len()),
        });
    }
    Ok(samples
        .par_iter()
        .map(|&i| run_sample(&cache.0, i, st.groups[i], &st.scenarios[i], method))
        .collect())
}

/// Rows as the text of `results.csv` (its header first when `header`), in the
/// given order, formatted by [`output::record`].
pub fn rows_csv(st: &Study, rows: &[Row], header: bool) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    if header {
        w.write_record(output::header(st))?;
    }
    for r in rows {
        w.write_record(output::record(st, r))?;
    }
    let bytes = w.into_inner().map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(String::from_utf8(bytes)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_path_enters_tables_and_arrays() {
        let mut v: toml::Value = toml::from_str(DEFAULT_SCENARIO).unwrap();
        set_path(&mut v, "excitation.voltage_v", toml::Value::Float(3.0)).unwrap();
        set_path(&mut v, "exciter.0.location", toml::Value::Float(0.5)).unwrap();
        assert_eq!(v["excitation"]["voltage_v"].as_float(), Some(3.0));
        assert_eq!(v["exciter"][0]["location"].as_float(), Some(0.5));
        let e = set_path(&mut v, "exciter.3.location", toml::Value::Float(0.5)).unwrap_err();
        assert!(e.contains("exciter.3") && e.contains("out of range"), "{e}");
        let e = set_path(&mut v, "cosim.point.0", toml::Value::Float(0.5)).unwrap_err();
        assert!(e.contains("cosim.point") && e.contains("no"), "{e}");
        let e = set_path(&mut v, "title.x", toml::Value::Float(0.5)).unwrap_err();
        assert!(e.contains("title.x"), "{e}");
    }

    #[test]
    fn unknown_key_and_bad_value_name_the_key_and_sample() {
        let base = Path::new(".");
        let t =
            "design = \"grid\"\n[[parameter]]\nkey = \"excitation.voltage_vv\"\nvalues = [1.0]\n";
        let e = Study::from_text(t, base).err().unwrap().to_string();
        assert!(
            e.contains("excitation.voltage_vv") && e.contains("sample 0"),
            "{e}"
        );
        let t = "design = \"grid\"\n[[parameter]]\nkey = \"excitation.voltage_v\"\nvalues = [1.0, -2.0]\n";
        let e = Study::from_text(t, base).err().unwrap().to_string();
        assert!(
            e.contains("excitation.voltage_v") && e.contains("sample 1"),
            "{e}"
        );
        let t = "design = \"lhs\"\nsamples = 3\nreference_subset = 4\n[[parameter]]\nkey = \"excitation.voltage_v\"\ndistribution = \"uniform\"\nlow = 1.0\nhigh = 2.0\n";
        let e = Study::from_text(t, base).err().unwrap().to_string();
        assert!(e.contains("reference_subset"), "{e}");
    }

    #[test]
    fn every_example_study_loads() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if name.starts_with("study_") && name.ends_with(".toml") {
                let st = Study::load(&p).unwrap_or_else(|e| panic!("{}: {e:#}", p.display()));
                assert!(!st.is_empty());
                n += 1;
            }
        }
        assert!(n >= 1, "no example study");
    }

    #[test]
    fn the_structure_key_ignores_the_excitation() {
        let a = Scenario::default_scenario();
        let mut b = a.clone();
        b.excitation.voltage_v = 3.0;
        b.exciter[0].armature_mass_kg = 0.05;
        assert_eq!(structure_key(&a), structure_key(&b));
        if let crate::scenario::StructureSpec::Beam(s) = &mut b.structure {
            s.k3_n_per_m3 = 1e9;
        }
        assert_ne!(structure_key(&a), structure_key(&b));
    }
}
