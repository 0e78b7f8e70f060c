//! The FMI 3.0 interface of the controller FMU (Co-Simulation only),
//! in-process: the checked-in FMI 3.0 modelDescription is the rendered one,
//! steps equal FMI 2.0's bit for bit, FMU states round trip,
//! `fmi3GetDirectionalDerivative` equals a central difference of the FMU's
//! outputs (all zero: the inputs are sampled at the start of a step), Model
//! Exchange is refused, and random call sequences neither crash, hang nor
//! return non-finite values with fmi3OK.
use std::path::Path;

use controller::model::*;
use fmi2_export::testing3::*;
use fmi2_export::CoSimModel;

#[test]
fn model_description_fmi3_is_the_one_the_code_gives() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../modelDescription/controller_fmi3/modelDescription.xml");
    let xml = fmi2_export::testing::check_model_description_file3::<Controller>(&path)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(xml.contains(&format!("instantiationToken=\"{}\"", Controller::GUID)));
    assert!(!xml.contains("<ModelExchange"));
}

fn inputs(k: usize) -> Vec<(u32, f64)> {
    let t = k as f64 * 1e-4;
    vec![
        (VR_F_MEAS, 2.0 * (356.2 * t).cos()),
        (VR_X_DRIVE, 1e-5 * (356.2 * t).sin()),
    ]
}

#[test]
fn fmi3_co_simulation_equals_fmi2_bit_for_bit() {
    // 0.2 s: about 11 periods, so the loop updates Omega several times
    let steps = 2000;
    let n = cs_equals_fmi2::<Controller>(None, &[], &inputs, 1e-4, steps).unwrap();
    assert!(n >= steps);
}

#[test]
fn fmi3_fmu_state_round_trips_and_is_the_fmi2_blob() {
    state_round_trip::<Controller>(None, &[], &[(VR_F_MEAS, 1.0), (VR_X_DRIVE, 1e-5)], 1e-4)
        .unwrap();
}

#[test]
fn fmi3_directional_derivatives_equal_central_differences() {
    let n = directional_derivatives::<Controller>(
        None,
        &[],
        &[(VR_F_MEAS, 1.0), (VR_X_DRIVE, 1e-5)],
        1e-4,
        1e-6,
    )
    .unwrap();
    assert!(n > 0);
}

#[test]
fn fmi3_model_exchange_is_refused() {
    assert!(instantiate3::<Controller>(false, None).is_null());
}

#[test]
fn fmi3_fuzz_no_crash_no_hang_no_nan() {
    let c = fuzz::<Controller>(None, 0x5EED_3003, 6, 300);
    eprintln!("fmi3 fuzz controller: {c:?}");
    assert_eq!((c.hung, c.accepted_wrong), (0, 0), "{c:?}");
    assert!(c.steps_ok > 0, "{c:?}");
}
