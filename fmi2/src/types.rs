//! The C ABI of FMI 2.0 (`fmi2TypesPlatform.h`, `fmi2FunctionTypes.h`), as Rust
//! types with the standard's names in the docs.
use std::os::raw::{c_char, c_int, c_uint, c_void};

/// `fmi2Component`: the opaque instance pointer handed to the importer.
pub type Component = *mut c_void;
/// `fmi2ComponentEnvironment`: the importer's opaque pointer, passed back unchanged.
pub type ComponentEnvironment = *mut c_void;
/// `fmi2FMUstate`: an opaque saved state.
pub type FmuState = *mut c_void;
/// `fmi2ValueReference`.
pub type ValueReference = c_uint;
/// `fmi2Real`.
pub type Real = f64;
/// `fmi2Integer`.
pub type Integer = c_int;
/// `fmi2Boolean` (`fmi2True` = 1, `fmi2False` = 0).
pub type Boolean = c_int;
/// `fmi2String`.
pub type FmiString = *const c_char;
/// `fmi2Byte`.
pub type Byte = c_char;

pub const FMI2_TRUE: Boolean = 1;
pub const FMI2_FALSE: Boolean = 0;

/// `fmi2Status` (a C enum, passed as `int`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

impl Status {
    /// The status a foreign function returned as a plain `int` (an importer
    /// must not trust a C enum value); `None` outside 0..=5.
    pub fn from_raw(raw: c_int) -> Option<Self> {
        Some(match raw {
            0 => Status::Ok,
            1 => Status::Warning,
            2 => Status::Discard,
            3 => Status::Error,
            4 => Status::Fatal,
            5 => Status::Pending,
            _ => return None,
        })
    }

    /// The name the standard uses (`fmi2OK`, ...), for log messages.
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "fmi2OK",
            Status::Warning => "fmi2Warning",
            Status::Discard => "fmi2Discard",
            Status::Error => "fmi2Error",
            Status::Fatal => "fmi2Fatal",
            Status::Pending => "fmi2Pending",
        }
    }
}

/// `fmi2Type`: `fmi2ModelExchange` = 0, `fmi2CoSimulation` = 1.
pub type FmuType = c_int;
pub const FMI2_MODEL_EXCHANGE: FmuType = 0;
pub const FMI2_CO_SIMULATION: FmuType = 1;

/// `fmi2StatusKind`.
pub type StatusKind = c_int;
pub const FMI2_DO_STEP_STATUS: StatusKind = 0;
pub const FMI2_PENDING_STATUS: StatusKind = 1;
pub const FMI2_LAST_SUCCESSFUL_TIME: StatusKind = 2;
pub const FMI2_TERMINATED: StatusKind = 3;

/// `fmi2CallbackLogger`: C-variadic. Rust can call (not define) such a function;
/// this layer always passes a fully formatted message (literal `%` escaped as `%%`)
/// and no variadic arguments.
pub type CallbackLogger = unsafe extern "C" fn(
    ComponentEnvironment,
    FmiString, // instanceName
    Status,
    FmiString, // category
    FmiString, // message (printf format)
    ...
);
/// `fmi2CallbackAllocateMemory`.
pub type CallbackAllocateMemory = unsafe extern "C" fn(usize, usize) -> *mut c_void;
/// `fmi2CallbackFreeMemory`.
pub type CallbackFreeMemory = unsafe extern "C" fn(*mut c_void);
/// `fmi2StepFinished`.
pub type StepFinished = unsafe extern "C" fn(ComponentEnvironment, Status);

/// `fmi2CallbackFunctions`. The layer copies it at instantiation and never uses
/// the memory functions (`canNotUseMemoryManagementFunctions = true`).
#[repr(C)]
#[derive(Clone, Copy)]
pub struct CallbackFunctions {
    pub logger: Option<CallbackLogger>,
    pub allocate_memory: Option<CallbackAllocateMemory>,
    pub free_memory: Option<CallbackFreeMemory>,
    pub step_finished: Option<StepFinished>,
    pub component_environment: ComponentEnvironment,
}

/// `fmi2EventInfo` (Model Exchange, filled by `fmi2NewDiscreteStates`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EventInfo {
    pub new_discrete_states_needed: Boolean,
    pub terminate_simulation: Boolean,
    pub nominals_of_continuous_states_changed: Boolean,
    pub values_of_continuous_states_changed: Boolean,
    pub next_event_time_defined: Boolean,
    pub next_event_time: Real,
}
