//! The registry's side of reading a scenario: the [`Catalog`] of
//! [`REGISTRY`] (its method names and options sections) and the entry points
//! that read and check a scenario with it. The scenario module itself takes
//! the catalog as an argument ([`Scenario::parse_in`]), so that it does not
//! depend on the methods, which depend on it.
use super::REGISTRY;
use crate::scenario::{
    load_scenario_in, Catalog, Method as MethodId, Scenario, ScenarioError, ScenarioSource,
    DEFAULT_SCENARIO,
};
use anyhow::Result;
use std::sync::OnceLock;

/// The registry's catalog: every method's name (in the registry's order)
/// and the options sections the methods own.
pub fn catalog() -> &'static Catalog {
    static CATALOG: OnceLock<Catalog> = OnceLock::new();
    CATALOG.get_or_init(|| {
        Catalog::new(
            REGISTRY.iter().map(|m| m.id()),
            REGISTRY.iter().filter_map(|m| m.options()).collect(),
        )
    })
}

impl MethodId {
    /// Every registered method, in the registry's order.
    pub fn all() -> impl Iterator<Item = MethodId> {
        catalog().methods()
    }

    /// The registered method named `name`.
    pub fn named(name: &str) -> Option<MethodId> {
        catalog().named(name)
    }
}

impl Scenario {
    /// Parse TOML text (unknown keys and unknown spellings are errors naming the
    /// key) and validate it ([`Scenario::parse_in`] with the registry's
    /// [`catalog`]).
    pub fn parse(text: &str) -> Result<Self, ScenarioError> {
        Self::parse_in(text, catalog())
    }

    /// The embedded default scenario.
    pub fn default_scenario() -> Self {
        Self::parse(DEFAULT_SCENARIO).expect("embedded default scenario is valid")
    }

    /// Check every value; the error names the key ([`Scenario::validate_in`]
    /// with the registry's [`catalog`]).
    pub fn validate(&self) -> Result<(), ScenarioError> {
        self.validate_in(catalog())
    }
}

/// Read a scenario as `host run` reads it ([`load_scenario_in`] with the
/// registry's [`catalog`]): optionally with `[run] methods` replaced by
/// `methods`; returns the scenario and its name in messages.
pub fn load_scenario(
    src: ScenarioSource,
    methods: Option<&[String]>,
) -> Result<(Scenario, String)> {
    load_scenario_in(src, methods, catalog())
}

/// [`load_scenario`] with the matrices of a `kind = "matrices"` structure
/// given in memory ([`crate::scenario::load_scenario_with`]).
pub fn load_scenario_with_matrices(
    src: ScenarioSource,
    methods: Option<&[String]>,
    matrices: crate::scenario::InMemoryMatrices,
) -> Result<(Scenario, String)> {
    crate::scenario::load_scenario_with(src, methods, Some(matrices), catalog())
}
