//! The paper's structure-shaker co-simulation as an SSP 1.0 archive
//! (issue 6 item 4), written by the host's exporter
//! ([`host::fmus::structure_shaker::export_ssp`]), and the host's own Jacobi master run on the
//! same FMUs with the same macro step, so that an SSP runner (fmpy's
//! `simulate_ssp`, fixed-step Jacobi with zero-order hold) can be compared
//! with it (`tests/test_cosim.py`).
//!
//! ```text
//! cargo run --release -p host --example cosim_ssp -- \
//!     STRUCTURE.fmu SHAKER.fmu OUT_DIR U_HAT_V OMEGA_START OMEGA_END RATE MACRO_STEP_S STOP_TIME_S [zoh|extrapolate]
//! ```
//!
//! The shaker is the paper's (`ShakerParams::paper()`, the `host run`
//! default exciter), driving the drive point `2l3`; the sweep is given in
//! rad/s and rad/s^2 as the shaker FMU takes it. Writes
//! `OUT_DIR/structure-shaker.ssp` and `OUT_DIR/host_jacobi.csv` (`t_s,
//! x_tip_m, x_m, force_N` at every communication point, from `t = 0`).
//! `zoh` (default) runs the master without input derivatives (zero-order
//! hold, what SSP runners do); `extrapolate` with first-order extrapolation.
//! An example rather than a `host` subcommand so that it needs no change to
//! the CLI; it uses the public API of the `cosim` crate.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use cosim::Algorithm;
use host::fmus::structure_shaker::{export_ssp, run_cosim, CosimParams};
use nlmode::attachment::ShakerParams;
use nlmode::excitation::LinearSweep;

const USAGE: &str =
    "usage: cosim_ssp STRUCTURE.fmu SHAKER.fmu OUT_DIR U_HAT_V OMEGA_START_RAD_S OMEGA_END_RAD_S \
                     RATE_RAD_S2 MACRO_STEP_S STOP_TIME_S [zoh|extrapolate]";

fn number(args: &[String], i: usize, name: &str) -> Result<f64, String> {
    let s = args
        .get(i)
        .ok_or_else(|| format!("missing {name}\n{USAGE}"))?;
    s.parse::<f64>().map_err(|e| format!("{name} = '{s}': {e}"))
}

fn main_inner() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 9 || args.len() > 10 {
        return Err(USAGE.into());
    }
    let structure = PathBuf::from(&args[0]);
    let shaker = PathBuf::from(&args[1]);
    let out = PathBuf::from(&args[2]);
    let sweep = LinearSweep {
        amplitude: number(&args, 3, "U_HAT_V")?,
        omega_start_rad_s: number(&args, 4, "OMEGA_START_RAD_S")?,
        omega_end_rad_s: number(&args, 5, "OMEGA_END_RAD_S")?,
        rate_rad_s2: number(&args, 6, "RATE_RAD_S2")?,
    };
    let h = number(&args, 7, "MACRO_STEP_S")?;
    let stop = number(&args, 8, "STOP_TIME_S")?;
    let extrapolate = match args.get(9).map(String::as_str) {
        None | Some("zoh") => false,
        Some("extrapolate") => true,
        Some(other) => {
            return Err(format!(
                "input mode '{other}': expected zoh or extrapolate\n{USAGE}"
            ))
        }
    };
    let mut p = CosimParams::new(ShakerParams::paper(), sweep);
    p.algorithm = Algorithm::Jacobi;
    p.extrapolate = extrapolate;
    p.macro_step_s = h;
    p.stop_time_s = Some(stop);
    p.output_interval_s = h;
    std::fs::create_dir_all(&out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let ssp = out.join("structure-shaker.ssp");
    export_ssp(&ssp, &structure, &shaker, &p).map_err(|e| format!("SSP export: {e}"))?;
    println!("wrote {}", ssp.display());
    let o = run_cosim(&structure, &shaker, &p, &mut |_| {}).map_err(|e| format!("cosim: {e}"))?;
    if let Some((t, msg)) = &o.stopped {
        return Err(format!("cosim stopped at t = {t} s: {msg}"));
    }
    let csv = out.join("host_jacobi.csv");
    let f =
        std::fs::File::create(&csv).map_err(|e| format!("cannot write {}: {e}", csv.display()))?;
    let mut w = std::io::BufWriter::new(f);
    let werr = |e: std::io::Error| format!("cannot write {}: {e}", csv.display());
    writeln!(w, "t_s,x_tip_m,x_m,force_N").map_err(werr)?;
    for k in 0..o.time_s.len() {
        writeln!(
            w,
            "{:e},{:e},{:e},{:e}",
            o.time_s[k], o.x_tip_m[k], o.x_m[k], o.force_n[k]
        )
        .map_err(werr)?;
    }
    w.flush().map_err(werr)?;
    println!(
        "wrote {} ({} rows; Jacobi, {}, h = {h:e} s, {} macro steps, wall {:.3} s)",
        csv.display(),
        o.time_s.len(),
        if extrapolate {
            "first-order extrapolation"
        } else {
            "zero-order hold"
        },
        o.stats.steps,
        o.wall_time_s
    );
    Ok(())
}

fn main() -> ExitCode {
    match main_inner() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
