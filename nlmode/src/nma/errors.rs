//! Errors and warnings of the nonlinear modal analysis.
use super::forced::ForcedResponse;
use super::results::NmaResult;

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
    #[error(
        "{samples} AFT samples are more than the {maximum} per period supported at H = {harmonics}"
    )]
    TooManySamples {
        samples: usize,
        harmonics: usize,
        maximum: usize,
    },
    #[error("harmonics = \"auto\": no H up to {max_harmonics} agrees with H + 4 within the table accuracy (at H = {max_harmonics}: omega {omega_rel:.1e}, D {damping_rel:.1e}, shapes {shape_rel:.1e}); set harmonics explicitly or lower the amplitude range")]
    AutoHarmonicsNotFound {
        max_harmonics: usize,
        omega_rel: f64,
        damping_rel: f64,
        shape_rel: f64,
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
    #[error("the amplitude turns back at a = {amplitude:e}, omega = {omega_rad_s} rad/s without an internal resonance (the largest other component, harmonic {harmonic} of mode {mode}, carries {share:.2e} of the energy at n omega / omega_k = {ratio:.3}): a fold of the nonlinear mode itself (e.g. friction saturating); the modal table ends there")]
    FoldNotInternalResonance {
        amplitude: f64,
        omega_rad_s: f64,
        harmonic: usize,
        mode: usize,
        ratio: f64,
        share: f64,
    },
    #[error("the end frequency {end_omega_rad_s} rad/s was not reached: the branch stopped at a = {amplitude:e}, omega = {omega_rad_s} rad/s (fundamental energy share {share:e}, last step {step:e})")]
    EndFrequencyNotReached {
        end_omega_rad_s: f64,
        amplitude: f64,
        omega_rad_s: f64,
        share: f64,
        step: f64,
    },
}
