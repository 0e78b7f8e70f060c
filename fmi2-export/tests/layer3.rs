//! Calls the exported `fmi3*` functions of a tiny model in-process (the
//! symbols `export_fmu3!` writes): the FMI 3.0 logger (not variadic, `%`
//! passed as is), the state machine and argument checks shared with FMI 2.0
//! under FMI 3.0 names, value references unique over the types (an Int32 and
//! a String sharing a Float64's FMI 2.0 number are offset), the independent
//! variable `time`, panics, and the features the layer refuses.
use std::ffi::{c_void, CStr, CString};
use std::os::raw::c_char;
use std::sync::Mutex;

use fmi2_export::render3::{type_offset, TIME_VALUE_REFERENCE};
use fmi2_export::*;

/// y = k u after each step; n (Int32, FMI 2.0 value reference 0, as k), on
/// (Boolean), s (String, value reference 0); a step with u == 13 panics.
#[derive(Clone)]
struct Gain {
    k: f64,
    u: f64,
    y: f64,
    n: i32,
    on: bool,
}

const VARS: &[Variable] = &[
    Variable::real(
        "k",
        0,
        Causality::Parameter,
        Variability::Fixed,
        Some(2.0),
        "",
    )
    .describe("gain"),
    Variable::real(
        "u",
        1,
        Causality::Input,
        Variability::Continuous,
        Some(0.0),
        "",
    )
    .describe("input"),
    Variable::real("y", 2, Causality::Output, Variability::Continuous, None, "").describe("output"),
    Variable::integer_parameter("n", 0, 7).describe("a number"),
    Variable::boolean_parameter("on", 5, true).describe("a flag"),
    Variable::string_parameter("s", 0, "abc").describe("a text"),
];

impl CoSimModel for Gain {
    const MODEL_IDENTIFIER: &'static str = "gain3";
    const GUID: &'static str = "{gain3-test}";
    const VARIABLES: &'static [Variable] = VARS;
    const INFO: ModelInfo = ModelInfo {
        name: "gain3",
        description: "test",
        version: None,
        generation_tool: "test",
        capabilities: Capabilities {
            can_handle_variable_communication_step_size: true,
            can_interpolate_inputs: false,
            max_output_derivative_order: 0,
            provides_directional_derivative: false,
        },
        units: &[],
        log_categories: LOG_CATEGORY_DESCRIPTIONS,
        default_experiment: DefaultExperiment {
            start_time: None,
            stop_time: None,
            tolerance: None,
            step_size: None,
        },
        model_structure: ModelStructure {
            outputs: &[],
            derivatives: &[],
            initial_unknowns: &[],
        },
    };
    fn instantiate(_: &InstantiateContext<'_>) -> Result<Self, ModelError> {
        Ok(Gain {
            k: 2.0,
            u: 0.0,
            y: 0.0,
            n: 7,
            on: true,
        })
    }
    fn get_real(&self, vr: u32) -> f64 {
        [self.k, self.u, self.y][vr as usize]
    }
    fn set_real(&mut self, vr: u32, v: f64) -> Result<(), ModelError> {
        if vr == 0 && v > 100.0 {
            return Err(ModelError::error(format!("k = {v} is above 100%")));
        }
        if vr == 0 {
            self.k = v
        } else {
            self.u = v
        }
        Ok(())
    }
    fn get_integer(&self, _: u32) -> Result<i32, ModelError> {
        Ok(self.n)
    }
    fn set_integer(&mut self, _: u32, v: i32) -> Result<(), ModelError> {
        self.n = v;
        Ok(())
    }
    fn get_boolean(&self, _: u32) -> Result<bool, ModelError> {
        Ok(self.on)
    }
    fn set_boolean(&mut self, _: u32, v: bool) -> Result<(), ModelError> {
        self.on = v;
        Ok(())
    }
    fn get_string(&self, _: u32) -> Result<String, ModelError> {
        Ok("abc".into())
    }
    fn do_step(&mut self, _t: f64, _h: f64, _log: &Logger) -> Result<(), ModelError> {
        assert!(self.u != 13.0, "u is 13");
        self.y = self.k * self.u;
        Ok(())
    }
    fn serialize_state(&self, w: &mut StateWriter) {
        w.f64(self.k);
        w.f64(self.u);
        w.f64(self.y);
    }
    fn deserialize_state(&mut self, r: &mut StateReader<'_>) -> Result<(), ModelError> {
        self.k = r.f64()?;
        self.u = r.f64()?;
        self.y = r.f64()?;
        Ok(())
    }
}

fmi2_export::export_fmu!(Gain);
fmi2_export::export_fmu3!(Gain);

static LOG: Mutex<Vec<(i32, String, String)>> = Mutex::new(Vec::new());

unsafe extern "C" fn logger(
    _: *mut c_void,
    status: Status,
    cat: *const c_char,
    msg: *const c_char,
) {
    let s = |p: *const c_char| CStr::from_ptr(p).to_string_lossy().into_owned();
    LOG.lock().unwrap().push((status as i32, s(cat), s(msg)));
}

fn take_log() -> Vec<(i32, String, String)> {
    std::mem::take(&mut *LOG.lock().unwrap())
}

fn instantiate(token: &str) -> *mut c_void {
    let name = CString::new("g").unwrap();
    let token = CString::new(token).unwrap();
    unsafe {
        fmi3InstantiateCoSimulation(
            name.as_ptr(),
            token.as_ptr(),
            std::ptr::null(),
            false,
            true,
            false,
            false,
            std::ptr::null(),
            0,
            std::ptr::null_mut(),
            Some(logger),
            None,
        )
    }
}

/// One test: the logger is process-global.
#[test]
fn fmi3_layer_through_the_exported_symbols() {
    take_log();
    // wrong token: NULL, logged
    assert!(instantiate("{other}").is_null());
    let log = take_log();
    assert!(
        log.iter()
            .any(|(s, _, m)| *s == 3 && m.contains("instantiationToken mismatch")),
        "{log:?}"
    );
    // Model Exchange of a CS-only model: NULL, logged
    let name = c"g";
    let token = CString::new(Gain::GUID).unwrap();
    let me = unsafe {
        fmi3InstantiateModelExchange(
            name.as_ptr(),
            token.as_ptr(),
            std::ptr::null(),
            false,
            false,
            std::ptr::null_mut(),
            Some(logger),
        )
    };
    assert!(me.is_null());
    assert!(take_log()
        .iter()
        .any(|(_, _, m)| m.contains("Co-Simulation only")));

    let c = instantiate(Gain::GUID);
    assert!(!c.is_null());
    let (mut ev, mut term, mut early, mut last) = (true, true, true, -1.0);
    // a step before initialization: illegal call sequence, FMI 3.0 name, out parameters set
    let s = unsafe {
        fmi3DoStep(
            c, 0.0, 0.1, false, &mut ev, &mut term, &mut early, &mut last,
        )
    };
    assert_eq!(s, Status::Error);
    assert_eq!((ev, term, early, last), (false, false, false, 0.0));
    let log = take_log();
    assert!(
        log.iter().any(
            |(_, _, m)| m == "fmi3DoStep: illegal call sequence (called in state Instantiated)"
        ),
        "{log:?}"
    );
    unsafe { fmi3Reset(c) };
    // a model error with '%': passed as is (FMI 3.0 logger is not variadic)
    let (k, big) = (0u32, 500.0);
    assert_eq!(unsafe { fmi3SetFloat64(c, &k, 1, &big, 1) }, Status::Error);
    let log = take_log();
    assert!(
        log.iter()
            .any(|(_, c, m)| c == "logStatusError" && m == "fmi3SetFloat64: k = 500 is above 100%"),
        "{log:?}"
    );
    unsafe { fmi3Reset(c) };
    // value references: Int32 n and String s share 0 with Float64 k: offset
    let (vn, vs, von) = (
        type_offset(VarType::Integer),
        type_offset(VarType::String),
        5u32,
    );
    unsafe {
        assert_eq!(
            fmi3EnterInitializationMode(c, false, 0.0, 0.0, true, 1.0),
            Status::Ok
        );
        let mut n = 0;
        assert_eq!(fmi3GetInt32(c, &vn, 1, &mut n, 1), Status::Ok);
        assert_eq!(n, 7);
        let mut b = false;
        assert_eq!(fmi3GetBoolean(c, &von, 1, &mut b, 1), Status::Ok);
        assert!(b);
        let f = 0u8;
        assert_eq!(fmi3SetBoolean(c, &von, 1, &f, 1), Status::Ok);
        assert_eq!(fmi3GetBoolean(c, &von, 1, &mut b, 1), Status::Ok);
        assert!(!b);
        let mut p: *const c_char = std::ptr::null();
        assert_eq!(fmi3GetString(c, &vs, 1, &mut p, 1), Status::Ok);
        assert_eq!(CStr::from_ptr(p).to_str().unwrap(), "abc");
        assert_eq!(fmi3ExitInitializationMode(c), Status::Ok);
        // u = 3, two steps; time through its value reference
        let (u, three) = (1u32, 3.0);
        assert_eq!(fmi3SetFloat64(c, &u, 1, &three, 1), Status::Ok);
        assert_eq!(
            fmi3DoStep(c, 0.0, 0.25, false, &mut ev, &mut term, &mut early, &mut last),
            Status::Ok
        );
        assert_eq!(last, 0.25);
        let vrs = [2u32, TIME_VALUE_REFERENCE];
        let mut v = [0.0; 2];
        assert_eq!(
            fmi3GetFloat64(c, vrs.as_ptr(), 2, v.as_mut_ptr(), 2),
            Status::Ok
        );
        assert_eq!(v, [6.0, 0.25]);
        // nValues != nValueReferences
        assert_eq!(
            fmi3GetFloat64(c, vrs.as_ptr(), 2, v.as_mut_ptr(), 1),
            Status::Error
        );
        assert!(take_log()
            .iter()
            .any(|(_, _, m)| m.contains("nValues = 1 but nValueReferences = 2")));
    }
    unsafe { fmi3Reset(c) };
    take_log();
    unsafe {
        // other types and features: fmi3Error with the reason, none at all: fmi3OK
        assert_eq!(
            fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0),
            Status::Ok
        );
        let mut x = 0f32;
        assert_eq!(fmi3GetFloat32(c, &k, 0, &mut x, 0), Status::Ok);
        assert_eq!(fmi3GetFloat32(c, &k, 1, &mut x, 1), Status::Error);
        assert!(take_log()
            .iter()
            .any(|(_, _, m)| m.contains("no Float32 variables")));
        fmi3Reset(c);
        assert_eq!(fmi3EnterConfigurationMode(c), Status::Error);
        fmi3Reset(c);
        assert_eq!(fmi3EnterStepMode(c), Status::Error);
        assert!(take_log()
            .iter()
            .any(|(_, _, m)| m.contains("hasEventMode")));
        fmi3Reset(c);
        // a panic in the model: fmi3Error, logged, never across the C boundary
        assert_eq!(
            fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0),
            Status::Ok
        );
        assert_eq!(fmi3ExitInitializationMode(c), Status::Ok);
        let (u, thirteen) = (1u32, 13.0);
        assert_eq!(fmi3SetFloat64(c, &u, 1, &thirteen, 1), Status::Ok);
        assert_eq!(
            fmi3DoStep(c, 0.0, 0.1, false, &mut ev, &mut term, &mut early, &mut last),
            Status::Error
        );
        assert!(take_log()
            .iter()
            .any(|(_, _, m)| m.contains("panic") && m.contains("u is 13")));
        fmi3FreeInstance(c);
    }
    // the FMI 2.0 and FMI 3.0 symbols live side by side
    let v2 = unsafe { CStr::from_ptr(fmi2GetVersion()) };
    let v3 = unsafe { CStr::from_ptr(fmi3GetVersion()) };
    assert_eq!((v2.to_str().unwrap(), v3.to_str().unwrap()), ("2.0", "3.0"));
}
