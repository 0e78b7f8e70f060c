//! The one envelope type: fundamental-harmonic amplitudes of a sweep or a
//! steady state against the excitation frequency `Omega`, whichever method
//! produced them (`reference`, the slow flow of `eq:NM`, the linear steady
//! states, the co-simulation). Each producer of the library maps into it here,
//! in one place each; file I/O is the caller's (serde derives only).
//!
//! A row ([`EnvelopeRow`]) carries the column names of the host's
//! `<method>_envelope.csv` (`omega_rad_s`, `force_amplitude_N`,
//! `tip_amplitude_m`, then the optional columns that are present).
use crate::reduced::{ForceEnvelope, ReducedError, SlowFlowResult};
use serde::{Deserialize, Serialize};

/// Fundamental-harmonic envelopes against the excitation frequency; the
/// optional columns are either present for every sample or absent.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Envelope {
    /// Excitation frequency `Omega` \[rad/s\].
    pub omega_rad_s: Vec<f64>,
    /// Fundamental force amplitude at the drive point `|F|` \[N\] (`eq:fc1`).
    pub force_amplitude_n: Vec<f64>,
    /// Fundamental tip amplitude `|q_tip,1|` \[m\].
    pub tip_amplitude_m: Vec<f64>,
    /// Phase of the force relative to the excitation phase `Phi` \[rad\]
    /// (`F(t) = Re(|F| e^{i(Phi + phase)})`).
    pub force_phase_rad: Option<Vec<f64>>,
    /// Fundamental drive-point amplitude \[m\].
    pub drive_amplitude_m: Option<Vec<f64>>,
    /// Modal amplitude `a` of `eq:NM` \[sqrt(kg) m\].
    pub modal_amplitude: Option<Vec<f64>>,
    /// Modal frequency `omega(a)` in force \[rad/s\].
    pub modal_frequency_rad_s: Option<Vec<f64>>,
}

/// One sample of an [`Envelope`], named as the CSV columns; absent optional
/// columns are skipped when serialised and `None` when deserialised.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct EnvelopeRow {
    pub omega_rad_s: f64,
    #[serde(rename = "force_amplitude_N")]
    pub force_amplitude_n: f64,
    pub tip_amplitude_m: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_phase_rad: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive_amplitude_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modal_amplitude: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modal_frequency_rad_s: Option<f64>,
}

/// Why rows do not form an [`Envelope`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EnvelopeError {
    /// An optional column is present in some rows and absent in others.
    #[error("column '{column}' is present in row 0 but {state} in row {row}")]
    RaggedColumn {
        column: &'static str,
        row: usize,
        state: &'static str,
    },
}

/// How one envelope differs from another (the other's samples interpolated
/// linearly at this envelope's frequencies, where they overlap), relative to
/// the other's peaks: the numbers the co-simulation checks and benches quote.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvelopeComparison {
    /// `max |q_tip| / max |q_tip,other| - 1`.
    pub peak_tip_rel: f64,
    /// Jump-down frequency ratio minus one ([`steepest_drop_omega_rad_s`]).
    pub jump_down_rel: f64,
    /// RMS of the tip difference over the other's peak tip amplitude.
    pub rms_tip_rel: f64,
    /// RMS of the force difference over the other's largest force amplitude.
    pub rms_force_rel: f64,
    /// Number of samples where both envelopes are defined.
    pub overlap: usize,
}

/// Frequency of the steepest drop of `tip` after its peak (the jump-down of a
/// hardening resonance), slopes taken over 1/400 of the samples.
pub fn steepest_drop_omega_rad_s(omega_rad_s: &[f64], tip: &[f64]) -> f64 {
    let Some(i) = (0..tip.len()).max_by(|&a, &b| tip[a].total_cmp(&tip[b])) else {
        return f64::NAN;
    };
    let w = (omega_rad_s.len() / 400).max(1);
    let mut best = (0.0, omega_rad_s[i]);
    for k in i..omega_rad_s.len().saturating_sub(w) {
        let s = (tip[k + w] - tip[k]) / (omega_rad_s[k + w] - omega_rad_s[k]);
        if s < best.0 {
            best = (s, 0.5 * (omega_rad_s[k] + omega_rad_s[k + w]));
        }
    }
    best.1
}

/// Linear interpolation of `(x, y)` at `x0` (`x` increasing); `None` outside.
fn interpolate(x: &[f64], y: &[f64], x0: f64) -> Option<f64> {
    let k = x.partition_point(|&v| v <= x0);
    (k > 0 && k < x.len())
        .then(|| y[k - 1] + (x0 - x[k - 1]) / (x[k] - x[k - 1]) * (y[k] - y[k - 1]))
}

impl Envelope {
    /// This envelope against another one given by its columns (frequency
    /// increasing), see [`EnvelopeComparison`].
    pub fn compare_with(
        &self,
        omega_rad_s: &[f64],
        force_amplitude_n: &[f64],
        tip_amplitude_m: &[f64],
    ) -> EnvelopeComparison {
        let peak = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
        let (mut st, mut sf, mut n) = (0.0, 0.0, 0);
        for (k, &w) in self.omega_rad_s.iter().enumerate() {
            if let (Some(t), Some(f)) = (
                interpolate(omega_rad_s, tip_amplitude_m, w),
                interpolate(omega_rad_s, force_amplitude_n, w),
            ) {
                st += (self.tip_amplitude_m[k] - t).powi(2);
                sf += (self.force_amplitude_n[k] - f).powi(2);
                n += 1;
            }
        }
        let m = n.max(1) as f64;
        let tip_other = peak(tip_amplitude_m);
        EnvelopeComparison {
            peak_tip_rel: peak(&self.tip_amplitude_m) / tip_other - 1.0,
            jump_down_rel: steepest_drop_omega_rad_s(&self.omega_rad_s, &self.tip_amplitude_m)
                / steepest_drop_omega_rad_s(omega_rad_s, tip_amplitude_m)
                - 1.0,
            rms_tip_rel: (st / m).sqrt() / tip_other,
            rms_force_rel: (sf / m).sqrt() / peak(force_amplitude_n),
            overlap: n,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.omega_rad_s.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.omega_rad_s.is_empty()
    }

    /// Sample `i` as a row (optional columns as present).
    pub fn row(&self, i: usize) -> EnvelopeRow {
        let opt = |c: &Option<Vec<f64>>| c.as_ref().map(|v| v[i]);
        EnvelopeRow {
            omega_rad_s: self.omega_rad_s[i],
            force_amplitude_n: self.force_amplitude_n[i],
            tip_amplitude_m: self.tip_amplitude_m[i],
            force_phase_rad: opt(&self.force_phase_rad),
            drive_amplitude_m: opt(&self.drive_amplitude_m),
            modal_amplitude: opt(&self.modal_amplitude),
            modal_frequency_rad_s: opt(&self.modal_frequency_rad_s),
        }
    }

    /// The rows, shortest column first (all columns have equal lengths when
    /// built by this module).
    pub fn rows(&self) -> impl Iterator<Item = EnvelopeRow> + '_ {
        let mut n = self
            .omega_rad_s
            .len()
            .min(self.force_amplitude_n.len())
            .min(self.tip_amplitude_m.len());
        for c in [
            &self.force_phase_rad,
            &self.drive_amplitude_m,
            &self.modal_amplitude,
            &self.modal_frequency_rad_s,
        ]
        .into_iter()
        .flatten()
        {
            n = n.min(c.len());
        }
        (0..n).map(|i| self.row(i))
    }

    /// From rows; an optional column must be present in every row or in none.
    pub fn from_rows(rows: &[EnvelopeRow]) -> Result<Self, EnvelopeError> {
        fn column(
            rows: &[EnvelopeRow],
            name: &'static str,
            f: fn(&EnvelopeRow) -> Option<f64>,
        ) -> Result<Option<Vec<f64>>, EnvelopeError> {
            let Some(first) = rows.first() else {
                return Ok(None);
            };
            let present = f(first).is_some();
            let mut v = Vec::with_capacity(if present { rows.len() } else { 0 });
            for (i, r) in rows.iter().enumerate() {
                match (f(r), present) {
                    (Some(x), true) => v.push(x),
                    (None, false) => {}
                    (Some(_), false) => {
                        return Err(EnvelopeError::RaggedColumn {
                            column: name,
                            row: i,
                            state: "present",
                        })
                    }
                    (None, true) => {
                        return Err(EnvelopeError::RaggedColumn {
                            column: name,
                            row: i,
                            state: "absent",
                        })
                    }
                }
            }
            Ok(present.then_some(v))
        }
        Ok(Self {
            omega_rad_s: rows.iter().map(|r| r.omega_rad_s).collect(),
            force_amplitude_n: rows.iter().map(|r| r.force_amplitude_n).collect(),
            tip_amplitude_m: rows.iter().map(|r| r.tip_amplitude_m).collect(),
            force_phase_rad: column(rows, "force_phase_rad", |r| r.force_phase_rad)?,
            drive_amplitude_m: column(rows, "drive_amplitude_m", |r| r.drive_amplitude_m)?,
            modal_amplitude: column(rows, "modal_amplitude", |r| r.modal_amplitude)?,
            modal_frequency_rad_s: column(rows, "modal_frequency_rad_s", |r| {
                r.modal_frequency_rad_s
            })?,
        })
    }

    /// The complex force envelope imposed by the `imposed-force` model (paper
    /// Section 5.3); needs the `force_phase_rad` column.
    pub fn to_force_envelope(&self) -> Result<ForceEnvelope, ReducedError> {
        let phase = self.force_phase_rad.as_ref().ok_or_else(|| {
            ReducedError::Envelope(
                "the envelope has no column 'force_phase_rad' (required to impose the force)"
                    .into(),
            )
        })?;
        ForceEnvelope::new(&self.omega_rad_s, &self.force_amplitude_n, phase)
    }
}

/// The slow flow of `eq:NM` (`nlmode`, `linear-slowflow`, `imposed-force`):
/// every column.
impl From<&SlowFlowResult> for Envelope {
    fn from(res: &SlowFlowResult) -> Self {
        let s = &res.samples;
        let col = |f: fn(&crate::reduced::SlowFlowSample) -> f64| s.iter().map(f).collect();
        Self {
            omega_rad_s: col(|x| x.omega_rad_s),
            force_amplitude_n: col(|x| x.force_amplitude_n),
            tip_amplitude_m: col(|x| x.tip_amplitude_m),
            force_phase_rad: Some(col(|x| x.force_phase_rad())),
            drive_amplitude_m: Some(col(|x| x.drive_amplitude_m)),
            modal_amplitude: Some(col(|x| x.a)),
            modal_frequency_rad_s: Some(col(|x| x.modal_frequency_rad_s)),
        }
    }
}

/// The slow flow's amplitude-only envelope.
impl From<crate::reduced::Envelope> for Envelope {
    fn from(e: crate::reduced::Envelope) -> Self {
        Self {
            omega_rad_s: e.omega_rad_s,
            force_amplitude_n: e.force_amplitude_n,
            tip_amplitude_m: e.tip_amplitude_m,
            ..Default::default()
        }
    }
}

/// The windowed envelope of the full-order reference (with the force phase).
impl From<crate::reference::Envelope> for Envelope {
    fn from(e: crate::reference::Envelope) -> Self {
        Self {
            omega_rad_s: e.omega_rad_s,
            force_amplitude_n: e.force_amplitude_n,
            tip_amplitude_m: e.tip_amplitude_m,
            force_phase_rad: Some(e.force_phase_rad),
            ..Default::default()
        }
    }
}

/// The linear single-mode steady state (`linear-steady`).
impl From<&crate::reduced::LinearSteady> for Envelope {
    fn from(ls: &crate::reduced::LinearSteady) -> Self {
        let p = &ls.points;
        Self {
            omega_rad_s: p.iter().map(|x| x.omega_rad_s).collect(),
            force_amplitude_n: p.iter().map(|x| x.force_amplitude_n).collect(),
            tip_amplitude_m: p.iter().map(|x| x.tip_amplitude_m).collect(),
            force_phase_rad: Some(p.iter().map(|x| x.force_phase_rad).collect()),
            drive_amplitude_m: Some(p.iter().map(|x| x.drive_amplitude_m).collect()),
            ..Default::default()
        }
    }
}

/// An imposed force envelope (amplitude and phase, no response columns: the
/// tip amplitude is NaN).
impl From<&ForceEnvelope> for Envelope {
    fn from(f: &ForceEnvelope) -> Self {
        Self {
            omega_rad_s: f.omega_rad_s.clone(),
            force_amplitude_n: f.amplitude_n.clone(),
            tip_amplitude_m: vec![f64::NAN; f.omega_rad_s.len()],
            force_phase_rad: Some(f.phase_rad.clone()),
            ..Default::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_with_optional_columns() {
        let e = Envelope {
            omega_rad_s: vec![1.0, 2.0],
            force_amplitude_n: vec![3.0, 4.0],
            tip_amplitude_m: vec![5.0, 6.0],
            drive_amplitude_m: Some(vec![7.0, 8.0]),
            ..Default::default()
        };
        let rows: Vec<EnvelopeRow> = e.rows().collect();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].drive_amplitude_m, Some(8.0));
        assert_eq!(rows[1].force_phase_rad, None);
        assert_eq!(Envelope::from_rows(&rows).unwrap(), e);
        let mut ragged = rows.clone();
        ragged[1].drive_amplitude_m = None;
        assert_eq!(
            Envelope::from_rows(&ragged),
            Err(EnvelopeError::RaggedColumn {
                column: "drive_amplitude_m",
                row: 1,
                state: "absent"
            })
        );
        assert!(matches!(
            e.to_force_envelope(),
            Err(ReducedError::Envelope(m)) if m.contains("force_phase_rad")
        ));
    }
}
