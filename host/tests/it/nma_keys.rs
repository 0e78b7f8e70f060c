//! The `[nma]` keys of issue 22 (`mode`, `start_amplitude_m`, `samples`,
//! `harmonics = "auto"`, `initial_slider`) and `host nma` on a matrices
//! structure without an exciter, checked against closed forms:
//!
//! * two unit masses in a chain (`k = 1e4 N/m` to ground and between them,
//!   Rayleigh `C = beta K`): `omega_{1,2}^2 = k (3 -+ sqrt 5) / 2`,
//!   `D_j = beta omega_j / 2`; the table at its small-amplitude end follows mode
//!   `[nma] mode`.
//! * one mass on a spring with a quadratic spring and a stuck Jenkins element:
//!   the mean displacement of the stuck motion is `u0 = -c2 x^2 / (2 k_s)` with
//!   the static stiffness `k_s = k` for `initial_slider = "mean"` (the stuck
//!   element carries no static force) and `k + k_t` for `"zero"`.
use crate::common::{expect_failure, host, scenario, tmpdir, write_mtx};
use host::methods;
use host::model::Setup;
use nalgebra::DMatrix;
use std::path::Path;

const K: f64 = 1e4;
const BETA: f64 = 1e-4;

/// The two-mass chain in `dir` (`M.mtx`, `K.mtx`), points `a` (mass 1) and
/// `b` (mass 2), a weak cubic spring at `b`, no exciter, plus `extra`.
fn chain(dir: &Path, extra: &str) -> String {
    write_mtx(dir, "M.mtx", &DMatrix::identity(2, 2));
    write_mtx(
        dir,
        "K.mtx",
        &DMatrix::from_row_slice(2, 2, &[2.0 * K, -K, -K, K]),
    );
    format!(
        "[structure]\nkind = \"matrices\"\nmass_mtx = \"M.mtx\"\nstiffness_mtx = \"K.mtx\"\n\
         rayleigh = [0.0, {BETA}]\nreduction = \"none\"\n\
         [[structure.point]]\nname = \"a\"\ndof = 0\n[[structure.point]]\nname = \"b\"\ndof = 1\n\
         [[nonlinearity]]\ntype = \"cubic-spring\"\npoint = \"b\"\nk3_n_per_m3 = 1e8\n\
         [output]\nresponse_point = \"b\"\n{extra}"
    )
}

fn omega_closed_form(mode: usize) -> f64 {
    let s5 = 5f64.sqrt();
    (K * if mode == 1 {
        (3.0 - s5) / 2.0
    } else {
        (3.0 + s5) / 2.0
    })
    .sqrt()
}

#[test]
fn nma_follows_the_mode_asked_for_from_the_start_amplitude() {
    let dir = tmpdir("modes");
    for mode in [1usize, 2] {
        let text = chain(
            &dir,
            &format!(
                "[nma]\nmode = {mode}\nstart_amplitude_m = 1e-6\nmax_tip_amplitude_m = 1e-3\nharmonics = 3\nconservative = false\n"
            ),
        );
        let sc = scenario(&dir, &text);
        assert!(sc.exciter.is_empty(), "no default exciter on matrices");
        let setup = Setup::new(&sc).unwrap();
        let w = omega_closed_form(mode);
        assert!(
            (setup.omega0_rad_s / w - 1.0).abs() < 1e-12,
            "mode {mode}: omega0 {} vs {w}",
            setup.omega0_rad_s
        );
        assert!(
            (setup.d0 / (BETA * w / 2.0) - 1.0).abs() < 1e-10,
            "D0 {}",
            setup.d0
        );
        let (nma, _) = methods::nma_table(&setup, &sc, false).unwrap();
        let t = &nma.table;
        // the first point is the start: |q_b,1| = 1e-6 m, linear within
        // k3 x^2 / k ~ 1e-8
        assert!(
            (t.omega_rad_s[0] / w - 1.0).abs() < 1e-7,
            "{}",
            t.omega_rad_s[0]
        );
        assert!(
            (t.damping_ratio[0] / (BETA * w / 2.0) - 1.0).abs() < 1e-6,
            "{}",
            t.damping_ratio[0]
        );
        let b = t.points.iter().find(|p| p.name == "b").unwrap();
        let tip = (b.re[0][1].powi(2) + b.im[0][1].powi(2)).sqrt() * t.amplitude[0];
        assert!((tip / 1e-6 - 1.0).abs() < 1e-6, "start |q_b,1| = {tip:e}");
        assert!(nma.note.contains(&format!("mode {mode}")), "{}", nma.note);
        // hardening cubic: omega rises with the amplitude
        assert!(t.omega_rad_s.last().unwrap() > &(w * (1.0 + 1e-4)));
    }
}

#[test]
fn host_nma_runs_on_matrices_without_an_exciter_and_host_run_says_what_is_missing() {
    let dir = tmpdir("noexciter");
    let text = chain(&dir, "[nma]\nharmonics = 3\nmax_tip_amplitude_m = 1e-3\n");
    let p = dir.join("s.toml");
    std::fs::write(&p, &text).unwrap();
    let out = dir.join("out");
    let o = host()
        .arg("nma")
        .arg(&p)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(o.status.success(), "{so}\n{se}");
    let t = nlmode::nma::ModalTable::read(&out.join("modal_table.json")).unwrap();
    assert!((t.omega_rad_s[0] / omega_closed_form(1) - 1.0).abs() < 1e-7);
    assert!(out.join("damped_branch.csv").is_file());
    expect_failure(&dir, "run", &text, &["exciter", "host nma"]);
    expect_failure(&dir, "frf", &text, &["exciter", "host nma"]);
}

#[test]
fn bad_nma_keys_name_the_key() {
    let dir = tmpdir("badkeys");
    let base = chain(&dir, "");
    let cases: &[(&str, &[&str])] = &[
        ("[nma]\nmode = 3\n", &["nma.mode", "2 modes"]),
        ("[nma]\nmode = 0\n", &["nma.mode", "1 <= mode"]),
        ("[nma]\nsamples = 20\n", &["nma.samples", "4H+1 = 29"]),
        (
            "[nma]\nsamples = 20000\nharmonics = 50\n",
            &["nma.samples", "16384"],
        ),
        (
            "[nma]\nstart_amplitude_m = 0.05\n",
            &["nma.start_amplitude_m", "2e-2"],
        ),
        (
            "[nma]\nstart_amplitude_m = -1.0\n",
            &["nma.start_amplitude_m"],
        ),
        ("[nma]\nharmonics = \"many\"\n", &["nma.harmonics", "auto"]),
        ("[nma]\nharmonics = 0\n", &["nma.harmonics"]),
    ];
    for (extra, needles) in cases {
        expect_failure(&dir, "nma", &format!("{base}{extra}"), needles);
    }
    let slider = base.replace(
        "[output]",
        "[[nonlinearity]]\ntype = \"elastic-dry-friction\"\npoint = \"a\"\n\
         tangential_stiffness_n_per_m = 1e3\nslip_force_n = 1.0\ninitial_slider = \"stuck\"\n[output]",
    );
    expect_failure(
        &dir,
        "nma",
        &slider,
        &["nonlinearity[1].initial_slider", "mean", "zero"],
    );
    let wrong_type = base.replace(
        "k3_n_per_m3 = 1e8\n",
        "k3_n_per_m3 = 1e8\ninitial_slider = \"zero\"\n",
    );
    expect_failure(
        &dir,
        "nma",
        &wrong_type,
        &["nonlinearity[0].initial_slider", "cubic-spring"],
    );
}

#[test]
fn initial_slider_sets_the_static_force_of_a_stuck_jenkins_element() {
    let dir = tmpdir("slider");
    let (k, kt, c2) = (1e4, 3e3, 1e6);
    write_mtx(&dir, "M1.mtx", &DMatrix::identity(1, 1));
    write_mtx(&dir, "K1.mtx", &DMatrix::from_element(1, 1, k));
    let mean_shape = |slider: &str| -> (f64, f64) {
        let text = format!(
            "[structure]\nkind = \"matrices\"\nmass_mtx = \"M1.mtx\"\nstiffness_mtx = \"K1.mtx\"\n\
             rayleigh = [0.0, 1e-5]\nreduction = \"none\"\n\
             [[structure.point]]\nname = \"x\"\ndof = 0\n\
             [[nonlinearity]]\ntype = \"polynomial-spring\"\npoint = \"x\"\ncoefficients = {{\"2\" = {c2}}}\n\
             [[nonlinearity]]\ntype = \"elastic-dry-friction\"\npoint = \"x\"\n\
             tangential_stiffness_n_per_m = {kt}\nslip_force_n = 10.0\ninitial_slider = \"{slider}\"\n\
             [output]\nresponse_point = \"x\"\n\
             [nma]\nharmonics = 3\nmax_tip_amplitude_m = 1e-4\nconservative = false\n"
        );
        let sc = scenario(&dir, &text);
        let setup = Setup::new(&sc).unwrap();
        let (nma, _) = methods::nma_table(&setup, &sc, false).unwrap();
        assert!(
            nma.note.contains(&format!("initial_slider = \"{slider}\"")),
            "{}",
            nma.note
        );
        let t = &nma.table;
        let j = t.amplitude.len() - 1;
        let p = &t.points[0];
        // u0 and |u_1| at the table's largest amplitude
        let x = (p.re[j][1].powi(2) + p.im[j][1].powi(2)).sqrt() * t.amplitude[j];
        (p.re[j][0] * t.amplitude[j], x)
    };
    let (u_mean, x_mean) = mean_shape("mean");
    let (u_zero, x_zero) = mean_shape("zero");
    // stuck throughout: x < F_s / k_t = 3.3e-3 m
    assert!(x_mean < 1e-3 && x_zero < 1e-3);
    let expect_mean = -c2 * x_mean * x_mean / (2.0 * k);
    let expect_zero = -c2 * x_zero * x_zero / (2.0 * (k + kt));
    assert!(
        (u_mean / expect_mean - 1.0).abs() < 1e-2,
        "{u_mean:e} vs {expect_mean:e}"
    );
    assert!(
        (u_zero / expect_zero - 1.0).abs() < 1e-2,
        "{u_zero:e} vs {expect_zero:e}"
    );
}

#[test]
fn harmonics_auto_is_the_smallest_order_that_agrees_with_four_more() {
    use host::scenario::Harmonics;
    use nlmode::nma::{table_agreement, RefineOptions};
    let dir = tmpdir("auto");
    // a stronger cubic spring: k3 x^2 / k = 0.3 at the end of the range
    let text = chain(
        &dir,
        "[nma]\nharmonics = \"auto\"\nmax_tip_amplitude_m = 1e-3\nconservative = false\n",
    )
    .replace("k3_n_per_m3 = 1e8", "k3_n_per_m3 = 3e9");
    let sc = scenario(&dir, &text);
    let setup = Setup::new(&sc).unwrap();
    let (auto, _) = methods::nma_table(&setup, &sc, false).unwrap();
    let h = auto.table.harmonics;
    assert!(auto.note.contains("\"auto\""), "{}", auto.note);
    let fixed = |h: usize| {
        let mut s = sc.clone();
        s.nma.harmonics = Harmonics::Fixed(h);
        methods::nma_table(&setup, &s, false).unwrap().0.table
    };
    let r = RefineOptions::default();
    let ok = |h: usize| {
        let (w, d, s) = table_agreement(&fixed(h), &fixed(h + 4)).unwrap();
        w <= r.omega_rel && d <= r.rel && s <= r.rel
    };
    assert!(ok(h), "H = {h} chosen");
    assert!(
        h > 1,
        "the cubic spring needs the third harmonic at this level"
    );
    assert!(!ok(h - 1), "H - 1 = {} already agrees", h - 1);
    assert_eq!(auto.table, fixed(h));
}

/// A 600-mass chain (above `SPARSE_MIN_DOF`): the sparse Craig-Bampton path
/// reports its stage timings in `host run` and refuses, before factorising,
/// a model above `[structure] memory_limit_gb`, naming the key.
#[test]
fn large_matrices_report_timings_and_respect_the_memory_limit() {
    let dir = tmpdir("memory");
    let n = 600;
    let mut k = String::from("%%MatrixMarket matrix coordinate real symmetric\n");
    k += &format!("{n} {n} {}\n", 2 * n - 1);
    for i in 1..=n {
        k += &format!("{i} {i} 2e4\n");
        if i < n {
            k += &format!("{} {i} -1e4\n", i + 1);
        }
    }
    std::fs::write(dir.join("K.mtx"), k).unwrap();
    let mut m = String::from("%%MatrixMarket matrix coordinate real symmetric\n");
    m += &format!("{n} {n} {n}\n");
    for i in 1..=n {
        m += &format!("{i} {i} 1.0\n");
    }
    std::fs::write(dir.join("M.mtx"), m).unwrap();
    let text = |limit: &str| {
        format!(
            "[structure]\nkind = \"matrices\"\nmass_mtx = \"M.mtx\"\nstiffness_mtx = \"K.mtx\"\n\
             rayleigh = [0.0, 1e-4]\nreduction = \"craig-bampton\"\ncb_modes = 5\n{limit}\
             [[structure.point]]\nname = \"end\"\ndof = {}\n\
             [[exciter]]\npoint = \"end\"\n[output]\nresponse_point = \"end\"\n\
             [run]\nmethods = [\"linear-frf\"]\nfrf_points = 20\n",
            n - 1
        )
    };
    expect_failure(
        &dir,
        "run",
        &text("memory_limit_gb = 1e-9\n"),
        &["structure.memory_limit_gb", "memory limit"],
    );
    expect_failure(
        &dir,
        "run",
        &text("memory_limit_gb = -1.0\n"),
        &["structure.memory_limit_gb", "positive"],
    );
    let p = dir.join("ok.toml");
    std::fs::write(&p, text("")).unwrap();
    let o = host()
        .arg("run")
        .arg(&p)
        .arg("-o")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    let so = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{so}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        so.contains("sparse reduction:") && so.contains("memory estimate"),
        "{so}"
    );
    // the stage times in summary.json, from the read on
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/summary.json")).unwrap())
            .unwrap();
    let st = &summary["structure_stages"];
    assert!(st["read_s"].as_f64().unwrap() >= 0.0, "{st}");
    assert_eq!(st["ordering"], "amd", "auto is AMD below 20,000 DOFs");
    assert!(st["factor_nnz"].as_u64().unwrap() > 0);
    let stages: Vec<&str> = st["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["stage"].as_str().unwrap())
        .collect();
    assert_eq!(stages.first(), Some(&"read"), "{stages:?}");
    for name in ["order", "factor", "eigen", "constraint_modes", "project"] {
        assert!(stages.contains(&name), "{name} in {stages:?}");
    }
    // a bad ordering names the key and the values
    expect_failure(
        &dir,
        "run",
        &text("ordering = \"metis\"\n"),
        &["structure.ordering", "nested-dissection"],
    );
}

/// NLvib's friction-contact chain through full slip (nlmode's
/// `nlvib_friction_contact_chain`): its backbone folds in `a` where mode 2
/// enters the shape (not an internal resonance), so the table ends there and
/// `host nma`/`host run` warn with the fold, the end of the backbone and the
/// remedy; the paper beam's table, cut at its 1:3 internal resonance (listed
/// in the note), gets no such warning.
#[test]
fn a_table_ending_at_a_genuine_fold_of_a_is_a_warning() {
    use nlmode::nma::{
        nonlinear_modal_analysis, problems::nlvib::nlvib_friction_contact_chain, AmplitudeRange,
        NmaOptions, RefineOptions, TablePolicy,
    };
    use std::sync::Arc;
    let model = nlvib_friction_contact_chain().unwrap();
    let opts = NmaOptions {
        harmonics: 7,
        amplitude: AmplitudeRange::Modal {
            log10_start: -2.0,
            log10_end: 1.0,
        },
        ..Default::default()
    };
    let r = nonlinear_modal_analysis(&model, &opts).unwrap();
    let basis = Arc::new(nlmode::nma::modal_basis::ModalBasis::new(&model, false).unwrap());
    let t = r
        .refined_table(
            &model,
            basis,
            &opts,
            TablePolicy::PrimaryBranch,
            &RefineOptions::default(),
        )
        .unwrap();
    let w = methods::fold_warning(&r, &t).expect("a warning");
    eprintln!("{w}");
    let a = t.truncated_at_fold.unwrap();
    assert!(w.contains(&format!("{a:.4e}")) && w.contains("not an internal resonance"));
    assert!(w.contains("hb"), "{w}");
    let d: f64 = w
        .split("damping ratio up to ")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(d > 0.3, "{w}");
    // the paper beam: its table ends at the 1:3 loop, no fold warning
    let sc = host::scenario::Scenario::default_scenario();
    let setup = Setup::new(&sc).unwrap();
    let (n, _) = methods::nma_table(&setup, &sc, false).unwrap();
    assert!(n.table.truncated_at_fold.is_some());
    assert!(!n
        .warnings
        .iter()
        .any(|w| w.contains("fold of the modal amplitude")));
}
