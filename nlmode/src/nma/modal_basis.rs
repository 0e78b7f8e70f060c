//! The linear modes of the structure that the modal Harmonic Balance
//! residuals of [`super::epmc`] are written in (`q = Phi eta`, `Phi^T M Phi =
//! I`, all modes: no truncation), and the nonlinear elements' directions in
//! them.
use super::hb::harmonic_of;
use super::NmaError;
use crate::structure::{NonlinearLaw, StructuralModel};
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// Linear modes of the structure and the nonlinear directions in modal coordinates.
#[derive(Debug, Clone)]
pub struct ModalBasis {
    /// Mass-normalized mode shapes (columns), ascending frequency.
    pub phi: DMatrix<f64>,
    /// Squared natural frequencies `omega_k^2` [rad^2/s^2].
    pub omega2: DVector<f64>,
    /// Modal damping matrix `Phi^T C Phi` [1/s] (zero if conservative).
    pub cm: DMatrix<f64>,
    /// Whether `cm` is diagonal (the condensed solver applies).
    pub diagonal_damping: bool,
    /// Nonlinear directions in modal coordinates, `n x E`.
    pub w: DMatrix<f64>,
    /// Nonlinear force laws, one per column of `w`.
    pub laws: Vec<Arc<dyn NonlinearLaw>>,
    /// Whether the damping was dropped (`cm = 0`).
    pub conservative: bool,
}

impl ModalBasis {
    /// All linear modes of `(M, K)`; `C` projected (or dropped if `conservative`).
    ///
    /// Mode signs: the first named point (else the first nonlinear direction,
    /// else the largest entry) moves in the positive direction.
    pub fn new(model: &StructuralModel, conservative: bool) -> Result<Self, NmaError> {
        let n = model.mass.nrows();
        assert_eq!(model.mass.shape(), (n, n), "mass matrix must be square");
        assert_eq!(
            model.stiffness.shape(),
            (n, n),
            "stiffness matrix must be n x n"
        );
        assert_eq!(
            model.damping.shape(),
            (n, n),
            "damping matrix must be n x n"
        );
        if nalgebra::Cholesky::new(model.mass.clone()).is_none() {
            return Err(NmaError::MassNotPositiveDefinite);
        }
        let (omega2, mut phi) = match nalgebra::Cholesky::new(model.stiffness.clone()) {
            Some(ck) => flexibility_modes(&model.mass, &ck.l()),
            None => stiffness_modes(&model.mass, &model.stiffness),
        };
        let reference: Option<&DVector<f64>> = model
            .points
            .first()
            .map(|p| &p.direction)
            .or_else(|| model.nonlinear.first().map(|e| &e.direction));
        for k in 0..n {
            let col = phi.column(k).clone_owned();
            let mut s = reference.map(|e| e.dot(&col)).unwrap_or(0.0);
            let tol = 1e-9 * col.amax() * reference.map(|e| e.norm()).unwrap_or(0.0);
            if s.abs() <= tol {
                let imax = col.iamax();
                s = col[imax];
            }
            if s < 0.0 {
                phi.column_mut(k).neg_mut();
            }
        }
        let cm = if conservative {
            DMatrix::zeros(n, n)
        } else {
            let cm = phi.transpose() * &model.damping * &phi;
            (&cm + cm.transpose()) * 0.5
        };
        // Off-diagonal modal damping counts if it exceeds both a relative
        // 1e-9 of the diagonal and the rounding level of Phi^T C Phi (about
        // eps times the largest modal damping; a fine FE mesh has
        // omega_max^2 / omega_1^2 ~ 1e10, so C = beta K is not diagonal to
        // much better than that in floating point).
        let c_max = (0..n).map(|k| cm[(k, k)].abs()).fold(0.0, f64::max);
        let mut diagonal_damping = true;
        for i in 0..n {
            for j in 0..n {
                if i != j {
                    let bound = (1e-9 * (cm[(i, i)].abs() * cm[(j, j)].abs()).sqrt())
                        .max(1e4 * f64::EPSILON * c_max);
                    if cm[(i, j)].abs() > bound {
                        diagonal_damping = false;
                    }
                }
            }
        }
        let ne = model.nonlinear.len();
        let mut w = DMatrix::zeros(n, ne);
        for (e, el) in model.nonlinear.iter().enumerate() {
            assert_eq!(
                el.direction.len(),
                n,
                "nonlinear direction '{}' has wrong length",
                el.name
            );
            w.set_column(e, &(phi.transpose() * &el.direction));
        }
        let laws = model.nonlinear.iter().map(|e| e.law.clone()).collect();
        Ok(Self {
            phi,
            omega2,
            cm,
            diagonal_damping,
            w,
            laws,
            conservative,
        })
    }

    pub fn n_modes(&self) -> usize {
        self.omega2.len()
    }

    /// Natural frequency of mode `k` [rad/s].
    pub fn omega(&self, k: usize) -> f64 {
        self.omega2[k].max(0.0).sqrt()
    }

    /// Linear modal damping ratio of mode `k`, `c_kk / (2 omega_k)`.
    pub fn damping_ratio(&self, k: usize) -> f64 {
        self.cm[(k, k)] / (2.0 * self.omega(k))
    }

    /// The modes other than `mode_index` (the one a nonlinear mode continues),
    /// at most [`crate::table::MAX_LINEAR_MODES`] of the lowest, with their
    /// shapes at the model's points `names` (a table's points), for residual
    /// modes ([`crate::reduced::ResidualModes`]). The damping ratios are the
    /// diagonal of `Phi^T C Phi` (zero for a conservative basis; an off-diagonal
    /// modal damping coupling is not carried). `None` if a name is not a point
    /// of `model`.
    pub fn linear_modes(
        &self,
        model: &StructuralModel,
        mode_index: usize,
        names: &[String],
    ) -> Option<crate::table::LinearModes> {
        let modes: Vec<usize> = (0..self.n_modes())
            .filter(|&k| k != mode_index)
            .take(crate::table::MAX_LINEAR_MODES)
            .collect();
        let points = names
            .iter()
            .map(|name| {
                let p = model.points.iter().find(|p| &p.name == name)?;
                Some(crate::table::LinearModeShape {
                    name: name.clone(),
                    shape: modes
                        .iter()
                        .map(|&k| self.phi.column(k).dot(&p.direction))
                        .collect(),
                })
            })
            .collect::<Option<Vec<_>>>()?;
        Some(crate::table::LinearModes {
            omega_rad_s: modes.iter().map(|&k| self.omega(k)).collect(),
            damping_ratio: modes
                .iter()
                .map(|&k| self.damping_ratio(k).max(0.0))
                .collect(),
            points,
        })
    }

    /// Row scales of the harmonic residual: `max(omega_k^2, (n omega_ref)^2)`.
    pub(super) fn row_scale(&self, harmonics: usize, omega_ref: f64) -> DVector<f64> {
        let n = self.n_modes();
        let nh = 2 * harmonics + 1;
        let mut s = DVector::zeros(n * nh);
        for h in 0..nh {
            let nn = harmonic_of(h) as f64;
            for k in 0..n {
                s[h * n + k] = self.omega2[k]
                    .abs()
                    .max((nn * omega_ref).powi(2))
                    .max(1e-300);
            }
        }
        s
    }

    /// `Y = B_n X` per mode for `B_n = n omega (C_m - 2 D omega I)`, `x` one component block.
    pub(super) fn apply_b(&self, nn: f64, omega: f64, d: f64, x: &[f64], out: &mut [f64]) {
        let n = self.n_modes();
        if self.diagonal_damping {
            for k in 0..n {
                out[k] = nn * omega * (self.cm[(k, k)] - 2.0 * d * omega) * x[k];
            }
        } else {
            let xv = DVector::from_column_slice(x);
            let cx = &self.cm * xv;
            for k in 0..n {
                out[k] = nn * omega * (cx[k] - 2.0 * d * omega * x[k]);
            }
        }
    }

    /// Relative displacement harmonics `U_e = scale * W_e^T X` of every element.
    pub(super) fn element_coeffs(&self, x: &[f64], nh: usize, scale: f64) -> Vec<DVector<f64>> {
        let n = self.n_modes();
        (0..self.w.ncols())
            .map(|e| {
                let we = self.w.column(e);
                DVector::from_fn(nh, |h, _| {
                    scale * (0..n).map(|k| we[k] * x[h * n + k]).sum::<f64>()
                })
            })
            .collect()
    }
}

/// All modes from the flexibility form `B = L_K^-1 M L_K^-T`, `K = L_K L_K^T`:
/// `B u = (1/omega^2) u`, `phi = L_K^-T u / sqrt(mu)`. A dense eigensolver has
/// an absolute eigenvalue error of about `eps max(mu)`, so the low modes (large
/// `mu = 1/omega^2`) come out to machine precision even on fine FE meshes
/// where `omega_max^2 / omega_1^2 ~ 1e14` (the stiffness form would lose
/// `omega_1` there). The highest modes of such meshes are not resolved
/// (`mu` at rounding level): their `mu` is floored at `1e3 eps max(mu)`,
/// which keeps their quasi-static flexibility `phi phi^T / omega^2 =
/// L_K^-T u u^T L_K^-1` exact and only misstates their negligible inertia.
fn flexibility_modes(m: &DMatrix<f64>, lk: &DMatrix<f64>) -> (DVector<f64>, DMatrix<f64>) {
    let n = m.nrows();
    let linv_m = lk
        .solve_lower_triangular(m)
        .expect("Cholesky factor is regular");
    let b = lk
        .solve_lower_triangular(&linv_m.transpose())
        .expect("Cholesky factor is regular");
    let b = (&b + b.transpose()) * 0.5;
    let eig = nalgebra::SymmetricEigen::new(b);
    let mu_max = eig.eigenvalues.max();
    let floor = 1e3 * f64::EPSILON * mu_max;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let mut u = DMatrix::zeros(n, n);
    let mut omega2 = DVector::zeros(n);
    for (c, &i) in order.iter().enumerate() {
        let mu = eig.eigenvalues[i].max(floor);
        u.set_column(c, &(eig.eigenvectors.column(i) / mu.sqrt()));
        omega2[c] = 1.0 / mu;
    }
    let phi = lk
        .transpose()
        .solve_upper_triangular(&u)
        .expect("Cholesky factor is regular");
    (omega2, phi)
}

/// All modes from `A = L_M^-1 K L_M^-T` (used when `K` is singular, e.g. free
/// structures); low modes carry an absolute error of `eps omega_max^2`.
fn stiffness_modes(m: &DMatrix<f64>, k: &DMatrix<f64>) -> (DVector<f64>, DMatrix<f64>) {
    let n = m.nrows();
    let l = nalgebra::Cholesky::new(m.clone())
        .expect("mass checked positive definite")
        .l();
    let linv_k = l
        .solve_lower_triangular(k)
        .expect("Cholesky factor is regular");
    let a = l
        .solve_lower_triangular(&linv_k.transpose())
        .expect("Cholesky factor is regular");
    let a = (&a + a.transpose()) * 0.5;
    let eig = nalgebra::SymmetricEigen::new(a);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let mut v = DMatrix::zeros(n, n);
    let mut omega2 = DVector::zeros(n);
    for (c, &i) in order.iter().enumerate() {
        v.set_column(c, &eig.eigenvectors.column(i));
        omega2[c] = eig.eigenvalues[i];
    }
    let phi = l
        .transpose()
        .solve_upper_triangular(&v)
        .expect("Cholesky factor is regular");
    (omega2, phi)
}
