//! Model Exchange (event-free): time, continuous states, derivatives, the
//! event-mode calls that have nothing to do.
use super::*;

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
