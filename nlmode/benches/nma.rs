//! Nonlinear modal analysis of the paper's beam (issue 3, performance section).
//!
//! - `nma_paper_cb/H3`, `nma_paper_cb/H13`: Craig-Bampton beam (11 DOF), damped,
//!   `a = 1e-6` up to and through the first loop (1:3 internal resonance with
//!   mode 2, fold at a ~ 4e-3) until `a = 6e-3`. Targets: H = 3 < 10 ms,
//!   H = 13 < 100 ms.
//! - scaling report (printed, one run each, `NMA_BENCH_SCALING=0` skips it):
//!   the same analysis (H = 13, `a` from 1e-6 to 1e-3, weakly to moderately
//!   nonlinear) on the CB model, the unreduced 100-node beam and unreduced
//!   300- and 1000-node beams: time per continuation point and per Newton
//!   iteration against the number of DOFs, with the one-off modal
//!   decomposition timed separately.
use criterion::{criterion_group, criterion_main, Criterion};
use nlmode::nma::epmc::ModalBasis;
use nlmode::nma::{nonlinear_modal_analysis, AmplitudeRange, ContinuationOptions, NmaOptions};
use nlmode::structure::{paper_structure, PaperStructureOptions};
use std::time::{Duration, Instant};

fn options(harmonics: usize, log10_end: f64) -> NmaOptions {
    NmaOptions {
        harmonics,
        amplitude: AmplitudeRange::Modal { log10_start: -6.0, log10_end },
        continuation: ContinuationOptions { ds: 0.1, ..Default::default() },
        store_coordinates: false,
        ..Default::default()
    }
}

fn paper_cb(c: &mut Criterion) {
    let ps = paper_structure(&PaperStructureOptions::default()).expect("paper structure");
    let mut group = c.benchmark_group("nma_paper_cb");
    group.sample_size(20).measurement_time(Duration::from_secs(4));
    for h in [3usize, 13] {
        let opts = options(h, 6e-3f64.log10());
        let r = nonlinear_modal_analysis(&ps.model, &opts).expect("NMA of the paper's beam");
        eprintln!(
            "paper CB beam, H = {h}: {} points, {} Newton iterations, {} rejected steps, folds at a = {:?}",
            r.n_points(),
            r.newton_iterations,
            r.rejected_steps,
            r.folds.iter().map(|f| f.amplitude).collect::<Vec<_>>()
        );
        group.bench_function(format!("H{h}"), |b| b.iter(|| nonlinear_modal_analysis(&ps.model, &opts).unwrap()));
    }
    group.finish();
}

fn scaling(_c: &mut Criterion) {
    if std::env::var("NMA_BENCH_SCALING").map(|v| v == "0").unwrap_or(false) {
        return;
    }
    eprintln!("scaling: H = 13, damped, log10 a = -6 .. -3");
    eprintln!("{:>22} {:>6} {:>10} {:>8} {:>8} {:>12} {:>12}", "model", "ndof", "modes [s]", "points", "Newton", "ms/point", "ms/iter");
    let cases: [(&str, usize, Option<usize>); 4] =
        [("CB (100 nodes)", 100, Some(10)), ("full 100 nodes", 100, None), ("full 300 nodes", 300, None), ("full 1000 nodes", 1000, None)];
    for (label, n_nodes, cb) in cases {
        let ps = paper_structure(&PaperStructureOptions { n_nodes, cb_modes: cb, ..Default::default() })
            .expect("beam");
        let t = Instant::now();
        let _basis = ModalBasis::new(&ps.model, false).expect("modes");
        let t_modes = t.elapsed().as_secs_f64();
        let opts = options(13, -3.0);
        let t = Instant::now();
        let r = nonlinear_modal_analysis(&ps.model, &opts).expect("NMA");
        let t_cont = t.elapsed().as_secs_f64() - t_modes;
        eprintln!(
            "{:>22} {:>6} {:>10.3} {:>8} {:>8} {:>12.3} {:>12.3}",
            label,
            ps.model.mass.nrows(),
            t_modes,
            r.n_points(),
            r.newton_iterations,
            1e3 * t_cont / r.n_points() as f64,
            1e3 * t_cont / (r.newton_iterations + r.n_points()) as f64
        );
    }
}

criterion_group!(benches, paper_cb, scaling);
criterion_main!(benches);
