//! The scale benchmark's counterpart of `scripts/scale/scipy_eigsh.py`
//! (`docs/performance.md`): the 10 lowest modes of the plate written by the
//! `hex_plate` example by nlmode's sparse path alone (fill-reducing ordering,
//! Cholesky of `K`, shift-invert block Lanczos), so that its time compares
//! with scipy's `eigsh(K, 10, M, sigma=0)` for the same work. Prints one JSON
//! line: the stage wall times [s] (and the solves' share of the Lanczos run),
//! the basis size and `omega` [rad/s].
//!
//! ```text
//! cargo run --release -p nlmode --example lowest_modes -- DIR [--modes N] [--threads N]
//!     [--ordering auto|amd|nested-dissection]
//! ```
use nlmode::structure::lanczos::{lanczos, omega_of, Pencil, ShiftInvert};
use nlmode::structure::matrices::{read_matrix_market_sparse, MatrixRole};
use nlmode::structure::sparse::{Ordering, SparseCholesky, SymbolicFactor};
use std::cell::Cell;
use std::path::PathBuf;
use std::time::Instant;

fn main() {
    if let Err(e) = run() {
        eprintln!("lowest_modes: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let usage =
        "usage: lowest_modes DIR [--modes N] [--threads N] [--ordering auto|amd|nested-dissection]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut dir, mut n_modes, mut threads) = (None, 10usize, 0usize);
    let mut ordering = Ordering::Auto;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or(format!("{a}: missing value"));
        match a.as_str() {
            "--modes" => n_modes = value()?.parse().map_err(|e| format!("{a}: {e}"))?,
            "--threads" => threads = value()?.parse().map_err(|e| format!("{a}: {e}"))?,
            "--ordering" => {
                let v = value()?;
                ordering = serde_json::from_value(serde_json::json!(v))
                    .map_err(|_| format!("{a}: {v} is not auto, amd or nested-dissection"))?;
            }
            _ if dir.is_none() => dir = Some(PathBuf::from(a)),
            _ => return Err(format!("unknown argument {a}; {usage}")),
        }
    }
    let dir = dir.ok_or(usage)?;
    let par = match threads {
        1 => faer::Par::Seq,
        0 => faer::Par::rayon(0),
        t => faer::Par::rayon(t),
    };
    let t0 = Instant::now();
    let (mp, kp) = (dir.join("plate_M.mtx"), dir.join("plate_K.mtx"));
    let m = read_matrix_market_sparse(MatrixRole::Mass, &mp).map_err(|e| e.to_string())?;
    let k = read_matrix_market_sparse(MatrixRole::Stiffness, &kp).map_err(|e| e.to_string())?;
    let t1 = Instant::now();
    let symbolic = SymbolicFactor::with_ordering(&k, ordering).ok_or("ordering of K failed")?;
    let t2 = Instant::now();
    let factor = SparseCholesky::with_symbolic(&symbolic, &k, par)
        .ok_or("K is not positive definite (this benchmark takes no rigid-body modes)")?;
    let t3 = Instant::now();
    let pencil = Pencil {
        m: &m,
        k: &k,
        fixed: &[],
        par,
    };
    let timed = TimedSolves {
        factor: &factor,
        seconds: Cell::new(0.0),
        count: Cell::new(0),
    };
    let modes = lanczos(&pencil, &timed, 0.0, n_modes, "modes").map_err(|e| e.to_string())?;
    let omega = omega_of(&modes.lambda, modes.lambda_scale).map_err(|e| e.to_string())?;
    let t4 = Instant::now();
    let s = |a: Instant, b: Instant| (b - a).as_secs_f64();
    let out = serde_json::json!({
        "ndof": k.nrows(),
        "read_s": s(t0, t1),
        "order_s": s(t1, t2),
        "factor_s": s(t2, t3),
        "lanczos_s": s(t3, t4),
        "eigen_s": s(t1, t4),
        "solve_s": timed.seconds.get(),
        "solves": timed.count.get(),
        "basis": modes.basis,
        "omega_rad_s": omega,
    });
    println!("{out}");
    Ok(())
}

/// The factor's solves, counted and timed (the Lanczos run's main cost).
struct TimedSolves<'a> {
    factor: &'a SparseCholesky,
    seconds: Cell<f64>,
    count: Cell<usize>,
}

impl ShiftInvert for TimedSolves<'_> {
    fn solve_in_place(&self, b: &mut nalgebra::DMatrix<f64>) {
        let t = Instant::now();
        self.factor.solve_in_place(b);
        self.seconds
            .set(self.seconds.get() + t.elapsed().as_secs_f64());
        self.count.set(self.count.get() + 1);
    }
}
