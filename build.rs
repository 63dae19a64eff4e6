//! Builds the C++ bridge to OpenVDB (`cpp/`) with cxx and links Debian's OpenVDB 10.
//!
//! When a header the bridge needs is missing, the build stops with one line naming the
//! command that installs it, instead of a page of compiler errors.

#[cfg(feature = "vdb")]
use std::path::{Path, PathBuf};

#[cfg(feature = "vdb")]
/// Header to look for, the Debian package that ships it.
const REQUIRED: &[(&str, &str)] = &[
    ("openvdb/openvdb.h", "libopenvdb-dev"),
    ("boost/any.hpp", "libboost-dev"),
    ("tbb/tbb.h", "libtbb-dev"),
    ("Imath/half.h", "libimath-dev"),
];

#[cfg(feature = "vdb")]
const BRIDGE_SOURCES: &[&str] = &[
    "cpp/vdb_bridge.cc",
    "cpp/vdb_tools.cc",
    "cpp/vdb_points.cc",
    "cpp/vdb_vectors.cc",
];

#[cfg(feature = "vdb")]
/// Folders named by `OPENVDB_INCLUDE_DIR` (a PATH-style list), searched before the system's.
fn extra_include_dirs() -> Vec<PathBuf> {
    std::env::var_os("OPENVDB_INCLUDE_DIR")
        .map(|d| std::env::split_paths(&d).collect())
        .unwrap_or_default()
}

fn main() {
    // Without the `vdb` feature there is no C++ to build: the core is pure Rust.
    #[cfg(feature = "vdb")]
    build_bridge();
}

#[cfg(feature = "vdb")]
fn build_bridge() {
    println!("cargo::rerun-if-changed=src/io/vdb/ffi.rs");
    println!("cargo::rerun-if-changed=cpp");
    println!("cargo::rerun-if-env-changed=OPENVDB_INCLUDE_DIR");
    println!("cargo::rerun-if-env-changed=OPENVDB_LIB_DIR");

    let extra = extra_include_dirs();
    let system = [
        PathBuf::from("/usr/include"),
        PathBuf::from("/usr/local/include"),
    ];
    let dirs: Vec<&PathBuf> = extra.iter().chain(&system).collect();
    let found = |header: &str| dirs.iter().any(|d| Path::new(d).join(header).is_file());
    let missing: Vec<&str> = REQUIRED
        .iter()
        .filter(|(header, _)| !found(header))
        .map(|&(_, package)| package)
        .collect();
    if !missing.is_empty() {
        println!(
            "cargo::error=OpenVDB build headers are missing; install them with `make deps` \
             or `sudo apt-get install {}`",
            missing.join(" ")
        );
        return;
    }

    let mut build = cxx_build::bridge("src/io/vdb/ffi.rs");
    build
        .files(BRIDGE_SOURCES)
        .include("cpp")
        .std("c++17")
        .flag_if_supported("-Wno-deprecated-declarations")
        .flag_if_supported("-Wno-unused-parameter")
        // No fused multiply-adds where the twin build (x86-64-v3, cc reads its target CPU)
        // has them: it rounds as the baseline build does, the same frames bit for bit.
        .flag_if_supported("-ffp-contract=off")
        // OpenVDB's headers are template-heavy; -O2 keeps volumeToMesh & co. fast in tests.
        .opt_level(2);
    build.includes(&extra);
    build.compile("activeskin_vdb_bridge");

    if let Some(lib_dir) = std::env::var_os("OPENVDB_LIB_DIR") {
        println!(
            "cargo::rustc-link-search=native={}",
            lib_dir.to_string_lossy()
        );
    }
    for lib in ["openvdb", "tbb", "Imath-3_1"] {
        println!("cargo::rustc-link-lib={lib}");
    }
}
