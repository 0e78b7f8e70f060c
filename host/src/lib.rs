//! The `host` tool as a library: scenarios, the sweep methods, NMA, FMU
//! packaging and the co-simulation commands; `src/main.rs` is the thin
//! command line on top (clap and the exit code only).
//!
//! `host run [SCENARIO] -o DIR` sweeps through resonance by the methods the
//! scenario lists and writes the output contract (DESIGN.md section 7);
//! `host nma` computes the nonlinear mode; `host frf` the steady-state
//! frequency responses; `host package` packages the FMUs; `host cosim` runs a
//! generic co-simulation file; `host study` runs a parameter study.
#![forbid(unsafe_code)]
pub mod api;
pub mod cosim_cmd;
pub mod figures;
pub mod fmus;
pub mod methods;
pub mod model;
pub mod nma_cmd;
pub mod package;
pub mod plot;
pub mod results;
pub mod run;
pub mod scenario;
pub mod stages;
pub mod study;
pub mod validity;

/// The controlled tests' modules under their former paths.
pub use methods::phase_resonance as controlled;
pub use methods::phase_resonance::cosim as controlled_cosim;
pub use methods::{stepped, test_plan};
