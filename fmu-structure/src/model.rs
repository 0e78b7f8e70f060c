//! The structure FMU's variables, parameters and FMU state, mapped onto the
//! oscillator of [`nlmode::oscillator`] (loaded from a modal table).
use std::cell::{Cell, RefCell};
use std::path::PathBuf;

use fmi2_export::{
    ArrayOutput, Capabilities, Causality as C, CoSimModel, ContinuousState, DefaultExperiment,
    Dependencies, InstantiateContext, Logger, ModelError, ModelInfo, ModelStructure, StateReader,
    StateWriter, StepOutcome, StructuralParameter, Unit, Variability as V, Variable,
};
use nlmode::nma::ModalTable;
use nlmode::oscillator::{
    InputPolynomial, ModalOscillator, OscillatorState, PointResponse, StepEnd,
};

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
    /// Integer parameters.
    pub const DRIVE_POINT_INDEX: u32 = 0;
    pub const RESIDUAL_MODES: u32 = 1;
    /// Boolean parameters.
    pub const HARMONIC_FORCE_PROJECTION: u32 = 0;
    /// FMI 3.0 only: the UInt64 structural parameter and the Float64 arrays
    /// it sizes (value references unique over all FMI 3.0 variables).
    pub const MODE_SHAPE_POINTS: u32 = 400_000_000;
    pub const MODE_SHAPE_RE: u32 = 400_000_001;
    pub const MODE_SHAPE_IM: u32 = 400_000_002;
}

/// Points of the modal table the FMU is packaged with by default (the
/// paper's beam: `tip`, `2l3`, `l3`): the start value of the FMI 3.0
/// structural parameter `mode_shape_points` in the checked-in
/// modelDescription (`host package` renders the count of the table it
/// ships, [`fmi2_export::render3::with_structural_start`]).
pub const DEFAULT_MODE_SHAPE_POINTS: u64 = 3;

/// The FMI 3.0 structural parameter: the number of points of the modal table.
pub const STRUCTURAL_PARAMETERS: &[StructuralParameter] = &[StructuralParameter {
    name: "mode_shape_points",
    vr: vr::MODE_SHAPE_POINTS,
    start: DEFAULT_MODE_SHAPE_POINTS,
    max: 1_000_000,
    description: "Number of points of the modal table (the length of mode_shape_re, mode_shape_im); must equal the table's point count (set it in Configuration Mode for another table)",
}];

/// The FMI 3.0 arrays: the mode shape at the table's points at the current
/// amplitude (`eq:ansatz`, fundamental harmonic), one entry per point in
/// the table's order.
pub const ARRAY_OUTPUTS: &[ArrayOutput] = &[
    ArrayOutput {
        name: "mode_shape_re",
        vr: vr::MODE_SHAPE_RE,
        dimension_vr: vr::MODE_SHAPE_POINTS,
        unit: "m",
        description: "Re q_1,k = Re(a phi_1,k(a) |phi_1,ex|/phi_1,ex): fundamental harmonic of the displacement of each point k of the modal table (table order) at the current amplitude a, phase relative to the drive point; the point moves as Re(q_1,k e^(i psi)) plus higher harmonics",
        initial_dependencies: &["drive_point", "drive_point_index", "modal_table"],
    },
    ArrayOutput {
        name: "mode_shape_im",
        vr: vr::MODE_SHAPE_IM,
        dimension_vr: vr::MODE_SHAPE_POINTS,
        unit: "m",
        description: "Im q_1,k: imaginary part of the fundamental harmonic of the displacement of each point of the modal table (see mode_shape_re)",
        initial_dependencies: &["drive_point", "drive_point_index", "modal_table"],
    },
];

/// File name of the modal table in the FMU's `resources/` folder.
pub const RESOURCE_TABLE: &str = "modal_table.json";
/// Name of the tip point in the table.
pub const TIP_POINT: &str = "tip";
/// Default drive point (the paper's exciter at `2l/3`).
pub const DEFAULT_DRIVE_POINT: &str = "2l3";

/// GUID of the FMU (written here only; the modelDescription is rendered from it).
pub const GUID: &str = "{60aa93fb-2eb2-4b1e-a6da-f73a230326bf}";

/// All variables, in the order of their indices (the single source of the
/// modelDescription's `<ModelVariables>`).
pub const VARIABLES: &[Variable] = &[
    Variable::real("F", vr::F, C::Input, V::Continuous, Some(0.0), "N")
        .describe("Force on the structure at the drive point, positive along positive displacement (from the attachment, e.g. the shaker's stinger)"),
    Variable::real("x", vr::X, C::Output, V::Continuous, None, "m")
        .describe("Displacement of the drive point, Re(a sum_n phi_n,ex(a) e^(i n psi))"),
    Variable::real("v", vr::V, C::Output, V::Continuous, None, "m/s")
        .describe("Velocity of the drive point along the mode's periodic motion, Re(a sum_n i n omega phi_n,ex(a) e^(i n psi))"),
    Variable::real("x_tip", vr::X_TIP, C::Output, V::Continuous, None, "m")
        .describe("Displacement of the beam tip (point 'tip' of the modal table), all harmonics"),
    Variable::real("a", vr::A, C::Output, V::Continuous, None, "sqrt(kg).m")
        .describe("Modal amplitude a = |eta - i eta'/omega(a)| (mass-normalized fundamental harmonic)"),
    Variable::real("omega", vr::OMEGA, C::Output, V::Continuous, None, "rad/s")
        .describe("Modal frequency (1 + frequency_error) omega(a) at the current amplitude"),
    Variable::real("frequency_error", vr::FREQUENCY_ERROR, C::Parameter, V::Fixed, Some(0.0), "")
        .describe("Relative natural-frequency error eps: the oscillator uses (1 + eps) omega(a) (paper's frequency-error study)"),
    Variable::string_parameter("drive_point", vr::DRIVE_POINT, DEFAULT_DRIVE_POINT)
        .describe("Name of the drive point in the modal table (the paper's beam: l3 or 2l3); used when drive_point_index is negative"),
    Variable::integer_parameter("drive_point_index", vr::DRIVE_POINT_INDEX, -1)
        .describe("0-based index of the drive point among the modal table's points; -1: use drive_point"),
    Variable::string_parameter("modal_table", vr::MODAL_TABLE, "")
        .describe("Path of the modal-table file (nlmode-modal-table JSON); empty: modal_table.json in the FMU's resources folder"),
    Variable::real("eta", vr::ETA, C::Local, V::Continuous, None, "sqrt(kg).m")
        .describe("Modal coordinate eta = a cos(psi) (continuous state; 0 at the start)"),
    Variable::real("u", vr::U, C::Local, V::Continuous, None, "sqrt(kg).m")
        .describe("Normalized modal velocity u = eta'/omega(a), a = sqrt(eta^2 + u^2) (continuous state; 0 at the start)"),
    Variable::real("der(eta)", vr::DER_ETA, C::Local, V::Continuous, None, "sqrt(kg).m/s")
        .describe("eta' = omega(a) u (plus the force's term with harmonic_force_projection)"),
    Variable::real("der(u)", vr::DER_U, C::Local, V::Continuous, None, "sqrt(kg).m/s")
        .describe("u' = -omega(a) eta - 2 D(a) omega(a) u + |phi_ex(a)| F / omega(a) (the force's term projected on every harmonic with harmonic_force_projection)"),
    Variable::integer_parameter("residual_modes", vr::RESIDUAL_MODES, 0)
        .describe("Linear modes of the structure (the modal table's linear_modes, lowest first) carried beside the nonlinear mode as linear modal oscillators driven by F; x, v, x_tip include them. 0: the single nonlinear mode. Co-Simulation only"),
    Variable::boolean_parameter("harmonic_force_projection", vr::HARMONIC_FORCE_PROJECTION, false)
        .describe("true: F acts on every harmonic of the mode at the drive point (its work on the whole motion Re(a sum_n phi_n,ex e^(i n psi))), so the power F's higher harmonics exchange with the mode's own is kept (e.g. a shaker's third harmonic at phase resonance); false: on the fundamental only (the paper's eq. NM)"),
];

/// The normal-form state `(eta, u)` of [`nlmode::oscillator`] (nominal:
/// the paper's modal amplitudes, up to about 4.5e-3 sqrt(kg) m).
pub const CONTINUOUS_STATES: &[ContinuousState] = &[
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

/// The rest of the modelDescription. `<ModelStructure>`: no output depends
/// directly on `F` (no algebraic loop with an attachment whose force depends
/// directly on `x`); the state starts at rest (`eta = u = 0`), so `x`, `v`,
/// `x_tip`, `a` start at 0 whatever the knowns, `omega = (1 +
/// frequency_error) omega_table(0)` depends on `frequency_error` and the
/// table (`modal_table`), `der(u)` on `F` and everything that selects the
/// table and the drive point.
pub const INFO: ModelInfo = ModelInfo {
    name: "structure",
    description: "Nonlinear structure as a single nonlinear modal oscillator (Krack, single-nonlinear-mode theory): eta'' + 2 D(a) omega(a) eta' + omega(a)^2 eta = |phi_ex(a)| F, outputs synthesized with all harmonics of the modal table",
    version: None,
    generation_tool: "nlmode fmu-structure",
    capabilities: Capabilities {
        can_handle_variable_communication_step_size: true,
        can_interpolate_inputs: true,
        max_output_derivative_order: 1,
        provides_directional_derivative: true,
    },
    units: &[
        Unit {
            name: "sqrt(kg).m",
            base: None,
        },
        Unit {
            name: "sqrt(kg).m/s",
            base: None,
        },
    ],
    log_categories: &[
        "informative messages (table loaded, parameters)",
        "messages with status fmi2Warning",
        "messages with status fmi2Discard",
        "messages with status fmi2Error",
        "messages with status fmi2Fatal",
        "all messages",
    ],
    // stepSize: stable when coupled explicitly to the paper's shaker (stinger
    // k_s = 2.6e7 N/m: about 2e-5 s at most)
    default_experiment: DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(1.0),
        tolerance: None,
        step_size: Some(1e-5),
    },
    model_structure: ModelStructure {
        outputs: &[],
        derivatives: &[
            // F with harmonic_force_projection (module nlmode::oscillator::projection)
            Dependencies::on("der(eta)", &["F", "eta", "u"]),
            Dependencies::on("der(u)", &["F", "eta", "u"]),
        ],
        initial_unknowns: &[
            Dependencies::on("omega", &["frequency_error", "modal_table"]),
            Dependencies::on(
                "der(u)",
                &["F", "frequency_error", "drive_point", "drive_point_index", "modal_table"],
            ),
        ],
    },
};

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
    /// Residual modes ([`ModalOscillator::with_residual_modes`]).
    residual_modes: i32,
    /// [`ModalOscillator::with_harmonic_force_projection`].
    harmonic_force_projection: bool,
    modal_table: String,
    /// FMI 3.0 structural parameter `mode_shape_points`.
    mode_shape_points: u64,
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
        let n = usize::try_from(self.residual_modes).map_err(|_| {
            ModelError::error(format!(
                "residual_modes = {}: expected 0 or more",
                self.residual_modes
            ))
        })?;
        let mut osc = ModalOscillator::new(&table, &drive, self.frequency_error)?
            .with_residual_modes(&table, n)?
            .with_harmonic_force_projection(self.harmonic_force_projection);
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

    /// Model Exchange has the two states `eta`, `u`: residual modes (states
    /// of their own, integrated exactly per step) run in Co-Simulation only.
    fn single_mode_for_model_exchange(&self) -> Result<(), ModelError> {
        if self.residual_modes > 0 {
            return Err(ModelError::error(format!(
                "residual_modes = {}: residual modes are available in Co-Simulation only (Model Exchange \
                 has the two states eta, u); set residual_modes = 0 or import the FMU as Co-Simulation",
                self.residual_modes
            )));
        }
        Ok(())
    }

    /// The input after `elapsed_s` of a step: it continues from the
    /// polynomial's value there until the master sets it (derivatives apply
    /// to one step only).
    fn input_advanced(&mut self, elapsed_s: f64) {
        let p = self.force;
        let h = elapsed_s;
        self.force = InputPolynomial::constant(p.c0 + h * (p.c1 + 0.5 * h * p.c2));
    }

    fn oscillator(&self) -> Result<&ModalOscillator, ModelError> {
        self.osc.as_ref().ok_or_else(|| {
            ModelError::error("the modal table is loaded at fmi2ExitInitializationMode")
        })
    }
}

impl CoSimModel for Structure {
    const MODEL_IDENTIFIER: &'static str = "structure";
    const GUID: &'static str = GUID;
    const VARIABLES: &'static [Variable] = VARIABLES;
    const INFO: ModelInfo = INFO;

    const CONTINUOUS_STATES: &'static [ContinuousState] = CONTINUOUS_STATES;

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
            residual_modes: 0,
            harmonic_force_projection: false,
            modal_table: String::new(),
            mode_shape_points: DEFAULT_MODE_SHAPE_POINTS,
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
             {} residual modes, force on {}, frequency factor {}, RK4 sub-step <= {:e} s",
            self.table_path()?.display(),
            osc.table().harmonics(),
            osc.drive_index(),
            osc.residual_modes(),
            if osc.harmonic_force_projection() {
                "every harmonic of the mode"
            } else {
                "the mode's fundamental"
            },
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
            vr::RESIDUAL_MODES => Ok(self.residual_modes),
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
            vr::RESIDUAL_MODES => {
                if value < 0 {
                    return Err(ModelError::error(format!(
                        "residual_modes = {value}: expected 0 or more (at most the modal table's linear modes)"
                    )));
                }
                self.residual_modes = value;
                self.parameters_changed();
                Ok(())
            }
            _ => Err(ModelError::error(format!(
                "no Integer variable with value reference {vr}"
            ))),
        }
    }

    fn get_boolean(&self, vr: u32) -> Result<bool, ModelError> {
        match vr {
            vr::HARMONIC_FORCE_PROJECTION => Ok(self.harmonic_force_projection),
            _ => Err(ModelError::error(format!(
                "no Boolean variable with value reference {vr}"
            ))),
        }
    }

    fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), ModelError> {
        match vr {
            vr::HARMONIC_FORCE_PROJECTION => {
                self.harmonic_force_projection = value;
                self.parameters_changed();
                Ok(())
            }
            _ => Err(ModelError::error(format!(
                "no Boolean variable with value reference {vr}"
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
        self.input_advanced(h);
        self.update_outputs()
    }

    /// The structure returns early at the end of its modal table.
    const MIGHT_RETURN_EARLY: bool = true;

    /// FMI 3.0 with `earlyReturnAllowed`: [`Self::do_step`], except that a
    /// step in which the modal amplitude would leave the modal table stops
    /// at the last RK4 sub-step inside it
    /// ([`ModalOscillator::step_to_table_end`]) and returns early there with
    /// `terminateSimulation` (the mode, hence the model, is not known above
    /// the table's last amplitude), the reason logged.
    fn do_step_early(&mut self, t: f64, h: f64, log: &Logger) -> Result<StepOutcome, ModelError> {
        let osc = self
            .osc
            .as_mut()
            .ok_or_else(|| ModelError::error("not initialized"))?;
        let end = osc.step_to_table_end(h, self.force)?;
        let StepEnd::TableEnd {
            elapsed_s,
            a,
            a_max,
            ..
        } = end
        else {
            self.input_advanced(h);
            self.update_outputs()?;
            return Ok(StepOutcome::Completed);
        };
        self.input_advanced(elapsed_s);
        self.update_outputs()?;
        let time_s = t + elapsed_s;
        log.warning(&format!(
            "fmi3DoStep: returning early at t = {time_s:.9} s (step [{t}, {}] s): the modal amplitude \
             would reach a = {a:.6e} sqrt(kg) m in the next RK4 sub-step, above the modal table's end \
             a_max = {a_max:.6e} sqrt(kg) m, where the nonlinear mode is not known; the state is left \
             at the last sub-step inside the table (a = {:.6e}) and the simulation must end here \
             (terminateSimulation; extend the modal analysis or lower the excitation)",
            t + h,
            self.out.a
        ));
        Ok(StepOutcome::EarlyReturn {
            time_s,
            terminate: true,
        })
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
        self.single_mode_for_model_exchange()?;
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
        self.single_mode_for_model_exchange()?;
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

    /// Partial derivatives (`fmi2GetDirectionalDerivative`,
    /// `fmi3GetDirectionalDerivative`) at the current state and input `F`
    /// (before initialization at the start state `eta = u = 0`):
    /// * `der(eta)`, `der(u)` with respect to `eta`, `u`, `F`: the exact
    ///   Jacobian of the normal form ([`ModalOscillator::jacobian`];
    ///   `d der(eta)/dF = 0`, structurally);
    /// * the outputs with respect to `F`: 0 (no direct feedthrough);
    /// * the outputs with respect to the states `eta`, `u` (Model Exchange):
    ///   `a` and `omega` exactly, `x`, `v`, `x_tip` by a central difference
    ///   of the oscillator's synthesis in the state with the step
    ///   `6e-6 max(a, 1e-3 a_max)` (truncation and round-off about 1e-11
    ///   relative; [`ModalOscillator::output_state_jacobian`]).
    ///
    /// Residual modes (Co-Simulation only) do not change `eta`, `u`. Any
    /// other pair is an error.
    fn partial_derivative(&self, unknown: u32, known: u32) -> Result<f64, ModelError> {
        let output = matches!(unknown, vr::X | vr::V | vr::X_TIP | vr::A | vr::OMEGA);
        let derivative = matches!(unknown, vr::DER_ETA | vr::DER_U);
        let state = matches!(known, vr::ETA | vr::U);
        // no output depends directly on the input F (ModelStructure dependencies="")
        if known == vr::F && output {
            return Ok(0.0);
        }
        if derivative && (state || known == vr::F) {
            let j = self.with_oscillator(|osc, _| Ok(osc.jacobian(self.force.c0)?))?;
            let row = usize::from(unknown == vr::DER_U);
            let col = match known {
                vr::ETA => 0,
                vr::U => 1,
                _ => 2,
            };
            return finite(j[row][col]);
        }
        if output && state {
            let col = usize::from(known == vr::U);
            let d = self.with_oscillator(|osc, tip| {
                let mut p = [[[0.0; 2]; 2]; 2];
                let m = osc.output_state_jacobian(&[osc.drive_index(), tip], &mut p)?;
                Ok(match unknown {
                    vr::X => p[0][0][col],
                    vr::V => p[0][1][col],
                    vr::X_TIP => p[1][0][col],
                    vr::A => m[0][col],
                    _ => m[1][col],
                })
            })?;
            return finite(d);
        }
        // e.g. F = 1e300: the force's term of d der(u)/d a overflows
        fn finite(d: f64) -> Result<f64, ModelError> {
            if d.is_finite() {
                Ok(d)
            } else {
                Err(ModelError::error(format!(
                    "directional derivative: the partial derivative is {d} (input F too large?)"
                )))
            }
        }
        Err(ModelError::error(format!(
            "directional derivative d(vr {unknown})/d(vr {known}) is not available (only der(eta), der(u) and the outputs w.r.t. F, eta, u)"
        )))
    }

    const STRUCTURAL_PARAMETERS: &'static [StructuralParameter] = STRUCTURAL_PARAMETERS;
    const ARRAY_OUTPUTS: &'static [ArrayOutput] = ARRAY_OUTPUTS;

    fn get_uint64(&self, vr: u32) -> Result<u64, ModelError> {
        match vr {
            vr::MODE_SHAPE_POINTS => Ok(self.mode_shape_points),
            _ => Err(ModelError::error(format!(
                "no UInt64 variable with value reference {vr}"
            ))),
        }
    }

    fn set_uint64(&mut self, vr: u32, value: u64) -> Result<(), ModelError> {
        match vr {
            vr::MODE_SHAPE_POINTS => {
                self.mode_shape_points = value;
                Ok(())
            }
            _ => Err(ModelError::error(format!(
                "no UInt64 variable with value reference {vr}"
            ))),
        }
    }

    /// `mode_shape_re`, `mode_shape_im` at the current state (before
    /// initialization: the start state, `a = 0`, the table's first
    /// amplitude's shape times 0) from
    /// [`ModalOscillator::fundamental_displacements`]; a table whose point
    /// count is not `mode_shape_points` is an error naming both.
    fn get_array(&self, vr: u32, out: &mut [f64]) -> Result<(), ModelError> {
        let name = match vr {
            vr::MODE_SHAPE_RE => "mode_shape_re",
            vr::MODE_SHAPE_IM => "mode_shape_im",
            _ => {
                return Err(ModelError::error(format!(
                    "no array variable with value reference {vr}"
                )))
            }
        };
        self.with_oscillator(|osc, _| {
            let n = osc.point_count();
            if n != out.len() {
                return Err(ModelError::error(format!(
                    "{name}: the modal table has {n} points but the structural parameter \
                     mode_shape_points = {} (set mode_shape_points = {n} in Configuration Mode, or \
                     package the FMU with this table)",
                    out.len()
                )));
            }
            let mut q = vec![nlmode::Complex64::new(0.0, 0.0); n];
            osc.fundamental_displacements(&mut q)?;
            for (o, q) in out.iter_mut().zip(&q) {
                *o = if vr == vr::MODE_SHAPE_RE { q.re } else { q.im };
            }
            Ok(())
        })
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
            let q = osc.residual_state();
            w.u64(q.len() as u64);
            for &v in q {
                w.f64(v);
            }
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
            let nq = r.u64()?;
            if nq != osc.residual_state().len() as u64 {
                return Err(ModelError::error(format!(
                    "FMU state with {nq} residual-mode states, this instance has {} ({} residual modes)",
                    osc.residual_state().len(),
                    osc.residual_modes()
                )));
            }
            let q = (0..nq).map(|_| r.f64()).collect::<Result<Vec<f64>, _>>()?;
            osc.set_residual_state(&q)?;
        }
        self.update_outputs()
    }
}
