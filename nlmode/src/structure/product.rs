//! `A X` of a symmetric sparse matrix (compressed columns, faer's storage)
//! and a dense block `X` (column-major, nalgebra): the products with `M`, `K`
//! and `C` of the Lanczos and subspace iterations ([`super::lanczos`],
//! [`super::subspace`]) and of the Craig-Bampton projection
//! ([`super::craig_bampton`]).
//!
//! Hand-written instead of faer's `sparse_dense_matmul` (performance): faer's
//! kernel makes one pass over `A` per column of `X` and scatters into `A X`,
//! which made the products with `M` a quarter of `host nma`'s CPU time at 10^5
//! DOFs. Here `A` is symmetric (the structure's matrices are checked to be,
//! [`super::matrices::SYMMETRY_RTOL`]), so a stored column `j` is also row `j`
//! and `(A X)_j = sum_i a_ij X_i` is gathered row by row: one pass over `A`
//! serves a block of up to [`BLOCK`] columns (`X` transposed to rows for the
//! pass, so an entry reads one contiguous row of the block), the rows are
//! shared among the threads with no write shared, and each row is summed in
//! the stored order whatever the threads: the result does not depend on the
//! thread count. Strictly it is `A^T X`, which for a matrix symmetric only
//! within the tolerance differs from `A X` by that much (the factorisation
//! reads one triangle alone).
use super::sparse::SparseMatrix;
use faer::sparse::SparseColMatRef;
use faer::Par;
use nalgebra::DMatrix;
use std::borrow::Cow;
use std::ops::Range;

/// Most columns of `X` one pass over `A` serves (a row of the block is then one
/// cache line of 64 bytes).
pub const BLOCK: usize = 8;

/// Runs of rows per thread (load balance; the result does not depend on it).
const RUNS_PER_THREAD: usize = 4;

/// `A X` of a symmetric sparse `A` and a dense block `X`, sequential.
pub fn sym_mul(a: &SparseMatrix, x: &DMatrix<f64>) -> DMatrix<f64> {
    sym_mul_par(a, x, Par::Seq)
}

/// `A X` of a symmetric sparse `A`, the rows shared among the threads of
/// `par` (module docs).
pub fn sym_mul_par(a: &SparseMatrix, x: &DMatrix<f64>, par: Par) -> DMatrix<f64> {
    assert_eq!(a.ncols(), x.nrows(), "sym_mul: sizes");
    let (nr, nc) = (a.nrows(), x.ncols());
    let mut y = DMatrix::zeros(nr, nc);
    mul_into(a.as_ref(), x.as_slice(), y.as_mut_slice(), nc, par);
    y
}

/// `y = A x` (as `A^T x`, module docs) for column-major `x` and `y` (`n x
/// nc`) of a square `A`, in blocks of [`BLOCK`] columns.
pub(crate) fn mul_into(
    a: SparseColMatRef<'_, usize, f64>,
    x: &[f64],
    y: &mut [f64],
    nc: usize,
    par: Par,
) {
    let n = a.ncols();
    assert_eq!(a.nrows(), n, "sym_mul: a square matrix");
    debug_assert_eq!((x.len(), y.len()), (n * nc, n * nc));
    if n == 0 {
        return;
    }
    let runs = row_runs(a, par.degree().max(1) * RUNS_PER_THREAD);
    let mut c0 = 0;
    while c0 < nc {
        let w = BLOCK.min(nc - c0);
        // the block of X by rows (one column is its own transpose)
        let xt: Cow<[f64]> = if w == 1 {
            Cow::Borrowed(&x[c0 * n..(c0 + 1) * n])
        } else {
            let mut t = vec![0.0; n * w];
            for k in 0..w {
                for (j, v) in x[(c0 + k) * n..(c0 + k + 1) * n].iter().enumerate() {
                    t[j * w + k] = *v;
                }
            }
            Cow::Owned(t)
        };
        // each run's rows of the block's columns
        let mut jobs: Vec<(Range<usize>, Vec<&mut [f64]>)> = runs
            .iter()
            .map(|r| (r.clone(), Vec::with_capacity(w)))
            .collect();
        for col in y[c0 * n..(c0 + w) * n].chunks_mut(n) {
            let mut rest = col;
            for (r, out) in jobs.iter_mut() {
                let (mine, tail) = std::mem::take(&mut rest).split_at_mut(r.len());
                out.push(mine);
                rest = tail;
            }
        }
        let job = |(r, out): &mut (Range<usize>, Vec<&mut [f64]>)| {
            gather_block(a, r.clone(), &xt, out, w)
        };
        if par.degree() > 1 {
            use rayon::prelude::*;
            jobs.par_iter_mut().for_each(job);
        } else {
            jobs.iter_mut().for_each(job);
        }
        c0 += w;
    }
}

/// About `count` contiguous runs of the rows (= columns) of `A` with about
/// equal stored entries, covering `0..n` in order.
fn row_runs(a: SparseColMatRef<'_, usize, f64>, count: usize) -> Vec<Range<usize>> {
    let n = a.ncols();
    let nnz: usize = (0..n).map(|c| a.symbolic().col_range(c).len()).sum();
    let count = count.clamp(1, n.max(1));
    let mut out = Vec::with_capacity(count);
    let (mut start, mut seen, mut c) = (0, 0, 0);
    for p in 1..=count {
        let target = nnz * p / count;
        while c < n && (seen < target || p == count) {
            seen += a.symbolic().col_range(c).len();
            c += 1;
        }
        if c > start {
            out.push(start..c);
            start = c;
        }
    }
    out
}

/// `out[k][i] = sum_p a_pj xt[p][k]` for the rows `j = rows.start + i` (the
/// stored columns `j` of `A`), `xt` held by rows of `w` values.
fn gather_block(
    a: SparseColMatRef<'_, usize, f64>,
    rows: Range<usize>,
    xt: &[f64],
    out: &mut [&mut [f64]],
    w: usize,
) {
    macro_rules! dispatch {
        ($($n:literal)*) => {
            match w {
                $($n => gather::<$n>(a, rows, xt, out),)*
                _ => unreachable!("block width {w} above BLOCK"),
            }
        };
    }
    dispatch!(1 2 3 4 5 6 7 8)
}

/// [`gather_block`] for a block of `W` columns (the row sum unrolled).
fn gather<const W: usize>(
    a: SparseColMatRef<'_, usize, f64>,
    rows: Range<usize>,
    xt: &[f64],
    out: &mut [&mut [f64]],
) {
    let (xr, _) = xt.as_chunks::<W>();
    let (idx, vals) = (a.symbolic().row_idx(), a.val());
    let start = rows.start;
    for j in rows {
        let mut acc = [0.0; W];
        for p in a.symbolic().col_range(j) {
            let (xi, v) = (&xr[idx[p]], vals[p]);
            for k in 0..W {
                acc[k] += v * xi[k];
            }
        }
        for (k, o) in out.iter_mut().enumerate() {
            o[j - start] = acc[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::sparse::{sparse_from_triplets, sparse_to_dense, Xorshift};

    /// A random symmetric sparse matrix with empty columns (and rows).
    fn random_sparse(n: usize, per_col: usize, rng: &mut Xorshift) -> SparseMatrix {
        let mut t = Vec::new();
        for c in 0..n {
            if c % 7 == 3 {
                continue;
            }
            for _ in 0..per_col {
                let r = ((rng.next() + 1.0) * 0.5 * n as f64) as usize % n;
                if r % 7 != 3 {
                    let v = rng.next();
                    t.push((r, c, v));
                    t.push((c, r, v));
                }
            }
        }
        sparse_from_triplets(n, &t).unwrap()
    }

    #[test]
    fn equals_the_dense_product_for_every_block_width() {
        let mut rng = Xorshift(0x1234_5678_9abc_def1);
        for &(n, per_col) in &[(1, 1), (5, 2), (60, 9), (700, 12)] {
            let a = random_sparse(n, per_col, &mut rng);
            let d = sparse_to_dense(&a);
            for nc in [1, 2, 3, 7, 8, 9, 17] {
                let mut x = rng.block(n, nc);
                if nc > 2 {
                    x.row_mut(n / 2).fill(0.0); // a skipped row of X
                }
                let want = &d * &x;
                for par in [Par::Seq, Par::rayon(2)] {
                    let got = sym_mul_par(&a, &x, par);
                    let err = (&got - &want).amax();
                    assert!(err <= 1e-13 * (1.0 + want.amax()), "n {n} nc {nc}: {err}");
                }
            }
        }
    }

    #[test]
    fn the_thread_count_does_not_change_the_rounding() {
        let mut rng = Xorshift(0x0dd_ba11);
        let a = random_sparse(3000, 10, &mut rng);
        let x = rng.block(3000, 5);
        let seq = sym_mul_par(&a, &x, Par::Seq);
        for t in [2, 3, 4] {
            assert_eq!(sym_mul_par(&a, &x, Par::rayon(t)), seq);
        }
    }

    #[test]
    fn an_unsymmetric_matrix_gives_its_transpose_product() {
        let a = sparse_from_triplets(2, &[(0, 0, 1.0), (1, 0, 2.0), (1, 1, 3.0)]).unwrap();
        let x = DMatrix::from_column_slice(2, 1, &[1.0, 10.0]);
        assert_eq!(sym_mul(&a, &x).as_slice(), &[21.0, 30.0]);
    }

    #[test]
    fn runs_cover_the_rows_in_order() {
        let mut rng = Xorshift(77);
        for (n, count) in [(1, 8), (2, 8), (100, 3), (3000, 8)] {
            let a = random_sparse(n, 4, &mut rng);
            let r = row_runs(a.as_ref(), count);
            assert_eq!(r.first().unwrap().start, 0);
            assert_eq!(r.last().unwrap().end, n);
            for w in r.windows(2) {
                assert_eq!(w[0].end, w[1].start);
            }
        }
    }
}
