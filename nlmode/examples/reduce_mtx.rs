//! The scale benchmark's reduction (`docs/performance.md`): reads the plate
//! written by the `hex_plate` example and runs nlmode's large-model path on it
//! (checks, ordering and memory estimate, factorisation, the full model's 7
//! lowest modes, Craig-Bampton onto the points `tip` and `drive` plus 10
//! fixed-interface modes), printing each stage's wall time and the process'
//! peak memory after it, then one JSON line with the results.
//!
//! ```text
//! cargo run --release -p nlmode --example reduce_mtx -- DIR [--threads N] [--memory-limit-gb X]
//!     [--ordering auto|amd|nested-dissection]
//! ```
//!
//! The memory limit defaults to 75 % of `MemAvailable` in `/proc/meminfo`
//! (what `host` passes as well).
use nlmode::structure::matrices::{
    matrix_structure_sparse_cb_with, read_matrix_market_sparse, MatrixDamping, MatrixRole,
    MatrixStructureOptions,
};
use nlmode::structure::sparse::{SparseOptions, Stage};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// 75 % of the available memory [bytes] from `/proc/meminfo` (`None` where
/// the file or the field is missing).
fn default_memory_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024 / 4 * 3)
}

/// Peak resident memory of this process so far [GB] (`VmHWM`).
fn peak_gb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|t| {
            let l = t.lines().find(|l| l.starts_with("VmHWM:"))?.to_string();
            l.split_whitespace().nth(1)?.parse::<f64>().ok()
        })
        .map_or(f64::NAN, |kb| kb * 1024.0 / 1e9)
}

fn main() {
    if let Err(e) = run() {
        eprintln!("reduce_mtx: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut dir = None;
    let mut sparse = SparseOptions {
        memory_limit_bytes: default_memory_limit(),
        ..Default::default()
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or(format!("{a}: missing value"));
        match a.as_str() {
            "--threads" => sparse.threads = value()?.parse().map_err(|e| format!("{a}: {e}"))?,
            "--memory-limit-gb" => {
                let gb: f64 = value()?.parse().map_err(|e| format!("{a}: {e}"))?;
                sparse.memory_limit_bytes = Some((gb * 1e9) as u64);
            }
            "--ordering" => {
                let v = value()?;
                sparse.ordering = serde_json::from_value(serde_json::json!(v))
                    .map_err(|_| format!("{a}: {v} is not auto, amd or nested-dissection"))?;
            }
            _ if dir.is_none() => dir = Some(PathBuf::from(a)),
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    let dir = dir.ok_or(
        "usage: reduce_mtx DIR [--threads N] [--memory-limit-gb X] [--ordering auto|amd|nested-dissection]",
    )?;
    let points = std::fs::read_to_string(dir.join("points.json")).map_err(|e| e.to_string())?;
    let points: serde_json::Value = serde_json::from_str(&points).map_err(|e| e.to_string())?;
    let dof = |k: &str| {
        points[k]
            .as_u64()
            .map(|v| v as usize)
            .ok_or(format!("points.json: {k}"))
    };
    let (tip, drive) = (dof("tip")?, dof("drive")?);
    let t0 = Instant::now();
    let (mp, kp) = (dir.join("plate_M.mtx"), dir.join("plate_K.mtx"));
    let mass = read_matrix_market_sparse(MatrixRole::Mass, &mp).map_err(|e| e.to_string())?;
    let stiffness =
        read_matrix_market_sparse(MatrixRole::Stiffness, &kp).map_err(|e| e.to_string())?;
    let read_s = t0.elapsed().as_secs_f64();
    eprintln!("read     {read_s:8.2} s   peak {:6.2} GB", peak_gb());
    sparse.progress = Some(Arc::new(|stage: Stage, dt| {
        eprintln!(
            "{:<8} {:8.2} s   peak {:6.2} GB",
            stage.name(),
            dt.as_secs_f64(),
            peak_gb()
        );
    }));
    let opts = MatrixStructureOptions {
        mass,
        mass_path: mp,
        stiffness,
        stiffness_path: kp,
        damping: MatrixDamping::StiffnessProportional {
            ratio: 0.004,
            mode_index: 0,
        },
        damping_path: None,
        points: vec![("tip".into(), tip), ("drive".into(), drive)],
        cubic_spring: None,
        craig_bampton: Some((vec!["tip".into(), "drive".into()], 10)),
        allow_rigid_body_modes: false,
    };
    let t1 = Instant::now();
    let mut s = matrix_structure_sparse_cb_with(&opts, &sparse).map_err(|e| e.to_string())?;
    if let Some(t) = s.timings.as_mut() {
        t.read_s = read_s;
    }
    let reduce_s = t1.elapsed().as_secs_f64();
    let out = serde_json::json!({
        "ndof": s.full_ndof,
        "read_s": read_s,
        "reduce_s": reduce_s,
        "timings": s.timings,
        "omega0_rad_s": s.omega0_rad_s,
        "interface_omega_rad_s": s.interface_omega_rad_s,
        "peak_gb": peak_gb(),
        "memory_limit_bytes": sparse.memory_limit_bytes,
    });
    println!("{out}");
    Ok(())
}
