//! `cargo run -p fmi2 --bin package-fmus -- --out DIR [--debug] [--resource ID=FILE]...`
//!
//! Builds the FMU crates of the workspace (release profile unless `--debug`)
//! and writes `DIR/<id>.fmu` for every FMU whose
//! `modelDescription/<id>/modelDescription.xml` exists:
//! * `modelDescription.xml`,
//! * `binaries/linux64/<id>.so` (the crate's cdylib),
//! * `resources/`: every file below `modelDescription/<id>/resources/`, plus
//!   files given with `--resource <id>=<file>`,
//! * `documentation/`: the crate's `README.md` (equations, variable table) as
//!   `README.md` and `index.html`, plus `modelDescription/<id>/documentation/`.
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use fmi2::package::{build_libraries, package_workspace_fmu};

/// (modelIdentifier = cdylib lib name, cargo package)
const FMUS: &[(&str, &str)] = &[("shaker", "fmu-shaker"), ("structure", "fmu-structure")];

fn usage() -> ! {
    eprintln!("usage: package-fmus --out DIR [--debug] [--resource ID=FILE]...");
    std::process::exit(2)
}

fn main() -> ExitCode {
    let mut out: Option<PathBuf> = None;
    let mut debug = false;
    let mut extra: Vec<(String, PathBuf)> = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--out" => out = Some(args.next().unwrap_or_else(|| usage()).into()),
            "--debug" => debug = true,
            "--resource" => {
                let v = args.next().unwrap_or_else(|| usage());
                let (id, f) = v.split_once('=').unwrap_or_else(|| usage());
                extra.push((id.to_string(), PathBuf::from(f)));
            }
            _ => usage(),
        }
    }
    let Some(out) = out else { usage() };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf();
    let present: Vec<(&str, &str)> = FMUS
        .iter()
        .copied()
        .filter(|(id, _)| {
            root.join("modelDescription")
                .join(id)
                .join("modelDescription.xml")
                .is_file()
        })
        .collect();
    if present.is_empty() {
        eprintln!(
            "no modelDescription/<id>/modelDescription.xml found under {}",
            root.display()
        );
        return ExitCode::FAILURE;
    }
    let libs = match build_libraries(
        &root,
        &present.iter().map(|p| p.1).collect::<Vec<_>>(),
        !debug,
    ) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    if let Err(e) = std::fs::create_dir_all(&out) {
        eprintln!("cannot create {}: {e}", out.display());
        return ExitCode::FAILURE;
    }
    for (id, krate) in present {
        let Some((_, lib)) = libs.iter().find(|(n, _)| n == id) else {
            eprintln!("cargo built no shared library for {id} ({krate})");
            return ExitCode::FAILURE;
        };
        let extra_here: Vec<PathBuf> = extra
            .iter()
            .filter(|(eid, _)| eid == id)
            .map(|(_, f)| f.clone())
            .collect();
        match package_workspace_fmu(&root, id, krate, lib, &extra_here, &out) {
            Ok(p) => println!("wrote {}", p.display()),
            Err(e) => {
                eprintln!("{id}: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    ExitCode::SUCCESS
}
