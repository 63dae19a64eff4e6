//! `activeskin mesh`: our polygonizer on an OpenVDB level set agrees with volumeToMesh and
//! with the analytic sphere; fog volumes need --iso.
#![cfg(feature = "vdb")]

mod common;

use std::path::Path;
use std::process::Command;

use activeskin::mesh::Mesh;
use activeskin::vdb::{self, FileMetadata, Grid, WriteOptions};
use activeskin::volume::GridClass;
use glam::Vec3;

fn activeskin(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .args(args)
        .output()
        .expect("run activeskin")
}

fn write(grid: &Grid, path: &Path) {
    let meta = FileMetadata {
        creator: "test".into(),
        has_frame: false,
        frame: 0,
    };
    vdb::write_grids(path, &[(grid, WriteOptions::default())], &meta).unwrap();
}

/// Area of OpenVDB's volumeToMesh (triangles and quads).
fn openvdb_area(grid: &Grid) -> f64 {
    let m = grid.volume_to_mesh(0.0, 0.0).unwrap();
    let p = |i: u32| {
        let i = 3 * i as usize;
        Vec3::new(m.points[i], m.points[i + 1], m.points[i + 2]).as_dvec3()
    };
    let tri = |a, b, c| 0.5 * (p(b) - p(a)).cross(p(c) - p(a)).length();
    let tris: f64 = m.triangles.chunks(3).map(|t| tri(t[0], t[1], t[2])).sum();
    let quads: f64 = m
        .quads
        .chunks(4)
        .map(|q| tri(q[0], q[1], q[2]) + tri(q[0], q[2], q[3]))
        .sum();
    tris + quads
}

/// Reads our binary PLY back (x y z nx ny nz floats; uchar count, int indices) and checks
/// it is closed and manifold; returns its area and volume.
fn read_ply(path: &Path) -> (f64, f64) {
    let bytes = std::fs::read(path).unwrap();
    let text = String::from_utf8_lossy(&bytes);
    let end = text.find("end_header\n").unwrap() + "end_header\n".len();
    let count = |key: &str| -> usize {
        let line = text.lines().find(|l| l.starts_with(key)).unwrap();
        line.rsplit(' ').next().unwrap().parse().unwrap()
    };
    let (nv, nf) = (count("element vertex"), count("element face"));
    let word = |o: usize| -> [u8; 4] { bytes[o..o + 4].try_into().unwrap() };
    let mut mesh = Mesh::default();
    for v in 0..nv {
        let o = end + v * 24;
        let f = |k: usize| f32::from_le_bytes(word(o + 4 * k));
        mesh.positions.push(Vec3::new(f(0), f(1), f(2)));
    }
    let faces = end + nv * 24;
    for f in 0..nf {
        let o = faces + f * 13;
        assert_eq!(bytes[o], 3);
        let u = |k: usize| u32::from_le_bytes(word(o + 1 + 4 * k));
        mesh.triangles.push([u(0), u(1), u(2)]);
    }
    let check = mesh.check();
    assert!(check.is_clean(), "{check}");
    (mesh.area(), mesh.volume())
}

#[test]
fn meshes_an_openvdb_sphere_like_volume_to_mesh() {
    let dir = common::scratch();
    let grid = Grid::level_set_sphere(1.0, [0.1, 0.2, -0.3], 0.05, 3.0).unwrap();
    let input = dir.path().join("sphere.vdb");
    write(&grid, &input);
    let output = dir.path().join("sphere.ply");
    let result = activeskin(&["mesh", input.to_str().unwrap(), output.to_str().unwrap()]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let (area, volume) = read_ply(&output);
    let theirs = openvdb_area(&grid);
    assert!(
        (area - theirs).abs() / theirs < 0.005,
        "{area} vs volumeToMesh {theirs}"
    );
    let exact = 4.0 * std::f64::consts::PI;
    assert!((area - exact).abs() / exact < 0.01, "{area} vs {exact}");
    assert!(
        (volume - exact / 3.0).abs() / (exact / 3.0) < 0.01,
        "{volume}"
    );
}

#[test]
fn fog_volumes_need_iso() {
    let dir = common::scratch();
    let mut data = Grid::level_set_sphere(1.0, [0.0; 3], 0.1, 3.0)
        .unwrap()
        .to_data()
        .unwrap();
    let bg = data.background;
    data.class = GridClass::FogVolume;
    data.background = 0.0;
    data.leaf_values
        .iter_mut()
        .for_each(|v| *v = (0.5 - 0.5 * *v / bg).clamp(0.0, 1.0));
    data.tiles.iter_mut().for_each(|t| t.value = 1.0);
    let input = dir.path().join("fog.vdb");
    write(&Grid::from_data(&data).unwrap(), &input);
    let output = dir.path().join("fog.ply");
    let (i, o) = (input.to_str().unwrap(), output.to_str().unwrap());
    let result = activeskin(&["mesh", i, o]);
    assert_eq!(result.status.code(), Some(2));
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(err.contains("--iso") && err.contains("fog.vdb"), "{err}");
    assert!(!output.exists());
    let result = activeskin(&["mesh", i, o, "--iso", "0.5"]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let (area, _) = read_ply(&output);
    let exact = 4.0 * std::f64::consts::PI;
    assert!((area - exact).abs() / exact < 0.02, "{area}");
}
