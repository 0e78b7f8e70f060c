//! `[structure]`: the paper's beam or FE matrices, with its checks.
use super::*;

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
    memory_limit_gb: Option<f64>,
    matrix_format: Option<MatrixFormat>,
    ordering: Option<nlmode::structure::sparse::Ordering>,
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
                        ("memory_limit_gb", r.memory_limit_gb.is_some()),
                        ("matrix_format", r.matrix_format.is_some()),
                        ("ordering", r.ordering.is_some()),
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
                    memory_limit_gb: r.memory_limit_gb,
                    matrix_format: r.matrix_format.unwrap_or_default(),
                    ordering: r.ordering.unwrap_or_default(),
                    in_memory: None,
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

/// A named DOF of a matrices structure (`[[structure.point]]`): its row `dof`,
/// or, in a labelled file (Abaqus' `node, dof, node, dof, value`), its `node`
/// and `direction`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PointSpec {
    pub name: String,
    /// 0-based row of `M` and `K`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dof: Option<usize>,
    /// Node label of a labelled matrix file (with `direction`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<u64>,
    /// Abaqus DOF of `node`: 1..6 or `x`, `y`, `z`, `rx`, `ry`, `rz`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<Direction>,
}

/// The direction of a labelled point: Abaqus' DOF number (1, 2, 3 the
/// translations x, y, z; 4, 5, 6 the rotations about x, y, z), given as that
/// number or as `"x"`, `"y"`, `"z"`, `"rx"`, `"ry"`, `"rz"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Direction(pub u8);

impl Direction {
    const NAMES: [&'static str; 6] = ["x", "y", "z", "rx", "ry", "rz"];

    /// Its name (`x`, ..., `rz`).
    pub fn name(self) -> &'static str {
        Self::NAMES[(self.0 as usize).clamp(1, 6) - 1]
    }
}

impl<'de> Deserialize<'de> for Direction {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Number(i64),
            Name(String),
        }
        let found = match Raw::deserialize(d)? {
            Raw::Number(n) if (1..=6).contains(&n) => return Ok(Direction(n as u8)),
            Raw::Number(n) => n.to_string(),
            Raw::Name(s) => match Self::NAMES.iter().position(|n| n.eq_ignore_ascii_case(&s)) {
                Some(i) => return Ok(Direction(i as u8 + 1)),
                None => format!("\"{s}\""),
            },
        };
        Err(D::Error::custom(format!(
            "expected a direction 1..6 or \"x\", \"y\", \"z\", \"rx\", \"ry\", \"rz\", found {found}"
        )))
    }
}

impl Serialize for Direction {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// The format of the matrix files (`structure.matrix_format`); `auto` detects
/// it per file (`feio::detect`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MatrixFormat {
    #[default]
    Auto,
    MatrixMarket,
    HarwellBoeing,
    Abaqus,
}

impl MatrixFormat {
    /// The reader's format.
    pub fn feio(self) -> feio::Format {
        match self {
            MatrixFormat::Auto => feio::Format::Auto,
            MatrixFormat::MatrixMarket => feio::Format::MatrixMarket,
            MatrixFormat::HarwellBoeing => feio::Format::HarwellBoeing,
            MatrixFormat::Abaqus => feio::Format::Abaqus,
        }
    }

    fn is_auto(&self) -> bool {
        *self == MatrixFormat::Auto
    }
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
    /// Refuse a sparse Craig-Bampton reduction whose memory estimate exceeds
    /// this [GB] before factorising (default: 75 % of the memory available,
    /// [`default_memory_limit_bytes`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory_limit_gb: Option<f64>,
    /// The format of `mass_mtx`, `stiffness_mtx`, `damping_mtx` (default: detected).
    #[serde(skip_serializing_if = "MatrixFormat::is_auto")]
    pub matrix_format: MatrixFormat,
    /// The fill-reducing ordering of the sparse Cholesky factorisations
    /// (`auto`, `amd`, `nested-dissection`).
    #[serde(skip_serializing_if = "is_auto_ordering")]
    pub ordering: nlmode::structure::sparse::Ordering,
    /// The matrices given in memory instead of read from the files (the
    /// Python package's `matrices=`: `scipy.sparse` or numpy arrays); the
    /// file keys then hold their names in messages ([`InMemoryMatrices`]).
    #[serde(skip)]
    pub in_memory: Option<InMemoryMatrices>,
}

/// `M`, `K` and optionally `C` of a `kind = "matrices"` structure given in
/// memory (the entries as stored, every one given: no symmetric storage),
/// shared, not copied, by the clones of the scenario.
#[derive(Debug, Clone)]
pub struct InMemoryMatrices {
    pub mass: std::sync::Arc<feio::Triplets>,
    pub stiffness: std::sync::Arc<feio::Triplets>,
    pub damping: Option<std::sync::Arc<feio::Triplets>>,
}

impl PartialEq for InMemoryMatrices {
    /// The same matrices: the same shared storage.
    fn eq(&self, other: &Self) -> bool {
        use std::sync::Arc;
        Arc::ptr_eq(&self.mass, &other.mass)
            && Arc::ptr_eq(&self.stiffness, &other.stiffness)
            && match (&self.damping, &other.damping) {
                (Some(a), Some(b)) => Arc::ptr_eq(a, b),
                (None, None) => true,
                _ => false,
            }
    }
}

impl InMemoryMatrices {
    /// Matrix `k` in the order mass, stiffness, damping.
    pub fn get(&self, k: usize) -> Option<&feio::Triplets> {
        match k {
            0 => Some(&self.mass),
            1 => Some(&self.stiffness),
            2 => self.damping.as_deref(),
            _ => None,
        }
    }

    /// The name of matrix `key` (`mass_mtx`, `stiffness_mtx`, `damping_mtx`)
    /// in messages and in the modal table's provenance.
    pub fn placeholder(key: &str) -> String {
        format!("matrices['{}'] (in memory)", key.trim_end_matches("_mtx"))
    }
}

fn is_auto_ordering(o: &nlmode::structure::sparse::Ordering) -> bool {
    *o == nlmode::structure::sparse::Ordering::Auto
}

/// 75 % of `MemAvailable` (Linux `/proc/meminfo`), `None` where unknown: the
/// default `[structure] memory_limit_gb` of a matrices structure.
pub fn default_memory_limit_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kb: u64 = text
        .lines()
        .find_map(|l| l.strip_prefix("MemAvailable:"))?
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kb.saturating_mul(1024) / 4 * 3)
}

impl MatricesStructureSpec {
    /// The memory limit of the sparse path [bytes]: `memory_limit_gb` or the default.
    pub fn memory_limit_bytes(&self) -> Option<u64> {
        match self.memory_limit_gb {
            Some(gb) => Some((gb * 1e9) as u64),
            None => default_memory_limit_bytes(),
        }
    }
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

/// `[[structure.point]]`: a non-empty unique name, and either `dof` or `node`
/// and `direction`.
fn validate_points(st: &MatricesStructureSpec) -> Result<(), ScenarioError> {
    for (i, p) in st.point.iter().enumerate() {
        if p.name.is_empty() {
            return Err(bad(
                &format!("structure.point[{i}].name"),
                "expected a non-empty name",
            ));
        }
        let key = |k: &str| format!("structure.point[{i}].{k}");
        match (p.dof, p.node, p.direction) {
            (Some(_), None, None) | (None, Some(_), Some(_)) => {}
            (Some(_), _, _) => {
                return Err(bad(
                    &key("node"),
                    "give either dof or node and direction, not both",
                ))
            }
            (None, Some(_), None) => {
                return Err(bad(
                    &key("direction"),
                    "missing: node needs a direction (1..6 or \"x\", \"y\", \"z\", \"rx\", \"ry\", \"rz\")",
                ))
            }
            (None, None, Some(_)) => {
                return Err(bad(&key("node"), "missing: direction needs a node"))
            }
            (None, None, None) => {
                return Err(bad(
                    &key("dof"),
                    "missing: give dof (the 0-based row of M and K), or node and direction \
                     (matrices in Abaqus' labels format)",
                ))
            }
        }
        if st.point[..i].iter().any(|o| o.name == p.name) {
            return Err(bad(
                &format!("structure.point[{i}].name"),
                format!("point names must be unique, '{}' repeats", p.name),
            ));
        }
    }
    Ok(())
}

/// The damping of a matrices structure: exactly one of `damping_mtx`,
/// `rayleigh` or `damping_ratio` (+ `damping_mode`), in range.
fn validate_damping(st: &MatricesStructureSpec) -> Result<(), ScenarioError> {
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
    Ok(())
}

impl Scenario {
    /// `[structure]` of `kind = "matrices"` and the keys that refer to its points
    /// (the matrices themselves are checked when they are read).
    pub(crate) fn validate_matrices(
        &self,
        st: &MatricesStructureSpec,
    ) -> Result<(), ScenarioError> {
        validate_points(st)?;
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
        validate_damping(st)?;
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
        if let Some(gb) = st.memory_limit_gb {
            positive("structure.memory_limit_gb", gb)?;
        }
        {
            use nlmode::structure::ordering::{Ordering, NESTED_DISSECTION_AVAILABLE};
            if st.ordering == Ordering::NestedDissection && !NESTED_DISSECTION_AVAILABLE {
                return Err(bad(
                    "structure.ordering",
                    "nested-dissection needs METIS, which this build of host leaves out \
                     (build it with `cargo build --release -p host --features metis`): use \"auto\" or \"amd\"",
                ));
            }
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
                     (the exciter is attached at a [[structure.point]]: point = \"name\")",
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

    pub(crate) fn validate_beam(&self, st: &BeamStructureSpec) -> Result<(), ScenarioError> {
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
}
