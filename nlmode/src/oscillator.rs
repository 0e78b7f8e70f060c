//! The time-domain nonlinear-mode oscillator (DESIGN.md section 4): the
//! structure as a single nonlinear modal oscillator driven by a force at one
//! physical point, written so that a co-simulation unit can integrate it
//! without knowing the excitation frequency.
//!
//! # Equations
//!
//! The slow flow `eq:NMpre` needs the excitation frequency `Omega`. Its
//! time-domain counterpart is the modal oscillator
//!
//! ```text
//! eta'' + 2 D(a) omega(a) eta' + omega(a)^2 eta = p(t),
//! z = eta - i eta'/omega(a) = a e^{i psi},   a = |z|   (so eta = a cos psi),
//! ```
//!
//! integrated in its amplitude-phase normal form with the state `(eta, u)`,
//! `u = eta'/omega(a)`, `z = eta - i u`:
//!
//! ```text
//! eta' = omega(a) u
//! u'   = -omega(a) eta - 2 D(a) omega(a) u + p(t)/omega(a),    a = sqrt(eta^2 + u^2).
//! ```
//!
//! For constant `omega`, `D` this is exactly `eta'' + 2 D omega eta' + omega^2 eta = p`
//! (the linear single-mode model, for any input). With amplitude-dependent `omega(a)`
//! it differs from the literal second-order form above by the term
//! `(omega'(a) a'/omega) eta'` on the right-hand side, which is of the order of the
//! slow modulation that averaging neglects, and it is chosen on purpose:
//! * the free undamped motion is an exact circle `z = a e^{i omega(a) t}`, so the
//!   backbone `omega(a)` of the table is reproduced without averaging error;
//! * first-order averaging (`psi = Omega t + theta`, `p = Re(p_hat e^{i Omega t})`) gives
//!   `a' = -D omega a - Im(p_hat e^{-i theta})/(2 omega)`,
//!   `a theta' = (omega - Omega) a - Re(p_hat e^{-i theta})/(2 omega)`,
//!   which is `eq:NMpre` with `2 Omega -> 2 omega` and `omega^2 - Omega^2 -> 2 omega (omega - Omega)`
//!   (equal to first order in the detuning, the order of the averaging itself).
//!   The literal form, with `a` defined implicitly by `a^2 = eta^2 + eta'^2/omega(a)^2`,
//!   instead gives `a' (1 + a omega'(a)/omega sin^2 psi) = ...`: the averaged decay rate
//!   and forcing are scaled by `2 <sin^2 psi/(1 + kappa sin^2 psi)>`, `kappa = a omega'/omega`,
//!   about 0.67 at the paper's highest amplitudes (kappa ~ 0.7): a 33 % error in the
//!   transient damping. See the tests `free_decay_follows_the_slow_flow` and
//!   `literal_second_order_form_misses_the_slow_flow_decay` (after 1 s of free decay from
//!   kappa = 0.87: normal form 0.583, slow flow 0.582, literal form 0.760).
//!
//! Beyond first order: under forcing at `Omega != omega(a)` the steady orbit of
//! `z` is an ellipse (`|z|` ripples between `A Omega/omega` and `A`), so
//! `omega(|z|)` is sampled over the ripple. The settled fundamental amplitude
//! then differs from the `eq:NM` steady state by roughly 0.3-0.4 times the
//! relative detuning `|omega(a) - Omega|/omega` for a strongly hardening mode
//! (measured 0.8 % at 1.9 % detuning and 1.0-1.2 % at 3-4 % detuning,
//! `omega^2 - omega0^2` about 10-20 % of `omega0^2`), and not at all at
//! resonance or in the linear limit, where the oscillator is exact.
//!
//! # Modal force and the phase of a complex mode shape
//!
//! The drive point `ex` receives the force `c(t)` [N] (positive along positive
//! displacement). Projected onto the fundamental harmonic of the mode
//! (`eq:NMpre`), its modal force has the Fourier coefficient `conj(phi_ex(a)) c_hat`.
//! A complex `phi_ex = |phi_ex| e^{i beta}` would need the Hilbert transform of
//! `c(t)`, which a time-domain unit cannot form without knowing `Omega`. The phase
//! of a nonlinear mode is a gauge (the ansatz `eq:ansatz` is invariant under
//! `psi -> psi + beta`, `phi_n -> phi_n e^{-i n beta}`), so the oscillator works in
//! the gauge in which the drive point's fundamental is real and positive:
//! `phi'_n,k = phi_n,k g^{-n}`, `g(a) = phi_ex(a)/|phi_ex(a)|`. Then the modal force
//! is exactly `p(t) = |phi_ex(a)| c(t)` and every point keeps its phase relative to
//! the drive point: the drive-point and tip responses are those of `eq:NM` with
//! imposed force, including the phase of `phi_ex`. (For an amplitude-dependent
//! `beta(a)` the gauge adds a term `-2 Omega a beta'(a) a'` to `eq:NMpre`, of the
//! same order as the `phi'(a) a'` terms that `eq:NMpre` already neglects.) In the
//! linear limit with a real mode shape this is `p = phi_ex c(t)` up to the sign of
//! the modal coordinate, which does not appear in any physical output.
//!
//! # Outputs
//!
//! A point `k` moves as `eq:ansatz`,
//! `q_k = Re( a sum_{n=0}^{H} phi_{n,k}(a) w^n )` with `w = e^{i psi}/g(a)`, and
//! its velocity is the derivative along the mode's own periodic motion
//! (`a' = 0`, `psi' = omega(a)`), `q_k' = Re( a sum_n i n omega(a) phi_{n,k}(a) w^n )`.
//! In the linear limit with a real shape both are exact (`x = phi eta`,
//! `v = phi eta'`). Taking the velocity along the free motion keeps it free of
//! direct feedthrough from the force (the exact derivative of the nonlinear
//! synthesis contains `a'` and `psi'`, hence `c(t)`), so that a shaker whose
//! force depends directly on `x` does not form an algebraic loop.
//!
//! # Integration
//!
//! Classical RK4 with the step split into `ceil(dt / h_max)` equal sub-steps,
//! `h_max = T_min / 40`, `T_min = 2 pi / max_a omega(a)` (with the frequency
//! error factor applied). For the harmonic oscillator RK4 has the per-step
//! amplification `|R(i w h)| = 1 - (w h)^6/144 + O(h^8)` and phase error
//! `(w h)^5/120`; at `w h <= 2 pi/40 = 0.157` that is at most a relative amplitude
//! loss of 8.5e-6 and a phase error of 3.2e-5 rad per period (an artificial
//! damping ratio below 1.4e-6 and a relative frequency error below 5.1e-6).
//! The input over a step is the polynomial `c(t0 + s) = c0 + c1 s + c2 s^2/2`
//! (linear interpolation between two samples, or the value and the input
//! derivatives an FMI master provides), which RK4 samples exactly at its stages.
use crate::nma::ModalTable;
use crate::table::{TableError, TableInterpolator, TableLocation};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::sync::Arc;

/// RK4 sub-steps per period of the highest modal frequency.
pub const STEPS_PER_PERIOD: f64 = 40.0;

/// Errors of the time-domain oscillator; each names the offending value.
#[derive(Debug, thiserror::Error)]
pub enum OscillatorError {
    #[error(transparent)]
    Table(#[from] TableError),
    /// `step_s`: the communication step in which the amplitude left the table
    /// (`None` for a state set directly).
    #[error("modal amplitude a = {a:.6e} sqrt(kg) m at t = {time_s:.9} s lies above the modal table's range (max {max:.6e}){}", above_range_hint(*step_s))]
    AboveRange {
        a: f64,
        max: f64,
        time_s: f64,
        step_s: Option<f64>,
    },
    #[error("communication step {step_s:e} s needs {substeps:e} RK4 sub-steps of at most {substep_s:e} s ({STEPS_PER_PERIOD} per period of the highest modal frequency), more than the cap of {cap} per step: use a smaller communication step")]
    TooManySubsteps {
        step_s: f64,
        substep_s: f64,
        substeps: f64,
        cap: u64,
    },
    #[error("communication step {0} s: must be finite and non-negative")]
    BadStep(f64),
    #[error("input force coefficient {name} = {value}: must be finite")]
    BadInput { name: &'static str, value: f64 },
    #[error("frequency error eps = {0}: the factor 1 + eps must be finite and positive, and (1 + eps) omega(a) finite")]
    BadFrequencyError(f64),
    #[error("oscillator state {field} = {value}: must be finite")]
    BadState { field: &'static str, value: f64 },
    #[error("{0}")]
    ResidualModes(String),
}

/// The end of the [`OscillatorError::AboveRange`] message: the likely causes.
fn above_range_hint(step_s: Option<f64>) -> String {
    match step_s {
        None => "; the response left the computed nonlinear mode (extend the modal analysis or lower the excitation)".into(),
        Some(h) => format!(
            " after a communication step of {h:e} s: either the response left the computed nonlinear mode \
             (extend the modal analysis or lower the excitation), or the macro step is too large for an \
             explicitly coupled stiff attachment (the paper's shaker stinger, k_s = 2.6e7 N/m, is stable \
             up to about 2e-5 s): use a smaller macro step (1e-5 s) or an iterative master"
        ),
    }
}

/// Most RK4 sub-steps one [`ModalOscillator::step`] takes (a bound on the work
/// of one `fmi2DoStep`: about 0.5 s at 0.5 us per sub-step); a longer step is
/// [`OscillatorError::TooManySubsteps`]. The paper's table (highest
/// `omega` about 400 rad/s, sub-step 3.9e-4 s) allows steps up to about 390 s.
pub const MAX_SUBSTEPS_PER_STEP: u64 = 1_000_000;

/// The gauge `g = phi_ex/|phi_ex|` of the module docs (1 where `phi_ex = 0`).
#[inline]
fn gauge(phi_ex: Complex64) -> Complex64 {
    if phi_ex.norm() > 0.0 {
        phi_ex / phi_ex.norm()
    } else {
        Complex64::new(1.0, 0.0)
    }
}

/// Harmonics `phi_0..phi_H` held on the stack (the paper uses `H <= 13`).
const HARMONICS_ON_STACK: usize = 32;

/// A buffer of `nh` harmonics: `stack` when it is long enough, else `heap`.
#[inline]
fn harmonic_buffer<'a>(
    nh: usize,
    stack: &'a mut [Complex64; HARMONICS_ON_STACK],
    heap: &'a mut Vec<Complex64>,
) -> &'a mut [Complex64] {
    if nh <= stack.len() {
        &mut stack[..nh]
    } else {
        heap.resize(nh, Complex64::new(0.0, 0.0));
        heap
    }
}

/// The integration state: modal coordinate `eta` [sqrt(kg) m], `u = eta'/omega(a)`
/// [sqrt(kg) m] and time [s]. `z = eta - i u = a e^{i psi}`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct OscillatorState {
    pub time_s: f64,
    pub eta: f64,
    pub u: f64,
}

impl OscillatorState {
    /// Complex modal coordinate `z = eta - i u = a e^{i psi}`.
    pub fn z(&self) -> Complex64 {
        Complex64::new(self.eta, -self.u)
    }
    /// Modal amplitude `a = |z|` [sqrt(kg) m].
    pub fn amplitude(&self) -> f64 {
        self.eta.hypot(self.u)
    }
}

/// Input force over one step: `c(t0 + s) = c0 + c1 s + c2 s^2 / 2` [N, N/s, N/s^2].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct InputPolynomial {
    pub c0: f64,
    pub c1: f64,
    pub c2: f64,
}

impl InputPolynomial {
    /// Constant force (zero-order hold).
    pub fn constant(c0: f64) -> Self {
        Self {
            c0,
            c1: 0.0,
            c2: 0.0,
        }
    }
    /// Linear interpolation from `c_start` at `t0` to `c_end` at `t0 + dt`.
    pub fn linear(c_start: f64, c_end: f64, dt_s: f64) -> Self {
        let c1 = if dt_s > 0.0 {
            (c_end - c_start) / dt_s
        } else {
            0.0
        };
        Self {
            c0: c_start,
            c1,
            c2: 0.0,
        }
    }
    #[inline]
    fn at(&self, s: f64) -> f64 {
        self.c0 + s * (self.c1 + 0.5 * s * self.c2)
    }
    fn check(&self) -> Result<(), OscillatorError> {
        for (name, value) in [("c0", self.c0), ("c1", self.c1), ("c2", self.c2)] {
            if !value.is_finite() {
                return Err(OscillatorError::BadInput { name, value });
            }
        }
        Ok(())
    }
}

/// How [`ModalOscillator::step_to_table_end`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepEnd {
    /// The whole step was taken.
    Completed,
    /// The amplitude would have left the modal table (above its last
    /// amplitude `a_max`, where the mode is not known) in the RK4 sub-step
    /// after `elapsed_s` [s] from the step's start; the state is left at
    /// that time, `time_s` [s], the end of the last sub-step inside the table.
    TableEnd {
        elapsed_s: f64,
        time_s: f64,
        /// The amplitude above the table that stopped the step [sqrt(kg) m].
        a: f64,
        /// The table's last amplitude [sqrt(kg) m].
        a_max: f64,
    },
}

/// Modal quantities at the current state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalSnapshot {
    /// `a` [sqrt(kg) m].
    pub amplitude: f64,
    /// `(1 + eps) omega(a)` [rad/s].
    pub omega_rad_s: f64,
    /// `D(a)` [-].
    pub damping_ratio: f64,
    /// `eta' = omega u` [sqrt(kg) m/s].
    pub eta_dot: f64,
}

/// Displacement and velocity of one physical point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointResponse {
    pub x_m: f64,
    pub v_m_s: f64,
}

/// The time-domain nonlinear-mode oscillator driven at one point of the table.
#[derive(Debug, Clone)]
pub struct ModalOscillator {
    /// shared: clones (FMU states, rollback) do not copy the table
    interp: Arc<TableInterpolator>,
    drive: usize,
    frequency_factor: f64,
    h_max_s: f64,
    a_max: f64,
    state: OscillatorState,
    /// Residual modes ([`Self::with_residual_modes`]; module `residual`).
    residual: Option<residual::Residual>,
    /// Their state `[q_1, q_1', q_2, q_2', ...]` \[m / (sqrt(kg) m) * sqrt(kg) m, /s\].
    residual_state: Vec<f64>,
    /// The modal force on every harmonic of the mode
    /// ([`Self::with_harmonic_force_projection`]; module `projection`).
    harmonic_projection: bool,
}

mod derivatives;
mod projection;
mod residual;

impl ModalOscillator {
    /// Oscillator for `table`, driven at the named point, with modal frequency
    /// `(1 + frequency_error) omega(a)` (the paper's frequency-error study), at rest at `t = 0`.
    pub fn new(
        table: &ModalTable,
        drive_point: &str,
        frequency_error: f64,
    ) -> Result<Self, OscillatorError> {
        let interp = table.interpolator()?;
        let drive = interp.point_index(drive_point)?;
        let factor = 1.0 + frequency_error;
        if !(factor.is_finite() && factor > 0.0) {
            return Err(OscillatorError::BadFrequencyError(frequency_error));
        }
        // PCHIP stays within the data range on every interval, so the node maximum bounds omega(a).
        let omega_max = factor * table.omega_rad_s.iter().cloned().fold(0.0, f64::max);
        if !omega_max.is_finite() {
            // e.g. eps = DBL_MAX: the scaled frequencies overflow
            return Err(OscillatorError::BadFrequencyError(frequency_error));
        }
        let (_, a_max) = interp.amplitude_range();
        Ok(Self {
            interp: Arc::new(interp),
            drive,
            frequency_factor: factor,
            h_max_s: 2.0 * PI / (omega_max * STEPS_PER_PERIOD),
            a_max,
            state: OscillatorState::default(),
            residual: None,
            residual_state: Vec::new(),
            harmonic_projection: false,
        })
    }

    /// Adds the lowest `n` linear modes `table` carries as residual modes
    /// (module `residual`: exact linear modal oscillators driven by the
    /// drive-point force, added to every output), at rest. `n = 0`: the
    /// single nonlinear mode, unchanged. `table` must be the table the
    /// oscillator was made from.
    pub fn with_residual_modes(
        mut self,
        table: &ModalTable,
        n: usize,
    ) -> Result<Self, OscillatorError> {
        if n == 0 {
            return Ok(self);
        }
        let modes = crate::reduced::ResidualModes::from_table(table, n)
            .map_err(|e| OscillatorError::ResidualModes(e.to_string()))?;
        self.residual = Some(residual::Residual::new(modes, self.drive));
        self.residual_state = vec![0.0; 2 * n];
        Ok(self)
    }

    /// With `on`, the drive-point force acts on every harmonic of the mode
    /// at the drive point, not on its fundamental alone (module
    /// `projection`: the power the force's higher harmonics exchange with
    /// the mode's own, which an attachment answering the mode's harmonics,
    /// such as the paper's shaker at phase resonance, makes large). `false`
    /// (the default) is `eq:NM`'s projection, bit for bit.
    pub fn with_harmonic_force_projection(mut self, on: bool) -> Self {
        self.harmonic_projection = on;
        self
    }

    /// Whether the force is projected on every harmonic of the mode.
    pub fn harmonic_force_projection(&self) -> bool {
        self.harmonic_projection
    }

    /// Number of residual modes.
    pub fn residual_modes(&self) -> usize {
        self.residual.as_ref().map_or(0, |r| r.len())
    }

    /// The residual modes' state `[q_1, q_1', q_2, q_2', ...]` (empty without).
    pub fn residual_state(&self) -> &[f64] {
        &self.residual_state
    }

    /// Replace the residual modes' state (rollback): `2 n` finite numbers.
    pub fn set_residual_state(&mut self, q: &[f64]) -> Result<(), OscillatorError> {
        if q.len() != self.residual_state.len() {
            return Err(OscillatorError::ResidualModes(format!(
                "residual_modes: a state of {} numbers given, {} residual modes need {}",
                q.len(),
                self.residual_modes(),
                self.residual_state.len()
            )));
        }
        if let Some(&value) = q.iter().find(|v| !v.is_finite()) {
            return Err(OscillatorError::BadState {
                field: "residual mode state",
                value,
            });
        }
        self.residual_state.copy_from_slice(q);
        Ok(())
    }

    /// The interpolated table.
    pub fn table(&self) -> &TableInterpolator {
        &self.interp
    }

    /// Index of a named point of the table (for [`Self::point_response`]).
    pub fn point_index(&self, name: &str) -> Result<usize, OscillatorError> {
        Ok(self.interp.point_index(name)?)
    }

    /// Index of the drive point.
    pub fn drive_index(&self) -> usize {
        self.drive
    }

    /// Largest RK4 sub-step [s].
    pub fn max_substep_s(&self) -> f64 {
        self.h_max_s
    }

    /// Current state.
    pub fn state(&self) -> OscillatorState {
        self.state
    }

    /// Replace the state (initial conditions, rollback).
    pub fn set_state(&mut self, state: OscillatorState) -> Result<(), OscillatorError> {
        for (field, value) in [("time_s", state.time_s), ("eta", state.eta), ("u", state.u)] {
            if !value.is_finite() {
                return Err(OscillatorError::BadState { field, value });
            }
        }
        let a = state.amplitude();
        if a > self.a_max {
            return Err(OscillatorError::AboveRange {
                a,
                max: self.a_max,
                time_s: state.time_s,
                step_s: None,
            });
        }
        self.state = state;
        Ok(())
    }

    /// Locate `a` in the table once, with range errors stamped with `time_s`.
    #[inline]
    fn locate(&self, a: f64, time_s: f64) -> Result<TableLocation, OscillatorError> {
        self.interp.locate(a).map_err(|e| match e {
            TableError::AboveRange { a, max } => OscillatorError::AboveRange {
                a,
                max,
                time_s,
                step_s: None,
            },
            e => OscillatorError::Table(e),
        })
    }

    /// `(1 + eps) omega(a)`, `D(a)` and `phi_ex(a)` (complex) at a located amplitude.
    #[inline]
    fn properties_at(&self, loc: &TableLocation) -> (f64, f64, Complex64) {
        let (w, d) = self.interp.values_at(loc);
        (
            self.frequency_factor * w,
            d,
            self.interp.shape_at(self.drive, 1, loc),
        )
    }

    /// `(1 + eps) omega(a)`, `D(a)`, `|phi_ex(a)|` with range errors stamped with `time_s`
    /// (one table look-up).
    #[inline]
    fn properties(&self, a: f64, time_s: f64) -> Result<(f64, f64, f64), OscillatorError> {
        let (w, d, phi_ex) = self.properties_at(&self.locate(a, time_s)?);
        Ok((w, d, phi_ex.norm()))
    }

    /// Right-hand side `(eta', u')` of the normal form.
    #[inline]
    fn rhs(&self, eta: f64, u: f64, c: f64, time_s: f64) -> Result<(f64, f64), OscillatorError> {
        let a = eta.hypot(u);
        if self.harmonic_projection && a > 0.0 {
            let loc = self.locate(a, time_s)?;
            return Ok(self.rhs_projected(&loc, (eta, u), a, c));
        }
        let (w, d, phi_ex) = self.properties(a, time_s)?;
        Ok((w * u, -w * eta - 2.0 * d * w * u + phi_ex * c / w))
    }

    /// [`Self::rhs`] with the force on every harmonic (module `projection`)
    /// at `a = hypot(eta, u) > 0` located at `loc`.
    #[inline]
    fn rhs_projected(
        &self,
        loc: &TableLocation,
        (eta, u): (f64, f64),
        a: f64,
        c: f64,
    ) -> (f64, f64) {
        let (w, d, phi_ex) = self.properties_at(loc);
        let (fe, fu) =
            projection::harmonic_forcing(&self.interp, self.drive, loc, (eta, u), a, c, w, phi_ex);
        (w * u + fe, -w * eta - 2.0 * d * w * u + fu)
    }

    /// Advance by `dt_s` under the input polynomial (relative to the current time).
    /// On error the state is left at the start of the step.
    pub fn step(&mut self, dt_s: f64, input: InputPolynomial) -> Result<(), OscillatorError> {
        self.step_with(dt_s, input, false).map(|_| ())
    }

    /// [`Self::step`] that stops at the end of the modal table instead of
    /// failing (the stop hook of an FMI 3.0 early return): when the
    /// amplitude of a stage or of the end of RK4 sub-step `j` would lie
    /// above the table's last amplitude, the state is left at the end of
    /// sub-step `j - 1` (the last one inside the table; the step's start for
    /// `j = 0`) and [`StepEnd::TableEnd`] reports that time. A step that stays
    /// inside the table is exactly [`Self::step`] (bit for bit); any other
    /// error leaves the state at the start of the step, as there.
    pub fn step_to_table_end(
        &mut self,
        dt_s: f64,
        input: InputPolynomial,
    ) -> Result<StepEnd, OscillatorError> {
        self.step_with(dt_s, input, true)
    }

    /// [`Self::step`] (`stop = false`) or [`Self::step_to_table_end`].
    fn step_with(
        &mut self,
        dt_s: f64,
        input: InputPolynomial,
        stop: bool,
    ) -> Result<StepEnd, OscillatorError> {
        if !(dt_s.is_finite() && dt_s >= 0.0) {
            return Err(OscillatorError::BadStep(dt_s));
        }
        input.check()?;
        if dt_s == 0.0 {
            return Ok(StepEnd::Completed);
        }
        let n = (dt_s / self.h_max_s).ceil().max(1.0);
        if n.is_nan() || n > MAX_SUBSTEPS_PER_STEP as f64 {
            return Err(OscillatorError::TooManySubsteps {
                step_s: dt_s,
                substep_s: self.h_max_s,
                substeps: n,
                cap: MAX_SUBSTEPS_PER_STEP,
            });
        }
        let end = self.advance(dt_s, n, input, stop).map_err(|e| match e {
            OscillatorError::AboveRange { a, max, time_s, .. } => OscillatorError::AboveRange {
                a,
                max,
                time_s,
                step_s: Some(dt_s),
            },
            e => e,
        })?;
        let advanced_s = match end {
            StepEnd::Completed => dt_s,
            StepEnd::TableEnd { elapsed_s, .. } => elapsed_s,
        };
        if let Some(res) = &self.residual {
            if advanced_s > 0.0 {
                res.advance(
                    &mut self.residual_state,
                    advanced_s,
                    [input.c0, input.c1, input.c2],
                );
            }
        }
        Ok(end)
    }

    /// One classical RK4 sub-step of length `h` from `(eta, u)` at `s`
    /// after the step's start `t0` (`eq:NM`'s normal form, module docs).
    #[inline]
    fn rk4(
        &self,
        (eta, u): (f64, f64),
        s: f64,
        h: f64,
        t0: f64,
        input: &InputPolynomial,
    ) -> Result<(f64, f64), OscillatorError> {
        let t = t0 + s;
        let c_start = input.at(s);
        let c_mid = input.at(s + 0.5 * h);
        let c_end = input.at(s + h);
        let (k1e, k1u) = self.rhs(eta, u, c_start, t)?;
        let (k2e, k2u) = self.rhs(eta + 0.5 * h * k1e, u + 0.5 * h * k1u, c_mid, t + 0.5 * h)?;
        let (k3e, k3u) = self.rhs(eta + 0.5 * h * k2e, u + 0.5 * h * k2u, c_mid, t + 0.5 * h)?;
        let (k4e, k4u) = self.rhs(eta + h * k3e, u + h * k3u, c_end, t + h)?;
        Ok((
            eta + h / 6.0 * (k1e + 2.0 * k2e + 2.0 * k3e + k4e),
            u + h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u),
        ))
    }

    /// [`Self::step`] in `n` equal RK4 sub-steps; with `stop`, the stop at
    /// the table's end of [`Self::step_to_table_end`].
    #[inline]
    fn advance(
        &mut self,
        dt_s: f64,
        n: f64,
        input: InputPolynomial,
        stop: bool,
    ) -> Result<StepEnd, OscillatorError> {
        let h = dt_s / n;
        let t0 = self.state.time_s;
        let (mut eta, mut u) = (self.state.eta, self.state.u);
        // the state stays at the end of sub-step `j - 1`, inside the table
        let stopped = |osc: &mut Self, j: usize, eta: f64, u: f64, a: f64| {
            let elapsed_s = j as f64 * h;
            osc.state = OscillatorState {
                time_s: t0 + elapsed_s,
                eta,
                u,
            };
            StepEnd::TableEnd {
                elapsed_s,
                time_s: t0 + elapsed_s,
                a,
                a_max: osc.a_max,
            }
        };
        let last = n as usize - 1;
        for j in 0..n as usize {
            let s = j as f64 * h;
            match self.rk4((eta, u), s, h, t0, &input) {
                Ok((e, v)) if stop && j == last && e.hypot(v) > self.a_max => {
                    return Ok(stopped(self, j, eta, u, e.hypot(v)));
                }
                Ok((e, v)) => (eta, u) = (e, v),
                Err(OscillatorError::AboveRange { a, .. }) if stop => {
                    return Ok(stopped(self, j, eta, u, a));
                }
                Err(e) => return Err(e),
            }
        }
        let a = eta.hypot(u);
        if a > self.a_max {
            return Err(OscillatorError::AboveRange {
                a,
                max: self.a_max,
                time_s: t0 + dt_s,
                step_s: None,
            });
        }
        self.state = OscillatorState {
            time_s: t0 + dt_s,
            eta,
            u,
        };
        Ok(StepEnd::Completed)
    }

    /// Modal amplitude, frequency and damping at the current state.
    pub fn modal(&self) -> Result<ModalSnapshot, OscillatorError> {
        let a = self.state.amplitude();
        let (w, d, _) = self.properties(a, self.state.time_s)?;
        Ok(ModalSnapshot {
            amplitude: a,
            omega_rad_s: w,
            damping_ratio: d,
            eta_dot: w * self.state.u,
        })
    }

    /// Displacement and velocity of point `point` synthesized with all harmonics
    /// of the table (`eq:ansatz`, see the module docs).
    pub fn point_response(&self, point: usize) -> Result<PointResponse, OscillatorError> {
        let mut out = [PointResponse {
            x_m: 0.0,
            v_m_s: 0.0,
        }];
        self.synthesize(&self.state, &[point], &mut out)?;
        Ok(out[0])
    }

    /// Modal quantities and the responses of several points at once (one table
    /// look-up for all of them; the FMU's output path).
    pub fn outputs(
        &self,
        points: &[usize],
        out: &mut [PointResponse],
    ) -> Result<ModalSnapshot, OscillatorError> {
        self.synthesize(&self.state, points, out)
    }

    /// Number of named points of the table.
    pub fn point_count(&self) -> usize {
        self.interp.point_count()
    }

    /// The fundamental harmonic of the displacement of every point of the
    /// table (table order) at the current amplitude, `q_{1,k} = a
    /// phi_{1,k}(a) / g(a)` [m] (`eq:ansatz`, `n = 1`; `g = phi_ex/|phi_ex|`,
    /// the gauge of the module docs, in which the drive point's is real and
    /// positive), so that the point moves as `Re(q_{1,k} e^{i psi})` plus
    /// its higher harmonics. The nonlinear mode alone (no residual modes).
    /// `out` has one entry per point ([`Self::point_count`]).
    pub fn fundamental_displacements(&self, out: &mut [Complex64]) -> Result<(), OscillatorError> {
        assert_eq!(out.len(), self.point_count(), "one entry per point");
        let a = self.state.amplitude();
        let loc = self.locate(a, self.state.time_s)?;
        let g = gauge(self.interp.shape_at(self.drive, 1, &loc));
        for (k, o) in out.iter_mut().enumerate() {
            *o = a * self.interp.shape_at(k, 1, &loc) / g;
        }
        Ok(())
    }

    fn synthesize(
        &self,
        s: &OscillatorState,
        points: &[usize],
        out: &mut [PointResponse],
    ) -> Result<ModalSnapshot, OscillatorError> {
        assert_eq!(points.len(), out.len());
        let z = s.z();
        let a = z.norm();
        let loc = self.locate(a, s.time_s)?;
        let (w_rad_s, d, phi_ex) = self.properties_at(&loc);
        let g = gauge(phi_ex);
        // w = e^{i psi} / g: unit phasor of the original gauge of the table
        let unit = if a > 0.0 {
            z / (a * g)
        } else {
            Complex64::new(1.0, 0.0)
        };
        let mut stack = [Complex64::new(0.0, 0.0); HARMONICS_ON_STACK];
        let mut heap = Vec::new();
        let phi = harmonic_buffer(self.interp.harmonics() + 1, &mut stack, &mut heap);
        for (&point, o) in points.iter().zip(out.iter_mut()) {
            self.interp.shape_all_at(point, &loc, phi);
            let mut x = 0.0;
            let mut v = 0.0;
            let mut wn = Complex64::new(1.0, 0.0);
            for (n, p) in phi.iter().enumerate() {
                let term = a * p * wn;
                x += term.re;
                // Re(i n omega term) = -n omega Im(term)
                v -= n as f64 * w_rad_s * term.im;
                wn *= unit;
            }
            if let Some(res) = &self.residual {
                let (xr, vr) = res.response(&self.residual_state, point);
                x += xr;
                v += vr;
            }
            *o = PointResponse { x_m: x, v_m_s: v };
        }
        Ok(ModalSnapshot {
            amplitude: a,
            omega_rad_s: w_rad_s,
            damping_ratio: d,
            eta_dot: w_rad_s * s.u,
        })
    }

    /// Rates `(eta', u')` of the state under the force `c_n` [N].
    pub fn state_rate(&self, c_n: f64) -> Result<(f64, f64), OscillatorError> {
        self.rhs(self.state.eta, self.state.u, c_n, self.state.time_s)
    }
}

#[cfg(test)]
#[path = "oscillator_tests.rs"]
mod tests;
