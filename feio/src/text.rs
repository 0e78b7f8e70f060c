//! Byte-level helpers shared by the readers.
use crate::Error;
use std::io::Read;
use std::path::Path;

/// Bytes of text below which a window is parsed on one thread.
pub const PARALLEL_MIN_BYTES: usize = 4 << 20;

/// Line-aligned byte ranges of `data`: one below [`PARALLEL_MIN_BYTES`], else
/// about four per thread.
pub(crate) fn line_chunks(data: &[u8]) -> Vec<std::ops::Range<usize>> {
    let threads = rayon::current_num_threads().max(1);
    if data.len() < PARALLEL_MIN_BYTES || threads == 1 {
        return std::iter::once(0..data.len()).collect();
    }
    let target = (data.len() / (4 * threads)).max(1 << 20);
    let mut out = Vec::new();
    let mut start = 0;
    while start < data.len() {
        let mut end = (start + target).min(data.len());
        if end < data.len() {
            end = data[end..]
                .iter()
                .position(|&c| c == b'\n')
                .map_or(data.len(), |i| end + i + 1);
        }
        out.push(start..end);
        start = end;
    }
    out
}

/// The lines of `b` as [`lines`] counts them.
pub(crate) fn count_lines(b: &[u8]) -> usize {
    b.iter().filter(|&&c| c == b'\n').count()
        + usize::from(!b.is_empty() && b[b.len() - 1] != b'\n')
}

/// Reads the text `buf` (already read) and then `rest` in windows of about
/// `window` bytes of whole lines, handing each window to `f` in file order
/// (the last may end without `\n`); a line longer than the window is read
/// on until it ends. So a line-oriented reader holds one window of text,
/// not the file's.
pub(crate) fn for_each_window(
    path: &Path,
    mut buf: Vec<u8>,
    rest: &mut dyn Read,
    window: usize,
    mut f: impl FnMut(&[u8]) -> Result<(), Error>,
) -> Result<(), Error> {
    let io = |e: std::io::Error| Error::Io {
        path: path.into(),
        message: e.to_string(),
    };
    let window = window.max(1);
    let mut eof = false;
    while !eof {
        // fill the window, then hand on its whole lines and keep the last partial one
        while buf.len() < window && !eof {
            let got = (&mut *rest)
                .take((window - buf.len()) as u64)
                .read_to_end(&mut buf)
                .map_err(io)?;
            eof = got == 0;
        }
        let end = if eof {
            buf.len()
        } else {
            match buf.iter().rposition(|&c| c == b'\n') {
                Some(i) => i + 1,
                // a line longer than the window: read on (at the end of
                // the file, it is the last line)
                None => {
                    let more = buf.len();
                    buf.reserve(more);
                    let got = (&mut *rest)
                        .take(more as u64)
                        .read_to_end(&mut buf)
                        .map_err(io)?;
                    if got > 0 {
                        continue;
                    }
                    eof = true;
                    buf.len()
                }
            }
        };
        f(&buf[..end])?;
        buf.drain(..end);
    }
    Ok(())
}

/// `(1-based line number, line without its `\n` and a trailing `\r`)`.
pub(crate) fn lines(b: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    let mut rest = b;
    let mut n = 0usize;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        n += 1;
        let (line, next) = match rest.iter().position(|&c| c == b'\n') {
            Some(i) => (&rest[..i], &rest[i + 1..]),
            None => (rest, &rest[rest.len()..]),
        };
        rest = next;
        Some((n, line.strip_suffix(b"\r").unwrap_or(line)))
    })
}

/// Without leading and trailing blanks (space, tab, `\r`).
pub(crate) fn trim(mut b: &[u8]) -> &[u8] {
    while let [c, rest @ ..] = b {
        if is_blank(*c) {
            b = rest;
        } else {
            break;
        }
    }
    while let [rest @ .., c] = b {
        if is_blank(*c) {
            b = rest;
        } else {
            break;
        }
    }
    b
}

#[inline]
pub(crate) fn is_blank(c: u8) -> bool {
    c == b' ' || c == b'\t' || c == b'\r'
}

/// The text of a token for a message: at most 40 characters, lossy UTF-8.
pub(crate) fn shown(b: &[u8]) -> String {
    let b = trim(b);
    let s = String::from_utf8_lossy(&b[..b.len().min(40)]).into_owned();
    if b.len() > 40 {
        format!("{s}...")
    } else if s.is_empty() {
        "end of line".into()
    } else {
        s
    }
}

/// An unsigned decimal integer at `*p` (at most 19 digits), advancing `*p`.
#[inline]
pub(crate) fn uint(b: &[u8], p: &mut usize) -> Option<u64> {
    let s = *p;
    let mut v: u64 = 0;
    while let Some(&c) = b.get(*p) {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        v = v.wrapping_mul(10).wrapping_add(d as u64);
        *p += 1;
    }
    let n = *p - s;
    (n > 0 && n <= 19).then_some(v)
}

/// A whole field as an unsigned integer (blanks around it allowed).
pub(crate) fn uint_field(f: &[u8]) -> Option<u64> {
    let f = trim(f);
    let f = f.strip_prefix(b"+").unwrap_or(f);
    let mut p = 0;
    let v = uint(f, &mut p)?;
    (p == f.len()).then_some(v)
}

/// A whole field as a decimal number (blanks around it allowed).
pub(crate) fn real_field(f: &[u8]) -> Option<f64> {
    let f = trim(f);
    match fast_float2::parse_partial::<f64, _>(f) {
        Ok((v, n)) if n == f.len() && n > 0 => Some(v),
        _ => None,
    }
}

/// Skips spaces and tabs.
#[inline]
pub(crate) fn skip_ws(b: &[u8], p: &mut usize) {
    while let Some(&c) = b.get(*p) {
        if c == b' ' || c == b'\t' {
            *p += 1;
        } else {
            break;
        }
    }
}
