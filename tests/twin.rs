//! The twin build (src/cli/twin.rs): where `make test` built it beside the binary and the
//! CPU runs it, it takes the process over and writes the same files, bit for bit, as the
//! baseline build (`ACTIVESKIN_BASELINE=1`). Without a twin (plain `cargo test`) there is
//! nothing to compare: the test says so, and fails when `ACTIVESKIN_EXPECT_TWIN=1` (set by
//! `make test` where it builds one).

use std::path::Path;
use std::process::{Command, Output};

mod common;

fn run(baseline: bool, args: &[&str]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_activeskin"));
    command.args(args).env_remove("ACTIVESKIN_BASELINE");
    if baseline {
        command.env("ACTIVESKIN_BASELINE", "1");
    }
    command.output().unwrap()
}

/// Whether the twin takes over: its `--version` says what it was built for.
fn twin_runs() -> bool {
    let version = |baseline| String::from_utf8(run(baseline, &["--version"]).stdout).unwrap();
    assert!(
        !version(true).contains("x86-64-v3"),
        "ACTIVESKIN_BASELINE=1 keeps the baseline build"
    );
    version(false).contains("(x86-64-v3)")
}

/// The files under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<String> {
    common::files_under(dir)
        .iter()
        .map(|p| p.strip_prefix(dir).unwrap().display().to_string())
        .collect()
}

/// A file's bytes with what differs between any two runs taken out: a VDB file's UUID
/// (OpenVDB draws one per file, bytes 21..57 of its header) and the stats' wall times.
fn comparable(path: &Path) -> Vec<u8> {
    let mut bytes = std::fs::read(path).unwrap();
    let name = path.file_name().unwrap().to_str().unwrap();
    if name.ends_with(".vdb") && bytes.len() > 57 {
        bytes[21..57].fill(b'-');
    }
    if name.ends_with(".jsonl") {
        let text = String::from_utf8(bytes).unwrap();
        let lines: Vec<String> = text
            .lines()
            .map(|l| {
                let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
                if let Some(map) = v.as_object_mut() {
                    map.remove("milliseconds");
                }
                v.to_string()
            })
            .collect();
        bytes = lines.join("\n").into_bytes();
    }
    bytes
}

#[test]
fn the_twin_build_writes_the_baseline_builds_files_bit_for_bit() {
    if !twin_runs() {
        let expected = std::env::var_os("ACTIVESKIN_EXPECT_TWIN").is_some_and(|v| v == "1");
        assert!(
            !expected,
            "no twin build took over: `make twin-test` builds it beside {} (or the CPU lacks \
             x86-64-v3)",
            env!("CARGO_BIN_EXE_activeskin")
        );
        eprintln!("no twin build beside the binary (or the CPU lacks AVX2): nothing compared");
        return;
    }
    let dir = common::scratch();
    // The demo: a morph (VDB, OBJ), a moving target (EXR, USD) and a splash of moving
    // particles (smoothed, carried by their velocities).
    for (baseline, name) in [(true, "baseline"), (false, "twin")] {
        let out = dir.path().join(name);
        common::assert_ok(&run(baseline, &["demo", "--out", out.to_str().unwrap()]));
    }
    let (a, b) = (dir.path().join("baseline"), dir.path().join("twin"));
    let names = files(&a);
    assert_eq!(names, files(&b));
    assert!(names.len() > 100, "{names:?}");
    let differ: Vec<&String> = names
        .iter()
        .filter(|n| comparable(&a.join(n)) != comparable(&b.join(n)))
        .collect();
    assert!(differ.is_empty(), "differ: {differ:?}");
}
