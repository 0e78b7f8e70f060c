//! The FMI 3.0 `modelDescription.xml` reader, into the types of
//! [`crate::schema`] so that one master and one importer serve both versions.
//!
//! What maps how (FMI 3.0 -> the version-neutral [`ModelDescription`]):
//! * `instantiationToken` -> [`ModelDescription::guid`] (the same role: the
//!   string `fmi3Instantiate*` must be given);
//! * scalar `<Float64>`, `<Int32>`, `<Boolean>`, `<String>`, `<Enumeration>`
//!   -> [`ScalarVariable`] of type `Real`, `Integer`, `Boolean`, `String`,
//!   `Enumeration`, numbered 1, 2, ... in the file's order (FMI 3.0 has no
//!   index; [`ScalarVariable::index`] is this position); `structuralParameter`
//!   reads as a parameter; a `String`'s `<Start value>` child as its start;
//! * every other variable (`Float32`, the other integer widths, `Binary`,
//!   `Clock`, and any variable with `<Dimension>`, i.e. an array) ->
//!   [`OtherVariable`], named so that a connection to it is refused with what
//!   it is;
//! * `<ModelStructure>` refers to value references (`<Output>`,
//!   `<ContinuousStateDerivative>`, `<InitialUnknown>`): they are resolved to
//!   the positions above (entries about other variables are left out; a
//!   value reference no variable has is an error with its line); the
//!   `derivative` attribute (the state's value reference) likewise;
//!   `<EventIndicator>`s are counted;
//! * `<CoSimulation>` / `<ModelExchange>`: the FMI 3.0 attribute names
//!   (`canGetAndSetFMUState`, `providesDirectionalDerivatives`,
//!   `needsCompletedIntegratorStep`, ...); FMI 3.0 has no input derivatives,
//!   so `can_interpolate_inputs` is false.
//!
//! Value references are unique across all variables in FMI 3.0: a repeated
//! one is an error with both lines.
use std::collections::{HashMap, HashSet};

use crate::schema::{
    default_experiment, get, parse_bool, parse_num, walk, Causality, CoSimCapabilities,
    ModelDescription, ModelExchangeCapabilities, OtherVariable, ScalarVariable, SchemaError,
    Unknown, VarType, Variability, Walk,
};

type Result<T, E = SchemaError> = std::result::Result<T, E>;

/// The scalar type a master exchanges, for a `<ModelVariables>` element.
fn exchanged_type(element: &str) -> Option<VarType> {
    Some(match element {
        "Float64" => VarType::Real,
        "Int32" => VarType::Integer,
        "Boolean" => VarType::Boolean,
        "String" => VarType::String,
        "Enumeration" => VarType::Enumeration,
        _ => return None,
    })
}

/// The other variable elements of FMI 3.0.
const OTHER_ELEMENTS: [&str; 10] = [
    "Float32", "Int8", "UInt8", "Int16", "UInt16", "UInt32", "Int64", "UInt64", "Binary", "Clock",
];

/// A variable element being read (its children may add dimensions or a start).
struct Pending {
    element: String,
    attrs: Vec<(String, String)>,
    line: usize,
    array: bool,
    /// `<Start value="...">` children (String, Binary).
    start_children: Vec<String>,
}

/// The variables read so far, by value reference and by name (hashed: a
/// description with 10^5 variables is read in linear time), and the
/// `derivative` attributes to resolve.
#[derive(Default)]
struct Seen {
    /// value reference -> (line, position among the scalars if exchanged)
    by_vr: HashMap<u32, (usize, Option<usize>)>,
    names: HashSet<String>,
    /// (position of the derivative, the state's value reference, line)
    derivative_of: Vec<(usize, u32, usize)>,
}

/// A `<ModelStructure>` entry before value references are resolved.
struct RawUnknown {
    section: &'static str,
    vr: u32,
    dependencies: Option<Vec<u32>>,
    line: usize,
}

/// Parse an FMI 3.0 `modelDescription.xml` (called by
/// [`ModelDescription::parse`] for `fmiVersion="3.*"`).
pub fn parse(text: &str) -> Result<ModelDescription> {
    let mut md = ModelDescription::default();
    let mut has_root = false;
    let mut has_cs = false;
    let mut pending: Option<Pending> = None;
    let mut unknowns: Vec<RawUnknown> = Vec::new();
    let mut seen = Seen::default();
    walk(text, |ev| {
        match ev {
            Walk::End { name, .. } => {
                if pending.as_ref().is_some_and(|p| p.element == name) {
                    let p = pending.take().expect("checked");
                    finish(&mut md, p, &mut seen)?;
                }
            }
            Walk::Start {
                parent,
                name,
                attrs: a,
                line,
                empty,
            } => match (parent, name) {
                ("", "fmiModelDescription") => {
                    has_root = true;
                    root(&mut md, &a, line)?;
                }
                ("fmiModelDescription", "CoSimulation") => {
                    has_cs = true;
                    md.co_simulation = co_simulation(&a, line)?;
                    md.cosim_flags = a;
                }
                ("fmiModelDescription", "ModelExchange") => {
                    md.model_exchange = Some(model_exchange(&a, line)?);
                }
                ("fmiModelDescription", "DefaultExperiment") => {
                    md.default_experiment = default_experiment(&a, line)?;
                }
                ("ModelVariables", t)
                    if exchanged_type(t).is_some() || OTHER_ELEMENTS.contains(&t) =>
                {
                    let p = Pending {
                        element: t.to_string(),
                        attrs: a,
                        line,
                        array: false,
                        start_children: Vec::new(),
                    };
                    if empty {
                        finish(&mut md, p, &mut seen)?;
                    } else {
                        pending = Some(p);
                    }
                }
                (_, "Dimension") => {
                    if let Some(p) = pending.as_mut() {
                        p.array = true;
                    }
                }
                (_, "Start") => {
                    if let Some(p) = pending.as_mut() {
                        p.start_children
                            .push(get(&a, "value").unwrap_or("").to_string());
                    }
                }
                (
                    "ModelStructure",
                    s @ ("Output"
                    | "ContinuousStateDerivative"
                    | "InitialUnknown"
                    | "EventIndicator"
                    | "ClockedState"),
                ) => {
                    let section: &'static str = match s {
                        "Output" => "Output",
                        "ContinuousStateDerivative" => "ContinuousStateDerivative",
                        "InitialUnknown" => "InitialUnknown",
                        "EventIndicator" => "EventIndicator",
                        _ => "ClockedState",
                    };
                    let vr = parse_num::<u32>(
                        get(&a, "valueReference").ok_or_else(|| SchemaError::Xml {
                            line,
                            message: format!("<{s}> has no valueReference"),
                        })?,
                        "valueReference",
                        line,
                        "an unsigned 32-bit integer",
                    )?;
                    let dependencies = get(&a, "dependencies")
                        .map(|d| {
                            d.split_whitespace()
                                .map(|x| {
                                    parse_num::<u32>(x, "dependencies", line, "value references")
                                })
                                .collect::<Result<Vec<_>>>()
                        })
                        .transpose()?;
                    unknowns.push(RawUnknown {
                        section,
                        vr,
                        dependencies,
                        line,
                    });
                }
                _ => {}
            },
        }
        Ok(())
    })?;
    if !has_root {
        return Err(SchemaError::Xml {
            line: 1,
            message: "no <fmiModelDescription> element".into(),
        });
    }
    resolve(&mut md, &seen, unknowns)?;
    if !has_cs {
        return Err(SchemaError::NoCoSimulation {
            model: md.model_name,
        });
    }
    Ok(md)
}

/// The attributes of `<fmiModelDescription>` (an `instantiationToken`).
fn root(md: &mut ModelDescription, a: &[(String, String)], line: usize) -> Result<()> {
    md.fmi_version = get(a, "fmiVersion").unwrap_or("").trim().to_string();
    md.model_name = get(a, "modelName").unwrap_or("").to_string();
    md.guid = get(a, "instantiationToken")
        .ok_or_else(|| SchemaError::Xml {
            line,
            message: "fmiModelDescription (FMI 3.0) has no instantiationToken attribute".into(),
        })?
        .to_string();
    md.description = get(a, "description").unwrap_or("").to_string();
    md.generation_tool = get(a, "generationTool").unwrap_or("").to_string();
    Ok(())
}

/// A variable element read to its end: a [`ScalarVariable`] or an [`OtherVariable`].
fn finish(md: &mut ModelDescription, p: Pending, seen: &mut Seen) -> Result<()> {
    let (a, line) = (&p.attrs, p.line);
    let name = get(a, "name").ok_or_else(|| SchemaError::Xml {
        line,
        message: format!("<{}> has no name", p.element),
    })?;
    let vr: u32 = parse_num(
        get(a, "valueReference").ok_or_else(|| SchemaError::Xml {
            line,
            message: format!("variable '{name}' has no valueReference"),
        })?,
        "valueReference",
        line,
        "an unsigned 32-bit integer",
    )?;
    let c = get(a, "causality").unwrap_or("local");
    let causality = match c {
        // a parameter that the FMU's structure (array sizes) depends on
        "structuralParameter" => Causality::Parameter,
        other => Causality::from_name(other).ok_or_else(|| SchemaError::Xml {
            line,
            message: format!("variable '{name}': unknown causality \"{c}\""),
        })?,
    };
    if !seen.names.insert(name.to_string()) {
        return Err(SchemaError::Xml {
            line,
            message: format!("variable name '{name}' repeats"),
        });
    }
    let ty = exchanged_type(&p.element).filter(|_| !p.array);
    let position = ty.map(|_| md.variables.len());
    if let Some((first, _)) = seen.by_vr.insert(vr, (line, position)) {
        return Err(SchemaError::Xml {
            line,
            message: format!(
                "valueReference {vr} of '{name}' is already used by the variable on line {first} \
                 (FMI 3.0 value references are unique across all variables)"
            ),
        });
    }
    let Some(ty) = ty else {
        md.other_variables.push(OtherVariable {
            name: name.to_string(),
            value_reference: vr,
            element: p.element.clone(),
            array: p.array,
            causality,
            line,
        });
        return Ok(());
    };
    let default_variability = if ty == VarType::Real {
        "continuous"
    } else {
        "discrete"
    };
    let v = get(a, "variability").unwrap_or(default_variability);
    let variability = Variability::from_name(v).ok_or_else(|| SchemaError::Xml {
        line,
        message: format!("variable '{name}': unknown variability \"{v}\""),
    })?;
    if let Some(d) = get(a, "derivative") {
        let state = parse_num::<u32>(d, "derivative", line, "a value reference")?;
        seen.derivative_of.push((md.variables.len(), state, line));
    }
    let start = get(a, "start")
        .map(str::to_string)
        .or_else(|| p.start_children.first().cloned());
    md.variables.push(ScalarVariable {
        index: md.variables.len() + 1,
        name: name.to_string(),
        value_reference: vr,
        description: get(a, "description").unwrap_or("").to_string(),
        causality,
        variability,
        ty,
        start,
        unit: get(a, "unit").map(str::to_string),
        derivative: None,
        line,
    });
    Ok(())
}

/// Resolve `<ModelStructure>` and `derivative` value references to the
/// 1-based positions of [`ModelDescription::variables`].
fn resolve(md: &mut ModelDescription, seen: &Seen, unknowns: Vec<RawUnknown>) -> Result<()> {
    let by_vr = &seen.by_vr;
    let lookup = |vr: u32, line: usize, what: &str| -> Result<Option<usize>> {
        match by_vr.get(&vr) {
            Some((_, pos)) => Ok(pos.map(|p| p + 1)),
            None => Err(SchemaError::Xml {
                line,
                message: format!("{what} names valueReference {vr}, which no variable has"),
            }),
        }
    };
    for &(i, state, line) in &seen.derivative_of {
        md.variables[i].derivative = lookup(state, line, "derivative")?;
    }
    for u in unknowns {
        let index = lookup(u.vr, u.line, u.section)?;
        let dependencies = match u.dependencies {
            None => None,
            Some(d) => {
                let mut out = Vec::with_capacity(d.len());
                for vr in d {
                    if let Some(i) = lookup(vr, u.line, "dependencies")? {
                        out.push(i);
                    }
                }
                Some(out)
            }
        };
        if u.section == "EventIndicator" {
            md.number_of_event_indicators += 1;
            continue;
        }
        let Some(index) = index else { continue };
        let unknown = Unknown {
            index,
            dependencies,
            line: u.line,
        };
        match u.section {
            "Output" => md.outputs.push(unknown),
            "ContinuousStateDerivative" => md.derivatives.push(unknown),
            "InitialUnknown" => md.initial_unknowns.push(unknown),
            _ => {}
        }
    }
    Ok(())
}

/// The capability flags common to `<CoSimulation>` and `<ModelExchange>`:
/// (canGetAndSetFMUState, canSerializeFMUState, providesDirectionalDerivatives).
fn common_flags(a: &[(String, String)], line: usize) -> Result<(bool, bool, bool)> {
    let flag = |k: &str| -> Result<bool> {
        get(a, k)
            .map(|v| parse_bool(v, k, line))
            .transpose()
            .map(|b| b.unwrap_or(false))
    };
    Ok((
        flag("canGetAndSetFMUState")?,
        flag("canSerializeFMUState")?,
        flag("providesDirectionalDerivatives")?,
    ))
}

fn model_identifier(a: &[(String, String)], line: usize, element: &str) -> Result<String> {
    get(a, "modelIdentifier")
        .map(str::to_string)
        .ok_or_else(|| SchemaError::Xml {
            line,
            message: format!("<{element}> has no modelIdentifier"),
        })
}

fn co_simulation(a: &[(String, String)], line: usize) -> Result<CoSimCapabilities> {
    let (state, serialize, directional) = common_flags(a, line)?;
    let flag = |k: &str| -> Result<bool> {
        get(a, k)
            .map(|v| parse_bool(v, k, line))
            .transpose()
            .map(|b| b.unwrap_or(false))
    };
    Ok(CoSimCapabilities {
        model_identifier: model_identifier(a, line, "CoSimulation")?,
        can_handle_variable_communication_step_size: flag(
            "canHandleVariableCommunicationStepSize",
        )?,
        can_interpolate_inputs: false,
        max_output_derivative_order: get(a, "maxOutputDerivativeOrder")
            .map(|v| parse_num(v, "maxOutputDerivativeOrder", line, "an unsigned integer"))
            .transpose()?
            .unwrap_or(0),
        can_get_and_set_fmu_state: state,
        can_serialize_fmu_state: serialize,
        provides_directional_derivative: directional,
        needs_execution_tool: flag("needsExecutionTool")?,
        can_be_instantiated_only_once_per_process: flag("canBeInstantiatedOnlyOncePerProcess")?,
        provides_intermediate_update: flag("providesIntermediateUpdate")?,
        might_return_early_from_do_step: flag("mightReturnEarlyFromDoStep")?,
        has_event_mode: flag("hasEventMode")?,
    })
}

fn model_exchange(a: &[(String, String)], line: usize) -> Result<ModelExchangeCapabilities> {
    let (state, serialize, directional) = common_flags(a, line)?;
    let needs_completed = get(a, "needsCompletedIntegratorStep")
        .map(|v| parse_bool(v, "needsCompletedIntegratorStep", line))
        .transpose()?
        .unwrap_or(false);
    Ok(ModelExchangeCapabilities {
        model_identifier: model_identifier(a, line, "ModelExchange")?,
        completed_integrator_step_not_needed: !needs_completed,
        can_get_and_set_fmu_state: state,
        can_serialize_fmu_state: serialize,
        provides_directional_derivative: directional,
    })
}

#[cfg(test)]
#[path = "schema3_tests.rs"]
mod tests;
