//! The bad-input corpus of issue 7, generated here (no opaque blobs): each damaged input
//! gives one line naming the file and the problem, exit code 1 for bad data (2 for bad
//! usage), no panic text, no partial output, and the frames written before it intact.
//! (More cases — missing, empty, NaN, empty grid, non-uniform, fog without --iso, bad
//! options — are in `cli_skin.rs`, `cli_info.rs`, `cli_particles.rs` and `vdb_points.rs`.)
#![cfg(feature = "vdb")]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{activeskin, assert_fails, names, Lcg};

use activeskin::target::{sample, Sphere, Target};
use activeskin::vdb::{self, FileMetadata, Grid, WriteOptions};
use activeskin::volume::GridData;
use glam::Vec3;

fn sphere(dx: f32) -> GridData {
    let sphere = Sphere {
        center: Vec3::splat(1.5),
        radius: 0.3,
    };
    sample::level_set(&sphere as &dyn Target, dx, 3.0)
}

/// `skin` on the level set `target` for frames 1–2, meshes into `mesh`, plus `extra`.
fn skin_two_frames<'a>(target: &'a Path, mesh: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "skin",
        "--target",
        target.to_str().unwrap(),
        "--frames",
        "1-2",
        "--mesh",
        mesh.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    args
}

fn write(path: &Path, data: &GridData) {
    let meta = FileMetadata {
        creator: "test".into(),
        has_frame: false,
        frame: 0,
    };
    let grid = Grid::from_data(data).unwrap();
    vdb::write_grids(path, &[(&grid, WriteOptions::default())], &meta).unwrap();
}

/// Runs `skin` over frames 1–3 where frame 2 is `damage`d; frame 1 must be the only
/// output, whole.
fn skin_stops_at_frame_2(what: &str, damage: impl Fn(&Path)) {
    let dir = common::scratch();
    for frame in 1..=3 {
        write(
            &dir.path().join(format!("t.{frame:04}.vdb")),
            &sphere(1.0 / 16.0),
        );
    }
    damage(&dir.path().join("t.0002.vdb"));
    let out = dir.path().join("out");
    let result = activeskin(&[
        "skin",
        "--target",
        dir.path().join("t.####.vdb").to_str().unwrap(),
        "--frames",
        "1-3",
        "--out",
        out.join("s.####.vdb").to_str().unwrap(),
        "--mesh",
        out.join("s.####.obj").to_str().unwrap(),
        "-q",
    ]);
    assert_fails(&result, 1, "t.0002.vdb", what);
    assert_eq!(names(&out), ["s.0001.obj", "s.0001.vdb"], "{what}");
    let grids: Vec<String> = vdb::list_grids(&out.join("s.0001.vdb"))
        .unwrap()
        .into_iter()
        .map(|g| g.name)
        .collect();
    assert_eq!(grids, ["surface", "v"], "{what}");
}

#[test]
fn damaged_vdb_frames() {
    skin_stops_at_frame_2("random bytes", |f| {
        std::fs::write(f, Lcg(99).bytes(4096)).unwrap();
    });
    let whole = {
        let dir = common::scratch();
        let path = dir.path().join("whole.vdb");
        write(&path, &sphere(1.0 / 16.0));
        std::fs::read(path).unwrap()
    };
    for tenth in 0..10 {
        skin_stops_at_frame_2(&format!("cut at {tenth}0 %"), |f| {
            std::fs::write(f, &whole[..whole.len() * tenth / 10]).unwrap();
        });
    }
    skin_stops_at_frame_2("only a vector grid", |f| {
        vdb::write_vector_grid_file(f).unwrap();
    });
    skin_stops_at_frame_2("an infinite value", |f| {
        let mut data = sphere(1.0 / 16.0);
        data.leaf_values[7] = f32::INFINITY;
        write(f, &data);
    });
    skin_stops_at_frame_2("a sheared (affine) transform", |f| {
        let mut data = sphere(1.0 / 16.0);
        data.transform.matrix[1] = 0.02; // x index axis leans into y
        write(f, &data);
    });
}

fn ply_frames(dir: &Path, second: &[u8]) -> PathBuf {
    let good = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1.5 1.5 1.5\n1.55 1.5 1.5\n";
    std::fs::write(dir.join("p.0001.ply"), good).unwrap();
    std::fs::write(dir.join("p.0002.ply"), second).unwrap();
    dir.join("p.####.ply")
}

#[test]
fn damaged_ply_frames() {
    let cases: [(&str, &[u8]); 5] = [
        ("broken header", b"ply\nformat ascii 1.0\nelement vertex many\nend_header\n"),
        ("no end of header", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"),
        ("not a PLY", b"solid cube\nfacet normal 0 0 1\n"),
        ("too few vertices", b"ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n"),
        ("wrong property type", b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float128 x\nproperty float y\nproperty float z\nend_header\n"),
    ];
    for (what, bytes) in cases {
        let dir = common::scratch();
        let pattern = ply_frames(dir.path(), bytes);
        let out = dir.path().join("out");
        let result = activeskin(&[
            "particles",
            "--particles",
            pattern.to_str().unwrap(),
            "--radius",
            "0.05",
            "--out",
            out.join("s.####.vdb").to_str().unwrap(),
            "-q",
        ]);
        assert_fails(&result, 1, "p.0002.ply", what);
        assert_eq!(names(&out), ["s.0001.vdb"], "{what}");
    }
}

#[test]
fn bad_usage_exits_2() {
    let dir = common::scratch();
    write(&dir.path().join("t.0001.vdb"), &sphere(1.0 / 16.0));
    let target = dir.path().join("t.####.vdb");
    let target = target.to_str().unwrap();
    let out = dir.path().join("o.####.vdb");
    let out = out.to_str().unwrap();
    let nothing = dir.path().join("none.####.vdb");
    let cases: [(&str, Vec<&str>, &str); 11] = [
        (
            "a warm-up that is not a number",
            vec!["skin", "--target", target, "--warmup", "soon", "--out", out],
            "--warmup",
        ),
        (
            "a negative warm-up",
            vec!["skin", "--target", target, "--warmup=-3", "--out", out],
            "--warmup",
        ),
        (
            "a morph's warm-up",
            vec![
                "morph",
                "--from",
                "sphere:r=0.5",
                "--to",
                "sphere:r=0.4",
                "--frames",
                "1-3",
                "--warmup",
                "2",
                "--out",
                out,
            ],
            "--warmup",
        ),
        (
            "negative α",
            vec!["skin", "--target", target, "--alpha=-2", "--out", out],
            "--alpha",
        ),
        (
            "empty range",
            vec!["skin", "--target", target, "--frames", "3-1", "--out", out],
            "--frames",
        ),
        (
            "no frame number",
            vec!["skin", "--target", "t.vdb", "--out", out],
            "no frame number",
        ),
        (
            "matches nothing",
            vec!["skin", "--target", nothing.to_str().unwrap(), "--out", out],
            "none.####.vdb",
        ),
        (
            "nothing to write",
            vec!["skin", "--target", target],
            "nothing to write",
        ),
        (
            "negative radius",
            vec![
                "particles",
                "--particles",
                target,
                "--radius=-1",
                "--out",
                out,
            ],
            "--radius",
        ),
        (
            "voxels coarser than the particles' kernel",
            vec![
                "particles",
                "--particles",
                target,
                "--radius=0.02",
                "--voxel-size=1e4",
                "--out",
                out,
            ],
            "coarser than the particles' kernel",
        ),
        (
            "clap: unknown option",
            vec!["skin", "--targte", target],
            "unexpected argument '--targte' found (a similar argument exists: '--target'); see --help",
        ),
    ];
    for (what, args, names) in cases {
        let result = activeskin(&args);
        let err = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{what}: {err}");
        assert!(err.contains(names), "{what}: {err}");
        assert!(!err.contains("panicked"), "{what}: {err}");
        // clap's mistakes too: one line, with its tip (were 4-5 lines with a usage block).
        assert_eq!(err.lines().count(), 1, "{what}: {err}");
    }
}

#[test]
fn negative_numbers_are_bad_values_in_one_line() {
    // `--alpha -1`, as users type it: the same one-line usage error as `--alpha=-1`.
    let dir = common::scratch();
    write(&dir.path().join("t.0001.vdb"), &sphere(1.0 / 16.0));
    let target = dir.path().join("t.####.vdb");
    let target = target.to_str().unwrap();
    let out = dir.path().join("o.####.vdb");
    let out = out.to_str().unwrap();
    let skin = |option: &'static str, value: &'static str| {
        (
            option,
            vec!["skin", "--target", target, "--out", out, option, value],
        )
    };
    let cases = [
        skin("--alpha", "-1"),
        skin("--beta", "-0.5"),
        skin("--voxel-size", "-0.1"),
        skin("--fps", "-24"),
        (
            "--radius",
            vec![
                "particles",
                "--particles",
                target,
                "--out",
                out,
                "--radius",
                "-1",
            ],
        ),
        (
            "--smoothing-length",
            vec![
                "particles",
                "--particles",
                target,
                "--out",
                out,
                "--radius",
                "0.1",
                "--smoothing-length",
                "-2",
            ],
        ),
    ];
    for (option, args) in cases {
        common::assert_usage_error(&activeskin(&args), option);
    }
    assert!(common::names(&dir.path().join("o")).is_empty());
}

/// A full disk: a 480 KB tmpfs, a few frames' worth (when this machine lets the test
/// mount one; it says so otherwise — the injected failing writer of `io.rs`'s unit tests
/// covers the rest). OpenVDB itself reports success on a short write: found here.
#[test]
fn full_disk_stops_with_one_line_and_keeps_written_frames() {
    let dir = common::scratch();
    let small = dir.path().join("small");
    std::fs::create_dir(&small).unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=480k", "tmpfs"])
        .arg(&small)
        .output()
        .is_ok_and(|o| o.status.success());
    if !mounted {
        println!("no tmpfs could be mounted here: full-disk CLI test skipped");
        return;
    }
    struct Unmount<'a>(&'a Path);
    impl Drop for Unmount<'_> {
        fn drop(&mut self) {
            let _ = Command::new("umount").arg(self.0).status();
        }
    }
    let _unmount = Unmount(&small);
    let result = activeskin(&[
        "morph",
        "--from",
        "sphere:r=0.4",
        "--to",
        "torus:R=0.6,r=0.25",
        "--voxel-size",
        "0.04",
        "--frames",
        "1-40",
        "--out",
        small.join("m.####.vdb").to_str().unwrap(),
        "-q",
    ]);
    let err = String::from_utf8_lossy(&result.stderr);
    assert_fails(&result, 1, "m.00", "full disk");
    assert!(err.contains("space"), "{err}");
    let left = names(&small);
    assert!(!left.is_empty() && left.len() < 40, "{left:?}");
    assert!(
        left.iter().all(|n| !n.starts_with('.')),
        "temporary left: {left:?}"
    );
    for name in left {
        // The level set and the surface's velocity, both whole.
        assert_eq!(
            vdb::list_grids(&small.join(&name)).unwrap().len(),
            2,
            "{name}"
        );
    }
}

/// Runs activeskin, killed after a minute: a named pipe opened for reading waits for a
/// writer, forever.
fn within_a_minute(args: &[&str]) -> std::process::Output {
    Command::new("timeout")
        .arg("60")
        .arg(env!("CARGO_BIN_EXE_activeskin"))
        .args(args)
        .output()
        .unwrap()
}

fn mkfifo(path: &Path) {
    let made = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(made.success());
}

#[test]
fn frames_that_are_not_files_are_errors_not_missing_frames() {
    // A directory, a named pipe and a symlink loop where frame 2 should be: one line
    // saying what it is, never a missing frame that --hold-missing would hold over.
    type Make = fn(&Path);
    let cases: [(&str, &str, Make); 3] = [
        ("a directory", "is a directory", |p| {
            std::fs::create_dir(p).unwrap()
        }),
        ("a FIFO", "named pipe", mkfifo),
        ("a symlink loop", "symbolic links", |p| {
            std::os::unix::fs::symlink(p, p).unwrap()
        }),
    ];
    for (what, says, make) in cases {
        skin_stops_at_frame_2(what, |p| {
            std::fs::remove_file(p).unwrap();
            make(p);
        });
        let dir = common::scratch();
        for frame in [1, 3] {
            write(
                &dir.path().join(format!("t.{frame:04}.vdb")),
                &sphere(1.0 / 16.0),
            );
        }
        make(&dir.path().join("t.0002.vdb"));
        let out = dir.path().join("s.####.obj");
        let held = within_a_minute(&[
            "skin",
            "--target",
            dir.path().join("t.####.vdb").to_str().unwrap(),
            "--frames",
            "1-3",
            "--hold-missing",
            "--mesh",
            out.to_str().unwrap(),
            "-q",
        ]);
        assert_fails(&held, 1, "t.0002.vdb", what);
        assert!(common::stderr(&held).contains(says), "{what}");
    }

    // Read directly, a named pipe is refused at once by every reader.
    let dir = common::scratch();
    for name in ["p.vdb", "p.ply", "p.bgeo", "p.vtk"] {
        let fifo = dir.path().join(name);
        mkfifo(&fifo);
        let fifo = fifo.to_str().unwrap();
        let mesh = dir.path().join("m.obj");
        let runs: Vec<Vec<&str>> = if name.ends_with(".vdb") {
            vec![
                vec!["info", fifo],
                vec!["mesh", fifo, mesh.to_str().unwrap()],
                vec!["validate", fifo],
            ]
        } else {
            vec![vec![
                "particles",
                "--particles",
                fifo,
                "--radius",
                "0.05",
                "--frames",
                "1-2",
                "--mesh",
                mesh.to_str().unwrap(),
                "-q",
            ]]
        };
        for args in runs {
            let out = within_a_minute(&args);
            assert_fails(&out, 1, name, &format!("{args:?}"));
            assert!(common::stderr(&out).contains("named pipe"), "{args:?}");
        }
        // The scratch folder checks its meshes (.ply too) when dropped.
        std::fs::remove_file(fifo).unwrap();
    }
}

#[test]
fn an_inside_reaching_past_the_leaves_is_closed_where_they_end() {
    let dir = common::scratch();
    // A sphere of radius 1 (40 voxels) sampled in a box that cuts it at x = 16 voxels,
    // then flood-filled as OpenVDB does an open band: 27 000 inside tiles of 128³ beyond.
    let full = Grid::level_set_sphere(1.0, [0.0; 3], 0.025, 3.0)
        .unwrap()
        .to_data()
        .unwrap();
    let mut data = GridData::empty("surface", full.class, full.background, full.transform);
    for (i, origin) in full.leaf_origins.iter().enumerate() {
        if origin[0] < 16 {
            data.leaf_origins.push(*origin);
            data.leaf_masks.push(full.leaf_masks[i]);
            data.leaf_values
                .extend_from_slice(&full.leaf_values[i * 512..(i + 1) * 512]);
        }
    }
    data.tiles
        .extend(full.tiles.iter().filter(|t| t.origin[0] < 16).copied());
    for i in 1..=30 {
        for j in -15..15 {
            for k in -15..15 {
                data.tiles.push(activeskin::volume::Tile {
                    origin: [i * 128, j * 128, k * 128],
                    dim: 128,
                    value: -full.background,
                    active: false,
                });
            }
        }
    }
    // And a whole root tile of 4096³ inside beyond them.
    data.tiles.push(activeskin::volume::Tile {
        origin: [8192, 0, 0],
        dim: 4096,
        value: -full.background,
        active: false,
    });
    let file = dir.path().join("clipped.vdb");
    write(&file, &data);
    let mesh = dir.path().join("clipped.obj");
    let out = common::activeskin_bounded(&[
        "mesh",
        file.to_str().unwrap(),
        mesh.to_str().unwrap(),
        "--check",
    ]);
    common::assert_ok(&out);
    let said = common::stderr(&out);
    assert!(said.contains("closed where the voxels end"), "{said}");
    // The sphere below the cut (x < 0.39), closed by a disc there.
    let cut = 0.39f64;
    let expected = std::f64::consts::PI * (cut - cut.powi(3) / 3.0 + 2.0 / 3.0);
    let volume = common::read_mesh(&mesh).unwrap().volume();
    assert!(
        (volume / expected - 1.0).abs() < 0.03,
        "{volume} against {expected}"
    );
    // The skin reads it alike.
    let skin = dir.path().join("skin.####.obj");
    let out = common::activeskin_bounded(&skin_two_frames(&file, &skin, &["-q"]));
    common::assert_ok(&out);
    assert_eq!(common::assert_clean_meshes(dir.path()), 3);
}

#[test]
fn a_level_set_too_far_for_its_voxels_is_one_line() {
    let dir = common::scratch();
    // A millimetre sphere a kilometre out, voxels of 30 µm: 3.3·10⁷ voxels from the
    // origin, where a 32-bit position is 2 voxels coarse (it meshed into degenerate
    // triangles).
    let far = Grid::level_set_sphere(0.001, [1000.0, 0.0, 0.0], 3e-5, 3.0).unwrap();
    let file = dir.path().join("far.vdb");
    write(&file, &far.to_data().unwrap());
    let mesh = dir.path().join("far.obj");
    let out = activeskin(&["mesh", file.to_str().unwrap(), mesh.to_str().unwrap()]);
    assert_fails(&out, 1, "far.vdb", "mesh");
    assert!(common::stderr(&out).contains("32-bit positions do not resolve"));
    let skin = dir.path().join("s.####.obj");
    let out = activeskin(&skin_two_frames(&file, &skin, &["-q"]));
    assert_fails(&out, 1, "far.vdb", "skin");
    assert!(common::stderr(&out).contains("32-bit positions do not resolve"));
    assert_eq!(names(dir.path()), vec!["far.vdb"]);
}

/// A level set in absurd units (distances ×1e30) is measured and rescaled like one in
/// voxels: the skin is the sphere, not empty (|∇φ|² overflowed f32, the distances were
/// rescaled by 0 and every frame came out empty, exit 0), and the note says by how much.
#[test]
fn a_level_set_in_absurd_units_is_rescaled_not_emptied() {
    let dir = common::scratch();
    let mut data = Grid::level_set_sphere(0.5, [0.0; 3], 0.025, 3.0)
        .unwrap()
        .to_data()
        .unwrap();
    activeskin::volume::units::rescale(&mut data, 1e30);
    let file = dir.path().join("absurd.vdb");
    write(&file, &data);
    let mesh = dir.path().join("skin.####.obj");
    let out = common::activeskin_bounded(&skin_two_frames(&file, &mesh, &[]));
    common::assert_ok(&out);
    let note = common::stderr(&out);
    assert!(
        note.contains("rescaled by 1.0") && note.contains("e-30"),
        "{note}"
    );
    let skin = common::read_mesh(&dir.path().join("skin.0002.obj")).unwrap();
    let sphere = 4.0 / 3.0 * std::f64::consts::PI * 0.125;
    let volume = skin.area_and_volume().1;
    assert!(
        (volume / sphere - 1.0).abs() < 0.03,
        "{volume} against {sphere}"
    );
}

/// An output whose extension no writer knows is a usage error (exit 2) in every command,
/// said before anything is read: `mesh` and `render` exited 1 after the work, `skin` 2.
#[test]
fn an_unknown_output_extension_is_a_usage_error_everywhere() {
    let dir = common::scratch();
    let input = dir.path().join("sphere.vdb");
    write(
        &input,
        &Grid::level_set_sphere(0.5, [0.0; 3], 0.05, 3.0)
            .unwrap()
            .to_data()
            .unwrap(),
    );
    let input = input.to_str().unwrap();
    for (args, name) in [
        (vec!["mesh", input, "out.stl"], "out.stl"),
        (vec!["render", input, "out.tiff"], "out.tiff"),
        (vec!["mesh", "missing.vdb", "out.stl"], "out.stl"),
        (
            vec![
                "skin",
                "--target",
                input,
                "--frames",
                "1-1",
                "--mesh",
                "o.####.stl",
            ],
            "o.####.stl",
        ),
    ] {
        let out = activeskin(&args);
        assert_fails(&out, 2, name, &args.join(" "));
    }
    assert!(!Path::new("out.stl").exists() && !Path::new("out.tiff").exists());
}
