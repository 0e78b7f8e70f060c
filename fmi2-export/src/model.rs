//! What a model implements: [`CoSimModel`], its variable table ([`Variable`]),
//! its errors ([`ModelError`]) and the services the layer gives it ([`Logger`],
//! [`InstantiateContext`], [`StateWriter`] / [`StateReader`]).
use std::ffi::CString;
use std::path::PathBuf;

use crate::types::{CallbackLogger, ComponentEnvironment, Status};

/// The FMI 3.0 `fmi3LogMessageCallback` (not variadic: the message is
/// passed as is): `(instanceEnvironment, status, category, message)`.
pub type LogMessage3 = unsafe extern "C" fn(
    ComponentEnvironment,
    Status,
    *const std::os::raw::c_char,
    *const std::os::raw::c_char,
);

/// The importer's logging function, FMI 2.0 or FMI 3.0.
#[derive(Clone, Copy)]
pub(crate) enum LogCallback {
    None,
    Fmi2(CallbackLogger),
    Fmi3(LogMessage3),
}
pub use fmi2::{Causality, VarType, Variability};

/// `start` attribute of a variable (must equal the model's value right after
/// instantiation: masters such as libcosim and OMSimulator never set start values).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Start {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(&'static str),
}

/// One scalar variable as the code sees it: the single source of the
/// modelDescription's `<ScalarVariable>` (rendered by
/// [`crate::render::model_description`]; its index is the position in
/// [`CoSimModel::VARIABLES`] + 1). A table entry reads
/// `Variable::real(...).describe("...")`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Variable {
    pub name: &'static str,
    pub vr: u32,
    pub ty: VarType,
    pub causality: Causality,
    pub variability: Variability,
    pub start: Option<Start>,
    /// Unit name (`""` for none); defined in [`crate::description::UNITS`]
    /// or the model's [`crate::ModelInfo::units`].
    pub unit: &'static str,
    /// The `description` attribute (required by the renderer).
    pub description: &'static str,
}

impl Variable {
    /// A Real variable; `start` `None` for none (calculated parameters, outputs).
    pub const fn real(
        name: &'static str,
        vr: u32,
        causality: Causality,
        variability: Variability,
        start: Option<f64>,
        unit: &'static str,
    ) -> Self {
        Self {
            name,
            vr,
            ty: VarType::Real,
            causality,
            variability,
            start: match start {
                Some(s) => Some(Start::Real(s)),
                None => None,
            },
            unit,
            description: "",
        }
    }

    /// The same variable with its description.
    pub const fn describe(mut self, description: &'static str) -> Self {
        self.description = description;
        self
    }

    /// A fixed Integer parameter with its start value.
    pub const fn integer_parameter(name: &'static str, vr: u32, start: i32) -> Self {
        Self {
            name,
            vr,
            ty: VarType::Integer,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(Start::Integer(start)),
            unit: "",
            description: "",
        }
    }

    /// A fixed Boolean parameter with its start value.
    pub const fn boolean_parameter(name: &'static str, vr: u32, start: bool) -> Self {
        Self {
            name,
            vr,
            ty: VarType::Boolean,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(Start::Boolean(start)),
            unit: "",
            description: "",
        }
    }

    /// A fixed String parameter with its start value.
    pub const fn string_parameter(name: &'static str, vr: u32, start: &'static str) -> Self {
        Self {
            name,
            vr,
            ty: VarType::String,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(Start::String(start)),
            unit: "",
            description: "",
        }
    }

    /// A discrete output of type `ty` (Integer or Boolean), no start value.
    pub const fn discrete_output(name: &'static str, vr: u32, ty: VarType) -> Self {
        Self {
            name,
            vr,
            ty,
            causality: Causality::Output,
            variability: Variability::Discrete,
            start: None,
            unit: "",
            description: "",
        }
    }

    /// May the importer set this variable in the given phase? (FMI 2.0 CS:
    /// before/while initializing, inputs and parameters; while stepping, inputs
    /// and tunable parameters.)
    pub(crate) fn settable(&self, initialized: bool) -> bool {
        match self.causality {
            Causality::Input => true,
            Causality::Parameter => !initialized || self.variability == Variability::Tunable,
            _ => false,
        }
    }
}

/// An FMI 3.0 `UInt64` structural parameter (FMI 3.0 section 2.4.7.4,
/// causality `structuralParameter`, variability `fixed`, initial `exact`)
/// that sizes array variables ([`ArrayOutput`]). FMI 3.0 only (FMI 2.0 has
/// no arrays): rendered by [`crate::render3`] after the scalar variables,
/// read by `fmi3GetUInt64` and set by `fmi3SetUInt64` in Configuration Mode
/// only (FMI 3.0 section 2.3.4, "Configuration Mode").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StructuralParameter {
    pub name: &'static str,
    /// FMI 3.0 value reference (unique over all variables).
    pub vr: u32,
    /// The `start` attribute: the model's value after instantiation.
    pub start: u64,
    /// Largest value accepted (`fmi3SetUInt64` refuses more, naming it).
    pub max: u64,
    pub description: &'static str,
}

/// An FMI 3.0 `Float64` array output with one `<Dimension>`, the structural
/// parameter `dimension_vr` (FMI 3.0 section 2.4.7.3, "Array Variables").
/// `fmi3GetFloat64` writes its values in order, `nValues` counting them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArrayOutput {
    pub name: &'static str,
    pub vr: u32,
    pub dimension_vr: u32,
    pub unit: &'static str,
    pub description: &'static str,
    /// `<InitialUnknown>` dependencies by variable name (scalar variables).
    pub initial_dependencies: &'static [&'static str],
}

/// One continuous state of a Model Exchange model: the variable that holds it,
/// the variable that holds its time derivative (`<Real derivative="...">` in
/// the XML, listed in `<ModelStructure><Derivatives>`) and its nominal value
/// (`fmi2GetNominalsOfContinuousStates`, the integrator's error scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContinuousState {
    pub state_vr: u32,
    pub derivative_vr: u32,
    pub nominal: f64,
}

/// A failure of the model, reported to the importer through the logger with
/// the status it carries (`fmi2Discard` or `fmi2Error`).
#[derive(Debug, Clone, PartialEq)]
pub struct ModelError {
    pub status: Status,
    pub message: String,
}

impl ModelError {
    /// An error: the instance goes to the error state (`fmi2Error`).
    pub fn error(message: impl Into<String>) -> Self {
        Self {
            status: Status::Error,
            message: message.into(),
        }
    }
    /// A step that could not be completed but may be retried (`fmi2Discard`).
    pub fn discard(message: impl Into<String>) -> Self {
        Self {
            status: Status::Discard,
            message: message.into(),
        }
    }
}

impl std::fmt::Display for ModelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.message)
    }
}

/// Any typed error of the physics crates converts into an `fmi2Error`.
impl<E: std::error::Error> From<E> for ModelError {
    fn from(e: E) -> Self {
        ModelError::error(e.to_string())
    }
}

/// The standard log categories this layer uses (declare them in the
/// modelDescription's `<LogCategories>`).
pub const LOG_CATEGORIES: &[&str] = &[
    "logEvents",
    "logStatusWarning",
    "logStatusDiscard",
    "logStatusError",
    "logStatusFatal",
    "logAll",
];

/// Logging through the importer's `fmi2CallbackLogger`. Messages with status
/// warning or worse are always passed on; informative ones (`logEvents`) only
/// when the importer switched logging on (`loggingOn` / `fmi2SetDebugLogging`).
/// The instance name and category are never NULL, and a literal `%` is written
/// `%%` because every master formats the message with `vsnprintf`.
pub struct Logger {
    callback: LogCallback,
    env: ComponentEnvironment,
    instance_name: CString,
    pub(crate) logging_on: bool,
    /// Enabled categories (indices into [`LOG_CATEGORIES`]); all when empty.
    pub(crate) categories: Vec<usize>,
}

fn c_string_lossy(s: &str) -> CString {
    CString::new(s.replace('\0', " ")).expect("NUL bytes were replaced")
}

impl Logger {
    pub(crate) fn new(
        callback: Option<CallbackLogger>,
        env: ComponentEnvironment,
        instance_name: &str,
        logging_on: bool,
    ) -> Self {
        let callback = callback.map_or(LogCallback::None, LogCallback::Fmi2);
        Self::with_callback(callback, env, instance_name, logging_on)
    }

    /// A logger calling the FMI 3.0 `logMessage` callback (NULL: none).
    pub(crate) fn fmi3(
        callback: Option<LogMessage3>,
        env: ComponentEnvironment,
        instance_name: &str,
        logging_on: bool,
    ) -> Self {
        let callback = callback.map_or(LogCallback::None, LogCallback::Fmi3);
        Self::with_callback(callback, env, instance_name, logging_on)
    }

    pub(crate) fn with_callback(
        callback: LogCallback,
        env: ComponentEnvironment,
        instance_name: &str,
        logging_on: bool,
    ) -> Self {
        Self {
            callback,
            env,
            instance_name: c_string_lossy(instance_name),
            logging_on,
            categories: Vec::new(),
        }
    }

    /// A logger that drops every message (for using a model outside an FMU, e.g.
    /// in tests and benchmarks).
    pub fn silent() -> Self {
        Self::new(None, std::ptr::null_mut(), "silent", false)
    }

    /// The instance name given by the importer.
    pub fn instance_name(&self) -> &str {
        self.instance_name.to_str().unwrap_or("?")
    }

    fn category_enabled(&self, category: &str) -> bool {
        if !self.logging_on {
            return false;
        }
        if self.categories.is_empty() {
            return true;
        }
        self.categories
            .iter()
            .any(|&i| LOG_CATEGORIES[i] == category || LOG_CATEGORIES[i] == "logAll")
    }

    /// Send `message` with `status` and `category` to the importer.
    pub fn log(&self, status: Status, category: &str, message: &str) {
        if matches!(self.callback, LogCallback::None) {
            return;
        }
        let always = status >= Status::Warning;
        if !always && !self.category_enabled(category) {
            return;
        }
        let cat = c_string_lossy(category);
        match self.callback {
            LogCallback::None => {}
            LogCallback::Fmi2(cb) => {
                let msg = c_string_lossy(&message.replace('%', "%%"));
                // SAFETY: the callback is the importer's fmi2CallbackLogger, called with
                // valid NUL-terminated strings and no variadic arguments (the message has
                // no unescaped conversion specifications).
                unsafe {
                    cb(
                        self.env,
                        self.instance_name.as_ptr(),
                        status,
                        cat.as_ptr(),
                        msg.as_ptr(),
                    )
                }
            }
            LogCallback::Fmi3(cb) => {
                // FMI 3.0: not variadic, the message goes as it is
                let msg = c_string_lossy(message);
                // SAFETY: the importer's fmi3LogMessageCallback with valid
                // NUL-terminated strings.
                unsafe { cb(self.env, status, cat.as_ptr(), msg.as_ptr()) }
            }
        }
    }

    pub(crate) fn callback(&self) -> LogCallback {
        self.callback
    }
    pub(crate) fn env(&self) -> ComponentEnvironment {
        self.env
    }

    /// An informative message (category `logEvents`, status OK).
    pub fn info(&self, message: &str) {
        self.log(Status::Ok, "logEvents", message);
    }

    /// A warning (category `logStatusWarning`).
    pub fn warning(&self, message: &str) {
        self.log(Status::Warning, "logStatusWarning", message);
    }

    /// An error (category `logStatusError`).
    pub fn error(&self, message: &str) {
        self.log(Status::Error, "logStatusError", message);
    }
}

/// What a model gets at `fmi2Instantiate` (and again at `fmi2Reset`).
pub struct InstantiateContext<'a> {
    pub instance_name: &'a str,
    /// The decoded `fmuResourceLocation` (None when the importer gave none or a
    /// non-`file:` URI).
    pub resource_dir: Option<PathBuf>,
    pub logger: &'a Logger,
}

/// How [`CoSimModel::do_step_early`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepOutcome {
    /// The step reached `t + h`.
    Completed,
    /// The model stopped at `time_s` (`t <= time_s < t + h`) at an event:
    /// `fmi3DoStep` returns `earlyReturn = fmi3True` and
    /// `lastSuccessfulTime = time_s` (FMI 3.0 section 4.2.1: "the FMU's
    /// request for a communication point at lastSuccessfulTime").
    EarlyReturn {
        time_s: f64,
        /// The model is not valid beyond `time_s`: `terminateSimulation =
        /// fmi3True` (the importer must call `fmi3Terminate`) and the step
        /// returns `fmi3Warning` (the model logged why).
        terminate: bool,
    },
}

/// Little-endian byte writer for serialized FMU states.
#[derive(Default)]
pub struct StateWriter {
    pub(crate) bytes: Vec<u8>,
}

impl StateWriter {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn f64(&mut self, v: f64) {
        self.bytes.extend_from_slice(&v.to_le_bytes());
    }
    pub fn u64(&mut self, v: u64) {
        self.bytes.extend_from_slice(&v.to_le_bytes());
    }
    pub fn bool(&mut self, v: bool) {
        self.bytes.push(v as u8);
    }
    pub fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        v.iter().for_each(|&x| self.f64(x));
    }
    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }
}

/// Reader matching [`StateWriter`]; every read is checked against the length.
pub struct StateReader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> StateReader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, pos: 0 }
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], ModelError> {
        if self.pos + n > self.bytes.len() {
            return Err(ModelError::error(format!(
                "serialized FMU state truncated: need {} bytes at offset {}, have {}",
                n,
                self.pos,
                self.bytes.len()
            )));
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    /// The next value; non-finite values are refused (every Real an FMU
    /// state holds is finite, so NaN or inf means a corrupted state, which
    /// would otherwise return NaN with fmi2OK or hang the next step).
    pub fn f64(&mut self) -> Result<f64, ModelError> {
        let at = self.pos;
        let x = f64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes"));
        if !x.is_finite() {
            return Err(ModelError::error(format!(
                "serialized FMU state: non-finite value {x} at byte {at}"
            )));
        }
        Ok(x)
    }
    pub fn u64(&mut self) -> Result<u64, ModelError> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    pub fn bool(&mut self) -> Result<bool, ModelError> {
        match self.take(1)?[0] {
            0 => Ok(false),
            1 => Ok(true),
            b => Err(ModelError::error(format!(
                "serialized FMU state: bad boolean byte {b}"
            ))),
        }
    }
    pub fn f64s(&mut self, expected_len: usize) -> Result<Vec<f64>, ModelError> {
        let n = self.u64()? as usize;
        if n != expected_len {
            return Err(ModelError::error(format!(
                "serialized FMU state: array of {n} values, expected {expected_len}"
            )));
        }
        (0..n).map(|_| self.f64()).collect()
    }
    /// Error unless every byte was consumed.
    pub fn finish(&self) -> Result<(), ModelError> {
        if self.pos != self.bytes.len() {
            return Err(ModelError::error(format!(
                "serialized FMU state has {} trailing bytes",
                self.bytes.len() - self.pos
            )));
        }
        Ok(())
    }
}

/// A co-simulation model. The layer ([`crate::export_fmu!`]) guarantees:
/// * every value reference passed to `get_*`/`set_*` is in [`Self::VARIABLES`]
///   with the matching type, and `set_*` is only called for variables settable
///   in the current phase, with finite Real values;
/// * `do_step` gets `h > 0` and the current communication point `t`;
/// * methods are never called concurrently on one instance.
///
/// A model keeps all its state in `self` (no statics: several instances live
/// in one process and may step on different threads).
pub trait CoSimModel: Clone + Sized + 'static {
    /// `modelIdentifier` (the shared library's name without extension).
    const MODEL_IDENTIFIER: &'static str;
    /// `guid` of the modelDescription (checked at instantiation); written
    /// only here, the XML is rendered from it.
    const GUID: &'static str;
    /// All scalar variables in the order of their indices: the single source
    /// of the modelDescription's `<ModelVariables>`.
    const VARIABLES: &'static [Variable];
    /// Everything else the modelDescription says (name, texts, capabilities,
    /// units, default experiment, `<ModelStructure>` dependencies).
    const INFO: crate::description::ModelInfo;

    /// Build the model with the modelDescription start values.
    fn instantiate(ctx: &InstantiateContext<'_>) -> Result<Self, ModelError>;

    /// `fmi2SetupExperiment`: the start time (the model's time from then on).
    fn setup_experiment(
        &mut self,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<(), ModelError> {
        let _ = (start_time, stop_time);
        Ok(())
    }
    /// `fmi2EnterInitializationMode`.
    fn enter_initialization_mode(&mut self, log: &Logger) -> Result<(), ModelError> {
        let _ = log;
        Ok(())
    }
    /// `fmi2ExitInitializationMode`: validate parameters, compute initial outputs.
    fn exit_initialization_mode(&mut self, log: &Logger) -> Result<(), ModelError> {
        let _ = log;
        Ok(())
    }

    /// Value of a Real variable at the current time.
    fn get_real(&self, vr: u32) -> f64;
    /// `fmi2GetReal` of one variable: [`Self::get_real`], or an error saying why
    /// the value cannot be computed (e.g. in Initialization Mode with
    /// parameters that do not define the model); a model overrides this when
    /// its `get_real` can be non-finite for a reason the importer should read.
    fn try_get_real(&self, vr: u32) -> Result<f64, ModelError> {
        Ok(self.get_real(vr))
    }
    /// Set a Real input or parameter.
    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError>;
    fn get_integer(&self, vr: u32) -> Result<i32, ModelError> {
        Err(ModelError::error(format!(
            "no Integer variable with value reference {vr}"
        )))
    }
    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), ModelError> {
        let _ = value;
        Err(ModelError::error(format!(
            "no Integer variable with value reference {vr}"
        )))
    }
    fn get_boolean(&self, vr: u32) -> Result<bool, ModelError> {
        Err(ModelError::error(format!(
            "no Boolean variable with value reference {vr}"
        )))
    }
    fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), ModelError> {
        let _ = value;
        Err(ModelError::error(format!(
            "no Boolean variable with value reference {vr}"
        )))
    }
    fn get_string(&self, vr: u32) -> Result<String, ModelError> {
        Err(ModelError::error(format!(
            "no String variable with value reference {vr}"
        )))
    }
    fn set_string(&mut self, vr: u32, value: &str) -> Result<(), ModelError> {
        let _ = value;
        Err(ModelError::error(format!(
            "no String variable with value reference {vr}"
        )))
    }

    /// Advance from `t` to `t + h` (`fmi2DoStep`).
    fn do_step(&mut self, t: f64, h: f64, log: &Logger) -> Result<(), ModelError>;

    /// FMI 3.0 early return (`mightReturnEarlyFromDoStep="true"` in the
    /// modelDescription, FMI 3.0 section 4.2.1 `fmi3DoStep`): the model may
    /// stop a step before `t + h` at an event ([`Self::do_step_early`]).
    const MIGHT_RETURN_EARLY: bool = false;

    /// `fmi3DoStep` of an instance created with `earlyReturnAllowed = true`
    /// (only when [`Self::MIGHT_RETURN_EARLY`]): like [`Self::do_step`], but
    /// the model may stop at an event at `t <= time_s < t + h`, leaving its
    /// state there, and say why through `log`
    /// ([`StepOutcome::EarlyReturn`]); the default never stops.
    fn do_step_early(&mut self, t: f64, h: f64, log: &Logger) -> Result<StepOutcome, ModelError> {
        self.do_step(t, h, log).map(|()| StepOutcome::Completed)
    }

    /// `fmi2SetRealInputDerivatives` for one input (`order >= 1`).
    fn set_real_input_derivative(
        &mut self,
        vr: u32,
        order: u32,
        value: f64,
    ) -> Result<(), ModelError> {
        let _ = value;
        Err(ModelError::error(format!(
            "input derivatives are not supported (value reference {vr}, order {order})"
        )))
    }
    /// `fmi2GetRealOutputDerivatives` for one output (`order >= 1`).
    fn get_real_output_derivative(&self, vr: u32, order: u32) -> Result<f64, ModelError> {
        Err(ModelError::error(format!(
            "output derivatives are not supported (value reference {vr}, order {order})"
        )))
    }
    /// Partial derivative `d unknown / d known` at the current point
    /// (`fmi2GetDirectionalDerivative` sums these).
    fn partial_derivative(&self, unknown: u32, known: u32) -> Result<f64, ModelError> {
        Err(ModelError::error(format!(
            "directional derivatives are not supported (d{unknown}/d{known})"
        )))
    }

    /// Model Exchange (optional): the continuous states, in the order of
    /// `<Derivatives>`. A model that declares any is instantiable as
    /// `fmi2ModelExchange` (event-free: no event indicators, no discrete
    /// states) and implements [`Self::set_time`], [`Self::set_continuous_states`]
    /// and [`Self::derivatives`]; the states are read with `get_real` of
    /// `state_vr`, and `get_real(derivative_vr)` must equal [`Self::derivatives`].
    const CONTINUOUS_STATES: &'static [ContinuousState] = &[];

    /// `fmi2SetTime` (Model Exchange): the model's time [s].
    fn set_time(&mut self, t: f64) -> Result<(), ModelError> {
        let _ = t;
        Err(ModelError::error("Model Exchange is not supported"))
    }
    /// `fmi2SetContinuousStates` (Model Exchange): `x` has one finite value per
    /// entry of [`Self::CONTINUOUS_STATES`].
    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), ModelError> {
        let _ = x;
        Err(ModelError::error("Model Exchange is not supported"))
    }
    /// `fmi2GetDerivatives` (Model Exchange): the time derivatives of the
    /// continuous states at the current time, states and inputs.
    fn derivatives(&self, dx: &mut [f64]) -> Result<(), ModelError> {
        let _ = dx;
        Err(ModelError::error("Model Exchange is not supported"))
    }

    /// FMI 3.0 structural parameters (none: the FMU has no Configuration Mode).
    const STRUCTURAL_PARAMETERS: &'static [StructuralParameter] = &[];
    /// FMI 3.0 array outputs, each sized by one of [`Self::STRUCTURAL_PARAMETERS`].
    const ARRAY_OUTPUTS: &'static [ArrayOutput] = &[];

    /// Value of a structural parameter (`fmi3GetUInt64`).
    fn get_uint64(&self, vr: u32) -> Result<u64, ModelError> {
        Err(ModelError::error(format!(
            "no UInt64 variable with value reference {vr}"
        )))
    }
    /// Set a structural parameter (`fmi3SetUInt64` in Configuration Mode;
    /// the layer has checked `value <= max`).
    fn set_uint64(&mut self, vr: u32, value: u64) -> Result<(), ModelError> {
        let _ = value;
        Err(ModelError::error(format!(
            "no UInt64 variable with value reference {vr}"
        )))
    }
    /// The values of an array output at the current time into `out`, whose
    /// length is its dimension's current value; a model whose data has
    /// another length returns an error naming both numbers.
    fn get_array(&self, vr: u32, out: &mut [f64]) -> Result<(), ModelError> {
        let _ = out;
        Err(ModelError::error(format!(
            "no array variable with value reference {vr}"
        )))
    }

    /// Append the complete dynamic state (states, inputs, parameters, time).
    fn serialize_state(&self, w: &mut StateWriter);
    /// Restore what [`Self::serialize_state`] wrote (into a clone of a live instance).
    fn deserialize_state(&mut self, r: &mut StateReader<'_>) -> Result<(), ModelError>;
}
