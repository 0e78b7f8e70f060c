//! Harmonic Balance building blocks: the real Fourier layout and the
//! Alternating-Frequency-Time (AFT) evaluation of a scalar nonlinear force law
//! with its analytic Jacobian.
//!
//! A periodic signal of the normalized time `tau = omega t` is truncated to `H`
//! harmonics (`eq:fourier`) and stored as `2H+1` real coefficients
//!
//! ```text
//! u(tau) = U[0] + sum_{n=1..H} ( U[2n-1] cos(n tau) + U[2n] sin(n tau) ),
//! ```
//!
//! so the complex coefficient of `eq:fourier` is `u_n = U[2n-1] - i U[2n]`
//! (`u_0 = U[0]`). The AFT scheme samples `u(tau)` and `du/dt = omega du/dtau`
//! at `N >= 4H+1` equidistant instants, evaluates the law `f(u, v)` there and
//! projects back onto the harmonics. With `N >= 4H+1` the harmonics `0..=H` of a
//! cubic force are exact (no aliasing).
//!
//! The transforms are precomputed real DFT matrices rather than rustfft: the
//! Jacobian `dF/dU = E diag(df/du) E^-1 + omega E diag(df/dv) D E^-1` needs the
//! full matrices anyway, and for the few nonlinear DOFs of a local nonlinearity
//! the matrix products are as cheap as FFTs at these sizes (`N` ~ 50).
use crate::structure::NonlinearLaw;
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

/// Index of the cosine coefficient of harmonic `n` (`n = 0` is the mean).
#[inline]
pub fn cos_index(n: usize) -> usize {
    if n == 0 {
        0
    } else {
        2 * n - 1
    }
}

/// Index of the sine coefficient of harmonic `n >= 1`.
#[inline]
pub fn sin_index(n: usize) -> usize {
    debug_assert!(n >= 1);
    2 * n
}

/// Harmonic number of real coefficient index `h` (0 for the mean).
#[inline]
pub fn harmonic_of(h: usize) -> usize {
    h.div_ceil(2)
}

/// Complex harmonic `n` of a real coefficient vector (`u_n = U_c - i U_s`).
pub fn complex_harmonic(u: &[f64], n: usize) -> num_complex::Complex64 {
    if n == 0 {
        num_complex::Complex64::new(u[0], 0.0)
    } else {
        num_complex::Complex64::new(u[cos_index(n)], -u[sin_index(n)])
    }
}

/// Default number of AFT samples for `H` harmonics: `4H+1` (exact for cubic laws).
pub fn default_samples(harmonics: usize) -> usize {
    4 * harmonics + 1
}

/// Precomputed real DFT matrices of the AFT scheme.
#[derive(Debug, Clone)]
pub struct Aft {
    harmonics: usize,
    samples: usize,
    /// `N x (2H+1)`: `u(tau_t) = inv[t, :] U`.
    inv: DMatrix<f64>,
    /// `N x (2H+1)`: `du/dtau(tau_t) = dinv[t, :] U`.
    dinv: DMatrix<f64>,
    /// `(2H+1) x N`: `U = fwd f(tau_t)` (least-squares / exact projection).
    fwd: DMatrix<f64>,
}

/// Fourier coefficients of the force of one nonlinear element and their
/// derivatives (all `2H+1` real coefficients, layout of [`cos_index`]).
#[derive(Debug, Clone)]
pub struct AftOutput {
    /// Force harmonics `F` [N].
    pub force: DVector<f64>,
    /// `dF/dU` [N/m], `(2H+1) x (2H+1)`.
    pub jac_u: DMatrix<f64>,
    /// `dF/domega` [N s/rad] (through the velocity `v = omega du/dtau`).
    pub jac_omega: DVector<f64>,
}

impl Aft {
    /// DFT matrices for `harmonics` harmonics and `samples` time samples.
    ///
    /// Panics if `samples < 2H+1` (the projection would be rank deficient); the
    /// drivers check user input against `4H+1` before getting here.
    pub fn new(harmonics: usize, samples: usize) -> Self {
        let nh = 2 * harmonics + 1;
        assert!(
            samples >= nh,
            "AFT needs at least 2H+1 = {nh} samples, got {samples}"
        );
        let mut inv = DMatrix::zeros(samples, nh);
        let mut dinv = DMatrix::zeros(samples, nh);
        let mut fwd = DMatrix::zeros(nh, samples);
        let nf = samples as f64;
        for t in 0..samples {
            let tau = 2.0 * PI * t as f64 / nf;
            inv[(t, 0)] = 1.0;
            fwd[(0, t)] = 1.0 / nf;
            for n in 1..=harmonics {
                let (s, c) = (n as f64 * tau).sin_cos();
                let (ic, is) = (cos_index(n), sin_index(n));
                inv[(t, ic)] = c;
                inv[(t, is)] = s;
                dinv[(t, ic)] = -(n as f64) * s;
                dinv[(t, is)] = n as f64 * c;
                fwd[(ic, t)] = 2.0 * c / nf;
                fwd[(is, t)] = 2.0 * s / nf;
            }
        }
        Self {
            harmonics,
            samples,
            inv,
            dinv,
            fwd,
        }
    }

    pub fn harmonics(&self) -> usize {
        self.harmonics
    }

    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Number of real coefficients `2H+1`.
    pub fn n_coeffs(&self) -> usize {
        2 * self.harmonics + 1
    }

    /// Time samples of a signal and of its `tau`-derivative.
    pub fn to_time(&self, u: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
        (&self.inv * u, &self.dinv * u)
    }

    /// AFT of `law` for the relative displacement harmonics `u` [m] at
    /// oscillation frequency `omega` [rad/s]: force harmonics and analytic
    /// Jacobians `dF/dU`, `dF/domega`.
    pub fn eval(&self, law: &dyn NonlinearLaw, u: &DVector<f64>, omega: f64) -> AftOutput {
        let n = self.samples;
        let nh = self.n_coeffs();
        let ut = &self.inv * u;
        let dut = &self.dinv * u;
        let mut f = DVector::zeros(n);
        let mut fu = DVector::zeros(n);
        let mut fv = DVector::zeros(n);
        for t in 0..n {
            let (ft, fut, fvt) = law.eval(ut[t], omega * dut[t]);
            f[t] = ft;
            fu[t] = fut;
            fv[t] = fvt;
        }
        let force = &self.fwd * &f;
        // d f(t)/dU = fu(t) inv[t,:] + omega fv(t) dinv[t,:]
        let mut dft = DMatrix::zeros(n, nh);
        for t in 0..n {
            let (a, b) = (fu[t], omega * fv[t]);
            for h in 0..nh {
                dft[(t, h)] = a * self.inv[(t, h)] + b * self.dinv[(t, h)];
            }
        }
        let jac_u = &self.fwd * dft;
        let jac_omega = &self.fwd * fv.component_mul(&dut);
        AftOutput {
            force,
            jac_u,
            jac_omega,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug)]
    struct Poly;
    impl NonlinearLaw for Poly {
        fn name(&self) -> &str {
            "poly"
        }
        fn eval(&self, u: f64, v: f64) -> (f64, f64, f64) {
            (
                2.0 * u * u * u + 0.5 * u * v * v,
                6.0 * u * u + 0.5 * v * v,
                u * v,
            )
        }
    }

    #[test]
    fn cubic_of_a_cosine_is_exact() {
        // (A cos)^3 = 3/4 A^3 cos + 1/4 A^3 cos 3
        let aft = Aft::new(3, default_samples(3));
        let mut u = DVector::zeros(7);
        u[cos_index(1)] = 0.7;
        #[derive(Debug)]
        struct Cube;
        impl NonlinearLaw for Cube {
            fn name(&self) -> &str {
                "cube"
            }
            fn eval(&self, u: f64, _v: f64) -> (f64, f64, f64) {
                (u * u * u, 3.0 * u * u, 0.0)
            }
        }
        let out = aft.eval(&Cube, &u, 1.0);
        let a3 = 0.7f64.powi(3);
        assert!((out.force[cos_index(1)] - 0.75 * a3).abs() < 1e-14);
        assert!((out.force[cos_index(3)] - 0.25 * a3).abs() < 1e-14);
        for h in [0, 2, 3, 4, 6] {
            assert!(out.force[h].abs() < 1e-14, "h={h}: {}", out.force[h]);
        }
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let aft = Aft::new(4, 23);
        let u = DVector::from_fn(9, |i, _| {
            0.3 / (1.0 + i as f64) * if i % 2 == 0 { 1.0 } else { -1.0 }
        });
        let omega = 1.7;
        let out = aft.eval(&Poly, &u, omega);
        let h = 1e-6;
        for j in 0..9 {
            let mut up = u.clone();
            up[j] += h;
            let mut um = u.clone();
            um[j] -= h;
            let fd =
                (aft.eval(&Poly, &up, omega).force - aft.eval(&Poly, &um, omega).force) / (2.0 * h);
            let err = (fd - out.jac_u.column(j)).norm();
            assert!(err < 1e-8, "column {j}: {err}");
        }
        let fd = (aft.eval(&Poly, &u, omega + h).force - aft.eval(&Poly, &u, omega - h).force)
            / (2.0 * h);
        assert!((fd - &out.jac_omega).norm() < 1e-8);
    }
}
