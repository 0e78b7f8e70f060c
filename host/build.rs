//! Compiles the C logger shim (`csrc/logger.c`, linked into `host`) and the
//! tiny test FMU library (`csrc/testosc.c` -> `$OUT_DIR/libtestosc.so`, used
//! only by tests and benches through `HOST_TEST_FMU_LIB`).
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=csrc/logger.c");
    println!("cargo:rerun-if-changed=csrc/testosc.c");
    cc::Build::new()
        .file("csrc/logger.c")
        .warnings(true)
        .compile("host_fmi2_logger");

    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR"));
    let so = out.join("libtestosc.so");
    let compiler = cc::Build::new().get_compiler();
    let status = compiler
        .to_command()
        .args([
            "-shared",
            "-fPIC",
            "-O2",
            "-fvisibility=hidden",
            "-Wall",
            "-o",
        ])
        .arg(&so)
        .arg("csrc/testosc.c")
        .arg("-lm")
        .status();
    match status {
        Ok(s) if s.success() => {}
        Ok(s) => panic!("compiling csrc/testosc.c failed with {s}"),
        Err(e) => panic!("cannot run the C compiler {:?}: {e}", compiler.path()),
    }
    println!("cargo:rustc-env=HOST_TEST_FMU_LIB={}", so.display());
}
