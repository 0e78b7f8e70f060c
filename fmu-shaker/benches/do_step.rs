//! Time per `fmi2DoStep` of the shaker FMU, called through the exported C
//! functions (layer checks included), at the co-simulation macro step 1e-5 s
//! and at 1e-3 s, with new inputs set before every step as a master does.
use std::ffi::{c_char, c_void, CString};

use criterion::{criterion_group, criterion_main, Criterion};
/// The logger's fixed arguments without the C variadic tail.
type PlainLogger =
    unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char);

use fmi2_export::types::{CallbackFunctions, CallbackLogger, Status, FMI2_CO_SIMULATION};
use shaker::model::{GUID, VR_F, VR_V, VR_X};
use shaker::*;

unsafe extern "C" fn quiet(
    _: *mut c_void,
    _: *const c_char,
    _: Status,
    _: *const c_char,
    _: *const c_char,
) {
}

fn bench(c: &mut Criterion) {
    let f: PlainLogger = quiet;
    let cb = CallbackFunctions {
        // non-variadic logger through the variadic type: no variadic arguments are passed
        logger: Some(unsafe { std::mem::transmute::<PlainLogger, CallbackLogger>(f) }),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: std::ptr::null_mut(),
    };
    let guid = CString::new(GUID).unwrap();
    for h in [1e-5, 1e-3] {
        let comp = unsafe {
            fmi2Instantiate(
                c"bench".as_ptr(),
                FMI2_CO_SIMULATION,
                guid.as_ptr(),
                std::ptr::null(),
                &cb,
                0,
                0,
            )
        };
        assert!(!comp.is_null());
        unsafe {
            assert_eq!(fmi2SetupExperiment(comp, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
            assert_eq!(fmi2EnterInitializationMode(comp), Status::Ok);
            assert_eq!(fmi2ExitInitializationMode(comp), Status::Ok);
        }
        let mut t: f64 = 0.0;
        c.bench_function(
            &format!("shaker fmi2DoStep h={h:e} s (set x, v; step; get F)"),
            |b| {
                b.iter(|| unsafe {
                    let vrs = [VR_X, VR_V];
                    let xv = [1e-6 * (300.0 * t).sin(), 3e-4 * (300.0 * t).cos()];
                    fmi2SetReal(comp, vrs.as_ptr(), 2, xv.as_ptr());
                    let st = fmi2DoStep(comp, t, h, 1);
                    t += h;
                    let mut f = 0.0;
                    fmi2GetReal(comp, &VR_F, 1, &mut f);
                    (st, f)
                })
            },
        );
        unsafe { fmi2FreeInstance(comp) };
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
