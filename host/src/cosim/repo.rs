//! The repository's own FMUs: build the two cdylibs with cargo and package
//! them (with `fmi2::package`) into `.fmu` files, so that `host run` can
//! co-simulate on a fresh clone without a separate packaging step.
use std::path::{Path, PathBuf};

use fmi2::package::PackageError;

#[derive(Debug, thiserror::Error)]
pub enum RepoFmuError {
    #[error("building or packaging the FMUs failed: {0}")]
    Build(String),
    #[error("cargo built no shared library for '{0}'")]
    NoLibrary(String),
    #[error("the workspace sources are not at {0} (the FMUs are built from the repository this host was compiled in)")]
    NoWorkspace(PathBuf),
    #[error(transparent)]
    Package(#[from] PackageError),
    #[error("cannot create {path}: {source}")]
    Dir {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// The workspace this binary was built from.
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("host lies inside the workspace")
        .to_path_buf()
}

/// Build `fmu-structure` and `fmu-shaker` (release unless this binary is a
/// debug build) and write `out_dir/structure.fmu` and `out_dir/shaker.fmu`;
/// `modal_table` (if given) goes into the structure FMU's `resources/` as
/// `modal_table.json`. Returns (structure, shaker) paths.
pub fn package_repo_fmus(
    out_dir: &Path,
    modal_table: Option<&Path>,
) -> Result<(PathBuf, PathBuf), RepoFmuError> {
    let root = workspace_root();
    let md = |id: &str| {
        root.join("modelDescription")
            .join(id)
            .join("modelDescription.xml")
    };
    if !md("structure").is_file() || !md("shaker").is_file() {
        return Err(RepoFmuError::NoWorkspace(root));
    }
    let libs = fmi2::package::build_libraries(
        &root,
        &["fmu-shaker", "fmu-structure"],
        !cfg!(debug_assertions),
    )
    .map_err(RepoFmuError::Build)?;
    std::fs::create_dir_all(out_dir).map_err(|source| RepoFmuError::Dir {
        path: out_dir.into(),
        source,
    })?;
    let mut paths = Vec::new();
    for (id, krate) in [("structure", "fmu-structure"), ("shaker", "fmu-shaker")] {
        let lib = libs
            .iter()
            .find(|(n, _)| n == id)
            .ok_or_else(|| RepoFmuError::NoLibrary(id.into()))?
            .1
            .clone();
        let extra: Vec<PathBuf> = match (id, modal_table) {
            ("structure", Some(t)) => vec![t.to_path_buf()],
            _ => vec![],
        };
        let p = fmi2::package::package_workspace_fmu(&root, id, krate, &lib, &extra, out_dir)
            .map_err(RepoFmuError::Build)?;
        paths.push(p);
    }
    Ok((paths[0].clone(), paths[1].clone()))
}
