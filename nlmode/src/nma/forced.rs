//! Harmonic Balance frequency responses of the forced full model.
use super::continuation::{continuation, ContinuationOptions, StopReason};
use super::driver::point_indices;
use super::epmc::ForcedResidual;
use super::errors::NmaError;
use super::modal_basis::ModalBasis;
use super::options::{check_harmonics, continuation_for};
use crate::structure::StructuralModel;
use crate::Complex64;
use nalgebra::DVector;
use std::sync::Arc;

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
