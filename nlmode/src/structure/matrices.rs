//! The user's own structure from FE matrices (`eq:component1` with `M`, `K`, `C`
//! given as Matrix Market files): reading, the physical checks, named DOFs, a cubic
//! spring at a named point, damping and Craig-Bampton reduction.
//!
//! * [`read_matrix_market`] reads a Matrix Market file (coordinate or array, real,
//!   general or symmetric) by the `nalgebra-sparse` crate (feature `io`) into a
//!   dense `DMatrix`; [`write_matrix_market`] writes the coordinate symmetric form
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
use super::craig_bampton::craig_bampton;
use super::damping::{rayleigh_damping, stiffness_proportional_damping_from_modes};
use super::modal::modal_analysis;
use super::{CubicSpring, StructuralModel, StructureError};
use nalgebra::{DMatrix, DVector};
use std::path::{Path, PathBuf};

/// Relative symmetry tolerance of the matrices: `max |A - A^T| <= 1e-9 max |A|`.
pub const SYMMETRY_RTOL: f64 = 1e-9;

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
    /// The file is not valid Matrix Market (line 1-based where the reader names it).
    #[error("{role}: {} is not a valid Matrix Market file{}: {message}", path.display(),
        line.map(|l| format!(" (line {l})")).unwrap_or_default())]
    Malformed {
        role: MatrixRole,
        path: PathBuf,
        line: Option<usize>,
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
    /// A NaN or infinite entry.
    #[error("{role}: {} has a non-finite entry {value} at row {row}, column {col} (0-based)", path.display())]
    NonFinite {
        role: MatrixRole,
        path: PathBuf,
        row: usize,
        col: usize,
        value: f64,
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
    /// `M` is not positive definite.
    #[error("mass_mtx: {} is not positive definite (Cholesky factorisation failed)", path.display())]
    MassNotPositiveDefinite { path: PathBuf },
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
    /// An error of the structure layer (modal analysis, Craig-Bampton).
    #[error(transparent)]
    Structure(#[from] StructureError),
}

/// Line number (1-based) from a pest error message (`--> 7:3`).
fn pest_line(message: &str) -> Option<usize> {
    let rest = &message[message.find("-->")? + 3..];
    let rest = rest.trim_start();
    let end = rest.find(':')?;
    rest[..end].trim().parse().ok()
}

/// Reads a Matrix Market file (coordinate or array; real; general, symmetric or
/// skew-symmetric) into a dense square matrix; duplicate coordinate entries add up.
pub fn read_matrix_market(role: MatrixRole, path: &Path) -> Result<DMatrix<f64>, MatricesError> {
    let text = std::fs::read_to_string(path).map_err(|e| MatricesError::Io {
        role,
        path: path.into(),
        message: e.to_string(),
    })?;
    read_matrix_market_str(role, path, &text)
}

/// As [`read_matrix_market`] from the file's text (`path` only names it in errors).
pub fn read_matrix_market_str(
    role: MatrixRole,
    path: &Path,
    text: &str,
) -> Result<DMatrix<f64>, MatricesError> {
    let coo = nalgebra_sparse::io::load_coo_from_matrix_market_str::<f64>(text).map_err(|e| {
        let message = e.message().replace('\n', " ");
        MatricesError::Malformed {
            role,
            path: path.into(),
            line: pest_line(e.message()),
            message: message.split_whitespace().collect::<Vec<_>>().join(" "),
        }
    })?;
    let (rows, cols) = (coo.nrows(), coo.ncols());
    if rows != cols {
        return Err(MatricesError::NotSquare {
            role,
            path: path.into(),
            rows,
            cols,
        });
    }
    let mut a = DMatrix::zeros(rows, cols);
    for (r, c, v) in coo.triplet_iter() {
        if !v.is_finite() {
            return Err(MatricesError::NonFinite {
                role,
                path: path.into(),
                row: r,
                col: c,
                value: *v,
            });
        }
        a[(r, c)] += *v;
    }
    Ok(a)
}

/// The Matrix Market text (coordinate, real, symmetric: the lower triangle's
/// non-zeros) of the symmetric matrix `a`; numbers in Rust's shortest round-trip
/// form, so [`read_matrix_market_str`] gives back the same bits.
pub fn write_matrix_market(a: &DMatrix<f64>) -> String {
    let mut entries = Vec::new();
    for c in 0..a.ncols() {
        for r in c..a.nrows() {
            if a[(r, c)] != 0.0 {
                entries.push(format!("{} {} {:e}", r + 1, c + 1, a[(r, c)]));
            }
        }
    }
    format!(
        "%%MatrixMarket matrix coordinate real symmetric\n{} {} {}\n{}\n",
        a.nrows(),
        a.ncols(),
        entries.len(),
        entries.join("\n")
    )
}

/// Linear damping of a matrices structure.
#[derive(Debug, Clone, PartialEq)]
pub enum MatrixDamping {
    /// `C` given as a matrix (already read and checked for shape).
    Matrix(DMatrix<f64>),
    /// `C = alpha M + beta K` (`alpha` [1/s], `beta` [s]).
    Rayleigh { alpha_per_s: f64, beta_s: f64 },
    /// `C = beta K` with damping ratio `ratio` on mode `mode_index` (0-based) of the
    /// full model, as the paper's beam (`D0` on mode 1).
    StiffnessProportional { ratio: f64, mode_index: usize },
}

/// Everything [`matrix_structure`] needs; the file paths only name the matrices in
/// errors.
#[derive(Debug, Clone)]
pub struct MatrixStructureOptions {
    pub mass: DMatrix<f64>,
    pub mass_path: PathBuf,
    pub stiffness: DMatrix<f64>,
    pub stiffness_path: PathBuf,
    pub damping: MatrixDamping,
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

/// The structure built from matrices: the model to simulate (reduced or full), the
/// full model and `q_full = transform q`.
#[derive(Debug, Clone)]
pub struct MatrixStructure {
    /// The model used downstream (Craig-Bampton reduced unless none was asked).
    pub model: StructuralModel,
    /// The full model with damping, points and the nonlinear element.
    pub full: StructuralModel,
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
    if a.nrows() != n {
        return Err(MatricesError::SizeMismatch {
            role,
            path: path.into(),
            n: a.nrows(),
            expected: n,
        });
    }
    if let Some(i) = a.iter().position(|v| !v.is_finite()) {
        return Err(MatricesError::NonFinite {
            role,
            path: path.into(),
            row: i % n,
            col: i / n,
            value: a[i],
        });
    }
    let scale = a.amax();
    let asymmetry = (a - a.transpose()).amax();
    if asymmetry > SYMMETRY_RTOL * scale {
        return Err(MatricesError::NotSymmetric {
            role,
            path: path.into(),
            asymmetry,
            scale,
        });
    }
    let (what, expected, ok): (_, _, fn(f64) -> bool) = match role {
        MatrixRole::Mass => ("mass", "positive", |v| v > 0.0),
        MatrixRole::Stiffness => ("stiffness", ">= 0", |v| v >= 0.0),
        MatrixRole::Damping => ("damping", ">= 0", |v| v >= 0.0),
    };
    if let Some(row) = (0..n).find(|&i| !ok(a[(i, i)])) {
        return Err(MatricesError::BadDiagonal {
            role,
            path: path.into(),
            row,
            value: a[(row, row)],
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

/// Checks and builds the structure of `opts` (see the module docs).
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
        });
    }
    let mut full = StructuralModel::new(opts.mass.clone(), opts.stiffness.clone());
    let mut point_dofs = Vec::new();
    for (name, dof) in &opts.points {
        if *dof >= n {
            return Err(MatricesError::DofOutOfRange {
                name: name.clone(),
                dof: *dof,
                ndof: n,
            });
        }
        if point_dofs.iter().any(|(p, _): &(String, usize)| p == name) {
            return Err(MatricesError::DuplicatePoint { name: name.clone() });
        }
        full.add_named_point(name, unit(n, *dof))?;
        point_dofs.push((name.clone(), *dof));
    }
    let dof_of = |key: &'static str, name: &str| {
        point_dofs
            .iter()
            .find(|(p, _)| p == name)
            .map(|(_, d)| *d)
            .ok_or_else(|| MatricesError::UnknownPoint {
                key,
                name: name.to_string(),
                available: point_dofs.iter().map(|(p, _)| p.clone()).collect(),
            })
    };
    if let Some((point, k3)) = &opts.cubic_spring {
        if !(k3.is_finite() && *k3 >= 0.0) {
            return Err(MatricesError::InvalidParameter {
                key: "k3_n_per_m3",
                value: *k3,
                expected: "a finite number >= 0",
            });
        }
        let dof = dof_of("nonlinear_point", point)?;
        if *k3 != 0.0 {
            full.add_nonlinear(CUBIC_SPRING, unit(n, dof), CubicSpring::new(*k3)?)?;
        }
    }
    // Enough modes to count rigid-body modes (at most 6 in space) and to calibrate
    // the damping mode; the eigenvalues do not depend on how many are kept.
    let damping_mode = match opts.damping {
        MatrixDamping::StiffnessProportional { mode_index, .. } => mode_index,
        _ => 0,
    };
    if damping_mode >= n {
        return Err(MatricesError::InvalidParameter {
            key: "damping_mode",
            value: (damping_mode + 1) as f64,
            expected: "a mode number between 1 and the number of DOFs",
        });
    }
    let n_modes = (damping_mode + 1).max(7).min(n);
    let modes = modal_analysis(&full, n_modes).map_err(|e| match e {
        StructureError::NegativeEigenvalue { lambda, .. } => MatricesError::StiffnessIndefinite {
            path: opts.stiffness_path.clone(),
            lambda,
        },
        e => e.into(),
    })?;
    let rigid_body_modes = modes.omega_rad_s.iter().filter(|w| **w == 0.0).count();
    if rigid_body_modes > 0 && !opts.allow_rigid_body_modes {
        return Err(MatricesError::RigidBodyModes {
            path: opts.stiffness_path.clone(),
            count: rigid_body_modes,
        });
    }
    let omega0_rad_s = modes.omega_rad_s.iter().copied().find(|w| *w > 0.0).ok_or(
        MatricesError::RigidBodyModes {
            path: opts.stiffness_path.clone(),
            count: rigid_body_modes,
        },
    )?;
    match &opts.damping {
        MatrixDamping::Matrix(c) => full.damping = c.clone(),
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
            rayleigh_damping(&mut full, *alpha_per_s, *beta_s)?;
        }
        MatrixDamping::StiffnessProportional { ratio, mode_index } => {
            if !(ratio.is_finite() && *ratio >= 0.0 && *ratio < 1.0) {
                return Err(MatricesError::InvalidParameter {
                    key: "damping_ratio",
                    value: *ratio,
                    expected: "0 <= D < 1",
                });
            }
            stiffness_proportional_damping_from_modes(&mut full, &modes, *mode_index, *ratio)?;
        }
    }
    // exact for the proportional kinds (damping.rs), the projection for a matrix
    let damping_ratio = match &opts.damping {
        MatrixDamping::StiffnessProportional { ratio, mode_index } => {
            ratio * omega0_rad_s / modes.omega_rad_s[*mode_index]
        }
        MatrixDamping::Rayleigh {
            alpha_per_s,
            beta_s,
        } => alpha_per_s / (2.0 * omega0_rad_s) + beta_s * omega0_rad_s / 2.0,
        MatrixDamping::Matrix(c) => {
            let phi = modes.shape(rigid_body_modes);
            phi.dot(&(c * &phi)) / (2.0 * omega0_rad_s)
        }
    };
    let (model, transform, interface_omega_rad_s) = match &opts.craig_bampton {
        Some((masters, n_modes)) => {
            let dofs = masters
                .iter()
                .map(|m| dof_of("cb_masters", m))
                .collect::<Result<Vec<_>, _>>()?;
            let cb = craig_bampton(&full, &dofs, *n_modes)?;
            (cb.reduced, cb.transform, cb.interface_omega_rad_s)
        }
        None => (full.clone(), DMatrix::identity(n, n), Vec::new()),
    };
    Ok(MatrixStructure {
        model,
        full,
        transform,
        rigid_body_modes,
        omega0_rad_s,
        damping_ratio,
        interface_omega_rad_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pest_line_numbers() {
        assert_eq!(pest_line("Error:  --> 7:3\n  |"), Some(7));
        assert_eq!(pest_line("no line"), None);
    }
}
