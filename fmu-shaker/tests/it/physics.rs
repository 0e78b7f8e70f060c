//! The shaker model against closed forms (paper Section 4):
//! blocked force `k_s/(z_a + k_s) G u_hat/(R + i W L)` and interface
//! impedance `F = -k_s z_a/(z_a + k_s) x` of a harmonically moving drive point.
use fmi2_export::{CoSimModel, InstantiateContext, Logger};
use num_complex::Complex64;
use shaker::model::*;

fn shaker() -> Shaker {
    let log = Logger::silent();
    Shaker::instantiate(&InstantiateContext {
        instance_name: "t",
        resource_dir: None,
        logger: &log,
    })
    .unwrap()
}

/// Complex amplitude `Z` of `y(t) ~ Re(Z e^{i W t})` by least squares on whole periods.
fn fundamental(t: &[f64], y: &[f64], w: f64) -> Complex64 {
    let (mut cc, mut ss, mut cs, mut yc, mut ys) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (&t, &y) in t.iter().zip(y) {
        let (s, c) = (w * t).sin_cos();
        cc += c * c;
        ss += s * s;
        cs += c * s;
        yc += y * c;
        ys += y * s;
    }
    let det = cc * ss - cs * cs;
    let a = (yc * ss - ys * cs) / det;
    let b = (ys * cc - yc * cs) / det;
    Complex64::new(a, -b)
}

/// Run with the fixed-frequency internal source and a prescribed drive point
/// motion `x = Re(X e^{iWt})`; returns the fundamental of F over the last periods.
fn steady_force(w: f64, u_hat: f64, x_hat: Complex64, h: f64, with_velocity: bool) -> Complex64 {
    let mut m = shaker();
    let log = Logger::silent();
    m.set_real(VR_U_HAT, u_hat).unwrap();
    m.set_real(VR_OMEGA_START, w).unwrap();
    m.set_real(VR_OMEGA_RATE, 0.0).unwrap();
    m.setup_experiment(0.0, None).unwrap();
    m.exit_initialization_mode(&log).unwrap();
    let period = 2.0 * std::f64::consts::PI / w;
    // transients decay with ~940 1/s (stinger mode) and R/L: settle 60 ms
    let n_settle = (0.06 / h).ceil() as usize;
    let n_per = ((4.0 * period) / h).round() as usize; // fit over ~4 periods
    let (mut ts, mut fs) = (Vec::new(), Vec::new());
    let mut t = 0.0;
    for k in 0..n_settle + n_per {
        let e = Complex64::from_polar(1.0, w * t);
        let x = (x_hat * e).re;
        let v = (x_hat * Complex64::i() * w * e).re;
        m.set_real(VR_X, x).unwrap();
        m.set_real(VR_V, if with_velocity { v } else { 0.0 })
            .unwrap();
        if k >= n_settle {
            ts.push(t);
            fs.push(m.get_real(VR_F));
        }
        m.do_step(t, h, &log).unwrap();
        t = (k + 1) as f64 * h;
    }
    fundamental(&ts, &fs, w)
}

#[test]
fn blocked_force_matches_closed_form_at_three_frequencies_and_two_steps() {
    let p = nlmode::attachment::ShakerParams::paper();
    for w in [100.0, 356.2, 3000.0] {
        let exact = p.closed_form_blocked_force(w, Complex64::new(10.0, 0.0));
        for h in [1e-5, 1e-3] {
            let f = steady_force(w, 10.0, Complex64::new(0.0, 0.0), h, true);
            let err = (f - exact).norm() / exact.norm();
            println!("W = {w} rad/s, h = {h:e} s: F = {f:.6}, closed form {exact:.6}, rel. error {err:.2e}");
            assert!(err < 1e-3, "W={w} h={h}: {f} vs {exact} ({err:e})");
        }
    }
    // sanity of the closed form itself: at low frequency F -> G u/R k_s/(k_a + k_s)
    let low = p.closed_form_blocked_force(1e-3, Complex64::new(1.0, 0.0));
    assert!((low.re - 15.5 / 3.0 * 2.6e7 / (2.6e7 + 2.07e4)).abs() < 1e-6);
}

#[test]
fn moving_drive_point_sees_the_interface_impedance() {
    // u = 0, x = X cos(W t): F = -k_s z_a/(z_a + k_s) X
    let p = nlmode::attachment::ShakerParams::paper();
    let x_hat = Complex64::new(1e-6, 0.0);
    for w in [200.0, 356.2, 1000.0] {
        let exact = -p.closed_form_interface_impedance(w) * x_hat;
        let f = steady_force(w, 0.0, x_hat, 1e-5, true);
        let err = (f - exact).norm() / exact.norm();
        // linear extrapolation misses x''/2 tau^2: a mean displacement error of
        // (W h)^2/6 |X|, seen through the stiff stinger as k_s (W h)^2/6 |X|
        let bound = 2.6e7 * (w * 1e-5f64).powi(2) / 6.0 * x_hat.norm() / exact.norm();
        println!("W = {w}: F = {f:.6e}, -Z_G X = {exact:.6e}, rel. error {err:.2e} (estimate {bound:.2e})");
        assert!(err < 1.1 * bound + 1e-5, "W={w}: {f} vs {exact} ({err:e})");
        // without the velocity input x is held constant over each step (zero-order
        // hold): the k_s-stiff stinger turns the h/2 lag into a large force error
        let f_zoh = steady_force(w, 0.0, x_hat, 1e-5, false);
        let err_zoh = (f_zoh - exact).norm() / exact.norm();
        assert!(
            err_zoh > 10.0 * err,
            "ZOH {err_zoh:e} vs extrapolated {err:e}"
        );
    }
}

fn initialized(external: bool) -> Shaker {
    let mut m = shaker();
    m.set_boolean(VR_USE_EXTERNAL, external).unwrap();
    m.setup_experiment(0.0, None).unwrap();
    m.exit_initialization_mode(&Logger::silent()).unwrap();
    m
}

#[test]
fn external_dc_voltage_gives_the_static_blocked_force() {
    // x = 0, u = V0 constant: I = V0/R, (k_a + k_s) q_a = G I, F = k_s q_a
    let mut m = initialized(true);
    let log = Logger::silent();
    m.set_real(VR_U_EXT, 4.0).unwrap();
    let h = 1e-3;
    for k in 0..200 {
        m.do_step(k as f64 * h, h, &log).unwrap();
    }
    let exact = 2.6e7 / (2.07e4 + 2.6e7) * 15.5 * 4.0 / 3.0;
    assert!(
        (m.get_real(VR_F) - exact).abs() < 1e-9 * exact,
        "{} vs {exact}",
        m.get_real(VR_F)
    );
    assert!((m.get_real(VR_I) - 4.0 / 3.0).abs() < 1e-12);
    assert_eq!(m.get_real(VR_U), 4.0);
    assert_eq!(m.get_real(VR_OMEGA), 0.0);
    // der(u_ext) ramps the applied voltage inside the step
    m.set_real(VR_U_EXT, 4.0).unwrap();
    m.set_real_input_derivative(VR_U_EXT, 1, 100.0).unwrap();
    m.do_step(0.2, 1e-3, &log).unwrap();
    assert!((m.get_real(VR_U) - 4.1).abs() < 1e-12);
    assert_eq!(m.get_real_output_derivative(VR_U, 1).unwrap(), 100.0);
    assert!(m.set_real_input_derivative(VR_U_EXT, 2, 1.0).is_err());
}

#[test]
fn input_derivative_of_x_replaces_the_velocity() {
    let log = Logger::silent();
    let mut a = initialized(false);
    let mut b = initialized(false);
    for k in 0..50 {
        let t = k as f64 * 1e-4;
        a.set_real(VR_X, 1e-3 * t).unwrap();
        a.set_real(VR_V, 1e-3).unwrap();
        b.set_real(VR_X, 1e-3 * t).unwrap();
        b.set_real(VR_V, 0.0).unwrap();
        b.set_real_input_derivative(VR_X, 1, 1e-3).unwrap();
        a.do_step(t, 1e-4, &log).unwrap();
        b.do_step(t, 1e-4, &log).unwrap();
    }
    assert_eq!(a.states(), b.states());
    // output derivative of F is k_s (v_a - xdot)
    let dfdt = b.get_real_output_derivative(VR_F, 1).unwrap();
    assert!((dfdt - 2.6e7 * (b.get_real(VR_V_A) - 1e-3)).abs() < 1e-9 * dfdt.abs());
    // a new value of x without a derivative falls back to v (= 0 here)
    b.set_real(VR_X, 0.0).unwrap();
    assert_eq!(
        b.get_real_output_derivative(VR_F, 1).unwrap(),
        2.6e7 * b.get_real(VR_V_A)
    );
}

/// A communication step far too long for the internal sweep (1e6 s at 285
/// rad/s would need 5.7e9 sub-steps) is refused at once with the numbers,
/// instead of running without bound; the state stays usable.
#[test]
fn a_huge_step_is_refused_not_run() {
    let mut m = shaker();
    let log = Logger::silent();
    m.setup_experiment(0.0, None).unwrap();
    m.exit_initialization_mode(&log).unwrap();
    let t0 = std::time::Instant::now();
    let e = m.do_step(0.0, 1e6, &log).unwrap_err();
    assert!(t0.elapsed().as_secs_f64() < 1.0);
    let msg = e.to_string();
    assert!(
        msg.contains("1000000 s") && msg.contains("sub-steps"),
        "{msg}"
    );
    // a normal step still works afterwards
    m.do_step(0.0, 1e-5, &log).unwrap();
    assert!(m.get_real(VR_F).is_finite());
}

/// Issue 14: the shaker hung in the matrix exponential for accepted absurd
/// parameters (R 1e40, k_a 1e80, D_a 1e60, k_s 1e100, Omega_start 1e12).
/// Now each is refused at initialization with its physical range, at once.
#[test]
fn absurd_parameters_are_refused_with_their_range() {
    let log = Logger::silent();
    for (vr, value, needle) in [
        (
            VR_R,
            1e40,
            "R = 1e40 Ohm is outside its physical range [1e-6, 1e6] Ohm",
        ),
        (VR_R, 1e60, "R = 1e60 Ohm"),
        (
            VR_K_A,
            1e80,
            "k_a = 1e80 N/m is outside its physical range [1e-6, 1e12] N/m",
        ),
        (
            VR_D_A_RATIO,
            1e60,
            "D_a = 1e60 1 is outside its physical range [0e0, 1e3] 1",
        ),
        (
            VR_K_S,
            1e100,
            "k_s = 1e100 N/m is outside its physical range [1e-6, 1e12] N/m",
        ),
        (
            VR_OMEGA_START,
            1e12,
            "Omega_start = 1e12 rad/s is outside its physical range [0e0, 1e7] rad/s",
        ),
        (VR_U_HAT, f64::MAX, "u_hat = 1.7976931348623157e308 V"),
    ] {
        let mut m = shaker();
        m.set_real(vr, value).unwrap();
        m.setup_experiment(0.0, None).unwrap();
        let t0 = std::time::Instant::now();
        let e = m.exit_initialization_mode(&log).unwrap_err();
        assert!(t0.elapsed().as_secs_f64() < 0.1);
        assert!(
            e.message.contains(needle),
            "{needle:?} not in {:?}",
            e.message
        );
    }
}

/// The extremes of the accepted ranges still terminate: the stiffest stinger
/// on the lightest armature (||A|| ~ 1e18 1/s) with an external voltage (one
/// sub-step per step) is refused for a long step by the exponential's norm
/// bound, and steps at a short one.
#[test]
fn the_matrix_exponential_norm_is_bounded_per_step() {
    let log = Logger::silent();
    let mut m = shaker();
    m.set_real(VR_K_S, 1e12).unwrap();
    m.set_real(VR_M_A, 1e-6).unwrap();
    m.set_real(VR_D_A_RATIO, 1e3).unwrap();
    m.set_boolean(VR_USE_EXTERNAL, true).unwrap();
    m.setup_experiment(0.0, None).unwrap();
    m.exit_initialization_mode(&log).unwrap();
    let t0 = std::time::Instant::now();
    let e = m.do_step(0.0, 1.0, &log).unwrap_err();
    assert!(e.message.contains("exceeds 1e15"), "{}", e.message);
    m.do_step(0.0, 1e-6, &log).unwrap();
    assert!(t0.elapsed().as_secs_f64() < 1.0);
}

/// Model Exchange Jacobian (`fmi2GetDirectionalDerivative`): the partials of
/// the state derivatives equal their difference quotients (the system is
/// linear, so central differences are exact up to round-off).
#[test]
fn state_derivative_jacobian_matches_difference_quotients() {
    let log = Logger::silent();
    for external in [false, true] {
        let mut m = shaker();
        m.set_boolean(VR_USE_EXTERNAL, external).unwrap();
        m.setup_experiment(0.0, None).unwrap();
        m.exit_initialization_mode(&log).unwrap();
        m.set_time(0.01).unwrap();
        let s0 = [0.3, 2e-5, 0.04];
        m.set_continuous_states(&s0).unwrap();
        m.set_real(VR_X, 1e-5).unwrap();
        m.set_real(VR_U_EXT, 2.0).unwrap();
        let rates = |m: &Shaker| {
            let mut d = [0.0; 3];
            m.derivatives(&mut d).unwrap();
            d
        };
        let knowns: [(u32, f64); 5] = [
            (VR_I, 1e-3),
            (VR_Q_A, 1e-8),
            (VR_V_A, 1e-4),
            (VR_X, 1e-8),
            (VR_U_EXT, 1e-3),
        ];
        for (k, eps) in knowns {
            let (mut p, mut q) = (m.clone(), m.clone());
            let set = |m: &mut Shaker, d: f64| match k {
                VR_I | VR_Q_A | VR_V_A => {
                    let mut s = s0;
                    s[[VR_I, VR_Q_A, VR_V_A].iter().position(|&v| v == k).unwrap()] += d;
                    m.set_continuous_states(&s).unwrap();
                }
                _ => {
                    let v = m.get_real(k);
                    m.set_real(k, v + d).unwrap();
                }
            };
            set(&mut p, eps);
            set(&mut q, -eps);
            let (rp, rq) = (rates(&p), rates(&q));
            for (i, der) in [VR_DER_I, VR_DER_Q_A, VR_DER_V_A].into_iter().enumerate() {
                let fd = (rp[i] - rq[i]) / (2.0 * eps);
                let j = m.partial_derivative(der, k).unwrap();
                assert!(
                    (j - fd).abs() <= 1e-6 * fd.abs().max(1.0),
                    "d der {i} / d vr {k} (external {external}): {j} vs {fd}"
                );
            }
        }
        assert_eq!(m.partial_derivative(VR_F, VR_Q_A).unwrap(), 2.6e7);
        assert_eq!(m.partial_derivative(VR_I, VR_I).unwrap(), 1.0);
    }
}

/// Issue 26: every Real, the Model Exchange derivatives included, is readable
/// in Initialization Mode (the start state under the current parameters, the
/// same values as right after initialization); parameters that give no model
/// are an error saying why, not NaN.
#[test]
fn every_real_is_readable_in_initialization_mode() {
    let log = Logger::silent();
    let mut m = shaker();
    m.setup_experiment(0.0, None).unwrap();
    m.enter_initialization_mode(&log).unwrap();
    let reals: Vec<u32> = VARIABLES
        .iter()
        .filter(|v| v.ty == fmi2_export::VarType::Real)
        .map(|v| v.vr)
        .collect();
    let before: Vec<f64> = reals.iter().map(|&v| m.try_get_real(v).unwrap()).collect();
    assert!(before.iter().all(|x| x.is_finite()), "{before:?}");
    m.exit_initialization_mode(&log).unwrap();
    for (&v, b) in reals.iter().zip(&before) {
        assert_eq!(m.try_get_real(v).unwrap(), *b, "vr {v}");
    }
    let mut m = shaker();
    m.set_real(VR_L, -1.0).unwrap();
    m.enter_initialization_mode(&log).unwrap();
    let e = m.try_get_real(VR_DER_I).unwrap_err().message;
    assert!(e.contains("derivatives at the current parameters"), "{e}");
}
