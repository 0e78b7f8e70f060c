//! `host package`: build `structure.fmu` and `shaker.fmu` (cargo builds the
//! two cdylibs of this workspace if needed) with the paper beam's modal table
//! in the structure FMU's `resources/`.
use crate::methods;
use crate::model::Setup;
use crate::scenario::Scenario;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Harmonics of the modal table shipped in the structure FMU (the paper's H).
pub const FMU_TABLE_HARMONICS: usize = 13;

/// Writes `out/structure.fmu` and `out/shaker.fmu`; returns their paths.
pub fn package(out: &Path) -> Result<Vec<PathBuf>> {
    let mut sc = Scenario::default_scenario();
    sc.nma.harmonics = FMU_TABLE_HARMONICS;
    let setup = Setup::new(&sc).context("paper beam for the FMU's modal table")?;
    let (nma, _) = methods::nma_table(&setup, &sc, false)?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let tmp = out.join(".host-package-tmp");
    std::fs::create_dir_all(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
    let table = tmp.join("modal_table.json");
    nma.table.write(&table)?;
    let (structure, shaker) = crate::cosim::repo::package_repo_fmus(out, Some(&table))?;
    let _ = std::fs::remove_dir_all(&tmp);
    Ok(vec![structure, shaker])
}
