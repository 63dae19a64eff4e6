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

/// `bytes` in GB for messages.
pub fn gb(bytes: u64) -> String {
    format!("{:.1} GB", bytes as f64 / 1e9)
}
