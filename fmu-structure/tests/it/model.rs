//! The structure model through its `CoSimModel` interface: table loading,
//! drive-point selection, state round trips, input derivatives and errors.
use std::f64::consts::PI;

use fmi2_export::{CoSimModel, InstantiateContext, Logger, StateReader, StateWriter};
use nlmode::nma::ModalTable;
use nlmode::Complex64;
use structure::{vr, Structure};

/// A linear modal table of the paper's beam (356.2 rad/s, D = 0.4 %) in `dir`.
pub(crate) fn linear_table(dir: &std::path::Path) -> std::path::PathBuf {
    let t = ModalTable::linear(
        356.2,
        0.004,
        &[
            ("tip", Complex64::new(1.43, 0.0)),
            ("l3", Complex64::new(0.3, 0.0)),
            ("2l3", Complex64::new(-1.04, 0.0)),
        ],
        1e-9,
        1.0,
    );
    let p = dir.join("modal_table.json");
    t.write(&p).unwrap();
    p
}

/// A nonlinear modal table in `dir` (40 amplitudes over `[1e-4, 1e-2]`):
/// hardening `omega(a)^2 = 356.2^2 (1 + 0.5 (a/1e-2)^2)`, damping
/// `D = 0.004 (1 + 2 a/1e-2)`, drive-point (`2l3`) and tip fundamentals
/// whose modulus and phase change with `a`, a third harmonic at the tip.
pub(crate) fn nonlinear_table(dir: &std::path::Path) -> std::path::PathBuf {
    let mut t = ModalTable::linear(
        356.2,
        0.004,
        &[
            ("tip", Complex64::new(1.43, 0.0)),
            ("l3", Complex64::new(0.3, 0.0)),
            ("2l3", Complex64::new(-1.04, 0.0)),
        ],
        1e-4,
        1e-2,
    );
    let n = 40;
    t.harmonics = 3;
    t.amplitude = (0..n)
        .map(|j| 1e-4 + (1e-2 - 1e-4) * j as f64 / (n - 1) as f64)
        .collect();
    let s: Vec<f64> = t.amplitude.iter().map(|a| a / 1e-2).collect();
    t.omega_rad_s = s
        .iter()
        .map(|s| 356.2 * (1.0 + 0.5 * s * s).sqrt())
        .collect();
    t.damping_ratio = s.iter().map(|s| 0.004 * (1.0 + 2.0 * s)).collect();
    for p in &mut t.points {
        let phi0 = p.re[0][1];
        let (re, im): (Vec<Vec<f64>>, Vec<Vec<f64>>) = s
            .iter()
            .map(|&s| {
                let phi = Complex64::new(phi0, 0.0) * Complex64::new(1.0 + 0.3 * s, 0.2 * s * s);
                let phi3 = 0.05 * s * phi0;
                (
                    vec![0.0, phi.re, 0.0, phi3],
                    vec![0.0, phi.im, 0.0, 0.01 * s],
                )
            })
            .unzip();
        p.re = re;
        p.im = im;
    }
    t.validate().unwrap();
    let p = dir.join("modal_table.json");
    t.write(&p).unwrap();
    p
}

pub(crate) fn instantiate(resource_dir: Option<std::path::PathBuf>) -> Structure {
    let log = Logger::silent();
    Structure::instantiate(&InstantiateContext {
        instance_name: "s",
        resource_dir,
        logger: &log,
    })
    .unwrap()
}

/// Model Exchange: the derivatives are the normal form of `eq:NM`; a linear
/// table gives `eta' = omega u`, `u' = -omega eta - 2 D omega u + |phi_ex| F/omega`.
#[test]
fn model_exchange_derivatives_are_the_normal_form() {
    let dir = tempfile::tempdir().unwrap();
    let table = linear_table(dir.path());
    let log = Logger::silent();
    let mut m = instantiate(None);
    m.set_string(vr::MODAL_TABLE, table.to_str().unwrap())
        .unwrap();
    m.setup_experiment(0.0, None).unwrap();
    m.exit_initialization_mode(&log).unwrap();
    m.set_time(0.25).unwrap();
    m.set_continuous_states(&[1e-3, -2e-3]).unwrap();
    m.set_real(vr::F, 0.5).unwrap();
    let mut dx = [0.0; 2];
    m.derivatives(&mut dx).unwrap();
    let (w, d, phi) = (356.2, 0.004, 1.04);
    assert!((dx[0] - w * -2e-3).abs() < 1e-12, "{dx:?}");
    let du = -w * 1e-3 - 2.0 * d * w * -2e-3 + phi * 0.5 / w;
    assert!(
        (dx[1] - du).abs() < 1e-12 * du.abs().max(1.0),
        "{dx:?} vs {du}"
    );
    assert_eq!(m.get_real(vr::ETA), 1e-3);
    assert_eq!(m.get_real(vr::U), -2e-3);
    assert_eq!(m.get_real(vr::DER_U), dx[1]);
    // the outputs follow the set state: x = phi_ex eta at the drive point
    assert!(
        (m.get_real(vr::X) + 1.04 * 1e-3).abs() < 1e-12
            || (m.get_real(vr::X) - 1.04 * 1e-3).abs() < 1e-12
    );
    // a state above the table's range is refused with the numbers
    let e = m.set_continuous_states(&[2.0, 0.0]).unwrap_err();
    assert!(e.message.contains("above the modal table's range"), "{e}");
}

#[test]
fn table_from_resources_or_parameter_and_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = linear_table(dir.path());
    let log = Logger::silent();
    // from the resources folder, default drive point 2l3: x = phi_ex eta, a static force
    let mut m = instantiate(Some(dir.path().to_path_buf()));
    m.exit_initialization_mode(&log).unwrap();
    assert_eq!(m.get_real(vr::OMEGA), 356.2);
    // missing resources
    let mut m = instantiate(Some(dir.path().join("nope")));
    let e = m.exit_initialization_mode(&log).unwrap_err();
    assert!(e.message.contains("does not exist"), "{}", e.message);
    let mut m = instantiate(None);
    let e = m.exit_initialization_mode(&log).unwrap_err();
    assert!(e.message.contains("no modal table"), "{}", e.message);
    // explicit path, unknown drive point, index out of range
    let mut m = instantiate(None);
    m.set_string(vr::MODAL_TABLE, path.to_str().unwrap())
        .unwrap();
    m.set_string(vr::DRIVE_POINT, "mid").unwrap();
    let e = m.exit_initialization_mode(&log).unwrap_err();
    assert!(
        e.message.contains("no point named 'mid'") && e.message.contains("2l3"),
        "{}",
        e.message
    );
    let mut m = instantiate(None);
    m.set_string(vr::MODAL_TABLE, path.to_str().unwrap())
        .unwrap();
    m.set_integer(vr::DRIVE_POINT_INDEX, 7).unwrap();
    assert!(m
        .exit_initialization_mode(&log)
        .unwrap_err()
        .message
        .contains("drive_point_index = 7"));
    // frequency error
    let mut m = instantiate(None);
    m.set_string(vr::MODAL_TABLE, path.to_str().unwrap())
        .unwrap();
    assert!(m.set_real(vr::FREQUENCY_ERROR, -1.5).is_err());
    m.set_real(vr::FREQUENCY_ERROR, 0.05).unwrap();
    m.exit_initialization_mode(&log).unwrap();
    assert!((m.get_real(vr::OMEGA) - 1.05 * 356.2).abs() < 1e-12);
}

/// Static deflection under a constant force: x -> phi_ex^2 F / omega^2, x_tip -> phi_tip phi_ex F / omega^2,
/// for the drive point chosen by name or by index.
#[test]
fn static_limit_by_name_and_by_index() {
    let dir = tempfile::tempdir().unwrap();
    let path = linear_table(dir.path());
    let log = Logger::silent();
    for (name, index, phi_ex) in [("l3", -1, 0.3), ("2l3", -1, -1.04), ("ignored", 1, 0.3)] {
        let mut m = instantiate(None);
        m.set_string(vr::MODAL_TABLE, path.to_str().unwrap())
            .unwrap();
        m.set_string(vr::DRIVE_POINT, name).unwrap();
        m.set_integer(vr::DRIVE_POINT_INDEX, index).unwrap();
        m.exit_initialization_mode(&log).unwrap();
        let f = 10.0;
        m.set_real(vr::F, f).unwrap();
        let h = 1e-3;
        // 5 s = 7 decay times 1/(D omega)
        for k in 0..5000 {
            m.do_step(k as f64 * h, h, &log).unwrap();
        }
        let w2 = 356.2f64 * 356.2;
        let x = m.get_real(vr::X);
        assert!(
            (x - phi_ex * phi_ex * f / w2).abs() < 2e-3 * (phi_ex * phi_ex * f / w2),
            "{name}: {x}"
        );
        let xt = m.get_real(vr::X_TIP);
        assert!(
            (xt - 1.43 * phi_ex * f / w2).abs() < 2e-3 * (1.43 * phi_ex * f / w2).abs(),
            "{name}: {xt}"
        );
        assert!(m.get_real(vr::V).abs() < 1e-3 * x.abs() * 356.2);
    }
}

/// Input derivatives make the input a polynomial over the step: a ramp given as
/// value + slope equals the same ramp fed by linear interpolation in small steps.
#[test]
fn input_derivatives_are_honoured_and_state_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = linear_table(dir.path());
    let log = Logger::silent();
    let mk = || {
        let mut m = instantiate(None);
        m.set_string(vr::MODAL_TABLE, path.to_str().unwrap())
            .unwrap();
        m.exit_initialization_mode(&log).unwrap();
        m
    };
    let (mut a, mut b, mut z) = (mk(), mk(), mk());
    let om = 300.0;
    let f = |t: f64| 5.0 * (om * t).sin();
    let df = |t: f64| 5.0 * om * (om * t).cos();
    let ddf = |t: f64| -5.0 * om * om * (om * t).sin();
    let h = 5e-4;
    let mut t = 0.0;
    for _ in 0..200 {
        z.set_real(vr::F, f(t)).unwrap();
        z.do_step(t, h, &log).unwrap();
        a.set_real(vr::F, f(t)).unwrap();
        a.set_real_input_derivative(vr::F, 1, df(t)).unwrap();
        a.set_real_input_derivative(vr::F, 2, ddf(t)).unwrap();
        a.do_step(t, h, &log).unwrap();
        // reference: 100 sub-steps with zero-order hold at the midpoint value
        for j in 0..100 {
            let s = t + (j as f64 + 0.5) * h / 100.0;
            b.set_real(vr::F, f(s)).unwrap();
            b.do_step(s, h / 100.0, &log).unwrap();
        }
        t += h;
    }
    let (xa, xb, xz) = (a.get_real(vr::X), b.get_real(vr::X), z.get_real(vr::X));
    // quadratic input over 0.5 ms steps at 300 rad/s: cubic remainder (om h)^3/6 = 5.6e-4 of F;
    // midpoint ZOH reference error ~ (om h/100)^2/24 ~ 1e-8
    assert!((xa - xb).abs() < 2e-3 * xb.abs(), "{xa} vs {xb}");
    // without the derivatives (zero-order hold) the input lags by h/2: clearly worse
    assert!((xz - xb).abs() > 10.0 * (xa - xb).abs(), "{xz} vs {xb}");
    assert!(a.get_real_output_derivative(vr::F, 1).is_err());
    assert!(a.set_real_input_derivative(vr::F, 3, 1.0).is_err());
    // output derivative of x equals v in the linear limit
    let dx = a.get_real_output_derivative(vr::X, 1).unwrap();
    assert!(
        (dx - a.get_real(vr::V)).abs() < 1e-6 * a.get_real(vr::V).abs(),
        "{dx}"
    );

    // serialize, continue, restore, continue: identical bit for bit
    let mut w = StateWriter::new();
    a.serialize_state(&mut w);
    let bytes = w.into_bytes();
    let run = |m: &mut Structure, t0: f64| {
        let mut out = vec![];
        for k in 0..200 {
            let tk = t0 + k as f64 * 1e-4;
            m.set_real(vr::F, 3.0 * (2.0 * PI * 57.0 * tk).cos())
                .unwrap();
            m.do_step(tk, 1e-4, &log).unwrap();
            out.push([
                m.get_real(vr::X),
                m.get_real(vr::V),
                m.get_real(vr::X_TIP),
                m.get_real(vr::A),
            ]);
        }
        out
    };
    let first = run(&mut a, t);
    let mut c = mk();
    let mut r = StateReader::new(&bytes);
    c.deserialize_state(&mut r).unwrap();
    r.finish().unwrap();
    assert_eq!(run(&mut c, t), first);
    // a state of another configuration is refused
    let mut d = instantiate(None);
    d.set_string(vr::MODAL_TABLE, path.to_str().unwrap())
        .unwrap();
    d.set_real(vr::FREQUENCY_ERROR, 0.05).unwrap();
    d.exit_initialization_mode(&log).unwrap();
    assert!(d.deserialize_state(&mut StateReader::new(&bytes)).is_err());
}

#[test]
fn leaving_the_table_is_an_error_naming_the_amplitude() {
    let dir = tempfile::tempdir().unwrap();
    let t = ModalTable::linear(
        100.0,
        0.01,
        &[
            ("tip", Complex64::new(1.0, 0.0)),
            ("2l3", Complex64::new(1.0, 0.0)),
        ],
        1e-9,
        1e-3,
    );
    t.write(&dir.path().join("modal_table.json")).unwrap();
    let log = Logger::silent();
    let mut m = instantiate(Some(dir.path().to_path_buf()));
    m.exit_initialization_mode(&log).unwrap();
    m.set_real(vr::F, 1e3).unwrap();
    let mut err = None;
    for k in 0..1000 {
        if let Err(e) = m.do_step(k as f64 * 1e-3, 1e-3, &log) {
            err = Some(e);
            break;
        }
    }
    let e = err.expect("leaves the table");
    assert!(
        e.message.contains("above the modal table's range"),
        "{}",
        e.message
    );
}

/// The output derivatives are computed once per state and input and cached:
/// the cache must follow `F`, the step and a restored state. Linear limit at
/// the drive point (`phi = -1.04`): `v = phi eta'`, so
/// `dv/dt = phi (phi F - omega^2 eta - 2 D omega eta')` changes by `phi^2` per
/// newton of `F`, and `dx/dt = v`.
#[test]
fn cached_output_derivatives_follow_the_input_the_step_and_the_state() {
    let dir = tempfile::tempdir().unwrap();
    let path = linear_table(dir.path());
    let log = Logger::silent();
    let mut m = instantiate(None);
    m.set_string(vr::MODAL_TABLE, path.to_str().unwrap())
        .unwrap();
    m.exit_initialization_mode(&log).unwrap();
    let (w, d, phi): (f64, f64, f64) = (356.2, 0.004, -1.04);
    let mut t: f64 = 0.0;
    for k in 0..300 {
        m.set_real(vr::F, 4.0 * (300.0 * t).sin() + 1.0).unwrap();
        if k == 150 {
            // a derivative read mid-run must not disturb the cache of the next step
            m.get_real_output_derivative(vr::V, 1).unwrap();
        }
        m.do_step(t, 1e-4, &log).unwrap();
        t += 1e-4;
    }
    let (x, v) = (m.get_real(vr::X), m.get_real(vr::V));
    assert!(v.abs() > 1e-4, "{v}");
    // eta = x / phi, eta' = v / phi
    let expected_dv = |f: f64| phi * (phi * f - w * w * x / phi - 2.0 * d * w * v / phi);
    let mut state = StateWriter::new();
    m.serialize_state(&mut state);
    let state = state.into_bytes();
    let f0 = m.get_real(vr::F);
    let dv0 = m.get_real_output_derivative(vr::V, 1).unwrap();
    let dx0 = m.get_real_output_derivative(vr::X, 1).unwrap();
    let tol = |e: f64| 1e-6 * e.abs().max(w * v.abs());
    assert!(
        (dv0 - expected_dv(f0)).abs() < tol(dv0),
        "{dv0} vs {}",
        expected_dv(f0)
    );
    assert!((dx0 - v).abs() < 1e-6 * v.abs(), "{dx0} vs {v}");
    // new input: the V derivative moves by phi^2 per newton, X's does not move
    m.set_real(vr::F, f0 + 10.0).unwrap();
    let dv1 = m.get_real_output_derivative(vr::V, 1).unwrap();
    assert!(
        (dv1 - dv0 - 10.0 * phi * phi).abs() < tol(dv1),
        "{dv1} - {dv0} vs {}",
        10.0 * phi * phi
    );
    assert!((dv1 - expected_dv(f0 + 10.0)).abs() < tol(dv1));
    assert!((m.get_real_output_derivative(vr::X, 1).unwrap() - dx0).abs() < 1e-6 * dx0.abs());
    // a step: the derivatives are those of the new state
    m.do_step(t, 1e-4, &log).unwrap();
    let (x2, v2) = (m.get_real(vr::X), m.get_real(vr::V));
    assert!((m.get_real_output_derivative(vr::X, 1).unwrap() - v2).abs() < 1e-6 * v2.abs());
    let f2 = m.get_real(vr::F);
    let dv2 = m.get_real_output_derivative(vr::V, 1).unwrap();
    let e2 = phi * (phi * f2 - w * w * x2 / phi - 2.0 * d * w * v2 / phi);
    assert!((dv2 - e2).abs() < tol(e2), "{dv2} vs {e2}");
    assert!(
        (dv2 - dv1).abs() > 1e3 * tol(e2),
        "the step must change the derivative: {dv2} {dv1}"
    );
    // restoring the earlier state (with its F = f0) gives its derivatives back exactly
    let mut r = StateReader::new(&state);
    m.deserialize_state(&mut r).unwrap();
    r.finish().unwrap();
    assert_eq!(m.get_real_output_derivative(vr::V, 1).unwrap(), dv0);
    assert_eq!(m.get_real_output_derivative(vr::X, 1).unwrap(), dx0);
}

/// Issue 14: `fmi2DoStep` of 1e6 s, or with `frequency_error` 1e9, never
/// returned; now it is an error naming the step, the sub-step and the cap.
#[test]
fn do_step_work_is_bounded() {
    let dir = tempfile::tempdir().unwrap();
    linear_table(dir.path());
    let log = Logger::silent();
    let mut m = instantiate(Some(dir.path().to_path_buf()));
    m.exit_initialization_mode(&log).unwrap();
    let t0 = std::time::Instant::now();
    let e = m.do_step(0.0, 1e6, &log).unwrap_err();
    assert!(
        e.message.contains("communication step 1e6 s"),
        "{}",
        e.message
    );
    assert!(e.message.contains("cap of 1000000"), "{}", e.message);
    let mut m = instantiate(Some(dir.path().to_path_buf()));
    m.set_real(vr::FREQUENCY_ERROR, 1e9).unwrap();
    m.exit_initialization_mode(&log).unwrap();
    let e = m.do_step(0.0, 1e-4, &log).unwrap_err();
    assert!(e.message.contains("sub-steps"), "{}", e.message);
    assert!(t0.elapsed().as_secs_f64() < 1.0);
}

/// Issue 14: `frequency_error = DBL_MAX` or an input `F = DBL_MAX` returned
/// NaN/inf with fmi2OK; now initialization or the step is an error.
#[test]
fn extreme_parameters_and_inputs_are_errors_not_nan() {
    let dir = tempfile::tempdir().unwrap();
    linear_table(dir.path());
    let log = Logger::silent();
    let mut m = instantiate(Some(dir.path().to_path_buf()));
    m.set_real(vr::FREQUENCY_ERROR, f64::MAX).unwrap();
    assert!(m.exit_initialization_mode(&log).is_err());
    let mut m = instantiate(Some(dir.path().to_path_buf()));
    m.exit_initialization_mode(&log).unwrap();
    m.set_real(vr::F, f64::MAX).unwrap();
    assert!(m.do_step(0.0, 1e-5, &log).is_err());
    for v in [vr::X, vr::V, vr::X_TIP, vr::A, vr::OMEGA] {
        assert!(m.get_real(v).is_finite(), "vr {v}");
    }
}

/// Issue 26: in Initialization Mode every Real is readable: the outputs and
/// `der(eta)`, `der(u)` are those of the start state `eta = u = 0` under the
/// current parameters and `F` (libcosim reads them all and aborted on the
/// former error); without a table the error says why.
#[test]
fn every_real_is_readable_in_initialization_mode() {
    let dir = tempfile::tempdir().unwrap();
    let path = linear_table(dir.path());
    let log = Logger::silent();
    let mut m = instantiate(Some(dir.path().to_path_buf()));
    m.setup_experiment(0.0, None).unwrap();
    m.enter_initialization_mode(&log).unwrap();
    for v in Structure::VARIABLES
        .iter()
        .filter(|v| v.ty == fmi2_export::VarType::Real)
    {
        let x = m.try_get_real(v.vr).unwrap();
        assert!(x.is_finite(), "{} = {x}", v.name);
    }
    assert_eq!(m.get_real(vr::OMEGA), 356.2);
    assert_eq!(m.get_real(vr::DER_ETA), 0.0);
    assert_eq!(m.get_real(vr::DER_U), 0.0);
    // a force: u' = |phi_ex| F / omega at rest, as after initialization
    m.set_real(vr::F, 0.5).unwrap();
    let mut dx = [0.0; 2];
    m.derivatives(&mut dx).unwrap();
    assert!((dx[1] - 1.04 * 0.5 / 356.2).abs() < 1e-12, "{dx:?}");
    assert_eq!(m.get_real(vr::DER_U), dx[1]);
    // a parameter set in Initialization Mode is seen at once
    m.set_real(vr::FREQUENCY_ERROR, 0.05).unwrap();
    assert!((m.get_real(vr::OMEGA) - 1.05 * 356.2).abs() < 1e-12);
    let du_init = m.get_real(vr::DER_U);
    assert!((du_init - 1.04 * 0.5 / (1.05 * 356.2)).abs() < 1e-12);
    // the same values after initialization
    m.exit_initialization_mode(&log).unwrap();
    assert!((m.get_real(vr::OMEGA) - 1.05 * 356.2).abs() < 1e-12);
    let mut after = [0.0; 2];
    m.derivatives(&mut after).unwrap();
    assert_eq!(after, [0.0, du_init]);
    // no table: an error naming the cause, not NaN with OK
    let mut m = instantiate(None);
    m.enter_initialization_mode(&log).unwrap();
    let e = m.try_get_real(vr::DER_ETA).unwrap_err().message;
    assert!(e.contains("no modal table"), "{e}");
    // ... until the parameter names one
    m.set_string(vr::MODAL_TABLE, path.to_str().unwrap())
        .unwrap();
    assert_eq!(m.try_get_real(vr::OMEGA).unwrap(), 356.2);
    // a device names the parameter and what it expects (issue 26: "does not exist")
    let mut m = instantiate(None);
    m.set_string(vr::MODAL_TABLE, "/dev/zero").unwrap();
    let e = m.exit_initialization_mode(&log).unwrap_err().message;
    assert!(
        e.contains("parameter modal_table = \"/dev/zero\"")
            && e.contains("not a regular file")
            && e.contains("expected a modal-table JSON file"),
        "{e}"
    );
}

/// `residual_modes`: the FMU steps the oscillator of `nlmode` with the
/// table's linear modes (bit for bit), restores their states with the FMU
/// state, and refuses what it cannot do with the key named.
#[test]
fn residual_modes_follow_the_oscillator_round_trip_and_bad_values_are_named() {
    use nlmode::nma::{LinearModeShape, LinearModes};
    use nlmode::oscillator::{InputPolynomial, ModalOscillator};
    let dir = tempfile::tempdir().unwrap();
    let path = linear_table(dir.path());
    let mut t = ModalTable::read(&path).unwrap();
    let shape = |name: &str, v: f64| LinearModeShape {
        name: name.into(),
        shape: vec![v],
    };
    t.linear_modes = Some(LinearModes {
        omega_rad_s: vec![2000.0],
        damping_ratio: vec![0.01],
        points: vec![shape("tip", 0.8), shape("l3", 0.5), shape("2l3", 0.6)],
    });
    t.write(&path).unwrap();
    let log = Logger::silent();
    let make = |n: i32| {
        let mut m = instantiate(None);
        m.set_string(vr::MODAL_TABLE, path.to_str().unwrap())
            .unwrap();
        m.set_integer(vr::RESIDUAL_MODES, n).unwrap();
        m
    };
    let mut m = make(1);
    assert_eq!(m.get_integer(vr::RESIDUAL_MODES).unwrap(), 1);
    m.exit_initialization_mode(&log).unwrap();
    let mut osc = ModalOscillator::new(&t, "2l3", 0.0)
        .unwrap()
        .with_residual_modes(&t, 1)
        .unwrap();
    let tip = osc.point_index("tip").unwrap();
    let force = |k: usize| 3.0 * (700.0 * k as f64 * 1e-4).sin();
    let mut state = None;
    let mut at_save = (0.0, 0.0);
    for k in 0..400 {
        m.set_real(vr::F, force(k)).unwrap();
        m.do_step(k as f64 * 1e-4, 1e-4, &log).unwrap();
        osc.step(1e-4, InputPolynomial::constant(force(k))).unwrap();
        assert_eq!(
            m.get_real(vr::X),
            osc.point_response(osc.drive_index()).unwrap().x_m
        );
        assert_eq!(m.get_real(vr::X_TIP), osc.point_response(tip).unwrap().x_m);
        if k == 200 {
            let mut w = StateWriter::new();
            m.serialize_state(&mut w);
            state = Some(w.into_bytes());
            at_save = (m.get_real(vr::X), m.get_real(vr::V));
        }
    }
    // the residual mode is in the output: the largest difference to the
    // single mode under the same force is the mode's response, forced
    // 0.6^2 * 3 N / (2000^2 - 700^2) = 3.1e-7 m plus its start transient
    // (from rest, at most 700/2000 of that again): within [0.6, 1.5] x 3.1e-7
    let mut m0 = make(0);
    m0.exit_initialization_mode(&log).unwrap();
    let mut m1 = make(1);
    m1.exit_initialization_mode(&log).unwrap();
    let mut largest: f64 = 0.0;
    for k in 0..400 {
        m0.set_real(vr::F, force(k)).unwrap();
        m1.set_real(vr::F, force(k)).unwrap();
        m0.do_step(k as f64 * 1e-4, 1e-4, &log).unwrap();
        m1.do_step(k as f64 * 1e-4, 1e-4, &log).unwrap();
        largest = largest.max((m1.get_real(vr::X) - m0.get_real(vr::X)).abs());
    }
    let forced = 0.36 * 3.0 / (2000f64.powi(2) - 700f64.powi(2));
    assert!(
        largest > 0.6 * forced && largest < 1.5 * forced,
        "{largest} vs {forced}"
    );
    // restore: the residual state comes back with the rest
    let state = state.unwrap();
    m.deserialize_state(&mut StateReader::new(&state)).unwrap();
    assert_eq!((m.get_real(vr::X), m.get_real(vr::V)), at_save);
    // a state of the single-mode configuration is refused
    let mut one = make(0);
    one.exit_initialization_mode(&log).unwrap();
    let e = one
        .deserialize_state(&mut StateReader::new(&state))
        .unwrap_err();
    assert!(e.message.contains("residual-mode states"), "{}", e.message);
    // Model Exchange has eta and u only
    let mut dx = [0.0; 2];
    let e = m.derivatives(&mut dx).unwrap_err();
    assert!(
        e.message.contains("residual_modes = 1") && e.message.contains("Co-Simulation"),
        "{}",
        e.message
    );
    // more than the table carries, and negative values
    let mut two = make(2);
    let e = two.exit_initialization_mode(&log).unwrap_err();
    assert!(
        e.message.contains("residual_modes = 2") && e.message.contains("1 to 1"),
        "{}",
        e.message
    );
    let e = instantiate(None)
        .set_integer(vr::RESIDUAL_MODES, -1)
        .unwrap_err();
    assert!(e.message.contains("residual_modes = -1"), "{}", e.message);
}

/// The Model Exchange partial derivatives (`partial_derivative`) against
/// central differences of the model's own `derivatives` and outputs in the
/// states and `F`, on the nonlinear table at states inside its segments
/// (amplitudes 1.5e-3 to 8.7e-3). Step `1e-6` of the known's scale
/// (`a` for the states): truncation `(1e-6)^2` and round-off `1e-16/1e-6`
/// relative; tolerance `1e-6` of the row's largest entry (the exact
/// Jacobian; the outputs `x`, `v`, `x_tip` are themselves central
/// differences, about 1e-10). Outputs with respect to `F`: 0. Measured: the
/// state derivatives and `x`, `v`, `x_tip` within 2e-10; `omega` within
/// 1.1e-8, the round-off of this test's own difference (`1e-16 omega / h`
/// against `d omega/d eta ~ 2e3` at `h = 1.5e-9`).
#[test]
fn model_exchange_partial_derivatives_equal_central_differences() {
    partials_against_central_differences(false);
}

/// The same with `harmonic_force_projection` (`der(eta)` then depends on
/// `F` too; the state columns of the Jacobian are central differences of
/// their own, about 1e-10).
#[test]
fn model_exchange_partial_derivatives_with_harmonic_projection() {
    partials_against_central_differences(true);
}

fn partials_against_central_differences(projection: bool) {
    let dir = tempfile::tempdir().unwrap();
    nonlinear_table(dir.path());
    let mut m = instantiate(Some(dir.path().to_path_buf()));
    m.set_boolean(vr::HARMONIC_FORCE_PROJECTION, projection)
        .unwrap();
    m.exit_initialization_mode(&Logger::silent()).unwrap();
    let outputs = [vr::X, vr::V, vr::X_TIP, vr::A, vr::OMEGA];
    let ders = [vr::DER_ETA, vr::DER_U];
    let mut worst: f64 = 0.0;
    for &(eta, u, f) in &[
        (1.2e-3, -0.9e-3, 3.0),
        (-4.1e-3, 2.3e-3, -20.0),
        (7.7e-3, 4.0e-3, 0.0),
        (0.3e-3, -6.1e-3, 50.0),
    ] {
        m.set_continuous_states(&[eta, u]).unwrap();
        m.set_real(vr::F, f).unwrap();
        let a = f64::hypot(eta, u);
        // all unknowns at (eta, u, F)
        let eval = |m: &Structure| {
            let mut dx = [0.0; 2];
            m.derivatives(&mut dx).unwrap();
            let mut y: Vec<f64> = dx.to_vec();
            y.extend(outputs.iter().map(|&o| m.get_real(o)));
            y
        };
        let unknowns: Vec<u32> = ders.iter().chain(outputs.iter()).copied().collect();
        for (known, step) in [
            (vr::ETA, 1e-6 * a),
            (vr::U, 1e-6 * a),
            (vr::F, 1e-6 * f.abs().max(1.0)),
        ] {
            let at = |k: f64| {
                let mut mm = m.clone();
                match known {
                    vr::ETA => mm.set_continuous_states(&[eta + k, u]).unwrap(),
                    vr::U => mm.set_continuous_states(&[eta, u + k]).unwrap(),
                    _ => mm.set_real(vr::F, f + k).unwrap(),
                }
                eval(&mm)
            };
            let (yp, ym) = (at(step), at(-step));
            let fd: Vec<f64> = yp
                .iter()
                .zip(&ym)
                .map(|(p, q)| (p - q) / (2.0 * step))
                .collect();
            let exact: Vec<f64> = unknowns
                .iter()
                .map(|&un| m.partial_derivative(un, known).unwrap())
                .collect();
            for (i, &un) in unknowns.iter().enumerate() {
                if known == vr::F && i >= 2 {
                    assert_eq!(exact[i], 0.0, "output {un} w.r.t. F");
                    assert_eq!(fd[i], 0.0, "output {un} w.r.t. F");
                    continue;
                }
                // the row's scale: the largest partial of this unknown
                let scale = [vr::ETA, vr::U]
                    .iter()
                    .map(|&k| m.partial_derivative(un, k).unwrap().abs())
                    .fold(exact[i].abs().max(fd[i].abs()), f64::max);
                let err = (exact[i] - fd[i]).abs() / scale;
                worst = worst.max(err);
                assert!(
                    err < 1e-6,
                    "({eta}, {u}, F = {f}): d(vr {un})/d(vr {known}) = {} vs central difference {} ({err:e})",
                    exact[i],
                    fd[i]
                );
            }
        }
    }
    eprintln!(
        "structure ME partial derivatives vs central differences: max relative error {worst:e}"
    );
    // undeclared pairs stay errors
    assert!(m.partial_derivative(vr::X, vr::FREQUENCY_ERROR).is_err());
    assert!(m.partial_derivative(vr::ETA, vr::F).is_err());
}

/// `harmonic_force_projection`: the FMU steps `nlmode`'s oscillator with
/// the force on every harmonic of the mode (bit for bit), the parameter
/// reads back, and on the nonlinear table (higher harmonics at the drive
/// point) a force with a third harmonic moves the response away from the
/// default projection's.
#[test]
fn harmonic_force_projection_follows_the_oscillator() {
    use nlmode::oscillator::{InputPolynomial, ModalOscillator};
    let dir = tempfile::tempdir().unwrap();
    nonlinear_table(dir.path());
    let t = ModalTable::read(&dir.path().join("modal_table.json")).unwrap();
    let log = Logger::silent();
    let make = |on: bool| {
        let mut m = instantiate(Some(dir.path().to_path_buf()));
        m.set_boolean(vr::HARMONIC_FORCE_PROJECTION, on).unwrap();
        assert_eq!(m.get_boolean(vr::HARMONIC_FORCE_PROJECTION).unwrap(), on);
        m.exit_initialization_mode(&log).unwrap();
        m
    };
    assert!(!instantiate(None)
        .get_boolean(vr::HARMONIC_FORCE_PROJECTION)
        .unwrap());
    let (mut on, mut off) = (make(true), make(false));
    let mut osc = ModalOscillator::new(&t, "2l3", 0.0)
        .unwrap()
        .with_harmonic_force_projection(true);
    let w = t.omega_rad_s[0];
    let force = |k: usize| {
        let s = w * k as f64 * 1e-4;
        20.0 * s.sin() + 15.0 * (3.0 * s).sin()
    };
    let mut largest: f64 = 0.0;
    for k in 0..2000 {
        for m in [&mut on, &mut off] {
            m.set_real(vr::F, force(k)).unwrap();
            m.do_step(k as f64 * 1e-4, 1e-4, &log).unwrap();
        }
        osc.step(1e-4, InputPolynomial::constant(force(k))).unwrap();
        assert_eq!(
            on.get_real(vr::X),
            osc.point_response(osc.drive_index()).unwrap().x_m
        );
        largest = largest.max((on.get_real(vr::A) / off.get_real(vr::A) - 1.0).abs());
    }
    assert!(
        largest > 1e-4,
        "the projection changed the amplitude by {largest:e}"
    );
    assert!(largest < 0.5, "{largest:e}");
    eprintln!(
        "harmonic projection against the fundamental: amplitude differs by up to {largest:e}"
    );
}
