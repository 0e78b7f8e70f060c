//! The safe importer: [`Fmu`] (unpacked archive, parsed model description,
//! loaded library) and [`Instance`] (one `fmi2Component`, freed in `Drop`).
use std::collections::VecDeque;
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use fmi2::types::{CallbackFunctions, Component, FmuState};
use fmi2::ModelDescription;

use crate::archive::{unpack_with, ImportLimits};
use crate::error::{FmuError, Result};
use crate::library::{Fns, RawStatus};
use crate::logger::{
    alloc_memory, free_memory, host_fmi2_logger, status_name, LogRecord, LogSink, LOG_KEEP,
};

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
    /// that it reports version 2.0; within the default [`ImportLimits`].
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_with(path, &ImportLimits::default())
    }

    /// [`Self::load`] within `limits`. Before the binary is loaded: no
    /// duplicate value reference, a plain-file-name `modelIdentifier`, the
    /// binary inside the unpacked folder and a well-formed ELF for this host.
    pub fn load_with(path: &Path, limits: &ImportLimits) -> Result<Self> {
        let dir = tempfile::Builder::new()
            .prefix("host-fmu-")
            .tempdir()
            .map_err(|source| FmuError::Open {
                path: path.into(),
                source,
            })?;
        unpack_with(path, dir.path(), limits)?;
        let mdp = dir.path().join("modelDescription.xml");
        if !mdp.exists() {
            return Err(FmuError::NoModelDescription { path: path.into() });
        }
        let text = fmi2::read_regular_to_string(&mdp, limits.max_unpacked_bytes)
            .map_err(|source| FmuError::File { source })?;
        let md = ModelDescription::parse(&text)?;
        if let Some(p) = md.duplicate_value_references().into_iter().next() {
            return Err(FmuError::Schema(fmi2::SchemaError::Xml {
                line: p.line.unwrap_or(0),
                message: format!("{}; each variable needs its own", p.message),
            }));
        }
        // every declared identifier names a binary of this archive (the host
        // co-simulates, but a tool may load the Model Exchange one)
        let plain = |id: &str| {
            !id.is_empty()
                && !id.contains(['/', '\\', '\0'])
                && id != "."
                && id != ".."
                && !id.contains("..")
        };
        let declared = std::iter::once(&md.co_simulation.model_identifier)
            .chain(md.model_exchange.as_ref().map(|me| &me.model_identifier));
        for id in declared {
            if !plain(id) {
                return Err(FmuError::BadIdentifier {
                    model: md.model_name.clone(),
                    identifier: id.clone(),
                });
            }
        }
        let id = &md.co_simulation.model_identifier;
        let rel = PathBuf::from(format!("binaries/linux64/{id}.so"));
        let so = dir.path().join(&rel);
        if !so.is_file() {
            return Err(FmuError::MissingBinary {
                model: md.model_name.clone(),
                identifier: id.clone(),
                path: rel,
            });
        }
        let outside = || FmuError::BinaryOutside {
            model: md.model_name.clone(),
            path: rel.clone(),
        };
        let root = dir.path().canonicalize().map_err(|_| outside())?;
        let so = so.canonicalize().map_err(|_| outside())?;
        if !so.starts_with(&root) {
            return Err(outside());
        }
        let bytes = fmi2::read_regular(&so, limits.max_unpacked_bytes)
            .map_err(|source| FmuError::File { source })?;
        crate::elf::check(&bytes).map_err(|reason| FmuError::BadBinary {
            model: md.model_name.clone(),
            path: rel.clone(),
            reason,
        })?;
        drop(bytes);
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
            logger: Some(host_fmi2_logger),
            allocate_memory: Some(alloc_memory),
            free_memory: Some(free_memory),
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
    saved: FmuState,
    /// Start of the last step attempted (for error messages) [s].
    time_s: f64,
}

impl Instance {
    #[inline]
    fn check(&self, function: &'static str, st: RawStatus) -> Result<()> {
        if st == 0 || st == 1 {
            Ok(())
        } else {
            Err(self.status_error(function, st))
        }
    }

    #[cold]
    fn status_error(&self, function: &'static str, st: RawStatus) -> FmuError {
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

    #[test]
    fn file_uri_encodes() {
        assert_eq!(
            file_uri(Path::new("/tmp/a b/r%s")),
            "file:///tmp/a%20b/r%25s"
        );
    }
}
