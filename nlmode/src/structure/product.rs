//! `A X`: a sparse matrix (compressed columns, faer's storage) times a dense
//! block `X` (column-major, nalgebra), the products with `M` and `K` of the
//! Lanczos and subspace iterations ([`super::lanczos`], [`super::subspace`])
//! and of the Craig-Bampton projection ([`super::craig_bampton`]).
//!
//! Hand-written instead of faer's `sparse_dense_matmul` (performance): faer's
//! kernel makes one pass over `A` per column of `X`, which made the products
//! with `M` a quarter of `host nma`'s CPU time at 10^5 DOFs. Here one pass over
//! `A` serves a block of up to [`BLOCK`] columns: `X` and `A X` are held by rows
//! for the pass, so a stored entry `a_ij` updates a contiguous row
//! `(A X)_i += a_ij X_j` of the block. The columns of `A` are split in
//! [`PARTS`] runs of equal stored entries, each summed into its own block
//! (in parallel when `par` has threads, so a single column is parallel too), and
//! the blocks are added in a fixed order: the result does not depend on the
//! number of threads. No symmetry of `A` is assumed.
use super::sparse::SparseMatrix;
use faer::sparse::SparseColMatRef;
use faer::Par;
use nalgebra::DMatrix;

/// Most columns of `X` one pass over `A` serves (a row of the block is then one
/// cache line of 64 bytes).
pub const BLOCK: usize = 8;

/// Runs of the columns of `A` summed separately (fixed, so that the rounding
/// does not depend on the thread count; two is this machine's core count).
pub const PARTS: usize = 2;

/// `A X` of a sparse `A` and a dense block `X`, sequential.
pub fn sparse_mul(a: &SparseMatrix, x: &DMatrix<f64>) -> DMatrix<f64> {
    sparse_mul_par(a, x, Par::Seq)
}

/// `A X`, the [`PARTS`] runs of `A`'s columns shared among the threads of `par`
/// (module docs).
pub fn sparse_mul_par(a: &SparseMatrix, x: &DMatrix<f64>, par: Par) -> DMatrix<f64> {
    assert_eq!(a.ncols(), x.nrows(), "sparse_mul: sizes");
    let (nr, nc) = (a.nrows(), x.ncols());
    let mut y = DMatrix::zeros(nr, nc);
    mul_into(a.as_ref(), x.as_slice(), y.as_mut_slice(), nc, par);
    y
}

/// `y = A x` for column-major `x` (`A.ncols() x nc`) and `y` (`A.nrows() x
/// nc`), in blocks of [`BLOCK`] columns.
pub(crate) fn mul_into(
    a: SparseColMatRef<'_, usize, f64>,
    x: &[f64],
    y: &mut [f64],
    nc: usize,
    par: Par,
) {
    let (nr, nx) = (a.nrows(), a.ncols());
    debug_assert_eq!((x.len(), y.len()), (nx * nc, nr * nc));
    let runs = runs(a);
    let mut c0 = 0;
    while c0 < nc {
        let w = BLOCK.min(nc - c0);
        // the block of X by rows
        let mut xt = vec![0.0; nx * w];
        for k in 0..w {
            for (j, v) in x[(c0 + k) * nx..(c0 + k + 1) * nx].iter().enumerate() {
                xt[j * w + k] = *v;
            }
        }
        let mut parts: Vec<Vec<f64>> = (0..runs.len()).map(|_| vec![0.0; nr * w]).collect();
        let job = |(run, yt): (&std::ops::Range<usize>, &mut Vec<f64>)| {
            scatter_block(a, run.clone(), &xt, yt, w)
        };
        if par.degree() > 1 {
            use rayon::prelude::*;
            runs.par_iter().zip(parts.par_iter_mut()).for_each(job);
        } else {
            runs.iter().zip(parts.iter_mut()).for_each(job);
        }
        // the runs' blocks added in order, back to columns
        for k in 0..w {
            let yc = &mut y[(c0 + k) * nr..(c0 + k + 1) * nr];
            for (i, out) in yc.iter_mut().enumerate() {
                *out = parts.iter().map(|p| p[i * w + k]).sum();
            }
        }
        c0 += w;
    }
}

/// [`PARTS`] runs of `A`'s columns with about equal stored entries (fewer for
/// a small `A`).
fn runs(a: SparseColMatRef<'_, usize, f64>) -> Vec<std::ops::Range<usize>> {
    let n = a.ncols();
    let nnz: usize = (0..n).map(|c| a.symbolic().col_range(c).len()).sum();
    let parts = if nnz < 4096 { 1 } else { PARTS };
    let mut out = Vec::with_capacity(parts);
    let (mut start, mut seen, mut c) = (0, 0, 0);
    for p in 1..=parts {
        let target = nnz * p / parts;
        while c < n && (seen < target || p == parts) {
            seen += a.symbolic().col_range(c).len();
            c += 1;
        }
        out.push(start..c);
        start = c;
    }
    out
}

/// `yt += A[:, run] xt[run, :]` with `xt`, `yt` held by rows of `w` values.
fn scatter_block(
    a: SparseColMatRef<'_, usize, f64>,
    run: std::ops::Range<usize>,
    xt: &[f64],
    yt: &mut [f64],
    w: usize,
) {
    macro_rules! dispatch {
        ($($n:literal)*) => {
            match w {
                $($n => scatter::<$n>(a, run, xt, yt),)*
                _ => unreachable!("block width {w} above BLOCK"),
            }
        };
    }
    dispatch!(1 2 3 4 5 6 7 8)
}

/// [`scatter_block`] for a block of `W` columns (the row update unrolled).
fn scatter<const W: usize>(
    a: SparseColMatRef<'_, usize, f64>,
    run: std::ops::Range<usize>,
    xt: &[f64],
    yt: &mut [f64],
) {
    let (xr, _) = xt.as_chunks::<W>();
    let (yr, _) = yt.as_chunks_mut::<W>();
    let (rows, vals) = (a.symbolic().row_idx(), a.val());
    for j in run {
        let xj = xr[j];
        if xj == [0.0; W] {
            continue;
        }
        for p in a.symbolic().col_range(j) {
            let (yi, v) = (&mut yr[rows[p]], vals[p]);
            for k in 0..W {
                yi[k] += v * xj[k];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::sparse::{sparse_from_triplets, sparse_to_dense, Xorshift};

    /// A random unsymmetric sparse matrix with empty columns and rows.
    fn random_sparse(n: usize, per_col: usize, rng: &mut Xorshift) -> SparseMatrix {
        let mut t = Vec::new();
        for c in 0..n {
            if c % 7 == 3 {
                continue;
            }
            for _ in 0..per_col {
                let r = ((rng.next() + 1.0) * 0.5 * n as f64) as usize % n;
                if r % 11 != 5 {
                    t.push((r, c, rng.next()));
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
                    let got = sparse_mul_par(&a, &x, par);
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
        let seq = sparse_mul_par(&a, &x, Par::Seq);
        for t in [2, 3, 4] {
            assert_eq!(sparse_mul_par(&a, &x, Par::rayon(t)), seq);
        }
    }

    #[test]
    fn runs_cover_the_columns_in_order() {
        let mut rng = Xorshift(77);
        for n in [1, 2, 100, 3000] {
            let a = random_sparse(n, 4, &mut rng);
            let r = runs(a.as_ref());
            assert_eq!(r.first().unwrap().start, 0);
            assert_eq!(r.last().unwrap().end, n);
            for w in r.windows(2) {
                assert_eq!(w[0].end, w[1].start);
            }
        }
    }
}
