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
    let cases: [(&str, Damage); 6] = [
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
            // The level set and the surface's velocity `v`.
            assert_eq!(vdb::list_grids(&path).unwrap().len(), 2, "{what}");
        }
    }
}

/// The sphere level set emptied: a frame without liquid.
fn empty_level_set() -> GridData {
    let mut grid = sphere_level_set();
    grid.leaf_origins.clear();
    grid.leaf_values.clear();
    grid.leaf_masks.clear();
    grid.tiles.clear();
    grid
}

#[test]
fn empty_frames_are_written_and_the_skin_goes_on() {
    // An emitter that starts at frame 3 and a pool drained at frame 6: frames 1–2 and 6–8
    // hold empty level sets.
    let dir = common::scratch();
    let target = copy_of_moving(dir.path());
    for frame in [1, 2, 6, 7, 8] {
        write_grid(
            &dir.path().join(format!("sphere.{frame:04}.vdb")),
            &empty_level_set(),
        );
    }
    let out = dir.path().join("out/skin.####.vdb");
    let mesh = dir.path().join("out/skin.####.ply");
    let stats = dir.path().join("out/stats.jsonl");
    let result = activeskin(&skin_args(
        &target,
        out.to_str().unwrap(),
        &[
            "--mesh",
            mesh.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
        ],
    ));
    assert_ok(&result);
    let components = common::stats_field(&stats, "components");
    // Seeded at frame 3 (the liquid appears), gone once it drains (α = 24: within three
    // frames of 3 voxels a frame toward the background).
    assert_eq!(&components[..5], [0, 0, 1, 1, 1]);
    assert_eq!(components[7], 0, "{components:?}");
    for frame in 1..=8 {
        // Every frame a level set OpenVDB reads, and a mesh (empty ones too).
        let grid = vdb::Grid::read(&dir.path().join(format!("out/skin.{frame:04}.vdb")), None)
            .unwrap()
            .to_data()
            .unwrap();
        assert_eq!(grid.class, GridClass::LevelSet);
        assert!(grid.background > 0.0);
        assert!(dir
            .path()
            .join(format!("out/skin.{frame:04}.ply"))
            .is_file());
    }
}

/// A Mantaflow-style `phi`: a sphere's signed distance in voxels over a dense 64³ domain
/// at Δx = 1/32, every voxel active, background 0.
fn mantaflow_phi() -> GridData {
    mantaflow_dense(|p| (p - Vec3::splat(1.0)).length() - 0.4)
}

/// `distance` (world units) as Mantaflow writes its `phi`: in voxels over a dense 64³
/// domain at Δx = 1/32, every voxel active, background 0.
fn mantaflow_dense(distance: impl Fn(Vec3) -> f32) -> GridData {
    let dx = 1.0 / 32.0;
    let transform = activeskin::volume::Transform::uniform(dx, [0.0; 3]);
    let mut grid = GridData::empty("phi", GridClass::LevelSet, 0.0, transform);
    for x in 0..8 {
        for y in 0..8 {
            for z in 0..8 {
                let origin = [x * 8, y * 8, z * 8];
                let values: Vec<f32> = (0..512)
                    .map(|o: i32| {
                        let ijk = Vec3::new(
                            (origin[0] + (o >> 6)) as f32,
                            (origin[1] + ((o >> 3) & 7)) as f32,
                            (origin[2] + (o & 7)) as f32,
                        );
                        distance(ijk * dx as f32) / dx as f32
                    })
                    .collect();
                grid.push_leaf(origin, &values, [u64::MAX; 8]);
            }
        }
    }
    grid
}

/// A pool filling the bottom of a dense domain touches its floor and four walls: `phi` is
/// negative up to the last voxel there. Beyond the voxels is outside, so both the mesh of
/// `phi` and the skin close the liquid within a voxel past the last voxels (where depends
/// on the distances stored there: it is interpolated toward the background).
#[test]
fn a_pool_against_a_dense_domains_walls_is_closed() {
    let dir = common::scratch();
    for frame in 1..=2 {
        write_grid(
            &dir.path().join(format!("fluid_data_{frame:04}.vdb")),
            &mantaflow_dense(|p| p.z - 0.5),
        );
    }
    // The box, up to z = 0.5, closed at the last voxels (0 and 63) or one voxel beyond.
    let dx = 1.0 / 32.0;
    let (least, most) = (
        (63.0 * dx) * (63.0 * dx) * 0.5,
        (65.0 * dx) * (65.0 * dx) * (0.5 + dx),
    );
    let volume_of = |mesh: &activeskin::mesh::Mesh| mesh.area_and_volume().1;

    let phi = dir.path().join("fluid_data_0001.vdb");
    let mesh_path = dir.path().join("phi.obj");
    let result = activeskin(&[
        "mesh",
        phi.to_str().unwrap(),
        mesh_path.to_str().unwrap(),
        "--check",
    ]);
    assert_ok(&result);
    let mesh = common::read_mesh(&mesh_path).unwrap();
    assert!(mesh.check().is_clean(), "{}", mesh.check());
    assert_eq!(mesh.euler_characteristic(), 2);
    let volume = volume_of(&mesh);
    assert!(
        (least..most).contains(&volume),
        "meshed phi encloses {volume}, the box {least}…{most}"
    );

    let target = dir.path().join("fluid_data_####.vdb");
    let skin = dir.path().join("skin.####.obj");
    let result = activeskin(&[
        "skin",
        "--target",
        target.to_str().unwrap(),
        "--mesh",
        skin.to_str().unwrap(),
        "-q",
    ]);
    assert_ok(&result);
    for frame in 1..=2 {
        let mesh = common::read_mesh(&dir.path().join(format!("skin.{frame:04}.obj"))).unwrap();
        assert!(mesh.check().is_clean(), "frame {frame}: {}", mesh.check());
        assert_eq!(mesh.euler_characteristic(), 2);
        let volume = volume_of(&mesh);
        assert!(
            (least..most).contains(&volume),
            "frame {frame}: the skin encloses {volume}, the box {least}…{most}"
        );
    }
}

#[test]
fn mantaflow_phi_in_voxels_with_background_0_is_read_in_world_units() {
    let dir = common::scratch();
    for frame in 1..=3 {
        write_grid(
            &dir.path().join(format!("fluid_data_{frame:04}.vdb")),
            &mantaflow_phi(),
        );
    }
    let target = dir.path().join("fluid_data_####.vdb");
    let run = |units: &str| {
        let folder = dir.path().join(units);
        let mesh = folder.join("skin.####.obj");
        let stats = folder.join("stats.jsonl");
        let result = activeskin(&[
            "skin",
            "--target",
            target.to_str().unwrap(),
            "--mesh",
            mesh.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
            "--target-units",
            units,
        ]);
        assert_ok(&result);
        let substeps: u64 = common::stats_field(&stats, "substeps").iter().sum();
        let mesh = common::read_mesh(&folder.join("skin.0003.obj")).unwrap();
        let off = mesh
            .positions
            .iter()
            .map(|p| ((*p - Vec3::splat(1.0)).length() - 0.4).abs() * 32.0)
            .sum::<f32>()
            / mesh.positions.len() as f32;
        (stderr(&result), substeps, off)
    };
    let (said, substeps, off) = run("auto");
    assert!(said.contains("voxels") && said.contains("'phi'"), "{said}");
    assert!(said.contains("background 0"), "{said}");
    assert_eq!(said.trim_end().lines().count(), 1, "{said}");
    assert!(off < 0.1, "{off} voxel off the sphere");
    // Read as world distances, the attraction is 32 times what was asked.
    let (_, substeps_world, _) = run("world");
    println!("sub-steps over 3 frames: {substeps} rescaled, {substeps_world} as world units");
    assert!(
        substeps_world >= 3 * substeps,
        "{substeps_world} vs {substeps}"
    );
    let (_, substeps_voxel, off_voxel) = run("voxel");
    assert_eq!(substeps_voxel, substeps);
    assert!(off_voxel < 0.1);
}

/// `--init` on another frame of a Mantaflow cache starts on its `--grid`, not on the
/// file's first float grid (Mantaflow writes `phi_obstacle` and others beside `phi`), in
/// the units the target's are read in; without `--grid`, `phi` is the grid read.
#[test]
fn init_from_a_cache_frame_reads_the_targets_grid() {
    let dir = common::scratch();
    let write = |path: &Path, radius: f32| {
        let mut obstacle = mantaflow_dense(|p| 0.9 - (p - Vec3::splat(1.0)).abs().max_element());
        obstacle.name = "phi_obstacle".into();
        let phi = mantaflow_dense(|p| (p - Vec3::splat(1.0)).length() - radius);
        let grids = [obstacle, phi].map(|g| activeskin::vdb::Grid::from_data(&g).unwrap());
        let meta = activeskin::vdb::frame_metadata(1);
        let grids: Vec<_> = grids.iter().map(|g| (g, Default::default())).collect();
        activeskin::vdb::write_grids(path, &grids, &meta).unwrap();
    };
    write(&dir.path().join("fluid_data_0001.vdb"), 0.4);
    write(&dir.path().join("fluid_data_0002.vdb"), 0.4);
    let init = dir.path().join("init.vdb");
    write(&init, 0.25);
    let target = dir.path().join("fluid_data_####.vdb");
    let mesh = dir.path().join("skin.####.obj");
    let result = activeskin(&[
        "skin",
        "--target",
        target.to_str().unwrap(),
        "--grid",
        "phi",
        "--init",
        init.to_str().unwrap(),
        "--mesh",
        mesh.to_str().unwrap(),
        "-q",
    ]);
    assert_ok(&result);
    let first = common::read_mesh(&dir.path().join("skin.0001.obj")).unwrap();
    let off = first
        .positions
        .iter()
        .map(|p| ((*p - Vec3::splat(1.0)).length() - 0.25).abs() * 32.0)
        .fold(0.0f32, f32::max);
    assert!(off < 0.1, "the first skin is {off} voxels off init's phi");
    // Without --grid, Mantaflow's `phi` is read, not the first float grid.
    let unnamed = dir.path().join("unnamed.####.obj");
    assert_ok(&activeskin(&[
        "skin",
        "--target",
        target.to_str().unwrap(),
        "--init",
        init.to_str().unwrap(),
        "--mesh",
        unnamed.to_str().unwrap(),
        "-q",
    ]));
    for frame in ["0001", "0002"] {
        let named = std::fs::read(dir.path().join(format!("skin.{frame}.obj"))).unwrap();
        let unnamed = std::fs::read(dir.path().join(format!("unnamed.{frame}.obj"))).unwrap();
        assert!(
            named == unnamed,
            "frame {frame}: without --grid, not phi's skin"
        );
    }
}

#[test]
fn one_file_is_a_static_target_held_for_the_frames() {
    let dir = common::scratch();
    let shape = dir.path().join("shape.vdb");
    write_grid(&shape, &sphere_level_set());
    let shape = shape.to_str().unwrap();
    let out = dir.path().join("out/skin.####.vdb");
    let out = out.to_str().unwrap();
    // Without --frames there is no telling how long to hold it.
    let result = activeskin(&skin_args(shape, out, &[]));
    assert_usage_error(&result, "--frames");
    let result = activeskin(&skin_args(
        shape,
        out,
        &["--frames", "1-5", "--beta", "0.001"],
    ));
    assert_ok(&result);
    assert_eq!(common::names(&dir.path().join("out")).len(), 5);
    // A file that is not there, without a frame number either.
    let missing = dir.path().join("nope.vdb");
    let result = activeskin(&skin_args(
        missing.to_str().unwrap(),
        out,
        &["--frames", "1-5"],
    ));
    assert_usage_error(&result, "nope.vdb");
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
