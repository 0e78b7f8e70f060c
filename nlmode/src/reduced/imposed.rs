//! A prescribed complex force envelope `F(Omega)` for the `imposed-force`
//! model (paper Section 5.3): the force `F(t) = Re(|F| e^{i(Phi + phase)})`,
//! `Phi = int Omega dt`, with amplitude and (unwrapped) phase interpolated
//! linearly in `Omega`.
use super::{ReducedError, SlowFlowResult};
use num_complex::Complex64;

/// Complex force amplitude against the excitation frequency.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ForceEnvelope {
    /// Strictly increasing excitation frequencies \[rad/s\].
    pub omega_rad_s: Vec<f64>,
    /// Force amplitudes \[N\].
    pub amplitude_n: Vec<f64>,
    /// Force phases relative to `Phi` \[rad\], unwrapped (no jumps above pi).
    pub phase_rad: Vec<f64>,
}

impl ForceEnvelope {
    /// From samples in any order of `Omega` (sorted here; the phase is
    /// unwrapped along increasing `Omega`). Needs at least 2 distinct,
    /// positive, finite frequencies and finite, non-negative amplitudes.
    pub fn new(
        omega_rad_s: &[f64],
        amplitude_n: &[f64],
        phase_rad: &[f64],
    ) -> Result<Self, ReducedError> {
        if omega_rad_s.len() != amplitude_n.len() || omega_rad_s.len() != phase_rad.len() {
            return Err(ReducedError::Envelope(format!(
                "column lengths differ: omega {}, amplitude {}, phase {}",
                omega_rad_s.len(),
                amplitude_n.len(),
                phase_rad.len()
            )));
        }
        let mut rows: Vec<(f64, f64, f64)> = Vec::with_capacity(omega_rad_s.len());
        for (j, ((&w, &f), &p)) in omega_rad_s
            .iter()
            .zip(amplitude_n)
            .zip(phase_rad)
            .enumerate()
        {
            if !(w.is_finite() && w > 0.0) {
                return Err(ReducedError::Envelope(format!(
                    "row {j}: omega_rad_s = {w} must be positive and finite"
                )));
            }
            if !(f.is_finite() && f >= 0.0) {
                return Err(ReducedError::Envelope(format!(
                    "row {j}: force_amplitude_N = {f} must be finite and non-negative"
                )));
            }
            if !p.is_finite() {
                return Err(ReducedError::Envelope(format!(
                    "row {j}: force_phase_rad = {p} must be finite"
                )));
            }
            rows.push((w, f, p));
        }
        rows.sort_by(|a, b| a.0.total_cmp(&b.0));
        rows.dedup_by(|b, a| b.0 == a.0);
        if rows.len() < 2 {
            return Err(ReducedError::Envelope(format!(
                "need at least 2 distinct frequencies, got {}",
                rows.len()
            )));
        }
        let mut phase = Vec::with_capacity(rows.len());
        let tau = std::f64::consts::TAU;
        for (j, r) in rows.iter().enumerate() {
            if j == 0 {
                phase.push(r.2);
            } else {
                let prev: f64 = phase[j - 1];
                phase.push(r.2 + tau * ((prev - r.2) / tau).round());
            }
        }
        Ok(Self {
            omega_rad_s: rows.iter().map(|r| r.0).collect(),
            amplitude_n: rows.iter().map(|r| r.1).collect(),
            phase_rad: phase,
        })
    }

    /// The drive-point force of another method's slow-flow result.
    pub fn from_result(result: &SlowFlowResult) -> Result<Self, ReducedError> {
        let s = &result.samples;
        let w: Vec<f64> = s.iter().map(|x| x.omega_rad_s).collect();
        let f: Vec<f64> = s.iter().map(|x| x.force_amplitude_n).collect();
        let p: Vec<f64> = s.iter().map(|x| x.force_phase_rad()).collect();
        Self::new(&w, &f, &p)
    }

    /// A constant force `F0` (complex) over `[lo, hi]` rad/s.
    pub fn constant(force_n: Complex64, lo: f64, hi: f64) -> Result<Self, ReducedError> {
        Self::new(&[lo, hi], &[force_n.norm(); 2], &[force_n.arg(); 2])
    }

    /// Frequency range `(min, max)` \[rad/s\].
    pub fn range(&self) -> (f64, f64) {
        (self.omega_rad_s[0], *self.omega_rad_s.last().unwrap())
    }

    /// The envelope extended to cover `[lo, hi]` \[rad/s\] by holding its first
    /// and last values (amplitude and phase). For envelopes measured with a
    /// sliding window, which leaves half a window undefined at each end of a
    /// sweep (the reference's one excitation period: about 1 % of `omega0` at
    /// the paper's rate); the start-up transient dominates there anyway.
    pub fn with_held_ends(mut self, lo: f64, hi: f64) -> Self {
        let (min, max) = self.range();
        if lo < min {
            self.omega_rad_s.insert(0, lo);
            self.amplitude_n.insert(0, self.amplitude_n[0]);
            self.phase_rad.insert(0, self.phase_rad[0]);
        }
        if hi > max {
            let n = self.omega_rad_s.len();
            self.omega_rad_s.push(hi);
            self.amplitude_n.push(self.amplitude_n[n - 1]);
            self.phase_rad.push(self.phase_rad[n - 1]);
        }
        self
    }

    /// Errors unless `[lo, hi]` lies inside the envelope's range (with a
    /// relative slack of 1e-9 for round-off at the ends).
    pub(crate) fn check_covers(&self, lo: f64, hi: f64) -> Result<(), ReducedError> {
        let (min, max) = self.range();
        let slack = 1e-9 * max;
        for w in [lo, hi] {
            if w < min - slack || w > max + slack {
                return Err(ReducedError::EnvelopeRange {
                    omega_rad_s: w,
                    min,
                    max,
                });
            }
        }
        Ok(())
    }

    /// Complex force at `Omega` (linear in amplitude and phase; held within the
    /// 1e-9 slack at the ends).
    #[inline]
    pub fn eval(&self, omega_rad_s: f64) -> Result<Complex64, ReducedError> {
        let (min, max) = self.range();
        let slack = 1e-9 * max;
        if !(omega_rad_s >= min - slack && omega_rad_s <= max + slack) {
            return Err(ReducedError::EnvelopeRange {
                omega_rad_s,
                min,
                max,
            });
        }
        let w = omega_rad_s.clamp(min, max);
        let n = self.omega_rad_s.len();
        let k = self
            .omega_rad_s
            .partition_point(|&x| x <= w)
            .clamp(1, n - 1)
            - 1;
        let s = (w - self.omega_rad_s[k]) / (self.omega_rad_s[k + 1] - self.omega_rad_s[k]);
        let amp = self.amplitude_n[k] + s * (self.amplitude_n[k + 1] - self.amplitude_n[k]);
        let ph = self.phase_rad[k] + s * (self.phase_rad[k + 1] - self.phase_rad[k]);
        Ok(Complex64::from_polar(amp, ph))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn held_ends_cover_the_sweep_and_keep_the_inside() {
        let e = ForceEnvelope::new(&[100.0, 200.0], &[1.0, 3.0], &[0.5, 0.7]).unwrap();
        assert!(e.check_covers(90.0, 210.0).is_err());
        let h = e.clone().with_held_ends(90.0, 210.0);
        h.check_covers(90.0, 210.0).unwrap();
        assert_eq!(h.eval(90.0).unwrap(), Complex64::from_polar(1.0, 0.5));
        assert_eq!(h.eval(210.0).unwrap(), Complex64::from_polar(3.0, 0.7));
        assert_eq!(h.eval(150.0).unwrap(), e.eval(150.0).unwrap());
        // already covered: unchanged
        assert_eq!(e.clone().with_held_ends(120.0, 180.0), e);
    }

    #[test]
    fn unsorted_rows_interpolation_and_unwrapping() {
        // rows out of frequency order (CSV files are read by host::results::read_envelope)
        let e = ForceEnvelope::new(&[200.0, 100.0, 300.0], &[1.0, 3.0, 2.0], &[3.0, -3.0, 3.1])
            .unwrap();
        assert_eq!(e.omega_rad_s, vec![100.0, 200.0, 300.0]);
        // phase -3 -> 3 jumps by 6 > pi: unwrapped to 3 - 2 pi
        let tau = std::f64::consts::TAU;
        assert!((e.phase_rad[1] - (3.0 - tau)).abs() < 1e-15);
        assert!((e.phase_rad[2] - (3.1 - tau)).abs() < 1e-15);
        let f = e.eval(150.0).unwrap();
        assert!((f.norm() - 2.0).abs() < 1e-14);
        assert!((f.arg() - 0.5 * (-3.0 + 3.0 - tau)).abs() < 1e-14);
        assert!(matches!(
            e.eval(99.0),
            Err(ReducedError::EnvelopeRange { .. })
        ));
        assert!(matches!(
            ForceEnvelope::new(&[1.0, 2.0], &[1.0], &[0.0, 0.0]),
            Err(ReducedError::Envelope(_))
        ));
        assert!(matches!(
            ForceEnvelope::new(&[1.0, 2.0], &[f64::NAN, 1.0], &[0.0, 0.0]),
            Err(ReducedError::Envelope(_))
        ));
        assert!(matches!(
            ForceEnvelope::new(&[1.0, 2.0], &[1.0, -1.0], &[0.0, 0.0]),
            Err(ReducedError::Envelope(_))
        ));
    }
}
