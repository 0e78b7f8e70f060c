//! Calls the exported `fmi2*` functions of a tiny model in-process: state
//! machine, argument checks, logging, panics, FMU states, several instances.
//!
//! The FMI logger is C-variadic, which stable Rust cannot define. The test
//! logger is a non-variadic `extern "C"` function cast to the variadic type:
//! the layer never passes variadic arguments, and on x86_64/aarch64 System V a
//! variadic call with no variadic arguments is ABI-compatible with it.
use std::ffi::{c_void, CStr, CString};
use std::os::raw::c_char;
use std::sync::Mutex;

/// The logger's fixed arguments without the C variadic tail.
type PlainLogger =
    unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char);

use fmi2_export::types::*;
use fmi2_export::*;

/// x' = -x/tau + u/tau (exactly discretized), y = x + d*u; panics when u == 13.
#[derive(Clone)]
struct Lag {
    tau: f64,
    d: f64,
    u: f64,
    x: f64,
    du: f64,
    n: i32,
    on: bool,
    /// The decoded resource folder (String output `resources`).
    resources: String,
}

const VR_TAU: u32 = 0;
const VR_U: u32 = 1;
const VR_Y: u32 = 2;
const VR_D: u32 = 3;

impl CoSimModel for Lag {
    const MODEL_IDENTIFIER: &'static str = "lag";
    const GUID: &'static str = "{lag-test}";
    const VARIABLES: &'static [Variable] = &[
        Variable {
            name: "tau",
            vr: VR_TAU,
            ty: VarType::Real,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(Start::Real(0.5)),
            unit: "s",
            description: "time constant",
        },
        Variable {
            name: "u",
            vr: VR_U,
            ty: VarType::Real,
            causality: Causality::Input,
            variability: Variability::Continuous,
            start: Some(Start::Real(0.0)),
            unit: "",
            description: "input",
        },
        Variable {
            name: "y",
            vr: VR_Y,
            ty: VarType::Real,
            causality: Causality::Output,
            variability: Variability::Continuous,
            start: None,
            unit: "",
            description: "output",
        },
        Variable {
            name: "d",
            vr: VR_D,
            ty: VarType::Real,
            causality: Causality::Parameter,
            variability: Variability::Tunable,
            start: Some(Start::Real(2.0)),
            unit: "",
            description: "feedthrough",
        },
        Variable {
            name: "n",
            vr: 0,
            ty: VarType::Integer,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(Start::Integer(3)),
            unit: "",
            description: "n",
        },
        Variable {
            name: "on",
            vr: 0,
            ty: VarType::Boolean,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(Start::Boolean(true)),
            unit: "",
            description: "on",
        },
        Variable {
            name: "resources",
            vr: 0,
            ty: VarType::String,
            causality: Causality::Local,
            variability: Variability::Continuous,
            start: None,
            unit: "",
            description: "decoded resource folder",
        },
    ];
    const INFO: ModelInfo = ModelInfo {
        name: "lag",
        description: "first-order lag with feedthrough",
        version: None,
        generation_tool: "fmi2-export tests",
        capabilities: Capabilities {
            can_handle_variable_communication_step_size: true,
            can_interpolate_inputs: false,
            max_output_derivative_order: 0,
            provides_directional_derivative: false,
        },
        units: &[],
        log_categories: LOG_CATEGORY_DESCRIPTIONS,
        default_experiment: DefaultExperiment {
            start_time: Some(0.0),
            stop_time: Some(1.0),
            tolerance: None,
            step_size: Some(0.1),
        },
        model_structure: ModelStructure {
            outputs: &[Dependencies::fixed("y", &["u"])],
            derivatives: &[],
            initial_unknowns: &[Dependencies::on("y", &["u", "d"])],
        },
    };
    fn instantiate(ctx: &InstantiateContext<'_>) -> Result<Self, ModelError> {
        let resources = ctx
            .resource_dir
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_default();
        Ok(Lag {
            tau: 0.5,
            d: 2.0,
            u: 0.0,
            x: 0.0,
            du: 0.0,
            n: 3,
            on: true,
            resources,
        })
    }
    fn get_string(&self, _: u32) -> Result<String, ModelError> {
        Ok(self.resources.clone())
    }
    fn exit_initialization_mode(&mut self, _: &Logger) -> Result<(), ModelError> {
        if self.tau <= 0.0 {
            return Err(ModelError::error(format!(
                "tau must be positive, got {} s",
                self.tau
            )));
        }
        Ok(())
    }
    fn get_real(&self, vr: u32) -> f64 {
        match vr {
            VR_TAU => self.tau,
            VR_U => self.u,
            VR_Y => self.x + self.d * self.u,
            VR_D => self.d,
            _ => unreachable!(),
        }
    }
    fn set_real(&mut self, vr: u32, v: f64) -> Result<(), ModelError> {
        match vr {
            VR_TAU => self.tau = v,
            VR_U => self.u = v,
            VR_D => self.d = v,
            _ => unreachable!(),
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
    fn do_step(&mut self, _t: f64, h: f64, log: &Logger) -> Result<(), ModelError> {
        if self.u == 13.0 {
            panic!("unlucky input");
        }
        if h > 10.0 {
            return Err(ModelError::discard(format!(
                "step {h} s too large, 100% sure"
            )));
        }
        let e = (-h / self.tau).exp();
        self.x = e * self.x + (1.0 - e) * self.u;
        self.u += self.du * h;
        log.info("stepped");
        Ok(())
    }
    fn set_real_input_derivative(
        &mut self,
        _vr: u32,
        order: u32,
        v: f64,
    ) -> Result<(), ModelError> {
        if order != 1 {
            return Err(ModelError::error(format!("only order 1, got {order}")));
        }
        self.du = v;
        Ok(())
    }
    fn partial_derivative(&self, unknown: u32, known: u32) -> Result<f64, ModelError> {
        Ok(if unknown == VR_Y && known == VR_U {
            self.d
        } else {
            0.0
        })
    }
    fn serialize_state(&self, w: &mut StateWriter) {
        w.f64s(&[self.tau, self.d, self.u, self.x, self.du]);
    }
    fn deserialize_state(&mut self, r: &mut StateReader<'_>) -> Result<(), ModelError> {
        let v = r.f64s(5)?;
        (self.tau, self.d, self.u, self.x, self.du) = (v[0], v[1], v[2], v[3], v[4]);
        Ok(())
    }
}

fmi2_export::export_fmu!(Lag);

/// Messages received by the logger: (instance, status, category, message).
type Log = Mutex<Vec<(String, Status, String, String)>>;

unsafe extern "C" fn record(
    env: *mut c_void,
    name: *const c_char,
    status: Status,
    cat: *const c_char,
    msg: *const c_char,
) {
    assert!(!env.is_null() && !name.is_null() && !cat.is_null() && !msg.is_null());
    let log = &*(env as *const Log);
    let s = |p| CStr::from_ptr(p).to_string_lossy().into_owned();
    log.lock().unwrap().push((s(name), status, s(cat), s(msg)));
}

fn callbacks(log: &Log) -> CallbackFunctions {
    let f: PlainLogger = record;
    CallbackFunctions {
        // SAFETY: see the module doc (no variadic arguments are ever passed).
        logger: Some(unsafe { std::mem::transmute::<PlainLogger, CallbackLogger>(f) }),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: log as *const Log as *mut c_void,
    }
}

struct Inst {
    c: Component,
    _cb: Box<CallbackFunctions>,
}

impl Drop for Inst {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) }
    }
}

fn new(log: &Log, name: &str, guid: &str, res: Option<&str>) -> Option<Inst> {
    let cb = Box::new(callbacks(log));
    let name = CString::new(name).unwrap();
    let guid = CString::new(guid).unwrap();
    let res = res.map(|r| CString::new(r).unwrap());
    let c = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            res.as_ref().map_or(std::ptr::null(), |r| r.as_ptr()),
            &*cb,
            0,
            0,
        )
    };
    (!c.is_null()).then_some(Inst { c, _cb: cb })
}

fn init(i: &Inst) {
    unsafe {
        assert_eq!(fmi2SetupExperiment(i.c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(i.c), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(i.c), Status::Ok);
    }
}

fn get(i: &Inst, vr: u32) -> f64 {
    let mut v = f64::NAN;
    assert_eq!(unsafe { fmi2GetReal(i.c, &vr, 1, &mut v) }, Status::Ok);
    v
}

fn set(i: &Inst, vr: u32, v: f64) -> Status {
    unsafe { fmi2SetReal(i.c, &vr, 1, &v) }
}

fn last(log: &Log) -> (String, Status, String, String) {
    log.lock().unwrap().last().cloned().expect("a log message")
}

fn resources_of(log: &Log, uri: &str) -> String {
    let i = new(log, "res", Lag::GUID, Some(uri)).unwrap();
    init(&i);
    let mut p: FmiString = std::ptr::null();
    assert_eq!(unsafe { fmi2GetString(i.c, &0, 1, &mut p) }, Status::Ok);
    unsafe { CStr::from_ptr(p) }.to_str().unwrap().to_string()
}

#[test]
fn resource_location_reaches_the_model_decoded() {
    let log = Log::default();
    assert_eq!(
        resources_of(&log, "file:///tmp/my%20fmu%25/resources"),
        "/tmp/my fmu%/resources"
    );
    assert_eq!(
        resources_of(&log, "file:////tmp/x y/resources"),
        "/tmp/x y/resources"
    );
    assert_eq!(resources_of(&log, "file:/tmp/r"), "/tmp/r");
    assert!(log.lock().unwrap().is_empty());
}

#[test]
fn version_and_platform() {
    unsafe {
        assert_eq!(CStr::from_ptr(fmi2GetVersion()).to_str().unwrap(), "2.0");
        assert_eq!(
            CStr::from_ptr(fmi2GetTypesPlatform()).to_str().unwrap(),
            "default"
        );
    }
}

#[test]
fn steps_match_the_exact_solution() {
    let log = Log::default();
    let i = new(&log, "a", Lag::GUID, None).unwrap();
    init(&i);
    assert_eq!(set(&i, VR_U, 1.0), Status::Ok);
    let (mut t, h) = (0.0, 0.1);
    for _ in 0..10 {
        assert_eq!(unsafe { fmi2DoStep(i.c, t, h, 0) }, Status::Ok);
        t += h;
    }
    // y = 1 - exp(-t/tau) + d u
    let expect = 1.0 - (-1.0f64 / 0.5).exp() + 2.0;
    assert!((get(&i, VR_Y) - expect).abs() < 1e-14, "{}", get(&i, VR_Y));
    let mut ts = 0.0;
    assert_eq!(
        unsafe { fmi2GetRealStatus(i.c, FMI2_LAST_SUCCESSFUL_TIME, &mut ts) },
        Status::Ok
    );
    assert!((ts - 1.0).abs() < 1e-12);
    let mut term = 7;
    assert_eq!(
        unsafe { fmi2GetBooleanStatus(i.c, FMI2_TERMINATED, &mut term) },
        Status::Ok
    );
    assert_eq!(term, FMI2_FALSE);
    assert!(log.lock().unwrap().iter().all(|m| m.1 < Status::Warning));
    let mut st = Status::Ok;
    assert_eq!(
        unsafe { fmi2GetStatus(i.c, FMI2_DO_STEP_STATUS, &mut st) },
        Status::Discard
    );
    assert_eq!(last(&log).1, Status::Discard);
    // integer and boolean round trip with start values
    let (mut n, mut b) = (0, 0);
    unsafe {
        assert_eq!(fmi2GetInteger(i.c, &0, 1, &mut n), Status::Ok);
        assert_eq!(fmi2GetBoolean(i.c, &0, 1, &mut b), Status::Ok);
    }
    assert_eq!((n, b), (3, 1));
    assert_eq!(unsafe { fmi2Terminate(i.c) }, Status::Ok);
}

#[test]
fn instantiate_rejects_bad_guid_type_and_name() {
    let log = Log::default();
    assert!(new(&log, "a", "{wrong}", None).is_none());
    let m = last(&log);
    assert_eq!(m.1, Status::Error);
    assert!(
        m.3.contains("GUID mismatch") && m.3.contains("{wrong}") && m.3.contains(Lag::GUID),
        "{}",
        m.3
    );
    assert!(new(&log, "", Lag::GUID, None).is_none());
    assert!(last(&log).3.contains("instanceName"));
    let cb = callbacks(&log);
    let c = unsafe {
        fmi2Instantiate(
            c"x".as_ptr(),
            FMI2_MODEL_EXCHANGE,
            c"{lag-test}".as_ptr(),
            std::ptr::null(),
            &cb,
            0,
            0,
        )
    };
    assert!(c.is_null());
    assert!(last(&log).3.contains("fmuType"));
    let c = unsafe {
        fmi2Instantiate(
            c"x".as_ptr(),
            1,
            c"{lag-test}".as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            0,
            0,
        )
    };
    assert!(c.is_null());
    // a bad resource URI is only a warning
    assert!(new(&log, "r", Lag::GUID, Some("http://example/x")).is_some());
    assert_eq!(last(&log).1, Status::Warning);
}

#[test]
fn illegal_call_sequence_is_refused_and_logged() {
    let log = Log::default();
    let i = new(&log, "seq", Lag::GUID, None).unwrap();
    unsafe {
        assert_eq!(fmi2DoStep(i.c, 0.0, 0.1, 0), Status::Error);
        let m = last(&log);
        assert_eq!(
            (m.0.as_str(), m.1, m.2.as_str()),
            ("seq", Status::Error, "logStatusError")
        );
        assert!(m.3.contains("fmi2DoStep: illegal call sequence"), "{}", m.3);
        let mut v = 0.0;
        assert_eq!(fmi2GetReal(i.c, &VR_Y, 1, &mut v), Status::Error);
        assert_eq!(fmi2ExitInitializationMode(i.c), Status::Error);
        assert_eq!(fmi2CancelStep(i.c), Status::Error);
        // the state was not changed: normal use still works
        init(&i);
        assert_eq!(fmi2SetupExperiment(i.c, 0, 0.0, 0.0, 0, 0.0), Status::Error);
        assert_eq!(fmi2DoStep(i.c, 0.0, 0.1, 0), Status::Ok);
        // a fixed parameter cannot be set after initialization, a tunable one can
        assert_eq!(set(&i, VR_D, 3.0), Status::Ok);
        assert_eq!(get(&i, VR_D), 3.0);
        assert_eq!(set(&i, VR_TAU, 1.0), Status::Error);
        assert!(
            last(&log).3.contains("tau (value reference 0"),
            "{}",
            last(&log).3
        );
        // now in the error state: only reset helps
        assert_eq!(fmi2DoStep(i.c, 0.1, 0.1, 0), Status::Error);
        assert_eq!(fmi2Reset(i.c), Status::Ok);
        init(&i);
        assert_eq!(get(&i, VR_D), 2.0);
        assert_eq!(fmi2DoStep(i.c, 0.0, 0.1, 0), Status::Ok);
    }
}

/// A misuse and the text its log message must contain.
type Case = (Box<dyn Fn(&Inst) -> Status>, &'static str);

#[test]
fn bad_arguments_are_errors_with_numbers() {
    let log = Log::default();
    let cases: Vec<Case> = vec![
        (Box::new(|i| set(i, 99, 1.0)), "unknown value reference 99"),
        (
            Box::new(|i| set(i, VR_U, f64::NAN)),
            "must be finite, got NaN",
        ),
        (
            Box::new(|i| set(i, VR_U, f64::INFINITY)),
            "must be finite, got inf",
        ),
        (Box::new(|i| set(i, VR_Y, 1.0)), "cannot be set"),
        (
            Box::new(|i| unsafe { fmi2DoStep(i.c, 0.0, -0.1, 0) }),
            "communicationStepSize must be positive and finite, got -0.1",
        ),
        (
            Box::new(|i| unsafe { fmi2DoStep(i.c, 0.0, 0.0, 0) }),
            "got 0",
        ),
        (
            Box::new(|i| unsafe { fmi2DoStep(i.c, 0.5, 0.1, 0) }),
            "expected currentCommunicationPoint = 0 but was 0.5",
        ),
        (
            Box::new(|i| unsafe { fmi2GetReal(i.c, std::ptr::null(), 1, &mut 0.0) }),
            "argument vr is a NULL pointer",
        ),
        (
            Box::new(|i| unsafe { fmi2SetReal(i.c, &VR_U, 1, std::ptr::null()) }),
            "argument value is a NULL pointer",
        ),
        (
            Box::new(|i| unsafe { fmi2GetReal(i.c, &7, 1, &mut 0.0) }),
            "unknown value reference 7",
        ),
        (
            Box::new(|i| unsafe { fmi2GetInteger(i.c, &5, 1, &mut 0) }),
            "unknown value reference 5",
        ),
        (
            Box::new(|i| unsafe { fmi2SetRealInputDerivatives(i.c, &VR_U, 1, &0, &1.0) }),
            "order must be >= 1, got 0",
        ),
        (
            Box::new(|i| unsafe { fmi2SetRealInputDerivatives(i.c, &VR_Y, 1, &1, &1.0) }),
            "y (value reference 2) is not an input",
        ),
        (
            Box::new(|i| unsafe { fmi2GetRealOutputDerivatives(i.c, &VR_Y, 1, &1, &mut 0.0) }),
            "output derivatives are not supported",
        ),
        (
            Box::new(|i| unsafe { fmi2SetDebugLogging(i.c, 1, 1, [c"logNope".as_ptr()].as_ptr()) }),
            "unknown log category \"logNope\"",
        ),
        (
            Box::new(|i| unsafe { fmi2SetTime(i.c, 1.0) }),
            "fmi2SetTime: this FMU implements Co-Simulation only",
        ),
        (
            Box::new(|i| unsafe { fmi2GetDerivatives(i.c, std::ptr::null_mut(), 0) }),
            "fmi2GetDerivatives: this FMU implements Co-Simulation only",
        ),
        (
            Box::new(|i| unsafe { fmi2DoStep(i.c, 0.0, 11.0, 0) }),
            "too large, 100%% sure",
        ),
    ];
    for (f, expect) in cases {
        let i = new(&log, "bad", Lag::GUID, None).unwrap();
        init(&i);
        let st = f(&i);
        assert!(st >= Status::Discard, "{expect}: {st:?}");
        let m = last(&log);
        assert!(m.3.contains(expect), "expected {expect:?} in {:?}", m.3);
    }
    // the literal % reached the logger escaped for vsnprintf
    assert!(last(&log).3.contains("100%% sure"));
    // a discarded step leaves the instance in stepFailed, where terminate is allowed
    let i = new(&log, "disc", Lag::GUID, None).unwrap();
    init(&i);
    assert_eq!(unsafe { fmi2DoStep(i.c, 0.0, 11.0, 0) }, Status::Discard);
    assert_eq!(unsafe { fmi2DoStep(i.c, 0.0, 0.1, 0) }, Status::Error);
    assert_eq!(unsafe { fmi2Terminate(i.c) }, Status::Ok);
}

#[test]
fn panics_never_cross_the_boundary() {
    let log = Log::default();
    let i = new(&log, "p", Lag::GUID, None).unwrap();
    init(&i);
    assert_eq!(set(&i, VR_U, 13.0), Status::Ok);
    assert_eq!(unsafe { fmi2DoStep(i.c, 0.0, 0.1, 0) }, Status::Error);
    assert!(last(&log)
        .3
        .contains("internal error (panic): unlucky input"));
    assert_eq!(unsafe { fmi2Reset(i.c) }, Status::Ok);
}

#[test]
fn exit_init_validates_parameters() {
    let log = Log::default();
    let i = new(&log, "v", Lag::GUID, None).unwrap();
    assert_eq!(set(&i, VR_TAU, -1.0), Status::Ok);
    unsafe {
        assert_eq!(fmi2EnterInitializationMode(i.c), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(i.c), Status::Error);
    }
    assert!(last(&log).3.contains("tau must be positive, got -1 s"));
}

fn run_steps(i: &Inst, t0: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| {
            let t = t0 + k as f64 * 0.05;
            set(i, VR_U, (3.0 * t).sin());
            assert_eq!(unsafe { fmi2DoStep(i.c, t, 0.05, 0) }, Status::Ok);
            get(i, VR_Y)
        })
        .collect()
}

#[test]
fn fmu_state_round_trips_reproduce_the_trajectory() {
    let log = Log::default();
    let i = new(&log, "s", Lag::GUID, None).unwrap();
    init(&i);
    unsafe {
        assert_eq!(
            fmi2SetRealInputDerivatives(i.c, &VR_U, 1, &1, &0.5),
            Status::Ok
        )
    };
    run_steps(&i, 0.0, 7);
    let mut s: FmuState = std::ptr::null_mut();
    unsafe { assert_eq!(fmi2GetFMUstate(i.c, &mut s), Status::Ok) };
    let a = run_steps(&i, 0.35, 10);
    unsafe { assert_eq!(fmi2SetFMUstate(i.c, s), Status::Ok) };
    let b = run_steps(&i, 0.35, 10);
    assert_eq!(a, b);
    // serialize, continue elsewhere, deserialize into a new state
    let mut size = 0usize;
    unsafe { assert_eq!(fmi2SerializedFMUstateSize(i.c, s, &mut size), Status::Ok) };
    let mut buf = vec![0 as Byte; size];
    unsafe {
        assert_eq!(
            fmi2SerializeFMUstate(i.c, s, buf.as_mut_ptr(), size),
            Status::Ok
        )
    };
    let j = new(&log, "other", Lag::GUID, None).unwrap();
    let mut s2: FmuState = std::ptr::null_mut();
    unsafe {
        assert_eq!(
            fmi2DeSerializeFMUstate(j.c, buf.as_ptr(), size, &mut s2),
            Status::Ok
        );
        assert_eq!(fmi2SetFMUstate(j.c, s2), Status::Ok);
    }
    let c = run_steps(&j, 0.35, 10);
    assert_eq!(a, c);
    // corrupt buffers are rejected
    unsafe {
        let mut s3: FmuState = std::ptr::null_mut();
        assert_eq!(
            fmi2DeSerializeFMUstate(j.c, buf.as_ptr(), size - 1, &mut s3),
            Status::Error
        );
        assert!(s3.is_null());
        assert!(last(&log).3.contains("truncated"), "{}", last(&log).3);
        assert_eq!(
            fmi2SerializeFMUstate(i.c, s, buf.as_mut_ptr(), size - 1),
            Status::Error
        );
        assert_eq!(fmi2FreeFMUstate(i.c, &mut s), Status::Ok);
        assert!(s.is_null());
        assert_eq!(fmi2FreeFMUstate(i.c, &mut s), Status::Ok);
        assert_eq!(fmi2FreeFMUstate(j.c, &mut s2), Status::Ok);
    }
}

#[test]
fn directional_derivative_sums_partials() {
    let log = Log::default();
    let i = new(&log, "dd", Lag::GUID, None).unwrap();
    init(&i);
    let (mut out, known) = ([0.0; 2], [VR_U, VR_D]);
    unsafe {
        assert_eq!(
            fmi2GetDirectionalDerivative(
                i.c,
                [VR_Y, VR_U].as_ptr(),
                2,
                known.as_ptr(),
                2,
                [2.0, 5.0].as_ptr(),
                out.as_mut_ptr()
            ),
            Status::Ok
        );
    }
    assert_eq!(out, [4.0, 0.0]);
}

#[test]
fn instances_are_independent_across_threads() {
    let logs: Vec<Log> = (0..4).map(|_| Log::default()).collect();
    let results: Vec<Vec<f64>> = std::thread::scope(|sc| {
        let hs: Vec<_> = logs
            .iter()
            .enumerate()
            .map(|(k, log)| {
                sc.spawn(move || {
                    let i = new(log, &format!("t{k}"), Lag::GUID, None).unwrap();
                    init(&i);
                    set(&i, VR_D, k as f64);
                    run_steps(&i, 0.0, 200)
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    // serial reference per instance
    for (k, r) in results.iter().enumerate() {
        let log = Log::default();
        let i = new(&log, "ref", Lag::GUID, None).unwrap();
        init(&i);
        set(&i, VR_D, k as f64);
        assert_eq!(&run_steps(&i, 0.0, 200), r);
    }
    assert_ne!(results[0], results[1]);
}

#[test]
fn debug_logging_switches_info_messages() {
    let log = Log::default();
    let i = new(&log, "l", Lag::GUID, None).unwrap();
    init(&i);
    unsafe { fmi2DoStep(i.c, 0.0, 0.1, 0) };
    assert!(log.lock().unwrap().is_empty());
    unsafe {
        assert_eq!(
            fmi2SetDebugLogging(i.c, 1, 1, [c"logEvents".as_ptr()].as_ptr()),
            Status::Ok
        )
    };
    unsafe { fmi2DoStep(i.c, 0.1, 0.1, 0) };
    assert_eq!(
        last(&log),
        ("l".into(), Status::Ok, "logEvents".into(), "stepped".into())
    );
}

#[test]
fn xml_checker_finds_drift() {
    let xml = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="lag" guid="{lag-test}">
  <CoSimulation modelIdentifier="lag" canHandleVariableCommunicationStepSize="true"/>
  <ModelVariables>
    <ScalarVariable name="tau" valueReference="0" causality="parameter" variability="fixed" description="time constant"><Real start="0.5" unit="s"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="1" causality="input" description="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="2" causality="output" description="output"><Real/></ScalarVariable>
    <ScalarVariable name="d" valueReference="3" causality="parameter" variability="tunable" description="feedthrough"><Real start="2"/></ScalarVariable>
    <ScalarVariable name="n" valueReference="0" causality="parameter" variability="fixed" description="n"><Integer start="3"/></ScalarVariable>
    <ScalarVariable name="on" valueReference="0" causality="parameter" variability="fixed" description="on"><Boolean start="true"/></ScalarVariable>
    <ScalarVariable name="resources" valueReference="0" description="decoded resource folder"><String/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="3" dependencies="2"/></Outputs></ModelStructure>
</fmiModelDescription>"#;
    let md =
        fmi2_export::xml::check_model_description(xml, "lag", Lag::GUID, Lag::VARIABLES).unwrap();
    assert_eq!(md.outputs[0].dependencies, Some(vec![2]));
    let m = Lag::instantiate(&InstantiateContext {
        instance_name: "x",
        resource_dir: None,
        logger: &Logger::silent(),
    })
    .unwrap();
    assert!(fmi2_export::xml::check_start_values(&m).is_empty());
    let drifted = xml
        .replace(
            r#"name="d" valueReference="3""#,
            r#"name="d" valueReference="4""#,
        )
        .replace("start=\"0.5\"", "start=\"0.6\"");
    let errs =
        fmi2_export::xml::check_model_description(&drifted, "lag", Lag::GUID, Lag::VARIABLES)
            .unwrap_err();
    assert!(
        errs.iter()
            .any(|e| e.contains("d: valueReference 4 in XML, 3 in code")),
        "{errs:?}"
    );
    assert!(errs.iter().any(|e| e.contains("tau: start")), "{errs:?}");
    let no_out = xml.replace(r#"<Unknown index="3" dependencies="2"/>"#, "");
    assert!(
        fmi2_export::xml::check_model_description(&no_out, "lag", Lag::GUID, Lag::VARIABLES)
            .is_err()
    );
}

/// Issue 14, item 6: no fmi2OK with a non-finite output (`y = x + d u` with
/// `u = 1.5e308` overflows), neither from fmi2GetReal nor from fmi2DoStep.
#[test]
fn non_finite_outputs_are_errors_not_ok() {
    let log = Log::default();
    let i = new(&log, "inf", Lag::GUID, None).unwrap();
    init(&i);
    assert_eq!(set(&i, VR_U, 1.5e308), Status::Ok);
    let mut v = 0.0;
    assert_eq!(unsafe { fmi2GetReal(i.c, &VR_Y, 1, &mut v) }, Status::Error);
    assert!(last(&log).3.contains("not finite"), "{}", last(&log).3);
    let j = new(&log, "inf-step", Lag::GUID, None).unwrap();
    init(&j);
    assert_eq!(set(&j, VR_U, 1.5e308), Status::Ok);
    assert_eq!(unsafe { fmi2DoStep(j.c, 0.0, 0.05, 1) }, Status::Error);
    assert!(last(&log).3.contains("output y = inf"), "{}", last(&log).3);
}

/// Issue 14, item 6: deserialized states with NaN/inf, an Error/Fatal state
/// code (7 left an unusable instance) or a huge GUID length are refused.
#[test]
fn corrupted_serialized_states_are_refused() {
    let log = Log::default();
    let i = new(&log, "s", Lag::GUID, None).unwrap();
    init(&i);
    let mut s: FmuState = std::ptr::null_mut();
    unsafe { assert_eq!(fmi2GetFMUstate(i.c, &mut s), Status::Ok) };
    let mut size = 0usize;
    unsafe { assert_eq!(fmi2SerializedFMUstateSize(i.c, s, &mut size), Status::Ok) };
    let mut buf = vec![0 as Byte; size];
    unsafe {
        assert_eq!(
            fmi2SerializeFMUstate(i.c, s, buf.as_mut_ptr(), size),
            Status::Ok
        );
        assert_eq!(fmi2FreeFMUstate(i.c, &mut s), Status::Ok);
    }
    let bytes: Vec<u8> = buf.iter().map(|&b| b as u8).collect();
    let code_at = 16 + Lag::GUID.len();
    let mut cases: Vec<(Vec<u8>, &str)> = Vec::new();
    for code in [6u64, 7, 8, u64::MAX] {
        let mut b = bytes.clone();
        b[code_at..code_at + 8].copy_from_slice(&code.to_le_bytes());
        cases.push((b, "bad state code"));
    }
    for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        // the time, then the last 8 bytes (a model value)
        let mut b = bytes.clone();
        b[code_at + 8..code_at + 16].copy_from_slice(&x.to_le_bytes());
        cases.push((b, "non-finite"));
        let mut b = bytes.clone();
        let n = b.len();
        b[n - 8..].copy_from_slice(&x.to_le_bytes());
        cases.push((b, "non-finite"));
    }
    let mut b = bytes.clone();
    b[8..16].copy_from_slice(&u64::MAX.to_le_bytes());
    cases.push((b, "different FMU"));
    for (b, needle) in cases {
        let mut s2: FmuState = std::ptr::null_mut();
        let st =
            unsafe { fmi2DeSerializeFMUstate(i.c, b.as_ptr() as *const Byte, b.len(), &mut s2) };
        assert_eq!(st, Status::Error, "{needle}");
        assert!(s2.is_null());
        assert!(last(&log).3.contains(needle), "{}", last(&log).3);
    }
    // the intact buffer still deserializes
    let mut s3: FmuState = std::ptr::null_mut();
    let j = new(&log, "t", Lag::GUID, None).unwrap();
    unsafe {
        assert_eq!(
            fmi2DeSerializeFMUstate(j.c, buf.as_ptr(), size, &mut s3),
            Status::Ok
        );
        assert_eq!(fmi2FreeFMUstate(j.c, &mut s3), Status::Ok);
    }
}

/// The modelDescription rendered from the code passes the drift check, and
/// tables that disagree are refused with the name at fault.
#[test]
fn rendered_model_description_agrees_with_the_code() {
    let xml = fmi2_export::render::model_description::<Lag>().unwrap();
    let md = fmi2_export::xml::check_model_description(&xml, "lag", Lag::GUID, Lag::VARIABLES)
        .unwrap_or_else(|e| panic!("{e:#?}\n{xml}"));
    assert!(md.model_exchange.is_none());
    assert_eq!(md.outputs[0].dependencies, Some(vec![2]));
    assert!(xml.contains(r#"<Unknown index="3" dependencies="2" dependenciesKind="fixed"/>"#));
    assert!(
        xml.contains(r#"<Unknown index="3" dependencies="2 4"/>"#),
        "{xml}"
    );
    assert!(xml.contains(r#"<Real unit="s" start="0.5"/>"#), "{xml}");
    assert!(
        xml.contains(r#"<Unit name="s"><BaseUnit s="1"/></Unit>"#),
        "{xml}"
    );
    assert!(xml.contains(r#"<DefaultExperiment startTime="0" stopTime="1" stepSize="0.1"/>"#));
    assert_eq!(md.guid, "{lag-test}");
    // a dependency on an output, an unknown unit: errors naming them
    let layout = fmi2_export::description::Layout::of::<Lag>().unwrap();
    assert_eq!(layout.units.len(), 1);
    #[derive(Clone)]
    struct Bad(Lag);
    impl CoSimModel for Bad {
        const MODEL_IDENTIFIER: &'static str = "bad";
        const GUID: &'static str = "{bad}";
        const VARIABLES: &'static [Variable] = &[Variable::real(
            "y",
            0,
            Causality::Output,
            Variability::Continuous,
            None,
            "furlong",
        )
        .describe("y")];
        const INFO: ModelInfo = Lag::INFO;
        fn instantiate(ctx: &InstantiateContext<'_>) -> Result<Self, ModelError> {
            Lag::instantiate(ctx).map(Bad)
        }
        fn get_real(&self, vr: u32) -> f64 {
            self.0.get_real(vr)
        }
        fn set_real(&mut self, vr: u32, v: f64) -> Result<(), ModelError> {
            self.0.set_real(vr, v)
        }
        fn do_step(&mut self, t: f64, h: f64, log: &Logger) -> Result<(), ModelError> {
            self.0.do_step(t, h, log)
        }
        fn serialize_state(&self, w: &mut StateWriter) {
            self.0.serialize_state(w)
        }
        fn deserialize_state(&mut self, r: &mut StateReader<'_>) -> Result<(), ModelError> {
            self.0.deserialize_state(r)
        }
    }
    let e = fmi2_export::render::model_description::<Bad>().unwrap_err();
    assert!(e.to_string().contains("furlong"), "{e}");
}
