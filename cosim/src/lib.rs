//! # cosim — co-simulation of FMI 2.0 Co-Simulation FMUs
//!
//! * [`master`]: the master algorithms (Jacobi, Gauss-Seidel, iterative with
//!   rollback), connection ordering, recording ([`master::run`],
//!   [`master::Recording`]) and the generic run ([`master::run_generic`]);
//! * [`spec`]: the generic TOML co-simulation file (`docs/cosim.md`);
//! * [`ssp`]: SSP 1.0 export of a coupled system.
//!
//! The generic master only: it knows no physics and no particular FMU. This
//! repository's FMUs and their pairing (the `cosim` method of `host run`) are
//! the host's (`host/src/fmus/`), written as a co-simulation file like any
//! user's.
//!
//! FMUs are loaded by `fmi2-import` (re-exported as [`import`]); input files
//! are read by the FMI core's bounded regular-file reader (re-exported as
//! [`file`], also for the host's scenario files).
#![forbid(unsafe_code)]
pub use fmi2::file;
pub use fmi2_import as import;

pub mod master;
pub mod spec;
pub mod ssp;

#[cfg(test)]
mod tests;

pub use master::{Algorithm, Master, MasterError, MasterOptions, ParamValue};
