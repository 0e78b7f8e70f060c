use super::*;

/// A small FMI 3.0 description with every construct the reader maps: the
/// independent time, Float64 input/output/state/derivative, an Int32
/// parameter, a String with a `<Start>` child, a structural parameter sizing
/// a Float64 array, a UInt64, and `<ModelStructure>` by value reference.
const MD3: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="m3" instantiationToken="{tok}" description="d">
  <ModelExchange modelIdentifier="m3" needsCompletedIntegratorStep="false" providesDirectionalDerivatives="true"/>
  <CoSimulation modelIdentifier="m3" canHandleVariableCommunicationStepSize="true"
      canGetAndSetFMUState="true" canSerializeFMUState="true" providesDirectionalDerivatives="true"
      maxOutputDerivativeOrder="1" providesIntermediateUpdate="false" hasEventMode="false"/>
  <DefaultExperiment startTime="0" stopTime="2" stepSize="0.01"/>
  <ModelVariables>
    <Float64 name="time" valueReference="100" causality="independent" variability="continuous"/>
    <Float64 name="F" valueReference="0" causality="input" start="0" unit="N"/>
    <Float64 name="x" valueReference="1" causality="output" initial="exact" start="0"/>
    <Float64 name="der(x)" valueReference="2" causality="local" derivative="1"/>
    <Int32 name="n" valueReference="3" causality="parameter" variability="fixed" start="2"/>
    <String name="file" valueReference="4" causality="parameter" variability="fixed"><Start value="a.json"/></String>
    <UInt64 name="n_points" valueReference="5" causality="structuralParameter" variability="fixed" start="3"/>
    <Float64 name="phi" valueReference="6" causality="output" variability="fixed" initial="calculated"><Dimension valueReference="5"/></Float64>
  </ModelVariables>
  <ModelStructure>
    <Output valueReference="1" dependencies=""/>
    <Output valueReference="6" dependencies="5"/>
    <ContinuousStateDerivative valueReference="2" dependencies="0 1"/>
    <InitialUnknown valueReference="1"/>
    <EventIndicator valueReference="1"/>
  </ModelStructure>
</fmiModelDescription>
"#;

#[test]
fn fmi3_maps_onto_the_version_neutral_types() {
    let md = ModelDescription::parse(MD3).unwrap();
    assert_eq!(md.fmi_version, "3.0");
    assert_eq!(md.guid, "{tok}");
    let names: Vec<&str> = md.variables.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, ["time", "F", "x", "der(x)", "n", "file"]);
    let x = md.variable("x").unwrap();
    assert_eq!((x.index, x.value_reference, x.ty), (3, 1, VarType::Real));
    let d = md.variable("der(x)").unwrap();
    assert_eq!(
        d.derivative,
        Some(3),
        "derivative vr 1 is x, the third scalar"
    );
    assert_eq!(md.variable("n").unwrap().ty, VarType::Integer);
    assert_eq!(md.variable("n").unwrap().variability, Variability::Fixed);
    assert_eq!(
        md.variable("file").unwrap().start.as_deref(),
        Some("a.json")
    );
    assert_eq!(
        md.variable("time").unwrap().causality,
        Causality::Independent
    );
    // the array and the UInt64 are named, not exchanged
    let e = md.variable("phi").unwrap_err().to_string();
    assert!(e.contains("Float64 array") && e.contains("line 16"), "{e}");
    assert!(md
        .variable("n_points")
        .unwrap_err()
        .to_string()
        .contains("UInt64"));
    // ModelStructure: by value reference -> positions; the array's output left out
    assert_eq!(md.outputs.len(), 1);
    assert_eq!(md.outputs[0].index, 3);
    assert_eq!(md.outputs[0].dependencies, Some(vec![]));
    assert_eq!(md.derivatives[0].index, 4);
    assert_eq!(md.derivatives[0].dependencies, Some(vec![2, 3]));
    assert_eq!(md.initial_unknowns.len(), 1);
    assert_eq!(md.number_of_event_indicators, 1);
    let cs = &md.co_simulation;
    assert!(cs.can_get_and_set_fmu_state && cs.can_serialize_fmu_state);
    assert!(cs.provides_directional_derivative && !cs.can_interpolate_inputs);
    assert_eq!(cs.max_output_derivative_order, 1);
    let me = md.model_exchange.as_ref().unwrap();
    assert!(me.completed_integrator_step_not_needed && me.provides_directional_derivative);
    assert_eq!(md.default_experiment.stop_time, Some(2.0));
    assert!(md.validate().is_empty(), "{:?}", md.validate());
    // x depends on nothing directly; der(x) is not an output
    assert!(!md.output_depends_on(2, 1));
}

#[test]
fn fmi3_errors_name_the_line() {
    let cases = [
        (
            MD3.replace(r#"instantiationToken="{tok}" "#, ""),
            "instantiationToken",
        ),
        (
            MD3.replace(
                r#"name="n" valueReference="3""#,
                r#"name="n" valueReference="1""#,
            ),
            "already used by the variable on line 11",
        ),
        (
            MD3.replace(
                r#"<Output valueReference="1" dependencies=""/>"#,
                r#"<Output valueReference="77"/>"#,
            ),
            "valueReference 77",
        ),
        (
            MD3.replace(r#"derivative="1""#, r#"derivative="9""#),
            "derivative names valueReference 9",
        ),
        (
            MD3.replace("causality=\"input\"", "causality=\"inflow\""),
            "unknown causality",
        ),
        (MD3.replace("<CoSimulation ", "<Other "), "Co-Simulation"),
        (MD3.replace("</ModelVariables>", ""), "line"),
    ];
    for (text, want) in cases {
        let e = ModelDescription::parse(&text).unwrap_err().to_string();
        assert!(e.contains(want), "expected '{want}' in: {e}");
    }
}

#[test]
fn fmi2_and_fmi3_dispatch_on_the_root_version() {
    let v4 = MD3.replace(r#"fmiVersion="3.0""#, r#"fmiVersion="4.0""#);
    assert!(matches!(
        ModelDescription::parse(&v4),
        Err(SchemaError::Version { found }) if found == "4.0"
    ));
}

/// The FMI 3.0 reader is linear in the number of variables like the FMI 2.0
/// one (names and value references hashed): 100k variables, one of them
/// repeating a name, which is found (a quadratic scan here took minutes).
#[test]
fn fmi3_parsing_is_linear_in_the_number_of_variables() {
    let mut s = String::from(
        "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"big\" instantiationToken=\"{g}\">\n\
         <CoSimulation modelIdentifier=\"big\"/>\n<ModelVariables>\n",
    );
    for i in 0..100_000 {
        s.push_str(&format!(
            "<Float64 name=\"v{i}\" valueReference=\"{i}\"/>\n"
        ));
    }
    let body_end = "</ModelVariables>\n</fmiModelDescription>\n";
    let md = ModelDescription::parse(&format!("{s}{body_end}")).unwrap();
    assert_eq!(md.variables.len(), 100_000);
    s.push_str("<Float64 name=\"v17\" valueReference=\"100000\"/>\n");
    let e = ModelDescription::parse(&format!("{s}{body_end}")).unwrap_err();
    assert!(e.to_string().contains("'v17' repeats"), "{e}");
}

/// The structure FMU's FMI 3.0 description (checked in, rendered from its
/// code): its mode-shape arrays and their UInt64 structural parameter are
/// listed as other variables and named when asked for, the scalars read as
/// before.
#[test]
fn the_structure_fmus_arrays_are_other_variables() {
    let md = ModelDescription::parse(include_str!(
        "../../modelDescription/structure_fmi3/modelDescription.xml"
    ))
    .unwrap();
    assert!(md.validate().is_empty(), "{:?}", md.validate());
    for name in ["mode_shape_re", "mode_shape_im"] {
        let e = md.variable(name).unwrap_err().to_string();
        assert!(e.contains("Float64 array"), "{e}");
    }
    let e = md.variable("mode_shape_points").unwrap_err().to_string();
    assert!(e.contains("UInt64"), "{e}");
    assert_eq!(md.other_variables.len(), 3);
    assert_eq!(
        md.outputs.len(),
        5,
        "the scalar outputs x, v, x_tip, a, omega"
    );
    assert_eq!(md.variable("x_tip").unwrap().value_reference, 3);
}
