//! Issue 14: `host run /dev/zero` read without bound and a named pipe as
//! scenario blocked forever; only regular files of bounded size are read.
use std::path::Path;

#[test]
fn scenario_files_must_be_bounded_regular_files() {
    let t0 = std::time::Instant::now();
    for p in ["/dev/zero", "/dev/null", "/"] {
        let e = host::run::load_scenario(Some(Path::new(p))).unwrap_err();
        assert!(
            format!("{e:#}").contains("not a regular file"),
            "{p}: {e:#}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("sweep.toml");
    if std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
    {
        let e = host::run::load_scenario(Some(&fifo)).unwrap_err();
        assert!(format!("{e:#}").contains("named pipe"), "{e:#}");
    }
    let big = dir.path().join("big.toml");
    std::fs::write(
        &big,
        vec![b'#'; (host::run::MAX_SCENARIO_BYTES + 1) as usize],
    )
    .unwrap();
    let e = host::run::load_scenario(Some(&big)).unwrap_err();
    assert!(format!("{e:#}").contains("limit"), "{e:#}");
    assert!(t0.elapsed().as_secs_f64() < 2.0);
}
