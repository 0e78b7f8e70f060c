//! The modelDescription and the code cannot drift: the checked-in
//! `modelDescription/controller/modelDescription.xml` is the one rendered
//! from the code, its `<ModelStructure>` matches the code's dependencies
//! (checked by perturbation), the declared capabilities work and the start
//! values are the model's.
use std::path::Path;

use crate::model::fresh;
use controller::model::*;
use fmi2_export::{CoSimModel, Logger};

#[test]
fn model_description_is_the_one_the_code_gives() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../modelDescription")
        .join(Controller::MODEL_IDENTIFIER)
        .join("modelDescription.xml");
    let md = fmi2_export::testing::check_model_description_file::<Controller>(&path)
        .unwrap_or_else(|e| panic!("{e}"));
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
    let xml = fmi2_export::render::model_description::<Controller>().unwrap();
    let md = fmi2_export::xml::ModelDescription::parse(&xml).unwrap();
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
}

#[test]
fn capabilities_are_backed_by_the_code() {
    let log = Logger::silent();
    let mut m = fresh();
    m.setup_experiment(0.0, None).unwrap();
    m.enter_initialization_mode(&log).unwrap();
    m.exit_initialization_mode(&log).unwrap();
    m.set_real(VR_F_MEAS, 1.0).unwrap();
    let errs = fmi2_export::testing::check_capabilities(&m, 1e-4);
    assert!(errs.is_empty(), "{errs:#?}");
}

#[test]
fn model_starts_from_the_start_values() {
    let errs = fmi2_export::xml::check_start_values(&fresh());
    assert!(errs.is_empty(), "{errs:?}");
}
