//! The shaker FMU's variables, parameters and FMU state, mapped onto
//! `nlmode`: the internal voltage source is an
//! [`nlmode::excitation::LinearSweep`], the physics and its exact stepping
//! are [`nlmode::attachment::ShakerStepper`].
use fmi2_export::{
    Capabilities, Causality as C, CoSimModel, ContinuousState, DefaultExperiment, Dependencies,
    InstantiateContext, Logger, ModelError, ModelInfo, ModelStructure, StateReader, StateWriter,
    Variability as V, Variable, LOG_CATEGORY_DESCRIPTIONS,
};
use nalgebra::{Matrix3, Matrix3x2, Vector2, Vector3};
pub use nlmode::attachment::MAX_PHASE_PER_SUBSTEP;
use nlmode::attachment::{
    sweep_substeps, ArmatureDamping, ShakerParams, ShakerStepper, Stinger, MAX_SWEEP_SUBSTEPS,
};
use nlmode::benchmark as bm;
use nlmode::excitation::{LinearSweep, SweepEnd, SweepError};

/// GUID of the FMU (written here only; the modelDescription is rendered from it).
pub const GUID: &str = "{8c4d2f6e-1b7a-4e3d-9f15-2a6b0c9e7d41}";

// Value references (Real unless noted). Tested against the XML.
pub const VR_L: u32 = 0;
pub const VR_R: u32 = 1;
pub const VR_G: u32 = 2;
pub const VR_M_A: u32 = 3;
pub const VR_K_A: u32 = 4;
pub const VR_D_A_RATIO: u32 = 5;
pub const VR_K_S: u32 = 6;
pub const VR_U_HAT: u32 = 7;
pub const VR_OMEGA_START: u32 = 8;
pub const VR_OMEGA_END: u32 = 9;
pub const VR_OMEGA_RATE: u32 = 10;
/// Boolean.
pub const VR_USE_EXTERNAL: u32 = 11;
pub const VR_D_A: u32 = 12;
pub const VR_X: u32 = 20;
pub const VR_V: u32 = 21;
pub const VR_U_EXT: u32 = 22;
pub const VR_F: u32 = 30;
pub const VR_I: u32 = 31;
pub const VR_Q_A: u32 = 32;
pub const VR_V_A: u32 = 33;
pub const VR_U: u32 = 34;
pub const VR_OMEGA: u32 = 35;
/// Derivatives of the continuous states `[I, q_a, v_a]` (Model Exchange).
pub const VR_DER_I: u32 = 40;
pub const VR_DER_Q_A: u32 = 41;
pub const VR_DER_V_A: u32 = 42;

/// The Model Exchange states `[I, q_a, v_a]` and their derivatives, with
/// nominal values of the paper's sweep (about 1 A, 0.1 mm, 0.1 m/s).
pub const CONTINUOUS_STATES: &[ContinuousState] = &[
    ContinuousState {
        state_vr: VR_I,
        derivative_vr: VR_DER_I,
        nominal: 1.0,
    },
    ContinuousState {
        state_vr: VR_Q_A,
        derivative_vr: VR_DER_Q_A,
        nominal: 1e-4,
    },
    ContinuousState {
        state_vr: VR_V_A,
        derivative_vr: VR_DER_V_A,
        nominal: 0.1,
    },
];

/// Default sweep: from 0.8 to 1.8 omega0 of the paper's beam (omega0 = 356.2
/// rad/s) at 2 % per pseudo period (`r omega0^2 / (2 pi)` = 404 rad/s^2).
pub const DEFAULT_OMEGA_START: f64 = 285.0;
pub const DEFAULT_OMEGA_END: f64 = 641.0;
pub const DEFAULT_OMEGA_RATE: f64 = 404.0;
pub const DEFAULT_U_HAT: f64 = 10.0;

/// All variables, in the order of their indices (the single source of the
/// modelDescription's `<ModelVariables>`).
pub const VARIABLES: &[Variable] = &[
    Variable::real("L", VR_L, C::Parameter, V::Fixed, Some(bm::SHAKER_L_H), "H")
        .describe("coil inductance"),
    Variable::real("R", VR_R, C::Parameter, V::Fixed, Some(bm::SHAKER_R_OHM), "Ohm")
        .describe("coil resistance"),
    Variable::real("G", VR_G, C::Parameter, V::Fixed, Some(bm::SHAKER_G_N_PER_A), "N/A")
        .describe("force constant (= back-EMF constant)"),
    Variable::real("m_a", VR_M_A, C::Parameter, V::Fixed, Some(bm::SHAKER_MA_KG), "kg")
        .describe("armature mass"),
    Variable::real("k_a", VR_K_A, C::Parameter, V::Fixed, Some(bm::SHAKER_KA_N_PER_M), "N/m")
        .describe("armature suspension stiffness"),
    Variable::real("D_a", VR_D_A_RATIO, C::Parameter, V::Fixed, Some(bm::SHAKER_DA), "1")
        .describe("total armature damping ratio, 2 D_a sqrt(k_a m_a) = d_a + G^2/R (electro-mechanical damping included)"),
    Variable::real("k_s", VR_K_S, C::Parameter, V::Fixed, Some(bm::STINGER_KS_N_PER_M), "N/m")
        .describe("stinger (push rod) stiffness"),
    Variable::real("u_hat", VR_U_HAT, C::Parameter, V::Fixed, Some(DEFAULT_U_HAT), "V")
        .describe("amplitude of the internal sine-sweep voltage"),
    Variable::real("Omega_start", VR_OMEGA_START, C::Parameter, V::Fixed, Some(DEFAULT_OMEGA_START), "rad/s")
        .describe("start frequency of the internal sweep"),
    Variable::real("Omega_end", VR_OMEGA_END, C::Parameter, V::Fixed, Some(DEFAULT_OMEGA_END), "rad/s")
        .describe("end frequency of the internal sweep (held afterwards)"),
    Variable::real("Omega_rate", VR_OMEGA_RATE, C::Parameter, V::Fixed, Some(DEFAULT_OMEGA_RATE), "rad/s2")
        .describe("magnitude of dOmega/dt of the internal sweep (0: fixed sine at Omega_start)"),
    Variable::boolean_parameter("use_external_voltage", VR_USE_EXTERNAL, false)
        .describe("true: the applied voltage is the input u_ext instead of the internal sweep"),
    Variable::real("d_a", VR_D_A, C::CalculatedParameter, V::Fixed, None, "N.s/m")
        .describe("mechanical armature damping d_a = 2 D_a sqrt(k_a m_a) - G^2/R"),
    Variable::real("x", VR_X, C::Input, V::Continuous, Some(0.0), "m")
        .describe("structure displacement at the drive point (stinger end)"),
    Variable::real("v", VR_V, C::Input, V::Continuous, Some(0.0), "m/s")
        .describe("structure velocity at the drive point (extrapolates x inside the step)"),
    Variable::real("u_ext", VR_U_EXT, C::Input, V::Continuous, Some(0.0), "V")
        .describe("external voltage (used when use_external_voltage = true)"),
    Variable::real("F", VR_F, C::Output, V::Continuous, None, "N")
        .describe("stinger force on the structure k_s (q_a - x), positive along positive x"),
    Variable::real("I", VR_I, C::Output, V::Continuous, None, "A")
        .describe("coil current"),
    Variable::real("q_a", VR_Q_A, C::Output, V::Continuous, None, "m")
        .describe("armature displacement"),
    Variable::real("v_a", VR_V_A, C::Output, V::Continuous, None, "m/s")
        .describe("armature velocity"),
    Variable::real("u", VR_U, C::Output, V::Continuous, None, "V")
        .describe("applied voltage (internal sweep or u_ext)"),
    Variable::real("Omega", VR_OMEGA, C::Output, V::Continuous, None, "rad/s")
        .describe("instantaneous excitation frequency of the internal sweep (0 with external voltage)"),
    Variable::real("der(I)", VR_DER_I, C::Local, V::Continuous, None, "A/s")
        .describe("coil current rate (u - R I - G v_a)/L"),
    Variable::real("der(q_a)", VR_DER_Q_A, C::Local, V::Continuous, None, "m/s")
        .describe("armature velocity v_a (rate of q_a)"),
    Variable::real("der(v_a)", VR_DER_V_A, C::Local, V::Continuous, None, "m/s2")
        .describe("armature acceleration (G I - d_a v_a - k_a q_a - k_s (q_a - x))/m_a"),
];

/// The rest of the modelDescription. `<ModelStructure>`: `F = k_s (q_a - x)`
/// feeds through from `x`, `u` from `u_ext` (with `use_external_voltage`),
/// nothing else; the states start at rest (`I = q_a = v_a = 0`), so at the
/// start `d_a` follows from `R, G, m_a, k_a, D_a`, `F = k_s (0 - x)`,
/// `u = u_ext` or `u_hat cos(0)`, `Omega = Omega_start` or 0.
pub const INFO: ModelInfo = ModelInfo {
    name: "shaker",
    description: "Electrodynamic exciter (B&K V4808 by default) with elastic stinger, voltage driven, integrated exactly (matrix exponential, inputs linear in time); Krack, exciter-structure interaction, Section 4",
    version: Some("0.1.0"),
    generation_tool: "fmi2 (Rust workspace nlmode)",
    capabilities: Capabilities {
        can_handle_variable_communication_step_size: true,
        can_interpolate_inputs: true,
        max_output_derivative_order: 1,
        provides_directional_derivative: true,
    },
    units: &[],
    log_categories: LOG_CATEGORY_DESCRIPTIONS,
    default_experiment: DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(0.9),
        tolerance: None,
        step_size: Some(1e-5),
    },
    model_structure: ModelStructure {
        outputs: &[
            Dependencies::fixed("F", &["x"]),
            Dependencies::fixed("u", &["u_ext"]),
        ],
        derivatives: &[
            Dependencies::fixed("der(I)", &["u_ext", "I", "v_a"]),
            Dependencies::fixed("der(q_a)", &["v_a"]),
            Dependencies::fixed("der(v_a)", &["x", "I", "q_a", "v_a"]),
        ],
        initial_unknowns: &[
            Dependencies::on("d_a", &["R", "G", "m_a", "k_a", "D_a"]),
            Dependencies::on("F", &["k_s", "x"]),
            Dependencies::on("u", &["u_hat", "use_external_voltage", "u_ext"]),
            Dependencies::on("Omega", &["Omega_start", "use_external_voltage"]),
            Dependencies::on("der(I)", &["L", "u_hat", "use_external_voltage", "u_ext"]),
            Dependencies::on("der(v_a)", &["m_a", "k_s", "x"]),
        ],
    },
};

/// Physical range of each Real parameter, checked at
/// `fmi2ExitInitializationMode` (value reference, name, min, max, unit).
/// Generous for laboratory exciters (the B&K V4808: L = 1.4e-4 H, R = 3 Ohm,
/// G = 15.5 N/A, m_a = 0.043 kg, k_a = 2.07e4 N/m, k_s = 2.6e7 N/m), and
/// narrow enough that every entry of the state matrix `A` stays below about
/// 1e18 1/s, so the matrix exponential's scaling and squaring is bounded
/// (see [`MAX_EXPONENT_NORM`]).
pub const PARAMETER_RANGES: &[(u32, &str, f64, f64, &str)] = &[
    (VR_L, "L", 1e-9, 10.0, "H"),
    (VR_R, "R", 1e-6, 1e6, "Ohm"),
    (VR_G, "G", 1e-6, 1e6, "N/A"),
    (VR_M_A, "m_a", 1e-6, 1e3, "kg"),
    (VR_K_A, "k_a", 1e-6, 1e12, "N/m"),
    (VR_D_A_RATIO, "D_a", 0.0, 1e3, "1"),
    (VR_K_S, "k_s", 1e-6, 1e12, "N/m"),
    (VR_U_HAT, "u_hat", -1e6, 1e6, "V"),
    (VR_OMEGA_START, "Omega_start", 0.0, 1e7, "rad/s"),
    (VR_OMEGA_END, "Omega_end", 0.0, 1e7, "rad/s"),
    (VR_OMEGA_RATE, "Omega_rate", 0.0, 1e10, "rad/s2"),
];

/// Largest `||A||_1 h` of one exact sub-step: nalgebra's exponential squares
/// `log2(||A h|| / 4.25)` times (about 48 here) after its Pade step, and an
/// unbounded norm (parameters near 1e40 or 1e80) made it loop without end.
pub const MAX_EXPONENT_NORM: f64 = 1e15;

/// A held input: value set at time `t_set`, first and second derivatives
/// used to extrapolate it inside the step.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Held {
    value: f64,
    t_set: f64,
    /// First derivative from `fmi2SetRealInputDerivatives` (None: not given).
    der1: Option<f64>,
}

impl Held {
    fn new(value: f64) -> Self {
        Self {
            value,
            t_set: 0.0,
            der1: None,
        }
    }
}

/// The shaker FMU model.
#[derive(Debug, Clone)]
pub struct Shaker {
    /// Physical parameters (`L, R, G, m_a, k_a, D_a, k_s`).
    pub params: ShakerParams,
    /// The internal voltage source (sweep time counts from the experiment's
    /// start; held at `Omega_end` after the sweep, a fixed sine for a zero rate).
    pub source: LinearSweep,
    pub use_external_voltage: bool,
    /// States `[I, q_a, v_a]` (A, m, m/s).
    s: Vector3<f64>,
    t: f64,
    t0: f64,
    x: Held,
    v: Held,
    u_ext: Held,
    /// The physics once parameters are fixed.
    stepper: Option<ShakerStepper>,
    /// `||A||_1` of the state matrix [1/s] (set with `stepper`).
    a_norm_per_s: f64,
    /// `A`, `B` of `s' = A s + B [u, x]` (set with `stepper`; the Model
    /// Exchange Jacobian of `fmi2GetDirectionalDerivative`).
    ab: Option<(Matrix3<f64>, Matrix3x2<f64>)>,
}

impl Shaker {
    /// The modelDescription start values.
    pub fn new() -> Self {
        Self {
            params: ShakerParams::paper(),
            source: LinearSweep {
                omega_start_rad_s: DEFAULT_OMEGA_START,
                omega_end_rad_s: DEFAULT_OMEGA_END,
                rate_rad_s2: DEFAULT_OMEGA_RATE,
                amplitude: DEFAULT_U_HAT,
            },
            use_external_voltage: false,
            s: Vector3::zeros(),
            t: 0.0,
            t0: 0.0,
            x: Held::new(0.0),
            v: Held::new(0.0),
            u_ext: Held::new(0.0),
            stepper: None,
            a_norm_per_s: 0.0,
            ab: None,
        }
    }

    fn k_s(&self) -> f64 {
        match self.params.stinger {
            Stinger::Elastic { stiffness_n_per_m } => stiffness_n_per_m,
            Stinger::Rigid => f64::NAN,
        }
    }

    fn d_a_ratio(&self) -> f64 {
        match self.params.armature_damping {
            ArmatureDamping::Ratio(r) => r,
            ArmatureDamping::Viscous(_) => self.params.damping_ratio(),
        }
    }

    /// Validate the parameters and build the state space (`exit_initialization_mode`).
    pub fn fix_parameters(&mut self) -> Result<(), ModelError> {
        self.source.check_source().map_err(|e| match e {
            SweepError::NegativeSourceFrequency { which, value } => {
                let name = match which {
                    SweepEnd::Start => "Omega_start",
                    SweepEnd::End => "Omega_end",
                };
                ModelError::error(format!("{name} must be >= 0 rad/s, got {value}"))
            }
            SweepError::NegativeSourceRate(v) => {
                ModelError::error(format!("Omega_rate must be >= 0 rad/s2, got {v}"))
            }
            other => other.into(),
        })?;
        let ss = self.params.state_space()?;
        // after the physics' own validation (sign, finiteness), before any
        // matrix exponential is formed
        for &(vr, name, lo, hi, unit) in PARAMETER_RANGES {
            let v = self.get_real(vr);
            if !(lo..=hi).contains(&v) {
                return Err(ModelError::error(format!(
                    "{name} = {v:e} {unit} is outside its physical range [{lo:e}, {hi:e}] {unit}"
                )));
            }
        }
        self.a_norm_per_s =
            ss.a.column_iter()
                .map(|c| c.iter().map(|x| x.abs()).sum::<f64>())
                .fold(0.0, f64::max);
        self.ab = Some((
            Matrix3::from_fn(|i, j| ss.a[(i, j)]),
            Matrix3x2::from_fn(|i, j| ss.b[(i, j)]),
        ));
        self.stepper = Some(ShakerStepper::new(&self.params)?);
        Ok(())
    }

    /// Displacement input extrapolated to time `t` [m]: `x + xdot (t - t_set)`
    /// with `xdot` the input derivative if given, else the velocity input.
    fn x_at(&self, t: f64) -> f64 {
        self.x.value + self.xdot() * (t - self.x.t_set)
    }
    fn xdot(&self) -> f64 {
        self.x.der1.unwrap_or(self.v.value)
    }

    /// Applied voltage at time `t` [V].
    fn u_at(&self, t: f64) -> f64 {
        if self.use_external_voltage {
            self.u_ext.value + self.u_ext.der1.unwrap_or(0.0) * (t - self.u_ext.t_set)
        } else {
            self.source.value(t - self.t0)
        }
    }

    /// Number of sub-steps for a step `[t, t+h]` (the internal sweep is
    /// followed in phase increments of at most [`MAX_PHASE_PER_SUBSTEP`]).
    fn substeps(&self, t: f64, h: f64) -> Result<usize, ModelError> {
        if self.use_external_voltage {
            Ok(1)
        } else {
            sweep_substeps(&self.source, t - self.t0, h).map_err(|needed| {
                ModelError::error(format!(
                    "communication step h = {h} s at t = {t} s would need {needed:e} sub-steps of the internal sweep (at most {MAX_SWEEP_SUBSTEPS}); use a shorter step"
                ))
            })
        }
    }

    /// Advance the states from `t` to `t + h` exactly for inputs linear in
    /// time inside each sub-step.
    pub fn advance(&mut self, t: f64, h: f64) -> Result<(), ModelError> {
        let n = self.substeps(t, h)?;
        let hs = h / n as f64;
        if self.a_norm_per_s * hs > MAX_EXPONENT_NORM {
            return Err(ModelError::error(format!(
                "sub-step {hs:e} s times ||A||_1 = {:e} 1/s exceeds {MAX_EXPONENT_NORM:e} (the exact \
                 discretization's matrix exponential): use a step below {:e} s",
                self.a_norm_per_s,
                MAX_EXPONENT_NORM / self.a_norm_per_s
            )));
        }
        let mut stepper = self.stepper.take().ok_or_else(|| {
            ModelError::error("parameters not fixed (initialization not completed)")
        })?;
        let mut s = self.s;
        let stepped = stepper.advance(&mut s, t, h, n, |tk: f64| {
            Vector2::new(self.u_at(tk), self.x_at(tk))
        });
        self.stepper = Some(stepper);
        stepped?;
        self.s = s;
        self.t = t + h;
        Ok(())
    }

    /// State derivative `[I', q_a', v_a']` at the current time.
    fn rates(&self) -> Result<Vector3<f64>, ModelError> {
        let (u, x) = (self.u_at(self.t), self.x_at(self.t));
        Ok(match &self.stepper {
            Some(st) => st.rates(&self.s, u, x),
            None => ShakerStepper::new(&self.params)?.rates(&self.s, u, x),
        })
    }

    /// Current states `[I, q_a, v_a]` (A, m, m/s).
    pub fn states(&self) -> [f64; 3] {
        [self.s[0], self.s[1], self.s[2]]
    }

    /// Overwrite the states `[I, q_a, v_a]` (analysis of the coupled step map).
    pub fn set_states(&mut self, s: [f64; 3]) {
        self.s = Vector3::new(s[0], s[1], s[2]);
    }
}

impl Default for Shaker {
    fn default() -> Self {
        Self::new()
    }
}

fn bad_vr(vr: u32) -> ModelError {
    ModelError::error(format!("value reference {vr} is not handled by the shaker"))
}

impl CoSimModel for Shaker {
    const MODEL_IDENTIFIER: &'static str = "shaker";
    const GUID: &'static str = GUID;
    const VARIABLES: &'static [Variable] = VARIABLES;
    const CONTINUOUS_STATES: &'static [ContinuousState] = CONTINUOUS_STATES;
    const INFO: ModelInfo = INFO;

    fn instantiate(_ctx: &InstantiateContext<'_>) -> Result<Self, ModelError> {
        Ok(Self::new())
    }

    fn setup_experiment(&mut self, start_time: f64, _stop: Option<f64>) -> Result<(), ModelError> {
        self.t0 = start_time;
        self.t = start_time;
        for h in [&mut self.x, &mut self.v, &mut self.u_ext] {
            h.t_set = start_time;
        }
        Ok(())
    }

    fn exit_initialization_mode(&mut self, _log: &Logger) -> Result<(), ModelError> {
        self.fix_parameters()
    }

    fn get_real(&self, vr: u32) -> f64 {
        let p = &self.params;
        match vr {
            VR_L => p.inductance_h,
            VR_R => p.resistance_ohm,
            VR_G => p.force_constant_n_per_a,
            VR_M_A => p.armature_mass_kg,
            VR_K_A => p.armature_stiffness_n_per_m,
            VR_D_A_RATIO => self.d_a_ratio(),
            VR_K_S => self.k_s(),
            VR_U_HAT => self.source.amplitude,
            VR_OMEGA_START => self.source.omega_start_rad_s,
            VR_OMEGA_END => self.source.omega_end_rad_s,
            VR_OMEGA_RATE => self.source.rate_rad_s2,
            VR_D_A => p.d_a(),
            VR_X => self.x.value,
            VR_V => self.v.value,
            VR_U_EXT => self.u_ext.value,
            VR_F => self.k_s() * (self.s[1] - self.x_at(self.t)),
            VR_I => self.s[0],
            VR_Q_A => self.s[1],
            VR_V_A => self.s[2],
            VR_U => self.u_at(self.t),
            VR_OMEGA => {
                if self.use_external_voltage {
                    0.0
                } else {
                    self.source.omega_rad_s(self.t - self.t0)
                }
            }
            // a failure (parameters out of range before initialization) is NaN
            // here and a message in `try_get_real`
            VR_DER_I => self.rates().map_or(f64::NAN, |r| r[0]),
            VR_DER_Q_A => self.rates().map_or(f64::NAN, |r| r[1]),
            VR_DER_V_A => self.rates().map_or(f64::NAN, |r| r[2]),
            _ => f64::NAN, // unreachable: the layer only passes Real vrs of VARIABLES
        }
    }

    /// The derivatives are readable in every state, Initialization Mode
    /// included (those of the start state under the current parameters);
    /// parameters that give no model are an error saying why, not NaN.
    fn try_get_real(&self, vr: u32) -> Result<f64, ModelError> {
        match vr {
            VR_DER_I | VR_DER_Q_A | VR_DER_V_A => {
                let r = self.rates().map_err(|e| {
                    ModelError::error(format!(
                        "derivatives at the current parameters: {}",
                        e.message
                    ))
                })?;
                Ok(r[(vr - VR_DER_I) as usize])
            }
            _ => Ok(self.get_real(vr)),
        }
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        let p = &mut self.params;
        match vr {
            VR_L => p.inductance_h = value,
            VR_R => p.resistance_ohm = value,
            VR_G => p.force_constant_n_per_a = value,
            VR_M_A => p.armature_mass_kg = value,
            VR_K_A => p.armature_stiffness_n_per_m = value,
            VR_D_A_RATIO => p.armature_damping = ArmatureDamping::Ratio(value),
            VR_K_S => {
                p.stinger = Stinger::Elastic {
                    stiffness_n_per_m: value,
                }
            }
            VR_U_HAT => self.source.amplitude = value,
            VR_OMEGA_START => self.source.omega_start_rad_s = value,
            VR_OMEGA_END => self.source.omega_end_rad_s = value,
            VR_OMEGA_RATE => self.source.rate_rad_s2 = value,
            VR_X => {
                self.x = Held {
                    value,
                    t_set: self.t,
                    der1: None,
                }
            }
            VR_V => {
                self.v = Held {
                    value,
                    t_set: self.t,
                    der1: None,
                }
            }
            VR_U_EXT => {
                self.u_ext = Held {
                    value,
                    t_set: self.t,
                    der1: None,
                }
            }
            _ => return Err(bad_vr(vr)),
        }
        Ok(())
    }

    fn get_boolean(&self, vr: u32) -> Result<bool, ModelError> {
        match vr {
            VR_USE_EXTERNAL => Ok(self.use_external_voltage),
            _ => Err(bad_vr(vr)),
        }
    }

    fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), ModelError> {
        match vr {
            VR_USE_EXTERNAL => {
                self.use_external_voltage = value;
                Ok(())
            }
            _ => Err(bad_vr(vr)),
        }
    }

    fn do_step(&mut self, t: f64, h: f64, _log: &Logger) -> Result<(), ModelError> {
        self.advance(t, h)
    }

    /// Model Exchange: the inputs are the values at the current time (no
    /// extrapolation inside a step, so the held inputs are re-based to `t`);
    /// the internal sweep voltage is a function of time, without events.
    fn set_time(&mut self, t: f64) -> Result<(), ModelError> {
        self.t = t;
        for h in [&mut self.x, &mut self.v, &mut self.u_ext] {
            h.t_set = t;
        }
        Ok(())
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), ModelError> {
        self.s = Vector3::new(x[0], x[1], x[2]);
        Ok(())
    }

    /// `[I', q_a', v_a'] = A s + B [u(t), x]` ([`ShakerStepper::rates`]).
    fn derivatives(&self, dx: &mut [f64]) -> Result<(), ModelError> {
        let r = self.rates()?;
        dx.copy_from_slice(r.as_slice());
        Ok(())
    }

    /// Order 1 only: `der(x)` replaces `v` in the extrapolation of `x`,
    /// `der(u_ext)` makes the external voltage ramp; `der(v)` is accepted and
    /// has no effect (the displacement is extrapolated linearly).
    fn set_real_input_derivative(
        &mut self,
        vr: u32,
        order: u32,
        value: f64,
    ) -> Result<(), ModelError> {
        if order != 1 {
            return Err(ModelError::error(format!(
                "only first-order input derivatives are supported (maxOutputDerivativeOrder = 1), got order {order} for value reference {vr}"
            )));
        }
        let held = match vr {
            VR_X => &mut self.x,
            VR_V => &mut self.v,
            VR_U_EXT => &mut self.u_ext,
            _ => return Err(bad_vr(vr)),
        };
        // the derivative refers to the value set last (at `t_set`)
        held.der1 = Some(value);
        Ok(())
    }

    fn get_real_output_derivative(&self, vr: u32, order: u32) -> Result<f64, ModelError> {
        if order != 1 {
            return Err(ModelError::error(format!(
                "only first-order output derivatives are available, got order {order} for value reference {vr}"
            )));
        }
        let r = self.rates()?;
        Ok(match vr {
            VR_F => self.k_s() * (r[1] - self.xdot()),
            VR_I => r[0],
            VR_Q_A => r[1],
            VR_V_A => r[2],
            VR_U => {
                if self.use_external_voltage {
                    self.u_ext.der1.unwrap_or(0.0)
                } else {
                    self.source.value_rate(self.t - self.t0)
                }
            }
            VR_OMEGA => {
                if self.use_external_voltage {
                    0.0
                } else {
                    self.source.omega_rate_rad_s2(self.t - self.t0)
                }
            }
            _ => return Err(bad_vr(vr)),
        })
    }

    /// Outputs: direct feedthrough `dF/dx = -k_s`, `du/du_ext = 1` (external
    /// voltage). Model Exchange: the state derivatives' Jacobian, `A` with
    /// respect to the states `I, q_a, v_a`, the columns of `B` with respect to
    /// `u_ext` (external voltage) and `x`; and `dF/dq_a = k_s`, `ds_i/ds_j = delta_ij`.
    fn partial_derivative(&self, unknown: u32, known: u32) -> Result<f64, ModelError> {
        let states = [VR_I, VR_Q_A, VR_V_A];
        let ders = [VR_DER_I, VR_DER_Q_A, VR_DER_V_A];
        if let Some(i) = ders.iter().position(|&d| d == unknown) {
            let (a, b) = self.ab.as_ref().ok_or_else(|| {
                ModelError::error("the Jacobian is available after fmi2ExitInitializationMode")
            })?;
            return Ok(match known {
                VR_X => b[(i, 1)],
                VR_U_EXT if self.use_external_voltage => b[(i, 0)],
                VR_U_EXT | VR_V => 0.0,
                k => match states.iter().position(|&s| s == k) {
                    Some(j) => a[(i, j)],
                    None => {
                        return Err(ModelError::error(format!(
                            "directional derivatives of the state derivatives are provided with respect to the states I, q_a, v_a and the inputs x, v, u_ext, not value reference {known}"
                        )))
                    }
                },
            });
        }
        if let Some(j) = states.iter().position(|&s| s == known) {
            return Ok(match unknown {
                VR_F if j == 1 => self.k_s(),
                u if u == known => 1.0,
                VR_F | VR_I | VR_Q_A | VR_V_A | VR_U | VR_OMEGA => 0.0,
                _ => {
                    return Err(ModelError::error(format!(
                        "directional derivatives are provided for outputs and state derivatives only, not value reference {unknown}"
                    )))
                }
            });
        }
        if ![VR_X, VR_V, VR_U_EXT].contains(&known) {
            return Err(ModelError::error(format!(
                "directional derivatives are provided with respect to the inputs x, v, u_ext only, not value reference {known}"
            )));
        }
        Ok(match (unknown, known) {
            (VR_F, VR_X) => -self.k_s(),
            (VR_U, VR_U_EXT) if self.use_external_voltage => 1.0,
            (VR_F | VR_I | VR_Q_A | VR_V_A | VR_U | VR_OMEGA, _) => 0.0,
            _ => {
                return Err(ModelError::error(format!(
                    "directional derivatives are provided for outputs only, not value reference {unknown}"
                )))
            }
        })
    }

    fn serialize_state(&self, w: &mut StateWriter) {
        let p = &self.params;
        w.f64s(&[
            p.inductance_h,
            p.resistance_ohm,
            p.force_constant_n_per_a,
            p.armature_mass_kg,
            p.armature_stiffness_n_per_m,
            self.d_a_ratio(),
            self.k_s(),
            self.source.amplitude,
            self.source.omega_start_rad_s,
            self.source.omega_end_rad_s,
            self.source.rate_rad_s2,
            self.s[0],
            self.s[1],
            self.s[2],
            self.t,
            self.t0,
        ]);
        w.bool(self.use_external_voltage);
        w.bool(self.stepper.is_some());
        for h in [&self.x, &self.v, &self.u_ext] {
            w.f64(h.value);
            w.f64(h.t_set);
            w.bool(h.der1.is_some());
            w.f64(h.der1.unwrap_or(0.0));
        }
    }

    fn deserialize_state(&mut self, r: &mut StateReader<'_>) -> Result<(), ModelError> {
        let v = r.f64s(16)?;
        let old = self.params;
        self.params.inductance_h = v[0];
        self.params.resistance_ohm = v[1];
        self.params.force_constant_n_per_a = v[2];
        self.params.armature_mass_kg = v[3];
        self.params.armature_stiffness_n_per_m = v[4];
        self.params.armature_damping = ArmatureDamping::Ratio(v[5]);
        self.params.stinger = Stinger::Elastic {
            stiffness_n_per_m: v[6],
        };
        self.source = LinearSweep {
            amplitude: v[7],
            omega_start_rad_s: v[8],
            omega_end_rad_s: v[9],
            rate_rad_s2: v[10],
        };
        self.s = Vector3::new(v[11], v[12], v[13]);
        self.t = v[14];
        self.t0 = v[15];
        self.use_external_voltage = r.bool()?;
        let fixed = r.bool()?;
        for h in [&mut self.x, &mut self.v, &mut self.u_ext] {
            h.value = r.f64()?;
            h.t_set = r.f64()?;
            let has = r.bool()?;
            let d = r.f64()?;
            h.der1 = has.then_some(d);
        }
        if !fixed {
            self.stepper = None;
            self.ab = None;
        } else if self.stepper.is_none() || old != self.params {
            self.fix_parameters()?;
        }
        Ok(())
    }
}
