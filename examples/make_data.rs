//! Writes the sample target sequences of `data/` (analytic shapes sampled into VDB level
//! sets): `cargo run --release --example make_data [-- OUT_DIR]`.
//!
//! Voxel size 1/16, half-float values, 8 frames each, around (1.5, 1.5, 1.5):
//! - `moving/sphere.####.vdb`: a sphere of radius 0.3 gliding 0.2 along x.
//! - `splitting/pair.####.vdb`: two overlapping spheres of radius 0.25 that move apart
//!   and separate (a merge, read backwards).
//!
//! and a particle sequence:
//! - `splash/drop.####.ply`: a drop of about 500 particles (spacing 0.04) falling on a
//!   floor and splashing, 36 frames at 24 fps (`activeskin::particles::splash`).

use std::path::PathBuf;

use activeskin::io::ply;
use activeskin::particles::splash::Splash;
use activeskin::target::{sample, Sphere, Target, Union};
use activeskin::vdb::{self, FileMetadata, Grid, WriteOptions};
use glam::Vec3;

const DX: f32 = 1.0 / 16.0;
const SPLASH_FRAMES: i64 = 36;

/// Every shape sits around this point, inside one of OpenVDB's top-level nodes (4096
/// voxels from the origin): a shape straddling the origin touches eight, whose masks,
/// written uncompressed, would make each file five times larger.
const CENTRE: Vec3 = Vec3::splat(1.5);

fn write(target: &dyn Target, path: PathBuf, frame: i64) -> Result<(), activeskin::Error> {
    let grid = Grid::from_data(&sample::level_set(target, DX, 3.0))?;
    let options = WriteOptions { half_float: true };
    let meta = FileMetadata {
        creator: "activeskin examples/make_data.rs".into(),
        has_frame: true,
        frame,
    };
    vdb::write_grids(&path, &[(&grid, options)], &meta)?;
    Ok(())
}

fn main() -> Result<(), activeskin::Error> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "data".into()));
    std::fs::create_dir_all(out.join("moving")).expect("create data/moving");
    std::fs::create_dir_all(out.join("splitting")).expect("create data/splitting");
    for frame in 1..=8 {
        let t = (frame - 1) as f32 / 7.0;
        let sphere = Sphere {
            center: CENTRE + Vec3::new(-0.1 + 0.2 * t, 0.0, 0.0),
            radius: 0.3,
        };
        write(
            &sphere,
            out.join(format!("moving/sphere.{frame:04}.vdb")),
            frame,
        )?;
        let gap = 0.3 + 0.5 * t;
        let pair = Union(vec![
            Box::new(Sphere {
                center: CENTRE + Vec3::new(-gap / 2.0, 0.0, 0.0),
                radius: 0.25,
            }) as Box<dyn Target>,
            Box::new(Sphere {
                center: CENTRE + Vec3::new(gap / 2.0, 0.0, 0.0),
                radius: 0.25,
            }),
        ]);
        write(
            &pair,
            out.join(format!("splitting/pair.{frame:04}.vdb")),
            frame,
        )?;
    }
    std::fs::create_dir_all(out.join("splash")).expect("create data/splash");
    let mut splash = Splash::new();
    for frame in 1..=SPLASH_FRAMES {
        ply::write_ply(
            &out.join(format!("splash/drop.{frame:04}.ply")),
            splash.positions(),
        )?;
        splash.advance(1.0 / 24.0);
    }
    Ok(())
}
