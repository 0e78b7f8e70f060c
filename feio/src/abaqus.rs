//! Abaqus matrix output (`*MATRIX GENERATE`, `*MATRIX OUTPUT`; files such as
//! `job_STIF1.mtx`, `job_MASS1.mtx`):
//!
//! * the coordinate format, one entry per line: `row, column, value` (1-based
//!   global DOF numbers);
//! * the labels format (`FORMAT=MATRIX INPUT`, the default of `*MATRIX
//!   GENERATE`): `node, dof, node, dof, value`. The rows are the distinct
//!   `(node, dof)` labels in ascending order, kept in [`Triplets::labels`].
//!
//! Abaqus writes one triangle of a symmetric matrix (lower or upper); a file
//! with entries in both triangles is read as general (all entries given).
//! Lines starting with `*` (keywords, `**` comments) and blank lines are skipped.
use crate::text::{self, shown};
use crate::{parse_error, Detail, Error, Format, Label, Triplets, MAX_DIM};
use rayon::prelude::*;
use std::path::Path;

const F: Format = Format::Abaqus;

/// Parses an Abaqus matrix file's bytes.
pub fn parse(path: &Path, b: &[u8]) -> Result<Triplets, Error> {
    let mut r = Entries::new(path, b.len() as u64);
    r.window(b)?;
    r.finish()
}

/// Parses an Abaqus matrix file whose first bytes are `buf` and whose rest
/// `rest` gives, in windows of about `window` bytes of whole lines
/// ([`crate::text::for_each_window`]): the memory is the entries plus one
/// window of text, not the file's text. `file_bytes` (the file's size, if
/// known) bounds what is reserved. The same entries and errors as [`parse`].
pub fn parse_reader_window(
    path: &Path,
    buf: Vec<u8>,
    rest: &mut dyn std::io::Read,
    file_bytes: Option<u64>,
    window: usize,
) -> Result<Triplets, Error> {
    let mut r = Entries::new(path, file_bytes.unwrap_or(buf.len() as u64));
    text::for_each_window(path, buf, rest, window, |w| r.window(w))?;
    r.finish()
}

/// The error at `line` of `path`.
fn err(path: &Path, line: usize, detail: Detail) -> Error {
    parse_error(path, line, F, detail)
}

/// The entries as read, before the labels are numbered.
struct Read {
    /// Fields per entry: 3 (`row, column, value`), 5 (labels) or 0 (none).
    nfields: usize,
    /// Coordinate format: 0-based rows and columns.
    rows: Vec<usize>,
    cols: Vec<usize>,
    vals: Vec<f64>,
    /// Labels format: the raw labels of each entry.
    labels: Vec<(Label, Label)>,
    /// Labels format: the first non-finite value (line, entry, value).
    bad_value: Option<(usize, usize, f64)>,
    /// The last line.
    last: usize,
}

/// The entry lines read so far (the format is the first entry's), checked
/// as they come, window by window.
struct Entries<'p> {
    path: &'p Path,
    out: Read,
    /// Lines of the windows before the current one.
    lines_before: usize,
}

impl<'p> Entries<'p> {
    /// For a file of about `bytes` bytes (bounds the entries reserved).
    fn new(path: &'p Path, bytes: u64) -> Self {
        let cap = (bytes / 16).min(1 << 24) as usize;
        Entries {
            path,
            out: Read::empty(0, cap),
            lines_before: 0,
        }
    }

    /// The whole lines of the next window of the file: the lines up to the
    /// first entry (which fixes the format) one by one, the rest in
    /// line-aligned chunks on all threads ([`text::line_chunks`]), merged in
    /// file order (so the first error in file order is the one reported, as
    /// when read line by line).
    fn window(&mut self, b: &[u8]) -> Result<(), Error> {
        let path = self.path;
        let mut rest = b;
        if self.out.nfields == 0 {
            let end = first_entry_end(rest);
            self.lines_before += read_lines(path, &rest[..end], self.lines_before, &mut self.out)?;
            rest = &rest[end..];
        }
        let nfields = self.out.nfields;
        let parse = |r: &std::ops::Range<usize>| {
            let mut part = Read::empty(nfields, 0);
            let lines = read_lines(path, &rest[r.clone()], 0, &mut part);
            (part, lines)
        };
        let chunks = text::line_chunks(rest);
        let parts: Vec<(Read, Result<usize, Error>)> = if chunks.len() > 1 {
            chunks.par_iter().map(parse).collect()
        } else {
            chunks.iter().map(parse).collect()
        };
        for (part, lines) in parts {
            let base = self.lines_before;
            let lines = lines.map_err(|mut e| {
                if let Error::Parse { line, .. } = &mut e {
                    *line += base;
                }
                e
            })?;
            self.out.append(part, base);
            self.lines_before += lines;
        }
        Ok(())
    }

    /// The matrix of the entries read: the coordinate format's size from its
    /// largest index, the labels format's rows the distinct labels.
    fn finish(self) -> Result<Triplets, Error> {
        let path = self.path;
        let Read {
            nfields,
            mut rows,
            mut cols,
            vals,
            labels,
            bad_value,
            last,
        } = self.out;
        if nfields == 0 {
            return Err(err(
                path,
                last.max(1),
                Detail::Expected {
                    expected:
                        "at least one entry `row, column, value` or `node, dof, node, dof, value`"
                            .into(),
                    found: String::from("end of file"),
                },
            ));
        }
        let mut names = None;
        let n = if nfields == 3 {
            rows.iter().chain(&cols).max().map_or(0, |m| m + 1)
        } else {
            let all;
            (rows, cols, all) = label_indices(path, last, &labels, bad_value)?;
            let n = all.len();
            names = Some(all);
            n
        };
        let lower = rows.iter().zip(&cols).any(|(r, c)| r > c);
        let upper = rows.iter().zip(&cols).any(|(r, c)| r < c);
        Ok(Triplets {
            nrows: n,
            ncols: n,
            rows,
            cols,
            vals,
            symmetric_storage: !(lower && upper),
            labels: names,
            format: F,
        })
    }
}

impl Read {
    /// No entries yet, `nfields` per entry (0: not known), `cap` reserved.
    fn empty(nfields: usize, cap: usize) -> Self {
        Read {
            nfields,
            rows: Vec::with_capacity(cap),
            cols: Vec::with_capacity(cap),
            vals: Vec::with_capacity(cap),
            labels: Vec::new(),
            bad_value: None,
            last: 0,
        }
    }

    /// The entries of `part`, read after these, its lines numbered from 1
    /// after `base` lines.
    fn append(&mut self, part: Read, base: usize) {
        if self.bad_value.is_none() {
            let before = self.labels.len();
            self.bad_value = part.bad_value.map(|(l, k, v)| (base + l, before + k, v));
        }
        self.rows.extend_from_slice(&part.rows);
        self.cols.extend_from_slice(&part.cols);
        self.vals.extend_from_slice(&part.vals);
        self.labels.extend_from_slice(&part.labels);
        if part.last > 0 {
            self.last = base + part.last;
        }
    }
}

/// The end of the line of the first entry of `b` (a line neither blank nor a
/// keyword or comment), or the end of `b` if it has none.
fn first_entry_end(b: &[u8]) -> usize {
    let mut p = 0;
    while p < b.len() {
        let end = b[p..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(b.len(), |i| p + i + 1);
        let t = text::trim(&b[p..end]);
        let t = t.strip_suffix(b"\n").map_or(t, text::trim);
        if !t.is_empty() && t[0] != b'*' {
            return end;
        }
        p = end;
    }
    b.len()
}

/// Reads the entry lines of `b` (whole lines, numbered from `base + 1`) into
/// `out`, checked (the format is the first entry's: `out.nfields`, set by
/// the first entry if 0); returns the number of lines.
fn read_lines(path: &Path, b: &[u8], base: usize, out: &mut Read) -> Result<usize, Error> {
    let mut fields: Vec<&[u8]> = Vec::with_capacity(6);
    let mut count = 0;
    for (k, line) in text::lines(b) {
        count = k;
        let l = base + k;
        out.last = l;
        let t = text::trim(line);
        if t.is_empty() || t[0] == b'*' {
            continue;
        }
        fields.clear();
        fields.extend(t.split(|&c| c == b','));
        // a trailing comma
        if fields.len() > 1 && text::trim(fields[fields.len() - 1]).is_empty() {
            fields.pop();
        }
        if out.nfields == 0 {
            out.nfields = fields.len();
            if out.nfields != 3 && out.nfields != 5 {
                return Err(err(
                    path,
                    l,
                    Detail::Expected {
                        expected: "`row, column, value` or `node, dof, node, dof, value`".into(),
                        found: shown(t),
                    },
                ));
            }
        }
        let (ints, v) = entry_fields(path, l, t, &fields, out.nfields)?;
        if out.nfields == 3 {
            let (r, c) = coordinate_entry(path, l, &ints, v)?;
            out.rows.push(r);
            out.cols.push(c);
        } else {
            let entry = labels_entry(path, l, &ints)?;
            if !v.is_finite() && out.bad_value.is_none() {
                out.bad_value = Some((l, out.labels.len(), v));
            }
            out.labels.push(entry);
        }
        out.vals.push(v);
    }
    Ok(count)
}

/// The integers and the value of the entry line `l` (text `t`, split into
/// `fields`), which has `nfields` fields like the file's first entry.
fn entry_fields(
    path: &Path,
    l: usize,
    t: &[u8],
    fields: &[&[u8]],
    nfields: usize,
) -> Result<(Vec<u64>, f64), Error> {
    let what = if nfields == 3 {
        "`row, column, value` (as the file's first entry)"
    } else {
        "`node, dof, node, dof, value` (as the file's first entry)"
    };
    let expected = |found: &[u8]| {
        err(
            path,
            l,
            Detail::Expected {
                expected: what.into(),
                found: shown(found),
            },
        )
    };
    if fields.len() != nfields {
        return Err(expected(t));
    }
    let ints: Option<Vec<u64>> = fields[..nfields - 1]
        .iter()
        .map(|f| text::uint_field(f))
        .collect();
    let ints = ints.ok_or_else(|| expected(t))?;
    let v = text::real_field(fields[nfields - 1]).ok_or_else(|| expected(t))?;
    Ok((ints, v))
}

/// `row, column, value` at line `l`: the 0-based row and column (1 to
/// [`MAX_DIM`] in the file), the value finite.
fn coordinate_entry(path: &Path, l: usize, ints: &[u64], v: f64) -> Result<(usize, usize), Error> {
    for (k, name) in [(0, "row"), (1, "column")] {
        if ints[k] == 0 || ints[k] > MAX_DIM as u64 {
            return Err(err(
                path,
                l,
                Detail::OutOfRange {
                    what: name,
                    value: ints[k],
                    min: 1,
                    max: MAX_DIM as u64,
                },
            ));
        }
    }
    let (r, c) = (ints[0] as usize - 1, ints[1] as usize - 1);
    if !v.is_finite() {
        return Err(err(
            path,
            l,
            Detail::NonFinite {
                row: r,
                col: c,
                value: v,
            },
        ));
    }
    Ok((r, c))
}

/// `node, dof, node, dof, value` at line `l`: the two labels (dofs 1 to 255).
fn labels_entry(path: &Path, l: usize, ints: &[u64]) -> Result<(Label, Label), Error> {
    for k in [1, 3] {
        if ints[k] == 0 || ints[k] > 255 {
            return Err(err(
                path,
                l,
                Detail::OutOfRange {
                    what: "dof",
                    value: ints[k],
                    min: 1,
                    max: 255,
                },
            ));
        }
    }
    Ok(((ints[0], ints[1] as u8), (ints[2], ints[3] as u8)))
}

/// Rows, columns (indices into the labels) and the distinct labels in
/// ascending order.
type LabelIndices = (Vec<usize>, Vec<usize>, Vec<Label>);

/// The labels format's rows and columns: the indices of the entries' labels
/// among the distinct labels in ascending order (returned too); then the
/// first non-finite value, named by its indices.
fn label_indices(
    path: &Path,
    last: usize,
    labels: &[(Label, Label)],
    bad_value: Option<(usize, usize, f64)>,
) -> Result<LabelIndices, Error> {
    let mut all: Vec<Label> = labels.iter().flat_map(|(a, b)| [*a, *b]).collect();
    all.par_sort_unstable();
    all.dedup();
    if all.len() > MAX_DIM {
        return Err(err(
            path,
            last,
            Detail::TooLarge {
                what: "distinct (node, dof) labels",
                value: all.len() as u64,
                limit: MAX_DIM as u64,
            },
        ));
    }
    // each entry's labels among `all`: through the first label of each node
    // where the node numbers are dense enough for a table of them (an FE
    // model's), else by binary search (the same indices either way)
    let max_node = all.last().map_or(0, |l| l.0);
    let first = (max_node <= 4 * all.len() as u64 + 1024).then(|| {
        let mut first = vec![usize::MAX; max_node as usize + 1];
        for (i, l) in all.iter().enumerate().rev() {
            first[l.0 as usize] = i;
        }
        first
    });
    let index = |x: &Label| match &first {
        Some(first) => {
            let s = first[x.0 as usize];
            s + all[s..].iter().position(|y| y == x).unwrap_or(0)
        }
        None => all.binary_search(x).unwrap_or(0),
    };
    let rows: Vec<usize> = labels.par_iter().map(|(a, _)| index(a)).collect();
    let cols: Vec<usize> = labels.par_iter().map(|(_, b)| index(b)).collect();
    if let Some((l, k, value)) = bad_value {
        return Err(err(
            path,
            l,
            Detail::NonFinite {
                row: rows[k],
                col: cols[k],
                value,
            },
        ));
    }
    Ok((rows, cols, all))
}
