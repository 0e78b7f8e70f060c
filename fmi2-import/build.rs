//! Compiles the C logger shim `csrc/logger.c` (the FMI 2.0 logger callback is
//! C-variadic, which stable Rust cannot define) into this crate.
fn main() {
    println!("cargo:rerun-if-changed=csrc/logger.c");
    cc::Build::new()
        .file("csrc/logger.c")
        .warnings(true)
        .compile("fmi2_import_logger");
}
