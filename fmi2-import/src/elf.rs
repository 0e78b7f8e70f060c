//! A shared library must be a well-formed ELF file for this architecture,
//! with its header, program headers, loaded segments and section headers all
//! inside the file, before `dlopen` maps it: a truncated ELF mapped by the
//! dynamic loader kills the process with SIGBUS instead of giving an error.
//! Hand-rolled (fixed ELF64 offsets, about forty lines) rather than a parser
//! crate: only these bounds are checked, and no other dependency is needed.

/// `e_machine` of the host architecture (`None`: not checked).
const MACHINE: Option<u16> = if cfg!(target_arch = "x86_64") {
    Some(62)
} else if cfg!(target_arch = "aarch64") {
    Some(183)
} else {
    None
};

fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}
fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"))
}
fn u64_at(b: &[u8], o: usize) -> u64 {
    u64::from_le_bytes(b[o..o + 8].try_into().expect("8 bytes"))
}

/// `Ok` if `b` is a little-endian ELF64 shared object for this machine whose
/// headers and `PT_LOAD` segments lie inside `b`; otherwise the reason.
pub(crate) fn check(b: &[u8]) -> Result<(), String> {
    let len = b.len() as u64;
    if b.len() < 64 || &b[..4] != b"\x7fELF" {
        return Err(format!("not an ELF file ({len} bytes)"));
    }
    if b[4] != 2 || b[5] != 1 {
        return Err("not a 64-bit little-endian ELF file".into());
    }
    let e_type = u16_at(b, 16);
    if e_type != 3 {
        return Err(format!("ELF type {e_type}, not a shared object (3)"));
    }
    let machine = u16_at(b, 18);
    if let Some(m) = MACHINE {
        if machine != m {
            return Err(format!(
                "ELF machine {machine}, but this host is {} (machine {m})",
                std::env::consts::ARCH
            ));
        }
    }
    let inside = |what: &str, off: u64, size: u64| -> Result<(), String> {
        match off.checked_add(size) {
            Some(end) if end <= len => Ok(()),
            _ => Err(format!(
                "{what} at offset {off} with {size} bytes ends beyond the file ({len} bytes): truncated?"
            )),
        }
    };
    let (phoff, phentsize, phnum) = (u64_at(b, 32), u16_at(b, 54), u16_at(b, 56));
    let (shoff, shentsize, shnum) = (u64_at(b, 40), u16_at(b, 58), u16_at(b, 60));
    if phnum == 0 || phentsize != 56 {
        return Err(format!(
            "{phnum} program headers of {phentsize} bytes (expected 56)"
        ));
    }
    inside("program header table", phoff, phnum as u64 * 56)?;
    for i in 0..phnum as u64 {
        let h = (phoff + i * 56) as usize;
        let p_type = u32_at(b, h);
        if p_type == 1 {
            // PT_LOAD: the file part of the segment must be in the file
            inside(
                &format!("loadable segment {i}"),
                u64_at(b, h + 8),
                u64_at(b, h + 32),
            )?;
        }
    }
    if shnum > 0 {
        inside(
            "section header table",
            shoff,
            shnum as u64 * shentsize as u64,
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::check;

    #[test]
    fn this_test_binary_passes_and_truncations_fail() {
        // a shared object of this build: the test's own C library built by build.rs
        // is not at hand here, so use the dynamic loader's own library
        let candidates = [
            "/lib/x86_64-linux-gnu/libc.so.6",
            "/lib/aarch64-linux-gnu/libc.so.6",
            "/usr/lib64/libc.so.6",
        ];
        let Some(bytes) = candidates.iter().find_map(|p| std::fs::read(p).ok()) else {
            return;
        };
        check(&bytes).unwrap();
        for cut in [0, 3, 63, 64 + 10, bytes.len() / 2, bytes.len() - 1] {
            assert!(check(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        let mut other = bytes.clone();
        other[18] ^= 0x40;
        assert!(check(&other).unwrap_err().contains("machine"));
        assert!(check(b"#!/bin/sh\n").is_err());
    }
}
