//! The scenario file (TOML): structure, exciters, excitation, NMA, methods, output.
//! Documented in `docs/scenario.md`; the commented default is `sweep.toml` at
//! the repository root, embedded into the binary.
//!
//! Every spelling (method, boundary, reduction, stinger, integrator, algorithm,
//! force source, location) is a typed value, checked when the file is
//! deserialized; unknown keys are rejected (serde `deny_unknown_fields`). Every
//! number is checked by [`Scenario::validate`]. Both report a [`ScenarioError`]
//! naming the key as the user wrote it (`exciter[1].stinger`).
use nlmode::reference::Integrator;
use nlmode::structure::BoundaryCondition;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::path::PathBuf;

/// The default scenario (paper case (a)), embedded from `sweep.toml`;
/// it deserializes to exactly [`Scenario::default`].
pub const DEFAULT_SCENARIO: &str = include_str!("../../sweep.toml");

/// Title of the default scenario.
const DEFAULT_TITLE: &str = "Paper case (a): exciter at 2l/3, 10 V, 2 % per pseudo period";

/// A sweep method of `host run` (`[run] methods`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Time integration of the assembled full-order model.
    Reference,
    /// Assembled linear frequency response (with `closed-form` beside it).
    LinearFrf,
    /// Slow flow of the single nonlinear modal oscillator with the shaker (`eq:NM`).
    Nlmode,
    /// The same with constant linear modal properties.
    LinearSlowflow,
    /// Its algebraic linear steady state.
    LinearSteady,
    /// The FMUs co-simulated by the host's master.
    Cosim,
    /// The modal oscillator driven by a prescribed force (paper Section 5.3).
    ImposedForce,
    /// Phase-resonance test: phase-locked loop stepped through voltage levels
    /// (`[phase_resonance]`, `phase_resonance.csv`).
    PhaseResonance,
    /// Force-controlled stepped sine (`[force_control]`, `force_control.csv`).
    ForceControlled,
    /// Response-controlled stepped sine (`[response_control]`,
    /// `response_control.csv`).
    ResponseControlled,
    /// Test planning on the single-nonlinear-mode model (`[test_plan]`,
    /// `test_plan.csv`).
    TestPlan,
}

impl Method {
    /// Every method, in the order of the docs.
    pub const ALL: [Method; 11] = [
        Method::Reference,
        Method::LinearFrf,
        Method::Nlmode,
        Method::LinearSlowflow,
        Method::LinearSteady,
        Method::ImposedForce,
        Method::Cosim,
        Method::PhaseResonance,
        Method::ForceControlled,
        Method::ResponseControlled,
        Method::TestPlan,
    ];

    /// The name in scenarios and output files (`linear-frf`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Reference => "reference",
            Method::LinearFrf => "linear-frf",
            Method::Nlmode => "nlmode",
            Method::LinearSlowflow => "linear-slowflow",
            Method::LinearSteady => "linear-steady",
            Method::Cosim => "cosim",
            Method::ImposedForce => "imposed-force",
            Method::PhaseResonance => "phase-resonance",
            Method::ForceControlled => "force-controlled",
            Method::ResponseControlled => "response-controlled",
            Method::TestPlan => "test-plan",
        }
    }

    /// Whether the method needs the nonlinear mode (the modal table).
    pub fn needs_mode(self) -> bool {
        matches!(
            self,
            Method::Nlmode
                | Method::LinearSlowflow
                | Method::LinearSteady
                | Method::ImposedForce
                | Method::PhaseResonance
                | Method::ForceControlled
                | Method::ResponseControlled
                | Method::TestPlan
        )
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Free text (empty when omitted).
    #[serde(default)]
    pub title: String,
    #[serde(default)]
    pub structure: StructureSpec,
    /// `[[nonlinearity]]`: nonlinear elements at or between points (besides the
    /// `k3_n_per_m3` shorthand of `[structure]`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nonlinearity: Vec<NonlinearitySpec>,
    #[serde(default = "default_exciters")]
    pub exciter: Vec<ExciterSpec>,
    /// `[[attachment]]`: linear attachments besides the exciters.
    #[serde(default)]
    pub attachment: Vec<AttachmentSpec>,
    #[serde(default)]
    pub excitation: ExcitationSpec,
    #[serde(default)]
    pub nma: NmaSpec,
    #[serde(default)]
    pub run: RunSpec,
    #[serde(default)]
    pub imposed_force: ImposedForceSpec,
    #[serde(default)]
    pub slowflow: SlowFlowSpec,
    #[serde(default)]
    pub reference: ReferenceSpec,
    #[serde(default)]
    pub cosim: CosimSpec,
    #[serde(default)]
    pub output: OutputSpec,
    #[serde(default)]
    pub phase_resonance: PhaseResonanceSpec,
    #[serde(default)]
    pub force_control: ForceControlSpec,
    #[serde(default)]
    pub response_control: ResponseControlSpec,
    #[serde(default)]
    pub test_plan: TestPlanSpec,
}

/// The paper's case (a): every section's default, one exciter at 2l/3 and the
/// title of `sweep.toml` (a file without `title` gets an empty one).
impl Default for Scenario {
    fn default() -> Self {
        Self {
            title: DEFAULT_TITLE.into(),
            structure: StructureSpec::default(),
            nonlinearity: Vec::new(),
            exciter: default_exciters(),
            attachment: Vec::new(),
            excitation: ExcitationSpec::default(),
            nma: NmaSpec::default(),
            run: RunSpec::default(),
            imposed_force: ImposedForceSpec::default(),
            slowflow: SlowFlowSpec::default(),
            reference: ReferenceSpec::default(),
            cosim: CosimSpec::default(),
            output: OutputSpec::default(),
            phase_resonance: PhaseResonanceSpec::default(),
            force_control: ForceControlSpec::default(),
            response_control: ResponseControlSpec::default(),
            test_plan: TestPlanSpec::default(),
        }
    }
}

/// `[structure]`: what is tested. One variant per `kind`; the beam is the
/// default. (Dispatch on `kind` lives in this type's `Deserialize`: every key of
/// every kind is read into one table, so that unknown keys and bad spellings keep
/// their key paths, then the kind's keys are taken and a key of another kind is
/// rejected by name.)
#[derive(Debug, Clone, PartialEq)]
pub enum StructureSpec {
    /// `kind = "beam"`: the paper's Euler-Bernoulli beam with a cubic tip spring.
    Beam(BeamStructureSpec),
    /// `kind = "matrices"`: the user's structure from Matrix Market files.
    Matrices(MatricesStructureSpec),
}

impl Default for StructureSpec {
    fn default() -> Self {
        StructureSpec::Beam(BeamStructureSpec::default())
    }
}

/// Every key of every structure kind (the `[structure]` table as read).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStructure {
    kind: Option<StructureKind>,
    length_m: Option<f64>,
    height_m: Option<f64>,
    width_m: Option<f64>,
    youngs_modulus_pa: Option<f64>,
    density_kg_m3: Option<f64>,
    n_nodes: Option<usize>,
    boundary: Option<BoundaryCondition>,
    k3_n_per_m3: Option<f64>,
    damping_ratio: Option<f64>,
    reduction: Option<Reduction>,
    cb_modes: Option<usize>,
    mass_mtx: Option<PathBuf>,
    stiffness_mtx: Option<PathBuf>,
    damping_mtx: Option<PathBuf>,
    rayleigh: Option<[f64; 2]>,
    damping_mode: Option<usize>,
    cb_masters: Option<Vec<String>>,
    point: Option<Vec<PointSpec>>,
    nonlinear_point: Option<String>,
    allow_rigid_body_modes: Option<bool>,
}

impl<'de> Deserialize<'de> for StructureSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let r = RawStructure::deserialize(d)?;
        let other = |kind: &str, keys: &[(&str, bool)]| -> Result<(), D::Error> {
            match keys.iter().find(|(_, given)| *given) {
                Some((k, _)) => Err(D::Error::custom(format!(
                    "structure.{k} is not a key of kind = \"{kind}\""
                ))),
                None => Ok(()),
            }
        };
        match r.kind.unwrap_or_default() {
            StructureKind::Beam => {
                other(
                    "beam",
                    &[
                        ("mass_mtx", r.mass_mtx.is_some()),
                        ("stiffness_mtx", r.stiffness_mtx.is_some()),
                        ("damping_mtx", r.damping_mtx.is_some()),
                        ("rayleigh", r.rayleigh.is_some()),
                        ("damping_mode", r.damping_mode.is_some()),
                        ("cb_masters", r.cb_masters.is_some()),
                        ("point", r.point.is_some()),
                        ("nonlinear_point", r.nonlinear_point.is_some()),
                        ("allow_rigid_body_modes", r.allow_rigid_body_modes.is_some()),
                    ],
                )?;
                let b = BeamStructureSpec::default();
                Ok(StructureSpec::Beam(BeamStructureSpec {
                    kind: StructureKind::Beam,
                    length_m: r.length_m.unwrap_or(b.length_m),
                    height_m: r.height_m.unwrap_or(b.height_m),
                    width_m: r.width_m.unwrap_or(b.width_m),
                    youngs_modulus_pa: r.youngs_modulus_pa.unwrap_or(b.youngs_modulus_pa),
                    density_kg_m3: r.density_kg_m3.unwrap_or(b.density_kg_m3),
                    n_nodes: r.n_nodes.unwrap_or(b.n_nodes),
                    boundary: r.boundary.unwrap_or(b.boundary),
                    k3_n_per_m3: r.k3_n_per_m3.unwrap_or(b.k3_n_per_m3),
                    damping_ratio: r.damping_ratio.unwrap_or(b.damping_ratio),
                    reduction: r.reduction.unwrap_or(b.reduction),
                    cb_modes: r.cb_modes.unwrap_or(b.cb_modes),
                }))
            }
            StructureKind::Matrices => {
                other(
                    "matrices",
                    &[
                        ("length_m", r.length_m.is_some()),
                        ("height_m", r.height_m.is_some()),
                        ("width_m", r.width_m.is_some()),
                        ("youngs_modulus_pa", r.youngs_modulus_pa.is_some()),
                        ("density_kg_m3", r.density_kg_m3.is_some()),
                        ("n_nodes", r.n_nodes.is_some()),
                        ("boundary", r.boundary.is_some()),
                    ],
                )?;
                let missing = |k: &str| {
                    D::Error::custom(format!(
                        "structure.{k} is missing: kind = \"matrices\" needs mass_mtx and stiffness_mtx (Matrix Market files)"
                    ))
                };
                Ok(StructureSpec::Matrices(MatricesStructureSpec {
                    mass_mtx: r.mass_mtx.ok_or_else(|| missing("mass_mtx"))?,
                    stiffness_mtx: r.stiffness_mtx.ok_or_else(|| missing("stiffness_mtx"))?,
                    damping_mtx: r.damping_mtx,
                    rayleigh: r.rayleigh,
                    damping_ratio: r.damping_ratio,
                    damping_mode: r.damping_mode,
                    reduction: r.reduction.unwrap_or_default(),
                    cb_modes: r.cb_modes.unwrap_or(nlmode::benchmark::CB_MODES),
                    cb_masters: r.cb_masters,
                    point: r.point.unwrap_or_default(),
                    k3_n_per_m3: r.k3_n_per_m3.unwrap_or(0.0),
                    nonlinear_point: r.nonlinear_point,
                    allow_rigid_body_modes: r.allow_rigid_body_modes.unwrap_or(false),
                }))
            }
        }
    }
}

impl Serialize for StructureSpec {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            StructureSpec::Beam(b) => b.serialize(s),
            StructureSpec::Matrices(m) => m.serialize(s),
        }
    }
}

impl StructureSpec {
    /// The beam of `kind = "beam"`, `None` for other kinds.
    pub fn beam(&self) -> Option<&BeamStructureSpec> {
        match self {
            StructureSpec::Beam(b) => Some(b),
            StructureSpec::Matrices(_) => None,
        }
    }

    /// The matrices of `kind = "matrices"`, `None` for other kinds.
    pub fn matrices(&self) -> Option<&MatricesStructureSpec> {
        match self {
            StructureSpec::Matrices(m) => Some(m),
            StructureSpec::Beam(_) => None,
        }
    }
}

/// The structure kinds (`structure.kind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StructureKind {
    #[default]
    Beam,
    Matrices,
}

/// Model reduction of the structure (`structure.reduction`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reduction {
    /// Craig-Bampton with the masters (beam: the tip translation; matrices:
    /// `cb_masters`) and `cb_modes` fixed-interface modes.
    #[default]
    CraigBampton,
    /// The full FE model.
    None,
}

/// A named DOF of a matrices structure (`[[structure.point]]`).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PointSpec {
    pub name: String,
    /// 0-based row of `M` and `K`.
    pub dof: usize,
}

/// `[structure]` with `kind = "matrices"` (docs/scenario.md). Paths are relative
/// to the scenario file ([`Scenario::resolve_paths`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MatricesStructureSpec {
    pub mass_mtx: PathBuf,
    pub stiffness_mtx: PathBuf,
    pub damping_mtx: Option<PathBuf>,
    /// `[alpha, beta]`: `C = alpha M + beta K` (`alpha` [1/s], `beta` [s]).
    pub rayleigh: Option<[f64; 2]>,
    /// Stiffness-proportional damping with this ratio on `damping_mode`.
    pub damping_ratio: Option<f64>,
    /// 1-based mode of the full model for `damping_ratio` (default 1).
    pub damping_mode: Option<usize>,
    pub reduction: Reduction,
    pub cb_modes: usize,
    /// Craig-Bampton master points; default: the nonlinear point and every
    /// exciter point.
    pub cb_masters: Option<Vec<String>>,
    pub point: Vec<PointSpec>,
    /// Grounded cubic spring `f = k3 u^3` at `nonlinear_point` [N/m^3] (0: none).
    pub k3_n_per_m3: f64,
    pub nonlinear_point: Option<String>,
    pub allow_rigid_body_modes: bool,
}

/// `[structure]` with `kind = "beam"`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct BeamStructureSpec {
    pub kind: StructureKind,
    pub length_m: f64,
    pub height_m: f64,
    pub width_m: f64,
    pub youngs_modulus_pa: f64,
    pub density_kg_m3: f64,
    pub n_nodes: usize,
    /// `clamped-free`, `clamped-clamped`, `pinned-pinned` or `clamped-pinned`.
    pub boundary: BoundaryCondition,
    pub k3_n_per_m3: f64,
    pub damping_ratio: f64,
    pub reduction: Reduction,
    pub cb_modes: usize,
}

impl Default for BeamStructureSpec {
    fn default() -> Self {
        use nlmode::benchmark as b;
        Self {
            kind: StructureKind::Beam,
            length_m: b::LENGTH_M,
            height_m: b::HEIGHT_M,
            width_m: b::WIDTH_M,
            youngs_modulus_pa: b::YOUNGS_MODULUS_PA,
            density_kg_m3: b::DENSITY_KG_M3,
            n_nodes: b::N_NODES,
            boundary: BoundaryCondition::ClampedFree,
            k3_n_per_m3: b::K3_N_PER_M3,
            damping_ratio: b::D0,
            reduction: Reduction::CraigBampton,
            cb_modes: b::CB_MODES,
        }
    }
}

/// The exciter's stinger (`exciter[i].stinger`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StingerKind {
    /// Elastic, `stinger_stiffness_n_per_m`.
    #[default]
    Elastic,
    /// The armature attached directly.
    Rigid,
}

/// A location along the beam as a fraction of its length, written `"l/3"`,
/// `"2l/3"`, `"l"` or as a number (`0.5`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LengthFraction(pub f64);

impl<'de> Deserialize<'de> for LengthFraction {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Number(f64),
            Text(String),
        }
        let expected =
            "a fraction of the length like \"l/3\", \"2l/3\", \"l\" or a number in (0, 1]";
        match Raw::deserialize(d)
            .map_err(|_| serde::de::Error::custom(format!("expected {expected}")))?
        {
            Raw::Number(f) => Ok(LengthFraction(f)),
            Raw::Text(s) => parse_fraction(&s).map(LengthFraction).ok_or_else(|| {
                serde::de::Error::custom(format!("expected {expected}, got \"{s}\""))
            }),
        }
    }
}

impl Serialize for LengthFraction {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(self.0)
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExciterSpec {
    pub name: String,
    /// Beam: fraction of the length: "l/3", "2l/3", "l" or a number in (0, 1].
    pub location: Option<LengthFraction>,
    /// Matrices: the `[[structure.point]]` the exciter drives.
    pub point: Option<String>,
    pub location_m: Option<f64>,
    pub inductance_h: f64,
    pub resistance_ohm: f64,
    pub force_constant_n_per_a: f64,
    pub armature_mass_kg: f64,
    pub armature_stiffness_n_per_m: f64,
    /// `D_a` incl. electro-mechanical damping; the paper's 1.36 when neither
    /// this nor `armature_damping_n_s_per_m` is given.
    pub armature_damping_ratio: Option<f64>,
    pub armature_damping_n_s_per_m: Option<f64>,
    pub stinger: StingerKind,
    pub stinger_stiffness_n_per_m: f64,
    /// Voltage amplitude of this exciter [V]; default: `[excitation] voltage_v`.
    pub voltage_v: Option<f64>,
    /// Phase of this exciter's voltage against the sweep's `cos Phi` [rad].
    pub phase_rad: f64,
}

impl Default for ExciterSpec {
    fn default() -> Self {
        use nlmode::benchmark as b;
        Self {
            name: "shaker".into(),
            location: None,
            point: None,
            location_m: None,
            inductance_h: b::SHAKER_L_H,
            resistance_ohm: b::SHAKER_R_OHM,
            force_constant_n_per_a: b::SHAKER_G_N_PER_A,
            armature_mass_kg: b::SHAKER_MA_KG,
            armature_stiffness_n_per_m: b::SHAKER_KA_N_PER_M,
            armature_damping_ratio: None,
            armature_damping_n_s_per_m: None,
            stinger: StingerKind::Elastic,
            stinger_stiffness_n_per_m: b::STINGER_KS_N_PER_M,
            voltage_v: None,
            phase_rad: 0.0,
        }
    }
}

fn default_exciters() -> Vec<ExciterSpec> {
    vec![ExciterSpec {
        location: Some(LengthFraction(2.0 / 3.0)),
        ..Default::default()
    }]
}
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExcitationSpec {
    /// Voltage amplitude `u_hat` [V].
    pub voltage_v: f64,
    pub eta_start: f64,
    pub eta_end: f64,
    /// The paper's `r`: `dOmega/dt = r omega0^2/(2 pi)`.
    pub rate_per_pseudo_period: f64,
}

impl Default for ExcitationSpec {
    fn default() -> Self {
        Self {
            voltage_v: 10.0,
            eta_start: 0.8,
            eta_end: 1.8,
            rate_per_pseudo_period: 0.02,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct NmaSpec {
    /// Harmonic order `H` of the modal table (default
    /// [`nlmode::nma::SWEEP_TABLE_HARMONICS`] = 7: agrees with `H = 13` within
    /// the refined table's accuracy up to `a = 2.5e-3`).
    pub harmonics: usize,
    /// Largest tip amplitude |q_tip,1| the NMA continues to [m].
    pub max_tip_amplitude_m: f64,
    /// Modal table to use instead of computing one (JSON, `nlmode-modal-table`).
    pub table: Option<String>,
    /// Compute the conservative branch too (for the backbone plot).
    pub conservative: bool,
}

impl Default for NmaSpec {
    fn default() -> Self {
        Self {
            harmonics: nlmode::nma::SWEEP_TABLE_HARMONICS,
            max_tip_amplitude_m: 0.02,
            table: None,
            conservative: true,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RunSpec {
    pub methods: Vec<Method>,
    /// Number of excitation frequencies of `linear-frf` / `linear-steady`.
    pub frf_points: usize,
}

impl Default for RunSpec {
    fn default() -> Self {
        Self {
            methods: vec![
                Method::Reference,
                Method::Nlmode,
                Method::LinearSlowflow,
                Method::LinearSteady,
                Method::LinearFrf,
                Method::Cosim,
            ],
            frf_points: 500,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImposedForceSpec {
    /// Where the imposed force envelope comes from: a method of this run
    /// (`nlmode`, `reference`) or a CSV file (columns `omega_rad_s`,
    /// `force_amplitude_N`, `force_phase_rad`).
    pub source: ForceSource,
    /// Relative natural-frequency error `eps`: omega(a) -> (1 + eps) omega(a).
    pub frequency_error: f64,
    /// Additive natural-frequency offset [rad/s].
    pub frequency_offset_rad_s: f64,
    /// Additive natural-frequency offset as a fraction of omega0 (the paper's
    /// "+5 %" amplitude-independent offset is 0.05); added to `frequency_offset_rad_s`.
    pub frequency_offset_omega0: f64,
    /// Apply the same frequency error to `nlmode` (the paper's "NM with shaker, +5 %").
    pub apply_to_nlmode: bool,
}

/// Source of the imposed force envelope (`imposed_force.source`): `"nlmode"`,
/// `"reference"` or the path of a CSV file.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, Serialize)]
#[serde(from = "String", into = "String")]
pub enum ForceSource {
    /// The drive-point force of `nlmode` of this run.
    Nlmode,
    /// The windowed force envelope of `reference` of this run.
    Reference,
    /// A CSV file in the `<method>_envelope.csv` format.
    Csv(PathBuf),
}

impl From<String> for ForceSource {
    fn from(s: String) -> Self {
        match s.as_str() {
            "nlmode" => ForceSource::Nlmode,
            "reference" => ForceSource::Reference,
            _ => ForceSource::Csv(s.into()),
        }
    }
}

impl From<ForceSource> for String {
    fn from(s: ForceSource) -> Self {
        match s {
            ForceSource::Nlmode => "nlmode".into(),
            ForceSource::Reference => "reference".into(),
            ForceSource::Csv(p) => p.display().to_string(),
        }
    }
}

impl Default for ImposedForceSpec {
    fn default() -> Self {
        Self {
            source: ForceSource::Nlmode,
            frequency_error: 0.0,
            frequency_offset_rad_s: 0.0,
            frequency_offset_omega0: 0.0,
            apply_to_nlmode: false,
        }
    }
}

/// Integration of the slow flow (`nlmode`, `linear-slowflow`, `imposed-force`).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlowFlowSpec {
    /// Relative tolerance of `nlmode` and `linear-slowflow`.
    pub rtol: f64,
    /// Relative tolerance of `imposed-force` (more sensitive near a force minimum).
    pub imposed_force_rtol: f64,
    /// Output samples along the sweep, uniform in time (both ends included).
    pub output_samples: usize,
}

impl Default for SlowFlowSpec {
    fn default() -> Self {
        let lib = nlmode::reduced::SlowFlowOptions::default();
        Self {
            rtol: lib.rtol,
            imposed_force_rtol: 1e-5,
            output_samples: lib.output_samples,
        }
    }
}

impl SlowFlowSpec {
    /// The library options for `method`.
    pub fn options(&self, method: Method) -> nlmode::reduced::SlowFlowOptions {
        nlmode::reduced::SlowFlowOptions {
            rtol: if method == Method::ImposedForce {
                self.imposed_force_rtol
            } else {
                self.rtol
            },
            output_samples: self.output_samples,
            ..Default::default()
        }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceSpec {
    /// Integrator of the full-order reference: `exponential` or
    /// `dormand-prince`; the library default when omitted or `""`.
    #[serde(deserialize_with = "integrator_or_empty")]
    pub integrator: Option<Integrator>,
    pub rtol: f64,
    /// Output sample interval of the time series [s] (0 = a library default).
    pub output_interval_s: f64,
}

/// `""` (the library default) or an [`Integrator`] name.
fn integrator_or_empty<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Integrator>, D::Error> {
    let s = String::deserialize(d)?;
    if s.is_empty() {
        return Ok(None);
    }
    Integrator::deserialize(serde::de::value::StrDeserializer::<D::Error>::new(&s)).map(Some)
}

impl Default for ReferenceSpec {
    fn default() -> Self {
        Self {
            integrator: None,
            rtol: 1e-6,
            output_interval_s: 0.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct CosimSpec {
    /// Co-simulation master algorithm.
    pub algorithm: CosimAlgorithm,
    /// Macro (communication) step [s].
    pub macro_step_s: f64,
    pub structure_fmu: Option<String>,
    pub shaker_fmu: Option<String>,
}

/// Co-simulation master algorithm (`cosim.algorithm`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CosimAlgorithm {
    /// Both units stepped on the inputs of the last communication point.
    #[default]
    Jacobi,
    /// Units stepped in sequence, each on the new outputs of the one before.
    GaussSeidel,
    /// Quasi-Newton iteration of the coupling with rollback.
    Iterative,
}

impl Default for CosimSpec {
    fn default() -> Self {
        Self {
            algorithm: CosimAlgorithm::Jacobi,
            macro_step_s: 1e-5,
            structure_fmu: None,
            shaker_fmu: None,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSpec {
    pub time_series: bool,
    pub plots: bool,
    /// Package structure.fmu and shaker.fmu into `<out>/fmus`.
    pub fmus: bool,
    /// The point whose displacement the envelopes call `tip_amplitude_m`
    /// (default `tip` for beams; required for matrices).
    pub response_point: Option<String>,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            time_series: true,
            plots: true,
            fmus: true,
            response_point: None,
        }
    }
}

/// A scenario error: the key at fault as the user wrote it (`exciter[1].stinger`,
/// `structure.lenght_m` for an unknown key), what was expected and, for errors
/// found while reading the file, the line (`key` is `scenario` for TOML syntax
/// errors).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {message}{}", line.map(|l| format!(" (line {l})")).unwrap_or_default())]
pub struct ScenarioError {
    pub key: String,
    pub message: String,
    pub line: Option<usize>,
}

/// Largest `structure.n_nodes` of a beam: its matrices are assembled dense
/// (2000 nodes: about 4000 DOFs, 128 MB per matrix).
pub const MAX_BEAM_NODES: usize = 2000;
/// Largest `excitation.eta_start` / `eta_end` (`Omega / omega0`): the time
/// step of every integrator follows the highest excitation frequency.
pub const MAX_ETA: f64 = 100.0;
/// Smallest `excitation.rate_per_pseudo_period`: a sweep of `|eta_end -
/// eta_start|` lasts `|eta_end - eta_start| / r` pseudo periods (1e5 at the
/// limit, a 4-million-sample reference at 40 samples per period).
pub const MIN_RATE_PER_PSEUDO_PERIOD: f64 = 1e-5;
/// Tip amplitude the NMA starts from \[m\] (`nma.max_tip_amplitude_m` must exceed it).
pub const NMA_START_TIP_AMPLITUDE_M: f64 = 1e-7;

fn bad(key: &str, message: impl Into<String>) -> ScenarioError {
    ScenarioError {
        key: key.into(),
        message: message.into(),
        line: None,
    }
}

fn positive(key: &str, v: f64) -> Result<(), ScenarioError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(
            key,
            format!("expected a positive finite number, got {v}"),
        ))
    }
}

impl Scenario {
    /// Parse TOML text (unknown keys and unknown spellings are errors naming the
    /// key) and validate it.
    pub fn parse(text: &str) -> Result<Self, ScenarioError> {
        let s: Scenario =
            serde_path_to_error::deserialize(toml::Deserializer::new(text)).map_err(|e| {
                let path = e.path().to_string();
                let inner = e.into_inner();
                let line = inner
                    .span()
                    .map(|sp| text[..sp.start.min(text.len())].matches('\n').count() + 1);
                ScenarioError {
                    key: if path == "." { "scenario".into() } else { path },
                    message: inner.message().trim().to_string(),
                    line,
                }
            })?;
        s.validate()?;
        Ok(s)
    }

    /// The embedded default scenario.
    pub fn default_scenario() -> Self {
        Self::parse(DEFAULT_SCENARIO).expect("embedded default scenario is valid")
    }

    /// Check every value; the error names the key.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        match &self.structure {
            StructureSpec::Beam(st) => self.validate_beam(st)?,
            StructureSpec::Matrices(st) => self.validate_matrices(st)?,
        }
        self.validate_nonlinearities()?;
        self.validate_rest()
    }

    /// `[structure]` of `kind = "matrices"` and the keys that refer to its points
    /// (the matrices themselves are checked when they are read).
    fn validate_matrices(&self, st: &MatricesStructureSpec) -> Result<(), ScenarioError> {
        for (i, p) in st.point.iter().enumerate() {
            if p.name.is_empty() {
                return Err(bad(
                    &format!("structure.point[{i}].name"),
                    "expected a non-empty name",
                ));
            }
            if st.point[..i].iter().any(|o| o.name == p.name) {
                return Err(bad(
                    &format!("structure.point[{i}].name"),
                    format!("point names must be unique, '{}' repeats", p.name),
                ));
            }
        }
        let names: Vec<&str> = st.point.iter().map(|p| p.name.as_str()).collect();
        let known = |key: &str, name: &str| {
            if names.contains(&name) {
                Ok(())
            } else {
                Err(bad(
                    key,
                    format!("unknown point '{name}'; the [[structure.point]] names are {names:?}"),
                ))
            }
        };
        let given = [
            st.damping_mtx.is_some(),
            st.rayleigh.is_some(),
            st.damping_ratio.is_some(),
        ];
        if given.iter().filter(|g| **g).count() != 1 {
            return Err(bad(
                "structure.damping_mtx",
                "give exactly one of damping_mtx, rayleigh = [alpha, beta] or damping_ratio (+ damping_mode)",
            ));
        }
        if st.damping_mode.is_some() && st.damping_ratio.is_none() {
            return Err(bad(
                "structure.damping_mode",
                "damping_mode needs damping_ratio",
            ));
        }
        if let Some(r) = st.damping_ratio {
            if !(r.is_finite() && (0.0..1.0).contains(&r)) {
                return Err(bad(
                    "structure.damping_ratio",
                    format!("expected 0 <= D < 1, got {r}"),
                ));
            }
        }
        if st.damping_mode == Some(0) {
            return Err(bad(
                "structure.damping_mode",
                "expected a mode number >= 1 (1 = the lowest mode)",
            ));
        }
        if let Some([a, b]) = st.rayleigh {
            for (k, v) in [("structure.rayleigh[0]", a), ("structure.rayleigh[1]", b)] {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(bad(k, format!("expected a finite number >= 0, got {v}")));
                }
            }
        }
        if !(st.k3_n_per_m3.is_finite() && st.k3_n_per_m3 >= 0.0) {
            return Err(bad(
                "structure.k3_n_per_m3",
                format!("expected a finite number >= 0, got {}", st.k3_n_per_m3),
            ));
        }
        match &st.nonlinear_point {
            Some(p) => known("structure.nonlinear_point", p)?,
            None if st.k3_n_per_m3 != 0.0 => {
                return Err(bad(
                    "structure.nonlinear_point",
                    "missing: k3_n_per_m3 needs the point of the cubic spring",
                ))
            }
            None => {}
        }
        if st.reduction == Reduction::CraigBampton && st.cb_modes == 0 {
            return Err(bad(
                "structure.cb_modes",
                "expected at least 1 fixed-interface mode",
            ));
        }
        let max_cb = nlmode::structure::sparse::MAX_SPARSE_MODES;
        if st.reduction == Reduction::CraigBampton && st.cb_modes > max_cb {
            return Err(bad(
                "structure.cb_modes",
                format!(
                    "expected at most {max_cb} fixed-interface modes, got {}",
                    st.cb_modes
                ),
            ));
        }
        if let Some(m) = &st.cb_masters {
            for (i, p) in m.iter().enumerate() {
                known(&format!("structure.cb_masters[{i}]"), p)?;
            }
        }
        for (i, ex) in self.exciter.iter().enumerate() {
            if ex.location.is_some() || ex.location_m.is_some() {
                return Err(bad(
                    &format!("exciter[{i}].location"),
                    "a structure of kind = \"matrices\" takes point = \"name\", not location \
                     (without [[exciter]] tables the default exciter at 2l/3 applies: add one with point = \"name\")",
                ));
            }
            match &ex.point {
                Some(p) => known(&format!("exciter[{i}].point"), p)?,
                None => {
                    return Err(bad(
                        &format!("exciter[{i}].point"),
                        "missing: expected point = \"name\" of a [[structure.point]]",
                    ))
                }
            }
        }
        match &self.output.response_point {
            Some(p) => known("output.response_point", p)?,
            None => {
                return Err(bad(
                    "output.response_point",
                    "missing: a structure of kind = \"matrices\" needs the point whose displacement is tip_amplitude_m",
                ))
            }
        }
        Ok(())
    }

    fn validate_beam(&self, st: &BeamStructureSpec) -> Result<(), ScenarioError> {
        for (i, ex) in self.exciter.iter().enumerate() {
            if ex.point.is_some() {
                return Err(bad(
                    &format!("exciter[{i}].point"),
                    "a beam takes location = \"2l/3\" or location_m, not point",
                ));
            }
        }
        positive("structure.length_m", st.length_m)?;
        positive("structure.height_m", st.height_m)?;
        positive("structure.width_m", st.width_m)?;
        positive("structure.youngs_modulus_pa", st.youngs_modulus_pa)?;
        positive("structure.density_kg_m3", st.density_kg_m3)?;
        if !(3..=MAX_BEAM_NODES).contains(&st.n_nodes) {
            return Err(bad(
                "structure.n_nodes",
                format!(
                    "expected 3 ..= {MAX_BEAM_NODES} nodes (the beam is assembled dense; a larger model \
                     goes in as kind = \"matrices\"), got {}",
                    st.n_nodes
                ),
            ));
        }
        if st.boundary == BoundaryCondition::FreeFree {
            return Err(bad(
                "structure.boundary",
                "expected clamped-free, clamped-clamped, pinned-pinned or clamped-pinned, got 'free-free'",
            ));
        }
        if !(st.k3_n_per_m3.is_finite() && st.k3_n_per_m3 >= 0.0) {
            return Err(bad(
                "structure.k3_n_per_m3",
                format!("expected a finite number >= 0, got {}", st.k3_n_per_m3),
            ));
        }
        if !(st.damping_ratio.is_finite() && st.damping_ratio >= 0.0 && st.damping_ratio < 1.0) {
            return Err(bad(
                "structure.damping_ratio",
                format!("expected 0 <= D0 < 1, got {}", st.damping_ratio),
            ));
        }
        if st.reduction == Reduction::CraigBampton && st.cb_modes == 0 {
            return Err(bad(
                "structure.cb_modes",
                "expected at least 1 fixed-interface mode",
            ));
        }
        for i in 0..self.exciter.len() {
            self.exciter_location_m(i)?;
        }
        Ok(())
    }

    fn validate_rest(&self) -> Result<(), ScenarioError> {
        self.phase_resonance.validate()?;
        self.force_control.validate("force_control")?;
        self.response_control.validate("response_control")?;
        self.test_plan.validate()?;
        if self.exciter.is_empty() {
            return Err(bad("exciter", "expected at least one [[exciter]] table"));
        }
        for (i, ex) in self.exciter.iter().enumerate() {
            let k = |f: &str| format!("exciter[{i}].{f}");
            positive(&k("inductance_h"), ex.inductance_h)?;
            positive(&k("resistance_ohm"), ex.resistance_ohm)?;
            positive(&k("force_constant_n_per_a"), ex.force_constant_n_per_a)?;
            positive(&k("armature_mass_kg"), ex.armature_mass_kg)?;
            positive(
                &k("armature_stiffness_n_per_m"),
                ex.armature_stiffness_n_per_m,
            )?;
            match (ex.armature_damping_ratio, ex.armature_damping_n_s_per_m) {
                (Some(_), Some(_)) => return Err(bad(
                    &k("armature_damping_ratio"),
                    "give either armature_damping_ratio or armature_damping_n_s_per_m, not both",
                )),
                (Some(d), None) => positive(&k("armature_damping_ratio"), d)?,
                (None, Some(d)) if !(d.is_finite() && d >= 0.0) => {
                    return Err(bad(
                        &k("armature_damping_n_s_per_m"),
                        format!("expected a finite number >= 0, got {d}"),
                    ))
                }
                _ => {}
            }
            positive(
                &k("stinger_stiffness_n_per_m"),
                ex.stinger_stiffness_n_per_m,
            )?;
            if let Some(v) = ex.voltage_v {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(bad(
                        &k("voltage_v"),
                        format!("expected a finite voltage >= 0, got {v}"),
                    ));
                }
            }
            if !ex.phase_rad.is_finite() {
                return Err(bad(
                    &k("phase_rad"),
                    format!("expected a finite phase, got {}", ex.phase_rad),
                ));
            }
            if self.exciter[..i].iter().any(|o| o.name == ex.name) {
                return Err(bad(
                    &k("name"),
                    format!("exciter names must be unique, '{}' repeats", ex.name),
                ));
            }
        }
        let e = &self.excitation;
        // 0 V (or -0.0) has no response: every ratio (force drop) would be 0/0
        if !(e.voltage_v.is_finite() && e.voltage_v > 0.0) {
            return Err(bad(
                "excitation.voltage_v",
                format!("expected a finite voltage > 0, got {}", e.voltage_v),
            ));
        }
        for (key, eta) in [
            ("excitation.eta_start", e.eta_start),
            ("excitation.eta_end", e.eta_end),
        ] {
            if !(eta.is_finite() && eta > 0.0 && eta <= MAX_ETA) {
                return Err(bad(
                    key,
                    format!("expected 0 < Omega/omega0 <= {MAX_ETA}, got {eta:e}"),
                ));
            }
        }
        if e.eta_start == e.eta_end {
            return Err(bad(
                "excitation.eta_end",
                format!("expected eta_end != eta_start (both {})", e.eta_start),
            ));
        }
        let r = e.rate_per_pseudo_period;
        if !(r.is_finite() && r >= MIN_RATE_PER_PSEUDO_PERIOD) {
            return Err(bad(
                "excitation.rate_per_pseudo_period",
                format!(
                    "expected a rate >= {MIN_RATE_PER_PSEUDO_PERIOD:e} (the sweep lasts |eta_end - eta_start| / r pseudo periods), got {r:e}"
                ),
            ));
        }
        if !(1..=64).contains(&self.nma.harmonics) {
            return Err(bad(
                "nma.harmonics",
                format!("expected 1 <= H <= 64, got {}", self.nma.harmonics),
            ));
        }
        let a = self.nma.max_tip_amplitude_m;
        if !(a.is_finite() && a > NMA_START_TIP_AMPLITUDE_M) {
            return Err(bad(
                "nma.max_tip_amplitude_m",
                format!(
                    "expected an amplitude above the NMA's start {NMA_START_TIP_AMPLITUDE_M:e} m, got {a:e}"
                ),
            ));
        }
        if self.run.methods.is_empty() {
            let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
            return Err(bad(
                "run.methods",
                format!("expected a non-empty list from {names:?}"),
            ));
        }
        if self.run.frf_points < 2 {
            return Err(bad(
                "run.frf_points",
                format!("expected at least 2, got {}", self.run.frf_points),
            ));
        }
        if !self.imposed_force.frequency_error.is_finite()
            || self.imposed_force.frequency_error <= -1.0
        {
            return Err(bad(
                "imposed_force.frequency_error",
                "expected a finite number > -1",
            ));
        }
        for (k, v) in [
            (
                "imposed_force.frequency_offset_rad_s",
                self.imposed_force.frequency_offset_rad_s,
            ),
            (
                "imposed_force.frequency_offset_omega0",
                self.imposed_force.frequency_offset_omega0,
            ),
        ] {
            if !v.is_finite() {
                return Err(bad(k, format!("expected a finite number, got {v}")));
            }
        }
        if let ForceSource::Csv(p) = &self.imposed_force.source {
            if p.as_os_str().is_empty() {
                return Err(bad(
                    "imposed_force.source",
                    "expected \"nlmode\", \"reference\" or the path of a CSV file, got \"\"",
                ));
            }
        }
        for (k, v) in [
            ("slowflow.rtol", self.slowflow.rtol),
            (
                "slowflow.imposed_force_rtol",
                self.slowflow.imposed_force_rtol,
            ),
        ] {
            if !(v > 0.0 && v < 0.1) {
                return Err(bad(k, format!("expected a number in (0, 0.1), got {v}")));
            }
        }
        if self.slowflow.output_samples < 2 {
            return Err(bad(
                "slowflow.output_samples",
                format!("expected at least 2, got {}", self.slowflow.output_samples),
            ));
        }
        positive("reference.rtol", self.reference.rtol)?;
        if !(self.reference.output_interval_s.is_finite()
            && self.reference.output_interval_s >= 0.0)
        {
            return Err(bad(
                "reference.output_interval_s",
                "expected a finite number >= 0",
            ));
        }
        positive("cosim.macro_step_s", self.cosim.macro_step_s)?;
        self.validate_attachments()?;
        Ok(())
    }

    /// Makes the relative paths of `[structure]` (the Matrix Market files)
    /// relative to `base`, the folder of the scenario file.
    pub fn resolve_paths(&mut self, base: &std::path::Path) {
        for a in &mut self.attachment {
            a.resolve_paths(base);
        }
        if let StructureSpec::Matrices(m) = &mut self.structure {
            for p in [&mut m.mass_mtx, &mut m.stiffness_mtx]
                .into_iter()
                .chain(m.damping_mtx.as_mut())
            {
                if p.is_relative() {
                    *p = base.join(&*p);
                }
            }
        }
    }

    /// The point whose displacement is `tip_amplitude_m`: `[output]
    /// response_point`, `tip` for beams when not given.
    pub fn response_point(&self) -> String {
        self.output
            .response_point
            .clone()
            .unwrap_or_else(|| nlmode::structure::paper::TIP.into())
    }

    /// Location of exciter `i` along the beam [m] (an error for other kinds).
    pub fn exciter_location_m(&self, i: usize) -> Result<f64, ScenarioError> {
        let ex = &self.exciter[i];
        let Some(beam) = self.structure.beam() else {
            return Err(bad(
                &format!("exciter[{i}].location"),
                "only a beam has locations; use point = \"name\"",
            ));
        };
        let l = beam.length_m;
        let key = format!("exciter[{i}].location");
        let x = match (ex.location, ex.location_m) {
            (Some(_), Some(_)) => {
                return Err(bad(&key, "give either location or location_m, not both"))
            }
            (None, None) => {
                return Err(bad(
                    &key,
                    "missing: expected location = \"2l/3\" (fraction of l) or location_m",
                ))
            }
            (None, Some(x)) => x,
            (Some(LengthFraction(f)), None) => l * f,
        };
        if !(x.is_finite() && x > 0.0 && x <= l * (1.0 + 1e-12)) {
            return Err(bad(
                &key,
                format!("location {x} m lies outside the beam (0, {l}] m"),
            ));
        }
        Ok(x.min(l))
    }
}

// ---- [[nonlinearity]]: the nonlinear element library --------------------------

/// The element types of `[[nonlinearity]] type = "..."`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum NonlinearityKind {
    /// `f = k3 u^3` (`k3_n_per_m3`).
    CubicSpring,
    /// `f = sum_p c_p u^p` (`coefficients = {"2" = c2, "3" = c3}`, `c_p` in N/m^p).
    PolynomialSpring,
    /// Contact `f = k max(u - gap, 0)` (`stiffness_n_per_m`, `gap_m`).
    UnilateralSpring,
    /// `f = F_s tanh(v / v_r)` (`slip_force_n`, `regularization_velocity_m_s`).
    TanhFriction,
    /// Jenkins element (`tangential_stiffness_n_per_m`, `slip_force_n`).
    ElasticDryFriction,
    /// `f = c2 v |v|` (`c2_n_s2_per_m2`).
    QuadraticDamper,
}

impl NonlinearityKind {
    /// The spelling in scenarios.
    pub fn name(self) -> &'static str {
        match self {
            NonlinearityKind::CubicSpring => "cubic-spring",
            NonlinearityKind::PolynomialSpring => "polynomial-spring",
            NonlinearityKind::UnilateralSpring => "unilateral-spring",
            NonlinearityKind::TanhFriction => "tanh-friction",
            NonlinearityKind::ElasticDryFriction => "elastic-dry-friction",
            NonlinearityKind::QuadraticDamper => "quadratic-damper",
        }
    }

    /// The parameter keys of this type (all required).
    fn keys(self) -> &'static [&'static str] {
        match self {
            NonlinearityKind::CubicSpring => &["k3_n_per_m3"],
            NonlinearityKind::PolynomialSpring => &["coefficients"],
            NonlinearityKind::UnilateralSpring => &["stiffness_n_per_m", "gap_m"],
            NonlinearityKind::TanhFriction => &["slip_force_n", "regularization_velocity_m_s"],
            NonlinearityKind::ElasticDryFriction => {
                &["tangential_stiffness_n_per_m", "slip_force_n"]
            }
            NonlinearityKind::QuadraticDamper => &["c2_n_s2_per_m2"],
        }
    }
}

/// One `[[nonlinearity]]` table: a law acting at a point (grounded, `u` = the
/// point's displacement) or between two points (`u = u_a - u_b`); the element's
/// force acts on the structure as `w f` with `w = e` or `w = e_a - e_b`.
/// Parameters carry their units in their names; which ones a type takes is in
/// [`NonlinearityKind`] (docs/scenario.md).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct NonlinearitySpec {
    #[serde(rename = "type")]
    pub kind: NonlinearityKind,
    /// Element name (default `nonlinearity<i>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Grounded element at this point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point: Option<String>,
    /// Relative element between `[a, b]`: `u = u_a - u_b`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points: Option<Vec<String>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k3_n_per_m3: Option<f64>,
    /// Power (as a string key, TOML tables have string keys) -> `c_p` [N/m^p].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coefficients: Option<std::collections::BTreeMap<String, f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness_n_per_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gap_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slip_force_n: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub regularization_velocity_m_s: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_stiffness_n_per_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub c2_n_s2_per_m2: Option<f64>,
}

impl NonlinearitySpec {
    /// The element name: `name` or `nonlinearity<i>`.
    pub fn element_name(&self, i: usize) -> String {
        self.name
            .clone()
            .unwrap_or_else(|| format!("nonlinearity{i}"))
    }

    /// The points the element uses (one grounded, or `[a, b]`).
    pub fn point_names(&self) -> Vec<String> {
        match (&self.point, &self.points) {
            (Some(p), _) => vec![p.clone()],
            (None, Some(ps)) => ps.clone(),
            (None, None) => Vec::new(),
        }
    }

    fn given(&self, key: &str) -> bool {
        match key {
            "k3_n_per_m3" => self.k3_n_per_m3.is_some(),
            "coefficients" => self.coefficients.is_some(),
            "stiffness_n_per_m" => self.stiffness_n_per_m.is_some(),
            "gap_m" => self.gap_m.is_some(),
            "slip_force_n" => self.slip_force_n.is_some(),
            "regularization_velocity_m_s" => self.regularization_velocity_m_s.is_some(),
            "tangential_stiffness_n_per_m" => self.tangential_stiffness_n_per_m.is_some(),
            "c2_n_s2_per_m2" => self.c2_n_s2_per_m2.is_some(),
            _ => false,
        }
    }

    /// The `nlmode` law of table `i` with validated parameters; errors name the
    /// key (`nonlinearity[1].slip_force_n`).
    pub fn law(
        &self,
        i: usize,
    ) -> Result<std::sync::Arc<dyn nlmode::structure::NonlinearLaw>, ScenarioError> {
        use nlmode::structure::{
            CubicSpring, ElasticDryFriction, PolynomialSpring, QuadraticDamper,
            RegularizedFriction, StructureError, UnilateralSpring,
        };
        use std::sync::Arc;
        let key = |k: &str| format!("nonlinearity[{i}].{k}");
        const ALL: [&str; 8] = [
            "k3_n_per_m3",
            "coefficients",
            "stiffness_n_per_m",
            "gap_m",
            "slip_force_n",
            "regularization_velocity_m_s",
            "tangential_stiffness_n_per_m",
            "c2_n_s2_per_m2",
        ];
        let keys = self.kind.keys();
        for k in ALL {
            if self.given(k) && !keys.contains(&k) {
                return Err(bad(
                    &key(k),
                    format!(
                        "not a parameter of type = \"{}\" (it takes {keys:?})",
                        self.kind.name()
                    ),
                ));
            }
        }
        if let Some(k) = keys.iter().find(|k| !self.given(k)) {
            return Err(bad(
                &key(k),
                format!("missing: type = \"{}\" needs {keys:?}", self.kind.name()),
            ));
        }
        let num = |v: Option<f64>| v.unwrap_or(f64::NAN);
        let err = |e: StructureError| -> ScenarioError {
            let (name, msg) = match &e {
                StructureError::NonPositive { name, value } => (
                    *name,
                    format!("expected a positive finite number, got {value}"),
                ),
                StructureError::InvalidParameter {
                    name,
                    value,
                    expected,
                } => (*name, format!("expected {expected}, got {value}")),
                other => ("type", other.to_string()),
            };
            // nlmode's RegularizedFriction names its field regularization_m_s
            let name = if name == "regularization_m_s" {
                "regularization_velocity_m_s"
            } else {
                name
            };
            bad(&key(name), msg)
        };
        Ok(match self.kind {
            NonlinearityKind::CubicSpring => {
                Arc::new(CubicSpring::new(num(self.k3_n_per_m3)).map_err(err)?)
            }
            NonlinearityKind::PolynomialSpring => {
                let mut terms = Vec::new();
                for (p, c) in self.coefficients.iter().flatten() {
                    let power = p
                        .trim()
                        .parse::<i32>()
                        .ok()
                        .filter(|p| (1..=PolynomialSpring::MAX_POWER).contains(p))
                        .ok_or_else(|| {
                            bad(
                                &format!("nonlinearity[{i}].coefficients.{p}"),
                                format!(
                                    "expected a power between 1 and {} as the key (\"3\" = c3 in N/m^3)",
                                    PolynomialSpring::MAX_POWER
                                ),
                            )
                        })?;
                    if !c.is_finite() {
                        return Err(bad(
                            &format!("nonlinearity[{i}].coefficients.{p}"),
                            format!("expected a finite coefficient, got {c}"),
                        ));
                    }
                    terms.push((power, *c));
                }
                if terms.is_empty() {
                    return Err(bad(
                        &key("coefficients"),
                        "expected at least one term, e.g. {\"3\" = 6e9}",
                    ));
                }
                Arc::new(PolynomialSpring::new(&terms).map_err(err)?)
            }
            NonlinearityKind::UnilateralSpring => Arc::new(
                UnilateralSpring::new(num(self.stiffness_n_per_m), num(self.gap_m)).map_err(err)?,
            ),
            NonlinearityKind::TanhFriction => Arc::new(
                RegularizedFriction::new(
                    num(self.slip_force_n),
                    num(self.regularization_velocity_m_s),
                )
                .map_err(err)?,
            ),
            NonlinearityKind::ElasticDryFriction => Arc::new(
                ElasticDryFriction::new(
                    num(self.tangential_stiffness_n_per_m),
                    num(self.slip_force_n),
                )
                .map_err(err)?,
            ),
            NonlinearityKind::QuadraticDamper => {
                Arc::new(QuadraticDamper::new(num(self.c2_n_s2_per_m2)).map_err(err)?)
            }
        })
    }
}

impl Scenario {
    /// `[[nonlinearity]]`: parameters (through [`NonlinearitySpec::law`]),
    /// `point` xor `points = [a, b]` (two different names), unique element names,
    /// and for matrices that the points exist (beam points are checked when the
    /// beam is built: `tip`, `l3`, `2l3` and the exciters' points).
    fn validate_nonlinearities(&self) -> Result<(), ScenarioError> {
        for (i, nl) in self.nonlinearity.iter().enumerate() {
            nl.law(i)?;
            let key = |k: &str| format!("nonlinearity[{i}].{k}");
            match (&nl.point, &nl.points) {
                (Some(_), Some(_)) => {
                    return Err(bad(
                        &key("points"),
                        "give either point = \"name\" (grounded) or points = [\"a\", \"b\"] (relative), not both",
                    ))
                }
                (None, None) => {
                    return Err(bad(
                        &key("point"),
                        "missing: expected point = \"name\" (grounded) or points = [\"a\", \"b\"] (relative, u = u_a - u_b)",
                    ))
                }
                (None, Some(ps)) if ps.len() != 2 || ps[0] == ps[1] => {
                    return Err(bad(
                        &key("points"),
                        format!("expected two different point names [\"a\", \"b\"], got {ps:?}"),
                    ))
                }
                _ => {}
            }
            let name = nl.element_name(i);
            if name.is_empty()
                || self.nonlinearity[..i]
                    .iter()
                    .enumerate()
                    .any(|(j, o)| o.element_name(j) == name)
            {
                return Err(bad(
                    &key("name"),
                    format!("element names must be non-empty and unique, got '{name}'"),
                ));
            }
            if let StructureSpec::Matrices(st) = &self.structure {
                for (j, p) in nl.point_names().iter().enumerate() {
                    if st.point.iter().all(|q| &q.name != p) {
                        let k = match nl.point {
                            Some(_) => key("point"),
                            None => format!("nonlinearity[{i}].points[{j}]"),
                        };
                        let names: Vec<&str> = st.point.iter().map(|q| q.name.as_str()).collect();
                        return Err(bad(
                            &k,
                            format!(
                                "unknown point '{p}'; the [[structure.point]] names are {names:?}"
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

/// "l/3" -> 1/3, "2l/3" -> 2/3, "l" -> 1.
fn parse_fraction(s: &str) -> Option<f64> {
    let s = s.replace(' ', "");
    let (num, den) = match s.split_once('/') {
        Some((n, d)) => (n.to_string(), d.parse::<f64>().ok()?),
        None => (s.clone(), 1.0),
    };
    let num = num.strip_suffix('l').or_else(|| num.strip_suffix('L'))?;
    let k = if num.is_empty() {
        1.0
    } else {
        num.parse::<f64>().ok()?
    };
    if den == 0.0 {
        return None;
    }
    Some(k / den)
}

// ---- [phase_resonance] (method `phase-resonance`) ----

/// The model the phase-resonance test runs on (`phase_resonance.model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PhaseResonanceModel {
    /// The full-order assembly with the shaker, integrated period by period.
    #[default]
    Reference,
    /// The slow flow of `eq:NM` with the shakers (the loop sees its fundamental).
    Nlmode,
    /// The structure, shaker and controller FMUs co-simulated
    /// (`host/src/controlled_cosim.rs`).
    Cosim,
}

impl PhaseResonanceModel {
    /// The spelling in scenarios.
    pub fn name(self) -> &'static str {
        match self {
            PhaseResonanceModel::Reference => "reference",
            PhaseResonanceModel::Nlmode => "nlmode",
            PhaseResonanceModel::Cosim => "cosim",
        }
    }
}

// ---------------------------------------------------------------------------
// `[[attachment]]`: linear attachments besides the exciters (issue 11, item 3).

/// The kind of an `[[attachment]]` (`type = "..."`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AttachmentType {
    /// Mass on a spring and a dashpot to one point.
    TunedMassDamper,
    /// Rigid added mass at one point.
    Mass,
    /// Piezoelectric stack to ground at one point, shunted by a resistor.
    PiezoShunt,
    /// Any `sum_k A_k d^k x/dt^k = b u(t) + c2` with interface rows `B2`.
    Lti,
}

impl AttachmentType {
    /// The spelling in scenarios.
    pub fn name(self) -> &'static str {
        match self {
            AttachmentType::TunedMassDamper => "tuned-mass-damper",
            AttachmentType::Mass => "mass",
            AttachmentType::PiezoShunt => "piezo-shunt",
            AttachmentType::Lti => "lti",
        }
    }
}

/// The default voltage levels \[V\]: the paper beam at 2l/3 from the linear
/// range (0.5 V: |q_tip,1| = 0.14 mm, omega = 1.001 omega0) along the backbone
/// to 40 V (|q_tip,1| = 5.0 mm, omega = 1.93 omega0), below the loop of the
/// 1:3 internal resonance with mode 2 (omega near 2.09 omega0).
pub const DEFAULT_VOLTAGE_LEVELS_V: [f64; 12] = [
    0.5, 1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 14.0, 20.0, 25.0, 32.0, 40.0,
];

/// `[phase_resonance]`: the phase-locked-loop test (docs/scenario.md).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct PhaseResonanceSpec {
    pub model: PhaseResonanceModel,
    /// Voltage amplitudes, in the order they are applied \[V\].
    pub voltage_levels_v: Vec<f64>,
    /// Start frequency of the loop, in units of omega0 (default 1).
    pub eta_start: f64,
    /// Samples per excitation period (demodulation and largest step; default 40).
    pub samples_per_period: usize,
    /// Loop tuning and settle criterion ([`nlmode::control::PllOptions`]).
    pub pll: nlmode::control::PllOptions,
}

impl Default for PhaseResonanceSpec {
    fn default() -> Self {
        Self {
            model: PhaseResonanceModel::Reference,
            voltage_levels_v: DEFAULT_VOLTAGE_LEVELS_V.to_vec(),
            eta_start: 1.0,
            samples_per_period: 40,
            pll: nlmode::control::PllOptions::default(),
        }
    }
}

impl PhaseResonanceSpec {
    fn validate(&self) -> Result<(), ScenarioError> {
        if self.voltage_levels_v.is_empty() {
            return Err(bad(
                "phase_resonance.voltage_levels_v",
                "expected a non-empty list of voltage amplitudes",
            ));
        }
        for (i, v) in self.voltage_levels_v.iter().enumerate() {
            positive(&format!("phase_resonance.voltage_levels_v[{i}]"), *v)?;
        }
        positive("phase_resonance.eta_start", self.eta_start)?;
        if !(8..=1000).contains(&self.samples_per_period) {
            return Err(bad(
                "phase_resonance.samples_per_period",
                format!("expected 8 ..= 1000, got {}", self.samples_per_period),
            ));
        }
        if 2 * (self.pll.harmonics + 1) > self.samples_per_period {
            return Err(bad(
                "phase_resonance.pll.harmonics",
                format!(
                    "expected at most samples_per_period / 2 - 1 = {}, got {}",
                    self.samples_per_period / 2 - 1,
                    self.pll.harmonics
                ),
            ));
        }
        self.pll.validate().map_err(|e| match e {
            nlmode::control::ControlError::BadOption {
                name,
                value,
                expected,
            } => bad(
                &format!("phase_resonance.pll.{name}"),
                format!("expected {expected}, got {value}"),
            ),
            other => bad("phase_resonance.pll", other.to_string()),
        })
    }
}

/// Most frequency steps of a controlled stepped sine, and most response levels.
pub const MAX_CONTROL_STEPS: usize = 2000;
/// Most response levels of `[response_control]`.
pub const MAX_RESPONSE_LEVELS: usize = 50;
/// Most periods per step of a controlled stepped sine.
pub const MAX_PERIODS_PER_STEP: usize = 1_000_000;

/// Default set value of `[force_control] force_set_n` \[N\].
pub const DEFAULT_FORCE_SET_N: f64 = 0.1;
/// Default set values of `[response_control] response_levels_m` \[m\].
pub const DEFAULT_RESPONSE_LEVELS_M: [f64; 3] = [1e-4, 3e-4, 6e-4];

/// `[force_control]` (method `force-controlled`, the force-controlled stepped
/// sine) and `[response_control]` (method `response-controlled`, one stepped
/// sine per response level): the frequency steps, model and controller they
/// share, and the set value of each (every key of both sections is read into
/// this one table; [`SteppedSpec::validate`] rejects the other section's set
/// value by name).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SteppedSpec {
    /// `[force_control]` only: set value of the force fundamental at the
    /// structure \[N\] (default [`DEFAULT_FORCE_SET_N`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_set_n: Option<f64>,
    /// `[response_control]` only: set values of the drive-point response
    /// amplitude \[m\] (default [`DEFAULT_RESPONSE_LEVELS_M`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub response_levels_m: Option<Vec<f64>>,
    /// `reference` or `nlmode` (`cosim` is refused).
    pub model: PhaseResonanceModel,
    /// First and last frequency, in units of omega0 (defaults 0.9, 1.1).
    pub eta_start: f64,
    pub eta_end: f64,
    /// Number of frequency steps, uniform in `Omega` (default 21).
    pub steps: usize,
    /// Voltage amplitude of the first step \[V\] (default 0.5).
    pub voltage_start_v: f64,
    /// Samples per excitation period (default 40).
    pub samples_per_period: usize,
    /// Tolerances and limits ([`nlmode::control::ForceControlOptions`]).
    pub control: nlmode::control::ForceControlOptions,
}

/// `[force_control]`: [`SteppedSpec`] with `force_set_n`.
pub type ForceControlSpec = SteppedSpec;
/// `[response_control]`: [`SteppedSpec`] with `response_levels_m`.
pub type ResponseControlSpec = SteppedSpec;

impl Default for SteppedSpec {
    fn default() -> Self {
        Self {
            force_set_n: None,
            response_levels_m: None,
            model: PhaseResonanceModel::Reference,
            eta_start: 0.9,
            eta_end: 1.1,
            steps: 21,
            voltage_start_v: 0.5,
            samples_per_period: 40,
            control: nlmode::control::ForceControlOptions::default(),
        }
    }
}

/// The two sections of [`SteppedSpec`] and the set-value key each has.
const STEPPED_SECTIONS: [(&str, &str); 2] = [
    ("force_control", "force_set_n"),
    ("response_control", "response_levels_m"),
];

impl SteppedSpec {
    /// `[force_control] force_set_n` \[N\], or its default.
    pub fn force_set_n(&self) -> f64 {
        self.force_set_n.unwrap_or(DEFAULT_FORCE_SET_N)
    }

    /// `[response_control] response_levels_m` \[m\], or their default.
    pub fn response_levels_m(&self) -> &[f64] {
        self.response_levels_m
            .as_deref()
            .unwrap_or(&DEFAULT_RESPONSE_LEVELS_M)
    }

    /// Checks the section `section` (`force_control` or `response_control`):
    /// its set value, no set value of the other section, and the shared keys.
    fn validate(&self, section: &str) -> Result<(), ScenarioError> {
        let set_value = |name: &str| match name {
            "force_set_n" => self.force_set_n.is_some(),
            _ => self.response_levels_m.is_some(),
        };
        for (other, key) in STEPPED_SECTIONS {
            if other != section && set_value(key) {
                return Err(bad(
                    &format!("{section}.{key}"),
                    format!("not a key of [{section}] (it belongs to [{other}])"),
                ));
            }
        }
        if section == "force_control" {
            positive("force_control.force_set_n", self.force_set_n())?;
        } else {
            let levels = self.response_levels_m();
            let n = levels.len();
            if n == 0 || n > MAX_RESPONSE_LEVELS {
                return Err(bad(
                    "response_control.response_levels_m",
                    format!("expected 1 ..= {MAX_RESPONSE_LEVELS} response amplitudes, got {n}"),
                ));
            }
            for (i, v) in levels.iter().enumerate() {
                positive(&format!("response_control.response_levels_m[{i}]"), *v)?;
            }
        }
        positive(&format!("{section}.eta_start"), self.eta_start)?;
        positive(&format!("{section}.eta_end"), self.eta_end)?;
        if !(2..=MAX_CONTROL_STEPS).contains(&self.steps) {
            return Err(bad(
                &format!("{section}.steps"),
                format!("expected 2 ..= {MAX_CONTROL_STEPS}, got {}", self.steps),
            ));
        }
        positive(&format!("{section}.voltage_start_v"), self.voltage_start_v)?;
        if !(8..=1000).contains(&self.samples_per_period) {
            return Err(bad(
                &format!("{section}.samples_per_period"),
                format!("expected 8 ..= 1000, got {}", self.samples_per_period),
            ));
        }
        let c = &self.control;
        if 2 * (c.harmonics + 1) > self.samples_per_period {
            return Err(bad(
                &format!("{section}.control.harmonics"),
                format!(
                    "expected at most samples_per_period / 2 - 1 = {}, got {}",
                    self.samples_per_period / 2 - 1,
                    c.harmonics
                ),
            ));
        }
        for (name, v) in [
            ("settle_periods", c.settle_periods),
            ("max_periods_per_step", c.max_periods_per_step),
        ] {
            if v > MAX_PERIODS_PER_STEP {
                return Err(bad(
                    &format!("{section}.control.{name}"),
                    format!("expected at most {MAX_PERIODS_PER_STEP}, got {v}"),
                ));
            }
        }
        c.validate().map_err(|e| match e {
            nlmode::control::ControlError::BadOption {
                name,
                value,
                expected,
            } => bad(
                &format!("{section}.control.{name}"),
                format!("expected {expected}, got {value}"),
            ),
            other => bad(&format!("{section}.control"), other.to_string()),
        })
    }
}

// ---- [test_plan] (method `test-plan`) ----

/// Most target amplitudes of `[test_plan]`.
pub const MAX_TEST_PLAN_TARGETS: usize = 200;

/// `[test_plan]`: the voltage, current and stroke the shaker needs to hold
/// the structure at phase resonance at each target amplitude, and the force
/// drop of an open-loop sweep at that voltage (docs/scenario.md).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct TestPlanSpec {
    /// Target fundamental amplitudes `|q_tip,1|` of the response point \[m\]
    /// (default `[0.5e-3, 1e-3, 2e-3, 3e-3]`).
    pub target_amplitudes_m: Vec<f64>,
    /// Voltage amplitude the amplifier gives \[V\] (default 40).
    pub voltage_limit_v: f64,
    /// Coil current amplitude allowed \[A\] (default 10).
    pub current_limit_a: f64,
    /// Armature displacement amplitude allowed \[m\] (default 6.35e-3, half
    /// of a 12.7 mm peak-to-peak stroke).
    pub stroke_limit_m: f64,
    /// Whether to run the open-loop sweep (the scenario's `[excitation]` at the
    /// planned voltage) per target for its force drop (default true).
    pub open_loop_sweep: bool,
}

impl Default for TestPlanSpec {
    fn default() -> Self {
        Self {
            target_amplitudes_m: vec![0.5e-3, 1e-3, 2e-3, 3e-3],
            voltage_limit_v: 40.0,
            current_limit_a: 10.0,
            stroke_limit_m: 6.35e-3,
            open_loop_sweep: true,
        }
    }
}

impl TestPlanSpec {
    fn validate(&self) -> Result<(), ScenarioError> {
        let n = self.target_amplitudes_m.len();
        if n == 0 || n > MAX_TEST_PLAN_TARGETS {
            return Err(bad(
                "test_plan.target_amplitudes_m",
                format!("expected 1 ..= {MAX_TEST_PLAN_TARGETS} amplitudes, got {n}"),
            ));
        }
        for (i, v) in self.target_amplitudes_m.iter().enumerate() {
            positive(&format!("test_plan.target_amplitudes_m[{i}]"), *v)?;
        }
        positive("test_plan.voltage_limit_v", self.voltage_limit_v)?;
        positive("test_plan.current_limit_a", self.current_limit_a)?;
        positive("test_plan.stroke_limit_m", self.stroke_limit_m)
    }
}

/// A matrix of an `lti` attachment: inline rows or a Matrix Market file
/// (relative to the scenario file).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(untagged)]
pub enum MatrixSpec {
    Rows(Vec<Vec<f64>>),
    File(PathBuf),
}

/// One `[[attachment]]` table. Every key of every type is read into this one
/// flat table, then [`Scenario::validate`] rejects a key the type does not
/// have (by name) and requires the ones it needs.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AttachmentSpec {
    #[serde(rename = "type")]
    pub kind: AttachmentType,
    /// Name in outputs and messages; default `attachment<i>`.
    pub name: Option<String>,
    /// Matrices: the `[[structure.point]]` it attaches to (all types but `lti`).
    pub point: Option<String>,
    /// `lti`: one structure point per row of `b2`.
    pub points: Option<Vec<String>>,
    /// Beam: fraction of the length (like `exciter.location`).
    pub location: Option<LengthFraction>,
    /// Beam: position [m].
    pub location_m: Option<f64>,
    /// `tuned-mass-damper`, `mass` [kg].
    pub mass_kg: Option<f64>,
    /// `tuned-mass-damper` spring; `piezo-shunt` short-circuit stack stiffness [N/m].
    pub stiffness_n_per_m: Option<f64>,
    /// `tuned-mass-damper` dashpot [N s/m].
    pub damping_n_s_per_m: Option<f64>,
    /// `tuned-mass-damper`: `c = 2 zeta sqrt(k m)` instead of `damping_n_s_per_m`.
    pub damping_ratio: Option<f64>,
    /// `piezo-shunt`: blocked capacitance `C_p` [F].
    pub capacitance_f: Option<f64>,
    /// `piezo-shunt`: shunt resistance `R` [Ohm].
    pub resistance_ohm: Option<f64>,
    /// `piezo-shunt`: electromechanical coupling `theta` [N/V] (= C/m).
    pub coupling_n_per_v: Option<f64>,
    /// `lti`: `A_0, A_1, ...` (`ndim x ndim` each).
    pub a_k: Option<Vec<MatrixSpec>>,
    /// `lti`: interface rows `B2` (`ncon x ndim`).
    pub b2: Option<MatrixSpec>,
    /// `lti`: input vector `b` (`ndim`), driven by the sweep's voltage `u(t)`;
    /// default: no input.
    pub input: Option<Vec<f64>>,
    /// `lti`: names of the states (default `x0, x1, ...`).
    pub state_names: Option<Vec<String>>,
}

impl AttachmentSpec {
    /// The name used in outputs (`attachment<i>` when not given).
    pub fn name_or(&self, i: usize) -> String {
        self.name
            .clone()
            .unwrap_or_else(|| format!("attachment{i}"))
    }

    fn resolve_paths(&mut self, base: &std::path::Path) {
        let fix = |m: &mut MatrixSpec| {
            if let MatrixSpec::File(p) = m {
                if p.is_relative() {
                    *p = base.join(&*p);
                }
            }
        };
        for m in self.a_k.iter_mut().flatten() {
            fix(m);
        }
        if let Some(m) = self.b2.as_mut() {
            fix(m);
        }
    }

    /// The keys of this table that are set, by name.
    fn set_keys(&self) -> Vec<&'static str> {
        let mut k = Vec::new();
        macro_rules! set {
            ($($f:ident),*) => {$(if self.$f.is_some() { k.push(stringify!($f)); })*};
        }
        set!(
            point,
            points,
            location,
            location_m,
            mass_kg,
            stiffness_n_per_m,
            damping_n_s_per_m,
            damping_ratio,
            capacitance_f,
            resistance_ohm,
            coupling_n_per_v,
            a_k,
            b2,
            input,
            state_names
        );
        k
    }
}

impl Scenario {
    /// `[[attachment]]`: the keys of each type, positive parameters, a location
    /// that fits the structure kind, unique names (also against the exciters).
    fn validate_attachments(&self) -> Result<(), ScenarioError> {
        let beam = self.structure.beam().is_some();
        for (i, a) in self.attachment.iter().enumerate() {
            let k = |f: &str| format!("attachment[{i}].{f}");
            let (location_keys, params): (&[&str], &[&str]) = match a.kind {
                AttachmentType::TunedMassDamper => (
                    &["point", "location", "location_m"],
                    &[
                        "mass_kg",
                        "stiffness_n_per_m",
                        "damping_n_s_per_m",
                        "damping_ratio",
                    ],
                ),
                AttachmentType::Mass => (&["point", "location", "location_m"], &["mass_kg"]),
                AttachmentType::PiezoShunt => (
                    &["point", "location", "location_m"],
                    &[
                        "capacitance_f",
                        "resistance_ohm",
                        "coupling_n_per_v",
                        "stiffness_n_per_m",
                    ],
                ),
                AttachmentType::Lti => (&["points"], &["a_k", "b2", "input", "state_names"]),
            };
            for key in a.set_keys() {
                if !location_keys.contains(&key) && !params.contains(&key) {
                    return Err(bad(
                        &k(key),
                        format!(
                            "not a key of type \"{}\" (its keys: {:?})",
                            a.kind.name(),
                            location_keys.iter().chain(params).collect::<Vec<_>>()
                        ),
                    ));
                }
            }
            let need = |key: &str, v: Option<f64>| -> Result<f64, ScenarioError> {
                let v = v.ok_or_else(|| {
                    bad(
                        &k(key),
                        format!("missing: type \"{}\" needs it", a.kind.name()),
                    )
                })?;
                positive(&k(key), v)?;
                Ok(v)
            };
            match a.kind {
                AttachmentType::TunedMassDamper => {
                    need("mass_kg", a.mass_kg)?;
                    need("stiffness_n_per_m", a.stiffness_n_per_m)?;
                    match (a.damping_n_s_per_m, a.damping_ratio) {
                        (Some(_), Some(_)) => {
                            return Err(bad(
                                &k("damping_ratio"),
                                "give either damping_n_s_per_m or damping_ratio, not both",
                            ))
                        }
                        (Some(d), None) | (None, Some(d)) if !(d.is_finite() && d >= 0.0) => {
                            let key = if a.damping_ratio.is_some() {
                                "damping_ratio"
                            } else {
                                "damping_n_s_per_m"
                            };
                            return Err(bad(
                                &k(key),
                                format!("expected a finite number >= 0, got {d}"),
                            ));
                        }
                        (None, None) => {
                            return Err(bad(
                                &k("damping_n_s_per_m"),
                                "missing: give damping_n_s_per_m or damping_ratio (0 for none)",
                            ))
                        }
                        _ => {}
                    }
                }
                AttachmentType::Mass => {
                    need("mass_kg", a.mass_kg)?;
                }
                AttachmentType::PiezoShunt => {
                    need("capacitance_f", a.capacitance_f)?;
                    need("resistance_ohm", a.resistance_ohm)?;
                    need("coupling_n_per_v", a.coupling_n_per_v)?;
                    if let Some(s) = a.stiffness_n_per_m {
                        if !(s.is_finite() && s >= 0.0) {
                            return Err(bad(
                                &k("stiffness_n_per_m"),
                                format!("expected a finite number >= 0, got {s}"),
                            ));
                        }
                    }
                }
                AttachmentType::Lti => {
                    let ak = a.a_k.as_ref().ok_or_else(|| {
                        bad(&k("a_k"), "missing: type \"lti\" needs A_0, A_1, ...")
                    })?;
                    if ak.is_empty() {
                        return Err(bad(&k("a_k"), "expected at least A_0"));
                    }
                    if a.b2.is_none() {
                        return Err(bad(&k("b2"), "missing: type \"lti\" needs B2"));
                    }
                    let pts = a.points.as_ref().ok_or_else(|| {
                        bad(&k("points"), "missing: one structure point per row of b2")
                    })?;
                    if pts.is_empty() {
                        return Err(bad(&k("points"), "expected at least one point"));
                    }
                    if let Some(b) = &a.input {
                        if let Some(v) = b.iter().find(|v| !v.is_finite()) {
                            return Err(bad(&k("input"), format!("non-finite entry {v}")));
                        }
                    }
                }
            }
            if a.kind != AttachmentType::Lti {
                match (beam, &a.point, a.location, a.location_m) {
                    (true, Some(_), _, _) => {
                        return Err(bad(
                            &k("point"),
                            "a beam has no named points: use location = \"2l/3\" or location_m",
                        ))
                    }
                    (true, None, None, None) => {
                        return Err(bad(
                            &k("location"),
                            "missing: expected location = \"2l/3\" (fraction of l) or location_m",
                        ))
                    }
                    (true, None, Some(_), Some(_)) => {
                        return Err(bad(
                            &k("location"),
                            "give either location or location_m, not both",
                        ))
                    }
                    (false, None, _, _) => {
                        return Err(bad(
                            &k("point"),
                            "missing: the [[structure.point]] it attaches to",
                        ))
                    }
                    (false, Some(_), l, lm) if l.is_some() || lm.is_some() => {
                        return Err(bad(
                            &k("location"),
                            "only a beam has locations; use point = \"name\"",
                        ))
                    }
                    _ => {}
                }
            }
            let name = a.name_or(i);
            let taken = self.exciter.iter().any(|e| e.name == name)
                || self.attachment[..i]
                    .iter()
                    .enumerate()
                    .any(|(j, o)| o.name_or(j) == name);
            if taken {
                return Err(bad(
                    &k("name"),
                    format!("attachment and exciter names must be unique, '{name}' repeats"),
                ));
            }
        }
        Ok(())
    }

    /// Location of attachment `i` along the beam [m] (beams only).
    pub fn attachment_location_m(&self, i: usize) -> Result<f64, ScenarioError> {
        let a = &self.attachment[i];
        let key = format!("attachment[{i}].location");
        let beam = self
            .structure
            .beam()
            .ok_or_else(|| bad(&key, "only a beam has locations; use point = \"name\""))?;
        let l = beam.length_m;
        let x = match (a.location, a.location_m) {
            (Some(LengthFraction(f)), None) => l * f,
            (None, Some(x)) => x,
            _ => return Err(bad(&key, "expected exactly one of location, location_m")),
        };
        if !(x.is_finite() && x > 0.0 && x <= l * (1.0 + 1e-12)) {
            return Err(bad(
                &key,
                format!("location {x} m lies outside the beam (0, {l}] m"),
            ));
        }
        Ok(x.min(l))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nonlinearity_tables_parse_validate_and_round_trip() {
        let text = "[[nonlinearity]]\ntype = \"polynomial-spring\"\npoints = [\"tip\", \"2l3\"]\n\
                    coefficients = { \"2\" = 1e5, \"3\" = 2e9 }\n\
                    [[nonlinearity]]\ntype = \"elastic-dry-friction\"\nname = \"joint\"\npoint = \"tip\"\n\
                    tangential_stiffness_n_per_m = 1e4\nslip_force_n = 0.5\n";
        let s = Scenario::parse(text).unwrap();
        assert_eq!(s.nonlinearity.len(), 2);
        assert_eq!(s.nonlinearity[0].kind, NonlinearityKind::PolynomialSpring);
        assert_eq!(s.nonlinearity[0].point_names(), ["tip", "2l3"]);
        assert_eq!(s.nonlinearity[1].element_name(1), "joint");
        assert!(s.nonlinearity[1].law(1).unwrap().hysteresis().is_some());
        let back = Scenario::parse(&toml::to_string(&s).unwrap()).unwrap();
        assert_eq!(back, s);
        // the default scenario serializes without the table
        assert!(!toml::to_string(&Scenario::default_scenario())
            .unwrap()
            .contains("nonlinearity"));
        let e = Scenario::parse(
            "[[nonlinearity]]\ntype = \"cubic-spring\"\npoint = \"tip\"\nk3_n_per_m3 = 1.0\n\
             [[nonlinearity]]\ntype = \"cubic-spring\"\nname = \"nonlinearity0\"\npoint = \"tip\"\nk3_n_per_m3 = 1.0\n",
        )
        .unwrap_err();
        assert_eq!(e.key, "nonlinearity[1].name");
    }

    #[test]
    fn default_scenario_is_the_papers_case_a() {
        let s = Scenario::default_scenario();
        assert_eq!(s.exciter.len(), 1);
        let x = s.exciter_location_m(0).unwrap();
        assert!((x - 2.0 * 0.53 / 3.0).abs() < 1e-15);
        assert_eq!(s.excitation.voltage_v, 10.0);
        assert_eq!(s.excitation.rate_per_pseudo_period, 0.02);
        assert!(s.excitation.eta_end >= 1.8);
    }

    #[test]
    fn fractions() {
        let f = parse_fraction;
        assert_eq!(f("l/3"), Some(1.0 / 3.0));
        assert_eq!(f("2l/3"), Some(2.0 / 3.0));
        assert_eq!(f("l"), Some(1.0));
        assert_eq!(f("2/3"), None);
        assert_eq!(f("x"), None);
    }

    #[test]
    fn unknown_keys_and_bad_values_name_the_key() {
        let e = Scenario::parse("[structure]\nlenght_m = 1.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("lenght_m"), "{e}");
        let e = Scenario::parse("[structure]\nlength_m = -1.0\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("structure.length_m") && e.contains("positive"),
            "{e}"
        );
        let e = Scenario::parse("[[exciter]]\nlocation = \"4l/3\"\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("exciter[0].location") && e.contains("outside"),
            "{e}"
        );
        let e = Scenario::parse("[excitation]\neta_start = 1.0\neta_end = 1.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("excitation.eta_end"), "{e}");
        let e = Scenario::parse("[excitation]\nrate_per_pseudo_period = 0.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("rate_per_pseudo_period"), "{e}");
        let e = Scenario::parse("[run]\nmethods = [\"magic\"]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("run.methods[0]") && e.contains("magic"), "{e}");
        let e = Scenario::parse("[slowflow]\nrtol = 0.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("slowflow.rtol"), "{e}");
        let e = Scenario::parse("[slowflow]\noutput_samples = 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("slowflow.output_samples"), "{e}");
    }

    #[test]
    fn embedded_sweep_toml_is_the_rust_default() {
        let parsed = Scenario::parse(DEFAULT_SCENARIO).unwrap();
        assert_eq!(parsed, Scenario::default());
        assert!(parsed.run.methods.contains(&Method::Cosim));
    }

    #[test]
    fn method_names_are_the_serde_names() {
        for m in Method::ALL {
            let v: Method = serde::Deserialize::deserialize(serde::de::value::StrDeserializer::<
                serde::de::value::Error,
            >::new(m.name()))
            .unwrap();
            assert_eq!(v, m);
            assert_eq!(m.to_string(), m.name());
        }
    }

    #[test]
    fn every_spelling_is_typed_and_names_the_key() {
        let e = Scenario::parse("[reference]\nintegrator = \"rk4\"\n").unwrap_err();
        assert_eq!(e.key, "reference.integrator");
        assert!(
            e.message.contains("rk4") && e.message.contains("dormand-prince"),
            "{e}"
        );
        let s = Scenario::parse("[reference]\nintegrator = \"\"\n").unwrap();
        assert_eq!(s.reference.integrator, None);
        let s = Scenario::parse("[reference]\nintegrator = \"dormand-prince\"\n").unwrap();
        assert_eq!(s.reference.integrator, Some(Integrator::DormandPrince));
        let two = "[[exciter]]\nlocation = \"l/3\"\n[[exciter]]\nname = \"b\"\nlocation = \"2l/3\"\nstinger = \"glued\"\n";
        let e = Scenario::parse(two).unwrap_err();
        assert_eq!(e.key, "exciter[1].stinger");
        assert!(
            e.message.contains("glued") && e.message.contains("rigid"),
            "{e}"
        );
        assert_eq!(e.line, Some(6), "{e}");
        let e = Scenario::parse("[cosim]\nalgorithm = \"newton\"\n").unwrap_err();
        assert_eq!(e.key, "cosim.algorithm");
        let e = Scenario::parse("[structure]\nboundary = \"free-free\"\n").unwrap_err();
        assert_eq!(e.key, "structure.boundary");
        let e = Scenario::parse("[structure]\nboundary = \"hinged\"\n").unwrap_err();
        assert_eq!(e.key, "structure.boundary");
        let e = Scenario::parse("[structure]\nkind = \"plate\"\n").unwrap_err();
        assert_eq!(e.key, "structure.kind");
        let e = Scenario::parse("[structure]\nkind = \"matrices\"\n").unwrap_err();
        assert!(e.message.contains("mass_mtx"), "{e}");
        let e = Scenario::parse("[structure]\nreduction = \"guyan\"\n").unwrap_err();
        assert_eq!(e.key, "structure.reduction");
        // more fixed-interface modes than the sparse eigensolver takes: the key named
        let e = Scenario::parse(
            "[structure]\nkind = \"matrices\"\nmass_mtx = \"M.mtx\"\nstiffness_mtx = \"K.mtx\"\n\
             damping_ratio = 0.01\ncb_modes = 501\n[[structure.point]]\nname = \"a\"\ndof = 0\n\
             [[exciter]]\npoint = \"a\"\n[output]\nresponse_point = \"a\"\n",
        )
        .unwrap_err();
        assert_eq!(e.key, "structure.cb_modes", "{e}");
        assert!(
            e.message.contains("501") && e.message.contains("500"),
            "{e}"
        );
        let e = Scenario::parse("[[exciter]]\nlocation = \"x\"\n").unwrap_err();
        assert_eq!(e.key, "exciter[0].location");
        let e = Scenario::parse("[excitation]\nvoltage_v = -1.0\n").unwrap_err();
        assert_eq!(e.key, "excitation.voltage_v");
        let s = Scenario::parse("[imposed_force]\nsource = \"f.csv\"\n").unwrap();
        assert_eq!(s.imposed_force.source, ForceSource::Csv("f.csv".into()));
        let s = Scenario::parse("[[exciter]]\nlocation = 1\n").unwrap();
        assert_eq!(s.exciter[0].location, Some(LengthFraction(1.0)));
    }

    #[test]
    fn slowflow_options_per_method() {
        let s = Scenario::parse("[slowflow]\nrtol = 3e-4\noutput_samples = 101\n").unwrap();
        let o = s.slowflow.options(Method::Nlmode);
        assert_eq!((o.rtol, o.output_samples), (3e-4, 101));
        assert_eq!(s.slowflow.options(Method::ImposedForce).rtol, 1e-5);
        let d = Scenario::default_scenario()
            .slowflow
            .options(Method::Nlmode);
        assert_eq!(d, nlmode::reduced::SlowFlowOptions::default());
    }

    #[test]
    fn every_example_scenario_parses() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            // study_*.toml are study files (`host study`), checked by the study module's test
            let study = p
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("study_"));
            if p.extension().and_then(|e| e.to_str()) == Some("toml") && !study {
                let text = std::fs::read_to_string(&p).unwrap();
                Scenario::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
                n += 1;
            }
        }
        assert!(n >= 9, "only {n} example scenarios");
    }

    #[test]
    fn attachment_tables_parse_and_name_their_keys() {
        let s = Scenario::parse(
            "[[attachment]]\ntype = \"tuned-mass-damper\"\nlocation = \"l\"\nmass_kg = 0.01\n\
             stiffness_n_per_m = 1e3\ndamping_ratio = 0.1\n\
             [[attachment]]\ntype = \"lti\"\npoints = [\"tip\"]\na_k = [[[1.0]], \"A1.mtx\"]\nb2 = [[1.0]]\n\
             [[exciter]]\nlocation = \"2l/3\"\nvoltage_v = 4.0\nphase_rad = 0.5\n",
        )
        .unwrap();
        assert_eq!(s.attachment.len(), 2);
        assert_eq!(s.attachment[0].kind, AttachmentType::TunedMassDamper);
        assert_eq!(s.attachment[0].name_or(0), "attachment0");
        assert_eq!(
            s.attachment[1].a_k.as_ref().unwrap()[1],
            MatrixSpec::File("A1.mtx".into())
        );
        assert_eq!(s.exciter[0].voltage_v, Some(4.0));
        assert_eq!(s.exciter[0].phase_rad, 0.5);
        for (text, key) in [
            ("[[attachment]]\ntype = \"mass\"\npoint = \"a\"\nmass_kg = 1.0\n", "attachment[0].point"),
            ("[[attachment]]\ntype = \"mass\"\nlocation = \"l\"\n", "attachment[0].mass_kg"),
            (
                "[[attachment]]\ntype = \"tuned-mass-damper\"\nlocation = \"l\"\nmass_kg = 1.0\nstiffness_n_per_m = -1.0\ndamping_ratio = 0.1\n",
                "attachment[0].stiffness_n_per_m",
            ),
            ("[[attachment]]\ntype = \"piezo\"\n", "attachment[0]"),
            ("[[exciter]]\nlocation = \"l\"\nphase_rad = nan\n", "exciter[0].phase_rad"),
            (
                "[[attachment]]\ntype = \"mass\"\nname = \"shaker\"\nlocation = \"l\"\nmass_kg = 1.0\n",
                "attachment[0].name",
            ),
        ] {
            let e = Scenario::parse(text).unwrap_err();
            assert!(e.key.starts_with(key), "{text}: {e}");
        }
    }
}
