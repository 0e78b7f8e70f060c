//! # controller — the phase-locked loop of phase-resonant testing as an FMI 2.0 CS FMU
//!
//! Inputs: the measured force at the structure `F_meas` \[N\] and the
//! drive-point displacement `x_drive` \[m\] (plus `x_tip`, `I_meas`, recorded
//! only); output: the shaker's external voltage
//!
//! ```text
//! u_ext = u_hat cos(theta),   theta' = Omega,
//! ```
//!
//! with `Omega` updated once per excitation period by the PI law of
//! [`nlmode::control::PhaseLockedLoop`] towards a 90 degree lag of the
//! drive-point displacement behind the force; the time stepping,
//! demodulation and settle criterion are [`nlmode::control::streaming`].
//! `u_ext` has no direct feedthrough from the inputs (they are sampled at the
//! start of each step), so the loop with the shaker forms no algebraic loop.
//!
//! See `README.md` for the variable table; `modelDescription/controller/`
//! holds the modelDescription.xml rendered from [`model::VARIABLES`] and
//! [`model::INFO`].
pub mod model;

pub use model::Controller;

fmi2_export::export_fmu!(model::Controller);
fmi2_export::export_fmu3!(model::Controller);
