//! Helpers shared by the host's integration tests (`mod common;` in each).
use std::path::Path;
use std::process::Command;

/// The `host` binary of this build.
pub fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

/// `host nma` on `toml` (written to `dir`) fails with exit 2, without a panic
/// or a NaN in its message, and the message holds every needle.
pub fn expect_nma_failure(dir: &Path, toml: &str, needles: &[&str]) {
    let p = dir.join("bad.toml");
    std::fs::write(&p, toml).unwrap();
    let o = host()
        .arg("nma")
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
