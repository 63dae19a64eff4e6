//! `activeskin skin` on inputs as they come: broken and missing frames, bad usage, grids
//! that cannot be used, frames in other voxel sizes and rotated transforms.
#![cfg(feature = "vdb")]

mod common;

use std::path::{Path, PathBuf};

use common::{
    activeskin, assert_ok, assert_one_line_error, assert_usage_error, data, skin_args, stderr,
    write_grid,
};

use activeskin::target::{sample, Sphere, Target};
use activeskin::vdb;
use activeskin::volume::{GridClass, GridData};
use glam::Vec3;

const DATA_DX: f64 = 1.0 / 16.0;

fn copy_of_moving(dir: &Path) -> String {
    for frame in 1..=8 {
        let name = format!("sphere.{frame:04}.vdb");
        std::fs::copy(data(&format!("moving/{name}")), dir.join(&name)).unwrap();
    }
    dir.join("sphere.####.vdb").to_string_lossy().into_owned()
}

fn sphere_level_set() -> GridData {
    let sphere = Sphere {
        center: Vec3::ZERO,
        radius: 0.3,
    };
    sample::level_set(&sphere as &dyn Target, DATA_DX as f32, 3.0)
}

#[test]
fn a_bad_frame_stops_the_run_and_keeps_earlier_frames() {
    type Damage = fn(&Path);
    let cases: [(&str, Damage); 7] = [
        ("missing", |f| {
            std::fs::remove_file(f).unwrap();
        }),
        ("empty", |f| {
            std::fs::write(f, b"").unwrap();
        }),
        ("garbage", |f| {
            std::fs::write(f, b"this is not a VDB file, just some words").unwrap();
        }),
        ("truncated", |f| {
            let bytes = std::fs::read(f).unwrap();
            std::fs::write(f, &bytes[..bytes.len() / 2]).unwrap();
        }),
        ("NaN", |f| {
            let mut grid = sphere_level_set();
            grid.leaf_values[100] = f32::NAN;
            write_grid(f, &grid);
        }),
        ("empty grid", |f| {
            let mut grid = sphere_level_set();
            grid.leaf_origins.clear();
            grid.leaf_values.clear();
            grid.leaf_masks.clear();
            grid.tiles.clear();
            write_grid(f, &grid);
        }),
        ("non-uniform", |f| {
            let mut grid = sphere_level_set();
            grid.transform.matrix[5] *= 2.0;
            write_grid(f, &grid);
        }),
    ];
    for (what, damage) in cases {
        let dir = common::scratch();
        let target = copy_of_moving(dir.path());
        let bad = dir.path().join("sphere.0004.vdb");
        damage(&bad);
        let out_dir = dir.path().join("out");
        let out = out_dir.join("skin.####.vdb");
        let result = activeskin(&skin_args(
            &target,
            out.to_str().unwrap(),
            &["--frames", "1-8"],
        ));
        assert_one_line_error(&result, "sphere.0004.vdb");
        assert_eq!(
            common::names(&out_dir),
            ["skin.0001.vdb", "skin.0002.vdb", "skin.0003.vdb"],
            "{what}"
        );
        for frame in 1..=3 {
            let path = out_dir.join(format!("skin.{frame:04}.vdb"));
            assert_eq!(vdb::list_grids(&path).unwrap().len(), 1, "{what}");
        }
    }
}

#[test]
fn hold_missing_keeps_the_last_target() {
    let dir = common::scratch();
    let target = copy_of_moving(dir.path());
    std::fs::remove_file(dir.path().join("sphere.0005.vdb")).unwrap();
    let out = dir.path().join("out/skin.####.vdb");
    let result = activeskin(&skin_args(
        &target,
        out.to_str().unwrap(),
        &["--frames", "1-8", "--hold-missing"],
    ));
    assert_ok(&result);
    assert_eq!(common::names(&dir.path().join("out")).len(), 8);
}

#[test]
fn bad_usage_and_unusable_grids_are_one_line_errors() {
    let dir = common::scratch();
    let target = copy_of_moving(dir.path());
    let out = dir.path().join("out/skin.####.vdb");
    let out = out.to_str().unwrap();

    let result = activeskin(&skin_args(&target, out, &["--grid", "density"]));
    assert_one_line_error(&result, "sphere.0001.vdb");
    assert!(stderr(&result).contains("density"));

    let nothing = dir.path().join("nothing.####.vdb");
    let result = activeskin(&skin_args(nothing.to_str().unwrap(), out, &[]));
    assert_usage_error(&result, "nothing.####.vdb");

    let result = activeskin(&["skin", "--target", &target, "--alpha=-1", "--out", out]);
    assert_usage_error(&result, "--alpha");
    let result = activeskin(&skin_args(&target, out, &["--frames", "5-2"]));
    assert_usage_error(&result, "--frames");

    // A fog volume (density 1 inside) needs --iso; with it, the skin runs.
    let fog_dir = dir.path().join("fog");
    std::fs::create_dir(&fog_dir).unwrap();
    let mut fog = sphere_level_set();
    let bg = fog.background;
    fog.class = GridClass::FogVolume;
    fog.background = 0.0;
    fog.leaf_values
        .iter_mut()
        .for_each(|v| *v = (0.5 - 0.5 * *v / bg).clamp(0.0, 1.0));
    fog.tiles.iter_mut().for_each(|t| t.value = 1.0);
    write_grid(&fog_dir.join("fog.0001.vdb"), &fog);
    write_grid(&fog_dir.join("fog.0002.vdb"), &fog);
    let fog_target = fog_dir.join("fog.####.vdb");
    let fog_target = fog_target.to_str().unwrap();
    let result = activeskin(&skin_args(fog_target, out, &[]));
    assert_usage_error(&result, "fog.0001.vdb");
    assert!(stderr(&result).contains("--iso"));
    let mesh = dir.path().join("fog_out/fog.####.ply");
    let result = activeskin(&[
        "skin",
        "--target",
        fog_target,
        "--iso",
        "0.5",
        "--mesh",
        mesh.to_str().unwrap(),
        "-q",
    ]);
    assert_ok(&result);

    // An output folder that cannot be made (a file stands in its way).
    let blocker = dir.path().join("blocker");
    std::fs::write(&blocker, b"").unwrap();
    let inside: PathBuf = blocker.join("skin.####.vdb");
    let result = activeskin(&skin_args(&target, inside.to_str().unwrap(), &[]));
    assert_one_line_error(&result, "blocker");
}

#[test]
fn frames_with_other_voxel_sizes_and_rotated_transforms_are_sampled_in_world_space() {
    // A sphere of radius 0.3 at (0.1, 0, 0), written at three voxel sizes, the last one
    // with its index space rotated 30° about z and translated to keep the sphere put.
    let dir = common::scratch();
    let centre = Vec3::new(0.1, 0.0, 0.0);
    let radius = 0.3;
    for (frame, dx) in [
        (1, 1.0 / 16.0),
        (2, 1.0 / 20.0),
        (3, 1.0 / 12.0),
        (4, 1.0 / 16.0),
    ] {
        let rotated = frame == 4;
        // Sampled off the grid's origin, then turned and moved there by the transform.
        let local = Vec3::new(0.2, 0.0, 0.0);
        let sphere = Sphere {
            center: local,
            radius,
        };
        let mut grid = sample::level_set(&sphere as &dyn Target, dx, 3.0);
        let m = &mut grid.transform.matrix;
        let (s, c) = if rotated {
            30f64.to_radians().sin_cos()
        } else {
            (0.0, 1.0)
        };
        let d = f64::from(dx);
        // Rows are the world images of the index axes: world = i·row0 + j·row1 + t.
        m[0] = c * d;
        m[1] = s * d;
        m[4] = -s * d;
        m[5] = c * d;
        let turned = (c * f64::from(local.x), s * f64::from(local.x));
        m[12] = f64::from(centre.x) - turned.0;
        m[13] = f64::from(centre.y) - turned.1;
        write_grid(&dir.path().join(format!("ball.{frame:04}.vdb")), &grid);
    }
    let target = dir.path().join("ball.####.vdb");
    let mesh = dir.path().join("out/ball.####.obj");
    let result = activeskin(&[
        "skin",
        "--target",
        target.to_str().unwrap(),
        "--alpha",
        "24",
        "--mesh",
        mesh.to_str().unwrap(),
        "-q",
    ]);
    assert_ok(&result);
    let truth = Sphere {
        center: centre,
        radius,
    };
    for frame in 1..=4 {
        let mesh = common::read_mesh(&dir.path().join(format!("out/ball.{frame:04}.obj"))).unwrap();
        let max = mesh
            .positions
            .iter()
            .map(|&p| f64::from(truth.distance(p).abs()) / DATA_DX)
            .fold(0.0, f64::max);
        assert!(max <= 0.5, "frame {frame}: {max:.2} voxels off");
    }
}
