//! Helpers shared by the host's integration tests (`crate::common::...`).
use host::scenario::Scenario;
use nalgebra::DMatrix;
use nlmode::structure::matrices::write_matrix_market;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty scratch directory `host-test-<file>-<name>-<pid>` in the
/// system's temporary directory, `<file>` the stem of the calling test file
/// (`name` unique within that file: every file's tests share this process).
#[track_caller]
pub fn tmpdir(name: &str) -> PathBuf {
    let file = Path::new(std::panic::Location::caller().file())
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("test");
    let d = std::env::temp_dir().join(format!("host-test-{file}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The scenario `text` with its relative paths taken from `dir` (panics with
/// the message and the text if it does not parse).
pub fn scenario(dir: &Path, text: &str) -> Scenario {
    let mut sc = Scenario::parse(text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    sc.resolve_paths(dir);
    sc
}

/// Writes `m` as the Matrix Market file `dir/name`.
pub fn write_mtx(dir: &Path, name: &str, m: &DMatrix<f64>) {
    std::fs::write(dir.join(name), write_matrix_market(m)).unwrap();
}

/// The `host` binary of this build.
pub fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

/// `host <command>` (`run`, `nma`, ...) on `toml` (written to `dir`) fails
/// with exit 2, without a panic or a NaN in its message, and the message holds
/// every needle.
pub fn expect_failure(dir: &Path, command: &str, toml: &str, needles: &[&str]) {
    let p = dir.join("bad.toml");
    std::fs::write(&p, toml).unwrap();
    let o = host()
        .arg(command)
        .arg(&p)
        .arg("-o")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{toml}\nstderr: {err}");
    assert!(!err.contains("panicked") && !err.contains("NaN"), "{err}");
    for n in needles {
        assert!(err.contains(n), "expected '{n}' in: {err}");
    }
}
