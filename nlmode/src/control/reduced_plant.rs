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
//!
//! # Attachment states ([`ReducedPlant::with_attachment_states`])
//!
//! With `[slowflow] attachments = "dynamic"` the attachments' slow internal
//! states `y` (poles near the band; [`crate::reduced::dynamic`]) are carried
//! beside `A`: over a period the pair `z = [A; y]` obeys the linear system
//! with constant coefficients (frozen at the period's amplitude, as `K`)
//!
//! ```text
//! A' = -i (phi^H f_ex(y) - K A) / (2 Omega),     y' = -P1 y - P2 U + p,   U = phi_G A,
//! ```
//!
//! (the force on the structure taking `F_G = -Q1 U - Q2 y + q`), i.e.
//! `z' = M z + b`, stepped exactly with the exponential of the augmented
//! matrix `[[M, b], [0, 0]] T`. `M` and `b` are read off the slow flow's own
//! right-hand side (affine in `z`: one evaluation at `z = 0` and one per
//! unit vector), so the plant and the `dynamic` sweep integrate the same
//! equations. A model whose attachments have no pole near the band carries
//! nothing and is the quasi-steady plant bit for bit.
use super::{ControlError, PeriodSamples, Plant};
use crate::reduced::dynamic::StatePort;
use crate::reduced::{ImposedForces, ReducedError, ReducedModel, MAX_PHI};
use nalgebra::DMatrix;
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
    /// The attachments' carried states (module docs), if any.
    carried: Option<Carried>,
    /// The attachments' work on the mode's harmonics in `K`
    /// ([`Self::with_harmonic_force_projection`]).
    harmonic_projection: bool,
}

/// The attachments whose slow states the plant carries, and the states.
#[derive(Debug, Clone)]
struct Carried {
    ports: Vec<StatePort>,
    /// Standard plus the ports' extra channels.
    nch_total: usize,
    /// The carried complex states, ports in order (zero from rest).
    y: Vec<Complex64>,
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
            carried: None,
            harmonic_projection: false,
        })
    }

    /// Carry the internal states of the attachments with a pole within
    /// `fast_pole_factor * omega_hi_rad_s` of the band `[omega_lo_rad_s,
    /// omega_hi_rad_s]` the test covers (`[slowflow] attachments =
    /// "dynamic"`; module docs). Refused, naming the attachment, for one
    /// given by its frequency response only or with a state without
    /// dynamics. Without such a pole the plant stays the quasi-steady one.
    pub fn with_attachment_states(
        mut self,
        omega_lo_rad_s: f64,
        omega_hi_rad_s: f64,
        fast_pole_factor: f64,
    ) -> Result<Self, ControlError> {
        let (lo, hi) = (omega_lo_rad_s, omega_hi_rad_s);
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) {
            return Err(ControlError::BadOption {
                name: "omega band",
                value: format!("[{lo}, {hi}] rad/s"),
                expected: "0 < omega_lo <= omega_hi, finite",
            });
        }
        if !(fast_pole_factor.is_finite() && fast_pole_factor > 0.0) {
            return Err(ControlError::BadOption {
                name: "fast_pole_factor",
                value: fast_pole_factor.to_string(),
                expected: "a positive number",
            });
        }
        let ports = StatePort::select(&self.model, lo, hi, fast_pole_factor).map_err(reduced)?;
        self.carried = if ports.is_empty() {
            None
        } else {
            let ns = ports.iter().map(|p| p.ns).sum();
            let nch_total = self.model.nch + ports.iter().map(StatePort::nextra).sum::<usize>();
            Some(Carried {
                ports,
                nch_total,
                y: vec![Complex64::new(0.0, 0.0); ns],
            })
        };
        self.channels = None;
        Ok(self)
    }

    /// With `on`, the attachments' forces act on every harmonic of the mode,
    /// not on its fundamental alone: `K` gets the harmonic impedance
    /// [`ReducedModel::harmonic_impedance`] at each period's amplitude (the
    /// averaged counterpart of the structure FMU's `harmonic_force_projection`;
    /// the power the shaker's third harmonic takes at phase resonance).
    /// `false` (the default) is `eq:NM`.
    pub fn with_harmonic_force_projection(mut self, on: bool) -> Self {
        self.harmonic_projection = on;
        self
    }

    /// `z_h` at the amplitude `a` if the projection is on, else 0.
    fn harmonic_term(&self, a: f64, omega: f64) -> Result<Complex64, ControlError> {
        if !self.harmonic_projection {
            return Ok(Complex64::new(0.0, 0.0));
        }
        self.model.harmonic_impedance(a, omega).map_err(reduced)
    }

    /// Number of attachment states carried (0: the quasi-steady plant).
    pub fn carried_states(&self) -> usize {
        self.carried.as_ref().map_or(0, |c| c.y.len())
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
        let n = self.carried.as_ref().map_or(m.nch, |c| c.nch_total);
        let mut ch = match self.channels.take() {
            Some((_, ch, _)) => ch,
            None => vec![Complex64::new(0.0, 0.0); n],
        };
        m.fill_channels(omega, u, &mut ch[..m.nch])
            .map_err(reduced)?;
        for p in self.carried.iter().flat_map(|c| &c.ports) {
            p.fill(m, omega, u, &mut ch).map_err(reduced)?;
        }
        let fi = m.imposed_at(omega).map_err(reduced)?;
        self.channels = Some((key, ch, fi));
        Ok(())
    }

    /// `A` after one period from `a0` with `K` (plus the harmonic term `zh`)
    /// and the modal force of `eq:NM` frozen at the amplitude `a` (channels
    /// `ch`, imposed force `fi` at `omega`).
    fn frozen_step(
        model: &ReducedModel,
        (ch, fi): (&[Complex64], ImposedForces),
        a0: Complex64,
        (a, zh): (f64, Complex64),
        omega: f64,
    ) -> Result<Complex64, ControlError> {
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        let p = model.gather(a, &mut phi).map_err(reduced)?;
        let (k, fm, _) = model.terms_with(&p, &phi, omega, ch, &fi);
        let k = k + zh;
        let t = 2.0 * std::f64::consts::PI / omega;
        if k.norm() == 0.0 {
            // undamped and tuned: A grows linearly, A' = -i fm / (2 Omega)
            return Ok(a0 + Complex64::new(0.0, -t / (2.0 * omega)) * fm);
        }
        let decay = (Complex64::new(0.0, 1.0) * k * (t / (2.0 * omega))).exp();
        let a_s = fm / k;
        Ok(a_s + (a0 - a_s) * decay)
    }

    /// `[A; y]` after one period from `(a0, y0)` with the linear system of
    /// the module docs frozen at the amplitude `a`: `M`, `b` read off the
    /// slow-flow right-hand side, stepped with the exponential of the
    /// augmented matrix.
    fn frozen_step_carried(
        model: &ReducedModel,
        carried: &Carried,
        (ch, fi): (&[Complex64], ImposedForces),
        (a0, y0): (Complex64, &[Complex64]),
        (a, zh): (f64, Complex64),
        omega: f64,
    ) -> Result<(Complex64, Vec<Complex64>), ControlError> {
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        let props = model.gather(a, &mut phi).map_err(reduced)?;
        let ns = y0.len();
        let n = 1 + ns;
        let zero = Complex64::new(0.0, 0.0);
        let mut work = ch.to_vec();
        let mut dy = vec![zero; ns];
        // the right-hand side [A'; y'] at (amp, y): affine in both
        let mut rhs = |amp: Complex64, y: &[Complex64], out: &mut [Complex64]| {
            work.copy_from_slice(ch);
            for p in &carried.ports {
                let r = p.state_offset..p.state_offset + p.ns;
                p.apply(model, &mut work, &phi, amp, &y[r.clone()], Some(&mut dy[r]));
            }
            let (k, fm, _) = model.terms_with(&props, &phi, omega, &work[..model.nch], &fi);
            out[0] = Complex64::new(0.0, -0.5 / omega) * (fm - (k + zh) * amp);
            out[1..].copy_from_slice(&dy);
        };
        let t = 2.0 * std::f64::consts::PI / omega;
        // augmented [[M, b], [0, 0]] T
        let mut e = DMatrix::<Complex64>::zeros(n + 1, n + 1);
        let mut col = vec![zero; n];
        let mut unit = vec![zero; ns];
        rhs(zero, &unit, &mut col);
        let b = col.clone();
        for (i, bi) in b.iter().enumerate() {
            e[(i, n)] = bi * t;
        }
        rhs(Complex64::new(1.0, 0.0), &unit, &mut col);
        for i in 0..n {
            e[(i, 0)] = (col[i] - b[i]) * t;
        }
        for j in 0..ns {
            unit[j] = Complex64::new(1.0, 0.0);
            rhs(zero, &unit, &mut col);
            unit[j] = zero;
            for i in 0..n {
                e[(i, 1 + j)] = (col[i] - b[i]) * t;
            }
        }
        let x = e.exp();
        let mut z = vec![zero; n];
        for (i, zi) in z.iter_mut().enumerate() {
            *zi = x[(i, n)] + x[(i, 0)] * a0;
            for j in 0..ns {
                *zi += x[(i, 1 + j)] * y0[j];
            }
        }
        Ok((z[0], z[1..].to_vec()))
    }

    /// The channels with each carried port's force channel including its
    /// states (`q - Q2 y`), for [`Self::fundamentals`].
    fn channels_with_states(
        model: &ReducedModel,
        carried: &Carried,
        ch: &[Complex64],
        amp: Complex64,
    ) -> Result<Vec<Complex64>, ControlError> {
        let mut phi = [Complex64::new(0.0, 0.0); MAX_PHI];
        model.gather(amp.norm(), &mut phi).map_err(reduced)?;
        let mut out = ch.to_vec();
        for p in &carried.ports {
            let r = p.state_offset..p.state_offset + p.ns;
            p.apply(model, &mut out, &phi, amp, &carried.y[r], None);
        }
        Ok(out)
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
        let at = |a: f64| -> Result<(f64, Complex64), ControlError> {
            Ok((a, self.harmonic_term(a, omega)?))
        };
        let (next, states) = match &self.carried {
            None => {
                let pred = Self::frozen_step(m, c, a0, at(a0.norm())?, omega)?;
                let mid = at((0.5 * (a0 + pred)).norm())?;
                let next = Self::frozen_step(m, c, a0, mid, omega)?;
                (next, None)
            }
            Some(cs) => {
                let z0 = (a0, cs.y.as_slice());
                let (pred, _) = Self::frozen_step_carried(m, cs, c, z0, at(a0.norm())?, omega)?;
                let mid = at((0.5 * (a0 + pred)).norm())?;
                let (next, y) = Self::frozen_step_carried(m, cs, c, z0, mid, omega)?;
                (next, Some(y))
            }
        };
        let finite = |z: &Complex64| z.re.is_finite() && z.im.is_finite();
        if !finite(&next) || !states.iter().flatten().all(finite) {
            return Err(ControlError::Reduced(format!(
                "the modal amplitude or an attachment state is not finite after the period at t = {} s",
                self.time_s
            )));
        }
        let (drive, tip, force) = match (&mut self.carried, states) {
            (Some(cs), Some(y)) => {
                cs.y = y;
                let with = Self::channels_with_states(m, cs, c.0, next)?;
                Self::fundamentals(m, (&with, c.1), next)?
            }
            _ => Self::fundamentals(m, c, next)?,
        };
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
