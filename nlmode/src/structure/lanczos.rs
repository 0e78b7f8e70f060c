//! The lowest eigenpairs of `K phi = lambda M phi` (`eq:component1` without
//! damping and nonlinearity) of a large sparse model by a shift-invert block
//! Lanczos iteration on a sparse factorisation ([`super::sparse`]).
//!
//! The eigensolver is hand-rolled on purpose: faer has no sparse eigensolver, and
//! the iteration is a few dense block operations around faer's sparse solves.
//!
//! Shift-invert: with a solver of `K - sigma M` ([`ShiftInvert`]), the operator
//! `Op = (K - sigma M)^{-1} M` is self-adjoint in the `M` inner product and has the
//! eigenvalues `mu = 1 / (lambda - sigma)`: the lowest `lambda` are its largest,
//! well-separated `mu`. The block Lanczos basis `V` is kept `M`-orthonormal by full
//! re-orthogonalisation (two classical Gram-Schmidt passes), so that
//! `Op V_m = V_m T_m + V_next R E^T`; the Ritz pairs of the small `T_m` converge
//! when their residual `||R y_last|| <= LANCZOS_RTOL mu`. Each converged pair is
//! then verified on the residual of the original problem, `K x - lambda M x`,
//! measured in the norm of `(K - sigma M)^{-1}` relative to `||x||_M`:
//! `||x - (lambda - sigma) Op x||_M <= RESIDUAL_RTOL` (one more solve). The plain
//! `||K x - lambda M x|| / ||K x||` is reported too ([`SparseModes::residual`]) but
//! not tested: on a stiff FE model (`cond(K) ~ 1e10` and more) rounding-size
//! high-frequency content of an accurate `x` dominates it (`1e-4` on a 100-element
//! beam whose frequencies are exact to `1e-13`). The basis grows as the iteration
//! needs it (no full-size block is allocated ahead) and is bounded (error with the
//! numbers when the iteration does not converge within it).
//!
//! Fixed DOFs ([`Pencil::fixed`], the Craig-Bampton masters): the problem on the
//! subspace `x_fixed = 0`, i.e. `K_ii phi_i = lambda M_ii phi_i` without forming
//! `K_ii` or `M_ii`: `M x` and `K x` have their fixed rows dropped, the solver
//! returns vectors with zero fixed rows (see
//! [`super::craig_bampton::InteriorSolver`]).
use super::product::{tall_mul_add, tall_tr_mul};
use super::sparse::{diagonal, sym_mul_par, Xorshift};
use super::sparse::{sparse_add, SparseCholesky, SparseMatrix, SymbolicFactor};
use super::{Result, StructureError};
use faer::Par;
use nalgebra::{DMatrix, DMatrixView, SymmetricEigen};

/// Convergence of a Ritz pair of the shift-inverted problem:
/// `||Op x - mu x||_M <= LANCZOS_RTOL mu`.
pub const LANCZOS_RTOL: f64 = 1e-12;

/// Verification of a converged pair on the original problem (module docs):
/// `||x - (lambda - sigma) Op x||_M <= RESIDUAL_RTOL` (shift 0), or the shifted
/// factorisation's rounding floor `64 eps lambda_scale / |sigma|` if larger.
pub const RESIDUAL_RTOL: f64 = 1e-10;

/// Most eigenpairs one sparse eigen-analysis computes (the basis grows with them).
pub const MAX_SPARSE_MODES: usize = 500;

/// Largest Lanczos basis for `n_modes` modes (`n` DOFs): `min(8 n_modes + 40, n)`
/// (allocated as the iteration grows, counted whole by the memory estimate).
pub fn max_basis(n_modes: usize, n: usize) -> usize {
    (8 * n_modes + 40).min(n)
}

/// Solves `(K - sigma M) X = B` in place for a shift-invert iteration.
pub trait ShiftInvert {
    /// `B` overwritten by `X`.
    fn solve_in_place(&self, b: &mut DMatrix<f64>);
}

impl ShiftInvert for SparseCholesky {
    fn solve_in_place(&self, b: &mut DMatrix<f64>) {
        SparseCholesky::solve_in_place(self, b)
    }
}

/// The pencil `(K, M)` of the iteration, with the DOFs `fixed` held at zero
/// (module docs), and the parallelism of its products.
#[derive(Debug, Clone, Copy)]
pub struct Pencil<'a> {
    pub m: &'a SparseMatrix,
    pub k: &'a SparseMatrix,
    pub fixed: &'a [usize],
    pub par: Par,
}

impl Pencil<'_> {
    /// Zero rows of the fixed DOFs.
    pub fn mask(&self, y: &mut DMatrix<f64>) {
        for &d in self.fixed {
            y.row_mut(d).fill(0.0);
        }
    }

    /// `M x` with the fixed rows dropped.
    pub fn mul_m(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        let mut y = sym_mul_par(self.m, x, self.par);
        self.mask(&mut y);
        y
    }

    /// `K x` with the fixed rows dropped.
    pub fn mul_k(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        let mut y = sym_mul_par(self.k, x, self.par);
        self.mask(&mut y);
        y
    }

    /// `max_i |M_ii|`, the scale of the rounding of `x^T M x` ([`m_norm`]).
    pub fn mass_scale(&self) -> f64 {
        diagonal(self.m).iter().fold(0.0, |a, d| a.max(d.abs()))
    }

    /// `lambda_scale = max_i K_ii / M_ii` over the free DOFs (a lower bound of
    /// the largest eigenvalue).
    pub fn lambda_scale(&self) -> f64 {
        self.scales().1
    }

    /// [`Pencil::mass_scale`] and [`Pencil::lambda_scale`] from one pass over
    /// each diagonal (a pass reads all of a matrix' row indices).
    pub fn scales(&self) -> (f64, f64) {
        let (dk, dm) = (diagonal(self.k), diagonal(self.m));
        let mut free = vec![true; dk.len()];
        for &d in self.fixed {
            free[d] = false;
        }
        let lambda = (0..dk.len())
            .filter(|&i| free[i])
            .map(|i| dk[i] / dm[i])
            .fold(0.0, f64::max);
        (dm.iter().fold(0.0, |a, d| a.max(d.abs())), lambda)
    }
}

/// Eigenpairs of `K phi = lambda M phi` from [`lanczos`]: `lambda` ascending,
/// mass-normalised shapes (sign as [`super::modal`]: the first largest entry
/// positive), the verified shift-inverted residuals and the plain ones.
#[derive(Debug, Clone)]
pub struct SparseModes {
    pub lambda: Vec<f64>,
    pub shapes: DMatrix<f64>,
    /// `||x - (lambda - sigma) Op x||_M` (tested against [`RESIDUAL_RTOL`]).
    pub inverse_residual: Vec<f64>,
    /// `||K x - lambda M x|| / ||K x||` (0 for a rigid-body mode), reported only.
    pub residual: Vec<f64>,
    /// Size of the Lanczos basis at convergence.
    pub basis: usize,
    /// [`Pencil::lambda_scale`] of the pencil ([`omega_of`]).
    pub lambda_scale: f64,
}

/// `x^T M x` below `-MASS_NORM_RTOL max_i |M_ii| x^T x` proves `M` indefinite
/// (the rounding of `x^T M x` is about `eps` times the row count of `M`
/// times that scale).
pub const MASS_NORM_RTOL: f64 = 1e-8;

/// The `M`-norm `sqrt(q)` of a vector `x` from `q = x^T M x` and `x_sq = x^T
/// x` (0 for a rounding-size negative `q`);
/// [`StructureError::MassNotPositiveDefinite`] when `q` is clearly negative
/// ([`MASS_NORM_RTOL`], `m_scale` = [`Pencil::mass_scale`]): the Lanczos
/// recurrence is then no inner product and `M` is indefinite.
pub fn m_norm(q: f64, x_sq: f64, m_scale: f64) -> Result<f64> {
    if q < -MASS_NORM_RTOL * m_scale * x_sq {
        return Err(StructureError::MassNotPositiveDefinite { name: "mass" });
    }
    Ok(q.max(0.0).sqrt())
}

/// `lambda_scale = max_i K_ii / M_ii` (a lower bound of the largest eigenvalue).
pub fn lambda_scale(m: &SparseMatrix, k: &SparseMatrix) -> f64 {
    Pencil {
        m,
        k,
        fixed: &[],
        par: Par::Seq,
    }
    .lambda_scale()
}

/// From this many DOFs on the Lanczos basis keeps `V` only and the
/// Gram-Schmidt coefficients `V^T M w` take `M w` afresh in each pass (two
/// more products with `M` per block step, about 10 % of a step at 10^6 DOFs)
/// instead of `(M V)^T w`: half the basis' memory (0.38 GB of 48 vectors at
/// 10^6 DOFs, the peak of the sparse path). Below it `M V` is kept.
pub const LEAN_BASIS_MIN_DOF: usize = 500_000;

/// The `M`-orthonormal Lanczos basis `V` and, below [`LEAN_BASIS_MIN_DOF`],
/// `M V`, grown column block by column block (column-major storage).
struct Basis {
    n: usize,
    v: Vec<f64>,
    mv: Option<Vec<f64>>,
}

impl Basis {
    fn cols(&self) -> usize {
        self.v.len() / self.n
    }
    fn v(&self) -> DMatrixView<'_, f64> {
        DMatrixView::from_slice(&self.v, self.n, self.cols())
    }
    fn mv(&self) -> Option<DMatrixView<'_, f64>> {
        let mv = self.mv.as_ref()?;
        Some(DMatrixView::from_slice(mv, self.n, self.cols()))
    }
    fn push(&mut self, q: &DMatrix<f64>, mq: &DMatrix<f64>) {
        self.v.extend_from_slice(q.as_slice());
        if let Some(mv) = &mut self.mv {
            mv.extend_from_slice(mq.as_slice());
        }
    }
}

/// The `n_modes` eigenpairs of `K phi = lambda M phi` with the lowest `lambda`
/// above the shift `sigma`, given `solver` of `K - sigma M` (module docs).
/// `name` names the mode count in errors.
pub fn lanczos(
    pencil: &Pencil,
    solver: &dyn ShiftInvert,
    sigma: f64,
    n_modes: usize,
    name: &'static str,
) -> Result<SparseModes> {
    let keep_mv = pencil.m.nrows() < LEAN_BASIS_MIN_DOF;
    lanczos_with(pencil, solver, sigma, n_modes, name, keep_mv)
}

/// [`lanczos`] with `M V` kept in the basis or not ([`LEAN_BASIS_MIN_DOF`]).
pub(crate) fn lanczos_with(
    pencil: &Pencil,
    solver: &dyn ShiftInvert,
    sigma: f64,
    n_modes: usize,
    name: &'static str,
    keep_mv: bool,
) -> Result<SparseModes> {
    let n = pencil.m.nrows() - pencil.fixed.len();
    if n_modes == 0 || n_modes > n || n_modes > MAX_SPARSE_MODES {
        return Err(StructureError::ModeCount {
            name,
            requested: n_modes,
            available: n.min(MAX_SPARSE_MODES),
        });
    }
    let nn = pencil.m.nrows();
    let (m_scale, lambda_scale) = pencil.scales();
    let b = n_modes.min(3);
    let m_max = max_basis(n_modes, n);
    let op = |x: &DMatrix<f64>| {
        let mut w = pencil.mul_m(x);
        solver.solve_in_place(&mut w);
        pencil.mask(&mut w);
        w
    };
    let mut rng = Xorshift(0x9e37_79b9_7f4a_7c15);
    let mut basis = Basis {
        n: nn,
        v: Vec::new(),
        mv: keep_mv.then(Vec::new),
    };
    let mut t = DMatrix::<f64>::zeros(m_max + b, m_max + b);
    // start block: Op applied to a random block, M-orthonormalised
    let w0 = op(&rng.block(nn, b));
    let (w0, mw0, _) = reorthogonalize(pencil, &basis, w0);
    let (q, mq, _) = orthonormalize_block(pencil, &basis, w0, mw0, b, &mut rng, m_scale)?;
    basis.push(&q, &mq);
    let mut m_cur = q.ncols();
    let mut m0 = 0;
    let mut last_residual = f64::INFINITY;
    let mut check = 0usize;
    loop {
        let bl = m_cur - m0;
        // Op on the last block: its M V is kept (below LEAN_BASIS_MIN_DOF)
        let w = match basis.mv() {
            Some(mv) => {
                let mut w = mv.columns(m0, bl).into_owned();
                solver.solve_in_place(&mut w);
                pencil.mask(&mut w);
                w
            }
            None => op(&basis.v().columns(m0, bl).into_owned()),
        };
        let (w, mw, coef) = reorthogonalize(pencil, &basis, w);
        t.view_mut((0, m0), (m_cur, bl)).copy_from(&coef);
        let exact = m_cur == n;
        let keep = bl.min(n - m_cur);
        let (q, mq, r) = if exact {
            (
                DMatrix::zeros(nn, 0),
                DMatrix::zeros(nn, 0),
                DMatrix::zeros(0, bl),
            )
        } else {
            orthonormalize_block(pencil, &basis, w, mw, keep, &mut rng, m_scale)?
        };
        t.view_mut((m_cur, m0), (r.nrows(), bl)).copy_from(&r);
        let full = exact || m_cur + q.ncols() > m_max;
        check += 1;
        // a truncated last block (keep < bl) has an incomplete R: wait for the
        // exact step that follows it
        if m_cur >= n_modes && (exact || keep == bl) && (check.is_multiple_of(2) || full) {
            let (worst, ritz) = ritz_pairs(&t, m_cur, m0, bl, &r, n_modes);
            last_residual = worst;
            if worst <= LANCZOS_RTOL {
                let (y, mus) = ritz;
                let mut x = DMatrix::zeros(nn, y.ncols());
                tall_mul_add(x.as_mut_slice(), &basis.v, &y, 1.0, nn, pencil.par);
                drop(basis);
                let found = Found {
                    basis: m_cur,
                    lambda_scale,
                };
                return finish(pencil, solver, sigma, &mus, x, found, name);
            }
        }
        if full {
            return Err(StructureError::EigenNotConverged {
                name,
                requested: n_modes,
                basis: m_cur,
                residual: last_residual,
            });
        }
        basis.push(&q, &mq);
        m0 = m_cur;
        m_cur += q.ncols();
    }
}

/// The largest relative Ritz residual of the `n_modes` largest Ritz values of
/// `T_m` (`m_cur x m_cur`, last block at `m0` of width `bl`, next factor `r`)
/// and those Ritz vectors (coefficients in `V`) and values `mu`, descending.
fn ritz_pairs(
    t: &DMatrix<f64>,
    m_cur: usize,
    m0: usize,
    bl: usize,
    r: &DMatrix<f64>,
    n_modes: usize,
) -> (f64, (DMatrix<f64>, Vec<f64>)) {
    // the upper triangle of T_m holds the Gram-Schmidt coefficients
    // V^T M Op V (complete); the lower one only the R factors
    let sym = DMatrix::from_fn(m_cur, m_cur, |i, j| t[(i.min(j), i.max(j))]);
    let eig = SymmetricEigen::new(sym);
    let mut order: Vec<usize> = (0..m_cur).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let mut worst = 0.0f64;
    let mut y = DMatrix::zeros(m_cur, n_modes);
    let mut mus = Vec::with_capacity(n_modes);
    for (c, &i) in order.iter().take(n_modes).enumerate() {
        let mu = eig.eigenvalues[i];
        let y_last = eig.eigenvectors.view((m0, i), (bl, 1));
        let res = if r.nrows() == 0 {
            0.0
        } else {
            (r * y_last).norm()
        };
        worst = worst.max(if mu > 0.0 { res / mu } else { f64::INFINITY });
        y.set_column(c, &eig.eigenvectors.column(i));
        mus.push(mu);
    }
    (worst, (y, mus))
}

/// Two classical Gram-Schmidt passes of `w` against the `M`-orthonormal basis:
/// the orthogonalised `w`, `M w` and the summed coefficients `V^T M w`
/// (`(M V)^T w`, or `V^T (M w)` for a basis without `M V`).
fn reorthogonalize(
    pencil: &Pencil,
    basis: &Basis,
    mut w: DMatrix<f64>,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let (n, par) = (basis.n, pencil.par);
    let mut coef = DMatrix::zeros(basis.cols(), w.ncols());
    if basis.cols() > 0 {
        for _ in 0..2 {
            // M w afresh each pass: updating it as M w - (M V) c would lose the small
            // remainder to cancellation once the Krylov space has converged
            let c = match &basis.mv {
                Some(mv) => tall_tr_mul(mv, w.as_slice(), n, par),
                None => tall_tr_mul(&basis.v, pencil.mul_m(&w).as_slice(), n, par),
            };
            tall_mul_add(w.as_mut_slice(), &basis.v, &c, -1.0, n, par);
            coef += c;
        }
    }
    let mw = pencil.mul_m(&w);
    (w, mw, coef)
}

/// A block column whose Gram-Schmidt update left less than this fraction of
/// its `M`-norm gets `M w` afresh ([`orthonormalize_block`]); above it the
/// updated `M w` loses at most about `eps / FRESH_PRODUCT_BELOW` relative.
const FRESH_PRODUCT_BELOW: f64 = 0.25;

/// `M`-orthonormalises `w` (already orthogonal to the basis) by modified
/// Gram-Schmidt into at most `keep` columns, `w[.., ..keep] = Q R` (`R` is
/// `keep x w.ncols()`); a direction that vanishes (relative `1e-10`) is replaced
/// by a random one orthogonal to the basis, with a zero factor. A clearly
/// negative `M`-norm is [`StructureError::MassNotPositiveDefinite`] ([`m_norm`]).
fn orthonormalize_block(
    pencil: &Pencil,
    basis: &Basis,
    mut w: DMatrix<f64>,
    mut mw: DMatrix<f64>,
    keep: usize,
    rng: &mut Xorshift,
    m_scale: f64,
) -> Result<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)> {
    let bl = w.ncols();
    let mut r = DMatrix::zeros(keep, bl);
    for c in 0..keep {
        let (wc, mwc) = (w.column(c), mw.column(c));
        let before = m_norm(wc.dot(&mwc), wc.norm_squared(), m_scale)?;
        for _ in 0..2 {
            // coefficients against the normalised columns, M w_d known exactly
            let s = mw.columns(0, c).tr_mul(&w.column(c));
            let upd = w.columns(0, c) * &s;
            w.column_mut(c).axpy(-1.0, &upd, 1.0);
            for d in 0..c {
                r[(d, c)] += s[d];
            }
        }
        // M w_c by the same update as w_c (M is linear), afresh when the update
        // cancelled much of w_c (the small remainder would be lost to rounding)
        let s_all = r.view((0, c), (c, 1)).into_owned();
        let mut mwc = mw.column(c) - mw.columns(0, c) * &s_all;
        let wc = w.column(c).into_owned();
        let mut norm = m_norm(wc.dot(&mwc), wc.norm_squared(), m_scale)?;
        if norm < FRESH_PRODUCT_BELOW * before {
            let fresh = pencil.mul_m(&DMatrix::from_column_slice(wc.len(), 1, wc.as_slice()));
            mwc = fresh.column(0).into_owned();
            norm = m_norm(wc.dot(&mwc), wc.norm_squared(), m_scale)?;
        }
        if norm > 1e-10 * before && norm > 0.0 {
            w.column_mut(c).scale_mut(1.0 / norm);
            mw.set_column(c, &(mwc / norm));
            r[(c, c)] = norm;
        } else {
            // an invariant subspace: continue with a fresh direction
            let mut fresh = rng.block(w.nrows(), 1);
            pencil.mask(&mut fresh);
            let (f, _, _) = reorthogonalize(pencil, basis, fresh);
            let (f, mf) = reorthogonalize_local(pencil, &w, c, f);
            let (fc, mfc) = (f.column(0), mf.column(0));
            let norm = m_norm(fc.dot(&mfc), fc.norm_squared(), m_scale)?;
            if norm.is_nan() || norm <= 0.0 {
                return Err(StructureError::MassNotPositiveDefinite { name: "mass" });
            }
            w.set_column(c, &(f.column(0) / norm));
            mw.set_column(c, &(mf.column(0) / norm));
        }
    }
    Ok((
        w.columns(0, keep).into_owned(),
        mw.columns(0, keep).into_owned(),
        r,
    ))
}

/// Two Gram-Schmidt passes of the column `f` against the first `c` columns of
/// the `M`-orthonormal block `w`.
fn reorthogonalize_local(
    pencil: &Pencil,
    w: &DMatrix<f64>,
    c: usize,
    mut f: DMatrix<f64>,
) -> (DMatrix<f64>, DMatrix<f64>) {
    for _ in 0..2 {
        let mf = pencil.mul_m(&f);
        let s = w.columns(0, c).tr_mul(&mf);
        f -= w.columns(0, c) * s;
    }
    let mf = pencil.mul_m(&f);
    (f, mf)
}

/// The converged basis size and [`Pencil::lambda_scale`] ([`finish`]).
struct Found {
    basis: usize,
    lambda_scale: f64,
}

/// Ritz vectors to eigenpairs: `lambda = sigma + 1/mu`, sign convention, the
/// verified residuals (module docs).
fn finish(
    pencil: &Pencil,
    solver: &dyn ShiftInvert,
    sigma: f64,
    mus: &[f64],
    mut x: DMatrix<f64>,
    found: Found,
    name: &'static str,
) -> Result<SparseModes> {
    let Found {
        basis,
        lambda_scale: scale,
    } = found;
    let lambda: Vec<f64> = mus.iter().map(|mu| sigma + 1.0 / mu).collect();
    if lambda.iter().any(|l| !l.is_finite()) {
        return Err(StructureError::NonFinite {
            name: "stiffness".into(),
        });
    }
    for mut col in x.column_iter_mut() {
        let amax = col.amax();
        if let Some(first) = col.iter().position(|v| v.abs() >= (1.0 - 1e-6) * amax) {
            if col[first] < 0.0 {
                col.neg_mut();
            }
        }
    }
    // a zero eigenvalue (|lambda| <= 1e-12 lambda_scale: a rigid-body mode, or
    // with sigma = 0 a singular K that passed the factorisation by rounding)
    // is left to the caller; its residual is rounding-dominated
    let zero: Vec<bool> = lambda.iter().map(|l| l.abs() <= 1e-12 * scale).collect();
    // the plain residuals first; then M x becomes Op x, then the residual
    // x - (lambda - sigma) Op x in place (three blocks of n x modes alive at most)
    let kx = pencil.mul_k(&x);
    let mut opx = pencil.mul_m(&x);
    let residual: Vec<f64> = lambda
        .iter()
        .enumerate()
        .map(|(j, &l)| {
            let kn = kx.column(j).norm();
            if zero[j] || kn == 0.0 {
                0.0
            } else {
                (kx.column(j) - opx.column(j) * l).norm() / kn
            }
        })
        .collect();
    drop(kx);
    solver.solve_in_place(&mut opx);
    pencil.mask(&mut opx);
    for (j, &l) in lambda.iter().enumerate() {
        let mut c = opx.column_mut(j);
        c *= -(l - sigma);
        c += x.column(j);
    }
    let mr = pencil.mul_m(&opx);
    // a shifted factorisation (rigid-body modes) is as ill-conditioned as
    // lambda_scale / |sigma|: its rounding floor
    let bound = if sigma == 0.0 {
        RESIDUAL_RTOL
    } else {
        RESIDUAL_RTOL.max(64.0 * f64::EPSILON * scale / sigma.abs())
    };
    let mut inverse_residual = Vec::with_capacity(lambda.len());
    for (j, &zero) in zero.iter().enumerate() {
        let inv = opx.column(j).dot(&mr.column(j)).max(0.0).sqrt();
        if !(inv <= bound || zero) {
            return Err(StructureError::EigenNotConverged {
                name,
                requested: mus.len(),
                basis,
                residual: inv,
            });
        }
        inverse_residual.push(inv);
    }
    Ok(SparseModes {
        lambda,
        shapes: x,
        inverse_residual,
        residual,
        basis,
        lambda_scale: scale,
    })
}

/// A factorisation of `K - sigma M` for [`modes`]: `K` itself when it is
/// positive definite (`sigma = 0`, the most accurate form), otherwise
/// `K + s M`, `sigma = -s`, `s = 1e-8 lambda_scale * 10^j`, `j = 0..12`, the
/// first positive definite one (rigid-body modes). No positive definite
/// `K + s M` at all is [`StructureError::NegativeEigenvalue`] with the bound
/// `lambda < -s_max`.
#[derive(Debug)]
pub struct ModalFactor {
    pub factor: SparseCholesky,
    pub sigma: f64,
}

/// [`ModalFactor`] of `(M, K)`; `symbolic` (of `K`'s pattern) and `par` for
/// the factorisation of `K` itself.
pub fn modal_factor(
    m: &SparseMatrix,
    k: &SparseMatrix,
    symbolic: Option<&SymbolicFactor>,
    par: Par,
) -> Result<ModalFactor> {
    let first = match symbolic {
        Some(s) => SparseCholesky::with_symbolic(s, k, par),
        None => SymbolicFactor::new(k).and_then(|s| SparseCholesky::with_symbolic(&s, k, par)),
    };
    if let Some(factor) = first {
        return Ok(ModalFactor { factor, sigma: 0.0 });
    }
    let scale = lambda_scale(m, k);
    let mut shift = 0.0;
    for j in 0..=12 {
        if scale.is_nan() || scale <= 0.0 {
            break;
        }
        shift = 1e-8 * scale * 10f64.powi(j);
        let a = sparse_add(1.0, k, shift, m);
        let f = SymbolicFactor::new(&a).and_then(|s| SparseCholesky::with_symbolic(&s, &a, par));
        if let Some(factor) = f {
            return Ok(ModalFactor {
                factor,
                sigma: -shift,
            });
        }
    }
    Err(StructureError::NegativeEigenvalue {
        index: 0,
        lambda: -shift,
    })
}

/// The `n_modes` lowest modes of `K phi = omega^2 M phi` of a sparse model
/// (`M` SPD, `K` positive semi-definite) from its [`ModalFactor`], as
/// [`super::modal::modal_analysis`]: `omega` ascending [rad/s], rigid-body modes
/// (`|lambda| <= 1e-12 lambda_scale`) exactly zero, mass-normalised shapes, and
/// the Lanczos basis size. A clearly negative eigenvalue is
/// [`StructureError::NegativeEigenvalue`].
pub fn modes(
    pencil: &Pencil,
    f: &ModalFactor,
    n_modes: usize,
    name: &'static str,
) -> Result<(Vec<f64>, DMatrix<f64>, usize)> {
    let modes = lanczos(pencil, &f.factor, f.sigma, n_modes, name)?;
    let omega = omega_of(&modes.lambda, modes.lambda_scale)?;
    Ok((omega, modes.shapes, modes.basis))
}

/// The natural frequencies [rad/s] of the eigenvalues `lambda` of a pencil
/// of [`Pencil::lambda_scale`] `scale`, as [`modes`]: rigid-body modes
/// (`|lambda| <= 1e-12 scale`) exactly zero, a clearly negative eigenvalue
/// [`StructureError::NegativeEigenvalue`].
pub fn omega_of(lambda: &[f64], scale: f64) -> Result<Vec<f64>> {
    let mut omega = Vec::with_capacity(lambda.len());
    for (c, &l) in lambda.iter().enumerate() {
        if l < -1e-12 * scale {
            return Err(StructureError::NegativeEigenvalue {
                index: c,
                lambda: l,
            });
        }
        omega.push(if l.abs() <= 1e-12 * scale {
            0.0
        } else {
            l.sqrt()
        });
    }
    Ok(omega)
}

/// [`modes`] of `(M, K)` with their own factorisation (sequential).
pub fn sparse_modal(
    m: &SparseMatrix,
    k: &SparseMatrix,
    n_modes: usize,
    name: &'static str,
) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let f = modal_factor(m, k, None, Par::Seq)?;
    let pencil = Pencil {
        m,
        k,
        fixed: &[],
        par: Par::Seq,
    };
    let (omega, shapes, _) = modes(&pencil, &f, n_modes, name)?;
    Ok((omega, shapes))
}
