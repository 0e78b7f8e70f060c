//! Loading an FMU's shared library (libloading) and its table of FMI 2.0
//! ([`Fns`]) or FMI 3.0 ([`Fns3`]) Co-Simulation functions. Return values stay plain `int`s ([`RawStatus`]):
//! an importer must not trust a foreign value to be a valid Rust enum.
use std::ffi::{c_char, c_int, c_uint, c_void};
use std::path::Path;

use fmi2::types::{CallbackFunctions, Component, FmuState};

use crate::error::{FmuError, Result};

/// `fmi2Status` as returned by the FMU (see [`fmi2::Status::from_raw`]).
pub type RawStatus = c_int;

macro_rules! fns {
    ($doc:literal $name:ident { $( $field:ident : $sym:literal : fn($($arg:ty),*) $(-> $ret:ty)? ;)* }) => {
        #[doc = $doc]
        #[allow(clippy::type_complexity)]
        pub(crate) struct $name {
            $( pub(crate) $field: unsafe extern "C" fn($($arg),*) $(-> $ret)?, )*
            _lib: libloading::Library,
        }
        impl $name {
            pub(crate) fn load(path: &Path) -> Result<Self> {
                // SAFETY: loading a shared library runs its initialisers; an FMU
                // binary is trusted code by the nature of co-simulation.
                let lib = unsafe { libloading::Library::new(path) }
                    .map_err(|source| FmuError::Load { path: path.into(), source })?;
                $(
                    // SAFETY: the symbol has the FMI signature declared here.
                    let $field = unsafe {
                        *lib.get::<unsafe extern "C" fn($($arg),*) $(-> $ret)?>(concat!($sym, "\0").as_bytes())
                            .map_err(|_| FmuError::Symbol { path: path.into(), name: $sym })?
                    };
                )*
                Ok($name { $($field,)* _lib: lib })
            }
        }
    };
}

fns! {
    "The FMI 2.0 CS functions of one loaded library." Fns {
    get_version: "fmi2GetVersion": fn() -> *const c_char;
    instantiate: "fmi2Instantiate": fn(*const c_char, c_int, *const c_char, *const c_char, *const CallbackFunctions, c_int, c_int) -> Component;
    free_instance: "fmi2FreeInstance": fn(Component);
    setup_experiment: "fmi2SetupExperiment": fn(Component, c_int, f64, f64, c_int, f64) -> RawStatus;
    enter_initialization_mode: "fmi2EnterInitializationMode": fn(Component) -> RawStatus;
    exit_initialization_mode: "fmi2ExitInitializationMode": fn(Component) -> RawStatus;
    terminate: "fmi2Terminate": fn(Component) -> RawStatus;
    get_real: "fmi2GetReal": fn(Component, *const c_uint, usize, *mut f64) -> RawStatus;
    set_real: "fmi2SetReal": fn(Component, *const c_uint, usize, *const f64) -> RawStatus;
    get_integer: "fmi2GetInteger": fn(Component, *const c_uint, usize, *mut c_int) -> RawStatus;
    set_integer: "fmi2SetInteger": fn(Component, *const c_uint, usize, *const c_int) -> RawStatus;
    get_boolean: "fmi2GetBoolean": fn(Component, *const c_uint, usize, *mut c_int) -> RawStatus;
    set_boolean: "fmi2SetBoolean": fn(Component, *const c_uint, usize, *const c_int) -> RawStatus;
    set_string: "fmi2SetString": fn(Component, *const c_uint, usize, *const *const c_char) -> RawStatus;
    get_fmu_state: "fmi2GetFMUstate": fn(Component, *mut FmuState) -> RawStatus;
    set_fmu_state: "fmi2SetFMUstate": fn(Component, FmuState) -> RawStatus;
    free_fmu_state: "fmi2FreeFMUstate": fn(Component, *mut FmuState) -> RawStatus;
    set_real_input_derivatives: "fmi2SetRealInputDerivatives": fn(Component, *const c_uint, usize, *const c_int, *const f64) -> RawStatus;
    get_real_output_derivatives: "fmi2GetRealOutputDerivatives": fn(Component, *const c_uint, usize, *const c_int, *mut f64) -> RawStatus;
    do_step: "fmi2DoStep": fn(Component, f64, f64, c_int) -> RawStatus;
    }
}

/// `fmi3LogMessageCallback` (not variadic in FMI 3.0: the message is formatted).
pub(crate) type LogMessage3 =
    unsafe extern "C" fn(*mut c_void, c_int, *const c_char, *const c_char);

/// `fmi3Boolean` is C's `bool`.
pub(crate) type Bool3 = bool;

fns! {
    "The FMI 3.0 CS functions of one loaded library (`fmi3Instance` as `*mut c_void`)." Fns3 {
    get_version: "fmi3GetVersion": fn() -> *const c_char;
    instantiate: "fmi3InstantiateCoSimulation": fn(*const c_char, *const c_char, *const c_char, Bool3, Bool3, Bool3, Bool3, *const c_uint, usize, *mut c_void, Option<LogMessage3>, *const c_void) -> *mut c_void;
    free_instance: "fmi3FreeInstance": fn(*mut c_void);
    enter_initialization_mode: "fmi3EnterInitializationMode": fn(*mut c_void, Bool3, f64, f64, Bool3, f64) -> RawStatus;
    exit_initialization_mode: "fmi3ExitInitializationMode": fn(*mut c_void) -> RawStatus;
    terminate: "fmi3Terminate": fn(*mut c_void) -> RawStatus;
    get_float64: "fmi3GetFloat64": fn(*mut c_void, *const c_uint, usize, *mut f64, usize) -> RawStatus;
    set_float64: "fmi3SetFloat64": fn(*mut c_void, *const c_uint, usize, *const f64, usize) -> RawStatus;
    get_int32: "fmi3GetInt32": fn(*mut c_void, *const c_uint, usize, *mut i32, usize) -> RawStatus;
    set_int32: "fmi3SetInt32": fn(*mut c_void, *const c_uint, usize, *const i32, usize) -> RawStatus;
    get_boolean: "fmi3GetBoolean": fn(*mut c_void, *const c_uint, usize, *mut Bool3, usize) -> RawStatus;
    set_boolean: "fmi3SetBoolean": fn(*mut c_void, *const c_uint, usize, *const Bool3, usize) -> RawStatus;
    set_string: "fmi3SetString": fn(*mut c_void, *const c_uint, usize, *const *const c_char, usize) -> RawStatus;
    get_fmu_state: "fmi3GetFMUState": fn(*mut c_void, *mut *mut c_void) -> RawStatus;
    set_fmu_state: "fmi3SetFMUState": fn(*mut c_void, *mut c_void) -> RawStatus;
    free_fmu_state: "fmi3FreeFMUState": fn(*mut c_void, *mut *mut c_void) -> RawStatus;
    get_output_derivatives: "fmi3GetOutputDerivatives": fn(*mut c_void, *const c_uint, usize, *const i32, *mut f64, usize) -> RawStatus;
    get_directional_derivative: "fmi3GetDirectionalDerivative": fn(*mut c_void, *const c_uint, usize, *const c_uint, usize, *const f64, usize, *mut f64, usize) -> RawStatus;
    do_step: "fmi3DoStep": fn(*mut c_void, f64, f64, Bool3, *mut Bool3, *mut Bool3, *mut Bool3, *mut f64) -> RawStatus;
    }
}
