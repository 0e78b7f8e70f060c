//! The generic co-simulation file (TOML, format in `docs/cosim.md`): any FMI
//! 2.0 Co-Simulation FMUs, connections, parameters and recorded variables,
//! read and checked into a [`GenericSpec`] for [`crate::master::run_generic`].
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::Deserialize;

use crate::master::{Algorithm, GenericSpec, MasterOptions, ParamValue};

/// Why a co-simulation file cannot be used; each variant names the file and the key.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Toml { path: PathBuf, message: String },
    #[error("{path}: master.algorithm: {message}")]
    Algorithm { path: PathBuf, message: String },
    #[error("{path}: master.macro_step_s: expected a positive step, got {value}")]
    MacroStep { path: PathBuf, value: f64 },
    #[error("{path}: master.stop_time_s: expected > start_time_s ({start}), got {stop}")]
    StopTime {
        path: PathBuf,
        start: f64,
        stop: f64,
    },
    #[error("{path}: master.{0}", .source)]
    Steps {
        path: PathBuf,
        source: Box<crate::master::MasterError>,
    },
    #[error(transparent)]
    File(#[from] fmi2::FileError),
    #[error("{path}: units: expected at least one `name = \"file.fmu\"`")]
    NoUnits { path: PathBuf },
    #[error("parameters.\"{key}\": {value} does not fit an fmi2Integer")]
    Integer { key: String, value: i64 },
    #[error("parameters.\"{key}\": expected a number, boolean or string, got {found}")]
    ParamType { key: String, found: String },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Spec {
    #[serde(default)]
    master: MasterSpec,
    /// unit name -> .fmu path (relative paths are relative to the spec file)
    units: BTreeMap<String, String>,
    /// `["unit.output", "unit.input"]` pairs
    #[serde(default)]
    connections: Vec<[String; 2]>,
    /// `"unit.variable" = value` (number, boolean, integer or string)
    #[serde(default)]
    parameters: BTreeMap<String, toml::Value>,
    /// `"unit.variable"` Real variables to record
    #[serde(default)]
    record: Vec<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct MasterSpec {
    algorithm: String,
    macro_step_s: f64,
    extrapolate: bool,
    directional_derivatives: bool,
    start_time_s: f64,
    stop_time_s: f64,
    record_every: usize,
}

impl Default for MasterSpec {
    fn default() -> Self {
        Self {
            algorithm: "jacobi".into(),
            macro_step_s: 1e-5,
            extrapolate: true,
            directional_derivatives: false,
            start_time_s: 0.0,
            stop_time_s: 1.0,
            record_every: 1,
        }
    }
}

fn param(key: &str, v: &toml::Value) -> Result<ParamValue, SpecError> {
    Ok(match v {
        toml::Value::Float(x) => ParamValue::Real(*x),
        toml::Value::Integer(i) => {
            ParamValue::Integer(i32::try_from(*i).map_err(|_| SpecError::Integer {
                key: key.into(),
                value: *i,
            })?)
        }
        toml::Value::Boolean(b) => ParamValue::Boolean(*b),
        toml::Value::String(s) => ParamValue::String(s.clone()),
        other => {
            return Err(SpecError::ParamType {
                key: key.into(),
                found: other.to_string(),
            })
        }
    })
}

/// Largest co-simulation file read [bytes] (a real one is a few hundred).
pub const MAX_SPEC_BYTES: u64 = 1 << 20;

/// Read and check the co-simulation file `path` (a regular file of at most
/// [`MAX_SPEC_BYTES`]); relative `.fmu` paths are
/// taken relative to the file's folder.
pub fn load_spec(path: &Path) -> Result<GenericSpec, SpecError> {
    let text = fmi2::read_regular_to_string(path, MAX_SPEC_BYTES)?;
    parse_spec(&text, path)
}

/// Check the text of a co-simulation file (`path` names it in errors and is
/// the base of relative `.fmu` paths).
// `!(stop > start)` on purpose: NaN times are refused too
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn parse_spec(text: &str, path: &Path) -> Result<GenericSpec, SpecError> {
    let spec: Spec = toml::from_str(text).map_err(|e| SpecError::Toml {
        path: path.into(),
        message: e.to_string(),
    })?;
    let m = &spec.master;
    let algorithm = Algorithm::from_str(&m.algorithm).map_err(|e| SpecError::Algorithm {
        path: path.into(),
        message: e.to_string(),
    })?;
    if !(m.macro_step_s.is_finite() && m.macro_step_s > 0.0) {
        return Err(SpecError::MacroStep {
            path: path.into(),
            value: m.macro_step_s,
        });
    }
    if !(m.stop_time_s > m.start_time_s) {
        return Err(SpecError::StopTime {
            path: path.into(),
            start: m.start_time_s,
            stop: m.stop_time_s,
        });
    }
    crate::master::macro_steps(m.start_time_s, m.stop_time_s, m.macro_step_s).map_err(
        |source| SpecError::Steps {
            path: path.into(),
            source: Box::new(source),
        },
    )?;
    if spec.units.is_empty() {
        return Err(SpecError::NoUnits { path: path.into() });
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let units = spec
        .units
        .iter()
        .map(|(n, p)| {
            let p = PathBuf::from(p);
            (n.clone(), if p.is_absolute() { p } else { base.join(p) })
        })
        .collect();
    let parameters = spec
        .parameters
        .iter()
        .map(|(k, v)| Ok((k.clone(), param(k, v)?)))
        .collect::<Result<Vec<_>, SpecError>>()?;
    Ok(GenericSpec {
        units,
        connections: spec
            .connections
            .iter()
            .map(|[a, b]| (a.clone(), b.clone()))
            .collect(),
        parameters,
        options: MasterOptions {
            algorithm,
            macro_step_s: m.macro_step_s,
            extrapolate: m.extrapolate,
            directional_derivatives: m.directional_derivatives,
            ..Default::default()
        },
        start_time_s: m.start_time_s,
        stop_time_s: m.stop_time_s,
        record: spec.record.clone(),
        record_every: m.record_every.max(1),
    })
}
