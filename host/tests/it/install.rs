//! The host installed outside the source tree: the built `host` binary and
//! the two FMU libraries it ships with copied into a temporary prefix (what
//! `cargo install --path host --root PREFIX` does for the binary, plus the
//! libraries beside it), run from a working directory outside the
//! repository with `PATH=/usr/bin:/bin` (no cargo) and no `CARGO*`
//! variables. With the libraries: exit 0 and the whole output contract;
//! without them: the other methods' outputs, `cosim` listed under
//! `failed_methods` with a message saying how to get the libraries, exit 3.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A prefix `<tmp>/bin/host` (+ the FMU libraries if `with_libs`) and an
/// empty working directory `<tmp>/work`.
fn install(with_libs: bool) -> (tempfile::TempDir, PathBuf, PathBuf) {
    let prefix = tempfile::Builder::new()
        .prefix("host-install-")
        .tempdir()
        .unwrap();
    let bin = prefix.path().join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let host = bin.join("host");
    std::fs::copy(env!("CARGO_BIN_EXE_host"), &host).unwrap();
    if with_libs {
        // built by this test run (host's dev-dependencies fmu-structure, fmu-shaker)
        let libs = host::fmus::locate_libraries(None).unwrap();
        std::fs::copy(&libs.structure, bin.join("libstructure.so")).unwrap();
        std::fs::copy(&libs.shaker, bin.join("libshaker.so")).unwrap();
    }
    let work = prefix.path().join("work");
    std::fs::create_dir_all(&work).unwrap();
    (prefix, host, work)
}

/// `host ARGS` in `work` with a clean environment: PATH without cargo, no CARGO*.
fn run_clean(host: &Path, work: &Path, args: &[&str]) -> Output {
    let o = Command::new(host)
        .args(args)
        .current_dir(work)
        .env_clear()
        .env("PATH", "/usr/bin:/bin")
        .env("HOME", work)
        .output()
        .unwrap();
    assert!(
        !String::from_utf8_lossy(&o.stdout).contains("Compiling"),
        "host ran cargo"
    );
    o
}

fn text(o: &Output) -> String {
    format!(
        "status {:?}\nstdout: {}\nstderr: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn summary(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn installed_host_runs_the_default_scenario_anywhere() {
    let (_prefix, host, work) = install(true);
    let o = run_clean(&host, &work, &["run", "-o", "out"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let out = work.join("out");
    let s = summary(&out);
    assert!(s.get("failed_methods").is_none(), "{s}");
    for m in [
        "reference",
        "nlmode",
        "linear-slowflow",
        "linear-steady",
        "linear-frf",
        "closed-form",
        "cosim",
    ] {
        assert!(
            s["methods"][m]["peak_tip_amplitude_m"].as_f64().is_some(),
            "{m}: {s}"
        );
        let csv = out.join(format!("{m}_envelope.csv"));
        assert!(csv.is_file(), "{}", csv.display());
    }
    for f in ["structure.fmu", "shaker.fmu"] {
        let p = out.join("fmus").join(f);
        let md = cosim::ssp::read_model_description(&p).unwrap();
        assert!(md.validate().is_empty(), "{f}: {:?}", md.validate());
    }
}

#[test]
fn installed_host_without_the_libraries_runs_the_other_methods() {
    let (_prefix, host, work) = install(false);
    std::fs::write(
        work.join("two.toml"),
        "[run]\nmethods = [\"linear-frf\", \"cosim\"]\n",
    )
    .unwrap();
    let o = run_clean(&host, &work, &["run", "two.toml", "-o", "out"]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    let all = text(&o);
    assert!(
        all.contains("cargo build --release") && all.contains("--fmu-dir"),
        "{all}"
    );
    let out = work.join("out");
    let s = summary(&out);
    let why = s["failed_methods"]["cosim"].as_str().unwrap_or_default();
    assert!(why.contains("libstructure.so"), "{s}");
    assert!(
        why.contains(&host.parent().unwrap().display().to_string()),
        "{why}"
    );
    assert!(s["methods"]["linear-frf"]["peak_tip_amplitude_m"]
        .as_f64()
        .is_some());
    assert!(out.join("linear-frf_envelope.csv").is_file());
    assert!(!out.join("cosim_envelope.csv").exists());

    // `host package` fails with the same advice; --fmu-dir / NLMODE_FMU_DIR point elsewhere
    let o = run_clean(
        &host,
        &work,
        &["package", "--fmu-dir", "nowhere", "-o", "f"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("nowhere") && err.contains("cargo build --release"),
        "{err}"
    );
}

#[test]
fn installed_host_cosimulates_fmus_it_is_given() {
    let (_prefix, host, work) = install(false);
    // the libraries elsewhere: `host package --fmu-dir` packages from there
    let libs = host::fmus::locate_libraries(None).unwrap();
    let lib_dir = work.join("libs");
    std::fs::create_dir_all(&lib_dir).unwrap();
    std::fs::copy(&libs.structure, lib_dir.join("libstructure.so")).unwrap();
    std::fs::copy(&libs.shaker, lib_dir.join("libshaker.so")).unwrap();
    let o = run_clean(
        &host,
        &work,
        &["package", "--fmu-dir", "libs", "-o", "given"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // a scenario naming those FMUs needs no libraries beside the host
    std::fs::write(
        work.join("given.toml"),
        "[run]\nmethods = [\"cosim\"]\n[output]\nfmus = false\n\
         [cosim]\nstructure_fmu = \"given/structure.fmu\"\nshaker_fmu = \"given/shaker.fmu\"\n",
    )
    .unwrap();
    let o = run_clean(&host, &work, &["run", "given.toml", "-o", "out"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let s = summary(&work.join("out"));
    assert!(s.get("failed_methods").is_none(), "{s}");
    assert!(s["methods"]["cosim"]["peak_tip_amplitude_m"]
        .as_f64()
        .is_some());
}
