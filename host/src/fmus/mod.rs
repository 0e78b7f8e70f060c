//! This repository's FMUs and their pairing (the `cosim` crate is the generic
//! master; what is specific to these FMUs is here).
//!
//! * [`FMUS`]: the FMU list (one line per FMU crate; [`STRUCTURE`],
//!   [`SHAKER`], [`CONTROLLER`] name its entries for the pairings);
//! * [`structure_shaker`]: the structure + shaker pairing of the `cosim`
//!   method, written as a co-simulation file like any user's.
//!
//! The repository's own FMUs are packaged at run time from parts fixed at
//! build time: the shared libraries `lib<id>.so` are *found*, never built (a
//! workspace `cargo build [--release]` puts them in `target/<profile>/`,
//! beside the `host` binary), and everything else an `.fmu` holds (the
//! modelDescription.xml of `modelDescription/<id>/` and the FMU crate's
//! README.md as documentation) is embedded in the host at compile time, so
//! that an installed binary needs neither the source tree nor a toolchain.
//! The modelDescription.xml is rendered from the FMU crate's code
//! (`fmi2_export::render`) and checked in; the crate's tests keep the two
//! identical. (The host embeds the file rather than rendering it: linking
//! the FMU crates would put every FMU's `fmi2*` symbols into the host and
//! the Python extension.) `modelDescription/<id>/` holds no `resources/` or
//! `documentation/` folder (a test keeps it so); the structure FMU's modal
//! table is added by the caller ([`fmu_resources`]).
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use fmi2_export::package::{readme_documentation, write_fmu, write_fmu3, FmuSpec, PackageError};

pub mod structure_shaker;

/// Environment variable naming the folder with the FMU libraries (like `--fmu-dir`).
pub const FMU_DIR_ENV: &str = "NLMODE_FMU_DIR";

/// One FMU of this repository.
#[derive(Debug, Clone, Copy)]
pub struct RepoFmu {
    /// `modelIdentifier` = the cdylib's name (`lib<id>.so`).
    pub id: &'static str,
    /// The cargo package that builds the library.
    pub package: &'static str,
    /// `modelDescription/<id>/modelDescription.xml` (rendered from the FMU
    /// crate's code and checked by its tests to be so).
    pub model_description: &'static str,
    /// `modelDescription/<id>_fmi3/modelDescription.xml`, the FMI 3.0 one
    /// (rendered by `fmi2_export::render3`, checked the same way); the same
    /// library serves both versions.
    pub model_description3: &'static str,
    /// The FMU crate's README.md (the `.fmu`'s documentation).
    pub readme: &'static str,
    /// How `host package` treats it.
    pub packaging: Packaging,
}

/// How `host package` ships an FMU of [`FMUS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Packaging {
    /// Its library must be found (before the modal analysis runs).
    Required,
    /// Required, with the paper beam's modal table as `resources/modal_table.json`.
    WithModalTable,
    /// Left out with a warning when its library is not found (an
    /// installation may ship only the required ones).
    Optional,
}

/// A [`RepoFmu`] from its identifier, its cargo package and its
/// [`Packaging`]; the modelDescription and the README are embedded from
/// `modelDescription/<id>/` and `<package>/`.
macro_rules! repo_fmu {
    ($id:literal, $package:literal, $packaging:expr) => {
        RepoFmu {
            id: $id,
            package: $package,
            model_description: include_str!(concat!(
                "../../../modelDescription/",
                $id,
                "/modelDescription.xml"
            )),
            model_description3: include_str!(concat!(
                "../../../modelDescription/",
                $id,
                "_fmi3/modelDescription.xml"
            )),
            readme: include_str!(concat!("../../../", $package, "/README.md")),
            packaging: $packaging,
        }
    };
}

/// The structure FMU (crate `fmu-structure`).
pub const STRUCTURE: RepoFmu = repo_fmu!("structure", "fmu-structure", Packaging::WithModalTable);

/// The shaker FMU (crate `fmu-shaker`).
pub const SHAKER: RepoFmu = repo_fmu!("shaker", "fmu-shaker", Packaging::Required);

/// The controller FMU (crate `fmu-controller`): the phase-locked loop of
/// phase-resonant testing, packaged on its own ([`package_controller_fmu`]).
pub const CONTROLLER: RepoFmu = repo_fmu!("controller", "fmu-controller", Packaging::Optional);

/// This repository's FMUs, in the order `host package` writes them. Adding
/// an FMU crate (a copy of the template, see CONTRIBUTING.md) adds one line
/// here, `repo_fmu!("<id>", "fmu-<id>", Packaging::Optional),` (a named
/// constant like the ones above only where host code pairs it with others).
pub const FMUS: &[RepoFmu] = &[STRUCTURE, SHAKER, CONTROLLER];

/// Why the repository's FMUs could not be packaged.
#[derive(Debug, thiserror::Error)]
pub enum RepoFmuError {
    #[error(
        "FMU libraries not found ({missing}); looked in {searched}. Build them with \
         `cargo build --release` in the source tree (they land in target/release/ beside \
         target/release/host), or point to a folder holding them with --fmu-dir DIR or \
         {FMU_DIR_ENV}=DIR",
        missing = .missing.join(", "),
        searched = .searched.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    )]
    NotFound {
        missing: Vec<String>,
        searched: Vec<PathBuf>,
    },
    #[error(transparent)]
    Package(#[from] PackageError),
    #[error("cannot create {path}: {source}")]
    Dir {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// The shared libraries of the two FMUs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FmuLibraries {
    pub structure: PathBuf,
    pub shaker: PathBuf,
}

/// The folders searched for the libraries: `fmu_dir` alone if given, else
/// the folder in `NLMODE_FMU_DIR` alone if set, else the folder of the
/// running executable and its `deps/` (where `cargo test` leaves the
/// cdylibs of dev-dependencies), and, for a test binary inside `deps/`, the
/// profile folder above it.
pub fn search_dirs(fmu_dir: Option<&Path>) -> Vec<PathBuf> {
    if let Some(d) = fmu_dir {
        return vec![d.to_path_buf()];
    }
    if let Some(d) = std::env::var_os(FMU_DIR_ENV).filter(|d| !d.is_empty()) {
        return vec![PathBuf::from(d)];
    }
    let mut dirs = Vec::new();
    if let Some(exe_dir) = std::env::current_exe()
        .ok()
        .and_then(|e| e.parent().map(Path::to_path_buf))
    {
        dirs.push(exe_dir.join("deps"));
        if exe_dir.file_name().is_some_and(|n| n == "deps") {
            if let Some(up) = exe_dir.parent() {
                dirs.push(up.to_path_buf());
            }
        }
        dirs.insert(0, exe_dir);
    }
    dirs
}

/// Find `libstructure.so` and `libshaker.so` in [`search_dirs`]; where a
/// library is in several of them, the most recently built one is taken (a
/// `cargo test` rebuilds `deps/` but leaves an older `cargo build` copy).
pub fn locate_libraries(fmu_dir: Option<&Path>) -> Result<FmuLibraries, RepoFmuError> {
    let searched = search_dirs(fmu_dir);
    let find = |id: &str| newest_library(&searched, id);
    match (find(STRUCTURE.id), find(SHAKER.id)) {
        (Some(structure), Some(shaker)) => Ok(FmuLibraries { structure, shaker }),
        (s, sh) => Err(RepoFmuError::NotFound {
            missing: [(s, STRUCTURE.id), (sh, SHAKER.id)]
                .into_iter()
                .filter(|(p, _)| p.is_none())
                .map(|(_, id)| format!("lib{id}.so"))
                .collect(),
            searched,
        }),
    }
}

/// The most recently built `lib<id>.so` in `dirs`.
fn newest_library(dirs: &[PathBuf], id: &str) -> Option<PathBuf> {
    dirs.iter()
        .map(|d| d.join(format!("lib{id}.so")))
        .filter(|p| p.is_file())
        .max_by_key(|p| {
            std::fs::metadata(p)
                .and_then(|m| m.modified())
                .unwrap_or(SystemTime::UNIX_EPOCH)
        })
}

/// Find the library of one FMU (`lib<fmu.id>.so`) in [`search_dirs`], the
/// most recently built where there are several.
pub fn locate_library(fmu_dir: Option<&Path>, fmu: &RepoFmu) -> Result<PathBuf, RepoFmuError> {
    let searched = search_dirs(fmu_dir);
    newest_library(&searched, fmu.id).ok_or_else(|| RepoFmuError::NotFound {
        missing: vec![format!("lib{}.so", fmu.id)],
        searched,
    })
}

/// Write `out_dir/<id>.fmu` from its library and the embedded parts, with
/// `resources` (path inside `resources/`, contents).
pub fn package_fmu(
    fmu: &RepoFmu,
    library: &Path,
    out_dir: &Path,
    resources: Vec<(String, Vec<u8>)>,
) -> Result<PathBuf, RepoFmuError> {
    package_as(fmu, library, out_dir, resources, false)
}

/// [`package_fmu`] as FMI 2.0 (`<id>.fmu`) or, with `fmi3`, as FMI 3.0
/// (`<id>_fmi3.fmu`: the same library in `binaries/x86_64-linux/`, the FMI
/// 3.0 modelDescription).
fn package_as(
    fmu: &RepoFmu,
    library: &Path,
    out_dir: &Path,
    resources: Vec<(String, Vec<u8>)>,
    fmi3: bool,
) -> Result<PathBuf, RepoFmuError> {
    std::fs::create_dir_all(out_dir).map_err(|source| RepoFmuError::Dir {
        path: out_dir.into(),
        source,
    })?;
    let model_description = if fmi3 {
        fmi3_description(fmu, &resources)?
    } else {
        fmu.model_description.into()
    };
    let spec = FmuSpec {
        model_identifier: fmu.id.into(),
        model_description,
        library: library.into(),
        resources,
        documentation: readme_documentation(fmu.id, fmu.readme),
    };
    if fmi3 {
        let path = out_dir.join(format!("{}_fmi3.fmu", fmu.id));
        write_fmu3(&spec, &path)?;
        Ok(path)
    } else {
        let path = out_dir.join(format!("{}.fmu", fmu.id));
        write_fmu(&spec, &path)?;
        Ok(path)
    }
}

/// The FMI 3.0 structural parameter of a [`Packaging::WithModalTable`]
/// FMU (the structure) that is the number of points of its modal table
/// (the length of its mode-shape arrays).
pub const TABLE_POINTS_PARAMETER: &str = "mode_shape_points";

/// The FMI 3.0 modelDescription of `fmu` for the `resources` it is shipped
/// with: for a [`Packaging::WithModalTable`] FMU with `modal_table.json`,
/// [`TABLE_POINTS_PARAMETER`] starts at that table's number of points
/// (the checked-in XML has the paper beam's); else the embedded one.
fn fmi3_description(
    fmu: &RepoFmu,
    resources: &[(String, Vec<u8>)],
) -> Result<String, RepoFmuError> {
    let table = resources
        .iter()
        .find(|(name, _)| name == "modal_table.json")
        .filter(|_| fmu.packaging == Packaging::WithModalTable);
    let Some((_, bytes)) = table else {
        return Ok(fmu.model_description3.into());
    };
    let bad = |reason: String| {
        RepoFmuError::Package(PackageError::BadModelDescription {
            model: fmu.id.into(),
            reason,
        })
    };
    let text = std::str::from_utf8(bytes).map_err(|e| bad(format!("modal table: {e}")))?;
    let points = nlmode::nma::ModalTable::from_json(text)
        .map_err(|e| bad(format!("modal table: {e}")))?
        .points
        .len();
    fmi2_export::render3::with_structural_start(
        fmu.model_description3,
        TABLE_POINTS_PARAMETER,
        points as u64,
    )
    .map_err(bad)
}

/// Which FMI versions `host package` writes (`--fmi 2|3|all`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmiVersions {
    /// `<id>.fmu` (FMI 2.0), the default.
    Fmi2,
    /// `<id>_fmi3.fmu` (FMI 3.0).
    Fmi3,
    /// Both.
    All,
}

impl FmiVersions {
    /// From the `--fmi` value (`2`, `3`, `all`).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "2" => Some(Self::Fmi2),
            "3" => Some(Self::Fmi3),
            "all" => Some(Self::All),
            _ => None,
        }
    }
    pub fn fmi2(self) -> bool {
        self != Self::Fmi3
    }
    pub fn fmi3(self) -> bool {
        self != Self::Fmi2
    }
}

/// Write `out_dir/<id>_fmi3.fmu` (FMI 3.0: the same library in
/// `binaries/x86_64-linux/`, the FMI 3.0 modelDescription) with `resources`.
pub fn package_fmu3(
    fmu: &RepoFmu,
    library: &Path,
    out_dir: &Path,
    resources: Vec<(String, Vec<u8>)>,
) -> Result<PathBuf, RepoFmuError> {
    package_as(fmu, library, out_dir, resources, true)
}

/// The `resources/` of an FMU packaged with `modal_table` (if given): the
/// table as `modal_table.json` for [`Packaging::WithModalTable`], nothing
/// for the others.
pub fn fmu_resources(
    fmu: &RepoFmu,
    modal_table: Option<&Path>,
) -> Result<Vec<(String, Vec<u8>)>, RepoFmuError> {
    match (fmu.packaging, modal_table) {
        (Packaging::WithModalTable, Some(t)) => {
            let bytes = std::fs::read(t).map_err(|source| PackageError::Read {
                path: t.into(),
                source,
            })?;
            Ok(vec![("modal_table.json".to_string(), bytes)])
        }
        _ => Ok(Vec::new()),
    }
}

/// Write `out_dir/controller.fmu` from its library and the embedded parts.
pub fn package_controller_fmu(library: &Path, out_dir: &Path) -> Result<PathBuf, RepoFmuError> {
    package_fmu(&CONTROLLER, library, out_dir, Vec::new())
}

/// Write `out_dir/structure.fmu` and `out_dir/shaker.fmu` from `libs` and
/// the embedded parts; `modal_table` (if given) goes into the structure
/// FMU's `resources/` as `modal_table.json`. Returns (structure, shaker) paths.
pub fn package_repo_fmus(
    libs: &FmuLibraries,
    out_dir: &Path,
    modal_table: Option<&Path>,
) -> Result<(PathBuf, PathBuf), RepoFmuError> {
    let structure = package_fmu(
        &STRUCTURE,
        &libs.structure,
        out_dir,
        fmu_resources(&STRUCTURE, modal_table)?,
    )?;
    let shaker = package_fmu(&SHAKER, &libs.shaker, out_dir, Vec::new())?;
    Ok((structure, shaker))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_description_folders_hold_only_what_is_embedded() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        for fmu in FMUS {
            let dir = root.join("modelDescription").join(fmu.id);
            let names: Vec<String> = std::fs::read_dir(&dir)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            assert_eq!(names, ["modelDescription.xml"], "{}", dir.display());
            let md = cosim::import::ModelDescription::parse(fmu.model_description).unwrap();
            assert_eq!(md.co_simulation.model_identifier, fmu.id);
            let dir3 = root
                .join("modelDescription")
                .join(format!("{}_fmi3", fmu.id));
            let names: Vec<String> = std::fs::read_dir(&dir3)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            assert_eq!(names, ["modelDescription.xml"], "{}", dir3.display());
            assert!(fmu.model_description3.contains("fmiVersion=\"3.0\""));
        }
    }

    /// The FMI 3.0 structure FMU declares the point count of the table it
    /// ships as the start of `mode_shape_points` (the checked-in XML: the
    /// paper beam's 3 points); the other FMUs' descriptions are embedded.
    #[test]
    fn fmi3_structure_description_follows_the_shipped_table() {
        use nlmode::nma::ModalTable;
        let one = nlmode::Complex64::new(1.0, 0.0);
        let names = ["tip", "2l3", "l3", "root", "mid"];
        let start = |n: usize| {
            let shape: Vec<(&str, nlmode::Complex64)> =
                names[..n].iter().map(|p| (*p, one)).collect();
            let t = ModalTable::linear(100.0, 0.01, &shape, 1e-9, 1e-3);
            let res = vec![("modal_table.json".to_string(), t.to_json().into_bytes())];
            fmi3_description(&STRUCTURE, &res).unwrap()
        };
        assert_eq!(start(3), STRUCTURE.model_description3);
        let five = start(5);
        assert!(five.contains("name=\"mode_shape_points\""));
        assert!(
            five.contains("min=\"1\" max=\"1000000\" start=\"5\"/>"),
            "{five}"
        );
        assert_eq!(five.len(), STRUCTURE.model_description3.len());
        let shaker = fmi3_description(&SHAKER, &[]).unwrap();
        assert_eq!(shaker, SHAKER.model_description3);
        let bad = vec![("modal_table.json".to_string(), b"{".to_vec())];
        let e = fmi3_description(&STRUCTURE, &bad).unwrap_err().to_string();
        assert!(e.contains("modal table"), "{e}");
    }

    #[test]
    fn missing_libraries_say_where_and_how() {
        let dir = tempfile::tempdir().unwrap();
        let e = locate_libraries(Some(dir.path())).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("libstructure.so, libshaker.so"), "{msg}");
        assert!(msg.contains(&dir.path().display().to_string()), "{msg}");
        assert!(
            msg.contains("cargo build --release") && msg.contains("--fmu-dir"),
            "{msg}"
        );
        std::fs::write(dir.path().join("libstructure.so"), b"x").unwrap();
        std::fs::write(dir.path().join("libshaker.so"), b"y").unwrap();
        let libs = locate_libraries(Some(dir.path())).unwrap();
        assert_eq!(libs.shaker, dir.path().join("libshaker.so"));
    }

    #[test]
    fn libraries_of_this_build_are_found_beside_the_test_binary() {
        // the host's dev-dependencies fmu-structure / fmu-shaker put the cdylibs in target/<profile>/deps
        let libs = locate_libraries(None).unwrap();
        assert!(
            libs.structure.is_file() && libs.shaker.is_file(),
            "{libs:?}"
        );
        let controller = locate_library(None, &CONTROLLER).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let fmu = package_controller_fmu(&controller, dir.path()).unwrap();
        let loaded = cosim::import::Fmu::load(&fmu).unwrap();
        assert_eq!(loaded.md.co_simulation.model_identifier, "controller");
    }
}
