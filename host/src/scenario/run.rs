//! `[run]`: the methods of `host run` and the steady-state methods' frequency points.
use super::*;
use std::cell::Cell;

/// A method of `host run` by its name (`[run] methods`, `linear-frf`): one
/// of the method registry's (`crate::methods::REGISTRY`). Each method's file
/// declares its own name (`impl Method { pub const Hb: Method = Method::new("hb"); }`)
/// and returns it from `crate::methods::Method::id`; a scenario naming
/// another method is rejected when it is read, naming the registry's methods
/// (the [`Catalog`] given to [`Scenario::parse_in`]).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Method(&'static str);

impl Method {
    /// The method named `name` (for the method's own file; a name that is not
    /// the registry's is never read from a scenario).
    pub const fn new(name: &'static str) -> Self {
        Self(name)
    }

    /// The name in scenarios and output files (`linear-frf`).
    pub fn name(self) -> &'static str {
        self.0
    }
}

/// The method registry as the scenario reader needs it: the names a scenario
/// may write in `[run] methods` and the methods' own options sections. The
/// scenario module does not know the registry (the methods depend on the
/// scenario, not the reverse): the host's catalog is `crate::methods::catalog`,
/// given to [`Scenario::parse_in`], [`Scenario::validate_in`] and
/// [`load_scenario_in`] by the registry's own entry points
/// (`Scenario::parse`, `Scenario::validate`, `crate::methods::load_scenario`).
pub struct Catalog {
    /// The registered names, in the registry's order (the order of the names
    /// in messages and serde's list of expected spellings).
    names: Vec<&'static str>,
    /// The methods' own options sections (`crate::methods::Method::options`).
    pub sections: Vec<OptionsSection>,
}

impl Catalog {
    /// The catalog of `methods` (in the registry's order) and `sections`.
    pub fn new(methods: impl IntoIterator<Item = Method>, sections: Vec<OptionsSection>) -> Self {
        Self {
            names: methods.into_iter().map(Method::name).collect(),
            sections,
        }
    }

    /// Every registered method, in the registry's order.
    pub fn methods(&self) -> impl Iterator<Item = Method> + '_ {
        self.names.iter().map(|&n| Method(n))
    }

    /// The registered method named `name`.
    pub fn named(&self, name: &str) -> Option<Method> {
        self.methods().find(|m| m.0 == name)
    }

    /// The registered names, in the registry's order.
    pub fn names(&self) -> &[&'static str] {
        &self.names
    }

    /// `f()` with this catalog's names as the ones [`Method`]'s deserializer
    /// accepts on this thread, for a scenario deserialized otherwise than by
    /// [`Scenario::parse_in`] (which does this itself), e.g. from a TOML tree.
    pub fn scope<T>(&'static self, f: impl FnOnce() -> T) -> T {
        reading_with(self, f)
    }
}

thread_local! {
    /// The catalog of the scenario being read on this thread ([`reading_with`]):
    /// the names [`Method`]'s deserializer accepts.
    static READING: Cell<Option<&'static Catalog>> = const { Cell::new(None) };
}

/// `f()` with `catalog` as the one [`Method`]'s deserializer reads (the
/// previous one restored afterwards, also on a panic).
pub(super) fn reading_with<T>(catalog: &'static Catalog, f: impl FnOnce() -> T) -> T {
    struct Restore(Option<&'static Catalog>);
    impl Drop for Restore {
        fn drop(&mut self) {
            READING.with(|c| c.set(self.0));
        }
    }
    let _restore = Restore(READING.with(|c| c.replace(Some(catalog))));
    f()
}

/// The names of the catalog being read (none outside [`reading_with`]).
fn reading_names() -> &'static [&'static str] {
    match READING.with(Cell::get) {
        Some(c) => &c.names,
        None => &[],
    }
}

impl std::fmt::Debug for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Method({:?})", self.0)
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Written as a unit variant (a string in TOML), as a `#[derive]`d enum of the
/// registered names would be (its index: the position in the catalog being
/// read, if any; TOML and JSON write the name only).
impl Serialize for Method {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let index = reading_names()
            .iter()
            .position(|n| *n == self.0)
            .unwrap_or(0);
        s.serialize_unit_variant("Method", index as u32, self.0)
    }
}

/// Read as a unit variant of the registered names (the messages of a
/// `#[derive]`d enum: `unknown variant `x`, expected one of ...`): those of
/// the [`Catalog`] of the [`Scenario::parse_in`] under way.
impl<'de> Deserialize<'de> for Method {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::{self, EnumAccess, VariantAccess};
        struct Name;
        impl<'de> de::Visitor<'de> for Name {
            type Value = Method;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("variant identifier")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Method, E> {
                let names = reading_names();
                match names.iter().find(|&&n| n == v) {
                    Some(&n) => Ok(Method(n)),
                    None => Err(E::unknown_variant(v, names)),
                }
            }
            fn visit_bytes<E: de::Error>(self, v: &[u8]) -> Result<Method, E> {
                match std::str::from_utf8(v) {
                    Ok(v) => self.visit_str(v),
                    Err(_) => Err(E::invalid_value(de::Unexpected::Bytes(v), &self)),
                }
            }
        }
        impl<'de> de::DeserializeSeed<'de> for Name {
            type Value = Method;
            fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Method, D::Error> {
                d.deserialize_identifier(self)
            }
        }
        struct Unit;
        impl<'de> de::Visitor<'de> for Unit {
            type Value = Method;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("enum Method")
            }
            fn visit_enum<A: EnumAccess<'de>>(self, a: A) -> Result<Method, A::Error> {
                let (m, v) = a.variant_seed(Name)?;
                v.unit_variant()?;
                Ok(m)
            }
        }
        d.deserialize_enum("Method", reading_names(), Unit)
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

impl RunSpec {
    /// Check the method list and the frequency points.
    pub(crate) fn validate(&self, catalog: &Catalog) -> Result<(), ScenarioError> {
        if self.methods.is_empty() {
            let names = catalog.names();
            return Err(bad(
                "run.methods",
                format!("expected a non-empty list from {names:?}"),
            ));
        }
        if self.frf_points < 2 {
            return Err(bad(
                "run.frf_points",
                format!("expected at least 2, got {}", self.frf_points),
            ));
        }
        Ok(())
    }
}
