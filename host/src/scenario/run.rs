//! `[run]`: the methods of `host run` and the steady-state methods' frequency points.
use super::*;

/// A method of `host run` by its name (`[run] methods`, `linear-frf`): one
/// of the method registry's ([`crate::methods::REGISTRY`]). Each method's file
/// declares its own name (`impl Method { pub const Hb: Method = Method::new("hb"); }`)
/// and returns it from [`crate::methods::Method::id`]; a scenario naming
/// another method is rejected when it is read, naming the registry's methods.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Method(&'static str);

impl Method {
    /// The method named `name` (for the method's own file; a name that is not
    /// the registry's is never read from a scenario).
    pub const fn new(name: &'static str) -> Self {
        Self(name)
    }

    /// Every registered method, in the registry's order.
    pub fn all() -> impl Iterator<Item = Method> {
        crate::methods::REGISTRY.iter().map(|m| m.id())
    }

    /// The registered method named `name`.
    pub fn named(name: &str) -> Option<Method> {
        Self::all().find(|m| m.0 == name)
    }

    /// The name in scenarios and output files (`linear-frf`).
    pub fn name(self) -> &'static str {
        self.0
    }

    /// The registered names, in the registry's order (serde's list of
    /// expected spellings).
    fn names() -> &'static [&'static str] {
        static NAMES: std::sync::OnceLock<Vec<&'static str>> = std::sync::OnceLock::new();
        NAMES.get_or_init(|| Self::all().map(Method::name).collect())
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
/// registered names would be.
impl Serialize for Method {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let index = Self::names().iter().position(|n| *n == self.0).unwrap_or(0);
        s.serialize_unit_variant("Method", index as u32, self.0)
    }
}

/// Read as a unit variant of the registered names (the messages of a
/// `#[derive]`d enum: `unknown variant `x`, expected one of ...`).
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
                Method::named(v).ok_or_else(|| E::unknown_variant(v, Method::names()))
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
        d.deserialize_enum("Method", Self::names(), Unit)
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
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        if self.methods.is_empty() {
            let names = Method::names();
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
