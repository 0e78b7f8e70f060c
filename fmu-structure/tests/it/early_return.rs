//! FMI 3.0 early return at the end of the modal table
//! (`mightReturnEarlyFromDoStep="true"`): a step in which the amplitude
//! would leave the table stops at the last RK4 sub-step inside it, within
//! one sub-step of the crossing time of the analytic linear response, in
//! the state of a run that stopped there; without `earlyReturnAllowed` the
//! step is the `fmi3Error` of FMI 2.0.
use fmi2_export::testing3::*;
use fmi2_export::{CoSimModel, Status};
use nlmode::nma::ModalTable;
use nlmode::oscillator::ModalOscillator;
use nlmode::Complex64;
use structure::{vr, Structure};

/// omega = 100 rad/s, D = 1 %, `phi_ex = phi_tip = 1`, amplitudes up to
/// `A_MAX`: under the constant force `F` the response rises to about twice
/// the static `F / omega^2 = 6e-4` and leaves the table.
const OMEGA: f64 = 100.0;
const D: f64 = 0.01;
const A_MAX: f64 = 1e-3;
const F: f64 = 6.0;

fn table() -> (tempfile::TempDir, ModalTable) {
    let d = tempfile::tempdir().unwrap();
    let one = Complex64::new(1.0, 0.0);
    let t = ModalTable::linear(OMEGA, D, &[("tip", one), ("2l3", one)], 1e-9, A_MAX);
    t.write(&d.path().join("modal_table.json")).unwrap();
    (d, t)
}

/// `a(t) = |eta - i eta'/omega|` of `eta'' + 2 D omega eta' + omega^2 eta = F`
/// from rest (the step response of the linear oscillator).
fn analytic_amplitude(t: f64) -> f64 {
    let xs = F / (OMEGA * OMEGA);
    let wd = OMEGA * (1.0 - D * D).sqrt();
    let e = (-D * OMEGA * t).exp();
    let eta = xs * (1.0 - e * ((wd * t).cos() + D * OMEGA / wd * (wd * t).sin()));
    let deta = xs * OMEGA * OMEGA / wd * e * (wd * t).sin();
    eta.hypot(deta / OMEGA)
}

/// First time the analytic amplitude reaches `A_MAX` (scan, then bisection).
fn crossing_time() -> f64 {
    let mut hi = 0.0;
    while analytic_amplitude(hi) < A_MAX {
        hi += 1e-5;
    }
    let mut lo = hi - 1e-5;
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if analytic_amplitude(mid) < A_MAX {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

fn ready<M: CoSimModel>(
    res: Option<&std::path::Path>,
    allowed: bool,
    values: &[(u32, f64)],
) -> fmi2_export::types::Component {
    let c = instantiate3_early::<M>(res, allowed).unwrap();
    initialize3::<M>(c, values).unwrap();
    c
}

const OUTPUTS: [u32; 5] = [vr::X, vr::V, vr::X_TIP, vr::A, vr::OMEGA];

#[test]
fn table_end_inside_a_step_returns_early_at_the_last_substep_inside() {
    let (d, t) = table();
    let h = 0.05;
    let h_max = ModalOscillator::new(&t, "2l3", 0.0)
        .unwrap()
        .max_substep_s();
    let h_sub = h / (h / h_max).ceil();
    let c = ready::<Structure>(Some(d.path()), true, &[(vr::F, F)]);
    take_logged();
    let (s, [ev, term, early], last) = do_step3::<Structure>(c, 0.0, h);
    let log = take_logged().join("\n");
    assert_eq!(s, Status::Warning, "{log}");
    assert!(
        early && term && !ev,
        "earlyReturn, terminateSimulation: {log}"
    );
    let t_cross = crossing_time();
    let err = t_cross - last;
    eprintln!(
        "table end: crossing {t_cross:.9} s (analytic), early return at {last:.9} s, \
         {err:.3e} s earlier, sub-step {h_sub:.6e} s"
    );
    assert!(
        err >= 0.0 && err <= h_sub,
        "early return at {last} s, analytic crossing {t_cross} s, sub-step {h_sub} s"
    );
    assert!(
        log.contains("returning early") && log.contains("a_max = 1.000000e-3"),
        "{log}"
    );
    assert!(log.contains("terminateSimulation"), "{log}");
    let y = get_float64::<Structure>(c, &OUTPUTS).unwrap();
    assert!(y[3] <= A_MAX && y[3] > 0.9 * A_MAX, "a = {}", y[3]);
    // the same sub-steps as single FMI 2.0-equal steps stop in the same state
    let j = (last / h_sub).round() as usize;
    assert!((j as f64 * h_sub - last).abs() < 1e-12);
    let r = ready::<Structure>(Some(d.path()), false, &[(vr::F, F)]);
    let mut tr = 0.0;
    for _ in 0..j {
        let (s, _, l) = do_step3::<Structure>(r, tr, h_sub);
        assert_eq!(s, Status::Ok);
        tr = l;
    }
    let yr = get_float64::<Structure>(r, &OUTPUTS).unwrap();
    assert_eq!(
        y.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        yr.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        "early return state {y:?} != run stopped there {yr:?}"
    );
    // the next sub-step of the run that stopped there leaves the table
    let (s, _, _) = do_step3::<Structure>(r, tr, h_sub);
    assert_eq!(s, Status::Error);
    // a master that ignores terminateSimulation gets no progress, no NaN
    let (s, [_, term, early], again) = do_step3::<Structure>(c, last, h);
    assert_eq!((s, term, early, again), (Status::Warning, true, true, last));
    unsafe {
        assert_eq!(fmi2_export::ffi::terminate::<Structure>(c), Status::Ok);
        fmi2_export::ffi::free_instance::<Structure>(c);
        fmi2_export::ffi::free_instance::<Structure>(r);
    }
}

#[test]
fn without_early_return_allowed_the_table_end_is_the_fmi2_error() {
    let (d, _) = table();
    let c = ready::<Structure>(Some(d.path()), false, &[(vr::F, F)]);
    take_logged();
    let (s, [ev, term, early], last) = do_step3::<Structure>(c, 0.0, 0.05);
    let log = take_logged().join("\n");
    assert_eq!(s, Status::Error, "{log}");
    assert!(!ev && !term && !early && last == 0.0);
    assert!(
        log.contains("above the modal table's range (max 1.000000e-3)"),
        "{log}"
    );
    unsafe { fmi2_export::ffi::free_instance::<Structure>(c) };
}

/// Steps that stay inside the table are the FMI 2.0 steps, early return
/// allowed or not (bit for bit).
#[test]
fn early_return_allowed_inside_the_table_is_the_plain_step() {
    let (d, _) = table();
    let a = ready::<Structure>(Some(d.path()), true, &[(vr::F, 1.0)]);
    let b = ready::<Structure>(Some(d.path()), false, &[(vr::F, 1.0)]);
    let mut t = 0.0;
    for k in 0..40 {
        let h = 1e-3 * (1.0 + (k % 3) as f64);
        let ra = do_step3::<Structure>(a, t, h);
        let rb = do_step3::<Structure>(b, t, h);
        assert_eq!((ra.0, ra.1), (Status::Ok, [false; 3]));
        assert_eq!(ra, rb);
        let (ya, yb) = (
            get_float64::<Structure>(a, &OUTPUTS).unwrap(),
            get_float64::<Structure>(b, &OUTPUTS).unwrap(),
        );
        assert_eq!(format!("{ya:?}"), format!("{yb:?}"));
        t = ra.2;
    }
    unsafe {
        fmi2_export::ffi::free_instance::<Structure>(a);
        fmi2_export::ffi::free_instance::<Structure>(b);
    }
}
