//! Sparse FE matrices for large models (the `craig-bampton` path of a matrices
//! structure, [`super::matrices::matrix_structure_sparse`]): compressed-column
//! storage and sparse Cholesky factorisation by the `faer` crate, products with
//! dense blocks, and the lowest eigenpairs of `K phi = lambda M phi`
//! (`eq:component1` without damping and nonlinearity) by a shift-invert block
//! Lanczos iteration on the sparse factorisation.
//!
//! The eigensolver is hand-rolled on purpose: faer has no sparse eigensolver, and
//! the iteration is a few dense block operations around faer's sparse solves.
//!
//! Shift-invert: with `K - sigma M = L L^T` (sparse Cholesky), the operator
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
//! beam whose frequencies are exact to `1e-13`). The basis size is bounded (error
//! with the numbers when the iteration does not converge within it).
use super::{Result, StructureError};
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::Llt;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Accum, MatMut, MatRef, Par, Side};
use nalgebra::{DMatrix, SymmetricEigen};

/// A sparse square matrix in compressed-column storage (faer).
pub type SparseMatrix = SparseColMat<usize, f64>;

/// Convergence of a Ritz pair of the shift-inverted problem:
/// `||Op x - mu x||_M <= LANCZOS_RTOL mu`.
pub const LANCZOS_RTOL: f64 = 1e-12;

/// Verification of a converged pair on the original problem (module docs):
/// `||x - (lambda - sigma) Op x||_M <= RESIDUAL_RTOL` (shift 0), or the shifted
/// factorisation's rounding floor `64 eps lambda_scale / |sigma|` if larger.
pub const RESIDUAL_RTOL: f64 = 1e-10;

/// A factorisation that reproduces `z` from `A z` worse than this (relative, max
/// norm) counts as singular: a regular FE stiffness with `cond(K) ~ 1e10` does it
/// to about `1e-8`, a singular one that passed by rounding misses by `O(1)` or more.
pub const SINGULAR_PROBE_RTOL: f64 = 1e-3;

/// Most eigenpairs one sparse eigen-analysis computes (the basis grows with them).
pub const MAX_SPARSE_MODES: usize = 500;

/// `n x n` sparse matrix from `(row, col, value)` triplets, duplicates summed;
/// `None` if an index is out of range.
pub fn sparse_from_triplets(n: usize, triplets: &[(usize, usize, f64)]) -> Option<SparseMatrix> {
    let t: Vec<_> = triplets
        .iter()
        .map(|&(r, c, v)| Triplet::new(r, c, v))
        .collect();
    SparseColMat::try_new_from_triplets(n, n, &t).ok()
}

/// The non-zero (and non-finite) entries of a dense square matrix as a sparse one.
pub fn sparse_from_dense(a: &DMatrix<f64>) -> SparseMatrix {
    let mut t = Vec::new();
    for c in 0..a.ncols() {
        for r in 0..a.nrows() {
            let v = a[(r, c)];
            if v != 0.0 {
                t.push((r, c, v));
            }
        }
    }
    sparse_from_triplets(a.nrows().max(a.ncols()), &t).expect("indices of the matrix")
}

/// The dense form of a sparse matrix.
pub fn sparse_to_dense(a: &SparseMatrix) -> DMatrix<f64> {
    let mut d = DMatrix::zeros(a.nrows(), a.ncols());
    for_each_entry(a, |r, c, v| d[(r, c)] += v);
    d
}

/// Calls `f(row, col, value)` for every stored entry, column by column with
/// ascending rows.
pub fn for_each_entry(a: &SparseMatrix, mut f: impl FnMut(usize, usize, f64)) {
    let a = a.as_ref();
    let (sym, val) = (a.symbolic(), a.val());
    let rows = sym.row_idx();
    for c in 0..a.ncols() {
        for p in sym.col_range(c) {
            f(rows[p], c, val[p]);
        }
    }
}

/// `max |A - A^T|` and `max |A|` of a square sparse matrix.
pub fn asymmetry(a: &SparseMatrix) -> (f64, f64) {
    // A^T in compressed-column storage, then the columns of A and A^T merged.
    let at = a
        .as_ref()
        .transpose()
        .to_col_major()
        .expect("transpose of a sparse matrix");
    let (a, at) = (a.as_ref(), at.as_ref());
    let (ra, va, rt, vt) = (
        a.symbolic().row_idx(),
        a.val(),
        at.symbolic().row_idx(),
        at.val(),
    );
    let (mut asym, mut scale) = (0.0f64, 0.0f64);
    for c in 0..a.ncols() {
        let (pa, pt) = (a.symbolic().col_range(c), at.symbolic().col_range(c));
        let (mut i, mut j) = (pa.start, pt.start);
        while i < pa.end || j < pt.end {
            let (x, y);
            if j >= pt.end || (i < pa.end && ra[i] < rt[j]) {
                (x, y) = (va[i], 0.0);
                i += 1;
            } else if i >= pa.end || rt[j] < ra[i] {
                (x, y) = (0.0, vt[j]);
                j += 1;
            } else {
                (x, y) = (va[i], vt[j]);
                i += 1;
                j += 1;
            }
            scale = scale.max(x.abs());
            asym = asym.max((x - y).abs());
        }
    }
    (asym, scale)
}

/// The diagonal of a square sparse matrix.
pub fn diagonal(a: &SparseMatrix) -> Vec<f64> {
    let mut d = vec![0.0; a.nrows().min(a.ncols())];
    for_each_entry(a, |r, c, v| {
        if r == c {
            d[r] += v;
        }
    });
    d
}

/// `alpha A + beta B` of two sparse matrices of one size.
pub fn sparse_add(alpha: f64, a: &SparseMatrix, beta: f64, b: &SparseMatrix) -> SparseMatrix {
    let mut t = Vec::new();
    for_each_entry(a, |r, c, v| t.push((r, c, alpha * v)));
    for_each_entry(b, |r, c, v| t.push((r, c, beta * v)));
    sparse_from_triplets(a.nrows(), &t).expect("indices of the matrices")
}

/// The sub-matrix `A[rows, cols]` (`rows`, `cols` as position maps: `pos[i]` is
/// the new index of old index `i`, `None` if dropped) as triplets.
fn sub_triplets(
    a: &SparseMatrix,
    rows: &[Option<usize>],
    cols: &[Option<usize>],
) -> Vec<(usize, usize, f64)> {
    let mut t = Vec::new();
    for_each_entry(a, |r, c, v| {
        if let (Some(i), Some(j)) = (rows[r], cols[c]) {
            t.push((i, j, v));
        }
    });
    t
}

/// The square sub-matrix `A[idx, idx]` (`pos` maps old to new indices).
pub fn sparse_submatrix(a: &SparseMatrix, pos: &[Option<usize>], n: usize) -> SparseMatrix {
    sparse_from_triplets(n, &sub_triplets(a, pos, pos)).expect("indices of the sub-matrix")
}

/// The dense block `A[rows, cols]` (`nr x nc`, position maps as above).
pub fn dense_block(
    a: &SparseMatrix,
    rows: &[Option<usize>],
    nr: usize,
    cols: &[Option<usize>],
    nc: usize,
) -> DMatrix<f64> {
    let mut d = DMatrix::zeros(nr, nc);
    for (i, j, v) in sub_triplets(a, rows, cols) {
        d[(i, j)] += v;
    }
    d
}

/// `A X` of a sparse `A` and a dense block `X`.
pub fn sparse_mul(a: &SparseMatrix, x: &DMatrix<f64>) -> DMatrix<f64> {
    assert_eq!(a.ncols(), x.nrows(), "sparse_mul: sizes");
    let mut y = DMatrix::zeros(a.nrows(), x.ncols());
    let (nr, nc) = (a.nrows(), x.ncols());
    let xr = MatRef::from_column_major_slice(x.as_slice(), x.nrows(), nc);
    let yr = MatMut::from_column_major_slice_mut(y.as_mut_slice(), nr, nc);
    faer::sparse::linalg::matmul::sparse_dense_matmul(
        yr,
        Accum::Replace,
        a.as_ref(),
        xr,
        1.0,
        Par::Seq,
    );
    y
}

/// Sparse Cholesky factorisation `A = L L^T` of a symmetric positive definite
/// matrix (faer, fill-reducing ordering; the lower triangle is read).
pub struct SparseCholesky {
    llt: Llt<usize, f64>,
}

impl std::fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SparseCholesky")
    }
}

impl SparseCholesky {
    /// `None` when `a` is not (numerically) positive definite: the factorisation
    /// fails, or it does not reproduce a pseudo-random `z` from `A z` to
    /// [`SINGULAR_PROBE_RTOL`] (a singular `A`, e.g. a stiffness with rigid-body
    /// modes, can pass the factorisation with rounding-size pivots).
    pub fn new(a: &SparseMatrix) -> Option<Self> {
        let f = Self {
            llt: a.sp_cholesky(Side::Lower).ok()?,
        };
        let z = Xorshift(0x2545_f491_4f6c_dd1d).block(a.nrows(), 1);
        let mut x = sparse_mul(a, &z);
        f.solve_in_place(&mut x);
        let err = (x - &z).amax() / z.amax();
        (err <= SINGULAR_PROBE_RTOL).then_some(f)
    }

    /// Solves `A X = B` in place (`B` overwritten by `X`).
    pub fn solve_in_place(&self, b: &mut DMatrix<f64>) {
        let (nr, nc) = b.shape();
        let view = MatMut::from_column_major_slice_mut(b.as_mut_slice(), nr, nc);
        self.llt.solve_in_place(view);
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
}

/// `lambda_scale = max_i K_ii / M_ii` (a lower bound of the largest eigenvalue).
pub fn lambda_scale(m: &SparseMatrix, k: &SparseMatrix) -> f64 {
    diagonal(k)
        .iter()
        .zip(diagonal(m))
        .map(|(kk, mm)| kk / mm)
        .fold(0.0, f64::max)
}

/// Deterministic pseudo-random numbers in `(-1, 1)` (xorshift64*), for the start
/// block and for replacing deflated directions: reproducible results.
struct Xorshift(u64);

impl Xorshift {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let u = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
        2.0 * (u as f64 / (1u64 << 53) as f64) - 1.0
    }
    fn block(&mut self, n: usize, b: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, b, |_, _| self.next())
    }
}

/// The `n_modes` eigenpairs of `K phi = lambda M phi` with the lowest `lambda`
/// above the shift `sigma`, given `factor` of `K - sigma M` (module docs).
/// `name` names the mode count in errors.
pub fn lanczos(
    m: &SparseMatrix,
    k: &SparseMatrix,
    factor: &SparseCholesky,
    sigma: f64,
    n_modes: usize,
    name: &'static str,
) -> Result<SparseModes> {
    let n = m.nrows();
    if n_modes == 0 || n_modes > n || n_modes > MAX_SPARSE_MODES {
        return Err(StructureError::ModeCount {
            name,
            requested: n_modes,
            available: n.min(MAX_SPARSE_MODES),
        });
    }
    let b = n_modes.min(3);
    let m_max = (8 * n_modes + 40).min(n);
    let op = |x: &DMatrix<f64>| {
        let mut w = sparse_mul(m, x);
        factor.solve_in_place(&mut w);
        w
    };
    let mut rng = Xorshift(0x9e37_79b9_7f4a_7c15);
    let mut v = DMatrix::<f64>::zeros(n, m_max);
    let mut mv = DMatrix::<f64>::zeros(n, m_max);
    let mut t = DMatrix::<f64>::zeros(m_max + b, m_max + b);
    // start block: Op applied to a random block, M-orthonormalised
    let w0 = op(&rng.block(n, b));
    let (q, mq, _) = orthonormalize(m, &v, &mv, 0, w0, b, &mut rng);
    let mut m_cur = q.ncols();
    v.columns_mut(0, m_cur).copy_from(&q);
    mv.columns_mut(0, m_cur).copy_from(&mq);
    let mut m0 = 0;
    let mut last_residual = f64::INFINITY;
    let mut check = 0usize;
    loop {
        let bl = m_cur - m0;
        let w = op(&v.columns(m0, bl).into_owned());
        let (w, mw, coef) = reorthogonalize(m, &v, &mv, m_cur, w);
        t.view_mut((0, m0), (m_cur, bl)).copy_from(&coef);
        let exact = m_cur == n;
        let keep = bl.min(n - m_cur);
        let (q, mq, r) = if exact {
            (
                DMatrix::zeros(n, 0),
                DMatrix::zeros(n, 0),
                DMatrix::zeros(0, bl),
            )
        } else {
            orthonormalize_block(m, &v, &mv, m_cur, w, mw, keep, &mut rng)
        };
        t.view_mut((m_cur, m0), (r.nrows(), bl)).copy_from(&r);
        check += 1;
        let full = exact || m_cur + q.ncols() > m_max;
        // a truncated last block (keep < bl) has an incomplete R: wait for the
        // exact step that follows it
        if m_cur >= n_modes && (exact || keep == bl) && (check % 2 == 0 || full) {
            // the upper triangle of T_m holds the Gram-Schmidt coefficients
            // V^T M Op V (complete); the lower one only the R factors
            let sym = DMatrix::from_fn(m_cur, m_cur, |i, j| t[(i.min(j), i.max(j))]);
            let eig = SymmetricEigen::new(sym);
            let mut order: Vec<usize> = (0..m_cur).collect();
            order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
            let mut worst = 0.0f64;
            for &i in order.iter().take(n_modes) {
                let mu = eig.eigenvalues[i];
                let y_last = eig.eigenvectors.view((m0, i), (bl, 1));
                let res = if r.nrows() == 0 {
                    0.0
                } else {
                    (&r * y_last).norm()
                };
                worst = worst.max(if mu > 0.0 { res / mu } else { f64::INFINITY });
            }
            last_residual = worst;
            if worst <= LANCZOS_RTOL {
                let mut y = DMatrix::zeros(m_cur, n_modes);
                let mut mus = Vec::with_capacity(n_modes);
                for (c, &i) in order.iter().take(n_modes).enumerate() {
                    y.set_column(c, &eig.eigenvectors.column(i));
                    mus.push(eig.eigenvalues[i]);
                }
                let x = v.columns(0, m_cur) * y;
                return finish(m, k, factor, sigma, &mus, x, m_cur, name);
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
        let nq = q.ncols();
        v.columns_mut(m_cur, nq).copy_from(&q);
        mv.columns_mut(m_cur, nq).copy_from(&mq);
        m0 = m_cur;
        m_cur += nq;
    }
}

/// Two classical Gram-Schmidt passes of `w` against the first `m_cur` columns
/// of the `M`-orthonormal `v` (`mv = M v`): the orthogonalised `w`, `M w` and the
/// summed coefficients `V^T M w`.
fn reorthogonalize(
    m: &SparseMatrix,
    v: &DMatrix<f64>,
    mv: &DMatrix<f64>,
    m_cur: usize,
    mut w: DMatrix<f64>,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let vv = v.columns(0, m_cur);
    let mvv = mv.columns(0, m_cur);
    let mut coef = DMatrix::zeros(m_cur, w.ncols());
    for _ in 0..2 {
        // M w afresh each pass: updating it as M w - (M V) c would lose the small
        // remainder to cancellation once the Krylov space has converged
        let c = mvv.tr_mul(&w);
        w -= &vv * &c;
        coef += c;
    }
    let mw = sparse_mul(m, &w);
    (w, mw, coef)
}

/// `M`-orthonormalises `w` (already orthogonal to `v[.., ..m_cur]`) by modified
/// Gram-Schmidt into at most `keep` columns, `w[.., ..keep] = Q R` (`R` is
/// `keep x w.ncols()`); a direction that vanishes (relative `1e-10`) is replaced
/// by a random one orthogonal to the basis, with a zero factor.
#[allow(clippy::too_many_arguments)]
fn orthonormalize_block(
    m: &SparseMatrix,
    v: &DMatrix<f64>,
    mv: &DMatrix<f64>,
    m_cur: usize,
    mut w: DMatrix<f64>,
    mut mw: DMatrix<f64>,
    keep: usize,
    rng: &mut Xorshift,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let bl = w.ncols();
    let mut r = DMatrix::zeros(keep, bl);
    for c in 0..keep {
        let before = w.column(c).dot(&mw.column(c)).max(0.0).sqrt();
        for _ in 0..2 {
            // coefficients against the normalised columns, M w_d known exactly
            let s = mw.columns(0, c).tr_mul(&w.column(c));
            let upd = w.columns(0, c) * &s;
            w.column_mut(c).axpy(-1.0, &upd, 1.0);
            for d in 0..c {
                r[(d, c)] += s[d];
            }
        }
        let wc = w.column(c).into_owned();
        let mwc = sparse_mul(m, &DMatrix::from_column_slice(wc.len(), 1, wc.as_slice()));
        let norm = wc.dot(&mwc.column(0)).max(0.0).sqrt();
        if norm > 1e-10 * before && norm > 0.0 {
            w.column_mut(c).scale_mut(1.0 / norm);
            mw.set_column(c, &(mwc.column(0) / norm));
            r[(c, c)] = norm;
        } else {
            // an invariant subspace: continue with a fresh direction
            let fresh = rng.block(w.nrows(), 1);
            let (f, _, _) = reorthogonalize(m, v, mv, m_cur, fresh);
            let (f, mf) = reorthogonalize_local(m, &w, c, f);
            let norm = f.column(0).dot(&mf.column(0)).max(0.0).sqrt();
            w.set_column(c, &(f.column(0) / norm));
            mw.set_column(c, &(mf.column(0) / norm));
        }
    }
    (
        w.columns(0, keep).into_owned(),
        mw.columns(0, keep).into_owned(),
        r,
    )
}

/// Two Gram-Schmidt passes of the column `f` against the first `c` columns of
/// the `M`-orthonormal block `w`.
fn reorthogonalize_local(
    m: &SparseMatrix,
    w: &DMatrix<f64>,
    c: usize,
    mut f: DMatrix<f64>,
) -> (DMatrix<f64>, DMatrix<f64>) {
    for _ in 0..2 {
        let mf = sparse_mul(m, &f);
        let s = w.columns(0, c).tr_mul(&mf);
        f -= w.columns(0, c) * s;
    }
    let mf = sparse_mul(m, &f);
    (f, mf)
}

/// The first block of the basis: `w` orthogonalised against `v[.., ..m_cur]` and
/// `M`-orthonormalised (`b` columns).
fn orthonormalize(
    m: &SparseMatrix,
    v: &DMatrix<f64>,
    mv: &DMatrix<f64>,
    m_cur: usize,
    w: DMatrix<f64>,
    b: usize,
    rng: &mut Xorshift,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let (w, mw, _) = reorthogonalize(m, v, mv, m_cur, w);
    orthonormalize_block(m, v, mv, m_cur, w, mw, b, rng)
}

/// Ritz vectors to eigenpairs: `lambda = sigma + 1/mu`, sign convention, the
/// verified residuals (module docs).
#[allow(clippy::too_many_arguments)]
fn finish(
    m: &SparseMatrix,
    k: &SparseMatrix,
    factor: &SparseCholesky,
    sigma: f64,
    mus: &[f64],
    mut x: DMatrix<f64>,
    basis: usize,
    name: &'static str,
) -> Result<SparseModes> {
    let scale = lambda_scale(m, k);
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
    let (kx, mx) = (sparse_mul(k, &x), sparse_mul(m, &x));
    let mut opx = mx.clone();
    factor.solve_in_place(&mut opx);
    let mut inverse_residual = Vec::with_capacity(lambda.len());
    let mut residual = Vec::with_capacity(lambda.len());
    for (j, &l) in lambda.iter().enumerate() {
        let r = x.column(j) - opx.column(j) * (l - sigma);
        let mr = sparse_mul(m, &DMatrix::from_column_slice(r.len(), 1, r.as_slice()));
        let inv = r.dot(&mr.column(0)).max(0.0).sqrt();
        // a zero eigenvalue (|lambda| <= 1e-12 lambda_scale: a rigid-body mode, or
        // with sigma = 0 a singular K that passed the factorisation by rounding)
        // is left to the caller; its residual is rounding-dominated
        let zero = l.abs() <= 1e-12 * scale;
        // a shifted factorisation (rigid-body modes) is as ill-conditioned as
        // lambda_scale / |sigma|: its rounding floor
        let bound = if sigma == 0.0 {
            RESIDUAL_RTOL
        } else {
            RESIDUAL_RTOL.max(64.0 * f64::EPSILON * scale / sigma.abs())
        };
        if !(inv <= bound || zero) {
            return Err(StructureError::EigenNotConverged {
                name,
                requested: mus.len(),
                basis,
                residual: inv,
            });
        }
        inverse_residual.push(inv);
        let kn = kx.column(j).norm();
        residual.push(if zero || kn == 0.0 {
            0.0
        } else {
            (kx.column(j) - mx.column(j) * l).norm() / kn
        });
    }
    Ok(SparseModes {
        lambda,
        shapes: x,
        inverse_residual,
        residual,
        basis,
    })
}

/// The `n_modes` lowest modes of `K phi = omega^2 M phi` of a sparse model
/// (`M` SPD, `K` positive semi-definite), as [`super::modal::modal_analysis`]:
/// `omega` ascending [rad/s], rigid-body modes (`|lambda| <= 1e-12 lambda_scale`)
/// exactly zero, mass-normalised shapes. `K` itself is factorised when it is
/// positive definite (shift 0, the most accurate form); otherwise the shift
/// `sigma = -s`, `s = 1e-8 lambda_scale * 10^j`, `j = 0..12`, is the first with
/// `K + s M` positive definite. A clearly negative eigenvalue is
/// [`StructureError::NegativeEigenvalue`]; no positive definite `K + s M` at all
/// reports the bound `lambda < -s_max`.
pub fn sparse_modal(
    m: &SparseMatrix,
    k: &SparseMatrix,
    n_modes: usize,
    name: &'static str,
) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let scale = lambda_scale(m, k);
    let mut shift = 0.0;
    let mut factor = SparseCholesky::new(k);
    let mut j = 0;
    while factor.is_none() {
        if j > 12 || !(scale > 0.0) {
            return Err(StructureError::NegativeEigenvalue {
                index: 0,
                lambda: -shift,
            });
        }
        shift = 1e-8 * scale * 10f64.powi(j);
        factor = SparseCholesky::new(&sparse_add(1.0, k, shift, m));
        j += 1;
    }
    let factor = factor.expect("factorised");
    let modes = lanczos(m, k, &factor, -shift, n_modes, name)?;
    let mut omega = Vec::with_capacity(n_modes);
    for (c, &l) in modes.lambda.iter().enumerate() {
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
    Ok((omega, modes.shapes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::modal::generalized_eigen;
    use crate::structure::{BeamSpec, BoundaryCondition};

    #[test]
    fn triplets_sum_duplicates_and_dense_round_trips() {
        let a = sparse_from_triplets(2, &[(0, 0, 1.0), (1, 0, 2.0), (0, 0, 3.0)]).unwrap();
        let d = sparse_to_dense(&a);
        assert_eq!(d, DMatrix::from_row_slice(2, 2, &[4.0, 0.0, 2.0, 0.0]));
        assert_eq!(asymmetry(&a), (2.0, 4.0));
        assert_eq!(sparse_to_dense(&sparse_from_dense(&d)), d);
        assert!(sparse_from_triplets(2, &[(2, 0, 1.0)]).is_none());
        let x = DMatrix::from_row_slice(2, 1, &[1.0, -1.0]);
        assert_eq!(sparse_mul(&a, &x), &d * &x);
        assert_eq!(diagonal(&a), vec![4.0, 0.0]);
    }

    fn beam(n_nodes: usize, boundary: BoundaryCondition) -> (SparseMatrix, SparseMatrix) {
        let b = BeamSpec {
            n_nodes,
            boundary,
            ..BeamSpec::paper()
        }
        .assemble()
        .unwrap();
        (
            sparse_from_dense(&b.model.mass),
            sparse_from_dense(&b.model.stiffness),
        )
    }

    #[test]
    fn lanczos_matches_the_dense_eigensolver() {
        for (nodes, bc) in [
            (61, BoundaryCondition::ClampedFree),
            (6, BoundaryCondition::ClampedFree),
            (41, BoundaryCondition::FreeFree),
        ] {
            let (m, k) = beam(nodes, bc);
            let n = m.nrows();
            let nev = 8.min(n);
            let (wd, pd) =
                generalized_eigen(&sparse_to_dense(&m), &sparse_to_dense(&k), nev, "n").unwrap();
            let (ws, ps) = sparse_modal(&m, &k, nev, "n").unwrap();
            for j in 0..nev {
                if wd[j] == 0.0 {
                    assert_eq!(ws[j], 0.0, "{nodes} nodes: rigid-body mode {j}");
                    continue;
                }
                let rel = (ws[j] - wd[j]).abs() / wd[j];
                assert!(
                    rel < 1e-9,
                    "{nodes} nodes, mode {j}: {} vs {}",
                    ws[j],
                    wd[j]
                );
                let e = (ps.column(j) - pd.column(j)).amax() / pd.column(j).amax();
                assert!(e < 1e-7, "{nodes} nodes, shape {j}: {e:e}");
            }
        }
    }

    #[test]
    fn indefinite_stiffness_and_bad_counts_are_errors() {
        let m = sparse_from_triplets(2, &[(0, 0, 1.0), (1, 1, 1.0)]).unwrap();
        let k = sparse_from_triplets(2, &[(0, 0, -3.0), (1, 1, 2.0)]).unwrap();
        assert!(matches!(
            sparse_modal(&m, &k, 1, "n"),
            Err(StructureError::NegativeEigenvalue { lambda, .. }) if (lambda + 3.0).abs() < 1e-9
        ));
        let k = sparse_from_triplets(2, &[(0, 0, 1.0), (1, 1, 2.0)]).unwrap();
        assert!(matches!(
            sparse_modal(&m, &k, 3, "n"),
            Err(StructureError::ModeCount { requested: 3, .. })
        ));
        let (w, _) = sparse_modal(&m, &k, 2, "n").unwrap();
        assert!((w[0] - 1.0).abs() < 1e-14 && (w[1] - 2f64.sqrt()).abs() < 1e-14);
    }
}
