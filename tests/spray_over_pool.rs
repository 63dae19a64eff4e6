//! Spray over a pool at rest (the end of every splash, a drip into a tank): the liquid at
//! large holds still, so its particles' motion is not carried — but a drop flying eight
//! voxels a frame must be. Before, the whole frame's motion was judged at once: the drop
//! was left behind as a ghost, seeded again where it had gone, and flickered between
//! the two.

mod common;

use activeskin::particles::Particles;
use glam::Vec3;

const R: f32 = 0.005;
const FPS: f32 = 24.0;
const SPEED: f32 = 1.0;
const FRAMES: i64 = 8;

/// A pool of 20 × 20 × 6 particles 2r apart, at rest, and a drop of 2³ particles above it
/// flying along x at `SPEED`, with ids and velocities, frame `frame`.
fn frame(frame: i64) -> Particles {
    let lattice = |n: [i32; 3], at: Vec3| {
        let mut out = Vec::new();
        for i in 0..n[0] {
            for j in 0..n[1] {
                for k in 0..n[2] {
                    out.push(at + Vec3::new(i as f32, j as f32, k as f32) * 2.0 * R);
                }
            }
        }
        out
    };
    let pool = lattice([20, 20, 6], Vec3::ZERO);
    let travelled = SPEED * (frame - 1) as f32 / FPS;
    let drop = lattice([2, 2, 2], Vec3::new(0.1 + travelled, 0.1, 0.1));
    let velocities = (pool.iter().map(|_| Vec3::ZERO))
        .chain(drop.iter().map(|_| Vec3::X * SPEED))
        .collect();
    let positions: Vec<Vec3> = pool.into_iter().chain(drop).collect();
    Particles {
        ids: Some((0..positions.len() as i64).collect()),
        velocities: Some(velocities),
        positions,
        ..Particles::default()
    }
}

#[test]
fn a_drop_flying_over_a_pool_at_rest_is_carried() {
    let dir = common::scratch();
    let meshes = common::particle_shot(
        dir.path(),
        FRAMES,
        frame,
        R,
        // The carry alone: the smoothing's volume hold is another matter.
        &["--smooth", "0"],
    );
    let mut first = None;
    for (k, mesh) in meshes.iter().enumerate() {
        let f = k as i64 + 1;
        let check = mesh.check();
        assert!(check.is_clean(), "frame {f}: {check}");
        // The pool and the drop, and no ghost of the drop where it was.
        let found = common::mesh_pieces(mesh);
        assert_eq!(found.len(), 2, "frame {f}: pieces {found:?}");
        let (volume, centre) = found[0];
        let particles = frame(f).positions;
        let drop: Vec3 = particles[particles.len() - 8..].iter().sum::<Vec3>() / 8.0;
        assert!(
            centre.distance(drop) < R,
            "frame {f}: the drop's surface is centred {} voxels off its particles",
            centre.distance(drop) / R
        );
        // Its volume carried from frame to frame, not lost and seeded again.
        let first = *first.get_or_insert(volume);
        assert!(
            (volume / first - 1.0).abs() < 0.15,
            "frame {f}: the drop holds {volume:e}, {first:e} on frame 1"
        );
    }
}
