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
    let err = |line, detail| parse_error(path, line, F, detail);
    let expected = |line, what: &str, found: &[u8]| {
        err(
            line,
            Detail::Expected {
                expected: what.into(),
                found: shown(found),
            },
        )
    };
    // header
    let (first, mut pos) = match b.iter().position(|&c| c == b'\n') {
        Some(i) => (&b[..i], i + 1),
        None => (b, b.len()),
    };
    let tokens: Vec<String> = String::from_utf8_lossy(first)
        .split_whitespace()
        .map(|t| t.to_ascii_lowercase())
        .collect();
    let header =
        "the header `%%MatrixMarket matrix coordinate|array real|integer general|symmetric`";
    if tokens.len() != 5 || tokens[0] != "%%matrixmarket" || tokens[1] != "matrix" {
        return Err(expected(1, header, first));
    }
    let layout = match tokens[2].as_str() {
        "coordinate" => Layout::Coordinate,
        "array" => Layout::Array,
        _ => {
            return Err(expected(
                1,
                "format `coordinate` or `array`",
                tokens[2].as_bytes(),
            ))
        }
    };
    let field =
        match tokens[3].as_str() {
            "real" | "double" => Field::Real,
            "integer" => Field::Integer,
            "pattern" => return Err(err(
                1,
                Detail::Unsupported(
                    "a `pattern` matrix has no values: a mass, stiffness or damping matrix needs \
                     `real` (or `integer`) values"
                        .into(),
                ),
            )),
            "complex" => {
                return Err(err(
                    1,
                    Detail::Unsupported(
                        "a `complex` matrix: mass, stiffness and damping matrices are real".into(),
                    ),
                ))
            }
            _ => {
                return Err(expected(
                    1,
                    "field `real` or `integer`",
                    tokens[3].as_bytes(),
                ))
            }
        };
    let symmetric = match tokens[4].as_str() {
        "general" => false,
        "symmetric" => true,
        "skew-symmetric" | "hermitian" => {
            return Err(err(
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
                1,
                "symmetry `general` or `symmetric`",
                tokens[4].as_bytes(),
            ))
        }
    };
    // comments, then the size line
    let mut line = 1usize;
    let size_line = loop {
        if pos >= b.len() {
            return Err(expected(line + 1, "the size line", b""));
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
    let what = match layout {
        Layout::Coordinate => "the size line `rows columns entries`",
        Layout::Array => "the size line `rows columns`",
    };
    let nums: Vec<Option<u64>> = size_line
        .split(|c| text::is_blank(*c))
        .filter(|t| !t.is_empty())
        .map(text::uint_field)
        .collect();
    let want = if layout == Layout::Coordinate { 3 } else { 2 };
    if nums.len() != want || nums.iter().any(|n| n.is_none()) {
        return Err(expected(line, what, size_line));
    }
    let nums: Vec<u64> = nums.into_iter().flatten().collect();
    for (k, name) in [(0, "rows"), (1, "columns")] {
        if nums[k] > MAX_DIM as u64 {
            return Err(err(
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
    if symmetric && nrows != ncols {
        return Err(err(
            line,
            Detail::Unsupported(format!(
                "a symmetric matrix must be square, the size line says {nrows}x{ncols}"
            )),
        ));
    }
    let data = &b[pos..];
    let size_line_no = line;
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    match layout {
        Layout::Coordinate => {
            let nnz = nums[2];
            // more entries than the matrix has places: refused before reading on
            // (a smaller wrong count is found at the end, naming the line)
            let full = if symmetric {
                (nrows as u64) * (nrows as u64 + 1) / 2
            } else {
                nrows as u64 * ncols as u64
            };
            if nnz > full {
                return Err(err(
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
                field,
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
            // the first error in file order; lines counted before its chunk
            for (k, o) in outs.iter().enumerate() {
                if let Some((l, d)) = &o.err {
                    let before = count_lines(&data[..chunks[k].start]);
                    return Err(err(size_line_no + before + l, d.clone()));
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
                    size_line_no + count_lines(data),
                    Detail::Count {
                        what: "entries (the size line's count): the file ends early",
                        expected: nnz,
                        found,
                    },
                ));
            }
            let n = nnz as usize;
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
        }
        Layout::Array => {
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
                            last,
                            Detail::Count {
                                what: "values (rows x columns)",
                                expected: total as u64,
                                found: total as u64 + 1,
                            },
                        ));
                    }
                    let v = value(tok, field).ok_or_else(|| expected(last, "a number", tok))?;
                    if !v.is_finite() {
                        return Err(err(
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
                    last,
                    Detail::Count {
                        what: "values (rows x columns): the file ends early",
                        expected: total as u64,
                        found: vals.len() as u64,
                    },
                ));
            }
        }
    }
    Ok(Triplets {
        nrows,
        ncols,
        rows,
        cols,
        vals,
        symmetric_storage: symmetric,
        labels: None,
        format: F,
    })
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
