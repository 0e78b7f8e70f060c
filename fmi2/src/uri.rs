//! Decoding of `fmuResourceLocation` URIs into paths.
//!
//! Masters send `file:///path/with%20escapes/resources` (fmpy, libcosim,
//! fmuCheck), `file:/path`, `file://localhost/path` and, unescaped,
//! `file:////tmp/...` (OMSimulator). All of these are accepted: one to four
//! slashes after `file:`, an empty or `localhost` authority, and `%XX` escapes.
use std::path::PathBuf;

/// Why a resource URI could not be turned into a path.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum UriError {
    #[error("resource location {0:?} is not a file: URI")]
    NotFile(String),
    #[error("resource location {uri:?}: bad percent escape at byte {pos}")]
    BadEscape { uri: String, pos: usize },
    #[error("resource location {uri:?}: unsupported host {host:?} (only local files)")]
    RemoteHost { uri: String, host: String },
}

/// Decode a `file:` URI into a local path.
pub fn file_uri_to_path(uri: &str) -> Result<PathBuf, UriError> {
    let rest = uri
        .strip_prefix("file:")
        .or_else(|| uri.strip_prefix("FILE:"))
        .ok_or_else(|| UriError::NotFile(uri.to_string()))?;
    let slashes = rest.bytes().take_while(|&b| b == b'/').count();
    let path_part: &str = match slashes {
        0 => return Err(UriError::NotFile(uri.to_string())),
        2 => {
            // authority: empty is handled by the 3-slash case; accept localhost
            let after = &rest[2..];
            let (host, tail) = match after.find('/') {
                Some(i) => (&after[..i], &after[i..]),
                None => (after, ""),
            };
            if host.eq_ignore_ascii_case("localhost") {
                tail
            } else {
                return Err(UriError::RemoteHost {
                    uri: uri.to_string(),
                    host: host.to_string(),
                });
            }
        }
        _ => &rest[slashes - 1..], // 1, 3, 4 (or more) slashes: one absolute root
    };
    let bytes = percent_decode(path_part).map_err(|pos| UriError::BadEscape {
        uri: uri.to_string(),
        pos: pos + (uri.len() - path_part.len()),
    })?;
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStringExt;
        Ok(PathBuf::from(std::ffi::OsString::from_vec(bytes)))
    }
    #[cfg(not(unix))]
    {
        Ok(PathBuf::from(String::from_utf8_lossy(&bytes).into_owned()))
    }
}

fn hex(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'a'..=b'f' => Some(b - b'a' + 10),
        b'A'..=b'F' => Some(b - b'A' + 10),
        _ => None,
    }
}

/// `%XX` -> byte; `Err(position)` of a malformed escape.
fn percent_decode(s: &str) -> Result<Vec<u8>, usize> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hi = b.get(i + 1).copied().and_then(hex).ok_or(i)?;
            let lo = b.get(i + 2).copied().and_then(hex).ok_or(i)?;
            out.push(hi * 16 + lo);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masters_variants_decode() {
        let p = |s: &str| file_uri_to_path(s).unwrap();
        assert_eq!(
            p("file:///tmp/a%20b/resources"),
            PathBuf::from("/tmp/a b/resources")
        );
        assert_eq!(
            p("file:/tmp/x/resources/"),
            PathBuf::from("/tmp/x/resources/")
        );
        assert_eq!(
            p("file:////tmp/x y/resources"),
            PathBuf::from("/tmp/x y/resources")
        );
        assert_eq!(p("file://localhost/tmp/r"), PathBuf::from("/tmp/r"));
        assert_eq!(p("file:///tmp/%C3%A4%25"), PathBuf::from("/tmp/\u{e4}%"));
        assert_eq!(p("file:///tmp/%c3%a4"), PathBuf::from("/tmp/\u{e4}"));
    }

    #[test]
    fn bad_uris_are_typed_errors() {
        assert_eq!(
            file_uri_to_path("http://x/y"),
            Err(UriError::NotFile("http://x/y".into()))
        );
        assert!(matches!(
            file_uri_to_path("file:///a%2"),
            Err(UriError::BadEscape { pos: 9, .. })
        ));
        assert!(matches!(
            file_uri_to_path("file:///a%zz"),
            Err(UriError::BadEscape { .. })
        ));
        assert!(matches!(
            file_uri_to_path("file://server/share"),
            Err(UriError::RemoteHost { .. })
        ));
        assert!(matches!(
            file_uri_to_path("file:relative"),
            Err(UriError::NotFile(_))
        ));
    }
}
