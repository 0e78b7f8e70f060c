//! The AFT evaluation of the nonlinear elements (issue 11, performance):
//! `aft_h7/jenkins` is one [`Aft::eval`] of the hysteretic Jenkins element
//! (`ElasticDryFriction`) at `H = 7`, `N = 4H + 1 = 29` samples, in gross slip
//! with higher harmonics present (target < 20 us per evaluation);
//! `aft_h7/cubic` is the memoryless cubic spring at the same size, for scale;
//! `aft_h7/jenkins_256` the Jenkins element at the NMA's default for hysteretic
//! models, 256 samples.
//!
//! Run: `cargo bench -p nlmode --bench elements`.
//!
//! Measured (release, shared 2-core machine with four other builds running,
//! 2026-12-01):
//!
//! | case | time per evaluation |
//! |---|---|
//! | `aft_h7/jenkins` (N = 29) | 17.7 us (16.4 .. 19.2) |
//! | `aft_h7/cubic` (N = 29) | 17.5 us (15.1 .. 20.0) |
//! | `aft_h7/jenkins_256` (N = 256) | 198 us |
//!
//! The march costs about as much as the memoryless path: both are dominated
//! by the projection `dF/dU = fwd (df/dU)`, `(2H+1) x N x (2H+1)`.
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::DVector;
use nlmode::nma::hb::{cos_index, default_samples, sin_index, Aft};
use nlmode::structure::{CubicSpring, ElasticDryFriction};
use std::hint::black_box;

fn aft_h7(c: &mut Criterion) {
    let h = 7;
    let aft = Aft::new(h, default_samples(h));
    let mut u = DVector::zeros(2 * h + 1);
    u[0] = 1e-5;
    u[cos_index(1)] = 4e-4;
    u[sin_index(1)] = -1e-4;
    u[cos_index(3)] = 3e-5;
    u[sin_index(5)] = 1e-5;
    let jenkins = ElasticDryFriction::new(1e4, 0.5).unwrap();
    let cubic = CubicSpring::new(6e9).unwrap();
    let mut g = c.benchmark_group("aft_h7");
    g.bench_function("jenkins", |b| {
        b.iter(|| aft.eval(black_box(&jenkins), black_box(&u), black_box(356.0)))
    });
    g.bench_function("cubic", |b| {
        b.iter(|| aft.eval(black_box(&cubic), black_box(&u), black_box(356.0)))
    });
    let aft256 = Aft::new(h, 256);
    g.bench_function("jenkins_256", |b| {
        b.iter(|| aft256.eval(black_box(&jenkins), black_box(&u), black_box(356.0)))
    });
    g.finish();
}

criterion_group!(benches, aft_h7);
criterion_main!(benches);
