//! SSP 1.0 export: the coupled system as a `.ssp` archive
//! (`SystemStructure.ssd` + the FMUs under `resources/`), so that other tools
//! (fmpy, OMSimulator, ...) can run the same co-simulation.
//!
//! The `.ssd` declares one `Component` per FMU with a `Connector` for every
//! input and output (and every bound parameter), the connections, the
//! parameter values inline (`ssv:ParameterSet` in a `ParameterBinding`) and
//! the `DefaultExperiment`. Start values of connected inputs are the FMUs'
//! own; SSP runners that start connectors at 0 (fmpy) see the same values as
//! long as the FMUs' input start values are 0, which holds for this
//! repository's FMUs.
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

use quick_xml::escape::escape;

use crate::import::{Causality, FmuError, ModelDescription, VarType};
use crate::master::ParamValue;

#[derive(Debug, thiserror::Error)]
pub enum SspError {
    #[error(transparent)]
    Fmu(#[from] FmuError),
    #[error(transparent)]
    Archive(#[from] fmi2::ZipWriteError),
    #[error("'{0}': expected 'unit.variable' with a unit of the system")]
    BadEndpoint(String),
    #[error("unit name '{0}' repeats or is empty")]
    BadUnit(String),
}

/// Read `modelDescription.xml` of a `.fmu` without unpacking the rest.
pub fn read_model_description(fmu: &Path) -> Result<ModelDescription, FmuError> {
    let f = File::open(fmu).map_err(|source| FmuError::Open {
        path: fmu.into(),
        source,
    })?;
    let mut z = zip::ZipArchive::new(f).map_err(|source| FmuError::Zip {
        path: fmu.into(),
        source,
    })?;
    let mut e = z
        .by_name("modelDescription.xml")
        .map_err(|_| FmuError::NoModelDescription { path: fmu.into() })?;
    let mut text = String::new();
    e.read_to_string(&mut text)
        .map_err(|source| FmuError::Open {
            path: fmu.into(),
            source,
        })?;
    Ok(ModelDescription::parse(&text)?)
}

fn type_element(t: VarType) -> &'static str {
    match t {
        VarType::Real => "ssc:Real",
        VarType::Integer => "ssc:Integer",
        VarType::Boolean => "ssc:Boolean",
        VarType::String => "ssc:String",
        VarType::Enumeration => "ssc:Integer",
    }
}

fn value_element(v: &ParamValue) -> String {
    match v {
        ParamValue::Real(x) => format!("<ssv:Real value=\"{x:e}\"/>"),
        ParamValue::Integer(x) => format!("<ssv:Integer value=\"{x}\"/>"),
        ParamValue::Boolean(x) => format!("<ssv:Boolean value=\"{x}\"/>"),
        ParamValue::String(x) => format!("<ssv:String value=\"{}\"/>", escape(x.as_str())),
    }
}

/// The `SystemStructure.ssd` text.
pub fn system_structure(
    name: &str,
    units: &[(String, ModelDescription)],
    connections: &[(String, String)],
    parameters: &[(String, ParamValue)],
    stop_time_s: f64,
) -> Result<String, SspError> {
    for (i, (u, _)) in units.iter().enumerate() {
        if u.is_empty() || units[..i].iter().any(|(o, _)| o == u) {
            return Err(SspError::BadUnit(u.clone()));
        }
    }
    let split = |ep: &str| -> Result<(usize, String), SspError> {
        let (u, v) = ep
            .split_once('.')
            .ok_or_else(|| SspError::BadEndpoint(ep.into()))?;
        let ui = units
            .iter()
            .position(|(n, _)| n == u)
            .ok_or_else(|| SspError::BadEndpoint(ep.into()))?;
        units[ui].1.variable(v).map_err(FmuError::from)?;
        Ok((ui, v.to_string()))
    };
    let mut s = String::new();
    s.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    s.push_str(&format!(
        "<ssd:SystemStructureDescription xmlns:ssc=\"http://ssp-standard.org/SSP1/SystemStructureCommon\" \
         xmlns:ssd=\"http://ssp-standard.org/SSP1/SystemStructureDescription\" \
         xmlns:ssv=\"http://ssp-standard.org/SSP1/SystemStructureParameterValues\" version=\"1.0\" name=\"{}\">\n",
        escape(name)
    ));
    s.push_str("  <ssd:System name=\"root\">\n    <ssd:Elements>\n");
    for (ui, (u, md)) in units.iter().enumerate() {
        s.push_str(&format!(
            "      <ssd:Component name=\"{}\" type=\"application/x-fmu-sharedlibrary\" source=\"resources/{}.fmu\">\n        <ssd:Connectors>\n",
            escape(u.as_str()),
            escape(u.as_str())
        ));
        let mut params: Vec<(String, &ParamValue)> = Vec::new();
        for (ep, v) in parameters {
            let (pu, var) = split(ep)?;
            if pu == ui {
                params.push((var, v));
            }
        }
        for var in &md.variables {
            let kind = match var.causality {
                Causality::Input => "input",
                Causality::Output => "output",
                Causality::Parameter if params.iter().any(|(n, _)| n == &var.name) => "parameter",
                _ => continue,
            };
            s.push_str(&format!(
                "          <ssd:Connector name=\"{}\" kind=\"{kind}\"><{}/></ssd:Connector>\n",
                escape(var.name.as_str()),
                type_element(var.ty)
            ));
        }
        s.push_str("        </ssd:Connectors>\n");
        if !params.is_empty() {
            s.push_str(
                "        <ssd:ParameterBindings>\n          <ssd:ParameterBinding>\n            <ssd:ParameterValues>\n",
            );
            s.push_str(&format!(
                "              <ssv:ParameterSet version=\"1.0\" name=\"{}\">\n                <ssv:Parameters>\n",
                escape(u.as_str())
            ));
            for (n, v) in &params {
                s.push_str(&format!(
                    "                  <ssv:Parameter name=\"{}\">{}</ssv:Parameter>\n",
                    escape(n.as_str()),
                    value_element(v)
                ));
            }
            s.push_str("                </ssv:Parameters>\n              </ssv:ParameterSet>\n            </ssd:ParameterValues>\n          </ssd:ParameterBinding>\n        </ssd:ParameterBindings>\n");
        }
        s.push_str("      </ssd:Component>\n");
    }
    s.push_str("    </ssd:Elements>\n    <ssd:Connections>\n");
    for (from, to) in connections {
        let (a, av) = split(from)?;
        let (b, bv) = split(to)?;
        s.push_str(&format!(
            "      <ssd:Connection startElement=\"{}\" startConnector=\"{}\" endElement=\"{}\" endConnector=\"{}\"/>\n",
            escape(units[a].0.as_str()),
            escape(av.as_str()),
            escape(units[b].0.as_str()),
            escape(bv.as_str())
        ));
    }
    s.push_str("    </ssd:Connections>\n  </ssd:System>\n");
    s.push_str(&format!(
        "  <ssd:DefaultExperiment startTime=\"0\" stopTime=\"{stop_time_s:e}\"/>\n"
    ));
    s.push_str("</ssd:SystemStructureDescription>\n");
    Ok(s)
}

/// Write `out` (`.ssp`): `SystemStructure.ssd` and `resources/<unit>.fmu`.
pub fn write_ssp(
    out: &Path,
    name: &str,
    units: &[(String, PathBuf)],
    connections: &[(String, String)],
    parameters: &[(String, ParamValue)],
    stop_time_s: f64,
) -> Result<(), SspError> {
    let mut mds = Vec::new();
    for (u, p) in units {
        mds.push((u.clone(), read_model_description(p)?));
    }
    let ssd = system_structure(name, &mds, connections, parameters, stop_time_s)?;
    let mut entries = vec![("SystemStructure.ssd".to_string(), ssd.into_bytes())];
    for (u, p) in units {
        let bytes = std::fs::read(p).map_err(|source| {
            SspError::Fmu(FmuError::Open {
                path: p.clone(),
                source,
            })
        })?;
        entries.push((format!("resources/{u}.fmu"), bytes));
    }
    Ok(fmi2::write_zip(out, &entries)?)
}
