//! Unpacking an `.fmu` (a zip archive), refusing entries that would escape
//! the extraction folder or are symbolic links, and archives that would
//! unpack to more than [`ImportLimits`] allow.
use std::fs::File;
use std::io::Read;
use std::path::{Component as PathComponent, Path};

use crate::error::{FmuError, Result};

/// Bounds on what importing one `.fmu` may cost. The defaults are generous
/// for real FMUs (the two of this workspace unpack to a few MB in a dozen
/// entries) and stop zip bombs (issue 14: a 1.4 MB `.fmu` expanded to 934 MB).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImportLimits {
    /// Total bytes of all unpacked files (declared sizes, and enforced while
    /// writing, since a declared size can lie). Default 512 MiB.
    pub max_unpacked_bytes: u64,
    /// Entries (files and folders) of the archive. Default 10 000.
    pub max_entries: usize,
}

impl Default for ImportLimits {
    fn default() -> Self {
        ImportLimits {
            max_unpacked_bytes: 512 << 20,
            max_entries: 10_000,
        }
    }
}

/// Unpack `fmu` into `dir` within the default [`ImportLimits`].
pub fn unpack(fmu: &Path, dir: &Path) -> Result<()> {
    unpack_with(fmu, dir, &ImportLimits::default())
}

/// Unpack `fmu` (a regular file) into `dir`. Every entry is checked before
/// anything is written: absolute paths, `..` components and symbolic links
/// are refused, and so are more entries or (declared) bytes than `limits`
/// allow; the bytes actually written are counted against the limit too.
pub fn unpack_with(fmu: &Path, dir: &Path, limits: &ImportLimits) -> Result<()> {
    let file = fmi2::open_regular(fmu).map_err(|source| FmuError::File { source })?;
    let mut z = zip::ZipArchive::new(file).map_err(|source| FmuError::Zip {
        path: fmu.into(),
        source,
    })?;
    let zerr = |source| FmuError::Zip {
        path: fmu.into(),
        source,
    };
    if z.len() > limits.max_entries {
        return Err(FmuError::TooManyEntries {
            path: fmu.into(),
            entries: z.len(),
            max: limits.max_entries,
        });
    }
    let mut declared: u64 = 0;
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
        declared = declared.saturating_add(f.size());
        if declared > limits.max_unpacked_bytes {
            return Err(FmuError::TooLarge {
                path: fmu.into(),
                size: declared,
                max: limits.max_unpacked_bytes,
            });
        }
        plan.push((i, name, f.is_dir()));
    }
    let mut written: u64 = 0;
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
        let f = z.by_index(i).map_err(zerr)?;
        let mut out = File::create(&target).map_err(uerr)?;
        let room = limits.max_unpacked_bytes - written;
        let n = std::io::copy(&mut f.take(room.saturating_add(1)), &mut out).map_err(uerr)?;
        written += n;
        if written > limits.max_unpacked_bytes {
            return Err(FmuError::TooLarge {
                path: fmu.into(),
                size: written,
                max: limits.max_unpacked_bytes,
            });
        }
    }
    Ok(())
}
