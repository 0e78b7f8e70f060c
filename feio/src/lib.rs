//! Readers of FE matrix files into one triplet type, at disk speed.
//!
//! * Matrix Market ([`mm`]): `coordinate` and `array`; `real` and `integer`
//!   (`pattern`, `complex`, `hermitian` and `skew-symmetric` refused by name: a
//!   mass, stiffness or damping matrix is real and symmetric); `general` and
//!   `symmetric` (lower triangle); `%` comments; gzip-compressed (`.mtx.gz`).
//!   A hand-written byte-level parser (no grammar engine), decimal numbers by
//!   `fast-float2` (correctly rounded: the same bits as `str::parse::<f64>`),
//!   line-aligned chunks parsed in parallel by rayon for large files.
//! * Harwell-Boeing / Rutherford-Boeing ([`hb`], `.rb`, `.rsa`, `.rua`): the
//!   fixed-format header, Fortran edit descriptors (`(10I8)`, `(1P,4E20.12)`,
//!   `D` exponents, fields with no space between them), assembled real or
//!   integer matrices (`RSA`, `RUA`, `RRA`, ...); elemental (`RSE`), pattern
//!   and complex refused by name.
//! * Abaqus matrix output ([`abaqus`], `*MATRIX GENERATE` / `*MATRIX OUTPUT`,
//!   e.g. `job_STIF1.mtx`): the coordinate format `row, column, value` and the
//!   labels format `node, dof, node, dof, value` (one triangle or both; the rows
//!   numbered by the distinct `(node, dof)` labels in ascending order, kept in
//!   [`Triplets::labels`]).
//!
//! Every error is a typed [`Error`] naming the file, the 1-based line and what
//! was expected; no input panics, and nothing is allocated from a count that a
//! header claims beyond what the file's size can hold ([`MAX_DIM`] bounds the
//! dimensions).
#![forbid(unsafe_code)]

pub mod abaqus;
pub mod hb;
pub mod mm;
mod text;

use std::io::Read;
use std::path::{Path, PathBuf};

/// Largest number of rows or columns accepted (10^8: a hundred times the
/// million-DOF models this crate is made for); a size line claiming more is
/// refused before anything is allocated.
pub const MAX_DIM: usize = 100_000_000;

/// Largest decompressed size of a gzip file [bytes] (64 GiB).
pub const MAX_DECOMPRESSED: u64 = 1 << 36;

/// A DOF label of a labelled file: `(node, dof)` with Abaqus' DOF numbers
/// (1, 2, 3 translations x, y, z; 4, 5, 6 rotations about x, y, z).
pub type Label = (u64, u8);

/// The file format (`Auto` detects it, [`detect`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Format {
    #[default]
    Auto,
    MatrixMarket,
    HarwellBoeing,
    Abaqus,
}

impl Format {
    /// The name used in messages and in the host's `matrix_format` key.
    pub fn name(self) -> &'static str {
        match self {
            Format::Auto => "auto",
            Format::MatrixMarket => "matrix-market",
            Format::HarwellBoeing => "harwell-boeing",
            Format::Abaqus => "abaqus",
        }
    }

    /// The format of a key value (`auto`, `matrix-market`, `harwell-boeing`, `abaqus`).
    pub fn from_name(s: &str) -> Option<Format> {
        [
            Format::Auto,
            Format::MatrixMarket,
            Format::HarwellBoeing,
            Format::Abaqus,
        ]
        .into_iter()
        .find(|f| f.name() == s)
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A sparse matrix as read: 0-based `(rows[k], cols[k], vals[k])` in file order
/// (duplicates kept: they add up). With `symmetric_storage` only one triangle
/// is stored and each off-diagonal entry stands for itself and its transpose
/// ([`Triplets::expanded`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Triplets {
    pub nrows: usize,
    pub ncols: usize,
    pub rows: Vec<usize>,
    pub cols: Vec<usize>,
    pub vals: Vec<f64>,
    pub symmetric_storage: bool,
    /// The `(node, dof)` of each row (and column) of a labelled file, ascending.
    pub labels: Option<Vec<Label>>,
    /// The format the file was read as.
    pub format: Format,
}

impl Triplets {
    /// An unlabelled `nrows x ncols` matrix of the entries `(rows, cols,
    /// vals)` read as `format`.
    pub fn unlabelled(
        (nrows, ncols): (usize, usize),
        (rows, cols, vals): (Vec<usize>, Vec<usize>, Vec<f64>),
        symmetric_storage: bool,
        format: Format,
    ) -> Self {
        Self {
            nrows,
            ncols,
            rows,
            cols,
            vals,
            symmetric_storage,
            labels: None,
            format,
        }
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.vals.len()
    }

    /// Every entry of the full matrix: a stored `(r, c, v)`, then for symmetric
    /// storage off the diagonal `(c, r, v)` (the order of nalgebra-sparse's
    /// Matrix Market reader).
    pub fn expanded(&self) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
        let sym = self.symmetric_storage;
        (0..self.vals.len()).flat_map(move |k| {
            let (r, c, v) = (self.rows[k], self.cols[k], self.vals[k]);
            let mirror = (sym && r != c).then_some((c, r, v));
            std::iter::once((r, c, v)).chain(mirror)
        })
    }

    /// The row of `(node, dof)` in a labelled file.
    pub fn index_of(&self, label: Label) -> Option<usize> {
        self.labels.as_ref()?.binary_search(&label).ok()
    }

    /// Renumbers a labelled matrix onto `labels` (ascending, a superset of its
    /// own), so that matrices of one model whose files name different DOF sets
    /// share one numbering. `Err(label)`: a label of the file missing there.
    pub fn relabel(&mut self, labels: &[Label]) -> Result<(), Label> {
        let Some(own) = self.labels.as_ref() else {
            return Ok(());
        };
        let mut map = Vec::with_capacity(own.len());
        for l in own {
            map.push(labels.binary_search(l).map_err(|_| *l)?);
        }
        for r in self.rows.iter_mut().chain(self.cols.iter_mut()) {
            *r = map[*r];
        }
        self.nrows = labels.len();
        self.ncols = labels.len();
        self.labels = Some(labels.to_vec());
        Ok(())
    }
}

/// What is wrong at a line of a file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Detail {
    /// A token that is not what the format requires there.
    #[error("expected {expected}, found `{found}`")]
    Expected { expected: String, found: String },
    /// A row, column or pointer outside its range.
    #[error("{what} {value} is out of range {min}..={max}")]
    OutOfRange {
        what: &'static str,
        value: u64,
        min: u64,
        max: u64,
    },
    /// A NaN or infinite value (0-based row and column where known).
    #[error("non-finite value {value} at row {}, column {} (1-based)", row + 1, col + 1)]
    NonFinite { row: usize, col: usize, value: f64 },
    /// Fewer or more entries than the header says.
    #[error("expected {expected} {what}, found {found}")]
    Count {
        what: &'static str,
        expected: u64,
        found: u64,
    },
    /// A count or size beyond what the file can hold or [`MAX_DIM`].
    #[error("{what} = {value} is too large: at most {limit}")]
    TooLarge {
        what: &'static str,
        value: u64,
        limit: u64,
    },
    /// A valid variant of the format that cannot hold a real FE matrix.
    #[error("{0}")]
    Unsupported(String),
    /// `Format::Auto` found no known format.
    #[error(
        "cannot tell the format: expected a Matrix Market header `%%MatrixMarket`, a Harwell-Boeing \
         file (.rb, .rsa, .rua, or its header), or Abaqus matrix output (`row, column, value` or \
         `node, dof, node, dof, value`); set the format explicitly if it is one of them"
    )]
    UnknownFormat,
}

/// Errors of the readers: the file, and for a malformed file the 1-based line,
/// the format and what was expected there.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// The file cannot be read (missing, no permission, bad gzip stream).
    #[error("cannot read {}: {message}", path.display())]
    Io { path: PathBuf, message: String },
    /// The file is not valid in its format.
    #[error("{} (line {line}, {format}): {detail}", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        format: Format,
        detail: Detail,
    },
}

impl Error {
    /// The file named.
    pub fn path(&self) -> &Path {
        match self {
            Error::Io { path, .. } | Error::Parse { path, .. } => path,
        }
    }

    /// The 1-based line of a malformed file.
    pub fn line(&self) -> Option<usize> {
        match self {
            Error::Io { .. } => None,
            Error::Parse { line, .. } => Some(*line),
        }
    }
}

pub(crate) fn parse_error(path: &Path, line: usize, format: Format, detail: Detail) -> Error {
    Error::Parse {
        path: path.into(),
        line,
        format,
        detail,
    }
}

/// "expected `what`, found `found`" at `line` of `path` in `format`.
pub(crate) fn expected_error(
    path: &Path,
    line: usize,
    format: Format,
    what: &str,
    found: &[u8],
) -> Error {
    parse_error(
        path,
        line,
        format,
        Detail::Expected {
            expected: what.into(),
            found: text::shown(found),
        },
    )
}

/// Reads the file at `path` (gzip-compressed or not) in `format`. A Matrix
/// Market or Abaqus file, plain or gzip-compressed (`.mtx.gz`, decompressed
/// as it is parsed), is read in windows of whole lines ([`parse_stream`]):
/// the memory is its entries plus one window of text, not the file's text;
/// a Harwell-Boeing file is read line by line.
pub fn read(path: &Path, format: Format) -> Result<Triplets, Error> {
    let io = |e: std::io::Error| Error::Io {
        path: path.into(),
        message: e.to_string(),
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let file_bytes = file.metadata().ok().map(|m| m.len());
    let mut first = Vec::new();
    (&mut file)
        .take(mm::WINDOW_BYTES as u64)
        .read_to_end(&mut first)
        .map_err(io)?;
    if first.starts_with(&[0x1f, 0x8b]) {
        let compressed = std::io::Cursor::new(first).chain(file);
        let reserve = file_bytes.map(|b| b.saturating_mul(GZIP_RESERVE_RATIO));
        return read_gzip(
            path,
            compressed,
            format,
            reserve,
            mm::WINDOW_BYTES,
            MAX_DECOMPRESSED,
        );
    }
    let size = Size {
        exact: file_bytes,
        reserve: file_bytes,
    };
    parse_stream(path, first, &mut file, format, size, mm::WINDOW_BYTES)
}

/// What is known of a file's (decompressed) size when it is read.
#[derive(Clone, Copy)]
struct Size {
    /// Its exact size (a plain file's), which bounds the counts a header may
    /// announce.
    exact: Option<u64>,
    /// The bytes that bound what is reserved ahead of reading (a gzip file:
    /// [`GZIP_RESERVE_RATIO`] times its compressed size).
    reserve: Option<u64>,
}

/// Bytes assumed for the reservations of a file whose size is unknown.
const UNKNOWN_SIZE_RESERVE: u64 = 1 << 26;

/// Parses the text whose first bytes are `first` (at most `window` of them;
/// fewer: all of it) and whose rest `rest` gives, in `format` (`Auto`: from
/// `first` and the name), without holding the file's text: Matrix Market
/// and Abaqus in windows of `window` bytes of whole lines
/// ([`mm::parse_reader_window`], [`abaqus::parse_reader_window`]),
/// Harwell-Boeing line by line ([`hb::parse_reader`]).
fn parse_stream(
    path: &Path,
    mut first: Vec<u8>,
    rest: &mut dyn Read,
    format: Format,
    size: Size,
    window: usize,
) -> Result<Triplets, Error> {
    let format = match format {
        Format::Auto => detect(path, &first).unwrap_or(Format::Auto),
        f => f,
    };
    let reserve = size.reserve;
    let mut t = match format {
        Format::MatrixMarket => mm::parse_reader_window(path, first, rest, reserve, window)?,
        Format::Abaqus => abaqus::parse_reader_window(path, first, rest, reserve, window)?,
        Format::HarwellBoeing => {
            let reserve = reserve.unwrap_or(UNKNOWN_SIZE_RESERVE);
            hb::parse_reader(path, first, rest, size.exact, reserve)?
        }
        Format::Auto => {
            rest.read_to_end(&mut first).map_err(|e| Error::Io {
                path: path.into(),
                message: e.to_string(),
            })?;
            return read_plain(path, &first, format);
        }
    };
    t.format = format;
    Ok(t)
}

/// Decompressed bytes per compressed byte assumed for the entries reserved
/// ahead from a `.mtx.gz` file's size line (Matrix Market text compresses
/// 3-5 times): a reservation bound only, more entries grow the arrays, and a
/// size line claiming more than the file can hold reserves no more.
const GZIP_RESERVE_RATIO: u64 = 32;

/// A gzip-compressed file's stream `compressed`, decompressed as it is
/// read and parsed as it comes ([`parse_stream`]: Matrix Market and Abaqus
/// text in windows of `window` bytes, Harwell-Boeing line by line); more than
/// `limit` decompressed bytes is an error naming the limit, and a broken
/// stream an error saying `gzip`. `reserve`: the data bytes that bound the
/// entries reserved ahead.
fn read_gzip(
    path: &Path,
    compressed: impl Read,
    format: Format,
    reserve: Option<u64>,
    window: usize,
    limit: u64,
) -> Result<Triplets, Error> {
    let io = |e: std::io::Error| Error::Io {
        path: path.into(),
        message: e.to_string(),
    };
    let mut dec = GzipLimit {
        inner: flate2::read::MultiGzDecoder::new(compressed),
        read: 0,
        limit,
    };
    let mut first = Vec::new();
    (&mut dec)
        .take(window as u64)
        .read_to_end(&mut first)
        .map_err(io)?;
    let size = Size {
        exact: None,
        reserve,
    };
    parse_stream(path, first, &mut dec, format, size, window)
}

/// A gzip decoder that counts what it gives and fails past `limit` bytes
/// (so a decompression bomb stops at the limit, not at the memory's end),
/// its errors prefixed `gzip:`.
struct GzipLimit<R> {
    inner: R,
    read: u64,
    limit: u64,
}

impl<R: Read> Read for GzipLimit<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self
            .inner
            .read(buf)
            .map_err(|e| std::io::Error::new(e.kind(), format!("gzip: {e}")))?;
        self.read += n as u64;
        if self.read > self.limit {
            return Err(std::io::Error::other(format!(
                "gzip: decompresses to more than {} bytes",
                self.limit
            )));
        }
        Ok(n)
    }
}

/// As [`read`] from the file's bytes (`path` names it in errors and gives the
/// extension for detection).
pub fn read_bytes(path: &Path, bytes: &[u8], format: Format) -> Result<Triplets, Error> {
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        let mut dec = flate2::read::MultiGzDecoder::new(bytes).take(MAX_DECOMPRESSED + 1);
        dec.read_to_end(&mut out).map_err(|e| Error::Io {
            path: path.into(),
            message: format!("gzip: {e}"),
        })?;
        if out.len() as u64 > MAX_DECOMPRESSED {
            return Err(Error::Io {
                path: path.into(),
                message: format!("gzip: decompresses to more than {MAX_DECOMPRESSED} bytes"),
            });
        }
        return read_plain(path, &out, format);
    }
    read_plain(path, bytes, format)
}

fn read_plain(path: &Path, bytes: &[u8], format: Format) -> Result<Triplets, Error> {
    let format = match format {
        Format::Auto => detect(path, bytes)
            .ok_or_else(|| parse_error(path, 1, Format::Auto, Detail::UnknownFormat))?,
        f => f,
    };
    let mut t = match format {
        Format::MatrixMarket | Format::Auto => mm::parse(path, bytes)?,
        Format::HarwellBoeing => hb::parse(path, bytes)?,
        Format::Abaqus => abaqus::parse(path, bytes)?,
    };
    t.format = format;
    Ok(t)
}

/// The format of a file from its (decompressed) content and name: a
/// `%%MatrixMarket` header; a `.rb`, `.rsa`, `.rua` (`.rra`, `.hb`, `.csa`, ...)
/// extension or a Harwell-Boeing header; Abaqus lines of 3 or 5 comma-separated
/// fields. `None` where none fits.
pub fn detect(path: &Path, bytes: &[u8]) -> Option<Format> {
    let head = &bytes[..bytes.len().min(4096)];
    if head.len() >= 14 && head[..14].eq_ignore_ascii_case(b"%%MatrixMarket") {
        return Some(Format::MatrixMarket);
    }
    let name = path.to_string_lossy().to_ascii_lowercase();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let ext = name.rsplit_once('.').map(|(_, e)| e).unwrap_or("");
    if matches!(
        ext,
        "rb" | "hb" | "rsa" | "rua" | "rra" | "psa" | "pua" | "rse" | "rue"
    ) {
        return Some(Format::HarwellBoeing);
    }
    if hb::looks_like_header(head) {
        return Some(Format::HarwellBoeing);
    }
    let line = text::lines(head)
        .map(|(_, l)| text::trim(l))
        .find(|l| !l.is_empty() && !l.starts_with(b"*"))?;
    let fields = line
        .split(|&b| b == b',')
        .filter(|f| !text::trim(f).is_empty());
    match fields.count() {
        3 | 5 => Some(Format::Abaqus),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// A coordinate file of `n` entries on the diagonal and the first
    /// subdiagonal (symmetric, lower triangle).
    fn text(n: usize) -> String {
        let mut t = format!(
            "%%MatrixMarket matrix coordinate real symmetric\n{n} {n} {}\n",
            2 * n - 1
        );
        for i in 1..=n {
            t.push_str(&format!("{i} {i} {}\n", 2.0 + i as f64 * 1e-3));
            if i > 1 {
                t.push_str(&format!("{i} {} -1.25e0\n", i - 1));
            }
        }
        t
    }

    fn gzip(t: &str) -> Vec<u8> {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        enc.write_all(t.as_bytes()).unwrap();
        enc.finish().unwrap()
    }

    /// Decompressed while parsed in windows much smaller than the file (4 KiB
    /// of a 250 kB text): the entries of the plain parse, exactly.
    #[test]
    fn gzip_matrix_market_streams_in_windows() {
        let t = text(10_000);
        let p = Path::new("K.mtx.gz");
        let z = gzip(&t);
        let streamed = read_gzip(
            p,
            &z[..],
            Format::Auto,
            Some(z.len() as u64 * 32),
            4096,
            1 << 30,
        )
        .unwrap();
        let plain = mm::parse(p, t.as_bytes()).unwrap();
        assert_eq!((streamed.nrows, streamed.ncols), (plain.nrows, plain.ncols));
        assert_eq!(streamed.rows, plain.rows);
        assert_eq!(streamed.cols, plain.cols);
        assert_eq!(streamed.vals, plain.vals);
        assert_eq!(streamed.format, Format::MatrixMarket);
        // a malformed line is named by its line in the decompressed text
        // (entry i below the diagonal: line 2 i + 1)
        let bad = t.replacen("5000 4999 -1.25e0", "5000 4999 nope", 1);
        let e = read_gzip(p, &gzip(&bad)[..], Format::Auto, None, 4096, 1 << 30).unwrap_err();
        assert_eq!(e.line(), Some(2 * 5000 + 1), "{e}");
    }

    /// More decompressed bytes than the limit, and a stream cut short: Io
    /// errors naming the file and `gzip`.
    #[test]
    fn gzip_limit_and_truncation_are_errors() {
        let t = text(10_000);
        let p = Path::new("K.mtx.gz");
        let z = gzip(&t);
        let e = read_gzip(p, &z[..], Format::Auto, None, 4096, 100_000).unwrap_err();
        assert!(
            matches!(e, Error::Io { .. }) && e.to_string().contains("more than 100000 bytes"),
            "{e}"
        );
        let e = read_gzip(p, &z[..z.len() / 2], Format::Auto, None, 4096, 1 << 30).unwrap_err();
        assert!(e.to_string().contains("K.mtx.gz"), "{e}");
    }
}
