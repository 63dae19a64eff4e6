//! `activeskin demo` (what `make demo` runs) writes both sequences, whole and valid.

use std::process::Command;

#[test]
fn demo_writes_both_sequences() {
    let dir = tempfile::tempdir().unwrap();
    let result = Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .args(["demo", "-q", "--out", dir.path().to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    for (name, components, euler) in [("fig7", 2, 4), ("orbit", 1, 2)] {
        let folder = dir.path().join(name);
        let names: Vec<String> = std::fs::read_dir(&folder)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), 3 * 48 + 1, "{name}: {names:?}");
        let grid =
            activeskin::vdb::Grid::read(&folder.join(format!("{name}.0048.vdb")), None).unwrap();
        assert_eq!(grid.check_level_set().unwrap(), Ok(()), "{name}");
        let stats = std::fs::read_to_string(folder.join("stats.jsonl")).unwrap();
        let last: serde_json::Value = serde_json::from_str(stats.lines().last().unwrap()).unwrap();
        assert_eq!(last["components"], components, "{name}");
        assert_eq!(last["euler_characteristic"], euler, "{name}");
    }
}
