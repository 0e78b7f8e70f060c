//! Co-simulation benchmarks (issue 6, performance section).
//!
//! * `cosim_overhead/<algorithm>`: one macro step of the master on two test
//!   FMUs (`csrc/testosc.c` with `substeps = 0`, whose `fmi2DoStep` only
//!   advances time) coupled both ways: everything measured is the host's own
//!   work per macro step plus the trivial FMI calls (an upper bound of the
//!   host overhead).
//! * With `COSIM_CASE_A=1`: the paper's case (a) (2l/3, 10 V, r = 2 %,
//!   0.8-1.8 omega0) co-simulated with the repository's FMUs (release
//!   cdylibs, nonlinear modal table by NMA with H = 3) for every algorithm and
//!   a ladder of macro steps; prints the envelope errors against
//!   `nlmode::reference::simulate_sweep` and against the finest co-simulation,
//!   and the wall times.
//!
//! `cargo bench -p cosim --bench cosim` (add `COSIM_CASE_A=1` for the table).
use cosim::import::Fmu;
use cosim::master::{run, Algorithm, Master, MasterOptions, ParamValue};
use cosim::paper::{run_cosim, CosimOutput, CosimParams};
use criterion::{criterion_group, Criterion};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

const TEST_MD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="testosc" guid="{host-test-osc-0001}">
  <CoSimulation modelIdentifier="testosc" canInterpolateInputs="true" canGetAndSetFMUstate="true"/>
  <ModelVariables>
    <ScalarVariable name="F" valueReference="3" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="4" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="substeps" valueReference="8" causality="parameter" variability="fixed"><Real start="10"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="2" dependencies=""/></Outputs></ModelStructure>
</fmiModelDescription>
"#;

fn null_fmu(dir: &Path, name: &str) -> Fmu {
    let p = dir.join(name);
    let mut z = zip::ZipWriter::new(std::fs::File::create(&p).unwrap());
    let o = zip::write::SimpleFileOptions::default();
    z.start_file("modelDescription.xml", o).unwrap();
    z.write_all(TEST_MD.as_bytes()).unwrap();
    z.start_file("binaries/linux64/testosc.so", o).unwrap();
    z.write_all(&std::fs::read(env!("COSIM_TEST_FMU_LIB")).unwrap())
        .unwrap();
    z.finish().unwrap();
    Fmu::load(&p).unwrap()
}

fn null_master(dir: &Path, alg: Algorithm, extrapolate: bool) -> Master {
    let c = vec![
        ("a.x".to_string(), "b.F".to_string()),
        ("b.x".to_string(), "a.F".to_string()),
    ];
    let mut m = Master::new(
        vec![
            ("a".into(), null_fmu(dir, "a.fmu")),
            ("b".into(), null_fmu(dir, "b.fmu")),
        ],
        &c,
        MasterOptions {
            algorithm: alg,
            macro_step_s: 1e-5,
            extrapolate,
            ..Default::default()
        },
    )
    .unwrap();
    for u in 0..2 {
        m.set_parameter(u, "substeps", &ParamValue::Real(0.0))
            .unwrap();
    }
    m.initialize(0.0, None).unwrap();
    m
}

fn overhead(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("cosim_overhead");
    for (name, alg, extrapolate) in [
        ("jacobi", Algorithm::Jacobi, false),
        ("jacobi_extrapolated", Algorithm::Jacobi, true),
        ("gauss_seidel", Algorithm::GaussSeidel, true),
    ] {
        let mut m = null_master(dir.path(), alg, extrapolate);
        g.bench_function(name, |b| b.iter(|| m.step().unwrap()));
    }
    g.finish();
}

criterion_group!(benches, overhead);

// ---------------------------------------------------------------------------
// Case (a) table

fn release_fmus(dir: &Path, table: &nlmode::nma::ModalTable) -> (PathBuf, PathBuf) {
    let tp = dir.join("modal_table.json");
    table.write(&tp).unwrap();
    // the bench profile builds the dev-dependencies fmu-structure / fmu-shaker
    // (optimised cdylibs in target/release/deps, beside this bench binary)
    let libs = cosim::repo::locate_libraries(None).unwrap();
    cosim::repo::package_repo_fmus(&libs, dir, Some(&tp)).unwrap()
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

fn case_a() {
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
    // host overhead inside a real run: a Jacobi run on null FMUs of the same length
    let nd = tempfile::tempdir().unwrap();
    let mut m = null_master(nd.path(), Algorithm::GaussSeidel, true);
    let n = 1_000_000;
    let t0 = Instant::now();
    let rec = run(&mut m, n as f64 * 1e-5, &["a.x".into()], 25, &mut |_| {}).unwrap();
    let dt = t0.elapsed().as_secs_f64();
    println!("Gauss-Seidel on null FMUs incl. recording every 25 steps: {:.1} ns per macro step ({} steps)", 1e9 * dt / rec.stats.steps as f64, rec.stats.steps);
}

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    if std::env::var("COSIM_CASE_A").is_ok() {
        case_a();
    }
}
