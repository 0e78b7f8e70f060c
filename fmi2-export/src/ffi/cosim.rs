//! Co-Simulation: `fmi2DoStep`, the status queries, input and output
//! derivatives, and the directional derivatives (shared with Model Exchange).
use super::*;

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
            find::<M>(false, kv, VarType::Real)?;
        }
        for (o, &uv) in du.iter_mut().zip(u) {
            find::<M>(false, uv, VarType::Real)?;
            let mut s = 0.0;
            for (&kv, &d) in k.iter().zip(dk) {
                s += inst.model.partial_derivative(uv, kv)? * d;
            }
            // finite partials times finite seeds can still overflow (a seed
            // of 1e300): an error, not a non-finite sensitivity with OK
            if !s.is_finite() && dk.iter().all(|d| d.is_finite()) {
                return Err(ModelError::error(format!(
                    "directional derivative of value reference {uv}: the seed {dk:?} gives the non-finite {s}"
                )));
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
            let var = find::<M>(false, v, VarType::Real)?;
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
            let var = find::<M>(false, v, VarType::Real)?;
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
    run::<M>(c, "fmi2DoStep", STEP_COMPLETE, |inst| step(inst, t, h))
}

/// The step of `fmi2DoStep` and `fmi3DoStep`: checks `t` and `h`, advances
/// the model, checks the outputs.
pub(crate) fn step<M: CoSimModel>(
    inst: &mut Instance<M>,
    t: f64,
    h: f64,
) -> Result<Status, ModelError> {
    step_early(inst, t, h, false).map(|(s, _)| s)
}

/// [`step`]; with `early` (an FMI 3.0 instance that allows early return)
/// through [`CoSimModel::do_step_early`], which may stop before `t + h`:
/// the instance's time is then the time reached, and a stop that ends the
/// model's validity returns `fmi3Warning` (FMI 3.0 section 4.2.1: "the FMU
/// requests to stop the simulation" with `terminateSimulation`).
pub(crate) fn step_early<M: CoSimModel>(
    inst: &mut Instance<M>,
    t: f64,
    h: f64,
    early: bool,
) -> Result<(Status, StepOutcome), ModelError> {
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
    let outcome = if early {
        inst.model.do_step_early(t, h, &inst.logger)
    } else {
        inst.model
            .do_step(t, h, &inst.logger)
            .map(|()| StepOutcome::Completed)
    };
    let reached = |o: &StepOutcome| match *o {
        StepOutcome::Completed => Ok(t + h),
        StepOutcome::EarlyReturn { time_s, .. } if time_s >= t && time_s < t + h => Ok(time_s),
        StepOutcome::EarlyReturn { time_s, .. } => Err(ModelError::error(format!(
            "internal error: early return at {time_s} outside the step [{t}, {})",
            t + h
        ))),
    };
    match outcome.and_then(|o| {
        let end = reached(&o)?;
        outputs_finite(&inst.model, &inst.outputs, end).map(|()| (o, end))
    }) {
        Ok((o, end)) => {
            inst.time = end;
            inst.last_successful_time = end;
            let status = match o {
                StepOutcome::EarlyReturn {
                    terminate: true, ..
                } => Status::Warning,
                _ => Status::Ok,
            };
            Ok((status, o))
        }
        Err(e) => {
            if e.status == Status::Discard {
                inst.state = State::StepFailed;
            }
            Err(e)
        }
    }
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
