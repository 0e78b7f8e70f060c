//! Harwell-Boeing and Rutherford-Boeing (`.rb`, `.rsa`, `.rua`: what ANSYS'
//! HBMAT writes): compressed columns in fixed-format Fortran records.
//!
//! ```text
//! line 1  title (A72), key (A8)
//! line 2  TOTCRD PTRCRD INDCRD VALCRD [RHSCRD]      (I14 each; Rutherford-Boeing: 4)
//! line 3  MXTYPE (A3), NROW NCOL NNZERO [NELTVL]     (I14 each, from column 15)
//! line 4  PTRFMT (A16) INDFMT (A16) VALFMT (A20) [RHSFMT (A20)]
//! line 5  RHSTYP ... only when RHSCRD > 0 (Harwell-Boeing)
//! then    NCOL+1 column pointers, NNZERO row indices (1-based), NNZERO values
//! ```
//!
//! `MXTYPE`: `R` real or `I` integer (`P` pattern and `C` complex refused);
//! `S` symmetric (the lower triangle), `U` unsymmetric, `R` rectangular, `H`
//! (real: symmetric), `Z` skew refused; `A` assembled (`E` elemental refused).
//! Fields are read by their widths from the formats (`(10I8)`, `(1P,4E20.12)`,
//! `(5D16.8)`), so fields without a space between them are read, as are `D`
//! exponents and Fortran's exponent without a letter (`1.5-100`).
use crate::text::{self, shown};
use crate::{parse_error, Detail, Error, Format, Triplets, MAX_DIM};
use std::io::{BufRead, Read};
use std::path::Path;

const F: Format = Format::HarwellBoeing;

/// Whether `head` begins like a Harwell-Boeing file (line 2 of 4 or 5
/// integers, line 3 starting with a matrix type such as `RSA`).
pub fn looks_like_header(head: &[u8]) -> bool {
    let mut it = text::lines(head).map(|(_, l)| l);
    let (Some(_), Some(l2), Some(l3)) = (it.next(), it.next(), it.next()) else {
        return false;
    };
    let ints = l2
        .split(|c| text::is_blank(*c))
        .filter(|t| !t.is_empty())
        .map(text::uint_field)
        .collect::<Option<Vec<_>>>();
    let ok2 = matches!(ints, Some(v) if v.len() == 4 || v.len() == 5);
    let t = l3.get(..3).map(|t| t.to_ascii_uppercase());
    let ok3 = matches!(t.as_deref(), Some([a, b, c]) if b"RCPI".contains(a) && b"SUHZR".contains(b) && b"AE".contains(c));
    ok2 && ok3
}

/// A Fortran edit descriptor `(rIw)`, `(rEw.d)`, ...: `repeat` fields of
/// `width` characters per record.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Fmt {
    repeat: usize,
    width: usize,
}

fn fortran_format(s: &[u8]) -> Option<Fmt> {
    let s: Vec<u8> = s
        .iter()
        .filter(|c| !c.is_ascii_whitespace())
        .map(|c| c.to_ascii_uppercase())
        .collect();
    let s = s.strip_prefix(b"(")?.strip_suffix(b")")?;
    // an optional scale factor `kP` (with or without a comma)
    let mut p = 0;
    let lead = text::uint(s, &mut p);
    let s = if s.get(p) == Some(&b'P') {
        let rest = &s[p + 1..];
        rest.strip_prefix(b",").unwrap_or(rest)
    } else {
        let _ = lead;
        s
    };
    let mut p = 0;
    let repeat = text::uint(s, &mut p).unwrap_or(1) as usize;
    let letter = *s.get(p)?;
    if !b"IEDFG".contains(&letter) {
        return None;
    }
    p += 1;
    let width = text::uint(s, &mut p)? as usize;
    if s.get(p) == Some(&b'.') {
        p += 1;
        text::uint(s, &mut p)?;
        // an exponent width `Ee` (E20.12E3)
        if s.get(p) == Some(&b'E') {
            p += 1;
            text::uint(s, &mut p)?;
        }
    }
    (p == s.len() && (1..=1000).contains(&repeat) && (1..=100).contains(&width))
        .then_some(Fmt { repeat, width })
}

/// A Fortran real field: `D` exponents, an exponent sign without a letter.
fn fortran_real(f: &[u8]) -> Option<f64> {
    let f = text::trim(f);
    if f.is_empty() || f.len() > 100 {
        return None;
    }
    let mut buf = [0u8; 104];
    let mut n = 0;
    let mut has_exp = false;
    for (i, &c) in f.iter().enumerate() {
        let c = match c {
            b'D' | b'd' | b'E' | b'e' => {
                has_exp = true;
                b'e'
            }
            b'+' | b'-' if i > 0 && !has_exp && f[i - 1] != b'e' && f[i - 1] != b'E' => {
                // `1.5-100`: the exponent's letter omitted
                buf[n] = b'e';
                n += 1;
                has_exp = true;
                c
            }
            c => c,
        };
        buf[n] = c;
        n += 1;
    }
    text::real_field(&buf[..n])
}

/// What one section holds: `count` values in records of `fmt`; at most
/// `max_fields` reserved (what the rest of the file can hold).
struct Want {
    count: usize,
    max_fields: usize,
    fmt: Fmt,
    what: &'static str,
}

/// `(index of its first value, its line)` of each record of a section.
type Records = Vec<(usize, usize)>;

/// The file's lines one at a time, numbered from 1, without their `\n` and a
/// trailing `\r` (as [`text::lines`]): each line is borrowed until the next is
/// read, so a file is parsed holding one line of its text, not all of it.
struct Lines<'p, R> {
    path: &'p Path,
    inner: R,
    buf: Vec<u8>,
    n: usize,
}

impl<'p, R: BufRead> Lines<'p, R> {
    fn new(path: &'p Path, inner: R) -> Self {
        Lines {
            path,
            inner,
            buf: Vec::new(),
            n: 0,
        }
    }

    /// The next line and its number, `None` at the end of the file.
    fn next(&mut self) -> Result<Option<(usize, &[u8])>, Error> {
        self.buf.clear();
        let got = self
            .inner
            .read_until(b'\n', &mut self.buf)
            .map_err(|e| Error::Io {
                path: self.path.into(),
                message: e.to_string(),
            })?;
        if got == 0 {
            return Ok(None);
        }
        self.n += 1;
        let line = self.buf.strip_suffix(b"\n").unwrap_or(&self.buf);
        Ok(Some((self.n, line.strip_suffix(b"\r").unwrap_or(line))))
    }
}

/// The fields of one section from the next lines of `lines` (`last_line`: the
/// last line read); returns the values and their records.
fn section<T, R: BufRead>(
    path: &Path,
    lines: &mut Lines<'_, R>,
    want: Want,
    last_line: &mut usize,
    parse: impl Fn(&[u8]) -> Option<T>,
) -> Result<(Vec<T>, Records), Error> {
    let Want {
        count,
        max_fields,
        fmt,
        what,
    } = want;
    // no more reserved than the rest of the file can hold (one field per `width` bytes)
    let mut out = Vec::with_capacity(count.min(max_fields));
    let mut at = Vec::new();
    while out.len() < count {
        let Some((l, rec)) = lines.next()? else {
            return Err(parse_error(
                path,
                *last_line,
                F,
                Detail::Count {
                    what,
                    expected: count as u64,
                    found: out.len() as u64,
                },
            ));
        };
        *last_line = l;
        at.push((out.len(), l));
        let before = out.len();
        for k in 0..fmt.repeat {
            if out.len() == count {
                break;
            }
            let s = k * fmt.width;
            if s >= rec.len() {
                break;
            }
            let field = &rec[s..(s + fmt.width).min(rec.len())];
            if text::trim(field).is_empty() {
                break;
            }
            let v = parse(field).ok_or_else(|| {
                parse_error(
                    path,
                    l,
                    F,
                    Detail::Expected {
                        expected: format!("{what}: field {} of {} characters", k + 1, fmt.width),
                        found: shown(field),
                    },
                )
            })?;
            out.push(v);
        }
        if out.len() == before {
            return Err(parse_error(
                path,
                l,
                F,
                Detail::Expected {
                    expected: format!(
                        "{what} (a record of {}x{} characters)",
                        fmt.repeat, fmt.width
                    ),
                    found: shown(rec),
                },
            ));
        }
    }
    Ok((out, at))
}

/// The line of value `k` of a section from its records' starts.
fn line_of(at: &[(usize, usize)], k: usize) -> usize {
    match at.binary_search_by(|(i, _)| i.cmp(&k)) {
        Ok(i) => at[i].1,
        Err(i) => at[i.saturating_sub(1)].1,
    }
}

/// Parses a Harwell-Boeing / Rutherford-Boeing file's bytes.
pub fn parse(path: &Path, b: &[u8]) -> Result<Triplets, Error> {
    parse_lines(
        path,
        Lines::new(path, b),
        Some(b.len() as u64),
        b.len() as u64,
    )
}

/// Parses a Harwell-Boeing / Rutherford-Boeing file whose first bytes are
/// `buf` and whose rest `rest` gives, line by line: the memory is the
/// pointers, indices and values, not the file's text. `file_bytes`: the
/// file's size if known (the header's counts are checked against it, as by
/// [`parse`]); `reserve`: the bytes that bound what is reserved ahead.
pub fn parse_reader(
    path: &Path,
    buf: Vec<u8>,
    rest: &mut dyn std::io::Read,
    file_bytes: Option<u64>,
    reserve: u64,
) -> Result<Triplets, Error> {
    let text = std::io::BufReader::with_capacity(1 << 20, std::io::Cursor::new(buf).chain(rest));
    parse_lines(path, Lines::new(path, text), file_bytes, reserve)
}

/// [`parse`] from the file's lines (`len`: its size if known; `reserve`:
/// bounds the fields reserved ahead, one per field width).
fn parse_lines<R: BufRead>(
    path: &Path,
    mut lines: Lines<'_, R>,
    len: Option<u64>,
    reserve: u64,
) -> Result<Triplets, Error> {
    let h = header(path, len, &mut lines)?;
    let (nrows, ncols, nnz, fmts) = (h.nrows, h.ncols, h.nnz, h.fmts);
    let max_fields = |f: Fmt| (reserve / f.width as u64).saturating_add(1) as usize;
    let mut last = h.last;
    let (ptr, ptr_at) = section(
        path,
        &mut lines,
        Want {
            count: ncols + 1,
            max_fields: max_fields(fmts[0]),
            fmt: fmts[0],
            what: "column pointers",
        },
        &mut last,
        text::uint_field,
    )?;
    let cols = entry_columns(path, &ptr, &ptr_at, ncols, nnz)?;
    let (ind, ind_at) = section(
        path,
        &mut lines,
        Want {
            count: nnz,
            max_fields: max_fields(fmts[1]),
            fmt: fmts[1],
            what: "row indices",
        },
        &mut last,
        text::uint_field,
    )?;
    let (vals, val_at) = section(
        path,
        &mut lines,
        Want {
            count: nnz,
            max_fields: max_fields(fmts[2]),
            fmt: fmts[2],
            what: "values",
        },
        &mut last,
        fortran_real,
    )?;
    let rows = entry_rows(path, &ind, &ind_at, nrows, h.symmetric, &cols)?;
    for (k, &v) in vals.iter().enumerate() {
        if !v.is_finite() {
            return Err(err(
                path,
                line_of(&val_at, k),
                Detail::NonFinite {
                    row: rows[k],
                    col: cols[k],
                    value: v,
                },
            ));
        }
    }
    Ok(Triplets::unlabelled(
        (nrows, ncols),
        (rows, cols, vals),
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

/// The blank-separated unsigned integers of `l` (`None` if one is not).
fn ints(l: &[u8]) -> Option<Vec<u64>> {
    l.split(|c| text::is_blank(*c))
        .filter(|t| !t.is_empty())
        .map(text::uint_field)
        .collect()
}

/// The next line (its number and bytes), or "expected `what`" after `last`.
fn next_line<'l, R: BufRead>(
    path: &Path,
    lines: &'l mut Lines<'_, R>,
    what: &str,
    last: usize,
) -> Result<(usize, &'l [u8]), Error> {
    lines
        .next()?
        .ok_or_else(|| expected(path, last + 1, what, b""))
}

/// The header (lines 1 to 4, and 5 when RHSCRD > 0), checked.
struct Header {
    nrows: usize,
    ncols: usize,
    nnz: usize,
    symmetric: bool,
    /// The formats of the pointers, the indices and the values.
    fmts: [Fmt; 3],
    /// The header's last line.
    last: usize,
}

/// Reads the header lines from `lines` (`len`: the file's size if known,
/// which bounds the counts it announces).
fn header<R: BufRead>(
    path: &Path,
    len: Option<u64>,
    lines: &mut Lines<'_, R>,
) -> Result<Header, Error> {
    let (_, _title) = next_line(path, lines, "the title line", 0)?;
    let (l2, counts) = next_line(
        path,
        lines,
        "line 2: TOTCRD PTRCRD INDCRD VALCRD [RHSCRD]",
        1,
    )?;
    let cards = match ints(counts) {
        Some(v) if v.len() == 4 || v.len() == 5 => v,
        _ => {
            return Err(expected(
                path,
                l2,
                "line 2: TOTCRD PTRCRD INDCRD VALCRD [RHSCRD] (4 or 5 integers)",
                counts,
            ))
        }
    };
    let rhscrd = cards.get(4).copied().unwrap_or(0);
    let (l3, tl) = next_line(path, lines, "line 3: MXTYPE NROW NCOL NNZERO [NELTVL]", l2)?;
    let (symmetric, dims) = matrix_type(path, l3, tl)?;
    let (nrows, ncols, nnz) = dimensions(path, l3, &dims, len, symmetric)?;
    let (l4, fl) = next_line(path, lines, "line 4: PTRFMT INDFMT VALFMT", l3)?;
    let fmts = formats(path, l4, fl)?;
    let mut last = l4;
    if rhscrd > 0 {
        let (l5, _) = next_line(path, lines, "line 5: RHSTYP NRHS NRHSIX", l4)?;
        last = l5;
    }
    if cards[3] == 0 && nnz > 0 {
        return Err(err(
            path,
            l2,
            Detail::Unsupported(
                "VALCRD = 0: the file has no values (a pattern); mass, stiffness and damping matrices need values"
                    .into(),
            ),
        ));
    }
    Ok(Header {
        nrows,
        ncols,
        nnz,
        symmetric,
        fmts,
        last,
    })
}

/// Line 3 (`l3`, text `tl`): MXTYPE checked (real or integer, symmetric or
/// not, assembled), whether it is symmetric and the integers after it.
fn matrix_type(path: &Path, l3: usize, tl: &[u8]) -> Result<(bool, Vec<u64>), Error> {
    let mxtype = tl
        .get(..3)
        .map(|t| t.to_ascii_uppercase())
        .unwrap_or_default();
    let dims = tl.get(3..).and_then(ints);
    let (Some(dims), [t0, t1, t2]) = (dims, mxtype.as_slice()) else {
        return Err(expected(
            path,
            l3,
            "line 3: MXTYPE (e.g. RSA) NROW NCOL NNZERO [NELTVL]",
            tl,
        ));
    };
    if !(3..=4).contains(&dims.len()) {
        return Err(expected(
            path,
            l3,
            "line 3: MXTYPE NROW NCOL NNZERO [NELTVL]",
            tl,
        ));
    }
    match t0 {
        b'R' | b'I' => {}
        b'P' => {
            return Err(err(
                path,
                l3,
                Detail::Unsupported(
                    "matrix type P (pattern) has no values: a mass, stiffness or damping matrix needs real values"
                        .into(),
                ),
            ))
        }
        b'C' => {
            return Err(err(
                path,
                l3,
                Detail::Unsupported(
                    "matrix type C (complex): mass, stiffness and damping matrices are real".into(),
                ),
            ))
        }
        _ => return Err(expected(path, l3, "matrix type R, I, P or C", &mxtype)),
    }
    let symmetric = match t1 {
        b'S' | b'H' => true,
        b'U' | b'R' => false,
        b'Z' => {
            return Err(err(
                path,
                l3,
                Detail::Unsupported(
                    "matrix type ?Z? (skew-symmetric): mass, stiffness and damping matrices are symmetric"
                        .into(),
                ),
            ))
        }
        _ => return Err(expected(path, l3, "symmetry S, U, H, Z or R", &mxtype)),
    };
    match t2 {
        b'A' => {}
        b'E' => {
            return Err(err(
                path,
                l3,
                Detail::Unsupported(format!(
                    "matrix type {} is elemental (unassembled): only assembled matrices (?{}A) are read",
                    String::from_utf8_lossy(&mxtype),
                    *t1 as char
                )),
            ))
        }
        _ => return Err(expected(path, l3, "A (assembled) or E (elemental)", &mxtype)),
    }
    Ok((symmetric, dims))
}

/// NROW, NCOL and NNZERO of line 3 (`l3`), bounded by [`MAX_DIM`] and the
/// file's length `len` if known (each value and pointer takes at least a
/// character).
fn dimensions(
    path: &Path,
    l3: usize,
    dims: &[u64],
    len: Option<u64>,
    symmetric: bool,
) -> Result<(usize, usize, usize), Error> {
    let len = len.unwrap_or(u64::MAX);
    let limit = MAX_DIM as u64;
    for (v, what) in [(dims[0], "NROW"), (dims[1], "NCOL")] {
        if v > limit {
            return Err(err(
                path,
                l3,
                Detail::TooLarge {
                    what,
                    value: v,
                    limit,
                },
            ));
        }
    }
    let (nrows, ncols, nnz) = (dims[0] as usize, dims[1] as usize, dims[2]);
    // each value takes at least one character of the file
    if nnz > len {
        return Err(err(
            path,
            l3,
            Detail::TooLarge {
                what: "NNZERO",
                value: nnz,
                limit: len,
            },
        ));
    }
    if ncols as u64 + 1 > len {
        return Err(err(
            path,
            l3,
            Detail::TooLarge {
                what: "NCOL",
                value: ncols as u64,
                limit: len,
            },
        ));
    }
    if symmetric && nrows != ncols {
        return Err(err(
            path,
            l3,
            Detail::Unsupported(format!(
                "a symmetric matrix must be square, line 3 says {nrows}x{ncols}"
            )),
        ));
    }
    Ok((nrows, ncols, nnz as usize))
}

/// Line 4 (`l4`, text `fl`): the Fortran formats of pointers, indices and
/// values, in fixed columns 1-16, 17-32, 33-52, else blank-separated.
fn formats(path: &Path, l4: usize, fl: &[u8]) -> Result<[Fmt; 3], Error> {
    // fixed columns 1-16, 17-32, 33-52; else blank-separated
    let fixed = [(0, 16), (16, 32), (32, 52)]
        .map(|(s, e)| fl.get(s..e.min(fl.len())).and_then(fortran_format));
    Ok(match fixed {
        [Some(a), Some(b), Some(c)] => [a, b, c],
        _ => {
            let toks: Vec<Option<Fmt>> = fl
                .split(|c| text::is_blank(*c))
                .filter(|t| !t.is_empty())
                .map(fortran_format)
                .collect();
            match toks.as_slice() {
                [Some(a), Some(b), Some(c), ..] => [*a, *b, *c],
                _ => {
                    return Err(expected(
                        path,
                        l4,
                        "line 4: the Fortran formats of pointers, indices and values, e.g. (10I8) (10I8) (4E20.12)",
                        fl,
                    ))
                }
            }
        }
    })
}

/// The column of every entry from the column pointers `ptr` (lines
/// `ptr_at`): they start at 1, do not decrease and end at NNZERO + 1.
fn entry_columns(
    path: &Path,
    ptr: &[u64],
    ptr_at: &[(usize, usize)],
    ncols: usize,
    nnz: usize,
) -> Result<Vec<usize>, Error> {
    // pointers: 1, non-decreasing, NNZERO + 1
    let mut cols = Vec::with_capacity(nnz);
    for j in 0..ncols {
        let (a, e) = (ptr[j], ptr[j + 1]);
        let lo = if j == 0 { 1 } else { a };
        if (j == 0 && a != 1) || e < lo || e > nnz as u64 + 1 {
            let bad = if j == 0 && a != 1 { j } else { j + 1 };
            return Err(err(
                path,
                line_of(ptr_at, bad),
                Detail::OutOfRange {
                    what: "column pointer",
                    value: ptr[bad],
                    min: if bad == 0 { 1 } else { ptr[bad - 1] },
                    max: if bad == 0 { 1 } else { nnz as u64 + 1 },
                },
            ));
        }
        cols.extend(std::iter::repeat_n(j, (e - a) as usize));
    }
    if ncols == 0 && ptr[0] != 1 || ptr[ncols] != nnz as u64 + 1 {
        return Err(err(
            path,
            line_of(ptr_at, ncols),
            Detail::Count {
                what: "entries (the last column pointer minus 1 against NNZERO)",
                expected: nnz as u64,
                found: ptr[ncols].saturating_sub(1),
            },
        ));
    }
    Ok(cols)
}

/// The 0-based row of every entry from the row indices `ind` (lines
/// `ind_at`): within 1..=NROW and, for a symmetric file, in the lower
/// triangle of the entries' columns `cols`.
fn entry_rows(
    path: &Path,
    ind: &[u64],
    ind_at: &[(usize, usize)],
    nrows: usize,
    symmetric: bool,
    cols: &[usize],
) -> Result<Vec<usize>, Error> {
    let mut rows = Vec::with_capacity(ind.len());
    for (k, &r) in ind.iter().enumerate() {
        if r == 0 || r > nrows as u64 {
            return Err(err(
                path,
                line_of(ind_at, k),
                Detail::OutOfRange {
                    what: "row index",
                    value: r,
                    min: 1,
                    max: nrows as u64,
                },
            ));
        }
        let r = r as usize - 1;
        if symmetric && r < cols[k] {
            return Err(err(
                path,
                line_of(ind_at, k),
                Detail::Unsupported(format!(
                    "entry ({}, {}) is in the upper triangle: a symmetric file stores the lower triangle",
                    r + 1,
                    cols[k] + 1
                )),
            ));
        }
        rows.push(r);
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_and_fortran_reals() {
        assert_eq!(
            fortran_format(b"(10I8)"),
            Some(Fmt {
                repeat: 10,
                width: 8
            })
        );
        assert_eq!(
            fortran_format(b"(1P,4E20.12)  "),
            Some(Fmt {
                repeat: 4,
                width: 20
            })
        );
        assert_eq!(
            fortran_format(b"(1P5D16.8)"),
            Some(Fmt {
                repeat: 5,
                width: 16
            })
        );
        assert_eq!(fortran_format(b"(3(1X,E22.15))"), None);
        assert_eq!(fortran_real(b" 1.5D+02"), Some(150.0));
        assert_eq!(fortran_real(b"-2.5d-1"), Some(-0.25));
        assert_eq!(fortran_real(b"1.5-100"), Some(1.5e-100));
        assert_eq!(fortran_real(b"-1.5+10"), Some(-1.5e10));
        assert_eq!(fortran_real(b"x"), None);
    }
}
