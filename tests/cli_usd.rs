//! USD shots (`--usd`, issue 29), read by Pixar's own library: usd-core installed from
//! pip into a venv of the test's own (made here, once per build folder). A ball of
//! particles moving 4 voxels a frame whose particles carry `temperature` = their x: every
//! frame's mesh read through `UsdGeom.Mesh` is its OBJ (counts, triangles, positions
//! within 1e-6), the metadata is the run's, every registered validator passes, and the
//! temperature primvar follows the vertices' x. A resumed run and a 3-chunk farm run
//! write the same shot, byte for byte, as the uninterrupted one.
#![cfg(feature = "vdb")]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

use activeskin::particles::{Attribute, Particles};
use common::{activeskin, assert_ok, assert_usage_error, scratch};
use glam::Vec3;

const R: f32 = 0.02;
const FRAMES: i64 = 9;

/// A ball of particles 2r apart, 5 spacings in radius, centred at `at`.
fn ball(at: Vec3) -> Vec<Vec3> {
    common::lattice_ball(at, 2.0 * R, 5)
}

/// The ball over `FRAMES` frames, 4 voxels (r/2) a frame along x, ids in order and each
/// particle's `temperature` its x.
fn write_frames(dir: &Path) -> String {
    for frame in 1..=FRAMES {
        let positions = ball(Vec3::new(0.04 * frame as f32, 0.0, 0.0));
        let n = positions.len();
        let particles = Particles {
            ids: Some((0..n as i64).collect()),
            attributes: vec![Attribute {
                name: "temperature".into(),
                components: 1,
                values: positions.iter().map(|p| p.x).collect(),
            }],
            positions,
            ..Particles::default()
        };
        let path = dir.join(format!("p.{frame:04}.ply"));
        activeskin::io::ply::write_particles(&path, &particles).unwrap();
    }
    dir.join("p.####.ply").to_string_lossy().into_owned()
}

/// The run every test makes, writing into `out/` of the folder it runs in.
fn shot_words(particles: &str) -> Vec<String> {
    [
        "particles",
        "--particles",
        particles,
        "--radius",
        &R.to_string(),
        "--frames",
        &format!("1-{FRAMES}"),
        "--attribute",
        "temperature",
        "--mesh",
        "out/m.####.obj",
        "--usd",
        "out/shot.usda",
        "--out",
        "out/s.####.vdb",
        "--up",
        "z",
        "--fps",
        "30",
        "-q",
    ]
    .map(String::from)
    .to_vec()
}

fn run_in(dir: &Path, words: &[String], env: &[(&str, &str)]) -> std::process::Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_activeskin"));
    command.current_dir(dir).args(words);
    for (k, v) in env {
        command.env(k, v);
    }
    command.output().expect("run activeskin")
}

/// Every file of the shot (the stage, the manifest, the frames' layers), by name.
fn shot_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = vec![(
        "shot.usda".to_string(),
        std::fs::read(dir.join("out/shot.usda")).unwrap(),
    )];
    for name in common::names(&dir.join("out/shot")) {
        files.push((
            name.clone(),
            std::fs::read(dir.join("out/shot").join(name)).unwrap(),
        ));
    }
    files
}

fn assert_same_shot(a: &Path, b: &Path, what: &str) {
    let (a, b) = (shot_files(a), shot_files(b));
    let names = |f: &[(String, Vec<u8>)]| f.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&a), names(&b), "{what}: other files");
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{what}: {name} differs");
    }
    // The stage, the manifest and one layer a frame.
    assert_eq!(a.len(), 2 + FRAMES as usize);
}

/// A Python with Pixar's usd-core: a venv in the build's scratch folder, made and
/// filled from pip the first time (tests of this file share it).
fn usd_python() -> PathBuf {
    static MADE: Mutex<()> = Mutex::new(());
    let _made = MADE.lock().unwrap_or_else(|e| e.into_inner());
    common::venv(
        "usd-venv",
        &["usd-core"],
        "from pxr import Usd, UsdGeom, UsdValidation",
    )
}

/// `tests/usd/check_shot.py` on the shot in `dir`: what it measured.
fn check_with_pixar(dir: &Path) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/usd/check_shot.py");
    let expected = serde_json::json!({
        "upAxis": "Z", "metersPerUnit": 1.0, "timeCodesPerSecond": 30.0,
        "framesPerSecond": 30.0, "start": 1.0, "end": FRAMES as f64,
        "velocities": true, "primvars": {"temperature": "x"},
    });
    let out = Command::new(usd_python())
        .arg(&script)
        .arg(dir.join("out/shot.usda"))
        .arg(dir.join("out/m.{frame:04d}.obj"))
        .arg(expected.to_string())
        .output()
        .expect("run check_shot.py");
    assert_ok(&out);
    let printed = String::from_utf8(out.stdout).unwrap();
    println!("Pixar's reading: {printed}");
    serde_json::from_str(printed.trim()).unwrap()
}

#[test]
fn pixars_library_reads_every_frame_as_its_obj_and_validates_the_shot() {
    let data = scratch();
    let particles = write_frames(data.path());
    let dir = scratch();
    assert_ok(&run_in(dir.path(), &shot_words(&particles), &[]));
    let measured = check_with_pixar(dir.path());
    assert_eq!(measured["frames"], FRAMES);
    assert!(measured["worst_position"].as_f64().unwrap() <= 1e-6);
    assert!(measured["validators"].as_u64().unwrap() > 10, "{measured}");
    assert_eq!(measured["issues"], serde_json::json!([]), "{measured}");
    // temperature = x: the primvar within 2 % of the surface's width of each vertex's x.
    let error = measured["attribute_error"].as_f64().unwrap();
    assert!(error > 0.0 && error < 0.02, "{error}");
}

#[test]
fn a_resumed_run_and_a_farmed_one_write_the_uninterrupted_shot() {
    let data = scratch();
    let particles = write_frames(data.path());
    let words = shot_words(&particles);
    let whole = scratch();
    assert_ok(&run_in(whole.path(), &words, &[]));

    // Killed after frame 5: the skin VDB is its last file, so frames 6 on are missing
    // whole, and a half-written layer is a temporary file.
    let resumed = scratch();
    assert_ok(&run_in(resumed.path(), &words, &[]));
    for frame in 6..=FRAMES {
        for name in [
            format!("out/s.{frame:04}.vdb"),
            format!("out/m.{frame:04}.obj"),
            format!("out/shot/shot.{frame:04}.usda"),
        ] {
            std::fs::remove_file(resumed.path().join(name)).unwrap();
        }
    }
    std::fs::write(
        resumed.path().join("out/shot/.shot.0006.usda.4242.tmp"),
        "half",
    )
    .unwrap();
    let mut again = words.clone();
    again.push("--resume".into());
    assert_ok(&run_in(resumed.path(), &again, &[]));
    assert_same_shot(whole.path(), resumed.path(), "resumed");

    // Three chunks, each its own process as Slurm runs them. α 4 at 30 fps warms up 28
    // frames: each chunk starts from frame 1 and meets the sequential run exactly.
    let farmed = scratch();
    let mut farm: Vec<String> = ["farm", "--chunks", "3", "--dry-run", "--"]
        .map(String::from)
        .to_vec();
    farm.extend(words.iter().cloned());
    let printed = run_in(farmed.path(), &farm, &[]);
    assert_ok(&printed);
    let script = farmed.path().join("farm.sh");
    std::fs::write(&script, &printed.stdout).unwrap();
    assert!(
        String::from_utf8_lossy(&printed.stdout).contains(&format!("--shot-frames 1-{FRAMES}")),
        "the chunks are not told the shot's frames"
    );
    // The last chunk first: the stage each writes is the whole shot's, whatever the order.
    for task in ["2", "0", "1"] {
        let out = Command::new("bash")
            .arg(&script)
            .current_dir(farmed.path())
            .env("SLURM_ARRAY_TASK_ID", task)
            .output()
            .unwrap();
        assert_ok(&out);
    }
    assert_same_shot(whole.path(), farmed.path(), "farmed");
}

#[test]
fn a_stage_it_cannot_write_is_a_usage_error() {
    let dir = scratch();
    let base = |stage: &str, extra: &[&str]| {
        let mut args = vec![
            "morph",
            "--from",
            "sphere:r=0.5",
            "--to",
            "sphere:r=0.4",
            "--frames",
            "1-2",
            "--usd",
        ];
        args.push(stage);
        args.extend(extra);
        activeskin(&args)
    };
    let binary = dir.path().join("shot.usdc");
    let out = base(binary.to_str().unwrap(), &[]);
    assert_usage_error(&out, ".usda");
    let other = dir.path().join("shot.abc");
    assert_usage_error(&base(other.to_str().unwrap(), &[]), ".usda or .usd");
    let fine = dir.path().join("shot.usda");
    assert_usage_error(
        &base(fine.to_str().unwrap(), &["--meters-per-unit", "0"]),
        "--meters-per-unit",
    );
    assert!(!fine.exists() && !dir.path().join("shot").exists());
}
