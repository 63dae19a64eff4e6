//! `activeskin mesh`: our polygonizer on an OpenVDB level set agrees with volumeToMesh and
//! with the analytic sphere; fog volumes need --iso.
#![cfg(feature = "vdb")]

mod common;

use common::activeskin;

use std::path::Path;

use activeskin::vdb::{self, FileMetadata, Grid, WriteOptions};
use activeskin::volume::GridClass;
use glam::Vec3;

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

/// Reads our binary PLY back and checks it is a clean surface; returns its area and
/// volume.
fn read_ply(path: &Path) -> (f64, f64) {
    let mesh = common::read_mesh(path).expect("a PLY with faces");
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
    // --check adds the topology, and the OBJ writer (formatted in parallel chunks) gives
    // the same mesh as the PLY one.
    let obj = dir.path().join("sphere.obj");
    let result = activeskin(&[
        "mesh",
        input.to_str().unwrap(),
        obj.to_str().unwrap(),
        "--check",
    ]);
    let said = String::from_utf8_lossy(&result.stdout);
    assert!(
        result.status.success() && said.contains("χ 2, 1 component(s), clean"),
        "{said}"
    );
    let from_obj = common::read_mesh(&obj).unwrap();
    let from_ply = common::read_mesh(&output).unwrap();
    assert_eq!(from_obj.triangles, from_ply.triangles);
    assert_eq!(from_obj.positions, from_ply.positions);
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

/// Printing into a closed pipe (`activeskin mesh … | head -0`) ends the process quietly,
/// as C tools do, with no panic; the mesh is written all the same.
#[test]
fn a_closed_pipe_on_stdout_is_no_panic() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    let dir = common::scratch();
    let grid = Grid::level_set_sphere(1.0, [0.0; 3], 0.05, 3.0).unwrap();
    let input = dir.path().join("sphere.vdb");
    write(&grid, &input);
    let output = dir.path().join("sphere.ply");
    let mut child = Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .args(["mesh", input.to_str().unwrap(), output.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader is gone before the one line is printed
    let result = child.wait_with_output().unwrap();
    let stderr = common::stderr(&result);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(result.status.signal(), Some(libc::SIGPIPE), "{stderr}");
    read_ply(&output);
}

/// A value that is not a finite number, anywhere (a voxel, a tile, the background, for a
/// level set or a fog volume at --iso), is one line and exit 1, with no mesh written.
#[test]
fn values_that_are_not_numbers_are_refused() {
    use activeskin::target::{sample, Sphere};
    use activeskin::volume::Tile;
    let sphere = Sphere {
        center: Vec3::ZERO,
        radius: 0.5,
    };
    let base = sample::level_set(&sphere, 0.05, 3.0);
    type Damage = fn(&mut activeskin::volume::GridData);
    let cases: [(&str, Damage); 4] = [
        ("a NaN voxel", |d| d.leaf_values[100] = f32::NAN),
        ("an infinite voxel", |d| {
            d.leaf_values[7] = f32::NEG_INFINITY
        }),
        ("an infinite tile", |d| {
            d.tiles.push(Tile {
                origin: [800, 800, 800],
                dim: 8,
                value: f32::INFINITY,
                active: true,
            })
        }),
        ("a NaN background", |d| d.background = f32::NAN),
    ];
    for (what, damage) in cases {
        for iso in [None, Some("0.1")] {
            let dir = common::scratch();
            let mut data = base.clone();
            damage(&mut data);
            let input = dir.path().join("bad.vdb");
            write(&Grid::from_data(&data).unwrap(), &input);
            let output = dir.path().join("bad.obj");
            let mut args = vec!["mesh", input.to_str().unwrap(), output.to_str().unwrap()];
            args.extend(iso.map(|iso| ["--iso", iso]).into_iter().flatten());
            let result = activeskin(&args);
            common::assert_fails(&result, 1, "bad.vdb", what);
            assert!(
                common::stderr(&result).contains("NaN or infinite"),
                "{what}"
            );
            assert!(!output.exists(), "{what}");
        }
    }
}
