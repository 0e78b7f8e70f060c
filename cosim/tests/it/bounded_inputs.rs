//! Issue 14, item 4: every allocation and loop sized from a co-simulation
//! file is checked first. `stop_time_s = 1e10` aborted on an 800 TB
//! allocation, `macro_step_s = 1e-300` and `start_time_s = 1e300` panicked
//! with capacity overflow; a named pipe or `/dev/zero` as the file blocked or
//! read without bound. Now each is a clear error naming the key.
use std::path::Path;

use cosim::spec::{load_spec, parse_spec, SpecError};

fn spec(master: &str) -> String {
    format!("[master]\n{master}\n[units]\na = \"a.fmu\"\n")
}

#[test]
fn huge_runs_and_unresolvable_steps_name_the_key() {
    let p = Path::new("x.toml");
    for (master, needle) in [
        ("stop_time_s = 1e10", "macro steps, more than the limit"),
        (
            "macro_step_s = 1e-300\nstop_time_s = 1.0",
            "macro steps, more than the limit",
        ),
        (
            "start_time_s = 1e300\nstop_time_s = 2e300",
            "macro steps, more than the limit",
        ),
        (
            "start_time_s = 1e20\nstop_time_s = 1.0000000001e20\nmacro_step_s = 100.0",
            "resolution",
        ),
        ("stop_time_s = inf", "finite"),
    ] {
        match parse_spec(&spec(master), p) {
            Err(e @ SpecError::Steps { .. }) => {
                let m = e.to_string();
                assert!(m.contains("master.start_time_s"), "{m}");
                assert!(m.contains("macro_step_s") && m.contains(needle), "{m}");
            }
            other => panic!("{master}: {other:?}"),
        }
    }
    assert!(matches!(
        parse_spec(&spec("start_time_s = 1e300"), p),
        Err(SpecError::StopTime { .. })
    ));
    parse_spec(&spec("stop_time_s = 2.0"), p).unwrap();
}

#[test]
fn only_bounded_regular_files_are_read() {
    let t0 = std::time::Instant::now();
    for p in ["/dev/zero", "/"] {
        assert!(
            matches!(load_spec(Path::new(p)), Err(SpecError::File(_))),
            "{p}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("spec.toml");
    if std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
    {
        let e = load_spec(&fifo).unwrap_err();
        assert!(e.to_string().contains("named pipe"), "{e}");
    }
    let big = dir.path().join("big.toml");
    std::fs::write(&big, vec![b'#'; (cosim::spec::MAX_SPEC_BYTES + 1) as usize]).unwrap();
    assert!(load_spec(&big).unwrap_err().to_string().contains("limit"));
    assert!(t0.elapsed().as_secs_f64() < 2.0);
}
