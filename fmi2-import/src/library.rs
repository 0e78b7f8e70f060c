//! Loading an FMU's shared library (libloading) and its table of FMI 2.0
//! Co-Simulation functions. Return values stay plain `int`s ([`RawStatus`]):
//! an importer must not trust a foreign value to be a valid Rust enum.
use std::ffi::{c_char, c_int, c_uint};
use std::path::Path;

use fmi2::types::{CallbackFunctions, Component, FmuState};

use crate::error::{FmuError, Result};

/// `fmi2Status` as returned by the FMU (see [`fmi2::Status::from_raw`]).
pub type RawStatus = c_int;

macro_rules! fns {
    ($( $field:ident : $sym:literal : fn($($arg:ty),*) $(-> $ret:ty)? ;)*) => {
        /// The FMI 2.0 CS functions of one loaded library.
        #[allow(clippy::type_complexity)]
        pub(crate) struct Fns {
            $( pub(crate) $field: unsafe extern "C" fn($($arg),*) $(-> $ret)?, )*
            _lib: libloading::Library,
        }
        impl Fns {
            pub(crate) fn load(path: &Path) -> Result<Self> {
                // SAFETY: loading a shared library runs its initialisers; an FMU
                // binary is trusted code by the nature of co-simulation.
                let lib = unsafe { libloading::Library::new(path) }
                    .map_err(|source| FmuError::Load { path: path.into(), source })?;
                $(
                    // SAFETY: the symbol has the FMI 2.0 signature declared here.
                    let $field = unsafe {
                        *lib.get::<unsafe extern "C" fn($($arg),*) $(-> $ret)?>(concat!($sym, "\0").as_bytes())
                            .map_err(|_| FmuError::Symbol { path: path.into(), name: $sym })?
                    };
                )*
                Ok(Fns { $($field,)* _lib: lib })
            }
        }
    };
}

fns! {
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
