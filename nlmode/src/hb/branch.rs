//! Driving the continuation: the main branch, seeded branches (isolas), the
//! per-point outputs and stability, and the located bifurcations.
use super::hill::floquet;
use super::residual::{ForceRow, HbResidual};
use super::system::HbSystem;
use super::{
    Bifurcation, BranchStatus, Control, HbBranch, HbError, HbOptions, HbPoint, HbResult, Seed,
    MAX_SEEDS,
};
use crate::nma::continuation::{
    continuation, solve_fixed_parameter, BorderedSolve, ContinuationFailure, ContinuationOptions,
    Residual, StopReason,
};
use crate::nma::hb::{cos_index, sin_index, Aft};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::cell::RefCell;

/// Frequency samples used to find the peak linear amplitude `x_ref`.
const REF_SAMPLES: usize = 200;
/// Iterations of the bifurcation refinement (Illinois regula falsi).
const REFINE_ITERATIONS: usize = 60;
/// Chord-parameter accuracy of the refinement.
const REFINE_TOL: f64 = 1e-10;
/// Scaled distance below which two solutions at the same `Omega` are one.
const SAME_SOLUTION: f64 = 1e-6;

/// Converged points of one continuation with their unit tangents (scaled).
struct Raw {
    xs: Vec<DVector<f64>>,
    ts: Vec<DVector<f64>>,
    status: BranchStatus,
}

/// The frequency response of `sys` over `[omega_start, omega_end]` with
/// stability and bifurcations, plus the branches reached from `seeds` (module
/// docs of [`super`]). Errors on bad options and when the main branch's start
/// point does not converge; a continuation that stops early returns the part
/// computed with [`BranchStatus::Stopped`] naming `Omega` and the reason.
pub fn frequency_response(
    sys: &HbSystem,
    opts: &HbOptions,
    seeds: &[Seed],
) -> Result<HbResult, HbError> {
    opts.validate()?;
    check_seeds(seeds)?;
    let (res, scale, x0) = prepare(sys, opts)?;
    let (w0, w1) = (opts.omega_start_rad_s, opts.omega_end_rad_s);
    let copts = opts.continuation();
    let raw = match run(&res, x0, w1, &scale, &copts, false) {
        Ok(r) => r,
        Err((norm, reason)) => {
            return Err(HbError::StartNotConverged {
                omega_rad_s: w0,
                residual_norm: norm,
                reason,
            })
        }
    };
    let mut branches = vec![finish(&res, raw, &scale, opts, None)];
    for seed in seeds {
        if let Some(b) = seeded(&res, seed, &branches, &scale, opts) {
            branches.push(b);
        }
    }
    Ok(HbResult {
        branches,
        force_names: sys.force_names(),
        harmonics: opts.harmonics,
    })
}

/// Seeds: at most [`MAX_SEEDS`], positive frequency and amplitude, finite phase.
fn check_seeds(seeds: &[Seed]) -> Result<(), HbError> {
    if seeds.len() > MAX_SEEDS {
        return Err(HbError::BadOption {
            name: "seeds",
            value: seeds.len() as f64,
            expected: "at most 10000 seeds",
        });
    }
    for s in seeds {
        for (name, v) in [
            ("seed.omega_rad_s", s.omega_rad_s),
            ("seed.amplitude_m", s.amplitude_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(HbError::BadOption {
                    name,
                    value: v,
                    expected: "a positive number",
                });
            }
        }
        if !s.phase_rad.is_finite() {
            return Err(HbError::BadOption {
                name: "seed.phase_rad",
                value: s.phase_rad,
                expected: "a finite phase",
            });
        }
    }
    Ok(())
}

/// The residual, the unknowns' scale and the start point at `omega_start`
/// (the linear solution) of a frequency response.
fn prepare<'a>(
    sys: &'a HbSystem,
    opts: &HbOptions,
) -> Result<(HbResidual<'a>, DVector<f64>, DVector<f64>), HbError> {
    if opts.stability {
        if let Err(reason) = &sys.first_order {
            return Err(HbError::NoFirstOrderForm {
                reason: reason.clone(),
            });
        }
    }
    let force = match opts.control {
        Control::Voltage => None,
        Control::Force {
            column,
            amplitude_n,
        } => {
            if column >= sys.force_names().len() {
                return Err(HbError::UnknownForceColumn {
                    column,
                    available: sys.force_names(),
                });
            }
            Some(ForceRow {
                column,
                amplitude_n,
            })
        }
    };
    let (w0, w1) = (opts.omega_start_rad_s, opts.omega_end_rad_s);
    let h = opts.harmonics;
    // the input scale at the start (force control: from the linear force)
    let lin0 = sys.linear(w0, h)?;
    let alpha0 = match force {
        None => 1.0,
        Some(fr) => {
            let (phi, ..) = sys.force_map(&lin0, fr.column);
            if phi.norm() > 0.0 {
                fr.amplitude_n / phi.norm()
            } else {
                1.0
            }
        }
    };
    let x_ref = reference_amplitude(sys, w0, w1, h)? * alpha0;
    let res = HbResidual {
        sys,
        aft: Aft::new(h, opts.samples()),
        x_ref: if x_ref > 0.0 && x_ref.is_finite() {
            x_ref
        } else {
            1.0
        },
        force,
        last_error: RefCell::new(None),
    };
    let n = res.n_unknowns();
    let mut scale = DVector::from_element(n, 1.0);
    scale[n - 1] = (w1 - w0).abs();
    if force.is_some() {
        scale[n - 2] = alpha0.max(1e-300);
    }
    let mut x0 = res.linear_guess(&lin0, alpha0);
    if force.is_some() {
        x0 = x0.push(alpha0);
    }
    let x0 = x0.push(w0);
    Ok((res, scale, x0))
}

/// Adds to `result` (a [`frequency_response`] of `sys` with `opts`) the
/// branches reached from `seeds` that are not on one of its branches (e.g.
/// seeds found after the main branch, at its folds).
pub fn add_seeded_branches(
    sys: &HbSystem,
    opts: &HbOptions,
    result: &mut HbResult,
    seeds: &[Seed],
) -> Result<(), HbError> {
    opts.validate()?;
    check_seeds(seeds)?;
    let (res, scale, _) = prepare(sys, opts)?;
    for seed in seeds {
        if let Some(b) = seeded(&res, seed, &result.branches, &scale, opts) {
            result.branches.push(b);
        }
    }
    Ok(())
}

/// Peak fundamental linear amplitude at the elements over the range (at
/// `alpha = 1`); 0 without elements or excitation.
fn reference_amplitude(sys: &HbSystem, w0: f64, w1: f64, h: usize) -> Result<f64, HbError> {
    let mut peak: f64 = 0.0;
    if sys.n_elements() == 0 {
        return Ok(1.0);
    }
    for k in 0..REF_SAMPLES {
        let w = w0 + (w1 - w0) * k as f64 / (REF_SAMPLES - 1) as f64;
        let lin = sys.linear(w, h.min(1))?;
        peak = lin.a1.iter().map(|v| v.norm()).fold(peak, f64::max);
    }
    Ok(peak)
}

fn reason(res: &HbResidual, failure: &ContinuationFailure) -> String {
    let detail = res
        .last_error
        .borrow()
        .as_ref()
        .map(|e| format!(" ({e})"))
        .unwrap_or_default();
    match failure {
        ContinuationFailure::StartNotConverged { residual_norm, .. } => {
            format!("start point did not converge, residual {residual_norm:e}{detail}")
        }
        ContinuationFailure::StepSizeCollapse {
            residual_norm,
            step_size,
            ..
        } => format!("step size collapsed to {step_size:e} (residual {residual_norm:e}){detail}"),
        ContinuationFailure::SingularJacobian { .. } => {
            format!("singular augmented Jacobian{detail}")
        }
    }
}

/// One continuation from `x0` towards `lambda_end`; with `closure`, stops
/// when the branch returns to its start (an isola). `Err` only when the
/// start point does not converge.
fn run(
    res: &HbResidual,
    x0: DVector<f64>,
    lambda_end: f64,
    scale: &DVector<f64>,
    copts: &ContinuationOptions,
    closure: bool,
) -> Result<Raw, (f64, String)> {
    let (mut xs, mut ts): (Vec<DVector<f64>>, Vec<DVector<f64>>) = (Vec::new(), Vec::new());
    let mut closed = false;
    let mut far = 0.0f64;
    let dsmax = copts.dsmax();
    let out = continuation(res, x0, lambda_end, scale, copts, |st| {
        if closure && !xs.is_empty() {
            let d = (st.x - &xs[0]).component_div(scale).norm();
            far = far.max(d);
            if xs.len() >= 3 && far > 2.0 * dsmax && d < dsmax {
                closed = true;
                return false;
            }
        }
        xs.push(st.x.clone());
        ts.push(st.tangent.clone());
        true
    });
    let status = match out {
        Ok(summary) => match summary.stop {
            StopReason::MaxPoints => BranchStatus::MaxPoints,
            StopReason::Callback if closed => BranchStatus::Closed,
            _ => BranchStatus::Complete,
        },
        Err((failure, _)) => {
            if let ContinuationFailure::StartNotConverged { residual_norm, .. } = failure {
                return Err((residual_norm, reason(res, &failure)));
            }
            let omega = xs
                .last()
                .map_or(f64::NAN, |x: &DVector<f64>| x[x.len() - 1]);
            BranchStatus::Stopped {
                omega_rad_s: omega,
                reason: reason(res, &failure),
            }
        }
    };
    if closed {
        xs.push(xs[0].clone());
        ts.push(ts[0].clone());
    }
    Ok(Raw { xs, ts, status })
}

/// The outputs of one solution.
fn point(res: &HbResidual, x: &DVector<f64>, opts: &HbOptions) -> HbPoint {
    let omega = x[x.len() - 1];
    let alpha = res.alpha(x);
    let (response_m, forces_n) = match res.sys.linear(omega, res.harmonics()) {
        Ok(lin) => {
            let f = res.complex_forces(&res.element_forces(x));
            let q = res.sys.structure_harmonics(&lin, alpha, &f);
            (
                res.sys.response_harmonics(&q),
                res.sys.forces(&lin, alpha, &q[1]),
            )
        }
        Err(_) => (vec![], vec![]),
    };
    HbPoint {
        omega_rad_s: omega,
        response_m,
        forces_n,
        input_scale: alpha,
        floquet: if opts.stability {
            floquet(res, x, opts.hill_harmonics(), opts.hill)
        } else {
            None
        },
        bifurcation: Bifurcation::None,
        unknowns: x.iter().copied().collect(),
    }
}

/// The bordered matrix `[J; t^T / scale]` and its determinant (sign: the
/// branch-point test).
fn augmented_det(
    res: &HbResidual,
    x: &DVector<f64>,
    t: &DVector<f64>,
    scale: &DVector<f64>,
) -> f64 {
    let (_, j) = res.eval(x);
    let n = x.len();
    let mut a = j.insert_row(n - 1, 0.0);
    a.row_mut(n - 1)
        .copy_from(&t.component_div(scale).transpose());
    a.lu().determinant()
}

/// Newton on `[R(x); row . x - target] = 0`; the solution and its Jacobian.
fn bordered_newton(
    res: &HbResidual,
    mut x: DVector<f64>,
    row: &DVector<f64>,
    target: f64,
    opts: &HbOptions,
) -> Option<(DVector<f64>, DMatrix<f64>)> {
    for _ in 0..=opts.max_iterations {
        let (r, j) = res.eval(&x);
        let extra = row.dot(&x) - target;
        let norm = (r.norm_squared() + extra * extra).sqrt();
        if !norm.is_finite() {
            return None;
        }
        if norm <= opts.tolerance {
            return Some((x, j));
        }
        let rhs = (-r).push(-extra);
        x += j.solve_bordered(row, &rhs)?;
    }
    None
}

/// Unit tangent (scaled) at a solution, oriented along `t_ref`.
fn tangent_at(
    j: &DMatrix<f64>,
    t_ref: &DVector<f64>,
    scale: &DVector<f64>,
) -> Option<DVector<f64>> {
    let n = scale.len();
    let mut e = DVector::zeros(n);
    e[n - 1] = 1.0;
    let t = j
        .solve_bordered(&t_ref.component_div(scale), &e)?
        .component_div(scale);
    let norm = t.norm();
    (norm.is_finite() && norm > 0.0).then(|| t / norm)
}

/// What a test function sees at a corrected point.
type Test<'a> = dyn Fn(&DVector<f64>, &DVector<f64>) -> Option<f64> + 'a;

/// Refines the zero of `test` between the solutions `xa`, `xb` (test values
/// `ga`, `gb` of opposite signs) by Illinois regula falsi on the chord
/// parameter; the corrector solves `R = 0` on the hyperplane normal to the
/// chord (scaled).
#[allow(clippy::too_many_arguments)]
fn refine(
    res: &HbResidual,
    xa: &DVector<f64>,
    xb: &DVector<f64>,
    ta: &DVector<f64>,
    (mut ga, mut gb): (f64, f64),
    scale: &DVector<f64>,
    opts: &HbOptions,
    test: &Test,
) -> Option<DVector<f64>> {
    let chord = xb - xa;
    let row = chord.component_div(scale).component_div(scale);
    let (mut a, mut b) = (0.0f64, 1.0f64);
    let mut best = None;
    let mut side = 0i8;
    for _ in 0..REFINE_ITERATIONS {
        let theta = ((a * gb - b * ga) / (gb - ga)).clamp(a + 0.01 * (b - a), b - 0.01 * (b - a));
        let xp = xa + &chord * theta;
        let (x, j) = bordered_newton(res, xp.clone(), &row, row.dot(&xp), opts)?;
        let t = tangent_at(&j, ta, scale)?;
        let g = test(&x, &t)?;
        best = Some(x);
        if g == 0.0 || b - a < REFINE_TOL {
            break;
        }
        if g.signum() == ga.signum() {
            a = theta;
            ga = g;
            if side == -1 {
                gb /= 2.0;
            }
            side = -1;
        } else {
            b = theta;
            gb = g;
            if side == 1 {
                ga /= 2.0;
            }
            side = 1;
        }
    }
    best
}

/// Number of kept Floquet exponents with a non-zero imaginary part.
fn n_complex(p: &HbPoint) -> Option<usize> {
    p.floquet.as_ref().map(|f| f.n_complex)
}

/// Per-point outputs, stability, bifurcations (refined and inserted).
fn finish(
    res: &HbResidual,
    raw: Raw,
    scale: &DVector<f64>,
    opts: &HbOptions,
    from_seed: Option<Seed>,
) -> HbBranch {
    let n = scale.len();
    let pts: Vec<HbPoint> = raw.xs.iter().map(|x| point(res, x, opts)).collect();
    let mut points = Vec::with_capacity(pts.len());
    let dets: Vec<f64> = if opts.bifurcations {
        raw.xs
            .iter()
            .zip(&raw.ts)
            .map(|(x, t)| augmented_det(res, x, t, scale))
            .collect()
    } else {
        vec![]
    };
    let ns = |p: &HbPoint| {
        p.floquet
            .as_ref()
            .map(|f| f.max_re_complex)
            .filter(|v| v.is_finite())
    };
    for (i, p) in pts.iter().enumerate() {
        if i > 0 && opts.bifurcations {
            let (xa, xb, ta) = (&raw.xs[i - 1], &raw.xs[i], &raw.ts[i - 1]);
            let mut found: Vec<(Bifurcation, DVector<f64>)> = Vec::new();
            let (fa, fb) = (raw.ts[i - 1][n - 1], raw.ts[i][n - 1]);
            if fa * fb < 0.0 {
                let test = |_: &DVector<f64>, t: &DVector<f64>| Some(t[n - 1]);
                if let Some(x) = refine(res, xa, xb, ta, (fa, fb), scale, opts, &test) {
                    found.push((Bifurcation::Fold, x));
                }
            }
            if dets[i - 1] * dets[i] < 0.0 {
                let test =
                    |x: &DVector<f64>, t: &DVector<f64>| Some(augmented_det(res, x, t, scale));
                if let Some(x) = refine(res, xa, xb, ta, (dets[i - 1], dets[i]), scale, opts, &test)
                {
                    found.push((Bifurcation::BranchPoint, x));
                }
            }
            // a complex pair that becomes real (at a fold) is no Neimark-Sacker
            // point: test only where the complex exponents stay complex
            if let (Some(ga), Some(gb)) = (ns(&pts[i - 1]), ns(p)) {
                if ga * gb < 0.0 && n_complex(&pts[i - 1]) == n_complex(p) {
                    let test = |x: &DVector<f64>, _: &DVector<f64>| {
                        floquet(res, x, opts.hill_harmonics(), opts.hill)
                            .map(|f| f.max_re_complex)
                            .filter(|v| v.is_finite())
                    };
                    if let Some(x) = refine(res, xa, xb, ta, (ga, gb), scale, opts, &test) {
                        found.push((Bifurcation::NeimarkSacker, x));
                    }
                }
            }
            // in order along the chord
            let chord = xb - xa;
            found.sort_by(|a, b| chord.dot(&a.1).total_cmp(&chord.dot(&b.1)));
            for (kind, x) in found {
                let mut q = point(res, &x, opts);
                q.bifurcation = kind;
                points.push(q);
            }
        }
        points.push(p.clone());
    }
    HbBranch {
        points,
        status: raw.status,
        from_seed,
    }
}

/// The branch through `seed`, unless the seed does not converge or lies on
/// one of `found`.
fn seeded(
    res: &HbResidual,
    seed: &Seed,
    found: &[HbBranch],
    scale: &DVector<f64>,
    opts: &HbOptions,
) -> Option<HbBranch> {
    let w = seed.omega_rad_s;
    let lin = res.sys.linear(w, res.harmonics()).ok()?;
    // scale the linear solution so that the response point has the seed's fundamental
    let alpha = found
        .first()
        .and_then(|b| b.points.first())
        .map_or(1.0, |p| p.input_scale);
    let zero = vec![DVector::zeros(res.sys.n_elements()); res.harmonics() + 1];
    let q = res.sys.structure_harmonics(&lin, alpha, &zero);
    let r_lin = res.sys.response_harmonics(&q)[1];
    if r_lin.norm() == 0.0 {
        return None;
    }
    let target = Complex64::from_polar(seed.amplitude_m, seed.phase_rad);
    let mut x0 = res.linear_guess(&lin, alpha);
    let ratio = target / r_lin;
    let ne = res.sys.n_elements();
    for e in 0..ne {
        let (c, s) = (cos_index(1) * ne + e, sin_index(1) * ne + e);
        let z = Complex64::new(x0[c], -x0[s]) * ratio;
        x0[c] = z.re;
        x0[s] = -z.im;
    }
    if res.force.is_some() {
        x0 = x0.push(alpha);
    }
    let x0 = x0.push(w);
    let copts = opts.continuation();
    let (xs, ..) = solve_fixed_parameter(res, x0, &copts).ok()?;
    if on_found(res, &xs, found, scale, &copts) {
        return None;
    }
    let (w0, w1) = (opts.omega_start_rad_s, opts.omega_end_rad_s);
    let fwd = run(res, xs.clone(), w1, scale, &copts, true).ok()?;
    let raw = if fwd.status == BranchStatus::Closed {
        fwd
    } else {
        let bwd = run(res, xs, w0, scale, &copts, false).ok()?;
        let mut xs: Vec<_> = bwd.xs.into_iter().rev().collect();
        let mut ts: Vec<_> = bwd.ts.into_iter().rev().map(|t| -t).collect();
        xs.extend(fwd.xs.into_iter().skip(1));
        ts.extend(fwd.ts.into_iter().skip(1));
        let status = match (bwd.status, fwd.status) {
            (s @ BranchStatus::Stopped { .. }, _) => s,
            (_, s) => s,
        };
        Raw { xs, ts, status }
    };
    Some(finish(res, raw, scale, opts, Some(*seed)))
}

/// Whether the solution `x` lies on one of the branches `found`: at `x`'s
/// `Omega`, each crossing of a found branch is solved from the interpolated
/// point and compared with `x`.
fn on_found(
    res: &HbResidual,
    x: &DVector<f64>,
    found: &[HbBranch],
    scale: &DVector<f64>,
    copts: &ContinuationOptions,
) -> bool {
    let n = x.len();
    let w = x[n - 1];
    for b in found {
        for pair in b.points.windows(2) {
            let (wa, wb) = (pair[0].omega_rad_s, pair[1].omega_rad_s);
            if (wa - w) * (wb - w) > 0.0 || wa == wb {
                continue;
            }
            let th = (w - wa) / (wb - wa);
            let xa = DVector::from_column_slice(&pair[0].unknowns);
            let xb = DVector::from_column_slice(&pair[1].unknowns);
            let mut guess = &xa + (&xb - &xa) * th;
            guess[n - 1] = w;
            if let Ok((xc, ..)) = solve_fixed_parameter(res, guess, copts) {
                if (xc - x).component_div(scale).norm() < SAME_SOLUTION {
                    return true;
                }
            }
        }
    }
    false
}
