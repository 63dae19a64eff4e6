//! One canonical state per frame: the skin never depends on which outputs are written.
//! The same run with every combination of outputs gives byte-identical meshes, and a run
//! resumed from its VDB frames repeats the uninterrupted one.
#![cfg(feature = "vdb")]

mod common;

use std::path::Path;

use common::{activeskin, scratch};

const DATA: &str = env!("CARGO_MANIFEST_DIR");

/// The outputs of one run: each combination always includes the mesh.
const COMBINATIONS: [&[&str]; 5] = [
    &[],
    &["out"],
    &["render"],
    &["stats"],
    &["out", "render", "stats"],
];

/// Runs `command` (frames `frames`) into `dir` with the mesh and the outputs `with`.
fn run(command: &[&str], frames: &str, dir: &Path, with: &[&str], resume: bool) {
    let file = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let (mesh, out, render, stats) = (
        file("skin.####.obj"),
        file("skin.####.vdb"),
        file("skin.####.png"),
        file("stats.jsonl"),
    );
    let mut args: Vec<&str> = command.to_vec();
    args.extend(["--frames", frames, "--mesh", &mesh, "-q"]);
    for output in with {
        match *output {
            "out" => args.extend(["--out", &out]),
            "render" => args.extend(["--render", &render, "--render-size", "48x32"]),
            "stats" => args.extend(["--stats", &stats]),
            _ => unreachable!(),
        }
    }
    if resume {
        args.push("--resume");
    }
    let result = activeskin(&args);
    assert!(result.status.success(), "{}", common::stderr(&result));
}

fn meshes(dir: &Path, frames: std::ops::RangeInclusive<i64>) -> Vec<Vec<u8>> {
    frames
        .map(|f| std::fs::read(dir.join(format!("skin.{f:04}.obj"))).unwrap())
        .collect()
}

fn assert_outputs_do_not_change_the_skin(command: &[&str], last: i64) {
    let frames = format!("1-{last}");
    let mut reference: Option<Vec<Vec<u8>>> = None;
    for with in COMBINATIONS {
        let dir = scratch();
        run(command, &frames, dir.path(), with, false);
        let got = meshes(dir.path(), 1..=last);
        match &reference {
            None => reference = Some(got),
            Some(expected) => {
                for (frame, (a, b)) in (1..).zip(expected.iter().zip(&got)) {
                    assert!(a == b, "{command:?} with {with:?}: frame {frame} differs");
                }
            }
        }
    }
}

#[test]
fn outputs_do_not_change_a_skin_on_a_moving_vdb_target() {
    let target = format!("{DATA}/data/moving/sphere.####.vdb");
    assert_outputs_do_not_change_the_skin(&["skin", "--target", &target, "--alpha", "24"], 8);
}

/// The drop-and-splash sample of `data/`.
fn splash() -> String {
    format!("{DATA}/data/splash/drop.####.ply")
}

/// The particles command on `particles` as the demo dresses them (α = 48).
fn splash_command(particles: &str) -> [&str; 7] {
    [
        "particles",
        "--particles",
        particles,
        "--radius",
        "0.04",
        "--alpha",
        "48",
    ]
}

#[test]
fn outputs_do_not_change_a_skin_on_particles() {
    let particles = splash();
    let mut command = splash_command(&particles).to_vec();
    command.extend(["--beta", "0.0003"]);
    assert_outputs_do_not_change_the_skin(&command, 6);
}

#[test]
fn a_resumed_particle_run_repeats_the_whole_run() {
    let particles = splash();
    let command = splash_command(&particles);
    let whole = scratch();
    run(&command, "1-8", whole.path(), &["out", "render"], false);
    let part = scratch();
    run(&command, "1-4", part.path(), &["out", "render"], false);
    run(&command, "1-8", part.path(), &["out", "render"], true);
    let (a, b) = (meshes(whole.path(), 1..=8), meshes(part.path(), 1..=8));
    for (frame, (a, b)) in (1..).zip(a.iter().zip(&b)) {
        assert!(a == b, "frame {frame} differs after resuming at frame 5");
    }
    // The camera frames the run's first skin, not the first frame after the resume.
    for frame in 5..=8 {
        let name = format!("skin.{frame:04}.png");
        let read = |dir: &Path| std::fs::read(dir.join(&name)).unwrap();
        assert!(read(whole.path()) == read(part.path()), "{name} differs");
    }
}

#[test]
fn a_frame_whose_mesh_failed_is_recomputed_on_resume() {
    // The skin VDB is written last: it tells --resume where to restart, so a frame whose
    // other outputs did not all reach the disk must not have one.
    let particles = splash();
    let command = splash_command(&particles);
    let whole = scratch();
    run(&command, "1-5", whole.path(), &["out"], false);

    let part = scratch();
    let blocker = part.path().join("skin.0003.obj");
    std::fs::create_dir(&blocker).unwrap(); // the mesh of frame 3 cannot be renamed there
    let mut args: Vec<String> = command.iter().map(|s| s.to_string()).collect();
    let file = |name: &str| part.path().join(name).to_string_lossy().into_owned();
    args.extend(["--frames", "1-5", "--mesh", &file("skin.####.obj")].map(String::from));
    args.extend(["--out", &file("skin.####.vdb"), "-q"].map(String::from));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let failed = activeskin(&args);
    assert!(!failed.status.success());
    assert!(part.path().join("skin.0002.vdb").is_file());
    assert!(
        !part.path().join("skin.0003.vdb").exists(),
        "frame 3 marked done"
    );

    std::fs::remove_dir(&blocker).unwrap();
    run(&command, "1-5", part.path(), &["out"], true);
    let (a, b) = (meshes(whole.path(), 1..=5), meshes(part.path(), 1..=5));
    for (frame, (a, b)) in (1..).zip(a.iter().zip(&b)) {
        assert!(a == b, "frame {frame} differs after resuming");
    }
}
