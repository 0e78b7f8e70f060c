//! Getting and setting variables (`fmi2GetReal` ... `fmi2SetString`): value
//! references, types and settability checked against the model's table.
use super::*;

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
                for (o, &v) in out.iter_mut().zip(vrs) {
                    let $vr = find::<M>(inst.fmi3, v, $vt)?.vr;
                    let $m = &inst.model;
                    *o = $get;
                }
                Ok(Status::Ok)
            })
        }
    };
}

/// `fmi2GetReal` (FMI 3.0 `fmi3GetFloat64` also reads the independent
/// variable `time`, [`crate::render3::TIME_VALUE_REFERENCE`]).
pub unsafe fn get_real<M: CoSimModel>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *mut Real,
) -> Status {
    run::<M>(c, "fmi2GetReal", GETTABLE, |inst| {
        let vrs = slice(vr, n).ok_or_else(|| null_arg("vr"))?;
        let out = slice_mut(value, n).ok_or_else(|| null_arg("value"))?;
        for (o, &v) in out.iter_mut().zip(vrs) {
            if inst.fmi3 && v == crate::render3::TIME_VALUE_REFERENCE {
                *o = inst.time;
                continue;
            }
            find::<M>(inst.fmi3, v, VarType::Real)?;
            *o = finite(v, inst.model.try_get_real(v)?)?;
        }
        Ok(Status::Ok)
    })
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
            let v = find::<M>(inst.fmi3, v, VarType::String)?.vr;
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
            let var = find::<M>(inst.fmi3, v, VarType::Real)?;
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
            let var = find::<M>(inst.fmi3, v, VarType::Integer)?;
            inst.check_settable(var)?;
            inst.model.set_integer(var.vr, x)?;
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
            let var = find::<M>(inst.fmi3, v, VarType::Boolean)?;
            inst.check_settable(var)?;
            inst.model.set_boolean(var.vr, x != 0)?;
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
            let var = find::<M>(inst.fmi3, v, VarType::String)?;
            inst.check_settable(var)?;
            if p.is_null() {
                return Err(null_arg("value[i]"));
            }
            let s = CStr::from_ptr(p).to_str().map_err(|e| {
                ModelError::error(format!("value of {} is not UTF-8: {e}", var.name))
            })?;
            inst.model.set_string(var.vr, s)?;
        }
        Ok(Status::Ok)
    })
}
