//! `host package`: build `structure.fmu` and `shaker.fmu` from the cdylibs
//! next to this executable, with the paper beam's modal table in the
//! structure FMU's `resources/`.
use crate::methods;
use crate::model::Setup;
use crate::scenario::Scenario;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// (modelIdentifier = cdylib name, crate)
const FMUS: &[(&str, &str)] = &[("structure", "fmu-structure"), ("shaker", "fmu-shaker")];

/// Harmonics of the modal table shipped in the structure FMU (the paper's H).
pub const FMU_TABLE_HARMONICS: usize = 13;

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

/// The built `lib<id>.so` next to the running executable (same cargo profile).
fn library(id: &str) -> Result<PathBuf> {
    let exe = std::env::current_exe().context("cannot locate the host executable")?;
    let dir = exe.parent().context("host executable has no directory")?;
    let lib = dir.join(format!("lib{id}.so"));
    if !lib.is_file() {
        bail!(
            "{} not found: build the FMU crates with the same profile first (cargo build --release builds the whole workspace)",
            lib.display()
        );
    }
    Ok(lib)
}

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
    let root = workspace_root();
    let mut written = Vec::new();
    for (id, krate) in FMUS {
        let lib = library(id)?;
        let extra = if *id == "structure" { vec![table.clone()] } else { vec![] };
        let p = fmi2::package::package_workspace_fmu(&root, id, krate, &lib, &extra, out)
            .map_err(|e| anyhow::anyhow!("packaging {id}.fmu: {e}"))?;
        written.push(p);
    }
    let _ = std::fs::remove_dir_all(&tmp);
    Ok(written)
}
