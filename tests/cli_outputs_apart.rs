//! Outputs never overwrite inputs, nor each other (issue 31): an output pattern that names
//! a file the run reads — the same path, another spelling of it, a symlink or a hard link
//! — or a file another output writes is a usage error before anything is written.
#![cfg(feature = "vdb")]

mod common;

use std::path::Path;

use common::{activeskin, assert_usage_error, write_grid};

use activeskin::io::ply::write_ply;
use activeskin::target::{sample, Sphere};
use glam::Vec3;

/// A small ball of particles, moved a little each frame, as `dir/p.000F.ply`, F = 1..=3.
fn clouds(dir: &Path) {
    for f in 1..=3 {
        let mut positions = Vec::new();
        for x in -3..=3 {
            for y in -3..=3 {
                for z in -3..=3 {
                    let p = Vec3::new(x as f32, y as f32, z as f32) * 0.02;
                    if p.length() <= 0.06 {
                        positions.push(p + Vec3::new(0.5 + 0.01 * f as f32, 0.5, 0.5));
                    }
                }
            }
        }
        write_ply(&dir.join(format!("p.{f:04}.ply")), &positions).unwrap();
    }
}

/// Every file of `dir` with its bytes, sorted by name.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    files.sort();
    files
}

#[test]
fn particle_meshes_never_replace_the_particles() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    clouds(d);
    std::os::unix::fs::symlink(d.join("p.0002.ply"), d.join("link.0002.ply")).unwrap();
    std::fs::hard_link(d.join("p.0003.ply"), d.join("hard.0003.ply")).unwrap();
    let before = contents(d);
    let input = d.join("p.####.ply");
    let particles = |mesh: &str| {
        activeskin(&[
            "particles",
            "--particles",
            input.to_str().unwrap(),
            "--radius",
            "0.01",
            "--mesh",
            d.join(mesh).to_str().unwrap(),
            "-q",
        ])
    };
    for mesh in [
        "p.####.ply",
        "new/../p.####.ply",
        "link.####.ply",
        "hard.####.ply",
    ] {
        assert_usage_error(&particles(mesh), "would overwrite the input");
        assert_eq!(contents(d), before, "{mesh}: the inputs changed");
        assert!(!d.join("new").exists(), "{mesh}: a folder was made");
    }
    // Elsewhere, the same run writes its meshes.
    let out = particles("m.####.ply");
    common::assert_ok(&out);
    assert!(d.join("m.0003.ply").is_file());
}

#[test]
fn a_skin_never_replaces_its_target_and_outputs_never_collide() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sphere = Sphere {
        center: Vec3::ZERO,
        radius: 0.4,
    };
    for f in 1..=2 {
        write_grid(
            &d.join(format!("fl.{f:04}.vdb")),
            &sample::level_set(&sphere, 1.0 / 16.0, 3.0),
        );
    }
    let before = contents(d);
    let target = d.join("fl.####.vdb");
    let target = target.to_str().unwrap();
    let out = activeskin(&common::skin_args(target, target, &[]));
    assert_usage_error(&out, "--out would overwrite the input");
    assert_eq!(contents(d), before);

    // Two outputs naming one file: the stats would replace frame 2's VDB.
    let skins = d.join("o/s.####.vdb");
    let stats = d.join("o/s.0002.vdb");
    let out = activeskin(&common::skin_args(
        target,
        skins.to_str().unwrap(),
        &["--stats", stats.to_str().unwrap()],
    ));
    assert_usage_error(&out, "--out and --stats would both write");
    assert!(!d.join("o/s.0001.vdb").exists());
    assert_eq!(contents(d), before);
}
