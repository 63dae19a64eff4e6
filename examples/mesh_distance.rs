//! Mean distances between two OBJ sequences, in voxels: how far a skin sits from another
//! surfacing of the same frames (error), and how much each moves from frame to frame
//! (flicker). `cargo run --release --example mesh_distance -- A.####.obj B.####.obj
//! FIRST LAST DX`.

use activeskin::mesh::mean_distance;
use activeskin::sequence::FramePattern;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 6 {
        eprintln!("usage: mesh_distance A.####.obj B.####.obj FIRST LAST DX");
        std::process::exit(2);
    }
    let a = FramePattern::parse(&args[1]).expect("a frame pattern");
    let b = FramePattern::parse(&args[2]).expect("a frame pattern");
    let (first, last): (i64, i64) = (args[3].parse().unwrap(), args[4].parse().unwrap());
    let dx: f32 = args[5].parse().unwrap();
    let read = |p: &FramePattern, f: i64| activeskin::io::obj::read(&p.path(f)).expect("an OBJ");
    // Nearest triangles searched within 16 voxels: a droplet one side lacks counts.
    let cell = 8.0 * dx;
    let (mut error, mut flicker_a, mut flicker_b) = (0.0, 0.0, 0.0);
    let (mut previous_a, mut previous_b) = (read(&a, first), read(&b, first));
    for f in first..=last {
        let (ma, mb) = (read(&a, f), read(&b, f));
        let (ab, ba) = (
            mean_distance(&ma, &mb, cell) / f64::from(dx),
            mean_distance(&mb, &ma, cell) / f64::from(dx),
        );
        let e = 0.5 * (ab + ba);
        error += e;
        if f > first {
            flicker_a += mean_distance(&ma, &previous_a, cell) / f64::from(dx);
            flicker_b += mean_distance(&mb, &previous_b, cell) / f64::from(dx);
        }
        println!("frame {f}: {e:.3} voxel apart (A to B {ab:.3}, B to A {ba:.3})");
        (previous_a, previous_b) = (ma, mb);
    }
    let n = (last - first + 1) as f64;
    println!(
        "mean {:.3} voxel apart; flicker A {:.3}, B {:.3} voxel/frame",
        error / n,
        flicker_a / (n - 1.0),
        flicker_b / (n - 1.0)
    );
}
