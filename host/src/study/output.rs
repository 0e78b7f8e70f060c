//! The files of a study in `DIR`:
//!
//! - `results.csv`: one row per sample (`sample`, one column per parameter
//!   named by its key, `peak_tip_amplitude_m`, `peak_omega_rad_s`,
//!   `jump_down_omega_rad_s` (empty when there is none),
//!   `min_force_amplitude_N`, `max_force_amplitude_N`, `left_table`,
//!   `status` (`ok` or the error), then `force_drop` = 1 - min/max of the
//!   force envelope). Rows are appended as samples finish, in batches
//!   ([`RowWriter`]), in completion order; at the end the file is rewritten sorted by sample.
//!   Numbers in their shortest round-trip decimal form.
//! - `results.parquet`: the same table, rebuilt from the sorted CSV at the
//!   end (one row group; parquet's low-level column writer, no compression).
//! - `results_reference.csv`, `.parquet`: the `reference_subset` samples run
//!   by `reference`, same columns.
//! - `study_fingerprint.json`: the study and its base scenario; `--resume`
//!   refuses a folder holding another study.
//! - `study_summary.json`: parameter ranges, figure-of-merit ranges, Pearson
//!   and Spearman correlations of each figure of merit with each parameter
//!   (over the `ok` samples), run statistics.
//! - `plots/`: each figure of merit against each parameter; histograms of the
//!   figures of merit for random and lhs designs.
use super::{Row, Study};
use crate::plot;
use anyhow::{anyhow, bail, Context, Result};
use serde_json::json;
use std::collections::{BTreeMap, HashSet};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

pub const FINGERPRINT: &str = "study_fingerprint.json";
pub const SUMMARY: &str = "study_summary.json";

/// The figure-of-merit columns after the parameters (the contract), then the extension.
pub const FIGURE_COLUMNS: [&str; 8] = [
    "peak_tip_amplitude_m",
    "peak_omega_rad_s",
    "jump_down_omega_rad_s",
    "min_force_amplitude_N",
    "max_force_amplitude_N",
    "left_table",
    "status",
    "force_drop",
];

/// Which results table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Table {
    /// The study's method on every sample.
    Main,
    /// The `reference_subset` samples by `reference`.
    Reference,
}

impl Table {
    pub fn stem(self) -> &'static str {
        match self {
            Table::Main => "results",
            Table::Reference => "results_reference",
        }
    }

    pub fn label(self, method: crate::scenario::Method) -> String {
        method.name().to_string()
    }
}

/// The CSV header of a study.
pub fn header(st: &Study) -> Vec<String> {
    let mut h = vec!["sample".to_string()];
    h.extend(st.keys.iter().cloned());
    h.extend(FIGURE_COLUMNS.iter().map(|s| s.to_string()));
    h
}

fn num(v: Option<f64>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::Float(f) => f.to_string(),
        toml::Value::Integer(i) => i.to_string(),
        other => other.to_string(),
    }
}

/// The CSV record of a row.
pub fn record(st: &Study, r: &Row) -> Vec<String> {
    let f = &r.figures;
    let mut rec = vec![r.sample.to_string()];
    rec.extend(st.values[r.sample].iter().map(value_text));
    rec.extend([
        num(f.peak_tip_amplitude_m),
        num(f.peak_omega_rad_s),
        num(f.jump_down_omega_rad_s),
        num(f.min_force_amplitude_n),
        num(f.max_force_amplitude_n),
        r.left_table.to_string(),
        r.status.clone(),
        num(f.force_drop()),
    ]);
    rec
}

/// Rows a [`RowWriter`] holds before it writes them to its file.
pub const FLUSH_ROWS: usize = 64;
/// Longest a finished row waits in a [`RowWriter`] before it is written (the
/// next row to finish after this writes the batch) [s].
pub const FLUSH_INTERVAL_S: f64 = 0.5;

/// Appends rows to a results CSV as samples finish (shared by the workers),
/// in batches: the rows are formatted into memory and written (whole lines,
/// one `write` per batch) every [`FLUSH_ROWS`] rows or after
/// [`FLUSH_INTERVAL_S`], so an interrupted study loses at most the last
/// `FLUSH_ROWS - 1` rows (those finished within the interval), which
/// `--resume` computes again. [`RowWriter::flush`] writes the rest.
pub struct RowWriter {
    inner: Mutex<Pending>,
    path: PathBuf,
}

/// The rows of a [`RowWriter`] not yet written.
struct Pending {
    file: File,
    rows: csv::Writer<Vec<u8>>,
    count: usize,
    since: std::time::Instant,
}

impl RowWriter {
    fn new(file: File, path: PathBuf) -> Self {
        let rows = row_buffer(Vec::with_capacity(FLUSH_ROWS * 256));
        Self {
            inner: Mutex::new(Pending {
                file,
                rows,
                count: 0,
                since: std::time::Instant::now(),
            }),
            path,
        }
    }

    pub fn append(&self, st: &Study, r: &Row) -> Result<()> {
        let mut p = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        p.rows
            .write_record(record(st, r))
            .with_context(|| format!("cannot write {}", self.path.display()))?;
        p.count += 1;
        if p.count >= FLUSH_ROWS || p.since.elapsed().as_secs_f64() >= FLUSH_INTERVAL_S {
            self.write_pending(&mut p)?;
        }
        Ok(())
    }

    /// Write the rows held.
    pub fn flush(&self) -> Result<()> {
        let mut p = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        self.write_pending(&mut p)
    }

    fn write_pending(&self, p: &mut Pending) -> Result<()> {
        use std::io::Write;
        let context = || format!("cannot write {}", self.path.display());
        let mut bytes = std::mem::replace(&mut p.rows, row_buffer(Vec::new()))
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(context)?;
        p.file
            .write_all(&bytes)
            .and_then(|()| p.file.flush())
            .with_context(context)?;
        bytes.clear();
        p.rows = row_buffer(bytes);
        p.count = 0;
        p.since = std::time::Instant::now();
        Ok(())
    }
}

/// The in-memory CSV writer of a [`RowWriter`]'s batch.
fn row_buffer(v: Vec<u8>) -> csv::Writer<Vec<u8>> {
    csv::WriterBuilder::new().has_headers(false).from_writer(v)
}

/// How a study ran (`study_summary.json`'s `run`).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct RunStats {
    pub threads: usize,
    /// Whole study before sorting the tables and plotting [s].
    pub wall_time_s: f64,
    /// Building the distinct structures and their modal tables [s].
    pub structures_s: f64,
    /// Running the samples, rows written [s].
    pub samples_s: f64,
    /// Samples computed by this invocation (not those kept by `--resume`).
    pub computed: usize,
    pub distinct_structures: usize,
}

impl RunStats {
    /// Samples per second of the sample phase.
    pub fn samples_per_s(&self) -> f64 {
        if self.samples_s > 0.0 {
            self.computed as f64 / self.samples_s
        } else {
            0.0
        }
    }
}

/// The open files of a running study.
pub struct StudyFiles {
    dir: PathBuf,
    tables: Vec<(Table, HashSet<usize>, RowWriter)>,
}

/// What [`StudyFiles::finish`] wrote.
pub struct Finished {
    pub failed: usize,
    pub files: Vec<PathBuf>,
}

/// The rows already in a results CSV that belong to this study: complete
/// records with the study's header and a sample index in range, each sample
/// once; reading stops at the first damaged record, and a last line without
/// its line end (a row cut by a kill) is dropped.
fn read_done(path: &Path, st: &Study) -> Result<Vec<csv::StringRecord>> {
    let text = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    // a row is complete with its line end: a kill may leave a cut one after the last
    let end = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let mut rd = csv::ReaderBuilder::new().from_reader(&text[..end]);
    let want = header(st);
    let got: Vec<String> = rd
        .headers()
        .with_context(|| format!("cannot read {}", path.display()))?
        .iter()
        .map(str::to_string)
        .collect();
    if got != want {
        bail!(
            "{}: columns {:?} are not this study's {:?}: not resumed",
            path.display(),
            got,
            want
        );
    }
    let mut seen = HashSet::new();
    let mut rows = Vec::new();
    for rec in rd.records() {
        let Ok(rec) = rec else { break };
        let Some(i) = rec.get(0).and_then(|s| s.parse::<usize>().ok()) else {
            break;
        };
        if i < st.len() && seen.insert(i) {
            rows.push(rec);
        }
    }
    Ok(rows)
}

/// Write a CSV file whole through a temporary file in the same folder (a
/// kill leaves the old file or the new one, never half of one).
fn write_csv_atomic(path: &Path, header: &[String], rows: &[csv::StringRecord]) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let tmp = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("cannot write in {}", dir.display()))?;
    {
        let mut w = csv::Writer::from_writer(tmp.as_file());
        w.write_record(header)?;
        for r in rows {
            w.write_record(r)?;
        }
        w.flush()?;
    }
    tmp.persist(path)
        .map_err(|e| anyhow!("cannot write {}: {}", path.display(), e.error))?;
    Ok(())
}

impl StudyFiles {
    /// Open `dir` for `st`: fresh (old results replaced) or, with `resume`,
    /// keeping the rows of the same study.
    pub fn open(dir: &Path, st: &Study, resume: bool) -> Result<Self> {
        let fp = dir.join(FINGERPRINT);
        let tables = [Table::Main, Table::Reference];
        if resume && dir.exists() {
            match std::fs::read_to_string(&fp) {
                Ok(t) if t == st.fingerprint => {}
                Ok(_) => bail!(
                    "--resume: {} holds a different study ({} differs): not resumed, nothing changed",
                    dir.display(),
                    fp.display()
                ),
                Err(_) if dir.join("results.csv").exists() => bail!(
                    "--resume: {} has results but no {FINGERPRINT}: not a study folder of this tool, nothing changed",
                    dir.display()
                ),
                Err(_) => {}
            }
        }
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create output directory {}", dir.display()))?;
        std::fs::write(&fp, &st.fingerprint)
            .with_context(|| format!("cannot write {}", fp.display()))?;
        let h = header(st);
        let mut open = Vec::new();
        for t in tables {
            let path = dir.join(format!("{}.csv", t.stem()));
            let kept = if resume && path.exists() {
                read_done(&path, st)?
            } else {
                Vec::new()
            };
            write_csv_atomic(&path, &h, &kept)?;
            let done = kept
                .iter()
                .filter_map(|r| r.get(0).and_then(|s| s.parse().ok()))
                .collect();
            let file = std::fs::OpenOptions::new()
                .append(true)
                .open(&path)
                .with_context(|| format!("cannot open {}", path.display()))?;
            open.push((t, done, RowWriter::new(file, path)));
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            tables: open,
        })
    }

    /// Whether sample `i` of `table` is already in the folder.
    pub fn done(&self, table: Table, i: usize) -> bool {
        self.tables
            .iter()
            .any(|(t, d, _)| *t == table && d.contains(&i))
    }

    pub fn writer(&self, table: Table) -> &RowWriter {
        &self
            .tables
            .iter()
            .find(|(t, _, _)| *t == table)
            .expect("both tables are open")
            .2
    }

    /// Sort the tables by sample, write the Parquet files, the summary and the plots.
    pub fn finish(self, st: &Study, run: &RunStats) -> Result<Finished> {
        let h = header(st);
        let mut files = Vec::new();
        let mut main_rows = Vec::new();
        for (t, _, w) in self.tables {
            w.flush()?;
            drop(w);
            let csv_path = self.dir.join(format!("{}.csv", t.stem()));
            let mut rows = read_done(&csv_path, st)?;
            rows.sort_by_key(|r| r.get(0).and_then(|s| s.parse::<usize>().ok()));
            write_csv_atomic(&csv_path, &h, &rows)?;
            let pq = self.dir.join(format!("{}.parquet", t.stem()));
            write_parquet(&pq, st, &rows)?;
            files.push(csv_path);
            files.push(pq);
            if t == Table::Main {
                main_rows = rows;
            }
        }
        let parsed: Vec<Parsed> = main_rows.iter().map(|r| Parsed::of(st, r)).collect();
        let failed = parsed.iter().filter(|p| p.status != "ok").count();
        let summary = summary_json(st, &parsed, run, failed);
        let sp = self.dir.join(SUMMARY);
        std::fs::write(&sp, serde_json::to_string_pretty(&summary)?)
            .with_context(|| format!("cannot write {}", sp.display()))?;
        files.push(sp);
        files.extend(plots(&self.dir.join("plots"), st, &parsed)?);
        Ok(Finished { failed, files })
    }
}

/// A results row read back.
struct Parsed {
    params: Vec<f64>,
    /// The figure-of-merit columns (numbers), `None` when empty.
    figures: Vec<Option<f64>>,
    left_table: bool,
    status: String,
}

/// Number columns of [`FIGURE_COLUMNS`] (their index there).
const NUMBER_FIGURES: [usize; 6] = [0, 1, 2, 3, 4, 7];

impl Parsed {
    fn of(st: &Study, r: &csv::StringRecord) -> Self {
        let p = st.keys.len();
        let f = |j: usize| r.get(1 + p + j).and_then(|s| s.parse::<f64>().ok());
        Self {
            params: (0..p)
                .map(|j| {
                    r.get(1 + j)
                        .and_then(|s| s.parse().ok())
                        .unwrap_or(f64::NAN)
                })
                .collect(),
            figures: NUMBER_FIGURES.iter().map(|&j| f(j)).collect(),
            left_table: r.get(1 + p + 5) == Some("true"),
            status: r.get(1 + p + 6).unwrap_or("").to_string(),
        }
    }
}

/// The Parquet copy of a results table: `sample` int64, parameters double,
/// figures optional double, `left_table` boolean, `status` UTF-8.
fn write_parquet(path: &Path, st: &Study, rows: &[csv::StringRecord]) -> Result<()> {
    use parquet::basic::{LogicalType, Repetition, Type as Physical};
    use parquet::data_type::{BoolType, ByteArray, ByteArrayType, DoubleType, Int64Type};
    use parquet::file::properties::WriterProperties;
    use parquet::file::writer::SerializedFileWriter;
    use parquet::schema::types::Type;
    use std::sync::Arc;
    let h = header(st);
    let p = st.keys.len();
    // column kinds: 0 int64, 1 required double, 2 optional double, 3 bool, 4 string
    let kind = |j: usize| -> u8 {
        if j == 0 {
            0
        } else if j <= p {
            1
        } else {
            match FIGURE_COLUMNS[j - 1 - p] {
                "left_table" => 3,
                "status" => 4,
                _ => 2,
            }
        }
    };
    let mut fields = Vec::new();
    for (j, name) in h.iter().enumerate() {
        let (phys, rep) = match kind(j) {
            0 => (Physical::INT64, Repetition::REQUIRED),
            1 => (Physical::DOUBLE, Repetition::REQUIRED),
            2 => (Physical::DOUBLE, Repetition::OPTIONAL),
            3 => (Physical::BOOLEAN, Repetition::REQUIRED),
            _ => (Physical::BYTE_ARRAY, Repetition::REQUIRED),
        };
        let mut b = Type::primitive_type_builder(name, phys).with_repetition(rep);
        if kind(j) == 4 {
            b = b.with_logical_type(Some(LogicalType::String));
        }
        fields.push(Arc::new(b.build()?));
    }
    let schema = Arc::new(
        Type::group_type_builder("results")
            .with_fields(fields)
            .build()?,
    );
    let dir = path.parent().unwrap_or(Path::new("."));
    let tmp = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("cannot write in {}", dir.display()))?;
    let mut w = SerializedFileWriter::new(
        tmp.reopen()?,
        schema,
        Arc::new(WriterProperties::builder().build()),
    )?;
    let cell = |r: &csv::StringRecord, j: usize| r.get(j).unwrap_or("").to_string();
    let mut rg = w.next_row_group()?;
    let mut j = 0;
    while let Some(mut col) = rg.next_column()? {
        match kind(j) {
            0 => {
                let v: Vec<i64> = rows
                    .iter()
                    .map(|r| cell(r, j).parse().unwrap_or(-1))
                    .collect();
                col.typed::<Int64Type>().write_batch(&v, None, None)?;
            }
            1 => {
                let v: Vec<f64> = rows
                    .iter()
                    .map(|r| cell(r, j).parse().unwrap_or(f64::NAN))
                    .collect();
                col.typed::<DoubleType>().write_batch(&v, None, None)?;
            }
            2 => {
                let parsed: Vec<Option<f64>> =
                    rows.iter().map(|r| cell(r, j).parse().ok()).collect();
                let v: Vec<f64> = parsed.iter().flatten().copied().collect();
                let def: Vec<i16> = parsed.iter().map(|x| i16::from(x.is_some())).collect();
                col.typed::<DoubleType>()
                    .write_batch(&v, Some(&def), None)?;
            }
            3 => {
                let v: Vec<bool> = rows.iter().map(|r| cell(r, j) == "true").collect();
                col.typed::<BoolType>().write_batch(&v, None, None)?;
            }
            _ => {
                let v: Vec<ByteArray> = rows
                    .iter()
                    .map(|r| ByteArray::from(cell(r, j).as_str()))
                    .collect();
                col.typed::<ByteArrayType>().write_batch(&v, None, None)?;
            }
        }
        col.close()?;
        j += 1;
    }
    rg.close()?;
    w.close()?;
    tmp.persist(path)
        .map_err(|e| anyhow!("cannot write {}: {}", path.display(), e.error))?;
    Ok(())
}

/// Average ranks (ties share their mean rank).
fn ranks(x: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && x[idx[j + 1]] == x[idx[i]] {
            j += 1;
        }
        let mean = 0.5 * (i + j) as f64 + 1.0;
        for &k in &idx[i..=j] {
            r[k] = mean;
        }
        i = j + 1;
    }
    r
}

/// Pearson correlation; `None` for fewer than 3 pairs or a constant series.
/// (Twenty lines of textbook arithmetic: no crate for it is worth the build.)
pub fn pearson(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len();
    if n < 3 || y.len() != n {
        return None;
    }
    let mx = x.iter().sum::<f64>() / n as f64;
    let my = y.iter().sum::<f64>() / n as f64;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
    }
    (sxx > 0.0 && syy > 0.0).then(|| (sxy / (sxx * syy).sqrt()).clamp(-1.0, 1.0))
}

/// Spearman rank correlation (Pearson of the average ranks).
pub fn spearman(x: &[f64], y: &[f64]) -> Option<f64> {
    pearson(&ranks(x), &ranks(y))
}

fn stats(v: &[f64]) -> serde_json::Value {
    if v.is_empty() {
        return json!({ "count": 0, "min": null, "max": null, "mean": null });
    }
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    json!({ "count": v.len(), "min": min, "max": max, "mean": v.iter().sum::<f64>() / v.len() as f64 })
}

fn figure_name(k: usize) -> &'static str {
    FIGURE_COLUMNS[NUMBER_FIGURES[k]]
}

fn summary_json(st: &Study, rows: &[Parsed], run: &RunStats, failed: usize) -> serde_json::Value {
    let ok: Vec<&Parsed> = rows.iter().filter(|r| r.status == "ok").collect();
    let mut parameters = BTreeMap::new();
    for (j, k) in st.keys.iter().enumerate() {
        let v: Vec<f64> = rows.iter().map(|r| r.params[j]).collect();
        parameters.insert(k.clone(), stats(&v));
    }
    let mut figures = BTreeMap::new();
    let mut correlation = BTreeMap::new();
    for k in 0..NUMBER_FIGURES.len() {
        let pairs: Vec<&Parsed> = ok
            .iter()
            .copied()
            .filter(|r| r.figures[k].is_some())
            .collect();
        let y: Vec<f64> = pairs.iter().filter_map(|r| r.figures[k]).collect();
        figures.insert(figure_name(k), stats(&y));
        let mut per = BTreeMap::new();
        for (j, key) in st.keys.iter().enumerate() {
            let x: Vec<f64> = pairs.iter().map(|r| r.params[j]).collect();
            per.insert(
                key.clone(),
                json!({ "pearson": pearson(&x, &y), "spearman": spearman(&x, &y) }),
            );
        }
        correlation.insert(figure_name(k), per);
    }
    json!({
        "format": "nlmode-study-summary",
        "method": st.method.name(),
        "design": st.spec.design,
        "samples": rows.len(),
        "ok_samples": ok.len(),
        "failed_samples": failed,
        "left_table_samples": rows.iter().filter(|r| r.left_table).count(),
        "reference_samples": st.reference_samples,
        "parameters": parameters,
        "figures": figures,
        "correlation": correlation,
        "run": run,
        "samples_per_s": run.samples_per_s(),
    })
}

/// A file name part from a key.
fn file_part(key: &str) -> String {
    key.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// The figures of merit plotted: (index into the number figures, label, scale).
const PLOTTED: [(usize, &str, f64); 4] = [
    (0, "peak tip amplitude [mm]", 1e3),
    (2, "jump-down Omega [rad/s]", 1.0),
    (3, "min force amplitude [N]", 1.0),
    (4, "max force amplitude [N]", 1.0),
];

fn plots(dir: &Path, st: &Study, rows: &[Parsed]) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let ok: Vec<&Parsed> = rows.iter().filter(|r| r.status == "ok").collect();
    let mut files = Vec::new();
    for (j, key) in st.keys.iter().enumerate() {
        for &(k, label, scale) in &PLOTTED {
            let pairs: Vec<(f64, f64)> = ok
                .iter()
                .filter_map(|r| r.figures[k].map(|y| (r.params[j], scale * y)))
                .collect();
            if pairs.is_empty() {
                continue;
            }
            let x: Vec<f64> = pairs.iter().map(|p| p.0).collect();
            let y: Vec<f64> = pairs.iter().map(|p| p.1).collect();
            let path = dir.join(format!(
                "{}_vs_{}.svg",
                file_part(figure_name(k)),
                file_part(key)
            ));
            plot::xy_plot(
                &path,
                &format!("{label} against {key} ({} samples)", pairs.len()),
                key,
                label,
                &[plot::Curve {
                    label: st.method.name().into(),
                    x: &x,
                    y: &y,
                }],
                plot::Style::Dots,
            )?;
            files.push(path);
        }
    }
    if st.spec.design != super::design::DesignKind::Grid {
        for &(k, label, scale) in &PLOTTED {
            let v: Vec<f64> = ok
                .iter()
                .filter_map(|r| r.figures[k])
                .map(|y| scale * y)
                .collect();
            if v.is_empty() {
                continue;
            }
            let path = dir.join(format!("histogram_{}.svg", file_part(figure_name(k))));
            histogram(&path, &format!("{label}: {} samples", v.len()), label, &v)?;
            files.push(path);
        }
    }
    Ok(files)
}

/// A histogram (sqrt(n) bins, at most 50).
fn histogram(path: &Path, title: &str, xlabel: &str, v: &[f64]) -> Result<()> {
    use plotters::prelude::*;
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else {
        (lo - 0.5, lo + 0.5)
    };
    let bins = ((v.len() as f64).sqrt().ceil() as usize).clamp(1, 50);
    let width = (hi - lo) / bins as f64;
    let mut counts = vec![0u32; bins];
    for &x in v {
        counts[(((x - lo) / width) as usize).min(bins - 1)] += 1;
    }
    let top = counts.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.05;
    let err = |e: &dyn std::fmt::Display| anyhow!("plot {}: {e}", path.display());
    let root = SVGBackend::new(path, (900, 500)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(lo..hi, 0.0..top)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc(xlabel)
        .y_desc("samples")
        .draw()
        .map_err(|e| err(&e))?;
    chart
        .draw_series(counts.iter().enumerate().map(|(i, &c)| {
            let x0 = lo + i as f64 * width;
            Rectangle::new([(x0, 0.0), (x0 + width, c as f64)], BLUE.mix(0.6).filled())
        }))
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlations_of_known_series() {
        let x = [1.0, 2.0, 3.0, 4.0, 5.0];
        let y = [1.0, 4.0, 9.0, 16.0, 25.0];
        assert!((spearman(&x, &y).unwrap() - 1.0).abs() < 1e-15);
        let p = pearson(&x, &y).unwrap();
        assert!((p - 0.9811049102515929).abs() < 1e-12, "{p}");
        assert_eq!(pearson(&x, &[2.0; 5]), None);
        assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), vec![3.5, 1.0, 3.5, 2.0]);
    }
}
