//! `host cosim SPEC -o DIR`: the generic mode of the co-simulation master:
//! any FMI 2.0 Co-Simulation FMUs, connections and parameters from a TOML file
//! (format in `docs/cosim.md`), recorded variables written to `cosim.csv`.
use crate::cosim::master::{run_generic, GenericSpec};
use crate::cosim::{Algorithm, MasterOptions, ParamValue};
use crate::results::write_csv;
use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::str::FromStr;

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
            start_time_s: 0.0,
            stop_time_s: 1.0,
            record_every: 1,
        }
    }
}

fn param(key: &str, v: &toml::Value) -> Result<ParamValue> {
    Ok(match v {
        toml::Value::Float(x) => ParamValue::Real(*x),
        toml::Value::Integer(i) => {
            ParamValue::Integer(i32::try_from(*i).with_context(|| {
                format!("parameters.\"{key}\": {i} does not fit an fmi2Integer")
            })?)
        }
        toml::Value::Boolean(b) => ParamValue::Boolean(*b),
        toml::Value::String(s) => ParamValue::String(s.clone()),
        other => bail!("parameters.\"{key}\": expected a number, boolean or string, got {other}"),
    })
}

/// Run the generic co-simulation described by the TOML file `path`.
pub fn cosim(path: &Path, out: &Path) -> Result<()> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let spec: Spec =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let m = &spec.master;
    let algorithm = Algorithm::from_str(&m.algorithm)
        .map_err(|e| anyhow::anyhow!("{}: master.algorithm: {e}", path.display()))?;
    if !(m.macro_step_s.is_finite() && m.macro_step_s > 0.0) {
        bail!(
            "{}: master.macro_step_s: expected a positive step, got {}",
            path.display(),
            m.macro_step_s
        );
    }
    if !(m.stop_time_s > m.start_time_s) {
        bail!(
            "{}: master.stop_time_s: expected > start_time_s ({}), got {}",
            path.display(),
            m.start_time_s,
            m.stop_time_s
        );
    }
    if spec.units.is_empty() {
        bail!(
            "{}: units: expected at least one `name = \"file.fmu\"`",
            path.display()
        );
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
        .collect::<Result<Vec<_>>>()?;
    let g = GenericSpec {
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
            ..Default::default()
        },
        start_time_s: m.start_time_s,
        stop_time_s: m.stop_time_s,
        record: spec.record.clone(),
        record_every: m.record_every.max(1),
    };
    let rec =
        run_generic(&g, &mut |_| {}).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut header = vec!["t_s".to_string()];
    let mut cols: Vec<&[f64]> = vec![&rec.time_s];
    for (n, v) in &rec.columns {
        header.push(n.clone());
        cols.push(v);
    }
    write_csv(&out.join("cosim.csv"), &header, &cols)?;
    println!(
        "{} macro steps of {} s ({} unit steps) in {:.3} s; wrote {}",
        rec.stats.steps,
        m.macro_step_s,
        rec.stats.do_steps,
        rec.wall_time_s,
        out.join("cosim.csv").display()
    );
    if let Some((t, msg)) = &rec.stopped {
        bail!("co-simulation stopped at t = {t} s (results up to there are in cosim.csv): {msg}");
    }
    Ok(())
}
