//! Method results and the machine-readable output contract (DESIGN.md section 7):
//! `summary.json`, `<method>_envelope.csv`, `<method>_timeseries.csv`.
use anyhow::{Context, Result};
use serde_json::{json, Map, Value};
use std::io::Write;
use std::path::Path;

/// Fundamental-harmonic amplitudes against the instantaneous excitation frequency.
#[derive(Debug, Clone, Default)]
pub struct Envelope {
    pub omega_rad_s: Vec<f64>,
    pub force_amplitude_n: Vec<f64>,
    pub tip_amplitude_m: Vec<f64>,
    /// Optional further columns (name, values), e.g. `force_phase_rad`, `drive_amplitude_m`.
    pub extra: Vec<(String, Vec<f64>)>,
}

impl Envelope {
    pub fn len(&self) -> usize {
        self.omega_rad_s.len()
    }
}

/// Named columns of equal length.
#[derive(Debug, Clone, Default)]
pub struct TimeSeries {
    pub columns: Vec<(String, Vec<f64>)>,
}

/// What one method produced.
#[derive(Debug, Clone)]
pub struct MethodResult {
    pub name: String,
    pub wall_time_s: f64,
    pub envelope: Envelope,
    /// Whether the envelope comes from a sweep (transient) rather than a steady state.
    pub is_sweep: bool,
    pub time_series: Option<TimeSeries>,
    /// Further summary entries (force_drop, steps, ...).
    pub extra: Map<String, Value>,
    pub warnings: Vec<String>,
}

impl MethodResult {
    pub fn new(name: &str, wall_time_s: f64, envelope: Envelope, is_sweep: bool) -> Self {
        Self {
            name: name.into(),
            wall_time_s,
            envelope,
            is_sweep,
            time_series: None,
            extra: Map::new(),
            warnings: Vec::new(),
        }
    }

    /// Peak tip amplitude [m] and the excitation frequency there [rad/s].
    pub fn peak(&self) -> (f64, f64) {
        let e = &self.envelope;
        let mut best = (f64::NAN, f64::NAN);
        for (i, &t) in e.tip_amplitude_m.iter().enumerate() {
            if t.is_finite() && !(t <= best.0) {
                best = (t, e.omega_rad_s[i]);
            }
        }
        best
    }

    /// Excitation frequency of the jump-down: the steepest drop of the tip
    /// envelope per unit frequency after the peak (sweeps only).
    pub fn jump_down_omega(&self) -> Option<f64> {
        if !self.is_sweep {
            return None;
        }
        jump_down(&self.envelope.omega_rad_s, &self.envelope.tip_amplitude_m)
    }

    pub fn summary(&self) -> Value {
        let (peak, peak_w) = self.peak();
        let f = &self.envelope.force_amplitude_n;
        let fmin = f
            .iter()
            .cloned()
            .filter(|v| v.is_finite())
            .fold(f64::INFINITY, f64::min);
        let fmax = f
            .iter()
            .cloned()
            .filter(|v| v.is_finite())
            .fold(f64::NEG_INFINITY, f64::max);
        let mut m = Map::new();
        m.insert("wall_time_s".into(), json!(self.wall_time_s));
        m.insert("peak_tip_amplitude_m".into(), num(peak));
        m.insert("peak_omega_rad_s".into(), num(peak_w));
        m.insert("min_force_amplitude_N".into(), num(fmin));
        m.insert("max_force_amplitude_N".into(), num(fmax));
        if let Some(j) = self.jump_down_omega() {
            m.insert("jump_down_omega_rad_s".into(), json!(j));
        }
        m.insert("points".into(), json!(self.envelope.len()));
        for (k, v) in &self.extra {
            m.insert(k.clone(), v.clone());
        }
        if !self.warnings.is_empty() {
            m.insert("warnings".into(), json!(self.warnings));
        }
        Value::Object(m)
    }
}

fn num(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        Value::Null
    }
}

/// Steepest drop of `y(x)` after its maximum, smoothed over a few samples so that
/// the fundamental-harmonic ripple of a transient envelope does not count.
pub fn jump_down(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len();
    if n < 8 {
        return None;
    }
    let ipk = (0..n)
        .filter(|&i| y[i].is_finite())
        .max_by(|&a, &b| y[a].total_cmp(&y[b]))?;
    let w = (n / 400).max(1);
    let mut best: Option<(f64, f64)> = None;
    for i in ipk..n.saturating_sub(w) {
        let dx = x[i + w] - x[i];
        if dx == 0.0 {
            continue;
        }
        let slope = (y[i + w] - y[i]) / dx.abs();
        if best.map_or(true, |(s, _)| slope < s) {
            best = Some((slope, 0.5 * (x[i] + x[i + w])));
        }
    }
    best.map(|(_, xm)| xm)
}

/// Write `<name>_envelope.csv`.
pub fn write_envelope(dir: &Path, r: &MethodResult) -> Result<()> {
    let e = &r.envelope;
    let mut header = vec![
        "omega_rad_s".to_string(),
        "force_amplitude_N".into(),
        "tip_amplitude_m".into(),
    ];
    let mut cols: Vec<&[f64]> = vec![&e.omega_rad_s, &e.force_amplitude_n, &e.tip_amplitude_m];
    for (n, v) in &e.extra {
        header.push(n.clone());
        cols.push(v);
    }
    write_csv(
        &dir.join(format!("{}_envelope.csv", r.name)),
        &header,
        &cols,
    )
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

pub fn write_csv(path: &Path, header: &[String], cols: &[&[f64]]) -> Result<()> {
    let n = cols.iter().map(|c| c.len()).min().unwrap_or(0);
    let f =
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = std::io::BufWriter::new(f);
    writeln!(w, "{}", header.join(","))?;
    let mut line = String::new();
    for i in 0..n {
        line.clear();
        for (j, c) in cols.iter().enumerate() {
            if j > 0 {
                line.push(',');
            }
            use std::fmt::Write as _;
            write!(line, "{:.9e}", c[i]).unwrap();
        }
        writeln!(w, "{line}")?;
    }
    w.flush()
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
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
}
