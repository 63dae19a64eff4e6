//! `activeskin particles`: a fluid at rest keeps its volume and the skin sits on the
//! density's iso-surface; the first frame starts as one solid; broken particle files stop
//! the run with one line naming them.
#![cfg(feature = "vdb")]

mod common;

use std::path::Path;
use std::process::Command;

use activeskin::target::{fluid_iso, Density, DensityGrid, Target, DEFAULT_SMOOTHING_LENGTH};
use glam::Vec3;

const RADIUS: f32 = 0.02;
/// Seven supports: the calibration is for a flat boundary, and a ball's surface sits
/// outward by about 10/(R/h) % of its volume (+2.1 % at five supports, +1.4 % at seven).
const BALL: f32 = 0.56;

/// A fluid at rest: particles of RADIUS on a lattice of spacing 2·RADIUS filling a ball of
/// radius BALL, each jittered by up to ±0.15 RADIUS (repeatably).
fn cloud() -> Vec<Vec3> {
    let mut state = 12345u64;
    let mut jitter = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.3 * RADIUS
    };
    let spacing = 2.0 * RADIUS;
    let mut points = Vec::new();
    let n = (BALL / spacing) as i32;
    for x in -n..=n {
        for y in -n..=n {
            for z in -n..=n {
                let p = Vec3::new(x as f32, y as f32, z as f32) * spacing;
                if p.length() <= BALL {
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
fn a_fluid_at_rest_keeps_its_volume_on_the_iso_density_surface() {
    let dir = common::scratch();
    let points = cloud();
    for frame in 1..=6 {
        write_ply(&dir.path().join(format!("cloud.{frame:04}.ply")), &points);
    }
    let pattern = dir.path().join("cloud.####.ply");
    let mesh = dir.path().join("out/skin.####.obj");
    let fog = dir.path().join("out/density.####.vdb");
    let stats_file = dir.path().join("out/stats.jsonl");
    let radius = RADIUS.to_string();
    let result = activeskin(&[
        "particles",
        "--particles",
        pattern.to_str().unwrap(),
        "--radius",
        &radius,
        "--mesh",
        mesh.to_str().unwrap(),
        "--density-out",
        fog.to_str().unwrap(),
        "--stats",
        stats_file.to_str().unwrap(),
        // The attraction onto the density's iso-surface, unsmoothed (smoothing takes
        // the skin off the lattice's terraces: tests/look.rs).
        "--smooth",
        "0",
        "-q",
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    // The calibration: the fluid's volume is its particles' share of the lattice.
    let fluid = points.len() as f64 * f64::from(2.0 * RADIUS).powi(3);
    for line in common::stats_lines(&stats_file) {
        let volume = line["volume"].as_f64().unwrap();
        assert!(
            (volume / fluid - 1.0).abs() < 0.02,
            "frame {}: volume {volume:.5} against the fluid's {fluid:.5}",
            line["frame"]
        );
        assert_eq!(line["components"], 1);
    }

    let iso = fluid_iso(DEFAULT_SMOOTHING_LENGTH);
    let h = 2.0 * DEFAULT_SMOOTHING_LENGTH * RADIUS;
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
    let vertices = common::read_mesh(&dir.path().join("out/skin.0006.obj"))
        .unwrap()
        .positions;
    assert!(!vertices.is_empty());
    let density = Density::new(points, h, iso).normalized(DEFAULT_SMOOTHING_LENGTH);
    let dx = 0.5 * RADIUS;
    let distances: Vec<f32> = vertices
        .iter()
        .map(|&p| density.distance(p).abs() / dx)
        .collect();
    let mean = distances.iter().sum::<f32>() / distances.len() as f32;
    let worst = distances.iter().copied().fold(0.0f32, f32::max);
    println!("skin to the iso-density surface: mean {mean:.3}, worst {worst:.3} voxel");
    assert!(
        mean < 0.1 && worst < 0.5,
        "skin {mean:.2} (worst {worst:.2}) voxels from the iso-density surface"
    );
}

#[test]
fn the_first_frame_starts_as_one_solid() {
    // A kernel that barely spans the spacing with a high iso: the density dips below the
    // iso between particles inside the fluid. Started on it as it is, the skin would hold
    // a skin around each dip.
    let dir = common::scratch();
    let points = cloud();
    let (smoothing, iso) = (1.0f32, 0.33f32);
    let density = Density::new(points.clone(), 2.0 * smoothing * RADIUS, iso).normalized(smoothing);
    let mut grid = DensityGrid::rasterize(&density, 0.5 * RADIUS);
    let voids = grid.fill_voids(1.0);
    assert!(
        voids > 10,
        "only {voids} voids: the test needs a density with some"
    );

    write_ply(&dir.path().join("c.0001.ply"), &points);
    let stats_file = dir.path().join("stats.jsonl");
    let result = activeskin(&[
        "particles",
        "--particles",
        dir.path().join("c.####.ply").to_str().unwrap(),
        "--radius",
        &RADIUS.to_string(),
        "--smoothing-length",
        &smoothing.to_string(),
        "--iso",
        &iso.to_string(),
        "--stats",
        stats_file.to_str().unwrap(),
        "-q",
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let first = &common::stats_lines(&stats_file)[0];
    assert_eq!(first["components"], 1, "{first}");
    assert_eq!(first["euler_characteristic"], 2, "{first}");
}

#[test]
fn liquid_that_appears_mid_shot_is_skinned_on_its_first_frame() {
    // An emitter starting at frame 3, far from the skin: the skin is seeded there at once;
    // a frame without particles is a frame without liquid.
    let dir = common::scratch();
    let ball = |centre: Vec3| -> Vec<Vec3> {
        let mut points = Vec::new();
        for x in -4..=4 {
            for y in -4..=4 {
                for z in -4..=4 {
                    let p = Vec3::new(x as f32, y as f32, z as f32) * 2.0 * RADIUS;
                    if p.length() <= 8.0 * RADIUS {
                        points.push(centre + p);
                    }
                }
            }
        }
        points
    };
    for frame in 1..=6 {
        let mut points = ball(Vec3::ZERO);
        if frame >= 3 {
            points.extend(ball(Vec3::X));
        }
        // A frame with no particles at all: no liquid, written empty.
        if frame == 6 {
            points.clear();
        }
        write_ply(&dir.path().join(format!("e.{frame:04}.ply")), &points);
    }
    let stats_file = dir.path().join("stats.jsonl");
    let mesh = dir.path().join("e.####.obj");
    let result = activeskin(&[
        "particles",
        "--particles",
        dir.path().join("e.####.ply").to_str().unwrap(),
        "--radius",
        &RADIUS.to_string(),
        "--stats",
        stats_file.to_str().unwrap(),
        "--mesh",
        mesh.to_str().unwrap(),
        "-q",
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let components = common::stats_field(&stats_file, "components");
    assert_eq!(&components[..5], [1, 1, 2, 2, 2]);
    assert!(dir.path().join("e.0006.obj").is_file());
}

#[test]
fn broken_particle_frames_are_one_line_errors() {
    let dir = common::scratch();
    let points = cloud();
    let cases: [(&str, &[u8]); 2] = [
        ("truncated", b"ply\nformat binary_little_endian 1.0\nelement vertex 9\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0"),
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

/// `--velocity-time` offers particles only what they can use: `auto` measures on level
/// sets, so it is neither listed nor accepted (exit 2, one line).
#[test]
fn velocity_time_offers_particles_start_and_mid_only() {
    let help = activeskin(&["particles", "--help"]);
    let text = String::from_utf8_lossy(&help.stdout);
    let listed = text.split("--velocity-time").nth(1).unwrap_or_default();
    let listed = &listed[..listed.find("[default").unwrap_or(listed.len())];
    assert!(
        listed.contains("- start:") && listed.contains("- mid:"),
        "{listed}"
    );
    assert!(!listed.contains("- auto:"), "{listed}");
    let out = activeskin(&[
        "particles",
        "--particles",
        "p.####.ply",
        "--radius",
        "0.02",
        "--mesh",
        "m.####.obj",
        "--velocity-time",
        "auto",
    ]);
    common::assert_usage_error(&out, "auto");
}
