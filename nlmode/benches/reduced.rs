//! Benchmarks of the single-nonlinear-mode model (issue 4 performance targets):
//! one `nlmode` sweep of case (a) (2l/3, 10 V, 2 % per pseudo period,
//! 0.8-1.8 omega0) below 1 ms, and a steady-state FRF with 500 frequencies
//! below 5 ms, on the modal table of the paper's beam (Craig-Bampton model,
//! EPMC with H = 3, steps of at most 0.05 in log10 a, computed once outside
//! the timed loops) with the paper's
//! shaker; the same run times the full-order reference of case (a) for the
//! speed-up. CPU times are printed first (robust on a loaded machine), then
//! criterion's wall-clock statistics.
use criterion::{criterion_group, criterion_main, Criterion};
use nlmode::attachment::{LinearAttachment, ShakerParams};
use nlmode::excitation::LinearSweep;
use nlmode::nma::{nonlinear_modal_analysis, TablePolicy};
use nlmode::reduced::{ReducedModel, SlowFlowOptions};
use nlmode::reference::{Integrator, ReferenceOptions};
use nlmode::structure::{paper_structure, PaperStructure, PaperStructureOptions};
use nlmode::Complex64;
use std::hint::black_box;
use std::time::Duration;

fn paper_table(ps: &PaperStructure) -> nlmode::nma::ModalTable {
    let opts = nlmode::benchmark::sweep_table_options();
    nonlinear_modal_analysis(&ps.model, &opts)
        .unwrap()
        .to_table(TablePolicy::PrimaryBranch)
}

fn model(table: &nlmode::nma::ModalTable) -> ReducedModel {
    let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    ReducedModel::new(table, "tip", "2l3")
        .unwrap()
        .with_linear_attachment(&shaker, &[Complex64::new(1.0, 0.0)])
        .unwrap()
}

/// Process CPU time [s] from /proc/self/stat (utime + stime, clock ticks of
/// 10 ms): on a shared, loaded machine wall-clock numbers overstate the cost.
fn cpu_time_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

/// CPU time per call of `f`, averaged over `n` calls [s].
fn cpu_per_call(n: usize, mut f: impl FnMut()) -> f64 {
    let t0 = cpu_time_s();
    for _ in 0..n {
        f();
    }
    (cpu_time_s() - t0) / n as f64
}

fn timing(m: &ReducedModel, sweep: &LinearSweep, omegas: &[f64], ps: &PaperStructure) {
    let with_samples = |n: usize| SlowFlowOptions {
        output_samples: n,
        ..Default::default()
    };
    let sweep_cpu = |n: usize| {
        let opts = with_samples(n);
        cpu_per_call(2000, || {
            black_box(m.simulate_sweep(sweep, &opts).unwrap());
        })
    };
    // default output (2001 samples), the output density of Matlab's ode45 on
    // the paper's model (~4 per step: a few hundred), and integration only
    let (sw, sw501, sw2) = (sweep_cpu(2001), sweep_cpu(501), sweep_cpu(2));
    let ss = cpu_per_call(100, || {
        black_box(m.steady_state(omegas, 10.0).unwrap());
    });
    let atts = [LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap()];
    let reference = |method: Integrator, n: usize| {
        let opts = ReferenceOptions {
            method,
            ..Default::default()
        };
        cpu_per_call(n, || {
            black_box(nlmode::reference::simulate_sweep(&ps.model, &atts, sweep, &opts).unwrap());
        })
    };
    let rf = reference(Integrator::Exponential, 20);
    let rf_dp = reference(Integrator::DormandPrince, 3);
    eprintln!(
        "CPU time, case (a): nlmode sweep {:.3} ms with 2001 output samples (target < 1 ms), \
         {:.3} ms with 501, {:.3} ms integration only; reference {:.2} ms (exponential integrator, \
         default) / {:.0} ms (Dormand-Prince, the paper's method)",
        sw * 1e3,
        sw501 * 1e3,
        sw2 * 1e3,
        rf * 1e3,
        rf_dp * 1e3,
    );
    eprintln!(
        "speed-up over the default reference: x{:.0} (2001 samples), x{:.0} (501), x{:.0} (integration \
         only); over the Dormand-Prince reference: x{:.0} (2001 samples)",
        rf / sw,
        rf / sw501,
        rf / sw2,
        rf_dp / sw
    );
    eprintln!(
        "steady-state FRF with {} frequencies {:.3} ms (target < 5 ms)",
        omegas.len(),
        ss * 1e3
    );
}

fn bench(c: &mut Criterion) {
    let ps = paper_structure(&PaperStructureOptions::default()).unwrap();
    let w0 = ps.omega0_rad_s;
    let table = paper_table(&ps);
    let m = model(&table);
    let sweep = LinearSweep::per_pseudo_period(w0, 0.8, 1.8, 0.02, 10.0).unwrap();
    let omegas: Vec<f64> = (0..500).map(|j| w0 * (0.8 + j as f64 / 499.0)).collect();
    timing(&m, &sweep, &omegas, &ps);
    if std::env::var("ONLY_TIMING").is_ok() {
        return;
    }
    let opts = SlowFlowOptions::default();
    let r = m.simulate_sweep(&sweep, &opts).unwrap();
    eprintln!(
        "case (a) sweep: {:?}, {} accepted / {} rejected steps, {} rhs evaluations, {} channel nodes",
        r.status, r.stats.accepted_steps, r.stats.rejected_steps, r.stats.rhs_evaluations, r.channel_nodes
    );
    c.bench_function("nlmode_sweep_case_a", |b| {
        b.iter(|| m.simulate_sweep(black_box(&sweep), &opts).unwrap())
    });
    c.bench_function("steady_state_frf_500", |b| {
        b.iter(|| m.steady_state(black_box(&omegas), 10.0).unwrap())
    });
    c.bench_function("linear_steady_500", |b| {
        b.iter(|| m.linear_steady(black_box(&omegas), 10.0).unwrap())
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_secs(1));
    targets = bench
}
criterion_main!(benches);
