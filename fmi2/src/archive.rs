//! The deflated zip writer (an `.fmu` and an `.ssp` are zip archives). Pure
//! Rust (the `zip` crate).
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use zip::write::SimpleFileOptions;

/// Why writing a zip archive (`.fmu`, `.ssp`) failed.
#[derive(Debug, thiserror::Error)]
pub enum ZipWriteError {
    #[error("cannot write {path}: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("zip error writing {path}: {source}")]
    Zip {
        path: PathBuf,
        source: zip::result::ZipError,
    },
}

/// Writes `out` as a deflated zip archive of `entries` (path inside, bytes).
pub fn write_zip(out: &Path, entries: &[(String, Vec<u8>)]) -> Result<(), ZipWriteError> {
    let zerr = |source| ZipWriteError::Zip {
        path: out.to_path_buf(),
        source,
    };
    let werr = |source| ZipWriteError::Write {
        path: out.to_path_buf(),
        source,
    };
    let file = File::create(out).map_err(werr)?;
    let mut z = zip::ZipWriter::new(file);
    // level 1: `host run` writes six FMUs (FMI 2.0 and 3.0) every time;
    // the fastest deflate level takes a third of the default's (6) time
    // on the FMU libraries at about 15 % larger archives
    let opts = SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .compression_level(Some(1));
    for (name, bytes) in entries {
        z.start_file(name.as_str(), opts).map_err(zerr)?;
        z.write_all(bytes).map_err(werr)?;
    }
    z.finish().map_err(zerr)?;
    Ok(())
}
