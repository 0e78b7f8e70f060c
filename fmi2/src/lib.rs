//! # fmi2 — the FMI 2.0 vocabulary, written once
//!
//! Shared by the export layer (`fmi2-export`, which both FMUs of this
//! workspace build on) and the importer (`fmi2-import`):
//! * [`types`]: the C ABI of `fmi2TypesPlatform.h` / `fmi2FunctionTypes.h`
//!   (status, callback struct) — declarations only, no `unsafe` code here;
//! * [`schema`]: [`Causality`], [`Variability`], [`VarType`] and the one typed
//!   modelDescription.xml schema ([`ModelDescription::parse`], linear in the
//!   size of the file) with [`ModelDescription::validate`] (fmpy-like problems
//!   with the XML line);
//! * [`schema3`]: the FMI 3.0 reader into the same types (scalar variables
//!   a master exchanges; arrays and other types listed by name);
//! * [`uri`]: `fmuResourceLocation` decoding;
//! * [`archive`]: the deflated zip writer (an `.fmu` and an `.ssp` are zips);
//! * [`file`]: bounded reading of regular files only (no pipe or device).
#![forbid(unsafe_code)]
pub mod archive;
pub mod file;
pub mod schema;
pub mod schema3;
pub mod types;
pub mod uri;

pub use archive::{write_zip, ZipWriteError};
pub use file::{open_regular, read_regular, read_regular_to_string, FileError};
pub use schema::{
    Causality, CoSimCapabilities, DefaultExperiment, ModelDescription, OtherVariable, Problem,
    ScalarVariable, SchemaError, Unknown, VarType, Variability,
};
pub use types::Status;
