//! Adaptive explicit Runge-Kutta Dormand-Prince 5(4) with FSAL, the dopri5 PI
//! step-size controller (or the elementary one, [`Controller`]) and the free
//! 4th-order continuous extension
//! (coefficients of Hairer, Norsett & Wanner, *Solving ODEs I*, Table II.5.2
//! and `dopri5`), written once for every state storage ([`State`]): the
//! slow flow of [`crate::reduced`] integrates a fixed-size `[f64; 2]`, the
//! full-order reference of [`crate::reference`] a `DVector<f64>`.
//!
//! Hand-written rather than taken from a crate (performance and control): the
//! slow flow's hot loop must stay free of heap allocations on a stack array
//! with the right-hand side inlined into the stage arithmetic (the ODE crates
//! on crates.io work on `Vec`/`DVector` states), the reference evaluates its
//! assembled system into preallocated vectors, a failing right-hand side (the
//! amplitude leaves the modal table, `TableError::AboveRange`) must shrink the
//! step instead of aborting, and the observer of accepted steps may stop the
//! integration with its own typed error.
use nalgebra::DVector;

/// Nodes `c_i` of the Butcher tableau.
const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
/// Coefficients `a_ij` (row 6 holds the fifth-order weights `b_j`: FSAL).
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// Error coefficients `b - b*` (fifth minus embedded fourth-order weights).
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];
/// Dense-output coefficients (`contd5` of `dopri5`).
const D: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

/// `sum_j w_j k_j[i]` over the non-zero weights, in the order of `j` (the
/// zero tests fold away: the weights are constants of the tableau).
#[inline(always)]
fn weighted<S: State>(w: &[f64], k: &[S], i: usize) -> f64 {
    let mut s = 0.0;
    for (j, wj) in w.iter().enumerate() {
        if *wj != 0.0 {
            s += wj * k[j].as_slice()[i];
        }
    }
    s
}

/// `out = sum_j w_j k_j` over the non-zero weights, term by term in the
/// order of `j` (the same sums as [`weighted`], one vector operation per
/// stage, so that long states vectorize).
#[inline(always)]
fn weighted_sum<S: State>(out: &mut [f64], w: &[f64], k: &[S]) {
    let mut first = true;
    for (wj, kj) in w.iter().zip(k) {
        if *wj == 0.0 {
            continue;
        }
        let kj = kj.as_slice();
        if first {
            for (o, x) in out.iter_mut().zip(kj) {
                *o = wj * x;
            }
            first = false;
        } else {
            for (o, x) in out.iter_mut().zip(kj) {
                *o += wj * x;
            }
        }
    }
}

/// Storage of an ODE state: a contiguous vector of `f64`.
pub(crate) trait State: Clone {
    fn as_slice(&self) -> &[f64];
    fn as_mut_slice(&mut self) -> &mut [f64];
}

impl<const N: usize> State for [f64; N] {
    #[inline(always)]
    fn as_slice(&self) -> &[f64] {
        self
    }
    #[inline(always)]
    fn as_mut_slice(&mut self) -> &mut [f64] {
        self
    }
}

impl State for DVector<f64> {
    #[inline(always)]
    fn as_slice(&self) -> &[f64] {
        nalgebra::Matrix::as_slice(self)
    }
    #[inline(always)]
    fn as_mut_slice(&mut self) -> &mut [f64] {
        nalgebra::Matrix::as_mut_slice(self)
    }
}

/// How the error of a component is scaled: `atol_i + rtol s_i`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ErrorScale {
    /// `s_i = max(|y_i(t)|, |y_i(t + h)|)` (dopri5).
    Local,
    /// `s_i = max(max_{t' <= t} |y_i(t')|, |y_i(t + h)|)`: the running maximum,
    /// for oscillating states whose zero crossings would otherwise force
    /// tiny steps.
    RunningMax,
}

/// Step-size rule after an accepted step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Controller {
    /// dopri5's PI controller (Gustafsson, beta = 0.04), no growth right
    /// after a rejection: smooth steps for the slow flow.
    Pi,
    /// The elementary controller `h *= 0.9 err^(-1/5)` in `[0.2, 5]`: on a
    /// stability-bounded explicit integration (the reference's stiff
    /// stinger) it takes fewer steps than the PI controller.
    Integral,
}

/// Tolerances and step limits.
#[derive(Debug, Clone)]
pub(crate) struct Tolerances<S> {
    pub rtol: f64,
    /// Absolute tolerance per component.
    pub atol: S,
    pub scale: ErrorScale,
    pub controller: Controller,
    pub h_max: f64,
    pub h_min: f64,
    /// Largest number of steps, accepted and rejected.
    pub max_steps: usize,
    /// Initial step; `None`: chosen from the initial state and slope.
    pub h0: Option<f64>,
}

/// Why the integration stopped early. The last accepted state is kept.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Stop<E> {
    /// The right-hand side failed at every step size down to `h_min`.
    Rhs { t: f64, error: E },
    /// The observer of accepted steps stopped the integration after the step
    /// that ended at `t`.
    Observer { t: f64, error: E },
    /// The error controller asked for a step below `h_min`.
    StepTooSmall { t: f64, h: f64 },
    /// `max_steps` steps (accepted and rejected) were taken.
    MaxSteps { t: f64 },
    /// The state became non-finite.
    NotFinite { t: f64 },
}

/// Counters of one integration.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct IntegratorStats {
    pub accepted_steps: usize,
    pub rejected_steps: usize,
    pub rhs_evaluations: usize,
}

/// The continuous extension of one accepted step on `[t0, t0 + h]`, evaluated
/// on demand from the step's stages (most steps of a stiff reference run are
/// never sampled).
#[derive(Debug, Clone, Copy)]
pub(crate) struct DenseStep<'a, S> {
    pub t0: f64,
    pub h: f64,
    inv_h: f64,
    y0: &'a S,
    y1: &'a S,
    k: &'a [S; 7],
}

/// The coefficients `[y0, ydiff, bspl, r3, r4]` of one component's
/// continuous extension (`rcont1..5` of `dopri5`'s `contd5`).
type Contd = [f64; 5];

/// A component of the continuous extension at local time `s in [0, 1]`
/// from its coefficients ([`Contd`]).
#[inline(always)]
fn contd(c: &Contd, s: f64) -> f64 {
    let [y0, ydiff, bspl, r3, r4] = *c;
    let s1 = 1.0 - s;
    y0 + s * (ydiff + s1 * (bspl + s * (r3 + s1 * r4)))
}

impl<S: State> DenseStep<'_, S> {
    /// The coefficients of component `i` of the continuous extension.
    #[inline(always)]
    fn coefficients(&self, i: usize) -> Contd {
        let h = self.h;
        let y0 = self.y0.as_slice()[i];
        let ydiff = self.y1.as_slice()[i] - y0;
        let bspl = h * self.k[0].as_slice()[i] - ydiff;
        let r3 = ydiff - h * self.k[6].as_slice()[i] - bspl;
        let r4 = h * weighted(&D, self.k, i);
        [y0, ydiff, bspl, r3, r4]
    }

    /// Component `i` of the state at local time `s in [0, 1]` (4th-order
    /// accurate; `contd5` of `dopri5`).
    #[inline(always)]
    fn component(&self, s: f64, i: usize) -> f64 {
        contd(&self.coefficients(i), s)
    }

    /// The state at `t` in `[t0, t0 + h]` into `out`.
    pub fn eval_into(&self, t: f64, out: &mut S) {
        let s = (t - self.t0) * self.inv_h;
        for (i, o) in out.as_mut_slice().iter_mut().enumerate() {
            *o = self.component(s, i);
        }
    }
}

impl<const N: usize> DenseStep<'_, [f64; N]> {
    /// The state at `t` in `[t0, t0 + h]`.
    #[cfg(test)]
    #[inline]
    pub fn eval(&self, t: f64) -> [f64; N] {
        let mut y = [0.0; N];
        self.eval_into(t, &mut y);
        y
    }

    /// The continuous extension with its coefficients computed once: for
    /// several samples in one step (the slow flow's output takes about 13
    /// per step), each then costs the polynomial alone instead of the
    /// step's 7-stage sum. The same numbers as [`Self::eval`], bit for bit.
    #[inline]
    pub fn polynomial(&self) -> DensePoly<N> {
        DensePoly {
            t0: self.t0,
            inv_h: self.inv_h,
            c: std::array::from_fn(|i| self.coefficients(i)),
        }
    }
}

/// The continuous extension of one step of a fixed-size state, its
/// coefficients precomputed ([`DenseStep::polynomial`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct DensePoly<const N: usize> {
    t0: f64,
    inv_h: f64,
    c: [Contd; N],
}

impl<const N: usize> DensePoly<N> {
    /// The state at `t` in `[t0, t0 + h]` (as [`DenseStep::eval`]).
    #[inline(always)]
    pub fn eval(&self, t: f64) -> [f64; N] {
        let s = (t - self.t0) * self.inv_h;
        std::array::from_fn(|i| contd(&self.c[i], s))
    }
}

/// Integrates `y' = f(t, y)` (`f` writes the slope into its last argument)
/// from `t0` to `t_end` (`t_end > t0`), calling `on_step` with the
/// continuous extension of every accepted step and the state at its end; an
/// error of `on_step` stops
/// the integration ([`Stop::Observer`]). Returns the counters and
/// `Some(stop)` if the integration ended early.
pub(crate) fn integrate<S: State, E>(
    mut f: impl FnMut(f64, &S, &mut S) -> Result<(), E>,
    t0: f64,
    y0: S,
    t_end: f64,
    tol: &Tolerances<S>,
    mut on_step: impl FnMut(&DenseStep<S>, &S) -> Result<(), E>,
) -> (IntegratorStats, Option<Stop<E>>) {
    let n = y0.as_slice().len();
    let atol = tol.atol.as_slice();
    assert_eq!(atol.len(), n, "one absolute tolerance per state");
    let mut stats = IntegratorStats::default();
    let zeros = || {
        let mut z = y0.clone();
        z.as_mut_slice().fill(0.0);
        z
    };
    let mut t = t0;
    let mut y = y0.clone();
    let mut w = y0.clone();
    let mut y1 = zeros();
    let mut ys = zeros();
    let mut e = zeros();
    let mut k: [S; 7] = std::array::from_fn(|_| zeros());
    if let Err(error) = f(t, &y, &mut k[0]) {
        return (stats, Some(Stop::Rhs { t, error }));
    }
    stats.rhs_evaluations += 1;
    let mut h = initial_step(tol, &y, &k[0], &mut e, t_end - t0);
    let mut ctl = StepSizeControl {
        ln_last_err_ok: 1e-4f64.ln(),
        reject_streak: false,
    };
    loop {
        if t >= t_end {
            return (stats, None);
        }
        if stats.accepted_steps + stats.rejected_steps >= tol.max_steps {
            return (stats, Some(Stop::MaxSteps { t }));
        }
        let mut last = false;
        if t + h >= t_end || t + 1.01 * h >= t_end {
            h = t_end - t;
            last = true;
        }
        if let Err(error) = stages(&mut f, t, h, &y, &mut y1, &mut ys, &mut k, &mut stats) {
            // The right-hand side is undefined somewhere in this step (e.g. the
            // amplitude left the table): shrink and retry.
            stats.rejected_steps += 1;
            if h <= tol.h_min {
                return (stats, Some(Stop::Rhs { t, error }));
            }
            h = (0.25 * h).max(tol.h_min);
            ctl.reject_streak = true;
            continue;
        }
        let scale = match tol.scale {
            ErrorScale::Local => y.as_slice(),
            ErrorScale::RunningMax => w.as_slice(),
        };
        let (err, finite) = error_estimate(tol, scale, &y1, &k, h);
        if !err.is_finite() || !finite {
            stats.rejected_steps += 1;
            if h <= tol.h_min {
                return (stats, Some(Stop::NotFinite { t }));
            }
            h = (0.25 * h).max(tol.h_min);
            ctl.reject_streak = true;
            continue;
        }
        if err <= 1.0 {
            stats.accepted_steps += 1;
            let dense = DenseStep {
                t0: t,
                h,
                inv_h: 1.0 / h,
                y0: &y,
                y1: &y1,
                k: &k,
            };
            let observed = on_step(&dense, &y1);
            t = if last { t_end } else { t + h };
            if let Err(error) = observed {
                return (stats, Some(Stop::Observer { t, error }));
            }
            std::mem::swap(&mut y, &mut y1);
            k.swap(0, 6);
            if tol.scale == ErrorScale::RunningMax {
                for (wi, yi) in w.as_mut_slice().iter_mut().zip(y.as_slice()) {
                    *wi = wi.abs().max(yi.abs());
                }
            }
            h = ctl.accepted(tol, h, err);
        } else {
            stats.rejected_steps += 1;
            let fac = (0.9 * err.powf(-0.2)).clamp(0.2, 1.0);
            h *= fac;
            ctl.reject_streak = true;
            if h < tol.h_min {
                return (stats, Some(Stop::StepTooSmall { t, h }));
            }
        }
    }
}

/// The weighted RMS norm of `e` with the scales `atol + rtol max(|w|, |y1|)`
/// (`w`: |y| (local) or its running maximum, the error scale besides |y1|).
fn rms_norm<S: State>(tol: &Tolerances<S>, e: &[f64], w: &[f64], y1: &[f64]) -> f64 {
    let atol = tol.atol.as_slice();
    let n = atol.len();
    let mut s = 0.0;
    for i in 0..n {
        let sc = atol[i] + tol.rtol * w[i].abs().max(y1[i].abs());
        s += (e[i] / sc).powi(2);
    }
    (s / n as f64).sqrt()
}

/// The first step: `tol.h0` if given, else (Hairer-Norsett-Wanner II.4,
/// simplified) `h = 0.01 |y|/|y'|` (`1e-6` of the interval `span` for a
/// state or slope near 0), bounded by `h_min`, `h_max`. `zero`: a scratch
/// state (left zero).
fn initial_step<S: State>(tol: &Tolerances<S>, y: &S, slope: &S, zero: &mut S, span: f64) -> f64 {
    // Initial step (Hairer-Norsett-Wanner II.4, simplified): h = 0.01 |y|/|y'|,
    // bounded by h_max; for y = 0 (start from rest) use the scale atol/|y'|.
    if let Some(h0) = tol.h0 {
        h0.min(tol.h_max).max(tol.h_min)
    } else {
        let e: &[f64] = {
            let z = zero.as_mut_slice();
            z.fill(0.0);
            z
        };
        let d0 = rms_norm(tol, y.as_slice(), e, e);
        let d1 = rms_norm(tol, slope.as_slice(), e, e);
        let h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6 * span
        } else {
            0.01 * d0 / d1
        };
        h0.min(tol.h_max).max(tol.h_min)
    }
}

/// Stages 2..7 of the step from `(t, y)` with step `h` into `k[1..7]`;
/// stage 7 is evaluated at the fifth-order solution `y1` (FSAL), `ys` the
/// other stages' states. The error of the right-hand side, if it fails.
#[allow(clippy::too_many_arguments)]
#[inline]
fn stages<S: State, E>(
    f: &mut impl FnMut(f64, &S, &mut S) -> Result<(), E>,
    t: f64,
    h: f64,
    y: &S,
    y1: &mut S,
    ys: &mut S,
    k: &mut [S; 7],
    stats: &mut IntegratorStats,
) -> Result<(), E> {
    // stages 2..7; stage 7 is evaluated at the fifth-order solution (FSAL).
    // One call per stage with the stage a constant: its weights fold into
    // the arithmetic (no loop over the tableau's row, no zero tests at run
    // time); the same sums in the same order.
    stage::<_, _, 1>(f, t, h, y, ys, k, stats)?;
    stage::<_, _, 2>(f, t, h, y, ys, k, stats)?;
    stage::<_, _, 3>(f, t, h, y, ys, k, stats)?;
    stage::<_, _, 4>(f, t, h, y, ys, k, stats)?;
    stage::<_, _, 5>(f, t, h, y, ys, k, stats)?;
    stage::<_, _, 6>(f, t, h, y, y1, k, stats)
}

/// Stage `ST` (`1..7`) of the step from `(t, y)` with step `h`: its state
/// `y + h sum_j A[ST][j] k_j` into `stage`, its slope into `k[ST]`.
#[inline(always)]
fn stage<S: State, E, const ST: usize>(
    f: &mut impl FnMut(f64, &S, &mut S) -> Result<(), E>,
    t: f64,
    h: f64,
    y: &S,
    stage: &mut S,
    k: &mut [S; 7],
    stats: &mut IntegratorStats,
) -> Result<(), E> {
    let (done, rest) = k.split_at_mut(ST);
    let sv = stage.as_mut_slice();
    weighted_sum(sv, &A[ST][..ST], done);
    for (s, yi) in sv.iter_mut().zip(y.as_slice()) {
        *s = yi + h * *s;
    }
    stats.rhs_evaluations += 1;
    f(t + C[ST] * h, &*stage, &mut rest[0])
}

/// The error estimate `h sum_j E_j k_j`, its weighted RMS norm (scales
/// `atol + rtol max(|scale|, |y1|)`) and the finiteness of the new state
/// `y1`, in one pass (the same sums as [`rms_norm`]).
#[inline]
fn error_estimate<S: State>(
    tol: &Tolerances<S>,
    scale: &[f64],
    y1: &S,
    k: &[S; 7],
    h: f64,
) -> (f64, bool) {
    let atol = tol.atol.as_slice();
    let n = atol.len();
    // the error estimate h sum_j E_j k_j, its weighted RMS norm and the
    // finiteness of the new state in one pass (the same sums as `norm`)
    let (mut acc, mut finite) = (0.0, true);
    for (i, (sc_i, y1_i)) in scale.iter().zip(y1.as_slice()).enumerate() {
        let e_i = weighted(&E, k, i) * h;
        let sc = atol[i] + tol.rtol * sc_i.abs().max(y1_i.abs());
        acc += (e_i / sc).powi(2);
        finite &= y1_i.is_finite();
    }
    ((acc / n as f64).sqrt(), finite)
}

/// The step-size controller's memory: the logarithm of the last accepted
/// error (at least `1e-4`) and whether the last step was rejected.
struct StepSizeControl {
    ln_last_err_ok: f64,
    reject_streak: bool,
}

impl StepSizeControl {
    /// The step after an accepted step `h` with error norm `err`: integral
    /// controller (`0.9 err^-0.2` within `[0.2, 5]`) or PI controller.
    fn accepted<S: State>(&mut self, tol: &Tolerances<S>, h: f64, err: f64) -> f64 {
        let mut h = h;
        if tol.controller == Controller::Integral {
            h *= (0.9 * err.max(1e-10).powf(-0.2)).clamp(0.2, 5.0);
            return h.min(tol.h_max);
        }
        // PI controller (Gustafsson / dopri5: beta = 0.04):
        // fac = 0.9 err^(-0.2 + 0.08) last^0.08, as one exp of logarithms
        // (two powf were 8 % of an integration)
        let ln_err = err.max(1e-10).ln();
        let fac = 0.9 * ((-0.2 + 0.08) * ln_err + 0.08 * self.ln_last_err_ok).exp();
        let mut fac = fac.clamp(0.2, 10.0);
        if self.reject_streak {
            fac = fac.min(1.0);
        }
        self.ln_last_err_ok = ln_err.max(1e-4f64.ln());
        self.reject_streak = false;
        (h * fac).min(tol.h_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tol(rtol: f64, h_max: f64) -> Tolerances<[f64; 2]> {
        Tolerances {
            rtol,
            atol: [rtol; 2],
            scale: ErrorScale::Local,
            controller: Controller::Pi,
            h_max,
            h_min: 1e-14,
            max_steps: 1_000_000,
            h0: None,
        }
    }

    /// Harmonic oscillator y'' = -y: y = (cos t, -sin t).
    fn osc(_t: f64, y: &[f64; 2], dy: &mut [f64; 2]) -> Result<(), ()> {
        *dy = [y[1], -y[0]];
        Ok(())
    }

    #[test]
    fn harmonic_oscillator_meets_tolerance_and_order() {
        let mut errs = Vec::new();
        for rtol in [1e-6, 1e-9] {
            let (stats, stop) =
                integrate(osc, 0.0, [1.0, 0.0], 10.0, &tol(rtol, 1.0), |_, _| Ok(()));
            assert!(stop.is_none());
            let mut y_end = [0.0; 2];
            let (_, _) = integrate(osc, 0.0, [1.0, 0.0], 10.0, &tol(rtol, 1.0), |d, _| {
                if (d.t0 + d.h - 10.0).abs() < 1e-12 {
                    y_end = d.eval(10.0);
                }
                Ok(())
            });
            let e = ((y_end[0] - 10f64.cos()).powi(2) + (y_end[1] + 10f64.sin()).powi(2)).sqrt();
            errs.push(e);
            assert!(e < 100.0 * rtol, "rtol {rtol}: error {e}, {stats:?}");
        }
        assert!(errs[1] < errs[0] * 1e-2);
    }

    #[test]
    fn dense_output_is_fourth_order() {
        // Fixed steps (tolerance never binding): the midpoint interpolation error
        // must fall by ~2^5 per halving of h (local error of a 4th-order
        // continuous extension); with a wrong coefficient it falls by 2^4 or less.
        let mut errs = Vec::new();
        for h in [0.4, 0.2, 0.1] {
            let tl = Tolerances {
                rtol: 1e3,
                atol: [1e3; 2],
                scale: ErrorScale::Local,
                controller: Controller::Pi,
                h_max: h,
                h_min: 1e-14,
                max_steps: 1000,
                h0: Some(h),
            };
            let mut maxerr: f64 = 0.0;
            let (_, stop) = integrate(osc, 0.0, [1.0, 0.0], 0.4, &tl, |d, _| {
                if d.t0 == 0.0 {
                    for j in 1..10 {
                        let t = d.t0 + d.h * j as f64 / 10.0;
                        let y = d.eval(t);
                        maxerr = maxerr
                            .max((y[0] - t.cos()).abs())
                            .max((y[1] + t.sin()).abs());
                    }
                }
                Ok(())
            });
            assert!(stop.is_none());
            errs.push(maxerr);
        }
        let r1 = errs[0] / errs[1];
        let r2 = errs[1] / errs[2];
        assert!(r1 > 26.0 && r2 > 26.0, "{errs:?} ratios {r1} {r2}");
    }

    #[test]
    fn failing_rhs_shrinks_the_step_and_then_stops() {
        // y' = 1 undefined for y > 1: stops near t = 1 with the last good state.
        let mut last = 0.0;
        let f = |_t: f64, y: &[f64; 2], dy: &mut [f64; 2]| {
            if y[0] > 1.0 {
                Err(y[0])
            } else {
                *dy = [1.0, 0.0];
                Ok(())
            }
        };
        let tl = Tolerances {
            rtol: 1e-8,
            atol: [1e-8; 2],
            scale: ErrorScale::Local,
            controller: Controller::Pi,
            h_max: 0.3,
            h_min: 1e-9,
            max_steps: 10000,
            h0: None,
        };
        let (_, stop) = integrate(f, 0.0, [0.0, 0.0], 5.0, &tl, |d, _| {
            last = d.eval(d.t0 + d.h)[0];
            Ok(())
        });
        match stop {
            Some(Stop::Rhs { t, .. }) => {
                assert!((t - 1.0).abs() < 1e-6, "{t}");
                assert!(last <= 1.0 && last > 1.0 - 1e-6);
            }
            other => panic!("{other:?}"),
        }
    }
}
