//! The methods of `host run` as a registry: one file per method, each a
//! [`Method`] (its name, the scenario section it reads, the methods it takes
//! its input from, `run`), listed once in [`REGISTRY`]. [`crate::api::compute`]
//! runs the scenario's `[run] methods` in [`run_order`] through one
//! [`RunContext`], which holds what they share (the setup, the modal table,
//! the FMUs) and caches every method's [`MethodOutput`], so that a method
//! depending on another (`imposed-force` on its force source) reads it there
//! or has it computed once, unlisted. `host study` and the Python package
//! take the methods from the same registry ([`by_name`]).
//!
//! Adding a method: a file here implementing [`Method`] (with its name, a
//! [`MethodId`] constant in that file) and one line in [`REGISTRY`]
//! (CONTRIBUTING.md).
//! The physics is in `nlmode`; this is orchestration.
mod catalog;
mod common;
mod cosim;
mod force_controlled;
pub mod hb;
mod imposed_force;
mod linear_frf;
mod linear_slowflow;
mod linear_steady;
mod nlmode;
mod nma;
pub mod phase_resonance;
mod progress;
mod reference;
mod response_controlled;
pub mod stepped;
pub mod test_plan;

pub use self::catalog::{catalog, load_scenario, load_scenario_with_matrices};
pub use self::cosim::cosim;
pub use self::hb::{hb_response, hb_result, hb_table, single_mode_seeds};
pub use self::nma::{fold_warning, nma_table, Nma};
pub use common::{
    add_slowflow_exciter_forces, attachment_output, exciter_slow_flow, frf_omegas,
    modal_harvested_power, reduced_model, slow_flow, with_attachments,
};
pub use linear_frf::{closed_form, linear_frf};
pub use linear_steady::linear_steady;
pub use progress::Progress;
pub use reference::reference;

/// The name of a method as scenarios write it (`[run] methods`).
pub use crate::scenario::Method as MethodId;

use crate::model::Setup;
use crate::results::MethodResult;
use crate::scenario::{OptionsSection, Scenario};
use anyhow::Result;
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// A method of `host run`.
pub trait Method: Sync {
    /// Its name ([`MethodId::name`] is the spelling in scenarios and files).
    fn id(&self) -> MethodId;

    /// The scenario section holding its options (`imposed_force`), if any.
    fn section(&self) -> Option<&'static str> {
        None
    }

    /// The methods whose outputs it reads ([`RunContext::output`]): listed ones
    /// run before it, the others are computed for it, unpublished.
    fn depends_on(&self, _sc: &Scenario) -> Vec<MethodId> {
        Vec::new()
    }

    /// Its own options section, if it has one that no other part of the
    /// scenario reads: a table declared in the method's file
    /// ([`OptionsSection::of`] a [`crate::scenario::SectionOptions`] type),
    /// read with [`Scenario::section`]. (The sections of the methods that
    /// predate this, `[hb]`, `[cosim]`, ..., are fields of [`Scenario`].)
    fn options(&self) -> Option<OptionsSection> {
        None
    }

    /// Whether it needs the nonlinear mode ([`RunContext::table`]).
    fn needs_mode(&self, _sc: &Scenario) -> bool {
        false
    }

    /// Whether `host study` can run it per sample.
    fn in_studies(&self) -> bool {
        false
    }

    /// Checks of the scenario and the setup made before anything is
    /// computed (errors name the scenario's key).
    fn check(&self, _sc: &Scenario, _setup: &Setup) -> Result<()> {
        Ok(())
    }

    /// Compute. `ctx.published(self.id())` says whether the scenario lists it
    /// (else another method asked for its output).
    fn run(&self, ctx: &RunContext) -> Result<MethodOutput>;
}

/// The names of `nlmode` and `imposed-force` (kept here while their files are
/// reworked by the slow-flow variants; the other methods declare theirs in
/// their own file).
impl MethodId {
    #[allow(non_upper_case_globals)]
    pub const Nlmode: Self = Self::new("nlmode");
    #[allow(non_upper_case_globals)]
    pub const ImposedForce: Self = Self::new("imposed-force");
}

/// Every method, once: the methods a scenario can name (`[run] methods`).
/// The order is that of the checks before a run and of the names in messages.
pub static REGISTRY: &[&dyn Method] = &[
    &reference::Reference,
    &linear_frf::LinearFrf,
    &self::nlmode::Nlmode,
    &linear_slowflow::LinearSlowflow,
    &linear_steady::LinearSteady,
    &self::cosim::Cosim,
    &imposed_force::ImposedForce,
    &phase_resonance::PhaseResonance,
    &force_controlled::ForceControlled,
    &response_controlled::ResponseControlled,
    &test_plan::TestPlan,
    &hb::Hb,
];

/// The registry's entry of `id`.
pub fn get(id: MethodId) -> &'static dyn Method {
    *REGISTRY
        .iter()
        .find(|m| m.id() == id)
        .expect("every method is registered")
}

/// The registry's entry named `name` (`linear-frf`).
pub fn by_name(name: &str) -> Option<&'static dyn Method> {
    REGISTRY.iter().copied().find(|m| m.id().name() == name)
}

/// The order in which `host run` runs the scenario's methods: as listed,
/// each after the listed methods it depends on (a stable sort by the depth
/// of the dependency chain).
pub fn run_order(sc: &Scenario) -> Vec<MethodId> {
    fn depth(id: MethodId, sc: &Scenario, seen: usize) -> usize {
        if seen > REGISTRY.len() {
            return seen; // a cycle would be a programming error; bounded anyway
        }
        get(id)
            .depends_on(sc)
            .into_iter()
            .filter(|d| sc.run.methods.contains(d))
            .map(|d| 1 + depth(d, sc, seen + 1))
            .max()
            .unwrap_or(0)
    }
    let mut order = sc.run.methods.clone();
    order.sort_by_key(|&m| depth(m, sc, 0));
    order
}

/// What a method produced.
#[derive(Debug, Clone, Default)]
pub struct MethodOutput {
    /// Its results in output order (its own first; `linear-frf` adds
    /// `closed-form`, `nlmode` may add `nlmode-freq-error`); empty when it
    /// could not run for want of something outside the scenario (recorded in
    /// the run's failed methods).
    pub results: Vec<MethodResult>,
    /// The slow-flow methods: the sweep of their first result.
    pub flow: Option<::nlmode::reduced::SlowFlowResult>,
}

impl MethodOutput {
    /// One result.
    pub fn one(r: MethodResult) -> Self {
        Self {
            results: vec![r],
            flow: None,
        }
    }

    /// The method's own result.
    pub fn first(&self) -> Result<&MethodResult> {
        self.results
            .first()
            .ok_or_else(|| anyhow::anyhow!("the method produced no result"))
    }
}

/// What the methods of one run share; their outputs cached by method.
pub struct RunContext<'a> {
    pub sc: &'a Scenario,
    pub setup: &'a Setup,
    /// Where methods write the files they have besides their results
    /// (`phase_resonance.csv`, `cosim_modal_table.json`).
    pub out: &'a Path,
    /// Show progress bars on long methods.
    pub echo: bool,
    /// The nonlinear mode, when a method of the run needs it.
    pub nma: Option<Nma>,
    /// The structure and shaker FMUs (`cosim`), when available.
    pub fmus: Option<(PathBuf, PathBuf)>,
    /// The remedies of the validity checks that fired, once per kind (for
    /// `[slowflow] remedies = "run"`).
    pub remedies: Vec<crate::validity::Remedy>,
    cache: RefCell<HashMap<MethodId, Rc<MethodOutput>>>,
}

impl<'a> RunContext<'a> {
    pub fn new(sc: &'a Scenario, setup: &'a Setup, out: &'a Path, echo: bool) -> Self {
        Self {
            sc,
            setup,
            out,
            echo,
            nma: None,
            fmus: None,
            remedies: Vec::new(),
            cache: RefCell::default(),
        }
    }

    /// The modal table (computed before the methods when one needs it).
    pub fn table(&self) -> &::nlmode::nma::ModalTable {
        &self.nma.as_ref().expect("mode computed").table
    }

    /// Whether the scenario lists `id` (its results are published).
    pub fn published(&self, id: MethodId) -> bool {
        self.sc.run.methods.contains(&id)
    }

    /// The output of `id`: computed once (by the run, or now for a method
    /// depending on it), then cached.
    pub fn output(&self, id: MethodId) -> Result<Rc<MethodOutput>> {
        if let Some(o) = self.cache.borrow().get(&id) {
            return Ok(o.clone());
        }
        let o = Rc::new(get(id).run(self)?);
        self.cache.borrow_mut().insert(id, o.clone());
        Ok(o)
    }

    /// The published results of the methods `order` ran, in that order.
    pub fn into_results(self, order: &[MethodId]) -> Vec<MethodResult> {
        let mut cache = self.cache.into_inner();
        let mut done = Vec::new();
        for (k, id) in order.iter().enumerate() {
            // a method listed twice is published twice (as it ran before the registry)
            let again = order[k + 1..].contains(id);
            let o = if again {
                cache.get(id).cloned()
            } else {
                cache.remove(id)
            };
            if let Some(o) = o {
                let o = Rc::try_unwrap(o).unwrap_or_else(|rc| (*rc).clone());
                done.extend(o.results);
            }
        }
        done
    }

    /// A progress bar named `name` (drawn by `host run` only).
    pub fn progress(&self, name: &str) -> Progress {
        Progress::new(name, self.echo)
    }

    /// The natural-frequency error of `[imposed_force]`.
    pub fn frequency_error(&self) -> ::nlmode::reduced::FrequencyError {
        let f = &self.sc.imposed_force;
        ::nlmode::reduced::FrequencyError {
            eps: f.frequency_error,
            offset_rad_s: f.frequency_offset_rad_s
                + f.frequency_offset_omega0 * self.setup.omega0_rad_s,
        }
    }
}
