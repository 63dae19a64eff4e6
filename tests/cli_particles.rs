//! `activeskin particles`: on a static cloud the skin settles within a voxel of the
//! iso-density surface; broken particle files stop the run with one line naming them.
#![cfg(feature = "vdb")]

mod common;

use std::path::Path;
use std::process::Command;

use activeskin::target::{iso_for_radius, Density, Target};
use glam::Vec3;

const RADIUS: f32 = 0.05;

/// A ball of particles on a lattice of spacing RADIUS, jittered (repeatably).
fn cloud() -> Vec<Vec3> {
    let mut state = 12345u64;
    let mut jitter = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.3 * RADIUS
    };
    let mut points = Vec::new();
    let n = (0.4 / RADIUS) as i32;
    for x in -n..=n {
        for y in -n..=n {
            for z in -n..=n {
                let p = Vec3::new(x as f32, y as f32, z as f32) * RADIUS;
                if p.length() <= 0.4 {
                    points.push(p + Vec3::new(jitter(), jitter(), jitter()));
                }
            }
        }
    }
    points
}

fn write_ply(path: &Path, points: &[Vec3]) {
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        points.len()
    )
    .into_bytes();
    for p in points {
        for c in p.to_array() {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    std::fs::write(path, bytes).unwrap();
}

fn activeskin(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn static_cloud_skin_sits_on_the_iso_density_surface() {
    let dir = common::scratch();
    let points = cloud();
    for frame in 1..=6 {
        write_ply(&dir.path().join(format!("cloud.{frame:04}.ply")), &points);
    }
    let pattern = dir.path().join("cloud.####.ply");
    let mesh = dir.path().join("out/skin.####.obj");
    let fog = dir.path().join("out/density.####.vdb");
    let radius = RADIUS.to_string();
    let result = activeskin(&[
        "particles",
        "--particles",
        pattern.to_str().unwrap(),
        "--radius",
        &radius,
        "--alpha",
        "24",
        "--beta",
        "0",
        "--mesh",
        mesh.to_str().unwrap(),
        "--density-out",
        fog.to_str().unwrap(),
        "-q",
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let h = 2.0 * RADIUS;
    let iso = iso_for_radius(RADIUS, h);
    let fog = activeskin::vdb::Grid::read(&dir.path().join("out/density.0003.vdb"), None)
        .unwrap()
        .to_data()
        .unwrap();
    assert_eq!(fog.name, "density");
    assert_eq!(fog.class, activeskin::volume::GridClass::FogVolume);
    let max = fog.leaf_values.iter().copied().fold(0.0f32, f32::max);
    assert!(
        max > iso && fog.background == 0.0,
        "max density {max}, iso {iso}"
    );
    let obj = std::fs::read_to_string(dir.path().join("out/skin.0006.obj")).unwrap();
    let vertices: Vec<Vec3> = obj
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f32> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
            Vec3::new(v[0], v[1], v[2])
        })
        .collect();
    assert!(!vertices.is_empty());
    let density = Density::new(points, h, iso);
    let dx = 0.5 * RADIUS;
    let worst = vertices
        .iter()
        .map(|&p| density.distance(p).abs() / dx)
        .fold(0.0f32, f32::max);
    assert!(
        worst <= 1.0,
        "skin {worst:.2} voxels from the iso-density surface"
    );
}

#[test]
fn broken_particle_frames_are_one_line_errors() {
    let dir = common::scratch();
    let points = cloud();
    let cases: [(&str, &[u8]); 3] = [
        ("truncated", b"ply\nformat binary_little_endian 1.0\nelement vertex 9\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0"),
        ("empty", b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n"),
        ("nan", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\nnan 0 0\n"),
    ];
    for (what, bytes) in cases {
        let folder = dir.path().join(what);
        std::fs::create_dir(&folder).unwrap();
        write_ply(&folder.join("c.0001.ply"), &points);
        std::fs::write(folder.join("c.0002.ply"), bytes).unwrap();
        let out = folder.join("out/s.####.vdb");
        let result = activeskin(&[
            "particles",
            "--particles",
            folder.join("c.####.ply").to_str().unwrap(),
            "--radius",
            "0.05",
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]);
        let err = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(1), "{what}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{what}: {err}");
        assert!(
            err.contains("c.0002.ply") && !err.contains("panicked"),
            "{what}: {err}"
        );
        // Frame 1 is whole, frame 2 absent.
        assert!(folder.join("out/s.0001.vdb").is_file(), "{what}");
        assert!(!folder.join("out/s.0002.vdb").exists(), "{what}");
    }
}
