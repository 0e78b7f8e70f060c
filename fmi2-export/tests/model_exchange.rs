//! The Model Exchange interface of the layer, called through the exported
//! `fmi2*` symbols of a tiny event-free model (`x' = (u - x)/tau`, `y = x`):
//! the ME state machine (Instantiated -> Initialization -> Event ->
//! Continuous-Time Mode), argument checks, finite values, FMU states, and
//! the refusal of CS functions on an ME instance and vice versa.
//!
//! The logger is a non-variadic `extern "C"` function cast to the variadic
//! type, as in `layer.rs` (the layer never passes variadic arguments).
use std::ffi::{c_void, CStr, CString};
use std::os::raw::c_char;
use std::sync::Mutex;

use fmi2_export::types::*;
use fmi2_export::*;

type PlainLogger =
    unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char);

#[derive(Clone)]
struct Lag {
    tau: f64,
    u: f64,
    x: f64,
    t: f64,
}

const VR_TAU: u32 = 0;
const VR_U: u32 = 1;
const VR_Y: u32 = 2;
const VR_DER_Y: u32 = 3;

const fn real(name: &'static str, vr: u32, causality: Causality, start: Option<f64>) -> Variable {
    Variable {
        name,
        vr,
        ty: VarType::Real,
        causality,
        variability: match causality {
            Causality::Parameter => Variability::Fixed,
            _ => Variability::Continuous,
        },
        start: match start {
            Some(s) => Some(Start::Real(s)),
            None => None,
        },
        unit: "",
        description: name,
    }
}

impl CoSimModel for Lag {
    const MODEL_IDENTIFIER: &'static str = "lag";
    const GUID: &'static str = "{lag-me}";
    const VARIABLES: &'static [Variable] = &[
        real("tau", VR_TAU, Causality::Parameter, Some(0.5)),
        real("u", VR_U, Causality::Input, Some(0.0)),
        real("y", VR_Y, Causality::Output, None),
        real("der(y)", VR_DER_Y, Causality::Local, None),
    ];
    const CONTINUOUS_STATES: &'static [ContinuousState] = &[ContinuousState {
        state_vr: VR_Y,
        derivative_vr: VR_DER_Y,
        nominal: 2.0,
    }];
    const INFO: ModelInfo = ModelInfo {
        name: "lag",
        description: "x' = (u - x)/tau, y = x",
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
            start_time: None,
            stop_time: None,
            tolerance: None,
            step_size: None,
        },
        model_structure: ModelStructure {
            outputs: &[],
            derivatives: &[Dependencies::on("der(y)", &["u", "y"])],
            initial_unknowns: &[],
        },
    };
    fn instantiate(_: &InstantiateContext<'_>) -> Result<Self, ModelError> {
        Ok(Lag {
            tau: 0.5,
            u: 0.0,
            x: 0.0,
            t: 0.0,
        })
    }
    fn get_real(&self, vr: u32) -> f64 {
        match vr {
            VR_TAU => self.tau,
            VR_U => self.u,
            VR_Y => self.x,
            _ => (self.u - self.x) / self.tau,
        }
    }
    fn set_real(&mut self, vr: u32, v: f64) -> Result<(), ModelError> {
        match vr {
            VR_TAU => self.tau = v,
            _ => self.u = v,
        }
        Ok(())
    }
    fn do_step(&mut self, _t: f64, h: f64, _: &Logger) -> Result<(), ModelError> {
        self.x = self.u + (self.x - self.u) * (-h / self.tau).exp();
        Ok(())
    }
    fn set_time(&mut self, t: f64) -> Result<(), ModelError> {
        self.t = t;
        Ok(())
    }
    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), ModelError> {
        if x[0] > 1e6 {
            return Err(ModelError::error(format!("x = {} above 1e6", x[0])));
        }
        self.x = x[0];
        Ok(())
    }
    fn derivatives(&self, dx: &mut [f64]) -> Result<(), ModelError> {
        dx[0] = self.get_real(VR_DER_Y);
        Ok(())
    }
    fn serialize_state(&self, w: &mut StateWriter) {
        w.f64s(&[self.tau, self.u, self.x, self.t]);
    }
    fn deserialize_state(&mut self, r: &mut StateReader<'_>) -> Result<(), ModelError> {
        let v = r.f64s(4)?;
        (self.tau, self.u, self.x, self.t) = (v[0], v[1], v[2], v[3]);
        Ok(())
    }
}

fmi2_export::export_fmu!(Lag);

type Log = Mutex<Vec<(Status, String)>>;

unsafe extern "C" fn record(
    env: *mut c_void,
    _name: *const c_char,
    status: Status,
    _cat: *const c_char,
    msg: *const c_char,
) {
    let log = &*(env as *const Log);
    let m = CStr::from_ptr(msg).to_string_lossy().into_owned();
    log.lock().unwrap().push((status, m));
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

fn new(log: &Log, ty: FmuType) -> Option<Inst> {
    let f: PlainLogger = record;
    let cb = Box::new(CallbackFunctions {
        // SAFETY: see the module doc.
        logger: Some(unsafe { std::mem::transmute::<PlainLogger, CallbackLogger>(f) }),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: log as *const Log as *mut c_void,
    });
    let name = CString::new("me").unwrap();
    let guid = CString::new(Lag::GUID).unwrap();
    let c = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            ty,
            guid.as_ptr(),
            std::ptr::null(),
            &*cb,
            0,
            0,
        )
    };
    (!c.is_null()).then_some(Inst { c, _cb: cb })
}

fn last(log: &Log) -> String {
    log.lock()
        .unwrap()
        .last()
        .map(|m| m.1.clone())
        .unwrap_or_default()
}

/// Instantiate as ME and initialize into Event Mode.
fn me_initialized(log: &Log) -> Inst {
    let i = new(log, FMI2_MODEL_EXCHANGE).expect("ME instance");
    unsafe {
        assert_eq!(fmi2SetupExperiment(i.c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(i.c), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(i.c), Status::Ok);
    }
    i
}

#[test]
fn explicit_euler_master_integrates_the_lag() {
    let log = Log::default();
    let i = me_initialized(&log);
    let mut info = EventInfo {
        new_discrete_states_needed: 1,
        ..Default::default()
    };
    unsafe {
        assert_eq!(fmi2NewDiscreteStates(i.c, &mut info), Status::Ok);
        assert_eq!(info, EventInfo::default());
        assert_eq!(fmi2EnterContinuousTimeMode(i.c), Status::Ok);
        let mut nominal = [0.0];
        assert_eq!(
            fmi2GetNominalsOfContinuousStates(i.c, nominal.as_mut_ptr(), 1),
            Status::Ok
        );
        assert_eq!(nominal, [2.0]);
        assert_eq!(
            fmi2GetEventIndicators(i.c, std::ptr::null_mut(), 0),
            Status::Ok
        );
        assert_eq!(fmi2SetReal(i.c, &VR_U, 1, &1.0), Status::Ok);
        let (h, n) = (1e-4, 5000);
        let mut x = [0.0];
        let mut dx = [0.0];
        assert_eq!(fmi2GetContinuousStates(i.c, x.as_mut_ptr(), 1), Status::Ok);
        for k in 1..=n {
            assert_eq!(fmi2GetDerivatives(i.c, dx.as_mut_ptr(), 1), Status::Ok);
            x[0] += h * dx[0];
            assert_eq!(fmi2SetTime(i.c, k as f64 * h), Status::Ok);
            assert_eq!(fmi2SetContinuousStates(i.c, x.as_ptr(), 1), Status::Ok);
            let (mut enter, mut term) = (1, 1);
            assert_eq!(
                fmi2CompletedIntegratorStep(i.c, 1, &mut enter, &mut term),
                Status::Ok
            );
            assert_eq!((enter, term), (0, 0));
        }
        // x(0.5 s) = 1 - e^{-1} (explicit Euler error ~ h/(2 tau) relative)
        let mut y = 0.0;
        assert_eq!(fmi2GetReal(i.c, &VR_Y, 1, &mut y), Status::Ok);
        let exact = 1.0 - (-1.0f64).exp();
        assert!((y - exact).abs() < 1e-4, "{y} vs {exact}");
        // back to Event Mode and out again, then terminate
        assert_eq!(fmi2EnterEventMode(i.c), Status::Ok);
        assert_eq!(fmi2NewDiscreteStates(i.c, &mut info), Status::Ok);
        assert_eq!(fmi2EnterContinuousTimeMode(i.c), Status::Ok);
        assert_eq!(fmi2Terminate(i.c), Status::Ok);
        assert_eq!(fmi2GetReal(i.c, &VR_Y, 1, &mut y), Status::Ok);
    }
}

#[test]
fn me_call_sequence_and_arguments_are_checked() {
    let log = Log::default();
    unsafe {
        // states are set only in Continuous-Time Mode
        let i = me_initialized(&log);
        assert_eq!(
            fmi2SetContinuousStates(i.c, [1.0].as_ptr(), 1),
            Status::Error
        );
        assert!(
            last(&log).contains("fmi2SetContinuousStates: illegal call sequence"),
            "{}",
            last(&log)
        );
        // a step is Co-Simulation only
        let i = me_initialized(&log);
        assert_eq!(fmi2DoStep(i.c, 0.0, 0.1, 0), Status::Error);
        assert!(
            last(&log).contains("fmi2DoStep: illegal call sequence"),
            "{}",
            last(&log)
        );
        type Call = Box<dyn Fn(Component) -> Status>;
        let cases: Vec<(Call, &str)> = vec![
            (
                Box::new(|c| fmi2SetContinuousStates(c, [1.0, 2.0].as_ptr(), 2)),
                "nx = 2, but the model has 1",
            ),
            (
                Box::new(|c| fmi2GetDerivatives(c, std::ptr::null_mut(), 1)),
                "argument derivatives is a NULL pointer",
            ),
            (
                Box::new(|c| fmi2SetContinuousStates(c, [f64::NAN].as_ptr(), 1)),
                "must be finite, got NaN",
            ),
            (
                Box::new(|c| fmi2SetContinuousStates(c, [2e6].as_ptr(), 1)),
                "x = 2000000 above 1e6",
            ),
            (
                Box::new(|c| fmi2GetEventIndicators(c, [0.0].as_mut_ptr(), 1)),
                "ni = 1, but the model has 0",
            ),
            (
                Box::new(|c| fmi2SetTime(c, f64::INFINITY)),
                "time must be finite",
            ),
            (
                Box::new(|c| fmi2CompletedIntegratorStep(c, 0, std::ptr::null_mut(), &mut 0)),
                "enterEventMode is a NULL",
            ),
            (
                Box::new(|c| fmi2NewDiscreteStates(c, std::ptr::null_mut())),
                "illegal call sequence",
            ),
            (
                Box::new(|c| fmi2SetRealInputDerivatives(c, &VR_U, 1, &1, &1.0)),
                "illegal call sequence",
            ),
        ];
        for (f, needle) in cases {
            let i = me_initialized(&log);
            assert_eq!(fmi2EnterContinuousTimeMode(i.c), Status::Ok);
            assert!(f(i.c) >= Status::Error, "{needle}");
            assert!(
                last(&log).contains(needle),
                "expected {needle:?} in {:?}",
                last(&log)
            );
        }
        // a non-finite derivative is an error, never fmi2OK
        let i = me_initialized(&log);
        assert_eq!(fmi2EnterContinuousTimeMode(i.c), Status::Ok);
        assert_eq!(fmi2SetReal(i.c, &VR_U, 1, &1e308), Status::Ok);
        assert_eq!(fmi2SetContinuousStates(i.c, [-1e5].as_ptr(), 1), Status::Ok);
        let mut dx = [0.0];
        // (1e308 + 1e5)/0.5 overflows
        assert_eq!(fmi2GetDerivatives(i.c, dx.as_mut_ptr(), 1), Status::Error);
        assert!(last(&log).contains("not finite"), "{}", last(&log));
    }
}

#[test]
fn cs_instance_refuses_me_functions_and_states_do_not_cross() {
    let log = Log::default();
    unsafe {
        let cs = new(&log, FMI2_CO_SIMULATION).unwrap();
        assert_eq!(fmi2SetupExperiment(cs.c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(cs.c), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(cs.c), Status::Ok);
        assert_eq!(fmi2SetTime(cs.c, 1.0), Status::Error);
        assert!(
            last(&log).contains("instantiated as fmi2CoSimulation"),
            "{}",
            last(&log)
        );
        // an ME state (Continuous-Time Mode) cannot be loaded into a CS instance
        let me = me_initialized(&log);
        assert_eq!(fmi2EnterContinuousTimeMode(me.c), Status::Ok);
        let mut s: FmuState = std::ptr::null_mut();
        assert_eq!(fmi2GetFMUstate(me.c, &mut s), Status::Ok);
        let mut size = 0;
        assert_eq!(fmi2SerializedFMUstateSize(me.c, s, &mut size), Status::Ok);
        let mut buf = vec![0 as Byte; size];
        assert_eq!(
            fmi2SerializeFMUstate(me.c, s, buf.as_mut_ptr(), size),
            Status::Ok
        );
        assert_eq!(fmi2FreeFMUstate(me.c, &mut s), Status::Ok);
        let cs2 = new(&log, FMI2_CO_SIMULATION).unwrap();
        let mut s2: FmuState = std::ptr::null_mut();
        assert_eq!(
            fmi2DeSerializeFMUstate(cs2.c, buf.as_ptr(), size, &mut s2),
            Status::Error
        );
        assert!(last(&log).contains("bad state code 9"), "{}", last(&log));
        // into an ME instance it loads, and the instance continues in Continuous-Time Mode
        let me2 = new(&log, FMI2_MODEL_EXCHANGE).unwrap();
        assert_eq!(
            fmi2DeSerializeFMUstate(me2.c, buf.as_ptr(), size, &mut s2),
            Status::Ok
        );
        assert_eq!(fmi2SetFMUstate(me2.c, s2), Status::Ok);
        assert_eq!(
            fmi2SetContinuousStates(me2.c, [0.25].as_ptr(), 1),
            Status::Ok
        );
        assert_eq!(fmi2FreeFMUstate(me2.c, &mut s2), Status::Ok);
    }
}

/// The rendered modelDescription of a Model Exchange model: `<ModelExchange>`,
/// the `derivative` attribute and `<Derivatives>` agree with the code.
#[test]
fn rendered_model_description_declares_model_exchange() {
    let xml = fmi2_export::render::model_description::<Lag>().unwrap();
    let md = fmi2_export::xml::check_model_description(&xml, "lag", Lag::GUID, Lag::VARIABLES)
        .unwrap_or_else(|e| panic!("{e:#?}\n{xml}"));
    assert!(fmi2_export::xml::check_model_exchange::<Lag>(&md).is_empty());
    assert_eq!(md.variables[3].derivative, Some(3));
    assert_eq!(md.derivatives[0].dependencies, Some(vec![2, 3]));
    // initial unknowns: the output (a state) and the derivative
    let iu: Vec<usize> = md.initial_unknowns.iter().map(|u| u.index).collect();
    assert_eq!(iu, [3, 4]);
}
