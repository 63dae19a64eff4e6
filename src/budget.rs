//! The memory a run may take: a large allocation is estimated first and refused beyond
//! it, with one line naming what asks for it, instead of the allocator aborting the
//! process (or the machine swapping) part-way through a frame.

use std::sync::atomic::{AtomicU64, Ordering};

/// Set by [`set_bytes`]; 0 for the machine's default.
static CHOSEN: AtomicU64 = AtomicU64::new(0);

/// Sets the budget (bytes; 0 for the default).
pub fn set_bytes(bytes: u64) {
    CHOSEN.store(bytes, Ordering::Relaxed);
}

/// The budget: as set, else three quarters of the smaller of the machine's memory and
/// the process's address-space limit (`ulimit -v`), when they can be read.
pub fn bytes() -> u64 {
    match CHOSEN.load(Ordering::Relaxed) {
        0 => default_bytes(),
        chosen => chosen,
    }
}

fn default_bytes() -> u64 {
    let total = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
            let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(kb * 1024)
        })
        .unwrap_or(u64::MAX);
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes the struct it is given, which lives on this stack.
    let address_space = match unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } {
        0 if limit.rlim_cur != libc::RLIM_INFINITY => limit.rlim_cur,
        _ => u64::MAX,
    };
    total.min(address_space) / 4 * 3
}

/// What each particle handed over costs a frame at least, in bytes: its copies (position,
/// velocity, id, radius), the density's sorted table and its volume. A frame of more
/// particles than the budget holds at this rate is refused before it is copied.
pub const BYTES_PER_PARTICLE: u64 = 128;

/// `Err(bytes needed)` when `n` particles are over the budget at [`BYTES_PER_PARTICLE`].
pub fn particles_fit(n: usize) -> Result<(), u64> {
    let needed = (n as u64).saturating_mul(BYTES_PER_PARTICLE);
    match needed <= bytes() {
        true => Ok(()),
        false => Err(needed),
    }
}

/// The bytes the process holds in memory now (its resident set), where the system says.
pub fn resident_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    // SAFETY: sysconf only reads a configuration value.
    let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    Some(pages.saturating_mul(u64::try_from(page).ok()?))
}

/// Whether the next frame may be read while this one settles ([`crate::frames::run`]):
/// that holds a second frame's input beside the one the process already holds, so it
/// is done while the process holds at most half the budget (always where the system
/// does not say what it holds).
pub fn room_for_another_frame() -> bool {
    room_within(resident_bytes(), bytes())
}

fn room_within(resident: Option<u64>, budget: u64) -> bool {
    resident.map_or(true, |held| held.saturating_mul(2) <= budget)
}

/// `bytes` for messages, in kB, MB, GB or TB.
pub fn size(bytes: u64) -> String {
    let b = bytes as f64;
    let (value, unit) = match b {
        _ if b < 1e6 => (b / 1e3, "kB"),
        _ if b < 1e9 => (b / 1e6, "MB"),
        _ if b < 1e12 => (b / 1e9, "GB"),
        _ => (b / 1e12, "TB"),
    };
    format!("{value:.1} {unit}")
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_frame_is_read_ahead_only_within_half_the_budget() {
        let held = super::resident_bytes().expect("Linux says what a process holds");
        assert!(held > 1 << 20, "{held} bytes resident");
        assert!(super::room_within(Some(held), 2 * held));
        assert!(!super::room_within(Some(held), 2 * held - 1));
        assert!(super::room_within(None, 0));
    }

    #[test]
    fn sizes_read_in_their_unit() {
        assert_eq!(super::size(4_670_712), "4.7 MB");
        assert_eq!(super::size(3_100_000_000), "3.1 GB");
        assert_eq!(super::size(250_150_000_000_000), "250.2 TB");
        assert_eq!(super::size(100_000), "100.0 kB");
    }
}
