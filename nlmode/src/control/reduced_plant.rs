//! The plant of the controlled tests on the single-nonlinear-mode model
//! (`eq:NM` with the attachments' `Z_A` and the imposed modal force, the slow
//! flow of [`crate::reduced`]): the complex modal amplitude `A = a e^{i theta}`
//! is advanced one excitation period at a time at the period's `Omega` and
//! voltage amplitude `U`,
//!
//! ```text
//! 2 i Omega A' + K(a, Omega) A = phi(a)^H f_ex(Omega, U),
//! K(a, Omega) = omega(a)^2 - Omega^2 + 2 i D(a) omega(a) Omega + Z_A(a, Omega),
//! ```
//!
//! with `K` and the modal force frozen over the period (a linear equation with
//! constant coefficients, solved exactly: `A(T) = A_s + (A(0) - A_s)
//! e^{i K T / (2 Omega)}`, `A_s = phi^H f_ex / K`) and re-evaluated at the
//! amplitude of the period's midpoint (one corrector pass). A settled state is
//! the exact steady state of `eq:NM` (`a |K| = |phi^H f_ex|`).
//!
//! # What the averaging implies for the loop
//!
//! - The plant carries only the fundamental: the samples of a period are
//!   `Re(X_1 e^{i theta_i})` of the drive point `X_1 = phi_d,1(a) A`, the tip
//!   and the force at the drive point `F_1` (`eq:fc1`). The phase detector
//!   reads the slow-flow phase `arg F_1 - arg X_1`; no higher harmonics reach
//!   it, so the harmonic ratios of the record are zero.
//! - With the fundamental only, the power balance `P = 1/2 Re(F_1 conj(i Omega
//!   X_1)) = D(a) omega(a) Omega^2 a^2` and the loop's 90-degree point is
//!   `Omega = omega(a)`: the measured backbone is the table's backbone and the
//!   power-balance damping with the drive-point modal mass `m_d` is the
//!   table's `D(a) / (m_d |phi_d,1(a)|^2)`: exactly `D(a)` with `m_d =
//!   1/|phi_d,1(a)|^2`, and `D(a) |phi_d(0)|^2 / |phi_d,1(a)|^2` with the linear
//!   modal mass, whatever the single-point appropriation would add in the
//!   full-order plant (no higher harmonics do work).
//! - The slow flow has no transients faster than its envelope (no stinger or
//!   shaker resonances): a gain that is stable here may still not be on the
//!   reference.
//! - The coil current is not a state of the reduced model: it is not sampled
//!   (reported as 0).
use super::{ControlError, PeriodSamples, Plant};
use crate::reduced::{ReducedError, ReducedModel};
use num_complex::Complex64;

/// The single-nonlinear-mode model as a [`Plant`], from rest (`A = 0`).
#[derive(Debug, Clone)]
pub struct ReducedPlant {
    model: ReducedModel,
    samples_per_period: usize,
    amp: Complex64,
    time_s: f64,
    voltage_v: f64,
    omega_rad_s: f64,
    periods: usize,
    samples: PeriodSamples,
}

/// Errors of the reduced model inside the controlled tests.
fn reduced(source: ReducedError) -> ControlError {
    ControlError::Reduced(source.to_string())
}

impl ReducedPlant {
    /// `model` (with its attachments; the sweep amplitude is the voltage)
    /// sampled `samples_per_period` times per period (`>= 4`).
    pub fn new(model: ReducedModel, samples_per_period: usize) -> Result<Self, ControlError> {
        if samples_per_period < 4 {
            return Err(ControlError::BadOption {
                name: "samples_per_period",
                value: samples_per_period.to_string(),
                expected: "an integer >= 4",
            });
        }
        Ok(Self {
            model,
            samples_per_period,
            amp: Complex64::new(0.0, 0.0),
            time_s: 0.0,
            voltage_v: 0.0,
            omega_rad_s: 0.0,
            periods: 0,
            samples: PeriodSamples::default(),
        })
    }

    /// The complex modal amplitude `A = a e^{i theta}` now.
    pub fn modal_amplitude(&self) -> Complex64 {
        self.amp
    }

    /// Periods advanced so far.
    pub fn periods(&self) -> usize {
        self.periods
    }

    /// The model.
    pub fn model(&self) -> &ReducedModel {
        &self.model
    }

    /// `A` after one period from `a0` with `K` and the modal force frozen at
    /// the amplitude `a`.
    fn frozen_step(
        &self,
        a0: Complex64,
        a: f64,
        omega: f64,
        u: f64,
    ) -> Result<Complex64, ControlError> {
        let (za, fm) = self
            .model
            .modal_impedance_and_force(a, omega, u)
            .map_err(reduced)?;
        let p = self.model.modal_properties(a).map_err(reduced)?;
        let w = p.omega_rad_s;
        let k = Complex64::new(w * w - omega * omega, 2.0 * p.damping_ratio * w * omega) + za;
        let t = 2.0 * std::f64::consts::PI / omega;
        let decay = (Complex64::new(0.0, 1.0) * k * (t / (2.0 * omega))).exp();
        if k.norm() == 0.0 {
            // undamped and tuned: A grows linearly, A' = -i fm / (2 Omega)
            return Ok(a0 + Complex64::new(0.0, -t / (2.0 * omega)) * fm);
        }
        let a_s = fm / k;
        Ok(a_s + (a0 - a_s) * decay)
    }
}

impl Plant for ReducedPlant {
    fn set_excitation(&mut self, voltage_v: f64, omega_rad_s: f64) {
        self.voltage_v = voltage_v;
        self.omega_rad_s = omega_rad_s;
    }

    fn advance_period(&mut self) -> Result<&PeriodSamples, ControlError> {
        let (omega, u) = (self.omega_rad_s, self.voltage_v);
        if !(omega.is_finite() && omega > 0.0) {
            return Err(ControlError::BadOption {
                name: "omega_rad_s",
                value: omega.to_string(),
                expected: "a positive excitation frequency",
            });
        }
        let a0 = self.amp;
        let pred = self.frozen_step(a0, a0.norm(), omega, u)?;
        let next = self.frozen_step(a0, (0.5 * (a0 + pred)).norm(), omega, u)?;
        if !(next.re.is_finite() && next.im.is_finite()) {
            return Err(ControlError::Reduced(format!(
                "the modal amplitude is not finite after the period at t = {} s",
                self.time_s
            )));
        }
        self.amp = next;
        let m = &self.model;
        let drive = m
            .displacement_harmonics(m.drive_name(), next)
            .map_err(reduced)?[1];
        let tip = m
            .displacement_harmonics(m.tip_name(), next)
            .map_err(reduced)?[1];
        let force = m.force_harmonics(omega, u, next).map_err(reduced)?[1];
        let n = self.samples_per_period;
        let s = &mut self.samples;
        s.omega_rad_s = omega;
        s.voltage_v = u;
        s.current_a.clear();
        for (v, x) in [
            (&mut s.force_n, force),
            (&mut s.drive_m, drive),
            (&mut s.tip_m, tip),
        ] {
            v.clear();
            v.extend((0..n).map(|i| {
                let th = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                (x * Complex64::from_polar(1.0, th)).re
            }));
        }
        self.time_s += 2.0 * std::f64::consts::PI / omega;
        self.periods += 1;
        Ok(&self.samples)
    }

    fn time_s(&self) -> f64 {
        self.time_s
    }
}
