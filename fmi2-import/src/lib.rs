//! FMI 2.0 and FMI 3.0 Co-Simulation import: unpack a `.fmu`, read its
//! `modelDescription.xml` (either version, into one schema), load
//! `binaries/linux64/<modelIdentifier>.so` (FMI 2.0) or
//! `binaries/x86_64-linux/<modelIdentifier>.so` (FMI 3.0) and drive instances
//! through the C API with the same [`Instance`] calls ([`Version`] tells
//! which; FMI 3.0 without event mode, early return or intermediate update,
//! and with `fmi3GetDirectionalDerivative` for masters that use it).
//!
//! Together with `fmi2-export` the only crate with `unsafe` code and FFI. The
//! rules it keeps:
//! * the archive is unpacked into a fresh temporary folder that is removed
//!   when the [`Fmu`] is dropped; entries with absolute paths, `..`
//!   components or symbolic links are refused before anything is written,
//!   and so are archives beyond the [`ImportLimits`] (entries, unpacked bytes);
//! * only regular files are read (a named pipe or device is refused at once);
//! * the `modelIdentifier` must be a plain file name, the binary must resolve
//!   (canonicalised) inside the unpacked folder and be a well-formed ELF
//!   shared object for this architecture, fully inside its file, before it is
//!   loaded (a truncated ELF would kill the process with SIGBUS);
//! * duplicate (type, value reference) pairs are refused with their line;
//! * the library stays loaded while any [`Instance`] of it lives (`Arc`);
//! * every `fmi2Status` becomes a `Result`: `fmi2OK` / `fmi2Warning` are `Ok`,
//!   `fmi2Discard` / `fmi2Error` / `fmi2Fatal` (and `fmi2Pending`, which this
//!   synchronous master never asks for) are [`FmuError::Status`] carrying the
//!   function, the time and the FMU's recent log;
//! * an [`Instance`] frees its saved FMU state and itself in `Drop`;
//! * the FMI logger is C-variadic, which stable Rust cannot define: the C shim
//!   `csrc/logger.c` (compiled by this crate's build script) formats the
//!   message with `vsnprintf` and calls [`logger::host_fmi2_log_message`],
//!   which stores it in the instance's log and echoes warnings and errors to
//!   stderr.
//!
//! Modules: [`archive`] (unzip with the zip-slip and symlink checks),
//! [`library`] (libloading and the C function table), [`logger`] (the log
//! sink behind the C shim), [`instance`] (the safe [`Fmu`] and [`Instance`]).
//! The modelDescription schema is the FMI core's ([`fmi2::schema`]).
pub mod archive;
mod elf;
pub mod error;
pub mod instance;
pub mod library;
pub mod logger;

pub use archive::{unpack, unpack_with, ImportLimits};
pub use error::{FmuError, Result};
pub use fmi2::schema::{
    Causality, CoSimCapabilities, DefaultExperiment, ModelDescription, Problem, ScalarVariable,
    SchemaError, Unknown, VarType, Variability,
};
pub use instance::{Fmu, Instance, Version};
pub use logger::LogRecord;
