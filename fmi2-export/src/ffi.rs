//! The FMI 2.0 Co-Simulation and Model Exchange functions, generic over the model. The
//! [`crate::export_fmu!`] macro exports one `extern "C"` symbol per function
//! that forwards here. Every function
//! * checks its pointers and lengths before touching them,
//! * checks the call against the standard's state machine (a wrong call is
//!   logged as "illegal call sequence" and answered with `fmi2Error`, the state
//!   is left unchanged),
//! * runs the model inside `catch_unwind`, so no panic reaches the importer (a
//!   panic is logged and puts the instance into the error state),
//! * reports model and argument errors through the logger with the offending
//!   numbers, returns `fmi2Error` and puts the instance into the error state
//!   (from which only `fmi2Reset`, `fmi2FreeInstance` and the getters are allowed).
//!
//! There is no global or static mutable state: everything lives in the
//! [`Instance`] behind the `fmi2Component` pointer.
#![allow(clippy::missing_safety_doc)]
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_void};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use crate::model::{
    Causality, CoSimModel, InstantiateContext, Logger, ModelError, StateReader, StateWriter,
    VarType, Variable, LOG_CATEGORIES,
};
use crate::types::*;

/// The states of the FMI 2.0 state machines: Co-Simulation (standard,
/// section 4.2.4) and Model Exchange (section 3.2.3, `EventMode` and
/// `ContinuousTimeMode`; the other states are shared).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum State {
    Instantiated = 0,
    InitializationMode = 1,
    StepComplete = 2,
    StepFailed = 3,
    StepCanceled = 4,
    Terminated = 5,
    Error = 6,
    Fatal = 7,
    EventMode = 8,
    ContinuousTimeMode = 9,
}

impl State {
    fn bit(self) -> u16 {
        1 << (self as u8)
    }
    fn from_u64(v: u64) -> Option<State> {
        use State::*;
        [
            Instantiated,
            InitializationMode,
            StepComplete,
            StepFailed,
            StepCanceled,
            Terminated,
            Error,
            Fatal,
            EventMode,
            ContinuousTimeMode,
        ]
        .get(v as usize)
        .copied()
    }
}

const INSTANTIATED: u16 = 1 << 0;
const INIT: u16 = 1 << 1;
const STEP_COMPLETE: u16 = 1 << 2;
const STEP_FAILED: u16 = 1 << 3;
const STEP_CANCELED: u16 = 1 << 4;
const TERMINATED: u16 = 1 << 5;
const ERROR: u16 = 1 << 6;
const EVENT: u16 = 1 << 8;
const CONTINUOUS: u16 = 1 << 9;
const ALIVE: u16 = INSTANTIATED
    | INIT
    | STEP_COMPLETE
    | STEP_FAILED
    | STEP_CANCELED
    | TERMINATED
    | ERROR
    | EVENT
    | CONTINUOUS;
const GETTABLE: u16 =
    INIT | STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED | ERROR | EVENT | CONTINUOUS;
/// `fmi2SetReal` and friends (which variables, [`Variable::settable`]).
const SETTABLE: u16 = INSTANTIATED | INIT | STEP_COMPLETE | EVENT | CONTINUOUS;
/// `fmi2SetRealInputDerivatives` (Co-Simulation only).
const CS_SETTABLE: u16 = INSTANTIATED | INIT | STEP_COMPLETE;
const STEPPED: u16 = STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED;

/// One FMU instance: the state machine, the importer's callbacks and the model.
pub struct Instance<M> {
    state: State,
    /// Instantiated as `fmi2ModelExchange` (else Co-Simulation).
    model_exchange: bool,
    logger: Logger,
    instance_name: String,
    resource_dir: Option<PathBuf>,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    last_successful_time: f64,
    model: M,
    /// Keeps the strings returned by `fmi2GetString` alive until the next call.
    string_buf: Vec<CString>,
    /// Value references of the Real outputs (built once at instantiation,
    /// read by the per-step finiteness check).
    outputs: Box<[u32]>,
}

/// An `fmi2FMUstate`: the layer's part of the state plus a copy of the model.
struct Saved<M> {
    state: State,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    last_successful_time: f64,
    model: M,
}

const STATE_MAGIC: &[u8; 8] = b"RSFMI2S1";

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_string()
    }
}

/// Run `f` on the instance behind `c` if the state allows `func`.
unsafe fn run<M: CoSimModel>(
    c: Component,
    func: &str,
    allowed: u16,
    f: impl FnOnce(&mut Instance<M>) -> Result<Status, ModelError>,
) -> Status {
    if c.is_null() {
        return Status::Error;
    }
    let ptr = c as *mut Instance<M>;
    // SAFETY: a non-null component was created by `instantiate::<M>` (the
    // importer's contract) and is not used concurrently (FMI 2.0 rule).
    let state = (*ptr).state;
    if state.bit() & allowed == 0 {
        (*ptr).logger.error(&format!(
            "{func}: illegal call sequence (called in state {state:?})"
        ));
        return Status::Error;
    }
    match catch_unwind(AssertUnwindSafe(|| f(&mut *ptr))) {
        Ok(Ok(status)) => status,
        Ok(Err(e)) => {
            let inst = &mut *ptr;
            let msg = format!("{func}: {}", e.message);
            match e.status {
                Status::Discard => inst.logger.log(Status::Discard, "logStatusDiscard", &msg),
                Status::Warning => inst.logger.warning(&msg),
                _ => {
                    inst.logger.error(&msg);
                    inst.state = State::Error;
                }
            }
            e.status.max(Status::Warning)
        }
        Err(p) => {
            let inst = &mut *ptr;
            inst.state = State::Error;
            inst.logger.error(&format!(
                "{func}: internal error (panic): {}",
                panic_message(&*p)
            ));
            Status::Error
        }
    }
}

/// [`run`] for a Model Exchange function: on a Co-Simulation instance it is
/// refused (logged, fmi2Error) whatever the state.
unsafe fn run_me<M: CoSimModel>(
    c: Component,
    func: &str,
    allowed: u16,
    f: impl FnOnce(&mut Instance<M>) -> Result<Status, ModelError>,
) -> Status {
    // SAFETY: as in `run` (a non-null component is an `Instance<M>`)
    if !c.is_null() && !(*(c as *mut Instance<M>)).model_exchange {
        return run::<M>(c, func, ALIVE, |_| {
            Err(ModelError::error(if M::CONTINUOUS_STATES.is_empty() {
                "this FMU implements Co-Simulation only (no Model Exchange functions)"
            } else {
                "the instance was instantiated as fmi2CoSimulation; Model Exchange functions need fmuType fmi2ModelExchange"
            }))
        });
    }
    run::<M>(c, func, allowed, f)
}

/// Slice from a C array; `None` for a null pointer with `n > 0`.
unsafe fn slice<'a, T>(p: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        Some(&[])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts(p, n))
    }
}

unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        Some(&mut [])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts_mut(p, n))
    }
}

fn null_arg(name: &str) -> ModelError {
    ModelError::error(format!("argument {name} is a NULL pointer"))
}

fn find<M: CoSimModel>(vr: u32, ty: VarType) -> Result<&'static Variable, ModelError> {
    M::VARIABLES
        .iter()
        .find(|v| v.vr == vr && v.ty == ty)
        .ok_or_else(|| {
            ModelError::error(format!(
                "unknown value reference {vr} (no {ty:?} variable has it)"
            ))
        })
}

impl<M: CoSimModel> Instance<M> {
    fn check_settable(&self, v: &Variable) -> Result<(), ModelError> {
        let initialized = matches!(
            self.state,
            State::StepComplete | State::EventMode | State::ContinuousTimeMode
        );
        if v.settable(initialized) {
            Ok(())
        } else {
            Err(ModelError::error(format!(
                "variable {} (value reference {}, causality {:?}, variability {:?}) cannot be set in state {:?}",
                v.name, v.vr, v.causality, v.variability, self.state
            )))
        }
    }

    fn saved(&self) -> Saved<M> {
        Saved {
            state: self.state,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
            last_successful_time: self.last_successful_time,
            model: self.model.clone(),
        }
    }

    fn serialize(&self, s: &Saved<M>) -> Vec<u8> {
        let mut w = StateWriter::new();
        w.bytes.extend_from_slice(STATE_MAGIC);
        w.u64(M::GUID.len() as u64);
        w.bytes.extend_from_slice(M::GUID.as_bytes());
        w.u64(s.state as u64);
        w.f64(s.time);
        w.f64(s.start_time);
        w.bool(s.stop_time.is_some());
        w.f64(s.stop_time.unwrap_or(0.0));
        w.f64(s.last_successful_time);
        s.model.serialize_state(&mut w);
        w.into_bytes()
    }

    fn deserialize(&self, bytes: &[u8]) -> Result<Saved<M>, ModelError> {
        if bytes.len() < 8 || &bytes[..8] != STATE_MAGIC {
            return Err(ModelError::error(
                "serialized FMU state: bad magic (not written by this FMU)",
            ));
        }
        let mut r = StateReader::new(&bytes[8..]);
        let glen = r.u64()?;
        let start = 16;
        if glen != M::GUID.len() as u64
            || bytes.len() < start + M::GUID.len()
            || &bytes[start..start + M::GUID.len()] != M::GUID.as_bytes()
        {
            return Err(ModelError::error(format!(
                "serialized FMU state was written by a different FMU (expected GUID {})",
                M::GUID
            )));
        }
        let mut r = StateReader::new(&bytes[start + M::GUID.len()..]);
        let st = r.u64()?;
        let state = State::from_u64(st)
            .filter(|s| !matches!(s, State::Error | State::Fatal))
            .ok_or_else(|| {
                ModelError::error(format!(
                    "serialized FMU state: bad state code {st} (a saved state is never in Error or Fatal)"
                ))
            })?;
        let me_state = matches!(state, State::EventMode | State::ContinuousTimeMode);
        let cs_state = matches!(
            state,
            State::StepComplete | State::StepFailed | State::StepCanceled
        );
        if (me_state && !self.model_exchange) || (cs_state && self.model_exchange) {
            return Err(ModelError::error(format!(
                "serialized FMU state: bad state code {st} ({state:?} does not occur in a {} instance)",
                if self.model_exchange {
                    "Model Exchange"
                } else {
                    "Co-Simulation"
                }
            )));
        }
        let time = r.f64()?;
        let start_time = r.f64()?;
        let has_stop = r.bool()?;
        let stop = r.f64()?;
        let last_successful_time = r.f64()?;
        let mut model = self.model.clone();
        model.deserialize_state(&mut r)?;
        r.finish()?;
        Ok(Saved {
            state,
            time,
            start_time,
            stop_time: has_stop.then_some(stop),
            last_successful_time,
            model,
        })
    }
}

/// `fmi2GetTypesPlatform`.
pub fn get_types_platform() -> *const c_char {
    c"default".as_ptr()
}

/// `fmi2GetVersion`.
pub fn get_version() -> *const c_char {
    c"2.0".as_ptr()
}

unsafe fn opt_str<'a>(p: *const c_char) -> Option<&'a str> {
    if p.is_null() {
        None
    } else {
        CStr::from_ptr(p).to_str().ok()
    }
}

/// `fmi2Instantiate`: NULL on any failure (logged when a logger was given).
pub unsafe fn instantiate<M: CoSimModel>(
    instance_name: FmiString,
    fmu_type: FmuType,
    guid: FmiString,
    resource_location: FmiString,
    functions: *const CallbackFunctions,
    _visible: Boolean,
    logging_on: Boolean,
) -> Component {
    if functions.is_null() {
        return std::ptr::null_mut();
    }
    let cb = *functions;
    let name = opt_str(instance_name);
    let logger = Logger::new(
        cb.logger,
        cb.component_environment,
        name.unwrap_or("?"),
        logging_on != 0,
    );
    let result = catch_unwind(AssertUnwindSafe(|| -> Result<Instance<M>, String> {
        let name = match name {
            Some(n) if !n.is_empty() => n.to_string(),
            _ => return Err("fmi2Instantiate: instanceName must be a non-empty string".into()),
        };
        let model_exchange = match fmu_type {
            FMI2_CO_SIMULATION => false,
            FMI2_MODEL_EXCHANGE if !M::CONTINUOUS_STATES.is_empty() => true,
            FMI2_MODEL_EXCHANGE => {
                return Err(
                    "fmi2Instantiate: this FMU implements Co-Simulation only (fmuType fmi2ModelExchange refused)"
                        .into(),
                )
            }
            _ => {
                return Err(format!(
                    "fmi2Instantiate: fmuType must be fmi2ModelExchange ({FMI2_MODEL_EXCHANGE}) or fmi2CoSimulation ({FMI2_CO_SIMULATION}), got {fmu_type}"
                ))
            }
        };
        match opt_str(guid) {
            Some(g) if g == M::GUID => {}
            g => {
                return Err(format!(
                    "fmi2Instantiate: GUID mismatch: expected {} but was {:?}",
                    M::GUID,
                    g
                ))
            }
        }
        let resource_dir = match opt_str(resource_location) {
            None | Some("") => None,
            Some(uri) => match crate::uri::file_uri_to_path(uri) {
                Ok(p) => Some(p),
                Err(e) => {
                    logger.warning(&format!("fmi2Instantiate: {e}; resources unavailable"));
                    None
                }
            },
        };
        let ctx = InstantiateContext {
            instance_name: &name,
            resource_dir: resource_dir.clone(),
            logger: &logger,
        };
        let model = M::instantiate(&ctx).map_err(|e| format!("fmi2Instantiate: {}", e.message))?;
        Ok(Instance {
            state: State::Instantiated,
            model_exchange,
            logger: Logger::new(cb.logger, cb.component_environment, &name, logging_on != 0),
            instance_name: name,
            resource_dir,
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            last_successful_time: 0.0,
            model,
            string_buf: Vec::new(),
            outputs: real_outputs::<M>().map(|v| v.vr).collect(),
        })
    }));
    match result {
        Ok(Ok(inst)) => Box::into_raw(Box::new(inst)) as Component,
        Ok(Err(msg)) => {
            logger.error(&msg);
            std::ptr::null_mut()
        }
        Err(p) => {
            logger.error(&format!(
                "fmi2Instantiate: internal error (panic): {}",
                panic_message(&*p)
            ));
            std::ptr::null_mut()
        }
    }
}

/// `fmi2FreeInstance`.
pub unsafe fn free_instance<M: CoSimModel>(c: Component) {
    if c.is_null() {
        return;
    }
    // SAFETY: created by `instantiate::<M>` via Box::into_raw; freed once.
    let b = Box::from_raw(c as *mut Instance<M>);
    let _ = catch_unwind(AssertUnwindSafe(move || drop(b)));
}

/// `fmi2SetDebugLogging`.
pub unsafe fn set_debug_logging<M: CoSimModel>(
    c: Component,
    logging_on: Boolean,
    n: usize,
    categories: *const FmiString,
) -> Status {
    run::<M>(c, "fmi2SetDebugLogging", ALIVE, |inst| {
        let cats = slice(categories, n).ok_or_else(|| null_arg("categories"))?;
        let mut idx = Vec::with_capacity(n);
        for &p in cats {
            let name = opt_str(p).ok_or_else(|| null_arg("categories[i]"))?;
            let i = LOG_CATEGORIES
                .iter()
                .position(|&c| c == name)
                .ok_or_else(|| {
                    ModelError::error(format!(
                        "unknown log category {name:?} (known: {LOG_CATEGORIES:?})"
                    ))
                })?;
            idx.push(i);
        }
        inst.logger.logging_on = logging_on != 0;
        inst.logger.categories = idx;
        Ok(Status::Ok)
    })
}

/// `fmi2SetupExperiment`.
pub unsafe fn setup_experiment<M: CoSimModel>(
    c: Component,
    _tolerance_defined: Boolean,
    _tolerance: f64,
    start_time: f64,
    stop_time_defined: Boolean,
    stop_time: f64,
) -> Status {
    run::<M>(c, "fmi2SetupExperiment", INSTANTIATED, |inst| {
        if !start_time.is_finite() {
            return Err(ModelError::error(format!(
                "startTime must be finite, got {start_time}"
            )));
        }
        let stop = if stop_time_defined != 0 {
            if !(stop_time.is_finite() && stop_time >= start_time) {
                return Err(ModelError::error(format!(
                    "stopTime must be finite and >= startTime = {start_time}, got {stop_time}"
                )));
            }
            Some(stop_time)
        } else {
            None
        };
        inst.model.setup_experiment(start_time, stop)?;
        inst.start_time = start_time;
        inst.time = start_time;
        inst.last_successful_time = start_time;
        inst.stop_time = stop;
        Ok(Status::Ok)
    })
}

/// `fmi2EnterInitializationMode`.
pub unsafe fn enter_initialization_mode<M: CoSimModel>(c: Component) -> Status {
    run::<M>(c, "fmi2EnterInitializationMode", INSTANTIATED, |inst| {
        inst.model.enter_initialization_mode(&inst.logger)?;
        inst.state = State::InitializationMode;
        Ok(Status::Ok)
    })
}

/// `fmi2ExitInitializationMode`.
pub unsafe fn exit_initialization_mode<M: CoSimModel>(c: Component) -> Status {
    run::<M>(c, "fmi2ExitInitializationMode", INIT, |inst| {
        inst.model.exit_initialization_mode(&inst.logger)?;
        outputs_finite(&inst.model, &inst.outputs, inst.time)?;
        inst.state = if inst.model_exchange {
            State::EventMode
        } else {
            State::StepComplete
        };
        Ok(Status::Ok)
    })
}

/// `fmi2Terminate`.
pub unsafe fn terminate<M: CoSimModel>(c: Component) -> Status {
    run::<M>(
        c,
        "fmi2Terminate",
        STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | EVENT | CONTINUOUS,
        |inst| {
            inst.state = State::Terminated;
            Ok(Status::Ok)
        },
    )
}

/// `fmi2Reset`: back to the freshly instantiated state (model rebuilt from its
/// start values).
pub unsafe fn reset<M: CoSimModel>(c: Component) -> Status {
    run::<M>(c, "fmi2Reset", ALIVE, |inst| {
        let ctx = InstantiateContext {
            instance_name: &inst.instance_name,
            resource_dir: inst.resource_dir.clone(),
            logger: &inst.logger,
        };
        inst.model = M::instantiate(&ctx)?;
        inst.state = State::Instantiated;
        inst.time = 0.0;
        inst.start_time = 0.0;
        inst.stop_time = None;
        inst.last_successful_time = 0.0;
        Ok(Status::Ok)
    })
}

macro_rules! getter {
    ($fname:ident, $cname:literal, $ty:ty, $vt:expr, |$m:ident, $vr:ident| $get:expr) => {
        #[doc = concat!("`", $cname, "`.")]
        pub unsafe fn $fname<M: CoSimModel>(
            c: Component,
            vr: *const ValueReference,
            n: usize,
            value: *mut $ty,
        ) -> Status {
            run::<M>(c, $cname, GETTABLE, |inst| {
                let vrs = slice(vr, n).ok_or_else(|| null_arg("vr"))?;
                let out = slice_mut(value, n).ok_or_else(|| null_arg("value"))?;
                for (o, &$vr) in out.iter_mut().zip(vrs) {
                    find::<M>($vr, $vt)?;
                    let $m = &inst.model;
                    *o = $get;
                }
                Ok(Status::Ok)
            })
        }
    };
}

getter!(get_real, "fmi2GetReal", Real, VarType::Real, |m, v| finite(
    v,
    m.try_get_real(v)?
)?);

/// A Real value handed out must be finite: never fmi2OK with NaN or inf.
fn finite(vr: ValueReference, x: f64) -> Result<f64, ModelError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(ModelError::error(format!(
            "Real value reference {vr} is {x} (not finite); the model left its valid range"
        )))
    }
}

/// Value references of the Real outputs (listed once per model type: the
/// per-step check reads exactly these, no scan of the variable table).
fn real_outputs<M: CoSimModel>() -> impl Iterator<Item = &'static Variable> {
    M::VARIABLES
        .iter()
        .filter(|v| v.ty == VarType::Real && v.causality == Causality::Output)
}

/// After a step or initialization: every Real output finite, or an error
/// naming the first that is not (so the step itself fails, not a later get).
/// One branch-free pass over the outputs (`outputs`: the
/// instance's list); the variable table is searched only on failure.
fn outputs_finite<M: CoSimModel>(m: &M, outputs: &[u32], t: f64) -> Result<(), ModelError> {
    let mut all_finite = true;
    for &vr in outputs {
        all_finite &= m.get_real(vr).is_finite();
    }
    if all_finite {
        return Ok(());
    }
    for v in real_outputs::<M>() {
        let x = m.get_real(v.vr);
        if !x.is_finite() {
            return Err(ModelError::error(format!(
                "output {} = {x} at t = {t} s is not finite; the model left its valid range \
                 (check parameters and inputs)",
                v.name
            )));
        }
    }
    Ok(())
}
getter!(
    get_integer,
    "fmi2GetInteger",
    Integer,
    VarType::Integer,
    |m, v| m.get_integer(v)?
);
getter!(
    get_boolean,
    "fmi2GetBoolean",
    Boolean,
    VarType::Boolean,
    |m, v| m.get_boolean(v)? as Boolean
);

/// `fmi2GetString`: the returned pointers stay valid until the next call.
pub unsafe fn get_string<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *mut FmiString,
) -> Status {
    run::<M>(c, "fmi2GetString", GETTABLE, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("vr"))?;
        let out = slice_mut(value, n).ok_or_else(|| null_arg("value"))?;
        inst.string_buf.clear();
        for &v in vrs {
            find::<M>(v, VarType::String)?;
            let s = inst.model.get_string(v)?;
            inst.string_buf
                .push(CString::new(s.replace('\0', " ")).expect("NUL replaced"));
        }
        for (o, s) in out.iter_mut().zip(&inst.string_buf) {
            *o = s.as_ptr();
        }
        Ok(Status::Ok)
    })
}

/// `fmi2SetReal`: rejects unknown references, variables not settable now, and
/// non-finite values.
pub unsafe fn set_real<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const Real,
) -> Status {
    run::<M>(c, "fmi2SetReal", SETTABLE, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("vr"))?;
        let vals = slice(value, n).ok_or_else(|| null_arg("value"))?;
        for (&v, &x) in vrs.iter().zip(vals) {
            let var = find::<M>(v, VarType::Real)?;
            inst.check_settable(var)?;
            if !x.is_finite() {
                return Err(ModelError::error(format!(
                    "value of {} (value reference {v}) must be finite, got {x}",
                    var.name
                )));
            }
            inst.model.set_real(v, x)?;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2SetInteger`.
pub unsafe fn set_integer<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const Integer,
) -> Status {
    run::<M>(c, "fmi2SetInteger", SETTABLE, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("vr"))?;
        let vals = slice(value, n).ok_or_else(|| null_arg("value"))?;
        for (&v, &x) in vrs.iter().zip(vals) {
            let var = find::<M>(v, VarType::Integer)?;
            inst.check_settable(var)?;
            inst.model.set_integer(v, x)?;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2SetBoolean`.
pub unsafe fn set_boolean<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const Boolean,
) -> Status {
    run::<M>(c, "fmi2SetBoolean", SETTABLE, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("vr"))?;
        let vals = slice(value, n).ok_or_else(|| null_arg("value"))?;
        for (&v, &x) in vrs.iter().zip(vals) {
            let var = find::<M>(v, VarType::Boolean)?;
            inst.check_settable(var)?;
            inst.model.set_boolean(v, x != 0)?;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2SetString`.
pub unsafe fn set_string<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const FmiString,
) -> Status {
    run::<M>(c, "fmi2SetString", SETTABLE, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("vr"))?;
        let vals = slice(value, n).ok_or_else(|| null_arg("value"))?;
        for (&v, &p) in vrs.iter().zip(vals) {
            let var = find::<M>(v, VarType::String)?;
            inst.check_settable(var)?;
            if p.is_null() {
                return Err(null_arg("value[i]"));
            }
            let s = CStr::from_ptr(p).to_str().map_err(|e| {
                ModelError::error(format!("value of {} is not UTF-8: {e}", var.name))
            })?;
            inst.model.set_string(v, s)?;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2GetFMUstate`: a new state, or overwrite `*state` if it is non-NULL.
pub unsafe fn get_fmu_state<M: CoSimModel>(c: Component, state: *mut FmuState) -> Status {
    run::<M>(c, "fmi2GetFMUstate", ALIVE, |inst| {
        if state.is_null() {
            return Err(null_arg("FMUstate"));
        }
        let s = inst.saved();
        if (*state).is_null() {
            *state = Box::into_raw(Box::new(s)) as FmuState;
        } else {
            *((*state) as *mut Saved<M>) = s;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2SetFMUstate`.
pub unsafe fn set_fmu_state<M: CoSimModel>(c: Component, state: FmuState) -> Status {
    run::<M>(c, "fmi2SetFMUstate", ALIVE, |inst| {
        if state.is_null() {
            return Err(null_arg("FMUstate"));
        }
        let s = &*(state as *const Saved<M>);
        inst.state = s.state;
        inst.time = s.time;
        inst.start_time = s.start_time;
        inst.stop_time = s.stop_time;
        inst.last_successful_time = s.last_successful_time;
        inst.model = s.model.clone();
        Ok(Status::Ok)
    })
}

/// `fmi2FreeFMUstate`: frees `*state` and sets it to NULL (NULL is ignored).
pub unsafe fn free_fmu_state<M: CoSimModel>(c: Component, state: *mut FmuState) -> Status {
    run::<M>(c, "fmi2FreeFMUstate", ALIVE, |_inst| {
        if state.is_null() || (*state).is_null() {
            return Ok(Status::Ok);
        }
        drop(Box::from_raw(*state as *mut Saved<M>));
        *state = std::ptr::null_mut();
        Ok(Status::Ok)
    })
}

/// `fmi2SerializedFMUstateSize`.
pub unsafe fn serialized_fmu_state_size<M: CoSimModel>(
    c: Component,
    state: FmuState,
    size: *mut usize,
) -> Status {
    run::<M>(c, "fmi2SerializedFMUstateSize", ALIVE, |inst| {
        if state.is_null() {
            return Err(null_arg("FMUstate"));
        }
        if size.is_null() {
            return Err(null_arg("size"));
        }
        *size = inst.serialize(&*(state as *const Saved<M>)).len();
        Ok(Status::Ok)
    })
}

/// `fmi2SerializeFMUstate`.
pub unsafe fn serialize_fmu_state<M: CoSimModel>(
    c: Component,
    state: FmuState,
    buf: *mut Byte,
    size: usize,
) -> Status {
    run::<M>(c, "fmi2SerializeFMUstate", ALIVE, |inst| {
        if state.is_null() {
            return Err(null_arg("FMUstate"));
        }
        let bytes = inst.serialize(&*(state as *const Saved<M>));
        if size < bytes.len() {
            return Err(ModelError::error(format!(
                "buffer of {size} bytes is too small for the serialized state ({} bytes)",
                bytes.len()
            )));
        }
        let out =
            slice_mut(buf as *mut u8, bytes.len()).ok_or_else(|| null_arg("serializedState"))?;
        out.copy_from_slice(&bytes);
        Ok(Status::Ok)
    })
}

/// `fmi2DeSerializeFMUstate`.
pub unsafe fn deserialize_fmu_state<M: CoSimModel>(
    c: Component,
    buf: *const Byte,
    size: usize,
    state: *mut FmuState,
) -> Status {
    run::<M>(c, "fmi2DeSerializeFMUstate", ALIVE, |inst| {
        if state.is_null() {
            return Err(null_arg("FMUstate"));
        }
        let bytes = slice(buf as *const u8, size).ok_or_else(|| null_arg("serializedState"))?;
        let s = inst.deserialize(bytes)?;
        if (*state).is_null() {
            *state = Box::into_raw(Box::new(s)) as FmuState;
        } else {
            *((*state) as *mut Saved<M>) = s;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2GetDirectionalDerivative`: `dvUnknown = J dvKnown` from the model's
/// partial derivatives (an error when the model provides none).
#[allow(clippy::too_many_arguments)]
pub unsafe fn get_directional_derivative<M: CoSimModel>(
    c: Component,
    unknown: *const ValueReference,
    n_unknown: usize,
    known: *const ValueReference,
    n_known: usize,
    dv_known: *const Real,
    dv_unknown: *mut Real,
) -> Status {
    run::<M>(c, "fmi2GetDirectionalDerivative", GETTABLE, |inst| {
        let u = slice(unknown, n_unknown).ok_or_else(|| null_arg("vUnknown_ref"))?;
        let k = slice(known, n_known).ok_or_else(|| null_arg("vKnown_ref"))?;
        let dk = slice(dv_known, n_known).ok_or_else(|| null_arg("dvKnown"))?;
        let du = slice_mut(dv_unknown, n_unknown).ok_or_else(|| null_arg("dvUnknown"))?;
        for &kv in k {
            find::<M>(kv, VarType::Real)?;
        }
        for (o, &uv) in du.iter_mut().zip(u) {
            find::<M>(uv, VarType::Real)?;
            let mut s = 0.0;
            for (&kv, &d) in k.iter().zip(dk) {
                s += inst.model.partial_derivative(uv, kv)? * d;
            }
            *o = s;
        }
        Ok(Status::Ok)
    })
}

fn order_of(o: Integer) -> Result<u32, ModelError> {
    if o >= 1 {
        Ok(o as u32)
    } else {
        Err(ModelError::error(format!(
            "derivative order must be >= 1, got {o}"
        )))
    }
}

/// `fmi2SetRealInputDerivatives`.
pub unsafe fn set_real_input_derivatives<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    order: *const Integer,
    value: *const Real,
) -> Status {
    run::<M>(c, "fmi2SetRealInputDerivatives", CS_SETTABLE, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("vr"))?;
        let ord = slice(order, n).ok_or_else(|| null_arg("order"))?;
        let vals = slice(value, n).ok_or_else(|| null_arg("value"))?;
        for ((&v, &o), &x) in vrs.iter().zip(ord).zip(vals) {
            let var = find::<M>(v, VarType::Real)?;
            if var.causality != Causality::Input {
                return Err(ModelError::error(format!(
                    "{} (value reference {v}) is not an input",
                    var.name
                )));
            }
            let o = order_of(o)?;
            if !x.is_finite() {
                return Err(ModelError::error(format!(
                    "derivative of order {o} of {} must be finite, got {x}",
                    var.name
                )));
            }
            inst.model.set_real_input_derivative(v, o, x)?;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2GetRealOutputDerivatives`.
pub unsafe fn get_real_output_derivatives<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    order: *const Integer,
    value: *mut Real,
) -> Status {
    run::<M>(c, "fmi2GetRealOutputDerivatives", STEPPED | ERROR, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("vr"))?;
        let ord = slice(order, n).ok_or_else(|| null_arg("order"))?;
        let out = slice_mut(value, n).ok_or_else(|| null_arg("value"))?;
        for ((o, &v), &k) in out.iter_mut().zip(vrs).zip(ord) {
            let var = find::<M>(v, VarType::Real)?;
            if var.causality != Causality::Output {
                return Err(ModelError::error(format!(
                    "{} (value reference {v}) is not an output",
                    var.name
                )));
            }
            *o = finite(v, inst.model.get_real_output_derivative(v, order_of(k)?)?)?;
        }
        Ok(Status::Ok)
    })
}

/// Tolerance for comparing the master's communication point with ours.
fn time_tol(t: f64) -> f64 {
    1e-9 * t.abs().max(1.0)
}

/// `fmi2DoStep` (always synchronous).
pub unsafe fn do_step<M: CoSimModel>(
    c: Component,
    t: f64,
    h: f64,
    _no_set_prior: Boolean,
) -> Status {
    run::<M>(c, "fmi2DoStep", STEP_COMPLETE, |inst| {
        if !(h.is_finite() && h > 0.0) {
            return Err(ModelError::error(format!(
                "communicationStepSize must be positive and finite, got {h}"
            )));
        }
        if !t.is_finite() || (t - inst.time).abs() > time_tol(inst.time) {
            return Err(ModelError::error(format!(
                "expected currentCommunicationPoint = {} but was {t}",
                inst.time
            )));
        }
        if let Some(stop) = inst.stop_time {
            if t + h > stop + time_tol(stop) {
                return Err(ModelError::error(format!(
                    "step to {} goes beyond stopTime = {stop}",
                    t + h
                )));
            }
        }
        match inst
            .model
            .do_step(t, h, &inst.logger)
            .and_then(|()| outputs_finite(&inst.model, &inst.outputs, t + h))
        {
            Ok(()) => {
                inst.time = t + h;
                inst.last_successful_time = inst.time;
                Ok(Status::Ok)
            }
            Err(e) => {
                if e.status == Status::Discard {
                    inst.state = State::StepFailed;
                }
                Err(e)
            }
        }
    })
}

/// `fmi2CancelStep`: steps are never asynchronous, so there is never a step
/// in progress and every call is an illegal call sequence.
pub unsafe fn cancel_step<M: CoSimModel>(c: Component) -> Status {
    run::<M>(c, "fmi2CancelStep", 0, |_| Ok(Status::Ok))
}

fn unsupported_kind(kind: StatusKind, what: &str) -> ModelError {
    ModelError::discard(format!(
        "status kind {kind} is not available from {what} (steps are synchronous)"
    ))
}

/// `fmi2GetStatus`: no status kind applies to synchronous steps (fmi2Discard).
pub unsafe fn get_status<M: CoSimModel>(
    c: Component,
    kind: StatusKind,
    value: *mut Status,
) -> Status {
    run::<M>(c, "fmi2GetStatus", STEPPED, |_| {
        if value.is_null() {
            return Err(null_arg("value"));
        }
        Err(unsupported_kind(kind, "fmi2GetStatus"))
    })
}

/// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime`.
pub unsafe fn get_real_status<M: CoSimModel>(
    c: Component,
    kind: StatusKind,
    value: *mut Real,
) -> Status {
    run::<M>(c, "fmi2GetRealStatus", STEPPED, |inst| {
        if value.is_null() {
            return Err(null_arg("value"));
        }
        if kind == FMI2_LAST_SUCCESSFUL_TIME {
            *value = inst.last_successful_time;
            Ok(Status::Ok)
        } else {
            Err(unsupported_kind(kind, "fmi2GetRealStatus"))
        }
    })
}

/// `fmi2GetIntegerStatus`: no integer status exists (fmi2Discard).
pub unsafe fn get_integer_status<M: CoSimModel>(
    c: Component,
    kind: StatusKind,
    value: *mut Integer,
) -> Status {
    run::<M>(c, "fmi2GetIntegerStatus", STEPPED, |_| {
        if value.is_null() {
            return Err(null_arg("value"));
        }
        Err(unsupported_kind(kind, "fmi2GetIntegerStatus"))
    })
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` is always false (the FMU never
/// asks to end the simulation).
pub unsafe fn get_boolean_status<M: CoSimModel>(
    c: Component,
    kind: StatusKind,
    value: *mut Boolean,
) -> Status {
    run::<M>(c, "fmi2GetBooleanStatus", STEPPED, |_| {
        if value.is_null() {
            return Err(null_arg("value"));
        }
        if kind == FMI2_TERMINATED {
            *value = FMI2_FALSE;
            Ok(Status::Ok)
        } else {
            Err(unsupported_kind(kind, "fmi2GetBooleanStatus"))
        }
    })
}

/// `fmi2GetStringStatus`: only `fmi2PendingStatus` exists, never pending.
pub unsafe fn get_string_status<M: CoSimModel>(
    c: Component,
    kind: StatusKind,
    value: *mut FmiString,
) -> Status {
    run::<M>(c, "fmi2GetStringStatus", STEPPED, |_| {
        if value.is_null() {
            return Err(null_arg("value"));
        }
        Err(unsupported_kind(kind, "fmi2GetStringStatus"))
    })
}

/// `n` must be the number of continuous states.
fn check_n_states<M: CoSimModel>(n: usize, what: &str) -> Result<(), ModelError> {
    let nx = M::CONTINUOUS_STATES.len();
    if n == nx {
        Ok(())
    } else {
        Err(ModelError::error(format!(
            "{what} = {n}, but the model has {nx} continuous states"
        )))
    }
}

/// `fmi2SetTime` (Model Exchange; Event and Continuous-Time Mode).
pub unsafe fn set_time<M: CoSimModel>(c: Component, t: Real) -> Status {
    run_me::<M>(c, "fmi2SetTime", EVENT | CONTINUOUS, |inst| {
        if !t.is_finite() {
            return Err(ModelError::error(format!("time must be finite, got {t}")));
        }
        inst.model.set_time(t)?;
        inst.time = t;
        Ok(Status::Ok)
    })
}

/// `fmi2SetContinuousStates` (Continuous-Time Mode): finite values only.
pub unsafe fn set_continuous_states<M: CoSimModel>(
    c: Component,
    x: *const Real,
    n: usize,
) -> Status {
    run_me::<M>(c, "fmi2SetContinuousStates", CONTINUOUS, |inst| {
        check_n_states::<M>(n, "nx")?;
        let x = slice(x, n).ok_or_else(|| null_arg("x"))?;
        for (s, &v) in M::CONTINUOUS_STATES.iter().zip(x) {
            if !v.is_finite() {
                return Err(ModelError::error(format!(
                    "continuous state (value reference {}) must be finite, got {v}",
                    s.state_vr
                )));
            }
        }
        inst.model.set_continuous_states(x)?;
        Ok(Status::Ok)
    })
}

/// `fmi2GetContinuousStates`.
pub unsafe fn get_continuous_states<M: CoSimModel>(c: Component, x: *mut Real, n: usize) -> Status {
    run_me::<M>(c, "fmi2GetContinuousStates", GETTABLE, |inst| {
        check_n_states::<M>(n, "nx")?;
        let out = slice_mut(x, n).ok_or_else(|| null_arg("x"))?;
        for (o, s) in out.iter_mut().zip(M::CONTINUOUS_STATES) {
            *o = finite(s.state_vr, inst.model.get_real(s.state_vr))?;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2GetDerivatives`: never fmi2OK with a non-finite derivative.
pub unsafe fn get_derivatives<M: CoSimModel>(c: Component, dx: *mut Real, n: usize) -> Status {
    run_me::<M>(c, "fmi2GetDerivatives", GETTABLE, |inst| {
        check_n_states::<M>(n, "nx")?;
        let out = slice_mut(dx, n).ok_or_else(|| null_arg("derivatives"))?;
        inst.model.derivatives(out)?;
        for (&d, s) in out.iter().zip(M::CONTINUOUS_STATES) {
            finite(s.derivative_vr, d)?;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2GetEventIndicators`: the models are event-free (0 indicators).
pub unsafe fn get_event_indicators<M: CoSimModel>(c: Component, _z: *mut Real, n: usize) -> Status {
    run_me::<M>(c, "fmi2GetEventIndicators", GETTABLE, |_| {
        if n != 0 {
            return Err(ModelError::error(format!(
                "ni = {n}, but the model has 0 event indicators"
            )));
        }
        Ok(Status::Ok)
    })
}

/// `fmi2GetNominalsOfContinuousStates` (any state after instantiation).
pub unsafe fn get_nominals_of_continuous_states<M: CoSimModel>(
    c: Component,
    x: *mut Real,
    n: usize,
) -> Status {
    run_me::<M>(c, "fmi2GetNominalsOfContinuousStates", ALIVE, |_| {
        check_n_states::<M>(n, "nx")?;
        let out = slice_mut(x, n).ok_or_else(|| null_arg("x_nominal"))?;
        for (o, s) in out.iter_mut().zip(M::CONTINUOUS_STATES) {
            *o = s.nominal;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2EnterEventMode` (from Event or Continuous-Time Mode; the models have no events,
/// so Event Mode only passes the master's event iteration).
pub unsafe fn enter_event_mode<M: CoSimModel>(c: Component) -> Status {
    run_me::<M>(c, "fmi2EnterEventMode", EVENT | CONTINUOUS, |inst| {
        inst.state = State::EventMode;
        Ok(Status::Ok)
    })
}

/// `fmi2NewDiscreteStates`: no discrete states, no time events, nothing changed.
pub unsafe fn new_discrete_states<M: CoSimModel>(c: Component, info: *mut EventInfo) -> Status {
    run_me::<M>(c, "fmi2NewDiscreteStates", EVENT, |_| {
        if info.is_null() {
            return Err(null_arg("fmi2EventInfo"));
        }
        *info = EventInfo::default();
        Ok(Status::Ok)
    })
}

/// `fmi2EnterContinuousTimeMode`.
pub unsafe fn enter_continuous_time_mode<M: CoSimModel>(c: Component) -> Status {
    run_me::<M>(c, "fmi2EnterContinuousTimeMode", EVENT, |inst| {
        inst.state = State::ContinuousTimeMode;
        Ok(Status::Ok)
    })
}

/// `fmi2CompletedIntegratorStep`: never asks for an event or for termination.
pub unsafe fn completed_integrator_step<M: CoSimModel>(
    c: Component,
    _no_set_fmu_state_prior: Boolean,
    enter_event_mode: *mut Boolean,
    terminate_simulation: *mut Boolean,
) -> Status {
    run_me::<M>(c, "fmi2CompletedIntegratorStep", CONTINUOUS, |_| {
        if enter_event_mode.is_null() {
            return Err(null_arg("enterEventMode"));
        }
        if terminate_simulation.is_null() {
            return Err(null_arg("terminateSimulation"));
        }
        *enter_event_mode = FMI2_FALSE;
        *terminate_simulation = FMI2_FALSE;
        Ok(Status::Ok)
    })
}

/// Marker so `c_void` stays referenced in docs of the generated symbols.
#[doc(hidden)]
pub type Void = c_void;
