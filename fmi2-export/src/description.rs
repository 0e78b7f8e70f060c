//! What a model's modelDescription says, in terms of no particular FMI
//! version: [`ModelInfo`] (a model's [`CoSimModel::INFO`]) next to its
//! variable table ([`CoSimModel::VARIABLES`], [`CoSimModel::CONTINUOUS_STATES`]),
//! and [`Layout`], the resolved view of both (indices, units, initial
//! unknowns, dependencies as variable positions) that a renderer writes out.
//! The FMI 2.0 renderer is [`crate::render`], the FMI 3.0 one
//! [`crate::render3`]; both take the same [`Layout`] (FMI 3.0 names
//! variables by value reference where FMI 2.0 uses indices, so positions are
//! kept here, not indices).
use crate::model::{Causality, CoSimModel, Start, VarType, Variable, LOG_CATEGORIES};

/// The model-level part of a modelDescription.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelInfo {
    /// `modelName`.
    pub name: &'static str,
    /// `description` of the model.
    pub description: &'static str,
    /// `version` of the model (none: attribute left out).
    pub version: Option<&'static str>,
    /// `generationTool`.
    pub generation_tool: &'static str,
    pub capabilities: Capabilities,
    /// Units the shared catalogue [`UNITS`] does not define (written after it).
    pub units: &'static [Unit],
    /// One description per entry of [`LOG_CATEGORIES`], in that order
    /// (e.g. [`LOG_CATEGORY_DESCRIPTIONS`]).
    pub log_categories: &'static [&'static str],
    pub default_experiment: DefaultExperiment,
    pub model_structure: ModelStructure,
}

/// What the model implements beyond what the export layer gives every
/// model (FMU state get/set/serialize, several instances per process, no
/// memory-management callbacks). [`crate::testing::check_capabilities`]
/// checks that the model backs what it declares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Capabilities {
    /// `do_step` takes any step size `h > 0`.
    pub can_handle_variable_communication_step_size: bool,
    /// `set_real_input_derivative` of order 1 for every continuous Real input.
    pub can_interpolate_inputs: bool,
    /// `get_real_output_derivative` up to this order for every continuous Real output.
    pub max_output_derivative_order: u32,
    /// `partial_derivative` of every continuous Real output (and, with Model
    /// Exchange, state derivative) with respect to every continuous Real
    /// input (and state).
    pub provides_directional_derivative: bool,
}

/// A unit definition: its name and its exponents of the SI base units (none:
/// no `<BaseUnit>`, e.g. for `1` or units with non-integer exponents).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unit {
    pub name: &'static str,
    pub base: Option<BaseUnit>,
}

/// Exponents of `kg`, `m`, `s`, `A`, `K`, `mol`, `cd`, `rad` (FMI 2.0 `<BaseUnit>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BaseUnit {
    pub kg: i32,
    pub m: i32,
    pub s: i32,
    pub a: i32,
    pub k: i32,
    pub mol: i32,
    pub cd: i32,
    pub rad: i32,
}

impl BaseUnit {
    /// The exponents with their attribute names, in the standard's order.
    pub fn exponents(&self) -> [(&'static str, i32); 8] {
        [
            ("kg", self.kg),
            ("m", self.m),
            ("s", self.s),
            ("A", self.a),
            ("K", self.k),
            ("mol", self.mol),
            ("cd", self.cd),
            ("rad", self.rad),
        ]
    }
}

const fn si(name: &'static str, kg: i32, m: i32, s: i32, a: i32, rad: i32) -> Unit {
    Unit {
        name,
        base: Some(BaseUnit {
            kg,
            m,
            s,
            a,
            k: 0,
            mol: 0,
            cd: 0,
            rad,
        }),
    }
}

/// The units this workspace's models use, in the order they are written
/// (a model's `<UnitDefinitions>` holds those of its variables' units).
pub const UNITS: &[Unit] = &[
    Unit {
        name: "1",
        base: None,
    },
    si("1/rad", 0, 0, 0, 0, -1),
    si("A", 0, 0, 0, 1, 0),
    si("A/s", 0, 0, -1, 1, 0),
    si("H", 1, 2, -2, -2, 0),
    si("Ohm", 1, 2, -3, -2, 0),
    si("V", 1, 2, -3, -1, 0),
    si("N/A", 1, 1, -2, -1, 0),
    si("N", 1, 1, -2, 0, 0),
    si("N/m", 1, 0, -2, 0, 0),
    si("N.s/m", 1, 0, -1, 0, 0),
    si("W", 1, 2, -3, 0, 0),
    si("kg", 1, 0, 0, 0, 0),
    si("m", 0, 1, 0, 0, 0),
    si("m/s", 0, 1, -1, 0, 0),
    si("m/s2", 0, 1, -2, 0, 0),
    si("s", 0, 0, 1, 0, 0),
    si("rad", 0, 0, 0, 0, 1),
    si("rad/s", 0, 0, -1, 0, 1),
    si("rad/s2", 0, 0, -2, 0, 1),
];

/// Descriptions of [`LOG_CATEGORIES`] for a model with nothing to add.
pub const LOG_CATEGORY_DESCRIPTIONS: &[&str] = &[
    "informative messages",
    "warnings",
    "discarded calls",
    "errors (always logged)",
    "fatal errors",
    "everything",
];

/// `<DefaultExperiment>` (each attribute left out when `None`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DefaultExperiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    pub step_size: Option<f64>,
}

/// The dependencies of the model's unknowns, by variable name. Which
/// unknowns are listed follows from the variable table (every output; the
/// state derivatives; the initial unknowns: outputs, calculated parameters,
/// states and derivatives with a calculated start); an unknown not named
/// here depends on nothing (`dependencies=""`). The
/// `fmi2_export::xml::check_dependencies` test holds them to the code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ModelStructure {
    /// `<Outputs>`: direct feedthrough from inputs.
    pub outputs: &'static [Dependencies],
    /// `<Derivatives>` (Model Exchange): inputs and states.
    pub derivatives: &'static [Dependencies],
    /// `<InitialUnknowns>`: inputs and parameters set before initialization.
    pub initial_unknowns: &'static [Dependencies],
}

/// One unknown's dependencies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dependencies {
    pub unknown: &'static str,
    pub knowns: &'static [&'static str],
    /// Linear with a constant factor in every known (`dependenciesKind="fixed"`);
    /// otherwise the kind is left out (FMI 2.0: "dependent").
    pub fixed: bool,
}

impl Dependencies {
    /// `unknown` depends on `knowns` in any way.
    pub const fn on(unknown: &'static str, knowns: &'static [&'static str]) -> Self {
        Self {
            unknown,
            knowns,
            fixed: false,
        }
    }
    /// `unknown` depends linearly, with constant factors, on `knowns`.
    pub const fn fixed(unknown: &'static str, knowns: &'static [&'static str]) -> Self {
        Self {
            unknown,
            knowns,
            fixed: true,
        }
    }
}

/// Why a model's description cannot be rendered (its tables disagree).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DescriptionError {
    #[error("variable {name}: no description")]
    NoDescription { name: &'static str },
    #[error("variable name {name} appears twice")]
    DuplicateName { name: &'static str },
    #[error("variable {name}: unit {unit:?} is neither in fmi2_export::description::UNITS nor in the model's ModelInfo::units")]
    UnknownUnit {
        name: &'static str,
        unit: &'static str,
    },
    #[error("continuous state {k}: no Real variable with value reference {vr}")]
    NoStateVariable { k: usize, vr: u32 },
    #[error("ModelStructure {list}: {name} is not {what}")]
    NotAnUnknown {
        list: &'static str,
        name: &'static str,
        what: &'static str,
    },
    #[error("ModelStructure {list}: {unknown} depends on {name}, which is not {what}")]
    NotAKnown {
        list: &'static str,
        unknown: &'static str,
        name: &'static str,
        what: &'static str,
    },
    #[error("variable {name}: FMI 3.0 value reference {vr} is used twice (or is the one of time)")]
    DuplicateValueReference3 { name: &'static str, vr: u32 },
    #[error("FMI 3.0 array {array}: {what} {name} is not a variable of the model")]
    UnknownVariable {
        array: &'static str,
        what: &'static str,
        name: String,
    },
    #[error("ModelInfo::log_categories has {found} descriptions, LOG_CATEGORIES {expected} names")]
    LogCategories { found: usize, expected: usize },
}

/// `initial` of a variable (FMI 2.0 / 3.0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Initial {
    Exact,
    Approx,
    Calculated,
}

impl Initial {
    pub fn name(self) -> &'static str {
        match self {
            Initial::Exact => "exact",
            Initial::Approx => "approx",
            Initial::Calculated => "calculated",
        }
    }
}

/// One listed unknown of [`Layout`]: positions in the variable table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Unknown {
    pub variable: usize,
    /// Ascending.
    pub dependencies: Vec<usize>,
    pub fixed: bool,
}

/// A model's description resolved against its variable table, ready to be
/// written by a renderer; variables are named by their position in
/// [`CoSimModel::VARIABLES`].
#[derive(Debug, Clone)]
pub struct Layout {
    pub model_identifier: &'static str,
    pub guid: &'static str,
    pub info: ModelInfo,
    pub variables: &'static [Variable],
    /// Per variable: the position of the state it is the derivative of.
    pub derivative_of: Vec<Option<usize>>,
    /// The unit definitions the variables use: [`UNITS`] order, then the model's own.
    pub units: Vec<Unit>,
    /// Whether the model is instantiable for Model Exchange (it has continuous states).
    pub model_exchange: bool,
    pub outputs: Vec<Unknown>,
    pub derivatives: Vec<Unknown>,
    pub initial_unknowns: Vec<Unknown>,
}

impl Layout {
    /// The `initial` attribute a variable gets: left out (`None`, the
    /// standard's default) except for a calculated output, local or
    /// calculated parameter (no start value).
    pub fn initial(v: &Variable) -> Option<Initial> {
        let computed = matches!(
            v.causality,
            Causality::Output | Causality::Local | Causality::CalculatedParameter
        );
        (computed && v.start.is_none()).then_some(Initial::Calculated)
    }

    /// Resolve `M`'s tables; the first inconsistency is the error.
    pub fn of<M: CoSimModel>() -> Result<Self, DescriptionError> {
        let vars = M::VARIABLES;
        let info = M::INFO;
        if info.log_categories.len() != LOG_CATEGORIES.len() {
            return Err(DescriptionError::LogCategories {
                found: info.log_categories.len(),
                expected: LOG_CATEGORIES.len(),
            });
        }
        for (i, v) in vars.iter().enumerate() {
            if v.description.is_empty() {
                return Err(DescriptionError::NoDescription { name: v.name });
            }
            if vars[..i].iter().any(|w| w.name == v.name) {
                return Err(DescriptionError::DuplicateName { name: v.name });
            }
        }
        let units = used_units(vars, info.units)?;
        let real_at = |vr: u32| {
            vars.iter()
                .position(|v| v.vr == vr && v.ty == VarType::Real)
        };
        let mut derivative_of = vec![None; vars.len()];
        let mut states = Vec::new();
        let mut derivs = Vec::new();
        for (k, s) in M::CONTINUOUS_STATES.iter().enumerate() {
            let state = real_at(s.state_vr)
                .ok_or(DescriptionError::NoStateVariable { k, vr: s.state_vr })?;
            let der = real_at(s.derivative_vr).ok_or(DescriptionError::NoStateVariable {
                k,
                vr: s.derivative_vr,
            })?;
            derivative_of[der] = Some(state);
            states.push(state);
            derivs.push(der);
        }
        let pos = |name: &str| vars.iter().position(|v| v.name == name);
        let is_input = |i: usize| vars[i].causality == Causality::Input;
        let is_parameter = |i: usize| vars[i].causality == Causality::Parameter;
        // outputs: every output in table order, knowns are inputs
        let output_positions: Vec<usize> = (0..vars.len())
            .filter(|&i| vars[i].causality == Causality::Output)
            .collect();
        let outputs = unknowns(
            "Outputs",
            info.model_structure.outputs,
            &output_positions,
            "an output",
            &pos,
            &|i| is_input(i),
            "an input",
        )?;
        // derivatives: in the order of the continuous states, knowns are inputs and states
        let derivatives = unknowns(
            "Derivatives",
            info.model_structure.derivatives,
            &derivs,
            "a state derivative",
            &pos,
            &|i| is_input(i) || states.contains(&i),
            "an input or a continuous state",
        )?;
        // initial unknowns: outputs, calculated parameters, states and
        // derivatives whose start is calculated, ascending
        let mut initial: Vec<usize> = (0..vars.len())
            .filter(|&i| {
                let v = &vars[i];
                let calculated = Self::initial(v).is_some();
                v.causality == Causality::Output && calculated
                    || v.causality == Causality::CalculatedParameter
                    || (states.contains(&i) || derivs.contains(&i)) && calculated
            })
            .collect();
        initial.sort_unstable();
        initial.dedup();
        let initial_unknowns = unknowns(
            "InitialUnknowns",
            info.model_structure.initial_unknowns,
            &initial,
            "an initial unknown (output, calculated parameter, state or derivative with a calculated start)",
            &pos,
            &|i| is_input(i) || is_parameter(i),
            "an input or a parameter",
        )?;
        Ok(Layout {
            model_identifier: M::MODEL_IDENTIFIER,
            guid: M::GUID,
            info,
            variables: vars,
            derivative_of,
            units,
            model_exchange: !M::CONTINUOUS_STATES.is_empty(),
            outputs,
            derivatives,
            initial_unknowns,
        })
    }
}

/// The unit definitions `vars` use: [`UNITS`] order, then `own` order.
fn used_units(vars: &[Variable], own: &[Unit]) -> Result<Vec<Unit>, DescriptionError> {
    for v in vars.iter().filter(|v| !v.unit.is_empty()) {
        if !UNITS.iter().chain(own).any(|u| u.name == v.unit) {
            return Err(DescriptionError::UnknownUnit {
                name: v.name,
                unit: v.unit,
            });
        }
    }
    let mut units: Vec<Unit> = Vec::new();
    for u in UNITS.iter().chain(own) {
        if vars.iter().any(|v| v.unit == u.name) && !units.iter().any(|w| w.name == u.name) {
            units.push(*u);
        }
    }
    Ok(units)
}

/// The listed unknowns at `positions` with their declared dependencies.
fn unknowns(
    list: &'static str,
    declared: &'static [Dependencies],
    positions: &[usize],
    what: &'static str,
    pos: &dyn Fn(&str) -> Option<usize>,
    known_ok: &dyn Fn(usize) -> bool,
    known_what: &'static str,
) -> Result<Vec<Unknown>, DescriptionError> {
    for d in declared {
        if !pos(d.unknown).is_some_and(|i| positions.contains(&i)) {
            return Err(DescriptionError::NotAnUnknown {
                list,
                name: d.unknown,
                what,
            });
        }
    }
    positions
        .iter()
        .map(|&i| {
            let d = declared.iter().find(|d| pos(d.unknown) == Some(i)).copied();
            let mut dependencies = Vec::new();
            for &k in d.map_or(&[][..], |d| d.knowns) {
                match pos(k) {
                    Some(j) if known_ok(j) => dependencies.push(j),
                    _ => {
                        return Err(DescriptionError::NotAKnown {
                            list,
                            unknown: d.map_or("", |d| d.unknown),
                            name: k,
                            what: known_what,
                        })
                    }
                }
            }
            dependencies.sort_unstable();
            Ok(Unknown {
                variable: i,
                dependencies,
                fixed: d.is_some_and(|d| d.fixed),
            })
        })
        .collect()
}

/// The text of a start value as the modelDescription writes it.
pub fn start_text(s: &Start) -> String {
    match s {
        Start::Real(x) => real_text(*x),
        Start::Integer(i) => i.to_string(),
        Start::Boolean(b) => b.to_string(),
        Start::String(t) => t.to_string(),
    }
}

/// A Real as an XML double: the shortest text that reads back to the same
/// value, in exponent form only for very small or large magnitudes, written
/// as C's `%g` and Python's `repr` write it (`1e-05`, `2.5e+20`).
pub fn real_text(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-4..1e16).contains(&a) {
        return format!("{x}");
    }
    let s = format!("{x:e}");
    match s.split_once('e') {
        Some((mantissa, exp)) => {
            let (sign, digits) = match exp.strip_prefix('-') {
                Some(d) => ('-', d),
                None => ('+', exp),
            };
            format!("{mantissa}e{sign}{digits:0>2}")
        }
        None => s,
    }
}

#[cfg(test)]
mod tests {
    use super::real_text;

    #[test]
    fn reals_are_written_like_c_and_python() {
        for (x, t) in [
            (0.0, "0"),
            (1.0, "1"),
            (0.9, "0.9"),
            (-3.5, "-3.5"),
            (0.00014, "0.00014"),
            (26e6, "26000000"),
            (1e-5, "1e-05"),
            (-2.5e-7, "-2.5e-07"),
            (2.5e20, "2.5e+20"),
            (1e-300, "1e-300"),
        ] {
            assert_eq!(real_text(x), t);
            assert_eq!(t.parse::<f64>().unwrap(), x);
        }
    }
}
