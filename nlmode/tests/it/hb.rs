//! Tests of `nlmode::hb` (nlmode/tests/it/hb.rs): the Duffing oscillator's
//! closed-form H = 1 curve, folds and stability; the linear limit of the
//! paper beam with its shaker (and with two shakers and a TMD) against the
//! assembled linear FRF; force control against the bare structure's
//! receptance; convergence in H on the paper beam; bad options; Hill's
//! stability against fixed-frequency runs of the full system (reference);
//! a branch disconnected within the band found from seeds; Neimark-Sacker
//! points of the forced van der Pol oscillator and branch points of two
//! coupled Duffing oscillators against their closed-form conditions.
use nalgebra::DVector;
use nlmode::attachment::{LinearAttachment, ShakerParams};
use nlmode::frf::{assembled_frf, linear_force_drop, structure_receptance};
use nlmode::hb::{
    frequency_response, Bifurcation, Control, HbError, HbOptions, HbSystem, HillMethod, Seed,
};
use nlmode::nma::problems::{duffing, CubicLaw};
use nlmode::structure::{paper_structure, PaperStructure, PaperStructureOptions};
use nlmode::Complex64;
use std::sync::Arc;

const M: f64 = 1.0;
const C: f64 = 0.02;
const K: f64 = 1.0;
const K3: f64 = 1.0;
const F: f64 = 0.01;

/// `G(A, Omega)` of the H = 1 Duffing relation `A [(k - m W^2 + 3/4 k3 A)^2 + (c W)^2] = F^2`.
fn duffing_relation(a2: f64, w: f64) -> f64 {
    let y = K - M * w * w + 0.75 * K3 * a2;
    a2 * (y * y + C * C * w * w) - F * F
}

/// The two fold frequencies of the H = 1 relation: `dG/dA = 0` with `G = 0`
/// gives `y = -2 F^2 / (3 k3 A^2)`, `m W^2 = k + 3/4 k3 A - y`, and the
/// remaining equation `y^2 + c^2 W^2 + 3/2 k3 A y = 0` in `A` (bisection).
fn duffing_folds() -> Vec<f64> {
    let h = |a2: f64| {
        let y = -2.0 * F * F / (3.0 * K3 * a2 * a2);
        let w2 = (K + 0.75 * K3 * a2 - y) / M;
        y * y + C * C * w2 + 1.5 * K3 * a2 * y
    };
    // scan A on a log grid for sign changes, bisect each
    let grid: Vec<f64> = (0..2000)
        .map(|i| 10f64.powf(-4.0 + 4.0 * i as f64 / 1999.0))
        .collect();
    let mut out = vec![];
    for p in grid.windows(2) {
        let (mut lo, mut hi) = (p[0], p[1]);
        if h(lo) * h(hi) >= 0.0 {
            continue;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if h(lo) * h(mid) <= 0.0 {
                hi = mid
            } else {
                lo = mid
            }
        }
        let a2 = 0.5 * (lo + hi);
        let y = -2.0 * F * F / (3.0 * K3 * a2 * a2);
        out.push(((K + 0.75 * K3 * a2 - y) / M).sqrt());
    }
    out.sort_by(f64::total_cmp);
    out
}

/// The Duffing oscillator (`M`, `C`, `K`, `K3`) forced by `F` at its mass.
fn duffing_system() -> HbSystem {
    let model = duffing(M, C, K, K3);
    HbSystem::new(
        &model,
        &[],
        &[],
        &[("x".into(), Complex64::new(F, 0.0))],
        "x",
    )
    .unwrap()
}

fn duffing_run(harmonics: usize) -> nlmode::hb::HbResult {
    let sys = duffing_system();
    let opts = HbOptions {
        harmonics,
        omega_start_rad_s: 0.6,
        omega_end_rad_s: 1.6,
        ds: 0.01,
        ..HbOptions::default()
    };
    frequency_response(&sys, &opts, &[]).unwrap()
}

#[test]
fn duffing_h1_curve_folds_and_stability_match_closed_form() {
    let res = duffing_run(1);
    let b = &res.branches[0];
    assert_eq!(b.status, nlmode::hb::BranchStatus::Complete);
    assert!(b.points.len() > 20);
    for p in &b.points {
        let a = p.tip_amplitude_m();
        let g = duffing_relation(a * a, p.omega_rad_s);
        assert!(
            g.abs() <= 1e-8 * F * F,
            "H=1 relation off by {g:e} at {}",
            p.omega_rad_s
        );
        // the imposed force is the force column
        assert!((p.force_amplitudes_n()[0] - F).abs() < 1e-15);
    }
    let folds: Vec<_> = b
        .points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.bifurcation == Bifurcation::Fold)
        .collect();
    let analytic = duffing_folds();
    assert_eq!(analytic.len(), 2, "analytic folds {analytic:?}");
    assert_eq!(folds.len(), 2, "HB folds");
    let mut hb_folds: Vec<f64> = folds.iter().map(|(_, p)| p.omega_rad_s).collect();
    hb_folds.sort_by(f64::total_cmp);
    for (h, a) in hb_folds.iter().zip(&analytic) {
        assert!((h - a).abs() < 1e-7 * a, "fold {h} vs analytic {a}");
    }
    println!("Duffing H=1 folds: HB {hb_folds:?}, analytic {analytic:?}");
    // stability: stable before the first fold (upper branch) and after the
    // second (lower branch), unstable between (the middle branch); points
    // within two steps of a fold are left out
    let (i1, i2) = (folds[0].0, folds[1].0);
    for (i, p) in b.points.iter().enumerate() {
        let stable = p.stable().expect("stability computed");
        if i + 2 < i1 || i > i2 + 2 {
            assert!(stable, "point {i} at {} should be stable", p.omega_rad_s);
        } else if i > i1 + 2 && i + 2 < i2 {
            assert!(!stable, "point {i} at {} should be unstable", p.omega_rad_s);
        }
    }
    // the middle branch has exactly one positive real exponent (a saddle)
    let mid = &b.points[(i1 + i2) / 2];
    let f = mid.floquet.as_ref().unwrap();
    assert_eq!(f.exponents.len(), 2);
    assert_eq!(f.exponents.iter().filter(|e| e.re > 0.0).count(), 1);
    // on the stable branches the exponents are -c/2m +- i nu (sum of Re = -c/m)
    let first = b.points[0].floquet.as_ref().unwrap();
    let sum: f64 = first.exponents.iter().map(|e| e.re).sum();
    assert!((sum + C / M).abs() < 1e-6, "trace {sum} vs {}", -C / M);
}

#[test]
fn duffing_higher_harmonics_converge_and_seed_finds_no_new_branch() {
    let h1 = duffing_run(1);
    let h5 = duffing_run(5);
    let peak = |r: &nlmode::hb::HbResult| {
        r.branches[0]
            .points
            .iter()
            .map(|p| p.tip_amplitude_m())
            .fold(0.0, f64::max)
    };
    // the third harmonic of a weakly nonlinear Duffing is small: the peaks agree to 1 %
    let (p1, p5) = (peak(&h1), peak(&h5));
    assert!((p1 - p5).abs() < 1e-2 * p5, "{p1} vs {p5}");
    let p = &h5.branches[0].points[h5.branches[0].points.len() / 2];
    assert!(p.harmonic_amplitudes_m()[3] > 0.0);
    // a seed on the main branch is recognised
    let sys = duffing_system();
    let q = &h1.branches[0].points[10];
    let seed = Seed {
        omega_rad_s: q.omega_rad_s,
        amplitude_m: q.tip_amplitude_m(),
        phase_rad: q.response_m[1].arg(),
    };
    let opts = HbOptions {
        harmonics: 1,
        omega_start_rad_s: 0.6,
        omega_end_rad_s: 1.6,
        ds: 0.01,
        stability: false,
        ..HbOptions::default()
    };
    let r = frequency_response(&sys, &opts, &[seed]).unwrap();
    assert_eq!(r.branches.len(), 1);
}

#[test]
fn duffing_branch_disconnected_in_the_band_is_found_from_seeds() {
    // over a band that starts between the Duffing's folds, the curve through
    // the start point is one solution branch; the other branch in the band
    // (two of the three solutions at each Omega there, joined at the jump-down
    // fold) is not connected to it inside the band, the situation of an
    // isola. Seeded with the three closed-form solutions at one frequency,
    // the continuation reports both branches, every point on the closed-form
    // relation and the disconnected branch's fold at the analytic frequency.
    let folds = duffing_folds();
    let (wl, wu) = (folds[0], folds[1]);
    let (wa, wb) = (wl + 0.3 * (wu - wl), wu + 0.2);
    let ws = 0.5 * (wa + wu);
    // the three H = 1 amplitudes at ws: sign changes of G on a log grid, bisected
    let grid: Vec<f64> = (0..4000)
        .map(|i| 10f64.powf(-6.0 + 6.0 * i as f64 / 3999.0))
        .collect();
    let mut roots = vec![];
    for p in grid.windows(2) {
        let (mut lo, mut hi) = (p[0], p[1]);
        if duffing_relation(lo, ws) * duffing_relation(hi, ws) >= 0.0 {
            continue;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if duffing_relation(lo, ws) * duffing_relation(mid, ws) <= 0.0 {
                hi = mid
            } else {
                lo = mid
            }
        }
        roots.push((0.5 * (lo + hi)).sqrt());
    }
    assert_eq!(roots.len(), 3, "{roots:?}");
    // response u_1 = A e^{-i theta} to the real force F
    let seeds: Vec<Seed> = roots
        .iter()
        .map(|&a| {
            let y = K - M * ws * ws + 0.75 * K3 * a * a;
            Seed {
                omega_rad_s: ws,
                amplitude_m: a,
                phase_rad: -(C * ws).atan2(y),
            }
        })
        .collect();
    let sys = duffing_system();
    let opts = HbOptions {
        harmonics: 1,
        omega_start_rad_s: wa,
        omega_end_rad_s: wb,
        ds: 0.01,
        ..HbOptions::default()
    };
    let mut without = frequency_response(&sys, &opts, &[]).unwrap();
    assert_eq!(without.branches.len(), 1);
    let r = frequency_response(&sys, &opts, &seeds).unwrap();
    // the same branches when the seeds come after the main branch
    nlmode::hb::add_seeded_branches(&sys, &opts, &mut without, &seeds).unwrap();
    assert_eq!(without, r);
    assert_eq!(
        r.branches.len(),
        2,
        "{:?}",
        r.branches
            .iter()
            .map(|b| (b.points.len(), &b.status))
            .collect::<Vec<_>>()
    );
    assert!(r.branches[1].from_seed.is_some());
    for b in &r.branches {
        assert_eq!(b.status, nlmode::hb::BranchStatus::Complete);
        for p in &b.points {
            let a = p.tip_amplitude_m();
            assert!(duffing_relation(a * a, p.omega_rad_s).abs() <= 1e-8 * F * F);
        }
    }
    // every closed-form solution at ws lies on one of the two branches
    for &a in &roots {
        let on = r.branches.iter().any(|b| {
            b.points.windows(2).any(|q| {
                let (w0, w1) = (q[0].omega_rad_s, q[1].omega_rad_s);
                if (w0 - ws) * (w1 - ws) > 0.0 || w0 == w1 {
                    return false;
                }
                let t = (ws - w0) / (w1 - w0);
                let ai =
                    q[0].tip_amplitude_m() + t * (q[1].tip_amplitude_m() - q[0].tip_amplitude_m());
                (ai - a).abs() < 2e-2 * a
            })
        });
        assert!(on, "solution {a} at {ws} on no branch");
    }
    // one fold in the band, the jump-down one, at its analytic frequency; the
    // middle part of the branch holding it is unstable
    let found: Vec<f64> = r
        .bifurcations()
        .iter()
        .filter(|(_, p)| p.bifurcation == Bifurcation::Fold)
        .map(|(_, p)| p.omega_rad_s)
        .collect();
    assert_eq!(found.len(), 1, "{found:?}");
    assert!((found[0] - wu).abs() < 1e-7 * wu, "{} vs {wu}", found[0]);
    assert!(r
        .branches
        .iter()
        .any(|b| b.points.iter().any(|p| p.stable() == Some(false))));
}

/// The paper's case (a): the beam with its cubic spring, the shaker at 2l/3
/// driven at `volts`, the tip observed.
fn case_a(volts: f64) -> (PaperStructure, LinearAttachment, HbSystem) {
    let p = paper(nlmode::benchmark::K3_N_PER_M3);
    let shaker = LinearAttachment::shaker("shaker", &ShakerParams::paper(), "2l3").unwrap();
    let u = DVector::from_element(1, Complex64::new(volts, 0.0));
    let sys = HbSystem::new(&p.model, std::slice::from_ref(&shaker), &[u], &[], "tip").unwrap();
    (p, shaker, sys)
}

/// The paper beam with its cubic spring's coefficient set to `k3` (the
/// element kept, so the HB carries its unknowns even at `k3 = 0`).
fn paper(k3: f64) -> PaperStructure {
    let mut p = paper_structure(&PaperStructureOptions::default()).unwrap();
    p.model.nonlinear[0].law = Arc::new(CubicLaw { k3, c3: 0.0 });
    p
}

fn tip_index(p: &PaperStructure) -> usize {
    p.model.points.iter().position(|q| q.name == "tip").unwrap()
}

#[test]
fn linear_limit_paper_beam_with_shaker_equals_assembled_frf() {
    let p = paper(0.0);
    let sp = ShakerParams::paper();
    let shaker = LinearAttachment::shaker("shaker", &sp, "2l3").unwrap();
    let u = DVector::from_element(1, Complex64::new(10.0, 0.0));
    let sys = HbSystem::new(
        &p.model,
        std::slice::from_ref(&shaker),
        std::slice::from_ref(&u),
        &[],
        "tip",
    )
    .unwrap();
    let w0 = p.omega0_rad_s;
    let opts = HbOptions {
        harmonics: 3,
        omega_start_rad_s: 0.8 * w0,
        omega_end_rad_s: 1.8 * w0,
        stability: false,
        ..HbOptions::default()
    };
    let res = frequency_response(&sys, &opts, &[]).unwrap();
    let b = &res.branches[0];
    assert!(b.points.len() > 20);
    let omegas: Vec<f64> = b.points.iter().map(|q| q.omega_rad_s).collect();
    let frf = assembled_frf(
        &p.model,
        std::slice::from_ref(&shaker),
        std::slice::from_ref(&u),
        &omegas,
    )
    .unwrap();
    let ti = tip_index(&p);
    let mut worst: f64 = 0.0;
    for (q, f) in b.points.iter().zip(&frf) {
        let e_tip = (q.response_m[1] - f.points[ti]).norm() / f.points[ti].norm();
        let e_force = (q.forces_n[0] - f.force_n[0]).norm() / f.force_n[0].norm();
        worst = worst.max(e_tip).max(e_force);
        for n in [0, 2, 3] {
            assert!(q.response_m[n].norm() < 1e-12 * f.points[ti].norm());
        }
    }
    println!("linear limit: worst relative deviation from linear-frf {worst:e}");
    assert!(worst < 1e-10, "{worst:e}");
    assert!(b.points.iter().all(|q| q.bifurcation == Bifurcation::None));
    // the force drop at omega0 (a run starting exactly there)
    let at = HbOptions {
        omega_start_rad_s: w0,
        omega_end_rad_s: 1.01 * w0,
        ..opts
    };
    let r0 = frequency_response(&sys, &at, &[]).unwrap();
    let q0 = &r0.branches[0].points[0];
    let drop_hb =
        1.0 - q0.force_amplitudes_n()[0] / (10.0 * sp.force_constant_n_per_a / sp.resistance_ohm);
    let drop = linear_force_drop(&p.model, &sp, "2l3", w0).unwrap();
    println!("force drop at omega0: hb {drop_hb}, linear-frf {drop}");
    assert!((drop_hb - drop).abs() < 1e-10, "{drop_hb} vs {drop}");
}

#[test]
fn linear_limit_two_shakers_and_tmd_equal_assembled_frf() {
    let p = paper(0.0);
    let sp = ShakerParams::paper();
    let atts = vec![
        LinearAttachment::shaker("s1", &sp, "l3").unwrap(),
        LinearAttachment::shaker("s2", &sp.with_rigid_stinger(), "2l3").unwrap(),
        LinearAttachment::tuned_mass_damper("tmd", "tip", 0.05, 0.05 * 350.0f64.powi(2), 0.5)
            .unwrap(),
    ];
    let u = vec![
        DVector::from_element(1, Complex64::new(5.0, 0.0)),
        DVector::from_element(1, Complex64::from_polar(3.0, 0.5)),
        DVector::zeros(0),
    ];
    let sys = HbSystem::new(&p.model, &atts, &u, &[], "tip").unwrap();
    assert_eq!(sys.force_names(), vec!["s1", "s2", "tmd"]);
    let w0 = p.omega0_rad_s;
    let opts = HbOptions {
        harmonics: 2,
        omega_start_rad_s: 0.5 * w0,
        omega_end_rad_s: 2.0 * w0,
        stability: false,
        ..HbOptions::default()
    };
    let res = frequency_response(&sys, &opts, &[]).unwrap();
    let b = &res.branches[0];
    let omegas: Vec<f64> = b.points.iter().map(|q| q.omega_rad_s).collect();
    let frf = assembled_frf(&p.model, &atts, &u, &omegas).unwrap();
    let ti = tip_index(&p);
    let mut worst: f64 = 0.0;
    for (q, f) in b.points.iter().zip(&frf) {
        worst = worst.max((q.response_m[1] - f.points[ti]).norm() / f.points[ti].norm());
        for k in 0..3 {
            worst = worst.max((q.forces_n[k] - f.force_n[k]).norm() / f.force_n[k].norm());
        }
    }
    println!("two shakers + TMD: worst relative deviation {worst:e}");
    assert!(worst < 1e-10, "{worst:e}");
}

#[test]
fn force_control_holds_the_force_and_sees_the_bare_structure() {
    // with the shaker's interface force held at 2 N, the structure sees exactly
    // 2 N at 2l3: tip = H_tip,2l3(Omega) F, whatever the shaker does
    let p = paper(0.0);
    let sp = ShakerParams::paper();
    let shaker = LinearAttachment::shaker("shaker", &sp, "2l3").unwrap();
    let u = DVector::from_element(1, Complex64::new(1.0, 0.0));
    let sys = HbSystem::new(&p.model, &[shaker], &[u], &[], "tip").unwrap();
    let w0 = p.omega0_rad_s;
    let opts = HbOptions {
        harmonics: 1,
        omega_start_rad_s: 0.8 * w0,
        omega_end_rad_s: 1.2 * w0,
        stability: false,
        control: Control::Force {
            column: 0,
            amplitude_n: 2.0,
        },
        ..HbOptions::default()
    };
    let res = frequency_response(&sys, &opts, &[]).unwrap();
    let b = &res.branches[0];
    let omegas: Vec<f64> = b.points.iter().map(|q| q.omega_rad_s).collect();
    let h = structure_receptance(&p.model, "2l3", "tip", &omegas).unwrap();
    for (q, hq) in b.points.iter().zip(&h) {
        assert!((q.force_amplitudes_n()[0] - 2.0).abs() < 1e-8);
        let rel = (q.tip_amplitude_m() - 2.0 * hq.norm()).abs() / (2.0 * hq.norm());
        assert!(rel < 1e-9, "{rel:e} at {}", q.omega_rad_s);
    }
    // the voltage needed dips at the resonance (the force drop)
    let v: Vec<f64> = b.points.iter().map(|q| q.input_scale).collect();
    let vmax = v.iter().cloned().fold(0.0, f64::max);
    assert!(v.iter().cloned().fold(f64::INFINITY, f64::min) < 0.2 * vmax);
}

#[test]
fn convergence_in_h_paper_beam_10v() {
    let (p, _, sys) = case_a(10.0);
    let w0 = p.omega0_rad_s;
    let run = |h: usize| {
        let opts = HbOptions {
            harmonics: h,
            omega_start_rad_s: 0.8 * w0,
            omega_end_rad_s: 1.8 * w0,
            stability: false,
            ..HbOptions::default()
        };
        frequency_response(&sys, &opts, &[]).unwrap()
    };
    let (r7, r13) = (run(7), run(13));
    let summary = |r: &nlmode::hb::HbResult| {
        let b = &r.branches[0];
        assert_eq!(b.status, nlmode::hb::BranchStatus::Complete);
        let peak = b
            .points
            .iter()
            .map(|q| q.tip_amplitude_m())
            .fold(0.0, f64::max);
        let folds: Vec<f64> = b
            .points
            .iter()
            .filter(|q| q.bifurcation == Bifurcation::Fold)
            .map(|q| q.omega_rad_s)
            .collect();
        (peak, folds)
    };
    let (p7, f7) = summary(&r7);
    let (p13, f13) = summary(&r13);
    println!("H=7: peak {p7:e} m, folds {f7:?}; H=13: peak {p13:e} m, folds {f13:?}");
    println!("relative peak difference {:e}", (p7 - p13).abs() / p13);
    assert_eq!(f7.len(), 2);
    assert_eq!(f13.len(), 2);
    // measured: peak 2.7e-11, folds 4e-13
    assert!((p7 - p13).abs() < 1e-8 * p13);
    for (a, b) in f7.iter().zip(&f13) {
        println!("fold shift H 7 -> 13: {:e}", (a - b).abs() / b);
        assert!((a - b).abs() < 1e-9 * b);
    }
    // the jump-down fold lies far above omega0 at 10 V
    assert!(f7.iter().cloned().fold(0.0, f64::max) > 1.2 * w0);
}

#[test]
fn bad_options_are_named() {
    let sys = duffing_system();
    let base = HbOptions {
        omega_start_rad_s: 0.6,
        omega_end_rad_s: 1.6,
        ..HbOptions::default()
    };
    let name = |o: HbOptions| match frequency_response(&sys, &o, &[]) {
        Err(HbError::BadOption { name, .. }) => name,
        other => panic!("expected a bad option, got {other:?}"),
    };
    assert_eq!(
        name(HbOptions {
            harmonics: 0,
            ..base.clone()
        }),
        "harmonics"
    );
    assert_eq!(
        name(HbOptions {
            harmonics: 65,
            ..base.clone()
        }),
        "harmonics"
    );
    assert_eq!(
        name(HbOptions {
            samples: Some(3),
            ..base.clone()
        }),
        "samples"
    );
    assert_eq!(
        name(HbOptions {
            ds: f64::NAN,
            ..base.clone()
        }),
        "ds"
    );
    assert_eq!(
        name(HbOptions {
            omega_end_rad_s: 0.6,
            ..base.clone()
        }),
        "omega_end_rad_s"
    );
    assert_eq!(
        name(HbOptions {
            omega_start_rad_s: -1.0,
            ..base.clone()
        }),
        "omega_start_rad_s"
    );
    assert_eq!(
        name(HbOptions {
            max_points: 1,
            ..base.clone()
        }),
        "max_points"
    );
    assert_eq!(
        name(HbOptions {
            tolerance: 0.0,
            ..base.clone()
        }),
        "tolerance"
    );
    assert_eq!(
        name(HbOptions {
            control: Control::Force {
                column: 0,
                amplitude_n: -1.0
            },
            ..base.clone()
        }),
        "force_amplitude_n"
    );
    assert!(matches!(
        frequency_response(
            &sys,
            &HbOptions {
                control: Control::Force {
                    column: 3,
                    amplitude_n: 1.0
                },
                ..base.clone()
            },
            &[]
        ),
        Err(HbError::UnknownForceColumn { column: 3, .. })
    ));
    assert!(matches!(
        HbSystem::new(&duffing(M, C, K, K3), &[], &[], &[], "nowhere"),
        Err(HbError::UnknownPoint { .. })
    ));
}

#[test]
fn paper_beam_10v_middle_branch_unstable_by_hill() {
    // case (a), H = 3: between the jump-down and jump-up folds the branch is
    // unstable, elsewhere stable (the shaker's states are part of the Hill matrix)
    let (p, _, sys) = case_a(10.0);
    let w0 = p.omega0_rad_s;
    let opts = HbOptions {
        harmonics: 3,
        omega_start_rad_s: 0.8 * w0,
        omega_end_rad_s: 1.8 * w0,
        ..HbOptions::default()
    };
    let t = std::time::Instant::now();
    let r = frequency_response(&sys, &opts, &[]).unwrap();
    let b = &r.branches[0];
    let folds: Vec<usize> = b
        .points
        .iter()
        .enumerate()
        .filter(|(_, q)| q.bifurcation == Bifurcation::Fold)
        .map(|(i, _)| i)
        .collect();
    let unstable: Vec<f64> = b
        .points
        .iter()
        .filter(|q| q.stable() == Some(false))
        .map(|q| q.omega_rad_s)
        .collect();
    println!(
        "paper beam 10 V, H = 3: {} points in {:.2} s, folds at {:?}, unstable at {unstable:?}, other labels {:?}",
        b.points.len(),
        t.elapsed().as_secs_f64(),
        folds.iter().map(|&i| b.points[i].omega_rad_s).collect::<Vec<_>>(),
        r.bifurcations().iter().map(|(_, q)| (q.bifurcation.label(), q.omega_rad_s)).collect::<Vec<_>>()
    );
    assert_eq!(folds.len(), 2);
    // only the two folds: the resonant pair turning real near a fold (its
    // copies at +-i Omega are real multipliers) is no Neimark-Sacker point
    assert_eq!(r.bifurcations().len(), 2, "{:?}", r.bifurcations());
    // the full Hill matrix on the same branch: one exponent per family (nz
    // of them, no two copies of one), the same stability at every point and
    // the same largest real part up to the truncation error that separates
    // two copies of one exponent (3e-3 1/s measured at H = 7; the condensed
    // problem keeps the band copy, the full one the most centred copy)
    let full = frequency_response(
        &sys,
        &HbOptions {
            hill: HillMethod::Full,
            ..opts.clone()
        },
        &[],
    )
    .unwrap();
    let bf = &full.branches[0];
    assert_eq!(bf.points.len(), b.points.len());
    let nz = bf.points[0].floquet.as_ref().unwrap().exponents.len();
    let no_copies = |f: &nlmode::hb::Floquet, w: f64, range: f64| {
        for (i, a) in f.exponents.iter().enumerate() {
            for c in &f.exponents[i + 1..] {
                let k = ((a.im - c.im) / w).round();
                let d = (a - c - Complex64::new(0.0, k * w)).norm();
                // copies lie within the Hill matrix's harmonic range
                let copy = k != 0.0 && k.abs() <= range && d < 1e-2 * w;
                assert!(!copy, "copies {a} {c}");
            }
        }
    };
    for (q, qf) in b.points.iter().zip(&bf.points) {
        let (f, ff) = (q.floquet.as_ref().unwrap(), qf.floquet.as_ref().unwrap());
        assert_eq!(ff.exponents.len(), nz, "at {}", q.omega_rad_s);
        no_copies(ff, q.omega_rad_s, 6.0);
        no_copies(f, q.omega_rad_s, 6.0);
        // the condensed exponents lie in the band
        assert!(f
            .exponents
            .iter()
            .all(|e| e.im.abs() <= 0.5 * q.omega_rad_s * (1.0 + 1e-9)));
        assert_eq!(f.stable, ff.stable, "at {}", q.omega_rad_s);
        assert!(
            (f.max_re - ff.max_re).abs() < 1e-2,
            "at {}: {} vs {}",
            q.omega_rad_s,
            f.max_re,
            ff.max_re
        );
    }
    for (i, q) in b.points.iter().enumerate() {
        let s = q.stable().unwrap();
        if i + 1 < folds[0] || i > folds[1] + 1 {
            assert!(s, "point {i} at {} should be stable", q.omega_rad_s);
        } else if i > folds[0] + 1 && i + 1 < folds[1] {
            assert!(!s, "point {i} at {} should be unstable", q.omega_rad_s);
        }
    }
}

/// The periodic state `z(0)` of the assembled first-order system (structure
/// and shaker states, `nlmode::reference`) on the HB solution `q`: with the
/// element force `f(t)` of the solution's tip motion (sampled finely here,
/// independently of the production AFT), `z_n = (i n Omega - A)^{-1} (b u_n +
/// G f_n)` is the unique periodic response of the linear part to the known
/// periodic inputs, i.e. the HB solution's state.
fn periodic_state(
    asys: &nlmode::reference::AssembledSystem,
    law: &dyn nlmode::structure::NonlinearLaw,
    q: &nlmode::hb::HbPoint,
    volts: f64,
) -> DVector<f64> {
    let fo = &asys.first_order;
    let w = q.omega_rad_s;
    let u = &q.response_m;
    let h = u.len() - 1;
    let ns = 512;
    let mut f_n = vec![Complex64::new(0.0, 0.0); h + 1];
    for k in 0..ns {
        let tau = 2.0 * std::f64::consts::PI * k as f64 / ns as f64;
        let (mut x, mut v) = (0.0, 0.0);
        for (n, un) in u.iter().enumerate() {
            let e = Complex64::from_polar(1.0, n as f64 * tau);
            x += (un * e).re;
            v += (Complex64::new(0.0, n as f64 * w) * un * e).re;
        }
        let (f, _, _) = law.eval(x, v);
        for (n, fnn) in f_n.iter_mut().enumerate() {
            let scale = if n == 0 { 1.0 } else { 2.0 };
            *fnn += Complex64::from_polar(scale * f / ns as f64, -(n as f64) * tau);
        }
    }
    let nz = fo.nz();
    let mut z0 = DVector::<f64>::zeros(nz);
    for (n, fnn) in f_n.iter().enumerate() {
        let mut lhs = fo.a.map(|a| Complex64::new(-a, 0.0));
        for i in 0..nz {
            lhs[(i, i)] += Complex64::new(0.0, n as f64 * w);
        }
        let mut rhs = fo.g.column(0).map(|g| Complex64::new(g, 0.0)) * *fnn;
        if n == 1 {
            rhs += fo.b.column(0).map(|b| Complex64::new(b * volts, 0.0));
        }
        let zn = lhs.lu().solve(&rhs).unwrap();
        z0 += zn.map(|c| c.re);
    }
    z0
}

/// Fundamental amplitude of the tip over each window of 10 periods of a
/// fixed-frequency run of the full assembled system from `z0`.
fn window_amplitudes(
    asys: &nlmode::reference::AssembledSystem,
    z0: &DVector<f64>,
    w: f64,
    volts: f64,
    periods: usize,
) -> Vec<f64> {
    use nlmode::reference::{integrate, ReferenceOptions, SampleGrid};
    let per = 64;
    let window = 10 * per;
    let t = 2.0 * std::f64::consts::PI / w;
    let grid = SampleGrid {
        interval_s: t / per as f64,
        count: per * periods,
    };
    let mut obs = DVector::zeros(asys.n_observed());
    let mut a1 = vec![Complex64::new(0.0, 0.0); periods / 10];
    let opts = ReferenceOptions {
        rtol: 1e-10,
        atol: 1e-16,
        ..ReferenceOptions::default()
    };
    integrate(
        asys,
        z0,
        grid,
        &|s| volts * (w * s).cos(),
        &opts,
        &mut |i, z| {
            if i / window < a1.len() {
                let ph = w * i as f64 * t / per as f64;
                asys.observe(z, volts * ph.cos(), &[0.0], &mut obs);
                a1[i / window] += Complex64::from_polar(2.0 * obs[0] / window as f64, -ph);
            }
        },
        &mut |_| {},
    )
    .unwrap();
    a1.iter().map(|a| a.norm()).collect()
}

#[test]
fn fixed_frequency_runs_of_the_full_system_confirm_hill_stability() {
    // case (a), 10 V, H = 7: started on an HB solution, the full assembled
    // system (the reference integrator, tolerance 1e-10) stays on a stable one
    // (its amplitude within 1e-4 of the HB amplitude for 150 periods: 3e-11
    // measured on the upper branch, 2e-9 next to the jump-up fold) and leaves
    // an unstable one (by 17 %, onto another branch), its deviation growing
    // at the rate of Hill's unstable exponent
    let volts = 10.0;
    let (p, shaker, sys) = case_a(volts);
    let asys = nlmode::reference::AssembledSystem::new(&p.model, &[shaker], "tip").unwrap();
    // the element is the grounded tip spring: its displacement is the tip's
    let el = &p.model.nonlinear[0];
    let tip = p.model.points.iter().find(|q| q.name == "tip").unwrap();
    assert!((&el.direction - &tip.direction).norm() < 1e-12);
    let w0 = p.omega0_rad_s;
    let opts = HbOptions {
        harmonics: 7,
        omega_start_rad_s: 0.8 * w0,
        omega_end_rad_s: 1.8 * w0,
        ..HbOptions::default()
    };
    let r = frequency_response(&sys, &opts, &[]).unwrap();
    let b = &r.branches[0];
    let re = |q: &nlmode::hb::HbPoint| q.floquet.as_ref().unwrap().max_re;
    // the most unstable point, the stable point of largest amplitude (upper
    // branch, near its fold) and the first stable point after the jump
    let unstable = b
        .points
        .iter()
        .filter(|q| q.stable() == Some(false))
        .max_by(|a, c| re(a).total_cmp(&re(c)))
        .unwrap();
    let upper = b
        .points
        .iter()
        .filter(|q| q.stable() == Some(true) && q.bifurcation == Bifurcation::None)
        .max_by(|a, c| a.tip_amplitude_m().total_cmp(&c.tip_amplitude_m()))
        .unwrap();
    let last_fold = b
        .points
        .iter()
        .rposition(|q| q.bifurcation == Bifurcation::Fold)
        .unwrap();
    let lower = b.points[last_fold + 1..]
        .iter()
        .find(|q| q.stable() == Some(true))
        .unwrap();
    for (q, stable) in [(upper, true), (lower, true), (unstable, false)] {
        let z0 = periodic_state(&asys, el.law.as_ref(), q, volts);
        let periods = if stable { 150 } else { 350 };
        let a = window_amplitudes(&asys, &z0, q.omega_rad_s, volts, periods);
        let dev: Vec<f64> = a
            .iter()
            .map(|x| (x - q.tip_amplitude_m()).abs() / q.tip_amplitude_m())
            .collect();
        println!(
            "Omega {:.4} rad/s, max Re s {:.3} 1/s: HB {:.6e} m, deviation per 10 periods {:?}",
            q.omega_rad_s,
            re(q),
            q.tip_amplitude_m(),
            dev.iter().map(|d| format!("{d:.2e}")).collect::<Vec<_>>()
        );
        if stable {
            assert!(
                dev.iter().all(|d| *d < 1e-4),
                "stable point at {} drifted: {dev:?}",
                q.omega_rad_s
            );
        } else {
            // it leaves the branch, and while the deviation is small it grows
            // at the rate of the unstable Floquet exponent
            assert!(
                *dev.last().unwrap() > 5e-2,
                "unstable point at {} stayed: {dev:?}",
                q.omega_rad_s
            );
            let (i, j) = (5, 15);
            assert!(dev[j] < 1e-2);
            let dt = (j - i) as f64 * 10.0 * 2.0 * std::f64::consts::PI / q.omega_rad_s;
            let sigma = (dev[j] / dev[i]).ln() / dt;
            println!(
                "measured growth rate {sigma:.3} 1/s against Re s = {:.3} 1/s",
                re(q)
            );
            // (4.401 against 4.401 measured)
            assert!(
                (sigma - re(q)).abs() < 1e-2 * re(q),
                "growth {sigma} vs {}",
                re(q)
            );
        }
    }
}

/// `f(u, v) = eps (u^2 - b) v`: with the linear damping `c`, the forced van
/// der Pol oscillator `x'' + (c - eps b) x' + eps x^2 x' + x = F cos(Omega t)`.
#[derive(Debug)]
struct VanDerPol {
    eps: f64,
    b: f64,
}

impl nlmode::structure::NonlinearLaw for VanDerPol {
    fn name(&self) -> &str {
        "van-der-pol"
    }
    fn eval(&self, u: f64, v: f64) -> (f64, f64, f64) {
        let e = self.eps;
        (
            e * (u * u - self.b) * v,
            2.0 * e * u * v,
            e * (u * u - self.b),
        )
    }
}

#[test]
fn forced_van_der_pol_loses_entrainment_at_neimark_sacker_points() {
    // x'' - eps (1 - x^2) x' + x = F cos(Omega t), eps = 0.1, F = 0.2 (above
    // the forcing where the entrainment boundary is a fold, F = 0.1 here): the
    // entrained (periodic) response is stable near Omega = 1 and becomes
    // quasi-periodic where a complex pair of Floquet exponents crosses the
    // axis. Averaging gives the slow flow's trace eps (1 - r^2 / 2): the
    // Neimark-Sacker points lie where the response amplitude r = sqrt(2);
    // Hill's problem at H = 1 puts them there to 1e-12 (1e-8 asserted). The
    // linear part carries +0.05 of damping (a stable A: the condensed Hill
    // problem) and the law the rest; the full Hill matrix must find the same
    // points.
    let eps = 0.1;
    let mut model = duffing(1.0, 0.5 * eps, 1.0, 0.0);
    model.nonlinear[0].law = Arc::new(VanDerPol { eps, b: 1.5 });
    let sys = HbSystem::new(
        &model,
        &[],
        &[],
        &[("x".into(), Complex64::new(0.2, 0.0))],
        "x",
    )
    .unwrap();
    let mut found = vec![];
    for hill in [HillMethod::Condensed, HillMethod::Full] {
        let opts = HbOptions {
            harmonics: 1,
            omega_start_rad_s: 0.7,
            omega_end_rad_s: 1.3,
            ds: 0.01,
            hill,
            ..HbOptions::default()
        };
        let r = frequency_response(&sys, &opts, &[]).unwrap();
        let b = &r.branches[0];
        let ns: Vec<&nlmode::hb::HbPoint> = b
            .points
            .iter()
            .filter(|q| q.bifurcation == Bifurcation::NeimarkSacker)
            .collect();
        println!(
            "{hill:?}: NS at {:?}, other labels {:?}",
            ns.iter()
                .map(|q| (q.omega_rad_s, q.tip_amplitude_m()))
                .collect::<Vec<_>>(),
            r.bifurcations()
                .iter()
                .filter(|(_, q)| q.bifurcation != Bifurcation::NeimarkSacker)
                .map(|(_, q)| (q.bifurcation.label(), q.omega_rad_s))
                .collect::<Vec<_>>()
        );
        assert_eq!(ns.len(), 2);
        for q in &ns {
            let r = q.tip_amplitude_m();
            assert!(
                (r - 2f64.sqrt()).abs() < 0.05 * 2f64.sqrt(),
                "NS at r = {r}"
            );
            // the refined point: the complex pair on the axis
            let f = q.floquet.as_ref().unwrap();
            assert!(f.max_re_complex.abs() < 1e-6, "{}", f.max_re_complex);
        }
        // stable between the two points (entrained), unstable outside
        let (w1, w2) = (
            ns[0].omega_rad_s.min(ns[1].omega_rad_s),
            ns[0].omega_rad_s.max(ns[1].omega_rad_s),
        );
        for q in &b.points {
            let w = q.omega_rad_s;
            if w < w1 - 1e-3 || w > w2 + 1e-3 {
                assert_eq!(q.stable(), Some(false), "at {w}");
            } else if w > w1 + 1e-3 && w < w2 - 1e-3 {
                assert_eq!(q.stable(), Some(true), "at {w}");
            }
        }
        found.push((w1, w2));
    }
    // the two Hill problems agree on the points
    assert!(
        (found[0].0 - found[1].0).abs() < 1e-8 && (found[0].1 - found[1].1).abs() < 1e-8,
        "{found:?}"
    );
}

#[test]
fn coupled_duffings_forced_out_of_phase_break_symmetry_at_branch_points() {
    // two unit masses on grounded springs k = 1 with cubic springs k3 = 1,
    // coupled by kc = 0.05, damping c = 0.01, forced out of phase (+-F): the
    // out-of-phase response x1 = -x2 = A cos(Omega t + phi) loses its symmetry
    // (localisation) where the in-phase perturbation y = x1 + x2,
    // y'' + c y' + k y + 3 k3 x^2 y = 0, has a singular H = 1 balance:
    // (k - W^2 + 9/4 k3 A^2)(k - W^2 + 3/4 k3 A^2) + c^2 W^2 = 0. The
    // continuation labels branch points there (an augmented determinant
    // changing sign), refined onto that closed-form condition.
    use nalgebra::DMatrix;
    use nlmode::structure::{NamedPoint, NonlinearElement, StructuralModel};
    let (k, kc, c, k3, f) = (1.0, 0.05, 0.01, 1.0, 0.02);
    let e = |i: usize| DVector::from_fn(2, |j, _| if i == j { 1.0 } else { 0.0 });
    let model = StructuralModel {
        mass: DMatrix::identity(2, 2),
        stiffness: DMatrix::from_row_slice(2, 2, &[k + kc, -kc, -kc, k + kc]),
        damping: DMatrix::identity(2, 2) * c,
        nonlinear: (0..2)
            .map(|i| NonlinearElement {
                name: format!("cubic{i}"),
                direction: e(i),
                law: Arc::new(CubicLaw { k3, c3: 0.0 }),
            })
            .collect(),
        points: (0..2)
            .map(|i| NamedPoint {
                name: format!("p{}", i + 1),
                direction: e(i),
            })
            .collect(),
    };
    let sys = HbSystem::new(
        &model,
        &[],
        &[],
        &[
            ("p1".into(), Complex64::new(f, 0.0)),
            ("p2".into(), Complex64::new(-f, 0.0)),
        ],
        "p1",
    )
    .unwrap();
    let opts = HbOptions {
        harmonics: 1,
        omega_start_rad_s: 0.9,
        omega_end_rad_s: 2.5,
        ds: 0.01,
        stability: false,
        ..HbOptions::default()
    };
    let r = frequency_response(&sys, &opts, &[]).unwrap();
    let bps: Vec<&nlmode::hb::HbPoint> = r.branches[0]
        .points
        .iter()
        .filter(|q| q.bifurcation == Bifurcation::BranchPoint)
        .collect();
    println!(
        "branch points {:?}, status {:?}",
        bps.iter()
            .map(|q| (q.omega_rad_s, q.tip_amplitude_m()))
            .collect::<Vec<_>>(),
        r.branches[0].status
    );
    assert!(!bps.is_empty());
    for q in &bps {
        let (w, a) = (q.omega_rad_s, q.tip_amplitude_m());
        let k1 = k - w * w + 2.25 * k3 * a * a;
        let k2 = k - w * w + 0.75 * k3 * a * a;
        let g = k1 * k2 + c * c * w * w;
        let scale = (k1 * k2).abs() + c * c * w * w;
        println!("BP at {w}: A = {a}, condition {g:e} of {scale:e}");
        assert!(g.abs() < 1e-6 * scale, "at {w}: {g:e} vs {scale:e}");
    }
}
