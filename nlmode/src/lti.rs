//! Exact discretization of linear time-invariant systems `x' = A x + B u` with
//! first-order-hold inputs (`u` linear in time over each step).
//!
//! Over a step of length `h` with `u(s) = u0 + (u1 - u0) s / h`,
//!
//! ```text
//! x(h) = Phi x0 + Gamma0 u0 + Gamma1 (u1 - u0) / h,
//! Phi = e^{A h},  Gamma0 = int_0^h e^{A (h-s)} B ds,  Gamma1 = int_0^h e^{A (h-s)} B s ds,
//! ```
//!
//! all three read off one matrix exponential of the augmented matrix
//! `[[A h, B h, 0], [0, 0, I], [0, 0, 0]]` (normalized time `s/h`, state
//! `[x; u; u1 - u0]`), whose top row of blocks is `[Phi, Gamma0, Gamma1/h]`.
//! The result is exact for piecewise-linear inputs, for any `h`, so a stiff
//! system (the shaker with its stinger, eigenvalues ~ 2.5e4 1/s) stays stable
//! and accurate at any communication step.
//!
//! The exponential is nalgebra's `Matrix::exp` (scaling and squaring with
//! Pade approximants, Higham 2005). It stays accurate to ~1e-9 relative on the
//! badly scaled mechanical matrices of the shaker (6e8 1/s^2 next to 1), as the
//! tests against analytic solutions show.
use nalgebra::{DMatrix, DVector};

/// Errors of the discretization; each names the offending number.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LtiError {
    #[error("step size must be positive and finite, got {h} s")]
    BadStep { h: f64 },
    #[error("system matrices contain a non-finite entry")]
    NonFiniteSystem,
    #[error("matrix exponential is not finite for step {h} s")]
    NonFiniteExponential { h: f64 },
}

/// The discrete-time map of one step of length `h`:
/// `x1 = phi x0 + p u0 + q u1` (`p = Gamma0 - Gamma1/h`, `q = Gamma1/h`).
#[derive(Debug, Clone, PartialEq)]
pub struct FohStep {
    /// Step size [s].
    pub h: f64,
    pub phi: DMatrix<f64>,
    pub p: DMatrix<f64>,
    pub q: DMatrix<f64>,
}

impl FohStep {
    /// Discretize `x' = A x + B u` for step `h` (`A`: n x n, `B`: n x m).
    pub fn new(a: &DMatrix<f64>, b: &DMatrix<f64>, h: f64) -> Result<Self, LtiError> {
        let n = a.nrows();
        assert_eq!(a.ncols(), n, "A must be square");
        assert_eq!(b.nrows(), n, "B must have as many rows as A");
        let m = b.ncols();
        if !(h.is_finite() && h > 0.0) {
            return Err(LtiError::BadStep { h });
        }
        if a.iter().chain(b.iter()).any(|v| !v.is_finite()) {
            return Err(LtiError::NonFiniteSystem);
        }
        let na = n + 2 * m;
        let mut big = DMatrix::zeros(na, na);
        big.view_mut((0, 0), (n, n)).copy_from(&(a * h));
        big.view_mut((0, n), (n, m)).copy_from(&(b * h));
        // In normalized time tau = s/h the input is u0 + (u1 - u0) tau, so the
        // augmented state [x; u; u1 - u0] has du/dtau = (u1 - u0): entry 1.
        for k in 0..m {
            big[(n + k, n + m + k)] = 1.0;
        }
        let e = big.exp();
        if e.iter().any(|v| !v.is_finite()) {
            return Err(LtiError::NonFiniteExponential { h });
        }
        let phi = e.view((0, 0), (n, n)).into_owned();
        let gamma0 = e.view((0, n), (n, m)).into_owned();
        // the third block column multiplies (u1 - u0): it is Gamma1 / h
        let gamma1_over_h = e.view((0, n + m), (n, m)).into_owned();
        let p = &gamma0 - &gamma1_over_h;
        Ok(Self {
            h,
            phi,
            p,
            q: gamma1_over_h,
        })
    }

    /// `out = phi x0 + p u0 + q u1` (no allocation).
    pub fn step_into(
        &self,
        x0: &DVector<f64>,
        u0: &DVector<f64>,
        u1: &DVector<f64>,
        out: &mut DVector<f64>,
    ) {
        out.gemv(1.0, &self.phi, x0, 0.0);
        out.gemv(1.0, &self.p, u0, 1.0);
        out.gemv(1.0, &self.q, u1, 1.0);
    }

    /// `phi x0 + p u0 + q u1`.
    pub fn step(&self, x0: &DVector<f64>, u0: &DVector<f64>, u1: &DVector<f64>) -> DVector<f64> {
        let mut out = DVector::zeros(x0.len());
        self.step_into(x0, u0, u1, &mut out);
        out
    }
}

/// A small most-recently-used cache of per-step-size data keyed by the exact
/// step size [s] (a co-simulation master usually repeats one or two step
/// sizes).
#[derive(Debug, Clone, PartialEq)]
pub struct StepCache<D> {
    entries: Vec<(f64, D)>,
}

/// How many step sizes a [`StepCache`] keeps.
const CACHE_SIZE: usize = 4;

impl<D> Default for StepCache<D> {
    fn default() -> Self {
        Self {
            entries: Vec::with_capacity(CACHE_SIZE),
        }
    }
}

impl<D> StepCache<D> {
    /// The entry for step `h`, made by `make` if absent (then the least
    /// recently used entry is dropped when full); the entry moves to the front.
    #[inline]
    pub fn get_or_try_insert<E>(
        &mut self,
        h: f64,
        make: impl FnOnce() -> Result<D, E>,
    ) -> Result<&D, E> {
        if let Some(i) = self.entries.iter().position(|(hi, _)| *hi == h) {
            if i != 0 {
                self.entries[..=i].rotate_right(1);
            }
        } else {
            let d = make()?;
            if self.entries.len() == CACHE_SIZE {
                self.entries.pop();
            }
            self.entries.insert(0, (h, d));
        }
        Ok(&self.entries[0].1)
    }

    /// Number of cached step sizes.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether nothing is cached.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Drop every entry.
    pub fn clear(&mut self) {
        self.entries.clear();
    }
}

/// An LTI system with a small cache of discretizations keyed by the exact step
/// size ([`StepCache`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LtiFoh {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    cache: StepCache<FohStep>,
}

impl LtiFoh {
    pub fn new(a: DMatrix<f64>, b: DMatrix<f64>) -> Self {
        assert_eq!(a.nrows(), a.ncols(), "A must be square");
        assert_eq!(a.nrows(), b.nrows(), "B must have as many rows as A");
        Self {
            a,
            b,
            cache: StepCache::default(),
        }
    }

    /// The discretization for step `h` (computed once, then cached).
    pub fn discretization(&mut self, h: f64) -> Result<&FohStep, LtiError> {
        let (a, b) = (&self.a, &self.b);
        self.cache.get_or_try_insert(h, || FohStep::new(a, b, h))
    }

    /// Advance `x` by `h` with inputs going linearly from `u0` to `u1`.
    pub fn step(
        &mut self,
        x: &mut DVector<f64>,
        u0: &DVector<f64>,
        u1: &DVector<f64>,
        h: f64,
    ) -> Result<(), LtiError> {
        let d = self.discretization(h)?;
        let x1 = d.step(x, u0, u1);
        x.copy_from(&x1);
        Ok(())
    }

    /// Number of cached step sizes.
    pub fn cached(&self) -> usize {
        self.cache.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{dmatrix, dvector};

    /// Scalar lag x' = -x/tau + u/tau, ramp input: analytic solution.
    #[test]
    fn scalar_lag_with_ramp_matches_analytic() {
        let tau: f64 = 0.3;
        let a = dmatrix![-1.0 / tau];
        let b = dmatrix![1.0 / tau];
        let (x0, u0, u1) = (0.7, -0.2, 1.5);
        for h in [1e-6_f64, 1e-3, 0.1, 2.0, 50.0] {
            let w = (u1 - u0) / h;
            // x = u0 + w (t - tau) + (x0 - u0 + w tau) e^{-t/tau}, written
            // without cancellation: u0 + w t + (x0 - u0) e^{-t/tau} + w tau expm1(-t/tau)
            let exact = u0 + w * h + (x0 - u0) * (-h / tau).exp() + w * tau * (-h / tau).exp_m1();
            let s = FohStep::new(&a, &b, h).unwrap();
            let x = s.step(&dvector![x0], &dvector![u0], &dvector![u1])[0];
            assert!(
                (x - exact).abs() < 1e-12 * (1.0 + exact.abs()),
                "h={h}: {x} vs {exact}"
            );
        }
    }

    /// Damped oscillator x'' + 2 z w x' + w^2 x = w^2 u, u = u0 + r t:
    /// x_p = u0 + r (t - 2z/w), plus the homogeneous solution.
    fn oscillator_exact(w: f64, z: f64, x0: f64, v0: f64, u0: f64, r: f64, t: f64) -> (f64, f64) {
        let wd = w * (1.0 - z * z).sqrt();
        let c1 = x0 - (u0 - r * 2.0 * z / w);
        let c2 = (v0 - r + z * w * c1) / wd;
        let e = (-z * w * t).exp();
        let (s, c) = (wd * t).sin_cos();
        let x = u0 + r * (t - 2.0 * z / w) + e * (c1 * c + c2 * s);
        let v = r + e * (-z * w * (c1 * c + c2 * s) + (-c1 * wd * s + c2 * wd * c));
        (x, v)
    }

    #[test]
    fn stiff_badly_scaled_oscillator_matches_analytic_for_any_step() {
        // the shaker's stinger mode: w ~ 2.46e4 rad/s, A has 6e8 next to 1
        for (w, z) in [(2.46e4, 0.02), (356.0, 0.004), (10.0, 0.5)] {
            let a = dmatrix![0.0, 1.0; -w * w, -2.0 * z * w];
            let b = dmatrix![0.0; w * w];
            let (x0, v0, u0, r) = (1e-6, -3e-3, 2e-6, 4e-3);
            for h in [1e-7, 1e-5, 1e-3, 0.1] {
                let u1 = u0 + r * h;
                let s = FohStep::new(&a, &b, h).unwrap();
                let x = s.step(&dvector![x0, v0], &dvector![u0], &dvector![u1]);
                let (xe, ve) = oscillator_exact(w, z, x0, v0, u0, r, h);
                let xs = 1e-6_f64.max(xe.abs());
                let vs = (w * 1e-6).max(ve.abs());
                assert!(
                    (x[0] - xe).abs() < 1e-9 * xs,
                    "w={w} h={h}: x {} vs {xe}",
                    x[0]
                );
                assert!(
                    (x[1] - ve).abs() < 1e-9 * vs,
                    "w={w} h={h}: v {} vs {ve}",
                    x[1]
                );
            }
        }
    }

    #[test]
    fn many_steps_equal_one_step_for_linear_input() {
        // FOH is exact for a ramp, so 1000 steps of h equal one step of 1000 h
        let a = dmatrix![-21428.0, 0.0, -1.1e5; 0.0, 0.0, 1.0; 360.0, -6.05e8, -20.0];
        let b = dmatrix![7142.0, 0.0; 0.0, 0.0; 0.0, 6.04e8];
        let mut sys = LtiFoh::new(a, b);
        let u = |t: f64| dvector![2.0 + 30.0 * t, 1e-5 - 0.01 * t];
        let mut x = dvector![0.1, 1e-6, 0.0];
        let x_start = x.clone();
        let h = 1e-5;
        for k in 0..1000 {
            let t = k as f64 * h;
            sys.step(&mut x, &u(t), &u(t + h), h).unwrap();
        }
        let mut y = x_start;
        sys.step(&mut y, &u(0.0), &u(1000.0 * h), 1000.0 * h)
            .unwrap();
        for i in 0..3 {
            assert!(
                (x[i] - y[i]).abs() < 1e-9 * y[i].abs().max(1e-9),
                "{i}: {} vs {}",
                x[i],
                y[i]
            );
        }
        assert_eq!(sys.cached(), 2);
    }

    #[test]
    fn cache_keeps_recent_steps_and_bad_steps_are_errors() {
        let mut sys = LtiFoh::new(dmatrix![-1.0], dmatrix![1.0]);
        for h in [0.1, 0.2, 0.3, 0.4, 0.5, 0.1] {
            assert_eq!(sys.discretization(h).unwrap().h, h);
        }
        assert_eq!(sys.cached(), 4);
        assert_eq!(sys.discretization(-1.0), Err(LtiError::BadStep { h: -1.0 }));
        assert_eq!(
            sys.discretization(f64::NAN).unwrap_err().to_string(),
            "step size must be positive and finite, got NaN s"
        );
        let mut bad = LtiFoh::new(dmatrix![f64::NAN], dmatrix![1.0]);
        assert_eq!(bad.discretization(1.0), Err(LtiError::NonFiniteSystem));
    }
}
