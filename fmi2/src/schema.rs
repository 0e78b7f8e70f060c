//! The one typed modelDescription.xml schema of FMI 2.0 Co-Simulation, used
//! by the export side (the XML/code drift check of `fmi2-export`) and by the
//! importer (`fmi2-import`).
//!
//! [`ModelDescription::parse`] reads the file in one pass (quick-xml, line
//! numbers counted incrementally, so linear in the size of the file) and
//! fails on what makes the file unusable (malformed XML, missing or invalid
//! attributes, a version other than 2.0, no `<CoSimulation>`), with the line.
//! [`ModelDescription::validate`] lists the violations of the standard's
//! rules that a parsed file can still have, like fmpy's `validate`.
use quick_xml::events::{BytesStart, Event};

/// Type of a scalar variable (the child element of `<ScalarVariable>`). The
/// export layer never declares `Enumeration`; the importer reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
    Enumeration,
}

impl VarType {
    /// The element name (`Real`, ...).
    pub fn name(self) -> &'static str {
        match self {
            VarType::Real => "Real",
            VarType::Integer => "Integer",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
            VarType::Enumeration => "Enumeration",
        }
    }
}

/// `causality` attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
    Independent,
}

impl Causality {
    /// The attribute value (`parameter`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Local => "local",
            Causality::Independent => "independent",
        }
    }

    pub(crate) fn from_name(s: &str) -> Option<Self> {
        Some(match s {
            "parameter" => Causality::Parameter,
            "calculatedParameter" => Causality::CalculatedParameter,
            "input" => Causality::Input,
            "output" => Causality::Output,
            "local" => Causality::Local,
            "independent" => Causality::Independent,
            _ => return None,
        })
    }
}

/// Compares with the attribute value as written in the XML.
impl PartialEq<&str> for Causality {
    fn eq(&self, other: &&str) -> bool {
        self.name() == *other
    }
}

/// `variability` attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    Continuous,
}

impl Variability {
    /// The attribute value (`fixed`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Variability::Constant => "constant",
            Variability::Fixed => "fixed",
            Variability::Tunable => "tunable",
            Variability::Discrete => "discrete",
            Variability::Continuous => "continuous",
        }
    }

    pub(crate) fn from_name(s: &str) -> Option<Self> {
        Some(match s {
            "constant" => Variability::Constant,
            "fixed" => Variability::Fixed,
            "tunable" => Variability::Tunable,
            "discrete" => Variability::Discrete,
            "continuous" => Variability::Continuous,
            _ => return None,
        })
    }
}

/// Compares with the attribute value as written in the XML.
impl PartialEq<&str> for Variability {
    fn eq(&self, other: &&str) -> bool {
        self.name() == *other
    }
}

/// Why a modelDescription.xml cannot be used, or a variable looked up by
/// name is not there / not of the kind asked for.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SchemaError {
    #[error("modelDescription.xml line {line}: {message}")]
    Xml { line: usize, message: String },
    #[error(
        "modelDescription.xml: fmiVersion is \"{found}\", but this host imports FMI 2.0 and 3.0"
    )]
    Version { found: String },
    #[error("modelDescription.xml of '{model}': no <CoSimulation> element (Model Exchange only?); the host needs FMI 2.0 Co-Simulation")]
    NoCoSimulation { model: String },
    #[error("FMU '{model}' has no variable named '{name}'")]
    UnknownVariable { model: String, name: String },
    #[error("FMU '{model}': variable '{name}' is {found}, expected {expected}")]
    WrongVariable {
        model: String,
        name: String,
        found: String,
        expected: &'static str,
    },
}

type Result<T, E = SchemaError> = std::result::Result<T, E>;

/// One `<ScalarVariable>`.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalarVariable {
    /// 1-based position in `<ModelVariables>` (the index `<ModelStructure>` uses).
    pub index: usize,
    pub name: String,
    pub value_reference: u32,
    pub description: String,
    pub causality: Causality,
    pub variability: Variability,
    pub ty: VarType,
    /// The `start` attribute, unparsed (its meaning depends on `ty`).
    pub start: Option<String>,
    pub unit: Option<String>,
    /// The `derivative` attribute of `<Real>`: 1-based index of the state
    /// this variable is the time derivative of (Model Exchange).
    pub derivative: Option<usize>,
    /// Line of the `<ScalarVariable>` element in modelDescription.xml.
    pub line: usize,
}

/// An FMI 3.0 variable outside [`ModelDescription::variables`].
#[derive(Debug, Clone, PartialEq)]
pub struct OtherVariable {
    pub name: String,
    pub value_reference: u32,
    /// The element (`Float32`, `UInt64`, `Binary`, `Clock`, ...).
    pub element: String,
    /// Whether it has `<Dimension>` children (an array).
    pub array: bool,
    pub causality: Causality,
    pub line: usize,
}

/// The `<CoSimulation>` capabilities.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CoSimCapabilities {
    pub model_identifier: String,
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
    pub needs_execution_tool: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    /// FMI 3.0 `providesIntermediateUpdate` (false in FMI 2.0).
    pub provides_intermediate_update: bool,
    /// FMI 3.0 `mightReturnEarlyFromDoStep` (false in FMI 2.0).
    pub might_return_early_from_do_step: bool,
    /// FMI 3.0 `hasEventMode` (false in FMI 2.0).
    pub has_event_mode: bool,
}

/// The `<ModelExchange>` capabilities (present when the FMU also provides
/// Model Exchange; the host itself only co-simulates).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModelExchangeCapabilities {
    pub model_identifier: String,
    pub completed_integrator_step_not_needed: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
}

/// `<DefaultExperiment>`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DefaultExperiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    pub step_size: Option<f64>,
}

/// An `<Unknown>` of `<ModelStructure>` (`<Outputs>`, `<Derivatives>` or
/// `<InitialUnknowns>`): 1-based variable indices as in the XML.
#[derive(Debug, Clone, PartialEq)]
pub struct Unknown {
    pub index: usize,
    /// `None` when the attribute is absent (= may depend on everything).
    pub dependencies: Option<Vec<usize>>,
    pub line: usize,
}

/// The parsed `modelDescription.xml`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModelDescription {
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: String,
    pub generation_tool: String,
    pub co_simulation: CoSimCapabilities,
    /// Every attribute of `<CoSimulation>` as written (capability flags).
    pub cosim_flags: Vec<(String, String)>,
    /// `<ModelExchange>`, if the FMU declares it.
    pub model_exchange: Option<ModelExchangeCapabilities>,
    /// `numberOfEventIndicators` of the root element (0 when absent).
    pub number_of_event_indicators: usize,
    pub default_experiment: DefaultExperiment,
    /// The scalar variables of the types a master exchanges (FMI 3.0:
    /// `Float64` as `Real`, `Int32` as `Integer`, `Boolean`, `String`,
    /// `Enumeration`), in the file's order.
    pub variables: Vec<ScalarVariable>,
    /// FMI 3.0 variables of other types or with dimensions (arrays), which
    /// this importer does not exchange: named so that a connection to one is
    /// refused with what it is. Empty for FMI 2.0.
    pub other_variables: Vec<OtherVariable>,
    pub outputs: Vec<Unknown>,
    pub derivatives: Vec<Unknown>,
    pub initial_unknowns: Vec<Unknown>,
}

/// One violation found by [`ModelDescription::validate`].
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// Line in modelDescription.xml, where known.
    pub line: Option<usize>,
    pub message: String,
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.line {
            Some(l) => write!(f, "line {l}: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

/// Byte offset -> line number, advanced monotonically (the parser reads
/// forward), so that all line numbers together cost one pass over the text.
pub(crate) struct Lines<'a> {
    text: &'a [u8],
    pos: usize,
    line: usize,
}

impl Lines<'_> {
    pub(crate) fn new(text: &str) -> Lines<'_> {
        Lines {
            text: text.as_bytes(),
            pos: 0,
            line: 1,
        }
    }

    pub(crate) fn at(&mut self, pos: usize) -> usize {
        let end = pos.min(self.text.len());
        if end < self.pos {
            // never happens for forward reading; stay correct anyway
            self.pos = 0;
            self.line = 1;
        }
        self.line += self.text[self.pos..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        self.pos = end;
        self.line
    }
}

pub(crate) fn parse_bool(v: &str, attr: &str, line: usize) -> Result<bool> {
    match v {
        "true" | "1" => Ok(true),
        "false" | "0" => Ok(false),
        _ => Err(SchemaError::Xml {
            line,
            message: format!("attribute {attr}=\"{v}\": expected true or false"),
        }),
    }
}

pub(crate) fn parse_num<T: std::str::FromStr>(
    v: &str,
    attr: &str,
    line: usize,
    what: &str,
) -> Result<T> {
    v.trim().parse::<T>().map_err(|_| SchemaError::Xml {
        line,
        message: format!("attribute {attr}=\"{v}\": expected {what}"),
    })
}

/// Attributes of an element as (name, unescaped value).
pub(crate) fn attrs(e: &BytesStart<'_>, line: usize) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|err| SchemaError::Xml {
            line,
            message: format!("malformed attribute: {err}"),
        })?;
        let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let val = a
            .unescape_value()
            .map_err(|err| SchemaError::Xml {
                line,
                message: format!("attribute {key}: {err}"),
            })?
            .into_owned();
        out.push((key, val));
    }
    Ok(out)
}

pub(crate) fn get<'a>(a: &'a [(String, String)], k: &str) -> Option<&'a str> {
    a.iter().find(|(n, _)| n == k).map(|(_, v)| v.as_str())
}

/// A `<ScalarVariable>` being read: its attributes, line, and type element (type, attributes).
type PendingVariable = (
    Vec<(String, String)>,
    usize,
    Option<(VarType, Vec<(String, String)>)>,
);

/// Which `<ModelStructure>` list an `<Unknown>` belongs to.
#[derive(Clone, Copy, PartialEq)]
enum Section {
    Outputs,
    Derivatives,
    InitialUnknowns,
}

/// The type of a `<ScalarVariable>`'s type element (`Real`, ...).
fn type_element(name: &str) -> Option<VarType> {
    Some(match name {
        "Real" => VarType::Real,
        "Integer" => VarType::Integer,
        "Boolean" => VarType::Boolean,
        "String" => VarType::String,
        "Enumeration" => VarType::Enumeration,
        _ => return None,
    })
}

/// The attributes of `<DefaultExperiment>`.
pub(crate) fn default_experiment(a: &[(String, String)], line: usize) -> Result<DefaultExperiment> {
    let f = |k: &str| -> Result<Option<f64>> {
        get(a, k)
            .map(|v| parse_num::<f64>(v, k, line, "a number"))
            .transpose()
    };
    Ok(DefaultExperiment {
        start_time: f("startTime")?,
        stop_time: f("stopTime")?,
        tolerance: f("tolerance")?,
        step_size: f("stepSize")?,
    })
}

/// One element event of [`walk`].
pub(crate) enum Walk<'a> {
    /// A start or empty element: its parent's local name (`""` at the root),
    /// its local name, its attributes and line.
    Start {
        parent: &'a str,
        name: &'a str,
        attrs: Vec<(String, String)>,
        line: usize,
        empty: bool,
    },
    /// The end of a (non-empty) element.
    End { name: &'a str, line: usize },
}

/// The `fmiVersion` of the root element, if the file starts with one (the
/// parser of that version then reads the whole file).
fn root_version(text: &str) -> Option<String> {
    let mut reader = quick_xml::Reader::from_str(text);
    loop {
        match reader.read_event() {
            Ok(Event::Start(e)) | Ok(Event::Empty(e)) => {
                let a = attrs(&e, 0).ok()?;
                return get(&a, "fmiVersion").map(|v| v.trim().to_string());
            }
            Ok(Event::Eof) | Err(_) => return None,
            _ => {}
        }
    }
}

/// Read `text` in one pass (quick-xml, line numbers counted incrementally)
/// and hand every element start and end to `visit`; malformed XML, a root
/// other than `<fmiModelDescription>` and a file that ends inside an element
/// are [`SchemaError::Xml`] with the line. Shared by the FMI 2.0 and FMI 3.0
/// readers.
pub(crate) fn walk(text: &str, mut visit: impl FnMut(Walk<'_>) -> Result<()>) -> Result<()> {
    let mut reader = quick_xml::Reader::from_str(text);
    reader.config_mut().trim_text(true);
    let mut lines = Lines::new(text);
    let mut stack: Vec<String> = Vec::new();
    loop {
        let pos = reader.buffer_position() as usize;
        let ev = match reader.read_event() {
            Ok(ev) => ev,
            Err(e) => {
                let at = (reader.error_position() as usize).max(pos);
                return Err(SchemaError::Xml {
                    line: lines.at(at),
                    message: e.to_string(),
                });
            }
        };
        // The event starts at the first non-blank byte after `pos`.
        let start = pos
            + text.as_bytes()[pos.min(text.len())..]
                .iter()
                .take_while(|b| b.is_ascii_whitespace())
                .count();
        let line = lines.at(start);
        let (e, empty) = match &ev {
            Event::Start(e) => (e.clone(), false),
            Event::Empty(e) => (e.clone(), true),
            Event::End(_) => {
                let name = stack.pop().unwrap_or_default();
                visit(Walk::End { name: &name, line })?;
                continue;
            }
            Event::Eof => break,
            _ => continue,
        };
        let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
        let a = attrs(&e, line)?;
        let parent = stack.last().map(String::as_str).unwrap_or("");
        if parent.is_empty() && name != "fmiModelDescription" {
            return Err(SchemaError::Xml {
                line,
                message: format!("root element is <{name}>, expected <fmiModelDescription>"),
            });
        }
        visit(Walk::Start {
            parent,
            name: &name,
            attrs: a,
            line,
            empty,
        })?;
        if !empty {
            stack.push(name);
        }
    }
    if let Some(open) = stack.last() {
        // quick-xml accepts a document that ends inside an element
        return Err(SchemaError::Xml {
            line: lines.at(text.len()),
            message: format!("end of file inside <{open}>: the element is not closed"),
        });
    }
    Ok(())
}

impl ModelDescription {
    /// Parse the text of a `modelDescription.xml` of FMI 2.0 or FMI 3.0 (the
    /// latter read by [`crate::schema3`] into the same types). Malformed XML
    /// and invalid attributes are [`SchemaError::Xml`] with the line; another
    /// version is [`SchemaError::Version`]; a missing `<CoSimulation>` is
    /// [`SchemaError::NoCoSimulation`].
    pub fn parse(text: &str) -> Result<Self> {
        if root_version(text).is_some_and(|v| v.starts_with("3.")) {
            return crate::schema3::parse(text);
        }
        let mut md = ModelDescription::default();
        let mut has_root = false;
        let mut has_cs = false;
        let mut current: Option<PendingVariable> = None;
        let mut names = std::collections::HashSet::new();
        walk(text, |ev| {
            let (parent, name, a, line, empty) = match ev {
                Walk::End { name, line } => {
                    if name == "ScalarVariable" {
                        md.finish_variable(current.take(), line, &mut names)?;
                    }
                    return Ok(());
                }
                Walk::Start {
                    parent,
                    name,
                    attrs: a,
                    line,
                    empty,
                } => (parent, name, a, line, empty),
            };
            match (parent, name) {
                ("", "fmiModelDescription") => {
                    has_root = true;
                    md.root(&a, line)?;
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
                ("ModelVariables", "ScalarVariable") => {
                    current = Some((a, line, None));
                    if empty {
                        md.finish_variable(current.take(), line, &mut names)?;
                    }
                }
                ("ScalarVariable", t) if type_element(t).is_some() => {
                    let ty = type_element(t).expect("a type element");
                    let cur = current.as_mut().expect("inside ScalarVariable");
                    if cur.2.is_some() {
                        return Err(SchemaError::Xml {
                            line,
                            message: "ScalarVariable has more than one type element".into(),
                        });
                    }
                    cur.2 = Some((ty, a));
                }
                (s @ ("Outputs" | "Derivatives" | "InitialUnknowns"), "Unknown") => {
                    let section = match s {
                        "Outputs" => Section::Outputs,
                        "Derivatives" => Section::Derivatives,
                        _ => Section::InitialUnknowns,
                    };
                    md.unknown(section, &a, line)?;
                }
                _ => {}
            }
            Ok(())
        })?;
        if !has_root {
            return Err(SchemaError::Xml {
                line: 1,
                message: "no <fmiModelDescription> element".into(),
            });
        }
        if !has_cs {
            return Err(SchemaError::NoCoSimulation {
                model: md.model_name,
            });
        }
        Ok(md)
    }

    /// The attributes of `<fmiModelDescription>` (version 2.0 only, a guid).
    fn root(&mut self, a: &[(String, String)], line: usize) -> Result<()> {
        self.fmi_version = get(a, "fmiVersion").unwrap_or("").to_string();
        if self.fmi_version != "2.0" {
            return Err(SchemaError::Version {
                found: self.fmi_version.clone(),
            });
        }
        self.model_name = get(a, "modelName").unwrap_or("").to_string();
        self.guid = get(a, "guid")
            .ok_or_else(|| SchemaError::Xml {
                line,
                message: "fmiModelDescription has no guid attribute".into(),
            })?
            .to_string();
        self.description = get(a, "description").unwrap_or("").to_string();
        self.generation_tool = get(a, "generationTool").unwrap_or("").to_string();
        self.number_of_event_indicators = get(a, "numberOfEventIndicators")
            .map(|v| parse_num(v, "numberOfEventIndicators", line, "an unsigned integer"))
            .transpose()?
            .unwrap_or(0);
        Ok(())
    }

    fn unknown(&mut self, section: Section, a: &[(String, String)], line: usize) -> Result<()> {
        let index: usize = parse_num(
            get(a, "index").ok_or_else(|| SchemaError::Xml {
                line,
                message: "<Unknown> has no index".into(),
            })?,
            "index",
            line,
            "a positive integer",
        )?;
        let dependencies = match get(a, "dependencies") {
            None => None,
            Some(d) => Some(
                d.split_whitespace()
                    .map(|s| parse_num::<usize>(s, "dependencies", line, "positive integers"))
                    .collect::<Result<Vec<_>>>()?,
            ),
        };
        let n = self.variables.len();
        for i in std::iter::once(index).chain(dependencies.iter().flatten().copied()) {
            if i == 0 || i > n {
                return Err(SchemaError::Xml {
                    line,
                    message: format!("index {i} outside 1..={n} (the ScalarVariables)"),
                });
            }
        }
        let u = Unknown {
            index,
            dependencies,
            line,
        };
        match section {
            Section::Outputs => self.outputs.push(u),
            Section::Derivatives => self.derivatives.push(u),
            Section::InitialUnknowns => self.initial_unknowns.push(u),
        }
        Ok(())
    }

    fn finish_variable(
        &mut self,
        cur: Option<PendingVariable>,
        end_line: usize,
        names: &mut std::collections::HashSet<String>,
    ) -> Result<()> {
        let Some((a, line, ty)) = cur else {
            return Ok(());
        };
        let name = get(&a, "name").ok_or_else(|| SchemaError::Xml {
            line,
            message: "ScalarVariable has no name".into(),
        })?;
        let vr: u32 = parse_num(
            get(&a, "valueReference").ok_or_else(|| SchemaError::Xml {
                line,
                message: format!("ScalarVariable '{name}' has no valueReference"),
            })?,
            "valueReference",
            line,
            "an unsigned 32-bit integer",
        )?;
        let (ty, ta) = ty.ok_or_else(|| SchemaError::Xml {
            line: end_line,
            message: format!("ScalarVariable '{name}' has no type element (Real, Integer, Boolean, String, Enumeration)"),
        })?;
        let c = get(&a, "causality").unwrap_or("local");
        let causality = Causality::from_name(c).ok_or_else(|| SchemaError::Xml {
            line,
            message: format!("ScalarVariable '{name}': unknown causality \"{c}\""),
        })?;
        let v = get(&a, "variability").unwrap_or("continuous");
        let variability = Variability::from_name(v).ok_or_else(|| SchemaError::Xml {
            line,
            message: format!("ScalarVariable '{name}': unknown variability \"{v}\""),
        })?;
        if !names.insert(name.to_string()) {
            return Err(SchemaError::Xml {
                line,
                message: format!("ScalarVariable name '{name}' repeats"),
            });
        }
        self.variables.push(ScalarVariable {
            index: self.variables.len() + 1,
            name: name.to_string(),
            value_reference: vr,
            description: get(&a, "description").unwrap_or("").to_string(),
            causality,
            variability,
            ty,
            start: get(&ta, "start").map(str::to_string),
            unit: get(&ta, "unit").map(str::to_string),
            derivative: get(&ta, "derivative")
                .map(|d| parse_num::<usize>(d, "derivative", line, "a positive integer"))
                .transpose()?,
            line,
        });
        Ok(())
    }

    /// The variable called `name`.
    pub fn variable(&self, name: &str) -> Result<&ScalarVariable> {
        if let Some(o) = self.other_variables.iter().find(|v| v.name == name) {
            return Err(SchemaError::WrongVariable {
                model: self.model_name.clone(),
                name: name.into(),
                found: format!(
                    "{}{} (line {})",
                    o.element,
                    if o.array { " array" } else { "" },
                    o.line
                ),
                expected: "a scalar Float64, Int32, Boolean or String",
            });
        }
        self.variables
            .iter()
            .find(|v| v.name == name)
            .ok_or_else(|| SchemaError::UnknownVariable {
                model: self.model_name.clone(),
                name: name.into(),
            })
    }

    /// Value reference of the Real variable `name` whose causality is one of `allowed`.
    pub fn real_vr(&self, name: &str, allowed: &[Causality]) -> Result<u32> {
        let v = self.variable(name)?;
        if v.ty != VarType::Real || !allowed.contains(&v.causality) {
            return Err(SchemaError::WrongVariable {
                model: self.model_name.clone(),
                name: name.into(),
                found: format!("{:?} {:?}", v.causality, v.ty),
                expected: "a Real of the required causality",
            });
        }
        Ok(v.value_reference)
    }

    /// Whether output `output` (0-based position in [`Self::variables`])
    /// depends directly on variable `input` (0-based). Without
    /// `<ModelStructure>` information every output may depend on every input.
    pub fn output_depends_on(&self, output: usize, input: usize) -> bool {
        match self.outputs.iter().find(|o| o.index == output + 1) {
            None => true,
            Some(o) => match &o.dependencies {
                None => true,
                Some(d) => d.contains(&(input + 1)),
            },
        }
    }

    /// The standard's rules a parsed file can still break, each with the line
    /// where known (empty: valid). Checked: unique value references per type,
    /// `<ModelStructure><Outputs>` listing exactly the output variables in
    /// order, start values present where required (inputs, parameters,
    /// constants) and forbidden where FMI 2.0 forbids them (calculated
    /// parameters, independent), start values parseable for their type,
    /// causality/variability combinations (parameters fixed or tunable,
    /// constants only outputs or locals).
    /// Variables sharing a (type, value reference) with an earlier one, each
    /// with its line: a master addresses variables by them, so such an FMU
    /// would record or set the wrong signal (the importer refuses it).
    pub fn duplicate_value_references(&self) -> Vec<Problem> {
        let mut seen: std::collections::HashMap<(u32, &'static str), &str> =
            std::collections::HashMap::with_capacity(self.variables.len());
        let mut p = Vec::new();
        for v in &self.variables {
            if let Some(first) = seen.insert((v.value_reference, v.ty.name()), &v.name) {
                p.push(Problem {
                    line: Some(v.line),
                    message: format!(
                        "valueReference {} used twice for {} ({first} and {})",
                        v.value_reference,
                        v.ty.name(),
                        v.name
                    ),
                });
            }
        }
        p
    }

    pub fn validate(&self) -> Vec<Problem> {
        let mut p = self.duplicate_value_references();
        let mut push = |line: Option<usize>, message: String| p.push(Problem { line, message });
        for v in &self.variables {
            let l = Some(v.line);
            let needs_start = matches!(v.causality, Causality::Input | Causality::Parameter)
                || v.variability == Variability::Constant;
            let forbids_start = matches!(
                v.causality,
                Causality::CalculatedParameter | Causality::Independent
            );
            match (&v.start, needs_start, forbids_start) {
                (None, true, _) => push(
                    l,
                    format!(
                        "{}: a {} {} variable needs a start value",
                        v.name,
                        v.variability.name(),
                        v.causality.name()
                    ),
                ),
                (Some(_), _, true) => push(
                    l,
                    format!(
                        "{}: a {} variable must not have a start value",
                        v.name,
                        v.causality.name()
                    ),
                ),
                _ => {}
            }
            if let Some(s) = &v.start {
                let ok = match v.ty {
                    VarType::Real => s.trim().parse::<f64>().is_ok(),
                    VarType::Integer | VarType::Enumeration => s.trim().parse::<i32>().is_ok(),
                    VarType::Boolean => matches!(s.trim(), "true" | "false" | "1" | "0"),
                    VarType::String => true,
                };
                if !ok {
                    push(
                        l,
                        format!("{}: start \"{s}\" is not a {}", v.name, v.ty.name()),
                    );
                }
            }
            if matches!(
                v.causality,
                Causality::Parameter | Causality::CalculatedParameter
            ) && !matches!(v.variability, Variability::Fixed | Variability::Tunable)
            {
                push(
                    l,
                    format!(
                        "{}: a {} must be fixed or tunable, not {}",
                        v.name,
                        v.causality.name(),
                        v.variability.name()
                    ),
                );
            }
            if v.variability == Variability::Constant
                && !matches!(v.causality, Causality::Output | Causality::Local)
            {
                push(
                    l,
                    format!(
                        "{}: a constant must be an output or local, not {}",
                        v.name,
                        v.causality.name()
                    ),
                );
            }
        }
        let outputs: Vec<usize> = self
            .variables
            .iter()
            .filter(|v| v.causality == Causality::Output)
            .map(|v| v.index)
            .collect();
        let listed: Vec<usize> = self.outputs.iter().map(|u| u.index).collect();
        if outputs != listed {
            push(
                self.outputs.first().map(|u| u.line),
                format!(
                    "ModelStructure/Outputs lists {listed:?}, output variables are {outputs:?}"
                ),
            );
        }
        // Model Exchange: <Derivatives> lists exactly the variables with a
        // `derivative` attribute, in order, each the derivative of a Real
        let derivs: Vec<usize> = self
            .variables
            .iter()
            .filter(|v| v.derivative.is_some())
            .map(|v| v.index)
            .collect();
        let listed: Vec<usize> = self.derivatives.iter().map(|u| u.index).collect();
        if derivs != listed {
            push(
                self.derivatives.first().map(|u| u.line),
                format!(
                    "ModelStructure/Derivatives lists {listed:?}, variables with a derivative attribute are {derivs:?}"
                ),
            );
        }
        for v in &self.variables {
            if let Some(i) = v.derivative {
                let state = i
                    .checked_sub(1)
                    .and_then(|k| self.variables.get(k))
                    .filter(|s| s.ty == VarType::Real && s.index != v.index);
                if v.ty != VarType::Real || state.is_none() {
                    push(
                        Some(v.line),
                        format!(
                            "{}: derivative=\"{i}\" must name another Real variable (1..={})",
                            v.name,
                            self.variables.len()
                        ),
                    );
                }
            }
        }
        p
    }
}

fn model_exchange(a: &[(String, String)], line: usize) -> Result<ModelExchangeCapabilities> {
    let mut me = ModelExchangeCapabilities {
        model_identifier: get(a, "modelIdentifier")
            .ok_or_else(|| SchemaError::Xml {
                line,
                message: "<ModelExchange> has no modelIdentifier".into(),
            })?
            .to_string(),
        ..Default::default()
    };
    for (k, v) in a {
        match k.as_str() {
            "completedIntegratorStepNotNeeded" => {
                me.completed_integrator_step_not_needed = parse_bool(v, k, line)?
            }
            "canGetAndSetFMUstate" => me.can_get_and_set_fmu_state = parse_bool(v, k, line)?,
            "canSerializeFMUstate" => me.can_serialize_fmu_state = parse_bool(v, k, line)?,
            "providesDirectionalDerivative" => {
                me.provides_directional_derivative = parse_bool(v, k, line)?
            }
            _ => {}
        }
    }
    Ok(me)
}

fn co_simulation(a: &[(String, String)], line: usize) -> Result<CoSimCapabilities> {
    let mut cs = CoSimCapabilities {
        model_identifier: get(a, "modelIdentifier")
            .ok_or_else(|| SchemaError::Xml {
                line,
                message: "<CoSimulation> has no modelIdentifier".into(),
            })?
            .to_string(),
        ..Default::default()
    };
    for (k, v) in a {
        match k.as_str() {
            "canHandleVariableCommunicationStepSize" => {
                cs.can_handle_variable_communication_step_size = parse_bool(v, k, line)?
            }
            "canInterpolateInputs" => cs.can_interpolate_inputs = parse_bool(v, k, line)?,
            "maxOutputDerivativeOrder" => {
                cs.max_output_derivative_order = parse_num(v, k, line, "an unsigned integer")?
            }
            "canGetAndSetFMUstate" => cs.can_get_and_set_fmu_state = parse_bool(v, k, line)?,
            "canSerializeFMUstate" => cs.can_serialize_fmu_state = parse_bool(v, k, line)?,
            "providesDirectionalDerivative" => {
                cs.provides_directional_derivative = parse_bool(v, k, line)?
            }
            "needsExecutionTool" => cs.needs_execution_tool = parse_bool(v, k, line)?,
            "canBeInstantiatedOnlyOncePerProcess" => {
                cs.can_be_instantiated_only_once_per_process = parse_bool(v, k, line)?
            }
            _ => {}
        }
    }
    Ok(cs)
}

#[cfg(test)]
#[path = "schema_tests.rs"]
mod tests;
