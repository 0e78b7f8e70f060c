//! Floquet exponents in the fundamental band from Hill's problem condensed
//! onto the nonlinear elements: the same exponents as the full Hill matrix
//! ([`super::hill`]) at a small fraction of its cost.
//!
//! In the complex Fourier basis `e^{i n Omega t}`, `n = -H..H`, Hill's
//! problem reads (module docs of [`super::hill`])
//!
//! ```text
//! (s + i n Omega - A) Y_n = sum_e g_e phi_n^e,
//! phi^e = T_c[df_e/du] w^e + T_c[df_e/dv] v^e,   w_m^e = c_e^T Y_m,  v_m^e = d_e^T Y_m,
//! ```
//!
//! `T_c = P T P^{-1}` the element operators of the real Hill matrix in the
//! complex basis. Eliminating `Y` leaves the `E (2H+1)` unknowns `Phi`:
//!
//! ```text
//! M(s) Phi = 0,   M(s) = I - T_c G(s),
//! G_n(s) = [c^T; d^T] (s + i n Omega - A)^{-1} G = sum_j r_j l_j^T / (s - p_jn),
//! p_jn = lambda_j - i n Omega,
//! ```
//!
//! with `A = V diag(lambda) V^{-1}` (computed once per system), `r_j = [c^T;
//! d^T] V e_j`, `l_j^T = e_j^T V^{-1} G`. The exponents are the roots of `det
//! M(s)` (plus the eigenvalues of `A` that no element sees, unchanged).
//!
//! **Roots near the band.** The poles `p_jn` within `NEAR_OMEGAS Omega` of the
//! band segment `{i y : |y| <= Omega/2}` are kept as states; the others enter
//! through their value at `s = 0` (a static correction `F_0`). The roots of
//! the reduced problem are the eigenvalues of
//!
//! ```text
//! diag(p_N) + L_N (I - T_c F_0)^{-1} T_c R_N,
//! ```
//!
//! a matrix of the size of the near set (about 50 on the paper beam against
//! 375 rows of the full Hill matrix at H = 7). Each one in the band `|Im s|
//! <= Omega/2` is then refined by Newton's method on `det M(s)` with every
//! pole (`d ln det M / ds = tr(M^{-1} M')`) to `1e-12` of `Omega`: the kept
//! exponents are roots of the exact condensed problem, one per family and
//! sorting-free (the band holds one copy of each exponent). An eigenvalue on a
//! pole (a mode no element sees) is kept as it is.
//!
//! Exponents far from the band (real part below about `-NEAR_OMEGAS Omega`:
//! the shaker's electrical pole, heavily damped modes) and those of modes
//! above `(H + NEAR_OMEGAS) Omega` are not computed: they are linear modes'
//! exponents barely moved by the elements, stable for a stable linear part.
//! A linear part with an eigenvalue in the right half-plane, an ill-conditioned
//! eigenvector basis of `A`, or a root whose Newton correction does not
//! converge makes [`floquet_band`] return `None`, and the caller falls back to
//! the full Hill matrix.
use super::hill::{band, element_operators, real_eigen, summarise, Floquet};
use super::residual::HbResidual;
use crate::nma::hb::{cos_index, sin_index};
use crate::reference::assembly::FirstOrderSystem;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// Poles within this many `Omega` of the band segment are kept as states.
const NEAR_OMEGAS: f64 = 2.0;
/// Newton iterations per root.
const NEWTON_ITERATIONS: usize = 30;
/// Largest accepted `||V|| ||V^{-1}||` of `A`'s eigenvectors.
const MAX_CONDITION: f64 = 1e10;

/// The eigen-decomposition of the assembly's `A` and the elements' view of it.
#[derive(Debug, Clone)]
pub(crate) struct ModalForm {
    /// Eigenvalues `lambda_j` of `A` \[1/s\].
    lambda: Vec<Complex64>,
    /// `V^{-1} G` (`nz x E`).
    l: DMatrix<Complex64>,
    /// `[c^T; d^T] V` (`2E x nz`).
    r: DMatrix<Complex64>,
}

impl ModalForm {
    /// `None` when `A` is not diagonalisable to working accuracy or has an
    /// eigenvalue with a non-negative real part (the full Hill matrix is used).
    pub(crate) fn new(fo: &FirstOrderSystem) -> Option<Self> {
        let (lambda, v) = real_eigen(&fo.a)?;
        if lambda
            .iter()
            .any(|l| l.re.is_nan() || l.re >= 0.0 || !l.im.is_finite())
        {
            return None;
        }
        let vinv = v.clone().try_inverse()?;
        let condition = v.norm() * vinv.norm();
        if condition.is_nan() || condition >= MAX_CONDITION {
            return None;
        }
        let c = |m: &DMatrix<f64>| m.map(|x| Complex64::new(x, 0.0));
        Some(Self {
            lambda,
            l: &vinv * c(&fo.g),
            r: c(&fo.proj) * &v,
        })
    }
}

/// Index of the complex harmonic `n` (`-H..=H`).
fn ci(n: i64, h: usize) -> usize {
    (n + h as i64) as usize
}

/// `P T P^{-1}`: the real cos/sin operator `t` (harmonics `0..=h` of it)
/// in the complex basis `e^{i n tau}`, `n = -h..=h`.
fn to_complex(t: &DMatrix<f64>, h: usize) -> DMatrix<Complex64> {
    let (nr, nc) = (2 * h + 1, 2 * h + 1);
    let i = Complex64::i();
    let one = Complex64::new(1.0, 0.0);
    let mut p = DMatrix::<Complex64>::zeros(nc, nr);
    let mut pinv = DMatrix::<Complex64>::zeros(nr, nc);
    p[(ci(0, h), 0)] = one;
    pinv[(0, ci(0, h))] = one;
    for n in 1..=h {
        let (c, s, ni) = (cos_index(n), sin_index(n), n as i64);
        // X_n = (a_n - i b_n)/2, X_-n = (a_n + i b_n)/2
        p[(ci(ni, h), c)] = 0.5 * one;
        p[(ci(ni, h), s)] = -0.5 * i;
        p[(ci(-ni, h), c)] = 0.5 * one;
        p[(ci(-ni, h), s)] = 0.5 * i;
        // a_n = X_n + X_-n, b_n = i (X_n - X_-n)
        pinv[(c, ci(ni, h))] = one;
        pinv[(c, ci(-ni, h))] = one;
        pinv[(s, ci(ni, h))] = i;
        pinv[(s, ci(-ni, h))] = -i;
    }
    let tr = t.view((0, 0), (nr, nr)).map(|x| Complex64::new(x, 0.0));
    p * tr * pinv
}

/// The condensed problem at one solution.
struct Condensed<'a> {
    modal: &'a ModalForm,
    /// `T_c`: `E nh x 2E nh` (rows `Phi[e nh + n]`, columns `W[rho nh + n]`,
    /// `rho` the element displacement rows then the velocity rows).
    t: DMatrix<Complex64>,
    h: usize,
    omega: f64,
}

impl Condensed<'_> {
    fn nh(&self) -> usize {
        2 * self.h + 1
    }

    fn pole(&self, j: usize, n: i64) -> Complex64 {
        self.modal.lambda[j] - Complex64::new(0.0, n as f64 * self.omega)
    }

    /// `G(s)` and `G'(s)` (`2E nh x E nh`, block diagonal in `n`).
    fn transfer(&self, s: Complex64) -> (DMatrix<Complex64>, DMatrix<Complex64>) {
        let (nh, h) = (self.nh(), self.h as i64);
        let ne = self.modal.l.ncols();
        let mut g = DMatrix::zeros(2 * ne * nh, ne * nh);
        let mut dg = DMatrix::zeros(2 * ne * nh, ne * nh);
        for n in -h..=h {
            let k = ci(n, self.h);
            for j in 0..self.modal.lambda.len() {
                let q = 1.0 / (s - self.pole(j, n));
                for rho in 0..2 * ne {
                    let rj = self.modal.r[(rho, j)];
                    for e in 0..ne {
                        let v = rj * self.modal.l[(j, e)];
                        g[(rho * nh + k, e * nh + k)] += v * q;
                        dg[(rho * nh + k, e * nh + k)] -= v * q * q;
                    }
                }
            }
        }
        (g, dg)
    }

    /// Newton's method on `det M(s)` from `s`; `None` if it does not settle.
    fn refine(&self, mut s: Complex64) -> Option<Complex64> {
        let r = self.t.nrows();
        let tol = 1e-12 * self.omega;
        for _ in 0..NEWTON_ITERATIONS {
            let (g, dg) = self.transfer(s);
            let m = DMatrix::<Complex64>::identity(r, r) - &self.t * g;
            let dm = -(&self.t * dg);
            let lu = m.lu();
            let x = lu.solve(&dm)?;
            let step = 1.0 / x.trace();
            if !(step.re.is_finite() && step.im.is_finite()) {
                return None;
            }
            s -= step;
            if step.norm() <= tol {
                return Some(s);
            }
        }
        None
    }
}

/// The Floquet exponents in the fundamental band of the solution `x` by the
/// condensed Hill problem (module docs), `None` where the full Hill matrix
/// must be used.
pub(crate) fn floquet_band(
    res: &HbResidual,
    modal: &ModalForm,
    x: &DVector<f64>,
    h: usize,
) -> Option<Floquet> {
    let h = h.min(res.harmonics());
    let nh = 2 * h + 1;
    let omega = x[x.len() - 1];
    let ne = modal.l.ncols();
    let mut t = DMatrix::<Complex64>::zeros(ne * nh, 2 * ne * nh);
    for (e, (tk, td)) in element_operators(res, x).into_iter().enumerate() {
        t.view_mut((e * nh, e * nh), (nh, nh))
            .copy_from(&to_complex(&tk, h));
        if let Some(td) = td {
            t.view_mut((e * nh, (ne + e) * nh), (nh, nh))
                .copy_from(&to_complex(&td, h));
        }
    }
    let c = Condensed { modal, t, h, omega };
    // near poles (states) and the far ones' static correction F0 = G_far(0)
    let near_dist = NEAR_OMEGAS * omega;
    let dist = |p: Complex64| {
        let dy = (p.im.abs() - 0.5 * omega).max(0.0);
        p.re.hypot(dy)
    };
    let hi = h as i64;
    let mut near: Vec<(usize, i64)> = Vec::new();
    let mut f0 = DMatrix::<Complex64>::zeros(2 * ne * nh, ne * nh);
    for n in -hi..=hi {
        let k = ci(n, h);
        for j in 0..modal.lambda.len() {
            let p = c.pole(j, n);
            if dist(p) <= near_dist {
                near.push((j, n));
            } else {
                let q = -1.0 / p;
                for rho in 0..2 * ne {
                    for e in 0..ne {
                        f0[(rho * nh + k, e * nh + k)] += modal.r[(rho, j)] * modal.l[(j, e)] * q;
                    }
                }
            }
        }
    }
    let r = ne * nh;
    let tt = (DMatrix::<Complex64>::identity(r, r) - &c.t * &f0)
        .lu()
        .solve(&c.t)?;
    let nn = near.len();
    let mut lmat = DMatrix::<Complex64>::zeros(nn, r);
    let mut rmat = DMatrix::<Complex64>::zeros(2 * ne * nh, nn);
    for (a, &(j, n)) in near.iter().enumerate() {
        let k = ci(n, h);
        for e in 0..ne {
            lmat[(a, e * nh + k)] = modal.l[(j, e)];
        }
        for rho in 0..2 * ne {
            rmat[(rho * nh + k, a)] = modal.r[(rho, j)];
        }
    }
    let mut red = &lmat * tt * &rmat;
    for (a, &(j, n)) in near.iter().enumerate() {
        red[(a, a)] += c.pole(j, n);
    }
    let m = faer::Mat::<Complex64>::from_fn(nn, nn, |i, j| red[(i, j)]);
    let eig = m.eigenvalues().ok()?;
    let on_pole = |s: Complex64| {
        near.iter()
            .any(|&(j, n)| (s - c.pole(j, n)).norm() <= 1e-10 * omega)
    };
    // copies of one exponent: `a - b = i k Omega`
    let same = |a: Complex64, b: Complex64| {
        let d = a - b;
        (d - Complex64::new(0.0, (d.im / omega).round() * omega)).norm() <= 1e-8 * omega
    };
    let mut kept: Vec<Complex64> = Vec::new();
    for s0 in eig {
        if s0.im.abs() > 0.5 * omega * (1.0 + 1e-6) {
            continue;
        }
        let s = if on_pole(s0) { s0 } else { c.refine(s0)? };
        let b = band(s, omega);
        if kept.iter().any(|k| same(*k, b)) {
            // both copies of an exponent on the band's edges are in the band;
            // two estimates converging to one interior root may hide another
            if (b.im.abs() - 0.5 * omega).abs() > 1e-3 * omega {
                return None;
            }
            continue;
        }
        kept.push(b);
    }
    summarise(kept, omega)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attachment::{LinearAttachment, ShakerParams};
    use crate::hb::HbSystem;
    use crate::nma::hb::Aft;
    use crate::structure::{paper_structure, PaperStructureOptions};
    use std::cell::RefCell;

    #[test]
    fn band_roots_are_the_full_hill_matrix_eigenvalues_in_the_band() {
        // the paper beam with its shaker at 10 V; any element motion defines
        // a Hill matrix: a large fundamental with a third harmonic
        let p = paper_structure(&PaperStructureOptions::default()).unwrap();
        let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
        let u = DVector::from_element(1, Complex64::new(10.0, 0.0));
        let sys = HbSystem::new(&p.model, &[shaker], &[u], &[], "tip").unwrap();
        let modal = sys.modal.as_ref().expect("A is diagonalisable and stable");
        for (h, amp, ratio) in [(3usize, 2e-3, 1.25), (3, 4e-3, 0.9), (5, 1e-3, 1.4)] {
            let res = HbResidual {
                sys: &sys,
                aft: Aft::new(h, 4 * h + 1),
                x_ref: 1.0,
                force: None,
                last_error: RefCell::new(None),
            };
            let omega = ratio * p.omega0_rad_s;
            let mut x = DVector::<f64>::zeros(2 * h + 2);
            x[cos_index(1)] = amp;
            x[sin_index(1)] = -0.5 * amp;
            x[cos_index(3)] = 0.1 * amp;
            x[2 * h + 1] = omega;
            let band_roots = floquet_band(&res, modal, &x, h)
                .expect("condensed")
                .exponents;
            let mut hill = crate::hb::hill::hill_matrix(&res, &x, h).unwrap();
            // balanced (Parlett-Reinsch by powers of 2: exact in floating
            // point) so that the full EVD is accurate to its backward error
            let nr = hill.nrows();
            for _ in 0..50 {
                let mut done = true;
                for i in 0..nr {
                    let c: f64 = (0..nr)
                        .filter(|&k| k != i)
                        .map(|k| hill[(k, i)].abs())
                        .sum();
                    let r: f64 = (0..nr)
                        .filter(|&k| k != i)
                        .map(|k| hill[(i, k)].abs())
                        .sum();
                    if c == 0.0 || r == 0.0 {
                        continue;
                    }
                    let f = 2f64.powi(((r / c).log2() / 2.0).round() as i32);
                    if f != 1.0 {
                        done = false;
                        for k in 0..nr {
                            hill[(k, i)] *= f;
                            hill[(i, k)] /= f;
                        }
                    }
                }
                if done {
                    break;
                }
            }
            let (all, _) = real_eigen(&hill).unwrap();
            // every root is an eigenvalue of the full matrix: the smallest
            // singular value of `Hill - s I` is at rounding level (its EVD's
            // eigenvalues agree only to about 1e-5 1/s: an ill-conditioned
            // eigenvalue of a matrix with entries up to 1e5, whose EVD moved
            // by 4e-4 1/s towards the root when balanced)
            let hc = hill.map(|v| Complex64::new(v, 0.0));
            let backward = |z: Complex64| {
                let m = &hc - DMatrix::<Complex64>::identity(nr, nr) * z;
                m.singular_values().min() / hc.norm()
            };
            assert!(!band_roots.is_empty());
            for b in &band_roots {
                let e = backward(*b);
                assert!(e < 1e-12, "H {h}: root {b}: backward error {e:e}");
            }
            // every eigenvalue in the band near the axis is a root
            let inner: Vec<&Complex64> = all
                .iter()
                .filter(|l| l.im.abs() < 0.49 * omega && l.re > -0.5 * omega)
                .collect();
            assert!(!inner.is_empty());
            for l in inner {
                let d = band_roots
                    .iter()
                    .map(|b| (l - b).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(d < 1e-6 * omega, "H {h}: eigenvalue {l} missed ({d})");
            }
        }
    }

    #[test]
    fn complex_basis_of_a_multiplication_is_toeplitz() {
        // k(t) = 2 + cos(tau): T maps the harmonics of u to those of k u
        let h = 3;
        let nh = 2 * h + 1;
        let n = 64;
        let mut t = DMatrix::<f64>::zeros(nh, nh);
        // build T column by column from a sampled product
        for col in 0..nh {
            let mut u = DVector::<f64>::zeros(nh);
            u[col] = 1.0;
            let mut f = DVector::<f64>::zeros(nh);
            for k in 0..n {
                let tau = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
                let mut uu = u[0];
                for m in 1..=h {
                    uu += u[cos_index(m)] * (m as f64 * tau).cos()
                        + u[sin_index(m)] * (m as f64 * tau).sin();
                }
                let fv = (2.0 + tau.cos()) * uu;
                f[0] += fv / n as f64;
                for m in 1..=h {
                    f[cos_index(m)] += 2.0 * fv * (m as f64 * tau).cos() / n as f64;
                    f[sin_index(m)] += 2.0 * fv * (m as f64 * tau).sin() / n as f64;
                }
            }
            t.set_column(col, &f);
        }
        let tc = to_complex(&t, h);
        for a in 0..nh {
            for b in 0..nh {
                let d = a as i64 - b as i64;
                let want = match d {
                    0 => 2.0,
                    1 | -1 => 0.5,
                    _ => 0.0,
                };
                assert!(
                    (tc[(a, b)] - Complex64::new(want, 0.0)).norm() < 1e-12,
                    "{a} {b}"
                );
            }
        }
    }
}
