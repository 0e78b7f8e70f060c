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
    let mut triplets = Vec::with_capacity(t.nnz().saturating_mul(2).min(1 << 28));
    for (r, c, v) in t.expanded() {
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
        triplets.push((r, c, v));
    }
    sparse_from_triplets(rows, &triplets).ok_or_else(|| MatricesError::Malformed {
        role,
        path: path.into(),
        line: None,
        format: "matrix",
        message: "an entry's index is out of range".into(),
    })
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
