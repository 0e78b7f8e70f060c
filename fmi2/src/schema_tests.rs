//! Tests of `schema.rs`.
use super::*;

const MD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="osc" guid="{g}">
  <CoSimulation modelIdentifier="osc" canHandleVariableCommunicationStepSize="true"
      canInterpolateInputs="true" maxOutputDerivativeOrder="1" canGetAndSetFMUstate="true"/>
  <DefaultExperiment startTime="0" stopTime="2.5" stepSize="1e-4"/>
  <ModelVariables>
    <ScalarVariable name="m" valueReference="0" causality="parameter" variability="fixed">
      <Real start="1" unit="kg"/>
    </ScalarVariable>
    <ScalarVariable name="F" valueReference="3" causality="input"><Real start="0" unit="N"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="4" causality="output"><Real unit="m"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="3" dependencies=""/></Outputs>
  </ModelStructure>
</fmiModelDescription>
"#;

#[test]
fn parses_variables_capabilities_and_structure() {
    let md = ModelDescription::parse(MD).unwrap();
    assert_eq!(md.guid, "{g}");
    assert!(md.co_simulation.can_interpolate_inputs && md.co_simulation.can_get_and_set_fmu_state);
    assert_eq!(md.co_simulation.max_output_derivative_order, 1);
    assert_eq!(md.default_experiment.stop_time, Some(2.5));
    assert_eq!(md.variables.len(), 3);
    let f = md.variable("F").unwrap();
    assert_eq!(
        (f.value_reference, f.causality, f.ty, f.line),
        (3, Causality::Input, VarType::Real, 10)
    );
    assert_eq!(md.variable("m").unwrap().unit.as_deref(), Some("kg"));
    assert_eq!(
        md.variable("x").unwrap().variability,
        Variability::Continuous
    );
    assert_eq!(md.real_vr("x", &[Causality::Output]).unwrap(), 4);
    assert!(matches!(
        md.real_vr("x", &[Causality::Input]),
        Err(SchemaError::WrongVariable { .. })
    ));
    assert!(!md.output_depends_on(2, 1));
    assert!(matches!(
        md.variable("nope"),
        Err(SchemaError::UnknownVariable { .. })
    ));
    assert!(md.validate().is_empty(), "{:?}", md.validate());
}

#[test]
fn malformed_xml_reports_the_line() {
    let bad = MD.replace("<Real unit=\"m\"/>", "<Real unit=\"m\">");
    match ModelDescription::parse(&bad) {
        Err(SchemaError::Xml { line, message }) => assert!(
            line == 11 && message.contains("</Real>"),
            "line {line}: {message}"
        ),
        other => panic!("{other:?}"),
    }
    let bad = MD.replace("valueReference=\"3\"", "valueReference=\"-3\"");
    match ModelDescription::parse(&bad) {
        Err(SchemaError::Xml { line, message }) => assert!(
            line == 10 && message.contains("valueReference"),
            "{line} {message}"
        ),
        other => panic!("{other:?}"),
    }
    let bad = MD.replace("dependencies=\"\"", "dependencies=\"7\"");
    assert!(matches!(
        ModelDescription::parse(&bad),
        Err(SchemaError::Xml { line: 14, .. })
    ));
}

/// Issue 14: a modelDescription without its closing root tag was accepted,
/// a duplicate value reference recorded the wrong signal.
#[test]
fn unclosed_misnested_duplicate_and_unknown_causality_are_refused_with_the_line() {
    let bad = MD.replace("</fmiModelDescription>\n", "");
    match ModelDescription::parse(&bad) {
        Err(SchemaError::Xml { line, message }) => assert!(
            line == 16 && message.contains("<fmiModelDescription>"),
            "line {line}: {message}"
        ),
        other => panic!("{other:?}"),
    }
    let bad = MD.replace("</ModelVariables>", "</ModelStructure></ModelVariables>");
    assert!(matches!(
        ModelDescription::parse(&bad),
        Err(SchemaError::Xml { line: 12, .. })
    ));
    let bad = MD.replace("valueReference=\"4\"", "valueReference=\"3\"");
    let d = ModelDescription::parse(&bad)
        .unwrap()
        .duplicate_value_references();
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].line, Some(11));
    assert!(d[0].message.contains("(F and x)"), "{d:?}");
    let bad = MD.replace("causality=\"output\"", "causality=\"outptu\"");
    match ModelDescription::parse(&bad) {
        Err(SchemaError::Xml { line, message }) => assert!(
            line == 11 && message.contains("outptu"),
            "line {line}: {message}"
        ),
        other => panic!("{other:?}"),
    }
}

/// Issue 14: parsing was quadratic; 100k variables must take well under 1 s
/// (checked loosely here: the test profile is shared by parallel tests).
#[test]
fn parsing_is_linear_in_the_number_of_variables() {
    let mut s = String::from(
            "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"big\" guid=\"{g}\">\n<CoSimulation modelIdentifier=\"big\"/>\n<ModelVariables>\n",
        );
    for i in 0..100_000 {
        s.push_str(&format!(
                "<ScalarVariable name=\"v{i}\" valueReference=\"{i}\" causality=\"local\"><Real/></ScalarVariable>\n"
            ));
    }
    s.push_str("</ModelVariables>\n</fmiModelDescription>\n");
    let t0 = std::time::Instant::now();
    let md = ModelDescription::parse(&s).unwrap();
    assert_eq!(md.variables.len(), 100_000);
    assert!(t0.elapsed().as_secs_f64() < 5.0, "{:?}", t0.elapsed());
}

#[test]
fn version_and_cosimulation_are_required() {
    let v1 = MD.replace("fmiVersion=\"2.0\"", "fmiVersion=\"1.0\"");
    let e = ModelDescription::parse(&v1).unwrap_err();
    assert!(
        matches!(&e, SchemaError::Version { found } if found == "1.0"),
        "{e}"
    );
    // an FMI 2.0 body under fmiVersion 3.0 is read as FMI 3.0: no instantiationToken
    let v3 = MD.replace("fmiVersion=\"2.0\"", "fmiVersion=\"3.0\"");
    let e = ModelDescription::parse(&v3).unwrap_err().to_string();
    assert!(e.contains("instantiationToken"), "{e}");
    let me = MD.replace("<CoSimulation", "<ModelExchange");
    let e = ModelDescription::parse(&me).unwrap_err();
    assert!(
        matches!(e, SchemaError::NoCoSimulation { .. }) && e.to_string().contains("Co-Simulation"),
        "{e}"
    );
}

#[test]
fn model_exchange_and_derivatives_are_read_and_checked() {
    let me = MD
            .replace(
                "  <CoSimulation",
                "  <ModelExchange modelIdentifier=\"osc\" completedIntegratorStepNotNeeded=\"true\"/>\n  <CoSimulation",
            )
            .replace(
                "  </ModelVariables>",
                "    <ScalarVariable name=\"der(x)\" valueReference=\"5\"><Real derivative=\"3\"/></ScalarVariable>\n  </ModelVariables>",
            )
            .replace(
                "</Outputs>",
                "</Outputs>\n    <Derivatives><Unknown index=\"4\" dependencies=\"2 3\"/></Derivatives>",
            );
    let md = ModelDescription::parse(&me).unwrap();
    let cap = md.model_exchange.as_ref().unwrap();
    assert_eq!(cap.model_identifier, "osc");
    assert!(cap.completed_integrator_step_not_needed);
    assert_eq!(md.variables[3].derivative, Some(3));
    assert_eq!(md.derivatives[0].dependencies, Some(vec![2, 3]));
    assert!(md.validate().is_empty(), "{:?}", md.validate());
    // a derivative not listed in <Derivatives>, and one naming itself
    let unlisted = me.replace(
        "<Derivatives><Unknown index=\"4\" dependencies=\"2 3\"/></Derivatives>",
        "",
    );
    let p = ModelDescription::parse(&unlisted).unwrap().validate();
    assert!(
        p.iter().any(|q| q.message.contains("Derivatives lists []")),
        "{p:?}"
    );
    let selfref = me.replace("derivative=\"3\"", "derivative=\"4\"");
    let p = ModelDescription::parse(&selfref).unwrap().validate();
    assert!(
        p.iter()
            .any(|q| q.message.contains("must name another Real variable")),
        "{p:?}"
    );
    let bad = me.replace("derivative=\"3\"", "derivative=\"x\"");
    assert!(ModelDescription::parse(&bad).is_err());
}

#[test]
fn validate_lists_problems_with_lines() {
    let bad = MD
        .replace("valueReference=\"4\"", "valueReference=\"3\"")
        .replace("<Real start=\"0\" unit=\"N\"/>", "<Real unit=\"N\"/>")
        .replace("<Unknown index=\"3\" dependencies=\"\"/>", "");
    let md = ModelDescription::parse(&bad).unwrap();
    let p = md.validate();
    let has = |needle: &str, line: Option<usize>| {
        p.iter()
            .any(|q| q.message.contains(needle) && q.line == line)
    };
    assert!(
        has("valueReference 3 used twice for Real", Some(11)),
        "{p:?}"
    );
    assert!(
        has("F: a continuous input variable needs a start", Some(10)),
        "{p:?}"
    );
    assert!(has("ModelStructure/Outputs lists []", None), "{p:?}");
    assert_eq!(p.len(), 3, "{p:?}");
}

#[test]
fn line_numbers_are_linear_in_the_file() {
    // 20000 variables parse in one pass (quadratic line counting took seconds)
    let mut xml = String::from(
            "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"big\" guid=\"g\">\n<CoSimulation modelIdentifier=\"big\"/>\n<ModelVariables>\n",
        );
    for i in 0..20000 {
        xml.push_str(&format!(
            "<ScalarVariable name=\"v{i}\" valueReference=\"{i}\"><Real/></ScalarVariable>\n"
        ));
    }
    xml.push_str("</ModelVariables>\n</fmiModelDescription>\n");
    let t = std::time::Instant::now();
    let md = ModelDescription::parse(&xml).unwrap();
    assert_eq!(md.variables.len(), 20000);
    assert_eq!(md.variables[19999].line, 20003);
    assert!(md.validate().is_empty());
    assert!(t.elapsed().as_secs_f64() < 2.0, "{:?}", t.elapsed());
}

/// Issue 14: 100k scalar variables (each an output listed in
/// `<ModelStructure>`, 17 MB of XML) parse and validate in under 1 s
/// in release (measured 0.21 s). A timing, so not run in CI:
/// `cargo test --release -p fmi2 -- --ignored --nocapture hundred_thousand`
/// (the CI bound is the 20k test above).
#[test]
#[ignore]
fn hundred_thousand_variables_parse_in_under_a_second() {
    let n = 100_000;
    let mut xml = String::from(
            "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"big\" guid=\"g\">\n<CoSimulation modelIdentifier=\"big\"/>\n<ModelVariables>\n",
        );
    for i in 0..n {
        xml.push_str(&format!(
                "<ScalarVariable name=\"v{i}\" valueReference=\"{i}\" causality=\"output\" description=\"output {i}\"><Real unit=\"m\"/></ScalarVariable>\n"
            ));
    }
    xml.push_str("</ModelVariables>\n<ModelStructure>\n<Outputs>\n");
    for i in 1..=n {
        xml.push_str(&format!("<Unknown index=\"{i}\" dependencies=\"\"/>\n"));
    }
    xml.push_str("</Outputs>\n</ModelStructure>\n</fmiModelDescription>\n");
    let t = std::time::Instant::now();
    let md = ModelDescription::parse(&xml).unwrap();
    let problems = md.validate();
    let dt = t.elapsed().as_secs_f64();
    println!(
        "{n} variables, {} bytes: parse + validate {dt:.3} s",
        xml.len()
    );
    assert_eq!(md.variables.len(), n);
    assert_eq!(md.outputs.len(), n);
    assert!(
        problems.is_empty(),
        "{:?}",
        &problems[..problems.len().min(3)]
    );
    assert!(dt < 1.0, "{dt} s");
}
