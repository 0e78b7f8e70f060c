//! Reading and writing the matrix files (Matrix Market through `feio`) of a
//! matrices structure, with the errors naming the key ([`MatrixRole`]),
//! file and line.
use super::*;

/// The [`MatricesError`] of a reader's error (`feio`): the key, file and line.
pub fn matrices_error(role: MatrixRole, e: feio::Error) -> MatricesError {
    match e {
        feio::Error::Io { path, message } => MatricesError::Io {
            role,
            path,
            message,
        },
        feio::Error::Parse {
            path,
            line,
            detail: feio::Detail::NonFinite { row, col, value },
            ..
        } => MatricesError::NonFinite {
            role,
            path,
            row,
            col,
            value,
            line: Some(line),
        },
        feio::Error::Parse {
            path,
            line,
            format,
            detail,
        } => MatricesError::Malformed {
            role,
            path,
            line: Some(line),
            format: match format {
                feio::Format::MatrixMarket => "Matrix Market",
                feio::Format::HarwellBoeing => "Harwell-Boeing",
                feio::Format::Abaqus => "Abaqus matrix",
                feio::Format::Auto => "matrix",
            },
            message: detail.to_string(),
        },
    }
}

/// The sparse matrix of a reader's triplets (`feio::Triplets`, symmetric
/// storage expanded; duplicates add up): square, finite, indices in range.
/// Every reader of this module ends here, so the checks live once.
pub fn sparse_from_feio(
    role: MatrixRole,
    path: &Path,
    t: &feio::Triplets,
) -> Result<SparseMatrix, MatricesError> {
    let (rows, cols) = (t.nrows, t.ncols);
    if rows != cols {
        return Err(MatricesError::NotSquare {
            role,
            path: path.into(),
            rows,
            cols,
        });
    }
    let out_of_range = || MatricesError::Malformed {
        role,
        path: path.into(),
        line: None,
        format: "matrix",
        message: "an entry's index is out of range".into(),
    };
    for k in 0..t.nnz() {
        let (r, c, v) = (t.rows[k], t.cols[k], t.vals[k]);
        if !v.is_finite() {
            return Err(MatricesError::NonFinite {
                role,
                path: path.into(),
                row: r,
                col: c,
                value: v,
                line: None,
            });
        }
        if r >= rows || c >= cols {
            return Err(out_of_range());
        }
    }
    csc_of_triplets(t).ok_or_else(out_of_range)
}

/// The compressed-column matrix of checked triplets (indices in range),
/// symmetric storage expanded, duplicates summed in the order of
/// [`feio::Triplets::expanded`]: column counts, then the entries bucketed by
/// column, then each column sorted by row (stable) and its duplicates summed.
/// Hand-written rather than faer's `try_new_from_triplets`, which takes every
/// entry of both triangles as a triplet list of its own and sorts a copy of
/// it (about three times the matrix's memory at 10^6 DOFs).
fn csc_of_triplets(t: &feio::Triplets) -> Option<SparseMatrix> {
    let n = t.ncols;
    let sym = t.symmetric_storage;
    let mut col_ptr = vec![0usize; n + 1];
    for k in 0..t.nnz() {
        let (r, c) = (t.rows[k], t.cols[k]);
        col_ptr[c + 1] += 1;
        if sym && r != c {
            col_ptr[r + 1] += 1;
        }
    }
    for c in 0..n {
        col_ptr[c + 1] += col_ptr[c];
    }
    let total = col_ptr[n];
    let mut next = col_ptr.clone();
    let (mut row_idx, mut vals) = (vec![0usize; total], vec![0.0f64; total]);
    let mut put = |r: usize, c: usize, v: f64| {
        row_idx[next[c]] = r;
        vals[next[c]] = v;
        next[c] += 1;
    };
    for k in 0..t.nnz() {
        let (r, c, v) = (t.rows[k], t.cols[k], t.vals[k]);
        put(r, c, v);
        if sym && r != c {
            put(c, r, v);
        }
    }
    drop(next);
    // each column sorted by row, duplicates summed, compacted in place
    let mut scratch: Vec<(usize, f64)> = Vec::new();
    let mut w = 0usize;
    let mut start = 0usize;
    for c in 0..n {
        let end = col_ptr[c + 1];
        scratch.clear();
        scratch.extend((start..end).map(|p| (row_idx[p], vals[p])));
        scratch.sort_by_key(|e| e.0);
        col_ptr[c] = w;
        for (i, &(r, v)) in scratch.iter().enumerate() {
            if i > 0 && scratch[i - 1].0 == r {
                vals[w - 1] += v;
            } else {
                row_idx[w] = r;
                vals[w] = v;
                w += 1;
            }
        }
        start = end;
    }
    col_ptr[n] = w;
    row_idx.truncate(w);
    vals.truncate(w);
    let symbolic =
        faer::sparse::SymbolicSparseColMat::new_checked(t.nrows, n, col_ptr, None, row_idx);
    Some(SparseMatrix::new(symbolic, vals))
}

/// Reads a matrix file in `format` (`feio`: Matrix Market, `.mtx.gz`,
/// Harwell-Boeing, Abaqus matrix output; `Auto` detects it) into its triplets.
pub fn read_matrix_triplets(
    role: MatrixRole,
    path: &Path,
    format: feio::Format,
) -> Result<feio::Triplets, MatricesError> {
    feio::read(path, format).map_err(|e| matrices_error(role, e))
}

/// Reads a Matrix Market file (coordinate or array; real or integer; general or
/// symmetric; also gzip-compressed) into a dense square matrix; duplicate
/// coordinate entries add up.
pub fn read_matrix_market(role: MatrixRole, path: &Path) -> Result<DMatrix<f64>, MatricesError> {
    Ok(sparse_to_dense(&read_matrix_market_sparse(role, path)?))
}

/// As [`read_matrix_market`] into a sparse matrix (compressed columns).
pub fn read_matrix_market_sparse(
    role: MatrixRole,
    path: &Path,
) -> Result<SparseMatrix, MatricesError> {
    let t = read_matrix_triplets(role, path, feio::Format::MatrixMarket)?;
    sparse_from_feio(role, path, &t)
}

/// As [`read_matrix_market`] from the file's text (`path` only names it in errors).
pub fn read_matrix_market_str(
    role: MatrixRole,
    path: &Path,
    text: &str,
) -> Result<DMatrix<f64>, MatricesError> {
    Ok(sparse_to_dense(&read_matrix_market_sparse_str(
        role, path, text,
    )?))
}

/// As [`read_matrix_market_sparse`] from the file's text.
pub fn read_matrix_market_sparse_str(
    role: MatrixRole,
    path: &Path,
    text: &str,
) -> Result<SparseMatrix, MatricesError> {
    let t = feio::read_bytes(path, text.as_bytes(), feio::Format::MatrixMarket)
        .map_err(|e| matrices_error(role, e))?;
    sparse_from_feio(role, path, &t)
}

/// The Matrix Market text (coordinate, real, symmetric: the lower triangle's
/// non-zeros) of the symmetric matrix `a`; numbers in Rust's shortest round-trip
/// form, so [`read_matrix_market_str`] gives back the same bits.
pub fn write_matrix_market(a: &DMatrix<f64>) -> String {
    write_matrix_market_sparse(&sparse_from_dense(a))
}

/// As [`write_matrix_market`] for a sparse symmetric matrix (its lower triangle).
pub fn write_matrix_market_sparse(a: &SparseMatrix) -> String {
    let mut entries = Vec::new();
    for_each_entry(a, |r, c, v| {
        if r >= c && v != 0.0 {
            entries.push(format!("{} {} {:e}", r + 1, c + 1, v));
        }
    });
    format!(
        "%%MatrixMarket matrix coordinate real symmetric\n{} {} {}\n{}\n",
        a.nrows(),
        a.ncols(),
        entries.len(),
        entries.join("\n")
    )
}
