//! Nonlinear modal analysis (paper Section 3.1): Harmonic Balance with AFT,
//! the Extended Periodic Motion Concept (`eq:EPMC`:
//! `M q'' - 2 D omega M q' + g(q, q') = 0`), arc-length continuation, and the
//! modal table that every consumer of the nonlinear mode reads.
//!
//! - [`hb`]: Fourier layout and AFT with analytic Jacobians,
//! - [`epmc`]: the EPMC and forced-response Harmonic Balance residuals in modal
//!   coordinates and their condensed (Schur-complement) Newton solver,
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
use serde::{Deserialize, Serialize};

/// Identifier written into every modal-table file.
pub const MODAL_TABLE_FORMAT: &str = "nlmode-modal-table";
/// Current modal-table format version.
pub const MODAL_TABLE_VERSION: u32 = 1;

/// The harmonics of the mode shape at one named physical point along the branch:
/// `phi_n(a)` for `n = 0..=H`, so that the point's displacement is
/// `u(t) = Re( a sum_n phi_n(a) e^{i n psi} )` (`eq:ansatz`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointShape {
    pub name: String,
    /// `re[j][n]`: real part of `phi_n` at amplitude `amplitude[j]` [m / (sqrt(kg) m)].
    pub re: Vec<Vec<f64>>,
    /// `im[j][n]`: imaginary part of `phi_n`.
    pub im: Vec<Vec<f64>>,
}

/// A nonlinear modal table (file format `nlmode-modal-table`, version 1; JSON).
///
/// Modal amplitude `a = sqrt(q1^H M q1)` (paper Section 3.1), so the fundamental
/// harmonic of the shape is mass-normalized. `amplitude` is strictly increasing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModalTable {
    pub format: String,
    pub version: u32,
    /// Free text: model, harmonics, how the table was made.
    pub description: String,
    /// Harmonic truncation order `H` of the stored shapes.
    pub harmonics: usize,
    /// Modal amplitude `a` [sqrt(kg) m], strictly increasing.
    pub amplitude: Vec<f64>,
    /// Modal frequency `omega(a)` [rad/s].
    pub omega_rad_s: Vec<f64>,
    /// Modal damping ratio `D(a)` [-].
    pub damping_ratio: Vec<f64>,
    /// Shape harmonics at named physical points (`tip`, exciter locations, DOFs).
    pub points: Vec<PointShape>,
    /// Shape harmonics of all generalized (reduced) coordinates, if stored;
    /// `coordinates[i]` is coordinate `i` (named `q<i>`).
    #[serde(default)]
    pub coordinates: Vec<PointShape>,
    /// Amplitude at which the primary branch was truncated (first fold of `a`),
    /// if any [sqrt(kg) m].
    #[serde(default)]
    pub truncated_at_fold: Option<f64>,
    /// Measured interpolation accuracy of the table (set by
    /// [`NmaResult::refined_table`]; `None` for unrefined or measured tables
    /// and for files written before this field existed).
    #[serde(default)]
    pub accuracy: Option<TableAccuracy>,
}

/// Interpolation accuracy of a refined [`ModalTable`]: the largest PCHIP
/// errors against fresh Harmonic Balance solves at the midpoints of all table
/// intervals, and the targets of the refinement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableAccuracy {
    /// Largest relative error of `omega` [-].
    pub omega_rel: f64,
    /// Largest relative error of `D` [-] (against `max(|D|, 1e-10)`).
    pub damping_rel: f64,
    /// Largest error of the point shapes relative to each point's largest harmonic [-].
    pub shape_rel: f64,
    /// Target for `omega_rel`.
    pub target_omega_rel: f64,
    /// Target for `damping_rel` and `shape_rel`.
    pub target_rel: f64,
    /// Midpoint HB solves made (including those that led to insertions; a
    /// re-check of an interval after a neighbour's insertion reuses its solve).
    pub checks: usize,
    /// `true` if the point cap stopped the refinement before all targets were met.
    pub capped: bool,
    /// Set if the table ends before the first fold `a_f` of a truncated
    /// primary branch: its last amplitude is `(1 - fold_margin) a_f` [-].
    #[serde(default)]
    pub fold_margin: Option<f64>,
}

pub mod continuation;
mod driver;
pub mod epmc;
pub mod hb;
pub mod problems;

pub use continuation::{ContinuationOptions, StopReason};
pub use driver::*;
pub use epmc::Normalisation;
