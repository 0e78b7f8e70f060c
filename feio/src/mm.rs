//! Matrix Market (NIST): the header `%%MatrixMarket matrix <format> <field>
//! <symmetry>`, `%` comment lines, the size line (`rows cols nnz` for
//! `coordinate`, `rows cols` for `array`), then one entry per line
//! (`row col value`, 1-based; `array`: the values by columns, the lower
//! triangle's for `symmetric`).
//!
//! Coordinate data is split into line-aligned chunks parsed in parallel
//! (rayon) above [`PARALLEL_MIN_BYTES`]; a chunk's lines are numbered after
//! the fact, so an error still names its line.
use crate::text::{self, shown, skip_ws, uint};
use crate::{parse_error, Detail, Error, Format, Triplets, MAX_DIM};
use rayon::prelude::*;
use std::path::Path;

/// Coordinate data of at least this many bytes is parsed on all threads.
pub const PARALLEL_MIN_BYTES: usize = 4 << 20;

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
    let (rows, cols, vals) = match h.layout {
        Layout::Coordinate => coordinate_entries(path, data, &size, h)?,
        Layout::Array => array_values(path, data, &size, h)?,
    };
    Ok(Triplets {
        nrows: size.nrows,
        ncols: size.ncols,
        rows,
        cols,
        vals,
        symmetric_storage: h.symmetric,
        labels: None,
        format: F,
    })
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
    let (nrows, ncols, symmetric) = (size.nrows, size.ncols, h.symmetric);
    let size_line_no = size.line;
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
            size_line_no,
            Detail::TooLarge {
                what: "entries",
                value: nnz,
                limit: full,
            },
        ));
    }
    let ctx = Ctx {
        nrows,
        ncols,
        symmetric,
        field: h.field,
    };
    let chunks = chunks(data);
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
    check_entry_count(path, data, size_line_no, nnz, &chunks, &outs)?;
    let n = nnz as usize;
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    if outs.len() == 1 {
        let o = outs.into_iter().next().unwrap_or_default();
        (rows, cols, vals) = (o.rows, o.cols, o.vals);
    } else {
        rows.reserve_exact(n);
        cols.reserve_exact(n);
        vals.reserve_exact(n);
        for o in outs {
            rows.extend_from_slice(&o.rows);
            cols.extend_from_slice(&o.cols);
            vals.extend_from_slice(&o.vals);
        }
    }
    Ok((rows, cols, vals))
}

/// The chunks' first error in file order (its line counted over the chunks
/// before it), then the number of entries against `nnz`: too many names the
/// line of entry `nnz + 1`, too few the file's end.
fn check_entry_count(
    path: &Path,
    data: &[u8],
    size_line_no: usize,
    nnz: u64,
    chunks: &[std::ops::Range<usize>],
    outs: &[Chunk],
) -> Result<(), Error> {
    // the first error in file order; lines counted before its chunk
    for (k, o) in outs.iter().enumerate() {
        if let Some((l, d)) = &o.err {
            let before = count_lines(&data[..chunks[k].start]);
            return Err(err(path, size_line_no + before + l, d.clone()));
        }
    }
    let found: u64 = outs.iter().map(|o| o.vals.len() as u64).sum();
    if found > nnz {
        // the line of entry nnz + 1
        let mut seen = 0u64;
        for (k, o) in outs.iter().enumerate() {
            if seen + o.vals.len() as u64 > nnz {
                let chunk = &data[chunks[k].clone()];
                let l = nth_entry_line(chunk, (nnz - seen) as usize);
                let before = count_lines(&data[..chunks[k].start]);
                return Err(err(
                    path,
                    size_line_no + before + l,
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
    if found < nnz {
        return Err(err(
            path,
            size_line_no + count_lines(data),
            Detail::Count {
                what: "entries (the size line's count): the file ends early",
                expected: nnz,
                found,
            },
        ));
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

/// Line-aligned byte ranges of `data`: one below [`PARALLEL_MIN_BYTES`], else
/// about four per thread.
fn chunks(data: &[u8]) -> Vec<std::ops::Range<usize>> {
    let threads = rayon::current_num_threads().max(1);
    if data.len() < PARALLEL_MIN_BYTES || threads == 1 {
        return std::iter::once(0..data.len()).collect();
    }
    let target = (data.len() / (4 * threads)).max(1 << 20);
    let mut out = Vec::new();
    let mut start = 0;
    while start < data.len() {
        let mut end = (start + target).min(data.len());
        if end < data.len() {
            end = data[end..]
                .iter()
                .position(|&c| c == b'\n')
                .map_or(data.len(), |i| end + i + 1);
        }
        out.push(start..end);
        start = end;
    }
    out
}

fn count_lines(b: &[u8]) -> usize {
    b.iter().filter(|&&c| c == b'\n').count()
        + usize::from(!b.is_empty() && b[b.len() - 1] != b'\n')
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
