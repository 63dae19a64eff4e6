//! `activeskin info`: the report on good files, and one clear line for every bad one.
#![cfg(feature = "vdb")]

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use activeskin::vdb::{self, FileMetadata, Grid, WriteOptions};

fn activeskin(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .arg("info")
        .args(args)
        .output()
        .expect("run activeskin")
}

fn sphere_file(dir: &Path) -> PathBuf {
    let path = dir.join("sphere.vdb");
    let grid = Grid::level_set_sphere(1.0, [0.0; 3], 0.05, 3.0).unwrap();
    let meta = FileMetadata {
        creator: "test".into(),
        has_frame: false,
        frame: 0,
    };
    vdb::write_grids(&path, &[(&grid, WriteOptions::default())], &meta).unwrap();
    path
}

/// Exit code 1, exactly one line on stderr naming the file, no panic, nothing on stdout
/// unless the file had something to describe.
fn assert_one_line_error(out: &Output, file: &Path, expect: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "stderr: {stderr}");
    let name = file.file_name().unwrap().to_string_lossy();
    assert!(
        stderr.contains(&*name),
        "error does not name {name}: {stderr}"
    );
    assert!(stderr.contains(expect), "expected '{expect}' in: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn describes_a_level_set() {
    let dir = common::scratch();
    let path = sphere_file(dir.path());
    let expected_voxels = Grid::read(&path, None).unwrap().active_voxel_count();
    let out = activeskin(&[&path]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("1 grid\n"), "{text}");
    assert!(text.contains("grid 'surface'"), "{text}");
    assert!(text.contains("value type     float"), "{text}");
    assert!(text.contains("class          level set"), "{text}");
    assert!(
        text.contains("voxel size     0.05 (uniform linear transform)"),
        "{text}"
    );
    assert!(
        text.contains(&format!("active voxels  {expected_voxels}")),
        "{text}"
    );
    assert!(text.contains("background     0.15"), "{text}");
    // Active voxels lie within 3 voxels (|φ| < 0.15) of the unit sphere: centres up to 1.1.
    assert!(
        text.contains("bbox (world)   (-1.1, -1.1, -1.1) to (1.1, 1.1, 1.1)"),
        "{text}"
    );
}

#[test]
fn missing_empty_and_random_files() {
    let dir = common::scratch();
    let missing = dir.path().join("missing.vdb");
    assert_one_line_error(&activeskin(&[&missing]), &missing, "no such file");

    let empty = dir.path().join("empty.vdb");
    std::fs::write(&empty, b"").unwrap();
    assert_one_line_error(&activeskin(&[&empty]), &empty, "empty file");

    // Deterministic noise (a 64-bit LCG), so a failure can be replayed.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let noise: Vec<u8> = (0..4096)
        .map(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 56) as u8
        })
        .collect();
    let random = dir.path().join("random.vdb");
    std::fs::write(&random, &noise).unwrap();
    assert_one_line_error(&activeskin(&[&random]), &random, "not a VDB file");

    let folder = dir.path().join("folder.vdb");
    std::fs::create_dir(&folder).unwrap();
    assert_one_line_error(&activeskin(&[&folder]), &folder, "directory");
}

#[test]
fn truncated_files() {
    let dir = common::scratch();
    let whole = std::fs::read(sphere_file(dir.path())).unwrap();
    // Every tenth of the file, and a dense sweep through the header where counts live.
    let cuts = (0..10)
        .map(|tenth| whole.len() * tenth / 10)
        .chain((1..400).step_by(3))
        .chain([whole.len() - 1]);
    for cut in cuts {
        let path = dir.path().join(format!("cut{cut}.vdb"));
        std::fs::write(&path, &whole[..cut]).unwrap();
        let out = activeskin(&[&path]);
        let expect = if cut == 0 { "empty" } else { "VDB file" };
        assert_one_line_error(&out, &path, expect);
    }
}

#[test]
fn vector_grid_only() {
    let dir = common::scratch();
    let path = dir.path().join("velocity.vdb");
    vdb::write_vector_grid_file(&path).unwrap();
    let out = activeskin(&[&path]);
    assert_one_line_error(&out, &path, "no float or point data grid");
    // The grid is still described, so the user sees what the file holds.
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("grid 'v'") && text.contains("vec3s"),
        "{text}"
    );
}

#[test]
fn several_files_report_each_failure() {
    let dir = common::scratch();
    let good = sphere_file(dir.path());
    let bad = dir.path().join("bad.vdb");
    std::fs::write(&bad, b"junk").unwrap();
    let out = activeskin(&[&good, &bad]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("bad.vdb") && stderr.contains("1 of 2 files"),
        "{stderr}"
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("grid 'surface'"));
}

#[test]
fn bad_usage_exits_2() {
    let out = Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .arg("info")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

/// A level set `phi` and a point data grid `particles` in one file, the points' position
/// codec renamed in the file's bytes to one OpenVDB does not register — as Mantaflow's
/// `int32_trnc` is to OpenVDB 10.
fn mantaflow_like_file(dir: &Path) -> PathBuf {
    let path = dir.join("fluid_data_0001.vdb");
    let mut data = Grid::level_set_sphere(0.5, [1.0; 3], 0.05, 3.0)
        .unwrap()
        .to_data()
        .unwrap();
    data.name = "phi".into();
    let phi = Grid::from_data(&data).unwrap();
    let points: Vec<[f32; 3]> = (0..200)
        .map(|i| {
            let t = i as f32 * 0.37;
            [
                1.0 + 0.3 * t.sin(),
                1.0 + 0.3 * t.cos(),
                1.0 + 0.001 * i as f32,
            ]
        })
        .collect();
    vdb::write_points_beside(&path, &points, 0.05, "particles", &phi).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let codec = b"fxpt16";
    let at = bytes
        .windows(codec.len())
        .position(|w| w == codec)
        .expect("the position codec's name in the file");
    bytes[at..at + codec.len()].copy_from_slice(b"zzpt16");
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn a_grid_openvdb_cannot_decode_is_listed_and_hides_nothing() {
    let dir = common::scratch();
    let path = mantaflow_like_file(dir.path());
    let out = activeskin(&[&path]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains(": 2 grids"), "{stdout}");
    assert!(
        stdout.contains("grid 'phi'") && stdout.contains("grid 'particles'"),
        "{stdout}"
    );
    assert!(
        stdout.contains("NOT DECODABLE") && stdout.contains("zzpt16"),
        "{stdout}"
    );
    // What the writer recorded of the undecodable grid.
    assert!(stdout.contains(" (as written)"), "{stdout}");
    // Reading the level set does not depend on decoding the points.
    let phi = Grid::read(&path, Some("phi")).unwrap().to_data().unwrap();
    assert!(phi.leaf_count() > 0);
    let skin = dir.path().join("skin.####.obj");
    let result = Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .args(["skin", "--target"])
        .arg(&path)
        .args(["--frames", "1-2", "--grid", "phi", "-q", "--mesh"])
        .arg(&skin)
        .output()
        .unwrap();
    common::assert_ok(&result);
}

/// OpenVDB's own warnings (Debian builds it with log4cplus, which writes them to stdout
/// in colour) go to stderr, plain: `info`'s listing and pipes stay clean. Run in a child
/// process (this test binary again) whose output is read.
#[test]
fn openvdb_warnings_go_to_stderr_without_colour() {
    const CHILD: &str = "ACTIVESKIN_TEST_LOG_CHILD";
    if std::env::var_os(CHILD).is_some() {
        if !activeskin::vdb::log_openvdb_warning("a test warning") {
            println!("no log4cplus");
        }
        return;
    }
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "openvdb_warnings_go_to_stderr_without_colour",
            "--nocapture",
        ])
        .env(CHILD, "1")
        .output()
        .unwrap();
    assert!(out.status.success());
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    if stdout.contains("no log4cplus") {
        return;
    }
    assert!(!stdout.contains("a test warning"), "stdout: {stdout}");
    assert!(
        stderr.contains("OpenVDB WARN: a test warning"),
        "stderr: {stderr}"
    );
    assert!(!stderr.contains('\x1b'), "stderr: {stderr:?}");
}
