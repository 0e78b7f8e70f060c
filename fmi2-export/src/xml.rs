//! Keeps modelDescription.xml and the code from drifting apart: parse the XML
//! with the one schema ([`fmi2::schema`]), list what
//! [`ModelDescription::validate`] finds, and compare every `<ScalarVariable>`
//! with the model's [`Variable`] table, the GUID and `modelIdentifier`.
pub use fmi2::schema::ModelDescription;

use crate::model::{CoSimModel, Start, VarType, Variable};

fn start_matches(s: &Start, xml: &str) -> bool {
    match s {
        Start::Real(x) => xml.trim().parse::<f64>().map(|y| y == *x).unwrap_or(false),
        Start::Integer(i) => xml.trim().parse::<i32>().map(|y| y == *i).unwrap_or(false),
        Start::Boolean(b) => matches!(
            (xml.trim(), b),
            ("true", true) | ("false", false) | ("1", true) | ("0", false)
        ),
        Start::String(t) => xml == *t,
    }
}

/// Compare the XML with the code's identity and variable table; every
/// mismatch and every [`ModelDescription::validate`] problem is reported
/// (`Ok` = agreement). The validation includes that
/// `<ModelStructure><Outputs>` lists exactly the output variables, in order.
pub fn check_model_description(
    xml: &str,
    model_identifier: &str,
    guid: &str,
    variables: &[Variable],
) -> Result<ModelDescription, Vec<String>> {
    let md = ModelDescription::parse(xml).map_err(|e| vec![e.to_string()])?;
    let mut errs: Vec<String> = md.validate().iter().map(|p| p.to_string()).collect();
    if md.guid != guid {
        errs.push(format!("guid {:?} in XML, {:?} in code", md.guid, guid));
    }
    let id = &md.co_simulation.model_identifier;
    if id != model_identifier {
        errs.push(format!(
            "modelIdentifier {id:?} in XML, {model_identifier:?} in code"
        ));
    }
    if md.variables.len() != variables.len() {
        errs.push(format!(
            "{} variables in XML, {} in code",
            md.variables.len(),
            variables.len()
        ));
    }
    for v in variables {
        let Some(x) = md.variables.iter().find(|x| x.name == v.name) else {
            errs.push(format!("variable {} missing in XML", v.name));
            continue;
        };
        if x.value_reference != v.vr {
            errs.push(format!(
                "{}: valueReference {} in XML, {} in code",
                v.name, x.value_reference, v.vr
            ));
        }
        if x.ty != v.ty {
            errs.push(format!(
                "{}: type {} in XML, {:?} in code",
                v.name,
                x.ty.name(),
                v.ty
            ));
        }
        if x.causality != v.causality {
            errs.push(format!(
                "{}: causality {} in XML, {:?} in code",
                v.name,
                x.causality.name(),
                v.causality
            ));
        }
        if x.variability != v.variability {
            errs.push(format!(
                "{}: variability {} in XML, {:?} in code",
                v.name,
                x.variability.name(),
                v.variability
            ));
        }
        match (&v.start, &x.start) {
            (None, None) => {}
            (Some(s), Some(xs)) if start_matches(s, xs) => {}
            (s, xs) => errs.push(format!(
                "{}: start {:?} in XML, {:?} in code",
                v.name, xs, s
            )),
        }
        let unit = x.unit.as_deref().unwrap_or("");
        if unit != v.unit {
            errs.push(format!(
                "{}: unit {:?} in XML, {:?} in code",
                v.name, unit, v.unit
            ));
        }
        if x.description.is_empty() {
            errs.push(format!("{}: no description in XML", v.name));
        }
    }
    for x in &md.variables {
        if !variables.iter().any(|v| v.name == x.name) {
            errs.push(format!(
                "variable {} of the XML is unknown to the code",
                x.name
            ));
        }
    }
    if errs.is_empty() {
        Ok(md)
    } else {
        Err(errs)
    }
}

/// Check that a freshly instantiated model reports the XML/table start values
/// of its Real variables (masters that never set start values rely on it).
pub fn check_start_values<M: CoSimModel>(model: &M) -> Vec<String> {
    M::VARIABLES
        .iter()
        .filter_map(|v| match v.start {
            Some(Start::Real(s)) if v.ty == VarType::Real => {
                let got = model.get_real(v.vr);
                (got != s).then(|| format!("{}: start {s} declared, model has {got}", v.name))
            }
            Some(Start::Boolean(b)) => match model.get_boolean(v.vr) {
                Ok(got) if got == b => None,
                other => Some(format!(
                    "{}: start {b} declared, model has {other:?}",
                    v.name
                )),
            },
            Some(Start::Integer(i)) => match model.get_integer(v.vr) {
                Ok(got) if got == i => None,
                other => Some(format!(
                    "{}: start {i} declared, model has {other:?}",
                    v.name
                )),
            },
            _ => None,
        })
        .collect()
}
