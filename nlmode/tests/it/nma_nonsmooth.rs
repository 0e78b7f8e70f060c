//! Nonlinear modes through non-smooth regimes (issue 22): friction through full
//! slip, regularised friction far beyond saturation, contact, and a beam
//! crossing an internal resonance; answers known independently of the solver
//! (closed-form describing function, a fine-sampled residual with its own
//! friction march, fresh HB solves). `cargo test -p nlmode --test it nma_nonsmooth`.
use nlmode::nma::modal_basis::ModalBasis;
use nlmode::nma::problems::nlvib::{
    jenkins_describing_function, jenkins_oscillator, nlvib_cantilever_cubic,
    nlvib_friction_contact_chain, nlvib_tanh_friction_2dof,
};
use nlmode::nma::*;
use nlmode::Complex64;
use std::sync::Arc;

/// Single-DOF Jenkins oscillator: m = 1 kg, k = 1 N/m, k_t = 9 N/m (stick
/// omega = sqrt(10) rad/s, full slip 1 rad/s), F_s = 0.9 N (x_s = 0.1 m),
/// light viscous damping c = 0.002 N s/m.
const M: f64 = 1.0;
const K: f64 = 1.0;
const KT: f64 = 9.0;
const FS: f64 = 0.9;
const C: f64 = 0.002;

fn jenkins_opts(harmonics: usize, log10_end: f64) -> NmaOptions {
    NmaOptions {
        harmonics,
        amplitude: AmplitudeRange::Modal {
            log10_start: -3.0,
            log10_end,
        },
        ..Default::default()
    }
}

/// The EPMC at H = 1 in closed form: `omega^2 = (k + c_J / x) / m`,
/// `D = (c omega x - s_J) / (2 omega^2 m x)` with the describing function
/// `(c_J, s_J)` of the Jenkins element at displacement amplitude `x`.
fn jenkins_h1(x: f64) -> (f64, f64) {
    let (cj, sj) = jenkins_describing_function(KT, FS, x);
    let w2 = (K + cj / x) / M;
    let w = w2.sqrt();
    (w, (C * w * x - sj) / (2.0 * w2 * M * x))
}

#[test]
fn jenkins_h1_backbone_is_the_describing_function_through_full_slip() {
    let model = jenkins_oscillator(M, C, K, KT, FS).unwrap();
    // x from 0.001 to 100 x_s = 10 m
    let r = nonlinear_modal_analysis(&model, &jenkins_opts(1, 1.0)).unwrap();
    assert_eq!(r.stop, Some(StopReason::ReachedEnd), "{:?}", r.warnings);
    let mut d_max: f64 = 0.0;
    let mut worst = (0.0f64, 0.0f64);
    for b in &r.branch {
        let x = b.amplitude / M.sqrt();
        let (w, d) = jenkins_h1(x);
        worst.0 = worst.0.max((b.omega_rad_s / w - 1.0).abs());
        worst.1 = worst.1.max((b.damping_ratio - d).abs() / d);
        d_max = d_max.max(b.damping_ratio);
    }
    // the AFT integrates the loop exactly between its located transitions:
    // the describing function to rounding (measured 2e-15 / 5e-13)
    eprintln!(
        "jenkins H=1: {} points, omega {:e}, D {:e}, D max {d_max}",
        r.branch.len(),
        worst.0,
        worst.1
    );
    assert!(
        worst.0 < 1e-9 && worst.1 < 1e-8,
        "omega {:e}, D {:e}",
        worst.0,
        worst.1
    );
    assert!(d_max > 0.3, "full slip reaches D = {d_max}");
    let last = r.branch.last().unwrap();
    assert!(
        (last.omega_rad_s - 1.0).abs() < 0.05,
        "full slip: omega -> sqrt(k/m)"
    );
    assert!(r.folds.is_empty(), "{:?}", r.folds);
}

/// The EPMC residual of a branch point evaluated independently of the
/// production AFT: the motion synthesised at `n` instants, the Jenkins force
/// marched with its own clamp rule (two periods, second recorded), harmonics by
/// the rectangle rule; returned relative to `k |Q_1|`.
fn jenkins_residual_fine(b: &BranchPoint, harmonics: usize, n: usize) -> f64 {
    let q: Vec<Complex64> = b.coordinates[0].iter().map(|c| c * b.amplitude).collect();
    let tau = |t: usize| 2.0 * std::f64::consts::PI * t as f64 / n as f64;
    let u = |t: usize| {
        q.iter()
            .enumerate()
            .map(|(h, c)| (c * Complex64::from_polar(1.0, h as f64 * tau(t))).re)
            .sum::<f64>()
    };
    let us: Vec<f64> = (0..n).map(u).collect();
    let mut w = q[0].re; // slider at the mean
    let mut f = vec![0.0; n];
    for pass in 0..2 {
        for t in 0..n {
            let trial = KT * (us[t] - w);
            let ft = trial.clamp(-FS, FS);
            w = us[t] - ft / KT;
            if pass == 1 {
                f[t] = ft;
            }
        }
    }
    let (om, d) = (b.omega_rad_s, b.damping_ratio);
    let mut r2 = 0.0;
    for (h, qh) in q[..=harmonics].iter().enumerate() {
        let fh: Complex64 = f
            .iter()
            .enumerate()
            .map(|(t, ft)| ft * Complex64::from_polar(1.0, -(h as f64) * tau(t)))
            .sum::<Complex64>()
            * if h == 0 { 1.0 } else { 2.0 }
            / n as f64;
        let nh = h as f64;
        let lin = Complex64::new(K - nh * nh * om * om * M, nh * om * (C - 2.0 * d * om * M));
        r2 += (lin * qh + fh).norm_sqr();
    }
    r2.sqrt() / (K * q[1].norm())
}

#[test]
fn jenkins_h7_branch_solves_a_fine_sampled_independent_residual() {
    let model = jenkins_oscillator(M, C, K, KT, FS).unwrap();
    let h = 7;
    let r = nonlinear_modal_analysis(&model, &jenkins_opts(h, 1.0)).unwrap();
    assert_eq!(r.stop, Some(StopReason::ReachedEnd), "{:?}", r.warnings);
    let worst = r
        .branch
        .iter()
        .map(|b| jenkins_residual_fine(b, h, 20_000))
        .fold(0.0, f64::max);
    // the production AFT integrates the loop exactly; the fine-sampled check
    // differs by its own sampling error of a loop with corners, O(1/n)
    eprintln!(
        "jenkins H=7: {} points, worst residual {worst:e}",
        r.branch.len()
    );
    assert!(worst < 1e-5, "worst relative residual {worst:e}");
    let d_max = r.branch.iter().map(|b| b.damping_ratio).fold(0.0, f64::max);
    assert!(d_max > 0.3, "{d_max}");
}

/// The first fundamental amplitude `|q_{p,1}|` [m] of point `p` at every branch point.
fn point_amp(r: &NmaResult, p: &str) -> Vec<f64> {
    r.point_fundamental_amplitude(p).unwrap()
}

#[test]
fn nlvib_tanh_friction_2dof_continues_far_beyond_saturation() {
    // NLvib example 05 at its H = 21: stick (q1 held by friction) to 100x the
    // saturation displacement
    let model = nlvib_tanh_friction_2dof();
    let opts = NmaOptions {
        harmonics: 21,
        amplitude: AmplitudeRange::Modal {
            log10_start: -1.5,
            log10_end: 1.0,
        },
        ..Default::default()
    };
    let r = nonlinear_modal_analysis(&model, &opts);
    match &r {
        Ok(r) => eprintln!(
            "tanh: {} points, stop {:?}, q1 up to {:e}, warnings {:?}, folds {:?}",
            r.branch.len(),
            r.stop,
            point_amp(r, "q1").last().unwrap(),
            r.warnings,
            r.folds.len()
        ),
        Err(e) => eprintln!("tanh: {e}"),
    }
    let r = r.unwrap();
    assert_eq!(r.stop, Some(StopReason::ReachedEnd));
    assert!(r.folds.iter().all(|f| f.internal_resonance.is_none()));
    // stick at the start (q1 held by the friction: the complex-mode start),
    // 100x the saturation displacement F_s / k_12 = 0.125 m at the end
    let (q1, q2) = (point_amp(&r, "q1"), point_amp(&r, "q2"));
    assert!(q1[0] < 0.05 * q2[0], "{} {}", q1[0], q2[0]);
    assert!(*q1.last().unwrap() > 100.0 * 5.0 / 40.0);
    // a continuous backbone: no fold, no jump of omega between points
    assert!(r.folds.is_empty(), "{:?}", r.folds);
    for w in r.branch.windows(2) {
        assert!((w[1].omega_rad_s / w[0].omega_rad_s - 1.0).abs() < 0.01);
    }
}

#[test]
fn nlvib_friction_contact_chain_passes_full_slip() {
    use nlmode::structure::{ElasticDryFriction, InitialSlider};
    // both stuck-slider conventions: the slider at the mean (default) and at
    // zero (NLvib's); with zero the onset of full slip of the grounded element
    // is a corner where the branch folds back (passed by the corner turn)
    for slider in [InitialSlider::Mean, InitialSlider::Zero] {
        let mut model = nlvib_friction_contact_chain().unwrap();
        for e in model.nonlinear.iter_mut() {
            if e.law.hysteresis().is_some() {
                e.law = Arc::new(
                    ElasticDryFriction::new(20.0, 1.0)
                        .unwrap()
                        .with_initial_slider(slider),
                );
            }
        }
        let opts = NmaOptions {
            harmonics: 7,
            amplitude: AmplitudeRange::Modal {
                log10_start: -2.0,
                log10_end: 1.0,
            },
            ..Default::default()
        };
        let r = nonlinear_modal_analysis(&model, &opts);
        match &r {
            Ok(r) => eprintln!(
                "chain ({slider:?}): {} points, stop {:?}, D max {}, warnings {:?}",
                r.branch.len(),
                r.stop,
                r.branch.iter().map(|b| b.damping_ratio).fold(0.0, f64::max),
                r.warnings
            ),
            Err(e) => eprintln!("chain ({slider:?}): {e}"),
        }
        let r = r.unwrap();
        assert_eq!(r.stop, Some(StopReason::ReachedEnd));
        let d_max = r.branch.iter().map(|b| b.damping_ratio).fold(0.0, f64::max);
        assert!(d_max > 0.3, "{d_max}");
        // the loops of a while D climbs are no internal resonances: mode 2 is
        // in the stick mode's shape from the start
        assert!(
            r.folds.iter().all(|f| f.internal_resonance.is_none()),
            "{:?}",
            r.folds
        );
    }
}

#[test]
fn nlvib_cantilever_table_never_jumps_and_meets_its_accuracy() {
    let model = nlvib_cantilever_cubic(0.004).unwrap();
    let opts = NmaOptions {
        harmonics: 5,
        amplitude: AmplitudeRange::Modal {
            log10_start: -5.0,
            log10_end: -1.5,
        },
        stop_at_first_fold: true,
        ..Default::default()
    };
    let basis = Arc::new(ModalBasis::new(&model, false).unwrap());
    let r = nonlinear_modal_analysis_with_basis(&model, basis.clone(), &opts);
    let r = match r {
        Ok(r) => r,
        Err(e) => {
            eprintln!("beam: {e}");
            e.partial().unwrap().clone()
        }
    };
    eprintln!(
        "beam: {} points, stop {:?}, folds {:?}, discontinuity {:?}",
        r.branch.len(),
        r.stop,
        r.folds.iter().map(|f| f.amplitude).collect::<Vec<_>>(),
        r.branch_discontinuity(TablePolicy::PrimaryBranch)
    );
    let t = r
        .refined_table(
            &model,
            basis.clone(),
            &opts,
            TablePolicy::PrimaryBranch,
            &RefineOptions::default(),
        )
        .unwrap();
    let acc = t.accuracy.clone().unwrap();
    eprintln!(
        "beam table: {} points, {:?}, warnings {:?}",
        t.amplitude.len(),
        acc,
        acc.warnings()
    );
    assert!(!acc.capped || acc.discontinuity.is_some());
    // the stated accuracy against fresh HB solves at pseudo-random amplitudes
    // (the refinement's midpoint checks underestimate an interval's largest
    // error: 2x the target)
    let interp = t.interpolator().unwrap();
    let fixed = NmaOptions {
        points: r.point_names.clone(),
        ..opts.clone()
    };
    let (lo, hi) = interp.amplitude_range();
    let mut seed = 12345u64;
    for _ in 0..8 {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let u = (seed >> 11) as f64 / (1u64 << 53) as f64;
        let a = lo * (hi / lo).powf(u);
        let k = t.amplitude.partition_point(|&x| x < a).max(1) - 1;
        let guess = r
            .branch
            .iter()
            .min_by(|p, q| (p.amplitude - a).abs().total_cmp(&(q.amplitude - a).abs()))
            .unwrap();
        let sol = solve_at_amplitude(&model, basis.clone(), &fixed, a, guess).unwrap();
        let (ew, ed, es) = table_errors(&interp, &sol).unwrap();
        assert!(
            ew <= 2.0 * acc.target_omega_rel
                && ed <= 2.0 * acc.target_rel
                && es <= 2.0 * acc.target_rel,
            "a = {a:e} (interval {k}): omega {ew:e}, D {ed:e}, shapes {es:e}"
        );
    }
}

/// The start from the system linearised at rest: a `tanh` friction acts as
/// the damper `F_s / v_r`, so the start is the complex mode of the damped
/// linear system. 1 DOF: `omega = sqrt(k/m)`, `D = c / (2 m omega)` in closed
/// form (the EPMC of a linear oscillator); 2 DOF (NLvib example 05): the
/// residual `(K_l + i omega C_l - omega^2 (1 + 2 i D) M) phi` of the guess in
/// physical coordinates vanishes.
#[test]
fn start_guess_is_the_mode_of_the_system_linearised_at_rest() {
    use nlmode::nma::problems::nlvib::chain_of_oscillators;
    use nlmode::structure::RegularizedFriction;
    let mut one = chain_of_oscillators(&[2.0], &[0.0, 0.0], &[8.0, 0.0]);
    let e = nalgebra::DVector::from_element(1, 1.0);
    one.add_nonlinear("tanh", e, RegularizedFriction::new(0.3, 0.5).unwrap())
        .unwrap();
    let basis = Arc::new(ModalBasis::new(&one, false).unwrap());
    let res = nlmode::nma::epmc::EpmcResidual::new(basis, 3, 13, 0);
    let x = res.linearised_guess(-4.0);
    let m = res.n_coeffs();
    let (w, d) = (x[m], x[m + 1]);
    assert!((w - 2.0).abs() < 1e-12, "{w}");
    // c = 0.3 / 0.5 = 0.6 N s/m: D = 0.6 / (2 * 2 * 2)
    assert!((d - 0.075).abs() < 1e-12, "{d}");
    assert_eq!(x[m + 2], -4.0);

    let model = nlvib_tanh_friction_2dof();
    let basis = Arc::new(ModalBasis::new(&model, false).unwrap());
    let res = nlmode::nma::epmc::EpmcResidual::new(basis.clone(), 1, 5, 0);
    let x = res.linearised_guess(-2.0);
    let n = basis.n_modes();
    let m = res.n_coeffs();
    let (w, d) = (x[m], x[m + 1]);
    let psi = nalgebra::DVector::from_fn(n, |k, _| Complex64::new(x[n + k], -x[2 * n + k]));
    let phi = basis.phi.map(|v| Complex64::new(v, 0.0)) * psi;
    let c_t = 5.0 / 0.05;
    let mut a = model.stiffness.map(|v| Complex64::new(v, 0.0))
        - model.mass.map(|v| Complex64::new(v, 0.0)) * Complex64::new(w * w, 2.0 * d * w * w);
    a[(0, 0)] += Complex64::new(0.0, w * c_t);
    let r = (&a * &phi).norm() / (model.stiffness.map(|v| Complex64::new(v, 0.0)) * &phi).norm();
    assert!(r < 1e-10, "{r}");
    // stick: mass 1 held by the damper, mass 2 on 640 N/m
    assert!((w - 640f64.sqrt()).abs() < 0.01 * w, "{w}");
    assert!(phi[0].norm() < 0.05 * phi[1].norm());
}
