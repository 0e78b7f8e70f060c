//! `[structure] kind = "matrices"` end to end.
//!
//! * The paper beam, written to Matrix Market files by this test (its full `M`
//!   and `K` from `nlmode`'s beam) and read back as `kind = "matrices"` with the
//!   same points (`tip`, `2l3`, `l3`), damping (`D0 = 0.4 %` stiffness-proportional
//!   on mode 1), reduction (Craig-Bampton, master `tip`, 10 modes) and cubic
//!   spring, reproduces the beam scenario's `omega0`, NMA table and case-(a)
//!   envelopes of `nlmode` and `reference` to 1e-9 (relative to each array's
//!   largest value).
//! * Bad matrices input through the CLI: one message naming the key (and the file,
//!   the line), exit 2, no panic.
//! * The example `examples/matrices_frame.toml` runs with `host run`.
use crate::common::{expect_failure, host, scenario, tmpdir};
use host::methods;
use host::model::Setup;
use host::scenario::{Method, Scenario};
use nlmode::structure::matrices::write_matrix_market;
use nlmode::structure::{paper_structure, PaperStructureOptions};
use std::path::Path;

/// The paper beam as a matrices scenario in `dir` (files `M.mtx`, `K.mtx`).
fn beam_as_matrices(dir: &Path) -> Scenario {
    let ps = paper_structure(&PaperStructureOptions::default()).unwrap();
    let b = &ps.beam;
    std::fs::write(dir.join("M.mtx"), write_matrix_market(&b.model.mass)).unwrap();
    std::fs::write(dir.join("K.mtx"), write_matrix_market(&b.model.stiffness)).unwrap();
    let l = b.spec.length_m;
    let dof = |x: f64| b.translation_dof(b.node_at(x).unwrap()).unwrap();
    let text = format!(
        "[structure]\nkind = \"matrices\"\nmass_mtx = \"M.mtx\"\nstiffness_mtx = \"K.mtx\"\n\
         damping_ratio = 0.004\ndamping_mode = 1\nreduction = \"craig-bampton\"\ncb_modes = 10\n\
         cb_masters = [\"tip\"]\nk3_n_per_m3 = 6e9\nnonlinear_point = \"tip\"\n\
         [[structure.point]]\nname = \"tip\"\ndof = {}\n\
         [[structure.point]]\nname = \"2l3\"\ndof = {}\n\
         [[structure.point]]\nname = \"l3\"\ndof = {}\n\
         [[exciter]]\npoint = \"2l3\"\n[output]\nresponse_point = \"tip\"\n",
        dof(l),
        dof(2.0 * l / 3.0),
        dof(l / 3.0)
    );
    scenario(dir, &text)
}

fn assert_close(what: &str, a: &[f64], b: &[f64], rtol: f64) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    let scale = a.iter().chain(b).fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= rtol * scale,
            "{what}[{i}]: {x} vs {y} (scale {scale:e})"
        );
    }
}

#[test]
fn the_paper_beam_read_back_from_matrix_market_reproduces_the_beam() {
    let dir = tmpdir("beam");
    let mtx = beam_as_matrices(&dir);
    let beam = Scenario::default_scenario();
    let (sb, sm) = (Setup::new(&beam).unwrap(), Setup::new(&mtx).unwrap());
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    assert!(rel(sm.omega0_rad_s, sb.omega0_rad_s) < 1e-12);
    assert!((sm.omega0_rad_s - 356.2).abs() < 0.1);
    assert_eq!(
        (sm.full_ndof, sm.model.ndof()),
        (sb.full_ndof, sb.model.ndof())
    );
    assert!(rel(sm.d0, sb.d0) < 1e-9, "{} vs {}", sm.d0, sb.d0);
    assert_eq!(sm.exciter_points, sb.exciter_points);
    for (mb, mm) in sb.modal_masses.iter().zip(&sm.modal_masses) {
        assert!(rel(mm.0, mb.0) < 1e-9 && rel(mm.1, mb.1) < 1e-9);
    }
    // the NMA table
    let (tb, _) = methods::nma_table(&sb, &beam, false).unwrap();
    let (tm, _) = methods::nma_table(&sm, &mtx, false).unwrap();
    let (tb, tm) = (&tb.table, &tm.table);
    assert!(tb.amplitude.len() > 10);
    assert_close("amplitude", &tm.amplitude, &tb.amplitude, 1e-9);
    assert_close("omega", &tm.omega_rad_s, &tb.omega_rad_s, 1e-9);
    assert_close("damping", &tm.damping_ratio, &tb.damping_ratio, 1e-9);
    for p in &tb.points {
        let q = tm.points.iter().find(|q| q.name == p.name).unwrap();
        let flat = |v: &Vec<Vec<f64>>| v.iter().flatten().copied().collect::<Vec<f64>>();
        assert_close(&format!("{} re", p.name), &flat(&q.re), &flat(&p.re), 1e-9);
        assert_close(&format!("{} im", p.name), &flat(&q.im), &flat(&p.im), 1e-9);
    }
    // case (a) by nlmode and reference
    let opts = beam.slowflow.options(Method::Nlmode);
    let nb = methods::reduced_model(&sb, tb, None).unwrap();
    let nm = methods::reduced_model(&sm, tm, None).unwrap();
    let (rb, _) = methods::slow_flow("nlmode", &sb, &nb, &opts).unwrap();
    let (rm, _) = methods::slow_flow("nlmode", &sm, &nm, &opts).unwrap();
    let (b, m) = (&rb.envelope, &rm.envelope);
    assert_close("nlmode omega", &m.omega_rad_s, &b.omega_rad_s, 1e-9);
    assert_close("nlmode tip", &m.tip_amplitude_m, &b.tip_amplitude_m, 1e-9);
    assert_close(
        "nlmode force",
        &m.force_amplitude_n,
        &b.force_amplitude_n,
        1e-9,
    );
    let peak = rm
        .envelope
        .tip_amplitude_m
        .iter()
        .fold(0.0f64, |a, b| a.max(*b));
    assert!((peak - 2.274e-3).abs() < 0.01e-3, "nlmode peak {peak}");
    let fb = methods::reference(&sb, &beam, &mut |_| {}).unwrap();
    let fm = methods::reference(&sm, &mtx, &mut |_| {}).unwrap();
    assert_close(
        "reference omega",
        &fm.envelope.omega_rad_s,
        &fb.envelope.omega_rad_s,
        1e-9,
    );
    assert_close(
        "reference tip",
        &fm.envelope.tip_amplitude_m,
        &fb.envelope.tip_amplitude_m,
        1e-9,
    );
    assert_close(
        "reference force",
        &fm.envelope.force_amplitude_n,
        &fb.envelope.force_amplitude_n,
        1e-9,
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_matrices_input_names_the_key_and_exits_2() {
    let dir = tmpdir("bad");
    let m2 = "%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n1 1 1.0\n2 2 2.0\n";
    let k2 = "%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 3e4\n2 1 -1e4\n2 2 1e4\n";
    std::fs::write(dir.join("M.mtx"), m2).unwrap();
    std::fs::write(dir.join("K.mtx"), k2).unwrap();
    std::fs::write(
        dir.join("bad_line.mtx"),
        "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1.0\n2 2 two\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("K3.mtx"),
        "%%MatrixMarket matrix array real general\n3 3\n1\n0\n0\n0\n1\n0\n0\n0\n1\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("Kasym.mtx"),
        "%%MatrixMarket matrix coordinate real general\n2 2 3\n1 1 3e4\n2 1 -1e4\n2 2 1e4\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("Mindef.mtx"),
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 1.0\n2 1 3.0\n2 2 2.0\n",
    )
    .unwrap();
    let sc = |mass: &str, stiff: &str, extra: &str, dof_b: usize| {
        format!(
            "[structure]\nkind = \"matrices\"\nmass_mtx = \"{mass}\"\nstiffness_mtx = \"{stiff}\"\n\
             rayleigh = [0.0, 1e-4]\nreduction = \"none\"\nk3_n_per_m3 = 1e9\nnonlinear_point = \"b\"\n{extra}\
             [[structure.point]]\nname = \"a\"\ndof = 0\n[[structure.point]]\nname = \"b\"\ndof = {dof_b}\n\
             [[exciter]]\npoint = \"a\"\n[output]\nresponse_point = \"b\"\n"
        )
    };
    let ok = sc("M.mtx", "K.mtx", "", 1);
    // the good one parses and builds (relative paths from the scenario's folder)
    let mut good = Scenario::parse(&ok).unwrap();
    good.resolve_paths(&dir);
    let s = Setup::new(&good).unwrap();
    assert_eq!(s.model.ndof(), 2);
    assert!(s.omega0_rad_s > 0.0 && s.d0 > 0.0);
    expect_failure(
        &dir,
        "nma",
        &sc("missing.mtx", "K.mtx", "", 1),
        &["structure.mass_mtx", "missing.mtx", "cannot read"],
    );
    expect_failure(
        &dir,
        "nma",
        &sc("M.mtx", "bad_line.mtx", "", 1),
        &["structure.stiffness_mtx", "bad_line.mtx", "line 4"],
    );
    expect_failure(
        &dir,
        "nma",
        &sc("M.mtx", "K3.mtx", "", 1),
        &["structure.stiffness_mtx", "3x3", "mass_mtx is 2x2"],
    );
    expect_failure(
        &dir,
        "nma",
        &sc("M.mtx", "Kasym.mtx", "", 1),
        &["structure.stiffness_mtx", "not symmetric"],
    );
    expect_failure(
        &dir,
        "nma",
        &sc("Mindef.mtx", "K.mtx", "", 1),
        &["structure.mass_mtx", "not positive definite"],
    );
    expect_failure(
        &dir,
        "nma",
        &sc("M.mtx", "K.mtx", "", 2),
        &["structure.point[1].dof", "out of range"],
    );
    expect_failure(
        &dir,
        "nma",
        &ok.replace("name = \"b\"", "name = \"a\""),
        &["structure.point[1].name", "unique"],
    );
    expect_failure(
        &dir,
        "nma",
        &ok.replace("response_point = \"b\"", "response_point = \"c\""),
        &["output.response_point", "unknown point 'c'"],
    );
    expect_failure(
        &dir,
        "nma",
        &ok.replace("point = \"a\"\n[output]", "point = \"z\"\n[output]"),
        &["exciter[0].point", "unknown point 'z'"],
    );
    expect_failure(
        &dir,
        "nma",
        &ok.replace("k3_n_per_m3 = 1e9", "k3_n_per_m3 = -1e9"),
        &["structure.k3_n_per_m3"],
    );
    expect_failure(
        &dir,
        "nma",
        &ok.replace("rayleigh = [0.0, 1e-4]", "rayleigh = [0.0, -1e-4]"),
        &["structure.rayleigh[1]"],
    );
    expect_failure(
        &dir,
        "nma",
        &ok.replace("rayleigh = [0.0, 1e-4]\n", ""),
        &["structure.damping_mtx", "exactly one"],
    );
    expect_failure(
        &dir,
        "nma",
        &ok.replace("[output]", "location = \"l/3\"\n[output]"),
        &["exciter[0].location", "point"],
    );
    expect_failure(
        &dir,
        "nma",
        &ok.replace("reduction = \"none\"", "length_m = 1.0"),
        &["structure.length_m", "not a key of kind"],
    );
    // a rigid-body mode (free-free two-mass chain): refused unless confirmed
    std::fs::write(
        dir.join("Kfree.mtx"),
        "%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 1e4\n2 1 -1e4\n2 2 1e4\n",
    )
    .unwrap();
    expect_failure(
        &dir,
        "nma",
        &sc("M.mtx", "Kfree.mtx", "", 1),
        &[
            "structure.stiffness_mtx",
            "rigid-body mode",
            "allow_rigid_body_modes",
        ],
    );
    let mut free = Scenario::parse(&sc(
        "M.mtx",
        "Kfree.mtx",
        "allow_rigid_body_modes = true\n",
        1,
    ))
    .unwrap();
    free.resolve_paths(&dir);
    let s = Setup::new(&free).unwrap();
    assert_eq!(s.mode_index, 1);
    // the elastic mode of the free two-mass chain: k (1/m1 + 1/m2)
    let w = (1e4f64 * (1.0 + 0.5)).sqrt();
    assert!((s.omega0_rad_s - w).abs() < 1e-9 * w, "{}", s.omega0_rad_s);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_frame_example_runs_with_host_run() {
    let out = tmpdir("frame");
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/matrices_frame.toml");
    let o = host()
        .arg("run")
        .arg(&example)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "stdout: {stdout}\nstderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["full_ndof"].as_u64(), Some(33));
    let peak = |m: &str| s["methods"][m]["peak_tip_amplitude_m"].as_f64().unwrap();
    for m in [
        "reference",
        "nlmode",
        "linear-frf",
        "linear-steady",
        "cosim",
    ] {
        assert!(peak(m).is_finite() && peak(m) > 0.0, "{m}");
    }
    // the reduced model follows the reference and cosim the nlmode path
    let r = peak("reference");
    assert!(
        (peak("nlmode") - r).abs() < 0.05 * r,
        "{} vs {r}",
        peak("nlmode")
    );
    assert!(
        (peak("cosim") - r).abs() < 0.05 * r,
        "{} vs {r}",
        peak("cosim")
    );
    // cosim of the matrix model through the structure FMU's modal table (drive
    // point and response point by name) against nlmode: the beam's
    // cosim-vs-nlmode tolerances for the peak (3 %) and the jump-down (1 %); the
    // RMS envelope differences measured here (2026-12-02) are 5.1 % (tip) and
    // 7.7 % (force) of the peaks, above the beam's 5 % (measured there: 4.5 %,
    // 3.7 %), so they are held at 10 %, a factor-of-2 error still fails
    let env =
        |m: &str| host::results::read_envelope(&out.join(format!("{m}_envelope.csv"))).unwrap();
    let (c, n) = (env("cosim"), env("nlmode"));
    let cmp = c.compare_with(&n.omega_rad_s, &n.force_amplitude_n, &n.tip_amplitude_m);
    eprintln!("frame cosim vs nlmode: {cmp:?}");
    assert!(cmp.overlap >= 200, "{cmp:?}");
    assert!(cmp.peak_tip_rel.abs() < 0.03, "{cmp:?}");
    assert!(cmp.jump_down_rel.abs() < 0.01, "{cmp:?}");
    assert!(
        cmp.rms_tip_rel < 0.10 && cmp.rms_force_rel < 0.10,
        "{cmp:?}"
    );
    std::fs::remove_dir_all(&out).ok();
}

/// A 3-DOF spring-mass chain: masses 1, 2, 3 kg; springs 100 N/m (ground to
/// mass 1), 200, 300 N/m between the masses, 100 N/m (mass 3 to ground).
const CHAIN_M: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]];
const CHAIN_K: [[f64; 3]; 3] = [
    [300.0, -200.0, 0.0],
    [-200.0, 500.0, -300.0],
    [0.0, -300.0, 400.0],
];

/// `(row, col, value)` of the lower triangle's non-zeros, by columns.
fn lower(a: &[[f64; 3]; 3]) -> Vec<(usize, usize, f64)> {
    let mut t = Vec::new();
    for c in 0..3 {
        for (r, row) in a.iter().enumerate().skip(c) {
            if row[c] != 0.0 {
                t.push((r, c, row[c]));
            }
        }
    }
    t
}

fn chain_mm(a: &[[f64; 3]; 3]) -> String {
    let t = lower(a);
    let mut s = format!(
        "%%MatrixMarket matrix coordinate real symmetric\n3 3 {}\n",
        t.len()
    );
    for (r, c, v) in t {
        s += &format!("{} {} {:.16e}\n", r + 1, c + 1, v);
    }
    s
}

/// Rutherford-Boeing `RSA`, values in `(3E20.12)` with `D` exponents.
fn chain_hb(a: &[[f64; 3]; 3]) -> String {
    let t = lower(a);
    let mut ptr = vec![1usize];
    for c in 0..3 {
        ptr.push(ptr[c] + t.iter().filter(|e| e.1 == c).count());
    }
    let ints = |v: &[usize]| v.iter().map(|x| format!("{x:>8}")).collect::<String>();
    let rows: Vec<usize> = t.iter().map(|e| e.0 + 1).collect();
    let mut vals = String::new();
    for (k, (_, _, v)) in t.iter().enumerate() {
        vals += &format!("{:>20}", format!("{v:.12E}").replace('E', "D"));
        if k % 3 == 2 || k + 1 == t.len() {
            vals.push('\n');
        }
    }
    let nval = t.len().div_ceil(3);
    format!(
        "{:<72}{:<8}\n{:>14}{:>14}{:>14}{:>14}\n{:<14}{:>14}{:>14}{:>14}{:>14}\n{:<16}{:<16}{:<20}\n{}\n{}\n{vals}",
        "3-DOF chain",
        "chain",
        2 + nval,
        1,
        1,
        nval,
        "RSA",
        3,
        3,
        t.len(),
        0,
        "(10I8)",
        "(10I8)",
        "(3E20.12)",
        ints(&ptr),
        ints(&rows)
    )
}

/// Abaqus' labels format: DOF 1 of nodes 10, 20, 30, the upper triangle.
fn chain_abaqus(a: &[[f64; 3]; 3]) -> String {
    let mut s = String::from("** generated by the test\n");
    for (r, c, v) in lower(a) {
        s += &format!("{},1, {},1, {:.16e}\n", 10 * (c + 1), 10 * (r + 1), v);
    }
    s
}

fn gzip(text: &str) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(text.as_bytes()).unwrap();
    e.finish().unwrap()
}

fn chain_scenario(mass: &str, stiff: &str, extra: &str, points: &str) -> String {
    format!(
        "[structure]\nkind = \"matrices\"\nmass_mtx = \"{mass}\"\nstiffness_mtx = \"{stiff}\"\n{extra}\
         rayleigh = [0.0, 1e-4]\nreduction = \"none\"\nk3_n_per_m3 = 1e9\nnonlinear_point = \"b\"\n{points}\
         [[exciter]]\npoint = \"a\"\n[output]\nresponse_point = \"b\"\n"
    )
}

const DOF_POINTS: &str =
    "[[structure.point]]\nname = \"a\"\ndof = 0\n[[structure.point]]\nname = \"b\"\ndof = 2\n";
const NODE_POINTS: &str = "[[structure.point]]\nname = \"a\"\nnode = 10\ndirection = \"x\"\n\
    [[structure.point]]\nname = \"b\"\nnode = 30\ndirection = 1\n";

#[test]
fn every_matrix_format_gives_the_same_omega0() {
    let dir = tmpdir("formats");
    let w = |name: &str, bytes: &[u8]| std::fs::write(dir.join(name), bytes).unwrap();
    w("M.mtx", chain_mm(&CHAIN_M).as_bytes());
    w("K.mtx", chain_mm(&CHAIN_K).as_bytes());
    w("M.mtx.gz", &gzip(&chain_mm(&CHAIN_M)));
    w("K.mtx.gz", &gzip(&chain_mm(&CHAIN_K)));
    w("M.rsa", chain_hb(&CHAIN_M).as_bytes());
    w("K.rb", chain_hb(&CHAIN_K).as_bytes());
    w("job_MASS1.mtx", chain_abaqus(&CHAIN_M).as_bytes());
    w("job_STIF1.mtx", chain_abaqus(&CHAIN_K).as_bytes());
    let cases = [
        chain_scenario("M.mtx", "K.mtx", "", DOF_POINTS),
        chain_scenario("M.mtx.gz", "K.mtx.gz", "", DOF_POINTS),
        chain_scenario(
            "M.mtx.gz",
            "K.mtx.gz",
            "matrix_format = \"matrix-market\"\n",
            DOF_POINTS,
        ),
        chain_scenario("M.rsa", "K.rb", "", DOF_POINTS),
        chain_scenario(
            "M.rsa",
            "K.rb",
            "matrix_format = \"harwell-boeing\"\n",
            DOF_POINTS,
        ),
        chain_scenario("job_MASS1.mtx", "job_STIF1.mtx", "", NODE_POINTS),
        chain_scenario(
            "job_MASS1.mtx",
            "job_STIF1.mtx",
            "matrix_format = \"abaqus\"\n",
            DOF_POINTS,
        ),
    ];
    let reference = Setup::new(&scenario(&dir, &cases[0])).unwrap();
    assert!(reference.omega0_rad_s > 0.0);
    assert_eq!(reference.model.ndof(), 3);
    for text in &cases[1..] {
        let s = Setup::new(&scenario(&dir, text)).unwrap_or_else(|e| panic!("{e:#}\n{text}"));
        let (a, b) = (s.omega0_rad_s, reference.omega0_rad_s);
        assert!((a - b).abs() <= 1e-12 * b, "{a} vs {b}\n{text}");
        assert_eq!(s.d0, reference.d0, "{text}");
    }
    // host nma runs on the labelled files (points by node and direction)
    let p = dir.join("abaqus.toml");
    std::fs::write(&p, &cases[5]).unwrap();
    let o = host()
        .arg("nma")
        .arg(&p)
        .arg("-o")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_matrix_files_of_every_format_name_the_key_file_and_line() {
    let dir = tmpdir("badformats");
    let w = |name: &str, bytes: &[u8]| std::fs::write(dir.join(name), bytes).unwrap();
    w("M.mtx", chain_mm(&CHAIN_M).as_bytes());
    w("K.mtx", chain_mm(&CHAIN_K).as_bytes());
    w("job_MASS1.mtx", chain_abaqus(&CHAIN_M).as_bytes());
    w("job_STIF1.mtx", chain_abaqus(&CHAIN_K).as_bytes());
    // gzip: a malformed entry on line 4
    let k = chain_mm(&CHAIN_K).replacen("2 1 ", "2 x ", 1);
    w("K_bad.mtx.gz", &gzip(&k));
    expect_failure(
        &dir,
        "nma",
        &chain_scenario("M.mtx", "K_bad.mtx.gz", "", DOF_POINTS),
        &[
            "structure.stiffness_mtx",
            "K_bad.mtx.gz",
            "line 4",
            "column",
        ],
    );
    // Harwell-Boeing: a value that is not a number (line 7), an infinite value
    let hb = chain_hb(&CHAIN_K);
    w(
        "K_bad.rsa",
        hb.replacen("-2.000000000000D2", &format!("{:>17}", "-2.0x0D2"), 1)
            .as_bytes(),
    );
    expect_failure(
        &dir,
        "nma",
        &chain_scenario("M.mtx", "K_bad.rsa", "", DOF_POINTS),
        &["structure.stiffness_mtx", "K_bad.rsa", "line 7", "values"],
    );
    w(
        "K_inf.rsa",
        hb.replacen("-2.000000000000D2", &format!("{:>17}", "inf"), 1)
            .as_bytes(),
    );
    expect_failure(
        &dir,
        "nma",
        &chain_scenario("M.mtx", "K_inf.rsa", "", DOF_POINTS),
        &[
            "structure.stiffness_mtx",
            "K_inf.rsa",
            "line 7",
            "non-finite",
        ],
    );
    // Abaqus: a truncated line (line 3)
    let ab = chain_abaqus(&CHAIN_M);
    let mut lines: Vec<&str> = ab.lines().collect();
    lines[2] = "20,1, 20";
    w("M_bad.mtx", (lines.join("\n") + "\n").as_bytes());
    expect_failure(
        &dir,
        "nma",
        &chain_scenario("M_bad.mtx", "job_STIF1.mtx", "", NODE_POINTS),
        &["structure.mass_mtx", "M_bad.mtx", "line 3", "node, dof"],
    );
    // a format that the file is not
    expect_failure(
        &dir,
        "nma",
        &chain_scenario(
            "M.mtx",
            "K.mtx",
            "matrix_format = \"harwell-boeing\"\n",
            DOF_POINTS,
        ),
        &["structure.mass_mtx", "M.mtx", "line 2", "Harwell-Boeing"],
    );
    expect_failure(
        &dir,
        "nma",
        &chain_scenario("M.mtx", "K.mtx", "matrix_format = \"csv\"\n", DOF_POINTS),
        &["structure.matrix_format"],
    );
    // a node or direction not in the labelled files
    expect_failure(
        &dir,
        "nma",
        &chain_scenario(
            "job_MASS1.mtx",
            "job_STIF1.mtx",
            "",
            &NODE_POINTS.replace("node = 30", "node = 40"),
        ),
        &["structure.point[1].node", "node 40", "job_MASS1.mtx"],
    );
    expect_failure(
        &dir,
        "nma",
        &chain_scenario(
            "job_MASS1.mtx",
            "job_STIF1.mtx",
            "",
            &NODE_POINTS.replace("direction = 1", "direction = \"y\""),
        ),
        &["structure.point[1].node", "node 30", "direction 2"],
    );
    expect_failure(
        &dir,
        "nma",
        &chain_scenario(
            "job_MASS1.mtx",
            "job_STIF1.mtx",
            "",
            &NODE_POINTS.replace("direction = 1", "direction = \"q\""),
        ),
        &["structure.point[1].direction", "\"rx\""],
    );
    expect_failure(
        &dir,
        "nma",
        &chain_scenario(
            "job_MASS1.mtx",
            "job_STIF1.mtx",
            "",
            &NODE_POINTS.replace("direction = 1\n", ""),
        ),
        &["structure.point[1].direction", "missing"],
    );
    // node and direction on unlabelled files; labelled and unlabelled mixed
    expect_failure(
        &dir,
        "nma",
        &chain_scenario("M.mtx", "K.mtx", "", NODE_POINTS),
        &["structure.point[0].node", "labelled", "M.mtx"],
    );
    expect_failure(
        &dir,
        "nma",
        &chain_scenario("job_MASS1.mtx", "K.mtx", "", DOF_POINTS),
        &["structure.stiffness_mtx", "K.mtx", "no node labels"],
    );
    std::fs::remove_dir_all(&dir).ok();
}
