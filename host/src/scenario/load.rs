//! Reading a scenario: the one loader of `host run`, `host nma`, `host frf`,
//! the study's base scenario and the Python package.
use super::{Catalog, InMemoryMatrices, Scenario, ScenarioError, StructureSpec, DEFAULT_SCENARIO};
use anyhow::{Context, Result};
use std::path::Path;

/// Largest scenario file read [bytes] (a real one is a few kB): `host run
/// /dev/zero` or a huge file fails at once instead of reading without bound.
pub const MAX_SCENARIO_BYTES: u64 = 1 << 20;

/// Where a scenario comes from (the library's counterpart of `host run`'s
/// argument).
#[derive(Debug, Clone, Copy)]
pub enum ScenarioSource<'a> {
    /// The embedded default ([`crate::scenario::DEFAULT_SCENARIO`]).
    Default,
    /// TOML text; relative paths in it are taken from the working directory.
    Text(&'a str),
    /// A scenario file, read as `host run` reads it ([`load_scenario_in`]).
    File(&'a Path),
}

/// Read a scenario (a file as `host run` reads it, with
/// the same messages) with `catalog` the method registry's (the host's:
/// `crate::methods::load_scenario`), optionally with `[run] methods` replaced by `methods`
/// (checked by the scenario's own rules: an unknown method is named as
/// `run.methods[i]`). Returns the scenario and its name in messages. The
/// errors read as `host run`'s (`scenario NAME: key: message`), with the
/// [`crate::scenario::ScenarioError`] in their chain.
pub fn load_scenario_in(
    src: ScenarioSource,
    methods: Option<&[String]>,
    catalog: &'static Catalog,
) -> Result<(Scenario, String)> {
    load_scenario_with(src, methods, None, catalog)
}

/// [`load_scenario_in`] with the matrices of a `kind = "matrices"`
/// structure given in memory (the Python package's `matrices=`): the
/// scenario must not name their files (`mass_mtx`, `stiffness_mtx`,
/// `damping_mtx`), which then hold [`InMemoryMatrices::placeholder`]
/// names for messages and provenance.
pub fn load_scenario_with(
    src: ScenarioSource,
    methods: Option<&[String]>,
    matrices: Option<InMemoryMatrices>,
    catalog: &'static Catalog,
) -> Result<(Scenario, String)> {
    let (text, name, dir) = match src {
        ScenarioSource::Default => (
            DEFAULT_SCENARIO.to_string(),
            "embedded default (sweep.toml)".to_string(),
            None,
        ),
        ScenarioSource::Text(t) => (t.to_string(), "(text)".to_string(), None),
        ScenarioSource::File(p) => (
            cosim::file::read_regular_to_string(p, MAX_SCENARIO_BYTES)
                .with_context(|| format!("cannot read scenario file {}", p.display()))?,
            p.display().to_string(),
            p.parent().map(Path::to_path_buf),
        ),
    };
    let regenerated = methods.is_some() || matrices.is_some();
    let text = if regenerated {
        let bad = |key: &str, message: String| {
            anyhow::Error::new(ScenarioError {
                key: key.into(),
                message,
                line: None,
            })
            .context(format!("scenario {name}"))
        };
        let mut tree: toml::Value =
            toml::from_str(&text).map_err(|e| bad("scenario", e.message().to_string()))?;
        if let Some(m) = methods {
            let list = toml::Value::Array(m.iter().cloned().map(toml::Value::String).collect());
            set_path(&mut tree, "run.methods", list).map_err(|e| bad("scenario", e))?;
        }
        if let Some(mem) = &matrices {
            for (key, value) in in_memory_keys(&tree, mem).map_err(|(k, e)| bad(&k, e))? {
                set_path(&mut tree, &key, value).map_err(|e| bad(&key, e))?;
            }
        }
        toml::to_string(&tree).map_err(|e| bad("scenario", e.to_string()))?
    } else {
        text
    };
    let mut sc = Scenario::parse_in(&text, catalog).map_err(|e| {
        // a regenerated text's line numbers mean nothing
        let e = if regenerated {
            ScenarioError { line: None, ..e }
        } else {
            e
        };
        anyhow::Error::new(e).context(format!("scenario {name}"))
    })?;
    sc.resolve_paths(dir.as_deref().unwrap_or(Path::new("")));
    if let (Some(mem), StructureSpec::Matrices(st)) = (matrices, &mut sc.structure) {
        st.mass_mtx = InMemoryMatrices::placeholder("mass_mtx").into();
        st.stiffness_mtx = InMemoryMatrices::placeholder("stiffness_mtx").into();
        if mem.damping.is_some() {
            st.damping_mtx = Some(InMemoryMatrices::placeholder("damping_mtx").into());
        }
        st.in_memory = Some(mem);
    }
    Ok((sc, name))
}

/// The `[structure]` keys naming the in-memory matrices in the scenario
/// tree: `kind = "matrices"` is required and the file keys must be absent
/// (`(key, message)` otherwise).
fn in_memory_keys(
    tree: &toml::Value,
    mem: &InMemoryMatrices,
) -> Result<Vec<(String, toml::Value)>, (String, String)> {
    let st = tree.get("structure");
    let kind = st.and_then(|s| s.get("kind")).and_then(|k| k.as_str());
    if kind != Some("matrices") {
        return Err((
            "structure.kind".into(),
            format!(
                "matrices given in memory need [structure] kind = \"matrices\", got {}",
                kind.map_or("none (a beam)".to_string(), |k| format!("\"{k}\""))
            ),
        ));
    }
    let mut keys = vec!["mass_mtx", "stiffness_mtx"];
    if mem.damping.is_some() {
        keys.push("damping_mtx");
    }
    let mut out = Vec::new();
    for key in keys {
        if st.and_then(|s| s.get(key)).is_some() {
            return Err((
                format!("structure.{key}"),
                format!(
                    "given both as a file here and in memory as {}: give one of the two",
                    InMemoryMatrices::placeholder(key)
                ),
            ));
        }
        let name = InMemoryMatrices::placeholder(key);
        out.push((format!("structure.{key}"), toml::Value::String(name)));
    }
    Ok(out)
}

/// Set `value` at the dotted `key` of a TOML tree: tables are entered (a
/// missing table or key is created: the scenario parser then accepts or
/// rejects it by name), arrays by index (`exciter.0`), which must exist.
pub fn set_path(root: &mut toml::Value, key: &str, value: toml::Value) -> Result<(), String> {
    let parts: Vec<&str> = key.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(format!("{key}: not a dotted key (empty part)"));
    }
    let mut node = root;
    for (depth, part) in parts.iter().enumerate() {
        let last = depth + 1 == parts.len();
        let here = parts[..=depth].join(".");
        node = match node {
            toml::Value::Table(t) => {
                if last {
                    t.insert(part.to_string(), value);
                    return Ok(());
                }
                let next_is_index = parts[depth + 1].parse::<usize>().is_ok();
                if next_is_index && !t.contains_key(*part) {
                    return Err(format!(
                        "{key}: the base scenario has no `{here}` entries to index: write them \
                         out in it (e.g. the [[exciter]] tables)"
                    ));
                }
                t.entry(part.to_string())
                    .or_insert_with(|| toml::Value::Table(Default::default()))
            }
            toml::Value::Array(a) => {
                let i: usize = part.parse().map_err(|_| {
                    format!(
                        "{here}: `{part}` must be an index into the array {}",
                        parts[..depth].join(".")
                    )
                })?;
                let len = a.len();
                let slot = a.get_mut(i).ok_or_else(|| {
                    format!(
                        "{here}: index {i} out of range (the scenario has {len} entries of {})",
                        parts[..depth].join(".")
                    )
                })?;
                if last {
                    *slot = value;
                    return Ok(());
                }
                slot
            }
            _ => {
                return Err(format!(
                    "{here}: {} is a value, not a table or an array",
                    parts[..depth].join(".")
                ))
            }
        };
    }
    unreachable!("the loop returns at the last part")
}
