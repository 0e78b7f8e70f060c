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
use crate::library::{Fns, Fns3, RawStatus};
use crate::logger::{
    alloc_memory, free_memory, host_fmi2_logger, host_fmi3_log_message, status_name, LogRecord,
    LogSink, LOG_KEEP,
};

/// The loaded library's function table, by FMI version.
#[derive(Clone)]
enum Api {
    V2(Arc<Fns>),
    V3(Arc<Fns3>),
}

impl Api {
    fn version(&self) -> Version {
        match self {
            Api::V2(_) => Version::Fmi2,
            Api::V3(_) => Version::Fmi3,
        }
    }
}

/// The FMI version of an imported FMU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Version {
    Fmi2,
    Fmi3,
}

impl Version {
    /// `"2.0"` / `"3.0"`, as `fmi*GetVersion` returns it.
    pub fn name(self) -> &'static str {
        match self {
            Version::Fmi2 => "2.0",
            Version::Fmi3 => "3.0",
        }
    }

    /// The binaries folder of this platform (`binaries/<platform>/`).
    fn platform(self) -> String {
        match self {
            Version::Fmi2 => "linux64".into(),
            Version::Fmi3 => format!("{}-linux", std::env::consts::ARCH),
        }
    }

    /// The function-name prefix (`fmi2`, `fmi3`) for messages.
    fn prefix(self) -> &'static str {
        match self {
            Version::Fmi2 => "fmi2",
            Version::Fmi3 => "fmi3",
        }
    }
}

/// An unpacked, loaded FMU. The temporary folder is removed on drop, after
/// the last instance (instances hold the library, not the folder: a loaded
/// `.so` stays mapped after its file is deleted).
pub struct Fmu {
    pub md: ModelDescription,
    api: Api,
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
    /// description (FMI 2.0 or 3.0, Co-Simulation), load the binary of this
    /// platform (`binaries/linux64/` for FMI 2.0, `binaries/x86_64-linux/`
    /// for FMI 3.0) and check that it reports the description's version;
    /// within the default [`ImportLimits`].
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
        let version = if md.fmi_version.starts_with("3.") {
            Version::Fmi3
        } else {
            Version::Fmi2
        };
        let id = &md.co_simulation.model_identifier;
        let rel = PathBuf::from(format!("binaries/{}/{id}.so", version.platform()));
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
        // SAFETY (both): fmi*GetVersion takes no arguments and returns a static C string.
        let (api, v) = match version {
            Version::Fmi2 => {
                let fns = Fns::load(&so)?;
                let v = unsafe { (fns.get_version)() };
                (Api::V2(Arc::new(fns)), v)
            }
            Version::Fmi3 => {
                let fns = Fns3::load(&so)?;
                let v = unsafe { (fns.get_version)() };
                (Api::V3(Arc::new(fns)), v)
            }
        };
        let found = if v.is_null() {
            String::new()
        } else {
            unsafe { CStr::from_ptr(v) }.to_string_lossy().into_owned()
        };
        if found != version.name() {
            return Err(FmuError::BinaryVersion {
                path: so,
                found,
                expected: version.name(),
            });
        }
        Ok(Fmu {
            md,
            api,
            dir,
            path: path.into(),
        })
    }

    /// The FMI version of this FMU.
    pub fn version(&self) -> Version {
        self.api.version()
    }

    /// The unpacked folder (removed on drop).
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// Create an instance (`fmi2Instantiate` for Co-Simulation, or
    /// `fmi3InstantiateCoSimulation` without event mode, early return or
    /// intermediate update) with this FMU's GUID / instantiation token and
    /// resource location. `echo_log`: copy warnings and errors of the FMU to
    /// stderr as they arrive.
    pub fn instantiate(&self, name: &str, echo_log: bool) -> Result<Instance> {
        let sink = Box::new(LogSink {
            records: Mutex::new(VecDeque::with_capacity(LOG_KEEP)),
            echo: echo_log,
            instance: name.to_string(),
        });
        let env = &*sink as *const LogSink as *mut c_void;
        let cname =
            CString::new(name).unwrap_or_else(|_| CString::new("instance").expect("no NUL"));
        let guid = CString::new(self.md.guid.as_str()).unwrap_or_default();
        let resources = self.dir.path().join("resources");
        let (comp, cb) = match &self.api {
            Api::V2(fns) => {
                let cb = Box::new(CallbackFunctions {
                    logger: Some(host_fmi2_logger),
                    allocate_memory: Some(alloc_memory),
                    free_memory: Some(free_memory),
                    step_finished: None,
                    component_environment: env,
                });
                let res = CString::new(file_uri(&resources)).unwrap_or_default();
                // SAFETY: all strings are NUL-terminated and outlive the call; the
                // callback struct and the sink live (boxed) as long as the instance.
                let comp = unsafe {
                    (fns.instantiate)(cname.as_ptr(), 1, guid.as_ptr(), res.as_ptr(), &*cb, 0, 0)
                };
                (comp, Some(cb))
            }
            Api::V3(fns) => {
                // FMI 3.0: a native path with a trailing separator
                let res = CString::new(format!("{}/", resources.display())).unwrap_or_default();
                // SAFETY: as above; no required intermediate variables (null, 0),
                // no intermediate-update callback.
                let comp = unsafe {
                    (fns.instantiate)(
                        cname.as_ptr(),
                        guid.as_ptr(),
                        res.as_ptr(),
                        false,
                        false,
                        false,
                        false,
                        std::ptr::null(),
                        0,
                        env,
                        Some(host_fmi3_log_message),
                        std::ptr::null(),
                    )
                };
                (comp, None)
            }
        };
        if comp.is_null() {
            return Err(FmuError::Instantiate {
                function: if self.version() == Version::Fmi3 {
                    "fmi3InstantiateCoSimulation"
                } else {
                    "fmi2Instantiate"
                },
                instance: name.into(),
                model: self.md.model_name.clone(),
                guid: self.md.guid.clone(),
                log: sink.summary(),
            });
        }
        Ok(Instance {
            api: self.api.clone(),
            comp,
            _cb: cb,
            sink,
            name: name.into(),
            saved: std::ptr::null_mut(),
            time_s: 0.0,
            experiment: Experiment::default(),
        })
    }
}

/// The start/stop time and tolerance of `fmi2SetupExperiment`, which FMI 3.0
/// passes to `fmi3EnterInitializationMode` instead.
#[derive(Debug, Clone, Copy, Default)]
struct Experiment {
    start_s: f64,
    stop_s: Option<f64>,
    tolerance: Option<f64>,
}

/// One FMU instance; freed (with its saved state) on drop. The same calls for
/// FMI 2.0 and 3.0: `Real` is `Float64`, `Integer` is `Int32` in FMI 3.0.
pub struct Instance {
    api: Api,
    comp: Component,
    _cb: Option<Box<CallbackFunctions>>,
    sink: Box<LogSink>,
    pub name: String,
    saved: FmuState,
    /// Start of the last step attempted (for error messages) [s].
    time_s: f64,
    experiment: Experiment,
}

/// One call of either version: `$v2` with the FMI 2.0 table, `$v3` with the
/// FMI 3.0 one, the status checked under the function's name.
macro_rules! call {
    ($self:ident, $f2:literal, |$fns2:ident| $v2:expr, $f3:literal, |$fns3:ident| $v3:expr) => {{
        let (function, st) = match &$self.api {
            // SAFETY: valid instance; the arguments are checked by the caller
            Api::V2($fns2) => ($f2, unsafe { $v2 }),
            Api::V3($fns3) => ($f3, unsafe { $v3 }),
        };
        $self.check(function, st)
    }};
}

impl Instance {
    #[inline]
    fn check(&self, function: &'static str, st: RawStatus) -> Result<()> {
        if st == 0 || st == 1 {
            Ok(())
        } else {
            Err(self.status_error(function, status_name(self.api.version().prefix(), st)))
        }
    }

    #[cold]
    fn status_error(&self, function: &'static str, status: &'static str) -> FmuError {
        FmuError::Status {
            function,
            instance: self.name.clone(),
            status,
            time_s: self.time_s,
            log: self.sink.summary(),
        }
    }

    /// The FMI version of this instance's FMU.
    pub fn version(&self) -> Version {
        self.api.version()
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

    /// `fmi2SetupExperiment`; in FMI 3.0 the values are kept for
    /// `fmi3EnterInitializationMode`.
    pub fn setup_experiment(
        &mut self,
        start_s: f64,
        stop_s: Option<f64>,
        tolerance: Option<f64>,
    ) -> Result<()> {
        self.time_s = start_s;
        self.experiment = Experiment {
            start_s,
            stop_s,
            tolerance,
        };
        match &self.api {
            Api::V3(_) => Ok(()),
            Api::V2(fns) => {
                // SAFETY: valid component.
                let st = unsafe {
                    (fns.setup_experiment)(
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
        }
    }

    pub fn enter_initialization_mode(&mut self) -> Result<()> {
        let e = self.experiment;
        call!(
            self,
            "fmi2EnterInitializationMode",
            |f| (f.enter_initialization_mode)(self.comp),
            "fmi3EnterInitializationMode",
            |f| (f.enter_initialization_mode)(
                self.comp,
                e.tolerance.is_some(),
                e.tolerance.unwrap_or(0.0),
                e.start_s,
                e.stop_s.is_some(),
                e.stop_s.unwrap_or(0.0)
            )
        )
    }

    pub fn exit_initialization_mode(&mut self) -> Result<()> {
        call!(
            self,
            "fmi2ExitInitializationMode",
            |f| (f.exit_initialization_mode)(self.comp),
            "fmi3ExitInitializationMode",
            |f| (f.exit_initialization_mode)(self.comp)
        )
    }

    pub fn terminate(&mut self) -> Result<()> {
        call!(
            self,
            "fmi2Terminate",
            |f| (f.terminate)(self.comp),
            "fmi3Terminate",
            |f| (f.terminate)(self.comp)
        )
    }

    /// `fmi2GetReal` / `fmi3GetFloat64` into `values` (same length as `vrs`).
    #[inline]
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        let n = vrs.len();
        // both slices have `n` elements
        call!(
            self,
            "fmi2GetReal",
            |f| (f.get_real)(self.comp, vrs.as_ptr(), n, values.as_mut_ptr()),
            "fmi3GetFloat64",
            |f| (f.get_float64)(self.comp, vrs.as_ptr(), n, values.as_mut_ptr(), n)
        )
    }

    /// `fmi2SetReal` / `fmi3SetFloat64`.
    #[inline]
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        let n = vrs.len();
        call!(
            self,
            "fmi2SetReal",
            |f| (f.set_real)(self.comp, vrs.as_ptr(), n, values.as_ptr()),
            "fmi3SetFloat64",
            |f| (f.set_float64)(self.comp, vrs.as_ptr(), n, values.as_ptr(), n)
        )
    }

    /// `fmi2GetInteger` / `fmi3GetInt32`.
    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        let n = vrs.len();
        call!(
            self,
            "fmi2GetInteger",
            |f| (f.get_integer)(self.comp, vrs.as_ptr(), n, values.as_mut_ptr()),
            "fmi3GetInt32",
            |f| (f.get_int32)(self.comp, vrs.as_ptr(), n, values.as_mut_ptr(), n)
        )
    }

    /// `fmi2SetInteger` / `fmi3SetInt32`.
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        let n = vrs.len();
        call!(
            self,
            "fmi2SetInteger",
            |f| (f.set_integer)(self.comp, vrs.as_ptr(), n, values.as_ptr()),
            "fmi3SetInt32",
            |f| (f.set_int32)(self.comp, vrs.as_ptr(), n, values.as_ptr(), n)
        )
    }

    /// `fmi2GetBoolean` (`int`) / `fmi3GetBoolean` (C `bool`).
    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [bool]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        let n = vrs.len();
        let mut raw = vec![0 as c_int; n];
        call!(
            self,
            "fmi2GetBoolean",
            |f| (f.get_boolean)(self.comp, vrs.as_ptr(), n, raw.as_mut_ptr()),
            "fmi3GetBoolean",
            |f| (f.get_boolean)(self.comp, vrs.as_ptr(), n, values.as_mut_ptr(), n)
        )?;
        if let Api::V2(_) = self.api {
            for (v, r) in values.iter_mut().zip(raw) {
                *v = r != 0;
            }
        }
        Ok(())
    }

    /// `fmi2SetBoolean` / `fmi3SetBoolean`.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        let n = vrs.len();
        let raw: Vec<c_int> = values.iter().map(|&b| b as c_int).collect();
        call!(
            self,
            "fmi2SetBoolean",
            |f| (f.set_boolean)(self.comp, vrs.as_ptr(), n, raw.as_ptr()),
            "fmi3SetBoolean",
            |f| (f.set_boolean)(self.comp, vrs.as_ptr(), n, values.as_ptr(), n)
        )
    }

    /// `fmi2SetString` / `fmi3SetString` (a NUL inside a string is dropped).
    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<()> {
        assert_eq!(vrs.len(), values.len());
        let n = vrs.len();
        let owned: Vec<CString> = values
            .iter()
            .map(|s| CString::new(s.replace('\0', "")).expect("no NUL"))
            .collect();
        let ptrs: Vec<*const c_char> = owned.iter().map(|s| s.as_ptr()).collect();
        // the strings outlive the call
        call!(
            self,
            "fmi2SetString",
            |f| (f.set_string)(self.comp, vrs.as_ptr(), n, ptrs.as_ptr()),
            "fmi3SetString",
            |f| (f.set_string)(self.comp, vrs.as_ptr(), n, ptrs.as_ptr(), n)
        )
    }

    /// `fmi2SetRealInputDerivatives` of the given orders. FMI 3.0 has no
    /// input derivatives (its descriptions read `canInterpolateInputs =
    /// false`, so a master does not call this): an error.
    #[inline]
    pub fn set_real_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> Result<()> {
        assert!(vrs.len() == orders.len() && vrs.len() == values.len());
        match &self.api {
            Api::V3(_) => Err(self.status_error(
                "fmi2SetRealInputDerivatives",
                "not called: FMI 3.0 has no input derivatives",
            )),
            Api::V2(fns) => {
                // SAFETY: all slices have `vrs.len()` elements.
                let st = unsafe {
                    (fns.set_real_input_derivatives)(
                        self.comp,
                        vrs.as_ptr(),
                        vrs.len(),
                        orders.as_ptr(),
                        values.as_ptr(),
                    )
                };
                self.check("fmi2SetRealInputDerivatives", st)
            }
        }
    }

    /// `fmi2GetRealOutputDerivatives` / `fmi3GetOutputDerivatives`.
    pub fn get_real_output_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &mut [f64],
    ) -> Result<()> {
        assert!(vrs.len() == orders.len() && vrs.len() == values.len());
        let n = vrs.len();
        call!(
            self,
            "fmi2GetRealOutputDerivatives",
            |f| (f.get_real_output_derivatives)(
                self.comp,
                vrs.as_ptr(),
                n,
                orders.as_ptr(),
                values.as_mut_ptr()
            ),
            "fmi3GetOutputDerivatives",
            |f| (f.get_output_derivatives)(
                self.comp,
                vrs.as_ptr(),
                n,
                orders.as_ptr(),
                values.as_mut_ptr(),
                n
            )
        )
    }

    /// `fmi3GetDirectionalDerivative`: `sensitivity = J seed` with `J` the
    /// partial derivatives of the `unknowns` with respect to the `knowns` at
    /// the current point (FMI 3.0 FMUs that declare
    /// `providesDirectionalDerivatives`; FMI 2.0 is not asked).
    pub fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        sensitivity: &mut [f64],
    ) -> Result<()> {
        assert!(knowns.len() == seed.len() && unknowns.len() == sensitivity.len());
        match &self.api {
            Api::V2(_) => Err(self.status_error(
                "fmi2GetDirectionalDerivative",
                "not called: directional derivatives are used from FMI 3.0 FMUs only",
            )),
            Api::V3(fns) => {
                // SAFETY: every slice has the length passed with it.
                let st = unsafe {
                    (fns.get_directional_derivative)(
                        self.comp,
                        unknowns.as_ptr(),
                        unknowns.len(),
                        knowns.as_ptr(),
                        knowns.len(),
                        seed.as_ptr(),
                        seed.len(),
                        sensitivity.as_mut_ptr(),
                        sensitivity.len(),
                    )
                };
                self.check("fmi3GetDirectionalDerivative", st)
            }
        }
    }

    /// `fmi2DoStep(t, h, noSetFMUStatePriorToCurrentPoint = false)` or
    /// `fmi3DoStep`; in FMI 3.0 a step that returns early or asks to
    /// terminate is an error (this master steps synchronously to the end).
    #[inline]
    pub fn do_step(&mut self, t_s: f64, h_s: f64) -> Result<()> {
        self.time_s = t_s;
        let (mut event, mut terminate, mut early, mut last) = (false, false, false, t_s);
        call!(
            self,
            "fmi2DoStep",
            |f| (f.do_step)(self.comp, t_s, h_s, 0),
            "fmi3DoStep",
            |f| (f.do_step)(
                self.comp,
                t_s,
                h_s,
                false,
                &mut event,
                &mut terminate,
                &mut early,
                &mut last
            )
        )?;
        if terminate || early {
            let why = if terminate {
                "terminateSimulation = true"
            } else {
                "earlyReturn = true"
            };
            return Err(FmuError::Status {
                function: "fmi3DoStep",
                instance: self.name.clone(),
                status: "fmi3OK",
                time_s: t_s,
                log: format!(
                    "{why} (last successful time {last} s of the step to {} s); {}",
                    t_s + h_s,
                    self.sink.summary()
                ),
            });
        }
        Ok(())
    }

    /// Save the current state into this instance's slot
    /// (`fmi2GetFMUstate` / `fmi3GetFMUState`, reusing the slot's memory
    /// after the first call).
    pub fn save_state(&mut self) -> Result<()> {
        let slot: *mut FmuState = &mut self.saved;
        // `saved` is null or a state of this instance.
        call!(
            self,
            "fmi2GetFMUstate",
            |f| (f.get_fmu_state)(self.comp, slot),
            "fmi3GetFMUState",
            |f| (f.get_fmu_state)(self.comp, slot)
        )
    }

    /// Roll back to the state saved by [`save_state`](Self::save_state).
    pub fn restore_state(&mut self) -> Result<()> {
        if self.saved.is_null() {
            return Err(self.status_error("fmi2SetFMUstate", "not called: no state saved"));
        }
        // `saved` is a state of this instance.
        call!(
            self,
            "fmi2SetFMUstate",
            |f| (f.set_fmu_state)(self.comp, self.saved),
            "fmi3SetFMUState",
            |f| (f.set_fmu_state)(self.comp, self.saved)
        )
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: `comp` is a live instance; `saved` is null or its state.
        unsafe {
            match &self.api {
                Api::V2(f) => {
                    if !self.saved.is_null() {
                        (f.free_fmu_state)(self.comp, &mut self.saved);
                    }
                    (f.free_instance)(self.comp);
                }
                Api::V3(f) => {
                    if !self.saved.is_null() {
                        (f.free_fmu_state)(self.comp, &mut self.saved);
                    }
                    (f.free_instance)(self.comp);
                }
            }
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
