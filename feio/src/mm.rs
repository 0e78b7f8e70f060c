//! Matrix Market (NIST): the header `%%MatrixMarket matrix <format> <field>
//! <symmetry>`, `%` comment lines, the size line (`rows cols nnz` for
//! `coordinate`, `rows cols` for `array`), then one entry per line
//! (`row col value`, 1-based; `array`: the values by columns, the lower
//! triangle's for `symmetric`).
//!
//! Coordinate data is split into line-aligned chunks parsed in parallel
//! (rayon) above [`PARALLEL_MIN_BYTES`]; a chunk's lines are numbered after
//! the fact, so an error still names its line.
use crate::text::{self, count_lines, line_chunks as chunks, shown, skip_ws, uint};
use crate::{parse_error, Detail, Error, Format, Triplets, MAX_DIM};
use rayon::prelude::*;
use std::io::Read;
use std::path::Path;

/// Coordinate data of at least this many bytes is parsed on all threads.
pub use crate::text::PARALLEL_MIN_BYTES;

const F: Format = Format::MatrixMarket;

#[derive(Clone, Copy, PartialEq)]
enum Layout {
    Coordinate,
    Array,
}

#[derive(Clone, Copy, PartialEq)]
enum Field {
    Real,
    Integer,
}

/// Parses a Matrix Market file's bytes (not compressed).
pub fn parse(path: &Path, b: &[u8]) -> Result<Triplets, Error> {
    let (first, pos) = match b.iter().position(|&c| c == b'\n') {
        Some(i) => (&b[..i], i + 1),
        None => (b, b.len()),
    };
    let h = header(path, first)?;
    let size = size_line(path, b, pos, h)?;
    let data = &b[size.data_start..];
    let entries = match h.layout {
        Layout::Coordinate => coordinate_entries(path, data, &size, h)?,
        Layout::Array => array_values(path, data, &size, h)?,
    };
    Ok(Triplets::unlabelled(
        (size.nrows, size.ncols),
        entries,
        h.symmetric,
        F,
    ))
}

/// The error at `line` of `path`.
fn err(path: &Path, line: usize, detail: Detail) -> Error {
    parse_error(path, line, F, detail)
}

/// "expected `what`, found `found`" at `line` of `path`.
fn expected(path: &Path, line: usize, what: &str, found: &[u8]) -> Error {
    crate::expected_error(path, line, F, what, found)
}

/// The header line's format, field and symmetry.
#[derive(Clone, Copy)]
struct Header {
    layout: Layout,
    field: Field,
    symmetric: bool,
}

/// The header `%%MatrixMarket matrix <format> <field> <symmetry>` (line 1).
fn header(path: &Path, first: &[u8]) -> Result<Header, Error> {
    let tokens: Vec<String> = String::from_utf8_lossy(first)
        .split_whitespace()
        .map(|t| t.to_ascii_lowercase())
        .collect();
    let header =
        "the header `%%MatrixMarket matrix coordinate|array real|integer general|symmetric`";
    if tokens.len() != 5 || tokens[0] != "%%matrixmarket" || tokens[1] != "matrix" {
        return Err(expected(path, 1, header, first));
    }
    let layout = match tokens[2].as_str() {
        "coordinate" => Layout::Coordinate,
        "array" => Layout::Array,
        _ => {
            return Err(expected(
                path,
                1,
                "format `coordinate` or `array`",
                tokens[2].as_bytes(),
            ))
        }
    };
    let field = header_field(path, &tokens[3])?;
    let symmetric = match tokens[4].as_str() {
        "general" => false,
        "symmetric" => true,
        "skew-symmetric" | "hermitian" => {
            return Err(err(
                path,
                1,
                Detail::Unsupported(format!(
                    "`{}` storage: mass, stiffness and damping matrices are real symmetric; \
                     write them `general` or `symmetric`",
                    tokens[4]
                )),
            ))
        }
        _ => {
            return Err(expected(
                path,
                1,
                "symmetry `general` or `symmetric`",
                tokens[4].as_bytes(),
            ))
        }
    };
    Ok(Header {
        layout,
        field,
        symmetric,
    })
}

/// The header's field token (`real`, `double` or `integer`).
fn header_field(path: &Path, token: &str) -> Result<Field, Error> {
    match token {
        "real" | "double" => Ok(Field::Real),
        "integer" => Ok(Field::Integer),
        "pattern" => Err(err(
            path,
            1,
            Detail::Unsupported(
                "a `pattern` matrix has no values: a mass, stiffness or damping matrix needs \
                 `real` (or `integer`) values"
                    .into(),
            ),
        )),
        "complex" => Err(err(
            path,
            1,
            Detail::Unsupported(
                "a `complex` matrix: mass, stiffness and damping matrices are real".into(),
            ),
        )),
        _ => Err(expected(
            path,
            1,
            "field `real` or `integer`",
            token.as_bytes(),
        )),
    }
}

/// The size line: the matrix's dimensions, the entry count (`coordinate`),
/// where the size line is and where the data after it starts.
struct Size {
    nrows: usize,
    ncols: usize,
    /// `coordinate`: the entries the size line announces.
    nnz: Option<u64>,
    /// 1-based line of the size line.
    line: usize,
    /// Byte offset of the data after the size line.
    data_start: usize,
}

/// The comment lines after the header (from byte `pos`), then the size line
/// (`rows cols nnz` or `rows cols`), checked against [`MAX_DIM`] and, for
/// `symmetric`, squareness.
fn size_line(path: &Path, b: &[u8], mut pos: usize, h: Header) -> Result<Size, Error> {
    let mut line = 1usize;
    let size_line = loop {
        if pos >= b.len() {
            return Err(expected(path, line + 1, "the size line", b""));
        }
        line += 1;
        let end = b[pos..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(b.len(), |i| pos + i);
        let l = text::trim(&b[pos..end]);
        pos = (end + 1).min(b.len());
        if !l.is_empty() && l[0] != b'%' {
            break l;
        }
    };
    let what = match h.layout {
        Layout::Coordinate => "the size line `rows columns entries`",
        Layout::Array => "the size line `rows columns`",
    };
    let nums: Vec<Option<u64>> = size_line
        .split(|c| text::is_blank(*c))
        .filter(|t| !t.is_empty())
        .map(text::uint_field)
        .collect();
    let want = if h.layout == Layout::Coordinate { 3 } else { 2 };
    if nums.len() != want || nums.iter().any(|n| n.is_none()) {
        return Err(expected(path, line, what, size_line));
    }
    let nums: Vec<u64> = nums.into_iter().flatten().collect();
    for (k, name) in [(0, "rows"), (1, "columns")] {
        if nums[k] > MAX_DIM as u64 {
            return Err(err(
                path,
                line,
                Detail::TooLarge {
                    what: name,
                    value: nums[k],
                    limit: MAX_DIM as u64,
                },
            ));
        }
    }
    let (nrows, ncols) = (nums[0] as usize, nums[1] as usize);
    if h.symmetric && nrows != ncols {
        return Err(err(
            path,
            line,
            Detail::Unsupported(format!(
                "a symmetric matrix must be square, the size line says {nrows}x{ncols}"
            )),
        ));
    }
    Ok(Size {
        nrows,
        ncols,
        nnz: nums.get(2).copied(),
        line,
        data_start: pos,
    })
}

/// The triplets (row indices, column indices, values).
type Entries = (Vec<usize>, Vec<usize>, Vec<f64>);

/// `coordinate` data: the entries, parsed in line-aligned chunks (in
/// parallel above [`PARALLEL_MIN_BYTES`]); the first error in file order,
/// then the count against the size line's.
fn coordinate_entries(path: &Path, data: &[u8], size: &Size, h: Header) -> Result<Entries, Error> {
    let mut s = Stream::new(path, size, h, data.len() as u64)?;
    s.window(data)?;
    s.finish()
}

/// The coordinate entries of a file read in windows of whole lines
/// ([`Stream::window`]), so that the file's text is never held whole: the
/// entries so far and the lines before the current window (for the errors'
/// line numbers).
struct Stream<'p> {
    path: &'p Path,
    ctx: Ctx,
    nnz: u64,
    size_line_no: usize,
    lines_before: usize,
    rows: Vec<usize>,
    cols: Vec<usize>,
    vals: Vec<f64>,
}

impl<'p> Stream<'p> {
    /// After the size line; `data_bytes` (the bytes of data the file can
    /// hold) bounds what is reserved from the size line's count.
    fn new(path: &'p Path, size: &Size, h: Header, data_bytes: u64) -> Result<Self, Error> {
        let (nrows, ncols, symmetric) = (size.nrows, size.ncols, h.symmetric);
        let nnz = size.nnz.unwrap_or(0);
        // more entries than the matrix has places: refused before reading on
        // (a smaller wrong count is found at the end, naming the line)
        let full = if symmetric {
            (nrows as u64) * (nrows as u64 + 1) / 2
        } else {
            nrows as u64 * ncols as u64
        };
        if nnz > full {
            return Err(err(
                path,
                size.line,
                Detail::TooLarge {
                    what: "entries",
                    value: nnz,
                    limit: full,
                },
            ));
        }
        // an entry line has at least 6 bytes (`1 1 1\n`)
        let cap = nnz.min(data_bytes / 6) as usize;
        Ok(Self {
            path,
            ctx: Ctx {
                nrows,
                ncols,
                symmetric,
                field: h.field,
            },
            nnz,
            size_line_no: size.line,
            lines_before: 0,
            rows: Vec::with_capacity(cap),
            cols: Vec::with_capacity(cap),
            vals: Vec::with_capacity(cap),
        })
    }

    /// The entries of `data` (whole lines, the next ones of the file).
    fn window(&mut self, data: &[u8]) -> Result<(), Error> {
        let chunks = chunks(data);
        let ctx = self.ctx;
        let outs: Vec<Chunk> = if chunks.len() > 1 {
            chunks
                .par_iter()
                .map(|r| parse_chunk(&data[r.clone()], ctx))
                .collect()
        } else {
            chunks
                .iter()
                .map(|r| parse_chunk(&data[r.clone()], ctx))
                .collect()
        };
        let base = self.size_line_no + self.lines_before;
        let seen = self.vals.len() as u64;
        check_entry_count(self.path, data, base, self.nnz, seen, &chunks, &outs)?;
        for o in outs {
            self.rows.extend_from_slice(&o.rows);
            self.cols.extend_from_slice(&o.cols);
            self.vals.extend_from_slice(&o.vals);
        }
        self.lines_before += count_lines(data);
        Ok(())
    }

    /// The entries, after the count check at the end of the file.
    fn finish(self) -> Result<Entries, Error> {
        let found = self.vals.len() as u64;
        if found < self.nnz {
            return Err(err(
                self.path,
                self.size_line_no + self.lines_before,
                Detail::Count {
                    what: "entries (the size line's count): the file ends early",
                    expected: self.nnz,
                    found,
                },
            ));
        }
        Ok((self.rows, self.cols, self.vals))
    }
}

/// Bytes of Matrix Market text read and parsed at a time by [`parse_reader`].
pub const WINDOW_BYTES: usize = 64 << 20;

/// Parses a Matrix Market file whose first bytes are `buf` (at most
/// `WINDOW_BYTES` of them; fewer: the whole file) and whose rest `rest`
/// gives: `coordinate` data is read and parsed in windows of about
/// [`WINDOW_BYTES`] of whole lines (each in parallel chunks), so that the
/// memory is the entries plus one window, not the file's text; `array` data,
/// or a header and size line longer than the first window, is read whole and
/// parsed by [`parse`]. `file_bytes` (the file's size, if known) bounds what
/// is reserved.
pub fn parse_reader(
    path: &Path,
    buf: Vec<u8>,
    rest: &mut dyn Read,
    file_bytes: Option<u64>,
) -> Result<Triplets, Error> {
    parse_reader_window(path, buf, rest, file_bytes, WINDOW_BYTES)
}

/// As [`parse_reader`] with windows of `window` bytes (`buf`: the first
/// `window` bytes of the file, or all of it).
pub fn parse_reader_window(
    path: &Path,
    mut buf: Vec<u8>,
    rest: &mut dyn Read,
    file_bytes: Option<u64>,
    window: usize,
) -> Result<Triplets, Error> {
    let io = |e: std::io::Error| Error::Io {
        path: path.into(),
        message: e.to_string(),
    };
    let head = buf.iter().position(|&c| c == b'\n').and_then(|i| {
        let h = header(path, &buf[..i]).ok()?;
        let size = size_line(path, &buf, i + 1, h).ok()?;
        // the size line ends inside the buffer (not cut by its end)
        (h.layout == Layout::Coordinate && size.data_start < buf.len()).then_some((h, size))
    });
    let Some((h, size)) = head.filter(|_| buf.len() >= window) else {
        rest.read_to_end(&mut buf).map_err(io)?;
        return parse(path, &buf);
    };
    let data_bytes = file_bytes.map_or(u64::MAX, |b| b.saturating_sub(size.data_start as u64));
    let mut s = Stream::new(path, &size, h, data_bytes)?;
    buf.drain(..size.data_start);
    crate::text::for_each_window(path, buf, rest, window, |w| s.window(w))?;
    Ok(Triplets::unlabelled(
        (size.nrows, size.ncols),
        s.finish()?,
        h.symmetric,
        F,
    ))
}

/// The chunks' first error in file order (its line counted over the chunks
/// before it, `base` the lines before `data`), then the number of entries
/// (`seen` before `data`) against `nnz`: too many names the line of entry
/// `nnz + 1`.
fn check_entry_count(
    path: &Path,
    data: &[u8],
    base: usize,
    nnz: u64,
    seen: u64,
    chunks: &[std::ops::Range<usize>],
    outs: &[Chunk],
) -> Result<(), Error> {
    // the first error in file order; lines counted before its chunk
    for (k, o) in outs.iter().enumerate() {
        if let Some((l, d)) = &o.err {
            let before = count_lines(&data[..chunks[k].start]);
            return Err(err(path, base + before + l, d.clone()));
        }
    }
    let found: u64 = seen + outs.iter().map(|o| o.vals.len() as u64).sum::<u64>();
    if found > nnz {
        // the line of entry nnz + 1
        let mut seen = seen;
        for (k, o) in outs.iter().enumerate() {
            if seen + o.vals.len() as u64 > nnz {
                let chunk = &data[chunks[k].clone()];
                let l = nth_entry_line(chunk, (nnz - seen) as usize);
                let before = count_lines(&data[..chunks[k].start]);
                return Err(err(
                    path,
                    base + before + l,
                    Detail::Count {
                        what: "entries (the size line's count)",
                        expected: nnz,
                        found,
                    },
                ));
            }
            seen += o.vals.len() as u64;
        }
    }
    Ok(())
}

/// `array` data: the values by columns (from the diagonal down for
/// `symmetric`), exactly as many as the matrix (or its lower triangle) has.
fn array_values(path: &Path, data: &[u8], size: &Size, h: Header) -> Result<Entries, Error> {
    let (nrows, ncols, symmetric, field) = (size.nrows, size.ncols, h.symmetric, h.field);
    let size_line_no = size.line;
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    let total = if symmetric {
        nrows as u64 * (nrows as u64 + 1) / 2
    } else {
        nrows as u64 * ncols as u64
    };
    // a value takes at least 2 bytes: no more reserved than the file holds
    let cap = total.min((data.len() as u64).div_ceil(2)) as usize;
    let total = total as usize;
    rows.reserve_exact(cap);
    cols.reserve_exact(cap);
    vals.reserve_exact(cap);
    let (mut r, mut c) = (0usize, 0usize);
    let mut last = size_line_no;
    for (l, text) in text::lines(data) {
        last = size_line_no + l;
        let t = text::trim(text);
        if t.is_empty() || t[0] == b'%' {
            continue;
        }
        for tok in t.split(|c| text::is_blank(*c)).filter(|t| !t.is_empty()) {
            if vals.len() == total {
                return Err(err(
                    path,
                    last,
                    Detail::Count {
                        what: "values (rows x columns)",
                        expected: total as u64,
                        found: total as u64 + 1,
                    },
                ));
            }
            let v = value(tok, field).ok_or_else(|| expected(path, last, "a number", tok))?;
            if !v.is_finite() {
                return Err(err(
                    path,
                    last,
                    Detail::NonFinite {
                        row: r,
                        col: c,
                        value: v,
                    },
                ));
            }
            rows.push(r);
            cols.push(c);
            vals.push(v);
            r += 1;
            if r == nrows {
                c += 1;
                r = if symmetric { c } else { 0 };
            }
        }
    }
    if vals.len() < total {
        return Err(err(
            path,
            last,
            Detail::Count {
                what: "values (rows x columns): the file ends early",
                expected: total as u64,
                found: vals.len() as u64,
            },
        ));
    }
    Ok((rows, cols, vals))
}

fn value(tok: &[u8], field: Field) -> Option<f64> {
    match field {
        Field::Real => text::real_field(tok),
        Field::Integer => {
            let t = text::trim(tok);
            let (neg, digits) = match t.first() {
                Some(b'-') => (true, &t[1..]),
                Some(b'+') => (false, &t[1..]),
                _ => (false, t),
            };
            let v = text::uint_field(digits)? as f64;
            Some(if neg { -v } else { v })
        }
    }
}

#[derive(Clone, Copy)]
struct Ctx {
    nrows: usize,
    ncols: usize,
    symmetric: bool,
    field: Field,
}

#[derive(Default)]
struct Chunk {
    rows: Vec<usize>,
    cols: Vec<usize>,
    vals: Vec<f64>,
    /// (1-based line within the chunk, what is wrong)
    err: Option<(usize, Detail)>,
}

/// 1-based line (within `chunk`) of its `k`-th (0-based) entry.
fn nth_entry_line(chunk: &[u8], k: usize) -> usize {
    text::lines(chunk)
        .filter(|(_, l)| {
            let t = text::trim(l);
            !t.is_empty() && t[0] != b'%'
        })
        .nth(k)
        .map_or(1, |(l, _)| l)
}

/// The coordinate entries of one chunk (whole lines).
fn parse_chunk(b: &[u8], ctx: Ctx) -> Chunk {
    let cap = (b.len() / 24).min(1 << 24);
    let mut out = Chunk {
        rows: Vec::with_capacity(cap),
        cols: Vec::with_capacity(cap),
        vals: Vec::with_capacity(cap),
        err: None,
    };
    let mut p = 0usize;
    let mut line = 0usize;
    let n = b.len();
    while p < n {
        line += 1;
        skip_ws(b, &mut p);
        if p >= n {
            break;
        }
        match b[p] {
            b'\n' => {
                p += 1;
                continue;
            }
            b'\r' | b'%' => {
                p = b[p..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(n, |i| p + i + 1);
                continue;
            }
            _ => {}
        }
        match entry(b, &mut p, ctx) {
            Ok((r, c, v)) => {
                out.rows.push(r);
                out.cols.push(c);
                out.vals.push(v);
            }
            Err(d) => {
                out.err = Some((line, d));
                return out;
            }
        }
    }
    out
}

/// One `row col value` line from `*p` (at its first token) through its `\n`.
#[inline]
fn entry(b: &[u8], p: &mut usize, ctx: Ctx) -> Result<(usize, usize, f64), Detail> {
    let start = *p;
    let rest = |p: usize| {
        let end = b[p..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(b.len(), |i| p + i);
        shown(&b[p..end])
    };
    let bad = |what: &str, at: usize| Detail::Expected {
        expected: what.into(),
        found: rest(at),
    };
    let r = uint(b, p).ok_or_else(|| bad("a row index", *p))?;
    let sep = *p;
    skip_ws(b, p);
    if *p == sep {
        return Err(bad("a row index and a column index", start));
    }
    let c = uint(b, p).ok_or_else(|| bad("a column index", *p))?;
    let sep = *p;
    skip_ws(b, p);
    if *p == sep {
        return Err(bad("a column index, then a value", sep));
    }
    let v = match ctx.field {
        Field::Real => match fast_float2::parse_partial::<f64, _>(&b[*p..]) {
            Ok((v, k)) if k > 0 => {
                *p += k;
                v
            }
            _ => return Err(bad("a value", *p)),
        },
        Field::Integer => {
            let s = *p;
            let neg = matches!(b.get(*p), Some(b'-'));
            if matches!(b.get(*p), Some(b'-' | b'+')) {
                *p += 1;
            }
            let v = uint(b, p).ok_or_else(|| bad("an integer value", s))? as f64;
            if neg {
                -v
            } else {
                v
            }
        }
    };
    skip_ws(b, p);
    match b.get(*p) {
        None => {}
        Some(b'\n') => *p += 1,
        Some(b'\r') if matches!(b.get(*p + 1), None | Some(b'\n')) => *p += 2,
        Some(_) => return Err(bad("the end of the line after `row col value`", *p)),
    }
    *p = (*p).min(b.len());
    if r == 0 || r > ctx.nrows as u64 {
        return Err(Detail::OutOfRange {
            what: "row",
            value: r,
            min: 1,
            max: ctx.nrows as u64,
        });
    }
    if c == 0 || c > ctx.ncols as u64 {
        return Err(Detail::OutOfRange {
            what: "column",
            value: c,
            min: 1,
            max: ctx.ncols as u64,
        });
    }
    let (r, c) = (r as usize - 1, c as usize - 1);
    if !v.is_finite() {
        return Err(Detail::NonFinite {
            row: r,
            col: c,
            value: v,
        });
    }
    if ctx.symmetric && r < c {
        return Err(Detail::Unsupported(format!(
            "entry ({}, {}) is in the upper triangle: a `symmetric` file stores the lower triangle",
            r + 1,
            c + 1
        )));
    }
    Ok((r, c, v))
}
