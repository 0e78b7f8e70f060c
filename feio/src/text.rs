//! Byte-level helpers shared by the readers.

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
