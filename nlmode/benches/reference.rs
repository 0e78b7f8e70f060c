//! Reference sweep of the paper's case (a) (exciter at 2l/3, 10 V, 2 % per pseudo
//! period, 0.8 -> 1.8 omega0): Craig-Bampton model with the exponential
//! (default) and the Dormand-Prince integrator side by side, and the unreduced
//! 100-node model. The structure and shaker are built outside the timed loop;
//! the timed part is `simulate_sweep` (assembly, integration, envelopes).
//!
//! `cargo bench -p nlmode --bench reference`
use criterion::{criterion_group, criterion_main, Criterion};
use nlmode::attachment::{LinearAttachment, ShakerParams};
use nlmode::excitation::LinearSweep;
use nlmode::reference::{simulate_sweep, Integrator, ReferenceOptions};
use nlmode::structure::{paper_structure, PaperStructureOptions};
use std::time::Duration;

fn case_a(c: &mut Criterion) {
    let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    let cb = paper_structure(&PaperStructureOptions::default()).unwrap();
    let full = paper_structure(&PaperStructureOptions {
        cb_modes: None,
        ..Default::default()
    })
    .unwrap();
    let sweep = LinearSweep::per_pseudo_period(cb.omega0_rad_s, 0.8, 1.8, 0.02, 10.0).unwrap();
    let exponential = ReferenceOptions::default();
    let dopri = ReferenceOptions {
        method: Integrator::DormandPrince,
        ..Default::default()
    };
    let atts = [shaker];

    let mut g = c.benchmark_group("reference_case_a");
    g.sample_size(20).measurement_time(Duration::from_secs(4));
    g.bench_function("craig_bampton/exponential", |b| {
        b.iter(|| simulate_sweep(&cb.model, &atts, &sweep, &exponential).unwrap())
    });
    g.sample_size(10).measurement_time(Duration::from_secs(6));
    g.bench_function("craig_bampton/dormand_prince", |b| {
        b.iter(|| simulate_sweep(&cb.model, &atts, &sweep, &dopri).unwrap())
    });
    g.bench_function("unreduced/exponential", |b| {
        b.iter(|| simulate_sweep(&full.model, &atts, &sweep, &exponential).unwrap())
    });
    g.finish();
}

criterion_group!(benches, case_a);
criterion_main!(benches);
