//! `host package`: `structure.fmu`, `shaker.fmu` and (when its library
//! `libcontroller.so` is there too) `controller.fmu` from the built FMU
//! libraries (found by [`crate::fmus::locate_libraries`]: `--fmu-dir`,
//! `NLMODE_FMU_DIR` or beside this executable; never built here), with the
//! paper beam's modal table in the structure FMU's `resources/`.
use crate::methods;
use crate::model::Setup;
use crate::scenario::Scenario;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Harmonics of the modal table shipped in the structure FMU (the paper's H).
pub const FMU_TABLE_HARMONICS: usize = 13;

/// Writes `out/structure.fmu`, `out/shaker.fmu` and `out/controller.fmu`;
/// returns their paths (in this order). Fails (before the modal analysis) if
/// the structure or shaker library is not found, with a message naming where
/// it looked and how to build them; without the controller's library (an
/// installation that ships only the first two) the controller FMU is left
/// out with a warning on stderr.
pub fn package(out: &Path, fmu_dir: Option<&Path>) -> Result<Vec<PathBuf>> {
    let libs = crate::fmus::locate_libraries(fmu_dir)?;
    let mut sc = Scenario::default_scenario();
    sc.nma.harmonics = crate::scenario::Harmonics::Fixed(FMU_TABLE_HARMONICS);
    let setup = Setup::new(&sc).context("paper beam for the FMU's modal table")?;
    let (nma, _) = methods::nma_table(&setup, &sc, false)?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let tmp = out.join(".host-package-tmp");
    std::fs::create_dir_all(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
    let table = tmp.join("modal_table.json");
    nma.table.write(&table)?;
    let result = crate::fmus::package_repo_fmus(&libs, out, Some(&table));
    let _ = std::fs::remove_dir_all(&tmp);
    let (structure, shaker) = result?;
    let mut paths = vec![structure, shaker];
    match crate::fmus::locate_library(fmu_dir, &crate::fmus::CONTROLLER) {
        Ok(lib) => paths.push(crate::fmus::package_controller_fmu(&lib, out)?),
        Err(e) => eprintln!("warning: controller.fmu not packaged: {e}"),
    }
    Ok(paths)
}
