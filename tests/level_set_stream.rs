//! Level sets handed over frame by frame ([`LevelSetStream`], what the Python API's
//! `LevelSetSkin` runs) make the same surfaces as `activeskin skin` and `morph` on the
//! same grids in VDB files, byte for byte; dense arrays (numpy's) are level sets and fog
//! volumes like any other, in world units or voxels.

mod common;

use activeskin::flow::Timing;
use activeskin::frames::{dense_grid, LevelSetFrame, LevelSetSpec, LevelSetStream, TargetUnits};
use activeskin::skin::Physics;
use activeskin::volume::{GridClass, GridData};
use glam::Vec3;

fn spec() -> LevelSetSpec {
    LevelSetSpec {
        physics: Physics::default(),
        fps: 24.0,
        timing: Timing::Start,
        velocity_scale: 1.0,
        iso: None,
        units: TargetUnits::Auto,
        velocities: false,
        velocity_grid: false,
        first_frame: 1,
        seed: true,
        init: None,
        region: None,
        collider: None,
    }
}

/// A dense `n³` block of voxels of size `dx` from `origin`, holding `f` at each voxel's
/// centre (C order, as numpy's `(n, n, n)` arrays are).
fn dense(n: usize, dx: f32, origin: Vec3, f: impl Fn(Vec3) -> f32) -> Vec<f32> {
    let mut values = Vec::with_capacity(n * n * n);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                values.push(f(origin + Vec3::new(i as f32, j as f32, k as f32) * dx));
            }
        }
    }
    values
}

fn at(origin: Vec3) -> [f64; 3] {
    origin.to_array().map(f64::from)
}

fn frame(grid: GridData) -> LevelSetFrame {
    LevelSetFrame {
        grid,
        velocity: None,
        label: "frame".into(),
    }
}

/// The mean of |distance to the sphere| over the mesh's vertices, in voxels.
fn off_sphere(mesh: &activeskin::mesh::Mesh, center: Vec3, radius: f32, dx: f32) -> f32 {
    let sum: f32 = mesh
        .positions
        .iter()
        .map(|p| ((*p - center).length() - radius).abs())
        .sum();
    sum / mesh.positions.len() as f32 / dx
}

#[test]
fn a_dense_level_set_in_voxels_is_skinned_onto_its_sphere() {
    // Not a whole number of leaves: the leaves' voxels past the block are outside.
    let (n, dx) = (43, 0.05f32);
    let origin = Vec3::splat(-1.0);
    // Off centre along each axis differently: a transposed block would miss it by voxels.
    let (center, radius) = (Vec3::new(0.15, -0.1, 0.05), 0.55);
    // Distances in voxels, as Mantaflow's phi: rescaled to world units by themselves.
    let values = dense(n, dx, origin, |p| ((p - center).length() - radius) / dx);
    let mut stream = LevelSetStream::start(spec()).unwrap();
    let mut last = None;
    for f in 1..=12 {
        let grid = dense_grid(GridClass::LevelSet, ([n; 3], &values), dx, at(origin)).unwrap();
        let surface = stream.advance(frame(grid)).unwrap();
        assert_eq!(surface.frame, f);
        assert_eq!(surface.stats.euler_characteristic, 2);
        last = Some(surface);
    }
    let last = last.unwrap();
    let off = off_sphere(&last.mesh, center, radius, dx);
    println!("dense sphere: {off:.3} voxel off");
    assert!(off < 0.1, "{off} voxel from the sphere");
    assert!(last.level_set.leaf_count() > 0);
}

#[test]
fn a_dense_block_is_checked() {
    let error = dense_grid(GridClass::LevelSet, ([4, 4, 4], &[0.0; 63]), 0.1, [0.0; 3])
        .unwrap_err()
        .to_string();
    assert!(error.contains("needs 64 values, got 63"), "{error}");
    let error = dense_grid(GridClass::LevelSet, ([4, 4, 4], &[0.0; 64]), -0.1, [0.0; 3])
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("`spacing` must be a positive number"),
        "{error}"
    );
    // A NaN is refused by the frame, as in a file.
    let mut values = vec![1.0; 64];
    values[9] = f32::NAN;
    let grid = dense_grid(GridClass::LevelSet, ([4, 4, 4], &values), 0.1, [0.0; 3]).unwrap();
    let error = LevelSetStream::start(spec())
        .unwrap()
        .advance(frame(grid))
        .unwrap_err()
        .to_string();
    assert!(error.contains("holds NaN or infinite values"), "{error}");
}

#[test]
fn a_dense_fog_volume_is_read_at_its_iso() {
    let (n, dx) = (33, 0.05f32);
    let origin = Vec3::splat(-0.8);
    // Density 1 inside a ball of 0.5, fading linearly over 0.2: iso 0.5 is radius 0.6.
    let values = dense(n, dx, origin, |p| {
        (1.0 - (p.length() - 0.5) / 0.2).clamp(0.0, 1.0)
    });
    let grid = dense_grid(GridClass::FogVolume, ([n; 3], &values), dx, at(origin)).unwrap();
    // A fog volume without its iso is refused, the setting named as the library names it.
    let mut refused = LevelSetStream::start(spec()).unwrap();
    let error = refused
        .advance(frame(grid.clone()))
        .unwrap_err()
        .to_string();
    assert!(error.contains("is not a level set: give `iso`"), "{error}");
    let mut stream = LevelSetStream::start(LevelSetSpec {
        iso: Some(0.5),
        ..spec()
    })
    .unwrap();
    let mut last = None;
    for _ in 1..=12 {
        last = Some(stream.advance(frame(grid.clone())).unwrap());
    }
    let off = off_sphere(&last.unwrap().mesh, Vec3::ZERO, 0.6, dx);
    println!("dense fog: {off:.3} voxel off");
    assert!(off < 0.15, "{off} voxel from the iso-surface");
}

#[test]
fn a_dense_morph_from_a_sphere_to_a_torus_ends_a_torus() {
    let (n, dx) = (48, 0.04f32);
    let origin = Vec3::splat(-0.96);
    let sphere = dense(n, dx, origin, |p| p.length() - 0.5);
    let torus = dense(n, dx, origin, |p| {
        Vec3::new(p.truncate().length() - 0.55, p.z, 0.0).length() - 0.2
    });
    let grid =
        |values: &[f32]| dense_grid(GridClass::LevelSet, ([n; 3], values), dx, at(origin)).unwrap();
    let mut stream = LevelSetStream::start(LevelSetSpec {
        physics: Physics {
            alpha: 16.0,
            ..Physics::default()
        },
        seed: false,
        init: Some(frame(grid(&sphere))),
        ..spec()
    })
    .unwrap();
    let first = stream.advance(frame(grid(&torus))).unwrap();
    // Frame 1 is the shape the morph starts on.
    assert_eq!(first.stats.euler_characteristic, 2);
    let mut last = first;
    for _ in 2..=48 {
        last = stream.advance(frame(grid(&torus))).unwrap();
    }
    assert_eq!(last.frame, 48);
    assert_eq!(last.stats.euler_characteristic, 0, "a torus at the end");
}

#[cfg(feature = "vdb")]
mod against_the_commands {
    use std::path::Path;

    use super::*;
    use activeskin::frames::{read_level_set_frame, VelocitySource};
    use activeskin::io::mesh::write;
    use activeskin::target::{sample, Sphere, Target};
    use activeskin::vdb::{self, Grid, VectorWrite, WriteOptions};
    use common::{activeskin, assert_ok, scratch};
    use glam::IVec3;

    const DX: f32 = 1.0 / 32.0;

    /// Writes `liquid.####.vdb`, frames 1–8: a sphere turning about z half a turn a
    /// second, 0.4 off the axis, with its velocity `vel` over its voxels.
    fn write_spinning(dir: &Path) -> String {
        let omega = std::f32::consts::PI;
        for frame in 1..=8i64 {
            let angle = omega * (frame - 1) as f32 / 24.0;
            let s = Sphere {
                center: 0.4 * Vec3::new(angle.cos(), angle.sin(), 0.0),
                radius: 0.25,
            };
            let grid = Grid::from_data(&sample::level_set(&s, DX, 3.0)).unwrap();
            let b = s.bounds();
            let (lo, hi) = (
                (b.min / DX).floor().as_ivec3(),
                (b.max / DX).ceil().as_ivec3(),
            );
            let (mut coords, mut values) = (Vec::new(), Vec::new());
            for x in lo.x..=hi.x {
                for y in lo.y..=hi.y {
                    for z in lo.z..=hi.z {
                        let p = IVec3::new(x, y, z).as_vec3() * DX;
                        if s.distance(p) <= 0.0 {
                            coords.push([x, y, z]);
                            values.push([-omega * p.y, omega * p.x, 0.0]);
                        }
                    }
                }
            }
            let vel = VectorWrite {
                name: "vel",
                staggered: false,
                voxel_size: f64::from(DX),
                coords: &coords,
                values: &values,
                half_float: false,
            };
            let path = dir.join(format!("liquid.{frame:04}.vdb"));
            let meta = vdb::frame_metadata(frame);
            vdb::write_grids_and_vectors(&path, &[(&grid, WriteOptions::default())], &[vel], &meta)
                .unwrap();
        }
        dir.join("liquid.####.vdb").to_string_lossy().into_owned()
    }

    fn same_bytes(a: &Path, b: &Path) -> bool {
        std::fs::read(a).unwrap() == std::fs::read(b).unwrap()
    }

    #[test]
    fn handed_vdb_frames_make_the_skin_commands_meshes_and_vdbs() {
        let data = scratch();
        let target = write_spinning(data.path());
        let cli = scratch();
        let (meshes, out) = (cli.path().join("m.####.obj"), cli.path().join("s.####.vdb"));
        assert_ok(&activeskin(&[
            "skin",
            "--target",
            &target,
            "--velocity-scale",
            "1",
            "--velocity-time",
            "start",
            "--mesh",
            meshes.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]));
        let ours = scratch();
        // The surface's velocity at the skin's voxels too, as --out writes it (grid v).
        let mut stream = LevelSetStream::start(LevelSetSpec {
            velocities: true,
            velocity_grid: true,
            ..spec()
        })
        .unwrap();
        for f in 1..=8i64 {
            let path = data.path().join(format!("liquid.{f:04}.vdb"));
            let handed = read_level_set_frame(&path, None, VelocitySource::Auto).unwrap();
            assert!(handed.velocity.is_some(), "the file's vel grid");
            let surface = stream.advance(handed).unwrap();
            let (mesh, skin) = (
                ours.path().join(format!("m.{f:04}.obj")),
                ours.path().join(format!("s.{f:04}.vdb")),
            );
            write(&surface.mesh, &mesh).unwrap();
            let v = surface.voxel_velocities.as_ref();
            assert!(v.is_some(), "frame {f}: no velocity at the voxels");
            activeskin::frames::write_skin_vdb(&skin, f, &surface.level_set, v).unwrap();
            let theirs = |name: &str| {
                cli.path().join(format!(
                    "{name}.{f:04}.{}",
                    match name {
                        "m" => "obj",
                        _ => "vdb",
                    }
                ))
            };
            assert!(same_bytes(&mesh, &theirs("m")), "frame {f}'s mesh differs");
            // A VDB file holds a random UUID after its 21-byte header: the rest is the same.
            let without_uuid = |p: &Path| {
                let mut bytes = std::fs::read(p).unwrap();
                bytes.drain(21..57);
                bytes
            };
            assert!(
                without_uuid(&skin) == without_uuid(&theirs("s")),
                "frame {f}'s VDB differs"
            );
        }
    }

    #[test]
    fn a_handed_morph_between_vdb_files_is_the_morph_commands() {
        let data = scratch();
        let (from, to) = (data.path().join("from.vdb"), data.path().join("to.vdb"));
        for (path, center) in [(&from, Vec3::ZERO), (&to, Vec3::new(0.3, 0.1, 0.0))] {
            let s = Sphere {
                center,
                radius: 0.3,
            };
            common::write_grid(path, &sample::level_set(&s, DX, 3.0));
        }
        let cli = scratch();
        let meshes = cli.path().join("m.####.obj");
        assert_ok(&activeskin(&[
            "morph",
            "--from",
            from.to_str().unwrap(),
            "--to",
            to.to_str().unwrap(),
            "--frames",
            "1-10",
            "--mesh",
            meshes.to_str().unwrap(),
            "-q",
        ]));
        let read = |p: &Path| read_level_set_frame(p, None, VelocitySource::Off).unwrap();
        let mut stream = LevelSetStream::start(LevelSetSpec {
            seed: false,
            init: Some(read(&from)),
            ..spec()
        })
        .unwrap();
        let ours = scratch();
        for f in 1..=10i64 {
            let surface = stream.advance(read(&to)).unwrap();
            let mesh = ours.path().join(format!("m.{f:04}.obj"));
            write(&surface.mesh, &mesh).unwrap();
            let theirs = cli.path().join(format!("m.{f:04}.obj"));
            assert!(same_bytes(&mesh, &theirs), "frame {f} differs");
        }
    }
}
