//! Writes the scale benchmark's solid FE model (`docs/performance.md`): the
//! steel cantilever plate of 8-node hexahedra of [`nlmode::structure::solid`]
//! at about the requested number of DOFs, as Matrix Market files (coordinate,
//! real, symmetric: the lower triangle, 17 significant digits, as scipy's
//! `mmwrite` writes them) and a `host nma` scenario that reduces it by
//! Craig-Bampton onto two points (the free edge's middle and a drive point at
//! 2/3 of the length, transverse) plus 10 fixed-interface modes.
//!
//! ```text
//! cargo run --release -p nlmode --example hex_plate -- --dofs 100000 --out /tmp/plate100k
//! ```
//!
//! writes `plate_M.mtx`, `plate_K.mtx`, `plate.toml` and `points.json` (the
//! points' DOFs, 0-based) into the folder.
use nlmode::structure::solid::HexPlate;
use nlmode::structure::SparseMatrix;
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};

fn main() {
    if let Err(e) = run() {
        eprintln!("hex_plate: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut dofs = 100_000usize;
    let mut out = PathBuf::from("plate");
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or(format!("{a}: missing value"));
        match a.as_str() {
            "--dofs" => dofs = value()?.parse().map_err(|e| format!("--dofs: {e}"))?,
            "--out" => out = PathBuf::from(value()?),
            _ => return Err(format!("unknown argument {a}; use --dofs N --out DIR")),
        }
    }
    let plate = HexPlate::benchmark(dofs);
    let t0 = std::time::Instant::now();
    let (m, k) = plate.assemble().map_err(|e| e.to_string())?;
    eprintln!(
        "plate {} x {} x {} elements, {} DOFs, {} stored entries per matrix, assembled in {:.1} s",
        plate.nx,
        plate.ny,
        plate.nz,
        plate.ndof(),
        k.compute_nnz(),
        t0.elapsed().as_secs_f64()
    );
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    write_mtx(&out.join("plate_M.mtx"), &m)?;
    drop(m);
    write_mtx(&out.join("plate_K.mtx"), &k)?;
    let mid = plate.ny / 2;
    let tip = plate.dof(plate.nx, mid, plate.nz, 2).expect("free node");
    let drive = plate
        .dof((2 * plate.nx).div_ceil(3), mid, plate.nz, 2)
        .expect("free node");
    let scenario = format!(
        r#"# Scale benchmark (docs/performance.md): steel cantilever plate
# {l} x {w} x {t} m of {nx} x {ny} x {nz} 8-node hexahedra, {n} DOFs,
# written by `cargo run --release -p nlmode --example hex_plate`.
title = "Hexahedral cantilever plate, {n} DOFs"

[structure]
kind = "matrices"
mass_mtx = "plate_M.mtx"
stiffness_mtx = "plate_K.mtx"
damping_ratio = 0.004
reduction = "craig-bampton"
cb_masters = ["tip", "drive"]
cb_modes = 10
k3_n_per_m3 = 1e9
nonlinear_point = "tip"

[[structure.point]]
name = "tip"      # middle of the free edge, top face, transverse
dof = {tip}

[[structure.point]]
name = "drive"    # 2/3 of the length, top face, transverse
dof = {drive}

[[exciter]]
point = "drive"

[excitation]
voltage_v = 1.0
eta_start = 0.8
eta_end = 1.5
rate_per_pseudo_period = 0.02

[nma]
max_tip_amplitude_m = 1e-3

[output]
response_point = "tip"
"#,
        l = plate.length_m,
        w = plate.width_m,
        t = plate.thickness_m,
        nx = plate.nx,
        ny = plate.ny,
        nz = plate.nz,
        n = plate.ndof(),
    );
    let write = |name: &str, text: &str| {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))
    };
    write("plate.toml", &scenario)?;
    write(
        "points.json",
        &format!(
            "{{\"ndof\": {}, \"tip\": {tip}, \"drive\": {drive}}}\n",
            plate.ndof()
        ),
    )?;
    eprintln!(
        "written to {} in {:.1} s",
        out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The lower triangle of the symmetric `a` as Matrix Market text, 17
/// significant digits; the columns formatted in parallel chunks.
fn write_mtx(path: &Path, a: &SparseMatrix) -> Result<(), String> {
    let err = |e: std::io::Error| format!("{}: {e}", path.display());
    let sym = a.symbolic();
    let (col_ptr, rows, val) = (sym.col_ptr(), sym.row_idx(), a.val());
    let lower: usize = (0..a.ncols())
        .map(|c| {
            (col_ptr[c]..col_ptr[c + 1])
                .filter(|&p| rows[p] >= c)
                .count()
        })
        .sum();
    let mut f =
        std::io::BufWriter::with_capacity(1 << 22, std::fs::File::create(path).map_err(err)?);
    writeln!(f, "%%MatrixMarket matrix coordinate real symmetric").map_err(err)?;
    writeln!(f, "{} {} {}", a.nrows(), a.ncols(), lower).map_err(err)?;
    let chunk = 20_000;
    let starts: Vec<usize> = (0..a.ncols()).step_by(chunk).collect();
    for group in starts.chunks(8) {
        let texts: Vec<String> = group
            .par_iter()
            .map(|&c0| {
                let mut s = String::new();
                for c in c0..(c0 + chunk).min(a.ncols()) {
                    for p in col_ptr[c]..col_ptr[c + 1] {
                        if rows[p] >= c {
                            use std::fmt::Write as _;
                            let _ = writeln!(s, "{} {} {:.16e}", rows[p] + 1, c + 1, val[p]);
                        }
                    }
                }
                s
            })
            .collect();
        for t in texts {
            f.write_all(t.as_bytes()).map_err(err)?;
        }
    }
    f.flush().map_err(err)
}
