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
//!
//! **Play-type hysteresis** (the Jenkins element,
//! [`crate::structure::Hysteresis::play`]): the loop is integrated exactly
//! between located reversals and slip onsets (`super::play`), so the force
//! harmonics have no sampling error and are smooth in `U` through slip onset;
//! the samples only serve as the grid on which reversals are searched.
//!
//! **Other hysteretic laws** ([`crate::structure::Hysteresis`]) have no force
//! `f(u, v)`: the AFT marches the internal state over the
//! sampled period, starting from the relaxed state at the mean displacement
//! `U[0]` (a stuck slider carrying no mean force), and repeats the period until
//! the state at its end equals the state at its start; the last period's force
//! samples are projected. For a play-type element (Jenkins) the second period is
//! periodic: the first one visits the sampled maximum and minimum. The Jacobian
//! is the exact derivative of these force samples with respect to `U`, by the
//! chain rule through the march (`d s_t/dU` is carried along): in stick
//! `df_t/dU = k_t (E_t - E_slip)` with `E_slip` the row of the last slip sample
//! (or of the mean), in slip `0`.
use crate::structure::{Hysteresis, NonlinearLaw};
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
    /// `inv^T`, `(2H+1) x N`: the rows of `inv` contiguous (hysteretic march).
    inv_t: DMatrix<f64>,
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
            inv_t: inv.transpose(),
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
        if let Some(h) = law.hysteresis() {
            if let Some(p) = h.play() {
                return self.eval_play(p, h, u, true);
            }
            return self.eval_hysteretic(h, u);
        }
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
    /// The force harmonics of [`Aft::eval`] alone (no Jacobians; the same numbers).
    pub fn force(&self, law: &dyn NonlinearLaw, u: &DVector<f64>, omega: f64) -> DVector<f64> {
        if let Some(h) = law.hysteresis() {
            if let Some(p) = h.play() {
                return self.eval_play(p, h, u, false).force;
            }
            return self.eval_hysteretic(h, u).force;
        }
        let ut = &self.inv * u;
        let dut = &self.dinv * u;
        let f = DVector::from_fn(self.samples, |t, _| law.eval(ut[t], omega * dut[t]).0);
        &self.fwd * &f
    }

    /// Most periods marched by [`Aft::eval`] for a hysteretic law (two suffice
    /// for a play-type element; the cap only bounds exotic laws).
    pub const MAX_HYSTERESIS_PERIODS: usize = 4;

    /// The exact AFT of a play-type law ([`super::play`]): the samples only
    /// serve as the grid on which the reversals of `u` are searched. Without
    /// `jacobian` the returned `jac_u` is empty (`(2H+1) x 0`).
    fn eval_play(
        &self,
        p: crate::structure::PlayOperator,
        law: &dyn Hysteresis,
        u: &DVector<f64>,
        jacobian: bool,
    ) -> AftOutput {
        let du = &self.dinv * u;
        let (force, jac_u) =
            super::play::play_aft(p, self.harmonics, u, &du, law.initial_state(u[0]), jacobian);
        AftOutput {
            force,
            jac_u,
            jac_omega: DVector::zeros(self.n_coeffs()),
        }
    }

    /// The sampled AFT of a hysteretic law (see the module docs); rate independent, so
    /// `dF/domega = 0`.
    fn eval_hysteretic(&self, law: &dyn Hysteresis, u: &DVector<f64>) -> AftOutput {
        let n = self.samples;
        let nh = self.n_coeffs();
        let ut = &self.inv * u;
        let rows = self.inv_t.as_slice();
        let mut f = DVector::zeros(n);
        // column t: d f_t / dU (the transposed sample Jacobian)
        let mut dft_t = DMatrix::zeros(nh, n);
        let (mut s, ds0) = law.initial_state(u[0]);
        // d s / dU, a row of length 2H+1 (the mean U[0] only, at the start)
        let mut ds = vec![0.0; nh];
        ds[0] = ds0;
        // the first period only moves the state; later ones record the forces
        // until the state at the end of a period equals that at its start
        for period in 0..Self::MAX_HYSTERESIS_PERIODS {
            let s_start = s;
            let record = period > 0;
            for t in 0..n {
                let st = law.step(s, ut[t]);
                let e = &rows[t * nh..(t + 1) * nh];
                if record {
                    f[t] = st.force;
                    let col = &mut dft_t.as_mut_slice()[t * nh..(t + 1) * nh];
                    for h in 0..nh {
                        col[h] = st.dforce_du * e[h] + st.dforce_ds * ds[h];
                    }
                }
                if st.dstate_ds == 0.0 {
                    for h in 0..nh {
                        ds[h] = st.dstate_du * e[h];
                    }
                } else if !(st.dstate_ds == 1.0 && st.dstate_du == 0.0) {
                    for h in 0..nh {
                        ds[h] = st.dstate_du * e[h] + st.dstate_ds * ds[h];
                    }
                }
                s = st.state;
            }
            if record && s == s_start {
                break;
            }
        }
        AftOutput {
            force: &self.fwd * &f,
            jac_u: &self.fwd * dft_t.transpose(),
            jac_omega: DVector::zeros(nh),
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

    /// First harmonic of the Jenkins loop for `u = x cos(theta)`, `x > F_s/k_t`
    /// (derived in `host/tests/it/elements.rs`): with `cos(theta*) = 1 - 2 F_s/(k_t x)`,
    /// `F_c = k_t x (theta* - sin(2 theta*)/2) / pi`, `F_s = -4 F_s (1 - F_s/(k_t x)) / pi`.
    fn jenkins_first_harmonic(kt: f64, fs: f64, x: f64) -> (f64, f64) {
        let th = (1.0 - 2.0 * fs / (kt * x)).acos();
        (
            kt * x * (th - (2.0 * th).sin() / 2.0) / PI,
            -4.0 * fs * (1.0 - fs / (kt * x)) / PI,
        )
    }

    #[test]
    fn jenkins_aft_matches_the_sampled_loop_and_the_describing_function() {
        use crate::structure::ElasticDryFriction;
        let (kt, fs, x) = (2e5, 3.0, 4e-5);
        let law = ElasticDryFriction::new(kt, fs).unwrap();
        let th = (1.0 - 2.0 * fs / (kt * x)).acos();
        // the loop in closed form (turning points on samples: N even): f(theta) on
        // the descending branch, odd half-wave
        let loop_force = |theta: f64| -> f64 {
            let t = theta.rem_euclid(2.0 * PI);
            let (t, sg) = if t < PI { (t, 1.0) } else { (t - PI, -1.0) };
            sg * if t <= th {
                fs - kt * x * (1.0 - t.cos())
            } else {
                -fs
            }
        };
        for (h, n) in [(1, 6), (7, 30), (7, 64), (3, 1000)] {
            let aft = Aft::new(h, n);
            let mut u = DVector::zeros(2 * h + 1);
            u[cos_index(1)] = x;
            let out = aft.eval_hysteretic(&law, &u);
            let samples = DVector::from_fn(n, |t, _| loop_force(2.0 * PI * t as f64 / n as f64));
            let expect = &aft.fwd * samples;
            assert!((&out.force - &expect).amax() < 1e-12 * fs, "H={h} N={n}");
            assert_eq!(out.jac_omega.amax(), 0.0);
        }
        // the describing function: O(N^-2) sampling error from the slip-onset
        // kink of the sampled march; the exact AFT (transitions located) has none
        let (fc, fsn) = jenkins_first_harmonic(kt, fs, x);
        let mut u = DVector::zeros(3);
        u[cos_index(1)] = x;
        let sampled = Aft::new(1, 1 << 16).eval_hysteretic(&law, &u);
        for (out, tol) in [(sampled, 1e-9), (Aft::new(1, 6).eval(&law, &u, 1.0), 1e-14)] {
            assert!(
                (out.force[cos_index(1)] - fc).abs() < tol * kt * x,
                "{out:?} {fc}"
            );
            assert!((out.force[sin_index(1)] - fsn).abs() < tol * kt * x);
            assert!(out.force[0].abs() < 1e-12 * fs);
        }
        // a phase-shifted, multi-harmonic signal: the exact AFT is the limit of
        // the sampled one (O(1/N) for a reversal between samples)
        let u = DVector::from_vec(vec![2e-6, 3e-5, -2.5e-5, 4e-6, 3e-6, -2e-6, 1e-6]);
        let exact = Aft::new(3, 31).eval(&law, &u, 1.0).force;
        let fine = Aft::new(3, 1 << 16).eval_hysteretic(&law, &u).force;
        assert!(
            (&exact - &fine).amax() < 2e-4 * fs,
            "{}",
            (&exact - &fine).amax()
        );
        // stick: linear with k_t on the oscillating part, no mean force
        let mut u = DVector::zeros(3);
        u[0] = 1e-3;
        u[cos_index(1)] = 0.4 * fs / kt;
        let out = Aft::new(1, 64).eval(&law, &u, 1.0);
        assert!((out.force[cos_index(1)] - 0.4 * fs).abs() < 1e-12 * fs);
        assert!(out.force[0].abs() < 1e-12 * fs && out.force[sin_index(1)].abs() < 1e-12 * fs);
    }

    #[test]
    fn jenkins_aft_jacobian_is_the_exact_derivative() {
        use crate::structure::{ElasticDryFriction, InitialSlider};
        for slider in [InitialSlider::Mean, InitialSlider::Zero] {
            let law = ElasticDryFriction::new(1e5, 2.0)
                .unwrap()
                .with_initial_slider(slider);
            let aft = Aft::new(3, 31);
            for u in [
                vec![1e-5, 6e-5, -1e-5, 0.0, 1.5e-5, 4e-6, -3e-6],
                // stick throughout (mean away from zero)
                vec![1e-5, 6e-6, -1e-6, 0.0, 1.5e-6, 4e-7, -3e-7],
            ] {
                let u = DVector::from_vec(u);
                // the sampled march: piecewise linear in U (central differences
                // exact away from switches); the exact one: smooth
                let sampled = |u: &DVector<f64>| aft.eval_hysteretic(&law, u);
                let exact = |u: &DVector<f64>| aft.eval(&law, u, 10.0);
                for (name, f) in [
                    ("sampled", &sampled as &dyn Fn(&DVector<f64>) -> AftOutput),
                    ("exact", &exact),
                ] {
                    let out = f(&u);
                    let h = 1e-11;
                    for j in 0..7 {
                        let mut up = u.clone();
                        up[j] += h;
                        let mut um = u.clone();
                        um[j] -= h;
                        let fd = (f(&up).force - f(&um).force) / (2.0 * h);
                        let err = (fd - out.jac_u.column(j)).amax();
                        assert!(err < 1e-5 * 1e5, "{name} {slider:?} column {j}: {err}");
                    }
                    assert!(out.jac_u.amax() > 1e3);
                }
            }
        }
    }

    #[test]
    fn polynomial_and_quadratic_damper_aft_match_closed_forms() {
        use crate::structure::{PolynomialSpring, QuadraticDamper};
        // (x cos)^2 = x^2/2 (1 + cos 2), (x cos)^3 = x^3 (3 cos + cos 3)/4
        let (c2, c3, x) = (3e5, 2e9, 1e-3);
        let law = PolynomialSpring::new(&[(2, c2), (3, c3)]).unwrap();
        let aft = Aft::new(3, default_samples(3));
        let mut u = DVector::zeros(7);
        u[cos_index(1)] = x;
        let out = aft.eval(&law, &u, 1.0);
        let scale = c3 * x.powi(3);
        assert!((out.force[0] - c2 * x * x / 2.0).abs() < 1e-10 * scale);
        assert!((out.force[cos_index(1)] - 0.75 * c3 * x.powi(3)).abs() < 1e-10 * scale);
        assert!((out.force[cos_index(2)] - c2 * x * x / 2.0).abs() < 1e-10 * scale);
        assert!((out.force[cos_index(3)] - 0.25 * c3 * x.powi(3)).abs() < 1e-10 * scale);
        // v = -omega x sin: v|v| has first sine harmonic -(8/(3 pi)) (omega x)^2;
        // v|v| is C^1 with its kinks on samples, so the AFT error is O(N^-4)
        let (c, om) = (5.0, 300.0);
        let law = QuadraticDamper::new(c).unwrap();
        let aft = Aft::new(3, 4096);
        let out = aft.eval(&law, &u, om);
        let s1 = -8.0 / (3.0 * PI) * c * (om * x).powi(2);
        assert!(
            (out.force[sin_index(1)] - s1).abs() < 1e-10 * s1.abs(),
            "{}",
            out.force[sin_index(1)] - s1
        );
        // sin|sin| = -(8/pi) sum_{n odd} sin(n theta) / (n (n^2 - 4))
        let s3 = 8.0 / (15.0 * PI) * c * (om * x).powi(2);
        assert!(
            (out.force[sin_index(3)] - s3).abs() < 1e-10 * s1.abs(),
            "{}",
            out.force[sin_index(3)] - s3
        );
    }

    #[test]
    fn unilateral_spring_aft_converges_to_the_closed_form() {
        use crate::structure::UnilateralSpring;
        // contact for cos > g/x: F_0 = k (x sin tc - g tc)/pi,
        // F_1c = k (x (tc + sin tc cos tc) - 2 g sin tc)/pi, tc = acos(g/x)
        let (k, g, x) = (1e6, 3e-4, 1e-3);
        let law = UnilateralSpring::new(k, g).unwrap();
        let tc = (g / x).acos();
        let f0 = k * (x * tc.sin() - g * tc) / PI;
        let f1 = k * (x * (tc + tc.sin() * tc.cos()) - 2.0 * g * tc.sin()) / PI;
        let aft = Aft::new(1, 1 << 18);
        let mut u = DVector::zeros(3);
        u[cos_index(1)] = x;
        let out = aft.eval(&law, &u, 1.0);
        assert!(
            (out.force[0] - f0).abs() < 1e-10 * k * x,
            "{}",
            out.force[0] - f0
        );
        assert!(
            (out.force[cos_index(1)] - f1).abs() < 1e-10 * k * x,
            "{}",
            out.force[cos_index(1)] - f1
        );
    }
}
