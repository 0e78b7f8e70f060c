//! # fmi2-export — the FMI 2.0 and FMI 3.0 Co-Simulation and Model Exchange export layer, written once
//!
//! The FMUs of this workspace (`fmu-structure`, `fmu-shaker`,
//! `fmu-controller`) are thin models on top of this crate. It exports both
//! FMI versions from the same model code: one `lib<id>.so` defines every
//! `fmi2*` ([`export_fmu!`]) and every `fmi3*` ([`export_fmu3!`]) function
//! (the names do not collide), and is packaged twice, as `<id>.fmu` (FMI
//! 2.0, `binaries/linux64/`) and `<id>_fmi3.fmu` (FMI 3.0,
//! `binaries/x86_64-linux/`). It holds the export side's `unsafe` code and
//! FFI (the importer's is in `fmi2-import`): every FMI 2.0 Co-Simulation and
//! (event-free) Model Exchange function with the standard's state machines,
//! argument checks, logging and `catch_unwind` ([`ffi`]); the FMI 3.0 API
//! ([`fmi3`]) on the same instance, state machine, checks, logging and
//! FMU-state blob (only the signatures are translated; unsupported
//! features — clocks, Scheduled Execution, Binary, other integer widths,
//! Configuration Mode, adjoint derivatives, event mode in Co-Simulation —
//! answer `fmi3Error` with the reason logged); the modelDescription.xml
//! rendered from the code ([`description`], version-neutral, [`render`],
//! FMI 2.0, and [`render3`], FMI 3.0: `instantiationToken` = the GUID, the
//! independent variable `time` with value reference
//! [`render3::TIME_VALUE_REFERENCE`], typed variable elements,
//! `<ModelStructure>` by value reference); the checks that an XML and a
//! model agree ([`xml`], on the one schema of [`fmi2::schema`]); the checks
//! every FMU crate's tests run ([`testing`], and [`testing3`] for FMI 3.0:
//! CS and ME equal to FMI 2.0 bit for bit, FMU-state round trip, directional
//! derivatives against central differences, a fuzz campaign) and the `.fmu`
//! packager ([`package`]: [`package::write_fmu`], [`package::write_fmu3`]).
//! The C ABI types ([`types`]) and resource-URI decoding ([`uri`]) are the
//! FMI core's (`fmi2`), re-exported here.
//!
//! ## How to implement a model
//!
//! 1. Write a `Clone` struct with all the model's state (no statics: several
//!    instances share one library and may step on different threads).
//! 2. Implement [`CoSimModel`]:
//!    * `MODEL_IDENTIFIER` (= the cdylib's lib name), `GUID` (written only
//!      there: the XML is rendered from it),
//!    * `VARIABLES`: one [`Variable`] per `<ScalarVariable>`, in index order,
//!      with value reference, type, causality, variability, start value, unit
//!      and description (`Variable::real(...).describe("...")`),
//!    * `INFO`: the rest of the modelDescription ([`ModelInfo`]: name,
//!      description, [`Capabilities`], units beyond [`description::UNITS`],
//!      default experiment, the [`ModelStructure`] dependencies by name),
//!    * `instantiate` (start values; `ctx.resource_dir` is the decoded
//!      `resources/` folder), `get_real` / `set_real` (and the other types if
//!      declared), `do_step(t, h)`, `serialize_state` / `deserialize_state`,
//!    * optionally `setup_experiment`, `exit_initialization_mode` (validate
//!      parameters here), `set_real_input_derivative`,
//!      `get_real_output_derivative`, `partial_derivative`.
//!    * optionally Model Exchange: `CONTINUOUS_STATES` (state and derivative
//!      value references, nominals), `set_time`, `set_continuous_states`,
//!      `derivatives` (the model is then instantiable as `fmi2ModelExchange`,
//!      without events; the rendered XML gets `<ModelExchange>`, the
//!      `derivative` attributes and `<Derivatives>`),
//!    * the layer has already checked value references, settability, finite
//!      inputs, pointers, the call sequence and `h > 0` before it calls you;
//!      return [`ModelError`] for failures (any `std::error::Error` converts).
//! 3. In the cdylib crate root: `fmi2_export::export_fmu!(MyModel);` and
//!    `fmi2_export::export_fmu3!(MyModel);` — these define every `fmi2*` and
//!    every `fmi3*` symbol of the shared library.
//! 4. Never build an FMU with `panic = "abort"`: the layer relies on
//!    unwinding to turn a panic into `fmi2Error` instead of killing the importer.
//! 5. Test with [`testing`]: `check_model_description_file::<MyModel>(path)`
//!    keeps `modelDescription/<id>/modelDescription.xml` the rendered one
//!    (`UPDATE_MODEL_DESCRIPTION=1` writes it; `check_model_description_file3`
//!    the FMI 3.0 one in `modelDescription/<id>_fmi3/`), [`xml::check_dependencies`]
//!    holds `<ModelStructure>` to the code, `check_capabilities` the declared
//!    capabilities, [`xml::check_start_values`] the start values.
//!
//! ```ignore
//! #[derive(Clone)]
//! struct Gain { k: f64, u: f64 }
//! impl fmi2_export::CoSimModel for Gain {
//!     const MODEL_IDENTIFIER: &'static str = "gain";
//!     const GUID: &'static str = "{...}";
//!     const VARIABLES: &'static [fmi2_export::Variable] = &[/* k, u, y */];
//!     const INFO: fmi2_export::ModelInfo = fmi2_export::ModelInfo { /* ... */ };
//!     fn instantiate(_: &fmi2_export::InstantiateContext) -> Result<Self, fmi2_export::ModelError> { Ok(Gain { k: 2.0, u: 0.0 }) }
//!     fn get_real(&self, vr: u32) -> f64 { match vr { 0 => self.k, 1 => self.u, _ => self.k * self.u } }
//!     fn set_real(&mut self, vr: u32, v: f64) -> Result<(), fmi2_export::ModelError> { if vr == 0 { self.k = v } else { self.u = v }; Ok(()) }
//!     fn do_step(&mut self, _t: f64, _h: f64, _log: &fmi2_export::Logger) -> Result<(), fmi2_export::ModelError> { Ok(()) }
//!     fn serialize_state(&self, w: &mut fmi2_export::StateWriter) { w.f64(self.k); w.f64(self.u) }
//!     fn deserialize_state(&mut self, r: &mut fmi2_export::StateReader) -> Result<(), fmi2_export::ModelError> { self.k = r.f64()?; self.u = r.f64()?; Ok(()) }
//! }
//! fmi2_export::export_fmu!(Gain);
//! ```
pub mod description;
pub mod ffi;
pub mod fmi3;
pub mod model;
pub mod package;
pub mod render;
pub mod render3;
pub mod testing;
pub mod testing3;
pub mod xml;

pub use fmi2::{types, uri};

pub use description::{
    BaseUnit, Capabilities, DefaultExperiment, Dependencies, ModelInfo, ModelStructure, Unit,
    LOG_CATEGORY_DESCRIPTIONS,
};
pub use model::{
    ArrayOutput, Causality, CoSimModel, ContinuousState, InstantiateContext, LogMessage3, Logger,
    ModelError, Start, StateReader, StateWriter, StepOutcome, StructuralParameter, VarType,
    Variability, Variable, LOG_CATEGORIES,
};
pub use types::Status;

/// Export every FMI 2.0 Co-Simulation and Model Exchange function of a shared library for the
/// model type `$model` (implementing [`CoSimModel`]). Invoke exactly once, in
/// the cdylib crate's root.
#[macro_export]
macro_rules! export_fmu {
    ($model:ty) => {
        #[allow(non_snake_case, clippy::missing_safety_doc)]
        mod __fmi2_exports {
            use super::*;
            use $crate::types::{
                Boolean, Byte, CallbackFunctions, Component, FmiString, FmuState, FmuType, Integer,
                Real, Status, StatusKind, ValueReference,
            };
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const ::std::os::raw::c_char {
                $crate::ffi::get_types_platform()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> *const ::std::os::raw::c_char {
                $crate::ffi::get_version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: Component,
                on: Boolean,
                n: usize,
                cats: *const FmiString,
            ) -> Status {
                $crate::ffi::set_debug_logging::<M>(c, on, n, cats)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: FmiString,
                ty: FmuType,
                guid: FmiString,
                res: FmiString,
                f: *const CallbackFunctions,
                visible: Boolean,
                logging_on: Boolean,
            ) -> Component {
                $crate::ffi::instantiate::<M>(name, ty, guid, res, f, visible, logging_on)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeInstance(c: Component) {
                $crate::ffi::free_instance::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: Component,
                tol_def: Boolean,
                tol: Real,
                t0: Real,
                stop_def: Boolean,
                stop: Real,
            ) -> Status {
                $crate::ffi::setup_experiment::<M>(c, tol_def, tol, t0, stop_def, stop)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Component) -> Status {
                $crate::ffi::enter_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Component) -> Status {
                $crate::ffi::exit_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Terminate(c: Component) -> Status {
                $crate::ffi::terminate::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Reset(c: Component) -> Status {
                $crate::ffi::reset::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetReal(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                v: *mut Real,
            ) -> Status {
                $crate::ffi::get_real::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                v: *mut Integer,
            ) -> Status {
                $crate::ffi::get_integer::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                v: *mut Boolean,
            ) -> Status {
                $crate::ffi::get_boolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetString(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                v: *mut FmiString,
            ) -> Status {
                $crate::ffi::get_string::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetReal(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                v: *const Real,
            ) -> Status {
                $crate::ffi::set_real::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                v: *const Integer,
            ) -> Status {
                $crate::ffi::set_integer::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                v: *const Boolean,
            ) -> Status {
                $crate::ffi::set_boolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetString(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                v: *const FmiString,
            ) -> Status {
                $crate::ffi::set_string::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetFMUstate(c: Component, s: *mut FmuState) -> Status {
                $crate::ffi::get_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetFMUstate(c: Component, s: FmuState) -> Status {
                $crate::ffi::set_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeFMUstate(c: Component, s: *mut FmuState) -> Status {
                $crate::ffi::free_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: Component,
                s: FmuState,
                size: *mut usize,
            ) -> Status {
                $crate::ffi::serialized_fmu_state_size::<M>(c, s, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: Component,
                s: FmuState,
                buf: *mut Byte,
                size: usize,
            ) -> Status {
                $crate::ffi::serialize_fmu_state::<M>(c, s, buf, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: Component,
                buf: *const Byte,
                size: usize,
                s: *mut FmuState,
            ) -> Status {
                $crate::ffi::deserialize_fmu_state::<M>(c, buf, size, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: Component,
                u: *const ValueReference,
                nu: usize,
                k: *const ValueReference,
                nk: usize,
                dk: *const Real,
                du: *mut Real,
            ) -> Status {
                $crate::ffi::get_directional_derivative::<M>(c, u, nu, k, nk, dk, du)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                order: *const Integer,
                v: *const Real,
            ) -> Status {
                $crate::ffi::set_real_input_derivatives::<M>(c, vr, n, order, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: Component,
                vr: *const ValueReference,
                n: usize,
                order: *const Integer,
                v: *mut Real,
            ) -> Status {
                $crate::ffi::get_real_output_derivatives::<M>(c, vr, n, order, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DoStep(
                c: Component,
                t: Real,
                h: Real,
                no_set_prior: Boolean,
            ) -> Status {
                $crate::ffi::do_step::<M>(c, t, h, no_set_prior)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CancelStep(c: Component) -> Status {
                $crate::ffi::cancel_step::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: Component,
                k: StatusKind,
                v: *mut Status,
            ) -> Status {
                $crate::ffi::get_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: Component,
                k: StatusKind,
                v: *mut Real,
            ) -> Status {
                $crate::ffi::get_real_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: Component,
                k: StatusKind,
                v: *mut Integer,
            ) -> Status {
                $crate::ffi::get_integer_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: Component,
                k: StatusKind,
                v: *mut Boolean,
            ) -> Status {
                $crate::ffi::get_boolean_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterEventMode(c: Component) -> Status {
                $crate::ffi::enter_event_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2NewDiscreteStates(
                c: Component,
                info: *mut $crate::types::EventInfo,
            ) -> Status {
                $crate::ffi::new_discrete_states::<M>(c, info)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterContinuousTimeMode(c: Component) -> Status {
                $crate::ffi::enter_continuous_time_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CompletedIntegratorStep(
                c: Component,
                no_set: Boolean,
                enter: *mut Boolean,
                term: *mut Boolean,
            ) -> Status {
                $crate::ffi::completed_integrator_step::<M>(c, no_set, enter, term)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetTime(c: Component, t: Real) -> Status {
                $crate::ffi::set_time::<M>(c, t)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetContinuousStates(
                c: Component,
                x: *const Real,
                n: usize,
            ) -> Status {
                $crate::ffi::set_continuous_states::<M>(c, x, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDerivatives(
                c: Component,
                dx: *mut Real,
                n: usize,
            ) -> Status {
                $crate::ffi::get_derivatives::<M>(c, dx, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetEventIndicators(
                c: Component,
                z: *mut Real,
                n: usize,
            ) -> Status {
                $crate::ffi::get_event_indicators::<M>(c, z, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetContinuousStates(
                c: Component,
                x: *mut Real,
                n: usize,
            ) -> Status {
                $crate::ffi::get_continuous_states::<M>(c, x, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetNominalsOfContinuousStates(
                c: Component,
                x: *mut Real,
                n: usize,
            ) -> Status {
                $crate::ffi::get_nominals_of_continuous_states::<M>(c, x, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: Component,
                k: StatusKind,
                v: *mut FmiString,
            ) -> Status {
                $crate::ffi::get_string_status::<M>(c, k, v)
            }
        }
        pub use __fmi2_exports::*;
    };
}

/// Export every function of the FMI 3.0 C API (common, Co-Simulation,
/// Model Exchange, and the Scheduled Execution, clock, Binary and other-width
/// functions, which answer `fmi3Error` with the reason logged) for the model
/// type `$model`. Invoke once, in the cdylib crate's root, beside
/// [`export_fmu!`]: the `fmi2*` and `fmi3*` names do not collide, so one
/// `lib<id>.so` serves the FMI 2.0 and the FMI 3.0 FMU.
#[macro_export]
macro_rules! export_fmu3 {
    ($model:ty) => {
        #[allow(non_snake_case, clippy::missing_safety_doc, clippy::too_many_arguments)]
        mod __fmi3_exports {
            use super::*;
            use ::std::os::raw::c_void;
            use $crate::types::{Component, FmiString, FmuState, Status, ValueReference};
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi3GetVersion() -> *const ::std::os::raw::c_char {
                $crate::fmi3::get_version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetDebugLogging(c: Component, on: bool, n: usize, cats: *const FmiString) -> Status {
                $crate::fmi3::set_debug_logging::<M>(c, on, n, cats)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateModelExchange(name: FmiString, token: FmiString, res: FmiString, visible: bool, logging_on: bool, env: *mut c_void, log: Option<$crate::LogMessage3>) -> Component {
                $crate::fmi3::instantiate_model_exchange::<M>(name, token, res, visible, logging_on, env, log)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateCoSimulation(name: FmiString, token: FmiString, res: FmiString, visible: bool, logging_on: bool, event_mode_used: bool, early_return_allowed: bool, required: *const ValueReference, n_required: usize, env: *mut c_void, log: Option<$crate::LogMessage3>, update: Option<$crate::fmi3::IntermediateUpdate>) -> Component {
                $crate::fmi3::instantiate_co_simulation::<M>(name, token, res, visible, logging_on, event_mode_used, early_return_allowed, required, n_required, env, log, update)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(name: FmiString, _token: FmiString, _res: FmiString, _visible: bool, logging_on: bool, env: *mut c_void, log: Option<$crate::LogMessage3>, _clock_update: *mut c_void, _lock: *mut c_void, _unlock: *mut c_void) -> Component {
                $crate::fmi3::instantiate_scheduled_execution::<M>(name, env, log, logging_on)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3FreeInstance(c: Component) -> () {
                $crate::ffi::free_instance::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterInitializationMode(c: Component, tol_def: bool, tol: f64, t0: f64, stop_def: bool, stop: f64) -> Status {
                $crate::fmi3::enter_initialization_mode::<M>(c, tol_def, tol, t0, stop_def, stop)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ExitInitializationMode(c: Component) -> Status {
                $crate::ffi::exit_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterEventMode(c: Component) -> Status {
                $crate::ffi::enter_event_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3Terminate(c: Component) -> Status {
                $crate::ffi::terminate::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3Reset(c: Component) -> Status {
                $crate::ffi::reset::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetFloat64(c: Component, vr: *const ValueReference, n: usize, v: *mut f64, nv: usize) -> Status {
                $crate::fmi3::get_float64::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetFloat64(c: Component, vr: *const ValueReference, n: usize, v: *const f64, nv: usize) -> Status {
                $crate::fmi3::set_float64::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetInt32(c: Component, vr: *const ValueReference, n: usize, v: *mut i32, nv: usize) -> Status {
                $crate::fmi3::get_int32::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetInt32(c: Component, vr: *const ValueReference, n: usize, v: *const i32, nv: usize) -> Status {
                $crate::fmi3::set_int32::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetBoolean(c: Component, vr: *const ValueReference, n: usize, v: *mut bool, nv: usize) -> Status {
                $crate::fmi3::get_boolean::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetBoolean(c: Component, vr: *const ValueReference, n: usize, v: *const u8, nv: usize) -> Status {
                $crate::fmi3::set_boolean::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetString(c: Component, vr: *const ValueReference, n: usize, v: *mut FmiString, nv: usize) -> Status {
                $crate::fmi3::get_string::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetString(c: Component, vr: *const ValueReference, n: usize, v: *const FmiString, nv: usize) -> Status {
                $crate::fmi3::set_string::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetFloat32(c: Component, vr: *const ValueReference, n: usize, _v: *mut f32, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3GetFloat32", "Float32", vr, n, false)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetFloat32(c: Component, vr: *const ValueReference, n: usize, _v: *const f32, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3SetFloat32", "Float32", vr, n, true)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetInt8(c: Component, vr: *const ValueReference, n: usize, _v: *mut i8, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3GetInt8", "Int8", vr, n, false)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetInt8(c: Component, vr: *const ValueReference, n: usize, _v: *const i8, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3SetInt8", "Int8", vr, n, true)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetUInt8(c: Component, vr: *const ValueReference, n: usize, _v: *mut u8, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3GetUInt8", "UInt8", vr, n, false)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetUInt8(c: Component, vr: *const ValueReference, n: usize, _v: *const u8, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3SetUInt8", "UInt8", vr, n, true)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetInt16(c: Component, vr: *const ValueReference, n: usize, _v: *mut i16, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3GetInt16", "Int16", vr, n, false)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetInt16(c: Component, vr: *const ValueReference, n: usize, _v: *const i16, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3SetInt16", "Int16", vr, n, true)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetUInt16(c: Component, vr: *const ValueReference, n: usize, _v: *mut u16, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3GetUInt16", "UInt16", vr, n, false)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetUInt16(c: Component, vr: *const ValueReference, n: usize, _v: *const u16, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3SetUInt16", "UInt16", vr, n, true)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetUInt32(c: Component, vr: *const ValueReference, n: usize, _v: *mut u32, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3GetUInt32", "UInt32", vr, n, false)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetUInt32(c: Component, vr: *const ValueReference, n: usize, _v: *const u32, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3SetUInt32", "UInt32", vr, n, true)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetInt64(c: Component, vr: *const ValueReference, n: usize, _v: *mut i64, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3GetInt64", "Int64", vr, n, false)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetInt64(c: Component, vr: *const ValueReference, n: usize, _v: *const i64, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3SetInt64", "Int64", vr, n, true)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetUInt64(c: Component, vr: *const ValueReference, n: usize, v: *mut u64, nv: usize) -> Status {
                $crate::fmi3::get_uint64::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetUInt64(c: Component, vr: *const ValueReference, n: usize, v: *const u64, nv: usize) -> Status {
                $crate::fmi3::set_uint64::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetBinary(c: Component, vr: *const ValueReference, n: usize, _sizes: *mut usize, _v: *mut *const u8, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3GetBinary", "Binary", vr, n, false)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetBinary(c: Component, vr: *const ValueReference, n: usize, _sizes: *const usize, _v: *const *const u8, _nv: usize) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3SetBinary", "Binary", vr, n, true)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetClock(c: Component, vr: *const ValueReference, n: usize, _v: *mut bool) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3GetClock", "Clock", vr, n, false)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetClock(c: Component, vr: *const ValueReference, n: usize, _v: *const bool) -> Status {
                $crate::fmi3::no_such_type::<M>(c, "fmi3SetClock", "Clock", vr, n, true)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetIntervalDecimal(c: Component, _vr: *const ValueReference, _n: usize, _i: *mut f64, _q: *mut i32) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3GetIntervalDecimal", "the FMU has no clocks (the controller samples with a fixed internal step; see its README)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetIntervalFraction(c: Component, _vr: *const ValueReference, _n: usize, _counters: *mut u64, _r: *mut u64, _q: *mut i32) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3GetIntervalFraction", "the FMU has no clocks (the controller samples with a fixed internal step; see its README)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetShiftDecimal(c: Component, _vr: *const ValueReference, _n: usize, _s: *mut f64) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3GetShiftDecimal", "the FMU has no clocks (the controller samples with a fixed internal step; see its README)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetShiftFraction(c: Component, _vr: *const ValueReference, _n: usize, _counters: *mut u64, _r: *mut u64) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3GetShiftFraction", "the FMU has no clocks (the controller samples with a fixed internal step; see its README)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetIntervalDecimal(c: Component, _vr: *const ValueReference, _n: usize, _i: *const f64) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3SetIntervalDecimal", "the FMU has no clocks (the controller samples with a fixed internal step; see its README)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetIntervalFraction(c: Component, _vr: *const ValueReference, _n: usize, _counters: *const u64, _r: *const u64) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3SetIntervalFraction", "the FMU has no clocks (the controller samples with a fixed internal step; see its README)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetShiftDecimal(c: Component, _vr: *const ValueReference, _n: usize, _s: *const f64) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3SetShiftDecimal", "the FMU has no clocks (the controller samples with a fixed internal step; see its README)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetShiftFraction(c: Component, _vr: *const ValueReference, _n: usize, _counters: *const u64, _r: *const u64) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3SetShiftFraction", "the FMU has no clocks (the controller samples with a fixed internal step; see its README)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ActivateModelPartition(c: Component, _clock: ValueReference, _t: f64) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3ActivateModelPartition", "no Scheduled Execution: the FMU has no clocks (the controller samples with a fixed internal step; see its README)")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EvaluateDiscreteStates(c: Component) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3EvaluateDiscreteStates", "not provided (providesEvaluateDiscreteStates=\"false\"): the FMU has no discrete states")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterConfigurationMode(c: Component) -> Status {
                $crate::fmi3::enter_configuration_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ExitConfigurationMode(c: Component) -> Status {
                $crate::fmi3::exit_configuration_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNumberOfVariableDependencies(c: Component, _vr: ValueReference, _n: *mut usize) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3GetNumberOfVariableDependencies", "not provided (providesPerElementDependencies=\"false\"): the dependencies are in <ModelStructure>")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetVariableDependencies(c: Component, _vr: ValueReference, _ei: *mut usize, _ind: *mut ValueReference, _eii: *mut usize, _kinds: *mut i32, _n: usize) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3GetVariableDependencies", "not provided (providesPerElementDependencies=\"false\"): the dependencies are in <ModelStructure>")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetFMUState(c: Component, s: *mut FmuState) -> Status {
                $crate::fmi3::get_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetFMUState(c: Component, s: FmuState) -> Status {
                $crate::fmi3::set_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3FreeFMUState(c: Component, s: *mut FmuState) -> Status {
                $crate::fmi3::free_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SerializedFMUStateSize(c: Component, s: FmuState, size: *mut usize) -> Status {
                $crate::fmi3::serialized_fmu_state_size::<M>(c, s, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SerializeFMUState(c: Component, s: FmuState, buf: *mut u8, size: usize) -> Status {
                $crate::fmi3::serialize_fmu_state::<M>(c, s, buf, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3DeserializeFMUState(c: Component, buf: *const u8, size: usize, s: *mut FmuState) -> Status {
                $crate::fmi3::deserialize_fmu_state::<M>(c, buf, size, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetDirectionalDerivative(c: Component, u: *const ValueReference, nu: usize, k: *const ValueReference, nk: usize, seed: *const f64, ns: usize, sens: *mut f64, nsens: usize) -> Status {
                $crate::fmi3::get_directional_derivative::<M>(c, u, nu, k, nk, seed, ns, sens, nsens)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetAdjointDerivative(c: Component, _u: *const ValueReference, _nu: usize, _k: *const ValueReference, _nk: usize, _seed: *const f64, _ns: usize, _sens: *mut f64, _nsens: usize) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3GetAdjointDerivative", "not provided (providesAdjointDerivatives=\"false\")")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterStepMode(c: Component) -> Status {
                $crate::fmi3::unsupported::<M>(c, "fmi3EnterStepMode", "the FMU has no Event Mode in Co-Simulation (hasEventMode=\"false\"): the instance is in Step Mode after fmi3ExitInitializationMode")
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetOutputDerivatives(c: Component, vr: *const ValueReference, n: usize, orders: *const i32, v: *mut f64, nv: usize) -> Status {
                $crate::fmi3::get_output_derivatives::<M>(c, vr, n, orders, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3DoStep(c: Component, t: f64, h: f64, no_set: bool, ev: *mut bool, term: *mut bool, early: *mut bool, last: *mut f64) -> Status {
                $crate::fmi3::do_step::<M>(c, t, h, no_set, ev, term, early, last)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3UpdateDiscreteStates(c: Component, a: *mut bool, b: *mut bool, d: *mut bool, e: *mut bool, f: *mut bool, g: *mut f64) -> Status {
                $crate::fmi3::update_discrete_states::<M>(c, a, b, d, e, f, g)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterContinuousTimeMode(c: Component) -> Status {
                $crate::ffi::enter_continuous_time_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3CompletedIntegratorStep(c: Component, no_set: bool, enter: *mut bool, term: *mut bool) -> Status {
                $crate::fmi3::completed_integrator_step::<M>(c, no_set, enter, term)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetTime(c: Component, t: f64) -> Status {
                $crate::ffi::set_time::<M>(c, t)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetContinuousStates(c: Component, x: *const f64, n: usize) -> Status {
                $crate::ffi::set_continuous_states::<M>(c, x, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetContinuousStateDerivatives(c: Component, dx: *mut f64, n: usize) -> Status {
                $crate::ffi::get_derivatives::<M>(c, dx, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetEventIndicators(c: Component, z: *mut f64, n: usize) -> Status {
                $crate::ffi::get_event_indicators::<M>(c, z, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetContinuousStates(c: Component, x: *mut f64, n: usize) -> Status {
                $crate::ffi::get_continuous_states::<M>(c, x, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNominalsOfContinuousStates(c: Component, x: *mut f64, n: usize) -> Status {
                $crate::ffi::get_nominals_of_continuous_states::<M>(c, x, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNumberOfEventIndicators(c: Component, n: *mut usize) -> Status {
                $crate::fmi3::get_number_of_event_indicators::<M>(c, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNumberOfContinuousStates(c: Component, n: *mut usize) -> Status {
                $crate::fmi3::get_number_of_continuous_states::<M>(c, n)
            }
        }
        pub use __fmi3_exports::*;
    };
}
