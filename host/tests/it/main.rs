//! The host's integration tests, one test binary (one link of the dependency
//! graph instead of one per file): `cargo test -p host --test it [module::]`.
//! The modules' tests run concurrently in one process, so none sets an
//! environment variable or the working directory, and each scratch directory
//! is unique (`common::tmpdir`, `tempfile`).
mod common;

mod attachments;
mod bounded_files;
mod cli;
mod controlled_stepped;
mod elements;
mod fuzz_fmus;
mod fuzz_scenario;
mod generic;
mod hb_method;
mod install;
mod matrices;
mod measured_table;
mod nma_keys;
mod phase_resonance;
mod phase_resonance_cosim;
mod slowflow_states;
mod study;
mod test_plan;
