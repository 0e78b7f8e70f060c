//! `[[nonlinearity]]`: the nonlinear element library.
use super::*;

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
    pub(crate) fn keys(self) -> &'static [&'static str] {
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
    /// `elastic-dry-friction` only: where the slider starts the AFT's
    /// periodic march, `"mean"` (default) or `"zero"`
    /// ([`nlmode::structure::InitialSlider`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_slider: Option<nlmode::structure::InitialSlider>,
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

    pub(crate) fn given(&self, key: &str) -> bool {
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
        if self.initial_slider.is_some() && self.kind != NonlinearityKind::ElasticDryFriction {
            return Err(bad(
                &key("initial_slider"),
                format!(
                    "not a parameter of type = \"{}\" (only elastic-dry-friction has a slider)",
                    self.kind.name()
                ),
            ));
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
            NonlinearityKind::ElasticDryFriction => Arc::new(ElasticDryFriction {
                initial_slider: self.initial_slider.unwrap_or_default(),
                ..ElasticDryFriction::new(
                    num(self.tangential_stiffness_n_per_m),
                    num(self.slip_force_n),
                )
                .map_err(err)?
            }),
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
    pub(crate) fn validate_nonlinearities(&self) -> Result<(), ScenarioError> {
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
