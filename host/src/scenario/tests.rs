//! The scenario's own tests (parsing, key paths, the examples).
use super::*;

#[test]
fn nonlinearity_tables_parse_validate_and_round_trip() {
    let text = "[[nonlinearity]]\ntype = \"polynomial-spring\"\npoints = [\"tip\", \"2l3\"]\n\
                coefficients = { \"2\" = 1e5, \"3\" = 2e9 }\n\
                [[nonlinearity]]\ntype = \"elastic-dry-friction\"\nname = \"joint\"\npoint = \"tip\"\n\
                tangential_stiffness_n_per_m = 1e4\nslip_force_n = 0.5\n";
    let s = Scenario::parse(text).unwrap();
    assert_eq!(s.nonlinearity.len(), 2);
    assert_eq!(s.nonlinearity[0].kind, NonlinearityKind::PolynomialSpring);
    assert_eq!(s.nonlinearity[0].point_names(), ["tip", "2l3"]);
    assert_eq!(s.nonlinearity[1].element_name(1), "joint");
    assert!(s.nonlinearity[1].law(1).unwrap().hysteresis().is_some());
    let back = Scenario::parse(&toml::to_string(&s).unwrap()).unwrap();
    assert_eq!(back, s);
    // the default scenario serializes without the table
    assert!(!toml::to_string(&Scenario::default_scenario())
        .unwrap()
        .contains("nonlinearity"));
    let e = Scenario::parse(
        "[[nonlinearity]]\ntype = \"cubic-spring\"\npoint = \"tip\"\nk3_n_per_m3 = 1.0\n\
         [[nonlinearity]]\ntype = \"cubic-spring\"\nname = \"nonlinearity0\"\npoint = \"tip\"\nk3_n_per_m3 = 1.0\n",
    )
    .unwrap_err();
    assert_eq!(e.key, "nonlinearity[1].name");
}

#[test]
fn default_scenario_is_the_papers_case_a() {
    let s = Scenario::default_scenario();
    assert_eq!(s.exciter.len(), 1);
    let x = s.exciter_location_m(0).unwrap();
    assert!((x - 2.0 * 0.53 / 3.0).abs() < 1e-15);
    assert_eq!(s.excitation.voltage_v, 10.0);
    assert_eq!(s.excitation.rate_per_pseudo_period, 0.02);
    assert!(s.excitation.eta_end >= 1.8);
}

#[test]
fn fractions() {
    let f = parse_fraction;
    assert_eq!(f("l/3"), Some(1.0 / 3.0));
    assert_eq!(f("2l/3"), Some(2.0 / 3.0));
    assert_eq!(f("l"), Some(1.0));
    assert_eq!(f("2/3"), None);
    assert_eq!(f("x"), None);
}

#[test]
fn unknown_keys_and_bad_values_name_the_key() {
    let e = Scenario::parse("[structure]\nlenght_m = 1.0\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("lenght_m"), "{e}");
    let e = Scenario::parse("[structure]\nlength_m = -1.0\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("structure.length_m") && e.contains("positive"),
        "{e}"
    );
    let e = Scenario::parse("[[exciter]]\nlocation = \"4l/3\"\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("exciter[0].location") && e.contains("outside"),
        "{e}"
    );
    let e = Scenario::parse("[excitation]\neta_start = 1.0\neta_end = 1.0\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("excitation.eta_end"), "{e}");
    let e = Scenario::parse("[excitation]\nrate_per_pseudo_period = 0.0\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("rate_per_pseudo_period"), "{e}");
    let e = Scenario::parse("[run]\nmethods = [\"magic\"]\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("run.methods[0]") && e.contains("magic"), "{e}");
    let e = Scenario::parse("[slowflow]\nrtol = 0.0\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("slowflow.rtol"), "{e}");
    let e = Scenario::parse("[slowflow]\noutput_samples = 1\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("slowflow.output_samples"), "{e}");
}

#[test]
fn embedded_sweep_toml_is_the_rust_default() {
    let parsed = Scenario::parse(DEFAULT_SCENARIO).unwrap();
    assert_eq!(parsed, Scenario::default());
    assert!(parsed.run.methods.contains(&Method::Cosim));
}

#[test]
fn method_names_are_the_serde_names() {
    for m in Method::all() {
        let v: Method = crate::methods::catalog()
            .scope(|| {
                serde::Deserialize::deserialize(serde::de::value::StrDeserializer::<
                    serde::de::value::Error,
                >::new(m.name()))
            })
            .unwrap();
        assert_eq!(v, m);
        assert_eq!(m.to_string(), m.name());
    }
}

#[test]
fn every_spelling_is_typed_and_names_the_key() {
    let e = Scenario::parse("[reference]\nintegrator = \"rk4\"\n").unwrap_err();
    assert_eq!(e.key, "reference.integrator");
    assert!(
        e.message.contains("rk4") && e.message.contains("dormand-prince"),
        "{e}"
    );
    let s = Scenario::parse("[reference]\nintegrator = \"\"\n").unwrap();
    assert_eq!(s.reference.integrator, None);
    let s = Scenario::parse("[reference]\nintegrator = \"dormand-prince\"\n").unwrap();
    assert_eq!(s.reference.integrator, Some(Integrator::DormandPrince));
    let two = "[[exciter]]\nlocation = \"l/3\"\n[[exciter]]\nname = \"b\"\nlocation = \"2l/3\"\nstinger = \"glued\"\n";
    let e = Scenario::parse(two).unwrap_err();
    assert_eq!(e.key, "exciter[1].stinger");
    assert!(
        e.message.contains("glued") && e.message.contains("rigid"),
        "{e}"
    );
    assert_eq!(e.line, Some(6), "{e}");
    let e = Scenario::parse("[cosim]\nalgorithm = \"newton\"\n").unwrap_err();
    assert_eq!(e.key, "cosim.algorithm");
    let e = Scenario::parse("[structure]\nboundary = \"free-free\"\n").unwrap_err();
    assert_eq!(e.key, "structure.boundary");
    let e = Scenario::parse("[structure]\nboundary = \"hinged\"\n").unwrap_err();
    assert_eq!(e.key, "structure.boundary");
    let e = Scenario::parse("[structure]\nkind = \"plate\"\n").unwrap_err();
    assert_eq!(e.key, "structure.kind");
    let e = Scenario::parse("[structure]\nkind = \"matrices\"\n").unwrap_err();
    assert!(e.message.contains("mass_mtx"), "{e}");
    let e = Scenario::parse("[structure]\nreduction = \"guyan\"\n").unwrap_err();
    assert_eq!(e.key, "structure.reduction");
    // more fixed-interface modes than the sparse eigensolver takes: the key named
    let e = Scenario::parse(
        "[structure]\nkind = \"matrices\"\nmass_mtx = \"M.mtx\"\nstiffness_mtx = \"K.mtx\"\n\
         damping_ratio = 0.01\ncb_modes = 501\n[[structure.point]]\nname = \"a\"\ndof = 0\n\
         [[exciter]]\npoint = \"a\"\n[output]\nresponse_point = \"a\"\n",
    )
    .unwrap_err();
    assert_eq!(e.key, "structure.cb_modes", "{e}");
    assert!(
        e.message.contains("501") && e.message.contains("500"),
        "{e}"
    );
    let e = Scenario::parse("[[exciter]]\nlocation = \"x\"\n").unwrap_err();
    assert_eq!(e.key, "exciter[0].location");
    let e = Scenario::parse("[excitation]\nvoltage_v = -1.0\n").unwrap_err();
    assert_eq!(e.key, "excitation.voltage_v");
    let s = Scenario::parse("[imposed_force]\nsource = \"f.csv\"\n").unwrap();
    assert_eq!(s.imposed_force.source, ForceSource::Csv("f.csv".into()));
    let s = Scenario::parse("[[exciter]]\nlocation = 1\n").unwrap();
    assert_eq!(s.exciter[0].location, Some(LengthFraction(1.0)));
}

#[test]
fn slowflow_options_per_method() {
    let s = Scenario::parse("[slowflow]\nrtol = 3e-4\noutput_samples = 101\n").unwrap();
    let o = s.slowflow.options(Method::Nlmode);
    assert_eq!((o.rtol, o.output_samples), (3e-4, 101));
    assert_eq!(s.slowflow.options(Method::ImposedForce).rtol, 1e-5);
    let d = Scenario::default_scenario()
        .slowflow
        .options(Method::Nlmode);
    assert_eq!(d, nlmode::reduced::SlowFlowOptions::default());
}

#[test]
fn every_example_scenario_parses() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let p = entry.unwrap().path();
        // study_*.toml are study files (`host study`), checked by the study module's test
        let study = p
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with("study_"));
        if p.extension().and_then(|e| e.to_str()) == Some("toml") && !study {
            let text = std::fs::read_to_string(&p).unwrap();
            Scenario::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            n += 1;
        }
    }
    assert!(n >= 9, "only {n} example scenarios");
}

#[test]
fn attachment_tables_parse_and_name_their_keys() {
    let s = Scenario::parse(
        "[[attachment]]\ntype = \"tuned-mass-damper\"\nlocation = \"l\"\nmass_kg = 0.01\n\
         stiffness_n_per_m = 1e3\ndamping_ratio = 0.1\n\
         [[attachment]]\ntype = \"lti\"\npoints = [\"tip\"]\na_k = [[[1.0]], \"A1.mtx\"]\nb2 = [[1.0]]\n\
         [[exciter]]\nlocation = \"2l/3\"\nvoltage_v = 4.0\nphase_rad = 0.5\n",
    )
    .unwrap();
    assert_eq!(s.attachment.len(), 2);
    assert_eq!(s.attachment[0].kind, AttachmentType::TunedMassDamper);
    assert_eq!(s.attachment[0].name_or(0), "attachment0");
    assert_eq!(
        s.attachment[1].a_k.as_ref().unwrap()[1],
        MatrixSpec::File("A1.mtx".into())
    );
    assert_eq!(s.exciter[0].voltage_v, Some(4.0));
    assert_eq!(s.exciter[0].phase_rad, 0.5);
    for (text, key) in [
        ("[[attachment]]\ntype = \"mass\"\npoint = \"a\"\nmass_kg = 1.0\n", "attachment[0].point"),
        ("[[attachment]]\ntype = \"mass\"\nlocation = \"l\"\n", "attachment[0].mass_kg"),
        (
            "[[attachment]]\ntype = \"tuned-mass-damper\"\nlocation = \"l\"\nmass_kg = 1.0\nstiffness_n_per_m = -1.0\ndamping_ratio = 0.1\n",
            "attachment[0].stiffness_n_per_m",
        ),
        ("[[attachment]]\ntype = \"piezo\"\n", "attachment[0]"),
        ("[[exciter]]\nlocation = \"l\"\nphase_rad = nan\n", "exciter[0].phase_rad"),
        (
            "[[attachment]]\ntype = \"mass\"\nname = \"shaker\"\nlocation = \"l\"\nmass_kg = 1.0\n",
            "attachment[0].name",
        ),
    ] {
        let e = Scenario::parse(text).unwrap_err();
        assert!(e.key.starts_with(key), "{text}: {e}");
    }
}

/// A method's own options section (`[demo]`), as a method file declares it.
#[derive(Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Demo {
    steps: usize,
}

impl SectionOptions for Demo {
    const NAME: &'static str = "demo";
    fn validate(&self) -> Result<(), ScenarioError> {
        if self.steps == 0 {
            return Err(bad("demo.steps", "expected at least 1"));
        }
        Ok(())
    }
}

#[test]
fn a_methods_own_section_is_read_checked_and_set_aside() {
    let own: &'static Catalog = Box::leak(Box::new(Catalog::new(
        Method::all(),
        vec![OptionsSection::of::<Demo>()],
    )));
    let s = Scenario::parse_in("title = \"t\"\n[demo]\nsteps = 3\n", own).unwrap();
    assert_eq!(s.section::<Demo>().unwrap(), Demo { steps: 3 });
    assert_eq!(s.title, "t");
    // absent: the defaults
    let s = Scenario::parse_in("", own).unwrap();
    assert_eq!(s.section::<Demo>().unwrap(), Demo::default());
    // the checks name the key, with the section's line
    let e = Scenario::parse_in("\n[demo]\nsteps = 0\n", own).unwrap_err();
    assert_eq!((e.key.as_str(), e.line), ("demo.steps", Some(2)));
    let e = Scenario::parse_in("[demo]\nstep = 1\n", own).unwrap_err();
    assert_eq!(e.key, "demo.step", "{e}");
    assert!(e.message.contains("unknown field `step`"), "{e}");
    // the scenario's own keys keep their messages and lines
    let e = Scenario::parse_in("[demo]\nsteps = 1\n[structure]\nlenght_m = 1\n", own).unwrap_err();
    assert_eq!(
        (e.key.as_str(), e.line),
        ("structure.lenght_m", Some(4)),
        "{e}"
    );
    let e = Scenario::parse_in("[demo]\nsteps = 1\n[demo2]\n", own).unwrap_err();
    assert_eq!((e.key.as_str(), e.line), ("demo2", Some(3)), "{e}");
    // unregistered, the table is an unknown key
    assert_eq!(Scenario::parse("[demo]\n").unwrap_err().key, "demo");
}
