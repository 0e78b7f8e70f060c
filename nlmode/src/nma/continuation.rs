//! Pseudo-arc-length predictor-corrector continuation over any [`Residual`]
//! (the NLvib pattern: one residual function returning `(R, dR/dX)` together,
//! one continuation routine for nonlinear modes and frequency responses alike).
//!
//! The unknowns `X` (length `n`) carry the continuation parameter `lambda` as
//! their last entry; the residual has `n - 1` equations. Continuation works on
//! scaled unknowns `X~ = X / s` (`s` given by the caller) so that the arc
//! length mixes quantities of different units sensibly. One step:
//!
//! 1. predictor `X~_p = X~_i + ds t~_i` along the unit tangent `t~_i`,
//! 2. corrector: Newton on `[R(X); t~_i . (X~ - X~_p)] = 0` (pseudo-arc-length),
//! 3. new tangent from `[dR/dX; t~_i^T] t = [0; 1]`, normalized (this keeps the
//!    orientation, so turning points in `lambda` are passed without special
//!    treatment and are detected as a sign change of `t_lambda`),
//!    The last step lands exactly on `lambda_end` (corrector with the parameter
//!    fixed instead of the arc-length equation).
//! 4. step adaptation `ds <- ds * clamp(n_opt / n_iter, 1/2, 2)` within
//!    `[dsmin, dsmax]`; a failed corrector halves `ds`; below `dsmin` the
//!    continuation stops with [`ContinuationFailure::StepSizeCollapse`].
//!    Optional controls reject a step (and halve `ds`) whose tangent turns by
//!    more than `max_tangent_angle_deg` or whose corrector contracts by less
//!    than `max_contraction` per iteration; with them, `dsmax` bounds how far
//!    one step can go along a straight branch, and curved parts (loops) are
//!    resolved by the angle limit.
//! 5. Before a step-size collapse is reported, `corner_step` tries Newton
//!    with the parameter fixed just past the last point (a corner of a
//!    piecewise-smooth branch, e.g. one-sided slip onset of a friction
//!    element, where the tangent turns by nearly 90 degrees), then
//!    `corner_turn` (the tangent of the piece beyond the corner, for a turn
//!    the parameter cannot follow, e.g. a fold at the corner). A corrector that
//!    lands farther than `2 dsmax` from the last point is rejected even at
//!    `dsmin` (it ran off along a flat direction of the residual).
use nalgebra::DVector;

/// A Jacobian that can solve the square system obtained by appending one
/// dense row: `[J; c^T] y = rhs`, where `J` is `(n-1) x n`.
pub trait BorderedSolve {
    /// A factorisation of one bordered matrix `[J; c^T]`, reusable for many
    /// right-hand sides (the chord iterations of [`solve_fixed_parameter_chord`]).
    type Factor: BorderedFactor;
    /// Factor `[J; c^T]` with `c = row`, or `None` if it is (numerically) singular.
    fn factor_bordered(&self, row: &DVector<f64>) -> Option<Self::Factor>;
    /// Solution `y`, or `None` if the bordered matrix is (numerically) singular.
    fn solve_bordered(&self, row: &DVector<f64>, rhs: &DVector<f64>) -> Option<DVector<f64>> {
        self.factor_bordered(row)?.solve(rhs)
    }
}

/// A factored bordered matrix ([`BorderedSolve::factor_bordered`]).
pub trait BorderedFactor {
    /// Solution `y` of `[J; c^T] y = rhs`, or `None` if it is not finite.
    fn solve(&self, rhs: &DVector<f64>) -> Option<DVector<f64>>;
}

impl BorderedSolve for nalgebra::DMatrix<f64> {
    type Factor = nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>;
    fn factor_bordered(&self, row: &DVector<f64>) -> Option<Self::Factor> {
        let n = self.ncols();
        assert_eq!(
            self.nrows() + 1,
            n,
            "bordered solve needs an (n-1) x n Jacobian"
        );
        let mut a = self.clone().insert_row(n - 1, 0.0);
        a.row_mut(n - 1).copy_from(&row.transpose());
        let lu = a.lu();
        lu.is_invertible().then_some(lu)
    }
}

impl BorderedFactor for nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn> {
    fn solve(&self, rhs: &DVector<f64>) -> Option<DVector<f64>> {
        let y = nalgebra::linalg::LU::solve(self, rhs)?;
        y.iter().all(|v| v.is_finite()).then_some(y)
    }
}

/// An underdetermined system `R(X) = 0` (`n - 1` equations, `n` unknowns, the
/// last unknown being the continuation parameter) whose evaluation returns the
/// residual and its Jacobian together.
pub trait Residual {
    type Jacobian: BorderedSolve;
    /// Number of unknowns `n` including the continuation parameter.
    fn n_unknowns(&self) -> usize;
    /// Residual `R(X)` (length `n - 1`) and Jacobian `dR/dX`.
    fn eval(&self, x: &DVector<f64>) -> (DVector<f64>, Self::Jacobian);
    /// The residual alone (the chord iterations need no Jacobian); the same
    /// numbers as `eval(x).0`. Override where the Jacobian is the dominant cost.
    fn residual(&self, x: &DVector<f64>) -> DVector<f64> {
        self.eval(x).0
    }
}

/// Options of the continuation (defaults as in NLvib: `dsmin = ds/5`,
/// `dsmax = 5 ds`). Serialisable; missing keys take the defaults.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ContinuationOptions {
    /// Initial step length in the scaled arc length.
    pub ds: f64,
    /// Smallest step; default `ds / 5`.
    pub dsmin: Option<f64>,
    /// Largest step; default `5 ds`.
    pub dsmax: Option<f64>,
    /// Adapt the step to the number of Newton iterations.
    pub step_adaptation: bool,
    /// Desired number of Newton iterations per step (`n_opt`).
    pub target_iterations: usize,
    /// Newton iterations before a corrector counts as failed.
    pub max_iterations: usize,
    /// Convergence: Euclidean norm of the (scaled) residual, including the
    /// arc-length equation.
    pub tolerance: f64,
    /// Maximum number of branch points (including the start point).
    pub max_points: usize,
    /// Tangent-angle control: a step whose new tangent turns by more than
    /// this angle [deg] from the previous one is rejected and retried with
    /// half the step (unless `ds` is at `dsmin`). `None` (default): no control.
    /// Keeps the continuation from cutting across sharply curved parts of a
    /// branch such as internal-resonance loops.
    pub max_tangent_angle_deg: Option<f64>,
    /// Corrector-contraction control: a corrector whose second residual norm
    /// exceeds this fraction of the first (a Newton iteration that contracts
    /// badly, the sign of a predictor far from the branch) is rejected and
    /// the step halved. `None` (default): no control.
    pub max_contraction: Option<f64>,
}

impl Default for ContinuationOptions {
    fn default() -> Self {
        Self {
            ds: 0.05,
            dsmin: None,
            dsmax: None,
            step_adaptation: true,
            target_iterations: 3,
            max_iterations: 12,
            tolerance: 1e-10,
            max_points: 2000,
            max_tangent_angle_deg: None,
            max_contraction: None,
        }
    }
}

impl ContinuationOptions {
    pub fn dsmin(&self) -> f64 {
        self.dsmin.unwrap_or(self.ds / 5.0)
    }
    pub fn dsmax(&self) -> f64 {
        self.dsmax.unwrap_or(self.ds * 5.0)
    }
}

/// Why a continuation ended normally.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// The parameter reached the end of its range.
    ReachedEnd,
    /// The branch turned back and left the parameter range at its start.
    LeftRange,
    /// `max_points` were computed.
    MaxPoints,
    /// The point callback asked to stop.
    Callback,
}

/// Failure of a continuation; the points computed so far have been reported
/// through the callback already.
#[derive(Debug, Clone, PartialEq)]
pub enum ContinuationFailure {
    /// Newton did not converge for the start point.
    StartNotConverged {
        parameter: f64,
        residual_norm: f64,
        iterations: usize,
    },
    /// The corrector kept failing until `ds < dsmin` (`residual_norm` is that of
    /// the last non-converged corrector, NaN if the correctors converged but
    /// jumped too far from the predictor).
    StepSizeCollapse {
        parameter: f64,
        residual_norm: f64,
        step_size: f64,
        dsmin: f64,
    },
    /// A bordered Jacobian was singular (e.g. at a branch point).
    SingularJacobian { parameter: f64 },
}

/// Summary of a continuation run.
#[derive(Debug, Clone, PartialEq)]
pub struct ContinuationSummary {
    pub points: usize,
    /// Newton iterations of accepted and rejected correctors.
    pub newton_iterations: usize,
    /// Corrector attempts that failed or jumped away (then `ds` was halved).
    pub rejected_steps: usize,
    /// Indices `i` of branch points such that a turning point of the parameter
    /// lies between points `i - 1` and `i`.
    pub turning_points: Vec<usize>,
    pub stop: StopReason,
    /// Steps taken by `corner_step` (the arc-length corrector had failed
    /// down to `dsmin`).
    pub corner_steps: usize,
}

/// A converged branch point as handed to the callback.
#[derive(Debug)]
pub struct BranchState<'a> {
    pub index: usize,
    pub x: &'a DVector<f64>,
    /// Unit tangent in scaled unknowns.
    pub tangent: &'a DVector<f64>,
    pub newton_iterations: usize,
    /// Arc-length step that led to this point (0 for the start point).
    pub step: f64,
}

/// A converged Newton solve: solution, Jacobian there, iterations.
pub type NewtonOk<J> = (DVector<f64>, J, usize);
/// A failed Newton solve: last residual norm, iterations.
pub type NewtonErr = (f64, usize);
/// A step across a corner of the branch: the point, its Jacobian, the
/// Newton iterations and the new tangent.
type CornerOk<J> = (DVector<f64>, J, usize, DVector<f64>);

/// The stopping rules both Newton variants ([`newton`] and
/// [`solve_fixed_parameter_chord`]) apply to the bordered residual
/// `[R(X); extra]` at each iterate: converged at `opts.tolerance`; failed on a
/// non-finite norm, at the last iteration, or when the norm grew beyond 1e6
/// times the first one.
struct Stopping<'a> {
    opts: &'a ContinuationOptions,
    first_norm: Option<f64>,
}

/// What [`Stopping::check`] found at an iterate.
enum Verdict {
    Converged,
    /// Iterate on; the residual norm.
    Continue(f64),
}

impl<'a> Stopping<'a> {
    fn new(opts: &'a ContinuationOptions) -> Self {
        Self {
            opts,
            first_norm: None,
        }
    }

    fn check(&mut self, r: &DVector<f64>, extra: f64, it: usize) -> Result<Verdict, NewtonErr> {
        let norm = (r.norm_squared() + extra * extra).sqrt();
        if !norm.is_finite() {
            return Err((norm, it));
        }
        if norm <= self.opts.tolerance {
            return Ok(Verdict::Converged);
        }
        let f0 = *self.first_norm.get_or_insert(norm);
        if it == self.opts.max_iterations || norm > 1e6 * f0.max(self.opts.tolerance) {
            return Err((norm, it));
        }
        Ok(Verdict::Continue(norm))
    }
}

/// Newton iterations on `[R(X); c.X - target] = 0`. Returns the solution, the
/// Jacobian at it and the iteration count, or the last residual norm.
fn newton<R: Residual>(
    res: &R,
    mut x: DVector<f64>,
    row: &DVector<f64>,
    target: f64,
    opts: &ContinuationOptions,
) -> Result<NewtonOk<R::Jacobian>, NewtonErr> {
    let mut stopping = Stopping::new(opts);
    let mut prev_norm = f64::INFINITY;
    for it in 0..=opts.max_iterations {
        let (r, jac) = res.eval(&x);
        let extra = row.dot(&x) - target;
        let norm = match stopping.check(&r, extra, it)? {
            Verdict::Converged => return Ok((x, jac, it)),
            Verdict::Continue(norm) => norm,
        };
        // corrector contraction: Newton near a solution contracts (at least)
        // linearly; a residual that shrinks by less than `max_contraction`
        // signals a predictor far from the branch
        if let Some(kappa) = opts.max_contraction {
            if it >= 1 && norm > kappa * prev_norm && norm > 1e3 * opts.tolerance {
                return Err((norm, it));
            }
        }
        prev_norm = norm;
        let mut rhs = -r;
        rhs = rhs.push(-extra);
        match jac.solve_bordered(row, &rhs) {
            Some(dx) => x += dx,
            None => return Err((norm, it)),
        }
    }
    unreachable!()
}

/// Solve `R(X) = 0` with the parameter fixed, `X[n-1] = lambda` (no scaling
/// needed: the parameter equation is exact after one step).
pub fn solve_fixed_parameter<R: Residual>(
    res: &R,
    x0: DVector<f64>,
    opts: &ContinuationOptions,
) -> Result<NewtonOk<R::Jacobian>, NewtonErr> {
    let n = res.n_unknowns();
    let mut row = DVector::zeros(n);
    row[n - 1] = 1.0;
    let lambda = x0[n - 1];
    newton(res, x0, &row, lambda, opts)
}

/// Least residual contraction `|R_{k+1}| / |R_k|` a chord iteration of
/// [`solve_fixed_parameter_chord`] must achieve to keep its factorisation;
/// a weaker one refactors at the current iterate (a Newton step).
pub const CHORD_CONTRACTION: f64 = 0.25;

/// A converged chord solve: solution, iterations, factorisations.
pub type ChordOk = (DVector<f64>, usize, usize);

/// [`solve_fixed_parameter`] by simplified (chord) Newton: the bordered
/// Jacobian is factored at `x0` and reused by the following iterations, which
/// evaluate only the residual ([`Residual::residual`]), as long as each
/// reduces the residual norm by at least [`CHORD_CONTRACTION`]; otherwise it
/// is refactored at the current iterate. The convergence test is Newton's
/// (`opts.tolerance` on the residual norm), so the result solves `R(X) = 0`
/// as accurately; from a close guess it needs as many iterations as Newton
/// and one factorisation. `opts.max_contraction` does not apply (a weak
/// contraction refactors instead of failing).
pub fn solve_fixed_parameter_chord<R: Residual>(
    res: &R,
    x0: DVector<f64>,
    opts: &ContinuationOptions,
) -> Result<ChordOk, NewtonErr> {
    let n = res.n_unknowns();
    let lambda = x0[n - 1];
    let mut row = DVector::zeros(n);
    row[n - 1] = 1.0;
    let mut x = x0;
    let (mut r, jac0) = res.eval(&x);
    // the Jacobian at the current iterate, not yet factored
    let mut jac = Some(jac0);
    let mut factor: Option<<R::Jacobian as BorderedSolve>::Factor> = None;
    let mut factorisations = 0;
    let mut stopping = Stopping::new(opts);
    let mut prev_norm = f64::INFINITY;
    for it in 0..=opts.max_iterations {
        let extra = x[n - 1] - lambda;
        let norm = match stopping.check(&r, extra, it)? {
            Verdict::Converged => return Ok((x, it, factorisations)),
            Verdict::Continue(norm) => norm,
        };
        if factor.is_none() || norm > CHORD_CONTRACTION * prev_norm {
            let j = jac.take().unwrap_or_else(|| res.eval(&x).1);
            factor = Some(j.factor_bordered(&row).ok_or((norm, it))?);
            factorisations += 1;
        }
        prev_norm = norm;
        let mut rhs = -&r;
        rhs = rhs.push(-extra);
        let dx = factor
            .as_ref()
            .expect("factored above")
            .solve(&rhs)
            .ok_or((norm, it))?;
        x += dx;
        r = res.residual(&x);
    }
    unreachable!()
}

/// Unit tangent in scaled unknowns from `[J; c^T] t = [0; 1]`, `c` in scaled
/// unknowns; returns `None` if singular.
fn tangent<J: BorderedSolve>(
    jac: &J,
    c_scaled: &DVector<f64>,
    scale: &DVector<f64>,
) -> Option<DVector<f64>> {
    let n = scale.len();
    let row = c_scaled.component_div(scale);
    let mut rhs = DVector::zeros(n);
    rhs[n - 1] = 1.0;
    let t = jac.solve_bordered(&row, &rhs)?.component_div(scale);
    let norm = t.norm();
    (norm.is_finite() && norm > 0.0).then(|| t / norm)
}

/// Increments of the parameter tried by `corner_step`, in units of its base
/// increment (smallest first: the first point past a corner suffices).
const CORNER_INCREMENTS: [f64; 4] = [1.0, 4.0, 16.0, 64.0];

/// A step across a corner of the branch (a piecewise-smooth residual, e.g. the
/// onset of slip of a hysteretic element in one direction, where the tangent
/// turns abruptly and the arc-length corrector fails down to `dsmin`): Newton
/// with the parameter fixed at `lambda + dir delta` from `x`, `delta` from the
/// last accepted parameter increment (at least `1e-6` of the range) times
/// [`CORNER_INCREMENTS`], within the range. Accepted only if it converges
/// within `dsmax` (scaled) of `x`; the new tangent is bordered with and
/// oriented along the secant. Returns the point, its Jacobian, the Newton
/// iterations and the tangent.
#[allow(clippy::too_many_arguments)]
fn corner_step<R: Residual>(
    res: &R,
    x: &DVector<f64>,
    t: &DVector<f64>,
    scale: &DVector<f64>,
    dir: f64,
    last_dlambda: f64,
    (lo, hi): (f64, f64),
    opts: &ContinuationOptions,
) -> Option<CornerOk<R::Jacobian>> {
    let n = x.len();
    let fixed = ContinuationOptions {
        max_contraction: None,
        ..opts.clone()
    };
    if dir * t[n - 1] <= 0.0 {
        // the branch turns back in the parameter here: no natural step
        return corner_turn(res, x, t, scale, &fixed);
    }
    let base = last_dlambda.max(1e-6 * (hi - lo).abs().max(1e-300));
    let xs = x.component_div(scale);
    let mut iterations = 0;
    for k in CORNER_INCREMENTS {
        let lambda = (x[n - 1] + dir * k * base).clamp(lo, hi);
        if lambda == x[n - 1] {
            return None;
        }
        let mut guess = x.clone();
        guess[n - 1] = lambda;
        let Ok((xn, jn, it)) = solve_fixed_parameter(res, guess, &fixed) else {
            continue;
        };
        iterations += it;
        let secant = xn.component_div(scale) - &xs;
        let dist = secant.norm();
        if !(dist > 0.0 && dist <= opts.dsmax()) {
            continue;
        }
        let secant = secant / dist;
        let tn = tangent(&jn, &secant, scale)?;
        let tn = if tn.dot(&secant) < 0.0 { -tn } else { tn };
        return Some((xn, jn, iterations, tn));
    }
    corner_turn(res, x, t, scale, &fixed)
}

/// A corner where the branch turns by more than the natural step can follow
/// (also a fold of the parameter at the corner): the tangent `t_B` of the
/// piece beyond the corner, from the Jacobian at `x + r t` (`r = 1, 4, 16`
/// times `dsmin`, scaled), and an arc-length corrector from `x + r t_B` in both
/// orientations of `t_B`. A point is accepted within `dsmax` of `x` and not
/// back along the old branch (its secant within 45 degrees of `-t`); the
/// tangent is oriented along the secant.
fn corner_turn<R: Residual>(
    res: &R,
    x: &DVector<f64>,
    t: &DVector<f64>,
    scale: &DVector<f64>,
    opts: &ContinuationOptions,
) -> Option<CornerOk<R::Jacobian>> {
    let xs = x.component_div(scale);
    let mut iterations = 0;
    for k in [1.0, 4.0, 16.0] {
        let r = k * opts.dsmin();
        let (_, jp) = res.eval(&(&xs + t * r).component_mul(scale));
        let Some(tb) = tangent(&jp, t, scale) else {
            continue;
        };
        for sign in [1.0, -1.0] {
            let tb = &tb * sign;
            let start = (&xs + &tb * r).component_mul(scale);
            let row = tb.component_div(scale);
            let target = row.dot(&start);
            let Ok((xc, jc, it)) = newton(res, start, &row, target, opts) else {
                continue;
            };
            iterations += it;
            let d = xc.component_div(scale) - &xs;
            let dist = d.norm();
            if !(dist > 0.0 && dist <= opts.dsmax()) || -d.dot(t) > 0.7 * dist {
                continue;
            }
            let d = d / dist;
            let Some(tn) = tangent(&jc, &d, scale) else {
                continue;
            };
            let tn = if tn.dot(&d) < 0.0 { -tn } else { tn };
            return Some((xc, jc, iterations, tn));
        }
    }
    None
}

/// Continue the solution branch of `res` from `x0` (solved first with its
/// parameter fixed) until the parameter `X[n-1]` reaches `lambda_end`.
///
/// `scale` (length `n`, positive) scales the unknowns for the arc length. The
/// callback receives every converged point (including the start) and returns
/// `false` to stop. On failure the points already passed to the callback are
/// the computed part of the branch.
pub fn continuation<R: Residual>(
    res: &R,
    x0: DVector<f64>,
    lambda_end: f64,
    scale: &DVector<f64>,
    opts: &ContinuationOptions,
    mut on_point: impl FnMut(&BranchState) -> bool,
) -> Result<ContinuationSummary, (ContinuationFailure, ContinuationSummary)> {
    let n = res.n_unknowns();
    assert_eq!(x0.len(), n);
    assert_eq!(scale.len(), n);
    let lambda_start = x0[n - 1];
    let dir = if lambda_end >= lambda_start {
        1.0
    } else {
        -1.0
    };
    let mut summary = ContinuationSummary {
        points: 0,
        newton_iterations: 0,
        rejected_steps: 0,
        turning_points: vec![],
        stop: StopReason::ReachedEnd,
        corner_steps: 0,
    };

    let (mut x, mut jac, iters) = match start_point(res, x0, opts) {
        Ok(v) => v,
        Err(failure) => return Err((failure, summary)),
    };
    summary.newton_iterations += iters;
    let Some(mut t) = start_tangent(&jac, scale, dir) else {
        return Err((
            ContinuationFailure::SingularJacobian {
                parameter: lambda_start,
            },
            summary,
        ));
    };
    summary.points = 1;
    if !on_point(&BranchState {
        index: 0,
        x: &x,
        tangent: &t,
        newton_iterations: iters,
        step: 0.0,
    }) {
        summary.stop = StopReason::Callback;
        return Ok(summary);
    }
    let (dsmin, dsmax) = (opts.dsmin(), opts.dsmax());
    let mut ds = opts.ds.clamp(dsmin, dsmax);
    let mut last_dlambda = 0.0;
    let lo = lambda_start.min(lambda_end);
    let hi = lambda_start.max(lambda_end);
    let margin = 1e-12 * (hi - lo).abs().max(1.0);
    loop {
        if summary.points >= opts.max_points {
            summary.stop = StopReason::MaxPoints;
            return Ok(summary);
        }
        // corrector with step halving
        let step = Step {
            x: &x,
            t: &t,
            scale,
            dir,
            lambda_end,
            last_dlambda,
            range: (lo, hi),
        };
        let (x_new, jac_new, it, t_new) =
            match corrected_step(res, &step, &mut ds, opts, &mut summary) {
                Ok(v) => v,
                Err(failure) => return Err((failure, summary)),
            };
        let t_new = match t_new {
            Some(tn) => tn,
            None => {
                return Err((
                    ContinuationFailure::SingularJacobian {
                        parameter: x_new[n - 1],
                    },
                    summary,
                ))
            }
        };
        if t_new[n - 1] * t[n - 1] < 0.0 {
            summary.turning_points.push(summary.points);
        }
        summary.newton_iterations += it;
        let step = ds;
        last_dlambda = (x_new[n - 1] - x[n - 1]).abs();
        x = x_new;
        jac = jac_new;
        t = t_new;
        let _ = &jac;
        let state = BranchState {
            index: summary.points,
            x: &x,
            tangent: &t,
            newton_iterations: it,
            step,
        };
        summary.points += 1;
        if !on_point(&state) {
            summary.stop = StopReason::Callback;
            return Ok(summary);
        }
        let lambda = x[n - 1];
        if lambda > hi - margin && dir > 0.0 || lambda < lo + margin && dir < 0.0 {
            summary.stop = StopReason::ReachedEnd;
            return Ok(summary);
        }
        if lambda < lo - margin && dir > 0.0 || lambda > hi + margin && dir < 0.0 {
            summary.stop = StopReason::LeftRange;
            return Ok(summary);
        }
        if opts.step_adaptation {
            let factor = (opts.target_iterations.max(1) as f64 / it.max(1) as f64).clamp(0.5, 2.0);
            ds = (ds * factor).clamp(dsmin, dsmax);
        }
    }
}

/// The start point: `x0` solved with its parameter fixed (no contraction
/// control: it has no predictor), its Jacobian and Newton iterations.
fn start_point<R: Residual>(
    res: &R,
    x0: DVector<f64>,
    opts: &ContinuationOptions,
) -> Result<NewtonOk<R::Jacobian>, ContinuationFailure> {
    let lambda_start = x0[x0.len() - 1];
    // the start point has no predictor: no contraction control there
    let start_opts = ContinuationOptions {
        max_contraction: None,
        ..opts.clone()
    };
    solve_fixed_parameter(res, x0, &start_opts).map_err(|(norm, it)| {
        ContinuationFailure::StartNotConverged {
            parameter: lambda_start,
            residual_norm: norm,
            iterations: it,
        }
    })
}

/// The start point's unit tangent (scaled unknowns) for the Jacobian `jac`,
/// oriented along the continuation's direction `dir` (`None` if singular).
fn start_tangent<J: BorderedSolve>(
    jac: &J,
    scale: &DVector<f64>,
    dir: f64,
) -> Option<DVector<f64>> {
    let n = scale.len();
    let mut e = DVector::zeros(n);
    e[n - 1] = dir;
    let mut t = tangent(jac, &e.component_mul(scale), scale)?;
    if t[n - 1] * dir < 0.0 {
        t = -t;
    }
    Some(t)
}

/// Where a continuation step starts: the last point `x` and its tangent
/// `t`, the unknowns' `scale`, the direction and end of the parameter, the
/// last step's parameter change and the parameter's range `(lo, hi)`.
struct Step<'a> {
    x: &'a DVector<f64>,
    t: &'a DVector<f64>,
    scale: &'a DVector<f64>,
    dir: f64,
    lambda_end: f64,
    last_dlambda: f64,
    range: (f64, f64),
}

/// The next branch point: predictor and arc-length corrector at step `ds`,
/// halved on every failed or rejected attempt (counted in `summary`); below
/// `dsmin`, natural-parameter steps across a corner of the branch
/// ([`corner_step`], `ds` then `dsmin`), else the step-size collapse. The
/// point's tangent is `None` where its Jacobian is singular.
#[allow(clippy::type_complexity)]
fn corrected_step<R: Residual>(
    res: &R,
    st: &Step,
    ds: &mut f64,
    opts: &ContinuationOptions,
    summary: &mut ContinuationSummary,
) -> Result<(DVector<f64>, R::Jacobian, usize, Option<DVector<f64>>), ContinuationFailure> {
    let (x, t, scale) = (st.x, st.t, st.scale);
    let n = x.len();
    let dsmin = opts.dsmin();
    let mut last_norm = f64::NAN;
    loop {
        match corrector_attempt(res, st, *ds, opts) {
            Ok(v) => return Ok(v),
            Err((norm, it, jumped)) => {
                summary.rejected_steps += 1;
                summary.newton_iterations += it;
                if !jumped {
                    last_norm = norm;
                }
                *ds /= 2.0;
                if *ds < dsmin {
                    // before giving up: natural-parameter steps across a
                    // corner of the branch
                    if let Some(v) =
                        corner_step(res, x, t, scale, st.dir, st.last_dlambda, st.range, opts)
                    {
                        summary.newton_iterations += v.2;
                        summary.corner_steps += 1;
                        *ds = dsmin;
                        return Ok((v.0, v.1, v.2, Some(v.3)));
                    }
                    return Err(ContinuationFailure::StepSizeCollapse {
                        parameter: x[n - 1],
                        residual_norm: last_norm,
                        step_size: *ds,
                        dsmin,
                    });
                }
            }
        }
    }
}

/// One predictor-corrector attempt at step `ds` (the last step lands exactly
/// on `lambda_end` with the parameter fixed). Fails with (residual norm,
/// iterations, jumped): Newton not converged, or rejected as a jump to a
/// distant branch or by the tangent-angle control.
#[allow(clippy::type_complexity)]
fn corrector_attempt<R: Residual>(
    res: &R,
    st: &Step,
    ds: f64,
    opts: &ContinuationOptions,
) -> Result<(DVector<f64>, R::Jacobian, usize, Option<DVector<f64>>), (f64, usize, bool)> {
    let (x, t, scale, dir, lambda_end) = (st.x, st.t, st.scale, st.dir, st.lambda_end);
    let n = x.len();
    let (dsmin, dsmax) = (opts.dsmin(), opts.dsmax());
    let xs = x.component_div(scale);
    let mut xp = (&xs + t * ds).component_mul(scale);
    let mut row = t.component_div(scale);
    let mut target = row.dot(&xp);
    // last step: land exactly on lambda_end (parameter-fixing corrector)
    if dir * (xp[n - 1] - lambda_end) > 0.0 && dir * t[n - 1] > 0.0 {
        let ds_land = (lambda_end - x[n - 1]) / (t[n - 1] * scale[n - 1]);
        xp = (&xs + t * ds_land).component_mul(scale);
        row = DVector::zeros(n);
        row[n - 1] = 1.0;
        target = lambda_end;
    }
    let attempt = newton(res, xp, &row, target, opts).map_err(|(norm, it)| (norm, it, false));
    // reject a corrector that jumped to a distant branch (a converged
    // point much farther away than the step length), unless the step
    // is already at dsmin: a corner of the branch (the stick-slip
    // transition of a friction element, where D(a) has a kink) puts
    // the corrector's point farther than 2 ds at any step length
    // (never farther than 2 dsmax: a corrector that runs off along a
    // flat direction of the residual, e.g. to `a -> infinity` where a
    // saturating element vanishes, is not a corner)
    let attempt = attempt.and_then(|(xn, jn, it)| {
        let dist = (xn.component_div(scale) - &xs).norm();
        if dist > 2.0 * ds && (ds / 2.0 >= dsmin || dist > 2.0 * dsmax) {
            Err((0.0, it, true))
        } else {
            Ok((xn, jn, it))
        }
    });
    // new tangent; tangent-angle control rejects a step that turns
    // the branch direction by more than the allowed angle
    attempt.and_then(|(xn, jn, it)| match tangent(&jn, t, scale) {
        Some(tn) => {
            let cos = tn.dot(t).clamp(-1.0, 1.0);
            match opts.max_tangent_angle_deg {
                Some(max_deg) if cos.acos().to_degrees() > max_deg && ds / 2.0 >= dsmin => {
                    Err((0.0, it, true))
                }
                _ => Ok((xn, jn, it, Some(tn))),
            }
        }
        None => Ok((xn, jn, it, None)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// The unit circle x^2 + y^2 = 1 parametrized by y: two turning points in y.
    struct Circle;
    impl Residual for Circle {
        type Jacobian = DMatrix<f64>;
        fn n_unknowns(&self) -> usize {
            2
        }
        fn eval(&self, x: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
            (
                DVector::from_element(1, x[0] * x[0] + x[1] * x[1] - 1.0),
                DMatrix::from_row_slice(1, 2, &[2.0 * x[0], 2.0 * x[1]]),
            )
        }
    }

    #[test]
    fn circle_passes_its_turning_point() {
        let opts = ContinuationOptions {
            ds: 0.1,
            ..Default::default()
        };
        let scale = DVector::from_element(2, 1.0);
        let mut pts = vec![];
        // start at y = -0.5 on the right half, continue towards y = 2 (never
        // reached): the branch turns at y = 1 and comes back below the start.
        let s = continuation(
            &Circle,
            DVector::from_vec(vec![0.8, -0.5]),
            2.0,
            &scale,
            &opts,
            |b| {
                pts.push(b.x.clone());
                true
            },
        )
        .unwrap();
        for p in &pts {
            assert!((p.norm() - 1.0).abs() < 1e-10);
        }
        assert_eq!(s.turning_points.len(), 1, "{:?}", s.turning_points);
        assert_eq!(s.stop, StopReason::LeftRange);
        let i = s.turning_points[0];
        // the turning point is at (0, 1): x changes sign there
        assert!(
            pts[i - 1][0] > 0.0 && pts[i][0] < 0.0,
            "{:?} {:?}",
            pts[i - 1],
            pts[i]
        );
        assert!(pts[i][1] > 0.8);
        assert!(pts.last().unwrap()[1] < -0.5);
    }

    #[test]
    fn last_point_lands_on_the_end_of_the_range() {
        struct Parabola;
        impl Residual for Parabola {
            type Jacobian = DMatrix<f64>;
            fn n_unknowns(&self) -> usize {
                2
            }
            fn eval(&self, x: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
                (
                    DVector::from_element(1, x[0] - x[1] * x[1]),
                    DMatrix::from_row_slice(1, 2, &[1.0, -2.0 * x[1]]),
                )
            }
        }
        let opts = ContinuationOptions {
            ds: 0.1,
            ..Default::default()
        };
        let scale = DVector::from_element(2, 1.0);
        let mut pts = vec![];
        let s = continuation(
            &Parabola,
            DVector::from_vec(vec![0.3, 0.0]),
            0.77,
            &scale,
            &opts,
            |b| {
                pts.push(b.x.clone());
                true
            },
        )
        .unwrap();
        assert_eq!(s.stop, StopReason::ReachedEnd);
        let last = pts.last().unwrap();
        assert_eq!(last[1], 0.77);
        assert!((last[0] - 0.77 * 0.77).abs() < 1e-12);
        assert!(
            pts[0][0].abs() < 1e-12,
            "start point solved with the parameter fixed"
        );
        assert!(pts.windows(2).all(|w| w[1][1] > w[0][1]));
    }

    #[test]
    fn step_collapse_is_reported() {
        /// R = x - y^2, not evaluable (NaN) for y > 0.5.
        struct Wall;
        impl Residual for Wall {
            type Jacobian = DMatrix<f64>;
            fn n_unknowns(&self) -> usize {
                2
            }
            fn eval(&self, x: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
                let r = if x[1] <= 0.5 {
                    x[0] - x[1] * x[1]
                } else {
                    f64::NAN
                };
                (
                    DVector::from_element(1, r),
                    DMatrix::from_row_slice(1, 2, &[1.0, -2.0 * x[1]]),
                )
            }
        }
        let opts = ContinuationOptions {
            ds: 0.1,
            ..Default::default()
        };
        let scale = DVector::from_element(2, 1.0);
        let mut last = 0.0;
        let err = continuation(
            &Wall,
            DVector::from_vec(vec![0.0, 0.0]),
            1.0,
            &scale,
            &opts,
            |b| {
                last = b.x[1];
                true
            },
        )
        .unwrap_err();
        match err.0 {
            ContinuationFailure::StepSizeCollapse {
                parameter,
                step_size,
                dsmin,
                ..
            } => {
                assert_eq!(parameter, last);
                assert!(parameter < 0.5 && parameter > 0.3, "{parameter}");
                assert!(step_size < dsmin);
            }
            other => panic!("{other:?}"),
        }
        assert!(err.1.points > 3);
    }
}
