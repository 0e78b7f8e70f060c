//! Unpacking an `.fmu` (a zip archive), refusing entries that would escape
//! the extraction folder or are symbolic links.
use std::fs::File;
use std::path::{Component as PathComponent, Path};

use crate::error::{FmuError, Result};

/// Unpack `fmu` into `dir`. Every entry is checked before anything is written:
/// absolute paths, `..` components and symbolic links are refused.
pub fn unpack(fmu: &Path, dir: &Path) -> Result<()> {
    let file = File::open(fmu).map_err(|source| FmuError::Open {
        path: fmu.into(),
        source,
    })?;
    let mut z = zip::ZipArchive::new(file).map_err(|source| FmuError::Zip {
        path: fmu.into(),
        source,
    })?;
    let zerr = |source| FmuError::Zip {
        path: fmu.into(),
        source,
    };
    let mut plan = Vec::with_capacity(z.len());
    for i in 0..z.len() {
        let f = z.by_index_raw(i).map_err(zerr)?;
        let name = f.name().to_string();
        let rel = Path::new(&name);
        let safe = !name.contains('\\')
            && !name.contains('\0')
            && rel
                .components()
                .all(|c| matches!(c, PathComponent::Normal(_) | PathComponent::CurDir));
        if !safe || f.enclosed_name().is_none() {
            return Err(FmuError::UnsafeEntry {
                path: fmu.into(),
                entry: name,
            });
        }
        if f.is_symlink() {
            return Err(FmuError::Symlink {
                path: fmu.into(),
                entry: name,
            });
        }
        plan.push((i, name, f.is_dir()));
    }
    for (i, name, is_dir) in plan {
        let uerr = |source| FmuError::Unpack {
            path: fmu.into(),
            entry: name.clone(),
            source,
        };
        let target = dir.join(&name);
        if is_dir {
            std::fs::create_dir_all(&target).map_err(uerr)?;
            continue;
        }
        if let Some(p) = target.parent() {
            std::fs::create_dir_all(p).map_err(uerr)?;
        }
        let mut f = z.by_index(i).map_err(zerr)?;
        let mut out = File::create(&target).map_err(uerr)?;
        std::io::copy(&mut f, &mut out).map_err(uerr)?;
    }
    Ok(())
}
