//! FMI 3.0 array outputs, `UInt64` structural parameters and Configuration
//! Mode (FMI 3.0 sections 2.4.7.2 "Array variables and structural
//! parameters" and 2.3 "Configuration Mode"), for the models that declare
//! them ([`CoSimModel::STRUCTURAL_PARAMETERS`], [`CoSimModel::ARRAY_OUTPUTS`]):
//!
//! * `fmi3GetFloat64` counts `nValues` as the sum of the variables' sizes
//!   (a scalar 1, an array its dimension's current value) and refuses any
//!   other count before writing;
//! * `fmi3GetUInt64` reads a structural parameter in every state but
//!   Configuration Mode; `fmi3SetUInt64` sets one in Configuration Mode only
//!   (`1..=max`), which `fmi3EnterConfigurationMode` enters from
//!   Instantiated and `fmi3ExitConfigurationMode` leaves back to it.
use crate::ffi::{
    self, find, finite, null_arg, run, slice, slice_mut, State, ALIVE, CONFIG, GETTABLE,
    INSTANTIATED,
};
use crate::model::{ArrayOutput, CoSimModel, ModelError, StructuralParameter, VarType};
use crate::types::{Component, Status, ValueReference};

use super::{check_counts, counts, unsupported, MAX_VALUE_REFERENCES};

fn structural<M: CoSimModel>(vr: u32) -> Option<&'static StructuralParameter> {
    M::STRUCTURAL_PARAMETERS.iter().find(|p| p.vr == vr)
}

fn array<M: CoSimModel>(vr: u32) -> Option<&'static ArrayOutput> {
    M::ARRAY_OUTPUTS.iter().find(|a| a.vr == vr)
}

/// `fmi3GetFloat64` (also the independent variable `time`): for a model
/// without arrays the scalar function of FMI 2.0 (`nValues =
/// nValueReferences`); with arrays, the values of each variable in order.
pub unsafe fn get_float64<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *mut f64,
    nv: usize,
) -> Status {
    const F: &str = "fmi3GetFloat64";
    if M::ARRAY_OUTPUTS.is_empty() {
        return counts::<M>(c, F, n, nv).unwrap_or_else(|| ffi::get_real::<M>(c, vr, n, v));
    }
    run::<M>(c, F, GETTABLE, |inst| {
        if n > MAX_VALUE_REFERENCES || nv > MAX_VALUE_REFERENCES {
            return check_counts(n, nv).map(|()| Status::Ok);
        }
        let vrs = slice(vr, n).ok_or_else(|| null_arg("valueReferences"))?;
        // the size of each variable first: nothing is written on a wrong count
        let mut sizes = Vec::with_capacity(n);
        for &r in vrs {
            sizes.push(match array::<M>(r) {
                Some(a) => usize::try_from(inst.model.get_uint64(a.dimension_vr)?)
                    .map_err(|_| ModelError::error(format!("array {}: size too large", a.name)))?,
                None => 1,
            });
        }
        let total: usize = sizes.iter().sum();
        if total != nv {
            return Err(ModelError::error(format!(
                "nValues = {nv} but the {n} variables hold {total} values (sizes {sizes:?}; an array \
                 counts the current value of its structural parameter)"
            )));
        }
        let out = slice_mut(v, nv).ok_or_else(|| null_arg("values"))?;
        let mut at = 0;
        for (&r, &k) in vrs.iter().zip(&sizes) {
            let o = &mut out[at..at + k];
            at += k;
            if inst.fmi3 && r == crate::render3::TIME_VALUE_REFERENCE {
                o[0] = inst.time;
            } else if array::<M>(r).is_some() {
                inst.model.get_array(r, o)?;
                for x in o.iter() {
                    finite(r, *x)?;
                }
            } else {
                find::<M>(true, r, VarType::Real)?;
                o[0] = finite(r, inst.model.try_get_real(r)?)?;
            }
        }
        Ok(Status::Ok)
    })
}

/// `fmi3GetUInt64`: the structural parameters (in Instantiated too: their
/// start values or the values set in Configuration Mode).
pub unsafe fn get_uint64<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *mut u64,
    nv: usize,
) -> Status {
    const F: &str = "fmi3GetUInt64";
    if let Some(s) = counts::<M>(c, F, n, nv) {
        return s;
    }
    run::<M>(c, F, GETTABLE | INSTANTIATED, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("valueReferences"))?;
        let out = slice_mut(v, n).ok_or_else(|| null_arg("values"))?;
        for (o, &r) in out.iter_mut().zip(vrs) {
            let p = structural::<M>(r).ok_or_else(|| no_uint64(r))?;
            *o = inst.model.get_uint64(p.vr)?;
        }
        Ok(Status::Ok)
    })
}

fn no_uint64(vr: u32) -> ModelError {
    ModelError::error(format!(
        "unknown value reference {vr} (no UInt64 variable has it)"
    ))
}

/// `fmi3SetUInt64`: a structural parameter, in Configuration Mode only,
/// `1 ..= max`.
pub unsafe fn set_uint64<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    v: *const u64,
    nv: usize,
) -> Status {
    const F: &str = "fmi3SetUInt64";
    if let Some(s) = counts::<M>(c, F, n, nv) {
        return s;
    }
    run::<M>(c, F, ALIVE, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("valueReferences"))?;
        let vals = slice(v, n).ok_or_else(|| null_arg("values"))?;
        for (&r, &x) in vrs.iter().zip(vals) {
            let p = structural::<M>(r).ok_or_else(|| no_uint64(r))?;
            if inst.state != State::ConfigurationMode {
                return Err(ModelError::error(format!(
                    "structural parameter {} (value reference {r}) can be set in Configuration Mode only \
                     (fmi3EnterConfigurationMode after instantiation), not in state {:?}",
                    p.name, inst.state
                )));
            }
            if !(1..=p.max).contains(&x) {
                return Err(ModelError::error(format!(
                    "structural parameter {} = {x} is outside its range [1, {}]",
                    p.name, p.max
                )));
            }
            inst.model.set_uint64(r, x)?;
        }
        Ok(Status::Ok)
    })
}

/// `fmi3EnterConfigurationMode`: from Instantiated (the structural
/// parameters are `fixed`: no Reconfiguration Mode).
pub unsafe fn enter_configuration_mode<M: CoSimModel>(c: Component) -> Status {
    configuration::<M>(
        c,
        "fmi3EnterConfigurationMode",
        INSTANTIATED,
        State::ConfigurationMode,
    )
}

/// `fmi3ExitConfigurationMode`: back to Instantiated.
pub unsafe fn exit_configuration_mode<M: CoSimModel>(c: Component) -> Status {
    configuration::<M>(c, "fmi3ExitConfigurationMode", CONFIG, State::Instantiated)
}

/// The change of state of `func` (allowed in `from`) to `to`; refused for
/// a model without structural parameters.
unsafe fn configuration<M: CoSimModel>(c: Component, func: &str, from: u16, to: State) -> Status {
    if M::STRUCTURAL_PARAMETERS.is_empty() {
        return unsupported::<M>(
            c,
            func,
            "the FMU has no structural parameters (no Configuration Mode)",
        );
    }
    run::<M>(c, func, from, |inst| {
        inst.state = to;
        Ok(Status::Ok)
    })
}
