//! The structure FMU (FMI 2.0 Co-Simulation and Model Exchange): the time-domain nonlinear-mode
//! oscillator of DESIGN.md section 4 ([`nlmode::oscillator`]) driven by the
//! force of an attachment at one point of the modal table.
//!
//! Physics in [`nlmode::oscillator`]; this file only maps the FMI variables
//! (table [`Structure::VARIABLES`], the single source the modelDescription.xml
//! is tested against) onto it. See `README.md` for the equations and the
//! variable table.
//!
//! * input `F` [N]: force on the structure at the drive point, positive along
//!   positive displacement; over a step it is `F + F' s + F'' s^2/2` with the
//!   derivatives from `fmi2SetRealInputDerivatives` (zero unless given, reset
//!   after every step);
//! * outputs `x`, `v` (drive point), `x_tip`, `a`, `omega`, none with direct
//!   feedthrough from `F`;
//! * parameters `frequency_error` (`omega -> (1 + eps) omega`), `drive_point`
//!   (name in the table, default `2l3`), `drive_point_index` (index into the
//!   table's points, used when >= 0), `modal_table` (path; empty: the
//!   `modal_table.json` of the FMU's `resources/` folder).
use std::cell::{Cell, RefCell};
use std::path::PathBuf;

use fmi2_export::{
    Causality, CoSimModel, ContinuousState, InstantiateContext, Logger, ModelError, Start,
    StateReader, StateWriter, VarType, Variability, Variable,
};
use nlmode::nma::ModalTable;
use nlmode::oscillator::{InputPolynomial, ModalOscillator, OscillatorState, PointResponse};

/// Value references (Real).
pub mod vr {
    pub const F: u32 = 0;
    pub const X: u32 = 1;
    pub const V: u32 = 2;
    pub const X_TIP: u32 = 3;
    pub const A: u32 = 4;
    pub const OMEGA: u32 = 5;
    pub const FREQUENCY_ERROR: u32 = 6;
    /// Model Exchange: the states `eta`, `u = eta'/omega(a)` and their derivatives.
    pub const ETA: u32 = 7;
    pub const U: u32 = 8;
    pub const DER_ETA: u32 = 9;
    pub const DER_U: u32 = 10;
    /// String parameters.
    pub const DRIVE_POINT: u32 = 0;
    pub const MODAL_TABLE: u32 = 1;
    /// Integer parameter.
    pub const DRIVE_POINT_INDEX: u32 = 0;
}

/// File name of the modal table in the FMU's `resources/` folder.
pub const RESOURCE_TABLE: &str = "modal_table.json";
/// Name of the tip point in the table.
pub const TIP_POINT: &str = "tip";
/// Default drive point (the paper's exciter at `2l/3`).
pub const DEFAULT_DRIVE_POINT: &str = "2l3";

/// Outputs at the current communication point.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Outputs {
    x: f64,
    v: f64,
    x_tip: f64,
    a: f64,
    omega: f64,
}

/// First time derivatives of the outputs along the flow at the current state
/// and input (`fmi2GetRealOutputDerivatives`), computed together once.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct OutputRates {
    x: f64,
    v: f64,
    x_tip: f64,
    a: f64,
    omega: f64,
}

/// One structure FMU instance.
#[derive(Clone)]
pub struct Structure {
    resource_dir: Option<PathBuf>,
    start_time_s: f64,
    frequency_error: f64,
    drive_point: String,
    drive_point_index: i32,
    modal_table: String,
    /// `F` at the start of the next step and its first two time derivatives.
    force: InputPolynomial,
    /// The oscillator from `fmi2ExitInitializationMode` on.
    osc: Option<ModalOscillator>,
    tip: usize,
    out: Outputs,
    /// Before that (Initialization Mode): the oscillator the current
    /// parameters give, at the start state `eta = u = 0`, with its tip index,
    /// built at the first read that needs it (so that `omega`, the outputs
    /// and `der(eta)`, `der(u)` are readable at the start values) and
    /// dropped whenever a parameter or the start time changes.
    preview: RefCell<Option<Result<(ModalOscillator, usize), ModelError>>>,
    /// Output derivatives for the current state and `force.c0`, computed at the
    /// first request (a master asks for them variable by variable); emptied by
    /// everything that changes the state or `F`.
    rates: Cell<Option<OutputRates>>,
}

const fn real(
    name: &'static str,
    vr: u32,
    causality: Causality,
    variability: Variability,
    start: Option<Start>,
    unit: &'static str,
) -> Variable {
    Variable {
        name,
        vr,
        ty: VarType::Real,
        causality,
        variability,
        start,
        unit,
    }
}

impl Structure {
    /// Path of the modal table from the parameter or the resources folder.
    fn table_path(&self) -> Result<PathBuf, ModelError> {
        if !self.modal_table.is_empty() {
            return Ok(PathBuf::from(&self.modal_table));
        }
        match &self.resource_dir {
            Some(dir) => Ok(dir.join(RESOURCE_TABLE)),
            None => Err(ModelError::error(format!(
                "no modal table: parameter modal_table is empty and the importer gave no resource location \
                 (expected resources/{RESOURCE_TABLE})"
            ))),
        }
    }

    /// Load the table and build the oscillator at the start state `eta = u = 0`
    /// from the current parameters; returns it with the tip's point index.
    fn load(&self) -> Result<(ModalOscillator, usize), ModelError> {
        let path = self.table_path()?;
        // the key the importer can change: the parameter, or the resource file
        let source = if self.modal_table.is_empty() {
            format!(
                "modal table resources/{RESOURCE_TABLE} ({})",
                path.display()
            )
        } else {
            format!("parameter modal_table = \"{}\"", self.modal_table)
        };
        match std::fs::metadata(&path) {
            Err(_) => {
                return Err(ModelError::error(format!(
                    "{source}: the file does not exist; expected a modal-table JSON file"
                )))
            }
            // a device such as /dev/zero would be read without end
            Ok(m) if !m.is_file() => {
                return Err(ModelError::error(format!(
                    "{source}: not a regular file; expected a modal-table JSON file"
                )))
            }
            Ok(_) => {}
        }
        let table = ModalTable::read(&path)?;
        let drive = if self.drive_point_index >= 0 {
            let i = self.drive_point_index as usize;
            let names: Vec<&str> = table.points.iter().map(|p| p.name.as_str()).collect();
            names.get(i).map(|s| s.to_string()).ok_or_else(|| {
                ModelError::error(format!(
                    "drive_point_index = {i} but the table has {} points ({})",
                    names.len(),
                    names.join(", ")
                ))
            })?
        } else {
            self.drive_point.clone()
        };
        let mut osc = ModalOscillator::new(&table, &drive, self.frequency_error)?;
        let tip = osc.point_index(TIP_POINT)?;
        osc.set_state(OscillatorState {
            time_s: self.start_time_s,
            eta: 0.0,
            u: 0.0,
        })?;
        Ok((osc, tip))
    }

    /// Build the oscillator (at `fmi2ExitInitializationMode`), reusing the
    /// one Initialization Mode built from the same parameters.
    fn build(&mut self) -> Result<(), ModelError> {
        let (osc, tip) = match self.preview.take() {
            Some(Ok(p)) => p,
            _ => self.load()?,
        };
        self.tip = tip;
        self.osc = Some(osc);
        self.update_outputs()
    }

    /// A parameter or the start time changed: the preview oscillator and the
    /// cached rates no longer hold.
    fn parameters_changed(&mut self) {
        self.preview.replace(None);
        self.rates.set(None);
    }

    /// `f` on the oscillator and the tip index: the live one after
    /// initialization, before it the preview of the current parameters.
    fn with_oscillator<R>(
        &self,
        f: impl FnOnce(&ModalOscillator, usize) -> Result<R, ModelError>,
    ) -> Result<R, ModelError> {
        if let Some(osc) = &self.osc {
            return f(osc, self.tip);
        }
        let mut preview = self.preview.borrow_mut();
        match preview.get_or_insert_with(|| self.load()) {
            Ok((osc, tip)) => f(osc, *tip),
            Err(e) => Err(ModelError::error(format!(
                "cannot evaluate the model at the start values: {}",
                e.message
            ))),
        }
    }

    /// The outputs: after initialization those of the last step or state set,
    /// before it those of the start state under the current parameters.
    fn current_outputs(&self) -> Result<Outputs, ModelError> {
        if self.osc.is_some() {
            return Ok(self.out);
        }
        self.with_oscillator(Self::outputs_of)
    }

    fn outputs_of(osc: &ModalOscillator, tip: usize) -> Result<Outputs, ModelError> {
        let mut r = [PointResponse {
            x_m: 0.0,
            v_m_s: 0.0,
        }; 2];
        let m = osc.outputs(&[osc.drive_index(), tip], &mut r)?;
        Ok(Outputs {
            x: r[0].x_m,
            v: r[0].v_m_s,
            x_tip: r[1].x_m,
            a: m.amplitude,
            omega: m.omega_rad_s,
        })
    }

    fn update_outputs(&mut self) -> Result<(), ModelError> {
        self.rates.set(None);
        let Some(osc) = &self.osc else { return Ok(()) };
        self.out = Self::outputs_of(osc, self.tip)?;
        Ok(())
    }

    /// All output derivatives at the current state and input (cached).
    fn output_rates(&self) -> Result<OutputRates, ModelError> {
        if let Some(r) = self.rates.get() {
            return Ok(r);
        }
        let mut p = [PointResponse {
            x_m: 0.0,
            v_m_s: 0.0,
        }; 2];
        let (a, omega) = self.with_oscillator(|osc, tip| {
            Ok(osc.output_rates(&[osc.drive_index(), tip], self.force.c0, &mut p)?)
        })?;
        let r = OutputRates {
            x: p[0].x_m,
            v: p[0].v_m_s,
            x_tip: p[1].x_m,
            a,
            omega,
        };
        self.rates.set(Some(r));
        Ok(r)
    }

    /// `(eta', u')` at the current state under the input `F` (its value now);
    /// before initialization at the start state `eta = u = 0`.
    fn state_rate(&self) -> Result<(f64, f64), ModelError> {
        self.with_oscillator(|osc, _| Ok(osc.state_rate(self.force.c0)?))
    }

    fn oscillator(&self) -> Result<&ModalOscillator, ModelError> {
        self.osc.as_ref().ok_or_else(|| {
            ModelError::error("the modal table is loaded at fmi2ExitInitializationMode")
        })
    }
}

impl CoSimModel for Structure {
    const MODEL_IDENTIFIER: &'static str = "structure";
    const GUID: &'static str = "{60aa93fb-2eb2-4b1e-a6da-f73a230326bf}";
    const VARIABLES: &'static [Variable] = &[
        real(
            "F",
            vr::F,
            Causality::Input,
            Variability::Continuous,
            Some(Start::Real(0.0)),
            "N",
        ),
        real(
            "x",
            vr::X,
            Causality::Output,
            Variability::Continuous,
            None,
            "m",
        ),
        real(
            "v",
            vr::V,
            Causality::Output,
            Variability::Continuous,
            None,
            "m/s",
        ),
        real(
            "x_tip",
            vr::X_TIP,
            Causality::Output,
            Variability::Continuous,
            None,
            "m",
        ),
        real(
            "a",
            vr::A,
            Causality::Output,
            Variability::Continuous,
            None,
            "sqrt(kg).m",
        ),
        real(
            "omega",
            vr::OMEGA,
            Causality::Output,
            Variability::Continuous,
            None,
            "rad/s",
        ),
        real(
            "frequency_error",
            vr::FREQUENCY_ERROR,
            Causality::Parameter,
            Variability::Fixed,
            Some(Start::Real(0.0)),
            "",
        ),
        real(
            "eta",
            vr::ETA,
            Causality::Local,
            Variability::Continuous,
            None,
            "sqrt(kg).m",
        ),
        real(
            "u",
            vr::U,
            Causality::Local,
            Variability::Continuous,
            None,
            "sqrt(kg).m",
        ),
        real(
            "der(eta)",
            vr::DER_ETA,
            Causality::Local,
            Variability::Continuous,
            None,
            "sqrt(kg).m/s",
        ),
        real(
            "der(u)",
            vr::DER_U,
            Causality::Local,
            Variability::Continuous,
            None,
            "sqrt(kg).m/s",
        ),
        Variable {
            name: "drive_point",
            vr: vr::DRIVE_POINT,
            ty: VarType::String,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(Start::String(DEFAULT_DRIVE_POINT)),
            unit: "",
        },
        Variable {
            name: "drive_point_index",
            vr: vr::DRIVE_POINT_INDEX,
            ty: VarType::Integer,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(Start::Integer(-1)),
            unit: "",
        },
        Variable {
            name: "modal_table",
            vr: vr::MODAL_TABLE,
            ty: VarType::String,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(Start::String("")),
            unit: "",
        },
    ];

    /// The normal-form state `(eta, u)` of [`nlmode::oscillator`] (nominal:
    /// the paper's modal amplitudes, up to about 4.5e-3 sqrt(kg) m).
    const CONTINUOUS_STATES: &'static [ContinuousState] = &[
        ContinuousState {
            state_vr: vr::ETA,
            derivative_vr: vr::DER_ETA,
            nominal: 1e-3,
        },
        ContinuousState {
            state_vr: vr::U,
            derivative_vr: vr::DER_U,
            nominal: 1e-3,
        },
    ];

    fn instantiate(ctx: &InstantiateContext<'_>) -> Result<Self, ModelError> {
        if ctx.resource_dir.is_none() {
            ctx.logger.info(
                "no resource location given: set the parameter modal_table to a modal-table file",
            );
        }
        Ok(Structure {
            resource_dir: ctx.resource_dir.clone(),
            start_time_s: 0.0,
            frequency_error: 0.0,
            drive_point: DEFAULT_DRIVE_POINT.into(),
            drive_point_index: -1,
            modal_table: String::new(),
            force: InputPolynomial::default(),
            osc: None,
            tip: 0,
            out: Outputs::default(),
            rates: Cell::new(None),
            preview: RefCell::new(None),
        })
    }

    fn setup_experiment(
        &mut self,
        start_time: f64,
        _stop_time: Option<f64>,
    ) -> Result<(), ModelError> {
        self.start_time_s = start_time;
        self.parameters_changed();
        Ok(())
    }

    fn exit_initialization_mode(&mut self, log: &Logger) -> Result<(), ModelError> {
        self.build()?;
        let osc = self.oscillator()?;
        let (a_min, a_max) = osc.table().amplitude_range();
        log.info(&format!(
            "modal table {} loaded: a in [{a_min:e}, {a_max:e}] sqrt(kg) m, H = {}, drive point index {}, \
             frequency factor {}, RK4 sub-step <= {:e} s",
            self.table_path()?.display(),
            osc.table().harmonics(),
            osc.drive_index(),
            1.0 + self.frequency_error,
            osc.max_substep_s()
        ));
        Ok(())
    }

    fn get_real(&self, vr: u32) -> f64 {
        // a failure (no table, out of the table's range) is NaN here and a
        // message in `try_get_real`
        self.try_get_real(vr).unwrap_or(f64::NAN)
    }

    /// Every variable is readable in Initialization Mode too: the outputs and
    /// `der(eta)`, `der(u)` are then those of the start state `eta = u = 0`
    /// under the current parameters and `F` (the modal table is read for
    /// them); the error says why when the parameters do not give a model.
    fn try_get_real(&self, vr: u32) -> Result<f64, ModelError> {
        let out = || self.current_outputs();
        Ok(match vr {
            vr::F => self.force.c0,
            vr::X => out()?.x,
            vr::V => out()?.v,
            vr::X_TIP => out()?.x_tip,
            vr::A => out()?.a,
            vr::OMEGA => out()?.omega,
            vr::FREQUENCY_ERROR => self.frequency_error,
            vr::ETA => self.osc.as_ref().map_or(0.0, |o| o.state().eta),
            vr::U => self.osc.as_ref().map_or(0.0, |o| o.state().u),
            vr::DER_ETA => self.state_rate()?.0,
            vr::DER_U => self.state_rate()?.1,
            _ => unreachable!("the layer checks value references"),
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            vr::F => {
                self.force.c0 = value;
                self.rates.set(None);
            }
            vr::FREQUENCY_ERROR => {
                if 1.0 + value <= 0.0 {
                    return Err(ModelError::error(format!(
                        "frequency_error = {value}: the factor 1 + frequency_error must be positive"
                    )));
                }
                self.frequency_error = value;
                self.parameters_changed();
            }
            _ => unreachable!("the layer checks settability"),
        }
        Ok(())
    }

    fn get_integer(&self, vr: u32) -> Result<i32, ModelError> {
        match vr {
            vr::DRIVE_POINT_INDEX => Ok(self.drive_point_index),
            _ => Err(ModelError::error(format!(
                "no Integer variable with value reference {vr}"
            ))),
        }
    }

    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), ModelError> {
        match vr {
            vr::DRIVE_POINT_INDEX => {
                self.drive_point_index = value;
                self.parameters_changed();
                Ok(())
            }
            _ => Err(ModelError::error(format!(
                "no Integer variable with value reference {vr}"
            ))),
        }
    }

    fn get_string(&self, vr: u32) -> Result<String, ModelError> {
        match vr {
            vr::DRIVE_POINT => Ok(self.drive_point.clone()),
            vr::MODAL_TABLE => Ok(self.modal_table.clone()),
            _ => Err(ModelError::error(format!(
                "no String variable with value reference {vr}"
            ))),
        }
    }

    fn set_string(&mut self, vr: u32, value: &str) -> Result<(), ModelError> {
        match vr {
            vr::DRIVE_POINT => self.drive_point = value.to_string(),
            vr::MODAL_TABLE => self.modal_table = value.to_string(),
            _ => {
                return Err(ModelError::error(format!(
                    "no String variable with value reference {vr}"
                )))
            }
        }
        self.parameters_changed();
        Ok(())
    }

    fn do_step(&mut self, _t: f64, h: f64, _log: &Logger) -> Result<(), ModelError> {
        let osc = self
            .osc
            .as_mut()
            .ok_or_else(|| ModelError::error("not initialized"))?;
        osc.step(h, self.force)?;
        // the input continues from the polynomial's end value until the master sets it;
        // derivatives apply to one step only
        let p = self.force;
        self.force = InputPolynomial::constant(p.c0 + h * (p.c1 + 0.5 * h * p.c2));
        self.update_outputs()
    }

    /// Model Exchange: the oscillator is autonomous; the time only stamps
    /// its error messages.
    fn set_time(&mut self, t: f64) -> Result<(), ModelError> {
        let osc = self
            .osc
            .as_mut()
            .ok_or_else(|| ModelError::error("not initialized"))?;
        let s = osc.state();
        osc.set_state(OscillatorState { time_s: t, ..s })?;
        Ok(())
    }

    /// Model Exchange: `[eta, u]`; an amplitude above the table's range is an error.
    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), ModelError> {
        let osc = self
            .osc
            .as_mut()
            .ok_or_else(|| ModelError::error("not initialized"))?;
        let s = osc.state();
        osc.set_state(OscillatorState {
            time_s: s.time_s,
            eta: x[0],
            u: x[1],
        })?;
        self.update_outputs()
    }

    /// Model Exchange: `[eta', u']` of the normal form under the input `F`
    /// ([`ModalOscillator::state_rate`]).
    fn derivatives(&self, dx: &mut [f64]) -> Result<(), ModelError> {
        let (de, du) = self.state_rate()?;
        dx[0] = de;
        dx[1] = du;
        Ok(())
    }

    fn set_real_input_derivative(
        &mut self,
        vr: u32,
        order: u32,
        value: f64,
    ) -> Result<(), ModelError> {
        match (vr, order) {
            (vr::F, 1) => self.force.c1 = value,
            (vr::F, 2) => self.force.c2 = value,
            _ => {
                return Err(ModelError::error(format!(
                    "input derivative of order {order} of value reference {vr} is not supported (F: orders 1 and 2)"
                )))
            }
        }
        Ok(())
    }

    fn get_real_output_derivative(&self, vr: u32, order: u32) -> Result<f64, ModelError> {
        if order != 1 {
            return Err(ModelError::error(format!(
                "output derivatives of order {order} are not supported (only 1)"
            )));
        }
        let r = self.output_rates()?;
        Ok(match vr {
            vr::X => r.x,
            vr::V => r.v,
            vr::X_TIP => r.x_tip,
            vr::A => r.a,
            vr::OMEGA => r.omega,
            _ => {
                return Err(ModelError::error(format!(
                    "value reference {vr} is not an output"
                )))
            }
        })
    }

    fn partial_derivative(&self, unknown: u32, known: u32) -> Result<f64, ModelError> {
        // no output depends directly on the input F (ModelStructure dependencies="")
        if known == vr::F && matches!(unknown, vr::X | vr::V | vr::X_TIP | vr::A | vr::OMEGA) {
            return Ok(0.0);
        }
        Err(ModelError::error(format!(
            "directional derivative d(vr {unknown})/d(vr {known}) is not available (only outputs w.r.t. F)"
        )))
    }

    fn serialize_state(&self, w: &mut StateWriter) {
        w.f64(self.force.c0);
        w.f64(self.force.c1);
        w.f64(self.force.c2);
        w.f64(self.frequency_error);
        w.bool(self.osc.is_some());
        if let Some(osc) = &self.osc {
            let s = osc.state();
            w.u64(osc.drive_index() as u64);
            w.f64(s.time_s);
            w.f64(s.eta);
            w.f64(s.u);
        }
    }

    fn deserialize_state(&mut self, r: &mut StateReader<'_>) -> Result<(), ModelError> {
        self.force = InputPolynomial {
            c0: r.f64()?,
            c1: r.f64()?,
            c2: r.f64()?,
        };
        let eps = r.f64()?;
        let initialized = r.bool()?;
        if eps != self.frequency_error || initialized != self.osc.is_some() {
            return Err(ModelError::error(format!(
                "FMU state from another configuration (frequency_error {eps}, initialized {initialized}; \
                 this instance: {}, {})",
                self.frequency_error,
                self.osc.is_some()
            )));
        }
        if let Some(osc) = &mut self.osc {
            let drive = r.u64()? as usize;
            if drive != osc.drive_index() {
                return Err(ModelError::error(format!(
                    "FMU state for drive point index {drive}, this instance drives point {}",
                    osc.drive_index()
                )));
            }
            let s = OscillatorState {
                time_s: r.f64()?,
                eta: r.f64()?,
                u: r.f64()?,
            };
            osc.set_state(s)?;
        }
        self.update_outputs()
    }
}

fmi2_export::export_fmu!(Structure);
