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
use crate::reduced::{ImposedForces, ReducedError, ReducedModel, MAX_PHI};
use num_complex::Complex64;

/// The single-nonlinear-mode model as a [`Plant`], from rest (`A = 0`).
///
/// The attachments' channels of `eq:fc1` (`Z_G(Omega)`, `T_G(Omega) u_hat`)
/// are evaluated once per period (both slow-flow passes and the measured
/// force take them at the period's `Omega`), the sampling phasors
/// `e^{i theta_i}` once per plant: a period costs three table look-ups and
/// one condensation of each attachment, in buffers kept across periods.
#[derive(Debug, Clone)]
pub struct ReducedPlant {
    model: ReducedModel,
    amp: Complex64,
    time_s: f64,
    voltage_v: f64,
    omega_rad_s: f64,
    periods: usize,
    samples: PeriodSamples,
    /// `e^{i 2 pi i / N}`, `i = 0..N-1`.
    phasors: Vec<Complex64>,
    /// Channels at `(Omega, U)` of the key (`f64` bits), and the imposed force there.
    channels: Option<((u64, u64), Vec<Complex64>, ImposedForces)>,
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
        let n = samples_per_period;
        let phasors = (0..n)
            .map(|i| Complex64::from_polar(1.0, 2.0 * std::f64::consts::PI * i as f64 / n as f64))
            .collect();
        Ok(Self {
            model,
            amp: Complex64::new(0.0, 0.0),
            time_s: 0.0,
            voltage_v: 0.0,
            omega_rad_s: 0.0,
            periods: 0,
            samples: PeriodSamples {
                force_n: Vec::with_capacity(n),
                drive_m: Vec::with_capacity(n),
                tip_m: Vec::with_capacity(n),
                ..Default::default()
            },
            phasors,
            channels: None,
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

    /// The channels and the imposed force at `(omega, u)`, evaluated when the
    /// key changes.
    fn channels_at(&mut self, omega: f64, u: f64) -> Result<(), ControlError> {
        let key = (omega.to_bits(), u.to_bits());
        if self.channels.as_ref().is_some_and(|(k, _, _)| *k == key) {
            return Ok(());
        }
        let m = &self.model;
        let mut ch = match self.channels.take() {
            Some((_, ch, _)) => ch,
            None => vec![Complex64::new(0.0, 0.0); m.nch],
        };
        m.fill_channels(omega, u, &mut ch).map_err(reduced)?;
        let fi = m.imposed_at(omega).map_err(reduced)?;
        self.channels = Some((key, ch, fi));
        Ok(())
    }

    /// `A` after one period from `a0` with `K` and the modal force of
    /// `eq:NM` frozen at the amplitude `a` (channels `ch`, imposed force `fi`
    /// at `omega`).
    fn frozen_step(
        model: &ReducedModel,
        (ch, fi): (&[Complex64], ImposedForces),
        a0: Complex64,
        a: f64,
        omega: f64,
    ) -> Result<Complex64, ControlError> {
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        let p = model.gather(a, &mut phi).map_err(reduced)?;
        let (k, fm, _) = model.terms_with(&p, &phi, omega, ch, fi);
        let t = 2.0 * std::f64::consts::PI / omega;
        if k.norm() == 0.0 {
            // undamped and tuned: A grows linearly, A' = -i fm / (2 Omega)
            return Ok(a0 + Complex64::new(0.0, -t / (2.0 * omega)) * fm);
        }
        let decay = (Complex64::new(0.0, 1.0) * k * (t / (2.0 * omega))).exp();
        let a_s = fm / k;
        Ok(a_s + (a0 - a_s) * decay)
    }

    /// Fundamentals `(drive, tip, force at the drive point)` for the modal
    /// amplitude `amp`: `phi_1(a) A` at the points (`eq:ansatz`) and the
    /// interface forces `F_G = -Z_G u_G + T_G u_hat` of `eq:fc1` acting at
    /// the drive point plus the imposed force there (the fundamental of
    /// [`ReducedModel::force_harmonics`], from the channels of the period).
    fn fundamentals(
        model: &ReducedModel,
        (ch, fi): (&[Complex64], ImposedForces),
        amp: Complex64,
    ) -> Result<(Complex64, Complex64, Complex64), ControlError> {
        let loc = model
            .fast
            .locate(amp.norm())
            .map_err(|e| reduced(e.into()))?;
        let drive = model.phi1(loc, model.drive) * amp;
        let tip = model.phi1(loc, model.tip) * amp;
        let mut force = Complex64::new(0.0, 0.0);
        for port in &model.ports {
            let nc = port.points.len();
            let o = port.offset;
            for (r, &pr) in port.points.iter().enumerate() {
                if pr != model.drive {
                    continue;
                }
                force += ch[o + nc * nc + r];
                for (c, &pc) in port.points.iter().enumerate() {
                    force -= ch[o + r * nc + c] * model.phi1(loc, pc) * amp;
                }
            }
        }
        force += model.drive_imposed(&fi);
        Ok((drive, tip, force))
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
        self.channels_at(omega, u)?;
        let Some((_, ch, fi)) = &self.channels else {
            unreachable!("channels_at fills the cache")
        };
        let c = (ch.as_slice(), *fi);
        let m = &self.model;
        let a0 = self.amp;
        let pred = Self::frozen_step(m, c, a0, a0.norm(), omega)?;
        let next = Self::frozen_step(m, c, a0, (0.5 * (a0 + pred)).norm(), omega)?;
        if !(next.re.is_finite() && next.im.is_finite()) {
            return Err(ControlError::Reduced(format!(
                "the modal amplitude is not finite after the period at t = {} s",
                self.time_s
            )));
        }
        let (drive, tip, force) = Self::fundamentals(m, c, next)?;
        self.amp = next;
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
            v.extend(self.phasors.iter().map(|w| (x * w).re));
        }
        self.time_s += 2.0 * std::f64::consts::PI / omega;
        self.periods += 1;
        Ok(&self.samples)
    }

    fn time_s(&self) -> f64 {
        self.time_s
    }
}
