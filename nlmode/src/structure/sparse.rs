//! Sparse FE matrices for large models (the `craig-bampton` path of a matrices
//! structure, [`super::matrices::matrix_structure_sparse`]): compressed-column
//! storage (faer), products with dense blocks, and the sparse Cholesky
//! factorisation `A = L L^T` (faer's symbolic factorisation after a
//! fill-reducing ordering, [`super::ordering`]: AMD or nested dissection; the
//! numeric one subtree-parallel in faer's supernodal layout,
//! [`super::supernodal`], or faer's own where the factor is simplicial) with a memory estimate from the
//! symbolic factorisation taken before any numeric work
//! ([`MemoryEstimate`], [`SparseOptions::memory_limit_bytes`]).
//!
//! The eigensolver on top of the factorisation is [`super::lanczos`].
//!
//! Memory of the large-model path (`n` DOFs, `nnz(A)` stored entries of the
//! full symmetric matrices, `nnz(L)` of the factor, `m` the Lanczos basis,
//! `r` the reduced size): `M`, `K` (and a `C` file) `16 nnz(A)` bytes each, the
//! factor `8 nnz(L)` plus faer's workspace, the basis `16 n m` (`8 n m` from
//! [`super::lanczos::LEAN_BASIS_MIN_DOF`] DOFs on) and dense blocks
//! `8 n r` a few times. One factorisation of `K`, ordered with the
//! Craig-Bampton masters last, serves the full model and the fixed-interface
//! problem ([`SymbolicFactor::with_last`]); only when `K` is singular
//! (rigid-body modes) is `K_ii` factorised separately, from the values of `K`
//! with the masters decoupled (`8 nnz(A)`, on `K`'s pattern:
//! [`SparseCholesky::with_values`]). Nothing of size `n x n` is formed; one
//! factorisation is alive at a time.
pub use super::ordering::Ordering;
pub(crate) use super::product::mul_into;
pub use super::product::{sym_mul, sym_mul_par};
use super::supernodal::SolvePlan;
use super::{Result, StructureError};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMat, SparseColMatRef, Triplet};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::DMatrix;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A sparse square matrix in compressed-column storage (faer).
pub type SparseMatrix = SparseColMat<usize, f64>;

/// A factorisation that reproduces `z` from `A z` worse than this (relative, max
/// norm) counts as singular: a regular FE stiffness with `cond(K) ~ 1e10` does it
/// to about `1e-8`, a singular one that passed by rounding misses by `O(1)` or more.
pub const SINGULAR_PROBE_RTOL: f64 = 1e-3;

pub use super::lanczos::{
    lambda_scale, lanczos, sparse_modal, SparseModes, LANCZOS_RTOL, MAX_SPARSE_MODES, RESIDUAL_RTOL,
};

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
///
/// Each stored `a_ij` below the diagonal is compared with `a_ji`, found by a
/// binary search in column `i` (a missing entry is 0), and each stored
/// `a_ji` above it whose `a_ij` is missing counts whole: no transpose is
/// formed (at 10^6 DOFs it took 1.3 GB and most of the check's time), and the
/// columns are shared among rayon's threads. Columns whose rows are not
/// strictly ascending (faer allows them) are compared through the transpose.
pub fn asymmetry(a: &SparseMatrix) -> (f64, f64) {
    use rayon::prelude::*;
    let a = a.as_ref();
    let (sym, val) = (a.symbolic(), a.val());
    let rows = sym.row_idx();
    let col = |c: usize| &rows[sym.col_range(c)];
    if !(0..a.ncols()).all(|c| col(c).is_sorted_by(|p, q| p < q)) {
        return asymmetry_by_transpose(a);
    }
    let find = |r: usize, c: usize| -> f64 {
        let range = sym.col_range(c);
        rows[range.clone()]
            .binary_search(&r)
            .map_or(0.0, |p| val[range.start + p])
    };
    (0..a.ncols())
        .into_par_iter()
        .map(|c| {
            let (mut asym, mut scale) = (0.0f64, 0.0f64);
            for p in sym.col_range(c) {
                let (r, v) = (rows[p], val[p]);
                scale = scale.max(v.abs());
                if r > c {
                    // a_rc against a_cr (column r)
                    asym = asym.max((v - find(c, r)).abs());
                } else if r < c && col(r).binary_search(&c).is_err() {
                    // a_rc above the diagonal with no a_cr stored
                    asym = asym.max(v.abs());
                }
            }
            (asym, scale)
        })
        .reduce(|| (0.0, 0.0), |x, y| (x.0.max(y.0), x.1.max(y.1)))
}

/// [`asymmetry`] through `A^T` in compressed-column storage, the columns of
/// `A` and `A^T` merged.
fn asymmetry_by_transpose(a: SparseColMatRef<'_, usize, f64>) -> (f64, f64) {
    let at = a
        .transpose()
        .to_col_major()
        .expect("transpose of a sparse matrix");
    let at = at.as_ref();
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
    let a = a.as_ref();
    let (sym, val) = (a.symbolic(), a.val());
    let rows = sym.row_idx();
    (0..a.nrows().min(a.ncols()))
        .map(|c| {
            let range = sym.col_range(c);
            let col = &rows[range.clone()];
            if col.is_sorted_by(|p, q| p < q) {
                // rows strictly ascending (as faer builds them): one search
                col.binary_search(&c).map_or(0.0, |p| val[range.start + p])
            } else {
                col.iter()
                    .zip(&val[range])
                    .filter(|(r, _)| **r == c)
                    .map(|(_, v)| v)
                    .sum()
            }
        })
        .collect()
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

/// Deterministic pseudo-random numbers in `(-1, 1)` (xorshift64*), for start
/// blocks, deflated directions and the singularity probe: reproducible results.
pub(crate) struct Xorshift(pub(crate) u64);

impl Xorshift {
    pub(crate) fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let u = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
        2.0 * (u as f64 / (1u64 << 53) as f64) - 1.0
    }
    pub(crate) fn block(&mut self, n: usize, b: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, b, |_, _| self.next())
    }
}

/// A stage of the large-model path, for progress reports and [`StageTimings`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Symmetry, finite values, diagonals.
    Check,
    /// Fill-reducing ordering and symbolic factorisation (and the memory estimate).
    Order,
    /// Numeric factorisation of `K` (or `K - sigma M`).
    Factor,
    /// The fixed-interface modes and the full model's lowest modes (Lanczos,
    /// or subspace iteration from the Craig-Bampton basis).
    Eigen,
    /// Craig-Bampton constraint modes by sparse solves.
    ConstraintModes,
    /// The reduced matrices `T^T A T`.
    Project,
}

impl Stage {
    /// The stage's name as in [`StageTimings`]' keys (`order` for `order_s`).
    pub fn name(self) -> &'static str {
        match self {
            Stage::Check => "check",
            Stage::Order => "order",
            Stage::Factor => "factor",
            Stage::Eigen => "eigen",
            Stage::ConstraintModes => "constraint_modes",
            Stage::Project => "project",
        }
    }
}

/// Called at the end of each stage with the stage and its wall time.
pub type Progress = Arc<dyn Fn(Stage, Duration) + Send + Sync>;

/// Options of the large-model (sparse) path.
#[derive(Clone, Default)]
pub struct SparseOptions {
    /// Refuse, before any numeric factorisation, a model whose
    /// [`MemoryEstimate::total_bytes`] exceeds this ([`StructureError::MemoryLimit`]);
    /// `None`: no limit (the caller, e.g. the host, passes 75 % of the
    /// available memory).
    pub memory_limit_bytes: Option<u64>,
    /// Threads of the factorisation, the solves and the products: 0 = rayon's
    /// pool, 1 = sequential.
    pub threads: usize,
    /// Called after each stage (e.g. a progress bar).
    pub progress: Option<Progress>,
    /// The fill-reducing ordering of the factorisations of `K` and `K_ii`.
    pub ordering: Ordering,
    /// The last symbolic factorisation made by [`SymbolicFactor::with_options`],
    /// reused for a matrix of the same pattern (`K` with the masters decoupled
    /// is ordered once, with `K`).
    pub symbolic_cache: SymbolicCache,
}

/// See [`SparseOptions::symbolic_cache`]: the pattern's fingerprint and its
/// symbolic factorisation.
#[derive(Clone, Default)]
pub struct SymbolicCache(Arc<Mutex<Option<(u64, SymbolicFactor)>>>);

impl std::fmt::Debug for SparseOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseOptions")
            .field("memory_limit_bytes", &self.memory_limit_bytes)
            .field("threads", &self.threads)
            .field("progress", &self.progress.is_some())
            .field("ordering", &self.ordering)
            .finish()
    }
}

impl SparseOptions {
    /// faer's parallelism of these options.
    pub fn par(&self) -> Par {
        match self.threads {
            1 => Par::Seq,
            t => Par::rayon(t),
        }
    }
}

/// Wall times [s] of the stages of the large-model path ([`Stage`]; `read` is
/// the caller's), the factor's size and the memory estimate.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StageTimings {
    pub check_s: f64,
    pub order_s: f64,
    pub factor_s: f64,
    pub eigen_s: f64,
    pub constraint_modes_s: f64,
    pub project_s: f64,
    /// Non-zeros of the Cholesky factor (after the ordering).
    pub factor_nnz: usize,
    /// [`MemoryEstimate::total_bytes`] of the model.
    pub memory_estimate_bytes: u64,
    /// Vectors `K^{-1} M` was applied to: full model (its Lanczos basis, or
    /// the subspace iteration's columns times its steps), fixed-interface modes.
    pub lanczos_basis: Vec<usize>,
    /// The full model's subspace iteration ([`super::subspace::SubspaceStats`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub subspace: Option<super::subspace::SubspaceStats>,
    /// Reading the matrix files (the caller's, e.g. the host's; 0 when the
    /// matrices came from memory).
    #[serde(default)]
    pub read_s: f64,
    /// The fill-reducing ordering used ([`Ordering::name`], `auto` resolved).
    #[serde(default)]
    pub ordering: String,
    /// Each stage in order with its wall and CPU time and the process' peak
    /// memory after it, where the caller measures them (the host: from
    /// `read` on; empty otherwise).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stages: Vec<StageSample>,
}

/// One stage of [`StageTimings::stages`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StageSample {
    /// [`Stage::name`], or `read`.
    pub stage: String,
    pub wall_s: f64,
    /// CPU time of the process over the stage (all threads) [s].
    pub cpu_s: f64,
    /// Peak resident memory of the process at the end of the stage [bytes].
    pub peak_rss_bytes: u64,
}

impl StageTimings {
    /// Adds `dt` to the stage's time and reports it to `progress`.
    pub fn add(&mut self, stage: Stage, dt: Duration, progress: &Option<Progress>) {
        let s = dt.as_secs_f64();
        match stage {
            Stage::Check => self.check_s += s,
            Stage::Order => self.order_s += s,
            Stage::Factor => self.factor_s += s,
            Stage::Eigen => self.eigen_s += s,
            Stage::ConstraintModes => self.constraint_modes_s += s,
            Stage::Project => self.project_s += s,
        }
        if let Some(p) = progress {
            p(stage, dt);
        }
    }

    /// Runs `f` as the stage `stage` (timed, reported).
    pub fn time<T>(&mut self, stage: Stage, opts: &SparseOptions, f: impl FnOnce() -> T) -> T {
        let t0 = Instant::now();
        let out = f();
        self.add(stage, t0.elapsed(), &opts.progress);
        out
    }
}

/// The symbolic Cholesky factorisation of a sparsity pattern (lower triangle
/// read): the fill-reducing ordering ([`Ordering`]), the elimination tree and
/// the supernodal structure. Shared by every matrix of that pattern.
#[derive(Debug, Clone)]
pub struct SymbolicFactor {
    inner: Arc<SymbolicCholesky<usize>>,
    ordering: Ordering,
    /// DOFs ordered last, in this order ([`SymbolicFactor::with_last`]):
    /// the factor's leading block is then the factor of the matrix without
    /// them ([`SparseCholesky::solve_leading_in_place`]).
    last: Arc<[usize]>,
    /// The parallel solves' split of a supernodal factor ([`SolvePlan`]).
    pub(crate) plan: Option<Arc<SolvePlan>>,
}

/// A fingerprint of a sparsity pattern (size, column pointers, row indices).
fn pattern_fingerprint(a: &SparseMatrix) -> u64 {
    use std::hash::{Hash, Hasher};
    let sym = a.symbolic();
    let mut h = std::collections::hash_map::DefaultHasher::new();
    (sym.nrows(), sym.ncols()).hash(&mut h);
    for c in 0..sym.ncols() {
        sym.row_idx()[sym.col_range(c)].hash(&mut h);
    }
    h.finish()
}

impl SymbolicFactor {
    /// The symbolic factorisation of `a`'s pattern with faer's AMD ordering;
    /// `None` when faer runs out of memory or index range.
    pub fn new(a: &SparseMatrix) -> Option<Self> {
        Self::with_ordering(a, Ordering::Amd)
    }

    /// As [`SymbolicFactor::new`] with the ordering `ordering` (`auto`
    /// resolved by the size, [`Ordering::resolve`]). Where the nested
    /// dissection fails (METIS reports an error, or is not built in) the
    /// ordering is AMD, and [`SymbolicFactor::ordering`] says so.
    pub fn with_ordering(a: &SparseMatrix, ordering: Ordering) -> Option<Self> {
        Self::with_last(a, ordering, &[])
    }

    /// As [`SymbolicFactor::with_ordering`] with the DOFs `last` moved to the
    /// end of the fill-reducing permutation (in this order; the rest keeps
    /// its order). The factor `L` of `A` is then `[L_ii 0; L_bi L_bb]` with
    /// `L_ii` the Cholesky factor of `A` without the rows and columns `last`
    /// (Cholesky's column `j` depends on the columns before it only): one
    /// numeric factorisation solves with `A` and with `A_ii`
    /// ([`SparseCholesky::solve_leading_in_place`]). Moving a few DOFs to the
    /// end adds at most their rows of `L` (a path of the elimination tree
    /// each) to the fill.
    pub fn with_last(a: &SparseMatrix, ordering: Ordering, last: &[usize]) -> Option<Self> {
        let params = CholeskySymbolicParams {
            // supernodal unless the factor is very sparse (faer's own choice)
            supernodal_flop_ratio_threshold: SupernodalThreshold::AUTO,
            ..Default::default()
        };
        let mut ordering = ordering.resolve(a.nrows());
        let nd = match ordering {
            Ordering::NestedDissection => super::ordering::nested_dissection(a),
            _ => None,
        };
        if nd.is_none() {
            ordering = Ordering::Amd;
        }
        let nd = match nd {
            Some(fwd) if !last.is_empty() => Some(move_last(fwd, last)?),
            None if !last.is_empty() => {
                // faer's AMD permutation, then the DOFs `last` moved to the end
                let amd = factorize_symbolic_cholesky(
                    a.symbolic(),
                    Side::Lower,
                    SymmetricOrdering::Amd,
                    params,
                )
                .ok()?;
                let fwd = match amd.perm() {
                    Some(p) => p.arrays().0.to_vec(),
                    None => (0..a.nrows()).collect(),
                };
                Some(move_last(fwd, last)?)
            }
            nd => nd,
        };
        let inner = match nd {
            Some(fwd) => {
                let mut inv = vec![0usize; fwd.len()];
                for (new, &old) in fwd.iter().enumerate() {
                    inv[old] = new;
                }
                let perm = faer::perm::PermRef::new_checked(&fwd, &inv, fwd.len());
                factorize_symbolic_cholesky(
                    a.symbolic(),
                    Side::Lower,
                    SymmetricOrdering::Custom(perm),
                    params,
                )
            }
            None => factorize_symbolic_cholesky(
                a.symbolic(),
                Side::Lower,
                SymmetricOrdering::Amd,
                params,
            ),
        }
        .ok()?;
        let plan = match inner.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => SolvePlan::new(s).map(Arc::new),
            SymbolicCholeskyRaw::Simplicial(_) => None,
        };
        Some(Self {
            inner: Arc::new(inner),
            ordering,
            last: last.into(),
            plan,
        })
    }

    /// The DOFs ordered last ([`SymbolicFactor::with_last`]; empty otherwise).
    pub fn last(&self) -> &[usize] {
        &self.last
    }

    /// As [`SymbolicFactor::with_ordering`] with `opts.ordering`, reusing the
    /// symbolic factorisation in `opts.symbolic_cache` when `a` has its
    /// pattern (and storing the new one there otherwise).
    pub fn with_options(a: &SparseMatrix, opts: &SparseOptions) -> Option<Self> {
        Self::with_options_last(a, opts, &[])
    }

    /// As [`SymbolicFactor::with_options`] with the DOFs `last` ordered last
    /// ([`SymbolicFactor::with_last`]); a cached factorisation serves when
    /// `last` is empty (any ordering does) or its own.
    pub fn with_options_last(
        a: &SparseMatrix,
        opts: &SparseOptions,
        last: &[usize],
    ) -> Option<Self> {
        let key = pattern_fingerprint(a);
        let mut cache = opts
            .symbolic_cache
            .0
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        if let Some((k, s)) = cache.as_ref() {
            if *k == key && s.inner.nrows() == a.nrows() && (last.is_empty() || *s.last == *last) {
                return Some(s.clone());
            }
        }
        *cache = None;
        let s = Self::with_last(a, opts.ordering, last)?;
        *cache = Some((key, s.clone()));
        Some(s)
    }

    /// The ordering used (`auto` resolved).
    pub fn ordering(&self) -> Ordering {
        self.ordering
    }

    /// Non-zeros of the factor `L` (supernodal: with the dense supernode blocks).
    pub fn nnz(&self) -> usize {
        self.inner.len_val()
    }

    /// Bytes of the factor: values, row indices and the permutation.
    pub fn factor_bytes(&self) -> u64 {
        let idx = match self.inner.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => s.row_idx().len() + s.col_ptr().len(),
            SymbolicCholeskyRaw::Supernodal(s) => {
                s.row_idx().len() + s.col_ptr_for_row_idx().len() + s.col_ptr_for_val().len()
            }
        };
        8 * (self.nnz() + idx + 2 * self.inner.nrows()) as u64
    }

    /// Bytes of the numeric factorisation's workspace: faer's (a permuted copy
    /// of the matrix, `16 nnz(A)`, and the supernodal update blocks), an upper
    /// bound of the subtree-parallel one's ([`super::supernodal`]: `A` read in
    /// place, per thread `8 n` and one update block).
    pub fn workspace_bytes(&self, par: Par) -> u64 {
        self.inner
            .factorize_numeric_llt_scratch::<f64>(par, Default::default())
            .size_bytes() as u64
    }
}

/// The permutation `fwd` (new to old) with the indices `last` moved to its
/// end in that order; `None` if one is out of range or repeated.
fn move_last(fwd: Vec<usize>, last: &[usize]) -> Option<Vec<usize>> {
    let mut is_last = vec![false; fwd.len()];
    for &d in last {
        if d >= fwd.len() || is_last[d] {
            return None;
        }
        is_last[d] = true;
    }
    let mut out: Vec<usize> = fwd.into_iter().filter(|&old| !is_last[old]).collect();
    out.extend_from_slice(last);
    Some(out)
}

/// Whether `a` and `b` store the same pattern (then one [`SymbolicFactor`] serves both).
pub fn same_pattern(a: &SparseMatrix, b: &SparseMatrix) -> bool {
    let (sa, sb) = (a.symbolic(), b.symbolic());
    sa.nrows() == sb.nrows()
        && sa.col_ptr() == sb.col_ptr()
        && sa.col_nnz() == sb.col_nnz()
        && sa.row_idx() == sb.row_idx()
}

/// Whether `a` is diagonal (a lumped mass matrix).
pub fn is_diagonal(a: &SparseMatrix) -> bool {
    let mut diag = true;
    for_each_entry(a, |r, c, v| diag &= r == c || v == 0.0);
    diag
}

/// Sparse Cholesky factorisation `A = L L^T` of a symmetric positive definite
/// matrix stored in full (both triangles, as the products and the singular
/// probe read it): a supernodal factor by [`super::supernodal`] (the columns
/// of `A` read), a simplicial one by faer (its lower triangle read).
pub struct SparseCholesky {
    symbolic: SymbolicFactor,
    values: Vec<f64>,
    par: Par,
}

impl std::fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SparseCholesky(nnz(L) = {})", self.values.len())
    }
}

impl SparseCholesky {
    /// `None` when `a` is not (numerically) positive definite: the factorisation
    /// fails, or it does not reproduce a pseudo-random `z` from `A z` to
    /// [`SINGULAR_PROBE_RTOL`] (a singular `A`, e.g. a stiffness with rigid-body
    /// modes, can pass the factorisation with rounding-size pivots).
    pub fn new(a: &SparseMatrix) -> Option<Self> {
        Self::with_symbolic(&SymbolicFactor::new(a)?, a, Par::Seq)
    }

    /// As [`SparseCholesky::new`] with the symbolic factorisation of `a`'s
    /// pattern and the parallelism `par` (of the factorisation and the solves).
    pub fn with_symbolic(symbolic: &SymbolicFactor, a: &SparseMatrix, par: Par) -> Option<Self> {
        Self::factor(symbolic, a.as_ref(), par)
    }

    /// As [`SparseCholesky::with_symbolic`] for the matrix of `pattern`'s
    /// sparsity pattern with the stored values `values` (in `pattern`'s
    /// order): a matrix that differs from another only in its values (`K`
    /// with the masters decoupled) is factorised without a copy of the
    /// pattern (at 10^6 DOFs of hexahedra, 0.65 GB of row indices).
    pub fn with_values(
        symbolic: &SymbolicFactor,
        pattern: &SparseMatrix,
        values: &[f64],
        par: Par,
    ) -> Option<Self> {
        if values.len() != pattern.val().len() {
            return None;
        }
        Self::factor(
            symbolic,
            SparseColMatRef::new(pattern.symbolic(), values),
            par,
        )
    }

    fn factor(
        symbolic: &SymbolicFactor,
        a: SparseColMatRef<'_, usize, f64>,
        par: Par,
    ) -> Option<Self> {
        let sym = &symbolic.inner;
        if sym.nrows() != a.nrows() {
            return None;
        }
        let values = match symbolic.plan.as_deref() {
            Some(plan) => Self::planned_values(symbolic, plan, a, par)?,
            None => Self::faer_values(symbolic, a, par)?,
        };
        Self::probed(symbolic, values, a, par)
    }

    /// A zeroed factor of `symbolic`'s layout (`None` out of memory), written
    /// by the threads of `par`: the first touch of its pages is most of the
    /// cost (0.18 s for the 0.34 GB factor of 10^5 DOFs on one thread).
    fn zeroed(symbolic: &SymbolicFactor, par: Par) -> Option<Vec<f64>> {
        let len = symbolic.inner.len_val();
        let mut values = Vec::new();
        values.try_reserve_exact(len).ok()?;
        if par.degree() > 1 {
            use rayon::prelude::*;
            values.par_extend(rayon::iter::repeat_n(0.0, len));
        } else {
            values.resize(len, 0.0);
        }
        Some(values)
    }

    /// The factor's values by the subtree-parallel factorisation of
    /// [`SolvePlan::factorize`] (a supernodal factor with a solve plan).
    fn planned_values(
        symbolic: &SymbolicFactor,
        plan: &SolvePlan,
        a: SparseColMatRef<'_, usize, f64>,
        par: Par,
    ) -> Option<Vec<f64>> {
        let sym = &symbolic.inner;
        let SymbolicCholeskyRaw::Supernodal(s) = sym.raw() else {
            return Self::faer_values(symbolic, a, par);
        };
        let mut values = Self::zeroed(symbolic, par)?;
        let identity: Vec<usize>;
        let perm = match sym.perm() {
            Some(p) => p.arrays(),
            None => {
                identity = (0..sym.nrows()).collect();
                (&identity[..], &identity[..])
            }
        };
        plan.factorize(s, perm, a, &mut values, par)
            .then_some(values)
    }

    /// The factor's values by faer's numeric factorisation (`None` when it
    /// fails: not positive definite, or out of memory).
    pub(crate) fn faer_values(
        symbolic: &SymbolicFactor,
        a: SparseColMatRef<'_, usize, f64>,
        par: Par,
    ) -> Option<Vec<f64>> {
        let sym = &symbolic.inner;
        let mut values = Self::zeroed(symbolic, par)?;
        let req = sym.factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let mut mem = MemBuffer::try_new(req).ok()?;
        sym.factorize_numeric_llt(
            &mut values,
            a,
            Side::Lower,
            Default::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .ok()?;
        Some(values)
    }

    /// The factor's values in faer's layout of its symbolic factorisation,
    /// with the strict upper triangles of the supernodes' diagonal blocks
    /// cleared (faer leaves its work there, the solves never read it).
    #[cfg(test)]
    pub(crate) fn lower_values(symbolic: &SymbolicFactor, values: &[f64]) -> Vec<f64> {
        let mut out = values.to_vec();
        if let SymbolicCholeskyRaw::Supernodal(s) = symbolic.inner.raw() {
            let cpv = s.col_ptr_for_val();
            for k in 0..s.n_supernodes() {
                let sc = s.supernode_end()[k] - s.supernode_begin()[k];
                let rows = sc + s.supernode(k).pattern().len();
                for c in 1..sc {
                    out[cpv[k] + c * rows..][..c].fill(0.0);
                }
            }
        }
        out
    }

    /// [`SparseCholesky::lower_values`] of this factor.
    #[cfg(test)]
    pub(crate) fn values(&self) -> Vec<f64> {
        Self::lower_values(&self.symbolic, &self.values)
    }

    /// The factor with `values`, if it reproduces a random `z` from `A z`
    /// ([`SINGULAR_PROBE_RTOL`]).
    fn probed(
        symbolic: &SymbolicFactor,
        values: Vec<f64>,
        a: SparseColMatRef<'_, usize, f64>,
        par: Par,
    ) -> Option<Self> {
        let f = Self {
            symbolic: symbolic.clone(),
            values,
            par,
        };
        let z = Xorshift(0x2545_f491_4f6c_dd1d).block(a.nrows(), 1);
        // A z (as `sym_mul`)
        let mut x = DMatrix::zeros(a.nrows(), 1);
        mul_into(a, z.as_slice(), x.as_mut_slice(), 1, Par::Seq);
        f.solve_in_place(&mut x);
        let err = (x - &z).amax() / z.amax();
        (err <= SINGULAR_PROBE_RTOL).then_some(f)
    }

    /// Solves `A X = B` in place (`B` overwritten by `X`).
    pub fn solve_in_place(&self, b: &mut DMatrix<f64>) {
        let (nr, nc) = b.shape();
        if self.solve_planned(b, nr) {
            return;
        }
        let sym = &self.symbolic.inner;
        let mut mem = MemBuffer::new(sym.solve_in_place_scratch::<f64>(nc, self.par));
        let view = MatMut::from_column_major_slice_mut(b.as_mut_slice(), nr, nc);
        LltRef::new(sym, &self.values).solve_in_place_with_conj(
            Conj::No,
            view,
            self.par,
            MemStack::new(&mut mem),
        );
    }

    /// The solve of a supernodal factor by its [`SolvePlan`] (the permuted
    /// rows from `zero_from` on zeroed between `L` and `L^T`); `false` (and
    /// `b` untouched) without a plan.
    fn solve_planned(&self, b: &mut DMatrix<f64>, zero_from: usize) -> bool {
        let sym = &self.symbolic.inner;
        let (Some(plan), SymbolicCholeskyRaw::Supernodal(s)) = (&self.symbolic.plan, sym.raw())
        else {
            return false;
        };
        let nc = b.ncols();
        // row i of the permuted system is row fwd[i] of b (no copy of fwd)
        let fwd = sym.perm().map(|p| p.arrays().0);
        let old = |i: usize| fwd.map_or(i, |f| f[i]);
        use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
        let llt = SupernodalLltRef::new(s, &self.values);
        let mut x = plan.gather(llt, nc, |i, out| {
            for (j, o) in out.iter_mut().enumerate() {
                *o = b[(old(i), j)];
            }
        });
        plan.solve(llt, &mut x, zero_from, self.par);
        plan.scatter(llt, &x, |i, vals| {
            for (j, v) in vals.iter().enumerate() {
                b[(old(i), j)] = *v;
            }
        });
        true
    }

    /// Solves `A_ii X_i = B_i` in place, `A_ii` the matrix without the DOFs
    /// ordered last ([`SymbolicFactor::with_last`]), from the leading block
    /// `L_ii` of the factor: `L z = P B`, the last rows of `z` set to zero,
    /// `L^T y = z`, `X = P^T y` (faer's triangular solves with `L` and
    /// `L^T`). The rows of the DOFs `last` of `X` are zero, those of `B` are
    /// not read. With no DOF ordered last this is [`Self::solve_in_place`].
    pub fn solve_leading_in_place(&self, b: &mut DMatrix<f64>) {
        use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
        use faer::sparse::linalg::triangular_solve;
        let (nr, nc) = b.shape();
        let sym = &self.symbolic.inner;
        let keep = nr - self.symbolic.last.len();
        if self.solve_planned(b, keep) {
            return;
        }
        let fwd: Vec<usize> = match sym.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..nr).collect(),
        };
        let mut x = DMatrix::from_fn(nr, nc, |i, j| b[(fwd[i], j)]);
        let mut mem = MemBuffer::new(sym.solve_in_place_scratch::<f64>(nc, self.par));
        let stack = MemStack::new(&mut mem);
        let mut view = MatMut::from_column_major_slice_mut(x.as_mut_slice(), nr, nc);
        let par = self.par;
        match sym.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => {
                let l = SparseColMatRef::new(s.factor(), &self.values);
                triangular_solve::solve_lower_triangular_in_place(l, Conj::No, view.as_mut(), par);
                view.as_mut().subrows_mut(keep, nr - keep).fill(0.0);
                triangular_solve::solve_lower_triangular_transpose_in_place(
                    l,
                    Conj::No,
                    view.as_mut(),
                    par,
                );
            }
            SymbolicCholeskyRaw::Supernodal(s) => {
                let l = SupernodalLltRef::new(s, &self.values);
                l.l_solve_with_conj(Conj::No, view.as_mut(), par, stack);
                view.as_mut().subrows_mut(keep, nr - keep).fill(0.0);
                l.l_transpose_solve_with_conj(Conj::No, view.as_mut(), par, stack);
            }
        }
        for j in 0..nc {
            for (i, &old) in fwd.iter().enumerate() {
                b[(old, j)] = x[(i, j)];
            }
        }
    }

    /// The symbolic factorisation (shared with other matrices of the pattern).
    pub fn symbolic(&self) -> &SymbolicFactor {
        &self.symbolic
    }
}

/// The memory of the large-model path of one model, from its symbolic
/// factorisation (module docs), in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryEstimate {
    pub ndof: usize,
    /// The sparse matrices held (`M`, `K`, a `C` file).
    pub matrices_bytes: u64,
    pub factor_nnz: usize,
    pub factor_bytes: u64,
    /// faer's workspace of the numeric factorisation.
    pub workspace_bytes: u64,
    /// The Lanczos basis at its bound and the dense `n x r` blocks.
    pub eigen_bytes: u64,
    pub total_bytes: u64,
}

/// Bytes of a sparse matrix (values and row indices, column pointers).
pub fn matrix_bytes(a: &SparseMatrix) -> u64 {
    (16 * a.compute_nnz() + 8 * (a.ncols() + 1)) as u64
}

impl MemoryEstimate {
    /// The estimate for the matrices `held`, the factorisation `symbolic`, a
    /// Lanczos basis of `basis` vectors and dense blocks of `reduced` columns.
    pub fn new(
        held: &[&SparseMatrix],
        symbolic: &SymbolicFactor,
        par: Par,
        basis: usize,
        reduced: usize,
    ) -> Self {
        let ndof = symbolic.inner.nrows();
        let matrices_bytes = held.iter().map(|a| matrix_bytes(a)).sum();
        let factor_bytes = symbolic.factor_bytes();
        let workspace_bytes = symbolic.workspace_bytes(par);
        // V and M V (V only from LEAN_BASIS_MIN_DOF on), the block products
        // and solves, T and three n x r blocks
        let per = if ndof < super::lanczos::LEAN_BASIS_MIN_DOF {
            2
        } else {
            1
        };
        let eigen_bytes = 8 * (ndof * (per * basis + 12 + 4 * reduced)) as u64;
        Self {
            ndof,
            matrices_bytes,
            factor_nnz: symbolic.nnz(),
            factor_bytes,
            workspace_bytes,
            eigen_bytes,
            total_bytes: matrices_bytes + factor_bytes + workspace_bytes + eigen_bytes,
        }
    }

    /// [`StructureError::MemoryLimit`] when the total exceeds `limit_bytes`.
    pub fn check(&self, limit_bytes: Option<u64>) -> Result<()> {
        match limit_bytes {
            Some(limit) if self.total_bytes > limit => Err(StructureError::MemoryLimit {
                ndof: self.ndof,
                factor_nnz: self.factor_nnz,
                needed_bytes: self.total_bytes,
                factor_bytes: self.factor_bytes,
                limit_bytes: limit,
            }),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
#[path = "sparse_tests.rs"]
mod tests;
