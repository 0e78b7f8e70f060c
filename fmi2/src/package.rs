//! Writing `.fmu` archives (zip): `modelDescription.xml`,
//! `binaries/linux64/<modelIdentifier>.so`, `resources/...` and
//! `documentation/...`. Pure Rust (the `zip` crate).
use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use zip::write::SimpleFileOptions;

/// Why an FMU could not be written; each variant names the file involved.
#[derive(Debug, thiserror::Error)]
pub enum PackageError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(transparent)]
    Archive(#[from] ZipWriteError),
    #[error("{path}: invalid modelDescription: {reason}")]
    BadModelDescription { path: PathBuf, reason: String },
    #[error("{path}: modelIdentifier is {found:?}, expected {expected:?}")]
    IdentifierMismatch {
        path: PathBuf,
        found: String,
        expected: String,
    },
}

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
    let opts = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in entries {
        z.start_file(name.as_str(), opts).map_err(zerr)?;
        z.write_all(bytes).map_err(werr)?;
    }
    z.finish().map_err(zerr)?;
    Ok(())
}

/// The parts of one FMU.
#[derive(Debug, Clone)]
pub struct FmuSpec {
    /// `modelIdentifier` (= shared library name without `lib` and `.so`).
    pub model_identifier: String,
    pub model_description: PathBuf,
    /// The built shared library (`lib<id>.so`).
    pub library: PathBuf,
    /// Files to put under `resources/`: (source, path inside `resources/`).
    pub resources: Vec<(PathBuf, String)>,
    /// Files to put under `documentation/`: (source, path inside).
    pub documentation: Vec<(PathBuf, String)>,
}

fn read(path: &Path) -> Result<Vec<u8>, PackageError> {
    let mut v = Vec::new();
    File::open(path)
        .and_then(|mut f| f.read_to_end(&mut v))
        .map_err(|source| PackageError::Read {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(v)
}

/// All regular files below `dir`, as (path, relative path with `/`), sorted.
pub fn files_below(dir: &Path) -> Result<Vec<(PathBuf, String)>, PackageError> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let rd = std::fs::read_dir(&d).map_err(|source| PackageError::Read {
            path: d.clone(),
            source,
        })?;
        for e in rd {
            let e = e.map_err(|source| PackageError::Read {
                path: d.clone(),
                source,
            })?;
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p
                    .strip_prefix(dir)
                    .expect("below dir")
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect::<Vec<_>>()
                    .join("/");
                out.push((p, rel));
            }
        }
    }
    out.sort_by(|a, b| a.1.cmp(&b.1));
    Ok(out)
}

/// Write `spec` as a zip archive at `out`, after checking that the
/// modelDescription parses and names the same `modelIdentifier`.
pub fn write_fmu(spec: &FmuSpec, out: &Path) -> Result<(), PackageError> {
    let md = read(&spec.model_description)?;
    let md_text = String::from_utf8(md.clone()).map_err(|e| PackageError::BadModelDescription {
        path: spec.model_description.clone(),
        reason: e.to_string(),
    })?;
    let parsed =
        crate::xml::parse(&md_text).map_err(|reason| PackageError::BadModelDescription {
            path: spec.model_description.clone(),
            reason,
        })?;
    if parsed.model_identifier != spec.model_identifier {
        return Err(PackageError::IdentifierMismatch {
            path: spec.model_description.clone(),
            found: parsed.model_identifier,
            expected: spec.model_identifier.clone(),
        });
    }
    let mut entries = vec![
        ("modelDescription.xml".to_string(), md),
        (
            format!("binaries/linux64/{}.so", spec.model_identifier),
            read(&spec.library)?,
        ),
    ];
    for (src, rel) in &spec.resources {
        entries.push((format!("resources/{rel}"), read(src)?));
    }
    for (src, rel) in &spec.documentation {
        entries.push((format!("documentation/{rel}"), read(src)?));
    }
    Ok(write_zip(out, &entries)?)
}

/// Minimal HTML page showing a Markdown text verbatim (`documentation/index.html`
/// is the entry point the standard names).
pub fn markdown_as_html(title: &str, markdown: &str) -> String {
    let esc = markdown
        .replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;");
    format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{title}</title></head>\n<body><pre>\n{esc}\n</pre></body></html>\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_the_standard_layout_and_checks_the_identifier() {
        let dir = tempfile::tempdir().unwrap();
        let p = |n: &str| dir.path().join(n);
        std::fs::write(
            p("md.xml"),
            r#"<fmiModelDescription fmiVersion="2.0" modelName="m" guid="{g}"><CoSimulation modelIdentifier="m"/></fmiModelDescription>"#,
        )
        .unwrap();
        std::fs::write(p("libm.so"), b"\x7fELF...").unwrap();
        std::fs::create_dir_all(p("res/sub")).unwrap();
        std::fs::write(p("res/sub/table.json"), b"{}").unwrap();
        std::fs::write(p("res/a.txt"), b"a").unwrap();
        let spec = FmuSpec {
            model_identifier: "m".into(),
            model_description: p("md.xml"),
            library: p("libm.so"),
            resources: files_below(&p("res")).unwrap(),
            documentation: vec![(p("res/a.txt"), "index.html".into())],
        };
        write_fmu(&spec, &p("m.fmu")).unwrap();
        let mut z = zip::ZipArchive::new(File::open(p("m.fmu")).unwrap()).unwrap();
        let mut names: Vec<String> = (0..z.len())
            .map(|i| z.by_index(i).unwrap().name().to_string())
            .collect();
        names.sort();
        assert_eq!(
            names,
            [
                "binaries/linux64/m.so",
                "documentation/index.html",
                "modelDescription.xml",
                "resources/a.txt",
                "resources/sub/table.json"
            ]
        );
        let mut so = Vec::new();
        z.by_name("binaries/linux64/m.so")
            .unwrap()
            .read_to_end(&mut so)
            .unwrap();
        assert_eq!(so, b"\x7fELF...");
        let bad = FmuSpec {
            model_identifier: "other".into(),
            ..spec
        };
        assert!(matches!(
            write_fmu(&bad, &p("x.fmu")),
            Err(PackageError::IdentifierMismatch { .. })
        ));
    }
}

/// Package the workspace FMU `id` (crate `krate`) from its built library:
/// `modelDescription/<id>/modelDescription.xml`, every file below
/// `modelDescription/<id>/resources/` plus `extra_resources`, and as
/// documentation the crate's `README.md` (also rendered as `index.html`) plus
/// `modelDescription/<id>/documentation/`. Writes `out_dir/<id>.fmu`.
pub fn package_workspace_fmu(
    root: &Path,
    id: &str,
    krate: &str,
    library: &Path,
    extra_resources: &[PathBuf],
    out_dir: &Path,
) -> Result<PathBuf, String> {
    let md_dir = root.join("modelDescription").join(id);
    let mut resources = Vec::new();
    if md_dir.join("resources").is_dir() {
        resources = files_below(&md_dir.join("resources")).map_err(|e| e.to_string())?;
    }
    for f in extra_resources {
        let name = f
            .file_name()
            .ok_or(format!("resource {}: no file name", f.display()))?;
        resources.push((f.clone(), name.to_string_lossy().into_owned()));
    }
    std::fs::create_dir_all(out_dir)
        .map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;
    let tmp = out_dir.join(format!(".package-{id}-tmp"));
    let mut documentation = Vec::new();
    let readme = root.join(krate).join("README.md");
    if readme.is_file() {
        let text =
            std::fs::read_to_string(&readme).map_err(|e| format!("{}: {e}", readme.display()))?;
        std::fs::create_dir_all(&tmp).map_err(|e| e.to_string())?;
        let html = tmp.join("index.html");
        std::fs::write(&html, markdown_as_html(id, &text)).map_err(|e| e.to_string())?;
        documentation.push((readme.clone(), "README.md".to_string()));
        documentation.push((html, "index.html".to_string()));
    }
    if md_dir.join("documentation").is_dir() {
        documentation
            .extend(files_below(&md_dir.join("documentation")).map_err(|e| e.to_string())?);
    }
    let spec = FmuSpec {
        model_identifier: id.to_string(),
        model_description: md_dir.join("modelDescription.xml"),
        library: library.to_path_buf(),
        resources,
        documentation,
    };
    let path = out_dir.join(format!("{id}.fmu"));
    let result = write_fmu(&spec, &path).map_err(|e| e.to_string());
    let _ = std::fs::remove_dir_all(&tmp);
    result.map(|()| path)
}

/// Build the cdylibs of the workspace `packages` with cargo (`--release` if
/// `release`) and return (library target name, path of the `.so`) from cargo's
/// JSON messages. The libraries of the whole workspace are built, so that the
/// dependencies are compiled with the same features as by `cargo build` and
/// an up-to-date tree makes this a no-op.
pub fn build_libraries(
    root: &Path,
    packages: &[&str],
    release: bool,
) -> Result<Vec<(String, PathBuf)>, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = std::process::Command::new(&cargo);
    cmd.current_dir(root).args([
        "build",
        "--workspace",
        "--lib",
        "--message-format=json-render-diagnostics",
    ]);
    if release {
        cmd.arg("--release");
    }
    let out = cmd
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run cargo ({cargo}): {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "cargo build -p {} failed ({})",
            packages.join(" -p "),
            out.status
        ));
    }
    let mut libs = Vec::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        if v["reason"] != "compiler-artifact" {
            continue;
        }
        let package = v["package_id"].as_str().unwrap_or_default();
        if !packages
            .iter()
            .any(|p| package.contains(&format!("/{p}#")) || package.contains(&format!("{p} ")))
        {
            continue;
        }
        let name = v["target"]["name"].as_str().unwrap_or_default().to_string();
        for f in v["filenames"].as_array().into_iter().flatten() {
            if let Some(f) = f.as_str().filter(|f| f.ends_with(".so")) {
                libs.push((name.clone(), PathBuf::from(f)));
            }
        }
    }
    Ok(libs)
}
