//! Co-simulation of FMI 2.0 Co-Simulation FMUs: import ([`import`]), the
//! generic master ([`master`]) and the
//! `cosim` method on this repository's structure and shaker FMUs ([`paper`]).
//!
//! Self-contained (no `crate::` imports), so that benches and integration
//! tests can include it by path.
#![allow(dead_code)]
pub mod import;
pub mod master;
pub mod paper;
pub mod repo;
pub mod ssp;

#[cfg(test)]
mod tests;

#[allow(unused_imports)]
pub use master::{Algorithm, Master, MasterError, MasterOptions, ParamValue};
#[allow(unused_imports)]
pub use paper::{run_cosim, CosimEnvelope, CosimError, CosimOutput, CosimParams, SweepSpec};
