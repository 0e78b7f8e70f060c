//! Nonlinear modal analysis (paper Section 3.1): Harmonic Balance with AFT,
//! the Extended Periodic Motion Concept (`eq:EPMC`:
//! `M q'' - 2 D omega M q' + g(q, q') = 0`), arc-length continuation, and the
//! modal table that every consumer of the nonlinear mode reads.
//!
//! - [`hb`]: Fourier layout and AFT with analytic Jacobians,
//! - [`modal_basis`]: the structure's linear modes the residuals are written in,
//! - [`epmc`]: the EPMC and forced-response Harmonic Balance residuals in modal
//!   coordinates,
//! - [`hb_jacobian`]: their structured Jacobian and its condensed
//!   (Schur-complement) Newton solver,
//! - [`continuation`]: pseudo-arc-length continuation over any residual,
//! - this module: the drivers [`nonlinear_modal_analysis`] and
//!   [`forced_response`], the branch result and its conversion to a
//!   [`ModalTable`], and tables from measured modal data
//!   ([`table_from_measured_csv`]),
//! - [`problems`]: test problems with known answers (Duffing, chains), shared
//!   by tests and benchmarks.
//!
//! Typical use:
//!
//! ```no_run
//! use nlmode::nma::{nonlinear_modal_analysis, NmaOptions, TablePolicy};
//! # fn model() -> nlmode::structure::StructuralModel { unimplemented!() }
//! let result = nonlinear_modal_analysis(&model(), &NmaOptions::default())?;
//! for fold in &result.folds {
//!     println!("fold of a at a = {:e}, omega = {} rad/s", fold.amplitude, fold.omega_rad_s);
//! }
//! let table = result.to_table(TablePolicy::PrimaryBranch);
//! # Ok::<(), nlmode::nma::NmaError>(())
//! ```
//!
//! Cost: the Newton systems are condensed onto the nonlinear DOFs (see
//! [`epmc`]), so a continuation point costs `O(n H)` for `n` DOFs plus a dense
//! solve of size `~ E (2H+1)` for `E` nonlinear elements; the one-off modal
//! decomposition is `O(n^3)`. Measured times: the README's performance table
//! (`cargo bench -p nlmode --bench nma`).
mod driver;
mod errors;
mod folds;
mod forced;
mod harmonics;
mod measured;
mod options;
mod play;
mod refine;
mod results;

pub mod continuation;
pub mod epmc;
pub mod hb;
pub mod hb_jacobian;
pub mod modal_basis;
pub mod problems;

pub use crate::table::{
    LinearModeShape, LinearModes, ModalTable, PointShape, TableAccuracy, TableDiscontinuity,
    HIGHEST_HARMONIC_SHARE_WARNING, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION,
};
pub use continuation::{ContinuationOptions, StopReason};
pub use driver::{
    nonlinear_modal_analysis, nonlinear_modal_analysis_with_basis, solve_at_amplitude,
    DISSIPATIVE_DAMPING_SCALE,
};
pub use epmc::Normalisation;
pub use errors::{NmaError, NmaWarning};
pub use folds::{INTERNAL_RESONANCE_MIN_GROWTH, INTERNAL_RESONANCE_MISMATCH};
pub use forced::{forced_response, ForcedResponse, ForcedResponseOptions, ForcedResponsePoint};
pub use harmonics::{
    auto_harmonics, table_agreement, AutoHarmonics, AUTO_HARMONICS_MAX, AUTO_HARMONICS_STEP,
};
pub use measured::table_from_measured_csv;
pub use options::{
    max_aft_samples, AmplitudeRange, BackboneOptions, NmaOptions, HYSTERETIC_DEFAULT_SAMPLES,
    MAX_AFT_SAMPLES, MAX_AFT_TABLE_ENTRIES, SWEEP_TABLE_HARMONICS, SWEEP_TABLE_MAX_AMPLITUDE,
};
pub use refine::{table_errors, RefineOptions, JUMP_WIDTH};
pub use results::{
    BranchPoint, EnergyComponent, Fold, FoldKind, InternalResonance, NmaResult, TablePolicy,
    JUMP_SLOPE_RATIO,
};
