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
//!
//! The tall dense products of the Lanczos basis `V` (`n x k`, `k` a few tens)
//! with a block `W` (`n x b`), `V^T W` ([`tall_tr_mul`]) and `Y += alpha V C`
//! ([`tall_mul_add`]), are faer's kernel on fixed chunks of [`TALL_ROWS`] rows
//! shared among the threads (performance: nalgebra's product is sequential,
//! and `V^T W` is a reduction over the rows into a `k x b` result that faer's
//! parallel GEMM cannot share). The chunks' partial sums are added in chunk
//! order: the result does not depend on the thread count either.
use super::sparse::SparseMatrix;
use faer::linalg::matmul::matmul;
use faer::sparse::SparseColMatRef;
use faer::{Accum, Mat, MatMut, MatRef, Par};
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

/// Rows of a chunk of the tall dense products (module docs): fixed, so that
/// the sums do not depend on the thread count; a chunk of a 48-column basis
/// is 1.5 MB.
pub const TALL_ROWS: usize = 4096;

/// `V^T W` of the column-major `V` (`n x k`, `v.len() = n k`) and `W` (`n x
/// b`) (module docs).
pub fn tall_tr_mul(v: &[f64], w: &[f64], n: usize, par: Par) -> DMatrix<f64> {
    let (k, b) = tall_shape(v, w, n);
    let mut out = DMatrix::zeros(k, b);
    if k == 0 || b == 0 || n == 0 {
        return out;
    }
    let (v, w) = (
        MatRef::from_column_major_slice(v, n, k),
        MatRef::from_column_major_slice(w, n, b),
    );
    let part = |(vr, wr): (MatRef<'_, f64>, MatRef<'_, f64>)| {
        let mut p = Mat::<f64>::zeros(k, b);
        matmul(
            p.as_mut(),
            Accum::Replace,
            vr.transpose(),
            wr,
            1.0,
            Par::Seq,
        );
        p
    };
    let parts: Vec<Mat<f64>> = if par.degree() > 1 {
        use rayon::prelude::*;
        v.par_row_chunks(TALL_ROWS)
            .zip(w.par_row_chunks(TALL_ROWS))
            .map(part)
            .collect()
    } else {
        (0..n)
            .step_by(TALL_ROWS)
            .map(|r| {
                let len = TALL_ROWS.min(n - r);
                part((v.subrows(r, len), w.subrows(r, len)))
            })
            .collect()
    };
    for p in &parts {
        for j in 0..b {
            for i in 0..k {
                out[(i, j)] += p[(i, j)];
            }
        }
    }
    out
}

/// `Y += alpha V C` of the column-major `V` (`n x k`, `v.len() = n k`), `C`
/// (`k x b`) and `Y` (`n x b`) (module docs).
pub fn tall_mul_add(y: &mut [f64], v: &[f64], c: &DMatrix<f64>, alpha: f64, n: usize, par: Par) {
    let (k, b) = tall_shape(v, y, n);
    assert_eq!((c.nrows(), c.ncols()), (k, b), "tall_mul_add: sizes");
    if k == 0 || b == 0 || n == 0 {
        return;
    }
    let v = MatRef::from_column_major_slice(v, n, k);
    let y = MatMut::from_column_major_slice_mut(y, n, b);
    let c = MatRef::from_column_major_slice(c.as_slice(), k, b);
    let part = |(yr, vr): (MatMut<'_, f64>, MatRef<'_, f64>)| {
        matmul(yr, Accum::Add, vr, c, alpha, Par::Seq);
    };
    if par.degree() > 1 {
        use rayon::prelude::*;
        y.par_row_chunks_mut(TALL_ROWS)
            .zip(v.par_row_chunks(TALL_ROWS))
            .for_each(part);
    } else {
        let mut y = y;
        for r in (0..n).step_by(TALL_ROWS) {
            let len = TALL_ROWS.min(n - r);
            part((y.as_mut().subrows_mut(r, len), v.subrows(r, len)));
        }
    }
}

/// The column counts of two column-major blocks of `n` rows.
fn tall_shape(v: &[f64], w: &[f64], n: usize) -> (usize, usize) {
    if n == 0 {
        assert!(v.is_empty() && w.is_empty(), "tall product: sizes");
        return (0, 0);
    }
    assert!(
        v.len().is_multiple_of(n) && w.len().is_multiple_of(n),
        "tall product: sizes"
    );
    (v.len() / n, w.len() / n)
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
    fn tall_products_equal_nalgebra_for_any_thread_count() {
        let mut rng = Xorshift(0x7a11);
        for &(n, k, b) in &[
            (1, 1, 1),
            (10, 3, 2),
            (4095, 7, 3),
            (4097, 5, 1),
            (20_000, 42, 3),
        ] {
            let v = rng.block(n, k);
            let w = rng.block(n, b);
            let want = v.tr_mul(&w);
            let got = tall_tr_mul(v.as_slice(), w.as_slice(), n, Par::Seq);
            let scale = (n as f64).sqrt();
            assert!((&got - &want).amax() <= 1e-14 * scale, "V^T W {n} {k} {b}");
            let c = rng.block(k, b);
            let want_y = &w - &v * &c * 2.0;
            let mut y = w.clone();
            tall_mul_add(y.as_mut_slice(), v.as_slice(), &c, -2.0, n, Par::Seq);
            assert!(
                (&y - &want_y).amax() <= 1e-14 * k as f64,
                "Y - 2 V C {n} {k} {b}"
            );
            for t in [2, 3] {
                let par = Par::rayon(t);
                assert_eq!(tall_tr_mul(v.as_slice(), w.as_slice(), n, par), got);
                let mut yp = w.clone();
                tall_mul_add(yp.as_mut_slice(), v.as_slice(), &c, -2.0, n, par);
                assert_eq!(yp, y);
            }
        }
        assert_eq!(tall_tr_mul(&[], &[], 0, Par::Seq).shape(), (0, 0));
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
