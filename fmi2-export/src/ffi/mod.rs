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
//!
//! The FMI 3.0 functions ([`crate::fmi3`]) run on the same [`Instance`],
//! state machine, checks and FMU-state code: an instance created by
//! `fmi3Instantiate*` is flagged `Instance::fmi3`, which only changes the
//! function names in its messages (`fmi3_name`), the value references of
//! non-Float64 variables ([`crate::render3::fmi3_value_reference`]) and the
//! logging callback.
#![allow(clippy::missing_safety_doc)]
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_void};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use crate::model::{
    Causality, CoSimModel, InstantiateContext, Logger, ModelError, StateReader, StateWriter,
    StepOutcome, VarType, Variable, LOG_CATEGORIES,
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
    /// FMI 3.0 Configuration Mode (section 2.3): structural parameters are set.
    ConfigurationMode = 10,
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
            ConfigurationMode,
        ]
        .get(v as usize)
        .copied()
    }
}

pub(crate) const INSTANTIATED: u16 = 1 << 0;
pub(crate) const INIT: u16 = 1 << 1;
pub(crate) const STEP_COMPLETE: u16 = 1 << 2;
pub(crate) const STEP_FAILED: u16 = 1 << 3;
pub(crate) const STEP_CANCELED: u16 = 1 << 4;
pub(crate) const TERMINATED: u16 = 1 << 5;
pub(crate) const ERROR: u16 = 1 << 6;
pub(crate) const EVENT: u16 = 1 << 8;
pub(crate) const CONTINUOUS: u16 = 1 << 9;
pub(crate) const CONFIG: u16 = 1 << 10;
pub(crate) const ALIVE: u16 = CONFIG
    | INSTANTIATED
    | INIT
    | STEP_COMPLETE
    | STEP_FAILED
    | STEP_CANCELED
    | TERMINATED
    | ERROR
    | EVENT
    | CONTINUOUS;
pub(crate) const GETTABLE: u16 =
    INIT | STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED | ERROR | EVENT | CONTINUOUS;
/// `fmi2SetReal` and friends (which variables, [`Variable::settable`]).
pub(crate) const SETTABLE: u16 = INSTANTIATED | INIT | STEP_COMPLETE | EVENT | CONTINUOUS;
/// `fmi2SetRealInputDerivatives` (Co-Simulation only).
pub(crate) const CS_SETTABLE: u16 = INSTANTIATED | INIT | STEP_COMPLETE;
pub(crate) const STEPPED: u16 = STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED;

/// One FMU instance: the state machine, the importer's callbacks and the model.
pub struct Instance<M> {
    pub(crate) state: State,
    /// Created by `fmi3Instantiate*` (FMI 3.0 names, value references and logger).
    pub(crate) fmi3: bool,
    /// Instantiated as `fmi2ModelExchange` (else Co-Simulation).
    model_exchange: bool,
    logger: Logger,
    instance_name: String,
    resource_dir: Option<PathBuf>,
    pub(crate) time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    pub(crate) last_successful_time: f64,
    /// `fmi3InstantiateCoSimulation` with `earlyReturnAllowed = fmi3True` of a
    /// model that might return early ([`CoSimModel::MIGHT_RETURN_EARLY`]):
    /// `fmi3DoStep` runs [`CoSimModel::do_step_early`].
    pub(crate) early_return_allowed: bool,
    pub(crate) model: M,
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

/// The FMI 3.0 name of a shared function (messages of an FMI 3.0 instance
/// name the function the importer called).
pub(crate) fn fmi3_name(func: &str) -> std::borrow::Cow<'_, str> {
    let name = match func {
        "fmi2GetReal" => "fmi3GetFloat64",
        "fmi2SetReal" => "fmi3SetFloat64",
        "fmi2GetInteger" => "fmi3GetInt32",
        "fmi2SetInteger" => "fmi3SetInt32",
        "fmi2GetFMUstate" => "fmi3GetFMUState",
        "fmi2SetFMUstate" => "fmi3SetFMUState",
        "fmi2FreeFMUstate" => "fmi3FreeFMUState",
        "fmi2SerializedFMUstateSize" => "fmi3SerializedFMUStateSize",
        "fmi2SerializeFMUstate" => "fmi3SerializeFMUState",
        "fmi2DeSerializeFMUstate" => "fmi3DeserializeFMUState",
        "fmi2GetDerivatives" => "fmi3GetContinuousStateDerivatives",
        "fmi2GetRealOutputDerivatives" => "fmi3GetOutputDerivatives",
        "fmi2SetupExperiment" | "fmi2EnterInitializationMode" => "fmi3EnterInitializationMode",
        f => return f.replacen("fmi2", "fmi3", 1).into(),
    };
    name.into()
}

/// Run `f` on the instance behind `c` if the state allows `func`.
pub(crate) unsafe fn run<M: CoSimModel>(
    c: Component,
    func: &str,
    allowed: u16,
    f: impl FnOnce(&mut Instance<M>) -> Result<Status, ModelError>,
) -> Status {
    if c.is_null() {
        return Status::Error;
    }
    let ptr = c as *mut Instance<M>;
    let renamed;
    let func = if (*ptr).fmi3 {
        renamed = fmi3_name(func);
        &*renamed
    } else {
        func
    };
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
pub(crate) unsafe fn run_me<M: CoSimModel>(
    c: Component,
    func: &str,
    allowed: u16,
    f: impl FnOnce(&mut Instance<M>) -> Result<Status, ModelError>,
) -> Status {
    // SAFETY: as in `run` (a non-null component is an `Instance<M>`)
    if !c.is_null() && !(*(c as *mut Instance<M>)).model_exchange {
        return run::<M>(c, func, ALIVE, |_| {
            let fmi3 = (*(c as *mut Instance<M>)).fmi3;
            Err(ModelError::error(if M::CONTINUOUS_STATES.is_empty() {
                "this FMU implements Co-Simulation only (no Model Exchange functions)"
            } else if fmi3 {
                "the instance was created by fmi3InstantiateCoSimulation; Model Exchange functions need fmi3InstantiateModelExchange"
            } else {
                "the instance was instantiated as fmi2CoSimulation; Model Exchange functions need fmuType fmi2ModelExchange"
            }))
        });
    }
    run::<M>(c, func, allowed, f)
}

/// Slice from a C array; `None` for a null pointer with `n > 0`.
pub(crate) unsafe fn slice<'a, T>(p: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        Some(&[])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts(p, n))
    }
}

pub(crate) unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        Some(&mut [])
    } else if p.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts_mut(p, n))
    }
}

pub(crate) fn null_arg(name: &str) -> ModelError {
    ModelError::error(format!("argument {name} is a NULL pointer"))
}

/// The variable of type `ty` with value reference `vr` (FMI 3.0: the
/// variable's FMI 3.0 value reference, [`crate::render3::fmi3_value_reference`]).
pub(crate) fn find<M: CoSimModel>(
    fmi3: bool,
    vr: u32,
    ty: VarType,
) -> Result<&'static Variable, ModelError> {
    M::VARIABLES
        .iter()
        .find(|v| {
            v.ty == ty
                && if fmi3 && ty != VarType::Real {
                    crate::render3::fmi3_value_reference(M::VARIABLES, v) == vr
                } else {
                    v.vr == vr
                }
        })
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

pub(crate) unsafe fn opt_str<'a>(p: *const c_char) -> Option<&'a str> {
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
    let model_exchange = match fmu_type {
        FMI2_CO_SIMULATION => Ok(false),
        FMI2_MODEL_EXCHANGE if !M::CONTINUOUS_STATES.is_empty() => Ok(true),
        FMI2_MODEL_EXCHANGE => Err(
            "fmi2Instantiate: this FMU implements Co-Simulation only (fmuType fmi2ModelExchange refused)"
                .to_string(),
        ),
        _ => Err(format!(
            "fmi2Instantiate: fmuType must be fmi2ModelExchange ({FMI2_MODEL_EXCHANGE}) or fmi2CoSimulation ({FMI2_CO_SIMULATION}), got {fmu_type}"
        )),
    };
    let resource_dir = |logger: &Logger| match opt_str(resource_location) {
        None | Some("") => None,
        Some(uri) => match crate::uri::file_uri_to_path(uri) {
            Ok(p) => Some(p),
            Err(e) => {
                logger.warning(&format!("fmi2Instantiate: {e}; resources unavailable"));
                None
            }
        },
    };
    create::<M>(
        "fmi2Instantiate",
        name,
        model_exchange,
        opt_str(guid),
        resource_dir,
        logger,
        false,
    )
}

/// The instantiation both versions share: checks the instance name (after
/// `model_exchange`, the caller's decoding of the interface type) and the
/// GUID (`instantiationToken`), builds the model with `resource_dir` and
/// returns the new instance, or NULL with the reason logged through `logger`.
pub(crate) unsafe fn create<M: CoSimModel>(
    func: &str,
    name: Option<&str>,
    model_exchange: Result<bool, String>,
    guid: Option<&str>,
    resource_dir: impl FnOnce(&Logger) -> Option<PathBuf>,
    logger: Logger,
    fmi3: bool,
) -> Component {
    let result = catch_unwind(AssertUnwindSafe(|| -> Result<Instance<M>, String> {
        let name = match name {
            Some(n) if !n.is_empty() => n.to_string(),
            _ => return Err(format!("{func}: instanceName must be a non-empty string")),
        };
        let model_exchange = model_exchange?;
        match guid {
            Some(g) if g == M::GUID => {}
            g => {
                let what = if fmi3 { "instantiationToken" } else { "GUID" };
                return Err(format!(
                    "{func}: {what} mismatch: expected {} but was {:?}",
                    M::GUID,
                    g
                ));
            }
        }
        let resource_dir = resource_dir(&logger);
        let ctx = InstantiateContext {
            instance_name: &name,
            resource_dir: resource_dir.clone(),
            logger: &logger,
        };
        let model = M::instantiate(&ctx).map_err(|e| format!("{func}: {}", e.message))?;
        Ok(Instance {
            state: State::Instantiated,
            fmi3,
            model_exchange,
            logger: Logger::with_callback(
                logger.callback(),
                logger.env(),
                &name,
                logger.logging_on,
            ),
            instance_name: name,
            resource_dir,
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            last_successful_time: 0.0,
            early_return_allowed: false,
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
                "{func}: internal error (panic): {}",
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

/// A Real value handed out must be finite: never fmi2OK with NaN or inf.
pub(crate) fn finite(vr: ValueReference, x: f64) -> Result<f64, ModelError> {
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
pub(crate) fn outputs_finite<M: CoSimModel>(
    m: &M,
    outputs: &[u32],
    t: f64,
) -> Result<(), ModelError> {
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

mod values;
pub use values::*;
mod fmu_state;
pub use fmu_state::*;
mod cosim;
pub use cosim::*;
mod model_exchange;
pub use model_exchange::*;

/// Marker so `c_void` stays referenced in docs of the generated symbols.
#[doc(hidden)]
pub type Void = c_void;
