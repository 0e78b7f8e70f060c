//! The modelDescription and the code cannot drift: the checked-in
//! `modelDescription/shaker/modelDescription.xml` is the one rendered from
//! the code, its `<ModelStructure>` matches the code's dependencies (issue
//! 14, item 1: `F = k_s (q_a - x)` feeds through from `x`, `u` from `u_ext`
//! with `use_external_voltage`, nothing else), the declared capabilities
//! work and the start values are the model's.
use std::path::Path;

use fmi2_export::{CoSimModel, InstantiateContext, Logger};
use shaker::model::*;

fn fresh() -> Shaker {
    Shaker::instantiate(&InstantiateContext {
        instance_name: "s",
        resource_dir: None,
        logger: &Logger::silent(),
    })
    .unwrap()
}

#[test]
fn model_description_is_the_one_the_code_gives() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../modelDescription")
        .join(Shaker::MODEL_IDENTIFIER)
        .join("modelDescription.xml");
    let md = fmi2_export::testing::check_model_description_file::<Shaker>(&path)
        .unwrap_or_else(|e| panic!("{e}"));
    let me = md.model_exchange.as_ref().expect("<ModelExchange>");
    // the Jacobian of the derivatives (A, B) is provided
    assert!(me.provides_directional_derivative);
    let names: Vec<&str> = md
        .derivatives
        .iter()
        .map(|u| md.variables[u.index - 1].name.as_str())
        .collect();
    assert_eq!(names, ["der(I)", "der(q_a)", "der(v_a)"]);
    let index = |name: &str| md.variables.iter().find(|v| v.name == name).unwrap().index;
    let deps = |name: &str| {
        md.outputs
            .iter()
            .find(|u| u.index == index(name))
            .unwrap()
            .dependencies
            .clone()
    };
    assert_eq!(deps("F"), Some(vec![index("x")]));
    assert_eq!(deps("u"), Some(vec![index("u_ext")]));
    for n in ["I", "q_a", "v_a", "Omega"] {
        assert_eq!(deps(n), Some(vec![]), "{n}");
    }
}

#[test]
fn model_structure_dependencies_match_the_code() {
    let xml = fmi2_export::render::model_description::<Shaker>().unwrap();
    let md = fmi2_export::xml::ModelDescription::parse(&xml).unwrap();
    // configuration 0: internal sweep; 1: external voltage; 2: x = 1 um (F = -k_s x)
    let errs = fmi2_export::xml::check_dependencies(&md, 3, |k| {
        let mut m = fresh();
        m.set_boolean(VR_USE_EXTERNAL, k == 1).unwrap();
        if k == 2 {
            m.set_real(VR_X, 1e-6).unwrap();
        }
        m
    });
    assert!(errs.is_empty(), "{errs:#?}");
}

#[test]
fn capabilities_are_backed_by_the_code() {
    let log = Logger::silent();
    for external in [false, true] {
        let mut m = fresh();
        m.set_boolean(VR_USE_EXTERNAL, external).unwrap();
        m.setup_experiment(0.0, None).unwrap();
        m.enter_initialization_mode(&log).unwrap();
        m.exit_initialization_mode(&log).unwrap();
        m.set_real(VR_X, 1e-6).unwrap();
        m.set_real(VR_U_EXT, 1.0).unwrap();
        let errs = fmi2_export::testing::check_capabilities(&m, 1e-4);
        assert!(errs.is_empty(), "external voltage {external}: {errs:#?}");
    }
}

#[test]
fn model_starts_from_the_start_values() {
    let m = fresh();
    let errs = fmi2_export::xml::check_start_values(&m);
    assert!(errs.is_empty(), "{errs:?}");
    // the calculated d_a follows the paper's relation (1.067 N s/m, see nlmode::benchmark)
    assert!((m.get_real(VR_D_A) - nlmode::benchmark::shaker_da_n_s_per_m()).abs() < 1e-12);
}
