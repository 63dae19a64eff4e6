//! `activeskin morph` end to end: every frame written, readable by OpenVDB as a valid
//! level set named `surface`, meshes closed; bad arguments give one-line errors.
#![cfg(feature = "vdb")]

mod common;

use std::process::Command;

use activeskin::vdb::{self, Grid};
use activeskin::volume::GridClass;

fn activeskin(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .args(args)
        .output()
        .expect("run activeskin")
}

#[test]
fn morph_writes_valid_level_sets_and_meshes() {
    let dir = common::scratch();
    let out = dir.path().join("skin.####.vdb");
    let mesh = dir.path().join("skin.####.ply");
    let result = activeskin(&[
        "morph",
        "--from",
        "sphere:r=0.6",
        "--to",
        "torus:R=0.5,r=0.25",
        "--frames",
        "1-6",
        // With the defaults (α 4, β 0.001), frame 3 holds a thin sheet where the hole will
        // open, whose midline has |∇φ| < 0.5 on 16 voxels: checkLevelSet flags it.
        "--alpha",
        "2",
        "--beta",
        "0.01",
        "--out",
        out.to_str().unwrap(),
        "--mesh",
        mesh.to_str().unwrap(),
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    for frame in 1..=6 {
        let path = dir.path().join(format!("skin.{frame:04}.vdb"));
        let grids = vdb::list_grids(&path).unwrap();
        // The level set, then the surface's velocity.
        assert_eq!(grids.len(), 2);
        assert_eq!(grids[0].name, "surface");
        assert_eq!(grids[1].name, "v");
        assert_eq!(
            activeskin::vdb::from_bridge_class(grids[0].grid_class),
            GridClass::LevelSet
        );
        let grid = Grid::read(&path, None).unwrap();
        assert_eq!(grid.check_level_set().unwrap(), None, "frame {frame}");
        let ply = std::fs::read(dir.path().join(format!("skin.{frame:04}.ply"))).unwrap();
        assert!(ply.starts_with(b"ply\nformat binary_little_endian 1.0\n"));
    }
    // Nothing but the frames: no temporary file left behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 12);
}

#[test]
fn bad_morph_arguments_are_one_line_errors() {
    let dir = common::scratch();
    let out = dir.path().join("x.####.vdb");
    let out = out.to_str().unwrap();
    // Exit 2 for a bad command line, 1 for a file that cannot be read.
    for (args, expect, code) in [
        (
            vec!["--from", "cube:a=1", "--to", "sphere"],
            "not a .vdb file",
            2,
        ),
        (
            vec!["--from", "sphere:r=x", "--to", "sphere"],
            "not a number",
            2,
        ),
        // Typos and impossible sizes, where the default sphere or nothing was drawn.
        (
            vec!["--from", "sphere:radius=0.2", "--to", "sphere"],
            "sphere takes r, not 'radius'",
            2,
        ),
        (
            vec!["--from", "sphere:r=nan", "--to", "sphere"],
            "r must be a positive number",
            2,
        ),
        (
            vec!["--from", "sphere", "--to", "sphere:r=-1"],
            "r must be a positive number",
            2,
        ),
        (
            vec!["--from", "torus:R=0.2,r=0.3", "--to", "sphere"],
            "r < R",
            2,
        ),
        (
            vec!["--from", "sphere", "--to", "missing.vdb"],
            "no such file",
            1,
        ),
        (
            vec!["--from", "sphere", "--to", "sphere", "--frames", "9-1"],
            "FIRST <= LAST",
            2,
        ),
    ] {
        let mut all = vec!["morph", "--out", out];
        all.extend(args);
        let result = activeskin(&all);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(code), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains(expect), "expected '{expect}': {stderr}");
    }
}

/// Parameters that would need millions of sub-steps a frame stop at once with one line
/// naming the bound, instead of running until killed (issue 31).
#[test]
fn sub_steps_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.####.vdb");
    for (extra, names) in [
        (["--alpha", "1e9"], "α = 1000000000"),
        (["--fps", "1e-9"], "1.000e9 s at"),
    ] {
        let mut args = vec![
            "morph",
            "--from",
            "sphere:r=0.4",
            "--to",
            "sphere:r=0.5",
            "--frames",
            "1-3",
            "--out",
            out.to_str().unwrap(),
            "-q",
        ];
        args.extend(extra);
        let started = std::time::Instant::now();
        let result = activeskin(&args);
        common::assert_fails(&result, 1, names, "too many sub-steps");
        assert!(common::stderr(&result).contains("sub-steps"));
        assert!(started.elapsed().as_secs() < 30);
        // Frame 1 (the start) is written, frame 2 never.
        assert!(dir.path().join("m.0001.vdb").is_file());
        assert!(!dir.path().join("m.0002.vdb").exists());
    }
}
