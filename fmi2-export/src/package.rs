//! Writing `.fmu` archives (zip): `modelDescription.xml`,
//! `binaries/linux64/<modelIdentifier>.so` (FMI 2.0, [`write_fmu`]) or
//! `binaries/x86_64-linux/<modelIdentifier>.so` (FMI 3.0, [`write_fmu3`]),
//! `resources/...` and `documentation/...`. Pure Rust (the `zip` crate).
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

pub use fmi2::archive::{write_zip, ZipWriteError};

/// Why an FMU could not be written; each variant names the file or model involved.
#[derive(Debug, thiserror::Error)]
pub enum PackageError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(transparent)]
    Archive(#[from] ZipWriteError),
    #[error("FMU '{model}': invalid modelDescription: {reason}")]
    BadModelDescription { model: String, reason: String },
    #[error("modelDescription.xml names modelIdentifier {found:?}, expected {expected:?}")]
    IdentifierMismatch { found: String, expected: String },
}

/// The parts of one FMU. Everything but the shared library is given as
/// contents, so that a packager can embed them at compile time.
#[derive(Debug, Clone)]
pub struct FmuSpec {
    /// `modelIdentifier` (= shared library name without `lib` and `.so`).
    pub model_identifier: String,
    /// The text of `modelDescription.xml`.
    pub model_description: String,
    /// The built shared library (`lib<id>.so`).
    pub library: PathBuf,
    /// Files under `resources/`: (path inside `resources/`, contents).
    pub resources: Vec<(String, Vec<u8>)>,
    /// Files under `documentation/`: (path inside, contents).
    pub documentation: Vec<(String, Vec<u8>)>,
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

/// Every regular file below `dir`, as (relative path with `/`, contents), sorted.
pub fn read_files_below(dir: &Path) -> Result<Vec<(String, Vec<u8>)>, PackageError> {
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
                let bytes = read(&p)?;
                out.push((rel, bytes));
            }
        }
    }
    out.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(out)
}

/// Write `spec` as a zip archive at `out`, after checking that the
/// modelDescription parses and names the same `modelIdentifier`.
pub fn write_fmu(spec: &FmuSpec, out: &Path) -> Result<(), PackageError> {
    let parsed = fmi2::ModelDescription::parse(&spec.model_description).map_err(|e| {
        PackageError::BadModelDescription {
            model: spec.model_identifier.clone(),
            reason: e.to_string(),
        }
    })?;
    let found = parsed.co_simulation.model_identifier;
    if found != spec.model_identifier {
        return Err(PackageError::IdentifierMismatch {
            found,
            expected: spec.model_identifier.clone(),
        });
    }
    write_archive(spec, "linux64", out)
}

/// Write `spec` as an FMI 3.0 archive at `out` (the library in
/// `binaries/x86_64-linux/`), after checking that the modelDescription is an
/// FMI 3.0 one naming the same `modelIdentifier` (the same `lib<id>.so`
/// serves both versions: it exports the `fmi2*` and the `fmi3*` functions).
pub fn write_fmu3(spec: &FmuSpec, out: &Path) -> Result<(), PackageError> {
    let md = &spec.model_description;
    if !md.contains("fmiVersion=\"3.0\"") {
        return Err(PackageError::BadModelDescription {
            model: spec.model_identifier.clone(),
            reason: "not an FMI 3.0 modelDescription (no fmiVersion=\"3.0\")".into(),
        });
    }
    let ids: Vec<&str> = md
        .split("modelIdentifier=\"")
        .skip(1)
        .filter_map(|rest| rest.split('"').next())
        .collect();
    if let Some(found) = ids.iter().find(|&&id| id != spec.model_identifier) {
        return Err(PackageError::IdentifierMismatch {
            found: found.to_string(),
            expected: spec.model_identifier.clone(),
        });
    }
    if ids.is_empty() {
        return Err(PackageError::BadModelDescription {
            model: spec.model_identifier.clone(),
            reason: "no modelIdentifier".into(),
        });
    }
    write_archive(spec, "x86_64-linux", out)
}

/// The archive with the library in `binaries/<platform>/`.
fn write_archive(spec: &FmuSpec, platform: &str, out: &Path) -> Result<(), PackageError> {
    let mut entries = vec![
        (
            "modelDescription.xml".to_string(),
            spec.model_description.as_bytes().to_vec(),
        ),
        (
            format!("binaries/{platform}/{}.so", spec.model_identifier),
            read(&spec.library)?,
        ),
    ];
    for (rel, bytes) in &spec.resources {
        entries.push((format!("resources/{rel}"), bytes.clone()));
    }
    for (rel, bytes) in &spec.documentation {
        entries.push((format!("documentation/{rel}"), bytes.clone()));
    }
    Ok(write_zip(out, &entries)?)
}

/// The `documentation/` of an FMU from its README: `README.md` as written and
/// `index.html` (the entry point the standard names, see [`markdown_as_html`]).
pub fn readme_documentation(title: &str, readme: &str) -> Vec<(String, Vec<u8>)> {
    vec![
        ("README.md".to_string(), readme.as_bytes().to_vec()),
        (
            "index.html".to_string(),
            markdown_as_html(title, readme).into_bytes(),
        ),
    ]
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
        let md = r#"<fmiModelDescription fmiVersion="2.0" modelName="m" guid="{g}"><CoSimulation modelIdentifier="m"/></fmiModelDescription>"#;
        std::fs::write(p("libm.so"), b"\x7fELF...").unwrap();
        std::fs::create_dir_all(p("res/sub")).unwrap();
        std::fs::write(p("res/sub/table.json"), b"{}").unwrap();
        std::fs::write(p("res/a.txt"), b"a").unwrap();
        let spec = FmuSpec {
            model_identifier: "m".into(),
            model_description: md.into(),
            library: p("libm.so"),
            resources: read_files_below(&p("res")).unwrap(),
            documentation: vec![("index.html".into(), b"a".to_vec())],
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

    #[test]
    fn fmi3_archives_put_the_library_in_x86_64_linux() {
        let dir = tempfile::tempdir().unwrap();
        let p = |n: &str| dir.path().join(n);
        std::fs::write(p("libm.so"), b"\x7fELF...").unwrap();
        let md = r#"<fmiModelDescription fmiVersion="3.0" modelName="m" instantiationToken="{g}"><CoSimulation modelIdentifier="m"/></fmiModelDescription>"#;
        let spec = FmuSpec {
            model_identifier: "m".into(),
            model_description: md.into(),
            library: p("libm.so"),
            resources: vec![("t.json".into(), b"{}".to_vec())],
            documentation: vec![("index.html".into(), b"a".to_vec())],
        };
        write_fmu3(&spec, &p("m.fmu")).unwrap();
        let z = zip::ZipArchive::new(File::open(p("m.fmu")).unwrap()).unwrap();
        let mut names: Vec<&str> = z.file_names().collect();
        names.sort();
        assert_eq!(
            names,
            [
                "binaries/x86_64-linux/m.so",
                "documentation/index.html",
                "modelDescription.xml",
                "resources/t.json"
            ]
        );
        let fmi2 = FmuSpec {
            model_description: md.replace("3.0", "2.0"),
            ..spec.clone()
        };
        assert!(matches!(
            write_fmu3(&fmi2, &p("x.fmu")),
            Err(PackageError::BadModelDescription { .. })
        ));
        let other = FmuSpec {
            model_identifier: "other".into(),
            ..spec
        };
        assert!(matches!(
            write_fmu3(&other, &p("x.fmu")),
            Err(PackageError::IdentifierMismatch { .. })
        ));
    }
}
