//! Nonlinear modal analysis: Harmonic Balance (AFT), EPMC, continuation,
//! forced responses and modal tables, against analytic results.
use nalgebra::{DMatrix, DVector};
use nlmode::nma::continuation::{
    solve_fixed_parameter, solve_fixed_parameter_chord, BorderedFactor, BorderedSolve, Residual,
};
use nlmode::nma::epmc::{EpmcResidual, ForcedResidual};
use nlmode::nma::modal_basis::ModalBasis;
use nlmode::nma::problems::{
    chain, duffing, duffing_backbone_h1, duffing_exact_backbone, CubicLaw,
};
use nlmode::nma::*;
use nlmode::structure::{NonlinearElement, NonlinearLaw, StructuralModel};
use std::sync::Arc;

fn fd_jacobian<R: Residual>(res: &R, x: &DVector<f64>) -> DMatrix<f64> {
    let (r0, _) = res.eval(x);
    let mut j = DMatrix::zeros(r0.len(), x.len());
    for c in 0..x.len() {
        let h = 1e-6 * x[c].abs().max(1e-3);
        let mut xp = x.clone();
        xp[c] += h;
        let mut xm = x.clone();
        xm[c] -= h;
        j.set_column(c, &((res.eval(&xp).0 - res.eval(&xm).0) / (2.0 * h)));
    }
    j
}

fn pseudo_random(n: usize, seed: u64) -> DVector<f64> {
    let mut s = seed;
    DVector::from_fn(n, |_, _| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    })
}

/// A 3-mass chain with a cubic spring and a cubic damper at the end.
fn test_chain(extra_damper: f64) -> StructuralModel {
    chain(
        3,
        1.3,
        1000.0,
        0.5,
        1e-4,
        CubicLaw { k3: 4e5, c3: 30.0 },
        extra_damper,
    )
}

#[test]
fn epmc_jacobian_matches_finite_differences() {
    for extra in [0.0, 2.0] {
        let model = test_chain(extra);
        let basis = Arc::new(ModalBasis::new(&model, false).unwrap());
        assert_eq!(basis.diagonal_damping, extra == 0.0);
        let res = EpmcResidual::new(basis, 3, 13, 0);
        let m = res.n_coeffs();
        let mut x = res.linear_guess(-1.0) + pseudo_random(m + 3, 7) * 0.3;
        x[m] = 15.0;
        x[m + 1] = 0.02;
        x[m + 2] = -1.0;
        let (_, jac) = res.eval(&x);
        let fd = fd_jacobian(&res, &x);
        let err = (&fd - jac.to_dense()).amax();
        assert!(
            err < 1e-6 * fd.amax(),
            "extra damper {extra}: {err} vs {}",
            fd.amax()
        );
    }
}

#[test]
fn forced_jacobian_matches_finite_differences() {
    let model = test_chain(0.0);
    let basis = Arc::new(ModalBasis::new(&model, false).unwrap());
    let f = DVector::from_vec(vec![0.0, 0.0, 1.0]);
    let res = ForcedResidual::new(basis, 2, 9, &f, 10.0);
    let m = res.n_coeffs();
    let mut x = pseudo_random(m + 1, 3) * 0.05;
    x[m] = 12.0;
    let (_, jac) = res.eval(&x);
    let fd = fd_jacobian(&res, &x);
    let err = (&fd - jac.to_dense()).amax();
    assert!(err < 1e-6 * fd.amax(), "{err}");
}

#[test]
fn condensed_solve_equals_dense_solve() {
    let model = test_chain(0.0);
    let basis = Arc::new(ModalBasis::new(&model, false).unwrap());
    let om: Vec<f64> = (0..3).map(|k| basis.omega(k)).collect();
    let res = EpmcResidual::new(basis.clone(), 5, 21, 0);
    let m = res.n_coeffs();
    // generic point, and points with an internal resonance n omega ~ omega_k
    // (near-singular modal blocks that must be kept explicit)
    for (omega, d) in [
        (om[0] * 1.1, 0.01),
        (om[1] / 3.0 * 1.001, 0.0),
        (om[2] / 5.0, 0.0),
    ] {
        let mut x = res.linear_guess(-0.5) + pseudo_random(m + 3, 11) * 0.2;
        x[m] = omega;
        x[m + 1] = d;
        let (_, jac) = res.eval(&x);
        let row = pseudo_random(m + 3, 5);
        let rhs = pseudo_random(m + 3, 9);
        let y1 = jac.solve_bordered(&row, &rhs).unwrap();
        let y2 = jac.solve_bordered_dense(&row, &rhs).unwrap();
        assert!(
            (&y1 - &y2).amax() < 1e-9 * y2.amax(),
            "omega {omega}: {}",
            (&y1 - &y2).amax()
        );
        // and it solves the scaled system given by to_dense()
        let mut a = jac.to_dense().insert_row(m + 2, 0.0);
        a.row_mut(m + 2).copy_from(&row.transpose());
        assert!((a * &y1 - &rhs).amax() < 1e-9 * rhs.amax().max(1.0));
    }
    // forced residual at resonance of mode 2 (undamped block nearly singular)
    let f = DVector::from_vec(vec![1.0, 0.0, 0.0]);
    let res = ForcedResidual::new(basis, 3, 13, &f, om[1]);
    let m = res.n_coeffs();
    let mut x = pseudo_random(m + 1, 1) * 0.01;
    x[m] = om[1];
    let (_, jac) = res.eval(&x);
    let row = pseudo_random(m + 1, 2);
    let rhs = pseudo_random(m + 1, 4);
    let y1 = jac.solve_bordered(&row, &rhs).unwrap();
    let y2 = jac.solve_bordered_dense(&row, &rhs).unwrap();
    assert!((&y1 - &y2).amax() < 1e-9 * y2.amax());
}

/// One factorisation serves many right-hand sides; the residual alone is
/// `eval`'s; chord Newton from a close guess converges to Newton's solution
/// with a single factorisation.
#[test]
fn factored_jacobian_and_chord_newton_agree_with_newton() {
    let model = test_chain(0.0);
    let basis = Arc::new(ModalBasis::new(&model, false).unwrap());
    let res = EpmcResidual::new(basis, 5, 21, 0);
    let m = res.n_coeffs();
    let opts = ContinuationOptions::default();
    let x0 = res.linear_guess(-2.0);
    assert_eq!(res.residual(&x0), res.eval(&x0).0);
    let (x, jac, _) = solve_fixed_parameter(&res, x0, &opts).unwrap();
    let row = pseudo_random(m + 3, 5);
    let f = jac.factor_bordered(&row).unwrap();
    for seed in [9, 10] {
        let rhs = pseudo_random(m + 3, seed);
        let y = jac.solve_bordered(&row, &rhs).unwrap();
        assert_eq!(f.solve(&rhs).unwrap(), y);
    }
    let mut guess = &x + pseudo_random(m + 3, 3) * 1e-4;
    guess[m + 2] = x[m + 2];
    let (xc, it, factorisations) = solve_fixed_parameter_chord(&res, guess, &opts).unwrap();
    assert!((&xc - &x).amax() < 1e-8 * x.amax(), "{}", (&xc - &x).amax());
    assert!(it >= 1 && factorisations == 1, "{it} {factorisations}");
}

#[test]
fn duffing_h1_backbone_is_analytic() {
    let (omega0, k3) = (2.0, 0.5);
    let model = duffing(1.0, 0.0, omega0 * omega0, k3);
    let opts = NmaOptions {
        harmonics: 1,
        amplitude: AmplitudeRange::Modal {
            log10_start: -3.0,
            log10_end: 1.0,
        },
        ..Default::default()
    };
    let r = nonlinear_modal_analysis(&model, &opts).unwrap();
    assert_eq!(r.stop, Some(StopReason::ReachedEnd));
    assert!(r.n_points() > 10, "{}", r.n_points());
    let last = r.branch.last().unwrap();
    assert!(last.amplitude >= 10.0);
    // strongly nonlinear at the end: omega more than doubled
    assert!(last.omega_rad_s > 2.0 * omega0);
    for b in &r.branch {
        let exact = duffing_backbone_h1(omega0, k3, b.amplitude);
        assert!(
            (b.omega_rad_s / exact - 1.0).abs() < 1e-8,
            "a = {}: {} vs {exact}",
            b.amplitude,
            b.omega_rad_s
        );
        assert!(b.damping_ratio.abs() < 1e-10);
        // unit mass: |x_1| = a, phase normalized to a real positive fundamental
        assert!((b.points[0][1].re - 1.0).abs() < 1e-10 && b.points[0][1].im.abs() < 1e-12);
    }
    assert!(r.folds.is_empty());
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
}

#[test]
fn duffing_converges_to_the_exact_backbone() {
    let (omega0, k3) = (1.0, 1.0);
    let model = duffing(1.0, 0.0, omega0 * omega0, k3);
    let basis = Arc::new(ModalBasis::new(&model, true).unwrap());
    let copts = ContinuationOptions::default();
    for x_max in [0.5, 1.0, 2.0] {
        let (omega_ex, a_ex) = duffing_exact_backbone(omega0, k3, x_max);
        let mut errs = vec![];
        for h in [1, 3, 7] {
            let res = EpmcResidual::new(basis.clone(), h, 4 * h + 1, 0);
            let mut x0 = res.linear_guess(a_ex.log10());
            let m = res.n_coeffs();
            x0[m] = duffing_backbone_h1(omega0, k3, a_ex);
            let (x, _, _) = solve_fixed_parameter(&res, x0, &copts).unwrap();
            errs.push((x[m] / omega_ex - 1.0).abs());
        }
        // monotone convergence, H = 7 close to the exact value
        assert!(
            errs[1] < 0.1 * errs[0] && errs[2] < 0.1 * errs[1],
            "x_max {x_max}: {errs:?}"
        );
        assert!(errs[2] < 1e-8, "x_max {x_max}: {errs:?}");
    }
}

#[test]
fn epmc_damping_of_a_linear_viscous_oscillator_is_its_damping_ratio() {
    let (m, c, k) = (2.5, 0.7, 400.0);
    let model = duffing(m, c, k, 0.0);
    let zeta = c / (2.0 * (k * m).sqrt());
    let opts = NmaOptions {
        harmonics: 3,
        amplitude: AmplitudeRange::Modal {
            log10_start: -4.0,
            log10_end: 0.0,
        },
        ..Default::default()
    };
    let r = nonlinear_modal_analysis(&model, &opts).unwrap();
    for b in &r.branch {
        assert!(
            (b.damping_ratio / zeta - 1.0).abs() < 1e-10,
            "{} vs {zeta}",
            b.damping_ratio
        );
        assert!((b.omega_rad_s / (k / m).sqrt() - 1.0).abs() < 1e-12);
        // a = sqrt(m) |x_1|
        assert!((b.points[0][1].norm() - 1.0 / m.sqrt()).abs() < 1e-12);
    }
    assert!(
        matches!(r.warnings.as_slice(), [NmaWarning::LinearRegimeOnly { .. }]),
        "{:?}",
        r.warnings
    );
}

/// EPMC energy balance: the work of the linear damping over a period equals
/// that of the artificial negative damping,
/// `D = sum n^2 phi_n^H C phi_n / (2 omega sum n^2 phi_n^H M phi_n)`.
fn energy_balance_damping(model: &StructuralModel, b: &BranchPoint) -> f64 {
    let nh = b.coordinates[0].len();
    let (mut num, mut den) = (0.0, 0.0);
    for nn in 1..nh {
        let phi = DVector::from_fn(b.coordinates.len(), |i, _| b.coordinates[i][nn]);
        let cphi = model.damping.map(|v| nlmode::Complex64::new(v, 0.0)) * &phi;
        let mphi = model.mass.map(|v| nlmode::Complex64::new(v, 0.0)) * &phi;
        num += (nn * nn) as f64 * phi.dotc(&cphi).re;
        den += (nn * nn) as f64 * phi.dotc(&mphi).re;
    }
    num / (2.0 * b.omega_rad_s * den)
}

#[test]
fn damped_chain_satisfies_the_energy_balance_and_mass_normalization() {
    // proportional (condensed solver) and non-proportional (dense fallback)
    for extra in [0.0, 3.0] {
        let mut model = test_chain(extra);
        model.nonlinear[0].law = Arc::new(CubicLaw { k3: 4e5, c3: 0.0 });
        let opts = NmaOptions {
            harmonics: 5,
            amplitude: AmplitudeRange::Modal {
                log10_start: -3.0,
                log10_end: -0.5,
            },
            ..Default::default()
        };
        let r = nonlinear_modal_analysis(&model, &opts).unwrap();
        let first = &r.branch[0];
        let last = r.branch.last().unwrap();
        assert!(last.omega_rad_s > 1.05 * first.omega_rad_s, "hardening");
        for b in &r.branch {
            let d = energy_balance_damping(&model, b);
            assert!(
                (b.damping_ratio - d).abs() < 1e-9 * d.abs().max(1e-3),
                "extra {extra}: {} vs {d}",
                b.damping_ratio
            );
            let phi1 = DVector::from_fn(3, |i, _| b.coordinates[i][1]);
            let mm = model.mass.map(|v| nlmode::Complex64::new(v, 0.0));
            assert!((phi1.dotc(&(&mm * &phi1)).re - 1.0).abs() < 1e-10);
        }
    }
}

#[test]
fn cubic_damper_gives_the_equivalent_linearization_damping() {
    // x'' + c x' + k x + c3 x'^3 = 0 with H = 1: the fundamental of c3 v^3 for
    // v = -omega a sin is that of a viscous damper 3/4 c3 omega^2 a^2, so
    // omega = sqrt(k) and D = (c + 3/4 c3 k a^2) / (2 sqrt(k)).
    let (c, k, c3) = (0.1, 9.0, 0.4);
    let mut model = duffing(1.0, c, k, 0.0);
    model.nonlinear[0].law = Arc::new(CubicLaw { k3: 0.0, c3 });
    let opts = NmaOptions {
        harmonics: 1,
        amplitude: AmplitudeRange::Modal {
            log10_start: -2.0,
            log10_end: 0.5,
        },
        ..Default::default()
    };
    let r = nonlinear_modal_analysis(&model, &opts).unwrap();
    let last = r.branch.last().unwrap();
    assert!(last.damping_ratio > 10.0 * r.branch[0].damping_ratio);
    for b in &r.branch {
        let d = (c + 0.75 * c3 * k * b.amplitude.powi(2)) / (2.0 * k.sqrt());
        assert!(
            (b.damping_ratio / d - 1.0).abs() < 1e-8,
            "a {}: {} vs {d}",
            b.amplitude,
            b.damping_ratio
        );
        assert!((b.omega_rad_s / k.sqrt() - 1.0).abs() < 1e-10);
    }
}

/// Forced response options of the single-DOF tests: `harmonics`, force
/// amplitude `f` on the DOF, from `omega_start` up to 2 rad/s, arc-length step 0.02.
fn forced_to_2(harmonics: usize, f: f64, omega_start: f64) -> ForcedResponseOptions {
    ForcedResponseOptions {
        harmonics,
        samples: None,
        force: DVector::from_element(1, f),
        omega_start,
        omega_end: 2.0,
        continuation: ContinuationOptions {
            ds: 0.02,
            ..Default::default()
        },
        points: vec![],
    }
}

#[test]
fn forced_duffing_h1_satisfies_the_amplitude_frequency_relation() {
    let (omega0, c, k3, f) = (1.0, 0.02, 0.5, 0.05);
    let model = duffing(1.0, c, omega0 * omega0, k3);
    let opts = forced_to_2(1, f, 0.5);
    let r = forced_response(&model, &opts).unwrap();
    assert_eq!(r.stop, Some(StopReason::ReachedEnd));
    let mut amax: f64 = 0.0;
    for p in &r.points {
        let a = p.points[0][1].norm();
        amax = amax.max(a);
        let om = p.omega_rad_s;
        let lhs =
            a * a * ((omega0 * omega0 - om * om + 0.75 * k3 * a * a).powi(2) + (c * om).powi(2));
        assert!(
            (lhs / (f * f) - 1.0).abs() < 1e-8,
            "Omega {om}: {lhs} vs {}",
            f * f
        );
    }
    // hardening with two folds (jump-up and jump-down frequencies)
    assert_eq!(r.turning_points.len(), 2, "{:?}", r.turning_points);
    let t0 = r.points[r.turning_points[0]].omega_rad_s;
    let t1 = r.points[r.turning_points[1]].omega_rad_s;
    assert!(t0 > t1 && t0 > 1.2, "{t0} {t1}");
    // the peak lies on the H = 1 backbone: a_max ~ f / (c omega)
    let om_peak = duffing_backbone_h1(omega0, k3, amax);
    assert!((amax * c * om_peak / f - 1.0).abs() < 1e-3, "{amax}");
}

#[test]
fn forced_response_higher_harmonics_match_epmc_backbone_at_the_peak() {
    // forced H = 5 peak of the damped Duffing oscillator lies on the EPMC
    // backbone: at phase resonance the EPMC force balance is the forced one.
    let (omega0, c, k3, f) = (1.0, 0.01, 1.0, 0.02);
    let model = duffing(1.0, c, omega0 * omega0, k3);
    let opts = forced_to_2(5, f, 0.8);
    let r = forced_response(&model, &opts).unwrap();
    let peak = r
        .points
        .iter()
        .max_by(|a, b| a.points[0][1].norm().total_cmp(&b.points[0][1].norm()))
        .unwrap();
    let a_peak = peak.points[0][1].norm();
    let basis = Arc::new(ModalBasis::new(&model, false).unwrap());
    let res = EpmcResidual::new(basis, 5, 21, 0);
    let mut x0 = res.linear_guess(a_peak.log10());
    let m = res.n_coeffs();
    x0[m] = duffing_backbone_h1(omega0, k3, a_peak);
    let (x, _, _) = solve_fixed_parameter(&res, x0, &ContinuationOptions::default()).unwrap();
    // discrete points: the peak is within one step of the maximum
    assert!(
        (peak.omega_rad_s / x[m] - 1.0).abs() < 2e-3,
        "{} vs {}",
        peak.omega_rad_s,
        x[m]
    );
    assert!(
        (x[m + 1] - c / (2.0 * x[m])).abs() < 0.05 * c / (2.0 * x[m]),
        "D {}",
        x[m + 1]
    );
}

#[test]
fn table_keeps_the_primary_branch_and_is_monotone() {
    let model = duffing(1.0, 0.0, 4.0, 0.5);
    let opts = NmaOptions {
        harmonics: 3,
        amplitude: AmplitudeRange::Modal {
            log10_start: -2.0,
            log10_end: 0.5,
        },
        ..Default::default()
    };
    let mut r = nonlinear_modal_analysis(&model, &opts).unwrap();
    let t = r.to_table(TablePolicy::PrimaryBranch);
    assert_eq!(t.amplitude.len(), r.n_points());
    assert_eq!(t.truncated_at_fold, None);
    assert!(t.amplitude.windows(2).all(|w| w[1] > w[0]));
    assert_eq!(t.points[0].re[0].len(), 4);
    assert_eq!(t.coordinates.len(), 1);
    assert_eq!(t.coordinates[0].name, "q0");
    assert_eq!(t.format, MODAL_TABLE_FORMAT);
    // fake a loop: a decreases then increases again
    let n = r.branch.len();
    let k = n / 2;
    let mut bent = r.branch[k].clone();
    bent.amplitude = r.branch[k - 1].amplitude;
    r.branch.insert(k, bent);
    let t = r.to_table(TablePolicy::PrimaryBranch);
    assert_eq!(t.amplitude.len(), k);
    assert_eq!(t.truncated_at_fold, Some(r.branch[k - 1].amplitude));
    assert!(t.description.contains("first fold"));
    let t = r.to_table(TablePolicy::SkipLoops);
    assert_eq!(t.amplitude.len(), n);
    assert!(t.amplitude.windows(2).all(|w| w[1] > w[0]));
}

#[test]
fn point_amplitude_range_stops_at_the_point_amplitude() {
    let model = chain(
        3,
        1.0,
        1000.0,
        0.0,
        1e-4,
        CubicLaw { k3: 1e5, c3: 0.0 },
        0.0,
    );
    let opts = NmaOptions {
        harmonics: 3,
        amplitude: AmplitudeRange::Point {
            name: "last".into(),
            start_m: 1e-4,
            end_m: 0.05,
        },
        ..Default::default()
    };
    let r = nonlinear_modal_analysis(&model, &opts).unwrap();
    let amp = r.point_fundamental_amplitude("last").unwrap();
    assert!((amp[0] / 1e-4 - 1.0).abs() < 1e-6, "{}", amp[0]);
    assert!(*amp.last().unwrap() >= 0.05 && amp[amp.len() - 2] < 0.05);
    assert_eq!(r.stop, Some(StopReason::Callback));
}

#[derive(Debug)]
struct BreakingSpring;
impl NonlinearLaw for BreakingSpring {
    fn name(&self) -> &str {
        "breaking"
    }
    fn eval(&self, u: f64, _v: f64) -> (f64, f64, f64) {
        if u.abs() > 0.1 {
            (f64::NAN, f64::NAN, f64::NAN)
        } else {
            (100.0 * u.powi(3), 300.0 * u * u, 0.0)
        }
    }
}

#[test]
fn bad_input_is_reported_with_numbers() {
    let model = duffing(1.0, 0.1, 4.0, 1.0);
    let e = nonlinear_modal_analysis(
        &model,
        &NmaOptions {
            mode_index: 1,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(matches!(
        e,
        NmaError::ModeIndexOutOfRange {
            mode_index: 1,
            n_modes: 1
        }
    ));
    assert!(
        e.to_string().contains("mode index 1") && e.to_string().contains("1 modes"),
        "{e}"
    );
    let e = nonlinear_modal_analysis(
        &model,
        &NmaOptions {
            harmonics: 3,
            samples: Some(12),
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("12") && e.to_string().contains("13"),
        "{e}"
    );
    let e = nonlinear_modal_analysis(
        &model,
        &NmaOptions {
            amplitude: AmplitudeRange::Modal {
                log10_start: -1.0,
                log10_end: -2.0,
            },
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(matches!(e, NmaError::InvalidAmplitudeRange { .. }));
    let e = nonlinear_modal_analysis(
        &model,
        &NmaOptions {
            amplitude: AmplitudeRange::Point {
                name: "tip".into(),
                start_m: 1e-3,
                end_m: 1e-2,
            },
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("'tip'") && e.to_string().contains("x"),
        "{e}"
    );

    // the spring breaks at |u| = 0.1: step size collapse with the branch so far
    let mut broken = model.clone();
    broken.nonlinear = vec![NonlinearElement {
        name: "breaking".into(),
        direction: DVector::from_element(1, 1.0),
        law: Arc::new(BreakingSpring),
    }];
    let opts = NmaOptions {
        harmonics: 3,
        amplitude: AmplitudeRange::Modal {
            log10_start: -3.0,
            log10_end: 0.0,
        },
        ..Default::default()
    };
    let e = nonlinear_modal_analysis(&broken, &opts).unwrap_err();
    match &e {
        NmaError::StepSizeCollapse {
            amplitude,
            step_size,
            dsmin,
            partial,
            ..
        } => {
            assert!(*amplitude < 0.1 && *amplitude > 0.03, "{amplitude}");
            assert!(step_size < dsmin);
            assert!(partial.branch.len() > 5);
            assert_eq!(partial.branch.last().unwrap().amplitude, *amplitude);
        }
        other => panic!("{other}"),
    }
    assert!(e.partial().is_some());
    assert!(e.to_string().contains("step"), "{e}");

    // Newton cannot converge with a zero iteration budget
    let mut opts2 = opts.clone();
    opts2.continuation.max_iterations = 0;
    opts2.continuation.tolerance = 1e-300;
    let e = nonlinear_modal_analysis(&model, &opts2).unwrap_err();
    assert!(matches!(e, NmaError::StartNotConverged { .. }), "{e}");
    assert!(e.to_string().contains("1e-3"), "{e}");
}

#[test]
fn measured_csv_becomes_a_table() {
    let csv = "# phase-resonant test\na, omega_rad_s, D, tip_re, tip_im\n1e-4, 356.0, 0.004, 1.9, 0.01\n2e-4, 357.5, 0.0041, 1.89, 0.012\n5e-4, 365.0, 0.0045, 1.85, 0.02\n";
    let t = table_from_measured_csv(csv, "tip").unwrap();
    assert_eq!(t.amplitude, vec![1e-4, 2e-4, 5e-4]);
    assert_eq!(t.omega_rad_s, vec![356.0, 357.5, 365.0]);
    assert_eq!(t.damping_ratio, vec![0.004, 0.0041, 0.0045]);
    assert_eq!(t.harmonics, 1);
    assert_eq!(t.points[0].name, "tip");
    assert_eq!(t.points[0].re[1], vec![0.0, 1.89]);
    assert_eq!(t.points[0].im[2], vec![0.0, 0.02]);
    let bad = csv.replace("2e-4, 357.5", "1e-4, 357.5");
    let e = table_from_measured_csv(&bad, "tip").unwrap_err();
    assert!(e.to_string().contains("line 4"), "{e}");
    let e = table_from_measured_csv(csv, "l3").unwrap_err();
    assert!(e.to_string().contains("phi_re or l3_re"), "{e}");
    let bad = csv.replace("365.0", "abc");
    assert!(table_from_measured_csv(&bad, "tip")
        .unwrap_err()
        .to_string()
        .contains("'abc'"));
}

// ---------------------------------------------------------------------------
// The paper's beam (Craig-Bampton reduced, 11 DOF)
// ---------------------------------------------------------------------------

use nlmode::structure::{modal_analysis, paper_structure, PaperStructureOptions};

fn paper_beam() -> nlmode::structure::PaperStructure {
    paper_structure(&PaperStructureOptions::default()).unwrap()
}

fn beam_opts(harmonics: usize, conservative: bool, log10_start: f64, log10_end: f64) -> NmaOptions {
    NmaOptions {
        harmonics,
        conservative,
        amplitude: AmplitudeRange::Modal {
            log10_start,
            log10_end,
        },
        continuation: ContinuationOptions {
            ds: 0.1,
            ..Default::default()
        },
        ..Default::default()
    }
}

#[test]
fn paper_beam_low_amplitude_limit_is_the_linear_mode() {
    let ps = paper_beam();
    let r = nonlinear_modal_analysis(&ps.model, &beam_opts(3, false, -7.0, -6.0)).unwrap();
    let b = &r.branch[0];
    assert_eq!(b.amplitude, 1e-7);
    // 356.2 rad/s (the paper prints 346 rad/s; DESIGN.md), CB vs full model
    assert!((b.omega_rad_s - 356.2).abs() < 0.05, "{}", b.omega_rad_s);
    assert!((b.omega_rad_s / ps.omega0_rad_s - 1.0).abs() < 1e-4);
    assert!(
        (b.damping_ratio / 0.004 - 1.0).abs() < 1e-4,
        "{}",
        b.damping_ratio
    );
    // against the structure module's independent linear modal analysis
    let mut lin = modal_analysis(&ps.model, 2).unwrap();
    let tip = ps
        .model
        .points
        .iter()
        .find(|p| p.name == "tip")
        .unwrap()
        .direction
        .clone();
    lin.align_signs(&tip);
    assert!((b.omega_rad_s / lin.omega_rad_s[0] - 1.0).abs() < 1e-6);
    assert!((b.damping_ratio / (0.5 * ps.damping_beta_s * lin.omega_rad_s[0]) - 1.0).abs() < 1e-6);
    let phi = lin.shape(0);
    let err: f64 = (0..phi.len())
        .map(|i| (b.coordinates[i][1] - nlmode::Complex64::new(phi[i], 0.0)).norm())
        .fold(0.0, f64::max);
    assert!(err < 1e-6 * phi.amax(), "{err}");
    // higher harmonics vanish in the linear limit
    for c in &b.coordinates {
        assert!(
            c[0].norm() < 1e-6 * phi.amax()
                && c[2].norm() < 1e-6 * phi.amax()
                && c[3].norm() < 1e-6 * phi.amax()
        );
    }
    // the named points carry the same shape
    let p = r.point_index("tip").unwrap();
    assert!((b.points[p][1].re - tip.dot(&phi)).abs() < 1e-6 * tip.dot(&phi));
    assert!(r.point_index("l3").is_some() && r.point_index("2l3").is_some());
}

#[test]
fn paper_beam_hardens_and_converges_in_the_harmonics() {
    let ps = paper_beam();
    let a_end = 2.5e-3f64;
    let mut omega = vec![];
    for h in [3, 7, 13] {
        let r =
            nonlinear_modal_analysis(&ps.model, &beam_opts(h, false, -6.0, a_end.log10())).unwrap();
        let last = r.branch.last().unwrap();
        assert!((last.amplitude / a_end - 1.0).abs() < 1e-12);
        // hardening: omega increases monotonically with a
        assert!(r
            .branch
            .windows(2)
            .all(|w| w[1].omega_rad_s >= w[0].omega_rad_s - 1e-9));
        assert!(last.omega_rad_s > 1.5 * r.linear_omega_rad_s);
        assert!(r.folds.is_empty());
        omega.push(last.omega_rad_s);
    }
    let (e3, e7) = ((omega[0] - omega[2]).abs(), (omega[1] - omega[2]).abs());
    assert!(e7 < 0.2 * e3, "omega(H=3,7,13) = {omega:?}");
    assert!(e3 < 1e-2 * omega[2], "omega(H=3,7,13) = {omega:?}");
}

#[test]
fn paper_beam_loop_is_detected_as_a_fold_in_both_branches() {
    let ps = paper_beam();
    let lin = modal_analysis(&ps.model, 2).unwrap();
    // 1:3 internal resonance with mode 2 (hardened by the tip spring as well)
    let band = (lin.omega_rad_s[1] / 3.0, 1.25 * lin.omega_rad_s[1] / 3.0);
    let mut first_folds = vec![];
    for conservative in [false, true] {
        let r = nonlinear_modal_analysis(
            &ps.model,
            &beam_opts(7, conservative, -6.0, 6e-3f64.log10()),
        );
        let r = r.unwrap();
        assert!(!r.folds.is_empty(), "conservative {conservative}");
        let f = r.first_fold().unwrap().clone();
        assert_eq!(f.kind, FoldKind::AmplitudeMaximum);
        assert!(
            f.omega_rad_s > band.0 && f.omega_rad_s < band.1,
            "{f:?} not in {band:?}"
        );
        if conservative {
            assert!(r.branch.iter().all(|b| b.damping_ratio.abs() < 1e-8));
            // the conservative branch runs into the 1:3 internal-resonance
            // branch (a -> 0, energy in harmonic 3) and is stopped there
            assert!(
                matches!(r.warnings.as_slice(), [NmaWarning::FundamentalLost { share, .. }] if *share < 0.005),
                "{:?}",
                r.warnings
            );
        } else {
            // damping rises along the loop (energy in mode 2, harmonic 3)
            let dmax = r.branch.iter().map(|b| b.damping_ratio).fold(0.0, f64::max);
            assert!(dmax > 5.0 * 0.004, "{dmax}");
            // the damped loop closes: the branch comes back and reaches the end
            assert_eq!(r.stop, Some(StopReason::ReachedEnd));
            assert_eq!(r.folds.len(), 2);
            assert_eq!(r.folds[1].kind, FoldKind::AmplitudeMinimum);
            let share = r
                .branch
                .iter()
                .map(|b| b.fundamental_energy_share)
                .fold(1.0, f64::min);
            assert!(share < 0.1, "{share}");
        }
        let t = r.to_table(TablePolicy::PrimaryBranch);
        assert_eq!(t.truncated_at_fold, Some(f.amplitude));
        assert_eq!(*t.amplitude.last().unwrap(), f.amplitude);
        assert!(t.amplitude.windows(2).all(|w| w[1] > w[0]));
        assert_eq!(t.points.len(), 3);
        assert_eq!(t.coordinates.len(), 11);
        first_folds.push(f);
    }
    // conservative and damped loops nearly coincide (D0 = 0.4 % is light)
    assert!(
        (first_folds[0].omega_rad_s / first_folds[1].omega_rad_s - 1.0).abs() < 0.02,
        "{first_folds:?}"
    );
}

#[test]
fn paper_beam_conservative_and_damped_backbones_nearly_coincide() {
    let ps = paper_beam();
    let a = 1e-3f64;
    let d = nonlinear_modal_analysis(&ps.model, &beam_opts(7, false, -6.0, a.log10())).unwrap();
    let c = nonlinear_modal_analysis(&ps.model, &beam_opts(7, true, -6.0, a.log10())).unwrap();
    let (bd, bc) = (d.branch.last().unwrap(), c.branch.last().unwrap());
    assert!(
        bd.omega_rad_s > 1.1 * d.linear_omega_rad_s,
        "nonlinear at a = 1e-3: {}",
        bd.omega_rad_s
    );
    assert!(
        (bd.omega_rad_s / bc.omega_rad_s - 1.0).abs() < 1e-4,
        "{} {}",
        bd.omega_rad_s,
        bc.omega_rad_s
    );
    assert!(bc.damping_ratio.abs() < 1e-10);
    assert_eq!(c.linear_damping_ratio, 0.0);
}

#[test]
fn options_deserialize_with_defaults() {
    let o: NmaOptions = serde_json::from_str(
        r#"{"harmonics": 3, "amplitude": {"point": {"name": "tip", "start_m": 1e-6, "end_m": 0.02}}, "continuation": {"ds": 0.05}}"#,
    )
    .unwrap();
    assert_eq!(o.harmonics, 3);
    assert_eq!(
        o.amplitude,
        AmplitudeRange::Point {
            name: "tip".into(),
            start_m: 1e-6,
            end_m: 0.02
        }
    );
    assert_eq!(o.continuation.ds, 0.05);
    assert_eq!(o.continuation.dsmin(), 0.01);
    assert_eq!(o.continuation.dsmax(), 0.25);
    assert_eq!(o.mode_index, 0);
    assert!(serde_json::from_str::<NmaOptions>(r#"{"harmonic": 3}"#).is_err());
}

#[test]
fn higher_mode_index_continues_that_mode() {
    let mut model = test_chain(0.0);
    model.nonlinear[0].law = Arc::new(CubicLaw { k3: 4e5, c3: 0.0 });
    let basis = ModalBasis::new(&model, false).unwrap();
    let opts = NmaOptions {
        harmonics: 3,
        mode_index: 2,
        amplitude: AmplitudeRange::Modal {
            log10_start: -5.0,
            log10_end: -1.0,
        },
        ..Default::default()
    };
    let r = nonlinear_modal_analysis(&model, &opts).unwrap();
    let b = &r.branch[0];
    assert!((b.omega_rad_s / basis.omega(2) - 1.0).abs() < 1e-8);
    assert!((b.damping_ratio / basis.damping_ratio(2) - 1.0).abs() < 1e-6);
    let l = r.branch.last().unwrap();
    assert!(
        l.omega_rad_s > b.omega_rad_s,
        "{} {} {} {:?} {:?} {:?}",
        l.omega_rad_s,
        l.amplitude,
        l.damping_ratio,
        r.stop,
        r.warnings,
        r.folds
    );
    for (i, c) in b.coordinates.iter().enumerate() {
        assert!((c[1].re - basis.phi[(i, 2)]).abs() < 1e-6, "{i}");
    }
}

#[test]
fn unreduced_beam_backbone_matches_the_craig_bampton_model() {
    // same analysis on the 198-DOF beam (condensed solver over all 198 modes)
    // and on the 11-DOF CB model
    let full = paper_structure(&PaperStructureOptions {
        cb_modes: None,
        ..Default::default()
    })
    .unwrap();
    let cb = paper_beam();
    let opts = beam_opts(3, false, -6.0, -3.0);
    let rf = nonlinear_modal_analysis(&full.model, &opts).unwrap();
    let rc = nonlinear_modal_analysis(&cb.model, &opts).unwrap();
    let bf = &rf.branch[0];
    // at a = 1e-6 the first-order single-mode backbone
    // omega^2 = omega0^2 + 3/4 k3 phi_tip^4 a^2 holds (the shift is 2e-7)
    let phi_tip = bf.points[rf.point_index("tip").unwrap()][1].re;
    let expected = (full.omega0_rad_s.powi(2) + 0.75 * 6e9 * phi_tip.powi(4) * 1e-12).sqrt();
    assert!(
        (bf.omega_rad_s / expected - 1.0).abs() < 1e-9,
        "{} {expected}",
        bf.omega_rad_s
    );
    assert!((bf.omega_rad_s / full.omega0_rad_s - 1.0) > 1e-7);
    // stiffness-proportional damping: 2 D omega = beta omega0^2 = 2 D0 omega0
    let dw = bf.damping_ratio * bf.omega_rad_s / (0.004 * full.omega0_rad_s) - 1.0;
    // (Phi^T C Phi on the stiff FE matrices rounds at ~ eps omega_max^2/omega_1^2)
    assert!(
        dw.abs() < 1e-8,
        "{dw:e} {} {}",
        rf.linear_damping_ratio,
        rf.linear_omega_rad_s
    );
    let (lf, lc) = (rf.branch.last().unwrap(), rc.branch.last().unwrap());
    assert_eq!(lf.amplitude, 1e-3);
    assert!(lf.omega_rad_s > 1.1 * bf.omega_rad_s);
    // CB with 10 fixed-interface modes is accurate to well below 0.1 %
    assert!(
        (lf.omega_rad_s / lc.omega_rad_s - 1.0).abs() < 1e-3,
        "{} {}",
        lf.omega_rad_s,
        lc.omega_rad_s
    );
    assert!((lf.damping_ratio / lc.damping_ratio - 1.0).abs() < 1e-2);
    let (pf, pc) = (
        rf.point_index("tip").unwrap(),
        rc.point_index("tip").unwrap(),
    );
    assert!((lf.points[pf][1] - lc.points[pc][1]).norm() < 1e-3 * lc.points[pc][1].norm());
}

#[test]
fn paper_beam_conservative_small_steps_find_the_1_to_5_loop() {
    // with small steps the conservative branch resolves the thin 1:5 internal
    // resonance with mode 2 (the paper's first loop), which the damped branch
    // does not have; the branch then follows the resonance towards a -> 0
    // (energy in harmonic 5) and is stopped with a warning
    let ps = paper_beam();
    let lin = modal_analysis(&ps.model, 2).unwrap();
    let mut opts = beam_opts(7, true, -6.0, 6e-3f64.log10());
    opts.continuation = ContinuationOptions {
        ds: 0.005,
        dsmax: Some(0.01),
        ..Default::default()
    };
    opts.store_coordinates = false;
    let r = nonlinear_modal_analysis(&ps.model, &opts).unwrap();
    let f = r.first_fold().expect("a fold").clone();
    assert_eq!(f.kind, FoldKind::AmplitudeMaximum);
    let w5 = lin.omega_rad_s[1] / 5.0;
    assert!(
        f.omega_rad_s > w5 && f.omega_rad_s < 1.05 * w5,
        "{f:?}, omega2/5 = {w5}"
    );
    assert!(
        matches!(r.warnings.as_slice(), [NmaWarning::FundamentalLost { .. }]),
        "{:?}",
        r.warnings
    );
    let t = r.to_table(TablePolicy::PrimaryBranch);
    assert_eq!(t.truncated_at_fold, Some(f.amplitude));
    // the damped branch has no such loop at this amplitude
    let mut opts_d = opts.clone();
    opts_d.conservative = false;
    opts_d.amplitude = AmplitudeRange::Modal {
        log10_start: -6.0,
        log10_end: 2e-3f64.log10(),
    };
    let rd = nonlinear_modal_analysis(&ps.model, &opts_d).unwrap();
    assert!(rd.folds.is_empty(), "{:?}", rd.folds);
}

// ---------------------------------------------------------------------------
// Continuation through internal resonances (harmonic-energy normalisation)
// ---------------------------------------------------------------------------

/// The loops of a branch: (internal resonance, index of the amplitude maximum,
/// index of the following amplitude minimum).
fn loops(r: &NmaResult) -> Vec<(InternalResonance, usize, usize)> {
    let mut out = vec![];
    for (i, f) in r.folds.iter().enumerate() {
        if let Some(ir) = f.internal_resonance {
            let min = r.folds[i + 1..]
                .iter()
                .find(|g| g.kind == FoldKind::AmplitudeMinimum)
                .map(|g| g.index)
                .unwrap_or(r.branch.len() - 1);
            out.push((ir, f.index, min));
        }
    }
    out
}

/// Every loop: `|q_tip,1|` has a local maximum and then dips below 20 % of it,
/// at the frequency where `n omega` meets the participating mode's (hardened)
/// frequency.
fn check_loop(r: &NmaResult, lin: &[f64], ir: &InternalResonance, start: usize, end: usize) {
    let tip = r.point_fundamental_amplitude("tip").unwrap();
    let peak = tip[start.saturating_sub(2)..=(start + 2).min(tip.len() - 1)]
        .iter()
        .cloned()
        .fold(0.0, f64::max);
    let dip = tip[start..=end]
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min);
    assert!(dip < 0.2 * peak, "{ir}: dip {dip:e}, peak {peak:e}");
    let ratio = ir.harmonic as f64 * ir.omega_rad_s / lin[ir.mode_index];
    assert!(
        ratio > 1.0 && ratio < 1.1,
        "{ir}: n omega / omega_k = {ratio}"
    );
}

#[test]
fn conservative_paper_backbone_passes_the_internal_resonance_loops() {
    let ps = paper_beam();
    let lin = modal_analysis(&ps.model, 4).unwrap().omega_rad_s;
    let opts = BackboneOptions::default().nma_options(true);
    let r = nonlinear_modal_analysis(&ps.model, &opts).unwrap_or_else(|e| panic!("{e}"));
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    let last = r.branch.last().unwrap();
    assert!(last.omega_rad_s >= 2.7 * r.linear_omega_rad_s);
    let l = loops(&r);
    let found: Vec<(usize, usize)> = l
        .iter()
        .map(|(ir, _, _)| (ir.harmonic, ir.mode_index))
        .collect();
    // the paper's figure: 1:5 with mode 2, 1:9 with mode 3, 1:3 with mode 2
    assert_eq!(&found[..3], &[(5, 1), (9, 2), (3, 1)], "{found:?}");
    for (ir, s, e) in &l[..3] {
        check_loop(&r, &lin, ir, *s, *e);
        assert_eq!(
            ir.to_string().split(" (").next().unwrap(),
            format!("1:{} with mode {}", ir.harmonic, ir.mode_index + 1)
        );
    }
    assert!(r.branch.iter().all(|b| b.damping_ratio.abs() < 1e-8));
    // consecutive points never jump in frequency (no loop stepped over)
    let dmax = r
        .branch
        .windows(2)
        .map(|w| (w[1].omega_rad_s - w[0].omega_rad_s).abs() / r.linear_omega_rad_s)
        .fold(0.0, f64::max);
    assert!(dmax < 0.03, "{dmax}");
}

#[test]
fn damped_paper_backbone_keeps_only_the_1_3_loop_and_traces_it_back() {
    let ps = paper_beam();
    let lin = modal_analysis(&ps.model, 4).unwrap().omega_rad_s;
    let opts = BackboneOptions::default().nma_options(false);
    let r = nonlinear_modal_analysis(&ps.model, &opts).unwrap_or_else(|e| panic!("{e}"));
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    let l = loops(&r);
    assert_eq!(l.len(), 1, "{:?}", r.folds);
    let (ir, s, e) = &l[0];
    assert_eq!((ir.harmonic, ir.mode_index), (3, 1));
    // traced to its amplitude minimum and back: the amplitude rises after it
    assert!(*e < r.branch.len() - 1);
    let a_min = r.branch[*e].amplitude;
    assert!(r.branch[e + 1..].iter().any(|b| b.amplitude > 2.0 * a_min));
    assert!(r.branch.last().unwrap().omega_rad_s >= 2.7 * r.linear_omega_rad_s);
    let ratio = ir.harmonic as f64 * ir.omega_rad_s / lin[ir.mode_index];
    assert!(ratio > 1.0 && ratio < 1.1, "{ir}: {ratio}");
    let _ = s;
    // the primary-branch table policy is unchanged: it ends at the first fold
    let t = r.to_table(TablePolicy::PrimaryBranch);
    assert_eq!(t.truncated_at_fold, Some(r.first_fold().unwrap().amplitude));
}

#[test]
fn two_dof_1_3_internal_resonance_loop_agrees_with_direct_hb_solves() {
    use nlmode::nma::problems::two_dof_internal_resonance;
    // omega_2 = 3.3 omega_1: the hardening mode 1 meets 3 omega = omega_2(a)
    // at omega ~ 1.106 rad/s (an exact 3:1 ratio is degenerate at a -> 0: the
    // third harmonic of mode 2 is then undetermined in the linear limit)
    let model = two_dof_internal_resonance(3.3, 1.0);
    let mut opts = NmaOptions {
        harmonics: 5,
        conservative: true,
        amplitude: AmplitudeRange::Modal {
            log10_start: -3.0,
            log10_end: 0.5,
        },
        normalisation: Normalisation::HarmonicEnergy,
        ..Default::default()
    };
    let b = BackboneOptions::default().nma_options(true).continuation;
    opts.continuation = ContinuationOptions {
        tolerance: 1e-12,
        ..b
    };
    let r = nonlinear_modal_analysis(&model, &opts).unwrap();
    assert_eq!(r.stop, Some(StopReason::ReachedEnd));
    let l = loops(&r);
    assert_eq!(l.len(), 1, "{:?}", r.folds);
    let (ir, s, e) = &l[0];
    assert_eq!((ir.harmonic, ir.mode_index), (3, 1), "{ir}");
    assert!(
        ir.min_fundamental_share < 1e-2 && ir.max_share > 0.99,
        "{ir}"
    );
    assert!((3.0 * ir.omega_rad_s / 3.3 - 1.0).abs() < 0.02, "{ir}");
    let x1 = r.point_fundamental_amplitude("x1").unwrap();
    assert!(x1[*s..=*e].iter().cloned().fold(f64::INFINITY, f64::min) < 0.2 * x1[*s]);
    // direct HB solves (paper normalisation, fixed a) at every 7th point
    let basis = Arc::new(ModalBasis::new(&model, true).unwrap());
    let fixed = NmaOptions {
        normalisation: Normalisation::Fundamental,
        continuation: ContinuationOptions {
            tolerance: 1e-12,
            max_iterations: 30,
            ..Default::default()
        },
        ..opts.clone()
    };
    let mut checked = 0;
    for b in r.branch.iter().step_by(7) {
        let d = solve_at_amplitude(&model, basis.clone(), &fixed, b.amplitude, b).unwrap();
        assert!(
            (d.omega_rad_s / b.omega_rad_s - 1.0).abs() < 1e-9,
            "a {}: {} {}",
            b.amplitude,
            d.omega_rad_s,
            b.omega_rad_s
        );
        let scale = b
            .coordinates
            .iter()
            .flatten()
            .map(|c| c.norm())
            .fold(0.0, f64::max);
        for (pd, pb) in d
            .coordinates
            .iter()
            .flatten()
            .zip(b.coordinates.iter().flatten())
        {
            assert!(
                (pd - pb).norm() < 1e-9 * scale,
                "a {}: {pd} {pb}",
                b.amplitude
            );
        }
        checked += 1;
    }
    assert!(checked > 20, "{checked}");
}

#[test]
fn refined_table_meets_its_stated_accuracy_against_fresh_hb_solves() {
    let ps = paper_beam();
    let opts = NmaOptions::default();
    let basis = Arc::new(ModalBasis::new(&ps.model, false).unwrap());
    let r = nonlinear_modal_analysis_with_basis(&ps.model, basis.clone(), &opts).unwrap();
    let coarse = r.to_table(TablePolicy::PrimaryBranch);
    let t0 = std::time::Instant::now();
    let t = r
        .refined_table(
            &ps.model,
            basis.clone(),
            &opts,
            TablePolicy::PrimaryBranch,
            &RefineOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    let acc = t.accuracy.clone().unwrap();
    println!(
        "coarse {} points, refined {} points, {} checks, {:?}, {:?}",
        coarse.amplitude.len(),
        t.amplitude.len(),
        acc.checks,
        acc,
        t0.elapsed()
    );
    assert!(!acc.capped);
    assert!(
        acc.omega_rel <= 1e-5 && acc.damping_rel <= 1e-4 && acc.shape_rel <= 1e-4,
        "{acc:?}"
    );
    assert_eq!(t.truncated_at_fold, coarse.truncated_at_fold);
    assert!(t.description.contains("refined"));
    // the file format keeps the accuracy; old files without it still load
    let back = ModalTable::from_json(&t.to_json()).unwrap();
    assert_eq!(back.accuracy, t.accuracy);
    let old = ModalTable::from_json(&coarse.to_json().replace(",\"accuracy\":null", "")).unwrap();
    assert_eq!(old.accuracy, None);
    // 50 pseudo-random amplitudes over the tabulated range: fresh HB solves
    let interp = t.interpolator().unwrap();
    let (a0, a1) = interp.amplitude_range();
    let u = pseudo_random(50, 7);
    let fixed = NmaOptions {
        points: r.point_names.clone(),
        ..opts.clone()
    };
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..50 {
        let a = a0 * (a1 / a0).powf(u[k] + 0.5);
        let j = t
            .amplitude
            .partition_point(|&x| x < a)
            .clamp(1, t.amplitude.len() - 1);
        // guess: the refined table's nearest node
        let j = if a - t.amplitude[j - 1] < t.amplitude[j] - a {
            j - 1
        } else {
            j
        };
        let guess = BranchPoint {
            amplitude: t.amplitude[j],
            omega_rad_s: t.omega_rad_s[j],
            damping_ratio: t.damping_ratio[j],
            coordinates: t
                .coordinates
                .iter()
                .map(|c| {
                    c.re[j]
                        .iter()
                        .zip(&c.im[j])
                        .map(|(&re, &im)| nlmode::Complex64::new(re, im))
                        .collect()
                })
                .collect(),
            ..r.branch[0].clone()
        };
        let sol = solve_at_amplitude(&ps.model, basis.clone(), &fixed, a, &guess)
            .unwrap_or_else(|e| panic!("{e}"));
        let e = table_errors(&interp, &sol).unwrap();
        worst = (worst.0.max(e.0), worst.1.max(e.1), worst.2.max(e.2));
    }
    println!("50 random amplitudes: {worst:?}");
    assert!(
        worst.0 <= 1e-5 && worst.1 <= 1e-4 && worst.2 <= 1e-4,
        "{worst:?}"
    );
    // the converged values of the issue (H = 13, damped)
    for (a, w, d) in [(1e-3, 429.3106, 3.3854e-3), (2.5e-3, 641.2458, 4.9818e-3)] {
        let p = interp.eval(a).unwrap();
        println!("a = {a}: omega {} D {}", p.omega_rad_s, p.damping_ratio);
        assert!(
            (p.omega_rad_s - w).abs() < 1e-4 * 1.0 + 1e-5 * w,
            "{}",
            p.omega_rad_s
        );
        assert!(
            (p.damping_ratio / d - 1.0).abs() < 2e-4,
            "{}",
            p.damping_ratio
        );
    }
}

/// The damped paper-beam table as `host` makes it: tip amplitudes 1e-7 ..
/// 0.02 m (beyond the first fold), every named point, refined with the
/// default [`RefineOptions`].
fn host_like_refined_table(harmonics: usize) -> (NmaResult, ModalTable) {
    let ps = paper_beam();
    let basis = Arc::new(ModalBasis::new(&ps.model, false).unwrap());
    let opts = NmaOptions {
        harmonics,
        amplitude: AmplitudeRange::Point {
            name: "tip".into(),
            start_m: 1e-7,
            end_m: 0.02,
        },
        conservative: false,
        points: ps.model.points.iter().map(|p| p.name.clone()).collect(),
        store_coordinates: true,
        ..Default::default()
    };
    let r = nonlinear_modal_analysis_with_basis(&ps.model, basis.clone(), &opts).unwrap();
    let t = r
        .refined_table(
            &ps.model,
            basis,
            &opts,
            TablePolicy::PrimaryBranch,
            &RefineOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    (r, t)
}

#[test]
fn refined_table_ends_a_stated_margin_before_the_fold_and_meets_its_accuracy() {
    let (r, t) = host_like_refined_table(13);
    let acc = t.accuracy.clone().unwrap();
    let a_f = t
        .truncated_at_fold
        .expect("the tip range passes the first fold");
    let margin = RefineOptions::default().fold_margin;
    println!(
        "fold {a_f:e}, table {} points from {}, last a = {:e}, {acc:?}",
        t.amplitude.len(),
        r.branch.len(),
        t.amplitude.last().unwrap()
    );
    assert_eq!(acc.fold_margin, Some(margin));
    let last = *t.amplitude.last().unwrap();
    assert!(
        (last / ((1.0 - margin) * a_f) - 1.0).abs() < 1e-12,
        "{last} vs {a_f}"
    );
    assert!(t.description.contains("times the first fold"));
    // at the fold itself the targets are out of reach; a margin before it they are met
    assert!(!acc.capped, "{acc:?}");
    assert!(
        acc.omega_rel <= 1e-5 && acc.damping_rel <= 1e-4 && acc.shape_rel <= 1e-4,
        "{acc:?}"
    );
    // a margin outside [0, 1) is a typed error
    let ps = paper_beam();
    let basis = Arc::new(ModalBasis::new(&ps.model, false).unwrap());
    let opts = NmaOptions {
        points: r.point_names.clone(),
        store_coordinates: true,
        ..Default::default()
    };
    let bad = RefineOptions {
        fold_margin: 1.5,
        ..Default::default()
    };
    let e = r
        .refined_table(&ps.model, basis, &opts, TablePolicy::PrimaryBranch, &bad)
        .unwrap_err();
    assert!(matches!(e, NmaError::InvalidFoldMargin { .. }), "{e}");
}

/// Largest (omega, D, shape) differences of the table `t` from `t13` at 50
/// log-spaced amplitudes from the first table amplitude to `a_max`; shape
/// harmonics missing in `t` count fully.
fn table_difference(t: &ModalTable, t13: &ModalTable, a_max: f64) -> (f64, f64, f64) {
    let (i, i13) = (t.interpolator().unwrap(), t13.interpolator().unwrap());
    let a0 = t13.amplitude[0].max(t.amplitude[0]);
    let mut w = (0.0f64, 0.0f64, 0.0f64);
    let zero = nlmode::Complex64::new(0.0, 0.0);
    for k in 0..50 {
        let a = a0 * (a_max / a0).powf(k as f64 / 49.0);
        let (p, q) = (i13.eval(a).unwrap(), i.eval(a).unwrap());
        w.0 = w.0.max((q.omega_rad_s / p.omega_rad_s - 1.0).abs());
        w.1 = w.1.max((q.damping_ratio / p.damping_ratio - 1.0).abs());
        for pt in 0..t13.points.len() {
            let mut x = vec![zero; t13.harmonics + 1];
            let mut y = vec![zero; t13.harmonics + 1];
            i13.shape_all(pt, a, &mut x).unwrap();
            let j = t
                .points
                .iter()
                .position(|s| s.name == t13.points[pt].name)
                .unwrap();
            i.shape_all(j, a, &mut y[..t.harmonics + 1]).unwrap();
            let scale = x.iter().map(|c| c.norm()).fold(0.0, f64::max);
            for (x, y) in x.iter().zip(&y) {
                w.2 = w.2.max((x - y).norm() / scale);
            }
        }
    }
    w
}

#[test]
fn sweep_table_harmonics_agree_with_h13_within_the_refined_accuracy() {
    let (_, t13) = host_like_refined_table(13);
    let a_max = SWEEP_TABLE_MAX_AMPLITUDE;
    assert!(a_max < *t13.amplitude.last().unwrap());
    let acc = RefineOptions::default();
    let h = SWEEP_TABLE_HARMONICS;
    let (_, t) = host_like_refined_table(h);
    let d = table_difference(&t, &t13, a_max);
    println!(
        "H = {h} vs H = 13 up to a = {a_max:e}: omega {:.2e}, D {:.2e}, shapes {:.2e}",
        d.0, d.1, d.2
    );
    assert!(
        d.0 <= acc.omega_rel && d.1 <= acc.rel && d.2 <= acc.rel,
        "{d:?}"
    );
    // the smallest such H: the next lower odd order (cubic stiffness: odd harmonics) misses
    let (_, t) = host_like_refined_table(h - 2);
    let d = table_difference(&t, &t13, a_max);
    println!(
        "H = {} vs H = 13 up to a = {a_max:e}: omega {:.2e}, D {:.2e}, shapes {:.2e}",
        h - 2,
        d.0,
        d.1,
        d.2
    );
    assert!(
        d.0 > acc.omega_rel || d.1 > acc.rel || d.2 > acc.rel,
        "{d:?}"
    );
}

/// `stop_at_first_fold` ends the continuation one point past the first fold of
/// the primary branch; the refined table uses only the points before it, so it
/// is the same table (bit for bit, but for the branch count in its
/// description) as from the whole branch, loops included.
#[test]
fn stopping_at_the_first_fold_gives_the_same_refined_table() {
    let ps = paper_beam();
    let basis = Arc::new(ModalBasis::new(&ps.model, false).unwrap());
    let whole = NmaOptions {
        harmonics: 7,
        amplitude: AmplitudeRange::Point {
            name: "tip".into(),
            start_m: 1e-7,
            end_m: 0.02,
        },
        points: ps.model.points.iter().map(|p| p.name.clone()).collect(),
        ..Default::default()
    };
    let early = NmaOptions {
        stop_at_first_fold: true,
        ..whole.clone()
    };
    let table = |opts: &NmaOptions| {
        let r = nonlinear_modal_analysis_with_basis(&ps.model, basis.clone(), opts).unwrap();
        let mut t = r
            .refined_table(
                &ps.model,
                basis.clone(),
                opts,
                TablePolicy::PrimaryBranch,
                &RefineOptions::default(),
            )
            .unwrap_or_else(|e| panic!("{e}"));
        t.description.clear();
        (r, t)
    };
    let (rw, tw) = table(&whole);
    let (re, te) = table(&early);
    let (iw, fw) = rw.table_indices(TablePolicy::PrimaryBranch);
    println!(
        "whole branch {} points, stopped {} points, primary branch {} points, fold {fw:?}",
        rw.branch.len(),
        re.branch.len(),
        iw.len()
    );
    assert!(fw.is_some(), "the tip range passes the first fold");
    // one point past the fold, nothing more
    assert_eq!(re.branch.len(), iw.len() + 1);
    assert!(rw.branch.len() > re.branch.len() + 10);
    assert_eq!(re.table_indices(TablePolicy::PrimaryBranch), (iw, fw));
    assert_eq!(
        serde_json::to_string(&te).unwrap(),
        serde_json::to_string(&tw).unwrap()
    );
}

#[test]
fn paper_table_h7_writes_no_new_accuracy_fields() {
    // the default scenario's modal_table.json stays byte for byte: the
    // accuracy fields added for issue 22 are written only when set
    let (_, t) = host_like_refined_table(SWEEP_TABLE_HARMONICS);
    let acc = t.accuracy.clone().unwrap();
    eprintln!("paper H7 table: {} points, {:?}", t.amplitude.len(), acc);
    // no missed target, no discontinuity; the highest harmonic's share near
    // the fold (above the sweeps' range) is reported but not written
    assert!(acc.omega_worst_amplitude.is_none() && acc.discontinuity.is_none());
    assert!(acc.highest_harmonic_share.unwrap() < 3e-3);
    assert!(acc.highest_harmonic_share_amplitude.unwrap() > SWEEP_TABLE_MAX_AMPLITUDE);
    let json = t.to_json();
    for key in ["worst_amplitude", "discontinuity", "highest_harmonic_share"] {
        assert!(!json.contains(key), "{key}");
    }
}
