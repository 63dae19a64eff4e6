//! The twin build: on a CPU with AVX2 and FMA (x86-64-v3: Intel 2013 and AMD 2015 on),
//! the same program compiled for it — `make build` puts it beside this one as
//! `activeskin-x86-64-v3` — takes the process over: 8–15 % less time on particle shots
//! (wider vectors, rounding and bit instructions inline), the same frames bit for bit
//! (Rust never fuses a multiply and an add, so no result is rounded differently; the
//! C++ bridge is built with `-ffp-contract=off` for the same reason). A farm of mixed
//! machines gives the same frames either way.
//!
//! The twin is taken only when `activeskin-x86-64-v3.for` beside it names this binary's
//! GNU build ID (the linker's hash of the program): a twin left from an older build, or
//! beside another build of other features, is never run in its place.
//! `ACTIVESKIN_BASELINE=1` keeps this binary.

use std::path::{Path, PathBuf};

/// The twin's file name after this binary's.
const SUFFIX: &str = "-x86-64-v3";

/// What `--version` says this build is compiled for.
pub const VERSION: &str = if cfg!(target_feature = "avx2") {
    concat!(env!("CARGO_PKG_VERSION"), " (x86-64-v3)")
} else {
    env!("CARGO_PKG_VERSION")
};

/// Replaces this process with the twin when the CPU runs it and it is this build's;
/// returns when it does not (or the exec fails: this binary then goes on, as it would).
pub fn take_over() {
    #[cfg(all(
        target_arch = "x86_64",
        target_os = "linux",
        not(target_feature = "avx2")
    ))]
    {
        use std::os::unix::process::CommandExt;
        if std::env::var_os("ACTIVESKIN_BASELINE").is_some_and(|v| v != "0") || !cpu_runs_v3() {
            return;
        }
        let Some(twin) = std::env::current_exe().ok().and_then(|exe| twin_of(&exe)) else {
            return;
        };
        let mut args = std::env::args_os();
        let arg0 = args.next().unwrap_or_default();
        // `exec` returns only on failure: this binary runs instead.
        let _ = std::process::Command::new(twin)
            .arg0(arg0)
            .args(args)
            .exec();
    }
}

/// This program's file as the user named it: the baseline binary when this is its twin
/// (for a farm's jobs, which may land on machines that cannot run the twin).
pub fn program() -> std::io::Result<PathBuf> {
    let exe = std::env::current_exe()?;
    let baseline = exe
        .file_name()
        .and_then(|n| n.to_str())
        .and_then(|n| n.strip_suffix(SUFFIX))
        .map(|n| exe.with_file_name(n))
        .filter(|b| cfg!(target_feature = "avx2") && b.is_file());
    Ok(baseline.unwrap_or(exe))
}

/// x86-64-v3's features beyond what this binary was compiled for.
#[cfg(target_arch = "x86_64")]
#[cfg_attr(
    any(not(target_os = "linux"), target_feature = "avx2"),
    allow(dead_code)
)]
fn cpu_runs_v3() -> bool {
    is_x86_feature_detected!("avx2")
        && is_x86_feature_detected!("fma")
        && is_x86_feature_detected!("bmi1")
        && is_x86_feature_detected!("bmi2")
        && is_x86_feature_detected!("lzcnt")
        && is_x86_feature_detected!("movbe")
        && is_x86_feature_detected!("f16c")
        && is_x86_feature_detected!("sse4.2")
        && is_x86_feature_detected!("popcnt")
}

/// The twin beside `exe`, when its `.for` file names `exe`'s build ID.
#[cfg_attr(
    not(all(
        target_arch = "x86_64",
        target_os = "linux",
        not(target_feature = "avx2")
    )),
    allow(dead_code)
)]
fn twin_of(exe: &Path) -> Option<PathBuf> {
    let name = exe.file_name()?.to_str()?;
    let twin = exe.with_file_name(format!("{name}{SUFFIX}"));
    let stamp = std::fs::read_to_string(exe.with_file_name(format!("{name}{SUFFIX}.for"))).ok()?;
    let id = build_id(exe)?;
    (stamp.trim() == id && twin.is_file()).then_some(twin)
}

/// The GNU build ID of the 64-bit little-endian ELF file at `path`, in hex: the note the
/// linker writes (Debian's toolchain by default), a hash of the whole program.
pub fn build_id(path: &Path) -> Option<String> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = std::fs::File::open(path).ok()?;
    let mut header = [0u8; 64];
    file.read_exact(&mut header).ok()?;
    // 64-bit (class 2), little-endian (data 1).
    if header[..4] != *b"\x7fELF" || header[4] != 2 || header[5] != 1 {
        return None;
    }
    let u16_at = |b: &[u8], at: usize| u16::from_le_bytes([b[at], b[at + 1]]);
    let u32_at = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let u64_at = |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().unwrap());
    let (phoff, phentsize, phnum) = (
        u64_at(&header, 0x20),
        usize::from(u16_at(&header, 0x36)),
        usize::from(u16_at(&header, 0x38)),
    );
    if phentsize < 0x28 || phnum > 256 {
        return None;
    }
    let mut table = vec![0u8; phentsize * phnum];
    file.seek(SeekFrom::Start(phoff)).ok()?;
    file.read_exact(&mut table).ok()?;
    const PT_NOTE: u32 = 4;
    const NT_GNU_BUILD_ID: u32 = 3;
    for entry in table.chunks_exact(phentsize) {
        let (offset, size) = (u64_at(entry, 0x08), u64_at(entry, 0x20));
        if u32_at(entry, 0) != PT_NOTE || size > 1 << 16 {
            continue;
        }
        let mut notes = vec![0u8; size as usize];
        file.seek(SeekFrom::Start(offset)).ok()?;
        file.read_exact(&mut notes).ok()?;
        // Each note: name size, description size, type, then both padded to 4 bytes.
        let mut at = 0;
        while at + 12 <= notes.len() {
            let name_size = u32_at(&notes, at) as usize;
            let desc_size = u32_at(&notes, at + 4) as usize;
            let kind = u32_at(&notes, at + 8);
            let name_at = at + 12;
            let desc_at = name_at + name_size.div_ceil(4) * 4;
            let end = desc_at + desc_size.div_ceil(4) * 4;
            if desc_at + desc_size > notes.len() {
                break;
            }
            if kind == NT_GNU_BUILD_ID && notes[name_at..name_at + name_size] == *b"GNU\0" {
                let desc = &notes[desc_at..desc_at + desc_size];
                return Some(desc.iter().map(|b| format!("{b:02x}")).collect());
            }
            at = end;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn this_test_binary_has_a_build_id_as_readelf_prints_it() {
        let exe = std::env::current_exe().unwrap();
        let Ok(out) = std::process::Command::new("readelf")
            .arg("-n")
            .arg(&exe)
            .output()
        else {
            eprintln!("readelf is not installed: compared with nothing");
            return;
        };
        let text = String::from_utf8_lossy(&out.stdout);
        let readelf = text
            .lines()
            .find_map(|l| l.trim().strip_prefix("Build ID: "))
            .map(str::to_owned);
        assert_eq!(build_id(&exe), readelf);
        assert!(readelf.is_some(), "{text}");
    }

    #[test]
    fn no_build_id_in_what_is_not_an_elf_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("not_elf");
        std::fs::write(&path, b"#!/bin/sh\necho hello\n").unwrap();
        assert_eq!(build_id(&path), None);
        std::fs::write(&path, b"\x7fELF\x02\x01").unwrap();
        assert_eq!(build_id(&path), None);
    }

    #[test]
    fn a_twin_is_taken_only_when_its_stamp_names_this_build() {
        let dir = tempfile::tempdir().unwrap();
        let exe = dir.path().join("activeskin");
        std::fs::copy(std::env::current_exe().unwrap(), &exe).unwrap();
        let twin = dir.path().join("activeskin-x86-64-v3");
        let stamp = dir.path().join("activeskin-x86-64-v3.for");
        assert_eq!(twin_of(&exe), None, "no twin");
        std::fs::write(&twin, b"").unwrap();
        assert_eq!(twin_of(&exe), None, "no stamp");
        std::fs::write(&stamp, "0123456789abcdef\n").unwrap();
        assert_eq!(twin_of(&exe), None, "another build's stamp");
        let Some(id) = build_id(&exe) else {
            panic!("this test binary has no build ID");
        };
        std::fs::write(&stamp, format!("{id}\n")).unwrap();
        assert_eq!(twin_of(&exe), Some(twin));
    }
}
