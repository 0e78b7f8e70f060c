//! Reading input files that no input can hang or exhaust: only regular files
//! (a named pipe, a device such as `/dev/zero`, a directory are refused
//! before they are opened for reading), and at most a given number of bytes.
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Why an input file was not read.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("{path}: not a regular file ({kind}); only regular files are read")]
    NotRegular { path: PathBuf, kind: &'static str },
    #[error("{path}: {size} bytes, more than the limit of {max} bytes")]
    TooLarge { path: PathBuf, size: u64, max: u64 },
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not UTF-8 text")]
    NotUtf8 { path: PathBuf },
}

fn kind(m: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = m.file_type();
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a named pipe"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a file"
    }
}

/// Open `path` for reading if it is a regular file (symbolic links followed).
/// The type is checked before `open` (opening a named pipe blocks) and again
/// on the open file.
pub fn open_regular(path: &Path) -> Result<File, FileError> {
    let io = |source| FileError::Io {
        path: path.into(),
        source,
    };
    let m = std::fs::metadata(path).map_err(io)?;
    if !m.is_file() {
        return Err(FileError::NotRegular {
            path: path.into(),
            kind: kind(&m),
        });
    }
    let f = File::open(path).map_err(io)?;
    let m = f.metadata().map_err(io)?;
    if !m.is_file() {
        return Err(FileError::NotRegular {
            path: path.into(),
            kind: kind(&m),
        });
    }
    Ok(f)
}

/// The bytes of the regular file `path`, at most `max_bytes` of them (a larger
/// file is [`FileError::TooLarge`], also when it grows while being read).
pub fn read_regular(path: &Path, max_bytes: u64) -> Result<Vec<u8>, FileError> {
    let f = open_regular(path)?;
    let io = |source| FileError::Io {
        path: path.into(),
        source,
    };
    let size = f.metadata().map_err(io)?.len();
    if size > max_bytes {
        return Err(FileError::TooLarge {
            path: path.into(),
            size,
            max: max_bytes,
        });
    }
    let mut bytes = Vec::with_capacity(size as usize);
    f.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > max_bytes {
        return Err(FileError::TooLarge {
            path: path.into(),
            size: bytes.len() as u64,
            max: max_bytes,
        });
    }
    Ok(bytes)
}

/// [`read_regular`] as UTF-8 text.
pub fn read_regular_to_string(path: &Path, max_bytes: u64) -> Result<String, FileError> {
    String::from_utf8(read_regular(path, max_bytes)?)
        .map_err(|_| FileError::NotUtf8 { path: path.into() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_pipes_and_directories_are_refused_at_once() {
        let t0 = std::time::Instant::now();
        for p in ["/dev/zero", "/dev/null", "/"] {
            let e = read_regular(Path::new(p), 1 << 20).unwrap_err();
            assert!(matches!(e, FileError::NotRegular { .. }), "{p}: {e}");
        }
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let ok = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        if ok {
            let e = read_regular(&fifo, 1 << 20).unwrap_err();
            assert!(e.to_string().contains("named pipe"), "{e}");
        }
        assert!(t0.elapsed().as_secs_f64() < 1.0);
        let f = dir.path().join("big");
        std::fs::write(&f, vec![b'a'; 100]).unwrap();
        assert_eq!(read_regular(&f, 100).unwrap().len(), 100);
        let e = read_regular(&f, 99).unwrap_err();
        assert!(
            matches!(
                e,
                FileError::TooLarge {
                    size: 100,
                    max: 99,
                    ..
                }
            ),
            "{e}"
        );
        assert!(matches!(
            read_regular(&dir.path().join("none"), 10),
            Err(FileError::Io { .. })
        ));
    }
}
