//! Harmonic balance of the full model (issue 24, speed item): the 10 V curve
//! of the paper's case (a) (shaker at 2l/3, Craig-Bampton beam with the cubic
//! spring), 0.8 to 1.8 omega0 through both folds, H = 7, with Hill stability
//! and bifurcation location, on one core. Target: at most 0.5 s.
//!
//! Also timed: the same curve without stability (the HB continuation alone),
//! and with the Hill matrix truncated to `stability_harmonics` H_s = 1..7.
//!
//! Measured: see the report in docs/hb.md.
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::DVector;
use nlmode::attachment::{LinearAttachment, ShakerParams};
use nlmode::hb::{frequency_response, HbOptions, HbSystem, HillMethod};
use nlmode::structure::{paper_structure, PaperStructureOptions};
use nlmode::Complex64;
use std::time::{Duration, Instant};

fn case_a() -> (HbSystem, f64) {
    let p = paper_structure(&PaperStructureOptions::default()).unwrap();
    let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    let u = DVector::from_element(1, Complex64::new(10.0, 0.0));
    let sys = HbSystem::new(&p.model, &[shaker], &[u], &[], "tip").unwrap();
    (sys, p.omega0_rad_s)
}

fn options(w0: f64, stability: bool) -> HbOptions {
    HbOptions {
        harmonics: 7,
        omega_start_rad_s: 0.8 * w0,
        omega_end_rad_s: 1.8 * w0,
        stability,
        ..HbOptions::default()
    }
}

fn bench(c: &mut Criterion) {
    let (sys, w0) = case_a();
    // one timed run with its figures
    for stability in [false, true] {
        let t = Instant::now();
        let r = frequency_response(&sys, &options(w0, stability), &[]).unwrap();
        let dt = t.elapsed().as_secs_f64();
        let b = &r.branches[0];
        let folds: Vec<String> = r
            .bifurcations()
            .iter()
            .map(|(_, p)| format!("{} at {:.3} rad/s", p.bifurcation.label(), p.omega_rad_s))
            .collect();
        let unstable = b
            .points
            .iter()
            .filter(|p| p.stable() == Some(false))
            .count();
        println!(
            "case (a) 10 V, H = 7, stability {stability}: {dt:.3} s, {} points, {unstable} unstable, {folds:?}, status {:?}",
            b.points.len(),
            b.status
        );
    }
    // the condensed Hill problem against the full Hill matrix, and the Hill
    // matrix's harmonics H_s <= H: time of the curve and the largest
    // difference of the largest real part of the exponents from the full
    // Hill matrix at H_s = H
    let o = HbOptions {
        bifurcations: false,
        hill: HillMethod::Full,
        ..options(w0, true)
    };
    let full = frequency_response(&sys, &o, &[]).unwrap();
    for (hill, hs) in [(HillMethod::Condensed, 7)]
        .into_iter()
        .chain((1..=7).map(|hs| (HillMethod::Full, hs)))
    {
        let o2 = HbOptions {
            stability_harmonics: Some(hs),
            hill,
            ..o.clone()
        };
        let t = Instant::now();
        let r = frequency_response(&sys, &o2, &[]).unwrap();
        let dt = t.elapsed().as_secs_f64();
        let (mut worst, mut flips) = (0.0f64, 0);
        for (p, q) in r.branches[0].points.iter().zip(&full.branches[0].points) {
            let (a, b) = (p.floquet.as_ref().unwrap(), q.floquet.as_ref().unwrap());
            worst = worst.max((a.max_re - b.max_re).abs());
            flips += usize::from(a.stable != b.stable);
        }
        println!(
            "hill {hill:?}, stability_harmonics {hs}: {dt:.3} s, max |d max Re s| vs full at H_s = 7: {worst:.2e} 1/s, stability flags differing: {flips}"
        );
    }
    // a shooting computation of the same curve needs, per point and Newton
    // iteration, one period of the full system and of its nz sensitivities
    // (the monodromy matrix); the cost of one period of the reference
    // integrator (release, same tolerance as reference's default) times
    // (nz + 1) x 3 iterations x the 41 points is a lower bound of its cost
    {
        use nlmode::reference::{
            integrate, AssembledSystem, Integrator, ReferenceOptions, SampleGrid,
        };
        let p = paper_structure(&PaperStructureOptions::default()).unwrap();
        let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
        let asys = AssembledSystem::new(&p.model, &[shaker], "tip").unwrap();
        let w = 1.3 * w0;
        let per = 64;
        let z0 = nalgebra::DVector::zeros(asys.first_order.nz());
        let nz = asys.first_order.nz();
        let t = Instant::now();
        frequency_response(&sys, &options(w0, true), &[]).unwrap();
        let hb = t.elapsed().as_secs_f64();
        for (name, method, periods) in [
            (
                "exponential (the tool's reference)",
                Integrator::Exponential,
                200,
            ),
            (
                "Dormand-Prince 5(4) (ode45's method)",
                Integrator::DormandPrince,
                5,
            ),
        ] {
            let grid = SampleGrid {
                interval_s: 2.0 * std::f64::consts::PI / w / per as f64,
                count: per * periods,
            };
            let opts = ReferenceOptions {
                method,
                ..ReferenceOptions::default()
            };
            let t = Instant::now();
            integrate(
                &asys,
                &z0,
                grid,
                &|s| 10.0 * (w * s).cos(),
                &opts,
                &mut |_, _| {},
                &mut |_| {},
            )
            .unwrap();
            let per_period = t.elapsed().as_secs_f64() / periods as f64;
            let shooting = per_period * (nz + 1) as f64 * 3.0 * 41.0;
            println!(
                "one period of the full system, {name}: {:.3} ms; shooting lower bound for the curve ({nz} states + sensitivities, 3 Newton iterations, 41 points): {shooting:.2} s; hb with stability {hb:.3} s: {:.0}x",
                per_period * 1e3,
                shooting / hb
            );
        }
    }
    let mut g = c.benchmark_group("hb");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("case_a_10V_H7_with_stability", |bch| {
        bch.iter(|| frequency_response(&sys, &options(w0, true), &[]).unwrap())
    });
    g.bench_function("case_a_10V_H7_without_stability", |bch| {
        bch.iter(|| frequency_response(&sys, &options(w0, false), &[]).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
