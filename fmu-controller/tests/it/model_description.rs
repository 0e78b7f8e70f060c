//! The modelDescription.xml and the code cannot drift: names, value
//! references, types, causality, variability, start values, units and the
//! ModelStructure (checked by perturbation) against `controller::model::VARIABLES`.
use crate::model::fresh;
use controller::model::*;
use fmi2_export::CoSimModel;

const XML: &str = include_str!("../../../modelDescription/controller/modelDescription.xml");

#[test]
fn xml_matches_the_code() {
    let md = fmi2_export::xml::check_model_description(
        XML,
        Controller::MODEL_IDENTIFIER,
        Controller::GUID,
        Controller::VARIABLES,
    )
    .unwrap_or_else(|e| {
        panic!(
            "modelDescription.xml drifted from the code:\n{}",
            e.join("\n")
        )
    });
    let flag = |k: &str| {
        md.cosim_flags
            .iter()
            .find(|(n, _)| n == k)
            .map(|(_, v)| v.as_str())
    };
    assert_eq!(flag("canHandleVariableCommunicationStepSize"), Some("true"));
    assert_eq!(flag("canGetAndSetFMUstate"), Some("true"));
    assert_eq!(flag("canSerializeFMUstate"), Some("true"));
    assert_eq!(flag("maxOutputDerivativeOrder"), Some("1"));
    // every output is listed, with no direct dependency on an input
    let outputs: Vec<usize> = md
        .variables
        .iter()
        .filter(|v| v.causality == "output")
        .map(|v| v.index)
        .collect();
    assert_eq!(
        md.outputs.iter().map(|u| u.index).collect::<Vec<_>>(),
        outputs
    );
    assert!(md.outputs.iter().all(|u| u.dependencies == Some(vec![])));
}

#[test]
fn model_structure_dependencies_match_the_code() {
    let md = fmi2_export::xml::ModelDescription::parse(XML).unwrap();
    // configuration 1: inputs away from zero
    let errs = fmi2_export::xml::check_dependencies(&md, 2, |k| {
        let mut m = fresh();
        if k == 1 {
            m.set_real(VR_F_MEAS, 1.0).unwrap();
            m.set_real(VR_X_DRIVE, 1e-3).unwrap();
        }
        m
    });
    assert!(errs.is_empty(), "{errs:#?}");
    for u in &md.initial_unknowns {
        assert!(u.dependencies.is_some(), "initial unknown {}", u.index);
    }
}

#[test]
fn model_starts_from_the_xml_start_values() {
    let m = fresh();
    let errs = fmi2_export::xml::check_start_values(&m);
    assert!(errs.is_empty(), "{errs:?}");
}
