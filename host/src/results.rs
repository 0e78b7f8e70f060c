//! Method results and the machine-readable output contract (DESIGN.md section 7):
//! `summary.json`, `<method>_envelope.csv`, `<method>_timeseries.csv`.
pub use crate::figures::{jump_down, Figures};
use crate::scenario::OutputKind;
use anyhow::{Context, Result};
pub use nlmode::envelope::Envelope;
use nlmode::envelope::{EnvelopeError, EnvelopeRow};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Methods of a `host run` that could not run: (method, reason).
pub type FailedMethods = Vec<(String, String)>;

/// Named columns of equal length.
#[derive(Debug, Clone, Default)]
pub struct TimeSeries {
    pub columns: Vec<(String, Vec<f64>)>,
}

/// One method's entry of `summary.json` (DESIGN.md section 7): the figures
/// every method has (filled in by [`MethodResult::new`]), its warnings, the
/// attachments' outputs, and the method's own entries ([`MethodSummary::set`]:
/// `integrator`, `folds`, `force_drop`, ...). Written as one object, the keys
/// in (byte-wise) alphabetical order, then `max_harvested_power_W`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MethodSummary {
    /// Excitation frequency of the jump-down [rad/s] (sweeps; absent otherwise).
    pub jump_down_omega_rad_s: Option<f64>,
    /// Largest force amplitude [N] (null without finite values).
    pub max_force_amplitude_n: Option<f64>,
    /// Smallest force amplitude [N] (null without finite values).
    pub min_force_amplitude_n: Option<f64>,
    /// Excitation frequency at the peak [rad/s] (null without finite values).
    pub peak_omega_rad_s: Option<f64>,
    /// Peak tip amplitude [m] (null without finite values).
    pub peak_tip_amplitude_m: Option<f64>,
    /// Envelope samples.
    pub points: usize,
    /// Wall time of the method [s].
    pub wall_time_s: f64,
    pub warnings: Vec<String>,
    /// Piezo shunts: the largest mean harvested power `mean(R i^2)` over the
    /// envelope [W], by attachment name (`max_harvested_power_W`).
    pub max_harvested_power_w: BTreeMap<String, f64>,
    /// The method's own entries by key, set by the method
    /// ([`MethodSummary::set`]; the keys are part of the output contract).
    pub extra: BTreeMap<String, serde_json::Value>,
}

impl MethodSummary {
    /// Sets the method's entry `key` (`"integrator"`, `"folds"`).
    pub fn set(&mut self, key: &str, value: impl Serialize) {
        let v = serde_json::to_value(value).unwrap_or(serde_json::Value::Null);
        self.extra.insert(key.into(), v);
    }

    /// The method's entry `key`, if set and of type `T`.
    pub fn get<T: serde::de::DeserializeOwned>(&self, key: &str) -> Option<T> {
        self.extra
            .get(key)
            .and_then(|v| serde_json::from_value(v.clone()).ok())
    }
}

impl Serialize for MethodSummary {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::{Error, SerializeMap};
        use serde_json::Value;
        fn v<T: Serialize, E: Error>(x: &T) -> Result<Value, E> {
            serde_json::to_value(x).map_err(E::custom)
        }
        let mut keys: BTreeMap<&str, Value> = BTreeMap::new();
        if let Some(j) = self.jump_down_omega_rad_s {
            keys.insert("jump_down_omega_rad_s", v(&j)?);
        }
        keys.insert("max_force_amplitude_N", v(&self.max_force_amplitude_n)?);
        keys.insert("min_force_amplitude_N", v(&self.min_force_amplitude_n)?);
        keys.insert("peak_omega_rad_s", v(&self.peak_omega_rad_s)?);
        keys.insert("peak_tip_amplitude_m", v(&self.peak_tip_amplitude_m)?);
        keys.insert("points", v(&self.points)?);
        keys.insert("wall_time_s", v(&self.wall_time_s)?);
        if !self.warnings.is_empty() {
            keys.insert("warnings", v(&self.warnings)?);
        }
        for (k, x) in &self.extra {
            keys.insert(k, x.clone());
        }
        let harvested = !self.max_harvested_power_w.is_empty();
        let mut m = s.serialize_map(Some(keys.len() + usize::from(harvested)))?;
        for (k, x) in &keys {
            m.serialize_entry(k, x)?;
        }
        if harvested {
            m.serialize_entry("max_harvested_power_W", &self.max_harvested_power_w)?;
        }
        m.end()
    }
}

/// `summary.json` (DESIGN.md section 7); fields in the alphabetical order of the keys.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    pub damping_ratio: f64,
    pub exciters: Vec<ExciterSummary>,
    /// Methods that could not run (e.g. `cosim` without the FMU libraries): method -> reason.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub failed_methods: BTreeMap<String, String>,
    pub full_ndof: usize,
    pub methods: BTreeMap<String, MethodSummary>,
    pub model_ndof: usize,
    pub omega0_rad_s: f64,
    /// The remedies of the validity checks that fired (`warnings`): the
    /// `[slowflow]` setting of each and, with `[slowflow] remedies = "run"`,
    /// the result it was run as.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub remedies: Vec<crate::validity::RemedyEntry>,
    /// Wall time of `reference` over that of `nlmode` (null unless both ran).
    pub speedup_nlmode_over_reference: Option<f64>,
    /// The large-model path's stage times (read, check, order, factor,
    /// eigen, constraint modes, project), `nnz(L)`, the ordering and the
    /// memory estimate: FE matrices reduced on the sparse path only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub structure_stages: Option<nlmode::structure::sparse::StageTimings>,
    pub sweep: SweepSettings,
    pub title: String,
    /// Validity checks of the single-mode theory with attachments (quasi-steady
    /// attachment dynamics, internal resonance, mode-shape distortion;
    /// [`crate::model::Setup::validity_warnings`]). The methods' own warnings stay
    /// under `methods.<name>.warnings`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// An exciter's entry of [`Summary`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExciterSummary {
    pub mass_ratio: f64,
    pub modal_mass_kg: f64,
    pub point: String,
}

/// The sweep's entry of [`Summary`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepSettings {
    pub duration_s: f64,
    pub omega_end_rad_s: f64,
    pub omega_start_rad_s: f64,
    pub rate_rad_s2: f64,
    pub voltage_v: f64,
}

/// What one method produced.
#[derive(Debug, Clone)]
pub struct MethodResult {
    /// Output name (`<name>_envelope.csv`): a method's name, or `closed-form`,
    /// `nlmode-freq-error`.
    pub name: String,
    pub envelope: Envelope,
    pub time_series: Option<TimeSeries>,
    /// Its `summary.json` entry: the envelope's numbers are filled in by
    /// [`MethodResult::new`], the method adds its own (force_drop, steps, warnings, ...).
    pub summary: MethodSummary,
    /// Further envelope columns (same length as the envelope), appended to
    /// `<method>_envelope.csv`: each exciter's force with several exciters
    /// (`<name>_force_amplitude_N`), each piezo shunt's harvested power
    /// (`<name>_harvested_power_W`).
    pub extra_columns: Vec<(String, Vec<f64>)>,
    /// Further tables the method writes as `<name>.csv` (e.g. `hb_frc`):
    /// the same columns reach Python.
    pub tables: Vec<Table>,
}

/// One column of a [`Table`].
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    Numbers(Vec<f64>),
    /// Labels; an empty string is an empty CSV field.
    Text(Vec<String>),
}

impl Column {
    fn len(&self) -> usize {
        match self {
            Column::Numbers(v) => v.len(),
            Column::Text(v) => v.len(),
        }
    }

    fn field(&self, i: usize) -> String {
        match self {
            Column::Numbers(v) => v[i].to_string(),
            Column::Text(v) => v[i].clone(),
        }
    }
}

/// A table of named columns of one length, written as `<name>.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub name: String,
    pub columns: Vec<(String, Column)>,
}

impl Table {
    /// Number of rows (the shortest column's length).
    pub fn rows(&self) -> usize {
        self.columns.iter().map(|(_, c)| c.len()).min().unwrap_or(0)
    }

    /// Writes the table as CSV (header, then one record per row; numbers in
    /// Rust's shortest round-trip form).
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        let write = || -> Result<(), csv::Error> {
            let mut w = csv::Writer::from_path(path)?;
            w.write_record(self.columns.iter().map(|(n, _)| n.as_str()))?;
            for i in 0..self.rows() {
                w.write_record(self.columns.iter().map(|(_, c)| c.field(i)))?;
            }
            w.flush()?;
            Ok(())
        };
        write().with_context(|| format!("cannot write {}", path.display()))
    }
}

impl MethodResult {
    /// `is_sweep`: the envelope comes from a sweep (transient) rather than a
    /// steady state, so it has a jump-down.
    pub fn new(name: &str, wall_time_s: f64, envelope: Envelope, is_sweep: bool) -> Self {
        let f = Figures::of_envelope(&envelope, is_sweep);
        let summary = MethodSummary {
            wall_time_s,
            peak_tip_amplitude_m: f.peak_tip_amplitude_m,
            peak_omega_rad_s: f.peak_omega_rad_s,
            min_force_amplitude_n: f.min_force_amplitude_n,
            max_force_amplitude_n: f.max_force_amplitude_n,
            jump_down_omega_rad_s: f.jump_down_omega_rad_s,
            points: envelope.len(),
            ..Default::default()
        };
        Self {
            name: name.into(),
            envelope,
            time_series: None,
            summary,
            extra_columns: Vec::new(),
            tables: Vec::new(),
        }
    }

    /// Adds a piezo shunt's harvested power per envelope sample [W]: the column
    /// `<name>_harvested_power_W` and its maximum in the summary.
    pub fn add_harvested_power(&mut self, name: &str, power_w: Vec<f64>) {
        let max = power_w
            .iter()
            .cloned()
            .filter(|v| v.is_finite())
            .fold(f64::NEG_INFINITY, f64::max);
        if max.is_finite() {
            self.summary.max_harvested_power_w.insert(name.into(), max);
        }
        self.extra_columns
            .push((format!("{name}_harvested_power_W"), power_w));
    }

    /// Adds an output an attachment declares ([`crate::scenario::AttachmentOutput`])
    /// per envelope sample: its column and summary entry by its kind.
    pub fn add_output(&mut self, name: &str, kind: OutputKind, values: Vec<f64>) {
        match kind {
            OutputKind::HarvestedPower => self.add_harvested_power(name, values),
        }
    }

    /// Each exciter's force on the structure per envelope sample, `forces[i][k]`
    /// for exciter `i` named `names[i]` \[N\]: the columns
    /// `<name>_force_amplitude_N` (each in turn) then `<name>_force_phase_rad`
    /// (`F ~ |F| cos(Phi + phase)`, the convention of `force_phase_rad`).
    pub fn add_exciter_forces(&mut self, names: &[String], forces: &[Vec<nlmode::Complex64>]) {
        for (name, f) in names.iter().zip(forces) {
            self.extra_columns.push((
                format!("{name}_force_amplitude_N"),
                f.iter().map(|z| z.norm()).collect(),
            ));
        }
        for (name, f) in names.iter().zip(forces) {
            self.extra_columns.push((
                format!("{name}_force_phase_rad"),
                f.iter().map(|z| z.arg()).collect(),
            ));
        }
    }

    /// Wall time of the method [s].
    pub fn wall_time_s(&self) -> f64 {
        self.summary.wall_time_s
    }
}

/// Write `<name>_envelope.csv`: the columns `omega_rad_s`, `force_amplitude_N`,
/// `tip_amplitude_m` and the optional ones the envelope has, every number in
/// its shortest exact (round-trip) decimal form.
pub fn write_envelope(dir: &Path, r: &MethodResult) -> Result<()> {
    let path = dir.join(format!("{}_envelope.csv", r.name));
    let mut w = csv::Writer::from_path(&path)
        .with_context(|| format!("cannot create {}", path.display()))?;
    let write = |w: &mut csv::Writer<std::fs::File>| -> Result<(), csv::Error> {
        if !r.extra_columns.is_empty() {
            // the contract's columns, then the extra ones
            let mut head: Vec<String> = envelope_header(&r.envelope)
                .iter()
                .map(|s| s.to_string())
                .collect();
            head.extend(r.extra_columns.iter().map(|(n, _)| n.clone()));
            w.write_record(&head)?;
            for (i, row) in r.envelope.rows().enumerate() {
                let mut rec: Vec<String> = row_values(&row).iter().map(|v| v.to_string()).collect();
                rec.extend(
                    r.extra_columns
                        .iter()
                        .map(|(_, c)| c.get(i).copied().unwrap_or(f64::NAN).to_string()),
                );
                w.write_record(&rec)?;
            }
            w.flush()?;
            return Ok(());
        }
        if r.envelope.is_empty() {
            // serde writes the header with the first row; an empty envelope still gets one
            w.write_record(envelope_header(&r.envelope))?;
        }
        for row in r.envelope.rows() {
            w.serialize(row)?;
        }
        w.flush()?;
        Ok(())
    };
    write(&mut w).with_context(|| format!("cannot write {}", path.display()))
}

/// The values of one row in the order of [`envelope_header`].
fn row_values(row: &EnvelopeRow) -> Vec<f64> {
    let mut v = vec![row.omega_rad_s, row.force_amplitude_n, row.tip_amplitude_m];
    v.extend(
        [
            row.force_phase_rad,
            row.drive_amplitude_m,
            row.modal_amplitude,
            row.modal_frequency_rad_s,
        ]
        .into_iter()
        .flatten(),
    );
    v
}

/// The columns of `<name>_envelope.csv` in memory, named and ordered as
/// [`write_envelope`] writes them (the contract's, the optional ones the
/// envelope has, then [`MethodResult::extra_columns`]).
pub fn envelope_columns(r: &MethodResult) -> Vec<(String, Vec<f64>)> {
    let e = &r.envelope;
    let optional = [
        &e.force_phase_rad,
        &e.drive_amplitude_m,
        &e.modal_amplitude,
        &e.modal_frequency_rad_s,
    ];
    let data = [&e.omega_rad_s, &e.force_amplitude_n, &e.tip_amplitude_m]
        .into_iter()
        .chain(optional.into_iter().flatten());
    let mut cols: Vec<(String, Vec<f64>)> = envelope_header(e)
        .into_iter()
        .zip(data)
        .map(|(n, v)| (n.to_string(), v.clone()))
        .collect();
    cols.extend(r.extra_columns.iter().cloned());
    cols
}

/// The CSV header of an envelope without rows.
fn envelope_header(e: &Envelope) -> Vec<&'static str> {
    let mut h = vec!["omega_rad_s", "force_amplitude_N", "tip_amplitude_m"];
    for (name, c) in [
        ("force_phase_rad", &e.force_phase_rad),
        ("drive_amplitude_m", &e.drive_amplitude_m),
        ("modal_amplitude", &e.modal_amplitude),
        ("modal_frequency_rad_s", &e.modal_frequency_rad_s),
    ] {
        if c.is_some() {
            h.push(name);
        }
    }
    h
}

/// Why an envelope CSV cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum EnvelopeCsvError {
    #[error("cannot read '{path}': {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("line {line}: {message}")]
    Row { line: u64, message: String },
    #[error("{0}")]
    Csv(String),
    #[error(transparent)]
    Shape(#[from] EnvelopeError),
}

impl From<csv::Error> for EnvelopeCsvError {
    fn from(e: csv::Error) -> Self {
        match e.position() {
            Some(p) => EnvelopeCsvError::Row {
                line: p.line(),
                message: match e.kind() {
                    csv::ErrorKind::Deserialize { err, .. } => err.to_string(),
                    _ => e.to_string(),
                },
            },
            None => EnvelopeCsvError::Csv(e.to_string()),
        }
    }
}

/// Read an envelope CSV (the format [`write_envelope`] writes): required columns
/// `omega_rad_s`, `force_amplitude_N`; optional `tip_amplitude_m` (NaN when
/// absent), `force_phase_rad`, `drive_amplitude_m`,
/// `modal_amplitude`, `modal_frequency_rad_s`. Header names match case-insensitively,
/// columns in any order, other columns ignored, `#` comment lines skipped.
pub fn read_envelope(path: &Path) -> Result<Envelope, EnvelopeCsvError> {
    let text = std::fs::read_to_string(path).map_err(|source| EnvelopeCsvError::Io {
        path: path.display().to_string(),
        source,
    })?;
    parse_envelope(&text)
}

/// [`read_envelope`] on CSV text.
pub fn parse_envelope(text: &str) -> Result<Envelope, EnvelopeCsvError> {
    let mut rd = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    const NAMES: [&str; 7] = [
        "omega_rad_s",
        "force_amplitude_N",
        "tip_amplitude_m",
        "force_phase_rad",
        "drive_amplitude_m",
        "modal_amplitude",
        "modal_frequency_rad_s",
    ];
    let header: csv::StringRecord = rd
        .headers()?
        .iter()
        .map(|h| {
            NAMES
                .iter()
                .find(|n| n.eq_ignore_ascii_case(h))
                .map_or(h.to_string(), |n| n.to_string())
        })
        .collect();
    for required in &NAMES[..2] {
        if !header.iter().any(|h| h == *required) {
            return Err(EnvelopeCsvError::Csv(format!(
                "CSV header has no column '{required}' (columns: {})",
                header.iter().collect::<Vec<_>>().join(", ")
            )));
        }
    }
    // the response column of a prescribed force file is not needed: NaN when absent
    let add_tip = !header.iter().any(|h| h == "tip_amplitude_m");
    let mut header = header;
    if add_tip {
        header.push_field("tip_amplitude_m");
    }
    let mut rows = Vec::new();
    for rec in rd.records() {
        let mut rec = rec?;
        if add_tip {
            rec.push_field("NaN");
        }
        let line = rec.position().map_or(0, |p| p.line());
        rows.push(rec.deserialize::<EnvelopeRow>(Some(&header)).map_err(|e| {
            EnvelopeCsvError::Row {
                line,
                message: e.to_string(),
            }
        })?);
    }
    Ok(Envelope::from_rows(&rows)?)
}

/// The envelope columns that give each exciter's force with several exciters
/// (as [`MethodResult::add_exciter_forces`] writes them): `omega_rad_s`, then
/// per exciter name `<name>_force_amplitude_N` and `<name>_force_phase_rad`.
pub fn exciter_force_columns(names: &[String]) -> Vec<String> {
    let mut c = vec!["omega_rad_s".to_string()];
    for n in names {
        c.push(format!("{n}_force_amplitude_N"));
        c.push(format!("{n}_force_phase_rad"));
    }
    c
}

/// The columns `wanted` (names matched case-insensitively) of named columns
/// in memory (e.g. [`envelope_columns`]), in the order asked; a missing one is
/// an error naming it and the columns there are.
pub fn pick_columns(
    cols: &[(String, Vec<f64>)],
    wanted: &[String],
) -> Result<Vec<Vec<f64>>, EnvelopeCsvError> {
    wanted
        .iter()
        .map(|w| {
            cols.iter()
                .find(|(n, _)| n.eq_ignore_ascii_case(w))
                .map(|(_, v)| v.clone())
                .ok_or_else(|| missing_column(w, cols.iter().map(|(n, _)| n.as_str())))
        })
        .collect()
}

fn missing_column<'a>(name: &str, have: impl Iterator<Item = &'a str>) -> EnvelopeCsvError {
    EnvelopeCsvError::Csv(format!(
        "no column '{name}' (columns: {})",
        have.collect::<Vec<_>>().join(", ")
    ))
}

/// The numeric columns `wanted` of a CSV file (header names matched
/// case-insensitively, columns in any order, other columns ignored, `#`
/// comment lines skipped), in the order asked; a missing column or a value
/// that is not a number is an error naming it (and the line). At most
/// [`MAX_CSV_BYTES`] are read.
pub fn read_csv_columns(path: &Path, wanted: &[String]) -> Result<Vec<Vec<f64>>, EnvelopeCsvError> {
    let text = cosim::file::read_regular_to_string(path, MAX_CSV_BYTES).map_err(|e| {
        EnvelopeCsvError::Io {
            path: path.display().to_string(),
            source: std::io::Error::other(format!("{e:#}")),
        }
    })?;
    parse_csv_columns(&text, wanted)
}

/// Largest CSV file [`read_csv_columns`] reads [bytes].
pub const MAX_CSV_BYTES: u64 = 1 << 30;

/// [`read_csv_columns`] on CSV text.
pub fn parse_csv_columns(text: &str, wanted: &[String]) -> Result<Vec<Vec<f64>>, EnvelopeCsvError> {
    let mut rd = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header = rd.headers()?.clone();
    let idx = wanted
        .iter()
        .map(|w| {
            header
                .iter()
                .position(|h| h.eq_ignore_ascii_case(w))
                .ok_or_else(|| missing_column(w, header.iter()))
        })
        .collect::<Result<Vec<usize>, _>>()?;
    let mut out = vec![Vec::new(); wanted.len()];
    for rec in rd.records() {
        let rec = rec?;
        let line = rec.position().map_or(0, |p| p.line());
        for ((col, &i), name) in out.iter_mut().zip(&idx).zip(wanted) {
            let field = rec.get(i).unwrap_or("");
            let v = field.parse::<f64>().map_err(|_| EnvelopeCsvError::Row {
                line,
                message: format!("column '{name}': '{field}' is not a number"),
            })?;
            col.push(v);
        }
    }
    Ok(out)
}

/// Each exciter's force envelope from the columns of [`exciter_force_columns`]
/// (in that order: `omega_rad_s`, then amplitude and phase per exciter).
pub fn exciter_force_envelopes(
    cols: &[Vec<f64>],
) -> Result<Vec<nlmode::reduced::ForceEnvelope>, nlmode::reduced::ReducedError> {
    let (omega, forces) = cols.split_first().expect("omega_rad_s column");
    forces
        .chunks_exact(2)
        .map(|c| nlmode::reduced::ForceEnvelope::new(omega, &c[0], &c[1]))
        .collect()
}

/// Write `<name>_timeseries.csv` if the method has one.
pub fn write_time_series(dir: &Path, r: &MethodResult) -> Result<()> {
    if let Some(ts) = &r.time_series {
        let header: Vec<String> = ts.columns.iter().map(|(n, _)| n.clone()).collect();
        let cols: Vec<&[f64]> = ts.columns.iter().map(|(_, v)| v.as_slice()).collect();
        write_csv(
            &dir.join(format!("{}_timeseries.csv", r.name)),
            &header,
            &cols,
        )?;
    }
    Ok(())
}

/// Write named columns as CSV (header row, then one row per sample up to the
/// shortest column), numbers in their shortest exact decimal form; the writer of
/// the time series, `cosim.csv` and the NMA branches.
pub fn write_csv(path: &Path, header: &[String], cols: &[&[f64]]) -> Result<()> {
    let n = cols.iter().map(|c| c.len()).min().unwrap_or(0);
    let mut w = csv::Writer::from_path(path)
        .with_context(|| format!("cannot create {}", path.display()))?;
    let write = |w: &mut csv::Writer<std::fs::File>| -> Result<(), csv::Error> {
        w.write_record(header)?;
        let mut row = vec![0.0; cols.len()];
        for i in 0..n {
            for (x, c) in row.iter_mut().zip(cols) {
                *x = c[i];
            }
            w.serialize(&row)?;
        }
        w.flush()?;
        Ok(())
    };
    write(&mut w).with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jump_down_finds_the_drop() {
        let x: Vec<f64> = (0..1000).map(|i| i as f64).collect();
        let y: Vec<f64> = x
            .iter()
            .map(|&x| if x < 700.0 { x / 700.0 } else { 0.1 })
            .collect();
        let j = jump_down(&x, &y).unwrap();
        assert!((j - 700.0).abs() < 3.0, "{j}");
    }

    #[test]
    fn csv_has_header_and_full_precision() {
        let dir = std::env::temp_dir().join(format!("host-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.csv");
        write_csv(
            &p,
            &["a".into(), "b".into()],
            &[&[1.0, 2.0], &[3.5, -4.25e-7]],
        )
        .unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "a,b");
        let v: f64 = lines[2].split(',').nth(1).unwrap().parse().unwrap();
        assert_eq!(v, -4.25e-7);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn envelope_csv_round_trips_exactly_with_its_optional_columns() {
        let dir = std::env::temp_dir().join(format!("host-env-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let env = Envelope {
            omega_rad_s: vec![300.0, 356.218_765_432_1, 400.0],
            force_amplitude_n: vec![1.0 / 3.0, 2.5, 3.0],
            tip_amplitude_m: vec![1e-3, 2.296_012_345_678_9e-3, 1e-4],
            force_phase_rad: Some(vec![0.1, -0.2, 0.3]),
            drive_amplitude_m: Some(vec![4.0, 5.0, 6.0]),
            ..Default::default()
        };
        let r = MethodResult::new("x", 0.0, env.clone(), true);
        write_envelope(&dir, &r).unwrap();
        let text = std::fs::read_to_string(dir.join("x_envelope.csv")).unwrap();
        assert_eq!(
            text.lines().next().unwrap(),
            "omega_rad_s,force_amplitude_N,tip_amplitude_m,force_phase_rad,drive_amplitude_m"
        );
        assert_eq!(read_envelope(&dir.join("x_envelope.csv")).unwrap(), env);
        let empty = MethodResult::new("e", 0.0, Envelope::default(), false);
        write_envelope(&dir, &empty).unwrap();
        let text = std::fs::read_to_string(dir.join("e_envelope.csv")).unwrap();
        assert_eq!(text.trim(), "omega_rad_s,force_amplitude_N,tip_amplitude_m");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn envelope_reader_optional_columns_and_errors() {
        // any order, other columns ignored, comments, case-insensitive names, no tip
        let e = parse_envelope(
            "# imposed force\nFORCE_PHASE_RAD, x, omega_rad_s, force_amplitude_n\n0.5, 9, 200, 3\n0.25, 9, 100, 1\n",
        )
        .unwrap();
        assert_eq!(e.omega_rad_s, vec![200.0, 100.0]);
        assert_eq!(e.force_phase_rad, Some(vec![0.5, 0.25]));
        assert!(e.tip_amplitude_m.iter().all(|t| t.is_nan()));
        let f = e.to_force_envelope().unwrap();
        assert_eq!(f.omega_rad_s, vec![100.0, 200.0]);
        // without the phase: read, but it cannot be imposed
        let e = parse_envelope("omega_rad_s,force_amplitude_N\n1,2\n3,4\n").unwrap();
        assert_eq!(e.force_phase_rad, None);
        assert!(e.to_force_envelope().is_err());
        assert!(matches!(
            parse_envelope("omega_rad_s,tip_amplitude_m\n1,2\n"),
            Err(EnvelopeCsvError::Csv(m)) if m.contains("force_amplitude_N")
        ));
        match parse_envelope("omega_rad_s,force_amplitude_N\n1,2\n3,abc\n") {
            Err(EnvelopeCsvError::Row { line: 3, .. }) => {}
            other => panic!("{other:?}"),
        }
    }
}
