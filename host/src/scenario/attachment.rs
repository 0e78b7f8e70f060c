//! `[[attachment]]`: linear attachments besides the exciters.
use super::*;
use anyhow::{Context, Result};
use nlmode::attachment::LinearAttachment;

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

    pub(crate) fn resolve_paths(&mut self, base: &std::path::Path) {
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
    pub(crate) fn set_keys(&self) -> Vec<&'static str> {
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

impl AttachmentSpec {
    /// The parameters of its type (attachment `i`).
    pub(crate) fn validate_parameters(&self, i: usize) -> Result<(), ScenarioError> {
        let a = self;
        let k = |f: &str| format!("attachment[{i}].{f}");
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
                let ak = a
                    .a_k
                    .as_ref()
                    .ok_or_else(|| bad(&k("a_k"), "missing: type \"lti\" needs A_0, A_1, ..."))?;
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
        Ok(())
    }

    /// Where it attaches: a location on a beam, a named point otherwise (attachment `i`).
    pub(crate) fn validate_location(&self, i: usize, beam: bool) -> Result<(), ScenarioError> {
        let a = self;
        let k = |f: &str| format!("attachment[{i}].{f}");
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
        Ok(())
    }
}

impl Scenario {
    /// `[[attachment]]`: the keys of each type, positive parameters, a location
    /// that fits the structure kind, unique names (also against the exciters).
    pub(crate) fn validate_attachments(&self) -> Result<(), ScenarioError> {
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
            a.validate_parameters(i)?;
            a.validate_location(i, beam)?;
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

/// A matrix of an `lti` attachment: inline rows or a Matrix Market file.
fn lti_matrix(m: &MatrixSpec, key: &str) -> Result<nalgebra::DMatrix<f64>> {
    use nlmode::structure::{read_matrix_market, MatrixRole};
    match m {
        MatrixSpec::Rows(rows) => {
            let nr = rows.len();
            let nc = rows.first().map(|r| r.len()).unwrap_or(0);
            anyhow::ensure!(nr > 0 && nc > 0, "{key}: empty matrix");
            if let Some(i) = rows.iter().position(|r| r.len() != nc) {
                anyhow::bail!(
                    "{key}: row {i} has {} entries, row 0 has {nc}",
                    rows[i].len()
                );
            }
            Ok(nalgebra::DMatrix::from_fn(nr, nc, |i, j| rows[i][j]))
        }
        // read as a general (possibly non-symmetric) matrix; the role only labels messages
        MatrixSpec::File(p) => {
            read_matrix_market(MatrixRole::Stiffness, p).map_err(|e| anyhow::anyhow!("{key}: {e}"))
        }
    }
}

impl AttachmentSpec {
    /// The `nlmode` attachment of `[[attachment]]` `i` at structure point `point`
    /// (beam: the point name of its location). Errors name the key.
    pub fn build(&self, i: usize, point: &str) -> Result<LinearAttachment> {
        let spec = self;
        let name = spec.name_or(i);
        let key = |f: &str| format!("attachment[{i}].{f}");
        let get = |v: Option<f64>| v.unwrap_or(f64::NAN);
        let att = match spec.kind {
            AttachmentType::TunedMassDamper => {
                let (m, k) = (get(spec.mass_kg), get(spec.stiffness_n_per_m));
                let c = match (spec.damping_n_s_per_m, spec.damping_ratio) {
                    (Some(c), _) => c,
                    (None, Some(z)) => 2.0 * z * (k * m).sqrt(),
                    (None, None) => 0.0,
                };
                LinearAttachment::tuned_mass_damper(&name, point, m, k, c)
            }
            AttachmentType::Mass => LinearAttachment::rigid_mass(&name, point, get(spec.mass_kg)),
            AttachmentType::PiezoShunt => LinearAttachment::piezo_shunt(
                &name,
                point,
                get(spec.capacitance_f),
                get(spec.resistance_ohm),
                get(spec.coupling_n_per_v),
                spec.stiffness_n_per_m.unwrap_or(0.0),
            ),
            AttachmentType::Lti => {
                let coefficients = spec
                    .a_k
                    .iter()
                    .flatten()
                    .enumerate()
                    .map(|(k, m)| lti_matrix(m, &key(&format!("a_k[{k}]"))))
                    .collect::<Result<Vec<_>>>()?;
                let b2 = lti_matrix(spec.b2.as_ref().context("b2")?, &key("b2"))?;
                let n = coefficients[0].nrows();
                let input_map = match &spec.input {
                    Some(b) => {
                        anyhow::ensure!(
                            b.len() == n,
                            "{}: {} entries, the attachment has {n} states (rows of a_k[0])",
                            key("input"),
                            b.len()
                        );
                        nalgebra::DMatrix::from_column_slice(n, 1, b)
                    }
                    None => nalgebra::DMatrix::zeros(n, 0),
                };
                let state_names = match &spec.state_names {
                    Some(s) => s.clone(),
                    None => (0..n).map(|j| format!("x{j}")).collect(),
                };
                let att = LinearAttachment {
                    name: name.clone(),
                    coefficients,
                    b2,
                    interface_points: spec.points.clone().unwrap_or_default(),
                    input_names: (0..input_map.ncols()).map(|_| "u".to_string()).collect(),
                    input_map,
                    state_names,
                };
                // dimensions and rank of B2, named by the keys
                att.localization().map(|_| att)
            }
        };
        att.map_err(|e| {
            use nlmode::attachment::AttachmentError as E;
            let k = match &e {
                E::NonPositive { name, .. } | E::Negative { name, .. } => key(name),
                E::DimensionMismatch { what, .. } if what.starts_with("A_") => key("a_k"),
                E::DimensionMismatch { what, .. } if what == "interface_points" => key("points"),
                E::DimensionMismatch { what, .. } if what == "state_names" => key("state_names"),
                E::DimensionMismatch { .. }
                | E::TooManyConstraints { .. }
                | E::RankDeficientB2 { .. } => key("b2"),
                E::NotFinite { .. } => key("a_k"),
                _ => format!("attachment[{i}]"),
            };
            anyhow::anyhow!("{k}: {e}")
        })
    }
}

/// An output an attachment declares beside the envelope (its columns and
/// summary entry named after the attachment): `|x_state|^2 / divisor` of the
/// fundamental of one of its states, e.g. a piezo shunt's mean harvested
/// power `|v_hat|^2 / (2 R)` (the electrode voltage is state 1,
/// [`LinearAttachment::piezo_shunt`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttachmentOutput {
    pub kind: OutputKind,
    /// The state whose fundamental amplitude it reads.
    pub state: usize,
    pub divisor: f64,
}

/// What an [`AttachmentOutput`] is (its column `<name>_harvested_power_W`
/// and summary key `max_harvested_power_W`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// Mean harvested power \[W\].
    HarvestedPower,
}

impl AttachmentOutput {
    /// Its value at the complex fundamental amplitude `x` of its state.
    pub fn of_state(&self, x: nlmode::Complex64) -> f64 {
        x.norm_sqr() / self.divisor
    }

    /// Its value at the (real) fundamental amplitude `v` of its state.
    pub fn of_amplitude(&self, v: f64) -> f64 {
        v * v / self.divisor
    }
}

impl AttachmentSpec {
    /// The outputs this kind of attachment declares.
    pub fn outputs(&self) -> Vec<AttachmentOutput> {
        match self.kind {
            AttachmentType::PiezoShunt => vec![AttachmentOutput {
                kind: OutputKind::HarvestedPower,
                state: 1,
                divisor: 2.0 * self.resistance_ohm.unwrap_or(f64::NAN),
            }],
            _ => Vec::new(),
        }
    }
}
