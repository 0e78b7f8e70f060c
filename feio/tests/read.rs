//! The readers: known small matrices in every format, bad input naming the file
//! and the line, no panic on random bytes or truncations, and the Matrix Market
//! reader bit for bit against nalgebra-sparse's.
use feio::{read, read_bytes, Detail, Error, Format, Triplets};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// The 3-DOF chain's stiffness (springs 100, 200, 300 N/m, the first to ground).
const K: [[f64; 3]; 3] = [
    [300.0, -200.0, 0.0],
    [-200.0, 500.0, -300.0],
    [0.0, -300.0, 300.0],
];

fn rd(name: &str, text: &str, f: Format) -> Result<Triplets, Error> {
    read_bytes(Path::new(name), text.as_bytes(), f)
}

fn dense(t: &Triplets) -> Vec<Vec<f64>> {
    let mut d = vec![vec![0.0; t.ncols]; t.nrows];
    for (r, c, v) in t.expanded() {
        d[r][c] += v;
    }
    d
}

fn assert_k(t: &Triplets, what: &str) {
    let d = dense(t);
    let k: Vec<Vec<f64>> = K.iter().map(|r| r.to_vec()).collect();
    assert_eq!(d, k, "{what}");
}

/// The error's line, and its text names the file and the line.
fn line_of(e: &Error, file: &str) -> usize {
    let msg = e.to_string();
    let line = e.line().unwrap_or_else(|| panic!("no line: {msg}"));
    assert!(
        msg.contains(file) && msg.contains(&format!("line {line}")),
        "{msg}"
    );
    line
}

fn expect_line(r: Result<Triplets, Error>, file: &str, line: usize, words: &[&str]) -> Detail {
    let e = r.expect_err("an error");
    assert_eq!(line_of(&e, file), line, "{e}");
    let msg = e.to_string();
    for w in words {
        assert!(msg.contains(w), "`{w}` not in: {msg}");
    }
    match e {
        Error::Parse { detail, .. } => detail,
        Error::Io { .. } => unreachable!(),
    }
}

const MM_SYM: &str = "%%MatrixMarket matrix coordinate real symmetric\n% written by hand\n3 3 5\n\
    1 1 300\n2 1 -200\n2 2 500\n3 2 -300\n3 3 3.0e2\n";
const MM_GEN: &str = "%%MatrixMarket matrix coordinate real general\n3 3 7\n1 1 300\n1 2 -200\n\
    2 1 -200\n2 2 500\n2 3 -300\n3 2 -300\n3 3 300\n";
const MM_ARRAY: &str =
    "%%MatrixMarket matrix array real general\n3 3\n300\n-200\n0\n-200\n500\n-300\n0\n-300\n300\n";
const MM_ARRAY_SYM: &str =
    "%%MatrixMarket matrix array real symmetric\n3 3\n300\n-200\n0\n500\n-300\n300\n";

/// HB/RB of the chain (RSA, lower triangle by columns), values touching each
/// other in 17-character fields with `D` exponents.
fn hb_chain() -> String {
    let vals = [300.0, -200.0, 500.0, -300.0, 300.0];
    let mut v = String::new();
    for (k, x) in vals.iter().enumerate() {
        v += &format!("{:>17}", format!("{x:.12E}").replace('E', "D"));
        if k % 4 == 3 {
            v.push('\n');
        }
    }
    format!(
        "{:<72}{:<8}\n{:>14}{:>14}{:>14}{:>14}\n{:<14}{:>14}{:>14}{:>14}{:>14}\n{:<16}{:<16}{:<20}\n\
         {:>3}{:>3}{:>3}{:>3}\n{:>3}{:>3}{:>3}{:>3}{:>3}\n{v}\n",
        "chain stiffness",
        "K",
        5,
        1,
        1,
        2,
        "RSA",
        3,
        3,
        5,
        0,
        "(4I3)",
        "(5I3)",
        "(1P,4E17.12)",
        1,
        3,
        5,
        6,
        1,
        2,
        2,
        3,
        3
    )
}

const ABQ_LABELS: &str = "** MATRIX OUTPUT, STIFFNESS\n*MATRIX\n\
    10,1, 10,1, 3.000000000000000e+02\n\
    20,1, 10,1, -2.000000000000000e+02\n\
    20,1, 20,1, 5.000000000000000e+02\n\
    30,1, 20,1, -3.000000000000000e+02\n\
    30,1, 30,1, 3.000000000000000e+02\n";
const ABQ_COORD: &str = "1, 1, 300.\n1, 2, -200.\n2, 2, 500.\n2, 3, -300.\n3, 3, 300.\n";

#[test]
fn the_chain_in_every_format_gives_the_same_matrix() {
    for (name, text) in [
        ("sym.mtx", MM_SYM),
        ("gen.mtx", MM_GEN),
        ("array.mtx", MM_ARRAY),
        ("array_sym.mtx", MM_ARRAY_SYM),
        ("K.rsa", &hb_chain()),
        ("job_STIF1.mtx", ABQ_LABELS),
        ("coord.mtx", ABQ_COORD),
    ] {
        let t = rd(name, text, Format::Auto).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_k(&t, name);
    }
    // detection: by content, by extension, by the HB header without extension
    assert_eq!(
        rd("a", MM_SYM, Format::Auto).unwrap().format,
        Format::MatrixMarket
    );
    assert_eq!(
        rd("k.dat", &hb_chain(), Format::Auto).unwrap().format,
        Format::HarwellBoeing
    );
    let t = rd("x.mtx", ABQ_LABELS, Format::Auto).unwrap();
    assert_eq!(t.format, Format::Abaqus);
    assert_eq!(t.labels.as_deref(), Some(&[(10, 1), (20, 1), (30, 1)][..]));
    assert_eq!(t.index_of((20, 1)), Some(1));
    assert!(t.symmetric_storage);
    // upper triangle and both triangles of the labels format
    let upper: String = ABQ_LABELS
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            if f.len() == 5 {
                format!("{},{},{},{},{}\n", f[2], f[3], f[0], f[1], f[4])
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    assert_k(&rd("u.mtx", &upper, Format::Abaqus).unwrap(), "upper");
    let both = format!("{ABQ_LABELS}10,1, 20,1, -200.\n20,1, 30,1, -300.\n");
    let t = rd("b.mtx", &both, Format::Abaqus).unwrap();
    assert!(!t.symmetric_storage);
    assert_k(&t, "both");
    // relabelling onto a superset
    let mut t = rd("x.mtx", ABQ_LABELS, Format::Auto).unwrap();
    t.relabel(&[(5, 1), (10, 1), (20, 1), (30, 1)]).unwrap();
    assert_eq!(t.nrows, 4);
    assert_eq!(dense(&t)[1][1], 300.0);
    assert_eq!(t.relabel(&[(10, 1)]), Err((5, 1)));
    // integer fields, CRLF and a trailing blank line
    let t = rd(
        "i.mtx",
        "%%MatrixMarket matrix coordinate integer general\r\n2 2 2\r\n1 1 -3\r\n2 2 +4\r\n\r\n",
        Format::Auto,
    )
    .unwrap();
    assert_eq!(t.vals, vec![-3.0, 4.0]);
}

#[test]
fn gzip_files_are_read() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("K.mtx.gz");
    let mut enc = flate2_writer(std::fs::File::create(&p).unwrap());
    enc.write_all(MM_SYM.as_bytes()).unwrap();
    enc.finish().unwrap();
    assert_k(&read(&p, Format::Auto).unwrap(), "gz");
    // an HB file compressed: the extension under .gz still detects it
    let p = dir.path().join("K.rsa.gz");
    let mut enc = flate2_writer(std::fs::File::create(&p).unwrap());
    enc.write_all(hb_chain().as_bytes()).unwrap();
    enc.finish().unwrap();
    assert_k(&read(&p, Format::Auto).unwrap(), "rsa.gz");
    // a broken stream names the file
    let bad = dir.path().join("bad.mtx.gz");
    std::fs::write(&bad, [0x1f, 0x8b, 8, 0, 1, 2, 3]).unwrap();
    let e = read(&bad, Format::Auto).unwrap_err();
    assert!(
        matches!(e, Error::Io { .. }) && e.to_string().contains("bad.mtx.gz"),
        "{e}"
    );
    let e = read(&dir.path().join("missing.mtx"), Format::Auto).unwrap_err();
    assert!(e.to_string().contains("missing.mtx"), "{e}");
}

fn flate2_writer(f: std::fs::File) -> flate2::write::GzEncoder<std::fs::File> {
    flate2::write::GzEncoder::new(f, flate2::Compression::default())
}

#[test]
fn bad_matrix_market_names_the_file_and_line() {
    let f = Format::MatrixMarket;
    let h = "%%MatrixMarket matrix coordinate real general\n";
    // truncated line
    expect_line(
        rd("t.mtx", &format!("{h}2 2 2\n1 1 1.0\n2 2\n"), f),
        "t.mtx",
        4,
        &["value"],
    );
    expect_line(
        rd("t.mtx", &format!("{h}2 2 2\n1 1 1.0\n2 x 3.0\n"), f),
        "t.mtx",
        4,
        &["column"],
    );
    // wrong entry count: too few, too many
    let d = expect_line(
        rd("c.mtx", &format!("{h}2 2 3\n1 1 1.0\n2 2 1.0\n"), f),
        "c.mtx",
        4,
        &[],
    );
    assert!(
        matches!(
            d,
            Detail::Count {
                expected: 3,
                found: 2,
                ..
            }
        ),
        "{d}"
    );
    let d = expect_line(
        rd("c.mtx", &format!("{h}% c\n2 2 1\n1 1 1.0\n\n2 2 1.0\n"), f),
        "c.mtx",
        6,
        &[],
    );
    assert!(
        matches!(
            d,
            Detail::Count {
                expected: 1,
                found: 2,
                ..
            }
        ),
        "{d}"
    );
    // out-of-range index
    let d = expect_line(
        rd("o.mtx", &format!("{h}2 2 1\n3 1 1.0\n"), f),
        "o.mtx",
        3,
        &["row 3"],
    );
    assert!(matches!(d, Detail::OutOfRange { .. }));
    expect_line(
        rd("o.mtx", &format!("{h}2 2 1\n1 0 1.0\n"), f),
        "o.mtx",
        3,
        &["column 0"],
    );
    // NaN, inf
    for v in ["NaN", "inf", "-1e400"] {
        let d = expect_line(
            rd("n.mtx", &format!("{h}2 2 2\n1 1 1\n2 2 {v}\n"), f),
            "n.mtx",
            4,
            &[],
        );
        assert!(matches!(d, Detail::NonFinite { row: 1, col: 1, .. }), "{d}");
    }
    // bad header, size line, refused kinds
    expect_line(
        rd(
            "h.mtx",
            "%%MatrixMarket matrix coordinate real genral\n1 1 1\n1 1 1\n",
            f,
        ),
        "h.mtx",
        1,
        &["symmetry"],
    );
    expect_line(
        rd("h.mtx", "1 1 1\n1 1 1\n", f),
        "h.mtx",
        1,
        &["%%MatrixMarket"],
    );
    expect_line(
        rd("h.mtx", &format!("{h}2 2\n"), f),
        "h.mtx",
        2,
        &["size line"],
    );
    expect_line(rd("h.mtx", h, f), "h.mtx", 2, &["size line"]);
    expect_line(
        rd(
            "p.mtx",
            "%%MatrixMarket matrix coordinate pattern general\n2 2 1\n1 1\n",
            f,
        ),
        "p.mtx",
        1,
        &["pattern", "no values"],
    );
    expect_line(
        rd(
            "s.mtx",
            "%%MatrixMarket matrix coordinate real skew-symmetric\n2 2 1\n2 1 1\n",
            f,
        ),
        "s.mtx",
        1,
        &["skew-symmetric"],
    );
    expect_line(
        rd(
            "u.mtx",
            "%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n1 2 1\n",
            f,
        ),
        "u.mtx",
        3,
        &["upper triangle"],
    );
    // a size line claiming 10^15 entries or 10^12 rows: refused before allocating
    let d = expect_line(
        rd(
            "b.mtx",
            &format!("{h}1000000 1000000 1000000000000000\n1 1 1\n"),
            f,
        ),
        "b.mtx",
        2,
        &[],
    );
    assert!(matches!(d, Detail::TooLarge { .. }), "{d}");
    expect_line(
        rd("b.mtx", &format!("{h}1000000000000 1 1\n1 1 1\n"), f),
        "b.mtx",
        2,
        &["too large"],
    );
    expect_line(
        rd(
            "a.mtx",
            "%%MatrixMarket matrix array real general\n100000 100000\n1\n",
            f,
        ),
        "a.mtx",
        3,
        &["ends early"],
    );
    // array: a missing value, a bad value
    expect_line(
        rd(
            "a.mtx",
            "%%MatrixMarket matrix array real general\n2 1\n1\n",
            f,
        ),
        "a.mtx",
        3,
        &["ends early"],
    );
    expect_line(
        rd(
            "a.mtx",
            "%%MatrixMarket matrix array real general\n2 1\n1\nnan\n",
            f,
        ),
        "a.mtx",
        4,
        &["non-finite"],
    );
    // trailing garbage on an entry line
    expect_line(
        rd("g.mtx", &format!("{h}2 2 1\n1 1 1.0 7\n"), f),
        "g.mtx",
        3,
        &["end of the line"],
    );
}

#[test]
fn bad_harwell_boeing_names_the_file_and_line() {
    let f = Format::HarwellBoeing;
    let good = hb_chain();
    let lines: Vec<&str> = good.lines().collect();
    let with = |k: usize, l: &str| {
        let mut v = lines.clone();
        v[k] = l;
        v.join("\n") + "\n"
    };
    // truncated: the last values record missing
    let d = expect_line(
        rd("k.rsa", &(lines[..6].join("\n") + "\n"), f),
        "k.rsa",
        6,
        &["values"],
    );
    assert!(
        matches!(
            d,
            Detail::Count {
                expected: 5,
                found: 0,
                ..
            }
        ),
        "{d}"
    );
    // a truncated record (3 of 5 row indices)
    expect_line(
        rd("k.rsa", &with(5, "  1  2  2"), f),
        "k.rsa",
        7,
        &["row indices"],
    );
    // wrong entry count: NNZERO 6 against pointers ending at 6
    let l3 = format!("{:<14}{:>14}{:>14}{:>14}{:>14}", "RSA", 3, 3, 6, 0);
    let d = expect_line(rd("k.rsa", &with(2, &l3), f), "k.rsa", 5, &["NNZERO"]);
    assert!(
        matches!(
            d,
            Detail::Count {
                expected: 6,
                found: 5,
                ..
            }
        ),
        "{d}"
    );
    // out-of-range row index
    let d = expect_line(
        rd("k.rsa", &with(5, "  1  2  2  4  3"), f),
        "k.rsa",
        6,
        &["row index 4"],
    );
    assert!(matches!(d, Detail::OutOfRange { .. }));
    // a column pointer going backwards
    expect_line(
        rd("k.rsa", &with(4, "  1  3  2  6"), f),
        "k.rsa",
        5,
        &["column pointer"],
    );
    // NaN value
    let v = lines[6].replacen("-2.000000000000D2", "              NaN", 1);
    expect_line(rd("k.rsa", &with(6, &v), f), "k.rsa", 7, &["non-finite"]);
    let v = lines[6].replacen("-2.000000000000D2", "    -2.00000x00D2", 1);
    expect_line(rd("k.rsa", &with(6, &v), f), "k.rsa", 7, &["values"]);
    // bad headers
    let l3 = format!("{:<14}{:>14}{:>14}{:>14}{:>14}", "XSA", 3, 3, 5, 0);
    expect_line(rd("k.rsa", &with(2, &l3), f), "k.rsa", 3, &["matrix type"]);
    let l3 = format!("{:<14}{:>14}{:>14}{:>14}{:>14}", "RSE", 3, 3, 5, 0);
    expect_line(rd("k.rsa", &with(2, &l3), f), "k.rsa", 3, &["elemental"]);
    let l3 = format!("{:<14}{:>14}{:>14}{:>14}{:>14}", "PSA", 3, 3, 5, 0);
    expect_line(rd("k.rsa", &with(2, &l3), f), "k.rsa", 3, &["pattern"]);
    let l3 = format!(
        "{:<14}{:>14}{:>14}{:>14}{:>14}",
        "RSA", 3, 3, 5_000_000_000u64, 0
    );
    expect_line(rd("k.rsa", &with(2, &l3), f), "k.rsa", 3, &["too large"]);
    expect_line(
        rd("k.rsa", &with(1, "five cards"), f),
        "k.rsa",
        2,
        &["TOTCRD"],
    );
    expect_line(
        rd("k.rsa", &with(3, "(4I3) (5I3) (nonsense)"), f),
        "k.rsa",
        4,
        &["Fortran formats"],
    );
    expect_line(
        rd("k.rsa", &lines[..2].join("\n"), f),
        "k.rsa",
        3,
        &["line 3"],
    );
    // unsymmetric, blank-separated formats, E exponents
    let rua = "unsymmetric 2x2\n3 1 1 1\nRUA 2 2 3 0\n(3I2) (3I2) (3E12.4)\n 1 2 4\n 1 1 2\n  1.0000E+00  2.0000E+00 -3.0000E+00\n";
    let t = rd("k.rua", rua, Format::Auto).unwrap();
    assert_eq!(dense(&t), vec![vec![1.0, 2.0], vec![0.0, -3.0]]);
}

#[test]
fn bad_abaqus_names_the_file_and_line() {
    let f = Format::Abaqus;
    // truncated line, wrong field count
    expect_line(
        rd("K.mtx", &format!("{ABQ_LABELS}30,1, 10\n"), f),
        "K.mtx",
        8,
        &["node, dof"],
    );
    expect_line(
        rd("K.mtx", "1, 1, 2.0\n1, 2, 3.0, 4\n", f),
        "K.mtx",
        2,
        &["row, column"],
    );
    expect_line(rd("K.mtx", "1, 1\n", f), "K.mtx", 1, &["row, column"]);
    // out-of-range index or dof
    expect_line(
        rd("K.mtx", "1, 1, 2.0\n0, 2, 3.0\n", f),
        "K.mtx",
        2,
        &["row 0"],
    );
    expect_line(rd("K.mtx", "1, 1, 1, 0, 2.0\n", f), "K.mtx", 1, &["dof 0"]);
    expect_line(
        rd("K.mtx", "1, 1, 1, 300, 2.0\n", f),
        "K.mtx",
        1,
        &["dof 300"],
    );
    expect_line(
        rd("K.mtx", "1, 200000000000, 2.0\n", f),
        "K.mtx",
        1,
        &["column 200000000000"],
    );
    // NaN in each format, with the entry's row and column
    let d = expect_line(rd("K.mtx", "1, 1, 2.0\n2, 1, nan\n", f), "K.mtx", 2, &[]);
    assert!(matches!(d, Detail::NonFinite { row: 1, col: 0, .. }), "{d}");
    let d = expect_line(
        rd("K.mtx", "5,1, 5,1, 1.0\n7,2, 5,1, inf\n7,2, 7,2, 1.0\n", f),
        "K.mtx",
        2,
        &[],
    );
    assert!(matches!(d, Detail::NonFinite { row: 1, col: 0, .. }), "{d}");
    // bad first line; an empty file; a negative node
    expect_line(
        rd("K.mtx", "STIFFNESS MATRIX\n1,1,1.0\n", f),
        "K.mtx",
        1,
        &["row, column, value"],
    );
    expect_line(
        rd("K.mtx", "** nothing\n", f),
        "K.mtx",
        1,
        &["at least one entry"],
    );
    expect_line(
        rd("K.mtx", "-1, 1, -1, 1, 1.0\n", f),
        "K.mtx",
        1,
        &["node, dof"],
    );
    // auto-detection of nothing known
    let e = rd("K.txt", "hello world\n", Format::Auto).unwrap_err();
    assert_eq!(line_of(&e, "K.txt"), 1);
    assert!(e.to_string().contains("cannot tell the format"), "{e}");
}

/// Random bytes, random truncations and byte flips of valid files: an error or
/// a matrix, never a panic; a matrix read always has its indices in range.
#[test]
fn random_bytes_and_truncations_never_panic() {
    let mut rng = ChaCha8Rng::seed_from_u64(27);
    let hb = hb_chain();
    let valid = [
        MM_SYM,
        MM_GEN,
        MM_ARRAY,
        MM_ARRAY_SYM,
        hb.as_str(),
        ABQ_LABELS,
        ABQ_COORD,
    ];
    let formats = [
        Format::Auto,
        Format::MatrixMarket,
        Format::HarwellBoeing,
        Format::Abaqus,
    ];
    let check = |bytes: &[u8]| {
        for f in formats {
            for name in ["x.mtx", "x.rsa", "x.mtx.gz"] {
                if let Ok(t) = read_bytes(Path::new(name), bytes, f) {
                    assert!(t.rows.iter().all(|&r| r < t.nrows));
                    assert!(t.cols.iter().all(|&c| c < t.ncols));
                    assert!(t.vals.iter().all(|v| v.is_finite()));
                    assert_eq!(t.rows.len(), t.vals.len());
                }
            }
        }
    };
    let alphabet =
        b"0123456789 .,-+eEdD%\n\r*RSAUIPE()%%MatrixMarket coordinate array real symmetric";
    for _ in 0..300 {
        let n = rng.random_range(0..200);
        let bytes: Vec<u8> = (0..n)
            .map(|_| {
                if rng.random_bool(0.9) {
                    alphabet[rng.random_range(0..alphabet.len())]
                } else {
                    rng.random()
                }
            })
            .collect();
        check(&bytes);
    }
    for v in valid {
        let b = v.as_bytes();
        for cut in 0..b.len() {
            check(&b[..cut]);
        }
        for _ in 0..200 {
            let mut m = b.to_vec();
            let k = rng.random_range(0..m.len());
            m[k] = alphabet[rng.random_range(0..alphabet.len())];
            check(&m);
        }
    }
    // random bytes after a gzip magic
    for _ in 0..50 {
        let mut bytes = vec![0x1f, 0x8b];
        bytes.extend((0..rng.random_range(0..64)).map(|_| rng.random::<u8>()));
        check(&bytes);
    }
}

/// A random sparse matrix as Matrix Market text: `symmetric` stores the lower
/// triangle; values with 17 significant digits over many magnitudes.
fn random_mm(rng: &mut ChaCha8Rng, n: usize, per_col: usize, symmetric: bool) -> String {
    let mut entries = Vec::new();
    for c in 0..n {
        for _ in 0..per_col {
            let r = if symmetric {
                rng.random_range(c..n)
            } else {
                rng.random_range(0..n)
            };
            let v: f64 = (rng.random::<f64>() - 0.5) * 10f64.powi(rng.random_range(-30..30));
            entries.push(format!("{} {} {:.16e}", r + 1, c + 1, v));
        }
    }
    format!(
        "%%MatrixMarket matrix coordinate real {}\n% generated\n{n} {n} {}\n{}\n",
        if symmetric { "symmetric" } else { "general" },
        entries.len(),
        entries.join("\n")
    )
}

fn same_as_nalgebra(text: &str) {
    let t = rd("x.mtx", text, Format::Auto).unwrap();
    let coo = nalgebra_sparse::io::load_coo_from_matrix_market_str::<f64>(text).unwrap();
    assert_eq!((coo.nrows(), coo.ncols()), (t.nrows, t.ncols));
    let a: Vec<(usize, usize, u64)> = coo
        .triplet_iter()
        .map(|(r, c, v)| (r, c, v.to_bits()))
        .collect();
    let b: Vec<(usize, usize, u64)> = t.expanded().map(|(r, c, v)| (r, c, v.to_bits())).collect();
    assert!(a == b, "triplets differ from nalgebra-sparse's");
}

#[test]
fn matrix_market_gives_nalgebra_sparse_triplets_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for symmetric in [true, false] {
        same_as_nalgebra(&random_mm(&mut rng, 300, 5, symmetric));
    }
    same_as_nalgebra(MM_ARRAY);
    same_as_nalgebra(MM_ARRAY_SYM);
    // large enough for the parallel path (several chunks)
    let big = random_mm(&mut rng, 40_000, 5, true);
    assert!(big.len() > feio::mm::PARALLEL_MIN_BYTES, "{}", big.len());
    same_as_nalgebra(&big);
    // an error deep in the parallel path names its line
    let mut lines: Vec<&str> = big.lines().collect();
    let k = lines.len() - 1234;
    lines[k] = "1 1 oops";
    let bad = lines.join("\n");
    let e = rd("big.mtx", &bad, Format::Auto).unwrap_err();
    assert_eq!(line_of(&e, "big.mtx"), k + 1, "{e}");
    // one entry too many, deep in the file
    let mut lines: Vec<&str> = big.lines().collect();
    let size = format!("40000 40000 {}", 40_000 * 5 - 1);
    lines[2] = &size;
    let e = rd("big.mtx", &lines.join("\n"), Format::Auto).unwrap_err();
    assert_eq!(line_of(&e, "big.mtx"), lines.len(), "{e}");
}

/// `text` read in windows of `window` bytes ([`feio::mm::parse_reader_window`]).
fn windowed(text: &str, window: usize) -> Result<Triplets, Error> {
    let b = text.as_bytes();
    let first = b[..b.len().min(window)].to_vec();
    let mut rest = &b[first.len()..];
    feio::mm::parse_reader_window(
        Path::new("w.mtx"),
        first,
        &mut rest,
        Some(b.len() as u64),
        window,
    )
}

#[test]
fn matrix_market_read_in_windows_equals_the_whole_text() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let good = random_mm(&mut rng, 200, 4, true);
    let mut cases = vec![good.clone(), MM_SYM.to_string(), MM_GEN.to_string()];
    let lines: Vec<&str> = good.lines().collect();
    // a bad value, a NaN, an index out of range, a truncated line, too many
    // and too few entries, deep in the file
    for (k, bad) in [
        (400, "1 1 oops"),
        (500, "3 2 nan"),
        (600, "201 1 1.0"),
        (700, "5 4"),
    ] {
        let mut l = lines.clone();
        l[k] = bad;
        cases.push(l.join("\n"));
    }
    let mut l = lines.clone();
    let size = format!("200 200 {}", 200 * 4 - 3);
    l[2] = &size;
    cases.push(l.join("\n"));
    cases.push(lines[..lines.len() - 5].join("\n"));
    for text in &cases {
        let whole = rd("w.mtx", text, Format::MatrixMarket);
        for window in [1, 40, 64, 97, 1000, 1 << 20] {
            let w = windowed(text, window);
            match (&whole, &w) {
                (Ok(a), Ok(b)) => assert_eq!(a, b, "window {window}"),
                (Err(a), Err(b)) => {
                    assert_eq!(a.line(), b.line(), "window {window}: {a} / {b}");
                    assert_eq!(
                        std::mem::discriminant(a),
                        std::mem::discriminant(b),
                        "{a} / {b}"
                    );
                }
                _ => panic!("window {window}: {whole:?} vs {w:?}"),
            }
        }
    }
    // and from a file (read() streams a plain Matrix Market file)
    let dir = std::env::temp_dir().join(format!("feio_window_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("good.mtx");
    std::fs::write(&p, &good).unwrap();
    let mut a = read(&p, Format::Auto).unwrap();
    let b = rd("good.mtx", &good, Format::Auto).unwrap();
    a.format = b.format;
    assert_eq!(a, b);
    std::fs::remove_dir_all(&dir).ok();
}

/// A random Abaqus file of `n` nodes with 3 DOFs each: the labels format
/// (`node, dof, node, dof, value`, lower triangle of a band of 2 nodes, a
/// keyword line and a comment line between entries now and then) or, with
/// `coordinate`, the same entries as `row, column, value`.
fn random_abaqus(rng: &mut ChaCha8Rng, n: u64, coordinate: bool) -> String {
    let mut t = String::from("** MATRIX OUTPUT, STIFFNESS\n*MATRIX, TYPE=STIFFNESS\n");
    for a in 1..=n {
        for b in a.saturating_sub(2).max(1)..=a {
            for da in 1..=3u64 {
                for db in 1..=3u64 {
                    if (b, db) > (a, da) {
                        continue;
                    }
                    let v: f64 = rng.random_range(-1e8..1e8);
                    if coordinate {
                        let (r, c) = (3 * (a - 1) + da, 3 * (b - 1) + db);
                        t.push_str(&format!("{r}, {c}, {v:.16e}\n"));
                    } else {
                        t.push_str(&format!("{a}, {da}, {b}, {db}, {v:.16e}\n"));
                    }
                }
            }
        }
        if a % 37 == 0 {
            t.push_str("** a comment\n\n");
        }
    }
    t
}

/// Abaqus text read in windows ([`feio::abaqus::parse_reader_window`], what
/// `read` does with a file): the whole text's matrix, labels and errors
/// (the same line) at every window size, bad lines deep in the file; and
/// `read` of the plain and the gzip-compressed file equal to the bytes'.
#[test]
fn abaqus_read_in_windows_equals_the_whole_text() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let labels = random_abaqus(&mut rng, 60, false);
    let coordinate = random_abaqus(&mut rng, 60, true);
    let mut cases = vec![labels.clone(), coordinate.clone()];
    for good in [&labels, &coordinate] {
        let lines: Vec<&str> = good.lines().collect();
        let n = lines.len();
        for (k, bad) in [
            (n / 3, "1, 1, oops"),
            (n / 2, "7, 2, 5, 1, nan"),
            (2 * n / 3, "0, 1, 1.0"),
            (n - 3, "5, 4"),
        ] {
            let mut l = lines.clone();
            l[k] = bad;
            cases.push(l.join("\n"));
        }
        cases.push(lines[..n - 5].join("\r\n"));
    }
    let window_read = |text: &str, window: usize| {
        let b = text.as_bytes();
        let first = b[..b.len().min(window)].to_vec();
        let mut rest = &b[first.len()..];
        feio::abaqus::parse_reader_window(
            Path::new("K.mtx"),
            first,
            &mut rest,
            Some(b.len() as u64),
            window,
        )
    };
    for text in &cases {
        let whole = rd("K.mtx", text, Format::Abaqus);
        for window in [1, 40, 64, 97, 1000, 1 << 20] {
            let w = window_read(text, window);
            match (&whole, &w) {
                (Ok(a), Ok(b)) => {
                    let first = (0..a.rows.len().min(b.rows.len()))
                        .find(|&k| (a.rows[k], a.cols[k]) != (b.rows[k], b.cols[k]));
                    assert!(
                        a.rows == b.rows && a.cols == b.cols,
                        "window {window}: {} / {} entries, first difference {first:?}",
                        a.rows.len(),
                        b.rows.len()
                    );
                    assert!(a.vals == b.vals && a.labels == b.labels, "window {window}");
                    assert_eq!((a.nrows, a.ncols), (b.nrows, b.ncols), "window {window}");
                    assert_eq!(a.symmetric_storage, b.symmetric_storage);
                    assert_eq!(a.format, b.format, "window {window}");
                }
                (Err(a), Err(b)) => {
                    assert_eq!(a.to_string(), b.to_string(), "window {window}");
                    assert!(a.line().unwrap() > 100, "{a}");
                }
                _ => panic!("window {window}: {whole:?} vs {w:?}"),
            }
        }
    }
    let t = rd("K.mtx", &labels, Format::Auto).unwrap();
    assert_eq!(t.format, Format::Abaqus);
    assert_eq!(t.nrows, 180);
    let dir = std::env::temp_dir().join(format!("feio_abaqus_window_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, text) in [("job_STIF1.mtx", &labels), ("K.txt", &coordinate)] {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        assert_eq!(
            read(&p, Format::Auto).unwrap(),
            rd(name, text, Format::Auto).unwrap()
        );
        let pz = dir.join(format!("{name}.gz"));
        let mut enc = flate2_writer(std::fs::File::create(&pz).unwrap());
        std::io::Write::write_all(&mut enc, text.as_bytes()).unwrap();
        enc.finish().unwrap();
        assert_eq!(
            read(&pz, Format::Auto).unwrap(),
            rd(name, text, Format::Auto).unwrap()
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A random symmetric banded matrix of order `n` as Harwell-Boeing (RSA,
/// lower triangle by columns, `(10I8)`, `(10I8)`, `(1P,4E20.12)`).
fn random_hb(rng: &mut ChaCha8Rng, n: usize) -> String {
    let (mut ptr, mut ind, mut val) = (vec![1usize], Vec::new(), Vec::new());
    for c in 0..n {
        for r in c..(c + 4).min(n) {
            ind.push(r + 1);
            val.push(rng.random_range(-1e8..1e8));
        }
        ptr.push(ind.len() + 1);
    }
    let records = |items: Vec<String>, per: usize| -> Vec<String> {
        items.chunks(per).map(|c| c.concat()).collect()
    };
    let p = records(ptr.iter().map(|x| format!("{x:>8}")).collect(), 10);
    let i = records(ind.iter().map(|x| format!("{x:>8}")).collect(), 10);
    let v = records(
        val.iter().map(|x: &f64| format!("{x:>20.12E}")).collect(),
        4,
    );
    let mut t = format!(
        "{:<72}{:<8}\n{:>14}{:>14}{:>14}{:>14}\n{:<14}{:>14}{:>14}{:>14}{:>14}\n{:<16}{:<16}{:<20}\n",
        "random band",
        "K",
        p.len() + i.len() + v.len(),
        p.len(),
        i.len(),
        v.len(),
        "RSA",
        n,
        n,
        ind.len(),
        0,
        "(10I8)",
        "(10I8)",
        "(1P,4E20.12)"
    );
    for l in p.iter().chain(&i).chain(&v) {
        t.push_str(l);
        t.push('\n');
    }
    t
}

/// `read` parses a Harwell-Boeing file line by line (plain and
/// gzip-compressed): the matrix and the errors of the whole text, bad
/// records deep in the file named by the same line.
#[test]
fn harwell_boeing_read_line_by_line_equals_the_whole_text() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let good = random_hb(&mut rng, 300);
    let lines: Vec<&str> = good.lines().collect();
    let n = lines.len();
    let with = |k: usize, l: &str| {
        let mut v = lines.clone();
        v[k] = l;
        v.join("\n") + "\n"
    };
    let long = format!("{:>20.12E}", f64::NAN);
    let cases = [
        good.clone(),
        good.replace('\n', "\r\n"),
        lines[..n - 3].join("\n"),
        with(n - 10, "  1.0E+00  oops"),
        with(n - 2, &long),
        with(40, "       1    9999"),
    ];
    let dir = std::env::temp_dir().join(format!("feio_hb_lines_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (k, text) in cases.iter().enumerate() {
        let whole = rd("k.rsa", text, Format::Auto);
        if k <= 1 {
            let t = whole.as_ref().unwrap();
            assert_eq!((t.nrows, t.nnz()), (300, 300 * 4 - 6));
        } else {
            assert!(whole.as_ref().unwrap_err().line().unwrap() > 30);
        }
        let p = dir.join("k.rsa");
        std::fs::write(&p, text).unwrap();
        let pz = dir.join("k.rsa.gz");
        let mut enc = flate2_writer(std::fs::File::create(&pz).unwrap());
        std::io::Write::write_all(&mut enc, text.as_bytes()).unwrap();
        enc.finish().unwrap();
        for file in [&p, &pz] {
            let streamed = read(file, Format::Auto);
            match (&whole, &streamed) {
                (Ok(a), Ok(b)) => assert!(a == b, "case {k}: {}", file.display()),
                (Err(a), Err(b)) => {
                    assert_eq!(a.line(), b.line(), "case {k}: {a} / {b}");
                    assert_eq!(
                        a.to_string().replace("k.rsa", ""),
                        b.to_string()
                            .replace(&file.display().to_string(), "")
                            .replace("k.rsa.gz", ""),
                        "case {k}"
                    );
                }
                _ => panic!("case {k}: {:?} / {:?}", whole.is_ok(), streamed.is_ok()),
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// An Abaqus file large enough for several parallel chunks per window: the
/// matrix, labels and errors (bad entries deep in the file, a non-finite
/// value named by its line and indices) of a one-thread read, exactly.
#[test]
fn abaqus_parallel_chunks_equal_one_thread() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let big = random_abaqus(&mut rng, 6000, false);
    assert!(big.len() > feio::mm::PARALLEL_MIN_BYTES, "{}", big.len());
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let lines: Vec<&str> = big.lines().collect();
    let n = lines.len();
    let mut cases = vec![(big.clone(), None)];
    for (k, bad) in [
        (n - 1234, "1, 1, 1, 1, oops"),
        (n / 2 + 7, "7, 2, 5, 1, nan"),
        (n - 3, "5, 4"),
    ] {
        let mut l = lines.clone();
        l[k] = bad;
        cases.push((l.join("\n"), Some(k + 1)));
    }
    for (text, line) in &cases {
        let seq = one.install(|| rd("K.mtx", text, Format::Abaqus));
        let par = rd("K.mtx", text, Format::Abaqus);
        match (&seq, &par, line) {
            (Ok(a), Ok(b), None) => {
                assert!(a == b, "parallel read differs");
                assert_eq!(a.nrows, 18_000);
            }
            (Err(a), Err(b), Some(l)) => {
                assert_eq!(a.to_string(), b.to_string());
                assert_eq!(a.line(), Some(*l), "{a}");
            }
            _ => panic!("{line:?}: {:?} / {:?}", seq.is_ok(), par.is_ok()),
        }
    }
}

/// Node numbers far apart (no table of them: binary search) give the rows
/// and columns of the same file with dense node numbers.
#[test]
fn abaqus_sparse_node_numbers_give_the_same_indices() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let dense = random_abaqus(&mut rng, 50, false);
    let spread: String = dense
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(", ").collect();
            if f.len() != 5 {
                return format!("{l}\n");
            }
            let node = |s: &str| s.parse::<u64>().unwrap() * 10_000_000_000;
            format!(
                "{}, {}, {}, {}, {}\n",
                node(f[0]),
                f[1],
                node(f[2]),
                f[3],
                f[4]
            )
        })
        .collect();
    let (a, b) = (
        rd("K.mtx", &dense, Format::Abaqus).unwrap(),
        rd("K.mtx", &spread, Format::Abaqus).unwrap(),
    );
    assert!(a.rows == b.rows && a.cols == b.cols && a.vals == b.vals);
    let labels = b.labels.unwrap();
    assert_eq!(labels.len(), 150);
    assert_eq!(labels[149], (500_000_000_000, 3));
}
