//! The FMI 3.0 modelDescription.xml of a model, written from the same code
//! as the FMI 2.0 one ([`CoSimModel::VARIABLES`], [`CoSimModel::INFO`],
//! [`CoSimModel::CONTINUOUS_STATES`]) through the version-neutral
//! [`Layout`]; [`crate::render`] shares the unit definitions, log
//! categories and default experiment. The text is deterministic, so that a
//! checked-in copy (`modelDescription/<id>_fmi3/modelDescription.xml`) can be
//! compared byte for byte ([`crate::testing::check_model_description_file3`]).
//!
//! What FMI 3.0 adds or names differently:
//!
//! * `instantiationToken` is the model's [`CoSimModel::GUID`];
//! * the independent variable `time` (`causality="independent"`), value
//!   reference [`TIME_VALUE_REFERENCE`] (no FMI 2.0 variable has it;
//!   `fmi3GetFloat64` of it returns the instance's time);
//! * variables are typed elements, `<Float64>`, `<Int32>`, `<Boolean>`,
//!   `<String>` (its start value a `<Start value=".."/>` child);
//! * value references are unique over all variables (FMI 2.0's are unique
//!   per type): every variable keeps its FMI 2.0 value reference except a
//!   non-Real one whose number a variable of another type also has, which
//!   gets [`fmi3_value_reference`] (its FMI 2.0 number plus a per-type offset);
//! * `<ModelStructure>` names variables by value reference
//!   (`<Output>`, `<ContinuousStateDerivative>`, `<InitialUnknown>`) and the
//!   `derivative` attribute is the state's value reference.
use crate::description::{start_text, DescriptionError, Layout, Unknown};
use crate::model::{CoSimModel, Start, VarType, Variable};
use crate::render::{default_experiment, esc, log_categories, unit_definitions};

/// Value reference of the independent variable `time` in every FMI 3.0
/// modelDescription of this crate (above every FMI 2.0 value reference the
/// models use; [`Layout`] checks it is free).
pub const TIME_VALUE_REFERENCE: u32 = 999_999_999;

/// Offset added to the FMI 2.0 value reference of an Int32, Boolean or
/// String variable whose number is also used by a variable of another type
/// (FMI 3.0 value references are unique over all types).
pub const fn type_offset(ty: VarType) -> u32 {
    match ty {
        VarType::Real => 0,
        VarType::Integer => 100_000_000,
        VarType::Boolean => 200_000_000,
        _ => 300_000_000,
    }
}

/// The FMI 3.0 value reference of `v` in the table `vars`: its FMI 2.0 one
/// unless it is a non-Real variable whose number another variable of the
/// table also has (then plus [`type_offset`]). Float64 value references
/// are always the FMI 2.0 ones.
pub fn fmi3_value_reference(vars: &[Variable], v: &Variable) -> u32 {
    if v.ty == VarType::Real
        || !vars
            .iter()
            .any(|w| w.vr == v.vr && w.ty != v.ty && !std::ptr::eq(w, v))
    {
        v.vr
    } else {
        v.vr + type_offset(v.ty)
    }
}

/// The FMI 3.0 modelDescription.xml of `M` (Co-Simulation, and Model
/// Exchange when `M` has continuous states).
pub fn model_description<M: CoSimModel>() -> Result<String, DescriptionError> {
    let l = Layout::of::<M>()?;
    let vrs: Vec<u32> = l
        .variables
        .iter()
        .map(|v| fmi3_value_reference(l.variables, v))
        .collect();
    for (i, &vr) in vrs.iter().enumerate() {
        if vr == TIME_VALUE_REFERENCE || vrs[..i].contains(&vr) {
            return Err(DescriptionError::DuplicateValueReference3 {
                name: l.variables[i].name,
                vr,
            });
        }
    }
    let mut all = vrs.clone();
    for (name, vr) in extra_names::<M>() {
        if vr == TIME_VALUE_REFERENCE || all.contains(&vr) {
            return Err(DescriptionError::DuplicateValueReference3 { name, vr });
        }
        all.push(vr);
    }
    let x = Fmi3Only::of::<M>(&l, &vrs)?;
    Ok(fmi3(&l, &vrs, M::MIGHT_RETURN_EARLY, &x))
}

/// `xml` (an FMI 3.0 modelDescription rendered by [`model_description`])
/// with the `start` of the structural parameter `name` set to `start`: an
/// FMU packaged with data of another size (e.g. a modal table of another
/// number of points) declares the dimension of its arrays for that data
/// (FMI 3.0 section 2.4.7.2: the initial dimension sizes are the start
/// values of the structural parameters). Errors name what is missing.
pub fn with_structural_start(xml: &str, name: &str, start: u64) -> Result<String, String> {
    let head = format!("<UInt64 name=\"{}\" ", esc(name));
    let at = xml
        .find(&head)
        .ok_or_else(|| format!("no UInt64 variable {name} in the modelDescription"))?;
    let end = at + xml[at..].find("/>").ok_or("unterminated UInt64 element")?;
    let element = &xml[at..end];
    if !element.contains("causality=\"structuralParameter\"") {
        return Err(format!("{name} is not a structural parameter"));
    }
    let key = " start=\"";
    let s = at
        + element
            .find(key)
            .ok_or_else(|| format!("{name} has no start"))?
        + key.len();
    let e = s + xml[s..end]
        .find('"')
        .ok_or("unterminated start attribute")?;
    Ok(format!("{}{start}{}", &xml[..s], &xml[e..]))
}

/// The FMI 3.0-only variables' names and value references.
fn extra_names<M: CoSimModel>() -> impl Iterator<Item = (&'static str, u32)> {
    let s = M::STRUCTURAL_PARAMETERS.iter().map(|p| (p.name, p.vr));
    s.chain(M::ARRAY_OUTPUTS.iter().map(|a| (a.name, a.vr)))
}

/// What only the FMI 3.0 description has: the structural parameters and
/// array outputs of the model ([`CoSimModel::STRUCTURAL_PARAMETERS`],
/// [`CoSimModel::ARRAY_OUTPUTS`], FMI 3.0 section 2.4.7.2), rendered as
/// elements and as `<Output>` / `<InitialUnknown>` entries.
struct Fmi3Only {
    variables: String,
    outputs: String,
    initial_unknowns: String,
}

impl Fmi3Only {
    fn of<M: CoSimModel>(l: &Layout, vrs: &[u32]) -> Result<Self, DescriptionError> {
        let n = l.variables.len();
        let mut x = Fmi3Only {
            variables: String::new(),
            outputs: String::new(),
            initial_unknowns: String::new(),
        };
        for (k, p) in M::STRUCTURAL_PARAMETERS.iter().enumerate() {
            x.variables += &format!(
                "    <!-- {} (FMI 3.0 only) --><UInt64 name=\"{}\" valueReference=\"{}\" \
                 causality=\"structuralParameter\" variability=\"fixed\" description=\"{}\" \
                 min=\"1\" max=\"{}\" start=\"{}\"/>\n",
                n + 1 + k,
                esc(p.name),
                p.vr,
                esc(p.description),
                p.max,
                p.start
            );
        }
        let k0 = n + 1 + M::STRUCTURAL_PARAMETERS.len();
        for (k, a) in M::ARRAY_OUTPUTS.iter().enumerate() {
            if !M::STRUCTURAL_PARAMETERS
                .iter()
                .any(|p| p.vr == a.dimension_vr)
            {
                return Err(DescriptionError::UnknownVariable {
                    array: a.name,
                    what: "dimension (structural parameter) value reference",
                    name: a.dimension_vr.to_string(),
                });
            }
            let unit = if a.unit.is_empty() {
                String::new()
            } else {
                format!(" unit=\"{}\"", esc(a.unit))
            };
            x.variables += &format!(
                "    <!-- {} (FMI 3.0 only) --><Float64 name=\"{}\" valueReference=\"{}\" \
                 causality=\"output\" variability=\"continuous\" initial=\"calculated\" \
                 description=\"{}\"{unit}><Dimension valueReference=\"{}\"/></Float64>\n",
                k0 + k,
                esc(a.name),
                a.vr,
                esc(a.description),
                a.dimension_vr
            );
            let deps = a
                .initial_dependencies
                .iter()
                .map(|d| {
                    l.variables
                        .iter()
                        .position(|v| v.name == *d)
                        .map(|i| vrs[i].to_string())
                        .ok_or_else(|| DescriptionError::UnknownVariable {
                            array: a.name,
                            what: "initial dependency",
                            name: d.to_string(),
                        })
                })
                .collect::<Result<Vec<_>, _>>()?;
            x.outputs += &format!(
                "    {}\n",
                crate::render::unknown_element("Output", "valueReference", a.vr, &[], false)
            );
            x.initial_unknowns += &format!(
                "    {}\n",
                crate::render::unknown_element(
                    "InitialUnknown",
                    "valueReference",
                    a.vr,
                    &deps,
                    false
                )
            );
        }
        Ok(x)
    }
}

/// Write the FMI 3.0 XML of a resolved description (`vrs`: the FMI 3.0
/// value reference of each variable).
fn fmi3(l: &Layout, vrs: &[u32], early_return: bool, x: &Fmi3Only) -> String {
    [
        header(l),
        interfaces(l, early_return),
        unit_definitions(l),
        log_categories(l),
        default_experiment(l),
        model_variables(l, vrs, x),
        model_structure(l, vrs, x),
    ]
    .concat()
}

fn header(l: &Layout) -> String {
    crate::render::header_for(l, "fmi2_export::render3", "3.0", "instantiationToken", "")
}

/// `<ModelExchange>` (with continuous states) and `<CoSimulation>`. What
/// the layer does not implement is declared false: adjoint derivatives,
/// per-element dependencies, event mode in Co-Simulation and intermediate
/// update (see the FMU READMEs for why); `mightReturnEarlyFromDoStep` is
/// the model's [`CoSimModel::MIGHT_RETURN_EARLY`].
fn interfaces(l: &Layout, early_return: bool) -> String {
    let caps = &l.info.capabilities;
    let id = esc(l.model_identifier);
    let dd = caps.provides_directional_derivative;
    let common = format!(
        "    modelIdentifier=\"{id}\"\n    needsExecutionTool=\"false\"\n    \
         canBeInstantiatedOnlyOncePerProcess=\"false\"\n    canGetAndSetFMUState=\"true\"\n    \
         canSerializeFMUState=\"true\"\n    providesDirectionalDerivatives=\"{dd}\"\n    \
         providesAdjointDerivatives=\"false\"\n    providesPerElementDependencies=\"false\"\n"
    );
    let mut x = String::new();
    if l.model_exchange {
        x += &format!(
            "  <ModelExchange\n{common}    needsCompletedIntegratorStep=\"false\"\n    \
             providesEvaluateDiscreteStates=\"false\"/>\n\n"
        );
    }
    x + &format!(
        "  <CoSimulation\n{common}    canHandleVariableCommunicationStepSize=\"{}\"\n    \
         maxOutputDerivativeOrder=\"{}\"\n    providesIntermediateUpdate=\"false\"\n    \
         mightReturnEarlyFromDoStep=\"{early_return}\"\n    canReturnEarlyAfterIntermediateUpdate=\"false\"\n    \
         hasEventMode=\"false\"\n    providesEvaluateDiscreteStates=\"false\"/>\n\n",
        caps.can_handle_variable_communication_step_size, caps.max_output_derivative_order,
    )
}

fn type_name(ty: VarType) -> &'static str {
    match ty {
        VarType::Real => "Float64",
        VarType::Integer => "Int32",
        VarType::Boolean => "Boolean",
        _ => "String",
    }
}

/// `<ModelVariables>`: `time` first, then one element per variable in table
/// order (the FMI 2.0 index in a comment).
fn model_variables(l: &Layout, vrs: &[u32], extra: &Fmi3Only) -> String {
    let mut x = format!(
        "  <ModelVariables>\n    <Float64 name=\"time\" valueReference=\"{TIME_VALUE_REFERENCE}\" \
         causality=\"independent\" variability=\"continuous\" description=\"Simulation time [s]\"/>\n"
    );
    for (i, v) in l.variables.iter().enumerate() {
        let initial = Layout::initial(v)
            .map(|k| format!(" initial=\"{}\"", k.name()))
            .unwrap_or_default();
        let mut attrs = String::new();
        if !v.unit.is_empty() && v.ty == VarType::Real {
            attrs += &format!(" unit=\"{}\"", esc(v.unit));
        }
        let mut child = String::new();
        match &v.start {
            Some(Start::String(s)) => child = format!("<Start value=\"{}\"/>", esc(s)),
            Some(s) => attrs += &format!(" start=\"{}\"", esc(&start_text(s))),
            None => {}
        }
        if let Some(state) = l.derivative_of[i] {
            attrs += &format!(" derivative=\"{}\"", vrs[state]);
        }
        let tag = type_name(v.ty);
        let head = format!(
            "<{tag} name=\"{}\" valueReference=\"{}\" causality=\"{}\" variability=\"{}\"{initial} \
             description=\"{}\"{attrs}",
            esc(v.name),
            vrs[i],
            v.causality.name(),
            v.variability.name(),
            esc(v.description),
        );
        let body = if child.is_empty() {
            format!("{head}/>")
        } else {
            format!("{head}>{child}</{tag}>")
        };
        x += &format!("    <!-- {} -->{body}\n", i + 1);
    }
    x + &extra.variables + "  </ModelVariables>\n\n"
}

/// `<ModelStructure>`: `<Output>`, `<ContinuousStateDerivative>`,
/// `<InitialUnknown>` by value reference.
fn model_structure(l: &Layout, vrs: &[u32], extra: &Fmi3Only) -> String {
    let mut x = String::from("  <ModelStructure>\n");
    for (tag, list) in [
        ("Output", &l.outputs),
        ("ContinuousStateDerivative", &l.derivatives),
        ("InitialUnknown", &l.initial_unknowns),
    ] {
        for u in list {
            x += &format!("    {}\n", unknown(tag, u, vrs));
        }
        match tag {
            "Output" => x += &extra.outputs,
            "InitialUnknown" => x += &extra.initial_unknowns,
            _ => {}
        }
    }
    x + "  </ModelStructure>\n</fmiModelDescription>\n"
}

fn unknown(tag: &str, u: &Unknown, vrs: &[u32]) -> String {
    let deps: Vec<String> = u.dependencies.iter().map(|&j| vrs[j].to_string()).collect();
    crate::render::unknown_element(tag, "valueReference", vrs[u.variable], &deps, u.fixed)
}
