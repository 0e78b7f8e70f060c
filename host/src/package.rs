//! `host package`: the repository's FMUs ([`crate::fmus::FMUS`]:
//! `structure.fmu`, `shaker.fmu` and, when its library `libcontroller.so` is
//! there too, `controller.fmu`) from the built FMU libraries (found by
//! [`crate::fmus::locate_library`]: `--fmu-dir`, `NLMODE_FMU_DIR` or beside
//! this executable; never built here), with the paper beam's modal table in
//! the structure FMU's `resources/`. With `--fmi 3` or `--fmi all`
//! ([`package_versions`]) the FMI 3.0 FMUs `<id>_fmi3.fmu` too (the same
//! libraries, the FMI 3.0 modelDescriptions).
use crate::fmus::{self, FmiVersions, Packaging, RepoFmu, RepoFmuError};
use crate::methods;
use crate::model::Setup;
use crate::scenario::Scenario;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Harmonics of the modal table shipped in the structure FMU (the paper's H).
pub const FMU_TABLE_HARMONICS: usize = 13;

/// Writes `out/<id>.fmu` for every FMU of [`crate::fmus::FMUS`] (today
/// `structure.fmu`, `shaker.fmu`, `controller.fmu`); returns their paths in
/// that order. Fails (before the modal analysis) if the library of a
/// required FMU is not found, with a message naming where it looked and how
/// to build them; without the library of an optional one (the controller:
/// an installation may ship only the first two) it is left out with a
/// warning on stderr.
pub fn package(out: &Path, fmu_dir: Option<&Path>) -> Result<Vec<PathBuf>> {
    package_versions(out, fmu_dir, FmiVersions::Fmi2)
}

/// [`package`] for the FMI versions `versions`: the FMI 2.0 FMUs
/// (`<id>.fmu`) first, then the FMI 3.0 ones (`<id>_fmi3.fmu`), each in the
/// order of [`crate::fmus::FMUS`].
pub fn package_versions(
    out: &Path,
    fmu_dir: Option<&Path>,
    versions: FmiVersions,
) -> Result<Vec<PathBuf>> {
    let libs = locate(fmu_dir)?;
    let mut sc = Scenario::default_scenario();
    sc.nma.harmonics = crate::scenario::Harmonics::Fixed(FMU_TABLE_HARMONICS);
    let setup = Setup::new(&sc).context("paper beam for the FMU's modal table")?;
    let (nma, _) = methods::nma_table(&setup, &sc, false)?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let tmp = out.join(".host-package-tmp");
    std::fs::create_dir_all(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
    let table = tmp.join("modal_table.json");
    nma.table.write(&table)?;
    let found = || {
        libs.iter()
            .filter_map(|(fmu, lib)| lib.as_ref().ok().map(|l| (fmu, l)))
    };
    let fmi2 = found().filter(|_| versions.fmi2()).map(|(fmu, lib)| {
        let resources = fmus::fmu_resources(fmu, Some(&table))?;
        fmus::package_fmu(fmu, lib, out, resources)
    });
    let fmi3 = found().filter(|_| versions.fmi3()).map(|(fmu, lib)| {
        let resources = fmus::fmu_resources(fmu, Some(&table))?;
        fmus::package_fmu3(fmu, lib, out, resources)
    });
    let result: Result<Vec<PathBuf>, RepoFmuError> = fmi2.chain(fmi3).collect();
    let _ = std::fs::remove_dir_all(&tmp);
    let paths = result?;
    for (fmu, lib) in &libs {
        if let Err(e) = lib {
            eprintln!("warning: {}.fmu not packaged: {e}", fmu.id);
        }
    }
    Ok(paths)
}

/// Each FMU of [`fmus::FMUS`] with its library (an error for an optional
/// one not found).
type Located = Vec<(&'static RepoFmu, Result<PathBuf, RepoFmuError>)>;

/// The library of every FMU of [`fmus::FMUS`]; an error naming the required
/// ones missing.
fn locate(fmu_dir: Option<&Path>) -> Result<Located> {
    let mut found = Vec::new();
    let mut missing = Vec::new();
    let mut searched = Vec::new();
    for fmu in fmus::FMUS {
        match fmus::locate_library(fmu_dir, fmu) {
            Ok(lib) => found.push((fmu, Ok(lib))),
            Err(RepoFmuError::NotFound {
                missing: m,
                searched: s,
            }) if fmu.packaging != Packaging::Optional => {
                missing.extend(m);
                searched = s;
            }
            Err(e) if fmu.packaging == Packaging::Optional => found.push((fmu, Err(e))),
            Err(e) => return Err(e.into()),
        }
    }
    if !missing.is_empty() {
        return Err(RepoFmuError::NotFound { missing, searched }.into());
    }
    Ok(found)
}
