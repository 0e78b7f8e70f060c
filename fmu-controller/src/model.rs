//! The controller FMU's variables, parameters and FMU state, mapped onto
//! [`nlmode::control::StreamingPll`].
use fmi2_export::{
    Capabilities, Causality as C, CoSimModel, DefaultExperiment, Dependencies, InstantiateContext,
    Logger, ModelError, ModelInfo, ModelStructure, StateReader, StateWriter, StepOutcome,
    VarType as T, Variability as V, Variable, LOG_CATEGORY_DESCRIPTIONS,
};
use nlmode::control::{PllLevel, PllOptions, StreamEvent, StreamSample, StreamingPll};

/// GUID of the FMU (written here only; the modelDescription is rendered from it).
pub const GUID: &str = "{3e9b7c21-5d4a-4f08-b6e2-9a1c7d30f5b8}";

// Value references. Parameters (Real 0-7, Integer 8-11), inputs (Real 20-23),
// outputs (Real 30-40, Boolean 41-42, Integer 43), harmonics (Real 100-135:
// `100 + 12 s + 2 h + part`, signal s = F, x_drive, x_tip, harmonic h = 0..5,
// part 0 = re, 1 = im).
pub const VR_U_HAT: u32 = 0;
pub const VR_OMEGA_START: u32 = 1;
pub const VR_KP: u32 = 2;
pub const VR_KI: u32 = 3;
pub const VR_MAX_STEP_RATIO: u32 = 4;
pub const VR_PHASE_TOL: u32 = 5;
pub const VR_AMPLITUDE_TOL: u32 = 6;
pub const VR_DRIVE_MASS: u32 = 7;
/// Integer.
pub const VR_SETTLE_PERIODS: u32 = 8;
/// Integer.
pub const VR_MAX_PERIODS: u32 = 9;
/// Integer.
pub const VR_HARMONICS: u32 = 10;
/// Integer.
pub const VR_SAMPLES: u32 = 11;
pub const VR_F_MEAS: u32 = 20;
pub const VR_X_DRIVE: u32 = 21;
pub const VR_X_TIP: u32 = 22;
pub const VR_I_MEAS: u32 = 23;
pub const VR_U_EXT: u32 = 30;
pub const VR_OMEGA: u32 = 31;
pub const VR_THETA: u32 = 32;
pub const VR_PHASE_ERROR: u32 = 33;
pub const VR_AMPLITUDE_CHANGE: u32 = 34;
pub const VR_DAMPING: u32 = 35;
pub const VR_POWER: u32 = 36;
pub const VR_I_AMPLITUDE: u32 = 37;
pub const VR_RECORD_VOLTAGE: u32 = 38;
pub const VR_RECORD_OMEGA: u32 = 39;
pub const VR_RECORD_TIME: u32 = 40;
/// Boolean.
pub const VR_SETTLED: u32 = 41;
/// Boolean.
pub const VR_LEVEL_DONE: u32 = 42;
/// Integer.
pub const VR_PERIODS: u32 = 43;
/// First value reference of the harmonics' real and imaginary parts.
pub const VR_HARMONICS_BASE: u32 = 100;
/// Highest harmonic with outputs.
pub const MAX_HARMONICS: usize = 5;

/// Value reference of harmonic `h` (`0..=MAX_HARMONICS`) of signal `s` (0 =
/// `F`, 1 = `x_drive`, 2 = `x_tip`); `+ 1` for the imaginary part.
pub const fn vr_harmonic(s: u32, h: u32) -> u32 {
    VR_HARMONICS_BASE + 12 * s + 2 * h
}

/// All variables, in the order of their indices (the single source of the
/// modelDescription's `<ModelVariables>`).
pub const VARIABLES: &[Variable] = &[
    Variable::real("u_hat", VR_U_HAT, C::Parameter, V::Tunable, Some(1.0), "V")
        .describe("voltage amplitude of the level (applied from the next period start; a new value starts a new level)"),
    Variable::real("omega_start", VR_OMEGA_START, C::Parameter, V::Fixed, Some(356.2), "rad/s")
        .describe("start frequency of the loop (e.g. the linear natural frequency)"),
    Variable::real("kp", VR_KP, C::Parameter, V::Fixed, Some(0.001), "1/rad")
        .describe("proportional gain k_p: relative frequency change per rad of phase-error change"),
    Variable::real("ki", VR_KI, C::Parameter, V::Fixed, Some(0.001), "1/rad")
        .describe("integral gain k_i: relative frequency change per rad of phase error per period"),
    Variable::real("max_step_ratio", VR_MAX_STEP_RATIO, C::Parameter, V::Fixed, Some(0.002), "1")
        .describe("largest relative frequency change per period"),
    Variable::real("phase_tolerance", VR_PHASE_TOL, C::Parameter, V::Fixed, Some(0.001), "rad")
        .describe("phase-error tolerance of the settle criterion"),
    Variable::real("amplitude_tolerance", VR_AMPLITUDE_TOL, C::Parameter, V::Fixed, Some(0.0001), "1")
        .describe("tolerance on the relative change of |x_drive,1| per period"),
    Variable::real("drive_modal_mass", VR_DRIVE_MASS, C::Parameter, V::Fixed, Some(1.0), "kg")
        .describe("modal mass at the drive point 1/|phi_d|^2 of the power-balance damping"),
    Variable::integer_parameter("settle_periods", VR_SETTLE_PERIODS, 10)
        .describe("consecutive periods inside both tolerances to count as settled"),
    Variable::integer_parameter("max_periods_per_level", VR_MAX_PERIODS, 3000)
        .describe("periods per level before it is given up as not settled"),
    Variable::integer_parameter("harmonics", VR_HARMONICS, 5)
        .describe("harmonics demodulated (1..5; the outputs above it are 0)"),
    Variable::integer_parameter("samples_per_period", VR_SAMPLES, 40)
        .describe("uniform phases N per period of the demodulation (2 (harmonics + 1)..1000)"),
    Variable::real("F_meas", VR_F_MEAS, C::Input, V::Continuous, Some(0.0), "N")
        .describe("measured force on the structure at the drive point (force sensor; positive along positive x_drive)"),
    Variable::real("x_drive", VR_X_DRIVE, C::Input, V::Continuous, Some(0.0), "m")
        .describe("measured drive-point displacement"),
    Variable::real("x_tip", VR_X_TIP, C::Input, V::Continuous, Some(0.0), "m")
        .describe("response-point displacement (recorded only)"),
    Variable::real("I_meas", VR_I_MEAS, C::Input, V::Continuous, Some(0.0), "A")
        .describe("coil current (recorded only)"),
    Variable::real("u_ext", VR_U_EXT, C::Output, V::Continuous, None, "V")
        .describe("voltage command u_hat cos(theta) for the shaker's external voltage input"),
    Variable::real("Omega", VR_OMEGA, C::Output, V::Continuous, None, "rad/s")
        .describe("excitation frequency of the running period"),
    Variable::real("theta", VR_THETA, C::Output, V::Continuous, None, "rad")
        .describe("excitation phase within the running period"),
    Variable::real("phase_error", VR_PHASE_ERROR, C::Output, V::Continuous, None, "rad")
        .describe("phase error pi/2 - (arg F_1 - arg x_drive,1) of the last period"),
    Variable::real("amplitude_change", VR_AMPLITUDE_CHANGE, C::Output, V::Continuous, None, "1")
        .describe("relative change of |x_drive,1| in the last period"),
    Variable::real("damping_ratio", VR_DAMPING, C::Output, V::Continuous, None, "1")
        .describe("modal damping ratio from the power balance of the last period"),
    Variable::real("power", VR_POWER, C::Output, V::Continuous, None, "W")
        .describe("mean input power at the drive point in the last period"),
    Variable::real("I_amplitude", VR_I_AMPLITUDE, C::Output, V::Continuous, None, "A")
        .describe("fundamental amplitude of the coil current in the last period"),
    Variable::real("record_voltage", VR_RECORD_VOLTAGE, C::Output, V::Continuous, None, "V")
        .describe("voltage amplitude of the last period"),
    Variable::real("record_Omega", VR_RECORD_OMEGA, C::Output, V::Continuous, None, "rad/s")
        .describe("excitation frequency of the last period"),
    Variable::real("record_time", VR_RECORD_TIME, C::Output, V::Continuous, None, "s")
        .describe("time at the end of the last period"),
    Variable::discrete_output("settled", VR_SETTLED, T::Boolean)
        .describe("the last period met the settle criterion"),
    Variable::discrete_output("level_done", VR_LEVEL_DONE, T::Boolean)
        .describe("the level settled or ran out of periods (latched until u_hat changes)"),
    Variable::discrete_output("periods", VR_PERIODS, T::Integer)
        .describe("periods completed on the running level"),
    Variable::real("F_h0_re", vr_harmonic(0, 0), C::Output, V::Continuous, None, "N")
        .describe("real part of harmonic 0 of the force F_meas over the last period"),
    Variable::real("F_h0_im", vr_harmonic(0, 0) + 1, C::Output, V::Continuous, None, "N")
        .describe("imaginary part of harmonic 0 of the force F_meas over the last period"),
    Variable::real("F_h1_re", vr_harmonic(0, 1), C::Output, V::Continuous, None, "N")
        .describe("real part of harmonic 1 of the force F_meas over the last period"),
    Variable::real("F_h1_im", vr_harmonic(0, 1) + 1, C::Output, V::Continuous, None, "N")
        .describe("imaginary part of harmonic 1 of the force F_meas over the last period"),
    Variable::real("F_h2_re", vr_harmonic(0, 2), C::Output, V::Continuous, None, "N")
        .describe("real part of harmonic 2 of the force F_meas over the last period"),
    Variable::real("F_h2_im", vr_harmonic(0, 2) + 1, C::Output, V::Continuous, None, "N")
        .describe("imaginary part of harmonic 2 of the force F_meas over the last period"),
    Variable::real("F_h3_re", vr_harmonic(0, 3), C::Output, V::Continuous, None, "N")
        .describe("real part of harmonic 3 of the force F_meas over the last period"),
    Variable::real("F_h3_im", vr_harmonic(0, 3) + 1, C::Output, V::Continuous, None, "N")
        .describe("imaginary part of harmonic 3 of the force F_meas over the last period"),
    Variable::real("F_h4_re", vr_harmonic(0, 4), C::Output, V::Continuous, None, "N")
        .describe("real part of harmonic 4 of the force F_meas over the last period"),
    Variable::real("F_h4_im", vr_harmonic(0, 4) + 1, C::Output, V::Continuous, None, "N")
        .describe("imaginary part of harmonic 4 of the force F_meas over the last period"),
    Variable::real("F_h5_re", vr_harmonic(0, 5), C::Output, V::Continuous, None, "N")
        .describe("real part of harmonic 5 of the force F_meas over the last period"),
    Variable::real("F_h5_im", vr_harmonic(0, 5) + 1, C::Output, V::Continuous, None, "N")
        .describe("imaginary part of harmonic 5 of the force F_meas over the last period"),
    Variable::real("x_drive_h0_re", vr_harmonic(1, 0), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 0 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h0_im", vr_harmonic(1, 0) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 0 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h1_re", vr_harmonic(1, 1), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 1 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h1_im", vr_harmonic(1, 1) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 1 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h2_re", vr_harmonic(1, 2), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 2 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h2_im", vr_harmonic(1, 2) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 2 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h3_re", vr_harmonic(1, 3), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 3 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h3_im", vr_harmonic(1, 3) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 3 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h4_re", vr_harmonic(1, 4), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 4 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h4_im", vr_harmonic(1, 4) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 4 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h5_re", vr_harmonic(1, 5), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 5 of the drive-point displacement over the last period"),
    Variable::real("x_drive_h5_im", vr_harmonic(1, 5) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 5 of the drive-point displacement over the last period"),
    Variable::real("x_tip_h0_re", vr_harmonic(2, 0), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 0 of the response-point displacement over the last period"),
    Variable::real("x_tip_h0_im", vr_harmonic(2, 0) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 0 of the response-point displacement over the last period"),
    Variable::real("x_tip_h1_re", vr_harmonic(2, 1), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 1 of the response-point displacement over the last period"),
    Variable::real("x_tip_h1_im", vr_harmonic(2, 1) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 1 of the response-point displacement over the last period"),
    Variable::real("x_tip_h2_re", vr_harmonic(2, 2), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 2 of the response-point displacement over the last period"),
    Variable::real("x_tip_h2_im", vr_harmonic(2, 2) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 2 of the response-point displacement over the last period"),
    Variable::real("x_tip_h3_re", vr_harmonic(2, 3), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 3 of the response-point displacement over the last period"),
    Variable::real("x_tip_h3_im", vr_harmonic(2, 3) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 3 of the response-point displacement over the last period"),
    Variable::real("x_tip_h4_re", vr_harmonic(2, 4), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 4 of the response-point displacement over the last period"),
    Variable::real("x_tip_h4_im", vr_harmonic(2, 4) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 4 of the response-point displacement over the last period"),
    Variable::real("x_tip_h5_re", vr_harmonic(2, 5), C::Output, V::Continuous, None, "m")
        .describe("real part of harmonic 5 of the response-point displacement over the last period"),
    Variable::real("x_tip_h5_im", vr_harmonic(2, 5) + 1, C::Output, V::Continuous, None, "m")
        .describe("imaginary part of harmonic 5 of the response-point displacement over the last period"),
];

/// The rest of the modelDescription. `<ModelStructure>`: the inputs are
/// sampled at the start of a step, so no output feeds through; at the start
/// `u_ext = u_hat cos(0)`, `Omega = omega_start` and the records are 0.
pub const INFO: ModelInfo = ModelInfo {
    name: "controller",
    description: "Phase-locked loop for phase-resonant testing (Scheel 2018): demodulates the measured force and drive-point displacement over each excitation period and drives the shaker's external voltage u_ext = u_hat cos(theta) towards 90 degrees lag; Krack, exciter-structure interaction, issue 16",
    version: Some("0.1.0"),
    generation_tool: "fmi2 (Rust workspace nlmode)",
    capabilities: Capabilities {
        can_handle_variable_communication_step_size: true,
        can_interpolate_inputs: false,
        max_output_derivative_order: 1,
        provides_directional_derivative: true,
    },
    units: &[],
    log_categories: LOG_CATEGORY_DESCRIPTIONS,
    default_experiment: DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(2.0),
        tolerance: None,
        step_size: Some(1e-5),
    },
    model_structure: ModelStructure {
        outputs: &[],
        derivatives: &[],
        initial_unknowns: &[
            Dependencies::on("u_ext", &["u_hat"]),
            Dependencies::on("Omega", &["omega_start"]),
        ],
    },
};

/// Range of each Real parameter, checked at `fmi2ExitInitializationMode`
/// (value reference, name, min, max, unit).
pub const PARAMETER_RANGES: &[(u32, &str, f64, f64, &str)] = &[
    (VR_U_HAT, "u_hat", 0.0, 1e4, "V"),
    (VR_OMEGA_START, "omega_start", 1e-3, 1e7, "rad/s"),
    (VR_KP, "kp", 0.0, 1.0, "1/rad"),
    (VR_KI, "ki", 1e-12, 1.0, "1/rad"),
    (VR_MAX_STEP_RATIO, "max_step_ratio", 1e-12, 0.49, "1"),
    (VR_PHASE_TOL, "phase_tolerance", 1e-12, 1.0, "rad"),
    (VR_AMPLITUDE_TOL, "amplitude_tolerance", 1e-12, 1.0, "1"),
    (VR_DRIVE_MASS, "drive_modal_mass", 1e-12, 1e12, "kg"),
];

/// Range of each Integer parameter (value reference, name, min, max); the
/// lower bound of `samples_per_period` is `2 (harmonics + 1)`.
pub const INTEGER_RANGES: &[(u32, &str, i32, i32)] = &[
    (VR_SETTLE_PERIODS, "settle_periods", 1, 1_000_000),
    (VR_MAX_PERIODS, "max_periods_per_level", 1, 100_000_000),
    (VR_HARMONICS, "harmonics", 1, MAX_HARMONICS as i32),
    (VR_SAMPLES, "samples_per_period", 4, 1000),
];

/// The controller FMU model.
#[derive(Debug, Clone)]
pub struct Controller {
    pub u_hat: f64,
    pub omega_start: f64,
    pub kp: f64,
    pub ki: f64,
    pub max_step_ratio: f64,
    pub phase_tolerance: f64,
    pub amplitude_tolerance: f64,
    pub drive_modal_mass: f64,
    pub settle_periods: i32,
    pub max_periods_per_level: i32,
    pub harmonics: i32,
    pub samples_per_period: i32,
    inputs: StreamSample,
    t: f64,
    /// The loop once initialized.
    pll: Option<StreamingPll>,
}

impl Controller {
    /// The modelDescription start values.
    pub fn new() -> Self {
        let o = PllOptions::default();
        Self {
            u_hat: 1.0,
            omega_start: 356.2,
            kp: o.kp,
            ki: o.ki,
            max_step_ratio: o.max_step_ratio,
            phase_tolerance: o.phase_tolerance_rad,
            amplitude_tolerance: o.amplitude_tolerance,
            drive_modal_mass: 1.0,
            settle_periods: o.settle_periods as i32,
            max_periods_per_level: o.max_periods_per_level as i32,
            harmonics: o.harmonics as i32,
            samples_per_period: 40,
            inputs: StreamSample::default(),
            t: 0.0,
            pll: None,
        }
    }

    /// The loop options of the parameters (after [`Self::check_parameters`]).
    pub fn options(&self) -> PllOptions {
        PllOptions {
            kp: self.kp,
            ki: self.ki,
            max_step_ratio: self.max_step_ratio,
            phase_tolerance_rad: self.phase_tolerance,
            amplitude_tolerance: self.amplitude_tolerance,
            settle_periods: self.settle_periods as usize,
            max_periods_per_level: self.max_periods_per_level as usize,
            harmonics: self.harmonics as usize,
        }
    }

    /// Every parameter inside its range; the message names it, its value and the range.
    pub fn check_parameters(&self) -> Result<(), ModelError> {
        for &(vr, name, lo, hi, unit) in PARAMETER_RANGES {
            let v = self.get_real(vr);
            if !(lo..=hi).contains(&v) {
                return Err(ModelError::error(format!(
                    "{name} = {v:e} {unit} is outside its range [{lo:e}, {hi:e}] {unit}"
                )));
            }
        }
        for &(vr, name, lo, hi) in INTEGER_RANGES {
            let v = self.get_integer(vr)?;
            let lo = if vr == VR_SAMPLES {
                2 * (self.harmonics.clamp(1, MAX_HARMONICS as i32) + 1)
            } else {
                lo
            };
            if !(lo..=hi).contains(&v) {
                return Err(ModelError::error(format!(
                    "{name} = {v} is outside its range [{lo}, {hi}]"
                )));
            }
        }
        Ok(())
    }

    /// The running loop (after initialization).
    pub fn pll(&self) -> Option<&StreamingPll> {
        self.pll.as_ref()
    }

    /// One communication step of the loop from `t` by `h` (FMI 2.0 and FMI
    /// 3.0 `do_step`); with `stop`, stopped at a level change inside it
    /// (returns its time, [`StreamingPll::step_to_level_change`]). The
    /// first period without signal and the first measured one after them
    /// are logged.
    fn step_loop(
        &mut self,
        t: f64,
        h: f64,
        log: &Logger,
        stop: bool,
    ) -> Result<Option<f64>, ModelError> {
        let p = self
            .pll
            .as_mut()
            .ok_or_else(|| ModelError::error("the loop is built at fmi2ExitInitializationMode"))?;
        let held_before = p.unmeasured_periods();
        let mut next = p.clone();
        let (event, stopped) = if stop {
            next.step_to_level_change(t, h, self.inputs)
        } else {
            next.step(t, h, self.inputs).map(|e| (e, None))
        }
        .map_err(control_error)?;
        *p = next;
        let end = stopped.unwrap_or(t + h);
        self.t = end;
        let held = p.unmeasured_periods();
        if event == StreamEvent::Unmeasured && held_before == 0 {
            log.info(&format!(
                "the period ending at t = {end:e} s had no measurable force or drive-point fundamental \
                 (F_meas and x_drive without a component at Omega, e.g. all inputs 0 before the exciter is on): \
                 Omega held at {} rad/s, damping and harmonics held at the last measured period, \
                 u_ext goes on at the held frequency until a period with signal",
                p.omega_rad_s()
            ));
        } else if held == 0 && held_before > 0 {
            log.info(&format!(
                "signal measured again in the period ending by t = {end:e} s after {held_before} period(s) without; \
                 the loop runs"
            ));
        }
        Ok(stopped)
    }

    fn record(&self) -> Option<&PllLevel> {
        self.pll.as_ref().and_then(|p| p.last_period())
    }

    fn harmonic(&self, vr: u32) -> f64 {
        let k = vr - VR_HARMONICS_BASE;
        let (s, h, part) = ((k / 12) as usize, ((k % 12) / 2) as usize, k % 2);
        let Some(r) = self.record() else { return 0.0 };
        let sig = [
            &r.harmonics.force_n,
            &r.harmonics.drive_m,
            &r.harmonics.tip_m,
        ][s];
        sig.get(h)
            .map_or(0.0, |c| if part == 0 { c.re } else { c.im })
    }
}

impl Default for Controller {
    fn default() -> Self {
        Self::new()
    }
}

fn bad_vr(vr: u32) -> ModelError {
    ModelError::error(format!(
        "value reference {vr} is not handled by the controller"
    ))
}

fn control_error(e: nlmode::control::ControlError) -> ModelError {
    ModelError::error(e.to_string())
}

impl CoSimModel for Controller {
    const MODEL_IDENTIFIER: &'static str = "controller";
    const GUID: &'static str = GUID;
    const VARIABLES: &'static [Variable] = VARIABLES;
    const INFO: ModelInfo = INFO;

    fn instantiate(_ctx: &InstantiateContext<'_>) -> Result<Self, ModelError> {
        Ok(Self::new())
    }

    fn setup_experiment(&mut self, start_time: f64, _stop: Option<f64>) -> Result<(), ModelError> {
        self.t = start_time;
        Ok(())
    }

    fn exit_initialization_mode(&mut self, _log: &Logger) -> Result<(), ModelError> {
        self.check_parameters()?;
        self.pll = Some(
            StreamingPll::new(
                self.options(),
                self.omega_start,
                self.u_hat,
                self.drive_modal_mass,
                self.samples_per_period as usize,
            )
            .map_err(control_error)?,
        );
        Ok(())
    }

    fn get_real(&self, vr: u32) -> f64 {
        let r = self.record();
        let rec = |f: fn(&PllLevel) -> f64| r.map_or(0.0, f);
        match vr {
            VR_U_HAT => self.u_hat,
            VR_OMEGA_START => self.omega_start,
            VR_KP => self.kp,
            VR_KI => self.ki,
            VR_MAX_STEP_RATIO => self.max_step_ratio,
            VR_PHASE_TOL => self.phase_tolerance,
            VR_AMPLITUDE_TOL => self.amplitude_tolerance,
            VR_DRIVE_MASS => self.drive_modal_mass,
            VR_F_MEAS => self.inputs.force_n,
            VR_X_DRIVE => self.inputs.drive_m,
            VR_X_TIP => self.inputs.tip_m,
            VR_I_MEAS => self.inputs.current_a,
            VR_U_EXT => self.pll.as_ref().map_or(self.u_hat, |p| p.output_v()),
            VR_OMEGA => self
                .pll
                .as_ref()
                .map_or(self.omega_start, |p| p.omega_rad_s()),
            VR_THETA => self.pll.as_ref().map_or(0.0, |p| p.phase_rad()),
            VR_PHASE_ERROR => rec(|l| l.phase_error_rad),
            VR_AMPLITUDE_CHANGE => rec(|l| {
                if l.amplitude_change.is_finite() {
                    l.amplitude_change
                } else {
                    1.0
                }
            }),
            VR_DAMPING => rec(|l| l.damping_ratio),
            VR_POWER => rec(|l| l.power_w),
            VR_I_AMPLITUDE => rec(|l| l.harmonics.current_amplitude_a),
            VR_RECORD_VOLTAGE => rec(|l| l.voltage_v),
            VR_RECORD_OMEGA => rec(|l| l.omega_rad_s),
            VR_RECORD_TIME => rec(|l| l.time_s),
            v if (VR_HARMONICS_BASE..VR_HARMONICS_BASE + 36).contains(&v) => self.harmonic(v),
            _ => f64::NAN, // unreachable: the layer only passes Real vrs of VARIABLES
        }
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            VR_U_HAT => {
                if let Some(p) = &mut self.pll {
                    let (lo, hi) = (PARAMETER_RANGES[0].2, PARAMETER_RANGES[0].3);
                    if !(lo..=hi).contains(&value) {
                        return Err(ModelError::error(format!(
                            "u_hat = {value:e} V is outside its range [{lo:e}, {hi:e}] V"
                        )));
                    }
                    p.set_voltage(value).map_err(control_error)?;
                }
                self.u_hat = value;
            }
            VR_OMEGA_START => self.omega_start = value,
            VR_KP => self.kp = value,
            VR_KI => self.ki = value,
            VR_MAX_STEP_RATIO => self.max_step_ratio = value,
            VR_PHASE_TOL => self.phase_tolerance = value,
            VR_AMPLITUDE_TOL => self.amplitude_tolerance = value,
            VR_DRIVE_MASS => self.drive_modal_mass = value,
            VR_F_MEAS => self.inputs.force_n = value,
            VR_X_DRIVE => self.inputs.drive_m = value,
            VR_X_TIP => self.inputs.tip_m = value,
            VR_I_MEAS => self.inputs.current_a = value,
            _ => return Err(bad_vr(vr)),
        }
        Ok(())
    }

    fn get_integer(&self, vr: u32) -> Result<i32, ModelError> {
        Ok(match vr {
            VR_SETTLE_PERIODS => self.settle_periods,
            VR_MAX_PERIODS => self.max_periods_per_level,
            VR_HARMONICS => self.harmonics,
            VR_SAMPLES => self.samples_per_period,
            VR_PERIODS => self
                .pll
                .as_ref()
                .map_or(0, |p| i32::try_from(p.periods()).unwrap_or(i32::MAX)),
            _ => return Err(bad_vr(vr)),
        })
    }

    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), ModelError> {
        match vr {
            VR_SETTLE_PERIODS => self.settle_periods = value,
            VR_MAX_PERIODS => self.max_periods_per_level = value,
            VR_HARMONICS => self.harmonics = value,
            VR_SAMPLES => self.samples_per_period = value,
            _ => return Err(bad_vr(vr)),
        }
        Ok(())
    }

    fn get_boolean(&self, vr: u32) -> Result<bool, ModelError> {
        let p = self.pll.as_ref();
        match vr {
            VR_SETTLED => Ok(p.is_some_and(|p| p.settled())),
            VR_LEVEL_DONE => Ok(p.is_some_and(|p| p.level_done())),
            _ => Err(bad_vr(vr)),
        }
    }

    /// Samples the inputs at `t` (the start of the step), then advances the
    /// phase to `t + h`; a period completed by the sample updates `Omega`.
    /// A step longer than 1/8 of the excitation period is split into internal
    /// steps over which the inputs are held ([`StreamingPll::step`]). A
    /// period without signal (inputs 0) holds the loop; the first such period
    /// and the first measured period after them are logged.
    fn do_step(&mut self, t: f64, h: f64, log: &Logger) -> Result<(), ModelError> {
        self.step_loop(t, h, log, false).map(|_| ())
    }

    /// The controller returns early at a level change.
    const MIGHT_RETURN_EARLY: bool = true;

    /// FMI 3.0 with `earlyReturnAllowed`: [`Self::do_step`], except that a
    /// level change at an internal sample of a long step (the level done,
    /// or a new `u_hat` starting its level, [`StreamingPll::step_to_level_change`])
    /// ends the step there, so that the master has a communication point at
    /// the period end where it reads the record and sets the next `u_hat`;
    /// the next `fmi3DoStep` goes on from there.
    fn do_step_early(&mut self, t: f64, h: f64, log: &Logger) -> Result<StepOutcome, ModelError> {
        Ok(match self.step_loop(t, h, log, true)? {
            None => StepOutcome::Completed,
            Some(time_s) => {
                let p = self.pll.as_ref().expect("stepped");
                log.info(&format!(
                    "fmi3DoStep: returning early at t = {time_s:e} s (step [{t}, {}] s): the period ending \
                     there {} (u_hat = {} V, Omega = {} rad/s)",
                    t + h,
                    if p.level_done() {
                        "finished the level (level_done)"
                    } else {
                        "started a new level"
                    },
                    p.voltage_v(),
                    p.omega_rad_s()
                ));
                StepOutcome::EarlyReturn {
                    time_s,
                    terminate: false,
                }
            }
        })
    }
    /// `d u_ext / dt = -u_hat Omega sin(theta)`, `d theta / dt = Omega`, the
    /// rest piecewise constant (0).
    fn get_real_output_derivative(&self, vr: u32, order: u32) -> Result<f64, ModelError> {
        if order != 1 {
            return Err(ModelError::error(format!(
                "only first-order output derivatives are available, got order {order} for value reference {vr}"
            )));
        }
        let p = self.pll.as_ref();
        Ok(match vr {
            VR_U_EXT => p.map_or(0.0, |p| p.output_rate_v_per_s()),
            VR_THETA => p.map_or(self.omega_start, |p| p.omega_rad_s()),
            v if VARIABLES
                .iter()
                .any(|x| x.vr == v && x.causality == C::Output && x.ty == T::Real) =>
            {
                0.0
            }
            _ => return Err(bad_vr(vr)),
        })
    }

    /// No output depends directly on an input (all zero).
    fn partial_derivative(&self, unknown: u32, known: u32) -> Result<f64, ModelError> {
        let is = |vr: u32, c: C| VARIABLES.iter().any(|x| x.vr == vr && x.causality == c);
        if is(unknown, C::Output) && is(known, C::Input) {
            Ok(0.0)
        } else {
            Err(ModelError::error(format!(
                "directional derivatives are provided for outputs with respect to inputs only, not d{unknown}/d{known}"
            )))
        }
    }

    fn serialize_state(&self, w: &mut StateWriter) {
        w.f64s(&[
            self.u_hat,
            self.omega_start,
            self.kp,
            self.ki,
            self.max_step_ratio,
            self.phase_tolerance,
            self.amplitude_tolerance,
            self.drive_modal_mass,
            self.inputs.force_n,
            self.inputs.drive_m,
            self.inputs.tip_m,
            self.inputs.current_a,
            self.t,
        ]);
        for v in [
            self.settle_periods,
            self.max_periods_per_level,
            self.harmonics,
            self.samples_per_period,
        ] {
            w.u64(v as u32 as u64);
        }
        w.bool(self.pll.is_some());
        if let Some(p) = &self.pll {
            // the loop as JSON (exact floats), packed into little-endian u64 words
            let json = serde_json::to_vec(p).expect("the loop serializes");
            w.u64(json.len() as u64);
            for chunk in json.chunks(8) {
                let mut b = [0u8; 8];
                b[..chunk.len()].copy_from_slice(chunk);
                w.u64(u64::from_le_bytes(b));
            }
        }
    }

    fn deserialize_state(&mut self, r: &mut StateReader<'_>) -> Result<(), ModelError> {
        let v = r.f64s(13)?;
        let mut ints = [0i32; 4];
        for x in &mut ints {
            let u = r.u64()?;
            *x = u32::try_from(u)
                .map_err(|_| ModelError::error(format!("serialized FMU state: bad integer {u}")))?
                as i32;
        }
        let pll = if r.bool()? {
            let len = r.u64()?;
            // the loop's JSON is at most a few hundred kB (N <= 1000)
            if len > 1 << 24 {
                return Err(ModelError::error(format!(
                    "serialized FMU state: loop of {len} bytes"
                )));
            }
            let mut json = Vec::with_capacity(len as usize);
            for _ in 0..len.div_ceil(8) {
                json.extend_from_slice(&r.u64()?.to_le_bytes());
            }
            json.truncate(len as usize);
            let p: StreamingPll = serde_json::from_slice(&json).map_err(|e| {
                ModelError::error(format!("serialized FMU state: loop unreadable: {e}"))
            })?;
            Some(p.restored().map_err(control_error)?)
        } else {
            None
        };
        self.u_hat = v[0];
        self.omega_start = v[1];
        self.kp = v[2];
        self.ki = v[3];
        self.max_step_ratio = v[4];
        self.phase_tolerance = v[5];
        self.amplitude_tolerance = v[6];
        self.drive_modal_mass = v[7];
        self.inputs = StreamSample {
            force_n: v[8],
            drive_m: v[9],
            tip_m: v[10],
            current_a: v[11],
        };
        self.t = v[12];
        [
            self.settle_periods,
            self.max_periods_per_level,
            self.harmonics,
            self.samples_per_period,
        ] = ints;
        self.pll = pll;
        Ok(())
    }
}
