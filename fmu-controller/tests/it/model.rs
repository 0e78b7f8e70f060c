//! The controller model outside an FMU: parameter ranges at initialization,
//! the step limit, a level change, and the FMU state round trip.
use controller::model::*;
use fmi2_export::{CoSimModel, InstantiateContext, Logger, StateReader, StateWriter};

/// A freshly instantiated controller (shared with `model_description`).
pub(crate) fn fresh() -> Controller {
    let log = Logger::silent();
    Controller::instantiate(&InstantiateContext {
        instance_name: "c",
        resource_dir: None,
        logger: &log,
    })
    .unwrap()
}

fn initialized() -> Controller {
    let mut m = fresh();
    m.setup_experiment(0.0, None).unwrap();
    m.exit_initialization_mode(&Logger::silent()).unwrap();
    m
}

/// Drives the controller with a synthetic plant: the drive point lags the
/// force by `lag` rad.
fn run(m: &mut Controller, t0: f64, steps: usize, h: f64, lag: f64) {
    let log = Logger::silent();
    for n in 0..steps {
        let t = t0 + n as f64 * h;
        let th = m.get_real(VR_THETA);
        m.set_real(VR_F_MEAS, 2.0 * th.cos()).unwrap();
        m.set_real(VR_X_DRIVE, 1e-3 * (th - lag).cos()).unwrap();
        m.do_step(t, h, &log).unwrap();
    }
}

#[test]
fn parameters_out_of_range_are_refused_with_the_range() {
    let log = Logger::silent();
    for (vr, v, needle) in [
        (VR_KI, 0.0, "ki = 0e0 1/rad is outside its range"),
        (VR_OMEGA_START, -5.0, "omega_start"),
        (VR_MAX_STEP_RATIO, 0.7, "max_step_ratio"),
        (VR_U_HAT, 1e9, "u_hat"),
    ] {
        let mut m = fresh();
        m.set_real(vr, v).unwrap();
        let e = m.exit_initialization_mode(&log).unwrap_err().message;
        assert!(e.contains(needle), "{e}");
    }
    let mut m = fresh();
    m.set_integer(VR_HARMONICS, 3).unwrap();
    m.set_integer(VR_SAMPLES, 6).unwrap();
    let e = m.exit_initialization_mode(&log).unwrap_err().message;
    assert!(
        e.contains("samples_per_period = 6 is outside its range [8, 1000]"),
        "{e}"
    );
    // during stepping a bad u_hat is refused and the level kept
    let mut m = initialized();
    assert!(m.set_real(VR_U_HAT, -1.0).is_err());
    assert_eq!(m.get_real(VR_U_HAT), 1.0);
    // a step of more than 1/8 period is split internally (issue 26); one
    // that needs more than 1e7 internal steps is refused, naming h
    m.do_step(0.0, 3e-3, &log).unwrap();
    let e = m.do_step(3e-3, 1e30, &log).unwrap_err().message;
    assert!(
        e.contains("communication step h") && e.contains("1e30"),
        "{e}"
    );
}

fn all_reals_finite(m: &Controller) {
    for v in VARIABLES
        .iter()
        .filter(|v| v.ty == fmi2_export::VarType::Real)
    {
        let x = m.get_real(v.vr);
        assert!(x.is_finite(), "{} = {x}", v.name);
    }
}

/// Issue 26: with all inputs 0 (a bench before the exciter is on) the loop
/// holds (frequency at omega_start, no period counted, no record) for as
/// long as there is no signal, never NaN; with signal it then runs as usual.
#[test]
fn zero_inputs_hold_the_loop_for_many_periods_without_nan() {
    let mut m = initialized();
    let log = Logger::silent();
    all_reals_finite(&m);
    let h = 1e-5;
    // 0.5 s, about 28 periods
    for n in 0..50_000 {
        m.do_step(n as f64 * h, h, &log).unwrap();
        if n % 997 == 0 {
            all_reals_finite(&m);
        }
    }
    all_reals_finite(&m);
    assert_eq!(m.get_real(VR_OMEGA), 356.2);
    assert_eq!(m.get_real(VR_DAMPING), 0.0);
    assert_eq!(m.get_integer(VR_PERIODS).unwrap(), 0);
    let p = m.pll().unwrap();
    assert!(p.unmeasured_periods() >= 27, "{}", p.unmeasured_periods());
    assert!(p.last_period().is_none());
    // the output goes on (the exciter needs it to start)
    assert!(m.get_real(VR_THETA) >= 0.0);
    // signal: lag 60 degrees, below resonance, the frequency rises
    run(&mut m, 0.5, 20_000, h, 60f64.to_radians());
    all_reals_finite(&m);
    assert_eq!(m.pll().unwrap().unmeasured_periods(), 0);
    assert!(m.get_real(VR_OMEGA) > 356.2);
    assert!((m.get_real(VR_PHASE_ERROR) - 30f64.to_radians()).abs() < 1e-6);
    assert!(m.get_integer(VR_PERIODS).unwrap() > 10);
}

/// Issue 26: any communication step is accepted (fmpy's default output
/// interval 2.56e-3 s is more than 1/8 of the 17.6 ms period); the inputs are
/// held over the internal steps, the outputs stay finite, the loop runs.
#[test]
fn a_large_communication_step_is_sub_stepped() {
    let log = Logger::silent();
    for h in [2.56e-3, 0.1, 1.0] {
        let mut m = initialized();
        for n in 0..40 {
            m.do_step(n as f64 * h, h, &log).unwrap();
            all_reals_finite(&m);
        }
        assert!(m.pll().unwrap().unmeasured_periods() > 0, "h = {h}");
        let mut m = initialized();
        run(&mut m, 0.0, 400, h, 60f64.to_radians());
        all_reals_finite(&m);
        let w = m.get_real(VR_OMEGA);
        assert!(w.is_finite() && w > 0.0, "h = {h}: {w}");
        if h >= 0.1 {
            // fewer than 4 samples per period carry no phase: held throughout
            assert_eq!(w, 356.2, "h = {h}");
            assert_eq!(m.get_integer(VR_PERIODS).unwrap(), 0);
        } else {
            // about 7 samples per period: measured, coarsely
            assert!(m.get_integer(VR_PERIODS).unwrap() > 0);
            assert!((w / 356.2 - 1.0).abs() < 0.2, "{w}");
        }
    }
}

/// A step within 1/8 period is exactly the former sample and phase advance:
/// the loop stepped by `StreamingPll::step` equals the one stepped by
/// `measure` + `advance` bit for bit (the documented behaviour is unchanged).
#[test]
fn a_short_step_is_the_former_sample_and_advance() {
    use nlmode::control::{PllOptions, StreamSample, StreamingPll};
    let new = || StreamingPll::new(PllOptions::default(), 356.2, 1.0, 1.0, 40).unwrap();
    let (mut a, mut b) = (new(), new());
    let h = 1.7e-5;
    for n in 0..30_000 {
        let t = n as f64 * h;
        let th = a.phase_rad();
        let s = StreamSample {
            force_n: 2.0 * th.cos(),
            drive_m: 1e-3 * (th - 1.2).cos(),
            ..Default::default()
        };
        a.measure(t, s).unwrap();
        a.advance(h).unwrap();
        b.step(t, h, s).unwrap();
    }
    assert!(a.periods() > 20);
    assert_eq!(
        serde_json::to_string(&a).unwrap(),
        serde_json::to_string(&b).unwrap()
    );
}

#[test]
fn loop_moves_towards_ninety_degrees_and_a_new_level_starts_at_the_period_end() {
    let mut m = initialized();
    let h = 1e-5;
    // lag 60 degrees: below resonance, the frequency rises
    run(&mut m, 0.0, 20_000, h, 60f64.to_radians());
    let w = m.get_real(VR_OMEGA);
    assert!(w > 356.2, "{w}");
    assert!((m.get_real(VR_PHASE_ERROR) - 30f64.to_radians()).abs() < 1e-6);
    assert!((m.get_real(vr_harmonic(0, 1)) - 2.0).abs() < 1e-5);
    let x1 = m
        .get_real(vr_harmonic(1, 1))
        .hypot(m.get_real(vr_harmonic(1, 1) + 1));
    assert!((x1 - 1e-3).abs() < 1e-8, "{x1}");
    let periods = m.get_integer(VR_PERIODS).unwrap();
    assert!(periods > 10, "{periods}");
    m.set_real(VR_U_HAT, 3.0).unwrap();
    assert_eq!(m.get_real(VR_RECORD_VOLTAGE), 1.0);
    // the voltage changes at the next period end, the level count restarts
    let u_before = m.get_real(VR_U_EXT);
    assert!(u_before.abs() <= 1.0);
    run(&mut m, 0.2, 4000, h, 60f64.to_radians());
    assert_eq!(m.get_real(VR_RECORD_VOLTAGE), 3.0);
    assert!(m.get_integer(VR_PERIODS).unwrap() <= 2);
}

#[test]
fn serialized_state_continues_identically() {
    let mut m = initialized();
    let h = 1.1e-5;
    run(&mut m, 0.0, 7_000, h, 1.2);
    let mut w = StateWriter::new();
    m.serialize_state(&mut w);
    let bytes = w.into_bytes();
    let mut copy = fresh();
    let mut r = StateReader::new(&bytes);
    copy.deserialize_state(&mut r).unwrap();
    r.finish().unwrap();
    let t = 7_000.0 * h;
    run(&mut m, t, 3_000, h, 1.2);
    run(&mut copy, t, 3_000, h, 1.2);
    for v in controller::model::VARIABLES
        .iter()
        .filter(|v| v.ty == fmi2_export::VarType::Real)
    {
        assert_eq!(
            m.get_real(v.vr).to_bits(),
            copy.get_real(v.vr).to_bits(),
            "{}",
            v.name
        );
    }
    // a truncated state is an error, not a panic
    let mut r = StateReader::new(&bytes[..bytes.len() - 9]);
    assert!(fresh().deserialize_state(&mut r).is_err());
}
