//! `activeskin skin` end to end on the sample sequences of data/ and on generated ones:
//! every frame written and valid, the skin on target, splits seen, stats as JSON lines,
//! `--resume` equal to an uninterrupted run, and bad input reported in one line with
//! nothing lost.
#![cfg(feature = "vdb")]

mod common;

use std::path::Path;
use std::process::Command;

use common::{activeskin, assert_ok, data, skin_args, write_grid};

use activeskin::target::{sample, Sphere, Target};
use activeskin::vdb::{self, Grid};
use activeskin::volume::{GridClass, GridData};
use glam::Vec3;

const DATA_DX: f64 = 1.0 / 16.0;

fn read_skin(path: &Path) -> GridData {
    Grid::read(path, Some("surface"))
        .unwrap()
        .to_data()
        .unwrap()
}

#[test]
fn moving_sphere_every_frame_valid_and_on_target() {
    let dir = common::scratch();
    let out = dir.path().join("skin.$F4.vdb");
    let mesh = dir.path().join("skin.%04d.obj");
    let stats = dir.path().join("stats.jsonl");
    let result = activeskin(&[
        "skin",
        "--target",
        &data("moving/sphere.####.vdb"),
        "--alpha",
        "24",
        "--beta",
        "0.0002",
        "--out",
        out.to_str().unwrap(),
        "--mesh",
        mesh.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert_ok(&result);
    let lines: Vec<serde_json::Value> = std::fs::read_to_string(&stats)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON object per line"))
        .collect();
    assert_eq!(lines.len(), 8);
    for (i, frame) in (1..=8).enumerate() {
        let line = &lines[i];
        assert_eq!(line["frame"], frame);
        for key in [
            "time",
            "substeps",
            "band_nodes",
            "blocks",
            "area",
            "volume",
            "euler_characteristic",
            "components",
            "milliseconds",
        ] {
            assert!(line[key].is_number(), "stats line lacks {key}: {line}");
        }
        assert_eq!(line["manifold"], true, "{line}");
        assert_eq!(line["clean"], true, "{line}");
        let path = dir.path().join(format!("skin.{frame:04}.vdb"));
        let grids = vdb::list_grids(&path).unwrap();
        // The level set, then the surface's velocity.
        assert_eq!(grids.len(), 2);
        assert_eq!(grids[1].name, "v");
        let skin = read_skin(&path);
        assert_eq!(skin.name, "surface");
        assert_eq!(skin.class, GridClass::LevelSet);
        assert!((skin.transform.voxel_size() - DATA_DX).abs() < 1e-9);
        assert!((f64::from(skin.background) - 3.0 * DATA_DX).abs() < 1e-6);
        assert_eq!(
            Grid::from_data(&skin).unwrap().check_level_set().unwrap(),
            None
        );
        // The target of this frame, as examples/make_data.rs made it.
        let t = (frame - 1) as f32 / 7.0;
        let target = Sphere {
            center: Vec3::splat(1.5) + Vec3::new(-0.1 + 0.2 * t, 0.0, 0.0),
            radius: 0.3,
        };
        let mesh = common::read_mesh(&dir.path().join(format!("skin.{frame:04}.obj"))).unwrap();
        let check = mesh.check();
        assert!(check.is_clean(), "frame {frame}: {check}");
        let max = mesh
            .positions
            .iter()
            .map(|&p| f64::from(target.distance(p).abs()) / DATA_DX)
            .fold(0.0, f64::max);
        assert!(max <= 1.0, "frame {frame}: {max:.2} voxels off the target");
    }
    assert!(common::names(dir.path()).iter().all(|f| !f.contains("tmp")));
}

#[test]
fn splitting_target_gives_two_components() {
    let dir = common::scratch();
    let stats = dir.path().join("stats.jsonl");
    let result = activeskin(&[
        "skin",
        "--target",
        &data("splitting/pair.####.vdb"),
        "--alpha",
        "24",
        "--stats",
        stats.to_str().unwrap(),
        "--quiet",
    ]);
    assert_ok(&result);
    let text = std::fs::read_to_string(&stats).unwrap();
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines[0]["components"], 1);
    let last = lines.last().unwrap();
    assert_eq!(last["frame"], 8);
    assert_eq!(last["components"], 2, "{text}");
    assert_eq!(last["euler_characteristic"], 4);
}

#[test]
fn resume_equals_an_uninterrupted_run() {
    let target = data("splitting/pair.####.vdb");
    let whole = common::scratch();
    let whole_out = whole.path().join("skin.####.vdb");
    assert_ok(&activeskin(&skin_args(
        &target,
        whole_out.to_str().unwrap(),
        &[],
    )));

    // A run stopped after frame 3 (a killed run leaves whole frames only: each is renamed
    // into place), then resumed.
    let part = common::scratch();
    let part_out = part.path().join("skin.####.vdb");
    let stats = part.path().join("stats.jsonl");
    let stats = stats.to_str().unwrap();
    let out = part_out.to_str().unwrap();
    assert_ok(&activeskin(&skin_args(
        &target,
        out,
        &["--frames", "1-3", "--stats", stats],
    )));
    let frame3 = std::fs::read(part.path().join("skin.0003.vdb")).unwrap();
    assert_ok(&activeskin(&skin_args(
        &target,
        out,
        &["--resume", "--stats", stats],
    )));
    assert_eq!(
        std::fs::read(part.path().join("skin.0003.vdb")).unwrap(),
        frame3,
        "resume rewrote a finished frame"
    );
    for frame in 4..=8 {
        let name = format!("skin.{frame:04}.vdb");
        let (a, b) = (
            read_skin(&whole.path().join(&name)),
            read_skin(&part.path().join(&name)),
        );
        assert_eq!(a.leaf_origins, b.leaf_origins, "frame {frame}");
        assert_eq!(a.leaf_masks, b.leaf_masks, "frame {frame}");
        assert!(
            a.leaf_values
                .iter()
                .zip(&b.leaf_values)
                .all(|(x, y)| x.to_bits() == y.to_bits()),
            "frame {frame}: values differ"
        );
        assert_eq!(a.tiles.len(), b.tiles.len(), "frame {frame}");
    }
    let frames: Vec<i64> = std::fs::read_to_string(stats)
        .unwrap()
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["frame"]
                .as_i64()
                .unwrap()
        })
        .collect();
    assert_eq!(frames, (1..=8).collect::<Vec<_>>());
}

/// A copy of the moving sphere's frames in a fresh folder, to damage.
#[test]
fn killed_then_resumed_equals_uninterrupted() {
    let run = |out: &Path, resume: bool| {
        let out = out.join("m.####.vdb");
        let mut args = vec![
            "morph",
            "--from",
            "blobs:fig7",
            "--to",
            "spheres:fig7",
            "--frames",
            "1-30",
            "--alpha",
            "4",
            "--out",
            out.to_str().unwrap(),
            "-q",
        ];
        if resume {
            args.push("--resume");
        }
        args.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    let whole = common::scratch();
    assert_ok(&activeskin(
        &run(whole.path(), false)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    ));

    let part = common::scratch();
    let mut child = Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .args(run(part.path(), false))
        .spawn()
        .unwrap();
    // Kill it (SIGKILL) once a few frames are out, mid-sequence.
    let started = std::time::Instant::now();
    while !part.path().join("m.0008.vdb").exists() {
        assert!(
            started.elapsed().as_secs() < 120,
            "no frame 8 after 2 minutes"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let written = common::names(part.path())
        .iter()
        .filter(|f| f.ends_with(".vdb") && !f.starts_with('.'))
        .count();
    assert!(written < 30, "the run finished before it was killed");
    for frame in 1..=written {
        let path = part.path().join(format!("m.{frame:04}.vdb"));
        assert_eq!(
            vdb::list_grids(&path).unwrap().len(),
            2,
            "frame {frame} damaged"
        );
    }
    // What a kill inside a write leaves (whether this kill did or not).
    std::fs::write(part.path().join(".m.0015.vdb.4242.tmp"), b"half a frame").unwrap();
    assert_ok(&activeskin(
        &run(part.path(), true)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    ));
    let names = common::names(part.path());
    assert_eq!(names.len(), 30, "temporary files left: {names:?}");
    let (a, b) = (
        read_skin(&whole.path().join("m.0030.vdb")),
        read_skin(&part.path().join("m.0030.vdb")),
    );
    assert_eq!(a.leaf_origins, b.leaf_origins);
    assert!(a
        .leaf_values
        .iter()
        .zip(&b.leaf_values)
        .all(|(x, y)| x.to_bits() == y.to_bits()));
}

#[test]
fn init_starts_the_skin_on_another_shape() {
    let dir = common::scratch();
    let init = dir.path().join("init.vdb");
    let small = Sphere {
        center: Vec3::splat(1.5),
        radius: 0.15,
    };
    write_grid(
        &init,
        &sample::level_set(&small as &dyn Target, DATA_DX as f32, 3.0),
    );
    let stats = dir.path().join("stats.jsonl");
    let result = activeskin(&[
        "skin",
        "--target",
        &data("moving/sphere.####.vdb"),
        "--init",
        init.to_str().unwrap(),
        "--alpha",
        "24",
        // The growth is what is measured here, not tension (8·Δx²/s by default, which at
        // this coarse Δx = 1/16 slows it).
        "--beta",
        "0.001",
        "--stats",
        stats.to_str().unwrap(),
        "-q",
    ]);
    assert_ok(&result);
    let areas: Vec<f64> = std::fs::read_to_string(&stats)
        .unwrap()
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["area"]
                .as_f64()
                .unwrap()
        })
        .collect();
    let area = |r: f64| 4.0 * std::f64::consts::PI * r * r;
    // Frame 1 is the init sphere; the skin then grows toward the target's radius 0.3.
    assert!(
        (areas[0] - area(0.15)).abs() / area(0.15) < 0.1,
        "{areas:?}"
    );
    assert!(areas.windows(2).all(|w| w[1] > w[0]), "{areas:?}");
    assert!(areas[7] > 0.9 * area(0.3), "{areas:?}");
}
