//! Sine sweeps, linear in frequency (paper Section 5).
//!
//! The excitation is `u(t) = u_hat cos(Phi(t))` with `dPhi/dt = Omega(t)` and
//! `Omega(t) = Omega_start + rate t` (`u(t) = Re(u_hat e^{i int Omega dt})`, paper
//! Section 4). The paper states the rate as "r frequency change per pseudo period"
//! relative to the linear natural frequency `omega0`: the frequency changes by
//! `r omega0` during one period `2 pi / omega0`, so `dOmega/dt = r omega0^2 / (2 pi)`.

/// Errors of sweep definitions; each names the offending input and its value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SweepError {
    #[error("sweep start frequency must be positive and finite, got {0} rad/s")]
    BadStart(f64),
    #[error("sweep end frequency must be positive and finite, got {0} rad/s")]
    BadEnd(f64),
    #[error("sweep start and end frequency are equal ({0} rad/s)")]
    EmptyRange(f64),
    #[error("sweep rate must be non-zero and finite, got {0} rad/s^2")]
    BadRate(f64),
    #[error("reference frequency omega0 must be positive and finite, got {0} rad/s")]
    BadOmega0(f64),
    #[error("sweep source {which} frequency must be >= 0 rad/s, got {value}")]
    NegativeSourceFrequency { which: SweepEnd, value: f64 },
    #[error("sweep source rate must be >= 0 rad/s^2, got {0}")]
    NegativeSourceRate(f64),
}

/// Which end of a sweep a value belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepEnd {
    Start,
    End,
}

impl std::fmt::Display for SweepEnd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SweepEnd::Start => "start",
            SweepEnd::End => "end",
        })
    }
}

/// A linear sine sweep from `omega_start_rad_s` to `omega_end_rad_s`; forward when
/// the end lies above the start, backward otherwise.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LinearSweep {
    pub omega_start_rad_s: f64,
    pub omega_end_rad_s: f64,
    /// Magnitude of `dOmega/dt` [rad/s^2] (always positive; the direction follows
    /// from start and end).
    pub rate_rad_s2: f64,
    /// Excitation amplitude (`u_hat`: volts for a shaker, newtons for a force).
    pub amplitude: f64,
}

/// The excitation frequency `Omega(t)` of a [`LinearSweep`] with its
/// constants (the span `|Omega_end - Omega_start|`, the signed rate) taken
/// once: the slow flow evaluates it at every right-hand side and output
/// sample. The same operations on the same numbers as
/// [`LinearSweep::omega_rad_s`], which is this.
#[derive(Debug, Clone, Copy)]
pub(crate) struct OmegaRamp {
    start: f64,
    end: f64,
    rate: f64,
    span: f64,
    signed_rate: f64,
}

impl OmegaRamp {
    /// `Omega(t)` \[rad/s\]: on the ramp while `rate t <= span`, held at
    /// the end after it (a zero rate gives `Omega_start` exactly).
    #[inline(always)]
    pub fn at(&self, t_s: f64) -> f64 {
        if self.rate * t_s <= self.span {
            self.start + self.signed_rate * t_s
        } else {
            self.end
        }
    }
}

impl LinearSweep {
    /// A sweep with an explicit rate magnitude [rad/s^2].
    pub fn new(
        omega_start_rad_s: f64,
        omega_end_rad_s: f64,
        rate_rad_s2: f64,
        amplitude: f64,
    ) -> Result<Self, SweepError> {
        if !(omega_start_rad_s.is_finite() && omega_start_rad_s > 0.0) {
            return Err(SweepError::BadStart(omega_start_rad_s));
        }
        if !(omega_end_rad_s.is_finite() && omega_end_rad_s > 0.0) {
            return Err(SweepError::BadEnd(omega_end_rad_s));
        }
        if omega_start_rad_s == omega_end_rad_s {
            return Err(SweepError::EmptyRange(omega_start_rad_s));
        }
        if !(rate_rad_s2.is_finite() && rate_rad_s2 != 0.0) {
            return Err(SweepError::BadRate(rate_rad_s2));
        }
        Ok(Self {
            omega_start_rad_s,
            omega_end_rad_s,
            rate_rad_s2: rate_rad_s2.abs(),
            amplitude,
        })
    }

    /// The paper's definition: from `eta_start omega0` to `eta_end omega0` with a
    /// frequency change of `r` (e.g. 0.02 for 2 %) per pseudo period,
    /// `dOmega/dt = r omega0^2 / (2 pi)`.
    pub fn per_pseudo_period(
        omega0_rad_s: f64,
        eta_start: f64,
        eta_end: f64,
        r: f64,
        amplitude: f64,
    ) -> Result<Self, SweepError> {
        if !(omega0_rad_s.is_finite() && omega0_rad_s > 0.0) {
            return Err(SweepError::BadOmega0(omega0_rad_s));
        }
        let rate = r * omega0_rad_s * omega0_rad_s / (2.0 * std::f64::consts::PI);
        Self::new(
            eta_start * omega0_rad_s,
            eta_end * omega0_rad_s,
            rate,
            amplitude,
        )
    }

    /// Accepts the sweep as a free-running source (fields set one by one, as
    /// the shaker FMU's parameters are): frequencies `>= 0` rad/s, rate
    /// `>= 0` rad/s^2 (`0`: a fixed sine at `omega_start_rad_s`), not NaN.
    pub fn check_source(&self) -> Result<(), SweepError> {
        for (which, value) in [
            (SweepEnd::Start, self.omega_start_rad_s),
            (SweepEnd::End, self.omega_end_rad_s),
        ] {
            if value.is_nan() || value < 0.0 {
                return Err(SweepError::NegativeSourceFrequency { which, value });
            }
        }
        if self.rate_rad_s2.is_nan() || self.rate_rad_s2 < 0.0 {
            return Err(SweepError::NegativeSourceRate(self.rate_rad_s2));
        }
        Ok(())
    }

    /// `+1` for a forward (up) sweep, `-1` for a backward one.
    pub fn direction(&self) -> f64 {
        if self.omega_end_rad_s > self.omega_start_rad_s {
            1.0
        } else {
            -1.0
        }
    }

    /// Whether `t` lies within the frequency ramp, `rate t <= |Omega_end -
    /// Omega_start|` (a product, not the duration's division: the slow flow
    /// asks at every stage); always true for a zero rate.
    #[inline]
    fn in_ramp(&self, t_s: f64) -> bool {
        self.rate_rad_s2 * t_s <= (self.omega_end_rad_s - self.omega_start_rad_s).abs()
    }

    /// Signed `dOmega/dt` [rad/s^2].
    pub fn signed_rate_rad_s2(&self) -> f64 {
        self.direction() * self.rate_rad_s2
    }

    /// Sweep duration [s].
    pub fn duration_s(&self) -> f64 {
        (self.omega_end_rad_s - self.omega_start_rad_s).abs() / self.rate_rad_s2
    }

    /// Instantaneous excitation frequency `Omega(t)` [rad/s]; held at
    /// `omega_end_rad_s` after the sweep, `omega_start_rad_s` for a zero rate.
    #[inline]
    pub fn omega_rad_s(&self, t_s: f64) -> f64 {
        self.ramp().at(t_s)
    }

    /// `Omega(t)` with the sweep's constants taken once ([`OmegaRamp`]).
    #[inline(always)]
    pub(crate) fn ramp(&self) -> OmegaRamp {
        OmegaRamp {
            start: self.omega_start_rad_s,
            end: self.omega_end_rad_s,
            rate: self.rate_rad_s2,
            span: (self.omega_end_rad_s - self.omega_start_rad_s).abs(),
            signed_rate: self.signed_rate_rad_s2(),
        }
    }

    /// `dOmega/dt` at `t` [rad/s^2]: the signed rate during the sweep, `0`
    /// after it (and for a zero rate).
    pub fn omega_rate_rad_s2(&self, t_s: f64) -> f64 {
        if self.rate_rad_s2 != 0.0 && t_s < self.duration_s() {
            self.signed_rate_rad_s2()
        } else {
            0.0
        }
    }

    /// Phase `Phi(t) = int_0^t Omega dt` [rad].
    pub fn phase_rad(&self, t_s: f64) -> f64 {
        let ramp = |t: f64| self.omega_start_rad_s * t + 0.5 * self.signed_rate_rad_s2() * t * t;
        if self.in_ramp(t_s) {
            ramp(t_s)
        } else {
            let te = self.duration_s();
            ramp(te) + self.omega_end_rad_s * (t_s - te)
        }
    }

    /// Excitation signal `u_hat cos(Phi(t))`.
    pub fn value(&self, t_s: f64) -> f64 {
        self.amplitude * self.phase_rad(t_s).cos()
    }

    /// `d/dt` of the excitation signal, `-u_hat sin(Phi(t)) Omega(t)`.
    pub fn value_rate(&self, t_s: f64) -> f64 {
        -self.amplitude * self.phase_rad(t_s).sin() * self.omega_rad_s(t_s)
    }

    /// Time [s] at which `Omega(t)` equals `omega_rad_s`.
    pub fn time_at_omega(&self, omega_rad_s: f64) -> f64 {
        (omega_rad_s - self.omega_start_rad_s) / self.signed_rate_rad_s2()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn paper_rate_definition() {
        let w0 = 356.2;
        let s = LinearSweep::per_pseudo_period(w0, 0.8, 1.8, 0.02, 10.0).unwrap();
        // one pseudo period 2 pi / w0 changes Omega by r w0
        let dt = 2.0 * PI / w0;
        assert!(((s.omega_rad_s(dt) - s.omega_rad_s(0.0)) - 0.02 * w0).abs() < 1e-9);
        assert!((s.duration_s() - (w0 / (0.02 * w0 * w0 / (2.0 * PI)))).abs() < 1e-12);
        assert!((s.omega_rad_s(s.duration_s()) - 1.8 * w0).abs() < 1e-9);
    }

    #[test]
    fn phase_is_integral_of_omega() {
        for s in [
            LinearSweep::new(100.0, 300.0, 50.0, 1.0).unwrap(),
            LinearSweep::new(300.0, 100.0, 50.0, 1.0).unwrap(),
        ] {
            let t = 1.7;
            let h = 1e-5;
            let dphi = (s.phase_rad(t + h) - s.phase_rad(t - h)) / (2.0 * h);
            assert!((dphi - s.omega_rad_s(t)).abs() < 1e-6, "{dphi}");
            assert_eq!(s.phase_rad(0.0), 0.0);
            assert!((s.time_at_omega(s.omega_rad_s(t)) - t).abs() < 1e-12);
        }
        let back = LinearSweep::new(300.0, 100.0, 50.0, 1.0).unwrap();
        assert_eq!(back.direction(), -1.0);
        assert!((back.omega_rad_s(back.duration_s()) - 100.0).abs() < 1e-9);
    }

    #[test]
    fn bad_inputs_are_rejected() {
        assert_eq!(
            LinearSweep::new(-1.0, 2.0, 1.0, 1.0),
            Err(SweepError::BadStart(-1.0))
        );
        assert_eq!(
            LinearSweep::new(1.0, 0.0, 1.0, 1.0),
            Err(SweepError::BadEnd(0.0))
        );
        assert_eq!(
            LinearSweep::new(1.0, 1.0, 1.0, 1.0),
            Err(SweepError::EmptyRange(1.0))
        );
        assert_eq!(
            LinearSweep::new(1.0, 2.0, 0.0, 1.0),
            Err(SweepError::BadRate(0.0))
        );
        assert!(LinearSweep::new(1.0, 2.0, f64::NAN, 1.0).is_err());
    }

    #[test]
    fn source_holds_the_end_frequency_and_allows_a_fixed_sine() {
        let s = LinearSweep::new(100.0, 300.0, 50.0, 2.0).unwrap();
        let te = s.duration_s();
        assert_eq!(s.omega_rad_s(te + 1.0), 300.0);
        assert_eq!(s.omega_rate_rad_s2(te + 1.0), 0.0);
        assert_eq!(s.omega_rate_rad_s2(0.5 * te), 50.0);
        assert!((s.phase_rad(te + 1.0) - s.phase_rad(te) - 300.0).abs() < 1e-9);
        let fixed = LinearSweep {
            rate_rad_s2: 0.0,
            ..s
        };
        assert_eq!(fixed.check_source(), Ok(()));
        assert_eq!(fixed.omega_rad_s(7.0), 100.0);
        assert_eq!(fixed.phase_rad(2.0), 200.0);
        let h = 1e-6;
        let du = (s.value(1.0 + h) - s.value(1.0 - h)) / (2.0 * h);
        assert!((du - s.value_rate(1.0)).abs() < 1e-4 * s.amplitude * 300.0);
        let bad = LinearSweep {
            omega_end_rad_s: -1.0,
            ..s
        };
        assert_eq!(
            bad.check_source(),
            Err(SweepError::NegativeSourceFrequency {
                which: SweepEnd::End,
                value: -1.0
            })
        );
        let bad_rate = LinearSweep {
            rate_rad_s2: f64::NAN,
            ..s
        };
        assert!(matches!(
            bad_rate.check_source(),
            Err(SweepError::NegativeSourceRate(_))
        ));
    }
}
