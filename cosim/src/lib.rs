//! # cosim — co-simulation of FMI 2.0 Co-Simulation FMUs
//!
//! * [`master`]: the master algorithms (Jacobi, Gauss-Seidel, iterative with
//!   rollback), connection ordering, recording ([`master::run`],
//!   [`master::Recording`]) and the generic run ([`master::run_generic`]);
//! * [`spec`]: the generic TOML co-simulation file (`docs/cosim.md`);
//! * [`ssp`]: SSP 1.0 export of a coupled system;
//! * [`paper`]: the paper's pairing, the structure and shaker FMUs swept
//!   through resonance (the `cosim` method of `host run`);
//! * [`repo`]: packaging this repository's two FMUs from their built
//!   libraries (found beside the executable or in `--fmu-dir`) and the parts
//!   embedded at compile time.
//!
//! FMUs are loaded by `fmi2-import` (re-exported as [`import`]); input files
//! are read by the FMI core's bounded regular-file reader (re-exported as
//! [`file`], also for the host's scenario files).
#![forbid(unsafe_code)]
pub use fmi2::file;
pub use fmi2_import as import;

pub mod master;
pub mod paper;
pub mod repo;
pub mod spec;
pub mod ssp;

#[cfg(test)]
mod tests;

pub use master::{Algorithm, Master, MasterError, MasterOptions, ParamValue};
pub use paper::{run_cosim, CosimError, CosimOutput, CosimParams};
