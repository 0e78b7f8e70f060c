//! Compiles the tiny C test FMU library (`csrc/testosc.c` ->
//! `$OUT_DIR/libtestosc.so`), used only by this crate's tests and benches
//! through `COSIM_TEST_FMU_LIB`.
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=csrc/testosc.c");
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
    println!("cargo:rustc-env=COSIM_TEST_FMU_LIB={}", so.display());
}
