//! The harmonic-balance residual of the assembled model condensed onto the
//! nonlinear elements (module docs of [`super`]), with its analytic Jacobian.
use super::system::{HbSystem, Linear};
use super::HbError;
use crate::nma::continuation::Residual;
use crate::nma::hb::{cos_index, sin_index, Aft, AftOutput};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::cell::RefCell;

/// Force control: the fundamental force amplitude of one force column held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ForceRow {
    /// Index into [`HbSystem::force_names`].
    pub column: usize,
    /// Target amplitude `|F_1|` \[N\].
    pub amplitude_n: f64,
}

/// `R(X) = 0` with `X = [U~; (alpha); Omega]`, `U = x_ref U~` the element
/// displacement harmonics (harmonic-major, `X[h E + e]`).
pub(crate) struct HbResidual<'a> {
    pub sys: &'a HbSystem,
    pub aft: Aft,
    pub x_ref: f64,
    pub force: Option<ForceRow>,
    /// The last linear-part failure (singular dynamic stiffness, singular
    /// `Z22`): the residual is NaN there and the continuation reports it.
    pub last_error: RefCell<Option<HbError>>,
}

/// Complex harmonic `n` of a real coefficient vector at index offset.
fn cplx(v: &DVector<f64>, n: usize) -> Complex64 {
    if n == 0 {
        Complex64::new(v[0], 0.0)
    } else {
        Complex64::new(v[cos_index(n)], -v[sin_index(n)])
    }
}

impl<'a> HbResidual<'a> {
    pub fn harmonics(&self) -> usize {
        self.aft.harmonics()
    }

    fn ne(&self) -> usize {
        self.sys.n_elements()
    }

    /// Number of harmonic rows `E (2H+1)`.
    pub fn m(&self) -> usize {
        self.ne() * self.aft.n_coeffs()
    }

    pub fn alpha(&self, x: &DVector<f64>) -> f64 {
        if self.force.is_some() {
            x[x.len() - 2]
        } else {
            1.0
        }
    }

    /// Element displacement harmonics `U_e` \[m\].
    pub fn element_coeffs(&self, x: &DVector<f64>) -> Vec<DVector<f64>> {
        let (ne, nh) = (self.ne(), self.aft.n_coeffs());
        (0..ne)
            .map(|e| DVector::from_fn(nh, |h, _| self.x_ref * x[h * ne + e]))
            .collect()
    }

    /// AFT of every element at `x`.
    pub fn element_forces(&self, x: &DVector<f64>) -> Vec<AftOutput> {
        let omega = x[x.len() - 1];
        self.element_coeffs(x)
            .iter()
            .zip(&self.sys.laws)
            .map(|(u, law)| self.aft.eval(law.as_ref(), u, omega))
            .collect()
    }

    /// Complex element force harmonics `f[n][e]`.
    pub fn complex_forces(&self, out: &[AftOutput]) -> Vec<DVector<Complex64>> {
        (0..=self.harmonics())
            .map(|n| DVector::from_fn(self.ne(), |e, _| cplx(&out[e].force, n)))
            .collect()
    }

    /// A linear guess at `omega`: the linear response `U = alpha a_1`.
    pub fn linear_guess(&self, lin: &Linear, alpha: f64) -> DVector<f64> {
        let ne = self.ne();
        let mut x = DVector::zeros(self.m());
        if self.harmonics() >= 1 {
            for e in 0..ne {
                let a = lin.a1[e] * alpha / self.x_ref;
                x[cos_index(1) * ne + e] = a.re;
                x[sin_index(1) * ne + e] = -a.im;
            }
        }
        x
    }

    fn nan(&self, n: usize) -> (DVector<f64>, DMatrix<f64>) {
        (
            DVector::from_element(n - 1, f64::NAN),
            DMatrix::zeros(n - 1, n),
        )
    }

    /// Residual and Jacobian given the linear part at `x`'s `Omega`.
    #[allow(clippy::needless_range_loop)] // the harmonic `n` indexes `f`, `lin.r`, `lin.dr` and the columns
    fn assemble(&self, x: &DVector<f64>, lin: &Linear) -> (DVector<f64>, DMatrix<f64>) {
        let n_unk = x.len();
        let (ne, h) = (self.ne(), self.harmonics());
        let m = self.m();
        let alpha = self.alpha(x);
        let out = self.element_forces(x);
        let f = self.complex_forces(&out);
        let col_om = n_unk - 1;
        let mut r = DVector::zeros(n_unk - 1);
        let mut j = DMatrix::zeros(n_unk - 1, n_unk);
        for i in 0..m {
            r[i] = x[i];
            j[(i, i)] = 1.0;
        }
        let inv_ref = 1.0 / self.x_ref;
        for n in 0..=h {
            let rn = &lin.r[n];
            let fom = DVector::from_fn(ne, |e, _| cplx(&out[e].jac_omega, n));
            // complex residual contribution (R_n f_n - alpha a_n) / x_ref and its Omega derivative
            let mut w = rn * &f[n];
            let mut dw = &lin.dr[n] * &f[n] + rn * &fom;
            if n == 1 {
                w -= &lin.a1 * Complex64::new(alpha, 0.0);
                dw -= &lin.da1 * Complex64::new(alpha, 0.0);
            }
            let rows: &[usize] = if n == 0 {
                &[0]
            } else {
                &[cos_index(n), sin_index(n)]
            };
            for e in 0..ne {
                // real layout: c = Re, s = -Im
                let vals = [(w[e].re, dw[e].re), (-w[e].im, -dw[e].im)];
                for (k, &hr) in rows.iter().enumerate() {
                    r[hr * ne + e] += vals[k].0 * inv_ref;
                    j[(hr * ne + e, col_om)] += vals[k].1 * inv_ref;
                }
                if n == 1 && self.force.is_some() {
                    let a = -lin.a1[e] * inv_ref;
                    j[(cos_index(1) * ne + e, col_om - 1)] = a.re;
                    j[(sin_index(1) * ne + e, col_om - 1)] = -a.im;
                }
                for (e2, o) in out.iter().enumerate() {
                    let z = rn[(e, e2)];
                    for h2 in 0..self.aft.n_coeffs() {
                        let col = h2 * ne + e2;
                        if n == 0 {
                            j[(e, col)] += z.re * o.jac_u[(0, h2)];
                        } else {
                            let (gc, gs) = (o.jac_u[(rows[0], h2)], o.jac_u[(rows[1], h2)]);
                            j[(rows[0] * ne + e, col)] += z.re * gc + z.im * gs;
                            j[(rows[1] * ne + e, col)] += -z.im * gc + z.re * gs;
                        }
                    }
                }
            }
        }
        if let Some(fr) = self.force {
            self.force_row(x, lin, fr, &out, &f, &mut r, &mut j);
        }
        (r, j)
    }

    /// The force-control row `(|F|^2 - F*^2) / F*^2` and its derivatives.
    #[allow(clippy::too_many_arguments)]
    fn force_row(
        &self,
        x: &DVector<f64>,
        lin: &Linear,
        fr: ForceRow,
        out: &[AftOutput],
        f: &[DVector<Complex64>],
        r: &mut DVector<f64>,
        j: &mut DMatrix<f64>,
    ) {
        let (ne, row) = (self.ne(), self.m());
        let n_unk = x.len();
        let alpha = self.alpha(x);
        let (phi, dphi, psi, dpsi) = self.sys.force_map(lin, fr.column);
        let fom = DVector::from_fn(ne, |e, _| cplx(&out[e].jac_omega, 1));
        let force = phi * alpha - psi.dot(&f[1]);
        let dforce_om = dphi * alpha - dpsi.dot(&f[1]) - psi.dot(&fom);
        let t2 = fr.amplitude_n * fr.amplitude_n;
        let g = |d: Complex64| 2.0 * (force.conj() * d).re / t2;
        r[row] = (force.norm_sqr() - t2) / t2;
        j[(row, n_unk - 1)] = g(dforce_om);
        j[(row, n_unk - 2)] = g(phi);
        let (c1, s1) = (cos_index(1), sin_index(1));
        for (e, o) in out.iter().enumerate() {
            for h2 in 0..self.aft.n_coeffs() {
                // d f_1,e / dU~ = x_ref (J[c1,h2] - i J[s1,h2])
                let df = Complex64::new(o.jac_u[(c1, h2)], -o.jac_u[(s1, h2)]) * self.x_ref;
                j[(row, h2 * ne + e)] = g(-psi[e] * df);
            }
        }
    }
}

impl<'a> Residual for HbResidual<'a> {
    type Jacobian = DMatrix<f64>;

    fn n_unknowns(&self) -> usize {
        self.m() + usize::from(self.force.is_some()) + 1
    }

    fn eval(&self, x: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
        let omega = x[x.len() - 1];
        if !(omega.is_finite() && omega > 0.0) {
            return self.nan(x.len());
        }
        match self.sys.linear(omega, self.harmonics()) {
            Ok(lin) => self.assemble(x, &lin),
            Err(e) => {
                *self.last_error.borrow_mut() = Some(e);
                self.nan(x.len())
            }
        }
    }
}
