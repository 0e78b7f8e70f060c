//! Drivers: nonlinear modal analysis (EPMC branch) and forced Harmonic Balance
//! frequency responses, branch results, modal tables.
use super::continuation::{
    continuation, BranchState, ContinuationFailure, ContinuationOptions, ContinuationSummary,
    StopReason,
};
use super::epmc::{EpmcResidual, ForcedResidual, ModalBasis, Normalisation};
use super::hb::default_samples;
use super::{ModalTable, PointShape, TableAccuracy, MODAL_TABLE_FORMAT, MODAL_TABLE_VERSION};
use crate::structure::StructuralModel;
use crate::Complex64;
use nalgebra::DVector;
use rayon::prelude::*;
use std::sync::Arc;

/// Errors of the nonlinear modal analysis. Failures during continuation carry
/// the part of the branch computed before the failure (`partial`).
#[derive(Debug, thiserror::Error)]
pub enum NmaError {
    #[error("mode index {mode_index} does not exist: the model has {n_modes} modes (indices 0..{n_modes})")]
    ModeIndexOutOfRange { mode_index: usize, n_modes: usize },
    #[error("harmonics must be at least 1, got {harmonics}")]
    NoHarmonics { harmonics: usize },
    #[error("{samples} AFT samples are too few for H = {harmonics} harmonics (need at least 4H+1 = {minimum})")]
    TooFewSamples {
        samples: usize,
        harmonics: usize,
        minimum: usize,
    },
    #[error("invalid amplitude range: start {start}, end {end} ({reason})")]
    InvalidAmplitudeRange {
        start: f64,
        end: f64,
        reason: &'static str,
    },
    #[error("invalid frequency range: start {start} rad/s, end {end} rad/s")]
    InvalidFrequencyRange { start: f64, end: f64 },
    #[error("unknown named point '{name}' (the model has: {available})")]
    UnknownPoint { name: String, available: String },
    #[error("named point '{name}' does not move in mode {mode_index} (|phi| = {value:e}), cannot convert its amplitude")]
    PointAtNode {
        name: String,
        mode_index: usize,
        value: f64,
    },
    #[error("the mass matrix is not positive definite")]
    MassNotPositiveDefinite,
    #[error("force vector has length {got}, the model has {expected} coordinates")]
    ForceLength { got: usize, expected: usize },
    #[error("Newton did not converge at the start point a = {amplitude:e} (residual norm {residual_norm:e} after {iterations} iterations)")]
    StartNotConverged {
        amplitude: f64,
        residual_norm: f64,
        iterations: usize,
        partial: Box<NmaResult>,
    },
    #[error("continuation step size collapsed after a = {amplitude:e}, omega = {omega_rad_s} rad/s: step {step_size:e} < dsmin {dsmin:e} (last residual norm {residual_norm:e}); {} points computed", partial.branch.len())]
    StepSizeCollapse {
        amplitude: f64,
        omega_rad_s: f64,
        residual_norm: f64,
        step_size: f64,
        dsmin: f64,
        partial: Box<NmaResult>,
    },
    #[error("singular Jacobian (bifurcation point?) after a = {amplitude:e}; {} points computed", partial.branch.len())]
    SingularJacobian {
        amplitude: f64,
        partial: Box<NmaResult>,
    },
    #[error("forced response failed after Omega = {omega_rad_s} rad/s: {reason}; {} points computed", partial.points.len())]
    ForcedResponseFailed {
        omega_rad_s: f64,
        reason: String,
        partial: Box<ForcedResponse>,
    },
    #[error("measured modal data, line {line}: {message}")]
    MeasuredData { line: usize, message: String },
    #[error("table refinement needs the branch's generalized-coordinate shapes (NmaOptions::store_coordinates = true)")]
    RefinementNeedsCoordinates,
    #[error("table refinement: HB solve at a = {amplitude:e} failed (residual norm {residual_norm:e} after {iterations} iterations)")]
    RefinementSolveFailed {
        amplitude: f64,
        residual_norm: f64,
        iterations: usize,
    },
    #[error("table refinement: {0}")]
    Table(String),
    #[error("table refinement: fold_margin must be in [0, 1), got {fold_margin}")]
    InvalidFoldMargin { fold_margin: f64 },
}

impl NmaError {
    /// The part of the branch computed before a continuation failure.
    pub fn partial(&self) -> Option<&NmaResult> {
        match self {
            NmaError::StartNotConverged { partial, .. }
            | NmaError::StepSizeCollapse { partial, .. }
            | NmaError::SingularJacobian { partial, .. } => Some(partial),
            _ => None,
        }
    }
}

/// Non-fatal findings of the analysis (also printed by the host).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NmaWarning {
    #[error("the amplitude range never left the linear regime: up to a = {max_amplitude:e} the modal frequency changed by {omega_shift_rel:e} (relative) and the damping ratio by {damping_shift:e}")]
    LinearRegimeOnly {
        max_amplitude: f64,
        omega_shift_rel: f64,
        damping_shift: f64,
    },
    #[error("continuation stopped after the maximum of {points} points at a = {amplitude:e} before reaching the end of the range")]
    MaxPointsReached { points: usize, amplitude: f64 },
    #[error("the fundamental harmonic carries only {share:e} of the kinetic energy at a = {amplitude:e}, omega = {omega_rad_s} rad/s (energy localized in higher harmonics: internal resonance); continuation stopped")]
    FundamentalLost {
        amplitude: f64,
        omega_rad_s: f64,
        share: f64,
    },
    #[error(
        "the branch turned back below the start amplitude (a = {amplitude:e}) and was stopped"
    )]
    LeftRange { amplitude: f64 },
    #[error("the end frequency {end_omega_rad_s} rad/s was not reached: the branch stopped at a = {amplitude:e}, omega = {omega_rad_s} rad/s (fundamental energy share {share:e}, last step {step:e})")]
    EndFrequencyNotReached {
        end_omega_rad_s: f64,
        amplitude: f64,
        omega_rad_s: f64,
        share: f64,
        step: f64,
    },
}

/// Amplitude range of the continuation (serialised externally tagged,
/// e.g. TOML `amplitude = { modal = { log10_start = -6.0, log10_end = -1.0 } }`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum AmplitudeRange {
    /// Modal amplitude `a = sqrt(q1^H M q1)` [sqrt(kg) m], as `log10 a` bounds.
    Modal { log10_start: f64, log10_end: f64 },
    /// Magnitude of the fundamental harmonic at a named point [m]: the start is
    /// converted with the linear mode; the analysis stops once the point's
    /// amplitude reaches `end_m` (modal amplitude capped at 1000x the linear
    /// estimate of `end_m`).
    Point {
        name: String,
        start_m: f64,
        end_m: f64,
    },
}

/// Options of [`nonlinear_modal_analysis`]. Serialisable; missing keys take
/// the defaults (`Default`: H = 13, mode 0, `a` from 1e-6 to 1e-1, damped,
/// `ds = 0.1`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NmaOptions {
    /// Harmonic truncation order `H` (`eq:fourier`); the paper uses 13.
    pub harmonics: usize,
    /// AFT time samples per period; default `4H+1` (exact for cubic laws), at
    /// least [`HYSTERETIC_DEFAULT_SAMPLES`] for a model with a hysteretic element.
    pub samples: Option<usize>,
    /// Which linear mode to continue, 0-based in ascending frequency (0 = the
    /// paper's "mode 1").
    pub mode_index: usize,
    pub amplitude: AmplitudeRange,
    /// Drop the linear damping `C` (the underlying conservative system; `D`
    /// then comes out zero).
    pub conservative: bool,
    pub continuation: ContinuationOptions,
    /// Named points whose shape harmonics are stored; empty = all named points.
    pub points: Vec<String>,
    /// Store the shape harmonics of all generalized coordinates at every point.
    pub store_coordinates: bool,
    /// Stop (with a warning) once the fundamental harmonic's share of the
    /// kinetic energy ([`BranchPoint::fundamental_energy_share`]) falls below
    /// this: the branch has turned into another mode's internal-resonance
    /// branch, where `a -> 0` (default 0.005). Only with
    /// [`Normalisation::Fundamental`]; the harmonic-energy normalisation
    /// passes such loops.
    pub min_fundamental_share: f64,
    /// Normalisation and continuation parameter of the EPMC unknowns (default
    /// [`Normalisation::Fundamental`], continuation in `log10 a`; use
    /// [`Normalisation::HarmonicEnergy`] to pass internal-resonance loops: the
    /// amplitude range then bounds the harmonic-energy amplitude `A >= a`).
    pub normalisation: Normalisation,
    /// End the branch once `omega / omega0` reaches this (default `None`: no
    /// frequency end; the amplitude range ends the branch). A branch ending
    /// before it is reported with [`NmaWarning::EndFrequencyNotReached`].
    pub end_omega_over_omega0: Option<f64>,
    /// End the branch at the first point whose `a` falls below an earlier
    /// one (the first fold of the primary branch, [`NmaResult::table_indices`]):
    /// all that a [`TablePolicy::PrimaryBranch`] table uses, so the table is
    /// the same as from the whole branch (default `false`: the whole branch,
    /// loops included, for plots and `host nma`).
    pub stop_at_first_fold: bool,
}

/// Harmonic order `H` of the modal table the single-nonlinear-mode methods use
/// by default (the default `[nma] harmonics` of `host`): the smallest `H` whose
/// refined table ([`NmaResult::refined_table`], [`RefineOptions`] defaults)
/// agrees with the `H = 13` table within the refinement targets (omega 1e-5,
/// D and point shapes 1e-4, relative) for modal amplitudes up to
/// [`SWEEP_TABLE_MAX_AMPLITUDE`] on the paper beam (measured: omega 1.8e-9,
/// D 1.2e-6, shapes 4.2e-5; `H = 5` misses the shapes with 1.7e-4, `H = 3`
/// misses D with 3.5e-3 and the shapes with 6.5e-3 already below
/// a = 1.22e-3). Cubic stiffness excites only odd harmonics, so `H = 6` would
/// equal `H = 5`. The test `sweep_table_harmonics_agree_with_h13_within_the_refined_accuracy`
/// checks it.
pub const SWEEP_TABLE_HARMONICS: usize = 7;

/// Largest modal amplitude `a` [sqrt(kg) m] the paper's sweeps reach (with
/// margin) for which [`SWEEP_TABLE_HARMONICS`] is stated: case (a), 2l/3 at
/// 10 V, reaches 1.22e-3 and the 10 V sweep at l/3 2.07e-3; the first fold
/// of the damped primary branch is at 3.96e-3.
pub const SWEEP_TABLE_MAX_AMPLITUDE: f64 = 2.5e-3;

impl Default for NmaOptions {
    fn default() -> Self {
        Self {
            harmonics: 13,
            samples: None,
            mode_index: 0,
            amplitude: AmplitudeRange::Modal {
                log10_start: -6.0,
                log10_end: -1.0,
            },
            conservative: false,
            continuation: ContinuationOptions {
                ds: 0.1,
                ..Default::default()
            },
            points: vec![],
            store_coordinates: true,
            min_fundamental_share: 0.005,
            normalisation: Normalisation::Fundamental,
            end_omega_over_omega0: None,
            stop_at_first_fold: false,
        }
    }
}

/// Options of a backbone continuation through internal-resonance loops (the
/// scenario's `[nma]` backbone settings; serialisable, missing keys take the
/// defaults). [`BackboneOptions::nma_options`] turns them into [`NmaOptions`]
/// with [`Normalisation::HarmonicEnergy`].
///
/// Defaults (chosen on the paper beam, H = 13, where they pass the 1:5, 1:9,
/// 1:3, 1:7 and 1:13 loops up to 2.7 omega0 in about 660 points):
/// `harmonics = 13`, `log10_start = -6` (start at `A = 1e-6`, linear regime),
/// `log10_end = 0` (`A = 1`, in practice never reached), `end_omega_over_omega0
/// = 2.7`, `ds = 0.03`, `dsmin = 1e-5`, `dsmax = 0.03` (scaled arc length:
/// unit-norm shape, `omega / omega0`, `log10 A`; larger steps cut across the
/// narrow 1:5 and 1:9 loops), `max_tangent_angle_deg = 10`,
/// `max_contraction = 0.6`, `tolerance = 1e-8` (scaled residual; inside the
/// 1:13 loop at H = 13 Newton stalls near 1e-7 relative to 1e-10, the
/// conditioning of that branch), `max_points = 5000`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BackboneOptions {
    pub harmonics: usize,
    pub log10_start: f64,
    pub log10_end: f64,
    pub end_omega_over_omega0: Option<f64>,
    pub ds: f64,
    pub dsmin: f64,
    pub dsmax: f64,
    pub max_tangent_angle_deg: f64,
    pub max_contraction: f64,
    pub tolerance: f64,
    pub max_points: usize,
}

impl Default for BackboneOptions {
    fn default() -> Self {
        Self {
            harmonics: 13,
            log10_start: -6.0,
            log10_end: 0.0,
            end_omega_over_omega0: Some(2.7),
            ds: 0.03,
            dsmin: 1e-5,
            dsmax: 0.03,
            max_tangent_angle_deg: 10.0,
            max_contraction: 0.6,
            tolerance: 1e-8,
            max_points: 5000,
        }
    }
}

impl BackboneOptions {
    /// The [`NmaOptions`] of this backbone continuation (mode 0, all named
    /// points, coordinates stored).
    pub fn nma_options(&self, conservative: bool) -> NmaOptions {
        NmaOptions {
            harmonics: self.harmonics,
            amplitude: AmplitudeRange::Modal {
                log10_start: self.log10_start,
                log10_end: self.log10_end,
            },
            conservative,
            normalisation: Normalisation::HarmonicEnergy,
            end_omega_over_omega0: self.end_omega_over_omega0,
            continuation: ContinuationOptions {
                ds: self.ds,
                dsmin: Some(self.dsmin),
                dsmax: Some(self.dsmax),
                max_tangent_angle_deg: Some(self.max_tangent_angle_deg),
                max_contraction: Some(self.max_contraction),
                tolerance: self.tolerance,
                max_points: self.max_points,
                ..Default::default()
            },
            ..Default::default()
        }
    }
}

/// One converged point of the nonlinear-mode branch.
#[derive(Debug, Clone, PartialEq)]
pub struct BranchPoint {
    /// Modal amplitude `a` [sqrt(kg) m].
    pub amplitude: f64,
    /// Modal frequency `omega` [rad/s].
    pub omega_rad_s: f64,
    /// Modal damping ratio `D` [-].
    pub damping_ratio: f64,
    pub newton_iterations: usize,
    /// Share of the fundamental harmonic in the kinetic energy of the
    /// oscillation, `|phi_1|_M^2 / sum_n n^2 |phi_n|_M^2` (1 for a harmonic
    /// motion; drops where energy localizes in higher harmonics along loops).
    pub fundamental_energy_share: f64,
    /// Kinetic-energy share of every harmonic `n = 0..=H` (summed over the
    /// modes; `[0]` is 0, `[1]` is [`Self::fundamental_energy_share`]).
    pub harmonic_energy_shares: Vec<f64>,
    /// The largest energy component other than the continued mode's
    /// fundamental: where the energy goes along an internal-resonance loop.
    pub secondary: EnergyComponent,
    /// `points[p][n]`: harmonic `phi_n` (`n = 0..=H`) at stored named point `p`
    /// [m / (sqrt(kg) m)], so the point moves as `Re(a sum_n phi_n e^{i n psi})`.
    pub points: Vec<Vec<Complex64>>,
    /// `coordinates[i][n]`: harmonic `phi_n` of generalized coordinate `i` (if stored).
    pub coordinates: Vec<Vec<Complex64>>,
}

/// Direction of the amplitude at a fold of the branch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FoldKind {
    /// `a` stops increasing (the start of a loop).
    AmplitudeMaximum,
    /// `a` stops decreasing.
    AmplitudeMinimum,
}

/// One (harmonic, linear mode) component of the oscillation and its share of
/// the kinetic energy, `n^2 |Psi_{n,k}|^2 / sum_{n,k} n^2 |Psi_{n,k}|^2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyComponent {
    pub harmonic: usize,
    /// 0-based linear mode index (the paper's "mode 2" is index 1).
    pub mode_index: usize,
    pub share: f64,
}

/// An internal resonance `1:n` of the continued mode with another mode: the
/// `n`-th harmonic of the motion meets that mode's frequency, `n omega ~
/// omega_k(a)`, and takes over the energy along a loop of the backbone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InternalResonance {
    /// Harmonic order `n` (ratio `1:n`).
    pub harmonic: usize,
    /// 0-based index of the participating linear mode.
    pub mode_index: usize,
    /// Largest energy share of that component along the loop.
    pub max_share: f64,
    /// Smallest fundamental energy share along the loop.
    pub min_fundamental_share: f64,
    /// `omega` at the loop's amplitude minimum [rad/s].
    pub omega_rad_s: f64,
}

impl std::fmt::Display for InternalResonance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "1:{} with mode {} (n omega = {:.2} rad/s, {:.0} % of the energy in that component, fundamental share down to {:.1e})",
            self.harmonic,
            self.mode_index + 1,
            self.harmonic as f64 * self.omega_rad_s,
            100.0 * self.max_share,
            self.min_fundamental_share
        )
    }
}

/// A turning point of `a` along the branch (loops from internal resonances).
#[derive(Debug, Clone, PartialEq)]
pub struct Fold {
    /// Index of the branch point nearest to the fold.
    pub index: usize,
    pub kind: FoldKind,
    pub amplitude: f64,
    pub omega_rad_s: f64,
    /// For an [`FoldKind::AmplitudeMaximum`]: the internal resonance of the
    /// loop that starts there, identified from the harmonic energy
    /// distribution between it and the next amplitude minimum.
    pub internal_resonance: Option<InternalResonance>,
}

/// Full nonlinear-mode branch including loops/folds.
#[derive(Debug, Clone, PartialEq)]
pub struct NmaResult {
    pub harmonics: usize,
    pub samples: usize,
    pub mode_index: usize,
    pub conservative: bool,
    /// Linear natural frequency of the continued mode [rad/s].
    pub linear_omega_rad_s: f64,
    /// Linear modal damping ratio of the continued mode (0 if conservative).
    pub linear_damping_ratio: f64,
    /// Names of the stored points (order of [`BranchPoint::points`]).
    pub point_names: Vec<String>,
    pub branch: Vec<BranchPoint>,
    pub folds: Vec<Fold>,
    /// Total Newton iterations (including the start point and rejected steps).
    pub newton_iterations: usize,
    /// Rejected continuation steps (failed or jumped correctors).
    pub rejected_steps: usize,
    /// Why the continuation stopped (`None` if it failed).
    pub stop: Option<StopReason>,
    pub warnings: Vec<NmaWarning>,
}

/// Which part of the branch goes into a [`ModalTable`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TablePolicy {
    /// The primary branch up to the first turning point of `a` (default).
    #[default]
    PrimaryBranch,
    /// All points whose `a` exceeds every earlier one: steps over loops and
    /// continues on the branch beyond them (a jump in the table at each loop).
    SkipLoops,
}

impl NmaResult {
    pub fn n_points(&self) -> usize {
        self.branch.len()
    }

    /// Index of a stored named point.
    pub fn point_index(&self, name: &str) -> Option<usize> {
        self.point_names.iter().position(|p| p == name)
    }

    /// `|q_{point,1}| = a |phi_1(point)|` [m] along the branch, e.g. `|q_tip,1|`
    /// of the paper's backbone figure.
    pub fn point_fundamental_amplitude(&self, name: &str) -> Option<Vec<f64>> {
        let p = self.point_index(name)?;
        Some(
            self.branch
                .iter()
                .map(|b| b.amplitude * b.points[p][1].norm())
                .collect(),
        )
    }

    /// First fold of the amplitude (where the default table is truncated).
    pub fn first_fold(&self) -> Option<&Fold> {
        self.folds.first()
    }

    /// Indices of the branch points that go into the table under `policy`.
    pub fn table_indices(&self, policy: TablePolicy) -> (Vec<usize>, Option<f64>) {
        let mut idx = Vec::new();
        let mut amax = f64::NEG_INFINITY;
        let mut truncated = None;
        for (i, b) in self.branch.iter().enumerate() {
            if b.amplitude > amax {
                idx.push(i);
                amax = b.amplitude;
            } else {
                match policy {
                    TablePolicy::PrimaryBranch => {
                        truncated = Some(amax);
                        break;
                    }
                    TablePolicy::SkipLoops => {
                        truncated.get_or_insert(amax);
                    }
                }
            }
        }
        (idx, truncated)
    }

    /// The modal table (`a` strictly increasing) with the shape harmonics at
    /// every stored point and of all generalized coordinates (if stored).
    pub fn to_table(&self, policy: TablePolicy) -> ModalTable {
        let (idx, truncated) = self.table_indices(policy);
        let pts: Vec<&BranchPoint> = idx.iter().map(|&i| &self.branch[i]).collect();
        self.table_of(&pts, truncated, policy)
    }

    /// The table of the points `pts` (strictly increasing `a`).
    fn table_of(
        &self,
        pts: &[&BranchPoint],
        truncated: Option<f64>,
        policy: TablePolicy,
    ) -> ModalTable {
        let shape = |name: String, get: &dyn Fn(&BranchPoint) -> &Vec<Complex64>| PointShape {
            name,
            re: pts
                .iter()
                .map(|b| get(b).iter().map(|c| c.re).collect())
                .collect(),
            im: pts
                .iter()
                .map(|b| get(b).iter().map(|c| c.im).collect())
                .collect(),
        };
        let points = (0..self.point_names.len())
            .map(|p| shape(self.point_names[p].clone(), &|b: &BranchPoint| &b.points[p]))
            .collect();
        let ncoord = self
            .branch
            .first()
            .map(|b| b.coordinates.len())
            .unwrap_or(0);
        let coordinates = (0..ncoord)
            .map(|i| shape(format!("q{i}"), &|b: &BranchPoint| &b.coordinates[i]))
            .collect();
        let mut description = format!(
            "EPMC nonlinear mode {} (0-based) by Harmonic Balance, H = {}, {} AFT samples, {}; linear omega = {} rad/s, D = {}; {} of {} branch points",
            self.mode_index,
            self.harmonics,
            self.samples,
            if self.conservative { "conservative" } else { "damped" },
            self.linear_omega_rad_s,
            self.linear_damping_ratio,
            pts.len(),
            self.branch.len()
        );
        if let Some(a) = truncated {
            description += &match policy {
                TablePolicy::PrimaryBranch => {
                    format!("; primary branch truncated at the first fold of a = {a:e}")
                }
                TablePolicy::SkipLoops => format!("; loops skipped, first fold at a = {a:e}"),
            };
        }
        ModalTable {
            format: MODAL_TABLE_FORMAT.to_string(),
            version: MODAL_TABLE_VERSION,
            description,
            harmonics: self.harmonics,
            amplitude: pts.iter().map(|b| b.amplitude).collect(),
            omega_rad_s: pts.iter().map(|b| b.omega_rad_s).collect(),
            damping_ratio: pts.iter().map(|b| b.damping_ratio).collect(),
            points,
            coordinates,
            truncated_at_fold: truncated,
            accuracy: None,
        }
    }
}

/// Targets of [`NmaResult::refined_table`] (serialisable; missing keys take
/// the defaults): `omega_rel = 1e-5`, `rel = 1e-4` (damping ratio and point
/// shapes), `max_points = 400` (the cap on table points), `fold_margin = 0.01`
/// (a primary branch cut at its first fold `a_f` is tabulated up to
/// `(1 - fold_margin) a_f`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RefineOptions {
    /// Relative accuracy target of `omega(a)`.
    pub omega_rel: f64,
    /// Relative accuracy target of `D(a)` and of the point shapes.
    pub rel: f64,
    /// Largest number of table points; refinement stops there (recorded as
    /// [`TableAccuracy::capped`]).
    pub max_points: usize,
    /// Relative distance from the first fold `a_f` at which a truncated
    /// primary branch ([`TablePolicy::PrimaryBranch`]) ends: the last table
    /// point is the HB solution at `(1 - fold_margin) a_f` [-]. At the fold
    /// itself `omega(a)` has a vertical tangent, so intervals reaching it
    /// cannot meet the targets; `0` tabulates up to the last branch point.
    pub fold_margin: f64,
}

impl Default for RefineOptions {
    fn default() -> Self {
        Self {
            omega_rel: 1e-5,
            rel: 1e-4,
            max_points: 400,
            fold_margin: 0.01,
        }
    }
}

/// PCHIP errors of `interp` at `a` against the HB solution `sol`: relative
/// `omega`, relative `D` (against `max(|D|, 1e-10)`), largest point-shape
/// error relative to the point's largest harmonic.
pub fn table_errors(
    interp: &crate::table::TableInterpolator,
    sol: &BranchPoint,
) -> Result<(f64, f64, f64), crate::table::TableError> {
    let a = sol.amplitude;
    let p = interp.eval(a)?;
    let e_w = (p.omega_rad_s / sol.omega_rad_s - 1.0).abs();
    let e_d = (p.damping_ratio - sol.damping_ratio).abs() / sol.damping_ratio.abs().max(1e-10);
    let mut e_s: f64 = 0.0;
    let mut buf = vec![Complex64::new(0.0, 0.0); interp.harmonics() + 1];
    for (k, shape) in sol.points.iter().enumerate() {
        interp.shape_all(k, a, &mut buf)?;
        let scale = shape
            .iter()
            .map(|c| c.norm())
            .fold(0.0, f64::max)
            .max(1e-300);
        for (x, y) in buf.iter().zip(shape) {
            e_s = e_s.max((x - y).norm() / scale);
        }
    }
    Ok((e_w, e_d, e_s))
}

impl NmaResult {
    /// The modal table under `policy`, refined to a stated accuracy: the PCHIP
    /// interpolation is compared with fresh Harmonic Balance solves
    /// ([`solve_at_amplitude`], paper normalisation) at the midpoint of every
    /// interval, and each solve that misses a target is inserted, until
    /// `omega` is within `refine.omega_rel / 2` and `D` and the shapes within
    /// `refine.rel / 2` at every midpoint (half the target: the midpoint error
    /// underestimates the largest error of an interval), or the table has
    /// `refine.max_points`, or an interval is too narrow to split in floating
    /// point (next to a fold; both end the refinement there with `capped`).
    /// Intervals whose PCHIP slopes change by an insertion are checked again
    /// (against their midpoint solution, which stays valid while the
    /// interval's end points do), so [`ModalTable::accuracy`] holds the
    /// midpoint errors of the final table. The midpoint solves are converged
    /// HB solutions (tolerance of `opts.continuation`) by chord Newton
    /// ([`super::continuation::solve_fixed_parameter_chord`]: one
    /// factorisation per check from the close PCHIP guess).
    ///
    /// `model`, `basis` and `opts` are those of the analysis; the branch must
    /// have been computed with `store_coordinates` (the Newton guesses).
    pub fn refined_table(
        &self,
        model: &StructuralModel,
        basis: Arc<ModalBasis>,
        opts: &NmaOptions,
        policy: TablePolicy,
        refine: &RefineOptions,
    ) -> Result<ModalTable, NmaError> {
        let (idx, truncated) = self.table_indices(policy);
        let mut pts: Vec<BranchPoint> = idx.iter().map(|&i| self.branch[i].clone()).collect();
        if pts.iter().any(|b| b.coordinates.is_empty()) {
            return Err(NmaError::RefinementNeedsCoordinates);
        }
        let fixed = NmaOptions {
            normalisation: Normalisation::Fundamental,
            store_coordinates: true,
            points: self.point_names.clone(),
            ..opts.clone()
        };
        let solver = AmplitudeSolver {
            chord: true,
            ..AmplitudeSolver::new(model, basis.clone(), &fixed)?
        };
        // end a truncated primary branch a stated margin before the fold
        let mut range_end = None;
        if let (Some(a_f), TablePolicy::PrimaryBranch) = (truncated, policy) {
            let m = refine.fold_margin;
            if !(0.0..1.0).contains(&m) {
                return Err(NmaError::InvalidFoldMargin { fold_margin: m });
            }
            if m > 0.0 {
                let a_end = (1.0 - m) * a_f;
                let keep = pts.iter().take_while(|b| b.amplitude < a_end).count();
                if keep >= 1 {
                    // Newton from the nearest branch point above (else below)
                    let guess = pts.get(keep).unwrap_or(&pts[keep - 1]).clone();
                    let sol = solver
                        .solve(a_end, &guess)
                        .or_else(|_| solver.solve(a_end, &pts[keep - 1]))
                        .map_err(|e| refine_failed(e, a_end))?;
                    pts.truncate(keep);
                    pts.push(sol);
                    range_end = Some(a_end);
                }
            }
        }
        let n_int = pts.len().saturating_sub(1);
        // per interval: checked against the current table, and its errors
        let mut checked = vec![false; n_int];
        let mut errors = vec![(0.0, 0.0, 0.0); n_int];
        // per interval: its midpoint HB solution once solved (it stays valid
        // while the interval's end points do; a re-check after a neighbour's
        // insertion only measures the new interpolant against it)
        let mut mids: Vec<Option<BranchPoint>> = vec![None; n_int];
        let mut checks = 0;
        let mut capped = false;
        loop {
            let refs: Vec<&BranchPoint> = pts.iter().collect();
            let table = self.table_of(&refs, truncated, policy);
            let interp = table
                .interpolator()
                .map_err(|e| NmaError::Table(e.to_string()))?;
            // the unchecked intervals' HB solves are independent of each
            // other: solved in parallel, then taken in interval order (the
            // table is the same for any number of threads)
            let unsolved: Vec<usize> = (0..pts.len().saturating_sub(1))
                .filter(|&i| !checked[i] && mids[i].is_none())
                .collect();
            let mut solved = unsolved
                .par_iter()
                .map(|&i| check_interval(&solver, &interp, &pts[i], &pts[i + 1]))
                .collect::<Vec<_>>()
                .into_iter();
            let mut next: Vec<BranchPoint> = Vec::with_capacity(2 * pts.len());
            let mut next_checked = Vec::new();
            let mut next_errors = Vec::new();
            let mut next_mids = Vec::new();
            let mut inserted = Vec::new();
            for i in 0..pts.len().saturating_sub(1) {
                next.push(pts[i].clone());
                if checked[i] {
                    next_checked.push(true);
                    next_errors.push(errors[i]);
                    next_mids.push(mids[i].take());
                    continue;
                }
                let (p, q) = (&pts[i], &pts[i + 1]);
                let (sol, err) = match mids[i].take() {
                    Some(sol) => {
                        let err = table_errors(&interp, &sol)
                            .map_err(|e| NmaError::Table(e.to_string()))?;
                        (sol, err)
                    }
                    None => {
                        checks += 1;
                        solved.next().expect("one solve per unsolved interval")?
                    }
                };
                // the midpoint error underestimates an interval's largest
                // error (PCHIP's error is not symmetric): ask half the target
                let good = err.0 <= 0.5 * refine.omega_rel
                    && err.1 <= 0.5 * refine.rel
                    && err.2 <= 0.5 * refine.rel;
                // an interval too narrow to split in floating point (next to
                // the fold, where omega(a) has an infinite slope) stays as is
                let narrow = !(sol.amplitude > p.amplitude && sol.amplitude < q.amplitude);
                if good || narrow || pts.len() + inserted.len() >= refine.max_points {
                    capped |= !good;
                    next_checked.push(true);
                    next_errors.push(err);
                    next_mids.push(Some(sol));
                } else {
                    inserted.push(next.len());
                    next.push(sol);
                    next_checked.extend([false, false]);
                    next_errors.extend([err, err]);
                    next_mids.extend([None, None]);
                }
            }
            if let Some(last) = pts.last() {
                next.push(last.clone());
            }
            if inserted.is_empty() {
                errors = next_errors;
                break;
            }
            // PCHIP slopes at the nodes next to an insertion change: check the
            // neighbouring intervals again
            for &node in &inserted {
                if node >= 2 {
                    next_checked[node - 2] = false;
                }
                if node + 1 < next_checked.len() {
                    next_checked[node + 1] = false;
                }
            }
            pts = next;
            checked = next_checked;
            errors = next_errors;
            mids = next_mids;
        }
        let refs: Vec<&BranchPoint> = pts.iter().collect();
        let mut table = self.table_of(&refs, truncated, policy);
        let worst = errors.iter().fold((0.0f64, 0.0f64, 0.0f64), |w, e| {
            (w.0.max(e.0), w.1.max(e.1), w.2.max(e.2))
        });
        if let Some(a_end) = range_end {
            table.description += &format!(
                "; tabulated up to a = {a_end:e} = (1 - {}) times the first fold",
                refine.fold_margin
            );
        }
        table.description += &format!(
            "; refined to {} points: PCHIP vs HB at every interval midpoint within omega {:.1e}, D {:.1e}, shapes {:.1e} (relative){}",
            pts.len(),
            worst.0,
            worst.1,
            worst.2,
            if capped { ", capped" } else { "" }
        );
        table.accuracy = Some(TableAccuracy {
            omega_rel: worst.0,
            damping_rel: worst.1,
            shape_rel: worst.2,
            target_omega_rel: refine.omega_rel,
            target_rel: refine.rel,
            checks,
            capped,
            fold_margin: range_end.map(|_| refine.fold_margin),
        });
        Ok(table)
    }
}

/// A failed Newton solve of the refinement at amplitude `a` as
/// Default AFT samples of a model with a hysteretic element (Jenkins): a sample
/// switching between stick and slip is a corner of the nonlinear-mode branch,
/// and with `4H+1` samples these corners are so large that Newton cycles across
/// them near the maximum of `D(a)`; 256 samples pass them (and put the sampled
/// loop's describing function within ~1e-5 of the exact one).
pub const HYSTERETIC_DEFAULT_SAMPLES: usize = 256;

/// The continuation options for `model`: as given, but for a model with a
/// hysteretic element `dsmin` defaults to `1e-4 ds` (the stick-slip transition
/// is a corner of the branch, passed at `dsmin`, and `D(a)` turns sharply at its
/// maximum).
fn continuation_for(model: &StructuralModel, c: &ContinuationOptions) -> ContinuationOptions {
    let mut c = c.clone();
    if has_hysteresis(model) && c.dsmin.is_none() {
        c.dsmin = Some(1e-4 * c.ds);
    }
    c
}

/// [`NmaError::RefinementSolveFailed`].
fn refine_failed(e: NmaError, amplitude: f64) -> NmaError {
    match e {
        NmaError::StartNotConverged {
            residual_norm,
            iterations,
            ..
        } => NmaError::RefinementSolveFailed {
            amplitude,
            residual_norm,
            iterations,
        },
        other => other,
    }
}

/// Whether any nonlinear element of `model` is hysteretic.
fn has_hysteresis(model: &StructuralModel) -> bool {
    model.nonlinear.iter().any(|e| e.law.hysteresis().is_some())
}

/// The AFT samples: `samples`, by default `4H+1`, and at least
/// [`HYSTERETIC_DEFAULT_SAMPLES`] for a model with a hysteretic element.
fn check_harmonics(
    model: &StructuralModel,
    harmonics: usize,
    samples: Option<usize>,
) -> Result<usize, NmaError> {
    if harmonics == 0 {
        return Err(NmaError::NoHarmonics { harmonics });
    }
    let minimum = default_samples(harmonics);
    let samples = samples.unwrap_or(if has_hysteresis(model) {
        minimum.max(HYSTERETIC_DEFAULT_SAMPLES)
    } else {
        minimum
    });
    if samples < minimum {
        return Err(NmaError::TooFewSamples {
            samples,
            harmonics,
            minimum,
        });
    }
    Ok(samples)
}

/// Indices of the named points (every point of the model when `names` is empty).
fn point_indices(model: &StructuralModel, names: &[String]) -> Result<Vec<usize>, NmaError> {
    if names.is_empty() {
        Ok((0..model.points.len()).collect())
    } else {
        names.iter().map(|p| find_point(model, p)).collect()
    }
}

/// Modal direction vectors `Phi^T d_p` of the points `ids`.
fn modal_directions(
    model: &StructuralModel,
    basis: &ModalBasis,
    ids: &[usize],
) -> Vec<DVector<f64>> {
    ids.iter()
        .map(|&p| basis.phi.transpose() * &model.points[p].direction)
        .collect()
}

fn find_point(model: &StructuralModel, name: &str) -> Result<usize, NmaError> {
    model
        .points
        .iter()
        .position(|p| p.name == name)
        .ok_or_else(|| NmaError::UnknownPoint {
            name: name.to_string(),
            available: model
                .points
                .iter()
                .map(|p| p.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        })
}

/// Nonlinear modal analysis by the EPMC (`eq:EPMC`) with Harmonic Balance and
/// arc-length continuation in `log10 a`, starting from the linear mode.
///
/// Returns the full branch (loops included, folds of `a` reported); use
/// [`NmaResult::to_table`] for the modal table. On a continuation failure the
/// error carries the computed part of the branch.
pub fn nonlinear_modal_analysis(
    model: &StructuralModel,
    opts: &NmaOptions,
) -> Result<NmaResult, NmaError> {
    check_harmonics(model, opts.harmonics, opts.samples)?;
    let n = model.mass.nrows();
    if opts.mode_index >= n {
        return Err(NmaError::ModeIndexOutOfRange {
            mode_index: opts.mode_index,
            n_modes: n,
        });
    }
    let basis = Arc::new(ModalBasis::new(model, opts.conservative)?);
    nonlinear_modal_analysis_with_basis(model, basis, opts)
}

/// [`nonlinear_modal_analysis`] with the linear modes of `model` computed
/// beforehand (`ModalBasis::new(model, opts.conservative)`), e.g. to reuse
/// them or to time the continuation alone. Panics if `basis` does not belong
/// to `model` / `opts.conservative`.
pub fn nonlinear_modal_analysis_with_basis(
    model: &StructuralModel,
    basis: Arc<ModalBasis>,
    opts: &NmaOptions,
) -> Result<NmaResult, NmaError> {
    let samples = check_harmonics(model, opts.harmonics, opts.samples)?;
    let n = model.mass.nrows();
    assert_eq!(basis.n_modes(), n, "modal basis of another model");
    assert_eq!(
        basis.w.ncols(),
        model.nonlinear.len(),
        "modal basis of another model"
    );
    assert_eq!(
        basis.conservative, opts.conservative,
        "modal basis with the other damping option"
    );
    if opts.mode_index >= n {
        return Err(NmaError::ModeIndexOutOfRange {
            mode_index: opts.mode_index,
            n_modes: n,
        });
    }
    let point_ids = point_indices(model, &opts.points)?;
    let j = opts.mode_index;
    let res = EpmcResidual::new(basis.clone(), opts.harmonics, samples, j)
        .with_normalisation(opts.normalisation);
    let point_modal = modal_directions(model, &basis, &point_ids);

    // amplitude range in log10 a
    let (lg_start, lg_end, stop_point) = match &opts.amplitude {
        AmplitudeRange::Modal {
            log10_start,
            log10_end,
        } => {
            if !(log10_start.is_finite() && log10_end.is_finite()) || log10_end <= log10_start {
                return Err(NmaError::InvalidAmplitudeRange {
                    start: *log10_start,
                    end: *log10_end,
                    reason: "need finite log10 bounds with end > start",
                });
            }
            (*log10_start, *log10_end, None)
        }
        AmplitudeRange::Point {
            name,
            start_m,
            end_m,
        } => {
            if !(*start_m > 0.0 && end_m > start_m && end_m.is_finite()) {
                return Err(NmaError::InvalidAmplitudeRange {
                    start: *start_m,
                    end: *end_m,
                    reason: "need 0 < start_m < end_m",
                });
            }
            let pid = find_point(model, name)?;
            let c = (basis.phi.column(j).dot(&model.points[pid].direction)).abs();
            if c <= 1e-12 * basis.phi.column(j).amax() * model.points[pid].direction.norm() {
                return Err(NmaError::PointAtNode {
                    name: name.clone(),
                    mode_index: j,
                    value: c,
                });
            }
            let em = basis.phi.transpose() * &model.points[pid].direction;
            (
                (start_m / c).log10(),
                (end_m / c).log10() + 3.0,
                Some((em, *end_m)),
            )
        }
    };

    let omega0 = basis.omega(j);
    let d0 = basis.damping_ratio(j);
    let m = res.n_coeffs();
    let mut scale = DVector::from_element(m + 3, 1.0);
    scale[m] = omega0.abs().max(1e-12);
    scale[m + 1] = d0.abs().max(1e-3);
    scale[m + 2] = 1.0;

    let mut result = NmaResult {
        harmonics: opts.harmonics,
        samples,
        mode_index: j,
        conservative: opts.conservative,
        linear_omega_rad_s: omega0,
        linear_damping_ratio: d0,
        point_names: point_ids
            .iter()
            .map(|&p| model.points[p].name.clone())
            .collect(),
        branch: vec![],
        folds: vec![],
        newton_iterations: 0,
        rejected_steps: 0,
        stop: None,
        warnings: vec![],
    };
    let mut stop_reached = false;
    let mut share_stop = false;
    let mut tangent_sign: Vec<f64> = Vec::new();
    let bp_share = |r: &NmaResult| {
        r.branch
            .last()
            .map(|b| b.fundamental_energy_share)
            .unwrap_or(1.0)
    };
    let mut end_omega_reached = false;
    let mut last_step = 0.0;
    let mut max_amplitude = f64::NEG_INFINITY;
    let on_point = |s: &BranchState| -> bool {
        last_step = s.step;
        let bp = branch_point(
            &res,
            s.x,
            &point_modal,
            opts.store_coordinates,
            s.newton_iterations,
        );
        let x = &res.to_fundamental(s.x);
        // the criterion of `table_indices`: `a` no longer above every earlier one
        let below_fold = bp.amplitude <= max_amplitude;
        max_amplitude = max_amplitude.max(bp.amplitude);
        result.branch.push(bp);
        tangent_sign.push(s.tangent[m + 2].signum());
        if opts.normalisation == Normalisation::Fundamental
            && s.index > 0
            && bp_share(&result) < opts.min_fundamental_share
        {
            share_stop = true;
            return false;
        }
        if let Some(end) = opts.end_omega_over_omega0 {
            if x[m] >= end * omega0 {
                end_omega_reached = true;
                return false;
            }
        }
        if opts.stop_at_first_fold && below_fold {
            return false;
        }
        if let Some((em, end_m)) = &stop_point {
            let amp = 10f64.powf(x[m + 2]) * res.observe(x, em)[1].norm();
            if amp >= *end_m {
                stop_reached = true;
                return false;
            }
        }
        true
    };
    let outcome = continuation(
        &res,
        res.linear_guess(lg_start),
        lg_end,
        &scale,
        &continuation_for(model, &opts.continuation),
        on_point,
    );
    let summary = match &outcome {
        Ok(s) => s.clone(),
        Err((_, s)) => s.clone(),
    };
    if opts.normalisation == Normalisation::Fundamental {
        finish(&mut result, &summary, &tangent_sign);
    } else {
        finish_from_amplitudes(&mut result, &summary);
    }
    identify_internal_resonances(&mut result);
    if let Some(end) = opts.end_omega_over_omega0 {
        if !end_omega_reached {
            if let Some(b) = result.branch.last() {
                result.warnings.push(NmaWarning::EndFrequencyNotReached {
                    end_omega_rad_s: end * omega0,
                    amplitude: b.amplitude,
                    omega_rad_s: b.omega_rad_s,
                    share: b.fundamental_energy_share,
                    step: last_step,
                });
            }
        }
    }
    match outcome {
        Ok(s) => {
            result.stop = Some(s.stop);
            let last_a = result
                .branch
                .last()
                .map(|b| b.amplitude)
                .unwrap_or(f64::NAN);
            match s.stop {
                StopReason::MaxPoints => result.warnings.push(NmaWarning::MaxPointsReached {
                    points: s.points,
                    amplitude: last_a,
                }),
                StopReason::LeftRange => result
                    .warnings
                    .push(NmaWarning::LeftRange { amplitude: last_a }),
                StopReason::ReachedEnd => {}
                StopReason::Callback => {
                    if share_stop {
                        let b = result.branch.last().expect("stopped at a computed point");
                        result.warnings.push(NmaWarning::FundamentalLost {
                            amplitude: b.amplitude,
                            omega_rad_s: b.omega_rad_s,
                            share: b.fundamental_energy_share,
                        });
                    }
                    let _ = stop_reached;
                }
            }
            Ok(result)
        }
        Err((failure, _)) => {
            let last = result
                .branch
                .last()
                .map(|b| (b.amplitude, b.omega_rad_s))
                .unwrap_or((f64::NAN, f64::NAN));
            let partial = Box::new(result);
            Err(match failure {
                ContinuationFailure::StartNotConverged {
                    parameter,
                    residual_norm,
                    iterations,
                } => NmaError::StartNotConverged {
                    amplitude: 10f64.powf(parameter),
                    residual_norm,
                    iterations,
                    partial,
                },
                ContinuationFailure::StepSizeCollapse {
                    residual_norm,
                    step_size,
                    dsmin,
                    ..
                } => NmaError::StepSizeCollapse {
                    amplitude: last.0,
                    omega_rad_s: last.1,
                    residual_norm,
                    step_size,
                    dsmin,
                    partial,
                },
                ContinuationFailure::SingularJacobian { .. } => NmaError::SingularJacobian {
                    amplitude: last.0,
                    partial,
                },
            })
        }
    }
}

/// The branch point of a converged solution `x` of `res` (any
/// [`Normalisation`]): amplitude, frequency, damping, energy shares and the
/// shape harmonics in the paper's normalisation.
fn branch_point(
    res: &EpmcResidual,
    x_native: &DVector<f64>,
    point_modal: &[DVector<f64>],
    store_coordinates: bool,
    newton_iterations: usize,
) -> BranchPoint {
    let j = res.mode();
    let n = res.basis().n_modes();
    let m = res.n_coeffs();
    let x = &res.to_fundamental(x_native);
    let shares = res.harmonic_energy_shares(x_native);
    let mut secondary = EnergyComponent {
        harmonic: 1,
        mode_index: j,
        share: 0.0,
    };
    for (nn, row) in shares.iter().enumerate() {
        for (k, &e) in row.iter().enumerate() {
            if (nn, k) != (1, j) && e > secondary.share {
                secondary = EnergyComponent {
                    harmonic: nn,
                    mode_index: k,
                    share: e,
                };
            }
        }
    }
    BranchPoint {
        amplitude: 10f64.powf(x[m + 2]),
        omega_rad_s: x[m],
        damping_ratio: x[m + 1],
        newton_iterations,
        fundamental_energy_share: res.fundamental_energy_share(x),
        harmonic_energy_shares: shares.iter().map(|r| r.iter().sum()).collect(),
        secondary,
        points: point_modal.iter().map(|e| res.observe(x, e)).collect(),
        coordinates: if store_coordinates {
            let h = res.shape_harmonics(x);
            (0..n).map(|i| h.iter().map(|hn| hn[i]).collect()).collect()
        } else {
            vec![]
        },
    }
}

/// A direct Harmonic Balance solve of the EPMC at the fixed modal amplitude
/// `amplitude` (paper normalisation, [`Normalisation::Fundamental`], Newton
/// from `guess`, which must carry the generalized-coordinate shapes, e.g. a
/// branch point computed with `store_coordinates`): the independent check of
/// continuation points and the solver behind table refinement. Uses
/// `opts.harmonics`, `opts.samples`, `opts.mode_index`, `opts.conservative`,
/// `opts.points`, `opts.store_coordinates` and `opts.continuation`'s Newton
/// settings.
pub fn solve_at_amplitude(
    model: &StructuralModel,
    basis: Arc<ModalBasis>,
    opts: &NmaOptions,
    amplitude: f64,
    guess: &BranchPoint,
) -> Result<BranchPoint, NmaError> {
    AmplitudeSolver::new(model, basis, opts)?.solve(amplitude, guess)
}

/// [`solve_at_amplitude`] set up once for many amplitudes (the residual with
/// its AFT, the points' modal directions, `Phi^T M`): the refinement of a
/// table solves at every interval's midpoint.
/// The HB solution at the midpoint amplitude of the interval `p`-`q` and the
/// PCHIP errors of `interp` there ([`NmaResult::refined_table`]).
fn check_interval(
    solver: &AmplitudeSolver,
    interp: &crate::table::TableInterpolator,
    p: &BranchPoint,
    q: &BranchPoint,
) -> Result<(BranchPoint, (f64, f64, f64)), NmaError> {
    let am = 0.5 * (p.amplitude + q.amplitude);
    // frequency and damping from the table being checked (close to the
    // solution: fewer Newton steps), shapes blended
    let (omega_rad_s, damping_ratio) = match interp.eval(am) {
        Ok(t) => (t.omega_rad_s, t.damping_ratio),
        Err(_) => (
            0.5 * (p.omega_rad_s + q.omega_rad_s),
            0.5 * (p.damping_ratio + q.damping_ratio),
        ),
    };
    let guess = BranchPoint {
        omega_rad_s,
        damping_ratio,
        coordinates: p
            .coordinates
            .iter()
            .zip(&q.coordinates)
            .map(|(u, v)| u.iter().zip(v).map(|(x, y)| 0.5 * (x + y)).collect())
            .collect(),
        ..p.clone()
    };
    // Newton from the blended neighbours, else from either one (near the
    // fold ending the primary branch `omega(a)` is steep)
    let sol = solver
        .solve(am, &guess)
        .or_else(|_| solver.solve(am, q))
        .or_else(|_| solver.solve(am, p))
        .map_err(|e| refine_failed(e, am))?;
    let err = table_errors(interp, &sol).map_err(|e| NmaError::Table(e.to_string()))?;
    Ok((sol, err))
}

struct AmplitudeSolver<'a> {
    model: &'a StructuralModel,
    opts: &'a NmaOptions,
    samples: usize,
    point_ids: Vec<usize>,
    res: EpmcResidual,
    point_modal: Vec<DVector<f64>>,
    pm: nalgebra::DMatrix<f64>,
    continuation: ContinuationOptions,
    /// Chord (simplified) Newton ([`super::continuation::solve_fixed_parameter_chord`])
    /// instead of Newton: the refinement's checks, started close to the solution.
    chord: bool,
}

impl<'a> AmplitudeSolver<'a> {
    fn new(
        model: &'a StructuralModel,
        basis: Arc<ModalBasis>,
        opts: &'a NmaOptions,
    ) -> Result<Self, NmaError> {
        let samples = check_harmonics(model, opts.harmonics, opts.samples)?;
        let point_ids = point_indices(model, &opts.points)?;
        let res = EpmcResidual::new(basis.clone(), opts.harmonics, samples, opts.mode_index);
        let point_modal = modal_directions(model, &basis, &point_ids);
        // modal coordinates eta_n = Phi^T M q_n of a guess (q_n = c_n - i s_n)
        let pm = basis.phi.transpose() * &model.mass;
        let continuation = ContinuationOptions {
            max_contraction: None,
            ..opts.continuation.clone()
        };
        Ok(Self {
            model,
            opts,
            samples,
            point_ids,
            res,
            point_modal,
            pm,
            continuation,
            chord: false,
        })
    }

    fn solve(&self, amplitude: f64, guess: &BranchPoint) -> Result<BranchPoint, NmaError> {
        let (model, opts, res) = (self.model, self.opts, &self.res);
        let n = model.mass.nrows();
        if guess.coordinates.len() != n {
            return Err(NmaError::InvalidAmplitudeRange {
                start: amplitude,
                end: amplitude,
                reason: "the guess carries no generalized-coordinate shapes",
            });
        }
        let m = res.n_coeffs();
        let mut x0 = DVector::zeros(m + 3);
        for nn in 0..=opts.harmonics {
            let re = DVector::from_fn(n, |i, _| guess.coordinates[i][nn].re);
            let im = DVector::from_fn(n, |i, _| guess.coordinates[i][nn].im);
            let (c, s) = (&self.pm * re, &self.pm * im);
            for k in 0..n {
                x0[super::hb::cos_index(nn) * n + k] = c[k];
                if nn > 0 {
                    x0[super::hb::sin_index(nn) * n + k] = -s[k];
                }
            }
        }
        x0[m] = guess.omega_rad_s;
        x0[m + 1] = guess.damping_ratio;
        x0[m + 2] = amplitude.log10();
        let solved = if self.chord {
            super::continuation::solve_fixed_parameter_chord(res, x0, &self.continuation)
        } else {
            super::continuation::solve_fixed_parameter(res, x0, &self.continuation)
                .map(|(x, _, it)| (x, it, it))
        };
        match solved {
            Ok((x, it, _)) => Ok(branch_point(
                res,
                &x,
                &self.point_modal,
                opts.store_coordinates,
                it,
            )),
            Err((residual_norm, iterations)) => Err(NmaError::StartNotConverged {
                amplitude,
                residual_norm,
                iterations,
                partial: Box::new(NmaResult {
                    harmonics: opts.harmonics,
                    samples: self.samples,
                    mode_index: opts.mode_index,
                    conservative: opts.conservative,
                    linear_omega_rad_s: res.basis().omega(opts.mode_index),
                    linear_damping_ratio: res.basis().damping_ratio(opts.mode_index),
                    point_names: self
                        .point_ids
                        .iter()
                        .map(|&p| model.points[p].name.clone())
                        .collect(),
                    branch: vec![],
                    folds: vec![],
                    newton_iterations: iterations,
                    rejected_steps: 0,
                    stop: None,
                    warnings: vec![],
                }),
            }),
        }
    }
}

/// Folds, iteration count and the linear-regime warning from the summary.
fn finish(result: &mut NmaResult, summary: &ContinuationSummary, tangent_sign: &[f64]) {
    result.newton_iterations = summary.newton_iterations;
    result.rejected_steps = summary.rejected_steps;
    for &i in &summary.turning_points {
        if i == 0 || i >= result.branch.len() {
            continue;
        }
        let (p, q) = (&result.branch[i - 1], &result.branch[i]);
        // the parameter log10 a was increasing before the turning point
        let kind = if tangent_sign[i - 1] > 0.0 {
            FoldKind::AmplitudeMaximum
        } else {
            FoldKind::AmplitudeMinimum
        };
        let index = match kind {
            FoldKind::AmplitudeMaximum if p.amplitude >= q.amplitude => i - 1,
            FoldKind::AmplitudeMinimum if p.amplitude <= q.amplitude => i - 1,
            _ => i,
        };
        let b = &result.branch[index];
        result.folds.push(Fold {
            index,
            kind,
            amplitude: b.amplitude,
            omega_rad_s: b.omega_rad_s,
            internal_resonance: None,
        });
    }
    linear_regime_warning(result);
}

/// [`finish`] for a continuation parameter other than `log10 a`: the folds of
/// `a` are the local extrema of the computed amplitudes.
fn finish_from_amplitudes(result: &mut NmaResult, summary: &ContinuationSummary) {
    result.newton_iterations = summary.newton_iterations;
    result.rejected_steps = summary.rejected_steps;
    let a: Vec<f64> = result.branch.iter().map(|b| b.amplitude).collect();
    let mut rising = true;
    for i in 1..a.len() {
        let kind = if rising && a[i] < a[i - 1] {
            rising = false;
            FoldKind::AmplitudeMaximum
        } else if !rising && a[i] > a[i - 1] {
            rising = true;
            FoldKind::AmplitudeMinimum
        } else {
            continue;
        };
        let b = &result.branch[i - 1];
        result.folds.push(Fold {
            index: i - 1,
            kind,
            amplitude: b.amplitude,
            omega_rad_s: b.omega_rad_s,
            internal_resonance: None,
        });
    }
    linear_regime_warning(result);
}

/// The internal resonance of every loop (from an amplitude maximum to the next
/// minimum, or the branch end): the energy component other than the
/// fundamental that carries most energy at the point of least fundamental share.
fn identify_internal_resonances(result: &mut NmaResult) {
    let n_folds = result.folds.len();
    for f in 0..n_folds {
        if result.folds[f].kind != FoldKind::AmplitudeMaximum {
            continue;
        }
        let start = result.folds[f].index;
        let end = result.folds[f + 1..]
            .iter()
            .find(|g| g.kind == FoldKind::AmplitudeMinimum)
            .map(|g| g.index)
            .unwrap_or(result.branch.len() - 1);
        let Some(low) = (start..=end).min_by(|&p, &q| {
            result.branch[p]
                .fundamental_energy_share
                .total_cmp(&result.branch[q].fundamental_energy_share)
        }) else {
            continue;
        };
        let c = result.branch[low].secondary;
        let max_share = (start..=end)
            .map(|i| {
                let s = result.branch[i].secondary;
                if (s.harmonic, s.mode_index) == (c.harmonic, c.mode_index) {
                    s.share
                } else {
                    0.0
                }
            })
            .fold(0.0, f64::max);
        let lowest = (start..=end)
            .min_by(|&p, &q| {
                result.branch[p]
                    .amplitude
                    .total_cmp(&result.branch[q].amplitude)
            })
            .unwrap_or(low);
        result.folds[f].internal_resonance = Some(InternalResonance {
            harmonic: c.harmonic,
            mode_index: c.mode_index,
            max_share,
            min_fundamental_share: result.branch[low].fundamental_energy_share,
            omega_rad_s: result.branch[lowest].omega_rad_s,
        });
    }
}

/// The warning that the branch never left the linear regime.
fn linear_regime_warning(result: &mut NmaResult) {
    if let Some(first) = result.branch.first() {
        let mut omega_shift_rel: f64 = 0.0;
        let mut damping_shift: f64 = 0.0;
        let mut max_amplitude: f64 = 0.0;
        for b in &result.branch {
            omega_shift_rel = omega_shift_rel.max((b.omega_rad_s / first.omega_rad_s - 1.0).abs());
            damping_shift = damping_shift.max((b.damping_ratio - first.damping_ratio).abs());
            max_amplitude = max_amplitude.max(b.amplitude);
        }
        let d_ref = first.damping_ratio.abs().max(1e-6);
        if result.branch.len() > 1 && omega_shift_rel < 1e-4 && damping_shift < 1e-3 * d_ref {
            result.warnings.push(NmaWarning::LinearRegimeOnly {
                max_amplitude,
                omega_shift_rel,
                damping_shift,
            });
        }
    }
}

/// Options of [`forced_response`]: `M q'' + g(q, q') = f cos(Omega t)`.
#[derive(Debug, Clone, PartialEq)]
pub struct ForcedResponseOptions {
    pub harmonics: usize,
    pub samples: Option<usize>,
    /// Force amplitude vector `f` [N] in generalized coordinates.
    pub force: DVector<f64>,
    /// Excitation frequency range [rad/s] (either direction).
    pub omega_start: f64,
    pub omega_end: f64,
    pub continuation: ContinuationOptions,
    /// Named points whose response harmonics are stored; empty = all.
    pub points: Vec<String>,
}

/// One point of a forced frequency response.
#[derive(Debug, Clone, PartialEq)]
pub struct ForcedResponsePoint {
    pub omega_rad_s: f64,
    /// `points[p][n]`: complex harmonic `n` [m] at stored point `p`
    /// (`u(t) = Re(sum_n u_n e^{i n Omega t})`).
    pub points: Vec<Vec<Complex64>>,
    pub newton_iterations: usize,
}

/// A forced Harmonic Balance frequency response (turning points included).
#[derive(Debug, Clone, PartialEq)]
pub struct ForcedResponse {
    pub harmonics: usize,
    pub point_names: Vec<String>,
    pub points: Vec<ForcedResponsePoint>,
    /// Indices `i` with a turning point in `Omega` between points `i-1` and `i`.
    pub turning_points: Vec<usize>,
    pub newton_iterations: usize,
    pub stop: Option<StopReason>,
}

/// Harmonic Balance frequency response of the forced full model (for
/// validation of the single-nonlinear-mode model), by the same continuation.
pub fn forced_response(
    model: &StructuralModel,
    opts: &ForcedResponseOptions,
) -> Result<ForcedResponse, NmaError> {
    let samples = check_harmonics(model, opts.harmonics, opts.samples)?;
    let n = model.mass.nrows();
    if opts.force.len() != n {
        return Err(NmaError::ForceLength {
            got: opts.force.len(),
            expected: n,
        });
    }
    let valid = |w: f64| w > 0.0 && w.is_finite();
    if !valid(opts.omega_start) || !valid(opts.omega_end) || opts.omega_start == opts.omega_end {
        return Err(NmaError::InvalidFrequencyRange {
            start: opts.omega_start,
            end: opts.omega_end,
        });
    }
    let point_ids = point_indices(model, &opts.points)?;
    let basis = Arc::new(ModalBasis::new(model, false)?);
    let res = ForcedResidual::new(
        basis,
        opts.harmonics,
        samples,
        &opts.force,
        opts.omega_start,
    );
    let m = res.n_coeffs();
    // scale: largest linear response norm over the range, and the range width
    let mut eta_scale: f64 = 0.0;
    for i in 0..=200 {
        let om = opts.omega_start + (opts.omega_end - opts.omega_start) * i as f64 / 200.0;
        eta_scale = eta_scale.max(res.linear_guess(om).rows(0, m).amax());
    }
    let mut scale = DVector::from_element(m + 1, eta_scale.max(1e-300));
    scale[m] = (opts.omega_end - opts.omega_start).abs();
    let mut out = ForcedResponse {
        harmonics: opts.harmonics,
        point_names: point_ids
            .iter()
            .map(|&p| model.points[p].name.clone())
            .collect(),
        points: vec![],
        turning_points: vec![],
        newton_iterations: 0,
        stop: None,
    };
    let outcome = continuation(
        &res,
        res.linear_guess(opts.omega_start),
        opts.omega_end,
        &scale,
        &continuation_for(model, &opts.continuation),
        |s| {
            out.points.push(ForcedResponsePoint {
                omega_rad_s: s.x[m],
                points: point_ids
                    .iter()
                    .map(|&p| res.observe(s.x, &model.points[p].direction))
                    .collect(),
                newton_iterations: s.newton_iterations,
            });
            true
        },
    );
    match outcome {
        Ok(s) => {
            out.turning_points = s.turning_points;
            out.newton_iterations = s.newton_iterations;
            out.stop = Some(s.stop);
            Ok(out)
        }
        Err((failure, s)) => {
            out.turning_points = s.turning_points;
            out.newton_iterations = s.newton_iterations;
            let omega = out
                .points
                .last()
                .map(|p| p.omega_rad_s)
                .unwrap_or(opts.omega_start);
            Err(NmaError::ForcedResponseFailed {
                omega_rad_s: omega,
                reason: format!("{failure:?}"),
                partial: Box::new(out),
            })
        }
    }
}

/// A modal table from measured nonlinear modal data (e.g. phase-resonant
/// testing), as the paper suggests at the end of Section 3.2.
///
/// CSV with a header row; `#` starts a comment line. Columns (any order, names
/// case-insensitive): `a` or `amplitude` [sqrt(kg) m], `omega` or `omega_rad_s`
/// [rad/s], `D` or `damping_ratio` [-], and the drive-point shape
/// `phi_re`/`phi_im` or `<point>_re`/`<point>_im` (fundamental harmonic
/// `phi_1` at `point_name`). Rows must have strictly increasing `a > 0`.
/// The table has `H = 1` and `phi_0 = 0` (not measured).
pub fn table_from_measured_csv(text: &str, point_name: &str) -> Result<ModalTable, NmaError> {
    let err = |line: usize, message: String| NmaError::MeasuredData { line, message };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let (hline, header) = lines.next().ok_or_else(|| err(0, "no header row".into()))?;
    let cols: Vec<String> = header
        .split(',')
        .map(|c| c.trim().to_ascii_lowercase())
        .collect();
    let pn = point_name.to_ascii_lowercase();
    let find = |names: &[&str]| -> Result<usize, NmaError> {
        cols.iter()
            .position(|c| names.contains(&c.as_str()))
            .ok_or_else(|| {
                err(
                    hline,
                    format!("missing column {} (header: {header})", names.join(" or ")),
                )
            })
    };
    let re_name = format!("{pn}_re");
    let im_name = format!("{pn}_im");
    let ia = find(&["a", "amplitude"])?;
    let io = find(&["omega", "omega_rad_s"])?;
    let id = find(&["d", "damping_ratio"])?;
    let ir = find(&["phi_re", &re_name])?;
    let ii = find(&["phi_im", &im_name])?;
    let mut t = ModalTable {
        format: MODAL_TABLE_FORMAT.to_string(),
        version: MODAL_TABLE_VERSION,
        description: format!("measured nonlinear modal data, drive point '{point_name}'"),
        harmonics: 1,
        amplitude: vec![],
        omega_rad_s: vec![],
        damping_ratio: vec![],
        points: vec![PointShape {
            name: point_name.to_string(),
            re: vec![],
            im: vec![],
        }],
        coordinates: vec![],
        truncated_at_fold: None,
        accuracy: None,
    };
    for (ln, line) in lines {
        let vals: Vec<&str> = line.split(',').map(|v| v.trim()).collect();
        if vals.len() != cols.len() {
            return Err(err(
                ln,
                format!("{} fields, the header has {}", vals.len(), cols.len()),
            ));
        }
        let get = |i: usize| -> Result<f64, NmaError> {
            let v: f64 = vals[i].parse().map_err(|_| {
                err(
                    ln,
                    format!("'{}' in column '{}' is not a number", vals[i], cols[i]),
                )
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(err(
                    ln,
                    format!("non-finite value {v} in column '{}'", cols[i]),
                ))
            }
        };
        let (a, om, d, re, im) = (get(ia)?, get(io)?, get(id)?, get(ir)?, get(ii)?);
        if a <= 0.0 {
            return Err(err(ln, format!("amplitude a = {a} must be positive")));
        }
        if let Some(&prev) = t.amplitude.last() {
            if a <= prev {
                return Err(err(
                    ln,
                    format!("amplitude a = {a} is not larger than the previous {prev}"),
                ));
            }
        }
        if om <= 0.0 {
            return Err(err(
                ln,
                format!("modal frequency omega = {om} rad/s must be positive"),
            ));
        }
        t.amplitude.push(a);
        t.omega_rad_s.push(om);
        t.damping_ratio.push(d);
        t.points[0].re.push(vec![0.0, re]);
        t.points[0].im.push(vec![0.0, im]);
    }
    if t.amplitude.len() < 2 {
        return Err(err(
            hline,
            format!("need at least 2 data rows, got {}", t.amplitude.len()),
        ));
    }
    Ok(t)
}
