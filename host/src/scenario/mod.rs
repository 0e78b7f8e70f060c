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
use std::collections::BTreeMap;
use std::path::PathBuf;

mod load;
mod sections;
pub use self::sections::{OptionsSection, SectionOptions};
mod run;
pub use self::run::*;
mod structure;
pub use self::structure::*;
mod exciter;
pub use self::exciter::*;
mod excitation;
pub use self::excitation::*;
mod nma;
pub use self::nma::*;
mod hb;
pub use self::hb::*;
mod frf;
pub use self::frf::*;
mod imposed_force;
pub use self::imposed_force::*;
mod slowflow;
pub use self::slowflow::*;
mod reference;
pub use self::reference::*;
mod cosim;
pub use self::cosim::*;
mod output;
pub use self::output::*;
mod nonlinearity;
pub use self::nonlinearity::*;
mod phase_resonance;
pub use self::phase_resonance::*;
mod stepped;
pub use self::stepped::*;
mod test_plan;
pub use self::test_plan::*;
mod attachment;
pub use self::attachment::*;
pub use self::load::{
    load_scenario_in, load_scenario_with, set_path, ScenarioSource, MAX_SCENARIO_BYTES,
};

/// The default scenario (paper case (a)), embedded from `sweep.toml`;
/// it deserializes to exactly [`Scenario::default`].
pub const DEFAULT_SCENARIO: &str = include_str!("../../../sweep.toml");

/// Title of the default scenario.
const DEFAULT_TITLE: &str = "Paper case (a): exciter at 2l/3, 10 V, 2 % per pseudo period";

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
    pub hb: HbSpec,
    #[serde(default)]
    pub frf: FrfSpec,
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
    /// The options sections of methods that own theirs
    /// (`crate::methods::Method::options`), as written, by table name; a
    /// method reads its own with [`Scenario::section`].
    #[serde(skip)]
    pub sections: BTreeMap<String, toml::Value>,
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
            hb: HbSpec::default(),
            frf: FrfSpec::default(),
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
            sections: BTreeMap::new(),
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
/// Smallest `eta_start` / `eta_end` of a sweep or stepped sine: below a
/// thousandth of the natural frequency the excitation is quasi-static (one
/// period lasts 1000 natural periods) and the period-based methods' time
/// steps and amplitudes leave the floating-point range (`5e-324` ran no step,
/// `1e-308` overflowed the modal amplitude).
pub const MIN_ETA: f64 = 1e-3;
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

/// A frequency ratio `Omega / omega0` in `MIN_ETA ..= MAX_ETA`.
fn eta_in_range(key: &str, eta: f64) -> Result<(), ScenarioError> {
    if eta.is_finite() && (MIN_ETA..=MAX_ETA).contains(&eta) {
        Ok(())
    } else {
        Err(bad(
            key,
            format!("expected {MIN_ETA:e} <= Omega/omega0 <= {MAX_ETA}, got {eta:e}"),
        ))
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
    /// key) and validate it, with `catalog` the method registry's names and
    /// options sections (the host's: `Scenario::parse`, `crate::methods::catalog`).
    pub fn parse_in(text: &str, catalog: &'static Catalog) -> Result<Self, ScenarioError> {
        run::reading_with(catalog, || Self::parse_with(text, catalog))
    }

    /// [`Scenario::parse_in`] once the catalog is the one being read.
    fn parse_with(text: &str, catalog: &Catalog) -> Result<Self, ScenarioError> {
        let own = &catalog.sections;
        let names: Vec<&'static str> = own.iter().map(|o| o.name).collect();
        let aside = sections::SetAside::default();
        let de = sections::WithSections {
            inner: toml::Deserializer::new(text),
            names: &names,
            out: &aside,
        };
        let line_at = |at: usize| text[..at.min(text.len())].matches('\n').count() + 1;
        let s: Scenario = serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            let inner = e.into_inner();
            let line = inner.span().map(|sp| line_at(sp.start));
            ScenarioError {
                key: if path == "." { "scenario".into() } else { path },
                message: inner.message().trim().to_string(),
                line,
            }
        })?;
        let mut s = s;
        // the methods' own sections, checked by their method (the line: the section's)
        for (name, (v, at)) in aside.into_inner() {
            if let Some(o) = own.iter().find(|o| o.name == name) {
                (o.check)(&v).map_err(|e| ScenarioError {
                    line: e.line.or(Some(line_at(at))),
                    ..e
                })?;
            }
            s.sections.insert(name, v);
        }
        // a matrices structure has no default exciter (the paper's sits at 2l/3
        // of the beam): without [[exciter]] tables it has none (`host nma`)
        if matches!(s.structure, StructureSpec::Matrices(_))
            && !toml::from_str::<toml::Table>(text).is_ok_and(|t| t.contains_key("exciter"))
        {
            s.exciter.clear();
        }
        s.validate_in(catalog)?;
        Ok(s)
    }

    /// Check every value, with `catalog` the method registry's names and
    /// options sections (the host's: `Scenario::validate`); the error names
    /// the key.
    pub fn validate_in(&self, catalog: &Catalog) -> Result<(), ScenarioError> {
        match &self.structure {
            StructureSpec::Beam(st) => self.validate_beam(st)?,
            StructureSpec::Matrices(st) => self.validate_matrices(st)?,
        }
        self.validate_nonlinearities()?;
        self.validate_rest(catalog)
    }

    fn validate_rest(&self, catalog: &Catalog) -> Result<(), ScenarioError> {
        for o in &catalog.sections {
            if let Some(v) = self.sections.get(o.name) {
                (o.check)(v)?;
            }
        }
        self.phase_resonance.validate()?;
        self.force_control.validate("force_control")?;
        self.response_control.validate("response_control")?;
        self.test_plan.validate()?;
        self.validate_exciters()?;
        self.excitation.validate()?;
        self.nma.validate()?;
        self.hb.validate()?;
        self.run.validate(catalog)?;
        self.imposed_force.validate()?;
        self.slowflow.validate()?;
        self.reference.validate()?;
        self.cosim.validate()?;
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
}

#[cfg(test)]
mod tests;
