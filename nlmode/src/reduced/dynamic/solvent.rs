//! The exact-pole `B22` of a second-order internal block (module docs of
//! [`super`], "Exact poles"): `Z22(lambda) = (lambda M + M X + C)(lambda I -
//! X)` with the right solvent `X` of the positive-frequency poles.
use super::{complex_eigen, CMat};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// `B22(Omega) = i Omega M + (M X + C)` of a second-order internal block
/// with the right solvent `X` (module docs, "Exact poles").
#[derive(Debug, Clone)]
pub(super) struct Solvent {
    m: CMat,
    mx_c: CMat,
}

/// Condition number of `M_22` and of the eigenvector matrix `V` above which
/// [`Solvent::of`] gives up (the first-order `B22` is used).
const SOLVENT_CONDITION_LIMIT: f64 = 1e10;

impl Solvent {
    /// The solvent of the quadratic internal block `a22 = [K, C, M]`, or
    /// `None` where the exact-pole form does not apply (module docs).
    pub(super) fn of(a22: &[DMatrix<f64>]) -> Option<Self> {
        let [k, c, m] = a22 else { return None };
        let nr = k.nrows();
        if nr == 0 {
            return None;
        }
        let cond = |a: &CMat, inv: &CMat| a.norm() * inv.norm();
        let mc = m.map(|v| Complex64::new(v, 0.0));
        let minv = mc.clone().try_inverse()?;
        if cond(&mc, &minv) > SOLVENT_CONDITION_LIMIT {
            return None;
        }
        let cc = c.map(|v| Complex64::new(v, 0.0));
        let kc = k.map(|v| Complex64::new(v, 0.0));
        // companion form of M s^2 + C s + K: [x; s x]
        let mut l = CMat::zeros(2 * nr, 2 * nr);
        for i in 0..nr {
            l[(i, nr + i)] = Complex64::new(1.0, 0.0);
        }
        l.view_mut((nr, 0), (nr, nr)).copy_from(&(-&minv * &kc));
        l.view_mut((nr, nr), (nr, nr)).copy_from(&(-&minv * &cc));
        let (poles, vecs) = complex_eigen(&l)?;
        let mut order: Vec<usize> = (0..2 * nr).collect();
        order.sort_by(|&i, &j| poles[j].im.total_cmp(&poles[i].im));
        let sel = &order[..nr];
        if sel
            .iter()
            .any(|&j| poles[j].im.is_nan() || poles[j].im <= 0.0)
        {
            return None;
        }
        let v = CMat::from_fn(nr, nr, |i, j| vecs[(i, sel[j])]);
        let vinv = v.clone().try_inverse()?;
        if cond(&v, &vinv) > SOLVENT_CONDITION_LIMIT {
            return None;
        }
        let s = CMat::from_diagonal(&DVector::from_iterator(nr, sel.iter().map(|&j| poles[j])));
        let x = &v * s * vinv;
        let mx_c = &mc * x + cc;
        Some(Self { m: mc, mx_c })
    }

    /// `B22` at `Omega` [rad/s].
    pub(super) fn b22(&self, omega: f64) -> CMat {
        &self.m * Complex64::new(0.0, omega) + &self.mx_c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn real(rows: usize, v: &[f64]) -> DMatrix<f64> {
        DMatrix::from_row_slice(rows, rows, v)
    }

    /// One degree of freedom: `B22 = m (i Omega - conj(s))` with the
    /// positive-frequency pole `s`, so `Z22 / B22 = i Omega - s` at every
    /// `Omega` (module docs, "Exact poles").
    #[test]
    fn one_dof_solvent_gives_the_pole_at_every_frequency() {
        let (m, c, k) = (0.0138, 0.188, 1600.0);
        let s = Solvent::of(&[real(1, &[k]), real(1, &[c]), real(1, &[m])]).unwrap();
        let wn = (k / m).sqrt();
        let zeta = c / (2.0 * (k * m).sqrt());
        let pole = Complex64::new(-zeta * wn, wn * (1.0 - zeta * zeta).sqrt());
        for omega in [0.3 * wn, wn, 1.7 * wn] {
            let b = s.b22(omega)[(0, 0)];
            let expected = m * (Complex64::new(0.0, omega) - pole.conj());
            assert!(
                (b - expected).norm() <= 1e-12 * expected.norm(),
                "{b} {expected}"
            );
            let lambda = Complex64::new(0.0, omega);
            let z = m * lambda * lambda + c * lambda + k;
            let mu = z / b;
            assert!((mu - (lambda - pole)).norm() <= 1e-10 * wn, "{mu}");
        }
    }

    /// Two masses in a chain (non-proportional damping): `Z22(lambda) = (lambda
    /// M + M X + C)(lambda I - X)` at any `lambda`, checked through
    /// `B22^{-1} Z22 = lambda I - X` having the eigenvalues `lambda - s_j`
    /// of the two positive-frequency poles.
    #[test]
    fn two_dof_solvent_factorises_the_internal_block() {
        let m = real(2, &[1.0, 0.0, 0.0, 0.5]);
        let c = real(2, &[3.0, -1.0, -1.0, 1.0]);
        let k = real(2, &[3.0e4, -1.0e4, -1.0e4, 1.0e4]);
        let s = Solvent::of(&[k.clone(), c.clone(), m.clone()]).unwrap();
        // the poles from the companion form, independently of Solvent
        let cm = |a: &DMatrix<f64>| a.map(|v| Complex64::new(v, 0.0));
        for omega in [40.0, 110.0, 260.0] {
            let lambda = Complex64::new(0.0, omega);
            let z = cm(&m) * lambda * lambda + cm(&c) * lambda + cm(&k);
            let n = s.b22(omega).try_inverse().unwrap() * z;
            let (mu, _) = complex_eigen(&n).unwrap();
            for mu in mu {
                // lambda - mu is a root of det(M s^2 + C s + K) with Im > 0
                let p = lambda - mu;
                assert!(p.im > 0.0, "{p}");
                let det = (cm(&m) * p * p + cm(&c) * p + cm(&k)).determinant();
                let scale = (cm(&m) * p * p).determinant().norm();
                assert!(det.norm() <= 1e-9 * scale, "pole {p}: det {det}");
            }
        }
    }

    /// Where the exact-pole form does not apply: a first-order block, a
    /// singular mass (a coil current), an overdamped mode.
    #[test]
    fn no_solvent_where_the_form_does_not_apply() {
        assert!(Solvent::of(&[real(1, &[5.0]), real(1, &[2.0])]).is_none());
        let singular = [
            real(2, &[1.0e4, 0.0, 0.0, 3.0]),
            real(2, &[1.0, 0.5, -0.5, 1e-3]),
            real(2, &[0.1, 0.0, 0.0, 0.0]),
        ];
        assert!(Solvent::of(&singular).is_none());
        // c^2 > 4 k m
        assert!(Solvent::of(&[real(1, &[1.0]), real(1, &[10.0]), real(1, &[1.0])]).is_none());
    }
}
