//! Adaptive explicit Runge-Kutta Dormand-Prince 5(4) with FSAL, the standard
//! error-per-step controller and the free 4th-order continuous extension
//! (coefficients of Hairer, Norsett & Wanner, *Solving ODEs I*, `dopri5`).
//!
//! Hand-written rather than taken from a crate because the slow flow has only
//! two real states: a fixed-size `[f64; N]` state keeps the hot loop free of
//! heap allocations (the ODE crates on crates.io work on `Vec`/`DVector`
//! states), the right-hand side may fail (the amplitude leaves the modal
//! table, `TableError::AboveRange`) and that failure must shrink the step
//! instead of aborting, and the whole method is ~150 lines.

/// Butcher tableau of Dormand-Prince 5(4).
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
/// Error coefficients `b - b*` (5th minus 4th order weights).
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
/// Dense-output coefficients (`contd5` of `dopri5`).
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

/// Tolerances and step limits.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tolerances<const N: usize> {
    pub rtol: f64,
    pub atol: [f64; N],
    pub h_max: f64,
    pub h_min: f64,
    pub max_steps: usize,
    /// Initial step; `None`: chosen from the initial state and slope.
    pub h0: Option<f64>,
}

/// Why the integration stopped early. The last accepted state is kept.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Stop<E> {
    /// The right-hand side failed at every step size down to `h_min`.
    Rhs { t: f64, error: E },
    /// The error controller asked for a step below `h_min`.
    StepTooSmall { t: f64, h: f64 },
    /// `max_steps` accepted steps were taken.
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

/// The continuous extension of one accepted step on `[t0, t0 + h]`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DenseStep<const N: usize> {
    pub t0: f64,
    pub h: f64,
    inv_h: f64,
    r: [[f64; N]; 5],
}

impl<const N: usize> DenseStep<N> {
    /// State at `t` in `[t0, t0 + h]` (4th-order accurate).
    pub fn eval(&self, t: f64) -> [f64; N] {
        let s = (t - self.t0) * self.inv_h;
        let s1 = 1.0 - s;
        let mut y = [0.0; N];
        for i in 0..N {
            let r = &self.r;
            y[i] = r[0][i] + s * (r[1][i] + s1 * (r[2][i] + s * (r[3][i] + s1 * r[4][i])));
        }
        y
    }
}

#[inline]
fn comb<const N: usize>(y: &[f64; N], h: f64, terms: &[(f64, &[f64; N])]) -> [f64; N] {
    let mut out = *y;
    for i in 0..N {
        let mut s = 0.0;
        for (c, k) in terms {
            s += c * k[i];
        }
        out[i] += h * s;
    }
    out
}

/// Integrates `y' = f(t, y)` from `t0` to `t_end` (`t_end > t0`), calling
/// `on_step` with the continuous extension of every accepted step.
/// Returns the counters and `Some(stop)` if the integration ended early.
pub(crate) fn integrate<const N: usize, E>(
    mut f: impl FnMut(f64, &[f64; N]) -> Result<[f64; N], E>,
    t0: f64,
    y0: [f64; N],
    t_end: f64,
    tol: &Tolerances<N>,
    mut on_step: impl FnMut(&DenseStep<N>),
) -> (IntegratorStats, Option<Stop<E>>) {
    let mut stats = IntegratorStats::default();
    let norm = |e: &[f64; N], y0: &[f64; N], y1: &[f64; N]| -> f64 {
        let mut s = 0.0;
        for i in 0..N {
            let sc = tol.atol[i] + tol.rtol * y0[i].abs().max(y1[i].abs());
            s += (e[i] / sc).powi(2);
        }
        (s / N as f64).sqrt()
    };
    let mut t = t0;
    let mut y = y0;
    let mut k1 = match f(t, &y) {
        Ok(k) => k,
        Err(error) => return (stats, Some(Stop::Rhs { t, error })),
    };
    stats.rhs_evaluations += 1;
    // Initial step (Hairer-Norsett-Wanner II.4, simplified): h = 0.01 |y|/|y'|,
    // bounded by h_max; for y = 0 (start from rest) use the scale atol/|y'|.
    let mut h = if let Some(h0) = tol.h0 {
        h0.min(tol.h_max).max(tol.h_min)
    } else {
        let zero = [0.0; N];
        let d0 = norm(&y, &zero, &zero);
        let d1 = norm(&k1, &zero, &zero);
        let h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6 * (t_end - t0)
        } else {
            0.01 * d0 / d1
        };
        h0.min(tol.h_max).max(tol.h_min)
    };
    let mut ln_last_err_ok = 1e-4f64.ln();
    let mut reject_streak = false;
    loop {
        if t >= t_end {
            return (stats, None);
        }
        if stats.accepted_steps >= tol.max_steps {
            return (stats, Some(Stop::MaxSteps { t }));
        }
        let mut last = false;
        if t + h >= t_end || t + 1.01 * h >= t_end {
            h = t_end - t;
            last = true;
        }
        // stages (a plain closure over `f`, so the right-hand side is inlined
        // into the stage arithmetic)
        let nev = &mut stats.rhs_evaluations;
        let mut stage = |tt: f64, yy: [f64; N]| {
            *nev += 1;
            f(tt, &yy)
        };
        let mut run = || -> Result<[[f64; N]; 7], E> {
            let k2 = stage(t + C2 * h, comb(&y, h, &[(A21, &k1)]))?;
            let k3 = stage(t + C3 * h, comb(&y, h, &[(A31, &k1), (A32, &k2)]))?;
            let k4 = stage(
                t + C4 * h,
                comb(&y, h, &[(A41, &k1), (A42, &k2), (A43, &k3)]),
            )?;
            let k5 = stage(
                t + C5 * h,
                comb(&y, h, &[(A51, &k1), (A52, &k2), (A53, &k3), (A54, &k4)]),
            )?;
            let k6 = stage(
                t + h,
                comb(
                    &y,
                    h,
                    &[(A61, &k1), (A62, &k2), (A63, &k3), (A64, &k4), (A65, &k5)],
                ),
            )?;
            let y1 = comb(
                &y,
                h,
                &[(A71, &k1), (A73, &k3), (A74, &k4), (A75, &k5), (A76, &k6)],
            );
            let k7 = stage(t + h, y1)?;
            Ok([y1, k2, k3, k4, k5, k6, k7])
        };
        let res = run();
        let [y1, _k2, k3, k4, k5, k6, k7] = match res {
            Ok(v) => v,
            Err(error) => {
                // The right-hand side is undefined somewhere in this step (e.g. the
                // amplitude left the table): shrink and retry.
                stats.rejected_steps += 1;
                if h <= tol.h_min {
                    return (stats, Some(Stop::Rhs { t, error }));
                }
                h = (0.25 * h).max(tol.h_min);
                reject_streak = true;
                continue;
            }
        };
        let mut e = [0.0; N];
        for i in 0..N {
            e[i] =
                h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
        }
        let err = norm(&e, &y, &y1);
        if !err.is_finite() || y1.iter().any(|v| !v.is_finite()) {
            stats.rejected_steps += 1;
            if h <= tol.h_min {
                return (stats, Some(Stop::NotFinite { t }));
            }
            h = (0.25 * h).max(tol.h_min);
            reject_streak = true;
            continue;
        }
        if err <= 1.0 {
            // dense output
            let mut r = [[0.0; N]; 5];
            for i in 0..N {
                let ydiff = y1[i] - y[i];
                let bspl = h * k1[i] - ydiff;
                r[0][i] = y[i];
                r[1][i] = ydiff;
                r[2][i] = bspl;
                r[3][i] = ydiff - h * k7[i] - bspl;
                r[4][i] = h
                    * (D1 * k1[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] + D6 * k6[i] + D7 * k7[i]);
            }
            on_step(&DenseStep {
                t0: t,
                h,
                inv_h: 1.0 / h,
                r,
            });
            stats.accepted_steps += 1;
            t = if last { t_end } else { t + h };
            y = y1;
            k1 = k7;
            // PI controller (Gustafsson / dopri5: beta = 0.04):
            // fac = 0.9 err^(-0.2 + 0.08) last^0.08, as one exp of logarithms
            // (two powf were 8 % of an integration)
            let ln_err = err.max(1e-10).ln();
            let fac = 0.9 * ((-0.2 + 0.08) * ln_err + 0.08 * ln_last_err_ok).exp();
            let mut fac = fac.clamp(0.2, 10.0);
            if reject_streak {
                fac = fac.min(1.0);
            }
            ln_last_err_ok = ln_err.max(1e-4f64.ln());
            reject_streak = false;
            h = (h * fac).min(tol.h_max);
        } else {
            stats.rejected_steps += 1;
            let fac = (0.9 * err.powf(-0.2)).clamp(0.2, 1.0);
            h *= fac;
            reject_streak = true;
            if h < tol.h_min {
                return (stats, Some(Stop::StepTooSmall { t, h }));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tol(rtol: f64, h_max: f64) -> Tolerances<2> {
        Tolerances {
            rtol,
            atol: [rtol; 2],
            h_max,
            h_min: 1e-14,
            max_steps: 1_000_000,
            h0: None,
        }
    }

    /// Harmonic oscillator y'' = -y: y = (cos t, -sin t).
    fn osc(_t: f64, y: &[f64; 2]) -> Result<[f64; 2], ()> {
        Ok([y[1], -y[0]])
    }

    #[test]
    fn harmonic_oscillator_meets_tolerance_and_order() {
        let mut errs = Vec::new();
        for rtol in [1e-6, 1e-9] {
            let (stats, stop) = integrate(osc, 0.0, [1.0, 0.0], 10.0, &tol(rtol, 1.0), |_| {});
            assert!(stop.is_none());
            let mut y_end = [0.0; 2];
            let (_, _) = integrate(osc, 0.0, [1.0, 0.0], 10.0, &tol(rtol, 1.0), |d| {
                if (d.t0 + d.h - 10.0).abs() < 1e-12 {
                    y_end = d.eval(10.0);
                }
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
                h_max: h,
                h_min: 1e-14,
                max_steps: 1000,
                h0: Some(h),
            };
            let mut maxerr: f64 = 0.0;
            let (_, stop) = integrate(osc, 0.0, [1.0, 0.0], 0.4, &tl, |d| {
                if d.t0 == 0.0 {
                    for j in 1..10 {
                        let t = d.t0 + d.h * j as f64 / 10.0;
                        let y = d.eval(t);
                        maxerr = maxerr
                            .max((y[0] - t.cos()).abs())
                            .max((y[1] + t.sin()).abs());
                    }
                }
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
        let f = |_t: f64, y: &[f64; 2]| {
            if y[0] > 1.0 {
                Err(y[0])
            } else {
                Ok([1.0, 0.0])
            }
        };
        let tl = Tolerances {
            rtol: 1e-8,
            atol: [1e-8; 2],
            h_max: 0.3,
            h_min: 1e-9,
            max_steps: 10000,
            h0: None,
        };
        let (_, stop) = integrate(f, 0.0, [0.0, 0.0], 5.0, &tl, |d| {
            last = d.eval(d.t0 + d.h)[0]
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
