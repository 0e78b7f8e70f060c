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

    /// `+1` for a forward (up) sweep, `-1` for a backward one.
    pub fn direction(&self) -> f64 {
        if self.omega_end_rad_s > self.omega_start_rad_s {
            1.0
        } else {
            -1.0
        }
    }

    /// Signed `dOmega/dt` [rad/s^2].
    pub fn signed_rate_rad_s2(&self) -> f64 {
        self.direction() * self.rate_rad_s2
    }

    /// Sweep duration [s].
    pub fn duration_s(&self) -> f64 {
        (self.omega_end_rad_s - self.omega_start_rad_s).abs() / self.rate_rad_s2
    }

    /// Instantaneous excitation frequency `Omega(t)` [rad/s].
    pub fn omega_rad_s(&self, t_s: f64) -> f64 {
        self.omega_start_rad_s + self.signed_rate_rad_s2() * t_s
    }

    /// Phase `Phi(t) = int_0^t Omega dt` [rad].
    pub fn phase_rad(&self, t_s: f64) -> f64 {
        self.omega_start_rad_s * t_s + 0.5 * self.signed_rate_rad_s2() * t_s * t_s
    }

    /// Excitation signal `u_hat cos(Phi(t))`.
    pub fn value(&self, t_s: f64) -> f64 {
        self.amplitude * self.phase_rad(t_s).cos()
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
}
