//! Tests of import and master on the C test FMU (`csrc/testosc.c`, a
//! mass-spring-damper with injectable failures) and, in `fmus`, on the
//! repository's structure and shaker FMUs.
use super::import::*;
use super::master::*;
use std::io::Write;
use std::path::{Path, PathBuf};

const TEST_GUID: &str = "{host-test-osc-0001}";

fn test_md(guid: &str) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="testosc" guid="{guid}">
  <CoSimulation modelIdentifier="testosc" canHandleVariableCommunicationStepSize="true"
     canInterpolateInputs="true" canGetAndSetFMUstate="true"/>
  <ModelVariables>
    <ScalarVariable name="m" valueReference="0" causality="parameter" variability="fixed"><Real start="1" unit="kg"/></ScalarVariable>
    <ScalarVariable name="k" valueReference="1" causality="parameter" variability="fixed"><Real start="100" unit="N/m"/></ScalarVariable>
    <ScalarVariable name="d" valueReference="2" causality="parameter" variability="fixed"><Real start="0" unit="N.s/m"/></ScalarVariable>
    <ScalarVariable name="F" valueReference="3" causality="input"><Real start="0" unit="N"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="4" causality="output"><Real unit="m"/></ScalarVariable>
    <ScalarVariable name="v" valueReference="5" causality="output"><Real unit="m/s"/></ScalarVariable>
    <ScalarVariable name="fail_at_s" valueReference="6" causality="parameter" variability="fixed"><Real start="1e300" unit="s"/></ScalarVariable>
    <ScalarVariable name="discard_at_s" valueReference="7" causality="parameter" variability="fixed"><Real start="1e300" unit="s"/></ScalarVariable>
    <ScalarVariable name="substeps" valueReference="8" causality="parameter" variability="fixed"><Real start="10"/></ScalarVariable>
    <ScalarVariable name="x0" valueReference="9" causality="parameter" variability="fixed"><Real start="0" unit="m"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="5" dependencies=""/><Unknown index="6" dependencies=""/></Outputs></ModelStructure>
</fmiModelDescription>
"#
    )
}

/// The FMI 3.0 modelDescription of the same test oscillator (`csrc/testosc.c`,
/// `fmi3*` functions): Float64 variables with the FMI 2.0 value references,
/// the independent `time`, and `<ModelStructure>` by value reference.
fn test_md3(token: &str) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="testosc" instantiationToken="{token}">
  <CoSimulation modelIdentifier="testosc" canHandleVariableCommunicationStepSize="true"
     canGetAndSetFMUState="true" providesDirectionalDerivatives="true"/>
  <ModelVariables>
    <Float64 name="time" valueReference="1000" causality="independent" variability="continuous"/>
    <Float64 name="m" valueReference="0" causality="parameter" variability="fixed" start="1" unit="kg"/>
    <Float64 name="k" valueReference="1" causality="parameter" variability="fixed" start="100" unit="N/m"/>
    <Float64 name="d" valueReference="2" causality="parameter" variability="fixed" start="0" unit="N.s/m"/>
    <Float64 name="F" valueReference="3" causality="input" start="0" unit="N"/>
    <Float64 name="x" valueReference="4" causality="output" unit="m"/>
    <Float64 name="v" valueReference="5" causality="output" unit="m/s"/>
    <Float64 name="fail_at_s" valueReference="6" causality="parameter" variability="fixed" start="1e300" unit="s"/>
    <Float64 name="discard_at_s" valueReference="7" causality="parameter" variability="fixed" start="1e300" unit="s"/>
    <Float64 name="substeps" valueReference="8" causality="parameter" variability="fixed" start="10"/>
    <Float64 name="x0" valueReference="9" causality="parameter" variability="fixed" start="0" unit="m"/>
  </ModelVariables>
  <ModelStructure><Output valueReference="4" dependencies=""/><Output valueReference="5" dependencies=""/></ModelStructure>
</fmiModelDescription>
"#
    )
}

/// The FMI 3.0 test FMU with `md` as modelDescription (the binary in the
/// FMI 3.0 platform folder).
fn test_fmu3(dir: &Path, name: &str, md: &str) -> PathBuf {
    let p = dir.join(name);
    let so = format!("binaries/{}-linux/testosc.so", std::env::consts::ARCH);
    write_zip(
        &p,
        &[
            ("modelDescription.xml", md.as_bytes().to_vec()),
            (so.as_str(), test_lib()),
        ],
        &[],
    );
    p
}

/// Write a `.fmu` with the given entries (name, bytes) and optional symlink entries.
fn write_zip(path: &Path, entries: &[(&str, Vec<u8>)], symlinks: &[(&str, &str)]) {
    let f = std::fs::File::create(path).unwrap();
    let mut z = zip::ZipWriter::new(f);
    let o = zip::write::SimpleFileOptions::default();
    for (n, b) in entries {
        z.start_file(*n, o).unwrap();
        z.write_all(b).unwrap();
    }
    for (n, target) in symlinks {
        z.add_symlink(*n, *target, o).unwrap();
    }
    z.finish().unwrap();
}

fn test_lib() -> Vec<u8> {
    std::fs::read(env!("COSIM_TEST_FMU_LIB")).expect("test FMU library built by build.rs")
}

/// The test FMU with `md` as modelDescription.
pub(super) fn test_fmu(dir: &Path, name: &str, md: &str, with_binary: bool) -> PathBuf {
    let p = dir.join(name);
    let mut e = vec![("modelDescription.xml", md.as_bytes().to_vec())];
    if with_binary {
        e.push(("binaries/linux64/testosc.so", test_lib()));
    }
    write_zip(&p, &e, &[]);
    p
}

fn fmu_err(p: &Path) -> FmuError {
    Fmu::load(p).expect_err("import must fail")
}

#[test]
fn imports_the_test_fmu_and_simulates_a_free_oscillation() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = Fmu::load(&test_fmu(dir.path(), "osc.fmu", &test_md(TEST_GUID), true)).unwrap();
    assert_eq!(fmu.md.co_simulation.model_identifier, "testosc");
    let mut i = fmu.instantiate("osc", false).unwrap();
    i.set_real(&[1, 9], &[400.0, 1e-3]).unwrap(); // k = 400 N/m, m = 1 kg: omega = 20 rad/s
    i.setup_experiment(0.0, None, None).unwrap();
    i.enter_initialization_mode().unwrap();
    i.exit_initialization_mode().unwrap();
    let h = 1e-3;
    let mut x = [0.0];
    for n in 0..500 {
        i.do_step(n as f64 * h, h).unwrap();
        i.get_real(&[4], &mut x).unwrap();
        let t = (n + 1) as f64 * h;
        assert!(
            (x[0] - 1e-3 * (20.0 * t).cos()).abs() < 1e-9,
            "t = {t}: {}",
            x[0]
        );
    }
    // a wrong communication point is refused with the FMU's message (printf
    // arguments formatted by the C logger shim)
    let e = i.do_step(7.0, h).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("fmi2DoStep")
            && msg.contains("fmi2Error")
            && msg.contains("expected currentCommunicationPoint = 0.5"),
        "{msg}"
    );
    assert!(
        i.log()
            .iter()
            .any(|r| r.status == "fmi2Error" && r.message.contains("but was 7")),
        "{:?}",
        i.log()
    );
}

#[test]
fn rollback_restores_the_state_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = Fmu::load(&test_fmu(dir.path(), "osc.fmu", &test_md(TEST_GUID), true)).unwrap();
    let mut i = fmu.instantiate("osc", false).unwrap();
    i.set_real(&[9], &[1e-3]).unwrap();
    i.setup_experiment(0.0, None, None).unwrap();
    i.enter_initialization_mode().unwrap();
    i.exit_initialization_mode().unwrap();
    i.do_step(0.0, 0.01).unwrap();
    i.save_state().unwrap();
    let mut a = [0.0; 2];
    let mut b = [0.0; 2];
    i.do_step(0.01, 0.01).unwrap();
    i.get_real(&[4, 5], &mut a).unwrap();
    i.restore_state().unwrap();
    i.set_real(&[3], &[5.0]).unwrap();
    i.do_step(0.01, 0.01).unwrap();
    i.get_real(&[4, 5], &mut b).unwrap();
    assert!(a != b);
    i.restore_state().unwrap();
    i.set_real(&[3], &[0.0]).unwrap();
    i.do_step(0.01, 0.01).unwrap();
    i.get_real(&[4, 5], &mut b).unwrap();
    assert_eq!(a, b);
}

#[test]
fn rejects_entries_escaping_the_folder_and_writes_nothing_outside() {
    let dir = tempfile::tempdir().unwrap();
    let outside = std::env::temp_dir().join(format!("host-evil-{}.txt", std::process::id()));
    let tmp_before: usize = std::fs::read_dir(std::env::temp_dir()).unwrap().count();
    let md = test_md(TEST_GUID).into_bytes();
    let rel = format!("../../../../../../../../..{}", outside.display());
    for (name, entry) in [
        ("dotdot.fmu", rel.as_str()),
        ("abs.fmu", outside.to_str().unwrap()),
        ("inner.fmu", "resources/../../x.txt"),
    ] {
        let p = dir.path().join(name);
        // the bad entry comes after a good one: nothing may be unpacked at all
        write_zip(
            &p,
            &[
                ("modelDescription.xml", md.clone()),
                (entry, b"pwned".to_vec()),
            ],
            &[],
        );
        match fmu_err(&p) {
            FmuError::UnsafeEntry { entry: e, .. } => assert_eq!(e, entry),
            other => panic!("{name}: {other}"),
        }
        assert!(!outside.exists(), "{name} wrote {}", outside.display());
    }
    let p = dir.path().join("link.fmu");
    write_zip(
        &p,
        &[("modelDescription.xml", md)],
        &[("resources/link", "/etc/passwd")],
    );
    let e = fmu_err(&p);
    assert!(
        matches!(&e, FmuError::Symlink { entry, .. } if entry == "resources/link"),
        "{e}"
    );
    assert!(e.to_string().contains("symbolic link"));
    // the temporary folders of the failed imports are gone again
    let tmp_after: usize = std::fs::read_dir(std::env::temp_dir()).unwrap().count();
    assert!(tmp_after <= tmp_before + 2, "{tmp_before} -> {tmp_after}"); // other tests may run concurrently
}

#[test]
fn missing_binary_guid_mismatch_version_and_model_exchange_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let e = fmu_err(&test_fmu(
        dir.path(),
        "nobin.fmu",
        &test_md(TEST_GUID),
        false,
    ));
    assert!(
        matches!(&e, FmuError::MissingBinary { identifier, .. } if identifier == "testosc"),
        "{e}"
    );
    assert!(e.to_string().contains("binaries/linux64/testosc.so"), "{e}");

    let fmu = Fmu::load(&test_fmu(
        dir.path(),
        "guid.fmu",
        &test_md("{another-guid}"),
        true,
    ))
    .unwrap();
    let e = fmu.instantiate("g", false).err().unwrap();
    let msg = e.to_string();
    assert!(matches!(e, FmuError::Instantiate { .. }), "{msg}");
    assert!(
        msg.contains("GUID mismatch: expected {host-test-osc-0001}, got {another-guid}"),
        "{msg}"
    );

    let e = fmu_err(&test_fmu(
        dir.path(),
        "v1.fmu",
        &test_md(TEST_GUID).replace("fmiVersion=\"2.0\"", "fmiVersion=\"1.0\""),
        true,
    ));
    assert!(
        matches!(&e, FmuError::Schema(SchemaError::Version { found }) if found == "1.0"),
        "{e}"
    );
    let e = fmu_err(&test_fmu(
        dir.path(),
        "v3.fmu",
        &test_md(TEST_GUID).replace("fmiVersion=\"2.0\"", "fmiVersion=\"3.0\""),
        true,
    ));
    // read as FMI 3.0, which names its token differently
    assert!(e.to_string().contains("instantiationToken"), "{e}");
    let v4 = test_md(TEST_GUID).replace("fmiVersion=\"2.0\"", "fmiVersion=\"4.0\"");
    let e = fmu_err(&test_fmu(dir.path(), "v4.fmu", &v4, true));
    assert!(e.to_string().contains("FMI 2.0 and 3.0"), "{e}");

    let me = test_md(TEST_GUID).replace("<CoSimulation", "<ModelExchange");
    let e = fmu_err(&test_fmu(dir.path(), "me.fmu", &me, true));
    assert!(
        matches!(e, FmuError::Schema(SchemaError::NoCoSimulation { .. })),
        "{e}"
    );

    let bad = test_md(TEST_GUID).replace("<Real unit=\"m\"/>", "<Real unit=\"m\">");
    let e = fmu_err(&test_fmu(dir.path(), "xml.fmu", &bad, true));
    assert!(
        matches!(e, FmuError::Schema(SchemaError::Xml { line: 10, .. })),
        "{e}"
    );

    let p = dir.path().join("notzip.fmu");
    std::fs::write(&p, b"not a zip").unwrap();
    assert!(matches!(fmu_err(&p), FmuError::Zip { .. }));
}

fn single_osc_master(dir: &Path, fail: Option<(&str, f64)>) -> Master {
    let fmu = Fmu::load(&test_fmu(dir, "osc.fmu", &test_md(TEST_GUID), true)).unwrap();
    let mut m = Master::new(
        vec![("osc".into(), fmu)],
        &[],
        MasterOptions {
            macro_step_s: 1e-3,
            ..Default::default()
        },
    )
    .unwrap();
    m.set_parameter(0, "x0", &ParamValue::Real(1e-3)).unwrap();
    if let Some((name, t)) = fail {
        m.set_parameter(0, name, &ParamValue::Real(t)).unwrap();
    }
    m.initialize(0.0, None).unwrap();
    m
}

#[test]
fn an_fmu_error_mid_run_stops_cleanly_and_keeps_the_results() {
    let dir = tempfile::tempdir().unwrap();
    for (param, status) in [("fail_at_s", "fmi2Error"), ("discard_at_s", "fmi2Discard")] {
        let mut m = single_osc_master(dir.path(), Some((param, 0.0305)));
        let rec = run(&mut m, 0.1, &["osc.x".into()], 1, &mut |_| {}).unwrap();
        let (t, msg) = rec.stopped.clone().expect("stopped");
        assert!((t - 0.030).abs() < 1e-12, "{t}");
        assert!(
            msg.contains(status) && msg.contains("injected") && msg.contains("t = 0.03 s"),
            "{msg}"
        );
        // samples up to the last good communication point, and they are right
        assert_eq!(rec.time_s.len(), 31);
        let x = rec.column("osc.x").unwrap();
        for (k, &t) in rec.time_s.iter().enumerate() {
            assert!(
                (x[k] - 1e-3 * (10.0 * t).cos()).abs() < 1e-9,
                "{t}: {}",
                x[k]
            );
        }
    }
}

#[test]
fn connection_errors_name_the_endpoint() {
    let dir = tempfile::tempdir().unwrap();
    let mk = |c: &[(&str, &str)]| {
        let a = Fmu::load(&test_fmu(dir.path(), "a.fmu", &test_md(TEST_GUID), true)).unwrap();
        let b = Fmu::load(&test_fmu(dir.path(), "b.fmu", &test_md(TEST_GUID), true)).unwrap();
        let c: Vec<(String, String)> = c
            .iter()
            .map(|(x, y)| (x.to_string(), y.to_string()))
            .collect();
        Master::new(
            vec![("a".into(), a), ("b".into(), b)],
            &c,
            MasterOptions::default(),
        )
        .err()
        .unwrap()
        .to_string()
    };
    assert!(mk(&[("a.x", "c.F")]).contains("no unit named 'c'"));
    assert!(mk(&[("a.x", "b.nope")]).contains("'nope'"));
    assert!(mk(&[("a.F", "b.F")]).contains("expected output"));
    assert!(mk(&[("a.x", "b.x")]).contains("expected input"));
    assert!(mk(&[("a.x", "b.F"), ("a.v", "b.F")]).contains("more than one"));
    assert!(mk(&[("ax", "b.F")]).contains("unit.variable"));
}

#[test]
fn generic_mode_runs_fmus_from_a_connection_list() {
    let dir = tempfile::tempdir().unwrap();
    let a = test_fmu(dir.path(), "a.fmu", &test_md(TEST_GUID), true);
    let b = test_fmu(dir.path(), "b.fmu", &test_md(TEST_GUID), true);
    let spec = GenericSpec {
        units: vec![("a".into(), a), ("b".into(), b)],
        connections: vec![("a.x".into(), "b.F".into()), ("b.x".into(), "a.F".into())],
        parameters: vec![
            ("a.x0".into(), ParamValue::Real(1.0)),
            ("b.k".into(), ParamValue::Real(100.0)),
        ],
        options: MasterOptions {
            algorithm: Algorithm::GaussSeidel,
            macro_step_s: 1e-3,
            ..Default::default()
        },
        start_time_s: 0.0,
        stop_time_s: 1.0,
        record: vec!["a.x".into(), "b.x".into()],
        record_every: 100,
    };
    let rec = run_generic(&spec, &mut |_| {}).unwrap();
    assert_eq!(rec.time_s.len(), 11);
    let (w1, w2) = (99f64.sqrt(), 101f64.sqrt());
    let t = rec.time_s[10];
    assert!((t - 1.0).abs() < 1e-12);
    let xb = 0.5 * ((w1 * t).cos() - (w2 * t).cos());
    assert!(
        (rec.column("b.x").unwrap()[10] - xb).abs() < 1e-3,
        "{}",
        rec.column("b.x").unwrap()[10]
    );
    let mut bad = spec.clone();
    bad.parameters.push(("c.k".into(), ParamValue::Real(1.0)));
    assert!(run_generic(&bad, &mut |_| {})
        .unwrap_err()
        .to_string()
        .contains("no unit named 'c'"));
    let mut bad = spec.clone();
    bad.parameters
        .push(("a.k".into(), ParamValue::Boolean(true)));
    assert!(run_generic(&bad, &mut |_| {})
        .unwrap_err()
        .to_string()
        .contains("does not fit"));
}

/// The SSP archive holds both FMUs byte for byte and an .ssd whose
/// components, connectors, connections and parameter values are the inputs.
#[test]
fn ssp_export_round_trips() {
    use super::ssp::write_ssp;
    use quick_xml::events::Event;
    use std::io::Read;
    let dir = tempfile::tempdir().unwrap();
    let a = test_fmu(dir.path(), "a.fmu", &test_md(TEST_GUID), true);
    let b = test_fmu(dir.path(), "b.fmu", &test_md(TEST_GUID), true);
    let out = dir.path().join("sys.ssp");
    let conns = vec![
        ("a.x".to_string(), "b.F".to_string()),
        ("b.x".to_string(), "a.F".to_string()),
    ];
    let params = vec![
        ("a.x0".to_string(), ParamValue::Real(0.25)),
        ("b.k".to_string(), ParamValue::Real(400.0)),
    ];
    write_ssp(
        &out,
        "two <osc>",
        &[("a".into(), a.clone()), ("b".into(), b.clone())],
        &conns,
        &params,
        2.0,
    )
    .unwrap();
    let mut z = zip::ZipArchive::new(std::fs::File::open(&out).unwrap()).unwrap();
    for (u, p) in [("a", &a), ("b", &b)] {
        let mut bytes = Vec::new();
        z.by_name(&format!("resources/{u}.fmu"))
            .unwrap()
            .read_to_end(&mut bytes)
            .unwrap();
        assert_eq!(bytes, std::fs::read(p).unwrap());
    }
    let mut ssd = String::new();
    z.by_name("SystemStructure.ssd")
        .unwrap()
        .read_to_string(&mut ssd)
        .unwrap();
    let mut r = quick_xml::Reader::from_str(&ssd);
    let (mut comps, mut connections, mut values, mut connectors) = (vec![], vec![], vec![], 0);
    let mut current_param = String::new();
    let mut root_name = String::new();
    loop {
        match r.read_event().unwrap() {
            Event::Start(e) | Event::Empty(e) => {
                let at = |k: &str| {
                    e.try_get_attribute(k)
                        .unwrap()
                        .map(|a| a.unescape_value().unwrap().into_owned())
                };
                match e.name().as_ref() {
                    b"ssd:SystemStructureDescription" => root_name = at("name").unwrap(),
                    b"ssd:Component" => comps.push((at("name").unwrap(), at("source").unwrap())),
                    b"ssd:Connector" => connectors += 1,
                    b"ssd:Connection" => connections.push((
                        format!(
                            "{}.{}",
                            at("startElement").unwrap(),
                            at("startConnector").unwrap()
                        ),
                        format!(
                            "{}.{}",
                            at("endElement").unwrap(),
                            at("endConnector").unwrap()
                        ),
                    )),
                    b"ssv:Parameter" => current_param = at("name").unwrap(),
                    b"ssv:Real" => values.push((
                        current_param.clone(),
                        at("value").unwrap().parse::<f64>().unwrap(),
                    )),
                    _ => {}
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    assert_eq!(root_name, "two <osc>");
    assert_eq!(
        comps,
        vec![
            ("a".to_string(), "resources/a.fmu".to_string()),
            ("b".to_string(), "resources/b.fmu".to_string())
        ]
    );
    assert_eq!(connections, conns);
    assert_eq!(
        values,
        vec![("x0".to_string(), 0.25), ("k".to_string(), 400.0)]
    );
    // inputs and outputs (F, x, v) of both, plus one bound parameter each
    assert_eq!(connectors, 2 * 3 + 2);
    let e = write_ssp(
        &out,
        "s",
        &[("a".into(), a.clone())],
        &[("a.x".into(), "c.F".into())],
        &[],
        1.0,
    )
    .unwrap_err();
    assert!(e.to_string().contains("c.F"), "{e}");
}

/// Largest difference of the recorded `a.x`, `b.x` of two unit oscillators
/// (`m = 1`, `k = 100`) coupled by `F_a = x_b`, `F_b = x_a`, from `x_a(0) = 1`,
/// to the modal solution: `x_a = (cos w1 t + cos w2 t)/2`, `x_b = (cos w1 t -
/// cos w2 t)/2` with the symmetric mode `w1^2 = 99` and the antisymmetric
/// `w2^2 = 101`.
fn modal_error(rec: &crate::master::Recording) -> f64 {
    let (w1, w2) = (99f64.sqrt(), 101f64.sqrt());
    let (xa, xb) = (rec.column("a.x").unwrap(), rec.column("b.x").unwrap());
    let mut err: f64 = 0.0;
    for (k, &t) in rec.time_s.iter().enumerate() {
        let ea = 0.5 * ((w1 * t).cos() + (w2 * t).cos());
        let eb = 0.5 * ((w1 * t).cos() - (w2 * t).cos());
        err = err.max((xa[k] - ea).abs()).max((xb[k] - eb).abs());
    }
    err
}

/// Couple units `a` and `b` (`a.x -> b.F`, `b.x -> a.F`), start `a` at
/// `x0 = 1` and run 2 s with macro steps of 1 ms under `opts` (the algorithm
/// and its options; iteration tolerance 1e-10), recording `a.x`, `b.x`
/// every 10 steps.
fn run_coupled(a: Fmu, b: Fmu, opts: MasterOptions) -> crate::master::Recording {
    let c = vec![
        ("a.x".to_string(), "b.F".to_string()),
        ("b.x".to_string(), "a.F".to_string()),
    ];
    let mut m = Master::new(
        vec![("a".into(), a), ("b".into(), b)],
        &c,
        MasterOptions {
            macro_step_s: 1e-3,
            iteration_rtol: 1e-10,
            ..opts
        },
    )
    .unwrap();
    m.set_parameter(0, "x0", &ParamValue::Real(1.0)).unwrap();
    m.initialize(0.0, None).unwrap();
    let rec = run(&mut m, 2.0, &["a.x".into(), "b.x".into()], 10, &mut |_| {}).unwrap();
    assert!(rec.stopped.is_none());
    rec
}

/// Two test oscillators coupled by forces through the generic master:
/// a.F <- b.x, b.F <- a.x (k_c x of the other): with m = 1, k = 100, the
/// coupling `F_a = c x_b`, `F_b = c x_a` gives modes at omega^2 = 100 -+ c.
/// Here c = 1 through a unit "gain": the test FMU has no gain output, so the
/// forces are x itself (c = 1 N/m by units convention of the connection).
#[test]
fn coupled_oscillators_match_the_modal_solution_for_every_algorithm() {
    let dir = tempfile::tempdir().unwrap();
    for alg in [
        Algorithm::Jacobi,
        Algorithm::GaussSeidel,
        Algorithm::Iterative,
    ] {
        let a = Fmu::load(&test_fmu(dir.path(), "a.fmu", &test_md(TEST_GUID), true)).unwrap();
        let b = Fmu::load(&test_fmu(dir.path(), "b.fmu", &test_md(TEST_GUID), true)).unwrap();
        let rec = run_coupled(
            a,
            b,
            MasterOptions {
                algorithm: alg,
                ..Default::default()
            },
        );
        let err = modal_error(&rec);
        let tol = match alg {
            Algorithm::Iterative => 1e-6,
            _ => 1e-3,
        };
        assert!(err < tol, "{alg:?}: max error {err:e}");
        if alg == Algorithm::Iterative {
            assert!(
                rec.stats.evaluations >= rec.stats.steps && rec.stats.jacobian_builds >= 1,
                "{:?}",
                rec.stats
            );
        }
    }
}

/// Issue 14, item 5: a `modelIdentifier` with a path made the host dlopen a
/// library outside the FMU (its constructor ran) before any check failed.
#[test]
fn model_identifier_must_be_a_plain_file_name() {
    let dir = tempfile::tempdir().unwrap();
    for id in ["/abs/path/x", "../../x", "a/b", "..", "", "x\\y"] {
        let md = test_md(TEST_GUID).replace(
            "modelIdentifier=\"testosc\"",
            &format!("modelIdentifier=\"{id}\""),
        );
        let p = test_fmu(dir.path(), "id.fmu", &md, true);
        match fmu_err(&p) {
            FmuError::BadIdentifier { identifier, .. } => assert_eq!(identifier, id),
            e => panic!("{id}: {e}"),
        }
    }
}

/// Issue 14: a truncated ELF inside an `.fmu` killed the host with SIGBUS;
/// a non-ELF or foreign binary must be an error too, before dlopen.
#[test]
fn truncated_or_foreign_binaries_are_refused_before_loading() {
    let dir = tempfile::tempdir().unwrap();
    let lib = test_lib();
    let md = test_md(TEST_GUID);
    for (what, bytes) in [
        ("half", lib[..lib.len() / 2].to_vec()),
        ("header only", lib[..64].to_vec()),
        ("text", b"not a library".to_vec()),
        ("empty", Vec::new()),
    ] {
        let p = dir.path().join("bad.fmu");
        write_zip(
            &p,
            &[
                ("modelDescription.xml", md.as_bytes().to_vec()),
                ("binaries/linux64/testosc.so", bytes),
            ],
            &[],
        );
        match fmu_err(&p) {
            FmuError::BadBinary { reason, .. } => assert!(!reason.is_empty()),
            e => panic!("{what}: {e}"),
        }
    }
}

/// Issue 14: a duplicate value reference recorded the wrong signal with exit 0;
/// unclosed XML was accepted.
#[test]
fn duplicate_value_references_and_unclosed_xml_are_refused_with_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let md = test_md(TEST_GUID).replace(
        "name=\"v\" valueReference=\"5\"",
        "name=\"v\" valueReference=\"4\"",
    );
    let e = fmu_err(&test_fmu(dir.path(), "dup.fmu", &md, true));
    assert!(
        e.to_string().contains("line 11") && e.to_string().contains("used twice"),
        "{e}"
    );
    let md = test_md(TEST_GUID).replace("</fmiModelDescription>\n", "");
    let e = fmu_err(&test_fmu(dir.path(), "open.fmu", &md, true));
    assert!(e.to_string().contains("not closed"), "{e}");
}

/// Issue 14: a 1.4 MB `.fmu` expanded to 934 MB; entry count and unpacked
/// size are bounded (configurable), and an `.fmu` that is a named pipe or a
/// device is refused at once.
#[test]
fn unpacking_is_bounded_and_only_regular_files_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let good = test_fmu(dir.path(), "ok.fmu", &test_md(TEST_GUID), true);
    let small = ImportLimits {
        max_unpacked_bytes: 1000,
        ..ImportLimits::default()
    };
    assert!(matches!(
        Fmu::load_with(&good, &small),
        Err(FmuError::TooLarge { max: 1000, .. })
    ));
    let few = ImportLimits {
        max_entries: 1,
        ..ImportLimits::default()
    };
    assert!(matches!(
        Fmu::load_with(&good, &few),
        Err(FmuError::TooManyEntries {
            entries: 2,
            max: 1,
            ..
        })
    ));
    Fmu::load_with(&good, &ImportLimits::default()).unwrap();
    // a bomb: 600 MiB of zeros compress to well under 1 MB
    let bomb = dir.path().join("bomb.fmu");
    {
        let f = std::fs::File::create(&bomb).unwrap();
        let mut z = zip::ZipWriter::new(f);
        let o = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .large_file(true);
        z.start_file("resources/zeros", o).unwrap();
        let block = vec![0u8; 1 << 20];
        for _ in 0..600 {
            z.write_all(&block).unwrap();
        }
        z.finish().unwrap();
    }
    assert!(std::fs::metadata(&bomb).unwrap().len() < 2 << 20);
    assert!(matches!(fmu_err(&bomb), FmuError::TooLarge { .. }));
    let t0 = std::time::Instant::now();
    assert!(matches!(
        fmu_err(Path::new("/dev/zero")),
        FmuError::File { .. }
    ));
    let fifo = dir.path().join("pipe.fmu");
    if std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
    {
        let e = fmu_err(&fifo);
        assert!(e.to_string().contains("named pipe"), "{e}");
    }
    assert!(t0.elapsed().as_secs_f64() < 1.0);
}

/// The importer's FMI 3.0 path against a C implementation of the standard's
/// API (`csrc/testosc.c`, independent of the workspace's export layer): the
/// same oscillator as FMI 2.0 and FMI 3.0 gives the same free oscillation bit
/// for bit (inputs held: no input derivatives either way), rollback works,
/// and the token mismatch, an FMU error and a discard come back as errors
/// naming the fmi3 function, with the FMU's (non-variadic) log.
#[test]
fn fmi3_fmus_import_and_step_like_their_fmi2_twins() {
    use crate::import::Version;
    let dir = tempfile::tempdir().unwrap();
    let f2 = Fmu::load(&test_fmu(dir.path(), "osc2.fmu", &test_md(TEST_GUID), true)).unwrap();
    let f3 = Fmu::load(&test_fmu3(dir.path(), "osc3.fmu", &test_md3(TEST_GUID))).unwrap();
    assert_eq!((f2.version(), f3.version()), (Version::Fmi2, Version::Fmi3));
    assert!(!f3.md.co_simulation.can_interpolate_inputs);
    let run = |f: &Fmu| {
        let mut i = f.instantiate("osc", false).unwrap();
        i.set_real(&[1, 9], &[400.0, 1e-3]).unwrap();
        i.setup_experiment(0.0, Some(1.0), None).unwrap();
        i.enter_initialization_mode().unwrap();
        i.exit_initialization_mode().unwrap();
        let (mut xs, mut x) = (Vec::new(), [0.0, 0.0]);
        for n in 0..200 {
            if n == 100 {
                i.save_state().unwrap();
            }
            i.do_step(n as f64 * 1e-3, 1e-3).unwrap();
            i.get_real(&[4, 5], &mut x).unwrap();
            xs.push(x);
        }
        // roll back to t = 0.1 s and step again: the same value
        i.restore_state().unwrap();
        i.do_step(0.1, 1e-3).unwrap();
        i.get_real(&[4, 5], &mut x).unwrap();
        assert_eq!(x, xs[100]);
        let mut d = [f64::NAN; 2];
        if f.version() == Version::Fmi3 {
            i.directional_derivative(&[4, 5], &[3], &[1.0], &mut d)
                .unwrap();
            assert_eq!(d, [0.0, 0.0], "x, v do not depend directly on F");
        } else {
            assert!(i
                .directional_derivative(&[4, 5], &[3], &[1.0], &mut d)
                .is_err());
        }
        xs
    };
    let (x2, x3) = (run(&f2), run(&f3));
    assert_eq!(x2, x3);
    assert!((x3[199][0] - 1e-3 * (20.0f64 * 0.2).cos()).abs() < 1e-8);

    let bad = Fmu::load(&test_fmu3(dir.path(), "tok.fmu", &test_md3("{another}"))).unwrap();
    let e = bad.instantiate("t", false).err().unwrap().to_string();
    assert!(
        e.contains("fmi3InstantiateCoSimulation")
            && e.contains("token mismatch: expected {host-test-osc-0001}, got {another}"),
        "{e}"
    );
    for (param, status) in [("fail_at_s", "fmi3Error"), ("discard_at_s", "fmi3Discard")] {
        let mut i = f3.instantiate("f", false).unwrap();
        i.set_real(&[if param == "fail_at_s" { 6 } else { 7 }], &[0.0105])
            .unwrap();
        i.setup_experiment(0.0, None, None).unwrap();
        i.enter_initialization_mode().unwrap();
        i.exit_initialization_mode().unwrap();
        let e = (0..20)
            .find_map(|n| i.do_step(n as f64 * 1e-3, 1e-3).err())
            .expect("the step past 0.0105 s fails")
            .to_string();
        assert!(
            e.contains("fmi3DoStep")
                && e.contains(status)
                && e.contains("injected")
                && e.contains("t = 0.01 s"),
            "{e}"
        );
    }
    // a binary in the FMI 2.0 folder only is missing for FMI 3.0
    let p = dir.path().join("nobin3.fmu");
    write_zip(
        &p,
        &[
            ("modelDescription.xml", test_md3(TEST_GUID).into_bytes()),
            ("binaries/linux64/testosc.so", test_lib()),
        ],
        &[],
    );
    let e = fmu_err(&p).to_string();
    assert!(e.contains("-linux/testosc.so"), "{e}");
}

/// A mixed FMI 2.0 / FMI 3.0 pair in every master algorithm: the coupled
/// oscillators' modal solution. The FMI 3.0 unit holds its input over each
/// step (no input derivatives), a first-order error in `h` also for the
/// iterative master (measured 2.2e-5 at h = 1e-3, against 1e-7 with two FMI
/// 2.0 units interpolating linearly), hence the tolerance 1e-4 there. The
/// iterative master takes its first Jacobian from directional derivatives
/// (the FMI 3.0 unit provides them; the FMI 2.0 unit has no feedthrough) and
/// converges to the same coupled solution as with finite differences (to
/// its tolerance, 1e-10 per connection).
#[test]
fn mixed_fmi2_fmi3_pair_matches_the_modal_solution() {
    let dir = tempfile::tempdir().unwrap();
    let run_pair = |alg: Algorithm, directional: bool| {
        let a = Fmu::load(&test_fmu3(dir.path(), "a3.fmu", &test_md3(TEST_GUID))).unwrap();
        let b = Fmu::load(&test_fmu(dir.path(), "b2.fmu", &test_md(TEST_GUID), true)).unwrap();
        run_coupled(
            a,
            b,
            MasterOptions {
                algorithm: alg,
                directional_derivatives: directional,
                ..Default::default()
            },
        )
    };
    for alg in [
        Algorithm::Jacobi,
        Algorithm::GaussSeidel,
        Algorithm::Iterative,
    ] {
        let rec = run_pair(alg, true);
        let err = modal_error(&rec);
        let tol = match alg {
            Algorithm::Iterative => 1e-4,
            _ => 2e-3,
        };
        assert!(err < tol, "{alg:?}: max error {err:e}");
        if alg == Algorithm::Iterative {
            assert_eq!(
                (rec.stats.directional_jacobians, rec.stats.jacobian_builds),
                (1, 0),
                "{:?}",
                rec.stats
            );
            let fd = run_pair(alg, false);
            assert_eq!(fd.stats.directional_jacobians, 0);
            assert!(fd.stats.jacobian_builds >= 1);
            let d = rec
                .column("a.x")
                .unwrap()
                .iter()
                .zip(fd.column("a.x").unwrap())
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f64::max);
            assert!(d < 1e-8, "directional vs finite-difference Jacobian: {d:e}");
        }
    }
}
