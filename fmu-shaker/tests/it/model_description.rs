//! The modelDescription.xml and the code cannot drift: names, value
//! references, types, causality, variability, start values, units and the
//! ModelStructure are checked against `shaker::model::VARIABLES`.
use fmi2_export::{CoSimModel, InstantiateContext, Logger};
use shaker::model::*;

const XML: &str = include_str!("../../../modelDescription/shaker/modelDescription.xml");

#[test]
fn model_exchange_part_matches_the_code() {
    let md = fmi2_export::xml::ModelDescription::parse(XML).unwrap();
    let errs = fmi2_export::xml::check_model_exchange::<Shaker>(&md);
    assert!(errs.is_empty(), "{errs:#?}");
    let me = md.model_exchange.as_ref().expect("<ModelExchange>");
    assert_eq!(me.model_identifier, "shaker");
    // the Jacobian of the derivatives (A, B) is provided
    assert!(me.provides_directional_derivative);
    let names: Vec<&str> = md
        .derivatives
        .iter()
        .map(|u| md.variables[u.index - 1].name.as_str())
        .collect();
    assert_eq!(names, ["der(I)", "der(q_a)", "der(v_a)"]);
}

#[test]
fn xml_matches_the_code() {
    let md = fmi2_export::xml::check_model_description(
        XML,
        Shaker::MODEL_IDENTIFIER,
        Shaker::GUID,
        Shaker::VARIABLES,
    )
    .unwrap_or_else(|e| {
        panic!(
            "modelDescription.xml drifted from the code:\n{}",
            e.join("\n")
        )
    });
    let index = |name: &str| md.variables.iter().find(|v| v.name == name).unwrap().index;
    // F = k_s (q_a - x) depends directly on x only; u on u_ext; the rest on no input
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
    // initial unknowns: the calculated parameter, every output and (Model
    // Exchange) every state derivative, ascending
    let mut expect: Vec<usize> = md
        .variables
        .iter()
        .filter(|v| {
            v.causality == "output"
                || v.causality == "calculatedParameter"
                || v.derivative.is_some()
        })
        .map(|v| v.index)
        .collect();
    expect.sort();
    assert_eq!(
        md.initial_unknowns
            .iter()
            .map(|u| u.index)
            .collect::<Vec<_>>(),
        expect
    );
    // capability flags that the implementation backs
    let flag = |k: &str| {
        md.cosim_flags
            .iter()
            .find(|(n, _)| n == k)
            .map(|(_, v)| v.as_str())
    };
    assert_eq!(flag("canHandleVariableCommunicationStepSize"), Some("true"));
    assert_eq!(flag("canGetAndSetFMUstate"), Some("true"));
    assert_eq!(flag("canSerializeFMUstate"), Some("true"));
    assert_eq!(flag("providesDirectionalDerivative"), Some("true"));
    assert_eq!(flag("maxOutputDerivativeOrder"), Some("1"));
    assert_eq!(flag("canBeInstantiatedOnlyOncePerProcess"), Some("false"));
}

#[test]
fn model_starts_from_the_xml_start_values() {
    let log = Logger::silent();
    let m = Shaker::instantiate(&InstantiateContext {
        instance_name: "s",
        resource_dir: None,
        logger: &log,
    })
    .unwrap();
    let errs = fmi2_export::xml::check_start_values(&m);
    assert!(errs.is_empty(), "{errs:?}");
    // the calculated d_a follows the paper's relation (1.067 N s/m, see nlmode::benchmark)
    assert!((m.get_real(VR_D_A) - nlmode::benchmark::shaker_da_n_s_per_m()).abs() < 1e-12);
}
