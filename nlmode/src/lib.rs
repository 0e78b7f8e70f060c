//! # nlmode — single-nonlinear-mode theory with linear attachments
//!
//! Implements M. Krack, *Extension of the single-nonlinear-mode theory by linear
//! attachments and application to exciter-structure interaction*. Equation labels
//! in the docs (`eq:NM`, `eq:fc1`, ...) are the `\label`s of the paper's LaTeX source.
//!
//! Data flows one way: [`structure`] builds the structural model (`eq:component1`),
//! [`attachment`] the linear attachments (`eq:component2`) and their condensed
//! impedance (`eq:fc1`), [`nma`] computes the nonlinear mode (`eq:EPMC`) and its
//! modal table, [`reduced`] integrates the single nonlinear modal oscillator
//! (`eq:NM`), [`reference`] the assembled full-order model
//! (`eq:finalassembly1`-`eq:finalassembly2`), [`frf`] gives the assembled linear
//! steady state, and [`excitation`] the sine sweeps that drive them all.
//!
//! SI units throughout; names carry them where it helps (`omega_rad_s`, `force_n`).
#![forbid(unsafe_code)]

pub mod attachment;
pub mod benchmark;
pub mod control;
mod dopri;
pub mod envelope;
pub mod excitation;
pub mod frf;
pub mod hb;
pub mod lti;
pub mod nma;
pub mod oscillator;
pub mod reduced;
pub mod reference;
pub mod structure;
pub mod table;

pub use num_complex::Complex64;
