//! The FMI 2.0 modelDescription.xml of a model, written from its code
//! ([`CoSimModel::VARIABLES`], [`CoSimModel::INFO`], ...) through the
//! version-neutral [`Layout`]. The text is deterministic (one variable per
//! line, its index in a comment), so that a checked-in copy can be compared
//! byte for byte ([`crate::testing::check_model_description_file`]).
use std::fmt::Write;

use crate::description::{real_text, start_text, DescriptionError, Layout, Unknown};
use crate::model::{CoSimModel, VarType, LOG_CATEGORIES};

/// The modelDescription.xml of `M` (FMI 2.0, Co-Simulation, and Model
/// Exchange when `M` has continuous states).
pub fn model_description<M: CoSimModel>() -> Result<String, DescriptionError> {
    Ok(fmi2(&Layout::of::<M>()?))
}

/// Escape a text for an attribute value in double quotes.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Write the FMI 2.0 XML of a resolved description.
pub fn fmi2(l: &Layout) -> String {
    let info = &l.info;
    let caps = &info.capabilities;
    let id = esc(l.model_identifier);
    let mut x = String::new();
    // `write!` into a String cannot fail
    let mut w = |s: String| x.push_str(&s);
    w("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n".into());
    w(format!(
        "<!-- Generated from the code of the FMU {id} (its variable table and ModelInfo) by\n     \
         fmi2_export::render; do not edit. A test of the FMU crate compares this file with the\n     \
         code; `UPDATE_MODEL_DESCRIPTION=1 cargo test` rewrites it. -->\n"
    ));
    w("<fmiModelDescription\n  fmiVersion=\"2.0\"\n".into());
    w(format!("  modelName=\"{}\"\n", esc(info.name)));
    w(format!("  guid=\"{}\"\n", esc(l.guid)));
    w(format!("  description=\"{}\"\n", esc(info.description)));
    if let Some(v) = info.version {
        w(format!("  version=\"{}\"\n", esc(v)));
    }
    w(format!(
        "  generationTool=\"{}\"\n",
        esc(info.generation_tool)
    ));
    w("  variableNamingConvention=\"flat\"\n  numberOfEventIndicators=\"0\">\n\n".into());
    let dd = caps.provides_directional_derivative;
    if l.model_exchange {
        w(format!(
            "  <ModelExchange\n    modelIdentifier=\"{id}\"\n    needsExecutionTool=\"false\"\n    \
             completedIntegratorStepNotNeeded=\"true\"\n    \
             canBeInstantiatedOnlyOncePerProcess=\"false\"\n    \
             canNotUseMemoryManagementFunctions=\"true\"\n    canGetAndSetFMUstate=\"true\"\n    \
             canSerializeFMUstate=\"true\"\n    providesDirectionalDerivative=\"{dd}\"/>\n\n"
        ));
    }
    w(format!(
        "  <CoSimulation\n    modelIdentifier=\"{id}\"\n    needsExecutionTool=\"false\"\n    \
         canHandleVariableCommunicationStepSize=\"{}\"\n    canInterpolateInputs=\"{}\"\n    \
         maxOutputDerivativeOrder=\"{}\"\n    canRunAsynchronuously=\"false\"\n    \
         canBeInstantiatedOnlyOncePerProcess=\"false\"\n    \
         canNotUseMemoryManagementFunctions=\"true\"\n    canGetAndSetFMUstate=\"true\"\n    \
         canSerializeFMUstate=\"true\"\n    providesDirectionalDerivative=\"{dd}\"/>\n\n",
        caps.can_handle_variable_communication_step_size,
        caps.can_interpolate_inputs,
        caps.max_output_derivative_order,
    ));
    if !l.units.is_empty() {
        w("  <UnitDefinitions>\n".into());
        for u in &l.units {
            let base = u.base.map(|b| {
                let attrs: Vec<String> = b
                    .exponents()
                    .iter()
                    .filter(|(_, e)| *e != 0)
                    .map(|(n, e)| format!(" {n}=\"{e}\""))
                    .collect();
                format!("<BaseUnit{}/>", attrs.concat())
            });
            match base {
                Some(b) => w(format!("    <Unit name=\"{}\">{b}</Unit>\n", esc(u.name))),
                None => w(format!("    <Unit name=\"{}\"/>\n", esc(u.name))),
            }
        }
        w("  </UnitDefinitions>\n\n".into());
    }
    w("  <LogCategories>\n".into());
    for (name, d) in LOG_CATEGORIES.iter().zip(info.log_categories) {
        w(format!(
            "    <Category name=\"{name}\" description=\"{}\"/>\n",
            esc(d)
        ));
    }
    w("  </LogCategories>\n\n".into());
    let e = &info.default_experiment;
    let attrs: Vec<String> = [
        ("startTime", e.start_time),
        ("stopTime", e.stop_time),
        ("tolerance", e.tolerance),
        ("stepSize", e.step_size),
    ]
    .iter()
    .filter_map(|(n, v)| v.map(|v| format!(" {n}=\"{}\"", real_text(v))))
    .collect();
    if !attrs.is_empty() {
        w(format!("  <DefaultExperiment{}/>\n\n", attrs.concat()));
    }
    w("  <ModelVariables>\n".into());
    for (i, v) in l.variables.iter().enumerate() {
        let initial = Layout::initial(v)
            .map(|k| format!(" initial=\"{}\"", k.name()))
            .unwrap_or_default();
        let mut ty = String::new();
        if !v.unit.is_empty() && v.ty == VarType::Real {
            let _ = write!(ty, " unit=\"{}\"", esc(v.unit));
        }
        if let Some(s) = &v.start {
            let _ = write!(ty, " start=\"{}\"", esc(&start_text(s)));
        }
        if let Some(state) = l.derivative_of[i] {
            let _ = write!(ty, " derivative=\"{}\"", state + 1);
        }
        w(format!(
            "    <!-- {} --><ScalarVariable name=\"{}\" valueReference=\"{}\" causality=\"{}\" \
             variability=\"{}\"{initial} description=\"{}\"><{}{ty}/></ScalarVariable>\n",
            i + 1,
            esc(v.name),
            v.vr,
            v.causality.name(),
            v.variability.name(),
            esc(v.description),
            v.ty.name(),
        ));
    }
    w("  </ModelVariables>\n\n".into());
    w("  <ModelStructure>\n".into());
    for (tag, list) in [
        ("Outputs", &l.outputs),
        ("Derivatives", &l.derivatives),
        ("InitialUnknowns", &l.initial_unknowns),
    ] {
        if list.is_empty() {
            continue;
        }
        w(format!("    <{tag}>\n"));
        for u in list {
            w(format!("      {}\n", unknown(u)));
        }
        w(format!("    </{tag}>\n"));
    }
    w("  </ModelStructure>\n</fmiModelDescription>\n".into());
    x
}

/// One `<Unknown>` (indices are positions + 1).
fn unknown(u: &Unknown) -> String {
    let deps: Vec<String> = u.dependencies.iter().map(|j| (j + 1).to_string()).collect();
    let kind = if u.fixed && !deps.is_empty() {
        format!(
            " dependenciesKind=\"{}\"",
            vec!["fixed"; deps.len()].join(" ")
        )
    } else {
        String::new()
    };
    format!(
        "<Unknown index=\"{}\" dependencies=\"{}\"{kind}/>",
        u.variable + 1,
        deps.join(" ")
    )
}
