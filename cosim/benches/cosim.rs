//! Co-simulation benchmarks (issue 6, performance section).
//!
//! * `cosim_overhead/<algorithm>`: one macro step of the master on two test
//!   FMUs (`csrc/testosc.c` with `substeps = 0`, whose `fmi2DoStep` only
//!   advances time) coupled both ways: everything measured is the host's own
//!   work per macro step plus the trivial FMI calls (an upper bound of the
//!   host overhead).
//! * With `COSIM_CASE_A=1`: the host overhead per macro step inside a run as
//!   long as the paper's case (a), recording included (null FMUs). The case
//!   (a) table on the repository's FMUs is the host's example
//!   `cosim_case_a` (the pairing is the host's).
//!
//! `cargo bench -p cosim --bench cosim` (add `COSIM_CASE_A=1` for the long run).
use cosim::import::Fmu;
use cosim::master::{run, Algorithm, Master, MasterOptions, ParamValue};
use criterion::{criterion_group, Criterion};
use std::io::Write;
use std::path::Path;
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
// Host overhead inside a long run (with recording)

fn recording_overhead() {
    // a Gauss-Seidel run on null FMUs as long as the paper's case (a)
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
        recording_overhead();
    }
}
