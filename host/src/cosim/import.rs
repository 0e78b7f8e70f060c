//! FMI 2.0 Co-Simulation import: unpack a `.fmu`, read its
//! `modelDescription.xml`, load `binaries/linux64/<modelIdentifier>.so` and
//! drive instances through the C API.
//!
//! This is the only place in `host` with `unsafe` code and FFI. The rules it
//! keeps:
//! * the archive is unpacked into a fresh temporary folder that is removed
//!   when the [`Fmu`] is dropped; entries with absolute paths, `..`
//!   components or symbolic links are refused before anything is written;
//! * the library stays loaded while any [`Instance`] of it lives (`Arc`);
//! * every `fmi2Status` becomes a `Result`: `fmi2OK` / `fmi2Warning` are `Ok`,
//!   `fmi2Discard` / `fmi2Error` / `fmi2Fatal` (and `fmi2Pending`, which this
//!   synchronous master never asks for) are [`FmuError::Status`] carrying the
//!   function, the time and the FMU's recent log;
//! * an [`Instance`] frees its saved FMU state and itself in `Drop`;
//! * the FMI logger is C-variadic, which stable Rust cannot define: the C shim
//!   `csrc/logger.c` formats the message with `vsnprintf` and calls
//!   [`host_fmi2_log_message`], which stores it in the instance's log and
//!   echoes warnings and errors to stderr.
use std::collections::VecDeque;
use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::fs::File;
use std::io::Read;
use std::path::{Component as PathComponent, Path, PathBuf};
use std::sync::{Arc, Mutex};

use quick_xml::events::{BytesStart, Event};

/// Why an FMU could not be imported or an FMI call failed. Each variant names
/// the file, entry, variable or function at fault.
#[derive(Debug, thiserror::Error)]
pub enum FmuError {
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
    #[error("{path}: no modelDescription.xml at the archive root")]
    NoModelDescription { path: PathBuf },
    #[error("modelDescription.xml line {line}: {message}")]
    Xml { line: usize, message: String },
    #[error("modelDescription.xml: fmiVersion is \"{found}\", but this host imports FMI 2.0 only")]
    Version { found: String },
    #[error("modelDescription.xml of '{model}': no <CoSimulation> element (Model Exchange only?); the host needs FMI 2.0 Co-Simulation")]
    NoCoSimulation { model: String },
    #[error("FMU '{model}': binary {path} is missing (platform linux64, modelIdentifier '{identifier}')")]
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
    #[error("{path}: fmi2GetVersion returns \"{found}\", expected \"2.0\"")]
    BinaryVersion { path: PathBuf, found: String },
    #[error(
        "fmi2Instantiate of '{instance}' (model '{model}', GUID {guid}) failed; FMU log: {log}"
    )]
    Instantiate {
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
    #[error("FMU '{model}' has no variable named '{name}'")]
    UnknownVariable { model: String, name: String },
    #[error("FMU '{model}': variable '{name}' is {found}, expected {expected}")]
    WrongVariable {
        model: String,
        name: String,
        found: String,
        expected: &'static str,
    },
    #[error("FMU '{model}' does not support {what}")]
    Unsupported { model: String, what: &'static str },
}

pub type Result<T, E = FmuError> = std::result::Result<T, E>;

// ---------------------------------------------------------------------------
// modelDescription.xml

/// Type of a scalar variable (the child element of `<ScalarVariable>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
    Enumeration,
}

/// The attribute enums are the export layer's (one definition of FMI 2.0's vocabulary).
pub use fmi2::model::{Causality, Variability};

/// One `<ScalarVariable>`.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalarVariable {
    pub name: String,
    pub value_reference: u32,
    pub description: String,
    pub causality: Causality,
    pub variability: Variability,
    pub ty: VarType,
    /// The `start` attribute, unparsed (its meaning depends on `ty`).
    pub start: Option<String>,
    pub unit: Option<String>,
    /// Line of the `<ScalarVariable>` element in modelDescription.xml.
    pub line: usize,
}

/// The `<CoSimulation>` capabilities.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CoSimCapabilities {
    pub model_identifier: String,
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
    pub needs_execution_tool: bool,
    pub can_be_instantiated_only_once_per_process: bool,
}

/// `<DefaultExperiment>`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DefaultExperiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    pub step_size: Option<f64>,
}

/// An `<Outputs>` entry of `<ModelStructure>`: the output variable (index
/// into [`ModelDescription::variables`]) and the variables it depends on
/// (`None`: dependencies not given, i.e. possibly on everything).
#[derive(Debug, Clone, PartialEq)]
pub struct OutputDependency {
    pub output: usize,
    pub dependencies: Option<Vec<usize>>,
}

/// The parsed `modelDescription.xml`.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelDescription {
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: String,
    pub generation_tool: String,
    pub co_simulation: CoSimCapabilities,
    pub default_experiment: DefaultExperiment,
    pub variables: Vec<ScalarVariable>,
    pub outputs: Vec<OutputDependency>,
}

/// A `<ScalarVariable>` being read: its attributes, line, and type element (type, attributes).
type PendingVariable = (
    Vec<(String, String)>,
    usize,
    Option<(VarType, Vec<(String, String)>)>,
);

fn line_of(text: &str, pos: u64) -> usize {
    let end = (pos as usize).min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

fn parse_bool(v: &str, attr: &str, line: usize) -> Result<bool> {
    match v {
        "true" | "1" => Ok(true),
        "false" | "0" => Ok(false),
        _ => Err(FmuError::Xml {
            line,
            message: format!("attribute {attr}=\"{v}\": expected true or false"),
        }),
    }
}

fn parse_num<T: std::str::FromStr>(v: &str, attr: &str, line: usize, what: &str) -> Result<T> {
    v.trim().parse::<T>().map_err(|_| FmuError::Xml {
        line,
        message: format!("attribute {attr}=\"{v}\": expected {what}"),
    })
}

/// Attributes of an element as (name, unescaped value).
fn attrs(e: &BytesStart<'_>, line: usize) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|err| FmuError::Xml {
            line,
            message: format!("malformed attribute: {err}"),
        })?;
        let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let val = a
            .unescape_value()
            .map_err(|err| FmuError::Xml {
                line,
                message: format!("attribute {key}: {err}"),
            })?
            .into_owned();
        out.push((key, val));
    }
    Ok(out)
}

fn get<'a>(a: &'a [(String, String)], k: &str) -> Option<&'a str> {
    a.iter().find(|(n, _)| n == k).map(|(_, v)| v.as_str())
}

impl ModelDescription {
    /// Parse the text of a `modelDescription.xml`. Malformed XML and invalid
    /// attributes are [`FmuError::Xml`] with the line; a version other than
    /// 2.0 is [`FmuError::Version`]; a missing `<CoSimulation>` is
    /// [`FmuError::NoCoSimulation`].
    pub fn parse(text: &str) -> Result<Self> {
        let mut reader = quick_xml::Reader::from_str(text);
        reader.config_mut().trim_text(true);
        let mut md = ModelDescription {
            fmi_version: String::new(),
            model_name: String::new(),
            guid: String::new(),
            description: String::new(),
            generation_tool: String::new(),
            co_simulation: CoSimCapabilities::default(),
            default_experiment: DefaultExperiment::default(),
            variables: Vec::new(),
            outputs: Vec::new(),
        };
        let mut has_root = false;
        let mut has_cs = false;
        let mut stack: Vec<String> = Vec::new();
        // The <ScalarVariable> being read: (attributes, line, type child seen).
        let mut current: Option<PendingVariable> = None;
        loop {
            let pos = reader.buffer_position();
            let ev = reader.read_event().map_err(|e| FmuError::Xml {
                line: line_of(text, reader.error_position().max(pos)),
                message: e.to_string(),
            })?;
            // The event starts at the first non-blank byte after `pos`.
            let start = pos as usize
                + text.as_bytes()[(pos as usize).min(text.len())..]
                    .iter()
                    .take_while(|b| b.is_ascii_whitespace())
                    .count();
            let line = line_of(text, start as u64);
            let (e, empty) = match &ev {
                Event::Start(e) => (Some(e.clone()), false),
                Event::Empty(e) => (Some(e.clone()), true),
                Event::End(_) => {
                    let name = stack.pop().unwrap_or_default();
                    if name == "ScalarVariable" {
                        md.finish_variable(current.take(), line)?;
                    }
                    continue;
                }
                Event::Eof => break,
                _ => continue,
            };
            let e = e.expect("start or empty");
            let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
            let a = attrs(&e, line)?;
            let parent = stack.last().map(String::as_str).unwrap_or("");
            match (parent, name.as_str()) {
                ("", "fmiModelDescription") => {
                    has_root = true;
                    md.fmi_version = get(&a, "fmiVersion").unwrap_or("").to_string();
                    if md.fmi_version != "2.0" {
                        return Err(FmuError::Version {
                            found: md.fmi_version,
                        });
                    }
                    md.model_name = get(&a, "modelName").unwrap_or("").to_string();
                    md.guid = get(&a, "guid")
                        .ok_or_else(|| FmuError::Xml {
                            line,
                            message: "fmiModelDescription has no guid attribute".into(),
                        })?
                        .to_string();
                    md.description = get(&a, "description").unwrap_or("").to_string();
                    md.generation_tool = get(&a, "generationTool").unwrap_or("").to_string();
                }
                ("", other) => {
                    return Err(FmuError::Xml {
                        line,
                        message: format!(
                            "root element is <{other}>, expected <fmiModelDescription>"
                        ),
                    })
                }
                ("fmiModelDescription", "CoSimulation") => {
                    has_cs = true;
                    let cs = &mut md.co_simulation;
                    cs.model_identifier = get(&a, "modelIdentifier")
                        .ok_or_else(|| FmuError::Xml {
                            line,
                            message: "<CoSimulation> has no modelIdentifier".into(),
                        })?
                        .to_string();
                    for (k, v) in &a {
                        match k.as_str() {
                            "canHandleVariableCommunicationStepSize" => {
                                cs.can_handle_variable_communication_step_size =
                                    parse_bool(v, k, line)?
                            }
                            "canInterpolateInputs" => {
                                cs.can_interpolate_inputs = parse_bool(v, k, line)?
                            }
                            "maxOutputDerivativeOrder" => {
                                cs.max_output_derivative_order =
                                    parse_num(v, k, line, "an unsigned integer")?
                            }
                            "canGetAndSetFMUstate" => {
                                cs.can_get_and_set_fmu_state = parse_bool(v, k, line)?
                            }
                            "canSerializeFMUstate" => {
                                cs.can_serialize_fmu_state = parse_bool(v, k, line)?
                            }
                            "providesDirectionalDerivative" => {
                                cs.provides_directional_derivative = parse_bool(v, k, line)?
                            }
                            "needsExecutionTool" => {
                                cs.needs_execution_tool = parse_bool(v, k, line)?
                            }
                            "canBeInstantiatedOnlyOncePerProcess" => {
                                cs.can_be_instantiated_only_once_per_process =
                                    parse_bool(v, k, line)?
                            }
                            _ => {}
                        }
                    }
                }
                ("fmiModelDescription", "DefaultExperiment") => {
                    let f = |k: &str| -> Result<Option<f64>> {
                        get(&a, k)
                            .map(|v| parse_num::<f64>(v, k, line, "a number"))
                            .transpose()
                    };
                    md.default_experiment = DefaultExperiment {
                        start_time: f("startTime")?,
                        stop_time: f("stopTime")?,
                        tolerance: f("tolerance")?,
                        step_size: f("stepSize")?,
                    };
                }
                ("ModelVariables", "ScalarVariable") => {
                    current = Some((a, line, None));
                    if empty {
                        md.finish_variable(current.take(), line)?;
                    }
                }
                (
                    "ScalarVariable",
                    t @ ("Real" | "Integer" | "Boolean" | "String" | "Enumeration"),
                ) => {
                    let ty = match t {
                        "Real" => VarType::Real,
                        "Integer" => VarType::Integer,
                        "Boolean" => VarType::Boolean,
                        "String" => VarType::String,
                        _ => VarType::Enumeration,
                    };
                    let cur = current.as_mut().expect("inside ScalarVariable");
                    if cur.2.is_some() {
                        return Err(FmuError::Xml {
                            line,
                            message: "ScalarVariable has more than one type element".into(),
                        });
                    }
                    cur.2 = Some((ty, a));
                }
                ("Outputs", "Unknown") => {
                    let idx: usize = parse_num(
                        get(&a, "index").ok_or_else(|| FmuError::Xml {
                            line,
                            message: "<Unknown> has no index".into(),
                        })?,
                        "index",
                        line,
                        "a positive integer",
                    )?;
                    let deps = match get(&a, "dependencies") {
                        None => None,
                        Some(d) => Some(
                            d.split_whitespace()
                                .map(|s| {
                                    parse_num::<usize>(s, "dependencies", line, "positive integers")
                                })
                                .collect::<Result<Vec<_>>>()?,
                        ),
                    };
                    let check = |i: usize| -> Result<usize> {
                        if i == 0 || i > md.variables.len() {
                            Err(FmuError::Xml {
                                line,
                                message: format!(
                                    "index {i} outside 1..={} (the ScalarVariables)",
                                    md.variables.len()
                                ),
                            })
                        } else {
                            Ok(i - 1)
                        }
                    };
                    let output = check(idx)?;
                    let dependencies = deps
                        .map(|d| d.into_iter().map(check).collect::<Result<Vec<_>>>())
                        .transpose()?;
                    md.outputs.push(OutputDependency {
                        output,
                        dependencies,
                    });
                }
                _ => {}
            }
            if !empty {
                stack.push(name);
            }
        }
        if !has_root {
            return Err(FmuError::Xml {
                line: 1,
                message: "no <fmiModelDescription> element".into(),
            });
        }
        if !has_cs {
            return Err(FmuError::NoCoSimulation {
                model: md.model_name,
            });
        }
        Ok(md)
    }

    fn finish_variable(&mut self, cur: Option<PendingVariable>, end_line: usize) -> Result<()> {
        let Some((a, line, ty)) = cur else {
            return Ok(());
        };
        let name = get(&a, "name").ok_or_else(|| FmuError::Xml {
            line,
            message: "ScalarVariable has no name".into(),
        })?;
        let vr: u32 = parse_num(
            get(&a, "valueReference").ok_or_else(|| FmuError::Xml {
                line,
                message: format!("ScalarVariable '{name}' has no valueReference"),
            })?,
            "valueReference",
            line,
            "an unsigned 32-bit integer",
        )?;
        let (ty, ta) = ty.ok_or_else(|| FmuError::Xml {
            line: end_line,
            message: format!("ScalarVariable '{name}' has no type element (Real, Integer, Boolean, String, Enumeration)"),
        })?;
        let causality = match get(&a, "causality").unwrap_or("local") {
            "parameter" => Causality::Parameter,
            "calculatedParameter" => Causality::CalculatedParameter,
            "input" => Causality::Input,
            "output" => Causality::Output,
            "local" => Causality::Local,
            "independent" => Causality::Independent,
            other => {
                return Err(FmuError::Xml {
                    line,
                    message: format!("ScalarVariable '{name}': unknown causality \"{other}\""),
                })
            }
        };
        let variability = match get(&a, "variability").unwrap_or("continuous") {
            "constant" => Variability::Constant,
            "fixed" => Variability::Fixed,
            "tunable" => Variability::Tunable,
            "discrete" => Variability::Discrete,
            "continuous" => Variability::Continuous,
            other => {
                return Err(FmuError::Xml {
                    line,
                    message: format!("ScalarVariable '{name}': unknown variability \"{other}\""),
                })
            }
        };
        if self.variables.iter().any(|v| v.name == name) {
            return Err(FmuError::Xml {
                line,
                message: format!("ScalarVariable name '{name}' repeats"),
            });
        }
        self.variables.push(ScalarVariable {
            name: name.to_string(),
            value_reference: vr,
            description: get(&a, "description").unwrap_or("").to_string(),
            causality,
            variability,
            ty,
            start: get(&ta, "start").map(str::to_string),
            unit: get(&ta, "unit").map(str::to_string),
            line,
        });
        Ok(())
    }

    /// The variable called `name`.
    pub fn variable(&self, name: &str) -> Result<&ScalarVariable> {
        self.variables
            .iter()
            .find(|v| v.name == name)
            .ok_or_else(|| FmuError::UnknownVariable {
                model: self.model_name.clone(),
                name: name.into(),
            })
    }

    /// Value reference of the Real variable `name` whose causality is one of `allowed`.
    pub fn real_vr(&self, name: &str, allowed: &[Causality]) -> Result<u32> {
        let v = self.variable(name)?;
        if v.ty != VarType::Real || !allowed.contains(&v.causality) {
            return Err(FmuError::WrongVariable {
                model: self.model_name.clone(),
                name: name.into(),
                found: format!("{:?} {:?}", v.causality, v.ty),
                expected: "a Real of the required causality",
            });
        }
        Ok(v.value_reference)
    }

    /// Whether output `output` (variable index) depends directly on variable `input` (index).
    /// Without `<ModelStructure>` information every output may depend on every input.
    pub fn output_depends_on(&self, output: usize, input: usize) -> bool {
        match self.outputs.iter().find(|o| o.output == output) {
            None => true,
            Some(o) => match &o.dependencies {
                None => true,
                Some(d) => d.contains(&input),
            },
        }
    }
}

// ---------------------------------------------------------------------------
// Unpacking

/// Unpack `fmu` into `dir`. Every entry is checked before anything is written:
/// absolute paths, `..` components and symbolic links are refused.
pub fn unpack(fmu: &Path, dir: &Path) -> Result<()> {
    let file = File::open(fmu).map_err(|source| FmuError::Open {
        path: fmu.into(),
        source,
    })?;
    let mut z = zip::ZipArchive::new(file).map_err(|source| FmuError::Zip {
        path: fmu.into(),
        source,
    })?;
    let zerr = |source| FmuError::Zip {
        path: fmu.into(),
        source,
    };
    let mut plan = Vec::with_capacity(z.len());
    for i in 0..z.len() {
        let f = z.by_index_raw(i).map_err(zerr)?;
        let name = f.name().to_string();
        let rel = Path::new(&name);
        let safe = !name.contains('\\')
            && !name.contains('\0')
            && rel
                .components()
                .all(|c| matches!(c, PathComponent::Normal(_) | PathComponent::CurDir));
        if !safe || f.enclosed_name().is_none() {
            return Err(FmuError::UnsafeEntry {
                path: fmu.into(),
                entry: name,
            });
        }
        if f.is_symlink() {
            return Err(FmuError::Symlink {
                path: fmu.into(),
                entry: name,
            });
        }
        plan.push((i, name, f.is_dir()));
    }
    for (i, name, is_dir) in plan {
        let uerr = |source| FmuError::Unpack {
            path: fmu.into(),
            entry: name.clone(),
            source,
        };
        let target = dir.join(&name);
        if is_dir {
            std::fs::create_dir_all(&target).map_err(uerr)?;
            continue;
        }
        if let Some(p) = target.parent() {
            std::fs::create_dir_all(p).map_err(uerr)?;
        }
        let mut f = z.by_index(i).map_err(zerr)?;
        let mut out = File::create(&target).map_err(uerr)?;
        std::io::copy(&mut f, &mut out).map_err(uerr)?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// The C API

type Component = *mut c_void;
type FmuStatePtr = *mut c_void;
type Status = c_int;

/// `fmi2CallbackFunctions`.
#[repr(C)]
struct CallbackFunctions {
    logger:
        unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char, ...),
    allocate_memory: unsafe extern "C" fn(usize, usize) -> *mut c_void,
    free_memory: unsafe extern "C" fn(*mut c_void),
    step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    component_environment: *mut c_void,
}

extern "C" {
    /// The C shim (`csrc/logger.c`).
    fn host_fmi2_logger(
        env: *mut c_void,
        instance: *const c_char,
        status: c_int,
        category: *const c_char,
        fmt: *const c_char,
        ...
    );
}

unsafe extern "C" fn alloc_memory(n: usize, size: usize) -> *mut c_void {
    extern "C" {
        fn calloc(n: usize, size: usize) -> *mut c_void;
    }
    calloc(n, size)
}

unsafe extern "C" fn free_memory(p: *mut c_void) {
    extern "C" {
        fn free(p: *mut c_void);
    }
    free(p)
}

/// Receives every formatted FMU log message from the C shim.
///
/// # Safety
/// `env` is the `LogSink` the instance was created with (or null); the strings
/// are NUL-terminated or null.
#[no_mangle]
pub unsafe extern "C" fn host_fmi2_log_message(
    env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let s = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            CStr::from_ptr(p).to_string_lossy().into_owned()
        }
    };
    let (instance, category, message) = (s(instance), s(category), s(message));
    // Never unwind into C.
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let rec = LogRecord {
            status: status_name(status),
            category,
            message,
        };
        if env.is_null() {
            eprintln!("[fmu {instance}] {}: {}", rec.status, rec.message);
        } else {
            (*(env as *const LogSink)).push(&instance, rec);
        }
    }));
}

fn status_name(s: Status) -> &'static str {
    match s {
        0 => "fmi2OK",
        1 => "fmi2Warning",
        2 => "fmi2Discard",
        3 => "fmi2Error",
        4 => "fmi2Fatal",
        5 => "fmi2Pending",
        _ => "unknown status",
    }
}

/// One message an FMU sent to the logger.
#[derive(Debug, Clone, PartialEq)]
pub struct LogRecord {
    pub status: &'static str,
    pub category: String,
    pub message: String,
}

/// The most recent log messages of one instance.
struct LogSink {
    records: Mutex<VecDeque<LogRecord>>,
    echo: bool,
}

const LOG_KEEP: usize = 64;

impl LogSink {
    fn push(&self, instance: &str, rec: LogRecord) {
        if self.echo && rec.status != "fmi2OK" {
            eprintln!(
                "[fmu {instance}] {} ({}): {}",
                rec.status, rec.category, rec.message
            );
        }
        let mut r = self.records.lock().unwrap_or_else(|e| e.into_inner());
        if r.len() == LOG_KEEP {
            r.pop_front();
        }
        r.push_back(rec);
    }

    fn summary(&self) -> String {
        let r = self.records.lock().unwrap_or_else(|e| e.into_inner());
        if r.is_empty() {
            return "(no messages)".into();
        }
        r.iter()
            .rev()
            .take(8)
            .rev()
            .map(|m| format!("[{}] {}", m.status, m.message))
            .collect::<Vec<_>>()
            .join(" | ")
    }
}

macro_rules! fns {
    ($( $field:ident : $sym:literal : fn($($arg:ty),*) $(-> $ret:ty)? ;)*) => {
        /// The FMI 2.0 CS functions of one loaded library.
        #[allow(clippy::type_complexity)]
        struct Fns {
            $( $field: unsafe extern "C" fn($($arg),*) $(-> $ret)?, )*
            _lib: libloading::Library,
        }
        impl Fns {
            fn load(path: &Path) -> Result<Self> {
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
    setup_experiment: "fmi2SetupExperiment": fn(Component, c_int, f64, f64, c_int, f64) -> Status;
    enter_initialization_mode: "fmi2EnterInitializationMode": fn(Component) -> Status;
    exit_initialization_mode: "fmi2ExitInitializationMode": fn(Component) -> Status;
    terminate: "fmi2Terminate": fn(Component) -> Status;
    get_real: "fmi2GetReal": fn(Component, *const c_uint, usize, *mut f64) -> Status;
    set_real: "fmi2SetReal": fn(Component, *const c_uint, usize, *const f64) -> Status;
    get_integer: "fmi2GetInteger": fn(Component, *const c_uint, usize, *mut c_int) -> Status;
    set_integer: "fmi2SetInteger": fn(Component, *const c_uint, usize, *const c_int) -> Status;
    get_boolean: "fmi2GetBoolean": fn(Component, *const c_uint, usize, *mut c_int) -> Status;
    set_boolean: "fmi2SetBoolean": fn(Component, *const c_uint, usize, *const c_int) -> Status;
    set_string: "fmi2SetString": fn(Component, *const c_uint, usize, *const *const c_char) -> Status;
    get_fmu_state: "fmi2GetFMUstate": fn(Component, *mut FmuStatePtr) -> Status;
    set_fmu_state: "fmi2SetFMUstate": fn(Component, FmuStatePtr) -> Status;
    free_fmu_state: "fmi2FreeFMUstate": fn(Component, *mut FmuStatePtr) -> Status;
    set_real_input_derivatives: "fmi2SetRealInputDerivatives": fn(Component, *const c_uint, usize, *const c_int, *const f64) -> Status;
    get_real_output_derivatives: "fmi2GetRealOutputDerivatives": fn(Component, *const c_uint, usize, *const c_int, *mut f64) -> Status;
    do_step: "fmi2DoStep": fn(Component, f64, f64, c_int) -> Status;
}

/// An unpacked, loaded FMU. The temporary folder is removed on drop, after
/// the last instance (instances hold the library, not the folder: a loaded
/// `.so` stays mapped after its file is deleted).
pub struct Fmu {
    pub md: ModelDescription,
    fns: Arc<Fns>,
    dir: tempfile::TempDir,
    /// The `.fmu` file it came from.
    pub path: PathBuf,
}

impl std::fmt::Debug for Fmu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fmu")
            .field("path", &self.path)
            .field("model", &self.md.model_name)
            .finish()
    }
}

/// `file://` URI of an absolute path, percent-encoding everything but
/// unreserved characters and `/` (RFC 3986).
fn file_uri(p: &Path) -> String {
    let mut s = String::from("file://");
    for b in p.to_string_lossy().bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            s.push(b as char);
        } else {
            s.push_str(&format!("%{b:02X}"));
        }
    }
    s
}

impl Fmu {
    /// Unpack `path` into a fresh temporary folder, parse and check the model
    /// description (FMI 2.0, Co-Simulation), load the linux64 binary and check
    /// that it reports version 2.0.
    pub fn load(path: &Path) -> Result<Self> {
        let dir = tempfile::Builder::new()
            .prefix("host-fmu-")
            .tempdir()
            .map_err(|source| FmuError::Open {
                path: path.into(),
                source,
            })?;
        unpack(path, dir.path())?;
        let mdp = dir.path().join("modelDescription.xml");
        let mut text = String::new();
        File::open(&mdp)
            .and_then(|mut f| f.read_to_string(&mut text))
            .map_err(|_| FmuError::NoModelDescription { path: path.into() })?;
        let md = ModelDescription::parse(&text)?;
        let id = &md.co_simulation.model_identifier;
        let so = dir
            .path()
            .join("binaries")
            .join("linux64")
            .join(format!("{id}.so"));
        if !so.is_file() {
            return Err(FmuError::MissingBinary {
                model: md.model_name.clone(),
                identifier: id.clone(),
                path: PathBuf::from(format!("binaries/linux64/{id}.so")),
            });
        }
        let fns = Fns::load(&so)?;
        // SAFETY: fmi2GetVersion takes no arguments and returns a static C string.
        let v = unsafe { (fns.get_version)() };
        let found = if v.is_null() {
            String::new()
        } else {
            unsafe { CStr::from_ptr(v) }.to_string_lossy().into_owned()
        };
        if found != "2.0" {
            return Err(FmuError::BinaryVersion { path: so, found });
        }
        Ok(Fmu {
            md,
            fns: Arc::new(fns),
            dir,
            path: path.into(),
        })
    }

    /// The unpacked folder (removed on drop).
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// Create an instance (`fmi2Instantiate` for Co-Simulation with this
    /// FMU's GUID and resource URI). `echo_log`: copy warnings and errors
    /// of the FMU to stderr as they arrive.
    pub fn instantiate(&self, name: &str, echo_log: bool) -> Result<Instance> {
        let sink = Box::new(LogSink {
            records: Mutex::new(VecDeque::with_capacity(LOG_KEEP)),
            echo: echo_log,
        });
        let cb = Box::new(CallbackFunctions {
            logger: host_fmi2_logger,
            allocate_memory: alloc_memory,
            free_memory,
            step_finished: None,
            component_environment: &*sink as *const LogSink as *mut c_void,
        });
        let cname =
            CString::new(name).unwrap_or_else(|_| CString::new("instance").expect("no NUL"));
        let guid = CString::new(self.md.guid.as_str()).unwrap_or_default();
        let res = CString::new(file_uri(&self.dir.path().join("resources"))).unwrap_or_default();
        // SAFETY: all strings are NUL-terminated and outlive the call; the
        // callback struct and the sink live (boxed) as long as the instance.
        let comp = unsafe {
            (self.fns.instantiate)(cname.as_ptr(), 1, guid.as_ptr(), res.as_ptr(), &*cb, 0, 0)
        };
        if comp.is_null() {
            return Err(FmuError::Instantiate {
                instance: name.into(),
                model: self.md.model_name.clone(),
                guid: self.md.guid.clone(),
                log: sink.summary(),
            });
        }
        Ok(Instance {
            fns: self.fns.clone(),
            comp,
            _cb: cb,
            sink,
            name: name.into(),
            saved: std::ptr::null_mut(),
            time_s: 0.0,
        })
    }
}

/// One FMU instance; freed (with its saved state) on drop.
pub struct Instance {
    fns: Arc<Fns>,
    comp: Component,
    _cb: Box<CallbackFunctions>,
    sink: Box<LogSink>,
    pub name: String,
    saved: FmuStatePtr,
    /// Start of the last step attempted (for error messages) [s].
    time_s: f64,
}

impl Instance {
    #[inline]
    fn check(&self, function: &'static str, st: Status) -> Result<()> {
        if st == 0 || st == 1 {
            Ok(())
        } else {
            Err(self.status_error(function, st))
        }
    }

    #[cold]
    fn status_error(&self, function: &'static str, st: Status) -> FmuError {
        FmuError::Status {
            function,
            instance: self.name.clone(),
            status: status_name(st),
            time_s: self.time_s,
            log: self.sink.summary(),
        }
    }

    /// The recent log messages of this instance (at most 64).
    pub fn log(&self) -> Vec<LogRecord> {
        self.sink
            .records
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .cloned()
            .collect()
    }

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(
        &mut self,
        start_s: f64,
        stop_s: Option<f64>,
        tolerance: Option<f64>,
    ) -> Result<()> {
        self.time_s = start_s;
        // SAFETY: valid component.
        let st = unsafe {
            (self.fns.setup_experiment)(
                self.comp,
                tolerance.is_some() as c_int,
                tolerance.unwrap_or(0.0),
                start_s,
                stop_s.is_some() as c_int,
                stop_s.unwrap_or(0.0),
            )
        };
        self.check("fmi2SetupExperiment", st)
    }

    pub fn enter_initialization_mode(&mut self) -> Result<()> {
        // SAFETY: valid component.
        let st = unsafe { (self.fns.enter_initialization_mode)(self.comp) };
        self.check("fmi2EnterInitializationMode", st)
    }

    pub fn exit_initialization_mode(&mut self) -> Result<()> {
        // SAFETY: valid component.
        let st = unsafe { (self.fns.exit_initialization_mode)(self.comp) };
        self.check("fmi2ExitInitializationMode", st)
    }

    pub fn terminate(&mut self) -> Result<()> {
        // SAFETY: valid component.
        let st = unsafe { (self.fns.terminate)(self.comp) };
        self.check("fmi2Terminate", st)
    }

    /// `fmi2GetReal` into `values` (same length as `vrs`).
    #[inline]
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: both slices have `vrs.len()` elements.
        let st =
            unsafe { (self.fns.get_real)(self.comp, vrs.as_ptr(), vrs.len(), values.as_mut_ptr()) };
        self.check("fmi2GetReal", st)
    }

    #[inline]
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: both slices have `vrs.len()` elements.
        let st =
            unsafe { (self.fns.set_real)(self.comp, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        self.check("fmi2SetReal", st)
    }

    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: both slices have `vrs.len()` elements.
        let st = unsafe {
            (self.fns.get_integer)(self.comp, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        };
        self.check("fmi2GetInteger", st)
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: both slices have `vrs.len()` elements.
        let st =
            unsafe { (self.fns.set_integer)(self.comp, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        self.check("fmi2SetInteger", st)
    }

    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [bool]) -> Result<()> {
        let mut raw = vec![0 as c_int; vrs.len()];
        // SAFETY: both buffers have `vrs.len()` elements.
        let st =
            unsafe { (self.fns.get_boolean)(self.comp, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr()) };
        self.check("fmi2GetBoolean", st)?;
        for (v, r) in values.iter_mut().zip(raw) {
            *v = r != 0;
        }
        Ok(())
    }

    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        let raw: Vec<c_int> = values.iter().map(|&b| b as c_int).collect();
        // SAFETY: both buffers have `vrs.len()` elements.
        let st =
            unsafe { (self.fns.set_boolean)(self.comp, vrs.as_ptr(), vrs.len(), raw.as_ptr()) };
        self.check("fmi2SetBoolean", st)
    }

    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        let owned: Vec<CString> = values
            .iter()
            .map(|s| CString::new(s.replace('\0', "")).expect("no NUL"))
            .collect();
        let ptrs: Vec<*const c_char> = owned.iter().map(|s| s.as_ptr()).collect();
        // SAFETY: both buffers have `vrs.len()` elements; the strings outlive the call.
        let st =
            unsafe { (self.fns.set_string)(self.comp, vrs.as_ptr(), vrs.len(), ptrs.as_ptr()) };
        self.check("fmi2SetString", st)
    }

    /// `fmi2SetRealInputDerivatives` of the given orders.
    #[inline]
    pub fn set_real_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> Result<()> {
        assert!(vrs.len() == orders.len() && vrs.len() == values.len());
        // SAFETY: all slices have `vrs.len()` elements.
        let st = unsafe {
            (self.fns.set_real_input_derivatives)(
                self.comp,
                vrs.as_ptr(),
                vrs.len(),
                orders.as_ptr(),
                values.as_ptr(),
            )
        };
        self.check("fmi2SetRealInputDerivatives", st)
    }

    /// `fmi2GetRealOutputDerivatives`.
    pub fn get_real_output_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &mut [f64],
    ) -> Result<()> {
        assert!(vrs.len() == orders.len() && vrs.len() == values.len());
        // SAFETY: all slices have `vrs.len()` elements.
        let st = unsafe {
            (self.fns.get_real_output_derivatives)(
                self.comp,
                vrs.as_ptr(),
                vrs.len(),
                orders.as_ptr(),
                values.as_mut_ptr(),
            )
        };
        self.check("fmi2GetRealOutputDerivatives", st)
    }

    /// `fmi2DoStep(t, h, noSetFMUStatePriorToCurrentPoint = false)`.
    #[inline]
    pub fn do_step(&mut self, t_s: f64, h_s: f64) -> Result<()> {
        self.time_s = t_s;
        // SAFETY: valid component.
        let st = unsafe { (self.fns.do_step)(self.comp, t_s, h_s, 0) };
        self.check("fmi2DoStep", st)
    }

    /// Save the current state into this instance's slot (`fmi2GetFMUstate`,
    /// reusing the slot's memory after the first call).
    pub fn save_state(&mut self) -> Result<()> {
        // SAFETY: `saved` is null or a state of this instance.
        let st = unsafe { (self.fns.get_fmu_state)(self.comp, &mut self.saved) };
        self.check("fmi2GetFMUstate", st)
    }

    /// Roll back to the state saved by [`save_state`](Self::save_state).
    pub fn restore_state(&mut self) -> Result<()> {
        if self.saved.is_null() {
            return Err(FmuError::Status {
                function: "fmi2SetFMUstate",
                instance: self.name.clone(),
                status: "not called: no state saved",
                time_s: self.time_s,
                log: String::new(),
            });
        }
        // SAFETY: `saved` is a state of this instance.
        let st = unsafe { (self.fns.set_fmu_state)(self.comp, self.saved) };
        self.check("fmi2SetFMUstate", st)
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: `comp` is a live instance; `saved` is null or its state.
        unsafe {
            if !self.saved.is_null() {
                (self.fns.free_fmu_state)(self.comp, &mut self.saved);
            }
            (self.fns.free_instance)(self.comp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="osc" guid="{g}">
  <CoSimulation modelIdentifier="osc" canHandleVariableCommunicationStepSize="true"
      canInterpolateInputs="true" maxOutputDerivativeOrder="1" canGetAndSetFMUstate="true"/>
  <DefaultExperiment startTime="0" stopTime="2.5" stepSize="1e-4"/>
  <ModelVariables>
    <ScalarVariable name="m" valueReference="0" causality="parameter" variability="fixed">
      <Real start="1" unit="kg"/>
    </ScalarVariable>
    <ScalarVariable name="F" valueReference="3" causality="input"><Real start="0" unit="N"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="4" causality="output"><Real unit="m"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="3" dependencies=""/></Outputs>
  </ModelStructure>
</fmiModelDescription>
"#;

    #[test]
    fn parses_variables_capabilities_and_structure() {
        let md = ModelDescription::parse(MD).unwrap();
        assert_eq!(md.guid, "{g}");
        assert!(
            md.co_simulation.can_interpolate_inputs && md.co_simulation.can_get_and_set_fmu_state
        );
        assert_eq!(md.co_simulation.max_output_derivative_order, 1);
        assert_eq!(md.default_experiment.stop_time, Some(2.5));
        assert_eq!(md.variables.len(), 3);
        let f = md.variable("F").unwrap();
        assert_eq!(
            (f.value_reference, f.causality, f.ty, f.line),
            (3, Causality::Input, VarType::Real, 10)
        );
        assert_eq!(md.variable("m").unwrap().unit.as_deref(), Some("kg"));
        assert_eq!(
            md.variable("x").unwrap().variability,
            Variability::Continuous
        );
        assert_eq!(md.real_vr("x", &[Causality::Output]).unwrap(), 4);
        assert!(matches!(
            md.real_vr("x", &[Causality::Input]),
            Err(FmuError::WrongVariable { .. })
        ));
        assert!(!md.output_depends_on(2, 1));
        assert!(matches!(
            md.variable("nope"),
            Err(FmuError::UnknownVariable { .. })
        ));
    }

    #[test]
    fn malformed_xml_reports_the_line() {
        let bad = MD.replace("<Real unit=\"m\"/>", "<Real unit=\"m\">");
        match ModelDescription::parse(&bad) {
            Err(FmuError::Xml { line, message }) => assert!(
                line == 11 && message.contains("</Real>"),
                "line {line}: {message}"
            ),
            other => panic!("{other:?}"),
        }
        let bad = MD.replace("valueReference=\"3\"", "valueReference=\"-3\"");
        match ModelDescription::parse(&bad) {
            Err(FmuError::Xml { line, message }) => assert!(
                line == 10 && message.contains("valueReference"),
                "{line} {message}"
            ),
            other => panic!("{other:?}"),
        }
        let bad = MD.replace("dependencies=\"\"", "dependencies=\"7\"");
        assert!(matches!(
            ModelDescription::parse(&bad),
            Err(FmuError::Xml { line: 14, .. })
        ));
    }

    #[test]
    fn version_and_cosimulation_are_required() {
        let v1 = MD.replace("fmiVersion=\"2.0\"", "fmiVersion=\"1.0\"");
        let e = ModelDescription::parse(&v1).unwrap_err();
        assert!(
            matches!(&e, FmuError::Version { found } if found == "1.0"),
            "{e}"
        );
        let v3 = MD.replace("fmiVersion=\"2.0\"", "fmiVersion=\"3.0\"");
        assert!(matches!(
            ModelDescription::parse(&v3),
            Err(FmuError::Version { .. })
        ));
        let me = MD.replace("<CoSimulation", "<ModelExchange");
        let e = ModelDescription::parse(&me).unwrap_err();
        assert!(
            matches!(e, FmuError::NoCoSimulation { .. }) && e.to_string().contains("Co-Simulation"),
            "{e}"
        );
    }

    #[test]
    fn file_uri_encodes() {
        assert_eq!(
            file_uri(Path::new("/tmp/a b/r%s")),
            "file:///tmp/a%20b/r%25s"
        );
    }
}
