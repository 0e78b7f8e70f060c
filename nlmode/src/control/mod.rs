//! Controlled virtual vibration tests (issue 16): the controller drives a
//! [`Plant`] (the structure with its shaker) one excitation period at a time and
//! reads what a test rig measures, the force at the structure (the stinger force
//! of `eq:fc1`'s attachment, as a force sensor on the structure sees it) and the
//! drive-point and tip displacements.
//!
//! - [`pll`]: the phase-locked loop for phase resonance (phase detector by
//!   demodulation over the running excitation period, PI frequency update
//!   towards 90 degrees lag of the drive-point displacement behind the force),
//!   stepped through voltage levels; modal damping from the power balance.
//! - [`force`]: force control, a stepped sine whose voltage holds the
//!   fundamental of the force at the structure at a set value.
//! - [`response`]: response-controlled stepped sine, a stepped sine whose
//!   voltage holds the drive-point response amplitude at a set value (the
//!   constant-response FRF, whose peak lies on the backbone).
//! - [`plant`]: the plant driven by the full-order reference assembly
//!   (`eq:finalassembly1`-`eq:finalassembly2`), for the paper beam with its
//!   shaker or a single-DOF Duffing oscillator with the paper's shaker.
//! - [`ema`]: virtual experimental nonlinear modal analysis, the modal table
//!   of a phase-resonance test (force appropriation at phase resonance).
//! - [`plan`]: test planning, the voltage that holds the single-nonlinear-mode
//!   model at phase resonance at a target amplitude (`eq:NM`).
//! - [`reduced_plant`]: the plant on the single-nonlinear-mode model (`eq:NM`,
//!   the slow flow with the attachments), with what its averaging implies for
//!   the loop.
//!
//! # Demodulation
//!
//! Every period of the excitation `u = u_hat cos(Omega t)` starts at phase 0
//! (the plant advances exactly one period `T = 2 pi / Omega` at a time, so the
//! phase stays continuous when `Omega` changes between periods) and is sampled
//! at `N` uniform phases `theta_i = 2 pi i / N`, `i = 0..N-1`. The complex
//! harmonics of a signal `x` over that period are
//!
//! ```text
//! X_0 = 1/N sum_i x_i,   X_h = 2/N sum_i x_i e^{-i h theta_i}   (h >= 1),
//! x(theta) = X_0 + sum_h Re(X_h e^{i h theta}),
//! ```
//!
//! exact for harmonics `h < N/2` of a periodic signal (the rectangle rule is
//! exact on trigonometric polynomials over a full period).
pub mod ema;
pub mod force;
pub mod plan;
pub mod plant;
pub mod pll;
pub mod reduced_plant;
pub mod response;
pub mod streaming;

pub use ema::{
    modal_table_from_phase_resonance, EmaError, MeasuredModalPoint, MeasuredModalTable,
    SkippedLevel,
};
pub use force::{
    force_controlled_stepped_sine, ForceControlOptions, ForceControlResult, ForceStep,
};
pub use plan::{attachment_states, phase_resonance_voltage, PhaseResonancePoint, PlanError};
pub use plant::{DuffingOscillator, ReferencePlant};
pub use pll::{
    phase_resonance, PhaseLockedLoop, PhaseMeasurement, PllLevel, PllOptions, PllResult,
};
pub use reduced_plant::ReducedPlant;
pub use response::{constant_response_peak, response_controlled_stepped_sine};
pub use streaming::{StreamEvent, StreamSample, StreamingPll};

#[cfg(test)]
mod force_tests;
#[cfg(test)]
mod pll_tests;
#[cfg(test)]
mod reduced_tests;
#[cfg(test)]
mod response_tests;

use crate::reference::ReferenceError;
use num_complex::Complex64;

/// Errors of the controlled tests; each carries the offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ControlError {
    #[error("option {name} = {value}: expected {expected}")]
    BadOption {
        name: &'static str,
        value: String,
        expected: &'static str,
    },
    #[error("the plant has no attachment with an interface point (no force to measure)")]
    NoAttachment,
    #[error("assembly of the plant: {0}")]
    Assembly(#[source] ReferenceError),
    #[error(
        "the plant's structure has a hysteretic element ({law}): with the Dormand-Prince \
         integrator the controlled tests restart the time integration every period and do not \
         carry its slider state (use the exponential integrator)"
    )]
    Hysteretic { law: String },
    #[error("time integration of the plant failed at t = {time_s} s: {source}")]
    Integration {
        time_s: f64,
        #[source]
        source: ReferenceError,
    },
    #[error("single-nonlinear-mode model: {0}")]
    Reduced(String),
    #[error("structure model: {0}")]
    Structure(#[from] crate::structure::StructureError),
    #[error("attachment: {0}")]
    Attachment(#[from] crate::attachment::AttachmentError),
}

/// `Ok` for a finite positive `v`, else [`ControlError::BadOption`] naming
/// the option.
pub(crate) fn positive_option(name: &'static str, v: f64) -> Result<(), ControlError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ControlError::BadOption {
            name,
            value: v.to_string(),
            expected: "a positive number",
        })
    }
}

/// Samples of one excitation period at the phases `2 pi i / N`, `i = 0..N-1`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PeriodSamples {
    /// Excitation frequency of the period \[rad/s\].
    pub omega_rad_s: f64,
    /// Voltage amplitude of the period \[V\].
    pub voltage_v: f64,
    /// Force of the exciter on the structure at the drive point \[N\], positive
    /// along the drive point's positive displacement.
    pub force_n: Vec<f64>,
    /// Drive-point displacement \[m\].
    pub drive_m: Vec<f64>,
    /// Tip (response point) displacement \[m\].
    pub tip_m: Vec<f64>,
    /// Current through the shaker coil \[A\] (empty if the plant has none).
    pub current_a: Vec<f64>,
}

/// The harmonics `0..=H` of one measured period (see the module docs), what
/// every controlled test records per level or step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PeriodHarmonics {
    /// Harmonics of the force on the structure at the drive point \[N\].
    pub force_n: Vec<Complex64>,
    /// Harmonics of the drive-point displacement \[m\].
    pub drive_m: Vec<Complex64>,
    /// Harmonics of the tip displacement \[m\].
    pub tip_m: Vec<Complex64>,
    /// Fundamental amplitude of the coil current \[A\] (0 without one).
    pub current_amplitude_a: f64,
}

impl PeriodHarmonics {
    /// Demodulates `samples` up to harmonic `harmonics`; an error if
    /// `harmonics` is not below half the samples per period.
    pub fn from_samples(samples: &PeriodSamples, harmonics: usize) -> Result<Self, ControlError> {
        if 2 * (harmonics + 1) > samples.force_n.len() {
            return Err(ControlError::BadOption {
                name: "harmonics",
                value: harmonics.to_string(),
                expected: "fewer than half the samples per period",
            });
        }
        // one set of phasors for the signals of the period
        let w = demodulation_phasors(samples.force_n.len());
        let dem = |x: &[f64], h: usize| {
            if x.len() == w.len() {
                harmonics_with(x, h, &w)
            } else {
                period_harmonics(x, h)
            }
        };
        let current_amplitude_a = if samples.current_a.is_empty() {
            0.0
        } else {
            dem(&samples.current_a, 1)[1].norm()
        };
        Ok(Self {
            force_n: dem(&samples.force_n, harmonics),
            drive_m: dem(&samples.drive_m, harmonics),
            tip_m: dem(&samples.tip_m, harmonics),
            current_amplitude_a,
        })
    }
    /// `|q_tip,1|` \[m\].
    pub fn tip_amplitude_m(&self) -> f64 {
        self.tip_m[1].norm()
    }
    /// `|q_drive,1|` \[m\].
    pub fn drive_amplitude_m(&self) -> f64 {
        self.drive_m[1].norm()
    }
    /// `|F_1|` \[N\].
    pub fn force_amplitude_n(&self) -> f64 {
        self.force_n[1].norm()
    }
    /// Mean input power at the drive point ([`mean_power_w`]) \[W\].
    pub fn power_w(&self, omega_rad_s: f64) -> f64 {
        mean_power_w(&self.force_n, &self.drive_m, omega_rad_s)
    }
}

/// The plant a controller drives: set the excitation, advance one period,
/// read the measured samples.
pub trait Plant {
    /// Voltage amplitude \[V\] and frequency \[rad/s\] of the next period(s).
    fn set_excitation(&mut self, voltage_v: f64, omega_rad_s: f64);
    /// Advances one excitation period `T = 2 pi / Omega` (the phase continues
    /// from 0) and returns its samples.
    fn advance_period(&mut self) -> Result<&PeriodSamples, ControlError>;
    /// Time simulated so far \[s\].
    fn time_s(&self) -> f64;
}

/// Complex harmonics `X_0..=X_harmonics` of one period of uniform samples (see
/// the module docs). Hand-written: a few bins of a short period, where the
/// direct sum is exact and cheaper than an FFT plan.
pub fn period_harmonics(samples: &[f64], harmonics: usize) -> Vec<Complex64> {
    harmonics_with(samples, harmonics, &demodulation_phasors(samples.len()))
}

/// `e^{-i 2 pi k / N}`, `k = 0..N-1`: the phasors of [`period_harmonics`]
/// (harmonic `h` at sample `i` takes `k = h i mod N`).
fn demodulation_phasors(n: usize) -> Vec<Complex64> {
    assert!(n > 0, "at least one sample per period");
    (0..n)
        .map(|k| Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * k as f64 / n as f64))
        .collect()
}

/// [`period_harmonics`] with the phasors of [`demodulation_phasors`].
fn harmonics_with(samples: &[f64], harmonics: usize, phasors: &[Complex64]) -> Vec<Complex64> {
    let n = samples.len();
    assert!(n > 0 && phasors.len() == n, "one phasor per sample");
    (0..=harmonics)
        .map(|h| {
            let scale = if h == 0 { 1.0 } else { 2.0 } / n as f64;
            let hk = h % n;
            let (mut k, mut sum) = (0, Complex64::new(0.0, 0.0));
            for &x in samples {
                sum += x * phasors[k];
                k += hk;
                if k >= n {
                    k -= n;
                }
            }
            sum * scale
        })
        .collect()
}

/// Mean power `P = 1/2 sum_h Re(F_h conj(V_h))`, `V_h = i h Omega X_h`, that a
/// force with harmonics `force` puts into a point moving with displacement
/// harmonics `disp` (both from [`period_harmonics`]) \[W\].
pub fn mean_power_w(force: &[Complex64], disp: &[Complex64], omega_rad_s: f64) -> f64 {
    force
        .iter()
        .zip(disp)
        .enumerate()
        .skip(1)
        .map(|(h, (f, x))| {
            let v = Complex64::new(0.0, h as f64 * omega_rad_s) * x;
            0.5 * (f * v.conj()).re
        })
        .sum()
}

/// Wraps an angle to `(-pi, pi]`.
pub(crate) fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::PI;
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    if w <= -PI {
        w + 2.0 * PI
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn harmonics_of_a_period_are_exact() {
        let n = 40;
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let th = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                0.1 + 2.0 * (th + 0.3).cos() + 0.5 * (3.0 * th - 1.0).cos()
            })
            .collect();
        let h = period_harmonics(&x, 5);
        assert!((h[0].re - 0.1).abs() < 1e-14);
        assert!((h[1] - Complex64::from_polar(2.0, 0.3)).norm() < 1e-13);
        assert!(h[2].norm() < 1e-13);
        assert!((h[3] - Complex64::from_polar(0.5, -1.0)).norm() < 1e-13);
        // power of F = cos, x = sin/Omega (velocity in phase with the force): P = 1/2
        let f = [Complex64::new(0.0, 0.0), Complex64::new(1.0, 0.0)];
        let xd = [Complex64::new(0.0, 0.0), Complex64::new(0.0, -1.0 / 7.0)];
        assert!((mean_power_w(&f, &xd, 7.0) - 0.5).abs() < 1e-15);
        assert!((wrap_angle(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
    }
}
