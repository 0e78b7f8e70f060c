//! In-process checks of a model's FMI 3.0 interface that every FMU crate's
//! tests run (`tests/it/fmi3.rs`), through the functions the `fmi3*`
//! symbols forward to ([`crate::fmi3`], and [`crate::ffi`] for the FMI 2.0
//! side of the comparisons):
//!
//! * [`cs_equals_fmi2`]: `fmi3DoStep` gives bit for bit the outputs of
//!   `fmi2DoStep` for the same parameters and inputs;
//! * [`me_equals_fmi2`]: `fmi3GetContinuousStateDerivatives` equals
//!   `fmi2GetDerivatives` at the same states;
//! * [`state_round_trip`]: `fmi3GetFMUState` / `fmi3SetFMUState` and the
//!   serialized state (the same bytes as FMI 2.0's) restore a run exactly;
//! * [`directional_derivatives`]: `fmi3GetDirectionalDerivative` against a
//!   central difference of the FMU's own outputs (and state derivatives);
//! * [`fuzz`]: random call sequences (wrong state, NULL, NaN, huge steps,
//!   truncated state blobs): no panic, no hang, never a non-finite Float64
//!   with `fmi3OK`.
// The helpers take the instances they created themselves (`instantiate3`)
// and call the exported functions on them, as a test would: safe to call.
#![allow(clippy::missing_safety_doc, clippy::not_unsafe_ptr_arg_deref)]
use std::ffi::CString;
use std::os::raw::c_char;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::model::{Causality, CoSimModel, VarType, Variability};
use crate::types::{CallbackFunctions, Component, FmuState, Status};
use crate::{ffi, fmi3};

/// Parameters and inputs set before initialization (Float64 value reference, value).
pub type Values<'a> = &'a [(u32, f64)];

unsafe extern "C" fn quiet3(
    _: *mut std::ffi::c_void,
    _: Status,
    _: *const c_char,
    _: *const c_char,
) {
}

fn cstr(s: &str) -> CString {
    CString::new(s).expect("no NUL")
}

/// An FMI 3.0 instance (`cs`: Co-Simulation, else Model Exchange) with the
/// resources folder `res`.
pub fn instantiate3<M: CoSimModel>(cs: bool, res: Option<&Path>) -> Component {
    let name = cstr("fmi3-test");
    let token = cstr(M::GUID);
    let res = res.map(|p| cstr(&format!("{}/", p.display())));
    let rp = res.as_ref().map_or(std::ptr::null(), |r| r.as_ptr());
    // SAFETY: valid strings, a logger that ignores its arguments
    unsafe {
        if cs {
            co_simulation3::<M>(&name, &token, rp, false, false, quiet3)
        } else {
            fmi3::instantiate_model_exchange::<M>(
                name.as_ptr(),
                token.as_ptr(),
                rp,
                false,
                false,
                std::ptr::null_mut(),
                Some(quiet3),
            )
        }
    }
}

/// `fmi3InstantiateCoSimulation` without event mode and intermediate update.
unsafe fn co_simulation3<M: CoSimModel>(
    name: &CString,
    token: &CString,
    resources: *const c_char,
    logging_on: bool,
    early_return_allowed: bool,
    log: crate::LogMessage3,
) -> Component {
    fmi3::instantiate_co_simulation::<M>(
        name.as_ptr(),
        token.as_ptr(),
        resources,
        false,
        logging_on,
        false,
        early_return_allowed,
        std::ptr::null(),
        0,
        std::ptr::null_mut(),
        Some(log),
        None,
    )
}

thread_local! {
    /// Messages of [`instantiate3_early`] instances logged on this thread.
    static LOGGED: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
}

unsafe extern "C" fn record3(
    _: *mut std::ffi::c_void,
    _: Status,
    _: *const c_char,
    m: *const c_char,
) {
    let m = std::ffi::CStr::from_ptr(m).to_string_lossy().into_owned();
    LOGGED.with(|l| l.borrow_mut().push(m));
}

/// The messages [`instantiate3_early`] instances logged on this thread
/// since the last call (taken).
pub fn take_logged() -> Vec<String> {
    LOGGED.with(|l| std::mem::take(&mut *l.borrow_mut()))
}

/// An FMI 3.0 Co-Simulation instance created with `earlyReturnAllowed`,
/// logging on, its messages kept for [`take_logged`] (not initialized:
/// [`initialize3`]).
pub fn instantiate3_early<M: CoSimModel>(
    res: Option<&Path>,
    early_return_allowed: bool,
) -> Result<Component, String> {
    let name = cstr("fmi3-early");
    let token = cstr(M::GUID);
    let res = res.map(|p| cstr(&format!("{}/", p.display())));
    let rp = res.as_ref().map_or(std::ptr::null(), |r| r.as_ptr());
    // SAFETY: valid strings, a logger that copies the message
    let c = unsafe { co_simulation3::<M>(&name, &token, rp, true, early_return_allowed, record3) };
    if c.is_null() {
        return Err(format!("instantiation failed: {:?}", take_logged()));
    }
    Ok(c)
}

/// Set the Float64 `values` and initialize an FMI 3.0 instance at t = 0.
pub fn initialize3<M: CoSimModel>(c: Component, values: Values) -> Result<(), String> {
    init3::<M>(c, values)
}

/// `fmi3DoStep`'s status and out parameters `(eventHandlingNeeded,
/// terminateSimulation, earlyReturn, lastSuccessfulTime)`.
pub fn do_step3<M: CoSimModel>(c: Component, t: f64, h: f64) -> (Status, [bool; 3], f64) {
    let (mut ev, mut term, mut early, mut last) = (true, true, true, f64::NAN);
    // SAFETY: valid out pointers; `c` from an instantiation of `M`
    let s =
        unsafe { fmi3::do_step::<M>(c, t, h, false, &mut ev, &mut term, &mut early, &mut last) };
    (s, [ev, term, early], last)
}

/// Float64 values of `c` (`fmi3GetFloat64`).
pub fn get_float64<M: CoSimModel>(c: Component, vrs: &[u32]) -> Result<Vec<f64>, String> {
    get3::<M>(c, vrs)
}

/// An FMI 2.0 instance like [`instantiate3`] (no logger).
pub fn instantiate2<M: CoSimModel>(cs: bool, res: Option<&Path>) -> Component {
    let name = cstr("fmi2-test");
    let guid = cstr(M::GUID);
    let res = res.map(|p| cstr(&format!("file://{}", p.display())));
    let rp = res.as_ref().map_or(std::ptr::null(), |r| r.as_ptr());
    let cb = CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: std::ptr::null_mut(),
    };
    // SAFETY: valid strings and callbacks
    unsafe {
        ffi::instantiate::<M>(
            name.as_ptr(),
            if cs {
                crate::types::FMI2_CO_SIMULATION
            } else {
                crate::types::FMI2_MODEL_EXCHANGE
            },
            guid.as_ptr(),
            rp,
            &cb,
            0,
            0,
        )
    }
}

fn ok(s: Status, what: &str) -> Result<(), String> {
    if s <= Status::Warning {
        Ok(())
    } else {
        Err(format!("{what} returned {s:?}"))
    }
}

/// Set `values` (Float64) and initialize an FMI 3.0 instance at t = 0.
fn init3<M: CoSimModel>(c: Component, values: Values) -> Result<(), String> {
    unsafe {
        for &(vr, x) in values {
            ok(fmi3::set_float64::<M>(c, &vr, 1, &x, 1), "fmi3SetFloat64")?;
        }
        ok(
            fmi3::enter_initialization_mode::<M>(c, false, 0.0, 0.0, false, 0.0),
            "fmi3EnterInitializationMode",
        )?;
        ok(
            ffi::exit_initialization_mode::<M>(c),
            "fmi3ExitInitializationMode",
        )
    }
}

/// Set `values` (Real) and initialize an FMI 2.0 instance at t = 0.
fn init2<M: CoSimModel>(c: Component, values: Values) -> Result<(), String> {
    unsafe {
        for &(vr, x) in values {
            ok(ffi::set_real::<M>(c, &vr, 1, &x), "fmi2SetReal")?;
        }
        ok(
            ffi::setup_experiment::<M>(c, 0, 0.0, 0.0, 0, 0.0),
            "fmi2SetupExperiment",
        )?;
        ok(
            ffi::enter_initialization_mode::<M>(c),
            "fmi2EnterInitializationMode",
        )?;
        ok(
            ffi::exit_initialization_mode::<M>(c),
            "fmi2ExitInitializationMode",
        )
    }
}

fn real_vrs<M: CoSimModel>(causality: Causality) -> Vec<u32> {
    M::VARIABLES
        .iter()
        .filter(|v| {
            v.ty == VarType::Real
                && v.causality == causality
                && v.variability == Variability::Continuous
        })
        .map(|v| v.vr)
        .collect()
}

/// One FMI 3.0 step with its out parameters checked.
fn step3<M: CoSimModel>(c: Component, t: f64, h: f64) -> Result<(), String> {
    let (mut ev, mut term, mut early, mut last) = (true, true, true, f64::NAN);
    let s =
        unsafe { fmi3::do_step::<M>(c, t, h, false, &mut ev, &mut term, &mut early, &mut last) };
    ok(s, "fmi3DoStep")?;
    if ev || term || early || last != t + h {
        return Err(format!(
            "fmi3DoStep out parameters: eventHandlingNeeded {ev}, terminateSimulation {term}, \
             earlyReturn {early}, lastSuccessfulTime {last} (expected {})",
            t + h
        ));
    }
    Ok(())
}

fn get3<M: CoSimModel>(c: Component, vrs: &[u32]) -> Result<Vec<f64>, String> {
    let mut v = vec![0.0; vrs.len()];
    ok(
        unsafe { fmi3::get_float64::<M>(c, vrs.as_ptr(), vrs.len(), v.as_mut_ptr(), v.len()) },
        "fmi3GetFloat64",
    )?;
    Ok(v)
}

fn get2<M: CoSimModel>(c: Component, vrs: &[u32]) -> Result<Vec<f64>, String> {
    let mut v = vec![0.0; vrs.len()];
    ok(
        unsafe { ffi::get_real::<M>(c, vrs.as_ptr(), vrs.len(), v.as_mut_ptr()) },
        "fmi2GetReal",
    )?;
    Ok(v)
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Co-Simulation: `steps` steps with the inputs `inputs(k)` set before step
/// `k`, through FMI 3.0 and FMI 2.0: every continuous Real output after
/// every step must be the same bit for bit. The steps are `h`, `h/2`,
/// `3h/2`, ... when the model declares `canHandleVariableCommunicationStepSize`
/// (so that the capability is exercised through FMI 3.0), else `h`. Returns the number
/// of values compared.
pub fn cs_equals_fmi2<M: CoSimModel>(
    res: Option<&Path>,
    values: Values,
    inputs: &dyn Fn(usize) -> Vec<(u32, f64)>,
    h: f64,
    steps: usize,
) -> Result<usize, String> {
    let c3 = instantiate3::<M>(true, res);
    let c2 = instantiate2::<M>(true, res);
    if c3.is_null() || c2.is_null() {
        return Err("instantiation failed".into());
    }
    let r = (|| {
        init3::<M>(c3, values)?;
        init2::<M>(c2, values)?;
        let outs = real_vrs::<M>(Causality::Output);
        let mut n = 0;
        let mut t = 0.0;
        for k in 0..steps {
            // variable steps (canHandleVariableCommunicationStepSize): h, h/2, 3h/2, ...
            let h = if M::INFO
                .capabilities
                .can_handle_variable_communication_step_size
            {
                h * [1.0, 0.5, 1.5][k % 3]
            } else {
                h
            };
            for (vr, x) in inputs(k) {
                unsafe {
                    ok(fmi3::set_float64::<M>(c3, &vr, 1, &x, 1), "fmi3SetFloat64")?;
                    ok(ffi::set_real::<M>(c2, &vr, 1, &x), "fmi2SetReal")?;
                }
            }
            step3::<M>(c3, t, h)?;
            ok(unsafe { ffi::do_step::<M>(c2, t, h, 1) }, "fmi2DoStep")?;
            let (y3, y2) = (get3::<M>(c3, &outs)?, get2::<M>(c2, &outs)?);
            if bits(&y3) != bits(&y2) {
                return Err(format!(
                    "step {k}: FMI 3.0 outputs {y3:?} != FMI 2.0 {y2:?}"
                ));
            }
            n += y3.len();
            t += h;
        }
        Ok(n)
    })();
    unsafe {
        ffi::free_instance::<M>(c3);
        ffi::free_instance::<M>(c2);
    }
    r
}

/// Enter Continuous-Time Mode after initialization (FMI 3.0: Event Mode,
/// `fmi3UpdateDiscreteStates`, `fmi3EnterContinuousTimeMode`).
fn continuous_time3<M: CoSimModel>(c: Component) -> Result<(), String> {
    let mut b = [true; 5];
    let mut next = f64::NAN;
    unsafe {
        let [p0, p1, p2, p3, p4] = b.each_mut().map(|p| p as *mut bool);
        ok(
            fmi3::update_discrete_states::<M>(c, p0, p1, p2, p3, p4, &mut next),
            "fmi3UpdateDiscreteStates",
        )?;
        if b.iter().any(|&x| x) {
            return Err(format!("fmi3UpdateDiscreteStates reported {b:?}"));
        }
        ok(
            ffi::enter_continuous_time_mode::<M>(c),
            "fmi3EnterContinuousTimeMode",
        )
    }
}

/// Model Exchange: at each of `states` (with the inputs `values` set), the
/// FMI 3.0 and FMI 2.0 derivatives are the same bit for bit.
pub fn me_equals_fmi2<M: CoSimModel>(
    res: Option<&Path>,
    values: Values,
    states: &[Vec<f64>],
) -> Result<(), String> {
    let nx = M::CONTINUOUS_STATES.len();
    let c3 = instantiate3::<M>(false, res);
    let c2 = instantiate2::<M>(false, res);
    if c3.is_null() || c2.is_null() {
        return Err("instantiation failed".into());
    }
    let r = (|| unsafe {
        init3::<M>(c3, values)?;
        init2::<M>(c2, values)?;
        continuous_time3::<M>(c3)?;
        let mut info = crate::types::EventInfo::default();
        ok(
            ffi::new_discrete_states::<M>(c2, &mut info),
            "fmi2NewDiscreteStates",
        )?;
        ok(
            ffi::enter_continuous_time_mode::<M>(c2),
            "fmi2EnterContinuousTimeMode",
        )?;
        let mut n = 0usize;
        ok(
            fmi3::get_number_of_continuous_states::<M>(c3, &mut n),
            "fmi3GetNumberOfContinuousStates",
        )?;
        if n != nx {
            return Err(format!(
                "fmi3GetNumberOfContinuousStates = {n}, expected {nx}"
            ));
        }
        for (k, x) in states.iter().enumerate() {
            let t = 0.01 * k as f64;
            ok(ffi::set_time::<M>(c3, t), "fmi3SetTime")?;
            ok(ffi::set_time::<M>(c2, t), "fmi2SetTime")?;
            ok(
                ffi::set_continuous_states::<M>(c3, x.as_ptr(), nx),
                "fmi3SetContinuousStates",
            )?;
            ok(
                ffi::set_continuous_states::<M>(c2, x.as_ptr(), nx),
                "fmi2SetContinuousStates",
            )?;
            let (mut d3, mut d2) = (vec![0.0; nx], vec![0.0; nx]);
            ok(
                ffi::get_derivatives::<M>(c3, d3.as_mut_ptr(), nx),
                "fmi3GetContinuousStateDerivatives",
            )?;
            ok(
                ffi::get_derivatives::<M>(c2, d2.as_mut_ptr(), nx),
                "fmi2GetDerivatives",
            )?;
            if bits(&d3) != bits(&d2) {
                return Err(format!(
                    "state {x:?}: FMI 3.0 derivatives {d3:?} != FMI 2.0 {d2:?}"
                ));
            }
            let (mut e, mut term) = (true, true);
            ok(
                fmi3::completed_integrator_step::<M>(c3, true, &mut e, &mut term),
                "fmi3CompletedIntegratorStep",
            )?;
            if e || term {
                return Err("fmi3CompletedIntegratorStep asked for an event or termination".into());
            }
        }
        Ok(())
    })();
    unsafe {
        ffi::free_instance::<M>(c3);
        ffi::free_instance::<M>(c2);
    }
    r
}

/// Co-Simulation through FMI 3.0: after 3 steps the state is saved (in
/// memory and serialized); 2 more steps give the reference outputs; the
/// saved state, and the state deserialized from the bytes, each repeat
/// those 2 steps bit for bit. The serialized bytes are those of FMI 2.0
/// for the same history (the same blob).
pub fn state_round_trip<M: CoSimModel>(
    res: Option<&Path>,
    values: Values,
    inputs: Values,
    h: f64,
) -> Result<(), String> {
    let c = instantiate3::<M>(true, res);
    let c2 = instantiate2::<M>(true, res);
    if c.is_null() || c2.is_null() {
        return Err("instantiation failed".into());
    }
    let outs = real_vrs::<M>(Causality::Output);
    let r = (|| unsafe {
        init3::<M>(c, values)?;
        init2::<M>(c2, values)?;
        for &(vr, x) in inputs {
            ok(fmi3::set_float64::<M>(c, &vr, 1, &x, 1), "fmi3SetFloat64")?;
            ok(ffi::set_real::<M>(c2, &vr, 1, &x), "fmi2SetReal")?;
        }
        for k in 0..3 {
            step3::<M>(c, k as f64 * h, h)?;
            ok(ffi::do_step::<M>(c2, k as f64 * h, h, 1), "fmi2DoStep")?;
        }
        let mut s: FmuState = std::ptr::null_mut();
        ok(fmi3::get_fmu_state::<M>(c, &mut s), "fmi3GetFMUState")?;
        let mut size = 0usize;
        ok(
            fmi3::serialized_fmu_state_size::<M>(c, s, &mut size),
            "fmi3SerializedFMUStateSize",
        )?;
        let mut bytes = vec![0u8; size];
        ok(
            fmi3::serialize_fmu_state::<M>(c, s, bytes.as_mut_ptr(), size),
            "fmi3SerializeFMUState",
        )?;
        let mut s2: FmuState = std::ptr::null_mut();
        ok(ffi::get_fmu_state::<M>(c2, &mut s2), "fmi2GetFMUstate")?;
        let mut size2 = 0usize;
        ok(
            ffi::serialized_fmu_state_size::<M>(c2, s2, &mut size2),
            "fmi2SerializedFMUstateSize",
        )?;
        let mut bytes2 = vec![0u8; size2];
        ok(
            ffi::serialize_fmu_state::<M>(c2, s2, bytes2.as_mut_ptr() as *mut c_char, size2),
            "fmi2SerializeFMUstate",
        )?;
        ok(ffi::free_fmu_state::<M>(c2, &mut s2), "fmi2FreeFMUstate")?;
        if bytes != bytes2 {
            return Err("the FMI 3.0 serialized state differs from the FMI 2.0 one".into());
        }
        let run2 = |c: Component| -> Result<Vec<u64>, String> {
            step3::<M>(c, 3.0 * h, h)?;
            step3::<M>(c, 4.0 * h, h)?;
            Ok(bits(&get3::<M>(c, &outs)?))
        };
        let reference = run2(c)?;
        ok(fmi3::set_fmu_state::<M>(c, s), "fmi3SetFMUState")?;
        if run2(c)? != reference {
            return Err("fmi3SetFMUState: the repeated steps differ".into());
        }
        let mut d: FmuState = std::ptr::null_mut();
        ok(
            fmi3::deserialize_fmu_state::<M>(c, bytes.as_ptr(), bytes.len(), &mut d),
            "fmi3DeserializeFMUState",
        )?;
        ok(fmi3::set_fmu_state::<M>(c, d), "fmi3SetFMUState")?;
        if run2(c)? != reference {
            return Err("deserialized state: the repeated steps differ".into());
        }
        ok(fmi3::free_fmu_state::<M>(c, &mut s), "fmi3FreeFMUState")?;
        ok(fmi3::free_fmu_state::<M>(c, &mut d), "fmi3FreeFMUState")?;
        if !s.is_null() || !d.is_null() {
            return Err("fmi3FreeFMUState left the pointer set".into());
        }
        Ok(())
    })();
    unsafe {
        ffi::free_instance::<M>(c);
        ffi::free_instance::<M>(c2);
    }
    r
}

/// `d = fmi3GetDirectionalDerivative` with seed 1 against the central
/// difference `(y(k + d) - y(k - d)) / 2d` of the FMU's own values, for
/// every continuous output with respect to every continuous input
/// (Co-Simulation, after one step of `h`) and, with Model Exchange, every
/// state derivative with respect to every state and input. Agreement: `|d
/// - fd| <= rel * max(|d|, |fd|) + abs`. Returns the number of pairs compared.
pub fn directional_derivatives<M: CoSimModel>(
    res: Option<&Path>,
    values: Values,
    inputs: Values,
    h: f64,
    rel: f64,
) -> Result<usize, String> {
    directional_derivatives_at::<M>(res, values, inputs, None, h, rel)
}

/// [`directional_derivatives`] with the Model Exchange instance's
/// continuous states set to `states` (`fmi3SetContinuousStates`) before the
/// comparison (e.g. a state where a nonlinear model's Jacobian differs from
/// its linearization at rest); `None`: the states after initialization.
pub fn directional_derivatives_at<M: CoSimModel>(
    res: Option<&Path>,
    values: Values,
    inputs: Values,
    states_at: Option<&[f64]>,
    h: f64,
    rel: f64,
) -> Result<usize, String> {
    let ins = real_vrs::<M>(Causality::Input);
    let outs = real_vrs::<M>(Causality::Output);
    let mut n = 0;
    for cs in [true, false] {
        if !cs && M::CONTINUOUS_STATES.is_empty() {
            continue;
        }
        let c = instantiate3::<M>(cs, res);
        if c.is_null() {
            return Err("instantiation failed".into());
        }
        let r = (|| unsafe {
            init3::<M>(c, values)?;
            for &(vr, x) in inputs {
                ok(fmi3::set_float64::<M>(c, &vr, 1, &x, 1), "fmi3SetFloat64")?;
            }
            let states: Vec<u32> = M::CONTINUOUS_STATES.iter().map(|s| s.state_vr).collect();
            let (unknowns, knowns): (Vec<u32>, Vec<u32>) = if cs {
                step3::<M>(c, 0.0, h)?;
                (outs.clone(), ins.clone())
            } else {
                continuous_time3::<M>(c)?;
                if let Some(x) = states_at {
                    ok(
                        ffi::set_continuous_states::<M>(c, x.as_ptr(), x.len()),
                        "fmi3SetContinuousStates",
                    )?;
                }
                (
                    M::CONTINUOUS_STATES
                        .iter()
                        .map(|s| s.derivative_vr)
                        .collect(),
                    ins.iter().copied().chain(states.iter().copied()).collect(),
                )
            };
            let mut count = 0;
            for &k in &knowns {
                let k0 = get3::<M>(c, &[k])?[0];
                let d = 1e-6 * k0.abs().max(1e-3);
                let set = |x: f64| -> Result<(), String> {
                    if let Some(i) = states.iter().position(|&s| s == k) {
                        let mut xs = get3::<M>(c, &states)?;
                        xs[i] = x;
                        ok(
                            ffi::set_continuous_states::<M>(c, xs.as_ptr(), xs.len()),
                            "fmi3SetContinuousStates",
                        )
                    } else {
                        ok(fmi3::set_float64::<M>(c, &k, 1, &x, 1), "fmi3SetFloat64")
                    }
                };
                let mut dd = vec![0.0; unknowns.len()];
                ok(
                    fmi3::get_directional_derivative::<M>(
                        c,
                        unknowns.as_ptr(),
                        unknowns.len(),
                        &k,
                        1,
                        &1.0,
                        1,
                        dd.as_mut_ptr(),
                        dd.len(),
                    ),
                    "fmi3GetDirectionalDerivative",
                )?;
                set(k0 + d)?;
                let yp = get3::<M>(c, &unknowns)?;
                set(k0 - d)?;
                let ym = get3::<M>(c, &unknowns)?;
                set(k0)?;
                for (i, &u) in unknowns.iter().enumerate() {
                    let fd = (yp[i] - ym[i]) / (2.0 * d);
                    let scale = yp[i].abs().max(ym[i].abs());
                    let tol = rel * dd[i].abs().max(fd.abs()) + 1e-9 * scale / d + 1e-12;
                    if (dd[i] - fd).abs() > tol {
                        return Err(format!(
                            "d(vr {u})/d(vr {k}): fmi3GetDirectionalDerivative {} but central difference {fd}",
                            dd[i]
                        ));
                    }
                    count += 1;
                }
            }
            Ok(count)
        })();
        unsafe { ffi::free_instance::<M>(c) };
        n += r?;
    }
    Ok(n)
}

/// What [`fuzz`] counted.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct FuzzCounts {
    pub calls: usize,
    /// `fmi3DoStep` calls answered `fmi3OK` (the campaign reaches Step Mode).
    pub steps_ok: usize,
    pub hung: usize,
    pub accepted_wrong: usize,
}

/// The fuzz's random values on [`crate::testing::SplitMix64`].
struct Rng(crate::testing::SplitMix64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0.next_u64()
    }
    fn below(&mut self, n: usize) -> usize {
        self.0.below(n)
    }
    fn value(&mut self) -> f64 {
        const SPECIAL: [f64; 12] = [
            0.0,
            -1.0,
            1.0,
            1e-300,
            1e300,
            -1e300,
            f64::MAX,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e9,
            1e-5,
        ];
        if self.below(2) == 0 {
            SPECIAL[self.below(SPECIAL.len())]
        } else {
            (self.next() as f64 / u64::MAX as f64 - 0.5) * 10f64.powi(self.below(9) as i32 - 6)
        }
    }
}

/// One fuzz call of kind `kind` (0..8: values, initialization, steps, NULL
/// pointers, saving the state) on instance `c` ([`fuzz`]); `true` when
/// `fmi3OK` came with a non-finite value.
///
/// # Safety
/// `c` is a live instance of `M`.
#[allow(clippy::too_many_arguments)]
unsafe fn fuzz_values_and_steps<M: CoSimModel>(
    kind: usize,
    c: Component,
    cs: bool,
    nx: usize,
    reals: &[u32],
    vr: u32,
    rng: &mut Rng,
    t: &mut f64,
    blob: &mut Vec<u8>,
    steps_ok: &mut usize,
) -> bool {
    let _ = (cs, nx, reals);
    match kind {
        0 => {
            let x = rng.value();
            fmi3::set_float64::<M>(c, &vr, 1, &x, 1);
        }
        1 => {
            let mut x = 0.0;
            if fmi3::get_float64::<M>(c, &vr, 1, &mut x, 1) == Status::Ok && !x.is_finite() {
                return true;
            }
        }
        2 => {
            fmi3::enter_initialization_mode::<M>(
                c,
                rng.below(2) == 0,
                rng.value(),
                if rng.below(3) == 0 { rng.value() } else { 0.0 },
                rng.below(3) == 0,
                rng.value(),
            );
        }
        3 => {
            ffi::exit_initialization_mode::<M>(c);
        }
        4 | 5 => {
            let h = match rng.below(4) {
                0 => rng.value(),
                _ => 10f64.powi(rng.below(8) as i32 - 7),
            };
            let tt = if rng.below(8) == 0 { rng.value() } else { *t };
            let (mut a, mut b, mut e, mut last) = (false, false, false, 0.0);
            if fmi3::do_step::<M>(c, tt, h, false, &mut a, &mut b, &mut e, &mut last) == Status::Ok
            {
                *t = last;
                *steps_ok += 1;
            }
        }
        6 => {
            // NULL pointers
            let mut x = 0.0;
            let n = 1 + rng.below(2);
            match rng.below(3) {
                0 => fmi3::get_float64::<M>(c, std::ptr::null(), n, &mut x, n),
                1 => fmi3::set_float64::<M>(c, &vr, 1, std::ptr::null(), 1),
                _ => fmi3::do_step::<M>(
                    c,
                    *t,
                    1e-4,
                    false,
                    std::ptr::null_mut(),
                    std::ptr::null_mut(),
                    std::ptr::null_mut(),
                    std::ptr::null_mut(),
                ),
            };
        }
        7 => {
            let mut s: FmuState = std::ptr::null_mut();
            if fmi3::get_fmu_state::<M>(c, &mut s) == Status::Ok {
                let mut size = 0;
                fmi3::serialized_fmu_state_size::<M>(c, s, &mut size);
                *blob = vec![0; size];
                fmi3::serialize_fmu_state::<M>(c, s, blob.as_mut_ptr(), size);
                fmi3::free_fmu_state::<M>(c, &mut s);
            }
        }
        _ => {}
    }
    false
}

/// One fuzz call of kind `kind` (8..16: state blobs, directional
/// derivatives, Model Exchange, other types, resets and a sane
/// initialization) on instance `c` ([`fuzz`]); `true` when `fmi3OK` came
/// with a non-finite value.
///
/// # Safety
/// `c` is a live instance of `M`.
// the signature of `fuzz_values_and_steps` (both are called through one pointer)
#[allow(clippy::too_many_arguments, clippy::ptr_arg)]
unsafe fn fuzz_states_and_modes<M: CoSimModel>(
    kind: usize,
    c: Component,
    cs: bool,
    nx: usize,
    reals: &[u32],
    vr: u32,
    rng: &mut Rng,
    t: &mut f64,
    blob: &mut Vec<u8>,
    steps_ok: &mut usize,
) -> bool {
    let _ = steps_ok;
    match kind {
        8 => {
            // truncated or corrupted state blob
            let mut b = blob.clone();
            if !b.is_empty() {
                if rng.below(2) == 0 {
                    b.truncate(rng.below(b.len()));
                } else {
                    let k = rng.below(b.len());
                    b[k] ^= 1 << rng.below(8);
                }
            }
            let mut s: FmuState = std::ptr::null_mut();
            if fmi3::deserialize_fmu_state::<M>(c, b.as_ptr(), b.len(), &mut s) == Status::Ok {
                fmi3::set_fmu_state::<M>(c, s);
                fmi3::free_fmu_state::<M>(c, &mut s);
                let mut x = 0.0;
                *t = if fmi3::get_float64::<M>(
                    c,
                    &crate::render3::TIME_VALUE_REFERENCE,
                    1,
                    &mut x,
                    1,
                ) == Status::Ok
                {
                    x
                } else {
                    *t
                };
            }
        }
        9 => {
            let (u, k) = (vr, reals[rng.below(reals.len())]);
            let seed = rng.value();
            let mut d = 0.0;
            if fmi3::get_directional_derivative::<M>(c, &u, 1, &k, 1, &seed, 1, &mut d, 1)
                == Status::Ok
                && !d.is_finite()
                && seed.is_finite()
            {
                // a finite seed must give a finite sensitivity
                return true;
            }
        }
        10 => {
            if nx > 0 {
                let x: Vec<f64> = (0..nx).map(|_| rng.value()).collect();
                ffi::set_continuous_states::<M>(c, x.as_ptr(), nx);
                let mut d = vec![0.0; nx];
                if ffi::get_derivatives::<M>(c, d.as_mut_ptr(), nx) == Status::Ok
                    && d.iter().any(|x| !x.is_finite())
                {
                    return true;
                }
            }
        }
        11 => {
            if !cs {
                continuous_time3::<M>(c).ok();
            } else {
                ffi::set_time::<M>(c, rng.value());
            }
        }
        12 => {
            // other types and unsupported features
            let mut b = false;
            let mut i32v = 0;
            match rng.below(4) {
                0 => fmi3::get_boolean::<M>(c, &vr, 1, &mut b, 1),
                1 => fmi3::get_int32::<M>(c, &vr, 1, &mut i32v, 1),
                2 => fmi3::no_such_type::<M>(c, "fmi3GetInt64", "Int64", &vr, 1, false),
                _ => fmi3::unsupported::<M>(c, "fmi3EnterStepMode", "no event mode"),
            };
        }
        13 => {
            let mut x = [0.0; 2];
            // nValues != nValueReferences
            fmi3::get_float64::<M>(c, &vr, 1, x.as_mut_ptr(), 2);
        }
        14 => {
            if rng.below(4) == 0 {
                ffi::reset::<M>(c);
                *t = 0.0;
            } else {
                ffi::terminate::<M>(c);
            }
        }
        _ => {
            // a sane initialization, so that steps are reached
            fmi3::enter_initialization_mode::<M>(c, false, 0.0, 0.0, false, 0.0);
            ffi::exit_initialization_mode::<M>(c);
        }
    }
    false
}

/// Random FMI 3.0 call sequences on `instances` fresh instances (Co-Simulation
/// and, for a model with states, Model Exchange) of `calls` calls each:
/// wrong call order, NULL pointers, non-finite and huge values, huge and
/// non-positive steps, unknown value references, other types, truncated and
/// corrupted state blobs. A call over 2 s counts as hung; `fmi3OK` with a
/// non-finite Float64 (or derivative) as accepted-wrong. A panic crossing
/// the layer fails the calling test.
pub fn fuzz<M: CoSimModel>(
    res: Option<&Path>,
    seed: u64,
    instances: usize,
    calls: usize,
) -> FuzzCounts {
    let mut rng = Rng(crate::testing::SplitMix64(seed));
    let mut counts = FuzzCounts::default();
    let reals: Vec<u32> = M::VARIABLES
        .iter()
        .filter(|v| v.ty == VarType::Real)
        .map(|v| v.vr)
        .chain([crate::render3::TIME_VALUE_REFERENCE, 77_777])
        .collect();
    let nx = M::CONTINUOUS_STATES.len();
    for i in 0..instances {
        let cs = nx == 0 || i % 2 == 0;
        let c = instantiate3::<M>(cs, res);
        assert!(!c.is_null(), "instantiation failed");
        let mut t = 0.0;
        let mut blob: Vec<u8> = Vec::new();
        for _ in 0..calls {
            counts.calls += 1;
            let start = Instant::now();
            let vr = reals[rng.below(reals.len())];
            let wrong = unsafe {
                // mostly keep the instance usable: after an error (or while
                // not initialized) reset and initialize sanely, so that the
                // random calls reach Step / Continuous-Time Mode
                let state = (*(c as *mut ffi::Instance<M>)).state;
                let usable = matches!(
                    state,
                    ffi::State::StepComplete
                        | ffi::State::ContinuousTimeMode
                        | ffi::State::EventMode
                );
                if rng.below(4) != 0 && !usable {
                    ffi::reset::<M>(c);
                    fmi3::enter_initialization_mode::<M>(c, false, 0.0, 0.0, false, 0.0);
                    ffi::exit_initialization_mode::<M>(c);
                    if !cs {
                        continuous_time3::<M>(c).ok();
                    }
                    t = 0.0;
                }
                let kind = rng.below(16);
                let call = if kind < 8 {
                    fuzz_values_and_steps::<M>
                } else {
                    fuzz_states_and_modes::<M>
                };
                call(
                    kind,
                    c,
                    cs,
                    nx,
                    &reals,
                    vr,
                    &mut rng,
                    &mut t,
                    &mut blob,
                    &mut counts.steps_ok,
                )
            };
            if start.elapsed() > Duration::from_secs(2) {
                counts.hung += 1;
            }
            counts.accepted_wrong += wrong as usize;
        }
        unsafe { ffi::free_instance::<M>(c) };
    }
    counts
}
