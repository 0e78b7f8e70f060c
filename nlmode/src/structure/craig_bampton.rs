//! Craig-Bampton reduction (paper Section 5: tip translation as master plus 10
//! fixed-interface normal modes).
//!
//! With the master DOFs `b` and the remaining (interior) DOFs `i`,
//!
//! ```text
//! q = T q_red,   q_red = [q_b; eta],   T = [ I       0    ]   (rows b)
//!                                          [ Psi   Phi_i  ]   (rows i)
//! Psi = -K_ii^{-1} K_ib   (static constraint modes),
//! K_ii Phi_i = M_ii Phi_i diag(omega_i^2)   (fixed-interface modes, mass-normalised)
//! ```
//!
//! The reduced model is `T^T M T`, `T^T K T`, `T^T C T`; named points and nonlinear
//! element directions are projected as `T^T e` (so `u = e^T q = (T^T e)^T q_red`).
//! Reduced coordinates: the masters first (in the order given), then the modal
//! coordinates `eta` in ascending frequency.
//!
//! [`craig_bampton`] works on the dense [`StructuralModel`]; [`craig_bampton_sparse`]
//! on sparse `M`, `K`, `C` of a large FE model, with the same `T` (sparse solves
//! with the leading block of `K`'s factor, the masters ordered last, for `Psi` and inside the
//! shift-invert Lanczos of [`super::lanczos`] for `Phi_i`, [`InteriorSolver`]),
//! never forming a dense full-size matrix nor a copy of `K_ii`, `M_ii`.
use super::lanczos::{lanczos, Pencil, ShiftInvert};
use super::modal::generalized_eigen;
use super::sparse::{
    sym_mul_par, SparseCholesky, SparseMatrix, SparseOptions, Stage, StageTimings, SymbolicFactor,
};
use super::{symmetrize, NamedPoint, NonlinearElement, Result, StructuralModel, StructureError};
use nalgebra::{DMatrix, DVector};

/// A Craig-Bampton reduced model and its transformation.
#[derive(Debug, Clone)]
pub struct CraigBampton {
    /// The reduced structural model (`ndof = masters + modes`).
    pub reduced: StructuralModel,
    /// `n_full x n_red` transformation, `q_full = T q_red`.
    pub transform: DMatrix<f64>,
    /// Master DOFs of the full model, in the order of the first reduced coordinates.
    pub masters: Vec<usize>,
    /// Natural frequencies of the fixed-interface modes [rad/s].
    pub interface_omega_rad_s: Vec<f64>,
}

impl CraigBampton {
    /// Full-model coordinates `q_full = T q_red`.
    pub fn recover(&self, q_red: &DVector<f64>) -> DVector<f64> {
        assert_eq!(
            q_red.len(),
            self.transform.ncols(),
            "q_red has the wrong length"
        );
        &self.transform * q_red
    }

    /// One physical DOF of the full model, `q_full[dof] = T[dof, :] q_red`.
    pub fn recover_dof(&self, dof: usize, q_red: &DVector<f64>) -> Result<f64> {
        let n = self.transform.nrows();
        if dof >= n {
            return Err(StructureError::DofOutOfRange {
                name: "dof",
                dof,
                ndof: n,
            });
        }
        assert_eq!(
            q_red.len(),
            self.transform.ncols(),
            "q_red has the wrong length"
        );
        Ok(self.transform.row(dof).transpose().dot(q_red))
    }
}

/// Craig-Bampton reduction of `model` with the master DOFs `masters` and the
/// `n_modes` lowest fixed-interface modes (`n_modes = 0`: Guyan reduction).
pub fn craig_bampton(
    model: &StructuralModel,
    masters: &[usize],
    n_modes: usize,
) -> Result<CraigBampton> {
    model.validate()?;
    let n = model.ndof();
    let interior = split_masters(n, masters, n_modes)?;
    let nb = masters.len();
    let ni = interior.len();
    let mut t = DMatrix::zeros(n, nb + n_modes);
    for (c, &dof) in masters.iter().enumerate() {
        t[(dof, c)] = 1.0;
    }
    let mut interface_omega_rad_s = Vec::new();
    if ni > 0 {
        let k_ii = model
            .stiffness
            .select_rows(&interior)
            .select_columns(&interior);
        let k_ib = model
            .stiffness
            .select_rows(&interior)
            .select_columns(masters);
        let singular = || StructureError::SingularInterior {
            masters: masters.to_vec(),
        };
        // The lowest fixed-interface eigenvalue detects a singular K_ii robustly (a
        // Cholesky factorisation may pass with a rounding-size pivot).
        let m_ii = model.mass.select_rows(&interior).select_columns(&interior);
        let (omega, phi) =
            generalized_eigen(&m_ii, &k_ii, n_modes.max(1), "n_modes").map_err(|e| match e {
                StructureError::NegativeEigenvalue { .. } => singular(),
                e => e,
            })?;
        if omega[0] == 0.0 {
            return Err(singular());
        }
        let chol = k_ii.cholesky().ok_or_else(singular)?;
        let psi = -chol.solve(&k_ib);
        for (r, &dof) in interior.iter().enumerate() {
            for c in 0..nb {
                t[(dof, c)] = psi[(r, c)];
            }
            for j in 0..n_modes {
                t[(dof, nb + j)] = phi[(r, j)];
            }
        }
        interface_omega_rad_s = omega[..n_modes].to_vec();
    }
    let tt = t.transpose();
    let project = |a: &DMatrix<f64>| symmetrize(&tt * a * &t);
    let reduced = StructuralModel {
        mass: project(&model.mass),
        stiffness: project(&model.stiffness),
        damping: project(&model.damping),
        nonlinear: model
            .nonlinear
            .iter()
            .map(|e| NonlinearElement {
                name: e.name.clone(),
                direction: &tt * &e.direction,
                law: e.law.clone(),
            })
            .collect(),
        points: model
            .points
            .iter()
            .map(|p| NamedPoint {
                name: p.name.clone(),
                direction: &tt * &p.direction,
            })
            .collect(),
    };
    Ok(CraigBampton {
        reduced,
        transform: t,
        masters: masters.to_vec(),
        interface_omega_rad_s,
    })
}

/// The interior DOFs of the split of `0..n` into `masters` and the rest, after
/// checking the masters (in range, unique) and the mode count.
fn split_masters(n: usize, masters: &[usize], n_modes: usize) -> Result<Vec<usize>> {
    let mut is_master = vec![false; n];
    for &dof in masters {
        if dof >= n {
            return Err(StructureError::DofOutOfRange {
                name: "masters",
                dof,
                ndof: n,
            });
        }
        if is_master[dof] {
            return Err(StructureError::DuplicateDof {
                name: "masters",
                dof,
            });
        }
        is_master[dof] = true;
    }
    let interior: Vec<usize> = (0..n).filter(|&i| !is_master[i]).collect();
    let ni = interior.len();
    if (n_modes == 0 && masters.is_empty()) || n_modes > ni {
        return Err(StructureError::ModeCount {
            name: "n_modes",
            requested: n_modes,
            available: ni,
        });
    }
    Ok(interior)
}

/// A Craig-Bampton reduction of sparse matrices ([`craig_bampton_sparse`]): the
/// reduced `T^T M T`, `T^T K T`, `T^T C T` and `T` itself (`n_full x n_red`).
#[derive(Debug, Clone)]
pub struct SparseCraigBampton {
    /// Reduced mass matrix [kg].
    pub mass: DMatrix<f64>,
    /// Reduced stiffness matrix [N/m].
    pub stiffness: DMatrix<f64>,
    /// Reduced damping matrix [N s/m] (zero when no `C` was given).
    pub damping: DMatrix<f64>,
    /// `n_full x n_red` transformation, `q_full = T q_red`.
    pub transform: DMatrix<f64>,
    /// Master DOFs of the full model, in the order of the first reduced coordinates.
    pub masters: Vec<usize>,
    /// Natural frequencies of the fixed-interface modes [rad/s].
    pub interface_omega_rad_s: Vec<f64>,
}

/// Solves `K_ii x_i = f_i` on full-size vectors (rows of the masters `b` zero
/// in and out) without forming `K_ii`:
///
/// * `Leading`, from the factor of the whole `K` (positive definite) ordered
///   with the masters last ([`SymbolicFactor::with_last`]): its leading block
///   is the Cholesky factor of `K_ii`
///   ([`SparseCholesky::solve_leading_in_place`]), so one factorisation
///   serves the full model's modes, the fixed-interface modes and the
///   constraint modes, each solve as accurate as with a factorisation of its
///   own matrix.
/// * `Clamped`, when `K` itself is singular (rigid-body modes): the factor of
///   `K` with the masters' rows and columns replaced by their diagonal (same
///   pattern, decoupled masters).
pub enum InteriorSolver<'a> {
    Leading {
        factor: &'a SparseCholesky,
        masters: &'a [usize],
    },
    Clamped {
        factor: SparseCholesky,
        masters: &'a [usize],
    },
}

impl<'a> InteriorSolver<'a> {
    /// The solver from the factor of `K` ordered with the masters last
    /// (`None` if its last DOFs are not `masters`).
    pub fn leading(factor: &'a SparseCholesky, masters: &'a [usize]) -> Option<Self> {
        (factor.symbolic().last() == masters).then_some(Self::Leading { factor, masters })
    }

    /// The clamped solver: factorises `K` with the masters decoupled (`None`
    /// when `K_ii` is singular).
    pub fn clamped(
        k: &SparseMatrix,
        symbolic: Option<&SymbolicFactor>,
        masters: &'a [usize],
        par: faer::Par,
    ) -> Option<Self> {
        let mut is_master = vec![false; k.nrows()];
        for &d in masters {
            is_master[d] = true;
        }
        // K's values with the masters decoupled, on K's pattern (not copied)
        let (col_ptr, row_idx) = (k.symbolic().col_ptr(), k.symbolic().row_idx());
        let mut vals = k.val().to_vec();
        for c in 0..k.ncols() {
            for p in col_ptr[c]..col_ptr[c + 1] {
                let r = row_idx[p];
                if (is_master[r] || is_master[c]) && r != c {
                    vals[p] = 0.0;
                } else if r == c && is_master[r] && vals[p] <= 0.0 {
                    vals[p] = 1.0;
                }
            }
        }
        let own;
        let symbolic = match symbolic {
            Some(s) => s,
            None => {
                own = SymbolicFactor::new(k)?;
                &own
            }
        };
        let factor = SparseCholesky::with_values(symbolic, k, &vals, par)?;
        Some(Self::Clamped { factor, masters })
    }

    /// The `n x nb` constraint modes: `I` at the masters, `Psi` in the interior.
    pub fn constraint_modes(&self, k: &SparseMatrix) -> DMatrix<f64> {
        let (n, masters) = (k.nrows(), self.masters());
        // -K_ii^{-1} K_ib from the columns of K at the masters
        let mut psi = DMatrix::zeros(n, masters.len());
        let (sym, val) = (k.symbolic(), k.val());
        for (c, &d) in masters.iter().enumerate() {
            for p in sym.col_range(d) {
                psi[(sym.row_idx()[p], c)] = -val[p];
            }
        }
        for &d in masters {
            psi.row_mut(d).fill(0.0);
        }
        ShiftInvert::solve_in_place(self, &mut psi);
        for &d in masters {
            psi.row_mut(d).fill(0.0);
        }
        for (c, &d) in masters.iter().enumerate() {
            psi[(d, c)] = 1.0;
        }
        psi
    }

    fn masters(&self) -> &[usize] {
        match self {
            InteriorSolver::Leading { masters, .. } | InteriorSolver::Clamped { masters, .. } => {
                masters
            }
        }
    }
}

impl ShiftInvert for InteriorSolver<'_> {
    fn solve_in_place(&self, b: &mut DMatrix<f64>) {
        match self {
            InteriorSolver::Leading { factor, .. } => factor.solve_leading_in_place(b),
            InteriorSolver::Clamped { factor, .. } => factor.solve_in_place(b),
        }
        for &d in self.masters() {
            b.row_mut(d).fill(0.0);
        }
    }
}

/// Craig-Bampton reduction (module docs) of the sparse `M`, `K` and optional `C`
/// (symmetric, `n x n`, checked by the caller) with the master DOFs `masters` and
/// the `n_modes` lowest fixed-interface modes: the same `T` as [`craig_bampton`]
/// up to the signs of the fixed-interface modes' rounding, without a dense
/// full-size matrix (the work grows with the non-zeros of `K`'s factor).
pub fn craig_bampton_sparse(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    damping: Option<&SparseMatrix>,
    masters: &[usize],
    n_modes: usize,
) -> Result<SparseCraigBampton> {
    let opts = SparseOptions {
        threads: 1,
        ..Default::default()
    };
    // the clamped K_ii (see matrix_structure_sparse_cb_with)
    let factor: Option<SparseCholesky> = None;
    let mut timings = StageTimings::default();
    craig_bampton_sparse_with(
        mass,
        stiffness,
        damping,
        masters,
        n_modes,
        factor.as_ref(),
        &opts,
        &mut timings,
    )
}

/// As [`craig_bampton_sparse`] with the factor of `K` when it is positive
/// definite (`k_factor`, e.g. from the full model's modal analysis, ordered
/// with `masters` last: [`SymbolicFactor::with_last`]; `None`, or another
/// ordering: `K_ii` is factorised with the masters decoupled), the
/// options and the stage timings (eigen, constraint modes, project).
#[allow(clippy::too_many_arguments)]
pub fn craig_bampton_sparse_with(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    damping: Option<&SparseMatrix>,
    masters: &[usize],
    n_modes: usize,
    k_factor: Option<&SparseCholesky>,
    opts: &SparseOptions,
    timings: &mut StageTimings,
) -> Result<SparseCraigBampton> {
    let n = mass.nrows();
    let interior = split_masters(n, masters, n_modes)?;
    let nb = masters.len();
    let singular = || StructureError::SingularInterior {
        masters: masters.to_vec(),
    };
    let mut t = DMatrix::zeros(n, nb + n_modes);
    for (c, &dof) in masters.iter().enumerate() {
        t[(dof, c)] = 1.0;
    }
    let mut interface_omega_rad_s = Vec::new();
    if !interior.is_empty() {
        let par = opts.par();
        let solver = match k_factor {
            Some(f) if f.symbolic().last() == masters => InteriorSolver::leading(f, masters),
            _ => {
                // K with the masters decoupled has K's pattern: its ordering
                // is K's (from the options' cache when K was ordered before)
                let sym = timings
                    .time(Stage::Order, opts, || {
                        SymbolicFactor::with_options(stiffness, opts)
                    })
                    .ok_or_else(singular)?;
                timings.ordering = sym.ordering().name().into();
                timings.time(Stage::Factor, opts, || {
                    InteriorSolver::clamped(stiffness, Some(&sym), masters, par)
                })
            }
        }
        .ok_or_else(singular)?;
        let pencil = Pencil {
            m: mass,
            k: stiffness,
            fixed: masters,
            par,
        };
        // as the dense path: a singular K_ii may pass the factorisation by
        // rounding; its lowest fixed-interface eigenvalue then is rounding-size
        let modes = timings.time(Stage::Eigen, opts, || {
            lanczos(&pencil, &solver, 0.0, n_modes.max(1), "n_modes")
        })?;
        timings.lanczos_basis.push(modes.basis);
        let floor = 1e-12 * modes.lambda_scale;
        if modes.lambda[0].is_nan() || modes.lambda[0] <= floor {
            return Err(singular());
        }
        let psi = timings.time(Stage::ConstraintModes, opts, || {
            solver.constraint_modes(stiffness)
        });
        t.columns_mut(0, nb).copy_from(&psi);
        t.columns_mut(nb, n_modes)
            .copy_from(&modes.shapes.columns(0, n_modes));
        interface_omega_rad_s = modes.lambda[..n_modes].iter().map(|l| l.sqrt()).collect();
    }
    let par = opts.par();
    let project = |a: &SparseMatrix| symmetrize(t.tr_mul(&sym_mul_par(a, &t, par)));
    let nr = t.ncols();
    let (mass, stiffness, damping) = timings.time(Stage::Project, opts, || {
        (
            project(mass),
            project(stiffness),
            damping.map_or_else(|| DMatrix::zeros(nr, nr), project),
        )
    });
    Ok(SparseCraigBampton {
        mass,
        stiffness,
        damping,
        transform: t,
        masters: masters.to_vec(),
        interface_omega_rad_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::modal::modal_analysis;
    use crate::structure::{BeamSpec, BoundaryCondition, CubicSpring};

    fn beam(n_nodes: usize) -> crate::structure::Beam {
        let mut b = BeamSpec {
            n_nodes,
            ..BeamSpec::paper()
        }
        .assemble()
        .unwrap();
        let l = b.spec.length_m;
        b.add_point("tip", l).unwrap();
        b.add_point("mid", l / 2.0).unwrap();
        let e = b.translation_vector("spring", l).unwrap();
        b.model
            .add_nonlinear("spring", e, CubicSpring::new(6e9).unwrap())
            .unwrap();
        b
    }

    #[test]
    fn all_modes_kept_reproduces_the_spectrum() {
        let b = beam(9);
        let tip = b.translation_dof(8).unwrap();
        let cb = craig_bampton(&b.model, &[tip], b.model.ndof() - 1).unwrap();
        let full = modal_analysis(&b.model, b.model.ndof()).unwrap();
        let red = modal_analysis(&cb.reduced, b.model.ndof()).unwrap();
        for (wf, wr) in full.omega_rad_s.iter().zip(&red.omega_rad_s) {
            assert!((wf - wr).abs() < 1e-9 * wf, "{wf} vs {wr}");
        }
    }

    #[test]
    fn static_tip_load_is_exact_and_points_project() {
        let b = beam(21);
        let tip = b.translation_dof(20).unwrap();
        let cb = craig_bampton(&b.model, &[tip], 3).unwrap();
        assert_eq!(cb.reduced.ndof(), 4);
        // static tip load F = 1 N: constraint modes make the Guyan part exact
        let e_full = b.model.point("tip").unwrap().direction.clone();
        let e_red = cb.reduced.point("tip").unwrap().direction.clone();
        assert_eq!(e_red[0], 1.0);
        assert!(
            e_red.rows(1, 3).amax() < 1e-12,
            "fixed-interface modes vanish at the master"
        );
        let q_full = b.model.stiffness.clone().cholesky().unwrap().solve(&e_full);
        let q_red = cb
            .reduced
            .stiffness
            .clone()
            .cholesky()
            .unwrap()
            .solve(&e_red);
        let rec = cb.recover(&q_red);
        let err = (&rec - &q_full).amax() / q_full.amax();
        assert!(err < 1e-10, "{err:e}");
        // analytic cantilever tip compliance l^3 / (3 EI)
        let s = &b.spec;
        let c = s.length_m.powi(3) / (3.0 * s.bending_stiffness_n_m2());
        assert!((q_full[tip] - c).abs() < 1e-9 * c);
        let mid = b.translation_dof(10).unwrap();
        assert!((cb.recover_dof(mid, &q_red).unwrap() - q_full[mid]).abs() < 1e-12 * c);
        // nonlinear direction projected: w_red^T q_red = w^T T q_red
        let w = &cb.reduced.nonlinear[0].direction;
        assert!((w.dot(&q_red) - rec[tip]).abs() < 1e-15);
        assert!(matches!(
            cb.recover_dof(10_000, &q_red),
            Err(StructureError::DofOutOfRange { .. })
        ));
    }

    #[test]
    fn bad_masters_and_mode_counts() {
        let b = beam(7);
        let n = b.model.ndof();
        assert!(
            matches!(craig_bampton(&b.model, &[n], 2), Err(StructureError::DofOutOfRange { dof, .. }) if dof == n)
        );
        assert!(matches!(
            craig_bampton(&b.model, &[1, 1], 2),
            Err(StructureError::DuplicateDof { dof: 1, .. })
        ));
        assert!(matches!(
            craig_bampton(&b.model, &[1], n),
            Err(StructureError::ModeCount { .. })
        ));
        assert!(matches!(
            craig_bampton(&b.model, &[], 0),
            Err(StructureError::ModeCount { .. })
        ));
        let ff = BeamSpec {
            n_nodes: 5,
            boundary: BoundaryCondition::FreeFree,
            ..BeamSpec::paper()
        }
        .assemble()
        .unwrap();
        assert!(matches!(
            craig_bampton(&ff.model, &[0], 2),
            Err(StructureError::SingularInterior { .. })
        ));
        // two translations restrain both rigid-body modes of the free-free beam
        craig_bampton(&ff.model, &[0, 8], 2).unwrap();
    }

    /// `a` with the rows and columns of the fixed-interface coordinates `nb..`
    /// flipped where `sign[j] < 0`.
    fn flip(a: &DMatrix<f64>, nb: usize, sign: &[f64]) -> DMatrix<f64> {
        let s = |i: usize| if i < nb { 1.0 } else { sign[i - nb] };
        DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)] * s(i) * s(j))
    }

    fn assert_matrix_close(what: &str, a: &DMatrix<f64>, b: &DMatrix<f64>, rtol: f64) {
        let err = (a - b).amax() / b.amax();
        assert!(err < rtol, "{what}: {err:e}");
    }

    /// The sparse path equals the dense one: fixed-interface frequencies to 1e-9
    /// relative, reduced `M`, `K`, `C` and `T` to 1e-9 of their largest entry after
    /// aligning the signs of the fixed-interface modes; on the paper beam (master
    /// tip, 10 modes, its damping) and a beam with two masters.
    #[test]
    fn sparse_equals_dense() {
        use crate::structure::sparse::sparse_from_dense;
        use crate::structure::{paper_structure, PaperStructureOptions};
        let paper = paper_structure(&PaperStructureOptions::default()).unwrap();
        let pm = paper.beam.model.clone();
        let tip = paper
            .beam
            .translation_dof(paper.beam.n_nodes() - 1)
            .unwrap();
        let mut b = beam(31);
        b.model.damping = &b.model.stiffness * 1e-5 + &b.model.mass * 0.3;
        let two = vec![
            b.translation_dof(30).unwrap(),
            b.translation_dof(15).unwrap(),
        ];
        for (model, masters, modes) in [(pm, vec![tip], 10), (b.model.clone(), two, 6)] {
            let dense = craig_bampton(&model, &masters, modes).unwrap();
            let (m, k, c) = (
                sparse_from_dense(&model.mass),
                sparse_from_dense(&model.stiffness),
                sparse_from_dense(&model.damping),
            );
            let sp = craig_bampton_sparse(&m, &k, Some(&c), &masters, modes).unwrap();
            for (ws, wd) in sp
                .interface_omega_rad_s
                .iter()
                .zip(&dense.interface_omega_rad_s)
            {
                assert!((ws - wd).abs() < 1e-9 * wd, "{ws} vs {wd}");
            }
            let nb = masters.len();
            let sign: Vec<f64> = (0..modes)
                .map(|j| {
                    let d = sp
                        .transform
                        .column(nb + j)
                        .dot(&dense.transform.column(nb + j));
                    d.signum()
                })
                .collect();
            let r = &dense.reduced;
            assert_matrix_close("M", &flip(&sp.mass, nb, &sign), &r.mass, 1e-9);
            assert_matrix_close("K", &flip(&sp.stiffness, nb, &sign), &r.stiffness, 1e-9);
            assert_matrix_close("C", &flip(&sp.damping, nb, &sign), &r.damping, 1e-9);
            let ft = DMatrix::from_fn(sp.transform.nrows(), nb + modes, |i, j| {
                sp.transform[(i, j)] * if j < nb { 1.0 } else { sign[j - nb] }
            });
            assert_matrix_close("T", &ft, &dense.transform, 1e-9);
            // the reduced models' eigenfrequencies
            let red = |mm: &DMatrix<f64>, kk: &DMatrix<f64>| {
                modal_analysis(&StructuralModel::new(mm.clone(), kk.clone()), nb + modes)
                    .unwrap()
                    .omega_rad_s
            };
            let (ws, wd) = (red(&sp.mass, &sp.stiffness), red(&r.mass, &r.stiffness));
            // 2e-9: the dense eigensolver's own error on the 100-node beam is
            // about 1e-9 (matrices::SPARSE_MIN_DOF)
            for (a, b) in ws.iter().zip(&wd) {
                assert!((a - b).abs() < 2e-9 * b, "reduced {a} vs {b}");
            }
        }
        // the checks of the dense path
        let (m, k) = (
            sparse_from_dense(&b.model.mass),
            sparse_from_dense(&b.model.stiffness),
        );
        let n = m.nrows();
        assert!(matches!(
            craig_bampton_sparse(&m, &k, None, &[n], 2),
            Err(StructureError::DofOutOfRange { dof, .. }) if dof == n
        ));
        assert!(matches!(
            craig_bampton_sparse(&m, &k, None, &[1, 1], 2),
            Err(StructureError::DuplicateDof { dof: 1, .. })
        ));
        let ff = BeamSpec {
            n_nodes: 5,
            boundary: BoundaryCondition::FreeFree,
            ..BeamSpec::paper()
        }
        .assemble()
        .unwrap();
        let (m, k) = (
            sparse_from_dense(&ff.model.mass),
            sparse_from_dense(&ff.model.stiffness),
        );
        let e = craig_bampton_sparse(&m, &k, None, &[0], 2);
        assert!(
            matches!(e, Err(StructureError::SingularInterior { .. })),
            "{e:?}"
        );
        craig_bampton_sparse(&m, &k, None, &[0, 8], 2).unwrap();
    }
}
