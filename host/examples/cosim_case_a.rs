//! The paper's case (a) (2l/3, 10 V, r = 2 %, 0.8-1.8 omega0) co-simulated
//! with the repository's FMUs (release cdylibs, nonlinear modal table by NMA
//! with H = 3) for every algorithm and a ladder of macro steps (issue 6,
//! performance section): prints the envelope errors against
//! `nlmode::reference::simulate_sweep` and against the finest co-simulation,
//! and the wall times.
//!
//! `cargo build --release -p fmu-structure -p fmu-shaker && NLMODE_FMU_DIR=target/release
//! cargo run --release -p host --example cosim_case_a`
//! (the host overhead per macro step: `cargo bench -p cosim --bench cosim`).
use cosim::Algorithm;
use host::fmus::structure_shaker::{run_cosim, CosimOutput, CosimParams};
use std::path::{Path, PathBuf};
use std::time::Instant;

fn release_fmus(dir: &Path, table: &nlmode::nma::ModalTable) -> (PathBuf, PathBuf) {
    let tp = dir.join("modal_table.json");
    table.write(&tp).unwrap();
    // the FMU libraries of a release build: `NLMODE_FMU_DIR=target/release`
    let libs = host::fmus::locate_libraries(None).unwrap();
    host::fmus::package_repo_fmus(&libs, dir, Some(&tp)).unwrap()
}

/// (peak tip error, jump-down frequency error, RMS tip difference / peak, RMS force difference / max force)
fn compare(o: &CosimOutput, r_om: &[f64], r_f: &[f64], r_tip: &[f64]) -> (f64, f64, f64, f64) {
    let c = o.envelope.compare_with(r_om, r_f, r_tip);
    (
        c.peak_tip_rel,
        c.jump_down_rel,
        c.rms_tip_rel,
        c.rms_force_rel,
    )
}

fn main() {
    use nlmode::attachment::{LinearAttachment, ShakerParams};
    use nlmode::excitation::LinearSweep;
    use nlmode::nma::{nonlinear_modal_analysis, TablePolicy};
    use nlmode::reference::{simulate_sweep, ReferenceOptions};
    use nlmode::structure::{paper_structure, PaperStructureOptions};

    let ps = paper_structure(&PaperStructureOptions::default()).unwrap();
    let shaker = ShakerParams::paper();
    let sweep = LinearSweep::per_pseudo_period(ps.omega0_rad_s, 0.8, 1.8, 0.02, 10.0).unwrap();
    let t0 = Instant::now();
    let nma =
        nonlinear_modal_analysis(&ps.model, &nlmode::benchmark::tip_range_table_options()).unwrap();
    let table = nma.to_table(TablePolicy::PrimaryBranch);
    println!(
        "NMA (H = 3): {} points in {:.2} s",
        table.amplitude.len(),
        t0.elapsed().as_secs_f64()
    );
    let att = LinearAttachment::shaker("shaker", &shaker, "2l3").unwrap();
    let t0 = Instant::now();
    let r = simulate_sweep(&ps.model, &[att], &sweep, &ReferenceOptions::default()).unwrap();
    let ref_wall = t0.elapsed().as_secs_f64();
    let re = &r.envelope;
    println!(
        "reference: {} envelope points, wall {ref_wall:.2} s",
        re.omega_rad_s.len()
    );
    let dir = tempfile::tempdir().unwrap();
    let (st, sh) = release_fmus(dir.path(), &table);
    let base = CosimParams::new(shaker, sweep);
    // finest co-simulation as the converged FMU solution
    let mut pf = base.clone();
    pf.algorithm = Algorithm::Iterative;
    pf.macro_step_s = 2e-6;
    pf.output_interval_s = 2.5e-4;
    let fine = run_cosim(&st, &sh, &pf, &mut |_| {}).unwrap();
    assert!(fine.stopped.is_none(), "{:?}", fine.stopped);
    let fe = &fine.envelope;
    let e0 = compare(
        &fine,
        &re.omega_rad_s,
        &re.force_amplitude_n,
        &re.tip_amplitude_m,
    );
    println!(
        "finest cosim (iterative, h = 2e-6 s) vs reference: peak tip {:+.2} %, jump-down {:+.2} %, RMS tip {:.2} %, RMS force {:.2} %, wall {:.2} s",
        100.0 * e0.0, 100.0 * e0.1, 100.0 * e0.2, 100.0 * e0.3, fine.wall_time_s
    );
    println!("| algorithm | macro step [s] | vs reference: peak tip / jump-down / RMS tip / RMS force [%] | vs finest cosim: peak tip / RMS tip / RMS force [%] | steps | FMU DoSteps | wall [s] | us per macro step |");
    println!("|---|---|---|---|---|---|---|---|");
    for (name, alg, extrapolate, shaker_first) in [
        ("jacobi (ZOH)", Algorithm::Jacobi, false, false),
        ("jacobi", Algorithm::Jacobi, true, false),
        ("gauss-seidel", Algorithm::GaussSeidel, true, false),
        (
            "gauss-seidel (shaker first)",
            Algorithm::GaussSeidel,
            true,
            true,
        ),
        ("iterative", Algorithm::Iterative, true, false),
    ] {
        for h in [5e-6, 1e-5, 2e-5, 5e-5, 1e-4, 2e-4] {
            let mut p = base.clone();
            p.algorithm = alg;
            p.extrapolate = extrapolate;
            p.shaker_first = shaker_first;
            p.macro_step_s = h;
            p.output_interval_s = 2.5e-4;
            let o = run_cosim(&st, &sh, &p, &mut |_| {}).unwrap();
            if let Some((t, msg)) = &o.stopped {
                println!(
                    "| {name} | {h:e} | stopped at t = {t:.4} s: {} | | | | {:.2} | |",
                    msg.chars().take(90).collect::<String>(),
                    o.wall_time_s
                );
                continue;
            }
            let a = compare(
                &o,
                &re.omega_rad_s,
                &re.force_amplitude_n,
                &re.tip_amplitude_m,
            );
            let b = compare(
                &o,
                &fe.omega_rad_s,
                &fe.force_amplitude_n,
                &fe.tip_amplitude_m,
            );
            println!(
                "| {name} | {h:e} | {:+.2} / {:+.2} / {:.2} / {:.2} | {:+.2} / {:.2} / {:.2} | {} | {} | {:.3} | {:.2} |",
                100.0 * a.0, 100.0 * a.1, 100.0 * a.2, 100.0 * a.3,
                100.0 * b.0, 100.0 * b.2, 100.0 * b.3,
                o.stats.steps, o.stats.do_steps, o.wall_time_s, 1e6 * o.wall_time_s / o.stats.steps as f64
            );
        }
    }
}
