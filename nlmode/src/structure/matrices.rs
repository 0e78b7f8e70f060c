//! The user's own structure from FE matrices (`eq:component1` with `M`, `K`, `C`
//! given as Matrix Market files): reading, the physical checks, named DOFs, a cubic
//! spring at a named point, damping and Craig-Bampton reduction.
//!
//! * [`read_matrix_market`] reads a Matrix Market file (coordinate or array, real,
//!   general or symmetric, also `.mtx.gz`) by the `feio` crate into a dense
//!   `DMatrix`; [`read_matrix_triplets`] reads any format of `feio` (Harwell-Boeing,
//!   Abaqus matrix output) and [`sparse_from_feio`] makes the checked sparse
//!   matrix of its triplets; [`write_matrix_market`] writes the coordinate symmetric form
//!   (lower triangle, shortest round-trip decimal, so that reading it back gives the
//!   same bits).
//! * [`matrix_structure`] checks and builds the model: square, equal sizes, finite,
//!   symmetric within the relative tolerance [`SYMMETRY_RTOL`]
//!   (`max |A - A^T| <= 1e-9 max |A|`, the tolerance of [`StructuralModel::validate`]),
//!   non-negative diagonals of `K` and `C`, `M` positive definite (Cholesky), `K`
//!   positive semi-definite (no negative eigenvalue of `K phi = lambda M phi`), no
//!   rigid-body mode (`omega = 0`) unless allowed, DOFs in range, unique point names.
//!   Then, as for the paper's beam ([`super::paper_structure`]): damping on the full
//!   model, the cubic spring `f = k3 u^3` at its point, Craig-Bampton with the given
//!   master points and fixed-interface modes.
//! * [`matrix_structure_sparse`] does the same from sparse matrices
//!   ([`read_matrix_market_sparse`]) for large FE models: with Craig-Bampton the
//!   full model stays sparse from the file to the reduction (one sparse
//!   Cholesky factorisation of `K`, the masters ordered last, for the full
//!   model's modes, the fixed-interface modes and the constraint modes; `M`
//!   checked by the Lanczos `M`-norms and the reduced mass, see
//!   [`matrix_structure_sparse_cb_with`]; the shift-invert Lanczos of
//!   [`super::sparse`] for the full model's lowest modes and the fixed-interface
//!   modes); without reduction the model is made dense, up to [`DENSE_MAX_DOF`].
use super::craig_bampton::craig_bampton;
use super::craig_bampton::craig_bampton_sparse_with;
use super::damping::{rayleigh_damping, stiffness_proportional_damping_from_modes};
use super::lanczos::{max_basis, modal_factor, modes, Pencil};
use super::modal::modal_analysis;
use super::sparse::{
    asymmetry, diagonal, for_each_entry, sparse_from_dense, sparse_to_dense, sym_mul,
    MemoryEstimate, SparseMatrix, SparseOptions, Stage, StageTimings, SymbolicFactor,
};
use super::subspace::cb_first;
use super::{CubicSpring, NamedPoint, NonlinearElement, StructuralModel, StructureError};
use nalgebra::{DMatrix, DVector};
use std::path::{Path, PathBuf};
use std::sync::Arc;

mod io;
pub use io::{
    matrices_error, read_matrix_market, read_matrix_market_sparse, read_matrix_market_sparse_str,
    read_matrix_market_str, read_matrix_triplets, sparse_from_feio, write_matrix_market,
    write_matrix_market_sparse,
};

/// Relative symmetry tolerance of the matrices: `max |A - A^T| <= 1e-9 max |A|`.
pub const SYMMETRY_RTOL: f64 = 1e-9;

/// Largest full model kept dense (`reduction = "none"`): 3000 DOFs are 72 MB per
/// dense matrix and a dense eigen-analysis of some ten seconds; a larger model
/// needs `reduction = "craig-bampton"` (sparse to the reduction).
pub const DENSE_MAX_DOF: usize = 3000;

/// Smallest full model that [`matrix_structure_sparse`] reduces on the sparse
/// path. Smaller models take the dense path, whose numbers the paper beam's
/// scenario (198 DOFs) is held to: the two agree to about `1e-9` (the dense
/// eigensolver's own error on fine meshes), not bit for bit.
pub const SPARSE_MIN_DOF: usize = 500;

/// Name of the cubic spring element of a matrices structure.
pub const CUBIC_SPRING: &str = super::paper::CUBIC_SPRING;

/// Which matrix a file holds; [`MatrixRole::key`] is its scenario key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatrixRole {
    Mass,
    Stiffness,
    Damping,
}

impl MatrixRole {
    /// The scenario key naming the file (`mass_mtx`, `stiffness_mtx`, `damping_mtx`).
    pub fn key(self) -> &'static str {
        match self {
            MatrixRole::Mass => "mass_mtx",
            MatrixRole::Stiffness => "stiffness_mtx",
            MatrixRole::Damping => "damping_mtx",
        }
    }
}

impl std::fmt::Display for MatrixRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.key())
    }
}

/// Errors of the matrices structure: each names the key (and file, and line where
/// the file is malformed) and carries the numbers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MatricesError {
    /// The file cannot be read (missing, no permission).
    #[error("{role}: cannot read {}: {message}", path.display())]
    Io {
        role: MatrixRole,
        path: PathBuf,
        message: String,
    },
    /// The file is not valid in its format (Matrix Market, Harwell-Boeing,
    /// Abaqus; `feio`): the 1-based line and what was expected there.
    #[error("{role}: {} is not a valid {format} file{}: {message}", path.display(),
        line.map(|l| format!(" (line {l})")).unwrap_or_default())]
    Malformed {
        role: MatrixRole,
        path: PathBuf,
        line: Option<usize>,
        format: &'static str,
        message: String,
    },
    /// A matrix that is not square.
    #[error("{role}: {} is {rows}x{cols}, expected a square matrix", path.display())]
    NotSquare {
        role: MatrixRole,
        path: PathBuf,
        rows: usize,
        cols: usize,
    },
    /// `C` or `K` of another size than `M`.
    #[error("{role}: {} is {n}x{n}, but mass_mtx is {expected}x{expected}", path.display())]
    SizeMismatch {
        role: MatrixRole,
        path: PathBuf,
        n: usize,
        expected: usize,
    },
    /// A NaN or infinite entry (and its line in the file, where read from one).
    #[error("{role}: {} has a non-finite entry {value} at row {row}, column {col} (0-based){}", path.display(),
        line.map(|l| format!(" (line {l})")).unwrap_or_default())]
    NonFinite {
        role: MatrixRole,
        path: PathBuf,
        row: usize,
        col: usize,
        value: f64,
        line: Option<usize>,
    },
    /// Not symmetric within [`SYMMETRY_RTOL`].
    #[error("{role}: {} is not symmetric: max |A - A^T| = {asymmetry:e} > {SYMMETRY_RTOL:e} max |A| = {scale:e}", path.display())]
    NotSymmetric {
        role: MatrixRole,
        path: PathBuf,
        asymmetry: f64,
        scale: f64,
    },
    /// A negative (or, for `M`, non-positive) diagonal entry.
    #[error("{role}: {} has the diagonal entry {value:e} at row {row} (0-based): a {what} diagonal must be {expected}", path.display())]
    BadDiagonal {
        role: MatrixRole,
        path: PathBuf,
        row: usize,
        value: f64,
        what: &'static str,
        expected: &'static str,
    },
    /// `M` is not positive definite; `reason` says how it was found (its
    /// Cholesky factorisation failed, a Lanczos vector of negative `M`-norm,
    /// a negative eigenvalue of `K phi = lambda M phi` with `K` positive
    /// definite, or the reduced mass `T^T M T`).
    #[error("mass_mtx: {} is not positive definite ({reason})", path.display())]
    MassNotPositiveDefinite { path: PathBuf, reason: &'static str },
    /// `K` is not positive semi-definite.
    #[error("stiffness_mtx: {} is not positive semi-definite: K phi = lambda M phi has the eigenvalue {lambda:e}", path.display())]
    StiffnessIndefinite { path: PathBuf, lambda: f64 },
    /// `K phi = omega^2 M phi` has rigid-body modes and they were not allowed.
    #[error("stiffness_mtx: {} has {count} rigid-body mode(s) (omega = 0 of K phi = omega^2 M phi); \
             restrain the structure or set allow_rigid_body_modes = true", path.display())]
    RigidBodyModes { path: PathBuf, count: usize },
    /// A point's DOF beyond the matrices.
    #[error("point `{name}`: dof = {dof} is out of range: the matrices have {ndof} rows (dof is 0-based)")]
    DofOutOfRange {
        name: String,
        dof: usize,
        ndof: usize,
    },
    /// A point name used twice.
    #[error("point name `{name}` is used twice")]
    DuplicatePoint { name: String },
    /// A point name that is not defined.
    #[error("{key}: unknown point `{name}`; the points are {available:?}")]
    UnknownPoint {
        key: &'static str,
        name: String,
        available: Vec<String>,
    },
    /// A stiffness, damping or mode parameter out of range.
    #[error("{key} = {value} is invalid: expected {expected}")]
    InvalidParameter {
        key: &'static str,
        value: f64,
        expected: &'static str,
    },
    /// A full model above [`DENSE_MAX_DOF`] without reduction.
    #[error(
        "reduction = \"none\" keeps the full model dense: its {ndof} DOFs exceed the \
             limit of {max}; use reduction = \"craig-bampton\" (sparse up to the reduction)"
    )]
    TooLargeForDense { ndof: usize, max: usize },
    /// An error of the structure layer (modal analysis, Craig-Bampton).
    #[error(transparent)]
    Structure(#[from] StructureError),
}

/// Linear damping of a matrices structure (`A`: dense or [`SparseMatrix`]).
#[derive(Debug, Clone, PartialEq)]
pub enum MatrixDamping<A = DMatrix<f64>> {
    /// `C` given as a matrix (already read and checked for shape).
    Matrix(A),
    /// `C = alpha M + beta K` (`alpha` [1/s], `beta` [s]).
    Rayleigh { alpha_per_s: f64, beta_s: f64 },
    /// `C = beta K` with damping ratio `ratio` on mode `mode_index` (0-based) of the
    /// full model, as the paper's beam (`D0` on mode 1).
    StiffnessProportional { ratio: f64, mode_index: usize },
}

/// Everything [`matrix_structure`] (dense `A`) and [`matrix_structure_sparse`]
/// (`A = SparseMatrix`) need; the file paths only name the matrices in errors.
#[derive(Debug, Clone)]
pub struct MatrixStructureOptions<A = DMatrix<f64>> {
    pub mass: A,
    pub mass_path: PathBuf,
    pub stiffness: A,
    pub stiffness_path: PathBuf,
    pub damping: MatrixDamping<A>,
    /// `None` when the damping is not a matrix file.
    pub damping_path: Option<PathBuf>,
    /// Named points `(name, dof)`, `dof` the 0-based row of `M` and `K`.
    pub points: Vec<(String, usize)>,
    /// Cubic spring `(point, k3 [N/m^3])`, grounded at the point's translation.
    pub cubic_spring: Option<(String, f64)>,
    /// Craig-Bampton reduction: master points and fixed-interface modes; `None`
    /// keeps the full model.
    pub craig_bampton: Option<(Vec<String>, usize)>,
    /// Accept rigid-body modes (`omega = 0`) of `K phi = omega^2 M phi`.
    pub allow_rigid_body_modes: bool,
}

impl<A> MatrixDamping<A> {
    /// The same damping with the matrix (if any) converted by `f`.
    pub fn map_matrix<B>(&self, f: impl Fn(&A) -> B) -> MatrixDamping<B> {
        match self {
            MatrixDamping::Matrix(c) => MatrixDamping::Matrix(f(c)),
            MatrixDamping::Rayleigh {
                alpha_per_s,
                beta_s,
            } => MatrixDamping::Rayleigh {
                alpha_per_s: *alpha_per_s,
                beta_s: *beta_s,
            },
            MatrixDamping::StiffnessProportional { ratio, mode_index } => {
                MatrixDamping::StiffnessProportional {
                    ratio: *ratio,
                    mode_index: *mode_index,
                }
            }
        }
    }
}

impl<A> MatrixStructureOptions<A> {
    /// The same options with every matrix converted by `f` (dense <-> sparse).
    pub fn map_matrices<B>(&self, f: impl Fn(&A) -> B) -> MatrixStructureOptions<B> {
        MatrixStructureOptions {
            mass: f(&self.mass),
            mass_path: self.mass_path.clone(),
            stiffness: f(&self.stiffness),
            stiffness_path: self.stiffness_path.clone(),
            damping: self.damping.map_matrix(&f),
            damping_path: self.damping_path.clone(),
            points: self.points.clone(),
            cubic_spring: self.cubic_spring.clone(),
            craig_bampton: self.craig_bampton.clone(),
            allow_rigid_body_modes: self.allow_rigid_body_modes,
        }
    }
}

/// The structure built from matrices: the model to simulate (reduced or full), the
/// full model and `q_full = transform q`.
#[derive(Debug, Clone)]
pub struct MatrixStructure {
    /// The model used downstream (Craig-Bampton reduced unless none was asked).
    pub model: StructuralModel,
    /// The full model with damping, points and the nonlinear element (dense);
    /// `None` on the sparse Craig-Bampton path, where it is never formed.
    pub full: Option<StructuralModel>,
    /// Number of DOFs of the full model.
    pub full_ndof: usize,
    /// `n_full x model.ndof()`, identity when unreduced.
    pub transform: DMatrix<f64>,
    /// Rigid-body modes of the full model (0 unless allowed).
    pub rigid_body_modes: usize,
    /// Lowest non-zero natural frequency of the full model [rad/s].
    pub omega0_rad_s: f64,
    /// Modal damping ratio of that mode of the full model [-]: `D omega0 /
    /// omega_j` (stiffness-proportional on mode `j`), `alpha / (2 omega0) + beta
    /// omega0 / 2` (Rayleigh), `phi^T C phi / (2 omega0)` (a matrix, mass-normalised `phi`).
    pub damping_ratio: f64,
    /// Natural frequencies of the fixed-interface modes (empty when unreduced) [rad/s].
    pub interface_omega_rad_s: Vec<f64>,
    /// Stage times of the large-model (sparse Craig-Bampton) path, its factor
    /// size and memory estimate; `None` on the dense path.
    pub timings: Option<StageTimings>,
}

fn check_matrix(
    role: MatrixRole,
    path: &Path,
    a: &DMatrix<f64>,
    n: usize,
) -> Result<(), MatricesError> {
    if !a.is_square() {
        return Err(MatricesError::NotSquare {
            role,
            path: path.into(),
            rows: a.nrows(),
            cols: a.ncols(),
        });
    }
    check_sparse_matrix(role, path, &sparse_from_dense(a), n)
}

/// The checks of the module docs on one matrix: size, finite, symmetric, diagonal.
fn check_sparse_matrix(
    role: MatrixRole,
    path: &Path,
    a: &SparseMatrix,
    n: usize,
) -> Result<(), MatricesError> {
    if a.nrows() != a.ncols() {
        return Err(MatricesError::NotSquare {
            role,
            path: path.into(),
            rows: a.nrows(),
            cols: a.ncols(),
        });
    }
    if a.nrows() != n {
        return Err(MatricesError::SizeMismatch {
            role,
            path: path.into(),
            n: a.nrows(),
            expected: n,
        });
    }
    let mut bad = None;
    for_each_entry(a, |r, c, v| {
        if bad.is_none() && !v.is_finite() {
            bad = Some((r, c, v));
        }
    });
    if let Some((row, col, value)) = bad {
        return Err(MatricesError::NonFinite {
            role,
            path: path.into(),
            row,
            col,
            value,
            line: None,
        });
    }
    let (asym, scale) = asymmetry(a);
    if asym > SYMMETRY_RTOL * scale {
        return Err(MatricesError::NotSymmetric {
            role,
            path: path.into(),
            asymmetry: asym,
            scale,
        });
    }
    let (what, expected, ok): (_, _, fn(f64) -> bool) = match role {
        MatrixRole::Mass => ("mass", "positive", |v| v > 0.0),
        MatrixRole::Stiffness => ("stiffness", ">= 0", |v| v >= 0.0),
        MatrixRole::Damping => ("damping", ">= 0", |v| v >= 0.0),
    };
    let d = diagonal(a);
    if let Some(row) = (0..n).find(|&i| !ok(d[i])) {
        return Err(MatricesError::BadDiagonal {
            role,
            path: path.into(),
            row,
            value: d[row],
            what,
            expected,
        });
    }
    Ok(())
}

fn unit(n: usize, dof: usize) -> DVector<f64> {
    let mut e = DVector::zeros(n);
    e[dof] = 1.0;
    e
}

/// The points' DOFs in range and their names unique.
fn check_points(points: &[(String, usize)], n: usize) -> Result<(), MatricesError> {
    for (i, (name, dof)) in points.iter().enumerate() {
        if *dof >= n {
            return Err(MatricesError::DofOutOfRange {
                name: name.clone(),
                dof: *dof,
                ndof: n,
            });
        }
        if points[..i].iter().any(|(p, _)| p == name) {
            return Err(MatricesError::DuplicatePoint { name: name.clone() });
        }
    }
    Ok(())
}

/// The DOF of the point `name` (`key` names the option that refers to it).
fn dof_of(
    points: &[(String, usize)],
    key: &'static str,
    name: &str,
) -> Result<usize, MatricesError> {
    points
        .iter()
        .find(|(p, _)| p == name)
        .map(|(_, d)| *d)
        .ok_or_else(|| MatricesError::UnknownPoint {
            key,
            name: name.to_string(),
            available: points.iter().map(|(p, _)| p.clone()).collect(),
        })
}

/// The cubic spring's DOF and `k3` [N/m^3] when it is not zero.
fn cubic_spring_dof<A>(
    opts: &MatrixStructureOptions<A>,
) -> Result<Option<(usize, f64)>, MatricesError> {
    let Some((point, k3)) = &opts.cubic_spring else {
        return Ok(None);
    };
    if !(k3.is_finite() && *k3 >= 0.0) {
        return Err(MatricesError::InvalidParameter {
            key: "k3_n_per_m3",
            value: *k3,
            expected: "a finite number >= 0",
        });
    }
    let dof = dof_of(&opts.points, "nonlinear_point", point)?;
    Ok((*k3 != 0.0).then_some((dof, *k3)))
}

/// How many modes of the full model to compute: enough to count rigid-body modes
/// (at most 6 in space) and to calibrate the damping mode; the eigenvalues do not
/// depend on how many are kept.
fn full_mode_count<A>(damping: &MatrixDamping<A>, n: usize) -> Result<usize, MatricesError> {
    let damping_mode = match damping {
        MatrixDamping::StiffnessProportional { mode_index, .. } => *mode_index,
        _ => 0,
    };
    if damping_mode >= n {
        return Err(MatricesError::InvalidParameter {
            key: "damping_mode",
            value: (damping_mode + 1) as f64,
            expected: "a mode number between 1 and the number of DOFs",
        });
    }
    Ok((damping_mode + 1).max(7).min(n))
}

/// Rigid-body modes (refused unless allowed) and the lowest non-zero frequency.
fn rigid_and_omega0<A>(
    opts: &MatrixStructureOptions<A>,
    omega: &[f64],
) -> Result<(usize, f64), MatricesError> {
    let rigid_body_modes = omega.iter().filter(|w| **w == 0.0).count();
    if rigid_body_modes > 0 && !opts.allow_rigid_body_modes {
        return Err(MatricesError::RigidBodyModes {
            path: opts.stiffness_path.clone(),
            count: rigid_body_modes,
        });
    }
    let omega0_rad_s =
        omega
            .iter()
            .copied()
            .find(|w| *w > 0.0)
            .ok_or(MatricesError::RigidBodyModes {
                path: opts.stiffness_path.clone(),
                count: rigid_body_modes,
            })?;
    Ok((rigid_body_modes, omega0_rad_s))
}

/// The Rayleigh coefficients and the damping ratio checked (keys as the scenario's).
fn check_damping<A>(damping: &MatrixDamping<A>) -> Result<(), MatricesError> {
    match damping {
        MatrixDamping::Matrix(_) => {}
        MatrixDamping::Rayleigh {
            alpha_per_s,
            beta_s,
        } => {
            for (key, value) in [("rayleigh[0]", *alpha_per_s), ("rayleigh[1]", *beta_s)] {
                if !(value.is_finite() && value >= 0.0) {
                    return Err(MatricesError::InvalidParameter {
                        key,
                        value,
                        expected: "a finite number >= 0",
                    });
                }
            }
        }
        MatrixDamping::StiffnessProportional { ratio, .. } => {
            if !(ratio.is_finite() && *ratio >= 0.0 && *ratio < 1.0) {
                return Err(MatricesError::InvalidParameter {
                    key: "damping_ratio",
                    value: *ratio,
                    expected: "0 <= D < 1",
                });
            }
        }
    }
    Ok(())
}

/// Modal damping ratio of the mode `omega0` of the full model (field docs of
/// [`MatrixStructure::damping_ratio`]); `phi_c_phi` is `phi^T C phi` of that
/// mass-normalised mode.
fn damping_ratio_of<A>(
    damping: &MatrixDamping<A>,
    omega0_rad_s: f64,
    omega: &[f64],
    phi_c_phi: impl FnOnce() -> f64,
) -> f64 {
    // exact for the proportional kinds (damping.rs), the projection for a matrix
    match damping {
        MatrixDamping::StiffnessProportional { ratio, mode_index } => {
            ratio * omega0_rad_s / omega[*mode_index]
        }
        MatrixDamping::Rayleigh {
            alpha_per_s,
            beta_s,
        } => alpha_per_s / (2.0 * omega0_rad_s) + beta_s * omega0_rad_s / 2.0,
        MatrixDamping::Matrix(_) => phi_c_phi() / (2.0 * omega0_rad_s),
    }
}

/// Checks and builds the structure of `opts` (see the module docs), dense.
pub fn matrix_structure(opts: &MatrixStructureOptions) -> Result<MatrixStructure, MatricesError> {
    let n = opts.mass.nrows();
    check_matrix(MatrixRole::Mass, &opts.mass_path, &opts.mass, n)?;
    check_matrix(
        MatrixRole::Stiffness,
        &opts.stiffness_path,
        &opts.stiffness,
        n,
    )?;
    if let MatrixDamping::Matrix(c) = &opts.damping {
        let p = opts.damping_path.clone().unwrap_or_default();
        check_matrix(MatrixRole::Damping, &p, c, n)?;
    }
    if n == 0 || opts.mass.clone().cholesky().is_none() {
        return Err(MatricesError::MassNotPositiveDefinite {
            path: opts.mass_path.clone(),
            reason: "Cholesky factorisation failed",
        });
    }
    let mut full = StructuralModel::new(opts.mass.clone(), opts.stiffness.clone());
    check_points(&opts.points, n)?;
    for (name, dof) in &opts.points {
        full.add_named_point(name, unit(n, *dof))?;
    }
    if let Some((dof, k3)) = cubic_spring_dof(opts)? {
        full.add_nonlinear(CUBIC_SPRING, unit(n, dof), CubicSpring::new(k3)?)?;
    }
    let n_modes = full_mode_count(&opts.damping, n)?;
    let modes = modal_analysis(&full, n_modes).map_err(|e| match e {
        StructureError::NegativeEigenvalue { lambda, .. } => MatricesError::StiffnessIndefinite {
            path: opts.stiffness_path.clone(),
            lambda,
        },
        e => e.into(),
    })?;
    let (rigid_body_modes, omega0_rad_s) = rigid_and_omega0(opts, &modes.omega_rad_s)?;
    check_damping(&opts.damping)?;
    match &opts.damping {
        MatrixDamping::Matrix(c) => full.damping = c.clone(),
        MatrixDamping::Rayleigh {
            alpha_per_s,
            beta_s,
        } => rayleigh_damping(&mut full, *alpha_per_s, *beta_s)?,
        MatrixDamping::StiffnessProportional { ratio, mode_index } => {
            stiffness_proportional_damping_from_modes(&mut full, &modes, *mode_index, *ratio)?;
        }
    }
    let damping_ratio = damping_ratio_of(&opts.damping, omega0_rad_s, &modes.omega_rad_s, || {
        let phi = modes.shape(rigid_body_modes);
        phi.dot(&(&full.damping * &phi))
    });
    let (model, transform, interface_omega_rad_s) = match &opts.craig_bampton {
        Some((masters, n_modes)) => {
            let dofs = masters
                .iter()
                .map(|m| dof_of(&opts.points, "cb_masters", m))
                .collect::<Result<Vec<_>, _>>()?;
            let cb = craig_bampton(&full, &dofs, *n_modes)?;
            (cb.reduced, cb.transform, cb.interface_omega_rad_s)
        }
        None => (full.clone(), DMatrix::identity(n, n), Vec::new()),
    };
    Ok(MatrixStructure {
        model,
        full: Some(full),
        full_ndof: n,
        transform,
        rigid_body_modes,
        omega0_rad_s,
        damping_ratio,
        interface_omega_rad_s,
        timings: None,
    })
}

/// As [`matrix_structure`] from sparse matrices. With Craig-Bampton and at least
/// [`SPARSE_MIN_DOF`] DOFs the full model is never made dense
/// ([`matrix_structure_sparse_cb`]; [`MatrixStructure::full`] is `None`); a
/// smaller model, or one without reduction up to [`DENSE_MAX_DOF`] DOFs
/// ([`MatricesError::TooLargeForDense`] above), takes the dense path.
/// Default [`SparseOptions`] (no memory limit, rayon's threads).
pub fn matrix_structure_sparse(
    opts: &MatrixStructureOptions<SparseMatrix>,
) -> Result<MatrixStructure, MatricesError> {
    matrix_structure_sparse_with(opts, &SparseOptions::default())
}

/// As [`matrix_structure_sparse`] with the options of the large-model path
/// (memory limit, threads, progress).
pub fn matrix_structure_sparse_with(
    opts: &MatrixStructureOptions<SparseMatrix>,
    sparse: &SparseOptions,
) -> Result<MatrixStructure, MatricesError> {
    let n = opts.mass.nrows();
    if opts.craig_bampton.is_some() && n >= SPARSE_MIN_DOF {
        return matrix_structure_sparse_cb_with(opts, sparse);
    }
    if opts.craig_bampton.is_none() && n > DENSE_MAX_DOF {
        return Err(MatricesError::TooLargeForDense {
            ndof: n,
            max: DENSE_MAX_DOF,
        });
    }
    matrix_structure(&opts.map_matrices(sparse_to_dense))
}

/// The sparse Craig-Bampton path of [`matrix_structure_sparse`] at any size (the
/// module docs; `opts.craig_bampton` must be given, else
/// [`MatricesError::InvalidParameter`] on `cb_modes`).
pub fn matrix_structure_sparse_cb(
    opts: &MatrixStructureOptions<SparseMatrix>,
) -> Result<MatrixStructure, MatricesError> {
    matrix_structure_sparse_cb_with(opts, &SparseOptions::default())
}

/// [`matrix_structure_sparse_cb`] with options: the stages check, order (and
/// the memory estimate, refused above [`SparseOptions::memory_limit_bytes`]
/// before any numeric work), factor, then with `K` positive definite the
/// reduction (eigen of the fixed-interface modes, constraint modes, project)
/// followed by eigen of the full model's used modes from its basis
/// ([`super::subspace::cb_first`]; the Lanczos iteration if that does not
/// converge), otherwise eigen (full model, Lanczos) then the reduction;
/// their times in [`MatrixStructure::timings`].
///
/// One numeric factorisation: `K` ordered with the masters last, whose
/// leading block is the factor of `K_ii` ([`SymbolicFactor::with_last`]).
/// `M` is not factorised: every result depends on `M` only through the
/// subspaces the Lanczos bases, the subspace iteration's blocks and `T`
/// span, and there it is checked. The `M`-norm of every new Lanczos
/// direction must be positive (a clearly negative `x^T M x` proves `M`
/// indefinite, [`super::lanczos::MASS_NORM_RTOL`]; a block of the subspace
/// iteration whose `X^T M X` is not positive definite hands over to the
/// Lanczos iteration, which then tells); with `K` positive definite (its
/// factor) `K^{-1} M` is self-adjoint in the `K` inner product whatever `M`
/// is, so its largest eigenvalues, the lowest modes, are real and verified
/// by their residuals, and a negative eigenvalue there proves `M` indefinite;
/// the reduced `T^T M T` that the methods integrate must pass a dense
/// Cholesky factorisation ([`StructuralModel::validate`]). An `M` that is
/// indefinite only in directions none of these touch (high-frequency
/// content the reduced model does not contain) is not detected and does not
/// change a number of the result. Each failure is
/// [`MatricesError::MassNotPositiveDefinite`] naming how it was found.
pub fn matrix_structure_sparse_cb_with(
    opts: &MatrixStructureOptions<SparseMatrix>,
    sparse: &SparseOptions,
) -> Result<MatrixStructure, MatricesError> {
    let n = opts.mass.nrows();
    let Some((masters, cb_modes)) = &opts.craig_bampton else {
        return Err(MatricesError::InvalidParameter {
            key: "cb_modes",
            value: 0.0,
            expected: "a Craig-Bampton reduction on the sparse path",
        });
    };
    let (m, k) = (&opts.mass, &opts.stiffness);
    let mut timings = StageTimings::default();
    let c_matrix = match &opts.damping {
        MatrixDamping::Matrix(c) => Some(c),
        _ => None,
    };
    timings.time(Stage::Check, sparse, || {
        check_sparse_matrix(MatrixRole::Mass, &opts.mass_path, m, n)?;
        check_sparse_matrix(MatrixRole::Stiffness, &opts.stiffness_path, k, n)?;
        if let Some(c) = c_matrix {
            let p = opts.damping_path.clone().unwrap_or_default();
            check_sparse_matrix(MatrixRole::Damping, &p, c, n)?;
        }
        Ok::<_, MatricesError>(())
    })?;
    if n == 0 {
        return Err(MatricesError::MassNotPositiveDefinite {
            path: opts.mass_path.clone(),
            reason: "no rows",
        });
    }
    check_points(&opts.points, n)?;
    let spring = cubic_spring_dof(opts)?;
    let n_modes = full_mode_count(&opts.damping, n)?;
    check_damping(&opts.damping)?;
    let dofs = masters
        .iter()
        .map(|name| dof_of(&opts.points, "cb_masters", name))
        .collect::<Result<Vec<_>, _>>()?;
    let par = sparse.par();
    let mut held = vec![m, k];
    held.extend(c_matrix);
    let basis = max_basis(n_modes.max(*cb_modes), n);
    let reduced = dofs.len() + cb_modes;
    // K ordered with the masters last: its factor's leading block is K_ii's
    // (repeated masters are the reduction's error, below)
    let mut sorted = dofs.clone();
    sorted.sort_unstable();
    sorted.dedup();
    let last = if sorted.len() == dofs.len() {
        &dofs[..]
    } else {
        &[]
    };
    let sym = order_within_memory(&held, sparse, basis, reduced, last, &mut timings)?;
    let mf = timings
        .time(Stage::Factor, sparse, || {
            modal_factor(m, k, Some(&sym), par)
        })
        .map_err(|e| sparse_error(opts, e, None))?;
    drop(sym);
    let pencil = Pencil {
        m,
        k,
        fixed: &[],
        par,
    };
    // K positive definite: Craig-Bampton first on its factor, whose basis
    // starts the full model's modes (subspace.rs); a shifted factor (rigid-body
    // modes): the full model's modes by Lanczos, then the factor freed and
    // K_ii factorised on its own (one factorisation alive at a time)
    let (omega, phi, cb) = if mf.sigma == 0.0 {
        // the modes the result uses: omega0 and a stiffness-proportional
        // damping's mode (n_modes also counts rigid-body modes)
        let wanted = match &opts.damping {
            MatrixDamping::StiffnessProportional { mode_index, .. } => mode_index + 1,
            _ => 1,
        };
        let counts = (wanted.min(n_modes), n_modes);
        let (d, t) = (&dofs, &mut timings);
        let f = cb_first(&pencil, &mf, c_matrix, d, *cb_modes, counts, sparse, t)
            .map_err(|e| sparse_error(opts, e, Some(0.0)))?;
        (f.omega, f.phi, Some(f.cb))
    } else {
        let (omega, phi, basis) = timings
            .time(Stage::Eigen, sparse, || {
                modes(&pencil, &mf, n_modes, "n_modes")
            })
            .map_err(|e| sparse_error(opts, e, Some(mf.sigma)))?;
        timings.lanczos_basis.push(basis);
        (omega, phi, None)
    };
    let (rigid_body_modes, omega0_rad_s) = rigid_and_omega0(opts, &omega)?;
    if let MatrixDamping::StiffnessProportional { mode_index, .. } = &opts.damping {
        if omega[*mode_index] == 0.0 {
            return Err(StructureError::ZeroFrequencyMode {
                index: *mode_index,
                omega_rad_s: 0.0,
            }
            .into());
        }
    }
    let damping_ratio = damping_ratio_of(&opts.damping, omega0_rad_s, &omega, || {
        let p = phi.columns(rigid_body_modes, 1).into_owned();
        c_matrix.map_or(0.0, |c| p.dot(&sym_mul(c, &p)))
    });
    drop(phi);
    drop(mf);
    let cb = match cb {
        Some(cb) => cb,
        None => {
            let (d, n) = (&dofs, *cb_modes);
            craig_bampton_sparse_with(m, k, c_matrix, d, n, None, sparse, &mut timings)
        }
    }
    .map_err(|e| sparse_error(opts, e, None))?;
    let interface_omega_rad_s = cb.interface_omega_rad_s.clone();
    let (model, transform) =
        cb_structural_model(opts, cb, &omega, spring).map_err(|e| match e {
            MatricesError::Structure(e) => sparse_error(opts, e, None),
            e => e,
        })?;
    Ok(MatrixStructure {
        model,
        full: None,
        full_ndof: n,
        transform,
        rigid_body_modes,
        omega0_rad_s,
        damping_ratio,
        interface_omega_rad_s,
        timings: Some(timings),
    })
}

/// The errors of the sparse path named by their file: a negative eigenvalue
/// of `K phi = lambda M phi` is `K`'s ([`MatricesError::StiffnessIndefinite`])
/// unless `K` was factorised unshifted (`sigma = Some(0)`: `K` positive
/// definite, so the mass is indefinite), an indefinite mass found by the
/// Lanczos recurrence or in the reduced model is `M`'s
/// ([`MatricesError::MassNotPositiveDefinite`]).
fn sparse_error(
    opts: &MatrixStructureOptions<SparseMatrix>,
    e: StructureError,
    sigma: Option<f64>,
) -> MatricesError {
    let mass = |reason| MatricesError::MassNotPositiveDefinite {
        path: opts.mass_path.clone(),
        reason,
    };
    match e {
        StructureError::NegativeEigenvalue { .. } if sigma == Some(0.0) => {
            mass("K phi = lambda M phi has a negative eigenvalue with K positive definite")
        }
        StructureError::NegativeEigenvalue { lambda, .. } => MatricesError::StiffnessIndefinite {
            path: opts.stiffness_path.clone(),
            lambda,
        },
        StructureError::MassNotPositiveDefinite { .. } => {
            mass("x^T M x < 0 for a vector of the Lanczos basis, or the reduced mass T^T M T")
        }
        e => e.into(),
    }
}

/// The symbolic factorisation (ordering) of `K = held[1]`, the DOFs `last`
/// (the Craig-Bampton masters) ordered last, and the memory
/// estimate of the sparse path (`held`: the matrices kept, `basis` Lanczos
/// vectors, `reduced` reduced coordinates), refused above
/// [`SparseOptions::memory_limit_bytes`] before any numeric work; the
/// estimate recorded in `timings`.
fn order_within_memory(
    held: &[&SparseMatrix],
    sparse: &SparseOptions,
    basis: usize,
    reduced: usize,
    last: &[usize],
    timings: &mut StageTimings,
) -> Result<SymbolicFactor, MatricesError> {
    let (k, n) = (held[1], held[1].nrows());
    let par = sparse.par();
    let sym = timings.time(Stage::Order, sparse, || {
        SymbolicFactor::with_options_last(k, sparse, last)
    });
    let estimate = sym
        .as_ref()
        .map(|s| MemoryEstimate::new(held, s, par, basis, reduced));
    let Some((sym, estimate)) = sym.zip(estimate) else {
        // faer's symbolic factorisation ran out of memory or index range
        return Err(StructureError::MemoryLimit {
            ndof: n,
            factor_nnz: 0,
            needed_bytes: u64::MAX,
            factor_bytes: u64::MAX,
            limit_bytes: sparse.memory_limit_bytes.unwrap_or(u64::MAX),
        }
        .into());
    };
    timings.factor_nnz = estimate.factor_nnz;
    timings.memory_estimate_bytes = estimate.total_bytes;
    timings.ordering = sym.ordering().name().into();
    estimate.check(sparse.memory_limit_bytes)?;
    Ok(sym)
}

/// The reduced structural model of a sparse Craig-Bampton reduction `cb`:
/// its `M`, `K`, the damping (`C` projected, or `alpha M + beta K` and the
/// stiffness-proportional damping from the reduced `M`, `K`, with `omega`
/// [rad/s] the full model's natural frequencies), the cubic spring and the
/// named points as rows of the transformation (returned too).
fn cb_structural_model(
    opts: &MatrixStructureOptions<SparseMatrix>,
    cb: super::craig_bampton::SparseCraigBampton,
    omega: &[f64],
    spring: Option<(usize, f64)>,
) -> Result<(StructuralModel, DMatrix<f64>), MatricesError> {
    // C = alpha M + beta K projected as its parts (no full-size C is formed)
    let damping = match &opts.damping {
        MatrixDamping::Matrix(_) => cb.damping,
        MatrixDamping::Rayleigh {
            alpha_per_s,
            beta_s,
        } => &cb.mass * *alpha_per_s + &cb.stiffness * *beta_s,
        MatrixDamping::StiffnessProportional { ratio, mode_index } => {
            &cb.stiffness * (2.0 * ratio / omega[*mode_index])
        }
    };
    let row = |dof: usize| cb.transform.row(dof).transpose();
    let mut nonlinear = Vec::new();
    if let Some((dof, k3)) = spring {
        nonlinear.push(NonlinearElement {
            name: CUBIC_SPRING.into(),
            direction: row(dof),
            law: Arc::new(CubicSpring::new(k3)?),
        });
    }
    let model = StructuralModel {
        mass: cb.mass,
        stiffness: cb.stiffness,
        damping,
        nonlinear,
        points: opts
            .points
            .iter()
            .map(|(name, dof)| NamedPoint {
                name: name.clone(),
                direction: row(*dof),
            })
            .collect(),
    };
    model.validate()?;
    Ok((model, cb.transform))
}

#[cfg(test)]
#[path = "matrices_tests.rs"]
mod tests;
