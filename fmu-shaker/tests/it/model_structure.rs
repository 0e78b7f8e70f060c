//! `<ModelStructure>` of the shaker FMU against the code's actual
//! dependencies (issue 14, item 1): `F = k_s (q_a - x)` feeds through from
//! `x`, `u` from `u_ext` (with `use_external_voltage`), nothing else; every
//! initial unknown lists exactly what its start value depends on. (The
//! structure FMU's check is in `fmu-structure/tests/model.rs`.)
use fmi2_export::{CoSimModel, InstantiateContext, Logger};
use shaker::model::{Shaker, VR_USE_EXTERNAL, VR_X};

const XML: &str = include_str!("../../../modelDescription/shaker/modelDescription.xml");

#[test]
fn shaker_model_structure_dependencies_match_the_code() {
    let md = fmi2_export::xml::ModelDescription::parse(XML).unwrap();
    let log = Logger::silent();
    // configuration 0: internal sweep; 1: external voltage; 2: x = 1 um (F = -k_s x)
    let errs = fmi2_export::xml::check_dependencies(&md, 3, |k| {
        let mut m = Shaker::instantiate(&InstantiateContext {
            instance_name: "s",
            resource_dir: None,
            logger: &log,
        })
        .unwrap();
        m.set_boolean(VR_USE_EXTERNAL, k == 1).unwrap();
        if k == 2 {
            m.set_real(VR_X, 1e-6).unwrap();
        }
        m
    });
    assert!(errs.is_empty(), "{errs:#?}");
    for u in &md.initial_unknowns {
        assert!(u.dependencies.is_some(), "initial unknown {}", u.index);
    }
}
