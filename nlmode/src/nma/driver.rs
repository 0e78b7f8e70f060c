//! The driver of the nonlinear modal analysis (EPMC branch by continuation)
//! and direct Harmonic Balance solves at a fixed modal amplitude.
use super::continuation::{
    continuation, BranchState, ContinuationFailure, ContinuationOptions, StopReason,
};
use super::epmc::{EpmcResidual, Normalisation};
use super::errors::{NmaError, NmaWarning};
use super::folds::{finish, finish_from_amplitudes, identify_internal_resonances};
use super::modal_basis::ModalBasis;
use super::options::{check_harmonics, continuation_for, AmplitudeRange, NmaOptions};
use super::results::{BranchPoint, EnergyComponent, NmaResult};
use crate::structure::StructuralModel;
use nalgebra::DVector;
use std::sync::Arc;

/// Indices of the named points (every point of the model when `names` is empty).
pub(super) fn point_indices(
    model: &StructuralModel,
    names: &[String],
) -> Result<Vec<usize>, NmaError> {
    if names.is_empty() {
        Ok((0..model.points.len()).collect())
    } else {
        names.iter().map(|p| find_point(model, p)).collect()
    }
}

/// Modal direction vectors `Phi^T d_p` of the points `ids`.
pub(super) fn modal_directions(
    model: &StructuralModel,
    basis: &ModalBasis,
    ids: &[usize],
) -> Vec<DVector<f64>> {
    ids.iter()
        .map(|&p| basis.phi.transpose() * &model.points[p].direction)
        .collect()
}

pub(super) fn find_point(model: &StructuralModel, name: &str) -> Result<usize, NmaError> {
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

/// Arc-length scale of the damping ratio `D` for a model with a dissipative
/// nonlinear element ([`dissipative_elements`]): friction drives `D` from
/// the linear value to tens of percent (a Jenkins element to 40 %), so with
/// the linear `D` (or `1e-3`) as scale the continuation would crawl through
/// that rise in hundreds of steps limited by `dsmax`. Models with
/// conservative elements only keep `max(D_0, 1e-3)`.
pub const DISSIPATIVE_DAMPING_SCALE: f64 = 0.05;

/// Whether a nonlinear element of `model` can dissipate: hysteretic, or with
/// a velocity-dependent force (`df/dv != 0` at `v = 0`, `1e-3` or `1` m/s).
pub(super) fn dissipative_elements(model: &StructuralModel) -> bool {
    model.nonlinear.iter().any(|e| {
        e.law.hysteresis().is_some()
            || [0.0, 1e-3, 1.0]
                .iter()
                .any(|&v| e.law.eval(0.0, v).2 != 0.0)
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
    check_basis(model, &basis, opts)?;
    let point_ids = point_indices(model, &opts.points)?;
    let j = opts.mode_index;
    let res = EpmcResidual::new(basis.clone(), opts.harmonics, samples, j)
        .with_normalisation(opts.normalisation);
    let point_modal = modal_directions(model, &basis, &point_ids);

    // amplitude range in log10 a
    let (lg_start, lg_end, stop_point) = amplitude_range(model, &basis, &opts.amplitude, j)?;

    let omega0 = basis.omega(j);
    let d0 = basis.damping_ratio(j);
    let m = res.n_coeffs();
    let scale = continuation_scale(model, omega0, d0, m);

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
        res.linearised_guess(lg_start),
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
    let linear_omegas: Vec<f64> = (0..n).map(|k| basis.omega(k)).collect();
    identify_internal_resonances(&mut result, &linear_omegas);
    if let Some(end) = opts.end_omega_over_omega0 {
        if !end_omega_reached {
            end_frequency_warning(&mut result, end * omega0, last_step);
        }
    }
    match outcome {
        Ok(s) => {
            stop_warnings(&mut result, &s, share_stop);
            let _ = stop_reached;
            Ok(result)
        }
        Err((failure, _)) => Err(failure_error(result, failure)),
    }
}

/// Panics if `basis` is not that of `model` with `opts.conservative`; the
/// error if `opts.mode_index` is not one of its modes.
fn check_basis(
    model: &StructuralModel,
    basis: &ModalBasis,
    opts: &NmaOptions,
) -> Result<(), NmaError> {
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
    Ok(())
}

/// The continuation's range in `log10 a` of mode `j` (start, end) and, for a
/// range given as a point's amplitude [m], that point's modal direction and
/// end amplitude [m] (the branch stops there; the end in `log10 a` is then
/// 3 decades beyond the estimate `end_m / |phi_j^T d_p|`).
#[allow(clippy::type_complexity)]
fn amplitude_range(
    model: &StructuralModel,
    basis: &ModalBasis,
    amplitude: &AmplitudeRange,
    j: usize,
) -> Result<(f64, f64, Option<(DVector<f64>, f64)>), NmaError> {
    Ok(match amplitude {
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
    })
}

/// The arc-length scales of the `m` harmonic coefficients (1), the
/// frequency (`|omega0|` [rad/s]), the damping ratio (`|D_0|`, at least
/// [`DISSIPATIVE_DAMPING_SCALE`] with a dissipative element, else `1e-3`)
/// and `log10 a` (1).
fn continuation_scale(model: &StructuralModel, omega0: f64, d0: f64, m: usize) -> DVector<f64> {
    let mut scale = DVector::from_element(m + 3, 1.0);
    scale[m] = omega0.abs().max(1e-12);
    scale[m + 1] = d0.abs().max(if dissipative_elements(model) {
        DISSIPATIVE_DAMPING_SCALE
    } else {
        1e-3
    });
    scale[m + 2] = 1.0;
    scale
}

/// The warning of a branch that ended below the asked end frequency
/// `end_omega_rad_s` (`last_step`: the last arc-length step).
fn end_frequency_warning(result: &mut NmaResult, end_omega_rad_s: f64, last_step: f64) {
    if let Some(b) = result.branch.last() {
        result.warnings.push(NmaWarning::EndFrequencyNotReached {
            end_omega_rad_s,
            amplitude: b.amplitude,
            omega_rad_s: b.omega_rad_s,
            share: b.fundamental_energy_share,
            step: last_step,
        });
    }
}

/// The stop reason of a completed continuation `s` and its warnings
/// (`share_stop`: stopped because the fundamental's energy share fell below
/// the minimum).
fn stop_warnings(
    result: &mut NmaResult,
    s: &super::continuation::ContinuationSummary,
    share_stop: bool,
) {
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
        }
    }
}

/// The error of a failed continuation, carrying the computed part of the
/// branch (`result`).
fn failure_error(result: NmaResult, failure: ContinuationFailure) -> NmaError {
    let last = result
        .branch
        .last()
        .map(|b| (b.amplitude, b.omega_rad_s))
        .unwrap_or((f64::NAN, f64::NAN));
    let partial = Box::new(result);
    match failure {
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
    }
}

/// The branch point of a converged solution `x` of `res` (any
/// [`Normalisation`]): amplitude, frequency, damping, energy shares and the
/// shape harmonics in the paper's normalisation.
pub(super) fn branch_point(
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
pub(super) struct AmplitudeSolver<'a> {
    pub(super) model: &'a StructuralModel,
    pub(super) opts: &'a NmaOptions,
    pub(super) samples: usize,
    pub(super) point_ids: Vec<usize>,
    pub(super) res: EpmcResidual,
    pub(super) point_modal: Vec<DVector<f64>>,
    pub(super) pm: nalgebra::DMatrix<f64>,
    pub(super) continuation: ContinuationOptions,
    /// Chord (simplified) Newton ([`super::continuation::solve_fixed_parameter_chord`])
    /// instead of Newton: the refinement's checks, started close to the solution.
    pub(super) chord: bool,
}

impl<'a> AmplitudeSolver<'a> {
    pub(super) fn new(
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

    pub(super) fn solve(
        &self,
        amplitude: f64,
        guess: &BranchPoint,
    ) -> Result<BranchPoint, NmaError> {
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
