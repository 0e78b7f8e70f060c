//! The FMI 2.0 modelDescription.xml of a model, written from its code
//! ([`CoSimModel::VARIABLES`], [`CoSimModel::INFO`], ...) through the
//! version-neutral [`Layout`]. The text is deterministic (one variable per
//! line, its index in a comment), so that a checked-in copy can be compared
//! byte for byte ([`crate::testing::check_model_description_file`]).
use crate::description::{real_text, start_text, DescriptionError, Layout, Unknown};
use crate::model::{CoSimModel, VarType, LOG_CATEGORIES};

/// The modelDescription.xml of `M` (FMI 2.0, Co-Simulation, and Model
/// Exchange when `M` has continuous states).
pub fn model_description<M: CoSimModel>() -> Result<String, DescriptionError> {
    Ok(fmi2(&Layout::of::<M>()?))
}

/// Escape a text for an attribute value in double quotes.
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Write the FMI 2.0 XML of a resolved description.
pub fn fmi2(l: &Layout) -> String {
    [
        header(l),
        interfaces(l),
        unit_definitions(l),
        log_categories(l),
        default_experiment(l),
        model_variables(l),
        model_structure(l),
    ]
    .concat()
}

/// The XML declaration, the note that the file is generated and the
/// attributes of `<fmiModelDescription>`.
fn header(l: &Layout) -> String {
    header_for(
        l,
        "fmi2_export::render",
        "2.0",
        "guid",
        "\n  numberOfEventIndicators=\"0\"",
    )
}

/// The XML declaration, the note that `renderer` generated the file, and
/// `<fmiModelDescription>` of FMI version `fmi_version` with the GUID as
/// `token_attr` (`guid`, FMI 3.0's `instantiationToken`) and `extra`
/// attributes after the naming convention (FMI 2.0 and 3.0 agree on the rest).
pub(crate) fn header_for(
    l: &Layout,
    renderer: &str,
    fmi_version: &str,
    token_attr: &str,
    extra: &str,
) -> String {
    let info = &l.info;
    let mut x = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
         <!-- Generated from the code of the FMU {} (its variable table and ModelInfo) by\n     \
         {renderer}; do not edit. A test of the FMU crate compares this file with the\n     \
         code; `UPDATE_MODEL_DESCRIPTION=1 cargo test` rewrites it. -->\n\
         <fmiModelDescription\n  fmiVersion=\"{fmi_version}\"\n  modelName=\"{}\"\n  {token_attr}=\"{}\"\n  \
         description=\"{}\"\n",
        esc(l.model_identifier),
        esc(info.name),
        esc(l.guid),
        esc(info.description)
    );
    if let Some(v) = info.version {
        x += &format!("  version=\"{}\"\n", esc(v));
    }
    x + &format!(
        "  generationTool=\"{}\"\n  variableNamingConvention=\"flat\"{extra}>\n\n",
        esc(info.generation_tool)
    )
}

/// `<ModelExchange>` (with continuous states) and `<CoSimulation>`: the
/// model's [`Capabilities`](crate::description::Capabilities), the rest what
/// the export layer gives every model.
fn interfaces(l: &Layout) -> String {
    let caps = &l.info.capabilities;
    let id = esc(l.model_identifier);
    let dd = caps.provides_directional_derivative;
    let mut x = String::new();
    if l.model_exchange {
        x += &format!(
            "  <ModelExchange\n    modelIdentifier=\"{id}\"\n    needsExecutionTool=\"false\"\n    \
             completedIntegratorStepNotNeeded=\"true\"\n    \
             canBeInstantiatedOnlyOncePerProcess=\"false\"\n    \
             canNotUseMemoryManagementFunctions=\"true\"\n    canGetAndSetFMUstate=\"true\"\n    \
             canSerializeFMUstate=\"true\"\n    providesDirectionalDerivative=\"{dd}\"/>\n\n"
        );
    }
    x + &format!(
        "  <CoSimulation\n    modelIdentifier=\"{id}\"\n    needsExecutionTool=\"false\"\n    \
         canHandleVariableCommunicationStepSize=\"{}\"\n    canInterpolateInputs=\"{}\"\n    \
         maxOutputDerivativeOrder=\"{}\"\n    canRunAsynchronuously=\"false\"\n    \
         canBeInstantiatedOnlyOncePerProcess=\"false\"\n    \
         canNotUseMemoryManagementFunctions=\"true\"\n    canGetAndSetFMUstate=\"true\"\n    \
         canSerializeFMUstate=\"true\"\n    providesDirectionalDerivative=\"{dd}\"/>\n\n",
        caps.can_handle_variable_communication_step_size,
        caps.can_interpolate_inputs,
        caps.max_output_derivative_order,
    )
}

/// `<UnitDefinitions>`: the units the variables use.
pub(crate) fn unit_definitions(l: &Layout) -> String {
    if l.units.is_empty() {
        return String::new();
    }
    let mut x = String::from("  <UnitDefinitions>\n");
    for u in &l.units {
        match u.base {
            Some(b) => {
                let attrs: String = b
                    .exponents()
                    .iter()
                    .filter(|(_, e)| *e != 0)
                    .map(|(n, e)| format!(" {n}=\"{e}\""))
                    .collect();
                x += &format!(
                    "    <Unit name=\"{}\"><BaseUnit{attrs}/></Unit>\n",
                    esc(u.name)
                );
            }
            None => x += &format!("    <Unit name=\"{}\"/>\n", esc(u.name)),
        }
    }
    x + "  </UnitDefinitions>\n\n"
}

/// `<LogCategories>`: the layer's categories with the model's descriptions.
pub(crate) fn log_categories(l: &Layout) -> String {
    let mut x = String::from("  <LogCategories>\n");
    for (name, d) in LOG_CATEGORIES.iter().zip(l.info.log_categories) {
        x += &format!(
            "    <Category name=\"{name}\" description=\"{}\"/>\n",
            esc(d)
        );
    }
    x + "  </LogCategories>\n\n"
}

/// `<DefaultExperiment>` with the attributes the model gives.
pub(crate) fn default_experiment(l: &Layout) -> String {
    let e = &l.info.default_experiment;
    let attrs: String = [
        ("startTime", e.start_time),
        ("stopTime", e.stop_time),
        ("tolerance", e.tolerance),
        ("stepSize", e.step_size),
    ]
    .iter()
    .filter_map(|(n, v)| v.map(|v| format!(" {n}=\"{}\"", real_text(v))))
    .collect();
    if attrs.is_empty() {
        return String::new();
    }
    format!("  <DefaultExperiment{attrs}/>\n\n")
}

/// `<ModelVariables>`, one line per variable with its index in a comment.
fn model_variables(l: &Layout) -> String {
    let mut x = String::from("  <ModelVariables>\n");
    for (i, v) in l.variables.iter().enumerate() {
        let initial = Layout::initial(v)
            .map(|k| format!(" initial=\"{}\"", k.name()))
            .unwrap_or_default();
        let mut ty = String::new();
        if !v.unit.is_empty() && v.ty == VarType::Real {
            ty += &format!(" unit=\"{}\"", esc(v.unit));
        }
        if let Some(s) = &v.start {
            ty += &format!(" start=\"{}\"", esc(&start_text(s)));
        }
        if let Some(state) = l.derivative_of[i] {
            ty += &format!(" derivative=\"{}\"", state + 1);
        }
        x += &format!(
            "    <!-- {} --><ScalarVariable name=\"{}\" valueReference=\"{}\" causality=\"{}\" \
             variability=\"{}\"{initial} description=\"{}\"><{}{ty}/></ScalarVariable>\n",
            i + 1,
            esc(v.name),
            v.vr,
            v.causality.name(),
            v.variability.name(),
            esc(v.description),
            v.ty.name(),
        );
    }
    x + "  </ModelVariables>\n\n"
}

/// `<ModelStructure>`: `<Outputs>`, `<Derivatives>`, `<InitialUnknowns>`
/// (each left out when empty).
fn model_structure(l: &Layout) -> String {
    let mut x = String::from("  <ModelStructure>\n");
    for (tag, list) in [
        ("Outputs", &l.outputs),
        ("Derivatives", &l.derivatives),
        ("InitialUnknowns", &l.initial_unknowns),
    ] {
        if list.is_empty() {
            continue;
        }
        x += &format!("    <{tag}>\n");
        for u in list {
            x += &format!("      {}\n", unknown(u));
        }
        x += &format!("    </{tag}>\n");
    }
    x + "  </ModelStructure>\n</fmiModelDescription>\n"
}

/// One `<Unknown>` (indices are positions + 1).
fn unknown(u: &Unknown) -> String {
    let deps: Vec<String> = u.dependencies.iter().map(|j| (j + 1).to_string()).collect();
    unknown_element("Unknown", "index", u.variable + 1, &deps, u.fixed)
}

/// `<tag key="id" dependencies="deps" [dependenciesKind="fixed ..."]/>`:
/// an unknown of `<ModelStructure>` in either version (FMI 2.0 `<Unknown
/// index>`, FMI 3.0 `<Output valueReference>` ...).
pub(crate) fn unknown_element(
    tag: &str,
    key: &str,
    id: impl std::fmt::Display,
    deps: &[String],
    fixed: bool,
) -> String {
    let kind = if fixed && !deps.is_empty() {
        format!(
            " dependenciesKind=\"{}\"",
            vec!["fixed"; deps.len()].join(" ")
        )
    } else {
        String::new()
    };
    format!(
        "<{tag} {key}=\"{id}\" dependencies=\"{}\"{kind}/>",
        deps.join(" ")
    )
}
