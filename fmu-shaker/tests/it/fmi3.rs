//! The FMI 3.0 interface of the shaker FMU, in-process: the checked-in
//! FMI 3.0 modelDescription is the rendered one, Co-Simulation steps and
//! Model Exchange derivatives equal FMI 2.0's bit for bit, FMU states round
//! trip, `fmi3GetDirectionalDerivative` (exact: the system is linear) equals
//! a central difference of the FMU's own outputs and state derivatives, and
//! random call sequences neither crash, hang nor return non-finite values
//! with fmi3OK.
use std::path::Path;

use fmi2_export::testing3::*;
use fmi2_export::CoSimModel;
use shaker::model::*;

#[test]
fn model_description_fmi3_is_the_one_the_code_gives() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../modelDescription/shaker_fmi3/modelDescription.xml");
    let xml = fmi2_export::testing::check_model_description_file3::<Shaker>(&path)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(xml.contains(&format!("instantiationToken=\"{}\"", Shaker::GUID)));
    assert!(xml.contains("providesDirectionalDerivatives=\"true\""));
}

fn inputs(k: usize) -> Vec<(u32, f64)> {
    let t = k as f64 * 2e-5;
    vec![
        (VR_X, 1e-5 * (400.0 * t).sin()),
        (VR_V, 4e-3 * (400.0 * t).cos()),
    ]
}

#[test]
fn fmi3_co_simulation_equals_fmi2_bit_for_bit() {
    let n = cs_equals_fmi2::<Shaker>(None, &[], &inputs, 2e-5, 200).unwrap();
    assert_eq!(n, 200 * 6);
}

#[test]
fn fmi3_model_exchange_derivatives_equal_fmi2() {
    let states = [
        vec![0.0, 0.0, 0.0],
        vec![0.1, 1e-5, -3e-3],
        vec![-2.0, 2e-4, 0.5],
    ];
    me_equals_fmi2::<Shaker>(None, &[(VR_X, 1e-5), (VR_U_EXT, 0.5)], &states).unwrap();
}

#[test]
fn fmi3_fmu_state_round_trips_and_is_the_fmi2_blob() {
    state_round_trip::<Shaker>(None, &[], &[(VR_X, 2e-6), (VR_V, 1e-3)], 2e-5).unwrap();
}

#[test]
fn fmi3_directional_derivatives_equal_central_differences() {
    // CS: 6 outputs x 3 inputs; ME: 3 state derivatives x (3 inputs + 3 states)
    let n = directional_derivatives::<Shaker>(
        None,
        &[],
        &[(VR_X, 1e-5), (VR_V, 2e-3), (VR_U_EXT, 0.3)],
        2e-5,
        1e-6,
    )
    .unwrap();
    assert_eq!(n, 6 * 3 + 3 * 6);
}

#[test]
fn fmi3_fuzz_no_crash_no_hang_no_nan() {
    let c = fuzz::<Shaker>(None, 0x5EED_3002, 8, 300);
    eprintln!("fmi3 fuzz shaker: {c:?}");
    assert_eq!((c.hung, c.accepted_wrong), (0, 0), "{c:?}");
    assert!(c.steps_ok > 0, "{c:?}");
}

#[test]
fn exported_fmi3_symbols_answer() {
    let v = unsafe { std::ffi::CStr::from_ptr(shaker::fmi3GetVersion()) };
    assert_eq!(v.to_str().unwrap(), "3.0");
    let c = instantiate3::<Shaker>(false, None);
    let mut n = 0usize;
    assert_eq!(
        unsafe { shaker::fmi3GetNumberOfContinuousStates(c, &mut n) },
        fmi2_export::Status::Ok
    );
    assert_eq!(n, 3);
    unsafe { shaker::fmi3FreeInstance(c) };
}
