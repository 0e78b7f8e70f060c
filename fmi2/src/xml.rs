//! Keeps modelDescription.xml and the code from drifting apart: parse the XML
//! (quick-xml) and compare every `<ScalarVariable>` with the model's
//! [`Variable`] table, the GUID and `modelIdentifier`, and the
//! `<ModelStructure>` outputs with the output variables.
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::model::{Causality, CoSimModel, Start, VarType, Variability, Variable};

/// One `<ScalarVariable>` as written in the XML.
#[derive(Debug, Clone, PartialEq)]
pub struct XmlVariable {
    /// 1-based position in `<ModelVariables>` (the index ModelStructure uses).
    pub index: usize,
    pub name: String,
    pub vr: u32,
    pub causality: String,
    pub variability: String,
    pub ty: String,
    pub start: Option<String>,
    pub unit: Option<String>,
    pub description: Option<String>,
}

/// One `<Unknown>` of `<ModelStructure>`.
#[derive(Debug, Clone, PartialEq)]
pub struct XmlUnknown {
    pub index: usize,
    /// `None` when the attribute is absent (= depends on everything).
    pub dependencies: Option<Vec<usize>>,
}

/// What the checks need from a modelDescription.xml.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ModelDescription {
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub model_identifier: String,
    pub variables: Vec<XmlVariable>,
    pub outputs: Vec<XmlUnknown>,
    pub initial_unknowns: Vec<XmlUnknown>,
    /// Attributes of `<CoSimulation>` (capability flags).
    pub cosim_flags: Vec<(String, String)>,
}

fn attr(e: &BytesStart<'_>, key: &str) -> Result<Option<String>, String> {
    for a in e.attributes() {
        let a = a.map_err(|err| err.to_string())?;
        if a.key.as_ref() == key.as_bytes() {
            return Ok(Some(
                a.unescape_value()
                    .map_err(|err| err.to_string())?
                    .into_owned(),
            ));
        }
    }
    Ok(None)
}

fn all_attrs(e: &BytesStart<'_>) -> Result<Vec<(String, String)>, String> {
    e.attributes()
        .map(|a| {
            let a = a.map_err(|err| err.to_string())?;
            Ok((
                String::from_utf8_lossy(a.key.as_ref()).into_owned(),
                a.unescape_value()
                    .map_err(|err| err.to_string())?
                    .into_owned(),
            ))
        })
        .collect()
}

fn parse_indices(s: &str) -> Result<Vec<usize>, String> {
    s.split_whitespace()
        .map(|t| {
            t.parse::<usize>()
                .map_err(|e| format!("bad index {t:?}: {e}"))
        })
        .collect()
}

/// Parse the parts of a modelDescription.xml the checks use.
pub fn parse(xml: &str) -> Result<ModelDescription, String> {
    let mut r = Reader::from_str(xml);
    r.config_mut().trim_text(true);
    let mut md = ModelDescription::default();
    let mut in_var: Option<XmlVariable> = None;
    let mut section = String::new();
    loop {
        let ev = r
            .read_event()
            .map_err(|e| format!("XML error at byte {}: {e}", r.buffer_position()))?;
        let (e, is_empty) = match &ev {
            Event::Start(e) => (e.clone(), false),
            Event::Empty(e) => (e.clone(), true),
            Event::End(e) => {
                let name = e.name();
                let n = name.as_ref();
                if n == b"ScalarVariable" {
                    if let Some(v) = in_var.take() {
                        md.variables.push(v);
                    }
                } else if n == b"Outputs" || n == b"InitialUnknowns" || n == b"Derivatives" {
                    section.clear();
                }
                continue;
            }
            Event::Eof => break,
            _ => continue,
        };
        match e.name().as_ref() {
            b"fmiModelDescription" => {
                md.fmi_version = attr(&e, "fmiVersion")?.unwrap_or_default();
                md.model_name = attr(&e, "modelName")?.unwrap_or_default();
                md.guid = attr(&e, "guid")?.unwrap_or_default();
            }
            b"CoSimulation" => {
                md.model_identifier = attr(&e, "modelIdentifier")?.unwrap_or_default();
                md.cosim_flags = all_attrs(&e)?;
            }
            b"ScalarVariable" => {
                let name = attr(&e, "name")?.ok_or("ScalarVariable without name")?;
                let vr = attr(&e, "valueReference")?
                    .ok_or_else(|| format!("{name}: no valueReference"))?
                    .parse::<u32>()
                    .map_err(|err| format!("{name}: bad valueReference: {err}"))?;
                let v = XmlVariable {
                    index: md.variables.len() + 1,
                    name,
                    vr,
                    causality: attr(&e, "causality")?.unwrap_or_else(|| "local".into()),
                    variability: attr(&e, "variability")?.unwrap_or_else(|| "continuous".into()),
                    ty: String::new(),
                    start: None,
                    unit: None,
                    description: attr(&e, "description")?,
                };
                if is_empty {
                    md.variables.push(v);
                } else {
                    in_var = Some(v);
                }
            }
            t @ (b"Real" | b"Integer" | b"Boolean" | b"String" | b"Enumeration") => {
                if let Some(v) = in_var.as_mut() {
                    v.ty = String::from_utf8_lossy(t).into_owned();
                    v.start = attr(&e, "start")?;
                    v.unit = attr(&e, "unit")?;
                }
            }
            b"Outputs" | b"InitialUnknowns" | b"Derivatives" if !is_empty => {
                section = String::from_utf8_lossy(e.name().as_ref()).into_owned();
            }
            b"Unknown" => {
                let index = attr(&e, "index")?
                    .ok_or("Unknown without index")?
                    .parse::<usize>()
                    .map_err(|err| format!("bad Unknown index: {err}"))?;
                let dependencies = attr(&e, "dependencies")?
                    .map(|s| parse_indices(&s))
                    .transpose()?;
                let u = XmlUnknown {
                    index,
                    dependencies,
                };
                match section.as_str() {
                    "Outputs" => md.outputs.push(u),
                    "InitialUnknowns" => md.initial_unknowns.push(u),
                    _ => {}
                }
            }
            _ => {}
        }
    }
    Ok(md)
}

fn causality_name(c: Causality) -> &'static str {
    match c {
        Causality::Parameter => "parameter",
        Causality::CalculatedParameter => "calculatedParameter",
        Causality::Input => "input",
        Causality::Output => "output",
        Causality::Local => "local",
        Causality::Independent => "independent",
    }
}

fn variability_name(v: Variability) -> &'static str {
    match v {
        Variability::Constant => "constant",
        Variability::Fixed => "fixed",
        Variability::Tunable => "tunable",
        Variability::Discrete => "discrete",
        Variability::Continuous => "continuous",
    }
}

fn type_name(t: VarType) -> &'static str {
    match t {
        VarType::Real => "Real",
        VarType::Integer => "Integer",
        VarType::Boolean => "Boolean",
        VarType::String => "String",
    }
}

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
/// mismatch is reported (empty list = agreement). Also checks that
/// `<ModelStructure><Outputs>` lists exactly the output variables, in order.
pub fn check_model_description(
    xml: &str,
    model_identifier: &str,
    guid: &str,
    variables: &[Variable],
) -> Result<ModelDescription, Vec<String>> {
    let md = parse(xml).map_err(|e| vec![e])?;
    let mut errs = Vec::new();
    if md.fmi_version != "2.0" {
        errs.push(format!("fmiVersion {:?}, expected \"2.0\"", md.fmi_version));
    }
    if md.guid != guid {
        errs.push(format!("guid {:?} in XML, {:?} in code", md.guid, guid));
    }
    if md.model_identifier != model_identifier {
        errs.push(format!(
            "modelIdentifier {:?} in XML, {:?} in code",
            md.model_identifier, model_identifier
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
        if x.vr != v.vr {
            errs.push(format!(
                "{}: valueReference {} in XML, {} in code",
                v.name, x.vr, v.vr
            ));
        }
        if x.ty != type_name(v.ty) {
            errs.push(format!(
                "{}: type {} in XML, {:?} in code",
                v.name, x.ty, v.ty
            ));
        }
        if x.causality != causality_name(v.causality) {
            errs.push(format!(
                "{}: causality {} in XML, {:?} in code",
                v.name, x.causality, v.causality
            ));
        }
        if x.variability != variability_name(v.variability) {
            errs.push(format!(
                "{}: variability {} in XML, {:?} in code",
                v.name, x.variability, v.variability
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
        if x.description.as_deref().unwrap_or("").is_empty() {
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
        if md
            .variables
            .iter()
            .filter(|y| y.vr == x.vr && y.ty == x.ty)
            .count()
            > 1
        {
            errs.push(format!("valueReference {} used twice for {}", x.vr, x.ty));
        }
    }
    let outputs: Vec<usize> = md
        .variables
        .iter()
        .filter(|x| x.causality == "output")
        .map(|x| x.index)
        .collect();
    let listed: Vec<usize> = md.outputs.iter().map(|u| u.index).collect();
    if outputs != listed {
        errs.push(format!(
            "ModelStructure/Outputs lists {listed:?}, output variables are {outputs:?}"
        ));
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
