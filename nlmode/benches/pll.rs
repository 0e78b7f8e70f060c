//! Virtual phase-resonance test of the paper beam (exciter at 2l/3) on the
//! full-order reference: the phase-locked loop through 20 voltage levels,
//! 0.5 V to 40 V geometric (|q_tip,1| 0.14 mm to 5 mm, omega 1.001 to 1.93
//! omega0), from rest. Structure and shaker are built outside the timed loop;
//! the timed part is the plant's assembly and the whole test.
//!
//! Measured (release, 2 shared cores under load): 1430 periods, 103 542
//! exponential steps, 2773 propagator sets; 4.2-5.2 s. The time goes into the
//! per-period restart of the reference integrator (its propagator cache lives
//! for one `integrate` call, and every period has a new step size), not into
//! the steps; the target (< 1 s) needs an integrator that keeps its
//! propagators across periods.
//!
//! `cargo bench -p nlmode --bench pll`
use criterion::{criterion_group, criterion_main, Criterion};
use nlmode::attachment::{LinearAttachment, ShakerParams};
use nlmode::control::{phase_resonance, PllOptions, ReferencePlant};
use nlmode::reference::ReferenceOptions;
use nlmode::structure::{paper_structure, PaperStructureOptions};
use std::time::Duration;

fn pll_20_levels(c: &mut Criterion) {
    let ps = paper_structure(&PaperStructureOptions::default()).unwrap();
    let atts = [LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap()];
    let levels: Vec<f64> = (0..20).map(|i| 0.5 * 80f64.powf(i as f64 / 19.0)).collect();
    let opts = ReferenceOptions::default();
    let pll = PllOptions::default();
    let run = || {
        let mut plant = ReferencePlant::new(&ps.model, &atts, &opts).unwrap();
        let r = phase_resonance(&mut plant, ps.omega0_rad_s, &levels, 0.919, &pll).unwrap();
        assert!(r.failure.is_none() && r.levels.iter().all(|l| l.settled));
        (r, plant.stats())
    };
    let (r, stats) = run();
    let periods: usize = r.levels.iter().map(|l| l.periods).sum();
    eprintln!(
        "20 levels: {periods} periods, {} steps, {} propagators, last omega/omega0 = {:.4}",
        stats.steps,
        stats.propagators,
        r.levels.last().unwrap().omega_rad_s / ps.omega0_rad_s
    );
    let mut g = c.benchmark_group("pll");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("reference_20_levels", |b| b.iter(run));
    g.finish();
}

criterion_group!(benches, pll_20_levels);
criterion_main!(benches);
