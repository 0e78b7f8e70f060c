//! Linear modal analysis: the generalized symmetric eigenproblem
//! `K phi = omega^2 M phi` of the linear, undamped structure (`eq:component1` with
//! `C = 0`, no nonlinear elements), solved by the Cholesky factor `M = L L^T` and the
//! symmetric eigenproblem of `L^{-1} K L^{-T}` (nalgebra).
//!
//! Modes are sorted by ascending frequency and mass-normalised (`Phi^T M Phi = I`).
//! Eigenvalues `|omega^2| <= 1e-12 max omega^2` are rigid-body modes, reported as
//! exactly `omega = 0`.
//! Sign convention: the entry of largest magnitude of each shape is positive (ties
//! within a relative `1e-6` go to the lowest DOF index). Use
//! [`LinearModes::align_signs`] to make the shapes positive at a point instead (e.g.
//! the tip).
use super::{Result, StructuralModel, StructureError};
use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// Linear natural frequencies and mass-normalised mode shapes.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearModes {
    /// Natural angular frequencies `omega_j` [rad/s], ascending.
    pub omega_rad_s: Vec<f64>,
    /// Mode shapes as columns, mass-normalised: `Phi^T M Phi = I`
    /// [1/sqrt(kg) per unit of the generalized coordinate].
    pub shapes: DMatrix<f64>,
}

impl LinearModes {
    /// Number of modes.
    pub fn n_modes(&self) -> usize {
        self.omega_rad_s.len()
    }

    /// Natural frequencies in Hz.
    pub fn frequency_hz(&self) -> Vec<f64> {
        self.omega_rad_s
            .iter()
            .map(|w| w / (2.0 * std::f64::consts::PI))
            .collect()
    }

    /// Shape of mode `j` (mass-normalised column).
    pub fn shape(&self, j: usize) -> DVector<f64> {
        self.shapes.column(j).into_owned()
    }

    /// Modal deflection `phi_j(e) = e^T phi_j` at the point with vector `e`.
    pub fn deflection(&self, j: usize, e: &DVector<f64>) -> f64 {
        self.shapes.column(j).dot(e)
    }

    /// Modal mass of mode `j` with respect to the point `e`, `m_mod = 1 / phi_j(e)^2` [kg]
    /// (paper Section 4, used in the mass ratio `mu = m_a / m_mod`). Infinite at a node
    /// of the mode shape.
    pub fn modal_mass_kg(&self, j: usize, e: &DVector<f64>) -> f64 {
        1.0 / self.deflection(j, e).powi(2)
    }

    /// Flips shapes so that `e^T phi_j >= 0` (shapes with `e^T phi_j = 0` are kept).
    pub fn align_signs(&mut self, e: &DVector<f64>) {
        for j in 0..self.n_modes() {
            if self.deflection(j, e) < 0.0 {
                self.shapes.column_mut(j).neg_mut();
            }
        }
    }
}

/// The `n_modes` lowest modes of `model` (damping and nonlinear elements ignored).
pub fn modal_analysis(model: &StructuralModel, n_modes: usize) -> Result<LinearModes> {
    model.validate()?;
    let (omega_rad_s, shapes) =
        generalized_eigen(&model.mass, &model.stiffness, n_modes, "n_modes")?;
    Ok(LinearModes {
        omega_rad_s,
        shapes,
    })
}

/// The `n_modes` lowest solutions of `K phi = omega^2 M phi` (`M` SPD, `K` symmetric
/// positive semi-definite), mass-normalised, sign as in the module docs.
///
/// The dense eigensolver's eigenvalues carry an absolute error of order
/// `eps lambda_max`; on a fine FE mesh (`lambda_max / lambda_1 ~ 1e10` for 100
/// nodes, `~1e14` for 1000) that is a relative error of `1e-7` or worse on the
/// fundamental, and on very fine meshes the fundamental drowns in it. When `K` is
/// positive definite the flexibility form `M phi = mu K phi`, `mu = 1/omega^2`, is
/// solved instead: its largest eigenvalues are the lowest modes, each accurate to
/// near machine precision. A `K` with rigid-body modes uses the stiffness form.
pub(crate) fn generalized_eigen(
    m: &DMatrix<f64>,
    k: &DMatrix<f64>,
    n_modes: usize,
    name: &'static str,
) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let (omega, mut phi) = match flexibility_eigen(m, k, n_modes, name)? {
        Some(r) => r,
        None => dense_eigen(m, k, n_modes, name)?,
    };
    for mut col in phi.column_iter_mut() {
        let amax = col.amax();
        let first = col
            .iter()
            .position(|v| v.abs() >= (1.0 - 1e-6) * amax)
            .expect("non-empty column");
        if col[first] < 0.0 {
            col.neg_mut();
        }
    }
    Ok((omega, phi))
}

/// `1 <= n_modes <= n`, else [`StructureError::ModeCount`] naming `name`.
fn check_mode_count(n_modes: usize, n: usize, name: &'static str) -> Result<()> {
    if n_modes == 0 || n_modes > n {
        return Err(StructureError::ModeCount {
            name,
            requested: n_modes,
            available: n,
        });
    }
    Ok(())
}

/// The flexibility form of [`generalized_eigen`]: with `K = L L^T`, the symmetric
/// eigenproblem of `L^{-1} M L^{-T}` (eigenvalues `mu = 1/omega^2`), the
/// `n_modes` largest `mu`, mass-normalised. `None` if `K` is not positive definite.
fn flexibility_eigen(
    m: &DMatrix<f64>,
    k: &DMatrix<f64>,
    n_modes: usize,
    name: &'static str,
) -> Result<Option<(Vec<f64>, DMatrix<f64>)>> {
    let n = m.nrows();
    check_mode_count(n_modes, n, name)?;
    let Some(kchol) = k.clone().cholesky() else {
        return Ok(None);
    };
    let l = kchol.l();
    // A singular K (rigid-body modes) can pass the factorisation by rounding, with
    // pivots of order eps times the others; the FE stiffness of a restrained
    // structure has pivots within ~1e-8 of each other (translation vs rotation
    // DOFs on fine meshes). Leave such a K to the stiffness form, which reports
    // rigid-body modes as exactly zero.
    let pivots = l.diagonal().map(|d| d * d);
    if pivots.min() <= 1e-12 * pivots.max() {
        return Ok(None);
    }
    let Some(x) = l.solve_lower_triangular(m) else {
        return Ok(None);
    };
    let Some(b) = l.solve_lower_triangular(&x.transpose()) else {
        return Ok(None);
    };
    let eig = SymmetricEigen::new(super::symmetrize(b));
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let mut omega = Vec::with_capacity(n_modes);
    let mut phi = DMatrix::zeros(n, n_modes);
    for (c, &i) in order.iter().take(n_modes).enumerate() {
        let mu = eig.eigenvalues[i];
        if !(mu.is_finite() && mu > 0.0) {
            return Ok(None);
        }
        let Some(v) = l
            .transpose()
            .solve_upper_triangular(&eig.eigenvectors.column(i).into_owned())
        else {
            return Ok(None);
        };
        let mass = v.dot(&(m * &v));
        if !(mass.is_finite() && mass > 0.0) {
            return Err(StructureError::MassNotPositiveDefinite { name: "mass" });
        }
        phi.set_column(c, &(v / mass.sqrt()));
        omega.push(1.0 / mu.sqrt());
    }
    Ok(Some((omega, phi)))
}

/// The `n_modes` lowest solutions of `K phi = omega^2 M phi` by the dense symmetric
/// eigenproblem of `L^{-1} K L^{-T}`, mass-normalised, arbitrary sign.
fn dense_eigen(
    m: &DMatrix<f64>,
    k: &DMatrix<f64>,
    n_modes: usize,
    name: &'static str,
) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let n = m.nrows();
    check_mode_count(n_modes, n, name)?;
    let chol = m
        .clone()
        .cholesky()
        .ok_or(StructureError::MassNotPositiveDefinite { name: "mass" })?;
    let l = chol.l();
    // A = L^-1 K L^-T = L^-1 (L^-1 K)^T since K is symmetric.
    let x = l
        .solve_lower_triangular(k)
        .ok_or(StructureError::MassNotPositiveDefinite { name: "mass" })?;
    let a = l
        .solve_lower_triangular(&x.transpose())
        .ok_or(StructureError::MassNotPositiveDefinite { name: "mass" })?;
    let a = super::symmetrize(a);
    let eig = SymmetricEigen::new(a);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let lambda_max = eig.eigenvalues.amax();
    let mut omega = Vec::with_capacity(n_modes);
    let mut y = DMatrix::zeros(n, n_modes);
    for (c, &i) in order.iter().take(n_modes).enumerate() {
        let lambda = eig.eigenvalues[i];
        if !lambda.is_finite() {
            return Err(StructureError::NonFinite {
                name: "stiffness".into(),
            });
        }
        // Rigid-body eigenvalues come out as +-(rounding of order eps lambda_max);
        // |lambda| <= 1e-12 lambda_max counts as exactly zero. (The FE spectrum of the
        // 100-node beam spans 1e-10 lambda_max, so a tighter bound is not possible.)
        if lambda < -1e-12 * lambda_max {
            return Err(StructureError::NegativeEigenvalue { index: c, lambda });
        }
        let lambda = if lambda.abs() <= 1e-12 * lambda_max {
            0.0
        } else {
            lambda
        };
        omega.push(lambda.sqrt());
        y.set_column(c, &eig.eigenvectors.column(i));
    }
    let phi = l
        .transpose()
        .solve_upper_triangular(&y)
        .ok_or(StructureError::MassNotPositiveDefinite { name: "mass" })?;
    Ok((omega, phi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_dof_chain_matches_closed_form() {
        // m = 1, 2; springs k = 100 (ground-1), 50 (1-2):
        // det(K - l M) = 0 -> 2 l^2 - 350 l + 5000 = 0
        let m = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 2.0]);
        let k = DMatrix::from_row_slice(2, 2, &[150.0, -50.0, -50.0, 50.0]);
        let model = StructuralModel::new(m.clone(), k.clone());
        let modes = modal_analysis(&model, 2).unwrap();
        let disc = (350.0f64 * 350.0 - 4.0 * 2.0 * 5000.0).sqrt();
        let l1 = (350.0 - disc) / 4.0;
        let l2 = (350.0 + disc) / 4.0;
        assert!((modes.omega_rad_s[0] - l1.sqrt()).abs() < 1e-12 * l1.sqrt());
        assert!((modes.omega_rad_s[1] - l2.sqrt()).abs() < 1e-12 * l2.sqrt());
        let orth = modes.shapes.transpose() * &m * &modes.shapes;
        assert!((orth - DMatrix::identity(2, 2)).amax() < 1e-12);
        let kk = modes.shapes.transpose() * &k * &modes.shapes;
        assert!(
            (kk[(0, 0)] - l1).abs() < 1e-10
                && (kk[(1, 1)] - l2).abs() < 1e-10
                && kk[(0, 1)].abs() < 1e-10
        );
        for j in 0..2 {
            let col = modes.shape(j);
            let imax = col.iamax();
            assert!(col[imax] > 0.0, "sign convention");
        }
    }

    #[test]
    fn refined_modes_of_a_fine_mesh_have_small_residuals() {
        let model = crate::structure::BeamSpec::paper()
            .assemble()
            .unwrap()
            .model;
        let k = &model.stiffness;
        let m = &model.mass;
        let (w_plain, phi_plain) = dense_eigen(m, k, 3, "n_modes").unwrap();
        let kchol = k.clone().cholesky().unwrap();
        // residual phi - w^2 K^{-1} M phi, relative
        let residual = |phi: DVector<f64>, w: f64| {
            (kchol.solve(&(m * &phi)) * (w * w) - &phi).norm() / phi.norm()
        };
        let modes = modal_analysis(&model, 3).unwrap();
        let orth = modes.shapes.transpose() * m * &modes.shapes;
        assert!((orth - DMatrix::<f64>::identity(3, 3)).amax() < 1e-12);
        for (j, (&w, &wp)) in modes.omega_rad_s.iter().zip(&w_plain).enumerate() {
            let res = residual(modes.shape(j), w);
            let res_plain = residual(phi_plain.column(j).into_owned(), wp);
            eprintln!("mode {j}: residual refined {res:e}, plain {res_plain:e}");
            assert!(
                res < 1e-8 && res < 0.1 * res_plain,
                "mode {j}: residual {res:e} vs plain {res_plain:e}"
            );
            // the plain dense solve agrees to its own accuracy (~1e-7 relative)
            assert!((wp - w).abs() < 1e-6 * wp);
        }
    }

    #[test]
    fn bad_mode_counts_and_negative_stiffness() {
        let m = DMatrix::identity(2, 2);
        let k = DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 0.0, -1.0]);
        let model = StructuralModel::new(m, k);
        assert!(matches!(
            modal_analysis(&model, 0),
            Err(StructureError::ModeCount { requested: 0, .. })
        ));
        assert!(matches!(
            modal_analysis(&model, 3),
            Err(StructureError::ModeCount {
                requested: 3,
                available: 2,
                ..
            })
        ));
        assert!(matches!(
            modal_analysis(&model, 1),
            Err(StructureError::NegativeEigenvalue { index: 0, .. })
        ));
    }
}
