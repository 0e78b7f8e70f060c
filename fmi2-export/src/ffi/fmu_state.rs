//! The FMU state (`fmi2GetFMUstate` ... `fmi2DeSerializeFMUstate`): a copy of
//! the layer's part of the instance and of the model.
use super::*;

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
