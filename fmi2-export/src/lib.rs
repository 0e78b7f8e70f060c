//! # fmi2-export — the FMI 2.0 Co-Simulation and Model Exchange export layer, written once
//!
//! The FMUs of this workspace (`fmu-structure`, `fmu-shaker`,
//! `fmu-controller`) are thin models on top of this crate. It holds the
//! export side's `unsafe` code and FFI (the importer's is in `fmi2-import`):
//! every FMI 2.0 Co-Simulation and (event-free) Model Exchange function with
//! the standard's state machines, argument checks, logging and
//! `catch_unwind` ([`ffi`]), the modelDescription.xml rendered from the code
//! ([`description`], version-neutral, and [`render`], FMI 2.0), the checks
//! that an XML and a model agree ([`xml`], on the one schema of
//! [`fmi2::schema`]), the checks every FMU crate's tests run ([`testing`])
//! and the `.fmu` packager ([`package`]). The C ABI types ([`types`]) and
//! resource-URI decoding ([`uri`]) are the FMI core's (`fmi2`), re-exported here.
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
//! 3. In the cdylib crate root: `fmi2_export::export_fmu!(MyModel);` — this defines
//!    every `fmi2*` symbol of the shared library.
//! 4. Never build an FMU with `panic = "abort"`: the layer relies on
//!    unwinding to turn a panic into `fmi2Error` instead of killing the importer.
//! 5. Test with [`testing`]: `check_model_description_file::<MyModel>(path)`
//!    keeps `modelDescription/<id>/modelDescription.xml` the rendered one
//!    (`UPDATE_MODEL_DESCRIPTION=1` writes it), [`xml::check_dependencies`]
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
pub mod model;
pub mod package;
pub mod render;
pub mod testing;
pub mod xml;

pub use fmi2::{types, uri};

pub use description::{
    BaseUnit, Capabilities, DefaultExperiment, Dependencies, ModelInfo, ModelStructure, Unit,
    LOG_CATEGORY_DESCRIPTIONS,
};
pub use model::{
    Causality, CoSimModel, ContinuousState, InstantiateContext, Logger, ModelError, Start,
    StateReader, StateWriter, VarType, Variability, Variable, LOG_CATEGORIES,
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
