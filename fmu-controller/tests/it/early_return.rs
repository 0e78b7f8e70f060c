//! FMI 3.0 early return at a level change (`mightReturnEarlyFromDoStep="true"`):
//! a communication step longer than 1/8 period is split into internal steps
//! with held inputs; when the period that finishes the level (or starts a
//! new one) ends at an internal sample, `fmi3DoStep` returns there, at the
//! time an FMI 2.0 run stepping at the internal steps sees the change.
use controller::model::*;
use fmi2_export::testing3::*;
use fmi2_export::types::Component;
use fmi2_export::{ffi, fmi3, Status};

const W: f64 = 356.2;
/// Periods per level (the level is done after 3 measured periods).
const PERIODS: i32 = 3;

/// The measured signals at `t`: a force and a drive-point response at the
/// start frequency, 90 degrees apart.
fn inputs(t: f64) -> [(u32, f64); 2] {
    [
        (VR_F_MEAS, (W * t).cos()),
        (VR_X_DRIVE, 1e-3 * (W * t).sin()),
    ]
}

fn fmi3_controller(allowed: bool) -> Component {
    let c = instantiate3_early::<Controller>(None, allowed).unwrap();
    let v = PERIODS;
    let s = unsafe { fmi3::set_int32::<Controller>(c, &VR_MAX_PERIODS, 1, &v, 1) };
    assert_eq!(s, Status::Ok);
    initialize3::<Controller>(c, &[]).unwrap();
    c
}

fn set3(c: Component, t: f64) {
    for (vr, x) in inputs(t) {
        assert_eq!(
            unsafe { fmi3::set_float64::<Controller>(c, &vr, 1, &x, 1) },
            Status::Ok
        );
    }
}

fn level_done3(c: Component) -> bool {
    let mut b = false;
    let s = unsafe { fmi3::get_boolean::<Controller>(c, &VR_LEVEL_DONE, 1, &mut b, 1) };
    assert_eq!(s, Status::Ok);
    b
}

/// FMI 2.0 reference at half steps of `h` with the inputs of each step of
/// `h` held over its two halves: the index of the first half step whose
/// start sample finishes the level, its start time and `Omega`,
/// `phase_error` after it.
fn fmi2_level_change(h: f64) -> (usize, f64, [f64; 2]) {
    let c = instantiate2::<Controller>(true, None);
    unsafe {
        assert_eq!(
            ffi::set_integer::<Controller>(c, &VR_MAX_PERIODS, 1, &PERIODS),
            Status::Ok
        );
        ffi::setup_experiment::<Controller>(c, 0, 0.0, 0.0, 0, 0.0);
        ffi::enter_initialization_mode::<Controller>(c);
        assert_eq!(ffi::exit_initialization_mode::<Controller>(c), Status::Ok);
        let mut t = 0.0;
        let mut t_full = 0.0;
        for k in 0..4000 {
            if k % 2 == 0 {
                t_full = t;
            }
            for (vr, x) in inputs(t_full) {
                ffi::set_real::<Controller>(c, &vr, 1, &x);
            }
            assert_eq!(ffi::do_step::<Controller>(c, t, h / 2.0, 1), Status::Ok);
            let mut done = 0;
            ffi::get_boolean::<Controller>(c, &VR_LEVEL_DONE, 1, &mut done);
            if done != 0 {
                let mut y = [0.0; 2];
                ffi::get_real::<Controller>(
                    c,
                    [VR_OMEGA, VR_PHASE_ERROR].as_ptr(),
                    2,
                    y.as_mut_ptr(),
                );
                ffi::free_instance::<Controller>(c);
                return (k, t, y);
            }
            t += h / 2.0;
        }
        panic!("the level never finished");
    }
}

#[test]
fn level_done_inside_a_step_returns_early_at_the_period_end() {
    // a step of about 1/5 period: two internal steps of h/2 (at most 1/8
    // period each); pick one whose level change falls on an internal sample
    let period = 2.0 * std::f64::consts::PI / W;
    let (h, (k, t_change, y2)) = (0..40)
        .map(|i| period / 5.0 * (1.0 + 0.013 * i as f64))
        .map(|h| (h, fmi2_level_change(h)))
        .find(|(_, (k, _, _))| k % 2 == 1)
        .expect("a step whose level change is internal");
    let c = fmi3_controller(true);
    take_logged();
    let mut t = 0.0;
    let mut returned = None;
    for _ in 0..(k / 2 + 1) {
        set3(c, t);
        let (s, [ev, term, early], last) = do_step3::<Controller>(c, t, h);
        assert_eq!((s, ev, term), (Status::Ok, false, false));
        if early {
            returned = Some((t, last));
            break;
        }
        assert!(!level_done3(c));
        t = last;
    }
    let (t_step, last) = returned.expect("an early return at the level change");
    let log = take_logged().join("\n");
    eprintln!(
        "controller: step [{t_step}, {}] s returned early at {last} s, FMI 2.0 half steps \
         change at {t_change} s (difference {:.1e} s)",
        t_step + h,
        last - t_change
    );
    assert!((last - t_change).abs() < 1e-12, "{last} != {t_change}");
    assert!(last > t_step && last < t_step + h);
    assert!(level_done3(c), "level_done at the early return");
    let y3 = get_float64::<Controller>(c, &[VR_OMEGA, VR_PHASE_ERROR]).unwrap();
    // the same periods through the same loop (the phase sums differ in the
    // last bits: one internal step vs one FMI 2.0 step)
    for (a, b) in y3.iter().zip(y2) {
        assert!(
            (a - b).abs() <= 1e-12 * b.abs(),
            "Omega, phase error {y3:?} != {y2:?}"
        );
    }
    assert!(log.contains("finished the level (level_done)"), "{log}");
    // the master makes its communication point there: the next level, then
    // steps go on from the change
    let u = 2.0;
    assert_eq!(
        unsafe { fmi3::set_float64::<Controller>(c, &VR_U_HAT, 1, &u, 1) },
        Status::Ok
    );
    let mut t = last;
    let mut early_returns = Vec::new();
    take_logged();
    for _ in 0..20 {
        set3(c, t);
        let (s, [_, _, early], last) = do_step3::<Controller>(c, t, h);
        assert_eq!(s, Status::Ok);
        assert!(last > t && last <= t + h);
        if early {
            // the new level starts, or it is done, at an internal period end
            let log = take_logged().join("\n");
            let done = level_done3(c);
            let what = if done {
                "finished the level"
            } else {
                "started a new level"
            };
            assert!(log.contains(what), "{log}");
            early_returns.push((last, what));
        }
        t = last;
    }
    let v = get_float64::<Controller>(c, &[VR_U_EXT]).unwrap()[0];
    assert!(v.is_finite() && v.abs() <= u, "u_ext = {v}");
    eprintln!("controller: early returns after u_hat = 2: {early_returns:?}");
    unsafe { ffi::free_instance::<Controller>(c) };
}

/// Without `earlyReturnAllowed` the same steps are the FMI 2.0 ones: never
/// early, the level change seen at the end of the step that holds it.
#[test]
fn without_early_return_allowed_steps_are_never_early() {
    let period = 2.0 * std::f64::consts::PI / W;
    let h = period / 5.0;
    let c = fmi3_controller(false);
    let mut t = 0.0;
    let mut done = false;
    for _ in 0..100 {
        set3(c, t);
        let (s, flags, last) = do_step3::<Controller>(c, t, h);
        assert_eq!((s, flags), (Status::Ok, [false; 3]));
        assert_eq!(last, t + h);
        t = last;
        done |= level_done3(c);
    }
    assert!(done);
    unsafe { ffi::free_instance::<Controller>(c) };
}
