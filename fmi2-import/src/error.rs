//! The importer's errors.
use std::path::PathBuf;

/// Why an FMU could not be imported or an FMI call failed. Each variant names
/// the file, entry, variable or function at fault.
#[derive(Debug, thiserror::Error)]
pub enum FmuError {
    /// The modelDescription.xml cannot be used, or a variable is not there.
    #[error(transparent)]
    Schema(#[from] fmi2::SchemaError),
    #[error("cannot read FMU {path}: {source}")]
    Open {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a valid zip archive: {source}")]
    Zip {
        path: PathBuf,
        source: zip::result::ZipError,
    },
    #[error("{path}: archive entry '{entry}' escapes the extraction folder (absolute path or '..'); nothing unpacked")]
    UnsafeEntry { path: PathBuf, entry: String },
    #[error("{path}: archive entry '{entry}' is a symbolic link; nothing unpacked")]
    Symlink { path: PathBuf, entry: String },
    #[error("cannot unpack '{entry}' of {path}: {source}")]
    Unpack {
        path: PathBuf,
        entry: String,
        source: std::io::Error,
    },
    #[error(transparent)]
    File { source: fmi2::FileError },
    #[error("{path}: {entries} archive entries, more than the limit of {max} (ImportLimits::max_entries); nothing unpacked")]
    TooManyEntries {
        path: PathBuf,
        entries: usize,
        max: usize,
    },
    #[error("{path}: unpacks to more than {max} bytes ({size} so far; ImportLimits::max_unpacked_bytes)")]
    TooLarge { path: PathBuf, size: u64, max: u64 },
    #[error("FMU '{model}': modelIdentifier '{identifier}' must be a plain file name (no path separator, no '..', not absolute, not empty)")]
    BadIdentifier { model: String, identifier: String },
    #[error("FMU '{model}': binary {path} resolves outside the unpacked FMU folder")]
    BinaryOutside { model: String, path: PathBuf },
    #[error("FMU '{model}': binary {path} is not a loadable shared library: {reason}")]
    BadBinary {
        model: String,
        path: PathBuf,
        reason: String,
    },
    #[error("{path}: no modelDescription.xml at the archive root")]
    NoModelDescription { path: PathBuf },
    #[error("FMU '{model}': binary {path} is missing (modelIdentifier '{identifier}', this platform's folder)")]
    MissingBinary {
        model: String,
        identifier: String,
        path: PathBuf,
    },
    #[error("cannot load {path}: {source}")]
    Load {
        path: PathBuf,
        source: libloading::Error,
    },
    #[error("{path}: missing FMI function {name}")]
    Symbol { path: PathBuf, name: &'static str },
    #[error("{path}: fmi*GetVersion returns \"{found}\", expected \"{expected}\" (the modelDescription's fmiVersion)")]
    BinaryVersion {
        path: PathBuf,
        found: String,
        expected: &'static str,
    },
    #[error("{function} of '{instance}' (model '{model}', GUID {guid}) failed; FMU log: {log}")]
    Instantiate {
        function: &'static str,
        instance: String,
        model: String,
        guid: String,
        log: String,
    },
    #[error(
        "{function} of instance '{instance}' at t = {time_s} s returned {status}; FMU log: {log}"
    )]
    Status {
        function: &'static str,
        instance: String,
        status: &'static str,
        time_s: f64,
        log: String,
    },
    #[error("FMU '{model}' does not support {what}")]
    Unsupported { model: String, what: &'static str },
}

pub type Result<T, E = FmuError> = std::result::Result<T, E>;
