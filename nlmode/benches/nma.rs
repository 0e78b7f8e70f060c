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
//!
//! Measured (release, shared 2-core machine, 2026-11-22):
//!
//! | case | result |
//! |---|---|
//! | CB, H = 3, 1e-6 .. 6e-3 through the loop | 8.4 ms (91 points, 244 Newton iterations) |
//! | CB, H = 13, same | 39 ms (94 points, 246 Newton iterations) |
//!
//! | model (H = 13) | ndof | modes [s] | ms / point | ms / linear solve |
//! |---|---|---|---|---|
//! | CB | 11 | 0.000 | 0.57 | 0.20 |
//! | full 100 nodes | 198 | 0.013 | 1.9 | 0.69 |
//! | full 301 nodes | 600 | 0.51 | 7.5 | 2.7 |
//! | full 1000 nodes | 1998 | 85 | 53 | 19 |
//!
//! Issue 12 (`nma_loops`, release, shared 2-core machine with other jobs
//! running, 2026-12-01): conservative H = 13 backbone through the 1:5, 1:9,
//! 1:3, 1:7 and 1:13 loops to 2.7 omega0: 341 ms (660 points, 1467 Newton
//! iterations, 95 rejected steps, 0.36 ms/point; target 350 ms). Refined damped
//! H = 13 table (default `log10 a` = -6 .. -1 continuation, 135 points, then
//! 193 table points from 503 midpoint HB solves): 284 ms (target 50 ms, not
//! met: the midpoint solves dominate, about 0.5 ms each). With the table
//! ended 1 % before the first fold (`RefineOptions::fold_margin`, no solves
//! wasted on the vertical tangent; same machine, 4 jobs sharing it): 141 table
//! points from 331 midpoint solves, 109 ms (90 .. 133 ms; one cold run 82 ms,
//! 0.58 ms per table point), still above the 50 ms target.
//!
//! Chord Newton in the refinement checks (one factorisation of the condensed
//! Jacobian per check, residual-only iterations; `HbJacobian` factors once and
//! solves many) and re-checks against the stored midpoint solutions
//! (2026-12-02, callgrind, one thread, continuation plus refined table incl.
//! the modal basis, paper structure excluded): 589 M -> 352 M instructions;
//! the same 30 branch points (68 Newton iterations) and 141 table points,
//! 331 -> 255 midpoint HB solves, 256 factorisations and 483 chord iterations
//! for them; accuracy omega 2.79e-6, D 4.24e-5, shapes 4.16e-5 (as before);
//! the table's values move by at most 2e-11 (omega), 2.3e-9 (D) and 8.5e-10
//! (shapes) relative: the checks converge to the same tolerance. Criterion
//! medians not measured (machine load 12-14 on 2 cores); continuation plus
//! table, old and new release builds interleaved, 12 runs each under that
//! load: 2 threads 255 -> 154 ms median, 1 thread 276 -> 184 ms (x0.60 and
//! x0.67, as the instruction counts); scaled to the quiet-machine 49.4 / 78 ms
//! that is about 30 ms on 2 threads and 47-52 ms on 1.
//!
//! The cost per point grows about linearly with the number of DOFs (x3 DOFs:
//! x3.9, x3.3 DOFs: x7, the largest case leaving the caches); the one-off
//! dense eigen-decomposition (O(n^3)) dominates the unreduced analyses.
use criterion::{criterion_group, criterion_main, Criterion};
use nlmode::nma::modal_basis::ModalBasis;
use nlmode::nma::{
    nonlinear_modal_analysis, nonlinear_modal_analysis_with_basis, AmplitudeRange, BackboneOptions,
    ContinuationOptions, NmaOptions, RefineOptions, TablePolicy,
};
use nlmode::structure::{paper_structure, PaperStructureOptions};
use std::sync::Arc;
use std::time::{Duration, Instant};

fn options(harmonics: usize, log10_end: f64) -> NmaOptions {
    NmaOptions {
        harmonics,
        amplitude: AmplitudeRange::Modal {
            log10_start: -6.0,
            log10_end,
        },
        continuation: ContinuationOptions {
            ds: 0.1,
            ..Default::default()
        },
        store_coordinates: false,
        ..Default::default()
    }
}

fn paper_cb(c: &mut Criterion) {
    let ps = paper_structure(&PaperStructureOptions::default()).expect("paper structure");
    let mut group = c.benchmark_group("nma_paper_cb");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(4));
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
        group.bench_function(format!("H{h}"), |b| {
            b.iter(|| nonlinear_modal_analysis(&ps.model, &opts).unwrap())
        });
    }
    group.finish();
}

struct Model {
    model: nlmode::structure::StructuralModel,
}

/// Unreduced paper beam with `n_nodes` nodes, tip cubic spring and
/// stiffness-proportional damping `C = beta K`, `beta = 2 D0 / omega0`
/// (analytic `omega0`). Built without the structure module's linear modal
/// analysis, whose stiffness-form eigensolver cannot resolve the fundamental
/// of meshes this fine (`omega_max^2 / omega_1^2 ~ n^4`).
fn full_beam(n_nodes: usize) -> nlmode::structure::StructuralModel {
    use nlmode::structure::{BeamSpec, CubicSpring};
    let spec = BeamSpec {
        n_nodes,
        ..BeamSpec::paper()
    };
    let mut beam = spec.assemble().expect("beam");
    let l = spec.length_m;
    beam.add_point("tip", l).expect("tip");
    let e_tip = beam.translation_vector("cubic_spring", l).expect("tip");
    beam.model
        .add_nonlinear(
            "cubic_spring",
            e_tip,
            CubicSpring::new(nlmode::benchmark::K3_N_PER_M3).expect("k3"),
        )
        .expect("spring");
    let omega0 = spec.analytic_omega_rad_s(1.875_104_068_711_961);
    beam.model.damping = &beam.model.stiffness * (2.0 * nlmode::benchmark::D0 / omega0);
    beam.model
}

fn scaling(_c: &mut Criterion) {
    if std::env::var("NMA_BENCH_SCALING")
        .map(|v| v == "0")
        .unwrap_or(false)
    {
        return;
    }
    eprintln!("scaling: H = 13, damped, log10 a = -6 .. -3");
    eprintln!(
        "{:>22} {:>6} {:>10} {:>8} {:>8} {:>12} {:>12}",
        "model", "ndof", "modes [s]", "points", "Newton", "ms/point", "ms/solve"
    );
    let cases: [(&str, usize, bool); 4] = [
        ("CB (100 nodes)", 100, true),
        ("full 100 nodes", 100, false),
        ("full 301 nodes", 301, false),
        ("full 1000 nodes", 1000, false),
    ];
    for (label, n_nodes, cb) in cases {
        let model = if cb {
            paper_structure(&PaperStructureOptions::default())
                .expect("beam")
                .model
        } else {
            full_beam(n_nodes)
        };
        let ps = Model { model };
        let t = Instant::now();
        let basis = Arc::new(ModalBasis::new(&ps.model, false).expect("modes"));
        let t_modes = t.elapsed().as_secs_f64();
        let opts = options(13, -3.0);
        let t = Instant::now();
        let r = nonlinear_modal_analysis_with_basis(&ps.model, basis, &opts).expect("NMA");
        let t_cont = t.elapsed().as_secs_f64();
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

/// Issue 12: the conservative H = 13 backbone through the internal-resonance
/// loops up to 2.7 omega0 ([`BackboneOptions`] defaults; target <= 0.35 s),
/// and the refined damped H = 13 table to the first fold (continuation plus
/// refinement to omega 1e-5, D and shapes 1e-4; target <= 50 ms). The modal
/// bases are computed once outside the timing.
fn loops(c: &mut Criterion) {
    let ps = paper_structure(&PaperStructureOptions::default()).expect("paper structure");
    let mut group = c.benchmark_group("nma_loops");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(6));
    let cons = Arc::new(ModalBasis::new(&ps.model, true).expect("modes"));
    let bb = BackboneOptions::default().nma_options(true);
    let bb = NmaOptions {
        store_coordinates: false,
        ..bb
    };
    let r = nonlinear_modal_analysis_with_basis(&ps.model, cons.clone(), &bb).expect("backbone");
    let t = Instant::now();
    let _ = nonlinear_modal_analysis_with_basis(&ps.model, cons.clone(), &bb).expect("backbone");
    let dt = t.elapsed().as_secs_f64();
    eprintln!(
        "conservative H = 13 backbone to 2.7 omega0: {} points, {} Newton iterations, {} rejected steps, {} loops, {:.3} ms/point",
        r.n_points(),
        r.newton_iterations,
        r.rejected_steps,
        r.folds.iter().filter(|f| f.internal_resonance.is_some()).count(),
        1e3 * dt / r.n_points() as f64
    );
    group.bench_function("conservative_H13_to_2.7", |b| {
        b.iter(|| nonlinear_modal_analysis_with_basis(&ps.model, cons.clone(), &bb).unwrap())
    });
    let damped = Arc::new(ModalBasis::new(&ps.model, false).expect("modes"));
    // the table needs the primary branch only (the same table as from the whole branch)
    let topts = NmaOptions {
        stop_at_first_fold: true,
        ..NmaOptions::default()
    };
    let refine = RefineOptions::default();
    let table = |basis: &Arc<ModalBasis>| {
        let r = nonlinear_modal_analysis_with_basis(&ps.model, basis.clone(), &topts).unwrap();
        let t = r
            .refined_table(
                &ps.model,
                basis.clone(),
                &topts,
                TablePolicy::PrimaryBranch,
                &refine,
            )
            .unwrap();
        (r, t)
    };
    let t = Instant::now();
    let (r, tab) = table(&damped);
    let dt = t.elapsed().as_secs_f64();
    let acc = tab.accuracy.clone().expect("refined");
    eprintln!(
        "refined damped H = 13 table: {} branch points ({} Newton iterations), {} table points, {} HB checks, {:.1} ms, {:.3} ms per table point; accuracy {:?}",
        r.n_points(),
        r.newton_iterations,
        tab.amplitude.len(),
        acc.checks,
        1e3 * dt,
        1e3 * dt / tab.amplitude.len() as f64,
        acc
    );
    group.bench_function("refined_table_H13", |b| b.iter(|| table(&damped)));
    group.finish();
}

/// A single-DOF Jenkins oscillator (m = 1, k = 1, k_t = 9, F_s = 0.9, c =
/// 0.002) from stick (x = 1e-3 m) through full slip to x = 10 m = 100 x_s,
/// where the damping ratio passes its maximum of about 40 % (H = 7, 256 AFT
/// samples): issue 22's speed target is < 2 s.
fn jenkins_full_slip(c: &mut Criterion) {
    let model = nlmode::nma::problems::nlvib::jenkins_oscillator(1.0, 0.002, 1.0, 9.0, 0.9)
        .expect("Jenkins oscillator");
    let opts = NmaOptions {
        harmonics: 7,
        amplitude: AmplitudeRange::Modal {
            log10_start: -3.0,
            log10_end: 1.0,
        },
        ..Default::default()
    };
    let t0 = Instant::now();
    let r = nonlinear_modal_analysis(&model, &opts).expect("Jenkins backbone");
    eprintln!(
        "Jenkins full slip, H = 7: {} points, {} Newton iterations, {} rejected, D max {:.3}, {:.3} s",
        r.n_points(),
        r.newton_iterations,
        r.rejected_steps,
        r.branch.iter().map(|b| b.damping_ratio).fold(0.0, f64::max),
        t0.elapsed().as_secs_f64()
    );
    let mut group = c.benchmark_group("nma_jenkins");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(4));
    group.bench_function("full_slip_H7", |b| {
        b.iter(|| nonlinear_modal_analysis(&model, &opts).unwrap())
    });
    group.finish();
}

/// Measured (release, quiet 2-core machine, 2026-12-03, criterion medians):
/// Jenkins full slip H = 7 to D = 0.43 13.2 ms (71 points); `tanh_2dof_H21`
/// 209 ms (72 points, 1405 AFT samples); `chain_H7` 586 ms (347 points,
/// D max 0.39).
///
/// NLvib's published examples as `nlmode::nma::problems::nlvib` builds them
/// (issue 22, speed: "these analyses take 0.4-1.4 s today; keep that"): the
/// 2-DOF `tanh` friction oscillator at H = 21 from stick to 100x its
/// saturation displacement, and the 3-DOF chain with contact, two Jenkins
/// elements and cubic springs through full slip (H = 7, D beyond 30 %).
fn nlvib_examples(c: &mut Criterion) {
    use nlmode::nma::problems::nlvib::{nlvib_friction_contact_chain, nlvib_tanh_friction_2dof};
    let tanh = nlvib_tanh_friction_2dof();
    let tanh_opts = NmaOptions {
        harmonics: 21,
        amplitude: AmplitudeRange::Modal {
            log10_start: -1.5,
            log10_end: 1.0,
        },
        ..Default::default()
    };
    let chain = nlvib_friction_contact_chain().expect("chain");
    let chain_opts = NmaOptions {
        harmonics: 7,
        amplitude: AmplitudeRange::Modal {
            log10_start: -2.0,
            log10_end: 1.0,
        },
        ..Default::default()
    };
    for (name, model, opts) in [
        ("tanh_2dof_H21", &tanh, &tanh_opts),
        ("chain_H7", &chain, &chain_opts),
    ] {
        let t0 = Instant::now();
        let r = nonlinear_modal_analysis(model, opts).expect(name);
        eprintln!(
            "{name}: {} points, {} Newton iterations, {} AFT samples, D max {:.3}, {:.3} s",
            r.n_points(),
            r.newton_iterations,
            r.samples,
            r.branch.iter().map(|b| b.damping_ratio).fold(0.0, f64::max),
            t0.elapsed().as_secs_f64()
        );
    }
    let mut group = c.benchmark_group("nma_nlvib");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(8));
    group.bench_function("tanh_2dof_H21", |b| {
        b.iter(|| nonlinear_modal_analysis(&tanh, &tanh_opts).unwrap())
    });
    group.bench_function("chain_H7", |b| {
        b.iter(|| nonlinear_modal_analysis(&chain, &chain_opts).unwrap())
    });
    group.finish();
}

criterion_group!(
    benches,
    paper_cb,
    scaling,
    loops,
    jenkins_full_slip,
    nlvib_examples
);
criterion_main!(benches);
