//! The repository's own FMUs: build the two cdylibs with cargo and package
//! them (with `fmi2::package`) into `.fmu` files, so that `host run` can
//! co-simulate on a fresh clone without a separate packaging step.
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use fmi2::package::{write_fmu, FmuSpec, PackageError};

#[derive(Debug, thiserror::Error)]
pub enum RepoFmuError {
    #[error("cannot run cargo ({cargo}): {source}")]
    Cargo { cargo: String, source: std::io::Error },
    #[error("building the FMU libraries failed (cargo build -p fmu-shaker -p fmu-structure: {0})")]
    Build(String),
    #[error("cargo built no shared library for '{0}'")]
    NoLibrary(String),
    #[error("the workspace sources are not at {0} (the FMUs are built from the repository this host was compiled in)")]
    NoWorkspace(PathBuf),
    #[error(transparent)]
    Package(#[from] PackageError),
    #[error("cannot create {path}: {source}")]
    Dir { path: PathBuf, source: std::io::Error },
}

/// The workspace this binary was built from.
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("host lies inside the workspace").to_path_buf()
}

/// Build `fmu-structure` and `fmu-shaker` (release unless this binary is a
/// debug build) and write `out_dir/structure.fmu` and `out_dir/shaker.fmu`;
/// `modal_table` (if given) goes into the structure FMU's `resources/` as
/// `modal_table.json`. Returns (structure, shaker) paths.
pub fn package_repo_fmus(out_dir: &Path, modal_table: Option<&Path>) -> Result<(PathBuf, PathBuf), RepoFmuError> {
    let root = workspace_root();
    let md = |id: &str| root.join("modelDescription").join(id).join("modelDescription.xml");
    if !md("structure").is_file() || !md("shaker").is_file() {
        return Err(RepoFmuError::NoWorkspace(root));
    }
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(&cargo);
    cmd.current_dir(&root).args(["build", "--lib", "--message-format=json-render-diagnostics", "-p", "fmu-shaker", "-p", "fmu-structure"]);
    if !cfg!(debug_assertions) {
        cmd.arg("--release");
    }
    let out = cmd
        .stderr(Stdio::inherit())
        .output()
        .map_err(|source| RepoFmuError::Cargo { cargo: cargo.clone(), source })?;
    if !out.status.success() {
        return Err(RepoFmuError::Build(out.status.to_string()));
    }
    let mut libs: Vec<(String, PathBuf)> = Vec::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else { continue };
        if v["reason"] != "compiler-artifact" {
            continue;
        }
        let name = v["target"]["name"].as_str().unwrap_or_default().to_string();
        for f in v["filenames"].as_array().into_iter().flatten() {
            if let Some(f) = f.as_str().filter(|f| f.ends_with(".so")) {
                libs.push((name.clone(), PathBuf::from(f)));
            }
        }
    }
    std::fs::create_dir_all(out_dir).map_err(|source| RepoFmuError::Dir { path: out_dir.into(), source })?;
    let mut paths = Vec::new();
    for id in ["structure", "shaker"] {
        let lib = libs.iter().find(|(n, _)| n == id).ok_or_else(|| RepoFmuError::NoLibrary(id.into()))?.1.clone();
        let mut resources = Vec::new();
        let res_dir = root.join("modelDescription").join(id).join("resources");
        if res_dir.is_dir() {
            resources = fmi2::package::files_below(&res_dir)?;
        }
        if id == "structure" {
            if let Some(t) = modal_table {
                resources.retain(|(_, rel)| rel != "modal_table.json");
                resources.push((t.to_path_buf(), "modal_table.json".into()));
            }
        }
        let spec = FmuSpec { model_identifier: id.into(), model_description: md(id), library: lib, resources, documentation: vec![] };
        let p = out_dir.join(format!("{id}.fmu"));
        write_fmu(&spec, &p)?;
        paths.push(p);
    }
    Ok((paths[0].clone(), paths[1].clone()))
}
