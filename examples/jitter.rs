//! Temporal jitter of a surface sequence, in voxels: at each vertex of frame n's mesh, the
//! mean of the signed distances of frames n−1 and n+1 (their level sets). A surface moving
//! smoothly has one behind and one ahead by the same amount, so this is its acceleration;
//! flicker makes it large. Unlike the distance between consecutive frames it does not count
//! the motion itself.
//! `cargo run --release --example jitter -- MESH.####.obj LEVELSET.####.vdb GRID FIRST LAST`
//! (GRID: the level set's grid, e.g. `surface` or Mantaflow's `phi`; its distances are
//! rescaled to world units as `skin` does).

use std::path::Path;

use activeskin::frames::{read_target_in, TargetUnits};
use activeskin::sequence::FramePattern;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 6 {
        eprintln!("usage: jitter MESH.####.obj LEVELSET.####.vdb GRID FIRST LAST");
        std::process::exit(2);
    }
    let meshes = FramePattern::parse(&args[1]).expect("a frame pattern");
    let sets = FramePattern::parse(&args[2]).expect("a frame pattern");
    let grid = args[3].as_str();
    let (first, last): (i64, i64) = (args[4].parse().unwrap(), args[5].parse().unwrap());
    let read = |f: i64| {
        read_target_in(
            Path::new(&sets.path(f)),
            Some(grid),
            None,
            TargetUnits::Auto,
        )
        .expect("a level set")
    };
    let (mut sum, mut n) = (0.0, 0);
    for f in first + 1..last {
        let mesh = activeskin::io::obj::read(&meshes.path(f)).expect("an OBJ");
        let (before, after) = (read(f - 1), read(f + 1));
        let dx = before.dx;
        let j: f64 = mesh
            .positions
            .iter()
            .map(|&p| {
                let m = 0.5 * (before.target.distance(p) + after.target.distance(p));
                f64::from(m.abs() / dx)
            })
            .sum::<f64>()
            / mesh.positions.len().max(1) as f64;
        println!("frame {f}: jitter {j:.3} voxel");
        sum += j;
        n += 1;
    }
    println!("mean jitter {:.3} voxel", sum / f64::from(n.max(1)));
}
