//! `nlmode._native`: the Python bindings of the `host` library (PyO3). The
//! pure-Python package `nlmode` (python/nlmode) wraps these functions into
//! its public API (numpy arrays, pandas tables, Dask); nothing here computes
//! on its own: a sweep is [`host::api::compute`], the modal table
//! [`host::methods::nma_table`], the steady state [`host::api::frf`], a
//! study's samples [`host::study::evaluate_samples`], so the numbers are
//! those of the command line.
//!
//! Every long call releases the GIL (`Python::detach`). Errors become
//! `nlmode.ScenarioError` (a `ValueError`) when they are the input's fault (a
//! scenario or study key: the chain holds a
//! [`host::scenario::ScenarioError`] or [`host::study::StudyError`], or a file
//! that cannot be read) and `nlmode.NlmodeError` (a `RuntimeError`)
//! otherwise, with the message `host` prints after `error: `.
#![forbid(unsafe_code)]

use host::api::{self, ScenarioSource};
use host::scenario::ScenarioError as HostScenarioError;
use host::study::{StructureCache, Study as HostStudy, StudyError};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

/// The module's own allocator. Dask's worker processes start with
/// `MALLOC_TRIM_THRESHOLD_=65536` (its `distributed.nanny.pre-spawn-environ`):
/// glibc then hands memory back to the kernel whenever a sweep frees its
/// output buffers and faults it in again for the next one, which halved the
/// study's samples/s on a worker (2,600 against 4,400 per thread, measured
/// with `python/bench/dask_throughput.py`). mimalloc keeps its pages
/// whatever the environment says.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

create_exception!(
    _native,
    ScenarioError,
    PyValueError,
    "A bad scenario or study (the message names the key, as `host` prints it)."
);
create_exception!(
    _native,
    NlmodeError,
    PyRuntimeError,
    "A computation that failed (e.g. an NMA that did not converge)."
);

/// The Python exception of a `host` error, with its `{:#}` message.
fn py_err(e: anyhow::Error) -> PyErr {
    let input = e
        .chain()
        .any(|c| c.is::<HostScenarioError>() || c.is::<StudyError>() || c.is::<std::io::Error>());
    let msg = format!("{e:#}");
    if input {
        ScenarioError::new_err(msg)
    } else {
        NlmodeError::new_err(msg)
    }
}

/// Deepest nesting of a dict converted to TOML (a scenario has 3 levels).
const MAX_DEPTH: usize = 32;

/// A Python value as TOML: dict -> table (string keys), list/tuple -> array,
/// bool, int, float, str. Hand-rolled (30 lines) to keep `bool` apart from
/// `int` and to name the offending key.
fn to_toml(v: &Bound<'_, PyAny>, key: &str, depth: usize) -> PyResult<toml::Value> {
    let bad = |what: &str| ScenarioError::new_err(format!("{key}: {what}"));
    if depth > MAX_DEPTH {
        return Err(bad("nested too deeply"));
    }
    if v.is_instance_of::<PyBool>() {
        Ok(toml::Value::Boolean(v.extract()?))
    } else if v.is_instance_of::<PyInt>() {
        let i: i64 = v
            .extract()
            .map_err(|_| bad("integer out of the 64-bit range"))?;
        Ok(toml::Value::Integer(i))
    } else if v.is_instance_of::<PyFloat>() {
        Ok(toml::Value::Float(v.extract()?))
    } else if v.is_instance_of::<PyString>() {
        Ok(toml::Value::String(v.extract()?))
    } else if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::map::Map::new();
        for (k, x) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| bad("a table's keys must be strings"))?;
            let sub = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            t.insert(k, to_toml(&x, &sub, depth + 1)?);
        }
        Ok(toml::Value::Table(t))
    } else if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = v.try_iter()?.collect::<PyResult<_>>()?;
        let a = items
            .iter()
            .enumerate()
            .map(|(i, x)| to_toml(x, &format!("{key}[{i}]"), depth + 1))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(toml::Value::Array(a))
    } else if let Ok(x) = v.extract::<f64>() {
        // numpy scalars and other numbers
        Ok(toml::Value::Float(x))
    } else {
        Err(bad(&format!(
            "{} is not a TOML value (dict, list, bool, int, float, str)",
            v.get_type().name()?
        )))
    }
}

/// `dict_to_toml(d)`: the TOML text of a scenario or study given as a dict.
#[pyfunction]
fn dict_to_toml(d: &Bound<'_, PyDict>) -> PyResult<String> {
    let v = to_toml(d.as_any(), "", 0)?;
    toml::to_string(&v).map_err(|e| ScenarioError::new_err(format!("scenario: {e}")))
}

fn source<'a>(text: &'a Option<String>, path: &'a Option<PathBuf>) -> ScenarioSource<'a> {
    match (text, path) {
        (Some(t), _) => ScenarioSource::Text(t),
        (None, Some(p)) => ScenarioSource::File(p),
        (None, None) => ScenarioSource::Default,
    }
}

fn columns<'py>(py: Python<'py>, cols: Vec<(String, Vec<f64>)>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, v) in cols {
        d.set_item(name, PyArray1::from_vec(py, v))?;
    }
    Ok(d)
}

/// One matrix given in memory, `(nrows, ncols, rows, cols, values)` with
/// the entries as int64 / float64 arrays (the package's `_matrices` makes
/// them from `scipy.sparse` or dense arrays), checked: equal lengths,
/// indices in range. The values are checked with the files' rules later
/// (finite, square, symmetric, ...: `nlmode::structure::matrices`).
fn triplets(key: &str, v: &Bound<'_, PyAny>) -> PyResult<feio::Triplets> {
    let bad = |m: String| ScenarioError::new_err(format!("matrices['{key}']: {m}"));
    type Entries<'py> = (
        usize,
        usize,
        PyReadonlyArray1<'py, i64>,
        PyReadonlyArray1<'py, i64>,
        PyReadonlyArray1<'py, f64>,
    );
    let (nrows, ncols, rows, cols, vals): Entries = v.extract().map_err(|e| {
        bad(format!(
            "expected (nrows, ncols, rows: int64 array, cols: int64 array, values: float64 array): {e}"
        ))
    })?;
    let (r, c, x) = (rows.as_slice()?, cols.as_slice()?, vals.as_slice()?);
    if r.len() != x.len() || c.len() != x.len() {
        return Err(bad(format!(
            "{} rows, {} cols and {} values: expected one of each per entry",
            r.len(),
            c.len(),
            x.len()
        )));
    }
    let index = |what: &str, i: i64, n: usize, k: usize| {
        usize::try_from(i)
            .ok()
            .filter(|&i| i < n)
            .ok_or_else(|| bad(format!("entry {k}: {what} index {i} is outside 0..{n}")))
    };
    let mut t = feio::Triplets {
        nrows,
        ncols,
        rows: Vec::with_capacity(r.len()),
        cols: Vec::with_capacity(c.len()),
        vals: x.to_vec(),
        ..Default::default()
    };
    for (k, (&i, &j)) in r.iter().zip(c).enumerate() {
        t.rows.push(index("row", i, nrows, k)?);
        t.cols.push(index("column", j, ncols, k)?);
    }
    Ok(t)
}

/// The `matrices` argument (`{"mass": ..., "stiffness": ..., "damping": ...}`
/// of [`triplets`]' tuples) as the scenario's in-memory matrices.
fn in_memory(m: Option<&Bound<'_, PyDict>>) -> PyResult<Option<api::InMemoryMatrices>> {
    let Some(m) = m else { return Ok(None) };
    let get = |key: &str| -> PyResult<Option<Arc<feio::Triplets>>> {
        m.get_item(key)?
            .map(|v| triplets(key, &v).map(Arc::new))
            .transpose()
    };
    let (mass, stiffness, damping) = (get("mass")?, get("stiffness")?, get("damping")?);
    for k in m.keys() {
        let k: String = k.extract()?;
        if !["mass", "stiffness", "damping"].contains(&k.as_str()) {
            return Err(ScenarioError::new_err(format!(
                "matrices: unknown key '{k}', expected 'mass', 'stiffness' and optionally 'damping'"
            )));
        }
    }
    let need = |x: Option<_>, key| {
        x.ok_or_else(|| ScenarioError::new_err(format!("matrices: '{key}' is missing")))
    };
    Ok(Some(api::InMemoryMatrices {
        mass: need(mass, "mass")?,
        stiffness: need(stiffness, "stiffness")?,
        damping,
    }))
}

/// The scenario of `text`/`path` with `methods` and the in-memory matrices.
fn load(
    text: &Option<String>,
    path: &Option<PathBuf>,
    methods: Option<&[String]>,
    matrices: Option<api::InMemoryMatrices>,
) -> anyhow::Result<(host::scenario::Scenario, String)> {
    match matrices {
        None => api::load_scenario(source(text, path), methods),
        Some(m) => api::load_scenario_with_matrices(source(text, path), methods, m),
    }
}

/// `run(text, path, methods, out_dir, fmu_dir, matrices) -> (summary_json, [(name,
/// envelope, time_series or None, tables)])`: a sweep as `host run` computes
/// it; `tables` maps a further table's name (e.g. `hb_frc`) to its columns
/// (numpy arrays, lists of str for labels).
#[pyfunction]
#[pyo3(signature = (text=None, path=None, methods=None, out_dir=None, fmu_dir=None, matrices=None))]
fn run<'py>(
    py: Python<'py>,
    text: Option<String>,
    path: Option<PathBuf>,
    methods: Option<Vec<String>>,
    out_dir: Option<PathBuf>,
    fmu_dir: Option<PathBuf>,
    matrices: Option<Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyTuple>> {
    let mem = in_memory(matrices.as_ref())?;
    let computed = py
        .detach(|| -> anyhow::Result<_> {
            let (sc, name) = load(&text, &path, methods.as_deref(), mem)?;
            // the files some methods leave besides their results (packaged
            // FMUs, phase_resonance.csv): the caller's folder or a temporary one
            let tmp;
            let out: &Path = match &out_dir {
                Some(d) => {
                    std::fs::create_dir_all(d).map_err(|e| {
                        anyhow::Error::new(e)
                            .context(format!("cannot create output directory {}", d.display()))
                    })?;
                    d
                }
                None => {
                    tmp = tempfile::tempdir()?;
                    tmp.path()
                }
            };
            let opts = api::Options {
                fmu_dir,
                echo: false,
                package_fmus: out_dir.is_some(),
            };
            let c = api::compute(&sc, &name, out, &opts)?;
            let summary = serde_json::to_string(&c.summary)?;
            let results: Vec<_> = c
                .results
                .iter()
                .map(|r| {
                    (
                        r.name.clone(),
                        host::results::envelope_columns(r),
                        r.time_series.as_ref().map(|t| t.columns.clone()),
                        r.tables.clone(),
                    )
                })
                .collect();
            Ok((summary, results))
        })
        .map_err(py_err)?;
    let (summary, results) = computed;
    let list = PyList::empty(py);
    for (name, env, ts, tables) in results {
        let ts = match ts {
            Some(t) => columns(py, t)?.into_any(),
            None => py.None().into_bound(py),
        };
        let tabs = PyDict::new(py);
        for t in tables {
            let d = PyDict::new(py);
            for (col, v) in t.columns {
                match v {
                    host::results::Column::Numbers(x) => {
                        d.set_item(col, PyArray1::from_vec(py, x))?
                    }
                    host::results::Column::Text(x) => d.set_item(col, x)?,
                }
            }
            tabs.set_item(t.name, d)?;
        }
        list.append((name, columns(py, env)?, ts, tabs))?;
    }
    (summary, list).into_pyobject(py)
}

/// `nma(text, path, matrices) -> (table_json, note, omega0_rad_s)`: the refined modal
/// table as `host nma` writes it to `modal_table.json`.
#[pyfunction]
#[pyo3(signature = (text=None, path=None, matrices=None))]
fn nma(
    py: Python<'_>,
    text: Option<String>,
    path: Option<PathBuf>,
    matrices: Option<Bound<'_, PyDict>>,
) -> PyResult<(String, String, f64)> {
    let mem = in_memory(matrices.as_ref())?;
    py.detach(|| -> anyhow::Result<_> {
        let (mut sc, name) = load(&text, &path, None, mem)?;
        let setup =
            host::model::Setup::new(&sc).map_err(|e| e.context(format!("scenario {name}")))?;
        // `host nma` computes the table afresh even if the scenario names a file
        sc.nma.table = None;
        let (n, _) = host::methods::nma_table(&setup, &sc, false)?;
        Ok((serde_json::to_string(&n.table)?, n.note, setup.omega0_rad_s))
    })
    .map_err(py_err)
}

/// `frf(text, path, matrices) -> dict`: the steady-state branches (`host frf`'s frf.csv
/// columns, `stable` as bool) and `omega0_rad_s`, `note`.
#[pyfunction]
#[pyo3(signature = (text=None, path=None, matrices=None))]
fn frf<'py>(
    py: Python<'py>,
    text: Option<String>,
    path: Option<PathBuf>,
    matrices: Option<Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mem = in_memory(matrices.as_ref())?;
    let (nma, r, omega0) = py
        .detach(|| -> anyhow::Result<_> {
            let (sc, name) = load(&text, &path, None, mem)?;
            let setup =
                host::model::Setup::new(&sc).map_err(|e| e.context(format!("scenario {name}")))?;
            let (nma, r) = api::frf(&setup, &sc)?;
            Ok((nma, r, setup.omega0_rad_s))
        })
        .map_err(py_err)?;
    let d = columns(
        py,
        vec![
            ("omega_rad_s".into(), r.omega_rad_s),
            ("modal_amplitude".into(), r.modal_amplitude),
            ("tip_amplitude_m".into(), r.tip_amplitude_m),
            ("force_amplitude_N".into(), r.force_amplitude_n),
        ],
    )?;
    d.set_item("stable", PyArray1::from_vec(py, r.stable))?;
    d.set_item("omega0_rad_s", omega0)?;
    d.set_item("note", nma.note)?;
    Ok(d)
}

/// A loaded study and its structure cache.
struct Entry {
    study: HostStudy,
    cache: StructureCache,
}

/// Studies kept in this process (most recent last), each with its cache of
/// structures and modal tables, keyed by the study fingerprint: a Dask
/// worker loads a study and computes its NMA once for all its batches.
type Registry = Mutex<Vec<(String, Arc<Entry>)>>;

fn registry() -> &'static Registry {
    static R: OnceLock<Registry> = OnceLock::new();
    R.get_or_init(Default::default)
}

/// Studies kept by [`registry`] (the oldest is dropped beyond).
const MAX_KEPT_STUDIES: usize = 8;

fn lookup(fingerprint: &str) -> Option<Arc<Entry>> {
    let r = registry().lock().unwrap_or_else(|e| e.into_inner());
    r.iter()
        .find(|(f, _)| f == fingerprint)
        .map(|(_, e)| e.clone())
}

/// Keep `study` (or the entry already kept for its fingerprint, whose cache
/// is warm).
fn keep(study: HostStudy) -> Arc<Entry> {
    let mut r = registry().lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, e)) = r.iter().find(|(f, _)| *f == study.fingerprint) {
        return e.clone();
    }
    let fp = study.fingerprint.clone();
    let e = Arc::new(Entry {
        study,
        cache: StructureCache::new(),
    });
    r.push((fp, e.clone()));
    if r.len() > MAX_KEPT_STUDIES {
        r.remove(0);
    }
    e
}

/// Most worker threads a call may ask for.
const MAX_THREADS: usize = 1024;

/// A study loaded and checked (every sample's scenario), with its per-process
/// structure cache.
#[pyclass(frozen)]
struct Study {
    entry: Arc<Entry>,
}

#[pymethods]
impl Study {
    /// `Study(text, base_dir)`: STUDY.toml text; a relative `scenario` is
    /// taken from `base_dir`.
    #[new]
    fn new(py: Python<'_>, text: String, base_dir: PathBuf) -> PyResult<Self> {
        let st = py
            .detach(|| HostStudy::from_text(&text, &base_dir))
            .map_err(py_err)?;
        Ok(Self { entry: keep(st) })
    }

    /// `Study.cached(fingerprint, text, base_dir)`: the study this process
    /// already holds under `fingerprint`, else loaded (on a Dask worker: once);
    /// an error if the text loads into another study (the files differ there).
    #[staticmethod]
    fn cached(
        py: Python<'_>,
        fingerprint: &str,
        text: String,
        base_dir: PathBuf,
    ) -> PyResult<Self> {
        if let Some(entry) = lookup(fingerprint) {
            return Ok(Self { entry });
        }
        let st = py
            .detach(|| HostStudy::from_text(&text, &base_dir))
            .map_err(py_err)?;
        if st.fingerprint != fingerprint {
            return Err(ScenarioError::new_err(
                "study: the study or its base scenario reads differently here than where it \
                 was submitted (a Dask worker needs the same files at the same paths)",
            ));
        }
        Ok(Self { entry: keep(st) })
    }

    #[getter]
    fn fingerprint(&self) -> String {
        self.entry.study.fingerprint.clone()
    }

    /// The parameter keys (the columns after `sample`).
    #[getter]
    fn keys(&self) -> Vec<String> {
        self.entry.study.keys.clone()
    }

    #[getter]
    fn method(&self) -> String {
        self.entry.study.method.name().to_string()
    }

    /// Samples also run by `reference`.
    #[getter]
    fn reference_samples(&self) -> Vec<usize> {
        self.entry.study.reference_samples.clone()
    }

    /// Structures built so far in this process.
    #[getter]
    fn distinct_structures(&self) -> usize {
        self.entry.cache.distinct()
    }

    fn __len__(&self) -> usize {
        self.entry.study.len()
    }

    /// `evaluate(samples=None, threads=None, header=True, reference=False) -> str`:
    /// the rows of `results.csv` for these samples (all if None), in their
    /// order, computed on `threads` threads (None: all cores); `reference`:
    /// the rows of `results_reference.csv` instead, by `reference` (samples
    /// None: the `reference_subset`).
    #[pyo3(signature = (samples=None, threads=None, header=true, reference=false))]
    fn evaluate(
        &self,
        py: Python<'_>,
        samples: Option<Vec<usize>>,
        threads: Option<usize>,
        header: bool,
        reference: bool,
    ) -> PyResult<String> {
        if let Some(t) = threads {
            if t == 0 || t > MAX_THREADS {
                return Err(ScenarioError::new_err(format!(
                    "threads: {t} is not between 1 and {MAX_THREADS}"
                )));
            }
        }
        let entry = self.entry.clone();
        py.detach(move || -> anyhow::Result<String> {
            let st = &entry.study;
            let all: Vec<usize>;
            let samples = match &samples {
                Some(s) => s.as_slice(),
                None if reference => st.reference_samples.as_slice(),
                None => {
                    all = (0..st.len()).collect();
                    &all
                }
            };
            let method = if reference {
                host::scenario::Method::Reference
            } else {
                st.method
            };
            let go = || host::study::evaluate_samples_by(st, &entry.cache, samples, method);
            let rows = match threads {
                None => go()?,
                Some(t) => rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()?
                    .install(go)?,
            };
            host::study::rows_csv(st, &rows, header)
        })
        .map_err(py_err)
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ScenarioError", m.py().get_type::<ScenarioError>())?;
    m.add("NlmodeError", m.py().get_type::<NlmodeError>())?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(nma, m)?)?;
    m.add_function(wrap_pyfunction!(frf, m)?)?;
    m.add_function(wrap_pyfunction!(dict_to_toml, m)?)?;
    m.add_class::<Study>()?;
    Ok(())
}
