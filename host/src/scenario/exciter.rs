//! `[[exciter]]`: the shakers, where they drive the structure.
use super::*;

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

pub(crate) fn default_exciters() -> Vec<ExciterSpec> {
    vec![ExciterSpec {
        location: Some(LengthFraction(2.0 / 3.0)),
        ..Default::default()
    }]
}

impl Scenario {
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

/// "l/3" -> 1/3, "2l/3" -> 2/3, "l" -> 1.
pub(crate) fn parse_fraction(s: &str) -> Option<f64> {
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

impl Scenario {
    /// Check every `[[exciter]]` (its location is checked with the structure).
    pub(crate) fn validate_exciters(&self) -> Result<(), ScenarioError> {
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
        Ok(())
    }
}
