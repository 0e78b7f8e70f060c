//! The FMI 3.0 Co-Simulation and Model Exchange functions, generic over the
//! model; [`crate::export_fmu3!`] exports one `extern "C"` `fmi3*` symbol per
//! function of the FMI 3.0 C API (every one fmpy binds at load time) that
//! forwards here.
//!
//! Nothing of the FMI 2.0 layer ([`crate::ffi`]) is copied: an FMI 3.0
//! instance is the same [`crate::ffi::Instance`] (flagged `fmi3`), with the
//! same state machine, argument checks, `catch_unwind`, logging and FMU
//! state (the same serialized blob). The functions here only translate the
//! FMI 3.0 signatures (counts of values, `fmi3Boolean` = C `bool`, out
//! parameters, `fmi3EnterInitializationMode` = `fmi2SetupExperiment` +
//! `fmi2EnterInitializationMode`) and answer what the models do not have:
//!
//! * variables of types other than Float64, Int32, Boolean, String and
//!   the UInt64 structural parameters of [`arrays`] (a call with value
//!   references is an error; with none, `fmi3OK`), Binary, clocks,
//!   scheduled execution, Configuration Mode of a model without structural
//!   parameters, adjoint derivatives, per-element dependencies, event mode
//!   in Co-Simulation (`hasEventMode="false"`): `fmi3Error` with the reason
//!   logged;
//! * Float64 array outputs and Configuration Mode: [`arrays`];
//! * no event indicators, no discrete states: `fmi3UpdateDiscreteStates`
//!   reports nothing to do;
//! * `fmi3DoStep` never asks for event handling and always sets its out
//!   parameters; it returns early (and may ask for termination) only for a
//!   model that declares it ([`CoSimModel::MIGHT_RETURN_EARLY`]) in an
//!   instance whose importer allowed it.
#![allow(clippy::missing_safety_doc, clippy::too_many_arguments)]
use std::os::raw::{c_char, c_void};
use std::path::PathBuf;

use crate::ffi::{
    self, null_arg, opt_str, run, run_me, Instance, ALIVE, EVENT, GETTABLE, SETTABLE,
};
use crate::model::{CoSimModel, LogMessage3, Logger, ModelError, StepOutcome};
use crate::types::{Component, ComponentEnvironment, FmiString, FmuState, Status, ValueReference};

mod arrays;
pub use arrays::*;

/// `fmi3IntermediateUpdateCallback` (never called: `providesIntermediateUpdate="false"`,
/// argued in the FMU READMEs).
pub type IntermediateUpdate =
    unsafe extern "C" fn(ComponentEnvironment, f64, bool, bool, bool, bool, *mut bool, *mut f64);

/// `fmi3GetVersion`.
pub fn get_version() -> *const c_char {
    c"3.0".as_ptr()
}

/// An `fmi3Error` with `message` logged (the instance goes to the error state).
unsafe fn refuse<M: CoSimModel>(c: Component, func: &str, message: String) -> Status {
    run::<M>(c, func, ALIVE, |_| Err(ModelError::error(message)))
}

/// More value references than any importer passes (a larger count is a
/// corrupted argument; refused before a buffer of that size is allocated).
pub(crate) const MAX_VALUE_REFERENCES: usize = 1 << 24;

/// `nValues` must equal `nValueReferences` (every variable is a scalar;
/// arrays: [`arrays::get_float64`]).
pub(crate) fn check_counts(n_vr: usize, n_values: usize) -> Result<(), ModelError> {
    if n_vr > MAX_VALUE_REFERENCES {
        return Err(ModelError::error(format!(
            "nValueReferences = {n_vr} exceeds {MAX_VALUE_REFERENCES}"
        )));
    }
    if n_vr == n_values {
        Ok(())
    } else {
        Err(ModelError::error(format!(
            "nValues = {n_values} but nValueReferences = {n_vr} (every variable of this FMU is a scalar)"
        )))
    }
}

/// Refuse a count mismatch (logged, fmi3Error) before the shared function runs.
pub(crate) unsafe fn counts<M: CoSimModel>(
    c: Component,
    func: &str,
    n_vr: usize,
    n_values: usize,
) -> Option<Status> {
    match check_counts(n_vr, n_values) {
        Ok(()) => None,
        Err(e) => Some(run::<M>(c, func, ALIVE, |_| Err(e))),
    }
}

/// The FMI 3.0 `resourcePath`: a directory path (a `file:` URI is accepted too).
fn resource_path(p: Option<&str>, logger: &Logger, func: &str) -> Option<PathBuf> {
    match p {
        None | Some("") => None,
        Some(u) if u.starts_with("file:") => match crate::uri::file_uri_to_path(u) {
            Ok(p) => Some(p),
            Err(e) => {
                logger.warning(&format!("{func}: {e}; resources unavailable"));
                None
            }
        },
        Some(p) => Some(PathBuf::from(p)),
    }
}

/// `fmi3InstantiateModelExchange` (NULL for a Co-Simulation-only model).
pub unsafe fn instantiate_model_exchange<M: CoSimModel>(
    instance_name: FmiString,
    token: FmiString,
    resource: FmiString,
    _visible: bool,
    logging_on: bool,
    env: ComponentEnvironment,
    log: Option<LogMessage3>,
) -> Component {
    const F: &str = "fmi3InstantiateModelExchange";
    let name = opt_str(instance_name);
    let logger = Logger::fmi3(log, env, name.unwrap_or("?"), logging_on);
    let me = if M::CONTINUOUS_STATES.is_empty() {
        Err(format!(
            "{F}: this FMU implements Co-Simulation only (no <ModelExchange> in its modelDescription)"
        ))
    } else {
        Ok(true)
    };
    let res = opt_str(resource);
    ffi::create::<M>(
        F,
        name,
        me,
        opt_str(token),
        |l| resource_path(res, l, F),
        logger,
        true,
    )
}

/// `fmi3InstantiateCoSimulation`: `eventModeUsed` is refused
/// (`hasEventMode="false"`); `earlyReturnAllowed` switches `fmi3DoStep` to
/// [`CoSimModel::do_step_early`] for a model that might return early
/// ([`CoSimModel::MIGHT_RETURN_EARLY`]; else it is unused); the
/// intermediate variables and the intermediate update callback are
/// accepted and unused (`providesIntermediateUpdate="false"`: the FMU
/// never calls it).
pub unsafe fn instantiate_co_simulation<M: CoSimModel>(
    instance_name: FmiString,
    token: FmiString,
    resource: FmiString,
    _visible: bool,
    logging_on: bool,
    event_mode_used: bool,
    early_return_allowed: bool,
    _required_intermediate: *const ValueReference,
    _n_required_intermediate: usize,
    env: ComponentEnvironment,
    log: Option<LogMessage3>,
    _intermediate_update: Option<IntermediateUpdate>,
) -> Component {
    const F: &str = "fmi3InstantiateCoSimulation";
    let name = opt_str(instance_name);
    let logger = Logger::fmi3(log, env, name.unwrap_or("?"), logging_on);
    let cs = if event_mode_used {
        Err(format!(
            "{F}: eventModeUsed = true refused: the FMU has no events (hasEventMode=\"false\")"
        ))
    } else {
        Ok(false)
    };
    let res = opt_str(resource);
    let c = ffi::create::<M>(
        F,
        name,
        cs,
        opt_str(token),
        |l| resource_path(res, l, F),
        logger,
        true,
    );
    if !c.is_null() {
        // SAFETY: a non-null component just created by `create::<M>`
        (*(c as *mut Instance<M>)).early_return_allowed =
            early_return_allowed && M::MIGHT_RETURN_EARLY;
    }
    c
}

/// `fmi3InstantiateScheduledExecution`: not provided (NULL, logged).
pub unsafe fn instantiate_scheduled_execution<M: CoSimModel>(
    instance_name: FmiString,
    env: ComponentEnvironment,
    log: Option<LogMessage3>,
    logging_on: bool,
) -> Component {
    let name = opt_str(instance_name);
    Logger::fmi3(log, env, name.unwrap_or("?"), logging_on).error(
        "fmi3InstantiateScheduledExecution: this FMU provides Model Exchange and Co-Simulation only \
         (no <ScheduledExecution>, no clocks)",
    );
    std::ptr::null_mut()
}

/// `fmi3SetDebugLogging`.
pub unsafe fn set_debug_logging<M: CoSimModel>(
    c: Component,
    on: bool,
    n: usize,
    cats: *const FmiString,
) -> Status {
    ffi::set_debug_logging::<M>(c, on as i32, n, cats)
}

/// `fmi3EnterInitializationMode`: the experiment (FMI 2.0's
/// `fmi2SetupExperiment`) and the mode change.
pub unsafe fn enter_initialization_mode<M: CoSimModel>(
    c: Component,
    tolerance_defined: bool,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: bool,
    stop_time: f64,
) -> Status {
    let s = ffi::setup_experiment::<M>(
        c,
        tolerance_defined as i32,
        tolerance,
        start_time,
        stop_time_defined as i32,
        stop_time,
    );
    if s > Status::Warning {
        return s;
    }
    s.max(ffi::enter_initialization_mode::<M>(c))
}

/// `fmi3SetFloat64`.
pub unsafe fn set_float64<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *const f64,
    nv: usize,
) -> Status {
    counts::<M>(c, "fmi3SetFloat64", n, nv).unwrap_or_else(|| ffi::set_real::<M>(c, vr, n, v))
}

/// `fmi3GetInt32`.
pub unsafe fn get_int32<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *mut i32,
    nv: usize,
) -> Status {
    counts::<M>(c, "fmi3GetInt32", n, nv).unwrap_or_else(|| ffi::get_integer::<M>(c, vr, n, v))
}

/// `fmi3SetInt32`.
pub unsafe fn set_int32<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *const i32,
    nv: usize,
) -> Status {
    counts::<M>(c, "fmi3SetInt32", n, nv).unwrap_or_else(|| ffi::set_integer::<M>(c, vr, n, v))
}

/// `fmi3GetBoolean` (`fmi3Boolean` is C `bool`).
pub unsafe fn get_boolean<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *mut bool,
    nv: usize,
) -> Status {
    if let Some(s) = counts::<M>(c, "fmi3GetBoolean", n, nv) {
        return s;
    }
    let mut tmp = vec![0i32; n];
    let out = if v.is_null() {
        std::ptr::null_mut()
    } else {
        tmp.as_mut_ptr()
    };
    let s = ffi::get_boolean::<M>(c, vr, n, out);
    if s <= Status::Warning && n > 0 && !v.is_null() {
        for (i, &b) in tmp.iter().enumerate() {
            *v.add(i) = b != 0;
        }
    }
    s
}

/// `fmi3SetBoolean`.
pub unsafe fn set_boolean<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *const u8,
    nv: usize,
) -> Status {
    if let Some(s) = counts::<M>(c, "fmi3SetBoolean", n, nv) {
        return s;
    }
    let tmp: Vec<i32> = if v.is_null() || n == 0 {
        Vec::new()
    } else {
        std::slice::from_raw_parts(v, n)
            .iter()
            .map(|&b| (b != 0) as i32)
            .collect()
    };
    let p = if v.is_null() {
        std::ptr::null()
    } else {
        tmp.as_ptr()
    };
    ffi::set_boolean::<M>(c, vr, n, p)
}

/// `fmi3GetString` (the strings stay valid until the next call).
pub unsafe fn get_string<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *mut FmiString,
    nv: usize,
) -> Status {
    counts::<M>(c, "fmi3GetString", n, nv).unwrap_or_else(|| ffi::get_string::<M>(c, vr, n, v))
}

/// `fmi3SetString`.
pub unsafe fn set_string<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *const FmiString,
    nv: usize,
) -> Status {
    counts::<M>(c, "fmi3SetString", n, nv).unwrap_or_else(|| ffi::set_string::<M>(c, vr, n, v))
}

/// A getter or setter of a type the model has no variable of (Float32, the
/// integer widths other than 32 bit, Binary, Clock): `fmi3OK` for no value
/// references, else `fmi3Error` naming the first.
pub unsafe fn no_such_type<M: CoSimModel>(
    c: Component,
    func: &str,
    ty: &str,
    vr: *const ValueReference,
    n: usize,
    setter: bool,
) -> Status {
    let allowed = if setter { SETTABLE } else { GETTABLE };
    run::<M>(c, func, allowed, |_| {
        if n == 0 {
            return Ok(Status::Ok);
        }
        if vr.is_null() {
            return Err(null_arg("valueReferences"));
        }
        Err(ModelError::error(format!(
            "unknown value reference {} (the FMU has no {ty} variables)",
            *vr
        )))
    })
}

/// A function of a feature the FMU does not provide: `fmi3Error` with `why` logged.
pub unsafe fn unsupported<M: CoSimModel>(c: Component, func: &str, why: &str) -> Status {
    refuse::<M>(c, func, why.to_string())
}

/// `fmi3GetFMUState`.
pub unsafe fn get_fmu_state<M: CoSimModel>(c: Component, s: *mut FmuState) -> Status {
    ffi::get_fmu_state::<M>(c, s)
}

/// `fmi3SetFMUState`.
pub unsafe fn set_fmu_state<M: CoSimModel>(c: Component, s: FmuState) -> Status {
    ffi::set_fmu_state::<M>(c, s)
}

/// `fmi3FreeFMUState`.
pub unsafe fn free_fmu_state<M: CoSimModel>(c: Component, s: *mut FmuState) -> Status {
    ffi::free_fmu_state::<M>(c, s)
}

/// `fmi3SerializedFMUStateSize`.
pub unsafe fn serialized_fmu_state_size<M: CoSimModel>(
    c: Component,
    s: FmuState,
    size: *mut usize,
) -> Status {
    ffi::serialized_fmu_state_size::<M>(c, s, size)
}

/// `fmi3SerializeFMUState` (the same bytes as `fmi2SerializeFMUstate`).
pub unsafe fn serialize_fmu_state<M: CoSimModel>(
    c: Component,
    s: FmuState,
    buf: *mut u8,
    size: usize,
) -> Status {
    ffi::serialize_fmu_state::<M>(c, s, buf as *mut c_char, size)
}

/// `fmi3DeserializeFMUState`.
pub unsafe fn deserialize_fmu_state<M: CoSimModel>(
    c: Component,
    buf: *const u8,
    size: usize,
    s: *mut FmuState,
) -> Status {
    ffi::deserialize_fmu_state::<M>(c, buf as *const c_char, size, s)
}

/// `fmi3GetDirectionalDerivative`: `sensitivity = J seed` from the model's
/// partial derivatives (`nSeed = nKnowns`, `nSensitivity = nUnknowns`).
pub unsafe fn get_directional_derivative<M: CoSimModel>(
    c: Component,
    unknowns: *const ValueReference,
    n_unknowns: usize,
    knowns: *const ValueReference,
    n_knowns: usize,
    seed: *const f64,
    n_seed: usize,
    sensitivity: *mut f64,
    n_sensitivity: usize,
) -> Status {
    const F: &str = "fmi3GetDirectionalDerivative";
    if n_seed != n_knowns || n_sensitivity != n_unknowns {
        return refuse::<M>(
            c,
            F,
            format!(
                "nSeed = {n_seed}, nKnowns = {n_knowns}, nSensitivity = {n_sensitivity}, nUnknowns = {n_unknowns}: \
                 every variable is a scalar, so nSeed = nKnowns and nSensitivity = nUnknowns"
            ),
        );
    }
    ffi::get_directional_derivative::<M>(
        c,
        unknowns,
        n_unknowns,
        knowns,
        n_knowns,
        seed,
        sensitivity,
    )
}

/// `fmi3GetOutputDerivatives` (orders >= 1, up to `maxOutputDerivativeOrder`).
pub unsafe fn get_output_derivatives<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    orders: *const i32,
    v: *mut f64,
    nv: usize,
) -> Status {
    counts::<M>(c, "fmi3GetOutputDerivatives", n, nv)
        .unwrap_or_else(|| ffi::get_real_output_derivatives::<M>(c, vr, n, orders, v))
}

/// `fmi3DoStep` (FMI 3.0 section 4.2.1): always synchronous, no event
/// handling; the out parameters are set whatever the outcome
/// (`lastSuccessfulTime`: the instance's time). An instance created with
/// `earlyReturnAllowed` of a model that might return early steps through
/// [`CoSimModel::do_step_early`]: a stop at an event returns `earlyReturn =
/// fmi3True` with `lastSuccessfulTime` the time reached, and, when the model
/// is not valid beyond it, `terminateSimulation = fmi3True` with
/// `fmi3Warning`.
pub unsafe fn do_step<M: CoSimModel>(
    c: Component,
    t: f64,
    h: f64,
    _no_set_prior: bool,
    event_handling_needed: *mut bool,
    terminate_simulation: *mut bool,
    early_return: *mut bool,
    last_successful_time: *mut f64,
) -> Status {
    for p in [event_handling_needed, terminate_simulation, early_return] {
        if !p.is_null() {
            *p = false;
        }
    }
    let s = run::<M>(c, "fmi3DoStep", ffi::STEP_COMPLETE, |inst| {
        for (p, name) in [
            (event_handling_needed.is_null(), "eventHandlingNeeded"),
            (terminate_simulation.is_null(), "terminateSimulation"),
            (early_return.is_null(), "earlyReturn"),
            (last_successful_time.is_null(), "lastSuccessfulTime"),
        ] {
            if p {
                return Err(null_arg(name));
            }
        }
        let early = inst.early_return_allowed;
        let (status, outcome) = ffi::step_early(inst, t, h, early)?;
        if let StepOutcome::EarlyReturn { terminate, .. } = outcome {
            *early_return = true;
            *terminate_simulation = terminate;
        }
        Ok(status)
    });
    if !c.is_null() && !last_successful_time.is_null() {
        *last_successful_time = (*(c as *mut Instance<M>)).last_successful_time;
    }
    s
}

/// `fmi3UpdateDiscreteStates` (Model Exchange, Event Mode): no discrete
/// states, no time events: nothing to update.
pub unsafe fn update_discrete_states<M: CoSimModel>(
    c: Component,
    discrete_states_need_update: *mut bool,
    terminate_simulation: *mut bool,
    nominals_changed: *mut bool,
    values_changed: *mut bool,
    next_event_time_defined: *mut bool,
    next_event_time: *mut f64,
) -> Status {
    run_me::<M>(c, "fmi3UpdateDiscreteStates", EVENT, |_| {
        for (p, name) in [
            (discrete_states_need_update, "discreteStatesNeedUpdate"),
            (terminate_simulation, "terminateSimulation"),
            (nominals_changed, "nominalsOfContinuousStatesChanged"),
            (values_changed, "valuesOfContinuousStatesChanged"),
            (next_event_time_defined, "nextEventTimeDefined"),
        ] {
            if p.is_null() {
                return Err(null_arg(name));
            }
        }
        if next_event_time.is_null() {
            return Err(null_arg("nextEventTime"));
        }
        for p in [
            discrete_states_need_update,
            terminate_simulation,
            nominals_changed,
            values_changed,
            next_event_time_defined,
        ] {
            *p = false;
        }
        *next_event_time = 0.0;
        Ok(Status::Ok)
    })
}

/// `fmi3CompletedIntegratorStep`: never asks for an event or termination.
pub unsafe fn completed_integrator_step<M: CoSimModel>(
    c: Component,
    no_set_prior: bool,
    enter_event_mode: *mut bool,
    terminate_simulation: *mut bool,
) -> Status {
    let (mut e, mut t) = (0i32, 0i32);
    let ep = if enter_event_mode.is_null() {
        std::ptr::null_mut()
    } else {
        &mut e as *mut i32
    };
    let tp = if terminate_simulation.is_null() {
        std::ptr::null_mut()
    } else {
        &mut t as *mut i32
    };
    let s = ffi::completed_integrator_step::<M>(c, no_set_prior as i32, ep, tp);
    if s <= Status::Warning {
        *enter_event_mode = e != 0;
        *terminate_simulation = t != 0;
    }
    s
}

/// `fmi3GetNumberOfContinuousStates`.
pub unsafe fn get_number_of_continuous_states<M: CoSimModel>(
    c: Component,
    n: *mut usize,
) -> Status {
    run_me::<M>(c, "fmi3GetNumberOfContinuousStates", ALIVE, |_| {
        if n.is_null() {
            return Err(null_arg("nContinuousStates"));
        }
        *n = M::CONTINUOUS_STATES.len();
        Ok(Status::Ok)
    })
}

/// `fmi3GetNumberOfEventIndicators`: 0.
pub unsafe fn get_number_of_event_indicators<M: CoSimModel>(c: Component, n: *mut usize) -> Status {
    run_me::<M>(c, "fmi3GetNumberOfEventIndicators", ALIVE, |_| {
        if n.is_null() {
            return Err(null_arg("nEventIndicators"));
        }
        *n = 0;
        Ok(Status::Ok)
    })
}

/// Marker so `c_void` stays referenced in docs of the generated symbols.
#[doc(hidden)]
pub type Void = c_void;
