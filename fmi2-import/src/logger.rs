//! The FMU log: for FMI 2.0 the C shim `csrc/logger.c` (the FMI 2.0 logger
//! is C-variadic, which stable Rust cannot define) formats each message and
//! hands it to [`host_fmi2_log_message`]; FMI 3.0 calls
//! [`host_fmi3_log_message`] with the message formatted. Both keep the
//! instance's recent messages.
use std::collections::VecDeque;
use std::ffi::{c_char, c_int, c_void, CStr};
use std::sync::Mutex;

use fmi2::types::{ComponentEnvironment, FmiString, Status};

extern "C" {
    /// The C shim (`csrc/logger.c`): formats the message and calls
    /// [`host_fmi2_log_message`]. Declared with the standard's
    /// [`fmi2::types::CallbackLogger`] signature (the status arrives as an
    /// `int` in C and is passed on as such).
    pub(crate) fn host_fmi2_logger(
        env: ComponentEnvironment,
        instance: FmiString,
        status: Status,
        category: FmiString,
        fmt: FmiString,
        ...
    );
}

pub(crate) unsafe extern "C" fn alloc_memory(n: usize, size: usize) -> *mut c_void {
    extern "C" {
        fn calloc(n: usize, size: usize) -> *mut c_void;
    }
    calloc(n, size)
}

pub(crate) unsafe extern "C" fn free_memory(p: *mut c_void) {
    extern "C" {
        fn free(p: *mut c_void);
    }
    free(p)
}

/// A C string from the FMU as an owned string (empty for null).
///
/// # Safety
/// `p` is null or NUL-terminated.
unsafe fn c_string(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        CStr::from_ptr(p).to_string_lossy().into_owned()
    }
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
    let (instance, category, message) = (c_string(instance), c_string(category), c_string(message));
    // Never unwind into C.
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let rec = LogRecord {
            status: status_name("fmi2", status),
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

/// The FMI 3.0 logger (`fmi3LogMessageCallback`, not variadic): the
/// message arrives formatted, the instance is the sink's.
///
/// # Safety
/// `env` is the `LogSink` the instance was created with (or null); the strings
/// are NUL-terminated or null.
pub(crate) unsafe extern "C" fn host_fmi3_log_message(
    env: *mut c_void,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let (category, message) = (c_string(category), c_string(message));
    // Never unwind into C.
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let rec = LogRecord {
            status: status_name("fmi3", status),
            category,
            message,
        };
        if env.is_null() {
            eprintln!("[fmu] {}: {}", rec.status, rec.message);
        } else {
            let sink = &*(env as *const LogSink);
            sink.push(&sink.instance, rec);
        }
    }));
}

/// The standard's name of a status received as a plain `int`, for FMI
/// version prefix `"fmi2"` or `"fmi3"` (the two enumerations agree on
/// 0..=4; `fmi2Pending` has no FMI 3.0 counterpart).
pub(crate) fn status_name(prefix: &str, s: c_int) -> &'static str {
    let name = Status::from_raw(s).map_or("unknown status", Status::name);
    match (prefix, s) {
        ("fmi3", 0) => "fmi3OK",
        ("fmi3", 1) => "fmi3Warning",
        ("fmi3", 2) => "fmi3Discard",
        ("fmi3", 3) => "fmi3Error",
        ("fmi3", 4) => "fmi3Fatal",
        ("fmi3", _) => "unknown status",
        _ => name,
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
pub(crate) struct LogSink {
    pub(crate) records: Mutex<VecDeque<LogRecord>>,
    pub(crate) echo: bool,
    /// The instance name (FMI 3.0 messages do not carry it).
    pub(crate) instance: String,
}

pub(crate) const LOG_KEEP: usize = 64;

impl LogSink {
    pub(crate) fn push(&self, instance: &str, rec: LogRecord) {
        if self.echo && !rec.status.ends_with("OK") {
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

    pub(crate) fn summary(&self) -> String {
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
