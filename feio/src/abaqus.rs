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
use std::path::Path;

const F: Format = Format::Abaqus;

/// Parses an Abaqus matrix file's bytes.
pub fn parse(path: &Path, b: &[u8]) -> Result<Triplets, Error> {
    let err = |line, detail| parse_error(path, line, F, detail);
    let mut nfields = 0usize;
    let cap = (b.len() / 16).min(1 << 24);
    let (mut rows, mut cols, mut vals) = (
        Vec::with_capacity(cap),
        Vec::with_capacity(cap),
        Vec::with_capacity(cap),
    );
    // labels format: the raw labels of each entry and the line of a non-finite value
    let mut labels: Vec<(Label, Label)> = Vec::new();
    let mut bad_value: Option<(usize, usize, f64)> = None;
    let mut last = 0usize;
    let mut fields: Vec<&[u8]> = Vec::with_capacity(6);
    for (l, line) in text::lines(b) {
        last = l;
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
        if nfields == 0 {
            nfields = fields.len();
            if nfields != 3 && nfields != 5 {
                return Err(err(
                    l,
                    Detail::Expected {
                        expected: "`row, column, value` or `node, dof, node, dof, value`".into(),
                        found: shown(t),
                    },
                ));
            }
        }
        let what = if nfields == 3 {
            "`row, column, value` (as the file's first entry)"
        } else {
            "`node, dof, node, dof, value` (as the file's first entry)"
        };
        let expected = |found: &[u8]| {
            err(
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
        if nfields == 3 {
            for (k, name) in [(0, "row"), (1, "column")] {
                if ints[k] == 0 || ints[k] > MAX_DIM as u64 {
                    return Err(err(
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
                    l,
                    Detail::NonFinite {
                        row: r,
                        col: c,
                        value: v,
                    },
                ));
            }
            rows.push(r);
            cols.push(c);
        } else {
            for k in [1, 3] {
                if ints[k] == 0 || ints[k] > 255 {
                    return Err(err(
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
            if !v.is_finite() && bad_value.is_none() {
                bad_value = Some((l, labels.len(), v));
            }
            labels.push(((ints[0], ints[1] as u8), (ints[2], ints[3] as u8)));
        }
        vals.push(v);
    }
    if nfields == 0 {
        return Err(err(
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
        let mut all: Vec<Label> = labels.iter().flat_map(|(a, b)| [*a, *b]).collect();
        all.sort_unstable();
        all.dedup();
        if all.len() > MAX_DIM {
            return Err(err(
                last,
                Detail::TooLarge {
                    what: "distinct (node, dof) labels",
                    value: all.len() as u64,
                    limit: MAX_DIM as u64,
                },
            ));
        }
        let index = |x: &Label| all.binary_search(x).unwrap_or(0);
        rows = labels.iter().map(|(a, _)| index(a)).collect();
        cols = labels.iter().map(|(_, b)| index(b)).collect();
        if let Some((l, k, value)) = bad_value {
            return Err(err(
                l,
                Detail::NonFinite {
                    row: rows[k],
                    col: cols[k],
                    value,
                },
            ));
        }
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
