//! Co-simulation of FMI 2.0 Co-Simulation FMUs: import ([`import`]) and the
//! master algorithms ([`master`]).
//!
//! Self-contained (no `crate::` imports), so that benches and integration
//! tests can include it by path.
pub mod import;
