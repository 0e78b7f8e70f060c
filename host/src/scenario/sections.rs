//! Options sections owned by a method (`crate::methods::Method::options`):
//! a top-level table of the scenario that only that method reads, declared
//! in the method's file, not in [`Scenario`]. When the scenario is read, such
//! tables are set aside (the other keys are deserialized as before, with their
//! messages and lines), checked by their method ([`OptionsSection::check`]:
//! key paths `section.key`, the line of the section) and kept as written in
//! [`Scenario::sections`]; the method reads its typed options with
//! [`Scenario::section`].
use super::{Scenario, ScenarioError};
use serde::de::{self, DeserializeOwned, DeserializeSeed, IntoDeserializer, MapAccess, Visitor};
use serde::Deserializer;
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::fmt;

/// A method's own options section: its table name and its check.
#[derive(Clone, Copy)]
pub struct OptionsSection {
    /// The table's name (`[my_method]`).
    pub name: &'static str,
    /// Deserializes and checks the table as written (errors name
    /// `name.key`; the caller adds the line).
    pub check: fn(&toml::Value) -> Result<(), ScenarioError>,
}

/// The options of a method's own section: serde (unknown keys rejected) with
/// defaults, and checks of the values naming the key (`section.key`).
pub trait SectionOptions: DeserializeOwned + Default {
    /// The table's name (`[my_method]`).
    const NAME: &'static str;

    /// Check the values (the error's key is `NAME.key`).
    fn validate(&self) -> Result<(), ScenarioError> {
        Ok(())
    }
}

impl OptionsSection {
    /// The section of the options type `T`.
    pub fn of<T: SectionOptions>() -> Self {
        Self {
            name: T::NAME,
            check: |v| parse_section::<T>(v).and_then(|t| t.validate()),
        }
    }
}

/// `T` from its table as written; errors name `T::NAME.key`.
fn parse_section<T: SectionOptions>(v: &toml::Value) -> Result<T, ScenarioError> {
    serde_path_to_error::deserialize(v.clone()).map_err(|e| {
        let path = e.path().to_string();
        ScenarioError {
            key: if path == "." {
                T::NAME.to_string()
            } else {
                format!("{}.{path}", T::NAME)
            },
            message: e.into_inner().message().trim().to_string(),
            line: None,
        }
    })
}

impl Scenario {
    /// The options of a method's own section (its defaults where the
    /// scenario has no such table).
    pub fn section<T: SectionOptions>(&self) -> Result<T, ScenarioError> {
        match self.sections.get(T::NAME) {
            Some(v) => parse_section(v),
            None => Ok(T::default()),
        }
    }
}

/// The tables set aside while reading: name -> (value, byte offset).
pub(super) type SetAside = RefCell<BTreeMap<String, (toml::Value, usize)>>;

/// The scenario's deserializer with the tables named in `names` set aside
/// into `out` (every other key goes to the scenario's own deserialization).
pub(super) struct WithSections<'s, D> {
    pub inner: D,
    pub names: &'s [&'static str],
    pub out: &'s SetAside,
}

impl<'de, D: Deserializer<'de>> Deserializer<'de> for WithSections<'_, D> {
    type Error = D::Error;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, D::Error> {
        self.inner.deserialize_any(Top {
            visitor,
            names: self.names,
            out: self.out,
        })
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, D::Error> {
        self.inner.deserialize_struct(
            name,
            fields,
            Top {
                visitor,
                names: self.names,
                out: self.out,
            },
        )
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map enum identifier ignored_any
    }
}

/// The top-level visitor: the scenario's, with the map filtered.
struct Top<'s, V> {
    visitor: V,
    names: &'s [&'static str],
    out: &'s SetAside,
}

impl<'de, V: Visitor<'de>> Visitor<'de> for Top<'_, V> {
    type Value = V::Value;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        self.visitor.expecting(f)
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<V::Value, A::Error> {
        self.visitor.visit_map(Filtered {
            map,
            names: self.names,
            out: self.out,
        })
    }
}

/// The top-level table without the set-aside sections.
struct Filtered<'s, A> {
    map: A,
    names: &'s [&'static str],
    out: &'s SetAside,
}

/// A key: the scenario's own (deserialized by its seed) or a set-aside section.
enum Key<T> {
    Own(T),
    Section(String),
}

impl<'de, A: MapAccess<'de>> MapAccess<'de> for Filtered<'_, A> {
    type Error = A::Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, A::Error> {
        let mut seed = Some(seed);
        loop {
            let key = self.map.next_key_seed(KeySeed {
                seed: &mut seed,
                names: self.names,
            })?;
            match key {
                None => return Ok(None),
                Some(Key::Own(k)) => return Ok(Some(k)),
                Some(Key::Section(name)) => {
                    let v: toml::Spanned<toml::Value> = self.map.next_value()?;
                    let start = v.span().start;
                    self.out.borrow_mut().insert(name, (v.into_inner(), start));
                }
            }
        }
    }

    fn next_value_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<S::Value, A::Error> {
        self.map.next_value_seed(seed)
    }
}

/// Reads a key: a set-aside section's name, or the scenario's key through its
/// own seed (inside the table's key deserializer, so that its errors keep the
/// key's position).
struct KeySeed<'a, 's, K> {
    seed: &'a mut Option<K>,
    names: &'s [&'static str],
}

impl<'de, K: DeserializeSeed<'de>> DeserializeSeed<'de> for KeySeed<'_, '_, K> {
    type Value = Key<K::Value>;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_identifier(self)
    }
}

impl<'de, K: DeserializeSeed<'de>> Visitor<'de> for KeySeed<'_, '_, K> {
    type Value = Key<K::Value>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a key")
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
        if self.names.contains(&v) {
            return Ok(Key::Section(v.to_string()));
        }
        let seed = self
            .seed
            .take()
            .ok_or_else(|| E::custom("a key read twice"))?;
        seed.deserialize(v.into_deserializer()).map(Key::Own)
    }
}
