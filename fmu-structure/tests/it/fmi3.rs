//! The FMI 3.0 interface of the structure FMU, in-process: the checked-in
//! FMI 3.0 modelDescription is the rendered one, Co-Simulation steps and
//! Model Exchange derivatives equal FMI 2.0's bit for bit, FMU states round
//! trip, and random call sequences neither crash, hang nor return
//! non-finite values with fmi3OK.
use std::path::Path;

use crate::model::{linear_table, nonlinear_table};
use fmi2_export::testing3::*;
use fmi2_export::CoSimModel;
use structure::{vr, Structure};

fn table() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    linear_table(d.path());
    d
}

#[test]
fn model_description_fmi3_is_the_one_the_code_gives() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../modelDescription/structure_fmi3/modelDescription.xml");
    let xml = fmi2_export::testing::check_model_description_file3::<Structure>(&path)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(xml.contains(&format!("instantiationToken=\"{}\"", Structure::GUID)));
    assert!(xml.contains("providesDirectionalDerivatives=\"true\""));
    // the Integer and String parameters share numbers with Float64 ones: offset in FMI 3.0
    assert!(xml.contains("<Int32 name=\"drive_point_index\" valueReference=\"100000000\""));
    assert!(xml.contains("<String name=\"drive_point\" valueReference=\"300000000\""));
}

#[test]
fn fmi3_co_simulation_equals_fmi2_bit_for_bit() {
    let d = table();
    let n = cs_equals_fmi2::<Structure>(
        Some(d.path()),
        &[(vr::FREQUENCY_ERROR, 0.01)],
        &|k| vec![(vr::F, 5.0 * (0.3 * k as f64).sin())],
        1e-4,
        60,
    )
    .unwrap();
    assert_eq!(n, 60 * 5);
}

#[test]
fn fmi3_model_exchange_derivatives_equal_fmi2() {
    let d = table();
    let states = [vec![0.0, 0.0], vec![1e-4, -2e-4], vec![-3e-5, 1e-6]];
    me_equals_fmi2::<Structure>(Some(d.path()), &[(vr::F, 2.0)], &states).unwrap();
}

#[test]
fn fmi3_fmu_state_round_trips_and_is_the_fmi2_blob() {
    let d = table();
    state_round_trip::<Structure>(Some(d.path()), &[], &[(vr::F, 3.0)], 1e-4).unwrap();
}

/// `fmi3GetDirectionalDerivative` against central differences of the
/// FMU's own values: Co-Simulation the 5 outputs w.r.t. `F` (0, no
/// feedthrough), Model Exchange `der(eta)`, `der(u)` w.r.t. `F`, `eta`, `u`;
/// on the linear table at rest and on the nonlinear table at states inside
/// its segments, where the amplitude derivatives of `omega`, `D`, `phi_ex`
/// enter the Jacobian.
#[test]
fn fmi3_directional_derivatives_equal_central_differences() {
    // CS: 5 outputs x 1 input; ME: 2 state derivatives x (1 input + 2 states)
    let d = table();
    let n = directional_derivatives::<Structure>(Some(d.path()), &[], &[(vr::F, 2.0)], 1e-4, 1e-6)
        .unwrap();
    assert_eq!(n, 5 + 2 * 3);
    let nl = tempfile::tempdir().unwrap();
    nonlinear_table(nl.path());
    for states in [[1.2e-3, -0.9e-3], [-4.1e-3, 2.3e-3], [7.7e-3, 4.0e-3]] {
        let n = directional_derivatives_at::<Structure>(
            Some(nl.path()),
            &[(vr::FREQUENCY_ERROR, 0.01)],
            &[(vr::F, 30.0)],
            Some(&states),
            1e-4,
            1e-6,
        )
        .unwrap_or_else(|e| panic!("at {states:?}: {e}"));
        assert_eq!(n, 5 + 2 * 3);
    }
}

#[test]
fn fmi3_fuzz_no_crash_no_hang_no_nan() {
    let d = table();
    let c = fuzz::<Structure>(Some(d.path()), 0x5EED_3001, 8, 250);
    eprintln!("fmi3 fuzz structure: {c:?}");
    assert_eq!((c.hung, c.accepted_wrong), (0, 0), "{c:?}");
    assert!(c.steps_ok > 0, "{c:?}");
}

#[test]
fn exported_fmi3_symbols_answer() {
    // the cdylib's own symbols (the forwarders the macro wrote)
    let v = unsafe { std::ffi::CStr::from_ptr(structure::fmi3GetVersion()) };
    assert_eq!(v.to_str().unwrap(), "3.0");
    let name = c"s";
    let bad = c"{not-the-token}";
    let c = unsafe {
        structure::fmi3InstantiateCoSimulation(
            name.as_ptr(),
            bad.as_ptr(),
            std::ptr::null(),
            false,
            false,
            false,
            false,
            std::ptr::null(),
            0,
            std::ptr::null_mut(),
            None,
            None,
        )
    };
    assert!(c.is_null(), "a wrong instantiationToken is refused");
    let c = instantiate3::<Structure>(true, None);
    let mut n = 7usize;
    let s = unsafe { structure::fmi3GetNumberOfContinuousStates(c, &mut n) };
    assert_eq!(
        s,
        fmi2_export::Status::Error,
        "a CS instance has no ME functions"
    );
    unsafe { structure::fmi3FreeInstance(c) };
}
