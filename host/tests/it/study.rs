//! `host study` as a user runs it: a grid reproduces the individual `host
//! run`s, a seeded study is reproducible, survives a kill (`--resume`), records
//! a failing sample, and bad input is one clear error with exit status 2 and
//! nothing written.
use crate::common::{host, tmpdir};
use std::collections::HashMap;
use std::path::Path;
use std::process::Output;

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "status {:?}\nstdout: {}\nstderr: {}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A case-(a) scenario by `nlmode` only, no plots or FMUs, with extra TOML lines.
fn scenario(extra_excitation: &str, extra_structure: &str) -> String {
    format!(
        "[structure]\n{extra_structure}\n[excitation]\n{extra_excitation}\n[run]\nmethods = [\"nlmode\"]\n\
         [output]\ntime_series = false\nplots = false\nfmus = false\n"
    )
}

fn study(dir: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut c = host();
    c.arg("study")
        .arg(dir.join("study.toml"))
        .arg("-o")
        .arg(out);
    c.args(extra).output().unwrap()
}

/// The rows of a results CSV by column name.
fn read_csv(path: &Path) -> (Vec<String>, Vec<HashMap<String, String>>) {
    let mut r = csv::Reader::from_path(path).unwrap();
    let h: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    let rows = r
        .records()
        .map(|rec| {
            let rec = rec.unwrap();
            h.iter()
                .cloned()
                .zip(rec.iter().map(str::to_string))
                .collect()
        })
        .collect();
    (h, rows)
}

const CONTRACT: [&str; 7] = [
    "peak_tip_amplitude_m",
    "peak_omega_rad_s",
    "jump_down_omega_rad_s",
    "min_force_amplitude_N",
    "max_force_amplitude_N",
    "left_table",
    "status",
];

#[test]
fn grid_reproduces_the_individual_runs_on_any_thread_count() {
    let dir = tmpdir("grid");
    std::fs::write(dir.join("base.toml"), scenario("", "")).unwrap();
    std::fs::write(
        dir.join("study.toml"),
        "scenario = \"base.toml\"\ndesign = \"grid\"\n\
         [[parameter]]\nkey = \"structure.k3_n_per_m3\"\nvalues = [4e9, 6e9, 8e9]\n\
         [[parameter]]\nkey = \"excitation.voltage_v\"\nvalues = [2.0, 5.0, 10]\n",
    )
    .unwrap();
    let (o1, o2) = (dir.join("t1"), dir.join("t2"));
    ok(&study(&dir, &o1, &["--threads", "1"]));
    let out = study(&dir, &o2, &["--threads", "2"]);
    ok(&out);
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("3 distinct structures"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let csv1 = std::fs::read_to_string(o1.join("results.csv")).unwrap();
    assert_eq!(
        csv1,
        std::fs::read_to_string(o2.join("results.csv")).unwrap()
    );
    let (h, rows) = read_csv(&o1.join("results.csv"));
    let mut want = vec!["sample", "structure.k3_n_per_m3", "excitation.voltage_v"];
    want.extend(CONTRACT);
    assert_eq!(&h[..want.len()], &want[..]);
    assert_eq!(rows.len(), 9);
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row["sample"], i.to_string());
        assert_eq!(row["status"], "ok");
        let (k3, v) = (&row["structure.k3_n_per_m3"], &row["excitation.voltage_v"]);
        let sc = dir.join(format!("run{i}.toml"));
        std::fs::write(
            &sc,
            scenario(&format!("voltage_v = {v}"), &format!("k3_n_per_m3 = {k3}")),
        )
        .unwrap();
        let run_out = dir.join(format!("run{i}"));
        ok(&host()
            .arg("run")
            .arg(&sc)
            .arg("-o")
            .arg(&run_out)
            .output()
            .unwrap());
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(run_out.join("summary.json")).unwrap())
                .unwrap();
        let m = &s["methods"]["nlmode"];
        for key in &CONTRACT[..5] {
            let want = m[key].as_f64().unwrap_or_else(|| panic!("{i}: {key}: {m}"));
            let got: f64 = row[*key].parse().unwrap();
            assert!(
                (got - want).abs() <= 1e-12 * want.abs(),
                "sample {i} {key}: study {got} vs host run {want}"
            );
        }
        assert_eq!(row["left_table"], "false");
    }
    // the Parquet copy holds the same rows
    let f = std::fs::File::open(o1.join("results.parquet")).unwrap();
    use parquet::file::reader::FileReader;
    let rd = parquet::file::reader::SerializedFileReader::new(f).unwrap();
    assert_eq!(rd.metadata().file_metadata().num_rows(), 9);
    let first = rd.get_row_iter(None).unwrap().next().unwrap().unwrap();
    let peak = first
        .get_column_iter()
        .find(|(name, _)| name.as_str() == "peak_tip_amplitude_m")
        .map(|(_, f)| f.clone());
    assert_eq!(
        peak,
        Some(parquet::record::Field::Double(
            rows[0]["peak_tip_amplitude_m"].parse().unwrap()
        ))
    );
    // summary and plots
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o1.join("study_summary.json")).unwrap())
            .unwrap();
    let r = summary["correlation"]["peak_tip_amplitude_m"]["excitation.voltage_v"]["spearman"]
        .as_f64()
        .unwrap();
    assert!(r > 0.9, "{summary}");
    assert!(o1
        .join("plots/peak_tip_amplitude_m_vs_excitation_voltage_v.svg")
        .exists());
}

fn random_study(dir: &Path, samples: usize) {
    std::fs::write(dir.join("base.toml"), scenario("", "")).unwrap();
    std::fs::write(
        dir.join("study.toml"),
        format!(
            "scenario = \"base.toml\"\ndesign = \"random\"\nsamples = {samples}\nseed = 42\n\
             [[parameter]]\nkey = \"excitation.voltage_v\"\ndistribution = \"uniform\"\nlow = 1.0\nhigh = 10.0\n\
             [[parameter]]\nkey = \"excitation.rate_per_pseudo_period\"\ndistribution = \"truncated-normal\"\n\
             mean = 0.02\nstd = 0.01\nlow = 0.005\nhigh = 0.05\n"
        ),
    )
    .unwrap();
}

#[test]
fn seeded_random_study_is_reproducible_and_resumes_after_a_kill() {
    let dir = tmpdir("random");
    let n = 3000;
    random_study(&dir, n);
    let full = dir.join("full");
    ok(&study(&dir, &full, &[]));
    let again = dir.join("again");
    ok(&study(&dir, &again, &["--threads", "1"]));
    let want = std::fs::read_to_string(full.join("results.csv")).unwrap();
    assert_eq!(
        want,
        std::fs::read_to_string(again.join("results.csv")).unwrap()
    );
    assert_eq!(want.lines().count(), n + 1);
    // kill a run midway, then resume it
    let cut = dir.join("cut");
    let mut child = host()
        .arg("study")
        .arg(dir.join("study.toml"))
        .arg("-o")
        .arg(&cut)
        .args(["--threads", "1"])
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    loop {
        let rows = std::fs::read_to_string(cut.join("results.csv"))
            .map(|t| t.lines().count())
            .unwrap_or(0);
        if rows > 50 || t0.elapsed().as_secs() > 60 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let partial = std::fs::read_to_string(cut.join("results.csv")).unwrap();
    let kept = partial.lines().count().saturating_sub(1);
    assert!(kept > 0 && kept < n, "killed after {kept} of {n} samples");
    let out = study(&dir, &cut, &["--resume"]);
    ok(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        !stdout.contains(&format!("({n} computed")),
        "resume recomputed everything: {stdout}"
    );
    assert_eq!(
        want,
        std::fs::read_to_string(cut.join("results.csv")).unwrap()
    );
    // a folder of another study is refused for --resume, and left as it was
    let other = tmpdir("random-other");
    random_study(&other, n + 1);
    let o = study(&other, &cut, &["--resume"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("different study"));
    assert_eq!(
        want,
        std::fs::read_to_string(cut.join("results.csv")).unwrap()
    );
}

#[test]
fn a_failing_sample_is_recorded_and_the_others_complete() {
    let dir = tmpdir("failing");
    // the exciter written out, so that `exciter.0` exists
    let base = scenario("", "") + "[[exciter]]\nname = \"shaker\"\nlocation = \"2l/3\"\n";
    std::fs::write(dir.join("base.toml"), base).unwrap();
    // m_a = 0.03 kg: D_a = 1.36 is below the electro-mechanical part (the shaker's own check)
    std::fs::write(
        dir.join("study.toml"),
        "scenario = \"base.toml\"\ndesign = \"grid\"\nreference_subset = 1\n\
         [[parameter]]\nkey = \"exciter.0.armature_mass_kg\"\nvalues = [0.043, 0.03, 0.05]\n",
    )
    .unwrap();
    let out = dir.join("out");
    ok(&study(&dir, &out, &[]));
    let (_, rows) = read_csv(&out.join("results.csv"));
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[0]["status"], "ok");
    assert!(
        rows[1]["status"].contains("armature damping"),
        "{:?}",
        rows[1]
    );
    assert_eq!(rows[1]["peak_tip_amplitude_m"], "");
    assert_eq!(rows[2]["status"], "ok");
    let (_, reference) = read_csv(&out.join("results_reference.csv"));
    assert_eq!(reference.len(), 1);
    assert_eq!(reference[0]["sample"], "0");
    assert_eq!(reference[0]["status"], "ok");
    let (p_ref, p_nl): (f64, f64) = (
        reference[0]["peak_tip_amplitude_m"].parse().unwrap(),
        rows[0]["peak_tip_amplitude_m"].parse().unwrap(),
    );
    assert!((p_ref / p_nl - 1.0).abs() < 0.03, "{p_ref} vs {p_nl}");
}

#[test]
fn bad_input_is_one_error_naming_the_key_exit_2_nothing_written() {
    let dir = tmpdir("bad");
    let uniform = "distribution = \"uniform\"\nlow = 1.0\nhigh = 2.0\n";
    let cases: Vec<(String, &str)> = vec![
        (
            format!("design = \"lhs\"\nsamples = 4\n[[parameter]]\nkey = \"excitation.voltage\"\n{uniform}"),
            "excitation.voltage",
        ),
        (
            "design = \"grid\"\n[[parameter]]\nkey = \"excitation.voltage_v\"\nvalues = [1.0, 2.0, -3.0]\n".into(),
            "sample 2",
        ),
        (
            "design = \"random\"\nsamples = 4\n[[parameter]]\nkey = \"excitation.voltage_v\"\n\
             distribution = \"normal\"\nmean = 5.0\nstd = -1.0\n"
                .into(),
            "std",
        ),
        (
            format!("design = \"lhs\"\nsamples = 4\nreference_subset = 5\n[[parameter]]\nkey = \"excitation.voltage_v\"\n{uniform}"),
            "reference_subset",
        ),
        (
            format!("design = \"lhs\"\nsamples = 4\nsampels = 3\n[[parameter]]\nkey = \"excitation.voltage_v\"\n{uniform}"),
            "sampels",
        ),
    ];
    for (i, (text, key)) in cases.iter().enumerate() {
        std::fs::write(dir.join("study.toml"), text).unwrap();
        let out = dir.join(format!("out{i}"));
        let o = study(&dir, &out, &[]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{i}: {stderr}");
        assert!(stderr.contains(key), "{i}: {key} not in: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!out.exists(), "{i}: {} was written", out.display());
    }
    // a slow-flow sweep with what only the controllers apply
    std::fs::write(
        dir.join("base.toml"),
        "[slowflow]\nharmonic_force_projection = true\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("study.toml"),
        format!("scenario = \"base.toml\"\ndesign = \"lhs\"\nsamples = 2\n[[parameter]]\nkey = \"excitation.voltage_v\"\n{uniform}"),
    )
    .unwrap();
    let out = dir.join("out-projection");
    let o = study(&dir, &out, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("slowflow.harmonic_force_projection"),
        "{stderr}"
    );
    assert!(!out.exists());
    // an output folder that cannot be created
    std::fs::write(
        dir.join("study.toml"),
        format!("design = \"lhs\"\nsamples = 2\n[[parameter]]\nkey = \"excitation.voltage_v\"\n{uniform}"),
    )
    .unwrap();
    std::fs::write(dir.join("a_file"), "x").unwrap();
    let o = study(&dir, &dir.join("a_file/out"), &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("a_file"));
}
